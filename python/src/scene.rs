//! `raylab.Scene`: a loaded scene with its settings; rendering it and explaining its pixels.

use crate::image::Rendered;
use crate::{registry, runtime_error, scene_error};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use raylab::load::context::{LoadOptions, Overrides, key_value};
use raylab::param::value::{Node, Value};
use raylab::render::share::Share;
use raylab::render::{RenderJob, RenderOptions};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, mpsc};
use std::time::Duration;

/// How often a render hands control back to Python: to check for Ctrl-C and call the progress
/// callback.
const POLL: Duration = Duration::from_millis(50);

/// Where a scene comes from.
#[derive(Clone, Debug)]
enum Origin {
    /// A file, named as the caller named it (messages and `trace` show that name).
    File(PathBuf),
    /// TOML text, its name for messages, and the folder its relative paths resolve against.
    Text { name: String, text: String, dir: PathBuf },
}

/// The settings given outside the scene (the CLI's flags), kept as given so a changed copy can
/// be loaded again.
#[derive(Clone, Debug, Default, PartialEq)]
struct Settings {
    width: Option<u32>,
    height: Option<u32>,
    spp: Option<u32>,
    seed: Option<u64>,
    depth: Option<i64>,
    integrator: Option<String>,
    encoding: Option<String>,
    /// `KEY=VALUE` settings (value in TOML syntax): `integrator.`, `render.` or `camera.` keys,
    /// or bare integrator parameters as `--set` takes them.
    set: Vec<(String, String)>,
    accel: Option<String>,
    allow_outside_paths: bool,
    /// Limits by their CLI names without `--` (`max_pixels`, …, `max_depth_limit`).
    limits: Vec<(String, u64)>,
    /// Sweep knobs `(name, value in TOML syntax)`, applied last as `raylab sweep --vary` applies
    /// them ([`raylab::load::context::apply_knob`]).
    knobs: Vec<(String, String)>,
}

impl Settings {
    /// The load options these settings ask for, as the CLI builds them from its flags.
    fn load_options(&self) -> Result<LoadOptions, raylab::param::error::SceneError> {
        let mut ov = Overrides {
            width: self.width,
            height: self.height,
            spp: self.spp,
            seed: self.seed,
            integrator: self.integrator.clone(),
            depth: self.depth.map(|d| Node::given("depth", Value::Int(d))),
            ..Overrides::default()
        };
        if let Some(e) = &self.encoding {
            ov.encoding = Some(raylab::math::color::Encoding::parse(e).ok_or_else(|| {
                raylab::param::error::SceneError::msg(format!(
                    "encoding: expected one of {}, found \"{e}\"",
                    raylab::math::color::Encoding::NAMES.join(", ")
                ))
            })?);
        }
        for (key, value) in &self.set {
            let (key, node) = key_value("set", &format!("{key}={value}"))?;
            match key.split_once('.') {
                Some(("render", k)) => ov.render_params.push((k.to_string(), node)),
                Some(("camera", k)) => ov.camera_params.push((k.to_string(), node)),
                Some(("integrator", k)) => ov.integrator_params.push((k.to_string(), node)),
                _ => ov.integrator_params.push((key, node)),
            }
        }
        let mut limits = raylab::param::limits::Limits::default();
        for (name, v) in &self.limits {
            let narrow = |v: u64| u32::try_from(v).unwrap_or(u32::MAX);
            match name.as_str() {
                "max_pixels" => limits.max_pixels = *v,
                "max_side" => limits.max_side = narrow(*v),
                "max_spp" => limits.max_spp = narrow(*v),
                "max_depth_limit" => limits.max_depth = narrow(*v),
                "max_file_bytes" => limits.max_file_bytes = *v,
                "max_triangles" => limits.max_triangles = *v,
                "max_image_bytes" => limits.max_image_bytes = *v,
                "max_rays" => limits.max_rays = *v,
                "max_memory" => limits.max_memory = *v,
                other => return Err(raylab::param::error::SceneError::msg(format!("unknown limit \"{other}\""))),
            }
        }
        let accel = match self.accel.as_deref() {
            None => raylab::accel::AccelChoice::default(),
            Some(a) => raylab::accel::AccelChoice::parse(a)
                .ok_or_else(|| raylab::param::error::SceneError::msg(format!("accel: expected auto, bvh or list, found \"{a}\"")))?,
        };
        let mut opts = LoadOptions {
            overrides: ov,
            limits,
            allow_outside_paths: self.allow_outside_paths,
            accel,
            image: raylab::image::output::ImagePlan::default(),
            open_log: None,
        };
        for (name, value) in &self.knobs {
            let (name, node) = key_value("vary", &format!("{name}={value}"))?;
            raylab::load::context::apply_knob(&mut opts, "vary", &name, &node)?;
        }
        Ok(opts)
    }
}

