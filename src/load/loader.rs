//! Loading a scene: reading a scene file into raylab's scene description (a located [`Table`]),
//! then building it, plugin by plugin, through the [`Registry`].
//!
//! Every format (raylab's TOML here; others registered as [`crate::load::registry::SceneFormat`])
//! produces the same description, so validation, limits and error locations work alike for all.

use crate::accel::AccelChoice;
use crate::geometry::transform::{Transformed, parse_transform};
use crate::load::context::{LoadContext, LoadOptions, read_user_file, scene_dir};
use crate::load::registry::{BuiltGeometry, Registry};
use crate::load::textures::TextureLibrary;
use crate::math::color::Encoding;
use crate::param::description::SceneDescription;
use crate::param::error::{Loc, Num, Result, SceneError, Source, did_you_mean};
use crate::param::fingerprint::{Fingerprint, differing_fields};
use crate::param::limits::{OBJECT_BYTES, toml_memory_estimate};
use crate::param::params::Params;
use crate::param::spec::{ParamDefault, ParamKind, ParamSpec, Role};
use crate::param::toml::parse_toml;
use crate::param::value::{Node, Table, Value};
use crate::render::job::{AdaptiveSettings, ErrorTarget, MAX_ADAPTIVE_COARSE, MAX_CELL_SAMPLES};
use crate::render::{Antialiasing, MAX_ADAPTIVE_DEPTH, RenderJob, RenderSettings};
use crate::scene::Scene;
use crate::scene::camera::{CAMERA_PARAMS, Camera};
use crate::scene::material::{Material, MaterialLibrary};
use crate::scene::object::{EmissionSides, Object};
use std::path::Path;
use std::sync::Arc;

/// The keys of a scene file's root.
pub const SCENE_PARAMS: &[ParamSpec] = &[
    ParamSpec::new("name", ParamKind::Str, ParamDefault::Optional, "scene name (default: the file name)"),
    ParamSpec::new("background", ParamKind::Color, ParamDefault::Float(0.0), "colour of rays that hit nothing, linear RGB"),
    ParamSpec::new("render", ParamKind::Any, ParamDefault::Optional, "[render] table: image size, samples, seed, encoding"),
    ParamSpec::new("camera", ParamKind::Any, ParamDefault::Required, "[camera] table"),
    ParamSpec::new("integrator", ParamKind::Any, ParamDefault::Optional, "[integrator] table: `type` and its parameters"),
    ParamSpec::new(
        "textures",
        ParamKind::Any,
        ParamDefault::Optional,
        "[textures.NAME] tables: `type` and its parameters; a material colour names one (kd = \"NAME\"); read only when a material uses it",
    ),
    ParamSpec::new("materials", ParamKind::Any, ParamDefault::Optional, "[materials.NAME] tables"),
    ParamSpec::new(
        "object",
        ParamKind::Any,
        ParamDefault::Optional,
        "[[object]] tables: `type`, optional `name` and `transform`, and the type's parameters",
    ),
    ParamSpec::new("light", ParamKind::Any, ParamDefault::Optional, "[[light]] tables: `type`, optional `name`, and the type's parameters"),
];

