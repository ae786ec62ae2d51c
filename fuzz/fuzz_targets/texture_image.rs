//! Arbitrary bytes as a texture file (PNG, JPEG, Radiance .hdr, OpenEXR) through the decoder the
//! scene loader uses: an error naming the file, or an image within the limits with finite texels
//! whose memory was charged; never a panic (not even one the decoder's guard catches: libFuzzer's
//! panic hook aborts first), an abort, a hang or an allocation beyond the budget (run with
//! `-malloc_limit_mb=64`). The checks live in `raylab_plugins::textures::fuzz` so that
//! tests/fuzz_corpus.rs replays the corpus the same way. Needs the `exr` feature.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(v) = raylab_plugins::textures::fuzz::check_bytes(data) {
        panic!("{v}");
    }
});
