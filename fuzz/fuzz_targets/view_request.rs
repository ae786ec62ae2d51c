//! Arbitrary bytes as a request to the live view: the first byte picks the parser (a request's
//! line and headers; the page's settings, applied to a scene and loaded; an explain query against
//! a small rendered scene), the rest is its input; never a panic. The checks live in
//! `raylab::view::http::fuzz_request` so that tests/fuzz_corpus.rs replays the corpus the same way.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::LazyLock;

const SCENE: &str = include_str!("../../tests/assets/view-fuzz.toml");

struct Fixture {
    registry: raylab::Registry,
    job: raylab::render::RenderJob,
}

static FIXTURE: LazyLock<Fixture> = LazyLock::new(|| {
    let registry = raylab_plugins::registry();
    let job = raylab::load::loader::load_str(&registry, "view-fuzz.toml", SCENE, std::path::Path::new("."), &Default::default())
        .unwrap_or_else(|e| panic!("{}", e.report()));
    Fixture { registry, job }
});

fuzz_target!(|data: &[u8]| {
    let f = &*FIXTURE;
    let load = |o: &raylab::LoadOptions| raylab::load::loader::load_str(&f.registry, "view-fuzz.toml", SCENE, std::path::Path::new("."), o);
    if let Err(e) = raylab::view::http::fuzz_request(data, &f.registry, &Default::default(), &load, &f.job) {
        panic!("{e}");
    }
});
