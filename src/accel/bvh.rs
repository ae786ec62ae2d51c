//! Spatial indices over primitives given by their boxes: a bounding-volume hierarchy (with the
//! `bvh` feature) or a flat list, behind one interface, [`PrimitiveIndex`].
//!
//! The hierarchy is obvhs' compressed wide BVH (CWBVH: eight children per node, child boxes
//! quantised to 8 bits, 80 bytes per node), converted by obvhs from a binary tree raylab builds
//! itself (binned SAH, of bounded depth for any input: module `binned`). Traversal is
//! raylab's own, because it must be **conservative**: a ray that hits a primitive exactly (in
//! `f64`) must never be culled by a box test done in `f32`. Three things make it so:
//!
//! - the ray's origin is moved, in `f64`, to where it enters the root box before it is rounded
//!   to `f32`, so `f32` rounding errors scale with the size of the hierarchy's contents, not with
//!   the distance of the camera;
//! - every primitive box is rounded outward to `f32` and padded by [`BOX_PADDING`] of the
//!   root's magnitude, which bounds the rounding error of the `f32` slab test and of the ray
//!   itself (the quantised child boxes of a CWBVH are rounded outward by construction);
//! - a direction component of zero gets a large finite reciprocal, never an infinity, so no slab
//!   test produces NaN (obvhs' own traversal clamps `t` at an absolute 10⁻⁴ and reciprocals at
//!   1/ε, neither of which is safe at every scale).
//!
//! The primitive test is a closure, monomorphised into the traversal: no dynamic dispatch and no
//! allocation per ray. The caller stores its primitives in the index's slot order
//! ([`PrimitiveIndex::order`]), so a leaf reads them contiguously.

use crate::math::bounds::Aabb;
use crate::math::ray::Ray;
use std::time::Duration;

/// Which spatial index to use: chosen per scene and per mesh by [`AccelChoice::use_bvh`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AccelChoice {
    /// A hierarchy when there are enough primitives to pay for it, a list otherwise.
    #[default]
    Auto,
    /// Always a flat list.
    List,
    /// Always a hierarchy (an error at load time when raylab is built without `bvh`).
    Bvh,
}

impl AccelChoice {
    /// Parses `"auto"`, `"list"` or `"bvh"`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(AccelChoice::Auto),
            "list" => Some(AccelChoice::List),
            "bvh" => Some(AccelChoice::Bvh),
            _ => None,
        }
    }

    /// Whether `count` primitives get a hierarchy. `Auto` builds one from `threshold` primitives
    /// on, and only when raylab is built with the `bvh` feature.
    pub fn use_bvh(self, count: usize, threshold: usize) -> bool {
        BVH_AVAILABLE
            && match self {
                AccelChoice::Auto => count >= threshold,
                AccelChoice::List => false,
                AccelChoice::Bvh => count >= 2,
            }
    }
}

/// True when raylab is built with the `bvh` feature.
pub const BVH_AVAILABLE: bool = cfg!(feature = "bvh");

/// Fewest bounded scene objects for which `auto` builds a scene-level hierarchy. Below it a list
/// with a box test per object is as fast, within measurement noise; from about eight objects on
/// the hierarchy wins (measured: README, "Speed").
pub const SCENE_BVH_THRESHOLD: usize = 8;

/// Fewest triangles for which `auto` builds a mesh hierarchy.
pub const MESH_BVH_THRESHOLD: usize = 16;

/// Padding of every primitive box, relative to the magnitude of the root box (its largest
/// coordinate plus its diagonal). It exceeds the `f32` rounding error of the origin and
/// direction of a ray near the box (2⁻²⁴ each), of the quantised slab test (≈ 4·2⁻²⁴) and of
/// the quantisation itself, so the traversal never culls a box the exact ray meets.
pub const BOX_PADDING: f64 = 1.0 / (1u64 << 18) as f64;

/// Largest reciprocal of a direction component used by the `f32` slab test. A component
/// smaller than its inverse is treated as that small: the resulting displacement of the ray is
/// far below [`BOX_PADDING`] of anything the ray can reach.
#[cfg(feature = "bvh")]
const MAX_INV_DIR: f32 = 1e15;

/// What building an index cost, for the render summary and `raylab bench`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Hierarchies built (0 for a list).
    pub hierarchies: u32,
    /// Primitives indexed by hierarchies.
    pub primitives: u64,
    /// Hierarchy nodes.
    pub nodes: u64,
    /// Bytes of the hierarchies' nodes.
    pub bytes: u64,
    /// Wall time of building.
    pub time: Duration,
}

impl std::ops::AddAssign for BuildStats {
    fn add_assign(&mut self, o: BuildStats) {
        self.hierarchies += o.hierarchies;
        self.primitives += o.primitives;
        self.nodes += o.nodes;
        self.bytes += o.bytes;
        self.time += o.time;
    }
}

