//! Exact per-pixel sums. A pixel's colour is the mean of its samples' radiance; the sums are kept
//! in fixed point (`i128`, 64 fraction bits), where addition is exact and so does not depend on
//! order. That is what lets a frame be split by tiles, crops, sample passes, machines or a
//! resume and merge to the same bits as one process: the sums of disjoint shares of a pixel's
//! samples add up to exactly the sum one process computes.
//!
//! Range: each sample is rounded to the nearest multiple of 2⁻⁶⁴ (far below an `f32` film's
//! resolution at any value it can hold above 10⁻¹⁹), and a pixel's sum saturates at
//! ±2⁶³ ≈ 9.2·10¹⁸ (it never wraps).

use crate::math::color::{Color, LUMINANCE, luminance};
use crate::render::aov::AovSample;
use glam::Vec3;

/// 2⁶⁴: one unit of the colour sums.
const COLOR_SCALE: f64 = 18_446_744_073_709_551_616.0;
/// 2⁻⁶⁴: [`COLOR_SCALE`]'s reciprocal (exact).
const COLOR_UNIT: f64 = 1.0 / COLOR_SCALE;
/// 2³²: one unit of the depth sums (scene units).
const DEPTH_SCALE: f64 = 4_294_967_296.0;
/// 2³²: one unit of the emission sums (radiance): a pixel's sum saturates at 2³¹ ≈ 2.1·10⁹
/// (radiance × samples), each sample rounded to 2⁻³² (far below an `f32` film's resolution at the
/// values emitters have).
const EMITTED_SCALE: f64 = 4_294_967_296.0;
/// 2⁴⁰: one unit of the normal and albedo sums (each component is within [−1, 1]).
const UNIT_SCALE: f64 = 1_099_511_627_776.0;

/// `x` in units of `1 / scale`, rounded to nearest (half away from zero), saturating (NaN: 0).
#[inline]
fn fixed(x: f64, scale: f64) -> i128 {
    let y = x * scale;
    // Without library calls (`f64::round` and `as i128` are calls on x86-64 without SSE4.1), to
    // the bit: below 2⁵² through the integer part (`y − i` is exact: Sterbenz); from 2⁵² to just below
    // 2¹²⁶ (8.5·10³⁷; colours up to 2⁶² at the 2⁶⁴ scale) `y` is whole, and its significand shifted by its
    // exponent is exactly its value (no conversion, no saturation checks); beyond, the slow path.
    let a = y.abs();
    if a < 4_503_599_627_370_496.0 {
        let i = y as i64;
        let frac = y - i as f64;
        (i + i64::from(frac >= 0.5) - i64::from(frac <= -0.5)) as i128
    } else if a < 8.5e37 {
        let bits = y.to_bits();
        let significand = i128::from((bits & 0x000F_FFFF_FFFF_FFFF) | 0x0010_0000_0000_0000);
        let magnitude = significand << (((bits >> 52) & 0x7FF) - 1075);
        if y < 0.0 { -magnitude } else { magnitude }
    } else {
        y.round() as i128
    }
}

/// [`fixed`] at [`COLOR_SCALE`], the same value, with short paths for what radiance usually is:
/// zero, or `2⁻¹² ≤ x < 2⁶²`, where `x · 2⁶⁴` is whole and is the significand shifted left by
/// `exponent − 1011` (at most 73 places).
#[inline(always)]
fn fixed_color(x: f64) -> i128 {
    let bits = x.to_bits();
    // The sign bit is part of the exponent here: negative values take the long path.
    let shift = (bits >> 52).wrapping_sub(1011);
    if shift < 74 {
        i128::from((bits & 0x000F_FFFF_FFFF_FFFF) | 0x0010_0000_0000_0000) << shift
    } else if x == 0.0 {
        0
    } else {
        fixed_color_rest(x)
    }
}

/// [`fixed_color`] off its short paths: negative, tiny (subnormals included), huge and non-finite
/// colours, out of line.
#[inline(never)]
fn fixed_color_rest(x: f64) -> i128 {
    fixed(x, COLOR_SCALE)
}