/// A loaded scene: its origin, the settings it was loaded with, and the render job.
#[pyclass(frozen, module = "raylab._raylab")]
pub struct Scene {
    origin: Origin,
    settings: Settings,
    job: Arc<RenderJob>,
}

impl Scene {
    /// Loads `origin` with `settings` (the GIL released while it loads).
    fn open(py: Python<'_>, origin: Origin, settings: Settings) -> PyResult<Scene> {
        let opts = settings.load_options().map_err(|e| scene_error(py, &e))?;
        Scene::open_with(py, origin, settings, &opts)
    }

    /// Loads `origin` with `opts` (made from `settings`, perhaps changed further).
    fn open_with(py: Python<'_>, origin: Origin, settings: Settings, opts: &LoadOptions) -> PyResult<Scene> {
        let reg = registry()?;
        let loaded = py.detach(|| -> Result<RenderJob, raylab::param::error::SceneError> {
            let opts = opts.clone();
            match &origin {
                Origin::File(p) => raylab::load::loader::load_file(reg, p, &opts),
                Origin::Text { name, text, dir } => raylab::load::loader::load_str(reg, name, text, dir, &opts),
            }
        });
        let job = loaded.map_err(|e| scene_error(py, &e))?;
        Ok(Scene { origin, settings, job: Arc::new(job) })
    }

    /// The name `trace` and messages give the scene: its path as given, or its text's name.
    fn name(&self) -> String {
        match &self.origin {
            Origin::File(p) => p.display().to_string(),
            Origin::Text { name, .. } => name.clone(),
        }
    }
}

/// Settings from keyword arguments (the Python half passes them through).
#[allow(clippy::too_many_arguments)]
fn settings_from(
    width: Option<u32>,
    height: Option<u32>,
    spp: Option<u32>,
    seed: Option<u64>,
    depth: Option<i64>,
    integrator: Option<String>,
    encoding: Option<String>,
    set: Option<Vec<(String, String)>>,
    accel: Option<String>,
    allow_outside_paths: bool,
    limits: Option<Vec<(String, u64)>>,
) -> Settings {
    Settings {
        width,
        height,
        spp,
        seed,
        depth,
        integrator,
        encoding,
        set: set.unwrap_or_default(),
        accel,
        allow_outside_paths,
        limits: limits.unwrap_or_default(),
        knobs: Vec::new(),
    }
}

/// Loads the scene file at `path` (`.toml`, or a registered format such as the report's `.xml`).
#[pyfunction]
#[pyo3(signature = (path, *, width=None, height=None, spp=None, seed=None, depth=None, integrator=None, encoding=None, set=None, accel=None, allow_outside_paths=false, limits=None))]
#[allow(clippy::too_many_arguments)]
pub fn load(
    py: Python<'_>,
    path: PathBuf,
    width: Option<u32>,
    height: Option<u32>,
    spp: Option<u32>,
    seed: Option<u64>,
    depth: Option<i64>,
    integrator: Option<String>,
    encoding: Option<String>,
    set: Option<Vec<(String, String)>>,
    accel: Option<String>,
    allow_outside_paths: bool,
    limits: Option<Vec<(String, u64)>>,
) -> PyResult<Scene> {
    let settings = settings_from(width, height, spp, seed, depth, integrator, encoding, set, accel, allow_outside_paths, limits);
    Scene::open(py, Origin::File(path), settings)
}

