//! Sample instances of shapes, and the checks raylab runs over every registered one.
//!
//! A geometry plugin registers, beside its builder, one [`ShapeSampler`] per variant
//! ([`crate::Registry::add_geometry_with_samples`]): a function that draws a random valid instance
//! of the shape from a [`Draw`] (random numbers, or a fuzzer's bytes), together with its exact
//! surface (the oracle, [`ExactSurface`], written from the shape's definition) and what the checks
//! need to aim rays at it. Every registered shape, built-in or from another crate, is then held to
//! the same contracts by the same three harnesses:
//!
//! - [`check_sample`]: the property tests' body. Random rays aimed at a random instance: every hit
//!   exact and ascending ([`check_hits_ascending`]), `t` windows answered right
//!   ([`check_t_window`]), and a ray leaving the bounds misses.
//! - [`reintersect`]: the reintersection campaign (pbrt-v4's `Reintersect` tests, at more scales):
//!   secondary rays spawned from random hit points with [`Hit::spawn_ray`] and
//!   [`Hit::spawn_shadow_ray`] never meet the surface they leave where its [`Form`] says they
//!   cannot.
//! - [`check_bytes`]: the `intersect` fuzz target's body, also run over its checked-in corpus.
//!
//! So a new shape is its file (the shape, its oracle, its sampler) and one registration line.

use crate::geometry::testing::{ExactSurface, Tolerance, Violation, check_hits_ascending, check_intersect_into, check_t_window};
use crate::geometry::{Geometry, Hit};
use crate::math::float::{MACHINE_EPSILON, NORMAL_TOLERANCE, SURFACE_TOLERANCE, max_abs};
use crate::math::ray::Ray;
use crate::math::sampler::mix64;
use glam::DVec3;
use std::f64::consts::TAU;

/// Where the numbers of a sample come from: uniform random numbers ([`SplitMix`], for the property
/// tests and the reintersection campaign), or a fuzzer's bytes ([`Bytes`]), which answer with
/// lattice values (exact tangents, rays through edges and vertices, repeated vertices) and
/// degenerate ones as often as with fractions. A sampler asks for what it needs by meaning
/// (an offset, a direction, a length, an outline) and refuses what its constructor refuses.
pub trait Draw {
    /// A number in `[0, 1)`.
    fn uniform(&mut self) -> f64;

    /// A point of the cube `[-1, 1]³`, from three [`Draw::uniform`]s.
    fn cube(&mut self) -> DVec3 {
        DVec3::new(2.0 * self.uniform() - 1.0, 2.0 * self.uniform() - 1.0, 2.0 * self.uniform() - 1.0)
    }

