//! Deterministic random numbers: every value is a pure function of (pixel, sample, dimension,
//! seed), so an image is bit-identical whatever the thread count or tile order.
//!
//! Stratified 2-D patterns use correlated multi-jittered sampling (Kensler 2013, "Correlated
//! Multi-Jittered Sampling"), which stratifies any sample count, not only perfect squares.
//!
//! A stream also draws numbers stratified *across a pixel's samples*
//! ([`Sampler::pixel_1d`], [`Sampler::pixel_2d`]), as pbrt-v4's padded Sobol sampler does: each
//! dimension (the `dim`-th draw of the stream reached by the same chain of [`Sampler::fork`]s,
//! e.g. "the second bounce's light sample") is, over the pixel's samples `0, 1, 2, …`, the
//! first one or two dimensions of the Sobol sequence, Owen-scrambled with its own key per
//! (pixel, seed, fork chain, dimension) ("padded": dimensions are independent of each other).
//! Every prefix of `2^k` samples of a pixel then holds one point in each elementary interval
//! of area `2^-k` of each such pair, whatever the pixel's final count (passes, error targets);
//! each value is still a pure function of (pixel, sample, fork chain, dimension, seed), and
//! uniform on its own (Owen scrambling is a random nested permutation of the digits).

use glam::{DVec2, DVec3};

/// A stream of uniform numbers in [0, 1) for one (pixel, sample, seed).
#[derive(Clone, Debug)]
pub struct Sampler {
    /// This sample's stream key (what [`Sampler::next_1d`] hashes).
    key: u64,
    /// The key of this stream's place in the fork tree for the whole pixel: the same for every
    /// sample of the pixel (what [`Sampler::pixel_1d`] scrambles with).
    chain: u64,
    /// Numbers drawn so far.
    dim: u32,
    /// The sample's number in its pixel, bit-reversed (as [`shuffle`] takes it).
    reversed_index: u32,
}

impl Sampler {
    /// The stream for pixel index `pixel` (row-major), sample number `sample` and the render seed.
    #[inline]
    pub fn new(pixel: u64, sample: u32, seed: u64) -> Self {
        Sampler::with_seed(pixel, sample, SeedKey::new(seed))
    }

    /// [`Sampler::new`] with the seed's hash computed once by the caller (the same stream).
    #[inline]
    pub fn with_seed(pixel: u64, sample: u32, seed: SeedKey) -> Self {
        Sampler::with_pixel_key(seed.pixel(pixel), sample)
    }

    /// [`Sampler::with_seed`] with the pixel's hash ([`SeedKey::pixel`]) computed once for all
    /// its samples by the caller (the same stream).
    #[inline]
    pub fn with_pixel_key(pixel: PixelKey, sample: u32) -> Self {
        let key = mix64(pixel.0 ^ u64::from(sample).wrapping_mul(0xD1B5_4A32_D192_ED03));
        Sampler { key, chain: pixel.0, dim: 0, reversed_index: sample.reverse_bits() }
    }

    /// The next number in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f64 {
        let h = mix64(self.key ^ u64::from(self.dim).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        self.dim += 1;
        to_unit(h)
    }

