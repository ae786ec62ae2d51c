//! The third hardening round (issue 26), run as a user would: no command writes over a file it
//! reads, output into a closed pipe ends quietly, and the work budget measures what a scene does.

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};

mod common;
use common::{raylab, repo, temp_dir, text};

/// A tiny scene with an image texture (`tex.png`, 2×2).
const TEXTURED: &str = "[render]\nwidth = 8\nheight = 6\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[textures.t]\ntype = \"image\"\nfile = \"tex.png\"\n[[object]]\ntype = \"sphere\"\nmaterial = { kd = \"t\" }\n";

fn write_texture(path: &Path) {
    image::RgbImage::from_fn(2, 2, |x, y| image::Rgb([(x * 200) as u8, (y * 200) as u8, 90])).save(path).unwrap();
}

/// Every spelling of `name` in `dir` that names the same file: bare, `./`, through a folder and
/// `..`, absolute, a symbolic link and a hard link (the links are made here).
fn spellings(dir: &Path, name: &str) -> Vec<String> {
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let ext = Path::new(name).extension().unwrap().to_str().unwrap();
    let (soft, hard) = (format!("soft-{name}.{ext}"), format!("hard-{name}.{ext}"));
    let _ = std::fs::remove_file(dir.join(&soft));
    let _ = std::fs::remove_file(dir.join(&hard));
    std::os::unix::fs::symlink(dir.join(name), dir.join(&soft)).unwrap();
    std::fs::hard_link(dir.join(name), dir.join(&hard)).unwrap();
    vec![name.into(), format!("./{name}"), format!("sub/../{name}"), dir.join(name).to_str().unwrap().into(), soft, hard]
}

