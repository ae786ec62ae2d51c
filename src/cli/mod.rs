//! The `raylab` command line, as a library: a binary builds a [`Registry`] (the built-in plugins,
//! plus any of its own) and calls [`run`]. The built-in `raylab` binary and a third-party
//! plugin's binary therefore share one interface. One file per subcommand.

mod bench;
mod convert;
mod denoise;
mod dispatch;
mod farm;
mod fingerprint;
mod merge;
mod plot;
mod plugins;
mod render;
mod sweep;
mod tonemap;
mod trace;
#[cfg(feature = "view")]
mod view;

use crate::load::context::{LoadOptions, Overrides};
use crate::load::registry::Registry;
use crate::param::error::SceneError;
use crate::param::value::{Node, Value};
use crate::render::RenderJob;
use clap::Args;
use std::path::Path;

pub use dispatch::{run, run_with_args};
pub use render::stats_table;
#[cfg(feature = "exr")]
pub use render::{checkpoint_fuzz_scenes, fuzz_checkpoint};

/// What a binary brings to the CLI: its plugins and its default scene.
pub struct App {
    /// All plugins the binary offers.
    pub registry: Registry,
    /// The scene rendered when `raylab` runs without arguments: (display name, TOML text).
    pub default_scene: (&'static str, &'static str),
}

