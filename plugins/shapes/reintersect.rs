//! The reintersection campaign, for every built-in shape (pbrt-v4's `Reintersect` tests, at more
//! scales): secondary rays spawned from random hit points with [`Hit::spawn_ray`] and
//! [`Hit::spawn_shadow_ray`] (what the integrators use) never meet the surface they leave where
//! its geometry says they cannot.
//!
//! - From a flat shape (plane, triangle, quadrangle, polygon), a ray in any direction meets it
//!   nowhere, and a shadow ray toward a light anywhere off its plane is never blocked by it.
//! - From a convex solid (sphere, capped cylinder) or a piece of one's boundary (bowl, tube), a ray
//!   leaving on the outward side meets it nowhere, a ray entering meets it at most once (the far
//!   side, never the start point again), and a shadow ray toward a light on the outward side of the
//!   tangent plane, or strictly inside the solid, is never blocked by it.
//!
//! Directions are uniform, plus a share within 10⁻¹ to 10⁻¹² radians of the tangent plane (grazing).
//! Shapes range over sizes 10⁻⁶ to 10⁶, near the origin and 10³ sizes away from it: 10⁶ spawned rays
//! and 10⁶ shadow rays per shape, 0 failures allowed (pbrt-v4 checks 10⁶ per shape).

use super::cylinder::Cylinder;
use super::hemisphere::Hemisphere;
use super::plane::Plane;
use super::polygon::Polygon;
use super::sphere::Sphere;
use super::test_support::perpendicular;
use super::triangle::{EdgeRule, Triangle};
use raylab::Ray;
use raylab::geometry::{Geometry, Hit};
use raylab::glam::DVec3;
use raylab::math::sampler::mix64;
use std::f64::consts::TAU;

/// What the geometry of a shape allows a ray leaving it to do.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// Flat: a ray leaving it never meets it again.
    Flat,
    /// Part of a convex solid's boundary: leaving outward, never again; inward, at most once.
    Convex,
}

/// A random shape with what the campaign needs to know about it.
struct Subject {
    g: Box<dyn Geometry>,
    kind: Kind,
    /// Centre and size, for aiming rays at it.
    center: DVec3,
    size: f64,
    /// A point strictly inside the solid (for convex shapes), from a point of the cube `[-1, 1]³`.
    interior: Box<dyn Fn(DVec3) -> DVec3>,
}

/// The shapes of the campaign.
#[derive(Clone, Copy, Debug)]
enum Shape {
    Plane,
    Sphere,
    Bowl,
    Triangle,
    InclusiveTriangle,
    Quadrangle,
    Polygon,
    Cylinder,
    Tube,
    /// A textbook sphere without error bounds or on-surface test: the campaign must catch it.
    NaiveSphere,
}

const SHAPES: [Shape; 9] = [
    Shape::Plane,
    Shape::Sphere,
    Shape::Bowl,
    Shape::Triangle,
    Shape::InclusiveTriangle,
    Shape::Quadrangle,
    Shape::Polygon,
    Shape::Cylinder,
    Shape::Tube,
];

/// A deterministic stream of uniform numbers in `[0, 1)` (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        (mix64(self.0) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    fn cube(&mut self) -> DVec3 {
        DVec3::new(2.0 * self.next() - 1.0, 2.0 * self.next() - 1.0, 2.0 * self.next() - 1.0)
    }
    fn unit(&mut self) -> DVec3 {
        let z = 2.0 * self.next() - 1.0;
        let phi = TAU * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }
    /// A direction on the `n` side (`d·n > 0`) or the other: uniform, or one time in four within
    /// 10⁻¹ … 10⁻¹² radians of the tangent plane.
    fn direction(&mut self, n: DVec3, outward: bool) -> DVec3 {
        let sign = if outward { 1.0 } else { -1.0 };
        if self.next() < 0.25 {
            let tilt = 10f64.powf(-1.0 - 11.0 * self.next());
            return (perpendicular(n, TAU * self.next()) + sign * tilt * n).normalize();
        }
        let d = self.unit();
        if d.dot(n) * sign >= 0.0 { d } else { -d }
    }
}

