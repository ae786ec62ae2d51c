//! Writing images: 8-bit PNG and JPEG (clamped and encoded), chosen by file extension, with an
//! optional grid overlay (the report's `printGrid`). Files are written atomically: to a temporary
//! file beside the target, then renamed, so a crash never leaves a truncated image where a good
//! one was.

use crate::color::Encoding;
use crate::film::Film;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Grid lines drawn over an 8-bit image every `interval` pixels (rows and columns 0, interval, …).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    /// Spacing, pixels (≥ 1).
    pub interval: u32,
    /// Line colour, 8-bit sRGB.
    pub color: [u8; 3],
}

/// An image file type raylab can write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    /// PNG, 8 bits per channel.
    Png,
    /// JPEG, 8 bits per channel, quality 95.
    Jpeg,
    /// OpenEXR: linear, unclamped floating point (feature `exr`; see [`crate::exr`]).
    Exr,
}

/// Error writing an image.
#[derive(Debug)]
pub struct WriteError(pub String);

impl std::fmt::Display for WriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for WriteError {}

/// The kind for a path's extension (`png`, `jpg`, `jpeg`, `exr`; case-insensitive).
pub fn kind_for(path: &Path) -> Result<ImageKind, WriteError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    match ext.as_str() {
        "png" => Ok(ImageKind::Png),
        "jpg" | "jpeg" => Ok(ImageKind::Jpeg),
        "exr" if cfg!(feature = "exr") => Ok(ImageKind::Exr),
        "exr" => Err(WriteError(format!(
            "cannot write \"{}\": EXR output needs raylab built with the `exr` feature (cargo run --features exr)",
            path.display()
        ))),
        _ => Err(WriteError(format!(
            "cannot write \"{}\": unknown image type \".{ext}\"; expected .png, .jpg, .jpeg{}",
            path.display(),
            if cfg!(feature = "exr") { " or .exr" } else { "" }
        ))),
    }
}

/// The film as 8-bit RGB: clamped, encoded, with the grid drawn over it.
pub fn to_rgb8(film: &Film, encoding: Encoding, grid: Option<Grid>) -> Vec<u8> {
    let mut out = Vec::with_capacity(film.pixels.len() * 3);
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
    out
}

/// Writes `film` to `path` as PNG or JPEG (by extension), atomically.
pub fn write_image(path: &Path, film: &Film, encoding: Encoding, grid: Option<Grid>) -> Result<(), WriteError> {
    let kind = kind_for(path)?;
    let rgb = to_rgb8(film, encoding, grid);
    write_atomically(path, |w| encode_rgb8(w, &rgb, film.width, film.height, kind))
}

/// Encodes 8-bit RGB into `w`.
pub fn encode_rgb8(w: &mut dyn Write, rgb: &[u8], width: u32, height: u32, kind: ImageKind) -> Result<(), String> {
    use image::ImageEncoder;
    let r = match kind {
        ImageKind::Png => image::codecs::png::PngEncoder::new(w).write_image(rgb, width, height, image::ExtendedColorType::Rgb8),
        ImageKind::Jpeg => {
            image::codecs::jpeg::JpegEncoder::new_with_quality(w, 95).write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        }
        ImageKind::Exr => return Err("EXR is not an 8-bit format; write it with crate::exr".into()),
    };
    r.map_err(|e| e.to_string())
}

/// Runs `write` into a temporary file beside `path`, flushes it to disk and renames it over
/// `path`. On any failure the temporary file is removed and `path` is untouched.
pub fn write_atomically(path: &Path, write: impl FnOnce(&mut dyn Write) -> Result<(), String>) -> Result<(), WriteError> {
    let tmp = temp_path(path);
    let result = (|| {
        let file = std::fs::File::create(&tmp).map_err(|e| format!("cannot create \"{}\": {e}", tmp.display()))?;
        let mut buf = std::io::BufWriter::new(file);
        write(&mut buf)?;
        let file = buf.into_inner().map_err(|e| e.to_string())?;
        file.sync_all().map_err(|e| e.to_string())?;
        std::fs::rename(&tmp, path).map_err(|e| format!("cannot rename to \"{}\": {e}", path.display()))
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        WriteError(format!("writing \"{}\" failed: {e}", path.display()))
    })
}

fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map_or_else(|| "image".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn grid_lines_fall_every_interval() {
        let mut film = Film::new(5, 4);
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
    fn unknown_extensions_are_refused() {
        assert!(kind_for(Path::new("a.bmp")).is_err());
        assert_eq!(kind_for(Path::new("a.JPG")).unwrap(), ImageKind::Jpeg);
    }
}
