//! The triangle store of a mesh, its spatial index and its ray queries.
//!
//! Triangles are stored in the index's leaf order as packs of four ([`TriPack`]: nine lanes of four
//! `f32`), so a leaf reads them contiguously, four at a time, with no vertex-index indirection on
//! the hot path. A ray meets a leaf's triangles in two steps:
//!
//! 1. a **conservative `f32` filter** tests a whole pack at once (the edge functions of Woop, Benthin
//!    & Wald's watertight test in four lanes) and rejects only triangles it can prove the exact
//!    test rejects: some edge function certainly negative and another certainly positive, beyond a
//!    bound on the rounding error of both computations ([`PackRay`] derives it);
//! 2. the survivors, usually the triangle hit and none other, get the `f64` watertight test of the
//!    `triangle` shape (every `f32` is exact in `f64`), which alone decides: the hit, its `t`, its
//!    barycentrics and error bound are exactly what they were without the filter.
//!
//! `f32` alone would not do: its hit points would carry errors of 10⁻⁷ of the mesh's size, and the
//! offsets that keep secondary rays off the surface (derived from `f64` error bounds) would have to
//! grow by the same factor. As a filter it needs no such care: an uncertain triangle is passed on.
//!
//! Edges and vertices count as hits ([`EdgeRule::Inclusive`]): a lone triangle follows the report
//! (a ray through an edge misses it), but in a mesh that rule would let a ray slip between two
//! triangles sharing an edge, so a mesh uses the inclusive rule and no ray passes through a closed
//! mesh. The traversal is specialised for triangles: closures inlined into the core's
//! [`PrimitiveIndex`], no dynamic dispatch and no allocation per ray.

use crate::shapes::triangle::{EdgeRule, TriangleRay, barycentric_point};
use raylab::Material;
use raylab::accel::bvh::{PACKET, PAD_SLOT, PrimitiveIndex, tie_limit};
use raylab::accel::{AccelChoice, BuildStats, MESH_BVH_THRESHOLD};
use raylab::geometry::Hit;
use raylab::geometry::sampling::uniform_triangle;
use raylab::glam::{BVec4A, DMat2, DVec2, DVec3, Vec2, Vec3, Vec4};
pub use raylab::load::mesh::MeshData;
use raylab::math::distribution::AliasTable;
use raylab::math::float::{gamma, on_surface_slack};
use raylab::math::sampler::mix64;
use raylab::scene::material::Cutout;
use raylab::scene::texture::TexturePoint;
use raylab::{Aabb, Ray};
use rayon::prelude::*;
use std::sync::{Arc, OnceLock};

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
    /// The second set, indexed like `uv` (glTF's `TEXCOORD_1`), if the mesh has one.
    uv1: Option<Vec<Vec2>>,
    indices: Vec<[u32; 3]>,
}

/// Four triangles' vertices, lane = triangle: `v[vertex][axis][lane]`. Lanes that hold no
/// triangle (the padding of a leaf) are NaN.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct TriPack {
    v: [[[f32; 4]; 3]; 3],
}

impl TriPack {
    const EMPTY: TriPack = TriPack { v: [[[f32::NAN; 4]; 3]; 3] };
}

/// Triangles per pack.
const PACK: u32 = 4;

/// Triangles per job of the passes over a mesh done in parallel (smaller meshes: one pass).
const PARALLEL_TRIANGLES: usize = 1 << 14;

/// A run of input triangles checked: those with an area (input indices, in order), the number
/// without, and the box around the former.
struct Scanned {
    keep: Vec<u32>,
    degenerate: usize,
    bounds: Aabb,
}

/// A triangle mesh ready for ray queries.
#[derive(Debug)]
pub struct TriangleMesh {
    /// Triangles in slot order, four per pack: slot `s` is lane `s % 4` of pack `s / 4`.
    packs: Vec<TriPack>,
    /// Triangles stored (slots less padding).
    triangles: usize,
    index: PrimitiveIndex,
    /// The filter's bound on the rounding error of an `f32` sheared vertex coordinate, for the
    /// rays of this mesh, less its part that depends on the ray (see [`PackRay`]).
    filter_error: f64,
    /// The magnitude that part scales with: the bounds' largest coordinate plus largest extent.
    filter_scale: f64,
    shading: Option<Shading>,
    texcoords: Option<TexCoords>,
    /// Per stored triangle, its corners' tangents (`w` the handedness), for normal maps; `None`
    /// (the usual case) when the file has none.
    tangents: Option<Box<[[Vec4; 3]]>>,
    /// Per stored triangle, its material index (empty when the mesh has one material).
    material_ids: Vec<u32>,
    /// The file's materials (empty: none), shared by every object placing the mesh.
    materials: Option<Arc<[Material]>>,
    /// Per material, where its surface is cut away; `None` when no material cuts anything (the
    /// ray queries then never test coverage).
    cutouts: Option<Box<[Option<Cutout>]>>,
    /// Input triangles that were dropped as degenerate.
    degenerate: usize,
    bounds: Aabb,
    closed: OnceLock<bool>,
    /// Triangles by area, for choosing surface points ([`TriangleMesh::sample_point`]): built on
    /// first use (only emitting meshes are sampled); `None` for a mesh without area.
    by_area: OnceLock<Option<ByArea>>,
    build: BuildStats,
}

