//! The parallel render loop: tiles in parallel (rayon), samples per pixel, no allocation per ray.
//!
//! Two anti-aliasing schemes ([`Antialiasing`]):
//!
//! - **Stratified**: `spp` samples per pixel, one through the centre when `spp = 1`, otherwise
//!   correlated multi-jittered over the pixel; the pixel is their mean (a box filter). Rendered in
//!   passes when asked ([`render_progressive`]), with the same bits as a single pass.
//! - **Adaptive** (recursive corner subdivision, as Whitted 1980 and POV-Ray's `+AM2`): rays go
//!   through the four corners of each pixel. When the corners' displayed colours differ by more
//!   than `threshold` in any channel, the square is split into four, tracing the centre and the
//!   four edge midpoints, and each quarter is tested again, down to `max_depth` levels (a
//!   `2^max_depth` sub-grid). A square that is not split is the mean of its corners; a split
//!   square is the mean of its quarters. Corner samples are shared between neighbouring squares
//!   and pixels of a tile, so a flat region costs about one ray per pixel.
//!
//! Every sample is a pure function of (pixel or lattice point, sample, dimension, seed): the image
//! is bit-identical for any thread count and tile order.

pub mod aov;
pub mod integrator;
pub mod sampler;
pub mod stats;
pub mod trace;

use crate::image::film::Film;
use crate::math::color::{Color, Encoding};
use crate::render::integrator::Integrator;
use crate::render::sampler::{Sampler, mix64, stratified_2d};
use crate::render::stats::RayStats;
use crate::scene::Scene;
use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How pixels are sampled.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "mode", rename_all = "lowercase")]
pub enum Antialiasing {
    /// `spp` samples per pixel: the centre for 1, stratified (correlated multi-jitter) for more.
    Stratified,
    /// Recursive corner subdivision where neighbouring samples disagree (see the module docs).
    Adaptive {
        /// Split a square when its corners' displayed values (clamped, encoded, 0..1) differ by
        /// more than this in any channel.
        threshold: f64,
        /// Most subdivision levels per pixel (0 = the four corners only).
        max_depth: u32,
    },
}

/// Most adaptive subdivision levels (a 256 × 256 sub-grid per pixel).
pub const MAX_ADAPTIVE_DEPTH: u32 = 8;

/// Image and sampling settings of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width, pixels (≥ 1).
    pub width: u32,
    /// Image height, pixels (≥ 1).
    pub height: u32,
    /// Samples per pixel (≥ 1) for stratified anti-aliasing. One sample goes through the pixel
    /// centre; more are stratified. Unused by adaptive anti-aliasing.
    pub spp: u32,
    /// Random seed: same seed, same image.
    pub seed: u64,
    /// How 8-bit output encodes linear values (adaptive anti-aliasing compares encoded values).
    pub encoding: Encoding,
    /// Anti-aliasing scheme.
    pub aa: Antialiasing,
    /// Rays through distinct lens points per image sample (≥ 1), stratified over the lens; only
    /// used when the camera has an aperture.
    pub lens_samples: u32,
}

impl RenderSettings {
    /// Settings with stratified sampling at `spp`, seed 0, sRGB output and one lens sample.
    pub fn new(width: u32, height: u32, spp: u32) -> Self {
        RenderSettings { width, height, spp, seed: 0, encoding: Encoding::Srgb, aa: Antialiasing::Stratified, lens_samples: 1 }
    }

    /// A short description: `16 spp` or `adaptive (threshold 0.05, depth 3)`, plus lens samples.
    pub fn describe_sampling(&self) -> String {
        let aa = match self.aa {
            Antialiasing::Stratified => format!("{} spp", self.spp),
            Antialiasing::Adaptive { threshold, max_depth } => format!("adaptive AA (threshold {threshold}, depth {max_depth})"),
        };
        if self.lens_samples > 1 { format!("{aa}, {} lens samples", self.lens_samples) } else { aa }
    }
}