/// Options shared by every command that loads a scene: overrides of the scene's settings, and
/// the limits and path policy for untrusted scenes.
#[derive(Args, Debug, Default, Clone)]
pub(crate) struct SceneArgs {
    /// Image width in pixels (overrides the scene).
    #[arg(long, allow_hyphen_values = true, value_parser = int_in::<u32>(1, u32::MAX.into()))]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene).
    #[arg(long, allow_hyphen_values = true, value_parser = int_in::<u32>(1, u32::MAX.into()))]
    height: Option<u32>,
    /// Samples per pixel (overrides the scene).
    #[arg(long, allow_hyphen_values = true, value_parser = int_in::<u32>(1, u32::MAX.into()))]
    spp: Option<u32>,
    /// Maximum recursion depth (sets the integrator's depth parameter, whatever its name:
    /// `max_depth` for phong, `max_bounces` for path).
    #[arg(long, allow_hyphen_values = true)]
    depth: Option<i64>,
    /// Random seed (overrides the scene).
    #[arg(long, allow_hyphen_values = true, value_parser = int_in::<u64>(0, u64::MAX.into()))]
    seed: Option<u64>,
    /// Integrator type, replacing the scene's (e.g. `path`, `normals`, `depth`).
    #[arg(long)]
    integrator: Option<String>,
    /// Set an integrator parameter: `--set max_depth=5`, `--set ambient=first_hit` (value in TOML
    /// syntax, or a bare word for a string; repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Anti-aliasing: `stratified` (--spp samples per pixel) or `adaptive` (refinement where
    /// neighbouring samples disagree: edges located by bisection, squares subdivided).
    #[arg(long, value_parser = ["stratified", "adaptive"])]
    aa: Option<String>,
    /// Adaptive anti-aliasing: refine a pixel whose corners' displayed values (0..1) differ by
    /// more than this (a square of side s pixels: more than T / s^1.5).
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    aa_threshold: Option<f64>,
    /// Adaptive anti-aliasing: most subdivision levels per pixel (0–8).
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    aa_depth: Option<i64>,
    /// Adaptive anti-aliasing: locate edges by bisection (true, the default) or only subdivide.
    #[arg(long, value_name = "BOOL")]
    aa_edges: Option<bool>,
    /// Filter textures over each pixel's footprint (true, the default) or look them up at a
    /// point (false): `[render] texture_filter`.
    #[arg(long, value_name = "BOOL")]
    texture_filter: Option<bool>,
    /// Adaptive anti-aliasing: also refine where the corners' rays saw different objects.
    #[arg(long, value_name = "BOOL")]
    aa_signature: Option<bool>,
    /// Adaptive anti-aliasing: stratified samples inside each finest cell still unresolved (0–64).
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    aa_cell_samples: Option<i64>,
    /// Adaptive anti-aliasing: levels above the pixel tested first (0–3): blocks of 2^N pixels
    /// whose corners agree are interpolated from four rays.
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    aa_coarse: Option<i64>,
    /// Rays through distinct lens points per image sample (depth of field).
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    lens_samples: Option<i64>,
    /// Adaptive sampling: stop each pixel once the estimated error of its mean (relative, at
    /// luminance 1; over √mean) is at most E × √(samples / --target-min-spp) (e.g. 0.05), so
    /// samples go in proportion to each pixel's noise; --spp is then the most samples a pixel
    /// takes (stratified sampling). A relative RMSE in (0, 1].
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    target_error: Option<f64>,
    /// With --target-error: samples every pixel takes before its error is first tested (≥ 2).
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    target_min_spp: Option<i64>,
    /// Trace for at most this many seconds: the image refines in passes that double each pixel's
    /// samples (--spp is the most a pixel takes) and keeps what it has when the time is up. With
    /// `--aov spp` (EXR) the samples each pixel reached are recorded: `--spp-map FILE` repeats it.
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true)]
    time_budget: Option<f64>,
    /// Lens radius for depth of field, scene units (overrides the camera's `aperture`).
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    aperture: Option<f64>,
    /// Distance of the plane in focus, scene units (overrides the camera's `focus_distance`).
    #[arg(long, value_name = "D", allow_hyphen_values = true)]
    focus_distance: Option<f64>,
    /// Set a camera parameter: `--camera position=[0,0,10]` (value in TOML syntax; repeatable).
    /// Supplies the camera of a scene that has none (e.g. a report XML scene without <camera>).
    /// `--camera fit` frames the whole scene, replacing the file's position and target.
    #[arg(long = "camera", value_name = "KEY=VALUE")]
    camera: Vec<String>,
    /// 8-bit encoding: `srgb` (default), `linear` (clamped values written straight, as the report)
    /// or `linear-truncated` (straight and truncated, as the course's Java renderer).
    #[arg(long, value_parser = crate::math::color::Encoding::NAMES)]
    encoding: Option<String>,
    /// Spatial index for the objects and each mesh: `auto` (a BVH when there are enough to pay
    /// for it), `bvh` or `list`.
    #[arg(long, value_parser = ["auto", "bvh", "list"], default_value = "auto")]
    accel: String,
    /// Let the scene read files outside its own folder.
    #[arg(long)]
    allow_outside_paths: bool,
    /// Largest image in pixels (width × height) the scene may ask for.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = int_in::<u64>(0, u64::MAX.into()))]
    max_pixels: Option<u64>,
    /// Largest image side in pixels.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = int_in::<u32>(0, u32::MAX.into()))]
    max_side: Option<u32>,
    /// Most samples per pixel the scene may ask for.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = int_in::<u32>(0, u32::MAX.into()))]
    max_spp: Option<u32>,
    /// Deepest recursion the scene may ask for.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = int_in::<u32>(0, u32::MAX.into()))]
    max_depth_limit: Option<u32>,
    /// Largest file (bytes) the scene may make raylab read.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = int_in::<u64>(0, u64::MAX.into()))]
    max_file_bytes: Option<u64>,
    /// Most triangles one mesh object may have.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = int_in::<u64>(0, u64::MAX.into()))]
    max_triangles: Option<u64>,
    /// Most memory (bytes) the image may take: film, EXR layers and the encoder's copies,
    /// estimated before rendering for the costliest output (EXR with every layer).
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true, value_parser = int_in::<u64>(0, u64::MAX.into()))]
    max_image_bytes: Option<u64>,
    /// Most rays the render may trace: enforced as rays are traced (the render stops with the
    /// image so far and the count), and checked before it starts (camera rays alone, a bound from
    /// the scene's materials and pruning, then a pilot of 64 pixels when the bound is over).
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = int_in::<u64>(0, u64::MAX.into()))]
    max_rays: Option<u64>,
    /// Most memory (bytes) the whole job may take, as estimated before each large allocation:
    /// the parsed scene, objects, meshes with their hierarchies, glTF instances and the image.
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true, value_parser = int_in::<u64>(0, u64::MAX.into()))]
    max_memory: Option<u64>,
}

/// A user-facing failure: a located scene error, a plain message, or an interrupted render.
#[derive(Debug)]
pub(crate) enum Failure {
    Scene(SceneError),
    Other(String),
    /// Stopped by Ctrl-C; exit status 130 (128 + SIGINT), as shells report it.
    Interrupted(String),
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::Scene(e) => f.write_str(&e.report()),
            Failure::Other(s) | Failure::Interrupted(s) => f.write_str(s),
        }
    }
}

