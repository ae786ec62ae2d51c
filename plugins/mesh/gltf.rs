//! glTF 2.0 files (`.gltf` with its buffers, or binary `.glb`), read by the gltf crate: meshes
//! for the `mesh` object, and whole files as scenes (`raylab render model.glb`).
//!
//! Buffers are read through the scene's folder sandbox and size limit (never by the gltf crate
//! itself); `data:` URIs are decoded. Triangle lists, strips and fans are read; points and lines
//! are skipped. A file that *requires* an extension raylab does not implement (mesh compression,
//! quantisation) is refused with its name.
//!
//! Materials become `pbr` materials ([`crate::materials::pbr`]): in the path tracer the glTF
//! BRDF itself, with `KHR_materials_ior`, `_specular`, `_transmission` (thin-walled) and
//! `_emissive_strength`, and the `baseColorTexture`, `metallicRoughnessTexture`,
//! `emissiveTexture` and `transmissionTexture` slots (with `KHR_texture_transform`, on
//! `TEXCOORD_0` or `TEXCOORD_1` as `texCoord` says); for `phong`,
//! the Phong coefficients of [`crate::materials::pbr::phong_mapping`] (base colour `c`,
//! metallic `m`, roughness `r`, α = r²):
//!
//! | raylab | from glTF |
//! |---|---|
//! | `kd` | `c · (1 − m)` |
//! | `shininess` | `n = (2/α² − 2) / 4` (Blinn-Phong's equivalent exponent, in Phong's terms), in [1, 10⁴] |
//! | `ks` | `F0 · (n + 1) / 2`, `F0 = 0.04·(1 − m) + c·m` (the specular colour at normal incidence) |
//! | `kr` | `F0 · m · (1 − r)²`: smooth metals mirror; rough ones and dielectrics do not |
//! | `blur` | `α` where `kr > 0` and α ≥ 0.05 (sharper lobes are mirrors) |
//! | `kt` | `KHR_materials_transmission` factor |
//! | `ior` | `KHR_materials_ior` (default 1.5) |
//! | `emission` | `emissiveFactor × KHR_materials_emissive_strength` |
//! | textures | `baseColorTexture` multiplies `kd` (and `ks`, `kr` when `m > 0`), `emissiveTexture` the emission |
//!
//! The Phong lobe `ks · cos^n` reflects `2·ks / (n + 1)` of the light a viewer sees, so
//! `ks = F0·(n + 1)/2` keeps the specular reflectance at `F0` whatever the roughness: rough
//! materials get a dim, wide highlight and smooth ones a small, bright one, as GGX gives them. The
//! exponent stays ≥ 1 ([`MIN_SHININESS`]): below it the lobe is cut off by a step where the
//! mirror direction turns away from the viewer (a hard line across flat faces).
//! docs/gltf-materials.md compares the mapping with the glTF BRDF on a row of spheres.
//!
//! `alphaMode = MASK` (with `alphaCutoff`) and `BLEND` make the material a cut-out
//! ([`raylab::scene::material::Cutout`]), for every renderer and every ray: coverage is the base
//! colour factor's alpha times the base colour texture's alpha; MASK keeps the surface where
//! coverage ≥ the cutoff, BLEND keeps it with probability equal to the coverage (stochastic
//! transparency, decided by a hash of the ray, so images stay deterministic).
//!
//! `normalTexture` (with its `scale`) tilts the shading normal in every integrator
//! ([`raylab::scene::normal_map`]), over the primitive's `TANGENT`s or, without them, MikkTSpace
//! tangents ([`mikk_tangents`]).
//!
//! `occlusionTexture` (with its `strength`) darkens `phong`'s ambient term (`ka`); the path
//! tracer, which finds occlusion itself, does not read it (a warning says so).
//!
//! Vertex colours, animations, skins, morph targets, points and
//! lines, orthographic cameras and extensions raylab does not implement (those
//! `extensionsUsed` lists and those found on any element) are ignored with one warning per kind
//! (with a count, or naming each extension); so are the metallic-roughness and transmission
//! textures for `phong` (one warning each: the path tracer samples them). Sparse accessors are
//! read (the gltf crate applies their substitutions).
//! Non-finite numbers (NaN, or beyond f32) in transforms, cameras, lights and materials are
//! refused. Errors name the element by its JSON pointer (`/nodes/3/matrix`) at its line and
//! column in the JSON (the JSON chunk, for `.glb`).
//!
//! As a scene, the description is built directly from the file (no intermediate text): each node
//! with a mesh becomes a `mesh` object naming the node (`node = N`, placed by its world matrix;
//! a mesh used by several nodes is stored once), the first perspective camera becomes the camera
//! (else one is fitted to the scene's bounds), and `KHR_lights_punctual` lights become
//! `directional`, `point` (inverse-square) and `spot` lights, with intensity × colour as their
//! colour; a file without lights gets a sun and an ambient term. The instances' triangles count
//! against `--max-triangles` before anything is built.

use super::triangle_mesh::MeshData;
use crate::materials::pbr::{Pbr, Textured};
use crate::textures::image::{self as image_texture, ColorSpace, Filter, Image, ImageTexture, Wrap};
use raylab::geometry::transform::Transform;
use raylab::glam::{DAffine3, DMat3, DMat4, DQuat, DVec3, Mat4, Vec3};
use raylab::param::description::SceneDescription;
use raylab::param::error::{Loc, Result, SceneError, Source};
use raylab::param::value::{Entry, Node, Table, Value};
use raylab::scene::material::{AlphaMode, Channel, Cutout, Model, NormalMap, NormalMapKind, TextureMap};
use raylab::scene::texture::{Coords, Mapping, Texture};
use raylab::{Aabb, Color, LoadContext, Material};
use std::fmt::Display;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// Extensions a file may require.
const SUPPORTED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_texture_transform",
];

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

/// Shortest rotation quaternion normalised rather than refused (glTF requires unit ones).
const MIN_QUATERNION_LENGTH: f64 = 1e-6;

pub struct GltfFile {
    name: String,
    doc: gltf::Document,
    buffers: Vec<Vec<u8>>,
    /// The scene's triangle limit ([`raylab::param::limits::Limits::max_triangles`]).
    max_triangles: u64,
    /// The JSON text (the JSON chunk of a `.glb`), for locating errors.
    json: Arc<Source>,
    /// Where the elements errors point at are in [`GltfFile::json`].
    spans: Spans,
    /// Where the default scene places its nodes, computed once.
    placements: OnceLock<Result<Placements>>,
    /// The file's folder as the scene names it, for the files its images name.
    base: PathBuf,
    /// The textures built so far, by texture index and transform (`None`: unreadable, warned
    /// about once), shared by every mesh of the file.
    textures: std::sync::Mutex<std::collections::HashMap<TextureKey, Option<Arc<dyn Texture>>>>,
}

/// A texture of a glTF file as a material samples it: its index, `KHR_texture_transform`
/// (offset, rotation, scale as bits) and whether it holds colours or data.
type TextureKey = (usize, Option<[u64; 5]>, Slot, u64);

/// A texture info's `KHR_texture_transform`, read from its extensions (so that a malformed one is
/// a warning, not the whole file's error).
#[derive(Clone, Copy, Debug, PartialEq)]
struct UvTransform {
    offset: [f64; 2],
    /// Radians.
    rotation: f64,
    scale: [f64; 2],
    /// The texture coordinate set it asks for instead of the info's.
    tex_coord: Option<u64>,
}

impl UvTransform {
    /// The transform of `info`: `Ok(None)` without one, `Err` naming what is malformed.
    fn of(info: &TexRef) -> std::result::Result<Option<UvTransform>, String> {
        let Some(v) = &info.transform else { return Ok(None) };
        let obj = v.as_object().ok_or_else(|| format!("expected an object, found {v}"))?;
        let pair = |key: &str, default: [f64; 2]| -> std::result::Result<[f64; 2], String> {
            match obj.get(key) {
                None => Ok(default),
                Some(p) => match p.as_array().map(|a| a.iter().map(|x| x.as_f64()).collect::<Option<Vec<f64>>>()) {
                    Some(Some(a)) if a.len() == 2 && a.iter().all(|x| x.is_finite()) => Ok([a[0], a[1]]),
                    _ => Err(format!("`{key}`: expected two finite numbers, found {p}")),
                },
            }
        };
        let rotation = match obj.get("rotation") {
            None => 0.0,
            Some(r) => r.as_f64().filter(|r| r.is_finite()).ok_or_else(|| format!("`rotation`: expected a finite number, found {r}"))?,
        };
        let tex_coord = match obj.get("texCoord") {
            None => None,
            Some(c) => Some(c.as_u64().ok_or_else(|| format!("`texCoord`: expected a whole number, found {c}"))?),
        };
        Ok(Some(UvTransform { offset: pair("offset", [0.0, 0.0])?, rotation, scale: pair("scale", [1.0, 1.0])?, tex_coord }))
    }

    /// The transform as bits, for [`TextureKey`].
    fn key(&self) -> [u64; 5] {
        [self.offset[0], self.offset[1], self.rotation, self.scale[0], self.scale[1]].map(f64::to_bits)
    }
}

/// A material's reference to a texture (a `textureInfo`, or a `normalTexture` or
/// `occlusionTexture`, which the gltf crate types apart): the texture, its coordinate set and its
/// `KHR_texture_transform`.
struct TexRef<'a> {
    texture: gltf::Texture<'a>,
    tex_coord: u32,
    transform: Option<gltf::json::Value>,
}

impl<'a> From<&gltf::texture::Info<'a>> for TexRef<'a> {
    fn from(i: &gltf::texture::Info<'a>) -> Self {
        TexRef { texture: i.texture(), tex_coord: i.tex_coord(), transform: i.extension_value("KHR_texture_transform").cloned() }
    }
}

impl<'a> From<&gltf::material::NormalTexture<'a>> for TexRef<'a> {
    fn from(i: &gltf::material::NormalTexture<'a>) -> Self {
        TexRef { texture: i.texture(), tex_coord: i.tex_coord(), transform: i.extension_value("KHR_texture_transform").cloned() }
    }
}

impl<'a> From<&gltf::material::OcclusionTexture<'a>> for TexRef<'a> {
    fn from(i: &gltf::material::OcclusionTexture<'a>) -> Self {
        TexRef { texture: i.texture(), tex_coord: i.tex_coord(), transform: i.extension_value("KHR_texture_transform").cloned() }
    }
}

/// Byte ranges of the indexed JSON elements errors point at (empty where the text could not be
/// followed; errors then point at the document's start, with the pointer in the message).
#[derive(Default)]
struct Spans {
    nodes: Vec<Range<usize>>,
    cameras: Vec<Range<usize>>,
    materials: Vec<Range<usize>>,
    lights: Vec<Range<usize>>,
}

/// A kind of indexed glTF element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Element {
    /// `/nodes/i`.
    Node,
    /// `/cameras/i`.
    Camera,
    /// `/materials/i`.
    Material,
    /// `/extensions/KHR_lights_punctual/lights/i`.
    Light,
}

impl Element {
    /// The JSON pointer of the element array.
    fn pointer(self) -> &'static str {
        match self {
            Element::Node => "/nodes",
            Element::Camera => "/cameras",
            Element::Material => "/materials",
            Element::Light => "/extensions/KHR_lights_punctual/lights",
        }
    }
}

