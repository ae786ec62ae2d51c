//! Arbitrary bytes as an OBJ file read in small chunks (the parallel reader's joins: relative
//! indices, `usemtl`, deferred polygons and error lines across chunk ends) must give exactly what
//! the whole file read as one chunk gives: the same mesh, or the same located error. The first
//! byte picks the chunk size (1–64 bytes). Needs the `mesh` feature.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&size, bytes)) = data.split_first() else { return };
    let options = raylab::LoadOptions::default();
    let ctx = raylab::LoadContext::new(std::path::Path::new("."), &options);
    let src = raylab::Source::new("fuzz.toml", String::new());
    let loc = raylab::param::error::Loc::new(&src, 0..0);
    let path = std::path::Path::new("fuzz.obj");
    let read = |chunk: usize| {
        let r = raylab_plugins::mesh::obj::read_in_chunks(&ctx, "fuzz.obj", path, bytes, false, &loc, chunk);
        let warnings: Vec<String> = ctx.take_warnings().iter().map(|w| w.report()).collect();
        (r.map(|d| format!("{d:?}")).map_err(|e| e.report()), warnings)
    };
    let whole = read(usize::MAX);
    let chunked = read(usize::from(size % 64) + 1);
    assert_eq!(whole, chunked, "chunks of {} bytes", usize::from(size % 64) + 1);
});