impl From<SceneError> for Failure {
    fn from(e: SceneError) -> Self {
        Failure::Scene(e)
    }
}

impl From<String> for Failure {
    fn from(e: String) -> Self {
        Failure::Other(e)
    }
}

impl SceneArgs {
    /// The load options these arguments ask for.
    pub(crate) fn load_options(&self) -> Result<LoadOptions, Failure> {
        let mut params = Vec::new();
        params.extend(key_values("--set", &self.set)?);
        let mut render_params = Vec::new();
        if let Some(v) = &self.aa {
            render_params.push(flag_node("--aa", "aa", Value::Str(v.clone())));
        }
        if let Some(v) = self.aa_threshold {
            render_params.push(flag_node("--aa-threshold", "aa_threshold", Value::Float(v)));
        }
        if let Some(v) = self.aa_depth {
            render_params.push(flag_node("--aa-depth", "aa_depth", Value::Int(v)));
        }
        if let Some(v) = self.aa_edges {
            render_params.push(flag_node("--aa-edges", "aa_edges", Value::Bool(v)));
        }
        if let Some(v) = self.texture_filter {
            render_params.push(flag_node("--texture-filter", "texture_filter", Value::Bool(v)));
        }
        if let Some(v) = self.aa_signature {
            render_params.push(flag_node("--aa-signature", "aa_signature", Value::Bool(v)));
        }
        if let Some(v) = self.aa_cell_samples {
            render_params.push(flag_node("--aa-cell-samples", "aa_cell_samples", Value::Int(v)));
        }
        if let Some(v) = self.aa_coarse {
            render_params.push(flag_node("--aa-coarse", "aa_coarse", Value::Int(v)));
        }
        if let Some(v) = self.lens_samples {
            render_params.push(flag_node("--lens-samples", "lens_samples", Value::Int(v)));
        }
        if let Some(v) = self.target_error {
            render_params.push(flag_node("--target-error", "target_error", Value::Float(v)));
        }
        if let Some(v) = self.target_min_spp {
            render_params.push(flag_node("--target-min-spp", "target_min_spp", Value::Int(v)));
        }
        if let Some(v) = self.time_budget {
            render_params.push(flag_node("--time-budget", "time_budget", Value::Float(v)));
        }
        // `--camera fit` alone: frame the scene (the camera's `fit = true`).
        let (fit, camera): (Vec<String>, Vec<String>) = self.camera.iter().cloned().partition(|c| c.trim() == "fit");
        let mut camera_params = key_values("--camera", &camera)?;
        if !fit.is_empty() {
            camera_params.push(flag_node("--camera", "fit", Value::Bool(true)));
        }
        if let Some(v) = self.aperture {
            camera_params.push(flag_node("--aperture", "aperture", Value::Float(v)));
        }
        if let Some(v) = self.focus_distance {
            camera_params.push(flag_node("--focus-distance", "focus_distance", Value::Float(v)));
        }
        let mut limits = crate::param::limits::Limits::default();
        if let Some(v) = self.max_pixels {
            limits.max_pixels = v;
        }
        if let Some(v) = self.max_side {
            limits.max_side = v;
        }
        if let Some(v) = self.max_spp {
            limits.max_spp = v;
        }
        if let Some(v) = self.max_depth_limit {
            limits.max_depth = v;
        }
        if let Some(v) = self.max_file_bytes {
            limits.max_file_bytes = v;
        }
        if let Some(v) = self.max_triangles {
            limits.max_triangles = v;
        }
        if let Some(v) = self.max_image_bytes {
            limits.max_image_bytes = v;
        }
        if let Some(v) = self.max_rays {
            limits.max_rays = v;
        }
        if let Some(v) = self.max_memory {
            limits.max_memory = v;
        }
        Ok(LoadOptions {
            overrides: Overrides {
                width: self.width,
                height: self.height,
                spp: self.spp,
                seed: self.seed,
                encoding: self.encoding.as_deref().and_then(crate::math::color::Encoding::parse),
                integrator: self.integrator.clone(),
                integrator_params: params,
                depth: self.depth.map(|d| flag_node("--depth", "depth", Value::Int(d)).1),
                render_params,
                camera_params,
                light_params: Vec::new(),
            },
            limits,
            allow_outside_paths: self.allow_outside_paths,
            accel: crate::accel::AccelChoice::parse(&self.accel).unwrap_or_default(),
            image: crate::image::output::ImagePlan::default(),
            open_log: None,
        })
    }
}

