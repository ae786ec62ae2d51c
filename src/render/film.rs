//! The film: the rendered image as linear HDR RGB.

use glam::Vec3;

/// A vector of `n` copies of `value`, or an error naming `what` if the memory cannot be had
/// (instead of aborting the process): how films, their sums and layers are allocated.
pub fn try_filled<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, OutOfMemory> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| OutOfMemory(format!("out of memory for the {what} ({n} values)")))?;
    v.resize(n, value);
    Ok(v)
}

/// An image buffer whose memory could not be had; the message names it and its size.
#[derive(Debug)]
pub struct OutOfMemory(pub String);

impl std::fmt::Display for OutOfMemory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for OutOfMemory {}

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
    pub fn try_new(width: u32, height: u32) -> Result<Self, OutOfMemory> {
        let n = (width as usize).saturating_mul(height as usize);
        Ok(Film { width, height, pixels: try_filled(n, Vec3::ZERO, "film")? })
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
