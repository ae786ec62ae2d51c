//! `mesh`: a triangle mesh read from an OBJ (+ MTL) or glTF 2.0 file; and glTF files as whole
//! scenes (`raylab render model.glb`).
//!
//! A mesh file placed several times (several objects naming the same file and selection, each
//! with its own `transform`) is read, triangulated and indexed once and shared. Without a
//! `material`, the file's materials are used (MTL and glTF mappings: [`obj`], [`gltf`]).

pub mod gltf;
pub mod obj;
pub mod triangle_mesh;
pub mod triangulate;

use raylab::geometry::transform::{Transform, Transformed};
use raylab::geometry::{Geometry, Hit, Intersectable, PACKET, Surface, SurfaceDerivatives, SurfacePdf, SurfaceSample, face_forward};
use raylab::glam::{DMat2, DVec2, DVec3};
use raylab::load::context::MeshFormat;
use raylab::load::mesh::{MeshFile, MeshRequest};
use raylab::load::registry::{BuiltGeometry, SceneFormat};
use raylab::param::error::{Loc, Result, SceneError};
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::param::value::Value;
use raylab::{Aabb, LoadContext, PluginInfo, Ray, Registry};
use std::sync::Arc;
use triangle_mesh::{Normals, TriangleMesh};

/// The `mesh` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "mesh",
    summary: "A triangle mesh from a file in a registered mesh format (built in: .obj with its .mtl, glTF 2.0 .gltf and .glb). Watertight: a ray through a shared edge or vertex hits exactly one of its triangles. Place it with `transform`; a file used several times is stored once.",
    params: &[
        ParamSpec::new("file", ParamKind::Path, ParamDefault::Required, "the mesh file, relative to the scene file"),
        ParamSpec::new(
            "mesh",
            ParamKind::Int,
            ParamDefault::Optional,
            "glTF only: the index of one mesh, in its own frame; default: every mesh of the file's scene, placed by its nodes",
        ),
        ParamSpec::new(
            "node",
            ParamKind::Int,
            ParamDefault::Optional,
            "glTF only: the index of one node of the file's scene: its mesh, placed by the node's world matrix (what a glTF rendered as a scene is made of)",
        ),
        ParamSpec::new(
            "normals",
            ParamKind::Str,
            ParamDefault::Str("auto"),
            "\"auto\" (the file's vertex normals if any, else flat), \"flat\", or \"smooth\" (the file's, else computed)",
        ),
    ],
};

/// Registers the `mesh` geometry, the OBJ and glTF mesh formats and the glTF scene format.
pub fn register(r: &mut Registry) {
    r.add_geometry_with_materials(INFO, build);
    r.add_mesh_format(MeshFormat {
        name: "obj",
        extensions: &["obj"],
        summary: "Wavefront OBJ, with its MTL material libraries (read in parallel)",
        read: Arc::new(read_obj),
    });
    r.add_mesh_format(MeshFormat {
        name: "gltf",
        extensions: &["gltf", "glb"],
        summary: "glTF 2.0 (text or binary): one mesh (`mesh`), one node (`node`) or every mesh of the file's scene, placed by its nodes",
        read: Arc::new(read_gltf),
    });
    r.add_format(SceneFormat {
        extensions: &["gltf", "glb"],
        summary: "glTF 2.0 as a whole scene: meshes placed by their nodes, PBR materials mapped to Phong, the first camera, KHR_lights_punctual lights",
        read: Arc::new(gltf::read_scene),
    });
    r.add_format(SceneFormat {
        extensions: &["obj"],
        summary: "an OBJ model (with its .mtl) as a whole scene: the mesh, a camera that frames it, a default sun and sky",
        read: Arc::new(obj_scene),
    });
}

