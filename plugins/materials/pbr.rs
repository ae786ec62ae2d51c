//! `pbr`: glTF 2.0's metallic-roughness material, exactly the specification's BRDF (Appendix B)
//! in the path tracer, and the documented Phong mapping ([`phong_mapping`]) for `phong`.
//!
//! With base colour `c`, metallic `m`, roughness `r` (α = r²), `KHR_materials_ior` `η`,
//! `KHR_materials_specular` weight `s` and colour `sc`, `KHR_materials_transmission` `t`, and
//! `h` the half vector of `v` (toward the viewer) and `l` (toward the light):
//!
//! ```text
//! D   = α² / (π ((n·h)²(α² − 1) + 1)²)                                    GGX / Trowbridge–Reitz
//! V   = 0.5 / ((n·l)·√((n·v)²(1 − α²) + α²) + (n·v)·√((n·l)²(1 − α²) + α²))   height-correlated Smith
//! spec = D·V
//! metal      = spec · (c + (1 − c)(1 − v·h)⁵)                               conductor_fresnel
//! f0         = min(((η − 1)/(η + 1))² · sc, 1)
//! fr         = f0 + (1 − f0)(1 − v·h)⁵
//! base       = (1 − t)·c/π + t·btdf                                         KHR_materials_transmission
//! dielectric = (1 − s·max(fr))·base + s·fr·spec                             fresnel_mix (KHR_materials_specular)
//! f          = (1 − m)·dielectric + m·metal
//! ```
//!
//! With the defaults (η = 1.5, s = 1, sc = 1, t = 0) this is the core specification's
//! `mix(dielectric_brdf, metal_brdf, metallic)` with `fresnel_mix(ior = 1.5, …)`.
//!
//! **Sampling.** Three lobes, chosen in proportion to their expected weight at `v` (the Fresnel
//! terms taken at `n·v`): cosine-weighted directions for the diffuse lobe; GGX's distribution of
//! visible normals (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)) for
//! the specular lobe, whose density is `G1(v)·D(h)/(4·n·v)`; the same for transmission, mirrored
//! through the surface. [`Bsdf::pdf`] is the density of the diffuse and specular strategies
//! together (one-sample MIS), and a sampled direction carries `f·cos/pdf` of that mixture.
//!
//! **Transmission** is glTF's thin-walled one (without `KHR_materials_volume`): light passes
//! through the surface undeflected, blurred by the same microfacets (the reflected direction
//! mirrored through the tangent plane), tinted by `c`. It is a sampled event only: like the
//! Phong model's dielectric, it takes no light samples (`pdf` `None`).
//!
//! **Energy.** The specification's microfacet BRDF is single-scattering: light that would
//! bounce between microfacets more than once is lost, so a white rough metal reflects less than
//! all the light (1 − ln 2 ≈ 31 % at normal incidence for r = 1; under 1 % lost for r ≤ 0.25).
//! And its dielectric mix weighs the diffuse lobe by the Fresnel term of each half vector, so a
//! white dielectric reflects more than arrives toward grazing angles. `pbr` is kept exactly the
//! specification's BRDF, both included (as glTF viewers and the sample renderer are); the
//! furnace tests measure them against quadrature of the same BRDF. docs/materials.md has the
//! figures.
//!
//! **Shading normals.** The lobes live around the shading normal; a direction counts only on the
//! viewer's side of both normals (as for [`PhongBsdf`](super::phong::PhongBsdf)). Where the
//! viewer is below the shading normal's horizon (an interpolated normal at a silhouette), the
//! geometric normal is used instead, so no hit turns black.

use raylab::glam::{DVec2, DVec3};
use raylab::math::color::max_channel;
use raylab::math::sampler::{concentric_disc, orthonormal_basis};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::param::value::Value;
use raylab::scene::bsdf::{Bsdf, Lobe, MaterialModel, Scatter, Shading};
use raylab::scene::material::{Channel, Model, NORMAL_MAP_PARAMS, NormalMap, TextureMap};
use raylab::scene::texture::TextureResolver;
use raylab::scene::texture::{Texture, TexturePoint};
use raylab::{Color, Material, PluginInfo, RayKind};
use std::f64::consts::{FRAC_1_PI, PI, TAU};
use std::sync::Arc;

