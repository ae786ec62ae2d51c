//! Reusable checks for plugin authors: the contracts every geometry must meet, checked hit by hit
//! against an exact description of the surface. The built-in shapes' property tests use these, and
//! so can a third-party crate's (a torus, a metaball): write an [`ExactSurface`] from the shape's
//! definition, generate rays, and call [`check_hits_ascending`] (which runs [`check_hit`] on every
//! hit), [`check_closed_crossings`] for solids, and [`check_t_window`] for `t_min`/`t_max`.

use crate::geometry::{Geometry, Hit};
use crate::math::float::{NORMAL_TOLERANCE, SURFACE_TOLERANCE, gamma};
use crate::math::ray::Ray;
use glam::DVec3;

/// The exact surface a geometry stands for: the oracle its hits are checked against. Write it from
/// the shape's definition, independently of its intersection code.
pub trait ExactSurface {
    /// Signed distance (scene units) from `p` to the surface: positive on the outward side (outside
    /// a closed solid), negative on the other. Must be the true distance, at least near the surface.
    fn signed_distance(&self, p: DVec3) -> f64;

    /// Outward unit normal at the surface point nearest to `p`.
    fn outward_normal(&self, p: DVec3) -> DVec3;

    /// The outward normals a hit at `p` may report: [`ExactSurface::outward_normal`] alone by
    /// default. A surface with sharp edges (a cylinder's rim) returns the normal of every face
    /// within `within` (scene units) of `p`.
    fn outward_normals_near(&self, p: DVec3, within: f64) -> Vec<DVec3> {
        let _ = within;
        vec![self.outward_normal(p)]
    }
}

/// The point of segment `a b` closest to `p` (for oracles of shapes with edges).
pub fn closest_on_segment(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let ab = b - a;
    a + ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) * ab
}

/// How far a reported hit may stray from the exact answer. Distances are relative to the
/// magnitude of the problem, so one tolerance serves a scene at any scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Magnitude of the problem (scene units): the largest coordinate or size of the shape and of
    /// the ray origin.
    pub scale: f64,
    /// Largest distance of a hit point from the exact surface, and from `ray.at(t)` beyond the
    /// rounding of `ray.at` itself, as a fraction of `max(scale, |point|, t)` (see
    /// [`Tolerance::distance`]).
    pub relative: f64,
    /// Largest `|‖n‖ − 1|` of a unit normal and largest distance from the exact unit normal
    /// (≈ the angle between them, radians).
    pub normal: f64,
}

impl Tolerance {
    /// The named tolerances for a problem of magnitude `scale`: [`SURFACE_TOLERANCE`] for points,
    /// [`NORMAL_TOLERANCE`] for normals.
    pub fn for_scale(scale: f64) -> Self {
        Tolerance { scale, relative: SURFACE_TOLERANCE, normal: NORMAL_TOLERANCE }
    }

    /// The absolute distance tolerance (scene units) of a hit at `t` and `point`: `relative ·
    /// max(scale, |point|∞, t)`. A far hit (a grazing ray on a plane) is as precise as its
    /// coordinates allow, not as the shape's size.
    pub fn distance(&self, t: f64, point: DVec3) -> f64 {
        self.relative * self.scale.max(point.abs().max_element()).max(t.abs())
    }
}

/// A violated geometric property, with the ray that shows it.
#[derive(Debug, Clone)]
pub struct Violation {
    /// What went wrong.
    pub what: String,
    /// The ray.
    pub ray: Ray,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} (ray origin {:?}, dir {:?})", self.what, self.ray.origin, self.ray.dir)
    }
}