/// A random shape of `kind`: size `s`, centre `s · far · cube`, other parameters from `r`.
fn subject(shape: Shape, s: f64, far: f64, r: &mut Rng) -> Subject {
    let center = s * far * r.cube();
    let flat = |g: Box<dyn Geometry>, size: f64| Subject { g, kind: Kind::Flat, center, size, interior: Box::new(|_| DVec3::NAN) };
    // A strictly convex outline of `k` vertices on an ellipse in a random plane.
    let outline = |r: &mut Rng, k: usize| -> Vec<DVec3> {
        let n = r.unit();
        let e1 = perpendicular(n, TAU * r.next());
        let e2 = n.cross(e1);
        let aspect = 0.3 + 0.7 * r.next();
        (0..k)
            .map(|j| {
                let a = TAU * (j as f64 + 0.1 + 0.8 * r.next()) / k as f64;
                center + s * (a.cos() * e1 + aspect * a.sin() * e2)
            })
            .collect()
    };
    match shape {
        Shape::Plane => flat(Box::new(Plane::new(center, r.unit())), s),
        Shape::Triangle | Shape::InclusiveTriangle => loop {
            let p = [center + s * r.cube(), center + s * r.cube(), center + s * r.cube()];
            let rule = if matches!(shape, Shape::Triangle) { EdgeRule::Exclusive } else { EdgeRule::Inclusive };
            let area = (p[1] - p[0]).cross(p[2] - p[0]).length();
            let longest = (p[1] - p[0]).length().max((p[2] - p[1]).length()).max((p[0] - p[2]).length());
            if area > 0.05 * longest * longest
                && let Some(t) = Triangle::with_edges(p[0], p[1], p[2], rule)
            {
                break flat(Box::new(t), s);
            }
        },
        Shape::Quadrangle | Shape::Polygon => {
            let k = if matches!(shape, Shape::Quadrangle) { 4 } else { 3 + (r.next() * 6.0) as usize };
            loop {
                if let Ok(p) = Polygon::new(outline(r, k)) {
                    break flat(Box::new(p), s);
                }
            }
        }
        Shape::Sphere | Shape::NaiveSphere => {
            let radius = s * (0.05 + r.next());
            Subject {
                g: if matches!(shape, Shape::Sphere) {
                    Box::new(Sphere::new(center, radius))
                } else {
                    Box::new(NaiveSphere(center, radius))
                },
                kind: Kind::Convex,
                center,
                size: radius,
                interior: Box::new(move |c| center + 0.5 * radius * c),
            }
        }
        Shape::Bowl => {
            let radius = s * (0.05 + r.next());
            Subject {
                g: Box::new(Hemisphere::new(center, radius, r.unit())),
                kind: Kind::Convex,
                center,
                size: radius,
                interior: Box::new(move |c| center + 0.5 * radius * c),
            }
        }
        Shape::Cylinder | Shape::Tube => {
            let (axis, radius) = (r.unit(), s * (0.05 + r.next()));
            let height = matches!(shape, Shape::Cylinder).then(|| s * (0.05 + 2.0 * r.next()));
            let inside = move |c: DVec3| {
                let along = match height {
                    Some(h) => h * (0.5 + 0.45 * c.z),
                    None => 3.0 * radius * c.z,
                };
                let radial = c - c.dot(axis) * axis;
                center + along * axis + 0.5 * radius * radial
            };
            Subject {
                g: Box::new(Cylinder::new(center, axis, radius, height)),
                kind: Kind::Convex,
                center: center + 0.5 * height.unwrap_or(0.0) * axis,
                size: radius.max(height.unwrap_or(0.0)),
                interior: Box::new(inside),
            }
        }
    }
}

/// Counts of one shape's campaign.
#[derive(Debug, Default)]
struct Tally {
    hits: u64,
    spawned: u64,
    shadow: u64,
    failures: Vec<String>,
}

impl Tally {
    fn fail(&mut self, what: String) {
        if self.failures.len() < 2000 {
            self.failures.push(what);
        }
    }
}

/// Every hit of `ray` on `g` beyond `t = 0`, nearest first (at most `limit`).
fn all_hits(g: &dyn Geometry, ray: &Ray, limit: usize) -> Vec<Hit> {
    let mut hits: Vec<Hit> = Vec::new();
    let mut t_min = 0.0;
    while let Some(h) = g.intersect(ray, t_min, f64::INFINITY) {
        hits.push(h);
        if hits.len() > limit {
            break;
        }
        t_min = h.t;
    }
    hits
}

