//! A list's object boxes tested together: [`BoxLanes`] holds them in packs of [`LANES`] (structure
//! of arrays, `f64`), and one pass of lane-wise operations answers [`Aabb::hit`] for a whole pack
//! (one 256-bit register per quantity where the CPU has AVX, two SSE2 halves otherwise, scalar
//! code elsewhere).
//!
//! **The same answers as [`Aabb::hit`], bit for bit.** Each lane does `Aabb::hit`'s operations on
//! the same `f64` values in the same order: subtract, multiply, glam's `min`/`max` (`a < b ? a :
//! b`, which is what `minpd`/`maxpd` compute, NaN included), the far side's widening, then
//! `f64::max(t_min)` and `f64::min(t_max)` (a NaN operand yields the other one, as `maxpd`/`minpd`
//! do with the NaN first), and `!(t_near > t_far)`. A pack is tested against the query's limit
//! `t_max` once; a lane's entry distance `t_near` is kept, so a caller whose limit has since
//! shrunk to `t` (a closer hit found) decides `Aabb::hit(…, t)` exactly as `!(t_near > t)` on top
//! of the mask (`min` with a smaller limit only moves the far end down to it).

use crate::math::bounds::Aabb;
use crate::math::float::gamma;
use glam::DVec3;
use std::sync::OnceLock;

/// Boxes per pack: one 256-bit register of `f64`.
pub const LANES: usize = 4;

/// The far side's widening in [`Aabb::hit`] (`1 + 2γ(3)`).
const FAR_WIDENING: f64 = 1.0 + 2.0 * gamma(3);

/// [`LANES`] boxes, lane = box. Lanes past the list's end hold empty boxes and are masked off.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct BoxPack {
    /// `lo[axis][lane]`: the boxes' minima on `axis`.
    lo: [[f64; LANES]; 3],
    /// `hi[axis][lane]`: their maxima.
    hi: [[f64; LANES]; 3],
    /// The mask of the lanes that hold a box of the list (the others are masked off).
    valid: u32,
}

/// What a pack's slab test gives: the mask of the lanes whose box the ray meets within
/// `(t_min, t_max)`, and each lane's entry distance `max(near, t_min)` (`Aabb::hit`'s `t_near`).
pub type PackHits = (u32, [f64; LANES]);

/// A list's boxes in packs of [`LANES`], in slot order, tested with the copy of the slab test
/// this process runs ([`avx_available`]).
#[derive(Clone, Debug, Default)]
pub struct BoxLanes {
    packs: Vec<BoxPack>,
    avx: bool,
}

/// Whether the lists' slab tests run in AVX registers: the CPU has AVX and the environment
/// variable `RAYLAB_SIMD` is not `baseline` (which also picks the hierarchies' baseline copy).
/// Decided once per process; every copy gives the same answers.
pub fn avx_available() -> bool {
    static AVX: OnceLock<bool> = OnceLock::new();
    *AVX.get_or_init(|| {
        if std::env::var_os("RAYLAB_SIMD").is_some_and(|v| v == "baseline") {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        return std::arch::is_x86_feature_detected!("avx");
        #[cfg(not(target_arch = "x86_64"))]
        false
    })
}

impl BoxLanes {
    /// The boxes, in slot order.
    pub fn new(boxes: impl ExactSizeIterator<Item = Aabb>) -> BoxLanes {
        let len = boxes.len();
        let empty = BoxPack { lo: [[f64::INFINITY; LANES]; 3], hi: [[f64::NEG_INFINITY; LANES]; 3], valid: 0 };
        let mut packs = vec![empty; len.div_ceil(LANES)];
        for (slot, b) in boxes.enumerate() {
            let p = &mut packs[slot / LANES];
            p.valid |= 1 << (slot % LANES);
            for axis in 0..3 {
                p.lo[axis][slot % LANES] = b.min[axis];
                p.hi[axis][slot % LANES] = b.max[axis];
            }
        }
        BoxLanes { packs, avx: avx_available() }
    }

    /// Calls `visit(slot, t_near)` for every box the ray from `origin` with reciprocal direction
    /// `inv` meets within `(t_min, t_max)` by [`Aabb::hit`], in slot order, and for slot `always`
    /// (if any) at its place whatever its box, but never for slot `never`; stops when `visit`
    /// returns true, and says whether it did. `visit` itself tests a box against a limit lowered
    /// since (`!(t_near > t)`). The boxes of [`CHUNK`] slots are tested at once, before any is
    /// visited.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn visit(
        &self,
        origin: DVec3,
        inv: DVec3,
        t_min: f64,
        t_max: f64,
        always: usize,
        never: usize,
        mut visit: impl FnMut(usize, f64) -> bool,
    ) -> bool {
        let mut near = [0.0; CHUNK];
        let mut first = 0;
        for packs in self.packs.chunks(CHUNK / LANES) {
            let mut mask = self.chunk_hits(packs, origin, inv, t_min, t_max, &mut near);
            if always.wrapping_sub(first) < CHUNK {
                mask |= 1 << (always - first);
            }
            if never.wrapping_sub(first) < CHUNK {
                mask &= !(1 << (never - first));
            }
            while mask != 0 {
                let slot = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if visit(first + slot, near[slot]) {
                    return true;
                }
            }
            first += CHUNK;
        }
        false
    }

    /// The slab tests of up to [`CHUNK`] boxes (`packs`): the mask of those met (lanes past the
    /// list's end left out), their entry distances written to `near`, lane `LANES·p + l` for lane
    /// `l` of pack `p`. Out of line, in either copy: the caller's loop keeps no vector set-up
    /// across the objects' tests.
    #[inline(always)]
    fn chunk_hits(&self, packs: &[BoxPack], origin: DVec3, inv: DVec3, t_min: f64, t_max: f64, near: &mut [f64; CHUNK]) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where `avx_available` found AVX on this CPU.
            return unsafe { chunk_hits_avx(packs, origin, inv, t_min, t_max, near) };
        }
        chunk_hits_baseline(packs, origin, inv, t_min, t_max, near)
    }
}

