//! `polygon` and `quadrangle`: a flat convex polygon given by its vertices in order.
//!
//! The report builds a quadrangle from two triangles, which leaves a crack along the shared
//! diagonal when edge hits count as misses. raylab tests the polygon as one convex region instead:
//! plane hit, then the point must lie strictly inside every boundary edge. There is no internal
//! edge, so no crack; like a lone triangle, a ray exactly on the outline misses.

use super::plane::PlaneEquation;
use super::triangle::barycentric_point;
use raylab::geometry::samples::{Draw, Form, ShapeSample, ShapeSampler};
use raylab::geometry::sampling::uniform_triangle;
use raylab::geometry::testing::{ExactSurface, closest_on_segment};
use raylab::geometry::{Geometry, Hit, Intersectable, SurfaceDerivatives, SurfacePdf, SurfaceSample};
use raylab::glam::{DVec2, DVec3};
use raylab::math::float::{DEGENERACY_TOLERANCE, max_abs};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Aabb, LoadContext, PluginInfo, Ray};

/// Relative tolerance of the coplanarity check: every vertex must lie within this fraction of
/// the polygon's size from its plane.
pub const COPLANAR_TOLERANCE: f64 = 1e-9;

/// A planar, strictly convex polygon. Outward normal by the winding (counter-clockwise seen from
/// the outside).
#[derive(Clone, Debug)]
pub struct Polygon {
    vertices: Vec<DVec3>,
    /// Edge i's start `v[i]` and inward-pointing normal within the plane, `normal × (v[i+1] −
    /// v[i])`, four edges a pack ([`EdgePack`]).
    edges: Vec<EdgePack>,
    normal: DVec3,
    /// The plane through the first vertex with `normal`, its magnitudes computed once (the
    /// plane test `intersect_plane` makes, bit for bit).
    plane: PlaneEquation,
    /// The plane's right and up axes ([`super::uv::tangent_frame`]), and the vertices in them
    /// relative to the first, for texture coordinates.
    axes: (DVec3, DVec3),
    flat: Vec<DVec2>,
    /// Running totals of the areas of the fan's triangles `(v0, v[i+1], v[i+2])`: the last is the
    /// polygon's area. Surface samples choose a triangle by its area.
    fan: Vec<f64>,
    /// `1 / area`, the density of its surface samples.
    inv_area: f64,
}

/// Four edges of a polygon, structure of arrays: `v[axis][k]` is edge k's start, `n[axis][k]` its
/// inward normal within the plane. The last pack of a polygon is filled up with copies of its
/// first edge (a test repeated changes nothing).
#[derive(Clone, Debug)]
struct EdgePack {
    v: [[f64; 4]; 3],
    n: [[f64; 4]; 3],
}

impl EdgePack {
    /// Whether `p` lies strictly inside the four edges: `(p − v)·n > 0` for each, in
    /// `DVec3::dot`'s operations and order (the same decisions, bit for bit), every lane
    /// computed without a branch between them (the compiler keeps lanes side by side).
    #[inline(always)]
    fn inside(&self, p: DVec3) -> bool {
        let (v, n) = (&self.v, &self.n);
        let mut inside = true;
        for k in 0..4 {
            let d = (p.x - v[0][k]) * n[0][k] + (p.y - v[1][k]) * n[1][k] + (p.z - v[2][k]) * n[2][k];
            inside &= d > 0.0;
        }
        inside
    }
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
    /// The outline turns one way throughout but crosses itself (a star: it winds around twice).
    SelfCrossing,
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
            PolygonError::SelfCrossing => {
                write!(f, "the outline crosses itself (a star winds around twice); give the vertices in order around a convex shape")
            }
        }
    }
}