/// Largest coordinate a hierarchy is built over. obvhs costs its splits in `f32` (box areas times
/// primitive counts), which overflow beyond about 1e15 and then fail its build; primitives farther
/// out than this (1e6 times raylab's tested range) are indexed by a list instead: slower, exact.
pub const MAX_BVH_COORDINATE: f64 = 1e12;

/// A spatial index over `len` primitives: a hierarchy or a flat list.
pub struct PrimitiveIndex {
    len: u32,
    #[cfg(feature = "bvh")]
    bvh: Option<wide::WideBvh>,
}

impl std::fmt::Debug for PrimitiveIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "PrimitiveIndex({} primitives, {})", self.len, if self.is_bvh() { "BVH" } else { "list" })
    }
}

impl PrimitiveIndex {
    /// A flat list of `len` primitives, tested in order.
    pub fn list(len: usize) -> Self {
        PrimitiveIndex {
            len: len as u32,
            #[cfg(feature = "bvh")]
            bvh: None,
        }
    }

    /// An index over primitives with the given boxes (finite, non-empty), a hierarchy when
    /// `bvh` is true, raylab is built with the `bvh` feature and every box lies within
    /// [`MAX_BVH_COORDINATE`]. Returns the index and the slot
    /// order: `order[slot]` is the primitive stored at `slot`; the caller must store its
    /// primitives in that order, since the traversal reports slots.
    pub fn build(boxes: &[Aabb], bvh: bool) -> (Self, Vec<u32>, BuildStats) {
        let identity = || (0..boxes.len() as u32).collect::<Vec<u32>>();
        #[cfg(feature = "bvh")]
        if bvh && boxes.len() >= 2 && boxes.iter().all(|b| b.min.abs().max(b.max.abs()).max_element() <= MAX_BVH_COORDINATE) {
            let (w, order, stats) = wide::WideBvh::build(boxes);
            return (PrimitiveIndex { len: boxes.len() as u32, bvh: Some(w) }, order, stats);
        }
        let _ = bvh;
        (PrimitiveIndex::list(boxes.len()), identity(), BuildStats::default())
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// True when there is no primitive.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// True when this is a hierarchy (not a list).
    pub fn is_bvh(&self) -> bool {
        #[cfg(feature = "bvh")]
        return self.bvh.is_some();
        #[cfg(not(feature = "bvh"))]
        false
    }

    /// Bytes used by the hierarchy's nodes (0 for a list).
    pub fn memory_bytes(&self) -> usize {
        #[cfg(feature = "bvh")]
        return self.bvh.as_ref().map_or(0, |b| b.memory_bytes());
        #[cfg(not(feature = "bvh"))]
        0
    }

    /// The closest hit along `ray` in `(t_min, t_max)`. `test(slot, t_max)` intersects the
    /// primitive at `slot` and returns its `t` when it is hit closer than `t_max` (the caller
    /// keeps whatever else it needs about that hit). Returns the slot and `t` of the closest.
    #[inline]
    pub fn closest(&self, ray: &Ray, t_min: f64, t_max: f64, mut test: impl FnMut(u32, f64) -> Option<f64>) -> Option<(u32, f64)> {
        #[cfg(feature = "bvh")]
        if let Some(b) = &self.bvh {
            return b.closest(ray, t_min, t_max, test);
        }
        let mut best = None;
        let mut t_max = t_max;
        for slot in 0..self.len {
            if let Some(t) = test(slot, t_max) {
                t_max = t;
                best = Some((slot, t));
            }
        }
        let _ = (ray, t_min);
        best
    }

    /// Whether `test(slot)` holds for any primitive whose box the ray meets in `(t_min, t_max)`;
    /// stops at the first (a shadow ray).
    #[inline]
    pub fn any(&self, ray: &Ray, t_min: f64, t_max: f64, mut test: impl FnMut(u32) -> bool) -> bool {
        #[cfg(feature = "bvh")]
        if let Some(b) = &self.bvh {
            return b.any(ray, t_min, t_max, test);
        }
        let _ = (ray, t_min, t_max);
        (0..self.len).any(&mut test)
    }
}

#[cfg(feature = "bvh")]
mod binned {
    //! raylab's binary-tree builder, for obvhs to convert to its wide BVH: top-down binned SAH
    //! over primitive centroids, iterative, O(n log n) and of bounded depth for any input.
    //! (obvhs' own PLOC builder merges one pair per pass over coincident, nested or chained
    //! primitives: quadratic time, a chain as deep as the input, and a recursive conversion of
    //! that chain that overflows the stack.)

    use glam::Vec3A;
    use obvhs::aabb::Aabb;
    use obvhs::bvh2::Bvh2;
    use obvhs::bvh2::node::Bvh2Node;

