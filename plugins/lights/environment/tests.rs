//! The environment light: its samples, the rays that leave the scene and its densities agree; its
//! sampling passes the χ² test; the two strategies' MIS weights sum to one; directions map to the
//! image as documented.

use super::*;
use crate::integrators::path::power_heuristic;
use raylab::scene::light::testing::{check_light, chi2_light};
use raylab::testing::chi2::{Chi2Test, Sphere, Uniform};

/// A procedural sky, `w × h`: a gradient from a bright horizon to a deep blue zenith, a dark
/// ground, and a small sun (about 100× the sky) at azimuth `sun_u`, elevation 30°.
fn sky(w: usize, h: usize, sun_u: f64) -> Arc<Image> {
    let mut t = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        let v = (y as f64 + 0.5) / h as f64;
        for x in 0..w {
            let u = (x as f64 + 0.5) / w as f64;
            let elevation = (0.5 - v) * 180.0;
            let mut c = if elevation > 0.0 {
                let k = (elevation / 90.0).powf(0.5);
                [0.9 - 0.7 * k, 1.0 - 0.6 * k, 1.2 - 0.3 * k]
            } else {
                [0.15, 0.12, 0.1]
            };
            let d = ((u - sun_u) * 360.0).hypot(elevation - 30.0);
            if d < 6.0 {
                c = [120.0, 100.0, 80.0];
            }
            t.extend(c.map(|v| v as f32));
        }
    }
    Arc::new(Image::from_linear(w, h, t).unwrap())
}

fn lights() -> Vec<(&'static str, Environment)> {
    vec![
        ("constant", Environment::constant(Color::new(0.5, 0.7, 1.0), 0.4, 16)),
        ("sky", Environment::image(sky(64, 32, 0.3), Color::ONE, 0.0, 16, 1024)),
        ("turned sky", Environment::image(sky(64, 32, 0.7), Color::new(1.0, 0.5, 2.0), 1.1, 16, 1024)),
        ("coarse sky", Environment::image(sky(64, 32, 0.55), Color::ONE, -2.0, 16, 16)),
    ]
}

#[test]
fn directions_map_to_the_image_as_documented() {
    let env = Environment::constant(Color::ONE, 0.0, 1);
    let uv = |d: DVec3| env.to_uv(d.normalize()).0;
    assert!((uv(DVec3::NEG_Z) - DVec2::new(0.5, 0.5)).length() < 1e-12, "−z is the centre");
    assert!((uv(DVec3::X) - DVec2::new(0.75, 0.5)).length() < 1e-12, "+x is right of the centre");
    assert!((uv(DVec3::new(0.0, 1.0, -1e-9)).y).abs() < 1e-6, "up is the top row");
    assert!((uv(DVec3::new(0.0, -1.0, -1e-9)).y - 1.0).abs() < 1e-6, "down is the bottom row");
    // Turned by 90° counter-clockwise seen from above: what was along −z is now along −x.
    let turned = Environment::constant(Color::ONE, 90f64.to_radians(), 1);
    assert!((turned.to_uv(DVec3::NEG_X).0 - DVec2::new(0.5, 0.5)).length() < 1e-12);
    // direction_of inverts to_uv.
    let mut u = Uniform::new(5);
    for env in [&env, &turned] {
        for _ in 0..1000 {
            let p = u.next_2d();
            let (dir, s) = env.direction_of(p);
            let (back, s2) = env.to_uv(dir);
            assert!((dir.length() - 1.0).abs() < 1e-12 && (s - s2).abs() < 1e-12);
            assert!((back - p).length() < 1e-9, "{p} → {dir} → {back}");
        }
    }
}

#[test]
fn samples_rays_and_densities_agree() {
    for (name, light) in lights() {
        for p in [DVec3::ZERO, DVec3::new(3.0, -2.0, 100.0)] {
            // The image's radiance is bilinear between texels, the density constant on cells: the
            // grid integral converges slowly at the sun's rim.
            let (integral, mean) = check_light(&light, p, 1 << 14, 800, 0.02);
            assert!(mean.max_element() > 0.0, "{name}: {integral} vs {mean}");
        }
        // A ray that meets a surface first never reaches it.
        assert!(light.intersect(&Ray { origin: DVec3::ZERO, dir: DVec3::Y }, 1e30).is_none());
        assert!(light.is_area() && light.environment(DVec3::Y).is_some() && light.bound(DVec3::ZERO).is_none());
    }
}

