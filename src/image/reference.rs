//! Reference images for error measurement: reading and writing linear HDR images.
//!
//! - `.pfm` (Portable Float Map, little-endian RGB `f32`): raylab's lossless format for cached
//!   references; read and written by many tools (pbrt, ImageMagick, GIMP).
//! - `.png` (8 or 16 bits per channel): read only; its values are taken as displayed values and
//!   decoded with the render's encoding, so comparing a render with its own PNG measures only the
//!   quantisation.

use crate::math::color::{Encoding, srgb_decode};
use crate::render::film::Film;
use glam::Vec3;
use std::path::Path;

/// Largest reference image read, pixels (the same default as the largest render).
pub const MAX_REFERENCE_PIXELS: u64 = 1 << 26;

/// Largest reference file read, bytes: the largest image at 16 bytes a pixel (above a PFM's 12
/// and a 16-bit RGBA PNG's 8 with its compression overhead), plus headers.
pub const MAX_REFERENCE_BYTES: u64 = MAX_REFERENCE_PIXELS * 16 + (1 << 20);

/// Reads a reference image (`.pfm` or `.png`) as linear RGB; PNG values are decoded with `encoding`.
pub fn read(path: &Path, encoding: Encoding) -> Result<Film, String> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let bytes = crate::param::files::read_regular(path, MAX_REFERENCE_BYTES, None)
        .map_err(|e| e.message(&format!("reference \"{}\"", path.display())))?;
    let film = match ext.as_str() {
        "pfm" => decode_pfm(&bytes),
        "png" => decode_png(&bytes, encoding),
        _ => Err(format!("unknown reference image type \".{ext}\"; expected .pfm or .png")),
    };
    film.map_err(|e| format!("reference \"{}\": {e}", path.display()))
}

/// Writes `film` to `path` as PFM, atomically.
pub fn write_pfm(path: &Path, film: &Film) -> Result<(), String> {
    crate::image::write::write_atomically(path, |w| w.write_all(&encode_pfm(film)).map_err(|e| e.to_string())).map_err(|e| e.to_string())
}

/// `film` as a PFM file: header `PF`, size, scale −1 (little-endian), rows bottom to top.
pub fn encode_pfm(film: &Film) -> Vec<u8> {
    let mut out = format!("PF\n{} {}\n-1.0\n", film.width, film.height).into_bytes();
    out.reserve(film.pixels.len() * 12);
    for y in (0..film.height).rev() {
        for x in 0..film.width {
            for v in film.get(x, y).to_array() {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    out
}

/// Parses a PFM file (colour `PF` or grey `Pf`, either byte order).
pub fn decode_pfm(bytes: &[u8]) -> Result<Film, String> {
    // Header: three whitespace-separated tokens after the magic, then one whitespace byte.
    let mut pos = 0;
    let mut token = || -> Result<String, String> {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() && pos - start < 32 {
            pos += 1;
        }
        if start == pos {
            return Err("truncated PFM header".into());
        }
        Ok(String::from_utf8_lossy(&bytes[start..pos]).into_owned())
    };
    let channels = match token()?.as_str() {
        "PF" => 3,
        "Pf" => 1,
        m => return Err(format!("not a PFM file (magic \"{m}\", expected PF or Pf)")),
    };
    let bad = |what: &str, s: &str| format!("bad PFM {what} \"{s}\"");
    let (ws, hs, ss) = (token()?, token()?, token()?);
    let width: u32 = ws.parse().map_err(|_| bad("width", &ws))?;
    let height: u32 = hs.parse().map_err(|_| bad("height", &hs))?;
    let scale: f64 = ss.parse().map_err(|_| bad("scale", &ss))?;
    if width == 0 || height == 0 || u64::from(width) * u64::from(height) > MAX_REFERENCE_PIXELS {
        return Err(format!("PFM size {width}×{height} is empty or over {MAX_REFERENCE_PIXELS} pixels"));
    }
    if !(scale.is_finite() && scale != 0.0) {
        return Err(bad("scale", &ss));
    }
    let data = &bytes[(pos + 1).min(bytes.len())..];
    let expected = width as usize * height as usize * channels * 4;
    if data.len() != expected {
        return Err(format!("PFM data is {} bytes; {width}×{height}×{channels} floats need {expected}", data.len()));
    }
    let little = scale < 0.0;
    let value = |i: usize| {
        let b = [data[4 * i], data[4 * i + 1], data[4 * i + 2], data[4 * i + 3]];
        if little { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) }
    };
    let mut film = Film::new(width, height).map_err(|e| e.to_string())?;
    for row in 0..height {
        let y = height - 1 - row;
        for x in 0..width {
            let i = (row as usize * width as usize + x as usize) * channels;
            let c = if channels == 3 { Vec3::new(value(i), value(i + 1), value(i + 2)) } else { Vec3::splat(value(i)) };
            film.set(x, y, c);
        }
    }
    Ok(film)
}

/// Decodes an 8- or 16-bit PNG to linear RGB (values taken as displayed with `encoding`).
pub fn decode_png(bytes: &[u8], encoding: Encoding) -> Result<Film, String> {
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png).map_err(|e| e.to_string())?;
    let (width, height) = (img.width(), img.height());
    if u64::from(width) * u64::from(height) > MAX_REFERENCE_PIXELS {
        return Err(format!("PNG size {width}×{height} is over {MAX_REFERENCE_PIXELS} pixels"));
    }
    let rgb = img.to_rgb32f();
    let mut film = Film::new(width, height).map_err(|e| e.to_string())?;
    let decode = |v: f32| match encoding {
        Encoding::Srgb => srgb_decode(v),
        Encoding::Linear | Encoding::LinearTruncated => v,
    };
    for (x, y, p) in rgb.enumerate_pixels() {
        film.set(x, y, Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])));
    }
    Ok(film)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_round_trips_bit_exactly() {
        let mut film = Film::new(3, 2).unwrap();
        film.set(0, 0, Vec3::new(0.1, 2.5, -0.0));
        film.set(2, 1, Vec3::new(1e-30, 65504.0, f32::MIN_POSITIVE));
        let back = decode_pfm(&encode_pfm(&film)).unwrap();
        assert_eq!(back, film);
    }

    #[test]
    fn malformed_pfm_is_an_error_not_a_panic() {
        for bad in [&b""[..], b"P6\n1 1\n255\n", b"PF\n2 2\n-1.0\n\0\0", b"PF\n99999999 99999999\n-1\n", b"PF\n1 1\nnan\n"] {
            assert!(decode_pfm(bad).is_err(), "{:?}", String::from_utf8_lossy(bad));
        }
    }

    #[test]
    fn png_reference_decodes_to_the_rendered_values() {
        let mut film = Film::new(2, 1).unwrap();
        film.set(0, 0, Vec3::new(0.2, 0.5, 1.0));
        let rgb = crate::image::output::to_rgb8(&film, Encoding::Srgb, None);
        let mut png = Vec::new();
        crate::image::output::encode_rgb8(&mut png, &rgb, 2, 1, crate::image::output::ImageKind::Png).unwrap();
        let back = decode_png(&png, Encoding::Srgb).unwrap();
        assert!((back.get(0, 0) - film.get(0, 0)).abs().max_element() < 0.01);
        assert_eq!(back.get(1, 0), Vec3::ZERO);
    }
}
