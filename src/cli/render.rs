//! `raylab render`: render a scene to an image, with a progress bar and a one-line summary.

use super::{App, Failure, SceneArgs, si};
use crate::image::output::{Grid, ImagePlan, OutputFormat};
use crate::render::aov::AovLayers;
use crate::render::film::Film;
use crate::render::share::{Share, ShareSums};
use crate::render::{RenderJob, RenderOptions, Rendered};
use clap::Args;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Once;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub(crate) struct RenderArgs {
    /// Scene file (.toml, or any registered format). Omit for the bundled default scene.
    scene: Option<PathBuf>,
    /// Output image: .png, .jpg or .jpeg (8-bit, clamped and encoded), .pfm (linear float, e.g. a
    /// reference), .exr (linear HDR floats with optional layers; feature `exr`), or a format a
    /// plugin registers (`raylab plugins` lists them).
    #[arg(short, long, default_value = "render.png")]
    output: PathBuf,
    /// EXR only: store colour (and normal, albedo) as 16-bit half floats instead of 32-bit.
    #[arg(long)]
    half: bool,
    /// EXR only: extra layers, comma-separated: depth, normal, albedo, emission (for denoisers:
    /// `raylab denoise` leaves the emission camera rays met directly out of its filter), error
    /// (the estimated standard error of each pixel's mean luminance, and its samples per pixel
    /// `spp`; `spp` asks for the same two).
    #[arg(long, value_delimiter = ',', value_parser = ["depth", "normal", "albedo", "emission", "error", "variance", "spp"])]
    aov: Vec<String>,
    /// Repeat a render under --time-budget bit for bit: each pixel takes the samples the `spp`
    /// layer of FILE (an EXR it wrote with `--aov spp`) says it reached, whatever the clock.
    /// Give the same command and settings as that render.
    #[arg(long, value_name = "FILE")]
    spp_map: Option<PathBuf>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, allow_hyphen_values = true, value_parser = super::int_in::<usize>(1, super::MAX_THREADS))]
    threads: Option<usize>,
    /// Draw grid lines every N pixels over the image (the report's printGrid).
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = super::int_in::<u32>(1, u32::MAX.into()))]
    grid: Option<u32>,
    /// Grid line colour as R,G,B (0–255).
    #[arg(long, value_name = "R,G,B", allow_hyphen_values = true, default_value = "255,255,255")]
    grid_color: String,
    /// Denoise the finished image with Intel Open Image Denoise, guided by albedo and normal
    /// layers the render also takes (needs its `oidnDenoise` tool: `pip install pyoidn`, or
    /// RAYLAB_OIDN). Where --spp divides evenly, the render and the denoiser work on 4 × 4 (or
    /// 2 × 2) sub-pixels of spp/16 (spp/4) samples each, averaged back over each pixel: the same
    /// camera rays, less error. With --target-error (from a first stop of 32 samples a pixel) and
    /// --time-budget too: each pixel's sub-pixels stop together. Not with --tile, --crop or
    /// --pass: denoise the merged frame (`raylab denoise`).
    #[arg(long)]
    denoise: bool,
    /// The frame is the K × K sub-pixels of each pixel of a frame K times narrower and lower, as
    /// `render --denoise` renders it on its finer grid (give --width and --height K times the
    /// frame's and --spp ÷ K²; --target-error and --target-min-spp as for the frame): under
    /// --target-error or --time-budget each pixel's K × K sub-pixels stop together, on their
    /// merged sums. For a farm's parts of `render --denoise --target-error E` (crops and tiles
    /// of whole blocks): merge them, then `raylab denoise --subpixels K`. Not with --denoise,
    /// which chooses its own grid. K divides the render's 16-pixel tiles: 1, 2, 4, 8 or 16.
    #[arg(long, value_name = "K", allow_hyphen_values = true, value_parser = subpixel_side)]
    subpixels: Option<u32>,
    /// Print the counters of traced and avoided work after the summary.
    #[arg(long)]
    stats: bool,
    /// Reference image (.pfm, or .png) to measure the render against: prints RMSE, PSNR and SSIM.
    #[arg(long, value_name = "REF")]
    reference: Option<PathBuf>,
    /// With --reference: write error against samples per pixel as the render progresses (passes
    /// at 1, 2, 4, … spp) to this CSV file.
    #[arg(long, value_name = "CSV", requires = "reference")]
    error_csv: Option<PathBuf>,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
    /// Show the render live in the tev image viewer listening at HOST:PORT (tev's default is
    /// 127.0.0.1:14158): tiles as they finish, refined pass by pass (1, 2, 4, … spp).
    #[arg(long, value_name = "HOST:PORT")]
    display_server: Option<String>,
    /// Render only the pixel bounds [X0, X1) × [Y0, Y1) of the frame (pbrt's --pixelbounds), to a
    /// partial image (`-o NAME.exr`) that `raylab merge` combines with others.
    #[arg(long, value_name = "X0,X1,Y0,Y1")]
    crop: Option<String>,
    /// Render tile I of N (0-based; bands of whole rows balanced by estimated work), to a partial
    /// image; `auto` takes I and N from SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT or
    /// JOB_COMPLETION_INDEX, with RAYLAB_TILE_COUNT giving or overriding the count.
    #[arg(long, value_name = "I/N|auto")]
    tile: Option<String>,
    /// Render sample pass K of N: every pixel's samples K, K+N, … (under adaptive anti-aliasing,
    /// the pixels whose index is K modulo N), to a partial image.
    #[arg(long, value_name = "K/N")]
    pass: Option<String>,
    /// Save the render's state to this file (a partial EXR) as it goes, so `--resume FILE`
    /// continues it after any interruption; removed once the render is done.
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0, allow_hyphen_values = true)]
    checkpoint_every: f64,
    /// Continue the render a checkpoint saved (the same command, scene and settings: a changed
    /// scene or file it reads is refused). Only --threads and --quiet may be given beside it.
    #[arg(long, value_name = "FILE")]
    resume: Option<PathBuf>,
    /// The arguments as given (after `render`), for checkpoints.
    #[arg(skip)]
    pub(crate) raw: Vec<String>,
    #[command(flatten)]
    scene_args: SceneArgs,
}

