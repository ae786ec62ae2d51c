//! Texture coordinates of the built-in shapes (asked for only where a textured material is hit):
//!
//! | shape | u | v |
//! |---|---|---|
//! | `sphere` | longitude around +y: 0.5 facing +z, increasing toward +x | latitude: 0 at the bottom (−y), 1 at the top |
//! | `hemisphere` | longitude around `open` (as the sphere's when `open` is +y) | 0 at the bottom of the bowl, 1 at its rim |
//! | `plane` | scene units along the plane's right axis (+x projected onto a floor or ceiling, one tilted less than 45°; `+y × normal` on a wall) | scene units along its up axis (`normal × right`: −z on a floor) |
//! | `cylinder`, `tube` | around the axis, as the sphere's around +y | 0 at the base, 1 at the top (`tube`: scene units along the axis) |
//! | cylinder caps | the disc mapped onto [0, 1]², seen from outside | |
//! | `triangle` | barycentric: p0 = (0, 0), p1 = (1, 0), p2 = (0, 1) | |
//! | `quadrangle` | bilinear: p0 = (0, 0), p1 = (1, 0), p2 = (1, 1), p3 = (0, 1) | |
//! | `polygon` | its bounding rectangle in the plane's axes (as the plane's) mapped onto [0, 1]² | |
//!
//! So an image (v up) stands upright on walls, faces a camera on +z from the front of a sphere,
//! and lies on a floor with its top away from such a camera.

use raylab::glam::{DVec2, DVec3};
use std::f64::consts::{PI, TAU};

/// `|n·y|` above which a surface is a floor or ceiling (tilted less than 45° from level): its
/// right axis is +x projected onto it; below, a wall: `+y × n`, so images stand upright. Both
/// are at least `√½` long before normalising.
const FLOOR: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// The right and up axes (unit, with `right × up = n`) of a surface with unit normal `n`: on a
/// floor or ceiling (within 45° of level) +x projected onto it, so a slightly tilted floor keeps
/// its texture's orientation; on a wall `+y × n` normalised; up is `n × right`.
pub fn tangent_frame(n: DVec3) -> (DVec3, DVec3) {
    let right = if n.y.abs() > FLOOR { (DVec3::X - DVec3::X.dot(n) * n).normalize() } else { DVec3::Y.cross(n).normalize() };
    (right, n.cross(right))
}

/// The axes `(x, z)` of a frame around unit `axis` that are +x and +z when `axis` is +y (for
/// longitudes measured as the sphere's).
pub fn around_frame(axis: DVec3) -> (DVec3, DVec3) {
    let (right, up) = tangent_frame(axis);
    // For axis +y: right = +x, up = axis × x = −z.
    (right, -up)
}

/// Longitude of unit direction `d` in the frame `(x, z)` (from [`around_frame`]): 0.5 facing
/// `z`, increasing toward `x`, in [0, 1].
#[inline]
pub fn longitude(d: DVec3, (x, z): (DVec3, DVec3)) -> f64 {
    0.5 + d.dot(x).atan2(d.dot(z)) / TAU
}

/// Spherical coordinates of unit direction `d` from a sphere's centre: (longitude around +y,
/// latitude from 0 at −y to 1 at +y).
#[inline]
pub fn spherical(d: DVec3) -> DVec2 {
    DVec2::new(0.5 + d.x.atan2(d.z) / TAU, 0.5 + d.y.clamp(-1.0, 1.0).asin() / PI)
}

/// The derivatives of [`spherical`] coordinates on a sphere of `radius` at unit direction `d`
/// from its centre: `∂p/∂u` along the parallel (2π r cos θ long), `∂p/∂v` along the meridian
/// (π r long), the outward normal turning as `∂p/r`.
pub fn spherical_derivatives(d: DVec3, radius: f64) -> raylab::geometry::SurfaceDerivatives {
    let cos = d.x.hypot(d.z);
    let dpdu = TAU * radius * DVec3::new(d.z, 0.0, -d.x);
    let dpdv = if cos > 0.0 { PI * radius * DVec3::new(-d.y * d.x / cos, cos, -d.y * d.z / cos) } else { DVec3::ZERO };
    raylab::geometry::SurfaceDerivatives { dpdu, dpdv, dndu: dpdu / radius, dndv: dpdv / radius }
}