    /// The next pair in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> DVec2 {
        DVec2::new(self.next_1d(), self.next_1d())
    }

    /// An independent stream for a sub-task (a child ray, a light's samples), keyed by `tag`. It
    /// depends only on this stream's key and `tag`, not on how many numbers were drawn, so work
    /// skipped in one branch of a ray tree never shifts the numbers another branch sees.
    ///
    /// The fork of every sample of a pixel by the same chain of tags draws its
    /// [`Sampler::pixel_1d`] and [`Sampler::pixel_2d`] numbers from the same scrambled sequences.
    #[inline]
    pub fn fork(&self, tag: u64) -> Sampler {
        let t = tag.wrapping_add(0x2545_F491_4F6C_DD1D);
        // The chain only needs distinct values per chain of tags (it is hashed when drawn from):
        // an odd multiplication and a rotation, not a full hash.
        let chain = ((self.chain ^ t).wrapping_mul(0x9FB2_1C65_1E98_DF25)).rotate_left(29);
        Sampler { key: mix64(self.key ^ mix64(t)), chain, dim: 0, reversed_index: self.reversed_index }
    }

    /// The next number in [0, 1), stratified across the pixel's samples: sample `i` of the pixel
    /// takes point `shuffle(i)` of this dimension's Owen-scrambled van der Corput sequence (the
    /// Sobol sequence's first dimension), shuffle and scramble keyed by the dimension (Burley
    /// 2020, "Practical Hash-based Owen Scrambling"). It takes the place of one
    /// [`Sampler::next_1d`]: the numbers drawn after it are the same either way.
    #[inline]
    pub fn pixel_1d(&mut self) -> f64 {
        let h = self.dimension_key();
        sobol_unit(owen_scramble(shuffle(self.reversed_index, (h >> 32) as u32), h as u32))
    }

    /// The next pair in [0, 1)², stratified across the pixel's samples: sample `i` of the pixel
    /// takes point `shuffle(i)` of this dimension pair's Sobol (0, 2)-sequence, each coordinate
    /// Owen-scrambled with its own key. It takes the place of one [`Sampler::next_2d`] (two
    /// numbers).
    #[inline]
    pub fn pixel_2d(&mut self) -> DVec2 {
        let h = self.dimension_key();
        self.dim += 1;
        // The shuffle's key: the top half of a multiplicative hash of both scramble keys.
        let i = shuffle(self.reversed_index, (h.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as u32);
        DVec2::new(sobol_unit(owen_scramble(i, h as u32)), sobol_unit(owen_scramble(sobol_second(i), (h >> 32) as u32)))
    }

    /// The scramble keys of the next dimension (one draw) for the whole pixel.
    #[inline(always)]
    fn dimension_key(&mut self) -> u64 {
        let h = mix64(self.chain ^ u64::from(self.dim).wrapping_mul(0xC2B2_AE3D_27D4_EB4F));
        self.dim += 1;
        h
    }

    /// Skips one number: the stream goes on as if one had been drawn ([`Sampler::next_1d`],
    /// [`Sampler::pixel_1d`] or [`Sampler::next_pattern`]) and dropped, without computing it
    /// (a light's choice among one, the pattern of a single sample).
    #[inline]
    pub fn skip_1d(&mut self) {
        self.dim += 1;
    }

    /// A 32-bit pattern key for [`stratified_2d`], unique to this stream and dimension.
    #[inline]
    pub fn next_pattern(&mut self) -> u32 {
        let h = mix64(self.key ^ u64::from(self.dim).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        self.dim += 1;
        (h >> 32) as u32
    }
}

/// A render seed hashed for [`Sampler::with_seed`]: what every stream of a render shares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeedKey(u64);

impl SeedKey {
    /// The hash of render seed `seed`.
    #[inline]
    pub fn new(seed: u64) -> Self {
        SeedKey(mix64(seed.wrapping_add(0x9E37_79B9_7F4A_7C15)))
    }

    /// The hash of pixel (or stream) key `pixel` under this seed: what the streams of all its
    /// samples start from ([`Sampler::with_pixel_key`]).
    #[inline]
    pub fn pixel(self, pixel: u64) -> PixelKey {
        PixelKey(mix64(pixel ^ self.0))
    }
}

/// A pixel's key hashed with the render seed ([`SeedKey::pixel`]): what the streams of the
/// pixel's samples share.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelKey(u64);

/// Sample `index` of a stratified set of `count` points in [0, 1)² (correlated multi-jittered),
/// for pattern `pattern`. Each of the `count` points falls in its own cell of an m × n grid
/// (m·n ≥ count) and the projections on both axes are stratified too. A loop over one set's
/// points builds its [`StratifiedSet`] once instead (the same points).
// Not inlined: callers' hot loops (the camera sample path) stay as small as before.
#[inline(never)]
pub fn stratified_2d(index: u32, count: u32, pattern: u32) -> DVec2 {
    StratifiedSet::new(count, pattern).point(index)
}

/// The set of [`stratified_2d`] points for one `count` and `pattern`, with what its points share
/// (grid shape, hashed pattern keys, permutation masks, divisors) computed once.
#[derive(Clone, Copy, Debug)]
pub struct StratifiedSet {
    /// The set's size (≥ 1) and the m × n grid.
    count: Permutation,
    m: Permutation,
    n: Permutation,
    /// Pattern keys of the two jitters.
    jx: u32,
    jy: u32,
}

/// Point `index` of the first two dimensions of the Sobol sequence, a (0, 2)-sequence, each
/// coordinate scrambled by XOR with a hash of `pattern` (which keeps it a (0, 2)-sequence):
/// every prefix of 2^k points puts one point in each elementary interval of area 2^-k, so a
/// pixel that stops after any power of two of samples is stratified as if that were its count.
#[inline]
pub fn sobol_02(index: u32, pattern: u32) -> DVec2 {
    let h = mix64(u64::from(pattern) ^ 0x5851_f42d_4c95_7f2d);
    let x = index.reverse_bits() ^ (h as u32);
    let y = sobol_second(index).reverse_bits() ^ ((h >> 32) as u32);
    let unit = |b: u32| (f64::from(b) * (1.0 / 4_294_967_296.0)).min(ONE_MINUS_EPSILON);
    DVec2::new(unit(x), unit(y))
}

/// The second dimension of the Sobol sequence at `index`, bit-reversed (its least significant
/// bit is the point's most significant digit): the Pascal triangle mod 2 applied to `index`'s
/// bits. Bit `j` of the result is the parity of the bits `k` of `index` with `C(k, j)` odd,
/// that is (Lucas) with `j`'s bits a subset of `k`'s: a superset-sum transform over the five
/// bits of a bit position, five masked shifts.
#[inline(always)]
fn sobol_second(index: u32) -> u32 {
    let mut x = index;
    x ^= (x >> 1) & 0x5555_5555;
    x ^= (x >> 2) & 0x3333_3333;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^= (x >> 16) & 0x0000_ffff;
    x
}

/// A nested uniform scramble (Owen) of the digits of the bit-reversed value `v` (least
/// significant bit = first binary digit), keyed by `seed`, returned in the usual order (most
/// significant bit first): the Laine–Karras hash as pbrt-v4's `FastOwenScrambler` applies it.
/// Each step flips a digit by a function of the digits before it only (multiplications by even
/// numbers, an addition, a multiplication by an odd one, all in the reversed order), so every
/// elementary interval is carried onto one of the same size: nets stay nets.
#[inline(always)]
fn owen_scramble(v: u32, seed: u32) -> u32 {
    laine_karras(v, seed).reverse_bits()
}

/// The Laine–Karras hash: bit `b` of the result is bit `b` of `v` flipped by a function of the
/// bits below it and `seed` (a nested permutation, read from the least significant bit).
#[inline(always)]
fn laine_karras(mut v: u32, seed: u32) -> u32 {
    v ^= v.wrapping_mul(0x3d20_adea);
    v = v.wrapping_add(seed);
    v = v.wrapping_mul((seed >> 16) | 1);
    v ^= v.wrapping_mul(0x0552_6c56);
    v ^= v.wrapping_mul(0x53a2_2864);
    v
}

/// A sample index shuffled by a nested permutation keyed by `seed`, from the index
/// bit-reversed (`reversed_index`): bit `j` of the index is flipped by a function of its bits
/// above `j`. The indices `0 .. 2^k` then go to one aligned block `c·2^k .. (c+1)·2^k` of
/// the sequence (their bits from `k` up were all zero, so they all flip alike), and such a block
/// of Sobol points is a (0, k, 2)-net like the first: every power-of-two prefix stays
/// stratified, while dimensions with different keys take their points in unrelated orders (not
/// all from one shared order, which would tie a pixel's samples' numbers in one dimension to
/// their numbers in every other).
#[inline(always)]
fn shuffle(reversed_index: u32, seed: u32) -> u32 {
    // The same nested permutation as a digit scramble, applied to the index.
    owen_scramble(reversed_index, seed)
}

/// A 32-bit binary fraction as the centre of its interval of width 2⁻³²: never 0, never 1.
#[inline(always)]
fn sobol_unit(v: u32) -> f64 {
    (f64::from(v) + 0.5) * (1.0 / 4_294_967_296.0)
}

/// The `m` columns and `n` rows of strata of a stratified set of `count` points (0 counts as 1):
/// `m = ⌈√count⌉`, `n = ⌈count / m⌉`; each point of the set lies in its own stratum.
#[inline]
pub fn strata(count: u32) -> (u32, u32) {
    let count = count.max(1);
    // ⌈√count⌉, without `ceil` (a library call on x86-64 without SSE4.1): the truncation,
    // plus one where it fell short.
    let root = (count as f64).sqrt();
    let m = (root as u32 + u32::from(f64::from(root as u32) < root)).max(1);
    (m, count.div_ceil(m))
}

impl StratifiedSet {
    /// The set of `count` points (0 counts as 1) for `pattern`.
    #[inline]
    pub fn new(count: u32, pattern: u32) -> Self {
        let count = count.max(1);
        let (m, n) = strata(count);
        StratifiedSet {
            count: Permutation::new(count, pattern.wrapping_mul(0x51633e2d)),
            m: Permutation::new(m, pattern.wrapping_mul(0x68bc21eb)),
            n: Permutation::new(n, pattern.wrapping_mul(0x02e5be93)),
            jx: pattern.wrapping_mul(0x967a889b),
            jy: pattern.wrapping_mul(0x368cc8b7),
        }
    }

    /// Point `index` (below the set's size) of the set: `stratified_2d(index, count, pattern)`.
    #[inline]
    pub fn point(&self, index: u32) -> DVec2 {
        let s = self.count.apply(index);
        let (row, col) = self.m.div_rem(s);
        self.point_at(s, self.m.apply(col), self.n.apply(row))
    }

    /// The point of stratum `s`, whose column and row are permuted to `sx` and `sy`.
    #[inline(always)]
    fn point_at(&self, s: u32, sx: u32, sy: u32) -> DVec2 {
        let jx = randfloat(s, self.jx);
        let jy = randfloat(s, self.jy);
        let (m, n, count) = (self.m.len as f64, self.n.len as f64, self.count.len as f64);
        DVec2::new(((sx as f64 + (sy as f64 + jx) / n) / m).min(ONE_MINUS_EPSILON), ((s as f64 + jy) / count).min(ONE_MINUS_EPSILON))
    }

    /// Whether [`TabledSet::new`] pays for itself over `points` calls of [`StratifiedSet::point`]:
    /// the set's grid fits the table, and its `m + n` permuted columns and rows cost fewer
    /// permutations than the two per point they save.
    #[inline]
    pub fn tabled_pays(&self, points: u32) -> bool {
        let (m, n) = (self.m.len, self.n.len);
        m as usize <= TABLED_STRATA && n as usize <= TABLED_STRATA && m + n < points.saturating_mul(2)
    }
}

/// Most columns and rows of a [`TabledSet`]'s grid (sets of up to 64² = 4096 points).
pub const TABLED_STRATA: usize = 64;

/// A [`StratifiedSet`] with its permuted columns and rows computed once: the same points, two
/// permutations fewer per point, for a loop over many points of one set (a pixel's samples).
#[derive(Clone, Copy, Debug)]
pub struct TabledSet {
    set: StratifiedSet,
    cols: [u16; TABLED_STRATA],
    rows: [u16; TABLED_STRATA],
}

impl TabledSet {
    /// `set` with its tables, or `None` when its grid is larger than [`TABLED_STRATA`] a side.
    #[inline]
    pub fn new(set: &StratifiedSet) -> Option<Self> {
        let (m, n) = (set.m.len as usize, set.n.len as usize);
        if m > TABLED_STRATA || n > TABLED_STRATA {
            return None;
        }
        let mut t = TabledSet { set: *set, cols: [0; TABLED_STRATA], rows: [0; TABLED_STRATA] };
        for (c, v) in t.cols[..m].iter_mut().enumerate() {
            *v = set.m.apply(c as u32) as u16;
        }
        for (r, v) in t.rows[..n].iter_mut().enumerate() {
            *v = set.n.apply(r as u32) as u16;
        }
        Some(t)
    }

    /// [`StratifiedSet::point`]`(index)`, to the bit.
    #[inline]
    pub fn point(&self, index: u32) -> DVec2 {
        let set = &self.set;
        let s = set.count.apply(index);
        let (row, col) = set.m.div_rem(s);
        // `col < m` and `row < n` (`s < count ≤ m·n`): within the tables' filled part.
        set.point_at(s, u32::from(self.cols[col as usize % TABLED_STRATA]), u32::from(self.rows[row as usize % TABLED_STRATA]))
    }

    /// [`TabledSet::point`] for [`FILM_LANES`] indices at once (each below the set's size), to
    /// the bit: each step written lane by lane over arrays, so that a caller compiled for wider
    /// vectors (AVX2) runs each in a few vector instructions. The same integer operations; the
    /// quotients of [`Permutation::div_rem`] by `f64` division and truncation, which is exact
    /// here: for `a < 2³²` and `0 < len < 2³²`, `a / len` is either whole or at least
    /// `1 / len` below the next integer, a relative gap above 2⁻³³, far wider than the
    /// division's rounding (2⁻⁵³), so the truncated quotient is `⌊a / len⌋`.
    #[inline(always)]
    pub fn points(&self, index: &[u32; FILM_LANES]) -> [DVec2; FILM_LANES] {
        const L: usize = FILM_LANES;
        let set = &self.set;
        // `(⌊a / len⌋, a mod len)` lane by lane, as `Permutation::div_rem`.
        #[inline(always)]
        fn div_rem(p: &Permutation, a: &[u32; L], quot: &mut [u32; L], rem: &mut [u32; L]) {
            if p.len <= 1 {
                (*quot, *rem) = (*a, [0; L]);
                return;
            }
            let len = f64::from(p.len);
            for k in 0..L {
                quot[k] = (f64::from(a[k]) / len) as u32;
            }
            for k in 0..L {
                rem[k] = a[k] - quot[k] * p.len;
            }
        }
        // `s = count.apply(index)`: one round of Kensler's permutation for every lane, then
        // the lanes it left at or above `len` walked on one at a time (`permute`'s loop).
        let c = &set.count;
        let mut s = [0u32; L];
        if c.len > 1 {
            let mut i = [0u32; L];
            for k in 0..L {
                i[k] = permute_round(index[k], c.mask, c.p);
            }
            for v in &mut i {
                if *v >= c.len {
                    *v = permute(*v, c.mask, c.len, c.p);
                }
            }
            for v in &mut i {
                *v = v.wrapping_add(c.p);
            }
            div_rem(c, &i, &mut [0; L], &mut s);
        }
        let (mut row, mut col) = ([0u32; L], [0u32; L]);
        div_rem(&set.m, &s, &mut row, &mut col);
        let (m, n, count) = (set.m.len as f64, set.n.len as f64, set.count.len as f64);
        let mut out = [DVec2::ZERO; L];
        for k in 0..L {
            let sx = f64::from(self.cols[col[k] as usize % TABLED_STRATA]);
            let sy = f64::from(self.rows[row[k] as usize % TABLED_STRATA]);
            // As `StratifiedSet::point_at`.
            out[k] = DVec2::new(
                ((sx + (sy + randfloat(s[k], set.jx)) / n) / m).min(ONE_MINUS_EPSILON),
                ((s[k] as f64 + randfloat(s[k], set.jy)) / count).min(ONE_MINUS_EPSILON),
            );
        }
        out
    }
}

/// The points [`TabledSet::points`] computes at once.
pub const FILM_LANES: usize = 8;

/// Kensler's hash-based permutation of `0..len` for key `p`, with its mask and an exact division
/// by `len` by multiplication (Lemire et al. 2019, "Faster remainder by direct computation":
/// `⌊a / len⌋` and `a mod len` for every 32-bit `a` from a 64-bit reciprocal) precomputed.
#[derive(Clone, Copy, Debug)]
struct Permutation {
    len: u32,
    p: u32,
    /// `len − 1` with every lower bit set.
    mask: u32,
    /// `⌈2⁶⁴ / len⌉` (wrapping to 0 for `len` 1, whose quotient is then taken directly).
    reciprocal: u64,
}

impl Permutation {
    #[inline]
    fn new(len: u32, p: u32) -> Self {
        let mut w = len.saturating_sub(1);
        w |= w >> 1;
        w |= w >> 2;
        w |= w >> 4;
        w |= w >> 8;
        w |= w >> 16;
        Permutation { len, p, mask: w, reciprocal: (u64::MAX / u64::from(len.max(1))).wrapping_add(1) }
    }

    /// `(⌊a / len⌋, a mod len)`.
    #[inline]
    fn div_rem(&self, a: u32) -> (u32, u32) {
        if self.len <= 1 {
            return (a, 0);
        }
        let low = self.reciprocal.wrapping_mul(u64::from(a));
        let rem = ((u128::from(low) * u128::from(self.len)) >> 64) as u32;
        let quot = ((u128::from(self.reciprocal) * u128::from(a)) >> 64) as u32;
        (quot, rem)
    }

    /// The image of `i` (below `len`).
    #[inline]
    fn apply(&self, i: u32) -> u32 {
        if self.len <= 1 {
            return 0;
        }
        self.div_rem(permute(i, self.mask, self.len, self.p).wrapping_add(self.p)).1
    }
}

/// The largest `f64` below 1.
pub const ONE_MINUS_EPSILON: f64 = 1.0 - f64::EPSILON / 2.0;

/// A point on the unit disc from a point in [0, 1)², preserving stratification (Shirley–Chiu
/// concentric mapping). The angle's sine and cosine come from [`sin_cos_octant`] (within 3·10⁻¹⁶
/// of the exact values, a few ulp; `sin_cos` is a library call at several times the cost).
///
/// Which coordinate is the larger is a coin toss per sample, which a branch predictor loses half
/// the time: the two cases are one computation with their operands and results swapped by
/// selects (the same operations in the same order either way: the same bits).
#[inline]
pub fn concentric_disc(u: DVec2) -> DVec2 {
    let o = 2.0 * u - DVec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return DVec2::ZERO;
    }
    // |x| > |y|: θ = π/4 · y/x, the point x·(cos θ, sin θ). Else θ = π/2 − φ with
    // φ = π/4 · x/y: (cos θ, sin θ) = (sin φ, cos φ), the point y·(sin φ, cos φ).
    // (`select_unpredictable`: an `if` here is compiled back into the branch.)
    let x_major = o.x.abs() > o.y.abs();
    let (radius, across) = std::hint::select_unpredictable(x_major, (o.x, o.y), (o.y, o.x));
    let (sin, cos) = sin_cos_octant(std::f64::consts::FRAC_PI_4 * (across / radius));
    let (a, b) = std::hint::select_unpredictable(x_major, (cos, sin), (sin, cos));
    radius * DVec2::new(a, b)
}

