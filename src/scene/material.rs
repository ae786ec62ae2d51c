//! Surface materials: the report's coefficients (kd, ks, kr, kt, n), extended with colour,
//! ambient response, shininess, emission and a glossiness (blur) parameter.
//!
//! A [`Material`] describes a surface; [`Material::at`] gives its [`Coefficients`] at one point
//! of it, which is what integrators read. Every integrator interprets the same coefficients in
//! its own way (the report's Phong model, a path tracer's normalised Phong BRDF).
//!
//! Any colour of a material may be textured ([`TextureMap`]): the texture's value at the hit
//! multiplies the material's constant (a texture named in a scene file has the constant 1; a
//! mesh file's factor, such as glTF's `baseColorFactor`, is the constant). A material without
//! textures costs one test per hit more than constants.

use crate::math::color::Color;
use crate::param::error::{Loc, Result, SceneError, did_you_mean};
use crate::param::params::Params;
use crate::param::spec::{ParamDefault, ParamKind, ParamSpec};
use crate::param::value::{Node, Table, Value};
use crate::scene::bsdf::MaterialModel;
use crate::scene::texture::{Texture, TexturePoint, TextureResolver};
use glam::DVec3;
use std::collections::BTreeMap;
use std::sync::Arc;

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
    /// How reflection and transmission vary with the angle of incidence (off: the fixed `kr`
    /// and `kt` of the report).
    pub fresnel: Fresnel,
    /// Textures multiplying the colours above, evaluated at each hit (empty: constants).
    pub textures: Vec<TextureMap>,
    /// The material plugin's own scattering model (`None`: the coefficients alone, read by each
    /// integrator in its own way).
    pub model: Option<Model>,
    /// Where the surface is cut away (glTF `alphaMode` MASK and BLEND, MTL `map_d`): rays pass
    /// through those parts as if nothing were there. `None`: the surface is everywhere.
    pub cutout: Option<Cutout>,
    /// A normal or bump map tilting the shading normal (glTF `normalTexture`, MTL `norm`,
    /// `bump`, `map_Bump`; see [`crate::scene::normal_map`]). `None`: the shape's own normal.
    pub normal_map: Option<NormalMap>,
}

/// A surface's coverage (alpha): where it is there for rays and where it is a hole. Shapes that
/// support it (meshes) test it at each hit they find, for every kind of ray (camera, secondary,
/// shadow), and go on to the next hit when the surface is not there.
#[derive(Clone, Debug)]
pub struct Cutout {
    /// The coverage constant in [0, 1] (glTF's `baseColorFactor` alpha, MTL `d`), multiplied by
    /// the texture's first channel.
    pub alpha: f64,
    /// The coverage texture (its red channel: an image's alpha, or its grey value).
    pub texture: Option<Arc<dyn Texture>>,
    /// How coverage decides.
    pub mode: AlphaMode,
}

/// How a [`Cutout`]'s coverage decides whether a ray meets the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Present where coverage ≥ `cutoff` (glTF `MASK`, default cutoff 0.5).
    Mask {
        /// The threshold.
        cutoff: f64,
    },
    /// Present with probability equal to the coverage (stochastic transparency; glTF `BLEND`,
    /// MTL `map_d`): `u`, the ray's own hash, decides, so the same ray always gets the same
    /// answer and an image is the same whatever the threads or tiles.
    Blend,
}

/// Equal when the constants are and the texture is the same object.
impl PartialEq for Cutout {
    fn eq(&self, other: &Self) -> bool {
        self.alpha == other.alpha
            && self.mode == other.mode
            && match (&self.texture, &other.texture) {
                (Some(a), Some(b)) => Arc::ptr_eq(a, b),
                (None, None) => true,
                _ => false,
            }
    }
}

impl Cutout {
    /// The cut-out, or `None` when it cuts nothing away (an untextured coverage that keeps the
    /// whole surface): such a surface costs rays nothing.
    pub fn new(alpha: f64, texture: Option<Arc<dyn Texture>>, mode: AlphaMode) -> Option<Cutout> {
        let alpha = if alpha.is_finite() { alpha.clamp(0.0, 1.0) } else { 1.0 };
        let whole = match mode {
            AlphaMode::Mask { cutoff } => alpha >= cutoff,
            AlphaMode::Blend => alpha >= 1.0,
        };
        (texture.is_some() || !whole).then_some(Cutout { alpha, texture, mode })
    }