/// `s + v`, saturating; the saturation (a sum beyond ±2⁶³ in colour units) out of line.
#[inline(always)]
fn add_saturating(s: i128, v: i128) -> i128 {
    #[cold]
    #[inline(never)]
    fn saturated(s: i128, v: i128) -> i128 {
        s.saturating_add(v)
    }
    s.checked_add(v).unwrap_or_else(|| saturated(s, v))
}

/// `s` as a float: the sum of its two 64-bit halves, each converted in one instruction (not
/// rounded once like `s as f64`, but as deterministic, and within 2 ulp).
#[inline]
fn float(s: i128) -> f64 {
    ((s >> 64) as i64) as f64 * 18_446_744_073_709_551_616.0 + (s as u64) as f64
}

/// Whether the render loop's copies compiled for AVX2 (the film positions, the exact sums) run:
/// where the CPU has AVX2 and `RAYLAB_SIMD` is not `baseline`. Decided once.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn runs_avx2() -> bool {
    static AVX2: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AVX2.get_or_init(|| std::env::var_os("RAYLAB_SIMD").is_none_or(|v| v != "baseline") && std::arch::is_x86_feature_detected!("avx2"))
}

/// The finite radiance of some camera rays, summed exactly, with their count and how many of the
/// pixel's samples they came from.
///
/// `repr(C)`: `sum` and `sq` are four `i128` in a row, which [`PixelSum::add_sample`]'s AVX2 copy
/// reads and writes as two 32-byte vectors.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct PixelSum {
    /// Σ radiance per channel, in units of 2⁻⁶⁴.
    pub sum: [i128; 3],
    /// Σ of each ray's squared luminance (Rec. 709), in units of 2⁻⁶⁴: with `sum`, the sample
    /// variance behind [`PixelSum::std_error`].
    pub sq: i128,
    /// Σ luminance of the rays of the second half of the samples (a checkerboard over the
    /// pixel's strata; for Sobol points, the samples from the last power of two on), in units of
    /// 2⁻⁶⁴: the two halves behind [`PixelSum::half_variance`].
    pub odd: i128,
    /// Rays whose radiance was finite (the divisor of the mean).
    pub n: u32,
    /// Of those, rays of the second half.
    pub n_odd: u32,
    /// Samples of the pixel's share already added (for a resume: which come next).
    pub samples: u32,
}

// `PixelSum::add_sample_avx2` reads `sum` and `sq` as the struct's first 64 bytes.
const _: () =
    assert!(std::mem::offset_of!(PixelSum, sum) == 0 && std::mem::offset_of!(PixelSum, sq) == 48 && std::mem::align_of::<PixelSum>() >= 8);

impl PixelSum {
    /// Adds one ray's radiance `c` (finite), to the first half.
    #[inline]
    pub fn add(&mut self, c: Color) {
        self.add_luminance(c);
    }

    /// Adds one ray's radiance `c` (finite), to the second of the two halves of the error
    /// estimate when `second` ([`PixelSum::half_variance`]).
    ///
    /// Always inlined: the choice of copy is made where it is called, not in a call of its own.
    #[inline(always)]
    pub fn add_sample(&mut self, c: Color, second: bool) {
        #[cfg(target_arch = "x86_64")]
        if runs_avx2() {
            // SAFETY: `runs_avx2()` is true only where the CPU has AVX2.
            unsafe { self.add_sample_avx2(c, second) };
            return;
        }
        self.add_sample_scalar(c, second);
    }

    /// [`PixelSum::add_sample`] channel by channel (any CPU).
    #[inline(never)]
    fn add_sample_scalar(&mut self, c: Color, second: bool) {
        let y = self.add_luminance(c);
        self.add_second(y, second);
    }

    /// [`PixelSum::add_sample_scalar`] as the AVX2 copy's way out (off its short path, or at
    /// saturation), out of its way.
    #[cfg(target_arch = "x86_64")]
    #[cold]
    #[inline(never)]
    fn add_sample_rare(&mut self, c: Color, second: bool) {
        self.add_sample_scalar(c, second);
    }

    /// The second half's sum and count, for a ray of luminance `y` in it.
    #[inline(always)]
    fn add_second(&mut self, y: f64, second: bool) {
        if second {
            self.odd = add_saturating(self.odd, fixed_color(y));
            self.n_odd += 1;
        }
    }

