//! χ² goodness-of-fit tests for sampling routines: does a routine draw its points with the density
//! it claims? In the style of Mitsuba 3's `mi.chi2` (and pbrt-v4's `bsdfs_test.cpp`):
//!
//! 1. draw `samples` points from the routine (fed by a seeded [`Uniform`] stream);
//! 2. count them in the cells of a histogram over a 2-D parameterisation of the domain (for
//!    directions, [`Sphere`]: φ and cos θ, whose cells have equal solid angle; for points,
//!    [`Rect`]);
//! 3. the expected count of each cell is `samples ×` the integral of the claimed density over it
//!    (composite Simpson's rule on a sub-grid of each cell; a finer midpoint rule near the edge
//!    of the density's support);
//! 4. cells expected to hold fewer than [`Chi2Test::min_expected`] points are pooled together
//!    (the statistic is unreliable for them); points where the density is zero fail the test at
//!    once (beyond [`ZERO_DENSITY_ALLOWANCE`], for rounding at the edge of the support);
//! 5. Pearson's statistic and its degrees of freedom give a p-value (the regularised upper
//!    incomplete gamma function); the test fails when it is below the significance level,
//!    corrected (Šidák) for the number of tests run: `1 − (1 − α)^(1/tests)`.
//!
//! A routine may decline to give a point (return `None`, as a BSDF does for a direction below
//! the surface): the density then integrates to the fraction it accepts, and the test checks that
//! too. The stream is seeded, so a run is reproducible; a failure's message names the seed, the
//! statistic and the cells that deviate most, with their observed and expected counts.
//!
//! ```
//! use raylab::glam::DVec3;
//! use raylab::testing::chi2::{Chi2Test, Sphere};
//! use std::f64::consts::PI;
//! // Uniform directions on the sphere, density 1 / 4π.
//! Chi2Test::new(Sphere)
//!     .samples(50_000)
//!     .run(|u| {
//!         let (z, phi) = (1.0 - 2.0 * u.next_1d(), 2.0 * PI * u.next_1d());
//!         let r = (1.0 - z * z).sqrt();
//!         Some(DVec3::new(r * phi.cos(), r * phi.sin(), z))
//!     }, |_| 1.0 / (4.0 * PI))
//!     .assert_passes("uniform sphere");
//! ```
//!
//! Every sampling routine raylab ships has such a test beside it (lights, BSDF lobes, glossy fans,
//! the lens); a new one gets one too. Plugin crates use this module the same way.

use glam::{DVec2, DVec3};
use std::f64::consts::{PI, TAU};
use std::fmt;

/// A seeded stream of uniform numbers in [0, 1) (SplitMix64) for the routine under test.
#[derive(Clone, Debug)]
pub struct Uniform {
    state: u64,
}

