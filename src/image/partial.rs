//! Partial images (feature `exr`): one share of a frame ([`ShareSums`]) as an OpenEXR file that
//! `raylab merge` combines and `raylab render --resume` continues, and that any EXR viewer opens.
//!
//! - The **data window** is the share's pixel bounds; the **display window** is the whole frame.
//! - Channels `R`, `G`, `B` (`f32`) hold each pixel's mean so far, for viewers; `Z`,
//!   `normal.X/Y/Z`, `albedo.R/G/B`, `emission.R/G/B` the layers' means when the render made
//!   them.
//! - What merging needs, exactly: `raylab.sum.{R,G,B}.{0..3}` (each channel's fixed-point sum,
//!   an `i128` as four `u32` limbs, least significant first), `raylab.sq.{0..3}` (the sum of
//!   the rays' squared luminance, the same way: the error estimate), `raylab.odd.{0..3}` and
//!   `raylab.n_odd` (the luminance and rays of odd-numbered samples), `raylab.n` (rays summed) and
//!   `raylab.samples` (samples of the share done), and with layers `raylab.depth.{0..3}`,
//!   `raylab.hits`, `raylab.rays`, `raylab.normal.{X,Y,Z}.{0,1}`, `raylab.albedo.{R,G,B}.{0,1}`
//!   and `raylab.emitted.{R,G,B}.{0,1}` (`i64`s as two limbs).
//!   Files from before the emission layer lack its channels: their emission reads as zero, which
//!   only leaves it to the denoiser's filter with the rest.
//! - Header attributes (written in name order: the same share gives the same bytes): `raylab.partial` (the format version), `raylab.fingerprint` (scene, files
//!   and settings), `raylab.pass` and `raylab.passes` (the sample share), `raylab.sampling` (for
//!   people), with an error target `raylab.target_error` and `raylab.target_min_spp`, on a finer
//!   grid (`render --denoise`'s sub-pixels) `raylab.subpixels`, and for checkpoints
//!   `raylab.resume` (how to continue: JSON).
//!
//! Reading is hostile-input safe: sizes are checked against the limits from the header before
//! any pixel is decoded, every channel and attribute is checked, and every error says what was
//! expected.

use crate::image::write::{WriteError, write_atomically};
use crate::render::accum::{AovSum, PixelSum};
use crate::render::share::{Rect, Sampling, Share, ShareSums};
use exr::prelude::*;
use std::path::Path;
use std::result::Result;

/// The format version written in `raylab.partial`.
pub const PARTIAL_VERSION: i32 = 2;

/// Most channels a partial image has (colour, layers and their sums: 60); more is refused before
/// decoding, so a file cannot multiply its pixels' memory by claiming thousands of channels.
const MAX_CHANNELS: usize = 64;

/// What a partial file says about itself besides its pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct PartialInfo {
    /// The render's fingerprint ([`crate::RenderJob::fingerprint`]).
    pub fingerprint: String,
    /// A one-line description of the sampling (for messages).
    pub sampling: String,
    /// The scene's 8-bit encoding (`srgb` or `linear`), for merged PNG/JPEG output.
    pub encoding: String,
    /// How to continue the render (checkpoints only): JSON written by the CLI.
    pub resume: Option<String>,
}

const COLOR: [&str; 3] = ["R", "G", "B"];
const AXES: [&str; 3] = ["X", "Y", "Z"];

fn limbs(v: i128, n: usize) -> impl Iterator<Item = u32> {
    (0..n).map(move |k| (v >> (32 * k)) as u32)
}

fn from_limbs(l: &[u32]) -> i128 {
    let mut v: u128 = 0;
    for (k, &x) in l.iter().enumerate() {
        v |= u128::from(x) << (32 * k);
    }
    // Sign-extend from the limbs' width.
    let bits = 32 * l.len() as u32;
    if bits < 128 { ((v << (128 - bits)) as i128) >> (128 - bits) } else { v as i128 }
}

