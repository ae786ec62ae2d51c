//! Rays and their kinds.

use glam::DVec3;
use serde::Serialize;

/// A ray `origin + t·dir`, `t ≥ 0`. `dir` is unit length (constructors normalise; code that builds
/// a `Ray` literal is responsible for that invariant).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Ray {
    /// Start point, scene units.
    pub origin: DVec3,
    /// Unit direction.
    pub dir: DVec3,
}

impl Ray {
    /// A ray from `origin` along `dir`, which is normalised here. `dir` must be non-zero and finite.
    #[inline]
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        Ray { origin, dir: dir.normalize() }
    }

    /// The point at parameter `t` (distance along the ray, since `dir` is unit length).
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.dir
    }
}

/// What a ray is for; used for ray statistics and the ray-tree explanation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RayKind {
    /// From the camera through a pixel.
    Camera,
    /// Mirror or glossy reflection.
    Reflection,
    /// Transmission through a transparent surface (refracted, or passed straight through a thin sheet).
    Refraction,
    /// Toward a light, to test visibility.
    Shadow,
}
