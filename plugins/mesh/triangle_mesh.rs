//! The triangle store of a mesh, its spatial index and its ray queries.
//!
//! Triangles are stored as nine `f32` coordinates each, in the index's leaf order, so a leaf reads
//! them contiguously and no vertex-index indirection sits on the hot path. They are tested in
//! `f64` (every `f32` is exact in `f64`) by the watertight test of the `triangle` shape, with
//! **edges and vertices counted as hits** ([`EdgeRule::Inclusive`]): a lone triangle follows the
//! report (a ray through an edge misses it), but in a mesh that rule would let a ray slip between
//! two triangles sharing an edge, so a mesh uses the inclusive rule and no ray passes through a
//! closed mesh. The traversal is specialised for triangles: a closure inlined into the core's
//! [`PrimitiveIndex`], no dynamic dispatch and no allocation per ray.

use crate::shapes::triangle::{EdgeRule, TriangleRay, barycentric_point};
use raylab::Material;
use raylab::accel::bvh::PrimitiveIndex;
use raylab::accel::{AccelChoice, BuildStats, MESH_BVH_THRESHOLD};
use raylab::geometry::Hit;
use raylab::glam::{DVec2, DVec3, Vec2, Vec3};
use raylab::math::float::on_surface_slack;
use raylab::{Aabb, Ray};
use std::sync::{Arc, OnceLock};

/// A mesh as a loader produces it: indexed triangles with optional vertex normals and materials.
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
    /// Per triangle, an index into `materials` (empty: all use material 0).
    pub material_ids: Vec<u32>,
    /// The file's materials, mapped to raylab's (may be empty).
    pub materials: Vec<Material>,
}

/// How a mesh is shaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Normals {
    /// The file's vertex normals when it has them, flat facets otherwise.
    Auto,
    /// Flat facets: the geometric normal of each triangle.
    Flat,
    /// Vertex normals: the file's, or computed (angle-weighted) when it has none.
    Smooth,
}

/// Why mesh data is not usable.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshError {
    /// A vertex coordinate is NaN or infinite.
    NonFinite {
        /// Index of the vertex.
        vertex: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    IndexOutOfRange {
        /// Index of the triangle.
        triangle: usize,
        /// The bad index.
        index: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// Every triangle is degenerate (or there are none).
    NoTriangles,
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MeshError::NonFinite { vertex } => write!(f, "vertex {vertex} has a coordinate that is NaN or infinite"),
            MeshError::IndexOutOfRange { triangle, index, vertices } => {
                write!(f, "triangle {triangle} refers to vertex {index}, but there are only {vertices} vertices")
            }
            MeshError::NoTriangles => write!(f, "the mesh has no triangle with a non-zero area"),
        }
    }
}

/// Per-vertex shading normals, with each stored triangle's three normal indices.
#[derive(Clone, Debug)]
struct Shading {
    normals: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
}

/// Per-vertex texture coordinates, with each stored triangle's three indices.
#[derive(Clone, Debug)]
struct TexCoords {
    uv: Vec<Vec2>,
    indices: Vec<[u32; 3]>,
}

/// A triangle mesh ready for ray queries.
#[derive(Debug)]
pub struct TriangleMesh {
    /// Triangles in slot order: p0, p1, p2, three `f32` each.
    tris: Vec<[f32; 9]>,
    index: PrimitiveIndex,
    shading: Option<Shading>,
    texcoords: Option<TexCoords>,
    /// Per stored triangle, its material index (empty when the mesh has one material).
    material_ids: Vec<u32>,
    /// The file's materials (empty: none), shared by every object placing the mesh.
    materials: Option<Arc<[Material]>>,
    /// Input triangles that were dropped as degenerate.
    degenerate: usize,
    bounds: Aabb,
    closed: OnceLock<bool>,
    build: BuildStats,
}