/// A scene ready to render: the scene, its integrator and its settings.
pub struct RenderJob {
    /// The scene.
    pub scene: Scene,
    /// The integrator.
    pub integrator: Box<dyn Integrator>,
    /// The integrator's type name.
    pub integrator_name: String,
    /// Image and sampling settings.
    pub settings: RenderSettings,
    /// What loading ignored or approximated, to show the user (see [`crate::input::context::LoadContext::warn`]).
    pub warnings: Vec<crate::input::error::SceneError>,
}

/// Edge of the square tiles the image is split into, pixels.
pub const TILE_SIZE: u32 = 16;

/// How to run a render (not part of the scene: results do not depend on these).
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderOptions<'a> {
    /// Worker threads; `None` uses all cores.
    pub threads: Option<usize>,
    /// Set to stop early (checked per row of each tile); unfinished pixels keep the samples of
    /// earlier passes (black without) and [`Rendered::complete`] is false.
    pub cancel: Option<&'a AtomicBool>,
}

/// The result of a render.
pub struct Rendered {
    /// The image.
    pub film: Film,
    /// Rays traced and avoided.
    pub stats: RayStats,
    /// Wall time of tracing (excludes loading and writing).
    pub elapsed: Duration,
    /// False when cancelled before every tile was done.
    pub complete: bool,
}

/// The state of a progressive render after one pass.
pub struct Pass<'a> {
    /// The image so far: each pixel the mean of its first `samples` samples.
    pub film: &'a Film,
    /// Samples per pixel so far.
    pub samples: u32,
    /// Wall time of tracing so far.
    pub elapsed: Duration,
    /// Counters so far.
    pub stats: RayStats,
}