impl TriangleMesh {
    /// Validates `data`, drops degenerate triangles, and builds the spatial index (a hierarchy
    /// when `choice` asks for one for this many triangles).
    pub fn new(data: MeshData, normals: Normals, choice: AccelChoice) -> Result<TriangleMesh, MeshError> {
        let MeshData {
            positions,
            triangles,
            normals: file_normals,
            normal_indices,
            texcoords,
            texcoord_indices,
            texcoords1,
            tangents,
            material_ids,
            materials,
        } = data;
        if let Some(v) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(MeshError::NonFinite { vertex: v });
        }
        let n = positions.len();
        // Checked in order (the first bad index is reported), in parallel for a large mesh.
        let scan = |(job, chunk): (usize, &[[u32; 3]])| -> Result<Scanned, MeshError> {
            let first = job * PARALLEL_TRIANGLES;
            let mut s = Scanned { keep: Vec::with_capacity(chunk.len()), degenerate: 0, bounds: Aabb::EMPTY };
            for (i, t) in chunk.iter().enumerate() {
                if let Some(&bad) = t.iter().find(|&&v| v as usize >= n) {
                    return Err(MeshError::IndexOutOfRange { triangle: first + i, index: bad, vertices: n });
                }
                let [a, b, c] = t.map(|v| Vec3::from(positions[v as usize]).as_dvec3());
                let cross = (b - a).cross(c - a);
                if cross.length_squared() > 0.0 && cross.is_finite() {
                    s.keep.push((first + i) as u32);
                    s.bounds = s.bounds.include(a).include(b).include(c);
                } else {
                    s.degenerate += 1;
                }
            }
            Ok(s)
        };
        let scanned: Vec<Result<Scanned, MeshError>> = if triangles.len() >= PARALLEL_TRIANGLES {
            triangles.par_chunks(PARALLEL_TRIANGLES).enumerate().map(scan).collect()
        } else {
            vec![scan((0, &triangles))]
        };
        // The first error in order, whichever job found it first.
        let scanned = scanned.into_iter().collect::<Result<Vec<Scanned>, MeshError>>()?;
        let mut keep: Vec<u32> = Vec::with_capacity(scanned.iter().map(|s| s.keep.len()).sum());
        let (mut degenerate, mut bounds) = (0, Aabb::EMPTY);
        for s in scanned {
            keep.extend_from_slice(&s.keep);
            degenerate += s.degenerate;
            bounds = bounds.union(s.bounds);
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
        let tri_box = |k: usize| Aabb::from_points(triangles[keep[k] as usize].map(|v| Vec3::from(positions[v as usize]).as_dvec3()));
        let (index, mut source, build) =
            PrimitiveIndex::build_in(keep.len(), bounds, tri_box, choice.use_bvh(keep.len(), MESH_BVH_THRESHOLD), PACK);
        // Input triangle of each slot (padding: none).
        let unkeep = |s: &mut u32| {
            if *s != PAD_SLOT {
                *s = keep[*s as usize];
            }
        };
        let parallel = source.len() >= PARALLEL_TRIANGLES;
        if parallel {
            source.par_iter_mut().with_min_len(PARALLEL_TRIANGLES).for_each(unkeep);
        } else {
            source.iter_mut().for_each(unkeep);
        }
        let pack = |k: usize| {
            let mut pack = TriPack::EMPTY;
            let slots = &source[k * PACK as usize..source.len().min((k + 1) * PACK as usize)];
            for (lane, &i) in slots.iter().enumerate().filter(|(_, i)| **i != PAD_SLOT) {
                for (vertex, &v) in pack.v.iter_mut().zip(&triangles[i as usize]) {
                    for (lanes, &c) in vertex.iter_mut().zip(&positions[v as usize]) {
                        lanes[lane] = c;
                    }
                }
            }
            pack
        };
        let pack_count = source.len().div_ceil(PACK as usize);
        let packs: Vec<TriPack> = if parallel {
            (0..pack_count).into_par_iter().with_min_len(PARALLEL_TRIANGLES / PACK as usize).map(pack).collect()
        } else {
            (0..pack_count).map(pack).collect()
        };
        drop(keep);
        let stored = |i: u32| (i != PAD_SLOT).then_some(i as usize);
        let shading = shading
            .map(|s| Shading { indices: source.iter().map(|&i| stored(i).map_or([0; 3], |i| s.indices[i])).collect(), normals: s.normals });
        // Texture coordinates: the file's, when every triangle has valid ones.
        let texcoords = (texcoord_indices.len() == triangles.len()
            && texcoord_indices.iter().all(|t| t.iter().all(|&i| (i as usize) < texcoords.len()))
            && texcoords.iter().all(|c| c.iter().all(|v| v.is_finite())))
        .then(|| TexCoords {
            uv1: (texcoords1.len() == texcoords.len() && texcoords1.iter().all(|c| c.iter().all(|v| v.is_finite())))
                .then(|| texcoords1.iter().map(|&c| Vec2::from(c)).collect()),
            uv: texcoords.iter().map(|&c| Vec2::from(c)).collect(),
            indices: source.iter().map(|&i| stored(i).map_or([0; 3], |i| texcoord_indices[i])).collect(),
        });
        // Corner tangents: the file's (or MikkTSpace's), when every triangle has finite ones.
        let tangents = (tangents.len() == triangles.len() && tangents.iter().flatten().flatten().all(|c| c.is_finite()))
            .then(|| source.iter().map(|&i| stored(i).map_or([Vec4::ZERO; 3], |i| tangents[i].map(Vec4::from))).collect());
        let first = material_ids.first().copied().unwrap_or(0) as usize;
        let uniform = material_ids.iter().all(|&m| m as usize == first);
        let (material_ids, materials) = if material_ids.len() == triangles.len() && !uniform {
            (source.iter().map(|&i| stored(i).map_or(0, |i| material_ids[i])).collect(), materials)
        } else if first > 0 && first < materials.len() {
            (Vec::new(), vec![materials[first].clone()])
        } else {
            (Vec::new(), materials)
        };
        let cutouts: Box<[Option<Cutout>]> = materials.iter().map(|m| m.cutout.clone()).collect();
        let cutouts = cutouts.iter().any(Option::is_some).then_some(cutouts);
        let materials = (!materials.is_empty()).then(|| Arc::from(materials));
        let filter_scale = bounds.magnitude() + bounds.extent().max_element();
        let mut mesh = TriangleMesh {
            packs,
            triangles: source.iter().filter(|&&i| i != PAD_SLOT).count(),
            index,
            filter_error: FILTER_ROUNDING * filter_scale,
            filter_scale,
            shading,
            texcoords,
            tangents,
            material_ids,
            materials,
            cutouts,
            degenerate,
            bounds,
            closed: OnceLock::new(),
            by_area: OnceLock::new(),
            build,
        };
        // Reported per triangle: the whole store, not only the hierarchy's nodes.
        mesh.build.primitives = mesh.triangles as u64;
        mesh.build.bytes = mesh.memory_bytes() as u64;
        Ok(mesh)
    }

    /// Number of triangles stored.
    pub fn triangle_count(&self) -> usize {
        self.triangles
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
        self.packs.len() * std::mem::size_of::<TriPack>()
            + self.material_ids.len() * 4
            + self.shading.as_ref().map_or(0, |s| s.normals.len() * 12 + s.indices.len() * 12)
            + self.texcoords.as_ref().map_or(0, |t| t.uv.len() * 8 + t.uv1.as_ref().map_or(0, |u| u.len() * 8) + t.indices.len() * 12)
            + self.tangents.as_ref().map_or(0, |t| t.len() * 48)
            + self.index.memory_bytes()
    }

    /// Index into [`TriangleMesh::materials`] of the triangle at `slot`.
    #[inline]
    pub fn material_id(&self, slot: u32) -> usize {
        self.material_ids.get(slot as usize).map_or(0, |&m| m as usize)
    }

    #[inline(always)]
    fn vertices(&self, slot: u32) -> [[f64; 3]; 3] {
        let (p, lane) = (&self.packs[(slot / PACK) as usize], (slot % PACK) as usize);
        // Indexed in place: mapping `p.v` by value would copy the whole pack first.
        let at = |v: usize| [f64::from(p.v[v][0][lane]), f64::from(p.v[v][1][lane]), f64::from(p.v[v][2][lane])];
        [at(0), at(1), at(2)]
    }