/// Texture coordinates of point `p` (2-D, in the quad's plane) in the convex quadrangle
/// `a b c d` mapped bilinearly onto a(0, 0), b(1, 0), c(1, 1), d(0, 1): the inverse of
/// `a + u(b − a) + v(d − a) + uv(a − b + c − d)`. Parallelograms have one root; otherwise the
/// root in (or nearest) [0, 1] of the quadratic in `v`, computed without cancellation.
pub fn inverse_bilinear(p: DVec2, [a, b, c, d]: [DVec2; 4]) -> DVec2 {
    let cross = |x: DVec2, y: DVec2| x.x * y.y - x.y * y.x;
    let (e, f, g, h) = (b - a, d - a, a - b + c - d, p - a);
    let (k2, k1, k0) = (cross(g, f), cross(e, f) + cross(h, g), cross(h, e));
    let disc = (k1 * k1 - 4.0 * k0 * k2).max(0.0);
    let q = -0.5 * (k1 + disc.sqrt().copysign(k1));
    let u_for = |v: f64| {
        let w = e + g * v;
        DVec2::new((h - f * v).dot(w) / w.length_squared(), v)
    };
    let mut best = u_for(if q != 0.0 { k0 / q } else { 0.0 });
    if k2 != 0.0 {
        let other = u_for(q / k2);
        let outside = |t: DVec2| (t - t.clamp(DVec2::ZERO, DVec2::ONE)).length();
        if outside(other) < outside(best) {
            best = other;
        }
    }
    if best.is_finite() { best } else { DVec2::ZERO }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_right_handed_and_upright() {
        for n in [DVec3::Y, -DVec3::Y, DVec3::Z, DVec3::X, -DVec3::Z, DVec3::new(0.3, 0.9, -0.2).normalize()] {
            let (r, u) = tangent_frame(n);
            assert!((r.cross(u) - n).length() < 1e-12, "{n}");
            assert!(r.dot(n).abs() < 1e-12 && (r.length() - 1.0).abs() < 1e-12);
        }
        assert_eq!(tangent_frame(DVec3::Y), (DVec3::X, -DVec3::Z), "a floor: u = x, v away from a camera on +z");
        assert_eq!(tangent_frame(DVec3::Z), (DVec3::X, DVec3::Y), "a wall facing +z: upright");
        assert_eq!(around_frame(DVec3::Y), (DVec3::X, DVec3::Z));
    }

    #[test]
    fn a_slightly_tilted_floor_keeps_its_axes_and_a_turned_wall_stays_upright() {
        for tilt in [1e-9, 1e-4, 1e-2, 0.3] {
            for axis in [DVec3::X, DVec3::Z, DVec3::new(1.0, 0.0, 1.0).normalize()] {
                let n = raylab::glam::DQuat::from_axis_angle(axis, tilt) * DVec3::Y;
                let (r, u) = tangent_frame(n);
                // Within the tilt of the level floor's axes (+x, −z), not a quarter turn away.
                assert!(
                    r.dot(DVec3::X) > tilt.cos() - 1e-12 && u.dot(-DVec3::Z) > tilt.cos() - 1e-12,
                    "tilt {tilt} about {axis}: {r}, {u}"
                );
                let (r, u) = tangent_frame(-n);
                assert!(
                    r.dot(DVec3::X) > tilt.cos() - 1e-12 && u.dot(DVec3::Z) > tilt.cos() - 1e-12,
                    "ceiling, tilt {tilt} about {axis}: {r}, {u}"
                );
            }
        }
        for turn in [0.0f64, 0.5, 2.0, 3.0, 4.0, 6.0] {
            for lean in [0.0f64, 0.5] {
                let n = DVec3::new(turn.sin() * lean.cos(), lean.sin(), turn.cos() * lean.cos());
                let (r, u) = tangent_frame(n);
                assert!(r.y.abs() < 1e-12 && u.y > 0.0, "wall turned {turn}, leaning {lean}: right {r}, up {u}");
                assert!((r.cross(u) - n).length() < 1e-12);
            }
        }
    }

    #[test]
    fn the_sphere_faces_a_camera_on_z_with_its_middle() {
        assert_eq!(spherical(DVec3::Z), DVec2::new(0.5, 0.5));
        assert_eq!(spherical(DVec3::X).x, 0.75);
        assert_eq!(spherical(DVec3::Y).y, 1.0);
        assert_eq!(spherical(-DVec3::Y).y, 0.0);
        assert_eq!(longitude(DVec3::X, around_frame(DVec3::Y)), 0.75);
    }

    #[test]
    fn inverse_bilinear_inverts_the_bilinear_map() {
        let quads = [
            [DVec2::new(0.0, 0.0), DVec2::new(2.0, 0.0), DVec2::new(2.0, 1.0), DVec2::new(0.0, 1.0)],
            [DVec2::new(0.0, 0.0), DVec2::new(3.0, 0.5), DVec2::new(2.5, 2.0), DVec2::new(-0.5, 1.5)],
            [DVec2::new(1e6, 1e6), DVec2::new(1e6 + 1.0, 1e6), DVec2::new(1e6 + 0.7, 1e6 + 0.4), DVec2::new(1e6 + 0.1, 1e6 + 0.9)],
        ];
        for q in quads {
            for (u, v) in [(0.0, 0.0), (1.0, 1.0), (0.25, 0.75), (0.9, 0.1), (0.5, 0.5)] {
                let p = q[0] + u * (q[1] - q[0]) + v * (q[3] - q[0]) + u * v * (q[0] - q[1] + q[2] - q[3]);
                let got = inverse_bilinear(p, q);
                assert!((got - DVec2::new(u, v)).length() < 1e-6, "{q:?} ({u}, {v}) → {got}");
            }
        }
    }
}
