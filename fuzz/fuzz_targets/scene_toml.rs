//! Arbitrary bytes as a TOML scene: loading must return a scene or a located error, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let registry = raylab_plugins::registry();
        let _ = raylab::load::loader::load_str(&registry, "fuzz.toml", text, std::path::Path::new("."), &Default::default());
    }
});
