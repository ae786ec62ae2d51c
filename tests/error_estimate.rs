//! The render's estimate of its own error (`PixelSum::std_error`, `half_variance`,
//! `ShareSums::error_estimate`) and adaptive sampling to an error target.

use raylab::load::context::LoadOptions;
use raylab::render::{RenderOptions, Rendered, render};
use std::path::Path;

fn render_str(toml: &str) -> Rendered {
    let registry = raylab_plugins::registry();
    let job = raylab::load::loader::load_str(&registry, "test.toml", toml, Path::new("."), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.report()));
    render(&job, &RenderOptions { threads: Some(2), ..RenderOptions::default() }, &|_, _| {}).expect("render")
}

/// Nothing but a constant background: every sample of every pixel is the same, so every
/// estimate of error is exactly zero.
#[test]
fn a_constant_image_has_zero_estimated_error() {
    let r = render_str(
        r#"
        background = [0.3, 0.5, 0.7]
        [render]
        width = 8
        height = 6
        spp = 16
        [camera]
        position = [0, 0, 0]
        look_at = [0, 0, -1]
        "#,
    );
    for p in &r.sums.pixels {
        assert_eq!(p.std_error(), Some(0.0));
        assert_eq!(p.half_variance(), Some(0.0));
    }
    assert_eq!(r.sums.error_estimate().map(|e| e.relative_rmse), Some(0.0));
}

/// The share of the estimated variance in pixels lit by samples rarer than one per first test
/// (`ShareSums::rare_light_share`, behind the summary's "may read low"): a pixel whose light came
/// in one bright ray of 64 counts as rare for a first test at 16 samples and not at 128; a
/// pixel as noisy but lit by every ray never does.
#[test]
fn rare_bright_samples_are_told_from_spread_light() {
    use raylab::math::color::Color;
    use raylab::render::accum::PixelSum;
    let mut r = render_str(
        r#"
        background = 0.5
        [render]
        width = 3
        height = 1
        spp = 4
        [camera]
        position = [0, 0, 0]
        look_at = [0, 0, -1]
        "#,
    );
    let grey = |v: f64| Color::new(v, v, v);
    let (mut rare, mut spread) = (PixelSum::default(), PixelSum::default());
    for i in 0..64 {
        rare.add(grey(if i == 17 { 40.0 } else { 0.1 }));
        spread.add(grey(if i % 2 == 0 { 0.2 } else { 3.0 }));
    }
    r.sums.pixels = vec![rare, spread, PixelSum::default()];
    let var = |p: &PixelSum| p.std_error().unwrap().powi(2);
    let share = r.sums.rare_light_share(16);
    assert!((share - var(&rare) / (var(&rare) + var(&spread))).abs() < 1e-12, "{share}");
    assert!(share > 0.5, "{share}");
    assert_eq!(r.sums.rare_light_share(128), 0.0);
    r.sums.pixels = vec![spread, spread, spread];
    assert_eq!(r.sums.rare_light_share(16), 0.0);
}

/// A pixel split in half by the edge of a black square in front of a white background: `N`
/// stratified samples put exactly `N/2` on each side, so the sample variance of their luminance
/// is `N / (4 (N − 1))` and the standard error of the mean `1 / (2 √(N − 1))`, in closed form.
#[test]
fn a_half_covered_pixel_has_the_closed_form_standard_error() {
    for spp in [4u32, 16, 64] {
        let r = render_str(&format!(
            r#"
            background = 1
            [render]
            width = 3
            height = 3
            spp = {spp}
            [camera]
            position = [0, 0, 0]
            look_at = [0, 0, -1]
            fov = 60
            [materials.black]
            kd = 0
            [[object]]
            type = "quadrangle"
            material = "black"
            p0 = [-10, -10, -5]
            p1 = [0, -10, -5]
            p2 = [0, 10, -5]
            p3 = [-10, 10, -5]
            "#
        ));
        // The middle pixel of the 3 × 3 image: the square's edge x = 0 runs down its centre.
        let p = r.sums.pixels[4];
        let n = f64::from(spp);
        assert!((p.mean_luminance() - 0.5).abs() < 1e-12, "{spp} spp: mean {}", p.mean_luminance());
        let expected = 1.0 / (2.0 * (n - 1.0).sqrt());
        let e = p.std_error().unwrap();
        assert!((e - expected).abs() < 1e-9 * expected, "{spp} spp: standard error {e}, closed form {expected}");
        // Pixels wholly on one side have none.
        assert_eq!(r.sums.pixels[3].std_error(), Some(0.0));
        assert_eq!(r.sums.pixels[5].std_error(), Some(0.0));
    }
}

