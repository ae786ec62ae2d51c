//! The farm flow through the real binary: tiles and sample passes rendered as separate processes
//! (by GNU parallel, as a scheduler would run them) merge to the bits of one render; a render
//! killed with SIGKILL right after a checkpoint resumes to the same bits; hostile partial files are
//! refused with clear errors.
#![cfg(feature = "exr")]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::raylab;

fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes").join(name).display().to_string()
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("raylab-farm-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ok(out: &Output) {
    assert!(out.status.success(), "{}\n{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
}

const SIZE: [&str; 6] = ["--width", "96", "--height", "72", "--spp", "3"];

#[test]
fn gnu_parallel_renders_tiles_and_passes_that_merge_to_one_render() {
    if Command::new("parallel").arg("--version").output().map_or(true, |o| !o.status.success()) {
        raylab::testing::missing_tool(
            "gnu_parallel_renders_tiles_and_passes_that_merge_to_one_render",
            "GNU parallel",
            "apt-get install parallel",
        );
        return;
    }
    let dir = temp("parallel");
    let s = scene("quality.toml");
    let bin = env!("CARGO_BIN_EXE_raylab");
    ok(&raylab(&dir, &[&["render", &s, "-o", "whole.exr", "-q", "--aov", "depth,normal,albedo,emission"][..], &SIZE].concat()));
    // 4 tiles × 2 sample passes = 8 processes, two at a time.
    let cmd =
        format!("{bin} render {s} -q --aov depth,normal,albedo {} --tile {{1}}/4 --pass {{2}}/2 -o part-{{1}}-{{2}}.exr", SIZE.join(" "));
    let out = Command::new("parallel")
        .args(["-j", "2", "--halt", "now,fail=1", &cmd, ":::", "0", "1", "2", "3", ":::", "0", "1"])
        .current_dir(&dir)
        .output()
        .unwrap();
    ok(&out);
    let mut parts: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("part-"))
        .collect();
    parts.sort();
    assert_eq!(parts.len(), 8);
    let args: Vec<&str> = ["merge"].into_iter().chain(parts.iter().map(String::as_str)).chain(["-o", "merged.exr"]).collect();
    ok(&raylab(&dir, &args));
    assert_eq!(
        std::fs::read(dir.join("whole.exr")).unwrap(),
        std::fs::read(dir.join("merged.exr")).unwrap(),
        "bit-identical EXR, layers included"
    );
    // One part missing: a clear error.
    let args: Vec<&str> = ["merge"].into_iter().chain(parts.iter().skip(1).map(String::as_str)).chain(["-o", "x.png"]).collect();
    let out = raylab(&dir, &args);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("without all their samples"));
    std::fs::remove_dir_all(dir).unwrap();
}

/// How long a child may take to reach the event a test waits for (a loaded machine is slow).
const PATIENCE: std::time::Duration = std::time::Duration::from_secs(300);

