//! Spatial indices over primitives given by their boxes: a bounding-volume hierarchy (with the
//! `bvh` feature) or a flat list, behind one interface, [`PrimitiveIndex`].
//!
//! The hierarchy is raylab's own 8-wide BVH ([`super::wide`]): built by binned SAH, of bounded
//! depth for any input, its nodes eight `f32` child boxes tested at once (one AVX2 register
//! where the CPU has it, two SSE2 halves otherwise, with bit-identical results). Traversal must be
//! **conservative**: a ray that hits a primitive exactly (in `f64`) must never be culled by a box
//! test done in `f32`. Three things make it so:
//!
//! - the ray's origin is moved, in `f64`, to where it enters the root box before it is rounded
//!   to `f32`, so `f32` rounding errors scale with the size of the hierarchy's contents, not with
//!   the distance of the camera;
//! - every primitive box is rounded outward to `f32` and padded by
//!   [`BOX_PADDING`](crate::accel::build::BOX_PADDING) of the root's magnitude, which bounds the
//!   rounding error of the `f32` slab test and of the ray itself;
//! - a direction component of zero gets a large finite reciprocal, never an infinity, so no slab
//!   test produces NaN.
//!
//! **The tie rule.** Of hits at the same `t`, the closest-hit queries return the one in the
//! smallest slot (for an object list, the first in the list), whatever order the leaves are
//! visited in: a traversal that visits them in another order (a packet of rays, another kernel)
//! finds the same hit, so images do not depend on it. A caller that tests primitives itself
//! ([`Query::closest_leaves`]) keeps the rule by asking, once it has a hit at `t`, for hits up to
//! [`tie_limit`]`(t)` and keeping one only when it is closer, or as close in a smaller slot.
//!
//! The primitive test is a closure, monomorphised into the traversal: no dynamic dispatch and no
//! allocation per ray. The caller stores its primitives in the index's slot order (returned by
//! [`PrimitiveIndex::build`]), so a leaf reads them contiguously; [`PrimitiveIndex::query`] hands
//! whole leaves to callers that test several primitives at once.

use crate::accel::build::BuildStats;
use crate::math::bounds::Aabb;
use crate::math::ray::Ray;

/// Largest coordinate a hierarchy is built over: the `f32` boxes and slab distances of the
/// traversal keep their rounding-error bounds far inside `f32`'s range; primitives farther out
/// than this (1e6 times raylab's tested range) are indexed by a list instead: slower, exact.
pub const MAX_BVH_COORDINATE: f64 = 1e12;

/// Whether box `b` lies within [`MAX_BVH_COORDINATE`] (false for a box with a NaN).
fn within(b: Aabb) -> bool {
    b.min.abs().max(b.max.abs()).max_element() <= MAX_BVH_COORDINATE
}

/// Primitives from which the union of their boxes is computed in parallel.
const PARALLEL_BOXES: usize = 1 << 14;

/// Relative slack of [`tie_limit`]: a hit computed at exactly `t` must pass a test whose limit
/// is `tie_limit(t)` although the test compares a product rounded differently (a few ulps).
const TIE_SLACK: f64 = 8.0 * f64::EPSILON;

/// The exclusive limit to test primitives against once a hit at `t > 0` is held, so that hits
/// at the same `t` are found too (the tie rule: the smaller slot wins them).
#[inline(always)]
pub fn tie_limit(t: f64) -> f64 {
    t + t.abs() * TIE_SLACK
}

/// A spatial index over `len` primitives: a hierarchy or a flat list.
pub struct PrimitiveIndex {
    len: u32,
    /// Slots (primitives plus the padding of leaves to their group).
    slots: u32,
    /// Slots per leaf group of a list (a hierarchy's leaves say their own).
    group: u32,
    /// The box a query clips rays to (padded root of a hierarchy; `None`: no clipping).
    bounds: Option<Aabb>,
    #[cfg(feature = "bvh")]
    bvh: Option<wide::Bvh>,
}

impl std::fmt::Debug for PrimitiveIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "PrimitiveIndex({} primitives, {})", self.len, if self.is_bvh() { "BVH" } else { "list" })
    }
}

/// Slot of the order that holds no primitive (the padding of a leaf to its group).
pub const PAD_SLOT: u32 = u32::MAX;