/// One light sampled uniformly over a known area: a white diffuse floor (`phong`, `kd = 1`) lit
/// by a 2 × 2 rectangle at height `h = 1` right above the shaded point, attenuated by `1 / d²`,
/// one shadow ray per camera ray. Each sample's luminance is `f = h / d³` (`n·l = h / d` times
/// `1 / d²`) at a point uniform over the rectangle, so its mean is the rectangle's solid angle
/// over its area, `Ω / A` (`Ω = 4 atan(ab / (h √(a² + b² + h²)))` for half-sides `a`, `b`), and
/// its variance `E[f²] − E[f]²` follows by integrating `f²` over the rectangle (Simpson's rule,
/// checked against `Ω`). The camera's field of view is so narrow that every camera ray of every
/// pixel hits the same point to within 10⁻⁴ of `f`. The error layer, `√(s² / n)`, squared and
/// times `n`, is each pixel's sample variance `s²`: averaged over the pixels it must match the
/// closed form within a tolerance set by the sample count (four standard deviations of the mean
/// of the pixels' `s²`, from the fourth central moment, also integrated).
#[test]
fn one_light_sampled_uniformly_over_its_area_has_the_closed_form_variance() {
    const SPP: u32 = 256;
    const SIDE: usize = 8;
    let r = render_str(&format!(
        r#"
        [render]
        width = {SIDE}
        height = {SIDE}
        spp = {SPP}
        encoding = "linear"
        [camera]
        position = [0, 1, 3]
        look_at = [0, 0, 0]
        fov = 0.001
        [integrator]
        type = "phong"
        prune_threshold = 0
        [[object]]
        type = "plane"
        point = [0, 0, 0]
        normal = [0, 1, 0]
        material = {{ ka = 0, kd = 1, ks = 0 }}
        [[light]]
        type = "rect"
        center = [0, 1, 0]
        edge1 = [2, 0, 0]
        edge2 = [0, 0, 2]
        kc = 0
        kq = 1
        samples = 1
        "#
    ));
    // Moments of f = h / d³ over the rectangle [−a, a] × [−b, b] at height h (composite Simpson).
    let (a, b, h) = (1.0f64, 1.0f64, 1.0f64);
    let f = |x: f64, z: f64| h / (x * x + z * z + h * h).powf(1.5);
    let steps = 400usize;
    let weight = |i: usize| {
        if i == 0 || i == steps {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        }
    };
    let mut moments = [0.0f64; 5];
    for i in 0..=steps {
        for j in 0..=steps {
            let x = -a + 2.0 * a * i as f64 / steps as f64;
            let z = -b + 2.0 * b * j as f64 / steps as f64;
            let (w, v) = (weight(i) * weight(j), f(x, z));
            for (k, m) in moments.iter_mut().enumerate() {
                *m += w * v.powi(k as i32);
            }
        }
    }
    let norm = moments[0];
    let [_, m1, m2, m3, m4] = moments.map(|m| m / norm);
    let solid_angle = 4.0 * (a * b / (h * (a * a + b * b + h * h).sqrt())).atan();
    let mean = solid_angle / (4.0 * a * b);
    assert!((m1 - mean).abs() < 1e-9 * mean, "quadrature {m1}, closed form {mean}");
    let variance = m2 - mean * mean;
    let fourth = m4 - 4.0 * m3 * mean + 6.0 * m2 * mean * mean - 3.0 * mean.powi(4);
    let n = f64::from(SPP);
    let pixels = (SIDE * SIDE) as f64;
    // The spread of the unbiased sample variance of n independent samples, then of the mean of
    // the pixels' (the light's points may be stratified across a pixel's samples: then s² is
    // biased up by at most variance / (n − 1), allowed for).
    let spread = ((fourth - variance * variance * (n - 3.0) / (n - 1.0)) / n / pixels).sqrt();
    let tolerance = 4.0 * spread + variance / (n - 1.0);
    let (error, spp) = r.sums.error_layers().unwrap();
    assert!(spp.iter().all(|&s| s == SPP as f32));
    let measured = error.iter().map(|&e| n * f64::from(e) * f64::from(e)).sum::<f64>() / pixels;
    assert!(
        (measured - variance).abs() <= tolerance,
        "sample variance {measured:.6} from the error layer, closed form {variance:.6} (mean {mean:.6}), tolerance {tolerance:.6}"
    );
    // And the pixels' mean is the closed form's (within four standard errors of all the samples).
    let image_mean = r.sums.pixels.iter().map(|p| p.mean_luminance()).sum::<f64>() / pixels;
    assert!((image_mean - mean).abs() <= 4.0 * (variance / (n * pixels)).sqrt(), "mean {image_mean}, closed form {mean}");
    // The tolerance is tight enough to fail: 5 % off the variance is out of it.
    assert!(tolerance < 0.05 * variance, "tolerance {tolerance} against variance {variance}");
}

