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
        let c = compare(&rgb, expected.as_raw());
        if c.rejected() {
            write_png(&diff_dir.join(format!("{name}.diff.png")), w, h, &c.diff);
            write_png(&diff_dir.join(format!("{name}.new.png")), w, h, &rgb);
            failures.push(format!(
                "{name}: worst channel difference {}, {:.3}% of pixels differ; see {}",
                c.worst,
                100.0 * c.fraction,
                diff_dir.join(format!("{name}.diff.png")).display()
            ));
        }
    }
    assert!(failures.is_empty(), "golden images differ:\n  {}", failures.join("\n  "));
}

/// How a render differs from its golden image (both 8-bit RGB, the same size).
struct Comparison {
    /// Largest difference of any channel of any pixel.
    worst: u8,
    /// Fraction of pixels with a channel (red, green or blue) off by more than 2 levels.
    fraction: f64,
    /// Per-channel differences ×8, for the diff image.
    diff: Vec<u8>,
}

impl Comparison {
    /// True when the difference is beyond the tolerance.
    fn rejected(&self) -> bool {
        self.worst > MAX_CHANNEL_DIFF || self.fraction > MAX_DIFFERING_FRACTION
    }
}

/// Compares a render with its golden image, every channel of every pixel.
fn compare(rgb: &[u8], golden: &[u8]) -> Comparison {
    assert_eq!(rgb.len(), golden.len());
    let mut worst = 0u8;
    let mut differing = 0usize;
    let mut diff = vec![0u8; rgb.len()];
    for (i, (a, b)) in rgb.chunks_exact(3).zip(golden.chunks_exact(3)).enumerate() {
        let mut off = false;
        for c in 0..3 {
            let d = a[c].abs_diff(b[c]);
            worst = worst.max(d);
            diff[3 * i + c] = d.saturating_mul(8);
            off |= d > 2;
        }
        differing += usize::from(off);
    }
    Comparison { worst, fraction: differing as f64 / (rgb.len() / 3).max(1) as f64, diff }
}

/// Guard against a test that cannot fail: the comparison the golden test runs accepts the render
/// as blessed and rejects it once changed, whichever channel changes: a few pixels far off in
/// red, every pixel a little off in green alone, or in blue alone (each change within the
/// per-pixel tolerance, over far more pixels than the tolerated fraction).
#[test]
fn the_comparison_catches_a_changed_image() {
    let scene = root().join("scenes/report-two-colour.toml");
    let (_, _, rgb) = render_small(&scene);
    let golden = image::open(root().join("tests/golden/report-two-colour.png")).expect("golden exists").to_rgb8();
    let golden = golden.as_raw();
    assert_eq!(rgb, golden.as_slice(), "the simplest scene renders exactly as blessed");
    assert!(!compare(&rgb, golden).rejected(), "the blessed render is accepted");
    let changed = |channel: usize, pixels: usize, by: u8| {
        let mut v = rgb.clone();
        for px in v.chunks_mut(3).take(pixels) {
            px[channel] = if px[channel] > 127 { px[channel] - by } else { px[channel] + by };
        }
        v
    };
    let all = rgb.len() / 3;
    for (what, v) in [
        ("200 pixels' red by 40", changed(0, 200, 40)),
        ("every pixel's green by 10", changed(1, all, 10)),
        ("every pixel's blue by 10", changed(2, all, 10)),
        ("a tenth of the pixels' blue by 3", changed(2, all / 10, 3)),
    ] {
        let c = compare(&v, golden);
        assert!(c.rejected(), "{what}: accepted (worst {}, {:.3}% of pixels differ)", c.worst, 100.0 * c.fraction);
    }
}
