//! What loading is told (command-line overrides, limits, the path policy) and what a plugin's
//! constructor gets while it builds ([`LoadContext`]): the scene's folder, the sandbox every file
//! read goes through, the memory budget, shared assets and warnings.

use crate::accel::{AccelChoice, BuildStats};
use crate::load::mesh::{MeshFile, MeshRequest};
use crate::math::color::Encoding;
use crate::param::error::{Loc, Result, SceneError};
use crate::param::files::{OpenLog, ReadError, read_regular};
use crate::param::fingerprint::Fingerprint;
use crate::param::limits::Limits;
use crate::param::value::{Node, Value};
use std::any::Any;
use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

/// Reads a mesh file ([`crate::load::mesh`]). Unwind-safe, as the load context that carries
/// it must stay.
pub type MeshReader = Arc<dyn Fn(&MeshRequest, &LoadContext) -> Result<MeshFile> + Send + Sync + std::panic::RefUnwindSafe>;

/// A mesh file format, chosen by the file's extension.
#[derive(Clone)]
pub struct MeshFormat {
    /// Short name (`"obj"`).
    pub name: &'static str,
    /// Lower-case extensions without the dot (`["gltf", "glb"]`).
    pub extensions: &'static [&'static str],
    /// One line: what the format is and what of it is read.
    pub summary: &'static str,
    /// The reader.
    pub read: MeshReader,
}

/// Settings given outside the scene file (command line), which take precedence over it.
#[derive(Clone, Debug, Default)]
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
    /// The integrator's recursion depth (its parameter with [`crate::param::spec::Role::Depth`],
    /// whatever its name), applied before `integrator_params`.
    pub depth: Option<Node>,
    /// Light parameters, `(light type, name, value)`, applied over every light of that type in
    /// the scene (`environment.resolution`); a scene without such a light is an error.
    pub light_params: Vec<(String, String, Node)>,
    /// `[render]` keys, `(name, value)`, applied over the scene's (e.g. `aa`, `lens_samples`).
    pub render_params: Vec<(String, Node)>,
    /// Camera parameters, `(name, value)`, applied over the scene's `[camera]` (see
    /// [`crate::scene::camera::apply_overrides`]); they also supply a camera to a scene that has none.
    pub camera_params: Vec<(String, Node)>,
}

/// Parses one `KEY=VALUE` setting given outside the scene file, as `--set` and `--camera` take
/// them: the value in TOML syntax, or a bare word (`--set ambient=first_hit`) taken as a string,
/// as the shell leaves it once it has eaten quotes. Errors name `origin` (the flag) with the
/// column.
pub fn key_value(origin: &str, text: &str) -> Result<(String, Node)> {
    let src = crate::param::error::Source::new(origin, text.to_string());
    let Some(eq) = text.find('=') else {
        return Err(SceneError::at(&Loc::new(&src, 0..text.len()), "expected KEY=VALUE"));
    };
    let key = text[..eq].trim().to_string();
    let value = match crate::param::toml::parse_toml_value(&src, eq + 1..text.len()) {
        Ok(v) => v,
        Err(_) if is_bare_word(text[eq + 1..].trim()) => {
            let word = text[eq + 1..].trim();
            let start = eq + 1 + text[eq + 1..].find(word).unwrap_or(0);
            Node { value: Value::Str(word.to_string()), loc: Loc::new(&src, start..start + word.len()) }
        }
        Err(e) => return Err(e),
    };
    Ok((key, value))
}

/// A word a shell passes unquoted that TOML would need quoted: a letter, then letters, digits,
/// `_`, `-` or `.` (`first_hit`, `linear-truncated`). Numbers, `true`, `inf`, lists and tables
/// parse as TOML before this is asked.
fn is_bare_word(s: &str) -> bool {
    s.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && s.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
}