/// The estimate of the image's error is honest: on the path tracer's Cornell box, against the
/// spread of 12 renders with other seeds (their RMSE about the mean of all of them), it is
/// within a factor of 1.5, for a stratified set and for the Sobol points of a time budget (or
/// an error target). At 49 spp the set's grid has an odd number of columns (7 × 7), where halves
/// taken by a stratum's parity alone are stripes of the pixel (the estimate was 3.5× too high).
#[test]
fn the_image_error_estimate_matches_the_spread_between_seeds() {
    estimate_matches_spread(false, 32);
    estimate_matches_spread(false, 49);
    estimate_matches_spread(true, 32);
}

fn estimate_matches_spread(sobol: bool, spp: u32) {
    let (estimated, spread, reads_high) = estimate_and_spread(sobol, spp);
    let ratio = estimated / spread;
    assert!(
        (1.0 / 1.5..=1.5).contains(&ratio),
        "{} at {spp} spp: estimated relative RMSE {estimated:.4}, spread between seeds {spread:.4}: ratio {ratio:.2}",
        if sobol { "Sobol points" } else { "stratified" }
    );
    assert!(!reads_high, "at {spp} spp the estimate is within 1.5× and must not say it may read high");
}

/// Below `ErrorEstimate::FEW_SPP` samples a pixel, each half of a pixel's samples is stratified
/// much less well than the whole, and the halves' estimate reads high: at 8 spp on
/// `path-cornell` (stratified, a 3 × 3 grid with halves of four points) the bench read 2.25× the
/// true error, unflagged, and at 16 spp up to 1.55× one seed's true error (the threshold was 16).
/// Now the estimate is within 1.5× of the spread between seeds, or it says it may read high and
/// does (never low while saying high).
#[test]
fn with_few_samples_the_estimate_is_honest_or_says_it_reads_high() {
    for (sobol, spp) in [(false, 16), (false, 8), (false, 4), (true, 16), (true, 8)] {
        let (estimated, spread, reads_high) = estimate_and_spread(sobol, spp);
        let ratio = estimated / spread;
        let what = if sobol { "Sobol points" } else { "stratified" };
        assert!(
            (1.0 / 1.5..=1.5).contains(&ratio) || (reads_high && ratio > 1.0),
            "{what} at {spp} spp: estimated relative RMSE {estimated:.4}, spread between seeds {spread:.4}: ratio {ratio:.2}, {}",
            if reads_high { "flagged as reading high" } else { "not flagged" }
        );
        assert!(reads_high, "{what} at {spp} spp: below FEW_SPP the estimate says it may read high (ratio {ratio:.2})");
    }
}

