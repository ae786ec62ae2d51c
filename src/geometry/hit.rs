//! [`Hit`]: where a ray meets a surface, as the intersection test finds it, and the secondary rays
//! that leave it without re-hitting it.

use crate::math::float::{SHADOW_EPSILON, offset_ray_origin};
use crate::math::ray::Ray;
use glam::{DVec2, DVec3};

/// Where a ray meets a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (the ray's direction is unit length).
    pub t: f64,
    /// The hit point, computed by the shape as accurately as it can (often more accurately than
    /// `ray.at(t)`).
    pub point: DVec3,
    /// Conservative absolute rounding-error bound of `point`, per axis. Secondary rays start
    /// outside this box ([`crate::math::float::offset_ray_origin`]).
    pub error: DVec3,
    /// Shape-defined surface coordinates (barycentrics for triangles, angles for a sphere, …).
    pub uv: DVec2,
    /// Shape-defined index of the sub-primitive hit (the triangle of a mesh; 0 for simple shapes).
    pub prim: u32,
    /// Index of the scene object that was hit. Shapes set 0; the scene fills it in.
    pub object: u32,
}

impl Hit {
    /// A hit at `t` with point and error bound; `uv`, `prim` and `object` zero.
    pub fn new(t: f64, point: DVec3, error: DVec3) -> Self {
        Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 }
    }

    /// A secondary ray (reflection, refraction) leaving the hit along unit `dir`: it starts just
    /// outside the point's error box on `dir`'s side of the geometric normal `n`
    /// ([`offset_ray_origin`]), so it cannot hit the surface it leaves at `t ≈ 0`.
    #[inline(always)]
    pub fn spawn_ray(&self, n: DVec3, dir: DVec3) -> Ray {
        Ray { origin: offset_ray_origin(self.point, self.error, n, dir), dir }
    }

    /// A shadow ray toward a light `distance` away from the hit point along unit `dir` (infinite
    /// for a directional light): the ray of [`Hit::spawn_ray`] and the `t_max` that stops it
    /// [`SHADOW_EPSILON`] (relative) short of the light.
    #[inline(always)]
    pub fn spawn_shadow_ray(&self, n: DVec3, dir: DVec3, distance: f64) -> (Ray, f64) {
        self.shadow_ray_from(self.spawn_ray(n, dir), distance)
    }

    /// The shadow ray `ray` (leaving the hit from the origin [`Hit::spawn_ray`] gives it) toward
    /// a light `distance` away, with the `t_max` of [`Hit::spawn_shadow_ray`].
    #[inline(always)]
    pub fn shadow_ray_from(&self, ray: Ray, distance: f64) -> (Ray, f64) {
        let t_max =
            if distance.is_finite() { (distance - (ray.origin - self.point).length()) * (1.0 - SHADOW_EPSILON) } else { f64::INFINITY };
        (ray, t_max)
    }
}
