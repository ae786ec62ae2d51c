//! Arbitrary bytes → a built-in shape and a few rays, each checked against the shape's exact
//! surface: the body of the `intersect` fuzz target (`fuzz/fuzz_targets/intersect.rs`), also run
//! over its checked-in corpus by `tests/fuzz_corpus.rs`.
//!
//! Numbers are decoded either on a small integer lattice (exact tangents, rays through edges and
//! vertices, repeated vertices) or as arbitrary fractions, times a scale from 10⁻⁶ to 10⁶, around a
//! centre near the origin or 10³ sizes away. Shapes the loader would refuse (zero radius, zero
//! direction, degenerate triangle, non-convex polygon) are refused here too, through the same
//! constructors. Rays start anywhere, on the surface at a previous hit, or spawned from it. Hits
//! are held to [`SURFACE_TOLERANCE`] of the problem's magnitude, except on a sliver triangle, whose
//! hits are only as accurate as its shape allows (`4ε / aspect`, aspect = 2·area / longest edge²:
//! more than 1e-9 only for triangles thinner than 4e-7 of their length). Likewise the normals of a
//! curved surface are known only to the hit point's rounding over the radius: a bowl of radius 1e-9
//! at 30 has normals good to about 1e-6.

use super::cylinder::Cylinder;
use super::exact::{ExactBowl, ExactCylinder, ExactPlane, ExactPolygon, ExactSphere, ExactTriangle};
use super::hemisphere::Hemisphere;
use super::plane::Plane;
use super::polygon::Polygon;
use super::sphere::Sphere;
use super::triangle::{EdgeRule, Triangle};
use raylab::geometry::testing::{ExactSurface, Tolerance, Violation, check_hits_ascending};
use raylab::glam::DVec3;
use raylab::math::float::{MACHINE_EPSILON, NORMAL_TOLERANCE, SURFACE_TOLERANCE, max_abs, triangle_normal};
use raylab::{Geometry, Hit, Ray};

/// Reads the input a byte at a time; zeros once it is used up.
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        let Some((&b, rest)) = self.0.split_first() else { return 0 };
        self.0 = rest;
        b
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }
    /// A number times `s`: an integer in −3..=3, or a fraction in [−4, 4].
    fn number(&mut self, s: f64) -> f64 {
        if self.u8() & 1 == 0 { f64::from(self.u8() as i8 % 4) * s } else { (f64::from(self.u32()) / f64::from(u32::MAX) * 8.0 - 4.0) * s }
    }
    fn vec3(&mut self, s: f64) -> DVec3 {
        DVec3::new(self.number(s), self.number(s), self.number(s))
    }
    /// A unit direction, or `None` for the zero vector (which the loader refuses).
    fn direction(&mut self) -> Option<DVec3> {
        self.vec3(1.0).try_normalize()
    }
}

/// A decoded shape: the geometry, its exact surface, its magnitude and most hits per ray.
struct Case {
    name: &'static str,
    g: Box<dyn Geometry>,
    exact: Box<dyn ExactSurface>,
    magnitude: f64,
    max_hits: usize,
    /// Relative tolerance of the hits: [`SURFACE_TOLERANCE`], or more for a sliver triangle.
    relative: f64,
    /// Radius of curvature of a curved surface: its normals are known to the hit point's rounding
    /// (relative to the magnitude) over it; `INFINITY` for flat shapes.
    curvature_radius: f64,
}

