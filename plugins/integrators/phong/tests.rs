//! The Phong integrator against closed-form expectations.

use super::*;
use crate::lights::{ambient::Ambient, directional::Directional, point::PointLight, point::Spot};
use crate::shapes::{plane::Plane, sphere::Sphere};
use raylab::glam::DVec3;
use raylab::scene::object::Object;
use raylab::{Camera, Geometry, LightSource, Material};

const EPS: f64 = 1e-12;

/// A shape with its material.
type Thing = (Box<dyn Geometry>, Material);

fn scene(objects: Vec<Thing>, lights: Vec<Box<dyn LightSource>>, background: Color) -> Scene {
    let cam = Camera::look_at(DVec3::new(0.0, 5.0, 5.0), DVec3::ZERO, DVec3::Y, 45.0, 4, 4).unwrap();
    let objects = objects.into_iter().enumerate().map(|(i, (g, m))| Object::with_material(format!("object {i}"), g, m)).collect();
    let lights = lights.into_iter().enumerate().map(|(i, l)| (format!("light {i}"), l)).collect();
    Scene::new("test", cam, background, objects, lights)
}

fn floor(m: Material) -> Thing {
    (Box::new(Plane::new(DVec3::ZERO, DVec3::Y)), m)
}

fn shade(s: &Scene, integrator: &Phong, ray: &Ray) -> (Color, RayStats) {
    let mut stats = RayStats::new(COUNTERS);
    let c = integrator.radiance(s, ray, &mut Sampler::new(0, 0, 0), &mut stats, &mut AovSample::miss(s.background));
    (c, stats)
}

/// The camera ray of every light test: from (0, 5, 5) to the origin on the floor.
fn down_ray() -> Ray {
    Ray::new(DVec3::new(0.0, 5.0, 5.0), DVec3::new(0.0, -5.0, -5.0))
}

fn lambert_phong() -> Material {
    Material {
        ka: DVec3::new(0.5, 0.4, 0.3),
        kd: DVec3::new(0.5, 0.25, 0.125),
        ks: DVec3::splat(0.3),
        shininess: 10.0,
        emission: DVec3::new(0.01, 0.02, 0.03),
        ..Material::default()
    }
}

/// `emission + ka·ambient + (kd·(n·l) + ks·(−v·r)^n)·I` written out for the floor at the origin,
/// seen along `down_ray`, with `l` the unit direction to the light.
fn expected(m: &Material, ambient: Color, l: DVec3, intensity: Color) -> Color {
    let n = DVec3::Y;
    let v = DVec3::new(0.0, -1.0, -1.0) / 2f64.sqrt();
    let nl = n.dot(l);
    let r = -l + 2.0 * nl * n;
    let spec = (-v.dot(r)).max(0.0).powf(m.shininess);
    m.emission + m.ka * ambient + (m.kd * nl + m.ks * spec) * intensity
}

fn assert_close(a: Color, b: Color) {
    assert!((a - b).abs().max_element() < EPS, "{a} vs {b}");
}

#[test]
fn ambient_and_emission_alone() {
    let m = lambert_phong();
    let s = scene(vec![floor(m.clone())], vec![Box::new(Ambient::new(DVec3::new(1.0, 0.5, 0.25), 0.1))], Color::ZERO);
    let (c, _) = shade(&s, &Phong::default(), &down_ray());
    assert_close(c, m.emission + m.ka * DVec3::new(0.1, 0.05, 0.025));
}

#[test]
fn directional_light_terms() {
    let m = lambert_phong();
    let travel = DVec3::new(1.0, -2.0, 0.0).normalize();
    let i = DVec3::new(0.9, 0.8, 0.7);
    let s =
        scene(vec![floor(m.clone())], vec![Box::new(Directional::new(i, travel)), Box::new(Ambient::new(DVec3::ONE, 0.1))], Color::ZERO);
    let (c, stats) = shade(&s, &Phong::default(), &down_ray());
    // l = (−1, 2, 0)/√5: n·l = 2/√5; r = (1, 2, 0)/√5; −v·r = 2/√10.
    let spec = (2.0 / 10f64.sqrt()).powi(10);
    let by_hand = m.emission + m.ka * 0.1 + (m.kd * (2.0 / 5f64.sqrt()) + m.ks * spec) * i;
    assert_close(c, by_hand);
    assert_close(c, expected(&m, DVec3::splat(0.1), -travel, i));
    assert_eq!(stats.get("shadow_rays"), 1);
}

