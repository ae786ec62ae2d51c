//! Acceleration of ray queries over a scene's objects.
//!
//! [`ObjectAccel`] keeps unbounded objects (planes, tubes) in a small list that every ray tests,
//! and bounded ones in a [`PrimitiveIndex`]: a hierarchy when the scene has enough of them
//! ([`SCENE_BVH_THRESHOLD`] under `auto`), a list with a box test per object otherwise: for a
//! dozen analytic shapes, building a hierarchy costs more than it saves (a lone bounded object
//! gets no box test: its own test culls as well, and a mesh clips rays to its box). A list tests
//! its boxes four at a time ([`list`]: the same answers as one by one), then the objects whose
//! box the ray meets, in order. Meshes index
//! their own triangles, so a scene of meshes is a two-level hierarchy, and a mesh placed several
//! times is stored once.

pub mod build;
pub mod bvh;
mod list;
#[cfg(feature = "bvh")]
mod wide;

use crate::accel::bvh::PrimitiveIndex;
use crate::accel::list::BoxLanes;

pub use crate::accel::build::{AccelChoice, BVH_AVAILABLE, BuildStats, MESH_BVH_THRESHOLD, SCENE_BVH_THRESHOLD};
use crate::geometry::{Hit, Intersectable, PACKET};
use crate::math::bounds::Aabb;
use crate::math::ray::Ray;

/// The compiled copy of the hierarchy traversal this process runs: `avx2` (x86-64 CPUs with AVX2
/// and FMA), `baseline` (others, or the environment variable `RAYLAB_SIMD=baseline`), or `none`
/// without the `bvh` feature. Every copy gives the same results.
pub fn traversal_kernel() -> &'static str {
    #[cfg(feature = "bvh")]
    return wide::Kernel::detect().name();
    #[cfg(not(feature = "bvh"))]
    "none"
}

/// The objects of a scene (or a subset of them) arranged for ray queries.
#[derive(Debug)]
pub struct ObjectAccel {
    index: PrimitiveIndex,
    /// Box and object index of each bounded object, in the index's slot order.
    bounded: Vec<(Aabb, u32)>,
    unbounded: Vec<u32>,
    /// A list's boxes in packs, tested together (empty for a hierarchy).
    lanes: BoxLanes,
    /// The slot of each object of a list, by object index (`usize::MAX`: none).
    slot_of: Vec<usize>,
}

impl Default for ObjectAccel {
    fn default() -> Self {
        ObjectAccel {
            index: PrimitiveIndex::list(0),
            bounded: Vec::new(),
            unbounded: Vec::new(),
            lanes: BoxLanes::default(),
            slot_of: Vec::new(),
        }
    }
}

impl ObjectAccel {
    /// The structure over the objects for which `keep(index)` holds, given each object's box
    /// (`None`: unbounded); indices into `bounds` are stored. A hierarchy when `choice` asks for
    /// one for this many bounded objects.
    pub fn build(bounds: &[Option<Aabb>], keep: impl Fn(usize) -> bool, choice: AccelChoice) -> (Self, BuildStats) {
        let mut bounded = Vec::new();
        let mut unbounded = Vec::new();
        for (i, b) in bounds.iter().enumerate().filter(|(i, _)| keep(*i)) {
            match b.filter(|b| !b.is_empty() && b.min.is_finite() && b.max.is_finite()) {
                Some(b) => bounded.push((b, i as u32)),
                None => unbounded.push(i as u32),
            }
        }
        let boxes: Vec<Aabb> = bounded.iter().map(|(b, _)| *b).collect();
        let (index, order, stats) = PrimitiveIndex::build(&boxes, choice.use_bvh(boxes.len(), SCENE_BVH_THRESHOLD));
        let bounded: Vec<(Aabb, u32)> = order.iter().map(|&i| bounded[i as usize]).collect();
        let (lanes, slot_of) = if index.is_bvh() {
            (BoxLanes::default(), Vec::new())
        } else {
            let mut slot_of = vec![usize::MAX; bounds.len()];
            for (slot, (_, i)) in bounded.iter().enumerate() {
                slot_of[*i as usize] = slot;
            }
            (BoxLanes::new(bounded.iter().map(|(b, _)| *b)), slot_of)
        };
        (ObjectAccel { index, bounded, unbounded, lanes, slot_of }, stats)
    }

