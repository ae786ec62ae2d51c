//! `triangle`: a single triangle given by three vertices.
//!
//! The intersection is the watertight test of Woop, Benthin & Wald (JCGT 2013) with pbrt-v4's
//! conservative bound on `t`. By default a triangle follows the report: a ray through an edge or
//! a vertex does **not** hit it (edge functions must be strictly non-zero). That rule is right for
//! a lone triangle and wrong for triangles that share edges: two such triangles leave a crack
//! along the edge. `edges = "inclusive"` ([`EdgeRule::Inclusive`], what meshes use) counts edge
//! hits, and the test's consistent edge functions then make shared edges watertight.

use raylab::geometry::samples::{Draw, Form, ShapeSample, ShapeSampler};
use raylab::geometry::sampling::uniform_triangle;
use raylab::geometry::testing::{ExactSurface, closest_on_segment};
use raylab::geometry::{Geometry, Hit, Intersectable, SurfaceDerivatives, SurfacePdf, SurfaceSample};
use raylab::glam::{DVec2, DVec3};
use raylab::math::float::{DEGENERACY_TOLERANCE, gamma, max_abs, on_surface_slack, triangle_normal};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Aabb, LoadContext, PluginInfo, Ray};

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
/// `t` is accepted only when it exceeds its own rounding-error bound: the hit is certain for this
/// exact origin. An origin computed on the triangle, with rounding, can still lie just in front of
/// it; [`Triangle`] therefore also rejects hits within [`on_surface_slack`] of the origin.
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

    /// The axes permuted so the ray's largest direction component is the last: `[kx, ky, kz]`.
    #[inline]
    pub fn axes(&self) -> [usize; 3] {
        self.k
    }

    /// The shear onto +z in permuted axes: (−dx/dz, −dy/dz, 1/dz).
    #[inline]
    pub fn shear(&self) -> [f64; 3] {
        self.shear
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
        // The scaled tests above can pass a t that rounds onto t_min or t_max.
        if !(t > t_min && t < t_max) {
            return None;
        }
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
    edges: EdgeRule,
}

impl Triangle {
    /// A triangle, or `None` when it is degenerate (zero area, collinear or repeated vertices,
    /// non-finite coordinates).
    pub fn new(p0: DVec3, p1: DVec3, p2: DVec3) -> Option<Self> {
        Self::with_edges(p0, p1, p2, EdgeRule::Exclusive)
    }

    /// A triangle with the given edge rule, or `None` when it is degenerate.
    pub fn with_edges(p0: DVec3, p1: DVec3, p2: DVec3, edges: EdgeRule) -> Option<Self> {
        let (n, scale) = triangle_normal([p0, p1, p2]);
        if !(n.is_finite() && n.length() > DEGENERACY_TOLERANCE * scale && scale > 0.0) {
            return None;
        }
        Some(Triangle { p: [p0, p1, p2], normal: n.normalize(), edges })
    }
}

/// The `triangle` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "triangle",
    summary: "A triangle. Its outward normal follows the winding (p1 − p0) × (p2 − p0). As in the report, a ray exactly through an edge or vertex misses it, unless edges = \"inclusive\" (use that for triangles sharing edges: no crack).",
    params: &[
        ParamSpec::new("p0", ParamKind::Vec3, ParamDefault::Required, "first vertex"),
        ParamSpec::new("p1", ParamKind::Vec3, ParamDefault::Required, "second vertex"),
        ParamSpec::new("p2", ParamKind::Vec3, ParamDefault::Required, "third vertex"),
        ParamSpec::new(
            "edges",
            ParamKind::Str,
            ParamDefault::Str("exclusive"),
            "\"exclusive\": an edge or vertex hit is a miss (the report); \"inclusive\": it is a hit (watertight between triangles)",
        ),
    ],
};

/// Builds a triangle from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let (p0, p1, p2) = (p.vec3("p0")?, p.vec3("p1")?, p.vec3("p2")?);
    let edges = if p.choice("edges", &["exclusive", "inclusive"])? == "inclusive" { EdgeRule::Inclusive } else { EdgeRule::Exclusive };
    Triangle::with_edges(p0, p1, p2, edges)
        .map(|t| Box::new(t) as Box<dyn Geometry>)
        .ok_or_else(|| p.error("degenerate triangle: the vertices are collinear or repeated (zero area)"))
}

