//! Viewable images from HDR files (`raylab tonemap`): the colour of an OpenEXR or PFM file with
//! an exposure, or one of raylab's EXR layers visualised the usual way: depth as grey from white
//! (nearest) to black (farthest, and where nothing was hit), normals as `(n + 1) / 2`, albedo as
//! colour.
//!
//! Files are untrusted: the file's size is bounded before it is read, and an EXR's header
//! (pixels, channels) is checked before any pixel is decoded.

use crate::image::reference::MAX_REFERENCE_BYTES;
use crate::math::color::Encoding;
use crate::render::film::Film;
use glam::Vec3;

/// What to show of the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layer {
    /// The colour (R, G, B; or Y as grey).
    Color,
    /// Distance to the first surface (channel `Z`).
    Depth,
    /// Shading normal (`normal.X/Y/Z`).
    Normal,
    /// Albedo (`albedo.R/G/B`).
    Albedo,
    /// Radiance camera rays met directly (`emission.R/G/B`).
    Emission,
    /// Samples per pixel (`spp`).
    Spp,
}

impl Layer {
    /// Parses `color`, `depth`, `normal`, `albedo`, `emission` or `spp`.
    pub fn parse(s: &str) -> Option<Layer> {
        match s {
            "color" | "colour" => Some(Layer::Color),
            "depth" => Some(Layer::Depth),
            "normal" => Some(Layer::Normal),
            "albedo" => Some(Layer::Albedo),
            "emission" => Some(Layer::Emission),
            "spp" => Some(Layer::Spp),
            _ => None,
        }
    }

    /// Its name, as [`Layer::parse`] takes it.
    pub fn name(self) -> &'static str {
        match self {
            Layer::Color => "color",
            Layer::Depth => "depth",
            Layer::Normal => "normal",
            Layer::Albedo => "albedo",
            Layer::Emission => "emission",
            Layer::Spp => "spp",
        }
    }

    /// The EXR channel names holding it (one for depth, three otherwise).
    #[cfg(feature = "exr")]
    fn channels(self) -> &'static [&'static str] {
        match self {
            Layer::Color => &["R", "G", "B"],
            Layer::Depth => &["Z"],
            Layer::Normal => &["normal.X", "normal.Y", "normal.Z"],
            Layer::Albedo => &["albedo.R", "albedo.G", "albedo.B"],
            Layer::Emission => &["emission.R", "emission.G", "emission.B"],
            Layer::Spp => &["spp"],
        }
    }
}

/// Most channels an EXR file may declare.
#[cfg(feature = "exr")]
const MAX_CHANNELS: usize = 256;

/// Most values (pixels × channels) decoded from an EXR file: 1 GiB of `f32`.
#[cfg(feature = "exr")]
const MAX_SAMPLES: u64 = 1 << 28;

/// The largest file read, bytes (as for reference images).
pub const MAX_FILE_BYTES: u64 = MAX_REFERENCE_BYTES;

/// Reads `layer` of the image in `bytes` (an OpenEXR or PFM file, by `ext`) as a film: colour
/// channels as they are, depth in all three channels.
pub fn read_layer(bytes: &[u8], ext: &str, layer: Layer) -> Result<Film, String> {
    check_input(ext, layer)?;
    match ext {
        "pfm" => crate::image::reference::decode_pfm(bytes),
        _ => read_exr_layer(bytes, layer),
    }
}

/// What the `image_layer` fuzz target and its corpus replay check: `bytes` read as a PFM and as
/// an OpenEXR file, every layer, as `tonemap`, `denoise`, `--spp-map` and reference images read
/// them: a film whose pixels fill its size, or an error that says something; never a panic.
pub fn fuzz_read_layers(bytes: &[u8]) -> Result<(), String> {
    let layers = [Layer::Color, Layer::Depth, Layer::Normal, Layer::Albedo, Layer::Emission, Layer::Spp];
    for (ext, layer) in ["pfm", "exr"].into_iter().flat_map(|e| layers.map(|l| (e, l))) {
        match read_layer(bytes, ext, layer) {
            Ok(f) if f.width == 0 || f.height == 0 || f.pixels.len() != f.width as usize * f.height as usize => {
                return Err(format!(".{ext}, {}: a {}×{} film of {} pixels", layer.name(), f.width, f.height, f.pixels.len()));
            }
            Err(e) if e.is_empty() => return Err(format!(".{ext}, {}: an empty error", layer.name())),
            _ => {}
        }
    }
    Ok(())
}