    /// Centroid bins per axis in a split search.
    const BINS: usize = 16;

    /// Deepest level split by the surface-area heuristic; deeper ranges are halved by count
    /// (object median), as are ranges whose centroids coincide.
    const SAH_DEPTH: usize = 40;

    /// Most levels of a built tree: [`SAH_DEPTH`] plus the ⌈log₂ n⌉ of the median halving
    /// (n < 2³²), plus the leaf.
    pub(super) const MAX_BINARY_DEPTH: usize = SAH_DEPTH + 33;

    /// A binary tree over `boxes` (at least one), one primitive per leaf; children of a node are
    /// adjacent, the root is node 0, as obvhs' conversion expects.
    pub(super) fn build(boxes: &[Aabb]) -> Bvh2 {
        let n = boxes.len();
        let centers: Vec<Vec3A> = boxes.iter().map(Aabb::center).collect();
        let mut prims: Vec<u32> = (0..n as u32).collect();
        let mut nodes = vec![Bvh2Node::default(); 2 * n - 1];
        let mut next = 1;
        let root = boxes.iter().fold(Aabb::empty(), |a, b| a.union(b));
        // (node, its box, first primitive, end, depth)
        let mut todo = vec![(0usize, root, 0usize, n, 0usize)];
        while let Some((node, bounds, start, end, depth)) = todo.pop() {
            if end - start == 1 {
                nodes[node] = Bvh2Node::new(bounds, 1, start as u32);
                continue;
            }
            let (mid, left, right) = split(&mut prims[start..end], boxes, &centers, depth);
            nodes[node] = Bvh2Node::new(bounds, 0, next as u32);
            todo.push((next, left, start, start + mid, depth + 1));
            todo.push((next + 1, right, start + mid, end, depth + 1));
            next += 2;
        }
        debug_assert_eq!(next, nodes.len());
        Bvh2 { nodes, primitive_indices: prims, ..Bvh2::default() }
    }

    /// Reorders `range` (two or more primitives) into two non-empty parts; returns the length of
    /// the first and the boxes of both.
    fn split(range: &mut [u32], boxes: &[Aabb], centers: &[Vec3A], depth: usize) -> (usize, Aabb, Aabb) {
        let (lo, hi) = range.iter().fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), &p| {
            let c = centers[p as usize];
            (lo.min(c), hi.max(c))
        });
        let extent = hi - lo;
        if depth < SAH_DEPTH && extent.max_element() > 0.0 {
            let bins = Bins::new(lo, extent);
            if let Some((axis, bin, left, right)) = bins.best_split(range, boxes, centers) {
                let mut first = 0;
                for i in 0..range.len() {
                    if bins.bin(centers[range[i] as usize], axis) < bin {
                        range.swap(first, i);
                        first += 1;
                    }
                }
                return (first, left, right);
            }
        }
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let half = range.len() / 2;
        range.select_nth_unstable_by(half, |&a, &b| centers[a as usize][axis].total_cmp(&centers[b as usize][axis]));
        let bounds = |part: &[u32]| part.iter().fold(Aabb::empty(), |a, &p| a.union(&boxes[p as usize]));
        (half, bounds(&range[..half]), bounds(&range[half..]))
    }

    /// The centroid binning of one range: bin `i` of an axis covers `lo + [i, i + 1) · extent / BINS`.
    struct Bins {
        lo: Vec3A,
        /// BINS / extent per axis, in `f64` so that it is finite for the smallest extent; 0 for
        /// an axis of zero extent (every centroid in bin 0).
        scale: [f64; 3],
    }

    impl Bins {
        fn new(lo: Vec3A, extent: Vec3A) -> Self {
            let scale = |e: f32| if e > 0.0 { BINS as f64 / f64::from(e) } else { 0.0 };
            Bins { lo, scale: [scale(extent.x), scale(extent.y), scale(extent.z)] }
        }

        /// The bin of centroid `c` on `axis`.
        #[inline]
        fn bin(&self, c: Vec3A, axis: usize) -> usize {
            (((f64::from(c[axis]) - f64::from(self.lo[axis])) * self.scale[axis]) as usize).min(BINS - 1)
        }

        /// The axis, first right-hand bin and the two boxes of the cheapest split by the
        /// surface-area heuristic, or `None` when no axis has two non-empty sides.
        fn best_split(&self, range: &[u32], boxes: &[Aabb], centers: &[Vec3A]) -> Option<(usize, usize, Aabb, Aabb)> {
            let mut count = [[0u32; BINS]; 3];
            let mut bounds = [[Aabb::empty(); BINS]; 3];
            for &p in range {
                let (c, b) = (centers[p as usize], &boxes[p as usize]);
                for axis in 0..3 {
                    let i = self.bin(c, axis);
                    count[axis][i] += 1;
                    bounds[axis][i] = bounds[axis][i].union(b);
                }
            }
            let mut best: Option<(f64, usize, usize, Aabb, Aabb)> = None;
            for axis in 0..3 {
                // Box and primitive count of the right-hand side from each bin on.
                let mut right = [(Aabb::empty(), 0u32); BINS];
                let mut acc = (Aabb::empty(), 0u32);
                for i in (1..BINS).rev() {
                    acc = (acc.0.union(&bounds[axis][i]), acc.1 + count[axis][i]);
                    right[i] = acc;
                }
                let mut left = (Aabb::empty(), 0u32);
                for i in 1..BINS {
                    left = (left.0.union(&bounds[axis][i - 1]), left.1 + count[axis][i - 1]);
                    if left.1 == 0 || right[i].1 == 0 {
                        continue;
                    }
                    let cost =
                        f64::from(left.0.half_area()) * f64::from(left.1) + f64::from(right[i].0.half_area()) * f64::from(right[i].1);
                    if best.is_none_or(|b| cost < b.0) {
                        best = Some((cost, axis, i, left.0, right[i].0));
                    }
                }
            }
            best.map(|(_, axis, i, l, r)| (axis, i, l, r))
        }
    }
}

