//! Ray differentials and texture footprints (Igehy 1999, "Tracing Ray Differentials"; pbrt-v3
//! §10.1): how a ray and its hit move from one pixel to the next, so that a texture can be
//! looked up over the area a pixel covers instead of at one point.
//!
//! - [`RayDifferential`]: the derivatives of a ray's origin and unit direction with respect to
//!   the image's x and y (one pixel right, one pixel down). Camera rays have exact ones
//!   ([`crate::scene::camera::Camera::differential`]); mirror reflection and refraction carry
//!   them on ([`RayDifferential::reflect`], [`RayDifferential::refract`]).
//! - [`RaySpread`]: what a ray knows of its spread: nothing (filtering is off: nothing is
//!   computed), an exact differential, or, after a diffuse or glossy bounce, pbrt-v4's
//!   approximation: the footprint the camera's pixel spread would have at the hit seen directly.
//! - [`SurfaceDerivatives`]: how a surface point and its normal move with its texture
//!   coordinates (`∂p/∂u`, `∂p/∂v`, `∂n/∂u`, `∂n/∂v`), answered by shapes
//!   ([`crate::Geometry::derivatives`]).
//! - [`Footprint`]: what a texture lookup receives: the derivatives of the texture coordinates
//!   and of the point in the shape's own frame with respect to x and y.

use glam::{DMat2, DVec2, DVec3};

/// How a texture lookup's coordinates change from one pixel to the next: the derivatives of the
/// texture coordinates (`uv`) and of the point in the shape's own frame (`local`) with respect to
/// the image's x (one pixel right) and y (one pixel down). All zero ([`Footprint::POINT`]): a
/// point lookup, as when filtering is off.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Footprint {
    /// ∂uv/∂x.
    pub duv_dx: DVec2,
    /// ∂uv/∂y.
    pub duv_dy: DVec2,
    /// ∂uv₁/∂x: the second texture-coordinate set's ([`crate::Geometry::uv1`]; the first's
    /// where the shape has one set).
    pub duv1_dx: DVec2,
    /// ∂uv₁/∂y.
    pub duv1_dy: DVec2,
    /// ∂local/∂x.
    pub dlocal_dx: DVec3,
    /// ∂local/∂y.
    pub dlocal_dy: DVec3,
}

impl Footprint {
    /// No footprint: a point lookup.
    pub const POINT: Footprint = Footprint {
        duv_dx: DVec2::ZERO,
        duv_dy: DVec2::ZERO,
        duv1_dx: DVec2::ZERO,
        duv1_dy: DVec2::ZERO,
        dlocal_dx: DVec3::ZERO,
        dlocal_dy: DVec3::ZERO,
    };

    /// True when there is no footprint (a point lookup).
    #[inline]
    pub fn is_point(&self) -> bool {
        *self == Footprint::POINT
    }

    /// The footprint with every derivative finite (a non-finite one, from a degenerate hit,
    /// becomes 0: a point lookup in that direction).
    #[inline]
    pub fn finite(self) -> Footprint {
        let v2 = |v: DVec2| if v.is_finite() { v } else { DVec2::ZERO };
        let v3 = |v: DVec3| if v.is_finite() { v } else { DVec3::ZERO };
        Footprint {
            duv_dx: v2(self.duv_dx),
            duv_dy: v2(self.duv_dy),
            duv1_dx: v2(self.duv1_dx),
            duv1_dy: v2(self.duv1_dy),
            dlocal_dx: v3(self.dlocal_dx),
            dlocal_dy: v3(self.dlocal_dy),
        }
    }

    /// This footprint with the second texture-coordinate set's derivatives carried from the
    /// first's by `j` = ∂uv₁/∂uv (columns ∂uv₁/∂u, ∂uv₁/∂v: [`crate::Geometry::uv1`]).
    #[inline]
    pub fn with_second_set(mut self, j: DMat2) -> Footprint {
        (self.duv1_dx, self.duv1_dy) = (j * self.duv_dx, j * self.duv_dy);
        self.finite()
    }
}

/// How a surface point and its outward normal move with the surface's texture coordinates at a
/// hit: `∂p/∂u`, `∂p/∂v` (tangent to the surface) and `∂n/∂u`, `∂n/∂v` (zero for a flat surface).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SurfaceDerivatives {
    /// ∂p/∂u.
    pub dpdu: DVec3,
    /// ∂p/∂v.
    pub dpdv: DVec3,
    /// ∂n/∂u.
    pub dndu: DVec3,
    /// ∂n/∂v.
    pub dndv: DVec3,
}

impl SurfaceDerivatives {
    /// A flat surface's: the normal does not turn.
    pub const fn flat(dpdu: DVec3, dpdv: DVec3) -> SurfaceDerivatives {
        SurfaceDerivatives { dpdu, dpdv, dndu: DVec3::ZERO, dndv: DVec3::ZERO }
    }