/// Most worker threads `--threads` may ask for.
pub(crate) const MAX_THREADS: i128 = 4096;

/// Value parser of an integer option in `lo..=hi`. Options take it with `allow_hyphen_values`, so
/// a negative number reaches it and gets a range error naming the option (clap's message names
/// it: "invalid value '-1' for '--seed <SEED>': …"), instead of "unexpected argument '-1'".
pub(crate) fn int_in<T: TryFrom<i128>>(lo: i128, hi: i128) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static {
    move |text| {
        let range = || format!("expected an integer in {lo}..={hi}");
        let v: i128 = text.trim().parse().map_err(|_| range())?;
        if v < lo || v > hi {
            return Err(format!("{v} is out of range; {}", range()));
        }
        T::try_from(v).map_err(|_| range())
    }
}

/// A setting given by command-line flag `flag`, as the scene key `key` with a location naming the flag.
pub(crate) fn flag_node(flag: &str, key: &str, value: Value) -> (String, Node) {
    (key.to_string(), Node::given(flag, value))
}

/// Parses repeated `KEY=VALUE` options of option `flag`: the value in TOML syntax, or a bare word
/// (`--set ambient=first_hit`) taken as a string, as the shell leaves it once it has eaten quotes.
fn key_values(flag: &str, items: &[String]) -> Result<Vec<(String, Node)>, Failure> {
    Ok(items.iter().map(|s| crate::load::context::key_value(flag, s)).collect::<Result<_, _>>()?)
}

/// Loads `scene` (or the app's default scene) with the options in `a`; returns the job and a
/// display name.
/// Load warnings are printed to standard error.
/// `image` is what the command will write, for the image's memory budget.
pub(crate) fn load(
    app: &App,
    scene: Option<&Path>,
    a: &SceneArgs,
    image: crate::image::output::ImagePlan,
) -> Result<(RenderJob, String), Failure> {
    let opts = LoadOptions { image, ..a.load_options()? };
    let (job, name) = match scene {
        Some(p) => (crate::load::loader::load_file(&app.registry, p, &opts)?, p.display().to_string()),
        None => {
            let (name, text) = app.default_scene;
            (crate::load::loader::load_str(&app.registry, name, text, Path::new("."), &opts)?, format!("{name} (bundled)"))
        }
    };
    for w in &job.warnings {
        eprintln!("warning: {}", w.report());
    }
    Ok((job, name))
}

/// Refuses to run `command` when one of the files it writes (`outputs`) is one of the files it
/// reads (`inputs`), under any spelling, link or hard link ([`crate::param::files::same_file`]):
/// the input would be gone once the output is written.
pub(crate) fn refuse_overwrite<'a>(
    command: &str,
    outputs: &[&Path],
    inputs: impl IntoIterator<Item = &'a Path> + Clone,
) -> Result<(), Failure> {
    for out in outputs {
        if let Some(input) = crate::param::files::overwritten_input(out, inputs.clone()) {
            return Err(Failure::Other(format!(
                "{command} would overwrite its input \"{}\" with \"{}\" (the same file): write to another file",
                input.display(),
                out.display()
            )));
        }
    }
    Ok(())
}

/// Refuses an output whose folder is not there, before any work: a render that can only fail
/// to write should fail at once, not after its tracing (raylab creates no folders).
pub(crate) fn output_folder_exists(out: &Path) -> Result<(), Failure> {
    match out.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(dir) if dir.exists() && !dir.is_dir() => {
            Err(Failure::Other(format!("cannot write \"{}\": \"{}\" is not a folder", out.display(), dir.display())))
        }
        Some(dir) if !dir.is_dir() => Err(Failure::Other(format!(
            "cannot write \"{}\": there is no folder \"{}\" (raylab creates no folders)",
            out.display(),
            dir.display()
        ))),
        _ => Ok(()),
    }
}

/// `1234567.0` → `1.23 M`.
pub(crate) fn si(x: f64) -> String {
    if x >= 1e9 {
        format!("{:.2} G", x / 1e9)
    } else if x >= 1e6 {
        format!("{:.2} M", x / 1e6)
    } else if x >= 1e3 {
        format!("{:.1} k", x / 1e3)
    } else {
        format!("{x:.0}")
    }
}
