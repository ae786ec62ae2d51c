//! `torus`: a ring torus, the surface at distance `minor_radius` from a circle of radius
//! `major_radius` around `axis` through `center`. A closed solid (refraction bends rays at it).
//!
//! The ray–torus intersection is a quartic in `t`. Numerics:
//!
//! - **Origin moved near the torus.** A ray starting far away is first advanced to its entry into
//!   the torus's bounding sphere, so the quartic's coefficients are of the torus's own size, not
//!   the (possibly enormous) distance to it.
//! - **No cancellation in the coefficients.** Every term is written with components perpendicular
//!   to the axis, and the constant term is factored as
//!   `((ρ − R)² + z² − r²) · (|q|² + R² − r² + 2Rρ)`, accurate even when the origin is on the surface.
//! - **Robust roots.** [`crate::roots::first_quartic_root`] isolates each root between the
//!   critical points and polishes it with safeguarded Newton steps: no closed-form formula to lose
//!   digits. Only the first acceptable root is computed, and only where the ray is inside the
//!   bounding sphere and the slab `|z| ≤ r` around the torus's plane.
//! - **Exact surface point.** The hit point is projected onto the torus (nearest point on the core
//!   circle, then out by `r`), and a root within its own error bound of the origin is rejected, so
//!   a ray leaving the surface never reports it again.

use crate::roots::first_quartic_root;
use raylab::geometry::samples::{Draw, Form, ShapeSample, ShapeSampler};
use raylab::geometry::testing::ExactSurface;
use raylab::geometry::{Geometry, Hit, Intersectable};
use raylab::glam::{DVec2, DVec3};
use raylab::math::bounds::circle_extent;
use raylab::math::float::{gamma, max_abs};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Aabb, LoadContext, PluginInfo, Ray};
use std::f64::consts::TAU;

/// The `torus` plugin's description: its type name, summary and parameter table.
pub const INFO: PluginInfo = PluginInfo {
    name: "torus",
    summary: "A ring torus (a doughnut): the points at distance minor_radius from a circle of major_radius around axis through center. A closed solid. uv = (angle around the axis, angle around the tube) / 2π.",
    params: &[
        ParamSpec::new("center", ParamKind::Vec3, ParamDefault::Vec3([0.0, 0.0, 0.0]), "centre of the hole, scene units"),
        ParamSpec::new("axis", ParamKind::Vec3, ParamDefault::Vec3([0.0, 1.0, 0.0]), "axis of symmetry through the hole (any length > 0)"),
        ParamSpec::new(
            "major_radius",
            ParamKind::Float,
            ParamDefault::Float(1.0),
            "radius R of the tube's centre circle, scene units, > 0",
        ),
        ParamSpec::new("minor_radius", ParamKind::Float, ParamDefault::Float(0.25), "radius r of the tube, scene units, 0 < r < R"),
    ],
};

/// Builds a torus from its parameters (the registry calls this for `type = "torus"`).
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Geometry>> {
    let center = p.vec3("center")?;
    let axis = p.direction("axis")?;
    let major = p.positive("major_radius")?;
    let minor = p.positive("minor_radius")?;
    if minor >= major {
        return Err(p.error_at("minor_radius", format_args!("{minor} must be smaller than major_radius {major} (a ring torus)")));
    }
    Ok(Box::new(Torus::new(center, axis, major, minor)))
}

/// A ring torus. Invariants: `axis` unit, `0 < minor < major`, all finite.
#[derive(Clone, Debug)]
pub struct Torus {
    center: DVec3,
    axis: DVec3,
    /// `u`, `v`, `axis`: an orthonormal frame (for `uv` only).
    u: DVec3,
    v: DVec3,
    major: f64,
    minor: f64,
}

impl Torus {
    /// A torus; `axis` must be unit length and `0 < minor < major`.
    pub fn new(center: DVec3, axis: DVec3, major: f64, minor: f64) -> Self {
        let (u, v) = axis.any_orthonormal_pair();
        Torus { center, axis, u, v, major, minor }
    }

