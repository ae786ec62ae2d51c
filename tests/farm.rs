//! Frames beyond one process: any split of a frame into shares (crops, tiles, sample passes),
//! merged, has the bits of one whole render; a render resumed from any saved state ends with the
//! bits of an uninterrupted one; parts that do not belong together are refused.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use raylab::load::context::{LoadOptions, Overrides};
use raylab::load::loader::load_file;
use raylab::param::value::{Node, Value};
use raylab::render::share::{Part, Rect, Share, ShareSums, merge};
use raylab::render::{RenderJob, RenderOptions, Snapshots, render};
use std::path::Path;
use std::sync::Mutex;

/// A bundled scene at a small size, with `aa` and optional layers.
fn job(scene: &str, aa: &str, spp: u32) -> RenderJob {
    job_sized(scene, aa, spp, 40, 30)
}

/// A bundled scene at `width × height`, with `aa`.
fn job_sized(scene: &str, aa: &str, spp: u32, width: u32, height: u32) -> RenderJob {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(scene);
    let src = raylab::param::error::Source::new("test", "");
    let node = |v: Value| Node { value: v, loc: raylab::param::error::Loc::new(&src, 0..0) };
    let mut render_params = vec![("aa".to_string(), node(Value::Str(aa.into())))];
    if aa == "adaptive" {
        render_params.push(("aa_threshold".into(), node(Value::Float(0.03))));
        render_params.push(("aa_depth".into(), node(Value::Int(2))));
    }
    let overrides = Overrides { width: Some(width), height: Some(height), spp: Some(spp), render_params, ..Overrides::default() };
    load_file(&raylab_plugins::registry(), &path, &LoadOptions { overrides, ..LoadOptions::default() })
        .unwrap_or_else(|e| panic!("{}", e.report()))
}

fn part(job: &RenderJob, share: Share, layers: bool) -> Part {
    let r = render(job, &RenderOptions { share: Some(share), layers, threads: Some(2), ..RenderOptions::default() }, &|_, _| {}).unwrap();
    assert!(r.complete);
    Part { name: share.describe(), sums: r.sums, fingerprint: job.fingerprint.clone() }
}

/// `n` bands of rows at the given cut fractions (sorted, distinct, inside).
fn bands(height: u32, cuts: &[f64]) -> Vec<Rect> {
    let mut ys: Vec<u32> = cuts.iter().map(|c| (c * f64::from(height)) as u32).filter(|&y| y > 0 && y < height).collect();
    ys.sort_unstable();
    ys.dedup();
    let mut edges = vec![0];
    edges.extend(ys);
    edges.push(height);
    edges.windows(2).map(|w| Rect { x0: 0, y0: w[0], x1: 40, y1: w[1] }).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, rng_seed: RngSeed::Fixed(raylab::testing::seed("any_split_merges_to_the_whole_render")), ..ProptestConfig::default() })]

    /// Random crops (row bands, then a split column in one band) and random sample-pass counts,
    /// under both anti-aliasing schemes, with depth of field and area lights (quality.toml) and
    /// the layers: the merge equals the whole render, sums and all.
    #[test]
    fn any_split_merges_to_the_whole_render(
        adaptive in any::<bool>(),
        cuts in prop::collection::vec(0.05f64..0.95, 0..4),
        column in 1u32..39,
        passes in 1u32..4,
        layers in any::<bool>(),
    ) {
        let j = job("quality.toml", if adaptive { "adaptive" } else { "stratified" }, 3);
        let whole = render(&j, &RenderOptions { layers, threads: Some(1), ..RenderOptions::default() }, &|_, _| {}).unwrap();
        let mut rects = bands(30, &cuts);
        // Split the first band into two crops side by side.
        let first = rects.remove(0);
        rects.push(Rect { x1: column, ..first });
        rects.push(Rect { x0: column, ..first });
        let parts: Vec<Part> = rects
            .iter()
            .flat_map(|&bounds| (0..passes).map(move |pass| Share { bounds, pass, passes }))
            .map(|share| part(&j, share, layers))
            .collect();
        let merged = merge(&parts, false).unwrap();
        prop_assert_eq!(&merged.pixels, &whole.sums.pixels);
        prop_assert_eq!(&merged.layers, &whole.sums.layers);
        prop_assert_eq!(merged.film().unwrap(), whole.film);
    }
}

