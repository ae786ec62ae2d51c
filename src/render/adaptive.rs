//! Adaptive anti-aliasing: recursive corner subdivision (Whitted 1980, POV-Ray's `+AM2`).
//!
//! Rays go through the four corners of each pixel. When the corners' displayed colours differ by
//! more than `threshold` in any channel, the square is split into four, tracing the centre and
//! the four edge midpoints, and each quarter is tested again, down to `max_depth` levels (a
//! `2^max_depth` sub-grid). A square that is not split is the mean of its corners; a split square
//! is the mean of its quarters. Corner samples are shared between neighbouring squares and the
//! pixels of a tile, so a flat region costs about one ray per pixel. Lattice coordinates are
//! global ([`SampleId::Lattice`]), so a point's value does not depend on the tile that traces it.

use crate::math::color::Color;
use crate::render::accum::{LayerSum, PixelSum};
use crate::render::job::{MAX_ADAPTIVE_DEPTH, RenderJob};
use crate::render::sample::{SampleId, trace_sample};
use crate::render::stats::RayStats;
use glam::{DVec3, Vec3};
use std::collections::HashMap;

/// Layers as weighted means: combined with the same weights as the colour.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WeightedLayers {
    /// Weighted depth over the weight of the rays that hit.
    pub depth: f32,
    /// Weight of the rays that hit.
    pub hits: f32,
    /// Weighted shading normal.
    pub normal: Vec3,
    /// Weighted albedo.
    pub albedo: Vec3,
}

impl WeightedLayers {
    fn of(s: &LayerSum) -> Self {
        let (depth, normal, albedo) = s.mean();
        let hits = if s.rays > 0 { s.hits as f32 / s.rays as f32 } else { 0.0 };
        WeightedLayers { depth: if depth.is_finite() { depth * hits } else { 0.0 }, hits, normal, albedo }
    }

    fn mean4(v: [WeightedLayers; 4]) -> Self {
        let sum = |f: fn(&WeightedLayers) -> f32| (f(&v[0]) + f(&v[1]) + f(&v[2]) + f(&v[3])) * 0.25;
        WeightedLayers {
            depth: sum(|l| l.depth),
            hits: sum(|l| l.hits),
            normal: (v[0].normal + v[1].normal + v[2].normal + v[3].normal) * 0.25,
            albedo: (v[0].albedo + v[1].albedo + v[2].albedo + v[3].albedo) * 0.25,
        }
    }

    /// The pixel's layers as sums of one unit of weight.
    pub fn sum(&self) -> LayerSum {
        let depth = if self.hits > 0.0 { self.depth / self.hits } else { f32::INFINITY };
        LayerSum::whole(depth, self.normal, self.albedo)
    }
}

/// The value of a lattice point or a square: mean radiance, and mean layers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Value {
    /// Mean radiance.
    pub color: Color,
    /// Layers (zero unless asked for).
    pub layers: WeightedLayers,
}

fn mean4(v: [Value; 4]) -> Value {
    Value {
        color: (v[0].color + v[1].color + v[2].color + v[3].color) * 0.25,
        layers: WeightedLayers::mean4([v[0].layers, v[1].layers, v[2].layers, v[3].layers]),
    }
}

/// The adaptive scheme for one job, with the lattice points traced so far (shared by the
/// squares of one tile).
pub struct Adaptive<'a> {
    job: &'a RenderJob,
    threshold: f64,
    depth: u32,
    res: u64,
    row: u64,
    layers: bool,
    cache: HashMap<u64, Value>,
}

impl<'a> Adaptive<'a> {
    /// The scheme for `job` with this `threshold` and `max_depth`, for about `pixels` pixels;
    /// `layers` also computes the depth, normal and albedo layers.
    pub fn new(job: &'a RenderJob, threshold: f64, max_depth: u32, pixels: usize, layers: bool) -> Self {
        let depth = max_depth.min(MAX_ADAPTIVE_DEPTH);
        let res = 1u64 << depth;
        let row = u64::from(job.settings.width) * res + 1;
        Adaptive { job, threshold, depth, res, row, layers, cache: HashMap::with_capacity(pixels) }
    }

