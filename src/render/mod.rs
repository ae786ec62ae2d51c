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
//! (pixel or lattice point, sample, dimension, seed), and pixels are exact sums
//! ([`accum`]): the image is bit-identical for any thread count and tile order, and for any
//! split of the frame into shares ([`share`]: crops, tiles, sample passes, a resume) merged
//! again. The integrator fills the depth, normal and albedo layers from the same samples, in the
//! same pass.

pub mod accum;
pub mod adaptive;
pub mod aov;
pub mod budget;
pub mod explain;
pub mod film;
pub mod integrator;
pub mod job;
pub mod sample;
pub mod share;
pub mod split;
pub mod stats;
pub mod trace;

pub use job::{ADAPTIVE_TILE_SIZE, AdaptiveSettings, Antialiasing, MAX_ADAPTIVE_DEPTH, RenderJob, RenderSettings, TILE_SIZE};

use crate::geometry::{Intersectable, PACKET};
use crate::math::ray::Ray;
use crate::math::sampler::{Sampler, TabledSet};
use crate::render::accum::{AovSum, PixelSum};
use crate::render::adaptive::Adaptive;
use crate::render::aov::AovLayers;
use crate::render::film::Film;
use crate::render::sample::{
    ImageSetup, PixelSetup, PreparedSample, SampleId, camera_rays, image_setup, pixel_setup, single_camera_sample, trace_packet_from,
    trace_pixel_packet, trace_pixel_sample, trace_sample,
};
use crate::render::share::{Rect, Sampling, Share, ShareSums};
use crate::render::stats::{Counter, RayStats};
use glam::{DVec2, Vec3};
use rayon::prelude::*;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How to run a render (not part of the scene: results do not depend on these).
#[derive(Clone, Copy, Default)]
pub struct RenderOptions<'a> {
    /// Worker threads; `None` uses all cores.
    pub threads: Option<usize>,
    /// Set to stop early (checked per pixel row of each tile); every pixel keeps the samples it
    /// has, and [`Rendered::complete`] is false.
    pub cancel: Option<&'a AtomicBool>,
    /// Also compute the depth, normal and albedo layers ([`Rendered::layers`]).
    pub layers: bool,
    /// The part of the frame to render (default: all of it).
    pub share: Option<Share>,
    /// Continue from this state (of the same share; a checkpoint): samples already summed are
    /// not traced again.
    pub resume: Option<&'a ShareSums>,
    /// Hand the state to `write` every `every` while rendering (checkpoints).
    pub snapshots: Option<Snapshots<'a>>,
    /// Called as each tile finishes (from a worker thread, while the state is locked): live
    /// displays show the tile at once.
    pub on_tile: Option<&'a (dyn Fn(&TileDone) + Sync)>,
    /// The samples each pixel of the frame reached in a render under a time budget (row by row,
    /// the `spp` layer it wrote): with it, a render of the same job stops each pixel there
    /// instead of at the clock, and repeats that render bit for bit.
    pub spp_map: Option<&'a [u32]>,
}

/// A tile that has just finished, with the render's state at that moment.
pub struct TileDone<'a> {
    /// The tile's pixels.
    pub tile: Rect,
    /// The state of the whole share (the tile's pixels hold their new sums).
    pub sums: &'a ShareSums,
    /// Counters so far.
    pub stats: &'a RayStats,
    /// The stratified sample index the current pass ends at (1 under adaptive anti-aliasing).
    pub pass_end: u32,
    /// Wall time of tracing so far.
    pub elapsed: Duration,
}

/// Periodic copies of a render's state.
#[derive(Clone, Copy)]
pub struct Snapshots<'a> {
    /// How often.
    pub every: Duration,
    /// Receives the state (called from a worker thread, while the state is locked).
    pub write: &'a (dyn Fn(&ShareSums) + Sync),
}

/// The result of a render.
pub struct Rendered {
    /// The image (black outside the share's bounds).
    pub film: Film,
    /// The depth, normal and albedo layers, when asked for ([`RenderOptions::layers`]).
    pub layers: Option<AovLayers>,
    /// The exact per-pixel state: what a partial file or a checkpoint holds.
    pub sums: ShareSums,
    /// Rays traced and avoided.
    pub stats: RayStats,
    /// Wall time of tracing (excludes loading and writing).
    pub elapsed: Duration,
    /// False when cancelled, or stopped by the work budget, before every pixel had its samples.
    pub complete: bool,
    /// Set when the work budget ([`RenderJob::max_rays`]) stopped the render: the rays traced by
    /// then (the tiles that ran out are discarded; the image holds the tiles done).
    pub budget_stop: Option<u64>,
    /// Set when the time budget ([`RenderSettings::time_budget`]) ended the render before every
    /// pixel had `spp` samples (the render is complete all the same: each pixel keeps what it
    /// has, and the `spp` layer records it).
    pub time_stop: bool,
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
    /// The depth, normal and albedo layers so far, when the render takes them
    /// ([`RenderOptions::layers`]): a denoiser's guides for this pass's image.
    pub layers: Option<&'a AovLayers>,
}