    /// The closest hit in `(t_min, t_max)`: `prim` is the triangle's slot, `uv` its barycentric
    /// coordinates (b1, b2). Triangles whose material cuts the surface away at the hit
    /// ([`Cutout`]) are passed through.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        match &self.cutouts {
            None => self.intersect_kept(ray, t_min, t_max, |_, _| true),
            Some(c) => self.intersect_kept(ray, t_min, t_max, |slot, b| self.keeps(c, ray, slot, b)),
        }
    }

    /// Whether any triangle is hit in `(t_min, t_max)`; stops at the first (cut-away parts are
    /// passed through, as by [`TriangleMesh::intersect`]).
    #[inline]
    pub fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.occludes_leaving(ray, t_min, t_max, NO_SLOT)
    }

    /// [`TriangleMesh::occludes`] for a ray that leaves the triangle at `slot` (its origin moved
    /// off it toward the ray, [`raylab::geometry::Intersectable::occludes_leaving`]): that
    /// triangle is flat, so it is not tested (it would pass the `f32` filter, then the exact
    /// test would reject it).
    #[inline]
    pub fn occludes_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, slot: u32) -> bool {
        match &self.cutouts {
            None => self.occludes_kept(ray, t_min, t_max, slot, |_, _| true),
            Some(c) => self.occludes_kept(ray, t_min, t_max, slot, |s, b| self.keeps(c, ray, s, b)),
        }
    }

    /// Whether the surface of the triangle at `slot` is there at barycentrics `b` for `ray` (its
    /// material's cut-out, if any, at the hit's texture coordinates; stochastic coverage decided
    /// by a hash of the ray and the triangle: the same ray always gets the same answer).
    #[inline(never)]
    fn keeps(&self, cutouts: &[Option<Cutout>], ray: &Ray, slot: u32, b: DVec3) -> bool {
        let Some(Some(c)) = cutouts.get(self.material_id(slot)) else { return true };
        let at = || {
            let hit = Hit { uv: DVec2::new(b.y, b.z), prim: slot, ..Hit::new(0.0, DVec3::ZERO, DVec3::ZERO) };
            let [p0, p1, p2] = self.vertices(slot).map(DVec3::from);
            let mut at = TexturePoint::new(self.interpolated_uv(&hit).unwrap_or(hit.uv), b.x * p0 + b.y * p1 + b.z * p2);
            if let Some((uv1, _)) = self.interpolated_uv1(&hit) {
                at.uv1 = uv1;
            }
            at
        };
        c.keeps(at, || ray_hash(ray, slot))
    }

    /// [`TriangleMesh::intersect`], keeping only hits `keep(slot, barycentrics)` accepts.
    #[inline(always)]
    fn intersect_kept(&self, ray: &Ray, t_min: f64, t_max: f64, keep: impl Fn(u32, DVec3) -> bool) -> Option<Hit> {
        let q = self.index.query(ray, t_min, t_max)?;
        let base = q.base();
        // Prepared at the first leaf: a ray through the box's empty corners reaches none.
        let mut prepared: Option<(TriangleRay, PackRay)> = None;
        // The tie rule (see `raylab::accel::bvh`): the smallest `t`, then the smallest slot, so
        // the hit does not depend on the order leaves are visited in. `best_t` is exclusive
        // while nothing is found; after that a hit at `best_t` still wins with a smaller slot.
        let (mut best_t, mut best_slot, mut best_b) = (t_max, NO_SLOT, DVec3::ZERO);
        let t = q.closest_leaves(|first, count, _| {
            let mut found = None;
            let (tr, pr) = prepared.get_or_insert_with(|| {
                let tr = TriangleRay::new(ray);
                (tr, PackRay::new(ray, &tr, base, self.filter_error, self.filter_scale))
            });
            self.candidates(pr, first, count, |slot| {
                let [p0, p1, p2] = self.vertices(slot);
                let limit = if best_slot == NO_SLOT { best_t } else { tie_limit(best_t) };
                if let Some(h) = tr.intersect(p0, p1, p2, t_min, limit, EdgeRule::Inclusive)
                    && (h.t < best_t || (h.t == best_t && slot < best_slot))
                    && !on_surface(ray, h.t, p0, p1, p2)
                    && keep(slot, h.b)
                {
                    (best_t, best_slot, best_b) = (h.t, slot, h.b);
                    found = Some(h.t);
                }
                false
            });
            found
        })?;
        let (slot, b) = (best_slot, best_b);
        let [p0, p1, p2] = self.vertices(slot).map(DVec3::from);
        let (point, error) = barycentric_point(b, p0, p1, p2);
        Some(Hit { t, point, error, uv: DVec2::new(b.y, b.z), prim: slot, object: 0 })
    }

    /// [`TriangleMesh::intersect`] for the rays `rays[k]` of mask `live`, each up to its own
    /// `t_max[k]`, walked together ([`PrimitiveIndex::closest_packet_leaves`]): where
    /// `intersect(&rays[k], t_min, t_max[k])` returns a hit, `out[k]` is set to exactly that hit
    /// (the same leaves reach each ray, the same exact tests decide, and the tie rule makes the
    /// answer independent of the order); returns the mask of the lanes set. A mesh whose
    /// materials cut parts away answers ray by ray.
    pub fn intersect_packet(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        if self.cutouts.is_some() {
            let mut hits = 0;
            for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
                if let Some(h) = self.intersect(ray, t_min, t_max[k]) {
                    out[k] = h;
                    hits |= 1 << k;
                }
            }
            return hits;
        }
        // Each ray's state as in `intersect_kept`: prepared at its first leaf, its best hit.
        let mut prepared: [Option<(TriangleRay, PackRay)>; PACKET] = [None; PACKET];
        let mut best_t = *t_max;
        let (mut best_slot, mut best_b) = ([NO_SLOT; PACKET], [DVec3::ZERO; PACKET]);
        self.index.closest_packet_leaves(rays, live, t_min, &mut best_t, |first, count, mut who, best_t, base| {
            while who != 0 {
                let k = who.trailing_zeros() as usize;
                who &= who - 1;
                let ray = &rays[k];
                let (tr, pr) = prepared[k].get_or_insert_with(|| {
                    let tr = TriangleRay::new(ray);
                    (tr, PackRay::new(ray, &tr, base[k], self.filter_error, self.filter_scale))
                });
                let (bt, bs, bb) = (&mut best_t[k], &mut best_slot[k], &mut best_b[k]);
                self.candidates(pr, first, count, |slot| {
                    let [p0, p1, p2] = self.vertices(slot);
                    let limit = if *bs == NO_SLOT { *bt } else { tie_limit(*bt) };
                    if let Some(h) = tr.intersect(p0, p1, p2, t_min, limit, EdgeRule::Inclusive)
                        && (h.t < *bt || (h.t == *bt && slot < *bs))
                        && !on_surface(ray, h.t, p0, p1, p2)
                    {
                        (*bt, *bs, *bb) = (h.t, slot, h.b);
                    }
                    false
                });
            }
        });
        let mut hits = 0;
        for k in (0..PACKET).filter(|&k| best_slot[k] != NO_SLOT) {
            let (slot, b) = (best_slot[k], best_b[k]);
            let [p0, p1, p2] = self.vertices(slot).map(DVec3::from);
            let (point, error) = barycentric_point(b, p0, p1, p2);
            out[k] = Hit { t: best_t[k], point, error, uv: DVec2::new(b.y, b.z), prim: slot, object: 0 };
            hits |= 1 << k;
        }
        hits
    }

    /// [`TriangleMesh::occludes_leaving`] for the shadow rays `rays[k]` of mask `live`, each up
    /// to its own `t_max[k]` and leaving out the triangle at `prims[k]` where bit `k` of
    /// `leaving` is set, walked together ([`PrimitiveIndex::any_packet_leaves`]): the mask of
    /// the rays blocked, exactly the single rays' answers (each ray meets the leaves its own walk
    /// could, the same exact tests decide). A mesh whose materials cut parts away answers ray by
    /// ray.
    pub fn occludes_packet(
        &self,
        rays: &[Ray; PACKET],
        live: u32,
        t_min: f64,
        t_max: &[f64; PACKET],
        leaving: u32,
        prims: &[u32; PACKET],
    ) -> u32 {
        let skip = |k: usize| if leaving >> k & 1 != 0 { prims[k] } else { NO_SLOT };
        if self.cutouts.is_some() {
            let mut blocked = 0;
            for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
                blocked |= u32::from(self.occludes_leaving(ray, t_min, t_max[k], skip(k))) << k;
            }
            return blocked;
        }
        // Each ray prepared at its first leaf, as in `occludes_kept`.
        let mut prepared: [Option<(TriangleRay, PackRay)>; PACKET] = [None; PACKET];
        self.index.any_packet_leaves(rays, live, t_min, t_max, |first, count, mut who, base| {
            let mut hit = 0u32;
            while who != 0 {
                let k = who.trailing_zeros() as usize;
                who &= who - 1;
                let ray = &rays[k];
                let (tr, pr) = &*prepared[k].get_or_insert_with(|| {
                    let tr = TriangleRay::new(ray);
                    (tr, PackRay::new(ray, &tr, base[k], self.filter_error, self.filter_scale))
                });
                let (skip, limit) = (skip(k), t_max[k]);
                let found = self.candidates(pr, first, count, |slot| {
                    if slot == skip {
                        return false;
                    }
                    let [p0, p1, p2] = self.vertices(slot);
                    tr.intersect(p0, p1, p2, t_min, limit, EdgeRule::Inclusive).is_some_and(|h| !on_surface(ray, h.t, p0, p1, p2))
                });
                hit |= u32::from(found) << k;
            }
            hit
        })
    }

    /// [`TriangleMesh::occludes`], counting only hits `keep(slot, barycentrics)` accepts and
    /// leaving out the triangle at `skip` ([`NO_SLOT`]: none).
    #[inline(always)]
    fn occludes_kept(&self, ray: &Ray, t_min: f64, t_max: f64, skip: u32, keep: impl Fn(u32, DVec3) -> bool) -> bool {
        let Some(q) = self.index.query(ray, t_min, t_max) else { return false };
        let base = q.base();
        // Prepared at the first leaf, as for the closest hit: many rays that enter the box reach none.
        let mut prepared: Option<(TriangleRay, PackRay)> = None;
        q.any_leaves(|first, count| {
            let (tr, pr) = &*prepared.get_or_insert_with(|| {
                let tr = TriangleRay::new(ray);
                (tr, PackRay::new(ray, &tr, base, self.filter_error, self.filter_scale))
            });
            self.candidates(pr, first, count, |slot| {
                if slot == skip {
                    return false;
                }
                let [p0, p1, p2] = self.vertices(slot);
                tr.intersect(p0, p1, p2, t_min, t_max, EdgeRule::Inclusive)
                    .is_some_and(|h| !on_surface(ray, h.t, p0, p1, p2) && keep(slot, h.b))
            })
        })
    }

    /// Calls `confirm(slot)` for each triangle of the leaf `first .. first + count` that the
    /// `f32` filter cannot rule out, in slot order; stops when it returns true, and returns
    /// whether it did.
    #[inline(always)]
    fn candidates(&self, pr: &PackRay, first: u32, count: u32, confirm: impl FnMut(u32) -> bool) -> bool {
        // One code path per axis permutation: the filter indexes the packs by constant axes.
        match pr.kz {
            0 => self.candidates_in::<1, 2, 0>(pr, first, count, confirm),
            1 => self.candidates_in::<2, 0, 1>(pr, first, count, confirm),
            _ => self.candidates_in::<0, 1, 2>(pr, first, count, confirm),
        }
    }

    #[inline(always)]
    fn candidates_in<const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        pr: &PackRay,
        first: u32,
        count: u32,
        mut confirm: impl FnMut(u32) -> bool,
    ) -> bool {
        let (start, end) = (first / PACK, (first + count).div_ceil(PACK));
        for p in start..end {
            let live = (first + count - p * PACK).min(PACK);
            let mut mask = pr.filter::<KX, KY, KZ>(&self.packs[p as usize]) & ((1u32 << live) - 1);
            while mask != 0 {
                let lane = mask.trailing_zeros();
                mask &= mask - 1;
                if confirm(p * PACK + lane) {
                    return true;
                }
            }
        }
        false
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

    /// The interpolated second set of texture coordinates at a hit and its derivatives along the
    /// first set (`∂uv₁/∂uv`, columns `∂uv₁/∂u`, `∂uv₁/∂v`: both sets are affine over a
    /// triangle, so `C·A⁻¹` with `A`, `C` the triangle's edges in each; zero where the first set
    /// is degenerate), or `None` when the mesh has one set.
    pub fn interpolated_uv1(&self, at: &Hit) -> Option<(DVec2, DMat2)> {
        let t = self.texcoords.as_ref()?;
        let uv1 = t.uv1.as_ref()?;
        let [i0, i1, i2] = *t.indices.get(at.prim as usize)?;
        let (b1, b2) = (at.uv.x, at.uv.y);
        let [a0, a1, a2] = [i0, i1, i2].map(|i| t.uv[i as usize].as_dvec2());
        let [c0, c1, c2] = [i0, i1, i2].map(|i| uv1[i as usize].as_dvec2());
        let value = (1.0 - b1 - b2) * c0 + b1 * c1 + b2 * c2;
        let a = DMat2::from_cols(a1 - a0, a2 - a0);
        let det = a.determinant();
        let j = if det.abs() > 1e-12 && det.is_finite() { DMat2::from_cols(c1 - c0, c2 - c0) * a.inverse() } else { DMat2::ZERO };
        Some((value, if j.is_finite() { j } else { DMat2::ZERO }))
    }

    /// How the point moves with the texture coordinates on triangle `at.prim` (`∂p/∂u`, `∂p/∂v`):
    /// from the file's texture coordinates (pbrt-v4 §6.5.3), or the barycentric ones without
    /// them; `None` where the triangle's texture coordinates are degenerate.
    pub fn uv_derivatives(&self, at: &Hit) -> Option<(DVec3, DVec3)> {
        if (at.prim / PACK) as usize >= self.packs.len() {
            return None;
        }
        let [p0, p1, p2] = self.vertices(at.prim).map(DVec3::from);
        let Some(t) = self.texcoords.as_ref() else { return Some((p1 - p0, p2 - p0)) };
        let [i0, i1, i2] = *t.indices.get(at.prim as usize)?;
        let uv = |i: u32| t.uv.get(i as usize).map(|v| v.as_dvec2());
        let (uv0, uv1, uv2) = (uv(i0)?, uv(i1)?, uv(i2)?);
        let (duv02, duv12) = (uv0 - uv2, uv1 - uv2);
        let (dp02, dp12) = (p0 - p2, p1 - p2);
        let det = duv02.x * duv12.y - duv02.y * duv12.x;
        if !(det.abs() > 1e-12) {
            return None;
        }
        let dpdu = (duv12.y * dp02 - duv02.y * dp12) / det;
        let dpdv = (duv02.x * dp12 - duv12.x * dp02) / det;
        (dpdu.is_finite() && dpdv.is_finite()).then_some((dpdu, dpdv))
    }
    /// `[∂p/∂u, ∂p/∂v]` at a hit, for normal maps: from the corners' tangents where the mesh has
    /// them (`∂p/∂u` the interpolated tangent, `∂p/∂v` the bitangent `w·(n × t)`), else the
    /// triangle's own derivatives along its texture coordinates; `None` without texture
    /// coordinates, or where they are degenerate.
    pub fn tangents(&self, at: &Hit) -> Option<[DVec3; 2]> {
        let (b1, b2) = (at.uv.x, at.uv.y);
        let b0 = 1.0 - b1 - b2;
        if let Some(corners) = self.tangents.as_ref().and_then(|t| t.get(at.prim as usize)) {
            let t = b0 * corners[0].as_dvec4() + b1 * corners[1].as_dvec4() + b2 * corners[2].as_dvec4();
            if t.truncate().length_squared() > 0.0 {
                let n = self.interpolated_normal(at).unwrap_or_else(|| self.geometric_normal(at.prim));
                let w = if t.w < 0.0 { -1.0 } else { 1.0 };
                return Some([t.truncate(), w * n.cross(t.truncate())]);
            }
        }
        let tc = self.texcoords.as_ref()?;
        let [i0, i1, i2] = *tc.indices.get(at.prim as usize)?;
        let [uv0, uv1, uv2] = [i0, i1, i2].map(|i| tc.uv[i as usize].as_dvec2());
        let [p0, p1, p2] = self.vertices(at.prim).map(DVec3::from);
        let (d02, d12) = (uv0 - uv2, uv1 - uv2);
        let (e02, e12) = (p0 - p2, p1 - p2);
        let det = d02.x * d12.y - d02.y * d12.x;
        let inv = 1.0 / det;
        let dpdu = (d12.y * e02 - d02.y * e12) * inv;
        let dpdv = (d02.x * e12 - d12.x * e02) * inv;
        (det != 0.0 && dpdu.is_finite() && dpdv.is_finite()).then_some([dpdu, dpdv])
    }

    /// True when the mesh encloses a volume: every edge is shared by exactly two triangles that
    /// traverse it in opposite directions (vertices matched by position). Computed on first use.
    pub fn is_closed(&self) -> bool {
        *self.closed.get_or_init(|| closed(self.live_triangles()))
    }

    /// The slots' areas in an alias table, and their total (built on first use).
    fn by_area(&self) -> Option<&ByArea> {
        self.by_area
            .get_or_init(|| {
                let (areas, normals): (Vec<f64>, Vec<DVec3>) = (0..self.packs.len() as u32 * PACK)
                    .map(|slot| {
                        let [p0, p1, p2] = self.vertices(slot).map(DVec3::from);
                        let cross = (p1 - p0).cross(p2 - p0);
                        // `geometric_normal`, from the vertices read here.
                        (0.5 * cross.length(), cross.normalize())
                    })
                    .unzip();
                let total = areas.iter().filter(|a| a.is_finite()).sum();
                AliasTable::new(&areas).map(|table| ByArea { table, area: total, normals: normals.into_boxed_slice() })
            })
            .as_ref()
    }

    /// The mesh's surface area (0 for a mesh without triangles).
    pub fn area(&self) -> f64 {
        self.by_area().map_or(0.0, |b| b.area)
    }

    /// A point uniform by area on the mesh for `u` uniform in `[0, 1)²`: a triangle chosen by its
    /// area (`u.x`, reused within it), then a point of it.
    pub fn sample_point(&self, u: DVec2) -> Option<MeshPoint> {
        let ByArea { table, area, normals } = self.by_area()?;
        let (slot, _, rest) = table.sample(u.x);
        let b = uniform_triangle(DVec2::new(rest, u.y));
        let [p0, p1, p2] = self.vertices(slot as u32).map(DVec3::from);
        let (point, error) = barycentric_point(DVec3::new(1.0 - b.x - b.y, b.x, b.y), p0, p1, p2);
        Some(MeshPoint { slot: slot as u32, point, error, b, normal: normals[slot], area: *area })
    }

    /// Whether the triangles lie on the boundary of one convex body with their windings' normals
    /// outward ([`raylab::Geometry::is_convex`]): all in one plane, or (for at most
    /// [`CONVEX_CHECK_LIMIT`] triangles: the check is quadratic) every vertex on or behind every
    /// triangle's plane, within [`CONVEX_TOLERANCE`] of the mesh's size. Asked of emitters, once.
    pub fn is_convex(&self) -> bool {
        let corners: Vec<DVec3> =
            self.live_triangles().flat_map(|t| [0, 3, 6].map(|k| DVec3::new(t[k].into(), t[k + 1].into(), t[k + 2].into()))).collect();
        let b = self.bounds();
        let tolerance = CONVEX_TOLERANCE * (b.max - b.min).max_element().max(b.max.abs().max(b.min.abs()).max_element());
        let plane = |t: &[DVec3]| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]).try_normalize()?;
            Some((n, n.dot(t[0])))
        };
        let planes: Vec<(DVec3, f64)> = corners.chunks_exact(3).filter_map(plane).collect();
        let Some(&(n0, d0)) = planes.first() else { return false };
        if corners.iter().all(|p| (n0.dot(*p) - d0).abs() <= tolerance) {
            return true;
        }
        planes.len() <= CONVEX_CHECK_LIMIT && planes.iter().all(|&(n, d)| corners.iter().all(|p| n.dot(*p) - d <= tolerance))
    }

    /// The stored triangles (p0, p1, p2, three `f32` each), padding skipped.
    fn live_triangles(&self) -> impl Iterator<Item = [f32; 9]> + '_ {
        self.packs
            .iter()
            .flat_map(|p| (0..PACK as usize).map(move |l| p.v.map(|v| v.map(|a| a[l]))))
            .filter(|t| !t[0][0].is_nan())
            .map(|[a, b, c]| [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]])
    }
}

