//! The parallel render loop: tiles in parallel (rayon), samples per pixel, no allocation per ray.
//!
//! Two anti-aliasing schemes ([`Antialiasing`]):
//!
//! - **Stratified**: `spp` samples per pixel, one through the centre when `spp = 1`, otherwise
//!   correlated multi-jittered over the pixel; the pixel is their mean (a box filter). Rendered in
//!   passes when asked ([`render_progressive`]), with the same bits as a single pass.
//! - **Adaptive**: recursive corner subdivision where neighbouring samples disagree
//!   ([`adaptive`]).
//!
//! Every sample goes through one path ([`sample::trace_sample`]) and is a pure function of
//! (pixel or lattice point, sample, dimension, seed): the image is bit-identical for any thread
//! count and tile order. The integrator fills the depth, normal and albedo layers from the same
//! samples, in the same pass.

pub mod adaptive;
pub mod aov;
pub mod integrator;
pub mod job;
pub mod sample;
pub mod sampler;
pub mod stats;
pub mod trace;

pub use job::{ADAPTIVE_TILE_SIZE, AdaptiveSettings, Antialiasing, MAX_ADAPTIVE_DEPTH, RenderJob, RenderSettings, TILE_SIZE};

use crate::image::film::Film;
use crate::image::layers::Aovs;
use crate::render::adaptive::Adaptive;
use crate::render::sample::{LayerSum, SampleId, SampleSum, camera_rays, trace_sample};
use crate::render::stats::RayStats;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How to run a render (not part of the scene: results do not depend on these).
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderOptions<'a> {
    /// Worker threads; `None` uses all cores.
    pub threads: Option<usize>,
    /// Set to stop early (checked per row of each tile); unfinished pixels keep the samples of
    /// earlier passes (black without) and [`Rendered::complete`] is false.
    pub cancel: Option<&'a AtomicBool>,
    /// Also compute the depth, normal and albedo layers ([`Rendered::layers`]).
    pub layers: bool,
}