#[cfg(feature = "bvh")]
mod wide {
    //! The CWBVH and its conservative traversal.

    use super::binned;
    use super::{BOX_PADDING, BuildStats, MAX_INV_DIR};
    use crate::math::bounds::Aabb;
    use crate::math::ray::Ray;
    use glam::{DVec3, UVec2, Vec3A, Vec4};
    use std::mem::MaybeUninit;

    /// γ(3), for the far bound of the root box test.
    const GAMMA3: f64 = crate::math::float::gamma(3);
    use obvhs::cwbvh::node::CwBvhNode;
    use std::time::Instant;

    /// Most primitives in a CWBVH leaf (obvhs' limit).
    const CWBVH_LEAF_PRIMITIVES: u32 = 3;

    /// Deepest traversal stack kept on the machine stack; deeper hierarchies (pathological
    /// inputs only) traverse with a heap stack.
    const INLINE_STACK: usize = 64;

    /// A compressed wide BVH with its padded root box.
    pub(super) struct WideBvh {
        nodes: Vec<CwBvhNode>,
        /// The padded root box, in `f64`.
        root: Aabb,
        /// Largest number of node groups on the traversal stack.
        depth: usize,
    }

    /// A ray prepared for the `f32` slab tests: origin shifted to the root box.
    struct NodeRay {
        origin: Vec3A,
        inv: Vec3A,
        neg: [bool; 3],
        oct_inv4: u32,
    }

    /// Rounds toward −∞ to `f32`.
    fn down(x: f64) -> f32 {
        let v = x as f32;
        if f64::from(v) > x { v.next_down() } else { v }
    }

    /// Rounds toward +∞ to `f32`.
    fn up(x: f64) -> f32 {
        let v = x as f32;
        if f64::from(v) < x { v.next_up() } else { v }
    }

    impl WideBvh {
        /// Builds over `boxes` (at least two); returns the hierarchy, slot order and stats.
        pub(super) fn build(boxes: &[Aabb]) -> (WideBvh, Vec<u32>, BuildStats) {
            let start = Instant::now();
            let total = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(*b));
            let pad = BOX_PADDING * (total.magnitude() + total.extent().length());
            let pad = DVec3::splat(pad.max(f64::MIN_POSITIVE));
            let aabbs: Vec<obvhs::aabb::Aabb> = boxes
                .iter()
                .map(|b| {
                    let (lo, hi) = (b.min - pad, b.max + pad);
                    obvhs::aabb::Aabb::new(Vec3A::new(down(lo.x), down(lo.y), down(lo.z)), Vec3A::new(up(hi.x), up(hi.y), up(hi.z)))
                })
                .collect();
            let bvh2 = binned::build(&aabbs);
            // obvhs converts the binary tree recursively, one frame per level: `binned` bounds
            // the levels by MAX_BINARY_DEPTH.
            let cw = obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(&bvh2, CWBVH_LEAF_PRIMITIVES, true, false);
            drop(bvh2);
            let depth = stack_depth(&cw.nodes);
            debug_assert!(depth <= binned::MAX_BINARY_DEPTH);
            let order = cw.primitive_indices;
            let w = WideBvh { nodes: cw.nodes, root: total.expand(pad * 2.0), depth };
            let stats = BuildStats {
                hierarchies: 1,
                primitives: boxes.len() as u64,
                nodes: w.nodes.len() as u64,
                bytes: w.memory_bytes() as u64,
                time: start.elapsed(),
            };
            (w, order, stats)
        }