/// The triangles by area ([`TriangleMesh::sample_point`]).
#[derive(Debug)]
struct ByArea {
    /// Each slot's triangle by its area.
    table: AliasTable,
    /// The mesh's area.
    area: f64,
    /// Each slot's unit normal, as [`TriangleMesh::geometric_normal`] finds it (computed once:
    /// a sample reads it instead of a cross product and a square root).
    normals: Box<[DVec3]>,
}

/// A point chosen on a mesh ([`TriangleMesh::sample_point`]).
#[derive(Clone, Copy, Debug)]
pub struct MeshPoint {
    /// The triangle's slot.
    pub slot: u32,
    /// The point.
    pub point: DVec3,
    /// Its rounding-error bound.
    pub error: DVec3,
    /// Its barycentric coordinates `(b1, b2)`, as [`TriangleMesh::intersect`] reports them.
    pub b: DVec2,
    /// The triangle's [`TriangleMesh::geometric_normal`].
    pub normal: DVec3,
    /// The mesh's [`TriangleMesh::area`].
    pub area: f64,
}

/// Most triangles [`TriangleMesh::is_convex`] checks against every vertex (beyond: not convex,
/// unless flat): 4096 of them are ~5·10⁷ comparisons, a few tens of ms once per emitter.
const CONVEX_CHECK_LIMIT: usize = 4096;