/// `render -o` onto the scene, onto a texture the scene reads, onto `--reference`, and `tonemap`
/// onto its input, under every spelling: refused, the input unchanged, nothing written.
#[test]
fn render_and_tonemap_refuse_to_write_over_a_file_they_read() {
    let dir = temp_dir("overwrite");
    std::fs::write(dir.join("scene.toml"), TEXTURED).unwrap();
    write_texture(&dir.join("tex.png"));
    let tex = std::fs::read(dir.join("tex.png")).unwrap();
    for out in spellings(&dir, "tex.png") {
        let o = raylab(&dir, &["render", "scene.toml", "-o", &out, "-q"]);
        assert_eq!(o.status.code(), Some(1), "-o {out}: {}", text(&o.stdout));
        assert!(text(&o.stderr).contains("render would overwrite its input"), "-o {out}: {}", text(&o.stderr));
        assert_eq!(std::fs::read(dir.join("tex.png")).unwrap(), tex, "-o {out} changed the texture");
    }
    // `tonemap` reads HDR (.pfm, .exr) and writes 8-bit images: its input under an image's name.
    let o = raylab(&dir, &["render", "scene.toml", "-o", "in.pfm", "-q"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let pfm = std::fs::read(dir.join("in.pfm")).unwrap();
    std::os::unix::fs::symlink(dir.join("in.pfm"), dir.join("in-soft.png")).unwrap();
    std::fs::hard_link(dir.join("in.pfm"), dir.join("in-hard.png")).unwrap();
    for out in ["in-soft.png", "./in-hard.png"] {
        let o = raylab(&dir, &["tonemap", "in.pfm", "-o", out]);
        assert_eq!(o.status.code(), Some(1), "tonemap -o {out}: {}", text(&o.stdout));
        assert!(text(&o.stderr).contains("tonemap would overwrite its input"), "tonemap -o {out}: {}", text(&o.stderr));
        assert_eq!(std::fs::read(dir.join("in.pfm")).unwrap(), pfm, "tonemap -o {out} changed its input");
    }
    // The scene itself, through a link with an image's name (the format is known, the target is not).
    std::os::unix::fs::symlink(dir.join("scene.toml"), dir.join("scene-link.png")).unwrap();
    let o = raylab(&dir, &["render", "scene.toml", "-o", "scene-link.png", "-q"]);
    assert!(text(&o.stderr).contains("render would overwrite its input \"scene.toml\""), "{}", text(&o.stderr));
    assert_eq!(std::fs::read_to_string(dir.join("scene.toml")).unwrap(), TEXTURED);
    // Another file is written as before.
    let o = raylab(&dir, &["render", "scene.toml", "-o", "out.png", "-q"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    // The reference image, and the image written on interruption (`NAME.partial.EXT`).
    let o = raylab(&dir, &["render", "scene.toml", "-o", "ref.png", "--reference", "./out.png", "-q"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let o = raylab(&dir, &["render", "scene.toml", "-o", "out.png", "--reference", "./out.png", "-q"]);
    assert!(text(&o.stderr).contains("would overwrite its input \"./out.png\""), "{}", text(&o.stderr));
    std::fs::copy(dir.join("ref.png"), dir.join("x.partial.png")).unwrap();
    let o = raylab(&dir, &["render", "scene.toml", "-o", "x.png", "--reference", "x.partial.png", "-q"]);
    assert!(text(&o.stderr).contains("would overwrite its input \"x.partial.png\""), "{}", text(&o.stderr));
    let o = raylab(&dir, &["tonemap", "in.pfm", "-o", "mapped.png"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `render -o` onto a mesh the scene reads (through a link with an image's name).
#[cfg(feature = "mesh")]
#[test]
fn render_refuses_to_write_over_a_mesh_it_reads() {
    let dir = temp_dir("overwrite-mesh");
    std::fs::copy(repo().join("tests/assets/cube.obj"), dir.join("cube.obj")).unwrap();
    std::fs::copy(repo().join("tests/assets/cube.mtl"), dir.join("cube.mtl")).unwrap();
    let scene = "[render]\nwidth = 8\nheight = 6\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"mesh\"\nfile = \"cube.obj\"\n";
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    let mesh = std::fs::read(dir.join("cube.obj")).unwrap();
    std::os::unix::fs::symlink(dir.join("cube.obj"), dir.join("soft.png")).unwrap();
    std::fs::hard_link(dir.join("cube.obj"), dir.join("hard.png")).unwrap();
    for out in ["soft.png", "hard.png"] {
        let o = raylab(&dir, &["render", "scene.toml", "-o", out, "-q"]);
        assert!(text(&o.stderr).contains("render would overwrite its input"), "-o {out}: {}", text(&o.stderr));
        assert_eq!(std::fs::read(dir.join("cube.obj")).unwrap(), mesh, "-o {out} changed the mesh");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// `merge a0.exr a1.exr -o a0.exr` (any spelling) is refused and both parts survive.
#[cfg(feature = "exr")]
#[test]
fn merge_refuses_to_write_over_one_of_its_parts() {
    let dir = temp_dir("overwrite-merge");
    std::fs::write(dir.join("scene.toml"), TEXTURED).unwrap();
    write_texture(&dir.join("tex.png"));
    for k in 0..2 {
        let part = format!("a{k}.exr");
        let o = raylab(&dir, &["render", "scene.toml", "--tile", &format!("{k}/2"), "-o", &part, "-q"]);
        assert!(o.status.success(), "{}", text(&o.stderr));
    }
    let a0 = std::fs::read(dir.join("a0.exr")).unwrap();
    for out in spellings(&dir, "a0.exr") {
        let o = raylab(&dir, &["merge", "a0.exr", "a1.exr", "-o", &out]);
        assert_eq!(o.status.code(), Some(1), "-o {out}: {}", text(&o.stdout));
        assert!(text(&o.stderr).contains("merge would overwrite its input \"a0.exr\""), "-o {out}: {}", text(&o.stderr));
        assert_eq!(std::fs::read(dir.join("a0.exr")).unwrap(), a0, "-o {out} changed the part");
    }
    let o = raylab(&dir, &["merge", "a0.exr", "a1.exr", "-o", "whole.png"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// Output into a pipe whose reader has gone ends the command quietly (SIGPIPE, as `head` expects),
/// never with a panic: `trace` (long output), `plugins` and a render's summary line.
#[test]
fn a_closed_pipe_ends_every_printing_command_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let dir = temp_dir("pipe");
    std::fs::write(dir.join("scene.toml"), TEXTURED).unwrap();
    write_texture(&dir.join("tex.png"));
    let cornell = repo().join("scenes/path-cornell.toml");
    let cases: Vec<Vec<&str>> = vec![
        vec!["trace", cornell.to_str().unwrap(), "--pixel", "250,320"],
        vec!["trace", cornell.to_str().unwrap(), "--pixel", "250,320", "--json"],
        vec!["plugins"],
        vec!["render", "scene.toml", "-o", "out.png", "-q"],
    ];
    for args in cases {
        // The reader gone before the first line is written (`head` after its lines): every write
        // meets a closed pipe.
        let mut child = Command::new(env!("CARGO_BIN_EXE_raylab"))
            .args(&args)
            .current_dir(&dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let mut err = String::new();
        child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
        let status = child.wait().unwrap();
        assert!(status.success() || status.signal() == Some(libc_sigpipe()), "{args:?}: {status:?}, stderr: {err}");
        assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{args:?}: {err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// SIGPIPE's number (13 on every Unix raylab builds on).
fn libc_sigpipe() -> i32 {
    13
}

mod budget {
    use raylab::load::context::{LoadOptions, Overrides};
    use raylab::load::loader::{load_file, load_str};
    use raylab::param::value::{Node, Value};
    use raylab::render::budget::{Estimate, check};
    use raylab::render::share::Share;
    use raylab::render::{RenderJob, RenderOptions, render};
    use std::path::Path;

    fn repo() -> std::path::PathBuf {
        super::repo()
    }

    fn node(v: Value) -> Node {
        let src = raylab::param::error::Source::new("test", "");
        Node { value: v, loc: raylab::param::error::Loc::new(&src, 0..0) }
    }

    fn load(path: &Path, overrides: Overrides) -> RenderJob {
        load_file(&raylab_plugins::registry(), path, &LoadOptions { overrides, ..LoadOptions::default() })
            .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.report()))
    }

    /// The whole frame's pixel samples (stratified) or pixels (adaptive).
    fn units(job: &RenderJob) -> u64 {
        let s = job.settings;
        let pixels = u64::from(s.width) * u64::from(s.height);
        match s.aa {
            raylab::render::Antialiasing::Stratified => pixels * u64::from(s.spp),
            raylab::render::Antialiasing::Adaptive(_) => pixels,
        }
    }

    fn check_frame(job: &RenderJob) -> Result<(), String> {
        check(job, Share::whole(job.settings.width, job.settings.height), units(job))
    }

    /// A mirror sphere and a glass sphere over a reflecting floor at the course's recursion depth
    /// of 64 (the old budget estimated 10²³ rays and refused it): its bound now holds the default
    /// budget without a pilot, it renders, and each camera ray traces far fewer rays than bounded.
    #[test]
    fn a_mirror_and_a_glass_sphere_at_depth_64_render_with_the_default_budget() {
        let path = repo().join("tests/assets/mirror-glass-depth64.toml");
        let job = load(&path, Overrides::default());
        let e = Estimate::of(&job, units(&job));
        println!("bound {:.3e} rays ({:.3e} a camera ray)", e.bound(), e.rays_per_camera_ray);
        assert!(e.bound() <= job.max_rays as f64, "bound {:.3e}", e.bound());
        check_frame(&job).unwrap();
        let small = load(&path, Overrides { width: Some(60), height: Some(60), ..Overrides::default() });
        let r = render(&small, &RenderOptions::default(), &|_, _| {}).unwrap();
        assert!(r.complete && r.budget_stop.is_none());
        let per_camera_ray = r.stats.total_rays() as f64 / r.stats.camera_rays as f64;
        assert!(per_camera_ray < 16.0 && per_camera_ray <= e.rays_per_camera_ray, "{per_camera_ray} rays a camera ray");
    }

    /// The course scenes: the XML test scenes, the report's, and a mirror and a glass sphere at
    /// depth 64 (as three of the course's test scenes are).
    fn course_scenes() -> Vec<std::path::PathBuf> {
        let mut scenes: Vec<_> = std::fs::read_dir(repo().join("tests/assets/course")).unwrap().map(|e| e.unwrap().path()).collect();
        for e in std::fs::read_dir(repo().join("scenes")).unwrap() {
            let p = e.unwrap().path();
            if p.file_name().unwrap().to_str().unwrap().starts_with("report-") {
                scenes.push(p);
            }
        }
        scenes.push(repo().join("tests/assets/mirror-glass-depth64.toml"));
        scenes.sort();
        assert!(scenes.len() >= 10, "{scenes:?}");
        scenes
    }

    /// Every course scene loads and passes the budget with the default limits, as given and at
    /// the course's recursion depth of 64.
    #[test]
    fn every_course_scene_passes_the_default_budget_even_at_depth_64() {
        for p in &course_scenes() {
            for depth in [None, Some(64)] {
                let job = load(p, Overrides { depth: depth.map(|d| node(Value::Int(d))), ..Overrides::default() });
                check_frame(&job).unwrap_or_else(|e| panic!("{} at depth {depth:?}: {e}", p.display()));
            }
        }
    }

    /// Every course scene renders to its end at its full size with the default limits, at the
    /// course's recursion depth of 64 (at least the rays of its own depth), the budget counted as
    /// it traces.
    #[test]
    fn every_course_scene_renders_with_the_default_limits_at_depth_64() {
        for p in &course_scenes() {
            let job = load(p, Overrides { depth: Some(node(Value::Int(64))), ..Overrides::default() });
            let r = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            assert!(r.complete && r.budget_stop.is_none(), "{}: stopped after {:?} rays", p.display(), r.budget_stop);
            println!(
                "{}: {} rays, {:.2} a camera ray",
                p.display(),
                r.stats.total_rays(),
                r.stats.total_rays() as f64 / r.stats.camera_rays as f64
            );
        }
    }

    /// `scenes/dozen.toml` at 256 spp (a reference render) and with adaptive anti-aliasing at depth
    /// 4, both at 800×600: accepted (the old estimate, 2.1·10¹¹ and 2.4·10¹¹, refused both).
    #[test]
    fn dozen_at_256_spp_and_adaptive_depth_4_are_accepted() {
        let path = repo().join("scenes/dozen.toml");
        let spp = load(&path, Overrides { spp: Some(256), ..Overrides::default() });
        let adaptive = load(
            &path,
            Overrides {
                render_params: vec![("aa".into(), node(Value::Str("adaptive".into()))), ("aa_depth".into(), node(Value::Int(4)))],
                ..Overrides::default()
            },
        );
        for job in [&spp, &adaptive] {
            let e = Estimate::of(job, units(job));
            println!("{}: bound {:.3e} rays ({:.3} a camera ray)", job.settings.describe_sampling(), e.bound(), e.rays_per_camera_ray);
            assert!(e.bound() <= job.max_rays as f64);
            check_frame(job).unwrap();
        }
        // One sample per pixel measured: the bound holds it (18 rays a camera ray: five bounces,
        // two lights).
        let small = load(&path, Overrides { width: Some(80), height: Some(60), ..Overrides::default() });
        let r = render(&small, &RenderOptions::default(), &|_, _| {}).unwrap();
        let e = Estimate::of(&small, units(&small));
        assert!((r.stats.total_rays() as f64) <= e.bound(), "{} > {:.3e}", r.stats.total_rays(), e.bound());
    }

    /// Every surface splits (kr = kt = 0.5) and nothing is pruned, at depth 64: 2⁶⁵ rays a camera
    /// ray at worst. The pilot stops within its share of the budget (64 pixels' share of 10¹¹
    /// for 4·10⁶ pixels: 1.6·10⁶ rays), and the advice never names a --max-rays the flag refuses.
    #[test]
    fn a_scene_made_to_explode_is_stopped_by_the_pilot_with_advice_that_can_be_followed() {
        let text = "[render]\nwidth = 2000\nheight = 2000\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n\
                    [integrator]\ntype = \"phong\"\nmax_depth = 64\nprune_threshold = 0\n\
                    [materials.split]\nkd = 0.1\nkr = 0.5\nkt = 0.5\n\
                    [[object]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 100\nmaterial = \"split\"\n\
                    [[object]]\ntype = \"sphere\"\ncenter = [0, 0, -3]\nradius = 1\nmaterial = \"split\"\n";
        let job = load_str(&raylab_plugins::registry(), "explode.toml", text, Path::new("."), &LoadOptions::default()).unwrap();
        let e = Estimate::of(&job, units(&job));
        assert!(e.bound() > 1e25, "{:.3e}", e.bound());
        let t0 = std::time::Instant::now();
        let err = check_frame(&job).unwrap_err();
        println!("{err} ({:.2} s)", t0.elapsed().as_secs_f64());
        assert!(err.contains("a pilot of") && err.contains("ran out of its share of the work budget"), "{err}");
        assert!(err.contains("--set prune_threshold") && err.contains("--depth"), "{err}");
        // A --max-rays in the advice is one the flag accepts.
        for word in err.split(|c: char| !c.is_ascii_digit()) {
            if word.len() >= 20 {
                assert!(word.parse::<u64>().is_ok(), "{word} is beyond --max-rays: {err}");
            }
        }
    }

    /// The budget is enforced as rays are traced: a render the pilot cannot judge (the whole frame
    /// is smaller than a pilot) stops once its tiles spent the budget, keeps the tiles done, and
    /// says how many rays it traced; within the budget, the image is the same bits.
    #[test]
    fn the_budget_is_enforced_while_rendering() {
        let text = "[render]\nwidth = 8\nheight = 6\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n\
                    [integrator]\ntype = \"phong\"\nmax_depth = 40\nprune_threshold = 0\n\
                    [materials.split]\nkd = 0.1\nkr = 0.5\nkt = 0.5\n\
                    [[object]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 100\nmaterial = \"split\"\n\
                    [[object]]\ntype = \"sphere\"\ncenter = [0, 0, -3]\nradius = 1\nmaterial = \"split\"\n";
        let limits = raylab::param::limits::Limits { max_rays: 100_000, ..Default::default() };
        let opts = LoadOptions { limits, ..LoadOptions::default() };
        let job = load_str(&raylab_plugins::registry(), "explode.toml", text, Path::new("."), &opts).unwrap();
        let r = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap();
        let traced = r.budget_stop.expect("stopped by the budget");
        assert!(!r.complete);
        assert!(traced > 100_000 && traced <= 100_000 * (1 + rayon::current_num_threads() as u64), "{traced}");
        // Within a budget, the same image as without one.
        let text = text.replace("max_depth = 40", "max_depth = 6");
        let unlimited = raylab::param::limits::Limits::unlimited();
        let free = load_str(
            &raylab_plugins::registry(),
            "t.toml",
            &text,
            Path::new("."),
            &LoadOptions { limits: unlimited, ..LoadOptions::default() },
        )
        .unwrap();
        let bounded = load_str(&raylab_plugins::registry(), "t.toml", &text, Path::new("."), &opts).unwrap();
        let (a, b) = (
            render(&free, &RenderOptions::default(), &|_, _| {}).unwrap(),
            render(&bounded, &RenderOptions::default(), &|_, _| {}).unwrap(),
        );
        assert!(b.complete && b.budget_stop.is_none());
        assert_eq!(a.film.pixels, b.film.pixels);
    }
}

/// The command line: a refusal before rendering counts the camera rays; a render stopped by the
/// budget writes the image so far and says what it traced; `trace` of one pixel is never refused
/// by the whole frame's budget.
#[test]
fn the_budget_on_the_command_line() {
    let dir = temp_dir("budget");
    std::fs::write(dir.join("scene.toml"), TEXTURED).unwrap();
    write_texture(&dir.join("tex.png"));
    let o = raylab(&dir, &["render", "scene.toml", "--spp", "4", "--max-rays", "100"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("at least 192 camera rays") && err.contains("--max-rays 192"), "{err}");
    assert!(!dir.join("render.png").exists());
    let o = raylab(&dir, &["trace", "scene.toml", "--spp", "4", "--max-rays", "100", "--pixel", "4,3"]);
    assert!(o.status.success(), "one pixel is not the frame: {}", text(&o.stderr));
    let explode = "[render]\nwidth = 8\nheight = 6\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n[integrator]\ntype = \"phong\"\nmax_depth = 40\nprune_threshold = 0\n[[object]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 100\nmaterial = { kd = 0.1, kr = 0.5, kt = 0.5 }\n[[object]]\ntype = \"sphere\"\ncenter = [0, 0, -3]\nradius = 1\nmaterial = { kd = 0.1, kr = 0.5, kt = 0.5 }\n";
    std::fs::write(dir.join("explode.toml"), explode).unwrap();
    let o = raylab(&dir, &["render", "explode.toml", "-o", "e.png", "--max-rays", "20000", "-q"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("stopped by the work budget") && err.contains("rays traced, over --max-rays 20000"), "{err}");
    assert!(dir.join("e.partial.png").exists() && !dir.join("e.png").exists());
    // Its explanation is cut at a size one can read, with a note.
    let o = raylab(&dir, &["trace", "explode.toml", "--pixel", "4,3"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("stopped: the rays allowed"), "the cut is noted");
    std::fs::remove_dir_all(dir).unwrap();
}