/// Renders `job`. `progress(done, total)` is called (from worker threads) as tiles finish, in
/// units of pixel samples. The image is bit-identical for any thread count and tile order.
pub fn render(job: &RenderJob, options: &RenderOptions, progress: &(dyn Fn(u64, u64) + Sync)) -> Result<Rendered, String> {
    render_progressive(job, options, &[], progress, &mut |_| {})
}

/// Pass ends at 1, 2, 4, … samples per pixel (every power of two a `u32` holds): checkpoints for
/// [`render_progressive`] that refine the whole image, doubling its samples each pass.
pub const DOUBLING_PASSES: [u32; 32] = {
    let mut p = [0; 32];
    let mut k = 0;
    while k < 32 {
        p[k] = 1 << k;
        k += 1;
    }
    p
};

/// Renders `job` in passes: with stratified anti-aliasing, pass `k` takes each pixel up to sample
/// index `checkpoints[k]` (checkpoints beyond `spp` are ignored; the last pass always ends at
/// `spp`), and `on_pass` sees the image after each. The final image has the same bits as a
/// single-pass [`render`]. Adaptive anti-aliasing renders in one pass.
pub fn render_progressive(
    job: &RenderJob,
    options: &RenderOptions,
    checkpoints: &[u32],
    progress: &(dyn Fn(u64, u64) + Sync),
    on_pass: &mut (dyn FnMut(&Pass) + Send),
) -> Result<Rendered, String> {
    let run = || render_passes(job, options, checkpoints, progress, on_pass);
    // A pool of our own in every case: rayon's global pool has the default 2 MiB stacks, which
    // recursive integrators at their deepest allowed depth (1024 levels) overflow.
    let n = options.threads.map_or(0, |n| n.max(1));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .stack_size(RENDER_STACK_BYTES)
        .build()
        .map_err(|e| format!("cannot start {n} threads: {e}"))?;
    pool.install(run)
}

/// Stack of each render thread, bytes: address space reserved, committed only as used; enough
/// for 1024 levels of a recursive integrator (about 2 KiB a level optimised, several in debug).
pub const RENDER_STACK_BYTES: usize = 64 << 20;