impl Intersectable for Triangle {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let [p0, p1, p2] = self.p;
        let h = intersect_triangle(ray, p0, p1, p2, t_min, t_max, self.edges)?;
        // An origin within rounding of the triangle's plane is on it: no hit at t ≈ 0.
        if h.t * self.normal.dot(ray.dir).abs() <= on_surface_slack(ray.origin, p0) {
            return None;
        }
        let (point, error) = barycentric_point(h.b, p0, p1, p2);
        Some(Hit { t: h.t, point, error, uv: DVec2::new(h.b.y, h.b.z), prim: 0, object: 0 })
    }
    flat_leaving!();
    /// One plane.
    #[inline]
    fn is_flat(&self) -> bool {
        true
    }
}

impl Geometry for Triangle {
    fn outward_normal(&self, _: &Hit) -> DVec3 {
        self.normal
    }
    /// Barycentric: `u` toward `p1`, `v` toward `p2`.
    fn derivatives(&self, _: &Hit) -> Option<SurfaceDerivatives> {
        let [p0, p1, p2] = self.p;
        Some(SurfaceDerivatives::flat(p1 - p0, p2 - p0))
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::from_points(self.p))
    }
    /// Flat.
    fn is_convex(&self) -> bool {
        true
    }
    fn area(&self) -> Option<f64> {
        let [p0, p1, p2] = self.p;
        Some(0.5 * (p1 - p0).cross(p2 - p0).length())
    }
    /// Uniform by area.
    fn sample_surface(&self, reference: DVec3, u: DVec2) -> Option<SurfaceSample> {
        let [p0, p1, p2] = self.p;
        let b = uniform_triangle(u);
        let (point, error) = barycentric_point(DVec3::new(1.0 - b.x - b.y, b.x, b.y), p0, p1, p2);
        let mut s = SurfaceSample::new(reference, point, error, self.normal, SurfacePdf::Area(1.0 / self.area()?));
        s.hit.uv = b;
        Some(s)
    }
    fn surface_pdf(&self, _: DVec3, _: &Hit) -> SurfacePdf {
        SurfacePdf::Area(self.area().map_or(0.0, |a| 1.0 / a))
    }
    /// The plane through its vertices (exactly, up to rounding).
    fn plane(&self) -> Option<(DVec3, DVec3)> {
        Some((self.p[0], self.normal))
    }
}

// The shape harnesses' view of it (raylab::geometry::samples): its exact surface, written from
// the definition above and not from the intersection code, and random valid instances.

/// The exact triangle: signed distance to the closest point, positive on the winding side.
#[derive(Debug)]
pub struct ExactTriangle {
    /// Vertices; the winding gives the outward side.
    pub p: [DVec3; 3],
}

impl ExactTriangle {
    /// Unit normal of the winding.
    pub fn normal(&self) -> DVec3 {
        triangle_normal(self.p).0.normalize()
    }
    /// Barycentric coordinates of `p`'s projection onto the plane.
    pub fn barycentric(&self, p: DVec3) -> DVec3 {
        let [a, b, c] = self.p;
        let n = triangle_normal(self.p).0;
        let area = |x: DVec3, y: DVec3, z: DVec3| (y - x).cross(z - x).dot(n) / n.length_squared();
        DVec3::new(area(p, b, c), area(a, p, c), area(a, b, p))
    }
}

impl ExactSurface for ExactTriangle {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let [a, b, c] = self.p;
        let n = self.normal();
        // From the nearest vertex: the plane's offset is then as accurate as the normal allows.
        let q = self.p.into_iter().min_by(|x, y| (p - *x).length_squared().total_cmp(&(p - *y).length_squared())).unwrap_or(a);
        let plane = n.dot(p - q);
        let inside = self.barycentric(p).min_element() >= 0.0;
        let dist = if inside {
            plane.abs()
        } else {
            [(a, b), (b, c), (c, a)].iter().map(|&(x, y)| (p - closest_on_segment(p, x, y)).length()).fold(f64::INFINITY, f64::min)
        };
        dist.copysign(plane)
    }
    fn outward_normal(&self, _: DVec3) -> DVec3 {
        self.normal()
    }
}

