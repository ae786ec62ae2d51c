//! `raylab sweep`: renders a scene at many settings of its quality knobs, times each render,
//! measures its error against a reference, and reports a table, CSV, JSON and a plot of error
//! against time with the Pareto front marked.

use super::plot::{Plot, Series};
use super::{App, Failure, SceneArgs, si};
use crate::image::metrics::ImageError;
use crate::load::context::LoadOptions;
use crate::param::error::{Loc, SceneError, Source};
use crate::param::value::{Node, Value};
use crate::render::film::Film;
use crate::render::{RenderJob, RenderOptions};
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub(crate) struct SweepArgs {
    /// Scene file. Omit for the bundled default scene.
    scene: Option<PathBuf>,
    /// A knob and the values to try: `spp=1,4,16`, `depth=1,3,5`, `aa_threshold=0.1,0.05`,
    /// `aa_depth=…`, `aa_edges=…`, `aa_signature=…`, `aa_cell_samples=…`, `aa_coarse=…`, `lens_samples=…`,
    /// `target_error=0.1,0.03` (with spp as the cap), `target_min_spp=…`,
    /// `aperture=…`, `integrator=phong,path`, `denoise=off,on` (the finished image denoised by
    /// Intel Open Image Denoise, guided by albedo and normal; its time counts), a light
    /// parameter as `TYPE.PARAM` for every light of that type (`environment.resolution=64,1024`),
    /// or any integrator parameter (`glossy_rays`, `shadow_rays`, `shadow_probes`,
    /// `prune_threshold`, `light_samples`, `light_selection`, `emitter_samples`, …). Repeatable.
    #[arg(long = "vary", value_name = "KNOB=V1,V2,…", required = true)]
    vary: Vec<String>,
    /// Vary one knob at a time from the base settings (the scene's, with the flags below),
    /// instead of rendering every combination.
    #[arg(long)]
    one_at_a_time: bool,
    /// The reference image: a file (.pfm or .png), or `auto` for a render at high settings,
    /// computed once and cached in the output folder.
    #[arg(long, value_name = "REF|auto", default_value = "auto")]
    reference: String,
    /// Integrator of the `auto` reference, at its reference settings (default: the scene's).
    /// `--reference-integrator path` measures each setting against a physically based image.
    #[arg(long, value_name = "NAME")]
    reference_integrator: Option<String>,
    /// Samples per pixel of the `auto` reference (at least the largest swept `spp`).
    #[arg(long, value_name = "N", default_value_t = 256, allow_hyphen_values = true, value_parser = super::int_in::<u32>(1, u32::MAX.into()))]
    reference_spp: u32,
    /// Folder for results.csv, results.json, plot.png, plot.svg and the cached reference.
    #[arg(long, value_name = "DIR", default_value = "sweep")]
    out: PathBuf,
    /// Error on the plot's y axis and for --target: `dssim` (1 − SSIM), `rmse` or `psnr`.
    #[arg(long, default_value = "dssim", value_parser = ["dssim", "rmse", "psnr"])]
    metric: String,
    /// Print, per curve, the time needed to reach this error (in --metric's units).
    #[arg(long, value_name = "ERROR", allow_hyphen_values = true)]
    target: Option<f64>,
    /// Renders per setting; the fastest counts (machines are noisy).
    #[arg(long, value_name = "N", default_value_t = 1, allow_hyphen_values = true, value_parser = super::int_in::<u32>(1, u32::MAX.into()))]
    repeat: u32,
    /// Worker threads (default: all cores).
    #[arg(long, allow_hyphen_values = true, value_parser = super::int_in::<usize>(1, super::MAX_THREADS))]
    threads: Option<usize>,
    /// Also write each setting's image (PNG) into the output folder.
    #[arg(long)]
    save_images: bool,
    /// No progress lines.
    #[arg(short, long)]
    quiet: bool,
    #[command(flatten)]
    scene_args: SceneArgs,
}