impl RenderArgs {
    /// What `raylab` without arguments does: the default scene to render.png.
    pub(crate) fn default_scene() -> Self {
        RenderArgs {
            scene: None,
            output: "render.png".into(),
            threads: None,
            grid: None,
            grid_color: "255,255,255".into(),
            stats: false,
            denoise: false,
            subpixels: None,
            reference: None,
            error_csv: None,
            quiet: false,
            display_server: None,
            half: false,
            aov: Vec::new(),
            spp_map: None,
            crop: None,
            tile: None,
            pass: None,
            checkpoint: None,
            checkpoint_every: 60.0,
            resume: None,
            raw: Vec::new(),
            scene_args: SceneArgs::default(),
        }
    }
}

/// Set by Ctrl-C (SIGINT) while `raylab render` runs; a second Ctrl-C exits at once.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the Ctrl-C handler once per process. Without one (another handler was installed
/// first), Ctrl-C keeps its default effect.
fn catch_ctrl_c() {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            if INTERRUPTED.swap(true, Ordering::SeqCst) {
                eprintln!("\ninterrupted twice: exiting without writing");
                std::process::exit(130);
            }
        });
    });
    INTERRUPTED.store(false, Ordering::SeqCst);
}

/// Where the image of an interrupted render goes: beside the target, `NAME.partial.EXT`.
pub(crate) fn partial_path(output: &Path) -> PathBuf {
    let stem = output.file_stem().map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
    let ext = output.extension().map_or_else(String::new, |e| format!(".{}", e.to_string_lossy()));
    output.with_file_name(format!("{stem}.partial{ext}"))
}

/// Value parser of `--subpixels`: a side of [`crate::render::share::SUBPIXEL_SIDES`], with the
/// rule in the message (clap's names the option: "invalid value '3' for '--subpixels <K>': …").
fn subpixel_side(text: &str) -> Result<u32, String> {
    match text.trim().parse::<u32>() {
        Ok(k) if crate::render::share::SUBPIXEL_SIDES.contains(&k) => Ok(k),
        _ => Err(crate::render::share::subpixel_rule()),
    }
}

pub(crate) fn run(app: &App, a: RenderArgs) -> Result<(), Failure> {
    match a.resume.clone() {
        Some(file) => resume(app, a, &file),
        None => render(app, a, None),
    }
}

/// `render --resume FILE`: the checkpoint's command, continued from its state.
fn resume(app: &App, given: RenderArgs, file: &Path) -> Result<(), Failure> {
    #[cfg(not(feature = "exr"))]
    {
        let _ = (app, given, file);
        Err(Failure::Other(format!("--resume reads a checkpoint (an OpenEXR file); {}", crate::param::error::built_without("exr"))))
    }
    #[cfg(feature = "exr")]
    {
        let limits = given.scene_args.load_options()?.limits;
        let bytes = crate::load::context::read_user_file(file, "checkpoint", u64::MAX, None)?;
        let Checkpoint { sums, fingerprint, cwd, args: mut a, raw } =
            read_checkpoint(&bytes, &file.display().to_string(), limits.max_pixels).map_err(Failure::Other)?;
        // Relative paths are relative to the folder the render was started in.
        let at = |p: &Path| if p.is_absolute() { p.to_path_buf() } else { cwd.join(p) };
        a.scene = a.scene.as_deref().map(at);
        a.output = at(&a.output);
        a.reference = a.reference.as_deref().map(at);
        a.error_csv = a.error_csv.as_deref().map(at);
        a.spp_map = a.spp_map.as_deref().map(at);
        a.checkpoint = Some(file.to_path_buf());
        a.raw = raw;
        a.threads = given.threads.or(a.threads);
        a.quiet |= given.quiet;
        // Say what is being continued: how much was done and what is left.
        let (done, total, left) = sums.progress();
        eprintln!(
            "resuming {}: {done} of {total} samples done ({:.1} %), {left} of {} pixels still to finish; rendering to {}",
            file.display(),
            100.0 * done as f64 / total.max(1) as f64,
            sums.pixels.len(),
            a.output.display()
        );
        render(app, a, Some((sums, fingerprint)))
    }
}

/// A checkpoint read: the state saved, the fingerprint of the render it continues, and the
/// command that started it (parsed again, and as given).
#[cfg(feature = "exr")]
struct Checkpoint {
    sums: ShareSums,
    fingerprint: String,
    /// The folder the render was started in.
    cwd: PathBuf,
    args: RenderArgs,
    raw: Vec<String>,
}

/// Reads a checkpoint from `bytes` (named `name` in messages): a partial image (frames of more
/// than `max_pixels` refused before decoding) that says how to continue, in a command that still
/// parses.
#[cfg(feature = "exr")]
fn read_checkpoint(bytes: &[u8], name: &str, max_pixels: u64) -> Result<Checkpoint, String> {
    let (sums, info) = crate::image::partial::read_partial(bytes, name, max_pixels).map_err(|e| e.to_string())?;
    let json = info.resume.ok_or_else(|| format!("{name} is a partial image, not a checkpoint: it says nothing of how to continue"))?;
    let ri: super::farm::ResumeInfo = serde_json::from_str(&json).map_err(|e| format!("{name}: unreadable resume information ({e})"))?;
    let argv = std::iter::once("raylab render".to_string()).chain(ri.args.iter().cloned());
    let Ok(SavedCommand { args }) = <SavedCommand as clap::Parser>::try_parse_from(argv) else {
        return Err(format!("{name}: the saved command `render {}` no longer parses", ri.args.join(" ")));
    };
    Ok(Checkpoint { sums, fingerprint: info.fingerprint, cwd: ri.cwd, args, raw: ri.args })
}

