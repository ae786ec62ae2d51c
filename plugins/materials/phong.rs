//! `phong`: the report's coefficients, the default material (`[materials.NAME]` without a
//! `type`). `phong` the integrator reads them as the report did; the path tracer reads them
//! through the scattering model below, [`PhongBsdf`]:
//!
//! ```text
//! f(ωo, ωi) = kd/π + ks·(n+2)/(2π)·cos^n α + kr·δ_mirror + kt·δ_dielectric
//! ```
//!
//! - `kd`: Lambertian; `ks`: the normalised (energy-conserving) Phong lobe of exponent
//!   `shininess` around the mirror direction of ωo about the shading normal (α is the angle
//!   from it; Lafortune and Willems 1994);
//! - `kr`: a perfect mirror about the valid shading normal (`Interaction::specular_normal`:
//!   the shading normal, bent toward the geometric one only where the mirror direction would
//!   leave into the surface; a smooth-shaded mesh mirrors smoothly), or with `blur > 0` a second normalised
//!   Phong lobe of exponent `4 / blur²` (the Phong lobe whose mean squared angle equals that of
//!   phong's jitter disc of radius `blur`);
//! - `kt`: a smooth dielectric with the exact Fresnel reflectance, about that same normal (refraction
//!   about the geometric normal where the shading normal would send the ray back out): at a closed solid it reflects
//!   with probability F and refracts by Snell's law otherwise (total internal reflection where
//!   F = 1; transmitted radiance scales by (η_i/η_t)²); an open surface is a thin slab of index
//!   `ior` that reflects 2F/(1+F) and passes the rest straight through. With `blur > 0` the
//!   chosen direction is jittered in a Phong lobe of exponent `4 / blur²` (a stochastic specular
//!   event: no light samples toward it).
//! - a material's `fresnel` setting (for phong: reflection `F·kr`, transmission `(1 − F)·kt`):
//!   with `kt`, the dielectric's own `F` is the reflection and `kr` adds no mirror; without it,
//!   the mirror weighs `F·kr`.
//!
//! The four weights are scaled down together so their sum is at most 1 in every channel: a
//! material that would reflect more than it receives reflects all of it. Lobes are sampled in
//! proportion to their weights (mean over channels); the diffuse lobe with cosine-weighted
//! directions, the Phong lobes with `cos^n α`. The BSDF's `pdf` is the density of that whole
//! strategy, for weighing it against light samples.
//!
//! A material with no model of its own (`model` `None`: every `phong` material, and those of
//! OBJ files and the report's XML scenes) is read by the path tracer through [`PhongBsdf`].

use raylab::glam::{DVec2, DVec3};
use raylab::math::color::max_channel;
use raylab::math::sampler::{concentric_disc, orthonormal_basis};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::scene::bsdf::{Bsdf, Lobe, Scatter};
use raylab::scene::interaction::Interaction;
use raylab::scene::material::{Coefficients, Fresnel, MATERIAL_PARAMS};
use raylab::scene::texture::TextureResolver;
use raylab::{Color, Material, PluginInfo, RayKind};
use std::f64::consts::{FRAC_1_PI, TAU};

use crate::integrators::phong::{reflect, refract};

/// The lobes in the order of [`PhongBsdf::choice`].
const LOBES: [Lobe; 5] = [Lobe::Diffuse, Lobe::Specular, Lobe::Glossy, Lobe::Mirror, Lobe::Dielectric];

/// The `phong` material's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "phong",
    summary: "The report's coefficients (the default material: a [materials.NAME] table without a `type`). `phong` reads them as the report did; the path tracer as an energy-conserving BSDF: Lambertian kd, normalised Phong ks, mirror or glossy kr, Fresnel dielectric kt, scaled down together to reflect at most what arrives.",
    params: MATERIAL_PARAMS,
};

/// Builds a `phong` material: the coefficients alone, no model of their own.
pub fn build(p: &mut Params, textures: &dyn TextureResolver) -> Result<Material> {
    Material::from_params(p, textures)
}

