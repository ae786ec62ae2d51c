//! Parts of a frame (the whole image a render makes, `width × height` pixels: the one thing
//! "frame" means in raylab): a rectangle of pixels ([`Rect`]), the share of the frame's work one render
//! does ([`Share`]: pixel bounds and a sample pass), and that share's exact state
//! ([`ShareSums`]): what a partial file, a checkpoint and a merge hold.
//!
//! Shares never change what a sample computes (every sample is a pure function of its pixel or
//! lattice point, index and the seed) and the sums are exact ([`crate::render::accum`]), so any
//! set of disjoint shares that covers the frame merges to the bits of one whole render.

use crate::param::error::Num;
use crate::render::accum::{AovSum, PixelSum};
use crate::render::aov::AovLayers;
use crate::render::film::{Film, OutOfMemory, try_filled};
use crate::render::job::{Antialiasing, ErrorTarget, RenderSettings};
use glam::Vec3;
use serde::Serialize;

/// A rectangle of pixels, `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Rect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Rect {
    /// The whole of a `width × height` frame.
    pub fn frame(width: u32, height: u32) -> Rect {
        Rect { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Columns.
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Pixels.
    pub fn pixels(&self) -> u64 {
        u64::from(self.width()) * u64::from(self.height())
    }

    /// True when it holds no pixel.
    pub fn is_empty(&self) -> bool {
        self.pixels() == 0
    }

    /// Whether pixel (`x`, `y`) is inside.
    #[inline]
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    /// Whether `self` lies within `other`.
    pub fn within(&self, other: &Rect) -> bool {
        self.x0 >= other.x0 && self.y0 >= other.y0 && self.x1 <= other.x1 && self.y1 <= other.y1
    }

    /// The pixels both hold, if any.
    pub fn intersect(&self, o: &Rect) -> Option<Rect> {
        let r = Rect { x0: self.x0.max(o.x0), y0: self.y0.max(o.y0), x1: self.x1.min(o.x1), y1: self.y1.min(o.y1) };
        (r.x0 < r.x1 && r.y0 < r.y1).then_some(r)
    }

    /// The pixel at index `i` of the rectangle, row by row.
    #[inline]
    pub fn pixel(&self, i: usize) -> (u32, u32) {
        let w = self.width() as usize;
        (self.x0 + (i % w) as u32, self.y0 + (i / w) as u32)
    }

    /// The index of pixel (`x`, `y`) (inside) in row-by-row order.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        (y - self.y0) as usize * self.width() as usize + (x - self.x0) as usize
    }
}

/// The sides a block of [`Sampling::subpixels`] may have: the divisors of the render's tile
/// side ([`crate::render::job::TILE_SIZE`]), so that every tile holds whole blocks (a partial
/// image's attribute and `render --subpixels` are checked against them).
pub const SUBPIXEL_SIDES: [u32; 5] = [1, 2, 4, 8, 16];

/// The rule on [`SUBPIXEL_SIDES`], for messages: "K must divide 16, …: 1, 2, 4, 8 or 16".
pub fn subpixel_rule() -> String {
    let sides: Vec<String> = SUBPIXEL_SIDES.iter().map(u32::to_string).collect();
    let (last, rest) = sides.split_last().expect("sides");
    format!("K must divide {}, the side of the render's tiles: {} or {last}", crate::render::job::TILE_SIZE, rest.join(", "))
}

/// How many samples each pixel of a whole render has: `spp` stratified samples, or one adaptive
/// value (whose lattice samples are not counted).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Sampling {
    /// Samples per pixel (stratified).
    pub spp: u32,
    /// Adaptive anti-aliasing: one value per pixel.
    pub adaptive: bool,
    /// Pixels stop at this error (then `spp` is the most a pixel takes).
    pub target: Option<crate::render::job::ErrorTarget>,
    /// The pixels are sub-pixels in blocks of `subpixels × subpixels` that stop together
    /// ([`RenderSettings::subpixels`]; 1: each pixel alone).
    pub subpixels: u32,
}

