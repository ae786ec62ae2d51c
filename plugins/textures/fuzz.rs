//! Arbitrary bytes → an image texture, through [`super::image::decode`], the function the scene
//! loader uses (the header checked against the limits and the decoded size charged to the memory
//! budget before decoding): the body of the `texture_image` fuzz target
//! (`fuzz/fuzz_targets/texture_image.rs`), also run over its checked-in corpus by
//! `tests/fuzz_corpus.rs` and `plugins/tests/no_panics.rs`.
//!
//! The limits are [`limits`], small enough that a file declaring a large image is refused cheaply
//! and that the fuzzer's allocation limit (`-malloc_limit_mb`, see docs/robustness.md) catches any
//! allocation the budget does not cover.

use super::image::{ColorSpace, Filter, Wrap, decode};
use raylab::LoadContext;
use raylab::glam::DVec2;
use raylab::load::context::LoadOptions;
use raylab::param::limits::Limits;

/// The limits the images are read under: 2²⁰ pixels, 4096 per side, 64 MiB of memory, the
/// defaults otherwise.
pub fn limits() -> Limits {
    Limits { max_pixels: 1 << 20, max_side: 1 << 12, max_memory: 64 << 20, ..Limits::default() }
}

/// Decodes `data` as an image file named `fuzz.png` (the format is recognised from the bytes; its
/// values become linear as the scene's default `colorspace = "auto"` says). A read must either fail with an error naming the file, or give an image
/// within [`limits`] whose texels are finite and whose memory was charged; anything else is
/// described in the `Err`. A panic inside a decoder is caught by `decode` (and reported as an
/// error); `plugins/tests/no_panics.rs` checks that none happens.
pub fn check_bytes(data: &[u8]) -> Result<(), String> {
    let limits = limits();
    let options = LoadOptions { limits, ..LoadOptions::default() };
    let ctx = LoadContext::new(std::path::Path::new("."), &options);
    let image = match decode(data, "fuzz.png", ColorSpace::Auto, &ctx) {
        Ok(image) => image,
        Err(e) if e.where_().is_some_and(|w| w.starts_with("fuzz.png")) => return Ok(()),
        Err(e) => return Err(format!("an error that does not name the file: {}", e.report())),
    };
    let (w, h) = image.size();
    if w == 0 || h == 0 || w.max(h) as u64 > u64::from(limits.max_side) || (w * h) as u64 > limits.max_pixels {
        return Err(format!("a {w}×{h} image read under limits of {} pixels, {} per side", limits.max_pixels, limits.max_side));
    }
    if image.memory_bytes() as u64 > ctx.charged() || ctx.charged() > limits.max_memory {
        return Err(format!("{} bytes of texels, {} bytes charged, {} allowed", image.memory_bytes(), ctx.charged(), limits.max_memory));
    }
    for y in 0..h {
        for x in 0..w {
            let uv = DVec2::new((x as f64 + 0.5) / w as f64, 1.0 - (y as f64 + 0.5) / h as f64);
            let c = image.lookup(uv, [Wrap::Clamp; 2], Filter::Nearest);
            if !c.is_finite() || c.min_element() < 0.0 {
                return Err(format!("texel ({x}, {y}) of {w}×{h} is {c}"));
            }
        }
    }
    Ok(())
}
