//! Floating-point robustness, in one place: rounding-error bounds, ulp steps, robust ray
//! origins, and every tolerance the renderer uses.
//!
//! raylab computes geometry in `f64`. Rather than one magic epsilon, each shape returns the hit
//! point together with a conservative bound on its rounding error (pbrt-v4, §6.8). A secondary
//! ray starts from that point pushed just outside its error box along the normal
//! ([`offset_ray_origin`]), so it cannot re-hit the surface it leaves, whatever the scene's scale.

use glam::DVec3;

/// Bound on the relative rounding error of one correctly rounded `f64` operation (½ ulp of 1).
pub const MACHINE_EPSILON: f64 = f64::EPSILON * 0.5;

/// γ(n) = nε / (1 − nε): bound on the relative error accumulated by `n` successive
/// floating-point operations (Higham, *Accuracy and Stability of Numerical Algorithms*, §3.1).
#[inline]
pub const fn gamma(n: u32) -> f64 {
    let ne = n as f64 * MACHINE_EPSILON;
    ne / (1.0 - ne)
}

/// Fraction of a light's distance that shadow rays stop short of it, so a light placed on a
/// surface is not shadowed by that surface. Relative, hence independent of the scene's scale.
pub const SHADOW_EPSILON: f64 = 1e-9;

/// Relative size below which a cross product or determinant counts as zero, so the shape or
/// matrix it comes from is refused as degenerate: `|a × b| ≤ DEGENERACY_TOLERANCE · |a|·|b|`
/// (about 2⁻⁴⁰, far above rounding and far below any shape a scene means to draw).
pub const DEGENERACY_TOLERANCE: f64 = 1e-12;

/// Sine of the smallest angle a camera's `up` may make with its view direction; nearer to
/// parallel, "up" no longer defines a roll and the camera is refused.
pub const PARALLEL_TOLERANCE: f64 = 1e-6;

/// Relative tolerance used by tests and validators when checking that a point lies on a surface:
/// `|f(p)| ≤ SURFACE_TOLERANCE · scale`, where `scale` is the magnitude of the coordinates.
pub const SURFACE_TOLERANCE: f64 = 1e-9;

/// Tolerance of tests and validators on unit vectors: a normal `n` passes when `|‖n‖ − 1|` and its
/// distance from the exact unit normal (≈ the angle between them, radians) are at most this.
pub const NORMAL_TOLERANCE: f64 = 1e-9;

/// Distance (scene units) within which a ray origin counts as lying on a surface: the rounding
/// error of a point computed on a surface defined around `reference` (its centre, base or a
/// vertex), `γ(5) · (‖origin‖∞ + ‖reference‖∞)`. A shape does not report a hit at `t ≈ 0` closer
/// than this to the origin (a ray starting on the surface does not hit it again), as the plane's
/// numerator test does.
#[inline]
pub fn on_surface_slack(origin: DVec3, reference: DVec3) -> f64 {
    gamma(5) * (max_abs(origin) + max_abs(reference))
}

/// Componentwise absolute value bound helper: `gamma(n) * |v|`.
#[inline]
pub fn error_bound(n: u32, v: DVec3) -> DVec3 {
    gamma(n) * v.abs()
}

/// Moves `p` (with absolute error bound `err` per axis) off its surface along the unit normal `n`,
/// onto the side that direction `w` leaves towards, and rounds the result away from `p`, so that a
/// ray from the returned origin along `w` cannot intersect the surface it starts on.
///
/// This is pbrt-v4's `OffsetRayOrigin`: the offset is the projection of the error box onto the
/// normal, so it scales with the magnitude of the coordinates and needs no scene-specific epsilon.
// Always inlined: called out of line, its four vectors went through memory.
#[inline(always)]
pub fn offset_ray_origin(p: DVec3, err: DVec3, n: DVec3, w: DVec3) -> DVec3 {
    let d = n.abs().dot(err);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    DVec3::new(step_toward(po.x, offset.x), step_toward(po.y, offset.y), step_toward(po.z, offset.z))
}

/// `x.next_up()` where `toward > 0`, `x.next_down()` where `toward < 0`, else `x`: the same
/// values, computed on the bits with selects instead of branches on the (unpredictable) signs.
#[inline(always)]
fn step_toward(x: f64, toward: f64) -> f64 {
    /// The smallest positive subnormal's bits.
    const TINY: u64 = 1;
    const SIGN: u64 = 1 << 63;
    let (xb, tb) = (x.to_bits(), toward.to_bits());
    // Moving x's magnitude up (same sign as the step) adds one to its bits; down subtracts one.
    let same_sign = (xb ^ tb) & SIGN == 0;
    let stepped = if same_sign { xb.wrapping_add(1) } else { xb.wrapping_sub(1) };
    // ±0 steps to the smallest subnormal of the step's sign; NaN, and an infinity stepped
    // outward, stay.
    let stepped = if x == 0.0 { TINY | (tb & SIGN) } else { stepped };
    let moves = toward.abs() > 0.0; // not for ±0 or NaN
    let stays = !moves || x.is_nan() || (x.is_infinite() && same_sign);
    if stays { x } else { f64::from_bits(stepped) }
}

/// Quadratic `a t² + b t + c = 0` solved without cancellation; roots in ascending order.
/// Returns `None` when the discriminant is negative or the equation is degenerate.
#[inline]
pub fn solve_quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        let t = -c / b;
        return Some((t, t));
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let root = disc.sqrt();
    let q = if b < 0.0 { -0.5 * (b - root) } else { -0.5 * (b + root) };
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

