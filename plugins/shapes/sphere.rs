//! `sphere`: a sphere given by centre and radius.
//!
//! Numerics: the ray origin is moved to the sphere's frame, the discriminant is computed as
//! `r² − |f − (f·d)d|²` (Haines et al., *Ray Tracing Gems* ch. 7), which keeps precision for small
//! spheres far away, and the roots come from the cancellation-free quadratic formula. The hit
//! point is re-projected onto the sphere, and a root whose own error bound straddles zero is
//! rejected, so a ray leaving the surface never reports it again.

use raylab::geometry::samples::{Draw, ShapeSample, ShapeSampler};
use raylab::geometry::sampling::{NARROW_CONE_SIN2, cone_solid_angle, uniform_sphere};
use raylab::geometry::testing::ExactSurface;
use raylab::geometry::{Geometry, Hit, Intersectable, PACKET, SurfaceDerivatives, SurfacePdf, SurfaceSample};
use raylab::glam::{DVec2, DVec3};
use raylab::math::float::{gamma, max_abs};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Aabb, LoadContext, PluginInfo, Ray};
use std::f64::consts::{PI, TAU};

/// How far beyond `radius²` (relative) a reference point's squared distance from the centre must
/// be for [`Geometry::sample_surface`] to choose points in its cone. Closer, the cone's nearest
/// points collapse onto the reference itself (a point on the sphere sees its own surface at
/// distance 0 in every direction), so points are chosen by area, which holds from anywhere.
pub const CONE_MARGIN: f64 = 1e-6;

/// A sphere of `radius` (> 0) around `center`.
#[derive(Clone, Debug)]
pub struct Sphere {
    center: DVec3,
    radius: f64,
    /// `‖center‖∞`, the centre's part of [`raylab::math::float::on_surface_slack`], computed once.
    center_max: f64,
}

/// The `sphere` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "sphere",
    summary: "A sphere given by its centre and radius. A closed solid: refraction bends rays at its surface.",
    params: &[
        ParamSpec::new("center", ParamKind::Vec3, ParamDefault::Vec3([0.0, 0.0, 0.0]), "centre, scene units"),
        ParamSpec::new("radius", ParamKind::Float, ParamDefault::Float(1.0), "radius, scene units, > 0"),
    ],
};

/// Builds a sphere from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let center = p.vec3("center")?;
    let radius = p.positive("radius")?;
    Ok(Box::new(Sphere::new(center, radius)))
}

/// The two roots of the ray–sphere quadratic, ascending, each with a conservative absolute error
/// bound, for a ray with origin `f` relative to the centre and unit direction `d`. `None` on a miss.
/// `slack` is the distance within which the origin counts as on the sphere
/// ([`raylab::math::float::on_surface_slack`]): the near-zero root's bound includes its effect on `t`.
#[inline]
pub fn sphere_roots(f: DVec3, d: DVec3, radius: f64, slack: f64) -> Option<[(f64, f64); 2]> {
    let r2 = radius * radius;
    let b = f.dot(d);
    let l = f - b * d;
    let disc = r2 - l.length_squared();
    if disc < 0.0 {
        return None;
    }
    let c = f.length_squared() - r2;
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return None;
    }
    // c/q is the root of smaller magnitude; its error is dominated by that of c = |f|² − r².
    let small = c / q;
    let mut small_err = gamma(8) * (f.length_squared() + r2) / q.abs() + gamma(4) * small.abs();
    // Moving the origin by `slack` moves c by up to 2|f|·slack; only a root near zero needs that
    // term exactly (|f| ≤ 2·|f|∞ bounds it without a square root). The test is
    // `|small| ≤ small_err + 4|f|∞·slack/|q|` multiplied through by |q| (no division): its
    // rounding can only move the decision where the term is half of what the test allows.
    if (small.abs() - small_err) * q.abs() <= 4.0 * max_abs(f) * slack {
        small_err += 2.0 * f.length() * slack / q.abs();
    }
    let small = (small, small_err);
    let large = (q, gamma(8) * q.abs());
    Some(if small.0 <= large.0 { [small, large] } else { [large, small] })
}

