//! `sphere`: a sphere given by centre and radius.
//!
//! Numerics: the ray origin is moved to the sphere's frame, the discriminant is computed as
//! `r² − |f − (f·d)d|²` (Haines et al., *Ray Tracing Gems* ch. 7), which keeps precision for small
//! spheres far away, and the roots come from the cancellation-free quadratic formula. The hit
//! point is re-projected onto the sphere, and a root whose own error bound straddles zero is
//! rejected, so a ray leaving the surface never reports it again.

use raylab::error::Result;
use raylab::float::gamma;
use raylab::geometry::{Geometry, Hit, Intersectable};
use raylab::glam::{DVec2, DVec3};
use raylab::params::{Default, MATERIAL_PARAM, ParamKind, ParamSpec, Params};
use raylab::{Aabb, LoadContext, Material, PluginInfo, Ray};

/// A sphere of `radius` (> 0) around `center`.
#[derive(Clone, Debug)]
pub struct Sphere {
    center: DVec3,
    radius: f64,
    material: Material,
}

/// The `sphere` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "sphere",
    summary: "A sphere given by its centre and radius. A closed solid: refraction bends rays at its surface.",
    params: &[
        ParamSpec::new("center", ParamKind::Vec3, Default::Vec3([0.0, 0.0, 0.0]), "centre, scene units"),
        ParamSpec::new("radius", ParamKind::Float, Default::Float(1.0), "radius, scene units, > 0"),
        MATERIAL_PARAM,
    ],
};

/// Builds a sphere from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let center = p.vec3("center")?;
    let radius = p.positive("radius")?;
    Ok(Box::new(Sphere::new(center, radius, p.material("material")?)))
}

/// The two roots of the ray–sphere quadratic, ascending, each with a conservative absolute error
/// bound, for a ray with origin `f` relative to the centre and unit direction `d`. `None` on a miss.
#[inline]
pub fn sphere_roots(f: DVec3, d: DVec3, radius: f64) -> Option<[(f64, f64); 2]> {
    let r2 = radius * radius;
    let b = f.dot(d);
    let l = f - b * d;
    let disc = r2 - l.length_squared();
    if disc < 0.0 {
        return None;
    }
    let c = f.length_squared() - r2;
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return None;
    }
    // c/q is the root of smaller magnitude; its error is dominated by that of c = |f|² − r².
    let small = c / q;
    let small = (small, gamma(8) * (f.length_squared() + r2) / q.abs() + gamma(4) * small.abs());
    let large = (q, gamma(8) * q.abs());
    Some(if small.0 <= large.0 { [small, large] } else { [large, small] })
}

impl Sphere {
    /// A sphere; `radius` must be finite and > 0.
    pub fn new(center: DVec3, radius: f64, material: Material) -> Self {
        Sphere { center, radius, material }
    }

    fn hit_at(&self, ray: &Ray, f: DVec3, t: f64) -> Hit {
        let mut local = f + t * ray.dir;
        local *= self.radius / local.length();
        let point = self.center + local;
        let error = gamma(6) * (local.abs() + point.abs());
        Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 }
    }
}

impl Intersectable for Sphere {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let f = ray.origin - self.center;
        let roots = sphere_roots(f, ray.dir, self.radius)?;
        let (t, _) = roots.into_iter().find(|&(t, err)| t > t_min && t > err && t < t_max)?;
        Some(self.hit_at(ray, f, t))
    }
}

impl Geometry for Sphere {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        (at.point - self.center).normalize()
    }
    fn material(&self) -> &Material {
        &self.material
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(self.center - DVec3::splat(self.radius), self.center + DVec3::splat(self.radius)))
    }
    fn is_closed(&self) -> bool {
        true
    }
}
