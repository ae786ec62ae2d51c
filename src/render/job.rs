//! A render job: the scene, its integrator, and the image and sampling settings.

use crate::math::color::Encoding;
use crate::param::error::Num;
use crate::render::accum::PixelSum;
use crate::render::integrator::Integrator;
use crate::scene::Scene;

/// How pixels are sampled.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "mode", rename_all = "lowercase")]
pub enum Antialiasing {
    /// `spp` samples per pixel: the centre for 1, stratified (correlated multi-jitter) for more.
    Stratified,
    /// Recursive corner subdivision where neighbouring samples disagree
    /// ([`crate::render::adaptive`]).
    Adaptive(AdaptiveSettings),
}

/// The settings of adaptive anti-aliasing ([`crate::render::adaptive`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct AdaptiveSettings {
    /// Contrast threshold, in displayed units (clamped, encoded, 0..1): a pixel's square splits
    /// when its corners differ by more than this in some channel; a square of side `s` pixels
    /// when they differ by more than `threshold / s^1.5`.
    pub threshold: f64,
    /// Most subdivision levels per pixel (0 = the four corners only).
    pub max_depth: u32,
    /// Where exactly two sides of a square cross an edge, locate the crossings by bisection
    /// along the sides and split the square along the line between them, instead of
    /// subdividing.
    pub edges: bool,
    /// Also split where the corners' signatures differ
    /// ([`crate::render::aov::AovSample::signature`]: by default the first object hit).
    pub signature: bool,
    /// Stratified samples added inside each finest cell whose corners still disagree.
    pub cell_samples: u32,
    /// Levels above the pixel tested first (0 = none): blocks of `2^coarse` pixels whose
    /// corners agree are interpolated from those four rays; others split down to the pixel.
    pub coarse: u32,
}

impl AdaptiveSettings {
    /// `threshold` and `max_depth` with the other settings at their defaults (edges on,
    /// signatures off, no cell samples).
    pub fn new(threshold: f64, max_depth: u32) -> Self {
        AdaptiveSettings { threshold, max_depth, edges: true, signature: false, cell_samples: 0, coarse: 0 }
    }
}

/// Most adaptive subdivision levels (a 256 × 256 sub-grid per pixel).
pub const MAX_ADAPTIVE_DEPTH: u32 = 8;

/// Most coarse levels of adaptive anti-aliasing (blocks of 8 × 8 pixels).
pub const MAX_ADAPTIVE_COARSE: u32 = 3;

/// Most stratified samples in one unresolved cell of the adaptive lattice.
pub const MAX_CELL_SAMPLES: u32 = 64;

/// Adaptive sampling to a noise threshold. A pixel's error is the estimated standard error of
/// its mean luminance over the square root of that mean ([`PixelSum::sqrt_relative_error`],
/// Cycles' measure): for a pixel of luminance 1, its relative error; a darker pixel, whose noise
/// shows less once encoded for display and weighs less in the image's RMSE, is allowed more
/// relative error (`1 / √mean` times more), so that the dark corners do not take the samples.
/// It is tested at `min_spp` samples and each doubling of them (`min_spp`, `2·min_spp`,
/// `4·min_spp`, …), and a pixel stops at the first test where its error is at most `error`
/// times `√(n / min_spp)` for its `n` samples: at `min_spp`, `error` itself, and `√2` more per
/// doubling. So a pixel's samples grow in proportion to its noise (the per-sample deviation),
/// not with its square as under a fixed threshold: the allocation that gives an image the least
/// squared error for the samples spent (a fixed threshold gives every pixel the same error,
/// which in total is no better than uniform sampling; only the pixels with no noise at all
/// save). A pixel's per-sample deviation is taken to be at least [`ErrorTarget::FLOOR`]: a pixel
/// whose first samples all missed a rare bright path (a caustic, a glint, the sun seen through a
/// bounce) looks quieter than it is, and stopping on that look made the image's estimated error
/// run low (0.4–0.6× the true error on `pbr-spheres` and `environment`), so no pixel stops before
/// the count a pixel of that deviation would reach ([`ErrorTarget::floor_spp`], which grows as
/// `1 / error`). Where a pixel stops depends on its own samples alone: the image is the same for
/// any thread count, tile split or resume.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ErrorTarget {
    /// Error ([`PixelSum::sqrt_relative_error`]) a pixel must reach at its first test (> 0).
    pub error: f64,
    /// Samples a pixel takes before its error is first tested (≥ 2).
    pub min_spp: u32,
}

