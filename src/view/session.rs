//! The live view's render session: loads the scene with the page's settings, renders it on a
//! worker thread (a coarse preview, then the frame in passes, tile by tile), keeps the displayed
//! pixels and the status the page polls, and starts again when a setting or the scene file
//! changes (cancelling the render under way).
//!
//! Once the frame has the scene's own samples (the image `raylab render` writes), the view keeps
//! **refining**, whatever the integrator: it renders the frame again with samples that
//! accumulate pass after pass (1, 2, 4, … per pixel, at points of a sequence whose every such
//! prefix is stratified, as an error target's are), and a pass replaces the image on screen once
//! it has more samples per pixel than the scene's render spent. It goes on until every pixel
//! meets the error target (the scene's or the page's; without one, until a pixel's samples all
//! agree exactly), [`REFINE_MAX_SPP`], the work budget (`--max-rays`), the page's Stop button or
//! a restart. When the scene's render already sampled that sequence (an error target and more
//! than one sample per pixel), refining continues its sums instead of starting again.

use super::knobs::{self, Knob, Settings};
use crate::load::context::LoadOptions;
use crate::load::registry::Registry;
use crate::param::error::{Location, SceneError};
use crate::render::film::Film;
use crate::render::job::{Antialiasing, ErrorTarget, RenderJob, TILE_SIZE};
use crate::render::share::{Rect, Sampling, ShareSums};
use crate::render::{Pass, RenderOptions, TileDone};
use serde::Serialize;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock};
use std::time::{Duration, SystemTime};

/// Where the scene comes from.
pub enum SceneSource {
    /// A scene file, watched for changes.
    File(PathBuf),
    /// A scene built into the binary (its display name and TOML text).
    Bundled {
        /// The name errors use.
        name: &'static str,
        /// The TOML text.
        text: &'static str,
    },
}

impl SceneSource {
    /// The name shown on the page.
    pub fn name(&self) -> String {
        match self {
            SceneSource::File(p) => p.display().to_string(),
            SceneSource::Bundled { name, .. } => format!("{name} (bundled)"),
        }
    }

    /// The file's modification time and size, to notice a save (`None` for a bundled scene or
    /// an unreadable file).
    fn stamp(&self) -> Option<(SystemTime, u64)> {
        match self {
            SceneSource::File(p) => std::fs::metadata(p).ok().and_then(|m| Some((m.modified().ok()?, m.len()))),
            SceneSource::Bundled { .. } => None,
        }
    }
}

/// How often the scene file's modification time is looked at.
const WATCH_INTERVAL: Duration = Duration::from_millis(400);

/// The preview's pixels are this many of the frame's on a side (a 1/64 of the work).
const PREVIEW_FACTOR: u32 = 8;

/// Refining stops at this many samples per pixel (a 16th of a second of work per pixel at a
/// million samples a second: past it, only a stop button would end the render).
pub const REFINE_MAX_SPP: u32 = 1 << 16;

/// Without an error target, refining first tests a pixel at this many samples, then at each
/// doubling: a pixel whose samples all agree exactly (the background, an evenly lit wall) stops.
const REFINE_MIN_SPP: u32 = 16;

/// What the session is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// Reading and building the scene.
    Loading,
    /// The coarse preview.
    Preview,
    /// The frame, in passes, to the scene's samples.
    Rendering,
    /// More samples than the scene's, pass after pass, until a target, a limit or a stop.
    Refining,
    /// Nothing more will be rendered ([`Status::ended`] says why).
    Done,
    /// The scene or a setting is in error; the last good image stays.
    Error,
}

/// An error for the page: the message, where it is, and the full report (with the line and a caret).
#[derive(Clone, Debug, Serialize)]
pub struct ErrorInfo {
    /// What is wrong.
    pub message: String,
    /// The file (or flag, or control) at fault, when known.
    pub file: Option<String>,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// 1-based column, when known.
    pub column: Option<usize>,
    /// The report as the command line prints it.
    pub report: String,
}