    /// The texture-coordinate change `(du, dv)` of a move `dp` on the surface's tangent plane:
    /// the least-squares solution of `dp = du·∂p/∂u + dv·∂p/∂v` (pbrt-v3 §10.1.1); zero where
    /// the derivatives are degenerate.
    #[inline]
    pub fn uv_of(&self, dp: DVec3) -> DVec2 {
        let (a00, a01, a11) = (self.dpdu.dot(self.dpdu), self.dpdu.dot(self.dpdv), self.dpdv.dot(self.dpdv));
        let det = a00 * a11 - a01 * a01;
        if !(det.abs() > f64::MIN_POSITIVE) || !det.is_finite() {
            return DVec2::ZERO;
        }
        let (b0, b1) = (self.dpdu.dot(dp), self.dpdv.dot(dp));
        let d = DVec2::new((a11 * b0 - a01 * b1) / det, (a00 * b1 - a01 * b0) / det);
        if d.is_finite() { d } else { DVec2::ZERO }
    }

    /// The normal's change for a move `dp` on the tangent plane: `∂n/∂u·du + ∂n/∂v·dv`.
    #[inline]
    pub fn normal_change(&self, dp: DVec3) -> DVec3 {
        let d = self.uv_of(dp);
        self.dndu * d.x + self.dndv * d.y
    }

    /// The footprint of a pixel whose moves on the tangent plane are `dpdx`, `dpdy`, for a
    /// shape whose own frame is the world's.
    #[inline]
    pub fn footprint(&self, dpdx: DVec3, dpdy: DVec3) -> Footprint {
        let (duv_dx, duv_dy) = (self.uv_of(dpdx), self.uv_of(dpdy));
        Footprint { duv_dx, duv_dy, duv1_dx: duv_dx, duv1_dy: duv_dy, dlocal_dx: dpdx, dlocal_dy: dpdy }
    }
}

/// The derivatives of a ray's origin and unit direction with respect to the image's x and y (one
/// pixel right, one pixel down), after Igehy: the ray through the neighbouring pixel is, to
/// first order, `(origin + dodx) + t·(dir + dddx)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayDifferential {
    /// ∂origin/∂x.
    pub dodx: DVec3,
    /// ∂origin/∂y.
    pub dody: DVec3,
    /// ∂dir/∂x (orthogonal to the unit direction).
    pub dddx: DVec3,
    /// ∂dir/∂y.
    pub dddy: DVec3,
}

impl RayDifferential {
    /// How the hit of a ray along unit `dir` at distance `t` moves on the tangent plane with
    /// normal `n` (any length, not parallel to the plane): `(∂p/∂x, ∂p/∂y)` (Igehy's transfer).
    /// Zero where the ray runs along the plane.
    #[inline]
    pub fn on_plane(&self, dir: DVec3, t: f64, n: DVec3) -> (DVec3, DVec3) {
        let dn = dir.dot(n);
        if !(dn.abs() > 0.0) {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        let move_ = |dodx: DVec3, dddx: DVec3| {
            let d = dodx + t * dddx;
            let p = d - dir * (d.dot(n) / dn);
            if p.is_finite() { p } else { DVec3::ZERO }
        };
        (move_(self.dodx, self.dddx), move_(self.dody, self.dddy))
    }

    /// The differential of the ray mirrored at a hit: the incoming ray along unit `dir` (this
    /// differential), the unit normal `n` at the hit, how the hit moves (`dpdx`, `dpdy`, from
    /// [`RayDifferential::on_plane`]) and how the normal turns with it (`dndx`, `dndy`).
    /// pbrt-v3 §10.1.3: `r = d − 2(d·n)n`, differentiated.
    #[inline]
    pub fn reflect(&self, dir: DVec3, n: DVec3, (dpdx, dpdy): (DVec3, DVec3), (dndx, dndy): (DVec3, DVec3)) -> RayDifferential {
        let dn = dir.dot(n);
        let turn = |dddx: DVec3, dndx: DVec3| {
            let d_dn = dddx.dot(n) + dir.dot(dndx);
            dddx - 2.0 * (dn * dndx + d_dn * n)
        };
        RayDifferential { dodx: dpdx, dody: dpdy, dddx: turn(self.dddx, dndx), dddy: turn(self.dddy, dndy) }
    }

    /// The differential of the ray refracted at a hit into unit direction `t_dir`, with `eta` the
    /// ratio of the refractive indices (incident side over transmitted side); other arguments as
    /// [`RayDifferential::reflect`]. With `n` facing the incoming side (`c = −d·n > 0`), the
    /// refracted direction is `t = η d + (η c − cos θt) n`, `cos θt = √(1 − η²(1 − c²))`, so
    /// `∂t = η ∂d + μ ∂n + ∂μ n` with `μ = η c − cos θt` and `∂μ = (η − η² c / cos θt) ∂c`,
    /// `∂c = −(∂d·n + d·∂n)`.
    #[inline]
    pub fn refract(
        &self,
        dir: DVec3,
        n: DVec3,
        t_dir: DVec3,
        eta: f64,
        (dpdx, dpdy): (DVec3, DVec3),
        (dndx, dndy): (DVec3, DVec3),
    ) -> RayDifferential {
        // The normal facing the incoming side.
        let (n, dndx, dndy) = if dir.dot(n) > 0.0 { (-n, -dndx, -dndy) } else { (n, dndx, dndy) };
        let c = -dir.dot(n);
        let cos_t = -t_dir.dot(n);
        let mu = eta * c - cos_t;
        let turn = |dddx: DVec3, dndx: DVec3| {
            let dc = -(dddx.dot(n) + dir.dot(dndx));
            let dmu = if cos_t > 0.0 { (eta - eta * eta * c / cos_t) * dc } else { 0.0 };
            let d = eta * dddx + mu * dndx + dmu * n;
            if d.is_finite() { d } else { DVec3::ZERO }
        };
        RayDifferential { dodx: dpdx, dody: dpdy, dddx: turn(self.dddx, dndx), dddy: turn(self.dddy, dndy) }
    }

    /// This differential scaled by `s` (the spread of a pixel's samples: pbrt scales by
    /// `1/√spp`).
    #[inline]
    pub fn scaled(self, s: f64) -> RayDifferential {
        RayDifferential { dodx: self.dodx * s, dody: self.dody * s, dddx: self.dddx * s, dddy: self.dddy * s }
    }
}

/// The camera's spread for pbrt-v4's approximate footprints: its eye point and the change of a
/// ray's direction from one pixel to the next (at the image centre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpread {
    /// The eye point.
    pub eye: DVec3,
    /// ∂dir/∂x of the central ray.
    pub dddx: DVec3,
    /// ∂dir/∂y of the central ray.
    pub dddy: DVec3,
}