/// The scattering model at one hit (see the module docs). Built per hit, on the stack.
#[derive(Clone, Debug)]
pub struct PhongBsdf {
    /// Unit direction toward where the ray came from (−ray direction).
    wo: DVec3,
    /// Geometric normal facing `wo`.
    n: DVec3,
    /// Shading normal facing `wo`.
    ns: DVec3,
    /// The valid shading normal perfect specular events turn about
    /// (`Interaction::specular_normal`), where a mirror or dielectric lobe has weight (else `n`,
    /// never read).
    ms: DVec3,
    /// Mirror direction of `wo` about `ns`: the Phong lobes' axis, where one has weight (else
    /// `ns`, never read).
    axis: DVec3,
    kd: Color,
    ks: Color,
    shininess: f64,
    /// `kr` as a Phong lobe (blurry mirror).
    glossy: Color,
    /// `kr` as a perfect mirror.
    mirror: Color,
    kt: Color,
    /// `ior` of the material; `closed`: a solid's interface (else a thin sheet); `entering`: the
    /// ray arrived from outside.
    ior: f64,
    closed: bool,
    entering: bool,
    /// Exponent of the Phong lobe standing for the material's `blur`: the glossy lobe's, and the
    /// jitter of a blurry dielectric (0: sharp).
    blur_lobe: f64,
    /// Probability of choosing each lobe of [`LOBES`] (sum 1, or all 0 for a black surface).
    choice: [f64; 5],
}

/// Exponent of the Phong lobe standing for phong's jitter disc of radius `blur` (at unit
/// distance): the lobe's mean squared angle, `2 / n`, equals the disc's, `blur² / 2`.
pub fn blur_exponent(blur: f64) -> f64 {
    4.0 / (blur * blur)
}

/// Fresnel reflectance of a smooth dielectric interface for unpolarised light arriving at
/// `cos_i` (∈ [0, 1]) to the normal, with `eta` = η_t / η_i (transmitted over incident side);
/// 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (parallel * parallel + perpendicular * perpendicular)
}

/// The mirror weight of `si`'s material. A material's `fresnel` setting (phong weighs reflection
/// by `F·kr` and transmission by `(1 − F)·kt`) is honoured here too: with transmission, the
/// dielectric lobe already reflects `F`, so `kr` adds no mirror of its own (glass given as
/// `kr = kt = 1, fresnel = "exact"` is the dielectric alone); without it, the mirror is `F·kr`.
fn fresnel_mirror(si: &Interaction, m: &Coefficients) -> Color {
    match m.fresnel {
        Fresnel::Off => m.kr,
        _ if max_channel(m.kt) > 0.0 => Color::ZERO,
        f => m.kr * f.reflectance(-si.dir.dot(si.specular_normal()), if si.front_face { m.ior } else { 1.0 / m.ior }),
    }
}

/// Reflectance of a thin slab of index `eta` (relative to its surroundings) at `cos_i`, all
/// internal reflections summed: `2F / (1 + F)`.
pub fn thin_slab_reflectance(cos_i: f64, eta: f64) -> f64 {
    let f = fresnel_dielectric(cos_i, eta);
    2.0 * f / (1.0 + f)
}

/// Density of a Phong lobe of exponent `n` at cosine `c` from its axis: `(n+1)/(2π)·c^n`.
#[inline]
pub fn lobe_pdf(c: f64, n: f64) -> f64 {
    if c > 0.0 { (n + 1.0) / TAU * c.powf(n) } else { 0.0 }
}

/// The normalised Phong BRDF lobe of exponent `n` at cosine `c`: `(n+2)/(2π)·c^n`.
#[inline]
pub fn lobe_brdf(c: f64, n: f64) -> f64 {
    if c > 0.0 { (n + 2.0) / TAU * c.powf(n) } else { 0.0 }
}

/// A direction in the Phong lobe of exponent `n` around unit `axis`, from `u` ∈ [0, 1)².
#[inline]
pub fn sample_lobe(axis: DVec3, n: f64, u: DVec2) -> DVec3 {
    let cos = u.x.powf(1.0 / (n + 1.0));
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let (b1, b2) = orthonormal_basis(axis);
    let (s, c) = (TAU * u.y).sin_cos();
    (sin * c) * b1 + (sin * s) * b2 + cos * axis
}

/// Mean of the three channels: a lobe's share of the sampling.
#[inline]
fn mean(c: Color) -> f64 {
    (c.x + c.y + c.z) / 3.0
}

