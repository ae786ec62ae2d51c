//! Checks for material plugins' tests, as Mitsuba tests its BSDFs: a χ² test of a [`Bsdf`]'s
//! sampling against its own density, the agreement of each sample's weight and density with
//! [`Bsdf::eval`] and [`Bsdf::pdf`], and its albedo by sampling and by quadrature. The built-in
//! materials' tests use them, and so can a third-party crate's.

use crate::math::color::Color;
use crate::math::sampler::{mix64, orthonormal_basis};
use crate::scene::bsdf::Bsdf;
use glam::{DVec2, DVec3};
use std::f64::consts::{PI, TAU};

/// Relative agreement required between a sample's weight and density and the BSDF's own
/// `eval`·cos/`pdf` and `pdf` toward the sampled direction.
pub const SAMPLE_TOLERANCE: f64 = 1e-9;

/// How far inside a cell (as a fraction of its side) the integration points on its edges are
/// read.
const EDGE_NUDGE: f64 = 1e-9;

/// Smallest expected count of a χ² cell; cells expecting fewer are pooled into one (the usual
/// rule that keeps the statistic χ²-distributed).
pub const MIN_EXPECTED: f64 = 5.0;

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

/// What [`chi2_test`] found.
#[derive(Clone, Debug)]
pub struct Chi2 {
    /// The statistic.
    pub statistic: f64,
    /// Degrees of freedom (cells after pooling, less one).
    pub dof: usize,
    /// The probability of a statistic at least this large if the samples follow the density.
    pub p_value: f64,
    /// Fraction of the `n` samples that gave a non-specular direction.
    pub sampled: f64,
    /// The density integrated over the sphere (the fraction of samples it predicts).
    pub integral: f64,
}

/// The sphere's cell of unit `d` in a `res × 2·res` grid over (cos θ, φ) around the frame
/// `(t, b, n)`: cells of equal solid angle.
fn cell(d: DVec3, frame: (DVec3, DVec3, DVec3), res: usize) -> usize {
    let (t, b, n) = frame;
    let z = d.dot(n).clamp(-1.0, 1.0);
    let phi = d.dot(b).atan2(d.dot(t)).rem_euclid(TAU);
    let i = (((z + 1.0) / 2.0 * res as f64) as usize).min(res - 1);
    let j = ((phi / TAU * (2 * res) as f64) as usize).min(2 * res - 1);
    i * 2 * res + j
}

/// The direction at (cos θ, φ) = (`z`, `phi`) around the frame.
fn direction(z: f64, phi: f64, frame: (DVec3, DVec3, DVec3)) -> DVec3 {
    let (t, b, n) = frame;
    let s = (1.0 - z * z).max(0.0).sqrt();
    s * phi.cos() * t + s * phi.sin() * b + z * n
}