/// The tiles of `bounds`: `size` squares on the frame's grid, clipped to the bounds.
fn tiles(bounds: Rect, size: u32) -> Vec<Rect> {
    let mut tiles = Vec::new();
    let first = |v: u32| v - v % size;
    for y0 in (first(bounds.y0)..bounds.y1).step_by(size as usize) {
        for x0 in (first(bounds.x0)..bounds.x1).step_by(size as usize) {
            let t = Rect { x0, y0, x1: x0 + size, y1: y0 + size };
            tiles.extend(t.intersect(&bounds));
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

/// The passes of a render over its share of the frame (the loop behind [`render_progressive`]).
/// Never inlined: profiles select the render loop by this name (`benches/peers/README.md`,
/// "Profiling").
#[inline(never)]
fn render_passes(
    job: &RenderJob,
    options: &RenderOptions,
    checkpoints: &[u32],
    progress: &(dyn Fn(u64, u64) + Sync),
    on_pass: &mut (dyn FnMut(&Pass) + Send),
) -> Result<Rendered, String> {
    let s = job.settings;
    let share = options.share.unwrap_or_else(|| Share::whole(s.width, s.height));
    let sums = starting_sums(&s, share, options)?;
    let ends = match s.aa {
        // Under a time budget the image refines doubling its samples, so it is whole at any stop.
        Antialiasing::Stratified if s.time_budget.is_some() => pass_ends(s.spp, &DOUBLING_PASSES),
        Antialiasing::Stratified => pass_ends(s.spp, checkpoints),
        Antialiasing::Adaptive(_) => vec![1],
    };
    // The clock stops the render only without a map (which repeats where it stopped before).
    let deadline = s.time_budget.filter(|_| options.spp_map.is_none());
    // Adaptive tiles are larger: the lattice points on a tile's border are traced by both tiles.
    let tiles = tiles(
        share.bounds,
        match s.aa {
            Antialiasing::Stratified => TILE_SIZE,
            Antialiasing::Adaptive(_) => ADAPTIVE_TILE_SIZE,
        },
    );
    let already: u64 = sums.pixels.iter().map(|p| u64::from(p.samples)).sum();
    let total = total_samples(&s, share, &sums, options.spp_map);
    budget::check(job, share, total - already)?;
    let counters = job.integrator.counters();
    let run = Passes {
        job,
        counters,
        options,
        progress,
        total,
        done: AtomicU64::new(already),
        traced: AtomicU64::new(0),
        over: AtomicBool::new(false),
        state: Mutex::new(State { sums, stats: RayStats::new(counters), last_snapshot: Instant::now() }),
        start: Instant::now(),
    };
    let mut complete = true;
    let mut time_stop = false;
    for (k, &end) in ends.iter().enumerate() {
        // The first pass always completes, so every pixel has a sample; later ones stop at the
        // deadline, between pixel rows.
        let stop = Stop { cancel: options.cancel, deadline: deadline.filter(|_| k > 0).map(|d| run.start + d) };
        tiles.par_iter().for_each(|&tile| run.tile(tile, end, &stop));
        let st = run.lock();
        if run.stopped() {
            complete = st.sums.complete();
            break;
        }
        if stop.now() {
            time_stop = end != *ends.last().unwrap_or(&end) || !st.sums.complete();
            break;
        }
        if end != *ends.last().unwrap_or(&end) {
            let film = st.sums.film().map_err(|e| e.to_string())?;
            let layers = st.sums.aovs().map_err(|e| e.to_string())?;
            on_pass(&Pass { film: &film, samples: end, elapsed: run.start.elapsed(), stats: st.stats, layers: layers.as_ref() });
        }
    }
    let st = run.state.into_inner().unwrap_or_else(|e| e.into_inner());
    let film = st.sums.film_parallel().map_err(|e| e.to_string())?;
    let layers = st.sums.aovs().map_err(|e| e.to_string())?;
    let elapsed = run.start.elapsed();
    if complete {
        on_pass(&Pass { film: &film, samples: *ends.last().unwrap_or(&1), elapsed, stats: st.stats, layers: layers.as_ref() });
    }
    let budget_stop = run.over.load(Ordering::Relaxed).then(|| run.traced.load(Ordering::Relaxed));
    Ok(Rendered {
        film,
        layers,
        sums: st.sums,
        stats: st.stats,
        elapsed,
        complete: complete && budget_stop.is_none(),
        budget_stop,
        time_stop,
    })
}

/// The sums a render starts from: `share` checked against the frame, then the saved state it
/// resumes, or nothing yet.
fn starting_sums(s: &RenderSettings, share: Share, options: &RenderOptions) -> Result<ShareSums, String> {
    if share.bounds.is_empty() || !share.bounds.within(&Rect::frame(s.width, s.height)) || share.passes == 0 || share.pass >= share.passes {
        return Err(format!("{} is not a share of the {}×{} frame", share.describe(), s.width, s.height));
    }
    let k = s.subpixels;
    if k != 1
        && !(k > 1
            && TILE_SIZE.is_multiple_of(k)
            && [share.bounds.x0, share.bounds.y0, share.bounds.x1, share.bounds.y1].iter().all(|v| v.is_multiple_of(k))
            && matches!(s.aa, Antialiasing::Stratified))
    {
        return Err(format!(
            "{} of the {}×{} frame is not made of whole blocks of {k} × {k} sub-pixels (stratified sampling; {}; crops and the frame's sides multiples of K)",
            share.describe(),
            s.width,
            s.height,
            crate::render::share::subpixel_rule()
        ));
    }
    if (s.target.is_some() || s.time_budget.is_some()) && share.passes > 1 {
        return Err(format!(
            "{}: with an error target or a time budget, where a pixel stops depends on all its samples so far, so its samples cannot be split into passes; split the frame by tiles or crops instead",
            share.describe()
        ));
    }
    if let Some(map) = options.spp_map {
        if s.time_budget.is_none() || !matches!(s.aa, Antialiasing::Stratified) {
            return Err(
                "a map of samples per pixel repeats a render under a time budget: give the same command, with its time budget".into()
            );
        }
        if map.len() != s.width as usize * s.height as usize {
            return Err(format!("the map of samples per pixel has {} pixels, not the {}×{} of this frame", map.len(), s.width, s.height));
        }
        if let Some((i, &m)) = map.iter().enumerate().find(|(_, m)| **m > s.spp.max(1)) {
            return Err(format!(
                "the map gives pixel ({}, {}) {m} samples, more than the {} spp this render takes at most: it is of another render",
                i % s.width as usize,
                i / s.width as usize,
                s.spp
            ));
        }
    }
    match options.resume {
        Some(r) => {
            // A state of other sampling would be continued to other counts than it says (the
            // fingerprint that should rule this out is no secret: a forged file gives any).
            if r.sampling != Sampling::of(s) {
                return Err(format!(
                    "the saved state is of a render with {}, not {} as this one",
                    r.sampling.describe(),
                    Sampling::of(s).describe()
                ));
            }
            if (r.width, r.height, r.share) != (s.width, s.height, share) || r.layers.is_some() != options.layers {
                return Err(format!(
                    "the saved state is of {} of a {}×{} frame{}, not of {} of this {}×{} frame{}",
                    r.share.describe(),
                    r.width,
                    r.height,
                    if r.layers.is_some() { " with layers" } else { "" },
                    share.describe(),
                    s.width,
                    s.height,
                    if options.layers { " with layers" } else { "" }
                ));
            }
            Ok(r.clone())
        }
        None => ShareSums::new(s, share, options.layers).map_err(|e| e.to_string()),
    }
}

/// The samples `share` has when done, counting those `sums` already holds (at most `map`'s).
fn total_samples(s: &RenderSettings, share: Share, sums: &ShareSums, map: Option<&[u32]>) -> u64 {
    match s.aa {
        // Every pixel of a stratified share wants the same samples: its total is
        // `already + Σ missing`, each pixel's `max(samples, want)`, without asking pixel by pixel.
        Antialiasing::Stratified => {
            let want = share.samples_of(Sampling::of(s), s.width, share.bounds.x0, share.bounds.y0);
            match map {
                None => sums.pixels.iter().map(|p| u64::from(p.samples.max(want))).sum(),
                Some(map) => sums
                    .pixels
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let (x, y) = share.bounds.pixel(i);
                        u64::from(p.samples.max(want.min(map[y as usize * s.width as usize + x as usize])))
                    })
                    .sum(),
            }
        }
        Antialiasing::Adaptive(_) => {
            let already: u64 = sums.pixels.iter().map(|p| u64::from(p.samples)).sum();
            already + (0..sums.pixels.len()).map(|i| u64::from(sums.missing(i))).sum::<u64>()
        }
    }
}

/// The render's state: the sums, the counters, and when the state was last handed out.
struct State {
    sums: ShareSums,
    stats: RayStats,
    last_snapshot: Instant,
}

/// A render in passes, shared by the threads that render its tiles.
struct Passes<'a> {
    job: &'a RenderJob,
    counters: &'static [Counter],
    options: &'a RenderOptions<'a>,
    progress: &'a (dyn Fn(u64, u64) + Sync),
    /// Pixel samples when done.
    total: u64,
    /// Pixel samples done.
    done: AtomicU64,
    /// Rays traced so far, against the budget.
    traced: AtomicU64,
    /// Set once a tile ran out of the budget.
    over: AtomicBool,
    state: Mutex<State>,
    start: Instant,
}

