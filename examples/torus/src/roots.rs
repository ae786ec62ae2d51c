//! Real roots of polynomials up to degree 4 in an interval, by root isolation: the roots of the
//! derivative split the interval into pieces on which the polynomial is monotone, and each piece
//! whose ends differ in sign holds exactly one root, found by Newton's method safeguarded by
//! bisection (C. Yuksel, "High-Performance Polynomial Root Finding for Graphics", HPG 2022).
//!
//! Unlike closed-form quartic formulas (Ferrari, Descartes), nothing here cancels catastrophically:
//! each root is polished against the polynomial itself, to full precision. A root of even
//! multiplicity (the polynomial touches zero without changing sign) is not reported, which for a
//! ray means a hit exactly tangent to the surface.

/// A polynomial `c[0] + c[1]·x + … + c[N−1]·x^(N−1)`.
pub type Poly<const N: usize> = [f64; N];

/// The polynomial at `x` (Horner).
#[inline]
pub fn eval<const N: usize>(c: &Poly<N>, x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * x + k)
}

/// The polynomial and its derivative at `x`.
#[inline]
fn eval_with_derivative<const N: usize>(c: &Poly<N>, x: f64) -> (f64, f64) {
    let mut f = 0.0;
    let mut df = 0.0;
    for &k in c.iter().rev() {
        df = df * x + f;
        f = f * x + k;
    }
    (f, df)
}

/// Most Newton/bisection steps per root; bisection alone needs at most ~2100 for the full `f64`
/// range and about 60 for any realistic interval, so this only guards against pathological input.
const MAX_STEPS: u32 = 200;

/// Relative precision (of the interval's length) to which critical points are located. They only
/// separate monotone pieces: an error matters only for two roots closer together than it (a ray
/// within ~1e-9 of tangent to the surface), which may then be missed.
const CRITICAL_TOLERANCE: f64 = 1e-9;

/// The one root in `[a, b]` of a polynomial monotone there, with `f(a)` and `f(b)` of opposite
/// signs (neither zero), to within `xtol` (0: to full precision). Newton's method from the chord's
/// zero, falling back to bisection whenever a step would leave the bracket or shrink it too
/// slowly (Numerical Recipes' `rtsafe`).
fn polish<const N: usize>(c: &Poly<N>, mut a: f64, mut b: f64, fa: f64, fb: f64, xtol: f64) -> f64 {
    let rising = fa < 0.0;
    let chord = a + (b - a) * (fa / (fa - fb));
    let mut x = if chord > a && chord < b { chord } else { 0.5 * (a + b) };
    let mut last_step = b - a;
    for _ in 0..MAX_STEPS {
        let (f, df) = eval_with_derivative(c, x);
        if f == 0.0 {
            return x;
        }
        if (f < 0.0) == rising {
            a = x;
        } else {
            b = x;
        }
        let mid = 0.5 * (a + b);
        if mid <= a || mid >= b || b - a <= xtol {
            break; // the bracket is two adjacent floats, or as narrow as asked
        }
        let newton = x - f / df;
        let next = if newton > a && newton < b && (2.0 * f).abs() <= (last_step * df).abs() { newton } else { mid };
        last_step = next - x;
        if next == x || last_step.abs() <= xtol {
            return next;
        }
        x = next;
    }
    x
}

/// Walks the monotone pieces of a polynomial in order: fed the end of each piece (a critical
/// point, or the interval's end), it finds the piece's root, if its ends differ in sign, and
/// offers it to `accept`.
struct Pieces<'a, const N: usize> {
    c: &'a Poly<N>,
    lo: f64,
    xtol: f64,
    a: f64,
    fa: f64,
}

impl<'a, const N: usize> Pieces<'a, N> {
    fn new(c: &'a Poly<N>, lo: f64, xtol: f64) -> Self {
        Pieces { c, lo, xtol, a: lo, fa: eval(c, lo) }
    }

    /// The piece from the previous end to `b`: its root, if `accept` takes it.
    fn next(&mut self, b: f64, accept: &mut impl FnMut(f64) -> bool) -> Option<f64> {
        let fb = eval(self.c, b);
        let (a, fa) = (self.a, self.fa);
        self.a = b;
        self.fa = fb;
        if fa == 0.0 && a > self.lo && accept(a) {
            return Some(a);
        }
        if fa != 0.0 && fb != 0.0 && (fa < 0.0) != (fb < 0.0) {
            let x = polish(self.c, a, b, fa, fb, self.xtol);
            if accept(x) {
                return Some(x);
            }
        }
        None
    }
}

/// Real roots in the open interval `(lo, hi)` of the quadratic `c`, ascending, into `out`, from
/// the cancellation-free closed form (a double root counts once).
pub fn quadratic_roots(c: &Poly<3>, lo: f64, hi: f64, out: &mut [f64; 2]) -> usize {
    let mut n = 0;
    if let Some((x0, x1)) = raylab::math::float::solve_quadratic(c[2], c[1], c[0]) {
        for x in [x0, x1] {
            if x > lo && x < hi && (n == 0 || out[n - 1] != x) {
                out[n] = x;
                n += 1;
            }
        }
    }
    n
}