/// A knob and its values, as given by one `--vary`.
struct Knob {
    name: String,
    values: Vec<(String, Node)>,
}

/// One rendered setting and what it cost and scored.
#[derive(Serialize)]
struct Outcome {
    /// `knob=value` pairs ("base" when none).
    label: String,
    settings: Vec<(String, String)>,
    seconds: f64,
    /// Of `seconds`, the denoiser's (`denoise=on`).
    #[serde(skip_serializing_if = "Option::is_none")]
    denoise_seconds: Option<f64>,
    rays: u64,
    #[serde(flatten)]
    error: ImageError,
    dssim: f64,
    pareto: bool,
    #[serde(skip)]
    choice: Vec<(usize, usize)>,
}

pub(crate) fn run(app: &App, a: SweepArgs) -> Result<(), Failure> {
    let knobs = a.vary.iter().map(|v| parse_vary(v)).collect::<Result<Vec<_>, _>>()?;
    for (i, k) in knobs.iter().enumerate() {
        if knobs[..i].iter().any(|o| o.name == k.name) {
            return Err(format!("--vary {}: the knob is given twice", k.name).into());
        }
    }
    if a.repeat == 0 {
        return Err("--repeat must be at least 1".to_string().into());
    }
    let base = a.scene_args.load_options()?;
    let scene = a.scene.as_deref();
    let (base_job, scene_name) = super::load(app, scene, &a.scene_args, crate::image::output::ImagePlan::EIGHT_BIT)?;
    let encoding = base_job.settings.encoding;
    std::fs::create_dir_all(&a.out).map_err(|e| format!("cannot create \"{}\": {e}", a.out.display()))?;
    let options = RenderOptions { threads: a.threads, ..RenderOptions::default() };

    // Every setting, checked (loaded) before anything is rendered.
    let choices = if a.one_at_a_time { one_at_a_time(&knobs) } else { grid(&knobs) };
    let mut jobs = Vec::with_capacity(choices.len());
    let mut denoised = Vec::with_capacity(choices.len());
    for choice in &choices {
        let opts = options_for(&base, &knobs, choice)?;
        jobs.push(load_with(app, scene, &opts)?);
        denoised.push(denoise_of(&knobs, choice)?);
    }
    if denoised.contains(&true) {
        crate::image::denoise::find_tool().map_err(|e| format!("--vary denoise: {e}"))?;
    }

    // What it will cost, before it costs it.
    let mut plan = reference_plan(app, &a, &base, &knobs, &base_job)?;
    if !a.quiet {
        let mut settings = 0.0;
        for job in &mut jobs {
            settings += estimate_seconds(job, &options)? * f64::from(a.repeat);
        }
        let reference = match &mut plan {
            ReferencePlan::Render(job, _) => estimate_seconds(job, &options)?,
            ReferencePlan::Ready(_) => 0.0,
        };
        let what = match &plan {
            ReferencePlan::Render(job, _) => format!("reference ({}) ≈ {}, ", job.settings.describe_sampling(), duration(reference)),
            ReferencePlan::Ready(_) => String::new(),
        };
        eprintln!(
            "estimate: {what}{} setting{} ≈ {}; total ≈ {} (from probe renders at 1/{} size; Ctrl-C stops)",
            jobs.len(),
            if jobs.len() == 1 { "" } else { "s" },
            duration(settings),
            duration(settings + reference),
            PROBE_SCALE * PROBE_SCALE
        );
    }
    let (reference, reference_seconds) = match plan {
        ReferencePlan::Ready(film) => (film, None),
        ReferencePlan::Render(job, path) => render_reference(&a, &job, &path, &options)?,
    };
    let (w, h) = (base_job.settings.width, base_job.settings.height);
    if (reference.width, reference.height) != (w, h) {
        return Err(format!("the reference is {}×{} but the scene renders {w}×{h}", reference.width, reference.height).into());
    }

    let mut outcomes = Vec::with_capacity(jobs.len());
    let count = jobs.len();
    for (i, (job, choice)) in jobs.iter_mut().zip(&choices).enumerate() {
        let settings: Vec<(String, String)> = choice.iter().map(|&(k, v)| (knobs[k].name.clone(), knobs[k].values[v].0.clone())).collect();
        let label = if settings.is_empty() {
            "base".to_string()
        } else {
            settings.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(" ")
        };
        if !a.quiet {
            eprint!("[{}/{}] {label} … ", i + 1, count);
        }
        let denoise = denoised[i];
        let options = RenderOptions { layers: denoise, ..options };
        // The fastest of the repeats, the denoiser's time included.
        let mut best: Option<(crate::render::Rendered, Option<std::time::Duration>)> = None;
        // Denoised as `render --denoise` does: on a finer grid where it can.
        let (pixels, grid) = (job.settings, if denoise { crate::image::denoise::grid(&job.settings) } else { 1 });
        for _ in 0..a.repeat {
            job.settings = crate::image::denoise::fine_settings(&pixels, grid);
            let rendered = crate::render::render(job, &options, &|_, _| {});
            job.settings = pixels;
            let mut r = rendered?;
            let denoise_time = if denoise {
                let t = std::time::Instant::now();
                crate::image::denoise::denoise_rendered(&mut r, &pixels, grid, crate::image::denoise::guides_are_clean(job))?;
                Some(t.elapsed())
            } else {
                None
            };
            let total = |r: &crate::render::Rendered, d: Option<std::time::Duration>| r.elapsed + d.unwrap_or_default();
            if best.as_ref().is_none_or(|(b, bd)| total(&r, denoise_time) < total(b, *bd)) {
                best = Some((r, denoise_time));
            }
        }
        let (r, denoise_time) = best.expect("repeat ≥ 1");
        let error = crate::image::metrics::compare(&r.film, &reference, encoding)?;
        if a.save_images {
            let name = format!("{}.png", file_safe(&label));
            crate::image::output::write_image(&a.out.join(name), &r.film, encoding, None).map_err(|e| e.to_string())?;
        }
        let seconds = (r.elapsed + denoise_time.unwrap_or_default()).as_secs_f64();
        if !a.quiet {
            eprintln!("{seconds:.3} s, SSIM {:.4}", error.ssim);
        }
        outcomes.push(Outcome {
            label,
            settings,
            seconds,
            denoise_seconds: denoise_time.map(|d| d.as_secs_f64()),
            rays: r.stats.total_rays(),
            error,
            dssim: error.dssim(),
            pareto: false,
            choice: choice.clone(),
        });
    }

    let metric = Metric::parse(&a.metric);
    let front = mark_pareto(&mut outcomes, metric);
    print!("{}", table(&outcomes));
    write_csv(&a.out.join("results.csv"), &knobs, &outcomes)?;
    let json = serde_json::json!({
        "scene": scene_name,
        "size": [w, h],
        "reference": a.reference,
        "reference_integrator": a.reference_integrator.as_deref().unwrap_or(&base_job.integrator_name),
        "reference_spp": a.reference_spp,
        "reference_seconds": reference_seconds,
        "mode": if a.one_at_a_time { "one-at-a-time" } else { "grid" },
        "metric": a.metric,
        "results": outcomes,
    });
    let text = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?;
    crate::image::write::write_atomically(&a.out.join("results.json"), |f| f.write_all(text.as_bytes()).map_err(|e| e.to_string()))
        .map_err(|e| e.to_string())?;

    let series = curves(&knobs, &outcomes, metric, a.one_at_a_time);
    let plot = Plot {
        title: format!("{} ({w}×{h}): error against time", scene_title(&scene_name)),
        y_label: metric.axis_label().into(),
        log_y: metric != Metric::Psnr,
        series: &series,
        pareto: &front,
    };
    super::plot::write_png(&a.out.join("plot.png"), &plot)?;
    super::plot::write_svg(&a.out.join("plot.svg"), &plot)?;
    if let Some(target) = a.target {
        println!("time to reach {} {target}:", metric.name());
        for s in &series {
            println!("  {:<28}{}", s.name, time_to_reach(&s.points, target, metric));
        }
    }
    println!("wrote {}/results.csv, results.json, plot.png, plot.svg", a.out.display());
    Ok(())
}