/// Where the default scene places its nodes.
struct Placements {
    /// Indices of the placed nodes, depth first.
    order: Vec<usize>,
    /// World matrix of each node (by index); `None` for nodes outside the scene.
    world: Vec<Option<DAffine3>>,
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
    let json = json_source(&name, &bytes);
    let failed = || SceneError::in_file(&name, None, "the glTF reader failed on this file (it is malformed)");
    let gltf = match std::panic::catch_unwind(|| gltf::Gltf::from_slice_without_validation(&bytes)) {
        Ok(Ok(g)) => g,
        Ok(Err(e)) => return Err(gltf_error(&name, e)),
        Err(_) => return Err(failed()),
    };
    // Required extensions first: the crate's validation calls a file that needs one it does not
    // know invalid, and the file is valid, only unsupported.
    let unsupported: Vec<&str> = gltf.document.extensions_required().filter(|e| !SUPPORTED.contains(e)).collect();
    if !unsupported.is_empty() {
        return Err(SceneError::in_file(
            &name,
            None,
            format!("unsupported glTF extension: the file requires {}, which raylab does not read", unsupported.join(" and ")),
        )
        .with_help(format!("supported: {}; re-export the model without it", SUPPORTED.join(", "))));
    }
    check_accessor_references(&name, gltf.document.as_json())?;
    let blob = gltf.blob;
    let document = match std::panic::catch_unwind(move || gltf::Document::from_json(gltf.document.into_json())) {
        Ok(Ok(d)) => d,
        Ok(Err(e)) => return Err(gltf_error(&name, e)),
        Err(_) => return Err(failed()),
    };
    let gltf = gltf::Gltf { document, blob };
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
    let text = json.text.as_bytes();
    let spans = Spans {
        nodes: element_spans(text, &["nodes"]),
        cameras: element_spans(text, &["cameras"]),
        materials: element_spans(text, &["materials"]),
        lights: element_spans(text, &["extensions", "KHR_lights_punctual", "lights"]),
    };
    let file = GltfFile {
        name,
        doc: gltf.document,
        buffers,
        max_triangles: ctx.options.limits.max_triangles,
        json,
        spans,
        placements: OnceLock::new(),
        base,
        textures: Default::default(),
    };
    file.check_materials()?;
    file.warn_ignored(ctx);
    Ok(file)
}

/// The JSON text of glTF `bytes` (the JSON chunk of a GLB), named for messages.
fn json_source(name: &str, bytes: &[u8]) -> Arc<Source> {
    match bytes.get(12..16).filter(|_| bytes.starts_with(b"glTF")) {
        Some(len) => {
            let len = u32::from_le_bytes([len[0], len[1], len[2], len[3]]) as usize;
            let chunk = bytes.get(20..).unwrap_or_default();
            let chunk = &chunk[..len.min(chunk.len())];
            Source::new(format!("{name} (JSON chunk)"), String::from_utf8_lossy(chunk).into_owned())
        }
        None => Source::new(name, String::from_utf8_lossy(bytes).into_owned()),
    }
}

/// Byte ranges of the elements of the array at `path` (object keys from the root) in JSON
/// `text`: empty when the path is absent or the text is not JSON. Linear in the text, without
/// recursion.
fn element_spans(text: &[u8], path: &[&str]) -> Vec<Range<usize>> {
    let mut j = JsonCursor { b: text, i: 0 };
    let mut out = Vec::new();
    let found = path.iter().all(|key| j.enter_key(key).is_some());
    j.ws();
    if !found || j.peek() != Some(b'[') {
        return out;
    }
    j.i += 1;
    loop {
        j.ws();
        if j.peek() == Some(b']') {
            return out;
        }
        let start = j.i;
        if j.skip_value().is_none() {
            return out;
        }
        out.push(start..j.i);
        j.ws();
        match j.peek() {
            Some(b',') => j.i += 1,
            _ => return out,
        }
    }
}

/// A position in a JSON text, for [`element_spans`].
struct JsonCursor<'a> {
    b: &'a [u8],
    i: usize,
}