#[test]
fn point_light_attenuates_with_distance() {
    let m = lambert_phong();
    let pos = DVec3::new(1.0, 3.0, 0.0);
    let (kc, kl, kq) = (1.0, 0.1, 0.01);
    let i0 = DVec3::new(2.0, 1.5, 1.0);
    let s = scene(vec![floor(m.clone())], vec![Box::new(PointLight::new(i0, pos, kc, kl, kq))], Color::ZERO);
    let (c, _) = shade(&s, &Phong::default(), &down_ray());
    let d = 10f64.sqrt();
    let by_hand = expected(&m, Color::ZERO, pos / d, i0 / (kc + kl * d + kq * d * d));
    assert_close(c, by_hand);
}

#[test]
fn spot_light_narrows_by_its_exponent() {
    let m = lambert_phong();
    let pos = DVec3::new(2.0, 4.0, 0.0);
    let axis = DVec3::new(-1.0, -1.0, 0.0).normalize();
    let i0 = DVec3::splat(3.0);
    let spot = Spot { direction: axis, exponent: 2.0, cos_cutoff: 0.0 };
    let s = scene(vec![floor(m.clone())], vec![Box::new(PointLight::spot(i0, pos, 1.0, 0.0, 0.05, spot))], Color::ZERO);
    let (c, _) = shade(&s, &Phong::default(), &down_ray());
    let d = 20f64.sqrt();
    let l_from_light = -pos / d;
    // D·L = (1/√2)(2/√20 + 4/√20) = 6/√40
    let dl: f64 = 6.0 / 40f64.sqrt();
    assert!((axis.dot(l_from_light) - dl).abs() < EPS);
    let by_hand = expected(&m, Color::ZERO, pos / d, i0 * dl.powi(2) / (1.0 + 0.05 * d * d));
    assert_close(c, by_hand);
    // Outside the cone (the spot points away): no light and no shadow ray.
    let away = Spot { direction: -axis, exponent: 2.0, cos_cutoff: 0.0 };
    let s = scene(vec![floor(m.clone())], vec![Box::new(PointLight::spot(i0, pos, 1.0, 0.0, 0.05, away))], Color::ZERO);
    let (c, stats) = shade(&s, &Phong::default(), &down_ray());
    assert_close(c, m.emission);
    assert_eq!(stats.get("shadow_rays"), 0);
}

#[test]
fn no_light_through_an_opaque_wall() {
    // Light under the floor, viewer above: n·l and n·v disagree, so no contribution.
    let m = lambert_phong();
    let s =
        scene(vec![floor(m.clone())], vec![Box::new(PointLight::new(DVec3::ONE, DVec3::new(0.0, -3.0, 0.0), 1.0, 0.0, 0.0))], Color::ZERO);
    let (c, stats) = shade(&s, &Phong::default(), &down_ray());
    assert_close(c, m.emission);
    assert_eq!((stats.get("lights_behind"), stats.get("shadow_rays")), (1, 0));
}

#[test]
fn shadows_block_and_transparent_occluders_attenuate() {
    let m = lambert_phong();
    let light = || -> Box<dyn LightSource> { Box::new(PointLight::new(DVec3::ONE, DVec3::new(0.0, 6.0, 0.0), 1.0, 0.0, 0.0)) };
    let blocker = |kt: f64| -> Thing {
        (Box::new(Sphere::new(DVec3::new(0.0, 3.0, 0.0), 1.0)), Material { kt: DVec3::splat(kt), ..Material::default() })
    };
    let lit = expected(&m, Color::ZERO, DVec3::Y, DVec3::ONE);
    let open = scene(vec![floor(m.clone())], vec![light()], Color::ZERO);
    assert_close(shade(&open, &Phong::default(), &down_ray()).0, lit);
    let opaque = scene(vec![floor(m.clone()), blocker(0.0)], vec![light()], Color::ZERO);
    assert_close(shade(&opaque, &Phong::default(), &down_ray()).0, m.emission);
    // A shadow ray crosses the glass sphere twice: kt².
    let glass = scene(vec![floor(m.clone()), blocker(0.5)], vec![light()], Color::ZERO);
    let (c, _) = shade(&glass, &Phong::default(), &down_ray());
    assert_close(c, m.emission + (lit - m.emission) * 0.25);
}