impl PrimitiveIndex {
    /// A flat list of `len` primitives, tested in order.
    pub fn list(len: usize) -> Self {
        PrimitiveIndex {
            len: len as u32,
            slots: len as u32,
            group: 1,
            bounds: None,
            #[cfg(feature = "bvh")]
            bvh: None,
        }
    }

    /// An index over primitives with the given boxes (finite, non-empty), a hierarchy when
    /// `bvh` is true, raylab is built with the `bvh` feature and every box lies within
    /// [`MAX_BVH_COORDINATE`]; one primitive per leaf. Returns the index and the slot order:
    /// `order[slot]` is the primitive stored at `slot`; the caller must store its primitives in
    /// that order, since the traversal reports slots.
    pub fn build(boxes: &[Aabb], bvh: bool) -> (Self, Vec<u32>, BuildStats) {
        Self::build_grouped(boxes, bvh, 1)
    }

    /// [`PrimitiveIndex::build`] with leaves of up to `group` (1 or 4) primitives, each starting
    /// at a multiple of `group` slots and padded to it with [`PAD_SLOT`]: the caller can store
    /// its primitives in packs of `group` and test a leaf's at once ([`Query::closest_leaves`]).
    /// A list's slots are the primitives in order, in groups of `group` (the last may be short).
    pub fn build_grouped(boxes: &[Aabb], bvh: bool, group: u32) -> (Self, Vec<u32>, BuildStats) {
        Self::build_from(boxes.len(), |i| boxes[i], bvh, group)
    }

    /// [`PrimitiveIndex::build_grouped`] over `count` primitives whose boxes `box_of` gives (their
    /// union computed here; a caller that knows it calls [`PrimitiveIndex::build_in`]).
    pub fn build_from(count: usize, box_of: impl Fn(usize) -> Aabb + Sync, bvh: bool, group: u32) -> (Self, Vec<u32>, BuildStats) {
        // One pass: the boxes' union, and whether every box lies within the hierarchy's range.
        let start = std::time::Instant::now();
        let add = |(total, inside): (Aabb, bool), i: usize| {
            let b = box_of(i);
            (total.union(b), inside && within(b))
        };
        let (total, inside) = if count >= PARALLEL_BOXES {
            use rayon::prelude::*;
            (0..count).into_par_iter().fold(|| (Aabb::EMPTY, true), add).reduce(|| (Aabb::EMPTY, true), |a, b| (a.0.union(b.0), a.1 && b.1))
        } else {
            (0..count).fold((Aabb::EMPTY, true), add)
        };
        let union_time = start.elapsed();
        let (index, order, mut stats) = Self::build_within(count, total, inside, box_of, bvh, group);
        if stats.hierarchies > 0 {
            stats.time += union_time;
        }
        (index, order, stats)
    }

    /// [`PrimitiveIndex::build_from`] for a caller that knows `total`, the union of the boxes (a
    /// mesh: the box around its triangles' vertices), and whose boxes are finite: each box is
    /// computed once, by the hierarchy's build.
    pub fn build_in(
        count: usize,
        total: Aabb,
        box_of: impl Fn(usize) -> Aabb + Sync,
        bvh: bool,
        group: u32,
    ) -> (Self, Vec<u32>, BuildStats) {
        // Every finite box lies within the range exactly when their union does.
        Self::build_within(count, total, within(total), box_of, bvh, group)
    }

