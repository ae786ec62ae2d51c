//! OpenEXR output (feature `exr`): the film's linear, unclamped RGB as 32-bit floats (or half
//! floats), with optional extra layers for denoisers: depth `Z`, `normal.X/Y/Z`, `albedo.R/G/B`,
//! `emission.R/G/B` ([`crate::render::aov`]), and the error estimate `error` and samples per pixel `spp`
//! ([`crate::render::share::ShareSums::error_layers`]), with the image's estimated error in the
//! header (`raylab.estimated_relative_rmse`, `raylab.estimate_may_read`). One part, channels by name, lossless ZIP compression; depth is always 32-bit.
//! Written atomically, like every raylab image.

use crate::image::write::{WriteError, write_atomically};
use crate::render::aov::AovLayers;
use crate::render::film::Film;
use exr::prelude::*;
use std::path::Path;
use std::result::Result;

/// Writes `film` (and `aovs`) to `path` as OpenEXR; `half` stores colour, normal and albedo as
/// 16-bit floats.
pub fn write_exr(path: &Path, film: &Film, aovs: &AovLayers, half: bool) -> Result<(), WriteError> {
    let bytes = encode_exr(film, aovs, half).map_err(|e| WriteError(format!("encoding \"{}\" failed: {e}", path.display())))?;
    write_atomically(path, |w| w.write_all(&bytes).map_err(|e| e.to_string()))
}

/// The EXR file's bytes.
pub fn encode_exr(film: &Film, aovs: &AovLayers, half: bool) -> Result<Vec<u8>, String> {
    let n = film.pixels.len();
    let out_of_memory = |what: &str| format!("out of memory for the {what} of a {}×{} image", film.width, film.height);
    let samples = |v: &mut dyn Iterator<Item = f32>, what: &str| -> Result<FlatSamples, String> {
        if half {
            let mut s = Vec::new();
            s.try_reserve_exact(n).map_err(|_| out_of_memory(what))?;
            s.extend(v.map(f16::from_f32));
            Ok(FlatSamples::F16(s))
        } else {
            let mut s = Vec::new();
            s.try_reserve_exact(n).map_err(|_| out_of_memory(what))?;
            s.extend(v);
            Ok(FlatSamples::F32(s))
        }
    };
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    let mut rgb = |prefix: &str, names: [&str; 3], px: &[glam::Vec3]| -> Result<(), String> {
        for (c, name) in names.iter().enumerate() {
            let name = format!("{prefix}{name}");
            channels.push(AnyChannel::new(name.as_str(), samples(&mut px.iter().map(|p| p[c]), &format!("channel {name}"))?));
        }
        Ok(())
    };
    rgb("", ["R", "G", "B"], &film.pixels)?;
    if let Some(n) = &aovs.normal {
        rgb("normal.", ["X", "Y", "Z"], n)?;
    }
    if let Some(a) = &aovs.albedo {
        rgb("albedo.", ["R", "G", "B"], a)?;
    }
    if let Some(e) = &aovs.emitted {
        rgb("emission.", ["R", "G", "B"], e)?;
    }
    for (name, layer) in [("Z", &aovs.depth), ("error", &aovs.error), ("spp", &aovs.spp)] {
        if let Some(d) = layer {
            let mut z = Vec::new();
            z.try_reserve_exact(d.len()).map_err(|_| out_of_memory(&format!("channel {name}")))?;
            z.extend_from_slice(d);
            channels.push(AnyChannel::new(name, FlatSamples::F32(z)));
        }
    }
    let size = Vec2(film.width as usize, film.height as usize);
    let mut attributes = LayerAttributes::default();
    if let Some((rmse, reads)) = aovs.estimate {
        attributes.other.insert(Text::from("raylab.estimated_relative_rmse"), AttributeValue::F64(rmse));
        attributes.other.insert(Text::from("raylab.estimate_may_read"), AttributeValue::Text(Text::from(reads)));
    }
    let layer = Layer::new(size, attributes, Encoding::SMALL_LOSSLESS, AnyChannels::sort(SmallVec::from_vec(channels)));
    // The file is at most about its raw size: reserved up front, so the encoder never has to grow it.
    let raw: usize = n.saturating_mul(if half { 2 } else { 4 }).saturating_mul(layer.channel_data.list.len());
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(raw.saturating_add(raw / 64)).map_err(|_| out_of_memory("encoded file"))?;
    let mut out = std::io::Cursor::new(bytes);
    Image::from_layer(layer).write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    let mut bytes = out.into_inner();
    sort_header(&mut bytes)?;
    Ok(bytes)
}

/// Puts a single-part EXR file's header attributes in name order, in place.
///
/// The `exr` crate keeps custom attributes in a `HashMap` and writes them in its random order, so
/// two writes of the same image would differ in bytes. Sorting keeps the header's length, so the
/// offset table after it stays valid.
pub(crate) fn sort_header(bytes: &mut [u8]) -> Result<(), String> {
    let bad = || "EXR header is not a single-part header".to_string();
    let cstr = |at: usize| -> Option<usize> { bytes.get(at..)?.iter().position(|&b| b == 0).map(|n| at + n) };
    let mut at = 8;
    let mut records: Vec<(usize, usize, usize)> = Vec::new(); // (start, name end, record end)
    loop {
        let name_end = cstr(at).ok_or_else(bad)?;
        if name_end == at {
            break;
        }
        let type_end = cstr(name_end + 1).ok_or_else(bad)?;
        let size = bytes.get(type_end + 1..type_end + 5).ok_or_else(bad)?;
        let size = usize::try_from(i32::from_le_bytes([size[0], size[1], size[2], size[3]])).map_err(|_| bad())?;
        let end = type_end + 5 + size;
        if end > bytes.len() {
            return Err(bad());
        }
        records.push((at, name_end, end));
        at = end;
    }
    let start = records.first().map_or(at, |r| r.0);
    let mut sorted: Vec<&(usize, usize, usize)> = records.iter().collect();
    sorted.sort_by(|a, b| bytes[a.0..a.1].cmp(&bytes[b.0..b.1]));
    let header: Vec<u8> = sorted.iter().flat_map(|r| bytes[r.0..r.2].iter().copied()).collect();
    bytes[start..start + header.len()].copy_from_slice(&header);
    Ok(())
}

/// An EXR file's first layer with every channel, as stored.
pub type FlatImage = Image<Layer<AnyChannels<FlatSamples>>>;

/// Decodes every channel of the first valid layer of the EXR file in `bytes`. Callers bound the
/// file's size, pixels and channels (from its header) first: this allocates what they ask for.
pub fn read_flat(bytes: &[u8]) -> Result<FlatImage, exr::error::Error> {
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
}

/// Reads the colour channels of an EXR file raylab wrote (for tests and tools): width, height and
/// linear RGB pixels, row by row.
pub fn read_exr_rgb(bytes: &[u8]) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    let image = read_flat(bytes).map_err(|e| e.to_string())?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The same image encodes to the same bytes every time: the header's own attributes (the
    /// estimate's two) come in name order, not in a hash map's order, which changes per map.
    #[test]
    fn encoding_is_byte_identical_across_writes() {
        let film = Film::new(3, 2).unwrap();
        let aovs = AovLayers { error: Some(vec![0.5; 6]), estimate: Some((0.01, "no")), ..Default::default() };
        let first = encode_exr(&film, &aovs, false).unwrap();
        for _ in 0..16 {
            assert_eq!(encode_exr(&film, &aovs, false).unwrap(), first);
        }
    }
}