impl ErrorInfo {
    /// The page's view of a scene error.
    pub fn of(e: &SceneError) -> Self {
        let (file, line, column) = match &e.location {
            Location::None => (None, None, None),
            Location::File { path, line_col } => (Some(path.clone()), line_col.map(|l| l.0), line_col.map(|l| l.1)),
            Location::Span(loc) => {
                let (l, c) = loc.source.line_col(loc.start);
                (Some(loc.source.name.clone()), Some(l), Some(c))
            }
        };
        ErrorInfo { message: e.message.clone(), file, line, column, report: e.report() }
    }

    /// An error with no location.
    pub fn plain(message: impl Into<String>) -> Self {
        let message = message.into();
        ErrorInfo { report: message.clone(), message, file: None, line: None, column: None }
    }
}

/// The render's progress, as the page shows it.
#[derive(Clone, Debug, Serialize)]
pub struct Status {
    /// What is happening.
    pub phase: Phase,
    /// Renders started so far (each restart is a new generation).
    pub generation: u64,
    /// The scene's name.
    pub scene: String,
    /// Why the current render started (`start`, `settings`, `scene file changed`).
    pub reason: String,
    /// The sampling, in words (`adaptive AA (threshold 0.05, depth 3)`).
    pub sampling: String,
    /// The integrator and its settings, in words.
    pub integrator: String,
    /// Samples per pixel so far and in all (stratified), or 1 of 1 (adaptive); while refining,
    /// those of the image shown and [`REFINE_MAX_SPP`].
    pub samples: [u32; 2],
    /// Why the render ended (phase `done`), in words.
    pub ended: Option<String>,
    /// Fraction of the frame's work done, 0..1.
    pub progress: f64,
    /// Seconds of tracing so far.
    pub seconds: f64,
    /// Rays traced so far.
    pub rays: u64,
    /// Rays per second of tracing.
    pub rays_per_second: f64,
    /// Whether the image shown is denoised (the page's Denoise control).
    pub denoised: bool,
    /// Why the last load failed.
    pub error: Option<ErrorInfo>,
    /// What loading ignored or approximated.
    pub warnings: Vec<String>,
}

/// The displayed pixels: 8-bit RGBA, encoded as the scene's 8-bit output is; alpha 0 where
/// nothing is known yet. Each 16×16 tile remembers the update that last changed it.
pub struct Frame {
    /// Changes when the size does (the page then takes the whole frame).
    pub id: u64,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `width × height × 4` bytes, row by row.
    pub rgba: Vec<u8>,
    /// Per tile (row by row), the update number of its last change.
    pub tile_seq: Vec<u64>,
}

impl Frame {
    fn tiles_x(&self) -> u32 {
        self.width.div_ceil(TILE_SIZE)
    }

    /// The tiles changed after update `seq`, as rectangles.
    pub fn changed_since(&self, seq: u64) -> Vec<Rect> {
        let tx = self.tiles_x();
        (0..self.tile_seq.len())
            .filter(|&i| self.tile_seq[i] > seq)
            .map(|i| {
                let (x0, y0) = ((i as u32 % tx) * TILE_SIZE, (i as u32 / tx) * TILE_SIZE);
                Rect { x0, y0, x1: (x0 + TILE_SIZE).min(self.width), y1: (y0 + TILE_SIZE).min(self.height) }
            })
            .collect()
    }

    /// Marks the tiles `r` overlaps as changed by update `seq`.
    fn touch(&mut self, r: Rect, seq: u64) {
        let tx = self.tiles_x();
        for ty in r.y0 / TILE_SIZE..r.y1.div_ceil(TILE_SIZE) {
            for t in r.x0 / TILE_SIZE..r.x1.div_ceil(TILE_SIZE) {
                self.tile_seq[(ty * tx + t) as usize] = seq;
            }
        }
    }

    /// The RGBA bytes of `r`, row by row.
    pub fn bytes_of(&self, r: Rect, out: &mut Vec<u8>) {
        for y in r.y0..r.y1 {
            let at = 4 * (y as usize * self.width as usize + r.x0 as usize);
            out.extend_from_slice(&self.rgba[at..at + 4 * r.width() as usize]);
        }
    }
}