impl PhongBsdf {
    /// The model at the hit `si`.
    pub fn new(si: &Interaction) -> PhongBsdf {
        PhongBsdf::with_coefficients(si, &si.coefficients())
    }

    /// The model at the hit `si` of the material's coefficients there, `m`.
    fn with_coefficients(si: &Interaction, m: &Coefficients) -> PhongBsdf {
        let kr = fresnel_mirror(si, m);
        let scale = 1.0 / max_channel(m.kd + m.ks + kr + m.kt).max(1.0);
        let (kd, ks, kr, kt) = (m.kd * scale, m.ks * scale, kr * scale, m.kt * scale);
        let blurred = m.blur > 0.0;
        let (glossy, mirror) = if blurred { (kr, Color::ZERO) } else { (Color::ZERO, kr) };
        let mut choice = [mean(kd), mean(ks), mean(glossy), mean(mirror), mean(kt)];
        let total: f64 = choice.iter().sum();
        for p in &mut choice {
            *p = if total > 0.0 { *p / total } else { 0.0 };
        }
        let wo = -si.dir;
        // Only the lobes that can be chosen read their axes (the others' values are never
        // used): the Phong lobes' mirror axis, the specular events' normal.
        let axis = if choice[1] > 0.0 || choice[2] > 0.0 { reflect(si.dir, si.ns) } else { si.ns };
        let ms = if choice[3] > 0.0 || choice[4] > 0.0 { si.specular_normal() } else { si.n };
        PhongBsdf {
            wo,
            n: si.n,
            ns: si.ns,
            ms,
            axis,
            kd,
            ks,
            shininess: m.shininess,
            glossy,
            mirror,
            kt,
            ior: m.ior,
            // Only a dielectric asks (closedness is computed on first demand, per mesh).
            closed: max_channel(kt) > 0.0 && si.object.is_closed(),
            entering: si.front_face,
            blur_lobe: if blurred { blur_exponent(m.blur) } else { 0.0 },
            choice,
        }
    }

    /// Which of [`Bsdf::sample`]'s numbers this model reads, as `(pick, u, fresnel)`: the lobe
    /// choice only where more than one lobe can be picked, the direction's pair only for a smooth
    /// lobe or a blurry dielectric, the Fresnel choice only for a dielectric. A caller may pass
    /// anything for the others (the same scatter): a diffuse surface reads only `u`, a sharp
    /// mirror none.
    ///
    /// The lobe choice goes unread when the first lobe with weight has probability 1 (`pick`,
    /// below 1, then always picks it: a lone lobe's share is exactly 1), or none has weight.
    #[inline]
    pub fn numbers_read(&self) -> (bool, bool, bool) {
        let c = &self.choice;
        let first = if c[0] > 0.0 { c[0] } else { c[1..].iter().copied().find(|&p| p > 0.0).unwrap_or(1.0) };
        let dir = c[0] > 0.0 || c[1] > 0.0 || c[2] > 0.0 || (c[4] > 0.0 && self.blur_lobe > 0.0);
        (first < 1.0, dir, c[4] > 0.0)
    }

    /// At a lone sharp dielectric (the Fresnel number is all [`Bsdf::sample`] reads:
    /// [`PhongBsdf::numbers_read`] is `(false, false, true)`), the probability that it reflects
    /// (the Fresnel term it compares that number with; a thin sheet's `2F/(1+F)`) and whether the
    /// surface bounds a solid (a ray into its inside meets it again before anything else). Where
    /// there is no refraction (total internal reflection) it reflects whatever the number. `None`
    /// for any other model.
    pub fn dielectric_branches(&self) -> Option<(f64, bool)> {
        if self.numbers_read() != (false, false, true) {
            return None;
        }
        let cos_i = self.wo.dot(self.ms);
        Some(if self.closed {
            (fresnel_dielectric(cos_i, if self.entering { self.ior } else { 1.0 / self.ior }), true)
        } else {
            (thin_slab_reflectance(cos_i, self.ior), false)
        })
    }