/// Smallest GGX width α the BSDF uses: a smoother surface is this one (a lobe of about 0.06°,
/// narrower than any pixel), which keeps `D` and the densities finite.
pub const MIN_ALPHA: f64 = 1e-3;

/// Smallest Phong exponent the Phong mapping gives: from 1 up, the lobe `cos^n` falls
/// continuously to zero where the mirror direction turns 90° from the viewer.
pub const MIN_SHININESS: f64 = 1.0;

/// Largest Phong exponent the Phong mapping gives (a mirror-smooth lobe is narrower than a
/// pixel anyway).
pub const MAX_SHININESS: f64 = 1e4;

/// Cosine below which the viewer counts as under the shading normal's horizon (see the module
/// docs: the geometric normal is used there).
const GRAZING: f64 = 1e-6;

/// The `pbr` parameter table.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::new(
        "base_color",
        ParamKind::Texture,
        ParamDefault::Float(1.0),
        "glTF baseColor: the diffuse colour of dielectrics and the specular colour of metals, linear RGB in [0, 1], or a texture",
    ),
    ParamSpec::new(
        "metallic",
        ParamKind::Float,
        ParamDefault::Float(1.0),
        "glTF metallicFactor: 0 = dielectric, 1 = metal (glTF's default), 0..1",
    ),
    ParamSpec::new(
        "roughness",
        ParamKind::Float,
        ParamDefault::Float(1.0),
        "glTF roughnessFactor: the GGX width is α = roughness² (glTF's default 1: fully rough), 0..1",
    ),
    ParamSpec::new(
        "metallic_roughness",
        ParamKind::Texture,
        ParamDefault::Optional,
        "glTF metallicRoughnessTexture: its blue channel multiplies metallic, its green channel roughness (path tracer only; phong uses the factors)",
    ),
    ParamSpec::new(
        "ior",
        ParamKind::Float,
        ParamDefault::Float(1.5),
        "KHR_materials_ior: the dielectric's index of refraction (F0 = ((ior − 1)/(ior + 1))²), ≥ 1",
    ),
    ParamSpec::new(
        "specular",
        ParamKind::Float,
        ParamDefault::Float(1.0),
        "KHR_materials_specular specularFactor: the strength of the dielectric's reflection, 0..1",
    ),
    ParamSpec::new(
        "specular_color",
        ParamKind::Color,
        ParamDefault::Float(1.0),
        "KHR_materials_specular specularColorFactor: multiplies the dielectric's F0",
    ),
    ParamSpec::new(
        "transmission",
        ParamKind::Texture,
        ParamDefault::Float(0.0),
        "KHR_materials_transmission: the fraction of the dielectric's diffuse part that passes through (thin-walled), 0..1, or a texture (its red channel)",
    ),
    ParamSpec::new(
        "emission",
        ParamKind::Texture,
        ParamDefault::Float(0.0),
        "emitted radiance, linear RGB (glTF emissiveFactor × KHR_materials_emissive_strength), or a texture",
    ),
    NORMAL_MAP_PARAMS[0],
    NORMAL_MAP_PARAMS[1],
    NORMAL_MAP_PARAMS[2],
];

/// The `pbr` material's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "pbr",
    summary: "glTF 2.0 metallic-roughness (with KHR_materials_ior, _specular, _transmission, _emissive_strength): in the path tracer exactly the specification's BRDF (Lambert diffuse, GGX, height-correlated Smith, Schlick Fresnel, mixed by metallic), sampled by visible normals; in phong, the documented Phong mapping (docs/materials.md).",
    params: PARAMS,
};

/// A value that may be textured: a constant and an optional texture multiplying it.
#[derive(Clone, Debug)]
pub struct Textured<T> {
    /// The constant (the factor).
    pub value: T,
    /// The texture multiplying it.
    pub texture: Option<Arc<dyn Texture>>,
}