    /// The slot of object `i` in a list (`usize::MAX` when it is not in one).
    #[inline]
    fn slot_of(&self, i: u32) -> usize {
        self.slot_of.get(i as usize).copied().unwrap_or(usize::MAX)
    }

    /// The structure over `objects` (the slice it was built for), answering ray queries.
    #[inline]
    pub fn over<'a, O>(&'a self, objects: &'a [O]) -> Accelerated<'a, O> {
        Accelerated { accel: self, objects }
    }

    /// True when the structure holds no object.
    pub fn is_empty(&self) -> bool {
        self.bounded.is_empty() && self.unbounded.is_empty()
    }

    /// True when the bounded objects are in a hierarchy.
    pub fn is_bvh(&self) -> bool {
        self.index.is_bvh()
    }

    /// Number of (bounded, unbounded) objects.
    pub fn counts(&self) -> (usize, usize) {
        (self.bounded.len(), self.unbounded.len())
    }
}

/// An [`ObjectAccel`] over the objects it indexes: closest and any hit among them, with
/// [`Hit::object`] set to the object's index.
#[derive(Clone, Copy)]
pub struct Accelerated<'a, O> {
    accel: &'a ObjectAccel,
    objects: &'a [O],
}

impl<O: Intersectable> Intersectable for Accelerated<'_, O> {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let mut best = Hit::new(0.0, glam::DVec3::ZERO, glam::DVec3::ZERO);
        self.closest::<false>(ray, t_min, t_max, (u32::MAX, 0), &mut best).then_some(best)
    }
    #[inline]
    fn intersect_into(&self, ray: &Ray, t_min: f64, t_max: f64, hit: &mut Hit) -> bool {
        self.closest::<false>(ray, t_min, t_max, (u32::MAX, 0), hit)
    }

    /// The unbounded objects ray by ray, then a lone bounded object's own packet query
    /// ([`Intersectable::intersect_packet`]) with each ray's limit lowered to its hit so far, or
    /// the hierarchy walked by the packet ([`PrimitiveIndex::closest_packet_leaves`]) with each
    /// ray's exact tests at the leaves; with a list, ray by ray. Each ray's answer is
    /// [`Accelerated::intersect`]'s.
    #[inline]
    fn intersect_packet(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        let (accel, objects) = (self.accel, self.objects);
        let mut hits = 0;
        let lone = match accel.bounded[..] {
            [(_, i)] if !accel.index.is_bvh() => i,
            _ if accel.index.is_bvh() => return self.intersect_packet_bvh(rays, live, t_min, t_max, out),
            _ => {
                for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
                    if let Some(h) = self.intersect(ray, t_min, t_max[k]) {
                        out[k] = h;
                        hits |= 1 << k;
                    }
                }
                return hits;
            }
        };
        let mut limit = *t_max;
        for &i in &accel.unbounded {
            for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
                if let Some(h) = objects[i as usize].intersect(ray, t_min, limit[k]) {
                    out[k] = Hit { object: i, ..h };
                    limit[k] = h.t;
                    hits |= 1 << k;
                }
            }
        }
        // As in `intersect`: a lone bounded object is asked without its box test.
        let mut found = objects[lone as usize].intersect_packet(rays, live, t_min, &limit, out);
        hits |= found;
        while found != 0 {
            let k = found.trailing_zeros() as usize;
            found &= found - 1;
            out[k].object = lone;
        }
        hits
    }

    /// True when the bounded objects are in a hierarchy (walked by the packet), or are one
    /// object that walks packets.
    fn walks_packets(&self) -> bool {
        self.accel.index.is_bvh() || matches!(self.accel.bounded[..], [(_, i)] if self.objects[i as usize].walks_packets())
    }

    /// Stops at the first object hit.
    #[inline]
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        let (accel, objects) = (self.accel, self.objects);
        if accel.unbounded.iter().any(|&i| objects[i as usize].occludes(ray, t_min, t_max)) {
            return true;
        }
        if accel.index.is_bvh() {
            return self.any_bvh_except(ray, t_min, t_max, u32::MAX);
        }
        if let [(_, i)] = accel.bounded[..] {
            return objects[i as usize].occludes(ray, t_min, t_max);
        }
        // The boxes met, in slot order ([`BoxLanes::visit`]: `Aabb::hit`'s answers).
        accel.lanes.visit(ray.origin, ray.dir.recip(), t_min, t_max, usize::MAX, usize::MAX, |slot, _| {
            objects[accel.bounded[slot].1 as usize].occludes(ray, t_min, t_max)
        })
    }
}