impl Sphere {
    /// A sphere; `radius` must be finite and > 0.
    pub fn new(center: DVec3, radius: f64) -> Self {
        Sphere { center, radius, center_max: max_abs(center) }
    }

    /// The nearest root in `(t_min, t_max)` beyond its own error bound (a ray leaving the surface
    /// does not find it again); `f` is the ray origin relative to the centre. Always inlined: `f`
    /// stays in registers (passed in memory, its halves were stored apart and reloaded whole, a
    /// store-forwarding stall that cost a third of the function's time).
    #[inline(always)]
    fn first_root(&self, ray: &Ray, f: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
        // An origin outside (c > 0) moving away (b > 0): [`sphere_roots`] would find q < 0, so
        // both roots, q and c/q, ≤ 0, and none beyond t_min ≥ 0. Decided before the square root
        // and the division, with the same sums (the same rounding): the same answer, sooner.
        if t_min >= 0.0 && f.dot(ray.dir) > 0.0 && f.length_squared() > self.radius * self.radius {
            return None;
        }
        // `on_surface_slack` with the centre's magnitude stored (the same sum).
        let slack = gamma(5) * (max_abs(ray.origin) + self.center_max);
        let roots = sphere_roots(f, ray.dir, self.radius, slack)?;
        roots.into_iter().find(|&(t, err)| t > t_min && t > err && t < t_max).map(|(t, _)| t)
    }

    #[inline(always)]
    fn hit_at(&self, ray: &Ray, f: DVec3, t: f64) -> Hit {
        let mut local = f + t * ray.dir;
        local *= self.radius / local.length();
        let point = self.center + local;
        let error = gamma(6) * (local.abs() + point.abs());
        Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 }
    }
}

impl Intersectable for Sphere {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let f = ray.origin - self.center;
        let t = self.first_root(ray, f, t_min, t_max)?;
        Some(self.hit_at(ray, f, t))
    }
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.first_root(ray, ray.origin - self.center, t_min, t_max).is_some()
    }
    /// [`Sphere::intersect`], the hit written in place.
    fn intersect_into(&self, ray: &Ray, t_min: f64, t_max: f64, hit: &mut Hit) -> bool {
        let f = ray.origin - self.center;
        let Some(t) = self.first_root(ray, f, t_min, t_max) else { return false };
        *hit = self.hit_at(ray, f, t);
        true
    }
    /// The rays one after the other through the inlined test of [`Sphere::intersect`] (one call
    /// for the packet, not one per ray): the same hits, bit for bit.
    #[inline]
    fn intersect_packet(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        let mut hits = 0;
        let mut m = live;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let f = rays[k].origin - self.center;
            if let Some(t) = self.first_root(&rays[k], f, t_min, t_max[k]) {
                out[k] = self.hit_at(&rays[k], f, t);
                hits |= 1 << k;
            }
        }
        hits
    }
}