impl Polygon {
    /// A polygon through `vertices` in order, validated: planar, strictly convex, non-degenerate.
    pub fn new(vertices: Vec<DVec3>) -> Result<Self, PolygonError> {
        let n = vertices.len();
        if n < 3 {
            return Err(PolygonError::TooFew(n));
        }
        if !vertices.iter().all(|v| v.is_finite()) {
            return Err(PolygonError::NotFinite);
        }
        // Newell's method: robust normal of a planar polygon, relative to the first vertex (sums of
        // coordinates far from the origin would cost the normal their magnitude in accuracy).
        let mut normal = DVec3::ZERO;
        for i in 0..n {
            let (a, b) = (vertices[i] - vertices[0], vertices[(i + 1) % n] - vertices[0]);
            normal += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
        }
        let size = Aabb::from_points(vertices.iter().copied()).extent().max_element();
        if !(normal.length() > DEGENERACY_TOLERANCE * size * size) || !normal.is_finite() {
            return Err(PolygonError::Degenerate);
        }
        let normal = normal.normalize();
        let origin = vertices[0];
        for (i, v) in vertices.iter().enumerate() {
            if (v - origin).dot(normal).abs() > COPLANAR_TOLERANCE * size.max(f64::MIN_POSITIVE) {
                return Err(PolygonError::NotPlanar(i));
            }
        }
        // Strictly convex and simple: every turn is to the same side, and the turns add up to one
        // full turn. A closed outline turning one way throughout turns by a whole number of full
        // turns; a star (a pentagram) turns twice and crosses itself. O(n).
        let mut edge_normals = Vec::with_capacity(n);
        let mut turning = 0.0;
        for i in 0..n {
            let e = vertices[(i + 1) % n] - vertices[i];
            let next = vertices[(i + 2) % n] - vertices[(i + 1) % n];
            let sine = normal.dot(e.cross(next));
            if !(sine > DEGENERACY_TOLERANCE * e.length() * next.length()) {
                return Err(PolygonError::NotConvex((i + 1) % n));
            }
            turning += sine.atan2(e.dot(next));
            edge_normals.push(normal.cross(e));
        }
        // Each turn lies in (0, π), so the total is 2πk for a whole k ≥ 1; anything beyond one
        // and a half turns is two or more, whatever the rounding.
        let once_round = turning < 3.0 * std::f64::consts::PI; // false for NaN
        if !once_round {
            return Err(PolygonError::SelfCrossing);
        }
        // Every vertex strictly inside every edge's half-plane, with the tolerance relative to
        // its distance. Seen from an edge's start, the vertices of an outline that turns once one
        // way follow in angular order, so the smallest angle to an edge's line is at the vertex
        // after its end or the one before its start: two tests per edge, not n.
        for i in 0..n {
            let e = vertices[(i + 1) % n] - vertices[i];
            for j in [(i + 2) % n, (i + n - 1) % n] {
                let w = vertices[j] - vertices[i];
                if !(normal.dot(e.cross(w)) > DEGENERACY_TOLERANCE * e.length() * w.length()) {
                    return Err(PolygonError::SelfCrossing);
                }
            }
        }
        let axes = super::uv::tangent_frame(normal);
        let flat = vertices.iter().map(|v| DVec2::new((v - origin).dot(axes.0), (v - origin).dot(axes.1))).collect();
        let fan: Vec<f64> = (1..n - 1)
            .scan(0.0, |sum, i| {
                *sum += 0.5 * normal.dot((vertices[i] - vertices[0]).cross(vertices[i + 1] - vertices[0]));
                Some(*sum)
            })
            .collect();
        let plane = PlaneEquation::new(vertices[0], normal);
        let edges = (0..n.div_ceil(4))
            .map(|p| {
                let mut pack = EdgePack { v: [[0.0; 4]; 3], n: [[0.0; 4]; 3] };
                for k in 0..4 {
                    let i = if 4 * p + k < n { 4 * p + k } else { 0 };
                    for axis in 0..3 {
                        pack.v[axis][k] = vertices[i][axis];
                        pack.n[axis][k] = edge_normals[i][axis];
                    }
                }
                pack
            })
            .collect();
        let inv_area = fan.last().map_or(0.0, |a| 1.0 / a);
        Ok(Polygon { vertices, edges, normal, plane, axes, flat, fan, inv_area })
    }
}

/// The `polygon` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "polygon",
    summary: "A flat, strictly convex polygon through `vertices` in order (counter-clockwise seen from its outward side). Tested as one region: no internal edges, no cracks. A ray exactly on the outline misses.",
    params: &[ParamSpec::new(
        "vertices",
        ParamKind::Vec3List,
        ParamDefault::Required,
        "the corners, in order around the outline, at least 3, coplanar",
    )],
};