impl Sampling {
    /// The sampling of `settings`.
    pub fn of(settings: &RenderSettings) -> Self {
        Sampling {
            spp: settings.spp.max(1),
            adaptive: matches!(settings.aa, Antialiasing::Adaptive(_)),
            target: settings.target,
            subpixels: settings.subpixels.max(1),
        }
    }

    /// In words, for messages: "4 spp", "adaptive anti-aliasing", "at most 64 spp to a relative
    /// error of 0.02 (at least 8)".
    pub fn describe(&self) -> String {
        match (self.adaptive, self.target) {
            (true, _) => "adaptive anti-aliasing".into(),
            (false, None) => format!("{} spp", self.spp),
            (false, Some(t)) if self.subpixels > 1 => format!(
                "at most {} spp a sub-pixel to a relative error of {} (at least {}) over each {k} × {k} block",
                self.spp,
                Num(t.error),
                t.min_spp,
                k = self.subpixels
            ),
            (false, Some(t)) => format!("at most {} spp to a relative error of {} (at least {})", self.spp, Num(t.error), t.min_spp),
        }
    }
}

/// The share of a frame's work one render does: the pixels in `bounds`, and of those, sample
/// pass `pass` of `passes`. Under stratified anti-aliasing a pass takes every pixel's samples
/// `pass, pass + passes, …`; under adaptive anti-aliasing, whose samples depend on each other, it
/// takes the pixels whose index `y · width + x` is `pass` modulo `passes` (spread over the whole
/// frame all the same).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Share {
    /// The pixels.
    pub bounds: Rect,
    /// This render's pass (0-based).
    pub pass: u32,
    /// How many passes share the samples (≥ 1).
    pub passes: u32,
}

impl Share {
    /// All of a `width × height` frame.
    pub fn whole(width: u32, height: u32) -> Share {
        Share { bounds: Rect::frame(width, height), pass: 0, passes: 1 }
    }

    /// How many samples of pixel (`x`, `y`) of a frame `width` pixels wide the share takes: its
    /// stratified sample indices, or 1 for an adaptive pixel it owns; 0 outside it.
    pub fn samples_of(&self, sampling: Sampling, width: u32, x: u32, y: u32) -> u32 {
        if !self.bounds.contains(x, y) {
            return 0;
        }
        if sampling.adaptive {
            let index = u64::from(y) * u64::from(width) + u64::from(x);
            u32::from(index % u64::from(self.passes.max(1)) == u64::from(self.pass))
        } else if self.pass >= sampling.spp {
            0
        } else {
            (sampling.spp - self.pass).div_ceil(self.passes.max(1))
        }
    }

    /// The stratified sample index of the share's `k`-th sample of a pixel.
    #[inline]
    pub fn sample_index(&self, k: u32) -> u32 {
        self.pass + k * self.passes.max(1)
    }

    /// A description: `pixels [x0, x1) × [y0, y1), pass K/N`.
    pub fn describe(&self) -> String {
        let b = self.bounds;
        let pass = if self.passes > 1 { format!(", sample pass {}/{}", self.pass, self.passes) } else { String::new() };
        format!("pixels [{}, {}) × [{}, {}){pass}", b.x0, b.x1, b.y0, b.y1)
    }
}

/// The exact state of a render of one share of a frame: per pixel of the share's bounds, the
/// sums of its samples so far (and of its layers, when asked for).
#[derive(Clone, Debug, PartialEq)]
pub struct ShareSums {
    /// The frame's width, pixels.
    pub width: u32,
    /// The frame's height, pixels.
    pub height: u32,
    /// How many samples a pixel has in the whole render.
    pub sampling: Sampling,
    /// The share.
    pub share: Share,
    /// Per pixel of `share.bounds`, row by row.
    pub pixels: Vec<PixelSum>,
    /// Per pixel, the layers' sums (when asked for).
    pub layers: Option<Vec<AovSum>>,
}

impl ShareSums {
    /// Empty sums for `share` of a frame rendered with `settings` (allocated fallibly).
    pub fn new(settings: &RenderSettings, share: Share, layers: bool) -> Result<Self, OutOfMemory> {
        let n = share.bounds.pixels() as usize;
        Ok(ShareSums {
            width: settings.width,
            height: settings.height,
            sampling: Sampling::of(settings),
            share,
            pixels: try_filled(n, PixelSum::default(), "per-pixel sums")?,
            layers: if layers { Some(try_filled(n, AovSum::default(), "per-pixel layer sums")?) } else { None },
        })
    }