/// Loads a scene from TOML text; `name` names it in messages, relative paths resolve against `dir`.
#[pyfunction]
#[pyo3(signature = (text, *, name="<string>".to_string(), dir=PathBuf::from("."), width=None, height=None, spp=None, seed=None, depth=None, integrator=None, encoding=None, set=None, accel=None, allow_outside_paths=false, limits=None))]
#[allow(clippy::too_many_arguments)]
pub fn loads(
    py: Python<'_>,
    text: String,
    name: String,
    dir: PathBuf,
    width: Option<u32>,
    height: Option<u32>,
    spp: Option<u32>,
    seed: Option<u64>,
    depth: Option<i64>,
    integrator: Option<String>,
    encoding: Option<String>,
    set: Option<Vec<(String, String)>>,
    accel: Option<String>,
    allow_outside_paths: bool,
    limits: Option<Vec<(String, u64)>>,
) -> PyResult<Scene> {
    let settings = settings_from(width, height, spp, seed, depth, integrator, encoding, set, accel, allow_outside_paths, limits);
    Scene::open(py, Origin::Text { name, text, dir }, settings)
}

#[pymethods]
impl Scene {
    /// The same scene with some settings changed (None keeps one; `set` entries and sweep
    /// `knobs` are added after the scene's). Loads again only when a setting changed.
    #[pyo3(signature = (*, width=None, height=None, spp=None, seed=None, depth=None, integrator=None, encoding=None, set=None, accel=None, knobs=None))]
    #[allow(clippy::too_many_arguments)]
    fn with_settings(
        &self,
        py: Python<'_>,
        width: Option<u32>,
        height: Option<u32>,
        spp: Option<u32>,
        seed: Option<u64>,
        depth: Option<i64>,
        integrator: Option<String>,
        encoding: Option<String>,
        set: Option<Vec<(String, String)>>,
        accel: Option<String>,
        knobs: Option<Vec<(String, String)>>,
    ) -> PyResult<Scene> {
        let mut s = self.settings.clone();
        s.knobs.extend(knobs.unwrap_or_default());
        s.width = width.or(s.width);
        s.height = height.or(s.height);
        s.spp = spp.or(s.spp);
        s.seed = seed.or(s.seed);
        s.depth = depth.or(s.depth);
        s.integrator = integrator.or(s.integrator);
        s.encoding = encoding.or(s.encoding);
        s.accel = accel.or(s.accel);
        s.set.extend(set.unwrap_or_default());
        if s == self.settings {
            return Ok(Scene { origin: self.origin.clone(), settings: s, job: self.job.clone() });
        }
        Scene::open(py, self.origin.clone(), s)
    }

