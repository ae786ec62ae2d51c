//! The [`LightSource`] trait: how much light arrives at a point, from where, and how likely a
//! light's own sampling was to pick that direction.

pub mod testing;

use crate::math::color::Color;
use crate::math::ray::Ray;
use glam::{DVec2, DVec3};

/// Light arriving at a point from one light (or one sample point of an area light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shaded point toward the light (the report's `−L`).
    pub dir: DVec3,
    /// Distance to the light along `dir`, scene units; `f64::INFINITY` for directional lights.
    /// Shadow rays test for occluders closer than this.
    pub distance: f64,
    /// Intensity arriving at the point (linear RGB), attenuation included. For an area light it
    /// is the light's whole contribution as estimated from this one point: the mean over `u`
    /// uniform in [0, 1]² of the samples' intensities is the light's intensity at the point.
    pub intensity: Color,
}

/// The probability density with which [`LightSource::illuminate`] chooses a sample's direction,
/// for `u` uniform in [0, 1]²: what a Monte Carlo integrator needs to weigh the light's sampling
/// against its own (multiple importance sampling).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightPdf {
    /// The light arrives from one direction only (point, spot and directional lights): no other
    /// strategy can find it, and rays cannot meet it.
    Delta,
    /// Density per unit solid angle at the shaded point, sr⁻¹ (> 0; infinite where the emitter is
    /// seen edge-on). The light's incident radiance along the sample's direction, in the units of
    /// `intensity` per steradian, is `intensity × pdf`.
    SolidAngle(f64),
}

impl LightPdf {
    /// The solid-angle density of a point chosen on an emitter with density `per_area` (per unit
    /// area, e.g. `1 / area` for uniform points), seen from `distance` away at angle `cos_light`
    /// (cosine between the emitter's normal and the direction to the shaded point):
    /// `per_area × distance² / |cos_light|`.
    #[inline]
    pub fn from_area(per_area: f64, distance: f64, cos_light: f64) -> LightPdf {
        LightPdf::SolidAngle(per_area * distance * distance / cos_light.abs())
    }

    /// The density per unit solid angle; `None` for a delta light.
    #[inline]
    pub fn solid_angle(self) -> Option<f64> {
        match self {
            LightPdf::Delta => None,
            LightPdf::SolidAngle(p) => Some(p),
        }
    }
}

/// What a light says of itself that cannot change during a render
/// ([`LightSource::is_area`], [`LightSource::sample_count`]), asked once when the scene is built
/// ([`crate::Scene::light_facts`]) so integrators do not ask again at every hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightFacts {
    /// [`LightSource::is_area`].
    pub is_area: bool,
    /// [`LightSource::sample_count`].
    pub sample_count: u32,
    /// [`LightSource::illuminates`].
    pub illuminates: bool,
    /// The light is the scene's surroundings ([`LightSource::environment`] answers): rays that
    /// leave the scene see it instead of the background.
    pub environment: bool,
    /// [`LightSource::uniform`].
    pub uniform: bool,
}

impl LightFacts {
    /// The facts `light` reports.
    pub fn of(light: &dyn LightSource) -> LightFacts {
        LightFacts {
            is_area: light.is_area(),
            sample_count: light.sample_count(),
            illuminates: light.illuminates(),
            environment: light.environment(DVec3::Y).is_some(),
            uniform: light.uniform(),
        }
    }
}

