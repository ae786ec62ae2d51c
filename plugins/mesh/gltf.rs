//! glTF 2.0 files (`.gltf` with its buffers, or binary `.glb`), read by the gltf crate: meshes
//! for the `mesh` object, and whole files as scenes (`raylab render model.glb`).
//!
//! Buffers are read through the scene's folder sandbox and size limit (never by the gltf crate
//! itself); `data:` URIs are decoded. Triangle lists, strips and fans are read; points and lines
//! are skipped. A file that *requires* an extension raylab does not implement (mesh compression,
//! quantisation) is refused with its name.
//!
//! PBR metallic-roughness → Phong (base colour `c`, metallic `m`, roughness `r`, α = r²):
//!
//! | raylab | from glTF |
//! |---|---|
//! | `kd` | `c · (1 − m)` |
//! | `ks` | `F0 = 0.04·(1 − m) + c·m` (the specular colour at normal incidence) |
//! | `shininess` | `(2/α² − 2) / 4` (Blinn-Phong's equivalent exponent, in Phong's terms), at most 10⁴ |
//! | `kr` | `F0 · m · (1 − r)²`: smooth metals mirror; rough ones and dielectrics do not |
//! | `blur` | `α` where `kr > 0` and α ≥ 0.05 (sharper lobes are mirrors) |
//! | `kt` | `KHR_materials_transmission` factor, or `1 − alpha` for `alphaMode = BLEND` |
//! | `ior` | `KHR_materials_ior` (default 1.5) |
//! | `emission` | `emissiveFactor × KHR_materials_emissive_strength` |
//!
//! Textures are not sampled (their factors are used). As a scene: nodes with meshes become
//! `mesh` objects placed by their world matrix (a mesh used by several nodes is stored once), the
//! first perspective camera becomes the camera (else one is fitted to the scene's bounds), and
//! `KHR_lights_punctual` lights become `directional`, `point` (inverse-square) and `spot` lights,
//! with intensity × colour as their colour; a file without lights gets a sun and an ambient term.

use super::mesh::MeshData;
use raylab::error::{Loc, Result, SceneError, Source};
use raylab::glam::{DMat3, DMat4, DVec3, Mat4};
use raylab::load::SceneDescription;
use raylab::scene_toml::string as toml_string;
use raylab::{Aabb, Color, LoadContext, Material};
use std::fmt::Write;
use std::path::Path;
use std::sync::Arc;

/// Extensions a file may require.
const SUPPORTED: &[&str] = &["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_transmission"];

/// A parsed glTF file with its buffers loaded.
/// The triangles `mesh` declares (its accessors' counts; no data decoded): an upper bound for
/// strips and fans, exact for triangle lists.
fn triangle_count(mesh: &gltf::Mesh) -> u64 {
    mesh.primitives()
        .map(|p| {
            let corners = p.indices().or_else(|| p.get(&gltf::Semantic::Positions)).map_or(0, |a| a.count() as u64);
            corners / 3 + if matches!(p.mode(), gltf::mesh::Mode::Triangles) { 0 } else { corners }
        })
        .sum()
}

/// Refuses a mesh primitive whose attributes or indices name an accessor the file lacks.
fn check_accessor_references(name: &str, json: &gltf::json::Root) -> Result<()> {
    let count = json.accessors.len();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let named = prim.attributes.values().chain(prim.indices.iter()).map(|i| i.value());
            if let Some(bad) = named.into_iter().find(|&i| i >= count) {
                let msg = format!("mesh {m} primitive {p} refers to accessor {bad}, but the file has {count} accessors");
                return Err(SceneError::in_file(name, None, msg));
            }
        }
    }
    Ok(())
}

/// Deepest node hierarchy read from a glTF file (real files stay far below; a deeper chain is
/// refused rather than cut off).
pub const MAX_NODE_DEPTH: usize = 1024;