impl<T> Textured<T> {
    /// A constant.
    pub const fn constant(value: T) -> Self {
        Textured { value, texture: None }
    }
}

/// A glTF metallic-roughness material (see the module docs).
#[derive(Clone, Debug)]
pub struct Pbr {
    /// Base colour (linear RGB, [0, 1]) and `baseColorTexture`.
    pub base_color: Textured<Color>,
    /// Metallic factor in [0, 1].
    pub metallic: f64,
    /// Roughness factor in [0, 1].
    pub roughness: f64,
    /// `metallicRoughnessTexture`: blue multiplies metallic, green roughness.
    pub metallic_roughness: Option<Arc<dyn Texture>>,
    /// Index of refraction of the dielectric (≥ 1).
    pub ior: f64,
    /// `KHR_materials_specular` factor in [0, 1].
    pub specular: f64,
    /// `KHR_materials_specular` colour (≥ 0).
    pub specular_color: Color,
    /// `KHR_materials_transmission` factor in [0, 1] and its texture (red channel).
    pub transmission: Textured<f64>,
    /// Emitted radiance and its texture.
    pub emission: Textured<Color>,
}

impl Default for Pbr {
    /// glTF's defaults: white, metallic 1, roughness 1.
    fn default() -> Self {
        Pbr {
            base_color: Textured::constant(Color::ONE),
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness: None,
            ior: 1.5,
            specular: 1.0,
            specular_color: Color::ONE,
            transmission: Textured::constant(0.0),
            emission: Textured::constant(Color::ZERO),
        }
    }
}

/// A colour parameter that may name a texture: its constant (1 when textured) and the texture.
fn color_or_texture(p: &mut Params, name: &str, textures: &dyn TextureResolver) -> Result<Textured<Color>> {
    match p.node(name)? {
        Some(n) if !matches!(n.value, Value::Int(_) | Value::Float(_) | Value::Array(_)) => {
            let texture = textures.resolve(n, &format!("{}: parameter `{name}`", p.what()))?;
            Ok(Textured { value: Color::ONE, texture: Some(texture) })
        }
        _ => Ok(Textured::constant(p.color(name)?)),
    }
}

/// Builds a `pbr` material from its parameters.
pub fn build(p: &mut Params, textures: &dyn TextureResolver) -> Result<Material> {
    let base_color = color_or_texture(p, "base_color", textures)?;
    if base_color.value.max_element() > 1.0 {
        return Err(p.error_at("base_color", "expected a colour in [0, 1] (a reflectance)"));
    }
    let metallic = p.float_in("metallic", 0.0..=1.0)?;
    let roughness = p.float_in("roughness", 0.0..=1.0)?;
    let metallic_roughness = match p.node("metallic_roughness")? {
        Some(n) => Some(textures.resolve(n, &format!("{}: parameter `metallic_roughness`", p.what()))?),
        None => None,
    };
    let ior = p.float_in("ior", 1.0..=10.0)?;
    let specular = p.float_in("specular", 0.0..=1.0)?;
    let specular_color = p.color("specular_color")?;
    let transmission = match p.node("transmission")? {
        Some(n) if !matches!(n.value, Value::Int(_) | Value::Float(_)) => {
            let texture = textures.resolve(n, &format!("{}: parameter `transmission`", p.what()))?;
            Textured { value: 1.0, texture: Some(texture) }
        }
        _ => Textured::constant(p.float_in("transmission", 0.0..=1.0)?),
    };
    let emission = color_or_texture(p, "emission", textures)?;
    let normal_map = NormalMap::from_params(p, textures)?;
    let pbr = Pbr { base_color, metallic, roughness, metallic_roughness, ior, specular, specular_color, transmission, emission };
    Ok(Material { normal_map, ..pbr.material() })
}

