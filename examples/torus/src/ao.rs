//! `ao`: ambient occlusion, a view of how open each visible point is to its surroundings (the
//! integrator of `docs/writing-a-plugin.md`).
//!
//! At the first hit, `rays` rays leave in a cosine-weighted hemisphere around the normal (facing
//! the camera); the colour is the material's `kd` times the fraction that meet nothing within
//! `distance`. Sample directions come from the pixel's [`Sampler`], stratified, so the image is
//! deterministic and independent of the thread count. No allocation per ray.

use raylab::math::sampler::{concentric_disc, stratified_2d};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::render::aov::AovSample;
use raylab::render::stats::{Counter, CounterKind};
use raylab::{Color, Integrator, Intersectable, LoadContext, PluginInfo, Ray, RayStats, Sampler, Scene};

/// The `ao` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "ao",
    summary: "Ambient occlusion: kd × the fraction of a cosine-weighted hemisphere around the normal that is open within `distance`. Rays that miss show the background (or the environment light).",
    params: &[
        ParamSpec::new("rays", ParamKind::Int, ParamDefault::Int(16), "occlusion rays per camera ray, 1..4096"),
        ParamSpec::new(
            "distance",
            ParamKind::Float,
            ParamDefault::Optional,
            "only occluders closer than this count, scene units (> 0); default: any",
        ),
    ],
};

/// Index of the occlusion-ray counter in [`COUNTERS`].
const OCCLUSION_RAYS: usize = 0;

/// What `ao` counts (printed by `--stats`).
const COUNTERS: &[Counter] = &[Counter::new("occlusion_rays", CounterKind::Rays, "occlusion rays")];

/// Ambient occlusion.
#[derive(Clone, Debug)]
pub struct AmbientOcclusion {
    rays: u32,
    distance: f64,
}

/// Builds the integrator from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Integrator>> {
    let rays = p.int_in("rays", 1..=4096)? as u32;
    let distance = p.float_opt("distance")?.unwrap_or(f64::INFINITY);
    if !(distance > 0.0) {
        return Err(p.error_at("distance", "expected a distance > 0"));
    }
    Ok(Box::new(AmbientOcclusion { rays, distance }))
}

impl Integrator for AmbientOcclusion {
    fn radiance(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler, stats: &mut RayStats, aov: &mut AovSample) -> Color {
        let Some(si) = scene.trace(ray) else { return scene.escaped(ray.dir) };
        let n = si.n;
        let (t, b) = n.any_orthonormal_pair();
        let pattern = sampler.next_pattern();
        let mut open = 0;
        for i in 0..self.rays {
            // Cosine-weighted direction: a uniform disc point lifted onto the hemisphere.
            let d = concentric_disc(stratified_2d(i, self.rays, pattern));
            let dir = d.x * t + d.y * b + (1.0 - d.length_squared()).max(0.0).sqrt() * n;
            stats.add(OCCLUSION_RAYS, 1);
            if !scene.occludes(&si.spawn_ray(dir), 0.0, self.distance) {
                open += 1;
            }
        }
        let kd = si.coefficients().kd;
        *aov = AovSample::surface(&si, kd);
        kd * (f64::from(open) / f64::from(self.rays))
    }

    fn counters(&self) -> &'static [Counter] {
        COUNTERS
    }

    fn worst_case_rays(&self, _: &Scene) -> f64 {
        1.0 + f64::from(self.rays)
    }

    fn describe(&self) -> String {
        format!("rays {}, distance {}", self.rays, self.distance)
    }
}