/// The keys of `[render]`.
pub const RENDER_PARAMS: &[ParamSpec] = &[
    ParamSpec::new("width", ParamKind::Int, ParamDefault::Int(800), "image width, pixels"),
    ParamSpec::new("height", ParamKind::Int, ParamDefault::Int(600), "image height, pixels"),
    ParamSpec::new(
        "spp",
        ParamKind::Int,
        ParamDefault::Int(1),
        "samples per pixel (1 = through the pixel centre, more = stratified jitter)",
    ),
    ParamSpec::new("seed", ParamKind::Int, ParamDefault::Int(0), "random seed; same seed, same image"),
    ParamSpec::new(
        "encoding",
        ParamKind::Str,
        ParamDefault::Str("srgb"),
        "8-bit encoding: \"srgb\", \"linear\" (clamped values written straight, as the report) or \"linear-truncated\" (straight, truncated to 0–255 as the course's Java renderer did; its test images bit for bit)",
    ),
    ParamSpec::new(
        "aa",
        ParamKind::Str,
        ParamDefault::Str("stratified"),
        "anti-aliasing: \"stratified\" (spp samples per pixel) or \"adaptive\" (rays through pixel corners, more only where they disagree: edges located by bisection, squares subdivided)",
    ),
    ParamSpec::new(
        "aa_threshold",
        ParamKind::Float,
        ParamDefault::Float(0.02),
        "adaptive: refine a pixel whose corners' displayed values (0..1) differ by more than this (a square of side s pixels: more than this / s^1.5), in [0, 1]",
    ),
    ParamSpec::new(
        "aa_depth",
        ParamKind::Int,
        ParamDefault::Int(3),
        "adaptive: most subdivision levels per pixel, 0..=8 (edges are located to 1/2^depth of a pixel)",
    ),
    ParamSpec::new(
        "aa_edges",
        ParamKind::Bool,
        ParamDefault::Bool(true),
        "adaptive: where two sides of a square cross an edge, locate it by bisection and split the square along it instead of subdividing",
    ),
    ParamSpec::new(
        "aa_signature",
        ParamKind::Bool,
        ParamDefault::Bool(false),
        "adaptive: also refine where the corners' rays saw different objects (the integrator's sample signature)",
    ),
    ParamSpec::new(
        "aa_cell_samples",
        ParamKind::Int,
        ParamDefault::Int(0),
        "adaptive: stratified samples added inside each finest cell whose corners still disagree, 0..=64",
    ),
    ParamSpec::new(
        "aa_coarse",
        ParamKind::Int,
        ParamDefault::Int(0),
        "adaptive: levels above the pixel tested first, 0..=3: blocks of 2^n pixels whose corners agree are interpolated from four rays (features narrower than a block can be missed)",
    ),
    ParamSpec::new(
        "lens_samples",
        ParamKind::Int,
        ParamDefault::Int(1),
        "rays through distinct lens points per image sample (depth of field only), ≥ 1",
    ),
    ParamSpec::new(
        "target_error",
        ParamKind::Float,
        ParamDefault::Optional,
        "adaptive sampling: a pixel is tested at target_min_spp samples and each doubling, and stops once the estimated standard error of its mean luminance over √mean (its relative error at luminance 1) is at most this times √(samples / target_min_spp), so samples go in proportion to each pixel's noise (e.g. 0.05; in (0, 1]); spp is then the most a pixel takes (stratified only)",
    ),
    ParamSpec::new(
        "target_min_spp",
        ParamKind::Int,
        ParamDefault::Int(16),
        "with target_error: samples every pixel takes before its error is first tested, ≥ 2 (fewer lets pixels whose first samples happen to agree stop too early)",
    ),
    ParamSpec::new(
        "time_budget",
        ParamKind::Float,
        ParamDefault::Optional,
        "seconds of tracing: the image refines in passes that double each pixel's samples (spp is the most a pixel takes) and stops when the time is up, every pixel keeping the samples it has (stratified only); the `spp` layer (--aov spp) repeats it bit for bit (--spp-map)",
    ),
    ParamSpec::new(
        "texture_filter",
        ParamKind::Bool,
        ParamDefault::Bool(true),
        "filter textures over each pixel's footprint (ray differentials: MIP maps for images, band-limited patterns); false: look them up at a point",
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
        e.location = crate::param::error::Location::File { path: path.display().to_string(), line_col: None };
        e
    })?;
    ctx.fingerprint("the scene file", &bytes);
    if ext == "toml" {
        let text = String::from_utf8(bytes).map_err(|e| {
            SceneError::in_file(path, None, format!("scene file is not UTF-8 text (byte {})", e.utf8_error().valid_up_to()))
        })?;
        return parse_toml(&Source::new(path.display().to_string(), text), stem(path));
    }
    match registry.format_for(&ext) {
        Some(f) => (f.read)(path, &bytes, ctx),
        None if registry.absent_feature(&ext).is_some() => {
            let feature = registry.absent_feature(&ext).unwrap_or_default();
            Err(SceneError::in_file(path, None, format!("reading \".{ext}\" files needs the `{feature}` feature"))
                .with_help(crate::param::error::built_without(feature)))
        }
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
    ctx.fingerprint("the scene file", text.as_bytes());
    let desc = parse_toml(&Source::new(name, text), stem(Path::new(name)))?;
    let parts = build_parts(registry, &desc, &ctx)?;
    drop(desc);
    parts.assemble(&ctx)
}

fn stem(p: &Path) -> String {
    p.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_string()
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
    background: crate::math::color::Color,
    objects: Vec<Object>,
    lights: NamedLights,
    integrator: Box<dyn crate::render::integrator::Integrator>,
    integrator_name: String,
    integrator_params: Table,
    settings: RenderSettings,
    /// Whether textures are filtered over pixel footprints (`[render] texture_filter`).
    texture_filter: bool,
    /// The fingerprint of everything above that decides pixels (with the files read).
    fingerprint: Fingerprint,
}

impl Parts {
    fn assemble(self, ctx: &LoadContext) -> Result<RenderJob> {
        let mut scene = Scene::with_accel(self.name, self.camera, self.background, self.objects, self.lights, ctx.options.accel);
        scene.record_object_builds(ctx.assets.build_stats());
        // Footprints shrink with stratified samples; adaptive sampling's rays each stand for
        // a pixel's area at most.
        let s = &self.settings;
        let spp = if s.aa == Antialiasing::Stratified { s.spp } else { 1 };
        scene.set_texture_filter(self.texture_filter, s.width, s.height, spp);
        let (integrator, ty) = (self.integrator, self.integrator_name);
        let mut fingerprint = self.fingerprint;
        fingerprint.add("files", &ctx.files_fingerprint().hex().into_bytes());
        fingerprint.add("accel", format!("{:?}", ctx.options.accel).as_bytes());
        Ok(RenderJob {
            scene,
            integrator,
            integrator_name: ty,
            integrator_params: self.integrator_params,
            settings: self.settings,
            warnings: ctx.take_warnings(),
            fingerprint: fingerprint.hex(),
            inputs: ctx.files_read(),
            max_rays: ctx.options.limits.max_rays,
        })
    }
}