/// The error a plot and a target use; lower is better for all but PSNR.
#[derive(Clone, Copy, PartialEq)]
enum Metric {
    Dssim,
    Rmse,
    Psnr,
}

impl Metric {
    fn parse(s: &str) -> Metric {
        match s {
            "rmse" => Metric::Rmse,
            "psnr" => Metric::Psnr,
            _ => Metric::Dssim,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Metric::Dssim => "1 − SSIM",
            Metric::Rmse => "RMSE",
            Metric::Psnr => "PSNR",
        }
    }
    fn axis_label(self) -> &'static str {
        match self {
            Metric::Dssim => "1 − SSIM against the reference (log)",
            Metric::Rmse => "RMSE against the reference (log)",
            Metric::Psnr => "PSNR against the reference, dB",
        }
    }
    fn of(self, e: &ImageError) -> f64 {
        match self {
            Metric::Dssim => e.dssim(),
            Metric::Rmse => e.rmse,
            Metric::Psnr => e.psnr,
        }
    }
    /// True when `a` is at least as good as `b`.
    fn no_worse(self, a: f64, b: f64) -> bool {
        if self == Metric::Psnr { a >= b } else { a <= b }
    }
}

/// Parses `KNOB=V1,V2,…`. Values are TOML values; a bare word is a string.
fn parse_vary(s: &str) -> Result<Knob, Failure> {
    let src = Source::new("--vary", s.to_string());
    let Some(eq) = s.find('=') else {
        return Err(SceneError::at(&Loc::new(&src, 0..s.len()), "expected KNOB=V1,V2,…").into());
    };
    let name = s[..eq].trim().to_string();
    let mut values = Vec::new();
    let mut start = eq + 1;
    let mut depth = 0i32;
    for (i, ch) in s.char_indices().skip(eq + 1).chain(std::iter::once((s.len(), ','))) {
        match ch {
            '[' | '{' => depth += 1,
            ']' | '}' => depth -= 1,
            ',' if depth == 0 => {
                let text = s[start..i].trim();
                let lead = s[start..i].len() - s[start..i].trim_start().len();
                let range = start + lead..start + lead + text.len();
                if text.is_empty() {
                    return Err(SceneError::at(&Loc::new(&src, range), format!("--vary {name}: empty value")).into());
                }
                let node = match crate::param::toml::parse_toml_value(&src, range.clone()) {
                    Ok(n) => n,
                    Err(_) if text.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') => {
                        Node { value: Value::Str(text.to_string()), loc: Loc::new(&src, range) }
                    }
                    Err(e) => return Err(e.into()),
                };
                values.push((text.to_string(), node));
                start = i + 1;
            }
            _ => {}
        }
    }
    Ok(Knob { name, values })
}