impl ErrorTarget {
    /// Mean luminance (linear radiance) below which a pixel's error is taken against this
    /// instead of its own mean: the noise of pixels this dark is absolute, or they would never
    /// stop.
    pub const DARK: f64 = 1e-2;

    /// The least per-sample deviation of a pixel's √-relative error (its standard error times
    /// `√n`) a pixel is taken to have, however alike its samples. Chosen on `benches/error`
    /// (three seeds): 0.25 keeps the estimate within 0.8–1.0× the true error on `path-cornell`
    /// and `pbr-spheres` at every target, where without it `pbr-spheres` fell to 0.4×, and costs
    /// no efficiency at equal error (0.5 costs some on `pbr-spheres`).
    pub const FLOOR: f64 = 0.25;

    /// The share of an image's estimated variance in pixels lit by samples rarer than one per
    /// first possible stop ([`crate::render::share::ShareSums::rare_light_share`] at
    /// [`ErrorTarget::floor_spp`]) from which the summary says the estimate may read low: pixels
    /// like those that stopped there most likely missed their bright samples (a caustic of a small
    /// bright light), and no statistic of their own samples shows what they never saw. Chosen on
    /// `benches/error/honesty.py` (three seeds a target, 2026-11-28, with the path's stratified
    /// numbers): on `environment` 0.043–0.145 at `E` ≥ 0.05 and 0.012–0.024 at `E` = 0.025, where
    /// the estimate read 0.46–0.69× the true error (the sun's caustics through the glass and off
    /// the mirror); 0.000–0.002 at 0.0125 (0.82×); `pbr-spheres` 0.008–0.033 where it read
    /// 0.70–0.84×, 0 from 0.025 on (0.83–0.85×); `path-cornell` ≤ 0.005 (0.93–1.04×), `quality` 0.
    /// (It was 0.03 until the stratified numbers moved `environment` at 0.025 to 0.61×, unflagged.)
    /// With six seeds a target it missed readings below 1/1.5 (`environment` from 0.0125 on,
    /// `pbr-spheres` at 0.1): [`crate::render::share::LowReading::FEW_PIXELS`] flags those.
    pub const RARE_SHARE: f64 = 0.01;

    /// The largest error a target may ask for: a relative RMSE of 1, 100 % (a pixel of luminance
    /// 1 whose mean may be off by as much as itself; its first possible stop is `min_spp`). A
    /// looser one is a typo, or a fixed sample count meant (`spp`).
    pub const MAX: f64 = 1.0;

    /// The error `p` must reach to stop at its `n` samples: `error · √(n / min_spp)`.
    #[inline]
    pub fn allowed(&self, n: u32) -> f64 {
        self.error * (f64::from(n) / f64::from(self.min_spp)).sqrt()
    }

    /// Whether `p`'s error, at least [`ErrorTarget::FLOOR`] `/ √n` for its `n` samples, is within
    /// what its sample count allows ([`ErrorTarget::allowed`]), whether or not that count is a
    /// tested one.
    #[inline]
    pub fn met(&self, p: &PixelSum) -> bool {
        p.sqrt_relative_error(Self::DARK)
            .is_some_and(|e| e.max(Self::FLOOR / f64::from(p.samples.max(1)).sqrt()) <= self.allowed(p.samples))
    }