impl JsonCursor<'_> {
    fn peek(&self) -> Option<u8> {
        self.b.get(self.i).copied()
    }

    fn ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.i += 1;
        }
    }

    /// Skips a string (at its opening quote); returns the range of its raw contents.
    fn string(&mut self) -> Option<Range<usize>> {
        if self.peek() != Some(b'"') {
            return None;
        }
        let start = self.i + 1;
        let mut k = start;
        loop {
            match *self.b.get(k)? {
                b'"' => break,
                b'\\' => k += 2,
                _ => k += 1,
            }
        }
        self.i = k + 1;
        Some(start..k)
    }

    /// Skips one value (nested arrays and objects by counting brackets).
    fn skip_value(&mut self) -> Option<()> {
        let mut depth = 0usize;
        loop {
            self.ws();
            match self.peek()? {
                b'"' => {
                    self.string()?;
                }
                b'{' | b'[' => {
                    depth += 1;
                    self.i += 1;
                }
                b'}' | b']' => {
                    depth = depth.checked_sub(1)?;
                    self.i += 1;
                }
                b',' | b':' if depth > 0 => self.i += 1,
                b',' | b':' => return None,
                _ => {
                    while !matches!(self.peek(), None | Some(b',' | b'}' | b']' | b' ' | b'\t' | b'\n' | b'\r')) {
                        self.i += 1;
                    }
                }
            }
            if depth == 0 {
                return Some(());
            }
        }
    }

    /// Moves into the object at the cursor, to the value of `key`.
    fn enter_key(&mut self, key: &str) -> Option<()> {
        self.ws();
        if self.peek() != Some(b'{') {
            return None;
        }
        self.i += 1;
        loop {
            self.ws();
            let k = self.string()?;
            self.ws();
            if self.peek() != Some(b':') {
                return None;
            }
            self.i += 1;
            self.ws();
            if self.b.get(k) == Some(key.as_bytes()) {
                return Some(());
            }
            self.skip_value()?;
            self.ws();
            if self.peek() != Some(b',') {
                return None;
            }
            self.i += 1;
        }
    }
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
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
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

    /// Mesh `index` in its own frame, with the textures its materials sample.
    pub fn mesh(&self, ctx: &LoadContext, index: usize) -> Result<MeshData> {
        let mesh = self.doc.meshes().nth(index).ok_or_else(|| {
            SceneError::in_file(&self.name, None, format!("there is no mesh {index}: the file has {} meshes", self.mesh_count()))
        })?;
        let mut out = self.empty();
        self.check_triangles(triangle_count(&mesh))?;
        self.append(&mesh, DMat4::IDENTITY, &mut out)?;
        self.drop_unused_second_set(&mut out);
        self.attach_textures(ctx, &mut out);
        Ok(out)
    }

    /// Drops the second texture-coordinate set `out` carries (copies of the first) where no
    /// primitive of the file has a `TEXCOORD_1`.
    fn drop_unused_second_set(&self, out: &mut MeshData) {
        if !self.doc.meshes().any(|m| m.primitives().any(|p| p.get(&gltf::Semantic::TexCoords(1)).is_some())) {
            out.texcoords1 = Vec::new();
        }
    }

    /// Refuses more than [`raylab::param::limits::Limits::max_triangles`] triangles.
    fn check_triangles(&self, count: u64) -> Result<()> {
        if count > self.max_triangles {
            return Err(SceneError::in_file(&self.name, None, format!("{count} triangles, over the limit of {}", self.max_triangles))
                .with_help("raise the limit with --max-triangles"));
        }
        Ok(())
    }

    /// Every mesh of the default scene, placed by its node's world matrix, as one mesh, with the
    /// textures its materials sample.
    pub fn whole(&self, ctx: &LoadContext) -> Result<MeshData> {
        let mut out = self.empty();
        let placed = self.placements()?;
        let meshes = || placed.order.iter().filter_map(|&i| Some((self.doc.nodes().nth(i)?.mesh()?, placed.world[i]?)));
        // Counted from the accessors before any data is decoded: nodes may place one mesh many times.
        let count: u64 = meshes().map(|(m, _)| triangle_count(&m)).sum();
        self.check_triangles(count)?;
        for (mesh, world) in meshes() {
            self.append(&mesh, DMat4::from(world), &mut out)?;
        }
        if out.triangles.is_empty() {
            return Err(SceneError::in_file(&self.name, None, "the file's scene has no triangles"));
        }
        self.drop_unused_second_set(&mut out);
        self.attach_textures(ctx, &mut out);
        Ok(out)
    }

    /// Gives the materials `out`'s triangles use the textures they sample (images decoded once
    /// per scene; those of unused materials are not read). For `phong`, `baseColorTexture`
    /// multiplies `kd` (and `ks`, `kr` of metals, whose specular colour is the base colour),
    /// `emissiveTexture` the emission; the `pbr` model samples those and the
    /// `metallicRoughnessTexture` and `transmissionTexture` (linear data). An image that cannot
    /// be read (missing, malformed, over the limits) is a warning: the material keeps its
    /// factors.
    fn attach_textures(&self, ctx: &LoadContext, out: &mut MeshData) {
        let mut used = out.material_ids.clone();
        used.sort_unstable();
        used.dedup();
        for id in used {
            let Some(m) = self.doc.materials().nth(id as usize) else { continue };
            // Each texture is built (or found unreadable, with one warning) once per file.
            let mut sampled = |info: &TexRef, kind: &str, slot: Slot| {
                let transform = UvTransform::of(info).unwrap_or_else(|e| {
                    ctx.warn(SceneError::in_file(
                        &self.name,
                        None,
                        format!("material {id}: its {kind}'s KHR_texture_transform is malformed ({e}): ignored"),
                    ));
                    None
                });
                self.textures
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .entry((info.texture.index(), transform.map(|t| t.key()), slot, tex_coord_set(info)))
                    .or_insert_with(|| match self.texture(ctx, info, transform, id as usize, slot) {
                        Ok(t) => Some(t),
                        Err(e) => {
                            ctx.warn(e.context(format!("{}: material {id}: its {kind} is not sampled (its factor is used)", self.name)));
                            None
                        }
                    })
                    .clone()
            };
            let model = pbr_model(&m, &mut sampled);
            let mut maps = Vec::new();
            if let Some(t) = model.base_color.texture.clone() {
                maps.push((Channel::Kd, t.clone()));
                if m.pbr_metallic_roughness().metallic_factor() > 0.0 {
                    maps.extend([(Channel::Ks, t.clone()), (Channel::Kr, t)]);
                }
            }
            if let Some(t) = model.emission.texture.clone() {
                maps.push((Channel::Emission, t));
            }
            let alpha = match (m.alpha_mode(), m.pbr_metallic_roughness().base_color_texture()) {
                (gltf::material::AlphaMode::Opaque, _) | (_, None) => None,
                (_, Some(info)) => sampled(&TexRef::from(&info), "baseColorTexture's alpha", Slot::Alpha),
            };
            let normal_map = m.normal_texture().and_then(|n| {
                let scale = f64::from(n.scale());
                let texture = sampled(&TexRef::from(&n), "normalTexture", Slot::Data)?;
                Some(NormalMap { texture, kind: NormalMapKind::Tangent, scale: if scale.is_finite() { scale } else { 1.0 } })
            });
            // Occlusion darkens phong's ambient term: `ka = 1 + strength·(occlusion − 1)`.
            if let Some(o) = m.occlusion_texture() {
                let strength = f64::from(o.strength());
                let strength = if strength.is_finite() { strength.clamp(0.0, 1.0) } else { 1.0 };
                if let Some(texture) = sampled(&TexRef::from(&o), "occlusionTexture", Slot::Data) {
                    maps.push((Channel::Ka, Arc::new(Occlusion { texture, strength })));
                }
            }
            let material = &mut out.materials[id as usize];
            if alpha.is_some() {
                material.cutout = cutout(&m, alpha);
            }
            material.normal_map = normal_map;
            material.textures.extend(maps.into_iter().map(|(channel, texture)| TextureMap { channel, texture }));
            material.model = Some(Model(Arc::new(model)));
        }
    }

    /// The texture `info` of material `material` names: its image (sRGB), its sampler's wrap
    /// modes and magnification filter, placed by `transform` (its `KHR_texture_transform`).
    fn texture(
        &self,
        ctx: &LoadContext,
        info: &TexRef,
        transform: Option<UvTransform>,
        material: usize,
        slot: Slot,
    ) -> Result<Arc<dyn Texture>> {
        use gltf::texture::{MagFilter, WrappingMode};
        let t = &info.texture;
        let space = match slot {
            Slot::Color => ColorSpace::Srgb,
            Slot::Data => ColorSpace::Linear,
            Slot::Alpha => ColorSpace::Alpha,
        };
        let image = self.image(ctx, &t.source(), material, space)?;
        if space != ColorSpace::Alpha {
            image_texture::with_mip_maps(&image, ctx)?;
        }
        let sampler = t.sampler();
        let wrap = |w: WrappingMode| match w {
            WrappingMode::ClampToEdge => Wrap::Clamp,
            WrappingMode::MirroredRepeat => Wrap::Mirror,
            WrappingMode::Repeat => Wrap::Repeat,
        };
        let filter = if sampler.mag_filter() == Some(MagFilter::Nearest) { Filter::Nearest } else { Filter::Bilinear };
        // TEXCOORD_1 for set 1; set 0 otherwise (sets beyond 1 are warned about).
        let coords = if tex_coord_set(info) == 1 { Coords::Uv1 } else { Coords::Uv };
        let mapping = match transform {
            Some(t) => Mapping::with_inverse(coords, gltf_uv_transform(t.offset, t.rotation, t.scale)),
            None => Mapping::new(coords),
        };
        Ok(Arc::new(ImageTexture::new(image, mapping, [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())], filter, Color::ONE)))
    }

    /// Image `img` decoded (as `space`: sRGB colours or linear data), once per scene and colour
    /// space: a file beside the glTF (through the sandbox), a `data:` URI, or a buffer view.
    /// Errors name material `material`.
    fn image(&self, ctx: &LoadContext, img: &gltf::Image, material: usize, space: ColorSpace) -> Result<Arc<Image>> {
        let loc = self.loc(Element::Material, material);
        let what = format!("image {}", img.index());
        let embedded = |bytes: Option<&[u8]>| -> Result<Arc<Image>> {
            let key = match space {
                ColorSpace::Srgb => format!("gltf-image:{}:{}", self.name, img.index()),
                ColorSpace::Alpha => format!("gltf-image:{}:{}:alpha", self.name, img.index()),
                _ => format!("gltf-image:{}:{}:linear", self.name, img.index()),
            };
            ctx.assets.get_or_load(&key, || {
                let bytes = bytes.ok_or_else(|| {
                    SceneError::in_file(
                        &self.name,
                        None,
                        format!("image {}: its data lies outside its buffer or is malformed", img.index()),
                    )
                })?;
                image_texture::decode(bytes, &format!("{} ({what})", self.name), space, ctx)
            })
        };
        match img.source() {
            gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => embedded(data_uri(uri).as_deref()),
            gltf::image::Source::Uri { uri, .. } => {
                let rel = self.base.join(percent_decode(uri));
                image_texture::load(ctx, &rel.to_string_lossy(), &loc, space).map_err(|e| e.context(&what))
            }
            gltf::image::Source::View { view, .. } => {
                let bytes =
                    self.buffers.get(view.buffer().index()).and_then(|b| b.get(view.offset()..view.offset().checked_add(view.length())?));
                embedded(bytes)
            }
        }
    }

    /// The mesh node `index` places and its world matrix: what a `mesh` object with `node = N`
    /// shows.
    pub fn node_instance(&self, index: usize) -> Result<(usize, DAffine3)> {
        let count = self.doc.nodes().len();
        let node = self
            .doc
            .nodes()
            .nth(index)
            .ok_or_else(|| SceneError::in_file(&self.name, None, format!("there is no node {index}: the file has {count} nodes")))?;
        let mesh = node.mesh().ok_or_else(|| self.error(Element::Node, index, "", "the node has no mesh"))?;
        let world = self.placements()?.world[index]
            .ok_or_else(|| self.error(Element::Node, index, "", "the node is not in the file's default scene"))?;
        Ok((mesh.index(), world))
    }

    /// Mesh data with the file's materials (and a default one last, for primitives with none).
    fn empty(&self) -> MeshData {
        let mut materials: Vec<Material> = self.doc.materials().map(|m| material(&m)).collect();
        materials.push(default_gltf_material());
        MeshData { materials, ..MeshData::default() }
    }

    /// The error `message` about element `index` of `kind` (`tail`: the rest of its JSON pointer,
    /// such as `/matrix`), at the element's line and column in the JSON.
    fn error(&self, kind: Element, index: usize, tail: &str, message: impl Display) -> SceneError {
        let spans = match kind {
            Element::Node => &self.spans.nodes,
            Element::Camera => &self.spans.cameras,
            Element::Material => &self.spans.materials,
            Element::Light => &self.spans.lights,
        };
        let at = self.json.line_col(spans.get(index).map_or(0, |r| r.start));
        SceneError::in_file(&self.json.name, Some(at), format!("{}/{index}{tail}: {message}", kind.pointer()))
    }

    /// The location of element `index` of `kind` in the JSON (its whole text when not found).
    pub fn loc(&self, kind: Element, index: usize) -> Loc {
        let spans = match kind {
            Element::Node => &self.spans.nodes,
            Element::Camera => &self.spans.cameras,
            Element::Material => &self.spans.materials,
            Element::Light => &self.spans.lights,
        };
        Loc::new(&self.json, spans.get(index).cloned().unwrap_or(0..0))
    }

    /// Where the default scene (or the first) places its nodes, computed once. The hierarchy must
    /// be disjoint trees, as glTF requires: a node reached twice (a cycle, or a node with two
    /// parents, which could multiply the work exponentially) and a hierarchy deeper than
    /// [`MAX_NODE_DEPTH`] are errors, as are non-finite transforms and a singular world matrix
    /// on a node that places a mesh, camera or light.
    fn placements(&self) -> Result<&Placements> {
        self.placements.get_or_init(|| self.place()).as_ref().map_err(Clone::clone)
    }

    fn place(&self) -> Result<Placements> {
        let mut out = Placements { order: Vec::new(), world: vec![None; self.doc.nodes().len()] };
        let Some(scene) = self.doc.default_scene().or_else(|| self.doc.scenes().next()) else { return Ok(out) };
        // (node, its parent's world matrix, depth, the nearest node on its path with a singular transform)
        let mut todo: Vec<(gltf::Node, DAffine3, usize, Option<usize>)> = scene.nodes().map(|n| (n, DAffine3::IDENTITY, 0, None)).collect();
        while let Some((node, parent, depth, singular)) = todo.pop() {
            let i = node.index();
            if out.world[i].is_some() {
                return Err(self.error(
                    Element::Node,
                    i,
                    "",
                    "reached twice: the node hierarchy has a cycle or a node with two parents (glTF requires disjoint trees)",
                ));
            }
            if depth > MAX_NODE_DEPTH {
                return Err(self.error(Element::Node, i, "", format!("the node hierarchy is deeper than {MAX_NODE_DEPTH} levels")));
            }
            let local = self.local_matrix(&node)?;
            let singular = if Transform::new(local).is_none() { Some(i) } else { singular };
            let world = parent * local;
            let places = node.mesh().is_some() || node.camera().is_some() || node.light().is_some();
            if places && Transform::new(world).is_none() {
                let at = singular.unwrap_or(i);
                let what = if at == i { "its transform" } else { "the transform of its ancestor" };
                return Err(self.error(
                    Element::Node,
                    at,
                    self.transform_key(at),
                    format!("node {i} places a mesh, camera or light, but {what} is singular (a zero scale or matrix flattens it)"),
                ));
            }
            out.world[i] = Some(world);
            out.order.push(i);
            todo.extend(node.children().map(|c| (c, world, depth + 1, singular)));
        }
        Ok(out)
    }

    /// The key of node `index`'s transform, as a JSON pointer tail.
    fn transform_key(&self, index: usize) -> &'static str {
        match self.doc.nodes().nth(index).map(|n| n.transform()) {
            Some(gltf::scene::Transform::Decomposed { .. }) => "/scale",
            _ => "/matrix",
        }
    }

    /// Node `node`'s own transform; refuses non-finite values and a zero rotation quaternion
    /// (others are normalised).
    fn local_matrix(&self, node: &gltf::Node) -> Result<DAffine3> {
        let bad = |key: &str| self.error(Element::Node, node.index(), key, "a value is NaN or infinite (beyond f32)");
        let finite = |v: &[f32]| v.iter().all(|c| c.is_finite());
        match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                if !matrix.iter().all(|c| finite(c)) {
                    return Err(bad("/matrix"));
                }
                Ok(DAffine3::from_mat4(Mat4::from_cols_array_2d(&matrix).as_dmat4()))
            }
            gltf::scene::Transform::Decomposed { translation: t, rotation: r, scale: s } => {
                for (key, v) in [("/translation", &t[..]), ("/rotation", &r[..]), ("/scale", &s[..])] {
                    if !finite(v) {
                        return Err(bad(key));
                    }
                }
                let q = DQuat::from_array(r.map(f64::from));
                if q.length() < MIN_QUATERNION_LENGTH {
                    return Err(self.error(Element::Node, node.index(), "/rotation", "the rotation quaternion is zero"));
                }
                let [t, s] = [t, s].map(|v| DVec3::from(v.map(f64::from)));
                Ok(DAffine3::from_scale_rotation_translation(s, q.normalize(), t))
            }
        }
    }

    /// Refuses materials with non-finite factors (they would become NaN colours).
    fn check_materials(&self) -> Result<()> {
        for m in self.doc.materials() {
            let Some(i) = m.index() else { continue };
            let pbr = m.pbr_metallic_roughness();
            let values: [(&str, &[f32]); 7] = [
                ("/pbrMetallicRoughness/baseColorFactor", &pbr.base_color_factor()),
                ("/pbrMetallicRoughness/metallicFactor", &[pbr.metallic_factor()]),
                ("/pbrMetallicRoughness/roughnessFactor", &[pbr.roughness_factor()]),
                ("/emissiveFactor", &m.emissive_factor()),
                ("/extensions/KHR_materials_emissive_strength/emissiveStrength", &[m.emissive_strength().unwrap_or(1.0)]),
                ("/extensions/KHR_materials_ior/ior", &[m.ior().unwrap_or(1.5)]),
                ("/extensions/KHR_materials_transmission/transmissionFactor", &[m.transmission().map_or(0.0, |t| t.transmission_factor())]),
            ];
            for (key, v) in values {
                if !v.iter().all(|c| c.is_finite()) {
                    return Err(self.error(Element::Material, i, key, "a value is NaN or infinite (beyond f32)"));
                }
            }
            let emission = m.emissive_factor().map(|e| e * m.emissive_strength().unwrap_or(1.0));
            if !emission.iter().all(|c| c.is_finite()) {
                return Err(self.error(Element::Material, i, "/emissiveFactor", "emissiveFactor × emissive strength overflows"));
            }
        }
        Ok(())
    }

    /// Warns, once per kind and with a count, about what the file holds and raylab ignores.
    fn warn_ignored(&self, ctx: &LoadContext) {
        let warn = |count: usize, what: String| {
            if count > 0 {
                ctx.warn(SceneError::in_file(&self.name, None, what));
            }
        };
        let materials: Vec<gltf::Material> = self.doc.materials().collect();
        type Has = fn(&gltf::Material) -> bool;
        let n = materials.iter().filter(|m| m.occlusion_texture().is_some()).count();
        warn(
            n,
            format!("{n} material(s) use an occlusionTexture: phong's ambient term samples it; the path tracer computes occlusion itself"),
        );
        // Sampled by the `pbr` model (the path tracer); `phong` reads the factors.
        let phong_only: [(&str, Has); 2] = [
            ("metallicRoughnessTexture", |m| m.pbr_metallic_roughness().metallic_roughness_texture().is_some()),
            ("KHR_materials_transmission transmissionTexture", |m| m.transmission().is_some_and(|t| t.transmission_texture().is_some())),
        ];
        for (name, has) in phong_only {
            let n = materials.iter().filter(|m| has(m)).count();
            warn(n, format!("{n} material(s) use a {name}: the path tracer samples it, phong uses the factors"));
        }
        let prims = || self.doc.meshes().flat_map(|m| m.primitives().collect::<Vec<_>>());
        // The texture coordinate sets each material's textures read (KHR_texture_transform's
        // `texCoord` overriding the texture info's).
        let sets = |m: &gltf::Material| -> Vec<u64> {
            let pbr = m.pbr_metallic_roughness();
            [
                pbr.base_color_texture().as_ref().map(TexRef::from),
                m.emissive_texture().as_ref().map(TexRef::from),
                pbr.metallic_roughness_texture().as_ref().map(TexRef::from),
                m.transmission().and_then(|t| t.transmission_texture()).as_ref().map(TexRef::from),
                m.normal_texture().as_ref().map(TexRef::from),
                m.occlusion_texture().as_ref().map(TexRef::from),
            ]
            .iter()
            .flatten()
            .map(tex_coord_set)
            .collect()
        };
        let n = materials.iter().filter(|m| sets(m).iter().any(|&s| s > 1)).count();
        warn(n, format!("{n} material(s) sample a texture with a texture coordinate set beyond TEXCOORD_1: TEXCOORD_0 is used"));
        let n = prims().filter(|p| p.get(&gltf::Semantic::TexCoords(1)).is_none() && sets(&p.material()).contains(&1)).count();
        warn(n, format!("{n} primitive(s) have a material that samples TEXCOORD_1 but have no TEXCOORD_1: TEXCOORD_0 is used there"));
        let unsupported: Vec<String> = self.extensions().into_iter().filter(|e| !SUPPORTED.contains(&e.as_str())).collect();
        warn(unsupported.len(), format!("the file uses extensions raylab ignores: {}", unsupported.join(", ")));
        let n = prims().filter(|p| p.get(&gltf::Semantic::Colors(0)).is_some()).count();
        warn(n, format!("{n} primitive(s) have vertex colours (COLOR_0), which raylab ignores"));
        use gltf::mesh::Mode;
        let n = prims().filter(|p| !matches!(p.mode(), Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)).count();
        warn(n, format!("{n} primitive(s) are points or lines, which raylab skips"));
        let n = prims().filter(|p| p.morph_targets().len() > 0).count();
        warn(n, format!("{n} primitive(s) have morph targets: the base shape is used"));
        let n = self.doc.animations().len();
        warn(n, format!("{n} animation(s) ignored: the file is shown at rest"));
        let n = self.doc.skins().len();
        warn(n, format!("{n} skin(s) ignored: skinned meshes are shown in their bind pose"));
        let n = self.doc.scenes().len();
        warn(n.saturating_sub(1), format!("the file has {n} scenes: only its default scene is read"));
    }

    /// The names of the extensions the file uses, sorted: those `extensionsUsed` declares and
    /// those found on its elements (a file may omit some from the list).
    fn extensions(&self) -> std::collections::BTreeSet<String> {
        let mut names: std::collections::BTreeSet<String> = self.doc.extensions_used().map(String::from).collect();
        // Each element's extensions that the gltf crate does not read itself (a JSON map).
        macro_rules! add {
            ($extensions:expr) => {
                names.extend($extensions.into_iter().flat_map(|e| e.keys()).cloned())
            };
        }
        add!(self.doc.extensions());
        self.doc.nodes().for_each(|n| add!(n.extensions()));
        self.doc.cameras().for_each(|c| add!(c.extensions()));
        self.doc.images().for_each(|i| add!(i.extensions()));
        self.doc.samplers().for_each(|t| add!(t.extensions()));
        self.doc.textures().for_each(|t| add!(t.extensions()));
        self.doc.accessors().for_each(|a| add!(a.extensions()));
        self.doc.buffers().for_each(|b| add!(b.extensions()));
        for m in self.doc.meshes() {
            add!(m.extensions());
            m.primitives().for_each(|p| add!(p.extensions()));
        }
        for m in self.doc.materials() {
            add!(m.extensions());
            let pbr = m.pbr_metallic_roughness();
            add!(pbr.extensions());
            for info in [pbr.base_color_texture(), pbr.metallic_roughness_texture(), m.emissive_texture()].into_iter().flatten() {
                add!(info.extensions());
            }
        }
        names
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
            let max_elements = self.max_triangles.saturating_mul(3).min(u64::from(u32::MAX));
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
                Some(a) if a.count() == 0 => Err(err(format!("its {what} accessor has count 0 (at least 1 is required)"))),
                // Without a buffer view the reader yields `count` zeros (the sparse values over
                // them), bounded by no buffer: refused beyond what the triangle limit can use.
                Some(a) if a.view().is_none() && a.count() as u64 > max_elements => Err(err(format!(
                    "its {what} accessor has no bufferView and count {}, over the {max_elements} elements the triangle limit allows",
                    a.count()
                ))),
                Some(a) => match a.sparse() {
                    Some(sp) if sp.count() == 0 || sp.count() > a.count() => Err(err(format!(
                        "its {what} accessor's sparse count is {}; expected 1 to the accessor's count, {}",
                        sp.count(),
                        a.count()
                    ))),
                    Some(sp) if sp.indices().view().stride().is_some() || sp.values().view().stride().is_some() => {
                        Err(err(format!("its {what} accessor's sparse indices or values have a byteStride, which glTF forbids")))
                    }
                    _ => Ok(()),
                },
                None => Ok(()),
            };
            typed(prim.get(&gltf::Semantic::Positions), &[DataType::F32], Dimensions::Vec3, "POSITION")?;
            typed(prim.get(&gltf::Semantic::Normals), &[DataType::F32], Dimensions::Vec3, "NORMAL")?;
            typed(prim.get(&gltf::Semantic::TexCoords(0)), &[DataType::F32, DataType::U8, DataType::U16], Dimensions::Vec2, "TEXCOORD_0")?;
            typed(prim.get(&gltf::Semantic::TexCoords(1)), &[DataType::F32, DataType::U8, DataType::U16], Dimensions::Vec2, "TEXCOORD_1")?;
            typed(prim.indices(), &[DataType::U8, DataType::U16, DataType::U32], Dimensions::Scalar, "index")?;
            typed(prim.get(&gltf::Semantic::Tangents), &[DataType::F32], Dimensions::Vec4, "TANGENT")?;
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
            let has_normals = normals.is_some();
            let keep = has_normals && out.normal_indices.len() == out.triangles.len();
            match normals.filter(|_| keep) {
                Some(ns) => out.normals.extend(ns.iter().map(|v| (normal_m * DVec3::from(v.map(f64::from))).as_vec3().to_array())),
                None => {
                    out.normals.clear();
                    out.normal_indices.clear();
                }
            }
            // Texture coordinates (v flipped: glTF's run down from the image's top), kept only
            // if every primitive has them.
            let texcoords: Option<Vec<[f32; 2]>> = reader
                .read_tex_coords(0)
                .map(|r| r.into_f32().map(|[u, v]| [u, 1.0 - v]).collect())
                .filter(|v: &Vec<[f32; 2]>| v.len() == positions.len());
            let keep_uv = texcoords.is_some() && out.texcoord_indices.len() == out.triangles.len();
            // The second set (TEXCOORD_1), beside the first: a primitive without one repeats its
            // first set (textures asking for set 1 then read set 0, as warned).
            let texcoords1: Option<Vec<[f32; 2]>> = reader
                .read_tex_coords(1)
                .map(|r| r.into_f32().map(|[u, v]| [u, 1.0 - v]).collect())
                .filter(|v: &Vec<[f32; 2]>| v.len() == positions.len());
            match texcoords.filter(|_| keep_uv) {
                Some(uv) => {
                    out.texcoords1.extend(texcoords1.as_deref().unwrap_or(&uv));
                    out.texcoords.extend(uv);
                }
                None => {
                    out.texcoords.clear();
                    out.texcoords1.clear();
                    out.texcoord_indices.clear();
                }
            }
            let material = prim.material().index().map_or(default_material, |i| i as u32);
            let tris: Vec<[u32; 3]> = tris.into_iter().map(|t| if flip { [t[0], t[2], t[1]] } else { t }).collect();
            // Corner tangents, for a normal-mapped material only: the file's TANGENTs (with the
            // vertex normals they belong to), else MikkTSpace's from the placed vertices.
            if prim.material().normal_texture().is_some() {
                let first = out.tangents.is_empty();
                let file = reader
                    .read_tangents()
                    .map(|r| r.collect::<Vec<[f32; 4]>>())
                    .filter(|t| t.len() == positions.len() && has_normals && t.iter().flatten().all(|c| c.is_finite()));
                let corners: Vec<[[f32; 4]; 3]> = match file {
                    Some(ts) => {
                        let l = DMat3::from_mat4(m);
                        let placed = |[x, y, z, w]: [f32; 4]| {
                            let v = (l * DVec3::new(f64::from(x), f64::from(y), f64::from(z))).as_vec3();
                            [v.x, v.y, v.z, if flip { -w } else { w }]
                        };
                        tris.iter().map(|t| t.map(|v| placed(ts[v as usize]))).collect()
                    }
                    None => {
                        // Along the set the normal texture reads.
                        let set = prim.material().normal_texture().map_or(0, |n| tex_coord_set(&TexRef::from(&n)));
                        let uv = uv_of(out, base, keep_uv, set == 1 && texcoords1.is_some());
                        mikk_tangents(&out.positions[base as usize..], normals_placed(out, base, keep), uv, &tris)
                    }
                };
                if first {
                    out.tangents.resize(out.triangles.len(), [[0.0; 4]; 3]);
                }
                out.tangents.extend(corners);
            } else if !out.tangents.is_empty() {
                out.tangents.extend(std::iter::repeat_n([[0.0; 4]; 3], tris.len()));
            }
            for t in tris {
                out.triangles.push(t.map(|v| base + v));
                if keep {
                    out.normal_indices.push(t.map(|v| base + v));
                }
                if keep_uv {
                    out.texcoord_indices.push(t.map(|v| base + v));
                }
                out.material_ids.push(material);
            }
        }
        Ok(())
    }

    /// The box around the default scene's vertices (from the POSITION accessors' min and max).
    fn scene_bounds(&self) -> Result<Aabb> {
        let placed = self.placements()?;
        let mut b = Aabb::EMPTY;
        for &i in &placed.order {
            let (Some(mesh), Some(world)) = (self.doc.nodes().nth(i).and_then(|n| n.mesh()), placed.world[i]) else { continue };
            for prim in mesh.primitives() {
                let Some(a) = prim.get(&gltf::Semantic::Positions) else { continue };
                let corner = |v: Option<gltf::json::Value>| -> Option<DVec3> {
                    let v: Vec<f64> = v?.as_array()?.iter().map(|c| c.as_f64().map(|c| c as f32 as f64)).collect::<Option<_>>()?;
                    (v.len() == 3 && v.iter().all(|c| c.is_finite())).then(|| DVec3::new(v[0], v[1], v[2]))
                };
                let (Some(lo), Some(hi)) = (corner(a.min()), corner(a.max())) else {
                    return Err(SceneError::in_file(
                        &self.name,
                        None,
                        format!("/accessors/{}: a POSITION accessor needs finite `min` and `max` (3 numbers each)", a.index()),
                    ));
                };
                for k in 0..8 {
                    let c = DVec3::new(
                        if k & 1 == 0 { lo.x } else { hi.x },
                        if k & 2 == 0 { lo.y } else { hi.y },
                        if k & 4 == 0 { lo.z } else { hi.z },
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

/// The vertex normals `out` holds from vertex `base` on (the primitive just appended), if it
/// keeps them.
fn normals_placed(out: &MeshData, base: u32, keep: bool) -> Option<&[[f32; 3]]> {
    keep.then(|| out.normals.get(base as usize..)).flatten()
}

/// The texture coordinates `out` holds from vertex `base` on (the second set if `second`), if
/// it keeps them.
fn uv_of(out: &MeshData, base: u32, keep: bool, second: bool) -> Option<&[[f32; 2]]> {
    keep.then(|| if second { &out.texcoords1 } else { &out.texcoords }.get(base as usize..)).flatten()
}

/// The texture coordinate set a texture reference reads: its `KHR_texture_transform`'s
/// `texCoord` where it has one (the extension's override), else its own `texCoord`.
fn tex_coord_set(info: &TexRef) -> u64 {
    UvTransform::of(info).ok().flatten().and_then(|t| t.tex_coord).unwrap_or(u64::from(info.tex_coord))
}

/// MikkTSpace tangents (Mikkelsen 2008, the `mikktspace` crate: what glTF asks for when a
/// normal-mapped primitive has no `TANGENT`s) of triangles `tris` over `positions`, `normals`
/// (the triangle's own normal where there are none) and texture coordinates `uv` (raylab's, v up:
/// the bitangent then runs up the image, as a normal map's green channel does); zero (none)
/// without texture coordinates or where the algorithm fails.
fn mikk_tangents(positions: &[[f32; 3]], normals: Option<&[[f32; 3]]>, uv: Option<&[[f32; 2]]>, tris: &[[u32; 3]]) -> Vec<[[f32; 4]; 3]> {
    struct Faces<'a> {
        positions: &'a [[f32; 3]],
        normals: Option<&'a [[f32; 3]]>,
        uv: &'a [[f32; 2]],
        tris: &'a [[u32; 3]],
        out: Vec<[[f32; 4]; 3]>,
    }
    impl mikktspace::Geometry for Faces<'_> {
        fn num_faces(&self) -> usize {
            self.tris.len()
        }
        fn num_vertices_of_face(&self, _: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.positions[self.tris[face][vert] as usize]
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            match self.normals {
                Some(n) => n[self.tris[face][vert] as usize],
                None => {
                    let [a, b, c] = self.tris[face].map(|v| Vec3::from(self.positions[v as usize]));
                    (b - a).cross(c - a).normalize_or_zero().to_array()
                }
            }
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.uv[self.tris[face][vert] as usize]
        }
        fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
            self.out[face][vert] = tangent;
        }
    }
    let none = vec![[[0.0; 4]; 3]; tris.len()];
    let Some(uv) = uv else { return none };
    let mut faces = Faces { positions, normals, uv, tris, out: none };
    if !mikktspace::generate_tangents(&mut faces) {
        return vec![[[0.0; 4]; 3]; tris.len()];
    }
    faces.out.iter_mut().flatten().for_each(|t| {
        if !t.iter().all(|c| c.is_finite()) {
            *t = [0.0; 4];
        }
    });
    faces.out
}

/// The lookup of a `KHR_texture_transform` (`offset`, `rotation` in radians, `scale`) in
/// raylab's texture coordinates: the extension's `T·R·S` acts on glTF's coordinates, whose `v`
/// runs down, so it is conjugated by the flip `v ↦ 1 − v`.
pub fn gltf_uv_transform(offset: [f64; 2], rotation: f64, scale: [f64; 2]) -> DAffine3 {
    let (s, c) = rotation.sin_cos();
    let m = raylab::glam::DMat3::from_cols(DVec3::new(c, s, 0.0), DVec3::new(-s, c, 0.0), DVec3::Z);
    let gltf = DAffine3::from_translation(DVec3::new(offset[0], offset[1], 0.0))
        * DAffine3::from_mat3(m)
        * DAffine3::from_scale(DVec3::new(scale[0], scale[1], 1.0));
    let flip = DAffine3::from_translation(DVec3::Y) * DAffine3::from_scale(DVec3::new(1.0, -1.0, 1.0));
    flip * gltf * flip
}

pub use crate::materials::pbr::{MAX_SHININESS, MIN_SHININESS, phong_mapping as pbr_to_phong};

fn default_gltf_material() -> Material {
    let mut m = pbr_to_phong([1.0, 1.0, 1.0, 1.0], 1.0, 1.0, None, None, [0.0; 3]);
    m.model = Some(Model(Arc::new(Pbr::default())));
    m
}

/// A glTF material as a raylab material: the Phong coefficients of the module's table, with the
/// `pbr` model of its factors (textures are attached when a mesh samples them).
pub fn material(m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let transmission = m.transmission().map(|t| t.transmission_factor());
    let emissive = m.emissive_factor().map(|e| e * m.emissive_strength().unwrap_or(1.0));
    let mut out = pbr_to_phong(pbr.base_color_factor(), pbr.metallic_factor(), pbr.roughness_factor(), transmission, m.ior(), emissive);
    out.model = Some(Model(Arc::new(pbr_model(m, &mut |_, _, _| None))));
    out.cutout = cutout(m, None);
    out
}

/// Where glTF material `m` is cut away: `alphaMode` MASK (coverage ≥ `alphaCutoff`, 0.5 by
/// default) or BLEND (stochastic transparency), coverage being the base colour factor's alpha
/// times `alpha_texture` (the base colour texture's alpha). `None` for OPAQUE, and where
/// nothing is cut away.
fn cutout(m: &gltf::Material, alpha_texture: Option<Arc<dyn Texture>>) -> Option<Cutout> {
    let alpha = f64::from(m.pbr_metallic_roughness().base_color_factor()[3]);
    let mode = match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => return None,
        gltf::material::AlphaMode::Mask => {
            let cutoff = m.alpha_cutoff().unwrap_or(0.5);
            AlphaMode::Mask { cutoff: if cutoff.is_finite() { f64::from(cutoff) } else { 0.5 } }
        }
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
    };
    Cutout::new(alpha, alpha_texture, mode)
}

/// glTF's `occlusionTexture` as phong's ambient response: `1 + strength·(r − 1)`, `r` the
/// texture's red channel (linear).
#[derive(Debug)]
struct Occlusion {
    texture: Arc<dyn Texture>,
    strength: f64,
}

impl Texture for Occlusion {
    fn eval(&self, at: &raylab::scene::texture::TexturePoint) -> Color {
        let r = self.texture.eval(at).x;
        Color::splat((1.0 + self.strength * (r - 1.0)).max(0.0))
    }
}

/// Which colours a glTF texture holds: sRGB-encoded colours or linear data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Slot {
    /// `baseColorTexture`, `emissiveTexture`: sRGB.
    Color,
    /// `metallicRoughnessTexture`, `transmissionTexture`: linear.
    Data,
    /// The base colour texture's alpha: coverage of a cut-out.
    Alpha,
}