/// Builds every section of a scene file, in the order of its sections' dependencies: the
/// render settings (the camera needs the image size), the camera, textures and materials, the
/// objects (a fitted camera needs their bounds), the lights, the integrator.
fn build_parts(registry: &Registry, desc: &SceneDescription, ctx: &LoadContext) -> Result<Parts> {
    ctx.use_mesh_formats(registry.mesh_formats());
    if ctx.options.accel == AccelChoice::Bvh && !crate::accel::build::BVH_AVAILABLE {
        return Err(SceneError::msg("a BVH was asked for (--accel bvh), but it needs the `bvh` feature")
            .with_help(format!("{}; or use --accel auto or list", crate::param::error::built_without("bvh"))));
    }
    let mut root = Params::new(format!("scene {}", desc.name), SCENE_PARAMS, &desc.root, desc.loc.clone());
    let name = match root.node("name")? {
        Some(n) => match &n.value {
            Value::Str(s) => s.clone(),
            _ => return Err(SceneError::at(&n.loc, "`name` must be a string")),
        },
        None => desc.name.clone(),
    };
    let background = root.color("background")?;
    let (texture_filter, settings) = render_section(root.node("render")?, desc, ctx)?;
    let camera = CameraSection::read(root.node("camera")?, desc, ctx.options, &settings)?;
    // [textures.NAME]: built when a material first names one.
    let textures = TextureLibrary::new(registry, ctx);
    if let Some(n) = root.node("textures")? {
        textures.define(n)?;
    }
    let materials = material_section(root.node("materials")?, &textures)?;
    let objects = object_section(registry, root.node("object")?, ctx, &materials, &textures)?;
    let camera = camera.build(&objects, desc, &settings)?;
    for (name, loc) in textures.unused() {
        ctx.warn(SceneError::at(&loc, format!("texture \"{name}\" is not used by any material; it was not loaded")));
    }
    let lights = light_section(registry, root.node("light")?, ctx)?;
    warn_if_unlit(&objects, &lights, desc, ctx);
    let integ_node = root.node("integrator")?;
    root.finish()?;
    let integ = integrator_section(registry, integ_node, desc, ctx)?;

    // What decides the pixels besides the files: the resolved settings (those off their
    // defaults: a new setting at its default changes no fingerprint), camera and integrator
    // (its parameters as given).
    let mut fingerprint = Fingerprint::default();
    fingerprint.add("raylab", env!("CARGO_PKG_VERSION").as_bytes());
    fingerprint.add("settings", differing_fields(&settings, &default_settings()).as_bytes());
    fingerprint.add("camera", format!("{camera:?}").as_bytes());
    fingerprint.add("background", format!("{background:?}").as_bytes());
    fingerprint.add("integrator", integ.name.as_bytes());
    fingerprint.add("integrator parameters", crate::param::toml::table_to_toml(&integ.params).as_bytes());
    if objects.iter().flat_map(|o| o.materials()).any(Material::looks_up_textures) {
        // Only for a textured scene (the setting changes no other pixel, so other renders keep
        // their fingerprints); either way, so a render from before filtering was the default
        // (point lookups, no record) never matches a filtered one.
        fingerprint.add("texture filter", if texture_filter { b"footprint" } else { b"point" });
    }
    Ok(Parts {
        name,
        camera,
        background,
        objects,
        lights,
        integrator: integ.integrator,
        integrator_name: integ.name,
        integrator_params: integ.params,
        settings,
        texture_filter,
        fingerprint,
    })
}

/// The settings of an empty `[render]` table: [`RENDER_PARAMS`]' defaults for the image size and
/// samples, and [`RenderSettings::new`]'s for the rest (what the fingerprint compares with).
fn default_settings() -> RenderSettings {
    let int = |name: &str| match RENDER_PARAMS.iter().find(|s| s.name == name).map(|s| &s.default) {
        Some(ParamDefault::Int(v)) => u32::try_from(*v).unwrap_or(1),
        _ => 1,
    };
    RenderSettings::new(int("width"), int("height"), int("spp"))
}