/// Asks `o` for a hit closer than `t_max` into `best` ([`Intersectable::intersect_into`]), or,
/// when `LEAVING` and `leaves`, [`Intersectable::intersect_leaving`] its primitive `prim`; true
/// when it wrote one.
#[inline(always)]
fn test<O: Intersectable, const LEAVING: bool>(o: &O, ray: &Ray, t_min: f64, t_max: f64, leaves: bool, prim: u32, best: &mut Hit) -> bool {
    if LEAVING && leaves {
        match o.intersect_leaving(ray, t_min, t_max, prim) {
            Some(h) => {
                *best = h;
                true
            }
            None => false,
        }
    } else {
        o.intersect_into(ray, t_min, t_max, best)
    }
}

impl<O: Intersectable> Accelerated<'_, O> {
    /// [`Intersectable::intersect`] into `best` (as [`Intersectable::intersect_into`]: written
    /// only when a hit is found, and then true); with `LEAVING`, object `own` is asked
    /// [`Intersectable::intersect_leaving`] its primitive `prim`, without its box (its test is
    /// exact either way, and a flat primitive skips it), or not at all where it is flat
    /// ([`Intersectable::is_flat`]: it has nothing to answer): [`Accelerated::intersect_leaving`].
    /// The closest hit so far is kept in `best`, which the objects write into. The hierarchy's
    /// walk is out of line: a list's query keeps a small frame.
    #[inline(always)]
    fn closest<const LEAVING: bool>(&self, ray: &Ray, t_min: f64, mut t_max: f64, (own, prim): (u32, u32), best: &mut Hit) -> bool {
        let (accel, objects) = (self.accel, self.objects);
        // Whether the own object is asked at all (a flat one meets nothing of itself).
        let own_asked = LEAVING && objects.get(own as usize).is_some_and(|o| !o.is_flat());
        let mut found = false;
        for &i in &accel.unbounded {
            let leaves = LEAVING && i == own;
            if leaves && !own_asked {
                continue;
            }
            if test::<O, LEAVING>(&objects[i as usize], ray, t_min, t_max, leaves, prim, best) {
                best.object = i;
                t_max = best.t;
                found = true;
            }
        }
        if accel.index.is_bvh() {
            return self.closest_bvh::<LEAVING>(ray, t_min, t_max, (own, prim), own_asked, best) || found;
        }
        if let [(_, i)] = accel.bounded[..] {
            // One bounded object: its own test culls as well as its box would (a mesh clips the
            // ray to its box anyway), without the three divisions of the box test.
            let leaves = LEAVING && i == own;
            if (!leaves || own_asked) && test::<O, LEAVING>(&objects[i as usize], ray, t_min, t_max, leaves, prim, best) {
                best.object = i;
                found = true;
            }
            return found;
        }
        // The boxes met within the limit, in slot order, all at once ([`BoxLanes::visit`]:
        // `Aabb::hit`'s answers); each is tested again against the limit as it shrinks. The own
        // object is asked at its place without its box, or left out when flat.
        let own_slot = if LEAVING { accel.slot_of(own) } else { usize::MAX };
        let (always, never) = if own_asked { (own_slot, usize::MAX) } else { (usize::MAX, own_slot) };
        accel.lanes.visit(ray.origin, ray.dir.recip(), t_min, t_max, always, never, |slot, near| {
            let leaves = LEAVING && slot == always;
            let i = accel.bounded[slot].1;
            if (leaves || !(near > t_max)) && test::<O, LEAVING>(&objects[i as usize], ray, t_min, t_max, leaves, prim, best) {
                best.object = i;
                t_max = best.t;
                found = true;
            }
            false
        });
        found
    }

    /// [`Accelerated::closest`]'s walk of a hierarchy, below the hits `best` already holds (up
    /// to `t_max`).
    #[inline(never)]
    fn closest_bvh<const LEAVING: bool>(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        (own, prim): (u32, u32),
        own_asked: bool,
        best: &mut Hit,
    ) -> bool {
        let (accel, objects) = (self.accel, self.objects);
        // Ties go to the smallest slot (the index's tie rule); unbounded objects, tested first,
        // win ties with bounded ones.
        let found = accel.index.closest(ray, t_min, t_max, |slot, limit| {
            let i = accel.bounded[slot as usize].1;
            let mut h = if LEAVING && i == own {
                if !own_asked {
                    return None;
                }
                objects[i as usize].intersect_leaving(ray, t_min, limit, prim)?
            } else {
                objects[i as usize].intersect(ray, t_min, limit)?
            };
            h.object = i;
            Some((h.t, h))
        });
        found.map(|(_, _, h)| *best = h).is_some()
    }

    /// [`Intersectable::intersect`] for a ray leaving `from`, a hit of one of these objects (the
    /// ray spawned off it: a path's next ray): the same hit, for less work where `from`'s
    /// primitive is flat ([`Intersectable::intersect_leaving`]).
    #[inline]
    pub fn intersect_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, from: &Hit) -> Option<Hit> {
        let mut best = Hit::new(0.0, glam::DVec3::ZERO, glam::DVec3::ZERO);
        self.intersect_leaving_into(ray, t_min, t_max, from, &mut best).then_some(best)
    }

    /// [`Accelerated::intersect_leaving`] into `hit`, as [`Intersectable::intersect_into`]:
    /// written only when a hit is found, and then true.
    #[inline]
    pub fn intersect_leaving_into(&self, ray: &Ray, t_min: f64, t_max: f64, from: &Hit, hit: &mut Hit) -> bool {
        self.closest::<true>(ray, t_min, t_max, (from.object, from.prim), hit)
    }

    /// [`Intersectable::intersect_packet`] over a hierarchy: the unbounded objects ray by ray
    /// (they win ties, as in [`Accelerated::intersect`]), then the rays walk the hierarchy
    /// together and each ray tests the objects of the leaves its own slab tests enter, keeping
    /// the index's tie rule ([`bvh::tie_limit`]: once a ray holds a hit, objects are asked up to
    /// its tie limit and one is kept when closer, or as close in a smaller slot), so each ray's
    /// hit is the one [`PrimitiveIndex::closest`] finds whatever the order of the leaves.
    #[inline]
    fn intersect_packet_bvh(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        let (accel, objects) = (self.accel, self.objects);
        let mut hits = 0u32;
        let mut limit = *t_max;
        for &i in &accel.unbounded {
            let mut found = objects[i as usize].intersect_packet(rays, live, t_min, &limit, out);
            hits |= found;
            while found != 0 {
                let k = found.trailing_zeros() as usize;
                found &= found - 1;
                out[k].object = i;
                limit[k] = out[k].t;
            }
        }
        // The slot of each ray's hit among the bounded objects (`PAD_SLOT`: none yet), and each
        // object's hits for the rays that reach its leaf (kept when they win).
        let mut slot_of = [bvh::PAD_SLOT; PACKET];
        let mut found = [Hit::new(0.0, glam::DVec3::ZERO, glam::DVec3::ZERO); PACKET];
        accel.index.closest_packet_leaves(rays, live, t_min, &mut limit, |first, count, rays_in, limit, _| {
            for slot in first..first + count {
                let mut upto = *limit;
                let mut m = rays_in;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    if slot_of[k] != bvh::PAD_SLOT {
                        upto[k] = bvh::tie_limit(limit[k]);
                    }
                }
                let i = accel.bounded[slot as usize].1;
                let mut m = objects[i as usize].intersect_packet(rays, rays_in, t_min, &upto, &mut found);
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let h = &found[k];
                    if slot_of[k] == bvh::PAD_SLOT || h.t < limit[k] || (h.t == limit[k] && slot < slot_of[k]) {
                        out[k] = Hit { object: i, ..*h };
                        limit[k] = h.t;
                        slot_of[k] = slot;
                        hits |= 1 << k;
                    }
                }
            }
        });
        hits
    }

    /// [`Intersectable::occludes`] for a shadow ray leaving `from`, a hit of one of these
    /// objects (the ray's origin moved off it toward the ray): the others as by `occludes`, then
    /// `from`'s own object, asked [`Intersectable::occludes_leaving`] its primitive (which a flat
    /// one skips). The own object is asked without its box: its test is exact either way.
    #[inline]
    pub fn occludes_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, from: &Hit) -> bool {
        let (accel, objects, own) = (self.accel, self.objects, from.object);
        let other = |i: u32| i != own && objects[i as usize].occludes(ray, t_min, t_max);
        if accel.unbounded.iter().any(|&i| other(i)) {
            return true;
        }
        let blocked = if accel.index.is_bvh() {
            self.any_bvh_except(ray, t_min, t_max, own)
        } else if let [(_, i)] = accel.bounded[..] {
            other(i)
        } else {
            // The own object is asked below, without its box.
            let never = accel.slot_of(own);
            accel.lanes.visit(ray.origin, ray.dir.recip(), t_min, t_max, usize::MAX, never, |slot, _| other(accel.bounded[slot].1))
        };
        // A flat own object meets nothing of itself ([`Intersectable::is_flat`]).
        let o = &objects[own as usize];
        blocked || (!o.is_flat() && o.occludes_leaving(ray, t_min, t_max, from.prim))
    }

    /// [`Accelerated::occludes_leaving`] for the shadow rays `rays[k]` of mask `live`, ray `k` up
    /// to `t_max[k]` and leaving `from[k]`: the mask of the rays blocked, exactly
    /// `occludes_leaving`'s answers. The unbounded objects ray by ray, then a lone bounded
    /// object's packet query ([`Intersectable::occludes_packet`]) for the rays still open, each
    /// leaving out its primitive where it leaves that object; with other arrangements, ray by
    /// ray.
    #[inline]
    pub fn occludes_packet_leaving(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], from: &[Hit; PACKET]) -> u32 {
        let (accel, objects) = (self.accel, self.objects);
        let mut blocked = 0u32;
        let lone = match accel.bounded[..] {
            [(_, i)] if !accel.index.is_bvh() => i,
            _ if accel.index.is_bvh() => return self.occludes_packet_leaving_bvh(rays, live, t_min, t_max, from),
            _ => {
                for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
                    blocked |= u32::from(self.occludes_leaving(ray, t_min, t_max[k], &from[k])) << k;
                }
                return blocked;
            }
        };
        for &i in &accel.unbounded {
            let o = &objects[i as usize];
            let mut m = live & !blocked;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let hit = match from[k].object == i {
                    true => o.occludes_leaving(&rays[k], t_min, t_max[k], from[k].prim),
                    false => o.occludes(&rays[k], t_min, t_max[k]),
                };
                blocked |= u32::from(hit) << k;
            }
        }
        let open = live & !blocked;
        if open == 0 {
            return blocked;
        }
        let mut leaving = 0u32;
        let mut prims = [0u32; PACKET];
        for k in 0..PACKET {
            leaving |= u32::from(from[k].object == lone) << k;
            prims[k] = from[k].prim;
        }
        // As in `occludes`: a lone bounded object is asked without its box test.
        blocked | objects[lone as usize].occludes_packet(rays, open, t_min, t_max, leaving & open, &prims)
    }

    /// [`Accelerated::occludes_packet_leaving`] over a hierarchy: what
    /// [`Accelerated::occludes_leaving`] asks each ray, asked for the packet: the unbounded
    /// objects other than the ray's own, then the rays still open walk the hierarchy together
    /// ([`PrimitiveIndex::any_packet_leaves`], a ray leaving the walk once blocked) and each leaf's
    /// object is asked for the rays that do not leave it ([`Intersectable::occludes_packet`]),
    /// then each ray's own object, asked [`Intersectable::occludes_leaving`] its primitive. A
    /// union of exact answers, so each ray's is `occludes_leaving`'s.
    #[inline]
    fn occludes_packet_leaving_bvh(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], from: &[Hit; PACKET]) -> u32 {
        let (accel, objects) = (self.accel, self.objects);
        let mut blocked = 0u32;
        let own: [u32; PACKET] = std::array::from_fn(|k| from[k].object);
        let prims: [u32; PACKET] = std::array::from_fn(|k| from[k].prim);
        let except = |i: u32, m: u32| {
            let mut keep = m;
            let mut n = m;
            while n != 0 {
                let k = n.trailing_zeros() as usize;
                n &= n - 1;
                if own[k] == i {
                    keep &= !(1 << k);
                }
            }
            keep
        };
        for &i in &accel.unbounded {
            let open = except(i, live & !blocked);
            if open != 0 {
                blocked |= objects[i as usize].occludes_packet(rays, open, t_min, t_max, 0, &prims);
            }
        }
        let open = live & !blocked;
        if open != 0 {
            blocked |= accel.index.any_packet_leaves(rays, open, t_min, t_max, |first, count, m, _| {
                let mut hit = 0u32;
                for slot in first..first + count {
                    let i = accel.bounded[slot as usize].1;
                    let ask = except(i, m & !hit);
                    if ask != 0 {
                        hit |= objects[i as usize].occludes_packet(rays, ask, t_min, t_max, 0, &prims);
                    }
                }
                hit
            });
        }
        let mut m = live & !blocked;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            if objects[own[k] as usize].occludes_leaving(&rays[k], t_min, t_max[k], prims[k]) {
                blocked |= 1 << k;
            }
        }
        blocked
    }

    /// Whether a bounded object other than `skip` is hit with `t_min < t < t_max`, the hierarchy
    /// walked out of line (a list's query keeps a small frame).
    #[inline(never)]
    fn any_bvh_except(&self, ray: &Ray, t_min: f64, t_max: f64, skip: u32) -> bool {
        let (accel, objects) = (self.accel, self.objects);
        accel.index.any(ray, t_min, t_max, |slot| {
            let i = accel.bounded[slot as usize].1;
            i != skip && objects[i as usize].occludes(ray, t_min, t_max)
        })
    }

    /// [`Intersectable::occludes`] leaving out object `skip` (the object not asked): for a
    /// shadow ray that object cannot stop (an emitter's own point, facing the ray, on a convex
    /// shape).
    #[inline]
    pub fn occludes_except(&self, ray: &Ray, t_min: f64, t_max: f64, skip: u32) -> bool {
        let (accel, objects) = (self.accel, self.objects);
        if accel.unbounded.iter().any(|&i| i != skip && objects[i as usize].occludes(ray, t_min, t_max)) {
            return true;
        }
        if accel.index.is_bvh() {
            return self.any_bvh_except(ray, t_min, t_max, skip);
        }
        if let [(_, i)] = accel.bounded[..] {
            return i != skip && objects[i as usize].occludes(ray, t_min, t_max);
        }
        accel.lanes.visit(ray.origin, ray.dir.recip(), t_min, t_max, usize::MAX, accel.slot_of(skip), |slot, _| {
            objects[accel.bounded[slot].1 as usize].occludes(ray, t_min, t_max)
        })
    }
}
