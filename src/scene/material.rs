//! Surface materials: the report's coefficients (kd, ks, kr, kt, n), extended with colour,
//! ambient response, shininess, emission and a glossiness (blur) parameter.
//!
//! A [`Material`] describes a surface; [`Material::at`] gives its [`Coefficients`] at one point
//! of it, which is what integrators read. Every integrator interprets the same coefficients in
//! its own way (the report's Phong model, a path tracer's normalised Phong BRDF).

use crate::input::error::{Loc, Result, SceneError, did_you_mean};
use crate::input::params::Params;
use crate::input::spec::{Default, ParamKind, ParamSpec};
use crate::input::value::{Node, Table, Value};
use crate::math::color::Color;
use glam::{DVec2, DVec3};
use std::collections::BTreeMap;

/// How a surface responds to light. All coefficients are linear RGB in [0, ∞) (a single number in
/// a scene file means grey); energy conservation is the scene author's business, as in the report.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Response to ambient light (the report adds ambient unfiltered: 1).
    pub ka: Color,
    /// Diffuse (Lambert) coefficient: `kd · (n·l) · I_L`.
    pub kd: Color,
    /// Specular (Phong) coefficient: `ks · max(0, −v·r)^shininess · I_L`.
    pub ks: Color,
    /// Mirror reflection coefficient: weight of the reflected ray.
    pub kr: Color,
    /// Transmission coefficient: weight of the refracted ray, and the fraction of light a shadow
    /// ray keeps when it passes through this surface.
    pub kt: Color,
    /// Phong exponent (≥ 0); larger means a smaller, sharper highlight.
    pub shininess: f64,
    /// Index of refraction (> 0) of the solid's inside relative to the outside. Bends rays only at
    /// closed solids; open surfaces are thin sheets that transmit straight through.
    pub ior: f64,
    /// Light the surface emits itself (the report's emission), linear RGB.
    pub emission: Color,
    /// Glossiness: radius of the disc, at unit distance along the ideal reflected or refracted
    /// direction, in which jittered rays are spread (≈ half-angle of the blur cone in radians).
    /// 0 means a perfect mirror or clear glass.
    pub blur: f64,
}

impl std::default::Default for Material {
    fn default() -> Self {
        Material {
            ka: Color::ONE,
            kd: Color::splat(0.8),
            ks: Color::ZERO,
            kr: Color::ZERO,
            kt: Color::ZERO,
            shininess: 32.0,
            ior: 1.5,
            emission: Color::ZERO,
            blur: 0.0,
        }
    }
}

/// A material's coefficients at one point of a surface (see [`Material`] for their meaning).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    /// Response to ambient light.
    pub ka: Color,
    /// Diffuse coefficient.
    pub kd: Color,
    /// Specular coefficient.
    pub ks: Color,
    /// Mirror reflection coefficient.
    pub kr: Color,
    /// Transmission coefficient.
    pub kt: Color,
    /// Phong exponent (≥ 0).
    pub shininess: f64,
    /// Index of refraction of a closed solid's inside (> 0).
    pub ior: f64,
    /// Emitted light, linear RGB.
    pub emission: Color,
    /// Glossiness: jitter-disc radius at unit distance (0 = sharp).
    pub blur: f64,
}

/// The material parameter table (the keys of `[materials.NAME]` and of inline materials).
pub const MATERIAL_PARAMS: &[ParamSpec] = &[
    ParamSpec::new("ka", ParamKind::Color, Default::Float(1.0), "response to ambient light (1 = the report: ambient added unfiltered)"),
    ParamSpec::new("kd", ParamKind::Color, Default::Float(0.8), "diffuse coefficient (colour)"),
    ParamSpec::new("ks", ParamKind::Color, Default::Float(0.0), "specular (Phong highlight) coefficient"),
    ParamSpec::new("kr", ParamKind::Color, Default::Float(0.0), "mirror reflection coefficient"),
    ParamSpec::new("kt", ParamKind::Color, Default::Float(0.0), "transmission coefficient (also attenuates shadows)"),
    ParamSpec::new("shininess", ParamKind::Float, Default::Float(32.0), "Phong exponent, ≥ 0"),
    ParamSpec::new("ior", ParamKind::Float, Default::Float(1.5), "index of refraction of a closed solid's inside, > 0"),
    ParamSpec::new("emission", ParamKind::Color, Default::Float(0.0), "emitted light, linear RGB"),
    ParamSpec::new("blur", ParamKind::Float, Default::Float(0.0), "glossiness: jitter-disc radius at unit distance (0 = sharp), 0..1"),
];

