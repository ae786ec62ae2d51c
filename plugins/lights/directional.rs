//! `directional`: the report's DirectionalLight, parallel light from infinitely far away (a sun).

use raylab::glam::{DVec2, DVec3};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Color, LightSample, LightSource, LoadContext, PluginInfo};

/// Light of constant `color` travelling along unit `direction`.
#[derive(Clone, Debug)]
pub struct Directional {
    color: Color,
    direction: DVec3,
}

/// The `directional` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "directional",
    summary: "Parallel light from infinitely far away, of constant intensity (no attenuation).",
    params: &[
        ParamSpec::new("color", ParamKind::Color, ParamDefault::Float(1.0), "intensity, linear RGB"),
        ParamSpec::new(
            "direction",
            ParamKind::Vec3,
            ParamDefault::Vec3([0.0, -1.0, 0.0]),
            "direction the light travels (from the light toward the scene)",
        ),
    ],
};

/// Builds a directional light from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn LightSource>> {
    Ok(Box::new(Directional::new(p.color("color")?, p.direction("direction")?)))
}

impl Directional {
    /// A directional light; `direction` must be unit length.
    pub fn new(color: Color, direction: DVec3) -> Self {
        Directional { color, direction }
    }
}

impl LightSource for Directional {
    fn illuminate(&self, _: DVec3, _: DVec2) -> Option<LightSample> {
        Some(LightSample { dir: -self.direction, distance: f64::INFINITY, intensity: self.color })
    }
}