/// The Phong coefficients of a metallic-roughness material, as `phong` reads it (base colour
/// `c`, metallic `m`, roughness `r`, α = max(r², 10⁻³); docs/materials.md):
///
/// | coefficient | from |
/// |---|---|
/// | `kd` | `c · (1 − m) · (1 − kt)` |
/// | `shininess` | `n = (2/α² − 2) / 4` (Blinn-Phong's equivalent exponent, in Phong's terms), in [1, 10⁴] |
/// | `ks` | `F0 · (n + 1) / 2`, `F0 = 0.04·(1 − m) + c·m` (the specular colour at normal incidence) |
/// | `kr` | `F0 · m · (1 − r)²`: smooth metals mirror; rough ones and dielectrics do not |
/// | `blur` | `α` where `kr > 0` and α ≥ 0.05 (sharper lobes are mirrors) |
/// | `kt` | the transmission factor (alpha is not transmission: glTF's `alphaMode` is a [`Cutout`](raylab::scene::material::Cutout)) |
/// | `ior` | `ior` (1.5 when not finite and positive) |
/// | `emission` | `emission` (negative parts clamped to 0) |
///
/// The Phong lobe `ks · cos^n` reflects `2·ks / (n + 1)` of the light a viewer sees, so
/// `ks = F0·(n + 1)/2` keeps the specular reflectance at `F0` whatever the roughness, as GGX does.
/// `KHR_materials_specular` does not enter it.
pub fn phong_mapping(
    base: [f32; 4],
    metallic: f32,
    roughness: f32,
    transmission: Option<f32>,
    ior: Option<f32>,
    emissive: [f32; 3],
) -> Material {
    let clamp01 = |v: f32| if v.is_finite() { f64::from(v).clamp(0.0, 1.0) } else { 0.0 };
    let c = Color::new(clamp01(base[0]), clamp01(base[1]), clamp01(base[2]));
    let (m, r) = (clamp01(metallic), clamp01(roughness));
    let alpha = (r * r).max(1e-3);
    let f0 = Color::splat(0.04 * (1.0 - m)) + c * m;
    let kr = f0 * m * (1.0 - r) * (1.0 - r);
    let kt = transmission.map_or(0.0, clamp01);
    let shininess = ((2.0 / (alpha * alpha) - 2.0) / 4.0).clamp(MIN_SHININESS, MAX_SHININESS);
    Material {
        kd: c * (1.0 - m) * (1.0 - kt),
        ks: f0 * (shininess + 1.0) / 2.0,
        shininess,
        kr,
        kt: Color::splat(kt),
        ior: ior.filter(|i| i.is_finite() && *i > 0.0).map_or(1.5, f64::from),
        emission: Color::new(f64::from(emissive[0]), f64::from(emissive[1]), f64::from(emissive[2])).max(Color::ZERO),
        blur: if kr.max_element() > 0.0 && alpha >= 0.05 { alpha.min(1.0) } else { 0.0 },
        ..Material::default()
    }
}

impl Pbr {
    /// The material: [`phong_mapping`]'s coefficients (the base colour texture multiplying `kd`,
    /// and `ks`, `kr` of metals; the emission texture the emission) with this model.
    pub fn material(self) -> Material {
        let f32s = |c: Color| [c.x as f32, c.y as f32, c.z as f32];
        let [r, g, b] = f32s(self.base_color.value);
        let transmission = (self.transmission.value > 0.0).then_some(self.transmission.value as f32);
        let mut m = phong_mapping(
            [r, g, b, 1.0],
            self.metallic as f32,
            self.roughness as f32,
            transmission,
            Some(self.ior as f32),
            f32s(self.emission.value),
        );
        if let Some(t) = &self.base_color.texture {
            m.textures.push(TextureMap { channel: Channel::Kd, texture: t.clone() });
            if self.metallic > 0.0 {
                m.textures.push(TextureMap { channel: Channel::Ks, texture: t.clone() });
                m.textures.push(TextureMap { channel: Channel::Kr, texture: t.clone() });
            }
        }
        if let Some(t) = &self.emission.texture {
            m.textures.push(TextureMap { channel: Channel::Emission, texture: t.clone() });
        }
        m.model = Some(Model(Arc::new(self)));
        m
    }