/// What a model file rendered as a scene gets that the file does not say: its `[render]` table
/// (the showcase's anti-aliasing, so silhouettes are smooth) and, when the file has no lights,
/// a sun and a uniform sky, announced by a warning.
pub mod model_scene {
    use raylab::LoadContext;
    use raylab::glam::DVec3;
    use raylab::param::error::{Loc, SceneError};
    use raylab::param::value::{Entry, Node, Table, Value};

    /// Direction the default sun's light travels.
    pub const SUN_DIRECTION: DVec3 = DVec3::new(-0.4, -1.0, -0.6);
    /// The default sky's radiance: a uniform `environment` light (so occluded parts of a model
    /// are darker, and mirrors and glass reflect it), which the background shows too.
    pub const SKY_RADIANCE: f64 = 0.3;

    /// Builds located values (each at `loc`).
    pub struct At<'a>(pub &'a Loc);

    impl At<'_> {
        pub fn node(&self, value: Value) -> Node {
            Node { value, loc: self.0.clone() }
        }
        pub fn float(&self, v: f64) -> Node {
            self.node(Value::Float(v))
        }
        pub fn vec3(&self, v: DVec3) -> Node {
            self.node(Value::Array(v.to_array().into_iter().map(|c| self.float(c)).collect()))
        }
        pub fn str(&self, s: &str) -> Node {
            self.node(Value::Str(s.to_string()))
        }
        pub fn table(&self, entries: Vec<(&str, Node)>) -> Node {
            let entries = entries.into_iter().map(|(key, value)| Entry { key: key.to_string(), key_loc: self.0.clone(), value }).collect();
            self.node(Value::Table(Table { entries }))
        }
    }

    /// `[render]` of a model scene: `width × height`, adaptive anti-aliasing.
    pub fn render(at: &At, width: i64, height: i64) -> Node {
        at.table(vec![("width", at.node(Value::Int(width))), ("height", at.node(Value::Int(height))), ("aa", at.str("adaptive"))])
    }

    /// The default lights of a model without its own, and the one-line warning that says so.
    pub fn default_lights(at: &At, file: &str, ctx: &LoadContext) -> Vec<Node> {
        ctx.warn(SceneError::in_file(file, None, "the file has no lights: it is lit by a default sun and a uniform sky"));
        vec![
            at.table(vec![
                ("type", at.str("directional")),
                ("name", at.str("sun")),
                ("direction", at.vec3(SUN_DIRECTION)),
                ("color", at.float(1.0)),
            ]),
            at.table(vec![("type", at.str("environment")), ("name", at.str("sky")), ("color", at.float(SKY_RADIANCE))]),
        ]
    }
}

/// An OBJ file as a scene: the whole file as one `mesh` object (its MTL materials), a camera
/// fitted to it, the default sun and sky. An OBJ file holds no camera or light.
pub fn obj_scene(path: &std::path::Path, _bytes: &[u8], ctx: &LoadContext) -> Result<raylab::param::description::SceneDescription> {
    use model_scene::At;
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let src = raylab::Source::new(path.display().to_string(), String::new());
    let doc = Loc::new(&src, 0..0);
    let at = At(&doc);
    let camera = at.table(vec![("fit", at.node(Value::Bool(true))), ("fov", at.float(40.0))]);
    let object = at.table(vec![("type", at.str("mesh")), ("file", at.str(&file_name))]);
    let root = at.table(vec![
        ("background", at.vec3(raylab::glam::DVec3::splat(0.1))),
        ("render", model_scene::render(&at, 800, 600)),
        ("camera", camera),
        ("object", at.node(Value::Array(vec![object]))),
        ("light", at.node(Value::Array(model_scene::default_lights(&at, &path.display().to_string(), ctx)))),
    ]);
    let Value::Table(root) = root.value else { unreachable!("built as a table") };
    let name = path.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    Ok(raylab::param::description::SceneDescription { name, root, loc: doc })
}

