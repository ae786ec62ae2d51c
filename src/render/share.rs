//! Parts of a frame: a rectangle of pixels ([`Rect`]), the share of the frame's work one render
//! does ([`Share`]: pixel bounds and a sample pass), and that share's exact state
//! ([`FrameSums`]): what a partial file, a checkpoint and a merge hold.
//!
//! Shares never change what a sample computes (every sample is a pure function of its pixel or
//! lattice point, index and the seed) and the sums are exact ([`crate::render::accum`]), so any
//! set of disjoint shares that covers the frame merges to the bits of one whole render.

use crate::image::film::Film;
use crate::image::layers::Aovs;
use crate::image::write::{WriteError, try_filled};
use crate::render::accum::{LayerSum, PixelSum};
use crate::render::job::{Antialiasing, RenderSettings};
use glam::Vec3;
use serde::Serialize;

/// A rectangle of pixels, `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Rect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Rect {
    /// The whole of a `width × height` frame.
    pub fn frame(width: u32, height: u32) -> Rect {
        Rect { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Columns.
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Pixels.
    pub fn pixels(&self) -> u64 {
        u64::from(self.width()) * u64::from(self.height())
    }

    /// True when it holds no pixel.
    pub fn is_empty(&self) -> bool {
        self.pixels() == 0
    }

    /// Whether pixel (`x`, `y`) is inside.
    #[inline]
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    /// Whether `self` lies within `other`.
    pub fn within(&self, other: &Rect) -> bool {
        self.x0 >= other.x0 && self.y0 >= other.y0 && self.x1 <= other.x1 && self.y1 <= other.y1
    }

    /// The pixels both hold, if any.
    pub fn intersect(&self, o: &Rect) -> Option<Rect> {
        let r = Rect { x0: self.x0.max(o.x0), y0: self.y0.max(o.y0), x1: self.x1.min(o.x1), y1: self.y1.min(o.y1) };
        (r.x0 < r.x1 && r.y0 < r.y1).then_some(r)
    }

    /// The pixel at index `i` of the rectangle, row by row.
    #[inline]
    pub fn pixel(&self, i: usize) -> (u32, u32) {
        let w = self.width() as usize;
        (self.x0 + (i % w) as u32, self.y0 + (i / w) as u32)
    }

    /// The index of pixel (`x`, `y`) (inside) in row-by-row order.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        (y - self.y0) as usize * self.width() as usize + (x - self.x0) as usize
    }
}

/// The share of a frame's work one render does: the pixels in `bounds`, and of those, sample
/// pass `pass` of `passes`. Under stratified anti-aliasing a pass takes every pixel's samples
/// `pass, pass + passes, …`; under adaptive anti-aliasing, whose samples depend on each other, it
/// takes the pixels whose index `y · width + x` is `pass` modulo `passes` (spread over the whole
/// frame all the same).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Share {
    /// The pixels.
    pub bounds: Rect,
    /// This render's pass (0-based).
    pub pass: u32,
    /// How many passes share the samples (≥ 1).
    pub passes: u32,
}

impl Share {
    /// All of a `width × height` frame.
    pub fn whole(width: u32, height: u32) -> Share {
        Share { bounds: Rect::frame(width, height), pass: 0, passes: 1 }
    }

    /// How many samples of pixel (`x`, `y`) the share takes: its stratified sample indices, or
    /// 1 for an adaptive pixel it owns; 0 outside it.
    pub fn samples_of(&self, s: &RenderSettings, x: u32, y: u32) -> u32 {
        if !self.bounds.contains(x, y) {
            return 0;
        }
        match s.aa {
            Antialiasing::Stratified => {
                let spp = s.spp.max(1);
                if self.pass >= spp { 0 } else { (spp - self.pass).div_ceil(self.passes.max(1)) }
            }
            Antialiasing::Adaptive { .. } => {
                let index = u64::from(y) * u64::from(s.width) + u64::from(x);
                u32::from(index % u64::from(self.passes.max(1)) == u64::from(self.pass))
            }
        }
    }

    /// The stratified sample index of the share's `k`-th sample of a pixel.
    #[inline]
    pub fn sample_index(&self, k: u32) -> u32 {
        self.pass + k * self.passes.max(1)
    }

    /// A description: `pixels [x0, x1) × [y0, y1), pass K/N`.
    pub fn describe(&self) -> String {
        let b = self.bounds;
        let pass = if self.passes > 1 { format!(", sample pass {}/{}", self.pass, self.passes) } else { String::new() };
        format!("pixels [{}, {}) × [{}, {}){pass}", b.x0, b.x1, b.y0, b.y1)
    }
}

/// The exact state of a render of one share of a frame: per pixel of the share's bounds, the
/// sums of its samples so far (and of its layers, when asked for).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameSums {
    /// The frame's width, pixels.
    pub width: u32,
    /// The frame's height, pixels.
    pub height: u32,
    /// The share.
    pub share: Share,
    /// Per pixel of `share.bounds`, row by row.
    pub pixels: Vec<PixelSum>,
    /// Per pixel, the layers' sums (when asked for).
    pub layers: Option<Vec<LayerSum>>,
}

impl FrameSums {
    /// Empty sums for `share` of a frame rendered with `settings` (allocated fallibly).
    pub fn new(settings: &RenderSettings, share: Share, layers: bool) -> Result<Self, WriteError> {
        let n = share.bounds.pixels() as usize;
        Ok(FrameSums {
            width: settings.width,
            height: settings.height,
            share,
            pixels: try_filled(n, PixelSum::default(), "per-pixel sums")?,
            layers: if layers { Some(try_filled(n, LayerSum::default(), "per-pixel layer sums")?) } else { None },
        })
    }

    /// Whether every pixel has all the samples of its share.
    pub fn complete(&self, settings: &RenderSettings) -> bool {
        self.pixels.iter().enumerate().all(|(i, p)| {
            let (x, y) = self.share.bounds.pixel(i);
            p.samples >= self.share.samples_of(settings, x, y)
        })
    }

    /// The image: the mean of each pixel's samples so far, black outside the bounds (or where
    /// none is done).
    pub fn film(&self) -> Result<Film, WriteError> {
        let mut film = Film::try_new(self.width, self.height)?;
        for (i, p) in self.pixels.iter().enumerate() {
            let (x, y) = self.share.bounds.pixel(i);
            film.set(x, y, p.mean().as_vec3());
        }
        Ok(film)
    }

    /// The depth, normal and albedo layers over the whole frame, when summed.
    pub fn aovs(&self) -> Result<Option<Aovs>, WriteError> {
        let Some(sums) = &self.layers else { return Ok(None) };
        let n = self.width as usize * self.height as usize;
        let mut depth = try_filled(n, f32::INFINITY, "depth layer")?;
        let mut normal = try_filled(n, Vec3::ZERO, "normal layer")?;
        let mut albedo = try_filled(n, Vec3::ZERO, "albedo layer")?;
        for (i, l) in sums.iter().enumerate() {
            let (x, y) = self.share.bounds.pixel(i);
            let k = y as usize * self.width as usize + x as usize;
            (depth[k], normal[k], albedo[k]) = l.mean();
        }
        Ok(Some(Aovs { depth: Some(depth), normal: Some(normal), albedo: Some(albedo) }))
    }
}
