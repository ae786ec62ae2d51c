//! `point` and `spot`: the report's PointLight, `I_L = I₀ / (kc + kl·d + kq·d²)`, and SpotLight,
//! the same times `max(0, D·L)^exponent` (the report's formula has a typo: the terms add).
//!
//! With `radius > 0` the light is a ball: each sample takes a point, uniform over the disc of that
//! radius centred on the light and facing the shaded point, and attenuates by the distance to it;
//! shadows get penumbrae. The spot's cone and exponent use the light's centre, so the cone's edge
//! stays where it is written.

use raylab::glam::{DVec2, DVec3};
use raylab::math::sampler::{concentric_disc, orthonormal_basis};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::scene::light::LightBound;
use raylab::{Color, LightPdf, LightSample, LightSource, LoadContext, PluginInfo, Ray};
use std::f64::consts::PI;

/// A light at a point with distance attenuation, optionally a spot.
#[derive(Clone, Debug)]
pub struct PointLight {
    color: Color,
    position: DVec3,
    kc: f64,
    kl: f64,
    kq: f64,
    spot: Option<Spot>,
    radius: f64,
    samples: u32,
}

/// The directional part of a spot light.
#[derive(Clone, Copy, Debug)]
pub struct Spot {
    /// Unit axis of the spot (D).
    pub direction: DVec3,
    /// Narrowing exponent: `max(0, D·L)^exponent`; 1 is the report's spot.
    pub exponent: f64,
    /// Cosine of the cone's half-angle: no light where `D·L` is below it.
    pub cos_cutoff: f64,
}

/// The parameters that make a point or spot light an area light.
pub(crate) const AREA: [ParamSpec; 2] = [
    ParamSpec::new(
        "radius",
        ParamKind::Float,
        ParamDefault::Float(0.0),
        "radius of the ball-shaped light for soft shadows, scene units (0 = a point), ≥ 0",
    ),
    ParamSpec::new(
        "samples",
        ParamKind::Int,
        ParamDefault::Int(16),
        "shadow rays per shading point when radius > 0 (the integrator's shadow_rays may override), ≥ 1",
    ),
];

pub(crate) const ATTENUATION: [ParamSpec; 3] = [
    ParamSpec::new("kc", ParamKind::Float, ParamDefault::Float(1.0), "constant attenuation, ≥ 0"),
    ParamSpec::new("kl", ParamKind::Float, ParamDefault::Float(0.0), "linear attenuation, per scene unit, ≥ 0"),
    ParamSpec::new("kq", ParamKind::Float, ParamDefault::Float(0.0), "quadratic attenuation, per scene unit², ≥ 0 (kc + kl + kq > 0)"),
];

/// The `point` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "point",
    summary: "A light bulb at a point: I = color / (kc + kl·d + kq·d²), d the distance to the light.",
    params: &[
        ParamSpec::new("color", ParamKind::Color, ParamDefault::Float(1.0), "intensity I₀, linear RGB"),
        ParamSpec::new("position", ParamKind::Vec3, ParamDefault::Required, "where the light is"),
        ATTENUATION[0],
        ATTENUATION[1],
        ATTENUATION[2],
        AREA[0],
        AREA[1],
    ],
};

/// The `spot` plugin's description.
pub const SPOT_INFO: PluginInfo = PluginInfo {
    name: "spot",
    summary: "A spot light: a point light times max(0, D·L)^exponent, where L points from the light to the shaded point; no light beyond the cone angle.",
    params: &[
        ParamSpec::new("color", ParamKind::Color, ParamDefault::Float(1.0), "intensity I₀, linear RGB"),
        ParamSpec::new("position", ParamKind::Vec3, ParamDefault::Required, "where the light is"),
        ParamSpec::new("direction", ParamKind::Vec3, ParamDefault::Required, "axis of the spot (D), from the light outward"),
        ParamSpec::new(
            "exponent",
            ParamKind::Float,
            ParamDefault::Float(1.0),
            "narrowing exponent (1 = the report's spot; larger = tighter), ≥ 0",
        ),
        ParamSpec::new(
            "cone_angle",
            ParamKind::Float,
            ParamDefault::Float(90.0),
            "half-angle of the cone outside which there is no light, degrees, in (0, 90]",
        ),
        ATTENUATION[0],
        ATTENUATION[1],
        ATTENUATION[2],
        AREA[0],
        AREA[1],
    ],
};

/// Reads `samples` (a shadow-ray count).
pub(crate) fn samples(p: &mut Params) -> Result<u32> {
    Ok(p.int_in("samples", 1..=65536)? as u32)
}

pub(crate) fn attenuation(p: &mut Params) -> Result<(f64, f64, f64)> {
    let (kc, kl, kq) = (p.non_negative("kc")?, p.non_negative("kl")?, p.non_negative("kq")?);
    if kc + kl + kq <= 0.0 {
        return Err(p.error("at least one of kc, kl, kq must be > 0"));
    }
    Ok((kc, kl, kq))
}

