//! Writing images in formats chosen by file extension: [`OutputFormat`] is a registered kind
//! (`Registry::add_output_format`), and the core's own are [`builtin_formats`]: 8-bit PNG and
//! JPEG (clamped and encoded, with an optional grid overlay, the report's `printGrid`), OpenEXR
//! (linear floats with the depth/normal/albedo layers; feature `exr`) and PFM (linear floats,
//! the reference format). Files are written atomically: to a temporary file beside the
//! target, then renamed, so a crash never leaves a truncated image where a good one was.

use crate::image::write::{WriteError, write_atomically};
use crate::math::color::Encoding;
use crate::render::film::Film;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

/// Grid lines drawn over an 8-bit image every `interval` pixels (rows and columns 0, interval, …).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    /// Spacing, pixels (≥ 1).
    pub interval: u32,
    /// Line colour, 8-bit sRGB.
    pub color: [u8; 3],
}

/// An 8-bit encoding of RGB pixels ([`encode_rgb8`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    /// PNG, 8 bits per channel.
    Png,
    /// JPEG, 8 bits per channel, quality 95.
    Jpeg,
}

/// What a render will write, for the estimate of the image's memory ([`image_bytes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImagePlan {
    /// OpenEXR (linear floats) rather than 8-bit PNG or JPEG.
    pub exr: bool,
    /// The EXR's extra layers: depth, normal, albedo ([`crate::render::aov`]).
    pub depth: bool,
    /// See `depth`.
    pub normal: bool,
    /// See `depth`.
    pub albedo: bool,
    /// See `depth`: the radiance camera rays met directly.
    pub emission: bool,
    /// EXR colour, normal and albedo as 16-bit floats.
    pub half: bool,
    /// The EXR's error estimate and sample count layers (computed from the render's sums).
    pub error: bool,
}

impl ImagePlan {
    /// The costliest output: 32-bit EXR with every layer.
    pub const COSTLIEST: ImagePlan =
        ImagePlan { exr: true, depth: true, normal: true, albedo: true, emission: true, half: false, error: true };
    /// 8-bit PNG or JPEG.
    pub const EIGHT_BIT: ImagePlan =
        ImagePlan { exr: false, depth: false, normal: false, albedo: false, emission: false, half: false, error: false };
}

impl Default for ImagePlan {
    fn default() -> Self {
        ImagePlan::COSTLIEST
    }
}

/// Bytes per pixel of the film (linear RGB, `f32`).
const FILM_BYTES_PER_PIXEL: u64 = 12;
/// Bytes per pixel of the render's exact running sums ([`crate::render::accum::PixelSum`]).
const SUM_BYTES_PER_PIXEL: u64 = std::mem::size_of::<crate::render::accum::PixelSum>() as u64;
/// Bytes per pixel of the layers made of the sums: depth (`f32`), normal, albedo and emission.
const LAYER_BYTES_PER_PIXEL: u64 = 4 + 3 * 12;
/// Bytes per pixel of the layers' exact running sums ([`crate::render::accum::AovSum`]).
const LAYER_SUM_BYTES_PER_PIXEL: u64 = std::mem::size_of::<crate::render::accum::AovSum>() as u64;
/// Bytes per pixel of 8-bit output: the RGB copy and the encoder's buffer.
const EIGHT_BIT_BYTES_PER_PIXEL: u64 = 6;

/// The most memory rendering and writing an image of `pixels` pixels as `plan` takes at once,
/// bytes: the film, the render's running sums (and the layers' when asked for, with the layers
/// they become), then the encoder's copies (for EXR, every channel and the encoded file, at most
/// its raw size).
pub fn image_bytes(pixels: u64, plan: &ImagePlan) -> u64 {
    let any_layer = plan.exr && (plan.depth || plan.normal || plan.albedo || plan.emission);
    // The render makes every layer when any is asked for.
    let during_render = SUM_BYTES_PER_PIXEL + if any_layer { LAYER_SUM_BYTES_PER_PIXEL + LAYER_BYTES_PER_PIXEL } else { 0 };
    let during_writing = if plan.exr {
        let colour = if plan.half { 2 } else { 4 };
        let layers = if any_layer { LAYER_BYTES_PER_PIXEL } else { 0 };
        let channels = 3 * colour * (1 + u64::from(plan.normal) + u64::from(plan.albedo) + u64::from(plan.emission))
            + 4 * u64::from(plan.depth)
            + 8 * u64::from(plan.error);
        layers + 2 * channels
    } else {
        EIGHT_BIT_BYTES_PER_PIXEL
    };
    let per_pixel = FILM_BYTES_PER_PIXEL + during_render.max(during_writing);
    pixels.saturating_mul(per_pixel)
}

/// How an image is written besides its pixels (each format uses what it can store).
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteSettings<'a> {
    /// 8-bit encoding (PNG, JPEG).
    pub encoding: Encoding,
    /// Grid lines over an 8-bit image.
    pub grid: Option<Grid>,
    /// The depth, normal and albedo layers (EXR).
    pub layers: Option<&'a crate::render::aov::AovLayers>,
    /// 16-bit half floats for colour, normal and albedo (EXR).
    pub half: bool,
}

