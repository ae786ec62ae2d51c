//! Textures filtered by footprint (ray differentials, MIP maps, band-limited patterns): a
//! checker plane toward the horizon turns grey instead of moiré at 1 spp; a texture whose texels
//! are `k` times smaller than the pixels reads MIP level log2 k; a mirror carries the camera's
//! differential; filtering changes nothing for any thread count, and `texture_filter = false`
//! gives the point lookups back.

use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::render::{RenderJob, RenderOptions, render};
use std::path::Path;

/// A checker plane seen at a grazing angle, to the horizon, at 1 spp.
const CHECKER_PLANE: &str = r#"
[render]
width = 160
height = 120
spp = 1
texture_filter = true
[camera]
position = [0, 1, 0]
look_at = [0, 0.6, -10]
fov = 40
[[object]]
type = "plane"
material = { kd = { type = "checker", even = 0.9, odd = 0.05, transform = { scale = 0.5 } }, ks = 0 }
[[light]]
type = "directional"
direction = [0, -1, 0]
[[light]]
type = "ambient"
ka = 0.1
"#;

fn job(text: &str, extra: &str) -> RenderJob {
    load_str(&raylab_plugins::registry(), "test.toml", &format!("{text}{extra}"), Path::new("."), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.report()))
}

/// The luminance of every pixel, row by row.
fn pixels(job: &RenderJob, threads: usize) -> Vec<f64> {
    let r = render(job, &RenderOptions { threads: Some(threads), ..RenderOptions::default() }, &|_, _| {}).unwrap();
    let (w, h) = (job.settings.width, job.settings.height);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| f64::from(r.film.get(x, y).dot(raylab::glam::Vec3::splat(1.0 / 3.0))))
        .collect()
}

/// The energy of the differences between horizontal neighbours in rows `rows` (the image's
/// high frequencies: moiré and aliasing).
fn high_frequency(p: &[f64], width: usize, rows: std::ops::Range<usize>) -> f64 {
    let mut e = 0.0;
    for y in rows {
        for x in 1..width {
            let d = p[y * width + x] - p[y * width + x - 1];
            e += d * d;
        }
    }
    e
}

/// Toward the horizon (the far half of the plane, just below the horizon line), filtering cuts
/// the high-frequency energy by a large factor and brings the 1-spp image much nearer the
/// supersampled one (64 spp, point lookups: what the pixels should be); the near rows, where
/// cells are many pixels wide, keep their edges.
#[test]
fn a_checker_plane_turns_grey_toward_the_horizon() {
    let filtered = job(CHECKER_PLANE, "");
    assert!(filtered.scene.filters_textures(), "a textured scene filters when asked");
    let point = job(&CHECKER_PLANE.replace("texture_filter = true", "texture_filter = false"), "");
    assert!(!point.scene.filters_textures());
    let w = filtered.settings.width as usize;
    let (a, b) = (pixels(&filtered, 2), pixels(&point, 2));
    // The horizon is at row ~ h/2 + a little (the camera looks down); the far plane is the band
    // just below it.
    let h = filtered.settings.height as usize;
    let far = h / 2..h / 2 + h / 8;
    let (ea, eb) = (high_frequency(&a, w, far.clone()), high_frequency(&b, w, far.clone()));
    assert!(eb > 0.0, "the point-sampled plane aliases");
    assert!(ea * 5.0 < eb, "filtered {ea} vs point-sampled {eb}: not a large factor");
    let reference =
        pixels(&job(&CHECKER_PLANE.replace("texture_filter = true", "texture_filter = false").replace("spp = 1\n", "spp = 64\n"), ""), 2);
    let error = |p: &[f64]| far.clone().flat_map(|y| (0..w).map(move |x| y * w + x)).map(|i| (p[i] - reference[i]).powi(2)).sum::<f64>();
    let (ra, rb) = (error(&a), error(&b));
    assert!(ra * 5.0 < rb, "squared error against the supersampled image: filtered {ra}, point-sampled {rb}");
    // Near the camera the cells are wide: both images agree on most pixels.
    let near = (h - 10) * w..h * w;
    let same = near.clone().filter(|&i| (a[i] - b[i]).abs() < 1e-3).count();
    assert!(same * 10 > near.len() * 8, "near rows: {same} of {} agree", near.len());
    // The far band is close to the mean of the two colours (lit: kd · (1 + 0.1 ambient)).
    let mean_kd = 0.5 * (0.9 + 0.05);
    let row = h / 2 + 4;
    let band: f64 = (w / 4..3 * w / 4).map(|x| a[row * w + x]).sum::<f64>() / (w / 2) as f64;
    assert!(band > 0.3 * mean_kd && band < 1.5 * mean_kd, "far band {band}");
}

/// Filtering is the default: a scene that does not say filters its textures.
#[test]
fn filtering_is_on_by_default() {
    let unsaid = CHECKER_PLANE.replace("texture_filter = true\n", "");
    assert_ne!(unsaid, CHECKER_PLANE);
    assert!(job(&unsaid, "").scene.filters_textures());
}

/// Filtering is a pure function of each sample: the same bits for any thread count.
#[test]
fn filtered_images_do_not_depend_on_threads() {
    let j = job(CHECKER_PLANE, "");
    assert_eq!(pixels(&j, 1), pixels(&j, 3));
}

