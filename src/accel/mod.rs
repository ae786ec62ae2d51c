//! Acceleration of ray queries over a scene's objects.
//!
//! [`ObjectAccel`] keeps unbounded objects (planes, tubes) in a small list that every ray tests,
//! and bounded ones in a [`PrimitiveIndex`]: a hierarchy when the scene has enough of them
//! ([`SCENE_BVH_THRESHOLD`] under `auto`), a list with a box test per object otherwise: for a
//! dozen analytic shapes, building a hierarchy costs more than it saves. Meshes index their own
//! triangles, so a scene of meshes is a two-level hierarchy, and a mesh placed several times is
//! stored once.

pub mod bvh;

use crate::accel::bvh::PrimitiveIndex;
pub use crate::accel::bvh::{AccelChoice, BuildStats, MESH_BVH_THRESHOLD, SCENE_BVH_THRESHOLD};
use crate::geometry::{Geometry, Hit};
use crate::math::bounds::Aabb;
use crate::math::ray::Ray;

/// The objects of a scene (or a subset of them) arranged for ray queries.
#[derive(Debug)]
pub struct ObjectAccel {
    index: PrimitiveIndex,
    /// Box and object index of each bounded object, in the index's slot order.
    bounded: Vec<(Aabb, u32)>,
    unbounded: Vec<u32>,
}

impl Default for ObjectAccel {
    fn default() -> Self {
        ObjectAccel { index: PrimitiveIndex::list(0), bounded: Vec::new(), unbounded: Vec::new() }
    }
}

impl ObjectAccel {
    /// The structure over the objects for which `keep(index)` holds (indices into `objects` are
    /// stored); a hierarchy when `choice` asks for one for this many bounded objects.
    pub fn build<G: Geometry + ?Sized>(objects: &[&G], keep: impl Fn(usize) -> bool, choice: AccelChoice) -> (Self, BuildStats) {
        let mut bounded = Vec::new();
        let mut unbounded = Vec::new();
        for (i, g) in objects.iter().enumerate().filter(|(i, _)| keep(*i)) {
            match g.bounds().filter(|b| !b.is_empty() && b.min.is_finite() && b.max.is_finite()) {
                Some(b) => bounded.push((b, i as u32)),
                None => unbounded.push(i as u32),
            }
        }
        let boxes: Vec<Aabb> = bounded.iter().map(|(b, _)| *b).collect();
        let (index, order, stats) = PrimitiveIndex::build(&boxes, choice.use_bvh(boxes.len(), SCENE_BVH_THRESHOLD));
        let bounded = order.iter().map(|&i| bounded[i as usize]).collect();
        (ObjectAccel { index, bounded, unbounded }, stats)
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

    /// Closest hit among `objects` with `t_min < t < t_max`; `Hit::object` is set.
    #[inline]
    pub fn intersect<G: Geometry + ?Sized>(&self, objects: &[Box<G>], ray: &Ray, t_min: f64, mut t_max: f64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for &i in &self.unbounded {
            if let Some(mut h) = objects[i as usize].intersect(ray, t_min, t_max) {
                h.object = i;
                t_max = h.t;
                best = Some(h);
            }
        }
        if self.index.is_bvh() {
            self.index.closest(ray, t_min, t_max, |slot, t_max| {
                let i = self.bounded[slot as usize].1;
                let mut h = objects[i as usize].intersect(ray, t_min, t_max)?;
                h.object = i;
                best = Some(h);
                Some(h.t)
            });
        } else {
            let inv = ray.dir.recip();
            for (b, i) in &self.bounded {
                if b.hit(ray, inv, t_min, t_max)
                    && let Some(mut h) = objects[*i as usize].intersect(ray, t_min, t_max)
                {
                    h.object = *i;
                    t_max = h.t;
                    best = Some(h);
                }
            }
        }
        best
    }

    /// Whether any object is hit with `t_min < t < t_max`; stops at the first.
    #[inline]
    pub fn occluded<G: Geometry + ?Sized>(&self, objects: &[Box<G>], ray: &Ray, t_min: f64, t_max: f64) -> bool {
        if self.unbounded.iter().any(|&i| objects[i as usize].occludes(ray, t_min, t_max)) {
            return true;
        }
        if self.index.is_bvh() {
            return self.index.any(ray, t_min, t_max, |slot| objects[self.bounded[slot as usize].1 as usize].occludes(ray, t_min, t_max));
        }
        let inv = ray.dir.recip();
        self.bounded.iter().any(|(b, i)| b.hit(ray, inv, t_min, t_max) && objects[*i as usize].occludes(ray, t_min, t_max))
    }
}