/// Random triangles for the shape harnesses, with each edge rule.
pub const SAMPLERS: &[ShapeSampler] = &[
    ShapeSampler { name: "triangle", sample: |d, center, s| sample(d, center, s, EdgeRule::Exclusive) },
    ShapeSampler { name: "inclusive triangle", sample: |d, center, s| sample(d, center, s, EdgeRule::Inclusive) },
];

/// Three vertices anywhere within `s` of `center`: slivers too, whose hits are only as accurate
/// as their shape allows (the edge functions' rounding over the tiny area: `aspect` below).
fn sample(d: &mut dyn Draw, center: DVec3, s: f64, rule: EdgeRule) -> Option<ShapeSample> {
    let p = [center + d.offset(s), center + d.offset(s), center + d.offset(s)];
    let g = Triangle::with_edges(p[0], p[1], p[2], rule)?;
    let longest = (0..3).map(|i| (p[(i + 1) % 3] - p[i]).length_squared()).fold(0.0, f64::max);
    Some(ShapeSample {
        geometry: Box::new(g),
        exact: Box::new(ExactTriangle { p }),
        center,
        size: s,
        magnitude: p.iter().map(|v| max_abs(*v)).fold(0.0, f64::max),
        max_hits: 1,
        aspect: triangle_normal(p).0.length() / longest,
        curvature_radius: f64::INFINITY,
        form: Form::Flat,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::test_support::*;
    use proptest::prelude::*;
    use raylab::geometry::testing::{Tolerance, check_hits_ascending};

    /// A random triangle of reasonable shape (no sliver: every angle above ~3°).
    fn triangle() -> impl Strategy<Value = (Triangle, ExactTriangle, DVec3, f64, f64)> {
        (scale(), cube(), cube(), cube(), cube(), 0.1..2.0f64)
            .prop_map(|(s, c, a, b, d, size)| {
                let center = 5.0 * s * c;
                let p = [center + s * size * a, center + s * size * b, center + s * size * d];
                (p, center, s * size)
            })
            .prop_filter("sliver or degenerate", |(p, _, _)| {
                let [a, b, c] = *p;
                let n = (b - a).cross(c - a).length();
                let longest = (b - a).length().max((c - b).length()).max((a - c).length());
                n > 0.05 * longest * longest
            })
            .prop_map(|(p, center, size)| {
                let g = Triangle::new(p[0], p[1], p[2]).expect("a well-shaped triangle");
                let mag = p.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
                (g, ExactTriangle { p }, center, size, mag)
            })
    }

    /// A point with barycentric weights `w` (normalised) on the triangle.
    fn at(p: [DVec3; 3], w: DVec3) -> DVec3 {
        let w = w / w.element_sum();
        w.x * p[0] + w.y * p[1] + w.z * p[2]
    }

    proptest! {
        #![proptest_config(config(CASES))]

        #[test]
        fn hits_are_exact_and_single((g, exact, center, size, mag) in triangle(), aim in aim(), win in windows()) {
            let ray = aim.ray(center, size);
            let tol = tolerance(mag, &ray);
            check_ray(&g, &ray, &tol, &exact, 1, &win)?;
        }

        #[test]
        fn a_ray_toward_an_inner_point_hits_it(
            (g, exact, _, size, mag) in triangle(), w in prop::array::uniform3(0.02..1.0f64), d in unit(), back in 0.1..4.0f64,
        ) {
            let target = at(exact.p, DVec3::from_array(w));
            prop_assume!(d.dot(exact.normal()).abs() > 1e-3);
            let ray = Ray::new(target - back * size * d, d);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 1, &[])?;
            prop_assert_eq!(hits.len(), 1);
            prop_assert!((hits[0].point - target).length() <= tol.distance(hits[0].t, target) / 1e-3);
        }

        #[test]
        fn a_ray_toward_an_outer_point_misses(
            (g, exact, _, size, _) in triangle(), w in prop::array::uniform3(0.0..1.0f64), which in 0..3usize,
            out in 0.01..1.0f64, d in unit(), back in 0.1..4.0f64,
        ) {
            // A point beyond the edge opposite vertex `which`: that barycentric weight negative.
            let mut w = DVec3::from_array(w);
            w[which] = 0.0;
            prop_assume!(w.element_sum() > 1e-3);
            let mut outer = w * ((1.0 + out) / w.element_sum());
            outer[which] = -out;
            let target = outer.x * exact.p[0] + outer.y * exact.p[1] + outer.z * exact.p[2];
            prop_assume!(d.dot(exact.normal()).abs() > 1e-2);
            let ray = Ray::new(target - back * size * d, d);
            prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none());
        }

        #[test]
        fn a_ray_pointing_away_misses((g, _, _, _, _) in triangle(), w in unit(), v in unit(), gap in 0.0..3.0f64) {
            let ray = away_ray(g.bounds().unwrap(), w, v, gap);
            prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none());
            prop_assert!(!g.occludes(&ray, 0.0, f64::INFINITY));
        }

        #[test]
        fn a_ray_starting_on_the_triangle_does_not_hit_it((g, exact, _, _, _) in triangle(), w in prop::array::uniform3(0.02..1.0f64), d in unit()) {
            // A point of the triangle, onto its plane to the rounding of its own coordinates.
            let (on, n) = (at(exact.p, DVec3::from_array(w)), exact.normal());
            let ray = Ray::new(on - n.dot(on - exact.p[0]) * n, d);
            prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none());
        }

        /// Watertightness: a ray through any point of an edge shared by two triangles hits one of
        /// them, with [`EdgeRule::Inclusive`], whatever the triangles' placement.
        #[test]
        fn a_shared_edge_leaves_no_gap(
            (_, exact, _, size, _) in triangle(), apex in cube(), s in 0.01..0.99f64, d in unit(), back in 0.1..4.0f64,
        ) {
            let [a, b, c] = exact.p;
            // The second triangle b a e shares edge a b, with its apex e across it from c.
            let n = exact.normal();
            let across = (c - closest_on_segment(c, a, b)).normalize();
            let e = closest_on_segment(c, a, b) - size * (0.2 + apex.x.abs()) * across + 0.5 * size * apex.y * (b - a).normalize() + 0.3 * size * apex.z * n;
            let target = a + s * (b - a);
            prop_assume!(d.dot(n).abs() > 1e-3);
            // Seen along d, c and e must lie on opposite sides of the edge (else it is a silhouette).
            let side = (b - a).cross(d);
            prop_assume!(side.dot(c - a) * side.dot(e - a) < 0.0);
            let ray = Ray::new(target - back * size * d, d);
            let first = intersect_triangle(&ray, a, b, c, 0.0, f64::INFINITY, EdgeRule::Inclusive);
            let second = intersect_triangle(&ray, b, a, e, 0.0, f64::INFINITY, EdgeRule::Inclusive);
            prop_assert!(first.is_some() || second.is_some(), "ray {:?} passes between the triangles", ray);
        }
    }

    fn unit_triangle() -> Triangle {
        Triangle::new(DVec3::ZERO, DVec3::X, DVec3::Y).unwrap()
    }

    /// Rays along each axis, both ways, onto the points `(x, y)` of the triangle (0,0,0) (1,0,0)
    /// (0,1,0) turned into each coordinate plane: every coordinate dyadic, so each ray meets the
    /// point exactly.
    fn axis_rays(x: f64, y: f64) -> Vec<(Ray, [DVec3; 3])> {
        let mut out = Vec::new();
        for k in 0..3 {
            let rot = |v: DVec3| DVec3::new(v[(3 - k) % 3], v[(4 - k) % 3], v[(5 - k) % 3]);
            let tri = [rot(DVec3::ZERO), rot(DVec3::X), rot(DVec3::Y)];
            for z in [4.0, -4.0] {
                out.push((Ray::new(rot(DVec3::new(x, y, z)), rot(DVec3::new(0.0, 0.0, -z))), tri));
            }
        }
        out
    }

    const VERTICES: [(f64, f64); 3] = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)];
    const EDGE_POINTS: [(f64, f64); 6] = [(0.5, 0.0), (0.125, 0.0), (0.0, 0.25), (0.0, 0.875), (0.5, 0.5), (0.25, 0.75)];

    #[test]
    fn a_lone_triangle_misses_rays_through_its_edges_and_vertices() {
        for &(x, y) in VERTICES.iter().chain(&EDGE_POINTS) {
            for (ray, [a, b, c]) in axis_rays(x, y) {
                let g = Triangle::new(a, b, c).unwrap();
                assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none(), "({x}, {y}) hit by {ray:?}");
                assert!(!g.occludes(&ray, 0.0, f64::INFINITY));
            }
        }
    }

    #[test]
    fn the_inclusive_rule_counts_edges_and_vertices() {
        for &(x, y) in VERTICES.iter().chain(&EDGE_POINTS).chain(&[(0.25, 0.25)]) {
            for (ray, [a, b, c]) in axis_rays(x, y) {
                let h = intersect_triangle(&ray, a, b, c, 0.0, f64::INFINITY, EdgeRule::Inclusive);
                assert_eq!(h.map(|h| h.t), Some(4.0), "({x}, {y}) missed by {ray:?}");
                let g = Triangle::with_edges(a, b, c, EdgeRule::Inclusive).unwrap();
                assert_eq!(g.intersect(&ray, 0.0, f64::INFINITY).map(|h| h.t), Some(4.0));
            }
        }
    }

    #[test]
    fn an_inner_point_hits_with_exact_barycentrics() {
        let g = unit_triangle();
        let ray = Ray::new(DVec3::new(0.25, 0.5, 2.0), -DVec3::Z);
        let h = g.intersect(&ray, 0.0, f64::INFINITY).unwrap();
        assert_eq!((h.t, h.point, h.uv), (2.0, DVec3::new(0.25, 0.5, 0.0), DVec2::new(0.25, 0.5)));
        assert_eq!(g.normal(&h, ray.dir), DVec3::Z);
        assert_eq!(g.normal(&h, -ray.dir), -DVec3::Z);
    }

    #[test]
    fn two_triangles_sharing_an_edge_leave_no_gap_on_a_dense_grid() {
        // Triangles (0,0,0) (1,0,0) (0,1,0) and (1,0,0) (1,1,0) (0,1,0) share the diagonal x + y = 1.
        let (a, b, c, d) = (DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0));
        let dirs = [DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.3, -0.2, -1.0), DVec3::new(-0.7, 0.9, -0.4), DVec3::new(1.0, 1.0, 0.01)];
        let mut rays = 0;
        for dir in dirs {
            for i in 0..=200 {
                let s = i as f64 / 200.0 * 0.98 + 0.01;
                for off in [0.0, 1e-17, -1e-17, 1e-12, -1e-12, 1e-6, -1e-6] {
                    let target = DVec3::new(s + off, 1.0 - s, 0.0);
                    let ray = Ray::new(target - 3.0 * dir.normalize(), dir);
                    let first = intersect_triangle(&ray, a, b, c, 0.0, f64::INFINITY, EdgeRule::Inclusive);
                    let second = intersect_triangle(&ray, b, d, c, 0.0, f64::INFINITY, EdgeRule::Inclusive);
                    assert!(first.is_some() || second.is_some(), "ray {ray:?} passes between the triangles");
                    for h in [first, second].into_iter().flatten() {
                        assert!((h.t - 3.0).abs() < 1e-9, "t = {}", h.t);
                    }
                    rays += 1;
                }
            }
        }
        assert_eq!(rays, 4 * 201 * 7);
    }

    #[test]
    fn t_window_is_respected() {
        let g = unit_triangle();
        let ray = Ray::new(DVec3::new(0.25, 0.25, 2.0), -DVec3::Z);
        assert!(g.intersect(&ray, 0.0, 2.0).is_none());
        assert!(g.intersect(&ray, 2.0, 3.0).is_none());
        assert_eq!(g.intersect(&ray, 1.0, 2.5).map(|h| h.t), Some(2.0));
        let tol = Tolerance::for_scale(2.0);
        let hits = check_hits_ascending(&g, &ray, &tol, &ExactTriangle { p: [DVec3::ZERO, DVec3::X, DVec3::Y] }, 1).unwrap();
        assert_eq!(hits.len(), 1);
    }

    /// Found by the `intersect` fuzz target: a sliver 1e-9 as wide as it is long (7e5). Its normal,
    /// the plain cross product at p0, was off by 1e-7 rad, so a hit at its far vertex lay 0.005 off
    /// the plane; now from the edges at the largest angle, with compensated products.
    #[test]
    fn bad_case_a_slivers_normal_was_off_by_1e_7_rad() {
        let p =
            [DVec3::new(-52681.62727651227, 3e5, -3e5), DVec3::new(147318.37179216516, 7e5, 2e5), DVec3::new(147318.37272348773, 7e5, 2e5)];
        let g = Triangle::with_edges(p[0], p[1], p[2], EdgeRule::Inclusive).unwrap();
        let ray = Ray::new(DVec3::new(947318.3727234877, 1.5e6, 1e6), -DVec3::ONE);
        let exact = ExactTriangle { p };
        let hits = check_hits_ascending(&g, &ray, &Tolerance::for_scale(1.5e6), &exact, 1).unwrap_or_else(|v| panic!("{v}"));
        assert_eq!(hits.len(), 1);
        assert!((g.outward_normal(&hits[0]) - DVec3::new(0.0, 5.0, -4.0).normalize()).length() < 1e-15);
    }

    // Regressions: literal cases the properties found, kept as pbrt keeps Triangle.BadCases.

    /// The scaled range test passed a t that rounded onto t_max: a query in (0, t) returned t.
    #[test]
    fn bad_case_t_equal_to_t_max_was_returned() {
        let cases = [
            (
                [
                    DVec3::new(121.53333303779588, 568.7835996593128, -48190.190502268066),
                    DVec3::new(226.61169424885406, -563.7053439716464, -47518.6199406257),
                    DVec3::new(-849.7226444145446, -641.8112313164244, -47518.6199406257),
                ],
                Ray { origin: DVec3::new(0.0, 0.0, -47005.01894834951), dir: DVec3::new(0.0, -0.09890722109902335, -0.9950966594328758) },
                812.0052853516123,
            ),
            (
                [
                    DVec3::new(3.9077738731981637, 4.913669030507929, 0.8318765194363695),
                    DVec3::new(4.076807613047912, 3.540285856672028, 0.0),
                    DVec3::new(3.1080181318749243, 3.540285856672028, 1.5849631754180011),
                ],
                Ray {
                    origin: DVec3::new(3.8743256133835415, 4.222878717997288, 0.35121507286865455),
                    dir: DVec3::new(0.5960265884880274, -0.8029646977391495, 0.0),
                },
                0.19699987448074466,
            ),
        ];
        for ([a, b, c], ray, t) in cases {
            let g = Triangle::new(a, b, c).unwrap();
            assert_eq!(g.intersect(&ray, 0.0, f64::INFINITY).map(|h| h.t), Some(t));
            assert_eq!(g.intersect(&ray, 0.0, t), None);
            assert!(!g.occludes(&ray, 0.0, t));
        }
    }

    /// An origin computed on the triangle lay a rounding error in front of it: hit at t ≈ 1e-16.
    #[test]
    fn bad_case_a_ray_from_the_triangle_hit_it_again() {
        let p = [
            DVec3::new(-3.934438784016334, 0.0, 4.468437813679143),
            DVec3::new(-3.972869336081107, 0.0, 4.5730530956043225),
            DVec3::new(-3.934438784016334, 0.1754464572213331, 4.415710549976163),
        ];
        let g = Triangle::new(p[0], p[1], p[2]).unwrap();
        let on = at(p, DVec3::new(0.2978277008887222, 0.3051222605710677, 0.5209323715473884));
        let ray = Ray::new(on, DVec3::new(-0.7712068822766014, 0.6365845935374216, 0.0));
        assert_eq!(g.intersect(&ray, 0.0, f64::INFINITY), None);
    }
}