/// `[render]`, with the command line's settings over the file's, checked against the limits;
/// the image's memory is charged to the load.
/// `[render]`: the render settings, and whether textures are filtered (`texture_filter`).
fn render_section(node: Option<&Node>, desc: &SceneDescription, ctx: &LoadContext) -> Result<(bool, RenderSettings)> {
    let opts = ctx.options;
    let ov = &opts.overrides;
    let empty = Table::default();
    let (render_table, render_loc) = sub_table(node, &desc.loc, &empty, "render")?;
    let render_table = with_overrides(render_table, &ov.render_params);
    let mut rp = Params::new("[render]", RENDER_PARAMS, &render_table, render_loc);
    let limits = &opts.limits;
    let (width, height) = image_size_checked(&mut rp, ctx)?;
    let file_spp = rp.int_in("spp", 1..=i64::MAX)?;
    let spp = ov.spp.map_or(file_spp, i64::from);
    if spp < 1 || spp > i64::from(limits.max_spp) {
        return Err(rp
            .error_at("spp", format_args!("{spp} samples per pixel is outside 1..={}", limits.max_spp))
            .with_help("raise the limit with --max-spp"));
    }
    let file_seed = rp.int_in("seed", 0..=i64::MAX)? as u64;
    let seed = ov.seed.unwrap_or(file_seed);
    let file_encoding = Encoding::parse(&rp.choice("encoding", &Encoding::NAMES)?).unwrap_or_default();
    let encoding = ov.encoding.unwrap_or(file_encoding);
    let aa = antialiasing(&mut rp)?;
    let lens_samples = rp.int_in("lens_samples", 1..=i64::from(limits.max_spp))? as u32;
    if u64::from(lens_samples) * spp as u64 > u64::from(limits.max_spp) {
        return Err(rp
            .error_at(
                "lens_samples",
                format_args!("{spp} spp × {lens_samples} lens samples exceeds the limit of {} rays per pixel", limits.max_spp),
            )
            .with_help("raise the limit with --max-spp"));
    }
    let target = error_target(&mut rp, spp, aa)?;
    let time_budget = time_budget(&mut rp, aa)?;
    let texture_filter = rp.bool("texture_filter")?;
    rp.finish()?;
    Ok((
        texture_filter,
        RenderSettings {
            width: width as u32,
            height: height as u32,
            spp: spp as u32,
            seed,
            encoding,
            aa,
            lens_samples,
            target,
            time_budget,
            subpixels: 1,
        },
    ))
}

/// The image size of `[render]` with the command line's over it, checked against the limits
/// (sides, pixels, the image's memory), and that memory charged to the load.
fn image_size_checked(rp: &mut Params, ctx: &LoadContext) -> Result<(i64, i64)> {
    let (ov, limits) = (&ctx.options.overrides, &ctx.options.limits);
    let max_side = i64::from(limits.max_side.min(i32::MAX as u32));
    // The file's values are read (and validated) even when the command line overrides them.
    let (file_width, file_height) = (rp.int_in("width", 1..=i64::MAX)?, rp.int_in("height", 1..=i64::MAX)?);
    let (width, height) = image_size((file_width, file_height), (ov.width, ov.height));
    // An error about the size points at the flag that set it, else at the scene's [render].
    // (A side the other flag derived names that flag.)
    let width_flag = ov.width.map(|w| Node::given("--width", Value::Int(w.into())));
    let height_flag = ov.height.map(|h| Node::given("--height", Value::Int(h.into())));
    let size_error = |rp: &Params, key: &str, message: String| {
        let flag =
            if key == "height" { height_flag.as_ref().or(width_flag.as_ref()) } else { width_flag.as_ref().or(height_flag.as_ref()) };
        match flag {
            Some(n) => SceneError::at(&n.loc, message),
            None if key.is_empty() => rp.error(message),
            None => rp.error_at(key, message),
        }
    };
    for (v, what) in [(width, "width"), (height, "height")] {
        if v < 1 || v > max_side {
            return Err(
                size_error(rp, what, format!("image {what} {v} is outside 1..={max_side}")).with_help("raise the limit with --max-side")
            );
        }
    }
    let pixels = width as u64 * height as u64;
    if pixels > limits.max_pixels {
        return Err(size_error(
            rp,
            "",
            format!("image of {width}×{height} = {pixels} pixels exceeds the limit of {} pixels", limits.max_pixels),
        )
        .with_help("raise the limit with --max-pixels"));
    }
    let bytes = crate::image::output::image_bytes(pixels, &ctx.options.image);
    if bytes > limits.max_image_bytes {
        return Err(size_error(
            rp,
            "",
            format!(
                "image of {width}×{height} pixels needs about {} MB (film, per-pixel sums, layers and encoding), over the limit of {} MB",
                bytes.div_ceil(1 << 20),
                limits.max_image_bytes >> 20
            ),
        )
        .with_help("raise the limit with --max-image-bytes, or render a smaller image"));
    }
    ctx.charge(bytes, &format!("the image of {width}×{height} pixels"), Some(rp.loc()))?;
    Ok((width, height))
}

/// `[render]`'s anti-aliasing keys.
fn antialiasing(rp: &mut Params) -> Result<Antialiasing> {
    let aa = match rp.choice("aa", &["stratified", "adaptive"])?.as_str() {
        "adaptive" => Antialiasing::Adaptive(AdaptiveSettings {
            threshold: rp.float_in("aa_threshold", 0.0..=1.0)?,
            max_depth: rp.int_in("aa_depth", 0..=i64::from(MAX_ADAPTIVE_DEPTH))? as u32,
            edges: rp.bool("aa_edges")?,
            signature: rp.bool("aa_signature")?,
            cell_samples: rp.int_in("aa_cell_samples", 0..=i64::from(MAX_CELL_SAMPLES))? as u32,
            coarse: rp.int_in("aa_coarse", 0..=i64::from(MAX_ADAPTIVE_COARSE))? as u32,
        }),
        _ => Antialiasing::Stratified,
    };
    if let Antialiasing::Adaptive(a) = aa
        && a.max_depth + a.coarse > MAX_ADAPTIVE_DEPTH
    {
        return Err(rp
            .error_at(
                "aa_coarse",
                format_args!(
                    "{} coarse levels above {} levels of depth: the lattice holds at most {MAX_ADAPTIVE_DEPTH} in all",
                    a.coarse, a.max_depth
                ),
            )
            .with_help("lower aa_coarse or aa_depth"));
    }
    Ok(aa)
}

