//! What a mesh file format is asked ([`MeshRequest`]) and answers ([`MeshFile`], [`MeshData`]:
//! indexed triangles with optional normals, texture coordinates and materials), which a mesh
//! geometry then indexes. The formats themselves
//! ([`MeshFormat`](crate::load::context::MeshFormat)) are registered like shapes
//! ([`Registry::add_mesh_format`](crate::load::registry::Registry::add_mesh_format)) and found by
//! extension through the load context
//! ([`LoadContext::mesh_format_for`](crate::load::context::LoadContext::mesh_format_for)).

use crate::param::error::Loc;
use crate::scene::material::Material;

/// A mesh as a reader produces it: indexed triangles with optional vertex normals and materials.
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Triangles as indices into `positions`; the outward side follows the counter-clockwise
    /// winding (glTF and OBJ convention).
    pub triangles: Vec<[u32; 3]>,
    /// Vertex normals (may be empty).
    pub normals: Vec<[f32; 3]>,
    /// Per triangle, indices into `normals` (empty, or one per triangle).
    pub normal_indices: Vec<[u32; 3]>,
    /// Vertex texture coordinates, v up (may be empty).
    pub texcoords: Vec<[f32; 2]>,
    /// Per triangle, indices into `texcoords` (empty, or one per triangle).
    pub texcoord_indices: Vec<[u32; 3]>,
    /// A second set of texture coordinates (a glTF mesh's `TEXCOORD_1`), v up, indexed like
    /// `texcoords` (by `texcoord_indices`): empty, or as many as `texcoords`.
    pub texcoords1: Vec<[f32; 2]>,
    /// Per triangle, the tangents of its three corners: `xyz` along `∂p/∂u`, `w` = ±1 the
    /// handedness (the bitangent is `w·(normal × tangent)`, glTF's `TANGENT`). Empty when the
    /// mesh has none (normal maps then take each triangle's texture-coordinate derivatives); an
    /// all-zero triangle has none either.
    pub tangents: Vec<[[f32; 4]; 3]>,
    /// Per triangle, an index into `materials` (empty: all use material 0).
    pub material_ids: Vec<u32>,
    /// The file's materials, mapped to raylab's (may be empty).
    pub materials: Vec<Material>,
}

/// What a scene asks of a mesh file.
#[derive(Clone, Copy, Debug)]
pub struct MeshRequest<'a> {
    /// The file as the scene names it, relative to the scene's folder: read it through the
    /// context (`LoadContext::read_file`), which keeps it inside the sandbox and the limits.
    pub file: &'a str,
    /// Where the scene names it, for errors.
    pub loc: &'a Loc,
    /// One mesh of a file that holds several (the `mesh` parameter: a glTF mesh index); `None`:
    /// the whole file. A format without such meshes refuses `Some`.
    pub selection: Option<usize>,
    /// Whether the file's materials are wanted (false when the object names its own material:
    /// then material libraries need not be read).
    pub materials: bool,
}

/// A mesh file read.
#[derive(Clone, Debug, Default)]
pub struct MeshFile {
    /// Its triangles.
    pub data: MeshData,
    /// Bytes the reader held besides `data` at its peak (the file's own bytes when it read them
    /// whole), for the memory estimate charged before the mesh is indexed.
    pub file_bytes: u64,
}
