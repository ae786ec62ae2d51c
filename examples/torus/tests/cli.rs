//! The `raylab-torus` binary: the documented command renders the torus scene, and the crate's
//! plugins appear beside the built-in ones in `raylab-torus plugins`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_raylab-torus")).args(args).current_dir(repo()).output().expect("raylab-torus runs")
}

#[test]
fn the_documented_command_renders_the_torus_scene() {
    let out_dir = std::env::temp_dir().join(format!("raylab-torus-cli-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    let png = out_dir.join("torus.png");
    // The README's command, smaller so the test is quick.
    let out = run(&[
        "render",
        "examples/torus/scenes/torus.toml",
        "-o",
        png.to_str().unwrap(),
        "--width",
        "80",
        "--height",
        "60",
        "--spp",
        "1",
        "-q",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).starts_with(&format!("wrote {} (80×60", png.display())));
    assert!(std::fs::metadata(&png).unwrap().len() > 0);
    std::fs::remove_dir_all(&out_dir).unwrap();
}

#[test]
fn plugins_lists_the_crates_types_beside_the_built_ins() {
    let out = run(&["plugins"]);
    let text = String::from_utf8_lossy(&out.stdout);
    for ty in ["torus", "panel", "rect", "ao", "sphere", "phong"] {
        assert!(text.contains(&format!("\n  {ty}  — ")), "missing {ty} in:\n{text}");
    }
    assert!(text.contains("major_radius") && text.contains("samples"));
}

/// The crate's one-file image writer: `-o NAME.ppm` writes binary PPM whose pixels are the PNG
/// path's 8-bit conversion of the same render, and `plugins` lists the format.
#[test]
fn the_registered_ppm_writer_writes_the_render() {
    let out_dir = std::env::temp_dir().join(format!("raylab-torus-ppm-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    let ppm = out_dir.join("torus.ppm");
    let args =
        ["render", "examples/torus/scenes/torus.toml", "-o", ppm.to_str().unwrap(), "--width", "40", "--height", "30", "--spp", "1", "-q"];
    let out = run(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bytes = std::fs::read(&ppm).unwrap();
    let header = b"P6\n40 30\n255\n";
    assert_eq!(&bytes[..header.len()], header);

    let opts = raylab::LoadOptions {
        overrides: raylab::load::context::Overrides { width: Some(40), height: Some(30), spp: Some(1), ..Default::default() },
        ..Default::default()
    };
    let job = raylab::load::loader::load_file(&raylab_torus::registry(), &repo().join("examples/torus/scenes/torus.toml"), &opts).unwrap();
    let film = raylab::render::render(&job, &raylab::render::RenderOptions::default(), &|_, _| {}).unwrap().film;
    assert_eq!(&bytes[header.len()..], raylab::image::output::to_rgb8(&film, job.settings.encoding, None));

    let text = String::from_utf8_lossy(&run(&["plugins"]).stdout).into_owned();
    assert!(text.contains("\n  .ppm  — binary PPM"), "{text}");
    std::fs::remove_dir_all(&out_dir).unwrap();
}