/// Builds a point light from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn LightSource>> {
    let color = p.color("color")?;
    let position = p.vec3("position")?;
    let (kc, kl, kq) = attenuation(p)?;
    let (radius, samples) = (p.non_negative("radius")?, samples(p)?);
    Ok(Box::new(PointLight { color, position, kc, kl, kq, spot: None, radius, samples }))
}

/// Builds a spot light from its parameters.
pub fn build_spot(p: &mut Params, _: &LoadContext) -> Result<Box<dyn LightSource>> {
    let color = p.color("color")?;
    let position = p.vec3("position")?;
    let direction = p.direction("direction")?;
    let exponent = p.non_negative("exponent")?;
    let cone = p.float("cone_angle")?;
    if !(cone > 0.0 && cone <= 90.0) {
        return Err(p.error_at("cone_angle", format_args!("{cone} is out of range; expected a half-angle in (0, 90] degrees")));
    }
    let (kc, kl, kq) = attenuation(p)?;
    let spot = Spot { direction, exponent, cos_cutoff: cone.to_radians().cos() };
    let (radius, samples) = (p.non_negative("radius")?, samples(p)?);
    Ok(Box::new(PointLight { color, position, kc, kl, kq, spot: Some(spot), radius, samples }))
}

impl PointLight {
    /// A point light with attenuation `(kc, kl, kq)` (non-negative, not all zero).
    pub fn new(color: Color, position: DVec3, kc: f64, kl: f64, kq: f64) -> Self {
        PointLight { color, position, kc, kl, kq, spot: None, radius: 0.0, samples: 1 }
    }

    /// A spot light (the report's: exponent 1, cone 90°).
    pub fn spot(color: Color, position: DVec3, kc: f64, kl: f64, kq: f64, spot: Spot) -> Self {
        PointLight { color, position, kc, kl, kq, spot: Some(spot), radius: 0.0, samples: 1 }
    }

    /// The same light as a ball of `radius` (> 0 for soft shadows), sampled `samples` times.
    pub fn with_radius(mut self, radius: f64, samples: u32) -> Self {
        self.radius = radius;
        self.samples = samples.max(1);
        self
    }
}

impl PointLight {
    /// Light arriving from `d` away at a point that sees the light's centre along `to_centre`,
    /// `dc` away (the spot's cone and exponent use the centre).
    #[inline]
    fn intensity(&self, to_centre: DVec3, dc: f64, d: f64) -> Color {
        self.intensity_toward(|| to_centre / dc, d)
    }

    /// [`PointLight::intensity`] with the unit direction to the centre, `to_centre / dc`, computed
    /// by `centre_dir` (only for a spot; a point light's sample already holds it).
    #[inline]
    fn intensity_toward(&self, centre_dir: impl FnOnce() -> DVec3, d: f64) -> Color {
        let mut factor = 1.0;
        if let Some(s) = &self.spot {
            // L points from the light to the point: L = −dir (negation is exact: −(v/dc) = (−v)/dc).
            let cos = s.direction.dot(-centre_dir());
            factor = if cos <= 0.0 || cos < s.cos_cutoff { 0.0 } else { spot_power(cos, s.exponent) };
        }
        let attenuation = self.kc + self.kl * d + self.kq * d * d;
        // Without attenuation (kc = 1, kl = kq = 0, the default) the divisor is 1, and a division
        // by 1 changes no bit: skipped, off the path to the sample's intensity.
        if attenuation != 1.0 {
            factor /= attenuation;
        }
        self.color * factor
    }
}

/// `cos^exponent` for `0 < cos ≤ 1`: the common exponents 1 and 2 exactly (`cos`, and `cos²`
/// rounded once, which `powf` matches to its 0.52 ulp), any other by `powf` (a library call at
/// ten times the cost).
#[inline]
fn spot_power(cos: f64, exponent: f64) -> f64 {
    if exponent == 1.0 {
        cos
    } else if exponent == 2.0 {
        cos * cos
    } else {
        cos.powf(exponent)
    }
}

impl LightSource for PointLight {
    #[inline]
    fn illuminate(&self, p: DVec3, u: DVec2) -> Option<LightSample> {
        let to_centre = self.position - p;
        let dc = to_centre.length();
        if !(dc > 0.0) {
            return None;
        }
        if !(self.radius > 0.0) {
            // A point: the sample's direction is the centre's (one square root, one division).
            let dir = to_centre / dc;
            return Some(LightSample { dir, distance: dc, intensity: self.intensity_toward(|| dir, dc) });
        }
        let to_light = {
            let (b1, b2) = orthonormal_basis(to_centre / dc);
            let q = concentric_disc(u) * self.radius;
            to_centre + q.x * b1 + q.y * b2
        };
        let d = to_light.length();
        if !(d > 0.0) {
            return None;
        }
        Some(LightSample { dir: to_light / d, distance: d, intensity: self.intensity(to_centre, dc, d) })
    }