/// Every combination of knob values, the first knob varying fastest.
fn grid(knobs: &[Knob]) -> Vec<Vec<(usize, usize)>> {
    let mut out = vec![Vec::new()];
    for (k, knob) in knobs.iter().enumerate() {
        out = out
            .into_iter()
            .flat_map(|c: Vec<(usize, usize)>| (0..knob.values.len()).map(move |v| [c.clone(), vec![(k, v)]].concat()))
            .collect();
    }
    // Regroup so the first knob varies fastest (curves run along it).
    out.sort_by_key(|c| c.iter().rev().map(|&(_, v)| v).collect::<Vec<_>>());
    out
}

/// The base setting, then each knob's values alone.
fn one_at_a_time(knobs: &[Knob]) -> Vec<Vec<(usize, usize)>> {
    let mut out = vec![Vec::new()];
    for (k, knob) in knobs.iter().enumerate() {
        out.extend((0..knob.values.len()).map(|v| vec![(k, v)]));
    }
    out
}

/// The knob that is not a load option: whether the finished image is denoised.
const DENOISE: &str = "denoise";

/// Whether `choice` denoises: `denoise=on` (or `true`); `off` or `false`, or no such knob: not.
fn denoise_of(knobs: &[Knob], choice: &[(usize, usize)]) -> Result<bool, Failure> {
    for &(k, v) in choice {
        if knobs[k].name == DENOISE {
            let node = &knobs[k].values[v].1;
            return match &node.value {
                Value::Bool(b) => Ok(*b),
                Value::Str(s) if s == "on" => Ok(true),
                Value::Str(s) if s == "off" => Ok(false),
                _ => Err(SceneError::at(&node.loc, "denoise is off or on").into()),
            };
        }
    }
    Ok(false)
}

