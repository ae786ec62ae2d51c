//! Loading a scene: reading a scene file into raylab's scene description (a located [`Table`]),
//! then building it, plugin by plugin, through the [`Registry`].
//!
//! Every format (raylab's TOML here; others registered as [`crate::registry::SceneFormat`])
//! produces the same description, so validation, limits and error locations work alike for all.

use crate::accel::{AccelChoice, BuildStats};
use crate::camera::{CAMERA_PARAMS, Camera};
use crate::color::Encoding;
use crate::error::{Loc, Result, SceneError, Source, did_you_mean};
use crate::files::{OpenLog, ReadError, read_regular};
use crate::material::{Material, MaterialLibrary};
use crate::params::{Default, Node, ParamKind, ParamSpec, Params, Table, Value};
use crate::registry::Registry;
use crate::render::{Antialiasing, MAX_ADAPTIVE_DEPTH, RenderJob, RenderSettings};
use crate::scene::Scene;
use crate::transform::{Transformed, parse_transform};
use std::any::Any;
use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};
use std::sync::{Arc, Mutex};

/// A scene as read from a file, before building: the root table in raylab's format.
#[derive(Clone, Debug)]
pub struct SceneDescription {
    /// Scene name (the file stem unless the file sets `name`).
    pub name: String,
    /// The root table (keys as in the TOML format).
    pub root: Table,
    /// Location of the whole document.
    pub loc: Loc,
}

/// Upper bounds checked before anything is allocated. Each can be raised from the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Largest image, in pixels (width × height).
    pub max_pixels: u64,
    /// Largest image side, in pixels.
    pub max_side: u32,
    /// Most samples per pixel.
    pub max_spp: u32,
    /// Deepest recursion an integrator may be asked for.
    pub max_depth: u32,
    /// Largest file a scene may make raylab read (meshes, included files), bytes.
    pub max_file_bytes: u64,
    /// Most triangles one mesh object may have (counted before its index and hierarchy are built;
    /// for glTF, from the accessors before their data is decoded).
    pub max_triangles: u64,
    /// Most memory the image may take, bytes: the film, the extra layers and the encoder's
    /// copies, estimated before rendering ([`crate::output::image_bytes`]).
    pub max_image_bytes: u64,
    /// Most rays a render may trace in the worst case (pixels × camera samples × lens samples ×
    /// the integrator's [`crate::Integrator::worst_case_rays`]), checked before rendering.
    pub max_rays: u64,
    /// Most memory the whole job may take, bytes, as estimated before each large allocation
    /// ([`LoadContext::charge`]): the parsed scene description, every object, every mesh with
    /// its hierarchy, glTF instances, and the image.
    pub max_memory: u64,
}

/// Default [`Limits::max_image_bytes`]: 2 GiB, so an image with every layer and its encoder's
/// copies stays well under 4 GB with the scene beside it (4096 × 4096 as EXR with every layer).
pub const DEFAULT_MAX_IMAGE_BYTES: u64 = 2 << 30;

/// Default work budget, rays. The estimate is an upper bound (every fan full, every light
/// sampled at every hit); the bundled scenes estimate at most 3.4e10 (quality.toml) and render in
/// minutes, while the catalogue's knobs multiplied (2.3e14) would run for days.
pub const DEFAULT_MAX_RAYS: u64 = 100_000_000_000;

/// Default [`Limits::max_memory`]: 3.25 GiB of estimated memory, so that with one file read
/// whole beside it ([`DEFAULT_MAX_FILE_BYTES`]) a job stays under 4 GB.
pub const DEFAULT_MAX_MEMORY: u64 = 13 << 28;

/// Default [`Limits::max_file_bytes`]: 64 MiB, the largest single read, which is not part of
/// the memory estimate while it happens ([`DEFAULT_MAX_MEMORY`] + this < 4 GB), and the largest
/// input whose linear-time load stays within a minute (10⁶ spheres, 64 MB of TOML: about 20 s).
/// The 1.1 M-triangle bunny OBJ (42 MB) is within it.
pub const DEFAULT_MAX_FILE_BYTES: u64 = 1 << 26;

/// Estimated peak bytes of parsing TOML `text` into a description (the parser's tree and the
/// located [`Table`] it becomes), from one linear scan: per `=` (a key and its value) or `{`
/// [`TOML_BYTES_PER_KEY`], per `,` or `[` (an array element or a table header)
/// [`TOML_BYTES_PER_ITEM`], and [`TOML_BYTES_PER_BYTE`] per byte for the text and string copies.
pub fn toml_memory_estimate(text: &[u8]) -> u64 {
    let (mut keys, mut items) = (0u64, 0u64);
    for &b in text {
        match b {
            b'=' | b'{' => keys += 1,
            b',' | b'[' => items += 1,
            _ => {}
        }
    }
    keys * TOML_BYTES_PER_KEY + items * TOML_BYTES_PER_ITEM + text.len() as u64 * TOML_BYTES_PER_BYTE
}

/// Estimated bytes per TOML key while parsed (measured peak: about 370 for 2·10⁶ keys of one table).
pub const TOML_BYTES_PER_KEY: u64 = 512;
/// Estimated bytes per TOML array element or table header while parsed (measured peak: about 190
/// per element of an array of 10⁷ integers, 340 per empty `[[a]]` table).
pub const TOML_BYTES_PER_ITEM: u64 = 256;
/// Estimated bytes per byte of TOML text beyond its values: the text itself and string copies.
pub const TOML_BYTES_PER_BYTE: u64 = 3;

