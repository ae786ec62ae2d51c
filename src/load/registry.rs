//! The plugin registry: geometries, textures, materials, lights, integrators by type name, and
//! the file formats of scenes, meshes and output images by extension.
//!
//! Built-in plugins register themselves through exactly this API; a crate outside raylab adds a
//! geometry the same way (see docs/writing-a-plugin.md).

use crate::geometry::Geometry;
use crate::geometry::samples::ShapeSampler;
use crate::image::output::{OutputFormat, builtin_formats};
use crate::image::write::WriteError;
use crate::load::context::{LoadContext, MeshFormat};
use crate::param::description::SceneDescription;
use crate::param::error::Result;
use crate::param::params::Params;
use crate::param::spec::ParamSpec;
use crate::render::integrator::Integrator;
use crate::scene::light::LightSource;
use crate::scene::material::Material;
use crate::scene::texture::{Texture, TextureResolver};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

/// What a plugin is and which parameters it takes: written once, in the plugin.
#[derive(Clone, Copy, Debug)]
pub struct PluginInfo {
    /// The type name scene files use (`type = "sphere"`).
    pub name: &'static str,
    /// One or two sentences: what it is, its conventions and units.
    pub summary: &'static str,
    /// Its parameter table.
    pub params: &'static [ParamSpec],
}

/// A geometry as its builder made it: the shape, and the materials its own source defines (an
/// OBJ's MTL library, a glTF file's materials), indexed by
/// [`Surface::material`](crate::geometry::Surface::material); `None` for shapes that take the
/// object's material. An object's `material` in the scene replaces them.
pub struct BuiltGeometry {
    /// The shape.
    pub geometry: Box<dyn Geometry>,
    /// The materials its file defines, if any.
    pub materials: Option<Arc<[Material]>>,
}

/// Builds a geometry from its parameters.
pub type GeometryBuilder = Arc<dyn Fn(&mut Params, &LoadContext) -> Result<BuiltGeometry> + Send + Sync>;
/// Builds a texture from its parameters.
pub type TextureBuilder = Arc<dyn Fn(&mut Params, &LoadContext) -> Result<Arc<dyn Texture>> + Send + Sync>;
/// Builds a material from its parameters (colours may name textures, which `TextureResolver`
/// finds).
pub type MaterialBuilder = Arc<dyn Fn(&mut Params, &dyn TextureResolver) -> Result<Material> + Send + Sync>;
/// Builds a light from its parameters.
pub type LightBuilder = Arc<dyn Fn(&mut Params, &LoadContext) -> Result<Box<dyn LightSource>> + Send + Sync>;
/// Builds an integrator from its parameters.
pub type IntegratorBuilder = Arc<dyn Fn(&mut Params, &LoadContext) -> Result<Box<dyn Integrator>> + Send + Sync>;
/// Reads a scene file of some format into raylab's scene description.
pub type SceneReader = Arc<dyn Fn(&Path, &[u8], &LoadContext) -> Result<SceneDescription> + Send + Sync>;

/// A registered plugin: its description and its constructor.
#[derive(Clone)]
pub struct Plugin<B> {
    /// Name, summary and parameter table.
    pub info: PluginInfo,
    /// The constructor.
    pub build: B,
}

/// A scene-file format other than raylab's own TOML, chosen by file extension.
#[derive(Clone)]
pub struct SceneFormat {
    /// Lower-case extensions without the dot (`["xml"]`).
    pub extensions: &'static [&'static str],
    /// One line: what the format is.
    pub summary: &'static str,
    /// The reader.
    pub read: SceneReader,
}

/// All known plugins, by type name, and file formats.
#[derive(Clone)]
pub struct Registry {
    geometries: BTreeMap<&'static str, Plugin<GeometryBuilder>>,
    /// The geometries' sample generators, in registration order, with their geometry's type name.
    samplers: Vec<(&'static str, ShapeSampler)>,
    textures: BTreeMap<&'static str, Plugin<TextureBuilder>>,
    materials: BTreeMap<&'static str, Plugin<MaterialBuilder>>,
    lights: BTreeMap<&'static str, Plugin<LightBuilder>>,
    integrators: BTreeMap<&'static str, Plugin<IntegratorBuilder>>,
    formats: Vec<SceneFormat>,
    mesh_formats: Vec<MeshFormat>,
    output_formats: Vec<OutputFormat>,
    default_integrator: Option<&'static str>,
    absent: Vec<Absent>,
}

/// A plugin type or file extension a cargo feature of the binary would add, declared by a
/// plugin crate built without that feature, so that asking for it names the feature
/// ([`Registry::add_absent`], [`crate::param::error::built_without`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Absent {
    /// What would be there: a type name (`mesh`) or a file extension (`obj`, no dot).
    pub name: &'static str,
    /// The cargo feature that adds it.
    pub feature: &'static str,
}