/// The scenes the fuzz target `checkpoint` continues checkpoints with, from `scene` (an
/// adaptive one, `tests/assets/view-fuzz.toml`): as it is, stratified, and stratified to an
/// error target.
#[cfg(feature = "exr")]
pub fn checkpoint_fuzz_scenes(scene: &str) -> Vec<String> {
    let adaptive = "aa = \"adaptive\"";
    vec![
        scene.to_string(),
        scene.replace(adaptive, "aa = \"stratified\""),
        scene.replace(adaptive, "aa = \"stratified\"\ntarget_error = 0.05\ntarget_min_spp = 2"),
    ]
}

/// What the fuzz target `checkpoint` (and the replay of its corpus in `tests/fuzz_corpus.rs`)
/// checks of arbitrary bytes as a checkpoint, read as `raylab render --resume` reads one (named
/// `fuzz.exr`, frames of at most 2²⁰ pixels) and then continued: with the job of `jobs` whose
/// fingerprint it gives (a fingerprint is no secret: a forged file can give any), or else the
/// first, on one thread. Reading fails with a message naming the file, or the render refuses the
/// state with a message, or it finishes with every pixel's samples and a finite image. Never a
/// panic; `Err` names what broke.
#[cfg(feature = "exr")]
pub fn fuzz_checkpoint(data: &[u8], jobs: &[RenderJob]) -> Result<(), String> {
    let Checkpoint { sums, fingerprint, .. } = match read_checkpoint(data, "fuzz.exr", 1 << 20) {
        Ok(c) => c,
        Err(e) if e.starts_with("fuzz.exr") => return Ok(()),
        Err(e) => return Err(format!("an error that does not name the file: {e}")),
    };
    let Some(job) = jobs.iter().find(|j| j.fingerprint == fingerprint).or(jobs.first()) else { return Ok(()) };
    let options = RenderOptions {
        threads: Some(1),
        layers: sums.layers.is_some(),
        share: Some(sums.share),
        resume: Some(&sums),
        ..RenderOptions::default()
    };
    let Ok(rendered) = crate::render::render(job, &options, &|_, _| {}) else { return Ok(()) };
    if !rendered.complete {
        return Err(format!("a resumed render stopped unfinished (budget stop: {:?})", rendered.budget_stop));
    }
    if let Some(i) = (0..rendered.sums.pixels.len()).find(|&i| rendered.sums.missing(i) > 0) {
        return Err(format!(
            "pixel {:?} lacks {} samples after the resumed render",
            rendered.sums.share.bounds.pixel(i),
            rendered.sums.missing(i)
        ));
    }
    if let Some((i, c)) = rendered.film.pixels.iter().enumerate().find(|(_, c)| !c.is_finite()) {
        return Err(format!("pixel {i} of the resumed image is {c:?}"));
    }
    Ok(())
}

/// The arguments of `raylab render` alone: a checkpoint's saved command, parsed again.
#[cfg(feature = "exr")]
#[derive(clap::Parser)]
struct SavedCommand {
    #[command(flatten)]
    args: RenderArgs,
}

/// Renders as `a` asks, continuing `resumed` (a checkpoint's state and fingerprint) if given:
/// the arguments checked, the scene loaded and the work planned, the render run, its image
/// written and the summary printed.
fn render(app: &App, a: RenderArgs, resumed: Option<(ShareSums, String)>) -> Result<(), Failure> {
    catch_ctrl_c();
    let t0 = Instant::now();
    let request = validate(app, &a)?;
    let mut plan = plan(app, &a, request, resumed.as_ref().map(|(_, fingerprint)| fingerprint.as_str()), t0)?;
    // The denoiser works on a finer grid where it can (`denoise::grid`): the render runs there
    // (a checkpoint holds that grid's state, and resuming it chooses the same grid), and
    // `write_image` brings the result back to the frame's pixels.
    let settings = plan.job.settings;
    if plan.grid > 1 {
        plan.job.settings = crate::image::denoise::fine_settings(&settings, plan.grid);
    }
    let run = run_planned(&plan, resumed.as_ref().map(|(sums, _)| sums))?;
    if !run.rendered.complete {
        return Err(stopped(&plan, &run));
    }
    plan.job.settings = settings;
    let written = write_image(&plan, run.rendered)?;
    summarize(&plan, &written, run.trace_cpu)
}

/// What the arguments ask for, checked before anything is read.
struct Request<'a> {
    grid: Option<Grid>,
    /// A crop, tile or pass: a partial image.
    parts: bool,
    format: &'a OutputFormat,
    image: ImagePlan,
}

