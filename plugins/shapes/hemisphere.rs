//! `hemisphere`: the report's bowl, a sphere cut in half by a plane through its centre, open on
//! the side that `open` points to.
//!
//! The bowl is an open surface, seen from inside and outside: the direction-aware normal faces
//! whichever side the ray comes from, so its inside is shaded as well as its outside, and it
//! shadows itself (a shadow ray from its inner wall toward a light can hit the opposite wall).
//! Points exactly on the rim belong to the bowl.

use super::sphere::sphere_roots;
use raylab::geometry::samples::{Draw, ShapeSample, ShapeSampler};
use raylab::geometry::testing::ExactSurface;
use raylab::geometry::{Geometry, Hit, Intersectable, SurfaceDerivatives, SurfacePdf, SurfaceSample};
use raylab::glam::{DVec2, DVec3};
use raylab::math::float::{gamma, on_surface_slack};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Aabb, LoadContext, PluginInfo, Ray};
use std::f64::consts::TAU;

/// Half of the sphere (`center`, `radius`): the points `p` with `(p − center) · open ≤ 0`.
#[derive(Clone, Debug)]
pub struct Hemisphere {
    center: DVec3,
    radius: f64,
    open: DVec3,
}

/// The `hemisphere` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "hemisphere",
    summary: "The report's bowl: half a sphere, open toward `open`. Shaded inside and outside; shadows itself. An open surface (transmits as a thin sheet).",
    params: &[
        ParamSpec::new("center", ParamKind::Vec3, ParamDefault::Vec3([0.0, 0.0, 0.0]), "centre of the full sphere, scene units"),
        ParamSpec::new("radius", ParamKind::Float, ParamDefault::Float(1.0), "radius, scene units, > 0"),
        ParamSpec::new(
            "open",
            ParamKind::Vec3,
            ParamDefault::Vec3([0.0, 1.0, 0.0]),
            "direction from the centre toward the open side; the bottom of the bowl is at center − radius·open",
        ),
    ],
};

/// Builds a hemisphere from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let center = p.vec3("center")?;
    let radius = p.positive("radius")?;
    let open = p.direction("open")?;
    Ok(Box::new(Hemisphere { center, radius, open }))
}

impl Hemisphere {
    /// A bowl; `open` must be unit length and `radius` > 0.
    pub fn new(center: DVec3, radius: f64, open: DVec3) -> Self {
        Hemisphere { center, radius, open }
    }

    /// The lowest point of the bowl (the report's `bottom`).
    pub fn bottom(&self) -> DVec3 {
        self.center - self.radius * self.open
    }
}

impl Intersectable for Hemisphere {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let f = ray.origin - self.center;
        for (t, err) in sphere_roots(f, ray.dir, self.radius, on_surface_slack(ray.origin, self.center))? {
            if !(t > t_min && t > err && t < t_max) {
                continue;
            }
            let mut local = f + t * ray.dir;
            local *= self.radius / local.length();
            if local.dot(self.open) > 0.0 {
                continue;
            }
            let point = self.center + local;
            let error = gamma(6) * (local.abs() + point.abs());
            return Some(Hit { t, point, error, uv: DVec2::ZERO, prim: 0, object: 0 });
        }
        None
    }
}

impl Geometry for Hemisphere {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        (at.point - self.center).normalize()
    }
    /// Longitude around `open`, and 0 at the bottom to 1 at the rim ([`super::uv`]).
    fn uv(&self, at: &Hit) -> DVec2 {
        let d = (at.point - self.center).normalize();
        let from_bottom = (-d.dot(self.open)).clamp(-1.0, 1.0).acos() / std::f64::consts::FRAC_PI_2;
        DVec2::new(super::uv::longitude(d, super::uv::around_frame(self.open)), from_bottom.min(1.0))
    }
    /// Around `open` as the sphere's around +y; from the bottom by the angle from `-open`.
    fn derivatives(&self, at: &Hit) -> Option<SurfaceDerivatives> {
        let d = (at.point - self.center).normalize();
        let (x, z) = super::uv::around_frame(self.open);
        let dpdu = TAU * self.radius * (d.dot(z) * x - d.dot(x) * z);
        let radial = d - d.dot(self.open) * self.open;
        let sin = radial.length();
        let e = if sin > 0.0 { radial / sin } else { DVec3::ZERO };
        let dpdv = std::f64::consts::FRAC_PI_2 * self.radius * (sin * self.open - d.dot(self.open) * e);
        Some(SurfaceDerivatives { dpdu, dpdv, dndu: dpdu / self.radius, dndv: dpdv / self.radius })
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(self.center - DVec3::splat(self.radius), self.center + DVec3::splat(self.radius)))
    }
    /// A patch of a sphere, outward as the sphere.
    fn is_convex(&self) -> bool {
        true
    }
    fn area(&self) -> Option<f64> {
        Some(TAU * self.radius * self.radius)
    }
    /// Uniform by area: the height below the rim is uniform (Archimedes), the longitude too.
    fn sample_surface(&self, reference: DVec3, u: DVec2) -> Option<SurfaceSample> {
        let down = u.x;
        let ring = (1.0 - down * down).max(0.0).sqrt();
        let (x, z) = super::uv::around_frame(self.open);
        let (s, c) = (TAU * u.y).sin_cos();
        let n = (x * c + z * s) * ring - self.open * down;
        let local = self.radius * n;
        let point = self.center + local;
        let pdf = SurfacePdf::Area(1.0 / (TAU * self.radius * self.radius));
        Some(SurfaceSample::new(reference, point, gamma(6) * (local.abs() + point.abs()), n, pdf))
    }
    fn surface_pdf(&self, _: DVec3, _: &Hit) -> SurfacePdf {
        SurfacePdf::Area(1.0 / (TAU * self.radius * self.radius))
    }
}

