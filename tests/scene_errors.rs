//! Malformed scenes: each gives a specific, located error (file:line:col) and never panics.

use raylab::SceneError;
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use std::path::Path;

const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";

fn load(src: &str) -> Result<raylab::RenderJob, SceneError> {
    load_str(&raylab_plugins::registry(), "t.toml", src, Path::new("."), &LoadOptions::default())
}

/// Asserts that `src` fails with a message containing `needle` at 1-based `line:col`.
#[track_caller]
fn fails(src: &str, needle: &str, at: (usize, usize)) -> SceneError {
    let e = match load(src) {
        Ok(_) => panic!("expected an error containing {needle:?}, the scene loaded:\n{src}"),
        Err(e) => e,
    };
    let report = e.report();
    assert!(report.contains(needle), "expected {needle:?} in:\n{report}");
    let where_ = e.where_().expect("error has a location");
    assert_eq!(where_, format!("t.toml:{}:{}", at.0, at.1), "location of:\n{report}");
    e
}

#[test]
fn syntax_errors_point_at_the_problem() {
    fails(&format!("{CAMERA}[render]\nwidth = \n"), "TOML syntax error", (5, 9));
    fails("[camera\n", "TOML syntax error", (1, 8));
}

#[test]
fn unknown_types_and_parameters_suggest_the_right_name() {
    let e = fails(&format!("{CAMERA}[[object]]\ntype = \"sphre\"\n"), "unknown object type \"sphre\"", (5, 8));
    assert!(e.help.unwrap().contains("did you mean \"sphere\""));
    let e = fails(&format!("{CAMERA}[[object]]\ntype = \"sphere\"\nradus = 2\n"), "unknown parameter `radus`", (6, 1));
    assert!(e.help.unwrap().contains("did you mean `radius`"));
    fails(&format!("{CAMERA}[[light]]\ntype = \"lamp\"\n"), "unknown light type", (5, 8));
    fails(&format!("{CAMERA}[integrator]\ntype = \"pathtracer\"\n"), "unknown integrator \"pathtracer\"", (5, 8));
    fails(&format!("{CAMERA}[[object]]\nradius = 1\n"), "has no `type`", (4, 1));
    fails(&format!("{CAMERA}colour = [1, 0, 0]\n"), "unknown parameter `colour`", (4, 1));
}

#[test]
fn wrong_types_and_bad_numbers_are_rejected() {
    fails(&format!("{CAMERA}[[object]]\ntype = \"sphere\"\nradius = \"big\"\n"), "expected a number, found a string", (6, 10));
    fails(&format!("{CAMERA}[[object]]\ntype = \"sphere\"\nradius = nan\n"), "expected a finite number", (6, 10));
    fails(&format!("{CAMERA}[[object]]\ntype = \"sphere\"\nradius = -1\n"), "expected a number > 0", (6, 10));
    fails(&format!("{CAMERA}[[object]]\ntype = \"sphere\"\ncenter = [1, 2]\n"), "expected 3 numbers", (6, 10));
    fails(&format!("{CAMERA}[[object]]\ntype = \"sphere\"\ncenter = [1, inf, 2]\n"), "finite", (6, 10));
    fails(&format!("{CAMERA}[[object]]\ntype = \"plane\"\nnormal = [0, 0, 0]\n"), "non-zero direction", (6, 10));
    fails(&format!("background = [1, -1, 0]\n{CAMERA}"), "must be ≥ 0", (1, 14));
    fails(&format!("{CAMERA}[render]\nencoding = \"gamma\"\n"), "unknown value \"gamma\"", (5, 12));
}