impl Geometry for Sphere {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        (at.point - self.center).normalize()
    }
    /// Longitude around +y and latitude ([`super::uv`]).
    fn uv(&self, at: &Hit) -> DVec2 {
        super::uv::spherical((at.point - self.center).normalize())
    }
    fn derivatives(&self, at: &Hit) -> Option<SurfaceDerivatives> {
        let d = (at.point - self.center).normalize();
        Some(super::uv::spherical_derivatives(d, self.radius))
    }
    /// The derivatives of [`super::uv::spherical`]'s inverse: `2πr·(z, 0, −x)` along the
    /// longitude, `πr·(−xy/ρ, ρ, −zy/ρ)` along the latitude (`ρ = √(x² + z²)`); none at the poles.
    fn tangents(&self, at: &Hit) -> Option<[DVec3; 2]> {
        let d = (at.point - self.center).normalize();
        let rho = (d.x * d.x + d.z * d.z).sqrt();
        if !(rho > 0.0) {
            return None;
        }
        let r = self.radius;
        Some([TAU * r * DVec3::new(d.z, 0.0, -d.x), PI * r * DVec3::new(-d.x * d.y / rho, rho, -d.z * d.y / rho)])
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(self.center - DVec3::splat(self.radius), self.center + DVec3::splat(self.radius)))
    }
    fn is_closed(&self) -> bool {
        true
    }
    /// A convex solid.
    fn is_convex(&self) -> bool {
        true
    }
    fn area(&self) -> Option<f64> {
        Some(4.0 * PI * self.radius * self.radius)
    }
    /// Uniform in the cone of directions the sphere covers from `reference` (pbrt-v4 §6.2.4):
    /// every sample is visible, and the density is `1 / cone's solid angle`; from inside or on
    /// the sphere ([`CONE_MARGIN`]), uniform by area.
    fn sample_surface(&self, reference: DVec3, u: DVec2) -> Option<SurfaceSample> {
        let to_centre = self.center - reference;
        let d2 = to_centre.length_squared();
        let r2 = self.radius * self.radius;
        if !(d2 > r2 * (1.0 + CONE_MARGIN)) {
            let n = uniform_sphere(u);
            let point = self.center + self.radius * n;
            let pdf = SurfacePdf::Area(1.0 / (4.0 * PI * r2));
            return Some(SurfaceSample::new(reference, point, gamma(6) * (self.radius * n.abs() + point.abs()), n, pdf));
        }
        // The cone: sin²θmax = r²/d²; θ uniform in its solid angle, then the point on the sphere
        // seen at θ (angle α at the centre from the axis toward the reference).
        let sin2_max = r2 / d2;
        let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
        let (cos_theta, sin2_theta) = if sin2_max < NARROW_CONE_SIN2 {
            let s2 = sin2_max * u.x;
            ((1.0 - s2).sqrt(), s2)
        } else {
            let c = 1.0 - u.x * (1.0 - cos_max);
            (c, (1.0 - c * c).max(0.0))
        };
        let sin_max = sin2_max.sqrt();
        let cos_alpha = sin2_theta / sin_max + cos_theta * (1.0 - sin2_theta / sin2_max).max(0.0).sqrt();
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let w = -to_centre / d2.sqrt();
        let (b1, b2) = raylab::math::sampler::orthonormal_basis(w);
        let (s, c) = (TAU * u.y).sin_cos();
        let n = (b1 * c + b2 * s) * sin_alpha + w * cos_alpha;
        let local = self.radius * n;
        let point = self.center + local;
        let pdf = SurfacePdf::SolidAngle(1.0 / cone_solid_angle(cos_max, sin2_max));
        Some(SurfaceSample::new(reference, point, gamma(6) * (local.abs() + point.abs()), n, pdf))
    }
    fn surface_pdf(&self, reference: DVec3, _: &Hit) -> SurfacePdf {
        let d2 = (self.center - reference).length_squared();
        let r2 = self.radius * self.radius;
        if !(d2 > r2 * (1.0 + CONE_MARGIN)) {
            return SurfacePdf::Area(1.0 / (4.0 * PI * r2));
        }
        let sin2_max = r2 / d2;
        SurfacePdf::SolidAngle(1.0 / cone_solid_angle((1.0 - sin2_max).max(0.0).sqrt(), sin2_max))
    }
}

// The shape harnesses' view of it (raylab::geometry::samples): its exact surface, written from
// the definition above and not from the intersection code, and random valid instances.

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

/// Random spheres for the shape harnesses.
pub const SAMPLERS: &[ShapeSampler] = &[ShapeSampler { name: "sphere", sample }];