/// A scene without textures never filters (no ray computes a differential), whatever the
/// setting.
#[test]
fn untextured_scenes_compute_no_differentials() {
    let plain = CHECKER_PLANE.replace(r#"kd = { type = "checker", even = 0.9, odd = 0.05, transform = { scale = 0.5 } }"#, "kd = 0.5");
    assert!(!job(&plain, "").scene.filters_textures());
}

/// A quad facing the camera that fills exactly `N × N` pixels, textured with an image of
/// `N·k × N·k` texels: at its centre a pixel covers `k × k` texels, and the lookup reads MIP
/// level log2 k.
#[test]
fn a_quad_of_n_pixels_with_an_nk_texture_reads_level_log2_k() {
    use raylab_plugins::textures::image::{Filter, Image, Wrap, with_mip_maps};
    let (n, pixels_high, dist, fov) = (32u32, 96u32, 10.0f64, 30.0f64);
    // One pixel at the quad's distance (the screen is at the look-at point).
    let pixel = 2.0 * dist * (fov.to_radians() / 2.0).tan() / f64::from(pixels_high);
    let s = 0.5 * f64::from(n) * pixel;
    let scene = format!(
        r#"
[render]
width = {pixels_high}
height = {pixels_high}
texture_filter = true
[camera]
position = [0, 0, {dist}]
look_at = [0, 0, 0]
fov = {fov}
[[object]]
type = "quadrangle"
p0 = [{m}, {m}, 0]
p1 = [{s}, {m}, 0]
p2 = [{s}, {s}, 0]
p3 = [{m}, {s}, 0]
material = {{ kd = {{ type = "checker" }} }}
"#,
        m = -s
    );
    let j = job(&scene, "");
    let c = f64::from(pixels_high) / 2.0;
    // Just off the centre, inside the quad's central texel.
    let ray = j.scene.camera.ray_through(pixels_high, pixels_high, raylab::glam::DVec2::new(c + 0.25, c + 0.25), raylab::glam::DVec2::ZERO);
    let si = j.scene.trace(&ray).expect("the quad is hit").with_spread(j.scene.camera_spread(&ray));
    let f = si.texture_point().footprint;
    let one = 1.0 / f64::from(n);
    assert!((f.duv_dx - raylab::glam::DVec2::new(one, 0.0)).length() < 1e-9, "{f:?}");
    assert!((f.duv_dy - raylab::glam::DVec2::new(0.0, -one)).length() < 1e-9, "{f:?}");
    let ctx_options = LoadOptions::default();
    let ctx = raylab::LoadContext::new(Path::new("."), &ctx_options);
    for k in [1u32, 2, 4, 8] {
        let size = (n * k) as usize;
        // Texels alternating 0 and 1: level 0 is black or white, every level above grey.
        let texels = (0..size * size).flat_map(|i| [((i % size + i / size) % 2) as f32; 3]).collect();
        let image = Image::from_linear(size, size, texels).unwrap();
        with_mip_maps(&image, &ctx).unwrap();
        let level = image.mip_level((f.duv_dx, f.duv_dy));
        assert!((level - f64::from(k).log2()).abs() < 1e-6, "k = {k}: level {level}");
        let v = image.lookup_filtered(si.uv(), (f.duv_dx, f.duv_dy), [Wrap::Repeat; 2], Filter::Bilinear).x;
        if k > 1 {
            assert!((v - 0.5).abs() < 1e-6, "k = {k}: {v} is not the texels' mean");
        }
    }
}

/// The differential of a ray mirrored by a curved mirror (a sphere) matches finite differences
/// of the mirrored rays of neighbouring film positions: the hit's move and the direction's turn.
#[test]
fn differentials_through_a_mirror_match_finite_differences() {
    let scene = r#"
[render]
width = 64
height = 48
texture_filter = true
[camera]
position = [0, 0.5, 6]
look_at = [0.2, 0, 0]
fov = 40
[[object]]
type = "sphere"
center = [0, 0, 0]
radius = 1.5
material = { kd = { type = "checker" }, kr = 0.9 }
[[object]]
type = "plane"
point = [0, 0, -3]
normal = [0.1, 0, 1]
material = { kd = 0.5, kr = 1 }
"#;
    let j = job(scene, "");
    let (w, h) = (j.settings.width, j.settings.height);
    let reflect = |d: raylab::glam::DVec3, n: raylab::glam::DVec3| d - 2.0 * d.dot(n) * n;
    for film in [raylab::glam::DVec2::new(32.5, 24.5), raylab::glam::DVec2::new(27.25, 20.75), raylab::glam::DVec2::new(36.0, 29.0)] {
        let ray = j.scene.camera.ray_through(w, h, film, raylab::glam::DVec2::ZERO);
        let si = j.scene.trace(&ray).expect("the mirror ball").with_spread(j.scene.camera_spread(&ray));
        let out = reflect(ray.dir, si.n);
        let raylab::geometry::differential::RaySpread::Differential(d) = si.reflected_spread(out) else { panic!("no differential") };
        let eps = 1e-4;
        for (step, dodx, dddx) in
            [(raylab::glam::DVec2::new(eps, 0.0), d.dodx, d.dddx), (raylab::glam::DVec2::new(0.0, eps), d.dody, d.dddy)]
        {
            let r2 = j.scene.camera.ray_through(w, h, film + step, raylab::glam::DVec2::ZERO);
            let s2 = j.scene.trace(&r2).expect("the mirror ball");
            let fd_point = (s2.hit.point - si.hit.point) / eps;
            let fd_dir = (reflect(r2.dir, s2.n) - out) / eps;
            assert!((fd_point - dodx).length() < 1e-3 * fd_point.length().max(1e-3), "{film}: hit moves {fd_point} vs {dodx}");
            assert!((fd_dir - dddx).length() < 1e-3 * fd_dir.length().max(1e-3), "{film}: direction turns {fd_dir} vs {dddx}");
        }
    }
}
