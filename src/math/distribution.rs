//! Distributions for importance sampling: an [`AliasTable`] (a choice among weighted items in
//! constant time: lights by power) and piecewise-constant densities over `[0, 1)`
//! ([`Piecewise1d`]) and `[0, 1)²` ([`Piecewise2d`]: an environment image's texels by luminance).
//!
//! Every sampler takes uniform numbers in `[0, 1)` and returns what it chose with its
//! probability (or density), and the part of its input it did not use, rescaled to `[0, 1)`, so a
//! caller can draw one number for two decisions. A weight that is negative, NaN or infinite
//! counts as zero.

/// A weight as the distributions read it: finite and positive, else zero.
#[inline]
fn weight(w: f64) -> f64 {
    if w.is_finite() && w > 0.0 { w } else { 0.0 }
}

/// `u` kept below one (a rescaled number may round up to exactly 1).
#[inline]
fn below_one(u: f64) -> f64 {
    u.min(1.0 - f64::EPSILON / 2.0)
}

/// The bin of `n` equal ones over `[0, 1)` that holds `x` (the first below 0, the last from 1).
#[inline]
fn bin(x: f64, n: usize) -> usize {
    ((below_one(x.max(0.0)) * float(n)) as u32 as usize).min(n - 1)
}

/// `n` (below 2³², as every count of bins) as a float, through u32: the same value, and on x86-64
/// one conversion where a usize's takes a sequence.
#[inline]
fn float(n: usize) -> f64 {
    f64::from(n as u32)
}

/// One column of an alias table: keep the column's own item with probability `threshold`, else
/// take `alias`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Column {
    threshold: f64,
    alias: u32,
}

/// A discrete distribution over `0..n` proportional to weights, sampled in constant time
/// (Walker 1977, Vose 1991's construction).
#[derive(Clone, Debug, PartialEq)]
pub struct AliasTable {
    columns: Vec<Column>,
    /// Each item's probability.
    pmf: Vec<f64>,
}

impl AliasTable {
    /// The table for `weights` (see the module docs for invalid weights); `None` when no weight
    /// is positive (or there are none, or more than `u32::MAX`).
    pub fn new(weights: &[f64]) -> Option<AliasTable> {
        let n = weights.len();
        if n == 0 || n > u32::MAX as usize {
            return None;
        }
        let total: f64 = weights.iter().map(|&w| weight(w)).sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let pmf: Vec<f64> = weights.iter().map(|&w| weight(w) / total).collect();
        // Columns of height 1: scaled probabilities split into those under and over one.
        let mut scaled: Vec<f64> = pmf.iter().map(|p| p * n as f64).collect();
        let mut columns: Vec<Column> = (0..n).map(|i| Column { threshold: 1.0, alias: i as u32 }).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            columns[s] = Column { threshold: scaled[s], alias: l as u32 };
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left is one up to rounding.
        for i in small.into_iter().chain(large) {
            columns[i] = Column { threshold: 1.0, alias: i as u32 };
        }
        Some(AliasTable { columns, pmf })
    }

    /// Number of items.
    #[inline]
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// True when there is no item (never, for a table that was built).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// The probability of item `i` (0 beyond the table).
    #[inline]
    pub fn pmf(&self, i: usize) -> f64 {
        self.pmf.get(i).copied().unwrap_or(0.0)
    }

    /// An item for `u` uniform in `[0, 1)`: its index, its probability, and `u`'s unused part
    /// rescaled to `[0, 1)`.
    #[inline]
    pub fn sample(&self, u: f64) -> (usize, f64, f64) {
        let n = self.columns.len();
        // Counts and indices through u32 (a table has fewer than 2³² items): the same values,
        // one conversion each where a usize's takes a sequence.
        let scaled = below_one(u.max(0.0)) * float(n);
        let i = (scaled as u32 as usize).min(n - 1);
        let frac = below_one(scaled - float(i));
        let c = self.columns[i];
        let (item, rest) =
            if frac < c.threshold { (i, frac / c.threshold) } else { (c.alias as usize, (frac - c.threshold) / (1.0 - c.threshold)) };
        (item, self.pmf[item], below_one(rest))
    }
}