/// What builds the texture of a material's texture info (`None`: unreadable, or not wanted).
type TextureOf<'a> = dyn FnMut(&TexRef, &str, Slot) -> Option<Arc<dyn Texture>> + 'a;

/// The `pbr` model of glTF material `m` (factors clamped to their ranges), its textures from
/// `texture` (`None`: the factor alone).
fn pbr_model(m: &gltf::Material, texture: &mut TextureOf) -> Pbr {
    let unit = |v: f32| if v.is_finite() { f64::from(v).clamp(0.0, 1.0) } else { 0.0 };
    let pbr = m.pbr_metallic_roughness();
    let b = pbr.base_color_factor();
    let emissive = m.emissive_factor().map(|e| e * m.emissive_strength().unwrap_or(1.0));
    let emission = Color::new(f64::from(emissive[0]), f64::from(emissive[1]), f64::from(emissive[2])).max(Color::ZERO);
    let specular = m.specular();
    let sc = specular.as_ref().map_or([1.0; 3], |s| s.specular_color_factor());
    Pbr {
        base_color: Textured {
            value: Color::new(unit(b[0]), unit(b[1]), unit(b[2])),
            texture: pbr.base_color_texture().and_then(|i| texture(&TexRef::from(&i), "baseColorTexture", Slot::Color)),
        },
        metallic: unit(pbr.metallic_factor()),
        roughness: unit(pbr.roughness_factor()),
        metallic_roughness: pbr
            .metallic_roughness_texture()
            .and_then(|i| texture(&TexRef::from(&i), "metallicRoughnessTexture", Slot::Data)),
        ior: m.ior().filter(|i| i.is_finite() && *i >= 1.0).map_or(1.5, f64::from),
        specular: specular.as_ref().map_or(1.0, |s| unit(s.specular_factor())),
        specular_color: Color::new(f64::from(sc[0]), f64::from(sc[1]), f64::from(sc[2])).max(Color::ZERO),
        transmission: match m.transmission() {
            Some(t) => Textured {
                value: unit(t.transmission_factor()),
                texture: t.transmission_texture().and_then(|i| texture(&TexRef::from(&i), "transmissionTexture", Slot::Data)),
            },
            None => Textured::constant(0.0),
        },
        emission: Textured {
            value: emission,
            texture: m.emissive_texture().and_then(|i| texture(&TexRef::from(&i), "emissiveTexture", Slot::Color)),
        },
    }
}

