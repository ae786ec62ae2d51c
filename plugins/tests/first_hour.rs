//! What a newcomer tries in the first hour does what they expect: flags that say what they do,
//! a model file rendered by itself, a dark scene that says why.

use std::path::Path;

mod common;
use common::{raylab, repo, temp_dir, text};

fn png_size(path: &Path) -> (u32, u32) {
    let img = image::open(path).unwrap();
    (img.width(), img.height())
}

#[test]
fn width_or_height_alone_keeps_the_scenes_aspect_ratio() {
    let dir = temp_dir("aspect");
    let scene = repo().join("scenes/dozen.toml"); // 800×600
    for (flag, value, expected) in [("--width", "80", (80, 60)), ("--height", "30", (40, 30)), ("--width", "81", (81, 61))] {
        let out = raylab(&dir, &["render", scene.to_str().unwrap(), "-o", "a.png", flag, value, "-q"]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        assert_eq!(png_size(&dir.join("a.png")), expected, "{flag} {value}");
    }
    // Both given: exactly those.
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "-o", "b.png", "--width", "50", "--height", "20", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(png_size(&dir.join("b.png")), (50, 20));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_size_set_by_a_flag_is_reported_at_the_flag() {
    let dir = temp_dir("size-flag");
    let scene = repo().join("scenes/dozen.toml");
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "--width", "100000"]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(err.starts_with("error: --width:1:1: image width 100000 is outside"), "{err}");
    assert!(!err.contains("dozen.toml"), "the scene's own width is not the culprit: {err}");
    // The height the width implies is the width flag's doing too.
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "--width", "30000", "--max-pixels", "1000"]);
    let err = text(&out.stderr);
    assert!(err.starts_with("error: --width:1:1: image of 30000×22500"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn set_takes_a_bare_string_and_suggests_the_nearest_key() {
    let dir = temp_dir("set");
    let scene = repo().join("scenes/report-later.xml");
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "-o", "a.png", "--width", "40", "--set", "ambient=first_hit"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("ambient at the first hit"), "{}", text(&out.stdout));
    // Quoted, as TOML: the same.
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "-o", "b.png", "--width", "40", "--set", "ambient=\"first_hit\""]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(std::fs::read(dir.join("a.png")).unwrap(), std::fs::read(dir.join("b.png")).unwrap());
    // A bare word where a number is expected is a type error, not a TOML syntax error.
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "--set", "prune_threshold=small"]);
    let err = text(&out.stderr);
    assert!(!out.status.success() && !err.contains("expected a TOML value"), "{err}");
    // A misspelt key: the nearest one, and the caret under the key.
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "--set", "prune_treshold=0.01"]);
    let err = text(&out.stderr);
    assert!(err.contains("has no parameter `prune_treshold`") && err.contains("did you mean `prune_threshold`?"), "{err}");
    assert!(err.contains("| ^^^^^^^^^^^^^^\n"), "the caret marks the key: {err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_scene_with_no_light_warns() {
    let dir = temp_dir("no-light");
    std::fs::write(dir.join("dark.toml"), "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\n[[object]]\ntype = \"sphere\"\n")
        .unwrap();
    let out = raylab(&dir, &["render", "dark.toml", "-o", "d.png", "--width", "20", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert!(err.contains("warning: dark.toml: the scene has no light and nothing in it emits"), "{err}");
    // An emitting object lights a scene by itself: no warning.
    std::fs::write(
        dir.join("glow.toml"),
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\n[[object]]\ntype = \"sphere\"\nmaterial = { emission = 1 }\n",
    )
    .unwrap();
    let out = raylab(&dir, &["render", "glow.toml", "-o", "g.png", "--width", "20", "-q"]);
    assert!(out.status.success() && !text(&out.stderr).contains("no light"), "{}", text(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn camera_fit_frames_every_bounded_object() {
    let dir = temp_dir("fit");
    // A sphere far off the camera's view: fitted, it fills the middle of the image.
    std::fs::write(
        dir.join("off.toml"),
        "background = 0\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\n[[object]]\ntype = \"sphere\"\ncenter = [40, 0, 0]\nmaterial = { emission = 1, kd = 0 }\n",
    )
    .unwrap();
    let lit = |file: &str| {
        let img = image::open(dir.join(file)).unwrap().to_rgb8();
        let (w, h) = img.dimensions();
        (img.get_pixel(w / 2, h / 2)[0], img.pixels().filter(|p| p[0] > 0).count())
    };
    let out = raylab(&dir, &["render", "off.toml", "-o", "a.png", "--width", "40", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(lit("a.png"), (0, 0), "the sphere is out of view");
    let out = raylab(&dir, &["render", "off.toml", "-o", "b.png", "--width", "40", "--camera", "fit", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (centre, pixels) = lit("b.png");
    assert!(centre > 200 && pixels > 100 && pixels < 40 * 30, "fitted: centre {centre}, {pixels} lit pixels");
    std::fs::remove_dir_all(dir).unwrap();
}

#[cfg(feature = "mesh")]
#[test]
fn an_obj_file_is_a_scene_framed_and_lit_by_default() {
    let dir = temp_dir("obj");
    let knot = repo().join("scenes/assets/knot.obj");
    let out = raylab(&dir, &["render", knot.to_str().unwrap(), "-o", "k.png", "--width", "80"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert_eq!(err.matches("warning:").count(), 1, "{err}");
    assert!(err.contains("knot.obj: the file has no lights: it is lit by a default sun and a uniform sky"), "{err}");
    let stdout = text(&out.stdout);
    assert!(stdout.starts_with("wrote k.png (80×60, adaptive AA"), "anti-aliased as every model scene: {stdout}");
    // Framed: the knot covers the middle and leaves a border of background.
    let img = image::open(dir.join("k.png")).unwrap().to_rgb8();
    let background = *img.get_pixel(0, 0);
    let covered = img.pixels().filter(|p| **p != background).count();
    assert!(covered > 80 * 60 / 10, "the model fills the frame: {covered} pixels");
    for x in 0..80 {
        assert_eq!(*img.get_pixel(x, 0), background, "the model is not cropped at the top");
        assert_eq!(*img.get_pixel(x, 59), background, "the model is not cropped at the bottom");
    }
    // `trace` takes it too.
    let out = raylab(&dir, &["trace", knot.to_str().unwrap(), "--pixel", "400,300"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

#[cfg(feature = "mesh")]
#[test]
fn a_gltf_needing_an_unknown_extension_is_unsupported_not_invalid() {
    let dir = temp_dir("meshopt");
    // A valid file (the meshopt-compressed duck's header, without its buffers) that requires
    // extensions raylab does not read.
    std::fs::write(
        dir.join("duck.gltf"),
        r#"{"asset": {"version": "2.0"}, "extensionsUsed": ["EXT_meshopt_compression", "KHR_mesh_quantization"],
            "extensionsRequired": ["EXT_meshopt_compression", "KHR_mesh_quantization"], "scenes": [{"nodes": []}], "scene": 0}"#,
    )
    .unwrap();
    let out = raylab(&dir, &["render", "duck.gltf"]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.starts_with(
            "error: duck.gltf: unsupported glTF extension: the file requires EXT_meshopt_compression and KHR_mesh_quantization"
        ),
        "{err}"
    );
    assert!(!err.contains("invalid"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// `--resume` says what it continues, and the partial image an interrupted render left beside
/// its target is removed once the target is written (and the removal said).
#[cfg(feature = "exr")]
#[test]
fn a_resume_says_what_it_resumed_and_cleans_up() {
    let dir = temp_dir("resume");
    let scene = repo().join("scenes/quality.toml");
    let s = scene.to_str().unwrap();
    let size = ["--width", "300", "--spp", "2", "--threads", "2"];
    let mut said = None;
    for attempt in 0..4u64 {
        let _ = std::fs::remove_file(dir.join("out.png"));
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
            .args([&["render", s, "-o", "out.png", "-q", "--checkpoint", "state.exr", "--checkpoint-every", "0.05"][..], &size].concat())
            .current_dir(&dir)
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        while !dir.join("state.exr").exists() && start.elapsed().as_secs() < 60 && child.try_wait().unwrap().is_none() {
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        std::thread::sleep(std::time::Duration::from_millis(20 >> attempt));
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        if dir.join("out.png").exists() {
            continue; // finished before the kill
        }
        // As Ctrl-C leaves it: the image so far beside the target.
        std::fs::write(dir.join("out.partial.png"), b"the image so far").unwrap();
        let out = raylab(&dir, &["render", "--resume", "state.exr"]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        said = Some(text(&out.stderr));
        break;
    }
    let err = said.expect("no attempt killed the render part-way");
    let first = err.lines().next().unwrap_or("");
    assert!(
        first.starts_with("resuming state.exr: ") && first.contains(" samples done (") && first.contains(" pixels still to finish"),
        "{err}"
    );
    assert!(err.contains("out.partial.png, the image of an interrupted render of "), "{err}");
    assert!(!dir.join("out.partial.png").exists() && !dir.join("state.exr").exists() && dir.join("out.png").exists());
    std::fs::remove_dir_all(dir).unwrap();
}

/// `merge --allow-partial` merges an incomplete set of parts, and says how incomplete.
#[cfg(feature = "exr")]
#[test]
fn allow_partial_warns_of_what_is_missing() {
    let dir = temp_dir("allow-partial");
    let scene = repo().join("scenes/dozen.toml");
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "--width", "40", "--tile", "0/2", "-o", "part-0.exr", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = raylab(&dir, &["merge", "part-0.exr", "-o", "m.png"]);
    assert!(!out.status.success(), "an incomplete set is refused without --allow-partial");
    let out = raylab(&dir, &["merge", "part-0.exr", "-o", "m.png", "--allow-partial"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert!(err.starts_with("warning: --allow-partial: ") && err.contains(" of 1200 pixels lack samples"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}