    /// Fresnel reflection or transmission of the `kt` part, jittered when blurry.
    fn sample_dielectric(&self, u: DVec2, fresnel: f64) -> Scatter {
        let d = -self.wo;
        let cos_i = self.wo.dot(self.ms);
        let weight = self.kt / self.choice[4];
        let reflected = reflect(d, self.ms);
        let (mut dir, side, kind, eta_squared) = if self.closed {
            // η_t / η_i: into the solid through its outside, or out of it.
            let eta = if self.entering { self.ior } else { 1.0 / self.ior };
            let refracted = match refract(d, self.ms, 1.0 / eta) {
                Some(t) if t.dot(self.n) >= 0.0 => refract(d, self.n, 1.0 / eta),
                t => t,
            };
            match refracted {
                Some(t) if fresnel >= fresnel_dielectric(cos_i, eta) => (t, -self.n, RayKind::Refraction, eta * eta),
                _ => (reflected, self.n, RayKind::Reflection, 1.0),
            }
        } else if fresnel < thin_slab_reflectance(cos_i, self.ior) {
            (reflected, self.n, RayKind::Reflection, 1.0)
        } else {
            (d, -self.n, RayKind::Refraction, 1.0)
        };
        if self.blur_lobe > 0.0 {
            dir = sample_lobe(dir, self.blur_lobe, u);
            if dir.dot(side) < 0.0 {
                dir = reflect(dir, side);
            }
        }
        Scatter { dir, weight: weight / eta_squared, pdf: None, lobe: Lobe::Dielectric, kind, eta_squared }
    }
}

impl Bsdf for PhongBsdf {
    /// True when some lobe can be evaluated toward a given direction (diffuse, specular,
    /// glossy): light samples are worth taking here.
    fn has_smooth_lobes(&self) -> bool {
        self.choice[0] + self.choice[1] + self.choice[2] > 0.0
    }

    /// Reflectance as the albedo layer shows it: the sum of the weights.
    fn albedo(&self) -> Color {
        self.kd + self.ks + self.glossy + self.mirror + self.kt
    }

    /// `f(ωo, wi)` of the smooth lobes (specular events have no value toward a given direction):
    /// zero unless `wi` leaves on `wo`'s side of both normals.
    fn eval(&self, wi: DVec3) -> Color {
        if !(self.n.dot(wi) > 0.0 && self.ns.dot(wi) > 0.0) {
            return Color::ZERO;
        }
        let c = wi.dot(self.axis);
        // Lobes of weight zero add nothing (their values are finite): no `powf` for them.
        let mut f = self.kd * FRAC_1_PI;
        if self.choice[1] > 0.0 {
            f += self.ks * lobe_brdf(c, self.shininess);
        }
        if self.choice[2] > 0.0 {
            f += self.glossy * lobe_brdf(c, self.blur_lobe);
        }
        f
    }

    /// Density with which [`Bsdf::sample`] picks `wi` (per solid angle), for `wi` on `wo`'s side.
    fn pdf(&self, wi: DVec3) -> f64 {
        let cos = self.ns.dot(wi);
        let c = wi.dot(self.axis);
        let diffuse = if cos > 0.0 { cos * FRAC_1_PI } else { 0.0 };
        let mut pdf = self.choice[0] * diffuse;
        if self.choice[1] > 0.0 {
            pdf += self.choice[1] * lobe_pdf(c, self.shininess);
        }
        if self.choice[2] > 0.0 {
            pdf += self.choice[2] * lobe_pdf(c, self.blur_lobe);
        }
        pdf
    }

    /// Both of the above, their shared terms once (the cosines to the normals and the Phong
    /// axis, each lobe's `powf`), every value computed as they compute it.
    fn eval_pdf(&self, wi: DVec3) -> (Color, f64) {
        let cos = self.ns.dot(wi);
        let c = wi.dot(self.axis);
        let above = self.n.dot(wi) > 0.0 && cos > 0.0;
        // (lobe_brdf(c, n), lobe_pdf(c, n)) from one power.
        let lobe = |n: f64| {
            if c > 0.0 {
                let power = c.powf(n);
                ((n + 2.0) / TAU * power, (n + 1.0) / TAU * power)
            } else {
                (0.0, 0.0)
            }
        };
        let diffuse = if cos > 0.0 { cos * FRAC_1_PI } else { 0.0 };
        let mut f = self.kd * FRAC_1_PI;
        let mut pdf = self.choice[0] * diffuse;
        if self.choice[1] > 0.0 {
            let (brdf, density) = lobe(self.shininess);
            f += self.ks * brdf;
            pdf += self.choice[1] * density;
        }
        if self.choice[2] > 0.0 {
            let (brdf, density) = lobe(self.blur_lobe);
            f += self.glossy * brdf;
            pdf += self.choice[2] * density;
        }
        (if above { f } else { Color::ZERO }, pdf)
    }