/// Checks the closest hit of `ray` on `g` in `(t_min, t_max)` against the contracts of
/// [`Geometry`] and against the exact surface, and returns it:
/// - `occludes` agrees with `intersect`;
/// - `t` is finite and in `(t_min, t_max)`, and nothing is hit in `(t_min, t)` (closest hit; a
///   query whose `t_max` is exactly `t` must not return `t`);
/// - the point and its error bound are finite, the bound non-negative;
/// - the point is within [`Tolerance::distance`] of the exact surface and inside `g.bounds()`
///   (grown by the same), and within `Tolerance::distance / cos θ` of `ray.at(t)`, θ the angle
///   between the ray and the exact normal (a grazing hit is only that well defined along the
///   surface);
/// - `outward_normal` is unit length and within `tol.normal` of an exact outward normal
///   ([`ExactSurface::outward_normals_near`]);
/// - `normal(hit, dir)` is unit length, faces against the ray, and is `±outward_normal`.
pub fn check_hit(
    g: &dyn Geometry,
    ray: &Ray,
    t_min: f64,
    t_max: f64,
    tol: &Tolerance,
    surface: &dyn ExactSurface,
) -> Result<Option<Hit>, Violation> {
    let fail = |what: String| Err(Violation { what, ray: *ray });
    let hit = g.intersect(ray, t_min, t_max);
    if g.occludes(ray, t_min, t_max) != hit.is_some() {
        return fail(format!("occludes disagrees with intersect (hit: {hit:?}) in ({t_min}, {t_max})"));
    }
    let Some(h) = hit else { return Ok(None) };
    if !(h.t.is_finite() && h.t > t_min && h.t < t_max) {
        return fail(format!("t = {} outside ({t_min}, {t_max})", h.t));
    }
    if let Some(c) = g.intersect(ray, t_min, h.t) {
        return fail(format!("a query in ({t_min}, {}) returned t = {}: the closest hit was missed or t_max not respected", h.t, c.t));
    }
    if !h.point.is_finite() || !h.error.is_finite() || h.error.min_element() < 0.0 {
        return fail(format!("non-finite point {} or bad error bound {}", h.point, h.error));
    }
    let dist_tol = tol.distance(h.t, h.point);
    let along = ray.at(h.t);
    // A ray meeting the surface at a grazing angle fixes the hit only to within dist_tol / cos
    // along the surface: the hit's condition number.
    let cos = surface.outward_normal(h.point).dot(ray.dir).abs();
    let slack = dist_tol / cos + gamma(3) * (ray.origin.abs().max_element() + h.t);
    if (h.point - along).abs().max_element() > slack {
        return fail(format!("point {} is {} away from ray.at(t = {}) = {along}", h.point, (h.point - along).length(), h.t));
    }
    let d = surface.signed_distance(h.point);
    if !(d.abs() <= dist_tol) {
        return fail(format!("point {} at t = {} is {d} off the surface (tolerance {dist_tol})", h.point, h.t));
    }
    if let Some(b) = g.bounds()
        && !b.expand(DVec3::splat(dist_tol)).contains(h.point)
    {
        return fail(format!("point {} outside the bounds {b:?}", h.point));
    }
    let o = g.outward_normal(&h);
    if !((o.length() - 1.0).abs() <= tol.normal) {
        return fail(format!("outward normal {o} is not unit length"));
    }
    let exact = surface.outward_normals_near(h.point, dist_tol);
    if !exact.iter().any(|e| (o - *e).length() <= tol.normal) {
        return fail(format!("outward normal {o} at {} differs from the exact {exact:?}", h.point));
    }
    let n = g.normal(&h, ray.dir);
    if !((n.length() - 1.0).abs() <= tol.normal) {
        return fail(format!("normal {n} is not unit length"));
    }
    if n.dot(ray.dir) > 0.0 {
        return fail(format!("normal {n} does not face the ray (n·d = {})", n.dot(ray.dir)));
    }
    if !((n - o).length() <= tol.normal || (n + o).length() <= tol.normal) {
        return fail(format!("normal {n} is not ± the outward normal {o}"));
    }
    Ok(Some(h))
}

/// Walks every hit of `ray` on `g` beyond `t = 0`, nearest first, by repeatedly asking for the
/// closest hit beyond the previous one; checks each with [`check_hit`], checks that `t` strictly
/// increases, and that there are at most `max_hits` (e.g. 2 for a sphere). Returns the hits.
pub fn check_hits_ascending(
    g: &dyn Geometry,
    ray: &Ray,
    tol: &Tolerance,
    surface: &dyn ExactSurface,
    max_hits: usize,
) -> Result<Vec<Hit>, Violation> {
    let mut hits: Vec<Hit> = Vec::new();
    let mut t_min = 0.0;
    while let Some(h) = check_hit(g, ray, t_min, f64::INFINITY, tol, surface)? {
        if h.t <= t_min {
            return Err(Violation { what: format!("hit t = {} not after previous t = {t_min}", h.t), ray: *ray });
        }
        hits.push(h);
        if hits.len() > max_hits {
            let ts: Vec<f64> = hits.iter().map(|h| h.t).collect();
            return Err(Violation { what: format!("more than {max_hits} hits: t = {ts:?}"), ray: *ray });
        }
        t_min = h.t;
    }
    Ok(hits)
}

