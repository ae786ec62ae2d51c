//! Adaptive anti-aliasing: recursive corner subdivision (Whitted 1980, POV-Ray's `+AM2`) with
//! edges located by bisection.
//!
//! Rays go through the corners of each pixel, on a lattice of `2^max_depth` points per pixel side
//! ([`SampleId::Lattice`], global coordinates). A square (at first the pixel) whose corners'
//! displayed values differ by more than its threshold is refined:
//!
//! - **Edge**: when exactly two of its sides have ends that differ, an edge enters and leaves
//!   through them. Each crossing is found by bisection along its side's lattice points (a point
//!   joins the end it looks like; a point like neither is a ramp or a third value, and the edge
//!   attempt is abandoned). Bisection stops once the bracket, `L` pixels long, has ends that
//!   differ by at most `threshold / L`: a faint edge is located coarsely, a strong one to the
//!   lattice. The line between the crossings cuts the square into two regions; the lattice
//!   point at each region's centroid is traced and must look like the region's corners (a
//!   corner of an object, a curve or a thin feature fails this). Each region is the
//!   integral of the linear interpolation of its samples (its corners, the points bracketing
//!   the crossings on its side, its centroid), and the square is their sum: a piecewise-linear
//!   reconstruction with a discontinuity, filtered by the pixel's box.
//! - **Split**: otherwise the square is split into four by tracing its centre and edge midpoints,
//!   and each quarter is handled the same way, down to `max_depth` levels.
//!
//! A square that is not refined is the mean of its corners (the integral of their bilinear
//! interpolation: a box filter over the pixel, like stratified sampling's). A finest cell whose
//! corners still disagree may add `cell_samples` stratified points inside it
//! ([`SampleId::Cell`]).
//!
//! With [`AdaptiveSettings::coarse`] levels the test starts above the pixel (Mitchell's
//! low-density sampling, Radiance's `rpict -ps`): a block of `2^k × 2^k` pixels, when the image
//! holds all of it, is tested on its four corners; if they agree, each of its pixels is the mean of
//! their bilinear interpolation over the pixel (its value at the pixel's centre), otherwise the
//! pixel's block one level down is tested, down to the pixel's own square. A feature between a
//! block's corners that touches none of them is not seen: the trade for a quarter or less of a
//! ray per pixel in smooth regions.
//!
//! The threshold means the same at every depth: a square of side `s` pixels is refined when its
//! contrast exceeds `threshold / s^1.5`, about the error an unresolved edge across it leaves in
//! its pixel (the area it misjudges, `~s²` for each of the `~1/s` squares along the edge, adding
//! like random errors). A crossing bracketed to `L` pixels misplaces the line along the whole
//! edge, an error of about `contrast · L`, hence `threshold / L` for bisection. Contrast is
//! compared on displayed values (clamped, encoded, 0..1), the units of 8-bit images and their
//! error metrics.
//!
//! A pixel's value depends only on the lattice points on and inside its square (and its blocks'
//! corners), which are pure functions of their coordinates and the seed: any thread count, tile
//! split or crop gives the same pixels. Points shared by neighbouring squares and pixels are
//! traced once per tile: they are kept in a window of the lattice as wide as the tile and a pixel
//! (or block) row high, indexed by coordinates, each slot checked against its point's key, with no
//! hashing, allocation or locking per sample. The window holds at most `MAX_WINDOW` slots: from `aa_depth` 5 on a
//! 64-pixel tile it is narrower than the tile and some shared points are traced twice (the pixels
//! are the same). A pixel's weighted sum is computed in a fixed order from its own points,
//! then stored as one exact unit of weight ([`PixelSum::whole`]): a pixel is the same whichever
//! share of the frame ([`crate::render::share`]) renders it.

use crate::math::color::{Color, Encoding, srgb_encode};
use crate::render::accum::{AovSum, PixelSum};
use crate::render::job::{AdaptiveSettings, MAX_ADAPTIVE_COARSE, MAX_ADAPTIVE_DEPTH, MAX_CELL_SAMPLES, RenderJob};
use crate::render::sample::{ImageSetup, SampleId, image_setup, trace_sample};
use crate::render::stats::RayStats;
use glam::Vec3;
use std::cell::RefCell;