    /// Signed distance from `p` to the surface (negative inside the tube).
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        let q = p - self.center;
        let z = q.dot(self.axis);
        let rho = (q - z * self.axis).length();
        (rho - self.major).hypot(z) - self.minor
    }

    /// The point of the surface nearest `q` (relative to the centre), and the unit outward normal
    /// there. `None` on the core circle or the axis, where the nearest point is not unique.
    fn project(&self, q: DVec3) -> Option<(DVec3, DVec3)> {
        let z = q.dot(self.axis);
        let perp = q - z * self.axis;
        let rho = perp.length();
        if !(rho > 0.0) {
            return None;
        }
        let core = perp * (self.major / rho);
        let w = q - core;
        let len = w.length();
        if !(len > 0.0) {
            return None;
        }
        let n = w / len;
        Some((core + self.minor * n, n))
    }

    /// Radius of the bounding sphere around the centre (a little more than `major + minor`, so
    /// rounding in the sphere test never clips the torus).
    fn bounding_radius(&self) -> f64 {
        (self.major + self.minor) * (1.0 + 1e-9)
    }
}

impl Torus {
    /// The first root with `t_min < t < t_max`: its `t` and the point `ray.at(t)` relative to the
    /// centre (computed near the torus, not from the far origin).
    fn first_root(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
        let (r_big, r_small) = (self.major, self.minor);
        let d = ray.dir;
        let f = ray.origin - self.center;

        // Bounding sphere: skip misses, and move a far origin to just before the entry point.
        let b_rad = self.bounding_radius();
        let b = f.dot(d);
        let closest = f - b * d;
        let disc = b_rad * b_rad - closest.length_squared();
        if disc < 0.0 {
            return None;
        }
        let h = disc.sqrt();
        let (t_enter, t_exit) = (-b - h, -b + h);
        if t_exit <= t_min || t_enter >= t_max {
            return None;
        }
        // Start a quarter of the torus's size before the sphere (well beyond the rounding of
        // `t_enter`, which grows with the distance), so the new origin is surely outside.
        let margin = 0.25 * (r_big + r_small) + 8.0 * f64::EPSILON * t_enter.abs();
        let t0 = (t_enter - margin).max(0.0);
        let q = f + t0 * d;

        // Quartic in s = t − t0, from |p|² + R² − r² squared against 4R²ρ².
        let qa = q.dot(self.axis);
        let da = d.dot(self.axis);
        let q_perp = q - qa * self.axis;
        let d_perp = d - da * self.axis;
        let qd = q.dot(d);
        let rho = q_perp.length();
        let k = q.length_squared() + r_big * r_big - r_small * r_small;
        let tube = (rho - r_big) * (rho - r_big) + qa * qa - r_small * r_small;
        let c = [
            tube * (k + 2.0 * r_big * rho),
            4.0 * qd * k - 8.0 * r_big * r_big * q_perp.dot(d_perp),
            4.0 * qd * qd + 2.0 * k - 4.0 * r_big * r_big * d_perp.length_squared(),
            4.0 * qd,
            1.0,
        ];
        // Rounding-error bound of the constant term: how far from 0 a root may be and still be
        // the surface the origin lies on.
        let k_abs = q.length_squared() + r_big * r_big + r_small * r_small;
        let c0_err = gamma(12) * ((rho + r_big) * (rho + r_big) + qa * qa + r_small * r_small) * (k_abs + 2.0 * r_big * rho);

        // Roots from the (shifted) origin to beyond the sphere, whatever t_min and t_max (rays
        // start at t ≥ 0), so asking again from a hit's t never finds that root a hair further on;
        // only where the ray is within the slab |z| ≤ r around the torus's plane.
        let (mut lo, mut hi) = (0.0, t_exit + margin - t0);
        let slab = r_small + 1e-9 * (r_big + r_small);
        if da == 0.0 {
            if qa.abs() > slab {
                return None;
            }
        } else {
            let (s0, s1) = ((-slab - qa) / da, (slab - qa) / da);
            lo = f64::max(lo, s0.min(s1));
            hi = f64::min(hi, s0.max(s1));
            if !(lo < hi) {
                return None;
            }
        }
        let s = first_quartic_root(&c, lo, hi, |s| {
            // A root within c0_err / |f'(s)| of the origin is the surface the ray starts on.
            let slope = (c[1] + s * (2.0 * c[2] + s * (3.0 * c[3] + 4.0 * s))).abs();
            if t0 == 0.0 && s.abs() * slope <= c0_err {
                return false;
            }
            t0 + s > t_min && t0 + s < t_max
        })?;
        Some((t0 + s, q + s * d))
    }
}