impl TriangleMesh {
    /// Validates `data`, drops degenerate triangles, and builds the spatial index (a hierarchy
    /// when `choice` asks for one for this many triangles).
    pub fn new(data: MeshData, normals: Normals, choice: AccelChoice) -> Result<TriangleMesh, MeshError> {
        let MeshData { positions, triangles, normals: file_normals, normal_indices, texcoords, texcoord_indices, material_ids, materials } =
            data;
        if let Some(v) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(MeshError::NonFinite { vertex: v });
        }
        let n = positions.len();
        let mut keep = Vec::with_capacity(triangles.len());
        let mut degenerate = 0;
        for (i, t) in triangles.iter().enumerate() {
            if let Some(&bad) = t.iter().find(|&&v| v as usize >= n) {
                return Err(MeshError::IndexOutOfRange { triangle: i, index: bad, vertices: n });
            }
            let [a, b, c] = t.map(|v| Vec3::from(positions[v as usize]).as_dvec3());
            let cross = (b - a).cross(c - a);
            if cross.length_squared() > 0.0 && cross.is_finite() {
                keep.push(i);
            } else {
                degenerate += 1;
            }
        }
        if keep.is_empty() {
            return Err(MeshError::NoTriangles);
        }
        // Shading normals: the file's (valid ones only), computed, or none.
        let file_ok = normal_indices.len() == triangles.len()
            && !file_normals.is_empty()
            && normal_indices.iter().all(|t| t.iter().all(|&i| (i as usize) < file_normals.len()))
            && file_normals.iter().all(|v| v.iter().all(|c| c.is_finite()));
        let shading = match normals {
            Normals::Flat => None,
            Normals::Auto | Normals::Smooth if file_ok => Some(Shading {
                normals: file_normals.iter().map(|&v| Vec3::from(v).normalize_or_zero()).collect(),
                indices: normal_indices,
            }),
            Normals::Smooth => Some(Shading { normals: vertex_normals(&positions, &triangles), indices: triangles.clone() }),
            Normals::Auto => None,
        };
        let boxes: Vec<Aabb> =
            keep.iter().map(|&i| Aabb::from_points(triangles[i].map(|v| Vec3::from(positions[v as usize]).as_dvec3()))).collect();
        let (index, order, build) = PrimitiveIndex::build(&boxes, choice.use_bvh(boxes.len(), MESH_BVH_THRESHOLD));
        let source: Vec<usize> = order.iter().map(|&s| keep[s as usize]).collect();
        let tris = source
            .iter()
            .map(|&i| {
                let [a, b, c] = triangles[i].map(|v| positions[v as usize]);
                [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]]
            })
            .collect();
        let shading = shading.map(|s| Shading { indices: source.iter().map(|&i| s.indices[i]).collect(), normals: s.normals });
        // Texture coordinates: the file's, when every triangle has valid ones.
        let texcoords = (texcoord_indices.len() == triangles.len()
            && texcoord_indices.iter().all(|t| t.iter().all(|&i| (i as usize) < texcoords.len()))
            && texcoords.iter().all(|c| c.iter().all(|v| v.is_finite())))
        .then(|| TexCoords {
            uv: texcoords.iter().map(|&c| Vec2::from(c)).collect(),
            indices: source.iter().map(|&i| texcoord_indices[i]).collect(),
        });
        let first = material_ids.first().copied().unwrap_or(0) as usize;
        let uniform = material_ids.iter().all(|&m| m as usize == first);
        let (material_ids, materials) = if material_ids.len() == triangles.len() && !uniform {
            (source.iter().map(|&i| material_ids[i]).collect(), materials)
        } else if first > 0 && first < materials.len() {
            (Vec::new(), vec![materials[first].clone()])
        } else {
            (Vec::new(), materials)
        };
        let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(*b));
        let materials = (!materials.is_empty()).then(|| Arc::from(materials));
        let mut mesh =
            TriangleMesh { tris, index, shading, texcoords, material_ids, materials, degenerate, bounds, closed: OnceLock::new(), build };
        // Reported per triangle: the whole store, not only the hierarchy's nodes.
        mesh.build.primitives = mesh.tris.len() as u64;
        mesh.build.bytes = mesh.memory_bytes() as u64;
        Ok(mesh)
    }

    /// Number of triangles stored.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Input triangles dropped because they have no area.
    pub fn degenerate_count(&self) -> usize {
        self.degenerate
    }

    /// The box around the mesh.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// True when the triangles are in a hierarchy.
    pub fn is_bvh(&self) -> bool {
        self.index.is_bvh()
    }

    /// Cost of building the index; `bytes` counts the whole store (triangles, attributes, index).
    pub fn build_stats(&self) -> BuildStats {
        self.build
    }

    /// The file's materials (`None`: the file defines none).
    pub fn materials(&self) -> Option<&Arc<[Material]>> {
        self.materials.as_ref()
    }

    /// True when the mesh has vertex normals for shading.
    pub fn is_smooth(&self) -> bool {
        self.shading.is_some()
    }

    /// Bytes used by the triangles, their attributes and the index.
    pub fn memory_bytes(&self) -> usize {
        self.tris.len() * std::mem::size_of::<[f32; 9]>()
            + self.material_ids.len() * 4
            + self.shading.as_ref().map_or(0, |s| s.normals.len() * 12 + s.indices.len() * 12)
            + self.texcoords.as_ref().map_or(0, |t| t.uv.len() * 8 + t.indices.len() * 12)
            + self.index.memory_bytes()
    }

    /// Index into [`TriangleMesh::materials`] of the triangle at `slot`.
    #[inline]
    pub fn material_id(&self, slot: u32) -> usize {
        self.material_ids.get(slot as usize).map_or(0, |&m| m as usize)
    }

    #[inline(always)]
    fn vertices(&self, slot: u32) -> [[f64; 3]; 3] {
        let p = &self.tris[slot as usize];
        [
            [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])],
            [f64::from(p[3]), f64::from(p[4]), f64::from(p[5])],
            [f64::from(p[6]), f64::from(p[7]), f64::from(p[8])],
        ]
    }

    /// The closest hit in `(t_min, t_max)`: `prim` is the triangle's slot, `uv` its barycentric
    /// coordinates (b1, b2).
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let tr = TriangleRay::new(ray);
        let mut b = DVec3::ZERO;
        let (slot, t) = self.index.closest(ray, t_min, t_max, |slot, t_max| {
            let [p0, p1, p2] = self.vertices(slot);
            let h = tr.intersect(p0, p1, p2, t_min, t_max, EdgeRule::Inclusive)?;
            if on_surface(ray, h.t, p0, p1, p2) {
                return None;
            }
            b = h.b;
            Some(h.t)
        })?;
        let [p0, p1, p2] = self.vertices(slot).map(DVec3::from);
        let (point, error) = barycentric_point(b, p0, p1, p2);
        Some(Hit { t, point, error, uv: DVec2::new(b.y, b.z), prim: slot, object: 0 })
    }

    /// Whether any triangle is hit in `(t_min, t_max)`; stops at the first.
    #[inline]
    pub fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        let tr = TriangleRay::new(ray);
        self.index.any(ray, t_min, t_max, |slot| {
            let [p0, p1, p2] = self.vertices(slot);
            tr.intersect(p0, p1, p2, t_min, t_max, EdgeRule::Inclusive).is_some_and(|h| !on_surface(ray, h.t, p0, p1, p2))
        })
    }

    /// Unit geometric normal of the triangle at `slot`, by its winding.
    #[inline]
    pub fn geometric_normal(&self, slot: u32) -> DVec3 {
        let [p0, p1, p2] = self.vertices(slot).map(DVec3::from);
        (p1 - p0).cross(p2 - p0).normalize()
    }

    /// The interpolated vertex normal at a hit (unit), or `None` for flat shading.
    #[inline]
    pub fn interpolated_normal(&self, at: &Hit) -> Option<DVec3> {
        let s = self.shading.as_ref()?;
        let [i0, i1, i2] = *s.indices.get(at.prim as usize)?;
        let (b1, b2) = (at.uv.x, at.uv.y);
        let n = (1.0 - b1 - b2) * s.normals[i0 as usize].as_dvec3()
            + b1 * s.normals[i1 as usize].as_dvec3()
            + b2 * s.normals[i2 as usize].as_dvec3();
        n.try_normalize()
    }

    /// The interpolated texture coordinates at a hit, or `None` when the file has none.
    #[inline]
    pub fn interpolated_uv(&self, at: &Hit) -> Option<DVec2> {
        let t = self.texcoords.as_ref()?;
        let [i0, i1, i2] = *t.indices.get(at.prim as usize)?;
        let (b1, b2) = (at.uv.x, at.uv.y);
        Some((1.0 - b1 - b2) * t.uv[i0 as usize].as_dvec2() + b1 * t.uv[i1 as usize].as_dvec2() + b2 * t.uv[i2 as usize].as_dvec2())
    }

    /// True when the mesh encloses a volume: every edge is shared by exactly two triangles that
    /// traverse it in opposite directions (vertices matched by position). Computed on first use.
    pub fn is_closed(&self) -> bool {
        *self.closed.get_or_init(|| closed(&self.tris))
    }
}