/// `[render]`'s error target (`target_error`, `target_min_spp`), checked against `spp` and the
/// anti-aliasing.
fn error_target(rp: &mut Params, spp: i64, aa: Antialiasing) -> Result<Option<ErrorTarget>> {
    let target_min_spp = rp.int_in("target_min_spp", 2..=i64::from(u32::MAX))? as u32;
    Ok(match rp.float_opt("target_error")? {
        None => None,
        Some(e) if !(e > 0.0 && e <= ErrorTarget::MAX) => {
            return Err(rp
                .error_at(
                    "target_error",
                    format_args!("expected a relative error (RMSE) in (0, {}], found {}", Num(ErrorTarget::MAX), Num(e)),
                )
                .with_help("0.05 is 5 %; for a fixed number of samples a pixel, give spp (--spp) without a target"));
        }
        Some(_) if matches!(aa, Antialiasing::Adaptive(_)) => {
            return Err(rp
                .error_at("target_error", "an error target applies to stratified sampling, not to adaptive anti-aliasing")
                .with_help("use aa = \"stratified\" (--aa stratified) with target_error"));
        }
        Some(_) if spp < i64::from(target_min_spp) => {
            return Err(rp
                .error_at(
                    "target_error",
                    format_args!("with an error target, spp ({spp}) is the most samples a pixel takes: it must be at least target_min_spp ({target_min_spp})"),
                )
                .with_help("raise spp (--spp 1024, say) or lower target_min_spp"));
        }
        Some(error) => Some(ErrorTarget { error, min_spp: target_min_spp }),
    })
}

/// The longest time budget, seconds (a year).
const MAX_TIME_BUDGET: f64 = 365.0 * 24.0 * 3600.0;

/// `[render]`'s time budget, checked against the anti-aliasing.
fn time_budget(rp: &mut Params, aa: Antialiasing) -> Result<Option<std::time::Duration>> {
    Ok(match rp.float_opt("time_budget")? {
        None => None,
        Some(t) if !(t > 0.0 && t <= MAX_TIME_BUDGET) => {
            return Err(rp.error_at("time_budget", format_args!("expected seconds in (0, {MAX_TIME_BUDGET}], found {}", Num(t))));
        }
        Some(_) if matches!(aa, Antialiasing::Adaptive(_)) => {
            return Err(rp
                .error_at("time_budget", "a time budget applies to stratified sampling, not to adaptive anti-aliasing")
                .with_help("use aa = \"stratified\" (--aa stratified) with time_budget"));
        }
        Some(t) => Some(std::time::Duration::from_secs_f64(t)),
    })
}

/// `[camera]`, with the command line's keys over the file's: built at once, or, with
/// `fit = true`, once the objects' bounds are known ([`CameraSection::build`]).
struct CameraSection {
    table: Table,
    loc: Loc,
    /// Where `fit = true` was asked.
    fit: Option<Loc>,
    camera: Option<Camera>,
}

impl CameraSection {
    fn read(node: Option<&Node>, desc: &SceneDescription, opts: &LoadOptions, settings: &RenderSettings) -> Result<CameraSection> {
        let ov = &opts.overrides;
        if node.is_none() && ov.camera_params.is_empty() {
            return Err(SceneError::at(&desc.loc, "the scene has no [camera]").with_help(
                "add a [camera] table with `position` and `look_at` (or the report's `to` and `screen_*`), or give one with --camera KEY=VALUE",
            ));
        }
        let empty = Table::default();
        let (cam_table, loc) = sub_table(node, &desc.loc, &empty, "camera")?;
        let table = crate::scene::camera::apply_overrides(cam_table, &ov.camera_params);
        // `fit = true` needs the objects' bounds: that camera is built after them.
        let fit = match table.get("fit") {
            Some(Node { value: Value::Bool(b), loc }) => b.then(|| loc.clone()),
            Some(n) => return Err(SceneError::at(&n.loc, format!("`fit` must be true or false, found {}", n.value.type_name()))),
            None => None,
        };
        let camera = if fit.is_none() { Some(build_camera(&table, &loc, settings)?) } else { None };
        Ok(CameraSection { table, loc, fit, camera })
    }

    /// The camera: the one read, or the one that frames `objects`.
    fn build(self, objects: &[Object], desc: &SceneDescription, settings: &RenderSettings) -> Result<Camera> {
        let CameraSection { table, loc, fit, camera } = self;
        match camera {
            Some(c) => Ok(c),
            None => build_camera(&fitted_camera(table, objects, &fit.unwrap_or_else(|| desc.loc.clone()), settings)?, &loc, settings),
        }
    }
}