/// [`BoxLanes::chunk_hits`] in the baseline build: SSE2 halves on x86-64, lane by lane elsewhere.
#[inline(never)]
fn chunk_hits_baseline(packs: &[BoxPack], origin: DVec3, inv: DVec3, t_min: f64, t_max: f64, near: &mut [f64; CHUNK]) -> u32 {
    let mut mask = 0;
    for (p, pack) in packs.iter().enumerate().take(CHUNK / LANES) {
        #[cfg(target_arch = "x86_64")]
        let (m, n) = pack.hits_sse2(origin, inv, t_min, t_max);
        #[cfg(not(target_arch = "x86_64"))]
        let (m, n) = pack.hits_scalar(origin, inv, t_min, t_max);
        mask |= (m & pack.valid) << (p * LANES);
        near[p * LANES..(p + 1) * LANES].copy_from_slice(&n);
    }
    mask
}

/// Boxes tested in one call of the slab test ([`BoxLanes::visit`]): two packs.
pub const CHUNK: usize = 2 * LANES;

/// [`BoxLanes::chunk_hits`] compiled for AVX: a leaf function, its broadcasts made once for the
/// chunk's packs.
///
/// # Safety
/// The CPU has AVX.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
#[target_feature(enable = "avx")]
unsafe fn chunk_hits_avx(packs: &[BoxPack], origin: DVec3, inv: DVec3, t_min: f64, t_max: f64, near: &mut [f64; CHUNK]) -> u32 {
    let mut mask = 0;
    for (p, pack) in packs.iter().enumerate().take(CHUNK / LANES) {
        // SAFETY: the caller guarantees AVX.
        let (m, n) = unsafe { pack.hits_avx(origin, inv, t_min, t_max) };
        mask |= (m & pack.valid) << (p * LANES);
        near[p * LANES..(p + 1) * LANES].copy_from_slice(&n);
    }
    mask
}

