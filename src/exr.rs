//! OpenEXR output (feature `exr`): the film's linear, unclamped RGB as 32-bit floats (or half
//! floats), with optional extra layers for denoisers: depth `Z`, `normal.X/Y/Z`, `albedo.R/G/B`
//! ([`crate::aov`]). One part, channels by name, lossless ZIP compression; depth is always 32-bit.
//! Written atomically, like every raylab image.

use crate::aov::Aovs;
use crate::film::Film;
use crate::output::{WriteError, write_atomically};
use exr::prelude::*;
use std::path::Path;
use std::result::Result;

/// Writes `film` (and `aovs`) to `path` as OpenEXR; `half` stores colour, normal and albedo as
/// 16-bit floats.
pub fn write_exr(path: &Path, film: &Film, aovs: &Aovs, half: bool) -> Result<(), WriteError> {
    let bytes = encode_exr(film, aovs, half).map_err(|e| WriteError(format!("encoding \"{}\" failed: {e}", path.display())))?;
    write_atomically(path, |w| w.write_all(&bytes).map_err(|e| e.to_string()))
}

/// The EXR file's bytes.
pub fn encode_exr(film: &Film, aovs: &Aovs, half: bool) -> Result<Vec<u8>, String> {
    let samples = |v: Vec<f32>| if half { FlatSamples::F16(v.into_iter().map(f16::from_f32).collect()) } else { FlatSamples::F32(v) };
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    let mut rgb = |prefix: &str, names: [&str; 3], px: &[glam::Vec3]| {
        for (c, name) in names.iter().enumerate() {
            channels.push(AnyChannel::new(format!("{prefix}{name}").as_str(), samples(px.iter().map(|p| p[c]).collect())));
        }
    };
    rgb("", ["R", "G", "B"], &film.pixels);
    if let Some(n) = &aovs.normal {
        rgb("normal.", ["X", "Y", "Z"], n);
    }
    if let Some(a) = &aovs.albedo {
        rgb("albedo.", ["R", "G", "B"], a);
    }
    if let Some(d) = &aovs.depth {
        channels.push(AnyChannel::new("Z", FlatSamples::F32(d.clone())));
    }
    let size = Vec2(film.width as usize, film.height as usize);
    let layer = Layer::new(size, LayerAttributes::default(), Encoding::SMALL_LOSSLESS, AnyChannels::sort(SmallVec::from_vec(channels)));
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// Reads the colour channels of an EXR file raylab wrote (for tests and tools): width, height and
/// linear RGB pixels, row by row.
pub fn read_exr_rgb(bytes: &[u8]) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.0, layer.size.1);
    let channel = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .ok_or_else(|| format!("no channel {name}"))
            .map(|c| c.sample_data.values_as_f32().collect::<Vec<f32>>())
    };
    let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
    Ok((w, h, (0..w * h).map(|i| [r[i], g[i], b[i]]).collect()))
}
