//! `raylab trace` explains exactly what `raylab render` computed: the explanation of each of a
//! pixel's samples goes through the render's own camera-sample path, so the samples' colours
//! recombine to the rendered pixel, under stratified and adaptive anti-aliasing, with depth of
//! field and area lights (whose random streams must line up too).

use raylab::glam::DVec3;
use raylab::load::context::{LoadOptions, Overrides};
use raylab::load::loader::load_file;
use raylab::param::value::{Node, Value};
use raylab::render::{RenderOptions, render};
use raylab::render::{explain_sample, pixel_samples};
use std::path::Path;

fn quality(aa: &str) -> raylab::RenderJob {
    quality_with(aa, None)
}

fn quality_with(aa: &str, integrator: Option<&str>) -> raylab::RenderJob {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/quality.toml");
    let src = raylab::param::error::Source::new("test", "");
    let text = |k: &str, v: Value| (k.to_string(), Node { value: v, loc: raylab::param::error::Loc::new(&src, 0..0) });
    let mut render_params = vec![text("aa", Value::Str(aa.into())), text("lens_samples", Value::Int(2))];
    if aa == "adaptive" {
        render_params.push(text("aa_threshold", Value::Float(0.02)));
        render_params.push(text("aa_depth", Value::Int(2)));
    }
    let overrides = Overrides {
        width: Some(48),
        height: Some(36),
        spp: Some(3),
        render_params,
        integrator: integrator.map(String::from),
        ..Overrides::default()
    };
    load_file(&raylab_plugins::registry(), &path, &LoadOptions { overrides, ..LoadOptions::default() })
        .unwrap_or_else(|e| panic!("{}", e.report()))
}

/// Pixels spread over the image by a fixed-seed generator.
fn pixels(job: &raylab::RenderJob, n: usize) -> Vec<(u32, u32)> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    (0..n)
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) as u32 % job.settings.width, (state >> 13) as u32 % job.settings.height)
        })
        .collect()
}

#[test]
fn stratified_samples_explained_sum_to_the_rendered_pixel_bit_for_bit() {
    for integrator in [None, Some("path")] {
        stratified_samples_recombine(integrator);
    }
}

fn stratified_samples_recombine(integrator: Option<&str>) {
    let job = quality_with("stratified", integrator);
    assert!(job.scene.camera.aperture > 0.0, "the test needs depth of field");
    let film = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap().film;
    for (x, y) in pixels(&job, 40) {
        let samples = pixel_samples(&job, x, y);
        assert_eq!(samples.len(), 3);
        let (mut sum, mut n) = (DVec3::ZERO, 0u32);
        for (id, _) in samples {
            let trees = explain_sample(&job, id).expect("the integrator explains");
            assert_eq!(trees.len(), 2, "one tree per lens ray");
            for t in trees.iter().filter(|t| t.color.is_finite()) {
                sum += t.color;
                n += 1;
            }
        }
        assert_eq!((sum / f64::from(n)).as_vec3(), film.get(x, y), "{}: pixel ({x}, {y})", job.integrator_name);
    }
}

#[test]
fn adaptive_lattice_points_explained_recombine_to_the_rendered_pixel() {
    let job = quality("adaptive");
    let film = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap().film;
    let mut split = 0;
    for (x, y) in pixels(&job, 40) {
        let samples = pixel_samples(&job, x, y);
        let total: f64 = samples.iter().map(|(_, w)| w).sum();
        assert!((total - 1.0).abs() < 1e-12, "weights sum to {total}");
        split += usize::from(samples.len() > 4);
        let mut value = DVec3::ZERO;
        for (id, w) in samples {
            let trees = explain_sample(&job, id).expect("phong explains");
            let finite: Vec<DVec3> = trees.iter().map(|t| t.color).filter(|c| c.is_finite()).collect();
            value += w * finite.iter().sum::<DVec3>() / finite.len().max(1) as f64;
        }
        let px = film.get(x, y).as_dvec3();
        assert!((value - px).abs().max_element() <= 1e-6 * (1.0 + px.abs().max_element()), "pixel ({x}, {y}): {value} vs {px}");
    }
    assert!(split > 0, "some pixel was subdivided: the test reaches the recursion");
}