    /// A direction uniform on the unit sphere, from two [`Draw::uniform`]s.
    fn unit(&mut self) -> DVec3 {
        let z = 2.0 * self.uniform() - 1.0;
        let phi = TAU * self.uniform();
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// An offset of size about `s`: `s` times a point of the cube `[-1, 1]³`.
    fn offset(&mut self, s: f64) -> DVec3 {
        s * self.cube()
    }

    /// A unit direction; `None` when none can be made (a fuzzer's zero vector).
    fn direction(&mut self) -> Option<DVec3> {
        Some(self.unit())
    }

    /// A positive length of about `s`: `s · (0.05 + span · u)`; `None` for a fuzzer's zero.
    fn length(&mut self, s: f64, span: f64) -> Option<f64> {
        Some(s * (0.05 + span * self.uniform()))
    }

    /// An index in `0..n`.
    fn index(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// The `k` vertices of a strictly convex outline of size `s` around `center`: on an ellipse
    /// (aspect 0.3 to 1) in a random plane, one vertex in each of `k` equal sectors. A fuzzer
    /// answers with any `k` points, planar to rounding; `None` when they are not.
    fn outline(&mut self, center: DVec3, s: f64, k: usize) -> Option<Vec<DVec3>> {
        let n = self.unit();
        let e1 = perpendicular(n, TAU * self.uniform());
        let e2 = n.cross(e1);
        let aspect = 0.3 + 0.7 * self.uniform();
        Some(
            (0..k)
                .map(|j| {
                    let a = TAU * (j as f64 + 0.1 + 0.8 * self.uniform()) / k as f64;
                    center + s * (a.cos() * e1 + aspect * a.sin() * e2)
                })
                .collect(),
        )
    }
}

/// A unit vector perpendicular to unit `n`, at angle `phi` around it.
pub fn perpendicular(n: DVec3, phi: f64) -> DVec3 {
    let (b1, b2) = n.any_orthonormal_pair();
    (phi.cos() * b1 + phi.sin() * b2).normalize()
}

/// A deterministic stream of uniform numbers in `[0, 1)` (SplitMix64).
#[derive(Clone, Copy, Debug)]
pub struct SplitMix(pub u64);

impl Draw for SplitMix {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        (mix64(self.0) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// A fuzzer's bytes, read one at a time; zeros once used up. Numbers are on a small integer
/// lattice or arbitrary fractions (see [`Bytes::number`]).
#[derive(Clone, Copy, Debug)]
pub struct Bytes<'a>(pub &'a [u8]);

impl Bytes<'_> {
    /// The next byte (0 once the input is used up).
    pub fn u8(&mut self) -> u8 {
        let Some((&b, rest)) = self.0.split_first() else { return 0 };
        self.0 = rest;
        b
    }
    /// Four bytes, little-endian.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }
    /// A number times `s`: an integer in −3..=3, or a fraction in [−4, 4].
    pub fn number(&mut self, s: f64) -> f64 {
        if self.u8() & 1 == 0 { f64::from(self.u8() as i8 % 4) * s } else { (f64::from(self.u32()) / f64::from(u32::MAX) * 8.0 - 4.0) * s }
    }
    /// Three [`Bytes::number`]s.
    pub fn vec3(&mut self, s: f64) -> DVec3 {
        DVec3::new(self.number(s), self.number(s), self.number(s))
    }
}

impl Draw for Bytes<'_> {
    /// A quarter in 0..=3/4, or a fraction.
    fn uniform(&mut self) -> f64 {
        if self.u8() & 1 == 0 { f64::from(self.u8() % 4) / 4.0 } else { f64::from(self.u32()) / (f64::from(u32::MAX) + 1.0) }
    }
    fn offset(&mut self, s: f64) -> DVec3 {
        self.vec3(s)
    }
    fn direction(&mut self) -> Option<DVec3> {
        self.vec3(1.0).try_normalize()
    }
    /// `|number(s)|`, any size from 0 (refused) to `4s`.
    fn length(&mut self, s: f64, _: f64) -> Option<f64> {
        Some(self.number(s).abs()).filter(|r| *r > 0.0)
    }
    fn index(&mut self, n: usize) -> usize {
        usize::from(self.u8()) % n.max(1)
    }
    /// Any `k` offsets from `center`. The loader accepts vertices 1e-9 of the size off one plane;
    /// the exact surface of such an outline is ambiguous to that degree, and its normal to that
    /// distance over the outline's width (a sliver's normal turns with any vertex off its plane),
    /// so only outlines planar to rounding relative to their width are kept.
    fn outline(&mut self, center: DVec3, s: f64, k: usize) -> Option<Vec<DVec3>> {
        let v: Vec<DVec3> = (0..k).map(|_| center + self.vec3(s)).collect();
        let normal = (v[k / 2] - v[0]).cross(v[(3 * k) / 4] - v[k / 4]).normalize();
        let size = v.iter().map(|p| (*p - v[0]).length()).fold(0.0, f64::max);
        let twice_area = (1..k - 1).map(|i| (v[i] - v[0]).cross(v[i + 1] - v[0])).sum::<DVec3>().length();
        let width = twice_area / size;
        if v.iter().any(|p| normal.dot(*p - v[0]).abs() > 1e-12 * width) {
            return None;
        }
        Some(v)
    }
}

/// What the geometry of a shape allows a ray leaving it to do ([`reintersect`]).
pub enum Form {
    /// Flat (plane, triangle, polygon): a ray leaving it never meets it again, and a shadow ray
    /// toward a light anywhere off its plane is never blocked by it.
    Flat,
    /// A convex solid or a piece of one's boundary (sphere, bowl, cylinder, tube): a ray leaving on
    /// the outward side never meets it again, one entering meets it at most once (the far side),
    /// and a shadow ray toward a light on the outward side of the tangent plane, or strictly inside
    /// the solid, is never blocked by it. The function maps a point of the cube `[-1, 1]³` to a
    /// point strictly inside the solid.
    Convex(Box<dyn Fn(DVec3) -> DVec3>),
    /// Anything else (a torus): the campaign makes no claim about rays leaving it.
    Other,
}

/// A random instance of a shape with its oracle and what the checks need to know about it.
pub struct ShapeSample {
    /// The shape, as its constructor made it.
    pub geometry: Box<dyn Geometry>,
    /// Its exact surface, written from the shape's definition (not from its intersection code).
    pub exact: Box<dyn ExactSurface>,
    /// Where rays are aimed: a point at the middle of the shape.
    pub center: DVec3,
    /// Its size: rays start within `3 · size` of [`ShapeSample::center`].
    pub size: f64,
    /// The magnitude of the problem: the largest coordinate or size of the shape (tolerances are
    /// relative to it).
    pub magnitude: f64,
    /// The most hits one ray may have (1 for a flat shape, 2 for a convex solid).
    pub max_hits: usize,
    /// How thin the shape is: `2 · area / longest edge²` for a triangle, 1 for shapes without
    /// slivers. Hits are only as accurate as the shape allows, `4ε / aspect`; the campaign draws
    /// only shapes with aspect above [`MIN_CAMPAIGN_ASPECT`].
    pub aspect: f64,
    /// The radius of curvature of a curved surface (`INFINITY` for a flat one): its normals are
    /// known to the hit point's rounding (relative to the magnitude) over it.
    pub curvature_radius: f64,
    /// What rays leaving it may do.
    pub form: Form,
}

impl ShapeSample {
    /// A round solid (a sphere or a part of one) of `radius` about `center`: two hits at most, no
    /// slivers, curved at its radius, convex, rays leaving from half its radius inside.
    pub fn round(geometry: Box<dyn Geometry>, exact: Box<dyn ExactSurface>, center: DVec3, radius: f64) -> Self {
        ShapeSample {
            geometry,
            exact,
            center,
            size: radius,
            magnitude: max_abs(center) + radius,
            max_hits: 2,
            aspect: 1.0,
            curvature_radius: radius,
            form: Form::Convex(Box::new(move |c| center + 0.5 * radius * c)),
        }
    }