    /// The coverage in [0, 1] at `at`.
    #[inline]
    pub fn coverage(&self, at: impl FnOnce() -> TexturePoint) -> f64 {
        match &self.texture {
            Some(t) => {
                let a = self.alpha * t.eval(&at()).x;
                if a.is_finite() { a.clamp(0.0, 1.0) } else { 1.0 }
            }
            None => self.alpha,
        }
    }

    /// Whether the surface is there at `at` for a ray whose hash is `u` ∈ [0, 1) (read only in
    /// [`AlphaMode::Blend`]).
    #[inline]
    pub fn keeps(&self, at: impl FnOnce() -> TexturePoint, u: impl FnOnce() -> f64) -> bool {
        let a = self.coverage(at);
        match self.mode {
            AlphaMode::Mask { cutoff } => a >= cutoff,
            AlphaMode::Blend => a >= 1.0 || (a > 0.0 && u() < a),
        }
    }
}

/// What a [`NormalMap`]'s texture holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalMapKind {
    /// Tangent-space normals, each channel mapped from [0, 1] to [−1, 1]: red along the surface's
    /// `u` tangent, green along `v` (up in the image), blue along the normal (glTF
    /// `normalTexture`, MTL `norm`). `scale` multiplies red and green.
    Tangent,
    /// Heights (the texture's first channel), `scale` scene units per unit of texture value: the
    /// normal is that of the surface displaced by the height (MTL `bump`, `map_Bump`).
    Bump,
}

/// A texture that tilts the shading normal (see [`crate::scene::normal_map`]).
#[derive(Clone, Debug)]
pub struct NormalMap {
    /// The normals or heights.
    pub texture: Arc<dyn Texture>,
    /// What it holds.
    pub kind: NormalMapKind,
    /// glTF `normalTexture.scale`, MTL `-bm`: the strength of the tilt.
    pub scale: f64,
}

/// Equal when the kind and scale are and the texture is the same object.
impl PartialEq for NormalMap {
    fn eq(&self, other: &Self) -> bool {
        self.kind == other.kind && self.scale == other.scale && Arc::ptr_eq(&self.texture, &other.texture)
    }
}

/// A material plugin's scattering model, shared by every object using the material.
#[derive(Clone, Debug)]
pub struct Model(pub Arc<dyn MaterialModel>);

/// Two models are equal when they are the same object.
impl PartialEq for Model {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// A colour of a material that a texture may vary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    /// `ka`.
    Ka,
    /// `kd`.
    Kd,
    /// `ks`.
    Ks,
    /// `kr`.
    Kr,
    /// `kt`.
    Kt,
    /// `emission`.
    Emission,
}

impl Channel {
    /// Every channel with its parameter name.
    pub const ALL: [(Channel, &'static str); 6] = [
        (Channel::Ka, "ka"),
        (Channel::Kd, "kd"),
        (Channel::Ks, "ks"),
        (Channel::Kr, "kr"),
        (Channel::Kt, "kt"),
        (Channel::Emission, "emission"),
    ];
}

/// A texture multiplying one colour of a material.
#[derive(Clone, Debug)]
pub struct TextureMap {
    /// The colour it multiplies.
    pub channel: Channel,
    /// The texture.
    pub texture: Arc<dyn Texture>,
}

/// Two maps are equal when they vary the same channel by the same texture (the same object).
impl PartialEq for TextureMap {
    fn eq(&self, other: &Self) -> bool {
        self.channel == other.channel && Arc::ptr_eq(&self.texture, &other.texture)
    }
}

/// The Fresnel weighting of a material's reflection and transmission (POV-Ray's
/// `reflection { fresnel }`): with `F` the dielectric reflectance for the angle of incidence and
/// the material's `ior`, reflected light is weighted `F·kr` and transmitted light `(1 − F)·kt`,
/// so `kr` and `kt` become filters (1 and 1 for clear glass). Total internal reflection has
/// `F = 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Fresnel {
    /// Fixed `kr` and `kt` (the report).
    #[default]
    Off,
    /// Schlick's approximation `R₀ + (1 − R₀)(1 − cos θ)⁵` (θ on the optically thinner side).
    Schlick,
    /// The exact reflectance of unpolarised light at a dielectric boundary (Fresnel's equations).
    Exact,
}

