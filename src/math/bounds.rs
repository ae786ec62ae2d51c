//! Axis-aligned bounding boxes.

use crate::math::ray::Ray;
use glam::DVec3;

/// Largest coordinate magnitude of a bounded object, scene units. The hierarchy stores bounds as
/// f32 (finite below 3.4e38), and the f64 intersection math squares and multiplies coordinates
/// (a quartic's coefficients reach |x|⁴, 1e120 here, far from f64's 1.8e308); beyond this an
/// object would vanish silently, so the scene is refused instead.
pub const MAX_COORDINATE: f64 = 1e30;

/// An axis-aligned box `[min, max]`. The empty box has `min > max` on every axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner, scene units.
    pub min: DVec3,
    /// Upper corner, scene units.
    pub max: DVec3,
}

/// Half-extent along each world axis of a circle of `radius` in the plane perpendicular to the
/// unit vector `axis`: `radius · sqrt(1 − axis_i²)`, computed as `radius · sqrt(axis_j² + axis_k²)`
/// (no cancellation when `axis` is nearly a coordinate axis) and rounded up.
pub fn circle_extent(axis: DVec3, radius: f64) -> DVec3 {
    let a2 = axis * axis;
    let sin = DVec3::new(a2.y + a2.z, a2.x + a2.z, a2.x + a2.y).sqrt();
    radius * sin * (1.0 + crate::math::float::gamma(4))
}

impl Aabb {
    /// The empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb { min: DVec3::splat(f64::INFINITY), max: DVec3::splat(f64::NEG_INFINITY) };

    /// The box spanning two corners given in any order.
    pub fn new(a: DVec3, b: DVec3) -> Self {
        Aabb { min: a.min(b), max: a.max(b) }
    }

    /// The smallest box containing all `points`.
    pub fn from_points(points: impl IntoIterator<Item = DVec3>) -> Self {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.include(p))
    }

    /// This box grown to contain `p`.
    pub fn include(self, p: DVec3) -> Self {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }

    /// The smallest box containing both.
    pub fn union(self, o: Aabb) -> Self {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// This box grown by `margin` on every side.
    pub fn expand(self, margin: DVec3) -> Self {
        Aabb { min: self.min - margin, max: self.max + margin }
    }

    /// True when the box contains no point.
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Edge lengths (zero for the empty box).
    pub fn extent(&self) -> DVec3 {
        if self.is_empty() { DVec3::ZERO } else { self.max - self.min }
    }

    /// Centre point.
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// Largest absolute coordinate of the box: the magnitude that rounding errors scale with.
    pub fn magnitude(&self) -> f64 {
        if self.is_empty() { 0.0 } else { self.min.abs().max(self.max.abs()).max_element() }
    }

    /// True when `p` lies inside or on the box.
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Slab test: does the ray overlap the box within `(t_min, t_max)`? `inv_dir` is `1 / ray.dir`
    /// (infinities allowed). Conservative: the far bound is widened by 2γ(3) (pbrt-v4 §6.8.2) so a
    /// ray grazing a face is never rejected by rounding.
    #[inline]
    pub fn hit(&self, ray: &Ray, inv_dir: DVec3, t_min: f64, t_max: f64) -> bool {
        let t0 = (self.min - ray.origin) * inv_dir;
        let t1 = (self.max - ray.origin) * inv_dir;
        let near = t0.min(t1);
        let far = t0.max(t1) * (1.0 + 2.0 * crate::math::float::gamma(3));
        // NaN (0 · ∞, a ray in the plane of a face) compares false and is treated as "no limit".
        let t_near = near.max_element().max(t_min);
        let t_far = far.min_element().min(t_max);
        !(t_near > t_far)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every point of circles around nearly axis-aligned axes lies within the extent: `1 − a_z²`
    /// cancels to 0 for an axis 1e-8 rad off z, where the circle still rises 1e-8·r out of plane.
    #[test]
    fn circle_extent_holds_circles_around_nearly_aligned_axes() {
        for (axis, r) in [(DVec3::new(1e-8, 0.0, -1.0), 4e5), (DVec3::new(3e-9, -2e-9, 1.0), 1.0), (DVec3::new(1.0, 1.0, 0.5), 2.0)] {
            let a = axis.normalize();
            let ext = circle_extent(a, r);
            let (u, v) = (a.any_orthonormal_vector(), a.cross(a.any_orthonormal_vector()));
            for k in 0..3600 {
                let phi = f64::from(k) * std::f64::consts::TAU / 3600.0;
                let p = r * (phi.cos() * u + phi.sin() * v);
                assert!(p.abs().cmple(ext).all(), "{p} beyond {ext} (axis {a})");
            }
            assert!(ext.cmple(DVec3::splat(r * (1.0 + 1e-15))).all());
        }
    }

    #[test]
    fn slab_test_hits_and_misses() {
        let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0));
        let r = Ray::new(DVec3::new(0.0, 0.0, -5.0), DVec3::Z);
        assert!(b.hit(&r, r.dir.recip(), 0.0, f64::INFINITY));
        assert!(!b.hit(&r, r.dir.recip(), 0.0, 3.0));
        let miss = Ray::new(DVec3::new(2.0, 0.0, -5.0), DVec3::Z);
        assert!(!b.hit(&miss, miss.dir.recip(), 0.0, f64::INFINITY));
        // Along a face: origin in the plane x = 1, direction parallel to it.
        let graze = Ray::new(DVec3::new(1.0, 0.0, -5.0), DVec3::Z);
        assert!(b.hit(&graze, graze.dir.recip(), 0.0, f64::INFINITY));
    }

    #[test]
    fn empty_box_is_identity_of_union() {
        let b = Aabb::new(DVec3::ZERO, DVec3::ONE);
        assert_eq!(Aabb::EMPTY.union(b), b);
        assert!(Aabb::EMPTY.is_empty());
    }
}