    /// The parameters at a surface point (textures looked up at `at`, asked for only when some
    /// parameter is textured).
    #[inline]
    pub fn at(&self, at: impl FnOnce() -> TexturePoint) -> Params1 {
        let mut p = Params1 {
            base_color: self.base_color.value,
            metallic: self.metallic,
            roughness: self.roughness,
            transmission: self.transmission.value,
        };
        if self.base_color.texture.is_some() || self.metallic_roughness.is_some() || self.transmission.texture.is_some() {
            let at = at();
            if let Some(t) = &self.base_color.texture {
                p.base_color *= t.eval(&at);
            }
            if let Some(t) = &self.metallic_roughness {
                let v = t.eval(&at);
                p.metallic *= v.z;
                p.roughness *= v.y;
            }
            if let Some(t) = &self.transmission.texture {
                p.transmission *= t.eval(&at).x;
            }
            p.base_color = p.base_color.clamp(Color::ZERO, Color::ONE);
            p.metallic = p.metallic.clamp(0.0, 1.0);
            p.roughness = p.roughness.clamp(0.0, 1.0);
            p.transmission = p.transmission.clamp(0.0, 1.0);
        }
        p
    }

    /// The BSDF at a point with parameters `p`, seen from `wo` with geometric normal `n` and
    /// shading normal `ns` (both facing `wo`).
    pub fn bsdf_with(&self, p: &Params1, wo: DVec3, n: DVec3, ns: DVec3) -> PbrBsdf {
        let f0 = ((self.ior - 1.0) / (self.ior + 1.0)).powi(2);
        PbrBsdf::new(wo, n, ns, p, (Color::splat(f0) * self.specular_color).min(Color::ONE), self.specular)
    }
}

/// A `pbr` material's parameters at one point (textures applied).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params1 {
    /// Base colour in [0, 1].
    pub base_color: Color,
    /// Metallic in [0, 1].
    pub metallic: f64,
    /// Roughness in [0, 1].
    pub roughness: f64,
    /// Transmission in [0, 1].
    pub transmission: f64,
}

impl MaterialModel for Pbr {
    fn bsdf(&self, at: &dyn Shading, f: &mut dyn FnMut(&dyn Bsdf)) {
        let p = self.at(|| at.texture_point());
        f(&self.bsdf_with(&p, at.wo(), at.n(), at.ns()))
    }

    fn is_textured(&self) -> bool {
        self.base_color.texture.is_some() || self.metallic_roughness.is_some() || self.transmission.texture.is_some()
    }
}

