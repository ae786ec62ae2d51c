//! Anti-aliasing and the speed/accuracy measurements: error falls with samples, adaptive
//! supersampling beats uniform on rays, progressive passes match a single pass, renders do not
//! depend on the thread count, and an analytic scene matches its closed form.

use raylab::Encoding;
use raylab::glam::DVec3;
use raylab::image::metrics;
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::render::adaptive::Adaptive;
use raylab::render::film::Film;
use raylab::render::{AdaptiveSettings, Antialiasing, RenderJob, RenderOptions, Rendered, render, render_progressive};
use std::path::Path;

fn job(text: &str) -> RenderJob {
    load_str(&raylab_plugins::registry(), "test.toml", text, Path::new("."), &LoadOptions::default()).unwrap()
}

fn run(job: &RenderJob, threads: Option<usize>) -> Rendered {
    render(job, &RenderOptions { threads, ..RenderOptions::default() }, &|_, _| {}).unwrap()
}

/// Hard edges at many angles: spheres, a tilted triangle and a plane's horizon, in contrasting
/// colours.
const EDGES: &str = r#"
background = [0.9, 0.9, 0.95]
[render]
width = 48
height = 36
[camera]
position = [0, 1, 6]
look_at = [0, 0.6, 0]
fov = 40
[integrator]
max_depth = 1
[[object]]
type = "plane"
point = [0, 0, 0]
normal = [0, 1, 0]
material = { kd = [0.1, 0.1, 0.1] }
[[object]]
type = "sphere"
center = [-1.2, 0.8, 0]
radius = 0.8
material = { kd = [0.9, 0.2, 0.1], ks = 0.5, shininess = 40 }
[[object]]
type = "sphere"
center = [1.1, 0.5, 0.8]
radius = 0.5
material = { kd = [0.1, 0.3, 0.9] }
[[object]]
type = "triangle"
p0 = [-0.5, 0.0, -1]
p1 = [1.5, 0.3, -1.5]
p2 = [0.2, 2.2, -1.2]
material = { kd = [0.95, 0.9, 0.2] }
[[light]]
type = "directional"
direction = [-0.3, -1, -0.5]
[[light]]
type = "ambient"
"#;

fn with(text: &str, spp: u32, aa: Antialiasing) -> RenderJob {
    let mut j = job(text);
    j.settings.spp = spp;
    j.settings.aa = aa;
    j
}

fn rmse(a: &Film, b: &Film) -> f64 {
    metrics::compare(a, b, Encoding::Srgb).unwrap().rmse
}

#[test]
fn error_falls_as_samples_rise_on_a_scene_with_edges() {
    let reference = run(&with(EDGES, 1024, Antialiasing::Stratified), None).film;
    let errors: Vec<f64> =
        [1, 4, 16, 64].iter().map(|&spp| rmse(&run(&with(EDGES, spp, Antialiasing::Stratified), None).film, &reference)).collect();
    for w in errors.windows(2) {
        assert!(w[1] < w[0], "error did not fall: {errors:?}");
    }
    assert!(errors[3] < errors[0] / 4.0, "64 spp should be far better than 1: {errors:?}");
}

#[test]
fn adaptive_supersampling_traces_fewer_rays_than_16_spp_for_no_more_error() {
    let reference = run(&with(EDGES, 1024, Antialiasing::Stratified), None).film;
    let uniform = run(&with(EDGES, 16, Antialiasing::Stratified), None);
    // With edges located by bisection, and with subdivision alone.
    for edges in [true, false] {
        let settings = AdaptiveSettings { edges, ..AdaptiveSettings::new(0.005, 4) };
        let adaptive = run(&with(EDGES, 1, Antialiasing::Adaptive(settings)), None);
        let (eu, ea) = (rmse(&uniform.film, &reference), rmse(&adaptive.film, &reference));
        let (ru, ra) = (uniform.stats.camera_rays, adaptive.stats.camera_rays);
        assert!(ea <= eu, "edges {edges}: adaptive error {ea} > uniform {eu}");
        assert!(ra * 3 < ru * 2, "edges {edges}: adaptive traced {ra} camera rays, uniform {ru}");
    }
}

#[test]
fn adaptive_supersampling_refines_only_where_samples_disagree() {
    // A flat background costs the corner lattice alone: (w + 1)(h + 1) rays, shared by pixels;
    // a lattice column on the border of two tiles is traced by each.
    let flat = "[render]\nwidth = 100\nheight = 10\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n";
    let r = run(&with(flat, 1, Antialiasing::Adaptive(AdaptiveSettings::new(0.0, 4))), None);
    let tiles_x = 100u64.div_ceil(u64::from(raylab::render::ADAPTIVE_TILE_SIZE));
    assert_eq!(r.stats.camera_rays, 101 * 11 + (tiles_x - 1) * 11);
    // Edges force refinement, and a threshold of 1 never refines.
    let busy = run(&with(EDGES, 1, Antialiasing::Adaptive(AdaptiveSettings::new(0.05, 2))), None).stats.camera_rays;
    let none = run(&with(EDGES, 1, Antialiasing::Adaptive(AdaptiveSettings::new(1.0, 2))), None).stats.camera_rays;
    assert!(busy > none + 48 * 36 / 4, "{busy} vs {none}");
}