        /// Levels of the hierarchy (what the traversal stack must hold).
        #[cfg(test)]
        pub(super) fn depth(&self) -> usize {
            self.depth
        }

        pub(super) fn memory_bytes(&self) -> usize {
            self.nodes.len() * std::mem::size_of::<CwBvhNode>()
        }

        /// Clips the ray to the root box; returns the `f32` ray and the `t` its origin is at.
        #[inline(always)]
        fn prepare(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(NodeRay, f64)> {
            // The slab test of `Aabb::hit`, keeping the entry distance.
            let inv = ray.dir.recip();
            let t0 = (self.root.min - ray.origin) * inv;
            let t1 = (self.root.max - ray.origin) * inv;
            let enter = t0.min(t1).max_element();
            let exit = t0.max(t1).min_element() * (1.0 + 2.0 * GAMMA3);
            // NaN (0 · ∞, a ray in the plane of a face) compares false: no limit, origin kept.
            if enter.max(t_min) > exit.min(t_max) {
                return None;
            }
            let base = if enter > t_min { enter } else { t_min.max(0.0) };
            let o = ray.at(base);
            let d = ray.dir.as_vec3a();
            // Reciprocals never infinite: |1/d| is capped at MAX_INV_DIR, keeping the sign.
            let r = Vec3A::ONE / d;
            let cap = Vec3A::splat(MAX_INV_DIR).copysign(d);
            let inv = Vec3A::select(r.abs().cmple(Vec3A::splat(MAX_INV_DIR)), r, cap);
            // Signs from the reciprocal, so −0 counts as negative everywhere (as in 1/−0 = −∞).
            let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
            let oct_inv4 =
                (if neg[0] { 0 } else { 0x0404_0404 }) | (if neg[1] { 0 } else { 0x0202_0202 }) | (if neg[2] { 0 } else { 0x0101_0101 });
            Some((NodeRay { origin: o.as_vec3a(), inv, neg, oct_inv4 }, base))
        }

        #[inline]
        pub(super) fn closest(
            &self,
            ray: &Ray,
            t_min: f64,
            t_max: f64,
            mut test: impl FnMut(u32, f64) -> Option<f64>,
        ) -> Option<(u32, f64)> {
            let (r, base) = self.prepare(ray, t_min, t_max)?;
            let mut best: Option<(u32, f64)> = None;
            let mut t_max = t_max;
            let mut hi = far_limit(t_max - base);
            let mut visit = |slot: u32, hi: &mut f32| {
                if let Some(t) = test(slot, t_max) {
                    t_max = t;
                    best = Some((slot, t));
                    *hi = far_limit(t - base);
                }
                false
            };
            if self.depth <= INLINE_STACK {
                self.traverse(&r, &mut hi, &mut ArrayStack::<INLINE_STACK>::new(), &mut visit);
            } else {
                self.traverse(&r, &mut hi, &mut Vec::new(), &mut visit);
            }
            best
        }

        #[inline]
        pub(super) fn any(&self, ray: &Ray, t_min: f64, t_max: f64, mut test: impl FnMut(u32) -> bool) -> bool {
            let Some((r, base)) = self.prepare(ray, t_min, t_max) else { return false };
            let mut hi = far_limit(t_max - base);
            let mut visit = |slot: u32, _: &mut f32| test(slot);
            if self.depth <= INLINE_STACK {
                self.traverse(&r, &mut hi, &mut ArrayStack::<INLINE_STACK>::new(), &mut visit)
            } else {
                self.traverse(&r, &mut hi, &mut Vec::new(), &mut visit)
            }
        }

        /// Walks the nodes the ray meets with `t ≤ hi` (in the shifted frame), nearest child
        /// first, calling `visit(slot, &mut hi)` for each primitive; stops when it returns true.
        /// Returns whether it stopped early. (After obvhs' `traverse!`, Ylitie et al. 2017.)
        #[inline(always)]
        fn traverse<S: Stack>(&self, r: &NodeRay, hi: &mut f32, stack: &mut S, visit: &mut impl FnMut(u32, &mut f32) -> bool) -> bool {
            if self.nodes.is_empty() {
                return false;
            }
            let mut current = UVec2::new(0, 0x8000_0000);
            let mut prims = UVec2::ZERO;
            loop {
                while prims.y != 0 {
                    let local = 31 - prims.y.leading_zeros();
                    prims.y &= !(1u32 << local);
                    if visit(prims.x + local, hi) {
                        return true;
                    }
                }
                if current.y & 0xff00_0000 != 0 {
                    let hits = current.y;
                    let offset = 31 - hits.leading_zeros();
                    let base_index = current.x;
                    current.y &= !(1u32 << offset);
                    if current.y & 0xff00_0000 != 0 {
                        stack.push(current);
                    }
                    let slot = (offset - 24) ^ (r.oct_inv4 & 0xff);
                    let relative = (hits & !(0xffff_ffffu32 << slot)).count_ones();
                    let node = &self.nodes[(base_index + relative) as usize];
                    let mask = node_hits(node, r, *hi);
                    current = UVec2::new(node.child_base_idx, (mask & 0xff00_0000) | u32::from(node.imask));
                    prims = UVec2::new(node.primitive_base_idx, mask & 0x00ff_ffff);
                } else {
                    current = UVec2::ZERO;
                }
                if prims.y == 0 && current.y & 0xff00_0000 == 0 {
                    match stack.pop() {
                        Some(g) => current = g,
                        None => return false,
                    }
                }
            }
        }
    }