/// Reads a glTF file as a whole scene (the registered scene format for `.gltf` and `.glb`).
pub fn read_scene(path: &Path, _bytes: &[u8], ctx: &LoadContext) -> Result<SceneDescription> {
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let src = Source::new(path.display().to_string(), String::new());
    let file = open(ctx, &file_name, &Loc::new(&src, 0..0))?;
    let stem = path.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    scene_description(&file, &file_name, stem, ctx)
}

/// The sides a mesh's emission leaves, from its emissive materials' `doubleSided`: `"front"`
/// when every emissive material of its primitives is single-sided (glTF's default: a
/// single-sided surface is not seen from behind, so it sends no light there), `None` (raylab's
/// default, both sides) when any of them is double-sided or nothing emits. The front is the side
/// of the triangles' counter-clockwise winding, as glTF's.
fn emission_sides(mesh: &gltf::Mesh) -> Option<&'static str> {
    let emissive: Vec<bool> = mesh
        .primitives()
        .map(|p| p.material())
        .filter(|m| m.emissive_factor().iter().any(|&e| e > 0.0) && m.emissive_strength().unwrap_or(1.0) > 0.0)
        .map(|m| m.double_sided())
        .collect();
    (!emissive.is_empty() && !emissive.iter().any(|&double| double)).then_some("front")
}

/// Builds located scene values (each at the glTF element it comes from).
struct Located<'a>(&'a Loc);

impl Located<'_> {
    fn node(&self, value: Value) -> Node {
        Node { value, loc: self.0.clone() }
    }
    fn float(&self, v: f64) -> Node {
        self.node(Value::Float(v))
    }
    fn vec3(&self, v: DVec3) -> Node {
        self.node(Value::Array(v.to_array().into_iter().map(|c| self.float(c)).collect()))
    }
    fn str(&self, s: &str) -> Node {
        self.node(Value::Str(s.to_string()))
    }
    fn table(&self, entries: Vec<(&str, Node)>) -> Node {
        let entries = entries.into_iter().map(|(key, value)| Entry { key: key.to_string(), key_loc: self.0.clone(), value }).collect();
        self.node(Value::Table(Table { entries }))
    }
}

