//! The one camera-sample path: which camera rays an image sample traces and with which random
//! streams. The render, its depth/normal/albedo layers and `raylab trace` all go through
//! [`camera_rays`], so an explained sample is exactly the sample the render computed.

use crate::geometry::{Hit, PACKET};
use crate::math::color::Color;
use crate::math::ray::Ray;
use crate::math::sampler::{PixelKey, Sampler, SeedKey, StratifiedSet, mix64, sobol_02, stratified_2d};
use crate::render::accum::{AovSum, PixelSum};
use crate::render::aov::AovSample;
use crate::render::job::RenderJob;
use crate::render::stats::RayStats;
use crate::scene::camera::ScreenMap;
use glam::DVec2;
use serde::Serialize;

/// One image sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum SampleId {
    /// Sample `index` of the `spp` stratified samples of pixel (`x`, `y`): the pixel centre when
    /// `spp = 1`, correlated multi-jittered points otherwise.
    Pixel {
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// Sample number, `0..spp`.
        index: u32,
    },
    /// Point (`x`, `y`) of the adaptive lattice, in units of `1 / 2^depth` pixel from the image's
    /// top-left corner (shared by the squares and pixels around it).
    Lattice {
        /// Column of the lattice.
        x: u64,
        /// Row of the lattice.
        y: u64,
        /// Subdivision levels per pixel (the lattice has `2^depth` points per pixel side).
        depth: u32,
    },
    /// Point `index` of `count` stratified points (correlated multi-jitter) inside the finest
    /// cell of the adaptive lattice whose top-left point is (`x`, `y`): the extra samples of a
    /// cell still unresolved at the deepest level.
    Cell {
        /// Column of the cell's top-left lattice point.
        x: u64,
        /// Row of the cell's top-left lattice point.
        y: u64,
        /// Subdivision levels per pixel.
        depth: u32,
        /// Sample number, `0..count`.
        index: u32,
        /// Points in the cell.
        count: u32,
    },
}

/// Lens-pattern key offset, so lens and film patterns of a pixel are independent.
const LENS_PATTERN: u32 = 0x5bd1_e995;

/// Sample index that marks adaptive lattice samples in [`Sampler::with_seed`] (stratified samples
/// never reach it: `spp` is far smaller).
const LATTICE_SAMPLE: u32 = u32::MAX;

/// Key offset of [`SampleId::Cell`] streams, apart from the lattice points' own.
const CELL_STREAM: u64 = 0x6a09_e667_f3bc_c909;

/// The camera rays of one image sample, one per lens point (one for a pinhole camera), each with
/// its random stream.
pub struct CameraRays<'a> {
    job: &'a RenderJob,
    screen: ScreenMap,
    film: DVec2,
    sampler: Sampler,
    /// Lens points `first .. first + count` of a stratified set of `total`, or with
    /// `progressive` of the pixel's progressive lens sequence ([`progressive_lens`]).
    first: u32,
    count: u32,
    total: u32,
    pattern: u32,
    progressive: bool,
    next: u32,
}

impl Iterator for CameraRays<'_> {
    type Item = (Ray, Sampler);

    // Always inlined: the iterator then lives in registers of the sample loop.
    #[inline(always)]
    fn next(&mut self) -> Option<(Ray, Sampler)> {
        if self.next >= self.count {
            return None;
        }
        let l = self.next;
        self.next += 1;
        Some((self.ray(l), self.sampler(l)))
    }
}

impl CameraRays<'_> {
    /// The ray through lens point `l` (of `count`).
    #[inline(always)]
    fn ray(&self, l: u32) -> Ray {
        let camera = &self.job.scene.camera;
        let lens = if camera.aperture <= 0.0 {
            DVec2::ZERO
        } else if self.progressive {
            progressive_lens(self.first + l, self.pattern)
        } else {
            stratified_2d(self.first + l, self.total.max(1), self.pattern)
        };
        camera.ray_in(&self.screen, self.film, lens)
    }

    /// The random stream of the ray through lens point `l`.
    #[inline(always)]
    fn sampler(&self, l: u32) -> Sampler {
        if l == 0 { self.sampler.clone() } else { self.sampler.fork(u64::from(l)) }
    }
}

