//! The work budget ([`RenderJob::max_rays`], `--max-rays`): the most rays a render may trace,
//! enforced as rays are traced, with a bound and a measurement beforehand so that a render that
//! cannot fit stops at once instead of after the budget's worth of work.
//!
//! Before rendering ([`check`]):
//!
//! 1. **Certain**: the camera rays alone (pixels × samples × lens samples) over the budget are
//!    refused.
//! 2. **Bounded**: the integrator's [`crate::Integrator::worst_case_rays`] (for `phong`: the
//!    depth each branch can reach under the pruning threshold and the materials' coefficients,
//!    two fans only where a material both reflects and transmits) times the camera rays within
//!    the budget: the render goes ahead.
//! 3. **Measured** otherwise: a pilot traces [`PILOT_PIXELS`] pixels spread over the frame,
//!    exactly as the render would, within their share of the budget; the render goes ahead unless
//!    their cost, projected over the frame, is over the budget (then the message gives the
//!    measurement and a `--max-rays` that would hold it, when the flag can).
//!
//! While rendering, each tile may trace what is left of the budget ([`RayStats::set_allowance`]);
//! an integrator whose rays branch checks [`RayStats::exhausted`] at each hit, so not even one
//! camera ray runs away. A tile that runs out is discarded (its samples would be wrong) and the
//! render stops with the tiles done and the count ([`crate::render::Rendered::budget_stop`]).
//! Tiles already running may each use what was left when they started, so the count can pass the
//! budget by at most that much per worker thread.

use crate::render::accum::PixelSum;
use crate::render::adaptive::Adaptive;
use crate::render::job::{Antialiasing, MAX_ADAPTIVE_DEPTH, RenderJob};
use crate::render::sample::{SampleId, image_setup, trace_sample};
use crate::render::share::{Sampling, Share};
use crate::render::stats::RayStats;

/// Pixels the pilot traces: an 8 × 8 grid over the share's bounds.
pub const PILOT_PIXELS: u32 = 64;

/// What one render of `units` pixel samples (stratified: camera samples per lens point; adaptive:
/// pixels) costs in camera rays and in rays, at least and at most.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Camera rays the render certainly traces.
    pub camera_rays: f64,
    /// Camera rays it may trace (adaptive anti-aliasing: every lattice point and cell sample).
    pub max_camera_rays: f64,
    /// The integrator's most rays per camera ray.
    pub rays_per_camera_ray: f64,
}

impl Estimate {
    /// The estimate for `units` of `job`'s pixel samples (see [`Estimate`]).
    pub fn of(job: &RenderJob, units: u64) -> Estimate {
        let s = &job.settings;
        let lens = if job.scene.camera.aperture > 0.0 { f64::from(s.lens_samples.max(1)) } else { 1.0 };
        let per_unit = match s.aa {
            Antialiasing::Stratified => 1.0,
            // Every point of the 2^depth lattice of a pixel, corners included, and its cell samples.
            Antialiasing::Adaptive(a) => {
                let side = f64::from(1u32 << a.max_depth.min(MAX_ADAPTIVE_DEPTH));
                (side + 1.0).powi(2) + side * side * f64::from(a.cell_samples)
            }
        };
        let camera_rays = units as f64 * lens;
        Estimate { camera_rays, max_camera_rays: camera_rays * per_unit, rays_per_camera_ray: job.integrator.worst_case_rays(&job.scene) }
    }

    /// The most rays the render may trace.
    pub fn bound(&self) -> f64 {
        self.max_camera_rays * self.rays_per_camera_ray
    }
}

/// Checks `job`'s budget before rendering `units` pixel samples of `share` (steps 1 to 3 of the
/// module's description). An error says what was measured or counted, and what to change.
pub fn check(job: &RenderJob, share: Share, units: u64) -> Result<(), String> {
    let max = job.max_rays;
    if max == u64::MAX || units == 0 {
        return Ok(());
    }
    let e = Estimate::of(job, units);
    let knobs = knob_help(job);
    if e.camera_rays > max as f64 {
        let need = e.camera_rays.ceil();
        return Err(format!(
            "the render traces at least {need:.0} camera rays ({} {}), over the work budget of {max} rays; {}",
            units,
            unit_name(job),
            match flag_value(need) {
                Some(v) => format!("raise it with --max-rays {v} or more, or {knobs}"),
                None => knobs,
            }
        ));
    }
    if !(e.bound() > max as f64) {
        return Ok(());
    }
    let Some(pilot) = pilot(job, share, units) else { return Ok(()) };
    if pilot.units >= units {
        // The pilot would be the whole render: the render itself measures, and stops at the budget.
        return Ok(());
    }
    let projected = pilot.rays as f64 / pilot.units_done.max(1) as f64 * units as f64;
    if !pilot.exhausted && projected <= max as f64 {
        return Ok(());
    }
    let measured = format!(
        "a pilot of {} pixel{} spread over the frame traced {} rays for {} of the render's {units} {}",
        pilot.pixels_done,
        if pilot.pixels_done == 1 { "" } else { "s" },
        pilot.rays,
        pilot.units_done,
        unit_name(job)
    );
    if pilot.exhausted {
        // Stopped within its share: the projection is a lower bound.
        let at_least = (pilot.allowance as f64 / pilot.units as f64 * units as f64).max(projected);
        return Err(format!(
            "{measured} and ran out of its share of the work budget ({} rays): the render would trace more than {at_least:.3e} rays, over the budget of {max}; {knobs}{}",
            pilot.allowance,
            match flag_value(at_least * 2.0) {
                Some(v) => format!(", or raise the budget with --max-rays (more than {v}) if it should finish"),
                None => String::new(),
            }
        ));
    }
    Err(format!(
        "{measured}: the render would trace about {projected:.3e} rays, over the work budget of {max}; {}",
        match flag_value(projected * 1.25) {
            Some(v) => format!("raise it with --max-rays {v}, or {knobs}"),
            None => knobs,
        }
    ))
}