/// χ² test of `bsdf`'s sampling against its density (Mitsuba's `chi2` test of BSDFs): `n`
/// samples (lobe choice, direction and Fresnel numbers from a [`TestRng`] of `seed`) binned in a
/// `res × 2·res` grid of equal solid angle over the sphere around unit `normal`, against the
/// counts [`Bsdf::pdf`] predicts (each cell integrated by Simpson's rule on a `sub × sub` grid). Specular samples
/// (density `None`) are left out of both. Every non-specular sample is also checked (panics
/// with a message): its density equals `pdf` toward it and its weight `eval·|cos|/pdf`, within
/// [`SAMPLE_TOLERANCE`], cos taken to `normal`.
pub fn chi2_test(bsdf: &dyn Bsdf, normal: DVec3, n: u32, res: usize, sub: usize, seed: u64) -> Chi2 {
    let (t, b) = orthonormal_basis(normal);
    let frame = (t, b, normal);
    let mut rng = TestRng::new(seed);
    let mut observed = vec![0.0f64; 2 * res * res];
    let mut sampled = 0u32;
    for _ in 0..n {
        let (pick, u, fresnel) = (rng.uniform(), rng.next_2d(), rng.uniform());
        let Some(s) = bsdf.sample(pick, u, fresnel) else { continue };
        let Some(pdf) = s.pdf else { continue };
        let expected = bsdf.pdf(s.dir);
        assert!((pdf - expected).abs() <= SAMPLE_TOLERANCE * expected.abs().max(1.0), "sample {s:?}: density {pdf}, pdf() {expected}");
        let w = bsdf.eval(s.dir) * s.dir.dot(normal).abs() / expected;
        let scale = w.abs().max_element().max(1.0);
        assert!((s.weight - w).abs().max_element() <= SAMPLE_TOLERANCE * scale, "sample {s:?}: weight vs eval·cos/pdf {w}");
        observed[cell(s.dir, frame, res)] += 1.0;
        sampled += 1;
    }
    // The expected counts: the density integrated over each cell by Simpson's rule on a
    // `sub × sub` grid (`sub` even; every cell has solid angle 4π / (2·res²)). The points on a
    // cell's edges are nudged inside, so that a density that jumps at the horizon is read from
    // the cell's side.
    let sub = sub.max(2) & !1;
    let mut expected = vec![0.0f64; 2 * res * res];
    let (dz, dphi) = (2.0 / res as f64, TAU / (2 * res) as f64);
    let simpson = |k: usize| {
        if k == 0 || k == sub {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        }
    };
    let inside = |k: usize| (k as f64 / sub as f64).clamp(EDGE_NUDGE, 1.0 - EDGE_NUDGE);
    let mut integral = 0.0;
    for i in 0..res {
        for j in 0..2 * res {
            let mut sum = 0.0;
            for a in 0..=sub {
                let z = -1.0 + (i as f64 + inside(a)) * dz;
                for c in 0..=sub {
                    let phi = (j as f64 + inside(c)) * dphi;
                    sum += simpson(a) * simpson(c) * bsdf.pdf(direction(z, phi, frame));
                }
            }
            let mass = sum / (9.0 * (sub * sub) as f64) * dz * dphi;
            integral += mass;
            expected[i * 2 * res + j] = mass * f64::from(n);
        }
    }
    // Pool the cells that expect few samples.
    let (mut statistic, mut cells) = (0.0, 0usize);
    let (mut pooled_o, mut pooled_e) = (0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < MIN_EXPECTED {
            pooled_o += o;
            pooled_e += e;
        } else {
            statistic += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pooled_e > 0.0 {
        statistic += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        cells += 1;
    } else if pooled_o > 0.0 {
        // Samples where the density says none can be.
        statistic = f64::INFINITY;
    }
    let dof = cells.saturating_sub(1).max(1);
    Chi2 { statistic, dof, p_value: chi2_survival(statistic, dof as f64), sampled: f64::from(sampled) / f64::from(n), integral }
}

/// `P(X ≥ x)` for `X` χ²-distributed with `k` degrees of freedom: `Q(k/2, x/2)`.
pub fn chi2_survival(x: f64, k: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        return 0.0;
    }
    1.0 - regularized_gamma_p(k / 2.0, x / 2.0)
}

/// The regularised lower incomplete gamma function `P(a, x)` (series for `x < a + 1`, Lentz's
/// continued fraction otherwise; Numerical Recipes §6.2).
pub fn regularized_gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let ln_prefix = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (sum * ln_prefix.exp()).min(1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (1.0 - ln_prefix.exp() * h).max(0.0)
    }
}

/// `ln Γ(x)` for `x > 0` (Lanczos, g = 7, n = 9).
pub fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (TAU).ln() + (x + 0.5) * t.ln() - t + a.ln()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_chi2_distribution_is_right() {
        // Known quantiles: P(X ≥ 3.841) = 0.05 for k = 1; P(X ≥ 18.307) = 0.05 for k = 10;
        // P(X ≥ 124.342) = 0.05 for k = 100.
        for (x, k) in [(3.841_458_820_694_124, 1.0), (18.307_038_053_275_146, 10.0), (124.342_113_404_060_3, 100.0)] {
            let p = chi2_survival(x, k);
            assert!((p - 0.05).abs() < 1e-6, "k {k}: {p}");
        }
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
    }
}