/// A sample for a point lit from one side is the same sample as without the side, its
/// intensity left zero only where it arrives from behind: to the bit, so images do not change.
#[test]
fn facing_samples_are_the_samples_and_only_behind_are_dark() {
    let mut u = Uniform::new(11);
    for (name, light) in lights() {
        let (mut behind, mut facing) = (0, 0);
        for k in 0..4000 {
            let n = match k % 3 {
                0 => DVec3::Y,
                1 => DVec3::new(0.3, -0.5, 0.8).normalize(),
                _ => DVec3::NEG_Z,
            };
            let r = u.next_2d();
            let (a, pa) = light.illuminate_pdf(DVec3::ZERO, r).unwrap();
            let (b, pb) = light.illuminate_facing(DVec3::ZERO, n, r).unwrap();
            assert!(a.dir == b.dir && a.distance == b.distance && pa == pb, "{name}: {a:?} {pa:?} vs {b:?} {pb:?}");
            if a.dir.dot(n) > 0.0 {
                facing += 1;
                assert!(a.intensity == b.intensity, "{name}: facing {a:?} vs {b:?}");
            } else {
                behind += 1;
                // An image is not looked up behind; one colour costs nothing to give in full.
                let expected = if light.uniform() { a.intensity } else { Color::ZERO };
                assert!(b.intensity == expected, "{name}: behind {a:?} vs {b:?}");
            }
        }
        assert!(behind > 100 && facing > 100, "{name}: {behind} behind, {facing} facing");
    }
}

/// The camera sees the radiance the light's samples and rays imply: `environment(dir)` is
/// `π × intensity × pdf` of the ray leaving along `dir`.
#[test]
fn what_rays_see_is_what_lights_the_scene() {
    let mut u = Uniform::new(9);
    for (name, light) in lights() {
        for _ in 0..2000 {
            let s = light.illuminate(DVec3::ZERO, u.next_2d()).unwrap();
            let m = light.intersect(&Ray { origin: DVec3::ZERO, dir: s.dir }, f64::INFINITY).unwrap();
            let pdf = light.pdf(DVec3::ZERO, &m).solid_angle().unwrap();
            let implied = m.intensity * PI * pdf;
            let seen = light.environment(s.dir).unwrap();
            assert!((implied - seen).abs().max_element() <= 1e-9 * seen.max_element(), "{name}: {implied} vs {seen}");
        }
    }
}

/// A sky with a wide glow instead of a sharp sun: the χ² test integrates the density by
/// Simpson's rule, which a 100× step between neighbouring cells would defeat (the sharp skies'
/// densities are checked by [`samples_rays_and_densities_agree`] and the round trip).
fn glow(w: usize, h: usize, sun_u: f64) -> Arc<Image> {
    let mut t = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        let elevation = (0.5 - (y as f64 + 0.5) / h as f64) * 180.0;
        for x in 0..w {
            let u = (x as f64 + 0.5) / w as f64;
            let d = ((u - sun_u) * 360.0).hypot(elevation - 30.0);
            let g = 1.0 + 30.0 * (-d * d / (2.0 * 12.0 * 12.0)).exp();
            let ground = if elevation < 0.0 { 0.3 } else { 1.0 };
            t.extend([g * ground, 0.8 * g * ground, (0.6 + 0.5 * (elevation / 90.0).abs()) * ground].map(|v| v as f32));
        }
    }
    Arc::new(Image::from_linear(w, h, t).unwrap())
}

#[test]
fn sampling_passes_the_chi2_test() {
    let test = Chi2Test::new(Sphere).res(72, 36).samples(400_000).integration(32).tests(4);
    let cases = [
        ("constant", Environment::constant(Color::new(0.5, 0.7, 1.0), 0.4, 16)),
        ("glow", Environment::image(glow(64, 32, 0.3), Color::ONE, 0.0, 16, 1024)),
        ("turned glow", Environment::image(glow(64, 32, 0.7), Color::new(1.0, 0.5, 2.0), 1.1, 16, 1024)),
        ("coarse glow", Environment::image(glow(64, 32, 0.55), Color::ONE, -2.0, 16, 16)),
    ];
    for (name, light) in cases {
        // The histogram's pole (+z) on the map's (+y), where the map is singular: no sub-cell
        // point of the integration falls next to it, off a cell's edge.
        let turn = |d: DVec3| DVec3::new(d.x, -d.z, d.y);
        let back = |w: DVec3| DVec3::new(w.x, w.z, -w.y);
        test.run(|u| Some(turn(light.illuminate(DVec3::ZERO, u.next_2d())?.dir)), |w| light.density(back(w))).assert_passes(name);
        // The light's own interface, as chi2_light reads it, agrees with the density.
        let d = back(DVec3::new(0.3, 0.4, 0.5).normalize());
        let m = light.intersect(&Ray { origin: DVec3::ZERO, dir: d }, f64::INFINITY).unwrap();
        assert_eq!(light.pdf(DVec3::ZERO, &m).solid_angle(), Some(light.density(d)));
    }
    // Away from the poles, the generic light test (which turns nothing here) passes too.
    let near = Environment::constant(Color::ONE, 0.0, 1);
    chi2_light(&near, DVec3::ZERO, &test).assert_passes("constant, through chi2_light");
}

