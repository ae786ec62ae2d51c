//! `panel`: a rectangular area light, for soft shadows (the light of `docs/writing-a-plugin.md`).
//!
//! The rectangle `corner + a·edge1 + b·edge2` (a, b ∈ [0, 1]) emits from one side, toward
//! `edge1 × edge2`. Each of `samples` shadow samples picks a point on it from the integrator's
//! stratified `u` and sends light `color · cos θ / (kc + kl·d + kq·d²)` from there, θ being the
//! angle from the rectangle's normal; the integrator averages the samples, so points that see only
//! part of the rectangle lie in a penumbra. Samples are uniform over the rectangle (`pdf` gives
//! that density per solid angle), and a ray that meets the rectangle's lit side gets the same
//! sample back from `intersect`, so a path tracer can weigh its own directions against it.

use raylab::glam::{DVec2, DVec3};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Color, LightPdf, LightSample, LightSource, LoadContext, PluginInfo, Ray};

/// The `panel` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "panel",
    summary: "A one-sided rectangular area light, corner + a·edge1 + b·edge2, emitting toward edge1 × edge2: soft shadows. Each sample: color · cos θ / (kc + kl·d + kq·d²).",
    params: &[
        ParamSpec::new("color", ParamKind::Color, ParamDefault::Float(1.0), "intensity, linear RGB"),
        ParamSpec::new("corner", ParamKind::Vec3, ParamDefault::Required, "one corner of the rectangle"),
        ParamSpec::new("edge1", ParamKind::Vec3, ParamDefault::Required, "first edge from the corner, scene units"),
        ParamSpec::new(
            "edge2",
            ParamKind::Vec3,
            ParamDefault::Required,
            "second edge from the corner, perpendicular to edge1; light leaves toward edge1 × edge2",
        ),
        ParamSpec::new(
            "samples",
            ParamKind::Int,
            ParamDefault::Int(16),
            "shadow samples per shaded point (more: smoother penumbrae), 1..4096",
        ),
        ParamSpec::new("kc", ParamKind::Float, ParamDefault::Float(1.0), "constant attenuation, ≥ 0"),
        ParamSpec::new("kl", ParamKind::Float, ParamDefault::Float(0.0), "linear attenuation, per scene unit, ≥ 0"),
        ParamSpec::new("kq", ParamKind::Float, ParamDefault::Float(0.0), "quadratic attenuation, per scene unit², ≥ 0"),
    ],
};

/// A rectangular area light.
#[derive(Clone, Debug)]
pub struct PanelLight {
    color: Color,
    corner: DVec3,
    edge1: DVec3,
    edge2: DVec3,
    normal: DVec3,
    area: f64,
    samples: u32,
    attenuation: [f64; 3],
}

/// Builds a rectangular light from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn LightSource>> {
    let color = p.color("color")?;
    let corner = p.vec3("corner")?;
    let edge1 = p.vec3("edge1")?;
    let edge2 = p.vec3("edge2")?;
    let normal = edge1.cross(edge2);
    if !(normal.length() > 1e-12 * edge1.length() * edge2.length()) {
        return Err(p.error("edge1 and edge2 must be non-zero and not parallel"));
    }
    if edge1.dot(edge2).abs() > 1e-9 * edge1.length() * edge2.length() {
        return Err(p.error_at("edge2", "must be perpendicular to edge1 (the light is a rectangle)"));
    }
    let samples = p.int_in("samples", 1..=4096)? as u32;
    let attenuation = [p.non_negative("kc")?, p.non_negative("kl")?, p.non_negative("kq")?];
    if attenuation.iter().sum::<f64>() <= 0.0 {
        return Err(p.error("at least one of kc, kl, kq must be > 0"));
    }
    Ok(Box::new(PanelLight { color, corner, edge1, edge2, normal: normal.normalize(), area: normal.length(), samples, attenuation }))
}

impl PanelLight {
    /// The sample from the point `d` away along unit `dir`.
    fn sample(&self, dir: DVec3, d: f64) -> LightSample {
        let cos = -self.normal.dot(dir);
        if cos <= 0.0 {
            // Behind the emitting side: no light, but a direction.
            return LightSample { dir, distance: d, intensity: Color::ZERO };
        }
        let [kc, kl, kq] = self.attenuation;
        LightSample { dir, distance: d, intensity: self.color * (cos / (kc + kl * d + kq * d * d)) }
    }
}

impl LightSource for PanelLight {
    fn illuminate(&self, p: DVec3, u: DVec2) -> Option<LightSample> {
        let on_light = self.corner + u.x * self.edge1 + u.y * self.edge2;
        let to_light = on_light - p;
        let d = to_light.length();
        if !(d > 0.0) {
            return None;
        }
        Some(self.sample(to_light / d, d))
    }

    /// Uniform over the rectangle: `1 / area` per unit area.
    fn pdf(&self, _: DVec3, sample: &LightSample) -> LightPdf {
        LightPdf::from_area(1.0 / self.area, sample.distance, self.normal.dot(sample.dir))
    }

    fn intersect(&self, ray: &Ray, t_max: f64) -> Option<LightSample> {
        let facing = -ray.dir.dot(self.normal);
        if !(facing > 0.0) {
            return None; // parallel, or the side that sends no light
        }
        let t = (ray.origin - self.corner).dot(self.normal) / facing;
        let q = ray.at(t) - self.corner;
        // edge1 ⟂ edge2: the coordinates are projections.
        let (a, b) = (q.dot(self.edge1) / self.edge1.length_squared(), q.dot(self.edge2) / self.edge2.length_squared());
        if !(t > 0.0 && t < t_max && (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)) {
            return None;
        }
        Some(self.sample(ray.dir, t))
    }

    fn sample_count(&self) -> u32 {
        self.samples
    }

    fn is_area(&self) -> bool {
        true
    }
}
