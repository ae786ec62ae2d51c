//! Arbitrary output variables (AOVs): per-pixel depth, normal and albedo, the extra layers a
//! denoiser (Intel Open Image Denoise, OptiX) or a compositor wants beside the colour, and the
//! error estimate with its sample counts. Three names, one thing each: an [`Aov`] is a kind of
//! layer, an [`AovSample`] is what one camera ray gives the layers, [`AovLayers`] are an image's
//! layers ([`crate::render::accum::AovSum`] sums a pixel's samples exactly).
//!
//! The integrator fills an [`AovSample`] per camera ray during the render, from the render's own
//! samples, and each layer is the mean over the pixel's samples (weighted as the colour is, under
//! adaptive anti-aliasing):
//!
//! - `depth` (`Z`): distance along the camera ray to the first surface, scene units, over the
//!   samples that hit one; +∞ where none does.
//! - `normal` (`normal.X/Y/Z`): the shading normal at the first surface, world space, facing the
//!   camera; zero for misses.
//! - `albedo` (`albedo.R/G/B`): the first surface's reflectance as the integrator sees it,
//!   clamped to 1 (`phong`: `kd + kr + kt`, the diffuse colour of matte surfaces); for misses,
//!   what the ray sees (the background, or an environment light), clamped to 1.
//!
//! The denoiser's guides, albedo and normal, are taken **at the first non-specular hit**, as
//! Open Image Denoise asks and Cycles does: where the camera ray meets a surface that only
//! reflects or refracts specularly (a perfect mirror, smooth glass), they show what is seen
//! through it, the albedo tinted by the specular surfaces' reflectance, up to
//! [`GUIDE_SPECULAR_DEPTH`] such surfaces ([`AovSample::look_through`]). The chain is traced
//! only when the render sums the layers ([`AovSample::guides`]), and each specular surface sends
//! it on its most likely branch (glass: transmission, but where Fresnel reflection is the greater
//! part or total), the same for every sample: the guides stay free of noise. Depth and the
//! signature stay those of the first surface.
//! - `emission` (`emission.R/G/B`): what the camera ray met emitted on its way to its first
//!   surface and brought back as it is, free of Monte Carlo noise but for anti-aliasing: the
//!   lights and emitting surfaces it sees (`path`: the lights with an extent its ray meets and
//!   the first surface's emission, and, where that surface only reflects or refracts
//!   specularly, the lights and emitting surfaces its reflection and refraction meet next,
//!   counted as their expectation instead of sampled; `phong`: the first surface's emission). Not the background or
//!   an environment a miss sees: left out of the filter, that made `environment`'s denoised
//!   image worse by RMSE (`benches/error`). The denoiser leaves the layer out and adds it back
//!   ([`crate::image::denoise::denoise_guided`]): a lamp seen directly keeps its edge.
//! - `error` and `spp`: the estimated standard error of each pixel's mean luminance
//!   ([`crate::render::accum::PixelSum::std_error`]) and its samples.

use crate::math::color::Color;
use crate::scene::Scene;
use crate::scene::interaction::Interaction;
use glam::{DVec3, Vec3};

/// Most specular surfaces (mirrors, smooth glass) the albedo and normal guides look through
/// before they stop at the last one ([`AovSample::look_through`]): a ball of glass is two, a
/// mirror seen in a mirror two more.
pub const GUIDE_SPECULAR_DEPTH: u32 = 8;

/// What a surface is to the denoiser's guides, as an integrator reads its material
/// ([`AovSample::look_through`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GuideStep {
    /// A surface with some non-specular response (diffuse, glossy): the guides stop here and show
    /// its normal and this albedo.
    Surface(Color),
    /// A surface that only reflects or refracts specularly: the guides go on along `dir` (its
    /// most likely specular direction), their albedo multiplied by `tint` (the surface's
    /// reflectance, in [0, 1]).
    Specular {
        /// Unit direction the guides go on in.
        dir: DVec3,
        /// What the surface passes on of the albedo seen through it.
        tint: Color,
    },
}

/// What one camera ray saw first, for the depth, normal and albedo layers; the integrator fills
/// it during the render, from the render's own samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AovSample {
    /// Distance along the camera ray to the first surface, scene units (+∞: nothing hit).
    pub depth: f64,
    /// Shading normal at the first surface, world space, facing the camera (zero for a miss).
    pub normal: DVec3,
    /// Reflectance of the first surface as the integrator sees it (for a miss, the background
    /// clamped to 1).
    pub albedo: Color,
    /// What the ray saw, as an identifier: adaptive anti-aliasing may split a square whose
    /// corners' signatures differ. By default the first surface's object (`index + 1`; 0 for a
    /// miss); an integrator may fold in what its secondary rays met (the object a reflection
    /// hits, which lights are occluded) with [`AovSample::mix_signature`].
    pub signature: u64,
    /// Radiance the camera ray met emitted up to its first surface and brought back unscattered
    /// (the lights and emitting surface it sees; not the background or environment of a miss):
    /// part of the sample's colour that has no noise but anti-aliasing. Zero unless the
    /// integrator fills it. An integrator may add, when [`AovSample::guides`] is set, what a
    /// first surface that only reflects or refracts specularly shows of the emitters, as long
    /// as it computes it without noise (its branches followed together, weighed by their
    /// probabilities) and the colour counts it the same way (`path` does).
    pub emitted: Color,
    /// Set by the render when it sums the layers: the integrator then takes the albedo and normal
    /// at the first non-specular hit ([`AovSample::look_through`]), which costs rays. Without it
    /// only the signature is read.
    pub guides: bool,
}

