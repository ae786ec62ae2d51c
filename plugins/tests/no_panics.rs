//! Mesh and texture files never make raylab panic, not even inside a dependency whose panic
//! raylab catches (the message would still reach the user's terminal, and it means a check is
//! missing). Every input of the mesh and texture fuzz corpora (real and malformed files, and every
//! input that once failed) is read with a panic hook that records any panic. One test in its own
//! binary: the hook is process-wide.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

static PANICS: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// The files of fuzz target `target`'s corpus, sorted.
fn corpus(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus").join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    files
}

#[test]
fn no_mesh_or_texture_file_in_the_fuzz_corpora_panics_even_when_caught() {
    std::panic::set_hook(Box::new(|info| PANICS.lock().unwrap().push(info.to_string())));
    let mut report = Vec::new();
    let mut count = 0;
    let mut check = |f: &Path, read: &dyn Fn(&[u8])| {
        let bytes = std::fs::read(f).unwrap();
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read(&bytes)));
        count += 1;
        let panics = std::mem::take(&mut *PANICS.lock().unwrap());
        if !panics.is_empty() || result.is_err() {
            report.push(format!("{}: {}", f.display(), panics.join("; ")));
        }
    };
    #[cfg(feature = "mesh")]
    {
        let options = raylab::load::context::LoadOptions::default();
        let ctx = raylab::LoadContext::new(Path::new("."), &options);
        for (target, ext) in [("mesh_obj", "obj"), ("mesh_gltf", "gltf")] {
            for f in corpus(target) {
                check(&f, &|bytes| {
                    let _ = raylab_plugins::mesh::mesh_from_bytes(&ctx, "fuzz", ext, bytes).map(|m| m.triangle_count());
                });
            }
        }
    }
    for f in corpus("texture_image") {
        check(&f, &|bytes| {
            let _ = raylab_plugins::textures::fuzz::check_bytes(bytes);
        });
    }
    let _ = std::panic::take_hook();
    let least = if cfg!(feature = "mesh") { 120 } else { 40 };
    assert!(count >= least, "only {count} corpus files");
    assert!(report.is_empty(), "{} of {count} files panicked:\n{}", report.len(), report.join("\n"));
}