/// Checks the arguments that need no scene.
fn validate<'a>(app: &'a App, a: &RenderArgs) -> Result<Request<'a>, Failure> {
    let grid = match a.grid {
        None => None,
        Some(0) => return Err("--grid must be at least 1".to_string().into()),
        Some(interval) => Some(Grid { interval, color: parse_rgb8(&a.grid_color)? }),
    };
    if !(a.checkpoint_every > 0.0 && a.checkpoint_every.is_finite()) {
        return Err(Failure::Other(format!("--checkpoint-every: expected a number of seconds > 0, found {}", a.checkpoint_every)));
    }
    let parts = a.crop.is_some() || a.tile.is_some() || a.pass.is_some();
    let format = app.registry.output_format_for(&a.output).map_err(|e| e.to_string())?;
    for out in std::iter::once(&a.output).chain(&a.error_csv).chain(&a.checkpoint) {
        super::output_folder_exists(out)?;
    }
    let exr = format.name == "exr";
    if !format.layers && (a.half || !a.aov.is_empty()) {
        return Err("--half and --aov apply to .exr output only".to_string().into());
    }
    if parts && !exr {
        return Err(Failure::Other(format!(
            "--crop, --tile and --pass write a partial image for `raylab merge`: an OpenEXR file (-o NAME.exr), not {}",
            a.output.display()
        )));
    }
    if a.denoise && a.subpixels.is_some() {
        return Err(Failure::Other(
            "--subpixels renders a farm's part of --denoise's finer grid; --denoise chooses its own grid: give one or the other".into(),
        ));
    }
    if parts && a.denoise {
        return Err(Failure::Other(
            "--denoise applies to a whole image, not to a tile, crop or pass (the filter looks across tile borders): merge the parts, then `raylab denoise`".into(),
        ));
    }
    if !cfg!(feature = "exr") && (parts || a.checkpoint.is_some()) {
        return Err(Failure::Other(format!(
            "--crop, --tile, --pass and --checkpoint write OpenEXR files; {}",
            crate::param::error::built_without("exr")
        )));
    }
    if !parts && a.tile.is_none() && super::farm::TILE_INDEX_VARS.iter().any(|v| std::env::var_os(v).is_some()) {
        eprintln!(
            "note: a scheduler's task index is set ({}), but --tile is not: rendering the whole frame (--tile auto renders this task's tile)",
            super::farm::TILE_INDEX_VARS.join(" or ")
        );
    }
    let layer = |name: &str| a.aov.iter().any(|s| s == name);
    let image = ImagePlan {
        exr,
        depth: layer("depth"),
        normal: layer("normal"),
        albedo: layer("albedo"),
        emission: layer("emission"),
        half: a.half,
        error: layer("error") || layer("variance"),
    };
    Ok(Request { grid, parts, format, image })
}

/// A render planned: the scene loaded, the part of the frame to render, where it all goes.
struct Plan<'a> {
    a: &'a RenderArgs,
    request: Request<'a>,
    job: RenderJob,
    scene_name: String,
    share: Option<Share>,
    reference: Option<Film>,
    /// The samples per pixel of `--spp-map`, row by row.
    spp_map: Option<Vec<u32>>,
    /// The denoiser's tool, when asked for.
    denoiser: Option<PathBuf>,
    /// Sub-pixels per pixel side the render and the denoiser work on
    /// ([`crate::image::denoise::grid`]; 1 without the denoiser).
    grid: u32,
    /// Where the image of an interrupted render goes.
    partial: PathBuf,
    /// Where the state is saved to continue from.
    checkpoint: PathBuf,
    /// What a checkpoint says of how to continue it.
    resume_info: String,
    load_time: Duration,
}

/// Loads the scene (nothing it reads written over, a resumed render's scene unchanged) and plans
/// the render. `t0`: when the command started, for the load time.
fn plan<'a>(app: &App, a: &'a RenderArgs, request: Request<'a>, resumed: Option<&str>, t0: Instant) -> Result<Plan<'a>, Failure> {
    // Nothing the render reads is written over: checked before loading for the files named on the
    // command line, and after for those the scene names (meshes, textures).
    let partial = partial_path(&a.output);
    let checkpoint = a.checkpoint.clone().unwrap_or_else(|| super::farm::default_checkpoint(&a.output));
    let mut outputs = vec![a.output.as_path(), partial.as_path()];
    outputs.extend(a.error_csv.as_deref());
    // A resumed render rewrites its own checkpoint: that one file is both.
    outputs.extend(Some(checkpoint.as_path()).filter(|_| resumed.is_none()));
    let named: Vec<&Path> = a.scene.iter().chain(&a.reference).chain(&a.spp_map).map(PathBuf::as_path).collect();
    super::refuse_overwrite("render", &outputs, named.iter().copied())?;
    let (mut job, scene_name) = super::load(app, a.scene.as_deref(), &a.scene_args, request.image)?;
    // A part of `render --denoise`'s finer grid: its blocks of sub-pixels stop together (the
    // render checks that the frame and the share are made of whole blocks).
    if let Some(k) = a.subpixels {
        job.settings.subpixels = k;
    }
    super::refuse_overwrite("render", &outputs, job.inputs.iter().map(PathBuf::as_path))?;
    if INTERRUPTED.load(Ordering::SeqCst) {
        return Err(Failure::Interrupted("interrupted while loading: nothing rendered, nothing written".into()));
    }
    if let Some(fingerprint) = resumed
        && fingerprint != job.fingerprint
    {
        return Err(Failure::Other(format!(
            "the checkpoint is of another render (fingerprint {fingerprint}, now {}): the scene, a file it reads, or a setting changed since; render it anew",
            job.fingerprint
        )));
    }
    let share = super::farm::share(&job, a.crop.as_deref(), a.tile.as_deref(), a.pass.as_deref())?;
    let reference = match &a.reference {
        Some(p) => Some(crate::image::reference::read(p, job.settings.encoding)?),
        None => None,
    };
    let spp_map = match &a.spp_map {
        Some(p) => Some(read_spp_map(p, job.settings.width, job.settings.height)?),
        None => None,
    };
    let load_time = t0.elapsed();
    let denoiser = if a.denoise { Some(crate::image::denoise::find_tool().map_err(Failure::Other)?) } else { None };
    // Not with an error log against a reference: it measures each pass on the frame's pixels.
    let grid = if denoiser.is_some() && a.error_csv.is_none() { crate::image::denoise::grid(&job.settings) } else { 1 };
    // A time budget's map (the `spp` layer of the frame's pixels) repeated on the finer grid.
    let spp_map = match spp_map {
        Some(m) if grid > 1 => Some(
            crate::image::denoise::fine_spp_map(&m, job.settings.width, grid)
                .map_err(|e| Failure::Other(format!("{}: {e}", a.spp_map.as_deref().unwrap_or(Path::new("")).display())))?,
        ),
        m => m,
    };
    // Checkpoints: the state as a partial image, with the command that continues it.
    let resume_info = serde_json::to_string(&super::farm::ResumeInfo {
        cwd: std::env::current_dir().unwrap_or_default(),
        args: a.raw.iter().filter(|r| !r.is_empty()).cloned().collect(),
    })
    .map_err(|e| e.to_string())?;
    Ok(Plan { a, request, job, scene_name, share, reference, spp_map, denoiser, grid, partial, checkpoint, resume_info, load_time })
}