/// The mean over 12 seeds of the estimated relative RMSE of `path-cornell` at 64² and `spp`
/// (stratified, or the Sobol points of a time budget), the spread between those renders (the
/// RMS over pixels of each pixel's standard deviation across seeds, over the mean luminance),
/// and whether every estimate said it may read high.
fn estimate_and_spread(sobol: bool, spp: u32) -> (f64, f64, bool) {
    let registry = raylab_plugins::registry();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/path-cornell.toml");
    // A budget no render here reaches: every pixel takes its 16 samples.
    let budget = raylab::param::value::Node::given("test", raylab::param::value::Value::Float(1e6));
    let renders: Vec<Rendered> = (0..12u64)
        .map(|seed| {
            let opts = LoadOptions {
                overrides: raylab::load::context::Overrides {
                    width: Some(64),
                    height: Some(64),
                    spp: Some(spp),
                    seed: Some(seed),
                    render_params: if sobol { vec![("time_budget".into(), budget.clone())] } else { vec![] },
                    ..Default::default()
                },
                ..Default::default()
            };
            let job = raylab::load::loader::load_file(&registry, &path, &opts).unwrap_or_else(|e| panic!("{}", e.report()));
            render(&job, &RenderOptions { threads: Some(2), ..RenderOptions::default() }, &|_, _| {}).expect("render")
        })
        .collect();
    let lum = |r: &Rendered| r.sums.pixels.iter().map(|p| p.mean_luminance()).collect::<Vec<f64>>();
    let images: Vec<Vec<f64>> = renders.iter().map(lum).collect();
    let n = images[0].len();
    let k = images.len() as f64;
    let mean: Vec<f64> = (0..n).map(|i| images.iter().map(|im| im[i]).sum::<f64>() / k).collect();
    // Unbiased per-pixel variance across seeds, averaged over pixels.
    let variance = (0..n).map(|i| images.iter().map(|im| (im[i] - mean[i]).powi(2)).sum::<f64>() / (k - 1.0)).sum::<f64>() / n as f64;
    let brightness = mean.iter().sum::<f64>() / n as f64;
    let spread = variance.sqrt() / brightness;
    let estimates: Vec<_> = renders.iter().map(|r| r.sums.error_estimate().unwrap()).collect();
    let estimated = estimates.iter().map(|e| e.relative_rmse).sum::<f64>() / k;
    (estimated, spread, estimates.iter().all(|e| e.reads_high))
}

/// With an error target, a pixel that sees only the constant background stops at the fewest
/// samples the target allows ([`ErrorTarget::floor_spp`]: at the first test for a loose target,
/// later for a tight one), while pixels on a noisy, softly lit floor take many more samples: the
/// noisy half of the image gets at least 4× the samples per pixel of the flat half where the
/// floor lets the flat half stop at the first test, and 2× where it holds the flat half to 64
/// (it bounds the ratio by the noisy pixels' deviation over [`ErrorTarget::FLOOR`]).
///
/// [`ErrorTarget::floor_spp`]: raylab::render::job::ErrorTarget::floor_spp
/// [`ErrorTarget::FLOOR`]: raylab::render::job::ErrorTarget::FLOOR
#[test]
fn an_error_target_spends_samples_where_the_noise_is() {
    for (error, floor, ratio) in [(0.1, 8, 4.0), (0.02, 64, 2.0)] {
        spends_samples_where_the_noise_is(error, floor, ratio);
    }
}

fn spends_samples_where_the_noise_is(error: f64, floor: u32, ratio: f64) {
    let target = raylab::render::job::ErrorTarget { error, min_spp: 8 };
    assert_eq!(target.floor_spp(), floor, "0.25 · √8 / {error} rounded up to a tested count");
    let r = render_str(&format!(
        r#"
        background = 0.5
        [render]
        width = 16
        height = 8
        spp = 512
        target_error = {error}
        target_min_spp = 8
        [camera]
        position = [0, 1, 4]
        look_at = [0, 1, 0]
        fov = 60
        [integrator]
        type = "path"
        max_bounces = 3
        [materials.white]
        kd = 0.7
        [[object]]
        type = "quadrangle"
        material = "white"
        p0 = [0, -10, -10]
        p1 = [20, -10, -10]
        p2 = [20, 10, -10]
        p3 = [0, 10, -10]
        [[light]]
        type = "rect"
        center = [3, 3, -6]
        edge1 = [1, 0, 0]
        edge2 = [0, 1, 0]
        color = 400
        "#
    ));
    let (w, h) = (16usize, 8usize);
    let spp = |x0: usize, x1: usize| {
        let mut s = 0u64;
        for y in 0..h {
            for x in x0..x1 {
                s += u64::from(r.sums.pixels[y * w + x].samples);
            }
        }
        s as f64 / ((x1 - x0) * h) as f64
    };
    let (flat, noisy) = (spp(0, 6), spp(10, 16));
    assert_eq!(flat, f64::from(floor), "target {error}: background pixels stop at the floor's count");
    assert!(noisy >= ratio * flat, "target {error}: noisy half {noisy} spp, flat half {flat} spp");
    assert!(r.complete);
    // Every pixel either met the target (what its sample count allows) or reached the cap.
    for p in &r.sums.pixels {
        let e = p.sqrt_relative_error(raylab::render::job::ErrorTarget::DARK).unwrap();
        assert!(target.met(p) || p.samples == 512, "{} samples, error {e}", p.samples);
    }
}