/// Builds a mesh object from its parameters, with the materials its file defines.
pub fn build(p: &mut Params, ctx: &LoadContext) -> Result<BuiltGeometry> {
    let (file, loc) = match p.node("file")? {
        Some(n) => match &n.value {
            Value::Str(s) => (s.clone(), n.loc.clone()),
            other => return Err(p.error_at("file", format_args!("expected a path (a string), found {}", other.type_name()))),
        },
        None => return Err(p.error("missing required parameter `file` (path)")),
    };
    let mut selection = match p.node("mesh")? {
        Some(n) => match n.value {
            Value::Int(i) if i >= 0 => Some(i as usize),
            _ => return Err(p.error_at("mesh", "expected a mesh index (an integer ≥ 0)")),
        },
        None => None,
    };
    let node = match p.node("node")? {
        Some(n) => match n.value {
            Value::Int(i) if i >= 0 => Some(i as usize),
            _ => return Err(p.error_at("node", "expected a node index (an integer ≥ 0)")),
        },
        None => None,
    };
    // A node: its mesh (shared by every node that places it), and its world matrix.
    let placement = match node {
        Some(_) if selection.is_some() => return Err(p.error_at("node", "give `mesh` or `node`, not both")),
        Some(i) => {
            let ext = std::path::Path::new(&file).extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
            if !matches!(ext.as_str(), "gltf" | "glb") {
                return Err(p.error_at("node", "selects a node of a glTF file (.gltf, .glb)"));
            }
            let (mesh, world) = gltf::open(ctx, &file, &loc).and_then(|g| g.node_instance(i)).map_err(|e| e.context(p.what()))?;
            selection = Some(mesh);
            Some(Transform::new(world).ok_or_else(|| p.error_at("node", "the node's world matrix is singular"))?)
        }
        None => None,
    };
    let normals = match p.choice("normals", &["auto", "flat", "smooth"])?.as_str() {
        "flat" => Normals::Flat,
        "smooth" => Normals::Smooth,
        _ => Normals::Auto,
    };
    // An object's `material` replaces the file's (the loader attaches it): then the file's
    // material libraries are not read.
    let file_materials = !p.has("material");
    let mesh = load_mesh(ctx, &file, &loc, selection, normals, file_materials).map_err(|e| e.context(p.what()))?;
    let materials = mesh.materials().cloned();
    let object = MeshObject::new(mesh);
    let geometry: Box<dyn Geometry> = match placement {
        Some(t) => Box::new(Transformed::new(object, t)),
        None => Box::new(object),
    };
    Ok(BuiltGeometry { geometry, materials })
}

/// Estimated peak bytes per triangle of a mesh while it is indexed and once built: the decoded
/// data, the stored triangles, shading normals, material ids and the hierarchy with its build's
/// scratch space (charged to [`raylab::param::limits::Limits::max_memory`] before the index is built;
/// measured: about 360 for the 1.1 M-triangle bunny).
pub const MESH_BYTES_PER_TRIANGLE: u64 = 384;

/// Estimated extra peak bytes per triangle of a mesh with texture coordinates: the file's
/// coordinates and indices as read, and the stored ones (8 bytes per coordinate, 12 per
/// triangle each way, a coordinate or so per triangle).
pub const MESH_UV_BYTES_PER_TRIANGLE: u64 = 48;

