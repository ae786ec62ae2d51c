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

/// The one root in `[a, b]` of a polynomial monotone there, with `f(a)` and `f(b)` of opposite
/// signs (neither zero).
fn polish<const N: usize>(c: &Poly<N>, mut a: f64, mut b: f64, fa: f64) -> f64 {
    let rising = fa < 0.0;
    let mut x = 0.5 * (a + b);
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
        if mid <= a || mid >= b {
            break; // the bracket is two adjacent floats
        }
        let newton = x - f / df;
        let next = if newton > a && newton < b { newton } else { mid };
        if next == x {
            break; // Newton has converged to a fixed point
        }
        x = next;
    }
    x
}

/// Real roots in the open interval `(lo, hi)` of the quadratic `c`, ascending, into `out`;
/// returns how many. Sign changes only (a double root is not reported).
fn quadratic_roots(c: &Poly<3>, lo: f64, hi: f64, out: &mut [f64]) -> usize {
    critical_split(c, lo, hi, linear_root(&[c[1], 2.0 * c[2]], lo, hi).as_slice(), out)
}

/// The root of the linear `c` in `(lo, hi)`, if any.
fn linear_root(c: &Poly<2>, lo: f64, hi: f64) -> Option<f64> {
    if c[1] == 0.0 {
        return None;
    }
    let x = -c[0] / c[1];
    (x > lo && x < hi).then_some(x)
}

/// Roots of `c` in `(lo, hi)`, given the roots of its derivative there (ascending): one root per
/// monotone piece whose ends differ in sign.
fn critical_split<const N: usize>(c: &Poly<N>, lo: f64, hi: f64, critical: &[f64], out: &mut [f64]) -> usize {
    let mut n = 0;
    let mut a = lo;
    let mut fa = eval(c, a);
    let ends = critical.iter().copied().chain(std::iter::once(hi));
    for b in ends {
        let fb = eval(c, b);
        if fa == 0.0 && a > lo && n < out.len() && out[..n].last() != Some(&a) {
            out[n] = a;
            n += 1;
        }
        if fa != 0.0 && fb != 0.0 && (fa < 0.0) != (fb < 0.0) && n < out.len() {
            out[n] = polish(c, a, b, fa);
            n += 1;
        }
        a = b;
        fa = fb;
    }
    n
}

/// Real roots in the open interval `(lo, hi)` of the cubic `c`, ascending, into `out`.
pub fn cubic_roots(c: &Poly<4>, lo: f64, hi: f64, out: &mut [f64]) -> usize {
    let d = [c[1], 2.0 * c[2], 3.0 * c[3]];
    let mut crit = [0.0; 2];
    let k = quadratic_roots(&d, lo, hi, &mut crit);
    critical_split(c, lo, hi, &crit[..k], out)
}

/// Real roots in the open interval `(lo, hi)` of the quartic `c` (`c[4]` ≠ 0), ascending, into
/// `out` (at most 4); returns how many.
pub fn quartic_roots(c: &Poly<5>, lo: f64, hi: f64, out: &mut [f64; 4]) -> usize {
    let d = [c[1], 2.0 * c[2], 3.0 * c[3], 4.0 * c[4]];
    let mut crit = [0.0; 3];
    let k = cubic_roots(&d, lo, hi, &mut crit);
    critical_split(c, lo, hi, &crit[..k], out)
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
        let n = cubic_roots(&[8.0, -6.0, -3.0, 1.0], -5.0, 5.0, &mut out);
        assert_eq!(n, 3);
        for (got, want) in out.iter().zip([-2.0, 1.0, 4.0]) {
            assert!((got - want).abs() < 1e-14);
        }
    }
}