impl Passes<'_> {
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Cancelled, or over the work budget.
    fn stopped(&self) -> bool {
        self.options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) || self.over.load(Ordering::Relaxed)
    }

    /// Renders `tile` up to sample index `end` (or until `stop`) and puts it into the state
    /// (unless the budget ran out inside it), then hands the state to the tile and snapshot
    /// callbacks.
    fn tile(&self, tile: Rect, end: u32, stop: &Stop) {
        if self.stopped() || stop.now() {
            return;
        }
        let (job, options) = (self.job, self.options);
        let mut work = TileWork::take(&self.lock().sums, tile);
        let mut stats = RayStats::new(self.counters);
        stats.set_allowance(job.max_rays.saturating_sub(self.traced.load(Ordering::Relaxed)));
        let before = work.samples();
        work.render(job, end, stop, options.spp_map, &mut stats);
        let added = work.samples() - before;
        self.traced.fetch_add(stats.rays(), Ordering::Relaxed);
        let mut st = self.lock();
        st.stats += stats;
        if stats.exhausted() {
            // The budget ran out inside this tile: its last sample is cut short, so none of
            // its work is kept.
            self.over.store(true, Ordering::Relaxed);
            return;
        }
        work.put(&mut st.sums);
        if let Some(f) = options.on_tile {
            f(&TileDone { tile, sums: &st.sums, stats: &st.stats, pass_end: end, elapsed: self.start.elapsed() });
        }
        if let Some(snap) = options.snapshots
            && st.last_snapshot.elapsed() >= snap.every
        {
            (snap.write)(&st.sums);
            st.last_snapshot = Instant::now();
        }
        drop(st);
        (self.progress)(self.done.fetch_add(added, Ordering::Relaxed) + added, self.total);
    }
}

/// When a render stops: when cancelled, or at a deadline (a time budget).
struct Stop<'a> {
    cancel: Option<&'a AtomicBool>,
    deadline: Option<Instant>,
}

impl Stop<'_> {
    /// Whether the render is to stop now.
    #[inline]
    fn now(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) || self.deadline.is_some_and(|d| Instant::now() >= d)
    }
}

/// One tile's sums, taken out of the shared state while its samples are traced.
struct TileWork {
    tile: Rect,
    share: Share,
    pixels: Vec<PixelSum>,
    layers: Option<Vec<AovSum>>,
}

impl TileWork {
    fn take(sums: &ShareSums, tile: Rect) -> TileWork {
        let b = sums.share.bounds;
        let w = tile.width() as usize;
        // Row by row, each a slice copy.
        fn rows<T: Copy>(v: &[T], tile: Rect, b: Rect, w: usize) -> Vec<T> {
            let mut out = Vec::with_capacity(w * tile.height() as usize);
            for y in tile.y0..tile.y1 {
                let at = b.index(tile.x0, y);
                out.extend_from_slice(&v[at..at + w]);
            }
            out
        }
        let layers = sums.layers.as_ref().map(|l| rows(l, tile, b, w));
        TileWork { tile, share: sums.share, pixels: rows(&sums.pixels, tile, b, w), layers }
    }

    fn put(&self, sums: &mut ShareSums) {
        let b = sums.share.bounds;
        let w = self.tile.width() as usize;
        for (r, y) in (self.tile.y0..self.tile.y1).enumerate() {
            let at = b.index(self.tile.x0, y);
            sums.pixels[at..at + w].copy_from_slice(&self.pixels[r * w..(r + 1) * w]);
            if let (Some(dst), Some(src)) = (sums.layers.as_mut(), self.layers.as_ref()) {
                dst[at..at + w].copy_from_slice(&src[r * w..(r + 1) * w]);
            }
        }
    }