/// Whether a file of extension `ext` (lower case) can give `layer`, asked before the file is
/// read: an unknown type, a layer of a PFM file, or OpenEXR without the `exr` feature is refused.
pub fn check_input(ext: &str, layer: Layer) -> Result<(), String> {
    match ext {
        "pfm" if layer != Layer::Color => Err(format!("a PFM file holds colour only; the {} layer needs an OpenEXR file", layer.name())),
        "pfm" => Ok(()),
        "exr" if cfg!(feature = "exr") => Ok(()),
        "exr" => Err(exr_needs_feature()),
        _ => Err(format!("unknown image type \".{ext}\"; expected .exr or .pfm")),
    }
}

/// Why an OpenEXR file cannot be read by this build.
fn exr_needs_feature() -> String {
    format!("reading OpenEXR needs the `exr` feature; {}", crate::param::error::built_without("exr"))
}

#[cfg(not(feature = "exr"))]
fn read_exr_layer(_: &[u8], _: Layer) -> Result<Film, String> {
    Err(exr_needs_feature())
}

#[cfg(feature = "exr")]
fn read_exr_layer(bytes: &[u8], layer: Layer) -> Result<Film, String> {
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| format!("not a readable OpenEXR file ({e})"))?;
    let header = meta.headers.first().ok_or("the file has no image part")?;
    let (w, h) = (header.layer_size.0, header.layer_size.1);
    let most = crate::image::reference::MAX_REFERENCE_PIXELS;
    if w == 0 || h == 0 || (w as u64).saturating_mul(h as u64) > most {
        return Err(format!("an image of {w}×{h} pixels is empty or over the {most} pixels read"));
    }
    if header.channels.list.len() > MAX_CHANNELS {
        return Err(format!("{} channels; at most {MAX_CHANNELS} are read", header.channels.list.len()));
    }
    let names: Vec<String> = header.channels.list.iter().map(|c| c.name.to_string()).collect();
    let wanted: Vec<&str> = if layer == Layer::Color && !names.iter().any(|n| n == "R") && names.iter().any(|n| n == "Y") {
        vec!["Y"]
    } else {
        layer.channels().to_vec()
    };
    if let Some(missing) = wanted.iter().find(|c| !names.iter().any(|n| n == *c)) {
        return Err(format!("no channel {missing} (the file has: {}); raylab writes layers with `render --aov`", names.join(", ")));
    }
    let samples = (w as u64 * h as u64).saturating_mul(names.len() as u64);
    if samples > MAX_SAMPLES {
        return Err(format!("{w}×{h} pixels × {} channels exceed the {MAX_SAMPLES} values read", names.len()));
    }
    // Bounded above: decoding allocates at most MAX_SAMPLES values.
    let image = crate::image::exr::read_flat(bytes).map_err(|e| format!("cannot decode its pixels ({e})"))?;
    let data = &image.layer_data;
    let (w, h) = (data.size.0, data.size.1);
    let channel = |name: &str| -> Result<Vec<f32>, String> {
        let c = data.channel_data.list.iter().find(|c| c.name.eq(name)).ok_or_else(|| format!("no channel {name}"))?;
        let v: Vec<f32> = c.sample_data.values_as_f32().collect();
        if v.len() == w * h { Ok(v) } else { Err(format!("channel {name} has {} values for {w}×{h} pixels", v.len())) }
    };
    let planes: Vec<Vec<f32>> = wanted.iter().map(|n| channel(n)).collect::<Result<_, _>>()?;
    let mut film = Film::new(w as u32, h as u32).map_err(|e| e.to_string())?;
    for (i, p) in film.pixels.iter_mut().enumerate() {
        *p = match planes.as_slice() {
            [one] => Vec3::splat(one[i]),
            [r, g, b] => Vec3::new(r[i], g[i], b[i]),
            _ => Vec3::ZERO,
        };
    }
    Ok(film)
}