/// The χ² test can fail: one sky's samples judged against another's density.
#[test]
fn the_chi2_test_rejects_another_skys_density() {
    let test = Chi2Test::new(Sphere).res(72, 36).samples(200_000);
    let (a, b) =
        (Environment::image(sky(64, 32, 0.3), Color::ONE, 0.0, 1, 1024), Environment::image(sky(64, 32, 0.35), Color::ONE, 0.0, 1, 1024));
    test.run(|u| Some(a.illuminate(DVec3::ZERO, u.next_2d())?.dir), |w| b.density(w)).assert_fails("another sky");
}

/// Light samples and BSDF rays weigh each direction with densities that agree, so their power
/// heuristic weights sum to one wherever both can find the light.
#[test]
fn mis_weights_of_both_strategies_sum_to_one() {
    let mut u = Uniform::new(17);
    for (name, light) in lights() {
        for n in [1u32, 4] {
            for _ in 0..2000 {
                // A light sample's direction, and a cosine-distributed "BSDF" direction about +y.
                let s = light.illuminate(DVec3::ZERO, u.next_2d()).unwrap();
                let r = u.next_2d();
                let (sin, cos) = (r.x.sqrt(), (1.0 - r.x).sqrt());
                let b = DVec3::new(sin * (TAU * r.y).cos(), cos, sin * (TAU * r.y).sin());
                for dir in [s.dir, b] {
                    let bsdf_pdf = dir.y.max(0.0) / PI;
                    let light_pdf = light
                        .intersect(&Ray { origin: DVec3::ZERO, dir }, f64::INFINITY)
                        .and_then(|m| light.pdf(DVec3::ZERO, &m).solid_angle())
                        .unwrap();
                    let from_light = power_heuristic(f64::from(n) * light_pdf, bsdf_pdf);
                    let from_bsdf = power_heuristic(bsdf_pdf, f64::from(n) * light_pdf);
                    assert!((from_light + from_bsdf - 1.0).abs() < 1e-12, "{name}: {from_light} + {from_bsdf}");
                }
            }
        }
    }
}

#[test]
fn a_black_image_is_sampled_uniformly_and_lights_nothing() {
    let black = Environment::image(Arc::new(Image::from_linear(8, 4, vec![0.0; 96]).unwrap()), Color::ONE, 0.0, 1, 1024);
    let s = black.illuminate(DVec3::ZERO, DVec2::new(0.3, 0.6)).unwrap();
    assert_eq!(s.intensity, Color::ZERO);
    assert!(black.density(s.dir) > 0.0);
}

#[test]
fn the_grid_is_never_finer_than_a_quarter_texel() {
    assert_eq!(grid_size(4096, 2048, 1024), (1024, 512));
    assert_eq!(grid_size(64, 32, 1024), (128, 64));
    assert_eq!(grid_size(64, 32, 128), (128, 64));
    assert_eq!(grid_size(64, 32, 127), (64, 32));
    assert_eq!(grid_size(64, 32, 1), (1, 1));
    assert_eq!(grid_size(5, 1, 3), (3, 1));
}