impl Material {
    /// Reads a material from its parameters.
    pub fn from_params(p: &mut Params) -> Result<Material> {
        let ior = p.positive("ior")?;
        Ok(Material {
            ka: p.color("ka")?,
            kd: p.color("kd")?,
            ks: p.color("ks")?,
            kr: p.color("kr")?,
            kt: p.color("kt")?,
            shininess: p.non_negative("shininess")?,
            ior,
            emission: p.color("emission")?,
            blur: p.float_in("blur", 0.0..=1.0)?,
        })
    }

    /// Reads a material from a table written at `loc`, checking for unknown keys.
    pub fn from_table(t: &Table, loc: &Loc, what: &str) -> Result<Material> {
        let mut p = Params::new(what, MATERIAL_PARAMS, t, loc.clone());
        let m = Material::from_params(&mut p)?;
        p.finish()?;
        Ok(m)
    }

    /// The coefficients at a surface point with texture coordinates `uv` and position `local` in
    /// the shape's own frame.
    #[inline]
    pub fn at(&self, uv: DVec2, local: DVec3) -> Coefficients {
        let _ = (uv, local);
        Coefficients {
            ka: self.ka,
            kd: self.kd,
            ks: self.ks,
            kr: self.kr,
            kt: self.kt,
            shininess: self.shininess,
            ior: self.ior,
            emission: self.emission,
            blur: self.blur,
        }
    }

    /// True when the surface may transmit light somewhere.
    pub fn is_transmissive(&self) -> bool {
        self.kt.max_element() > 0.0
    }

    /// True when the surface reflects any light as a mirror.
    pub fn is_reflective(&self) -> bool {
        self.kr.max_element() > 0.0
    }

    /// A quick grey diffuse material.
    pub fn diffuse(kd: Color) -> Material {
        Material { kd, ..Material::default() }
    }

    /// The report's default material: kd = 1, ks = 1, no reflection or transmission, ior = 1,
    /// shininess 1, no emission.
    pub fn report_default() -> Material {
        Material { ka: DVec3::ONE, kd: DVec3::ONE, ks: DVec3::ONE, shininess: 1.0, ior: 1.0, ..Material::default() }
    }
}

/// Named materials of a scene (`[materials.NAME]`). A material named `default` replaces the
/// built-in default for objects that name no material.
#[derive(Clone, Debug, std::default::Default)]
pub struct MaterialLibrary {
    by_name: BTreeMap<String, Material>,
}

impl MaterialLibrary {
    /// Adds or replaces a named material.
    pub fn insert(&mut self, name: impl Into<String>, m: Material) {
        self.by_name.insert(name.into(), m);
    }

    /// The material called `name`.
    pub fn get(&self, name: &str) -> Option<&Material> {
        self.by_name.get(name)
    }

    /// All names, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.by_name.keys().map(String::as_str)
    }

    /// The material for objects that name none.
    pub fn default_material(&self) -> Material {
        self.by_name.get("default").cloned().unwrap_or_default()
    }

    /// The material a scene value names: the name of one of these materials, or an inline table
    /// of coefficients (`what` names the value's owner in messages).
    pub fn resolve(&self, node: &Node, what: &str) -> Result<Material> {
        match &node.value {
            Value::Str(s) => match self.get(s) {
                Some(m) => Ok(m.clone()),
                None if s == "default" => Ok(Material::default()),
                None => {
                    let names: Vec<&str> = self.names().collect();
                    let e =
                        SceneError::at(&node.loc, format!("parameter `material`: no material named \"{s}\" in [materials]")).context(what);
                    Err(e.with_help(match did_you_mean(s, names.iter().copied()) {
                        Some(m) => format!("did you mean \"{m}\"?"),
                        None if names.is_empty() => "no materials are defined; add a [materials.NAME] table".into(),
                        None => format!("defined materials: {}", names.join(", ")),
                    }))
                }
            },
            Value::Table(t) => Material::from_table(t, &node.loc, &format!("{what} material")),
            v => Err(SceneError::at(
                &node.loc,
                format!("parameter `material`: expected a material name or an inline table, found {}", v.type_name()),
            )
            .context(what)),
        }
    }
}
