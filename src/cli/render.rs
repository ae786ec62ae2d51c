//! `raylab render`: render a scene to an image, with a progress bar and a one-line summary.

use super::{App, Failure, SceneArgs, si};
use crate::image::output::Grid;
use crate::render::RenderOptions;
use clap::Args;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Once;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

#[derive(Args, Debug)]
pub(crate) struct RenderArgs {
    /// Scene file (.toml, or any registered format). Omit for the bundled default scene.
    scene: Option<PathBuf>,
    /// Output image: .png, .jpg or .jpeg (8-bit, clamped and encoded), .pfm (linear float, e.g. a
    /// reference), or .exr (linear HDR floats with optional layers; feature `exr`).
    #[arg(short, long, default_value = "render.png")]
    output: PathBuf,
    /// EXR only: store colour (and normal, albedo) as 16-bit half floats instead of 32-bit.
    #[arg(long)]
    half: bool,
    /// EXR only: extra layers for denoisers, comma-separated: depth, normal, albedo.
    #[arg(long, value_delimiter = ',', value_parser = ["depth", "normal", "albedo"])]
    aov: Vec<String>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, allow_hyphen_values = true, value_parser = super::int_in::<usize>(1, super::MAX_THREADS))]
    threads: Option<usize>,
    /// Draw grid lines every N pixels over the image (the report's printGrid).
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = super::int_in::<u32>(1, u32::MAX.into()))]
    grid: Option<u32>,
    /// Grid line colour as R,G,B (0–255).
    #[arg(long, value_name = "R,G,B", allow_hyphen_values = true, default_value = "255,255,255")]
    grid_color: String,
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
            reference: None,
            error_csv: None,
            quiet: false,
            half: false,
            aov: Vec::new(),
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