    /// The ball (a point: radius 0); the intensity unattenuated beyond the ball's nearest point,
    /// the spot's factor (at most 1) left out.
    fn bound(&self, p: DVec3) -> Option<LightBound> {
        let d = ((self.position - p).length() - self.radius).max(0.0);
        let attenuation = self.kc + self.kl * d + self.kq * d * d;
        Some(LightBound { centre: self.position, radius: self.radius, intensity: self.color.abs() / attenuation })
    }

    /// A point is a delta light; a ball's samples are uniform over its disc facing `p`.
    fn pdf(&self, p: DVec3, sample: &LightSample) -> LightPdf {
        if !(self.radius > 0.0) {
            return LightPdf::Delta;
        }
        let axis = (self.position - p).normalize();
        LightPdf::from_area(1.0 / (PI * self.radius * self.radius), sample.distance, sample.dir.dot(axis))
    }

    /// The ball's disc facing the ray's origin, where the ray crosses it.
    fn intersect(&self, ray: &Ray, t_max: f64) -> Option<LightSample> {
        if !(self.radius > 0.0) {
            return None;
        }
        let to_centre = self.position - ray.origin;
        let dc = to_centre.length();
        let toward = ray.dir.dot(to_centre);
        if !(dc > 0.0 && toward > 0.0) {
            return None;
        }
        // The disc's plane is at distance dc along its normal to_centre / dc.
        let t = dc * dc / toward;
        if !(t < t_max) || (ray.at(t) - self.position).length_squared() > self.radius * self.radius {
            return None;
        }
        Some(LightSample { dir: ray.dir, distance: t, intensity: self.intensity(to_centre, dc, t) })
    }

    fn sample_count(&self) -> u32 {
        if self.radius > 0.0 { self.samples } else { 1 }
    }

    fn is_area(&self) -> bool {
        self.radius > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raylab::scene::light::testing::check_light;

    #[test]
    fn samples_rays_and_densities_agree() {
        let p = DVec3::new(0.2, -0.1, 0.3);
        let at = DVec3::new(0.5, 1.5, -0.4);
        let spot = Spot { direction: DVec3::new(0.1, -1.0, 0.2).normalize(), exponent: 4.0, cos_cutoff: 0.5 };
        // A point and a spot are delta lights: no ray meets them.
        check_light(&PointLight::new(Color::ONE, at, 1.0, 0.2, 0.1), p, 4, 8, 0.0);
        check_light(&PointLight::spot(Color::ONE, at, 1.0, 0.0, 0.3, spot), p, 4, 8, 0.0);
        // Balls: the disc facing the shaded point, met by the rays toward it.
        check_light(&PointLight::new(Color::new(0.5, 1.0, 2.0), at, 1.0, 0.2, 0.1).with_radius(0.7, 16), p, 64, 1500, 0.01);
        check_light(&PointLight::spot(Color::ONE, at, 1.0, 0.0, 0.3, spot).with_radius(0.4, 16), p, 64, 1500, 0.01);
    }

    /// Balls and spots with a radius: the directions of their samples (a disc facing the shaded
    /// point) follow the density `pdf` claims, from far, from close by, and from inside a spot's
    /// cone and outside it (a spot's samples there carry no light but keep their directions).
    #[test]
    fn sampling_passes_the_chi2_test() {
        use raylab::scene::light::testing::chi2_light;
        use raylab::testing::chi2::{Chi2Test, Sphere};
        let test = Chi2Test::new(Sphere).res(72, 36).tests(4);
        let at = DVec3::new(0.5, 1.5, -0.4);
        let spot = Spot { direction: DVec3::new(0.1, -1.0, 0.2).normalize(), exponent: 4.0, cos_cutoff: 0.9 };
        let ball = PointLight::new(Color::ONE, at, 1.0, 0.2, 0.1).with_radius(0.9, 16);
        let spot = PointLight::spot(Color::ONE, at, 1.0, 0.0, 0.3, spot).with_radius(0.6, 16);
        chi2_light(&ball, DVec3::new(0.2, 0.3, 0.1), &test).assert_passes("ball, close");
        chi2_light(&ball, DVec3::new(-2.0, -1.0, 1.0), &test).assert_passes("ball, far");
        chi2_light(&spot, DVec3::new(0.55, 0.5, -0.3), &test).assert_passes("spot, inside its cone");
        chi2_light(&spot, DVec3::new(-0.5, 1.0, 0.3), &test).assert_passes("spot, outside its cone");
    }

    /// Exponent 1 is `cos` itself; 2 is within `powf`'s half ulp; others are `powf`.
    #[test]
    fn spot_power_matches_powf() {
        for k in 1..=1000 {
            let c = f64::from(k) / 1000.0;
            assert_eq!(spot_power(c, 1.0), c);
            let (a, b) = (spot_power(c, 2.0), c.powf(2.0));
            assert!((a - b).abs() <= f64::EPSILON * b, "{c}²: {a} vs {b}");
            assert_eq!(spot_power(c, 3.5), c.powf(3.5));
        }
    }
}
