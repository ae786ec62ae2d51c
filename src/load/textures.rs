//! A scene's textures while it loads: the `[textures.NAME]` tables, each built (and its files
//! read) only when a material first names it, and inline texture tables.
//!
//! ```toml
//! [textures.tiles]
//! type = "checker"
//! even = [0.9, 0.9, 0.85]
//! odd = [0.1, 0.1, 0.12]
//! transform = { scale = 0.5 }
//!
//! [materials.floor]
//! kd = "tiles"                                            # a named texture
//! ks = { type = "image", file = "assets/gloss.png" }      # an inline one
//! ```

use crate::load::context::LoadContext;
use crate::load::registry::Registry;
use crate::param::error::{Loc, Result, SceneError, did_you_mean};
use crate::param::params::Params;
use crate::param::value::{Node, Table, Value};
use crate::scene::material::{Material, MaterialTypes};
use crate::scene::texture::{Texture, TextureResolver};
use std::cell::RefCell;
use std::sync::Arc;

/// The keys of a texture table that are not its plugin's parameters.
const TEXTURE_KEYS: &[&str] = &["type"];

/// The keys of a material table that are not its plugin's parameters.
const MATERIAL_KEYS: &[&str] = &["type"];

/// One `[textures.NAME]` table and, once a material has named it, the texture.
struct Named<'a> {
    name: String,
    node: &'a Node,
    built: Option<Arc<dyn Texture>>,
}

/// The textures a scene defines, built on first use through the registry's texture plugins.
pub struct TextureLibrary<'a> {
    registry: &'a Registry,
    ctx: &'a LoadContext<'a>,
    named: RefCell<Vec<Named<'a>>>,
}

impl<'a> TextureLibrary<'a> {
    /// A library with no named textures; inline tables are built with `registry`'s plugins.
    pub fn new(registry: &'a Registry, ctx: &'a LoadContext<'a>) -> Self {
        TextureLibrary { registry, ctx, named: RefCell::new(Vec::new()) }
    }

    /// Records the scene's `textures` value: a table of `[textures.NAME]` tables. Nothing is
    /// built yet.
    pub fn define(&self, node: &'a Node) -> Result<()> {
        let Value::Table(t) = &node.value else {
            return Err(SceneError::at(&node.loc, "`textures` must be a table of [textures.NAME] tables"));
        };
        let mut named = self.named.borrow_mut();
        for e in &t.entries {
            if !matches!(e.value.value, Value::Table(_)) {
                return Err(SceneError::at(
                    &e.value.loc,
                    format!("texture \"{}\" must be a table with a `type`, found {}", e.key, e.value.value.type_name()),
                ));
            }
            named.push(Named { name: e.key.clone(), node: &e.value, built: None });
        }
        Ok(())
    }

    /// The texture a material colour names: the name of a `[textures.NAME]` table (built on its
    /// first use, then shared), or an inline table with a `type`. `what` names the colour in
    /// messages.
    pub fn resolve(&self, node: &Node, what: &str) -> Result<Arc<dyn Texture>> {
        match &node.value {
            Value::Str(s) => {
                let found = self.named.borrow().iter().position(|n| n.name == *s);
                let Some(i) = found else {
                    let named = self.named.borrow();
                    let names: Vec<&str> = named.iter().map(|n| n.name.as_str()).collect();
                    let e = SceneError::at(&node.loc, format!("no texture named \"{s}\" in [textures]")).context(what);
                    return Err(e.with_help(match did_you_mean(s, names.iter().copied()) {
                        Some(m) => format!("did you mean \"{m}\"?"),
                        None if names.is_empty() => {
                            "no textures are defined; add a [textures.NAME] table, or give a colour [r, g, b]".into()
                        }
                        None => format!("defined textures: {}", names.join(", ")),
                    }));
                };
                if let Some(t) = &self.named.borrow()[i].built {
                    return Ok(t.clone());
                }
                let (name, table_node) = {
                    let n = &self.named.borrow()[i];
                    (n.name.clone(), n.node)
                };
                let t = self.build(table_node, &format!("texture \"{name}\""))?;
                self.named.borrow_mut()[i].built = Some(t.clone());
                Ok(t)
            }
            Value::Table(_) => self.build(node, &format!("{what}: inline texture")),
            v => Err(SceneError::at(
                &node.loc,
                format!("expected a colour [r, g, b], a number, a texture name or an inline texture table, found {}", v.type_name()),
            )
            .context(what)),
        }
    }