impl Intersectable for Torus {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let (t, along) = self.first_root(ray, t_min, t_max)?;
        let local = self.project(along).map_or(along, |(p, _)| p);
        let point = self.center + local;
        let error = gamma(10) * (local.abs() + point.abs() + DVec3::splat(self.major + self.minor));
        Some(Hit::new(t, point, error))
    }

    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.first_root(ray, t_min, t_max).is_some()
    }
}

impl Geometry for Torus {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        self.project(at.point - self.center).map_or(self.axis, |(_, n)| n)
    }
    /// Asked only where a textured material is hit, so `intersect` does not pay for it.
    fn uv(&self, at: &Hit) -> DVec2 {
        let local = at.point - self.center;
        let z = local.dot(self.axis);
        let around = local.dot(self.v).atan2(local.dot(self.u));
        let tube_angle = z.atan2((local - z * self.axis).length() - self.major);
        DVec2::new(around.rem_euclid(TAU) / TAU, tube_angle.rem_euclid(TAU) / TAU)
    }
    fn bounds(&self) -> Option<Aabb> {
        // Per world axis i: r + R·sin(angle between axis and e_i).
        let ext = circle_extent(self.axis, self.major) + DVec3::splat(self.minor);
        Some(Aabb::new(self.center - ext, self.center + ext))
    }
    fn is_closed(&self) -> bool {
        true
    }
}

/// The exact torus, from its definition (the points at `minor` from the core circle), not from
/// the quartic: the oracle raylab's shape harnesses check every hit against.
#[derive(Clone, Copy, Debug)]
pub struct ExactTorus {
    /// Centre of the hole.
    pub center: DVec3,
    /// Unit axis.
    pub axis: DVec3,
    /// Radius of the core circle.
    pub major: f64,
    /// Radius of the tube.
    pub minor: f64,
}

impl ExactSurface for ExactTorus {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let q = p - self.center;
        let z = q.dot(self.axis);
        ((q - z * self.axis).length() - self.major).hypot(z) - self.minor
    }
    fn outward_normal(&self, p: DVec3) -> DVec3 {
        let q = p - self.center;
        let core = self.major * (q - q.dot(self.axis) * self.axis).normalize();
        (q - core).normalize()
    }
}

/// Random tori for raylab's shape harnesses ([`raylab::geometry::samples`]): registered with the
/// torus, they put it through the same property and fuzz checks as the built-in shapes.
pub const SAMPLERS: &[ShapeSampler] = &[ShapeSampler { name: "torus", sample }];