/// The base load options with the chosen knob values applied.
fn options_for(base: &LoadOptions, knobs: &[Knob], choice: &[(usize, usize)]) -> Result<LoadOptions, Failure> {
    let mut o = base.clone();
    for &(k, v) in choice.iter().filter(|&&(k, _)| knobs[k].name != DENOISE) {
        crate::load::context::apply_knob(&mut o, "--vary", &knobs[k].name, &knobs[k].values[v].1)?;
    }
    Ok(o)
}

fn load_with(app: &App, scene: Option<&Path>, opts: &LoadOptions) -> Result<RenderJob, Failure> {
    match scene {
        Some(p) => Ok(crate::load::loader::load_file(&app.registry, p, opts)?),
        None => {
            let (name, text) = app.default_scene;
            Ok(crate::load::loader::load_str(&app.registry, name, text, Path::new("."), opts)?)
        }
    }
}

/// Where the reference image comes from.
enum ReferencePlan {
    /// Read (a file given, or cached by an earlier sweep).
    Ready(Film),
    /// To be rendered with this job and cached at this path.
    Render(Box<RenderJob>, PathBuf),
}

/// The reference image: read from a file, or to be rendered at high settings by the scene's
/// integrator or `--reference-integrator` (cached by a hash of the scene, its settings, the
/// integrator and raylab's version).
fn reference_plan(app: &App, a: &SweepArgs, base: &LoadOptions, knobs: &[Knob], base_job: &RenderJob) -> Result<ReferencePlan, Failure> {
    if a.reference != "auto" {
        if a.reference_integrator.is_some() {
            return Err("--reference-integrator sets the integrator of `--reference auto`; it cannot change a reference image"
                .to_string()
                .into());
        }
        return Ok(ReferencePlan::Ready(crate::image::reference::read(Path::new(&a.reference), base_job.settings.encoding)?));
    }
    let mut o = base.clone();
    // The reference's worst case (every ray splitting at every bounce, to depth 12) is far above
    // what it costs; the estimate printed before it starts says that (so not under -q, which
    // hides it). A --max-rays given still holds.
    if a.scene_args.max_rays.is_none() && !a.quiet {
        o.limits.max_rays = u64::MAX;
    }
    let integrator = a.reference_integrator.as_deref().unwrap_or(&base_job.integrator_name);
    let swept =
        |name: &str| knobs.iter().find(|k| k.name == name).map(|k| k.values.iter().map(|(_, n)| n.value.clone()).collect::<Vec<_>>());
    app.registry.reference_options(&mut o, &base_job.integrator_name, integrator, &swept, a.reference_spp);
    let job = load_with(app, a.scene.as_deref(), &o)?;
    let scene_text = match a.scene.as_deref() {
        Some(p) => crate::load::context::read_user_file(p, "scene file", base.limits.max_file_bytes, None)?,
        None => app.default_scene.1.as_bytes().to_vec(),
    };
    let settings = format!("{:?}|{}|{:?}|{}", job.settings, job.integrator_name, job.integrator.describe(), env!("CARGO_PKG_VERSION"));
    let key = hash(&[&scene_text, settings.as_bytes()]);
    let path = a.out.join(format!("reference-{key:016x}.pfm"));
    if let Ok(film) = crate::image::reference::read(&path, job.settings.encoding) {
        if !a.quiet {
            eprintln!("reference: cached {} ({})", path.display(), job.settings.describe_sampling());
        }
        return Ok(ReferencePlan::Ready(film));
    }
    Ok(ReferencePlan::Render(Box::new(job), path))
}