#[test]
fn impossible_geometry_is_rejected_at_load_time() {
    fails(
        &format!("{CAMERA}[[object]]\ntype = \"triangle\"\np0 = [0, 0, 0]\np1 = [1, 1, 1]\np2 = [2, 2, 2]\n"),
        "degenerate triangle",
        (4, 1),
    );
    fails(
        &format!("{CAMERA}[[object]]\ntype = \"polygon\"\nvertices = [[0, 0, 0], [1, 0, 0], [0.2, 0.2, 0], [0, 1, 0]]\n"),
        "not strictly convex",
        (6, 12),
    );
    fails(
        &format!("{CAMERA}[[object]]\ntype = \"quadrangle\"\np0 = [0, 0, 0]\np1 = [1, 0, 0]\np2 = [1, 1, 1]\np3 = [0, 1, 0]\n"),
        "not in the plane",
        (4, 1),
    );
    fails(&format!("{CAMERA}[[object]]\ntype = \"cylinder\"\nheight = 0\n"), "expected a number > 0", (6, 10));
    fails(&format!("{CAMERA}[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nkc = 0\n"), "at least one of kc, kl, kq", (4, 1));
    fails(&format!("{CAMERA}[[light]]\ntype = \"point\"\n"), "missing required parameter `position`", (4, 1));
}

#[test]
fn cameras_must_be_well_formed() {
    fails("[[object]]\ntype = \"sphere\"\n", "the scene has no [camera]", (1, 1));
    fails("[camera]\nposition = [0, 0, 0]\nto = [0, 1, 0]\nscreen_width = 1\nscreen_height = 1\n", "parallel", (1, 1));
    fails("[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, 0]\n", "viewing direction is zero", (3, 11));
    fails("[camera]\nto = [0, 0, -1]\n", "needs `screen_width` and `screen_height`", (1, 1));
    let e = fails("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nscreen_width = 10\n", "does not apply here", (4, 1));
    assert!(e.help.is_some());
}

#[test]
fn absurd_sizes_are_refused_before_allocating() {
    fails(&format!("{CAMERA}[render]\nwidth = 1000000\n"), "outside 1..=", (5, 9));
    fails(&format!("{CAMERA}[render]\nwidth = 30000\nheight = 30000\n"), "exceeds the limit", (4, 1));
    fails(&format!("{CAMERA}[render]\nspp = 0\n"), "out of range", (5, 7));
    fails(&format!("{CAMERA}[render]\nspp = 10000000\n"), "samples per pixel", (5, 7));
    fails(&format!("{CAMERA}[integrator]\nmax_depth = 100000\n"), "exceeds the limit", (5, 13));
}

#[test]
fn names_and_materials_are_checked() {
    let e = fails(
        &format!("{CAMERA}[materials.glass]\nkt = 0.9\n[[object]]\ntype = \"sphere\"\nmaterial = \"glas\"\n"),
        "no material named \"glas\"",
        (8, 12),
    );
    assert!(e.help.unwrap().contains("did you mean \"glass\""));
    fails(&format!("{CAMERA}[materials.glass]\nkt = 2\nktt = 1\n"), "unknown parameter `ktt`", (6, 1));
    fails(&format!("{CAMERA}[[object]]\ntype = \"sphere\"\nmaterial = {{ kd = 0.5, blur = 3 }}\n"), "out of range", (6, 31));
    fails(
        &format!("{CAMERA}[[object]]\ntype = \"sphere\"\nname = \"a\"\n[[object]]\ntype = \"sphere\"\nname = \"a\"\n"),
        "already used",
        (7, 1),
    );
}

#[test]
fn command_line_overrides_are_validated_and_do_not_trip_the_unused_check() {
    use raylab::load::context::Overrides;
    let src = format!("{CAMERA}[render]\nwidth = 640\nheight = 480\nspp = 4\nseed = 3\n");
    let opts = LoadOptions {
        overrides: Overrides { width: Some(32), height: Some(24), spp: Some(2), seed: Some(9), ..Default::default() },
        ..Default::default()
    };
    let job = load_str(&raylab_plugins::registry(), "t.toml", &src, Path::new("."), &opts).unwrap_or_else(|e| panic!("{}", e.report()));
    assert_eq!((job.settings.width, job.settings.height, job.settings.spp, job.settings.seed), (32, 24, 2, 9));
    // An invalid value in the file is still an error when overridden.
    let bad = format!("{CAMERA}[render]\nwidth = -5\n");
    let e = load_str(&raylab_plugins::registry(), "t.toml", &bad, Path::new("."), &opts).err().expect("error");
    assert!(e.message.contains("out of range"), "{}", e.report());
}