    /// How many samples pixel `i` (of the bounds) lacks to complete its share.
    pub fn missing(&self, i: usize) -> u32 {
        let (x, y) = self.share.bounds.pixel(i);
        let p = &self.pixels[i];
        if self.sampling.target.is_some_and(|t| t.converged(&self.block_sums(x, y).unwrap_or(*p))) {
            return 0;
        }
        self.share.samples_of(self.sampling, self.width, x, y).saturating_sub(p.samples)
    }

    /// Under [`Sampling::subpixels`] `k` > 1, the merged sums of the `k × k` block of pixel
    /// (`x`, `y`), where the share holds all of it: what an error target tests.
    fn block_sums(&self, x: u32, y: u32) -> Option<PixelSum> {
        let (k, b) = (self.sampling.subpixels, self.share.bounds);
        if k <= 1 {
            return None;
        }
        let (x0, y0) = (x - x % k, y - y % k);
        if !(x0 >= b.x0 && y0 >= b.y0 && x0 + k <= b.x1 && y0 + k <= b.y1) {
            return None;
        }
        let mut m = PixelSum::default();
        for yy in y0..y0 + k {
            for xx in x0..x0 + k {
                m.merge(&self.pixels[b.index(xx, yy)]);
            }
        }
        Some(m)
    }

    /// How far the share is: (samples done, samples of the whole share, pixels still lacking
    /// some), for messages about a resumed or partial render.
    pub fn progress(&self) -> (u64, u64, u64) {
        let (mut done, mut total, mut left) = (0u64, 0u64, 0u64);
        for (i, p) in self.pixels.iter().enumerate() {
            let (x, y) = self.share.bounds.pixel(i);
            let want = self.share.samples_of(self.sampling, self.width, x, y);
            done += u64::from(p.samples.min(want));
            total += u64::from(want);
            left += u64::from(p.samples < want);
        }
        (done, total, left)
    }

    /// Whether every pixel has all the samples of its share.
    pub fn complete(&self) -> bool {
        (0..self.pixels.len()).all(|i| self.missing(i) == 0)
    }

    /// The image: the mean of each pixel's samples so far, black outside the bounds (or where
    /// none is done).
    pub fn film(&self) -> Result<Film, OutOfMemory> {
        self.film_rows(false)
    }

    /// [`Self::film`], rows in parallel on the current rayon pool. Not to be called while holding
    /// a lock that jobs of that pool may take: the waiting thread runs other jobs meanwhile.
    pub fn film_parallel(&self) -> Result<Film, OutOfMemory> {
        self.film_rows(true)
    }

    fn film_rows(&self, parallel: bool) -> Result<Film, OutOfMemory> {
        use rayon::prelude::*;
        let mut film = Film::new(self.width, self.height)?;
        let b = self.share.bounds;
        let (x0, x1) = (b.x0 as usize, b.x1 as usize);
        if x1 <= x0 {
            return Ok(film);
        }
        let fill = |(row, sums): (&mut [Vec3], &[PixelSum])| {
            for (out, p) in row[x0..x1].iter_mut().zip(sums) {
                *out = p.mean().as_vec3();
            }
        };
        let rows = (b.y0 as usize)..(b.y1 as usize);
        let (width, share_width) = (self.width as usize, x1 - x0);
        if parallel {
            film.pixels.par_chunks_mut(width).skip(rows.start).take(rows.len()).zip(self.pixels.par_chunks(share_width)).for_each(fill);
        } else {
            film.pixels.chunks_mut(width).skip(rows.start).take(rows.len()).zip(self.pixels.chunks(share_width)).for_each(fill);
        }
        Ok(film)
    }