/// Sets the quality knob `name` to `value` in `o`, as `raylab sweep --vary NAME=…` does: `spp`
/// (and stratified anti-aliasing unless `aa` is set), `depth`, `integrator`, the `[render]` keys
/// `aa`, `aa_*` (and adaptive anti-aliasing unless `aa` is set) and `lens_samples`, the camera's
/// `aperture` and `focus_distance`, `TYPE.PARAM` as the parameter of every light of that type
/// (`environment.resolution`), and any other name as an integrator parameter. Settings it
/// implies are located at `origin`.
pub fn apply_knob(o: &mut LoadOptions, origin: &str, name: &str, value: &Node) -> Result<()> {
    let ov = &mut o.overrides;
    let set = |list: &mut Vec<(String, Node)>, key: &str, v: &Node| list.push((key.to_string(), v.clone()));
    match name {
        "spp" => match value.value {
            Value::Int(n) if n >= 1 && n <= i64::from(u32::MAX) => {
                // Samples per pixel are stratified anti-aliasing's knob (adaptive ignores them).
                if !ov.render_params.iter().any(|(k, _)| k == "aa") {
                    ov.render_params.push(("aa".to_string(), Node::given(origin, Value::Str("stratified".into()))));
                }
                ov.spp = Some(n as u32)
            }
            _ => return Err(SceneError::at(&value.loc, "spp must be a whole number ≥ 1")),
        },
        "aa_threshold" | "aa_depth" | "aa_edges" | "aa_signature" | "aa_cell_samples" | "aa_coarse" => {
            if !ov.render_params.iter().any(|(k, _)| k == "aa") {
                ov.render_params.push(("aa".to_string(), Node::given(origin, Value::Str("adaptive".into()))));
            }
            set(&mut ov.render_params, name, value);
        }
        "aa" | "lens_samples" | "target_error" | "target_min_spp" | "time_budget" | "texture_filter" => {
            set(&mut ov.render_params, name, value)
        }
        "aperture" | "focus_distance" => set(&mut ov.camera_params, name, value),
        "integrator" => match &value.value {
            Value::Str(t) => ov.integrator = Some(t.clone()),
            _ => return Err(SceneError::at(&value.loc, "integrator must be a name (phong, path, …)")),
        },
        "depth" => ov.depth = Some(value.clone()),
        _ if name.contains('.') => {
            let (ty, param) = name.split_once('.').unwrap_or_default();
            ov.light_params.push((ty.to_string(), param.to_string(), value.clone()));
        }
        _ => set(&mut ov.integrator_params, name, value),
    }
    Ok(())
}

