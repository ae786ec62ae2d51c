//! `plane`: an infinite plane given by a point and a normal (the report's `Plane`).
//!
//! `t = n·(q − o) / (n·d)`. The hit point is projected back onto the plane, and a ray whose
//! origin is within [`raylab::math::float::on_surface_slack`] of the plane (it starts on the
//! plane) does not hit it.

use raylab::geometry::samples::{Draw, Form, ShapeSample, ShapeSampler};
use raylab::geometry::testing::ExactSurface;
use raylab::geometry::{Geometry, Hit, Intersectable, PACKET, SurfaceDerivatives};
use raylab::glam::{DVec2, DVec3};
use raylab::math::float::{gamma, max_abs};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Aabb, LoadContext, PluginInfo, Ray};

/// The plane through `point` with unit `normal` (its outward side).
#[derive(Clone, Debug)]
pub struct Plane {
    point: DVec3,
    normal: DVec3,
    equation: PlaneEquation,
    /// Right and up axes, for texture coordinates ([`super::uv::tangent_frame`]).
    axes: (DVec3, DVec3),
}

/// The `plane` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "plane",
    summary: "An infinite plane through a point, with a normal. Unbounded; shaded on both sides.",
    params: &[
        ParamSpec::new("point", ParamKind::Vec3, ParamDefault::Vec3([0.0, 0.0, 0.0]), "a point on the plane (the report's Q)"),
        ParamSpec::new("normal", ParamKind::Vec3, ParamDefault::Vec3([0.0, 1.0, 0.0]), "normal (any length > 0): the plane's outward side"),
    ],
};

/// Builds a plane from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let point = p.vec3("point")?;
    let normal = p.direction("normal")?;
    Ok(Box::new(Plane::new(point, normal)))
}

/// Intersects a ray with the plane through `q` with unit normal `n`: returns `t`, the point
/// projected onto the plane, and its error bound. A ray parallel to the plane within the rounding
/// of `n·d` (its side is then uncertain) misses, as does a ray starting on the plane.
#[inline]
pub fn intersect_plane(ray: &Ray, q: DVec3, n: DVec3, t_min: f64, t_max: f64) -> Option<(f64, DVec3, DVec3)> {
    PlaneEquation::new(q, n).intersect(ray, t_min, t_max)
}

/// The plane through `q` with unit normal `n`, with the magnitudes [`intersect_plane`] uses
/// computed once (the same results, bit for bit).
#[derive(Clone, Copy, Debug)]
pub struct PlaneEquation {
    q: DVec3,
    n: DVec3,
    /// `|n|` and `|q|` per axis, and `‖q‖∞`.
    n_abs: DVec3,
    q_abs: DVec3,
    q_max: f64,
    /// For a normal along an axis (`±1` there, `0` elsewhere): the axis and the sign.
    axis: Option<(usize, f64)>,
}

impl PlaneEquation {
    /// The plane through `q` with unit normal `n`.
    #[inline]
    pub fn new(q: DVec3, n: DVec3) -> Self {
        let axis = (0..3).find(|&k| n[k].abs() == 1.0 && n[(k + 1) % 3] == 0.0 && n[(k + 2) % 3] == 0.0).map(|k| (k, n[k]));
        PlaneEquation { q, n, n_abs: n.abs(), q_abs: q.abs(), q_max: max_abs(q), axis }
    }