/// Estimated bytes one scene object takes once built, beyond what its plugin charges itself: its
/// geometry box, an optional transform wrapper, its name and its share of the scenes' hierarchies.
pub const OBJECT_BYTES: u64 = 400;

impl std::default::Default for Limits {
    fn default() -> Self {
        Limits {
            max_pixels: 1 << 26,
            max_side: 1 << 15,
            max_spp: 1 << 16,
            max_depth: 64,
            max_file_bytes: DEFAULT_MAX_FILE_BYTES,
            max_triangles: 1 << 26,
            max_image_bytes: DEFAULT_MAX_IMAGE_BYTES,
            max_rays: DEFAULT_MAX_RAYS,
            max_memory: DEFAULT_MAX_MEMORY,
        }
    }
}

impl Limits {
    /// No limits (every bound at its type's maximum).
    pub fn unlimited() -> Self {
        Limits {
            max_pixels: u64::MAX,
            max_side: u32::MAX,
            max_spp: u32::MAX,
            max_depth: u32::MAX,
            max_file_bytes: u64::MAX,
            max_triangles: u64::MAX,
            max_image_bytes: u64::MAX,
            max_rays: u64::MAX,
            max_memory: u64::MAX,
        }
    }
}

/// Settings given outside the scene file (command line), which take precedence over it.
#[derive(Clone, Debug, std::default::Default)]
pub struct Overrides {
    /// Image width, pixels.
    pub width: Option<u32>,
    /// Image height, pixels.
    pub height: Option<u32>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Random seed.
    pub seed: Option<u64>,
    /// 8-bit encoding.
    pub encoding: Option<Encoding>,
    /// Integrator type; replaces the scene's integrator and its parameters.
    pub integrator: Option<String>,
    /// Integrator parameters, `(name, value)`, applied over the scene's.
    pub integrator_params: Vec<(String, Node)>,
    /// `[render]` keys, `(name, value)`, applied over the scene's (e.g. `aa`, `lens_samples`).
    pub render_params: Vec<(String, Node)>,
    /// Camera parameters, `(name, value)`, applied over the scene's `[camera]` (see
    /// [`crate::camera::apply_overrides`]); they also supply a camera to a scene that has none.
    pub camera_params: Vec<(String, Node)>,
}

/// How to load a scene.
#[derive(Clone, Debug, std::default::Default)]
pub struct LoadOptions {
    /// Command-line settings over the file's.
    pub overrides: Overrides,
    /// Size limits.
    pub limits: Limits,
    /// Let the scene read files outside its own folder (absolute paths, `..`). Off by default, so
    /// untrusted scenes can be rendered safely.
    pub allow_outside_paths: bool,
    /// List or hierarchy, for the scene's objects and for each mesh's triangles.
    pub accel: AccelChoice,
    /// What will be written, for the image's memory estimate (by default the costliest: EXR with
    /// every layer).
    pub image: crate::output::ImagePlan,
    /// Records the real path of every file the load opens (for tests of the folder confinement).
    pub open_log: Option<OpenLog>,
}

/// Things shared by the objects of one scene while it loads: decoded assets (a mesh file placed
/// several times is read and indexed once) and the cost of the spatial indices plugins build.
#[derive(Default)]
pub struct AssetCache {
    items: Mutex<HashMap<String, Arc<dyn Any + Send + Sync>>>,
    builds: Mutex<BuildStats>,
}

impl AssetCache {
    /// The asset stored under `key`, or the result of `load`, stored under `key` when it
    /// succeeds. Keys should name the resolved file and whatever else selects the asset.
    pub fn get_or_load<T: Any + Send + Sync>(&self, key: &str, load: impl FnOnce() -> Result<T>) -> Result<Arc<T>> {
        let found = self.items.lock().unwrap_or_else(|e| e.into_inner()).get(key).cloned();
        if let Some(a) = found.and_then(|a| a.downcast::<T>().ok()) {
            return Ok(a);
        }
        let a = Arc::new(load()?);
        self.items.lock().unwrap_or_else(|e| e.into_inner()).insert(key.to_string(), a.clone());
        Ok(a)
    }

    /// Records the cost of a spatial index a plugin built (for the render summary).
    pub fn record_build(&self, stats: BuildStats) {
        *self.builds.lock().unwrap_or_else(|e| e.into_inner()) += stats;
    }

    /// Total cost of the indices recorded so far.
    pub fn build_stats(&self) -> BuildStats {
        *self.builds.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// What a plugin constructor may use while building: where the scene is, the load options, and
/// the assets shared by the scene's objects.
pub struct LoadContext<'a> {
    /// Folder of the scene file; relative asset paths resolve against it (empty: the working
    /// folder).
    pub scene_dir: &'a Path,
    /// The options the scene is loaded with.
    pub options: &'a LoadOptions,
    /// Assets decoded once per scene, and the cost of the indices plugins build.
    pub assets: AssetCache,
    warnings: Mutex<Vec<SceneError>>,
    charged: std::sync::atomic::AtomicU64,
}

impl<'a> LoadContext<'a> {
    /// The context for a scene in `scene_dir`, with an empty asset cache.
    pub fn new(scene_dir: &'a Path, options: &'a LoadOptions) -> Self {
        LoadContext {
            scene_dir,
            options,
            assets: AssetCache::default(),
            warnings: Mutex::default(),
            charged: std::sync::atomic::AtomicU64::new(0),
        }
    }