    /// The index over `count` primitives whose boxes have the union `total`; `inside`: every box
    /// lies within [`MAX_BVH_COORDINATE`].
    fn build_within(
        count: usize,
        total: Aabb,
        inside: bool,
        box_of: impl Fn(usize) -> Aabb + Sync,
        bvh: bool,
        group: u32,
    ) -> (Self, Vec<u32>, BuildStats) {
        #[cfg(feature = "bvh")]
        if bvh && count >= 2 && inside {
            let shape = if group >= 4 { wide::Shape::PACK4 } else { wide::Shape::SINGLE };
            let built = wide::Bvh::build_timed(count, total, box_of, shape);
            let index = PrimitiveIndex {
                len: count as u32,
                slots: built.order.len() as u32,
                group: shape.group,
                bounds: Some(*built.bvh.root()),
                bvh: Some(built.bvh),
            };
            return (index, built.order, built.stats);
        }
        let _ = (bvh, inside, box_of);
        let mut index = PrimitiveIndex::list(count);
        index.group = group.max(1);
        index.bounds = (count > 0).then_some(total);
        (index, (0..count as u32).collect(), BuildStats::default())
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Number of slots: primitives plus padding.
    pub fn slots(&self) -> usize {
        self.slots as usize
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

    /// Levels of the hierarchy's nodes (0 for a list).
    pub fn depth(&self) -> usize {
        #[cfg(feature = "bvh")]
        return self.bvh.as_ref().map_or(0, |b| b.depth());
        #[cfg(not(feature = "bvh"))]
        0
    }

    /// The ray clipped to the index's box over `(t_min, t_max)`, ready to walk its leaves; `None`
    /// when it misses the box (no primitive can be hit).
    #[inline]
    pub fn query(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Query<'_>> {
        let base = match &self.bounds {
            Some(b) => clip(b, ray, t_min, t_max)?,
            None => t_min.max(0.0),
        };
        Some(Query {
            index: self,
            base,
            t_max,
            #[cfg(feature = "bvh")]
            node_ray: self.bvh.as_ref().map(|_| wide::NodeRay::new(ray.at(base), ray.dir)),
        })
    }

    /// The closest hit along `ray` in `(t_min, t_max)`, ties to the smallest slot. `test(slot,
    /// limit)` intersects the primitive at `slot` and returns its `t` and whatever else the
    /// caller needs about the hit when it is hit closer than `limit`. Returns the slot, `t` and
    /// payload of the closest.
    #[inline]
    pub fn closest<T>(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        mut test: impl FnMut(u32, f64) -> Option<(f64, T)>,
    ) -> Option<(u32, f64, T)> {
        let mut best: Option<(u32, f64, T)> = None;
        self.query(ray, t_min, t_max)?.closest_leaves(|first, count, _| {
            let mut found = None;
            for slot in first..first + count {
                let limit = best.as_ref().map_or(t_max, |b| tie_limit(b.1));
                if let Some((t, payload)) = test(slot, limit)
                    && best.as_ref().is_none_or(|b| t < b.1 || (t == b.1 && slot < b.0))
                {
                    best = Some((slot, t, payload));
                    found = Some(t);
                }
            }
            found
        });
        best
    }

    /// Whether `test(slot)` holds for any primitive whose box the ray meets in `(t_min, t_max)`;
    /// stops at the first (a shadow ray).
    #[inline]
    pub fn any(&self, ray: &Ray, t_min: f64, t_max: f64, mut test: impl FnMut(u32) -> bool) -> bool {
        self.query(ray, t_min, t_max).is_some_and(|q| q.any_leaves(|first, count| (first..first + count).any(&mut test)))
    }
}

/// A ray clipped to a [`PrimitiveIndex`]'s box: where its leaves are walked from.
pub struct Query<'a> {
    index: &'a PrimitiveIndex,
    base: f64,
    t_max: f64,
    #[cfg(feature = "bvh")]
    node_ray: Option<wide::NodeRay>,
}

impl Query<'_> {
    /// The `t` at which the ray enters the index's box (or `t_min` when it starts inside): the
    /// traversal's `f32` frame starts at `ray.at(base)`.
    #[inline]
    pub fn base(&self) -> f64 {
        self.base
    }

    /// Walks the leaves the ray meets, nearest first, until none can hold a hit closer than the
    /// closest so far. `test(first, count, t_max)` tests the leaf's primitives (slots `first ..
    /// first + count`, `first` a multiple of the group) and returns the closest `t < t_max` it
    /// found, if any. Returns the closest `t`.
    #[inline]
    pub fn closest_leaves(self, mut test: impl FnMut(u32, u32, f64) -> Option<f64>) -> Option<f64> {
        let mut t_max = self.t_max;
        let mut best = None;
        #[cfg(feature = "bvh")]
        if let (Some(b), Some(r)) = (&self.index.bvh, &self.node_ray) {
            let base = self.base;
            let mut hi = wide::far_limit(t_max - base);
            b.traverse(r, &mut hi, &mut |first, count, hi: &mut f32| {
                if let Some(t) = test(first, count, t_max) {
                    t_max = t;
                    best = Some(t);
                    *hi = wide::far_limit(t - base);
                }
                false
            });
            return best;
        }
        let g = self.index.group;
        for first in (0..self.index.slots).step_by(g as usize) {
            if let Some(t) = test(first, g.min(self.index.slots - first), t_max) {
                t_max = t;
                best = Some(t);
            }
        }
        best
    }