/// Writes a film (and what of [`WriteSettings`] the format stores) to a path, atomically
/// ([`crate::image::write::write_atomically`]).
pub type ImageWriter = Arc<dyn Fn(&Path, &Film, &WriteSettings) -> Result<(), WriteError> + Send + Sync>;

/// An image file format raylab writes, chosen by the output's extension.
#[derive(Clone)]
pub struct OutputFormat {
    /// Short name.
    pub name: &'static str,
    /// Lower-case file extensions without the dot.
    pub extensions: &'static [&'static str],
    /// One line: what it stores.
    pub summary: &'static str,
    /// Linear, unclamped values (HDR), rather than clamped and encoded 8-bit ones.
    pub hdr: bool,
    /// Stores the depth, normal and albedo layers.
    pub layers: bool,
    /// The writer.
    pub write: ImageWriter,
}

impl OutputFormat {
    /// Writes `film` to `path` in this format, atomically.
    pub fn write(&self, path: &Path, film: &Film, settings: &WriteSettings) -> Result<(), WriteError> {
        (self.write)(path, film, settings)
    }
}

fn write_8bit(path: &Path, film: &Film, s: &WriteSettings, kind: ImageKind) -> Result<(), WriteError> {
    let rgb = try_rgb8(film, s.encoding, s.grid)?;
    write_atomically(path, |w| encode_rgb8(w, &rgb, film.width, film.height, kind))
}

/// The core's own output formats, which every [`crate::load::registry::Registry`] starts with.
pub fn builtin_formats() -> Vec<OutputFormat> {
    let mut formats = vec![
        OutputFormat {
            name: "png",
            extensions: &["png"],
            summary: "PNG, 8 bits per channel: clamped and encoded (sRGB or linear), with an optional grid",
            hdr: false,
            layers: false,
            write: Arc::new(|p, f, s| write_8bit(p, f, s, ImageKind::Png)),
        },
        OutputFormat {
            name: "jpeg",
            extensions: &["jpg", "jpeg"],
            summary: "JPEG, 8 bits per channel, quality 95: clamped and encoded, with an optional grid",
            hdr: false,
            layers: false,
            write: Arc::new(|p, f, s| write_8bit(p, f, s, ImageKind::Jpeg)),
        },
    ];
    #[cfg(feature = "exr")]
    formats.push(OutputFormat {
        name: "exr",
        extensions: &["exr"],
        summary: "OpenEXR: linear, unclamped 32-bit floats (--half: 16-bit), with the depth, normal and albedo layers asked for (--aov)",
        hdr: true,
        layers: true,
        write: Arc::new(|p, f, s| crate::image::exr::write_exr(p, f, &s.layers.cloned().unwrap_or_default(), s.half)),
    });
    formats.push(OutputFormat {
        name: "pfm",
        extensions: &["pfm"],
        summary: "PFM: linear, unclamped 32-bit floats (references for `--reference` and `sweep`)",
        hdr: true,
        layers: false,
        write: Arc::new(|p, f, _| crate::image::reference::write_pfm(p, f).map_err(WriteError)),
    });
    formats
}

/// The format among `formats` for `path`'s extension (case-insensitive); the last registered
/// wins.
pub fn format_among<'f>(formats: &'f [OutputFormat], path: &Path) -> Result<&'f OutputFormat, WriteError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if let Some(f) = formats.iter().rev().find(|f| f.extensions.contains(&ext.as_str())) {
        return Ok(f);
    }
    if ext == "exr" {
        return Err(WriteError(format!(
            "cannot write \"{}\": EXR output needs the `exr` feature; {}",
            path.display(),
            crate::param::error::built_without("exr")
        )));
    }
    let known: Vec<String> = formats.iter().flat_map(|f| f.extensions.iter().map(|e| format!(".{e}"))).collect();
    Err(WriteError(format!("cannot write \"{}\": unknown image type \".{ext}\"; expected one of {}", path.display(), known.join(", "))))
}

/// The film as 8-bit RGB: clamped, encoded, with the grid drawn over it.
pub fn to_rgb8(film: &Film, encoding: Encoding, grid: Option<Grid>) -> Vec<u8> {
    try_rgb8(film, encoding, grid).unwrap_or_else(|e| panic!("{e}"))
}

/// [`to_rgb8`], or an error if the memory cannot be had.
pub fn try_rgb8(film: &Film, encoding: Encoding, grid: Option<Grid>) -> Result<Vec<u8>, WriteError> {
    let mut out = Vec::new();
    out.try_reserve_exact(film.pixels.len() * 3)
        .map_err(|_| WriteError(format!("out of memory for the 8-bit copy of a {}×{} image", film.width, film.height)))?;
    for p in &film.pixels {
        out.extend([encoding.to_u8(p.x), encoding.to_u8(p.y), encoding.to_u8(p.z)]);
    }
    if let Some(g) = grid.filter(|g| g.interval > 0) {
        for y in 0..film.height {
            for x in 0..film.width {
                if x % g.interval == 0 || y % g.interval == 0 {
                    let i = 3 * (y as usize * film.width as usize + x as usize);
                    out[i..i + 3].copy_from_slice(&g.color);
                }
            }
        }
    }
    Ok(out)
}

