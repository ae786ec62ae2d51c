//! The parallel render loop: tiles in parallel (rayon), samples per pixel, no allocation per ray.

use crate::color::{Color, Encoding};
use crate::film::Film;
use crate::integrator::Integrator;
use crate::sampler::{Sampler, stratified_2d};
use crate::scene::Scene;
use crate::stats::RayStats;
use glam::{DVec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Image and sampling settings of a render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    /// Image width, pixels (≥ 1).
    pub width: u32,
    /// Image height, pixels (≥ 1).
    pub height: u32,
    /// Samples per pixel (≥ 1). One sample goes through the pixel centre; more are stratified.
    pub spp: u32,
    /// Random seed: same seed, same image.
    pub seed: u64,
    /// How 8-bit output encodes linear values.
    pub encoding: Encoding,
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
}

/// Edge of the square tiles the image is split into, pixels.
pub const TILE_SIZE: u32 = 16;

/// How to run a render (not part of the scene: results do not depend on these).
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderOptions<'a> {
    /// Worker threads; `None` uses all cores.
    pub threads: Option<usize>,
    /// Set to stop early; unfinished tiles stay black and [`Rendered::complete`] is false.
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

/// Renders `job`. `progress(done, total)` is called (from worker threads) as tiles finish, with
/// counts in pixels. The image is bit-identical for any thread count and tile order.
pub fn render(job: &RenderJob, options: &RenderOptions, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<Rendered, String> {
    let run = || render_tiles(job, options, progress);
    match options.threads {
        None => Ok(run()),
        Some(n) => {
            let pool =
                rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build().map_err(|e| format!("cannot start {n} threads: {e}"))?;
            Ok(pool.install(run))
        }
    }
}

struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

fn render_tiles(job: &RenderJob, options: &RenderOptions, progress: &(dyn Fn(u64, u64) + Sync)) -> Rendered {
    let s = job.settings;
    let mut tiles = Vec::new();
    for y0 in (0..s.height).step_by(TILE_SIZE as usize) {
        for x0 in (0..s.width).step_by(TILE_SIZE as usize) {
            tiles.push(Tile { x0, y0, x1: (x0 + TILE_SIZE).min(s.width), y1: (y0 + TILE_SIZE).min(s.height) });
        }
    }
    let total = u64::from(s.width) * u64::from(s.height);
    let done = AtomicU64::new(0);
    let start = Instant::now();
    let results: Vec<Option<(Vec<Vec3>, RayStats)>> = tiles
        .par_iter()
        .map(|t| {
            if options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return None;
            }
            let r = render_tile(job, t);
            let n = done.fetch_add(u64::from((t.x1 - t.x0) * (t.y1 - t.y0)), Ordering::Relaxed) + u64::from((t.x1 - t.x0) * (t.y1 - t.y0));
            progress(n, total);
            Some(r)
        })
        .collect();
    let elapsed = start.elapsed();
    let mut film = Film::new(s.width, s.height);
    let mut stats = RayStats::default();
    let mut complete = true;
    for (t, r) in tiles.iter().zip(results) {
        let Some((pixels, st)) = r else {
            complete = false;
            continue;
        };
        stats += st;
        let w = t.x1 - t.x0;
        for (i, c) in pixels.into_iter().enumerate() {
            film.set(t.x0 + i as u32 % w, t.y0 + i as u32 / w, c);
        }
    }
    Rendered { film, stats, elapsed, complete }
}

fn render_tile(job: &RenderJob, t: &Tile) -> (Vec<Vec3>, RayStats) {
    let mut stats = RayStats::default();
    let mut out = Vec::with_capacity(((t.x1 - t.x0) * (t.y1 - t.y0)) as usize);
    for y in t.y0..t.y1 {
        for x in t.x0..t.x1 {
            out.push(render_pixel(job, x, y, &mut stats));
        }
    }
    (out, stats)
}

/// The colour of pixel (`x`, `y`): the mean of `spp` samples. One sample goes through the pixel
/// centre (the report's camera); more are stratified over the pixel (correlated multi-jitter).
/// Non-finite samples are counted and dropped.
pub fn render_pixel(job: &RenderJob, x: u32, y: u32, stats: &mut RayStats) -> Vec3 {
    let s = &job.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let mut sum = Color::ZERO;
    let mut n = 0u32;
    for i in 0..s.spp {
        let mut sampler = Sampler::new(pixel, i, s.seed);
        let ray = camera_ray(job, x, y, i);
        stats.camera_rays += 1;
        let c = job.integrator.radiance(&job.scene, &ray, &mut sampler, stats);
        if c.is_finite() {
            sum += c;
            n += 1;
        } else {
            stats.nonfinite_samples += 1;
        }
    }
    if n == 0 { Vec3::ZERO } else { (sum / f64::from(n)).as_vec3() }
}

/// The camera ray of sample `i` of pixel (`x`, `y`): through the pixel centre for one sample per
/// pixel, stratified over the pixel (and the lens) for more. A pure function of the pixel, the
/// sample and the seed, so other passes (depth, normal, albedo layers) see the same rays.
#[inline]
pub fn camera_ray(job: &RenderJob, x: u32, y: u32, i: u32) -> crate::ray::Ray {
    let s = &job.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let pattern = (crate::sampler::mix64(pixel ^ s.seed.rotate_left(17)) >> 32) as u32;
    let jitter = if s.spp == 1 { DVec2::splat(0.5) } else { stratified_2d(i, s.spp, pattern) };
    let lens = if job.scene.camera.aperture > 0.0 { stratified_2d(i, s.spp, pattern ^ 0x5bd1_e995) } else { DVec2::ZERO };
    let film = DVec2::new(f64::from(x), f64::from(y)) + jitter;
    job.scene.camera.ray_through(s.width, s.height, film, lens)
}
