//! Arbitrary bytes as an image whose layers raylab reads (`raylab tonemap --layer`, `raylab
//! denoise`, `render --spp-map`, reference images): as a PFM and as an OpenEXR file, every layer,
//! a film that fills its size or an error, never a panic or an allocation past the limits
//! (`raylab::image::tonemap::fuzz_read_layers`, which tests/fuzz_corpus.rs replays). Needs the
//! `exr` feature.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(v) = raylab::image::tonemap::fuzz_read_layers(data) {
        panic!("{v}");
    }
});