impl Uniform {
    /// The stream for `seed`.
    pub fn new(seed: u64) -> Self {
        Uniform { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// The next number in [0, 1).
    pub fn next_1d(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// The next pair in [0, 1)².
    pub fn next_2d(&mut self) -> DVec2 {
        DVec2::new(self.next_1d(), self.next_1d())
    }
}

/// A domain of samples and its parameterisation by the unit square, on which the histogram's
/// cells are laid out.
pub trait Domain {
    /// A sample: a direction, a point.
    type Point: Copy + fmt::Debug;
    /// The point's parameters in [0, 1]², `None` when it is not in the domain.
    fn parameters_of(&self, p: Self::Point) -> Option<DVec2>;
    /// The point with parameters `a` ∈ [0, 1]².
    fn point_at(&self, a: DVec2) -> Self::Point;
    /// The measure of the domain per unit of parameter area (constant: the parameterisation
    /// preserves area up to this factor).
    fn jacobian(&self) -> f64;
    /// The cell between parameters `lo` and `hi`, in the domain's own terms.
    fn describe(&self, lo: DVec2, hi: DVec2) -> String;
}

/// Unit directions, densities per steradian. Parameters: `φ / 2π` (azimuth about +z, from +x)
/// and `(1 − cos θ) / 2` (θ from +z), so every cell spans the same solid angle.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sphere;

/// How far from unit length a direction may be and still count as one.
pub const UNIT_TOLERANCE: f64 = 1e-6;

impl Domain for Sphere {
    type Point = DVec3;

    fn parameters_of(&self, d: DVec3) -> Option<DVec2> {
        if !d.is_finite() || (d.length() - 1.0).abs() > UNIT_TOLERANCE {
            return None;
        }
        let phi = d.y.atan2(d.x).rem_euclid(TAU);
        Some(DVec2::new(phi / TAU, ((1.0 - d.z) / 2.0).clamp(0.0, 1.0)))
    }

    fn point_at(&self, a: DVec2) -> DVec3 {
        let z = 1.0 - 2.0 * a.y;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (s, c) = (TAU * a.x).sin_cos();
        DVec3::new(r * c, r * s, z)
    }

    fn jacobian(&self) -> f64 {
        4.0 * PI
    }

    fn describe(&self, lo: DVec2, hi: DVec2) -> String {
        let theta = |b: f64| (1.0 - 2.0 * b).clamp(-1.0, 1.0).acos().to_degrees();
        format!("θ {:.1}°–{:.1}°, φ {:.1}°–{:.1}°", theta(lo.y), theta(hi.y), lo.x * 360.0, hi.x * 360.0)
    }
}

/// Points of the rectangle `[min, max]` of the plane, densities per unit area.
#[derive(Clone, Copy, Debug)]
pub struct Rect {
    /// The lower corner.
    pub min: DVec2,
    /// The upper corner.
    pub max: DVec2,
}

impl Domain for Rect {
    type Point = DVec2;

    fn parameters_of(&self, p: DVec2) -> Option<DVec2> {
        let a = (p - self.min) / (self.max - self.min);
        (a.is_finite() && a.cmpge(DVec2::ZERO).all() && a.cmple(DVec2::ONE).all()).then_some(a)
    }

    fn point_at(&self, a: DVec2) -> DVec2 {
        self.min + a * (self.max - self.min)
    }

    fn jacobian(&self) -> f64 {
        let s = self.max - self.min;
        s.x * s.y
    }

    fn describe(&self, lo: DVec2, hi: DVec2) -> String {
        let (lo, hi) = (self.point_at(lo), self.point_at(hi));
        format!("x {:.4}–{:.4}, y {:.4}–{:.4}", lo.x, hi.x, lo.y, hi.y)
    }
}

/// A χ² test of a sampling routine over domain `D` (see the module docs). Build it with
/// [`Chi2Test::new`] and the setters, then [`Chi2Test::run`].
#[derive(Clone, Debug)]
pub struct Chi2Test<D: Domain> {
    /// What the samples are.
    pub domain: D,
    /// Cells along the two parameters (for [`Sphere`]: φ, then cos θ).
    pub res: (u32, u32),
    /// Points drawn.
    pub samples: u32,
    /// Seed of the [`Uniform`] stream.
    pub seed: u64,
    /// Simpson sub-intervals per cell side when integrating the density (even, ≥ 2).
    pub integration: u32,
    /// Cells expected to hold fewer points than this are pooled.
    pub min_expected: f64,
    /// Significance level α of the whole family of tests.
    pub significance: f64,
    /// How many tests share α (Šidák correction).
    pub tests: u32,
}

/// The seed every test starts from unless it sets its own.
pub const DEFAULT_SEED: u64 = 0x5eed_c0de_cafe_f00d;

/// How far above 1 the integral of a claimed density may come (the integration's error near the
/// density's discontinuities) before the test fails.
pub const MASS_TOLERANCE: f64 = 0.01;

impl<D: Domain> Chi2Test<D> {
    /// A test over `domain` with Mitsuba's defaults scaled to a debug-build test suite: 10⁵
    /// samples, 40 × 20 cells, 8 Simpson intervals per cell side (the midpoint rule on a
    /// 64 × 64 grid near the edge of the density's support), pooling below 5 expected points,
    /// α = 1 %, one test.
    pub fn new(domain: D) -> Self {
        Chi2Test {
            domain,
            res: (40, 20),
            samples: 100_000,
            seed: DEFAULT_SEED,
            integration: 8,
            min_expected: 5.0,
            significance: 0.01,
            tests: 1,
        }
    }

    /// Sets the number of points drawn.
    pub fn samples(mut self, samples: u32) -> Self {
        self.samples = samples;
        self
    }

    /// Sets the histogram's resolution.
    pub fn res(mut self, first: u32, second: u32) -> Self {
        self.res = (first.max(1), second.max(1));
        self
    }

    /// Sets the seed.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Sets how many tests share the significance level.
    pub fn tests(mut self, tests: u32) -> Self {
        self.tests = tests.max(1);
        self
    }

    /// Sets the Simpson sub-intervals per cell side (rounded up to even).
    pub fn integration(mut self, intervals: u32) -> Self {
        self.integration = intervals.max(2).next_multiple_of(2);
        self
    }

    /// Draws the points with `sample` (`None`: the routine declined) and compares their
    /// histogram with the density `pdf` (of the points `sample` returns, per unit of the domain's
    /// measure).
    pub fn run(&self, mut sample: impl FnMut(&mut Uniform) -> Option<D::Point>, pdf: impl Fn(D::Point) -> f64) -> Chi2Outcome {
        let (nx, ny) = (self.res.0 as usize, self.res.1 as usize);
        let mut observed = vec![0u64; nx * ny];
        let mut rng = Uniform::new(self.seed);
        let mut outside = None;
        let (mut declined, mut unlikely, mut first_unlikely) = (0u64, 0u64, None);
        for _ in 0..self.samples {
            let Some(p) = sample(&mut rng) else {
                declined += 1;
                continue;
            };
            if !(pdf(p) > 0.0) {
                unlikely += 1;
                first_unlikely = first_unlikely.or(Some(p));
            }
            match self.domain.parameters_of(p) {
                Some(a) => {
                    let i = ((a.x * nx as f64) as usize).min(nx - 1);
                    let j = ((a.y * ny as f64) as usize).min(ny - 1);
                    observed[j * nx + i] += 1;
                }
                None => outside = outside.or(Some(format!("{p:?}"))),
            }
        }
        let expected = self.expected(&pdf);
        let mut outcome = Chi2Outcome {
            seed: self.seed,
            samples: self.samples,
            declined,
            statistic: 0.0,
            dof: 0,
            p_value: 1.0,
            threshold: 1.0 - (1.0 - self.significance).powf(1.0 / f64::from(self.tests)),
            mass: expected.iter().sum::<f64>() / f64::from(self.samples.max(1)),
            failure: None,
            worst: Vec::new(),
        };
        if let Some(p) = outside {
            outcome.failure = Some(format!("a sample lies outside the domain: {p}"));
            return outcome;
        }
        if unlikely as f64 > ZERO_DENSITY_ALLOWANCE * f64::from(self.samples) {
            outcome.failure = Some(format!(
                "{unlikely} samples lie where the density is zero (the first at {:?})",
                first_unlikely.expect("one was seen")
            ));
            return outcome;
        }
        if let Some(bad) = expected.iter().position(|e| !(e.is_finite() && *e >= 0.0)) {
            outcome.failure = Some(format!("the density is negative or not finite in the cell {}", self.cell(bad)));
            return outcome;
        }
        if outcome.mass > 1.0 + MASS_TOLERANCE {
            outcome.failure = Some(format!("the density integrates to {:.4} > 1 over the domain", outcome.mass));
            return outcome;
        }
        let observed: Vec<f64> = observed.iter().map(|&o| o as f64).collect();
        let Pearson { statistic, dof, mut cells, .. } = pearson(&observed, &expected, self.min_expected);
        (outcome.statistic, outcome.dof) = (statistic, dof);
        if outcome.dof == 0 {
            outcome.failure = Some("fewer than two cells expect enough samples: raise `samples` or lower `res`".into());
            return outcome;
        }
        outcome.p_value = chi2_survival(outcome.statistic, f64::from(outcome.dof));
        cells.sort_by(|a, b| b.1.total_cmp(&a.1));
        outcome.worst = cells
            .iter()
            .take(WORST_CELLS)
            .map(|&(c, _)| format!("{}: observed {}, expected {:.1}", self.cell(c), observed[c], expected[c]))
            .collect();
        if !(outcome.p_value >= outcome.threshold) {
            outcome.failure = Some(format!(
                "the samples do not follow the density: χ² = {:.1} for {} degrees of freedom, p = {:.3e} < {:.3e}",
                outcome.statistic, outcome.dof, outcome.p_value, outcome.threshold
            ));
        }
        outcome
    }

    /// Expected counts per cell: `samples ×` the integral of `pdf` over each, by composite
    /// Simpson's rule, or by the midpoint rule on a finer grid near the edge of the density's
    /// support (a cell whose Simpson points are some zero and some not, or which borders a cell
    /// that differs from it in that), where Simpson's rule errs most or misses a sliver.
    fn expected(&self, pdf: &impl Fn(D::Point) -> f64) -> Vec<f64> {
        let (nx, ny) = (self.res.0 as usize, self.res.1 as usize);
        let k = self.integration.max(2).next_multiple_of(2) as usize;
        let weight = |i: usize| {
            if i == 0 || i == k {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            }
        };
        let (hx, hy) = (1.0 / (nx * k) as f64, 1.0 / (ny * k) as f64);
        let scale = f64::from(self.samples) * self.domain.jacobian() * hx * hy / 9.0;
        let mut out = vec![0.0; nx * ny];
        // Per cell: (some Simpson point is zero, some is not).
        let mut support = vec![(false, false); nx * ny];
        for j in 0..ny {
            for i in 0..nx {
                let (mut sum, mut zero, mut positive) = (0.0, false, false);
                for b in 0..=k {
                    for a in 0..=k {
                        let at = DVec2::new((i * k + a) as f64 * hx, (j * k + b) as f64 * hy);
                        let v = pdf(self.domain.point_at(at));
                        zero |= v == 0.0;
                        positive |= v != 0.0;
                        sum += weight(a) * weight(b) * v;
                    }
                }
                out[j * nx + i] = sum * scale;
                support[j * nx + i] = (zero, positive);
            }
        }
        let m = EDGE_REFINEMENT;
        let (gx, gy) = (1.0 / (nx * m) as f64, 1.0 / (ny * m) as f64);
        let fine_scale = f64::from(self.samples) * self.domain.jacobian() * gx * gy;
        for j in 0..ny {
            for i in 0..nx {
                let here = support[j * nx + i];
                let mut edge = here.0 && here.1;
                for (di, dj) in [(nx - 1, 0), (1, 0), (0, ny - 1), (0, 1), (nx - 1, ny - 1), (1, 1), (nx - 1, 1), (1, ny - 1)] {
                    // Neighbours wrap around (the sphere's φ does; elsewhere it only refines more).
                    edge |= support[(j + dj) % ny * nx + (i + di) % nx] != here;
                }
                if !edge {
                    continue;
                }
                let mut fine = 0.0;
                for b in 0..m {
                    for a in 0..m {
                        let at = DVec2::new(((i * m + a) as f64 + 0.5) * gx, ((j * m + b) as f64 + 0.5) * gy);
                        fine += pdf(self.domain.point_at(at));
                    }
                }
                out[j * nx + i] = fine * fine_scale;
            }
        }
        out
    }

    fn cell(&self, c: usize) -> String {
        let (nx, ny) = (self.res.0 as usize, self.res.1 as usize);
        let (i, j) = (c % nx, c / nx);
        let lo = DVec2::new(i as f64 / nx as f64, j as f64 / ny as f64);
        let hi = DVec2::new((i + 1) as f64 / nx as f64, (j + 1) as f64 / ny as f64);
        self.domain.describe(lo, hi)
    }
}

/// The fraction of samples that may lie where the density is zero (at the support's edge, by
/// rounding) before the test fails.
pub const ZERO_DENSITY_ALLOWANCE: f64 = 1e-4;

/// Midpoint-rule samples per side of a cell the edge of the density's support crosses.
const EDGE_REFINEMENT: usize = 64;

/// Cells listed in a failure's report.
const WORST_CELLS: usize = 5;

/// What a [`Chi2Test::run`] found.
#[derive(Clone, Debug)]
pub struct Chi2Outcome {
    /// The stream's seed (to replay the run).
    pub seed: u64,
    /// Points asked for.
    pub samples: u32,
    /// How many of them the routine declined.
    pub declined: u64,
    /// Pearson's statistic.
    pub statistic: f64,
    /// Its degrees of freedom (cells after pooling, less one).
    pub dof: u32,
    /// The probability of a statistic at least this large if the samples follow the density.
    pub p_value: f64,
    /// The corrected significance level: the test fails below it.
    pub threshold: f64,
    /// The integral of the density over the domain (the fraction of points it expects).
    pub mass: f64,
    /// Why the test failed; `None` when it passed.
    pub failure: Option<String>,
    /// The cells that deviate most, with their observed and expected counts.
    pub worst: Vec<String>,
}

impl Chi2Outcome {
    /// True when the samples follow the density.
    pub fn passed(&self) -> bool {
        self.failure.is_none()
    }

    /// Panics with the report (named `name`) unless the test passed.
    #[track_caller]
    pub fn assert_passes(&self, name: &str) -> &Self {
        // Shown by the harness with the test's output (`--nocapture`, or on a failure).
        eprintln!("χ² test \"{name}\": {self}");
        assert!(self.passed(), "χ² test \"{name}\" failed: {self}");
        self
    }

    /// Panics unless the test failed: a guard that a test of a wrong density can fail.
    #[track_caller]
    pub fn assert_fails(&self, name: &str) -> &Self {
        assert!(!self.passed(), "χ² test \"{name}\" should have failed: {self}");
        self
    }
}

impl fmt::Display for Chi2Outcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(why) = &self.failure {
            write!(f, "{why}; ")?;
        }
        write!(
            f,
            "seed {:#x}, {} samples ({} declined), density mass {:.4}, χ² {:.1}, dof {}, p {:.3e}, threshold {:.3e}",
            self.seed, self.samples, self.declined, self.mass, self.statistic, self.dof, self.p_value, self.threshold
        )?;
        for w in &self.worst {
            write!(f, "\n    {w}")?;
        }
        Ok(())
    }
}

/// Pearson's statistic of a histogram ([`pearson`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Pearson {
    /// `Σ (observed − expected)² / expected` over the cells after pooling.
    pub statistic: f64,
    /// Degrees of freedom: cells after pooling, less one (0: too few cells for a test).
    pub dof: u32,
    /// The cells not pooled, with their terms of the statistic (for a report of the worst).
    pub cells: Vec<(usize, f64)>,
    /// Points in the last pool when it expects none at all (cells whose density integrates to
    /// zero): left out of the statistic, judged by the caller ([`Pearson::p_value`]: any fails).
    pub unexpected: f64,
}