/// Layers as weighted means: combined with the same weights as the colour.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WeightedLayers {
    /// Weighted depth over the weight of the rays that hit.
    pub depth: f32,
    /// Weight of the rays that hit.
    pub hits: f32,
    /// Weighted shading normal.
    pub normal: Vec3,
    /// Weighted albedo.
    pub albedo: Vec3,
    /// Weighted radiance met directly.
    pub emitted: Vec3,
}

impl WeightedLayers {
    /// The mean layers of `s` as one unit of weight.
    fn of(s: &AovSum) -> Self {
        let (depth, normal, albedo) = s.mean();
        let hits = if s.rays > 0 { s.hits as f32 / s.rays as f32 } else { 0.0 };
        WeightedLayers { depth: if depth.is_finite() { depth * hits } else { 0.0 }, hits, normal, albedo, emitted: s.emitted_mean() }
    }

    /// Adds `o` with weight `w`.
    #[inline]
    fn add_scaled(&mut self, o: &WeightedLayers, w: f32) {
        self.depth += o.depth * w;
        self.hits += o.hits * w;
        self.normal += o.normal * w;
        self.albedo += o.albedo * w;
        self.emitted += o.emitted * w;
    }

    /// The pixel's layers as sums of one unit of weight. The albedo is a convex combination of
    /// values in [0, 1]; clamping removes what rounding of the weights adds beyond.
    pub fn sum(&self) -> AovSum {
        let depth = if self.hits > 0.0 { self.depth / self.hits } else { f32::INFINITY };
        AovSum::whole(depth, self.normal, self.albedo.clamp(Vec3::ZERO, Vec3::ONE), self.emitted.max(Vec3::ZERO))
    }
}

/// The value of a pixel: mean radiance, and mean layers (weight 1).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Value {
    /// Mean radiance.
    pub color: Color,
    /// Layers (zero unless asked for).
    pub layers: WeightedLayers,
}

/// A traced lattice point.
/// A square of the lattice: its top-left point (`x`, `y`), its side `size`, its corners `c`
/// (top-left, top-right, bottom-left, bottom-right) and its weight `w` in the pixel.
#[derive(Clone, Copy)]
struct Square {
    x: u64,
    y: u64,
    size: u64,
    c: [Point; 4],
    w: f64,
}

#[derive(Clone, Copy, Debug)]
struct Point {
    /// Global lattice key (`y · row + x`), [`EMPTY`] for a free slot.
    key: u64,
    /// Mean radiance of the point's camera rays.
    color: Color,
    /// Displayed value per channel (clamped, encoded, 0..1) in units of [`DISPLAY_STEP`]: what
    /// the tests compare.
    display: [u16; 3],
    /// What the point's rays saw ([`crate::render::aov::AovSample::signature`]).
    signature: u64,
}

/// The key of a free slot (no lattice point has it: keys are below `height · 2^depth · row`).
const EMPTY: u64 = u64::MAX;

/// The resolution of [`Point::display`]: far finer than any useful threshold or 8-bit step.
const DISPLAY_STEP: f32 = 1.0 / 65535.0;

impl Point {
    const NONE: Point = Point { key: EMPTY, color: Color::ZERO, display: [0; 3], signature: 0 };
}

/// A step, not a ramp: while bisecting a side, each point must differ from the end it joins by
/// at most this fraction of the two ends' contrast (a point halfway in value is a gradient,
/// which two flat regions would misrepresent).
const STEP_FRACTION: f32 = 0.3;

/// Most slots of the window (48 bytes each, 3 MiB, kept per thread): at deep levels, wide
/// tiles lose some sharing between pixel rows rather than take more memory.
const MAX_WINDOW: usize = 1 << 16;

thread_local! {
    /// The window's slots, reused by the tiles a thread renders (cleared for each).
    static SLOTS: RefCell<Vec<Point>> = const { RefCell::new(Vec::new()) };
}