    /// Names of the `[textures.NAME]` tables no material has used (they were not built).
    pub fn unused(&self) -> Vec<(String, Loc)> {
        self.named.borrow().iter().filter(|n| n.built.is_none()).map(|n| (n.name.clone(), n.node.loc.clone())).collect()
    }

    /// Builds the texture table `node` (its `type` and parameters).
    fn build(&self, node: &Node, what: &str) -> Result<Arc<dyn Texture>> {
        let Value::Table(t) = &node.value else { unreachable!("callers pass tables") };
        let ty = texture_type(t, &node.loc, what, self.registry)?;
        let plugin = self.registry.texture(&ty).expect("checked by texture_type");
        let what = format!("{what} ({ty})");
        let mut p = Params::new(&what, plugin.info.params, t, node.loc.clone()).reserving(TEXTURE_KEYS);
        let texture = (plugin.build)(&mut p, self.ctx)?;
        p.finish()?;
        Ok(texture)
    }
}

impl TextureResolver for TextureLibrary<'_> {
    fn resolve(&self, node: &Node, what: &str) -> Result<Arc<dyn Texture>> {
        TextureLibrary::resolve(self, node, what)
    }
}

/// Material tables with a `type` are built by the registry's material plugins, their colours'
/// textures resolved by this library.
impl MaterialTypes for TextureLibrary<'_> {
    fn build_material(&self, ty: &Node, t: &Table, loc: &Loc, what: &str) -> Result<Material> {
        let Value::Str(name) = &ty.value else {
            let e = SceneError::at(&ty.loc, format!("`type` must be a material type name, found {}", ty.value.type_name()));
            return Err(e.context(what));
        };
        let Some(plugin) = self.registry.material(name) else {
            let names: Vec<&str> = self.registry.materials().map(|p| p.name).collect();
            let e = SceneError::at(&ty.loc, format!("unknown material type \"{name}\"")).context(what);
            return Err(e.with_help(match did_you_mean(name, names.iter().copied()) {
                Some(m) => format!("did you mean \"{m}\"?"),
                None => format!("material types: {}", names.join(", ")),
            }));
        };
        let what = format!("{what} ({name})");
        let mut p = Params::new(&what, plugin.info.params, t, loc.clone()).reserving(MATERIAL_KEYS);
        let m = (plugin.build)(&mut p, self)?;
        p.finish()?;
        Ok(m)
    }
}

/// The registered texture type a table names in its `type`.
fn texture_type(t: &Table, loc: &Loc, what: &str, registry: &Registry) -> Result<String> {
    let names = || registry.textures().map(|p| p.name).collect::<Vec<_>>().join(", ");
    let Some(n) = t.get("type") else {
        return Err(SceneError::at(loc, format!("{what} has no `type`")).with_help(format!("texture types: {}", names())));
    };
    match &n.value {
        Value::Str(s) if registry.texture(s).is_some() => Ok(s.clone()),
        Value::Str(s) => {
            let known: Vec<&str> = registry.textures().map(|p| p.name).collect();
            let help = match did_you_mean(s, known.iter().copied()) {
                Some(m) => format!("did you mean \"{m}\"? (texture types: {})", names()),
                None => format!("texture types: {}", names()),
            };
            Err(SceneError::at(&n.loc, format!("unknown texture type \"{s}\"")).context(what).with_help(help))
        }
        v => Err(SceneError::at(&n.loc, format!("`type` must be a string, found {}", v.type_name())).context(what)),
    }
}