/// `(sin x, cos x)` for `|x| ≤ π/4`, by their Taylor polynomials to degree 15 and 16: the
/// truncation errs by at most (π/4)¹⁷/17! < 5·10⁻¹⁷ (sine) and (π/4)¹⁸/18! < 3·10⁻¹⁸ (cosine), and
/// Horner's rounding by a few ulp of the result (each term is below half the previous one), so
/// the result is within 3·10⁻¹⁶ of the exact values. Deterministic: plain multiplications and
/// additions, no library call.
#[inline]
pub fn sin_cos_octant(x: f64) -> (f64, f64) {
    // 1/k! for k = 2..=16.
    const F: [f64; 15] = [
        1.0 / 2.0,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40320.0,
        1.0 / 362880.0,
        1.0 / 3628800.0,
        1.0 / 39916800.0,
        1.0 / 479001600.0,
        1.0 / 6227020800.0,
        1.0 / 87178291200.0,
        1.0 / 1307674368000.0,
        1.0 / 20922789888000.0,
    ];
    let x2 = x * x;
    let s = F[13] * x2 - F[11];
    let s = s * x2 + F[9];
    let s = s * x2 - F[7];
    let s = s * x2 + F[5];
    let s = s * x2 - F[3];
    let s = s * x2 + F[1];
    let sin = x - x * x2 * s;
    let c = F[14] * x2 - F[12];
    let c = c * x2 + F[10];
    let c = c * x2 - F[8];
    let c = c * x2 + F[6];
    let c = c * x2 - F[4];
    let c = c * x2 + F[2];
    let c = c * x2 - F[0];
    let cos = 1.0 + x2 * c;
    (sin, cos)
}