/// The adaptive scheme for one tile of one job, with the lattice points it has traced.
pub struct Adaptive<'a> {
    job: &'a RenderJob,
    /// What every sample of the image shares.
    setup: ImageSetup,
    settings: AdaptiveSettings,
    /// Threshold by the number of subdivisions left (the square's size), in display units.
    thresholds: [f32; MAX_ADAPTIVE_DEPTH as usize + 1],
    depth: u32,
    /// Coarse levels ([`AdaptiveSettings::coarse`], at most [`MAX_ADAPTIVE_COARSE`]).
    coarse: u32,
    /// Threshold of a block of `2^k` pixels at index `k` (1 ..= `coarse`), in display units.
    coarse_thresholds: [f32; MAX_ADAPTIVE_COARSE as usize + 1],
    /// Contrast a bisection bracket must exceed to be halved, by its length (2^k lattice
    /// steps at index k), in display units: `threshold / L` for a bracket `L` pixels long.
    bisect: [f32; MAX_ADAPTIVE_DEPTH as usize + 1],
    /// Lattice points per pixel side, `2^depth`.
    res: u64,
    /// Lattice points per lattice row of the image (`width · res + 1`): the key's stride.
    row: u64,
    /// The window: `rows` × `cols` slots, lattice row modulo `rows`, column from `x0` modulo
    /// `cols`.
    slots: Vec<Point>,
    /// Layers of each slot (empty unless asked for).
    layers: Vec<WeightedLayers>,
    x0: u64,
    cols: u64,
    rows: u64,
}

impl Drop for Adaptive<'_> {
    fn drop(&mut self) {
        let slots = std::mem::take(&mut self.slots);
        SLOTS.with(|s| *s.borrow_mut() = slots);
    }
}

impl<'a> Adaptive<'a> {
    /// The scheme for `job` over the pixel columns `x0 .. x0 + width` (pixels left of `x0` must
    /// not be asked for; pixels beyond share fewer points); `layers` also computes the depth,
    /// normal and albedo layers.
    pub fn new(job: &'a RenderJob, settings: AdaptiveSettings, x0: u32, width: u32, layers: bool) -> Self {
        let depth = settings.max_depth.min(MAX_ADAPTIVE_DEPTH);
        let res = 1u64 << depth;
        let row = u64::from(job.settings.width) * res + 1;
        // A block's lattice points must fit the window (`2^(depth + coarse) + 1` a side); the
        // loader refuses more.
        let coarse = settings.coarse.min(MAX_ADAPTIVE_COARSE).min(MAX_ADAPTIVE_DEPTH - depth);
        // A block row's lattice rows, so its bottom row is still there for the next block row.
        let rows = (res << coarse) + 1;
        // Columns from the left of `x0`'s block: a block's corners are all in the window.
        let (x0, width) = (x0 - x0 % (1 << coarse), width.max(1) + x0 % (1 << coarse));
        let cols = (u64::from(width) * res + 1).min((MAX_WINDOW as u64 / rows).max(rows));
        let n = (rows * cols) as usize;
        let mut slots = SLOTS.with(|s| std::mem::take(&mut *s.borrow_mut()));
        slots.clear();
        slots.resize(n, Point::NONE);
        let mut thresholds = [f32::INFINITY; MAX_ADAPTIVE_DEPTH as usize + 1];
        for (levels, t) in thresholds.iter_mut().enumerate().take(depth as usize + 1) {
            // A square with `levels` subdivisions left has side 2^(levels − depth) pixels.
            let side = 2f64.powi(levels as i32 - depth as i32);
            *t = (settings.threshold / side.powf(1.5)) as f32;
        }
        let mut coarse_thresholds = [f32::INFINITY; MAX_ADAPTIVE_COARSE as usize + 1];
        for (k, t) in coarse_thresholds.iter_mut().enumerate().take(coarse as usize + 1).skip(1) {
            *t = (settings.threshold / 2f64.powi(k as i32).powf(1.5)) as f32;
        }
        let mut bisect = [f32::INFINITY; MAX_ADAPTIVE_DEPTH as usize + 1];
        for (levels, t) in bisect.iter_mut().enumerate().take(depth as usize + 1) {
            // A bracket of 2^levels lattice steps is 2^(levels − depth) pixels long.
            *t = (settings.threshold / 2f64.powi(levels as i32 - depth as i32)) as f32;
        }
        Adaptive {
            bisect,
            job,
            setup: image_setup(job),
            settings,
            thresholds,
            depth,
            coarse,
            coarse_thresholds,
            res,
            row,
            slots,
            layers: if layers { vec![WeightedLayers::default(); n] } else { Vec::new() },
            x0: u64::from(x0) * res,
            cols,
            rows,
        }
    }