pub struct GltfFile {
    name: String,
    doc: gltf::Document,
    buffers: Vec<Vec<u8>>,
    /// The scene's triangle limit ([`raylab::load::Limits::max_triangles`]).
    max_triangles: u64,
}

/// The file `path` (as written in the scene), parsed once per scene.
pub fn open(ctx: &LoadContext, path: &str, loc: &Loc) -> Result<Arc<GltfFile>> {
    let full = ctx.resolve_path(path, loc)?;
    ctx.assets.get_or_load(&format!("gltf:{}", full.display()), || {
        let (full, bytes) = ctx.read_file(path, loc)?;
        parse(ctx, path, &full, bytes, loc)
    })
}

/// Parses glTF `bytes` (the file `path` of the scene, resolved to `full`); external buffers are
/// read relative to `path` through `ctx`.
pub fn parse(ctx: &LoadContext, path: &str, full: &Path, bytes: Vec<u8>, loc: &Loc) -> Result<GltfFile> {
    let name = full.display().to_string();
    // The gltf crate panics on a GLB length below its header and on a primitive naming an accessor
    // that does not exist (mesh_gltf fuzz target); both are checked before it reads them.
    if bytes.starts_with(b"glTF") && bytes.len() >= 12 {
        let length = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if length < 12 {
            return Err(SceneError::in_file(&name, None, format!("its GLB header declares {length} bytes, less than the header itself")));
        }
    }
    let failed = || SceneError::in_file(&name, None, "the glTF reader failed on this file (it is malformed)");
    let gltf = match std::panic::catch_unwind(|| gltf::Gltf::from_slice_without_validation(&bytes)) {
        Ok(Ok(g)) => g,
        Ok(Err(e)) => return Err(gltf_error(&name, e)),
        Err(_) => return Err(failed()),
    };
    check_accessor_references(&name, gltf.document.as_json())?;
    let blob = gltf.blob;
    let document = match std::panic::catch_unwind(move || gltf::Document::from_json(gltf.document.into_json())) {
        Ok(Ok(d)) => d,
        Ok(Err(e)) => return Err(gltf_error(&name, e)),
        Err(_) => return Err(failed()),
    };
    let gltf = gltf::Gltf { document, blob };
    for ext in gltf.document.extensions_required() {
        if !SUPPORTED.contains(&ext) {
            return Err(SceneError::in_file(&name, None, format!("the file requires the extension {ext}, which raylab does not support"))
                .with_help(format!("supported: {}; re-export the model without it", SUPPORTED.join(", "))));
        }
    }
    let base = Path::new(path).parent().map(Path::to_path_buf).unwrap_or_default();
    let mut blob = gltf.blob;
    let mut buffers = Vec::new();
    for b in gltf.document.buffers() {
        let data = match b.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                SceneError::in_file(&name, None, format!("buffer {} refers to the binary chunk, which the file lacks", b.index()))
            })?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => data_uri(uri)
                .ok_or_else(|| SceneError::in_file(&name, None, format!("buffer {}: malformed data: URI (expected base64)", b.index())))?,
            gltf::buffer::Source::Uri(uri) => {
                let rel = base.join(percent_decode(uri));
                ctx.read_file(&rel.to_string_lossy(), loc).map_err(|e| e.context(format!("{name}: buffer {} (\"{uri}\")", b.index())))?.1
            }
        };
        if data.len() < b.length() {
            return Err(SceneError::in_file(
                &name,
                None,
                format!("buffer {} holds {} bytes, fewer than the {} its byteLength declares", b.index(), data.len(), b.length()),
            ));
        }
        buffers.push(data);
    }
    Ok(GltfFile { name, doc: gltf.document, buffers, max_triangles: ctx.options.limits.max_triangles })
}