/// Renders the reference `job` and caches it at `path`; the image and the seconds it took.
fn render_reference(a: &SweepArgs, job: &RenderJob, path: &Path, options: &RenderOptions) -> Result<(Film, Option<f64>), Failure> {
    if !a.quiet {
        eprint!("reference: rendering {} with {}, {} … ", job.settings.describe_sampling(), job.integrator_name, job.integrator.describe());
    }
    let r = crate::render::render(job, options, &|_, _| {})?;
    if !a.quiet {
        eprintln!("{:.1} s, {} rays", r.elapsed.as_secs_f64(), si(r.stats.total_rays() as f64));
    }
    crate::image::reference::write_pfm(path, &r.film)?;
    Ok((r.film, Some(r.elapsed.as_secs_f64())))
}

/// Linear size of the estimate's probe: 1/PROBE_SCALE of the width and height.
const PROBE_SCALE: u32 = 4;

/// Most samples per pixel the probe traces (its time is scaled to the job's).
const PROBE_SPP: u32 = 4;

/// The expected seconds of rendering `job`: the time of a probe render at 1/[`PROBE_SCALE`] of the
/// size and at most [`PROBE_SPP`] samples per pixel, scaled by the pixels and samples it skipped.
/// Adaptive anti-aliasing is probed as it is; the smaller image has more edges per pixel, so its
/// estimate errs high.
fn estimate_seconds(job: &mut RenderJob, options: &RenderOptions) -> Result<f64, Failure> {
    let full = job.settings;
    let (w, h) = (full.width.div_ceil(PROBE_SCALE), full.height.div_ceil(PROBE_SCALE));
    let spp = full.spp.min(PROBE_SPP);
    job.settings = crate::render::RenderSettings { width: w, height: h, spp, ..full };
    let probe = crate::render::render(job, options, &|_, _| {});
    job.settings = full;
    let probe = probe?;
    let pixels = f64::from(full.width) * f64::from(full.height) / (f64::from(w) * f64::from(h));
    let samples = match full.aa {
        crate::render::Antialiasing::Stratified => f64::from(full.spp) / f64::from(spp),
        crate::render::Antialiasing::Adaptive(_) => 1.0,
    };
    Ok(probe.elapsed.as_secs_f64() * pixels * samples)
}

/// `93.4` → `1 min 33 s`.
fn duration(seconds: f64) -> String {
    if seconds < 60.0 {
        format!("{seconds:.1} s")
    } else if seconds < 3600.0 {
        format!("{} min {:02} s", (seconds / 60.0) as u64, seconds as u64 % 60)
    } else {
        format!("{} h {:02} min", (seconds / 3600.0) as u64, (seconds as u64 % 3600) / 60)
    }
}

