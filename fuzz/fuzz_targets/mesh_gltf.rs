//! Arbitrary bytes as a mesh file (glTF, JSON or binary): reading, triangulating and indexing must
//! give a mesh or a located error, never panic. Needs the `mesh` and `bvh` features.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let options = raylab::LoadOptions::default();
    let ctx = raylab::LoadContext::new(std::path::Path::new("."), &options);
    let _ = raylab_plugins::mesh::mesh_from_bytes(&ctx, "fuzz.gltf", "gltf", data);
});