pub(crate) fn run(app: &App, a: RenderArgs) -> Result<(), Failure> {
    catch_ctrl_c();
    let t0 = Instant::now();
    let grid = match a.grid {
        None => None,
        Some(0) => return Err("--grid must be at least 1".to_string().into()),
        Some(interval) => Some(Grid { interval, color: parse_rgb8(&a.grid_color)? }),
    };
    let pfm = a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("pfm"));
    let kind = if pfm { None } else { Some(crate::image::output::kind_for(&a.output).map_err(|e| e.to_string())?) };
    if kind != Some(crate::image::output::ImageKind::Exr) && (a.half || !a.aov.is_empty()) {
        return Err("--half and --aov apply to .exr output only".to_string().into());
    }
    let exr = kind == Some(crate::image::output::ImageKind::Exr);
    let layer = |name: &str| a.aov.iter().any(|s| s == name);
    let plan =
        crate::image::output::ImagePlan { exr, depth: layer("depth"), normal: layer("normal"), albedo: layer("albedo"), half: a.half };
    let (job, scene_name) = super::load(app, a.scene.as_deref(), &a.scene_args, plan)?;
    if INTERRUPTED.load(Ordering::SeqCst) {
        return Err(Failure::Interrupted("interrupted while loading: nothing rendered, nothing written".into()));
    }
    let s = job.settings;
    let reference = match &a.reference {
        Some(p) => Some(crate::image::reference::read(p, s.encoding)?),
        None => None,
    };
    let load_time = t0.elapsed();
    let bar = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let total = u64::from(s.width) * u64::from(s.height);
        let b = indicatif::ProgressBar::with_draw_target(Some(total), indicatif::ProgressDrawTarget::stderr());
        if let Ok(style) = indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent:>3}% ETA {eta} {msg}") {
            b.set_style(style.progress_chars("=> "));
        }
        b
    };
    bar.set_message(scene_name.clone());
    let options = RenderOptions { threads: a.threads, cancel: Some(&INTERRUPTED), layers: !a.aov.is_empty() };
    let mut error_log = match (&a.error_csv, &reference) {
        (Some(path), Some(r)) => Some(ErrorLog::new(path, r, s.encoding)?),
        _ => None,
    };
    let checkpoints: Vec<u32> = if error_log.is_some() { (0..32).map(|k| 1u32 << k).collect() } else { Vec::new() };
    let mut log_failure = None;
    let work = [AtomicU64::new(0), AtomicU64::new(1)];
    let cpu0 = crate::render::stats::process_cpu_time();
    let rendered = crate::render::render_progressive(
        &job,
        &options,
        &checkpoints,
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
    if let Some(e) = log_failure {
        return Err(e.into());
    }
    if !rendered.complete {
        // In the target's format, without the layers (they are complete only at the end).
        let partial = partial_path(&a.output);
        match kind {
            None => crate::image::reference::write_pfm(&partial, &rendered.film)?,
            Some(kind) => write(&job, &a, &partial, kind, &rendered.film, None, grid)?,
        }
        let done = 100.0 * work[0].load(Ordering::Relaxed) as f64 / work[1].load(Ordering::Relaxed) as f64;
        return Err(Failure::Interrupted(format!(
            "interrupted: wrote the {done:.1} % rendered so far to {} (pixels not reached are black); {} was not written",
            partial.display(),
            a.output.display()
        )));
    }
    let t_write = Instant::now();
    match kind {
        None => crate::image::reference::write_pfm(&a.output, &rendered.film)?,
        Some(kind) => write(&job, &a, &a.output, kind, &rendered.film, rendered.layers.as_ref(), grid)?,
    }
    let write_time = t_write.elapsed();
    let st = rendered.stats;
    let secs = rendered.elapsed.as_secs_f64();
    let threads = a.threads.unwrap_or_else(rayon::current_num_threads);
    let describe = job.integrator.describe();
    let accel = job.scene.accel_summary();
    let build_time = (accel.build.time + accel.object_builds.time).as_secs_f64();
    let memory = crate::render::stats::peak_memory_bytes().map_or_else(String::new, |b| format!(", peak memory {}B", si(b as f64)));
    println!(
        "wrote {} ({}×{}, {}, {}{}) from {scene_name}: trace {:.3} s{} on {threads} thread{}, {} rays, {} rays/s, {} non-finite samples (load {:.3} s, BVH build {:.3} s, write {:.3} s{memory})",
        a.output.display(),
        s.width,
        s.height,
        s.describe_sampling(),
        job.integrator_name,
        if describe.is_empty() { String::new() } else { format!(" {describe}") },
        secs,
        trace_cpu.map_or_else(String::new, |c| format!(" ({c:.3} CPU s)")),
        if threads == 1 { "" } else { "s" },
        si(st.total_rays() as f64),
        si(st.total_rays() as f64 / secs.max(1e-9)),
        st.nonfinite_samples,
        load_time.as_secs_f64() - build_time,
        build_time,
        write_time.as_secs_f64(),
    );
    println!("  {}", accel_line(&accel));
    if st.nonfinite_samples > 0 {
        eprintln!("warning: {} samples were NaN or infinite and were dropped from their pixels", st.nonfinite_samples);
    }
    if let Some(r) = &reference {
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

/// Writes the image to `path`: 8-bit PNG/JPEG, or EXR with the layers asked for (of `layers`).
#[allow(clippy::too_many_arguments)]
fn write(
    job: &crate::render::RenderJob,
    a: &RenderArgs,
    path: &Path,
    kind: crate::image::output::ImageKind,
    film: &crate::image::film::Film,
    layers: Option<&crate::image::layers::Aovs>,
    grid: Option<Grid>,
) -> Result<(), Failure> {
    #[cfg(feature = "exr")]
    if kind == crate::image::output::ImageKind::Exr {
        use crate::image::layers::{Aov, Aovs};
        let asked = |l: Aov| a.aov.iter().any(|s| Aov::parse(s) == Some(l));
        let chosen = match layers {
            Some(l) => Aovs {
                depth: l.depth.clone().filter(|_| asked(Aov::Depth)),
                normal: l.normal.clone().filter(|_| asked(Aov::Normal)),
                albedo: l.albedo.clone().filter(|_| asked(Aov::Albedo)),
            },
            None => Aovs::default(),
        };
        return crate::image::exr::write_exr(path, film, &chosen, a.half).map_err(|e| e.to_string().into());
    }
    let _ = (a, kind, layers);
    crate::image::output::write_image(path, film, job.settings.encoding, grid).map_err(|e| e.to_string().into())
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
    format!("acceleration: {objects}{unbounded}{meshes}")
}

/// Error against a reference after each pass of a progressive render, written as CSV lines as
/// they come (flushed, so the file can be watched).
struct ErrorLog<'a> {
    file: std::io::BufWriter<std::fs::File>,
    reference: &'a crate::image::film::Film,
    encoding: crate::math::color::Encoding,
}

impl<'a> ErrorLog<'a> {
    fn new(
        path: &std::path::Path,
        reference: &'a crate::image::film::Film,
        encoding: crate::math::color::Encoding,
    ) -> Result<Self, Failure> {
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