/// The mesh in `file` (with `selection` and `normals`), read and indexed once per scene.
pub fn load_mesh(
    ctx: &LoadContext,
    file: &str,
    loc: &Loc,
    selection: Option<usize>,
    normals: Normals,
    with_materials: bool,
) -> Result<Arc<TriangleMesh>> {
    // The format is told by the name alone, before the file is looked for (but not before a
    // name that leaves the folder is refused).
    ctx.check_written_path(file, loc)?;
    let ext = std::path::Path::new(file).extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let Some(format) = ctx.mesh_format_for(&ext) else {
        let known: Vec<String> = ctx.mesh_formats().iter().flat_map(|f| f.extensions.iter().map(|e| format!(".{e}"))).collect();
        let expected = match known.split_last() {
            None => "none is registered".to_string(),
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        };
        return Err(SceneError::at(loc, format!("unknown mesh format \".{ext}\"; expected {expected}")));
    };
    let full = ctx.resolve_path(file, loc)?;
    let key = format!("mesh:{}:{selection:?}:{normals:?}:{with_materials}", full.display());
    ctx.assets.get_or_load(&key, || {
        let request = MeshRequest { file, loc, selection, materials: with_materials };
        let MeshFile { data, file_bytes } = (format.read)(&request, ctx)?;
        let name = full.display().to_string();
        let limit = ctx.options.limits.max_triangles;
        if data.triangles.len() as u64 > limit {
            return Err(SceneError::in_file(&name, None, format!("{} triangles, over the limit of {limit}", data.triangles.len()))
                .with_help("raise the limit with --max-triangles"));
        }
        let per_triangle = MESH_BYTES_PER_TRIANGLE + if data.texcoord_indices.is_empty() { 0 } else { MESH_UV_BYTES_PER_TRIANGLE };
        let estimate = (data.triangles.len() as u64).saturating_mul(per_triangle).saturating_add(file_bytes);
        ctx.charge(estimate, &format!("the mesh \"{name}\" ({} triangles)", data.triangles.len()), Some(loc))?;
        let mesh = TriangleMesh::new(data, normals, ctx.options.accel).map_err(|e| SceneError::in_file(&name, None, e.to_string()))?;
        ctx.assets.record_build(mesh.build_stats());
        Ok(mesh)
    })
}

/// The OBJ mesh format's reader: the whole file (no `mesh` selection).
fn read_obj(r: &MeshRequest, ctx: &LoadContext) -> Result<MeshFile> {
    if r.selection.is_some() {
        return Err(SceneError::at(r.loc, "`mesh` selects a mesh of a glTF file; an OBJ file is read whole"));
    }
    // The file's bytes are freed once read: the index is built without them.
    let (full, bytes) = ctx.read_file(r.file, r.loc)?;
    Ok(MeshFile { data: obj::read(ctx, r.file, &full, &bytes, r.materials, r.loc)?, file_bytes: bytes.len() as u64 })
}

/// The glTF mesh format's reader: one mesh of the file, or every mesh of its scene.
fn read_gltf(r: &MeshRequest, ctx: &LoadContext) -> Result<MeshFile> {
    let g = gltf::open(ctx, r.file, r.loc)?;
    let data = match r.selection {
        Some(i) => g.mesh(ctx, i)?,
        None => g.whole(ctx)?,
    };
    Ok(MeshFile { data, file_bytes: 0 })
}

/// Reads mesh-file `bytes` of format `ext` (`obj`, `gltf`, `glb`) into an indexed mesh, without
/// touching the file system for the file itself (what the fuzz targets exercise): a mesh or a
/// located error, never a panic. The whole glTF scene is read; MTL libraries are not.
pub fn mesh_from_bytes(ctx: &LoadContext, name: &str, ext: &str, bytes: &[u8]) -> Result<TriangleMesh> {
    let src = raylab::Source::new(name, String::new());
    let loc = Loc::new(&src, 0..0);
    let data = match ext {
        "obj" => obj::read(ctx, name, std::path::Path::new(name), bytes, false, &loc)?,
        _ => gltf::parse(ctx, name, std::path::Path::new(name), bytes.to_vec(), &loc)?.whole(ctx)?,
    };
    TriangleMesh::new(data, Normals::Smooth, ctx.options.accel).map_err(|e| SceneError::in_file(name, None, e.to_string()))
}

/// A mesh as a scene object's shape (the triangle store is shared by every object placing it).
#[derive(Debug)]
pub struct MeshObject {
    mesh: Arc<TriangleMesh>,
}

impl MeshObject {
    /// The mesh as a shape.
    pub fn new(mesh: Arc<TriangleMesh>) -> Self {
        MeshObject { mesh }
    }