/// Writes `film` to `path` in the core's own format its extension names
/// ([`builtin_formats`]), atomically (no layers, full precision).
pub fn write_image(path: &Path, film: &Film, encoding: Encoding, grid: Option<Grid>) -> Result<(), WriteError> {
    format_among(&builtin_formats(), path)?.write(path, film, &WriteSettings { encoding, grid, ..WriteSettings::default() })
}

/// Encodes 8-bit RGB into `w`.
pub fn encode_rgb8(w: &mut dyn Write, rgb: &[u8], width: u32, height: u32, kind: ImageKind) -> Result<(), String> {
    use image::ImageEncoder;
    let r = match kind {
        ImageKind::Png => image::codecs::png::PngEncoder::new(w).write_image(rgb, width, height, image::ExtendedColorType::Rgb8),
        ImageKind::Jpeg => {
            image::codecs::jpeg::JpegEncoder::new_with_quality(w, 95).write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        }
    };
    r.map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {

    /// The estimate counts the film, the render's exact running sums, the layers and the
    /// encoder's copies; the default budget holds 4096² with every layer and refuses the next step
    /// up, and holds 8-bit output of an 8K UHD frame (7680 × 4320) but not of the largest image
    /// the pixel limit allows (8192², 7.2 GB: raise --max-image-bytes, or split it into tiles).
    #[test]
    fn image_memory_estimates_fit_the_default_budget() {
        let budget = crate::param::limits::DEFAULT_MAX_IMAGE_BYTES;
        assert_eq!(image_bytes(1, &ImagePlan::COSTLIEST), 244);
        assert_eq!(image_bytes(1, &ImagePlan::EIGHT_BIT), 108);
        assert!(image_bytes(4096 * 4096, &ImagePlan::COSTLIEST) <= budget);
        assert!(image_bytes(4608 * 4608, &ImagePlan::COSTLIEST) > budget);
        assert!(image_bytes(7680 * 4320, &ImagePlan::EIGHT_BIT) <= budget);
        assert!(image_bytes(crate::param::limits::Limits::default().max_pixels, &ImagePlan::EIGHT_BIT) > budget);
        let half = ImagePlan { half: true, ..ImagePlan::COSTLIEST };
        assert!(image_bytes(1, &half) <= image_bytes(1, &ImagePlan::COSTLIEST));
        assert_eq!(image_bytes(u64::MAX, &ImagePlan::COSTLIEST), u64::MAX);
    }

    /// An allocation that cannot succeed is an error, not an abort.
    #[test]
    fn an_impossible_buffer_is_an_error() {
        let e = crate::render::film::try_filled(usize::MAX / 2, 0u64, "film").unwrap_err();
        assert!(e.0.contains("out of memory for the film"), "{e}");
        assert!(crate::render::film::Film::new(u32::MAX, u32::MAX).is_err() || usize::BITS > 64);
    }
    use super::*;
    use glam::Vec3;

    #[test]
    fn grid_lines_fall_every_interval() {
        let mut film = Film::new(5, 4).unwrap();
        film.set(1, 1, Vec3::ONE);
        let rgb = to_rgb8(&film, Encoding::Linear, Some(Grid { interval: 2, color: [9, 9, 9] }));
        let px = |x: usize, y: usize| rgb[3 * (y * 5 + x)];
        assert_eq!(px(0, 3), 9);
        assert_eq!(px(3, 2), 9);
        assert_eq!(px(1, 1), 255);
        assert_eq!(px(3, 3), 0);
    }

    #[test]
    fn failed_write_keeps_the_old_file() {
        let dir = std::env::temp_dir().join(format!("raylab-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("keep.png");
        std::fs::write(&target, b"good").unwrap();
        let r = write_atomically(&target, |w| {
            w.write_all(b"partial").unwrap();
            Err("simulated crash".into())
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"good");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "temporary file removed");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn formats_are_chosen_by_extension_and_unknown_ones_refused() {
        let builtin = builtin_formats();
        let e = format_among(&builtin, Path::new("a.bmp")).err().unwrap();
        assert!(e.0.contains("unknown image type \".bmp\"") && e.0.contains(".png, .jpg, .jpeg"), "{e}");
        assert_eq!(format_among(&builtin, Path::new("a.JPG")).unwrap().name, "jpeg");
        assert_eq!(format_among(&builtin, Path::new("ref.pfm")).unwrap().name, "pfm");
        // Every extension names one built-in format.
        let mut all: Vec<&str> = builtin.iter().flat_map(|f| f.extensions.iter().copied()).collect();
        all.sort_unstable();
        let n = all.len();
        all.dedup();
        assert_eq!(all.len(), n);
        // A format registered later takes an extension over.
        let mut formats = builtin.clone();
        formats.push(OutputFormat {
            name: "mine",
            extensions: &["png"],
            summary: "",
            hdr: false,
            layers: false,
            write: Arc::new(|_, _, _| Ok(())),
        });
        assert_eq!(format_among(&formats, Path::new("a.png")).unwrap().name, "mine");
    }
}