    /// Whether `test(first, count)` holds for any leaf the ray meets (see
    /// [`Query::closest_leaves`]), the leaves taken in no particular order; stops at the first.
    #[inline]
    pub fn any_leaves(self, mut test: impl FnMut(u32, u32) -> bool) -> bool {
        #[cfg(feature = "bvh")]
        if let (Some(b), Some(r)) = (&self.index.bvh, &self.node_ray) {
            return b.traverse_any(r, wide::far_limit(self.t_max - self.base), &mut test);
        }
        let g = self.index.group;
        (0..self.index.slots).step_by(g as usize).any(|first| test(first, g.min(self.index.slots - first)))
    }
}

/// Rays walked together by [`PrimitiveIndex::closest_packet_leaves`]: one per lane of a
/// hierarchy's node.
pub use crate::geometry::PACKET;

impl PrimitiveIndex {
    /// [`Query::closest_leaves`] for the rays `rays[k]` of mask `live` (each in `(t_min,
    /// t_max[k])`), walked together through a hierarchy when more than one meets its box and
    /// their directions allow it (one near side per axis), else one after the other.
    /// `test(first, count, rays, t_max, base)` tests the leaf's primitives for the rays of mask
    /// `rays` and lowers `t_max[k]` to the closest `t` it finds for ray `k`; `base[k]` is the
    /// ray's [`Query::base`]. Each ray is handed the leaves its own walk
    /// could hand it, in another order, so a caller that keeps the tie rule gets each single
    /// ray's answer. Returns the mask of the rays that met the index's box.
    #[inline]
    pub fn closest_packet_leaves(
        &self,
        rays: &[Ray; PACKET],
        live: u32,
        t_min: f64,
        t_max: &mut [f64; PACKET],
        mut test: impl FnMut(u32, u32, u32, &mut [f64; PACKET], &[f64; PACKET]),
    ) -> u32 {
        let mut base = [0.0; PACKET];
        #[cfg(feature = "bvh")]
        if let (Some(b), Some(root)) = (&self.bvh, &self.bounds) {
            let mut met = 0u32;
            let mut lanes = [None; PACKET];
            let mut m = live;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                if let Some(at) = clip(root, &rays[k], t_min, t_max[k]) {
                    base[k] = at;
                    lanes[k] = Some(wide::NodeRay::new(rays[k].at(at), rays[k].dir));
                    met |= 1 << k;
                }
            }
            if met.count_ones() > 1
                && let Some(p) = wide::PacketRay::new(&lanes, met)
            {
                let mut hi = [f32::NEG_INFINITY; PACKET];
                let mut m = met;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    hi[k] = wide::far_limit(t_max[k] - base[k]);
                }
                b.traverse_packet(&p, &mut hi, &mut |first, count, rays, hi: &mut [f32; PACKET]| {
                    let before = *t_max;
                    test(first, count, rays, t_max, &base);
                    let mut m = rays;
                    while m != 0 {
                        let k = m.trailing_zeros() as usize;
                        m &= m - 1;
                        if t_max[k] < before[k] {
                            hi[k] = wide::far_limit(t_max[k] - base[k]);
                        }
                    }
                });
                return met;
            }
            // One ray, or directions of both signs on an axis: each walked alone.
            let mut m = met;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let q = Query { index: self, base: base[k], t_max: t_max[k], node_ray: lanes[k] };
                q.closest_leaves(|first, count, _| {
                    let before = t_max[k];
                    test(first, count, 1 << k, t_max, &base);
                    (t_max[k] < before).then_some(t_max[k])
                });
            }
            return met;
        }
        let mut met = 0u32;
        for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
            let Some(q) = self.query(ray, t_min, t_max[k]) else { continue };
            met |= 1 << k;
            base[k] = q.base;
            q.closest_leaves(|first, count, _| {
                let before = t_max[k];
                test(first, count, 1 << k, t_max, &base);
                (t_max[k] < before).then_some(t_max[k])
            });
        }
        met
    }
}