#[test]
fn mirror_reflects_the_background() {
    let mirror = Material { ka: DVec3::ZERO, kd: DVec3::ZERO, kr: DVec3::new(0.9, 0.8, 0.7), ..Material::default() };
    let bg = DVec3::new(0.2, 0.4, 0.6);
    let s = scene(vec![floor(mirror)], vec![], bg);
    let (c, stats) = shade(&s, &Phong::default(), &down_ray());
    assert_close(c, DVec3::new(0.9, 0.8, 0.7) * bg);
    assert_eq!(stats.get("reflection_rays"), 1);
    let tree = Phong::default().explain(&s, &down_ray(), &mut Sampler::new(0, 0, 0)).unwrap();
    let child = &tree.children[0];
    assert!((child.ray.dir - DVec3::new(0.0, 1.0, -1.0).normalize()).length() < EPS);
}

#[test]
fn refraction_follows_snell_and_total_internal_reflection() {
    let glass = Material { ka: DVec3::ZERO, kd: DVec3::ZERO, kt: DVec3::ONE, ior: 1.5, ..Material::default() };
    let s = scene(vec![(Box::new(Sphere::new(DVec3::ZERO, 1.0)), glass)], vec![], DVec3::new(0.3, 0.3, 0.3));
    // Enter at 30° from the normal at the top of the sphere.
    let hit = DVec3::new(0.0, 1.0, 0.0);
    let incoming = DVec3::new(30f64.to_radians().sin(), -30f64.to_radians().cos(), 0.0);
    let ray = Ray::new(hit - 3.0 * incoming, incoming);
    let tree = Phong::default().explain(&s, &ray, &mut Sampler::new(0, 0, 0)).unwrap();
    let inside = &tree.children[0];
    let sin_t = inside.ray.dir.cross(-DVec3::Y).length();
    assert!((sin_t - 0.5 / 1.5).abs() < 1e-9, "Snell: sin θt = sin θi / n, got {sin_t}");
    assert!(tree.hit.as_ref().unwrap().front_face && !inside.hit.as_ref().unwrap().front_face);
    // Inside, beyond the critical angle (sin θ > 1/1.5): total internal reflection.
    let inside_ray = Ray::new(DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0));
    let grazing = Ray::new(DVec3::new(0.9, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0));
    let t = Phong::default().explain(&s, &grazing, &mut Sampler::new(0, 0, 0)).unwrap();
    assert!(t.notes.iter().any(|n| n.contains("total internal reflection")), "{}", t.to_text());
    let t = Phong::default().explain(&s, &inside_ray, &mut Sampler::new(0, 0, 0)).unwrap();
    assert!(t.notes.iter().all(|n| !n.contains("total internal")));
}

#[test]
fn pruning_and_depth_limit_skip_rays() {
    let mirror = Material { kd: DVec3::ZERO, kr: DVec3::splat(0.5), ..Material::default() };
    // Two parallel mirrors: the ray bounces until depth or pruning stops it.
    let planes: Vec<Thing> = vec![floor(mirror.clone()), (Box::new(Plane::new(DVec3::new(0.0, 10.0, 0.0), -DVec3::Y)), mirror)];
    let s = scene(planes, vec![], DVec3::ONE);
    let ray = Ray::new(DVec3::new(0.0, 5.0, 0.0), DVec3::new(0.0, -1.0, 0.01));
    let deep = Phong { max_depth: 100, prune_threshold: 0.01, glossy_rays: 1, ..Phong::default() };
    let (c, st) = shade(&s, &deep, &ray);
    // 0.5^7 = 0.0078 < 0.01: the 7th reflection is pruned.
    assert_eq!((st.get("reflection_rays"), st.get("pruned_rays"), st.get("depth_limited")), (6, 1, 0));
    // Between two infinite mirrors no ray ever escapes to the background.
    assert_eq!(c, Color::ZERO);
    let shallow = Phong { max_depth: 2, prune_threshold: 0.0, glossy_rays: 1, ..Phong::default() };
    let (_, st) = shade(&s, &shallow, &ray);
    assert_eq!((st.get("reflection_rays"), st.get("pruned_rays"), st.get("depth_limited")), (2, 0, 1));
}