/// What a ray knows of its spread over the image (see the module's documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum RaySpread {
    /// Nothing: the scene filters no texture (nothing is computed for its rays).
    #[default]
    Off,
    /// An exact differential: a camera ray, or one reflected or refracted specularly.
    Differential(RayDifferential),
    /// After a diffuse or glossy bounce (pbrt-v4 §10.1.2): the footprint at a hit is the one a
    /// camera ray would have there, seen directly from the eye.
    Camera(CameraSpread),
}

impl RaySpread {
    /// How a hit at `point` (distance `t` along the unit direction `dir`) with unit normal `n`
    /// moves on its tangent plane from one pixel to the next; `None` when the spread is off.
    #[inline]
    pub fn on_surface(&self, point: DVec3, dir: DVec3, t: f64, n: DVec3) -> Option<(DVec3, DVec3)> {
        match self {
            RaySpread::Off => None,
            RaySpread::Differential(d) => Some(d.on_plane(dir, t, n)),
            RaySpread::Camera(c) => {
                let to = point - c.eye;
                let dist = to.length();
                let d = RayDifferential { dodx: DVec3::ZERO, dody: DVec3::ZERO, dddx: c.dddx, dddy: c.dddy };
                Some(d.on_plane(to / dist, dist, n))
            }
        }
    }

