//! Acceleration of ray queries over a scene's objects.
//!
//! [`ObjectList`] tests every object, bounding boxes first. It is the right structure for small
//! scenes (a dozen analytic shapes), where building a hierarchy costs more than it saves.

use crate::bounds::Aabb;
use crate::geometry::{Geometry, Hit};
use crate::ray::Ray;

/// Every object in a flat list; bounded objects are culled by their box before the exact test.
#[derive(Clone, Debug, Default)]
pub struct ObjectList {
    bounded: Vec<(Aabb, u32)>,
    unbounded: Vec<u32>,
}

impl ObjectList {
    /// The list over the objects for which `keep(index)` holds (indices into `objects` are stored).
    pub fn build<G: Geometry + ?Sized>(objects: &[&G], keep: impl Fn(usize) -> bool) -> Self {
        let mut list = ObjectList::default();
        for (i, g) in objects.iter().enumerate().filter(|(i, _)| keep(*i)) {
            match g.bounds() {
                Some(b) => list.bounded.push((b, i as u32)),
                None => list.unbounded.push(i as u32),
            }
        }
        list
    }

    /// True when the list holds no object.
    pub fn is_empty(&self) -> bool {
        self.bounded.is_empty() && self.unbounded.is_empty()
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
        let inv = ray.dir.recip();
        for &(b, i) in &self.bounded {
            if b.hit(ray, inv, t_min, t_max) {
                if let Some(mut h) = objects[i as usize].intersect(ray, t_min, t_max) {
                    h.object = i;
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
        let inv = ray.dir.recip();
        self.bounded.iter().any(|&(b, i)| b.hit(ray, inv, t_min, t_max) && objects[i as usize].occludes(ray, t_min, t_max))
    }
}