    /// The shifted-frame far limit for a hit at shifted distance `t`, rounded up.
    #[inline(always)]
    fn far_limit(t: f64) -> f32 {
        if t.is_finite() { up(t) } else { f32::INFINITY }
    }

    /// The CWBVH hit mask of a node's children for the ray over `[0, hi]` (obvhs' layout: leaf
    /// primitives in the low 24 bits, internal children in the high 8, in traversal order).
    #[inline(always)]
    fn node_hits(node: &CwBvhNode, r: &NodeRay, hi: f32) -> u32 {
        let e = Vec3A::new(
            f32::from_bits(u32::from(node.e[0]) << 23),
            f32::from_bits(u32::from(node.e[1]) << 23),
            f32::from_bits(u32::from(node.e[2]) << 23),
        );
        let scale = e * r.inv;
        let offset = (Vec3A::from(node.p) - r.origin) * r.inv;
        let (child_bits8, bit_index8) = node.get_child_and_index_bits(r.oct_inv4);
        let q = |v: &[u8; 8], i: usize| Vec4::new(f32::from(v[i]), f32::from(v[i + 1]), f32::from(v[i + 2]), f32::from(v[i + 3]));
        let (xn, xf) = if r.neg[0] { (&node.child_max_x, &node.child_min_x) } else { (&node.child_min_x, &node.child_max_x) };
        let (yn, yf) = if r.neg[1] { (&node.child_max_y, &node.child_min_y) } else { (&node.child_min_y, &node.child_max_y) };
        let (zn, zf) = if r.neg[2] { (&node.child_max_z, &node.child_min_z) } else { (&node.child_min_z, &node.child_max_z) };
        let mut hit8 = 0u32;
        for half in [0usize, 4] {
            let near_x = q(xn, half) * scale.x + Vec4::splat(offset.x);
            let far_x = q(xf, half) * scale.x + Vec4::splat(offset.x);
            let near_y = q(yn, half) * scale.y + Vec4::splat(offset.y);
            let far_y = q(yf, half) * scale.y + Vec4::splat(offset.y);
            let near_z = q(zn, half) * scale.z + Vec4::splat(offset.z);
            let far_z = q(zf, half) * scale.z + Vec4::splat(offset.z);
            let near = near_x.max(near_y).max(near_z).max(Vec4::ZERO);
            let far = far_x.min(far_y).min(far_z).min(Vec4::splat(hi));
            hit8 |= near.cmple(far).bitmask() << half;
        }
        // Branch-free gather of the hit children's bits (hit masks are unpredictable).
        let mut mask = 0u32;
        for child in 0..8 {
            let on = ((hit8 >> child) & 1).wrapping_neg();
            let bits = ((child_bits8 >> (child * 8)) as u32) & 0xff & on;
            let index = ((bit_index8 >> (child * 8)) as u32) & 0x1f;
            mask |= bits << index;
        }
        mask
    }

    /// Largest number of node groups the traversal stack can hold for these nodes: one per
    /// level below the root, at most.
    fn stack_depth(nodes: &[CwBvhNode]) -> usize {
        if nodes.is_empty() {
            return 0;
        }
        let mut deepest = 0;
        let mut todo = vec![(0usize, 0usize)];
        while let Some((i, d)) = todo.pop() {
            deepest = deepest.max(d);
            let n = &nodes[i];
            for c in 0..8 {
                if n.imask & (1 << c) != 0 {
                    todo.push((n.child_node_index(c) as usize, d + 1));
                }
            }
        }
        deepest + 1
    }

    /// A traversal stack of node groups.
    trait Stack {
        fn push(&mut self, v: UVec2);
        fn pop(&mut self) -> Option<UVec2>;
    }

    /// A fixed-capacity stack on the machine stack: no allocation and no initialisation per ray.
    /// Its capacity is at least the hierarchy's depth ([`stack_depth`]), checked before use.
    struct ArrayStack<const N: usize> {
        items: [MaybeUninit<UVec2>; N],
        len: usize,
    }

