//! Arbitrary bytes as a partial image (`raylab merge`, `raylab render --resume`): reading must
//! give the sums or an error, never panic, hang or allocate beyond the pixel limit; what reads
//! merges and becomes a film. Needs the `exr` feature.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok((sums, info)) = raylab::image::partial::read_partial(data, "fuzz.exr", 1 << 20) {
        let part = raylab::render::share::Part { name: "fuzz.exr".into(), sums, fingerprint: info.fingerprint };
        if let Ok(whole) = raylab::render::share::merge(&[part], true) {
            let _ = whole.film();
            let _ = whole.aovs();
        }
    }
});
