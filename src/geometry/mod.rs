//! The traits every shape implements: [`Intersectable`] (a ray can hit it) and [`Geometry`]
//! (it has a surface: material, bounds and the direction-aware normal).

pub mod testing;
pub mod transform;

use crate::math::bounds::Aabb;
use crate::math::float::{SHADOW_EPSILON, offset_ray_origin};
use crate::math::ray::Ray;
use crate::scene::material::Material;
use glam::{DVec2, DVec3};
use std::sync::Arc;

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
    #[inline]
    pub fn spawn_ray(&self, n: DVec3, dir: DVec3) -> Ray {
        Ray { origin: offset_ray_origin(self.point, self.error, n, dir), dir }
    }

    /// A shadow ray toward a light `distance` away from the hit point along unit `dir` (infinite
    /// for a directional light): the ray of [`Hit::spawn_ray`] and the `t_max` that stops it
    /// [`SHADOW_EPSILON`] (relative) short of the light.
    #[inline]
    pub fn spawn_shadow_ray(&self, n: DVec3, dir: DVec3, distance: f64) -> (Ray, f64) {
        let ray = self.spawn_ray(n, dir);
        let t_max =
            if distance.is_finite() { (distance - (ray.origin - self.point).length()) * (1.0 - SHADOW_EPSILON) } else { f64::INFINITY };
        (ray, t_max)
    }
}

/// Anything a ray can hit: a shape, a mesh, an acceleration structure.
pub trait Intersectable: Send + Sync {
    /// The closest hit with `t_min < t < t_max`, if any. `ray.dir` is unit length; `t_max` may be
    /// infinite. Must not panic and must not return a non-finite `t` or point for finite input.
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit>;

    /// Whether anything is hit with `t_min < t < t_max` (a shadow ray). May stop at the first hit
    /// found; the default calls [`Intersectable::intersect`].
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.intersect(ray, t_min, t_max).is_some()
    }
}

/// A surface with a material: what scene objects are made of.
pub trait Geometry: Intersectable {
    /// Unit normal at `at` on the surface's outside: out of the solid for closed shapes; for open
    /// shapes, the side the shape's parameters define (e.g. a triangle's winding).
    fn outward_normal(&self, at: &Hit) -> DVec3;

    /// Unit normal at `at` on the side that direction `dir` comes from (`n · dir ≤ 0`): the
    /// report's direction-aware `getNormal(point, direction)`. Shading uses only this, so no
    /// `abs()` and no "is it flat?" checks are needed anywhere.
    fn normal(&self, at: &Hit, dir: DVec3) -> DVec3 {
        face_forward(self.outward_normal(at), dir)
    }

    /// Unit normal used for shading at `at`, on the side `dir` comes from: the interpolated
    /// vertex normal of a smooth mesh, otherwise [`Geometry::normal`]. Integrators light with it
    /// but offset secondary rays and decide sides with the geometric [`Geometry::normal`].
    fn shading_normal(&self, at: &Hit, dir: DVec3) -> DVec3 {
        self.normal(at, dir)
    }

    /// The surface's material (for a shape with several, the first).
    fn material(&self) -> &Material;

    /// The material at a hit: meshes with several materials choose by triangle. Defaults to
    /// [`Geometry::material`].
    fn material_at(&self, at: &Hit) -> &Material {
        let _ = at;
        self.material()
    }

    /// True when some part of the surface may transmit light (shadow rays then walk through it
    /// rather than stopping). Defaults to whether [`Geometry::material`] is transmissive.
    fn may_transmit(&self) -> bool {
        self.material().is_transmissive()
    }

    /// A box containing the whole shape, or `None` for unbounded shapes (planes, infinite tubes).
    fn bounds(&self) -> Option<Aabb>;

    /// True when the surface encloses a volume (sphere, capped cylinder, closed mesh). Refraction
    /// bends rays only at such surfaces; open surfaces transmit as thin sheets.
    fn is_closed(&self) -> bool {
        false
    }
}

/// `n` flipped, if needed, to face against `dir` (`result · dir ≤ 0`).
#[inline]
pub fn face_forward(n: DVec3, dir: DVec3) -> DVec3 {
    if n.dot(dir) > 0.0 { -n } else { n }
}

macro_rules! forward_impls {
    ($($ptr:ident),*) => {$(
        impl<T: Intersectable + ?Sized> Intersectable for $ptr<T> {
            fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
                (**self).intersect(ray, t_min, t_max)
            }
            fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
                (**self).occludes(ray, t_min, t_max)
            }
        }
        impl<T: Geometry + ?Sized> Geometry for $ptr<T> {
            fn outward_normal(&self, at: &Hit) -> DVec3 {
                (**self).outward_normal(at)
            }
            fn normal(&self, at: &Hit, dir: DVec3) -> DVec3 {
                (**self).normal(at, dir)
            }
            fn shading_normal(&self, at: &Hit, dir: DVec3) -> DVec3 {
                (**self).shading_normal(at, dir)
            }
            fn material(&self) -> &Material {
                (**self).material()
            }
            fn material_at(&self, at: &Hit) -> &Material {
                (**self).material_at(at)
            }
            fn may_transmit(&self) -> bool {
                (**self).may_transmit()
            }
            fn bounds(&self) -> Option<Aabb> {
                (**self).bounds()
            }
            fn is_closed(&self) -> bool {
                (**self).is_closed()
            }
        }
    )*};
}
forward_impls!(Box, Arc);
