//! `ambient`: the report's AmbientLight, constant light everywhere: `color × ka`.

use raylab::glam::{DVec2, DVec3};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::{Color, LightSample, LightSource, LoadContext, PluginInfo};

/// Ambient light of intensity `color × ka`.
#[derive(Clone, Debug)]
pub struct Ambient {
    intensity: Color,
}

/// The `ambient` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "ambient",
    summary: "Ambient light: constant `color × ka` added at every surface point (times the material's ka). No shadows.",
    params: &[
        ParamSpec::new("color", ParamKind::Color, ParamDefault::Float(1.0), "colour, linear RGB"),
        ParamSpec::new("ka", ParamKind::Float, ParamDefault::Float(0.1), "ambient factor (the report fixes it at 0.1), ≥ 0"),
    ],
};

/// Builds an ambient light from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn LightSource>> {
    let color = p.color("color")?;
    let ka = p.non_negative("ka")?;
    Ok(Box::new(Ambient { intensity: color * ka }))
}

impl Ambient {
    /// Ambient light `color × ka`.
    pub fn new(color: Color, ka: f64) -> Self {
        Ambient { intensity: color * ka }
    }
}

impl LightSource for Ambient {
    fn illuminate(&self, _: DVec3, _: DVec2) -> Option<LightSample> {
        None
    }
    fn ambient(&self) -> Color {
        self.intensity
    }
    fn illuminates(&self) -> bool {
        false
    }
}