    /// The depth, normal, albedo and emission layers over the whole frame, when summed.
    pub fn aovs(&self) -> Result<Option<AovLayers>, OutOfMemory> {
        let Some(sums) = &self.layers else { return Ok(None) };
        let n = self.width as usize * self.height as usize;
        let mut depth = try_filled(n, f32::INFINITY, "depth layer")?;
        let mut normal = try_filled(n, Vec3::ZERO, "normal layer")?;
        let mut albedo = try_filled(n, Vec3::ZERO, "albedo layer")?;
        let mut emitted = try_filled(n, Vec3::ZERO, "emission layer")?;
        for (i, l) in sums.iter().enumerate() {
            let (x, y) = self.share.bounds.pixel(i);
            let k = y as usize * self.width as usize + x as usize;
            (depth[k], normal[k], albedo[k]) = l.mean();
            emitted[k] = l.emitted_mean();
        }
        Ok(Some(AovLayers {
            depth: Some(depth),
            normal: Some(normal),
            albedo: Some(albedo),
            emitted: Some(emitted),
            ..AovLayers::default()
        }))
    }

    /// The error estimate of each pixel ([`PixelSum::std_error`]; NaN where there is none) and its
    /// sample count, over the whole frame (0 outside the share's bounds).
    pub fn error_layers(&self) -> Result<(Vec<f32>, Vec<f32>), OutOfMemory> {
        let n = self.width as usize * self.height as usize;
        let mut error = try_filled(n, 0.0f32, "error layer")?;
        let mut spp = try_filled(n, 0.0f32, "sample count layer")?;
        for (i, p) in self.pixels.iter().enumerate() {
            let (x, y) = self.share.bounds.pixel(i);
            let k = y as usize * self.width as usize + x as usize;
            error[k] = p.std_error().map_or(f32::NAN, |e| e as f32);
            spp[k] = p.samples as f32;
        }
        Ok((error, spp))
    }

    /// The sums of the frame `k` times coarser, rendered at `settings`: each of its pixels the
    /// merge of the `k × k` block of these pixels it covers, so its mean is the mean of all their
    /// samples (the box filter over the coarse pixel: with the same count in every sub-pixel,
    /// the mean of their means) and its layers and error estimate are those of all of them.
    /// These must be the whole of a frame of `k · settings.width × k · settings.height` pixels,
    /// in one pass, each pixel with `settings.spp / k²` stratified samples, as a render of
    /// `settings` on the finer grid gives ([`crate::image::denoise::grid`]).
    pub fn downsample(&self, k: u32, settings: &RenderSettings) -> Result<ShareSums, String> {
        let whole = self.share == Share::whole(self.width, self.height);
        let fits = k >= 1
            && settings.width.checked_mul(k) == Some(self.width)
            && settings.height.checked_mul(k) == Some(self.height)
            && settings.spp.is_multiple_of(k * k)
            && self.sampling == Sampling { spp: settings.spp / (k * k), subpixels: k, ..Sampling::of(settings) };
        if !whole || !fits {
            return Err(format!(
                "cannot downsample a {}×{} share ({}) by {k} to a {}×{} frame at {} spp",
                self.width,
                self.height,
                self.share.describe(),
                settings.width,
                settings.height,
                settings.spp
            ));
        }
        let share = Share::whole(settings.width, settings.height);
        let mut out = ShareSums::new(settings, share, self.layers.is_some()).map_err(|e| e.to_string())?;
        let (w, cw) = (self.width as usize, settings.width as usize);
        for (i, p) in self.pixels.iter().enumerate() {
            let c = (i / w) / k as usize * cw + (i % w) / k as usize;
            out.pixels[c].merge(p);
            if let (Some(fine), Some(coarse)) = (&self.layers, out.layers.as_mut()) {
                coarse[c].merge(&fine[i]);
            }
        }
        Ok(out)
    }

    /// The image's estimated error, from its pixels' samples; `None` when no pixel has two samples.
    pub fn error_estimate(&self) -> Option<ErrorEstimate> {
        let (mut pixels, mut variance, mut mean, mut samples) = (0u64, 0.0f64, 0.0f64, 0u64);
        for p in &self.pixels {
            samples += u64::from(p.samples);
            if let Some(v) = p.half_variance() {
                pixels += 1;
                variance += v;
                mean += p.mean_luminance();
            }
        }
        let mean_spp = samples as f64 / self.pixels.len().max(1) as f64;
        (pixels > 0).then(|| ErrorEstimate {
            relative_rmse: (variance / pixels as f64).sqrt() / (mean / pixels as f64).max(f64::MIN_POSITIVE),
            pixels,
            mean_spp,
            reads_high: mean_spp < ErrorEstimate::FEW_SPP && self.sampling.target.is_none(),
        })
    }

