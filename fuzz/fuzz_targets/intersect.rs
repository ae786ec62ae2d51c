//! Arbitrary rays against arbitrary registered shapes: no panic, and every hit passes
//! `raylab::geometry::testing::check_hit` against the shape's exact surface (the oracle each shape
//! registers with its sampler, `raylab::geometry::samples`): on the surface, on the ray, closest
//! first, normals right. The decoding is `raylab::geometry::samples::check_bytes` over the built-in
//! registry's samplers (`raylab_plugins::shapes::fuzz`), so that tests/fuzz_corpus.rs replays the
//! corpus the same way and a shape registered with its sampler is fuzzed from that line.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(v) = raylab_plugins::shapes::fuzz::check_bytes(data) {
        panic!("{v}");
    }
});