    /// The scene as `raylab sweep --reference auto` renders its reference: stratified at
    /// `reference_spp` samples per pixel (at least the largest swept `spp`), one lens sample,
    /// the integrator's depth and quality knobs at their reference values and at least as
    /// accurate as any value in `swept` (`[(knob, [values in TOML syntax])]`). `integrator`
    /// renders the reference with another integrator (`--reference-integrator`). The ray budget
    /// is lifted unless a `max_rays` limit was given.
    #[pyo3(signature = (*, swept, integrator=None, reference_spp=256))]
    fn reference(
        &self,
        py: Python<'_>,
        swept: Vec<(String, Vec<String>)>,
        integrator: Option<String>,
        reference_spp: u32,
    ) -> PyResult<Scene> {
        let mut values: Vec<(String, Vec<Value>)> = Vec::with_capacity(swept.len());
        for (name, texts) in &swept {
            let mut vs = Vec::with_capacity(texts.len());
            for t in texts {
                vs.push(key_value("vary", &format!("{name}={t}")).map_err(|e| scene_error(py, &e))?.1.value);
            }
            values.push((name.clone(), vs));
        }
        let mut opts = self.settings.load_options().map_err(|e| scene_error(py, &e))?;
        if !self.settings.limits.iter().any(|(k, _)| k == "max_rays") {
            opts.limits.max_rays = u64::MAX;
        }
        let swept = |name: &str| values.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone());
        let scene_integrator = self.job.integrator_name.clone();
        let integrator = integrator.unwrap_or_else(|| scene_integrator.clone());
        registry()?.reference_options(&mut opts, &scene_integrator, &integrator, &swept, reference_spp);
        Scene::open_with(py, self.origin.clone(), self.settings.clone(), &opts)
    }

    /// Renders the scene (the GIL released; Ctrl-C cancels). `aov`: layers to compute (depth,
    /// normal, albedo, emission). `share`: `(x0, x1, y0, y1, pass, passes)` renders that part of the frame
    /// (a partial image for `merge`); `tile`: `(i, n)` renders tile i of n as `render --tile
    /// I/N` does. `progress(done, total)` is called about every 50 ms in pixel samples; an
    /// exception it raises cancels the render and is raised here.
    #[pyo3(signature = (*, aov=Vec::new(), tile=None, crop=None, pass_=None, threads=None, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn render(
        &self,
        py: Python<'_>,
        aov: Vec<String>,
        tile: Option<(u32, u32)>,
        crop: Option<(u32, u32, u32, u32)>,
        pass_: Option<(u32, u32)>,
        threads: Option<usize>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Rendered> {
        for name in &aov {
            if raylab::render::aov::Aov::parse(name).is_none() {
                return Err(PyValueError::new_err(format!(
                    "aov: expected depth, normal, albedo, emission, error or spp, found \"{name}\""
                )));
            }
        }
        if threads == Some(0) {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        let job = self.job.clone();
        let share = share_of(py, &job, tile, crop, pass_)?;
        let cancel = AtomicBool::new(false);
        let (done, total) = (AtomicU64::new(0), AtomicU64::new(0));
        let mut raised: Option<PyErr> = None;
        let result = py.detach(|| {
            std::thread::scope(|scope| {
                let (tx, rx) = mpsc::channel();
                let (job, cancel, done, total) = (&job, &cancel, &done, &total);
                scope.spawn(move || {
                    // The summed layers only for layers that need them, as the CLI: summing them
                    // makes `path` take its guides, which changes the colour (the error layer alone
                    // is of the colour's sums).
                    let layers = aov.iter().any(|a| raylab::render::aov::Aov::parse(a) != Some(raylab::render::aov::Aov::Error));
                    let options = RenderOptions { threads, cancel: Some(cancel), layers, share, ..RenderOptions::default() };
                    let r = raylab::render::render(job, &options, &|d, t| {
                        done.fetch_max(d, Ordering::Relaxed);
                        total.store(t, Ordering::Relaxed);
                    });
                    let _ = tx.send(r.map(|r| (r, aov)));
                });
                loop {
                    match rx.recv_timeout(POLL) {
                        Ok(r) => return Some(r),
                        Err(mpsc::RecvTimeoutError::Disconnected) => return None,
                        Err(mpsc::RecvTimeoutError::Timeout) if raised.is_some() => {}
                        Err(mpsc::RecvTimeoutError::Timeout) => Python::attach(|py| {
                            let step = py.check_signals().and_then(|()| match &progress {
                                Some(f) => f.call1(py, (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed))).map(drop),
                                None => Ok(()),
                            });
                            if let Err(e) = step {
                                raised = Some(e);
                                cancel.store(true, Ordering::Relaxed);
                            }
                        }),
                    }
                }
            })
        });
        if let Some(e) = raised {
            return Err(e);
        }
        let (r, aov) = result.ok_or_else(|| runtime_error("the render thread failed"))?.map_err(runtime_error)?;
        if let Some(f) = &progress {
            f.call1(py, (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed)))?;
        }
        Rendered::new(r, &job, aov, share.is_some()).map_err(runtime_error)
    }

    /// The explanation of sample `sample` of pixel `(x, y)`, or of one ray `(origin, direction)`,
    /// as the JSON text `raylab trace --json` prints.
    #[pyo3(signature = (*, pixel=None, sample=0, ray=None))]
    fn trace(&self, py: Python<'_>, pixel: Option<(u32, u32)>, sample: u32, ray: Option<([f64; 3], [f64; 3])>) -> PyResult<String> {
        let job = &self.job;
        let name = self.name();
        let out = py.detach(|| -> Result<serde_json::Value, String> {
            match (pixel, ray) {
                (Some((x, y)), None) => {
                    let (trees, sref) = raylab::render::explain_pixel(job, x, y, sample)?;
                    Ok(raylab::render::explain::explanation_json(job, &name, Some((x, y)), Some(sref), &trees))
                }
                (None, Some((o, d))) => {
                    let (o, d) = (glam::DVec3::from(o), glam::DVec3::from(d));
                    if !(o.is_finite() && d.is_finite()) {
                        return Err("ray: the origin and direction must be finite".into());
                    }
                    let dir = d.try_normalize().ok_or("ray: the direction must not be zero")?;
                    let tree = raylab::render::explain_ray(job, &raylab::math::ray::Ray { origin: o, dir })
                        .ok_or_else(|| format!("the integrator \"{}\" cannot explain rays", job.integrator_name))?;
                    Ok(raylab::render::explain::explanation_json(job, &name, None, None, &[tree]))
                }
                _ => Err("give pixel=(x, y) or ray=(origin, direction), one of them".into()),
            }
        });
        out.map(|v| v.to_string()).map_err(PyValueError::new_err)
    }

    /// The scene's name (its file as given, or its text's name).
    #[getter]
    fn name_(&self) -> String {
        self.name()
    }

    /// Image width, pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.job.settings.width
    }

    /// Image height, pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.job.settings.height
    }

    /// Samples per pixel (stratified anti-aliasing).
    #[getter]
    fn spp(&self) -> u32 {
        self.job.settings.spp
    }

    /// Random seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.job.settings.seed
    }

    /// The integrator's type name.
    #[getter]
    fn integrator(&self) -> String {
        self.job.integrator_name.clone()
    }

    /// `16 spp` or the adaptive settings, as the CLI's summary line says it.
    #[getter]
    fn sampling(&self) -> String {
        self.job.settings.describe_sampling()
    }

    /// The 8-bit encoding (`srgb`, `linear`, `linear-truncated`).
    #[getter]
    fn encoding(&self) -> &'static str {
        self.job.settings.encoding.name()
    }

    /// The fingerprint of the scene, the files it read and its settings (parts merge only under
    /// the same one).
    #[getter]
    fn fingerprint(&self) -> String {
        self.job.fingerprint.clone()
    }

    /// What loading ignored or approximated, as the CLI's warnings say it.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.job.warnings.iter().map(|w| w.report()).collect()
    }

    fn __repr__(&self) -> String {
        let s = &self.job.settings;
        format!("<raylab.Scene {} {}×{}, {}, {}>", self.name(), s.width, s.height, s.describe_sampling(), self.job.integrator_name)
    }
}