    /// [`PixelSum::add_sample`] with the four conversions and exact additions of the colour sums
    /// and the squared luminance done together, one 64-bit lane each (AVX2), to the bit: each
    /// lane is [`fixed_color`]'s short path (the significand shifted by `exponent − 1011` into a
    /// 128-bit value, split into its 64-bit halves by two variable shifts, AVX2's `vpsllvq` and
    /// `vpsrlvq`, which give 0 for counts of 64 or more) added to its sum with the carry from the
    /// low half. A sample with a value off the short path (negative, tiny, huge) or a sum that
    /// would overflow (and saturate) is added channel by channel instead, from the same state.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_sample_avx2(&mut self, c: Color, second: bool) {
        use std::arch::x86_64::*;
        let y = luminance(c);
        // Lanes in the order the sums' halves come out of `unpack` below: r, b, g, y².
        let v = _mm256_castpd_si256(_mm256_set_pd(y * y, c.y, c.z, c.x));
        let sign = _mm256_set1_epi64x(i64::MIN);
        let shift = _mm256_sub_epi64(_mm256_srli_epi64::<52>(v), _mm256_set1_epi64x(1011));
        // `shift < 74` unsigned (the sign bit in the exponent's place sends negatives off it).
        let short = _mm256_cmpgt_epi64(_mm256_set1_epi64x(74 ^ i64::MIN), _mm256_xor_si256(shift, sign));
        let zero = _mm256_cmpeq_epi64(_mm256_andnot_si256(sign, v), _mm256_setzero_si256());
        if _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_or_si256(short, zero))) != 0b1111 {
            return self.add_sample_rare(c, second);
        }
        let significand =
            _mm256_or_si256(_mm256_and_si256(v, _mm256_set1_epi64x(0x000F_FFFF_FFFF_FFFF)), _mm256_set1_epi64x(0x0010_0000_0000_0000));
        let lo = _mm256_and_si256(short, _mm256_sllv_epi64(significand, shift));
        let hi = _mm256_or_si256(
            _mm256_srlv_epi64(significand, _mm256_sub_epi64(_mm256_set1_epi64x(64), shift)),
            _mm256_sllv_epi64(significand, _mm256_sub_epi64(shift, _mm256_set1_epi64x(64))),
        );
        let hi = _mm256_and_si256(short, hi);
        let sums = (self as *mut PixelSum).cast::<__m256i>();
        // SAFETY: `repr(C)`: `sum` and `sq` are the struct's first 64 bytes (the assertion below
        // the struct), each `i128` its low then its high half (little-endian).
        let (a, b) = unsafe { (_mm256_loadu_si256(sums), _mm256_loadu_si256(sums.add(1))) };
        // [lo r, lo b, lo g, lo y²] and the high halves.
        let (sum_lo, sum_hi) = (_mm256_unpacklo_epi64(a, b), _mm256_unpackhi_epi64(a, b));
        let new_lo = _mm256_add_epi64(sum_lo, lo);
        // The carry, −1 where the low half wrapped (`new_lo < lo` unsigned).
        let carry = _mm256_cmpgt_epi64(_mm256_xor_si256(lo, sign), _mm256_xor_si256(new_lo, sign));
        let new_hi = _mm256_sub_epi64(_mm256_add_epi64(sum_hi, hi), carry);
        // A non-negative value overflows a sum only from non-negative to negative.
        if _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_andnot_si256(sum_hi, new_hi))) != 0 {
            return self.add_sample_rare(c, second);
        }
        // SAFETY: as the loads.
        unsafe {
            _mm256_storeu_si256(sums, _mm256_unpacklo_epi64(new_lo, new_hi));
            _mm256_storeu_si256(sums.add(1), _mm256_unpackhi_epi64(new_lo, new_hi));
        }
        self.n += 1;
        self.add_second(y, second);
    }

    /// Adds `c` to the sums and its squared luminance to `sq`; returns the luminance.
    #[inline(always)]
    fn add_luminance(&mut self, c: Color) -> f64 {
        for (s, v) in self.sum.iter_mut().zip(c.to_array()) {
            *s = add_saturating(*s, fixed_color(v));
        }
        let y = luminance(c);
        self.sq = add_saturating(self.sq, fixed_color(y * y));
        self.n += 1;
        y
    }

    /// A pixel whose value `c` was computed whole (adaptive anti-aliasing): one unit of weight.
    pub fn whole(c: Color) -> Self {
        let mut p = PixelSum::default();
        p.add(c);
        p.samples = 1;
        p
    }

    /// The mean radiance (black when no ray counted).
    #[inline]
    pub fn mean(&self) -> Color {
        if self.n == 0 {
            return Color::ZERO;
        }
        // `/ COLOR_SCALE` is exactly `* 2⁻⁶⁴` (a power of two), and `/ 1` changes no bit: one
        // sample per pixel needs no division.
        let c = Color::new(float(self.sum[0]), float(self.sum[1]), float(self.sum[2])) * COLOR_UNIT;
        if self.n == 1 { c } else { c / f64::from(self.n) }
    }

    /// The mean luminance (0 when no ray counted).
    pub fn mean_luminance(&self) -> f64 {
        luminance(self.mean())
    }

    /// The estimated standard error of the mean luminance, `√(s² / n)` with `s²` the unbiased
    /// sample variance of the rays' luminance (they are treated as independent: stratification
    /// makes the true error smaller, never larger). `None` below two rays; +∞ when the squares
    /// saturated.
    pub fn std_error(&self) -> Option<f64> {
        if self.n < 2 {
            return None;
        }
        if self.sq == i128::MAX {
            return Some(f64::INFINITY);
        }
        let n = f64::from(self.n);
        let sum = (float(self.sum[0]) * LUMINANCE.x + float(self.sum[1]) * LUMINANCE.y + float(self.sum[2]) * LUMINANCE.z) * COLOR_UNIT;
        let sq = float(self.sq) * COLOR_UNIT;
        let variance = ((sq - sum * sum / n) / (n - 1.0)).max(0.0);
        Some((variance / n).sqrt())
    }

    /// The variance of the mean luminance estimated from two halves of the samples (for a
    /// stratified set, the black and white squares of a checkerboard over the pixel's strata;
    /// for Sobol points, the first and the second half of the samples, each a (0, 2)-net: either
    /// way each half is stratified about as the whole is), `(A − B)² · n_A · n_B / n²` for half
    /// means `A` and `B` of `n_A` and `n_B` rays (`(A − B)² / 4` for equal halves): unlike
    /// [`PixelSum::std_error`], it sees what stratification gains, but from one pixel it has a
    /// single degree of freedom; averaged over many pixels it estimates an image's error. `None`
    /// unless both halves have rays.
    pub fn half_variance(&self) -> Option<f64> {
        let n_even = self.n - self.n_odd;
        if self.n_odd == 0 || n_even == 0 {
            return None;
        }
        let sum = (float(self.sum[0]) * LUMINANCE.x + float(self.sum[1]) * LUMINANCE.y + float(self.sum[2]) * LUMINANCE.z) * COLOR_UNIT;
        let odd = float(self.odd) * COLOR_UNIT;
        let d = (sum - odd) / f64::from(n_even) - odd / f64::from(self.n_odd);
        let n = f64::from(self.n);
        Some(d * d * (f64::from(n_even) / n) * (f64::from(self.n_odd) / n))
    }

    /// Empties the second half: the samples so far become the first half of the estimate in
    /// [`PixelSum::half_variance`] (for Sobol points, at each power of two of samples).
    #[inline]
    pub fn restart_second_half(&mut self) {
        self.odd = 0;
        self.n_odd = 0;
    }

    /// How many of `count` samples carry the pixel's light, were it brought by a few bright
    /// samples among dark ones: `count · Ȳ² / mean(Y²)` over its rays' luminances `Y` (Kish's
    /// effective sample size `(ΣY)² / ΣY²` as a share of the rays, times `count`). Light spread
    /// evenly over the rays gives `count`; one bright ray among `n` (and dark others) gives
    /// `count / n`. Below 1, a pixel like this one that took only `count` samples more likely
    /// than not saw none of its bright ones. `None` below two rays, or when the squares are zero
    /// or saturated.
    pub fn light_carriers(&self, count: u32) -> Option<f64> {
        if self.n < 2 || self.sq <= 0 || self.sq == i128::MAX {
            return None;
        }
        let mean = self.mean_luminance();
        let mean_sq = float(self.sq) * COLOR_UNIT / f64::from(self.n);
        Some(f64::from(count) * mean * mean / mean_sq)
    }

    /// [`PixelSum::std_error`] relative to the mean luminance, or to `floor` where the pixel is
    /// darker than that (dark pixels would otherwise never converge).
    pub fn relative_error(&self, floor: f64) -> Option<f64> {
        self.std_error().map(|e| e / self.mean_luminance().max(floor))
    }

    /// [`PixelSum::std_error`] over the square root of the mean luminance, or of `floor` where
    /// the pixel is darker than that: the error an error target ([`crate::render::job::ErrorTarget`])
    /// tests, as Cycles' adaptive sampling does (`|I − A| / √I`). For a pixel of luminance 1 it is
    /// the relative error; below, the relative error times `√mean`, about the error of the value
    /// once encoded for display (sRGB's slope goes as `mean^(−0.58)`).
    pub fn sqrt_relative_error(&self, floor: f64) -> Option<f64> {
        self.std_error().map(|e| e / self.mean_luminance().max(floor).sqrt())
    }

    /// `o`'s rays and samples added to these.
    pub fn merge(&mut self, o: &PixelSum) {
        for (s, v) in self.sum.iter_mut().zip(o.sum) {
            *s = s.saturating_add(v);
        }
        self.sq = self.sq.saturating_add(o.sq);
        self.odd = self.odd.saturating_add(o.odd);
        self.n_odd = self.n_odd.saturating_add(o.n_odd);
        self.n = self.n.saturating_add(o.n);
        self.samples = self.samples.saturating_add(o.samples);
    }
}