impl Fresnel {
    /// The fraction of light reflected (in [0, 1]) by a boundary into a medium of relative index
    /// `eta` (= n_transmitted / n_incident, > 0), for light arriving at `cos_i` (cosine of the
    /// angle to the normal, in [0, 1]). 0 when off.
    #[inline]
    pub fn reflectance(self, cos_i: f64, eta: f64) -> f64 {
        let cos_i = cos_i.clamp(0.0, 1.0);
        let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
        match self {
            Fresnel::Off => 0.0,
            _ if !(sin2_t < 1.0) => 1.0,
            Fresnel::Schlick => {
                let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
                // Schlick's cosine is the one on the thinner side.
                let c = if eta >= 1.0 { cos_i } else { (1.0 - sin2_t).sqrt() };
                r0 + (1.0 - r0) * (1.0 - c).powi(5)
            }
            Fresnel::Exact => {
                let cos_t = (1.0 - sin2_t).sqrt();
                let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
                let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
                (0.5 * (rs * rs + rp * rp)).clamp(0.0, 1.0)
            }
        }
    }
}

impl Default for Material {
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
            fresnel: Fresnel::Off,
            textures: Vec::new(),
            model: None,
            cutout: None,
            normal_map: None,
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
    /// How `kr` and `kt` vary with the angle of incidence.
    pub fresnel: Fresnel,
}

/// A material's [`Coefficients`] at one hit, as an
/// [`Interaction`](crate::scene::interaction::Interaction) holds them: borrowed from the object
/// when the material has no textures (the same everywhere, so nothing is copied per hit),
/// evaluated at the hit otherwise. Dereferences to the coefficients.
#[derive(Clone, Copy, Debug)]
pub enum CoefficientsAt<'s> {
    /// An untextured material's coefficients.
    Constant(&'s Coefficients),
    /// A textured material's coefficients at the hit.
    Textured(Coefficients),
}

/// Equal when the coefficients are, borrowed or evaluated.
impl PartialEq for CoefficientsAt<'_> {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl std::ops::Deref for CoefficientsAt<'_> {
    type Target = Coefficients;
    #[inline]
    fn deref(&self) -> &Coefficients {
        match self {
            CoefficientsAt::Constant(c) => c,
            CoefficientsAt::Textured(c) => c,
        }
    }
}

/// The material parameter table (the keys of `[materials.NAME]` and of inline materials).
pub const MATERIAL_PARAMS: &[ParamSpec] = &[
    ParamSpec::new(
        "ka",
        ParamKind::Texture,
        ParamDefault::Float(1.0),
        "response to ambient light (1 = the report: ambient added unfiltered)",
    ),
    ParamSpec::new("kd", ParamKind::Texture, ParamDefault::Float(0.8), "diffuse coefficient (colour)"),
    ParamSpec::new("ks", ParamKind::Texture, ParamDefault::Float(0.0), "specular (Phong highlight) coefficient"),
    ParamSpec::new("kr", ParamKind::Texture, ParamDefault::Float(0.0), "mirror reflection coefficient"),
    ParamSpec::new("kt", ParamKind::Texture, ParamDefault::Float(0.0), "transmission coefficient (also attenuates shadows)"),
    ParamSpec::new("shininess", ParamKind::Float, ParamDefault::Float(32.0), "Phong exponent, ≥ 0"),
    ParamSpec::new("ior", ParamKind::Float, ParamDefault::Float(1.5), "index of refraction of a closed solid's inside, > 0"),
    ParamSpec::new("emission", ParamKind::Texture, ParamDefault::Float(0.0), "emitted light, linear RGB"),
    ParamSpec::new("blur", ParamKind::Float, ParamDefault::Float(0.0), "glossiness: jitter-disc radius at unit distance (0 = sharp), 0..1"),
    ParamSpec::new(
        "fresnel",
        ParamKind::Str,
        ParamDefault::Str("off"),
        "\"off\" (fixed kr, kt: the report), \"schlick\" or \"exact\" (true = \"exact\"): reflection F·kr and transmission (1 − F)·kt with F the dielectric reflectance for the angle and `ior`; clear glass is kr = kt = 1",
    ),
    NORMAL_MAP_PARAMS[0],
    NORMAL_MAP_PARAMS[1],
    NORMAL_MAP_PARAMS[2],
];

/// The normal- and bump-map parameters every built-in material type reads
/// ([`NormalMap::from_params`]).
pub const NORMAL_MAP_PARAMS: [ParamSpec; 3] = [
    ParamSpec::new(
        "normal_map",
        ParamKind::Texture,
        ParamDefault::Optional,
        "a tangent-space normal map (a texture of linear data: an image with colorspace = \"linear\"), tilting the shading normal over the shape's texture coordinates",
    ),
    ParamSpec::new(
        "bump_map",
        ParamKind::Texture,
        ParamDefault::Optional,
        "a height map (its first channel, times normal_scale, in scene units) whose slopes tilt the shading normal; not with normal_map",
    ),
    ParamSpec::new(
        "normal_scale",
        ParamKind::Float,
        ParamDefault::Float(1.0),
        "normal_map: multiplies the normals' tilt (glTF normalTexture.scale); bump_map: scene units per unit of height",
    ),
];

