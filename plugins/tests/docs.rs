//! Documentation generated from the code stays in step with it.
#![cfg(all(feature = "mesh", feature = "exr"))]

use std::path::Path;

/// docs/plugins.md documents every built-in plugin, the feature-gated `mesh` too: it is compared
/// when that feature is on (as in CI's `--all-features`).
#[test]
fn docs_plugins_md_is_the_output_of_raylab_plugins_markdown() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raylab")).args(["plugins", "--markdown"]).output().unwrap();
    assert!(out.status.success());
    let generated = String::from_utf8(out.stdout).unwrap();
    let committed = std::fs::read_to_string(root.join("docs/plugins.md")).unwrap_or_default();
    assert!(
        committed == generated,
        "docs/plugins.md is out of date: run `cargo run --features mesh,exr -- plugins --markdown > docs/plugins.md`"
    );
}