impl Default for Registry {
    fn default() -> Self {
        Registry {
            geometries: BTreeMap::new(),
            samplers: Vec::new(),
            textures: BTreeMap::new(),
            materials: BTreeMap::new(),
            lights: BTreeMap::new(),
            integrators: BTreeMap::new(),
            formats: Vec::new(),
            mesh_formats: Vec::new(),
            output_formats: builtin_formats(),
            default_integrator: None,
            absent: Vec::new(),
        }
    }
}

impl Registry {
    /// A registry with no plugins, writing the core's own image formats (PNG, JPEG, PFM, and
    /// OpenEXR with the `exr` feature).
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers a geometry type; replaces any earlier one of the same name.
    pub fn add_geometry(
        &mut self,
        info: PluginInfo,
        build: impl Fn(&mut Params, &LoadContext) -> Result<Box<dyn Geometry>> + Send + Sync + 'static,
    ) {
        self.add_geometry_with_materials(info, move |p, ctx| Ok(BuiltGeometry { geometry: build(p, ctx)?, materials: None }));
    }

    /// Registers a geometry type with its sample generators: one [`ShapeSampler`] per variant,
    /// each drawing a random valid instance with its exact surface. raylab's property tests,
    /// reintersection campaign and `intersect` fuzz target check every registered sampler
    /// ([`crate::geometry::samples`]), so the shape is tested from this one line.
    pub fn add_geometry_with_samples(
        &mut self,
        info: PluginInfo,
        build: impl Fn(&mut Params, &LoadContext) -> Result<Box<dyn Geometry>> + Send + Sync + 'static,
        samplers: &[ShapeSampler],
    ) {
        self.add_geometry(info, build);
        self.samplers.extend(samplers.iter().map(|s| (info.name, *s)));
    }

    /// Registers a geometry type whose source may define its own materials (a mesh file's);
    /// replaces any earlier one of the same name (and its samplers).
    pub fn add_geometry_with_materials(
        &mut self,
        info: PluginInfo,
        build: impl Fn(&mut Params, &LoadContext) -> Result<BuiltGeometry> + Send + Sync + 'static,
    ) {
        self.samplers.retain(|(name, _)| *name != info.name);
        self.geometries.insert(info.name, Plugin { info, build: Arc::new(build) });
    }

    /// Registers a texture type; replaces any earlier one of the same name.
    pub fn add_texture(
        &mut self,
        info: PluginInfo,
        build: impl Fn(&mut Params, &LoadContext) -> Result<Arc<dyn Texture>> + Send + Sync + 'static,
    ) {
        self.textures.insert(info.name, Plugin { info, build: Arc::new(build) });
    }

    /// Registers a material type (`[materials.NAME] type = "…"`); replaces any earlier one of the
    /// same name. A material table without a `type` is the report's coefficients (`phong`).
    pub fn add_material(
        &mut self,
        info: PluginInfo,
        build: impl Fn(&mut Params, &dyn TextureResolver) -> Result<Material> + Send + Sync + 'static,
    ) {
        self.materials.insert(info.name, Plugin { info, build: Arc::new(build) });
    }

    /// Registers a light type; replaces any earlier one of the same name.
    pub fn add_light(
        &mut self,
        info: PluginInfo,
        build: impl Fn(&mut Params, &LoadContext) -> Result<Box<dyn LightSource>> + Send + Sync + 'static,
    ) {
        self.lights.insert(info.name, Plugin { info, build: Arc::new(build) });
    }

    /// Registers an integrator; replaces any earlier one of the same name. The first one registered
    /// is the default for scenes that name none.
    pub fn add_integrator(
        &mut self,
        info: PluginInfo,
        build: impl Fn(&mut Params, &LoadContext) -> Result<Box<dyn Integrator>> + Send + Sync + 'static,
    ) {
        self.default_integrator.get_or_insert(info.name);
        self.integrators.insert(info.name, Plugin { info, build: Arc::new(build) });
    }

    /// Makes `name` the integrator used when a scene names none.
    pub fn set_default_integrator(&mut self, name: &'static str) {
        self.default_integrator = Some(name);
    }

    /// Registers a scene-file format.
    pub fn add_format(&mut self, format: SceneFormat) {
        self.formats.push(format);
    }

    /// Registers a mesh-file format; its extensions take precedence over any earlier format's.
    pub fn add_mesh_format(&mut self, format: MeshFormat) {
        self.mesh_formats.push(format);
    }

    /// Registers an output image format; its extensions take precedence over any earlier
    /// format's (a plugin may replace a built-in writer).
    pub fn add_output_format(&mut self, format: OutputFormat) {
        self.output_formats.push(format);
    }