impl NormalMap {
    /// The normal or bump map of a material's parameters ([`NORMAL_MAP_PARAMS`]), if it names one.
    pub fn from_params(p: &mut Params, textures: &dyn TextureResolver) -> Result<Option<NormalMap>> {
        let scale = p.float("normal_scale")?;
        let normal = p.node("normal_map")?;
        let bump = p.node("bump_map")?;
        let (node, kind, name) = match (normal, bump) {
            (Some(_), Some(_)) => return Err(p.error_at("bump_map", "a material has a normal_map or a bump_map, not both")),
            (Some(n), None) => (n, NormalMapKind::Tangent, "normal_map"),
            (None, Some(n)) => (n, NormalMapKind::Bump, "bump_map"),
            (None, None) => return Ok(None),
        };
        let texture = textures.resolve(node, &format!("{}: parameter `{name}`", p.what()))?;
        Ok(Some(NormalMap { texture, kind, scale }))
    }
}

impl Material {
    /// Reads a material from its parameters; colours naming a texture (a name in `textures`, or
    /// an inline table with a `type`) are textured.
    pub fn from_params(p: &mut Params, textures: &dyn TextureResolver) -> Result<Material> {
        let mut m = Material::default();
        for (channel, name) in Channel::ALL {
            let c = match p.node(name)? {
                // Anything but a colour is a texture (or an error saying what a colour may be).
                Some(n) if !matches!(n.value, Value::Int(_) | Value::Float(_) | Value::Array(_)) => {
                    let texture = textures.resolve(n, &format!("{}: parameter `{name}`", p.what()))?;
                    m.textures.push(TextureMap { channel, texture });
                    Color::ONE
                }
                _ => p.color(name)?,
            };
            *m.channel_mut(channel) = c;
        }
        m.ior = p.positive("ior")?;
        m.shininess = p.non_negative("shininess")?;
        m.blur = p.float_in("blur", 0.0..=1.0)?;
        m.normal_map = NormalMap::from_params(p, textures)?;
        m.fresnel = match p.node("fresnel")? {
            None => Fresnel::Off,
            Some(n) => match &n.value {
                Value::Bool(b) => {
                    if *b {
                        Fresnel::Exact
                    } else {
                        Fresnel::Off
                    }
                }
                Value::Str(_) => match p.choice("fresnel", &["off", "schlick", "exact"])?.as_str() {
                    "schlick" => Fresnel::Schlick,
                    "exact" => Fresnel::Exact,
                    _ => Fresnel::Off,
                },
                v => {
                    return Err(p.error_at(
                        "fresnel",
                        format_args!("expected \"off\", \"schlick\", \"exact\" or true/false, found {}", v.type_name()),
                    ));
                }
            },
        };
        Ok(m)
    }

    /// Reads a material from a table written at `loc`, checking for unknown keys: its `type`'s
    /// plugin builds it (through `types`: the loader's registry); without a `type`, the table is
    /// the coefficients themselves (`phong`).
    pub fn from_table(t: &Table, loc: &Loc, what: &str, types: &dyn MaterialTypes) -> Result<Material> {
        if let Some(ty) = t.get("type") {
            return types.build_material(ty, t, loc, what);
        }
        let mut p = Params::new(what, MATERIAL_PARAMS, t, loc.clone());
        let m = Material::from_params(&mut p, types)?;
        p.finish()?;
        Ok(m)
    }

    /// The constant of a colour channel (the factor its texture multiplies).
    pub fn channel_mut(&mut self, channel: Channel) -> &mut Color {
        match channel {
            Channel::Ka => &mut self.ka,
            Channel::Kd => &mut self.kd,
            Channel::Ks => &mut self.ks,
            Channel::Kr => &mut self.kr,
            Channel::Kt => &mut self.kt,
            Channel::Emission => &mut self.emission,
        }
    }

    /// This material with `channel` multiplied by `texture`.
    pub fn with_texture(mut self, channel: Channel, texture: Arc<dyn Texture>) -> Material {
        self.textures.push(TextureMap { channel, texture });
        self
    }

    /// True when some colour is textured (hits then need texture coordinates).
    #[inline]
    pub fn is_textured(&self) -> bool {
        !self.textures.is_empty()
    }