/// A piecewise-constant density over `[0, 1)`: `n` equal bins with the density proportional to
/// their weights (uniform when every weight is zero).
///
/// Sampling inverts the cdf through a guide table (the cutpoint method, Chen & Asau 1974): `u`'s
/// `n`-th of `[0, 1)` names the few cdf entries its bin lies between, so a draw searches those
/// (on average about two, whatever the weights' skew: each guide cell holds one `1/n` of the
/// probability) instead of all `n`. The bin found is exactly the full search's.
#[derive(Clone, Debug, PartialEq)]
pub struct Piecewise1d {
    /// Each bin's weight.
    func: Vec<f64>,
    /// `cdf[i]` = the probability of bins `0..i`; `n + 1` entries from 0 to 1.
    cdf: Vec<f64>,
    /// `guide[k]` = the first `j` with `cdf[j] > k / n` (`n` entries): the first cdf entry above
    /// any `u` in `[k/n, (k+1)/n)` is `guide[k]` or one after it.
    guide: Vec<u32>,
    /// The mean weight (∫ of the function over `[0, 1)`), 0 when all are zero.
    integral: f64,
}

impl Piecewise1d {
    /// The density for `weights` (at least one, fewer than 2³²).
    pub fn new(weights: &[f64]) -> Piecewise1d {
        assert!(!weights.is_empty(), "a piecewise-constant density needs at least one bin");
        assert!(weights.len() < u32::MAX as usize, "a piecewise-constant density has fewer than 2³² bins");
        let n = weights.len();
        let mut func: Vec<f64> = weights.iter().map(|&w| weight(w)).collect();
        let total: f64 = func.iter().sum();
        let integral = if total.is_finite() { total / n as f64 } else { 0.0 };
        if !(integral > 0.0) {
            func.iter_mut().for_each(|f| *f = 1.0);
        }
        let total: f64 = func.iter().sum();
        let mut cdf = Vec::with_capacity(n + 1);
        let mut sum = 0.0;
        cdf.push(0.0);
        for f in &func {
            sum += f;
            cdf.push(sum / total);
        }
        cdf[n] = 1.0;
        // One pass over the cdf: guide cell k starts at the first entry above k/n.
        let mut guide = Vec::with_capacity(n);
        let mut j = 0;
        for k in 0..n {
            let edge = k as f64 / n as f64;
            while cdf[j] <= edge {
                j += 1;
            }
            guide.push(j as u32);
        }
        Piecewise1d { func, cdf, guide, integral }
    }

    /// Number of bins.
    #[inline]
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// True when there is no bin (never).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// ∫ of the weights as a function over `[0, 1)` (their mean); 0 when all are zero.
    #[inline]
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// The density at `x` in `[0, 1)` (of the bin holding it).
    #[inline]
    pub fn pdf(&self, x: f64) -> f64 {
        self.bin_pdf(bin(x, self.func.len()))
    }

    /// The density in bin `i`.
    #[inline]
    fn bin_pdf(&self, i: usize) -> f64 {
        (self.cdf[i + 1] - self.cdf[i]) * float(self.func.len())
    }

    /// A point for `u` uniform in `[0, 1)`: `x` in `[0, 1)`, its density, and its bin.
    #[inline(always)]
    pub fn sample(&self, u: f64) -> (f64, f64, usize) {
        let n = self.func.len();
        let u = below_one(u.max(0.0));
        // The last bin whose cdf is ≤ u, among those with a probability: the first cdf entry
        // above u, from the guide's start for u's cell on (about two steps on average; back
        // first where rounding put u before that start: the same answer either way).
        // `bin(u, n)`, `u` already clamped.
        let mut first_above = self.guide[((u * float(n)) as u32 as usize).min(n - 1)] as usize;
        // cdf[0] = 0 ≤ u ends the first scan, cdf[n] = 1 > u the second.
        while self.cdf[first_above - 1] > u {
            first_above -= 1;
        }
        while self.cdf[first_above] <= u {
            first_above += 1;
        }
        let i = (first_above - 1).min(n - 1);
        let p = self.cdf[i + 1] - self.cdf[i];
        let within = if p > 0.0 { (u - self.cdf[i]) / p } else { 0.5 };
        let x = below_one((float(i) + within.clamp(0.0, 1.0)) / float(n));
        (x, p * float(n), i)
    }
}