/// The depth, normal and albedo of what camera rays saw first, summed exactly (see the module
/// docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AovSum {
    /// Σ depth over the rays that hit something, in units of 2⁻³² scene units.
    pub depth: i128,
    /// Rays that hit something.
    pub hits: u32,
    /// Rays.
    pub rays: u32,
    /// Σ shading normal, in units of 2⁻⁴⁰.
    pub normal: [i64; 3],
    /// Σ albedo, in units of 2⁻⁴⁰.
    pub albedo: [i64; 3],
    /// Σ radiance met emitted ([`AovSample::emitted`]), in units of 2⁻³² (saturating).
    pub emitted: [i64; 3],
}

impl AovSum {
    /// Adds one ray's layers.
    #[inline]
    pub fn add(&mut self, l: &AovSample) {
        if l.depth.is_finite() {
            self.depth = self.depth.saturating_add(fixed(l.depth, DEPTH_SCALE));
            self.hits += 1;
        }
        self.rays += 1;
        for k in 0..3 {
            self.normal[k] = self.normal[k].saturating_add(fixed(l.normal[k], UNIT_SCALE) as i64);
            self.albedo[k] = self.albedo[k].saturating_add(fixed(l.albedo[k], UNIT_SCALE) as i64);
            let e = fixed(l.emitted[k], EMITTED_SCALE).clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64;
            self.emitted[k] = self.emitted[k].saturating_add(e);
        }
    }

