//! The `raylab` binary, run as a user would.

use std::path::Path;

mod common;
use common::{denoiser_here, displayed_rmse, raylab, repo, temp_dir, text};

#[test]
fn no_arguments_renders_the_default_scene_to_render_png() {
    let dir = temp_dir("default");
    let out = raylab(&dir, &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.starts_with("wrote render.png (800×600, adaptive AA (threshold 0.02, depth 3)"), "{stdout}");
    assert!(stdout.contains("rays/s") && stdout.contains("trace "), "{stdout}");
    assert!(stdout.contains(", 0 non-finite samples"), "the summary states the non-finite count: {stdout}");
    let img = image::open(dir.join("render.png")).unwrap();
    assert_eq!((img.width(), img.height()), (800, 600));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn render_writes_png_and_jpeg_with_a_grid() {
    let dir = temp_dir("grid");
    let scene = repo().join("scenes/report-two-colour.toml");
    let out = raylab(
        &dir,
        &[
            "render",
            scene.to_str().unwrap(),
            "-o",
            "g.png",
            "--width",
            "50",
            "--height",
            "50",
            "--grid",
            "10",
            "--grid-color",
            "255,0,0",
            "-q",
            "--stats",
        ],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("camera rays"), "--stats prints the counters");
    let img = image::open(dir.join("g.png")).unwrap().to_rgb8();
    assert_eq!(img.get_pixel(20, 7).0, [255, 0, 0], "grid column");
    assert_ne!(img.get_pixel(25, 25).0, [255, 0, 0], "not on the grid");
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "-o", "g.jpg", "--width", "40", "--height", "40", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(image::open(dir.join("g.jpg")).unwrap().width(), 40);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn scene_errors_exit_1_and_name_the_location() {
    let dir = temp_dir("errors");
    std::fs::write(
        dir.join("bad.toml"),
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"sphere\"\nradius = \"x\"\n",
    )
    .unwrap();
    let out = raylab(&dir, &["render", "bad.toml", "-q"]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.contains("bad.toml:6:10:") && err.contains("expected a number"), "{err}");
    assert!(!dir.join("render.png").exists(), "no image for a failed load");
    let out = raylab(&dir, &["render", "missing.toml"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("missing.toml: cannot read scene"));
    let out = raylab(&dir, &["render", "bad.toml", "-o", "x.bmp"]);
    assert!(text(&out.stderr).contains("unknown image type"));
    let out = raylab(&dir, &["render", "--no-such-flag"]);
    assert_eq!(out.status.code(), Some(2), "usage errors exit 2");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn trace_explains_a_pixel_as_text_and_json() {
    let scene = repo().join("scenes/showcase.toml");
    let out = raylab(&repo(), &["trace", scene.to_str().unwrap(), "--pixel", "330,280"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let t = text(&out.stdout);
    for needle in ["camera ray", "hit glass ball", "refraction ray", "light key", "diffuse", "sample colour"] {
        assert!(t.contains(needle), "missing {needle:?} in:\n{t}");
    }
    let out = raylab(&repo(), &["trace", scene.to_str().unwrap(), "--pixel", "330,280", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    assert_eq!(v["pixel"], serde_json::json!([330, 280]));
    assert_eq!(v["tree"]["hit"]["name"], "glass ball");
    assert!(v["tree"]["children"].as_array().unwrap().len() >= 2);
    assert_eq!(v["rgb8"].as_array().unwrap().len(), 3);
    let out = raylab(&repo(), &["trace", scene.to_str().unwrap(), "--ray", "0,1,10:0,0,-1"]);
    assert!(out.status.success() && text(&out.stdout).contains("camera ray"));
    let out = raylab(&repo(), &["trace", scene.to_str().unwrap(), "--pixel", "800,0"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("inside the 800×600 image"));
}

#[test]
fn the_pixel_trace_agrees_with_the_rendered_pixel() {
    let dir = temp_dir("agree");
    let scene = repo().join("scenes/showcase.toml");
    // One sample per pixel: the sample is the pixel (tests/trace_matches_render.rs recombines
    // adaptive and stratified samples).
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "-o", "a.png", "-q", "--aa", "stratified"]);
    assert!(out.status.success());
    let img = image::open(dir.join("a.png")).unwrap().to_rgb8();
    for (x, y) in [(330, 280), (100, 500), (600, 200), (10, 10)] {
        let out = raylab(&dir, &["trace", scene.to_str().unwrap(), "--pixel", &format!("{x},{y}"), "--json", "--aa", "stratified"]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let traced: Vec<u8> = v["rgb8"].as_array().unwrap().iter().map(|c| c.as_u64().unwrap() as u8).collect();
        assert_eq!(traced, img.get_pixel(x, y).0.to_vec(), "pixel ({x}, {y})");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn plugins_lists_every_type_with_its_parameters() {
    let out = raylab(&repo(), &["plugins"]);
    let t = text(&out.stdout);
    for ty in [
        "plane",
        "sphere",
        "hemisphere",
        "triangle",
        "quadrangle",
        "polygon",
        "cylinder",
        "tube",
        "ambient",
        "directional",
        "point",
        "spot",
        "phong",
        "pbr",
        "normals",
        "depth",
    ] {
        assert!(t.contains(&format!("\n  {ty}  — ")), "missing {ty}");
    }
    assert!(t.contains("MATERIALS ([materials.NAME] type = ..."), "no materials section");
    assert!(t.contains("radius") && t.contains("max_depth") && t.contains("0.001"));
    let md = text(&raylab(&repo(), &["plugins", "--markdown"]).stdout);
    assert!(md.contains("### `sphere`") && md.contains("| `radius` | float | 1 |"));
    assert!(md.contains("## Materials") && md.contains("### `pbr`") && md.contains("| `roughness` | float | 1 |"));
}

#[test]
fn integrator_and_parameter_overrides() {
    let dir = temp_dir("overrides");
    let scene = repo().join("scenes/showcase.toml");
    let s = scene.to_str().unwrap();
    let out = raylab(&dir, &["render", s, "-o", "n.png", "--integrator", "normals", "--width", "16", "--height", "12", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = raylab(
        &dir,
        &["render", s, "-o", "d.png", "--depth", "1", "--set", "prune_threshold=0.01", "--width", "16", "--height", "12", "-q"],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("max_depth 1, prune 0.01"));
    let out = raylab(&dir, &["render", s, "--integrator", "normals", "--depth", "2"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("integrator \"normals\" has no recursion depth to set"));
    let out = raylab(&dir, &["render", s, "--set", "max_depth"]);
    assert!(text(&out.stderr).contains("expected KEY=VALUE"));
    std::fs::remove_dir_all(dir).unwrap();
}

/// Ctrl-C during the render loop. The signal is sent on an event: the first checkpoint written
/// (the render loop runs, so the handler installed before loading is in place), not after a
/// fixed delay; the wait watches the child.
#[cfg(all(unix, feature = "exr"))]
#[test]
fn ctrl_c_writes_the_partial_image_beside_the_target_and_keeps_the_old_one() {
    use std::time::{Duration, Instant};
    let dir = temp_dir("sigint");
    let scene = repo().join("scenes/showcase.toml");
    std::fs::write(dir.join("out.png"), b"a good image from before").unwrap();
    // Hours of work: it cannot finish before the signal.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            "out.png",
            "--width",
            "1200",
            "--height",
            "900",
            "--aa",
            "stratified",
            "--spp",
            "1024",
            "--max-rays",
            "1000000000000000",
            "--checkpoint",
            "out.checkpoint.exr",
            "--checkpoint-every",
            "0.05",
            "-q",
        ])
        .current_dir(&dir)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !dir.join("out.checkpoint.exr").exists() {
        if let Some(status) = child.try_wait().unwrap() {
            let out = child.wait_with_output().unwrap();
            panic!("raylab exited ({status}) before its first checkpoint: {}", text(&out.stderr));
        }
        assert!(start.elapsed() < Duration::from_secs(300), "no checkpoint within 5 minutes");
        std::thread::sleep(Duration::from_millis(5));
    }
    let kill = std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            child.kill().unwrap();
            panic!("raylab did not stop within 2 minutes of Ctrl-C");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = child.wait_with_output().unwrap();
    let err = text(&out.stderr);
    assert_eq!(status.code(), Some(130), "exit status after Ctrl-C; stderr: {err}");
    assert!(err.contains("interrupted") && err.contains("out.partial.png") && err.contains("out.png was not written"), "{err}");
    assert_eq!(std::fs::read(dir.join("out.png")).unwrap(), b"a good image from before", "the old image is kept");
    let partial = image::open(dir.join("out.partial.png")).expect("a complete, readable partial image");
    assert_eq!((partial.width(), partial.height()), (1200, 900));
    let mut names: Vec<String> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    assert_eq!(names, ["out.checkpoint.exr", "out.partial.png", "out.png"], "the state to resume, and no temporary file left behind");
    assert!(err.contains("--resume out.checkpoint.exr"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

const TINY: &str = "# a comment convert would drop\n[render]\nwidth = 8\nheight = 6\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"sphere\"\n";

#[test]
fn convert_refuses_to_overwrite_its_input_under_any_name() {
    let dir = temp_dir("convert-self");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(dir.join("scene.toml"), TINY).unwrap();
    std::os::unix::fs::symlink(dir.join("scene.toml"), dir.join("link.toml")).unwrap();
    std::fs::hard_link(dir.join("scene.toml"), dir.join("hard.toml")).unwrap();
    for out in ["scene.toml", "./scene.toml", "sub/../scene.toml", "link.toml", "hard.toml"] {
        let o = raylab(&dir, &["convert", "scene.toml", "-o", out]);
        assert_eq!(o.status.code(), Some(1), "-o {out}: {}", text(&o.stdout));
        assert!(text(&o.stderr).contains("would overwrite its input"), "-o {out}: {}", text(&o.stderr));
        assert_eq!(std::fs::read_to_string(dir.join("scene.toml")).unwrap(), TINY, "-o {out} changed the input");
    }
    let abs = dir.join("scene.toml");
    let o = raylab(&dir.join("sub"), &["convert", "../scene.toml", "-o", abs.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    let o = raylab(&dir, &["convert", "scene.toml", "-o", "copy.toml"]);
    assert!(o.status.success(), "a different output is written: {}", text(&o.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn negative_numbers_get_range_errors_naming_the_option() {
    let dir = temp_dir("negative");
    std::fs::write(dir.join("scene.toml"), TINY).unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["render", "scene.toml", "--seed", "-1"], "'--seed <SEED>': -1 is out of range; expected an integer in 0..="),
        (&["render", "scene.toml", "--width", "-3"], "'--width <WIDTH>': -3 is out of range; expected an integer in 1..="),
        (&["render", "scene.toml", "--spp", "-1"], "'--spp <SPP>'"),
        (&["render", "scene.toml", "--max-rays", "-1"], "'--max-rays <N>'"),
        (&["render", "scene.toml", "--threads", "-2"], "'--threads <THREADS>': -2 is out of range; expected an integer in 1..=4096"),
        (&["render", "scene.toml", "--grid", "-2"], "'--grid <N>'"),
        (&["render", "scene.toml", "--seed", "1e3"], "expected an integer in 0..="),
        (&["bench", "--width", "-1"], "'--width <WIDTH>': -1 is out of range; expected an integer in 1..=32768"),
        (&["sweep", "scene.toml", "--vary", "spp=1", "--repeat", "-1"], "'--repeat <N>'"),
    ];
    for (args, needle) in cases {
        let o = raylab(&dir, args);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle) && !err.contains("unexpected argument"), "{args:?}: {err}");
    }
    // Signed and real values reach the scene's own checks, which name the flag and the range.
    let located: &[(&[&str], &str)] = &[
        (&["render", "scene.toml", "--focus-distance", "-2"], "--focus-distance"),
        (&["render", "scene.toml", "--aperture", "-0.5"], "--aperture"),
        (&["render", "scene.toml", "--depth", "-1"], "--depth"),
        (&["render", "scene.toml", "--lens-samples", "-4"], "--lens-samples"),
        (&["render", "scene.toml", "--aa", "adaptive", "--aa-depth", "-1"], "--aa-depth"),
        (&["render", "scene.toml", "--aa", "adaptive", "--aa-threshold", "-1"], "--aa-threshold"),
        (&["trace", "scene.toml", "--pixel", "-1,3"], "--pixel: expected X,Y inside the 8×6 image"),
        (&["trace", "scene.toml", "--ray", "-1,0,5:0,0,0"], "--ray"),
    ];
    for (args, needle) in located {
        let o = raylab(&dir, args);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(needle) && !err.contains("unexpected argument"), "{args:?}: {err}");
    }
    let o = raylab(&dir, &["trace", "scene.toml", "--ray", "-1,0,5:0,0,-1"]);
    assert!(o.status.success(), "a ray from a negative origin is traced: {}", text(&o.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn the_work_budget_refuses_a_render_and_names_the_flag_that_raises_it() {
    let dir = temp_dir("max-rays");
    std::fs::write(dir.join("scene.toml"), TINY).unwrap();
    let o = raylab(&dir, &["render", "scene.toml", "--spp", "4", "--max-rays", "100"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("at least 192 camera rays (192 pixel samples), over the work budget of 100 rays") && err.contains("--max-rays"),
        "{err}"
    );
    assert!(!dir.join("render.png").exists());
    let o = raylab(&dir, &["render", "scene.toml", "--spp", "4", "--max-rays", "100000000", "-q"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `trace --sample K` explains the K-th of the pixel's samples, and says how many there are.
#[test]
fn the_cli_prints_the_sample_it_was_asked_for() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/dozen.toml");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["trace"])
        .arg(&scene)
        .args(["--pixel", "10,10", "--sample", "3", "--spp", "4", "--json", "--width", "40", "--height", "30"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["sample"]["index"], 3);
    assert_eq!(v["sample"]["of"], 4);
    assert_eq!(v["sample"]["id"]["kind"], "pixel");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["trace"])
        .arg(&scene)
        .args(["--pixel", "10,10", "--sample", "4", "--spp", "4"])
        .output()
        .unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("has 4 samples"));
}

#[test]
fn tonemap_of_a_float_render_is_the_render_s_png_and_refuses_bad_files() {
    let dir = temp_dir("tonemap");
    let scene = repo().join("scenes/showcase.toml");
    let s = scene.to_str().unwrap();
    for out in ["a.pfm", "a.png"] {
        let r = raylab(&dir, &["render", s, "-o", out, "--width", "40", "--height", "30", "-q"]);
        assert!(r.status.success(), "{}", text(&r.stderr));
    }
    let r = raylab(&dir, &["tonemap", "a.pfm", "-o", "b.png"]);
    assert!(r.status.success(), "{}", text(&r.stderr));
    let (a, b) = (image::open(dir.join("a.png")).unwrap().to_rgb8(), image::open(dir.join("b.png")).unwrap().to_rgb8());
    assert_eq!(a, b, "exposure 0 gives the bits raylab render writes");
    let r = raylab(&dir, &["tonemap", "a.pfm", "-o", "c.png", "--exposure", "1"]);
    assert!(r.status.success());
    let c = image::open(dir.join("c.png")).unwrap().to_rgb8();
    assert!(c.pixels().zip(a.pixels()).all(|(c, a)| (0..3).all(|i| c[i] >= a[i])) && c != a, "a stop brighter");
    let r = raylab(&dir, &["tonemap", "a.pfm", "-o", "d.png", "--layer", "depth"]);
    assert!(text(&r.stderr).contains("a PFM file holds colour only"), "{}", text(&r.stderr));
    std::fs::write(dir.join("bad.pfm"), b"PF\n100000 100000\n-1\n").unwrap();
    let r = raylab(&dir, &["tonemap", "bad.pfm", "-o", "e.png"]);
    assert_eq!(r.status.code(), Some(1));
    assert!(text(&r.stderr).contains("over"), "{}", text(&r.stderr));
    // The input's type is checked before anything is read (the file need not even exist).
    let r = raylab(&dir, &["tonemap", "missing.png", "-o", "f.png"]);
    assert!(text(&r.stderr).contains("unknown image type \".png\""), "{}", text(&r.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn sweep_measures_phong_against_a_path_traced_reference() {
    let dir = temp_dir("sweep-path");
    let scene = repo().join("scenes/report-light-point.toml");
    let scene = scene.to_str().unwrap();
    let small = ["--width", "24", "--height", "18", "-q", "--out", "out"];
    // The phong parameter set for the swept renders does not reach the path tracer.
    let args = [
        &["sweep", scene, "--vary", "spp=1,2", "--set", "prune_threshold=0", "--reference-integrator", "path", "--reference-spp", "4"][..],
        &small,
    ]
    .concat();
    let out = raylab(&dir, &args);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("out/results.json")).unwrap()).unwrap();
    assert_eq!(json["reference_integrator"], "path");
    assert!(json["reference_seconds"].as_f64().is_some_and(|s| s > 0.0), "{json}");
    let results = json["results"].as_array().unwrap();
    assert_eq!(results.len(), 2);
    assert!(results.iter().all(|r| r["rmse"].as_f64().is_some_and(|e| e > 0.0)), "phong differs from the path tracer: {json}");
    // The reference is cached under a name that covers its integrator: phong's is another file.
    let refs = |d: &Path| {
        std::fs::read_dir(d.join("out"))
            .unwrap()
            .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with("reference-"))
            .count()
    };
    assert_eq!(refs(&dir), 1);
    let out = raylab(&dir, &[&["sweep", scene, "--vary", "spp=1", "--reference-spp", "2"][..], &small].concat());
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(refs(&dir), 2);
    // The integrator is a knob too: phong's and the path tracer's curves against one reference.
    let out = raylab(
        &dir,
        &[
            &[
                "sweep",
                scene,
                "--vary",
                "spp=1,2",
                "--vary",
                "integrator=phong,path",
                "--reference-integrator",
                "path",
                "--reference-spp",
                "4",
            ][..],
            &small,
        ]
        .concat(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let csv = std::fs::read_to_string(dir.join("out/results.csv")).unwrap();
    assert!(csv.starts_with("spp,integrator,") && csv.contains(",phong,") && csv.contains(",path,"), "{csv}");
    // A reference image cannot be re-rendered by another integrator.
    let out = raylab(
        &dir,
        &[&["sweep", scene, "--vary", "spp=1", "--reference", "x.pfm", "--reference-integrator", "path"][..], &small].concat(),
    );
    assert!(!out.status.success() && text(&out.stderr).contains("--reference-integrator"), "{}", text(&out.stderr));
    let out = raylab(&dir, &[&["sweep", scene, "--vary", "spp=1", "--reference-integrator", "pth"][..], &small].concat());
    assert!(!out.status.success() && text(&out.stderr).contains("unknown integrator \"pth\""), "{}", text(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `sweep --vary denoise=off,on`: each setting rendered as it is and denoised; the denoised
/// low-spp rows are closer to the reference, and the denoiser's time is counted and recorded. A
/// value other than off or on is refused at its place in the flag.
#[test]
fn sweep_varies_the_denoiser() {
    let dir = temp_dir("sweep-denoise");
    let scene = repo().join("scenes/path-cornell.toml");
    let scene = scene.to_str().unwrap();
    let small = ["--width", "32", "--height", "32", "--reference-spp", "64", "--metric", "rmse", "-q"];
    let out = raylab(&dir, &[&["sweep", scene, "--vary", "spp=1", "--vary", "denoise=off,maybe"][..], &small].concat());
    assert!(!out.status.success() && text(&out.stderr).contains("denoise is off or on"), "{}", text(&out.stderr));
    if !denoiser_here("the denoised rows") {
        return;
    }
    let out = raylab(&dir, &[&["sweep", scene, "--vary", "spp=2,4", "--vary", "denoise=off,on", "--out", "s"][..], &small].concat());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("s/results.json")).unwrap()).unwrap();
    let rows = json["results"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    let row = |spp: &str, denoise: &str| {
        rows.iter()
            .find(|r| r["label"] == format!("spp={spp} denoise={denoise}"))
            .unwrap_or_else(|| panic!("no row {spp} {denoise}: {json}"))
    };
    for spp in ["2", "4"] {
        let (off, on) = (row(spp, "off"), row(spp, "on"));
        assert!(off.get("denoise_seconds").is_none(), "{off}");
        let d = on["denoise_seconds"].as_f64().unwrap();
        assert!(d > 0.0 && on["seconds"].as_f64().unwrap() >= d, "{on}");
        let (e_off, e_on) = (off["rmse"].as_f64().unwrap(), on["rmse"].as_f64().unwrap());
        assert!(e_on < 0.8 * e_off, "{spp} spp: RMSE noisy {e_off}, denoised {e_on}");
    }
    let csv = std::fs::read_to_string(dir.join("s/results.csv")).unwrap();
    assert!(csv.starts_with("spp,denoise,seconds,") && csv.contains("\n4,on,"), "{csv}");
    // At 32 spp the denoised row is rendered and denoised on 2 × 2 sub-pixels of 8 spp, as
    // `render --denoise` does, and measured on the frame's pixels (against a reference of 512
    // spp: at 64 its own noise is most of the denoised row's error).
    let fine = ["--width", "32", "--height", "32", "--reference-spp", "512", "--metric", "rmse", "-q"];
    let out = raylab(&dir, &[&["sweep", scene, "--vary", "spp=32", "--vary", "denoise=off,on", "--out", "g"][..], &fine].concat());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("g/results.json")).unwrap()).unwrap();
    let rmse =
        |label: &str| json["results"].as_array().unwrap().iter().find(|r| r["label"] == label).and_then(|r| r["rmse"].as_f64()).unwrap();
    let (e_off, e_on) = (rmse("spp=32 denoise=off"), rmse("spp=32 denoise=on"));
    assert!(e_on < 0.8 * e_off, "32 spp: RMSE noisy {e_off}, denoised on the grid {e_on}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// `render --denoise` and `raylab denoise` (Intel Open Image Denoise's tool, which CI installs):
/// the denoised 4-spp path-traced box is closer to a 256-spp render than the noisy one, and the
/// two commands give the same image from the same render.
#[test]
fn denoising_brings_a_noisy_render_closer_to_the_reference() {
    if !denoiser_here("denoising_brings_a_noisy_render_closer_to_the_reference") {
        return;
    }
    let dir = temp_dir("denoise");
    let scene = repo().join("scenes/path-cornell.toml");
    let scene = scene.to_str().unwrap();
    let size = ["--width", "48", "--height", "48", "-q", "--seed", "3"];
    let run = |args: &[&str]| {
        let out = raylab(&dir, &[&["render", scene][..], &size[..], args].concat());
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stdout)
    };
    run(&["--spp", "256", "-o", "ref.pfm"]);
    run(&["--spp", "4", "-o", "noisy.exr", "--aov", "albedo,normal,emission"]);
    let summary = run(&["--spp", "4", "-o", "denoised.pfm", "--denoise"]);
    assert!(summary.contains("denoise ") && summary.contains("(before denoising)"), "{summary}");
    let out = raylab(&dir, &["denoise", "noisy.exr", "-o", "again.pfm"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("albedo and normal guides, its emission left out"), "{}", text(&out.stdout));
    let read = |name: &str| raylab::image::reference::decode_pfm(&std::fs::read(dir.join(name)).unwrap()).unwrap();
    let (reference, denoised, again) = (read("ref.pfm"), read("denoised.pfm"), read("again.pfm"));
    let noisy =
        raylab::image::tonemap::read_layer(&std::fs::read(dir.join("noisy.exr")).unwrap(), "exr", raylab::image::tonemap::Layer::Color)
            .unwrap();
    let rmse = |f: &raylab::Film| displayed_rmse(f, &reference);
    assert!(rmse(&denoised) < 0.75 * rmse(&noisy), "RMSE noisy {}, denoised {}", rmse(&noisy), rmse(&denoised));
    assert!(rmse(&again) < 0.75 * rmse(&noisy), "RMSE noisy {}, denoised again {}", rmse(&noisy), rmse(&again));
    // The same layers, the same filter: `raylab denoise` of the EXR is `render --denoise`.
    let apart = denoised.pixels.iter().zip(&again.pixels).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0f32, f32::max);
    assert!(apart < 1e-3, "render --denoise and raylab denoise differ by {apart}");
    // From 32 spp (a multiple of 4) the render and the denoiser work on 2 × 2 sub-pixels of 8
    // spp, brought back to the frame: its size, its sample count, and the error estimate of its
    // pixels, closer to the reference than the 4-spp image.
    let summary = run(&["--spp", "32", "-o", "fine.pfm", "--denoise"]);
    assert!(summary.contains("(48×48, 32 spp,") && summary.contains("32.0 spp on average"), "{summary}");
    let fine = read("fine.pfm");
    assert_eq!((fine.width, fine.height), (48, 48));
    assert!(rmse(&fine) < rmse(&denoised), "RMSE denoised at 32 spp on the grid {}, at 4 spp {}", rmse(&fine), rmse(&denoised));
    // The same sub-pixels rendered as a frame of twice the width and height at 8 spp (as a farm
    // would render them, tile by tile) and given to `raylab denoise --subpixels 2`: the image
    // `render --denoise` wrote. Without --subpixels it says it denoised the pixels it was given.
    let wide = ["--width", "96", "--height", "96", "--spp", "8", "-o", "sub.exr", "--aov", "albedo,normal,emission"];
    let out = raylab(&dir, &[&["render", scene][..], &wide[..], &["-q", "--seed", "3"]].concat());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = raylab(&dir, &["denoise", "sub.exr", "--subpixels", "2", "-o", "sub.pfm"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("(48×48, ") && text(&out.stdout).contains("on 2 × 2 sub-pixels"), "{}", text(&out.stdout));
    let sub = read("sub.pfm");
    let apart = fine.pixels.iter().zip(&sub.pixels).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0f32, f32::max);
    assert!(apart < 1e-3, "render --denoise on 2 × 2 and raylab denoise --subpixels 2 differ by {apart}");
    assert!(text(&raylab(&dir, &["denoise", "noisy.exr", "-o", "pixels.pfm"]).stdout).contains("on the frame's pixels"));
    let out = raylab(&dir, &["denoise", "noisy.exr", "--subpixels", "5", "-o", "odd.pfm"]);
    assert!(!out.status.success() && text(&out.stderr).contains("multiples of 5"), "{}", text(&out.stderr));
    // Never over its input.
    let out = raylab(&dir, &["denoise", "noisy.exr", "-o", "./noisy.exr"]);
    assert!(!out.status.success() && text(&out.stderr).contains("would overwrite its input"), "{}", text(&out.stderr));
    // Not per tile.
    let out = raylab(&dir, &[&["render", scene][..], &size[..], &["--tile", "0/2", "-o", "t.exr", "--denoise"]].concat());
    assert!(!out.status.success() && text(&out.stderr).contains("not to a tile"), "{}", text(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `render --target-error --denoise` on the finer grid (here 2 × 2 sub-pixels: the target's first
/// stop is 64 samples a pixel), each pixel's sub-pixels stopping together: the image has the
/// frame's size, pixels stopped at different counts (each a multiple of 4, the `spp` layer the
/// pixel's samples), and the denoised image is closer to the reference than the same target's
/// noisy one. Under a time budget the render goes to the same grid, and the `spp` layer of the
/// denoised render (or any map of counts its sub-pixels can share) repeats it bit for bit.
#[test]
fn an_error_target_or_time_budget_with_the_denoiser_stops_each_pixels_sub_pixels_together() {
    if !denoiser_here("an_error_target_or_time_budget_with_the_denoiser_stops_each_pixels_sub_pixels_together") {
        return;
    }
    let dir = temp_dir("target-denoise");
    let scene = repo().join("scenes/path-cornell.toml");
    let scene = scene.to_str().unwrap();
    let size = ["--width", "32", "--height", "32", "-q", "--seed", "5"];
    let run = |args: &[&str]| {
        let out = raylab(&dir, &[&["render", scene][..], &size[..], args].concat());
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stdout)
    };
    run(&["--spp", "512", "-o", "ref.pfm"]);
    let target = ["--spp", "256", "--target-error", "0.025"];
    run(&[&target[..], &["-o", "noisy.pfm"]].concat());
    let summary = run(&[&target[..], &["-o", "denoised.exr", "--denoise", "--aov", "spp"]].concat());
    assert!(summary.contains("(32×32, to error 0.025 (64..256 spp)") && summary.contains("(before denoising)"), "{summary}");
    let read = |name: &str, layer| {
        raylab::image::tonemap::read_layer(&std::fs::read(dir.join(name)).unwrap(), name.rsplit('.').next().unwrap(), layer).unwrap()
    };
    use raylab::image::tonemap::Layer;
    let (reference, noisy, denoised) = (read("ref.pfm", Layer::Color), read("noisy.pfm", Layer::Color), read("denoised.exr", Layer::Color));
    let spp: Vec<u32> = read("denoised.exr", Layer::Spp).pixels.iter().map(|p| p.x as u32).collect();
    assert_eq!((denoised.width, denoised.height), (32, 32));
    assert!(spp.iter().all(|&n| (64..=256).contains(&n) && n % 4 == 0), "{spp:?}");
    assert!(spp.iter().min() < spp.iter().max(), "pixels stopped at different counts");
    let rmse = |f: &raylab::Film| displayed_rmse(f, &reference);
    assert!(rmse(&denoised) < 0.75 * rmse(&noisy), "RMSE noisy {}, denoised {}", rmse(&noisy), rmse(&denoised));
    // A farm renders the same image: the 2 × 2 sub-pixels as a frame twice as wide and high at
    // 256 / 4 spp, `--subpixels 2` so that each pixel's block stops together, in tiles (bands of
    // whole blocks), merged, then `raylab denoise --subpixels 2`. A crop that cuts blocks is
    // refused, and so is --subpixels beside --denoise.
    let fine = ["--width", "64", "--height", "64", "--spp", "64", "--target-error", "0.025", "--subpixels", "2", "--seed", "5"];
    let part = |extra: &[&str]| raylab(&dir, &[&["render", scene, "-q"][..], &fine[..], extra].concat());
    for i in 0..3 {
        let (tile, name) = (format!("{i}/3"), format!("part{i}.exr"));
        let out = part(&["--tile", &tile, "--aov", "albedo,normal,emission", "-o", &name]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    let out = raylab(&dir, &["merge", "part0.exr", "part1.exr", "part2.exr", "-o", "farm.exr"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = raylab(&dir, &["denoise", "farm.exr", "--subpixels", "2", "-o", "farm.pfm"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let farm = read("farm.pfm", Layer::Color);
    let apart = denoised.pixels.iter().zip(&farm.pixels).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0f32, f32::max);
    assert!(apart < 1e-3, "render --target-error --denoise and its farm (--subpixels 2, merge, denoise) differ by {apart}");
    let out = part(&["--crop", "0,64,0,31", "-o", "cut.exr"]);
    assert!(!out.status.success() && text(&out.stderr).contains("whole blocks of 2 × 2 sub-pixels"), "{}", text(&out.stderr));
    let out = part(&["--denoise", "-o", "both.exr"]);
    assert!(!out.status.success() && text(&out.stderr).contains("--denoise chooses its own grid"), "{}", text(&out.stderr));
    // A time budget it does not reach: every pixel at 128, on 4 × 4 sub-pixels of 8; its `spp`
    // layer, and the target's (counts its 4 × 4 sub-pixels share), as maps.
    let budget = ["--spp", "128", "--time-budget", "100000", "--denoise", "--aov", "spp"];
    let summary = run(&[&budget[..], &["-o", "budget.exr"]].concat());
    assert!(summary.contains("at 128 spp"), "{summary}");
    run(&[&budget[..], &["-o", "again.exr", "--spp-map", "budget.exr"]].concat());
    assert_eq!(read("budget.exr", Layer::Color), read("again.exr", Layer::Color));
    let mapped = ["--spp", "256", "--time-budget", "100000", "--denoise", "--aov", "spp", "-o", "mapped.exr", "--spp-map", "denoised.exr"];
    run(&mapped);
    assert_eq!(read("mapped.exr", Layer::Spp), read("denoised.exr", Layer::Spp));
    // A map of the frame's pixels at 8 spp: not counts 4 × 4 sub-pixels can share.
    run(&["--spp", "8", "--time-budget", "100000", "--aov", "spp", "-o", "small.exr"]);
    let out = raylab(&dir, &[&["render", scene][..], &size[..], &budget[..], &["-o", "no.exr", "--spp-map", "small.exr"]].concat());
    let err = text(&out.stderr);
    assert!(!out.status.success() && err.contains("cannot share evenly"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// `--target-error` reaches the render: pixels stop at different counts, the summary says so,
/// and `--aov error` writes the estimate and the samples per pixel.
#[test]
fn an_error_target_from_the_command_line() {
    let dir = temp_dir("target-error");
    let scene = repo().join("scenes/path-cornell.toml");
    let out = raylab(
        &dir,
        &[
            "render",
            scene.to_str().unwrap(),
            "--width",
            "24",
            "--height",
            "24",
            "--spp",
            "256",
            "--target-error",
            "0.1",
            "-o",
            "t.png",
            "-q",
        ],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("to error 0.1 (16..256 spp)") && stdout.contains("an error target:"), "{stdout}");
    // So small an image's estimate rests on about 22 pixels' worth of variance, and may read
    // low: over six seeds it read 0.43–1.29× the true error (benches/error/RESULTS.md).
    assert!(stdout.contains("may read low") && stdout.contains("it rests on few pixels"), "{stdout}");
    // The sun's caustics on environment's floor, found by few samples: the estimate may read low.
    let env = repo().join("scenes/environment.toml");
    let out = raylab(
        &dir,
        &["render", env.to_str().unwrap(), "--width", "48", "--height", "27", "--spp", "1024", "--target-error", "0.1", "-o", "e.png"],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("may read low") && stdout.contains("rarer than 1 in 16"), "{stdout}");
    let out = raylab(
        &dir,
        &["render", scene.to_str().unwrap(), "--width", "24", "--height", "24", "--spp", "8", "--target-error", "0.1", "-o", "t.png"],
    );
    assert!(!out.status.success() && text(&out.stderr).contains("the most samples a pixel takes"), "{}", text(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `--time-budget` records the samples each pixel reached in the `spp` layer, and the same
/// command with `--spp-map` repeats the image bit for bit, whatever the budget reached.
#[cfg(feature = "exr")]
#[test]
fn a_time_budget_render_repeats_from_its_spp_layer() {
    let dir = temp_dir("time-budget");
    let scene = repo().join("scenes/path-cornell.toml");
    let args = |out: &str| -> Vec<String> {
        let s = ["render", scene.to_str().unwrap(), "--width", "24", "--height", "24", "--spp", "4096", "--time-budget", "0.1", "-q"];
        let mut v: Vec<String> = s.iter().map(|a| a.to_string()).collect();
        v.extend(["--aov", "spp", "-o", out].map(String::from));
        v
    };
    let run = |v: Vec<String>| raylab(&dir, &v.iter().map(String::as_str).collect::<Vec<_>>());
    let out = run(args("first.exr"));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("≤ 4096 spp within 0.1 s") && stdout.contains("time budget:"), "{stdout}");
    let mut repeat = args("again.exr");
    repeat.extend(["--spp-map", "first.exr"].map(String::from));
    let out = run(repeat);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("read from --spp-map"), "{}", text(&out.stdout));
    let read = |f: &str| raylab::image::exr::read_exr_rgb(&std::fs::read(dir.join(f)).unwrap()).unwrap();
    let (a, b) = (read("first.exr"), read("again.exr"));
    let bits = |v: &[[f32; 3]]| v.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!((a.0, a.1), (b.0, b.1));
    assert_eq!(bits(&a.2), bits(&b.2), "the repeat has the same bits");
    // A map is read only for a render under a time budget.
    let out =
        raylab(&dir, &["render", scene.to_str().unwrap(), "--width", "24", "--height", "24", "--spp-map", "first.exr", "-o", "x.png"]);
    assert!(!out.status.success() && text(&out.stderr).contains("time budget"), "{}", text(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `--spp-map` refuses a map that cannot be this render's, naming the file and what it expected:
/// a PFM (colour only), an EXR without an `spp` channel or of another size, a count that is not
/// a whole number of samples (NaN, infinite, negative, fractional, past 2^24) or more than the
/// render's `spp`.
#[cfg(feature = "exr")]
#[test]
fn a_malformed_spp_map_is_refused_clearly() {
    use exr::prelude::*;
    let dir = temp_dir("spp-map-hostile");
    let scene = repo().join("scenes/path-cornell.toml");
    let write = |name: &str, channel: &str, (w, h): (usize, usize), value: f32| {
        let channels = AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new(channel, FlatSamples::F32(vec![value; w * h]))]));
        Image::from_layer(Layer::new((w, h), LayerAttributes::default(), Encoding::UNCOMPRESSED, channels))
            .write()
            .to_file(dir.join(name))
            .unwrap();
    };
    write("ok.exr", "spp", (8, 8), 4.0);
    write("rgb.exr", "R", (8, 8), 4.0);
    write("small.exr", "spp", (4, 8), 4.0);
    std::fs::write(dir.join("map.pfm"), b"PF\n8 8\n-1\n").unwrap();
    write("many.exr", "spp", (8, 8), 8.0);
    let mut cases: Vec<(String, String)> = [
        ("map.pfm", "the spp layer needs an OpenEXR file"),
        ("rgb.exr", "no channel spp"),
        ("small.exr", "its 4×8 pixels are not this render's 8×8"),
        ("many.exr", "more than the 4 spp this render takes at most"),
    ]
    .map(|(m, e)| (m.to_string(), e.to_string()))
    .into();
    for (name, value) in [("nan", f32::NAN), ("inf", f32::INFINITY), ("neg", -1.0), ("half", 1.5), ("huge", 3e7)] {
        write(&format!("{name}.exr"), "spp", (8, 8), value);
        cases.push((format!("{name}.exr"), format!("pixel (0, 0) has {value} samples: expected a whole number")));
    }
    let render = |map: &str| {
        raylab(
            &dir,
            &[
                "render",
                scene.to_str().unwrap(),
                "--width",
                "8",
                "--height",
                "8",
                "--spp",
                "4",
                "--time-budget",
                "100",
                "--spp-map",
                map,
                "-o",
                "o.exr",
                "-q",
            ],
        )
    };
    assert!(render("ok.exr").status.success(), "{}", text(&render("ok.exr").stderr));
    for (map, expect) in &cases {
        let out = render(map);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{map}: {err}");
        assert!(err.contains(map.as_str()) || expect.contains("more than"), "{map}: the error names the file: {err}");
        assert!(err.contains(expect.as_str()), "{map}: expected {expect:?} in {err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// `raylab denoise` refuses a partial image (a tile, crop, pass or checkpoint), as `render
/// --denoise` refuses a tile: the filter reads each pixel's neighbours, so a tile denoised alone
/// leaves seams. Checked before the denoiser is looked for.
#[cfg(feature = "exr")]
#[test]
fn denoise_refuses_a_partial_image() {
    let dir = temp_dir("denoise-partial");
    let scene = repo().join("scenes/path-cornell.toml");
    for (share, name) in [(["--tile", "0/2"], "tile.exr"), (["--pass", "1/2"], "pass.exr")] {
        let args = ["render", scene.to_str().unwrap(), "--width", "8", "--height", "8", "--spp", "4", "-q", "-o", name];
        let out = raylab(&dir, &[&args[..], &share[..]].concat());
        assert!(out.status.success(), "{}", text(&out.stderr));
        let out = raylab(&dir, &["denoise", name, "-o", "d.pfm"]);
        let err = text(&out.stderr);
        assert!(out.status.code() == Some(1) && err.contains(&format!("{name}: a partial image")) && err.contains("raylab merge"), "{err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// `raylab denoise` does not let NaN, infinite or negative pixels pass in silence (Open Image
/// Denoise takes them as 0 without a word): it sets those channels to 0 itself and warns with
/// the count and the first pixel. A stand-in for the tool (`RAYLAB_OIDN`, copying its colour
/// input to its output) shows what raylab gave it, so the test needs no denoiser.
#[cfg(unix)]
#[test]
fn denoise_warns_of_pixels_it_cannot_filter() {
    use raylab::glam::Vec3;
    use std::os::unix::fs::PermissionsExt;
    let dir = temp_dir("denoise-nan");
    let tool = dir.join("fake-oidn");
    std::fs::write(
        &tool,
        "#!/bin/sh\nwhile [ $# -gt 0 ]; do case \"$1\" in --hdr) i=\"$2\"; shift;; -o) o=\"$2\"; shift;; esac; shift; done\ncp \"$i\" \"$o\"\n",
    )
    .unwrap();
    std::fs::set_permissions(&tool, std::fs::Permissions::from_mode(0o755)).unwrap();
    let mut film = raylab::Film::new(4, 3).unwrap();
    film.pixels.fill(Vec3::splat(0.5));
    film.pixels[6] = Vec3::new(0.5, f32::NAN, 0.5); // x 2, y 1: the first, row by row
    film.pixels[9] = Vec3::new(f32::INFINITY, 0.5, 0.5);
    film.pixels[11] = Vec3::new(0.5, 0.5, -1.0);
    std::fs::write(dir.join("in.pfm"), raylab::image::reference::encode_pfm(&film)).unwrap();
    let denoise = |input: &str, output: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
            .args(["denoise", input, "-o", output])
            .env("RAYLAB_OIDN", &tool)
            .current_dir(&dir)
            .output()
            .unwrap()
    };
    let out = denoise("in.pfm", "out.pfm");
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning: 3 pixels of in.pfm's colour have a channel that is NaN, infinite or negative (the first at x 2, y 1)"),
        "{err}"
    );
    let got = raylab::image::reference::decode_pfm(&std::fs::read(dir.join("out.pfm")).unwrap()).unwrap();
    let (bad, good) = ([6, 9, 11], Vec3::splat(0.5));
    assert_eq!(
        [got.pixels[6], got.pixels[9], got.pixels[11]],
        [Vec3::new(0.5, 0.0, 0.5), Vec3::new(0.0, 0.5, 0.5), Vec3::new(0.5, 0.5, 0.0)]
    );
    assert!(got.pixels.iter().enumerate().all(|(i, p)| bad.contains(&i) || *p == good), "{:?}", got.pixels);
    // A clean image: no warning.
    film.pixels.fill(Vec3::splat(0.5));
    std::fs::write(dir.join("clean.pfm"), raylab::image::reference::encode_pfm(&film)).unwrap();
    let out = denoise("clean.pfm", "clean-out.pfm");
    assert!(out.status.success() && !text(&out.stderr).contains("warning"), "{}", text(&out.stderr));
    let help = text(&raylab(&dir, &["denoise", "--help"]).stdout);
    assert!(help.contains("NaN, infinite or negative is taken as 0, with a warning"), "{help}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// An error target is a relative RMSE in (0, 1]: an absurd one is refused with the range, and
/// the summary and messages show targets compactly (`1e-9`, not `0.000000001`; `1e300`, not
/// 301 digits).
#[test]
fn error_targets_are_bounded_and_shown_compactly() {
    let dir = temp_dir("target-range");
    let scene = repo().join("scenes/path-cornell.toml");
    let render = |target: &str, spp: &str| {
        let args =
            ["render", scene.to_str().unwrap(), "--width", "8", "--height", "8", "--spp", spp, "-o", "t.png", "--target-min-spp", "2"];
        raylab(&dir, &[&args[..], &["--target-error", target]].concat())
    };
    for absurd in ["1e300", "1.5", "0", "-0.1", "inf", "NaN"] {
        let out = render(absurd, "4");
        let err = text(&out.stderr);
        let finite = absurd.parse::<f64>().unwrap().is_finite();
        let said = if finite { "expected a relative error (RMSE) in (0, 1]" } else { "expected a finite number" };
        assert!(!out.status.success() && err.contains(said), "{absurd}: {err}");
        assert!(err.len() < 600 && !err.contains("0000000000"), "{absurd}: {err}");
    }
    assert!(text(&render("1e300", "4").stderr).contains("found 1e300"));
    let out = render("1e-9", "4");
    let stdout = text(&out.stdout);
    assert!(out.status.success() && stdout.contains("to error 1e-9 (4..4 spp)"), "{}{stdout}", text(&out.stderr));
    let out = render("1", "4");
    assert!(out.status.success() && text(&out.stdout).contains("to error 1 (2..4 spp)"), "{}", text(&out.stdout));
    std::fs::remove_dir_all(dir).unwrap();
}

/// An output whose folder is not there is refused before anything is loaded or traced (it
/// used to fail only on writing, after the whole render).
#[test]
fn an_output_in_no_folder_is_refused_at_once() {
    let dir = temp_dir("no-folder");
    std::fs::write(dir.join("file"), "").unwrap();
    let scene = repo().join("scenes/path-cornell.toml");
    for (out, said) in [("no/such/x.png", "there is no folder \"no/such\""), ("file/x.png", "\"file\" is not a folder")] {
        // The scene is loaded after the check: a scene that is not there either is not reached.
        let out = raylab(&dir, &["render", "missing.toml", "-o", out]);
        let err = text(&out.stderr);
        assert!(!out.status.success() && err.contains(said) && !err.contains("missing.toml"), "{err}");
    }
    let out = raylab(&dir, &["render", scene.to_str().unwrap(), "-o", "x.png", "--reference", "r.pfm", "--error-csv", "no/e.csv"]);
    assert!(!out.status.success() && text(&out.stderr).contains("cannot write \"no/e.csv\""), "{}", text(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `render --subpixels K` takes the sides that divide the 16-pixel tiles, and says so.
#[test]
fn subpixels_must_divide_the_tiles() {
    let dir = temp_dir("subpixels-rule");
    let scene = repo().join("scenes/path-cornell.toml");
    for (k, ok) in [("3", false), ("6", false), ("32", false), ("0", false), ("4", true)] {
        let args =
            ["render", scene.to_str().unwrap(), "--width", "16", "--height", "16", "--spp", "4", "-q", "-o", "s.png", "--subpixels", k];
        let out = raylab(&dir, &args);
        let err = text(&out.stderr);
        assert_eq!(out.status.success(), ok, "--subpixels {k}: {err}");
        if !ok {
            assert!(err.contains("K must divide 16, the side of the render's tiles: 1, 2, 4, 8 or 16"), "--subpixels {k}: {err}");
            assert!(!err.contains("multiples"), "--subpixels {k}: {err}");
        }
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// `sweep` varies the light-sampling knobs: the path tracer's `light_samples` and a light's own
/// parameter as `TYPE.PARAM` (the environment's sampling grid); a parameter the light type has
/// not, or a type the scene has no light of, is refused.
#[test]
fn sweep_varies_light_knobs() {
    let dir = temp_dir("sweep-lights");
    let scene = repo().join("scenes/environment.toml");
    let scene = scene.to_str().unwrap();
    let small = ["--width", "16", "--height", "9", "--spp", "1", "--reference-spp", "2", "-q", "--out", "out"];
    let vary = ["sweep", scene, "--vary", "environment.resolution=4,64", "--vary", "light_samples=1,2"];
    let out = raylab(&dir, &[&vary[..], &small].concat());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let csv = std::fs::read_to_string(dir.join("out/results.csv")).unwrap();
    assert!(csv.starts_with("environment.resolution,light_samples,"), "{csv}");
    assert_eq!(csv.lines().count(), 5, "{csv}");
    // The grid's resolution changes the samples, so the images.
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("out/results.json")).unwrap()).unwrap();
    let rmse: Vec<f64> = json["results"].as_array().unwrap().iter().map(|r| r["rmse"].as_f64().unwrap()).collect();
    assert_ne!(rmse[0], rmse[1], "{json}");
    let out = raylab(&dir, &[&["sweep", scene, "--vary", "environment.resoluton=4"][..], &small].concat());
    assert!(!out.status.success() && text(&out.stderr).contains("has no parameter `resoluton`"), "{}", text(&out.stderr));
    let out = raylab(&dir, &[&["sweep", scene, "--vary", "rect.samples=4"][..], &small].concat());
    assert!(!out.status.success() && text(&out.stderr).contains("no \"rect\" light"), "{}", text(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}