    /// Declares `absent.name` (a type or a file extension) as what the cargo feature
    /// `absent.feature` would add: a plugin crate built without that feature calls this, and a
    /// scene or command asking for it is told which feature to build with.
    pub fn add_absent(&mut self, absent: Absent) {
        self.absent.push(absent);
    }

    /// The feature that would add the type or extension `name`, when one was declared absent.
    pub fn absent_feature(&self, name: &str) -> Option<&'static str> {
        self.absent.iter().find(|a| a.name.eq_ignore_ascii_case(name)).map(|a| a.feature)
    }

    /// The geometry type `name`.
    pub fn geometry(&self, name: &str) -> Option<&Plugin<GeometryBuilder>> {
        self.geometries.get(name)
    }

    /// The texture type `name`.
    pub fn texture(&self, name: &str) -> Option<&Plugin<TextureBuilder>> {
        self.textures.get(name)
    }

    /// The material type `name`.
    pub fn material(&self, name: &str) -> Option<&Plugin<MaterialBuilder>> {
        self.materials.get(name)
    }

    /// The light type `name`.
    pub fn light(&self, name: &str) -> Option<&Plugin<LightBuilder>> {
        self.lights.get(name)
    }

    /// The integrator `name`.
    pub fn integrator(&self, name: &str) -> Option<&Plugin<IntegratorBuilder>> {
        self.integrators.get(name)
    }

    /// The default integrator's name.
    pub fn default_integrator(&self) -> Option<&'static str> {
        self.default_integrator
    }

    /// The format that reads files with extension `ext` (lower case, no dot).
    pub fn format_for(&self, ext: &str) -> Option<&SceneFormat> {
        self.formats.iter().find(|f| f.extensions.contains(&ext))
    }

    /// Registered geometry types, sorted by name.
    pub fn geometries(&self) -> impl Iterator<Item = &PluginInfo> {
        self.geometries.values().map(|p| &p.info)
    }

    /// The sample generators of the registered geometries ([`Registry::add_geometry_with_samples`]),
    /// in registration order: what the shape harnesses of [`crate::geometry::samples`] check.
    pub fn shape_samplers(&self) -> Vec<ShapeSampler> {
        self.samplers.iter().map(|(_, s)| *s).collect()
    }

    /// The names of the samplers registered with geometry type `name`.
    pub fn samplers_of(&self, name: &str) -> Vec<&'static str> {
        self.samplers.iter().filter(|(n, _)| *n == name).map(|(_, s)| s.name).collect()
    }

    /// The registered geometry types that offer no sample generator (so are checked by no
    /// shape harness), sorted by name.
    pub fn unsampled_geometries(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.geometries.keys().copied().filter(|name| !self.samplers.iter().any(|(n, _)| n == name))
    }

    /// Registered texture types, sorted by name.
    pub fn textures(&self) -> impl Iterator<Item = &PluginInfo> {
        self.textures.values().map(|p| &p.info)
    }

    /// Registered material types, sorted by name.
    pub fn materials(&self) -> impl Iterator<Item = &PluginInfo> {
        self.materials.values().map(|p| &p.info)
    }

    /// Registered light types, sorted by name.
    pub fn lights(&self) -> impl Iterator<Item = &PluginInfo> {
        self.lights.values().map(|p| &p.info)
    }

    /// Registered integrators, sorted by name.
    pub fn integrators(&self) -> impl Iterator<Item = &PluginInfo> {
        self.integrators.values().map(|p| &p.info)
    }

    /// Registered scene formats.
    pub fn formats(&self) -> &[SceneFormat] {
        &self.formats
    }

    /// The options of a sweep's reference render (`raylab sweep --reference auto`): `o` (the base
    /// options, loading `scene_integrator`) changed to render `integrator` with stratified sampling
    /// at `reference_spp` samples per pixel (at least the largest `spp` swept), one lens sample, and
    /// every depth and quality knob of the integrator at its reference value (by role, whatever the
    /// parameter is called), at least as accurate as any value swept. `swept(name)` gives the
    /// values a knob is swept over.
    pub fn reference_options(
        &self,
        o: &mut crate::load::context::LoadOptions,
        scene_integrator: &str,
        integrator: &str,
        swept: &dyn Fn(&str) -> Option<Vec<crate::param::value::Value>>,
        reference_spp: u32,
    ) {
        use crate::param::spec::{Reference, Role};
        let ov = &mut o.overrides;
        if integrator != scene_integrator {
            // The swept integrator's parameters and depth mean nothing to another one.
            ov.integrator = Some(integrator.to_string());
            ov.integrator_params.clear();
            ov.depth = None;
        }
        let max_spp = swept("spp")
            .unwrap_or_default()
            .iter()
            .filter_map(|v| if let crate::param::value::Value::Int(i) = v { Some(*i) } else { None })
            .max()
            .unwrap_or(1);
        ov.spp = Some(u32::try_from(max_spp).unwrap_or(u32::MAX).max(reference_spp));
        ov.render_params.retain(|(k, _)| !k.starts_with("aa") && !k.starts_with("target"));
        ov.render_params.push((
            "aa".to_string(),
            crate::param::value::Node::given("--reference", crate::param::value::Value::Str("stratified".into())),
        ));
        ov.render_params
            .push(("lens_samples".to_string(), crate::param::value::Node::given("--reference", crate::param::value::Value::Int(1))));
        // Every depth and quality knob of the integrator at its reference value (by role, whatever
        // the parameter is called), and at least as accurate as any value swept.
        let params = self.integrator(integrator).map(|p| p.info.params).unwrap_or(&[]);
        for spec in params {
            let Some(reference) = spec.role.reference() else { continue };
            let is_depth = matches!(spec.role, Role::Depth(_));
            let numbers: Vec<f64> = swept(if is_depth { "depth" } else { spec.name })
                .unwrap_or_default()
                .iter()
                .filter_map(|v| match v {
                    crate::param::value::Value::Float(f) => Some(*f),
                    crate::param::value::Value::Int(i) => Some(*i as f64),
                    _ => None,
                })
                .collect();
            let value = match reference {
                Reference::Keep => continue,
                Reference::AtLeast(r) => numbers.iter().copied().fold(r, f64::max),
                Reference::AtMost(r) => numbers.iter().copied().fold(r, f64::min),
                Reference::Exactly(d) => match d {
                    crate::param::spec::ParamDefault::Int(i) => i as f64,
                    crate::param::spec::ParamDefault::Float(f) => f,
                    crate::param::spec::ParamDefault::Bool(b) => {
                        ov.integrator_params.push((
                            spec.name.to_string(),
                            crate::param::value::Node::given("--reference", crate::param::value::Value::Bool(b)),
                        ));
                        continue;
                    }
                    _ => continue,
                },
            };
            let value = if spec.kind == crate::param::spec::ParamKind::Int {
                crate::param::value::Value::Int(value.round() as i64)
            } else {
                crate::param::value::Value::Float(value)
            };
            if is_depth {
                ov.depth = Some(crate::param::value::Node::given("--reference", value));
            } else {
                ov.integrator_params.push((spec.name.to_string(), crate::param::value::Node::given("--reference", value)));
            }
        }
    }

    /// Every registered type with its parameter table, as JSON (`raylab plugins --json`, and
    /// `raylab.plugins()` in Python): `{"geometries": [{"name", "summary", "params": [{"name",
    /// "type", "default", "required", "doc", "role"}]}], "textures", "lights", "integrators",
    /// "formats": [{"extensions", "summary"}]}`. A default is `null` when there is none.
    pub fn to_json(&self) -> serde_json::Value {
        use crate::param::spec::{ParamDefault, Role};
        let param = |s: &ParamSpec| {
            let default = match s.default {
                ParamDefault::Required | ParamDefault::Optional => serde_json::Value::Null,
                ParamDefault::Float(v) => v.into(),
                ParamDefault::Int(v) => v.into(),
                ParamDefault::Bool(v) => v.into(),
                ParamDefault::Str(v) => v.into(),
                ParamDefault::Vec3(v) => v.to_vec().into(),
            };
            let role = match s.role {
                Role::Setting => "setting",
                Role::Depth(_) => "depth",
                Role::Quality(_) => "quality",
            };
            serde_json::json!({
                "name": s.name,
                "type": s.kind.name(),
                "default": default,
                "required": s.default == ParamDefault::Required,
                "doc": s.doc,
                "role": role,
            })
        };
        let plugins = |items: &mut dyn Iterator<Item = &PluginInfo>| -> serde_json::Value {
            items
                .map(|p| serde_json::json!({ "name": p.name, "summary": p.summary, "params": p.params.iter().map(param).collect::<Vec<_>>() }))
                .collect()
        };
        serde_json::json!({
            "geometries": plugins(&mut self.geometries()),
            "textures": plugins(&mut self.textures()),
            "lights": plugins(&mut self.lights()),
            "integrators": plugins(&mut self.integrators()),
            "formats": self.formats.iter().map(|f| serde_json::json!({ "extensions": f.extensions, "summary": f.summary })).collect::<Vec<_>>(),
        })
    }

    /// Registered mesh formats, in registration order.
    pub fn mesh_formats(&self) -> &[MeshFormat] {
        &self.mesh_formats
    }

    /// Registered output image formats, in registration order (the core's own first).
    pub fn output_formats(&self) -> &[OutputFormat] {
        &self.output_formats
    }

    /// The output format for `path`'s extension (case-insensitive).
    pub fn output_format_for(&self, path: &Path) -> std::result::Result<&OutputFormat, WriteError> {
        crate::image::output::format_among(&self.output_formats, path)
    }
}