impl PrimitiveIndex {
    /// [`Query::any_leaves`] for the rays `rays[k]` of mask `live` (each in `(t_min, t_max[k])`):
    /// walked together through a hierarchy when more than one meets its box and their
    /// directions allow it (shadow rays toward one light), else one after the other.
    /// `test(first, count, rays, base)` tests the leaf's primitives for the rays of mask `rays`
    /// and returns the mask of those it found a hit for; `base[k]` is ray `k`'s
    /// [`Query::base`]. A ray is dropped from the walk once hit, and is handed (until then) the
    /// leaves its own walk could hand it: with exact leaf tests its answer is the single ray's.
    /// Returns the mask of the rays hit.
    #[inline]
    pub fn any_packet_leaves(
        &self,
        rays: &[Ray; PACKET],
        live: u32,
        t_min: f64,
        t_max: &[f64; PACKET],
        mut test: impl FnMut(u32, u32, u32, &[f64; PACKET]) -> u32,
    ) -> u32 {
        let mut base = [0.0; PACKET];
        let mut blocked = 0u32;
        #[cfg(feature = "bvh")]
        if let (Some(b), Some(root)) = (&self.bvh, &self.bounds) {
            let mut met = 0u32;
            let mut lanes = [None; PACKET];
            let mut m = live;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                if let Some(at) = clip(root, &rays[k], t_min, t_max[k]) {
                    base[k] = at;
                    lanes[k] = Some(wide::NodeRay::new(rays[k].at(at), rays[k].dir));
                    met |= 1 << k;
                }
            }
            if met.count_ones() > 1
                && let Some(p) = wide::PacketRay::new(&lanes, met)
            {
                let mut hi = [f32::NEG_INFINITY; PACKET];
                let mut m = met;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    hi[k] = wide::far_limit(t_max[k] - base[k]);
                }
                // A ray hit leaves the walk: a far limit of −∞ enters no box.
                b.traverse_packet(&p, &mut hi, &mut |first, count, rays, hi: &mut [f32; PACKET]| {
                    let mut hit = test(first, count, rays, &base) & rays;
                    blocked |= hit;
                    while hit != 0 {
                        let k = hit.trailing_zeros() as usize;
                        hit &= hit - 1;
                        hi[k] = f32::NEG_INFINITY;
                    }
                });
                return blocked;
            }
            let mut m = met;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let q = Query { index: self, base: base[k], t_max: t_max[k], node_ray: lanes[k] };
                if q.any_leaves(|first, count| test(first, count, 1 << k, &base) != 0) {
                    blocked |= 1 << k;
                }
            }
            return blocked;
        }
        for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
            let Some(q) = self.query(ray, t_min, t_max[k]) else { continue };
            base[k] = q.base;
            if q.any_leaves(|first, count| test(first, count, 1 << k, &base) != 0) {
                blocked |= 1 << k;
            }
        }
        blocked
    }
}

/// Clips `ray` to `root` over `(t_min, t_max)`: the `t` the `f32` frame starts at (where the ray
/// enters the box, or `t_min`), or `None` when the ray misses the box. The slab test of
/// [`Aabb::hit`], keeping the entry distance.
#[inline(always)]
fn clip(root: &Aabb, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
    let inv = ray.dir.recip();
    let t0 = (root.min - ray.origin) * inv;
    let t1 = (root.max - ray.origin) * inv;
    let enter = t0.min(t1).max_element();
    let exit = t0.max(t1).min_element() * (1.0 + 2.0 * crate::math::float::gamma(3));
    // NaN (0 · ∞, a ray in the plane of a face) compares false: no limit, origin kept.
    if enter.max(t_min) > exit.min(t_max) {
        return None;
    }
    Some(if enter > t_min { enter } else { t_min.max(0.0) })
}