/// `a·b − c·d` to about 1.5 ulp (Kahan's algorithm with fused multiply-adds), where the plain
/// expression can lose every digit to cancellation.
#[inline]
pub fn difference_of_products(a: f64, b: f64, c: f64, d: f64) -> f64 {
    let cd = c * d;
    let err = (-c).mul_add(d, cd);
    a.mul_add(b, -cd) + err
}

/// `u × v` with each component from [`difference_of_products`]: accurate even when `u` and `v`
/// are nearly parallel.
#[inline]
pub fn cross_accurate(u: DVec3, v: DVec3) -> DVec3 {
    DVec3::new(
        difference_of_products(u.y, v.z, u.z, v.y),
        difference_of_products(u.z, v.x, u.x, v.z),
        difference_of_products(u.x, v.y, u.y, v.x),
    )
}

/// The (unnormalised) normal `(p1 − p0) × (p2 − p0)` of a triangle, computed from the two edges at
/// the vertex opposite its longest edge (the largest angle) with [`cross_accurate`], so that a
/// sliver's normal is as accurate as a well-shaped triangle's. Also returns the product of those
/// two edges' lengths: `|n| / product` is the sine of the largest angle.
#[inline]
pub fn triangle_normal(p: [DVec3; 3]) -> (DVec3, f64) {
    let len2 = |i: usize| (p[(i + 2) % 3] - p[(i + 1) % 3]).length_squared();
    let k = if len2(0) >= len2(1) && len2(0) >= len2(2) {
        0
    } else if len2(1) >= len2(2) {
        1
    } else {
        2
    };
    let (u, v) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
    (cross_accurate(u, v), u.length() * v.length())
}

/// Largest absolute coordinate of `v`, used as the "scale" of a position.
#[inline]
pub fn max_abs(v: DVec3) -> f64 {
    v.abs().max_element()
}

/// True when every component is finite.
#[inline]
pub fn is_finite3(v: DVec3) -> bool {
    v.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The branch-free step equals `next_up` / `next_down` on special values and random bits.
    #[test]
    fn step_toward_matches_next_up_and_down() {
        let specials = [
            0.0,
            -0.0,
            f64::from_bits(1),
            -f64::from_bits(1),
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            1.0,
            -1.0,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            3.5e-300,
            -7.25e200,
        ];
        let mut z = 0x1234_5678_9abc_def0u64;
        let mut xs = specials.to_vec();
        for _ in 0..20000 {
            z = z.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            xs.push(f64::from_bits(z));
        }
        for &x in &xs {
            for t in [1.0, -1.0, 0.0, -0.0, 1e-300, -1e-300, f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
                let expect = if t > 0.0 {
                    x.next_up()
                } else if t < 0.0 {
                    x.next_down()
                } else {
                    x
                };
                let got = step_toward(x, t);
                assert!(got.to_bits() == expect.to_bits() || (got.is_nan() && expect.is_nan()), "{x:e} toward {t}: {got:e} vs {expect:e}");
            }
        }
    }

    #[test]
    fn gamma_grows_with_operation_count() {
        assert!(gamma(1) > MACHINE_EPSILON * 0.99);
        assert!(gamma(5) > gamma(3));
        assert!(gamma(10) < 1e-14);
    }

    #[test]
    fn offset_moves_to_the_side_of_w_and_beyond_the_error_box() {
        let p = DVec3::new(1e5, -3.0, 7.5);
        let err = DVec3::splat(1e-9);
        let n = DVec3::Z;
        let above = offset_ray_origin(p, err, n, DVec3::new(0.3, 0.0, 1.0));
        let below = offset_ray_origin(p, err, n, DVec3::new(0.3, 0.0, -1.0));
        assert!(above.z > p.z + 1e-9 && below.z < p.z - 1e-9);
        assert_eq!(above.x, p.x);
    }

    #[test]
    fn a_slivers_normal_is_accurate() {
        // 1e-9 wide and 7e5 long: the plain cross product at p0 is off by ~1e-7 rad.
        let p =
            [DVec3::new(-52681.62727651227, 3e5, -3e5), DVec3::new(147318.37179216516, 7e5, 2e5), DVec3::new(147318.37272348773, 7e5, 2e5)];
        let (n, _) = triangle_normal(p);
        let exact = DVec3::new(0.0, 5e5, -4e5).normalize(); // ∝ (2e5, 4e5, 5e5) × (1, 0, 0): p1 − p0 and p2 − p1
        assert!((n.normalize() - exact).length() < 1e-15, "{n}");
        let plain = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        assert!((plain - exact).length() > 1e-9, "the plain product is not the accurate one: {plain}");
        assert_eq!(difference_of_products(1e8 + 1.0, 1e8 - 1.0, 1e8, 1e8), -1.0);
    }

    #[test]
    fn quadratic_roots_are_ordered_and_accurate() {
        // (t - 1e-8)(t - 1e8) = t² - (1e8 + 1e-8) t + 1
        let (t0, t1) = solve_quadratic(1.0, -(1e8 + 1e-8), 1.0).unwrap();
        assert!((t0 - 1e-8).abs() < 1e-20 && (t1 - 1e8).abs() < 1e-6);
        assert!(solve_quadratic(1.0, 0.0, 1.0).is_none());
        assert!(solve_quadratic(0.0, 0.0, 1.0).is_none());
    }
}