/// Lens point `j` (the pixel's `j`-th camera ray) of a pixel whose samples may stop after any
/// power of two (an error target, a time budget), for lens pattern `pattern`: the Sobol
/// (0, 2)-sequence ([`sobol_02`]) at `j` shuffled by a nested uniform scramble of its bits
/// (Burley 2020, "Practical Hash-based Owen Scrambling": each bit flipped by a hash of the bits
/// above it, Laine–Karras), so the first `2^k` rays take an aligned block of `2^k` points of the
/// sequence, a (0, k, 2)-net: stratified on the lens whatever the pixel's final count, and in
/// another order than the film positions `sobol_02` gives the same pixel's samples.
#[inline]
fn progressive_lens(j: u32, pattern: u32) -> DVec2 {
    let seed = pattern.wrapping_mul(0x9e37_79b9) | 1;
    let mut v = j.reverse_bits();
    v = v.wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    sobol_02(v.reverse_bits(), pattern)
}

/// The camera rays of sample `id` of `job`: where it lies on the film, and for each lens point
/// the ray and the random stream its integrator draws from.
#[inline]
pub fn camera_rays(job: &RenderJob, id: SampleId) -> CameraRays<'_> {
    camera_rays_in(job, &image_setup(job), id)
}

/// The setup every sample of one image shares, computed once per image or tile: the camera's
/// [`ScreenMap`], the hash of the render seed the samples' streams start from, the miss's AOVs
/// and how pixel samples are placed.
#[derive(Clone, Copy, Debug)]
pub struct ImageSetup {
    screen: ScreenMap,
    seed: SeedKey,
    /// The layers of a camera ray that hits nothing.
    miss: AovSample,
    /// A pixel's stratified samples: their count, and the columns `m` of their set's strata.
    strata: (f64, u32),
    /// Pixel samples are Sobol points (an error target, a time budget), not a stratified set.
    progressive: bool,
}

/// The [`ImageSetup`] of `job`'s image.
#[inline]
pub fn image_setup(job: &RenderJob) -> ImageSetup {
    ImageSetup {
        screen: job.scene.camera.screen_map(job.settings.width, job.settings.height),
        seed: SeedKey::new(job.settings.seed),
        miss: AovSample::miss(job.scene.background),
        strata: (f64::from(job.settings.spp.max(1)), crate::math::sampler::strata(job.settings.spp).0),
        progressive: job.settings.progressive(),
    }
}

/// [`camera_rays`] with `job`'s [`image_setup`] computed once by the caller.
#[inline(always)]
pub fn camera_rays_in<'a>(job: &'a RenderJob, image: &ImageSetup, id: SampleId) -> CameraRays<'a> {
    let s = &job.settings;
    let screen = image.screen;
    let per_sample = if job.scene.camera.aperture > 0.0 { s.lens_samples.max(1) } else { 1 };
    match id {
        SampleId::Pixel { x, y, index } => {
            let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
            // The pixel's pattern key, hashed only when a stratified set (film or lens) uses it.
            let pattern =
                if s.spp > 1 || job.scene.camera.aperture > 0.0 { (mix64(pixel ^ s.seed.rotate_left(17)) >> 32) as u32 } else { 0 };
            // Under an error target or a time budget a pixel may stop after any power of two of
            // samples: its positions then come from a sequence whose every such prefix is
            // stratified.
            let jitter = if s.spp == 1 {
                DVec2::splat(0.5)
            } else if s.progressive() {
                sobol_02(index, pattern)
            } else {
                stratified_2d(index, s.spp, pattern)
            };
            CameraRays {
                job,
                screen,
                film: DVec2::new(f64::from(x), f64::from(y)) + jitter,
                sampler: Sampler::with_seed(pixel, index, image.seed),
                first: index * s.lens_samples,
                count: per_sample,
                total: s.spp * s.lens_samples,
                pattern: pattern ^ LENS_PATTERN,
                // A pixel that may stop after any power of two of samples takes its lens points
                // from a sequence whose every such prefix is stratified too: the first `n` points
                // of a stratified set of `spp` (the cap) are a random choice of its strata.
                progressive: s.progressive(),
                next: 0,
            }
        }
        SampleId::Lattice { x, y, depth } => {
            let res = 1u64 << depth;
            let key = y * (u64::from(s.width) * res + 1) + x;
            let mut sampler = Sampler::with_seed(key, LATTICE_SAMPLE, image.seed);
            let pattern = sampler.next_pattern();
            CameraRays {
                job,
                screen,
                film: DVec2::new(x as f64 / res as f64, y as f64 / res as f64),
                sampler: sampler.fork(0),
                first: 0,
                count: per_sample,
                total: s.lens_samples,
                pattern,
                progressive: false,
                next: 0,
            }
        }
        SampleId::Cell { x, y, depth, index, count } => {
            let res = 1u64 << depth;
            let key = mix64((y * (u64::from(s.width) * res + 1) + x) ^ CELL_STREAM);
            let cell = (mix64(key ^ s.seed.rotate_left(17)) >> 32) as u32;
            let u = stratified_2d(index, count, cell);
            CameraRays {
                job,
                screen,
                film: DVec2::new((x as f64 + u.x) / res as f64, (y as f64 + u.y) / res as f64),
                sampler: Sampler::with_seed(key, index, image.seed),
                first: index * s.lens_samples,
                count: per_sample,
                total: count * s.lens_samples,
                pattern: cell ^ LENS_PATTERN,
                progressive: false,
                next: 0,
            }
        }
    }
}