/// An environment light (its image, its sampling) splits and merges like any scene: bands of
/// rows and sample passes merge to the whole render's bits.
#[test]
fn an_environment_lit_frame_merges_to_the_whole_render() {
    let j = job("environment.toml", "stratified", 4);
    let whole = render(&j, &RenderOptions { threads: Some(3), ..RenderOptions::default() }, &|_, _| {}).unwrap();
    let parts: Vec<Part> = bands(30, &[0.3, 0.7])
        .into_iter()
        .flat_map(|bounds| (0..2).map(move |pass| Share { bounds, pass, passes: 2 }))
        .map(|share| part(&j, share, false))
        .collect();
    let merged = merge(&parts, false).unwrap();
    assert_eq!(merged.pixels, whole.sums.pixels);
    assert_eq!(merged.film().unwrap(), whole.film);
}

/// Under an error target each pixel stops on its own samples: a frame cut into crops (bands of
/// rows, one split in two columns), each rendered to the target alone, merges to the whole
/// render's bits, the samples each pixel reached and its error halves included.
#[test]
fn an_error_target_frame_split_into_crops_merges_to_the_whole_render() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join("path-cornell.toml");
    let src = raylab::param::error::Source::new("test", "");
    let node = |v: Value| Node { value: v, loc: raylab::param::error::Loc::new(&src, 0..0) };
    let render_params = vec![("target_error".to_string(), node(Value::Float(0.1)))];
    let overrides = Overrides { width: Some(40), height: Some(30), spp: Some(128), render_params, ..Overrides::default() };
    let j = load_file(&raylab_plugins::registry(), &path, &LoadOptions { overrides, ..LoadOptions::default() })
        .unwrap_or_else(|e| panic!("{}", e.report()));
    let whole = render(&j, &RenderOptions { layers: true, threads: Some(2), ..RenderOptions::default() }, &|_, _| {}).unwrap();
    let spp: Vec<u32> = whole.sums.pixels.iter().map(|p| p.samples).collect();
    assert!(spp.iter().min() < spp.iter().max(), "pixels stopped at different counts");
    let mut rects = bands(30, &[0.2, 0.55]);
    let first = rects.remove(0);
    rects.push(Rect { x1: 13, ..first });
    rects.push(Rect { x0: 13, ..first });
    let parts: Vec<Part> = rects.into_iter().map(|bounds| part(&j, Share { bounds, pass: 0, passes: 1 }, true)).collect();
    let merged = merge(&parts, false).unwrap();
    assert_eq!(merged.pixels, whole.sums.pixels);
    assert_eq!(merged.layers, whole.sums.layers);
    assert_eq!(merged.film().unwrap(), whole.film);
    assert_eq!(merged.error_estimate(), whole.sums.error_estimate());
}