/// Renders `job`. `progress(done, total)` is called (from worker threads) as tiles finish, in
/// units of pixel samples. The image is bit-identical for any thread count and tile order.
pub fn render(job: &RenderJob, options: &RenderOptions, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<Rendered, String> {
    render_progressive(job, options, &[], progress, &mut |_| {})
}

/// Renders `job` in passes: with stratified anti-aliasing, pass `k` takes each pixel from
/// `checkpoints[k−1]` to `checkpoints[k]` samples (checkpoints beyond `spp` are ignored; the last
/// pass always ends at `spp`), and `on_pass` sees the image after each. The final image has the
/// same bits as a single-pass [`render`]. Adaptive anti-aliasing renders in one pass.
pub fn render_progressive(
    job: &RenderJob,
    options: &RenderOptions,
    checkpoints: &[u32],
    progress: &(dyn Fn(u64, u64) + Sync),
    on_pass: &mut (dyn FnMut(&Pass) + Send),
) -> Result<Rendered, String> {
    let mut run = || render_passes(job, options, checkpoints, progress, on_pass);
    match options.threads {
        None => Ok(run()),
        Some(n) => {
            let pool =
                rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build().map_err(|e| format!("cannot start {n} threads: {e}"))?;
            Ok(pool.install(run))
        }
    }
}

/// A rectangle of pixels, `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy)]
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl Tile {
    fn pixels(&self) -> u64 {
        u64::from(self.x1 - self.x0) * u64::from(self.y1 - self.y0)
    }
}

/// Running sum of one pixel's finite samples.
#[derive(Clone, Copy, Default)]
struct PixelSum {
    sum: Color,
    n: u32,
}

impl PixelSum {
    fn mean(&self) -> Vec3 {
        if self.n == 0 { Vec3::ZERO } else { (self.sum / f64::from(self.n)).as_vec3() }
    }
}

/// One tile's pixels and counters, carried from pass to pass.
struct TileState {
    tile: Tile,
    pixels: Vec<PixelSum>,
    stats: RayStats,
    done: bool,
}

fn tiles(width: u32, height: u32) -> Vec<Tile> {
    let mut tiles = Vec::new();
    for y0 in (0..height).step_by(TILE_SIZE as usize) {
        for x0 in (0..width).step_by(TILE_SIZE as usize) {
            tiles.push(Tile { x0, y0, x1: (x0 + TILE_SIZE).min(width), y1: (y0 + TILE_SIZE).min(height) });
        }
    }
    tiles
}

/// The sample counts at which passes end: the checkpoints below `spp`, ascending, then `spp`.
fn pass_ends(spp: u32, checkpoints: &[u32]) -> Vec<u32> {
    let mut ends: Vec<u32> = checkpoints.iter().copied().filter(|&c| c > 0 && c < spp).collect();
    ends.sort_unstable();
    ends.dedup();
    ends.push(spp);
    ends
}

fn render_passes(
    job: &RenderJob,
    options: &RenderOptions,
    checkpoints: &[u32],
    progress: &(dyn Fn(u64, u64) + Sync),
    on_pass: &mut (dyn FnMut(&Pass) + Send),
) -> Rendered {
    let s = job.settings;
    let ends = match s.aa {
        Antialiasing::Stratified => pass_ends(s.spp, checkpoints),
        Antialiasing::Adaptive { .. } => vec![1],
    };
    let mut states: Vec<TileState> = tiles(s.width, s.height)
        .into_iter()
        .map(|tile| TileState { tile, pixels: vec![PixelSum::default(); tile.pixels() as usize], stats: RayStats::default(), done: false })
        .collect();
    let pixels = u64::from(s.width) * u64::from(s.height);
    let total = pixels * u64::from(*ends.last().unwrap_or(&1));
    let done = AtomicU64::new(0);
    let start = Instant::now();
    let mut film = Film::new(s.width, s.height);
    let mut complete = true;
    let mut begin = 0;
    for &end in &ends {
        states.par_iter_mut().for_each(|st| {
            if options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                st.done = false;
                return;
            }
            st.done = match s.aa {
                Antialiasing::Stratified => stratified_tile(job, st, begin..end, options.cancel),
                Antialiasing::Adaptive { threshold, max_depth } => {
                    adaptive_tile(job, st, threshold, max_depth);
                    true
                }
            };
            if !st.done {
                return;
            }
            let work = st.tile.pixels() * u64::from(end - begin);
            progress(done.fetch_add(work, Ordering::Relaxed) + work, total);
        });
        begin = end;
        complete = states.iter().all(|st| st.done);
        let mut stats = RayStats::default();
        for st in &states {
            stats += st.stats;
            let w = st.tile.x1 - st.tile.x0;
            for (i, p) in st.pixels.iter().enumerate() {
                film.set(st.tile.x0 + i as u32 % w, st.tile.y0 + i as u32 / w, p.mean());
            }
        }
        if !complete {
            return Rendered { film, stats, elapsed: start.elapsed(), complete };
        }
        on_pass(&Pass { film: &film, samples: end, elapsed: start.elapsed(), stats });
    }
    let stats = states.iter().fold(RayStats::default(), |mut a, st| {
        a += st.stats;
        a
    });
    Rendered { film, stats, elapsed: start.elapsed(), complete }
}

/// Adds `samples` to every pixel of the tile; false when cancelled part-way (checked once per row
/// of the tile, so a cancel takes effect within one row of samples, not a whole tile).
fn stratified_tile(job: &RenderJob, st: &mut TileState, samples: std::ops::Range<u32>, cancel: Option<&AtomicBool>) -> bool {
    let t = st.tile;
    let w = t.x1 - t.x0;
    for (i, acc) in st.pixels.iter_mut().enumerate() {
        if (i as u32).is_multiple_of(w) && cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return false;
        }
        let (x, y) = (t.x0 + i as u32 % w, t.y0 + i as u32 / w);
        add_samples(job, x, y, samples.clone(), acc, &mut st.stats);
    }
    true
}

/// The colour of pixel (`x`, `y`) with stratified sampling: the mean of its `spp` samples
/// (non-finite samples are counted and dropped). The same bits as [`render`] gives this pixel.
pub fn render_pixel(job: &RenderJob, x: u32, y: u32, stats: &mut RayStats) -> Vec3 {
    let mut acc = PixelSum::default();
    add_samples(job, x, y, 0..job.settings.spp, &mut acc, stats);
    acc.mean()
}

