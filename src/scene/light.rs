//! The [`LightSource`] trait: how much light arrives at a point, from where.

use crate::math::color::Color;
use glam::{DVec2, DVec3};

/// Light arriving at a point from one light (or one sample point of an area light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shaded point toward the light (the report's `−L`).
    pub dir: DVec3,
    /// Distance to the light along `dir`, scene units; `f64::INFINITY` for directional lights.
    /// Shadow rays test for occluders closer than this.
    pub distance: f64,
    /// Intensity arriving at the point (linear RGB), attenuation included.
    pub intensity: Color,
}

/// A source of light.
pub trait LightSource: Send + Sync {
    /// Light arriving at `p`. `u` ∈ [0, 1]² picks a point on an area light's emitter (uniform
    /// samples for estimates; the square's corners should map to the emitter's extreme points,
    /// which integrators use as probes); point-like lights ignore it. `None` when the light has no direction
    /// at `p` (an ambient light, or `p` at the light itself). A light that cannot reach `p`
    /// (outside a spot's cone) returns a sample of zero intensity, so the integrator decides, and
    /// counts, what it skips.
    fn illuminate(&self, p: DVec3, u: DVec2) -> Option<LightSample>;

    /// Constant light this source adds everywhere, independent of direction (ambient light).
    /// Zero for lights with a position or direction.
    fn ambient(&self) -> Color {
        Color::ZERO
    }

    /// Number of shadow samples an integrator should take (1 for point-like lights; area lights
    /// may ask for more to resolve penumbrae).
    fn sample_count(&self) -> u32 {
        1
    }

    /// True for lights with an extent (whose samples depend on `u`): an integrator may override
    /// their [`LightSource::sample_count`] with its own shadow-ray count.
    fn is_area(&self) -> bool {
        false
    }
}

impl<T: LightSource + ?Sized> LightSource for Box<T> {
    fn illuminate(&self, p: DVec3, u: DVec2) -> Option<LightSample> {
        (**self).illuminate(p, u)
    }
    fn ambient(&self) -> Color {
        (**self).ambient()
    }
    fn sample_count(&self) -> u32 {
        (**self).sample_count()
    }
    fn is_area(&self) -> bool {
        (**self).is_area()
    }
}
