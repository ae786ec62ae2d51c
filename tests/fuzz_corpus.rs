//! Replays every fuzz corpus file through its fuzz target's code path (no libFuzzer needed), so
//! inputs that once crashed stay fixed. Fuzz for longer with `RUSTC_BOOTSTRAP=1 cargo fuzz run <target>`.

use std::path::Path;

fn corpus(target: &str) -> Vec<std::path::PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus").join(target);
    let mut files: Vec<_> =
        std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())).map(|e| e.unwrap().path()).collect();
    files.sort();
    assert!(!files.is_empty(), "empty corpus for {target}");
    files
}

#[test]
fn scene_toml_corpus_loads_or_fails_cleanly() {
    let registry = raylab_plugins::registry();
    for f in corpus("scene_toml") {
        let data = std::fs::read(&f).unwrap();
        if let Ok(text) = std::str::from_utf8(&data)
            && let Err(e) = raylab::load::loader::load_str(&registry, "fuzz.toml", text, Path::new("."), &Default::default())
        {
            assert!(e.where_().is_some(), "{}: error without a location: {e}", f.display());
        }
    }
}

#[test]
fn scene_xml_corpus_loads_or_fails_cleanly() {
    let registry = raylab_plugins::registry();
    let options = raylab::LoadOptions::default();
    let ctx = raylab::LoadContext::new(Path::new("."), &options);
    for f in corpus("scene_xml") {
        let data = std::fs::read(&f).unwrap();
        let result = raylab_plugins::formats::report_xml::read(Path::new("fuzz.xml"), &data, &ctx)
            .and_then(|desc| raylab::load::loader::build(&registry, &desc, &ctx));
        if let Err(e) = result {
            assert!(e.where_().is_some(), "{}: error without a location: {e}", f.display());
        }
    }
}

#[test]
fn intersect_corpus_keeps_every_geometric_contract() {
    for f in corpus("intersect") {
        let data = std::fs::read(&f).unwrap();
        if let Err(v) = raylab_plugins::shapes::fuzz::check_bytes(&data) {
            panic!("{}: {v}", f.display());
        }
    }
}

#[cfg(feature = "exr")]
#[test]
fn partial_exr_corpus_reads_or_fails_cleanly() {
    for f in corpus("partial_exr") {
        let data = std::fs::read(&f).unwrap();
        match raylab::image::partial::read_partial(&data, "fuzz.exr", 1 << 20) {
            Ok((sums, info)) => {
                let part = raylab::render::share::Part { name: "fuzz.exr".into(), sums, fingerprint: info.fingerprint };
                let whole = raylab::render::share::merge(&[part], true).unwrap();
                whole.film().unwrap();
            }
            Err(e) => assert!(e.0.starts_with("fuzz.exr: "), "{}: {e}", f.display()),
        }
    }
}

/// Images whose layers `tonemap`, `denoise` and `--spp-map` read (PFM, OpenEXR with layers).
#[test]
fn image_layer_corpus_reads_or_fails_cleanly() {
    for f in corpus("image_layer") {
        let data = std::fs::read(&f).unwrap();
        if let Err(v) = raylab::image::tonemap::fuzz_read_layers(&data) {
            panic!("{}: {v}", f.display());
        }
    }
}

#[test]
fn texture_image_corpus_decodes_within_the_limits_or_fails_cleanly() {
    for f in corpus("texture_image") {
        let data = std::fs::read(&f).unwrap();
        if let Err(v) = raylab_plugins::textures::fuzz::check_bytes(&data) {
            panic!("{}: {v}", f.display());
        }
    }
}

/// The live view's request parsers: a request's head, the page's settings (applied and loaded),
/// explain queries (`raylab::view::http::fuzz_request`, as the `view_request` target runs them).
#[cfg(feature = "view")]
#[test]
fn view_request_corpus_parses_or_fails_cleanly() {
    let registry = raylab_plugins::registry();
    let scene = include_str!("assets/view-fuzz.toml");
    let load = |o: &raylab::LoadOptions| raylab::load::loader::load_str(&registry, "view-fuzz.toml", scene, Path::new("."), o);
    let job = load(&Default::default()).unwrap_or_else(|e| panic!("{}", e.report()));
    for f in corpus("view_request") {
        let data = std::fs::read(&f).unwrap();
        if let Err(e) = raylab::view::http::fuzz_request(&data, &registry, &Default::default(), &load, &job) {
            panic!("{}: {e}", f.display());
        }
    }
}

/// Checkpoints, read as `raylab render --resume` reads them and continued
/// (`raylab::cli::fuzz_checkpoint`, as the `checkpoint` target runs them).
#[cfg(feature = "exr")]
#[test]
fn checkpoint_corpus_resumes_or_fails_cleanly() {
    let registry = raylab_plugins::registry();
    let scene = include_str!("assets/view-fuzz.toml");
    let jobs: Vec<_> = raylab::cli::checkpoint_fuzz_scenes(scene)
        .iter()
        .map(|text| {
            raylab::load::loader::load_str(&registry, "view-fuzz.toml", text, Path::new("."), &Default::default())
                .unwrap_or_else(|e| panic!("{}", e.report()))
        })
        .collect();
    for f in corpus("checkpoint") {
        let data = std::fs::read(&f).unwrap();
        if let Err(e) = raylab::cli::fuzz_checkpoint(&data, &jobs) {
            panic!("{}: {e}", f.display());
        }
    }
}
