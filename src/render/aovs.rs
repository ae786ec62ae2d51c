//! The extra layers of an image (depth, normal, albedo), as the render produces them and the EXR
//! writer stores them (see [`crate::render::aov`] for what each means).

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
}

impl Aov {
    /// Parses `depth`, `normal` or `albedo`.
    pub fn parse(s: &str) -> Option<Aov> {
        match s {
            "depth" => Some(Aov::Depth),
            "normal" => Some(Aov::Normal),
            "albedo" => Some(Aov::Albedo),
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
}
