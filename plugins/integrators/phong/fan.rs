//! Reflection and refraction: their weights at a hit (the material's `kr` and `kt`, or with
//! Fresnel, `F·kr` and `(1 − F)·kt`), the ideal direction, and the fan of child rays around it
//! (one ray at a sharp surface; `glossy_rays` jittered in a disc of radius `blur` otherwise).

use super::{Branch, Ctx, Front, Phong, TAG_REFLECTION, TAG_REFRACTION, counter};
use raylab::geometry::differential::RaySpread;
use raylab::glam::{DVec2, DVec3};
use raylab::math::color::max_channel;
use raylab::math::sampler::{StratifiedSet, concentric_disc, orthonormal_basis};
use raylab::render::trace::Recorder;
use raylab::scene::interaction::Interaction;
use raylab::scene::material::{Coefficients, Fresnel};
use raylab::{Color, RayKind};

/// Mirror reflection of direction `d` about unit normal `n`: `d − 2(d·n)n`.
#[inline]
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit direction `d` through a surface with unit normal `n` facing against `d`,
/// with `eta` = n_incident / n_transmitted. `None` on total internal reflection.
#[inline]
pub fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -n.dot(d);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((eta * d + (eta * cos_i - cos_t) * n).normalize())
}

/// The weights of the reflected and the transmitted light at `si`: the material's `kr` and `kt`,
/// or with Fresnel `F·kr` and `(1 − F)·kt`, `F` the dielectric reflectance for the angle of
/// incidence. Light enters a closed solid's inside (index `ior` relative to the outside) or
/// leaves it; an open surface is a sheet with air on both sides, entered from either.
#[inline]
pub(super) fn fresnel_weights<R: Recorder>(si: &Interaction, m: &Coefficients, rec: &mut R) -> (Color, Color) {
    if m.fresnel == Fresnel::Off {
        return (m.kr, m.kt);
    }
    let eta = if si.front_face || !si.object.is_closed() { m.ior } else { 1.0 / m.ior };
    let f = m.fresnel.reflectance(-si.dir.dot(si.specular_normal()), eta);
    rec.note(|| format!("Fresnel ({:?}, ior ratio {eta:.4}): F = {f:.4} weights reflection F·kr, transmission (1 − F)·kt", m.fresnel));
    (m.kr * f, m.kt * (1.0 - f))
}

/// `x.ceil() as u32` (saturating; NaN gives 0) without `ceil`, a library call on x86-64 without
/// SSE4.1: the truncation, plus one where it fell short of `x`.
#[inline]
fn ceil_count(x: f64) -> u32 {
    let t = x as u32;
    if f64::from(t) < x { t.saturating_add(1) } else { t }
}

/// Offset (within a ray kind's tags) of the stream a glossy fan's pattern comes from.
const FAN_PATTERN: u64 = 0xFFFF_FFFF;

/// A reflection or refraction fan: the ideal direction, the side it must stay on, the blur.
pub(super) struct Fan {
    ideal: DVec3,
    side: DVec3,
    blur: f64,
    kind: RayKind,
    tag: u64,
    /// The ratio of refractive indices of a transmitted ray (1 through a thin sheet); `None`
    /// for a reflected one (total internal reflection included).
    eta: Option<f64>,
}

impl Fan {
    /// The fan of `kind` at `si`: mirror reflection about the valid shading normal facing the
    /// ray ([`Interaction::specular_normal`]: a smooth-shaded mesh mirrors as a smooth surface);
    /// refraction by Snell's law about it at closed solids (total internal reflection reflects
    /// instead; about the geometric normal where the shading normal would send the refracted ray
    /// back out), straight through at open surfaces (thin sheets). The fan stays on the
    /// geometric normal's side it leaves by.
    pub(super) fn new<R: Recorder>(si: &Interaction, m: &Coefficients, kind: RayKind, rec: &mut R) -> Fan {
        let (d, n, ns) = (si.dir, si.n, si.specular_normal());
        let (ideal, side, tag, eta) = if kind == RayKind::Reflection {
            (reflect(d, ns), n, TAG_REFLECTION, None)
        } else if si.object.is_closed() {
            let eta = if si.front_face { 1.0 / m.ior } else { m.ior };
            let refracted = match refract(d, ns, eta) {
                Some(t) if t.dot(n) >= 0.0 => refract(d, n, eta),
                t => t,
            };
            match refracted {
                Some(t) => (t, -n, TAG_REFRACTION, Some(eta)),
                None => {
                    rec.note(|| "total internal reflection: the transmitted ray reflects".into());
                    (reflect(d, ns), n, TAG_REFRACTION, None)
                }
            }
        } else {
            (d, -n, TAG_REFRACTION, Some(1.0))
        };
        Fan { ideal, side, blur: m.blur, kind, tag, eta }
    }
}