/// What the units of [`check`] are.
fn unit_name(job: &RenderJob) -> &'static str {
    match job.settings.aa {
        Antialiasing::Stratified => "pixel samples",
        Antialiasing::Adaptive(_) => "pixels",
    }
}

/// The advice that holds whatever the flag can: the knobs that multiply rays.
fn knob_help(job: &RenderJob) -> String {
    let d = job.integrator.describe();
    format!(
        "lower the knobs that multiply rays (--spp, --depth, the image size, or the integrator's, e.g. --set prune_threshold=0.001; integrator \"{}\"{})",
        job.integrator_name,
        if d.is_empty() { String::new() } else { format!(": {d}") }
    )
}

/// `rays` rounded up as a `--max-rays` value, when the flag accepts it (at most `u64::MAX`).
pub fn flag_value(rays: f64) -> Option<u64> {
    let v = rays.ceil();
    (v.is_finite() && v >= 0.0 && v < u64::MAX as f64).then_some(v as u64)
}

/// What a pilot measured.
struct Pilot {
    /// Pixel samples of the pilot's pixels (all of them) and of those it finished.
    units: u64,
    units_done: u64,
    pixels_done: u32,
    /// Rays traced (those of an unfinished pixel included).
    rays: u64,
    /// The pilot's share of the budget, and whether it ran out of it.
    allowance: u64,
    exhausted: bool,
}

/// Traces up to [`PILOT_PIXELS`] pixels of `share` on a grid, each exactly as the render would
/// (its samples in this share, or its adaptive lattice), within their share of the budget:
/// `max_rays × pilot units / units`. `None` when the share has no pixel.
fn pilot(job: &RenderJob, share: Share, units: u64) -> Option<Pilot> {
    let s = &job.settings;
    let b = share.bounds;
    if b.is_empty() {
        return None;
    }
    let side = (PILOT_PIXELS as f64).sqrt() as u32;
    let mut pixels: Vec<(u32, u32)> = Vec::new();
    for j in 0..side {
        for i in 0..side {
            let x = b.x0 + ((2 * i + 1) * b.width()) / (2 * side);
            let y = b.y0 + ((2 * j + 1) * b.height()) / (2 * side);
            if !pixels.contains(&(x, y)) {
                pixels.push((x, y));
            }
        }
    }
    let units_of = |x: u32, y: u32| match s.aa {
        Antialiasing::Stratified => u64::from(share.samples_of(Sampling::of(s), s.width, x, y)),
        Antialiasing::Adaptive(_) => 1,
    };
    let total: u64 = pixels.iter().map(|&(x, y)| units_of(x, y)).sum();
    let allowance = (job.max_rays as f64 * total as f64 / units as f64).min(u64::MAX as f64) as u64;
    let mut stats = RayStats::new(job.integrator.counters());
    stats.set_allowance(allowance);
    let mut p = Pilot { units: total, units_done: 0, pixels_done: 0, rays: 0, allowance, exhausted: false };
    let setup = image_setup(job);
    'pixels: for &(x, y) in &pixels {
        match s.aa {
            Antialiasing::Stratified => {
                let mut acc = PixelSum::default();
                for k in 0..share.samples_of(Sampling::of(s), s.width, x, y) {
                    trace_sample(job, &setup, SampleId::Pixel { x, y, index: share.sample_index(k) }, &mut acc, None, &mut stats);
                    if stats.exhausted() {
                        break 'pixels;
                    }
                }
            }
            Antialiasing::Adaptive(a) => {
                Adaptive::new(job, a, x, 1, false).pixel(x, y, &mut stats);
                if stats.exhausted() {
                    break 'pixels;
                }
            }
        }
        p.units_done += units_of(x, y);
        p.pixels_done += 1;
    }
    p.rays = stats.rays();
    p.exhausted = stats.exhausted();
    Some(p)
}