fn decode(b: &mut Bytes) -> Option<(Case, DVec3, f64)> {
    let s = 10f64.powi(i32::from(b.u8() % 13) - 6);
    let far = if b.u8() & 1 == 1 { b.vec3(1e3 * s) } else { DVec3::ZERO };
    let center = far + b.vec3(s);
    let size = |b: &mut Bytes| Some(b.number(s).abs()).filter(|r| *r > 0.0);
    let case = match b.u8() % 9 {
        0 => {
            let normal = b.direction()?;
            Case {
                name: "plane",
                curvature_radius: f64::INFINITY,
                g: Box::new(Plane::new(center, normal)),
                exact: Box::new(ExactPlane { point: center, normal }),
                magnitude: max_abs(center) + s,
                max_hits: 1,
                relative: SURFACE_TOLERANCE,
            }
        }
        1 => {
            let radius = size(b)?;
            Case {
                name: "sphere",
                curvature_radius: radius,
                g: Box::new(Sphere::new(center, radius)),
                exact: Box::new(ExactSphere { center, radius }),
                magnitude: max_abs(center) + radius,
                max_hits: 2,
                relative: SURFACE_TOLERANCE,
            }
        }
        2 => {
            let (radius, open) = (size(b)?, b.direction()?);
            let g = Box::new(Hemisphere::new(center, radius, open));
            Case {
                name: "hemisphere",
                curvature_radius: radius,
                g,
                exact: Box::new(ExactBowl { center, radius, open }),
                magnitude: max_abs(center) + radius,
                max_hits: 2,
                relative: SURFACE_TOLERANCE,
            }
        }
        k @ (3 | 4) => {
            let p = [center + b.vec3(s), center + b.vec3(s), center + b.vec3(s)];
            let rule = if k == 3 { EdgeRule::Exclusive } else { EdgeRule::Inclusive };
            let g = Box::new(Triangle::with_edges(p[0], p[1], p[2], rule)?);
            // A sliver's hits are only as accurate as its shape allows: the edge functions' rounding
            // over its tiny area, ε / aspect (aspect = 2·area / longest edge²).
            let longest = (0..3).map(|i| (p[(i + 1) % 3] - p[i]).length_squared()).fold(0.0, f64::max);
            let aspect = triangle_normal(p).0.length() / longest;
            Case {
                name: if k == 3 { "triangle" } else { "inclusive triangle" },
                curvature_radius: f64::INFINITY,
                g,
                exact: Box::new(ExactTriangle { p }),
                magnitude: p.iter().map(|v| max_abs(*v)).fold(0.0, f64::max),
                max_hits: 1,
                relative: SURFACE_TOLERANCE.max(4.0 * MACHINE_EPSILON / aspect),
            }
        }
        k @ (5 | 6) => {
            let n = if k == 5 { 4 } else { 3 + usize::from(b.u8() % 6) };
            let v: Vec<DVec3> = (0..n).map(|_| center + b.vec3(s)).collect();
            let g = Box::new(Polygon::new(v.clone()).ok()?);
            let magnitude = v.iter().map(|p| max_abs(*p)).fold(0.0, f64::max);
            // The loader accepts vertices 1e-9 of the size off one plane; the exact surface of such
            // an outline is ambiguous to that degree, and its normal to that distance over the
            // outline's width (a sliver's normal turns with any vertex off its plane), so only
            // outlines planar to rounding relative to their width are checked.
            let exact = ExactPolygon { v: v.clone() };
            let size = v.iter().map(|p| (*p - v[0]).length()).fold(0.0, f64::max);
            let twice_area = (1..n - 1).map(|i| (v[i] - v[0]).cross(v[i + 1] - v[0])).sum::<DVec3>().length();
            let width = twice_area / size;
            if v.iter().any(|p| exact.normal().dot(*p - v[0]).abs() > 1e-12 * width) {
                return None;
            }
            Case {
                name: if k == 5 { "quadrangle" } else { "polygon" },
                curvature_radius: f64::INFINITY,
                g,
                exact: Box::new(exact),
                magnitude,
                max_hits: 1,
                relative: SURFACE_TOLERANCE,
            }
        }
        k => {
            let (axis, radius) = (b.direction()?, size(b)?);
            let height = if k == 7 { Some(size(b)?) } else { None };
            let g = Box::new(Cylinder::new(center, axis, radius, height));
            let exact = Box::new(ExactCylinder { base: center, axis, radius, height });
            Case {
                name: if k == 7 { "cylinder" } else { "tube" },
                curvature_radius: radius,
                g,
                exact,
                magnitude: max_abs(center) + radius + height.unwrap_or(0.0),
                max_hits: 2,
                relative: SURFACE_TOLERANCE,
            }
        }
    };
    Some((case, center, s))
}

/// Decodes `data` into a shape and up to four rays and checks every hit of every ray with
/// [`check_hits_ascending`] (hence [`raylab::geometry::testing::check_hit`]). Inputs that decode to a shape
/// the loader would refuse pass trivially.
pub fn check_bytes(data: &[u8]) -> Result<(), Violation> {
    let mut b = Bytes(data);
    let Some((case, center, s)) = decode(&mut b) else { return Ok(()) };
    let mut last: Option<(Hit, Ray)> = None;
    for _ in 0..1 + b.u8() % 4 {
        let mode = b.u8();
        let origin = match (mode % 3, last) {
            (1, Some((h, _))) => h.point,
            (2, Some((h, from))) => h.spawn_ray(case.g.normal(&h, from.dir), DVec3::X).origin,
            _ => center + b.vec3(3.0 * s),
        };
        // Free, or aimed at a point near the shape (so that most rays hit).
        let dir = if mode & 4 == 0 { b.direction() } else { (center + b.vec3(s) - origin).try_normalize() };
        let Some(dir) = dir else { continue };
        let ray = match (mode % 3, last) {
            (2, Some((h, from))) => h.spawn_ray(case.g.normal(&h, from.dir), dir),
            _ => Ray::new(origin, dir),
        };
        let scale = case.magnitude.max(max_abs(ray.origin));
        let normal = NORMAL_TOLERANCE.max(64.0 * MACHINE_EPSILON * case.magnitude / case.curvature_radius);
        let tol = Tolerance { relative: case.relative, normal, ..Tolerance::for_scale(scale) };
        let hits = check_hits_ascending(case.g.as_ref(), &ray, &tol, case.exact.as_ref(), case.max_hits)
            .map_err(|v| Violation { what: format!("{} (scale {s:e}, centre {center}): {}", case.name, v.what), ..v })?;
        if let Some(h) = hits.first() {
            last = Some((*h, ray));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::test_support::{CASES, config};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(config(CASES))]

        /// The fuzz target's check, over random inputs with the shapes' fixed seed.
        #[test]
        fn arbitrary_rays_on_arbitrary_shapes_keep_every_contract(data in prop::collection::vec(any::<u8>(), 0..160)) {
            check_bytes(&data).map_err(crate::shapes::test_support::fail)?;
        }
    }
}