impl Pearson {
    /// The p-value: [`chi2_survival`] of the statistic, and 0 (a certain failure) when points
    /// lie where no cell expects any, or when there are too few cells for a test.
    pub fn p_value(&self) -> f64 {
        if self.unexpected > 0.0 || self.dof == 0 { 0.0 } else { chi2_survival(self.statistic, f64::from(self.dof)) }
    }
}

/// Pearson's χ² statistic of `observed` counts against `expected` ones, the one pooling every χ²
/// test of raylab uses (Mitsuba's scheme): cells expecting fewer than `min_expected` points are
/// pooled in order of expectation, each pool closed once it expects `min_expected`; a last
/// pool that expects nothing is left out (its points are [`Pearson::unexpected`]). For a
/// histogram over a domain, [`Chi2Test`] does all of it (and judges points where the density
/// is zero itself, allowing [`ZERO_DENSITY_ALLOWANCE`] for rounding); a test that builds its
/// own histogram (a discrete distribution, a shape's samples seen through rays) calls this and
/// reads [`Pearson::p_value`].
pub fn pearson(observed: &[f64], expected: &[f64], min_expected: f64) -> Pearson {
    assert_eq!(observed.len(), expected.len(), "one expected count per observed one");
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut statistic, mut count, mut unexpected) = (0.0, 0u32, 0.0);
    let (mut pooled_obs, mut pooled_exp, mut pooled) = (0.0, 0.0, 0usize);
    let mut cells = Vec::with_capacity(order.len());
    for &c in &order {
        let (o, e) = (observed[c], expected[c]);
        // A cell whose integral is zero but which holds samples (a sliver of the support the
        // integration missed, or samples where none belong) is pooled with the next ones.
        if e < min_expected {
            pooled_obs += o;
            pooled_exp += e;
            pooled += 1;
            if pooled_exp >= min_expected {
                statistic += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
                count += 1;
                (pooled_obs, pooled_exp, pooled) = (0.0, 0.0, 0);
            }
        } else {
            let term = (o - e) * (o - e) / e;
            statistic += term;
            count += 1;
            cells.push((c, term));
        }
    }
    if pooled > 0 && pooled_exp > 0.0 {
        statistic += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        count += 1;
    } else if pooled > 0 {
        unexpected = pooled_obs;
    }
    Pearson { statistic, dof: count.saturating_sub(1), cells, unexpected }
}