/// The `quadrangle` plugin's description.
pub const QUADRANGLE_INFO: PluginInfo = PluginInfo {
    name: "quadrangle",
    summary: "The report's quadrangle: a flat convex four-sided polygon p0 p1 p2 p3 (in order around the outline). No crack along the diagonal.",
    params: &[
        ParamSpec::new("p0", ParamKind::Vec3, ParamDefault::Required, "first corner"),
        ParamSpec::new("p1", ParamKind::Vec3, ParamDefault::Required, "second corner"),
        ParamSpec::new("p2", ParamKind::Vec3, ParamDefault::Required, "third corner (opposite p0)"),
        ParamSpec::new("p3", ParamKind::Vec3, ParamDefault::Required, "fourth corner"),
    ],
};

/// Builds a polygon from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let vertices = p.vec3_list("vertices")?;
    Polygon::new(vertices).map(|g| Box::new(g) as Box<dyn Geometry>).map_err(|e| p.error_at("vertices", e))
}

/// Builds a quadrangle from its parameters.
pub fn build_quadrangle(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let vertices = vec![p.vec3("p0")?, p.vec3("p1")?, p.vec3("p2")?, p.vec3("p3")?];
    Polygon::new(vertices).map(|g| Box::new(g) as Box<dyn Geometry>).map_err(|e| p.error(e.to_string()))
}

impl Polygon {
    /// Whether `point` (on the plane) lies strictly inside every edge: `(point − v[i])·n[i] > 0`.
    #[inline(always)]
    fn inside(&self, point: DVec3) -> bool {
        self.edges.iter().all(|e| e.inside(point))
    }
}

impl Intersectable for Polygon {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let (t, point) = self.plane.crossing(ray, t_min, t_max)?;
        if !self.inside(point) {
            return None;
        }
        Some(Hit { t, point, error: self.plane.error(point), uv: DVec2::ZERO, prim: 0, object: 0 })
    }
    /// [`Polygon::intersect`]'s tests, the hit written in place.
    fn intersect_into(&self, ray: &Ray, t_min: f64, t_max: f64, hit: &mut Hit) -> bool {
        let Some((t, point)) = self.plane.crossing(ray, t_min, t_max) else { return false };
        if !self.inside(point) {
            return false;
        }
        *hit = Hit { t, point, error: self.plane.error(point), uv: DVec2::ZERO, prim: 0, object: 0 };
        true
    }
    /// [`Polygon::intersect`]'s tests without the error bound.
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.plane.crossing(ray, t_min, t_max).is_some_and(|(_, point)| self.inside(point))
    }
    /// One plane.
    #[inline]
    fn is_flat(&self) -> bool {
        true
    }
    flat_leaving!();
}

impl Geometry for Polygon {
    fn outward_normal(&self, _: &Hit) -> DVec3 {
        self.normal
    }
    /// Four corners: bilinear, the corners in order at (0, 0), (1, 0), (1, 1), (0, 1); more or
    /// fewer: the bounding rectangle in the plane's axes onto [0, 1]² ([`super::uv`]).
    fn uv(&self, at: &Hit) -> DVec2 {
        let d = at.point - self.vertices[0];
        let p = DVec2::new(d.dot(self.axes.0), d.dot(self.axes.1));
        if let [a, b, c, e] = self.flat[..] {
            return super::uv::inverse_bilinear(p, [a, b, c, e]);
        }
        let (lo, hi) = self.flat.iter().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
        (p - lo) / (hi - lo).max(DVec2::splat(f64::MIN_POSITIVE))
    }
    /// Four corners: the bilinear map's partial derivatives; more or fewer: the rectangle's
    /// sides.
    fn derivatives(&self, at: &Hit) -> Option<SurfaceDerivatives> {
        let lift = |v: DVec2| v.x * self.axes.0 + v.y * self.axes.1;
        if let [a, b, c, e] = self.flat[..] {
            let uv = self.uv(at);
            let g = a - b + c - e;
            return Some(SurfaceDerivatives::flat(lift(b - a + g * uv.y), lift(e - a + g * uv.x)));
        }
        let (lo, hi) = self.flat.iter().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
        let size = hi - lo;
        Some(SurfaceDerivatives::flat(size.x * self.axes.0, size.y * self.axes.1))
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::from_points(self.vertices.iter().copied()))
    }
    /// Flat.
    fn is_convex(&self) -> bool {
        true
    }
    fn area(&self) -> Option<f64> {
        self.fan.last().copied()
    }
    /// Uniform by area: a triangle of the fan from the first vertex, chosen by its area (with
    /// `u.x`, reused within it), then a point of it.
    fn sample_surface(&self, reference: DVec3, u: DVec2) -> Option<SurfaceSample> {
        let area = self.area()?;
        let target = u.x * area;
        // The first triangle whose running total passes `target`, the last one past every total
        // (rounding): a quadrangle's two in one comparison.
        let last = self.fan.len() - 1;
        let i = if last == 1 { usize::from(self.fan[0] <= target) } else { self.fan[..last].partition_point(|&a| a <= target) };
        let below = if i == 0 { 0.0 } else { self.fan[i - 1] };
        let ux = ((target - below) / (self.fan[i] - below)).clamp(0.0, 1.0 - f64::EPSILON / 2.0);
        let b = uniform_triangle(DVec2::new(ux, u.y));
        let (p0, p1, p2) = (self.vertices[0], self.vertices[i + 1], self.vertices[i + 2]);
        let (point, error) = barycentric_point(DVec3::new(1.0 - b.x - b.y, b.x, b.y), p0, p1, p2);
        Some(SurfaceSample::new(reference, point, error, self.normal, SurfacePdf::Area(self.inv_area)))
    }
    fn surface_pdf(&self, _: DVec3, _: &Hit) -> SurfacePdf {
        SurfacePdf::Area(self.inv_area)
    }
    /// The plane of its vertices: they lie within [`COPLANAR_TOLERANCE`] of its size from it.
    fn plane(&self) -> Option<(DVec3, DVec3)> {
        Some((self.vertices[0], self.normal))
    }
}

