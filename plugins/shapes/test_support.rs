//! Generators and checks shared by the shapes' property tests.
//!
//! Every property runs with a fixed seed and no failure files, so a failure reproduces on every
//! machine; a bug once found is kept as a literal regression test beside the shape.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError};
use raylab::geometry::testing::{ExactSurface, Tolerance, Violation, check_hits_ascending, check_t_window};
use raylab::glam::DVec3;
use raylab::math::float::max_abs;
use raylab::{Aabb, Geometry, Hit, Ray};

/// Seed of every shape property.
pub const SEED: u64 = 0x5a17_ab1e;

/// Cases per property: the whole shape suite runs in about a second in the test profile.
pub const CASES: u32 = 8192;

/// A property configuration: `cases` cases from the fixed [`SEED`], no failure persistence.
pub fn config(cases: u32) -> Config {
    Config { cases, max_global_rejects: 4 * cases, rng_seed: RngSeed::Fixed(SEED), failure_persistence: None, ..Config::default() }
}

/// The magnitude of a generated scene: tiny, unit or large (the moderate extremes).
pub fn scale() -> impl Strategy<Value = f64> {
    prop::sample::select(vec![1e-3, 1.0, 1e4])
}

/// A point uniform in the cube `[-1, 1]³`.
pub fn cube() -> impl Strategy<Value = DVec3> {
    prop::array::uniform3(-1.0..1.0f64).prop_map(DVec3::from_array)
}

/// A direction uniform on the unit sphere.
pub fn unit() -> impl Strategy<Value = DVec3> {
    (-1.0..=1.0f64, 0.0..std::f64::consts::TAU).prop_map(|(z, phi)| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z).normalize()
    })
}

/// A unit vector perpendicular to unit `n`, at angle `phi` around it.
pub fn perpendicular(n: DVec3, phi: f64) -> DVec3 {
    let (b1, b2) = n.any_orthonormal_pair();
    (phi.cos() * b1 + phi.sin() * b2).normalize()
}

/// How a random ray is placed around a shape: its origin, the point it aims at (both in shape
/// sizes from the shape's centre), a free direction, and which of the two it uses.
#[derive(Clone, Copy, Debug)]
pub struct Aim {
    from: DVec3,
    to: DVec3,
    dir: DVec3,
    free: bool,
}

/// Random rays around a shape: mostly aimed at a point near it (so most hit), some free.
pub fn aim() -> impl Strategy<Value = Aim> {
    (cube(), cube(), unit(), prop::bool::weighted(0.2)).prop_map(|(from, to, dir, free)| Aim { from, to, dir, free })
}

impl Aim {
    /// The ray for a shape centred at `center` of size `size`: from within `3·size`, toward a point
    /// within `1.2·size` of the centre (or along the free direction).
    pub fn ray(&self, center: DVec3, size: f64) -> Ray {
        let origin = center + 3.0 * size * self.from;
        let to = center + 1.2 * size * self.to;
        let d = to - origin;
        if self.free || !(d.length() > 1e-6 * size) { Ray::new(origin, self.dir) } else { Ray::new(origin, d) }
    }
}

/// A ray from outside the bounding sphere of `b` moving away from it: origin at `(1 + gap)` bounding
/// radii from the centre along `w`, direction `v` turned to the far side (`v · w ≥ 0`).
pub fn away_ray(b: Aabb, w: DVec3, v: DVec3, gap: f64) -> Ray {
    let radius = 0.5 * b.extent().length();
    let origin = b.center() + radius * (1.0 + 1e-6 + gap) * w;
    Ray::new(origin, if v.dot(w) < 0.0 { -v } else { v })
}

/// The tolerance of a test whose shape has magnitude `shape_scale` and whose ray is `ray`.
pub fn tolerance(shape_scale: f64, ray: &Ray) -> Tolerance {
    Tolerance::for_scale(shape_scale.max(max_abs(ray.origin)))
}

/// A violation as a property failure.
pub fn fail(v: Violation) -> TestCaseError {
    TestCaseError::fail(v.to_string())
}

/// The generic checks on one ray: every hit exact and ascending (at most `max_hits`), and each
/// `t` window in `windows` (fractions of the span of the hits) answering with the right hit.
pub fn check_ray(
    g: &dyn Geometry,
    ray: &Ray,
    tol: &Tolerance,
    surface: &dyn ExactSurface,
    max_hits: usize,
    windows: &[(f64, f64)],
) -> Result<Vec<Hit>, TestCaseError> {
    let hits = check_hits_ascending(g, ray, tol, surface, max_hits).map_err(fail)?;
    let span = hits.last().map_or(tol.scale, |h| 1.5 * h.t);
    for &(a, b) in windows {
        let (t0, t1) = (a.min(b) * span, a.max(b) * span);
        check_t_window(g, ray, &hits, t0, t1).map_err(fail)?;
    }
    Ok(hits)
}

/// Random `t` windows for [`check_ray`], as fractions of the span of the hits.
pub fn windows() -> impl Strategy<Value = Vec<(f64, f64)>> {
    prop::collection::vec((0.0..1.0f64, 0.0..1.0f64), 3)
}

/// Asserts `actual` is within `tol` of `expected`, naming `what`.
pub fn close(what: &str, actual: f64, expected: f64, tol: f64) -> Result<(), TestCaseError> {
    if (actual - expected).abs() <= tol {
        Ok(())
    } else {
        Err(TestCaseError::fail(format!("{what}: {actual} differs from {expected} by more than {tol}")))
    }
}