/// Runs the campaign on `shape`: `points` random hit points, `per_point` spawned rays and as many
/// shadow rays from each.
fn campaign(shape: Shape, points: u32, per_point: u32) -> Tally {
    let scales = [1e-6, 1e-3, 1.0, 1e3, 1e6];
    let mut tally = Tally::default();
    let mut r = Rng(0x5eed ^ shape as u64);
    while tally.hits < u64::from(points) {
        let s = scales[(r.next() * scales.len() as f64) as usize];
        let far = if r.next() < 0.5 { 5.0 } else { 1e3 };
        let sub = subject(shape, s, far, &mut r);
        // A ray from around the shape toward a point near it, as the shapes' own properties aim.
        let origin = sub.center + 3.0 * sub.size * r.cube();
        let target = sub.center + 1.2 * sub.size * r.cube();
        if (target - origin).length() <= 1e-6 * sub.size {
            continue;
        }
        let ray = Ray::new(origin, target - origin);
        let Some(hit) = sub.g.intersect(&ray, 0.0, f64::INFINITY) else { continue };
        tally.hits += 1;
        let at =
            |what: &str, d: DVec3| format!("{shape:?} s={s:e} {what}: hit {:?} err {:?} from ray {ray:?}, dir {d:?}", hit.point, hit.error);
        let n = sub.g.normal(&hit, ray.dir);
        let outward = sub.g.outward_normal(&hit);
        for i in 0..per_point {
            // Spawned rays: both sides of a flat shape; for a convex one, alternately out and in.
            let out = i % 2 == 0;
            let d = r.direction(outward, out);
            let spawned = hit.spawn_ray(n, d);
            tally.spawned += 1;
            let limit = if sub.kind == Kind::Convex && !out { 1 } else { 0 };
            let again = all_hits(sub.g.as_ref(), &spawned, limit);
            if again.len() > limit {
                let ts: Vec<f64> = again.iter().map(|h| h.t).collect();
                tally.fail(at(&format!("spawned ray met its own surface at t = {ts:?} (allowed {limit})"), d));
            }
            // Shadow rays toward a light off the plane / outside the tangent plane, or inside.
            let light = match sub.kind {
                Kind::Convex if !out => (sub.interior)(r.cube()),
                _ => {
                    let side = if sub.kind == Kind::Flat && !out { -outward } else { outward };
                    hit.point + sub.size * (1e-3 + 3.0 * r.next()) * side + sub.size * 3.0 * r.cube().reject_from(side)
                }
            };
            let to_light = light - hit.point;
            let distance = to_light.length();
            if !(distance > 0.0) {
                continue;
            }
            let (shadow, t_max) = hit.spawn_shadow_ray(n, to_light / distance, distance);
            tally.shadow += 1;
            if sub.g.occludes(&shadow, 0.0, t_max) || sub.g.intersect(&shadow, 0.0, t_max).is_some() {
                let t = sub.g.intersect(&shadow, 0.0, t_max).map(|h| h.t);
                tally.fail(at(&format!("shadow ray toward {light:?} blocked by its own surface at t = {t:?}, t_max {t_max}"), to_light));
            }
        }
    }
    tally
}

/// Runs the campaign on every shape and fails with the first failures of each.
fn run_all(points: u32, per_point: u32) {
    let mut report = String::new();
    for shape in SHAPES {
        let t = campaign(shape, points, per_point);
        eprintln!("{shape:?}: {} hit points, {} spawned rays, {} shadow rays, {} failures", t.hits, t.spawned, t.shadow, t.failures.len());
        if !t.failures.is_empty() {
            report +=
                &format!("{shape:?}: {} failures, e.g.\n  {}\n", t.failures.len(), t.failures[..t.failures.len().min(5)].join("\n  "));
        }
    }
    assert!(report.is_empty(), "{report}");
}

/// ≥ 10⁶ spawned rays and ≥ 10⁶ shadow rays per shape: about 3 s for all nine shapes in the test
/// profile, so it runs in every test run (no release build needed).
#[test]
fn spawned_rays_never_meet_their_own_surface_million_rays_per_shape() {
    run_all(1000, 1000);
}

/// A sphere as textbooks write it: the nearest root above `t_min`, `ray.at(t)` as the point, no
/// error bound.
struct NaiveSphere(DVec3, f64);

impl raylab::Intersectable for NaiveSphere {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let f = ray.origin - self.0;
        let (b, c) = (f.dot(ray.dir), f.length_squared() - self.1 * self.1);
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let t = [-b - disc.sqrt(), -b + disc.sqrt()].into_iter().find(|&t| t > t_min && t < t_max)?;
        Some(Hit::new(t, ray.at(t), DVec3::ZERO))
    }
}

impl Geometry for NaiveSphere {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        (at.point - self.0).normalize()
    }
    fn bounds(&self) -> Option<raylab::Aabb> {
        None
    }
}

#[test]
fn the_campaign_catches_a_sphere_without_error_bounds() {
    let t = campaign(Shape::NaiveSphere, 64, 64);
    assert!(t.failures.len() > 100, "only {} failures of {} rays", t.failures.len(), t.spawned + t.shadow);
}