    /// The value of pixel (`x`, `y`).
    pub fn pixel(&mut self, x: u32, y: u32, stats: &mut RayStats) -> Value {
        let mut acc = Acc::default();
        self.pixel_into(x, y, stats, &mut acc);
        Value { color: acc.color, layers: acc.layers }
    }

    /// The samples pixel (`x`, `y`) is made of, in the order first added, each with its weight
    /// in the pixel's value (the weights sum to 1). Points traced only to decide (bisection
    /// points that end up inside a region) are not listed.
    pub fn pixel_samples(&mut self, x: u32, y: u32, stats: &mut RayStats) -> Vec<(SampleId, f64)> {
        let mut acc = Acc { record: Some(Vec::new()), ..Acc::default() };
        self.pixel_into(x, y, stats, &mut acc);
        acc.record.unwrap_or_default()
    }

    fn pixel_into(&mut self, x: u32, y: u32, stats: &mut RayStats, acc: &mut Acc) {
        let (width, height) = (self.job.settings.width, self.job.settings.height);
        for k in (1..=self.coarse).rev() {
            // The block of 2^k pixels holding the pixel, when the image holds all of it.
            let side = 1u32 << k;
            let (bx, by) = (x - x % side, y - y % side);
            if bx + side > width || by + side > height {
                continue;
            }
            let (lx, ly, l) = (u64::from(bx) * self.res, u64::from(by) * self.res, u64::from(side) * self.res);
            let c = [
                self.point(lx, ly, stats),
                self.point(lx + l, ly, stats),
                self.point(lx, ly + l, stats),
                self.point(lx + l, ly + l, stats),
            ];
            if !self.disagree(&c, self.coarse_thresholds[k as usize]) {
                // The mean over the pixel of the corners' bilinear interpolation: its value at
                // the pixel's centre.
                let u = (f64::from(x - bx) + 0.5) / f64::from(side);
                let v = (f64::from(y - by) + 0.5) / f64::from(side);
                for (p, w) in c.iter().zip([(1.0 - u) * (1.0 - v), u * (1.0 - v), (1.0 - u) * v, u * v]) {
                    self.add(p, w, acc);
                }
                return;
            }
        }
        let (x, y, r) = (u64::from(x) * self.res, u64::from(y) * self.res, self.res);
        let c = [self.point(x, y, stats), self.point(x + r, y, stats), self.point(x, y + r, stats), self.point(x + r, y + r, stats)];
        self.square(Square { x, y, size: r, c, w: 1.0 }, self.depth, stats, acc);
    }

    /// Adds the square `sq`, allowed `levels` more subdivisions, to `acc`.
    fn square(&mut self, sq: Square, levels: u32, stats: &mut RayStats, acc: &mut Acc) {
        let Square { x, y, size, c, w } = sq;
        let t = self.thresholds[levels as usize];
        if !self.disagree(&c, t) {
            self.corners(&c, w, acc);
            return;
        }
        if levels == 0 {
            self.cell(x, y, &c, w, stats, acc);
            return;
        }
        if self.settings.edges && self.edge(&sq, t, stats, acc) {
            return;
        }
        let h = size / 2;
        let top = self.point(x + h, y, stats);
        let left = self.point(x, y + h, stats);
        let mid = self.point(x + h, y + h, stats);
        let right = self.point(x + size, y + h, stats);
        let bottom = self.point(x + h, y + size, stats);
        let q = 0.25 * w;
        self.square(Square { x, y, size: h, c: [c[0], top, left, mid], w: q }, levels - 1, stats, acc);
        self.square(Square { x: x + h, y, size: h, c: [top, c[1], mid, right], w: q }, levels - 1, stats, acc);
        self.square(Square { x, y: y + h, size: h, c: [left, mid, c[2], bottom], w: q }, levels - 1, stats, acc);
        self.square(Square { x: x + h, y: y + h, size: h, c: [mid, right, bottom, c[3]], w: q }, levels - 1, stats, acc);
    }

