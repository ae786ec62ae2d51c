//! `raylab denoise`: a finished image (an EXR with `--aov albedo,normal`, or a PFM) denoised by
//! Intel Open Image Denoise ([`crate::image::denoise`]), e.g. a frame merged from a farm's tiles.

use super::{App, Failure};
use crate::image::denoise::{Layers, denoise};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub(crate) struct DenoiseArgs {
    /// The noisy image: .exr (`--features exr`; its `albedo` and `normal` layers guide the
    /// denoiser when present, and its `emission` layer is left out of the filter: render with
    /// `--aov albedo,normal,emission`) or .pfm (colour alone).
    input: PathBuf,
    /// The denoised image: .exr, .pfm, .png, .jpg or .jpeg.
    #[arg(short, long)]
    output: PathBuf,
    /// The guides have noise: the frame was rendered with depth of field (a camera aperture),
    /// so the denoiser filters them too instead of following their edges (as `render --denoise`
    /// does by itself for such a camera).
    #[arg(long)]
    noisy_guides: bool,
}

pub(crate) fn run(app: &App, a: DenoiseArgs) -> Result<(), Failure> {
    super::refuse_overwrite("denoise", &[a.output.as_path()], [a.input.as_path()])?;
    let format = app.registry.output_format_for(&a.output).map_err(|e| e.to_string())?;
    let ext = a.input.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let bytes = crate::load::context::read_user_file(&a.input, "image", crate::image::tonemap::MAX_FILE_BYTES, None)?;
    let l = read(&a, &ext, &bytes)?;
    let guides = match (&l.albedo, &l.normal) {
        (Some(_), Some(_)) => "albedo and normal guides",
        (Some(_), None) => "an albedo guide",
        _ => "no guides (render with --aov albedo,normal,emission for better results)",
    };
    let emission = if l.emitted.is_some() { ", its emission left out of the filter" } else { "" };
    let film = denoise(&l.color, l.albedo.as_ref(), l.normal.as_ref(), l.emitted.as_ref(), !a.noisy_guides).map_err(Failure::Other)?;
    let settings =
        crate::image::output::WriteSettings { encoding: crate::math::color::Encoding::Srgb, grid: None, layers: None, half: false };
    format.write(&a.output, &film, &settings).map_err(|e| e.to_string())?;
    println!("wrote {} ({}×{}, denoised with {guides}{emission}) from {}", a.output.display(), film.width, film.height, a.input.display());
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