    /// A pixel whose layers were computed whole (adaptive anti-aliasing).
    pub fn whole(depth: f32, normal: Vec3, albedo: Vec3, emitted: Vec3) -> Self {
        let mut s = AovSum::default();
        s.add(&AovSample {
            depth: f64::from(depth),
            normal: normal.as_dvec3(),
            albedo: albedo.as_dvec3(),
            signature: 0,
            emitted: emitted.as_dvec3(),
            guides: false,
        });
        s
    }

    /// `o`'s rays added to these.
    pub fn merge(&mut self, o: &AovSum) {
        self.depth = self.depth.saturating_add(o.depth);
        self.hits = self.hits.saturating_add(o.hits);
        self.rays = self.rays.saturating_add(o.rays);
        for k in 0..3 {
            self.normal[k] = self.normal[k].saturating_add(o.normal[k]);
            self.albedo[k] = self.albedo[k].saturating_add(o.albedo[k]);
            self.emitted[k] = self.emitted[k].saturating_add(o.emitted[k]);
        }
    }

    /// The mean radiance met directly, over all rays (zero without rays).
    pub fn emitted_mean(&self) -> Vec3 {
        if self.rays == 0 {
            return Vec3::ZERO;
        }
        let n = f64::from(self.rays);
        let v = |k: usize| (self.emitted[k] as f64 / EMITTED_SCALE / n) as f32;
        Vec3::new(v(0), v(1), v(2))
    }