/// An orthonormal pair `(b1, b2)` perpendicular to unit `w` (Duff et al. 2017, "Building an
/// Orthonormal Basis, Revisited"): maps disc samples into 3-D around an axis.
#[inline]
pub fn orthonormal_basis(w: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(w.z);
    let a = -1.0 / (sign + w.z);
    let b = w.x * w.y * a;
    (DVec3::new(1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x), DVec3::new(b, sign + w.y * w.y * a, -w.y))
}

/// SplitMix64's finaliser: a fast, well-mixing 64-bit hash.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[inline]
fn to_unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Kensler's hash-based permutation of `i` within `0..l` (`w`: `l − 1` with every lower bit
/// set), before its final offset by `p` modulo `l`.
#[inline]
fn permute(mut i: u32, w: u32, l: u32, p: u32) -> u32 {
    loop {
        i = permute_round(i, w, p);
        if i < l {
            return i;
        }
    }
}

/// One round of [`permute`]'s cycle walk (within `0..=w`).
#[inline(always)]
fn permute_round(mut i: u32, w: u32, p: u32) -> u32 {
    i ^= p;
    i = i.wrapping_mul(0xe170893d);
    i ^= p >> 16;
    i ^= (i & w) >> 4;
    i ^= p >> 8;
    i = i.wrapping_mul(0x0929eb3f);
    i ^= p >> 23;
    i ^= (i & w) >> 1;
    i = i.wrapping_mul(1 | (p >> 27));
    i = i.wrapping_mul(0x6935fa69);
    i ^= (i & w) >> 11;
    i = i.wrapping_mul(0x74dcb303);
    i ^= (i & w) >> 2;
    i = i.wrapping_mul(0x9e501cc3);
    i ^= (i & w) >> 2;
    i = i.wrapping_mul(0xc860a3df);
    i &= w;
    i ^= i >> 5;
    i
}