    fn samples(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.samples)).sum()
    }

    /// Adds the share's samples below index `end` that each pixel lacks (stratified), or
    /// computes the pixels not done yet (adaptive); stops between pixel rows when cancelled or
    /// when `stats` ran out of its allowance (the integrator stops within a sample).
    fn render(&mut self, job: &RenderJob, end: u32, stop: &Stop, map: Option<&[u32]>, stats: &mut RayStats) {
        let s = &job.settings;
        let t = self.tile;
        let mut scheme = match s.aa {
            Antialiasing::Adaptive(a) => Adaptive::new(job, a, t.x0, t.width(), self.layers.is_some()),
            Antialiasing::Stratified => return self.render_stratified(job, end, stop, map, stats),
        };
        for (i, (x, y)) in (t.y0..t.y1).flat_map(|y| (t.x0..t.x1).map(move |x| (x, y))).enumerate() {
            if x == t.x0 && (stop.now() || stats.exhausted()) {
                return;
            }
            let acc = &mut self.pixels[i];
            if acc.samples < self.share.samples_of(Sampling::of(s), s.width, x, y) {
                let v = scheme.pixel(x, y, stats);
                *acc = PixelSum::whole(v.color);
                if let Some(l) = self.layers.as_mut() {
                    l[i] = v.layers.sum();
                }
            }
        }
    }

    /// [`TileWork::render`] under stratified sampling, row by row, with what is the same for
    /// every pixel of the tile (the samples it wants, whether layers are summed) decided once;
    /// with a map of samples per pixel, each pixel wants at most its entry.
    fn render_stratified(&mut self, job: &RenderJob, end: u32, stop: &Stop, map: Option<&[u32]>, stats: &mut RayStats) {
        let s = &job.settings;
        let t = self.tile;
        let share = self.share;
        // The tile lies inside the share's bounds, where every pixel takes the same samples.
        let want = share.samples_of(Sampling::of(s), s.width, t.x0, t.y0);
        let mut pixels = StratifiedPixels { job, setup: image_setup(job), share, want, end, row_map: None };
        if s.subpixels > 1 && s.progressive() {
            return self.render_blocks(&mut pixels, stop, map, stats);
        }
        let w = t.width() as usize;
        // Camera rays in packets of 8 pixels of a row, where the scene walks them together and
        // the integrator takes their hits: one sample per pixel (an error target or a time budget
        // decides per sample, and stratified film positions are per pixel), one camera ray each.
        // With more samples per pixel, the samples of one pixel (a stratified set of film
        // positions) are the packet, 8 at a time, in order.
        let packable = !s.progressive()
            && s.target.is_none()
            && (job.scene.camera.aperture <= 0.0 || s.lens_samples <= 1)
            && job.integrator.takes_camera_hits()
            && job.scene.walks_packets();
        let packets = s.spp == 1 && packable;
        let pixel_packets = packable && pixels.setup.stratified_film();
        // A packet's rays and hits, written lane by lane as each round needs them.
        let mut scratch = PacketScratch {
            ids: [SampleId::Pixel { x: 0, y: 0, index: 0 }; PACKET],
            samples: [PreparedSample::default(); PACKET],
            rays: [Ray { origin: glam::DVec3::ZERO, dir: glam::DVec3::Z }; PACKET],
            samplers: std::array::from_fn(|_| Sampler::new(0, 0, 0)),
            hits: [crate::geometry::Hit::new(0.0, glam::DVec3::ZERO, glam::DVec3::ZERO); PACKET],
        };
        for (row, y) in (t.y0..t.y1).enumerate() {
            if stop.now() || stats.exhausted() {
                return;
            }
            pixels.row_map = map.map(|m| &m[y as usize * s.width as usize..][..s.width as usize]);
            let span = row * w..(row + 1) * w;
            if packets {
                let accs = &mut self.pixels[span.clone()];
                let mut layers = self.layers.as_mut().map(|l| &mut l[span]);
                for (c, chunk) in accs.chunks_mut(PACKET).enumerate() {
                    let at = c * PACKET;
                    let chunk_layers = layers.as_deref_mut().map(|l| &mut l[at..at + chunk.len()]);
                    pixels.add_packet_samples(t.x0 + at as u32, y, chunk, chunk_layers, &mut scratch, stats);
                }
                continue;
            }
            let row_sums = self.pixels[span.clone()].iter_mut().zip(t.x0..t.x1);
            if pixel_packets {
                let mut layers = self.layers.as_mut().map(|l| l[span].iter_mut());
                for (acc, x) in row_sums {
                    let l = layers.as_mut().and_then(|l| l.next());
                    pixels.add_packet_pixel((x, y), acc, l, &mut scratch, stats);
                }
                continue;
            }
            match self.layers.as_mut() {
                None => {
                    for (acc, x) in row_sums {
                        pixels.add_samples((x, y), acc, None, stats);
                    }
                }
                Some(layers) => {
                    for ((acc, x), l) in row_sums.zip(&mut layers[span]) {
                        pixels.add_samples((x, y), acc, Some(l), stats);
                    }
                }
            }
        }
    }
}