    /// True when a hit on this material looks up a texture: a textured colour, or a material
    /// model that reads textures (what texture filtering is for).
    #[inline]
    pub fn looks_up_textures(&self) -> bool {
        self.is_textured() || self.model.as_ref().is_some_and(|m| m.0.is_textured())
    }

    /// The coefficients at the surface point `at` gives (asked for only when the material is
    /// textured: texture coordinates and footprint are computed only then).
    #[inline]
    pub fn at(&self, at: impl FnOnce() -> TexturePoint) -> Coefficients {
        let mut c = self.constants();
        if self.is_textured() {
            self.apply_textures(&mut c, &at());
        }
        c
    }

    /// The coefficients before textures: the constants textured colours multiply, and the
    /// coefficients everywhere on an untextured surface.
    #[inline]
    pub fn constants(&self) -> Coefficients {
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
            fresnel: self.fresnel,
        }
    }

    /// Multiplies the textured colours of `c` by their textures' values at `at`.
    fn apply_textures(&self, c: &mut Coefficients, at: &TexturePoint) {
        // A texture mapped to several channels in a row (a glTF base colour: kd, ks and kr) is
        // evaluated once: `eval` is a function of the point.
        let mut last: Option<(&Arc<dyn Texture>, Color)> = None;
        for m in &self.textures {
            let v = match last {
                Some((t, v)) if Arc::ptr_eq(t, &m.texture) => v,
                _ => {
                    let v = m.texture.eval(at);
                    last = Some((&m.texture, v));
                    v
                }
            };
            match m.channel {
                Channel::Ka => c.ka *= v,
                Channel::Kd => c.kd *= v,
                Channel::Ks => c.ks *= v,
                Channel::Kr => c.kr *= v,
                Channel::Kt => c.kt *= v,
                Channel::Emission => c.emission *= v,
            }
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

/// Where a material table with a `type` is built while a scene loads: the loader's texture
/// library ([`crate::load::textures::TextureLibrary`]), which builds it through the registry's
/// material plugins ([`crate::Registry::add_material`]). The scene layer names only this.
pub trait MaterialTypes: TextureResolver {
    /// The material of type `ty` (the table's `type` value) whose parameters are the table `t`,
    /// written at `loc` (`what` names it in messages).
    fn build_material(&self, ty: &Node, t: &Table, loc: &Loc, what: &str) -> Result<Material>;
}

/// Named materials of a scene (`[materials.NAME]`). A material named `default` replaces the
/// built-in default for objects that name no material.
#[derive(Clone, Debug, Default)]
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
    /// of coefficients, whose textures come from `textures` (`what` names the value's owner in
    /// messages).
    pub fn resolve(&self, node: &Node, what: &str, textures: &dyn MaterialTypes) -> Result<Material> {
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
            Value::Table(t) => Material::from_table(t, &node.loc, &format!("{what} material"), textures),
            v => Err(SceneError::at(
                &node.loc,
                format!("parameter `material`: expected a material name or an inline table, found {}", v.type_name()),
            )
            .context(what)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;
    use std::sync::atomic::{AtomicU32, Ordering};

    /// A grey texture that counts its evaluations.
    #[derive(Debug, Default)]
    struct Counting(AtomicU32);

    impl Texture for Counting {
        fn eval(&self, _: &TexturePoint) -> Color {
            self.0.fetch_add(1, Ordering::Relaxed);
            Color::splat(0.5)
        }
    }

    #[test]
    fn a_texture_on_several_channels_in_a_row_is_evaluated_once_per_point() {
        let shared = Arc::new(Counting::default());
        let other = Arc::new(Counting::default());
        let map = |channel, t: &Arc<Counting>| TextureMap { channel, texture: t.clone() as Arc<dyn Texture> };
        let textures = vec![map(Channel::Kd, &shared), map(Channel::Ks, &shared), map(Channel::Kr, &shared), map(Channel::Kt, &other)];
        let m = Material { kd: Color::ONE, ks: Color::splat(0.2), kr: Color::ONE, kt: Color::ONE, textures, ..Material::default() };
        let c = m.at(|| TexturePoint::new(DVec2::ZERO, DVec3::ZERO));
        assert_eq!((c.kd, c.ks, c.kr, c.kt), (Color::splat(0.5), Color::splat(0.1), Color::splat(0.5), Color::splat(0.5)));
        assert_eq!((shared.0.load(Ordering::Relaxed), other.0.load(Ordering::Relaxed)), (1, 1));
    }
}
