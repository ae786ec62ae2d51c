//! Arbitrary rays against arbitrary built-in shapes: no panic, and every hit passes
//! `raylab::geometry::testing::check_hit` against the shape's exact surface (`raylab_plugins::shapes::exact`):
//! on the surface, on the ray, closest first, normals right. The decoding lives in
//! `raylab_plugins::shapes::fuzz` so that tests/fuzz_corpus.rs replays the corpus the same way.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(v) = raylab_plugins::shapes::fuzz::check_bytes(data) {
        panic!("{v}");
    }
});
