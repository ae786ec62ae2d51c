//! The reintersection campaign ([`raylab::geometry::samples::reintersect`], pbrt-v4's
//! `Reintersect` tests at more scales) over every shape sampler of the built-in registry:
//! secondary rays spawned from random hit points with [`Hit::spawn_ray`] and
//! [`Hit::spawn_shadow_ray`] (what the integrators use) never meet the surface they leave where
//! its geometry says they cannot.
//!
//! Shapes range over sizes 10⁻⁶ to 10⁶, near the origin and 10³ sizes away from it: 10⁶ spawned rays
//! and 10⁶ shadow rays per shape, 0 failures allowed (pbrt-v4 checks 10⁶ per shape).

use raylab::Ray;
use raylab::geometry::samples::{ShapeSample, ShapeSampler, reintersect};
use raylab::geometry::testing::ExactSurface;
use raylab::geometry::{Geometry, Hit};
use raylab::glam::DVec3;

/// The campaign's seed for the `index`th sampler (as when the shapes were an enum).
fn seed(index: usize) -> u64 {
    0x5eed ^ index as u64
}

/// Runs the campaign on every registered shape sampler and fails with the first failures of each.
fn run_all(points: u32, per_point: u32) {
    let mut report = String::new();
    let samplers = crate::registry().shape_samplers();
    assert!(!samplers.is_empty());
    for (i, sampler) in samplers.iter().enumerate() {
        let t = reintersect(sampler, seed(i), points, per_point);
        let name = sampler.name;
        if t.no_claim {
            eprintln!("{name}: neither flat nor convex, no claim about rays leaving it");
            continue;
        }
        eprintln!("{name}: {} hit points, {} spawned rays, {} shadow rays, {} failures", t.hits, t.spawned, t.shadow, t.failures.len());
        if !t.failures.is_empty() {
            report += &format!("{name}: {} failures, e.g.\n  {}\n", t.failures.len(), t.failures[..t.failures.len().min(5)].join("\n  "));
        }
    }
    assert!(report.is_empty(), "{report}");
}

/// ≥ 10⁶ spawned rays and ≥ 10⁶ shadow rays per shape: about 3 s for all nine shapes in the test
/// profile, so it runs in every test run (no release build needed).
#[test]
fn spawned_rays_never_meet_their_own_surface_million_rays_per_shape() {
    run_all(1000, 1000);
}

/// A sphere as textbooks write it: the nearest root above `t_min`, `ray.at(t)` as the point, no
/// error bound.
struct NaiveSphere(DVec3, f64);

impl raylab::Intersectable for NaiveSphere {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let f = ray.origin - self.0;
        let (b, c) = (f.dot(ray.dir), f.length_squared() - self.1 * self.1);
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let t = [-b - disc.sqrt(), -b + disc.sqrt()].into_iter().find(|&t| t > t_min && t < t_max)?;
        Some(Hit::new(t, ray.at(t), DVec3::ZERO))
    }
}

impl Geometry for NaiveSphere {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        (at.point - self.0).normalize()
    }
    fn bounds(&self) -> Option<raylab::Aabb> {
        None
    }
}

/// The textbook sphere as a sampler: the registered sphere's draws, its own intersection.
const NAIVE: ShapeSampler = ShapeSampler {
    name: "naive sphere",
    sample: |d, center, s| {
        let radius = d.length(s, 1.0)?;
        Some(ShapeSample::round(Box::new(NaiveSphere(center, radius)), Box::new(ExactNaive(center, radius)), center, radius))
    },
};

/// The sphere's exact surface.
struct ExactNaive(DVec3, f64);

impl ExactSurface for ExactNaive {
    fn signed_distance(&self, p: DVec3) -> f64 {
        (p - self.0).length() - self.1
    }
    fn outward_normal(&self, p: DVec3) -> DVec3 {
        (p - self.0).normalize()
    }
}

#[test]
fn the_campaign_catches_a_sphere_without_error_bounds() {
    let t = reintersect(&NAIVE, seed(9), 64, 64);
    assert!(t.failures.len() > 100, "only {} failures of {} rays", t.failures.len(), t.spawned + t.shadow);
}
