//! Arbitrary bytes as a scene in the report's XML style: reading and building must return a scene
//! or a located error, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let registry = raylab_plugins::registry();
    let options = raylab::LoadOptions::default();
    let ctx = raylab::LoadContext::new(std::path::Path::new("."), &options);
    if let Ok(desc) = raylab_plugins::formats::report_xml::read(std::path::Path::new("fuzz.xml"), data, &ctx) {
        let _ = raylab::load::loader::build(&registry, &desc, &ctx);
    }
});