/// A render run, complete or not.
struct Run {
    rendered: Rendered,
    /// CPU time of every thread while tracing, seconds.
    trace_cpu: Option<f64>,
    /// The share of the work done, in per cent.
    done: f64,
}

/// Runs the render with a progress bar, checkpoints, a live display and an error log as asked,
/// continuing `resume`.
fn run_planned(plan: &Plan, resume: Option<&ShareSums>) -> Result<Run, Failure> {
    let (a, job) = (plan.a, &plan.job);
    let s = job.settings;
    let bar = progress_bar(a.quiet, u64::from(s.width) * u64::from(s.height));
    bar.set_message(match &plan.share {
        Some(sh) => format!("{}, {}", plan.scene_name, sh.describe()),
        None => plan.scene_name.clone(),
    });
    let checkpoint_failure: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);
    let write_checkpoint = |sums: &ShareSums| {
        if let Err(e) = save_state(&plan.checkpoint, sums, job, Some(&plan.resume_info)) {
            checkpoint_failure.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(e);
        }
    };
    let display = match &a.display_server {
        Some(addr) => {
            let name = a.output.file_name().map_or_else(|| "raylab".into(), |n| n.to_string_lossy().into_owned());
            Some(crate::image::tev::Display::start(addr, &name, s.width, s.height)?)
        }
        None => None,
    };
    let show_tile = |t: &crate::render::TileDone| {
        if let Some(d) = &display {
            let b = t.sums.share.bounds;
            let mut rgb = Vec::with_capacity(3 * t.tile.pixels() as usize);
            for y in t.tile.y0..t.tile.y1 {
                for x in t.tile.x0..t.tile.x1 {
                    rgb.extend_from_slice(&t.sums.pixels[b.index(x, y)].mean().as_vec3().to_array());
                }
            }
            d.send((t.tile, rgb));
        }
    };
    let snapshots = a
        .checkpoint
        .as_ref()
        .map(|_| crate::render::Snapshots { every: std::time::Duration::from_secs_f64(a.checkpoint_every), write: &write_checkpoint });
    let image = plan.request.image;
    let options = RenderOptions {
        threads: a.threads,
        cancel: Some(&INTERRUPTED),
        layers: image.depth || image.normal || image.albedo || image.emission || a.denoise,
        share: plan.share,
        resume,
        snapshots,
        on_tile: display.as_ref().map(|_| &show_tile as &(dyn Fn(&crate::render::TileDone) + Sync)),
        spp_map: plan.spp_map.as_deref(),
    };
    let mut error_log = match (&a.error_csv, &plan.reference) {
        (Some(path), Some(r)) => Some(ErrorLog::new(path, r, s.encoding)?),
        _ => None,
    };
    // Passes at 1, 2, 4, … spp (the same final bits) for the error log and for a live display.
    let checkpoints: &[u32] = if error_log.is_some() || display.is_some() { &crate::render::DOUBLING_PASSES } else { &[] };
    let mut log_failure = None;
    let work = [AtomicU64::new(0), AtomicU64::new(1)];
    let cpu0 = crate::render::stats::process_cpu_time();
    let rendered = crate::render::render_progressive(
        job,
        &options,
        checkpoints,
        &|done, total| {
            work[0].fetch_max(done, Ordering::Relaxed);
            work[1].store(total.max(1), Ordering::Relaxed);
            bar.set_length(total);
            bar.set_position(done)
        },
        &mut |pass| {
            if let Some(log) = error_log.as_mut()
                && let Err(e) = log.record(pass)
            {
                log_failure.get_or_insert(e);
            }
        },
    )?;
    // CPU time of every thread while tracing: a rate that other processes on a busy machine do
    // not inflate (as POV-Ray's "CPU-seconds total").
    let trace_cpu = cpu0.zip(crate::render::stats::process_cpu_time()).map(|(a, b)| (b - a).as_secs_f64());
    bar.finish_and_clear();
    if let (Some(d), Some(addr)) = (display, &a.display_server) {
        let report = d.finish();
        match (report.connected, report.error) {
            (true, None) => {}
            (true, Some(e)) => eprintln!("warning: the display server at {addr} missed part of the image: {e}"),
            (false, e) => eprintln!("warning: no display server (tev) reached at {addr}: {}", e.unwrap_or_default()),
        }
    }
    if let Some(e) = log_failure {
        return Err(e.into());
    }
    if let Some(e) = checkpoint_failure.lock().unwrap_or_else(|e| e.into_inner()).take() {
        eprintln!("warning: a checkpoint could not be written: {e}");
    }
    let done = 100.0 * work[0].load(Ordering::Relaxed) as f64 / work[1].load(Ordering::Relaxed) as f64;
    Ok(Run { rendered, trace_cpu, done })
}

/// A progress bar on standard error over `total` pixels (hidden when `quiet`).
fn progress_bar(quiet: bool, total: u64) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::with_draw_target(Some(total), indicatif::ProgressDrawTarget::stderr());
    if let Ok(style) = indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent:>3}% ETA {eta} {msg}") {
        b.set_style(style.progress_chars("=> "));
    }
    b
}