/// What the samples of one pixel share when their film positions are a stratified set
/// (`spp > 1`, neither an error target nor a time budget: [`ImageSetup::stratified_film`]): its
/// place, its streams' hashed key, its pattern key and that set, built once
/// ([`pixel_setup`]) instead of once per sample.
#[derive(Clone, Copy, Debug)]
pub struct PixelSetup {
    x: u32,
    y: u32,
    key: PixelKey,
    pattern: u32,
    film: StratifiedSet,
}

impl ImageSetup {
    /// Whether pixel samples lie at the points of a stratified set (`spp > 1`, not progressive):
    /// then [`pixel_setup`] builds each pixel's set once.
    #[inline]
    pub fn stratified_film(&self) -> bool {
        self.strata.0 > 1.0 && !self.progressive
    }
}

/// The [`PixelSetup`] of pixel (`x`, `y`) of `job`'s image (`image` its [`image_setup`], whose
/// [`ImageSetup::stratified_film`] holds).
#[inline(always)]
pub fn pixel_setup(job: &RenderJob, image: &ImageSetup, x: u32, y: u32) -> PixelSetup {
    let s = &job.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    // As `camera_rays_in` computes them for each sample.
    let pattern = (mix64(pixel ^ s.seed.rotate_left(17)) >> 32) as u32;
    PixelSetup { x, y, key: image.seed.pixel(pixel), pattern, film: StratifiedSet::new(s.spp, pattern) }
}

impl PixelSetup {
    /// The stratified set of the pixel's film positions: point `index` is sample `index`'s
    /// place in the pixel (`stratified_2d(index, spp, pattern)`).
    #[inline]
    pub fn film(&self) -> &StratifiedSet {
        &self.film
    }

    /// The camera rays of the pixel's sample `index`, whose place in the pixel is `at` (point
    /// `index` of [`PixelSetup::film`]): those [`camera_rays`] gives for [`SampleId::Pixel`].
    #[inline(always)]
    fn rays<'a>(&self, job: &'a RenderJob, image: &ImageSetup, index: u32, at: DVec2) -> CameraRays<'a> {
        let s = &job.settings;
        let per_sample = if job.scene.camera.aperture > 0.0 { s.lens_samples.max(1) } else { 1 };
        CameraRays {
            job,
            screen: image.screen,
            film: DVec2::new(f64::from(self.x), f64::from(self.y)) + at,
            sampler: Sampler::with_pixel_key(self.key, index),
            first: index * s.lens_samples,
            count: per_sample,
            total: s.spp * s.lens_samples,
            pattern: self.pattern ^ LENS_PATTERN,
            progressive: false,
            next: 0,
        }
    }
}

/// Where sample `id` of `job` lies on the film, in continuous pixel coordinates (pixel (x, y)
/// covers [x, x+1) × [y, y+1)): the point its camera rays pass through.
pub fn film_position(job: &RenderJob, id: SampleId) -> DVec2 {
    camera_rays(job, id).film
}

/// Traces sample `id` of `job` (every camera ray of it) and adds the result to `acc`; non-finite
/// radiance is counted in `stats` and dropped. With `layers`, each ray's first surface is added
/// to it too. Returns the sample's signature: its rays' [`AovSample::signature`]s combined. `setup`
/// is `job`'s [`image_setup`], computed once by the caller.
///
/// Always inlined: out of line, it read the sample's id as one 8-byte load across the caller's
/// 4-byte stores (a store-forwarding stall per sample).
#[inline(always)]
pub fn trace_sample(
    job: &RenderJob,
    setup: &ImageSetup,
    id: SampleId,
    acc: &mut PixelSum,
    layers: Option<&mut AovSum>,
    stats: &mut RayStats,
) -> u64 {
    trace_rays(job, setup, id, camera_rays_in(job, setup, id), None, acc, layers, stats)
}