impl TileWork {
    /// [`TileWork::render_stratified`] on the sub-pixels of a finer grid under an error target or
    /// a time budget ([`RenderSettings::subpixels`] = `k`): block by block, the `k × k`
    /// sub-pixels of a block taken together, all to the same count, up to each count the target
    /// tests (the coarse pixel's `min_spp · 2^j` samples, `k²` times the sub-pixels') until
    /// their merged sums meet the target, or to the pass's end; a stop (the clock, a cancel) only
    /// between rows of blocks. A block's samples and where it stops depend on its own samples
    /// alone, as a pixel's do on the pixel grid.
    fn render_blocks(&mut self, pixels: &mut StratifiedPixels, stop: &Stop, map: Option<&[u32]>, stats: &mut RayStats) {
        let s = &pixels.job.settings;
        let k = s.subpixels as usize;
        let kk = s.subpixels * s.subpixels;
        let t = self.tile;
        let w = t.width() as usize;
        debug_assert!([t.x0, t.y0, t.x1, t.y1].iter().all(|v| v.is_multiple_of(s.subpixels)), "tiles hold whole blocks");
        let (want, end) = (pixels.want, pixels.end);
        pixels.row_map = None;
        for by in (0..t.height() as usize).step_by(k) {
            if stop.now() || stats.exhausted() {
                break;
            }
            for bx in (0..w).step_by(k) {
                let at = |j: usize, i: usize| (by + j) * w + bx + i;
                // A map of samples per pixel gives each sub-pixel of a block the same count.
                let cap = map.map_or(want, |m| want.min(m[(t.y0 as usize + by) * s.width as usize + t.x0 as usize + bx]));
                loop {
                    let n = self.pixels[at(0, 0)].samples;
                    let next = match s.target {
                        Some(target) => {
                            let mut merged = PixelSum::default();
                            (0..k).for_each(|j| (0..k).for_each(|i| merged.merge(&self.pixels[at(j, i)])));
                            if target.converged(&merged) {
                                break;
                            }
                            target.next_block_test(n, kk)
                        }
                        None => end,
                    }
                    .min(cap)
                    .min(end);
                    if next <= n {
                        break;
                    }
                    pixels.want = next;
                    for j in 0..k {
                        for i in 0..k {
                            let xy = (t.x0 + (bx + i) as u32, t.y0 + (by + j) as u32);
                            let l = self.layers.as_mut().map(|l| &mut l[at(j, i)]);
                            pixels.add_samples(xy, &mut self.pixels[at(j, i)], l, stats);
                        }
                    }
                }
            }
        }
        pixels.want = want;
    }
}

/// What every pixel of a tile shares in one pass of stratified sampling.
struct StratifiedPixels<'a> {
    job: &'a RenderJob,
    setup: ImageSetup,
    share: Share,
    /// The samples each pixel takes in all.
    want: u32,
    /// The pass ends at this sample index.
    end: u32,
    /// The current row's entries of a map of samples per pixel (each pixel wants at most its own).
    row_map: Option<&'a [u32]>,
}

impl StratifiedPixels<'_> {
    /// Adds the samples of pixel `xy` that the share takes below the pass's end and `acc` lacks
    /// (up to `want`) to `acc` and, when summed, to `layers`.
    #[inline(always)]
    fn add_samples(&self, (x, y): (u32, u32), acc: &mut PixelSum, mut layers: Option<&mut AovSum>, stats: &mut RayStats) {
        let (job, share) = (self.job, self.share);
        let want = self.row_map.map_or(self.want, |m| self.want.min(m[x as usize]));
        if !self.setup.stratified_film() {
            while acc.samples < want && share.sample_index(acc.samples) < self.end {
                // On sub-pixels the block decides ([`TileWork::render_blocks`]).
                if job.settings.target.is_some_and(|t| job.settings.subpixels == 1 && t.converged(acc)) {
                    break;
                }
                let index = share.sample_index(acc.samples);
                trace_sample(job, &self.setup, SampleId::Pixel { x, y, index }, acc, layers.as_deref_mut(), stats);
                acc.samples += 1;
            }
            return;
        }
        if !(acc.samples < want && share.sample_index(acc.samples) < self.end) {
            return;
        }
        // A stratified set of film positions: what the pixel's samples share (its streams' key,
        // the set's permutations and divisors) computed once, not per sample; with many samples
        // in this pass, the set's permuted columns and rows too (the same points).
        let pixel = pixel_setup(job, &self.setup, x, y);
        let points = want.min(self.end).saturating_sub(acc.samples);
        match pixel.film().tabled_pays(points).then(|| TabledSet::new(pixel.film())).flatten() {
            // The film positions of up to 8 samples at a time, as for the pixel packets.
            Some(table) => self.add_pixel_samples(&pixel, |index, _| film_points(&table, index), want, acc, layers, stats),
            None => {
                let at = |index: &[u32; PACKET], taken: usize| {
                    let mut at = [DVec2::ZERO; PACKET];
                    for (p, &i) in at.iter_mut().zip(&index[..taken]) {
                        *p = pixel.film().point(i);
                    }
                    at
                };
                self.add_pixel_samples(&pixel, at, want, acc, layers, stats)
            }
        }
    }

    /// The samples [`StratifiedPixels::add_samples`] adds to a pixel with stratified film
    /// positions, sample `index[k]` at `points(index, taken)[k]` in the pixel (for `k < taken`):
    /// the positions of up to [`PACKET`] samples computed together (the lanes past the pass's
    /// last sample repeat the first index, a valid one; an error target's stop leaves some
    /// computed and unused), then the samples traced in order, each sum the one a sample at a
    /// time makes.
    #[inline(always)]
    fn add_pixel_samples(
        &self,
        pixel: &PixelSetup,
        points: impl Fn(&[u32; PACKET], usize) -> [DVec2; PACKET],
        want: u32,
        acc: &mut PixelSum,
        mut layers: Option<&mut AovSum>,
        stats: &mut RayStats,
    ) {
        let (job, share) = (self.job, self.share);
        let wants = |n: u32| n < want && share.sample_index(n) < self.end;
        while wants(acc.samples) {
            let mut index = [share.sample_index(acc.samples); PACKET];
            let mut taken = 1;
            while taken < PACKET && wants(acc.samples + taken as u32) {
                index[taken] = share.sample_index(acc.samples + taken as u32);
                taken += 1;
            }
            let at = points(&index, taken);
            for (&index, &at) in index[..taken].iter().zip(&at) {
                if job.settings.target.is_some_and(|t| t.converged(acc)) {
                    return;
                }
                trace_pixel_sample(job, &self.setup, pixel, index, at, acc, layers.as_deref_mut(), stats);
                acc.samples += 1;
            }
        }
    }
}