/// A render that stopped early (interrupted, or over the work budget): its state saved to
/// continue from, the image so far written beside the target, and the failure that says so.
fn stopped(plan: &Plan, run: &Run) -> Failure {
    let (a, job, rendered) = (plan.a, &plan.job, &run.rendered);
    let parts = plan.request.parts;
    // The state, to continue from; and the image so far, in the target's format (a partial
    // render's output is its state already).
    let saved = if cfg!(feature = "exr") {
        if let Err(e) = save_state(&plan.checkpoint, &rendered.sums, job, Some(&plan.resume_info)) {
            return Failure::Other(e);
        }
        format!("; continue with `raylab render --resume {}`", plan.checkpoint.display())
    } else {
        String::new()
    };
    if !parts && let Err(e) = write(plan, &plan.partial, &rendered.film, None, None) {
        return e;
    }
    let done = run.done;
    let (why, failure): (String, fn(String) -> Failure) = match rendered.budget_stop {
        Some(rays) => {
            // What the whole render would take at the rate so far, as a flag value when it is one.
            let whole = rays as f64 * 100.0 / done.max(1e-9);
            let advice = match crate::render::budget::flag_value(whole * 1.25).filter(|_| done > 0.0) {
                Some(v) => format!("the whole render would trace about {whole:.3e}: raise --max-rays to {v}, or lower the knobs"),
                None => "lower the knobs that multiply rays (--spp, --depth, the integrator's)".to_string(),
            };
            (
                format!(
                    "stopped by the work budget at {done:.1} %: {rays} rays traced, over --max-rays {} (integrator \"{}\": {}); {advice}",
                    job.max_rays,
                    job.integrator_name,
                    job.integrator.describe(),
                ),
                Failure::Other,
            )
        }
        None => (format!("interrupted at {done:.1} %"), Failure::Interrupted),
    };
    failure(format!(
        "{why}: {}{}{saved}; {} was not written",
        if parts { String::new() } else { format!("wrote the image so far to {} (pixels not reached are black)", plan.partial.display()) },
        if cfg!(feature = "exr") {
            format!("{}saved the state in {}", if parts { "" } else { " and " }, plan.checkpoint.display())
        } else {
            String::new()
        },
        a.output.display()
    ))
}

/// A complete render, written.
struct Written {
    rendered: Rendered,
    denoise_time: Option<Duration>,
    write_time: Duration,
}

/// Denoises the image if asked, writes it (a partial render: its state), and removes what an
/// earlier, interrupted render of the same target left.
fn write_image(plan: &Plan, mut rendered: Rendered) -> Result<Written, Failure> {
    let (a, job) = (plan.a, &plan.job);
    let t_denoise = Instant::now();
    if plan.denoiser.is_some() {
        let clean = crate::image::denoise::guides_are_clean(job);
        crate::image::denoise::denoise_rendered(&mut rendered, &job.settings, plan.grid, clean).map_err(Failure::Other)?;
    }
    let denoise_time = plan.denoiser.as_ref().map(|_| t_denoise.elapsed());
    let t_write = Instant::now();
    if plan.request.parts {
        save_state(&a.output, &rendered.sums, job, None).map_err(Failure::Other)?;
    } else {
        write(plan, &a.output, &rendered.film, rendered.layers.as_ref(), Some(&rendered.sums))?;
    }
    if a.checkpoint.is_some() && plan.checkpoint.exists() {
        // The render is done: its checkpoint has served.
        let _ = std::fs::remove_file(&plan.checkpoint);
    }
    // The image an interrupted render of this target left beside it is superseded now.
    let stale = &plan.partial;
    if !plan.request.parts && stale.exists() && std::fs::remove_file(stale).is_ok() {
        eprintln!("removed {}, the image of an interrupted render of {} (now complete)", stale.display(), a.output.display());
    }
    Ok(Written { rendered, denoise_time, write_time: t_write.elapsed() })
}

/// Prints the render's summary: what was written, how long each step took, the counters, the
/// error against a reference.
fn summarize(plan: &Plan, written: &Written, trace_cpu: Option<f64>) -> Result<(), Failure> {
    let (a, job, rendered) = (plan.a, &plan.job, &written.rendered);
    let s = job.settings;
    let st = rendered.stats;
    let secs = rendered.elapsed.as_secs_f64();
    let threads = a.threads.unwrap_or_else(rayon::current_num_threads);
    let describe = job.integrator.describe();
    let accel = job.scene.accel_summary();
    let build_time = (accel.build.time + accel.object_builds.time).as_secs_f64();
    let memory = crate::render::stats::peak_memory_bytes().map_or_else(String::new, |b| format!(", peak memory {}B", si(b as f64)));
    let what = match &plan.share {
        Some(sh) => format!("partial image: {}; ", sh.describe()),
        None => String::new(),
    };
    println!(
        "wrote {} ({what}{}×{}, {}, {}{}) from {}: trace {:.3} s{} on {threads} thread{}, {} rays, {} rays/s, {} non-finite samples (load {:.3} s, BVH build {:.3} s, {}write {:.3} s{memory})",
        a.output.display(),
        s.width,
        s.height,
        s.describe_sampling(),
        job.integrator_name,
        if describe.is_empty() { String::new() } else { format!(" {describe}") },
        plan.scene_name,
        secs,
        trace_cpu.map_or_else(String::new, |c| format!(" ({c:.3} CPU s)")),
        if threads == 1 { "" } else { "s" },
        si(st.total_rays() as f64),
        si(st.total_rays() as f64 / secs.max(1e-9)),
        st.nonfinite_samples,
        plan.load_time.as_secs_f64() - build_time,
        build_time,
        written.denoise_time.map_or_else(String::new, |d| format!("denoise {:.3} s, ", d.as_secs_f64())),
        written.write_time.as_secs_f64(),
    );
    println!("  {}", accel_line(&accel));
    if let Some(e) = rendered.sums.error_estimate() {
        let low = s.target.map(|t| rendered.sums.low_reading(&t));
        println!("  {}{}", error_line(&e, s.target.is_some(), low), if a.denoise { " (before denoising)" } else { "" });
    }
    if let Some(budget) = s.time_budget {
        let recorded = a.aov.iter().any(|l| l == "spp" || l == "error" || l == "variance");
        println!("  {}", budget_line(rendered, budget, plan.spp_map.is_some(), recorded));
    }
    if st.nonfinite_samples > 0 {
        eprintln!("warning: {} samples were NaN or infinite and were dropped from their pixels", st.nonfinite_samples);
    }
    if let Some(r) = &plan.reference {
        let e = crate::image::metrics::compare(&rendered.film, r, s.encoding)?;
        println!(
            "error against {}: RMSE {:.5}, PSNR {:.2} dB, SSIM {:.5}",
            a.reference.as_ref().map_or(String::new(), |p| p.display().to_string()),
            e.rmse,
            e.psnr,
            e.ssim
        );
    }
    if let Some(p) = &a.error_csv {
        println!("wrote {}", p.display());
    }
    if a.stats {
        print!("{}", stats_table(&st));
    }
    Ok(())
}

