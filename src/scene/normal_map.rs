//! Normal and bump maps: a material's texture tilting the shading normal
//! ([`crate::scene::material::NormalMap`]), applied where a ray hits
//! ([`crate::scene::interaction::Interaction::new`]), so every integrator shades with the tilted
//! normal.
//!
//! The frame is the shape's: [`Geometry::tangents`] gives `∂p/∂u` and `∂p/∂v` at the hit (a glTF
//! mesh's `TANGENT`s or MikkTSpace tangents, a triangle's texture-coordinate derivatives, a
//! sphere's analytic ones). Around the shading normal `n`, the tangent `t` is `∂p/∂u` made
//! orthogonal to `n` (Gram–Schmidt) and the bitangent `b = ±n × t`, on `∂p/∂v`'s side (mirrored
//! texture coordinates flip it).
//!
//! - **Tangent-space normals** (glTF `normalTexture`, MTL `norm`): the texel `(r, g, b)` is the
//!   direction `((2r − 1)·s, (2g − 1)·s, 2b − 1)` in `(t, b, n)`, normalised (glTF's formula, `s`
//!   its `scale`).
//! - **Bump maps** (MTL `bump`, `map_Bump`): heights `h = s·texture` displace the surface along
//!   `n`; the tilted normal is that of the displaced surface, `(∂p/∂u + ∂h/∂u·n) × (∂p/∂v +
//!   ∂h/∂v·n)` with `∂p/∂u`, `∂p/∂v` taken in the plane of `n` (Blinn 1978, as pbrt's
//!   `BumpMap`), the height's derivatives by forward differences [`BUMP_DELTA`] apart in `u` and
//!   `v`.
//!
//! **Robustness.** A tilted normal can face away from the viewer, or reflect the view below the
//! surface, where a BSDF evaluated around it goes black (a dark fringe) or lets light through
//! from behind (a leak). The tilted normal is bent back toward the geometric normal just enough
//! that the mirror reflection of the view direction stays above the geometric surface: Cycles'
//! `ensure_valid_specular_reflection` (Blender, `kernel/closure/bsdf_util.h`, formerly
//! `ensure_valid_reflection`), [`ensure_valid_reflection`].
//! BSDFs still count a direction only on the viewer's side of both normals.
//!
//! A map that tilts nothing at a hit (a flat normal texel `(0.5, 0.5, 1)`, a level height field)
//! leaves the shape's normal exactly as it was.

use crate::geometry::{Geometry, Hit, Surface};
use crate::math::sampler::orthonormal_basis;
use crate::scene::material::{NormalMap, NormalMapKind};
use crate::scene::texture::TexturePoint;
use glam::{DVec2, DVec3};

/// The step in texture coordinates of the forward differences that give a bump map's slope:
/// under a texel of a 1024² image, and far above rounding.
pub const BUMP_DELTA: f64 = 1.0 / 2048.0;

/// How far above the geometric surface (as a cosine) the reflected view must stay, at most
/// ([`ensure_valid_reflection`]'s threshold, Cycles' value).
pub const REFLECTION_MARGIN: f64 = 0.01;

/// The unit tangent and bitangent around unit normal `n`: `dpdu` made orthogonal to `n`, and
/// `n × t` on `dpdv`'s side. Where `dpdu` is degenerate (zero, along `n`, non-finite), from
/// `dpdv`; where both are, any orthonormal pair. `(t, b, n)` is orthonormal.
pub fn tangent_frame(n: DVec3, dpdu: DVec3, dpdv: DVec3) -> (DVec3, DVec3) {
    let t = match (dpdu - n * n.dot(dpdu)).try_normalize() {
        Some(t) => t,
        None => match (dpdv - n * n.dot(dpdv)).try_normalize() {
            Some(b) => b.cross(n),
            None => return orthonormal_basis(n),
        },
    };
    let b = n.cross(t);
    (t, if b.dot(dpdv) < 0.0 { -b } else { b })
}

impl NormalMap {
    /// The tilted shading normal (unit, on `n`'s side of the tangent plane when the map allows)
    /// at texture point `at` of a surface with unit shading normal `n` (on the outward side) and
    /// derivatives `dpdu`, `dpdv`; `None` where the map tilts nothing (or reads non-finite).
    pub fn tilt(&self, n: DVec3, dpdu: DVec3, dpdv: DVec3, at: &TexturePoint) -> Option<DVec3> {
        match self.kind {
            NormalMapKind::Tangent => {
                let c = self.texture.eval(at);
                let (x, y, z) = ((2.0 * c.x - 1.0) * self.scale, (2.0 * c.y - 1.0) * self.scale, 2.0 * c.z - 1.0);
                if x == 0.0 && y == 0.0 && z > 0.0 {
                    return None;
                }
                let (t, b) = tangent_frame(n, dpdu, dpdv);
                (x * t + y * b + z * n).try_normalize()
            }
            NormalMapKind::Bump => {
                let height = |uv: DVec2| self.scale * self.texture.eval(&TexturePoint { uv, ..*at }).x;
                let h = height(at.uv);
                let dhdu = (height(at.uv + DVec2::new(BUMP_DELTA, 0.0)) - h) / BUMP_DELTA;
                let dhdv = (height(at.uv + DVec2::new(0.0, BUMP_DELTA)) - h) / BUMP_DELTA;
                if (dhdu == 0.0 && dhdv == 0.0) || !(dhdu.is_finite() && dhdv.is_finite()) {
                    return None;
                }
                let (su, sv) = (dpdu - n * n.dot(dpdu), dpdv - n * n.dot(dpdv));
                let base = su.cross(sv);
                // The handedness of (u, v) on the surface: the displaced normal keeps n's side.
                let sign = if base.dot(n) < 0.0 { -1.0 } else { 1.0 };
                (sign * (su + dhdu * n).cross(sv + dhdv * n)).try_normalize()
            }
        }
    }
}