    /// The tolerance of a hit of `ray` on this instance: [`SURFACE_TOLERANCE`] of the magnitude
    /// (or `4ε / aspect` for a sliver), and [`NORMAL_TOLERANCE`] for normals (or the rounding of
    /// the hit point over the radius of curvature, for a small curved surface far away).
    pub fn tolerance(&self, ray: &Ray) -> Tolerance {
        let scale = self.magnitude.max(max_abs(ray.origin));
        let normal = NORMAL_TOLERANCE.max(64.0 * MACHINE_EPSILON * self.magnitude / self.curvature_radius);
        Tolerance { relative: SURFACE_TOLERANCE.max(4.0 * MACHINE_EPSILON / self.aspect), normal, ..Tolerance::for_scale(scale) }
    }
}

/// Draws a random instance of a shape around `center`, of size about `s`, or `None` when the draw
/// gives parameters its constructor (hence the loader) refuses.
pub type SampleFn = fn(d: &mut dyn Draw, center: DVec3, s: f64) -> Option<ShapeSample>;

/// One variant of a shape the harnesses check (a shape may offer several: the triangle with its
/// two edge rules).
#[derive(Clone, Copy, Debug)]
pub struct ShapeSampler {
    /// The variant's name, as failures report it (`"sphere"`, `"inclusive triangle"`).
    pub name: &'static str,
    /// Its instance generator.
    pub sample: SampleFn,
}

/// Most draws a harness makes for one instance before it calls the sampler broken.
pub const MAX_DRAWS: usize = 1000;

/// Thinnest shape the reintersection campaign draws (see [`ShapeSample::aspect`]).
pub const MIN_CAMPAIGN_ASPECT: f64 = 0.05;

/// An instance of `sampler` around `center` at size `s` that `keep` accepts, drawn again until
/// one is (at most [`MAX_DRAWS`] times).
fn draw_until(
    sampler: &ShapeSampler,
    d: &mut dyn Draw,
    center: DVec3,
    s: f64,
    keep: impl Fn(&ShapeSample) -> bool,
) -> Result<ShapeSample, String> {
    for _ in 0..MAX_DRAWS {
        if let Some(sample) = (sampler.sample)(d, center, s)
            && keep(&sample)
        {
            return Ok(sample);
        }
    }
    Err(format!("{}: no valid instance in {MAX_DRAWS} draws (scale {s:e}, centre {center})", sampler.name))
}

/// A violation named after the shape and its instance.
fn named(sampler: &ShapeSampler, s: f64, center: DVec3, v: Violation) -> Violation {
    Violation { what: format!("{} (scale {s:e}, centre {center}): {}", sampler.name, v.what), ..v }
}

/// The property tests' body for one case: from `seed`, an instance of `sampler` (scale 10⁻³, 1 or
/// 10⁴, centre within 5 sizes of the origin), one ray aimed at a point near it (one in five in a
/// free direction) whose hits are all checked with [`check_hits_ascending`] and whose three random
/// `t` windows with [`check_t_window`], and one ray starting outside its bounding sphere and moving
/// away, which must miss. Returns the number of hits checked.
pub fn check_sample(sampler: &ShapeSampler, seed: u64) -> Result<usize, Violation> {
    let d = &mut SplitMix(seed);
    let s = [1e-3, 1.0, 1e4][d.index(3)];
    let center = 5.0 * s * d.cube();
    let sample = draw_until(sampler, d, center, s, |_| true).map_err(|what| Violation { what, ray: Ray::new(center, DVec3::X) })?;
    let (from, to, free) = (d.cube(), d.cube(), d.uniform() < 0.2);
    let dir = d.unit();
    let origin = sample.center + 3.0 * sample.size * from;
    let toward = sample.center + 1.2 * sample.size * to - origin;
    let ray = if free || !(toward.length() > 1e-6 * sample.size) { Ray::new(origin, dir) } else { Ray::new(origin, toward) };
    let tol = sample.tolerance(&ray);
    let g = sample.geometry.as_ref();
    let hits = check_hits_ascending(g, &ray, &tol, sample.exact.as_ref(), sample.max_hits).map_err(|v| named(sampler, s, center, v))?;
    check_intersect_into(g, &ray, 0.0, f64::INFINITY).map_err(|v| named(sampler, s, center, v))?;
    let span = hits.last().map_or(tol.scale, |h| 1.5 * h.t);
    for _ in 0..3 {
        let (a, b) = (d.uniform(), d.uniform());
        check_t_window(g, &ray, &hits, a.min(b) * span, a.max(b) * span).map_err(|v| named(sampler, s, center, v))?;
    }
    if let Some(b) = g.bounds() {
        let (w, v, gap) = (d.unit(), d.unit(), 3.0 * d.uniform());
        let origin = b.center() + 0.5 * b.extent().length() * (1.0 + 1e-6 + gap) * w;
        let away = Ray::new(origin, if v.dot(w) < 0.0 { -v } else { v });
        if let Some(h) = g.intersect(&away, 0.0, f64::INFINITY) {
            let what = format!("a ray leaving the bounds {b:?} hit at t = {}", h.t);
            return Err(named(sampler, s, center, Violation { what, ray: away }));
        }
        if g.occludes(&away, 0.0, f64::INFINITY) {
            let what = format!("a ray leaving the bounds {b:?} is occluded");
            return Err(named(sampler, s, center, Violation { what, ray: away }));
        }
    }
    Ok(hits.len())
}

/// Counts of one shape's reintersection campaign.
#[derive(Debug, Default)]
pub struct Tally {
    /// Hit points rays were spawned from.
    pub hits: u64,
    /// Spawned rays checked.
    pub spawned: u64,
    /// Shadow rays checked.
    pub shadow: u64,
    /// The first failures (at most 2000).
    pub failures: Vec<String>,
    /// True when the shape's [`Form`] is [`Form::Other`]: no claim, nothing checked.
    pub no_claim: bool,
}

impl Tally {
    fn fail(&mut self, what: String) {
        if self.failures.len() < 2000 {
            self.failures.push(what);
        }
    }
}

/// Every hit of `ray` on `g` beyond `t = 0`, nearest first (at most `limit + 1`).
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

/// The reintersection campaign on `sampler`, from `seed`: `points` random hit points on instances
/// of sizes 10⁻⁶ to 10⁶, near the origin or 10³ sizes away, and from each `per_point` spawned rays
/// and as many shadow rays, in uniform directions plus a share within 10⁻¹ to 10⁻¹² radians of the
/// tangent plane (grazing), checked against the instance's [`Form`] (none for [`Form::Other`]).
pub fn reintersect(sampler: &ShapeSampler, seed: u64, points: u32, per_point: u32) -> Tally {
    let scales = [1e-6, 1e-3, 1.0, 1e3, 1e6];
    let mut tally = Tally::default();
    let r = &mut SplitMix(seed);
    let name = sampler.name;
    while tally.hits < u64::from(points) {
        let s = scales[(r.uniform() * scales.len() as f64) as usize];
        let far = if r.uniform() < 0.5 { 5.0 } else { 1e3 };
        let center = s * far * r.cube();
        let sub = match draw_until(sampler, r, center, s, |x| x.aspect > MIN_CAMPAIGN_ASPECT) {
            Ok(sub) => sub,
            Err(e) => {
                tally.fail(e);
                return tally;
            }
        };
        if matches!(sub.form, Form::Other) {
            tally.no_claim = true;
            return tally;
        }
        let g = sub.geometry.as_ref();
        // A ray from around the shape toward a point near it, as the shapes' own properties aim.
        let origin = sub.center + 3.0 * sub.size * r.cube();
        let target = sub.center + 1.2 * sub.size * r.cube();
        if (target - origin).length() <= 1e-6 * sub.size {
            continue;
        }
        let ray = Ray::new(origin, target - origin);
        let Some(hit) = g.intersect(&ray, 0.0, f64::INFINITY) else { continue };
        tally.hits += 1;
        let at =
            |what: &str, d: DVec3| format!("{name} s={s:e} {what}: hit {:?} err {:?} from ray {ray:?}, dir {d:?}", hit.point, hit.error);
        let n = g.normal(&hit, ray.dir);
        let outward = g.outward_normal(&hit);
        let convex = matches!(sub.form, Form::Convex(_));
        for i in 0..per_point {
            // Spawned rays: both sides of a flat shape; for a convex one, alternately out and in.
            let out = i % 2 == 0;
            let d = grazing_or_uniform(r, outward, out);
            let spawned = hit.spawn_ray(n, d);
            tally.spawned += 1;
            let limit = if convex && !out { 1 } else { 0 };
            let again = all_hits(g, &spawned, limit);
            if again.len() > limit {
                let ts: Vec<f64> = again.iter().map(|h| h.t).collect();
                tally.fail(at(&format!("spawned ray met its own surface at t = {ts:?} (allowed {limit})"), d));
            }
            // The path's next ray asks `intersect_leaving`: the same hit as `intersect`.
            let (closest, leaving) =
                (g.intersect(&spawned, 0.0, f64::INFINITY), g.intersect_leaving(&spawned, 0.0, f64::INFINITY, hit.prim));
            if closest != leaving {
                tally.fail(at(&format!("intersect_leaving found {leaving:?}, intersect {closest:?}"), d));
            }
            // A flat shape is not asked at all: it must meet nothing of itself.
            if g.is_flat() && closest.is_some() {
                tally.fail(at(&format!("is_flat, yet the spawned ray met it: {closest:?}"), d));
            }
            // Shadow rays toward a light off the plane / outside the tangent plane, or inside.
            let light = match &sub.form {
                Form::Convex(interior) if !out => interior(r.cube()),
                _ => {
                    let side = if !convex && !out { -outward } else { outward };
                    hit.point + sub.size * (1e-3 + 3.0 * r.uniform()) * side + sub.size * 3.0 * r.cube().reject_from(side)
                }
            };
            let to_light = light - hit.point;
            let distance = to_light.length();
            if !(distance > 0.0) {
                continue;
            }
            let (shadow, t_max) = hit.spawn_shadow_ray(n, to_light / distance, distance);
            tally.shadow += 1;
            if g.occludes(&shadow, 0.0, t_max)
                || g.occludes_leaving(&shadow, 0.0, t_max, hit.prim)
                || g.intersect(&shadow, 0.0, t_max).is_some()
            {
                let t = g.intersect(&shadow, 0.0, t_max).map(|h| h.t);
                tally.fail(at(&format!("shadow ray toward {light:?} blocked by its own surface at t = {t:?}, t_max {t_max}"), to_light));
            }
        }
    }
    tally
}

/// A direction on the `n` side (`d·n > 0`) or the other: uniform, or one time in four within
/// 10⁻¹ … 10⁻¹² radians of the tangent plane.
fn grazing_or_uniform(r: &mut SplitMix, n: DVec3, outward: bool) -> DVec3 {
    let sign = if outward { 1.0 } else { -1.0 };
    if r.uniform() < 0.25 {
        let tilt = 10f64.powf(-1.0 - 11.0 * r.uniform());
        return (perpendicular(n, TAU * r.uniform()) + sign * tilt * n).normalize();
    }
    let d = r.unit();
    if d.dot(n) * sign >= 0.0 { d } else { -d }
}

/// The `intersect` fuzz target's body: `data` decodes to one of `samplers` (an instance of size
/// 10⁻⁶ to 10⁶, around a centre near the origin or 10³ sizes away) and up to four rays, starting
/// anywhere, on the surface at a previous hit, or spawned from it; every hit of every ray is
/// checked with [`check_hits_ascending`] against the instance's oracle, within
/// [`ShapeSample::tolerance`]. Returns the name of the shape and the rays checked; `None` for
/// inputs that decode to parameters the shape's constructor refuses.
pub fn check_bytes(samplers: &[ShapeSampler], data: &[u8]) -> Result<Option<(&'static str, usize)>, Violation> {
    if samplers.is_empty() {
        return Ok(None);
    }
    let mut b = Bytes(data);
    let s = 10f64.powi(i32::from(b.u8() % 13) - 6);
    let far = if b.u8() & 1 == 1 { b.vec3(1e3 * s) } else { DVec3::ZERO };
    let center = far + b.vec3(s);
    let sampler = &samplers[usize::from(b.u8()) % samplers.len()];
    let Some(case) = (sampler.sample)(&mut b, center, s) else { return Ok(None) };
    let g = case.geometry.as_ref();
    let mut last: Option<(Hit, Ray)> = None;
    let mut rays = 0;
    for _ in 0..1 + b.u8() % 4 {
        let mode = b.u8();
        let origin = match (mode % 3, last) {
            (1, Some((h, _))) => h.point,
            (2, Some((h, from))) => h.spawn_ray(g.normal(&h, from.dir), DVec3::X).origin,
            _ => center + b.vec3(3.0 * s),
        };
        // Free, or aimed at a point near the shape (so that most rays hit).
        let dir = if mode & 4 == 0 { b.direction() } else { (center + b.vec3(s) - origin).try_normalize() };
        let Some(dir) = dir else { continue };
        let ray = match (mode % 3, last) {
            (2, Some((h, from))) => h.spawn_ray(g.normal(&h, from.dir), dir),
            _ => Ray::new(origin, dir),
        };
        rays += 1;
        let hits = check_hits_ascending(g, &ray, &case.tolerance(&ray), case.exact.as_ref(), case.max_hits)
            .map_err(|v| named(sampler, s, center, v))?;
        if let Some(h) = hits.first() {
            last = Some((*h, ray));
        }
    }
    Ok(Some((sampler.name, rays)))
}