    /// A new direction: a lobe chosen by `pick` ∈ [0, 1) in proportion to the weights, a
    /// direction from `u` ∈ [0, 1)², and (dielectrics) reflection or transmission by `fresnel` ∈
    /// [0, 1). `None` when the surface is black or the direction carries nothing (it points into
    /// the surface).
    fn sample(&self, pick: f64, u: DVec2, fresnel: f64) -> Option<Scatter> {
        let (mut acc, mut lobe) = (0.0, None);
        for (i, &p) in self.choice.iter().enumerate() {
            if p > 0.0 {
                lobe = Some(LOBES[i]);
                acc += p;
                if pick < acc {
                    break;
                }
            }
        }
        let lobe = lobe?;
        let dir = match lobe {
            Lobe::Diffuse => {
                let d = concentric_disc(u);
                let (b1, b2) = orthonormal_basis(self.ns);
                d.x * b1 + d.y * b2 + (1.0 - d.length_squared()).max(0.0).sqrt() * self.ns
            }
            Lobe::Specular => sample_lobe(self.axis, self.shininess, u),
            Lobe::Glossy => sample_lobe(self.axis, self.blur_lobe, u),
            Lobe::Mirror => {
                let weight = self.mirror / self.choice[3];
                let dir = reflect(-self.wo, self.ms);
                return Some(Scatter { dir, weight, pdf: None, lobe, kind: RayKind::Reflection, eta_squared: 1.0 });
            }
            // (Not among `LOBES`.)
            Lobe::Dielectric | Lobe::Transmission => return Some(self.sample_dielectric(u, fresnel)),
        };
        let (f, pdf) = self.eval_pdf(dir);
        if max_channel(f) <= 0.0 || !(pdf > 0.0) {
            return None;
        }
        let weight = f * self.ns.dot(dir) / pdf;
        Some(Scatter { dir, weight, pdf: Some(pdf), lobe, kind: RayKind::Reflection, eta_squared: 1.0 })
    }
}

/// `f` of the model at the hit `si` ([`PhongBsdf`]) and the numbers its sampling reads
/// ([`PhongBsdf::numbers_read`], as `(pick, u, fresnel)`): where only the Lambertian lobe has
/// weight (`ks`, `kr` and `kt` zero, Fresnel off, `kd` not black: most walls), the
/// [`LambertBsdf`] that answers every question with the same bits for a fraction of the work
/// (no five lobes to weigh, no axes, a third of the state to write); else the full model.
///
/// The diffuse case is built in place and handed on directly (no copy through a slot shared
/// with the full model); the full model is built out of line.
#[inline]
pub fn with_phong_bsdf<T>(si: &Interaction, f: impl FnOnce(&dyn Bsdf, (bool, bool, bool)) -> T) -> T {
    let m = si.coefficients();
    match lone_diffuse(&m) {
        Some(kd) => f(&LambertBsdf { n: si.n, ns: si.ns, kd }, LambertBsdf::NUMBERS_READ),
        None => with_full_bsdf(si, &m, f),
    }
}

/// [`with_phong_bsdf`] for a material with more than a diffuse lobe (or black): the full model.
#[inline(never)]
fn with_full_bsdf<T>(si: &Interaction, m: &Coefficients, f: impl FnOnce(&dyn Bsdf, (bool, bool, bool)) -> T) -> T {
    let full = PhongBsdf::with_coefficients(si, m);
    let numbers = full.numbers_read();
    f(&full, numbers)
}