    /// The square as the mean of its corners.
    fn corners(&self, c: &[Point; 4], w: f64, acc: &mut Acc) {
        for p in c {
            self.add(p, 0.25 * w, acc);
        }
    }

    /// A finest cell whose corners still disagree: the mean of its corners, or with
    /// `cell_samples` it and that many stratified points inside, each weighing as much as the
    /// four corners together.
    fn cell(&mut self, x: u64, y: u64, c: &[Point; 4], w: f64, stats: &mut RayStats, acc: &mut Acc) {
        let n = self.settings.cell_samples.min(MAX_CELL_SAMPLES);
        let share = w / (f64::from(n) + 1.0);
        self.corners(c, share, acc);
        let with_layers = !self.layers.is_empty();
        for index in 0..n {
            let id = SampleId::Cell { x, y, depth: self.depth, index, count: n };
            let (mut s, mut sums) = (PixelSum::default(), AovSum::default());
            trace_sample(self.job, &self.setup, id, &mut s, with_layers.then_some(&mut sums), stats);
            acc.color += s.mean() * share;
            if with_layers {
                acc.layers.add_scaled(&WeightedLayers::of(&sums), share as f32);
            }
            if let Some(r) = acc.record.as_mut() {
                r.push((id, share));
            }
        }
    }