/// `ambient = "first_hit"` adds the ambient term where the camera ray first hits only: a mirror
/// in front of an ambient-lit wall shows ambient once, not twice.
#[test]
fn ambient_at_the_first_hit_only_is_not_added_again_in_reflections() {
    use raylab::LoadOptions;
    let scene = r#"
        [render]
        width = 3
        height = 3
        encoding = "linear"
        [camera]
        position = [0, 0, 0]
        look_at = [0, 0, -1]
        fov = 1
        [[object]]
        type = "quadrangle"
        name = "mirror"
        p0 = [-10, -10, -5]
        p1 = [10, -10, -5]
        p2 = [10, 10, -5]
        p3 = [-10, 10, -5]
        material = { kd = 0, kr = 1 }
        [[object]]
        type = "quadrangle"
        name = "wall behind the camera"
        p0 = [-10, -10, 5]
        p1 = [10, -10, 5]
        p2 = [10, 10, 5]
        p3 = [-10, 10, 5]
        material = { kd = 0 }
        [[light]]
        type = "ambient"
        color = 1
        ka = 0.25
    "#;
    let centre = |ambient: &str| {
        let text = format!("{scene}\n[integrator]\ntype = \"phong\"\nambient = \"{ambient}\"\n");
        let job = raylab::load::loader::load_str(&crate::registry(), "t.toml", &text, std::path::Path::new("."), &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{}", e.report()));
        let mut stats = raylab::RayStats::new(job.integrator.counters());
        raylab::render::render_pixel(&job, 1, 1, &mut stats).x
    };
    assert_eq!(centre("every_hit"), 0.5, "the mirror's ambient and the wall's, reflected");
    assert_eq!(centre("first_hit"), 0.25, "the mirror's only");
}

/// The dielectric reflectance of glass: 4 % head on, growing toward grazing angles, total
/// beyond the critical angle inside; 0 when off (the report's fixed coefficients).
#[test]
fn fresnel_reflectance_is_4_percent_head_on_and_grows_to_total_reflection() {
    use raylab::scene::material::Fresnel;
    for kind in [Fresnel::Schlick, Fresnel::Exact] {
        let normal = kind.reflectance(1.0, 1.5);
        assert!((normal - 0.04).abs() < 1e-12, "{kind:?}: R0 of glass is 4 %, found {normal}");
        let grazing = kind.reflectance(0.05, 1.5);
        assert!(grazing > 0.5 && grazing <= 1.0, "{kind:?}: {grazing}");
        let mut last = 0.0;
        for i in (0..=100).rev() {
            let f = kind.reflectance(f64::from(i) / 100.0, 1.5);
            assert!(f >= last - 1e-12, "{kind:?}: reflectance grows toward grazing");
            last = f;
        }
        // From inside glass beyond the critical angle (sin θ > 1/1.5): total internal reflection.
        assert_eq!(kind.reflectance(0.5, 1.0 / 1.5), 1.0, "{kind:?}");
        assert!(kind.reflectance(0.9, 1.0 / 1.5) < 0.2, "{kind:?}: below the critical angle");
    }
    assert_eq!(Fresnel::Off.reflectance(0.1, 1.5), 0.0);
    // The exact curve against published values for n = 1.5 at 60°: Rs = 0.1766, Rp = 0.0018.
    let f = Fresnel::Exact.reflectance(60f64.to_radians().cos(), 1.5);
    assert!((f - 0.5 * (0.17656 + 0.00177)).abs() < 1e-4, "{f}");
}

/// A clear glass ball with Fresnel (kr = kt = 1) seen head on passes on about what lies behind
/// it (4 % reflected at each face); without Fresnel the same coefficients add light.
#[test]
fn fresnel_glass_passes_on_the_light_behind_it_without_adding_any() {
    use raylab::LoadOptions;
    let scene = |fresnel: &str| {
        format!(
            r#"
            background = [0, 0, 1]
            [render]
            width = 101
            height = 1
            [camera]
            position = [0, 0, 10]
            look_at = [0, 0, 0]
            fov = 11.4
            [integrator]
            type = "phong"
            max_depth = 6
            prune_threshold = 0
            [[object]]
            type = "sphere"
            radius = 1
            material = {{ ka = 0, kd = 0, kr = 1, kt = 1, ior = 1.5, fresnel = {fresnel} }}
            [[object]]
            type = "sphere"
            name = "red sky"
            radius = 100
            material = {{ ka = 0, kd = 0, emission = [1, 0, 0], kt = 0 }}
            "#
        )
    };
    let run = |fresnel: &str| {
        let job = raylab::load::loader::load_str(
            &crate::registry(),
            "t.toml",
            &scene(fresnel),
            std::path::Path::new("."),
            &LoadOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{}", e.report()));
        let mut stats = raylab::RayStats::new(job.integrator.counters());
        raylab::render::render_pixel(&job, 50, 0, &mut stats)
    };
    for kind in ["\"exact\"", "\"schlick\"", "true"] {
        let centre = run(kind);
        assert!(centre.x > 0.9 && centre.x <= 1.0 && centre.y == 0.0, "{kind}: the red sky, a little lost: {centre}");
    }
    let no_fresnel = run("false");
    assert!(no_fresnel.x > 1.5, "without Fresnel, kr + kt = 2 doubles the light: {no_fresnel}");
}

/// A light that counts its samples, with or without its bound.
struct Counted {
    light: PointLight,
    bounded: bool,
    samples: std::sync::Arc<std::sync::atomic::AtomicU32>,
}

impl LightSource for Counted {
    fn illuminate(&self, p: DVec3, u: raylab::glam::DVec2) -> Option<raylab::LightSample> {
        self.samples.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.light.illuminate(p, u)
    }
    fn sample_count(&self) -> u32 {
        self.light.sample_count()
    }
    fn is_area(&self) -> bool {
        self.light.is_area()
    }
    fn bound(&self, p: DVec3) -> Option<raylab::scene::light::LightBound> {
        if self.bounded { self.light.bound(p) } else { None }
    }
}

/// Skipping a light by its bound (wholly behind the surface, or too faint for the pruning
/// threshold) draws no sample and gives the same colour, bit for bit, as drawing them, with the
/// same shadow rays; a lit light is not skipped.
#[test]
fn a_light_skipped_by_its_bound_changes_nothing() {
    let ball = |at: DVec3, color: f64| PointLight::new(Color::splat(color), at, 1.0, 0.0, 0.0).with_radius(0.5, 16);
    let cases = [
        (ball(DVec3::new(1.0, -3.0, 0.0), 1.0), "lights_behind"),
        (ball(DVec3::new(1.0, 3.0, 0.0), 1e-6), "lights_negligible"),
        (ball(DVec3::new(1.0, 3.0, 0.0), 1.0), ""),
    ];
    for probes in [0, 4] {
        let phong = Phong { shadow_probes: probes, ..Phong::default() };
        for (light, skip) in &cases {
            let run = |bounded: bool| {
                let samples = std::sync::Arc::new(std::sync::atomic::AtomicU32::new(0));
                let counted = Counted { light: light.clone(), bounded, samples: samples.clone() };
                let s = scene(vec![floor(lambert_phong())], vec![Box::new(counted)], Color::ZERO);
                let (c, stats) = shade(&s, &phong, &down_ray());
                (c, stats, samples.load(std::sync::atomic::Ordering::Relaxed))
            };
            let ((a, sa, na), (b, sb, nb)) = (run(true), run(false));
            assert!(nb > 0);
            assert_eq!(na == 0, !skip.is_empty(), "{skip}: {na} samples drawn");
            assert_eq!(a.to_array().map(f64::to_bits), b.to_array().map(f64::to_bits), "{skip} probes {probes}");
            assert_eq!(sa.get("shadow_rays"), sb.get("shadow_rays"));
            if skip.is_empty() {
                assert!(sa.get("shadow_rays") > 0);
            } else {
                assert_eq!(sa.get("shadow_rays"), 0);
                assert!(sa.get(skip) > 0, "{skip}");
            }
        }
    }
}

/// The work budget's bound follows the scene's reflectance (`kr + kt` of its materials) and holds
/// the rays a glossy path tree really traces: two facing glossy mirrors, every fan to depth 4.
#[test]
fn the_ray_budget_follows_the_scenes_reflectance_and_bounds_the_rays_traced() {
    let glossy = |kr: f64| Material { kd: DVec3::ZERO, kr: DVec3::splat(kr), blur: 0.2, ..Material::default() };
    let phong = Phong { max_depth: 4, prune_threshold: 0.0, glossy_rays: 8, ..Phong::default() };
    let ray = Ray::new(DVec3::new(0.0, 5.0, 0.0), DVec3::new(0.0, -1.0, 0.01));
    let mut bounds = Vec::new();
    for kr in [2.0, 1.0, 0.5, 0.1, 0.0] {
        let m = glossy(kr);
        let walls: Vec<Thing> = vec![floor(m.clone()), (Box::new(Plane::new(DVec3::new(0.0, 10.0, 0.0), -DVec3::Y)), m)];
        let s = scene(walls, vec![Box::new(Directional::new(DVec3::ONE, DVec3::new(0.1, -1.0, 0.0)))], Color::ZERO);
        let bound = phong.worst_case_rays(&s);
        let (_, st) = shade(&s, &phong, &ray);
        let traced = 1 + st.get("reflection_rays") + st.get("refraction_rays") + st.get("shadow_rays");
        assert!(traced as f64 <= bound, "kr {kr}: traced {traced} rays, bound {bound}");
        bounds.push(bound);
    }
    assert!(bounds.windows(2).all(|w| w[1] < w[0]), "the bound should fall with kr: {bounds:?}");
}

/// With `emitter_samples`, an emitting ball lights the floor below it as an area light: a white
/// floor under a ball of radiance `L` and radius `r` at height `h` shows `L·(r/h)²` (the
/// Lambertian response to its irradiance π·L·(r/h)²); off by default, the floor stays dark; a
/// trace names the emitter's samples.
#[test]
fn emitter_samples_light_the_scene_with_emitting_objects() {
    let (l, r, h) = (2.0, 0.5, 3.0);
    let white = Material { kd: DVec3::ONE, ks: DVec3::ZERO, ..Material::default() };
    let glow = Material { kd: DVec3::ZERO, ks: DVec3::ZERO, emission: DVec3::splat(l), ..Material::default() };
    let s = scene(vec![floor(white.clone()), (Box::new(Sphere::new(DVec3::new(0.0, h, 0.0), r)), glow.clone())], vec![], Color::ZERO);
    let (off, _) = shade(&s, &Phong::default(), &down_ray());
    assert_eq!(off, Color::ZERO, "off by default: the emitter is only seen");
    // (No pruning: each of 256 samples carries less than the default threshold.)
    let phong = Phong { emitter_samples: 256, max_depth: 0, prune_threshold: 0.0, ..Phong::default() };
    let (on, stats) = shade(&s, &phong, &down_ray());
    let expected = l * (r / h) * (r / h);
    assert!((on - Color::splat(expected)).abs().max_element() < 5e-3 * expected, "{on} vs {expected}");
    assert_eq!(stats.get("shadow_rays"), 256);
    // A ball between the floor and the emitter shadows it.
    let ball = |y: f64, radius: f64, m: Material| -> Thing { (Box::new(Sphere::new(DVec3::new(0.0, y, 0.0), radius)), m) };
    let shadowed = scene(vec![floor(white), ball(h, r, glow), ball(1.0, 0.7, Material::default())], vec![], Color::ZERO);
    assert_eq!(shade(&shadowed, &phong, &down_ray()).0, Color::ZERO);
    let tree = phong.explain(&s, &down_ray(), &mut Sampler::new(0, 0, 0)).unwrap();
    assert!(tree.lights.iter().all(|t| t.light == "emitter object 1") && tree.lights.len() == 256, "{:?}", tree.lights.first());
}

#[test]
fn the_deepest_recursion_allowed_renders_on_the_render_threads() {
    // A mirror sphere around the camera: every ray is reflected the whole 1024 levels, one stack
    // frame of recursion each, on the render pool's worker threads (with and without a thread count).
    let depth = 1024;
    let text = format!(
        "background = 0\n[render]\nwidth = 2\nheight = 2\n[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n\
         [integrator]\ntype = \"phong\"\nmax_depth = {depth}\nprune_threshold = 0\n\
         [[object]]\ntype = \"sphere\"\nradius = 1\nmaterial = {{ kd = 0, ks = 0, kr = 1, emission = 0.5 }}\n"
    );
    let options = raylab::load::context::LoadOptions { limits: raylab::param::limits::Limits::unlimited(), ..Default::default() };
    let job = raylab::load::loader::load_str(&crate::registry(), "test.toml", &text, std::path::Path::new("."), &options)
        .unwrap_or_else(|e| panic!("{}", e.report()));
    for threads in [Some(2), None] {
        let options = raylab::render::RenderOptions { threads, ..raylab::render::RenderOptions::default() };
        let r = raylab::render::render(&job, &options, &|_, _| {}).unwrap();
        let c = r.film.get(0, 0).as_dvec3();
        assert!(c.is_finite() && c.x > 0.5 * f64::from(depth), "{c:?}");
    }
}