/// A piecewise-constant density over `[0, 1)²` from a grid of weights (`width × height`, rows
/// along `v`): a row chosen by its total, then a column within it.
#[derive(Clone, Debug, PartialEq)]
pub struct Piecewise2d {
    rows: Vec<Piecewise1d>,
    marginal: Piecewise1d,
    /// Each cell's density (row-major), the product [`Piecewise2d::sample`] forms: one load
    /// where [`Piecewise2d::pdf`] would look two densities up.
    cells: Vec<f64>,
    width: usize,
}

impl Piecewise2d {
    /// The density for `weights` in row-major order (`width × height` of them, both ≥ 1).
    pub fn new(weights: &[f64], width: usize, height: usize) -> Piecewise2d {
        assert!(width >= 1 && height >= 1 && weights.len() == width * height, "a {width}×{height} grid needs as many weights");
        let rows: Vec<Piecewise1d> = weights.chunks_exact(width).map(Piecewise1d::new).collect();
        let marginal = Piecewise1d::new(&rows.iter().map(Piecewise1d::integral).collect::<Vec<_>>());
        let cells = (0..width * height).map(|i| marginal.bin_pdf(i / width) * rows[i / width].bin_pdf(i % width)).collect();
        Piecewise2d { rows, marginal, cells, width }
    }

    /// The density at `(u, v)` in `[0, 1)²`.
    #[inline]
    pub fn pdf(&self, p: glam::DVec2) -> f64 {
        self.cells[bin(p.y, self.rows.len()) * self.width + bin(p.x, self.width)]
    }