    /// When exactly two sides of the square have ends that differ, the square split along the
    /// line between the two crossings (found by bisection) into two regions, each integrated
    /// from its samples (see the module docs); false (nothing added) when the square is not cut
    /// by one clean edge.
    fn edge(&mut self, sq: &Square, t: f32, stats: &mut RayStats, acc: &mut Acc) -> bool {
        let &Square { x, y, size, ref c, w } = sq;
        // Sides clockwise from the top-left corner: (from corner, to corner, start, step).
        let s = size as i64;
        let sides = [(0, 1, (0, 0), (1, 0)), (1, 3, (s, 0), (0, 1)), (3, 2, (s, s), (-1, 0)), (2, 0, (0, s), (0, -1))];
        let mut crossed = [false; 4];
        let mut contrast = f32::INFINITY;
        for (k, &(a, b, _, _)) in sides.iter().enumerate() {
            if self.differ(&c[a], &c[b], t) {
                crossed[k] = true;
                contrast = contrast.min(dist(&c[a], &c[b]));
            }
        }
        if crossed.iter().filter(|&&v| v).count() != 2 {
            return false;
        }
        // Each crossing: its perimeter position (side k spans [k, k + 1), clockwise) and the
        // points bracketing it, before and after it clockwise.
        let mut cross = [(0.0f64, c[0], c[0]); 2];
        let mut found = 0;
        // The longest final bracket, lattice units: how far the line may be from the edge.
        let mut bracket = 1i64;
        for (k, &(a, b, (ox, oy), (dx, dy))) in sides.iter().enumerate() {
            if !crossed[k] {
                continue;
            }
            let (mut lo, mut hi) = (0i64, s);
            let (mut vlo, mut vhi) = (c[a], c[b]);
            // Bisect while the bracket's ends differ by more than `threshold / L` (`L` its
            // length in pixels): a line misplaced by up to `L` misjudges about `L` of the
            // pixel's area along the whole edge, an error of about `contrast · L`, so a faint
            // edge is located only as finely as its contrast needs.
            while hi - lo > 1 && self.differ(&vlo, &vhi, self.bisect[(hi - lo).trailing_zeros() as usize]) {
                let m = (lo + hi) / 2;
                let p = self.point((x as i64 + ox + dx * m) as u64, (y as i64 + oy + dy * m) as u64, stats);
                match self.joins(&p, &vlo, &vhi, t) {
                    Some(true) => (lo, vlo) = (m, p),
                    Some(false) => (hi, vhi) = (m, p),
                    None => return false,
                }
            }
            cross[found] = (k as f64 + (lo + hi) as f64 / (2 * size) as f64, vlo, vhi);
            bracket = bracket.max(hi - lo);
            found += 1;
        }
        let [(s1, before1, after1), (s2, before2, after2)] = cross;
        let (p1, p2) = (perimeter_point(s1), perimeter_point(s2));
        // The two regions as polygons (unit square, y down), each vertex with the sample that
        // stands for it: region one runs clockwise from the first crossing to the second.
        const CLOCKWISE: [usize; 4] = [0, 1, 3, 2];
        let (mut one, mut two) = (Polygon::EMPTY, Polygon::EMPTY);
        let mut in_one = [false; 4];
        one.push(p1, after1);
        for (i, &corner) in CLOCKWISE.iter().enumerate() {
            if (i as f64) > s1 && (i as f64) < s2 {
                one.push(perimeter_point(i as f64), c[corner]);
                in_one[corner] = true;
            }
        }
        one.push(p2, before2);
        two.push(p2, after2);
        for i in (0..4).filter(|&i| i as f64 > s2).chain((0..4).filter(|&i| (i as f64) < s1)) {
            two.push(perimeter_point(i as f64), c[CLOCKWISE[i]]);
        }
        two.push(p1, before1);
        let (ex, ey) = (p2.0 - p1.0, p2.1 - p1.1);
        let norm = (ex * ex + ey * ey).sqrt().max(f64::MIN_POSITIVE);
        let side_of = |u: (f64, f64)| (ex * (u.1 - p1.1) - ey * (u.0 - p1.0)) / norm;
        let contrast = dist(&after1, &before1).min(dist(&after2, &before2));
        let tol = t.min(STEP_FRACTION * contrast.max(t));
        let mut apex = [None, None];
        // Each region's centroid (the nearest lattice point) must look like the region.
        for (r, poly) in [&one, &two].into_iter().enumerate() {
            let (cx, cy) = poly.centroid();
            let (lx, ly) = ((cx * size as f64).round(), (cy * size as f64).round());
            if lx <= 0.0 || ly <= 0.0 || lx >= size as f64 || ly >= size as f64 {
                continue;
            }
            let at = (lx / size as f64, ly / size as f64);
            let corner = poly.v[1].0;
            if side_of(at).abs() * size as f64 <= bracket as f64 || (side_of(at) > 0.0) != (side_of(corner) > 0.0) {
                continue;
            }
            let m = self.point(x + lx as u64, y + ly as u64, stats);
            let like = (0..4).filter(|&i| in_one[i] == (r == 0)).any(|i| dist(&m, &c[i]) <= tol);
            if !like {
                return false;
            }
            apex[r] = Some((at, m));
        }
        one.integrate(apex[0], w, |p, wp| self.add(p, wp, acc));
        two.integrate(apex[1], w, |p, wp| self.add(p, wp, acc));
        true
    }

    /// Which end a point `p` on a side joins while bisecting from `lo` to `hi`: `Some(true)` for
    /// `lo`, `Some(false)` for `hi`, `None` when it looks like neither (a ramp or a third value).
    fn joins(&self, p: &Point, lo: &Point, hi: &Point, t: f32) -> Option<bool> {
        if self.settings.signature && lo.signature != hi.signature {
            // Signatures tell the sides apart; colour must still agree with the side joined.
            let low = p.signature == lo.signature;
            if !low && p.signature != hi.signature {
                return None;
            }
            let end = if low { lo } else { hi };
            return (dist(p, end) <= t).then_some(low);
        }
        let (dl, dh) = (dist(p, lo), dist(p, hi));
        if dl.min(dh) > t.min(STEP_FRACTION * dist(lo, hi)) {
            return None;
        }
        Some(dl <= dh)
    }