impl Fan {
    /// The ideal direction (the one ray of a sharp surface).
    #[inline]
    pub(super) fn ideal(&self) -> DVec3 {
        self.ideal
    }

    /// The fan's ray for `u` ∈ [0, 1)²: the ideal direction jittered by the point of the disc of
    /// radius `blur` (at unit distance, across the axes `b1`, `b2`) `u` maps to, flipped onto the
    /// `side` hemisphere if the jitter pushed it through the surface.
    #[inline]
    fn jitter(&self, b1: DVec3, b2: DVec3, u: DVec2) -> DVec3 {
        let d = concentric_disc(u) * self.blur;
        let dir = (self.ideal + d.x * b1 + d.y * b2).normalize();
        if dir.dot(self.side) < 0.0 { reflect(dir, self.side) } else { dir }
    }
}

impl Phong {
    /// Traces the child ray(s) around `fan.ideal`: one ray, or `glossy_rays` jittered in a disc
    /// of radius `blur`, each flipped onto the `side` hemisphere if jitter pushed it through the
    /// surface. Returns their mean radiance. At a sharp surface with `avoid` off, the fan is
    /// `glossy_rays` copies of the one ideal ray (same stream, same weight). `b` is the place in
    /// the recursion of the ray that met `si`, with the fan's weight; `front` its rays' origin
    /// in front of the surface.
    pub(super) fn spread<R: Recorder>(&self, c: &mut Ctx, si: &Interaction, fan: &Fan, b: Branch, front: &Front, rec: &mut R) -> Color {
        let Branch { sampler, depth, weight, .. } = b;
        let sharp = fan.blur <= 0.0;
        // A fan gets rays in proportion to its weight in the pixel (at least one), so nested
        // glossy bounces cost about `glossy_rays` per sample instead of `glossy_rays^depth`.
        let fan_size = ceil_count(f64::from(self.glossy_rays) * max_channel(weight)).clamp(1, self.glossy_rays);
        let count = if sharp && self.avoid { 1 } else { fan_size };
        if sharp && self.avoid {
            c.stats.add(counter::GLOSSY_RAYS_SAVED, u64::from(fan_size - 1));
        }
        // The disc's axes, only where rays are jittered in it.
        let (b1, b2) = if sharp { (DVec3::ZERO, DVec3::ZERO) } else { orthonormal_basis(fan.ideal) };
        let child_weight = if sharp { weight } else { weight / f64::from(count) };
        let counter = if fan.kind == RayKind::Reflection { counter::REFLECTION_RAYS } else { counter::REFRACTION_RAYS };
        // The fan's pattern and its stratified points, only where rays are jittered.
        let points = (!sharp).then(|| StratifiedSet::new(count, sampler.fork(fan.tag | FAN_PATTERN).next_pattern()));
        let mut mean = Color::ZERO;
        for i in 0..count {
            let mut dir = fan.ideal;
            if let Some(points) = &points {
                dir = fan.jitter(b1, b2, points.point(i));
            }
            c.stats.add(counter, 1);
            let ray = front.ray(dir);
            let child_sampler = sampler.fork(fan.tag | if sharp { 0 } else { u64::from(i) });
            // A sharp mirror or refraction carries the ray differential on; a glossy fan's rays
            // take the camera's approximation.
            let spread = match (sharp, fan.eta) {
                // Without textures to filter, no spread: the tag, not a call returning the enum.
                (true, _) if matches!(si.spread, RaySpread::Off) => RaySpread::Off,
                (false, _) => c.scene.scattered_spread(si.spread),
                (true, None) => si.reflected_spread(dir),
                (true, Some(eta)) => si.refracted_spread(dir, eta),
            };
            let mut child = rec.child(fan.kind, &ray, depth + 1, child_weight);
            let li = self.li(c, &ray, Branch { sampler: &child_sampler, depth: depth + 1, weight: child_weight, spread }, &mut child);
            rec.adopt(child);
            if count == 1 {
                // The running mean of one ray, 0 + (li − 0) / 1, is li (up to the sign of a zero,
                // which the caller's sum of non-negative terms absorbs): without three divisions.
                return li;
            }
            // Running mean: copies of one ray average to exactly that ray's value.
            mean += (li - mean) / f64::from(i + 1);
        }
        mean
    }
}