/// `kd` scaled as [`PhongBsdf`] scales it, when only the Lambertian lobe of `m` has weight (`ks`,
/// `kr`, `kt` zero in every channel, Fresnel off: `kr` then stays zero, and `kd`'s mean above
/// zero); `None` otherwise. Every test and value as the full model's, with less work:
/// - `x == 0.0` (either sign) is `x`'s bits without the sign all clear: one test of the nine
///   channels' bits together instead of nine comparisons;
/// - the scale `1 / max(max_channel(kd + ks + kr + kt), 1)`: the zeros added change no channel
///   but a zero's sign, which the maximum with 1 does not see, so it is `kd`'s largest channel's;
///   where that is at most 1 the scale is exactly 1 and `kd · 1` is `kd`: no division;
/// - `mean(kd) > 0`, `(x + y + z) / 3 > 0`: the sum is above zero and its third does not round
///   to zero, that is the sum is above the smallest subnormal (`5e-324 / 3` rounds to 0, twice
///   it, the next value, to `5e-324`); NaN fails both.
#[inline(always)]
fn lone_diffuse(m: &Coefficients) -> Option<Color> {
    let bits = [m.ks, m.kr, m.kt].iter().fold(0u64, |a, c| a | c.x.to_bits() | c.y.to_bits() | c.z.to_bits());
    if m.fresnel != Fresnel::Off || bits << 1 != 0 {
        return None;
    }
    let largest = max_channel(m.kd).max(1.0);
    let kd = if largest > 1.0 { m.kd * (1.0 / largest) } else { m.kd };
    (kd.x + kd.y + kd.z > SMALLEST_SUBNORMAL).then_some(kd)
}

/// The smallest positive `f64` (2⁻¹⁰⁷⁴).
const SMALLEST_SUBNORMAL: f64 = f64::from_bits(1);

/// [`PhongBsdf`] where only its Lambertian lobe has weight: every answer (`eval`, `pdf`,
/// `eval_pdf`, `sample`, `albedo`) the full model's, bit for bit, computed as it computes them
/// with the other lobes' terms (zeros, never read) left out. The lobe's choice is exactly 1
/// (its mean over its own mean) and the lobes after it are never chosen.
#[derive(Clone, Copy, Debug)]
pub struct LambertBsdf {
    /// Geometric normal facing `wo`.
    n: DVec3,
    /// Shading normal facing `wo`.
    ns: DVec3,
    /// `kd` scaled as [`PhongBsdf`] scales it (by the four weights' largest channel, when above 1).
    kd: Color,
}

impl LambertBsdf {
    /// The numbers [`Bsdf::sample`] reads, as [`PhongBsdf::numbers_read`] says them for a lone
    /// diffuse lobe: the direction's pair only.
    pub const NUMBERS_READ: (bool, bool, bool) = (false, true, false);

    /// The model at `si` of the coefficients `m` when only their Lambertian lobe has weight
    /// (`ks`, `kr`, `kt` equal to zero in every channel, Fresnel off: `kr` then stays zero, and
    /// `kd`'s mean above zero); `None` otherwise (the full [`PhongBsdf`]).
    #[inline]
    pub fn of(si: &Interaction, m: &Coefficients) -> Option<LambertBsdf> {
        lone_diffuse(m).map(|kd| LambertBsdf { n: si.n, ns: si.ns, kd })
    }
}

impl Bsdf for LambertBsdf {
    fn has_smooth_lobes(&self) -> bool {
        true
    }

    /// The sum of the weights, the zeros' (+0) included: `-0` channels read `+0` as they do there.
    fn albedo(&self) -> Color {
        self.kd + Color::ZERO
    }

    fn eval(&self, wi: DVec3) -> Color {
        if !(self.n.dot(wi) > 0.0 && self.ns.dot(wi) > 0.0) {
            return Color::ZERO;
        }
        self.kd * FRAC_1_PI
    }

    /// The diffuse lobe's density times its choice, 1.
    fn pdf(&self, wi: DVec3) -> f64 {
        let cos = self.ns.dot(wi);
        if cos > 0.0 { cos * FRAC_1_PI } else { 0.0 }
    }

    fn eval_pdf(&self, wi: DVec3) -> (Color, f64) {
        let cos = self.ns.dot(wi);
        let above = self.n.dot(wi) > 0.0 && cos > 0.0;
        let diffuse = if cos > 0.0 { cos * FRAC_1_PI } else { 0.0 };
        (if above { self.kd * FRAC_1_PI } else { Color::ZERO }, diffuse)
    }

