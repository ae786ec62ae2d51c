//! A geometry defined right here, outside raylab, through the public API only: registered by type
//! name beside the built-in plugins, used from a scene file, rendered, and checked like any
//! built-in (parameter table, typo errors with locations, the reusable property checks).

use raylab::glam::{DVec2, DVec3};
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::math::float::gamma;
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::render::{RenderOptions, render};
use raylab::{Aabb, Geometry, Hit, Intersectable, LoadContext, PluginInfo, Ray, Registry};
use std::path::Path;

/// A flat round disc: the tiny third-party geometry.
struct Disc {
    center: DVec3,
    normal: DVec3,
    radius: f64,
}

const DISC: PluginInfo = PluginInfo {
    name: "disc",
    summary: "A flat disc of `radius` around `center`, facing `normal`.",
    params: &[
        ParamSpec::new("center", ParamKind::Vec3, ParamDefault::Vec3([0.0, 0.0, 0.0]), "centre"),
        ParamSpec::new("normal", ParamKind::Vec3, ParamDefault::Vec3([0.0, 0.0, 1.0]), "the side it faces"),
        ParamSpec::new("radius", ParamKind::Float, ParamDefault::Float(1.0), "radius, > 0"),
    ],
};

fn build_disc(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    Ok(Box::new(Disc { center: p.vec3("center")?, normal: p.direction("normal")?, radius: p.positive("radius")? }))
}

impl Intersectable for Disc {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let denom = self.normal.dot(ray.dir);
        let num = self.normal.dot(self.center - ray.origin);
        // Starting on the plane (within rounding) is not a hit.
        if denom == 0.0 || num.abs() <= gamma(5) * self.normal.abs().dot(self.center.abs() + ray.origin.abs()) {
            return None;
        }
        let t = num / denom;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let p = ray.at(t);
        let point = p - self.normal * self.normal.dot(p - self.center);
        ((point - self.center).length_squared() < self.radius * self.radius).then(|| Hit {
            t,
            point,
            error: gamma(6) * (point.abs() + self.center.abs()),
            uv: DVec2::ZERO,
            prim: 0,
            object: 0,
        })
    }
}

impl Geometry for Disc {
    fn outward_normal(&self, _: &Hit) -> DVec3 {
        self.normal
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(self.center - DVec3::splat(self.radius), self.center + DVec3::splat(self.radius)))
    }
}

fn registry() -> Registry {
    let mut r = raylab_plugins::registry();
    r.add_geometry(DISC, build_disc);
    r
}

const SCENE: &str = r#"
background = [0, 0, 1]
[render]
width = 33
height = 33
encoding = "linear"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
fov = 40
[[object]]
type = "disc"
name = "the disc"
center = [0, 0, 0]
normal = [0, 0, 1]
radius = 1
material = { kd = 0, ka = 0, emission = [1, 0.5, 0] }
"#;

#[test]
fn a_geometry_defined_outside_raylab_renders_from_a_scene_file() {
    let job =
        load_str(&registry(), "disc.toml", SCENE, Path::new("."), &LoadOptions::default()).unwrap_or_else(|e| panic!("{}", e.report()));
    assert_eq!(job.scene.object_name(0), "the disc");
    let film = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap().film;
    assert_eq!(film.get(16, 16).to_array(), [1.0, 0.5, 0.0], "the disc's emission at the centre");
    assert_eq!(film.get(0, 0).to_array(), [0.0, 0.0, 1.0], "background in the corner");
    // The disc covers the right fraction of the image: radius 1 at distance 5, fov 40°.
    let half = 5.0 * 20f64.to_radians().tan();
    let expected = std::f64::consts::PI / (2.0 * half).powi(2) * 33.0 * 33.0;
    let covered = film.pixels.iter().filter(|p| p.x == 1.0).count() as f64;
    assert!((covered - expected).abs() < 0.05 * expected, "{covered} pixels, expected about {expected}");
}

#[test]
fn the_plugin_gets_the_same_checks_and_listing_as_built_ins() {
    let reg = registry();
    assert!(reg.geometries().any(|p| p.name == "disc" && p.params.len() == 3));
    let typo = SCENE.replace("radius = 1", "radus = 1");
    let e = load_str(&reg, "disc.toml", &typo, Path::new("."), &LoadOptions::default()).err().expect("a typo is an error");
    assert_eq!(e.where_().as_deref(), Some("disc.toml:16:1"), "{}", e.report());
    assert!(e.help.unwrap().contains("did you mean `radius`"));
    let bad = SCENE.replace("radius = 1", "radius = -1");
    let e = load_str(&reg, "disc.toml", &bad, Path::new("."), &LoadOptions::default()).err().expect("a bad value is an error");
    assert!(e.report().contains("expected a number > 0"), "{}", e.report());
}

/// The disc of the test below, from its definition: radius 2 around (1, 2, 3) in the plane z = 3.
struct ExactDisc;

impl raylab::geometry::testing::ExactSurface for ExactDisc {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let radial = (p.truncate() - DVec3::new(1.0, 2.0, 3.0).truncate()).length();
        (p.z - 3.0).hypot((radial - 2.0).max(0.0)).copysign(p.z - 3.0)
    }
    fn outward_normal(&self, _: DVec3) -> DVec3 {
        DVec3::Z
    }
}

#[test]
fn the_reusable_property_checks_apply() {
    let disc = Disc { center: DVec3::new(1.0, 2.0, 3.0), normal: DVec3::Z, radius: 2.0 };
    for i in 0..200 {
        let a = f64::from(i) * 0.1;
        let target = disc.center + 1.9 * f64::from(i % 7) / 6.0 * DVec3::new(a.cos(), a.sin(), 0.0);
        let dir = DVec3::new(0.3 * a.sin(), 0.2, -1.0).normalize();
        let ray = Ray::new(target - 10.0 * dir, dir);
        let tol = raylab::geometry::testing::Tolerance::for_scale(20.0);
        let h = raylab::geometry::testing::check_hit(&disc, &ray, 0.0, f64::INFINITY, &tol, &ExactDisc).unwrap();
        assert!(h.is_some(), "ray {i} should hit");
        let hits = raylab::geometry::testing::check_hits_ascending(&disc, &ray, &tol, &ExactDisc, 1).unwrap();
        assert_eq!(hits.len(), 1);
    }
}