/// The shading normal of `map` at `hit` of `geometry`, whose surface there is `s`, seen along
/// unit `dir`: tilted by the map, facing the viewer as `s.ns` does, and bent by
/// [`ensure_valid_reflection`]. `None` where the map tilts nothing or the shape has no
/// tangents there (the shape's normal stands).
#[inline(never)]
pub fn shading_normal(map: &NormalMap, geometry: &dyn Geometry, hit: &Hit, s: &Surface, dir: DVec3) -> Option<DVec3> {
    let [dpdu, dpdv] = geometry.tangents(hit)?;
    let (at, _) = TexturePoint::at_hit(geometry, hit, s.local);
    let outward = if s.front_face { s.ns } else { -s.ns };
    let tilted = map.tilt(outward, dpdu, dpdv, &at)?;
    let facing = if s.front_face { tilted } else { -tilted };
    Some(ensure_valid_reflection(s.n, -dir, facing))
}

/// Shading normal `n` bent toward the geometric normal `ng` (unit, facing the viewer) just
/// enough that the mirror reflection of `wo` (unit, toward the viewer) about it stays
/// `t = min(0.9·(ng·wo), `[`REFLECTION_MARGIN`]`)` above the geometric surface; `n` itself where
/// it already does. Blender Cycles' `ensure_valid_specular_reflection` (formerly
/// `ensure_valid_reflection`, `kernel/closure/bsdf_util.h`): in the frame `(x, ng)` of the plane
/// holding `n` and `ng`, the bent normal `(√(1 − z²), z)` solves `2(√(1 − z²)·wo_x + z·wo_z)·z −
/// wo_z = t`; squared, a quadratic in `z²` of which one root solves the unsquared equation (the
/// one where both sides have `wo_x`'s sign).
pub fn ensure_valid_reflection(ng: DVec3, wo: DVec3, n: DVec3) -> DVec3 {
    let r = 2.0 * n.dot(wo) * n - wo;
    let iz = ng.dot(wo);
    let threshold = (0.9 * iz).min(REFLECTION_MARGIN);
    if ng.dot(r) >= threshold {
        return n;
    }
    let x = (n - n.dot(ng) * ng).try_normalize().unwrap_or(n);
    let ix = wo.dot(x);
    let a = ix * ix + iz * iz;
    let b = 2.0 * (a + iz * threshold);
    let c = (threshold + iz) * (threshold + iz);
    if !(a > 0.0) {
        return ng;
    }
    let root = (b * b - 4.0 * a * c).max(0.0).sqrt();
    let z2 = (0.25 * if ix < 0.0 { b + root } else { b - root } / a).clamp(0.0, 1.0);
    (((1.0 - z2).sqrt()) * x + z2.sqrt() * ng).try_normalize().unwrap_or(ng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::color::Color;
    use crate::scene::texture::Texture;
    use std::sync::Arc;

    #[derive(Debug)]
    struct Constant(Color);
    impl Texture for Constant {
        fn eval(&self, _: &TexturePoint) -> Color {
            self.0
        }
    }

    /// Heights `u²/2`: slope `u` along u.
    #[derive(Debug)]
    struct Ramp;
    impl Texture for Ramp {
        fn eval(&self, at: &TexturePoint) -> Color {
            Color::splat(at.uv.x * at.uv.x / 2.0)
        }
    }

    /// A deterministic stream of unit vectors.
    fn units(seed: u64) -> impl Iterator<Item = DVec3> {
        let mut s = seed;
        std::iter::from_fn(move || {
            let mut next = || {
                s = crate::math::sampler::mix64(s.wrapping_add(0x9E37_79B9_7F4A_7C15));
                (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
            };
            DVec3::new(next(), next(), next()).try_normalize()
        })
    }

    #[test]
    fn the_tangent_frame_is_orthonormal_and_follows_dpdv() {
        let mut v = units(1);
        for _ in 0..1000 {
            let (n, du, dv) = (v.next().unwrap(), v.next().unwrap() * 3.0, v.next().unwrap() * 0.2);
            let (t, b) = tangent_frame(n, du, dv);
            for (p, q) in [(t, b), (t, n), (b, n)] {
                assert!(p.dot(q).abs() < 1e-12, "{p} · {q}");
            }
            for w in [t, b] {
                assert!((w.length() - 1.0).abs() < 1e-12);
            }
            assert!(b.dot(dv) >= 0.0);
            assert!(t.dot(du) >= 0.0);
        }
        // Degenerate derivatives still give a frame.
        for (du, dv) in [(DVec3::ZERO, DVec3::ZERO), (DVec3::Z, DVec3::NAN), (DVec3::ZERO, DVec3::X)] {
            let (t, b) = tangent_frame(DVec3::Z, du, dv);
            assert!(t.dot(b).abs() < 1e-12 && t.dot(DVec3::Z).abs() < 1e-12 && (t.length() - 1.0).abs() < 1e-12, "{du} {dv}");
        }
    }

    #[test]
    fn a_flat_map_tilts_nothing_and_a_tilted_one_follows_the_tangents() {
        let at = TexturePoint::new(DVec2::new(0.3, 0.7), DVec3::ZERO);
        let map = |c: Color, scale| NormalMap { texture: Arc::new(Constant(c)), kind: NormalMapKind::Tangent, scale };
        let (n, du, dv) = (DVec3::Z, DVec3::X * 2.0, DVec3::Y * 5.0);
        assert_eq!(map(Color::new(0.5, 0.5, 1.0), 1.0).tilt(n, du, dv, &at), None);
        // Full red: 45° toward +u; its scale tilts further; green toward +v.
        let red = map(Color::new(1.0, 0.5, 1.0), 1.0).tilt(n, du, dv, &at).unwrap();
        assert!((red - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-12, "{red}");
        let scaled = map(Color::new(1.0, 0.5, 1.0), 2.0).tilt(n, du, dv, &at).unwrap();
        assert!((scaled - DVec3::new(2.0, 0.0, 1.0).normalize()).length() < 1e-12, "{scaled}");
        let green = map(Color::new(0.5, 1.0, 1.0), 1.0).tilt(n, du, -dv, &at).unwrap();
        assert!((green - DVec3::new(0.0, -1.0, 1.0).normalize()).length() < 1e-12, "mirrored v: {green}");
    }

    #[test]
    fn a_bump_map_tilts_by_the_height_slope() {
        let map = NormalMap { texture: Arc::new(Ramp), kind: NormalMapKind::Bump, scale: 1.0 };
        let level = NormalMap { texture: Arc::new(Constant(Color::splat(0.25))), kind: NormalMapKind::Bump, scale: 3.0 };
        let at = |u| TexturePoint::new(DVec2::new(u, 0.5), DVec3::ZERO);
        assert_eq!(level.tilt(DVec3::Z, DVec3::X, DVec3::Y, &at(0.5)), None);
        // Height u²/2 over p = (u, v, 0): slope u, normal (−u, 0, 1) normalised.
        for u in [0.25, 1.0, 2.0] {
            let n = map.tilt(DVec3::Z, DVec3::X, DVec3::Y, &at(u)).unwrap();
            let want = DVec3::new(-(u + BUMP_DELTA / 2.0), 0.0, 1.0).normalize();
            assert!((n - want).length() < 1e-9, "u = {u}: {n} vs {want}");
            // Left-handed (u, v) on the surface: still on n's side.
            let m = map.tilt(DVec3::Z, DVec3::X, -DVec3::Y, &at(u)).unwrap();
            assert!(m.z > 0.0 && (m - want).length() < 1e-9, "{m}");
        }
    }

    #[test]
    fn the_bent_normal_reflects_every_view_above_the_surface() {
        let ng = DVec3::Z;
        let mut v = units(7);
        let mut bent = 0;
        for _ in 0..20000 {
            let (wo, n) = (v.next().unwrap(), v.next().unwrap());
            let wo = DVec3::new(wo.x, wo.y, wo.z.abs().max(1e-4)).normalize();
            let n = DVec3::new(n.x, n.y, n.z.abs()).normalize();
            let m = ensure_valid_reflection(ng, wo, n);
            assert!((m.length() - 1.0).abs() < 1e-9 && m.is_finite(), "{m}");
            let r = 2.0 * m.dot(wo) * m - wo;
            let threshold = (0.9 * ng.dot(wo)).min(REFLECTION_MARGIN);
            assert!(r.z >= threshold - 1e-6, "wo {wo} n {n} → {m}: reflection {}", r.z);
            assert!(m.dot(wo) > 0.0, "the viewer is above the bent normal");
            if m != n {
                bent += 1;
                // Bent within the plane of n and ng, toward ng.
                assert!(m.dot(n.cross(ng)).abs() < 1e-9 && m.z >= n.z - 1e-12);
            }
        }
        assert!(bent > 1000, "the test reaches the bending ({bent})");
        // A valid normal is kept exactly.
        let n = DVec3::new(0.1, 0.0, 1.0).normalize();
        assert_eq!(ensure_valid_reflection(ng, DVec3::Z, n), n);
    }
}