/// How far, relative to a mesh's size, a vertex may stand in front of a triangle's plane for
/// [`TriangleMesh::is_convex`]: the vertices' own `f32` rounding and more (a bump this small
/// hides nothing a shadow ray's margin would not).
const CONVEX_TOLERANCE: f64 = 1e-6;

/// The part of [`PackRay`]'s error bound δ that scales with the mesh's magnitude (its bounds'
/// largest coordinate plus largest extent), in units of that magnitude: 10 u with u = 2⁻²⁴, the
/// unit roundoff of `f32` (the derivation needs 2u·|o| + 6u·|p − o| ≤ 8u of it; the rest covers
/// the root box's padding).
const FILTER_ROUNDING: f64 = 10.0 * F32_ROUNDOFF;

/// u = 2⁻²⁴: bound on the relative rounding error of one `f32` operation.
const F32_ROUNDOFF: f64 = 1.0 / (1u64 << 24) as f64;

/// A ray prepared for the `f32` filter of four triangles at once.
///
/// In Woop et al.'s sheared frame (axes permuted so the ray's largest component `kz` is last,
/// sheared so the ray runs along +z), a vertex `p` is at `X = (p_kx − o_kx) + Sx (p_kz − o_kz)`,
/// `Y` likewise, and the ray passes through the triangle where its three edge functions
/// `E = X₁Y₂ − Y₁X₂` (cyclically) share a sign. The exact `f64` test evaluates these with the
/// ray's own origin; the filter evaluates them in `f32` from `o'`, the origin moved along the ray
/// to where it enters the mesh's box (the shear frame is the same for any origin on the ray, so
/// only rounding differs). Bounds, with u = 2⁻²⁴ and R the mesh's largest coordinate plus its
/// largest extent (so |o'| ≤ R and |p − o'| ≤ R), |Sx|, |Sy| ≤ 1:
///
/// - each `f32` coordinate differs from the `f64` test's by at most
///   `δ = u(2|o'| + 6|p − o'|)(1 + O(u)) + 16γ₆₄(3)(R + |o| + |base|)` (the rounding of `o'`, of
///   the shear and of the four operations, plus the `f64` test's own error and that of `o'`);
/// - with `L` the largest |X|, |Y| of the triangle's three vertices, each edge function differs by
///   at most `4Lδ + 2δ² + 4u L²(1 + O(u))` (two products and a difference, in either precision).
///
/// The filter uses `err = L(5δ + 6uL) + 3δ² + 10⁻³⁷`, which also covers the rounding of computing
/// `err` itself and, by its absolute term, the absolute (not relative) rounding of subnormal
/// results. A triangle is rejected only when one edge function is below `−err` and another above
/// `err`: then the `f64` test sees one negative and one positive and rejects it too. Everything
/// else (the hit, triangles within `err` of an edge, edge-on triangles, triangles behind the
/// origin or beyond the closest hit) goes to the `f64` test.
#[derive(Clone, Copy, Debug)]
struct PackRay {
    /// The axis of the ray's largest direction component (kx = kz + 1, ky = kx + 1, mod 3).
    kz: usize,
    /// `o'` in permuted axes (x, y, z).
    origin: [Vec4; 3],
    /// Sx, Sy.
    shear: [Vec4; 2],
    /// 5δ.
    five_delta: Vec4,
    /// 3δ² plus the absolute term.
    delta_sq: Vec4,
}