    impl<const N: usize> ArrayStack<N> {
        #[inline(always)]
        fn new() -> Self {
            ArrayStack { items: [MaybeUninit::uninit(); N], len: 0 }
        }
    }

    impl<const N: usize> Stack for ArrayStack<N> {
        #[inline(always)]
        fn push(&mut self, v: UVec2) {
            self.items[self.len] = MaybeUninit::new(v);
            self.len += 1;
        }
        #[inline(always)]
        fn pop(&mut self) -> Option<UVec2> {
            if self.len == 0 {
                return None;
            }
            self.len -= 1;
            // SAFETY: every slot below `len` was written by `push`.
            Some(unsafe { self.items[self.len].assume_init() })
        }
    }

    impl Stack for Vec<UVec2> {
        fn push(&mut self, v: UVec2) {
            Vec::push(self, v);
        }
        fn pop(&mut self) -> Option<UVec2> {
            Vec::pop(self)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// Unit boxes on a line; a ray along the line hits them in order.
    fn boxes(n: usize) -> Vec<Aabb> {
        (0..n).map(|i| Aabb::new(DVec3::new(i as f64 * 2.0, 0.0, 0.0), DVec3::new(i as f64 * 2.0 + 1.0, 1.0, 1.0))).collect()
    }

    /// Slab-test primitives: the hit `t` is where the ray enters the box.
    fn enter(b: &Aabb, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        let inv = ray.dir.recip();
        let t0 = (b.min - ray.origin) * inv;
        let t1 = (b.max - ray.origin) * inv;
        let t = t0.min(t1).max_element();
        (t > t_min && t < t_max && t <= t0.max(t1).min_element()).then_some(t)
    }

    #[test]
    fn list_and_hierarchy_find_the_same_closest_box() {
        let bx = boxes(100);
        for bvh in [false, true] {
            let (index, order, _) = PrimitiveIndex::build(&bx, bvh);
            assert_eq!(index.is_bvh(), bvh && BVH_AVAILABLE);
            let stored: Vec<Aabb> = order.iter().map(|&i| bx[i as usize]).collect();
            for start in [-5.0, 13.5, 150.0] {
                let dir = if start > 100.0 { -DVec3::X } else { DVec3::X };
                let ray = Ray::new(DVec3::new(start, 0.5, 0.5), dir);
                let hit = index.closest(&ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], &ray, 0.0, tm));
                let expect = bx
                    .iter()
                    .enumerate()
                    .filter_map(|(i, b)| enter(b, &ray, 0.0, f64::INFINITY).map(|t| (i, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                assert_eq!(hit.map(|(s, t)| (order[s as usize] as usize, t)), expect, "start {start}, bvh {bvh}");
                let any = index.any(&ray, 0.0, f64::INFINITY, |s| enter(&stored[s as usize], &ray, 0.0, f64::INFINITY).is_some());
                assert_eq!(any, expect.is_some());
            }
        }
    }

    #[test]
    fn identical_boxes_build_and_traverse() {
        // Degenerate input (every primitive in one place): any tree shape must still find all.
        let bx = vec![Aabb::new(DVec3::ZERO, DVec3::ONE); 5000];
        let (index, _, _) = PrimitiveIndex::build(&bx, true);
        let ray = Ray::new(DVec3::new(0.5, 0.5, -3.0), DVec3::Z);
        let mut seen = 0;
        index.any(&ray, 0.0, f64::INFINITY, |_| {
            seen += 1;
            false
        });
        assert_eq!(seen, 5000);
        assert!(index.closest(&ray, 0.0, f64::INFINITY, |_, t| (t > 3.0).then_some(3.0)).is_some());
    }

    #[test]
    fn axis_parallel_rays_far_from_the_origin_are_not_culled() {
        // Thin boxes (zero thickness in y) far from the origin, rays with zero direction components.
        let bx: Vec<Aabb> =
            (0..50).map(|i| Aabb::new(DVec3::new(1e5 + i as f64, 7.0, -3.0), DVec3::new(1e5 + i as f64 + 0.5, 7.0, -2.0))).collect();
        let (index, order, _) = PrimitiveIndex::build(&bx, true);
        for (i, b) in bx.iter().enumerate() {
            let ray = Ray::new(DVec3::new(b.center().x, 1e6, b.center().z), -DVec3::Y);
            let mut seen = Vec::new();
            index.any(&ray, 0.0, f64::INFINITY, |s| {
                seen.push(order[s as usize] as usize);
                false
            });
            assert!(seen.contains(&i), "box {i} culled");
        }
    }

    /// Levels of the index's hierarchy (0 for a list).
    #[cfg(feature = "bvh")]
    fn depth(index: &PrimitiveIndex) -> usize {
        index.bvh.as_ref().map_or(0, |b| b.depth())
    }

    /// Builds a hierarchy over `bx`, checks its depth bound, and that the closest box along each
    /// ray and whether any is met agree with the list.
    fn agrees_with_list(bx: &[Aabb], rays: &[Ray]) {
        let (index, order, _) = PrimitiveIndex::build(bx, true);
        assert_eq!(index.is_bvh(), BVH_AVAILABLE);
        #[cfg(feature = "bvh")]
        assert!(depth(&index) <= binned::MAX_BINARY_DEPTH, "depth {}", depth(&index));
        let stored: Vec<Aabb> = order.iter().map(|&i| bx[i as usize]).collect();
        for ray in rays {
            let hit = index.closest(ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], ray, 0.0, tm));
            let expect = bx.iter().filter_map(|b| enter(b, ray, 0.0, f64::INFINITY)).min_by(f64::total_cmp);
            assert_eq!(hit.map(|(_, t)| t), expect, "{ray:?}");
            let any = index.any(ray, 0.0, f64::INFINITY, |s| enter(&stored[s as usize], ray, 0.0, f64::INFINITY).is_some());
            assert_eq!(any, expect.is_some(), "{ray:?}");
        }
    }