    /// [`intersect_plane`] for this plane.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, DVec3, DVec3)> {
        let (t, p) = self.crossing(ray, t_min, t_max)?;
        Some((t, p, gamma(8) * (p.abs() + self.q_abs)))
    }

    /// Whether [`PlaneEquation::intersect`] finds a hit: the same decision, without the error
    /// bound.
    #[inline(always)]
    pub fn crosses(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.crossing(ray, t_min, t_max).is_some()
    }

    /// `t` and the point projected onto the plane, where [`PlaneEquation::intersect`] hits.
    #[inline(always)]
    fn crossing(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
        if let Some((k, sign)) = self.axis {
            return self.crossing_along(ray, k, sign, t_min, t_max);
        }
        let (q, n) = (self.q, self.n);
        let denom = n.dot(ray.dir);
        if !(denom.abs() > gamma(3) * self.n_abs.dot(ray.dir.abs())) {
            return None;
        }
        let num = n.dot(q - ray.origin);
        self.crossing_at(ray, |p| p - n * n.dot(p - q), num, denom, t_min, t_max)
    }

    /// [`PlaneEquation::intersect`] for the rays `rays[k]` of mask `live` (each up to
    /// `t_max[k]`; hits written to `out[k]`, their mask returned) and a normal `sign` along axis
    /// `K`: the tests of [`PlaneEquation::crossing_along`] on the same values in the same
    /// operations, each lane's computed whole and its rejections combined without early exits
    /// (every test only rejects, so their order changes no answer): the same hits, bit for bit,
    /// without a branch per test.
    #[inline(always)]
    fn intersect_packet_along<const K: usize>(
        &self,
        sign: f64,
        rays: &[Ray; PACKET],
        live: u32,
        t_min: f64,
        t_max: &[f64; PACKET],
        out: &mut [Hit; PACKET],
    ) -> u32 {
        let q = self.q[K];
        let mut hits = 0;
        for (k, ray) in rays.iter().enumerate() {
            let denom = sign * ray.dir[K];
            let num = sign * (q - ray.origin[K]);
            let t = num / denom;
            let p = ray.at(t);
            let p = match K {
                0 => DVec3::new(p.x - (p.x - q), p.y, p.z),
                1 => DVec3::new(p.x, p.y - (p.y - q), p.z),
                _ => DVec3::new(p.x, p.y, p.z - (p.z - q)),
            };
            // `&` on booleans: every test evaluated, no branch between them.
            let crosses = (denom.abs() > gamma(3) * ray.dir[K].abs())
                & !(t_min >= 0.0 && (num < 0.0) != (denom < 0.0))
                & !(num.abs() <= gamma(5) * (max_abs(ray.origin) + self.q_max))
                & (t > t_min)
                & (t < t_max[k])
                & t.is_finite()
                & p.is_finite();
            if crosses && live >> k & 1 != 0 {
                out[k] = Hit { t, point: p, error: gamma(8) * (p.abs() + self.q_abs), uv: DVec2::ZERO, prim: 0, object: 0 };
                hits |= 1 << k;
            }
        }
        hits
    }

    /// [`PlaneEquation::crossing`] for a normal `sign` along axis `k`: the products with the
    /// normal's zeros and its `±1` left out. Bit for bit the general result for a finite unit
    /// direction and points whose differences are finite: `0·x` is `±0`, which adds nothing to a
    /// non-zero sum, and a zero sum's sign only decides cases both reject (`denom = ±0`) or
    /// leave unchanged.
    #[inline(always)]
    fn crossing_along(&self, ray: &Ray, k: usize, sign: f64, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
        let denom = sign * ray.dir[k];
        if !(denom.abs() > gamma(3) * ray.dir[k].abs()) {
            return None;
        }
        let num = sign * (self.q[k] - ray.origin[k]);
        let q = self.q[k];
        // The general `p − n (n·(p − q))`, rounded the same way (not simply `q[k]`). A `match`
        // on the axis, not `p[k] = …`: indexing by a variable put the point through memory.
        let onto = |p: DVec3| match k {
            0 => DVec3::new(p.x - (p.x - q), p.y, p.z),
            1 => DVec3::new(p.x, p.y - (p.y - q), p.z),
            _ => DVec3::new(p.x, p.y, p.z - (p.z - q)),
        };
        self.crossing_at(ray, onto, num, denom, t_min, t_max)
    }

    /// The rest of [`PlaneEquation::crossing`] once `denom` (`n·d`, clear of rounding) and `num`
    /// (`n·(q − o)`) are known: `onto` moves a point along the normal onto the plane. Every test
    /// here only rejects, so their order changes no answer: the cheapest come first.
    #[inline(always)]
    fn crossing_at(&self, ray: &Ray, onto: impl Fn(DVec3) -> DVec3, num: f64, denom: f64, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
        // Opposite signs (`denom` is non-zero here): the plane is behind the origin, t < 0 (or
        // −0). Known without the division.
        if t_min >= 0.0 && (num < 0.0) != (denom < 0.0) {
            return None;
        }
        // The numerator is the origin's distance from the plane: within the on-surface slack
        // ([`raylab::math::float::on_surface_slack`], written out with `‖q‖∞` stored), the origin lies on it.
        if num.abs() <= gamma(5) * (max_abs(ray.origin) + self.q_max) {
            return None;
        }
        let t = num / denom;
        if !(t > t_min && t < t_max && t.is_finite()) {
            return None;
        }
        let p = onto(ray.at(t));
        if !p.is_finite() {
            return None;
        }
        Some((t, p))
    }
}