    /// Adds point `p` with weight `w` to `acc`.
    #[inline]
    fn add(&self, p: &Point, w: f64, acc: &mut Acc) {
        acc.color += p.color * w;
        if !self.layers.is_empty() {
            acc.layers.add_scaled(&self.layers[self.slot(p.key % self.row, p.key / self.row)], w as f32);
        }
        if let Some(r) = acc.record.as_mut() {
            let id = SampleId::Lattice { x: p.key % self.row, y: p.key / self.row, depth: self.depth };
            match r.iter_mut().find(|(i, _)| *i == id) {
                Some(e) => e.1 += w,
                None => r.push((id, w)),
            }
        }
    }

    /// Whether the corners `c` disagree: their displayed values span more than `t` in some
    /// channel, or (when asked) their signatures differ.
    #[inline]
    fn disagree(&self, c: &[Point; 4], t: f32) -> bool {
        if self.settings.signature
            && (c[0].signature != c[1].signature || c[0].signature != c[2].signature || c[0].signature != c[3].signature)
        {
            return true;
        }
        (0..3).any(|k| {
            let v = [c[0].display[k], c[1].display[k], c[2].display[k], c[3].display[k]];
            let span = v[0].max(v[1]).max(v[2]).max(v[3]) - v[0].min(v[1]).min(v[2]).min(v[3]);
            f32::from(span) * DISPLAY_STEP > t
        })
    }

    /// Whether two points differ: by more than `t` in some displayed channel, or (when asked)
    /// in signature.
    #[inline]
    fn differ(&self, a: &Point, b: &Point, t: f32) -> bool {
        dist(a, b) > t || (self.settings.signature && a.signature != b.signature)
    }

    /// The window slot of lattice point (`x`, `y`): rows and columns modulo the window's, so the
    /// `res + 1` columns and rows of one pixel never share a slot.
    #[inline]
    fn slot(&self, x: u64, y: u64) -> usize {
        ((y % self.rows) * self.cols + x.wrapping_sub(self.x0) % self.cols) as usize
    }

    /// The value at lattice point (`x`, `y`), traced unless the window holds it.
    #[inline]
    fn point(&mut self, x: u64, y: u64, stats: &mut RayStats) -> Point {
        let key = y * self.row + x;
        let slot = self.slot(x, y);
        if self.slots[slot].key == key {
            return self.slots[slot];
        }
        let (mut acc, mut sums) = (PixelSum::default(), AovSum::default());
        let with_layers = !self.layers.is_empty();
        let signature = trace_sample(
            self.job,
            &self.setup,
            SampleId::Lattice { x, y, depth: self.depth },
            &mut acc,
            with_layers.then_some(&mut sums),
            stats,
        );
        let color = acc.mean();
        let enc = self.job.settings.encoding;
        let display = [color.x, color.y, color.z].map(|v| display_steps(enc, v as f32));
        let p = Point { key, color, display, signature };
        self.slots[slot] = p;
        if with_layers {
            self.layers[slot] = WeightedLayers::of(&sums);
        }
        p
    }
}

/// A convex region of a square cut by an edge: up to five vertices (unit square, y down), each
/// with the sample that stands for it.
struct Polygon {
    v: [((f64, f64), Point); 5],
    n: usize,
}

impl Polygon {
    const EMPTY: Polygon = Polygon { v: [((0.0, 0.0), Point::NONE); 5], n: 0 };

    fn push(&mut self, at: (f64, f64), p: Point) {
        self.v[self.n] = (at, p);
        self.n += 1;
    }