    #[test]
    fn a_million_coincident_boxes_build_shallow_and_traverse() {
        // Once a stack overflow (abort) in the conversion of a chain as deep as the input, after
        // a build quadratic in it.
        let n = 1_000_000;
        let mut bx = vec![Aabb::new(DVec3::ZERO, DVec3::ONE); n];
        bx.push(Aabb::new(DVec3::new(0.25, 0.25, -1.0), DVec3::new(0.75, 0.75, -0.5)));
        let (index, order, _) = PrimitiveIndex::build(&bx, true);
        assert_eq!(index.is_bvh(), BVH_AVAILABLE);
        #[cfg(feature = "bvh")]
        assert!(depth(&index) <= binned::MAX_BINARY_DEPTH, "depth {}", depth(&index));
        let stored: Vec<Aabb> = order.iter().map(|&i| bx[i as usize]).collect();
        // Through the small box in front: it is the closest.
        let ray = Ray::new(DVec3::new(0.5, 0.5, -3.0), DVec3::Z);
        let hit = index.closest(&ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], &ray, 0.0, tm));
        assert_eq!(hit.map(|(s, t)| (order[s as usize] as usize, t)), Some((n, 2.0)));
        // Beside it: one of the coincident boxes, at the list's distance; every one is seen.
        let ray = Ray::new(DVec3::new(0.9, 0.9, -3.0), DVec3::Z);
        let hit = index.closest(&ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], &ray, 0.0, tm));
        assert!(hit.is_some_and(|(s, t)| (order[s as usize] as usize) < n && t == 3.0), "{hit:?}");
        let mut seen = 0;
        index.any(&ray, 0.0, f64::INFINITY, |s| {
            seen += usize::from(enter(&stored[s as usize], &ray, 0.0, f64::INFINITY).is_some());
            false
        });
        assert_eq!(seen, n);
    }

    #[test]
    fn nested_boxes_growing_geometrically_build_shallow() {
        // Each box contains the previous one (radius ×1.00025, 1 to 7e10): an agglomerative
        // builder chains them.
        let bx: Vec<Aabb> = (0..100_000).map(|i| Aabb::new(DVec3::splat(-1.00025f64.powi(i)), DVec3::splat(1.00025f64.powi(i)))).collect();
        let rays = [
            Ray::new(DVec3::new(0.1, 0.2, -1e11), DVec3::Z),
            Ray::new(DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 2.0, 3.0).normalize()),
            Ray::new(DVec3::new(5e10, 0.0, -1e11), DVec3::Z),
        ];
        agrees_with_list(&bx, &rays);
    }

    #[test]
    fn collinear_tiny_boxes_at_growing_spacing_build_shallow() {
        // Tiny boxes on the x axis at k² (gaps growing: each box's nearest neighbour is the one
        // before it, so merging nearest pairs makes a chain).
        let bx: Vec<Aabb> = (0..100_000u64)
            .map(|k| {
                let x = (k * k) as f64;
                Aabb::new(DVec3::new(x, 0.0, 0.0), DVec3::new(x + 1e-3, 1e-3, 1e-3))
            })
            .collect();
        let rays = [
            Ray::new(DVec3::new(-5.0, 5e-4, 5e-4), DVec3::X),
            Ray::new(DVec3::new(2e10, 5e-4, 5e-4), -DVec3::X),
            Ray::new(DVec3::new(12345.0 * 12345.0 + 5e-4, 5e-4, -1.0), DVec3::Z),
        ];
        agrees_with_list(&bx, &rays);
    }
}
