//! The [`Integrator`] trait: turns a camera ray into a colour.

use crate::geometry::{Hit, PACKET};
use crate::math::color::Color;
use crate::math::ray::Ray;
use crate::math::ray::RayKind;
use crate::math::sampler::Sampler;
use crate::render::aov::AovSample;
use crate::render::stats::{Counter, RayStats};
use crate::render::trace::{MAX_EXPLAINED_RAYS, TraceNode};
use crate::scene::Scene;

/// A light-transport algorithm: the recursive Phong model, a path tracer, a debug view…
///
/// Implementations must be deterministic given the sampler (draw every random number from it)
/// and must not allocate per ray in [`Integrator::radiance`]. The usual shape is one recursion
/// generic over a [`crate::render::trace::Recorder`], called with
/// [`crate::render::trace::NoRecord`] by `radiance` and with a [`TraceNode`] by `explain`, so the
/// explanation is exactly what the render computed.
pub trait Integrator: Send + Sync {
    /// The colour seen along the camera ray `ray` (linear RGB). Counts work in `stats` (with the
    /// indices of [`Integrator::counters`]) and describes the first surface met in `aov`
    /// (left as [`AovSample::miss`] when nothing is hit).
    fn radiance(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler, stats: &mut RayStats, aov: &mut AovSample) -> Color;

    /// [`Integrator::radiance`] with the camera ray's closest hit already found: `hit` is what
    /// `scene.intersect(ray, 0.0, f64::INFINITY)` returns (the render loop finds the hits of a
    /// block's camera rays together, [`crate::geometry::Intersectable::intersect_packet`]). Must
    /// return exactly what `radiance` returns. Called only when
    /// [`Integrator::takes_camera_hits`] is true; the default asks the scene again.
    fn radiance_from(
        &self,
        scene: &Scene,
        ray: &Ray,
        hit: Option<&Hit>,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        aov: &mut AovSample,
    ) -> Color {
        let _ = hit;
        self.radiance(scene, ray, sampler, stats, aov)
    }

    /// [`Integrator::radiance_from`] for the camera rays `rays[k]` of mask `live` (a packet of
    /// one sample each of neighbouring pixels), with their closest hits: `hit[k]` where bit `k`
    /// of `hits` is set, none where it is not. Each ray's camera ray is counted here
    /// (`stats.camera_rays`), and its colour written to `out[k]`, with `samplers[k]` and
    /// `aovs[k]` as `radiance_from` would use them; the colours, layers and counters must be
    /// exactly those of `radiance_from` called lane by lane, each lane's camera ray counted just
    /// before it (as the default does), whatever the work budget allows. An integrator that
    /// shades a packet together (shadow rays of the block toward one light walked as a packet)
    /// overrides it. Called only when [`Integrator::takes_camera_hits`] is true.
    #[allow(clippy::too_many_arguments)]
    fn radiance_packet(
        &self,
        scene: &Scene,
        rays: &[Ray; PACKET],
        live: u32,
        hits: u32,
        hit: &[Hit; PACKET],
        samplers: &mut [Sampler; PACKET],
        stats: &mut RayStats,
        aovs: &mut [AovSample; PACKET],
        out: &mut [Color; PACKET],
    ) {
        let mut m = live;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            stats.camera_rays += 1;
            let h = (hits >> k & 1 != 0).then_some(&hit[k]);
            out[k] = self.radiance_from(scene, &rays[k], h, &mut samplers[k], stats, &mut aovs[k]);
        }
    }

    /// Whether [`Integrator::radiance_from`] uses the hit it is given (then the render loop
    /// traces camera rays in packets where the scene walks them).
    fn takes_camera_hits(&self) -> bool {
        false
    }

    /// The same computation as [`Integrator::radiance`] with the same sampler, recorded as a ray
    /// tree for `raylab trace`; `None` when the integrator cannot explain itself.
    fn explain(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler) -> Option<TraceNode> {
        let _ = (scene, ray, sampler);
        None
    }

    /// The counters this integrator keeps, in the order of the indices it counts with; printed by
    /// `--stats` and summed across threads. Camera rays are counted by the render loop.
    fn counters(&self) -> &'static [Counter] {
        &[]
    }

    /// Most rays (the camera ray, its shadow rays and every secondary ray) one camera ray can
    /// cost in `scene`: the factor of the work budget checked before rendering
    /// ([`crate::param::limits::Limits::max_rays`]); may be infinite. The default counts the camera
    /// ray and every light's shadow samples at one hit; an integrator that branches or recurses
    /// must give its own bound.
    fn worst_case_rays(&self, scene: &Scene) -> f64 {
        1.0 + scene.lights.iter().map(|l| f64::from(l.sample_count().max(1))).sum::<f64>()
    }

    /// One line describing the settings, for the render summary (e.g. `max_depth 3, prune 0.001`).
    fn describe(&self) -> String {
        String::new()
    }
}

/// [`Integrator::explain`] for an integrator written as one recursion over a
/// [`crate::render::trace::Recorder`]: `camera` is that recursion for a camera ray (the one
/// [`Integrator::radiance`] runs with [`crate::render::trace::NoRecord`]), run here with the ray
/// tree's root as its recorder, counters of its own (`counters`, allowed
/// [`MAX_EXPLAINED_RAYS`]) and an AovSample nobody reads.
pub fn explain_recursion(
    scene: &Scene,
    ray: &Ray,
    counters: &'static [Counter],
    camera: impl FnOnce(&mut RayStats, &mut AovSample, &mut TraceNode) -> Color,
) -> Option<TraceNode> {
    let mut stats = RayStats::new(counters);
    stats.set_allowance(MAX_EXPLAINED_RAYS);
    let mut aov = AovSample::miss(scene.background);
    let mut root = TraceNode::new(RayKind::Camera, *ray, 0, Color::ONE);
    camera(&mut stats, &mut aov, &mut root);
    Some(root)
}