impl StratifiedPixels<'_> {
    /// [`StratifiedPixels::add_samples`] for a pixel with stratified film positions, its
    /// samples' camera rays traced in packets ([`StratifiedPixels::add_pixel_packet_samples`]);
    /// the same choice of the set's points (from a table where it pays).
    fn add_packet_pixel(
        &self,
        (x, y): (u32, u32),
        acc: &mut PixelSum,
        layers: Option<&mut AovSum>,
        p: &mut PacketScratch,
        stats: &mut RayStats,
    ) {
        let (job, share) = (self.job, self.share);
        let want = self.row_map.map_or(self.want, |m| self.want.min(m[x as usize]));
        if !(acc.samples < want && share.sample_index(acc.samples) < self.end) {
            return;
        }
        let pixel = pixel_setup(job, &self.setup, x, y);
        let points = want.min(self.end).saturating_sub(acc.samples);
        match pixel.film().tabled_pays(points).then(|| TabledSet::new(pixel.film())).flatten() {
            Some(table) => {
                let at = |index: &[u32; PACKET]| film_points(&table, index);
                self.add_pixel_packet_samples(&pixel, |index| table.point(index), at, want, acc, layers, p, stats)
            }
            None => {
                let at = |index: &[u32; PACKET]| index.map(|i| pixel.film().point(i));
                self.add_pixel_packet_samples(&pixel, |index| pixel.film().point(index), at, want, acc, layers, p, stats)
            }
        }
    }

    /// [`StratifiedPixels::add_pixel_samples`] with the camera rays of up to [`PACKET`] of the
    /// pixel's samples at a time gathered and their closest hits found together
    /// ([`Intersectable::intersect_packet`]), then each sample traced in order with its hit:
    /// every sum is the one `add_pixel_samples` makes. (No error target here: it decides per
    /// sample.)
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn add_pixel_packet_samples(
        &self,
        pixel: &PixelSetup,
        point: impl Fn(u32) -> DVec2,
        points: impl Fn(&[u32; PACKET]) -> [DVec2; PACKET],
        want: u32,
        acc: &mut PixelSum,
        mut layers: Option<&mut AovSum>,
        p: &mut PacketScratch,
        stats: &mut RayStats,
    ) {
        let (job, share, setup) = (self.job, self.share, &self.setup);
        let wants = |n: u32| n < want && share.sample_index(n) < self.end;
        while wants(acc.samples) {
            // The next samples' indices (the lanes past them repeat the first, a valid index)
            // and their film positions, computed together.
            let first = share.sample_index(acc.samples);
            let mut index = [first; PACKET];
            let mut taken = 1;
            while taken < PACKET && wants(acc.samples + taken as u32) {
                index[taken] = share.sample_index(acc.samples + taken as u32);
                taken += 1;
            }
            let at = points(&index);
            let mut n = 0;
            while n < taken {
                let Some((sample, ray)) = pixel.prepare(job, setup, index[n], at[n]) else { break };
                (p.samples[n], p.rays[n]) = (sample, ray);
                n += 1;
            }
            if n == 0 {
                // A sample of several camera rays (not gathered: the render asks for packets
                // only without lens samples), traced alone.
                let index = share.sample_index(acc.samples);
                trace_pixel_sample(job, setup, pixel, index, point(index), acc, layers.as_deref_mut(), stats);
                acc.samples += 1;
                continue;
            }
            let live = (1u32 << n) - 1;
            let hits = job.scene.intersect_packet(&p.rays, live, 0.0, &[f64::INFINITY; PACKET], &mut p.hits);
            // The pixel's samples shaded together (`Integrator::radiance_packet`), in order.
            trace_pixel_packet(job, setup, pixel, &p.samples, &p.rays, (live, hits), &p.hits, acc, layers.as_deref_mut(), stats);
            acc.samples += n as u32;
        }
    }
}

/// The film positions of points `index[k]` of `table` ([`TabledSet::points`]), in the copy
/// compiled for AVX2 where the CPU has it (and `RAYLAB_SIMD` is not `baseline`): the same
/// operations on the same values, so the same bits either way.
#[inline(always)]
fn film_points(table: &TabledSet, index: &[u32; PACKET]) -> [DVec2; PACKET] {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2")]
        fn avx2(table: &TabledSet, index: &[u32; PACKET]) -> [DVec2; PACKET] {
            table.points(index)
        }
        if crate::render::accum::runs_avx2() {
            // SAFETY: `avx2` only runs AVX2 instructions, and is called only after
            // `is_x86_feature_detected!` found AVX2 on this CPU.
            return unsafe { avx2(table, index) };
        }
    }
    table.points(index)
}