/// What bounds every sample a light can give at a point ([`LightSource::bound`]). An integrator
/// may skip a light whose samples would all be skipped (all behind the surface, all negligible)
/// without drawing one. The bounds hold for exact arithmetic; a user allows for rounding.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBound {
    /// Centre of a ball holding every point a sample can come from.
    pub centre: DVec3,
    /// Radius of that ball, scene units, ≥ 0.
    pub radius: f64,
    /// At least each channel's magnitude of any sample's `intensity` at the point.
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

    /// [`LightSource::illuminate`] and the density with which it drew the sample
    /// ([`LightSource::pdf`]), in one call. A light that knows that density as it draws (an
    /// environment, from its sampling grid) should answer it here rather than find it again from
    /// the direction (for an environment, a turn into image coordinates and a lookup: a third of
    /// its cost per sample); the default asks [`LightSource::pdf`].
    fn illuminate_pdf(&self, p: DVec3, u: DVec2) -> Option<(LightSample, LightPdf)> {
        let sample = self.illuminate(p, u)?;
        Some((sample, self.pdf(p, &sample)))
    }

    /// [`LightSource::illuminate_pdf`] at a point `p` lit only from the side unit `n` faces: the
    /// same sample's direction, distance and density, but where `dir · n ≤ 0` (light the caller
    /// discards unseen) a light may leave the intensity zero rather than look it up (an
    /// environment image: a bilinear lookup and a division, for nearly half of a surface's
    /// samples). The default is `illuminate_pdf`.
    fn illuminate_facing(&self, p: DVec3, n: DVec3, u: DVec2) -> Option<(LightSample, LightPdf)> {
        let _ = n;
        self.illuminate_pdf(p, u)
    }

    /// The density with which `illuminate(p, u)`, for `u` uniform in [0, 1]², picks `sample`'s
    /// direction (a sample it returned for `p`, or one [`LightSource::intersect`] returned for a
    /// ray from `p`). Monte Carlo integrators weigh light samples with it; `phong` never asks.
    /// The default, [`LightPdf::Delta`], is right for lights that arrive from one direction.
    fn pdf(&self, p: DVec3, sample: &LightSample) -> LightPdf {
        let _ = (p, sample);
        LightPdf::Delta
    }

    /// Where `ray` meets this light's emitter first, closer than `t_max`: the sample
    /// [`LightSource::illuminate`] would give at `ray.origin` for that point of the emitter
    /// (`dir` the ray's, `distance` along it; its density is `pdf(ray.origin, &sample)`), so an
    /// integrator that sampled the direction itself can weigh it against the light's sampling
    /// (multiple importance sampling). `None` when the ray misses, when the emitter sends no
    /// light toward the origin, and for lights without an extent (the default: rays cannot hit a
    /// point or a direction).
    fn intersect(&self, ray: &Ray, t_max: f64) -> Option<LightSample> {
        let _ = (ray, t_max);
        None
    }

    /// True when [`LightSource::intersect`] answers the ray from `p` toward every sample
    /// [`LightSource::illuminate`] gives at `p` with a density per solid angle (the sample lies
    /// on the emitter a ray can meet; up to rounding at the emitter's edges): an integrator then
    /// weighs such a sample against its own rays without asking `intersect` (for a rectangle, a
    /// plane and two edge tests at every light sample). False (the default): it asks.
    /// [`testing::check_light`] checks the claim.
    fn meets_its_samples(&self) -> bool {
        false
    }

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

    /// False for a light whose [`LightSource::illuminate`] never gives a sample (an ambient
    /// light, all of whose light is [`LightSource::ambient`]): an integrator may skip it when it
    /// gathers direct light.
    fn illuminates(&self) -> bool {
        true
    }

    /// A bound on the samples [`LightSource::illuminate`] gives at `p`, for any `u`; `None` (the
    /// default) when the light has none (directional and ambient lights), and then every sample
    /// is taken.
    fn bound(&self, p: DVec3) -> Option<LightBound> {
        let _ = p;
        None
    }

    /// For a light infinitely far away all around the scene (an environment: a sky, an image of
    /// surroundings), the radiance arriving along unit direction `-dir`, i.e. seen by a ray
    /// leaving the scene along `dir`: rays that leave the scene see it in place of the
    /// scene's background. `None` (the default) for every other light. A light answers for
    /// every direction or for none. Its samples ([`LightSource::illuminate`]) come from infinitely
    /// far (`distance` ∞) and its [`LightSource::intersect`] answers rays that leave the scene
    /// (`t_max` ∞), so a Monte Carlo integrator weighs it like any light with an extent.
    fn environment(&self, dir: DVec3) -> Option<Color> {
        let _ = dir;
        None
    }

    /// True for an environment of one radiance along every direction (a constant colour): no
    /// sampling of its own can follow a surface's response × cosine better than the surface's
    /// own sampled rays (which meet it whenever nothing is in the way), so a Monte Carlo
    /// integrator that samples BSDFs may leave this light to those rays, in full, and spend no
    /// shadow ray on it. False (the default) for every other light.
    fn uniform(&self) -> bool {
        false
    }

    /// For an environment light ([`LightSource::environment`] answers), what a Monte Carlo
    /// integrator weighs a ray that leaves the scene from `origin` along unit `dir` with, in one
    /// call: the radiance arriving along it ([`LightSource::environment`]`(dir)`) and the density
    /// per steradian with which [`LightSource::illuminate`] at `origin` picks `dir` ([`LightSource::pdf`]
    /// of the sample [`LightSource::intersect`] gives for that ray); `None` for every other light
    /// (and for a delta density). The default asks those three; an environment that can answer
    /// both from one lookup (one turn of the direction into image coordinates) should, as this is
    /// asked for every ray that leaves the scene.
    fn environment_pdf(&self, origin: DVec3, dir: DVec3) -> Option<(Color, f64)> {
        let radiance = self.environment(dir)?;
        let sample = self.intersect(&Ray { origin, dir }, f64::INFINITY)?;
        Some((radiance, self.pdf(origin, &sample).solid_angle()?))
    }
}

impl<T: LightSource + ?Sized> LightSource for Box<T> {
    fn illuminate(&self, p: DVec3, u: DVec2) -> Option<LightSample> {
        (**self).illuminate(p, u)
    }
    fn illuminate_pdf(&self, p: DVec3, u: DVec2) -> Option<(LightSample, LightPdf)> {
        (**self).illuminate_pdf(p, u)
    }
    fn illuminate_facing(&self, p: DVec3, n: DVec3, u: DVec2) -> Option<(LightSample, LightPdf)> {
        (**self).illuminate_facing(p, n, u)
    }
    fn pdf(&self, p: DVec3, sample: &LightSample) -> LightPdf {
        (**self).pdf(p, sample)
    }
    fn intersect(&self, ray: &Ray, t_max: f64) -> Option<LightSample> {
        (**self).intersect(ray, t_max)
    }
    fn meets_its_samples(&self) -> bool {
        (**self).meets_its_samples()
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
    fn illuminates(&self) -> bool {
        (**self).illuminates()
    }
    fn bound(&self, p: DVec3) -> Option<LightBound> {
        (**self).bound(p)
    }
    fn environment(&self, dir: DVec3) -> Option<Color> {
        (**self).environment(dir)
    }
    fn uniform(&self) -> bool {
        (**self).uniform()
    }
    fn environment_pdf(&self, origin: DVec3, dir: DVec3) -> Option<(Color, f64)> {
        (**self).environment_pdf(origin, dir)
    }
}
