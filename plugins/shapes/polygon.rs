//! `polygon` and `quadrangle`: a flat convex polygon given by its vertices in order.
//!
//! The report builds a quadrangle from two triangles, which leaves a crack along the shared
//! diagonal when edge hits count as misses. raylab tests the polygon as one convex region instead:
//! plane hit, then the point must lie strictly inside every boundary edge. There is no internal
//! edge, so no crack; like a lone triangle, a ray exactly on the outline misses.

use super::plane::intersect_plane;
use raylab::error::Result;
use raylab::geometry::{Geometry, Hit, Intersectable};
use raylab::glam::{DVec2, DVec3};
use raylab::params::{Default, MATERIAL_PARAM, ParamKind, ParamSpec, Params};
use raylab::{Aabb, LoadContext, Material, PluginInfo, Ray};

/// Relative tolerance of the coplanarity check: every vertex must lie within this fraction of
/// the polygon's size from its plane.
pub const COPLANAR_TOLERANCE: f64 = 1e-9;

/// A planar, strictly convex polygon. Outward normal by the winding (counter-clockwise seen from
/// the outside).
#[derive(Clone, Debug)]
pub struct Polygon {
    vertices: Vec<DVec3>,
    /// Edge i's inward-pointing normal within the plane: `normal × (v[i+1] − v[i])`.
    edge_normals: Vec<DVec3>,
    normal: DVec3,
    material: Material,
}

/// Why vertices do not make a valid polygon.
#[derive(Clone, Debug, PartialEq)]
pub enum PolygonError {
    /// Fewer than three vertices.
    TooFew(usize),
    /// A vertex is not finite.
    NotFinite,
    /// The vertices enclose no area (collinear or repeated).
    Degenerate,
    /// A vertex lies off the plane of the others.
    NotPlanar(usize),
    /// The outline turns the wrong way, or repeats a vertex, at this vertex.
    NotConvex(usize),
}

impl std::fmt::Display for PolygonError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PolygonError::TooFew(n) => write!(f, "a polygon needs at least 3 vertices, found {n}"),
            PolygonError::NotFinite => write!(f, "vertices must be finite"),
            PolygonError::Degenerate => write!(f, "degenerate polygon: the vertices enclose no area (collinear or repeated)"),
            PolygonError::NotPlanar(i) => write!(f, "vertex {i} is not in the plane of the others; split the shape into triangles"),
            PolygonError::NotConvex(i) => write!(
                f,
                "the outline is not strictly convex at vertex {i} (or repeats it); give the vertices in order around a convex shape"
            ),
        }
    }
}

impl Polygon {
    /// A polygon through `vertices` in order, validated: planar, strictly convex, non-degenerate.
    pub fn new(vertices: Vec<DVec3>, material: Material) -> Result<Self, PolygonError> {
        let n = vertices.len();
        if n < 3 {
            return Err(PolygonError::TooFew(n));
        }
        if !vertices.iter().all(|v| v.is_finite()) {
            return Err(PolygonError::NotFinite);
        }
        // Newell's method: robust normal of a planar polygon.
        let mut normal = DVec3::ZERO;
        for i in 0..n {
            let (a, b) = (vertices[i], vertices[(i + 1) % n]);
            normal += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
        }
        let size = Aabb::from_points(vertices.iter().copied()).extent().max_element();
        if !(normal.length() > 1e-12 * size * size) || !normal.is_finite() {
            return Err(PolygonError::Degenerate);
        }
        let normal = normal.normalize();
        let origin = vertices[0];
        for (i, v) in vertices.iter().enumerate() {
            if (v - origin).dot(normal).abs() > COPLANAR_TOLERANCE * size.max(f64::MIN_POSITIVE) {
                return Err(PolygonError::NotPlanar(i));
            }
        }
        let mut edge_normals = Vec::with_capacity(n);
        for i in 0..n {
            let e = vertices[(i + 1) % n] - vertices[i];
            let next = vertices[(i + 2) % n] - vertices[(i + 1) % n];
            if !(normal.dot(e.cross(next)) > 1e-12 * e.length() * next.length()) {
                return Err(PolygonError::NotConvex((i + 1) % n));
            }
            edge_normals.push(normal.cross(e));
        }
        Ok(Polygon { vertices, edge_normals, normal, material })
    }
}

/// The `polygon` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "polygon",
    summary: "A flat, strictly convex polygon through `vertices` in order (counter-clockwise seen from its outward side). Tested as one region: no internal edges, no cracks. A ray exactly on the outline misses.",
    params: &[
        ParamSpec::new(
            "vertices",
            ParamKind::Vec3List,
            Default::Required,
            "the corners, in order around the outline, at least 3, coplanar",
        ),
        MATERIAL_PARAM,
    ],
};

/// The `quadrangle` plugin's description.
pub const QUADRANGLE_INFO: PluginInfo = PluginInfo {
    name: "quadrangle",
    summary: "The report's quadrangle: a flat convex four-sided polygon p0 p1 p2 p3 (in order around the outline). No crack along the diagonal.",
    params: &[
        ParamSpec::new("p0", ParamKind::Vec3, Default::Required, "first corner"),
        ParamSpec::new("p1", ParamKind::Vec3, Default::Required, "second corner"),
        ParamSpec::new("p2", ParamKind::Vec3, Default::Required, "third corner (opposite p0)"),
        ParamSpec::new("p3", ParamKind::Vec3, Default::Required, "fourth corner"),
        MATERIAL_PARAM,
    ],
};

/// Builds a polygon from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let vertices = p.vec3_list("vertices")?;
    let m = p.material("material")?;
    Polygon::new(vertices, m).map(|g| Box::new(g) as Box<dyn Geometry>).map_err(|e| p.error_at("vertices", e))
}

/// Builds a quadrangle from its parameters.
pub fn build_quadrangle(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let vertices = vec![p.vec3("p0")?, p.vec3("p1")?, p.vec3("p2")?, p.vec3("p3")?];
    let m = p.material("material")?;
    Polygon::new(vertices, m).map(|g| Box::new(g) as Box<dyn Geometry>).map_err(|e| p.error(e.to_string()))
}

impl Intersectable for Polygon {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let (t, point, error) = intersect_plane(ray, self.vertices[0], self.normal, t_min, t_max)?;
        for (v, en) in self.vertices.iter().zip(&self.edge_normals) {
            if !((point - *v).dot(*en) > 0.0) {
                return None;
            }
        }
        Some(Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 })
    }
}

impl Geometry for Polygon {
    fn outward_normal(&self, _: &Hit) -> DVec3 {
        self.normal
    }
    fn material(&self) -> &Material {
        &self.material
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::from_points(self.vertices.iter().copied()))
    }
}