#[test]
fn coarse_levels_trace_the_block_corners_of_flat_regions_and_refine_edges() {
    // A flat background costs the corners of 2 × 2 pixel blocks: 51 × 6 rays, the lattice
    // column on the tile border traced by both tiles.
    let flat = "[render]\nwidth = 100\nheight = 10\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n";
    let coarse = |t, depth, levels| Antialiasing::Adaptive(AdaptiveSettings { coarse: levels, ..AdaptiveSettings::new(t, depth) });
    let r = run(&with(flat, 1, coarse(0.0, 4, 1)), None);
    assert_eq!(r.stats.camera_rays, 51 * 6 + 6);
    // Where the image does not hold a whole block (the last row of an odd height), the pixels
    // are tested alone: the odd corners of their top row and their bottom row are added (and
    // the border column's bottom point again).
    let odd = flat.replace("height = 10", "height = 11");
    assert_eq!(run(&with(&odd, 1, coarse(0.0, 4, 1)), None).stats.camera_rays, 51 * 6 + 6 + 50 + 101 + 1);
    // On hard edges (a 48 × 36 image): blocks of 2 × 2 pixels trace far fewer rays for the same
    // error; blocks of 4 × 4 fewer still, and lose features narrower than a block (the trade).
    let reference = run(&with(EDGES, 1024, Antialiasing::Stratified), None).film;
    let rays_error = |levels| {
        let r = run(&with(EDGES, 1, coarse(0.05, 3, levels)), None);
        (r.stats.camera_rays, rmse(&r.film, &reference))
    };
    let (pixel, one, two) = (rays_error(0), rays_error(1), rays_error(2));
    assert!(one.1 <= pixel.1 * 1.1, "blocks of 2: error {} against {} testing every pixel", one.1, pixel.1);
    assert!(one.0 * 4 < pixel.0 * 3, "blocks of 2: {} camera rays against {} testing every pixel", one.0, pixel.0);
    assert!(two.0 < one.0 && two.1 > one.1, "blocks of 4: {two:?} against blocks of 2: {one:?}");
}

#[test]
fn coarse_levels_beyond_the_lattice_are_refused_where_they_are_set() {
    let text = "[render]\nwidth = 8\nheight = 8\naa = \"adaptive\"\naa_depth = 7\naa_coarse = 2\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n";
    let e = load_str(&raylab_plugins::registry(), "test.toml", text, Path::new("."), &LoadOptions::default()).err().expect("refused");
    let msg = e.to_string();
    assert!(msg.contains("test.toml:6") && msg.contains("2 coarse levels above 7 levels of depth"), "{msg}");
    assert!(
        load_str(
            &raylab_plugins::registry(),
            "test.toml",
            &text.replace("aa_depth = 7", "aa_depth = 6"),
            Path::new("."),
            &LoadOptions::default()
        )
        .is_ok()
    );
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    for aa in [
        Antialiasing::Stratified,
        Antialiasing::Adaptive(AdaptiveSettings::new(0.05, 3)),
        Antialiasing::Adaptive(AdaptiveSettings { coarse: 2, ..AdaptiveSettings::new(0.05, 3) }),
    ] {
        let mut j = with(EDGES, 5, aa);
        j.scene.camera.aperture = 0.05;
        j.settings.lens_samples = 2;
        assert_eq!(run(&j, Some(1)).film, run(&j, Some(2)).film, "{aa:?}");
    }
}

#[test]
fn progressive_passes_end_with_the_single_pass_image() {
    let j = with(EDGES, 8, Antialiasing::Stratified);
    let mut seen = Vec::new();
    let mut errors = Vec::new();
    let single = run(&j, None).film;
    let last = render_progressive(&j, &RenderOptions::default(), &[1, 2, 4, 16], &|_, _| {}, &mut |p| {
        seen.push(p.samples);
        errors.push(rmse(p.film, &single));
    })
    .unwrap();
    assert_eq!(seen, [1, 2, 4, 8]);
    assert_eq!(last.film, single);
    assert_eq!(*errors.last().unwrap(), 0.0);
    assert!(errors[0] > 0.0);
}

/// A pixel's stratified film positions are computed per pixel, from tables of the set's permuted
/// columns and rows where enough samples are taken in one pass (grids up to 64 × 64), per sample
/// otherwise: both give the per-sample path's image (`render_pixel`, every sample on its own),
/// in one pass or in doubling passes, for grids of every shape and beyond the tables.
#[test]
fn stratified_film_positions_do_not_depend_on_how_they_are_computed() {
    for (spp, size) in [(2, 12), (3, 12), (7, 12), (16, 12), (64, 6), (100, 6), (4100, 2)] {
        let mut j = with(EDGES, spp, Antialiasing::Stratified);
        (j.settings.width, j.settings.height) = (size, size * 3 / 4);
        let single = run(&j, Some(2)).film;
        let mut stats = raylab::render::stats::RayStats::new(j.integrator.counters());
        for y in 0..single.height {
            for x in 0..single.width {
                assert_eq!(single.get(x, y), raylab::render::render_pixel(&j, x, y, &mut stats), "spp {spp}, pixel ({x}, {y})");
            }
        }
        let passes = render_progressive(&j, &RenderOptions::default(), &raylab::render::DOUBLING_PASSES, &|_, _| {}, &mut |_| {}).unwrap();
        assert_eq!(passes.film, single, "spp {spp}");
    }
}