    /// The shared triangle store.
    pub fn mesh(&self) -> &Arc<TriangleMesh> {
        &self.mesh
    }
}

impl Intersectable for MeshObject {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        self.mesh.intersect(ray, t_min, t_max)
    }
    #[inline]
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.mesh.occludes(ray, t_min, t_max)
    }
    /// Triangles are flat: the one the ray leaves is not tested.
    #[inline]
    fn occludes_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> bool {
        self.mesh.occludes_leaving(ray, t_min, t_max, prim)
    }
    #[inline]
    fn intersect_packet(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        self.mesh.intersect_packet(rays, live, t_min, t_max, out)
    }
    /// Packets walk a hierarchy together; a list of triangles gains nothing from them.
    fn walks_packets(&self) -> bool {
        self.mesh.is_bvh()
    }
    /// Shadow rays of a block walk the hierarchy together, each leaving out its own triangle.
    #[inline]
    fn occludes_packet(
        &self,
        rays: &[Ray; PACKET],
        live: u32,
        t_min: f64,
        t_max: &[f64; PACKET],
        leaving: u32,
        prims: &[u32; PACKET],
    ) -> u32 {
        self.mesh.occludes_packet(rays, live, t_min, t_max, leaving, prims)
    }
}

impl Geometry for MeshObject {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        self.mesh.geometric_normal(at.prim)
    }
    /// The interpolated vertex normal as shading normal (on the side the ray came from), and
    /// the triangle's material slot.
    #[inline]
    fn surface(&self, at: &Hit, dir: DVec3) -> Surface {
        let outward = self.mesh.geometric_normal(at.prim);
        let front_face = outward.dot(dir) < 0.0;
        let n = if front_face { outward } else { -outward };
        let ns = match self.mesh.interpolated_normal(at) {
            Some(ns) => face_forward(ns, -n),
            None => n,
        };
        Surface { n, ns, front_face, local: at.point, material: self.mesh.material_id(at.prim) as u32 }
    }
    /// The file's texture coordinates, interpolated; without them, the triangle's barycentric
    /// coordinates.
    fn uv(&self, at: &Hit) -> DVec2 {
        self.mesh.interpolated_uv(at).unwrap_or(at.uv)
    }
    /// The file's second set (glTF's `TEXCOORD_1`), interpolated, with its derivatives along the first.
    fn uv1(&self, at: &Hit) -> Option<(DVec2, DMat2)> {
        self.mesh.interpolated_uv1(at)
    }
    /// Flat triangles (the normal's turn across a smooth mesh is not followed).
    fn derivatives(&self, at: &Hit) -> Option<SurfaceDerivatives> {
        self.mesh.uv_derivatives(at).map(|(u, v)| SurfaceDerivatives::flat(u, v))
    }
    fn tangents(&self, at: &Hit) -> Option<[DVec3; 2]> {
        self.mesh.tangents(at)
    }
    fn bounds(&self) -> Option<Aabb> {
        Some(self.mesh.bounds())
    }
    fn is_closed(&self) -> bool {
        self.mesh.is_closed()
    }
    fn area(&self) -> Option<f64> {
        Some(self.mesh.area()).filter(|&a| a > 0.0)
    }
    fn is_convex(&self) -> bool {
        self.mesh.is_convex()
    }
    /// Uniform by area: a triangle chosen by its area, then a point of it.
    fn sample_surface(&self, reference: DVec3, u: DVec2) -> Option<SurfaceSample> {
        let m = self.mesh.sample_point(u)?;
        let mut s = SurfaceSample::new(reference, m.point, m.error, m.normal, SurfacePdf::Area(1.0 / m.area));
        (s.hit.prim, s.hit.uv) = (m.slot, m.b);
        Some(s)
    }
    fn surface_pdf(&self, _: DVec3, _: &Hit) -> SurfacePdf {
        let a = self.mesh.area();
        SurfacePdf::Area(if a > 0.0 { 1.0 / a } else { 0.0 })
    }
}