    /// The share of the image's estimated variance (the pixels' [`PixelSum::std_error`]²) held
    /// by pixels whose light comes in samples rarer than one per `first` samples
    /// ([`PixelSum::light_carriers`] below 1): under an error target whose first possible stop
    /// is at `first` samples ([`crate::render::job::ErrorTarget::floor_spp`]), pixels like them
    /// that stopped there most likely missed their bright samples and read quiet (caustics of a
    /// small bright light, glints), so the image's estimate reads low. 0 without variance.
    pub fn rare_light_share(&self, first: u32) -> f64 {
        let (mut rare, mut all) = (0.0f64, 0.0f64);
        for p in &self.pixels {
            let Some(e) = p.std_error().filter(|e| e.is_finite()) else { continue };
            all += e * e;
            if p.light_carriers(first).is_some_and(|c| c < 1.0) {
                rare += e * e;
            }
        }
        if all > 0.0 { rare / all } else { 0.0 }
    }

    /// How many pixels the image's estimated variance rests on: `(Σ vᵢ)² / Σ vᵢ²` over the
    /// pixels' squared standard errors `vᵢ` ([`PixelSum::std_error`]; Kish's effective count),
    /// the number of equally noisy pixels whose variance would be as concentrated. Each pixel's
    /// share of the image's estimate comes from its own few samples, so an estimate resting on
    /// `m` pixels is itself noisy, by about `1/√m`, and so is the true error of one image. 0
    /// without variance.
    pub fn effective_pixels(&self) -> f64 {
        let (mut sum, mut sq) = (0.0f64, 0.0f64);
        for p in &self.pixels {
            let Some(e) = p.std_error().filter(|e| e.is_finite()) else { continue };
            sum += e * e;
            sq += e * e * e * e;
        }
        if sq > 0.0 { sum * sum / sq } else { 0.0 }
    }

    /// Why the estimate of this image, rendered to `target`, may read low ([`LowReading`]).
    pub fn low_reading(&self, target: &ErrorTarget) -> LowReading {
        let first = target.floor_spp();
        LowReading { rare_share: self.rare_light_share(first), first, pixels: self.effective_pixels() }
    }
}

/// What says the estimate of an image rendered to an error target may read low: a pixel stops
/// when its own samples look quiet, so the pixels that stop are selected for estimates that
/// are too low. Measured by `benches/error/honesty.py` (2026-11-28, six seeds a target): the
/// estimate read 0.19–1.01× the true error on `environment` at every target from 0.05 to 0.006,
/// 0.59–0.97× on `pbr-spheres` from 0.2 to 0.0125, 0.84–1.13× on `path-cornell`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowReading {
    /// The share of the estimated variance in pixels lit by samples rarer than one per first
    /// possible stop ([`ShareSums::rare_light_share`]): caustics, glints, which pixels like them
    /// that stopped there most likely missed.
    pub rare_share: f64,
    /// The target's first possible stop ([`ErrorTarget::floor_spp`]).
    pub first: u32,
    /// How many pixels the estimated variance rests on ([`ShareSums::effective_pixels`]).
    pub pixels: f64,
}

impl LowReading {
    /// The effective pixels below which the estimate may read low
    /// ([`ShareSums::effective_pixels`]): where a few bright pixels hold the variance, each
    /// reads from few samples, the stop selects the quiet readings, and the estimate and the
    /// image's true error each vary by about `1/√m` from image to image. Chosen on
    /// `benches/error/honesty.py` (2026-11-28, six seeds a target): `environment` rests on 6–8
    /// pixels (the sun seen in and through the balls, its caustics) and read
    /// 0.19–1.01× the true error, with readings below 1/1.5 at every target from 0.05 to 0.006
    /// that the rare share missed from 0.0125 on (0.40–0.62×, shares 0–0.003); `pbr-spheres`
    /// rests on 13–24 and read 0.59–0.97×, below 1/1.5 at 0.1 and 0.05 with shares 0.006–0.008;
    /// `path-cornell` rests on 61–73 and read 0.84–1.13× (`1/√32` ≈ 0.18: an estimate on 32
    /// pixels stays within 1.5× at about two standard deviations).
    pub const FEW_PIXELS: f64 = 32.0;

