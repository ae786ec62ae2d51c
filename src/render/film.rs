//! The film: the rendered image as linear HDR RGB.

use glam::Vec3;

/// A `width × height` image of linear RGB, row-major from the top-left pixel.
///
/// Stored as `f32`: 24 bits of mantissa are far beyond what 8-bit or half-float output needs, and
/// it halves the memory of `f64`. All shading arithmetic happens in `f64` before a pixel is stored.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `width × height` pixels, row by row.
    pub pixels: Vec<Vec3>,
}

impl Film {
    /// A black film. The caller has checked the size against [`crate::param::limits::Limits`].
    pub fn new(width: u32, height: u32) -> Self {
        Film { width, height, pixels: vec![Vec3::ZERO; width as usize * height as usize] }
    }

    /// A black film, or an error if its memory cannot be had (instead of aborting the process).
    pub fn try_new(width: u32, height: u32) -> Result<Self, crate::image::write::WriteError> {
        let n = (width as usize).saturating_mul(height as usize);
        Ok(Film { width, height, pixels: crate::image::write::try_filled(n, Vec3::ZERO, "film")? })
    }

    /// The pixel at column `x`, row `y`.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Sets the pixel at column `x`, row `y`.
    pub fn set(&mut self, x: u32, y: u32, c: Vec3) {
        self.pixels[y as usize * self.width as usize + x as usize] = c;
    }
}
