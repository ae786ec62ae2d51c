//! `raylab merge PARTS... -o OUT`: partial images of one frame (tiles, crops, sample passes)
//! checked against each other and combined: the same bits as one whole render.

use super::{App, Failure};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub(crate) struct MergeArgs {
    /// The partial images (OpenEXR files written by `raylab render --tile/--crop/--pass`).
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The merged image: .png, .jpg, .exr (linear floats, with the parts' depth, normal and
    /// albedo layers if they have them) or .pfm.
    #[arg(short, long)]
    output: PathBuf,
    /// Merge even when pixels lack samples (missing or unfinished parts): they show what they
    /// have, black where nothing.
    #[arg(long)]
    allow_partial: bool,
    /// 8-bit encoding of PNG/JPEG output: `srgb` or `linear` (default: the scene's, as the parts
    /// record it).
    #[arg(long, value_parser = ["srgb", "linear"])]
    encoding: Option<String>,
    /// Largest frame in pixels a part may claim (checked before its pixels are read).
    #[arg(long, value_name = "N", default_value_t = 1 << 26, value_parser = super::int_in::<u64>(1, u64::MAX.into()))]
    max_pixels: u64,
    /// Largest part file, bytes.
    #[arg(long, value_name = "N", default_value_t = 1 << 32, value_parser = super::int_in::<u64>(1, u64::MAX.into()))]
    max_file_bytes: u64,
}

pub(crate) fn run(app: &App, a: MergeArgs) -> Result<(), Failure> {
    #[cfg(not(feature = "exr"))]
    {
        let _ = (app, a);
        Err(Failure::Other(format!("partial images are OpenEXR files; {}", crate::param::error::built_without("exr"))))
    }
    #[cfg(feature = "exr")]
    {
        use crate::render::share::{Part, merge};
        super::refuse_overwrite("merge", &[a.output.as_path()], a.parts.iter().map(|p| p.as_path()))?;
        let t0 = std::time::Instant::now();
        let mut parts = Vec::with_capacity(a.parts.len());
        let mut encoding = a.encoding.clone();
        for path in &a.parts {
            let name = path.display().to_string();
            let bytes = crate::load::context::read_user_file(path, "partial image", a.max_file_bytes, None)?;
            let (sums, info) =
                crate::image::partial::read_partial(&bytes, &name, a.max_pixels).map_err(|e| Failure::Other(e.to_string()))?;
            encoding.get_or_insert(info.encoding);
            parts.push(Part { name, sums, fingerprint: info.fingerprint });
        }
        let read = t0.elapsed();
        let whole = merge(&parts, a.allow_partial).map_err(Failure::Other)?;
        if a.allow_partial {
            let (done, total, left) = whole.progress();
            if left > 0 {
                eprintln!(
                    "warning: --allow-partial: {left} of {} pixels lack samples ({done} of {total} samples present, {:.1} %); the image is incomplete there (black where a pixel has none)",
                    whole.pixels.len(),
                    100.0 * done as f64 / total.max(1) as f64
                );
            }
        }
        let film = whole.film().map_err(|e| e.to_string())?;
        let layers = whole.aovs().map_err(|e| e.to_string())?;
        let encoding = encoding.as_deref().and_then(crate::math::color::Encoding::parse).unwrap_or_default();
        let settings = crate::image::output::WriteSettings { encoding, layers: layers.as_ref(), ..Default::default() };
        app.registry.output_format_for(&a.output).and_then(|f| f.write(&a.output, &film, &settings)).map_err(|e| e.to_string())?;
        println!(
            "wrote {} ({}×{}) from {} part{}: read {:.3} s, merged and written {:.3} s",
            a.output.display(),
            whole.width,
            whole.height,
            parts.len(),
            if parts.len() == 1 { "" } else { "s" },
            read.as_secs_f64(),
            (t0.elapsed() - read).as_secs_f64()
        );
        Ok(())
    }
}
