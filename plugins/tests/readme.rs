//! The README's commands work as written, and what it shows of the tutorial's scenes is what the
//! files hold. Every `raylab …` line of its `sh` blocks runs (at a small image size, in a copy of
//! `scenes/`), in order, so a command that reads what an earlier one wrote finds it; only the
//! live view, which serves until stopped, is left out. The install command and the `cargo` lines
//! build what this test already runs.
#![cfg(all(feature = "mesh", feature = "bvh", feature = "exr"))]

use std::path::Path;
use std::process::Command;

mod common;
use common::repo;

/// The image width the README's render commands are run at (the height follows the scene's
/// aspect ratio).
const SMALL_WIDTH: &str = "48";

fn readme() -> String {
    std::fs::read_to_string(repo().join("README.md")).unwrap()
}

/// The fenced blocks of `lang` in `text`, each with the paragraph just before it.
fn blocks(text: &str, lang: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut lines = text.lines();
    let mut before = String::new();
    let mut blank = true;
    while let Some(line) = lines.next() {
        if line.trim_start() == format!("```{lang}") {
            let mut body = String::new();
            for l in lines.by_ref() {
                if l.trim_start().starts_with("```") {
                    break;
                }
                body.push_str(l);
                body.push('\n');
            }
            out.push((before.clone(), body));
        } else if line.trim().is_empty() {
            blank = true;
        } else {
            if blank {
                before.clear();
            }
            before.push_str(line);
            before.push('\n');
            blank = false;
        }
    }
    out
}

/// The README's `raylab` commands, in order, without their comments.
fn commands() -> Vec<String> {
    let text = readme();
    let mut out = Vec::new();
    for (_, body) in blocks(&text, "sh") {
        for line in body.lines() {
            let line = line.split(" # ").next().unwrap().trim();
            if line.starts_with("raylab ") {
                out.push(line.to_string());
            }
        }
    }
    out
}

/// `cmd` at a small size: renders and sweeps get `--width SMALL_WIDTH` (replacing a width
/// given); a resume continues the render as it was started.
fn small(cmd: &str) -> Vec<String> {
    let mut words: Vec<String> = cmd.split_whitespace().skip(1).map(str::to_string).collect();
    let sized = matches!(words[0].as_str(), "render" | "sweep") && !words.iter().any(|w| w == "--resume");
    if sized {
        match words.iter().position(|w| w == "--width") {
            Some(i) => words[i + 1] = SMALL_WIDTH.to_string(),
            None => words.extend(["--width".to_string(), SMALL_WIDTH.to_string()]),
        }
    }
    if words[0] == "bench" {
        words.extend(["--width", "64", "--height", "48"].map(str::to_string));
    }
    // `trace` keeps the scene's size: its pixel is one of the full-size image (one pixel's cost).
    words
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn every_readme_command_runs_as_written() {
    let dir = std::env::temp_dir().join(format!("raylab-readme-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    copy_dir(&repo().join("scenes"), &dir.join("scenes"));
    let cmds = commands();
    assert!(cmds.len() >= 15, "the README's commands were not found: {cmds:?}");
    let mut ran = 0;
    for cmd in &cmds {
        if cmd.starts_with("raylab view") {
            continue; // serves until stopped; plugins/tests/view.rs drives it
        }
        let args = small(cmd);
        if let Some(i) = args.iter().position(|a| a == "--resume")
            && !dir.join(&args[i + 1]).exists()
        {
            // The README's resume follows an interrupted render (a finished one removes its
            // checkpoint); plugins/tests/farm.rs kills a render and resumes it.
            continue;
        }
        let out = Command::new(env!("CARGO_BIN_EXE_raylab")).args(&args).current_dir(&dir).output().expect("raylab runs");
        assert!(
            out.status.success(),
            "the README's `{cmd}` (run as `raylab {}`) failed:\n{}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        ran += 1;
    }
    assert!(ran >= 15);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Each TOML block of "Your first scene" is a contiguous run of lines of the scene file named
/// just before it: what the reader copies is what the bundled file renders.
#[test]
fn the_tutorials_excerpts_are_the_scene_files() {
    let text = readme();
    let start = text.find("## Your first scene").expect("the tutorial section");
    let end = start + text[start + 3..].find("\n## ").expect("a section after it");
    let section = &text[start..end];
    let excerpts = blocks(section, "toml");
    assert!(excerpts.len() >= 3, "the tutorial shows its scenes");
    for (before, body) in excerpts {
        let file = before
            .split('`')
            .find(|w| w.starts_with("scenes/") && w.ends_with(".toml"))
            .unwrap_or_else(|| panic!("no `scenes/….toml` named before the excerpt:\n{before}"));
        let scene = std::fs::read_to_string(repo().join(file)).unwrap();
        assert!(scene.contains(&body), "README's excerpt of {file} is not a contiguous part of it:\n{body}");
    }
}

/// The error the tutorial shows is the one raylab prints for that typo.
#[test]
fn the_tutorials_error_is_what_raylab_prints() {
    let text = readme();
    let shown = blocks(&text, "text")
        .into_iter()
        .find_map(|(_, b)| b.lines().next().filter(|l| l.starts_with("error: scenes/first.toml")).map(str::to_string))
        .expect("the tutorial's error");
    let dir = std::env::temp_dir().join(format!("raylab-readme-error-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("scenes")).unwrap();
    let scene = std::fs::read_to_string(repo().join("scenes/first.toml")).unwrap();
    std::fs::write(dir.join("scenes/first.toml"), scene.replacen("radius = 1", "raduis = 1", 1)).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_raylab")).args(["render", "scenes/first.toml"]).current_dir(&dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(stderr.lines().next().unwrap_or(""), shown, "full message:\n{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The README's length limit: history and details go to `docs/`.
const MAX_README_LINES: usize = 400;

/// The README stays short, and every file it links to exists.
#[test]
fn the_readme_is_short_and_its_links_resolve() {
    let text = readme();
    let n = text.lines().count();
    assert!(n < MAX_README_LINES, "README.md has {n} lines; keep it under {MAX_README_LINES} (move details to docs/)");
    for link in text.split("](").skip(1) {
        let target = link.split(')').next().unwrap_or("");
        let file = target.split('#').next().unwrap_or("");
        if file.is_empty() || file.contains("://") {
            continue;
        }
        assert!(repo().join(file).exists(), "README.md links to {target}, which does not exist");
    }
}