fn build_camera(table: &Table, loc: &Loc, settings: &RenderSettings) -> Result<Camera> {
    let mut cp = Params::new("[camera]", CAMERA_PARAMS, table, loc.clone());
    let camera = Camera::from_params(&mut cp, settings.width, settings.height)?;
    cp.finish()?;
    Ok(camera)
}

/// `[materials.NAME]`.
fn material_section(node: Option<&Node>, textures: &TextureLibrary) -> Result<MaterialLibrary> {
    let mut materials = MaterialLibrary::default();
    if let Some(n) = node {
        let Value::Table(t) = &n.value else {
            return Err(SceneError::at(&n.loc, "`materials` must be a table of [materials.NAME] tables"));
        };
        for e in &t.entries {
            let Value::Table(mt) = &e.value.value else {
                return Err(SceneError::at(&e.value.loc, format!("material \"{}\" must be a table of coefficients", e.key)));
            };
            materials.insert(e.key.clone(), Material::from_table(mt, &e.value.loc, &format!("material \"{}\"", e.key), textures)?);
        }
    }
    Ok(materials)
}

/// `[[object]]`: each built by its plugin, placed by its `transform`, given its materials.
fn object_section(
    registry: &Registry,
    node: Option<&Node>,
    ctx: &LoadContext,
    materials: &MaterialLibrary,
    textures: &TextureLibrary,
) -> Result<Vec<Object>> {
    let mut objects = Vec::new();
    let default_material: Arc<[Material]> = Arc::from([materials.default_material()]);
    let mut names = NameSet::default();
    for (i, node) in array_of_tables(node, "object")?.into_iter().enumerate() {
        let (ty, label, params) = plugin_header(
            registry,
            node,
            i,
            "object",
            |n| registry.geometry(n).is_some(),
            || registry.geometries().map(|p| p.name).collect(),
        )?;
        let plugin = registry.geometry(&ty).expect("checked by plugin_header");
        let what = format!("object #{i} {label}({ty})");
        ctx.charge(OBJECT_BYTES, &what, Some(&node.loc))?;
        let transform = params.get("transform").map(|n| parse_transform(n).map_err(|e| e.context(&what))).transpose()?;
        let mut p = Params::new(&what, plugin.info.params, params, node.loc.clone()).reserving(OBJECT_KEYS);
        let BuiltGeometry { geometry: mut g, materials: own_materials } = (plugin.build)(&mut p, ctx)?;
        p.finish()?;
        if let Some(t) = transform.filter(|t| !t.is_identity()) {
            g = Box::new(Transformed::new(g, t));
        }
        if let Some(b) = g.bounds().filter(|b| !b.is_empty()) {
            let reach = b.min.abs().max(b.max.abs()).max_element();
            if reach.is_nan() || reach > crate::math::bounds::MAX_COORDINATE {
                return Err(SceneError::at(
                    &node.loc,
                    format!(
                        "{what} reaches {reach:.3e} from the origin, beyond the {:e} raylab represents",
                        crate::math::bounds::MAX_COORDINATE
                    ),
                )
                .with_help("scale the scene down, or move it toward the origin"));
            }
        }
        // The object's `material` replaces what the shape's file defines; without either, the
        // scene's default.
        let materials = match params.get("material") {
            Some(n) => Arc::from([materials.resolve(n, &what, textures)?]),
            None => own_materials.unwrap_or_else(|| default_material.clone()),
        };
        let sides = emission_sides(params, &what)?;
        objects.push(Object::new(names.claim(node, &label, &ty, i)?, g, materials).with_emission_sides(sides));
    }
    Ok(objects)
}

/// An object's `emission_sides`.
fn emission_sides(params: &Table, what: &str) -> Result<EmissionSides> {
    Ok(match params.get("emission_sides") {
        None => EmissionSides::Both,
        Some(n) => match &n.value {
            Value::Str(s) => EmissionSides::parse(s).ok_or_else(|| {
                let hint =
                    did_you_mean(s, EmissionSides::NAMES.iter().copied()).map_or(String::new(), |m| format!(" (did you mean \"{m}\"?)"));
                SceneError::at(&n.loc, format!("{what}: unknown emission_sides \"{s}\""))
                    .with_help(format!("expected one of: {}{hint}", EmissionSides::NAMES.join(", ")))
            })?,
            _ => {
                return Err(SceneError::at(&n.loc, format!("{what}: emission_sides must be a string: \"both\", \"front\" or \"back\"")));
            }
        },
    })
}

/// A scene's lights, each with its name.
type NamedLights = Vec<(String, Box<dyn crate::scene::light::LightSource>)>;