/// `render --denoise`'s finer grid under an error target: the frame's pixels are the 2 × 2
/// sub-pixels of a frame half as wide and high, and each block stops on its merged sums, all its
/// sub-pixels at the same count. Where blocks stop depends on their own samples alone: 1 and 3
/// threads give the same bits, and crops of whole blocks (rows cut at even rows, a band split at
/// an even column), each rendered alone, merge to the whole render's bits; a crop that cuts
/// blocks is refused.
#[test]
fn an_error_target_on_sub_pixels_stops_blocks_together_and_merges_from_crops() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join("path-cornell.toml");
    let src = raylab::param::error::Source::new("test", "");
    let node = |v: Value| Node { value: v, loc: raylab::param::error::Loc::new(&src, 0..0) };
    let render_params = vec![("target_error".to_string(), node(Value::Float(0.025)))];
    let overrides = Overrides { width: Some(20), height: Some(16), spp: Some(256), render_params, ..Overrides::default() };
    let mut j = load_file(&raylab_plugins::registry(), &path, &LoadOptions { overrides, ..LoadOptions::default() })
        .unwrap_or_else(|e| panic!("{}", e.report()));
    let target = j.settings.target.unwrap();
    assert_eq!((target.floor_spp(), raylab::image::denoise::grid(&j.settings)), (64, 2));
    j.settings = raylab::image::denoise::fine_settings(&j.settings, 2);
    let whole = render(&j, &RenderOptions { layers: true, threads: Some(3), ..RenderOptions::default() }, &|_, _| {}).unwrap();
    let (w, h) = (40usize, 32usize);
    let mut counts = Vec::new();
    for by in (0..h).step_by(2) {
        for bx in (0..w).step_by(2) {
            let subs = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(i, j)| whole.sums.pixels[(by + j) * w + bx + i]);
            assert!(subs.iter().all(|p| p.samples == subs[0].samples), "block ({bx}, {by}): {:?}", subs.map(|p| p.samples));
            let mut merged = raylab::render::accum::PixelSum::default();
            subs.iter().for_each(|p| merged.merge(p));
            // Each block stopped where its merged sums met the target, or at the most it may take.
            assert!(
                merged.samples == 256 || (target.converged(&merged) && merged.samples >= 64),
                "block ({bx}, {by}) at {}",
                merged.samples
            );
            counts.push(merged.samples);
        }
    }
    assert!(counts.iter().min() < counts.iter().max(), "blocks stopped at different counts: {counts:?}");
    let one = render(&j, &RenderOptions { layers: true, threads: Some(1), ..RenderOptions::default() }, &|_, _| {}).unwrap();
    assert_eq!(one.sums.pixels, whole.sums.pixels);
    let rects = [
        Rect { x0: 0, y0: 0, x1: 40, y1: 10 },
        Rect { x0: 0, y0: 10, x1: 18, y1: 22 },
        Rect { x0: 18, y0: 10, x1: 40, y1: 22 },
        Rect { x0: 0, y0: 22, x1: 40, y1: 32 },
    ];
    let parts: Vec<Part> = rects.into_iter().map(|bounds| part(&j, Share { bounds, pass: 0, passes: 1 }, true)).collect();
    let merged = merge(&parts, false).unwrap();
    assert_eq!(merged.pixels, whole.sums.pixels);
    assert_eq!(merged.layers, whole.sums.layers);
    assert_eq!(merged.film().unwrap(), whole.film);
    let cut = Share { bounds: Rect { x0: 0, y0: 0, x1: 40, y1: 11 }, pass: 0, passes: 1 };
    let e = render(&j, &RenderOptions { share: Some(cut), threads: Some(1), ..RenderOptions::default() }, &|_, _| {}).err().unwrap();
    assert!(e.contains("whole blocks of 2 × 2 sub-pixels"), "{e}");
}

