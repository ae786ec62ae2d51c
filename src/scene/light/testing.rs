//! Checks for light plugins' tests: a light's samples, the rays that meet it and its densities
//! tell one story, so a Monte Carlo integrator can combine its own directions with the light's
//! ([`LightSource::intersect`], [`LightPdf`]). The built-in lights' tests use it, and so can a
//! third-party crate's; [`chi2_light`] tests a light's sampling against its density.

use crate::math::color::Color;
use crate::math::ray::Ray;
use crate::math::sampler::stratified_2d;
use crate::scene::light::{LightPdf, LightSource};
use crate::testing::chi2::{Chi2Outcome, Chi2Test, Sphere};
use glam::{DQuat, DVec3};
use std::f64::consts::{PI, TAU};

/// Relative agreement required between a light's sample and the same point met by a ray.
pub const SAMPLE_TOLERANCE: f64 = 1e-9;

/// Checks `light` as seen from `p`, with `n` stratified samples (enough that their mean
/// intensity is accurate to `relative`; panics with a message on failure):
///
/// - every sample lies within the light's [`LightSource::bound`] (if it has one), and its
///   intensity within the bound's (both within [`SAMPLE_TOLERANCE`], relative);
/// - a light whose samples are [`LightPdf::Delta`] ([`LightSource::pdf`]) is met by no ray;
/// - otherwise every sample that carries light (every sample, when the light says
///   [`LightSource::meets_its_samples`]) comes back from [`LightSource::intersect`] for
///   the ray from `p` along its direction, with the same distance, intensity and density
///   (within [`SAMPLE_TOLERANCE`], relative);
/// - the radiance the light's samples imply (`intensity × pdf`), integrated over all directions
///   from `p` (rays on a `grid × 2·grid` grid in θ, φ), equals the mean intensity of its samples
///   within `relative`: the densities are those of the sampling.
///
/// Returns the integral and the mean.
pub fn check_light(light: &dyn LightSource, p: DVec3, n: u32, grid: u32, relative: f64) -> (Color, Color) {
    let mut mean = Color::ZERO;
    let mut delta = false;
    for i in 0..n {
        let Some(ls) = light.illuminate(p, stratified_2d(i, n, 0x5eed)) else {
            panic!("the light has no direction at {p}: nothing to check");
        };
        mean += ls.intensity / f64::from(n);
        if let Some(b) = light.bound(p) {
            if ls.distance.is_finite() {
                let from_centre = (p + ls.dir * ls.distance - b.centre).length();
                let slack = SAMPLE_TOLERANCE * (b.radius + (b.centre - p).length());
                assert!(
                    from_centre <= b.radius + slack,
                    "sample {ls:?} is {from_centre} from the bound's centre, beyond its radius {}",
                    b.radius
                );
            }
            let over = ls.intensity.abs() - b.intensity * (1.0 + SAMPLE_TOLERANCE);
            assert!(over.max_element() <= 0.0, "sample {ls:?} is brighter than the bound {}", b.intensity);
        }
        let met = light.intersect(&Ray { origin: p, dir: ls.dir }, f64::INFINITY);
        let LightPdf::SolidAngle(pdf) = light.pdf(p, &ls) else {
            delta = true;
            assert!(met.is_none(), "a ray met a delta light (sample {ls:?})");
            continue;
        };
        // A light that says rays meet its samples is met there, whatever the sample carries.
        assert!(!light.meets_its_samples() || met.is_some(), "the light says rays meet its samples, but not sample {ls:?} from {p}");
        if !(ls.intensity.max_element() > 0.0) {
            continue;
        }
        let m = met.unwrap_or_else(|| panic!("the ray toward sample {ls:?} from {p} does not meet the light"));
        // Equal infinities (an environment's distance) are close too.
        let close = |a: f64, b: f64| a == b || (a - b).abs() <= SAMPLE_TOLERANCE * a.abs().max(b.abs());
        assert!(close(m.distance, ls.distance), "distance: sample {} vs ray {}", ls.distance, m.distance);
        assert!((0..3).all(|c| close(m.intensity[c], ls.intensity[c])), "intensity: sample {} vs ray {}", ls.intensity, m.intensity);
        let met_pdf = light.pdf(p, &m).solid_angle().expect("a ray met the light: its density is per solid angle");
        assert!(close(met_pdf, pdf), "density: sample {pdf} vs ray {met_pdf}");
    }
    if delta {
        return (Color::ZERO, mean);
    }
    let (dt, dp) = (PI / f64::from(grid), TAU / f64::from(2 * grid));
    let mut integral = Color::ZERO;
    for i in 0..grid {
        let theta = (f64::from(i) + 0.5) * dt;
        for j in 0..2 * grid {
            let phi = (f64::from(j) + 0.5) * dp;
            let dir = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            if let Some(m) = light.intersect(&Ray { origin: p, dir }, f64::INFINITY) {
                let pdf = light.pdf(p, &m).solid_angle().expect("a ray met the light: its density is per solid angle");
                integral += m.intensity * pdf * theta.sin() * dt * dp;
            }
        }
    }
    assert!(
        (integral - mean).abs().max_element() <= relative * mean.max_element(),
        "the radiance over all directions, {integral}, is not the samples' mean intensity {mean}"
    );
    (integral, mean)
}

/// A χ² test ([`crate::testing::chi2`]) of `light`'s sampling as seen from `p`: the directions
/// of `illuminate(p, u)` for uniform `u` against the density [`LightSource::pdf`] gives the ray
/// from `p` that meets the light there ([`LightSource::intersect`]; zero where no ray meets it).
/// The directions are turned so the centre of the light's [`LightSource::bound`] lies on the
/// sphere's equator, where the histogram's cells are finest (place `p` so the light spans tens
/// of degrees). A delta light has nothing to test: it panics.
pub fn chi2_light(light: &dyn LightSource, p: DVec3, test: &Chi2Test<Sphere>) -> Chi2Outcome {
    let toward = light.bound(p).map_or(DVec3::X, |b| (b.centre - p).normalize_or(DVec3::X));
    // A rotation taking `toward` to +x (its inverse is its transpose).
    let turn = DQuat::from_rotation_arc(toward, DVec3::X);
    let back = turn.inverse();
    test.run(
        |u| {
            let s = light.illuminate(p, u.next_2d())?;
            assert!(light.pdf(p, &s) != LightPdf::Delta, "a delta light has no density to test");
            Some(turn * s.dir)
        },
        |w| {
            let dir = back * w;
            light.intersect(&Ray { origin: p, dir }, f64::INFINITY).and_then(|m| light.pdf(p, &m).solid_angle()).unwrap_or(0.0)
        },
    )
}