/// `[[light]]`: each built by its plugin.
fn light_section(registry: &Registry, node: Option<&Node>, ctx: &LoadContext) -> Result<NamedLights> {
    let mut lights = Vec::new();
    let mut light_names = NameSet::default();
    for (i, node) in array_of_tables(node, "light")?.into_iter().enumerate() {
        let (ty, label, params) =
            plugin_header(registry, node, i, "light", |n| registry.light(n).is_some(), || registry.lights().map(|p| p.name).collect())?;
        let plugin = registry.light(&ty).expect("checked by plugin_header");
        let what = format!("light #{i} {label}({ty})");
        let overrides: Vec<(String, Node)> =
            ctx.options.overrides.light_params.iter().filter(|(t, ..)| *t == ty).map(|(_, k, v)| (k.clone(), v.clone())).collect();
        for (k, v) in &overrides {
            if !plugin.info.params.iter().any(|s| s.name == k) {
                let names: Vec<&str> = plugin.info.params.iter().map(|s| s.name).collect();
                return Err(SceneError::at(&v.loc, format!("light type \"{ty}\" has no parameter `{k}`"))
                    .with_help(format!("its parameters: {}", names.join(", "))));
            }
        }
        let params = &with_overrides(params, &overrides);
        let mut p = Params::new(&what, plugin.info.params, params, node.loc.clone()).reserving(LIGHT_KEYS);
        let l = (plugin.build)(&mut p, ctx)?;
        p.finish()?;
        lights.push((light_names.claim(node, &label, &ty, i)?, l));
    }
    // A light parameter set from outside for a type the scene has none of would change nothing.
    let nodes = array_of_tables(node, "light")?;
    let has = |ty: &str| {
        nodes
            .iter()
            .any(|n| matches!(&n.value, Value::Table(t) if t.get("type").is_some_and(|v| matches!(&v.value, Value::Str(s) if s == ty))))
    };
    if let Some((ty, k, v)) = ctx.options.overrides.light_params.iter().find(|(t, ..)| !has(t)) {
        return Err(SceneError::at(&v.loc, format!("the scene has no \"{ty}\" light whose `{k}` could be set")));
    }
    Ok(lights)
}

/// A scene nothing lights renders black (or only its background): say so, since the render
/// itself succeeds.
fn warn_if_unlit(objects: &[Object], lights: &NamedLights, desc: &SceneDescription, ctx: &LoadContext) {
    if lights.is_empty()
        && !objects
            .iter()
            .any(|o| o.materials().iter().any(|m| crate::math::color::max_channel(m.emission) > 0.0 || !m.textures.is_empty()))
    {
        ctx.warn(
            SceneError::in_file(
                &desc.loc.source.name,
                None,
                "the scene has no light and nothing in it emits: the image will show only the background",
            )
            .with_help("add a [[light]], e.g. type = \"point\" with a `position`, or type = \"ambient\""),
        );
    }
}

/// The integrator a scene renders with: built, with its type name and the parameters it was
/// built from (the file's, with the command line's over them).
struct BuiltIntegrator {
    integrator: Box<dyn crate::render::integrator::Integrator>,
    name: String,
    params: Table,
}

/// `[integrator]`, with the command line's type, depth and `--set` parameters over the file's.
fn integrator_section(registry: &Registry, node: Option<&Node>, desc: &SceneDescription, ctx: &LoadContext) -> Result<BuiltIntegrator> {
    let (ov, limits) = (&ctx.options.overrides, &ctx.options.limits);
    let empty = Table::default();
    let (file_table, integ_loc) = sub_table(node, &desc.loc, &empty, "integrator")?;
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
    // The depth, whatever the integrator calls it.
    let depth_param = plugin.info.params.iter().find(|s| matches!(s.role, Role::Depth(_))).map(|s| s.name);
    if let Some(d) = &ov.depth {
        match depth_param {
            Some(name) => integ_table.set(name, d.loc.clone(), d.clone()),
            None => {
                return Err(SceneError::at(&d.loc, format!("integrator \"{ty}\" has no recursion depth to set"))
                    .with_help("its parameters are listed by `raylab plugins`"));
            }
        }
    }
    for (k, v) in &ov.integrator_params {
        if !plugin.info.params.iter().any(|s| s.name == k) {
            let names: Vec<&str> = plugin.info.params.iter().map(|s| s.name).collect();
            // Point at the key: `--set KEY=VALUE` holds it before the value.
            let key_at = v.loc.source.text.find(k.as_str()).filter(|&i| i + k.len() <= v.loc.start);
            let loc = key_at.map_or_else(|| v.loc.clone(), |i| Loc::new(&v.loc.source, i..i + k.len()));
            let help = match did_you_mean(k, names.iter().copied()) {
                Some(m) => format!("did you mean `{m}`?  (parameters: {})", names.join(", ")),
                None => format!("its parameters: {}", names.join(", ")),
            };
            return Err(SceneError::at(&loc, format!("integrator \"{ty}\" has no parameter `{k}`")).with_help(help));
        }
        integ_table.set(k, v.loc.clone(), v.clone());
    }
    if let Some(name) = depth_param
        && let Some(n) = integ_table.get(name)
        && let Value::Int(d) = n.value
        && d > i64::from(limits.max_depth)
    {
        return Err(SceneError::at(&n.loc, format!("{name} {d} exceeds the limit of {}", limits.max_depth))
            .with_help("raise it with --max-depth-limit"));
    }
    let mut ip = Params::new(format!("integrator \"{ty}\""), plugin.info.params, &integ_table, integ_loc.clone());
    let integrator = (plugin.build)(&mut ip, ctx)?;
    ip.finish()?;
    Ok(BuiltIntegrator { integrator, name: ty, params: integ_table })
}