/// Writes a render's state as a partial image (with `resume`: a checkpoint).
fn save_state(path: &Path, sums: &ShareSums, job: &RenderJob, resume: Option<&str>) -> Result<(), String> {
    #[cfg(feature = "exr")]
    {
        let info = crate::image::partial::PartialInfo {
            fingerprint: job.fingerprint.clone(),
            sampling: job.settings.describe_sampling(),
            encoding: job.settings.encoding.name().to_string(),
            resume: resume.map(str::to_string),
        };
        crate::image::partial::write_partial(path, sums, &info).map_err(|e| e.to_string())
    }
    #[cfg(not(feature = "exr"))]
    {
        let _ = (path, sums, job, resume);
        Err(format!("partial images and checkpoints are OpenEXR files; {}", crate::param::error::built_without("exr")))
    }
}

/// The summary's line on the image's estimated error ([`crate::render::share::ErrorEstimate`]);
/// under an error target, `low` says why it may read low ([`crate::render::share::LowReading`]):
/// when flagged, the line says so, and why.
pub fn error_line(e: &crate::render::share::ErrorEstimate, target: bool, low: Option<crate::render::share::LowReading>) -> String {
    let warning = match (estimate_may_read(e, low), low) {
        ("low", Some(l)) => {
            let mut why = Vec::new();
            if l.rare_share >= crate::render::job::ErrorTarget::RARE_SHARE {
                why.push(format!(
                    "{:.1} % of it is in pixels lit by samples rarer than 1 in {first} (caustics, glints), \
                     and pixels like them that stopped at {first} samples likely missed theirs (a larger target_min_spp looks longer)",
                    100.0 * l.rare_share,
                    first = l.first
                ));
            }
            if l.pixels < crate::render::share::LowReading::FEW_PIXELS {
                why.push(format!(
                    "it rests on few pixels (as concentrated as {:.0} equally noisy ones), which read from their own few samples, \
                     and the pixels that stop are those whose samples look quiet",
                    l.pixels
                ));
            }
            format!("; may read low: {}", why.join("; "))
        }
        ("high", _) => format!(
            "; may read high: below {} samples a pixel, each half of a pixel's samples is stratified much less well than the whole \
             (it read up to 2.3× the true error at 8 spp, 1.55× at 16, benches/error)",
            crate::render::share::ErrorEstimate::FEW_SPP
        ),
        _ => String::new(),
    };
    format!(
        "estimated error: relative RMSE {:.3} % (from the spread of each pixel's samples; {}{:.1} spp on average){warning}",
        100.0 * e.relative_rmse,
        if target { "an error target: " } else { "" },
        e.mean_spp
    )
}

/// Which way the estimate `e` may be wrong, as the summary's line says: `"low"` where, under an
/// error target, `low` is flagged ([`crate::render::share::LowReading::flagged`]), else `"high"`
/// below [`crate::render::share::ErrorEstimate::FEW_SPP`] samples a pixel without a target, else
/// `"no"`.
pub fn estimate_may_read(e: &crate::render::share::ErrorEstimate, low: Option<crate::render::share::LowReading>) -> &'static str {
    match low {
        Some(l) if l.flagged() => "low",
        _ if e.reads_high => "high",
        _ => "no",
    }
}

/// The summary's line on a render under a time budget: where it stopped, and how to repeat it.
fn budget_line(r: &Rendered, budget: std::time::Duration, from_map: bool, recorded: bool) -> String {
    let (lo, hi) = r.sums.pixels.iter().fold((u32::MAX, 0), |(lo, hi), p| (lo.min(p.samples), hi.max(p.samples)));
    let spp = if lo == hi { format!("{lo} spp") } else { format!("{lo}..{hi} spp") };
    let how = if from_map {
        "samples per pixel read from --spp-map (the clock not consulted)".to_string()
    } else if r.time_stop {
        format!("stopped by the time budget of {} s", budget.as_secs_f64())
    } else {
        format!("every pixel reached its most samples within the time budget of {} s", budget.as_secs_f64())
    };
    let repeat = if from_map || !r.time_stop {
        ""
    } else if recorded {
        "; the `spp` layer records it: --spp-map FILE repeats it bit for bit"
    } else {
        "; not recorded: with -o NAME.exr --aov spp, --spp-map NAME.exr repeats it bit for bit"
    };
    format!("time budget: {how} at {spp}{repeat}")
}