/// For a closed solid (`g.is_closed()`) and a ray that is nowhere tangent to it: the hits
/// (from [`check_hits_ascending`]) alternately enter and leave, starting with entering when the
/// origin is outside, and the ray ends outside. Entering means `outward_normal · dir < 0`.
pub fn check_closed_crossings(g: &dyn Geometry, ray: &Ray, hits: &[Hit], origin_inside: bool) -> Result<(), Violation> {
    let fail = |what: String| Err(Violation { what, ray: *ray });
    if !g.is_closed() {
        return fail("check_closed_crossings on a geometry that is not closed".into());
    }
    let mut inside = origin_inside;
    for h in hits {
        let entering = g.outward_normal(h).dot(ray.dir) < 0.0;
        if entering == inside {
            let what = if entering { "enters while already inside" } else { "leaves while outside" };
            return fail(format!("hit at t = {} {what}", h.t));
        }
        inside = entering;
    }
    if inside {
        return fail(format!("the ray ends inside the solid after {} hits", hits.len()));
    }
    Ok(())
}

/// Checks that [`Intersectable::intersect_into`] gives `intersect(ray, t_min, t_max)`'s answer
/// bit for bit: the same hit written (compared by its `Debug` text, which tells `-0.0` from `0.0`),
/// or nothing written on a miss.
///
/// [`Intersectable::intersect_into`]: crate::geometry::Intersectable::intersect_into
pub fn check_intersect_into(g: &dyn Geometry, ray: &Ray, t_min: f64, t_max: f64) -> Result<(), Violation> {
    let untouched = Hit { t: -1.0, point: DVec3::splat(-2.0), error: DVec3::splat(-3.0), uv: glam::DVec2::splat(-4.0), prim: 5, object: 6 };
    let mut into = untouched;
    let wrote = g.intersect_into(ray, t_min, t_max, &mut into);
    let whole = g.intersect(ray, t_min, t_max);
    let (got, expected) = (format!("{wrote} {into:?}"), format!("{} {:?}", whole.is_some(), whole.unwrap_or(untouched)));
    if got != expected {
        return Err(Violation { what: format!("in ({t_min}, {t_max}) intersect_into wrote {got}, intersect gives {expected}"), ray: *ray });
    }
    Ok(())
}