/// The share of the frame `tile`, `crop` and `pass_` ask for (None: the whole frame).
fn share_of(
    py: Python<'_>,
    job: &RenderJob,
    tile: Option<(u32, u32)>,
    crop: Option<(u32, u32, u32, u32)>,
    pass_: Option<(u32, u32)>,
) -> PyResult<Option<Share>> {
    let s = &job.settings;
    let frame = raylab::render::share::Rect::frame(s.width, s.height);
    let bounds = match (tile, crop) {
        (Some(_), Some(_)) => return Err(PyValueError::new_err("give tile or crop, not both")),
        (Some((i, n)), None) => py
            .detach(|| raylab::render::split::tile_bounds(s.width, &raylab::render::split::row_costs(job), i, n))
            .map_err(PyValueError::new_err)?,
        (None, Some((x0, x1, y0, y1))) => {
            let r = raylab::render::share::Rect { x0, y0, x1, y1 };
            if r.is_empty() || !r.within(&frame) {
                return Err(PyValueError::new_err(format!(
                    "crop: expected (x0, x1, y0, y1), pixel bounds [x0, x1) × [y0, y1) of the {}×{} frame",
                    s.width, s.height
                )));
            }
            r
        }
        (None, None) => frame,
    };
    let (pass, passes) = pass_.unwrap_or((0, 1));
    if passes == 0 || pass >= passes {
        return Err(PyValueError::new_err(format!("pass_: expected (k, n) with 0 ≤ k < n, found ({pass}, {passes})")));
    }
    if tile.is_none() && crop.is_none() && pass_.is_none() {
        return Ok(None);
    }
    Ok(Some(Share { bounds, pass, passes }))
}