/// 6u, the relative part of the filter's bound on an edge function.
const SIX_U: f32 = (6.0 * F32_ROUNDOFF) as f32;

impl PackRay {
    /// `ray` (prepared for the exact test as `tr`: the same axes and shear) from `ray.at(base)`,
    /// for a mesh whose rounding bound is `error` at magnitude `scale` (its `filter_error` and
    /// `filter_scale`).
    #[inline]
    fn new(ray: &Ray, tr: &TriangleRay, base: f64, error: f64, scale: f64) -> PackRay {
        let [kx, ky, kz] = tr.axes();
        let [sx, sy, _] = tr.shear();
        let o = ray.at(base).to_array();
        let delta = error + 16.0 * gamma(3) * (scale + ray.origin.abs().max_element() + base.abs());
        let delta = up32(delta);
        PackRay {
            kz,
            origin: [Vec4::splat(o[kx] as f32), Vec4::splat(o[ky] as f32), Vec4::splat(o[kz] as f32)],
            shear: [Vec4::splat(sx as f32), Vec4::splat(sy as f32)],
            five_delta: Vec4::splat(5.0 * delta),
            delta_sq: Vec4::splat(3.0 * delta * delta + 1e-37),
        }
    }

    /// The lanes of `pack` the exact test may accept (see [`PackRay`]); the axes are permuted to
    /// `KX, KY, KZ` (the ray's).
    #[inline(always)]
    fn filter<const KX: usize, const KY: usize, const KZ: usize>(&self, pack: &TriPack) -> u32 {
        let [ox, oy, oz] = self.origin;
        let [sx, sy] = self.shear;
        let vertex = |v: &[[f32; 4]; 3]| {
            let dz = Vec4::from_array(v[KZ]) - oz;
            ((Vec4::from_array(v[KX]) - ox) + sx * dz, (Vec4::from_array(v[KY]) - oy) + sy * dz)
        };
        let (x0, y0) = vertex(&pack.v[0]);
        let (x1, y1) = vertex(&pack.v[1]);
        let (x2, y2) = vertex(&pack.v[2]);
        let e0 = x1 * y2 - y1 * x2;
        let e1 = x2 * y0 - y2 * x0;
        let e2 = x0 * y1 - y0 * x1;
        let l = x0.abs().max(x1.abs()).max(x2.abs()).max(y0.abs().max(y1.abs()).max(y2.abs()));
        let err = l * (self.five_delta + Vec4::splat(SIX_U) * l) + self.delta_sq;
        let neg_err = -err;
        let neg: BVec4A = e0.cmplt(neg_err) | e1.cmplt(neg_err) | e2.cmplt(neg_err);
        let pos: BVec4A = e0.cmpgt(err) | e1.cmpgt(err) | e2.cmpgt(err);
        // NaN lanes (padding) compare false: kept, and masked off by the caller.
        !(neg & pos).bitmask() & 0xf
    }
}

/// No slot yet: larger than any slot, so the first hit found wins a tie with it.
const NO_SLOT: u32 = u32::MAX;

