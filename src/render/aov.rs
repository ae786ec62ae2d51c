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
//!   clamped to 1 (`phong`: `kd + kr + kt`, the diffuse colour of matte surfaces and about 1 for
//!   mirrors and glass, as the denoisers ask); the background colour (clamped to 1) for misses.
//! - `error` and `spp`: the estimated standard error of each pixel's mean luminance
//!   ([`crate::render::accum::PixelSum::std_error`]) and its samples.

use crate::math::color::Color;
use glam::{DVec3, Vec3};

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
}

impl AovSample {
    /// A ray that hit nothing, in front of `background`.
    #[inline]
    pub fn miss(background: Color) -> Self {
        AovSample { depth: f64::INFINITY, normal: DVec3::ZERO, albedo: background.min(Color::ONE), signature: 0 }
    }

    /// The first surface `si`, with the integrator's `albedo` (clamped to 1).
    #[inline]
    pub fn surface(si: &crate::scene::interaction::Interaction, albedo: Color) -> Self {
        AovSample { depth: si.hit.t, normal: si.ns, albedo: albedo.min(Color::ONE), signature: u64::from(si.hit.object) + 1 }
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
    /// The estimated standard error of each pixel's mean luminance, and its samples.
    Error,
}

impl Aov {
    /// Parses `depth`, `normal`, `albedo` or `error` (also called `variance`, and `spp`: the
    /// error layer comes with the samples per pixel).
    pub fn parse(s: &str) -> Option<Aov> {
        match s {
            "depth" => Some(Aov::Depth),
            "normal" => Some(Aov::Normal),
            "albedo" => Some(Aov::Albedo),
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
    /// Estimated standard error of each pixel's mean luminance (linear radiance units; NaN where
    /// fewer than two rays were summed).
    pub error: Option<Vec<f32>>,
    /// Samples per pixel (they differ under an error target).
    pub spp: Option<Vec<f32>>,
}