    /// The spread of a ray scattered diffusely or glossily: the camera's approximation (off
    /// stays off). `camera` is the spread every such ray gets.
    #[inline]
    pub fn scattered(&self, camera: Option<CameraSpread>) -> RaySpread {
        match (self, camera) {
            (RaySpread::Off, _) | (_, None) => RaySpread::Off,
            (_, Some(c)) => RaySpread::Camera(c),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A footprint's second set is the first's carried by `∂uv₁/∂uv`; until then, the first's.
    #[test]
    fn the_second_set_footprint_is_the_first_carried_over() {
        let d = SurfaceDerivatives::flat(DVec3::X, DVec3::Y);
        let f = d.footprint(DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 2.0, 0.0));
        assert_eq!((f.duv1_dx, f.duv1_dy), (f.duv_dx, f.duv_dy));
        // Swapped and mirrored: u₁ = v, v₁ = −2u.
        let g = f.with_second_set(DMat2::from_cols(DVec2::new(0.0, -2.0), DVec2::new(1.0, 0.0)));
        assert_eq!((g.duv1_dx, g.duv1_dy), (DVec2::new(0.0, -2.0), DVec2::new(2.0, 0.0)));
        assert_eq!((g.duv_dx, g.duv_dy), (f.duv_dx, f.duv_dy));
        let h = f.with_second_set(DMat2::from_cols(DVec2::splat(f64::NAN), DVec2::ZERO));
        assert_eq!(h.duv1_dx, DVec2::ZERO);
    }

    /// A plane hit at distance t: the transfer moves the hit by the change of the neighbouring
    /// ray's intersection.
    #[test]
    fn transfer_matches_the_neighbouring_ray_on_a_plane() {
        let n = DVec3::new(0.2, 1.0, -0.1).normalize();
        let plane_d = -1.3; // n·p = plane_d
        let o = DVec3::new(0.1, 2.0, 0.3);
        let dir = DVec3::new(0.3, -1.0, -0.7).normalize();
        let diff = RayDifferential {
            dodx: DVec3::new(0.01, 0.0, 0.002),
            dody: DVec3::new(0.0, 0.003, 0.0),
            dddx: DVec3::new(0.02, 0.01, -0.01),
            dddy: DVec3::new(-0.01, 0.0, 0.03),
        };
        let hit = |o: DVec3, d: DVec3| o + d * ((plane_d - n.dot(o)) / n.dot(d));
        let t = (plane_d - n.dot(o)) / n.dot(dir);
        let (dpdx, dpdy) = diff.on_plane(dir, t, n);
        let h = 1e-6;
        let fx = (hit(o + h * diff.dodx, dir + h * diff.dddx) - hit(o, dir)) / h;
        let fy = (hit(o + h * diff.dody, dir + h * diff.dddy) - hit(o, dir)) / h;
        assert!((fx - dpdx).length() < 1e-5 * fx.length().max(1.0), "{fx} vs {dpdx}");
        assert!((fy - dpdy).length() < 1e-5 * fy.length().max(1.0), "{fy} vs {dpdy}");
    }

    #[test]
    fn uv_of_inverts_the_derivatives() {
        let s = SurfaceDerivatives::flat(DVec3::new(2.0, 0.0, 0.1), DVec3::new(0.3, 0.0, -1.5));
        let d = DVec2::new(0.25, -0.4);
        let got = s.uv_of(s.dpdu * d.x + s.dpdv * d.y);
        assert!((got - d).length() < 1e-12, "{got}");
        assert_eq!(SurfaceDerivatives::flat(DVec3::X, DVec3::X).uv_of(DVec3::Y), DVec2::ZERO, "degenerate: zero");
    }

    /// Refraction's differential against finite differences of Snell's law.
    #[test]
    fn refraction_differential_matches_finite_differences() {
        let refract = |d: DVec3, n: DVec3, eta: f64| {
            let c = -d.dot(n);
            let k = 1.0 - eta * eta * (1.0 - c * c);
            eta * d + (eta * c - k.sqrt()) * n
        };
        let n = DVec3::new(0.1, 1.0, 0.2).normalize();
        let dir = DVec3::new(0.4, -1.0, 0.1).normalize();
        let dndx = DVec3::new(0.05, -0.01, 0.02);
        let dndx = dndx - n * n.dot(dndx);
        let dddx = DVec3::new(0.03, 0.0, -0.02);
        let dddx = dddx - dir * dir.dot(dddx);
        for eta in [1.0 / 1.5, 1.5, 1.0] {
            if 1.0 - eta * eta * (1.0 - dir.dot(n).powi(2)) <= 0.0 {
                continue;
            }
            let t = refract(dir, n, eta);
            let diff = RayDifferential { dddx, ..RayDifferential::default() };
            let got = diff.refract(dir, n, t, eta, (DVec3::ZERO, DVec3::ZERO), (dndx, DVec3::ZERO)).dddx;
            let h = 1e-6;
            let moved = refract((dir + h * dddx).normalize(), (n + h * dndx).normalize(), eta);
            let fd = (moved - t) / h;
            assert!((fd - got).length() < 1e-4, "eta {eta}: {fd} vs {got}");
        }
    }

    /// Reflection's differential against finite differences of the mirror law.
    #[test]
    fn reflection_differential_matches_finite_differences() {
        let reflect = |d: DVec3, n: DVec3| d - 2.0 * d.dot(n) * n;
        let n = DVec3::new(0.1, 1.0, 0.2).normalize();
        let dir = DVec3::new(0.4, -1.0, 0.1).normalize();
        let dndx = DVec3::new(0.05, -0.01, 0.02);
        let dndx = dndx - n * n.dot(dndx);
        let dddx = DVec3::new(0.03, 0.0, -0.02);
        let dddx = dddx - dir * dir.dot(dddx);
        let diff = RayDifferential { dddx, ..RayDifferential::default() };
        let got = diff.reflect(dir, n, (DVec3::ZERO, DVec3::ZERO), (dndx, DVec3::ZERO)).dddx;
        let h = 1e-6;
        let fd = (reflect((dir + h * dddx).normalize(), (n + h * dndx).normalize()) - reflect(dir, n)) / h;
        assert!((fd - got).length() < 1e-4, "{fd} vs {got}");
    }
}
