//! Every image in `docs/` is listed in `docs/images.toml` with what makes it, and every image
//! made from renders or sources is current: its recorded fingerprint is that of the renders it
//! shows (`raylab fingerprint`: the scene, the files it reads, the settings off their
//! defaults), of those scenes' golden images (re-blessed whenever shading changes) and of its
//! sources. Nothing is rendered.
//! `python3 scripts/docs-images.py` remakes the images and records the fingerprints (through
//! this test, with `RAYLAB_BLESS` set to the images it made, comma-separated, or to 1 for all).
#![cfg(feature = "mesh")]

use raylab::param::fingerprint::Fingerprint;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

fn strings(v: &toml::Value) -> Vec<String> {
    v.as_array().unwrap().iter().map(|s| s.as_str().unwrap().to_string()).collect()
}

/// `raylab fingerprint ARGS`, run from the top of the checkout.
fn render_fingerprint(args: &[String]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_raylab")).arg("fingerprint").args(args).current_dir(repo()).output().unwrap();
    assert!(out.status.success(), "raylab fingerprint {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap().trim().to_string()
}

/// The fingerprint of what makes an image: its renders, their scenes' golden images, its sources.
fn fingerprint(entry: &toml::Table) -> String {
    let mut f = Fingerprint::default();
    let mut renders: Vec<Vec<String>> =
        entry.get("render").map(|r| r.as_array().unwrap().iter().map(strings).collect()).unwrap_or_default();
    renders.extend(entry.get("view").map(strings));
    for (k, args) in renders.iter().enumerate() {
        f.add(&format!("render {k}"), render_fingerprint(args).as_bytes());
        let stem = Path::new(&args[0]).file_stem().unwrap().to_string_lossy().to_string();
        if let Ok(golden) = std::fs::read(repo().join("tests/golden").join(format!("{stem}.png"))) {
            f.add(&format!("golden {k}"), &golden);
        }
    }
    for s in entry.get("sources").map(strings).unwrap_or_default() {
        let bytes = std::fs::read(repo().join(&s)).unwrap_or_else(|e| panic!("{s}: {e}"));
        f.add(&format!("source {s}"), &bytes);
    }
    f.hex()
}

#[test]
fn every_docs_image_is_listed_and_current() {
    let path = repo().join("docs/images.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let manifest: toml::Table = text.parse().unwrap();
    let entries: Vec<&toml::Table> = manifest["image"].as_array().unwrap().iter().map(|e| e.as_table().unwrap()).collect();
    let listed: Vec<&str> = entries.iter().map(|e| e["file"].as_str().unwrap()).collect();
    let mut problems = Vec::new();
    for f in std::fs::read_dir(repo().join("docs")).unwrap() {
        let name = f.unwrap().file_name().to_string_lossy().to_string();
        let image = ["png", "svg", "jpg"].iter().any(|e| name.ends_with(&format!(".{e}")));
        if image && !listed.contains(&name.as_str()) {
            problems.push(format!("docs/{name} is not in docs/images.toml: say what makes it"));
        }
    }
    let bless = std::env::var("RAYLAB_BLESS").ok();
    let blessed = |file: &str| bless.as_deref().is_some_and(|b| b == "1" || b.split(',').any(|f| f == file));
    let mut computed = std::collections::BTreeMap::new();
    for e in &entries {
        let file = e["file"].as_str().unwrap();
        if !repo().join("docs").join(file).is_file() {
            problems.push(format!("docs/{file} is listed in docs/images.toml but missing"));
        }
        if e.get("record").and_then(toml::Value::as_bool) == Some(true) {
            assert!(e.contains_key("made_by"), "{file}: a record says what made it");
            continue;
        }
        let now = fingerprint(e);
        let recorded = e.get("fingerprint").and_then(toml::Value::as_str).unwrap_or("");
        if bless.is_none() && now != recorded {
            problems.push(format!(
                "docs/{file} is stale: the scene, a file it reads, its settings, its golden image or a source changed since it was made \
                 (fingerprint {recorded:?}, now {now:?}); run `python3 scripts/docs-images.py --only {file}`"
            ));
        }
        if blessed(file) {
            computed.insert(file.to_string(), now);
        }
    }
    if bless.is_some() {
        // Rewrite each entry's `fingerprint = "…"` line, keeping the rest of the file as written.
        let mut current = String::new();
        let mut out = String::new();
        let mut written = std::collections::BTreeSet::new();
        for line in text.lines() {
            if let Some(f) = line.strip_prefix("file = ") {
                current = f.trim_matches('"').to_string();
            }
            match computed.get(&current) {
                Some(fp) if line.starts_with("fingerprint = ") => {
                    out.push_str(&format!("fingerprint = \"{fp}\""));
                    written.insert(current.clone());
                }
                _ => out.push_str(line),
            }
            out.push('\n');
        }
        std::fs::write(&path, out).unwrap();
        let missing: Vec<&String> = computed.keys().filter(|f| !written.contains(*f)).collect();
        assert!(missing.is_empty(), "nothing recorded for {missing:?}: give each entry a line `fingerprint = \"\"` to fill");
        return;
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The check can fail: a setting, a scene's golden image and a source each change a fingerprint.
#[test]
fn a_changed_setting_golden_or_source_changes_the_fingerprint() {
    let entry = |extra: &str| -> toml::Table { format!("file = \"x.png\"\nrender = [[\"scenes/first.toml\"{extra}]]\n").parse().unwrap() };
    let base = fingerprint(&entry(""));
    assert_eq!(base, fingerprint(&entry("")), "the same render, the same fingerprint");
    assert_ne!(base, fingerprint(&entry(", \"--spp\", \"2\"")), "a setting");
    let other_golden: toml::Table = "file = \"x.png\"\nrender = [[\"scenes/first-mirror.toml\"]]\n".parse().unwrap();
    assert_ne!(base, fingerprint(&other_golden));
    let with_source: toml::Table = "file = \"x.png\"\nrender = [[\"scenes/first.toml\"]]\nsources = [\"README.md\"]\n".parse().unwrap();
    assert_ne!(base, fingerprint(&with_source), "a source");
}

/// What the fingerprint holds: the scene's content (a changed radius) and a setting off its
/// default make an image stale; a setting given at its default value (seed 0) does not, since
/// only settings off their defaults are fingerprinted (`param::fingerprint::differing_fields`).
#[test]
fn a_changed_scene_or_non_default_setting_makes_an_image_stale() {
    let dir = std::env::temp_dir().join(format!("raylab-docs-images-{}", std::process::id()));
    let scene = std::fs::read_to_string(repo().join("scenes/first.toml")).unwrap();
    let copy = |name: &str, text: &str| -> String {
        std::fs::create_dir_all(dir.join(name)).unwrap();
        std::fs::write(dir.join(name).join("first.toml"), text).unwrap();
        dir.join(name).join("first.toml").to_string_lossy().to_string()
    };
    let (same, changed) = (copy("same", &scene), copy("changed", &scene.replacen("radius = 1\n", "radius = 1.01\n", 1)));
    let args = |extra: &[&str]| -> Vec<String> { ["scenes/first.toml"].iter().chain(extra).map(|s| s.to_string()).collect() };
    let base = render_fingerprint(&args(&[]));
    assert_eq!(base, render_fingerprint(&[same]), "the same scene elsewhere");
    assert_ne!(base, render_fingerprint(&[changed]), "a changed scene");
    assert_ne!(base, render_fingerprint(&args(&["--seed", "3"])), "a setting off its default");
    assert_eq!(base, render_fingerprint(&args(&["--seed", "0"])), "a setting at its default");
    std::fs::remove_dir_all(&dir).unwrap();
}