/// The `spp` layer of an EXR file as a map of samples per pixel for a `width × height` frame.
fn read_spp_map(path: &Path, width: u32, height: u32) -> Result<Vec<u32>, Failure> {
    use crate::image::tonemap::{Layer, MAX_FILE_BYTES, check_input, read_layer};
    let at = |e: String| Failure::Other(format!("--spp-map {}: {e}", path.display()));
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    check_input(&ext, Layer::Spp).map_err(at)?;
    let bytes = crate::load::context::read_user_file(path, "map of samples per pixel", MAX_FILE_BYTES, None)?;
    let film = read_layer(&bytes, &ext, Layer::Spp).map_err(at)?;
    if (film.width, film.height) != (width, height) {
        return Err(at(format!("its {}×{} pixels are not this render's {width}×{height}", film.width, film.height)));
    }
    film.pixels
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let n = p.x;
            // Whole numbers up to 2^24 are exact in the layer's 32-bit floats.
            if n.is_finite() && n >= 0.0 && n.fract() == 0.0 && n <= (1u32 << 24) as f32 {
                Ok(n as u32)
            } else {
                Err(at(format!(
                    "pixel ({}, {}) has {n} samples: expected a whole number in 0..=2^24",
                    i % width as usize,
                    i / width as usize
                )))
            }
        })
        .collect()
}

/// Writes the image to `path` in the planned format, with the layers `--aov` asks for (of
/// `layers`, and the error layers from `sums`).
fn write(plan: &Plan, path: &Path, film: &Film, layers: Option<&AovLayers>, sums: Option<&ShareSums>) -> Result<(), Failure> {
    use crate::render::aov::Aov;
    let a = plan.a;
    let asked = |l: Aov| a.aov.iter().any(|s| Aov::parse(s) == Some(l));
    let mut chosen = layers.map(|l| AovLayers {
        depth: l.depth.clone().filter(|_| asked(Aov::Depth)),
        normal: l.normal.clone().filter(|_| asked(Aov::Normal)),
        albedo: l.albedo.clone().filter(|_| asked(Aov::Albedo)),
        emitted: l.emitted.clone().filter(|_| asked(Aov::Emission)),
        ..AovLayers::default()
    });
    if let Some(sums) = sums.filter(|_| asked(Aov::Error)) {
        let (error, spp) = sums.error_layers().map_err(|e| e.to_string())?;
        let c = chosen.get_or_insert_with(AovLayers::default);
        (c.error, c.spp) = (Some(error), Some(spp));
        let low = plan.job.settings.target.map(|t| sums.low_reading(&t));
        c.estimate = sums.error_estimate().map(|e| (e.relative_rmse, estimate_may_read(&e, low)));
    }
    let settings = crate::image::output::WriteSettings {
        encoding: plan.job.settings.encoding,
        grid: plan.request.grid,
        layers: chosen.as_ref(),
        half: a.half,
    };
    plan.request.format.write(path, film, &settings).map_err(|e| e.to_string().into())
}

/// One line saying how the objects and meshes are indexed for ray queries.
pub fn accel_line(s: &crate::scene::AccelSummary) -> String {
    let objects = if s.bvh { format!("BVH over {} objects", s.bounded) } else { format!("list of {} objects", s.bounded) };
    let unbounded = if s.unbounded > 0 { format!(" + {} unbounded", s.unbounded) } else { String::new() };
    let parts = &s.object_builds;
    let meshes = if parts.primitives == 0 {
        String::new()
    } else if parts.hierarchies > 0 {
        format!(
            "; {} mesh BVH{} over {} triangles",
            parts.hierarchies,
            if parts.hierarchies == 1 { "" } else { "s" },
            si(parts.primitives as f64)
        )
    } else {
        format!("; meshes as triangle lists ({} triangles)", si(parts.primitives as f64))
    };
    // Which compiled copy walks the hierarchies (the same results either way): for benchmarks.
    let kernel = if s.bvh || parts.hierarchies > 0 { format!("; {} traversal", crate::accel::traversal_kernel()) } else { String::new() };
    format!("acceleration: {objects}{unbounded}{meshes}{kernel}")
}

/// Error against a reference after each pass of a progressive render, written as CSV lines as
/// they come (flushed, so the file can be watched).
struct ErrorLog<'a> {
    file: std::io::BufWriter<std::fs::File>,
    reference: &'a Film,
    encoding: crate::math::color::Encoding,
}

impl<'a> ErrorLog<'a> {
    fn new(path: &std::path::Path, reference: &'a Film, encoding: crate::math::color::Encoding) -> Result<Self, Failure> {
        let f = std::fs::File::create(path).map_err(|e| Failure::Other(format!("cannot create \"{}\": {e}", path.display())))?;
        let mut file = std::io::BufWriter::new(f);
        writeln!(file, "spp,seconds,rays,rmse,psnr_db,ssim").map_err(|e| e.to_string())?;
        Ok(ErrorLog { file, reference, encoding })
    }

    fn record(&mut self, pass: &crate::render::Pass) -> Result<(), String> {
        let e = crate::image::metrics::compare(pass.film, self.reference, self.encoding)?;
        writeln!(
            self.file,
            "{},{:.6},{},{:.6e},{:.4},{:.6}",
            pass.samples,
            pass.elapsed.as_secs_f64(),
            pass.stats.total_rays(),
            e.rmse,
            e.psnr,
            e.ssim
        )
        .and_then(|_| self.file.flush())
        .map_err(|e| format!("writing the error CSV failed: {e}"))
    }
}

/// The counters of a render as an aligned table.
pub fn stats_table(st: &crate::render::stats::RayStats) -> String {
    let mut rows = vec![("camera rays", st.camera_rays)];
    rows.extend(st.counters().map(|(c, n)| (c.doc, n)));
    rows.push(("non-finite samples", st.nonfinite_samples));
    rows.iter().map(|(k, v)| format!("  {k:<32}{v:>14}\n")).collect()
}

fn parse_rgb8(s: &str) -> Result<[u8; 3], Failure> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || Failure::Other(format!("--grid-color: expected R,G,B with each 0–255, found \"{s}\""));
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut c = [0u8; 3];
    for (slot, p) in c.iter_mut().zip(parts) {
        *slot = p.parse().map_err(|_| bad())?;
    }
    Ok(c)
}