#[test]
fn missing_duplicated_overlapping_and_foreign_parts_are_refused() {
    let j = job("dozen.toml", "stratified", 2);
    let top = Rect { x0: 0, y0: 0, x1: 40, y1: 15 };
    let bottom = Rect { x0: 0, y0: 15, x1: 40, y1: 30 };
    let a = part(&j, Share { bounds: top, pass: 0, passes: 1 }, false);
    let b = part(&j, Share { bounds: bottom, pass: 0, passes: 1 }, false);
    assert!(merge(&[a, b], false).is_ok());
    let fresh = |r: Rect| part(&j, Share { bounds: r, pass: 0, passes: 1 }, false);
    let e = merge(&[fresh(top)], false).unwrap_err();
    assert!(e.contains("without all their samples") && e.contains("[0, 40) × [15, 30)"), "{e}");
    assert!(merge(&[fresh(top)], true).is_ok(), "--allow-partial");
    let e = merge(&[fresh(top), fresh(top), fresh(bottom)], false).unwrap_err();
    assert!(e.contains("overlap"), "{e}");
    let e = merge(&[fresh(Rect { y1: 20, ..top }), fresh(bottom)], false).unwrap_err();
    assert!(e.contains("overlap") && e.contains("[15, 20)"), "{e}");
    let other = job("dozen.toml", "stratified", 3);
    let foreign = Part { fingerprint: other.fingerprint.clone(), ..part(&other, Share { bounds: bottom, pass: 0, passes: 1 }, false) };
    let e = merge(&[fresh(top), foreign], false).unwrap_err();
    assert!(e.contains("another render"), "{e}");
    let e = merge(&[part(&j, Share { bounds: top, pass: 0, passes: 2 }, false), fresh(top)], false).unwrap_err();
    assert!(e.contains("different pass counts"), "{e}");
    assert_ne!(j.fingerprint, other.fingerprint);
}

/// A render stopped at any moment and resumed from the state saved then ends with the same bits:
/// every snapshot a render hands out (one after each tile here), resumed.
#[test]
fn resuming_from_any_snapshot_gives_the_uninterrupted_image() {
    // Adaptive tiles are larger (ADAPTIVE_TILE_SIZE): a frame of six of them.
    for (scene, aa, (w, h)) in [("quality.toml", "stratified", (40, 30)), ("showcase.toml", "adaptive", (140, 100))] {
        let j = job_sized(scene, aa, 2, w, h);
        let whole = render(&j, &RenderOptions { threads: Some(1), ..RenderOptions::default() }, &|_, _| {}).unwrap();
        let states: Mutex<Vec<ShareSums>> = Mutex::new(Vec::new());
        let keep = |s: &ShareSums| states.lock().unwrap().push(s.clone());
        let snapshots = Some(Snapshots { every: std::time::Duration::ZERO, write: &keep });
        let again = render(&j, &RenderOptions { threads: Some(2), snapshots, ..RenderOptions::default() }, &|_, _| {}).unwrap();
        assert_eq!(again.film, whole.film);
        let states = states.into_inner().unwrap();
        assert!(states.len() >= 4, "{} snapshots", states.len());
        assert!(states.iter().filter(|s| !s.complete()).count() >= 3, "snapshots part-way through");
        // Every third snapshot: resumed.
        for s in states.iter().step_by(3) {
            let resumed = render(&j, &RenderOptions { resume: Some(s), threads: Some(2), ..RenderOptions::default() }, &|_, _| {}).unwrap();
            assert!(resumed.complete);
            assert_eq!(resumed.film, whole.film, "{scene} {aa}");
        }
        // A state of the wrong share is refused.
        let wrong = ShareSums { share: Share { pass: 0, passes: 2, ..states[0].share }, ..states[0].clone() };
        assert!(render(&j, &RenderOptions { resume: Some(&wrong), ..RenderOptions::default() }, &|_, _| {}).is_err());
        // So is a state of other sampling (a checkpoint's fingerprint is no secret: a forged
        // file can claim 10⁹ samples per pixel of the right render); it was continued to them.
        for sampling in [
            raylab::render::share::Sampling { spp: 1_000_000_000, ..states[0].sampling },
            raylab::render::share::Sampling { adaptive: !states[0].sampling.adaptive, ..states[0].sampling },
        ] {
            let forged = ShareSums { sampling, ..states[0].clone() };
            let e = render(&j, &RenderOptions { resume: Some(&forged), ..RenderOptions::default() }, &|_, _| {}).err().expect("refused");
            assert!(e.starts_with("the saved state is of a render with "), "{e}");
        }
    }
}
