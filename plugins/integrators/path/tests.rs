//! The path tracer against closed forms: the dielectric's Fresnel reflectance and Snell's law,
//! the BSDF's sampling against its own density and its energy, closed and white furnaces, and
//! direct light against `phong`.

use super::*;
use crate::materials::phong::{LambertBsdf, PhongBsdf, fresnel_dielectric, lobe_brdf, lobe_pdf, thin_slab_reflectance};
use crate::shapes::sphere::Sphere;
use raylab::RayKind;
use raylab::glam::{DVec2, DVec3};
use raylab::load::context::LoadOptions;
use raylab::math::sampler::stratified_2d;
use raylab::param::limits::Limits;
use raylab::scene::bsdf::{Bsdf, Lobe};
use raylab::scene::object::Object;
use raylab::testing::chi2::{Chi2Test, Sphere as Directions};
use raylab::{Camera, Material, RenderJob};
use std::f64::consts::{FRAC_PI_2, TAU};
use std::path::Path;

/// Fresnel reflectance in Walter et al.'s form (2007, eq. 22), written independently of the
/// s/p-polarised form the BSDF uses.
fn walter_fresnel(c: f64, eta: f64) -> f64 {
    let g2 = eta * eta - 1.0 + c * c;
    if g2 < 0.0 {
        return 1.0;
    }
    let g = g2.sqrt();
    let a = (g - c) / (g + c);
    let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    0.5 * a * a * (1.0 + b * b)
}

#[test]
fn fresnel_matches_the_closed_form() {
    for eta in [1.0001, 1.1, 1.333, 1.5, 2.42, 1.0 / 1.333, 1.0 / 1.5, 1.0 / 2.42] {
        for i in 0..=1000 {
            let c = f64::from(i) / 1000.0;
            let (f, w) = (fresnel_dielectric(c, eta), walter_fresnel(c, eta));
            assert!((f - w).abs() < 1e-12, "eta {eta}, cos {c}: {f} vs {w}");
        }
        let r = (eta - 1.0) / (eta + 1.0);
        assert!((fresnel_dielectric(1.0, eta) - r * r).abs() < 1e-15, "normal incidence, eta {eta}");
        assert_eq!(fresnel_dielectric(0.0, eta), 1.0, "grazing incidence reflects everything");
    }
    // Total internal reflection beyond the critical angle, leaving glass (η = 1/1.5).
    let critical = (1.0f64 / 1.5).asin();
    assert_eq!(fresnel_dielectric((critical + 1e-6).cos(), 1.0 / 1.5), 1.0);
    assert!(fresnel_dielectric((critical - 1e-3).cos(), 1.0 / 1.5) < 1.0);
    // Brewster's angle: the parallel part vanishes, leaving half the perpendicular reflectance.
    let brewster = 1.5f64.atan();
    let (ci, ct) = (brewster.cos(), (brewster.sin() / 1.5).asin().cos());
    let rs = ((ci - 1.5 * ct) / (ci + 1.5 * ct)).powi(2);
    assert!((fresnel_dielectric(ci, 1.5) - rs / 2.0).abs() < 1e-15);
    // A thin slab sums its internal reflections: 2F / (1 + F).
    let f = 0.04;
    assert!((thin_slab_reflectance(1.0, 1.5) - 2.0 * f / (1.0 + f)).abs() < 1e-15);
}

/// The interaction of a ray meeting a unit sphere of `material` at its top, `theta` from the
/// normal, from outside (or from inside with `inside`).
fn top_of_sphere(material: Material, theta: f64, inside: bool) -> (Scene, Ray) {
    let cam = Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 45.0, 4, 4).unwrap();
    let object = Object::with_material("ball", Box::new(Sphere::new(DVec3::ZERO, 1.0)), material);
    let scene = Scene::new("test", cam, Color::ZERO, vec![object], vec![]);
    let (d, back) =
        if inside { (DVec3::new(theta.sin(), theta.cos(), 0.0), 0.05) } else { (DVec3::new(theta.sin(), -theta.cos(), 0.0), 2.0) };
    let ray = Ray::new(DVec3::Y - back * d, d);
    (scene, ray)
}

fn bsdf_at(material: Material, theta: f64, inside: bool) -> (PhongBsdf, DVec3) {
    let (scene, ray) = top_of_sphere(material, theta, inside);
    let si = scene.trace(&ray).expect("the ray meets the sphere");
    assert!((si.point() - DVec3::Y).length() < 1e-9);
    (PhongBsdf::new(&si), si.n)
}

/// The bits of everything a BSDF answers toward `wi` and for the numbers `(pick, u, fresnel)`.
fn answers(b: &dyn Bsdf, wi: DVec3, (pick, u, fresnel): (f64, DVec2, f64)) -> Vec<u64> {
    let (f, pdf) = b.eval_pdf(wi);
    let mut out: Vec<f64> = [b.eval(wi), f, b.albedo()].iter().flat_map(|c| c.to_array()).collect();
    out.extend([b.pdf(wi), pdf, f64::from(u8::from(b.has_smooth_lobes()))]);
    match b.sample(pick, u, fresnel) {
        Some(s) => {
            out.extend(s.dir.to_array());
            out.extend(s.weight.to_array());
            out.extend([s.pdf.unwrap_or(-1.0), s.eta_squared, f64::from(s.lobe as u8), f64::from(s.kind == RayKind::Reflection)]);
        }
        None => out.push(f64::NAN),
    }
    out.into_iter().map(f64::to_bits).collect()
}