/// Waits until `event` holds, watching `child`: panics with its output if it exits first (the
/// wrong error, early), or after [`PATIENCE`].
fn wait_for(child: &mut std::process::Child, what: &str, event: impl Fn() -> bool) {
    let start = std::time::Instant::now();
    while !event() {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            if let Some(mut e) = child.stderr.take() {
                let _ = std::io::Read::read_to_string(&mut e, &mut err);
            }
            panic!("raylab exited ({status}) before {what}: {err}");
        }
        assert!(start.elapsed() < PATIENCE, "raylab did not reach {what} within {PATIENCE:?}");
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

/// The identity of the file at `path` (a checkpoint is replaced by a rename: a new inode each
/// time), or `None` while there is none.
fn identity(path: &Path) -> Option<(u64, std::time::SystemTime)> {
    let m = std::fs::metadata(path).ok()?;
    #[cfg(unix)]
    let ino = std::os::unix::fs::MetadataExt::ino(&m);
    #[cfg(not(unix))]
    let ino = m.len();
    Some((ino, m.modified().ok()?))
}

/// Killed with SIGKILL right after its first and after its third checkpoint (events, not a
/// clock), resumed: the image is the uninterrupted render's, bit for bit, and the resumed run
/// did continue a part-done render (the kill came before the end).
#[test]
fn a_render_killed_after_a_checkpoint_resumes_to_the_same_image() {
    let dir = temp("kill");
    let s = scene("quality.toml");
    let size = ["--width", "300", "--height", "225", "--spp", "2", "--threads", "2"];
    ok(&raylab(&dir, &[&["render", &s, "-o", "whole.png", "-q"][..], &size].concat()));
    for checkpoints in [1, 3] {
        let _ = std::fs::remove_file(dir.join("resumed.png"));
        let state = dir.join("state.exr");
        let mut child = Command::new(env!("CARGO_BIN_EXE_raylab"))
            .args(
                [&["render", &s, "-o", "resumed.png", "-q", "--checkpoint", "state.exr", "--checkpoint-every", "0.05"][..], &size].concat(),
            )
            .current_dir(&dir)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let mut seen = None;
        for k in 1..=checkpoints {
            let last = seen;
            wait_for(&mut child, &format!("checkpoint {k}"), || identity(&state).is_some_and(|id| Some(id) != last));
            seen = identity(&state);
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        assert!(
            !dir.join("resumed.png").exists(),
            "the render finished before it was killed after checkpoint {checkpoints}: give it more work"
        );
        let out = raylab(&dir, &["render", "--resume", "state.exr"]);
        ok(&out);
        assert_eq!(
            std::fs::read(dir.join("whole.png")).unwrap(),
            std::fs::read(dir.join("resumed.png")).unwrap(),
            "killed after checkpoint {checkpoints}"
        );
        assert!(!state.exists(), "the checkpoint is removed once the render is done");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_changed_scene_is_not_resumed() {
    let dir = temp("changed");
    std::fs::copy(scene("dozen.toml"), dir.join("s.toml")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args([
            "render",
            "s.toml",
            "-o",
            "a.png",
            "-q",
            "--width",
            "300",
            "--height",
            "200",
            "--spp",
            "8",
            "--checkpoint",
            "c.exr",
            "--checkpoint-every",
            "0.05",
        ])
        .current_dir(&dir)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    wait_for(&mut child, "its first checkpoint", || dir.join("c.exr").exists());
    child.kill().unwrap();
    child.wait().unwrap();
    let text = std::fs::read_to_string(dir.join("s.toml")).unwrap().replace("seed = 0", "seed = 1");
    std::fs::write(dir.join("s.toml"), if text.contains("seed = 1") { text } else { text + "\n# changed\n" }).unwrap();
    let out = raylab(&dir, &["render", "--resume", "c.exr"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("another render"), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn share_options_are_checked() {
    let dir = temp("args");
    let s = scene("dozen.toml");
    let fails = |args: &[&str], needle: &str| {
        let out = raylab(&dir, args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(needle), "{args:?}: {err}");
    };
    fails(&["render", &s, "--tile", "0/4", "-o", "t.png"], "partial image");
    fails(&["render", &s, "--tile", "4/4", "-o", "t.exr"], "expected I/N");
    fails(&["render", &s, "--crop", "0,900,0,10", "-o", "t.exr"], "--crop");
    fails(&["render", &s, "--crop", "0,10,0,10", "--tile", "0/2", "-o", "t.exr"], "not both");
    let out = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", &s, "--tile", "auto", "-o", "t.exr"])
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("neither SLURM_ARRAY_TASK_ID"));
    // --tile auto under a Kubernetes Indexed Job.
    let out = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args([&["render", &s, "--tile", "auto", "-o", "k.exr", "-q"][..], &SIZE].concat())
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env("JOB_COMPLETION_INDEX", "1")
        .env("RAYLAB_TILE_COUNT", "3")
        .current_dir(&dir)
        .output()
        .unwrap();
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("partial image: pixels [0, 96)"));
    std::fs::remove_dir_all(dir).unwrap();
}

/// A partial that claims a frame of 10⁵ × 10⁵ pixels is refused from its header.
#[test]
fn a_partial_claiming_a_huge_frame_is_refused_before_decoding() {
    use raylab::render::share::{Rect, Sampling, Share, ShareSums};
    let dir = temp("huge");
    let share = Share { bounds: Rect { x0: 0, y0: 0, x1: 2, y1: 2 }, pass: 0, passes: 1 };
    let sums = ShareSums {
        width: 100_000,
        height: 100_000,
        sampling: Sampling { spp: 1, adaptive: false, target: None, subpixels: 1 },
        share,
        pixels: vec![Default::default(); 4],
        layers: None,
    };
    let info =
        raylab::image::partial::PartialInfo { fingerprint: "0".repeat(32), sampling: String::new(), encoding: "srgb".into(), resume: None };
    raylab::image::partial::write_partial(&dir.join("huge.exr"), &sums, &info).unwrap();
    let out = raylab(&dir, &["merge", "huge.exr", "-o", "x.png"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("exceeds the limit"), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}