/// A 64-bit hash of byte strings (for cache names, not security).
fn hash(parts: &[&[u8]]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for p in parts {
        for &b in *p {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        h = crate::math::sampler::mix64(h);
    }
    h
}

/// Marks the settings no other beats in both time and error; returns them by increasing time.
fn mark_pareto(outcomes: &mut [Outcome], metric: Metric) -> Vec<(f64, f64)> {
    let mut order: Vec<usize> = (0..outcomes.len()).collect();
    order.sort_by(|&i, &j| outcomes[i].seconds.total_cmp(&outcomes[j].seconds));
    let mut front = Vec::new();
    let mut best: Option<f64> = None;
    for i in order {
        let e = metric.of(&outcomes[i].error);
        if !e.is_finite() && metric != Metric::Psnr {
            continue;
        }
        if best.is_none_or(|b| metric.no_worse(e, b) && e != b) {
            best = Some(e);
            outcomes[i].pareto = true;
            front.push((outcomes[i].seconds, e));
        }
    }
    front
}

/// The curves: one per knob (one at a time), or one per combination of the other knobs (grid),
/// each running along the first knob's values.
fn curves(knobs: &[Knob], outcomes: &[Outcome], metric: Metric, one_at_a_time: bool) -> Vec<Series> {
    let mut series: Vec<Series> = Vec::new();
    for o in outcomes {
        let name = if one_at_a_time {
            match o.choice.first() {
                Some(&(k, _)) => knobs[k].name.clone(),
                None => continue,
            }
        } else {
            let rest: Vec<String> = o.choice.iter().skip(1).map(|&(k, v)| format!("{}={}", knobs[k].name, knobs[k].values[v].0)).collect();
            let first = o.choice.first().map_or(String::new(), |&(k, _)| knobs[k].name.clone());
            if rest.is_empty() { first } else { format!("{first} ({})", rest.join(", ")) }
        };
        let p = (o.seconds, metric.of(&o.error));
        match series.iter_mut().find(|s| s.name == name) {
            Some(s) => s.points.push(p),
            None => series.push(Series { name, points: vec![p] }),
        }
    }
    series
}

/// When a curve first reaches `target` (log-log interpolation between the bracketing settings,
/// taken in order of time).
fn time_to_reach(points: &[(f64, f64)], target: f64, metric: Metric) -> String {
    let mut pts = points.to_vec();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (i, &(t, e)) in pts.iter().enumerate() {
        if metric.no_worse(e, target) {
            if i == 0 {
                return format!("{t:.3} s (already at its fastest setting)");
            }
            let (t0, e0) = pts[i - 1];
            let f = if metric == Metric::Psnr { (target - e0) / (e - e0) } else { (target.ln() - e0.ln()) / (e.ln() - e0.ln()) };
            let time = (t0.ln() + f.clamp(0.0, 1.0) * (t.ln() - t0.ln())).exp();
            return format!("{time:.3} s");
        }
    }
    let best = pts.iter().map(|p| p.1).fold(None, |b: Option<f64>, e| Some(b.map_or(e, |b| if metric.no_worse(e, b) { e } else { b })));
    format!("not reached (best {:.4})", best.unwrap_or(f64::NAN))
}

fn table(outcomes: &[Outcome]) -> String {
    let width = outcomes.iter().map(|o| o.label.chars().count()).max().unwrap_or(4).max(7);
    let mut s = format!(
        "{:<width$}  {:>9}  {:>9}  {:>9}  {:>8}  {:>8}  {:>9}  pareto\n",
        "setting", "time s", "rays", "RMSE", "PSNR dB", "SSIM", "1 − SSIM"
    );
    for o in outcomes {
        s += &format!(
            "{:<width$}  {:>9.3}  {:>9}  {:>9.5}  {:>8.2}  {:>8.5}  {:>9.5}  {}\n",
            o.label,
            o.seconds,
            si(o.rays as f64),
            o.error.rmse,
            o.error.psnr,
            o.error.ssim,
            o.dssim,
            if o.pareto { "*" } else { "" }
        );
    }
    s
}

fn write_csv(path: &Path, knobs: &[Knob], outcomes: &[Outcome]) -> Result<(), Failure> {
    let mut text = knobs.iter().map(|k| k.name.clone()).collect::<Vec<_>>().join(",");
    text += if knobs.is_empty() { "" } else { "," };
    text += "seconds,rays,rmse,psnr_db,ssim,dssim,pareto\n";
    for o in outcomes {
        for k in knobs {
            let v = o.settings.iter().find(|(n, _)| *n == k.name).map_or("", |(_, v)| v.as_str());
            text += &csv_field(v);
            text += ",";
        }
        text += &format!(
            "{:.6},{},{:.6e},{:.4},{:.6},{:.6e},{}\n",
            o.seconds, o.rays, o.error.rmse, o.error.psnr, o.error.ssim, o.dssim, o.pareto
        );
    }
    crate::image::write::write_atomically(path, |f| f.write_all(text.as_bytes()).map_err(|e| e.to_string()))
        .map_err(|e| e.to_string().into())
}

fn csv_field(v: &str) -> String {
    if v.contains([',', '"', '\n']) { format!("\"{}\"", v.replace('"', "\"\"")) } else { v.to_string() }
}

/// `spp=4 depth=3` → `spp-4_depth-3`.
fn file_safe(label: &str) -> String {
    label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' {
                c
            } else if c == '=' {
                '-'
            } else {
                '_'
            }
        })
        .collect()
}