fn sample(d: &mut dyn Draw, center: DVec3, s: f64) -> Option<ShapeSample> {
    let radius = d.length(s, 1.0)?;
    Some(ShapeSample::round(Box::new(Sphere::new(center, radius)), Box::new(ExactSphere { center, radius }), center, radius))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::test_support::*;
    use proptest::prelude::*;
    use raylab::geometry::testing::{ExactSurface, Tolerance, check_closed_crossings};
    use raylab::math::float::max_abs;

    fn sphere() -> impl Strategy<Value = (Sphere, ExactSphere, f64)> {
        (scale(), cube(), 0.05..2.0f64).prop_map(|(s, c, r)| {
            let (center, radius) = (5.0 * s * c, s * r);
            (Sphere::new(center, radius), ExactSphere { center, radius }, max_abs(center) + radius)
        })
    }

    /// Distance from the centre to the ray's line.
    fn miss_distance(ray: &Ray, c: DVec3) -> f64 {
        let f = ray.origin - c;
        (f - f.dot(ray.dir) * ray.dir).length()
    }

    proptest! {
        #![proptest_config(config(CASES))]

        #[test]
        fn hits_are_exact_ascending_and_alternate((g, exact, mag) in sphere(), aim in aim(), win in windows()) {
            let ray = aim.ray(exact.center, exact.radius);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 2, &win)?;
            let inside = exact.signed_distance(ray.origin) < 0.0;
            let toward = (exact.center - ray.origin).dot(ray.dir) > 0.0;
            let margin = (miss_distance(&ray, exact.center) - exact.radius).abs();
            if margin > 1e-6 * exact.radius && exact.signed_distance(ray.origin).abs() > 1e-6 * exact.radius {
                check_closed_crossings(&g, &ray, &hits, inside).map_err(fail)?;
                let expected = if inside { 1 } else if toward && miss_distance(&ray, exact.center) < exact.radius { 2 } else { 0 };
                prop_assert_eq!(hits.len(), expected);
            }
        }

        #[test]
        fn a_ray_pointing_away_misses((g, _, _) in sphere(), w in unit(), v in unit(), gap in 0.0..3.0f64) {
            let ray = away_ray(g.bounds().unwrap(), w, v, gap);
            prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none());
            prop_assert!(!g.occludes(&ray, 0.0, f64::INFINITY));
        }

        #[test]
        fn a_ray_toward_the_centre_hits_at_the_exact_distance((g, exact, mag) in sphere(), w in unit(), gap in 1e-3..4.0f64) {
            let origin = exact.center + exact.radius * (1.0 + gap) * w;
            let ray = Ray::new(origin, -w);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 2, &[])?;
            prop_assert_eq!(hits.len(), 2);
            let dist = (origin - exact.center).length();
            close("entry t", hits[0].t, dist - exact.radius, tol.distance(dist, origin))?;
            close("exit t", hits[1].t, dist + exact.radius, tol.distance(dist, origin))?;
        }

        #[test]
        fn grazing_rays_keep_every_contract(
            (g, exact, mag) in sphere(), u in unit(), phi in 0.0..std::f64::consts::TAU,
            tilt in -8.0..-1.0f64, inward in any::<bool>(), back in 0.2..3.0f64,
        ) {
            // Tangent at p = c + r·u, tilted by 10^tilt toward or away from the centre.
            let p = exact.center + exact.radius * u;
            let eps = 10f64.powf(tilt) * if inward { -1.0 } else { 1.0 };
            let dir = (perpendicular(u, phi) + eps * u).normalize();
            let ray = Ray::new(p - back * exact.radius * dir, dir);
            let tol = tolerance(mag, &ray);
            check_ray(&g, &ray, &tol, &exact, 2, &[])?;
        }

        #[test]
        fn a_ray_starting_on_the_surface_does_not_hit_it_again(
            (g, exact, mag) in sphere(), u in unit(), d in unit(),
        ) {
            let cos = d.dot(u);
            prop_assume!(cos.abs() > 0.05);
            let ray = Ray::new(exact.center + exact.radius * u, d);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 1, &[])?;
            if cos > 0.0 {
                prop_assert!(hits.is_empty(), "leaving ray hit at t = {}", hits[0].t);
            } else {
                prop_assert_eq!(hits.len(), 1);
                close("far side t", hits[0].t, -2.0 * exact.radius * cos, tol.distance(exact.radius, ray.origin))?;
            }
        }
    }

    fn unit_sphere() -> (Sphere, ExactSphere) {
        (Sphere::new(DVec3::ZERO, 1.0), ExactSphere { center: DVec3::ZERO, radius: 1.0 })
    }

    #[test]
    fn a_tangent_ray_reports_at_most_the_tangent_point() {
        let (g, exact) = unit_sphere();
        for (origin, dir) in
            [(DVec3::new(-5.0, 1.0, 0.0), DVec3::X), (DVec3::new(0.0, -3.0, -1.0), DVec3::Y), (DVec3::new(0.6, 0.8, 9.0), -DVec3::Z)]
        {
            let ray = Ray::new(origin, dir);
            let hits = check_hits_ascending_ok(&g, &ray, &exact);
            assert!(hits.len() <= 1, "tangent ray hit {} times", hits.len());
            let tangent = origin + (-origin.dot(dir)) * dir;
            for h in hits {
                // The tangent point is ill-conditioned along the ray: √ε of the radius.
                assert!((h.point - tangent).length() < 1e-7, "{:?} far from the tangent point {tangent}", h.point);
            }
        }
    }

    #[test]
    fn a_ray_starting_on_the_surface_hits_only_the_far_side() {
        let (g, exact) = unit_sphere();
        let up = Ray::new(DVec3::Z, DVec3::Z);
        assert!(g.intersect(&up, 0.0, f64::INFINITY).is_none());
        let down = Ray::new(DVec3::Z, -DVec3::Z);
        let hits = check_hits_ascending_ok(&g, &down, &exact);
        assert_eq!(hits.len(), 1);
        assert!((hits[0].t - 2.0).abs() < 1e-15 && (hits[0].point + DVec3::Z).length() < 1e-15);
    }

    #[test]
    fn the_normal_faces_the_viewer_inside_and_outside() {
        let (g, _) = unit_sphere();
        let out = Ray::new(DVec3::new(0.0, 0.0, 5.0), -DVec3::Z);
        let h = g.intersect(&out, 0.0, f64::INFINITY).unwrap();
        assert_eq!(g.normal(&h, out.dir), DVec3::Z);
        let inside = Ray::new(DVec3::ZERO, -DVec3::Z);
        let h = g.intersect(&inside, 0.0, f64::INFINITY).unwrap();
        assert_eq!((h.t, g.outward_normal(&h), g.normal(&h, inside.dir)), (1.0, -DVec3::Z, DVec3::Z));
        assert!(g.is_closed());
    }

    fn check_hits_ascending_ok(g: &Sphere, ray: &Ray, exact: &ExactSphere) -> Vec<Hit> {
        let tol = Tolerance::for_scale(10.0);
        raylab::geometry::testing::check_hits_ascending(g, ray, &tol, exact, 2).unwrap_or_else(|v| panic!("{v}"))
    }

    // Regressions: literal cases the properties found.

    /// A small sphere away from the origin: the start point's own rounding (relative to its
    /// coordinates, not to the radius) put it just outside, and the sphere was hit at t ≈ 3e-19.
    #[test]
    fn bad_case_a_ray_from_a_small_offset_sphere_hit_it_again() {
        let (center, radius) = (DVec3::new(0.0, 0.004066781978006635, 0.0), 0.00025531711221155127);
        let g = Sphere::new(center, radius);
        let ray = Ray::new(center + radius * DVec3::new(-0.7222485624026194, 0.6916335837040807, 0.0), DVec3::X);
        let hits = check_hits_ascending_ok(&g, &ray, &ExactSphere { center, radius });
        assert_eq!(hits.len(), 1, "{hits:?}");
        assert!((hits[0].t - 2.0 * radius * 0.7222485624026194).abs() < 1e-15);
    }
}
