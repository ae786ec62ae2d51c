//! A render job: the scene, its integrator, and the image and sampling settings.

use crate::math::color::Encoding;
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
    /// ([`crate::render::aov::Layers::signature`]: by default the first object hit).
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
}

impl RenderSettings {
    /// Settings with stratified sampling at `spp`, seed 0, sRGB output and one lens sample.
    pub fn new(width: u32, height: u32, spp: u32) -> Self {
        RenderSettings { width, height, spp, seed: 0, encoding: Encoding::Srgb, aa: Antialiasing::Stratified, lens_samples: 1 }
    }

    /// A short description: `16 spp` or `adaptive (threshold 0.05, depth 3)`, plus lens samples.
    pub fn describe_sampling(&self) -> String {
        let aa = match self.aa {
            Antialiasing::Stratified => format!("{} spp", self.spp),
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
    /// The fingerprint of the scene, the files it read and the resolved settings
    /// ([`crate::param::fingerprint`]): parts of a frame merge, and a checkpoint resumes, only
    /// under the same one.
    pub fingerprint: String,
}

/// Edge of the square tiles the image is split into, pixels.
pub const TILE_SIZE: u32 = 16;

/// Edge of the tiles under adaptive anti-aliasing, pixels: the lattice points on a tile's border
/// are traced by both tiles it separates, `2 / ADAPTIVE_TILE_SIZE` more rays per pixel in flat
/// regions (3 % here, 13 % with 16-pixel tiles).
pub const ADAPTIVE_TILE_SIZE: u32 = 64;