/// GGX's distribution of normals `D(h)` for `cos_h` = n·h (> 0) and width `alpha`.
#[inline]
pub fn ggx_d(cos_h: f64, alpha: f64) -> f64 {
    if !(cos_h > 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Smith's masking `G1` of GGX for a direction at cosine `cos` (> 0) to the normal.
#[inline]
pub fn ggx_g1(cos: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    2.0 * cos / (cos + (a2 + (1.0 - a2) * cos * cos).sqrt())
}

/// The height-correlated Smith visibility `V = G2 / (4 (n·l)(n·v))` of glTF's Appendix B.
#[inline]
pub fn ggx_v(cos_l: f64, cos_v: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let gv = cos_l * (cos_v * cos_v * (1.0 - a2) + a2).sqrt();
    let gl = cos_v * (cos_l * cos_l * (1.0 - a2) + a2).sqrt();
    let s = gv + gl;
    if s > 0.0 { 0.5 / s } else { 0.0 }
}

/// `(1 − c)⁵`, Schlick's weight, for `c` clamped to [0, 1].
#[inline]
fn schlick_weight(c: f64) -> f64 {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// A microfacet normal from GGX's distribution of normals visible from `v` (local frame, z up,
/// `v.z > 0`), from `u` ∈ [0, 1)² (Heitz 2018, listing 1, isotropic).
pub fn sample_vndf(v: DVec3, alpha: f64, u: DVec2) -> DVec3 {
    // The view direction in the hemisphere configuration.
    let vh = DVec3::new(alpha * v.x, alpha * v.y, v.z).normalize();
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 { DVec3::new(-vh.y, vh.x, 0.0) / len2.sqrt() } else { DVec3::X };
    let t2 = vh.cross(t1);
    // A point of the projected disc, its lower half squeezed by the projection's foreshortening.
    let r = u.x.sqrt();
    let (s, c) = (TAU * u.y).sin_cos();
    let (p1, p2) = (r * c, r * s);
    let w = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - w) * (1.0 - p1 * p1).max(0.0).sqrt() + w * p2;
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    // Back to the ellipsoid configuration.
    DVec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// Mean of the three channels.
#[inline]
fn mean(c: Color) -> f64 {
    (c.x + c.y + c.z) / 3.0
}

/// The glTF BRDF at one hit (see the module docs). Built per hit, on the stack.
#[derive(Clone, Debug)]
pub struct PbrBsdf {
    /// Geometric normal facing `wo`.
    n: DVec3,
    /// The shading frame: tangents and normal.
    frame: [DVec3; 3],
    /// `wo` in the shading frame (z > 0).
    wo: DVec3,
    c: Color,
    metallic: f64,
    alpha: f64,
    transmission: f64,
    /// The dielectric's F0 and specular weight (KHR_materials_specular).
    f0: Color,
    specular: f64,
    /// Probabilities of the diffuse, specular and transmission lobes (sum 1, or all 0).
    choice: [f64; 3],
}

impl PbrBsdf {
    /// The BSDF seen from unit `wo`, with geometric normal `n` and shading normal `ns` facing it.
    pub fn new(wo: DVec3, n: DVec3, ns: DVec3, p: &Params1, f0: Color, specular: f64) -> PbrBsdf {
        // The viewer under the shading normal's horizon: the geometric normal instead.
        let ns = if ns.dot(wo) > GRAZING { ns } else { n };
        let (t, b) = orthonormal_basis(ns);
        let wo_local = DVec3::new(wo.dot(t), wo.dot(b), wo.dot(ns).max(GRAZING));
        let (c, m, tr) = (p.base_color, p.metallic, p.transmission);
        let alpha = (p.roughness * p.roughness).max(MIN_ALPHA);
        // Expected lobe weights, the Fresnel terms taken at n·v.
        let w = schlick_weight(wo_local.z);
        let fr = f0 + (Color::ONE - f0) * w;
        let metal = c + (Color::ONE - c) * w;
        let under = (1.0 - m) * (1.0 - specular * max_channel(fr));
        let mut choice = [under * (1.0 - tr) * mean(c), (1.0 - m) * specular * mean(fr) + m * mean(metal), under * tr * mean(c)];
        let total: f64 = choice.iter().sum();
        for q in &mut choice {
            *q = if total > 0.0 { *q / total } else { 0.0 };
        }
        PbrBsdf { n, frame: [t, b, ns], wo: wo_local, c, metallic: m, alpha, transmission: tr, f0, specular, choice }
    }

    /// A world direction in the shading frame.
    #[inline]
    fn local(&self, d: DVec3) -> DVec3 {
        DVec3::new(d.dot(self.frame[0]), d.dot(self.frame[1]), d.dot(self.frame[2]))
    }

    /// A shading-frame direction in the world.
    #[inline]
    fn world(&self, d: DVec3) -> DVec3 {
        d.x * self.frame[0] + d.y * self.frame[1] + d.z * self.frame[2]
    }

    /// The reflection BRDF for local `wi` (z > 0): glTF's `f`, transmission left out.
    fn brdf(&self, wi: DVec3) -> Color {
        let wo = self.wo;
        let h = (wo + wi).normalize();
        let voh = wo.dot(h);
        let spec = ggx_d(h.z, self.alpha) * ggx_v(wi.z, wo.z, self.alpha);
        let w = schlick_weight(voh);
        let metal = (self.c + (Color::ONE - self.c) * w) * spec;
        let fr = self.f0 + (Color::ONE - self.f0) * w;
        let diffuse = self.c * FRAC_1_PI * (1.0 - self.transmission);
        let dielectric = diffuse * (1.0 - self.specular * max_channel(fr)) + fr * (self.specular * spec);
        dielectric * (1.0 - self.metallic) + metal * self.metallic
    }

    /// Density of the visible-normal sampling of local `wi` (reflected).
    #[inline]
    fn vndf_pdf(&self, wi: DVec3) -> f64 {
        let h = (self.wo + wi).normalize();
        if !(self.wo.dot(h) > 0.0) {
            return 0.0;
        }
        ggx_g1(self.wo.z, self.alpha) * ggx_d(h.z, self.alpha) / (4.0 * self.wo.z)
    }

    /// Density of the diffuse and specular strategies together at local `wi` (z > 0).
    #[inline]
    fn pdf_local(&self, wi: DVec3) -> f64 {
        let mut pdf = self.choice[0] * wi.z * FRAC_1_PI;
        if self.choice[1] > 0.0 {
            pdf += self.choice[1] * self.vndf_pdf(wi);
        }
        pdf
    }

    /// True when `wi` leaves on the viewer's side of both normals.
    #[inline]
    fn above(&self, wi: DVec3) -> bool {
        self.n.dot(wi) > 0.0 && self.frame[2].dot(wi) > 0.0
    }
}

impl Bsdf for PbrBsdf {
    fn eval(&self, wi: DVec3) -> Color {
        if !self.above(wi) {
            return Color::ZERO;
        }
        self.brdf(self.local(wi))
    }

    fn pdf(&self, wi: DVec3) -> f64 {
        if !self.above(wi) {
            return 0.0;
        }
        self.pdf_local(self.local(wi))
    }

    /// Both of the above from one turn into the local frame.
    fn eval_pdf(&self, wi: DVec3) -> (Color, f64) {
        if !self.above(wi) {
            return (Color::ZERO, 0.0);
        }
        let local = self.local(wi);
        (self.brdf(local), self.pdf_local(local))
    }

    fn sample(&self, pick: f64, u: DVec2, _fresnel: f64) -> Option<Scatter> {
        let [pd, ps, pt] = self.choice;
        if pd + ps + pt <= 0.0 {
            return None;
        }
        if pick >= pd + ps && pt > 0.0 {
            // Thin-walled transmission: a reflected direction mirrored through the surface.
            let h = sample_vndf(self.wo, self.alpha, u);
            let wr = 2.0 * self.wo.dot(h) * h - self.wo;
            if !(wr.z > 0.0) {
                return None;
            }
            let fr = self.f0 + (Color::ONE - self.f0) * schlick_weight(self.wo.dot(h));
            let g = ggx_v(wr.z, self.wo.z, self.alpha) * 4.0 * wr.z * self.wo.z / ggx_g1(self.wo.z, self.alpha);
            let weight = self.c * ((1.0 - self.metallic) * self.transmission * (1.0 - self.specular * max_channel(fr)) * g / pt);
            let dir = self.world(DVec3::new(wr.x, wr.y, -wr.z));
            if !(self.n.dot(dir) < 0.0) {
                return None;
            }
            return Some(Scatter { dir, weight, pdf: None, lobe: Lobe::Transmission, kind: RayKind::Refraction, eta_squared: 1.0 });
        }
        let (wi, lobe) = if pick < pd {
            let d = concentric_disc(u);
            (DVec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt()), Lobe::Diffuse)
        } else {
            let h = sample_vndf(self.wo, self.alpha, u);
            (2.0 * self.wo.dot(h) * h - self.wo, Lobe::Glossy)
        };
        if !(wi.z > 0.0) {
            return None;
        }
        let dir = self.world(wi).normalize();
        if !(self.n.dot(dir) > 0.0) {
            return None;
        }
        let f = self.brdf(wi);
        let pdf = self.pdf_local(wi);
        if max_channel(f) <= 0.0 || !(pdf > 0.0) {
            return None;
        }
        Some(Scatter { dir, weight: f * wi.z / pdf, pdf: Some(pdf), lobe, kind: RayKind::Reflection, eta_squared: 1.0 })
    }

    fn has_smooth_lobes(&self) -> bool {
        self.choice[0] + self.choice[1] > 0.0
    }

    fn albedo(&self) -> Color {
        self.c
    }
}

#[cfg(test)]
mod tests;