/// [`trace_sample`] for sample `index` of the pixel `pixel` describes (its [`pixel_setup`],
/// computed once by the caller for all its samples), whose place in the pixel `at` is point
/// `index` of [`PixelSetup::film`] (computed by the caller, from that set or its
/// [`crate::math::sampler::TabledSet`]): the same rays, streams and sums.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn trace_pixel_sample(
    job: &RenderJob,
    setup: &ImageSetup,
    pixel: &PixelSetup,
    index: u32,
    at: DVec2,
    acc: &mut PixelSum,
    layers: Option<&mut AovSum>,
    stats: &mut RayStats,
) -> u64 {
    let id = SampleId::Pixel { x: pixel.x, y: pixel.y, index };
    trace_rays(job, setup, id, pixel.rays(job, setup, index, at), None, acc, layers, stats)
}

/// A pixel sample whose one camera ray is gathered into a packet ([`PixelSetup::prepare`]): its
/// index and place in the pixel, kept until its hit is found.
#[derive(Clone, Copy, Debug, Default)]
pub struct PreparedSample {
    index: u32,
    at: DVec2,
}

impl PixelSetup {
    /// Sample `index` of the pixel, whose place in the pixel is `at` (as for
    /// [`trace_pixel_sample`]), prepared for a packet, and its camera ray: `None` when it has
    /// more than one camera ray (lens samples).
    #[inline(always)]
    pub fn prepare(&self, job: &RenderJob, image: &ImageSetup, index: u32, at: DVec2) -> Option<(PreparedSample, Ray)> {
        let rays = self.rays(job, image, index, at);
        (rays.count == 1).then(|| (PreparedSample { index, at }, rays.ray(0)))
    }
}

/// [`trace_pixel_sample`] for a sample of `pixel` prepared for a packet, whose camera ray `ray`
/// (from [`PixelSetup::prepare`]) has the closest hit `hit` (see [`trace_sample_from`]): the
/// same sums.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn trace_prepared_sample(
    job: &RenderJob,
    setup: &ImageSetup,
    pixel: &PixelSetup,
    sample: PreparedSample,
    ray: &Ray,
    hit: Option<&Hit>,
    acc: &mut PixelSum,
    layers: Option<&mut AovSum>,
    stats: &mut RayStats,
) -> u64 {
    let id = SampleId::Pixel { x: pixel.x, y: pixel.y, index: sample.index };
    trace_rays(job, setup, id, pixel.rays(job, setup, sample.index, sample.at), Some((ray, hit)), acc, layers, stats)
}

/// The camera ray of sample `id` when it has only one (no lens samples): what the render loop
/// gathers into packets, then traces with [`trace_sample_from`].
#[inline(always)]
pub fn single_camera_ray(job: &RenderJob, setup: &ImageSetup, id: SampleId) -> Option<Ray> {
    let rays = camera_rays_in(job, setup, id);
    (rays.count == 1).then(|| rays.ray(0))
}

/// [`single_camera_ray`] with the random stream the integrator draws from for it (what
/// [`trace_packet_from`] takes, so the sample's stream is not set up twice).
#[inline(always)]
pub fn single_camera_sample(job: &RenderJob, setup: &ImageSetup, id: SampleId) -> Option<(Ray, Sampler)> {
    let rays = camera_rays_in(job, setup, id);
    (rays.count == 1).then(|| (rays.ray(0), rays.sampler(0)))
}

/// [`trace_sample`] for a sample whose one camera ray `ray` ([`single_camera_ray`]) has the
/// closest hit `hit` in the scene (found for a packet of them), for an integrator that
/// [takes camera hits](crate::render::integrator::Integrator::takes_camera_hits): the same sums.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn trace_sample_from(
    job: &RenderJob,
    setup: &ImageSetup,
    id: SampleId,
    ray: &Ray,
    hit: Option<&Hit>,
    acc: &mut PixelSum,
    layers: Option<&mut AovSum>,
    stats: &mut RayStats,
) -> u64 {
    trace_rays(job, setup, id, camera_rays_in(job, setup, id), Some((ray, hit)), acc, layers, stats)
}

