//! `raylab tonemap`: an HDR image (OpenEXR or PFM), or one of its layers, as a viewable PNG/JPEG.

use super::{App, Failure};
use crate::image::tonemap::{Layer, MAX_FILE_BYTES, check_input, read_layer, visualise};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub(crate) struct TonemapArgs {
    /// The HDR image: .exr (with `--features exr`) or .pfm.
    input: PathBuf,
    /// The viewable image: .png, .jpg or .jpeg.
    #[arg(short, long)]
    output: PathBuf,
    /// Exposure in stops: colour is multiplied by 2^EV before it is clamped and sRGB-encoded.
    #[arg(long, value_name = "EV", default_value_t = 0.0, allow_hyphen_values = true)]
    exposure: f64,
    /// Show a layer of raylab's EXR instead of the colour (`render --aov`): depth (white nearest
    /// to black farthest; black where nothing was hit), normal ((n + 1) / 2 as RGB), albedo,
    /// emission, spp (samples per pixel: grey by log₂, white at the most).
    #[arg(long, value_parser = ["depth", "normal", "albedo", "emission", "spp"])]
    layer: Option<String>,
}

pub(crate) fn run(app: &App, a: TonemapArgs) -> Result<(), Failure> {
    if !(a.exposure.is_finite() && a.exposure.abs() <= 64.0) {
        return Err(Failure::Other(format!("--exposure: expected stops in -64..=64, found {}", a.exposure)));
    }
    let format = app.registry.output_format_for(&a.output).map_err(|e| e.to_string())?;
    if format.hdr {
        return Err(Failure::Other(format!("{}: tonemap writes a viewable 8-bit image (.png, .jpg or .jpeg)", a.output.display())));
    }
    super::refuse_overwrite("tonemap", &[a.output.as_path()], [a.input.as_path()])?;
    let layer = a.layer.as_deref().and_then(Layer::parse).unwrap_or(Layer::Color);
    let ext = a.input.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    check_input(&ext, layer).map_err(|e| Failure::Other(format!("{}: {e}", a.input.display())))?;
    let bytes = crate::load::context::read_user_file(&a.input, "image", MAX_FILE_BYTES, None)?;
    let film = read_layer(&bytes, &ext, layer).map_err(|e| Failure::Other(format!("{}: {e}", a.input.display())))?;
    let (w, h) = (film.width, film.height);
    let (film, encoding) = visualise(film, layer, a.exposure);
    let settings = crate::image::output::WriteSettings { encoding, ..Default::default() };
    format.write(&a.output, &film, &settings).map_err(|e| e.to_string())?;
    println!("wrote {} ({w}×{h}, {}) from {}", a.output.display(), a.layer.as_deref().unwrap_or("colour"), a.input.display());
    Ok(())
}