// The shape harnesses' view of it (raylab::geometry::samples): its exact surface, written from
// the definition above and not from the intersection code, and random valid instances.

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

/// Random bowls for the shape harnesses.
pub const SAMPLERS: &[ShapeSampler] = &[ShapeSampler { name: "hemisphere", sample }];

fn sample(d: &mut dyn Draw, center: DVec3, s: f64) -> Option<ShapeSample> {
    let (radius, open) = (d.length(s, 1.0)?, d.direction()?);
    Some(ShapeSample::round(Box::new(Hemisphere::new(center, radius, open)), Box::new(ExactBowl { center, radius, open }), center, radius))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::test_support::*;
    use proptest::prelude::*;
    use raylab::geometry::testing::{Tolerance, check_hits_ascending};
    use raylab::math::float::max_abs;

    fn bowl() -> impl Strategy<Value = (Hemisphere, ExactBowl, f64)> {
        (scale(), cube(), 0.05..2.0f64, unit()).prop_map(|(s, c, r, open)| {
            let (center, radius) = (5.0 * s * c, s * r);
            (Hemisphere::new(center, radius, open), ExactBowl { center, radius, open }, max_abs(center) + radius)
        })
    }

    proptest! {
        #![proptest_config(config(CASES))]

        /// The oracle is the bowl alone: a hit on the cut half would be off its surface.
        #[test]
        fn hits_are_exact_ascending_and_on_the_bowl((g, exact, mag) in bowl(), aim in aim(), win in windows()) {
            let ray = aim.ray(exact.center, exact.radius);
            let tol = tolerance(mag, &ray);
            for h in check_ray(&g, &ray, &tol, &exact, 2, &win)? {
                prop_assert!((h.point - exact.center).dot(exact.open) <= tol.distance(h.t, h.point));
            }
        }

        #[test]
        fn a_ray_pointing_away_misses((g, _, _) in bowl(), w in unit(), v in unit(), gap in 0.0..3.0f64) {
            let ray = away_ray(g.bounds().unwrap(), w, v, gap);
            prop_assert!(g.intersect(&ray, 0.0, f64::INFINITY).is_none());
            prop_assert!(!g.occludes(&ray, 0.0, f64::INFINITY));
        }

        /// Toward the centre from the closed side: the outside of the bowl; from the open side:
        /// straight through the opening onto the inner wall.
        #[test]
        fn a_ray_toward_the_centre_hits((g, exact, mag) in bowl(), w in unit(), gap in 1e-3..4.0f64) {
            let side = w.dot(exact.open);
            prop_assume!(side.abs() > 1e-3);
            let origin = exact.center + exact.radius * (1.0 + gap) * w;
            let ray = Ray::new(origin, -w);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 2, &[])?;
            prop_assert_eq!(hits.len(), 1);
            let dist = (origin - exact.center).length();
            let expected = if side < 0.0 { dist - exact.radius } else { dist + exact.radius };
            close("t", hits[0].t, expected, tol.distance(dist, origin))?;
            // The normal faces the viewer: outward on the closed side, inward (toward the centre)
            // on the far wall seen through the opening; both times back along the ray.
            let n = g.normal(&hits[0], ray.dir);
            prop_assert!((n - w).length() < 1e-9, "normal {} for side {}", n, side);
            let outward = g.outward_normal(&hits[0]);
            prop_assert!((outward - -side.signum() * w).length() < 1e-9, "outward normal {}", outward);
        }

        /// Through the opening onto any point of the inner wall that it can see.
        #[test]
        fn the_inner_wall_is_visible_through_the_opening(
            (g, exact, mag) in bowl(), u in unit(), lateral in cube(), up in 0.2..3.0f64,
        ) {
            let u = if u.dot(exact.open) > 0.0 { u - 2.0 * u.dot(exact.open) * exact.open } else { u };
            prop_assume!(u.dot(exact.open) < -0.02);
            let target = exact.center + exact.radius * u;
            let flat = lateral - lateral.dot(exact.open) * exact.open;
            let origin = exact.center + exact.radius * ((1.0 + up) * exact.open + 0.9 * flat);
            let ray = Ray::new(origin, target - origin);
            // The ray must cross the cut plane inside the opening, then meet the wall first at `target`.
            let t_plane = (origin - exact.center).dot(exact.open) / -ray.dir.dot(exact.open);
            prop_assume!((ray.at(t_plane) - exact.center).length() < 0.999 * exact.radius);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 2, &[])?;
            prop_assert!(!hits.is_empty());
            let dist = (target - origin).length();
            close("t", hits[0].t, dist, tol.distance(dist, origin) / u.dot(-ray.dir).abs().max(1e-3))?;
            let n = g.normal(&hits[0], ray.dir);
            prop_assert!((n + u).length() < 1e-6, "inner normal {} should point to the centre ({})", n, -u);
        }

        /// No crack at the rim: a ray through any point just inside it (1e-10 radians, well above
        /// the rounding of the ray itself), from any side, hits the bowl there.
        #[test]
        fn rays_just_inside_the_rim_hit_it((g, exact, mag) in bowl(), phi in 0.0..std::f64::consts::TAU, from in unit(), dist in 0.2..3.0f64) {
            let (w, delta) = (perpendicular(exact.open, phi), 1e-10f64);
            let rim = exact.center + exact.radius * (delta.cos() * w - delta.sin() * exact.open);
            let origin = rim + dist * exact.radius * from;
            let ray = Ray::new(origin, rim - origin);
            // Not tangent to the sphere there.
            prop_assume!(ray.dir.dot((rim - exact.center) / exact.radius).abs() > 1e-3);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 2, &[])?;
            let at_rim = (rim - origin).length();
            prop_assert!(
                hits.iter().any(|h| (h.point - rim).length() <= 1e3 * tol.distance(at_rim, rim)),
                "no hit at the rim {} among {:?}", rim, hits
            );
        }

        #[test]
        fn grazing_rays_keep_every_contract(
            (g, exact, mag) in bowl(), u in unit(), phi in 0.0..std::f64::consts::TAU,
            tilt in -8.0..-1.0f64, inward in any::<bool>(), back in 0.2..3.0f64,
        ) {
            let p = exact.center + exact.radius * u;
            let eps = 10f64.powf(tilt) * if inward { -1.0 } else { 1.0 };
            let dir = (perpendicular(u, phi) + eps * u).normalize();
            let ray = Ray::new(p - back * exact.radius * dir, dir);
            check_ray(&g, &ray, &tolerance(mag, &ray), &exact, 2, &[])?;
        }

        /// From a point of the bowl: outward, nothing; inward, at most the opposite wall, if that
        /// point is on the bowl.
        #[test]
        fn a_ray_starting_on_the_bowl_does_not_hit_it_again((g, exact, mag) in bowl(), u in unit(), d in unit()) {
            let u = if u.dot(exact.open) > 0.0 { -u } else { u };
            let cos = d.dot(u);
            prop_assume!(cos.abs() > 0.05);
            let ray = Ray::new(exact.center + exact.radius * u, d);
            let tol = tolerance(mag, &ray);
            let hits = check_ray(&g, &ray, &tol, &exact, 1, &[])?;
            let far = ray.at(-2.0 * exact.radius * cos);
            let far_height = (far - exact.center).dot(exact.open);
            prop_assume!(far_height.abs() > 1e-6 * exact.radius);
            let expected = usize::from(cos < 0.0 && far_height < 0.0);
            prop_assert_eq!(hits.len(), expected);
        }
    }

    fn unit_bowl() -> (Hemisphere, ExactBowl) {
        (Hemisphere::new(DVec3::ZERO, 1.0, DVec3::Y), ExactBowl { center: DVec3::ZERO, radius: 1.0, open: DVec3::Y })
    }

    fn hits(g: &Hemisphere, exact: &ExactBowl, ray: &Ray) -> Vec<Hit> {
        check_hits_ascending(g, ray, &Tolerance::for_scale(10.0), exact, 2).unwrap_or_else(|v| panic!("{v}"))
    }

    #[test]
    fn the_inside_is_seen_from_above_with_the_normal_toward_the_viewer() {
        let (g, exact) = unit_bowl();
        let ray = Ray::new(DVec3::new(0.0, 2.0, 0.0), -DVec3::Y);
        let h = hits(&g, &exact, &ray);
        assert_eq!(h.len(), 1, "the cut half above is not part of the bowl");
        assert_eq!((h[0].t, h[0].point), (3.0, -DVec3::Y));
        assert_eq!((g.outward_normal(&h[0]), g.normal(&h[0], ray.dir)), (-DVec3::Y, DVec3::Y));
        assert_eq!(g.bottom(), -DVec3::Y);
    }

    #[test]
    fn the_outside_is_seen_from_below_and_the_cut_half_is_never_reported() {
        let (g, exact) = unit_bowl();
        let ray = Ray::new(DVec3::new(0.0, -3.0, 0.0), DVec3::Y);
        let h = hits(&g, &exact, &ray);
        assert_eq!(h.len(), 1);
        assert_eq!((h[0].t, g.normal(&h[0], ray.dir)), (2.0, -DVec3::Y));
        // Rays that meet only the cut half miss.
        for origin in [DVec3::new(0.5, 3.0, 0.0), DVec3::new(-3.0, 0.5, 0.2)] {
            let ray = Ray::new(origin, if origin.y > 1.0 { DVec3::new(0.0, -1.0, 0.0) } else { DVec3::new(1.0, 0.0, 0.0) });
            let cut = hits(&g, &exact, &ray);
            assert!(cut.iter().all(|h| h.point.y <= 0.0), "cut half reported: {cut:?}");
        }
        let above_only = Ray::new(DVec3::new(-3.0, 0.5, 0.0), DVec3::X);
        assert!(hits(&g, &exact, &above_only).is_empty());
    }

    #[test]
    fn the_rim_belongs_to_the_bowl() {
        let (g, exact) = unit_bowl();
        // Through the rim at (1, 0, 0) and (−1, 0, 0), in the cut plane.
        let ray = Ray::new(DVec3::new(3.0, 0.0, 0.0), -DVec3::X);
        let h = hits(&g, &exact, &ray);
        assert_eq!(h.iter().map(|h| h.t).collect::<Vec<_>>(), [2.0, 4.0]);
        // Down onto the rim from above, tangent to the sphere: at most the rim point.
        let ray = Ray::new(DVec3::new(0.0, 3.0, 1.0), -DVec3::Y);
        for h in hits(&g, &exact, &ray) {
            assert!((h.point - DVec3::Z).length() < 1e-7, "{:?}", h.point);
        }
    }

    #[test]
    fn a_ray_from_the_inner_wall_sees_the_opposite_wall() {
        let (g, exact) = unit_bowl();
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let ray = Ray::new(DVec3::new(-s, -s, 0.0), DVec3::X);
        let h = hits(&g, &exact, &ray);
        assert_eq!(h.len(), 1);
        assert!((h[0].point - DVec3::new(s, -s, 0.0)).length() < 1e-15);
        assert!((g.normal(&h[0], ray.dir) - DVec3::new(-s, s, 0.0)).length() < 1e-15);
        // Leaving through the opening: nothing.
        assert!(g.intersect(&Ray::new(DVec3::new(-s, -s, 0.0), DVec3::new(1.0, 3.0, 0.0)), 0.0, f64::INFINITY).is_none());
    }

    // Regressions: literal cases the properties found.

    /// A large bowl far from the origin: a ray from its inner wall out through the opening re-hit
    /// the wall at t ≈ 0.
    #[test]
    fn bad_case_a_ray_from_a_far_bowl_hit_it_again() {
        let (center, radius, open) =
            (DVec3::new(-34417.1139580764, -38967.203278238885, 0.0), 500.0, DVec3::new(-0.7042642209588147, 0.7099379600199399, 0.0));
        let g = Hemisphere::new(center, radius, open);
        let u = DVec3::new(-0.6191611402231467, 0.7852639571746387, 0.0);
        let u = if u.dot(open) > 0.0 { -u } else { u };
        let ray = Ray::new(center + radius * u, DVec3::new(-0.9223807222973924, 0.3862820253831915, 0.0));
        let far = ray.at(-2.0 * radius * ray.dir.dot(u));
        assert!(ray.dir.dot(u) < 0.0 && (far - center).dot(open) > 0.0, "into the sphere and out through the opening");
        assert_eq!(g.intersect(&ray, 0.0, f64::INFINITY), None);
    }
}