    /// Whether the summary says the estimate may read low: rare paths hold at least
    /// [`ErrorTarget::RARE_SHARE`] of it, or it rests on fewer than
    /// [`LowReading::FEW_PIXELS`] pixels.
    pub fn flagged(&self) -> bool {
        self.rare_share >= ErrorTarget::RARE_SHARE || self.pixels < Self::FEW_PIXELS
    }
}

/// The estimated error of an image, from the spread of its pixels' samples
/// ([`PixelSum::std_error`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorEstimate {
    /// √(mean over pixels of the variance of the mean luminance, from the samples' two
    /// interleaved halves: [`PixelSum::half_variance`]) ÷ the mean luminance: the expected RMSE
    /// of the image's luminance against the converged image, relative to its brightness.
    pub relative_rmse: f64,
    /// Pixels with an estimate (rays in both halves).
    pub pixels: u64,
    /// Mean samples per pixel.
    pub mean_spp: f64,
    /// Whether the estimate may read high: with fewer than [`ErrorEstimate::FEW_SPP`] samples a
    /// pixel on average, each of a pixel's two halves is stratified much less well than the
    /// whole (a few of a stratified set's points, or of a Sobol net's), so the halves' spread
    /// over-reads the error of their mean. Not under an error target, whose stop selects quiet
    /// readings ([`LowReading`]; it never read above 1.26× there).
    pub reads_high: bool,
}

impl ErrorEstimate {
    /// The mean samples per pixel below which the estimate may read high
    /// ([`ErrorEstimate::reads_high`]). The halves' estimate of the variance of the mean of `n`
    /// samples is, in expectation, `V(n/2) − V(n)` (the second half of a stratified set fills
    /// what the first left, so the halves are negatively correlated); where stratification makes
    /// the error fall faster than `1/√n` it reads `√(V(n/2)/V(n) − 1)` times the true error
    /// (`benches/error/RESULTS.md`, 2026-11-28). Against the spread between 12 seeds
    /// (`benches/error/spread.py`): 1.52, 1.34 and 2.30× at 2, 4 and 8 spp on `path-cornell`,
    /// 1.13–1.36× from 16 spp; against each seed's true error (`honesty.py`'s references) 1.14–1.55×
    /// at 16 spp over eight seeds (two above 1.5), 0.98–1.35× at 32 over six. It was 16 until
    /// then.
    pub const FEW_SPP: f64 = 32.0;
}

/// One part of a frame to merge, named for messages.
pub struct Part {
    /// The file name (or another name for messages).
    pub name: String,
    /// Its state.
    pub sums: ShareSums,
    /// Its fingerprint.
    pub fingerprint: String,
}