#[test]
fn scene_paths_cannot_leave_the_scene_folder() {
    let opts = LoadOptions::default();
    let ctx = raylab::LoadContext::new(Path::new(env!("CARGO_MANIFEST_DIR")), &opts);
    let src = raylab::Source::new("t.toml", "file = \"../x\"");
    let loc = raylab::param::error::Loc::new(&src, 7..13);
    assert!(ctx.resolve_path("../etc/passwd", &loc).unwrap_err().message.contains("leaves the scene's folder"));
    assert!(ctx.resolve_path("/etc/passwd", &loc).is_err());
    assert!(ctx.resolve_path("scenes/showcase.toml", &loc).is_ok());
    let permissive = LoadOptions { allow_outside_paths: true, ..Default::default() };
    let ctx = raylab::LoadContext::new(Path::new(env!("CARGO_MANIFEST_DIR")), &permissive);
    assert!(ctx.resolve_path("../shared", &loc).is_ok());
}

#[test]
fn every_bundled_scene_loads() {
    let meshes = raylab_plugins::registry().geometry("mesh").is_some();
    for e in std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")).unwrap() {
        let p = e.unwrap().path();
        // Scenes with meshes need the `mesh` feature (CI tests with --all-features).
        let needs_mesh = std::fs::read_to_string(&p).is_ok_and(|t| t.contains("type = \"mesh\""));
        if p.extension().is_some_and(|x| x == "toml") && (meshes || !needs_mesh) {
            raylab::load::loader::load_file(&raylab_plugins::registry(), &p, &LoadOptions::default())
                .unwrap_or_else(|e| panic!("{}", e.report()));
        }
    }
}

/// The catalogue of malformed scenes in tests/malformed/: each file's first line,
/// `# expect WHERE: MESSAGE`, is the error it must fail with. WHERE is `LINE:COL` in the scene file,
/// `budget` for a scene that loads but that the work budget stops before rendering,
/// or a file under tests/malformed (`assets/nan.obj:2:1`, `assets/cycle.gltf`) for errors inside a
/// mesh file; paths in the message are relative to tests/malformed. Scenes with meshes are checked
/// when the `mesh` feature is on.
#[test]
fn every_scene_in_the_malformed_catalogue_fails_as_its_first_line_says() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/malformed");
    let prefix = format!("{}/", dir.display());
    let registry = raylab_plugins::registry();
    let mut files: Vec<_> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|e| e == "toml")).collect();
    files.sort();
    assert!(files.len() >= 80, "the catalogue is missing");
    let mut wrong = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        if text.contains("type = \"mesh\"") && registry.geometry("mesh").is_none() {
            continue;
        }
        let expect =
            text.lines().next().and_then(|l| l.strip_prefix("# expect ")).unwrap_or_else(|| panic!("{}: no `# expect` line", f.display()));
        let (want_at, want) = expect.split_once(": ").unwrap();
        let name = f.file_name().unwrap().to_string_lossy();
        match raylab::load::loader::load_file(&registry, f, &LoadOptions::default()) {
            // A scene that loads must be stopped by the work budget before rendering (WHERE is
            // `budget`): the checks `raylab::render::render` makes first.
            Ok(job) => {
                let (w, h) = (job.settings.width, job.settings.height);
                let units = u64::from(w) * u64::from(h) * u64::from(job.settings.spp);
                match raylab::render::budget::check(&job, raylab::render::share::Share::whole(w, h), units) {
                    Ok(()) => wrong.push(format!("{name}: loaded, and the work budget lets it render")),
                    Err(message) if want_at == "budget" && message == want => {}
                    Err(message) => wrong.push(format!("{name}: expected {want_at}: {want}\n    got budget: {message}")),
                }
            }
            Err(e) => {
                let at = e.where_().unwrap_or_default().replace(&prefix, "");
                let at = at.strip_prefix(&format!("{name}:")).unwrap_or(&at).to_string();
                let message = e.message.replace(&prefix, "");
                if at != want_at || message != want {
                    wrong.push(format!("{name}: expected {want_at}: {want}\n    got {at}: {message}"));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