impl AovSample {
    /// A ray that hit nothing, in front of `background`.
    #[inline]
    pub fn miss(background: Color) -> Self {
        AovSample {
            depth: f64::INFINITY,
            normal: DVec3::ZERO,
            albedo: background.min(Color::ONE),
            signature: 0,
            emitted: Color::ZERO,
            guides: false,
        }
    }

    /// The first surface `si`, with the integrator's `albedo` (clamped to 1); [`AovSample::guides`]
    /// unset.
    #[inline]
    pub fn surface(si: &Interaction, albedo: Color) -> Self {
        AovSample {
            depth: si.hit.t,
            normal: si.ns,
            albedo: albedo.min(Color::ONE),
            signature: u64::from(si.hit.object) + 1,
            emitted: Color::ZERO,
            guides: false,
        }
    }

    /// Records the first surface `si` with the integrator's `albedo` (clamped to 1), keeping
    /// [`AovSample::guides`].
    #[inline]
    pub fn set_surface(&mut self, si: &Interaction, albedo: Color) {
        *self = AovSample { guides: self.guides, ..AovSample::surface(si, albedo) };
    }

    /// When the render takes guides ([`AovSample::guides`]): the albedo and normal of the first
    /// non-specular surface seen from the first surface `si` in `scene`, following each specular
    /// surface's [`GuideStep::Specular`] direction, the albedo multiplied by their tints. `step`
    /// reads a surface as the integrator does (the same for every sample: no random numbers).
    /// A chain that leaves the scene shows what it sees there ([`AovSample::escape`]); one
    /// still specular after [`GUIDE_SPECULAR_DEPTH`] surfaces stops at the last, its tint its
    /// albedo. Depth and signature are left alone. Traces no ray where `si` is not specular.
    pub fn look_through(&mut self, scene: &Scene, si: &Interaction, mut step: impl FnMut(&Interaction) -> GuideStep) {
        if !self.guides {
            return;
        }
        let mut tint = Color::ONE;
        let mut next = step(si);
        let mut here: Option<Interaction> = None;
        for _ in 0..GUIDE_SPECULAR_DEPTH {
            let GuideStep::Specular { dir, tint: t } = next else { break };
            let at = here.as_ref().unwrap_or(si);
            let ray = at.spawn_ray(dir);
            tint *= t.clamp(Color::ZERO, Color::ONE);
            match scene.trace(&ray) {
                Some(hit) => {
                    next = step(&hit);
                    here = Some(hit);
                }
                None => {
                    self.escape(scene, ray.dir);
                    self.albedo *= tint;
                    return;
                }
            }
        }
        let Some(last) = here else { return };
        let albedo = match next {
            GuideStep::Surface(a) => a.clamp(Color::ZERO, Color::ONE),
            GuideStep::Specular { tint: t, .. } => t.clamp(Color::ZERO, Color::ONE),
        };
        self.albedo = albedo * tint;
        self.normal = last.ns;
    }

    /// When the render takes guides: a ray along `dir` that leaves the scene shows, as its
    /// albedo, what it sees there ([`Scene::escaped`]: the background, or the environment
    /// lights' radiance) clamped to 1, as an emitter's is taken (OIDN's examples): a mirror or a
    /// glass ball that shows the sky gets the sky in its guide, not the black of a background
    /// the environment replaces. No normal.
    pub fn escape(&mut self, scene: &Scene, dir: DVec3) {
        if self.guides {
            self.albedo = scene.escaped(dir).clamp(Color::ZERO, Color::ONE);
            self.normal = DVec3::ZERO;
        }
    }

    /// Folds `what` (e.g. the index of the object a secondary ray hit) into the signature.
    #[inline]
    pub fn mix_signature(&mut self, what: u64) {
        self.signature = crate::math::sampler::mix64(self.signature ^ what.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    }
}

/// An extra output layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    /// Distance to the first surface.
    Depth,
    /// Shading normal at the first surface.
    Normal,
    /// Reflectance of the first surface.
    Albedo,
    /// Radiance camera rays met emitted (the lights and emitting surfaces they see).
    Emission,
    /// The estimated standard error of each pixel's mean luminance, and its samples.
    Error,
}

impl Aov {
    /// Parses `depth`, `normal`, `albedo`, `emission` or `error` (also called `variance`, and `spp`: the
    /// error layer comes with the samples per pixel).
    pub fn parse(s: &str) -> Option<Aov> {
        match s {
            "depth" => Some(Aov::Depth),
            "normal" => Some(Aov::Normal),
            "albedo" => Some(Aov::Albedo),
            "emission" => Some(Aov::Emission),
            "error" | "variance" | "spp" => Some(Aov::Error),
            _ => None,
        }
    }
}

/// The extra layers of an image, row-major like [`crate::render::film::Film`]; each present if asked for.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AovLayers {
    /// Distance per pixel (+∞: nothing hit).
    pub depth: Option<Vec<f32>>,
    /// Mean shading normal per pixel.
    pub normal: Option<Vec<Vec3>>,
    /// Mean albedo per pixel.
    pub albedo: Option<Vec<Vec3>>,
    /// Mean radiance camera rays met directly, per pixel ([`AovSample::emitted`]).
    pub emitted: Option<Vec<Vec3>>,
    /// Estimated standard error of each pixel's mean luminance (linear radiance units; NaN where
    /// fewer than two rays were summed).
    pub error: Option<Vec<f32>>,
    /// Samples per pixel (they differ under an error target).
    pub spp: Option<Vec<f32>>,
    /// With the `error` layer: the image's estimated relative RMSE and whether it may read
    /// `"high"`, `"low"` or `"no"` (the summary's line; [`crate::render::share::ErrorEstimate`]),
    /// written to an EXR's header as `raylab.estimated_relative_rmse` and
    /// `raylab.estimate_may_read`.
    pub estimate: Option<(f64, &'static str)>,
}