/// Estimated bytes of one mesh instance's table in a glTF scene's description (its located
/// `type`, `file` and `node` entries), charged to [`raylab::param::limits::Limits::max_memory`] before
/// the description is built; each instance is charged again as an object when it is built.
pub const INSTANCE_DESCRIPTION_BYTES: u64 = 1536;

/// The raylab scene `file` (named `file_name` in its folder) describes, built without an
/// intermediate text: one `mesh` object per node with a mesh (naming the node, so a mesh placed
/// many times is decoded and indexed once), the camera and the lights. The instances' triangles
/// (each instance counting at least one) are checked against `--max-triangles` first.
pub fn scene_description(file: &GltfFile, file_name: &str, name: String, ctx: &LoadContext) -> Result<SceneDescription> {
    let placed = file.placements()?;
    let nodes: Vec<gltf::Node> = file.doc.nodes().collect();
    let mut per_mesh: Vec<Option<u64>> = vec![None; file.doc.meshes().len()];
    let (mut instances, mut total) = (0u64, 0u64);
    for &i in &placed.order {
        if let Some(m) = nodes[i].mesh() {
            instances += 1;
            total = total.saturating_add((*per_mesh[m.index()].get_or_insert_with(|| triangle_count(&m))).max(1));
        }
    }
    if instances == 0 {
        return Err(SceneError::in_file(&file.name, None, "the file's scene has no meshes"));
    }
    if total > file.max_triangles {
        return Err(SceneError::in_file(
            &file.name,
            None,
            format!("its scene places {instances} mesh instances holding {total} triangles, over the limit of {}", file.max_triangles),
        )
        .with_help("raise the limit with --max-triangles"));
    }
    ctx.charge(
        instances.saturating_mul(INSTANCE_DESCRIPTION_BYTES),
        &format!("the description of the {instances} mesh instances of its scene"),
        None,
    )
    .map_err(|mut e| {
        e.location = raylab::param::error::Location::File { path: file.name.clone(), line_col: None };
        e
    })?;
    let doc = Loc::new(&file.json, 0..0);
    let at = Located(&doc);
    let mut root: Vec<(&str, Node)> = vec![("background", at.vec3(DVec3::splat(0.1)))];

    // Camera: the first perspective camera, or one fitted to the bounds.
    let cameras: Vec<(usize, gltf::Camera)> = placed.order.iter().filter_map(|&i| Some((i, nodes[i].camera()?))).collect();
    let camera = cameras.iter().find_map(|(i, c)| match c.projection() {
        gltf::camera::Projection::Perspective(p) => Some((*i, c.index(), p)),
        gltf::camera::Projection::Orthographic(_) => None,
    });
    let ignored = cameras.len() - usize::from(camera.is_some());
    if ignored > 0 {
        ctx.warn(SceneError::in_file(
            &file.name,
            None,
            format!("{ignored} camera(s) ignored: the first perspective camera is used (orthographic ones are not supported)"),
        ));
    }
    let (mut width, mut height) = (800, 600);
    let camera_table = match camera {
        Some((node, c, p)) => {
            let yfov = p.yfov();
            if !(yfov.is_finite() && yfov > 0.0 && f64::from(yfov) < std::f64::consts::PI) {
                return Err(file.error(Element::Camera, c, "/perspective/yfov", format!("the field of view {yfov} rad is outside (0, π)")));
            }
            if let Some(a) = p.aspect_ratio() {
                if !(a.is_finite() && a > 0.0) {
                    return Err(file.error(Element::Camera, c, "/perspective/aspectRatio", format!("{a} is not a positive number")));
                }
                height = ((800.0 / f64::from(a)).round() as u32).clamp(1, 800 * 100);
                if !(0.01..=100.0).contains(&a) {
                    width = 800;
                    height = 600;
                    ctx.warn(file.error(
                        Element::Camera,
                        c,
                        "/perspective/aspectRatio",
                        format!("{a} is out of 0.01..=100: 800×600 is used"),
                    ));
                }
            }
            let w = placed.world[node].unwrap_or_default();
            let pos = w.transform_point3(DVec3::ZERO);
            let fwd = w.transform_vector3(-DVec3::Z).try_normalize().unwrap_or(-DVec3::Z);
            let up = w.transform_vector3(DVec3::Y).try_normalize().unwrap_or(DVec3::Y);
            let (node_loc, cam_loc) = (file.loc(Element::Node, node), file.loc(Element::Camera, c));
            let (n, cl) = (Located(&node_loc), Located(&cam_loc));
            n.table(vec![
                ("position", n.vec3(pos)),
                ("look_at", n.vec3(pos + fwd)),
                ("up", n.vec3(up)),
                ("fov", cl.float(f64::from(yfov).to_degrees())),
            ])
        }
        None => {
            let bounds = file.scene_bounds()?;
            let (center, radius) = (bounds.center(), (bounds.extent().length() * 0.5).max(1e-6));
            let dir = DVec3::new(0.35, 0.3, 1.0).normalize();
            let dist = radius / (20f64.to_radians()).sin() * 1.1;
            at.table(vec![("position", at.vec3(center + dir * dist)), ("look_at", at.vec3(center)), ("fov", at.float(40.0))])
        }
    };
    root.push(("render", super::model_scene::render(&super::model_scene::At(&doc), width, height.into())));
    root.push(("camera", camera_table));

    // Objects: one per node with a mesh; emitting from the front only where glTF says so.
    let mut objects = Vec::with_capacity(instances as usize);
    for &i in &placed.order {
        if let Some(mesh) = nodes[i].mesh() {
            let loc = file.loc(Element::Node, i);
            let n = Located(&loc);
            let mut t = vec![("type", n.str("mesh")), ("file", n.str(file_name)), ("node", n.node(Value::Int(i as i64)))];
            if let Some(sides) = emission_sides(&mesh) {
                t.push(("emission_sides", n.str(sides)));
            }
            objects.push(n.table(t));
        }
    }
    root.push(("object", at.node(Value::Array(objects))));

    // Lights.
    let mut lights = Vec::new();
    for &i in &placed.order {
        let Some(light) = nodes[i].light() else { continue };
        let l = light.index();
        let bad = |key: &str, what: &str| file.error(Element::Light, l, key, what);
        let (rgb, intensity) = (light.color(), light.intensity());
        if !rgb.iter().all(|c| c.is_finite() && *c >= 0.0) {
            return Err(bad("/color", "expected finite numbers ≥ 0"));
        }
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(bad("/intensity", "expected a finite number ≥ 0"));
        }
        let color = DVec3::from(rgb.map(f64::from)) * f64::from(intensity);
        let world = placed.world[i].unwrap_or_default();
        let pos = world.transform_point3(DVec3::ZERO);
        let dir = world.transform_vector3(-DVec3::Z).try_normalize().unwrap_or(-DVec3::Z);
        let loc = file.loc(Element::Light, l);
        let n = Located(&loc);
        let label = format!("{} #{i}", nodes[i].name().or(light.name()).unwrap_or("light"));
        let mut t = vec![("name", n.str(&label)), ("color", n.vec3(color))];
        match light.kind() {
            gltf::khr_lights_punctual::Kind::Directional => {
                t.extend([("type", n.str("directional")), ("direction", n.vec3(dir))]);
            }
            gltf::khr_lights_punctual::Kind::Point => {
                t.extend([("type", n.str("point")), ("position", n.vec3(pos)), ("kc", n.float(0.0)), ("kq", n.float(1.0))]);
            }
            gltf::khr_lights_punctual::Kind::Spot { outer_cone_angle, .. } => {
                if !outer_cone_angle.is_finite() {
                    return Err(bad("/spot/outerConeAngle", "expected a finite angle"));
                }
                let cone = f64::from(outer_cone_angle).to_degrees().clamp(0.1, 90.0);
                t.extend([
                    ("type", n.str("spot")),
                    ("position", n.vec3(pos)),
                    ("direction", n.vec3(dir)),
                    ("cone_angle", n.float(cone)),
                    ("exponent", n.float(1.0)),
                    ("kc", n.float(0.0)),
                    ("kq", n.float(1.0)),
                ]);
            }
        }
        lights.push(n.table(t));
    }
    if lights.is_empty() {
        // The file has no KHR_lights_punctual lights: a sun and an ambient term.
        lights = super::model_scene::default_lights(&super::model_scene::At(&doc), &file.name, ctx);
    }
    root.push(("light", at.node(Value::Array(lights))));
    let Value::Table(root) = at.table(root).value else { unreachable!("built as a table") };
    Ok(SceneDescription { name, root, loc: doc })
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
        let gold = pbr_to_phong([1.0, 0.8, 0.3, 1.0], 1.0, 0.0, None, None, [0.0; 3]);
        assert_eq!(gold.kd, Color::ZERO);
        assert!(gold.kr.x > 0.9 && gold.blur < 0.01 && gold.shininess >= 1e3);
        let plastic = pbr_to_phong([0.2, 0.4, 0.8, 1.0], 0.0, 0.5, None, None, [0.0; 3]);
        assert_eq!(plastic.kr, Color::ZERO);
        assert!((plastic.kd - Color::new(0.2, 0.4, 0.8)).length() < 1e-6 && (plastic.ks.x - 0.04 * 8.5 / 2.0).abs() < 1e-9);
        assert!((plastic.shininess - 7.5).abs() < 1e-9);
        let glass = pbr_to_phong([1.0; 4], 0.0, 0.0, Some(1.0), Some(1.33), [0.0; 3]);
        assert_eq!((glass.kt, glass.ior), (Color::ONE, 1.33f32 as f64));
    }

    /// The specular reflectance a viewer sees, `2·ks / (n + 1)`, is `F0` at every roughness, and
    /// the exponent never drops below 1, where the lobe would end in a step.
    #[test]
    fn the_highlight_keeps_its_reflectance_and_never_ends_in_a_step() {
        for r in [0.0, 0.1, 0.3, 0.5, 0.7, 0.9, 1.0] {
            let plastic = pbr_to_phong([0.8, 0.2, 0.1, 1.0], 0.0, r, None, None, [0.0; 3]);
            assert!(plastic.shininess >= MIN_SHININESS, "roughness {r}: exponent {}", plastic.shininess);
            let reflectance = 2.0 * plastic.ks / (plastic.shininess + 1.0);
            assert!((reflectance - Color::splat(0.04)).abs().max_element() < 1e-9, "roughness {r}: {reflectance}");
        }
        let rough = pbr_to_phong([1.0; 4], 0.0, 1.0, None, None, [0.0; 3]);
        assert_eq!(rough.shininess, MIN_SHININESS);
    }

    /// One triangle as a data URI (vertices (0,0,0), (1,0,0), (0,1,0)).
    const TRIANGLE: &str = r#""meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]"#;

    /// A glTF document with the one-triangle mesh, `nodes` (a JSON list) in scene 0, and `extra`
    /// top-level members.
    fn doc(nodes: &str, extra: &str) -> String {
        let count = element_spans(format!("{{\"n\":{nodes}}}").as_bytes(), &["n"]).len();
        let roots: Vec<String> = (0..count).map(|i| i.to_string()).collect();
        format!(
            "{{\"asset\":{{\"version\":\"2.0\"}},\"scene\":0,\"scenes\":[{{\"nodes\":[{}]}}],\n\"nodes\":{nodes},\n{TRIANGLE}{extra}}}",
            roots.join(",")
        )
    }

    /// Writes `text` as `name` in a fresh temporary folder and loads it as a scene.
    fn load_scene(name: &str, text: &str, limits: raylab::param::limits::Limits) -> (Result<raylab::RenderJob>, std::path::PathBuf) {
        let dir = std::env::temp_dir().join(format!("raylab-gltf-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let options = raylab::LoadOptions { limits, ..raylab::LoadOptions::default() };
        let job = raylab::load::loader::load_file(&crate::registry(), &path, &options);
        let _ = std::fs::remove_dir_all(&dir);
        (job, path)
    }

    #[test]
    fn element_spans_follow_the_json() {
        let text = br#"{"a": {"b": [1, {"c": "x]\"y"}, [2, [3]] ]}, "nodes": []}"#;
        let spans = element_spans(text, &["a", "b"]);
        let got: Vec<&str> = spans.iter().map(|r| std::str::from_utf8(&text[r.clone()]).unwrap()).collect();
        assert_eq!(got, ["1", r#"{"c": "x]\"y"}"#, "[2, [3]]"]);
        assert!(element_spans(text, &["nodes"]).is_empty());
        assert!(element_spans(text, &["missing"]).is_empty());
        assert!(element_spans(b"{\"a\": [1, 2", &["a"]).len() <= 2);
    }

    /// 3·10⁵ nodes placing one triangle: the scene is built without a text round trip, the mesh
    /// is decoded and indexed once and shared, and the instances count against --max-triangles.
    #[test]
    fn many_nodes_instancing_one_triangle_share_it() {
        const N: usize = 300_000;
        let nodes: Vec<String> = (0..N).map(|i| format!("{{\"mesh\":0,\"translation\":[{},{},0]}}", i % 1000, i / 1000)).collect();
        let text = doc(&format!("[{}]", nodes.join(",")), "");
        let (job, _) = load_scene("many.gltf", &text, raylab::param::limits::Limits::default());
        let job = job.unwrap();
        assert_eq!(job.scene.objects.len(), N);
        let builds = job.scene.accel_summary().object_builds;
        assert!(builds.primitives <= 1, "the triangle was indexed {} times", builds.primitives);
        let limits = raylab::param::limits::Limits { max_triangles: N as u64 - 1, ..raylab::param::limits::Limits::default() };
        let e = load_scene("many.gltf", &text, limits).0.err().unwrap();
        assert!(
            e.message.contains(&format!("{N} mesh instances")) && e.help.as_deref().is_some_and(|h| h.contains("--max-triangles")),
            "{e}"
        );
    }

    /// Errors in a glTF rendered as a scene name the element (JSON pointer) at its line in the
    /// glTF, never a generated text; non-finite values are refused.
    #[test]
    fn scene_errors_point_into_the_gltf() {
        let zero = "[{\"mesh\":0},\n{\"mesh\":0,\"matrix\":[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0]}]";
        let huge = "[{\"mesh\":0,\"translation\":[0,1e39,0]}]";
        let lights = r#","extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","intensity":-1}]}}"#;
        let cases = [
            (doc(zero, ""), "/nodes/1/matrix: node 1 places a mesh, camera or light, but its transform is singular", 3),
            (doc(huge, ""), "/nodes/0/translation: a value is NaN or infinite", 2),
            (
                doc(
                    "[{\"mesh\":0},{\"camera\":0}]",
                    ",\n\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0,\"znear\":0.1}}]",
                ),
                "/cameras/0/perspective/yfov: the field of view 0 rad is outside (0, π)",
                7,
            ),
            (doc("[{\"mesh\":0},{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}]", lights), "lights/0/intensity: expected", 6),
            (
                doc("[{\"mesh\":0}]", ",\n\"materials\":[{\"emissiveFactor\":[1e39,0,0]}]"),
                "/materials/0/emissiveFactor: a value is NaN or infinite",
                7,
            ),
        ];
        for (i, (text, want, line)) in cases.iter().enumerate() {
            let (job, path) = load_scene(&format!("bad{i}.gltf"), text, raylab::param::limits::Limits::default());
            let e = job.err().unwrap_or_else(|| panic!("case {i} loaded"));
            assert!(e.message.contains(want), "case {i}: {}", e.report());
            let at = e.where_().unwrap();
            assert!(at.starts_with(&format!("{}:{line}:", path.display())), "case {i}: {at}: {}", e.report());
            assert!(!e.report().contains("raylab scene"), "{}", e.report());
        }
    }

    /// Textures, lines and unsupported extensions are reported once per kind, with a count.
    #[test]
    fn ignored_features_warn_once_per_kind() {
        let extra = r#",
"materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}},"occlusionTexture":{"index":0}},{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}},"occlusionTexture":{"index":0}}],
"textures":[{"source":0}],"images":[{"uri":"missing.png"}],
"extensionsUsed":["KHR_materials_clearcoat","KHR_lights_punctual"]"#;
        let text = doc("[{\"mesh\":0},{\"mesh\":1}]", extra).replacen(
            r#""meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]"#,
            r#""meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]},{"primitives":[{"attributes":{"POSITION":0},"mode":1},{"attributes":{"POSITION":0},"mode":0},{"attributes":{"POSITION":0},"material":1}]}]"#,
            1,
        );
        let job = load_scene("textured.gltf", &text, raylab::param::limits::Limits::default()).0.unwrap();
        let w: Vec<String> = job.warnings.iter().map(|w| w.message.clone()).collect();
        let has = |s: &str| w.iter().filter(|m| m.contains(s)).count();
        assert_eq!(has("2 material(s) use an occlusionTexture"), 1, "{w:?}");
        // The texture both materials sample cannot be read: one warning, naming it.
        let unread: Vec<String> =
            job.warnings.iter().map(|w| w.report()).filter(|r| r.contains("baseColorTexture is not sampled")).collect();
        assert_eq!(unread.len(), 1, "{w:?}");
        assert!(unread[0].contains("missing.png"), "{}", unread[0]);
        assert_eq!(has("2 primitive(s) are points or lines"), 1, "{w:?}");
        assert_eq!(has("ignores: KHR_materials_clearcoat"), 1, "{w:?}");
        assert_eq!(has("KHR_lights_punctual"), 0, "{w:?}");
    }

    /// The Khronos textured box samples its logo, from the PNG beside the .gltf and from the
    /// .glb's own buffer alike, without a warning about them: sky blue at the image's top, green below.
    #[test]
    fn the_textured_box_samples_its_logo() {
        use raylab::scene::texture::TexturePoint;
        let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/assets");
        for file in ["BoxTextured.gltf", "BoxTextured.glb"] {
            let options = raylab::LoadOptions::default();
            let job = raylab::load::loader::load_file(&crate::registry(), &assets.join(file), &options).unwrap();
            // The one warning: it has no lights of its own (the default rig lights it).
            let warnings: Vec<_> = job.warnings.iter().filter(|w| !w.message.contains("has no lights")).collect();
            assert!(warnings.is_empty(), "{file}: {warnings:?}");
            let m = &job.scene.objects[0].materials()[0];
            assert_eq!(m.textures.len(), 1, "{file}: the base colour (a dielectric: kd only)");
            assert_eq!(m.textures[0].channel, Channel::Kd);
            let at = |u, v| m.textures[0].texture.eval(&TexturePoint::new(raylab::glam::DVec2::new(u, v), DVec3::ZERO));
            let (sky, hill) = (at(0.5, 0.9), at(0.5, 0.15));
            assert!(sky.z > sky.x && sky.z > sky.y, "{file}: {sky}");
            assert!(hill.y > hill.x && hill.y > hill.z, "{file}: {hill}");
        }
    }

    /// `KHR_texture_transform` acts on glTF's texture coordinates (v down): an offset of half the
    /// image in u moves the lookup by half; a quarter turn maps u onto v.
    #[test]
    fn texture_transforms_act_in_gltf_coordinates() {
        let at = |m: DAffine3, u: f64, v: f64| m.transform_point3(DVec3::new(u, v, 0.0));
        let close = |a: DVec3, b: DVec3| assert!((a - b).length() < 1e-6, "{a} vs {b}");
        close(at(gltf_uv_transform([0.5, 0.0], 0.0, [1.0, 1.0]), 0.1, 0.3), DVec3::new(0.6, 0.3, 0.0));
        // glTF (u, v) = (0.1, 0.7) scaled by 2 in v: (0.1, 1.4); in raylab's v-up terms
        // (0.1, 0.3) → (0.1, −0.4).
        close(at(gltf_uv_transform([0.0, 0.0], 0.0, [1.0, 2.0]), 0.1, 0.3), DVec3::new(0.1, -0.4, 0.0));
        // A quarter turn: glTF (u, v) ↦ (u cos − v sin, u sin + v cos) = (−v, u).
        let q = gltf_uv_transform([0.0, 0.0], std::f64::consts::FRAC_PI_2, [1.0, 1.0]);
        close(at(q, 0.2, 1.0 - 0.6), DVec3::new(-0.6, 1.0 - 0.2, 0.0));
    }

    /// glTF's `doubleSided` decides the sides an emissive mesh gives light from: a single-sided
    /// emissive material (the default) emits from its front only, a double-sided one from both.
    #[test]
    fn emission_follows_double_sided() {
        use raylab::scene::object::EmissionSides;
        let with_material = |material: &str| {
            doc(r#"[{"mesh":0}]"#, &format!(",\n\"materials\":[{material}]"))
                .replace(r#"{"attributes":{"POSITION":0}}"#, r#"{"attributes":{"POSITION":0},"material":0}"#)
        };
        let sides = |material: &str| {
            let (job, _) = load_scene("e.gltf", &with_material(material), raylab::param::limits::Limits::default());
            job.unwrap_or_else(|e| panic!("{}", e.report())).scene.objects[0].emission_sides()
        };
        assert_eq!(sides(r#"{"emissiveFactor":[1,1,1]}"#), EmissionSides::Front);
        assert_eq!(sides(r#"{"emissiveFactor":[1,1,1],"doubleSided":true}"#), EmissionSides::Both);
        assert_eq!(sides(r#"{"emissiveFactor":[0,0,0]}"#), EmissionSides::Both);
    }

    /// Standard base64 (for `data:` URIs in test documents).
    fn base64(bytes: &[u8]) -> String {
        const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut out = String::new();
        for c in bytes.chunks(3) {
            let n = c.iter().enumerate().fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
            for i in 0..4 {
                out.push(if i <= c.len() { ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char } else { '=' });
            }
        }
        out
    }

    /// Reads glTF `text` as one mesh, with the warnings the read gave.
    fn read_mesh(text: &str) -> (Result<MeshData>, Vec<String>) {
        let options = raylab::LoadOptions::default();
        let ctx = LoadContext::new(Path::new("."), &options);
        let src = Source::new("t.gltf", String::new());
        let mesh = parse(&ctx, "t.gltf", Path::new("t.gltf"), text.as_bytes().to_vec(), &Loc::new(&src, 0..0)).and_then(|f| f.whole(&ctx));
        (mesh, ctx.take_warnings().iter().map(|w| w.message.clone()).collect())
    }

    /// `occlusionTexture` darkens phong's ambient response by its strength, over its own
    /// `KHR_texture_transform`, and says (once) that the path tracer does not read it.
    #[test]
    fn occlusion_textures_scale_the_ambient_response() {
        use image::ImageEncoder;
        // A 2 × 1 grey image: occlusion 0.2 on the left, 1 on the right (linear data).
        let mut png = Vec::new();
        image::codecs::png::PngEncoder::new(&mut png).write_image(&[51, 255], 2, 1, image::ExtendedColorType::L8).unwrap();
        let extra = format!(
            r#",
"materials":[{{"occlusionTexture":{{"index":0,"strength":0.5,"extensions":{{"KHR_texture_transform":{{"offset":[0.5,0]}}}}}}}}],
"textures":[{{"source":0,"sampler":0}}],"samplers":[{{"magFilter":9728}}],"images":[{{"uri":"data:image/png;base64,{}"}}]"#,
            base64(&png)
        );
        let text =
            doc("[{\"mesh\":0}]", &extra).replacen(r#""attributes":{"POSITION":0}}"#, r#""attributes":{"POSITION":0},"material":0}"#, 1);
        let (mesh, w) = read_mesh(&text);
        let mesh = mesh.unwrap();
        assert_eq!(
            w.iter().filter(|m| m.contains("1 material(s) use an occlusionTexture: phong's ambient term samples it")).count(),
            1,
            "{w:?}"
        );
        let m = &mesh.materials[0];
        let at = |u: f64| raylab::scene::texture::TexturePoint::new(raylab::glam::DVec2::new(u, 0.5), DVec3::ZERO);
        // Offset by half the image: u = 0.25 reads the right texel, u = 0.75 the left one.
        let ka = |u: f64| m.at(|| at(u)).ka;
        assert!((ka(0.25) - Color::ONE).abs().max_element() < 1e-9, "{}", ka(0.25));
        assert!((ka(0.75) - Color::splat(1.0 + 0.5 * (0.2 - 1.0))).abs().max_element() < 1e-6, "{}", ka(0.75));
    }

    /// A texture reads the set its `texCoord` names, or its `KHR_texture_transform`'s `texCoord`
    /// (which overrides it): on a unit quad whose `TEXCOORD_1` runs mirrored in u to its
    /// `TEXCOORD_0`, a 2 × 1 image (red left, green right) shows green at x = 0.25 through set
    /// 1 and red through set 0; the second set's derivatives along the first are the mirror's.
    #[test]
    fn textures_read_the_texture_coordinate_set_they_name() {
        use image::ImageEncoder;
        use raylab::glam::{DMat2, DVec2};
        use raylab::math::ray::Ray;
        let mut png = Vec::new();
        image::codecs::png::PngEncoder::new(&mut png).write_image(&[255, 0, 0, 0, 255, 0], 2, 1, image::ExtendedColorType::Rgb8).unwrap();
        let f32s = |v: &[f32]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
        let mut buffer = f32s(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0]);
        // glTF's v runs down: (x, 1 − y) and (1 − x, 1 − y).
        buffer.extend(f32s(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0]));
        buffer.extend(f32s(&[1.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0]));
        buffer.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
        let quad = |base_color: &str, emissive: &str| {
            format!(
                r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1,"TEXCOORD_1":2}},"indices":3,"material":0}}]}}],
"materials":[{{"pbrMetallicRoughness":{{"metallicFactor":0,"baseColorTexture":{base_color}}},"emissiveFactor":[1,1,1],"emissiveTexture":{emissive}}}],
"textures":[{{"source":0,"sampler":0}}],"samplers":[{{"magFilter":9728}}],"images":[{{"uri":"data:image/png;base64,{}"}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},{{"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"}},
{{"bufferView":3,"componentType":5123,"count":6,"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},{{"buffer":0,"byteOffset":80,"byteLength":32}},{{"buffer":0,"byteOffset":112,"byteLength":12}}],
"buffers":[{{"byteLength":124,"uri":"data:application/octet-stream;base64,{}"}}],
"extensionsUsed":["KHR_texture_transform"]}}"#,
                base64(&png),
                base64(&buffer)
            )
        };
        let set0 = r#"{"index":0}"#;
        let set1 = r#"{"index":0,"texCoord":1}"#;
        let overridden = r#"{"index":0,"texCoord":0,"extensions":{"KHR_texture_transform":{"texCoord":1}}}"#;
        for (base_color, emissive, want) in [(set1, overridden, [true, true]), (set0, set0, [false, false]), (set0, set1, [false, true])] {
            let (job, _) = load_scene("uv-sets.gltf", &quad(base_color, emissive), raylab::param::limits::Limits::default());
            let job = job.unwrap_or_else(|e| panic!("{}", e.report()));
            assert!(job.warnings.iter().all(|w| !w.message.contains("TEXCOORD")), "{:?}", job.warnings);
            let si = job.scene.trace(&Ray::new(DVec3::new(0.25, 0.5, 5.0), -DVec3::Z)).expect("the quad is hit");
            let m = si.coefficients();
            let green = |c: Color| c.y > 0.5 && c.x < 0.1;
            let red = |c: Color| c.x > 0.5 && c.y < 0.1;
            for (name, c, second) in [("base colour", m.kd, want[0]), ("emission", m.emission, want[1])] {
                assert!(if second { green(c) } else { red(c) }, "{name} {base_color} / {emissive}: {c} (want set {})", u8::from(second));
            }
            let (uv1, j) = si.object.geometry().uv1(&si.hit).expect("the mesh has a second set");
            assert!((uv1 - DVec2::new(0.75, 0.5)).length() < 1e-6 && (si.uv() - DVec2::new(0.25, 0.5)).length() < 1e-6, "{uv1}");
            assert!(j.abs_diff_eq(DMat2::from_cols(DVec2::new(-1.0, 0.0), DVec2::Y), 1e-6), "{j}");
        }
        // Without a TEXCOORD_1, set 1 reads set 0, and the file says so.
        let text = quad(set1, set0).replace(r#","TEXCOORD_1":2"#, "");
        let (job, _) = load_scene("uv-sets-missing.gltf", &text, raylab::param::limits::Limits::default());
        let job = job.unwrap_or_else(|e| panic!("{}", e.report()));
        assert!(
            job.warnings
                .iter()
                .any(|w| w.message.contains("1 primitive(s) have a material that samples TEXCOORD_1 but have no TEXCOORD_1")),
            "{:?}",
            job.warnings
        );
        let si = job.scene.trace(&Ray::new(DVec3::new(0.25, 0.5, 5.0), -DVec3::Z)).expect("the quad is hit");
        assert!(si.coefficients().kd.x > 0.5 && si.object.geometry().uv1(&si.hit).is_none());
    }

    /// Extensions a file uses without declaring them in `extensionsUsed`, the transmission
    /// texture (which only the path tracer samples) and vertex colours are named in a warning,
    /// once each.
    #[test]
    fn undeclared_extensions_transmission_textures_and_vertex_colours_warn() {
        let extra = r#",
"materials":[{"extensions":{"KHR_materials_clearcoat":{"clearcoatFactor":1},"KHR_materials_transmission":{"transmissionFactor":0.5,"transmissionTexture":{"index":0}}}},
{"extensions":{"KHR_materials_clearcoat":{}}}],
"textures":[{"source":0,"extensions":{"EXT_texture_webp":{"source":0}}}],"images":[{"uri":"missing.png"}],
"extensionsUsed":["KHR_materials_transmission"]"#;
        let text = doc("[{\"mesh\":0}]", extra).replacen(
            r#""attributes":{"POSITION":0}}"#,
            r#""attributes":{"POSITION":0,"COLOR_0":0},"material":0},{"attributes":{"POSITION":0},"material":1}"#,
            1,
        );
        let (mesh, w) = read_mesh(&text);
        assert_eq!(mesh.unwrap().triangles.len(), 2);
        let has = |s: &str| w.iter().filter(|m| m.contains(s)).count();
        assert_eq!(has("the file uses extensions raylab ignores: EXT_texture_webp, KHR_materials_clearcoat"), 1, "{w:?}");
        assert_eq!(has("KHR_materials_transmission transmissionTexture: the path tracer samples it, phong uses the factors"), 1, "{w:?}");
        // The texture's image is missing: one warning names it (the transmission texture is read
        // as data for the `pbr` model).
        assert_eq!(has("its transmissionTexture is not sampled"), 1, "{w:?}");
        assert_eq!(has("1 primitive(s) have vertex colours (COLOR_0), which raylab ignores"), 1, "{w:?}");
        assert_eq!(has("ignores: KHR_materials_transmission"), 0, "{w:?}");
    }

    /// A sparse accessor's substitutions are applied (vertex 2 moved from (0, 1, 0) to
    /// (0, 2, 0)), without a warning; a malformed one is an error naming the primitive.
    #[test]
    fn sparse_accessors_are_read() {
        let mut sparse = 2u16.to_le_bytes().to_vec();
        sparse.extend([0, 0]);
        sparse.extend([0.0f32, 2.0, 0.0].iter().flat_map(|v| v.to_le_bytes()));
        let with = |sparse_count: u32, stride: &str| {
            let text = doc("[{\"mesh\":0}]", "")
                .replacen(r#""max":[1,1,0]}"#, &format!(r#""max":[1,2,0],"sparse":{{"count":{sparse_count},"indices":{{"bufferView":1,"componentType":5123}},"values":{{"bufferView":2}}}}}}"#), 1)
                .replacen(
                    r#""bufferViews":[{"buffer":0,"byteLength":36}]"#,
                    &format!(r#""bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":1,"byteLength":2{stride}}},{{"buffer":1,"byteOffset":4,"byteLength":12}}]"#),
                    1,
                )
                .replacen("\"}]", &format!("\"}},{{\"byteLength\":16,\"uri\":\"data:application/octet-stream;base64,{}\"}}]", base64(&sparse)), 1);
            read_mesh(&text)
        };
        let (mesh, w) = with(1, "");
        assert_eq!(mesh.unwrap().positions, [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
        assert!(w.is_empty(), "{w:?}");
        for (count, stride, want) in [(0, "", "sparse"), (2, "", "outside its buffer"), (1, ",\"byteStride\":4", "sparse")] {
            let e = with(count, stride).0.err().unwrap_or_else(|| panic!("count {count}{stride} was read"));
            assert!(e.message.contains("primitive 0") && e.message.contains(want), "count {count}{stride}: {}", e.report());
        }
    }

    #[test]
    fn an_accessor_without_a_buffer_view_is_bounded_by_the_triangle_limit() {
        // A sparse accessor with no bufferView is `count` zeros: four billion normals would be
        // allocated (48 GB) before any check (the triangle count comes from the positions), from
        // a file of a few hundred bytes.
        let mut sparse = 0u16.to_le_bytes().to_vec();
        sparse.extend([0, 0]);
        sparse.extend([0.0f32, 2.0, 0.0].iter().flat_map(|v| v.to_le_bytes()));
        let text = doc("[{\"mesh\":0}]", "")
            .replacen(r#""attributes":{"POSITION":0}"#, r#""attributes":{"POSITION":0,"NORMAL":1}"#, 1)
            .replacen(
                r#""max":[1,1,0]}"#,
                r#""max":[1,1,0]},{"componentType":5126,"count":4000000000,"type":"VEC3","sparse":{"count":1,"indices":{"bufferView":1,"componentType":5123},"values":{"bufferView":2}}}"#,
                1,
            )
            .replacen(
                r#""bufferViews":[{"buffer":0,"byteLength":36}]"#,
                r#""bufferViews":[{"buffer":0,"byteLength":36},{"buffer":1,"byteLength":2},{"buffer":1,"byteOffset":4,"byteLength":12}]"#,
                1,
            )
            .replacen("\"}]", &format!("\"}},{{\"byteLength\":16,\"uri\":\"data:application/octet-stream;base64,{}\"}}]", base64(&sparse)), 1);
        let Err(e) = read_mesh(&text).0 else { panic!("an unbounded accessor was read") };
        assert!(e.message.contains("no bufferView") && e.message.contains("4000000000"), "{}", e.report());
    }
}