/// `P(X ≥ x)` for `X` χ²-distributed with `dof` degrees of freedom: `Q(dof/2, x/2)` (0 for an
/// infinite or NaN statistic).
pub fn chi2_survival(x: f64, dof: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        return 0.0;
    }
    gamma_q(dof / 2.0, x / 2.0)
}

/// The regularised upper incomplete gamma function `Q(a, x) = Γ(a, x) / Γ(a)`: its series below
/// `a + 1`, its continued fraction (modified Lentz) above (Numerical Recipes, §6.2).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    const EPS: f64 = 1e-15;
    const ITERATIONS: usize = 100_000;
    if !(x > 0.0) {
        return 1.0;
    }
    let log_prefix = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut term, mut sum, mut n) = (1.0 / a, 1.0 / a, a);
        for _ in 0..ITERATIONS {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * EPS {
                break;
            }
        }
        (1.0 - sum * log_prefix.exp()).clamp(0.0, 1.0)
    } else {
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..ITERATIONS {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < EPS {
                break;
            }
        }
        (log_prefix.exp() * h).clamp(0.0, 1.0)
    }
}

/// `ln Γ(x)` for `x > 0` (Lanczos, g = 7, 9 terms: about 15 digits).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
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
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut sum = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        sum += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * TAU.ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Table values of the χ² distribution's upper quantiles and of Γ.
    #[test]
    fn p_values_match_the_tables() {
        for (x, dof, p) in [
            (3.841_458_8, 1.0, 0.05),
            (6.634_896_6, 1.0, 0.01),
            (18.307_038, 10.0, 0.05),
            (124.342_11, 100.0, 0.05),
            (1.0, 2.0, (-0.5f64).exp()),
        ] {
            let q = chi2_survival(x, dof);
            assert!((q - p).abs() < 1e-6 * p.max(1e-3), "χ²({dof}) ≥ {x}: {q}, expected {p}");
        }
        // Large dof: the median of χ²(k) is about k(1 − 2/(9k))³.
        let k: f64 = 3000.0;
        let median = k * (1.0 - 2.0 / (9.0 * k)).powi(3);
        assert!((chi2_survival(median, k) - 0.5).abs() < 1e-3);
        for (x, g) in [(1.0, 1.0), (5.0, 24.0), (0.5, PI.sqrt()), (10.5, 1_133_278.388_948_785_5)] {
            assert!((ln_gamma(x) - f64::ln(g)).abs() < 1e-10, "ln Γ({x})");
        }
    }

    fn uniform_direction(u: &mut Uniform) -> Option<DVec3> {
        Some(Sphere.point_at(u.next_2d()))
    }

    /// Cosine-weighted directions about +z, by Malley's method.
    fn cosine_direction(u: &mut Uniform) -> Option<DVec3> {
        let (r, phi) = (u.next_1d().sqrt(), TAU * u.next_1d());
        Some(DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - r * r).max(0.0).sqrt()))
    }

    fn cosine_pdf(d: DVec3) -> f64 {
        d.z.max(0.0) / PI
    }

    #[test]
    fn right_densities_pass() {
        let test = Chi2Test::new(Sphere).tests(3);
        test.run(uniform_direction, |_| 1.0 / (4.0 * PI)).assert_passes("uniform");
        test.run(cosine_direction, cosine_pdf).assert_passes("cosine");
        // Declining half the points halves the density.
        let mut flip = false;
        let half = test.run(
            |u| {
                flip = !flip;
                if flip { cosine_direction(u) } else { None }
            },
            |d| cosine_pdf(d) / 2.0,
        );
        half.assert_passes("cosine, half declined");
        assert_eq!(half.declined, u64::from(test.samples / 2));
        Chi2Test::new(Rect { min: DVec2::splat(-1.0), max: DVec2::ONE })
            .run(|u| Some(2.0 * u.next_2d() - DVec2::ONE), |_| 0.25)
            .assert_passes("uniform square");
    }

    /// Guards: a test that cannot fail is no test.
    #[test]
    fn wrong_densities_fail() {
        let test = Chi2Test::new(Sphere);
        // Cosine samples against the uniform hemisphere's density.
        let wrong = test.run(cosine_direction, |d| if d.z > 0.0 { 1.0 / TAU } else { 0.0 });
        wrong.assert_fails("cosine vs uniform hemisphere");
        assert!(wrong.p_value < 1e-10 && wrong.worst.len() == WORST_CELLS, "{wrong}");
        // A slightly wrong lobe: cos^1.1 sampled, cos claimed.
        test.run(
            |u| {
                let z = u.next_1d().powf(1.0 / 2.1);
                let (r, phi) = ((1.0 - z * z).sqrt(), TAU * u.next_1d());
                Some(DVec3::new(r * phi.cos(), r * phi.sin(), z))
            },
            cosine_pdf,
        )
        .assert_fails("exponent 1.1 vs 1");
        // Points where the density is zero.
        let zero = test.run(uniform_direction, cosine_pdf);
        assert!(zero.failure.as_ref().is_some_and(|f| f.contains("where the density is zero")), "{zero}");
        // A density that claims more than all the points.
        let heavy = test.run(uniform_direction, |_| 1.0 / PI);
        assert!(heavy.failure.as_ref().is_some_and(|f| f.contains("> 1")), "{heavy}");
        // A density that forgets the declined points.
        let mut flip = false;
        test.run(
            |u| {
                flip = !flip;
                if flip { cosine_direction(u) } else { None }
            },
            cosine_pdf,
        )
        .assert_fails("declined points");
        // Not a unit vector.
        let long = test.run(|u| uniform_direction(u).map(|d| d * 1.1), |_| 1.0 / (4.0 * PI));
        assert!(long.failure.as_ref().is_some_and(|f| f.contains("outside the domain")), "{long}");
    }

    #[test]
    fn the_significance_is_corrected_for_the_number_of_tests() {
        let one = Chi2Test::new(Sphere).run(uniform_direction, |_| 1.0 / (4.0 * PI));
        let many = Chi2Test::new(Sphere).tests(100).run(uniform_direction, |_| 1.0 / (4.0 * PI));
        assert!((one.threshold - 0.01).abs() < 1e-15);
        assert!((many.threshold - (1.0 - 0.99f64.powf(0.01))).abs() < 1e-15 && many.threshold < 1.01e-4);
    }
}