    /// A cosine-weighted direction about `ns` from `u` (`pick` and `fresnel` are not read).
    fn sample(&self, _: f64, u: DVec2, _: f64) -> Option<Scatter> {
        let d = concentric_disc(u);
        let (b1, b2) = orthonormal_basis(self.ns);
        let dir = d.x * b1 + d.y * b2 + (1.0 - d.length_squared()).max(0.0).sqrt() * self.ns;
        let (f, pdf) = self.eval_pdf(dir);
        if max_channel(f) <= 0.0 || !(pdf > 0.0) {
            return None;
        }
        let weight = f * self.ns.dot(dir) / pdf;
        Some(Scatter { dir, weight, pdf: Some(pdf), lobe: Lobe::Diffuse, kind: RayKind::Reflection, eta_squared: 1.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `LambertBsdf::of` computed before [`lone_diffuse`] (as `PhongBsdf` computes it): nine
    /// comparisons with zero, the scale of the four weights' sum, the mean's division.
    fn lone_diffuse_as_before(m: &Coefficients) -> Option<Color> {
        if m.fresnel != Fresnel::Off || m.ks != Color::ZERO || m.kr != Color::ZERO || m.kt != Color::ZERO {
            return None;
        }
        let scale = 1.0 / max_channel(m.kd + m.ks + m.kr + m.kt).max(1.0);
        let kd = m.kd * scale;
        (mean(kd) > 0.0).then_some(kd)
    }

    /// [`lone_diffuse`] agrees with the old computation bit for bit over channels at every edge
    /// (zeros of either sign, subnormals about the mean's rounding to zero, 1 and just above it,
    /// negatives, infinities, NaN) in every place of every weight, and over random ones.
    #[test]
    fn lone_diffuse_answers_as_before_bit_for_bit() {
        let tiny = f64::from_bits(1);
        let edges = [
            0.0,
            -0.0,
            tiny,
            -tiny,
            2.0 * tiny,
            3.0 * tiny,
            1e-300,
            0.5,
            0.75,
            1.0,
            1.0 + f64::EPSILON,
            2.5,
            -0.3,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let base = Coefficients {
            ka: Color::ZERO,
            kd: Color::ZERO,
            ks: Color::ZERO,
            kr: Color::ZERO,
            kt: Color::ZERO,
            shininess: 32.0,
            ior: 1.5,
            emission: Color::ZERO,
            blur: 0.0,
            fresnel: Fresnel::Off,
        };
        let same = |m: &Coefficients| {
            let (new, old) = (lone_diffuse(m), lone_diffuse_as_before(m));
            let bits = |c: Option<Color>| c.map(|c| c.to_array().map(f64::to_bits));
            assert_eq!(bits(new), bits(old), "{m:?}");
            u32::from(new.is_some())
        };
        let mut lambert = 0;
        // Every kd over the edges (three channels), with the other weights zero of either sign.
        for &x in &edges {
            for &y in &edges {
                for &z in &edges {
                    for zero in [0.0, -0.0] {
                        let others = Color::splat(zero);
                        lambert += same(&Coefficients { kd: Color::new(x, y, z), ks: others, kr: others, kt: others, ..base });
                    }
                }
            }
        }
        // One edge value in one channel of one other weight, kd fixed: only zeros pass.
        for &v in &edges {
            for w in 0..3 {
                for c in 0..3 {
                    let mut weights = [Color::ZERO; 3];
                    weights[w][c] = v;
                    let [ks, kr, kt] = weights;
                    same(&Coefficients { kd: Color::new(0.6, 0.3, 0.2), ks, kr, kt, ..base });
                }
            }
        }
        for fresnel in [Fresnel::Schlick, Fresnel::Exact] {
            same(&Coefficients { kd: Color::splat(0.5), fresnel, ..base });
        }
        // Random weights, most zero.
        let mut h = 7u64;
        let mut next = || {
            h = raylab::math::sampler::mix64(h);
            let pick = edges[(h % 16) as usize];
            if h >> 60 < 6 { (h >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 0.5 } else { pick }
        };
        for i in 0..100_000 {
            let mut c = || Color::new(next(), next(), next());
            let kd = c();
            let (ks, kr, kt) = if i % 4 == 0 { (c(), c(), c()) } else { (Color::ZERO, Color::ZERO, Color::ZERO) };
            lambert += same(&Coefficients { kd, ks, kr, kt, ..base });
        }
        assert!(lambert > 20_000, "the diffuse case is exercised ({lambert})");
    }
}