#[cfg(feature = "bvh")]
use super::wide;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::build::BVH_AVAILABLE;
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
                let hit = index.closest(&ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], &ray, 0.0, tm).map(|t| (t, ())));
                let expect = bx
                    .iter()
                    .enumerate()
                    .filter_map(|(i, b)| enter(b, &ray, 0.0, f64::INFINITY).map(|t| (i, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                assert_eq!(hit.map(|(s, t, ())| (order[s as usize] as usize, t)), expect, "start {start}, bvh {bvh}");
                let any = index.any(&ray, 0.0, f64::INFINITY, |s| enter(&stored[s as usize], &ray, 0.0, f64::INFINITY).is_some());
                assert_eq!(any, expect.is_some());
            }
        }
    }

    #[test]
    fn ties_go_to_the_smallest_slot_whatever_the_order_of_the_walk() {
        // Boxes sharing their minimum corner, of different sizes (so they fall in different
        // leaves): a ray entering through the corner region enters many at the same `t`, and the
        // walk visits them in an order that depends on the ray. The hit must be the tie in the
        // smallest slot, as the list's (which tests slots in order) is.
        let mut seed = 1u64;
        let mut next = move || {
            seed = crate::math::sampler::mix64(seed.wrapping_add(0x9e37_79b9_7f4a_7c15));
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let bx: Vec<Aabb> = (0..300).map(|_| Aabb::new(DVec3::ZERO, DVec3::new(1.0 + next(), 1.0 + next(), 1.0 + next()))).collect();
        let (index, order, _) = PrimitiveIndex::build(&bx, true);
        let stored: Vec<Aabb> = order.iter().map(|&i| bx[i as usize]).collect();
        let mut ties = 0;
        for _ in 0..2000 {
            let target = DVec3::new(next(), next(), next()) * 0.5;
            let dir = DVec3::new(0.1 + next(), 0.1 + next(), 0.1 + next()).normalize();
            let ray = Ray::new(target - 3.0 * dir, dir);
            let hit = index.closest(&ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], &ray, 0.0, tm).map(|t| (t, ())));
            let t = stored.iter().filter_map(|b| enter(b, &ray, 0.0, f64::INFINITY)).min_by(f64::total_cmp);
            let tied: Vec<u32> = (0..stored.len() as u32).filter(|&s| enter(&stored[s as usize], &ray, 0.0, f64::INFINITY) == t).collect();
            ties += usize::from(tied.len() > 1);
            assert_eq!(hit.map(|(s, t, ())| (s, t)), t.map(|t| (tied[0], t)), "{ray:?}");
        }
        assert!(ties > 1000, "{ties} rays met ties");
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
        assert!(index.closest(&ray, 0.0, f64::INFINITY, |_, t| (t > 3.0).then_some((3.0, ()))).is_some());
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

    /// Builds a hierarchy over `bx`, checks its depth bound, and that the closest box along each
    /// ray and whether any is met agree with the list.
    fn agrees_with_list(bx: &[Aabb], rays: &[Ray]) {
        let (index, order, _) = PrimitiveIndex::build(bx, true);
        assert_eq!(index.is_bvh(), BVH_AVAILABLE);
        #[cfg(feature = "bvh")]
        assert!(index.depth() <= wide::MAX_DEPTH, "depth {}", index.depth());
        let stored: Vec<Aabb> = order.iter().map(|&i| bx[i as usize]).collect();
        for ray in rays {
            let hit = index.closest(ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], ray, 0.0, tm).map(|t| (t, ())));
            let expect = bx.iter().filter_map(|b| enter(b, ray, 0.0, f64::INFINITY)).min_by(f64::total_cmp);
            assert_eq!(hit.map(|(_, t, ())| t), expect, "{ray:?}");
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
        assert!(index.depth() <= wide::MAX_DEPTH, "depth {}", index.depth());
        let stored: Vec<Aabb> = order.iter().map(|&i| bx[i as usize]).collect();
        // Through the small box in front: it is the closest.
        let ray = Ray::new(DVec3::new(0.5, 0.5, -3.0), DVec3::Z);
        let hit = index.closest(&ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], &ray, 0.0, tm).map(|t| (t, ())));
        assert_eq!(hit.map(|(s, t, ())| (order[s as usize] as usize, t)), Some((n, 2.0)));
        // Beside it: one of the coincident boxes, at the list's distance; every one is seen.
        let ray = Ray::new(DVec3::new(0.9, 0.9, -3.0), DVec3::Z);
        let hit = index.closest(&ray, 0.0, f64::INFINITY, |s, tm| enter(&stored[s as usize], &ray, 0.0, tm).map(|t| (t, ())));
        // The tie rule: of the coincident boxes, the one in the smallest slot.
        let first = (0..order.len()).find(|&s| (order[s] as usize) < n).map(|s| s as u32);
        assert!(hit.is_some_and(|(s, t, ())| Some(s) == first && t == 3.0), "{hit:?}");
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
