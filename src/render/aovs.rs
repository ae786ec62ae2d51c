//! The extra layers of an image (depth, normal, albedo; the error estimate and sample counts), as
//! the render produces them and the EXR writer stores them (see [`crate::render::aov`] for what
//! the first three mean, [`crate::render::accum::PixelSum::std_error`] for the error).

use glam::Vec3;

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
pub struct Aovs {
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
