//! A block of camera hits shaded together (`Integrator::radiance_packet`) against the same hits
//! shaded lane by lane (`radiance_from`): what the packet tests of analytic scenes and of meshes
//! both check.

use raylab::render::RenderJob;
use raylab::render::aov::AovSample;
use raylab::render::sample::{SampleId, image_setup, single_camera_ray};
use raylab::{Color, Intersectable, Ray, RayStats, Sampler};

/// The camera rays of pixels `x0..x0 + 8` of row `y` (sample 0), the lanes set in `live` traced
/// as one packet, then shaded as one block and lane by lane under each work budget of
/// `allowances` (guide layers on the odd ones): asserts that every lane gets the same colour,
/// layers and counters both ways. `at` names the scene in failures. Returns how many blocks it
/// compared.
pub fn assert_block_shades_as_single_hits(
    job: &RenderJob,
    at: &str,
    (x0, y): (u32, u32),
    live: u32,
    allowances: impl IntoIterator<Item = u64>,
) -> usize {
    let (scene, integrator, setup) = (&job.scene, &job.integrator, image_setup(job));
    let rays: [Ray; 8] =
        std::array::from_fn(|k| single_camera_ray(job, &setup, SampleId::Pixel { x: x0 + k as u32, y, index: 0 }).unwrap());
    let mut hit = [raylab::geometry::Hit::new(0.0, raylab::glam::DVec3::ZERO, raylab::glam::DVec3::ZERO); 8];
    let hits = scene.intersect_packet(&rays, live, 0.0, &[f64::INFINITY; 8], &mut hit);
    let mut blocks = 0;
    for allowance in allowances {
        let guides = allowance % 2 == 1;
        let fresh = || {
            let mut stats = RayStats::new(integrator.counters());
            stats.set_allowance(allowance);
            let samplers: [Sampler; 8] = std::array::from_fn(|k| Sampler::new(u64::from(x0) + k as u64, 0, 7));
            let aovs = [AovSample { guides, ..AovSample::miss(scene.background) }; 8];
            (stats, samplers, aovs, [Color::ZERO; 8])
        };
        let (mut s1, mut r1, mut a1, mut c1) = fresh();
        integrator.radiance_packet(scene, &rays, live, hits, &hit, &mut r1, &mut s1, &mut a1, &mut c1);
        let (mut s2, mut r2, mut a2, mut c2) = fresh();
        for k in (0..8).filter(|k| live >> k & 1 != 0) {
            s2.camera_rays += 1;
            let h = (hits >> k & 1 != 0).then_some(&hit[k]);
            c2[k] = integrator.radiance_from(scene, &rays[k], h, &mut r2[k], &mut s2, &mut a2[k]);
        }
        let at = format!("{at}, row {y}, x {x0}, lanes {live:08b}, allowance {allowance}");
        assert_eq!(c1, c2, "{at}");
        assert_eq!(a1, a2, "{at}");
        assert_eq!((s1.camera_rays, s1.rays()), (s2.camera_rays, s2.rays()), "{at}");
        for (i, c) in integrator.counters().iter().enumerate() {
            assert_eq!(s1.count(i), s2.count(i), "{at}: {}", c.name);
        }
        blocks += 1;
    }
    blocks
}
