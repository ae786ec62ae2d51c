//! `hemisphere`: the report's bowl, a sphere cut in half by a plane through its centre, open on
//! the side that `open` points to.
//!
//! The bowl is an open surface, seen from inside and outside: the direction-aware normal faces
//! whichever side the ray comes from, so its inside is shaded as well as its outside, and it
//! shadows itself (a shadow ray from its inner wall toward a light can hit the opposite wall).
//! Points exactly on the rim belong to the bowl.

use super::sphere::sphere_roots;
use raylab::error::Result;
use raylab::float::gamma;
use raylab::geometry::{Geometry, Hit, Intersectable};
use raylab::glam::{DVec2, DVec3};
use raylab::params::{Default, MATERIAL_PARAM, ParamKind, ParamSpec, Params};
use raylab::{Aabb, LoadContext, Material, PluginInfo, Ray};

/// Half of the sphere (`center`, `radius`): the points `p` with `(p − center) · open ≤ 0`.
#[derive(Clone, Debug)]
pub struct Hemisphere {
    center: DVec3,
    radius: f64,
    open: DVec3,
    material: Material,
}

/// The `hemisphere` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "hemisphere",
    summary: "The report's bowl: half a sphere, open toward `open`. Shaded inside and outside; shadows itself. An open surface (transmits as a thin sheet).",
    params: &[
        ParamSpec::new("center", ParamKind::Vec3, Default::Vec3([0.0, 0.0, 0.0]), "centre of the full sphere, scene units"),
        ParamSpec::new("radius", ParamKind::Float, Default::Float(1.0), "radius, scene units, > 0"),
        ParamSpec::new(
            "open",
            ParamKind::Vec3,
            Default::Vec3([0.0, 1.0, 0.0]),
            "direction from the centre toward the open side; the bottom of the bowl is at center − radius·open",
        ),
        MATERIAL_PARAM,
    ],
};

/// Builds a hemisphere from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let center = p.vec3("center")?;
    let radius = p.positive("radius")?;
    let open = p.direction("open")?;
    Ok(Box::new(Hemisphere { center, radius, open, material: p.material("material")? }))
}

impl Hemisphere {
    /// A bowl; `open` must be unit length and `radius` > 0.
    pub fn new(center: DVec3, radius: f64, open: DVec3, material: Material) -> Self {
        Hemisphere { center, radius, open, material }
    }

    /// The lowest point of the bowl (the report's `bottom`).
    pub fn bottom(&self) -> DVec3 {
        self.center - self.radius * self.open
    }
}

impl Intersectable for Hemisphere {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let f = ray.origin - self.center;
        for (t, err) in sphere_roots(f, ray.dir, self.radius)? {
            if !(t > t_min && t > err && t < t_max) {
                continue;
            }
            let mut local = f + t * ray.dir;
            local *= self.radius / local.length();
            if local.dot(self.open) > 0.0 {
                continue;
            }
            let point = self.center + local;
            let error = gamma(6) * (local.abs() + point.abs());
            return Some(Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 });
        }
        None
    }
}

impl Geometry for Hemisphere {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        (at.point - self.center).normalize()
    }
    fn material(&self) -> &Material {
        &self.material
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(self.center - DVec3::splat(self.radius), self.center + DVec3::splat(self.radius)))
    }
}