impl BoxPack {
    /// The slab test of every lane ([`PackHits`]) in one 256-bit register per quantity. Not a closure per axis: a
    /// closure is not compiled for AVX, and its intrinsics would be calls.
    ///
    /// # Safety
    /// The CPU has AVX.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn hits_avx(&self, origin: DVec3, inv: DVec3, t_min: f64, t_max: f64) -> PackHits {
        use std::arch::x86_64::*;
        let widen = _mm256_set1_pd(FAR_WIDENING);
        let mut near = [_mm256_setzero_pd(); 3];
        let mut far = [_mm256_setzero_pd(); 3];
        for a in 0..3 {
            let (o, r) = (_mm256_set1_pd(origin[a]), _mm256_set1_pd(inv[a]));
            // SAFETY: the rows are `[f64; 4]` aligned to 32 bytes (`BoxPack`'s alignment).
            let (lo, hi) = unsafe { (_mm256_load_pd(self.lo[a].as_ptr()), _mm256_load_pd(self.hi[a].as_ptr())) };
            let t0 = _mm256_mul_pd(_mm256_sub_pd(lo, o), r);
            let t1 = _mm256_mul_pd(_mm256_sub_pd(hi, o), r);
            near[a] = _mm256_min_pd(t0, t1);
            far[a] = _mm256_mul_pd(_mm256_max_pd(t0, t1), widen);
        }
        let near = _mm256_max_pd(_mm256_max_pd(near[0], _mm256_max_pd(near[1], near[2])), _mm256_set1_pd(t_min));
        let far = _mm256_min_pd(_mm256_min_pd(far[0], _mm256_min_pd(far[1], far[2])), _mm256_set1_pd(t_max));
        let mask = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_NGT_UQ>(near, far)) as u32;
        let mut t_near = [0.0; LANES];
        // SAFETY: `t_near` holds 4 `f64`.
        unsafe { _mm256_storeu_pd(t_near.as_mut_ptr(), near) };
        (mask, t_near)
    }

    /// The slab test of every lane in two SSE2 halves (every x86-64 CPU has SSE2).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn hits_sse2(&self, origin: DVec3, inv: DVec3, t_min: f64, t_max: f64) -> PackHits {
        use std::arch::x86_64::*;
        let mut mask = 0;
        let mut t_near = [0.0; LANES];
        // SAFETY: SSE2 is part of x86-64; the loads read pairs `half..half + 2` of `[f64; 4]`
        // rows aligned to 32 bytes, the stores write 2 of `t_near`'s 4.
        unsafe {
            for half in [0, 2] {
                let widen = _mm_set1_pd(FAR_WIDENING);
                let mut near = [_mm_setzero_pd(); 3];
                let mut far = [_mm_setzero_pd(); 3];
                for a in 0..3 {
                    let (o, r) = (_mm_set1_pd(origin[a]), _mm_set1_pd(inv[a]));
                    let (lo, hi) = (_mm_load_pd(self.lo[a][half..].as_ptr()), _mm_load_pd(self.hi[a][half..].as_ptr()));
                    let t0 = _mm_mul_pd(_mm_sub_pd(lo, o), r);
                    let t1 = _mm_mul_pd(_mm_sub_pd(hi, o), r);
                    near[a] = _mm_min_pd(t0, t1);
                    far[a] = _mm_mul_pd(_mm_max_pd(t0, t1), widen);
                }
                let near = _mm_max_pd(_mm_max_pd(near[0], _mm_max_pd(near[1], near[2])), _mm_set1_pd(t_min));
                let far = _mm_min_pd(_mm_min_pd(far[0], _mm_min_pd(far[1], far[2])), _mm_set1_pd(t_max));
                mask |= (_mm_movemask_pd(_mm_cmpngt_pd(near, far)) as u32) << half;
                _mm_storeu_pd(t_near[half..].as_mut_ptr(), near);
            }
        }
        (mask, t_near)
    }

    /// The slab test of every lane one by one, in [`Aabb::hit`]'s own operations.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    #[inline(always)]
    fn hits_scalar(&self, origin: DVec3, inv: DVec3, t_min: f64, t_max: f64) -> PackHits {
        let mut mask = 0;
        let mut t_near = [0.0; LANES];
        for (lane, t) in t_near.iter_mut().enumerate() {
            let b = self.lane(lane);
            let t0 = (b.min - origin) * inv;
            let t1 = (b.max - origin) * inv;
            let near = t0.min(t1).max_element().max(t_min);
            let far = (t0.max(t1) * FAR_WIDENING).min_element().min(t_max);
            mask |= u32::from(!(near > far)) << lane;
            *t = near;
        }
        (mask, t_near)
    }

    /// The box in `lane`.
    fn lane(&self, lane: usize) -> Aabb {
        let (lo, hi) = (&self.lo, &self.hi);
        Aabb { min: DVec3::new(lo[0][lane], lo[1][lane], lo[2][lane]), max: DVec3::new(hi[0][lane], hi[1][lane], hi[2][lane]) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::ray::Ray;

    /// A small deterministic generator (no dependency for a test).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        /// Mostly ordinary values, with the cases that make NaN and infinities in a slab test:
        /// zero direction components, origins on a box's planes, flat boxes.
        fn coord(&mut self, specials: &[f64]) -> f64 {
            if self.next() < 0.2 {
                specials[(self.next() * specials.len() as f64) as usize % specials.len()]
            } else {
                4.0 * self.next() - 2.0
            }
        }
    }

    /// Every copy of the pack test answers `Aabb::hit` exactly, lane by lane, and so does a limit
    /// lowered after the test (`!(t_near > t)` on the mask), on random boxes and rays that include
    /// zero direction components, origins on box planes, flat boxes and infinite limits.
    #[test]
    fn packs_answer_aabb_hit_exactly() {
        let mut rng = Rng(7);
        let planes = [-1.0, 0.0, 0.5, 1.0];
        let mut agreed = [0usize; 2];
        for _ in 0..20_000 {
            let n = 1 + (rng.next() * 7.0) as usize;
            let boxes: Vec<Aabb> = (0..n)
                .map(|_| {
                    let a = DVec3::new(rng.coord(&planes), rng.coord(&planes), rng.coord(&planes));
                    let b = DVec3::new(rng.coord(&planes), rng.coord(&planes), rng.coord(&planes));
                    Aabb { min: a.min(b), max: a.max(b) }
                })
                .collect();
            let lanes = BoxLanes::new(boxes.iter().copied());
            let origin = DVec3::new(rng.coord(&planes), rng.coord(&planes), rng.coord(&planes));
            let zeros = [0.0, -0.0];
            let mut dir = DVec3::new(rng.coord(&zeros), rng.coord(&zeros), rng.coord(&zeros));
            if dir == DVec3::ZERO {
                dir = DVec3::X;
            }
            let ray = Ray { origin, dir: dir.normalize() };
            let inv = ray.dir.recip();
            let t_min = if rng.next() < 0.5 { 0.0 } else { rng.next() };
            let t_max = if rng.next() < 0.5 { f64::INFINITY } else { 3.0 * rng.next() };
            let lowered = t_max.min(3.0 * rng.next());
            for (p, pack) in lanes.packs.iter().enumerate() {
                let mut copies = vec![pack.hits_scalar(origin, inv, t_min, t_max)];
                #[cfg(target_arch = "x86_64")]
                {
                    copies.push(pack.hits_sse2(origin, inv, t_min, t_max));
                    if avx_available() {
                        // SAFETY: AVX was detected.
                        copies.push(unsafe { pack.hits_avx(origin, inv, t_min, t_max) });
                    }
                }
                for (mask, near) in copies {
                    for lane in 0..LANES.min(n - p * LANES) {
                        let b = boxes[p * LANES + lane];
                        let hit = mask >> lane & 1 != 0;
                        assert_eq!(hit, b.hit(&ray, inv, t_min, t_max), "{b:?} {ray:?}");
                        assert_eq!(hit && !(near[lane] > lowered), b.hit(&ray, inv, t_min, lowered), "{b:?} {ray:?} lowered to {lowered}");
                        agreed[usize::from(hit)] += 1;
                    }
                }
            }
        }
        // Both answers occur often: the test can fail either way.
        assert!(agreed[0] > 10_000 && agreed[1] > 10_000, "{agreed:?}");
    }

    /// `visit` goes through the boxes met in slot order, adds the `always` slot at its place,
    /// leaves the `never` slot out, and stops when asked.
    #[test]
    fn visit_goes_in_slot_order_and_stops() {
        let unit = |x: f64| Aabb { min: DVec3::new(x, -1.0, -1.0), max: DVec3::new(x + 1.0, 1.0, 1.0) };
        // Six boxes along +x; the ray misses the one at slot 3 (moved aside).
        let mut boxes: Vec<Aabb> = (0..6).map(|i| unit(2.0 * f64::from(i))).collect();
        boxes[3].min.y = 5.0;
        boxes[3].max.y = 6.0;
        let lanes = BoxLanes::new(boxes.iter().copied());
        let (origin, dir) = (DVec3::new(-1.0, 0.0, 0.0), DVec3::X);
        let mut seen = Vec::new();
        let stopped = lanes.visit(origin, dir.recip(), 0.0, f64::INFINITY, 3, usize::MAX, |slot, _| {
            seen.push(slot);
            false
        });
        assert!(!stopped);
        assert_eq!(seen, [0, 1, 2, 3, 4, 5]);
        seen.clear();
        lanes.visit(origin, dir.recip(), 0.0, f64::INFINITY, usize::MAX, 2, |slot, _| {
            seen.push(slot);
            false
        });
        assert_eq!(seen, [0, 1, 4, 5]);
        seen.clear();
        let stopped = lanes.visit(origin, dir.recip(), 0.0, f64::INFINITY, usize::MAX, usize::MAX, |slot, near| {
            seen.push(slot);
            assert_eq!(near, 1.0 + 2.0 * slot as f64);
            slot == 4
        });
        assert!(stopped);
        assert_eq!(seen, [0, 1, 2, 4]);
    }
}