/// Where pixels stop depends on their own samples alone: the same image from 1 and 3 threads.
#[test]
fn an_error_target_is_deterministic() {
    let registry = raylab_plugins::registry();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/path-cornell.toml");
    let target = raylab::param::value::Node::given("test", raylab::param::value::Value::Float(0.2));
    let opts = LoadOptions {
        overrides: raylab::load::context::Overrides {
            width: Some(24),
            height: Some(24),
            spp: Some(128),
            render_params: vec![("target_error".into(), target)],
            ..Default::default()
        },
        ..Default::default()
    };
    let job = raylab::load::loader::load_file(&registry, &path, &opts).unwrap_or_else(|e| panic!("{}", e.report()));
    let run = |threads| render(&job, &RenderOptions { threads: Some(threads), ..RenderOptions::default() }, &|_, _| {}).expect("render");
    let (a, b) = (run(1), run(3));
    assert_eq!(a.sums.pixels, b.sums.pixels);
    let spp: Vec<u32> = a.sums.pixels.iter().map(|p| p.samples).collect();
    assert!(spp.iter().min() < spp.iter().max(), "pixels stopped at different counts: {spp:?}");
}

/// A render under a time budget stops where the clock says; the samples each pixel reached
/// repeat it bit for bit, whatever the budget reached on this machine (no timing is asserted).
#[test]
fn a_time_budget_render_repeats_bit_for_bit_from_its_samples_per_pixel() {
    let registry = raylab_plugins::registry();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/path-cornell.toml");
    let budget = raylab::param::value::Node::given("test", raylab::param::value::Value::Float(0.05));
    let opts = LoadOptions {
        overrides: raylab::load::context::Overrides {
            width: Some(24),
            height: Some(24),
            spp: Some(4096),
            render_params: vec![("time_budget".into(), budget)],
            ..Default::default()
        },
        ..Default::default()
    };
    let job = raylab::load::loader::load_file(&registry, &path, &opts).unwrap_or_else(|e| panic!("{}", e.report()));
    let first = render(&job, &RenderOptions { threads: Some(2), layers: true, ..RenderOptions::default() }, &|_, _| {}).expect("render");
    assert!(first.complete, "a time budget ends a render complete");
    let map: Vec<u32> = first.sums.pixels.iter().map(|p| p.samples).collect();
    // The image refines by doubling: every pixel stops at a power of two, at least one sample.
    assert!(map.iter().all(|&n| n.is_power_of_two() && n <= 4096), "{map:?}");
    let again =
        render(&job, &RenderOptions { threads: Some(3), layers: true, spp_map: Some(&map), ..RenderOptions::default() }, &|_, _| {})
            .expect("repeat");
    assert!(!again.time_stop, "a repeat stops where the map says, not at the clock");
    assert_eq!(first.sums, again.sums);
    let bits = |r: &Rendered| r.film.pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&first), bits(&again));
    // A map of another frame, or over the cap, is refused.
    assert!(render(&job, &RenderOptions { spp_map: Some(&map[1..]), ..RenderOptions::default() }, &|_, _| {}).is_err());
    let over = vec![8192; map.len()];
    assert!(render(&job, &RenderOptions { spp_map: Some(&over), ..RenderOptions::default() }, &|_, _| {}).is_err());
}
