//! Exact descriptions of the built-in shapes ([`ExactSurface`]: signed distance and outward
//! normal, written from each shape's definition, independently of its intersection code): the
//! oracles that the shapes' property tests, the reintersection campaign and the `intersect` fuzz
//! target check every hit against with [`raylab::geometry::testing::check_hit`].

use raylab::geometry::testing::ExactSurface;
use raylab::glam::DVec3;
use raylab::math::float::triangle_normal;

/// The point of segment `a b` closest to `p`.
pub fn closest_on_segment(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let ab = b - a;
    a + ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) * ab
}

/// The exact plane.
#[derive(Debug)]
pub struct ExactPlane {
    /// A point of the plane.
    pub point: DVec3,
    /// Unit normal: the outward side.
    pub normal: DVec3,
}

impl ExactSurface for ExactPlane {
    fn signed_distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p - self.point)
    }
    fn outward_normal(&self, _: DVec3) -> DVec3 {
        self.normal
    }
}

/// The exact sphere.
#[derive(Debug)]
pub struct ExactSphere {
    /// Centre.
    pub center: DVec3,
    /// Radius (> 0).
    pub radius: f64,
}

impl ExactSurface for ExactSphere {
    fn signed_distance(&self, p: DVec3) -> f64 {
        (p - self.center).length() - self.radius
    }
    fn outward_normal(&self, p: DVec3) -> DVec3 {
        (p - self.center).normalize()
    }
}

/// The exact bowl: on the closed side, the sphere; on the open side, the nearest point is on
/// the rim circle. Positive outside the full sphere.
#[derive(Debug)]
pub struct ExactBowl {
    /// Centre of the full sphere.
    pub center: DVec3,
    /// Radius (> 0).
    pub radius: f64,
    /// Unit direction toward the open side.
    pub open: DVec3,
}

impl ExactBowl {
    /// The bowl point nearest to `p`.
    pub fn nearest(&self, p: DVec3) -> DVec3 {
        let f = p - self.center;
        if f.dot(self.open) <= 0.0 {
            self.center + self.radius * f.normalize()
        } else {
            let flat = f - f.dot(self.open) * self.open;
            self.center + self.radius * flat.normalize()
        }
    }
}

impl ExactSurface for ExactBowl {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let f = p - self.center;
        let d = if f.dot(self.open) <= 0.0 { (f.length() - self.radius).abs() } else { (p - self.nearest(p)).length() };
        d.copysign(f.length() - self.radius)
    }
    fn outward_normal(&self, p: DVec3) -> DVec3 {
        (self.nearest(p) - self.center).normalize()
    }
}

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

/// The exact capped cylinder (or tube, without `height`): positive outside.
#[derive(Clone, Copy, Debug)]
pub struct ExactCylinder {
    /// Centre of the base.
    pub base: DVec3,
    /// Unit axis, from the base toward the top.
    pub axis: DVec3,
    /// Radius (> 0).
    pub radius: f64,
    /// Height of a capped cylinder; `None` for the infinite tube.
    pub height: Option<f64>,
}

impl ExactCylinder {
    /// Height along the axis, radial vector, and the signed distances to the side (`dx`) and to
    /// the caps' slab (`dz`).
    pub fn parts(&self, p: DVec3) -> (f64, DVec3, f64, f64) {
        let f = p - self.base;
        let z = f.dot(self.axis);
        let radial = f - z * self.axis;
        let dx = radial.length() - self.radius;
        let dz = self.height.map_or(f64::NEG_INFINITY, |h| (z - 0.5 * h).abs() - 0.5 * h);
        (z, radial, dx, dz)
    }
    /// The middle of the axis (the base for a tube).
    pub fn mid(&self) -> DVec3 {
        self.base + 0.5 * self.height.unwrap_or(0.0) * self.axis
    }
}

impl ExactSurface for ExactCylinder {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let (_, _, dx, dz) = self.parts(p);
        if dx <= 0.0 && dz <= 0.0 { dx.max(dz) } else { dx.max(0.0).hypot(dz.max(0.0)) }
    }
    fn outward_normal(&self, p: DVec3) -> DVec3 {
        let (z, radial, dx, dz) = self.parts(p);
        if dx >= dz {
            radial.normalize()
        } else if z > 0.5 * self.height.unwrap_or(0.0) {
            self.axis
        } else {
            -self.axis
        }
    }
    fn outward_normals_near(&self, p: DVec3, within: f64) -> Vec<DVec3> {
        let (z, radial, dx, _) = self.parts(p);
        let mut normals = vec![self.outward_normal(p)];
        if dx.abs() <= within {
            normals.push(radial.normalize());
        }
        if let Some(h) = self.height {
            if z.abs() <= within {
                normals.push(-self.axis);
            }
            if (z - h).abs() <= within {
                normals.push(self.axis);
            }
        }
        normals
    }
}
