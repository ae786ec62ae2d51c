//! `raylab denoise`: a finished image (an EXR with `--aov albedo,normal`, or a PFM) denoised by
//! Intel Open Image Denoise ([`crate::image::denoise`]), e.g. a frame merged from a farm's tiles;
//! with `--subpixels K`, an image rendered on `K × K` sub-pixels per pixel denoised there and
//! averaged back over each pixel, as `render --denoise` does ([`crate::image::denoise::grid`]).

use super::{App, Failure};
use crate::image::denoise::{Layers, denoise};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub(crate) struct DenoiseArgs {
    /// The noisy image: .exr (`--features exr`; its `albedo` and `normal` layers guide the
    /// denoiser when present, and its `emission` layer is left out of the filter: render with
    /// `--aov albedo,normal,emission`) or .pfm (colour alone). A colour or emission channel
    /// that is NaN, infinite or negative is taken as 0, with a warning on stderr that counts
    /// the pixels and names the first (x, y from the top left).
    input: PathBuf,
    /// The denoised image: .exr, .pfm, .png, .jpg or .jpeg.
    #[arg(short, long)]
    output: PathBuf,
    /// The guides have noise: the frame was rendered with depth of field (a camera aperture),
    /// so the denoiser filters them too instead of following their edges (as `render --denoise`
    /// does by itself for such a camera).
    #[arg(long)]
    noisy_guides: bool,
    /// The input holds K × K sub-pixels per pixel of the frame (rendered at K times its width and
    /// height with spp / K² samples: `render --denoise`'s finer grid, e.g. by a farm): denoised
    /// there, then averaged over each K × K block, the frame's pixels. Less error than denoising
    /// the frame's pixels (docs/error-targets.md, "On a finer grid").
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = super::int_in::<u32>(1, i128::from(MAX_SUBPIXELS)))]
    subpixels: u32,
}

/// The most sub-pixels per pixel side `--subpixels` takes.
const MAX_SUBPIXELS: u32 = 16;

pub(crate) fn run(app: &App, a: DenoiseArgs) -> Result<(), Failure> {
    super::refuse_overwrite("denoise", &[a.output.as_path()], [a.input.as_path()])?;
    let format = app.registry.output_format_for(&a.output).map_err(|e| e.to_string())?;
    let ext = a.input.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let bytes = crate::load::context::read_user_file(&a.input, "image", crate::image::tonemap::MAX_FILE_BYTES, None)?;
    // The filter looks at each pixel's neighbourhood: a tile denoised alone leaves seams.
    #[cfg(feature = "exr")]
    if ext == "exr" && crate::image::partial::is_partial(&bytes) {
        return Err(Failure::Other(format!(
            "{}: a partial image (a tile, crop, pass or checkpoint of a frame): denoise the whole frame, merged first (`raylab merge`)",
            a.input.display()
        )));
    }
    let mut l = read(&a, &ext, &bytes)?;
    for (layer, bad) in l.clear_unfilterable() {
        eprintln!(
            "warning: {} pixel{} of {}'s {layer} {} a channel that is NaN, infinite or negative (the first at x {}, y {}): taken as 0",
            bad.pixels,
            if bad.pixels == 1 { "" } else { "s" },
            a.input.display(),
            if bad.pixels == 1 { "has" } else { "have" },
            bad.first.0,
            bad.first.1
        );
    }
    let guides = match (&l.albedo, &l.normal) {
        (Some(_), Some(_)) => "albedo and normal guides",
        (Some(_), None) => "an albedo guide",
        _ => "no guides (render with --aov albedo,normal,emission for better results)",
    };
    let emission = if l.emitted.is_some() { ", its emission left out of the filter" } else { "" };
    let k = a.subpixels;
    let (w, h) = (l.color.width, l.color.height);
    if !(w.is_multiple_of(k) && h.is_multiple_of(k)) {
        return Err(Failure::Other(format!(
            "{}: {w}×{h} pixels cannot be {k} × {k} sub-pixels of a frame's pixels (--subpixels {k} needs a width and height that are multiples of {k})",
            a.input.display()
        )));
    }
    let film = denoise(&l.color, l.albedo.as_ref(), l.normal.as_ref(), l.emitted.as_ref(), !a.noisy_guides).map_err(Failure::Other)?;
    let film = if k > 1 { crate::image::denoise::box_down(&film, k).map_err(Failure::Other)? } else { film };
    let grid = if k > 1 {
        format!(", on {k} × {k} sub-pixels averaged back over each pixel")
    } else {
        // Why not finer: this file holds the frame's pixels alone.
        ", on the frame's pixels (a frame rendered at K× its width and height with spp/K² samples, denoised with --subpixels K, has less error)".into()
    };
    let settings =
        crate::image::output::WriteSettings { encoding: crate::math::color::Encoding::Srgb, grid: None, layers: None, half: false };
    format.write(&a.output, &film, &settings).map_err(|e| e.to_string())?;
    println!(
        "wrote {} ({}×{}, denoised with {guides}{emission}{grid}) from {}",
        a.output.display(),
        film.width,
        film.height,
        a.input.display()
    );
    Ok(())
}

fn read(a: &DenoiseArgs, ext: &str, bytes: &[u8]) -> Result<Layers, Failure> {
    match ext {
        "pfm" => {
            let color = crate::image::reference::decode_pfm(bytes).map_err(|e| Failure::Other(format!("{}: {e}", a.input.display())))?;
            Ok(Layers { color, albedo: None, normal: None, emitted: None })
        }
        #[cfg(feature = "exr")]
        "exr" => crate::image::denoise::read_exr_layers(&a.input, bytes).map_err(Failure::Other),
        #[cfg(not(feature = "exr"))]
        "exr" => Err(Failure::Other(format!("reading OpenEXR needs the `exr` feature; {}", crate::param::error::built_without("exr")))),
        _ => Err(Failure::Other(format!("{}: expected an .exr or .pfm image", a.input.display()))),
    }
}
