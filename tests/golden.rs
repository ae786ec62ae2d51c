//! Golden-image tests: every scene in `scenes/` is rendered at reduced size and compared with
//! `tests/golden/<scene>.png`.
//!
//! Comparison is tolerant (8-bit channels may differ by a little on a few pixels, e.g. from a
//! different libm); on failure a diff image (differences ×8, on black) is written to
//! `target/golden-diff/<scene>.png` beside the new render. After an intended change in shading,
//! look at the new images and re-bless with `RAYLAB_BLESS=1 cargo test --test golden`.

use raylab::load::context::{LoadOptions, Overrides};
use std::path::{Path, PathBuf};

/// Largest per-channel difference (8-bit) tolerated on any pixel.
const MAX_CHANNEL_DIFF: u8 = 24;
/// Largest fraction of pixels allowed to differ by more than 2 levels.
const MAX_DIFFERING_FRACTION: f64 = 0.002;
/// Golden renders are this fraction of the scene's resolution (each side).
const SCALE_DIVISOR: u32 = 4;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn scenes() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join("scenes"))
        .expect("scenes/ exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    v
}

/// Renders a scene at 1/SCALE_DIVISOR of its resolution, as 8-bit RGB.
fn render_small(path: &Path) -> (u32, u32, Vec<u8>) {
    let registry = raylab_plugins::registry();
    let full = raylab::load::loader::load_file(&registry, path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{}", e.report()));
    let (w, h) = ((full.settings.width / SCALE_DIVISOR).max(8), (full.settings.height / SCALE_DIVISOR).max(8));
    let opts = LoadOptions { overrides: Overrides { width: Some(w), height: Some(h), ..Default::default() }, ..Default::default() };
    let job = raylab::load::loader::load_file(&registry, path, &opts).unwrap_or_else(|e| panic!("{}", e.report()));
    let out = raylab::render::render(&job, &Default::default(), &|_, _| {}).expect("render");
    assert_eq!(out.stats.nonfinite_samples, 0, "{}: NaN or infinite samples", path.display());
    (w, h, raylab::image::output::to_rgb8(&out.film, job.settings.encoding, None))
}

fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    raylab::image::write::write_atomically(path, |out| {
        raylab::image::output::encode_rgb8(out, rgb, w, h, raylab::image::output::ImageKind::Png)
    })
    .unwrap();
}

#[test]
fn every_scene_matches_its_golden_image() {
    let bless = std::env::var_os("RAYLAB_BLESS").is_some();
    let diff_dir = root().join("target/golden-diff");
    let mut failures = Vec::new();
    let meshes = raylab_plugins::registry().geometry("mesh").is_some();
    for scene in scenes() {
        let name = scene.file_stem().unwrap().to_string_lossy().to_string();
        // Scenes with meshes need the `mesh` feature (CI tests with --all-features).
        if !meshes && std::fs::read_to_string(&scene).is_ok_and(|t| t.contains("type = \"mesh\"")) {
            continue;
        }
        let golden = root().join("tests/golden").join(format!("{name}.png"));
        let (w, h, rgb) = render_small(&scene);
        if bless {
            write_png(&golden, w, h, &rgb);
            continue;
        }
        let Ok(expected) = image::open(&golden) else {
            failures.push(format!("{name}: no golden image at {} (look at a render, then bless with RAYLAB_BLESS=1)", golden.display()));
            continue;
        };
        let expected = expected.to_rgb8();
        if expected.dimensions() != (w, h) {
            failures.push(format!("{name}: golden image is {:?}, render is {w}×{h}", expected.dimensions()));
            continue;
        }
        let mut worst = 0u8;
        let mut differing = 0usize;
        let mut diff = vec![0u8; rgb.len()];
        for (i, (a, b)) in rgb.iter().zip(expected.as_raw()).enumerate() {
            let d = a.abs_diff(*b);
            worst = worst.max(d);
            diff[i] = d.saturating_mul(8);
            if d > 2 && i % 3 == 0 {
                differing += 1;
            }
        }
        let fraction = differing as f64 / f64::from(w * h);
        if worst > MAX_CHANNEL_DIFF || fraction > MAX_DIFFERING_FRACTION {
            write_png(&diff_dir.join(format!("{name}.diff.png")), w, h, &diff);
            write_png(&diff_dir.join(format!("{name}.new.png")), w, h, &rgb);
            failures.push(format!(
                "{name}: worst channel difference {worst}, {:.3}% of pixels differ; see {}",
                100.0 * fraction,
                diff_dir.join(format!("{name}.diff.png")).display()
            ));
        }
    }
    assert!(failures.is_empty(), "golden images differ:\n  {}", failures.join("\n  "));
}

#[test]
fn the_comparison_catches_a_changed_image() {
    // Guard against a test that cannot fail: a deliberately altered render must be rejected.
    let scene = root().join("scenes/report-two-colour.toml");
    let (_, _, mut rgb) = render_small(&scene);
    let golden = image::open(root().join("tests/golden/report-two-colour.png")).expect("golden exists").to_rgb8();
    assert_eq!(rgb, golden.as_raw().as_slice(), "the simplest scene renders exactly as blessed");
    for px in rgb.chunks_mut(3).take(200) {
        px[0] = px[0].wrapping_add(40);
    }
    let worst = rgb.iter().zip(golden.as_raw()).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
    assert!(worst > MAX_CHANNEL_DIFF);
}