/// The `[camera]` table with `position` and `look_at` chosen to frame the bounded objects (see
/// [`crate::scene::camera::fit`]), the report form's keys dropped.
fn fitted_camera(mut table: Table, objects: &[Object], fit: &Loc, settings: &RenderSettings) -> Result<Table> {
    let bounds = objects
        .iter()
        .filter_map(|o| o.geometry().bounds())
        .filter(|b| !b.is_empty() && b.min.is_finite() && b.max.is_finite())
        .reduce(|a, b| a.union(b))
        .ok_or_else(|| SceneError::at(fit, "`fit` frames the scene's bounded objects, and it has none (planes and tubes are unbounded)"))?;
    let vec3 = |key: &str| match table.get(key).map(|n| &n.value) {
        Some(Value::Array(a)) if a.len() == 3 => {
            let c: Vec<f64> = a
                .iter()
                .filter_map(|n| {
                    if let Value::Float(f) = n.value {
                        Some(f)
                    } else if let Value::Int(i) = n.value {
                        Some(i as f64)
                    } else {
                        None
                    }
                })
                .collect();
            (c.len() == 3).then(|| glam::DVec3::new(c[0], c[1], c[2]))
        }
        _ => None,
    };
    let direction = match (vec3("position"), vec3("look_at")) {
        (Some(p), Some(t)) => p - t,
        _ => glam::DVec3::ZERO,
    };
    let fov = match table.get("fov").map(|n| &n.value) {
        Some(Value::Float(f)) => *f,
        Some(Value::Int(i)) => *i as f64,
        _ => 45.0,
    };
    let (eye, target) = crate::scene::camera::fit(&bounds, direction, fov, settings.width, settings.height);
    for key in ["to", "screen_distance", "screen_width", "screen_height", "fit"] {
        table.remove(key);
    }
    let at = |v: glam::DVec3| Node {
        value: Value::Array(v.to_array().into_iter().map(|c| Node { value: Value::Float(c), loc: fit.clone() }).collect()),
        loc: fit.clone(),
    };
    table.set("position", fit.clone(), at(eye));
    table.set("look_at", fit.clone(), at(target));
    Ok(table)
}

/// The image size: the file's, with the command line's width and height over it. One side given
/// alone keeps the file's aspect ratio (the other side is scaled and rounded, at least 1).
pub fn image_size(file: (i64, i64), given: (Option<u32>, Option<u32>)) -> (i64, i64) {
    let scaled = |side: u32, num: i64, den: i64| ((f64::from(side) * num as f64 / den as f64).round() as i64).max(1);
    match given {
        (Some(w), Some(h)) => (w.into(), h.into()),
        (Some(w), None) => (w.into(), scaled(w, file.1, file.0)),
        (None, Some(h)) => (scaled(h, file.0, file.1), h.into()),
        (None, None) => file,
    }
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

/// The keys every `[[object]]` takes besides its type's parameters.
pub const OBJECT_PARAMS: &[ParamSpec] = &[
    ParamSpec::new("type", ParamKind::Str, ParamDefault::Required, "the geometry type (see Geometries below)"),
    ParamSpec::new("name", ParamKind::Str, ParamDefault::Optional, "a name for messages and `raylab trace` (default: the type and index)"),
    ParamSpec::new(
        "transform",
        ParamKind::Any,
        ParamDefault::Optional,
        "placement: { scale, rotate, translate }, a list of them, or { matrix = 4×4 } (README, \"Placing objects\")",
    ),
    ParamSpec::new(
        "material",
        ParamKind::Material,
        ParamDefault::Str("default"),
        "name of a material in [materials], or an inline table such as { kd = [0.8, 0.2, 0.2] }; replaces the materials a mesh file defines",
    ),
    ParamSpec::new(
        "emission_sides",
        ParamKind::Str,
        ParamDefault::Str("both"),
        "which sides give off the material's emission: \"both\" (raylab's convention), \"front\" (the outward side: out of a solid, a triangle's winding side; Mitsuba's) or \"back\"",
    ),
];

/// The keys of an `[[object]]` table that are not its plugin's parameters.
const OBJECT_KEYS: &[&str] = &["type", "name", "transform", "material", "emission_sides"];

/// The keys of a `[[light]]` table that are not its plugin's parameters.
const LIGHT_KEYS: &[&str] = &["type", "name"];

/// Reads `type` and `name` of a plugin table (without copying it); returns (type, "\"name\" "
/// or "", the table).
fn plugin_header<'a>(
    registry: &Registry,
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
            Value::Str(s) if registry.absent_feature(s).is_some() => {
                let feature = registry.absent_feature(s).unwrap_or_default();
                return Err(SceneError::at(&n.loc, format!("{what} type \"{s}\" needs the `{feature}` feature"))
                    .with_help(crate::param::error::built_without(feature)));
            }
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