/// A number in [0, 1) that is a function of the ray (its origin's and direction's bits) and the
/// triangle: what decides stochastic coverage ([`AlphaMode::Blend`](raylab::scene::material::AlphaMode)).
/// Deterministic, so an image does not depend on threads, tiles or passes.
#[inline]
fn ray_hash(ray: &Ray, slot: u32) -> f64 {
    let mut h = u64::from(slot) ^ 0x243f_6a88_85a3_08d3;
    for c in [ray.origin.x, ray.origin.y, ray.origin.z, ray.dir.x, ray.dir.y, ray.dir.z] {
        h = mix64(h ^ c.to_bits());
    }
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Rounds toward +∞ to `f32`.
#[inline]
fn up32(x: f64) -> f32 {
    let v = x as f32;
    if f64::from(v) < x { v.next_up() } else { v }
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
fn closed(tris: impl Iterator<Item = [f32; 9]>) -> bool {
    use std::collections::HashMap;
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut edges: Vec<(u32, u32, bool)> = Vec::new();
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform numbers in [0, 1) from a counter.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            (mix64(self.0) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn vec(&mut self) -> DVec3 {
            DVec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0
        }
    }

    /// The tie rule: of triangles hit at the same `t` (here, copies of one triangle spread over
    /// many leaves by the build, among others), the closest hit is the one in the smallest slot,
    /// whatever order the rays' walks visit the leaves in.
    #[test]
    fn ties_go_to_the_smallest_slot() {
        let mut r = Rng(11);
        let mut positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let mut triangles = Vec::new();
        for k in 0..400u32 {
            if k % 3 == 0 {
                triangles.push([0, 1, 2]);
            } else {
                // Clutter around the copies, so they fall in many leaves under different nodes.
                let c = r.vec() * 1.5;
                let n = positions.len() as u32;
                positions.extend([c, c + 0.3 * r.vec(), c + 0.3 * r.vec()].map(|v| v.as_vec3().to_array()));
                triangles.push([n, n + 1, n + 2]);
            }
        }
        let data = MeshData { positions, triangles, ..MeshData::default() };
        let mesh = TriangleMesh::new(data, Normals::Flat, AccelChoice::Bvh).unwrap();
        assert_eq!(mesh.is_bvh(), raylab::accel::BVH_AVAILABLE);
        let slots = mesh.packs.len() as u32 * PACK;
        let mut ties = 0;
        for _ in 0..3000 {
            let target = DVec3::new(0.05 + 0.4 * r.next(), 0.05 + 0.4 * r.next(), 0.0);
            let ray = Ray::new(target - 4.0 * r.vec().normalize(), r.vec());
            let ray = Ray::new(ray.origin, target - ray.origin);
            let tr = TriangleRay::new(&ray);
            let hits: Vec<(f64, u32)> = (0..slots)
                .filter_map(|slot| {
                    let [p0, p1, p2] = mesh.vertices(slot);
                    let h = tr.intersect(p0, p1, p2, 0.0, f64::INFINITY, EdgeRule::Inclusive)?;
                    (!on_surface(&ray, h.t, p0, p1, p2)).then_some((h.t, slot))
                })
                .collect();
            let expect = hits.iter().copied().min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            ties += usize::from(hits.iter().filter(|h| Some(h.0) == expect.map(|e| e.0)).count() > 1);
            let hit = mesh.intersect(&ray, 0.0, f64::INFINITY);
            assert_eq!(hit.map(|h| (h.t, h.prim)), expect, "{ray:?}");
            // In a packet of rays converging on the same point (another order of the leaves).
            let rays: [Ray; PACKET] =
                std::array::from_fn(|k| if k == 0 { ray } else { Ray::new(ray.origin + 0.01 * k as f64 * r.vec(), target - ray.origin) });
            let mut out = [Hit::new(-1.0, DVec3::ZERO, DVec3::ZERO); PACKET];
            let hits = mesh.intersect_packet(&rays, 0xff, 0.0, &[f64::INFINITY; PACKET], &mut out);
            assert_eq!((hits & 1 != 0).then_some(out[0]), hit, "{ray:?} in a packet");
        }
        assert!(ties > 1500, "{ties} rays met ties");
    }

    /// Rays walked as a packet get exactly the single rays' hits (the whole `Hit`, bit for bit):
    /// packets of neighbouring camera rays through a lumpy closed mesh and a cloud of triangles,
    /// some lanes empty, some with a far limit short of the mesh, some diverging (directions of
    /// other signs: walked one by one).
    #[test]
    fn packets_hit_what_single_rays_hit() {
        let mut r = Rng(5);
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for _ in 0..3000 {
            let c = r.vec();
            let n = positions.len() as u32;
            positions.extend([c, c + 0.08 * r.vec(), c + 0.08 * r.vec()].map(|v| v.as_vec3().to_array()));
            triangles.push([n, n + 1, n + 2]);
        }
        let data = MeshData { positions, triangles, ..MeshData::default() };
        let mesh = TriangleMesh::new(data, Normals::Flat, AccelChoice::Bvh).unwrap();
        let (mut hit, mut total) = (0, 0);
        for case in 0..4000 {
            let eye = r.vec().normalize() * (1.5 + 4.0 * r.next());
            let look = 0.5 * r.vec() - eye;
            let (u, v) = (look.any_orthonormal_pair().0, look.any_orthonormal_pair().1);
            let spread = [1e-4, 1e-3, 1e-2, 0.3][case % 4];
            let live = if case % 5 == 0 { (r.next() * 255.0) as u32 | 1 } else { 0xff };
            let rays: [Ray; PACKET] = std::array::from_fn(|k| {
                let (x, y) = ((k % 4) as f64 - 1.5, (k / 4) as f64 - 0.5);
                Ray::new(eye, look.normalize() + spread * (x * u + y * v))
            });
            let t_max: [f64; PACKET] = std::array::from_fn(|_| if r.next() < 0.1 { eye.length() * r.next() } else { f64::INFINITY });
            let t_min = if case % 7 == 0 { 0.5 } else { 0.0 };
            let mut out = [Hit::new(-1.0, DVec3::ZERO, DVec3::ZERO); PACKET];
            let hits = mesh.intersect_packet(&rays, live, t_min, &t_max, &mut out);
            assert_eq!(hits & !live, 0, "case {case}: lanes not live set");
            for k in 0..PACKET {
                if hits >> k & 1 == 0 {
                    assert_eq!(out[k].t, -1.0, "case {case}, lane {k}: not hit, but written");
                }
                if live >> k & 1 == 0 {
                    continue;
                }
                let single = mesh.intersect(&rays[k], t_min, t_max[k]);
                assert_eq!((hits >> k & 1 != 0).then_some(out[k]), single, "case {case}, lane {k}");
                total += 1;
                hit += usize::from(single.is_some());
            }
        }
        assert!(hit > total / 4 && hit < total, "{hit} of {total} rays hit");
    }

    /// Experiment (issue 29): the camera rays of `raylab bench`'s framing of the OBJ named by
    /// `RAYLAB_PACKET_OBJ` (800×600), one ray at a time against packets of 8 (blocks of
    /// `RAYLAB_PACKET_BLOCK` pixels of a row: 8 for 8×1, 4 for 4×2); run under callgrind with
    /// `--toggle-collect` on `camera_single` and on `camera_packet`.
    #[test]
    #[ignore]
    fn packet_experiment() {
        let Some(path) = std::env::var_os("RAYLAB_PACKET_OBJ") else { return };
        let text = std::fs::read_to_string(path).unwrap();
        let mut data = MeshData::default();
        for line in text.lines() {
            let mut w = line.split_whitespace();
            match w.next() {
                Some("v") => data.positions.push([0, 1, 2].map(|_| w.next().unwrap().parse::<f32>().unwrap())),
                Some("f") => {
                    data.triangles.push([0, 1, 2].map(|_| w.next().unwrap().split('/').next().unwrap().parse::<u32>().unwrap() - 1))
                }
                _ => {}
            }
        }
        let mesh = TriangleMesh::new(data, Normals::Flat, AccelChoice::Bvh).unwrap();
        let (width, height) = (800u32, 600u32);
        let b = mesh.bounds();
        let (center, radius) = (b.center(), b.extent().length() * 0.5);
        let dir = DVec3::new(0.3, 0.25, 1.0).normalize();
        let camera = raylab::scene::camera::Camera::look_at(center + dir * radius * 2.6, center, DVec3::Y, 45.0, width, height).unwrap();
        let block: u32 = std::env::var("RAYLAB_PACKET_BLOCK").ok().and_then(|v| v.parse().ok()).unwrap_or(8);
        let mut groups: Vec<[Ray; PACKET]> = Vec::new();
        for y0 in (0..height).step_by((8 / block) as usize) {
            for x0 in (0..width).step_by(block as usize) {
                groups.push(std::array::from_fn(|k| {
                    let (x, y) = (x0 + k as u32 % block, y0 + k as u32 / block);
                    camera.ray_through(width, height, DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5), DVec2::ZERO)
                }));
            }
        }
        let single = camera_single(&mesh, &groups);
        let packet = camera_packet(&mesh, &groups);
        assert!(single == packet);
        let hits = single.iter().flatten().filter(|h| h.is_some()).count();
        eprintln!("{} camera rays in {} packets, {hits} hits", groups.len() * PACKET, groups.len());
    }

    #[inline(never)]
    fn camera_single(mesh: &TriangleMesh, groups: &[[Ray; PACKET]]) -> Vec<[Option<Hit>; PACKET]> {
        groups.iter().map(|g| g.map(|r| mesh.intersect(&r, 0.0, f64::INFINITY))).collect()
    }

    #[inline(never)]
    fn camera_packet(mesh: &TriangleMesh, groups: &[[Ray; PACKET]]) -> Vec<[Option<Hit>; PACKET]> {
        groups
            .iter()
            .map(|g| {
                let mut out = [Hit::new(0.0, DVec3::ZERO, DVec3::ZERO); PACKET];
                let hits = mesh.intersect_packet(g, 0xff, 0.0, &[f64::INFINITY; PACKET], &mut out);
                std::array::from_fn(|k| (hits >> k & 1 != 0).then_some(out[k]))
            })
            .collect()
    }

    /// The filter never rejects a triangle the exact test accepts: rays aimed exactly at vertices,
    /// at points on edges, inside triangles and just outside them, from near and far, at scales
    /// from 10⁻³⁰ to 10¹² and far from the origin, through slivers.
    #[test]
    fn the_filter_passes_every_triangle_the_exact_test_hits() {
        let mut r = Rng(7);
        let (mut hits, mut rejected) = (0, 0);
        for case in 0..200_000 {
            let mut pick = |n: usize| ((r.next() * n as f64) as usize).min(n - 1);
            let (si, ci, di, kind, bi, sliver) = (pick(5), pick(3), pick(4), pick(4), pick(3), pick(7) == 0);
            let scale = [1e-30, 1e-3, 1.0, 1e3, 1e12][si];
            let center = [DVec3::ZERO, DVec3::splat(1e3 * scale), DVec3::new(-4e5, 2e4, 7e5) * scale][ci];
            let mut p = [r.vec(), r.vec(), r.vec()].map(|v| (center + scale * v).as_vec3().as_dvec3());
            if sliver {
                p[2] = (p[0] + (p[1] - p[0]) * r.next() + scale * 1e-6 * r.vec()).as_vec3().as_dvec3();
            }
            // Aim at a vertex, a point on an edge, inside, or outside (just beyond an edge, or far).
            let w = match kind {
                0 => DVec3::X,
                1 => {
                    let s = r.next();
                    DVec3::new(s, 1.0 - s, 0.0)
                }
                2 => DVec3::new(r.next(), r.next(), r.next()),
                _ => {
                    let beyond = [1e-7, 1e-3, 0.5][bi] * r.next();
                    DVec3::new(r.next() + beyond, r.next(), -beyond)
                }
            };
            let target = (w.x * p[0] + w.y * p[1] + w.z * p[2]) / w.element_sum();
            let distance = scale * [1e-3, 1.0, 1e3, 1e8][di];
            let origin = target - r.vec().normalize() * distance;
            let ray = Ray::new(origin, target - origin);
            let exact = TriangleRay::new(&ray).intersect(
                p[0].to_array(),
                p[1].to_array(),
                p[2].to_array(),
                0.0,
                f64::INFINITY,
                EdgeRule::Inclusive,
            );
            let bounds = Aabb::from_points(p);
            let scale_of = bounds.magnitude() + bounds.extent().max_element();
            // The frame starts where the ray enters the (padded) box, as in a query.
            let padded = bounds.expand(DVec3::splat(1e-6 * scale_of));
            let inv = ray.dir.recip();
            let (t0, t1) = ((padded.min - ray.origin) * inv, (padded.max - ray.origin) * inv);
            let base = t0.min(t1).max_element().max(0.0);
            let pr = PackRay::new(&ray, &TriangleRay::new(&ray), base, FILTER_ROUNDING * scale_of, scale_of);
            let mut pack = TriPack::EMPTY;
            for (k, v) in p.iter().enumerate() {
                for axis in 0..3 {
                    pack.v[k][axis][0] = v[axis] as f32;
                }
            }
            let mask = match pr.kz {
                0 => pr.filter::<1, 2, 0>(&pack),
                1 => pr.filter::<2, 0, 1>(&pack),
                _ => pr.filter::<0, 1, 2>(&pack),
            };
            if exact.is_some() {
                hits += 1;
                assert!(mask & 1 == 1, "case {case}: the filter rejects a hit: {p:?}, {ray:?}");
            } else if mask & 1 == 0 {
                rejected += 1;
            }
        }
        // Rays aimed at vertices and edges hit or miss by rounding, and only those aimed clearly
        // outside can be rejected (relative to the mesh's magnitude: not at 10³ or 10⁵ sizes from
        // the origin, and not at 10⁻³⁰, where `f32` products underflow and every triangle is
        // passed on).
        assert!(hits > 100_000, "{hits} hits");
        assert!(rejected > 8_000, "{rejected} misses rejected");
    }
}