/// `film` (of `layer`) as viewable values and the encoding that writes them: colour, albedo and
/// emission scaled by 2^`exposure` and sRGB-encoded; depth, normals and samples per pixel (grey by
/// log₂ spp, white at the most) as visualisation values written straight.
pub fn visualise(mut film: Film, layer: Layer, exposure: f64) -> (Film, Encoding) {
    match layer {
        Layer::Color | Layer::Albedo | Layer::Emission => {
            let scale = 2f32.powf(exposure as f32);
            for p in &mut film.pixels {
                *p *= scale;
            }
            (film, Encoding::Srgb)
        }
        Layer::Normal => {
            for p in &mut film.pixels {
                *p = if p.is_finite() { (*p + Vec3::ONE) * 0.5 } else { Vec3::ZERO };
            }
            (film, Encoding::Linear)
        }
        Layer::Spp => {
            let most = film.pixels.iter().map(|p| p.x).filter(|n| n.is_finite()).fold(1.0f32, f32::max);
            for p in &mut film.pixels {
                let n = if p.x.is_finite() { p.x.max(0.0) } else { 0.0 };
                *p = Vec3::splat((1.0 + n).log2() / (1.0 + most).log2());
            }
            (film, Encoding::Linear)
        }
        Layer::Depth => {
            let finite = film.pixels.iter().map(|p| p.x).filter(|d| d.is_finite() && *d >= 0.0);
            let (near, far) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), d| (lo.min(d), hi.max(d)));
            let span = far - near;
            for p in &mut film.pixels {
                let d = p.x;
                let v = if !(d.is_finite() && d >= 0.0) {
                    0.0
                } else if span > 0.0 {
                    1.0 - (d - near) / span
                } else {
                    1.0
                };
                *p = Vec3::splat(v);
            }
            (film, Encoding::Linear)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_goes_from_white_near_to_black_far_and_misses_are_black() {
        let mut f = Film::new(4, 1).unwrap();
        for (x, d) in [2.0, 4.0, 6.0, f32::INFINITY].into_iter().enumerate() {
            f.set(x as u32, 0, Vec3::splat(d));
        }
        let (v, enc) = visualise(f, Layer::Depth, 0.0);
        assert_eq!(enc, Encoding::Linear);
        assert_eq!(v.pixels.iter().map(|p| p.x).collect::<Vec<_>>(), vec![1.0, 0.5, 0.0, 0.0]);
    }

    #[test]
    fn normals_map_to_half_plus_half_and_exposure_doubles_per_stop() {
        let mut f = Film::new(1, 1).unwrap();
        f.set(0, 0, Vec3::new(-1.0, 0.0, 1.0));
        assert_eq!(visualise(f.clone(), Layer::Normal, 0.0).0.get(0, 0), Vec3::new(0.0, 0.5, 1.0));
        f.set(0, 0, Vec3::new(0.25, 0.5, 1.0));
        assert_eq!(visualise(f, Layer::Color, 1.0).0.get(0, 0), Vec3::new(0.5, 1.0, 2.0));
    }

    #[test]
    fn hostile_files_are_errors() {
        assert!(read_layer(b"PF\n1 1\n-1\n\0\0\0\0\0\0\0\0\0\0\0\0", "pfm", Layer::Depth).is_err(), "PFM has no layers");
        assert!(read_layer(b"garbage", "pfm", Layer::Color).is_err());
        assert!(read_layer(b"garbage", "exr", Layer::Color).is_err());
        assert!(read_layer(b"", "png", Layer::Color).is_err());
    }

    #[cfg(feature = "exr")]
    #[test]
    fn an_exr_with_layers_reads_back_each_layer() {
        use crate::render::aov::AovLayers;
        let mut film = Film::new(2, 1).unwrap();
        film.set(0, 0, Vec3::new(0.1, 0.2, 0.3));
        let aovs = AovLayers {
            depth: Some(vec![1.5, f32::INFINITY]),
            normal: Some(vec![Vec3::Z, Vec3::X]),
            albedo: Some(vec![Vec3::splat(0.5), Vec3::ONE]),
            ..AovLayers::default()
        };
        let bytes = crate::image::exr::encode_exr(&film, &aovs, false).unwrap();
        assert_eq!(read_layer(&bytes, "exr", Layer::Color).unwrap().get(0, 0), Vec3::new(0.1, 0.2, 0.3));
        assert_eq!(read_layer(&bytes, "exr", Layer::Depth).unwrap().get(0, 0), Vec3::splat(1.5));
        assert_eq!(read_layer(&bytes, "exr", Layer::Normal).unwrap().get(1, 0), Vec3::X);
        assert_eq!(read_layer(&bytes, "exr", Layer::Albedo).unwrap().get(0, 0), Vec3::splat(0.5));
        let plain = crate::image::exr::encode_exr(&film, &AovLayers::default(), false).unwrap();
        let e = read_layer(&plain, "exr", Layer::Depth).unwrap_err();
        assert!(e.contains("no channel Z"), "{e}");
    }
}