/// What a packet of camera rays is gathered in (kept for a tile, so no round initialises it).
struct PacketScratch {
    ids: [SampleId; PACKET],
    samples: [PreparedSample; PACKET],
    rays: [Ray; PACKET],
    /// The streams of the rays of `ids`.
    samplers: [Sampler; PACKET],
    hits: [crate::geometry::Hit; PACKET],
}

impl StratifiedPixels<'_> {
    /// [`StratifiedPixels::add_samples`] for the pixels (`x0 + k`, `y`) of `accs` (at most
    /// [`PACKET`]) of a render without stratified film positions or an error target, their camera
    /// rays' closest hits found together ([`Intersectable::intersect_packet`]): one sample of each
    /// pixel per round, each pixel's in order, so every sum is the one `add_samples` makes.
    fn add_packet_samples(
        &self,
        x0: u32,
        y: u32,
        accs: &mut [PixelSum],
        mut layers: Option<&mut [AovSum]>,
        p: &mut PacketScratch,
        stats: &mut RayStats,
    ) {
        let (job, share, setup) = (self.job, self.share, &self.setup);
        let wants = |acc: &PixelSum, x: u32| {
            let want = self.row_map.map_or(self.want, |m| self.want.min(m[x as usize]));
            acc.samples < want && share.sample_index(acc.samples) < self.end
        };
        let mut live = 0u32;
        for (k, acc) in accs.iter().enumerate() {
            live |= u32::from(wants(acc, x0 + k as u32)) << k;
        }
        while live != 0 {
            let mut m = live;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let id = SampleId::Pixel { x: x0 + k as u32, y, index: share.sample_index(accs[k].samples) };
                match single_camera_sample(job, setup, id) {
                    Some((ray, sampler)) => (p.ids[k], p.rays[k], p.samplers[k]) = (id, ray, sampler),
                    None => {
                        trace_sample(job, setup, id, &mut accs[k], layers.as_deref_mut().map(|l| &mut l[k]), stats);
                        accs[k].samples += 1;
                        live &= !(1 << k);
                    }
                }
            }
            let hits = job.scene.intersect_packet(&p.rays, live, 0.0, &[f64::INFINITY; PACKET], &mut p.hits);
            // The block's hits shaded together (`Integrator::radiance_packet`).
            trace_packet_from(job, setup, &p.ids, (&p.rays, &mut p.samplers), (live, hits), &p.hits, accs, layers.as_deref_mut(), stats);
            let mut m = live;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let acc = &mut accs[k];
                acc.samples += 1;
                if !wants(acc, x0 + k as u32) {
                    live &= !(1 << k);
                }
            }
        }
    }
}

/// The colour of pixel (`x`, `y`) with stratified sampling: the mean of its `spp` samples
/// (non-finite samples are counted and dropped). The same bits as [`render`] gives this pixel.
pub fn render_pixel(job: &RenderJob, x: u32, y: u32, stats: &mut RayStats) -> Vec3 {
    let mut acc = PixelSum::default();
    let setup = image_setup(job);
    for index in 0..job.settings.spp {
        trace_sample(job, &setup, SampleId::Pixel { x, y, index }, &mut acc, None, stats);
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

/// The explanation of one ray of `job`'s scene (`raylab trace --ray`), with the random stream of
/// pixel (0, 0)'s first sample; `None` when the integrator cannot explain itself.
pub fn explain_ray(job: &RenderJob, ray: &crate::math::ray::Ray) -> Option<crate::render::trace::TraceNode> {
    job.integrator.explain(&job.scene, ray, &mut crate::math::sampler::Sampler::new(0, 0, job.settings.seed))
}

/// The explanation of sample `index` of pixel (`x`, `y`) (0-based, as [`pixel_samples`] lists
/// them): one ray tree per camera ray, computed as the render computed that sample, bit for bit,
/// and which sample it is. What `raylab trace --pixel X,Y --sample K` shows; an error when the
/// pixel or the sample does not exist, or the integrator cannot explain itself.
pub fn explain_pixel(
    job: &RenderJob,
    x: u32,
    y: u32,
    index: u32,
) -> Result<(Vec<crate::render::trace::TraceNode>, crate::render::explain::SampleRef), String> {
    let s = &job.settings;
    if x >= s.width || y >= s.height {
        return Err(format!("pixel ({x}, {y}) is outside the {}×{} image", s.width, s.height));
    }
    let samples = pixel_samples(job, x, y);
    let &(id, weight) = samples
        .get(index as usize)
        .ok_or_else(|| format!("sample {index}: pixel ({x}, {y}) has {} samples (0..{})", samples.len(), samples.len()))?;
    let trees = explain_sample(job, id).ok_or_else(|| format!("the integrator \"{}\" cannot explain rays", job.integrator_name))?;
    Ok((trees, crate::render::explain::SampleRef { index, of: samples.len(), id, weight }))
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