/// Where only the diffuse lobe has weight the path tracer reads the coefficients through
/// `LambertBsdf`: it must give every answer of `PhongBsdf` bit for bit (the images stay the
/// same), read the same numbers, and stand aside for every other material.
#[test]
fn a_lone_diffuse_lobe_answers_as_the_full_model_bit_for_bit() {
    let plain = Material { kd: Color::ZERO, ks: Color::ZERO, kr: Color::ZERO, kt: Color::ZERO, ..Material::default() };
    let lone = [
        Color::new(0.8, 0.5, 0.3),
        Color::new(0.75, 0.75, 0.75),
        // Scaled down (a channel above 1), with a negative zero, and barely above black.
        Color::new(2.5, 0.4, -0.0),
        Color::new(0.0, 0.0, 1e-300),
    ];
    let mut compared = 0;
    for kd in lone {
        for (theta, inside) in [(0.0, false), (0.7, false), (1.45, false), (0.3, true)] {
            let (scene, ray) = top_of_sphere(Material { kd, ..plain.clone() }, theta, inside);
            let si = scene.trace(&ray).expect("the ray meets the sphere");
            let lambert = LambertBsdf::of(&si, &si.coefficients()).expect("a lone diffuse lobe");
            let full = PhongBsdf::new(&si);
            assert_eq!(full.numbers_read(), LambertBsdf::NUMBERS_READ);
            for i in 0..4096 {
                let u = stratified_2d(i, 4096, 5);
                // Directions all around (above and below both normals), and the sampled ones.
                let z = 2.0 * u.x - 1.0;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let wi = DVec3::new(r * (TAU * u.y).cos(), r * (TAU * u.y).sin(), z);
                let numbers = (f64::from(i) / 4096.0, u, 0.5);
                assert_eq!(answers(&lambert, wi, numbers), answers(&full, wi, numbers), "kd {kd}, θ {theta}, wi {wi}");
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 4 * 4 * 4096);
    // Any other lobe, a Fresnel setting, or black: the full model.
    for m in [
        Material { kd: Color::splat(0.5), ks: Color::new(0.0, 0.0, 0.1), ..plain.clone() },
        Material { kd: Color::splat(0.5), kr: Color::splat(0.2), ..plain.clone() },
        Material { kd: Color::splat(0.5), kt: Color::splat(0.2), ..plain.clone() },
        Material { kd: Color::splat(0.5), fresnel: raylab::scene::material::Fresnel::Schlick, ..plain.clone() },
        Material { kd: Color::ZERO, ..plain.clone() },
    ] {
        let (scene, ray) = top_of_sphere(m, 0.4, false);
        let si = scene.trace(&ray).expect("the ray meets the sphere");
        assert!(LambertBsdf::of(&si, &si.coefficients()).is_none());
    }
}

#[test]
fn the_dielectric_reflects_with_fresnels_probability_and_refracts_by_snells_law() {
    let glass = Material { kd: Color::ZERO, kt: Color::ONE, ior: 1.5, ..Material::default() };
    for (inside, eta) in [(false, 1.5), (true, 1.0 / 1.5)] {
        for theta in [0.0, 0.3, 0.7, 0.75, 1.2, 1.5] {
            let (bsdf, n) = bsdf_at(glass.clone(), theta, inside);
            let f = fresnel_dielectric(theta.cos(), eta);
            let steps = 10_000;
            let mut reflected = 0;
            for i in 0..steps {
                let s = bsdf.sample(0.5, DVec2::splat(0.5), (f64::from(i) + 0.5) / f64::from(steps)).expect("glass scatters");
                assert_eq!(s.lobe, Lobe::Dielectric);
                assert!(s.pdf.is_none(), "specular");
                if s.kind == RayKind::Reflection {
                    reflected += 1;
                    assert!((s.dir.dot(n) - theta.cos()).abs() < 1e-12);
                    assert!((s.weight - Color::ONE).abs().max_element() < 1e-12);
                } else {
                    let sin_t = s.dir.cross(n).length();
                    assert!((sin_t - theta.sin() / eta).abs() < 1e-12, "Snell: {sin_t} vs {}", theta.sin() / eta);
                    assert!(s.dir.dot(n) < 0.0, "transmitted through the surface");
                    assert!((s.eta_squared - eta * eta).abs() < 1e-12);
                    assert!((s.weight - Color::splat(1.0 / (eta * eta))).abs().max_element() < 1e-12, "radiance scales by (η_i/η_t)²");
                }
            }
            let fraction = f64::from(reflected) / f64::from(steps);
            assert!((fraction - f).abs() <= 1.0 / f64::from(steps), "θ {theta}: reflected {fraction}, F = {f}");
        }
    }
}
#[test]
fn a_materials_fresnel_setting_means_what_it_means_for_phong() {
    use raylab::scene::material::Fresnel;
    // Glass given phong's way (kr = kt = 1, Fresnel weights) is the dielectric alone: its own F
    // is the reflection, with no mirror beside it.
    let glass = Material { kd: Color::ZERO, kr: Color::ONE, kt: Color::ONE, ior: 1.5, fresnel: Fresnel::Exact, ..Material::default() };
    for theta in [0.0, 0.7, 1.4] {
        let (bsdf, _) = bsdf_at(glass.clone(), theta, false);
        for pick in [0.0, 0.3, 0.6, 0.99] {
            assert_eq!(bsdf.sample(pick, DVec2::splat(0.5), 0.5).expect("glass scatters").lobe, Lobe::Dielectric, "θ {theta}");
        }
        assert!((bsdf.albedo() - Color::ONE).abs().max_element() < 1e-15);
    }
    // An opaque Fresnel mirror reflects F·kr.
    let metal = Material { kd: Color::ZERO, kr: Color::splat(0.9), ior: 1.5, fresnel: Fresnel::Exact, ..Material::default() };
    for theta in [0.0, 0.7, 1.4] {
        let (bsdf, _) = bsdf_at(metal.clone(), theta, false);
        let f = fresnel_dielectric(theta.cos(), 1.5);
        assert!((bsdf.albedo() - Color::splat(0.9 * f)).abs().max_element() < 1e-12, "θ {theta}: {:?} vs F·kr {}", bsdf.albedo(), 0.9 * f);
    }
}

/// `∫ g(ω) dω` over the hemisphere around unit `n` (midpoint rule in θ, φ).
fn hemisphere_integral(n: DVec3, g: impl Fn(DVec3) -> f64) -> f64 {
    let (b1, b2) = raylab::math::sampler::orthonormal_basis(n);
    let (nt, np) = (600, 1200);
    let mut sum = 0.0;
    for i in 0..nt {
        let theta = (f64::from(i) + 0.5) / f64::from(nt) * FRAC_PI_2;
        let (st, ct) = theta.sin_cos();
        for j in 0..np {
            let phi = (f64::from(j) + 0.5) / f64::from(np) * TAU;
            let w = st * phi.cos() * b1 + st * phi.sin() * b2 + ct * n;
            sum += g(w) * st;
        }
    }
    sum * (FRAC_PI_2 / f64::from(nt)) * (TAU / f64::from(np))
}

/// Mean of `Bsdf::sample`'s weights (zero where it returns nothing) over stratified samples.
fn mean_weight(bsdf: &PhongBsdf, n: u32) -> (Color, f64) {
    let mut sum = Color::ZERO;
    let mut accepted = 0;
    for i in 0..n {
        let u = stratified_2d(i, n, 17);
        let pick = (f64::from(i) + 0.5) / f64::from(n);
        if let Some(s) = bsdf.sample(pick, u, 0.5) {
            sum += s.weight;
            accepted += 1;
        }
    }
    (sum / f64::from(n), f64::from(accepted) / f64::from(n))
}

#[test]
fn sampling_agrees_with_the_density_and_the_brdf() {
    let m = Material {
        kd: Color::new(0.3, 0.2, 0.1),
        ks: Color::splat(0.4),
        shininess: 20.0,
        kr: Color::splat(0.2),
        blur: 0.3,
        ..Material::default()
    };
    for theta in [0.0, 0.6, 1.3] {
        let (bsdf, n) = bsdf_at(m.clone(), theta, false);
        // The density integrates to the share of samples that stay above the surface.
        let mass = hemisphere_integral(n, |w| bsdf.pdf(w));
        let albedo = Color::new(
            hemisphere_integral(n, |w| bsdf.eval(w).x * w.dot(n)),
            hemisphere_integral(n, |w| bsdf.eval(w).y * w.dot(n)),
            hemisphere_integral(n, |w| bsdf.eval(w).z * w.dot(n)),
        );
        let (weight, accepted) = mean_weight(&bsdf, 1 << 18);
        assert!(mass <= 1.0 + 1e-3, "θ {theta}: density mass {mass}");
        assert!((mass - accepted).abs() < 5e-3, "θ {theta}: density mass {mass}, accepted {accepted}");
        assert!((weight - albedo).abs().max_element() < 5e-3, "θ {theta}: E[f cos / pdf] = {weight}, ∫ f cos = {albedo}");
    }
}

/// The density of the directions `Bsdf::sample` returns: `Bsdf::pdf` where the model has a
/// value (elsewhere it declines the direction).
fn returned_density(bsdf: &PhongBsdf, w: DVec3) -> f64 {
    if bsdf.eval(w).max_element() > 0.0 { bsdf.pdf(w) } else { 0.0 }
}

/// χ² tests of the path tracer's smooth lobes, alone and mixed, at normal, oblique and grazing
/// incidence (where lobes cross the surface and part of the samples are declined): the
/// directions follow the density `Bsdf::pdf` gives the integrator's multiple importance sampling.
#[test]
fn every_smooth_lobe_and_their_mixture_pass_the_chi2_test() {
    let plain = Material { kd: Color::ZERO, ks: Color::ZERO, kr: Color::ZERO, kt: Color::ZERO, ..Material::default() };
    let diffuse = Material { kd: Color::new(0.8, 0.5, 0.3), ..plain.clone() };
    let specular = |n: f64| Material { ks: Color::splat(0.9), shininess: n, ..plain.clone() };
    let glossy = Material { kr: Color::splat(0.9), blur: 0.3, ..plain.clone() };
    let mixture = Material {
        kd: Color::new(0.3, 0.2, 0.1),
        ks: Color::splat(0.4),
        shininess: 20.0,
        kr: Color::splat(0.2),
        blur: 0.3,
        ..plain.clone()
    };
    let cases = [
        ("diffuse, normal incidence", diffuse.clone(), 0.0),
        ("diffuse, grazing", diffuse, 1.4),
        ("specular n = 1", specular(1.0), 0.3),
        ("specular n = 20, oblique", specular(20.0), 0.6),
        ("specular n = 3, grazing", specular(3.0), 1.3),
        ("glossy (blur 0.3)", glossy.clone(), 0.5),
        ("glossy (blur 0.3), grazing", glossy, 1.35),
        ("mixture, normal incidence", mixture.clone(), 0.0),
        ("mixture, oblique", mixture.clone(), 0.6),
        ("mixture, grazing", mixture, 1.3),
    ];
    let test = Chi2Test::new(Directions).res(72, 36).tests(cases.len() as u32);
    for (name, m, theta) in cases {
        let (bsdf, _) = bsdf_at(m, theta, false);
        test.run(|u| bsdf.sample(u.next_1d(), u.next_2d(), 0.5).map(|s| s.dir), |w| returned_density(&bsdf, w)).assert_passes(name);
    }
}

/// The guard: the same test rejects the Phong lobe when its density is off by one in the exponent
/// (the classic slip: `(n+2)/2π`, the BRDF's normalisation, used as the density's).
#[test]
fn the_lobe_chi2_test_rejects_a_wrong_normalisation() {
    let (bsdf, _) = bsdf_at(Material { kd: Color::ZERO, ks: Color::splat(0.9), shininess: 20.0, ..Material::default() }, 0.6, false);
    Chi2Test::new(Directions)
        .res(72, 36)
        .run(|u| bsdf.sample(u.next_1d(), u.next_2d(), 0.5).map(|s| s.dir), |w| returned_density(&bsdf, w) * 22.0 / 21.0)
        .assert_fails("a lobe density normalised as the BRDF");
}

/// A blurry dielectric's directions (a stochastic specular event: no density reaches the
/// integrator, but the jitter must still be the lobe it stands for): Fresnel's choice between
/// the reflected and the refracted direction, each jittered in the Phong lobe of exponent
/// `4 / blur²` and flipped back onto its side of the surface.
#[test]
fn a_blurry_dielectric_passes_the_chi2_test() {
    use crate::integrators::phong::{reflect, refract};
    let glass = Material { kd: Color::ZERO, kt: Color::ONE, ior: 1.5, blur: 0.25, ..Material::default() };
    let n_lobe = crate::materials::phong::blur_exponent(0.25);
    // The lobe around `axis`, folded onto the side `side` faces.
    let folded = |w: DVec3, axis: DVec3, side: DVec3| {
        if w.dot(side) < 0.0 { 0.0 } else { lobe_pdf(w.dot(axis), n_lobe) + lobe_pdf(reflect(w, side).dot(axis), n_lobe) }
    };
    let cases = [(false, 0.2), (false, 1.2), (true, 0.4), (true, 0.9)];
    let test = Chi2Test::new(Directions).res(72, 36).tests(cases.len() as u32);
    for (inside, theta) in cases {
        let (bsdf, n) = bsdf_at(glass.clone(), theta, inside);
        let (_, ray) = top_of_sphere(glass.clone(), theta, inside);
        let eta = if inside { 1.0 / 1.5 } else { 1.5 };
        let f = fresnel_dielectric(theta.cos(), eta);
        let reflected = reflect(ray.dir, n);
        let refracted = refract(ray.dir, n, 1.0 / eta);
        test.run(
            |u| {
                let s = bsdf.sample(u.next_1d(), u.next_2d(), u.next_1d())?;
                assert!(s.pdf.is_none(), "a stochastic specular event");
                Some(s.dir)
            },
            |w| match refracted {
                Some(t) => f * folded(w, reflected, n) + (1.0 - f) * folded(w, t, -n),
                None => folded(w, reflected, n),
            },
        )
        .assert_passes(&format!("blurry glass, θ {theta}{}", if inside { ", from inside" } else { "" }));
    }
}

#[test]
fn the_normalised_phong_lobe_conserves_energy() {
    for n in [0.0, 1.0, 10.0, 100.0, 1000.0] {
        // At normal incidence the lobe's albedo is exactly 1: (n+2)/(2π) is its normalisation.
        let albedo = hemisphere_integral(DVec3::Z, |w| lobe_brdf(w.z, n) * w.z);
        assert!((albedo - 1.0).abs() < 2e-3, "exponent {n}: albedo {albedo}");
    }
    // Every material, however its coefficients add up, reflects at most what it receives.
    let greedy = Material { kd: Color::ONE, ks: Color::ONE, kr: Color::ONE, kt: Color::ONE, shininess: 5.0, ..Material::default() };
    for m in [greedy.clone(), Material { blur: 0.5, ..greedy }, Material { kd: Color::new(2.0, 0.5, 0.0), ..Material::default() }] {
        for theta in [0.0, 0.8, 1.4] {
            let (bsdf, n) = bsdf_at(m.clone(), theta, false);
            assert!(bsdf.albedo().max_element() <= 1.0 + 1e-12, "{m:?}: weights {}", bsdf.albedo());
            let smooth = hemisphere_integral(n, |w| bsdf.eval(w).max_element() * w.dot(n));
            assert!(smooth <= 1.0 + 2e-3, "{m:?} at θ {theta}: smooth albedo {smooth}");
        }
    }
}

fn load(text: &str) -> RenderJob {
    let options = LoadOptions { limits: Limits::unlimited(), ..LoadOptions::default() };
    raylab::load::loader::load_str(&crate::registry(), "test.toml", text, Path::new("."), &options)
        .unwrap_or_else(|e| panic!("{}", e.report()))
}

/// `n` independent estimates of the radiance along `ray` (each with its own stream).
fn estimates(job: &RenderJob, ray: &Ray, n: u64) -> Vec<Color> {
    let mut stats = RayStats::new(job.integrator.counters());
    (0..n)
        .map(|i| {
            let mut aov = AovSample::miss(job.scene.background);
            job.integrator.radiance(&job.scene, ray, &mut Sampler::new(i, 0, 11), &mut stats, &mut aov)
        })
        .collect()
}

/// Mean and standard error of the mean, per channel.
fn mean_and_error(values: &[Color]) -> (Color, Color) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<Color>() / n;
    let var = values.iter().map(|v| (*v - mean) * (*v - mean)).sum::<Color>() / (n - 1.0);
    (mean, (var / n).powf(0.5))
}

/// A closed sphere around the camera whose inside emits `le` and reflects diffusely with albedo
/// `a` (sampled perfectly: every bounce weighs exactly `a`).
fn closed_furnace(a: f64, le: f64, integrator: &str) -> RenderJob {
    load(&format!(
        "background = 0\n[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nfov = 60\n\
         [integrator]\ntype = \"path\"\n{integrator}\n[[object]]\ntype = \"sphere\"\nradius = 1\nmaterial = {{ kd = {a}, ks = 0, emission = {le} }}\n"
    ))
}

#[test]
fn a_closed_furnace_without_roulette_sums_the_geometric_series_exactly() {
    let (a, le, bounces) = (0.5, 0.7, 40);
    let job = closed_furnace(a, le, &format!("max_bounces = {bounces}\nroulette_depth = {bounces}"));
    // Emission at the first surface and after each of the max_bounces + 1 scattered rays.
    let expected = le * (1.0 - a.powi(bounces + 2)) / (1.0 - a);
    for dir in [DVec3::NEG_Z, DVec3::new(0.3, -0.2, 0.9)] {
        for v in estimates(&job, &Ray::new(DVec3::ZERO, dir), 64) {
            assert!((v - Color::splat(expected)).abs().max_element() < 1e-14 * expected, "{v} vs {expected}");
        }
    }
}

/// Russian roulette counts only diffuse or glossy bounces: inside a closed half-silvered mirror
/// (kr = 0.5, no smooth lobe) with `roulette_depth = 1`, no path is ever gambled on, so every
/// estimate is the geometric series exactly (counting mirror bounces, from the second on each
/// would end the path with probability ½ or more, the survivors reweighted: scattered estimates).
#[test]
fn specular_bounces_do_not_count_toward_roulette() {
    let (le, bounces) = (0.7, 40);
    let job = load(&format!(
        "background = 0\n[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nfov = 60\n\
         [integrator]\ntype = \"path\"\nmax_bounces = {bounces}\nroulette_depth = 1\n\
         [[object]]\ntype = \"sphere\"\nradius = 1\nmaterial = {{ kd = 0, ks = 0, kr = 0.5, emission = {le} }}\n"
    ));
    let expected = le * (1.0 - 0.5f64.powi(bounces + 2)) / 0.5;
    for dir in [DVec3::NEG_Z, DVec3::new(0.3, -0.2, 0.9)] {
        for v in estimates(&job, &Ray::new(DVec3::ZERO, dir), 64) {
            assert!((v - Color::splat(expected)).abs().max_element() < 1e-14 * expected, "{v} vs {expected}");
        }
    }
}

#[test]
fn the_deepest_path_allowed_renders_on_the_render_threads() {
    // A mirror sphere around the camera: every path goes the whole 1024 bounces, one stack
    // frame of recursion each, on the render pool's worker threads (default stacks).
    let (le, bounces) = (0.5, 1024);
    let job = load(&format!(
        "background = 0\n[render]\nwidth = 2\nheight = 2\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n\
         [integrator]\ntype = \"path\"\nmax_bounces = {bounces}\nroulette_depth = {bounces}\n\
         [[object]]\ntype = \"sphere\"\nradius = 1\nmaterial = {{ kd = 0, ks = 0, kr = 1, emission = {le} }}\n"
    ));
    let options = raylab::render::RenderOptions { threads: Some(2), ..raylab::render::RenderOptions::default() };
    let r = raylab::render::render(&job, &options, &|_, _| {}).unwrap();
    // Emission at the first surface and after each of the max_bounces + 1 mirrored rays.
    let expected = le * f64::from(bounces + 2);
    for (x, y) in [(0, 0), (1, 1)] {
        assert_eq!(r.film.get(x, y).as_dvec3(), DVec3::splat(expected));
    }
}

#[test]
fn a_closed_furnace_with_roulette_converges_to_le_over_one_minus_albedo() {
    for (a, le) in [(0.5, 1.0), (0.8, 0.25), (0.95, 0.1)] {
        let job = closed_furnace(a, le, "max_bounces = 1024\nroulette_depth = 0");
        let values = estimates(&job, &Ray::new(DVec3::ZERO, DVec3::NEG_Z), 1 << 16);
        let (mean, error) = mean_and_error(&values);
        let expected = le / (1.0 - a);
        assert!((mean.x - expected).abs() < 4.0 * error.x + 1e-12, "a {a}: {} ± {} vs {expected}", mean.x, error.x);
        assert!(error.x < 0.02 * expected, "a {a}: standard error {} of {expected}", error.x);
    }
}

/// A sphere of `material` under a uniform sky and background of radiance 1.
fn white_furnace(material: &str, seed_bounces: &str) -> RenderJob {
    load(&format!(
        "background = 1\n[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nfov = 30\n\
         [integrator]\ntype = \"path\"\n{seed_bounces}\n[[light]]\ntype = \"ambient\"\ncolor = 1\nka = 1\n\
         [[object]]\ntype = \"sphere\"\nradius = 1\nmaterial = {material}\n"
    ))
}

#[test]
fn a_white_diffuse_sphere_under_a_uniform_sky_disappears() {
    let job = white_furnace("{ kd = 1, ks = 0 }", "");
    for (x, y) in [(0.0, 0.0), (0.5, 0.2), (0.7, -0.69)] {
        let ray = Ray::new(DVec3::new(0.0, 0.0, 4.0), DVec3::new(x, y, -4.0));
        for v in estimates(&job, &ray, 256) {
            assert!((v - Color::ONE).abs().max_element() < 1e-12, "{v}");
        }
    }
}

#[test]
fn no_material_reflects_more_than_the_sky_sends() {
    // Glass (Fresnel, refraction, total internal reflection) loses nothing: the sphere disappears
    // on average. The others may lose energy (a lobe cut by the horizon) but never gain it.
    let cases = [
        ("{ kd = 0, kt = 1, ior = 1.5 }", true),
        ("{ kd = 0, kt = 1, ior = 1.5, blur = 0.3 }", true),
        ("{ kd = 0, ks = 1, shininess = 10 }", false),
        ("{ kd = 0, kr = 1, blur = 0.4 }", false),
        ("{ kd = 1, ks = 1, kr = 1, kt = 1, shininess = 3 }", false),
    ];
    for (material, lossless) in cases {
        let job = white_furnace(material, "max_bounces = 1024");
        let mut values = Vec::new();
        for (x, y) in [(0.0, 0.0), (0.5, 0.2), (0.7, -0.69)] {
            values.extend(estimates(&job, &Ray::new(DVec3::new(0.0, 0.0, 4.0), DVec3::new(x, y, -4.0)), 1 << 14));
        }
        let (mean, error) = mean_and_error(&values);
        for c in 0..3 {
            assert!(mean[c] <= 1.0 + 4.0 * error[c], "{material}: {mean} ± {error} exceeds the sky");
            if lossless {
                assert!((mean[c] - 1.0).abs() <= 4.0 * error[c] + 1e-9, "{material}: {mean} ± {error}, expected 1");
            }
        }
    }
}

/// A diffuse floor seen from above, lit by `light`, with `integrator`.
fn lit_floor(light: &str, integrator: &str) -> RenderJob {
    load(&format!(
        "background = 0\n[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 3, 3]\nlook_at = [0, 0, 0]\nfov = 30\n\
         [integrator]\n{integrator}\n[[light]]\n{light}\n\
         [[object]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 1, 0]\nmaterial = {{ kd = [0.6, 0.5, 0.4], ks = 0 }}\n"
    ))
}

#[test]
fn direct_light_agrees_with_phong() {
    let lights = [
        "type = \"spot\"\nposition = [0.5, 2, 0]\ndirection = [0, -1, 0]\ncone_angle = 60\nexponent = 3\nkq = 1\nkc = 0",
        "type = \"directional\"\ndirection = [0.3, -1, 0.2]\ncolor = 0.7",
        "type = \"rect\"\ncenter = [0.3, 1.2, 0]\nedge1 = [1.5, 0, 0]\nedge2 = [0, 0.4, 1.2]\nkq = 1\nkc = 0.1",
        // Large and near: most of its light is found by the BSDF's rays.
        "type = \"rect\"\ncenter = [-0.6, 0.8, 0]\nedge1 = [0, 0, 3]\nedge2 = [0, 1.6, 0]\ncolor = 0.3",
        "type = \"point\"\nposition = [0.4, 0.9, 0.2]\nradius = 0.5\ncolor = 0.4",
        "type = \"spot\"\nposition = [0, 1, 0.3]\ndirection = [0, -1, 0.1]\nradius = 0.3\ncone_angle = 80\ncolor = 0.5",
    ];
    let ray = Ray::new(DVec3::new(0.0, 3.0, 3.0), DVec3::new(0.1, -3.0, -3.0));
    for light in lights {
        let phong = lit_floor(light, "type = \"phong\"\nshadow_rays = 4096\nprune_threshold = 0");
        let reference = estimates(&phong, &ray, 1)[0];
        for samples in [1, 3] {
            let path = lit_floor(light, &format!("type = \"path\"\nmax_bounces = 0\nlight_samples = {samples}"));
            let (mean, error) = mean_and_error(&estimates(&path, &ray, 1 << 16));
            for c in 0..3 {
                // Phong's 4096 stratified samples are accurate to well below 1e-3.
                assert!(
                    (mean[c] - reference[c]).abs() <= 4.0 * error[c] + 1e-3 * reference[c] + 1e-12,
                    "{light}, light_samples {samples}: path {mean} ± {error}, phong {reference}"
                );
            }
        }
    }
}

#[test]
fn the_explanation_is_the_render() {
    let job = load(&std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/quality.toml")).unwrap());
    let integrator = PathTracer::default();
    for i in 0..64u64 {
        let ray = Ray::new(job.scene.camera.position, DVec3::new((i % 8) as f64 * 0.05 - 0.2, 0.1 - (i / 8) as f64 * 0.04, -1.0));
        let mut stats = RayStats::new(COUNTERS);
        let mut aov = AovSample::miss(job.scene.background);
        let c = integrator.radiance(&job.scene, &ray, &mut Sampler::new(i, 0, 3), &mut stats, &mut aov);
        let tree = integrator.explain(&job.scene, &ray, &mut Sampler::new(i, 0, 3)).unwrap();
        assert_eq!(c.to_array().map(f64::to_bits), tree.color.to_array().map(f64::to_bits), "ray {i}");
    }
}

/// An area light that rays cannot meet (it does not answer `intersect`): its samples must then
/// count in full, or its light would be lost.
struct Unmet(crate::lights::rect::RectLight);

impl raylab::LightSource for Unmet {
    fn illuminate(&self, p: DVec3, u: DVec2) -> Option<raylab::LightSample> {
        self.0.illuminate(p, u)
    }
    fn is_area(&self) -> bool {
        true
    }
}

#[test]
fn a_light_that_rays_cannot_meet_is_sampled_in_full() {
    use crate::lights::rect::RectLight;
    let rect = || {
        RectLight::new(
            Color::splat(0.8),
            DVec3::new(-0.6, 0.8, 0.0),
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::new(0.0, 1.6, 0.0),
            (1.0, 0.0, 0.0),
            1,
        )
    };
    let cam = Camera::look_at(DVec3::new(0.0, 3.0, 3.0), DVec3::ZERO, DVec3::Y, 30.0, 4, 4).unwrap();
    let floor = || {
        Object::with_material(
            "floor",
            Box::new(crate::shapes::plane::Plane::new(DVec3::ZERO, DVec3::Y)),
            Material::diffuse(Color::splat(0.5)),
        )
    };
    let ray = Ray::new(DVec3::new(0.0, 3.0, 3.0), DVec3::new(0.1, -3.0, -3.0));
    let path = PathTracer { max_bounces: 0, ..PathTracer::default() };
    let mean = |light: Box<dyn raylab::LightSource>| {
        let scene = Scene::new("t", cam.clone(), Color::ZERO, vec![floor()], vec![("light".into(), light)]);
        let mut stats = RayStats::new(COUNTERS);
        let values: Vec<Color> = (0..1u64 << 15)
            .map(|i| path.radiance(&scene, &ray, &mut Sampler::new(i, 0, 5), &mut stats, &mut AovSample::miss(Color::ZERO)))
            .collect();
        mean_and_error(&values)
    };
    let (met, met_error) = mean(Box::new(rect()));
    let (unmet, unmet_error) = mean(Box::new(Unmet(rect())));
    assert!(
        (met - unmet).abs().max_element() <= 4.0 * (met_error + unmet_error).max_element(),
        "{met} ± {met_error} vs {unmet} ± {unmet_error}"
    );
}

/// A white diffuse sphere inside a uniform environment light of radiance 0.5 disappears: every
/// pixel's expected value is the environment's (the rays that miss see it exactly), the
/// environment found by the BSDF's rays alone (a constant one is not sampled as a light).
#[test]
fn a_white_diffuse_sphere_inside_a_uniform_environment_disappears() {
    for samples in [1, 3] {
        let job = load(&format!(
            "background = 0.9\n[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nfov = 30\n\
             [integrator]\ntype = \"path\"\nmax_bounces = 1024\nlight_samples = {samples}\n\
             [[light]]\ntype = \"environment\"\ncolor = [0.5, 0.25, 0.125]\nrotation = 20\n\
             [[object]]\ntype = \"sphere\"\nradius = 1\nmaterial = {{ kd = 1, ks = 0 }}\n"
        ));
        let expected = Color::new(0.5, 0.25, 0.125);
        let miss = estimates(&job, &Ray::new(DVec3::new(0.0, 0.0, 4.0), DVec3::new(1.0, 0.3, -1.0)), 4);
        assert!(miss.iter().all(|&v| v == expected), "a ray that misses sees the environment, not the background: {miss:?}");
        let mut values = Vec::new();
        for (x, y) in [(0.0, 0.0), (0.5, 0.2), (0.7, -0.69)] {
            values.extend(estimates(&job, &Ray::new(DVec3::new(0.0, 0.0, 4.0), DVec3::new(x, y, -4.0)), 1 << 14));
        }
        let (mean, error) = mean_and_error(&values);
        for c in 0..3 {
            // (Rounding aside: every bounce off white weighs one, so the estimates hardly vary.)
            let rounding = 1e-12 * expected[c];
            assert!(
                (mean[c] - expected[c]).abs() <= 4.0 * error[c] + rounding,
                "light_samples {samples}: {mean} ± {error}, expected {expected}"
            );
            assert!(error[c] < 0.01 * expected[c], "light_samples {samples}: standard error {error}");
        }
    }
}

#[test]
fn direct_light_from_an_environment_agrees_with_phong() {
    let light = "type = \"environment\"\ncolor = [0.6, 0.8, 1.0]\nrotation = 30";
    let ray = Ray::new(DVec3::new(0.0, 3.0, 3.0), DVec3::new(0.1, -3.0, -3.0));
    let phong = lit_floor(light, "type = \"phong\"\nshadow_rays = 4096\nprune_threshold = 0");
    let reference = estimates(&phong, &ray, 1)[0];
    // A floor under a sky of radiance L shows kd × L.
    let exact = Color::new(0.6, 0.5, 0.4) * Color::new(0.6, 0.8, 1.0);
    assert!((reference - exact).abs().max_element() < 2e-3, "phong {reference} vs {exact}");
    for samples in [1, 3] {
        let path = lit_floor(light, &format!("type = \"path\"\nmax_bounces = 0\nlight_samples = {samples}"));
        let (mean, error) = mean_and_error(&estimates(&path, &ray, 1 << 15));
        for c in 0..3 {
            assert!((mean[c] - exact[c]).abs() <= 4.0 * error[c] + 1e-12, "light_samples {samples}: path {mean} ± {error}, exact {exact}");
        }
    }
}

/// A constant environment is left to the BSDF's rays ([`raylab::LightSource::uniform`]): `path`
/// spends no shadow ray on it, and a diffuse floor under it shows kd × L in every sample (each
/// bounce weighs exactly kd and its ray, leaving the scene, meets the sky in full): no variance
/// where sampling the sphere uniformly and weighing by MIS had some. Both halves fail if the
/// light is sampled again or its rays weighed against samples no longer taken.
#[test]
fn a_constant_environment_is_left_to_the_bsdfs_rays() {
    let path = lit_floor("type = \"environment\"\ncolor = [0.6, 0.8, 1.0]", "type = \"path\"\nmax_bounces = 0");
    let exact = Color::new(0.6, 0.5, 0.4) * Color::new(0.6, 0.8, 1.0);
    let ray = Ray::new(DVec3::new(0.0, 3.0, 3.0), DVec3::new(0.1, -3.0, -3.0));
    let mut stats = RayStats::new(path.integrator.counters());
    for i in 0..256 {
        let mut aov = AovSample::miss(path.scene.background);
        let v = path.integrator.radiance(&path.scene, &ray, &mut Sampler::new(i, 0, 11), &mut stats, &mut aov);
        assert!((v - exact).abs().max_element() < 1e-12, "sample {i}: {v} vs {exact}");
    }
    assert_eq!(stats.get("shadow_rays"), 0);
    assert_eq!(stats.get("bounce_rays"), 256);
}

/// The denoiser's guides are taken at the first non-specular hit, for `path` and `phong`: a
/// mirror's pixel shows the wall it reflects (its albedo tinted by the mirror's 0.5 and its
/// normal), a glass ball's the wall seen through it; without `guides` set (no layers summed),
/// the first surface itself. The emission layer holds what the camera ray met emitted.
#[test]
fn guides_look_through_mirrors_and_glass() {
    let scene = |integrator: &str, sky: &str| {
        load(&format!(
            "background = 0.25\n[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nfov = 60\n\
             [integrator]\ntype = \"{integrator}\"\n\
             [[object]]\ntype = \"sphere\"\ncenter = [-2, 0, -5]\nradius = 1\nmaterial = {{ kd = 0, kr = 0.5 }}\n\
             [[object]]\ntype = \"sphere\"\ncenter = [2, 0, -5]\nradius = 1\nmaterial = {{ kd = 0, kt = 1, ior = 1.5 }}\n\
             [[object]]\ntype = \"plane\"\npoint = [0, 0, 1]\nnormal = [0, 0, -1]\nmaterial = {{ kd = [0.8, 0.1, 0.1] }}\n\
             [[object]]\ntype = \"plane\"\npoint = [0, 0, -10]\nnormal = [0, 0, 1]\nmaterial = {{ kd = [0.1, 0.7, 0.2] }}\n\
             [[object]]\ntype = \"sphere\"\ncenter = [0, 2, -5]\nradius = 0.5\nmaterial = {{ kd = 0, emission = 3 }}\n{sky}"
        ))
    };
    for (integrator, sky) in [("path", ""), ("phong", ""), ("path", "sky"), ("phong", "sky")] {
        let sky = if sky.is_empty() { "" } else { "[[light]]\ntype = \"environment\"\ncolor = 0.6\n" };
        let job = scene(integrator, sky);
        let guide = |target: DVec3, guides: bool| {
            let mut stats = RayStats::new(job.integrator.counters());
            let mut aov = AovSample::miss(job.scene.background);
            aov.guides = guides;
            job.integrator.radiance(&job.scene, &Ray::new(DVec3::ZERO, target), &mut Sampler::new(0, 0, 1), &mut stats, &mut aov);
            aov
        };
        let close = |a: DVec3, b: DVec3| (a - b).abs().max_element() < 1e-9;
        // The mirror ball, hit facing the camera: the red wall behind the camera, tinted by 0.5.
        let (mirror, old) = (guide(DVec3::new(-2.0, 0.0, -5.0), true), guide(DVec3::new(-2.0, 0.0, -5.0), false));
        assert!(close(mirror.albedo, DVec3::new(0.4, 0.05, 0.05)), "{integrator}: mirror guide {:?}", mirror.albedo);
        assert!(close(mirror.normal, DVec3::new(0.0, 0.0, -1.0)), "{integrator}: mirror normal {:?}", mirror.normal);
        assert!(close(old.albedo, DVec3::splat(0.5)), "{integrator}: the mirror itself {:?}", old.albedo);
        // Depth and signature stay the first surface's.
        assert_eq!((mirror.depth, mirror.signature), (old.depth, old.signature), "{integrator}");
        // The glass ball through its centre: the green wall behind it, its normal toward the ball.
        let glass = guide(DVec3::new(2.0, 0.0, -5.0), true);
        assert!(close(glass.albedo, DVec3::new(0.1, 0.7, 0.2)), "{integrator}: glass guide {:?}", glass.albedo);
        assert!(close(glass.normal, DVec3::Z), "{integrator}: glass normal {:?}", glass.normal);
        let old = guide(DVec3::new(2.0, 0.0, -5.0), false);
        assert!(close(old.albedo, DVec3::ONE), "{integrator}: the glass itself {:?}", old.albedo);
        // A diffuse wall is its own guide either way.
        let (wall, old) = (guide(DVec3::new(0.3, -0.3, -1.0), true), guide(DVec3::new(0.3, -0.3, -1.0), false));
        assert!(close(wall.albedo, DVec3::new(0.1, 0.7, 0.2)) && (wall.albedo, wall.normal) == (old.albedo, old.normal), "{integrator}");
        // The emission layer: what the camera ray met emitted, an emitter's, not a wall's.
        assert_eq!(wall.emitted, Color::ZERO, "{integrator}");
        assert!(close(guide(DVec3::new(0.0, 2.0, -5.0), true).emitted, DVec3::splat(3.0)), "{integrator}: emitter");
        // A ray that leaves the scene (straight up) shows the background, or the sky that
        // replaces it, as its albedo; the sky stays out of the emission layer.
        let up = guide(DVec3::Y, true);
        let seen = if sky.is_empty() { 0.25 } else { 0.6 };
        assert!(close(up.albedo, DVec3::splat(seen)) && up.emitted == Color::ZERO, "{integrator} {sky}: {up:?}");
    }
}

/// A render that takes the denoiser's guides counts the emitters camera rays see through a
/// mirror or smooth glass as their expectation ([`PathTracer::specular_emission`]): camera rays
/// across a glass ball and a mirror ball that reflect (and, seen through the glass, show) an
/// emitting sphere give the same mean with and without guides, the part seen through the balls
/// the same in every sample (the emission layer) and the colour's spread smaller. Counting it
/// twice, or not at all, moves the mean by far more than the noise allows.
#[test]
fn emitters_seen_in_mirrors_and_glass_count_as_their_expectation() {
    let job = load(
        "background = 0.1\n[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nfov = 60\n\
         [integrator]\ntype = \"path\"\n\
         [[object]]\ntype = \"sphere\"\ncenter = [-1.2, 0, -4]\nradius = 1\nmaterial = { kd = 0, kt = 1, ior = 1.5 }\n\
         [[object]]\ntype = \"sphere\"\ncenter = [1.2, 0, -4]\nradius = 1\nmaterial = { kd = 0, kr = 0.8 }\n\
         [[object]]\ntype = \"plane\"\npoint = [0, -1, 0]\nnormal = [0, 1, 0]\nmaterial = { kd = 0.5 }\n\
         [[object]]\ntype = \"sphere\"\ncenter = [0, 2.5, -3]\nradius = 1\nmaterial = { kd = 0, emission = 4 }\n\
         [[object]]\ntype = \"sphere\"\ncenter = [-1.2, 0, -9]\nradius = 1.5\nmaterial = { kd = 0, emission = 2 }\n",
    );
    let n: u32 = 4000;
    let (mut off_sum, mut on_sum, mut var_sum, mut seen_total) = (Color::ZERO, Color::ZERO, Color::ZERO, Color::ZERO);
    let (mut spread_off, mut spread_on) = (0.0, 0.0);
    for j in 0..6 {
        for i in 0..12 {
            let target = DVec3::new(-2.4 + 0.4 * f64::from(i) + 0.05, -0.9 + 0.4 * f64::from(j), -4.0);
            let ray = Ray::new(DVec3::ZERO, target);
            let mut stats = RayStats::new(job.integrator.counters());
            let mut run = |guides: bool| {
                let (mut sum, mut sq, mut emitted) = (Color::ZERO, Color::ZERO, None);
                for k in 0..n {
                    let mut aov = AovSample::miss(job.scene.background);
                    aov.guides = guides;
                    let v = job.integrator.radiance(&job.scene, &ray, &mut Sampler::new(u64::from(k), 0, 7), &mut stats, &mut aov);
                    sum += v;
                    sq += v * v;
                    // The emission layer is the same in every sample: no noise but anti-aliasing.
                    assert!(emitted.is_none_or(|e| e == aov.emitted), "{target}: emission layer {:?} then {:?}", emitted, aov.emitted);
                    emitted = Some(aov.emitted);
                }
                let mean = sum / f64::from(n);
                (mean, (sq / f64::from(n) - mean * mean).max(Color::ZERO), emitted.unwrap_or(Color::ZERO))
            };
            let (off, var_off, _) = run(false);
            let (on, var_on, seen) = run(true);
            off_sum += off;
            on_sum += on;
            var_sum += (var_off + var_on) / f64::from(n);
            seen_total += seen;
            // Where the balls show no emitter the colour is the same sample for sample.
            if seen != Color::ZERO {
                spread_off += var_off.element_sum();
                spread_on += var_on.element_sum();
            } else {
                assert_eq!(off, on, "{target}");
            }
        }
    }
    let sigma = var_sum.map(f64::sqrt);
    for c in 0..3 {
        assert!((on_sum[c] - off_sum[c]).abs() <= 4.0 * sigma[c], "with guides {on_sum}, without {off_sum}, σ {sigma}");
    }
    assert!(seen_total.min_element() > 0.05 * on_sum.min_element(), "the balls show the emitters: {seen_total} of {on_sum}");
    assert!(spread_on < 0.9 * spread_off, "where the balls show an emitter, variance with guides {spread_on}, without {spread_off}");
}

/// Glass counts the bright sky its branch not taken sees as its expectation
/// ([`PathTracer::other_escape`], `split_glass`): camera rays at a glass ball under the bundled
/// sky, aimed where the ball reflects the sun, give the same mean with and without the split,
/// and with it the sun's reflection (the Fresnel branch taken by ~4 % of the samples, each worth
/// 25 times its share) no longer varies. Counting that branch's escape twice (or never) moves the
/// mean by far more than the noise allows.
#[test]
fn glass_counts_the_sun_its_branch_not_taken_sees_as_its_expectation() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let options = LoadOptions { limits: Limits::unlimited(), ..LoadOptions::default() };
    let job = |split: bool| {
        let text = format!(
            "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nfov = 60\n\
             [integrator]\ntype = \"path\"\nsplit_glass = {split}\n\
             [[light]]\ntype = \"environment\"\nfile = \"assets/sky.hdr\"\n\
             [[object]]\ntype = \"sphere\"\ncenter = [0, 0, -4]\nradius = 1\nmaterial = {{ kd = 0, kt = 1, ior = 1.5 }}\n\
             [[object]]\ntype = \"plane\"\npoint = [0, -1, 0]\nnormal = [0, 1, 0]\nmaterial = {{ kd = 0.5 }}\n"
        );
        raylab::load::loader::load_str(&crate::registry(), "test.toml", &text, &scenes, &options)
            .unwrap_or_else(|e| panic!("{}", e.report()))
    };
    let (on, off) = (job(true), job(false));
    // The sun: the sky's brightest direction, on a fine grid.
    let sky = &on.scene.lights[0];
    let sun = (0..512 * 256)
        .map(|i| {
            let (phi, theta) = ((f64::from(i % 512) + 0.5) / 512.0 * TAU, (f64::from(i / 512) + 0.5) / 256.0 * std::f64::consts::PI);
            DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
        })
        .max_by(|a, b| sky.environment(*a).unwrap().element_sum().total_cmp(&sky.environment(*b).unwrap().element_sum()))
        .unwrap();
    // Where the ball mirrors it toward the camera: the normal halfway between the sun and the
    // way back to the camera, found by a few fixed-point steps.
    let centre = DVec3::new(0.0, 0.0, -4.0);
    let mut point = centre + (sun - centre.normalize()).normalize();
    for _ in 0..20 {
        point = centre + (sun - point.normalize()).normalize();
    }
    let n: u32 = 2000;
    let (mut sum_on, mut sum_off, mut var_on, mut var_off) = (Color::ZERO, Color::ZERO, 0.0, 0.0);
    let mut err = Color::ZERO;
    for (dx, dy) in [(0.0, 0.0), (0.004, 0.0), (-0.004, 0.0), (0.0, 0.004), (0.0, -0.004), (0.03, 0.03)] {
        let ray = Ray::new(DVec3::ZERO, point + DVec3::new(dx, dy, 0.0));
        let run = |job: &RenderJob| {
            let mut stats = RayStats::new(job.integrator.counters());
            let values: Vec<Color> = (0..n)
                .map(|k| {
                    let mut aov = AovSample::miss(job.scene.background);
                    job.integrator.radiance(&job.scene, &ray, &mut Sampler::new(u64::from(k), 0, 7), &mut stats, &mut aov)
                })
                .collect();
            mean_and_error(&values)
        };
        let ((m_on, e_on), (m_off, e_off)) = (run(&on), run(&off));
        sum_on += m_on;
        sum_off += m_off;
        err += e_on * e_on + e_off * e_off;
        var_on += (e_on * e_on).element_sum();
        var_off += (e_off * e_off).element_sum();
    }
    let sigma = err.map(f64::sqrt);
    for c in 0..3 {
        assert!((sum_on[c] - sum_off[c]).abs() <= 4.0 * sigma[c], "split {sum_on}, not split {sum_off}, σ {sigma}");
    }
    // The rays see the sun in the ball: each worth ten times the sky's ~1 and more.
    assert!(sum_off.min_element() > 6.0 * 10.0, "the rays miss the sun's reflection: {sum_off}");
    assert!(var_on < 0.1 * var_off, "variance of the mean split {var_on}, not split {var_off}");
}

/// The BSDF's numbers, forked in each branch of `stratify`'s choice, are the ones drawn from one
/// fork with `draw_1d` and `draw_2d` as before (pixel draws below `stratify`, plain ones from
/// it), bit for bit, for every set of numbers read; the roulette's likewise.
#[test]
fn bsdf_numbers_are_one_forks_draws_as_before() {
    let tracer = PathTracer::default();
    let bits = |(a, u, b): (f64, DVec2, f64)| [a, u.x, u.y, b].map(f64::to_bits);
    let mut compared = 0;
    for depth in 0..4 {
        for sample in 0..64 {
            let sampler = Sampler::new(17, sample, 9).fork(TAG_NEXT);
            for flags in 1..8u8 {
                let draws = Draws { pick: flags & 1 != 0, dir: flags & 2 != 0, fresnel: flags & 4 != 0 };
                let mut stream = sampler.fork(TAG_BSDF);
                let pick = if draws.pick { tracer.draw_1d(depth, &mut stream) } else { skip(&mut stream, 1, 0.5) };
                let u = if draws.dir { tracer.draw_2d(depth, &mut stream) } else { DVec2::splat(skip(&mut stream, 2, 0.5)) };
                let fresnel = if draws.fresnel { tracer.draw_1d(depth, &mut stream) } else { 0.5 };
                assert_eq!(bits(tracer.bsdf_numbers(depth, &sampler, draws)), bits((pick, u, fresnel)), "depth {depth}, {draws:?}");
                compared += 1;
            }
            let roulette = tracer.draw_1d(depth, &mut sampler.fork(TAG_ROULETTE));
            assert_eq!(tracer.roulette_number(depth, &sampler).to_bits(), roulette.to_bits(), "depth {depth}");
        }
    }
    assert_eq!(compared, 4 * 64 * 7);
    assert_eq!(tracer.stratify, 2, "both branches are compared");
}