/// Merges `parts` of one frame into the state of the whole frame: every part must have the same
/// fingerprint, frame and sampling, no two may share samples of a pixel, and together they must
/// give every pixel all its samples (unless `allow_partial`). The sums add exactly, so the result
/// has the bits of one whole render.
pub fn merge(parts: &[Part], allow_partial: bool) -> Result<ShareSums, String> {
    let Some(first) = parts.first() else { return Err("no parts to merge".into()) };
    let f = &first.sums;
    for p in &parts[1..] {
        let s = &p.sums;
        if p.fingerprint != first.fingerprint {
            return Err(format!(
                "{} is from another render (fingerprint {}) than {} ({}): a different scene, file it reads, or setting",
                p.name, p.fingerprint, first.name, first.fingerprint
            ));
        }
        if (s.width, s.height, s.sampling) != (f.width, f.height, f.sampling) {
            return Err(format!(
                "{} is of a {}×{} frame ({:?}), {} of a {}×{} frame ({:?})",
                p.name, s.width, s.height, s.sampling, first.name, f.width, f.height, f.sampling
            ));
        }
        if s.layers.is_some() != f.layers.is_some() {
            return Err(format!("{} and {} differ in having the depth, normal and albedo layers", p.name, first.name));
        }
    }
    for (i, a) in parts.iter().enumerate() {
        for b in &parts[i + 1..] {
            let Some(r) = a.sums.share.bounds.intersect(&b.sums.share.bounds) else { continue };
            let (sa, sb) = (a.sums.share, b.sums.share);
            if sa.passes != sb.passes {
                return Err(format!(
                    "{} (sample pass {}/{}) and {} (pass {}/{}) overlap in pixels [{}, {}) × [{}, {}) with different pass counts",
                    a.name, sa.pass, sa.passes, b.name, sb.pass, sb.passes, r.x0, r.x1, r.y0, r.y1
                ));
            }
            if sa.pass == sb.pass {
                return Err(format!(
                    "{} and {} overlap: both hold pixels [{}, {}) × [{}, {}) of sample pass {}/{}",
                    a.name, b.name, r.x0, r.x1, r.y0, r.y1, sa.pass, sa.passes
                ));
            }
        }
    }
    let mut whole = ShareSums {
        width: f.width,
        height: f.height,
        sampling: f.sampling,
        share: Share::whole(f.width, f.height),
        pixels: try_filled(f.width as usize * f.height as usize, PixelSum::default(), "merged image's sums").map_err(|e| e.to_string())?,
        layers: match f.layers {
            Some(_) => {
                Some(try_filled(f.width as usize * f.height as usize, AovSum::default(), "merged layers").map_err(|e| e.to_string())?)
            }
            None => None,
        },
    };
    for p in parts {
        let b = p.sums.share.bounds;
        for (i, px) in p.sums.pixels.iter().enumerate() {
            let (x, y) = b.pixel(i);
            let k = whole.share.bounds.index(x, y);
            whole.pixels[k].merge(px);
            if let (Some(dst), Some(src)) = (whole.layers.as_mut(), p.sums.layers.as_ref()) {
                dst[k].merge(&src[i]);
            }
        }
    }
    if !allow_partial {
        let mut hole: Option<Rect> = None;
        let mut count = 0u64;
        for i in 0..whole.pixels.len() {
            if whole.missing(i) > 0 {
                let (x, y) = whole.share.bounds.pixel(i);
                count += 1;
                let h = hole.get_or_insert(Rect { x0: x, y0: y, x1: x + 1, y1: y + 1 });
                *h = Rect { x0: h.x0.min(x), y0: h.y0.min(y), x1: h.x1.max(x + 1), y1: h.y1.max(y + 1) };
            }
        }
        if let Some(h) = hole {
            return Err(format!(
                "the parts leave {count} pixel(s) without all their samples, within [{}, {}) × [{}, {}): a tile or pass is missing or unfinished (--allow-partial merges anyway)",
                h.x0, h.x1, h.y0, h.y1
            ));
        }
    }
    Ok(whole)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::color::Color;
    use crate::render::aov::AovSample;

    /// The sub-pixel sides are the divisors of the tile side, as the rule in messages says.
    #[test]
    fn subpixel_sides_divide_the_tiles() {
        let divisors: Vec<u32> = (1..=crate::render::job::TILE_SIZE).filter(|k| crate::render::job::TILE_SIZE.is_multiple_of(*k)).collect();
        assert_eq!(divisors, SUBPIXEL_SIDES);
        assert_eq!(subpixel_rule(), "K must divide 16, the side of the render's tiles: 1, 2, 4, 8 or 16");
    }

    /// The pixels an image's estimated variance rests on: all `P` of them when they are equally
    /// noisy, one when a single pixel holds it, and the summary's "may read low" for few pixels
    /// even where no rare path is seen (which the rare share alone let through: `environment`
    /// rests on 6–8 pixels and read 0.40–0.62× at `E` = 0.0125 with shares 0–0.003).
    #[test]
    fn an_estimate_on_few_pixels_may_read_low() {
        let settings = RenderSettings::new(8, 8, 4);
        let image = |noisy: &dyn Fn(usize) -> bool| {
            let mut sums = ShareSums::new(&settings, Share::whole(8, 8), false).unwrap();
            for (i, p) in sums.pixels.iter_mut().enumerate() {
                for s in 0..4 {
                    let v = if noisy(i) { [0.2, 1.8, 0.6, 1.4][s] } else { 1.0 };
                    p.add_sample(Color::splat(v), s % 2 == 1);
                }
            }
            sums
        };
        let all = image(&|_| true);
        assert!((all.effective_pixels() - 64.0).abs() < 1e-9, "{}", all.effective_pixels());
        let one = image(&|i| i == 9);
        assert!((one.effective_pixels() - 1.0).abs() < 1e-9, "{}", one.effective_pixels());
        assert_eq!(image(&|_| false).effective_pixels(), 0.0);
        let target = ErrorTarget { error: 0.1, min_spp: 4 };
        let quiet = LowReading { rare_share: 0.0, first: 16, pixels: 64.0 };
        assert!(!quiet.flagged());
        assert!(LowReading { pixels: 7.0, ..quiet }.flagged(), "few pixels, no rare path");
        assert!(LowReading { rare_share: ErrorTarget::RARE_SHARE, ..quiet }.flagged());
        assert_eq!(one.low_reading(&target).pixels, one.effective_pixels());
        assert_eq!(one.low_reading(&target).first, target.floor_spp());
    }

    /// A 4 × 2 frame of 2 samples a pixel brought to 2 × 1 pixels of 8: each pixel holds its
    /// block's samples (colour sums, squares, halves, counts, layers) exactly, so it is complete,
    /// its mean is the mean of the block's means, and a frame that does not fit is refused.
    #[test]
    fn downsampling_merges_each_block_exactly() {
        let (fine, coarse) = (RenderSettings { subpixels: 2, ..RenderSettings::new(4, 2, 2) }, RenderSettings::new(2, 1, 8));
        let mut sums = ShareSums::new(&fine, Share::whole(4, 2), true).unwrap();
        for (i, (p, l)) in sums.pixels.iter_mut().zip(sums.layers.as_mut().unwrap()).enumerate() {
            for s in 0..2 {
                let v = (i * 2 + s) as f64 * 0.25;
                p.add_sample(Color::new(v, 2.0 * v, 0.5), s == 1);
                p.samples += 1;
                l.add(&AovSample { depth: v, albedo: Color::splat(0.5), emitted: Color::splat(v), ..AovSample::miss(Color::ZERO) });
            }
        }
        let down = sums.downsample(2, &coarse).unwrap();
        assert_eq!((down.width, down.height, down.pixels.len()), (2, 1, 2));
        assert!((0..2).all(|i| down.missing(i) == 0), "each pixel has its 8 samples");
        let mut left = PixelSum::default();
        for i in [0, 1, 4, 5] {
            left.merge(&sums.pixels[i]);
        }
        assert_eq!(down.pixels[0], left);
        let film = sums.film().unwrap();
        let mean = (film.pixels[0] + film.pixels[1] + film.pixels[4] + film.pixels[5]) / 4.0;
        assert!((down.film().unwrap().pixels[0] - mean).abs().max_element() < 1e-6);
        let layers = down.aovs().unwrap().unwrap();
        let fine_layers = sums.aovs().unwrap().unwrap();
        let e = fine_layers.emitted.as_ref().unwrap();
        assert!((layers.emitted.unwrap()[1] - (e[2] + e[3] + e[6] + e[7]) / 4.0).abs().max_element() < 1e-6);
        assert!(down.error_estimate().is_some());
        for wrong in [RenderSettings::new(2, 1, 4), RenderSettings::new(3, 1, 8), RenderSettings::new(2, 2, 8)] {
            assert!(sums.downsample(2, &wrong).is_err(), "{wrong:?}");
        }
        let mut part = sums.clone();
        part.share.bounds = Rect { x0: 0, y0: 0, x1: 2, y1: 2 };
        assert!(part.downsample(2, &coarse).unwrap_err().contains("cannot downsample"));
    }
}