/// Checks that `intersect(ray, t_min, t_max)` (and `occludes`) return exactly the first of `hits`
/// (all hits of the ray, from [`check_hits_ascending`]) inside `(t_min, t_max)`, or nothing when
/// none lies there. A hit within a relative `1e-12` of either end may go either way. Also
/// [`check_intersect_into`] in that window.
pub fn check_t_window(g: &dyn Geometry, ray: &Ray, hits: &[Hit], t_min: f64, t_max: f64) -> Result<(), Violation> {
    check_intersect_into(g, ray, t_min, t_max)?;
    let fail = |what: String| Err(Violation { what, ray: *ray });
    let near = |t: f64, end: f64| (t - end).abs() <= 1e-12 * end.abs();
    if hits.iter().any(|h| near(h.t, t_min) || near(h.t, t_max)) {
        return Ok(());
    }
    let expected = hits.iter().find(|h| h.t > t_min && h.t < t_max).map(|h| h.t);
    let got = g.intersect(ray, t_min, t_max).map(|h| h.t);
    if got != expected {
        return fail(format!("in ({t_min}, {t_max}) expected t = {expected:?}, got {got:?}"));
    }
    if g.occludes(ray, t_min, t_max) != expected.is_some() {
        return fail(format!("occludes in ({t_min}, {t_max}) disagrees with the hits"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Intersectable;
    use crate::math::bounds::Aabb;

    /// The unit sphere at the origin, with one deliberate fault.
    #[derive(Default)]
    struct Faulty {
        fault: Option<Fault>,
    }

    #[derive(Clone, Copy, PartialEq)]
    enum Fault {
        PointOffSurface,
        TOffPoint,
        InwardNormal,
        FacesAway,
        OccludesLies,
        ReturnsTMax,
        FarHitFirst,
        TinyBounds,
    }

    struct UnitSphere;

    impl ExactSurface for UnitSphere {
        fn signed_distance(&self, p: DVec3) -> f64 {
            p.length() - 1.0
        }
        fn outward_normal(&self, p: DVec3) -> DVec3 {
            p.normalize()
        }
    }

    impl Intersectable for Faulty {
        fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
            let b = ray.origin.dot(ray.dir);
            let disc = b * b - (ray.origin.length_squared() - 1.0);
            if disc < 0.0 {
                return None;
            }
            let mut roots = [-b - disc.sqrt(), -b + disc.sqrt()];
            if self.fault == Some(Fault::FarHitFirst) {
                roots.reverse();
            }
            let accept = |t: f64| t > t_min && (t < t_max || (self.fault == Some(Fault::ReturnsTMax) && t <= t_max));
            let t = roots.into_iter().find(|&t| accept(t))?;
            let mut point = ray.at(t).normalize();
            let mut t_reported = t;
            match self.fault {
                Some(Fault::PointOffSurface) => point *= 1.001,
                Some(Fault::TOffPoint) => t_reported += 0.01,
                _ => {}
            }
            Some(Hit::new(t_reported, point, DVec3::ZERO))
        }
        fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
            let hit = self.intersect(ray, t_min, t_max).is_some();
            if self.fault == Some(Fault::OccludesLies) { !hit } else { hit }
        }
    }

    impl Geometry for Faulty {
        fn outward_normal(&self, at: &Hit) -> DVec3 {
            if self.fault == Some(Fault::InwardNormal) { -at.point.normalize() } else { at.point.normalize() }
        }
        fn normal(&self, at: &Hit, dir: DVec3) -> DVec3 {
            let n = crate::geometry::face_forward(self.outward_normal(at), dir);
            if self.fault == Some(Fault::FacesAway) { -n } else { n }
        }
        fn bounds(&self) -> Option<Aabb> {
            let r = if self.fault == Some(Fault::TinyBounds) { 0.5 } else { 1.0 };
            Some(Aabb::new(DVec3::splat(-r), DVec3::splat(r)))
        }
        fn is_closed(&self) -> bool {
            true
        }
    }

    fn ray() -> Ray {
        Ray::new(DVec3::new(0.3, -0.2, -5.0), DVec3::Z)
    }

    #[test]
    fn a_correct_geometry_passes_every_check() {
        let g = Faulty::default();
        let tol = Tolerance::for_scale(5.0);
        let hits = check_hits_ascending(&g, &ray(), &tol, &UnitSphere, 2).unwrap();
        assert_eq!(hits.len(), 2);
        check_closed_crossings(&g, &ray(), &hits, false).unwrap();
        for (t0, t1) in [(0.0, 1.0), (0.0, 5.0), (4.5, 10.0), (5.5, 6.0)] {
            check_t_window(&g, &ray(), &hits, t0, t1).unwrap();
        }
    }

    #[test]
    fn each_fault_is_caught() {
        use Fault::*;
        let tol = Tolerance::for_scale(5.0);
        for fault in [PointOffSurface, TOffPoint, InwardNormal, FacesAway, OccludesLies, TinyBounds] {
            let g = Faulty { fault: Some(fault) };
            assert!(check_hit(&g, &ray(), 0.0, f64::INFINITY, &tol, &UnitSphere).is_err());
        }
        // t_max itself returned: the closest-hit query up to the hit's own t finds it again.
        let g = Faulty { fault: Some(ReturnsTMax) };
        assert!(check_hit(&g, &ray(), 0.0, f64::INFINITY, &tol, &UnitSphere).is_err());
        // The far hit first: the walk sees a hit closer than the one reported.
        let g = Faulty { fault: Some(FarHitFirst) };
        assert!(check_hits_ascending(&g, &ray(), &tol, &UnitSphere, 2).is_err());
    }

    #[test]
    fn crossings_and_windows_catch_wrong_answers() {
        let g = Faulty::default();
        let tol = Tolerance::for_scale(5.0);
        let hits = check_hits_ascending(&g, &ray(), &tol, &UnitSphere, 2).unwrap();
        // Claiming the origin is inside makes the first hit an entry while inside.
        assert!(check_closed_crossings(&g, &ray(), &hits, true).is_err());
        assert!(check_closed_crossings(&g, &ray(), &hits[..1], false).is_err());
        // A window answered with a hit that was never there.
        let ghost = [Hit::new(4.2, DVec3::ZERO, DVec3::ZERO)];
        assert!(check_t_window(&g, &ray(), &ghost, 0.0, 10.0).is_err());
        // More hits than allowed.
        assert!(check_hits_ascending(&g, &ray(), &tol, &UnitSphere, 1).is_err());
    }

    #[test]
    fn the_distance_tolerance_grows_with_the_hit_magnitude() {
        let tol = Tolerance::for_scale(2.0);
        assert_eq!(tol.distance(1.0, DVec3::ONE), 2.0 * SURFACE_TOLERANCE);
        assert_eq!(tol.distance(1e6, DVec3::ONE), 1e6 * SURFACE_TOLERANCE);
        assert_eq!(tol.distance(1.0, DVec3::new(0.0, -3e3, 0.0)), 3e3 * SURFACE_TOLERANCE);
    }
}