/// A texel's value is seen along the direction of its centre, (u, v) = ((x + ½)/w, (y + ½)/h),
/// and nowhere past its neighbours' centres; the light's samples of a sky lit by that one texel
/// go through it. Rows at θ = y/(h − 1)·π (Mitsuba's `envmap`, pole to pole) would put the
/// texel below 22.5° elevation 7.5° higher, and the sun of a real sky where the comparison
/// with Mitsuba found it: 0.6° off, the floor 2–4 % too bright.
#[test]
fn a_bright_texel_lands_where_its_centre_points() {
    let (w, h, bx, by) = (8, 4, 5, 1);
    let mut t = vec![0.01f32; w * h * 3];
    t[(by * w + bx) * 3..][..3].copy_from_slice(&[100.0; 3]);
    let env = Environment::image(Arc::new(Image::from_linear(w, h, t).unwrap()), Color::ONE, 0.0, 1, 1024);
    // Elevation and azimuth (toward +x from −z) in degrees, as the module docs map them.
    let toward = |elevation: f64, azimuth: f64| {
        let (e, a) = (elevation.to_radians(), azimuth.to_radians());
        DVec3::new(e.cos() * a.sin(), e.sin(), -e.cos() * a.cos())
    };
    // Row 1 of 4: centre at θ = 1.5/4 · 180° = 67.5°, elevation 22.5°; column 5 of 8: centre at
    // 5.5/8 · 360° − 180° = 67.5°.
    let seen = |elevation, azimuth| env.environment(toward(elevation, azimuth)).unwrap();
    assert_eq!(seen(22.5, 67.5), Color::splat(100.0), "the texel's centre sees it alone");
    for (e, a) in [(67.5, 67.5), (-22.5, 67.5), (22.5, 22.5), (22.5, 112.5)] {
        assert!((seen(e, a) - Color::splat(0.01)).abs().max_element() < 1e-6, "a neighbour's centre ({e}°, {a}°) sees none of it");
    }
    // Bilinear between centres 45° apart: 7.5° above or below, a sixth of the way to the
    // neighbour (where Mitsuba's rows would see the texel in full, at 30°).
    for e in [30.0, 15.0] {
        let expected = 100.0 - (100.0 - 0.01) / 6.0;
        assert!((seen(e, 67.5).x - expected).abs() < 1e-3, "{e}°: {} vs {expected}", seen(e, 67.5));
    }
    // The light's samples go through the texel's cell (elevation 0°..45°, azimuth 45°..90°) or
    // its neighbours', where the lookup still sees it (elevation −45°..90°, azimuth 0°..135°),
    // and their mean azimuth is its centre's.
    let mut u = Uniform::new(3);
    let (mut around, mut inside, mut azimuths) = (0, 0, 0.0);
    for _ in 0..10_000 {
        let d = env.illuminate(DVec3::ZERO, u.next_2d()).unwrap().dir;
        let (elevation, azimuth) = (d.y.asin().to_degrees(), d.x.atan2(-d.z).to_degrees());
        if (-45.0..90.0).contains(&elevation) && (0.0..135.0).contains(&azimuth) {
            around += 1;
            azimuths += azimuth;
        }
        inside += usize::from((0.0..45.0).contains(&elevation) && (45.0..90.0).contains(&azimuth));
    }
    assert!(around > 9_900 && inside > 2_500, "{around} of 10000 samples around the bright texel, {inside} through it");
    let mean = azimuths / f64::from(around);
    assert!((mean - 67.5).abs() < 1.0, "the samples' mean azimuth {mean}°");
}

/// No light sample carries much more than the mean: the density holds each texel at the
/// brightest the bilinear lookup sees around it, so a sky texel beside the sun, which the lookup
/// sees half lit, is not drawn as rarely as the sky (by the texel values alone, samples there
/// carried 100× the mean on this sky: fireflies, and 5× Mitsuba's samples for equal error on
/// compare.py's image environment).
#[test]
fn no_sample_outweighs_the_mean_by_much() {
    let mut u = Uniform::new(23);
    for (name, light) in lights().into_iter().skip(1) {
        let coarse = name == "coarse sky";
        let values: Vec<f64> = (0..100_000).map(|_| luminance(light.illuminate(DVec3::ZERO, u.next_2d()).unwrap().intensity)).collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let most = values.iter().copied().fold(0.0, f64::max);
        // Within 2× from sin θ across a cell (most beside the poles), times the bound's excess
        // over the mean radiance where the sky changes fast; more on a grid coarser than the
        // image (its cells' means hide their brightest texels).
        let bound = if coarse { 20.0 } else { 4.0 };
        assert!(most < bound * mean, "{name}: a sample carries {:.1}× the mean", most / mean);
    }
}