    /// Counts `bytes` (an estimate of what is about to be allocated for `what`) against
    /// [`Limits::max_memory`], before allocating: an error naming `what`, the estimate and the
    /// flag when the job's running total would exceed it (then nothing is counted).
    pub fn charge(&self, bytes: u64, what: &str, loc: Option<&Loc>) -> Result<()> {
        use std::sync::atomic::Ordering;
        let limit = self.options.limits.max_memory;
        let mut total = self.charged.load(Ordering::Relaxed);
        loop {
            let next = total.saturating_add(bytes);
            if next > limit {
                let message = format!(
                    "{what} needs about {} MB, which brings the job's estimated memory to {} MB, over the limit of {} MB",
                    bytes.div_ceil(1 << 20),
                    next.div_ceil(1 << 20),
                    limit >> 20
                );
                let e = match loc {
                    Some(l) => SceneError::at(l, message),
                    None => SceneError::msg(message),
                };
                return Err(e.with_help("raise the limit with --max-memory (bytes)"));
            }
            match self.charged.compare_exchange_weak(total, next, Ordering::Relaxed, Ordering::Relaxed) {
                Ok(_) => return Ok(()),
                Err(t) => total = t,
            }
        }
    }

    /// The memory counted so far by [`LoadContext::charge`], bytes.
    pub fn charged(&self) -> u64 {
        self.charged.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Records something the scene asks for that raylab ignores or approximates (an unsupported
    /// feature of a file format, a value beyond what is represented): the load goes on, and the
    /// warning reaches the user with the job ([`RenderJob::warnings`]).
    pub fn warn(&self, warning: SceneError) {
        self.warnings.lock().unwrap_or_else(|e| e.into_inner()).push(warning);
    }

    /// The warnings recorded so far, in order, leaving none behind.
    pub fn take_warnings(&self) -> Vec<SceneError> {
        std::mem::take(&mut *self.warnings.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// The scene's folder as a path that names it (`.` for the empty folder of a bare file name).
    fn dir(&self) -> &Path {
        if self.scene_dir.as_os_str().is_empty() { Path::new(".") } else { self.scene_dir }
    }

    /// The scene's folder, canonicalised; an error at `loc` if it cannot be (the confinement
    /// check then cannot be made, so nothing is read).
    fn canonical_dir(&self, loc: &Loc) -> Result<PathBuf> {
        self.dir().canonicalize().map_err(|e| {
            SceneError::at(loc, format!("cannot resolve the scene's folder \"{}\": {e}", self.dir().display()))
                .with_help("files the scene names are read only once its folder is known; pass --allow-outside-paths to skip the check")
        })
    }

    /// Resolves a path written in the scene (at `loc`) against the scene's folder, refusing
    /// absolute paths and paths that leave the folder, through `..` or through symbolic links,
    /// unless `allow_outside_paths` is set. Fails closed: a path whose target or folder cannot be
    /// resolved is refused.
    pub fn resolve_path(&self, path: &str, loc: &Loc) -> Result<PathBuf> {
        self.check_written_path(path, loc)?;
        let p = Path::new(path);
        let full = self.scene_dir.join(p);
        if !self.options.allow_outside_paths {
            let dir = self.canonical_dir(loc)?;
            let target =
                self.dir().join(p).canonicalize().map_err(|e| SceneError::at(loc, format!("cannot read \"{}\": {e}", full.display())))?;
            self.confined(&target, &dir, path, loc)?;
        }
        Ok(full)
    }

    /// Refuses a path as written (at `loc`) that is empty, absolute or climbs out with `..`,
    /// unless `allow_outside_paths` is set. Looks at no file: [`LoadContext::resolve_path`] also
    /// checks where links lead.
    pub fn check_written_path(&self, path: &str, loc: &Loc) -> Result<()> {
        let p = Path::new(path);
        if path.is_empty() {
            return Err(SceneError::at(loc, "expected a file path, found an empty string"));
        }
        let escapes = p.is_absolute() || p.components().any(|c| matches!(c, Component::ParentDir | Component::Prefix(_)));
        if escapes && !self.options.allow_outside_paths {
            return Err(SceneError::at(loc, format!("path \"{path}\" leaves the scene's folder"))
                .with_help("scenes may only read files in their own folder; pass --allow-outside-paths to permit this"));
        }
        Ok(())
    }

    /// Refuses `target` (the real path of `path`) unless it is inside the canonical folder `dir`.
    fn confined(&self, target: &Path, dir: &Path, path: &str, loc: &Loc) -> Result<()> {
        if target.starts_with(dir) {
            return Ok(());
        }
        Err(SceneError::at(loc, format!("path \"{path}\" resolves outside the scene's folder"))
            .with_help("a symbolic link must not lead out of the folder; pass --allow-outside-paths to permit this"))
    }

    /// Reads a file the scene names (resolved with [`LoadContext::resolve_path`]): a regular file
    /// only (not a FIFO, device or folder), refused once it holds more than
    /// [`Limits::max_file_bytes`]. Every file a scene makes raylab read (meshes, glTF buffers, MTL
    /// libraries) is read here.
    pub fn read_file(&self, path: &str, loc: &Loc) -> Result<(PathBuf, Vec<u8>)> {
        let full = self.resolve_path(path, loc)?;
        let failed = |e: ReadError| {
            let err = SceneError::at(loc, e.message(&format!("\"{}\"", full.display())));
            match e.help() {
                Some(h) => err.with_help(h),
                None => err,
            }
        };
        let opened = crate::files::open_regular(&full, self.options.open_log.as_ref()).map_err(failed)?;
        if !self.options.allow_outside_paths {
            // The file opened is the one checked, even if a link changed in between.
            let dir = self.canonical_dir(loc)?;
            match &opened.real_path {
                Some(real) => self.confined(real, &dir, path, loc)?,
                None => return Err(SceneError::at(loc, format!("cannot resolve \"{}\" once opened", full.display()))),
            }
        }
        let bytes = opened.read_to_end(self.options.limits.max_file_bytes).map_err(failed)?;
        Ok((full, bytes))
    }
}

/// The folder of the scene file `path`, against which the scene's paths resolve: empty for a bare
/// file name, which [`LoadContext`] takes as the working folder.
pub fn scene_dir(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// Reads a file the user names on the command line (a scene, a reference image): a regular file
/// only, at most `limit` bytes; the error message calls it `what`.
pub fn read_user_file(path: &Path, what: &str, limit: u64, log: Option<&OpenLog>) -> Result<Vec<u8>> {
    read_regular(path, limit, log).map_err(|e| {
        let err = SceneError::in_file(path, None, e.message(what));
        match e.help() {
            Some(h) => err.with_help(h),
            None => err,
        }
    })
}

/// The keys of a scene file's root.
pub const SCENE_PARAMS: &[ParamSpec] = &[
    ParamSpec::new("name", ParamKind::Str, Default::Optional, "scene name (default: the file name)"),
    ParamSpec::new("background", ParamKind::Color, Default::Float(0.0), "colour of rays that hit nothing, linear RGB"),
    ParamSpec::new("render", ParamKind::Any, Default::Optional, "[render] table: image size, samples, seed, encoding"),
    ParamSpec::new("camera", ParamKind::Any, Default::Required, "[camera] table"),
    ParamSpec::new("integrator", ParamKind::Any, Default::Optional, "[integrator] table: `type` and its parameters"),
    ParamSpec::new("materials", ParamKind::Any, Default::Optional, "[materials.NAME] tables"),
    ParamSpec::new(
        "object",
        ParamKind::Any,
        Default::Optional,
        "[[object]] tables: `type`, optional `name` and `transform`, and the type's parameters",
    ),
    ParamSpec::new("light", ParamKind::Any, Default::Optional, "[[light]] tables: `type`, optional `name`, and the type's parameters"),
];

/// The keys of `[render]`.
pub const RENDER_PARAMS: &[ParamSpec] = &[
    ParamSpec::new("width", ParamKind::Int, Default::Int(800), "image width, pixels"),
    ParamSpec::new("height", ParamKind::Int, Default::Int(600), "image height, pixels"),
    ParamSpec::new("spp", ParamKind::Int, Default::Int(1), "samples per pixel (1 = through the pixel centre, more = stratified jitter)"),
    ParamSpec::new("seed", ParamKind::Int, Default::Int(0), "random seed; same seed, same image"),
    ParamSpec::new(
        "encoding",
        ParamKind::Str,
        Default::Str("srgb"),
        "8-bit encoding: \"srgb\" or \"linear\" (clamped values written straight, as the report)",
    ),
    ParamSpec::new(
        "aa",
        ParamKind::Str,
        Default::Str("stratified"),
        "anti-aliasing: \"stratified\" (spp samples per pixel) or \"adaptive\" (recursive corner subdivision)",
    ),
    ParamSpec::new(
        "aa_threshold",
        ParamKind::Float,
        Default::Float(0.05),
        "adaptive: split where corner values (displayed, 0..1) differ by more than this, in [0, 1]",
    ),
    ParamSpec::new("aa_depth", ParamKind::Int, Default::Int(3), "adaptive: most subdivision levels per pixel, 0..=8"),
    ParamSpec::new(
        "lens_samples",
        ParamKind::Int,
        Default::Int(1),
        "rays through distinct lens points per image sample (depth of field only), ≥ 1",
    ),
];

/// Reads and builds the scene file at `path`, choosing the format by extension (`.toml` is
/// raylab's own; others must be registered).
pub fn load_file(registry: &Registry, path: &Path, options: &LoadOptions) -> Result<RenderJob> {
    let dir = scene_dir(path);
    // One context for reading and building, so assets a format reader decoded are reused.
    let ctx = LoadContext::new(dir, options);
    let desc = read_with(registry, path, &ctx)?;
    let parts = build_parts(registry, &desc, &ctx)?;
    // The description is freed before the scene's hierarchy is built.
    drop(desc);
    parts.assemble(&ctx)
}

/// Reads the scene file at `path` into a description without building it.
pub fn read_file(registry: &Registry, path: &Path, options: &LoadOptions) -> Result<SceneDescription> {
    read_with(registry, path, &LoadContext::new(scene_dir(path), options))
}

fn read_with(registry: &Registry, path: &Path, ctx: &LoadContext) -> Result<SceneDescription> {
    let options = ctx.options;
    let bytes = read_user_file(path, "scene file", options.limits.max_file_bytes, options.open_log.as_ref())?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let estimate = if ext == "toml" { toml_memory_estimate(&bytes) } else { bytes.len() as u64 };
    ctx.charge(estimate, "the scene description", None).map_err(|mut e| {
        e.location = crate::error::Location::File { path: path.display().to_string(), line_col: None };
        e
    })?;
    if ext == "toml" {
        let text = String::from_utf8(bytes).map_err(|e| {
            SceneError::in_file(path, None, format!("scene file is not UTF-8 text (byte {})", e.utf8_error().valid_up_to()))
        })?;
        return parse_toml(&Source::new(path.display().to_string(), text), stem(path));
    }
    match registry.format_for(&ext) {
        Some(f) => (f.read)(path, &bytes, ctx),
        None => {
            let known: Vec<String> = std::iter::once("toml".to_string())
                .chain(registry.formats().iter().flat_map(|f| f.extensions.iter().map(|e| e.to_string())))
                .collect();
            Err(SceneError::in_file(path, None, format!("unknown scene format \".{ext}\"; expected one of: .{}", known.join(", ."))))
        }
    }
}

/// Builds a TOML scene given as text. `name` names it in messages; relative paths resolve
/// against `scene_dir`.
pub fn load_str(registry: &Registry, name: &str, text: &str, scene_dir: &Path, options: &LoadOptions) -> Result<RenderJob> {
    let ctx = LoadContext::new(scene_dir, options);
    ctx.charge(toml_memory_estimate(text.as_bytes()), "the scene description", None)?;
    let desc = parse_toml(&Source::new(name, text), stem(Path::new(name)))?;
    let parts = build_parts(registry, &desc, &ctx)?;
    drop(desc);
    parts.assemble(&ctx)
}

fn stem(p: &Path) -> String {
    p.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_string()
}

/// Parses raylab's TOML scene format into a description.
pub fn parse_toml(source: &Arc<Source>, name: String) -> Result<SceneDescription> {
    let doc = toml::de::DeTable::parse(&source.text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        SceneError::at(&Loc::new(source, span), format!("TOML syntax error: {}", e.message().trim()))
    })?;
    let loc = Loc::new(source, 0..source.text.len());
    // Consumed as it is converted: each part of the parser's tree is freed once copied, so the
    // two trees never coexist whole (10⁶ inline objects would need both at once).
    let root = convert_table(doc.into_inner(), source)?;
    Ok(SceneDescription { name, root, loc })
}

/// Parses one TOML value written on the command line (`--set key=VALUE`).
pub fn parse_toml_value(source: &Arc<Source>, range: std::ops::Range<usize>) -> Result<Node> {
    let text = &source.text[range.clone()];
    let v = toml::de::DeValue::parse(text)
        .map_err(|e| SceneError::at(&Loc::new(source, range.clone()), format!("expected a TOML value: {}", e.message().trim())))?;
    let mut n = convert_value(v, source)?;
    shift_locs(&mut n, range.start);
    Ok(n)
}

fn shift_locs(n: &mut Node, by: usize) {
    n.loc.start += by;
    n.loc.end += by;
    match &mut n.value {
        Value::Array(items) => items.iter_mut().for_each(|i| shift_locs(i, by)),
        Value::Table(t) => t.entries.iter_mut().for_each(|e| {
            e.key_loc.start += by;
            e.key_loc.end += by;
            shift_locs(&mut e.value, by);
        }),
        _ => {}
    }
}

fn convert_table(t: toml::de::DeTable<'_>, src: &Arc<Source>) -> Result<Table> {
    let mut entries = Vec::with_capacity(t.len());
    for (k, v) in t {
        let key_loc = Loc::new(src, k.span());
        entries.push(crate::params::Entry { key: k.into_inner().into_owned(), key_loc, value: convert_value(v, src)? });
    }
    Ok(Table { entries })
}

fn convert_value(v: toml::Spanned<toml::de::DeValue<'_>>, src: &Arc<Source>) -> Result<Node> {
    use toml::de::DeValue;
    let loc = Loc::new(src, v.span());
    let value = match v.into_inner() {
        DeValue::String(s) => Value::Str(s.into_owned()),
        DeValue::Boolean(b) => Value::Bool(b),
        DeValue::Integer(i) => {
            let digits = i.as_str().replace('_', "");
            let (neg, body) = match digits.strip_prefix('-') {
                Some(b) => (true, b),
                None => (false, digits.strip_prefix('+').unwrap_or(&digits)),
            };
            // The parser hands over the digits with or without a 0x/0o/0b prefix, and "0x" alone.
            let body = match body.get(..2) {
                Some("0x" | "0o" | "0b") if i.radix() != 10 => &body[2..],
                _ => body,
            };
            if body.is_empty() {
                return Err(SceneError::at(&loc, "expected digits after the 0x, 0o or 0b prefix"));
            }
            let mag = i128::from_str_radix(body, i.radix()).map_err(|_| SceneError::at(&loc, "integer out of range"))?;
            let val = if neg { -mag } else { mag };
            Value::Int(i64::try_from(val).map_err(|_| SceneError::at(&loc, "integer out of range for 64 bits"))?)
        }
        DeValue::Float(f) => {
            let s = f.as_str().replace('_', "");
            Value::Float(s.parse::<f64>().map_err(|_| SceneError::at(&loc, format!("malformed number {s}")))?)
        }
        DeValue::Datetime(_) => return Err(SceneError::at(&loc, "dates and times are not valid in a scene")),
        DeValue::Array(items) => Value::Array(items.into_iter().map(|i| convert_value(i, src)).collect::<Result<_>>()?),
        DeValue::Table(t) => Value::Table(convert_table(t, src)?),
    };
    Ok(Node { value, loc })
}

/// Builds a scene description into a render job: validates every table against its plugin's
/// parameter table, applies command-line overrides and limits, and constructs every plugin.
pub fn build(registry: &Registry, desc: &SceneDescription, ctx: &LoadContext) -> Result<RenderJob> {
    build_parts(registry, desc, ctx)?.assemble(ctx)
}

/// A scene's parts, built from its description, before the scene's hierarchy is built (so the
/// description can be freed first).
struct Parts {
    name: String,
    camera: Camera,
    background: crate::color::Color,
    objects: Vec<(String, Box<dyn crate::geometry::Geometry>)>,
    lights: Vec<(String, Box<dyn crate::light::LightSource>)>,
    integrator: Box<dyn crate::integrator::Integrator>,
    integrator_name: String,
    settings: RenderSettings,
    /// Where the integrator is set, for the work budget's error.
    integrator_loc: Loc,
}

impl Parts {
    fn assemble(self, ctx: &LoadContext) -> Result<RenderJob> {
        let mut scene = Scene::with_accel(self.name, self.camera, self.background, self.objects, self.lights, ctx.options.accel);
        scene.record_object_builds(ctx.assets.build_stats());
        let (integrator, ty) = (self.integrator, self.integrator_name);
        check_work(&self.settings, &scene, integrator.as_ref(), &ty, &self.integrator_loc, ctx.options.limits.max_rays)?;
        Ok(RenderJob { scene, integrator, integrator_name: ty, settings: self.settings, warnings: ctx.take_warnings() })
    }
}

fn build_parts(registry: &Registry, desc: &SceneDescription, ctx: &LoadContext) -> Result<Parts> {
    let opts = ctx.options;
    let ov = &opts.overrides;
    if opts.accel == AccelChoice::Bvh && !crate::bvh::BVH_AVAILABLE {
        return Err(SceneError::msg("a BVH was asked for, but raylab was built without the `bvh` feature")
            .with_help("rebuild with `--features bvh`, or use --accel auto/list"));
    }
    let mut root = Params::new(format!("scene {}", desc.name), SCENE_PARAMS, &desc.root, desc.loc.clone(), None);
    let name = match root.node("name")? {
        Some(n) => match &n.value {
            Value::Str(s) => s.clone(),
            _ => return Err(SceneError::at(&n.loc, "`name` must be a string")),
        },
        None => desc.name.clone(),
    };
    let background = root.color("background")?;

    // [render]
    let empty = Table::default();
    let (render_table, render_loc) = sub_table(root.node("render")?, &desc.loc, &empty, "render")?;
    let render_table = with_overrides(render_table, &ov.render_params);
    let mut rp = Params::new("[render]", RENDER_PARAMS, &render_table, render_loc, None);
    let limits = &opts.limits;
    let max_side = i64::from(limits.max_side.min(i32::MAX as u32));
    // The file's values are read (and validated) even when the command line overrides them.
    let (file_width, file_height) = (rp.int_in("width", 1..=i64::MAX)?, rp.int_in("height", 1..=i64::MAX)?);
    let width = ov.width.map_or(file_width, i64::from);
    let height = ov.height.map_or(file_height, i64::from);
    for (v, what) in [(width, "width"), (height, "height")] {
        if v < 1 || v > max_side {
            return Err(rp
                .error_at(what, format_args!("image {what} {v} is outside 1..={max_side}"))
                .with_help("raise the limit with --max-side"));
        }
    }
    let pixels = width as u64 * height as u64;
    if pixels > limits.max_pixels {
        return Err(rp
            .error(format!("image of {width}×{height} = {pixels} pixels exceeds the limit of {} pixels", limits.max_pixels))
            .with_help("raise the limit with --max-pixels"));
    }
    let bytes = crate::output::image_bytes(pixels, &opts.image);
    if bytes > limits.max_image_bytes {
        return Err(rp
            .error(format!(
                "image of {width}×{height} pixels needs about {} MB (film, layers and encoding), over the limit of {} MB",
                bytes.div_ceil(1 << 20),
                limits.max_image_bytes >> 20
            ))
            .with_help("raise the limit with --max-image-bytes, or render a smaller image"));
    }
    ctx.charge(bytes, &format!("the image of {width}×{height} pixels"), Some(rp.loc()))?;
    let file_spp = rp.int_in("spp", 1..=i64::MAX)?;
    let spp = ov.spp.map_or(file_spp, i64::from);
    if spp < 1 || spp > i64::from(limits.max_spp) {
        return Err(rp
            .error_at("spp", format_args!("{spp} samples per pixel is outside 1..={}", limits.max_spp))
            .with_help("raise the limit with --max-spp"));
    }
    let file_seed = rp.int_in("seed", 0..=i64::MAX)? as u64;
    let seed = ov.seed.unwrap_or(file_seed);
    let file_encoding = Encoding::parse(&rp.choice("encoding", &["srgb", "linear"])?).unwrap_or_default();
    let encoding = ov.encoding.unwrap_or(file_encoding);
    let aa = match rp.choice("aa", &["stratified", "adaptive"])?.as_str() {
        "adaptive" => Antialiasing::Adaptive {
            threshold: rp.float_in("aa_threshold", 0.0..=1.0)?,
            max_depth: rp.int_in("aa_depth", 0..=i64::from(MAX_ADAPTIVE_DEPTH))? as u32,
        },
        _ => Antialiasing::Stratified,
    };
    let lens_samples = rp.int_in("lens_samples", 1..=i64::from(limits.max_spp))? as u32;
    if u64::from(lens_samples) * spp as u64 > u64::from(limits.max_spp) {
        return Err(rp
            .error_at(
                "lens_samples",
                format_args!("{spp} spp × {lens_samples} lens samples exceeds the limit of {} rays per pixel", limits.max_spp),
            )
            .with_help("raise the limit with --max-spp"));
    }
    rp.finish()?;
    let settings = RenderSettings { width: width as u32, height: height as u32, spp: spp as u32, seed, encoding, aa, lens_samples };

    // [camera]
    let cam_node = root.node("camera")?;
    if cam_node.is_none() && ov.camera_params.is_empty() {
        return Err(SceneError::at(&desc.loc, "the scene has no [camera]").with_help(
            "add a [camera] table with `position` and `look_at` (or the report's `to` and `screen_*`), or give one with --camera KEY=VALUE",
        ));
    }
    let (cam_table, cam_loc) = sub_table(cam_node, &desc.loc, &empty, "camera")?;
    let cam_table = crate::camera::apply_overrides(cam_table, &ov.camera_params);
    let mut cp = Params::new("[camera]", CAMERA_PARAMS, &cam_table, cam_loc, None);
    let camera = Camera::from_params(&mut cp, settings.width, settings.height)?;
    cp.finish()?;

    // [materials.NAME]
    let mut materials = MaterialLibrary::default();
    if let Some(n) = root.node("materials")? {
        let Value::Table(t) = &n.value else {
            return Err(SceneError::at(&n.loc, "`materials` must be a table of [materials.NAME] tables"));
        };
        for e in &t.entries {
            let Value::Table(mt) = &e.value.value else {
                return Err(SceneError::at(&e.value.loc, format!("material \"{}\" must be a table of coefficients", e.key)));
            };
            materials.insert(e.key.clone(), Material::from_table(mt, &e.value.loc, &format!("material \"{}\"", e.key))?);
        }
    }

    // [[object]]
    let mut objects = Vec::new();
    let mut names = NameSet::default();
    for (i, node) in array_of_tables(root.node("object")?, "object")?.into_iter().enumerate() {
        let (ty, label, params) =
            plugin_header(node, i, "object", |n| registry.geometry(n).is_some(), || registry.geometries().map(|p| p.name).collect())?;
        let plugin = registry.geometry(&ty).expect("checked by plugin_header");
        let what = format!("object #{i} {label}({ty})");
        ctx.charge(OBJECT_BYTES, &what, Some(&node.loc))?;
        let transform = params.get("transform").map(|n| parse_transform(n).map_err(|e| e.context(&what))).transpose()?;
        let mut p = Params::new(&what, plugin.info.params, params, node.loc.clone(), Some(&materials)).reserving(OBJECT_KEYS);
        let mut g = (plugin.build)(&mut p, ctx)?;
        p.finish()?;
        if let Some(t) = transform.filter(|t| !t.is_identity()) {
            g = Box::new(Transformed::new(g, t));
        }
        if let Some(b) = g.bounds().filter(|b| !b.is_empty()) {
            let reach = b.min.abs().max(b.max.abs()).max_element();
            if reach.is_nan() || reach > crate::bounds::MAX_COORDINATE {
                return Err(SceneError::at(
                    &node.loc,
                    format!("{what} reaches {reach:.3e} from the origin, beyond the {:e} raylab represents", crate::bounds::MAX_COORDINATE),
                )
                .with_help("scale the scene down, or move it toward the origin"));
            }
        }
        objects.push((names.claim(node, &label, &ty, i)?, g));
    }

    // [[light]]
    let mut lights = Vec::new();
    let mut light_names = NameSet::default();
    for (i, node) in array_of_tables(root.node("light")?, "light")?.into_iter().enumerate() {
        let (ty, label, params) =
            plugin_header(node, i, "light", |n| registry.light(n).is_some(), || registry.lights().map(|p| p.name).collect())?;
        let plugin = registry.light(&ty).expect("checked by plugin_header");
        let what = format!("light #{i} {label}({ty})");
        let mut p = Params::new(&what, plugin.info.params, params, node.loc.clone(), None).reserving(LIGHT_KEYS);
        let l = (plugin.build)(&mut p, ctx)?;
        p.finish()?;
        lights.push((light_names.claim(node, &label, &ty, i)?, l));
    }

    // [integrator]
    let integ_node = root.node("integrator")?;
    root.finish()?;
    let (file_table, integ_loc) = sub_table(integ_node, &desc.loc, &empty, "integrator")?;
    let mut integ_table = file_table.clone();
    let file_type = match integ_table.remove("type") {
        Some(e) => match e.value.value {
            Value::Str(s) => Some((s, e.value.loc)),
            _ => return Err(SceneError::at(&e.value.loc, "integrator `type` must be a string")),
        },
        None => None,
    };
    let (ty, ty_loc) = match (&ov.integrator, file_type) {
        (Some(t), Some((ft, _))) if *t != ft => {
            integ_table = Table::default();
            (t.clone(), None)
        }
        (Some(t), _) => (t.clone(), None),
        (None, Some((t, l))) => (t, Some(l)),
        (None, None) => (registry.default_integrator().ok_or_else(|| SceneError::msg("no integrator is registered"))?.to_string(), None),
    };
    let Some(plugin) = registry.integrator(&ty) else {
        let names: Vec<&str> = registry.integrators().map(|p| p.name).collect();
        let e = match &ty_loc {
            Some(l) => SceneError::at(l, format!("unknown integrator \"{ty}\"")),
            None => SceneError::msg(format!("unknown integrator \"{ty}\"")),
        };
        return Err(e.with_help(suggest(&ty, &names)));
    };
    for (k, v) in &ov.integrator_params {
        if !plugin.info.params.iter().any(|s| s.name == k) {
            let names: Vec<&str> = plugin.info.params.iter().map(|s| s.name).collect();
            return Err(SceneError::at(&v.loc, format!("integrator \"{ty}\" has no parameter `{k}`"))
                .with_help(format!("its parameters: {}", names.join(", "))));
        }
        integ_table.set(k, v.loc.clone(), v.clone());
    }
    if let Some(n) = integ_table.get("max_depth")
        && let Value::Int(d) = n.value
        && d > i64::from(limits.max_depth)
    {
        return Err(SceneError::at(&n.loc, format!("max_depth {d} exceeds the limit of {}", limits.max_depth))
            .with_help("raise it with --max-depth-limit"));
    }
    let mut ip = Params::new(format!("integrator \"{ty}\""), plugin.info.params, &integ_table, integ_loc.clone(), None);
    let integrator = (plugin.build)(&mut ip, ctx)?;
    ip.finish()?;

    Ok(Parts { name, camera, background, objects, lights, integrator, integrator_name: ty, settings, integrator_loc: integ_loc })
}

/// Refuses a render whose worst-case ray count exceeds `max_rays`, naming each factor.
fn check_work(s: &RenderSettings, scene: &Scene, integrator: &dyn crate::Integrator, ty: &str, loc: &Loc, max_rays: u64) -> Result<()> {
    let pixels = f64::from(s.width) * f64::from(s.height);
    let (samples, what) = match s.aa {
        Antialiasing::Stratified => (f64::from(s.spp), "spp"),
        // Every point of the 2^depth lattice in each pixel, corners included.
        Antialiasing::Adaptive { max_depth, .. } => {
            ((f64::from(1u32 << max_depth.min(MAX_ADAPTIVE_DEPTH)) + 1.0).powi(2), "adaptive lattice points per pixel")
        }
    };
    let lens = if scene.camera.aperture > 0.0 { f64::from(s.lens_samples.max(1)) } else { 1.0 };
    let per_ray = integrator.worst_case_rays(scene);
    let total = pixels * samples * lens * per_ray;
    if total.is_nan() || total > max_rays as f64 {
        let e = SceneError::at(
            loc,
            format!(
                "the render may trace {total:.3e} rays, over the budget of {max_rays}: {}×{} pixels × {samples} {what} × {lens} lens samples × {per_ray:.3e} rays per camera ray (integrator \"{ty}\": {})",
                s.width,
                s.height,
                integrator.describe()
            ),
        );
        return Err(
            e.with_help("lower the knobs (spp, lens_samples, max_depth, glossy_rays, shadow_rays), or raise the budget with --max-rays")
        );
    }
    Ok(())
}

/// `table` with `overrides` set over it (unknown keys are reported by the table's reader, at the
/// override's location).
fn with_overrides(table: &Table, overrides: &[(String, Node)]) -> Table {
    let mut t = table.clone();
    for (k, v) in overrides {
        t.set(k, v.loc.clone(), v.clone());
    }
    t
}

fn sub_table<'a>(node: Option<&'a Node>, doc: &Loc, empty: &'a Table, what: &str) -> Result<(&'a Table, Loc)> {
    match node {
        None => Ok((empty, doc.clone())),
        Some(n) => match &n.value {
            Value::Table(t) => Ok((t, n.loc.clone())),
            other => Err(SceneError::at(&n.loc, format!("`{what}` must be a table, found {}", other.type_name()))),
        },
    }
}

fn array_of_tables<'a>(node: Option<&'a Node>, what: &str) -> Result<Vec<&'a Node>> {
    let Some(n) = node else { return Ok(Vec::new()) };
    let Value::Array(items) = &n.value else {
        return Err(SceneError::at(&n.loc, format!("`{what}` must be a list of tables; write [[{what}]]")));
    };
    for it in items {
        if !matches!(it.value, Value::Table(_)) {
            return Err(SceneError::at(&it.loc, format!("each {what} must be a table, found {}", it.value.type_name())));
        }
    }
    Ok(items.iter().collect())
}

/// The keys of an `[[object]]` table that are not its plugin's parameters.
const OBJECT_KEYS: &[&str] = &["type", "name", "transform"];

/// The keys of a `[[light]]` table that are not its plugin's parameters.
const LIGHT_KEYS: &[&str] = &["type", "name"];

/// Reads `type` and `name` of a plugin table (without copying it); returns (type, "\"name\" "
/// or "", the table).
fn plugin_header<'a>(
    node: &'a Node,
    i: usize,
    what: &str,
    known: impl Fn(&str) -> bool,
    names: impl Fn() -> Vec<&'static str>,
) -> Result<(String, String, &'a Table)> {
    let Value::Table(t) = &node.value else { unreachable!("array_of_tables checked this") };
    let ty = match t.get("type") {
        None => {
            return Err(SceneError::at(&node.loc, format!("{what} #{i} has no `type`"))
                .with_help(format!("known {what} types: {}", names().join(", "))));
        }
        Some(n) => match &n.value {
            Value::Str(s) if known(s) => s.clone(),
            Value::Str(s) => {
                return Err(SceneError::at(&n.loc, format!("unknown {what} type \"{s}\"")).with_help(suggest(s, &names())));
            }
            other => return Err(SceneError::at(&n.loc, format!("`type` must be a string, found {}", other.type_name()))),
        },
    };
    let label = match t.get("name") {
        None => String::new(),
        Some(n) => match &n.value {
            Value::Str(s) => format!("\"{s}\" "),
            other => return Err(SceneError::at(&n.loc, format!("`name` must be a string, found {}", other.type_name()))),
        },
    };
    Ok((ty, label, t))
}

fn suggest(word: &str, names: &[&str]) -> String {
    match did_you_mean(word, names.iter().copied()) {
        Some(m) => format!("did you mean \"{m}\"? (known: {})", names.join(", ")),
        None => format!("known: {}", names.join(", ")),
    }
}

#[derive(Default)]
struct NameSet(std::collections::HashMap<String, Loc>);

impl NameSet {
    /// The display name for a plugin instance, rejecting duplicates of explicit names.
    fn claim(&mut self, node: &Node, label: &str, ty: &str, i: usize) -> Result<String> {
        if label.is_empty() {
            return Ok(format!("{ty} #{i}"));
        }
        let name = label.trim().trim_matches('"').to_string();
        if let Some(prev) = self.0.get(&name) {
            return Err(SceneError::at(&node.loc, format!("the name \"{name}\" is already used at {}", prev.describe())));
        }
        self.0.insert(name.clone(), node.loc.clone());
        Ok(name)
    }
}