    /// The fewest samples a pixel takes under this target, however alike its samples: the first
    /// tested count `n` (`min_spp` times a power of two) from `FLOOR · √min_spp / error` on,
    /// where `FLOOR / √n` is within `error · √(n / min_spp)`.
    pub fn floor_spp(&self) -> u32 {
        let mut n = self.min_spp.max(1);
        while Self::FLOOR / f64::from(n).sqrt() > self.allowed(n) && n <= u32::MAX / 2 {
            n *= 2;
        }
        n
    }

    /// The samples each of a block's `kk` sub-pixels takes next when they have `n` each and
    /// their merged sums did not meet the target ([`RenderSettings::subpixels`]): the next count
    /// the target tests (`min_spp · 2^j`, in the coarse pixel's samples) above `kk · n` that the
    /// sub-pixels can share evenly, over `kk` (`u32::MAX` beyond every count).
    pub fn next_block_test(&self, n: u32, kk: u32) -> u32 {
        let (now, kk) = (u64::from(n) * u64::from(kk), u64::from(kk.max(1)));
        let mut c = u64::from(self.min_spp.max(1));
        while c <= now || !c.is_multiple_of(kk) {
            if c > u64::from(u32::MAX) * kk {
                return u32::MAX;
            }
            c *= 2;
        }
        u32::try_from(c / kk).unwrap_or(u32::MAX)
    }

    /// Whether `p` is done: it has a tested sample count and its error there meets the target.
    #[inline]
    pub fn converged(&self, p: &PixelSum) -> bool {
        let n = p.samples;
        n >= self.min_spp && n.is_multiple_of(self.min_spp) && (n / self.min_spp).is_power_of_two() && self.met(p)
    }
}

impl PartialEq for ErrorTarget {
    fn eq(&self, o: &Self) -> bool {
        self.error.to_bits() == o.error.to_bits() && self.min_spp == o.min_spp
    }
}

impl Eq for ErrorTarget {}

impl std::hash::Hash for ErrorTarget {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        self.error.to_bits().hash(h);
        self.min_spp.hash(h);
    }
}

/// Image and sampling settings of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width, pixels (≥ 1).
    pub width: u32,
    /// Image height, pixels (≥ 1).
    pub height: u32,
    /// Samples per pixel (≥ 1) for stratified anti-aliasing. One sample goes through the pixel
    /// centre; more are stratified. Unused by adaptive anti-aliasing.
    pub spp: u32,
    /// Random seed: same seed, same image.
    pub seed: u64,
    /// How 8-bit output encodes linear values (adaptive anti-aliasing compares encoded values).
    pub encoding: Encoding,
    /// Anti-aliasing scheme.
    pub aa: Antialiasing,
    /// Rays through distinct lens points per image sample (≥ 1), stratified over the lens; only
    /// used when the camera has an aperture.
    pub lens_samples: u32,
    /// Stop each pixel at this error (stratified only); `spp` is then the most a pixel takes.
    pub target: Option<ErrorTarget>,
    /// Stop the render after this much tracing (stratified only): the image refines in passes
    /// that double each pixel's samples (`spp` is the most a pixel takes), and where the time
    /// runs out each pixel keeps the samples it has. The samples each pixel reached (the `spp`
    /// layer) repeat the render bit for bit ([`crate::render::RenderOptions::spp_map`]).
    pub time_budget: Option<std::time::Duration>,
    /// The frame's pixels are the sub-pixels of a frame `subpixels` times coarser (≥ 1), in
    /// blocks of `subpixels × subpixels` (`render --denoise`'s finer grid,
    /// [`crate::image::denoise::grid`]): an error target decides per block, on the merged sums
    /// of its sub-pixels (the coarse pixel's samples, its counts and `min_spp` in the coarse
    /// pixel's units), and a time budget stops between rows of blocks, so all the sub-pixels of a
    /// pixel always have the same samples. 1: every pixel decides alone.
    pub subpixels: u32,
}

