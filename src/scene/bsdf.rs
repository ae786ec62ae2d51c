//! What a physically based integrator asks of a material at a hit: its [`Bsdf`] (evaluate,
//! sample, density, albedo), through the material's [`MaterialModel`].
//!
//! A [`Material`](crate::scene::material::Material) is the report's coefficients (which every
//! material plugin maps itself onto, and which `phong` reads) and, optionally, a model: the
//! surface's own scattering, which the path tracer uses instead of its reading of the
//! coefficients (a normalised Phong BSDF). Material plugins (`[materials.NAME] type = "…"`) are
//! registered like shapes and lights ([`crate::Registry::add_material`]).
//!
//! A BSDF lives for one hit, on the stack: a model hands it to a continuation
//! ([`MaterialModel::bsdf`], [`with_bsdf`]), so no hit allocates. Directions are world-space
//! unit vectors; `wo` (toward where the ray came from) is fixed when the BSDF is built.

pub mod testing;

use crate::math::color::Color;
use crate::math::ray::RayKind;
use crate::scene::texture::TexturePoint;
use glam::{DVec2, DVec3};
use std::fmt::Debug;

/// A component of a scattering model, for explanations and tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// Diffuse reflection (Lambertian, Oren–Nayar, …).
    Diffuse,
    /// A highlight lobe (the normalised Phong `ks`).
    Specular,
    /// A glossy reflection (a blurry mirror, a microfacet lobe).
    Glossy,
    /// A perfect mirror.
    Mirror,
    /// Fresnel reflection or transmission of a dielectric interface.
    Dielectric,
    /// Transmission through a rough or smooth surface into or through the solid.
    Transmission,
}

impl Lobe {
    /// The lobe's name in explanations.
    pub fn name(self) -> &'static str {
        match self {
            Lobe::Diffuse => "diffuse",
            Lobe::Specular => "specular",
            Lobe::Glossy => "glossy",
            Lobe::Mirror => "mirror",
            Lobe::Dielectric => "dielectric",
            Lobe::Transmission => "transmission",
        }
    }
}

/// A direction sampled from a [`Bsdf`], and what it carries.
#[derive(Clone, Copy, Debug)]
pub struct Scatter {
    /// Unit direction of the new ray.
    pub dir: DVec3,
    /// `f·|cos θ| / pdf`: the factor on the radiance the new ray brings back.
    pub weight: Color,
    /// Density of `dir` under the whole sampling strategy (per solid angle), for weighing light
    /// found by the new ray; `None` after a specular event (mirror, smooth dielectric), which
    /// light samples cannot find.
    pub pdf: Option<f64>,
    /// The lobe chosen.
    pub lobe: Lobe,
    /// Reflected or transmitted.
    pub kind: RayKind,
    /// (η_t/η_i)² of a refraction (1 otherwise): transmitted radiance was scaled by its inverse.
    pub eta_squared: f64,
}

/// The scattering at one hit, for the outgoing direction `wo` it was built with.
pub trait Bsdf {
    /// `f(wo, wi)` of the non-specular lobes (specular events have no value toward a given
    /// direction). Zero for directions the surface does not scatter into.
    fn eval(&self, wi: DVec3) -> Color;

    /// Density (per solid angle) with which [`Bsdf::sample`] picks `wi`, specular events left
    /// out: what multiple importance sampling weighs light samples against.
    fn pdf(&self, wi: DVec3) -> f64;

    /// [`Bsdf::eval`] and [`Bsdf::pdf`] toward `wi` in one call, each exactly as it would answer
    /// alone: what an integrator asks of a light sample, and a BSDF of its own sampled
    /// direction. A model whose two share work (the direction's cosines, a lobe's power)
    /// should answer both here; the default asks each.
    #[inline]
    fn eval_pdf(&self, wi: DVec3) -> (Color, f64) {
        (self.eval(wi), self.pdf(wi))
    }

    /// A new direction: a lobe chosen by `pick` ∈ [0, 1), a direction from `u` ∈ [0, 1)², and
    /// (dielectrics) reflection or transmission by `fresnel` ∈ [0, 1). `None` when the surface is
    /// black or the sampled direction carries nothing.
    fn sample(&self, pick: f64, u: DVec2, fresnel: f64) -> Option<Scatter>;

    /// True when some lobe can be evaluated toward a given direction: light samples are worth
    /// taking here.
    fn has_smooth_lobes(&self) -> bool;

    /// Reflectance as the albedo layer shows it (a colour in [0, 1] per channel).
    fn albedo(&self) -> Color;
}

/// What a material model reads of a hit: an
/// [`Interaction`](crate::scene::interaction::Interaction) answers it.
pub trait Shading {
    /// Unit direction toward where the ray came from (−ray direction).
    fn wo(&self) -> DVec3;
    /// Unit geometric normal facing `wo`.
    fn n(&self) -> DVec3;
    /// Unit shading normal facing `wo`.
    fn ns(&self) -> DVec3;
    /// True when the ray arrived on the surface's outward side.
    fn front_face(&self) -> bool;
    /// Where textures are looked up at the hit (computed on each call).
    fn texture_point(&self) -> TexturePoint;
}

/// A material's own scattering model (a plugin's), beside the coefficients every material has.
pub trait MaterialModel: Send + Sync + Debug {
    /// Builds the BSDF at the hit `at` (textures looked up there) and hands it to `f`. Called
    /// once per path vertex; the BSDF lives on this function's stack.
    fn bsdf(&self, at: &dyn Shading, f: &mut dyn FnMut(&dyn Bsdf));

    /// Radiance the surface emits at `at` toward the ray, where the model knows better than the
    /// coefficients (`None`, the default: the coefficients' `emission`, which every material
    /// maps its emission onto).
    fn emission(&self, _at: &dyn Shading) -> Option<Color> {
        None
    }

    /// Whether the model looks textures up ([`Shading::texture_point`]): a scene computes ray
    /// differentials for texture filtering only when some material does. `false` (the default):
    /// a model that reads textures without saying so gets point lookups.
    fn is_textured(&self) -> bool {
        false
    }
}

/// A surface that scatters nothing: what [`with_bsdf`] hands on when a model gives no BSDF.
#[derive(Clone, Copy, Debug)]
pub struct Black;

impl Bsdf for Black {
    fn eval(&self, _: DVec3) -> Color {
        Color::ZERO
    }
    fn pdf(&self, _: DVec3) -> f64 {
        0.0
    }
    fn sample(&self, _: f64, _: DVec2, _: f64) -> Option<Scatter> {
        None
    }
    fn has_smooth_lobes(&self) -> bool {
        false
    }
    fn albedo(&self) -> Color {
        Color::ZERO
    }
}

/// `f` of `model`'s BSDF at `at` ([`MaterialModel::bsdf`]); a model that hands on none is
/// [`Black`]. A model handing on several: the first counts.
#[inline]
pub fn with_bsdf<T>(model: &dyn MaterialModel, at: &dyn Shading, f: impl FnOnce(&dyn Bsdf) -> T) -> T {
    let mut f = Some(f);
    let mut out = None;
    model.bsdf(at, &mut |b| {
        if let Some(f) = f.take() {
            out = Some(f(b));
        }
    });
    match (out, f) {
        (Some(v), _) => v,
        (None, Some(f)) => f(&Black),
        (None, None) => unreachable!("`f` is taken only where `out` is set"),
    }
}