/// [`trace_sample_from`] for the samples `ids[k]` of mask `live`, one camera ray each
/// (`rays[k]`, [`single_camera_sample`], whose stream `samplers[k]` is) with its closest hit
/// (`hit[k]` where bit `k` of `hits` is set), shaded together
/// ([`crate::render::integrator::Integrator::radiance_packet`]): pixel `k`'s `accs[k]` (and
/// `layers[k]`) gets exactly the sums `trace_sample_from` adds.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn trace_packet_from(
    job: &RenderJob,
    setup: &ImageSetup,
    ids: &[SampleId; PACKET],
    (rays, samplers): (&[Ray; PACKET], &mut [Sampler; PACKET]),
    (live, hits): (u32, u32),
    hit: &[Hit; PACKET],
    accs: &mut [PixelSum],
    mut layers: Option<&mut [AovSum]>,
    stats: &mut RayStats,
) {
    let mut second = 0u32;
    // One sample per pixel here (`spp = 1`), never progressive: the film position matters to
    // `second_half` only for a stratified set of several, so no sample's is computed again.
    debug_assert!(!setup.progressive && setup.strata.1 <= 1);
    let mut m = live;
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        second |= u32::from(second_half(setup, ids[k], DVec2::ZERO, &mut accs[k])) << k;
    }
    let mut aovs = [setup.miss; PACKET];
    for a in &mut aovs {
        // Summed layers are a denoiser's guides, as in `trace_rays`.
        a.guides = layers.is_some();
    }
    let mut out = [Color::ZERO; PACKET];
    job.integrator.radiance_packet(&job.scene, rays, live, hits, hit, samplers, stats, &mut aovs, &mut out);
    let mut m = live;
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        if out[k].is_finite() {
            accs[k].add_sample(out[k], second >> k & 1 != 0);
        } else {
            stats.nonfinite_samples += 1;
        }
        if let Some(l) = layers.as_deref_mut() {
            l[k].add(&aovs[k]);
        }
    }
}

/// [`trace_prepared_sample`] for the samples `samples[k]` of mask `live` of one pixel (in order
/// of `k`), one camera ray each (`rays[k]`) with its closest hit (`hit[k]` where bit `k` of
/// `hits` is set), shaded together ([`crate::render::integrator::Integrator::radiance_packet`]):
/// `acc` (and `layers`) gets exactly the sums `trace_prepared_sample` adds sample after sample.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn trace_pixel_packet(
    job: &RenderJob,
    setup: &ImageSetup,
    pixel: &PixelSetup,
    samples: &[PreparedSample; PACKET],
    rays: &[Ray; PACKET],
    (live, hits): (u32, u32),
    hit: &[Hit; PACKET],
    acc: &mut PixelSum,
    mut layers: Option<&mut AovSum>,
    stats: &mut RayStats,
) {
    // The halves of a stratified set's samples depend on their places alone (`acc` is touched
    // only by progressive samples, which never come here), so they are chosen before shading.
    debug_assert!(!setup.progressive);
    let mut second = 0u32;
    let mut samplers: [Sampler; PACKET] = std::array::from_fn(|k| {
        let s = samples[k];
        let r = pixel.rays(job, setup, s.index, s.at);
        if live >> k & 1 != 0 {
            let id = SampleId::Pixel { x: pixel.x, y: pixel.y, index: s.index };
            second |= u32::from(second_half(setup, id, r.film, acc)) << k;
        }
        r.sampler(0)
    });
    let mut aovs = [setup.miss; PACKET];
    for a in &mut aovs {
        // Summed layers are a denoiser's guides, as in `trace_rays`.
        a.guides = layers.is_some();
    }
    let mut out = [Color::ZERO; PACKET];
    job.integrator.radiance_packet(&job.scene, rays, live, hits, hit, &mut samplers, stats, &mut aovs, &mut out);
    let mut m = live;
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        if out[k].is_finite() {
            acc.add_sample(out[k], second >> k & 1 != 0);
        } else {
            stats.nonfinite_samples += 1;
        }
        if let Some(l) = layers.as_deref_mut() {
            l.add(&aovs[k]);
        }
    }
}