/// A torus around `center` with a major radius of about `s` and a tube 0.05 to 0.95 of it.
fn sample(d: &mut dyn Draw, center: DVec3, s: f64) -> Option<ShapeSample> {
    let axis = d.direction()?;
    let major = d.length(s, 1.0)?;
    let minor = major * (0.05 + 0.9 * d.uniform());
    Some(ShapeSample {
        geometry: Box::new(Torus::new(center, axis, major, minor)),
        exact: Box::new(ExactTorus { center, axis, major, minor }),
        center,
        size: major + minor,
        magnitude: max_abs(center) + major + minor,
        max_hits: 4,
        aspect: 1.0,
        curvature_radius: minor,
        // Not convex: the reintersection campaign makes no claim; tests/torus.rs checks that
        // secondary rays neither self-hit nor leak.
        form: Form::Other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn torus() -> Torus {
        Torus::new(DVec3::ZERO, DVec3::Y, 2.0, 0.5)
    }

    /// The torus's exact surface ([`ExactTorus`]).
    fn exact(t: &Torus) -> ExactTorus {
        ExactTorus { center: t.center, axis: t.axis, major: t.major, minor: t.minor }
    }

    /// The `t` of every hit, each checked by `raylab::geometry::testing`.
    fn hit_ts(t: &Torus, ray: &Ray) -> Vec<f64> {
        let tol = raylab::geometry::testing::Tolerance::for_scale(20.0);
        let hits = raylab::geometry::testing::check_hits_ascending(t, ray, &tol, &exact(t), 8).unwrap_or_else(|v| panic!("{v}"));
        hits.iter().map(|h| h.t).collect()
    }

    #[test]
    fn a_ray_through_the_equator_hits_four_times() {
        let t = torus();
        let ray = Ray::new(DVec3::new(-10.0, 0.0, 0.0), DVec3::X);
        let ts = hit_ts(&t, &ray);
        let want = [7.5, 8.5, 11.5, 12.5];
        assert_eq!(ts.len(), 4, "{ts:?}");
        for (got, w) in ts.iter().zip(want) {
            assert!((got - w).abs() < 1e-12, "{got} vs {w}");
        }
    }

    #[test]
    fn the_hole_is_empty_and_a_ray_above_the_tube_misses() {
        let t = torus();
        assert!(t.intersect(&Ray::new(DVec3::new(0.0, 10.0, 0.0), DVec3::NEG_Y), 0.0, f64::INFINITY).is_none());
        assert!(t.intersect(&Ray::new(DVec3::new(0.0, 0.6, -10.0), DVec3::Z), 0.0, f64::INFINITY).is_none(), "just above the tube");
        let ray = Ray::new(DVec3::new(0.0, 0.4, -10.0), DVec3::Z);
        let ts = hit_ts(&t, &ray);
        assert_eq!(ts.len(), 4, "{ts:?}");
        for (got, w) in ts.iter().zip([7.7, 8.3, 11.7, 12.3]) {
            assert!((got - w).abs() < 1e-12, "{got} vs {w}");
        }
    }

    #[test]
    fn far_away_rays_keep_full_precision() {
        let t = torus();
        for dist in [1e3, 1e6, 1e9] {
            let ray = Ray::new(DVec3::new(-dist, 0.0, 0.0), DVec3::X);
            let h = t.intersect(&ray, 0.0, f64::INFINITY).expect("hit");
            assert!((h.t - (dist - 2.5)).abs() <= 4.0 * f64::EPSILON * dist, "{dist}: t = {}", h.t);
            assert!((h.point - DVec3::new(-2.5, 0.0, 0.0)).length() < 1e-12, "{}", h.point);
        }
    }

    #[test]
    fn bounds_are_tight_for_a_tilted_axis() {
        let axis = DVec3::new(1.0, 1.0, 0.0).normalize();
        let t = Torus::new(DVec3::new(1.0, 2.0, 3.0), axis, 2.0, 0.5);
        let b = t.bounds().unwrap();
        let mut seen = Aabb::EMPTY;
        for i in 0..360 {
            for j in 0..72 {
                let (a, c) = (f64::from(i).to_radians(), f64::from(j) * 5f64.to_radians());
                let ring = a.cos() * t.u + a.sin() * t.v;
                let p = t.center + (2.0 + 0.5 * c.cos()) * ring + 0.5 * c.sin() * axis;
                assert!(b.contains(p), "{p} outside {b:?}");
                seen = seen.union(Aabb::new(p, p));
            }
        }
        assert!((seen.extent() - b.extent()).abs().max_element() < 1e-3, "{seen:?} vs {b:?}");
    }
}