/// A glossy fan's rays follow the density of its construction: a uniform disc of radius `blur`
/// in the plane at unit distance along the ideal direction, seen from the hit (`1 / (π blur²
/// cos³ α)` per steradian, α from the ideal direction, out to `tan α = blur`), plus its part
/// folded back through the surface.
#[cfg(test)]
mod chi2_tests {
    use super::*;
    use raylab::testing::chi2::{Chi2Test, Sphere};
    use std::f64::consts::PI;

    /// The density of the unfolded jitter around `ideal`.
    fn disc_density(w: DVec3, ideal: DVec3, blur: f64) -> f64 {
        let c = w.dot(ideal);
        if !(c > 0.0) {
            return 0.0;
        }
        let tan = (1.0 - c * c).max(0.0).sqrt() / c;
        if tan > blur { 0.0 } else { 1.0 / (PI * blur * blur * c * c * c) }
    }

    fn fan(ideal: DVec3, side: DVec3, blur: f64) -> Fan {
        Fan { ideal: ideal.normalize(), side, blur, kind: RayKind::Reflection, tag: 0, eta: None }
    }

    #[test]
    fn glossy_fans_pass_the_chi2_test() {
        let n = DVec3::Z;
        let cases = [
            ("reflection, blur 0.2, steep", fan(DVec3::new(0.3, 0.1, 1.0), n, 0.2)),
            ("reflection, blur 0.6", fan(DVec3::new(0.5, -0.2, 1.0), n, 0.6)),
            ("reflection, blur 0.5, grazing: folded", fan(DVec3::new(1.0, 0.4, 0.15), n, 0.5)),
            ("refraction, blur 1.5: wide, folded", fan(DVec3::new(-0.4, 0.3, -1.0), -n, 1.5)),
        ];
        let test = Chi2Test::new(Sphere).res(72, 36).tests(cases.len() as u32 + 1);
        for (name, f) in &cases {
            let (b1, b2) = orthonormal_basis(f.ideal);
            let density = |w: DVec3| {
                if w.dot(f.side) < 0.0 { 0.0 } else { disc_density(w, f.ideal, f.blur) + disc_density(reflect(w, f.side), f.ideal, f.blur) }
            };
            test.run(|u| Some(f.jitter(b1, b2, u.next_2d())), density).assert_passes(name);
        }
        // As the renderer draws them: the stratified points of one fan's pattern after another.
        let f = &cases[2].1;
        let (b1, b2) = orthonormal_basis(f.ideal);
        let mut k = 0u32;
        test.run(
            |_| {
                let (fan_size, pattern) = (16, k / 16);
                let u = StratifiedSet::new(fan_size, pattern.wrapping_mul(0x9E37_79B9)).point(k % fan_size);
                k += 1;
                Some(f.jitter(b1, b2, u))
            },
            |w| {
                if w.dot(f.side) < 0.0 { 0.0 } else { disc_density(w, f.ideal, f.blur) + disc_density(reflect(w, f.side), f.ideal, f.blur) }
            },
        )
        .assert_passes("stratified fans of 16 rays");
    }
}

#[cfg(test)]
mod ceil_tests {
    use super::ceil_count;

    /// The same counts as `ceil() as u32`, at whole values, just above and below them, negative,
    /// NaN and beyond the `u32` range.
    #[test]
    fn ceil_count_matches_ceil() {
        let mut xs = vec![0.0, -0.0, -0.5, 0.5, 1.0, f64::NAN, f64::INFINITY, -f64::INFINITY, 4294967294.5, 4294967295.0, 5e9, 1e-300];
        for k in 0..2000 {
            let x = f64::from(k) / 16.0;
            xs.extend([x, x.next_up(), x.next_down()]);
        }
        for x in xs {
            assert_eq!(ceil_count(x), x.ceil() as u32, "{x}");
        }
    }
}
