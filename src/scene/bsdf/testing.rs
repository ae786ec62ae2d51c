//! Checks for material plugins' tests, as Mitsuba tests its BSDFs: a χ² test of a [`Bsdf`]'s
//! sampling against its own density, the agreement of each sample's weight and density with
//! [`Bsdf::eval`] and [`Bsdf::pdf`], and its albedo by sampling and by quadrature. The built-in
//! materials' tests use them, and so can a third-party crate's.

use crate::math::color::Color;
use crate::math::sampler::{mix64, orthonormal_basis};
use crate::scene::bsdf::Bsdf;
use crate::testing::chi2::{Chi2Outcome, Chi2Test, Sphere};
use glam::{DVec2, DVec3};
use std::f64::consts::{PI, TAU};

/// Relative agreement required between a sample's weight and density and the BSDF's own
/// `eval`·cos/`pdf` and `pdf` toward the sampled direction.
pub const SAMPLE_TOLERANCE: f64 = 1e-9;

/// A deterministic stream of uniform numbers in [0, 1) (SplitMix64), for tests.
#[derive(Clone, Debug)]
pub struct TestRng(u64);

impl TestRng {
    /// A stream from `seed`.
    pub fn new(seed: u64) -> Self {
        TestRng(mix64(seed ^ 0x9E37_79B9_7F4A_7C15))
    }

    /// The next number in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        (mix64(self.0) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// The next point in [0, 1)².
    pub fn next_2d(&mut self) -> DVec2 {
        DVec2::new(self.uniform(), self.uniform())
    }
}

/// The direction at (cos θ, φ) = (`z`, `phi`) around the frame `(t, b, n)`.
fn direction(z: f64, phi: f64, frame: (DVec3, DVec3, DVec3)) -> DVec3 {
    let (t, b, n) = frame;
    let s = (1.0 - z * z).max(0.0).sqrt();
    s * phi.cos() * t + s * phi.sin() * b + z * n
}

/// A χ² test ([`crate::testing::chi2`]) of `bsdf`'s sampling against its density (Mitsuba's
/// `chi2` test of BSDFs), run by `test` over the sphere of directions around unit `normal`
/// (taken as the test's +z, so its cells of cos θ meet at the horizon). Each sample draws its
/// lobe choice, direction and Fresnel numbers from the test's stream; specular samples (density
/// `None`) are declined, so the density must integrate to the share of samples that are not.
/// Every non-specular sample is also checked (panics with a message): its density equals
/// [`Bsdf::pdf`] toward it and its weight `eval·|cos|/pdf`, within [`SAMPLE_TOLERANCE`], cos
/// taken to `normal`; and toward every direction whose density the test integrates,
/// [`Bsdf::eval_pdf`] answers exactly (to the bit) what `eval` and `pdf` answer alone.
pub fn chi2_bsdf(bsdf: &dyn Bsdf, normal: DVec3, test: &Chi2Test<Sphere>) -> Chi2Outcome {
    let (t, b) = orthonormal_basis(normal);
    let local = |d: DVec3| DVec3::new(d.dot(t), d.dot(b), d.dot(normal));
    let world = |l: DVec3| l.x * t + l.y * b + l.z * normal;
    test.run(
        |u| {
            let (pick, uv, fresnel) = (u.next_1d(), u.next_2d(), u.next_1d());
            let s = bsdf.sample(pick, uv, fresnel)?;
            let pdf = s.pdf?;
            let expected = bsdf.pdf(s.dir);
            assert!((pdf - expected).abs() <= SAMPLE_TOLERANCE * expected.abs().max(1.0), "sample {s:?}: density {pdf}, pdf() {expected}");
            let w = bsdf.eval(s.dir) * s.dir.dot(normal).abs() / expected;
            let scale = w.abs().max_element().max(1.0);
            assert!((s.weight - w).abs().max_element() <= SAMPLE_TOLERANCE * scale, "sample {s:?}: weight vs eval·cos/pdf {w}");
            Some(local(s.dir))
        },
        |l| {
            let d = world(l);
            let (f, pdf) = (bsdf.eval(d), bsdf.pdf(d));
            let (f2, pdf2) = bsdf.eval_pdf(d);
            let bits = |c: Color| c.to_array().map(f64::to_bits);
            assert!(
                bits(f) == bits(f2) && pdf.to_bits() == pdf2.to_bits(),
                "toward {d}: eval_pdf ({f2}, {pdf2}), eval and pdf ({f}, {pdf})"
            );
            pdf
        },
    )
}

/// The directional albedo of `bsdf` (the light it scatters back of light arriving from its
/// `wo`), estimated with `n` of its own samples: the mean weight (specular events included),
/// and the standard error of that mean (per channel, its largest).
pub fn sampled_albedo(bsdf: &dyn Bsdf, n: u32, seed: u64) -> (Color, f64) {
    let mut rng = TestRng::new(seed);
    let (mut sum, mut sum2) = (Color::ZERO, Color::ZERO);
    for _ in 0..n {
        let (pick, u, fresnel) = (rng.uniform(), rng.next_2d(), rng.uniform());
        if let Some(s) = bsdf.sample(pick, u, fresnel) {
            sum += s.weight;
            sum2 += s.weight * s.weight;
        }
    }
    let nf = f64::from(n);
    let mean = sum / nf;
    let var = (sum2 / nf - mean * mean).max(Color::ZERO);
    (mean, (var / nf).max_element().sqrt())
}

/// The directional albedo of `bsdf`'s non-specular lobes by quadrature: `∫ eval(ω)·|cos θ| dω`
/// over the sphere around unit `normal` (midpoint rule, `res × 2·res` cells in θ and φ, finest
/// near the normal, where lobes seen head-on are narrowest).
pub fn quadrature_albedo(bsdf: &dyn Bsdf, normal: DVec3, res: usize) -> Color {
    let (t, b) = orthonormal_basis(normal);
    let frame = (t, b, normal);
    let (dtheta, dphi) = (PI / res as f64, TAU / (2 * res) as f64);
    let mut sum = Color::ZERO;
    for i in 0..res {
        let (sin, z) = ((i as f64 + 0.5) * dtheta).sin_cos();
        for j in 0..2 * res {
            let phi = (j as f64 + 0.5) * dphi;
            sum += bsdf.eval(direction(z, phi, frame)) * (z.abs() * sin);
        }
    }
    sum * dtheta * dphi
}
