//! `cylinder` (finite, with caps) and `tube` (infinite, open): the report's cylinder, made real.
//!
//! The side is the quadratic `|fₚ + t·dₚ|² = r²` in the plane perpendicular to the axis, solved
//! like the sphere: discriminant from the closest-approach vector (no cancellation), roots from the
//! stable formula, each root accepted only beyond its own rounding-error bound, and the hit point
//! re-projected onto the side. Caps are discs tested as planes.

use super::plane::intersect_plane;
use raylab::error::Result;
use raylab::float::gamma;
use raylab::geometry::{Geometry, Hit, Intersectable};
use raylab::glam::{DVec2, DVec3};
use raylab::params::{Default, MATERIAL_PARAM, ParamKind, ParamSpec, Params};
use raylab::{Aabb, LoadContext, Material, PluginInfo, Ray};

/// `Hit::prim` of a hit on the side.
pub const SIDE: u32 = 0;
/// `Hit::prim` of a hit on the bottom cap (at `base`).
pub const BOTTOM_CAP: u32 = 1;
/// `Hit::prim` of a hit on the top cap (at `base + height·axis`).
pub const TOP_CAP: u32 = 2;

/// A cylinder of `radius` around the axis through `base` along unit `axis`; finite (with caps)
/// when `height` is `Some`, an infinite open tube otherwise.
#[derive(Clone, Debug)]
pub struct Cylinder {
    base: DVec3,
    axis: DVec3,
    radius: f64,
    height: Option<f64>,
    material: Material,
}

/// The `cylinder` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "cylinder",
    summary: "A finite cylinder closed by two flat caps: a solid (refraction bends at it).",
    params: &[
        ParamSpec::new("base", ParamKind::Vec3, Default::Vec3([0.0, 0.0, 0.0]), "centre of the bottom cap"),
        ParamSpec::new(
            "axis",
            ParamKind::Vec3,
            Default::Vec3([0.0, 1.0, 0.0]),
            "direction from the bottom cap to the top cap (any length > 0)",
        ),
        ParamSpec::new("height", ParamKind::Float, Default::Float(1.0), "distance between the caps, scene units, > 0"),
        ParamSpec::new("radius", ParamKind::Float, Default::Float(1.0), "radius, scene units, > 0"),
        MATERIAL_PARAM,
    ],
};

/// The `tube` plugin's description.
pub const TUBE_INFO: PluginInfo = PluginInfo {
    name: "tube",
    summary: "An infinite open cylinder around an axis (the report's Cylinder: axis point, axis direction, radius). Unbounded; an open surface.",
    params: &[
        ParamSpec::new("point", ParamKind::Vec3, Default::Vec3([0.0, 0.0, 0.0]), "a point on the axis"),
        ParamSpec::new("axis", ParamKind::Vec3, Default::Vec3([0.0, 1.0, 0.0]), "axis direction (any length > 0)"),
        ParamSpec::new("radius", ParamKind::Float, Default::Float(1.0), "radius, scene units, > 0"),
        MATERIAL_PARAM,
    ],
};

/// Builds a capped cylinder from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let base = p.vec3("base")?;
    let axis = p.direction("axis")?;
    let height = p.positive("height")?;
    let radius = p.positive("radius")?;
    Ok(Box::new(Cylinder::new(base, axis, radius, Some(height), p.material("material")?)))
}

/// Builds an infinite tube from its parameters.
pub fn build_tube(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let point = p.vec3("point")?;
    let axis = p.direction("axis")?;
    let radius = p.positive("radius")?;
    Ok(Box::new(Cylinder::new(point, axis, radius, None, p.material("material")?)))
}

impl Cylinder {
    /// A cylinder; `axis` must be unit length, `radius` and `height` finite and > 0.
    pub fn new(base: DVec3, axis: DVec3, radius: f64, height: Option<f64>, material: Material) -> Self {
        Cylinder { base, axis, radius, height, material }
    }

    fn side_hit(&self, ray: &Ray, f: DVec3, t: f64) -> Hit {
        let local = f + t * ray.dir;
        let along = local.dot(self.axis);
        let radial = local - along * self.axis;
        let radial = radial * (self.radius / radial.length());
        let point = self.base + along * self.axis + radial;
        let error = gamma(10) * (local.abs() + point.abs() + self.base.abs());
        Hit { t, point, error, uv: DVec2::new(along, 0.0), prim: SIDE, object: 0 }
    }
}

impl Intersectable for Cylinder {
    fn intersect(&self, ray: &Ray, t_min: f64, mut t_max: f64) -> Option<Hit> {
        let a = self.axis;
        let f = ray.origin - self.base;
        let (fa, da) = (f.dot(a), ray.dir.dot(a));
        let (fp, dp) = (f - fa * a, ray.dir - da * a);
        let mut best: Option<Hit> = None;
        let aa = dp.length_squared();
        if aa > 0.0 {
            let r2 = self.radius * self.radius;
            let b = fp.dot(dp);
            let l = fp - (b / aa) * dp;
            let disc = r2 - l.length_squared();
            if disc >= 0.0 {
                let q = -(b + (aa * disc).sqrt().copysign(b));
                if q != 0.0 {
                    let c = fp.length_squared() - r2;
                    let small = (c / q, gamma(10) * (fp.length_squared() + r2) / q.abs() + gamma(5) * (c / q).abs());
                    let large = (q / aa, gamma(10) * (q / aa).abs());
                    let roots = if small.0 <= large.0 { [small, large] } else { [large, small] };
                    for (t, err) in roots {
                        if !(t > t_min && t > err && t < t_max) {
                            continue;
                        }
                        let z = fa + t * da;
                        if self.height.is_some_and(|h| !(0.0..=h).contains(&z)) {
                            continue;
                        }
                        let h = self.side_hit(ray, f, t);
                        t_max = h.t;
                        best = Some(h);
                        break;
                    }
                }
            }
        }
        if let Some(height) = self.height {
            for (prim, center, n) in [(BOTTOM_CAP, self.base, -a), (TOP_CAP, self.base + height * a, a)] {
                if let Some((t, point, error)) = intersect_plane(ray, center, n, t_min, t_max) {
                    if (point - center).length_squared() <= self.radius * self.radius {
                        t_max = t;
                        best = Some(Hit { t, point, error, uv: DVec2::ZERO, prim, object: 0 });
                    }
                }
            }
        }
        best
    }
}

impl Geometry for Cylinder {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        match at.prim {
            BOTTOM_CAP => -self.axis,
            TOP_CAP => self.axis,
            _ => {
                let rel = at.point - self.base;
                (rel - rel.dot(self.axis) * self.axis).normalize()
            }
        }
    }
    fn material(&self) -> &Material {
        &self.material
    }
    fn bounds(&self) -> Option<Aabb> {
        let h = self.height?;
        // Bounding box of the two cap discs: each axis extends by r·sqrt(1 − a_i²).
        let a = self.axis;
        let ext = self.radius * (DVec3::ONE - a * a).max(DVec3::ZERO).sqrt();
        let top = self.base + h * a;
        Some(Aabb::new(self.base.min(top) - ext, self.base.max(top) + ext))
    }
    fn is_closed(&self) -> bool {
        self.height.is_some()
    }
}