#[inline]
fn randfloat(mut i: u32, p: u32) -> f64 {
    i ^= p;
    i ^= i >> 17;
    i ^= i >> 10;
    i = i.wrapping_mul(0xb36534e5);
    i ^= i >> 12;
    i ^= i >> 21;
    i = i.wrapping_mul(0x93fc4795);
    i ^= 0xdf6e307f;
    i ^= i >> 17;
    i = i.wrapping_mul(1 | (p >> 18));
    i as f64 * (1.0 / 4_294_967_808.0)
}

#[cfg(test)]
mod tests {
    /// Every prefix of 2^k Sobol points, scrambled, has one point in each elementary interval
    /// of area 2^-k (every split into 2^a × 2^b cells with a + b = k).
    #[test]
    fn sobol_prefixes_are_0_2_nets() {
        for pattern in [0u32, 1, 0xdead_beef] {
            for k in 0..=8u32 {
                let n = 1u32 << k;
                let points: Vec<DVec2> = (0..n).map(|i| sobol_02(i, pattern)).collect();
                for a in 0..=k {
                    let (cols, rows) = (1u32 << a, 1u32 << (k - a));
                    let mut seen = vec![false; n as usize];
                    for p in &points {
                        let cell = (p.y * f64::from(rows)) as u32 * cols + (p.x * f64::from(cols)) as u32;
                        assert!(!seen[cell as usize], "pattern {pattern:#x}, {n} points, {cols}×{rows} cells: two in cell {cell}");
                        seen[cell as usize] = true;
                    }
                }
            }
        }
    }

    use super::*;

    /// The second Sobol dimension by the superset-sum transform is the Pascal-matrix loop's,
    /// bit-reversed (what `sobol_02` computes).
    #[test]
    fn sobol_second_dimension_matches_the_generator_loop() {
        let reference = |index: u32| {
            let (mut y, mut v, mut k) = (0u32, 1u32 << 31, index);
            while k != 0 {
                if k & 1 != 0 {
                    y ^= v;
                }
                k >>= 1;
                v ^= v >> 1;
            }
            y
        };
        let mut h = 1u64;
        for i in (0..70_000u32).chain((0..2000).map(|_| {
            h = mix64(h);
            h as u32
        })) {
            assert_eq!(sobol_second(i).reverse_bits(), reference(i), "index {i}");
        }
    }

    /// The samples `0 .. 2^k` of a pixel, for every `k`, put their [`Sampler::pixel_2d`] points
    /// of one dimension pair (one fork chain, one draw) in every elementary interval of area
    /// `2^-k` once (a (0, 2)-net), and their [`Sampler::pixel_1d`] numbers in every interval of
    /// width `2^-k` once: whatever the pixel's final count, each prefix is stratified.
    #[test]
    fn pixel_numbers_stratify_every_power_of_two_prefix() {
        let seed = SeedKey::new(17);
        for pixel in [0u64, 5, 123_456] {
            let key = seed.pixel(pixel);
            // The camera sample's stream, the second bounce's, a light's stream within it.
            let chains: [&dyn Fn(Sampler) -> Sampler; 3] = [&|s| s, &|s| s.fork(4).fork(4), &|s| s.fork(4).fork(1).fork(2)];
            for (c, chain) in chains.iter().enumerate() {
                // Draws 0 and 1: a pair, then a number, after one plain number.
                let draw = |i: u32| {
                    let mut s = chain(Sampler::with_pixel_key(key, i));
                    s.next_1d();
                    let p = s.pixel_2d();
                    (p, s.pixel_1d())
                };
                let points: Vec<(DVec2, f64)> = (0..512).map(draw).collect();
                for k in 0..=9u32 {
                    let n = 1usize << k;
                    let mut seen = vec![false; n];
                    for &(_, x) in &points[..n] {
                        let cell = (x * n as f64) as usize;
                        assert!(!seen[cell], "pixel {pixel}, chain {c}: {n} samples, two 1-D numbers in interval {cell}");
                        seen[cell] = true;
                    }
                    for a in 0..=k {
                        let (cols, rows) = (1u32 << a, 1u32 << (k - a));
                        let mut seen = vec![false; n];
                        for (p, _) in &points[..n] {
                            let cell = (p.y * f64::from(rows)) as u32 * cols + (p.x * f64::from(cols)) as u32;
                            assert!(!seen[cell as usize], "pixel {pixel}, chain {c}: {n} samples, {cols}×{rows} cells: two in {cell}");
                            seen[cell as usize] = true;
                        }
                    }
                }
            }
        }
    }

    /// A pixel number takes the place of the plain draws it replaces (the numbers after it are
    /// the same), and the pixel's sequences differ by pixel, by fork chain and by draw.
    #[test]
    fn pixel_numbers_keep_the_draw_count_and_differ_by_dimension() {
        let (mut a, mut b) = (Sampler::new(3, 5, 9), Sampler::new(3, 5, 9));
        a.next_2d();
        b.pixel_2d();
        a.next_1d();
        b.pixel_1d();
        assert_eq!(a.next_1d(), b.next_1d());
        // A skipped number counts as one drawn, of any kind.
        for draw in [Sampler::next_1d, Sampler::pixel_1d, |s: &mut Sampler| f64::from(s.next_pattern())] {
            let (mut a, mut b) = (Sampler::new(3, 5, 9), Sampler::new(3, 5, 9));
            draw(&mut a);
            b.skip_1d();
            assert_eq!((a.pixel_2d(), a.next_1d()), (b.pixel_2d(), b.next_1d()));
        }
        let first = |s: &Sampler| s.clone().pixel_2d();
        let s = Sampler::new(3, 5, 9);
        let mut t = s.clone();
        t.pixel_2d();
        assert_ne!(first(&s), t.pixel_2d());
        assert_ne!(first(&s), first(&s.fork(1)));
        assert_ne!(first(&s.fork(1)), first(&s.fork(2)));
        assert_ne!(first(&s.fork(1).fork(2)), first(&s.fork(2).fork(1)));
        assert_ne!(first(&s), first(&Sampler::new(4, 5, 9)));
        assert_ne!(first(&s), first(&Sampler::new(3, 5, 10)));
        // Samples of one pixel share the chain: the forks of sample 5 and 6 differ (their points do).
        assert_ne!(first(&Sampler::new(3, 6, 9).fork(1)), first(&s.fork(1)));
    }