    /// The value of pixel (`x`, `y`).
    pub fn pixel(&mut self, x: u32, y: u32, stats: &mut RayStats) -> Value {
        let (x, y) = (u64::from(x) * self.res, u64::from(y) * self.res);
        self.square(x, y, self.res, self.depth, stats)
    }

    /// The lattice points pixel (`x`, `y`) is made of, in the order first traced, each with its
    /// weight in the pixel's value (the weights sum to 1).
    pub fn pixel_samples(&mut self, x: u32, y: u32, stats: &mut RayStats) -> Vec<(SampleId, f64)> {
        let mut out: Vec<(SampleId, f64)> = Vec::new();
        let (x, y) = (u64::from(x) * self.res, u64::from(y) * self.res);
        self.weights(x, y, self.res, self.depth, 1.0, stats, &mut out);
        out
    }

    /// The value of the square with top-left lattice point (`x`, `y`) and side `size`, allowed
    /// `levels` more subdivisions.
    fn square(&mut self, x: u64, y: u64, size: u64, levels: u32, stats: &mut RayStats) -> Value {
        let c = self.corners(x, y, size, stats);
        if levels == 0 || !self.differ(&c) {
            return mean4(c);
        }
        let h = size / 2;
        mean4([
            self.square(x, y, h, levels - 1, stats),
            self.square(x + h, y, h, levels - 1, stats),
            self.square(x, y + h, h, levels - 1, stats),
            self.square(x + h, y + h, h, levels - 1, stats),
        ])
    }

    /// [`Adaptive::square`]'s decisions, recording each lattice point's weight in `out`.
    #[allow(clippy::too_many_arguments)]
    fn weights(&mut self, x: u64, y: u64, size: u64, levels: u32, w: f64, stats: &mut RayStats, out: &mut Vec<(SampleId, f64)>) {
        let c = self.corners(x, y, size, stats);
        if levels == 0 || !self.differ(&c) {
            for (px, py) in [(x, y), (x + size, y), (x, y + size), (x + size, y + size)] {
                let id = SampleId::Lattice { x: px, y: py, depth: self.depth };
                match out.iter_mut().find(|(i, _)| *i == id) {
                    Some(e) => e.1 += 0.25 * w,
                    None => out.push((id, 0.25 * w)),
                }
            }
            return;
        }
        let h = size / 2;
        for (qx, qy) in [(x, y), (x + h, y), (x, y + h), (x + h, y + h)] {
            self.weights(qx, qy, h, levels - 1, 0.25 * w, stats, out);
        }
    }

    fn corners(&mut self, x: u64, y: u64, size: u64, stats: &mut RayStats) -> [Value; 4] {
        [self.point(x, y, stats), self.point(x + size, y, stats), self.point(x, y + size, stats), self.point(x + size, y + size, stats)]
    }

    /// Whether the displayed values of `c` differ by more than the threshold in any channel.
    fn differ(&self, c: &[Value; 4]) -> bool {
        let enc = self.job.settings.encoding;
        let d = |v: &Value| {
            let v = v.color;
            DVec3::new(f64::from(enc.display(v.x as f32)), f64::from(enc.display(v.y as f32)), f64::from(enc.display(v.z as f32)))
        };
        let e = [d(&c[0]), d(&c[1]), d(&c[2]), d(&c[3])];
        let lo = e[0].min(e[1]).min(e[2]).min(e[3]);
        let hi = e[0].max(e[1]).max(e[2]).max(e[3]);
        (hi - lo).max_element() > self.threshold
    }

    /// The value at lattice point (`x`, `y`), traced once per scheme.
    fn point(&mut self, x: u64, y: u64, stats: &mut RayStats) -> Value {
        let key = y * self.row + x;
        if let Some(v) = self.cache.get(&key) {
            return *v;
        }
        let (mut acc, mut sums) = (PixelSum::default(), LayerSum::default());
        trace_sample(self.job, SampleId::Lattice { x, y, depth: self.depth }, &mut acc, self.layers.then_some(&mut sums), stats);
        let v = Value { color: acc.mean(), layers: WeightedLayers::of(&sums) };
        self.cache.insert(key, v);
        v
    }
}