/// The compensated density ([`LightSource::illuminate_mis`]) passes the χ² test against its own
/// density, the one [`LightSource::environment_pdf`] gives the rays it is weighed against.
#[test]
fn compensated_sampling_passes_the_chi2_test() {
    let test = Chi2Test::new(Sphere).res(72, 36).samples(400_000).integration(32).tests(4);
    let cases = [
        ("glow", Environment::image(glow(64, 32, 0.3), Color::ONE, 0.0, 16, 1024)),
        ("turned glow", Environment::image(glow(64, 32, 0.7), Color::new(1.0, 0.5, 2.0), 1.1, 16, 1024)),
        ("coarse glow", Environment::image(glow(64, 32, 0.55), Color::ONE, -2.0, 16, 16)),
    ];
    for (name, light) in cases {
        assert!(light.compensated.is_some(), "{name}: a glow has cells above the mean");
        let turn = |d: DVec3| DVec3::new(d.x, -d.z, d.y);
        let back = |w: DVec3| DVec3::new(w.x, w.z, -w.y);
        test.run(|u| Some(turn(light.illuminate_mis(DVec3::ZERO, None, u.next_2d())?.0.dir)), |w| light.mis_density(back(w)))
            .assert_passes(name);
        // And not against the density by luminance, which it is not.
        test.run(|u| Some(turn(light.illuminate_mis(DVec3::ZERO, None, u.next_2d())?.0.dir)), |w| light.density(back(w)))
            .assert_fails(&format!("{name}, against the uncompensated density"));
    }
}

/// A compensated sample says the density that [`LightSource::environment_pdf`] gives a ray
/// leaving along its direction, with the radiance the ray sees; lit from one side, the same
/// sample, dark only behind; the power heuristic's weights of the two strategies sum to one.
#[test]
fn compensated_samples_and_escaping_rays_agree() {
    let mut u = Uniform::new(29);
    for (name, light) in lights() {
        for _ in 0..4000 {
            let r = u.next_2d();
            let (s, p) = light.illuminate_mis(DVec3::ZERO, None, r).unwrap();
            let p = p.solid_angle().unwrap();
            let (seen, q) = light.environment_pdf(DVec3::ZERO, s.dir).unwrap();
            assert!((p - q).abs() <= 1e-9 * p, "{name}: drawn with {p}, the ray says {q}");
            let implied = s.intensity * PI * p;
            assert!((implied - seen).abs().max_element() <= 1e-9 * seen.max_element().max(1e-300), "{name}: {implied} vs {seen}");
            let n = DVec3::new(0.3, 0.8, -0.2).normalize();
            let (f, pf) = light.illuminate_mis(DVec3::ZERO, Some(n), r).unwrap();
            assert!(f.dir == s.dir && pf.solid_angle() == Some(p), "{name}");
            assert!(if s.dir.dot(n) > 0.0 { f.intensity == s.intensity } else { f.intensity == Color::ZERO || light.uniform() }, "{name}");
            let bsdf_pdf = 0.3;
            let sum = power_heuristic(p, bsdf_pdf) + power_heuristic(bsdf_pdf, p);
            assert!((sum - 1.0).abs() < 1e-12, "{name}: {sum}");
        }
    }
}

/// Compensation leaves the sky below its mean to the BSDF's rays: almost no compensated sample
/// goes where the sky is dimmer than its mean (the density floor's share, and cells the sun's
/// rim reaches into), and they go to the sun twice as often as by luminance.
#[test]
fn compensated_samples_leave_the_dim_sky_to_the_bsdf() {
    let light = Environment::image(sky(64, 32, 0.3), Color::ONE, 0.0, 16, 1024);
    let mut u = Uniform::new(31);
    // The sky's mean luminance over the sphere (uniform directions).
    let n = 100_000;
    let mean = (0..n)
        .map(|_| {
            let r = u.next_2d();
            let z = 1.0 - 2.0 * r.x;
            let s = (1.0 - z * z).max(0.0).sqrt();
            luminance(light.environment(DVec3::new(s * (TAU * r.y).cos(), z, s * (TAU * r.y).sin())).unwrap())
        })
        .sum::<f64>()
        / f64::from(n);
    let (mut dim, mut sun_mis, mut sun_all) = (0, 0, 0);
    for _ in 0..n {
        let r = u.next_2d();
        let seen = |s: LightSample, pdf: LightPdf| luminance(s.intensity * PI * pdf.solid_angle().unwrap());
        let (a, pa) = light.illuminate_mis(DVec3::ZERO, None, r).unwrap();
        let (b, pb) = light.illuminate_pdf(DVec3::ZERO, r).unwrap();
        dim += usize::from(seen(a, pa) < 0.5 * mean);
        sun_mis += usize::from(seen(a, pa) > 50.0);
        sun_all += usize::from(seen(b, pb) > 50.0);
    }
    assert!(dim < n as usize / 200, "{dim} of {n} compensated samples where the sky is below half its mean {mean}");
    assert!(sun_mis > 2 * sun_all, "{sun_mis} compensated samples in the sun, {sun_all} by luminance");
    // One colour: nothing above the mean, no compensated grid.
    let flat = Environment::image(Arc::new(Image::from_linear(8, 4, vec![0.5; 96]).unwrap()), Color::ONE, 0.0, 1, 1024);
    assert!(flat.compensated.is_none());
}