/// How to load a scene.
#[derive(Clone, Debug, Default)]
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
    pub image: crate::image::output::ImagePlan,
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
    fingerprint: Mutex<Fingerprint>,
    read: Mutex<Vec<PathBuf>>,
    /// Paths as written, resolved once per load ([`LoadContext::resolve_path`]): a glTF placed by
    /// 3·10⁵ instance nodes is looked up once, not 6·10⁵ times (each a `getcwd` and `readlink`s).
    resolved: Mutex<HashMap<String, PathBuf>>,
    /// The scene's folder, canonicalised once.
    canonical_dir: OnceLock<PathBuf>,
    resolutions: std::sync::atomic::AtomicU64,
    mesh_formats: OnceLock<Vec<MeshFormat>>,
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
            fingerprint: Mutex::default(),
            read: Mutex::default(),
            resolved: Mutex::default(),
            canonical_dir: OnceLock::new(),
            resolutions: std::sync::atomic::AtomicU64::new(0),
            mesh_formats: OnceLock::new(),
        }
    }

    /// Makes `formats` (a registry's) the mesh formats this load reads; the loader calls it
    /// before building objects. Only the first call counts.
    pub fn use_mesh_formats(&self, formats: &[MeshFormat]) {
        let _ = self.mesh_formats.set(formats.to_vec());
    }

    /// The mesh formats this load reads ([`Self::use_mesh_formats`]).
    pub fn mesh_formats(&self) -> &[MeshFormat] {
        self.mesh_formats.get().map_or(&[], Vec::as_slice)
    }

    /// The mesh format that reads files with extension `ext` (lower case, no dot).
    pub fn mesh_format_for(&self, ext: &str) -> Option<&MeshFormat> {
        self.mesh_formats().iter().rev().find(|f| f.extensions.contains(&ext))
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

    /// Adds a file (named as the scene names it) to the fingerprint of what the render depends on.
    pub fn fingerprint(&self, name: &str, bytes: &[u8]) {
        let mut f = self.fingerprint.lock().unwrap_or_else(|e| e.into_inner());
        f.add("file name", name.as_bytes());
        f.add("file", bytes);
    }

    /// Every file read through [`LoadContext::read_file`] so far, as resolved (once each): what a
    /// command must not overwrite ([`crate::param::files::same_file`]).
    pub fn files_read(&self) -> Vec<PathBuf> {
        self.read.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The fingerprint of the files read so far.
    pub fn files_fingerprint(&self) -> Fingerprint {
        *self.fingerprint.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The scene's folder as a path that names it (`.` for the empty folder of a bare file name).
    fn dir(&self) -> &Path {
        if self.scene_dir.as_os_str().is_empty() { Path::new(".") } else { self.scene_dir }
    }

    /// The scene's folder, canonicalised; an error at `loc` if it cannot be (the confinement
    /// check then cannot be made, so nothing is read).
    fn canonical_dir(&self, loc: &Loc) -> Result<PathBuf> {
        if let Some(d) = self.canonical_dir.get() {
            return Ok(d.clone());
        }
        let d = self.dir().canonicalize().map_err(|e| {
            SceneError::at(loc, format!("cannot resolve the scene's folder \"{}\": {e}", self.dir().display()))
                .with_help("files the scene names are read only once its folder is known; pass --allow-outside-paths to skip the check")
        })?;
        Ok(self.canonical_dir.get_or_init(|| d).clone())
    }

    /// How many paths this load resolved against the file system ([`LoadContext::resolve_path`]
    /// answers a path it resolved before from memory).
    pub fn path_resolutions(&self) -> u64 {
        self.resolutions.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Resolves a path written in the scene (at `loc`) against the scene's folder, refusing
    /// absolute paths and paths that leave the folder, through `..` or through symbolic links,
    /// unless `allow_outside_paths` is set. Fails closed: a path whose target or folder cannot be
    /// resolved is refused.
    /// A path is resolved once per load and remembered (a link changed in between is still caught
    /// when the file is opened: [`LoadContext::read_file`] checks the descriptor's real path).
    pub fn resolve_path(&self, path: &str, loc: &Loc) -> Result<PathBuf> {
        self.check_written_path(path, loc)?;
        if let Some(full) = self.resolved.lock().unwrap_or_else(|e| e.into_inner()).get(path) {
            return Ok(full.clone());
        }
        let full = self.resolve_anew(path, loc)?;
        self.resolved.lock().unwrap_or_else(|e| e.into_inner()).insert(path.to_string(), full.clone());
        Ok(full)
    }

    /// [`LoadContext::resolve_path`] against the file system.
    fn resolve_anew(&self, path: &str, loc: &Loc) -> Result<PathBuf> {
        self.resolutions.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
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
        let opened = crate::param::files::open_regular(&full, self.options.open_log.as_ref()).map_err(failed)?;
        if !self.options.allow_outside_paths {
            // The file opened is the one checked, even if a link changed in between.
            let dir = self.canonical_dir(loc)?;
            match &opened.real_path {
                Some(real) => self.confined(real, &dir, path, loc)?,
                None => return Err(SceneError::at(loc, format!("cannot resolve \"{}\" once opened", full.display()))),
            }
        }
        let bytes = opened.read_to_end(self.options.limits.max_file_bytes).map_err(failed)?;
        self.fingerprint(path, &bytes);
        let mut read = self.read.lock().unwrap_or_else(|e| e.into_inner());
        if !read.contains(&full) {
            read.push(full.clone());
        }
        drop(read);
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
