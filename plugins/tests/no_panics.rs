//! Mesh files never make raylab panic, not even inside a dependency whose panic raylab catches
//! (the message would still reach the user's terminal, and it means a check is missing). Every
//! input of the mesh fuzz corpora (real and malformed models, and every input that once failed)
//! is read with a panic hook that records any panic. One test in its own binary: the hook is
//! process-wide.
#![cfg(feature = "mesh")]

use std::path::Path;
use std::sync::Mutex;

static PANICS: Mutex<Vec<String>> = Mutex::new(Vec::new());

#[test]
fn no_mesh_file_in_the_fuzz_corpora_panics_even_when_caught() {
    std::panic::set_hook(Box::new(|info| PANICS.lock().unwrap().push(info.to_string())));
    let options = raylab::input::context::LoadOptions::default();
    let ctx = raylab::LoadContext::new(Path::new("."), &options);
    let mut report = Vec::new();
    let mut count = 0;
    for (target, ext) in [("mesh_obj", "obj"), ("mesh_gltf", "gltf")] {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus").join(target);
        let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        for f in files {
            let bytes = std::fs::read(&f).unwrap();
            let result =
                std::panic::catch_unwind(|| raylab_plugins::mesh::mesh_from_bytes(&ctx, "fuzz", ext, &bytes).map(|m| m.triangle_count()));
            count += 1;
            let panics = std::mem::take(&mut *PANICS.lock().unwrap());
            if !panics.is_empty() || result.is_err() {
                report.push(format!("{}: {}", f.display(), panics.join("; ")));
            }
        }
    }
    let _ = std::panic::take_hook();
    assert!(count >= 80, "only {count} corpus files");
    assert!(report.is_empty(), "{} of {count} files panicked:\n{}", report.len(), report.join("\n"));
}