/// A white furnace under a sky: a white diffuse surface lit by the environment shows (1/π) ∫ L cos,
/// estimated as `path` does, one compensated light sample and one cosine-distributed ray, each
/// weighed by the power heuristic against the other's density (the ray's from
/// [`LightSource::environment_pdf`]); the integral by quadrature of what rays see. The same
/// estimator weighing the rays by the uncompensated density (what the samples were not drawn
/// with) misses the light's share of the dim sky: the test can fail.
#[test]
fn a_white_surface_under_the_sky_shows_the_skys_irradiance() {
    let light = Environment::image(sky(64, 32, 0.3), Color::new(1.0, 0.8, 0.6), 0.4, 16, 1024);
    let (gu, gv) = (1024, 512);
    for n in [DVec3::Y, DVec3::new(0.6, 0.5, -0.62).normalize(), DVec3::new(-0.3, -0.2, 0.93).normalize()] {
        // (1/π) ∫ L(ω) max(0, n·ω) dω over the image's coordinates, dω = 2π² sin θ du dv.
        let mut exact = Color::ZERO;
        for j in 0..gv {
            for i in 0..gu {
                let uv = DVec2::new((i as f64 + 0.5) / gu as f64, (j as f64 + 0.5) / gv as f64);
                let (dir, sin_theta) = light.direction_of(uv);
                let cos = dir.dot(n).max(0.0);
                exact += light.environment(dir).unwrap() * (cos * 2.0 * PI * PI * sin_theta / (gu * gv) as f64 / PI);
            }
        }
        let estimate = |wrong: bool| {
            let mut u = Uniform::new(37);
            let (b1, b2) = raylab::math::sampler::orthonormal_basis(n);
            let count = 1 << 18;
            let (mut sum, mut sum2) = (Color::ZERO, Color::ZERO);
            for _ in 0..count {
                let mut v = Color::ZERO;
                // The light sample: f·cos·π·intensity·w with f = 1/π.
                let (s, p) = light.illuminate_mis(DVec3::ZERO, Some(n), u.next_2d()).unwrap();
                let (p, cos) = (p.solid_angle().unwrap(), s.dir.dot(n));
                if cos > 0.0 {
                    v += s.intensity * cos * power_heuristic(p, cos / PI);
                }
                // The cosine-distributed ray: weight 1, the radiance it sees weighed.
                let r = u.next_2d();
                let (sin, c) = (r.x.sqrt(), (1.0 - r.x).sqrt());
                let dir = sin * (TAU * r.y).cos() * b1 + sin * (TAU * r.y).sin() * b2 + c * n;
                let (seen, q) = light.environment_pdf(DVec3::ZERO, dir).unwrap();
                let q = if wrong { light.density(dir) } else { q };
                v += seen * power_heuristic(c / PI, q);
                sum += v;
                sum2 += v * v;
            }
            let mean = sum / f64::from(count);
            (mean, ((sum2 / f64::from(count) - mean * mean) / f64::from(count)).max(Color::ZERO).powf(0.5))
        };
        let (mean, error) = estimate(false);
        let (biased, biased_error) = estimate(true);
        for c in 0..3 {
            assert!((mean[c] - exact[c]).abs() <= 4.0 * error[c] + 2e-3 * exact[c], "n {n}: {mean} ± {error}, exact {exact}");
        }
        let off = (biased - exact).abs() - 4.0 * biased_error - 2e-3 * exact;
        assert!(off.max_element() > 0.0, "n {n}: the wrong weights gave {biased} ± {biased_error}, exact {exact}");
    }
}