/// Whether a hit at `t` is the ray's own origin: the origin lies within rounding
/// ([`on_surface_slack`]) of the triangle's plane, as for the `triangle` shape, so a ray starting
/// on the mesh does not hit it again at `t ≈ 0`.
#[inline(always)]
fn on_surface(ray: &Ray, t: f64, p0: [f64; 3], p1: [f64; 3], p2: [f64; 3]) -> bool {
    let (a, b, c) = (DVec3::from(p0), DVec3::from(p1), DVec3::from(p2));
    let n = (b - a).cross(c - a);
    t * n.dot(ray.dir).abs() <= on_surface_slack(ray.origin, a) * n.length()
}

/// Angle-weighted vertex normals (Thürmer & Wüthrich 1998).
fn vertex_normals(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut acc = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let p = t.map(|v| Vec3::from(positions[v as usize]).as_dvec3());
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let Some(n) = n.try_normalize() else { continue };
        for k in 0..3 {
            let (a, b) = ((p[(k + 1) % 3] - p[k]).try_normalize(), (p[(k + 2) % 3] - p[k]).try_normalize());
            if let (Some(a), Some(b)) = (a, b) {
                acc[t[k] as usize] += n * a.dot(b).clamp(-1.0, 1.0).acos();
            }
        }
    }
    acc.into_iter().map(|n| n.try_normalize().unwrap_or(DVec3::ZERO).as_vec3()).collect()
}

/// Whether the triangles form a closed, consistently oriented surface.
fn closed(tris: &[[f32; 9]]) -> bool {
    use std::collections::HashMap;
    let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(tris.len());
    let mut edges: Vec<(u32, u32, bool)> = Vec::with_capacity(tris.len() * 3);
    for t in tris {
        let mut v = [0u32; 3];
        for (k, slot) in v.iter_mut().enumerate() {
            let key = [t[3 * k].to_bits(), t[3 * k + 1].to_bits(), t[3 * k + 2].to_bits()];
            let next = ids.len() as u32;
            *slot = *ids.entry(key).or_insert(next);
        }
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), a < b));
        }
    }
    edges.sort_unstable();
    edges.chunks(2).all(|pair| pair.len() == 2 && pair[0].0 == pair[1].0 && pair[0].1 == pair[1].1 && pair[0].2 != pair[1].2)
        && edges.windows(3).all(|w| !(w[0].0 == w[2].0 && w[0].1 == w[2].1))
}