/// What the page polls, under one lock.
pub struct State {
    /// The page's settings (over the command line's).
    pub settings: Settings,
    /// Restarts asked for (by the page or the file watcher).
    requested: u64,
    /// Why the last restart was asked for.
    reason: String,
    /// Set to stop the render under way.
    cancel: Arc<AtomicBool>,
    /// The page asked to stop (the render under way is cancelled, and nothing starts again).
    stop: bool,
    /// Progress and errors.
    pub status: Status,
    /// The displayed pixels.
    pub frame: Option<Frame>,
    /// The job of the displayed render, for explanations.
    pub job: Option<Arc<RenderJob>>,
    /// The controls, with the values of the current render.
    pub knobs: Vec<Knob>,
    /// Bumps when the controls change.
    pub knobs_version: u64,
    /// The finished image (when the phase is done).
    pub film: Option<Film>,
    /// Bumps on every change; pollers wait for it to pass what they saw.
    pub version: u64,
    /// Update counter for the frame's tiles.
    seq: u64,
    frames: u64,
}

/// What refining continues from: the scene's render.
struct First {
    sums: ShareSums,
    rays: u64,
    camera_rays: u64,
    elapsed: Duration,
}

/// A live render session: the scene, the base options from the command line, and the state.
pub struct Session {
    registry: Registry,
    source: SceneSource,
    base: LoadOptions,
    threads: Option<usize>,
    /// Whether to keep refining after the scene's samples (see the module's description).
    refine: AtomicBool,
    /// The denoiser's tool, or why there is none (looked for once, when first needed).
    denoiser: OnceLock<Result<PathBuf, String>>,
    state: Mutex<State>,
    changed: Condvar,
}

impl Session {
    /// A session for `source`, loaded with `base` (the command line's options) and the page's
    /// settings over them, rendering on `threads` threads (all cores when `None`).
    pub fn new(registry: Registry, source: SceneSource, base: LoadOptions, threads: Option<usize>) -> Arc<Session> {
        let status = Status {
            phase: Phase::Loading,
            generation: 0,
            scene: source.name(),
            reason: "start".into(),
            sampling: String::new(),
            integrator: String::new(),
            samples: [0, 0],
            ended: None,
            progress: 0.0,
            seconds: 0.0,
            rays: 0,
            rays_per_second: 0.0,
            denoised: false,
            error: None,
            warnings: Vec::new(),
        };
        Arc::new(Session {
            registry,
            source,
            base,
            threads,
            refine: AtomicBool::new(true),
            denoiser: OnceLock::new(),
            state: Mutex::new(State {
                settings: Settings::default(),
                requested: 1,
                reason: "start".into(),
                cancel: Arc::new(AtomicBool::new(false)),
                stop: false,
                status,
                frame: None,
                job: None,
                knobs: Vec::new(),
                knobs_version: 0,
                film: None,
                version: 1,
                seq: 0,
                frames: 0,
            }),
            changed: Condvar::new(),
        })
    }

    /// Whether to keep refining after the scene's own samples (on unless turned off, as
    /// `raylab view --no-refine` does).
    pub fn set_refine(&self, on: bool) {
        self.refine.store(on, Ordering::Relaxed);
    }

    /// Stops the render under way, keeping the image shown (the page's Stop button); a setting
    /// or a save of the scene file starts again.
    pub fn stop(&self) {
        let mut st = self.lock();
        if st.status.phase != Phase::Done && st.status.phase != Phase::Error {
            st.stop = true;
            st.cancel.store(true, Ordering::Relaxed);
            self.bump(&mut st);
        }
    }

    /// Ends the render: nothing more comes (the page's Save PNG takes `film` when given, else
    /// the image it had).
    fn finish(&self, st: &mut State, film: Option<Film>, why: String) {
        st.status.phase = Phase::Done;
        st.status.ended = Some(why);
        st.status.progress = 1.0;
        if film.is_some() {
            st.film = film;
        }
        self.bump(st);
    }

    /// The scene's name, as the page shows it.
    pub fn scene_name(&self) -> String {
        self.source.name()
    }