    /// The mean layers: depth over the rays that hit (+∞ when none did), normal and albedo over
    /// all rays.
    pub fn mean(&self) -> (f32, Vec3, Vec3) {
        let depth = if self.hits > 0 { (float(self.depth) / DEPTH_SCALE / f64::from(self.hits)) as f32 } else { f32::INFINITY };
        if self.rays == 0 {
            return (depth, Vec3::ZERO, Vec3::ZERO);
        }
        let n = f64::from(self.rays) * UNIT_SCALE;
        let v = |a: [i64; 3]| Vec3::new((a[0] as f64 / n) as f32, (a[1] as f64 / n) as f32, (a[2] as f64 / n) as f32);
        (depth, v(self.normal), v(self.albedo))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rounding through the integer part is `f64::round`, including halves, the largest
    /// values of the fast path and its edges.
    #[test]
    fn fixed_rounds_as_round_does() {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -2.5,
            0.49999999999999994,
            -0.49999999999999994,
            4503599627370495.5,
            9.19e18,
            -9.19e18,
            9.21e18,
            -9.3e18,
            3.89e28,
            -3.89e28,
            3.91e28,
            1e30,
            4503599627370496.0,
            -4503599627370497.0,
            4503599627370495.5,
            8.49e37,
            -8.49e37,
            8.51e37,
            1.7e38,
        ];
        values.extend((0..20_000).map(|i| {
            let x = f64::from(i) * 0.7548776662466927;
            (x.sin() * 10f64.powi(i % 40 - 20)).copysign(if i % 3 == 0 { -1.0 } else { 1.0 })
        }));
        for v in values {
            for scale in [1.0, COLOR_SCALE, DEPTH_SCALE, UNIT_SCALE] {
                let y = v * scale;
                assert_eq!(fixed(v, scale), y.round() as i128, "{v} × {scale}");
            }
        }
        assert_eq!(fixed(f64::NAN, 1.0), 0);
    }

    /// The colour path is [`fixed`] at the colour scale, for every exponent, both signs, zeros,
    /// infinities and NaN.
    #[test]
    fn fixed_color_is_fixed_at_the_color_scale() {
        let mut values = vec![0.0, -0.0, f64::INFINITY, f64::NEG_INFINITY, f64::NAN, f64::MIN_POSITIVE, 5e-324, f64::MAX];
        for e in -1080..1030 {
            for m in [1.0, 1.0 + f64::EPSILON, 1.5, 1.9999999999999998, 1.2345678901234567] {
                let v = m * 2f64.powi(e);
                values.extend([v, -v]);
            }
        }
        for v in values {
            assert_eq!(fixed_color(v), fixed(v, COLOR_SCALE), "{v:e}");
        }
    }

    #[test]
    fn light_carriers_count_the_bright_samples() {
        let grey = |v: f64| Color::new(v, v, v);
        // Light spread evenly: every one of `count` samples carries it.
        let mut even = PixelSum::default();
        for _ in 0..64 {
            even.add(grey(0.7));
        }
        assert!((even.light_carriers(16).unwrap() - 16.0).abs() < 1e-9);
        // One bright ray among 64 dark ones (black): 16 samples hold a quarter of one.
        let mut rare = PixelSum::default();
        rare.add(grey(100.0));
        for _ in 0..63 {
            rare.add(Color::ZERO);
        }
        assert!((rare.light_carriers(16).unwrap() - 0.25).abs() < 1e-9);
        assert!((rare.light_carriers(128).unwrap() - 2.0).abs() < 1e-9);
        assert_eq!(PixelSum::default().light_carriers(16), None);
        assert_eq!(PixelSum::whole(grey(1.0)).light_carriers(16), None);
    }

