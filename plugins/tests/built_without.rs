//! A build without a feature names the feature to add, for everything the feature would add:
//! the mechanism (a plugin crate declares what its features would add, `Registry::add_absent`)
//! in any build, and the built-in `raylab`'s own sentences in a build without the features
//! (`cargo test -p raylab-plugins --no-default-features --test built_without`).

use raylab::load::context::LoadOptions;
use raylab::load::registry::Absent;
use std::path::{Path, PathBuf};
use std::process::Command;

#[allow(dead_code)]
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("raylab-built-without-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A type or an extension a registry declares absent is refused with the feature's name and how
/// to build it in, not as unknown.
#[test]
fn an_absent_type_or_extension_names_its_feature() {
    let mut registry = raylab_plugins::registry();
    registry.add_absent(Absent { name: "blob", feature: "blobs" });
    registry.add_absent(Absent { name: "blb", feature: "blobs" });
    let dir = temp("mechanism");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\n[[object]]\ntype = \"blob\"\n").unwrap();
    let Err(e) = raylab::load::loader::load_file(&registry, &scene, &LoadOptions::default()) else { panic!("a blob loaded") };
    let report = e.report();
    assert!(report.contains("object type \"blob\" needs the `blobs` feature"), "{report}");
    assert!(report.contains("built without the `blobs` feature: rebuild with `--features blobs`"), "{report}");
    assert!(report.contains(":6:"), "located at the type: {report}");
    let model = dir.join("m.blb");
    std::fs::write(&model, "blob").unwrap();
    let Err(e) = raylab::load::loader::load_file(&registry, &model, &LoadOptions::default()) else { panic!("a .blb loaded") };
    assert!(e.report().contains("reading \".blb\" files needs the `blobs` feature"), "{}", e.report());
    std::fs::remove_dir_all(dir).unwrap();
}

/// `raylab ARGS`: (success, stderr).
#[allow(dead_code)]
fn raylab(args: &[&str], dir: &Path) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_raylab")).args(args).current_dir(dir).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The sentence every such error ends with.
#[allow(dead_code)]
fn names(stderr: &str, feature: &str) -> bool {
    stderr.contains(&format!("built without the `{feature}` feature: rebuild with `--features {feature}`"))
        && stderr.contains("cargo install --path plugins --features mesh,bvh,exr")
}

#[cfg(not(feature = "mesh"))]
#[test]
fn without_mesh_a_model_file_or_a_mesh_object_names_the_feature() {
    let dir = temp("mesh");
    for scene in ["scenes/assets/knot.obj", "scenes/assets/BoxTextured.glb", "scenes/first-mesh.toml"] {
        let (ok, err) = raylab(&["render", repo().join(scene).to_str().unwrap(), "-o", "x.png"], &dir);
        assert!(!ok && names(&err, "mesh"), "{scene}: {err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[cfg(not(feature = "exr"))]
#[test]
fn without_exr_every_exr_input_and_output_names_the_feature() {
    let dir = temp("exr");
    let first = repo().join("scenes/first.toml");
    let s = first.to_str().unwrap();
    std::fs::write(dir.join("in.exr"), "not read").unwrap();
    for args in [
        vec!["render", s, "-o", "x.exr", "--width", "8"],
        vec!["render", s, "-o", "x.exr", "--tile", "0/2", "--width", "8"],
        vec!["render", s, "-o", "x.png", "--checkpoint", "state.exr", "--width", "8"],
        vec!["merge", "in.exr", "-o", "x.png"],
        vec!["tonemap", "in.exr", "-o", "x.png"],
    ] {
        let (ok, err) = raylab(&args, &dir);
        assert!(!ok && names(&err, "exr"), "{args:?}: {err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[cfg(not(feature = "bvh"))]
#[test]
fn without_bvh_asking_for_one_names_the_feature() {
    let dir = temp("bvh");
    let (ok, err) =
        raylab(&["render", repo().join("scenes/first.toml").to_str().unwrap(), "-o", "x.png", "--accel", "bvh", "--width", "8"], &dir);
    assert!(!ok && names(&err, "bvh"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[cfg(not(feature = "view"))]
#[test]
fn without_view_the_live_view_names_the_feature() {
    let dir = temp("view");
    let (ok, err) = raylab(&["view", "scenes/showcase.toml", "--port", "0"], &dir);
    assert!(!ok && names(&err, "view"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}