fn gltf_error(name: &str, e: gltf::Error) -> SceneError {
    match e {
        gltf::Error::Deserialize(j) => SceneError::in_file(name, Some((j.line(), j.column())), format!("invalid glTF JSON: {j}")),
        gltf::Error::Validation(errors) => {
            let list: Vec<String> = errors.iter().take(5).map(|(path, err)| format!("{path}: {err}")).collect();
            SceneError::in_file(name, None, format!("invalid glTF: {}", list.join("; ")))
        }
        other => SceneError::in_file(name, None, format!("invalid glTF: {other}")),
    }
}

/// The bytes of a base64 `data:` URI.
fn data_uri(uri: &str) -> Option<Vec<u8>> {
    let (head, payload) = uri.split_once(',')?;
    if !head.ends_with(";base64") {
        return None;
    }
    let mut out = Vec::with_capacity(payload.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in payload.bytes().filter(|&c| c != b'=' && !c.is_ascii_whitespace()) {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Some(out)
}

/// `%20` → ` ` in a relative URI.
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

impl GltfFile {
    /// The file's path, for messages.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Number of meshes in the file.
    pub fn mesh_count(&self) -> usize {
        self.doc.meshes().len()
    }

    /// Mesh `index` in its own frame.
    pub fn mesh(&self, index: usize) -> Result<MeshData> {
        let mesh = self.doc.meshes().nth(index).ok_or_else(|| {
            SceneError::in_file(&self.name, None, format!("there is no mesh {index}: the file has {} meshes", self.mesh_count()))
        })?;
        let mut out = self.empty();
        self.check_triangles(triangle_count(&mesh))?;
        self.append(&mesh, DMat4::IDENTITY, &mut out)?;
        Ok(out)
    }

    /// Refuses more than [`raylab::load::Limits::max_triangles`] triangles.
    fn check_triangles(&self, count: u64) -> Result<()> {
        if count > self.max_triangles {
            return Err(SceneError::in_file(&self.name, None, format!("{count} triangles, over the limit of {}", self.max_triangles))
                .with_help("raise the limit with --max-triangles"));
        }
        Ok(())
    }

    /// Every mesh of the default scene, placed by its node's world matrix, as one mesh.
    pub fn whole(&self) -> Result<MeshData> {
        let mut out = self.empty();
        let nodes = self.nodes()?;
        // Counted from the accessors before any data is decoded: nodes may place one mesh many times.
        let count: u64 = nodes.iter().filter_map(|(n, _)| n.mesh()).map(|m| triangle_count(&m)).sum();
        self.check_triangles(count)?;
        for (node, world) in nodes {
            if let Some(mesh) = node.mesh() {
                self.append(&mesh, world, &mut out)?;
            }
        }
        if out.triangles.is_empty() {
            return Err(SceneError::in_file(&self.name, None, "the file's scene has no triangles"));
        }
        Ok(out)
    }

    /// Mesh data with the file's materials (and a default one last, for primitives with none).
    fn empty(&self) -> MeshData {
        let mut materials: Vec<Material> = self.doc.materials().map(|m| material(&m)).collect();
        materials.push(default_gltf_material());
        MeshData { materials, ..MeshData::default() }
    }

    /// The nodes of the default scene (or the first), with their world matrices. The hierarchy
    /// must be disjoint trees, as glTF requires: a node reached twice (a cycle, or a node with two
    /// parents, which could multiply the work exponentially) and a hierarchy deeper than
    /// [`MAX_NODE_DEPTH`] are errors.
    pub fn nodes(&self) -> Result<Vec<(gltf::Node<'_>, DMat4)>> {
        let mut out = Vec::new();
        let Some(scene) = self.doc.default_scene().or_else(|| self.doc.scenes().next()) else { return Ok(out) };
        let mut seen = vec![false; self.doc.nodes().len()];
        let mut todo: Vec<(gltf::Node, DMat4, usize)> = scene.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect();
        while let Some((node, parent, depth)) = todo.pop() {
            let err = |msg: String| Err(SceneError::in_file(&self.name, None, format!("node {}: {msg}", node.index())));
            if std::mem::replace(&mut seen[node.index()], true) {
                return err(
                    "reached twice: the node hierarchy has a cycle or a node with two parents (glTF requires disjoint trees)".into()
                );
            }
            if depth > MAX_NODE_DEPTH {
                return err(format!("the node hierarchy is deeper than {MAX_NODE_DEPTH} levels"));
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
            todo.extend(node.children().map(|c| (c, world, depth + 1)));
            out.push((node, world));
        }
        Ok(out)
    }

    /// Appends the triangles of every primitive of `mesh`, transformed by `m`.
    fn append(&self, mesh: &gltf::Mesh, m: DMat4, out: &mut MeshData) -> Result<()> {
        let normal_m = DMat3::from_mat4(m).inverse().transpose();
        let flip = DMat3::from_mat4(m).determinant() < 0.0;
        let default_material = out.materials.len() as u32 - 1;
        for prim in mesh.primitives() {
            let what = || format!("mesh {} ({}) primitive {}", mesh.index(), mesh.name().unwrap_or("unnamed"), prim.index());
            let err = |msg: String| SceneError::in_file(&self.name, None, format!("{}: {msg}", what()));
            // The gltf crate's readers assume the types the specification requires (they panic
            // otherwise, found by the mesh_gltf fuzz target): checked first.
            use gltf::accessor::{DataType, Dimensions};
            let typed = |a: Option<gltf::Accessor>, types: &[DataType], dims: Dimensions, what: &str| match a {
                Some(a) if !(types.contains(&a.data_type()) && a.dimensions() == dims) => Err(err(format!(
                    "its {what} accessor holds {:?} of {:?}; expected {dims:?} of {types:?}",
                    a.dimensions(),
                    a.data_type()
                ))),
                Some(a) if a.view().and_then(|v| v.stride()).is_some_and(|s| s < a.size()) => Err(err(format!(
                    "its {what} accessor's buffer view has byteStride {}, less than one element ({} bytes)",
                    a.view().and_then(|v| v.stride()).unwrap_or(0),
                    a.size()
                ))),
                _ => Ok(()),
            };
            typed(prim.get(&gltf::Semantic::Positions), &[DataType::F32], Dimensions::Vec3, "POSITION")?;
            typed(prim.get(&gltf::Semantic::Normals), &[DataType::F32], Dimensions::Vec3, "NORMAL")?;
            typed(prim.indices(), &[DataType::U8, DataType::U16, DataType::U32], Dimensions::Scalar, "index")?;
            let reader = prim.reader(|b| self.buffers.get(b.index()).map(Vec::as_slice));
            let Some(positions) = reader.read_positions() else {
                return Err(err("its POSITION data is missing or lies outside its buffer".into()));
            };
            let positions: Vec<[f32; 3]> = positions.collect();
            if let Some(i) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
                return Err(err(format!("vertex {i} has a coordinate that is NaN or infinite")));
            }
            let n = positions.len() as u32;
            let indices: Vec<u32> = match (reader.read_indices(), prim.indices()) {
                (Some(i), _) => i.into_u32().collect(),
                (None, Some(_)) => return Err(err("its index data lies outside its buffer".into())),
                (None, None) => (0..n).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i >= n) {
                return Err(err(format!("index {bad} is out of range: there are {n} vertices")));
            }
            let tris: Vec<[u32; 3]> = match prim.mode() {
                gltf::mesh::Mode::Triangles => indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                gltf::mesh::Mode::TriangleStrip => {
                    indices.windows(3).enumerate().map(|(i, w)| if i % 2 == 0 { [w[0], w[1], w[2]] } else { [w[1], w[0], w[2]] }).collect()
                }
                gltf::mesh::Mode::TriangleFan => {
                    (1..indices.len().saturating_sub(1)).map(|i| [indices[0], indices[i], indices[i + 1]]).collect()
                }
                _ => continue,
            };
            let base = out.positions.len() as u32;
            out.positions.extend(positions.iter().map(|p| m.transform_point3(DVec3::from(p.map(f64::from))).as_vec3().to_array()));
            let normals: Option<Vec<[f32; 3]>> =
                reader.read_normals().map(|r| r.collect()).filter(|v: &Vec<[f32; 3]>| v.len() == positions.len());
            // The mesh keeps vertex normals only if every primitive has them.
            let keep = normals.is_some() && out.normal_indices.len() == out.triangles.len();
            match normals.filter(|_| keep) {
                Some(ns) => out.normals.extend(ns.iter().map(|v| (normal_m * DVec3::from(v.map(f64::from))).as_vec3().to_array())),
                None => {
                    out.normals.clear();
                    out.normal_indices.clear();
                }
            }
            let material = prim.material().index().map_or(default_material, |i| i as u32);
            for t in tris {
                let t = if flip { [t[0], t[2], t[1]] } else { t };
                out.triangles.push(t.map(|v| base + v));
                if keep {
                    out.normal_indices.push(t.map(|v| base + v));
                }
                out.material_ids.push(material);
            }
        }
        Ok(())
    }

    /// The box around the default scene's vertices.
    fn scene_bounds(&self) -> Result<Aabb> {
        let mut b = Aabb::EMPTY;
        for (node, world) in self.nodes()? {
            let Some(mesh) = node.mesh() else { continue };
            for prim in mesh.primitives() {
                let bb = prim.bounding_box();
                let local = Aabb::new(DVec3::from(bb.min.map(f64::from)), DVec3::from(bb.max.map(f64::from)));
                for i in 0..8 {
                    let c = DVec3::new(
                        if i & 1 == 0 { local.min.x } else { local.max.x },
                        if i & 2 == 0 { local.min.y } else { local.max.y },
                        if i & 4 == 0 { local.min.z } else { local.max.z },
                    );
                    b = b.include(world.transform_point3(c));
                }
            }
        }
        if b.is_empty() || !b.min.is_finite() || !b.max.is_finite() {
            return Err(SceneError::in_file(&self.name, None, "the file's scene has no meshes with finite bounds"));
        }
        Ok(b)
    }
}

fn default_gltf_material() -> Material {
    pbr_to_phong([1.0, 1.0, 1.0, 1.0], 1.0, 1.0, false, None, None, [0.0; 3])
}

/// A glTF material as a raylab material (see the module's table).
pub fn material(m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let blend = m.alpha_mode() == gltf::material::AlphaMode::Blend;
    let transmission = m.transmission().map(|t| t.transmission_factor());
    let emissive = m.emissive_factor().map(|e| e * m.emissive_strength().unwrap_or(1.0));
    pbr_to_phong(pbr.base_color_factor(), pbr.metallic_factor(), pbr.roughness_factor(), blend, transmission, m.ior(), emissive)
}

/// The mapping of the module's table.
pub fn pbr_to_phong(
    base: [f32; 4],
    metallic: f32,
    roughness: f32,
    blend: bool,
    transmission: Option<f32>,
    ior: Option<f32>,
    emissive: [f32; 3],
) -> Material {
    let clamp01 = |v: f32| if v.is_finite() { f64::from(v).clamp(0.0, 1.0) } else { 0.0 };
    let c = Color::new(clamp01(base[0]), clamp01(base[1]), clamp01(base[2]));
    let (m, r) = (clamp01(metallic), clamp01(roughness));
    let alpha = (r * r).max(1e-3);
    let f0 = Color::splat(0.04 * (1.0 - m)) + c * m;
    let kr = f0 * m * (1.0 - r) * (1.0 - r);
    let kt = match transmission {
        Some(t) => clamp01(t),
        None if blend => 1.0 - clamp01(base[3]),
        None => 0.0,
    };
    Material {
        kd: c * (1.0 - m) * (1.0 - kt),
        ks: f0,
        shininess: ((2.0 / (alpha * alpha) - 2.0) / 4.0).clamp(0.0, 1e4),
        kr,
        kt: Color::splat(kt),
        ior: ior.filter(|i| i.is_finite() && *i > 0.0).map_or(1.5, f64::from),
        emission: Color::new(f64::from(emissive[0]), f64::from(emissive[1]), f64::from(emissive[2])).max(Color::ZERO),
        blur: if kr.max_element() > 0.0 && alpha >= 0.05 { alpha.min(1.0) } else { 0.0 },
        ..Material::default()
    }
}

/// Reads a glTF file as a whole scene (the registered scene format for `.gltf` and `.glb`).
pub fn read_scene(path: &Path, _bytes: &[u8], ctx: &LoadContext) -> Result<SceneDescription> {
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let src = Source::new(path.display().to_string(), String::new());
    let loc = Loc::new(&src, 0..0);
    let file = open(ctx, &file_name, &loc)?;
    let toml = scene_toml(&file, &file_name)?;
    let stem = path.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    raylab::load::parse_toml(&Source::new(format!("{} (as a raylab scene)", path.display()), toml), stem)
}

/// The raylab scene (TOML) a glTF file describes.
pub fn scene_toml(file: &GltfFile, file_name: &str) -> Result<String> {
    let v = |p: DVec3| format!("[{:?}, {:?}, {:?}]", p.x, p.y, p.z);
    let mut t = String::new();
    let _ = writeln!(t, "# {} as a raylab scene\nbackground = [0.1, 0.1, 0.1]\n", file.name);
    let nodes = file.nodes()?;
    // Camera: the first perspective camera, or one fitted to the bounds.
    let camera = nodes.iter().find_map(|(n, w)| match n.camera()?.projection() {
        gltf::camera::Projection::Perspective(p) => Some((*w, p.yfov(), p.aspect_ratio())),
        gltf::camera::Projection::Orthographic(_) => None,
    });
    let (width, height) = match camera.and_then(|c| c.2).filter(|a| a.is_finite() && *a > 0.01 && *a < 100.0) {
        Some(a) => (800, ((800.0 / a).round() as u32).max(1)),
        None => (800, 600),
    };
    let _ = writeln!(t, "[render]\nwidth = {width}\nheight = {height}\n");
    let bounds = file.scene_bounds()?;
    match camera {
        Some((w, yfov, _)) => {
            let pos = w.transform_point3(DVec3::ZERO);
            let fwd = w.transform_vector3(-DVec3::Z).try_normalize().unwrap_or(-DVec3::Z);
            let up = w.transform_vector3(DVec3::Y).try_normalize().unwrap_or(DVec3::Y);
            let deg = f64::from(yfov).to_degrees().clamp(1.0, 170.0);
            let _ = writeln!(t, "[camera]\nposition = {}\nlook_at = {}\nup = {}\nfov = {deg:?}\n", v(pos), v(pos + fwd), v(up));
        }
        None => {
            let (center, radius) = (bounds.center(), (bounds.extent().length() * 0.5).max(1e-6));
            let dir = DVec3::new(0.35, 0.3, 1.0).normalize();
            let dist = radius / (20f64.to_radians()).sin() * 1.1;
            let _ = writeln!(t, "[camera]\nposition = {}\nlook_at = {}\nfov = 40.0\n", v(center + dir * dist), v(center));
        }
    }
    // Objects: one per node with a mesh.
    let mut any = false;
    for (node, w) in &nodes {
        let Some(mesh) = node.mesh() else { continue };
        any = true;
        let name = format!("{} #{}", node.name().unwrap_or("node"), node.index());
        let c = w.to_cols_array_2d();
        let rows: Vec<String> = (0..3).map(|r| format!("[{:?}, {:?}, {:?}, {:?}]", c[0][r], c[1][r], c[2][r], c[3][r])).collect();
        let _ = writeln!(
            t,
            "[[object]]\ntype = \"mesh\"\nname = {}\nfile = {}\nmesh = {}\ntransform = {{ matrix = [{}, [0.0, 0.0, 0.0, 1.0]] }}\n",
            toml_string(&name),
            toml_string(file_name),
            mesh.index(),
            rows.join(", ")
        );
    }
    if !any {
        return Err(SceneError::in_file(&file.name, None, "the file's scene has no meshes"));
    }
    // Lights.
    let mut lights = 0;
    for (node, w) in &nodes {
        let Some(light) = node.light() else { continue };
        lights += 1;
        let color = DVec3::from(light.color().map(f64::from)) * f64::from(light.intensity());
        let pos = w.transform_point3(DVec3::ZERO);
        let dir = w.transform_vector3(-DVec3::Z).try_normalize().unwrap_or(-DVec3::Z);
        let name = toml_string(&format!("{} #{}", node.name().or(light.name()).unwrap_or("light"), node.index()));
        match light.kind() {
            gltf::khr_lights_punctual::Kind::Directional => {
                let _ = writeln!(t, "[[light]]\ntype = \"directional\"\nname = {name}\ncolor = {}\ndirection = {}\n", v(color), v(dir));
            }
            gltf::khr_lights_punctual::Kind::Point => {
                let _ = writeln!(
                    t,
                    "[[light]]\ntype = \"point\"\nname = {name}\ncolor = {}\nposition = {}\nkc = 0.0\nkq = 1.0\n",
                    v(color),
                    v(pos)
                );
            }
            gltf::khr_lights_punctual::Kind::Spot { outer_cone_angle, .. } => {
                let cone = f64::from(outer_cone_angle).to_degrees().clamp(0.1, 90.0);
                let _ = writeln!(
                    t,
                    "[[light]]\ntype = \"spot\"\nname = {name}\ncolor = {}\nposition = {}\ndirection = {}\ncone_angle = {cone:?}\nexponent = 1.0\nkc = 0.0\nkq = 1.0\n",
                    v(color),
                    v(pos),
                    v(dir)
                );
            }
        }
    }
    if lights == 0 {
        t.push_str("# the file has no KHR_lights_punctual lights: a sun and an ambient term\n");
        t.push_str("[[light]]\ntype = \"directional\"\nname = \"sun\"\ndirection = [-0.4, -1.0, -0.6]\ncolor = 1.0\n\n");
        t.push_str("[[light]]\ntype = \"ambient\"\nname = \"sky\"\nka = 0.15\n");
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_and_percent_escapes_decode() {
        assert_eq!(data_uri("data:application/octet-stream;base64,AAEC/w==").unwrap(), vec![0, 1, 2, 255]);
        assert!(data_uri("data:text/plain,hello").is_none());
        assert_eq!(percent_decode("my%20model.bin"), "my model.bin");
        assert_eq!(percent_decode("100%"), "100%");
    }

    #[test]
    fn smooth_metal_mirrors_and_rough_plastic_does_not() {
        let gold = pbr_to_phong([1.0, 0.8, 0.3, 1.0], 1.0, 0.0, false, None, None, [0.0; 3]);
        assert_eq!(gold.kd, Color::ZERO);
        assert!(gold.kr.x > 0.9 && gold.blur < 0.01 && gold.shininess >= 1e3);
        let plastic = pbr_to_phong([0.2, 0.4, 0.8, 1.0], 0.0, 0.5, false, None, None, [0.0; 3]);
        assert_eq!(plastic.kr, Color::ZERO);
        assert!((plastic.kd - Color::new(0.2, 0.4, 0.8)).length() < 1e-6 && (plastic.ks.x - 0.04).abs() < 1e-9);
        assert!((plastic.shininess - 7.5).abs() < 1e-9);
        let glass = pbr_to_phong([1.0; 4], 0.0, 0.0, false, Some(1.0), Some(1.33), [0.0; 3]);
        assert_eq!((glass.kt, glass.ior), (Color::ONE, 1.33f32 as f64));
    }
}
