//! `triangle`: a single triangle given by three vertices.
//!
//! The intersection is the watertight test of Woop, Benthin & Wald (JCGT 2013) with pbrt-v4's
//! conservative bound on `t`. A lone triangle follows the report: a ray through an edge or a
//! vertex does **not** hit it (edge functions must be strictly non-zero). Meshes use the same
//! test with edges counted as hits ([`EdgeRule::Inclusive`]), which makes shared edges watertight.

use raylab::error::Result;
use raylab::float::gamma;
use raylab::geometry::{Geometry, Hit, Intersectable};
use raylab::glam::{DVec2, DVec3};
use raylab::params::{Default, MATERIAL_PARAM, ParamKind, ParamSpec, Params};
use raylab::{Aabb, LoadContext, Material, PluginInfo, Ray};

/// Whether a ray exactly through an edge or vertex counts as a hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeRule {
    /// Edges and vertices are hits: no ray passes between triangles sharing an edge.
    Inclusive,
    /// Edges and vertices are not hits: the report's rule for a lone triangle.
    Exclusive,
}

/// The result of [`intersect_triangle`]: distance and barycentric coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Distance along the ray.
    pub t: f64,
    /// Barycentric coordinates (b0, b1, b2) of the hit, summing to 1.
    pub b: DVec3,
}

/// Watertight ray–triangle intersection (Woop et al. 2013; pbrt-v4 §6.5.3) for `t_min < t < t_max`.
/// `t` is accepted only when it exceeds its own rounding-error bound, so a ray starting on the
/// triangle never reports it at `t ≈ 0`.
#[inline]
pub fn intersect_triangle(ray: &Ray, p0: DVec3, p1: DVec3, p2: DVec3, t_min: f64, t_max: f64, rule: EdgeRule) -> Option<TriangleHit> {
    TriangleRay::new(ray).intersect(p0.to_array(), p1.to_array(), p2.to_array(), t_min, t_max, rule)
}

/// A ray prepared for [`TriangleRay::intersect`]: the axis permutation and shear of Woop et al.,
/// computed once per ray rather than once per triangle (what a mesh traversal needs).
#[derive(Clone, Copy, Debug)]
pub struct TriangleRay {
    origin: [f64; 3],
    /// Axes permuted so the ray's largest direction component is the last.
    k: [usize; 3],
    /// Shear onto +z: (−dx/dz, −dy/dz, 1/dz) in permuted axes.
    shear: [f64; 3],
}

impl TriangleRay {
    /// Prepares `ray` (unit, finite direction).
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let kz = d.abs().max_position();
        let kx = if kz == 2 { 0 } else { kz + 1 };
        let ky = if kx == 2 { 0 } else { kx + 1 };
        let shear = [-d[kx] / d[kz], -d[ky] / d[kz], 1.0 / d[kz]];
        TriangleRay { origin: ray.origin.to_array(), k: [kx, ky, kz], shear }
    }

    /// The watertight test against the triangle `p0 p1 p2` (see [`intersect_triangle`]).
    #[inline(always)]
    pub fn intersect(&self, p0: [f64; 3], p1: [f64; 3], p2: [f64; 3], t_min: f64, t_max: f64, rule: EdgeRule) -> Option<TriangleHit> {
        let [kx, ky, kz] = self.k;
        let o = self.origin;
        let [sx, sy, sz] = self.shear;
        // Translate to the ray origin, permute so the ray's largest axis is z, and shear onto +z.
        let rel = |p: [f64; 3]| {
            let z = p[kz] - o[kz];
            DVec3::new(p[kx] - o[kx] + sx * z, p[ky] - o[ky] + sy * z, z)
        };
        let (mut a, mut b, mut c) = (rel(p0), rel(p1), rel(p2));
        // Edge functions. Evaluated identically for a shared edge from either triangle (with
        // opposite sign), which is what makes adjacent triangles watertight.
        let e0 = b.x * c.y - b.y * c.x;
        let e1 = c.x * a.y - c.y * a.x;
        let e2 = a.x * b.y - a.y * b.x;
        let inside = match rule {
            EdgeRule::Inclusive => !((e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0)),
            EdgeRule::Exclusive => (e0 > 0.0 && e1 > 0.0 && e2 > 0.0) || (e0 < 0.0 && e1 < 0.0 && e2 < 0.0),
        };
        let det = e0 + e1 + e2;
        if !inside || det == 0.0 {
            return None;
        }
        a.z *= sz;
        b.z *= sz;
        c.z *= sz;
        let t_scaled = e0 * a.z + e1 * b.z + e2 * c.z;
        if det < 0.0 && (t_scaled >= t_min * det || t_scaled <= t_max * det) {
            return None;
        }
        if det > 0.0 && (t_scaled <= t_min * det || t_scaled >= t_max * det) {
            return None;
        }
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        // Conservative error bound on t (pbrt-v4): reject hits indistinguishable from t = 0.
        let max_zt = DVec3::new(a.z, b.z, c.z).abs().max_element();
        let max_xt = DVec3::new(a.x, b.x, c.x).abs().max_element();
        let max_yt = DVec3::new(a.y, b.y, c.y).abs().max_element();
        let delta_z = gamma(3) * max_zt;
        let delta_x = gamma(5) * (max_xt + max_zt);
        let delta_y = gamma(5) * (max_yt + max_zt);
        let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = DVec3::new(e0, e1, e2).abs().max_element();
        let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
        if !(t > delta_t) || !t.is_finite() {
            return None;
        }
        Some(TriangleHit { t, b: DVec3::new(e0, e1, e2) * inv_det })
    }
}

