//! Arbitrary bytes as a checkpoint (`raylab render --resume FILE`): read as the command reads one
//! (a partial image that says how to continue, in a command that still parses), then continued
//! with a small scene's render (adaptive, stratified, or stratified to an error target: the job
//! whose fingerprint the file gives, else the first); never a panic, a hang or an unfinished or
//! non-finite image. The checks live in `raylab::cli::fuzz_checkpoint` so that
//! tests/fuzz_corpus.rs replays the corpus the same way. Needs the `exr` feature.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::LazyLock;

const SCENE: &str = include_str!("../../tests/assets/view-fuzz.toml");

static JOBS: LazyLock<Vec<raylab::RenderJob>> = LazyLock::new(|| {
    let registry = raylab_plugins::registry();
    raylab::cli::checkpoint_fuzz_scenes(SCENE)
        .iter()
        .map(|text| {
            raylab::load::loader::load_str(&registry, "view-fuzz.toml", text, std::path::Path::new("."), &Default::default())
                .unwrap_or_else(|e| panic!("{}", e.report()))
        })
        .collect()
});

fuzz_target!(|data: &[u8]| {
    if let Err(e) = raylab::cli::fuzz_checkpoint(data, &JOBS) {
        panic!("{e}");
    }
});