// The shape harnesses' view of it (raylab::geometry::samples): its exact surface, written from
// the definition above and not from the intersection code, and random valid instances.

/// The exact convex polygon: signed distance to its closest point, positive on the winding side.
#[derive(Debug)]
pub struct ExactPolygon {
    /// Vertices of a strictly convex outline; the winding gives the outward side.
    pub v: Vec<DVec3>,
}

impl ExactPolygon {
    /// From two well-spread chords, so it is accurate even where neighbouring vertices are close.
    pub fn normal(&self) -> DVec3 {
        let k = self.v.len();
        (self.v[k / 2] - self.v[0]).cross(self.v[(3 * k) / 4] - self.v[k / 4]).normalize()
    }
    /// Mean of the vertices.
    pub fn centroid(&self) -> DVec3 {
        self.v.iter().sum::<DVec3>() / self.v.len() as f64
    }
    /// The edges, as vertex pairs in winding order.
    pub fn edges(&self) -> impl Iterator<Item = (DVec3, DVec3)> + '_ {
        (0..self.v.len()).map(|i| (self.v[i], self.v[(i + 1) % self.v.len()]))
    }
}

impl ExactSurface for ExactPolygon {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let n = self.normal();
        let plane = n.dot(p - self.v[0]);
        let inside = self.edges().all(|(a, b)| n.cross(b - a).dot(p - a) >= 0.0);
        let dist = if inside {
            plane.abs()
        } else {
            self.edges().map(|(a, b)| (p - closest_on_segment(p, a, b)).length()).fold(f64::INFINITY, f64::min)
        };
        dist.copysign(plane)
    }
    fn outward_normal(&self, _: DVec3) -> DVec3 {
        self.normal()
    }
}

/// Random quadrangles for the shape harnesses.
pub const QUADRANGLE_SAMPLERS: &[ShapeSampler] = &[ShapeSampler { name: "quadrangle", sample: |d, center, s| sample(d, center, s, 4) }];

/// Random convex polygons (3 to 8 vertices) for the shape harnesses.
pub const SAMPLERS: &[ShapeSampler] = &[ShapeSampler {
    name: "polygon",
    sample: |d, center, s| {
        let k = 3 + d.index(6);
        sample(d, center, s, k)
    },
}];