    /// Two dimensions of a pixel are not tied: without the shuffle, the nested scrambles of one
    /// shared order would put a sample's numbers of every dimension in the same half of [0, 1)
    /// for all of a pixel's samples, or in opposite halves for all (a per-pixel error that
    /// never averages out). With it, a pixel's samples agree about half the time.
    #[test]
    fn pixel_dimensions_are_not_tied_to_each_other() {
        let seed = SeedKey::new(3);
        let mut tied = 0;
        let mut agree_total = 0;
        for pixel in 0..200u64 {
            let agree = (0..64u32)
                .filter(|&i| {
                    let mut s = Sampler::with_pixel_key(seed.pixel(pixel), i).fork(2);
                    let (a, b) = (s.pixel_1d(), s.pixel_2d());
                    let c = s.fork(9).pixel_1d();
                    (a < 0.5) == (b.x < 0.5) && (b.y < 0.5) == (c < 0.5)
                })
                .count();
            tied += usize::from(agree == 0 || agree == 64);
            agree_total += agree;
        }
        assert!(tied <= 2, "{tied} of 200 pixels have dimensions tied in halves");
        // Both pairs agree for a quarter of the samples, as for independent numbers.
        let share = agree_total as f64 / (200.0 * 64.0);
        assert!((share - 0.25).abs() < 0.03, "both agree in {share:.3} of samples");
    }

    /// Pixel numbers are uniform: a few samples of each of many pixels (a prefix that is no net,
    /// so the histogram shows the scrambles' randomness), a pair's two coordinates, and two
    /// draws of one sample against each other (padding: their scrambles are independent).
    #[test]
    fn pixel_numbers_pass_the_chi2_test() {
        use crate::testing::chi2::{Chi2Test, Rect};
        let test = Chi2Test::new(Rect { min: DVec2::ZERO, max: DVec2::ONE }).res(32, 32).tests(3);
        let seed = SeedKey::new(5);
        let (mut pixel, mut index) = (0u64, 0u32);
        let mut next = || {
            index += 1;
            if index == 3 {
                (pixel, index) = (pixel + 1, 0);
            }
            Sampler::with_pixel_key(seed.pixel(pixel), index).fork(7)
        };
        test.run(|_| Some(next().pixel_2d()), |_| 1.0).assert_passes("pixel_2d");
        test.run(
            |_| {
                let mut s = next();
                Some(DVec2::new(s.pixel_1d(), s.pixel_1d()))
            },
            |_| 1.0,
        )
        .assert_passes("two pixel_1d draws");
        test.run(
            |_| {
                let mut s = next();
                let a = s.pixel_2d();
                Some(DVec2::new(a.y, s.pixel_2d().x))
            },
            |_| 1.0,
        )
        .assert_passes("two pixel_2d draws");
        // Over all 64 samples of each pixel too (a net per pixel: only uniformity is tested).
        let (mut pixel, mut index) = (0u64, 0u32);
        test.run(
            |_| {
                index = (index + 1) % 64;
                pixel += u64::from(index == 0);
                Some(Sampler::with_pixel_key(seed.pixel(pixel), index).fork(2).pixel_2d())
            },
            |_| 1.0,
        )
        .assert_passes("whole pixels");
    }

    #[test]
    fn streams_are_deterministic_and_distinct() {
        let a: Vec<f64> = {
            let mut s = Sampler::new(7, 3, 42);
            (0..5).map(|_| s.next_1d()).collect()
        };
        let b: Vec<f64> = {
            let mut s = Sampler::new(7, 3, 42);
            (0..5).map(|_| s.next_1d()).collect()
        };
        let c: Vec<f64> = {
            let mut s = Sampler::new(7, 4, 42);
            (0..5).map(|_| s.next_1d()).collect()
        };
        assert_eq!(a, b);
        assert_ne!(a, c);
        let mut d = Sampler::with_seed(7, 3, SeedKey::new(42));
        assert_eq!(a, (0..5).map(|_| d.next_1d()).collect::<Vec<f64>>());
        assert!(a.iter().all(|v| (0.0..1.0).contains(v)));
    }

    #[test]
    fn forks_ignore_draws_and_differ_by_tag() {
        let a = Sampler::new(1, 2, 3);
        let mut b = a.clone();
        b.next_1d();
        assert_eq!(a.fork(5).next_1d(), b.fork(5).next_1d());
        assert_ne!(a.fork(5).next_1d(), a.fork(6).next_1d());
    }