    /// The state, locked.
    pub fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits until the state's version passes `seen` or `timeout` elapses; returns the state.
    pub fn wait_for_change(&self, seen: u64, timeout: Duration) -> MutexGuard<'_, State> {
        let st = self.lock();
        let (st, _) = self.changed.wait_timeout_while(st, timeout, |s| s.version <= seen).unwrap_or_else(|e| e.into_inner());
        st
    }

    fn bump(&self, st: &mut State) {
        st.version += 1;
        self.changed.notify_all();
    }

    /// Replaces the page's settings and starts the render again.
    pub fn apply(&self, settings: Settings) {
        let mut st = self.lock();
        st.settings = settings;
        self.restart(&mut st, "settings");
    }

    fn restart(&self, st: &mut State, reason: &str) {
        st.requested += 1;
        st.reason = reason.into();
        st.cancel.store(true, Ordering::Relaxed);
        self.bump(st);
    }

    /// Starts the worker threads: the renderer and (for a scene file) the watcher.
    pub fn start(self: &Arc<Self>) {
        let s = self.clone();
        std::thread::Builder::new().name("raylab-view-render".into()).spawn(move || s.render_loop()).expect("spawning the render thread");
        if matches!(self.source, SceneSource::File(_)) {
            let s = self.clone();
            std::thread::Builder::new().name("raylab-view-watch".into()).spawn(move || s.watch()).expect("spawning the watcher thread");
        }
    }

    /// Polls the scene file's modification time and size; a change restarts the render.
    fn watch(&self) {
        let mut last = self.source.stamp();
        loop {
            std::thread::sleep(WATCH_INTERVAL);
            let now = self.source.stamp();
            if now != last {
                last = now;
                let mut st = self.lock();
                self.restart(&mut st, "scene file changed");
            }
        }
    }

    fn render_loop(&self) {
        let mut handled = 0;
        loop {
            let (settings, cancel) = {
                let mut st = self.lock();
                while st.requested == handled {
                    st = self.changed.wait(st).unwrap_or_else(|e| e.into_inner());
                }
                handled = st.requested;
                let cancel = Arc::new(AtomicBool::new(false));
                st.cancel = cancel.clone();
                st.status.generation += 1;
                st.status.phase = Phase::Loading;
                st.status.reason = st.reason.clone();
                st.status.error = None;
                st.status.ended = None;
                st.stop = false;
                st.film = None;
                self.bump(&mut st);
                (st.settings.clone(), cancel)
            };
            if let Err(e) = self.render_once(&settings, &cancel) {
                let mut st = self.lock();
                st.status.phase = Phase::Error;
                st.status.error = Some(e);
                self.bump(&mut st);
            }
        }
    }

    /// Loads the scene with `settings` and renders it until done or cancelled.
    fn render_once(&self, settings: &Settings, cancel: &AtomicBool) -> Result<(), ErrorInfo> {
        let (job, knobs) = self.load(settings).map_err(|e| ErrorInfo::of(&e))?;
        let denoise = settings.denoise == Some(true);
        if denoise && let Err(why) = self.denoiser() {
            return Err(ErrorInfo::plain(format!("page control \"denoise\": {why}")));
        }
        let mut job = job;
        let s = job.settings;
        let threads = self.threads;
        {
            let mut st = self.lock();
            st.status.sampling = s.describe_sampling();
            st.status.integrator = format!("{} {}", job.integrator_name, job.integrator.describe()).trim().to_string();
            st.status.warnings = job.warnings.iter().map(|w| w.report()).collect();
            st.status.samples = [0, if matches!(s.aa, Antialiasing::Stratified) { s.spp } else { 1 }];
            st.status.progress = 0.0;
            st.status.seconds = 0.0;
            st.status.rays = 0;
            st.status.rays_per_second = 0.0;
            st.status.denoised = false;
            st.knobs = knobs;
            st.knobs_version += 1;
            let same = st.frame.as_ref().is_some_and(|f| (f.width, f.height) == (s.width, s.height));
            if !same {
                st.frames += 1;
                let n = s.width as usize * s.height as usize;
                let tiles = (s.width.div_ceil(TILE_SIZE) * s.height.div_ceil(TILE_SIZE)) as usize;
                st.frame = Some(Frame { id: st.frames, width: s.width, height: s.height, rgba: vec![0; 4 * n], tile_seq: vec![0; tiles] });
            }
            st.status.phase = Phase::Preview;
            self.bump(&mut st);
        }

        // A coarse preview: the same scene at 1/PREVIEW_FACTOR of the size, one sample per pixel.
        let (pw, ph) = (s.width.div_ceil(PREVIEW_FACTOR), s.height.div_ceil(PREVIEW_FACTOR));
        job.settings = crate::render::RenderSettings {
            width: pw,
            height: ph,
            spp: 1,
            aa: Antialiasing::Stratified,
            lens_samples: 1,
            target: None,
            ..s
        };
        let preview = crate::render::render(&job, &RenderOptions { threads, cancel: Some(cancel), ..RenderOptions::default() }, &|_, _| {});
        job.settings = s;
        if cancel.load(Ordering::Relaxed) {
            self.on_cancel(None, "during the preview");
            return Ok(());
        }
        if let Ok(p) = preview {
            let mut st = self.lock();
            st.seq += 1;
            let seq = st.seq;
            if let Some(f) = st.frame.as_mut() {
                for y in 0..s.height {
                    for x in 0..s.width {
                        // In u64: `x · pw` passes u32 for widths a raised --max-side allows.
                        let scale = |v: u32, part: u32, whole: u32| (u64::from(v) * u64::from(part) / u64::from(whole)) as u32;
                        let c = p.film.get(scale(x, pw, s.width), scale(y, ph, s.height));
                        let at = 4 * (y as usize * s.width as usize + x as usize);
                        f.rgba[at..at + 4].copy_from_slice(&[s.encoding.to_u8(c.x), s.encoding.to_u8(c.y), s.encoding.to_u8(c.z), 255]);
                    }
                }
                f.touch(Rect::frame(s.width, s.height), seq);
            }
            self.bump(&mut st);
        }

        // Denoised, on the finer grid `raylab render --denoise` uses where the samples divide
        // evenly (`denoise::grid`): the scene's samples on `grid × grid` sub-pixels, denoised
        // there and averaged back over each pixel. Its tiles are of sub-pixels, so the image is
        // shown once denoised, and pixels are explained once it is done.
        let grid = if denoise { crate::image::denoise::grid(&s) } else { 1 };
        if grid > 1 {
            job.settings = crate::image::denoise::fine_settings(&s, grid);
        }
        // The frame, in passes of 1, 2, 4, … samples per pixel, each tile shown as it finishes.
        let job = Arc::new(job);
        {
            let mut st = self.lock();
            st.job = if grid > 1 { None } else { Some(job.clone()) };
            st.status.phase = Phase::Rendering;
            self.bump(&mut st);
        }
        let work = [AtomicU64::new(0), AtomicU64::new(1)];
        let on_tile = |t: &TileDone| {
            let mut st = self.lock();
            if grid == 1 {
                self.show_tile(&mut st, t, &s);
            }
            let secs = t.elapsed.as_secs_f64();
            let rays = t.stats.total_rays();
            st.status.seconds = secs;
            st.status.rays = rays;
            st.status.rays_per_second = if secs > 0.0 { rays as f64 / secs } else { 0.0 };
            st.status.samples[0] = t.pass_end.saturating_mul(grid * grid).min(st.status.samples[1]);
            st.status.progress = work[0].load(Ordering::Relaxed) as f64 / work[1].load(Ordering::Relaxed).max(1) as f64;
            self.bump(&mut st);
        };
        let options = RenderOptions { threads, cancel: Some(cancel), on_tile: Some(&on_tile), layers: denoise, ..RenderOptions::default() };
        let rendered = crate::render::render_progressive(
            &job,
            &options,
            &crate::render::DOUBLING_PASSES,
            &|done, total| {
                work[0].fetch_max(done, Ordering::Relaxed);
                work[1].store(total.max(1), Ordering::Relaxed);
            },
            &mut |_| {},
        )
        .map_err(ErrorInfo::plain)?;
        let mut rendered = rendered;
        let job = if grid > 1 {
            // The job at the frame's pixels again, for explaining them (no one else holds it).
            let mut job = Arc::try_unwrap(job).map_err(|_| ErrorInfo::plain("the render's job is still in use".to_string()))?;
            job.settings = s;
            let job = Arc::new(job);
            self.lock().job = Some(job.clone());
            job
        } else {
            job
        };
        let undenoised = |film: Film| if grid > 1 { crate::image::denoise::box_down(&film, grid).ok() } else { Some(film) };
        if cancel.load(Ordering::Relaxed) {
            self.on_cancel(undenoised(rendered.film), "before the scene's samples were done");
            return Ok(());
        }
        // The finished image denoised whole, as `raylab render --denoise` writes it.
        let clean = crate::image::denoise::guides_are_clean(&job);
        let denoised = if denoise && rendered.budget_stop.is_none() {
            if grid > 1 {
                // The film, sums and layers are the frame's pixels' from here.
                crate::image::denoise::denoise_rendered(&mut rendered, &s, grid, clean).map_err(ErrorInfo::plain)?;
                Some(rendered.film.clone())
            } else {
                Some(crate::image::denoise::denoise_guided(&rendered.film, rendered.layers.as_ref(), clean).map_err(ErrorInfo::plain)?)
            }
        } else {
            if grid > 1 {
                rendered.film =
                    undenoised(rendered.film).ok_or_else(|| ErrorInfo::plain("the sub-pixels do not tile the frame".to_string()))?;
            }
            None
        };
        let mut st = self.lock();
        let secs = rendered.elapsed.as_secs_f64();
        st.status.seconds = secs;
        st.status.rays = rendered.stats.total_rays();
        st.status.rays_per_second = if secs > 0.0 { st.status.rays as f64 / secs } else { 0.0 };
        if let Some(rays) = rendered.budget_stop {
            let why = format!("the work budget stopped the render after {rays} rays (--max-rays)");
            self.finish(&mut st, Some(rendered.film), why);
            return Ok(());
        }
        st.status.samples[0] = st.status.samples[1];
        st.film = Some(match denoised {
            Some(d) => {
                self.show_film(&mut st, &d, &s);
                st.status.denoised = true;
                d
            }
            None => rendered.film,
        });
        if !self.refine.load(Ordering::Relaxed) {
            self.finish(&mut st, None, "at the scene's samples (--no-refine)".into());
            return Ok(());
        }
        st.status.phase = Phase::Refining;
        st.status.progress = 0.0;
        self.bump(&mut st);
        drop(st);
        let first = First {
            sums: rendered.sums,
            rays: rendered.stats.total_rays(),
            camera_rays: rendered.stats.camera_rays,
            elapsed: rendered.elapsed,
        };
        self.refine(settings, &s, first, cancel)
    }

    /// The denoiser's tool, or why there is none.
    fn denoiser(&self) -> Result<&PathBuf, &str> {
        self.denoiser.get_or_init(crate::image::denoise::find_tool).as_ref().map_err(String::as_str)
    }

    /// Draws a whole image (a denoised one) into the frame shown.
    fn show_film(&self, st: &mut State, film: &Film, s: &crate::render::RenderSettings) {
        st.seq += 1;
        let seq = st.seq;
        if let Some(f) = st.frame.as_mut()
            && (f.width, f.height) == (film.width, film.height)
        {
            for (i, c) in film.pixels.iter().enumerate() {
                f.rgba[4 * i..4 * i + 4].copy_from_slice(&[s.encoding.to_u8(c.x), s.encoding.to_u8(c.y), s.encoding.to_u8(c.z), 255]);
            }
            f.touch(Rect::frame(f.width, f.height), seq);
        }
    }

    /// Draws the pixels of a finished tile into the frame shown.
    fn show_tile(&self, st: &mut State, t: &TileDone, s: &crate::render::RenderSettings) {
        st.seq += 1;
        let seq = st.seq;
        if let Some(f) = st.frame.as_mut() {
            let b = t.sums.share.bounds;
            for y in t.tile.y0..t.tile.y1 {
                for x in t.tile.x0..t.tile.x1 {
                    let p = &t.sums.pixels[b.index(x, y)];
                    if p.samples == 0 {
                        continue;
                    }
                    let c = p.mean().as_vec3();
                    let at = 4 * (y as usize * f.width as usize + x as usize);
                    f.rgba[at..at + 4].copy_from_slice(&[s.encoding.to_u8(c.x), s.encoding.to_u8(c.y), s.encoding.to_u8(c.z), 255]);
                }
            }
            f.touch(t.tile, seq);
        }
    }

    /// After `cancel` was set: a stop from the page ends the render with `film` (the image so
    /// far, when given); otherwise a restart is under way and the state is left to it.
    fn on_cancel(&self, film: Option<Film>, when: &str) {
        let mut st = self.lock();
        if st.stop {
            self.finish(&mut st, film, format!("stopped {when}"));
        }
    }

    /// Keeps refining the frame after the scene's own samples (`s`, rendered as `first`): see
    /// the module's description.
    fn refine(&self, settings: &Settings, s: &crate::render::RenderSettings, first: First, cancel: &AtomicBool) -> Result<(), ErrorInfo> {
        let stratified = matches!(s.aa, Antialiasing::Stratified);
        let denoise = settings.denoise == Some(true);
        let target = s.target.unwrap_or(ErrorTarget { error: 0.0, min_spp: REFINE_MIN_SPP });
        if s.target.is_some() && first.sums.pixels.iter().all(|p| target.converged(p)) {
            let mut st = self.lock();
            self.finish(&mut st, None, "every pixel met the error target".into());
            return Ok(());
        }
        if stratified && s.spp >= REFINE_MAX_SPP {
            let mut st = self.lock();
            self.finish(&mut st, None, format!("the scene's {} samples per pixel, the most the view refines to", s.spp));
            return Ok(());
        }
        // A second job: the displayed render's stays, for explaining pixels as `raylab trace` does.
        let (mut job, _) = self.load(settings).map_err(|e| ErrorInfo::of(&e))?;
        job.settings = crate::render::RenderSettings { aa: Antialiasing::Stratified, spp: REFINE_MAX_SPP, target: Some(target), ..*s };
        // The budget is the whole session's, counted here as tiles finish (the render's own
        // estimate before it starts would refuse any open-ended refinement).
        let budget = job.max_rays;
        job.max_rays = u64::MAX;
        let clean_guides = crate::image::denoise::guides_are_clean(&job);
        // Samples per pixel of the image shown; a refined pass is drawn once it has more.
        let pixels = u64::from(s.width) * u64::from(s.height);
        let shown = if stratified {
            s.spp
        } else {
            let lens = if job.scene.camera.aperture > 0.0 { u64::from(s.lens_samples.max(1)) } else { 1 };
            let per_pixel = first.camera_rays.div_ceil((pixels * lens).max(1)).max(1);
            u32::try_from(per_pixel).unwrap_or(u32::MAX).checked_next_power_of_two().unwrap_or(REFINE_MAX_SPP)
        };
        {
            let mut st = self.lock();
            st.status.samples = [shown, REFINE_MAX_SPP];
            self.bump(&mut st);
        }
        // The scene's own samples are the sequence's first ones when it had an error target.
        let reuse = stratified && s.target.is_some() && s.spp > 1;
        let (resume, floor) = if reuse {
            let mut sums = first.sums;
            sums.sampling = Sampling::of(&job.settings);
            (Some(sums), 0)
        } else {
            (None, shown)
        };
        let tiles = u64::from(s.width.div_ceil(TILE_SIZE) * s.height.div_ceil(TILE_SIZE));
        let (pass, tiles_done, over) = (AtomicU32::new(0), AtomicU64::new(0), AtomicBool::new(false));
        let on_tile = |t: &TileDone| {
            if pass.swap(t.pass_end, Ordering::Relaxed) != t.pass_end {
                tiles_done.store(0, Ordering::Relaxed);
            }
            let done = tiles_done.fetch_add(1, Ordering::Relaxed) + 1;
            let mut st = self.lock();
            // Denoised, a pass is shown whole once it is done (a denoiser never sees a tile).
            if t.pass_end > floor && !denoise {
                self.show_tile(&mut st, t, s);
            }
            let secs = (first.elapsed + t.elapsed).as_secs_f64();
            let rays = first.rays + t.stats.total_rays();
            st.status.seconds = secs;
            st.status.rays = rays;
            st.status.rays_per_second = if secs > 0.0 { rays as f64 / secs } else { 0.0 };
            st.status.progress = done as f64 / tiles.max(1) as f64;
            self.bump(&mut st);
            if rays >= budget {
                over.store(true, Ordering::Relaxed);
                cancel.store(true, Ordering::Relaxed);
            }
        };
        let failed: Mutex<Option<String>> = Mutex::new(None);
        let mut on_pass = |p: &Pass| {
            if p.samples > floor {
                let film = if denoise {
                    match crate::image::denoise::denoise_guided(p.film, p.layers, clean_guides) {
                        Ok(d) => d,
                        Err(e) => {
                            *failed.lock().unwrap_or_else(|e| e.into_inner()) = Some(e);
                            cancel.store(true, Ordering::Relaxed);
                            return;
                        }
                    }
                } else {
                    p.film.clone()
                };
                let mut st = self.lock();
                st.status.samples = [p.samples, REFINE_MAX_SPP];
                if denoise {
                    self.show_film(&mut st, &film, s);
                    st.status.denoised = true;
                }
                st.film = Some(film);
                self.bump(&mut st);
            }
        };
        let options = RenderOptions {
            threads: self.threads,
            cancel: Some(cancel),
            on_tile: Some(&on_tile),
            resume: resume.as_ref(),
            layers: denoise,
            ..RenderOptions::default()
        };
        let rendered = crate::render::render_progressive(&job, &options, &crate::render::DOUBLING_PASSES, &|_, _| {}, &mut on_pass)
            .map_err(ErrorInfo::plain)?;
        if let Some(e) = failed.into_inner().unwrap_or_else(|e| e.into_inner()) {
            return Err(ErrorInfo::plain(e));
        }
        // The image on screen: the refined one once a pass past the scene's samples began (denoised:
        // the last whole pass, already kept).
        let showing = pass.load(Ordering::Relaxed) > floor && !denoise;
        let samples = self.lock().status.samples[0];
        if over.load(Ordering::Relaxed) {
            let mut st = self.lock();
            let why = format!("refined to {samples} samples per pixel, when the work budget of {budget} rays was spent (--max-rays)");
            self.finish(&mut st, showing.then_some(rendered.film), why);
        } else if cancel.load(Ordering::Relaxed) {
            self.on_cancel(showing.then_some(rendered.film), &format!("refining, at {samples} samples per pixel"));
        } else {
            let converged = rendered.sums.pixels.iter().all(|p| target.converged(p));
            let mut st = self.lock();
            let why = if converged && s.target.is_some() {
                "every pixel met the error target".to_string()
            } else if converged {
                "every pixel's samples agree".to_string()
            } else {
                format!("{REFINE_MAX_SPP} samples per pixel, the most the view refines to")
            };
            self.finish(&mut st, (!denoise).then_some(rendered.film), why);
        }
        Ok(())
    }

    /// Loads the scene with the page's `settings` over the command line's options; also
    /// describes the controls with the values this load resolved.
    fn load(&self, settings: &Settings) -> Result<(RenderJob, Vec<Knob>), SceneError> {
        let options = knobs::options(&self.base, settings, &self.registry)?;
        let job = match &self.source {
            SceneSource::File(p) => crate::load::loader::load_file(&self.registry, p, &options)?,
            SceneSource::Bundled { name, text } => {
                crate::load::loader::load_str(&self.registry, name, text, std::path::Path::new("."), &options)?
            }
        };
        let mut knobs = knobs::describe(&self.registry, &job);
        knobs.push(knobs::denoise_knob(settings.denoise == Some(true), self.denoiser().map(|_| ())));
        Ok((job, knobs))
    }
}