/// Lens-pattern key offset, so lens and film patterns of a pixel are independent.
const LENS_PATTERN: u32 = 0x5bd1_e995;

/// Adds samples `samples` (of `spp`) of pixel (`x`, `y`) to `acc`.
fn add_samples(job: &RenderJob, x: u32, y: u32, samples: std::ops::Range<u32>, acc: &mut PixelSum, stats: &mut RayStats) {
    let s = &job.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let pattern = (mix64(pixel ^ s.seed.rotate_left(17)) >> 32) as u32;
    for i in samples {
        let sampler = Sampler::new(pixel, i, s.seed);
        let jitter = if s.spp == 1 { DVec2::splat(0.5) } else { stratified_2d(i, s.spp, pattern) };
        let film = DVec2::new(f64::from(x), f64::from(y)) + jitter;
        let lenses = LensSet {
            first: i * s.lens_samples,
            per_sample: s.lens_samples,
            total: s.spp * s.lens_samples,
            pattern: pattern ^ LENS_PATTERN,
        };
        camera_sample(job, film, &lenses, &sampler, acc, stats);
    }
}

/// The (first) camera ray of stratified sample `i` of pixel (`x`, `y`): the same ray the render
/// traces for that sample, so other passes (the depth, normal and albedo layers of
/// [`crate::render::aov`]) see what the image shows.
pub fn camera_ray(job: &RenderJob, x: u32, y: u32, i: u32) -> crate::math::ray::Ray {
    let s = &job.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let pattern = (mix64(pixel ^ s.seed.rotate_left(17)) >> 32) as u32;
    let jitter = if s.spp == 1 { DVec2::splat(0.5) } else { stratified_2d(i, s.spp, pattern) };
    let film = DVec2::new(f64::from(x), f64::from(y)) + jitter;
    let camera = &job.scene.camera;
    let lens = if camera.aperture > 0.0 {
        stratified_2d(i * s.lens_samples, (s.spp * s.lens_samples).max(1), pattern ^ LENS_PATTERN)
    } else {
        DVec2::ZERO
    };
    camera.ray_through(s.width, s.height, film, lens)
}

/// Which stratified lens points an image sample uses: points `first .. first + per_sample` of a
/// set of `total`.
struct LensSet {
    first: u32,
    per_sample: u32,
    total: u32,
    pattern: u32,
}

/// Traces the camera ray(s) of one image sample at film position `film` (one per lens point when
/// the camera has an aperture) and adds each radiance to `acc`.
#[inline]
fn camera_sample(job: &RenderJob, film: DVec2, lenses: &LensSet, sampler: &Sampler, acc: &mut PixelSum, stats: &mut RayStats) {
    let s = &job.settings;
    let camera = &job.scene.camera;
    let count = if camera.aperture > 0.0 { lenses.per_sample.max(1) } else { 1 };
    for l in 0..count {
        let lens = if camera.aperture > 0.0 { stratified_2d(lenses.first + l, lenses.total.max(1), lenses.pattern) } else { DVec2::ZERO };
        let ray = camera.ray_through(s.width, s.height, film, lens);
        let mut sampler = if l == 0 { sampler.clone() } else { sampler.fork(u64::from(l)) };
        stats.camera_rays += 1;
        let c = job.integrator.radiance(&job.scene, &ray, &mut sampler, stats);
        if c.is_finite() {
            acc.sum += c;
            acc.n += 1;
        } else {
            stats.nonfinite_samples += 1;
        }
    }
}

/// Sample index that marks adaptive lattice samples in [`Sampler::new`] (stratified samples
/// never reach it: `spp` is far smaller).
const ADAPTIVE_SAMPLE: u32 = u32::MAX;