    /// Elementary intervals: a set of `count` points on an m × n grid (m = ⌈√count⌉, n =
    /// ⌈count / m⌉) puts exactly one point in each of the `count` rows (y-strata of height
    /// 1/count), at most one in each of the m·n columns (x-strata of width 1/(m·n)), and, when
    /// `count` fills the grid (m·n = count), exactly one in each column, each m × n cell, each
    /// row: every elementary interval of area 1/count of the three shapes.
    #[test]
    fn stratified_points_fill_every_row_and_column_stratum() {
        let mut full = 0;
        for count in (1u32..=300).chain([1024, 1089, 4096]) {
            let m = ((count as f64).sqrt().ceil() as u32).max(1);
            let n = count.div_ceil(m);
            for pattern in [12345u32, 0, 0xdead_beef] {
                let pts: Vec<DVec2> = (0..count).map(|i| stratified_2d(i, count, pattern)).collect();
                let (mut rows, mut columns, mut cells) =
                    (vec![0u32; count as usize], vec![0u32; (m * n) as usize], vec![0u32; (m * n) as usize]);
                for p in &pts {
                    assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y), "count {count}: {p}");
                    rows[(p.y * f64::from(count)) as usize] += 1;
                    columns[(p.x * f64::from(m * n)) as usize] += 1;
                    cells[(p.y * f64::from(n)) as usize * m as usize + (p.x * f64::from(m)) as usize] += 1;
                }
                let at = |v: &[u32], want: u32| v.iter().position(|&k| k != want);
                assert_eq!(at(&rows, 1), None, "count {count}, pattern {pattern}: a row holds no point or two");
                assert!(columns.iter().all(|&k| k <= 1), "count {count}, pattern {pattern}: a column holds two points");
                if m * n == count {
                    assert_eq!(at(&columns, 1), None, "count {count} = {m}×{n}, pattern {pattern}: an empty column");
                    assert_eq!(at(&cells, 1), None, "count {count} = {m}×{n}, pattern {pattern}: a cell holds no point or two");
                    full += 1;
                }
            }
        }
        assert!(full > 90, "only {full} full grids checked");
    }

    /// The points of many sets (and the sampler's plain stream) are uniform over the square.
    #[test]
    fn stratified_sets_and_streams_pass_the_chi2_test() {
        use crate::testing::chi2::{Chi2Test, Rect};
        let test = Chi2Test::new(Rect { min: DVec2::ZERO, max: DVec2::ONE }).res(32, 32).tests(2);
        // Sets of 7 to 11 points, each set whole, one after another.
        let (mut set, mut index) = (0u32, 0u32);
        test.run(
            |_| {
                let count = 7 + set % 5;
                let p = stratified_2d(index, count, set.wrapping_mul(0x9E37_79B9));
                index += 1;
                if index == count {
                    (set, index) = (set + 1, 0);
                }
                Some(p)
            },
            |_| 1.0,
        )
        .assert_passes("stratified sets");
        let mut pixel = 0;
        test.run(
            |_| {
                pixel += 1;
                Some(Sampler::new(pixel, 3, 42).next_2d())
            },
            |_| 1.0,
        )
        .assert_passes("sampler streams");
    }

    /// Kensler's construction written out directly (divisions and all), as `stratified_2d` was
    /// before its set constants were hoisted: the hoisted form gives the same bits.
    fn reference_stratified_2d(index: u32, count: u32, pattern: u32) -> DVec2 {
        fn permute(i: u32, l: u32, p: u32) -> u32 {
            if l <= 1 {
                return 0;
            }
            let mut w = l - 1;
            w |= w >> 1;
            w |= w >> 2;
            w |= w >> 4;
            w |= w >> 8;
            w |= w >> 16;
            (super::permute(i, w, l, p).wrapping_add(p)) % l
        }
        let count = count.max(1);
        let m = ((count as f64).sqrt().ceil() as u32).max(1);
        let n = count.div_ceil(m);
        let s = permute(index, count, pattern.wrapping_mul(0x51633e2d));
        let sx = permute(s % m, m, pattern.wrapping_mul(0x68bc21eb));
        let sy = permute(s / m, n, pattern.wrapping_mul(0x02e5be93));
        let jx = randfloat(s, pattern.wrapping_mul(0x967a889b));
        let jy = randfloat(s, pattern.wrapping_mul(0x368cc8b7));
        DVec2::new(
            ((sx as f64 + (sy as f64 + jx) / n as f64) / m as f64).min(ONE_MINUS_EPSILON),
            ((s as f64 + jy) / count as f64).min(ONE_MINUS_EPSILON),
        )
    }

    #[test]
    fn hoisted_set_matches_the_direct_construction() {
        for count in (0..=70).chain([100, 255, 256, 257, 1000, 4097]) {
            for pattern in [0u32, 1, 9, 0x5eed, 12345, 0xdead_beef, u32::MAX] {
                let set = StratifiedSet::new(count, pattern);
                for i in 0..count.max(1) {
                    let want = reference_stratified_2d(i, count, pattern);
                    assert_eq!(set.point(i), want, "count {count}, pattern {pattern}, index {i}");
                    assert_eq!(stratified_2d(i, count, pattern), want);
                }
            }
        }
    }

    /// The tabled set gives every point of the set it tables, for grids up to the table's size,
    /// and declines larger ones.
    #[test]
    fn tabled_set_matches_the_set() {
        for count in (0..=70).chain([100, 255, 256, 257, 1000, 4095, 4096, 4097, 5000]) {
            for pattern in [0u32, 1, 9, 0x5eed, 0xdead_beef, u32::MAX] {
                let set = StratifiedSet::new(count, pattern);
                let Some(t) = TabledSet::new(&set) else {
                    assert!(count > 4096, "count {count} fits the table");
                    assert!(!set.tabled_pays(u32::MAX));
                    continue;
                };
                assert!(count <= 4096, "count {count}");
                for i in 0..count.max(1) {
                    assert_eq!(t.point(i), set.point(i), "count {count}, pattern {pattern}, index {i}");
                }
            }
        }
    }

    /// `TabledSet::points` gives `TabledSet::point` for each of its lanes, to the bit, for
    /// every index of sets up to the table's size (lanes in order and in reverse, so each index
    /// is met in several lanes).
    #[test]
    fn eight_points_at_once_match_the_points() {
        for count in (0..=70).chain([100, 255, 256, 257, 1000, 4095, 4096]) {
            for pattern in [0u32, 1, 9, 0x5eed, 0xdead_beef, u32::MAX] {
                let set = StratifiedSet::new(count, pattern);
                let t = TabledSet::new(&set).unwrap();
                let count = count.max(1);
                for first in 0..count {
                    let index: [u32; super::FILM_LANES] = std::array::from_fn(|k| (first + k as u32) % count);
                    let at = t.points(&index);
                    let back = t.points(&std::array::from_fn(|k| index[super::FILM_LANES - 1 - k]));
                    for k in 0..super::FILM_LANES {
                        assert_eq!(at[k], t.point(index[k]), "count {count}, pattern {pattern}, index {}", index[k]);
                        assert_eq!(back[super::FILM_LANES - 1 - k], at[k]);
                    }
                }
            }
        }
    }

    /// The quotient `TabledSet::points` takes by `f64` division and truncation is `⌊a / len⌋`
    /// for 32-bit `a` and `len`, at the edges where rounding could reach the next integer.
    #[test]
    fn truncated_float_quotients_are_exact() {
        let mut a_values: Vec<u32> = (0..3000).collect();
        a_values.extend([u32::MAX, u32::MAX - 1, 1 << 31, (1 << 31) - 1, (1 << 31) + 1, 0xdead_beef, 4_294_967_291]);
        for len in (1..300).chain([1023, 1024, 1025, 4095, 4096, 4097, 65535, 65536, 65537, 4_294_967_291, u32::MAX]) {
            // Just below, at and just above each multiple of `len` near the top of the range.
            let top = (u32::MAX / len) * len;
            let mut values = a_values.clone();
            for q in [top, top - top % len, (top / 2) / len * len] {
                values.extend([q.wrapping_sub(1), q, q.wrapping_add(1)]);
            }
            for &a in &values {
                assert_eq!((f64::from(a) / f64::from(len)) as u32, a / len, "{a} / {len}");
            }
        }
    }

    #[test]
    fn division_by_reciprocal_is_exact() {
        let mut a_values: Vec<u32> = (0..2000).collect();
        a_values.extend([u32::MAX, u32::MAX - 1, 1 << 31, (1 << 31) - 1, 0xdead_beef, 4_294_967_291]);
        for len in (1..300).chain([1023, 1024, 1025, 65535, 65536, 65537, 4_294_967_291, u32::MAX]) {
            let perm = Permutation::new(len, 0);
            for &a in &a_values {
                assert_eq!(perm.div_rem(a), (a / len, a % len), "{a} / {len}");
            }
        }
    }

    #[test]
    fn basis_is_orthonormal() {
        for w in [DVec3::X, DVec3::NEG_Z, DVec3::Z, DVec3::new(0.3, -0.5, 0.8).normalize(), DVec3::new(-1e-9, 1.0, -1e-12).normalize()] {
            let (a, b) = orthonormal_basis(w);
            for (x, y) in [(a, b), (a, w), (b, w)] {
                assert!(x.dot(y).abs() < 1e-12);
            }
            assert!((a.length() - 1.0).abs() < 1e-12 && (b.length() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn octant_sin_cos_is_within_its_bound() {
        let quarter = std::f64::consts::FRAC_PI_4;
        for k in -100_000..=100_000 {
            let x = quarter * f64::from(k) / 100_000.0;
            let (s, c) = sin_cos_octant(x);
            assert!((s - x.sin()).abs() <= 3e-16 && (c - x.cos()).abs() <= 3e-16, "{x}: {s} {c}");
        }
        assert_eq!(sin_cos_octant(0.0), (0.0, 1.0));
    }

    /// The library's sine and cosine in the mapping, as before [`sin_cos_octant`]: the points
    /// differ by a few ulp at most.
    #[test]
    fn concentric_mapping_matches_the_library_angle() {
        for i in 0..4096 {
            let u = stratified_2d(i, 4096, 77);
            let o = 2.0 * u - DVec2::ONE;
            let (r, theta) = if o.x.abs() > o.y.abs() {
                (o.x, std::f64::consts::FRAC_PI_4 * (o.y / o.x))
            } else {
                (o.y, std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (o.x / o.y))
            };
            let want = r * DVec2::new(theta.cos(), theta.sin());
            assert!((concentric_disc(u) - want).abs().max_element() <= 1e-15, "{u}");
        }
        for u in [DVec2::ZERO, DVec2::ONE * ONE_MINUS_EPSILON, DVec2::new(0.0, ONE_MINUS_EPSILON), DVec2::new(0.5, 0.0), DVec2::splat(0.5)]
        {
            assert!(concentric_disc(u).length() <= 1.0 + 1e-15, "{u}");
        }
    }

    /// The mapping with its two cases chosen by selects gives the bits the branches gave
    /// (written here as they were): the images stay the same. Random points, the diagonals
    /// (where the cases meet), the axes and the corners.
    #[test]
    fn concentric_mapping_by_selects_is_the_branches_bit_for_bit() {
        let branches = |u: DVec2| {
            let o = 2.0 * u - DVec2::ONE;
            if o.x == 0.0 && o.y == 0.0 {
                return DVec2::ZERO;
            }
            if o.x.abs() > o.y.abs() {
                let (sin, cos) = sin_cos_octant(std::f64::consts::FRAC_PI_4 * (o.y / o.x));
                o.x * DVec2::new(cos, sin)
            } else {
                let (sin, cos) = sin_cos_octant(std::f64::consts::FRAC_PI_4 * (o.x / o.y));
                o.y * DVec2::new(sin, cos)
            }
        };
        let mut points: Vec<DVec2> = (0..1 << 16).map(|i| stratified_2d(i, 1 << 16, 3)).collect();
        for i in 0..=256 {
            let t = f64::from(i) / 256.0 * ONE_MINUS_EPSILON;
            points.extend([DVec2::splat(t), DVec2::new(t, 1.0 - t), DVec2::new(t, 0.5), DVec2::new(0.5, t), DVec2::new(t, 0.0)]);
        }
        for u in points {
            let (got, want) = (concentric_disc(u), branches(u));
            assert_eq!(got.to_array().map(f64::to_bits), want.to_array().map(f64::to_bits), "{u}");
        }
    }

    /// The concentric mapping carries uniform points of the square to uniform points of the
    /// disc (density `1 / π`): the lens's and the diffuse lobe's sampling.
    #[test]
    fn concentric_mapping_passes_the_chi2_test() {
        use crate::testing::chi2::{Chi2Test, Rect};
        Chi2Test::new(Rect { min: DVec2::splat(-1.0), max: DVec2::ONE })
            .res(50, 50)
            .run(|u| Some(concentric_disc(u.next_2d())), |p| if p.length_squared() <= 1.0 { std::f64::consts::FRAC_1_PI } else { 0.0 })
            .assert_passes("concentric disc");
    }

    /// A pair passed over is two numbers skipped ([`Sampler::skip_1d`], as the path tracer's
    /// BSDF numbers skip an unread direction): every later draw is as it was when drawn; one
    /// skip is not a pair's.
    #[test]
    fn a_skipped_pair_is_two_numbers() {
        for sample in [0u32, 1, 5, 63] {
            let base = Sampler::new(17, sample, 3).fork(2);
            let (mut drawn, mut skipped) = (base.clone(), base.clone());
            let _ = (drawn.pixel_1d(), drawn.pixel_2d(), drawn.next_2d());
            for _ in 0..5 {
                skipped.skip_1d();
            }
            assert_eq!((drawn.pixel_2d(), drawn.next_1d()), (skipped.pixel_2d(), skipped.next_1d()), "sample {sample}");
            let (mut drawn, mut skipped) = (base.clone(), base);
            let _ = drawn.pixel_2d();
            skipped.skip_1d();
            assert_ne!(drawn.pixel_1d(), skipped.pixel_1d(), "sample {sample}: one skip is not a pair's");
        }
    }

    #[test]
    fn concentric_mapping_stays_in_disc() {
        for i in 0..100 {
            let d = concentric_disc(stratified_2d(i, 100, 9));
            assert!(d.length() <= 1.0 + 1e-12);
        }
    }
}