/// Which of the error estimate's two halves sample `id` (on the film at `film`) joins.
#[inline(always)]
fn second_half(setup: &ImageSetup, id: SampleId, film: DVec2, acc: &mut PixelSum) -> bool {
    // Which half of the error estimate's two the sample joins. Stratified sets: its stratum `s`
    // of the pixel's `spp` rows is column `s mod m` of band `s / m` of the set's m × n grid, and
    // the halves are the grid's checkerboard, `(s mod m + s / m)` odd or even, so both halves
    // cover every band and every column. (`s + s / m`, the same for an even `m`, put each column
    // wholly in one half for an odd `m`, as at 25, 49 or 512 spp: the halves were stripes of
    // the pixel, and the estimate 2.5–6× too high on path-cornell.) Sobol points (an error
    // target, a time budget): a pixel stopping at `n` samples (a power of two) has halves
    // [0, n/2) and [n/2, n), each a (0, 2)-net; so at each power of two the second half starts
    // again, the samples before it becoming the first. (The parity of the index's bits split
    // the pixel in two along y: the Sobol y's top bit is that parity.)
    match id {
        SampleId::Pixel { index, .. } if setup.progressive => {
            if index.is_power_of_two() {
                acc.restart_second_half();
            }
            index > 0
        }
        SampleId::Pixel { y, .. } if setup.strata.1 > 1 => {
            let s = ((film.y - f64::from(y)) * setup.strata.0) as u32;
            let band = s / setup.strata.1;
            (s - band * setup.strata.1 + band) & 1 == 1
        }
        _ => false,
    }
}

/// [`trace_sample`] with sample `id`'s camera rays `rays` built; `given`: its one camera ray
/// with its closest hit, found by the caller.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn trace_rays(
    job: &RenderJob,
    setup: &ImageSetup,
    id: SampleId,
    rays: CameraRays<'_>,
    given: Option<(&Ray, Option<&Hit>)>,
    acc: &mut PixelSum,
    mut layers: Option<&mut AovSum>,
    stats: &mut RayStats,
) -> u64 {
    let mut signature = 0u64;
    let second = second_half(setup, id, rays.film, acc);
    // The rays of the iterator, each built where the integrator reads it: taken from the
    // iterator's `(Ray, Sampler)`, the ray was copied in pieces that straddled its stores (a
    // store-forwarding stall on every camera ray).
    debug_assert!(given.is_none() || rays.count == 1, "a given camera hit is of a sample's only camera ray");
    for l in 0..rays.count {
        let mut sampler = rays.sampler(l);
        let mut first = setup.miss;
        // Summed layers are a denoiser's guides: the integrator looks through mirrors and glass.
        first.guides = layers.is_some();
        stats.camera_rays += 1;
        let c = match given {
            Some((ray, hit)) => job.integrator.radiance_from(&job.scene, ray, hit, &mut sampler, stats, &mut first),
            None => job.integrator.radiance(&job.scene, &rays.ray(l), &mut sampler, stats, &mut first),
        };
        if c.is_finite() {
            acc.add_sample(c, second);
        } else {
            stats.nonfinite_samples += 1;
        }
        if let Some(l) = layers.as_deref_mut() {
            l.add(&first);
        }
        signature = mix64(signature.rotate_left(1) ^ first.signature);
    }
    signature
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Under an error target or a time budget a pixel's first `2^k` lens points, for every `k`,
    /// put one point in each elementary interval of area `2^-k` (a (0, k, 2)-net): stratified on
    /// the lens whatever the pixel's final count. (The first `n` points of a stratified set of
    /// the cap, as before, are not: they are a random choice of its strata.)
    #[test]
    fn progressive_lens_points_stratify_every_power_of_two_prefix() {
        for pattern in [0u32, 1, 0x5bd1_e995, 0xdead_beef, 123_456_789] {
            let points: Vec<DVec2> = (0..1024).map(|j| progressive_lens(j, pattern)).collect();
            for k in 0..=10u32 {
                let n = 1usize << k;
                for a in 0..=k {
                    let (cols, rows) = (1u32 << a, 1u32 << (k - a));
                    let mut seen = vec![false; n];
                    for p in &points[..n] {
                        assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
                        let cell = (p.y * f64::from(rows)) as usize * cols as usize + (p.x * f64::from(cols)) as usize;
                        assert!(!seen[cell], "pattern {pattern}: {n} points, {cols}×{rows} cells: two in cell {cell}");
                        seen[cell] = true;
                    }
                }
            }
            // In another order than the film's Sobol points of the same pixel.
            assert!((0..64).any(|j| progressive_lens(j, pattern) != sobol_02(j, pattern)));
        }
    }
}
