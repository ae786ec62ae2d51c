//! Property tests of the torus at scales from 1e-4 to 1e4 and distances up to 1e8 times its size,
//! with raylab's reusable geometry checks (`raylab::geometry::testing`), as for the built-in shapes.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use raylab::geometry::testing::{Tolerance, check_hits_ascending};
use raylab::glam::DVec3;
use raylab::math::float::offset_ray_origin;
use raylab::{Geometry, Intersectable, Ray};
use raylab_torus::torus::{ExactTorus, Torus};

/// A unit vector from two uniform numbers.
fn unit(u: f64, v: f64) -> DVec3 {
    let z = 2.0 * u - 1.0;
    let phi = std::f64::consts::TAU * v;
    let s = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// A unit direction entering the surface with outward normal `n` at angle `cos` (0 < cos ≤ 1)
/// from the inward normal, turned toward the random direction `(u, v)`.
fn entering(n: DVec3, cos: f64, u: f64, v: f64) -> DVec3 {
    let w = unit(u, v);
    let tangent = (w - w.dot(n) * n).try_normalize().unwrap_or_else(|| n.any_orthonormal_pair().0);
    (-cos * n + (1.0 - cos * cos).max(0.0).sqrt() * tangent).normalize()
}

/// A torus of random size, position, orientation and thickness.
#[derive(Debug, Clone)]
struct Case {
    center: DVec3,
    axis: DVec3,
    major: f64,
    minor: f64,
}

impl Case {
    /// Its exact surface, from the definition ([`ExactTorus`]).
    fn exact(&self) -> ExactTorus {
        ExactTorus { center: self.center, axis: self.axis, major: self.major, minor: self.minor }
    }

    fn torus(&self) -> Torus {
        Torus::new(self.center, self.axis, self.major, self.minor)
    }

    /// The point at angles (around the axis, around the tube) and its outward normal.
    fn surface(&self, a: f64, b: f64) -> (DVec3, DVec3) {
        let (u, v) = self.axis.any_orthonormal_pair();
        let ring = a.cos() * u + a.sin() * v;
        let n = b.cos() * ring + b.sin() * self.axis;
        (self.center + self.major * ring + self.minor * n, n)
    }

    /// Magnitude of the coordinates involved, for tolerances.
    fn scale(&self) -> f64 {
        self.center.abs().max_element() + self.major + self.minor
    }
}

fn fail(v: raylab::geometry::testing::Violation) -> TestCaseError {
    TestCaseError::fail(v.to_string())
}

fn case() -> impl Strategy<Value = Case> {
    (-4.0..4.0f64, 0.05..0.95f64, 0.0..1.0f64, 0.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -3.0..3.0f64).prop_map(
        |(log_size, thickness, au, av, cx, cy, cz, log_offset)| {
            let major = 10f64.powf(log_size);
            Case { center: DVec3::new(cx, cy, cz) * 10f64.powf(log_offset) * major, axis: unit(au, av), major, minor: major * thickness }
        },
    )
}

proptest! {
    // Failures print the minimal case; it belongs in a unit test, not in a persistence file.
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, rng_seed: RngSeed::Fixed(raylab::testing::seed("torus properties")), ..ProptestConfig::default() })]

    /// Rays from anywhere near the torus: every hit lies on the surface with the exact outward
    /// normal and a unit normal facing the ray, hits come in ascending order, there are at most
    /// four, and occludes agrees.
    #[test]
    fn hits_are_on_the_surface_in_order(c in case(), ou in 0.0..1.0f64, ov in 0.0..1.0f64, dist in 0.0..4.0f64, du in 0.0..1.0f64, dv in 0.0..1.0f64) {
        let t = c.torus();
        let origin = c.center + unit(ou, ov) * dist * (c.major + c.minor);
        let ray = Ray::new(origin, unit(du, dv));
        let tol = Tolerance::for_scale(c.scale() + origin.abs().max_element());
        check_hits_ascending(&t, &ray, &tol, &c.exact(), 4).map_err(fail)?;
    }

    /// A ray aimed at a surface point from up to 1e8 times the torus's size away finds that point
    /// (or something in front of it), as precisely as `f64` can place a point that far along a ray.
    #[test]
    fn far_rays_aimed_at_the_surface_find_it(c in case(), a in 0.0..std::f64::consts::TAU, b in 0.0..std::f64::consts::TAU,
                                            cos in 0.2..1.0f64, du in 0.0..1.0f64, dv in 0.0..1.0f64, log_far in -2.0..8.0f64) {
        let t = c.torus();
        let (target, n) = c.surface(a, b);
        let dir = entering(n, cos, du, dv);
        let far = 10f64.powf(log_far) * (c.major + c.minor);
        let origin = target - far * dir;
        let ray = Ray::new(origin, dir);
        let tol = (1e-13 * far + 1e-9 * c.scale()) / -dir.dot(n);
        let exact = Tolerance::for_scale(c.scale() + origin.abs().max_element());
        let hits = check_hits_ascending(&t, &ray, &exact, &c.exact(), 6).map_err(fail)?;
        let ts: Vec<f64> = hits.iter().map(|h| h.t).collect();
        prop_assert!(ts.first().is_some_and(|&t0| t0 <= far + tol), "first hit {ts:?} beyond the target at {far}");
        prop_assert!(ts.iter().any(|&th| (th - far).abs() <= tol), "no hit at the target {far} (tol {tol}): {ts:?}");
    }

    /// Secondary rays leave the surface cleanly: a reflected ray never meets the point it left,
    /// and a ray continuing into the solid always finds the way out (the tube is closed).
    #[test]
    fn secondary_rays_neither_self_hit_nor_leak(c in case(), a in 0.0..std::f64::consts::TAU, b in 0.0..std::f64::consts::TAU,
                                               cos in 0.2..1.0f64, du in 0.0..1.0f64, dv in 0.0..1.0f64) {
        let t = c.torus();
        let (target, n) = c.surface(a, b);
        let dir = entering(n, cos, du, dv);
        let ray = Ray::new(target - 3.0 * (c.major + c.minor) * dir, dir);
        let Some(hit) = t.intersect(&ray, 0.0, f64::INFINITY) else {
            return Err(TestCaseError::fail("missed the torus"));
        };
        let normal = t.normal(&hit, ray.dir);
        let reflected = ray.dir - 2.0 * ray.dir.dot(normal) * normal;
        let out = Ray::new(offset_ray_origin(hit.point, hit.error, normal, reflected), reflected);
        if let Some(again) = t.intersect(&out, 0.0, f64::INFINITY) {
            prop_assert!(again.t > 1e-3 * c.minor, "reflected ray hit its own surface at t = {}", again.t);
        }
        let inside = Ray::new(offset_ray_origin(hit.point, hit.error, normal, ray.dir), ray.dir);
        // The longest chord inside the tube touches the hole: 2·√((R + r)² − (R − r)²) = 4·√(R·r).
        let longest = 4.0 * (c.major * c.minor).sqrt() * (1.0 + 1e-9);
        let exit = t.intersect(&inside, 0.0, f64::INFINITY);
        prop_assert!(exit.is_some_and(|e| e.t > 1e-3 * c.minor && e.t <= longest),
            "transmitted ray: exit {:?} (longest chord {longest})", exit.map(|e| e.t));
    }

    /// The box holds the whole surface, and outward normals point out of the solid.
    #[test]
    fn bounds_hold_the_surface_and_normals_point_out(c in case(), a in 0.0..std::f64::consts::TAU, b in 0.0..std::f64::consts::TAU) {
        let t = c.torus();
        let (p, n) = c.surface(a, b);
        let bounds = t.bounds().unwrap().expand(DVec3::splat(1e-12 * c.scale()));
        prop_assert!(bounds.contains(p), "{p} outside {bounds:?}");
        let hit = raylab::Hit::new(0.0, p, DVec3::ZERO);
        let o = t.outward_normal(&hit);
        prop_assert!((o - n).length() < 1e-6, "outward normal {o}, expected {n}");
        prop_assert!(t.signed_distance(p + 0.01 * c.minor * o) > 0.0);
    }
}