/// The hit point from barycentrics, with pbrt's error bound γ(7)·Σ|bᵢpᵢ|.
#[inline]
pub fn barycentric_point(b: DVec3, p0: DVec3, p1: DVec3, p2: DVec3) -> (DVec3, DVec3) {
    let (q0, q1, q2) = (b.x * p0, b.y * p1, b.z * p2);
    (q0 + q1 + q2, gamma(7) * (q0.abs() + q1.abs() + q2.abs()))
}

/// A triangle with vertices `p0, p1, p2`; its outward normal follows the winding:
/// `(p1 − p0) × (p2 − p0)`.
#[derive(Clone, Debug)]
pub struct Triangle {
    p: [DVec3; 3],
    normal: DVec3,
    material: Material,
}

impl Triangle {
    /// A triangle, or `None` when it is degenerate (zero area, collinear or repeated vertices,
    /// non-finite coordinates).
    pub fn new(p0: DVec3, p1: DVec3, p2: DVec3, material: Material) -> Option<Self> {
        let n = (p1 - p0).cross(p2 - p0);
        let scale = (p1 - p0).length() * (p2 - p0).length();
        if !(n.is_finite() && n.length() > 1e-12 * scale && scale > 0.0) {
            return None;
        }
        Some(Triangle { p: [p0, p1, p2], normal: n.normalize(), material })
    }
}

/// The `triangle` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "triangle",
    summary: "A triangle. Its outward normal follows the winding (p1 − p0) × (p2 − p0). As in the report, a ray exactly through an edge or vertex misses a lone triangle; use a mesh for shared edges.",
    params: &[
        ParamSpec::new("p0", ParamKind::Vec3, Default::Required, "first vertex"),
        ParamSpec::new("p1", ParamKind::Vec3, Default::Required, "second vertex"),
        ParamSpec::new("p2", ParamKind::Vec3, Default::Required, "third vertex"),
        MATERIAL_PARAM,
    ],
};

/// Builds a triangle from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let (p0, p1, p2) = (p.vec3("p0")?, p.vec3("p1")?, p.vec3("p2")?);
    let m = p.material("material")?;
    Triangle::new(p0, p1, p2, m)
        .map(|t| Box::new(t) as Box<dyn Geometry>)
        .ok_or_else(|| p.error("degenerate triangle: the vertices are collinear or repeated (zero area)"))
}

impl Intersectable for Triangle {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let [p0, p1, p2] = self.p;
        let h = intersect_triangle(ray, p0, p1, p2, t_min, t_max, EdgeRule::Exclusive)?;
        let (point, error) = barycentric_point(h.b, p0, p1, p2);
        Some(Hit { t: h.t, point, error, uv: DVec2::new(h.b.y, h.b.z), prim: 0, object: 0 })
    }
}

impl Geometry for Triangle {
    fn outward_normal(&self, _: &Hit) -> DVec3 {
        self.normal
    }
    fn material(&self) -> &Material {
        &self.material
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::from_points(self.p))
    }
}