fn sample(d: &mut dyn Draw, center: DVec3, s: f64, k: usize) -> Option<ShapeSample> {
    let v = d.outline(center, s, k)?;
    let g = Polygon::new(v.clone()).ok()?;
    Some(ShapeSample {
        geometry: Box::new(g),
        magnitude: v.iter().map(|p| max_abs(*p)).fold(0.0, f64::max),
        exact: Box::new(ExactPolygon { v }),
        center,
        size: s,
        max_hits: 1,
        aspect: 1.0,
        curvature_radius: f64::INFINITY,
        form: Form::Flat,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::test_support::*;
    use proptest::prelude::*;
    use std::f64::consts::TAU;

    /// A random strictly convex polygon of 3 to 8 vertices: points of an ellipse, one per sector,
    /// in a random plane; also its centre, size and magnitude.
    fn polygon(sides: std::ops::RangeInclusive<usize>) -> impl Strategy<Value = (Polygon, ExactPolygon, DVec3, f64, f64)> {
        (scale(), cube(), unit(), 0.0..TAU, 0.1..2.0f64, 0.3..1.0f64, prop::collection::vec(0.0..1.0f64, sides)).prop_map(
            |(s, c, n, phi, size, aspect, us)| {
                let center = 5.0 * s * c;
                let (e1, e2) = (perpendicular(n, phi), n.cross(perpendicular(n, phi)));
                let k = us.len();
                let v: Vec<DVec3> = us
                    .iter()
                    .enumerate()
                    .map(|(j, u)| {
                        let a = TAU * (j as f64 + 0.1 + 0.8 * u) / k as f64;
                        center + s * size * (a.cos() * e1 + aspect * a.sin() * e2)
                    })
                    .collect();
                let mag = v.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max);
                let g = Polygon::new(v.clone()).expect("a strictly convex polygon");
                (g, ExactPolygon { v }, center, s * size, mag)
            },
        )
    }

    proptest! {
        #![proptest_config(config(CASES))]

        #[test]
        fn hits_are_exact_and_single((g, exact, center, size, mag) in polygon(3..=8), aim in aim(), win in windows()) {
            let ray = aim.ray(center, size);
            let tol = tolerance(mag, &ray);
            check_ray(&g, &ray, &tol, &exact, 1, &win)?;
        }

        #[test]
        fn a_ray_toward_an_inner_point_hits(
            (g, exact, _, size, mag) in polygon(3..=8), w in prop::collection::vec(0.02..1.0f64, 8), d in unit(), back in 0.1..4.0f64,
        ) {
            let w = &w[..exact.v.len()];
            let target = exact.v.iter().zip(w).map(|(v, w)| *w * *v).sum::<DVec3>() / w.iter().sum::<f64>();
            prop_assume!(d.dot(exact.normal()).abs() > 1e-3);
            let ray = Ray::new(target - back * size * d, d);
            let hits = check_ray(&g, &ray, &tolerance(mag, &ray), &exact, 1, &[])?;
            prop_assert_eq!(hits.len(), 1);
        }

        /// The packed edge test decides as `(p − v[i])·(normal × (v[i+1] − v[i])) > 0` on every
        /// edge, bit for bit, at points on the outline's lines (where rounding decides), inside
        /// and outside.
        #[test]
        fn packed_edges_decide_as_the_dot_products(
            (g, exact, _, size, _) in polygon(3..=8), i in 0usize..8, s in -0.5..1.5f64, off in prop::sample::select(vec![0.0, 1e-300, 1e-12, 1e-3]), w in unit(),
        ) {
            let v = &exact.v;
            let i = i % v.len();
            let p = v[i] + s * (v[(i + 1) % v.len()] - v[i]) + off * size * w;
            let expected = (0..v.len()).all(|k| (p - v[k]).dot(g.normal.cross(v[(k + 1) % v.len()] - v[k])) > 0.0);
            prop_assert_eq!(g.inside(p), expected);
        }

        /// No crack: rays through any point of any diagonal (an internal edge of the report's
        /// two-triangle quadrangle) hit.
        #[test]
        fn a_ray_through_a_diagonal_hits(
            (g, exact, _, size, mag) in polygon(4..=8), j in 2usize..7, s in 0.01..0.99f64, d in unit(), back in 0.1..4.0f64,
        ) {
            let j = 2 + j % (exact.v.len() - 3);
            let target = exact.v[0] + s * (exact.v[j] - exact.v[0]);
            prop_assume!(d.dot(exact.normal()).abs() > 1e-3);
            let ray = Ray::new(target - back * size * d, d);
            let hits = check_ray(&g, &ray, &tolerance(mag, &ray), &exact, 1, &[])?;
            prop_assert_eq!(hits.len(), 1);
        }

        #[test]
        fn a_ray_toward_an_outer_point_misses(
            (g, exact, _, size, _) in polygon(3..=8), i in 0usize..8, s in 0.0..=1.0f64, out in 0.01..0.5f64, d in unit(), back in 0.1..4.0f64,
        ) {
            let i = i % exact.v.len();
            let (a, b) = (exact.v[i], exact.v[(i + 1) % exact.v.len()]);
            let c = exact.centroid();
            let target = c + (1.0 + out) * (a + s * (b - a) - c);
            prop_assume!(d.dot(exact.normal()).abs() > 1e-2);
            let ray = Ray::new(target - back * size * d, d);
            prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none());
            prop_assert!(!g.occludes(&ray, 0.0, f64::INFINITY));
        }

        #[test]
        fn a_ray_pointing_away_misses((g, _, _, _, _) in polygon(3..=8), w in unit(), v in unit(), gap in 0.0..3.0f64) {
            let ray = away_ray(g.bounds().unwrap(), w, v, gap);
            prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none());
        }

        #[test]
        fn a_ray_starting_on_the_polygon_does_not_hit_it((g, exact, _, _, _) in polygon(3..=8), w in prop::collection::vec(0.02..1.0f64, 8), d in unit()) {
            let w = &w[..exact.v.len()];
            let on = exact.v.iter().zip(w).map(|(v, w)| *w * *v).sum::<DVec3>() / w.iter().sum::<f64>();
            // Onto the plane, to the rounding of its own coordinates.
            let n = exact.normal();
            let on = on - n.dot(on - exact.v[0]) * n;
            prop_assert!(g.intersect(&Ray::new(on, d), 0.0, f64::INFINITY).is_none());
        }
    }

    fn unit_square() -> Polygon {
        Polygon::new(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]).unwrap()
    }

    /// A dyadic convex pentagon in the plane z = 0.
    fn pentagon() -> Polygon {
        let v = [(0.0, 0.0), (2.0, 0.0), (3.0, 1.0), (1.5, 2.5), (-1.0, 1.5)];
        Polygon::new(v.iter().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect()).unwrap()
    }

    fn down(x: f64, y: f64) -> [Ray; 2] {
        [Ray::new(DVec3::new(x, y, 2.0), -DVec3::Z), Ray::new(DVec3::new(x, y, -2.0), DVec3::Z)]
    }

    #[test]
    fn no_crack_along_either_diagonal_of_a_quadrangle() {
        let g = unit_square();
        let dirs = [DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.3, -0.2, -1.0), DVec3::new(-0.7, 0.9, -0.4), DVec3::new(1.0, 1.0, -0.01)];
        for dir in dirs {
            for i in 1..400 {
                let s = i as f64 / 400.0;
                for off in [0.0, 1e-17, -1e-17, 1e-12, -1e-12] {
                    for target in [DVec3::new(s + off, s, 0.0), DVec3::new(s + off, 1.0 - s, 0.0)] {
                        let ray = Ray::new(target - 3.0 * dir.normalize(), dir);
                        let h = g.intersect(&ray, 0.0, f64::INFINITY);
                        assert!(h.is_some_and(|h| (h.t - 3.0).abs() < 1e-9), "crack at {target} for {ray:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn rays_exactly_on_the_outline_miss_and_just_inside_hit() {
        let g = unit_square();
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.0), (1.0, 0.25), (0.75, 1.0), (0.0, 0.5)] {
            for ray in down(x, y) {
                assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none(), "outline point ({x}, {y}) hit");
            }
        }
        for (x, y) in [(1e-300, 0.5), (0.5, 1.0 - f64::EPSILON / 2.0), (0.5, 0.5)] {
            for ray in down(x, y) {
                assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_some(), "inner point ({x}, {y}) missed");
            }
        }
        for (x, y) in [(-1e-300, 0.5), (0.5, 1.0 + f64::EPSILON), (1.5, 0.5), (2.0, 2.0)] {
            for ray in down(x, y) {
                assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none(), "outer point ({x}, {y}) hit");
            }
        }
    }

    #[test]
    fn a_polygon_outline_misses_and_its_inside_has_no_crack() {
        let g = pentagon();
        let v = [(0.0, 0.0), (2.0, 0.0), (3.0, 1.0), (1.5, 2.5), (-1.0, 1.5)];
        for i in 0..5 {
            let ((ax, ay), (bx, by)) = (v[i], v[(i + 1) % 5]);
            for s in [0.0, 0.25, 0.5, 0.75] {
                for ray in down(ax + s * (bx - ax), ay + s * (by - ay)) {
                    assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none(), "outline point of edge {i} at {s} hit");
                }
            }
        }
        // Every diagonal from vertex 0, densely: no crack where a fan of triangles would have one.
        for (j, &(x, y)) in v.iter().enumerate().skip(2).take(2) {
            for i in 1..256 {
                let s = i as f64 / 256.0;
                for ray in down(s * x, s * y) {
                    assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_some(), "crack on diagonal 0-{j} at {s}");
                }
            }
        }
    }

    /// Found by the `intersect` fuzz target: a star outline turns the same way at every vertex and
    /// was accepted as convex; only its inner pentagon was hit.
    #[test]
    fn bad_case_a_pentagram_was_accepted_as_convex() {
        let star: Vec<DVec3> =
            [0.0f64, 144.0, 288.0, 72.0, 216.0].iter().map(|a| DVec3::new(a.to_radians().cos(), a.to_radians().sin(), 0.0)).collect();
        assert_eq!(Polygon::new(star).err(), Some(PolygonError::SelfCrossing));
    }

    #[test]
    fn invalid_outlines_are_refused() {
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        assert_eq!(Polygon::new(vec![p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0)]).unwrap_err(), PolygonError::TooFew(2));
        assert_eq!(Polygon::new(vec![p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(f64::NAN, 0.0, 0.0)]).unwrap_err(), PolygonError::NotFinite);
        assert_eq!(Polygon::new(vec![p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(2.0, 0.0, 0.0)]).unwrap_err(), PolygonError::Degenerate);
        let skew = vec![p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(1.0, 1.0, 0.5), p(0.0, 1.0, 0.0)];
        assert!(matches!(Polygon::new(skew).unwrap_err(), PolygonError::NotPlanar(_)));
        let dart = vec![p(0.0, 0.0, 0.0), p(2.0, 0.0, 0.0), p(1.0, 0.5, 0.0), p(1.0, 2.0, 0.0)];
        assert!(matches!(Polygon::new(dart).unwrap_err(), PolygonError::NotConvex(_)));
    }

    /// The validity check is linear in the vertex count (it was quadratic: 38 s at 10⁵ vertices):
    /// a regular 10⁶-gon is accepted, and the same outline wound twice is refused.
    #[test]
    fn a_million_vertex_polygon_is_checked_and_one_winding_twice_is_refused() {
        let n = 1_000_000;
        let ring = |k: usize, turns: usize| {
            (0..k).map(move |i| {
                let a = TAU * (turns * i) as f64 / k as f64;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
        };
        let g = Polygon::new(ring(n, 1).collect()).unwrap();
        assert_eq!(g.vertices.len(), n);
        assert!(g.intersect(&Ray::new(DVec3::new(0.5, 0.5, 1.0), -DVec3::Z), 0.0, f64::INFINITY).is_some());
        // Every vertex twice, in order: each turn is convex, the total is two full turns.
        let twice: Vec<DVec3> = ring(n / 2, 1).chain(ring(n / 2, 1)).collect();
        assert_eq!(Polygon::new(twice).err(), Some(PolygonError::SelfCrossing));
        // A heptagram {7/3}: turning the same way, three times around.
        assert_eq!(Polygon::new(ring(7, 3).collect()).err(), Some(PolygonError::SelfCrossing));
    }

    // Regressions: literal cases the properties found.

    /// Newell's sums of coordinates far from the origin tilted the normal by 5e-15, so a ray
    /// starting on the polygon found it again 3e-14 away.
    #[test]
    fn bad_case_a_far_polygon_had_a_tilted_normal() {
        let v = vec![
            DVec3::new(5.725267332431449, -5.346158519809949, 1.0156084590696055),
            DVec3::new(3.797871597017973, -4.011467856951285, -1.2472884473455568),
            DVec3::new(5.457948279667441, -5.614629969938661, 1.2399140012659242),
        ];
        let g = Polygon::new(v.clone()).unwrap();
        let exact = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        assert!((g.normal - exact).length() < 1e-15, "{} vs {exact}", g.normal);
        let w = [0.02, 0.8375766139301917, 0.02];
        let on = v.iter().zip(w).map(|(v, w)| w * *v).sum::<DVec3>() / w.iter().sum::<f64>();
        let on = on - exact.dot(on - v[0]) * exact;
        let ray = Ray::new(on, DVec3::new(-0.9812681386666113, 0.19264693103645433, 0.0));
        assert_eq!(g.intersect(&ray, 0.0, f64::INFINITY), None);
    }
}