impl Plane {
    /// A plane; `normal` must be unit length.
    pub fn new(point: DVec3, normal: DVec3) -> Self {
        Plane { point, normal, equation: PlaneEquation::new(point, normal), axes: super::uv::tangent_frame(normal) }
    }
}

impl Intersectable for Plane {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let (t, point, error) = self.equation.intersect(ray, t_min, t_max)?;
        Some(Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 })
    }
    #[inline]
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.equation.crosses(ray, t_min, t_max)
    }
    /// A normal along an axis: [`PlaneEquation::intersect_packet_along`]; else the rays one
    /// after the other through the inlined test of [`Plane::intersect`]. The same hits, bit for
    /// bit.
    #[inline]
    fn intersect_packet(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        let e = &self.equation;
        match e.axis {
            Some((0, sign)) => return e.intersect_packet_along::<0>(sign, rays, live, t_min, t_max, out),
            Some((1, sign)) => return e.intersect_packet_along::<1>(sign, rays, live, t_min, t_max, out),
            Some((_, sign)) => return e.intersect_packet_along::<2>(sign, rays, live, t_min, t_max, out),
            None => {}
        }
        let mut hits = 0;
        let mut m = live;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            if let Some((t, point, error)) = self.equation.intersect(&rays[k], t_min, t_max[k]) {
                out[k] = Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 };
                hits |= 1 << k;
            }
        }
        hits
    }
    flat_leaving!();
}

impl Geometry for Plane {
    fn outward_normal(&self, _: &Hit) -> DVec3 {
        self.normal
    }
    /// Scene units from `point` along the plane's right and up axes ([`super::uv`]).
    fn uv(&self, at: &Hit) -> DVec2 {
        let d = at.point - self.point;
        DVec2::new(d.dot(self.axes.0), d.dot(self.axes.1))
    }
    fn derivatives(&self, _: &Hit) -> Option<SurfaceDerivatives> {
        Some(SurfaceDerivatives::flat(self.axes.0, self.axes.1))
    }
    /// The right and up axes (one scene unit per unit of u and v).
    fn tangents(&self, _: &Hit) -> Option<[DVec3; 2]> {
        Some([self.axes.0, self.axes.1])
    }
    fn bounds(&self) -> Option<Aabb> {
        None
    }
}

// The shape harnesses' view of it (raylab::geometry::samples): its exact surface, written from
// the definition above and not from the intersection code, and random valid instances.

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

/// Random planes for the shape harnesses.
pub const SAMPLERS: &[ShapeSampler] = &[ShapeSampler { name: "plane", sample }];