    #[test]
    fn sums_saturate_both_ways() {
        assert_eq!(add_saturating(i128::MAX - 1, 5), i128::MAX);
        assert_eq!(add_saturating(i128::MIN + 1, -5), i128::MIN);
        assert_eq!(add_saturating(-3, 5), 2);
    }

    #[test]
    fn sums_do_not_depend_on_order_or_split() {
        let values: Vec<Color> = (0..1000)
            .map(|i| {
                let x = f64::from(i);
                Color::new((x * 0.37).sin().abs() * 1e3, 1.0 / (x + 1.0), (x * 1e-3).exp() - 1.0 + 1e-12)
            })
            .collect();
        let mut forward = PixelSum::default();
        values.iter().for_each(|c| forward.add(*c));
        let mut backward = PixelSum::default();
        values.iter().rev().for_each(|c| backward.add(*c));
        assert_eq!(forward, backward);
        // Three passes of interleaved samples, merged.
        let mut merged = PixelSum::default();
        for k in 0..3 {
            let mut part = PixelSum::default();
            values.iter().skip(k).step_by(3).for_each(|c| part.add(*c));
            merged.merge(&part);
        }
        assert_eq!((merged.sum, merged.n), (forward.sum, forward.n));
        let plain: Color = values.iter().sum::<Color>() / 1000.0;
        assert!((forward.mean() - plain).abs().max_element() < 1e-12 * plain.max_element());
    }

    /// The AVX2 copy of `add_sample` leaves every sum as the scalar one does, to the bit: values on
    /// and off the short path (zeros of both signs, negatives, tiny, huge, every exponent), sums
    /// whose low halves carry, and sums at the edge of saturation both ways.
    #[test]
    fn avx2_sums_match_the_scalar_sums() {
        #[cfg(target_arch = "x86_64")]
        {
            if !std::arch::is_x86_feature_detected!("avx2") {
                return;
            }
            let mut values =
                vec![0.0, -0.0, 1.0, 0.5, 2f64.powi(-12), 2f64.powi(-13), 2f64.powi(62), 2f64.powi(61) * 1.5, 1e-300, 5e-324, -1.0, 1e30];
            for e in -20..70 {
                for m in [1.0, 1.0 + f64::EPSILON, 1.5, 1.9999999999999998, 1.2345678901234567] {
                    values.push(m * 2f64.powi(e));
                }
            }
            let mut starts = vec![PixelSum::default()];
            for (lo, hi) in
                [(u64::MAX, 0i64), (u64::MAX - 5, i64::MAX), (0, i64::MAX), (u64::MAX, -1), (3, i64::MIN), (u64::MAX, i64::MAX - 1)]
            {
                let s = (i128::from(hi) << 64) | i128::from(lo);
                starts.push(PixelSum { sum: [s, s.wrapping_add(7), -s], sq: s, odd: s, n: 3, n_odd: 1, samples: 3 });
            }
            let mut checked = 0;
            for start in &starts {
                for (i, &a) in values.iter().enumerate() {
                    let b = values[(i * 7 + 3) % values.len()];
                    let c = values[(i * 13 + 5) % values.len()];
                    for color in [Color::new(a, b, c), Color::new(c, a, b), Color::splat(a)] {
                        for second in [false, true] {
                            let (mut scalar, mut wide) = (*start, *start);
                            scalar.add_sample_scalar(color, second);
                            // SAFETY: AVX2 was detected above.
                            unsafe { wide.add_sample_avx2(color, second) };
                            assert_eq!(wide, scalar, "{color} added to {start:?}");
                            checked += 1;
                        }
                    }
                }
            }
            assert!(checked > 10_000);
        }
    }

    #[test]
    fn huge_radiance_saturates_and_tiny_rounds_to_zero() {
        let mut p = PixelSum::default();
        p.add(Color::splat(1e30));
        p.add(Color::splat(1e30));
        assert!(p.mean().x > 1e18 && p.mean().is_finite());
        let mut q = PixelSum::default();
        q.add(Color::splat(1e-30));
        assert_eq!(q.mean(), Color::ZERO);
    }
}