/// `scenes/showcase.toml (bundled)` → `showcase`.
fn scene_title(name: &str) -> String {
    let first = name.split_whitespace().next().unwrap_or(name);
    Path::new(first).file_stem().map_or(first.to_string(), |s| s.to_string_lossy().into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vary_values_split_at_top_level_commas_and_accept_words() {
        let k = parse_vary("aa=stratified, adaptive").unwrap();
        assert_eq!(k.values.iter().map(|v| v.0.as_str()).collect::<Vec<_>>(), ["stratified", "adaptive"]);
        let k = parse_vary("x=[1, 2],3").unwrap();
        assert_eq!(k.values.len(), 2);
        assert!(matches!(k.values[1].1.value, Value::Int(3)));
        assert!(parse_vary("spp").is_err());
        assert!(parse_vary("spp=1,,2").is_err());
    }

    #[test]
    fn grid_runs_along_the_first_knob() {
        let knobs = [parse_vary("spp=1,4").unwrap(), parse_vary("depth=1,2,3").unwrap()];
        let g = grid(&knobs);
        assert_eq!(g.len(), 6);
        assert_eq!(g[0], vec![(0, 0), (1, 0)]);
        assert_eq!(g[1], vec![(0, 1), (1, 0)]);
        assert_eq!(one_at_a_time(&knobs).len(), 6);
    }

    fn outcome(seconds: f64, dssim: f64) -> Outcome {
        Outcome {
            label: String::new(),
            settings: Vec::new(),
            seconds,
            denoise_seconds: None,
            rays: 0,
            error: ImageError { rmse: dssim, psnr: 0.0, ssim: 1.0 - dssim },
            dssim,
            pareto: false,
            choice: Vec::new(),
        }
    }

    #[test]
    fn pareto_front_keeps_only_unbeaten_settings() {
        let mut o = vec![outcome(1.0, 0.1), outcome(2.0, 0.2), outcome(3.0, 0.05), outcome(0.5, 0.3)];
        let front = mark_pareto(&mut o, Metric::Rmse);
        assert_eq!(front, vec![(0.5, 0.3), (1.0, 0.1), (3.0, 0.05)]);
        assert_eq!(o.iter().map(|x| x.pareto).collect::<Vec<_>>(), [true, false, true, true]);
    }

    #[test]
    fn time_to_reach_interpolates_in_log_log() {
        let pts = [(1.0, 0.1), (4.0, 0.001)];
        assert_eq!(time_to_reach(&pts, 0.01, Metric::Rmse), "2.000 s");
        assert!(time_to_reach(&pts, 1e-4, Metric::Rmse).starts_with("not reached"));
    }
}