fn sample(d: &mut dyn Draw, center: DVec3, s: f64) -> Option<ShapeSample> {
    let normal = d.direction()?;
    Some(ShapeSample {
        geometry: Box::new(Plane::new(center, normal)),
        exact: Box::new(ExactPlane { point: center, normal }),
        center,
        size: s,
        magnitude: max_abs(center) + s,
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
    use raylab::geometry::testing::ExactSurface;
    use raylab::math::float::max_abs;

    fn plane() -> impl Strategy<Value = (Plane, ExactPlane, f64)> {
        (scale(), cube(), unit()).prop_map(|(s, c, normal)| {
            let point = 5.0 * s * c;
            (Plane::new(point, normal), ExactPlane { point, normal }, max_abs(point) + s)
        })
    }

    proptest! {
        #![proptest_config(config(CASES))]

        #[test]
        fn hits_are_exact_and_single((g, exact, mag) in plane(), aim in aim(), win in windows()) {
            let ray = aim.ray(exact.point, mag);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 1, &win)?;
            // A ray clearly off the plane and clearly not parallel to it hits exactly when it points toward it.
            let height = exact.signed_distance(ray.origin);
            let cos = exact.normal.dot(ray.dir);
            if height.abs() > 1e-6 * mag && cos.abs() > 1e-6 {
                prop_assert_eq!(hits.len(), usize::from(height * cos < 0.0));
                if let Some(h) = hits.first() {
                    close("t", h.t, -height / cos, tol.distance(h.t, h.point))?;
                }
            }
        }

        #[test]
        fn a_ray_pointing_away_or_parallel_misses((g, exact, mag) in plane(), up in 1e-3..3.0f64, d in unit(), below in any::<bool>()) {
            let side = if below { -1.0 } else { 1.0 };
            let origin = exact.point + side * up * mag * exact.normal;
            let away = if side * d.dot(exact.normal) < 0.0 { d - 2.0 * d.dot(exact.normal) * exact.normal } else { d };
            // Parallel to within the rounding of n·d: which side it heads to is unknowable.
            let along = perpendicular(exact.normal, d.x * 3.0);
            let along = along - along.dot(exact.normal) * exact.normal;
            prop_assume!(along.dot(exact.normal).abs() <= raylab::math::float::gamma(3) * exact.normal.abs().dot(along.abs()));
            for dir in [away, along] {
                let ray = Ray { origin, dir };
                prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none(), "{:?}", ray);
                prop_assert!(!g.occludes(&ray, 0.0, f64::INFINITY));
            }
        }

        #[test]
        fn a_plane_along_an_axis_answers_as_the_general_equation_bit_for_bit(
            k in 0usize..3, neg in any::<bool>(), s in scale(), c in cube(), o in cube(), d in unit(), graze in -12.0..0.0f64, on in any::<bool>()
        ) {
            let mut n = DVec3::ZERO;
            n[k] = if neg { -1.0 } else { 1.0 };
            let q = 5.0 * s * c;
            let fast = PlaneEquation::new(q, n);
            prop_assert!(fast.axis.is_some());
            let general = PlaneEquation { axis: None, ..fast };
            // From off the plane or from a point of it; in any direction, or grazing it.
            let mut origin = q + 5.0 * s * o;
            if on {
                origin[k] = q[k];
            }
            let mut dir = d;
            dir[k] *= 10f64.powf(graze);
            let ray = Ray::new(origin, dir);
            let bits = |h: Option<(f64, DVec3, DVec3)>| h.map(|(t, p, e)| (t.to_bits(), p.to_array().map(f64::to_bits), e.to_array().map(f64::to_bits)));
            for (lo, hi) in [(0.0, f64::INFINITY), (f64::NEG_INFINITY, f64::INFINITY), (1e-3 * s, 2.0 * s)] {
                prop_assert_eq!(bits(fast.intersect(&ray, lo, hi)), bits(general.intersect(&ray, lo, hi)), "{:?} in ({}, {})", ray, lo, hi);
            }
        }

        #[test]
        fn occludes_is_whether_intersect_hits(
            (g, exact, mag) in plane(), k in 0usize..4, o in cube(), d in unit(), graze in -12.0..0.0f64, on in any::<bool>()
        ) {
            // A general plane, or one along an axis (its fast path); rays from off or on the
            // plane, in any direction or grazing it.
            let g = if k < 3 { let mut n = DVec3::ZERO; n[k] = if o.x < 0.0 { -1.0 } else { 1.0 }; Plane::new(exact.point, n) } else { g };
            let n = g.normal;
            let mut origin = exact.point + mag * o;
            if on {
                origin -= n * n.dot(origin - exact.point);
            }
            let dir = d - n * n.dot(d) * (1.0 - 10f64.powf(graze));
            let ray = Ray::new(origin, dir);
            for (lo, hi) in [(0.0, f64::INFINITY), (f64::NEG_INFINITY, f64::INFINITY), (1e-3 * mag, 2.0 * mag), (0.0, 1e-300)] {
                prop_assert_eq!(g.occludes(&ray, lo, hi), g.intersect(&ray, lo, hi).is_some(), "{:?} in ({}, {})", ray, lo, hi);
            }
        }

        #[test]
        fn a_ray_starting_on_the_plane_does_not_hit_it((g, exact, mag) in plane(), offset in cube(), d in unit()) {
            // A point of the plane, rounded: the ray starts within rounding error of the surface.
            let on = exact.point + mag * (offset - exact.normal.dot(offset) * exact.normal);
            let on = on - exact.normal.dot(on - exact.point) * exact.normal;
            let ray = Ray::new(on, d);
            prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none(), "hit {:?}", g.intersect(&ray, 0.0, f64::INFINITY));
        }

        #[test]
        fn grazing_rays_keep_every_contract((g, exact, mag) in plane(), up in 1e-3..3.0f64, phi in 0.0..6.3f64, tilt in -9.0..-1.0f64) {
            let origin = exact.point + up * mag * exact.normal;
            let dir = perpendicular(exact.normal, phi) - 10f64.powf(tilt) * exact.normal;
            let ray = Ray::new(origin, dir);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 1, &[])?;
            prop_assert_eq!(hits.len(), 1);
        }

        /// A packet (a normal along each axis, either way, and a general one) finds each live
        /// ray's hit of `intersect`, bit for bit, and no other.
        #[test]
        fn a_packet_finds_each_rays_own_hit(
            axis in 0..4usize, negative in any::<bool>(), general in unit(), c in cube(), s in scale(),
            aims in proptest::collection::vec(aim(), PACKET), limits in proptest::collection::vec(0.05..20.0f64, PACKET), live in 0..256u32,
        ) {
            let mut normal = general;
            if axis < 3 {
                normal = DVec3::ZERO;
                normal[axis] = if negative { -1.0 } else { 1.0 };
            }
            let point = 5.0 * s * c;
            let g = Plane::new(point, normal);
            let mag = max_abs(point) + s;
            let rays: [Ray; PACKET] = std::array::from_fn(|k| aims[k].ray(point, mag));
            let t_max: [f64; PACKET] = std::array::from_fn(|k| limits[k] * mag);
            let mut out = [Hit::new(0.0, DVec3::ZERO, DVec3::ZERO); PACKET];
            let hits = g.intersect_packet(&rays, live, 0.0, &t_max, &mut out);
            for (k, ray) in rays.iter().enumerate() {
                let single = if live >> k & 1 != 0 { g.intersect(ray, 0.0, t_max[k]) } else { None };
                prop_assert_eq!(hits >> k & 1 != 0, single.is_some(), "lane {}", k);
                if let Some(h) = single {
                    prop_assert_eq!((out[k].t.to_bits(), out[k].point, out[k].error), (h.t.to_bits(), h.point, h.error));
                }
            }
        }
    }

    #[test]
    fn is_unbounded_and_shaded_on_both_sides() {
        let g = Plane::new(DVec3::ZERO, DVec3::Y);
        assert!(g.bounds().is_none() && !g.is_closed());
        for (y, n) in [(2.0, DVec3::Y), (-2.0, -DVec3::Y)] {
            let ray = Ray::new(DVec3::new(0.5, y, 0.0), DVec3::new(0.0, -y, 0.0));
            let h = g.intersect(&ray, 0.0, f64::INFINITY).unwrap();
            assert_eq!((h.t, h.point, g.normal(&h, ray.dir)), (2.0, DVec3::new(0.5, 0.0, 0.0), n));
            assert!(g.occludes(&ray, 0.0, 2.5) && !g.occludes(&ray, 0.0, 1.5));
        }
    }

    #[test]
    fn a_ray_in_the_plane_misses() {
        let g = Plane::new(DVec3::new(0.0, 1.0, 0.0), DVec3::Y);
        for dir in [DVec3::X, DVec3::new(1.0, 0.0, -1.0)] {
            assert!(g.intersect(&Ray::new(DVec3::new(3.0, 1.0, 0.0), dir), 0.0, f64::INFINITY).is_none());
        }
    }

    // Regressions: literal cases the properties found.

    /// A direction parallel to the plane to within the rounding of n·d hit it ~1e11 away (on a
    /// side that rounding chose).
    #[test]
    fn bad_case_a_parallel_ray_hit_far_away() {
        let normal = DVec3::new(-0.9224963529793111, 0.3860058014329192, 0.0);
        let g = Plane::new(DVec3::ZERO, normal);
        let ray = Ray { origin: 1e-6 * normal, dir: DVec3::new(-0.09725808128787794, -0.2324323234334201, -0.9677376094001632) };
        assert_eq!(g.intersect(&ray, 0.0, f64::INFINITY), None);
    }
}
