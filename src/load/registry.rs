//! The plugin registry: geometries, textures, lights, integrators and scene formats, by type name.
//!
//! Built-in plugins register themselves through exactly this API; a crate outside raylab adds a
//! geometry the same way (see docs/writing-a-plugin.md).

use crate::geometry::Geometry;
use crate::load::context::LoadContext;
use crate::param::description::SceneDescription;
use crate::param::error::Result;
use crate::param::params::Params;
use crate::param::spec::ParamSpec;
use crate::render::integrator::Integrator;
use crate::scene::light::LightSource;
use crate::scene::material::Material;
use crate::scene::texture::Texture;
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

/// All known plugins, by type name.
#[derive(Clone, Default)]
pub struct Registry {
    geometries: BTreeMap<&'static str, Plugin<GeometryBuilder>>,
    textures: BTreeMap<&'static str, Plugin<TextureBuilder>>,
    lights: BTreeMap<&'static str, Plugin<LightBuilder>>,
    integrators: BTreeMap<&'static str, Plugin<IntegratorBuilder>>,
    formats: Vec<SceneFormat>,
    default_integrator: Option<&'static str>,
}

impl Registry {
    /// An empty registry.
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

    /// Registers a geometry type whose source may define its own materials (a mesh file's);
    /// replaces any earlier one of the same name.
    pub fn add_geometry_with_materials(
        &mut self,
        info: PluginInfo,
        build: impl Fn(&mut Params, &LoadContext) -> Result<BuiltGeometry> + Send + Sync + 'static,
    ) {
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

    /// The geometry type `name`.
    pub fn geometry(&self, name: &str) -> Option<&Plugin<GeometryBuilder>> {
        self.geometries.get(name)
    }

    /// The texture type `name`.
    pub fn texture(&self, name: &str) -> Option<&Plugin<TextureBuilder>> {
        self.textures.get(name)
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

    /// Registered texture types, sorted by name.
    pub fn textures(&self) -> impl Iterator<Item = &PluginInfo> {
        self.textures.values().map(|p| &p.info)
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
}