/// Calls `accept` with each root of the cubic `c` in `(lo, hi)`, ascending, to within `xtol`,
/// until it returns true; returns that root.
fn each_cubic_root(c: &Poly<4>, lo: f64, hi: f64, xtol: f64, mut accept: impl FnMut(f64) -> bool) -> Option<f64> {
    let mut crit = [0.0; 2];
    let k = quadratic_roots(&[c[1], 2.0 * c[2], 3.0 * c[3]], lo, hi, &mut crit);
    let mut pieces = Pieces::new(c, lo, xtol);
    crit[..k].iter().chain(&[hi]).find_map(|&b| pieces.next(b, &mut accept))
}

/// Real roots in the open interval `(lo, hi)` of the cubic `c`, ascending, to within `xtol`,
/// into `out`; returns how many.
pub fn cubic_roots(c: &Poly<4>, lo: f64, hi: f64, xtol: f64, out: &mut [f64; 3]) -> usize {
    let mut n = 0;
    each_cubic_root(c, lo, hi, xtol, |x| {
        out[n] = x;
        n += 1;
        false
    });
    n
}

/// The smallest root of the quartic `c` in `(lo, hi)` that `accept` accepts, to full precision.
/// Critical points and roots beyond it are not computed.
pub fn first_quartic_root(c: &Poly<5>, lo: f64, hi: f64, mut accept: impl FnMut(f64) -> bool) -> Option<f64> {
    let derivative = [c[1], 2.0 * c[2], 3.0 * c[3], 4.0 * c[4]];
    let mut pieces = Pieces::new(c, lo, 0.0);
    let mut found = None;
    // Each critical point, as the cubic walk finds it, ends a piece of the quartic.
    each_cubic_root(&derivative, lo, hi, CRITICAL_TOLERANCE * (hi - lo), |b| {
        found = pieces.next(b, &mut accept);
        found.is_some()
    });
    found.or_else(|| pieces.next(hi, &mut accept))
}

/// Real roots in the open interval `(lo, hi)` of the quartic `c`, ascending, to full precision,
/// into `out`; returns how many.
pub fn quartic_roots(c: &Poly<5>, lo: f64, hi: f64, out: &mut [f64; 4]) -> usize {
    let mut n = 0;
    first_quartic_root(c, lo, hi, |x| {
        out[n] = x;
        n += 1;
        false
    });
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The monic quartic with roots `r`.
    fn from_roots(r: [f64; 4]) -> Poly<5> {
        let mut c = [1.0, 0.0, 0.0, 0.0, 0.0];
        for (i, &x) in r.iter().enumerate() {
            // Multiply by (t − x).
            for j in (0..=i + 1).rev() {
                let lower = if j > 0 { c[j - 1] } else { 0.0 };
                c[j] = lower - x * if j <= i { c[j] } else { 0.0 };
            }
        }
        c
    }

    fn roots(c: &Poly<5>, lo: f64, hi: f64) -> Vec<f64> {
        let mut out = [0.0; 4];
        let n = quartic_roots(c, lo, hi, &mut out);
        out[..n].to_vec()
    }

    #[test]
    fn four_distinct_roots_are_found_in_order() {
        let r = roots(&from_roots([-3.0, -0.5, 0.25, 7.0]), -10.0, 10.0);
        assert_eq!(r.len(), 4, "{r:?}");
        for (got, want) in r.iter().zip([-3.0, -0.5, 0.25, 7.0]) {
            assert!((got - want).abs() < 1e-14, "{got} vs {want}");
        }
        assert_eq!(roots(&from_roots([-3.0, -0.5, 0.25, 7.0]), 0.0, 5.0), vec![0.25]);
    }

    #[test]
    fn close_and_widely_scaled_roots_are_separated() {
        let want = [1.0, 1.0 + 1e-4, 1e3, 1e3 + 1e-1];
        let r = roots(&from_roots(want), 0.0, 2e3);
        assert_eq!(r.len(), 4, "{r:?}");
        for (got, w) in r.iter().zip(want) {
            assert!((got - w).abs() <= 1e-10 * w, "{got} vs {w}");
        }
    }

    #[test]
    fn no_real_roots_give_none_and_double_roots_stay_put() {
        assert!(roots(&[1.0, 0.0, 1.0, 0.0, 1.0], -100.0, 100.0).is_empty(), "x⁴ + x² + 1 > 0");
        // (x − 1)² (x² + 1) touches zero at 1: rounding may show it as no root or two very close
        // ones, never anything elsewhere.
        let c = [1.0, -2.0, 2.0, -2.0, 1.0];
        assert!(roots(&c, -10.0, 10.0).iter().all(|r| (r - 1.0).abs() < 1e-7));
    }

    #[test]
    fn cubic_roots_match() {
        // (x + 2)(x − 1)(x − 4) = x³ − 3x² − 6x + 8
        let mut out = [0.0; 3];
        let n = cubic_roots(&[8.0, -6.0, -3.0, 1.0], -5.0, 5.0, 0.0, &mut out);
        assert_eq!(n, 3);
        for (got, want) in out.iter().zip([-2.0, 1.0, 4.0]) {
            assert!((got - want).abs() < 1e-14);
        }
    }
}
