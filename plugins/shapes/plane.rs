//! `plane`: an infinite plane given by a point and a normal (the report's `Plane`).
//!
//! `t = n·(q − o) / (n·d)`. The hit point is projected back onto the plane, and a hit whose
//! numerator is within its rounding error of zero (the ray starts on the plane) is rejected.

use raylab::error::Result;
use raylab::float::gamma;
use raylab::geometry::{Geometry, Hit, Intersectable};
use raylab::glam::{DVec2, DVec3};
use raylab::params::{Default, MATERIAL_PARAM, ParamKind, ParamSpec, Params};
use raylab::{Aabb, LoadContext, Material, PluginInfo, Ray};

/// The plane through `point` with unit `normal` (its outward side).
#[derive(Clone, Debug)]
pub struct Plane {
    point: DVec3,
    normal: DVec3,
    material: Material,
}

/// The `plane` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "plane",
    summary: "An infinite plane through a point, with a normal. Unbounded; shaded on both sides.",
    params: &[
        ParamSpec::new("point", ParamKind::Vec3, Default::Vec3([0.0, 0.0, 0.0]), "a point on the plane (the report's Q)"),
        ParamSpec::new("normal", ParamKind::Vec3, Default::Vec3([0.0, 1.0, 0.0]), "normal (any length > 0): the plane's outward side"),
        MATERIAL_PARAM,
    ],
};

/// Builds a plane from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let point = p.vec3("point")?;
    let normal = p.direction("normal")?;
    Ok(Box::new(Plane::new(point, normal, p.material("material")?)))
}

/// Intersects a ray with the plane through `q` with unit normal `n`: returns `t`, the point
/// projected onto the plane, and its error bound.
#[inline]
pub fn intersect_plane(ray: &Ray, q: DVec3, n: DVec3, t_min: f64, t_max: f64) -> Option<(f64, DVec3, DVec3)> {
    let denom = n.dot(ray.dir);
    if denom == 0.0 {
        return None;
    }
    let diff = q - ray.origin;
    let num = n.dot(diff);
    // A numerator within its rounding error of zero means the origin lies on the plane.
    let num_err = gamma(5) * n.abs().dot(q.abs() + ray.origin.abs());
    if num.abs() <= num_err {
        return None;
    }
    let t = num / denom;
    if !(t > t_min && t < t_max) || !t.is_finite() {
        return None;
    }
    let p = ray.at(t);
    let p = p - n * n.dot(p - q);
    if !p.is_finite() {
        return None;
    }
    Some((t, p, gamma(8) * (p.abs() + q.abs())))
}

impl Plane {
    /// A plane; `normal` must be unit length.
    pub fn new(point: DVec3, normal: DVec3, material: Material) -> Self {
        Plane { point, normal, material }
    }
}

impl Intersectable for Plane {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let (t, point, error) = intersect_plane(ray, self.point, self.normal, t_min, t_max)?;
        Some(Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 })
    }
}

impl Geometry for Plane {
    fn outward_normal(&self, _: &Hit) -> DVec3 {
        self.normal
    }
    fn material(&self) -> &Material {
        &self.material
    }
    fn bounds(&self) -> Option<Aabb> {
        None
    }
}