/// The result of a render.
pub struct Rendered {
    /// The image.
    pub film: Film,
    /// The depth, normal and albedo layers, when asked for ([`RenderOptions::layers`]).
    pub layers: Option<Aovs>,
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
        None => run(),
        Some(n) => {
            let pool =
                rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build().map_err(|e| format!("cannot start {n} threads: {e}"))?;
            pool.install(run)
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

    /// The pixel at index `i` of the tile, row by row.
    #[inline]
    fn pixel(&self, i: usize) -> (u32, u32) {
        let w = self.x1 - self.x0;
        (self.x0 + i as u32 % w, self.y0 + i as u32 / w)
    }
}

/// One tile's pixels and counters, carried from pass to pass.
struct TileState {
    tile: Tile,
    pixels: Vec<SampleSum>,
    /// Per pixel, the layers' sums (empty unless asked for).
    layers: Vec<LayerSum>,
    stats: RayStats,
    done: bool,
}

fn tiles(width: u32, height: u32, size: u32) -> Vec<Tile> {
    let mut tiles = Vec::new();
    for y0 in (0..height).step_by(size as usize) {
        for x0 in (0..width).step_by(size as usize) {
            tiles.push(Tile { x0, y0, x1: (x0 + size).min(width), y1: (y0 + size).min(height) });
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
) -> Result<Rendered, String> {
    let s = job.settings;
    let ends = match s.aa {
        Antialiasing::Stratified => pass_ends(s.spp, checkpoints),
        Antialiasing::Adaptive(_) => vec![1],
    };
    let counters = job.integrator.counters();
    // Adaptive tiles are larger: the lattice points on a tile's border are traced by both tiles.
    let size = match s.aa {
        Antialiasing::Stratified => TILE_SIZE,
        Antialiasing::Adaptive(_) => ADAPTIVE_TILE_SIZE,
    };
    let mut states: Vec<TileState> = tiles(s.width, s.height, size)
        .into_iter()
        .map(|tile| {
            let n = tile.pixels() as usize;
            let layers = if options.layers { vec![LayerSum::default(); n] } else { Vec::new() };
            TileState { tile, pixels: vec![SampleSum::default(); n], layers, stats: RayStats::new(counters), done: false }
        })
        .collect();
    let pixels = u64::from(s.width) * u64::from(s.height);
    let total = pixels * u64::from(*ends.last().unwrap_or(&1));
    let done = AtomicU64::new(0);
    let start = Instant::now();
    let mut film = Film::try_new(s.width, s.height).map_err(|e| e.to_string())?;
    let mut complete = true;
    let mut begin = 0;
    for &end in &ends {
        states.par_iter_mut().for_each(|st| {
            if options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                st.done = false;
                return;
            }
            st.done = match s.aa {
                Antialiasing::Stratified => stratified_tile(job, st, begin..end, options),
                Antialiasing::Adaptive(a) => {
                    adaptive_tile(job, st, a, options.layers);
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
        let mut stats = RayStats::new(counters);
        for st in &states {
            stats += st.stats;
            for (i, p) in st.pixels.iter().enumerate() {
                let (x, y) = st.tile.pixel(i);
                film.set(x, y, p.mean().as_vec3());
            }
        }
        if !complete {
            return Ok(Rendered { film, layers: None, stats, elapsed: start.elapsed(), complete });
        }
        on_pass(&Pass { film: &film, samples: end, elapsed: start.elapsed(), stats });
    }
    let mut stats = RayStats::new(counters);
    for st in &states {
        stats += st.stats;
    }
    let layers = if options.layers { Some(layers_of(&states, s.width, s.height).map_err(|e| e.to_string())?) } else { None };
    Ok(Rendered { film, layers, stats, elapsed: start.elapsed(), complete })
}

/// The mean layers of every pixel, row-major.
fn layers_of(states: &[TileState], width: u32, height: u32) -> Result<Aovs, crate::image::write::WriteError> {
    let n = width as usize * height as usize;
    let mut depth = crate::image::write::try_filled(n, f32::INFINITY, "depth layer")?;
    let mut normal = crate::image::write::try_filled(n, Vec3::ZERO, "normal layer")?;
    let mut albedo = crate::image::write::try_filled(n, Vec3::ZERO, "albedo layer")?;
    for st in states {
        for (i, p) in st.layers.iter().enumerate() {
            let (x, y) = st.tile.pixel(i);
            let k = y as usize * width as usize + x as usize;
            (depth[k], normal[k], albedo[k]) = p.mean();
        }
    }
    Ok(Aovs { depth: Some(depth), normal: Some(normal), albedo: Some(albedo) })
}

/// Adds `samples` to every pixel of the tile; false when cancelled part-way (checked once per row
/// of the tile, so a cancel takes effect within one row of samples, not a whole tile).
fn stratified_tile(job: &RenderJob, st: &mut TileState, samples: std::ops::Range<u32>, options: &RenderOptions) -> bool {
    let w = (st.tile.x1 - st.tile.x0) as usize;
    for (i, acc) in st.pixels.iter_mut().enumerate() {
        if i % w == 0 && options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return false;
        }
        let (x, y) = st.tile.pixel(i);
        for index in samples.clone() {
            trace_sample(job, SampleId::Pixel { x, y, index }, acc, st.layers.get_mut(i), &mut st.stats);
        }
    }
    true
}

/// The adaptive scheme over one tile (lattice points shared by its pixels).
fn adaptive_tile(job: &RenderJob, st: &mut TileState, settings: AdaptiveSettings, layers: bool) {
    let t = st.tile;
    let mut scheme = Adaptive::new(job, settings, t.x0, t.x1 - t.x0, layers);
    for (i, acc) in st.pixels.iter_mut().enumerate() {
        let (x, y) = t.pixel(i);
        let v = scheme.pixel(x, y, &mut st.stats);
        *acc = SampleSum { sum: v.color, n: 1 };
        if let Some(l) = st.layers.get_mut(i) {
            *l = v.layers;
        }
    }
}

/// The colour of pixel (`x`, `y`) with stratified sampling: the mean of its `spp` samples
/// (non-finite samples are counted and dropped). The same bits as [`render`] gives this pixel.
pub fn render_pixel(job: &RenderJob, x: u32, y: u32, stats: &mut RayStats) -> Vec3 {
    let mut acc = SampleSum::default();
    for index in 0..job.settings.spp {
        trace_sample(job, SampleId::Pixel { x, y, index }, &mut acc, None, stats);
    }
    acc.mean().as_vec3()
}

/// The samples pixel (`x`, `y`) of `job` is made of, each with its weight in the pixel's colour
/// (the weights sum to 1): its `spp` stratified samples, or the adaptive lattice points the
/// scheme traced for it (which this traces to decide).
pub fn pixel_samples(job: &RenderJob, x: u32, y: u32) -> Vec<(SampleId, f64)> {
    match job.settings.aa {
        Antialiasing::Stratified => {
            let spp = job.settings.spp.max(1);
            (0..spp).map(|index| (SampleId::Pixel { x, y, index }, 1.0 / f64::from(spp))).collect()
        }
        Antialiasing::Adaptive(a) => {
            let mut stats = RayStats::new(job.integrator.counters());
            Adaptive::new(job, a, x, 1, false).pixel_samples(x, y, &mut stats)
        }
    }
}

/// The explanation of sample `id` of `job`: one ray tree per camera ray (per lens point), each
/// computed with the camera ray and random stream the render used; `None` when the integrator
/// cannot explain itself.
pub fn explain_sample(job: &RenderJob, id: SampleId) -> Option<Vec<crate::render::trace::TraceNode>> {
    camera_rays(job, id).map(|(ray, mut sampler)| job.integrator.explain(&job.scene, &ray, &mut sampler)).collect()
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