/// The adaptive scheme over one tile. Lattice coordinates are global, in units of
/// `1 / 2^max_depth` pixel, so a lattice point's sample does not depend on the tile.
fn adaptive_tile(job: &RenderJob, st: &mut TileState, threshold: f64, max_depth: u32) {
    let s = &job.settings;
    let depth = max_depth.min(MAX_ADAPTIVE_DEPTH);
    let res = 1u64 << depth;
    let row = u64::from(s.width) * res + 1;
    let t = st.tile;
    let mut cache: HashMap<u64, Color> = HashMap::with_capacity(((t.x1 - t.x0 + 1) * (t.y1 - t.y0 + 1)) as usize);
    let mut ad = Adaptive { job, threshold, res, row, cache: &mut cache, stats: &mut st.stats };
    let w = t.x1 - t.x0;
    for (i, acc) in st.pixels.iter_mut().enumerate() {
        let (x, y) = (u64::from(t.x0 + i as u32 % w), u64::from(t.y0 + i as u32 / w));
        let c = ad.square(x * res, y * res, res, depth);
        *acc = PixelSum { sum: c, n: 1 };
    }
}

struct Adaptive<'a> {
    job: &'a RenderJob,
    threshold: f64,
    res: u64,
    row: u64,
    cache: &'a mut HashMap<u64, Color>,
    stats: &'a mut RayStats,
}

impl Adaptive<'_> {
    /// The colour of the square with top-left lattice point (`x`, `y`) and side `size`, allowed
    /// `levels` more subdivisions.
    fn square(&mut self, x: u64, y: u64, size: u64, levels: u32) -> Color {
        let c = [self.point(x, y), self.point(x + size, y), self.point(x, y + size), self.point(x + size, y + size)];
        if levels == 0 || !self.differ(&c) {
            return (c[0] + c[1] + c[2] + c[3]) * 0.25;
        }
        let h = size / 2;
        let q = [
            self.square(x, y, h, levels - 1),
            self.square(x + h, y, h, levels - 1),
            self.square(x, y + h, h, levels - 1),
            self.square(x + h, y + h, h, levels - 1),
        ];
        (q[0] + q[1] + q[2] + q[3]) * 0.25
    }

    /// Whether the displayed values of `c` differ by more than the threshold in any channel.
    fn differ(&self, c: &[Color; 4]) -> bool {
        let enc = self.job.settings.encoding;
        let d = |v: Color| {
            DVec3::new(f64::from(enc.display(v.x as f32)), f64::from(enc.display(v.y as f32)), f64::from(enc.display(v.z as f32)))
        };
        let e = c.map(d);
        let lo = e[0].min(e[1]).min(e[2]).min(e[3]);
        let hi = e[0].max(e[1]).max(e[2]).max(e[3]);
        (hi - lo).max_element() > self.threshold
    }

    /// The sample at lattice point (`x`, `y`), traced once per tile.
    fn point(&mut self, x: u64, y: u64) -> Color {
        let key = y * self.row + x;
        if let Some(c) = self.cache.get(&key) {
            return *c;
        }
        let s = &self.job.settings;
        let res = self.res as f64;
        let film = DVec2::new(x as f64 / res, y as f64 / res);
        let mut sampler = Sampler::new(key, ADAPTIVE_SAMPLE, s.seed);
        let pattern = sampler.next_pattern();
        let lenses = LensSet { first: 0, per_sample: s.lens_samples, total: s.lens_samples, pattern };
        let mut acc = PixelSum::default();
        camera_sample(self.job, film, &lenses, &sampler.fork(0), &mut acc, self.stats);
        let c = if acc.n == 0 { Color::ZERO } else { acc.sum / f64::from(acc.n) };
        self.cache.insert(key, c);
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_end_at_sorted_checkpoints_then_spp() {
        assert_eq!(pass_ends(16, &[8, 1, 4, 2, 64, 0, 4]), vec![1, 2, 4, 8, 16]);
        assert_eq!(pass_ends(1, &[1, 2]), vec![1]);
    }
}