impl RenderSettings {
    /// Settings with stratified sampling at `spp`, seed 0, sRGB output and one lens sample.
    pub fn new(width: u32, height: u32, spp: u32) -> Self {
        RenderSettings {
            width,
            height,
            spp,
            seed: 0,
            encoding: Encoding::Srgb,
            aa: Antialiasing::Stratified,
            lens_samples: 1,
            target: None,
            time_budget: None,
            subpixels: 1,
        }
    }

    /// Whether a pixel may stop after any power of two of its samples (an error target or a time
    /// budget): its positions are then Sobol (0,2) points, whose every such prefix is
    /// stratified, instead of one stratified set of `spp`.
    #[inline]
    pub fn progressive(&self) -> bool {
        self.spp > 1 && (self.target.is_some() || self.time_budget.is_some())
    }

    /// A short description: `16 spp` or `adaptive (threshold 0.05, depth 3)`, plus lens samples.
    pub fn describe_sampling(&self) -> String {
        let aa = match self.aa {
            Antialiasing::Stratified => {
                let spp = match self.target {
                    None if self.time_budget.is_some() => format!("≤ {} spp", self.spp),
                    None => format!("{} spp", self.spp),
                    Some(t) => format!("to error {} ({}..{} spp)", Num(t.error), t.floor_spp().min(self.spp), self.spp),
                };
                match self.time_budget {
                    Some(b) => format!("{spp} within {} s", b.as_secs_f64()),
                    None => spp,
                }
            }
            Antialiasing::Adaptive(a) => {
                let mut d = format!("adaptive AA (threshold {}, depth {}", a.threshold, a.max_depth);
                if !a.edges {
                    d += ", no edges";
                }
                if a.signature {
                    d += ", signatures";
                }
                if a.cell_samples > 0 {
                    d += &format!(", {} cell samples", a.cell_samples);
                }
                if a.coarse > 0 {
                    d += &format!(", coarse {}", a.coarse);
                }
                d + ")"
            }
        };
        if self.lens_samples > 1 { format!("{aa}, {} lens samples", self.lens_samples) } else { aa }
    }
}

/// A scene ready to render: the scene, its integrator and its settings.
pub struct RenderJob {
    /// The scene.
    pub scene: Scene,
    /// The integrator.
    pub integrator: Box<dyn Integrator>,
    /// The integrator's type name.
    pub integrator_name: String,
    /// The integrator's parameters as the scene and the overrides gave them (absent ones took
    /// their defaults).
    pub integrator_params: crate::param::value::Table,
    /// Image and sampling settings.
    pub settings: RenderSettings,
    /// What loading ignored or approximated, to show the user (see [`crate::load::context::LoadContext::warn`]).
    pub warnings: Vec<crate::param::error::SceneError>,
    /// The fingerprint of the scene, the files it read and the resolved settings off their
    /// defaults ([`crate::param::fingerprint`]): parts of a frame merge, and a checkpoint
    /// resumes, only under the same one.
    pub fingerprint: String,
    /// The files the scene made raylab read (meshes, textures, glTF buffers, MTL libraries), as
    /// resolved: a command writing a file checks it is none of them.
    pub inputs: Vec<std::path::PathBuf>,
    /// The work budget: the most rays a render of this job may trace (`--max-rays`;
    /// `u64::MAX` for none), enforced by the render loop ([`crate::render::budget`]). Not part
    /// of the image: a render within it gives the same bits whatever it is.
    pub max_rays: u64,
}

/// Edge of the square tiles the image is split into, pixels.
pub const TILE_SIZE: u32 = 16;

/// Edge of the tiles under adaptive anti-aliasing, pixels: the lattice points on a tile's border
/// are traced by both tiles it separates, `2 / ADAPTIVE_TILE_SIZE` more rays per pixel in flat
/// regions (3 % here, 13 % with 16-pixel tiles).
pub const ADAPTIVE_TILE_SIZE: u32 = 64;
