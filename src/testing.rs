//! Reusable checks for plugin authors: property checks every geometry must pass. The built-in
//! shapes' property tests use these, and so can a third-party crate's.

use crate::float::gamma;
use crate::geometry::Geometry;
use crate::ray::Ray;
use glam::DVec3;

/// A violated geometric property, with the ray that shows it.
#[derive(Debug, Clone)]
pub struct Violation {
    /// What went wrong.
    pub what: String,
    /// The ray.
    pub ray: Ray,
}

/// Checks a reported hit of `ray` on `g` against the contracts of [`Geometry`]:
/// - `t` lies in `(t_min, t_max)` and is finite;
/// - the point is within `tolerance` (absolute, scene units) of `ray.at(t)`;
/// - the point's error bound is finite and non-negative;
/// - `normal(hit, dir)` is unit length and faces against the ray;
/// - `outward_normal` is unit length;
/// - `surface_distance(point)` (the caller's signed distance to the exact surface) is within
///   `tolerance` of zero.
pub fn check_hit(
    g: &dyn Geometry,
    ray: &Ray,
    t_min: f64,
    t_max: f64,
    tolerance: f64,
    surface_distance: impl Fn(DVec3) -> f64,
) -> Result<Option<crate::geometry::Hit>, Violation> {
    let fail = |what: String| Violation { what, ray: *ray };
    let Some(h) = g.intersect(ray, t_min, t_max) else { return Ok(None) };
    if !(h.t.is_finite() && h.t > t_min && h.t < t_max) {
        return Err(fail(format!("t = {} outside ({t_min}, {t_max})", h.t)));
    }
    if !h.point.is_finite() || !h.error.is_finite() || h.error.min_element() < 0.0 {
        return Err(fail(format!("non-finite point {} or bad error bound {}", h.point, h.error)));
    }
    let along = ray.at(h.t);
    let slack = tolerance + gamma(4) * (along.abs().max_element() + h.t);
    if (h.point - along).abs().max_element() > slack {
        return Err(fail(format!("point {} is {} away from ray.at(t) = {along}", h.point, (h.point - along).length())));
    }
    let d = surface_distance(h.point);
    if !(d.abs() <= tolerance) {
        return Err(fail(format!("point {} is {d} off the surface (tolerance {tolerance})", h.point)));
    }
    let n = g.normal(&h, ray.dir);
    if !((n.length() - 1.0).abs() < 1e-9) {
        return Err(fail(format!("normal {n} is not unit length")));
    }
    if n.dot(ray.dir) > 0.0 {
        return Err(fail(format!("normal {n} does not face the ray (n·d = {})", n.dot(ray.dir))));
    }
    let o = g.outward_normal(&h);
    if !((o.length() - 1.0).abs() < 1e-9) {
        return Err(fail(format!("outward normal {o} is not unit length")));
    }
    Ok(Some(h))
}

/// Checks that the hits of `ray` on `g` come in ascending `t`: walks the surface by repeatedly
/// asking for the closest hit beyond the previous one, and checks that each is farther and that
/// `occludes` agrees with `intersect`. Returns the `t` values found.
pub fn check_hits_ascending(g: &dyn Geometry, ray: &Ray, max_hits: usize) -> Result<Vec<f64>, Violation> {
    let mut ts: Vec<f64> = Vec::new();
    let mut t_min = 0.0;
    for _ in 0..max_hits {
        let hit = g.intersect(ray, t_min, f64::INFINITY);
        if g.occludes(ray, t_min, f64::INFINITY) != hit.is_some() {
            return Err(Violation { what: format!("occludes disagrees with intersect beyond t = {t_min}"), ray: *ray });
        }
        let Some(h) = hit else { break };
        if let Some(&last) = ts.last() {
            if h.t <= last {
                return Err(Violation { what: format!("hit t = {} not after previous t = {last}", h.t), ray: *ray });
            }
        }
        ts.push(h.t);
        t_min = h.t;
    }
    Ok(ts)
}