    /// The centroid.
    fn centroid(&self) -> (f64, f64) {
        let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
        let o = self.v[0].0;
        for i in 1..self.n.saturating_sub(1) {
            let (b, c) = (self.v[i].0, self.v[i + 1].0);
            let area = 0.5 * cross2((b.0 - o.0, b.1 - o.1), (c.0 - o.0, c.1 - o.1));
            a += area;
            cx += area * (o.0 + b.0 + c.0) / 3.0;
            cy += area * (o.1 + b.1 + c.1) / 3.0;
        }
        if a.abs() > 0.0 { (cx / a, cy / a) } else { o }
    }

    /// The integral over the polygon (a share of its square) of the linear interpolation of
    /// its vertices' samples, fanned from `apex` (a sample inside it) or its first vertex, as
    /// weights of those samples scaled by `w`: exact for a linear function.
    fn integrate(&self, apex: Option<((f64, f64), Point)>, w: f64, mut add: impl FnMut(&Point, f64)) {
        let verts = &self.v[..self.n];
        let (a, pa) = apex.unwrap_or(verts[0]);
        let mut wa = 0.0;
        for i in 0..self.n {
            let (b, pb) = verts[i];
            let (c, pc) = verts[(i + 1) % self.n];
            let area = 0.5 * cross2((b.0 - a.0, b.1 - a.1), (c.0 - a.0, c.1 - a.1)).abs() * w;
            if area <= 0.0 {
                continue;
            }
            wa += area / 3.0;
            add(&pb, area / 3.0);
            add(&pc, area / 3.0);
        }
        add(&pa, wa);
    }
}

/// Entries of [`SRGB_TABLE`] per unit of linear value.
const SRGB_TABLE_STEPS: usize = 1 << 14;

/// The sRGB curve at `i / SRGB_TABLE_STEPS`, `i` = 0 ..= [`SRGB_TABLE_STEPS`], in units of
/// [`DISPLAY_STEP`]: interpolated linearly it is within `1e-5` of the curve (its second
/// derivative is below `2·10³` above the linear toe, the spacing `6·10⁻⁵`), under one step.
static SRGB_TABLE: std::sync::LazyLock<Vec<f32>> =
    std::sync::LazyLock::new(|| (0..=SRGB_TABLE_STEPS).map(|i| srgb_encode(i as f32 / SRGB_TABLE_STEPS as f32) / DISPLAY_STEP).collect());

/// The displayed value of linear `v` in units of [`DISPLAY_STEP`], rounded: sRGB by table (the
/// curve's `powf` per channel and point cost as much as a tenth of a ray).
#[inline]
fn display_steps(enc: Encoding, v: f32) -> u16 {
    let steps = match enc {
        Encoding::Srgb => {
            let x = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) } * SRGB_TABLE_STEPS as f32;
            let i = (x as usize).min(SRGB_TABLE_STEPS - 1);
            let f = x - i as f32;
            SRGB_TABLE[i] + (SRGB_TABLE[i + 1] - SRGB_TABLE[i]) * f
        }
        _ => enc.display(v) / DISPLAY_STEP,
    };
    (steps + 0.5) as u16
}

/// The largest difference between the displayed channels of `a` and `b`.
#[inline]
fn dist(a: &Point, b: &Point) -> f32 {
    let d = |k: usize| a.display[k].abs_diff(b.display[k]);
    f32::from(d(0).max(d(1)).max(d(2))) * DISPLAY_STEP
}

/// The point of the unit square's boundary at perimeter position `s` (clockwise from the
/// top-left corner, one unit per side; y down).
fn perimeter_point(s: f64) -> (f64, f64) {
    let f = s - s.floor();
    match s.floor() as u32 {
        0 => (f, 0.0),
        1 => (1.0, f),
        2 => (1.0 - f, 1.0),
        _ => (0.0, 1.0 - f),
    }
}

/// The z component of the cross product of `a` and `b` (twice the signed area they span).
fn cross2(a: (f64, f64), b: (f64, f64)) -> f64 {
    a.0 * b.1 - b.0 * a.1
}

/// A pixel's weighted sums (and, for `raylab trace`, the samples with their weights).
#[derive(Default)]
struct Acc {
    color: Color,
    layers: WeightedLayers,
    record: Option<Vec<(SampleId, f64)>>,
}