    /// A point for `u` uniform in `[0, 1)²`, and its density.
    #[inline]
    pub fn sample(&self, u: glam::DVec2) -> (glam::DVec2, f64) {
        let (v, pv, row) = self.marginal.sample(u.y);
        let (x, pu, _) = self.rows[row].sample(u.x);
        (glam::DVec2::new(x, v), pv * pu)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::pearson;
    use glam::DVec2;

    /// Significance under which a χ² test fails: the tests use fixed seeds, so a failure is
    /// reproducible, and a right routine fails one in this many seeds.
    const SIGNIFICANCE: f64 = 1e-4;

    fn rng(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn alias_table_draws_items_by_weight() {
        let weights = [3.0, 0.0, 1.0, 0.25, 10.0, f64::NAN, 0.5, 2.0];
        let t = AliasTable::new(&weights).unwrap();
        let total: f64 = t.pmf.iter().sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert_eq!((t.pmf(1), t.pmf(5)), (0.0, 0.0));
        let n = 200_000;
        let mut counts = vec![0.0; weights.len()];
        let mut next = rng(7);
        let mut rest_sum = 0.0;
        for _ in 0..n {
            let (i, p, rest) = t.sample(next());
            assert_eq!(p, t.pmf(i));
            assert!((0.0..1.0).contains(&rest));
            rest_sum += rest;
            counts[i] += 1.0;
        }
        let expected: Vec<f64> = (0..weights.len()).map(|i| t.pmf(i) * n as f64).collect();
        let r = pearson(&counts, &expected, 5.0);
        assert!(r.p_value() > SIGNIFICANCE, "{r:?}");
        // The reused number is uniform too (its mean, at least).
        assert!((rest_sum / n as f64 - 0.5).abs() < 0.01);
        assert!(AliasTable::new(&[0.0, -1.0]).is_none() && AliasTable::new(&[]).is_none());
    }

    #[test]
    fn chi_square_rejects_a_wrong_density() {
        // The test can fail: samples of one table judged against another's probabilities.
        let right = AliasTable::new(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        let wrong = AliasTable::new(&[1.0, 2.0, 3.2, 3.8]).unwrap();
        let n = 100_000;
        let mut counts = [0.0; 4];
        let mut next = rng(3);
        for _ in 0..n {
            counts[right.sample(next()).0] += 1.0;
        }
        let expected: Vec<f64> = (0..4).map(|i| wrong.pmf(i) * n as f64).collect();
        assert!(pearson(&counts, &expected, 5.0).p_value() < SIGNIFICANCE);
    }

    #[test]
    fn piecewise_2d_samples_match_its_density() {
        let (w, h) = (13, 7);
        let weights: Vec<f64> =
            (0..w * h).map(|i| if i % 5 == 0 { 0.0 } else { 1.0 + ((i * 37) % 11) as f64 * (i as f64).sin().abs() }).collect();
        let d = Piecewise2d::new(&weights, w, h);
        // The density integrates to one (it is constant on each cell).
        let integral: f64 =
            (0..w * h).map(|i| d.pdf(DVec2::new(((i % w) as f64 + 0.5) / w as f64, ((i / w) as f64 + 0.5) / h as f64))).sum::<f64>()
                / (w * h) as f64;
        assert!((integral - 1.0).abs() < 1e-12, "{integral}");
        // A histogram finer than the cells.
        let (gx, gy) = (w * 2, h * 3);
        let n = 400_000;
        let mut counts = vec![0.0; gx * gy];
        let mut next = rng(11);
        for _ in 0..n {
            let (p, pdf) = d.sample(DVec2::new(next(), next()));
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
            assert!((pdf - d.pdf(p)).abs() <= 1e-12 * pdf, "{pdf} vs {}", d.pdf(p));
            // The cells' table holds the product of the row's and the column's densities.
            let q = DVec2::new(next() * 1.2 - 0.1, next() * 1.2 - 0.1);
            let row = bin(q.y, h);
            assert_eq!(d.pdf(q).to_bits(), (d.marginal.pdf(q.y) * d.rows[row].pdf(q.x)).to_bits());
            counts[(p.y * gy as f64) as usize * gx + (p.x * gx as f64) as usize] += 1.0;
        }
        let expected: Vec<f64> = (0..gx * gy)
            .map(|i| {
                let c = DVec2::new(((i % gx) as f64 + 0.5) / gx as f64, ((i / gx) as f64 + 0.5) / gy as f64);
                d.pdf(c) * n as f64 / (gx * gy) as f64
            })
            .collect();
        let r = pearson(&counts, &expected, 5.0);
        assert!(r.p_value() > SIGNIFICANCE, "{r:?}");
    }

    #[test]
    fn the_guide_table_finds_the_bin_a_full_search_finds() {
        // Skewed weights (a sun among a dim sky, runs of zeros, a tiny floor), and the edges of
        // bins and guide cells as inputs: the bin is the one the whole cdf's search names.
        let mut next = rng(5);
        for n in [1usize, 2, 3, 7, 64, 257] {
            let weights: Vec<f64> = (0..n)
                .map(|i| match i % 9 {
                    0 => 0.0,
                    4 => 1e6 * next(),
                    _ => 1e-3 + next(),
                })
                .collect();
            let d = Piecewise1d::new(&weights);
            let full = |u: f64| {
                let u = below_one(u.max(0.0));
                (d.cdf.partition_point(|&c| c <= u).max(1) - 1).min(n - 1)
            };
            let mut inputs: Vec<f64> = d.cdf.iter().copied().chain((0..=n).map(|k| k as f64 / n as f64)).collect();
            inputs = inputs.iter().flat_map(|&c| [c, c - f64::EPSILON / 4.0, c + f64::EPSILON / 4.0, c - 1e-12, c + 1e-12]).collect();
            inputs.extend((0..20_000).map(|_| next()));
            inputs.extend([0.0, 1.0 - f64::EPSILON / 2.0, 1.0, -0.5]);
            for u in inputs {
                assert_eq!(d.sample(u).2, full(u), "n = {n}, u = {u:e}");
            }
        }
    }

    #[test]
    fn an_all_zero_density_is_uniform() {
        let d = Piecewise1d::new(&[0.0, 0.0, 0.0, 0.0]);
        assert_eq!(d.integral(), 0.0);
        assert_eq!(d.pdf(0.3), 1.0);
        let (x, p, i) = d.sample(0.6);
        assert!((x - 0.6).abs() < 1e-12 && p == 1.0 && i == 2);
    }
}