/// Writes `sums` to `path` as a partial EXR, atomically.
pub fn write_partial(path: &Path, sums: &ShareSums, info: &PartialInfo) -> Result<(), WriteError> {
    let bytes = encode_partial(sums, info).map_err(|e| WriteError(format!("encoding \"{}\" failed: {e}", path.display())))?;
    write_atomically(path, |w| w.write_all(&bytes).map_err(|e| e.to_string()))
}

/// The partial EXR's bytes.
pub fn encode_partial(sums: &ShareSums, info: &PartialInfo) -> Result<Vec<u8>, String> {
    let b = sums.share.bounds;
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    let mut f32s = |name: String, v: Vec<f32>| channels.push(AnyChannel::new(name.as_str(), FlatSamples::F32(v)));
    let means: Vec<_> = sums.pixels.iter().map(PixelSum::mean).collect();
    for (c, name) in COLOR.iter().enumerate() {
        f32s(name.to_string(), means.iter().map(|m| m[c] as f32).collect());
    }
    let layer_means: Option<Vec<_>> = sums.layers.as_ref().map(|l| l.iter().map(AovSum::mean).collect());
    if let Some(m) = &layer_means {
        f32s("Z".into(), m.iter().map(|l| l.0).collect());
        for (c, a) in AXES.iter().enumerate() {
            f32s(format!("normal.{a}"), m.iter().map(|l| l.1[c]).collect());
        }
        for (c, a) in COLOR.iter().enumerate() {
            f32s(format!("albedo.{a}"), m.iter().map(|l| l.2[c]).collect());
        }
    }
    if let Some(l) = &sums.layers {
        let emitted: Vec<_> = l.iter().map(AovSum::emitted_mean).collect();
        for (c, a) in COLOR.iter().enumerate() {
            f32s(format!("emission.{a}"), emitted.iter().map(|e| e[c]).collect());
        }
    }
    let mut u32s = |name: String, v: Vec<u32>| channels.push(AnyChannel::new(name.as_str(), FlatSamples::U32(v)));
    for (c, name) in COLOR.iter().enumerate() {
        for k in 0..4 {
            u32s(format!("raylab.sum.{name}.{k}"), sums.pixels.iter().map(|p| limbs(p.sum[c], 4).nth(k).unwrap_or(0)).collect());
        }
    }
    for k in 0..4 {
        u32s(format!("raylab.sq.{k}"), sums.pixels.iter().map(|p| limbs(p.sq, 4).nth(k).unwrap_or(0)).collect());
        u32s(format!("raylab.odd.{k}"), sums.pixels.iter().map(|p| limbs(p.odd, 4).nth(k).unwrap_or(0)).collect());
    }
    u32s("raylab.n_odd".into(), sums.pixels.iter().map(|p| p.n_odd).collect());
    u32s("raylab.n".into(), sums.pixels.iter().map(|p| p.n).collect());
    u32s("raylab.samples".into(), sums.pixels.iter().map(|p| p.samples).collect());
    if let Some(l) = &sums.layers {
        for k in 0..4 {
            u32s(format!("raylab.depth.{k}"), l.iter().map(|s| limbs(s.depth, 4).nth(k).unwrap_or(0)).collect());
        }
        u32s("raylab.hits".into(), l.iter().map(|s| s.hits).collect());
        u32s("raylab.rays".into(), l.iter().map(|s| s.rays).collect());
        for c in 0..3 {
            for k in 0..2 {
                u32s(
                    format!("raylab.normal.{}.{k}", AXES[c]),
                    l.iter().map(|s| limbs(i128::from(s.normal[c]), 2).nth(k).unwrap_or(0)).collect(),
                );
                u32s(
                    format!("raylab.albedo.{}.{k}", COLOR[c]),
                    l.iter().map(|s| limbs(i128::from(s.albedo[c]), 2).nth(k).unwrap_or(0)).collect(),
                );
            }
            for k in 0..2 {
                u32s(
                    format!("raylab.emitted.{}.{k}", COLOR[c]),
                    l.iter().map(|s| limbs(i128::from(s.emitted[c]), 2).nth(k).unwrap_or(0)).collect(),
                );
            }
        }
    }
    let mut attributes = LayerAttributes { layer_position: Vec2(b.x0 as i32, b.y0 as i32), ..LayerAttributes::default() };
    let mut attr = |k: &str, v: AttributeValue| {
        attributes.other.insert(Text::from(k), v);
    };
    attr("raylab.partial", AttributeValue::I32(PARTIAL_VERSION));
    attr("raylab.fingerprint", AttributeValue::Text(Text::from(info.fingerprint.as_str())));
    attr("raylab.spp", AttributeValue::I32(sums.sampling.spp.min(i32::MAX as u32) as i32));
    attr("raylab.adaptive", AttributeValue::I32(i32::from(sums.sampling.adaptive)));
    if let Some(t) = sums.sampling.target {
        attr("raylab.target_error", AttributeValue::F64(t.error));
        attr("raylab.target_min_spp", AttributeValue::I32(t.min_spp.min(i32::MAX as u32) as i32));
    }
    if sums.sampling.subpixels > 1 {
        attr("raylab.subpixels", AttributeValue::I32(sums.sampling.subpixels.min(i32::MAX as u32) as i32));
    }
    attr("raylab.pass", AttributeValue::I32(sums.share.pass as i32));
    attr("raylab.passes", AttributeValue::I32(sums.share.passes as i32));
    attr("raylab.sampling", AttributeValue::Text(Text::from(info.sampling.as_str())));
    attr("raylab.encoding", AttributeValue::Text(Text::from(info.encoding.as_str())));
    if let Some(r) = &info.resume {
        attr("raylab.resume", AttributeValue::Text(Text::from(r.as_str())));
    }
    let layer = Layer::new(
        Vec2(b.width() as usize, b.height() as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let image_attributes = ImageAttributes::new(IntegerBounds::new(Vec2(0, 0), Vec2(sums.width as usize, sums.height as usize)));
    let mut out = std::io::Cursor::new(Vec::new());
    Image::new(image_attributes, layer).write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    let mut bytes = out.into_inner();
    crate::image::exr::sort_header(&mut bytes)?;
    Ok(bytes)
}

/// Why a partial file cannot be used.
#[derive(Clone, Debug, PartialEq)]
pub struct PartialError(pub String);

impl std::fmt::Display for PartialError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Whether `bytes` are a partial EXR (its header has `raylab.partial`): a share of a frame, not
/// the frame. False for anything else, readable or not.
pub fn is_partial(bytes: &[u8]) -> bool {
    exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .is_ok_and(|m| m.headers.iter().any(|h| h.own_attributes.other.contains_key(&Text::from("raylab.partial"))))
}

/// Reads a partial EXR from `bytes` (named `name` in messages), refusing frames of more than
/// `max_pixels` pixels before decoding any.
pub fn read_partial(bytes: &[u8], name: &str, max_pixels: u64) -> Result<(ShareSums, PartialInfo), PartialError> {
    let err = |m: String| PartialError(format!("{name}: {m}"));
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| err(format!("not a readable OpenEXR file ({e})")))?;
    let [header] = meta.headers.as_slice() else {
        return Err(err(format!("expected one part, found {}", meta.headers.len())));
    };
    let attrs = &header.own_attributes.other;
    let int = |k: &str| match attrs.get(&Text::from(k)) {
        Some(AttributeValue::I32(v)) => Ok(*v),
        Some(_) => Err(err(format!("attribute {k} is not an integer"))),
        None => Err(err(format!(
            "no attribute {k}: not a raylab partial image (written by `raylab render --tile/--crop/--pass` or a checkpoint)"
        ))),
    };
    let text = |k: &str| match attrs.get(&Text::from(k)) {
        Some(AttributeValue::Text(t)) => Ok(Some(t.to_string())),
        Some(_) => Err(err(format!("attribute {k} is not text"))),
        None => Ok(None),
    };
    let version = int("raylab.partial")?;
    if version != PARTIAL_VERSION {
        return Err(err(format!("partial format version {version}; this raylab reads version {PARTIAL_VERSION}")));
    }
    let fingerprint = text("raylab.fingerprint")?.ok_or_else(|| err("no attribute raylab.fingerprint".into()))?;
    if fingerprint.len() != 32 || !fingerprint.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(err(format!("raylab.fingerprint \"{fingerprint}\" is not 32 hex digits")));
    }
    let (spp, adaptive) = (int("raylab.spp")?, int("raylab.adaptive")?);
    if spp < 1 || !(adaptive == 0 || adaptive == 1) {
        return Err(err(format!("sampling of {spp} spp, adaptive {adaptive}: expected spp ≥ 1 and adaptive 0 or 1")));
    }
    let target = match attrs.get(&Text::from("raylab.target_error")) {
        None => None,
        Some(AttributeValue::F64(e)) if *e > 0.0 && *e <= crate::render::job::ErrorTarget::MAX => {
            let min_spp = int("raylab.target_min_spp")?;
            if min_spp < 2 {
                return Err(err(format!("raylab.target_min_spp is {min_spp}: expected 2 or more")));
            }
            Some(crate::render::job::ErrorTarget { error: *e, min_spp: min_spp as u32 })
        }
        Some(_) => {
            return Err(err(format!("attribute raylab.target_error is not a number in (0, {}]", crate::render::job::ErrorTarget::MAX)));
        }
    };
    let subpixels = match attrs.get(&Text::from("raylab.subpixels")) {
        None => 1,
        Some(_) => match int("raylab.subpixels")? {
            k if u32::try_from(k).is_ok_and(|k| crate::render::share::SUBPIXEL_SIDES.contains(&k)) => k as u32,
            k => return Err(err(format!("raylab.subpixels is {k}: {}", crate::render::share::subpixel_rule()))),
        },
    };
    let sampling = Sampling { spp: spp as u32, adaptive: adaptive == 1, target, subpixels };
    let (pass, passes) = (int("raylab.pass")?, int("raylab.passes")?);
    if !(passes >= 1 && pass >= 0 && pass < passes) {
        return Err(err(format!("sample pass {pass}/{passes} is not a pass of 1 or more (0 ≤ pass < passes)")));
    }
    let display = header.shared_attributes.display_window;
    let (fw, fh) = (display.size.0, display.size.1);
    if display.position != Vec2(0, 0) || fw == 0 || fh == 0 || fw > u32::MAX as usize || fh > u32::MAX as usize {
        return Err(err(format!("display window {display:?} is not a frame from (0, 0)")));
    }
    if (fw as u64).saturating_mul(fh as u64) > max_pixels {
        return Err(err(format!("a frame of {fw}×{fh} pixels exceeds the limit of {max_pixels} pixels (raise --max-pixels)")));
    }
    let pos = header.own_attributes.layer_position;
    let size = header.layer_size;
    if pos.0 < 0 || pos.1 < 0 || size.0 == 0 || size.1 == 0 {
        return Err(err(format!("data window at {pos:?} of {size:?} is empty or outside the frame")));
    }
    let bounds = Rect {
        x0: pos.0 as u32,
        y0: pos.1 as u32,
        x1: (pos.0 as u64 + size.0 as u64).min(u64::from(u32::MAX)) as u32,
        y1: (pos.1 as u64 + size.1 as u64).min(u64::from(u32::MAX)) as u32,
    };
    if !bounds.within(&Rect::frame(fw as u32, fh as u32)) || bounds.pixels() != (size.0 as u64) * (size.1 as u64) {
        return Err(err(format!("data window {bounds:?} lies outside the {fw}×{fh} frame")));
    }
    let names: Vec<String> = header.channels.list.iter().map(|c| c.name.to_string()).collect();
    if names.len() > MAX_CHANNELS {
        return Err(err(format!("{} channels; a partial image has at most {MAX_CHANNELS}", names.len())));
    }
    let has = |n: &str| names.iter().any(|c| c == n);
    let layered = has("raylab.rays");
    // Every channel is read whole; the pixels were bounded above.
    let image = crate::image::exr::read_flat(bytes).map_err(|e| err(format!("cannot decode its pixels ({e})")))?;
    let n = bounds.pixels() as usize;
    let channel = |name: &str| -> Result<Vec<u32>, PartialError> {
        let c = image.layer_data.channel_data.list.iter().find(|c| c.name.eq(name)).ok_or_else(|| err(format!("no channel {name}")))?;
        match &c.sample_data {
            FlatSamples::U32(v) if v.len() == n => Ok(v.clone()),
            FlatSamples::U32(v) => Err(err(format!("channel {name} has {} values for {n} pixels", v.len()))),
            _ => Err(err(format!("channel {name} is not 32-bit unsigned integers"))),
        }
    };
    let wide = |prefix: &str, k: usize| -> Result<Vec<i128>, PartialError> {
        let parts: Vec<Vec<u32>> = (0..k).map(|i| channel(&format!("{prefix}.{i}"))).collect::<Result<_, _>>()?;
        Ok((0..n).map(|p| from_limbs(&parts.iter().map(|l| l[p]).collect::<Vec<u32>>())).collect())
    };
    let sum: Vec<Vec<i128>> = COLOR.iter().map(|c| wide(&format!("raylab.sum.{c}"), 4)).collect::<Result<_, _>>()?;
    let (sq, odd) = (wide("raylab.sq", 4)?, wide("raylab.odd", 4)?);
    let (count, samples, n_odd) = (channel("raylab.n")?, channel("raylab.samples")?, channel("raylab.n_odd")?);
    let pixels = (0..n)
        .map(|p| PixelSum {
            sum: [sum[0][p], sum[1][p], sum[2][p]],
            sq: sq[p],
            odd: odd[p],
            n: count[p],
            n_odd: n_odd[p],
            samples: samples[p],
        })
        .collect();
    let layers = if layered {
        let depth = wide("raylab.depth", 4)?;
        let (hits, rays) = (channel("raylab.hits")?, channel("raylab.rays")?);
        let normal: Vec<Vec<i128>> = AXES.iter().map(|a| wide(&format!("raylab.normal.{a}"), 2)).collect::<Result<_, _>>()?;
        let albedo: Vec<Vec<i128>> = COLOR.iter().map(|c| wide(&format!("raylab.albedo.{c}"), 2)).collect::<Result<_, _>>()?;
        let emitted: Vec<Vec<i128>> = if has("raylab.emitted.R.0") {
            COLOR.iter().map(|c| wide(&format!("raylab.emitted.{c}"), 2)).collect::<Result<_, _>>()?
        } else {
            vec![vec![0; n]; 3]
        };
        Some(
            (0..n)
                .map(|p| AovSum {
                    depth: depth[p],
                    hits: hits[p],
                    rays: rays[p],
                    normal: [normal[0][p] as i64, normal[1][p] as i64, normal[2][p] as i64],
                    albedo: [albedo[0][p] as i64, albedo[1][p] as i64, albedo[2][p] as i64],
                    emitted: [emitted[0][p] as i64, emitted[1][p] as i64, emitted[2][p] as i64],
                })
                .collect(),
        )
    } else {
        None
    };
    let share = Share { bounds, pass: pass as u32, passes: passes as u32 };
    let sums = ShareSums { width: fw as u32, height: fh as u32, sampling, share, pixels, layers };
    let encoding = text("raylab.encoding")?.unwrap_or_else(|| "srgb".into());
    if crate::math::color::Encoding::parse(&encoding).is_none() {
        return Err(err(format!("raylab.encoding \"{encoding}\": expected srgb or linear")));
    }
    let info =
        PartialInfo { fingerprint, sampling: text("raylab.sampling")?.unwrap_or_default(), encoding, resume: text("raylab.resume")? };
    Ok((sums, info))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::color::Color;

    fn sample() -> ShareSums {
        let share = Share { bounds: Rect { x0: 3, y0: 2, x1: 7, y1: 5 }, pass: 1, passes: 3 };
        let mut pixels = vec![PixelSum::default(); 12];
        for (i, p) in pixels.iter_mut().enumerate() {
            p.add(Color::new(i as f64 * 0.1, -1e-9, 3e12));
            p.samples = i as u32;
        }
        let mut layers = vec![AovSum::default(); 12];
        for (i, l) in layers.iter_mut().enumerate() {
            l.add(&crate::render::aov::AovSample {
                depth: if i == 3 { f64::INFINITY } else { 1e9 + i as f64 },
                normal: glam::DVec3::new(-0.5, 0.25, 1.0),
                albedo: glam::DVec3::splat(0.75),
                signature: 0,
                emitted: glam::DVec3::new(0.5, 1e6 + i as f64, 0.0),
                guides: false,
            });
        }
        ShareSums {
            width: 10,
            height: 8,
            sampling: Sampling { spp: 12, adaptive: false, target: None, subpixels: 1 },
            share,
            pixels,
            layers: Some(layers),
        }
    }

    #[test]
    fn the_same_share_encodes_to_the_same_bytes() {
        let info = PartialInfo {
            fingerprint: "0123456789abcdef0123456789abcdef".into(),
            sampling: "4 spp".into(),
            encoding: "srgb".into(),
            resume: Some("{}".into()),
        };
        let first = encode_partial(&sample(), &info).unwrap();
        for _ in 0..8 {
            assert_eq!(encode_partial(&sample(), &info).unwrap(), first);
        }
        assert_eq!(read_partial(&first, "p.exr", u64::MAX).unwrap().1, info);
    }

    #[test]
    fn a_partial_reads_back_exactly() {
        let s = sample();
        let info = PartialInfo {
            fingerprint: "0123456789abcdef0123456789abcdef".into(),
            sampling: "4 spp".into(),
            encoding: "linear".into(),
            resume: Some("{}".into()),
        };
        let bytes = encode_partial(&s, &info).unwrap();
        let (back, info2) = read_partial(&bytes, "p.exr", u64::MAX).unwrap();
        assert_eq!(back, s);
        assert_eq!(info2, info);
        assert!(read_partial(&bytes, "p.exr", 79).unwrap_err().0.contains("exceeds the limit"));
        // The blocks of sub-pixels an error target decides on (`render --denoise`'s finer grid).
        let fine = ShareSums { sampling: Sampling { subpixels: 2, ..s.sampling }, ..s };
        assert_eq!(read_partial(&encode_partial(&fine, &info).unwrap(), "p.exr", u64::MAX).unwrap().0, fine);
    }

    #[test]
    fn limbs_round_trip_signed_values() {
        for v in [0i128, 1, -1, i128::MAX, i128::MIN, 1 << 100, -(1 << 70) + 5] {
            assert_eq!(from_limbs(&limbs(v, 4).collect::<Vec<_>>()), v);
        }
        for v in [0i64, -1, i64::MIN, i64::MAX, 12345] {
            assert_eq!(from_limbs(&limbs(i128::from(v), 2).collect::<Vec<_>>()) as i64, v);
        }
    }

    #[test]
    fn damaged_or_foreign_files_are_errors_not_panics() {
        let s = sample();
        let info = PartialInfo {
            fingerprint: "0123456789abcdef0123456789abcdef".into(),
            sampling: String::new(),
            encoding: "srgb".into(),
            resume: None,
        };
        let bytes = encode_partial(&s, &info).unwrap();
        for cut in [0, 4, 100, bytes.len() / 2, bytes.len() - 1] {
            assert!(read_partial(&bytes[..cut], "p.exr", u64::MAX).is_err(), "cut at {cut}");
        }
        let mut film = crate::render::film::Film::new(4, 4).unwrap();
        film.set(1, 1, glam::Vec3::ONE);
        let plain = crate::image::exr::encode_exr(&film, &Default::default(), false).unwrap();
        assert!(read_partial(&plain, "plain.exr", u64::MAX).unwrap_err().0.contains("not a raylab partial image"));
    }
}