/// A Lambert sphere under a directional light, sampled at pixel centres: every pixel is
/// `kd · max(0, n·l)` at the point the report's pixel-centre ray hits, or the background.
#[test]
fn lambert_sphere_matches_the_closed_form() {
    let (nx, ny) = (41u32, 31u32);
    let kd = 0.7;
    let light_dir = DVec3::new(-1.0, -2.0, -1.5).normalize();
    let text = format!(
        r#"
[render]
width = {nx}
height = {ny}
encoding = "linear"
[camera]
position = [0, 0, 0]
to = [0, 0, -1]
up = [0, 1, 0]
screen_distance = 2
screen_width = 1.6
screen_height = 1.2
[integrator]
max_depth = 0
prune_threshold = 0
[[object]]
type = "sphere"
center = [0.1, -0.05, -5]
radius = 1.3
material = {{ ka = 0, kd = {kd}, ks = 0 }}
[[light]]
type = "directional"
direction = [{}, {}, {}]
"#,
        light_dir.x, light_dir.y, light_dir.z
    );
    let film = run(&job(&text), None).film;
    let (c, r) = (DVec3::new(0.1, -0.05, -5.0), 1.3);
    let mut lit = 0;
    for y in 0..ny {
        for x in 0..nx {
            // The report's pixel-centre ray, written out.
            let (rx, ry) = (1.6 / f64::from(nx), 1.2 / f64::from(ny));
            let p = DVec3::new(
                (f64::from(x) - f64::from(nx) / 2.0) * rx + rx / 2.0,
                -((f64::from(y) - f64::from(ny) / 2.0) * ry + ry / 2.0),
                -2.0,
            );
            let d = p.normalize();
            // |t d − c|² = r²  →  t = d·c − √((d·c)² − |c|² + r²)
            let b = d.dot(c);
            let disc = b * b - c.length_squared() + r * r;
            let expected = if disc < 0.0 {
                0.0
            } else {
                let n = (d * (b - disc.sqrt()) - c) / r;
                kd * n.dot(-light_dir).max(0.0)
            };
            if expected > 0.0 {
                lit += 1;
            }
            let got = film.get(x, y);
            for ch in 0..3 {
                assert!((f64::from(got[ch]) - expected).abs() < 1e-6, "pixel ({x}, {y}): {} vs {expected}", got[ch]);
            }
        }
    }
    assert!(lit > 200, "the sphere should cover many lit pixels, got {lit}");
}

#[test]
fn adaptive_pixels_do_not_depend_on_the_tile_or_the_order() {
    // Each pixel alone (its own one-pixel window), and the pixels of an odd window walked
    // backwards, give the render's bits: a pixel depends only on the lattice points inside it,
    // whatever a tile split or a crop shares or traces first.
    for settings in [
        AdaptiveSettings::new(0.01, 3),
        AdaptiveSettings { edges: false, cell_samples: 3, ..AdaptiveSettings::new(0.02, 2) },
        AdaptiveSettings { coarse: 2, ..AdaptiveSettings::new(0.01, 3) },
        AdaptiveSettings { coarse: 3, signature: true, ..AdaptiveSettings::new(0.02, 2) },
    ] {
        let mut j = with(EDGES, 1, Antialiasing::Adaptive(settings));
        j.scene.camera.aperture = 0.05;
        j.settings.lens_samples = 2;
        let film = run(&j, Some(2)).film;
        let mut stats = raylab::render::stats::RayStats::new(j.integrator.counters());
        // As the render stores a pixel: one exact unit of weight.
        let bits = |v: raylab::glam::DVec3| raylab::render::accum::PixelSum::whole(v).mean().as_vec3().to_array().map(f32::to_bits);
        for y in 0..j.settings.height {
            for x in 0..j.settings.width {
                let alone = Adaptive::new(&j, settings, x, 1, false).pixel(x, y, &mut stats).color;
                assert_eq!(bits(alone), film.get(x, y).to_array().map(f32::to_bits), "pixel ({x}, {y}), {settings:?}");
            }
        }
        let mut window = Adaptive::new(&j, settings, 5, 17, false);
        for y in (3..20).rev() {
            for x in (5..22).rev() {
                let v = window.pixel(x, y, &mut stats).color;
                assert_eq!(bits(v), film.get(x, y).to_array().map(f32::to_bits), "pixel ({x}, {y}) walked backwards");
            }
        }
    }
}
