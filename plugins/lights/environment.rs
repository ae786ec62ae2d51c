//! `environment`: the scene's surroundings as a light, infinitely far away all around: one
//! colour, or an equirectangular (latitude–longitude) image — OpenEXR (feature `exr`), Radiance
//! `.hdr`, PNG or JPEG — times `strength`, turned about the vertical axis by `rotation`.
//!
//! **What sees it.** Rays that leave the scene see it in place of the scene's `background`
//! (camera rays, mirrors, glass; [`raylab::Scene::escaped`]), in every integrator.
//!
//! **What it lights.** It is sampled like an area light. A sample's direction is drawn from a
//! piecewise-constant density over the image, each cell weighted by its luminance × sin θ (the
//! solid angle a cell of a latitude–longitude image covers): bright parts of the sky (the sun)
//! are found by light samples, dark ones cost almost nothing. A texel's luminance there is the
//! largest the (bilinear) lookup takes within half a texel of its centre, so a dim texel beside
//! the sun, which the lookup sees half lit, is sampled as often as it is bright. The grid of that
//! density has a cell per quarter texel (each at the brightest the lookup takes over it) when
//! `resolution` (the grid's most columns) allows twice the image's width; else it is the image's
//! own, or coarser (the height half the width), each cell the mean of the texels it holds; a small floor keeps every direction possible, so rays
//! sampled by a BSDF and light samples can always be weighed against each other (MIS). One
//! colour is sampled uniformly over the sphere (`phong`); `path` leaves it to its BSDF's rays
//! ([`LightSource::uniform`]), which follow a surface's response better. For an image, `path` takes `light_samples` samples per vertex
//! and weighs them against its BSDF's rays by the power heuristic, drawn from a second,
//! MIS-compensated density ([`LightSource::illuminate_mis`], Karlík et al. 2019): each cell's
//! excess over the cells' mean (over the sphere), so light samples go only where the sky is
//! brighter than its mean (the sun and its glow) and the BSDF's rays, which meet every
//! direction, take the smooth rest in full (on compare.py's image environment, 0.50× the MSE
//! at equal samples; nothing above the mean: the first density). `phong` takes `samples` (or
//! its `shadow_rays`) per shading point, stratified, and never probes it (adaptive soft shadows
//! probe an emitter's extreme points, which a sky has not).
//!
//! **Directions.** Up is +y. An image is seen as it is drawn: its centre column along −z (what a
//! camera on +z looking at the origin sees behind the scene), columns to the right of it toward
//! +x, its left and right edges along +z (u = ½ + atan2(x, −z)/2π); its top row straight up, its
//! bottom row straight down. `rotation` (degrees) turns the whole environment about +y,
//! counter-clockwise seen from above.
//!
//! **Units.** The values are radiance: a camera ray sees `strength × color × texel`; a white
//! diffuse object inside a uniform environment of radiance L shows L (the furnace).
//!
//! **Files.** Read through the scene's sandbox and size limits once per scene (the `image`
//! texture's decoder: the header checked before decoding, the decoded texels and the sampling
//! grid charged to the memory budget). PNG and JPEG are taken as sRGB, EXR and `.hdr` as
//! linear.

use crate::textures::image::{ColorSpace, Image};
use raylab::glam::{DVec2, DVec3};
use raylab::math::color::luminance;
use raylab::math::distribution::Piecewise2d;
use raylab::math::sampler::sin_cos_octant;
use raylab::param::error::{Result, SceneError};
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::param::value::Value;
use raylab::{Color, LightPdf, LightSample, LightSource, LoadContext, PluginInfo, Ray};
use std::f64::consts::{FRAC_2_PI, FRAC_PI_2, FRAC_PI_6, PI, TAU};
use std::sync::Arc;

/// The floor added to each cell's luminance in the sampling density, as a fraction of the mean
/// cell luminance: every direction keeps a density, so MIS can weigh any ray against the light's
/// samples, at a cost in variance of at most this fraction.
pub const DENSITY_FLOOR: f64 = 1e-3;

/// The `environment` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "environment",
    summary: "The scene's surroundings, infinitely far away: one colour or an equirectangular image (OpenEXR with `exr`, Radiance .hdr, PNG, JPEG), times strength, turned by rotation. Rays that leave the scene see it instead of the background; it lights the scene as a light sampled by its luminance (MIS in path).",
    params: &[
        ParamSpec::new(
            "color",
            ParamKind::Color,
            ParamDefault::Float(1.0),
            "radiance of the surroundings, linear RGB; with `file`, multiplies the image",
        ),
        ParamSpec::new(
            "file",
            ParamKind::Path,
            ParamDefault::Optional,
            "an equirectangular image of the surroundings (2:1; top row straight up, centre column along −z), relative to the scene file",
        ),
        ParamSpec::new("strength", ParamKind::Float, ParamDefault::Float(1.0), "multiplies the radiance, ≥ 0"),
        ParamSpec::new(
            "rotation",
            ParamKind::Float,
            ParamDefault::Float(0.0),
            "degrees the surroundings are turned about the up axis (+y), counter-clockwise seen from above",
        ),
        ParamSpec::new(
            "samples",
            ParamKind::Int,
            ParamDefault::Int(16),
            "phong's shadow rays toward it per shading point (its shadow_rays may override); path takes its light_samples, 1..65536",
        ),
        ParamSpec::new(
            "resolution",
            ParamKind::Int,
            ParamDefault::Int(1024),
            "most columns of the grid its samples are drawn from (rows: half as many; a cell per quarter texel when twice the image's width fits, else never finer than the image); coarser: less memory, more noise where the image has small bright parts, 1..65536",
        ),
    ],
};

/// Builds an environment light from its parameters.
pub fn build(p: &mut Params, ctx: &LoadContext) -> Result<Box<dyn LightSource>> {
    let color = p.color("color")?;
    let strength = p.non_negative("strength")?;
    let rotation = p.float("rotation")?.to_radians();
    let samples = p.int_in("samples", 1..=65536)? as u32;
    let resolution = p.int_in("resolution", 1..=65536)? as usize;
    let file = match p.node("file")? {
        Some(n) => match &n.value {
            Value::Str(s) => Some((s.clone(), n.loc.clone())),
            v => return Err(p.error_at("file", format_args!("expected a path (a string), found {}", v.type_name()))),
        },
        None => None,
    };
    let radiance = color * strength;
    let Some((file, loc)) = file else {
        return Ok(Box::new(Environment::constant(radiance, rotation, samples)));
    };
    let image = crate::textures::image::load(ctx, &file, &loc, ColorSpace::Auto).map_err(|e| e.context(p.what()))?;
    let (w, h) = image.size();
    let (gw, gh) = grid_size(w, h, resolution);
    // The sampling grid: each cell a weight, its cumulative sum and its density (three f64) and a
    // guide entry (a u32), per row and once more for the rows.
    // Two grids: the density by luminance and its MIS-compensated one.
    let grid_bytes = 2 * (gw as u64 * gh as u64 + gh as u64) * (3 * std::mem::size_of::<f64>() + std::mem::size_of::<u32>()) as u64;
    ctx.charge(grid_bytes, &format!("the sampling grids of the environment \"{file}\" (2 × {gw}×{gh})"), Some(&loc))
        .map_err(|e: SceneError| e.context(p.what()))?;
    Ok(Box::new(Environment::image(image, radiance, rotation, samples, resolution)))
}

/// The size of the sampling grid over a `w × h` image for `resolution` columns at most: a cell per
/// quarter of a texel (2w × 2h) when that fits, else never finer than the image, rows half the
/// columns (a 2:1 image's cells stay square).
fn grid_size(w: usize, h: usize, resolution: usize) -> (usize, usize) {
    if 2 * w <= resolution {
        return (2 * w, 2 * h);
    }
    (w.min(resolution).max(1), h.min(resolution.div_ceil(2)).max(1))
}

/// The largest luminance the bilinear lookup takes over the quarter of texel (`x`, `y`)'s
/// footprint (half a texel each way from its centre) toward its neighbour at (`dx`, `dy`) (each
/// ±1), of a `w × h` image of luminances `lum` wrapped across its sides and held at its top and
/// bottom rows. Bilinear is largest at a corner of the quarter: the texel, the midpoints toward
/// its 2 neighbours, the mean with its 3 neighbours at the corner. A density by texel values
/// alone would give a dim texel next to the sun the density of the sky while the lookup there
/// sees half the sun (a ratio of 150 on the bundled sky: fireflies, 5× Mitsuba's samples for
/// equal error); by this bound, the ratio of radiance to density stays below the mean's,
/// wherever a sample falls.
fn quarter_max(lum: &[f32], w: usize, h: usize, (x, y): (usize, usize), (dx, dy): (isize, isize)) -> f64 {
    let at = |dx: isize, dy: isize| {
        let (cx, cy) = ((x + w).wrapping_add_signed(dx) % w, y.saturating_add_signed(dy).min(h - 1));
        f64::from(lum[cy * w + cx])
    };
    let (c, side_x, side_y) = (at(0, 0), at(dx, 0), at(0, dy));
    c.max(0.5 * (c + side_x)).max(0.5 * (c + side_y)).max(0.25 * (c + side_x + side_y + at(dx, dy)))
}

/// The largest luminance the bilinear lookup takes over texel (`x`, `y`)'s whole footprint: the
/// most of its 4 quarters' ([`quarter_max`]).
fn footprint_max(lum: &[f32], w: usize, h: usize, x: usize, y: usize) -> f64 {
    [(-1, -1), (1, -1), (-1, 1), (1, 1)].into_iter().map(|d| quarter_max(lum, w, h, (x, y), d)).fold(0.0, f64::max)
}

/// The weights of the MIS-compensated density (Karlík et al. 2019, "MIS compensation: optimizing
/// sampling techniques in multiple importance sampling") over a `gw × gh` grid of cell luminances
/// `means` (as the density by luminance counts them): each cell's excess over their mean over
/// the sphere (weighted by sin θ, the cells' solid angles), `floor` added, times sin θ; `None`
/// when no cell exceeds the mean (one colour). Light samples weighed against a BSDF's rays by
/// MIS then go only where the sky is brighter than its mean (the sun, the glow around it); the
/// BSDF's rays, which follow the surface's response, take the smooth rest in full. On compare.py's
/// image environment, 0.50× the MSE at equal samples.
fn compensate(means: &[f64], gw: usize, gh: usize, floor: f64) -> Option<Vec<f64>> {
    let sin_theta: Vec<f64> = (0..gh).map(|y| ((y as f64 + 0.5) / gh as f64 * PI).sin()).collect();
    let (mut weighted, mut total) = (0.0, 0.0);
    for (row, s) in means.chunks_exact(gw).zip(&sin_theta) {
        weighted += s * row.iter().sum::<f64>();
        total += s * gw as f64;
    }
    let mean = weighted / total;
    if !(mean.is_finite() && means.iter().any(|&m| m > mean)) {
        return None;
    }
    Some(means.iter().enumerate().map(|(i, &m)| ((m - mean).max(0.0) + floor) * sin_theta[i / gw]).collect())
}

/// The density (per steradian) of directions drawn uniformly over the sphere.
const UNIFORM_DENSITY: f64 = 1.0 / (4.0 * PI);

/// An environment: radiance from every direction.
pub struct Environment {
    /// Radiance (or the image's multiplier).
    radiance: Color,
    /// The image and its sampling density; `None`: one colour, sampled uniformly.
    image: Option<(Arc<Image>, Piecewise2d)>,
    /// The image's density for samples weighed against BSDF rays by MIS
    /// ([`LightSource::illuminate_mis`]): its cells brighter than the mean only (MIS compensation);
    /// `None`: one colour, or no cell above the mean (the density above serves).
    compensated: Option<Piecewise2d>,
    /// cos and sin of the rotation about +y.
    rotation: (f64, f64),
    samples: u32,
}

impl std::fmt::Debug for Environment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Environment({}, {:?})", self.radiance, self.image.as_ref().map(|(i, _)| i.size()))
    }
}

impl Environment {
    /// Radiance `radiance` from every direction (`rotation` radians has no visible effect, but
    /// turns the sampling pattern).
    pub fn constant(radiance: Color, rotation: f64, samples: u32) -> Environment {
        Environment { radiance, image: None, compensated: None, rotation: (rotation.cos(), rotation.sin()), samples: samples.max(1) }
    }

    /// `image` (equirectangular) times `radiance`, turned by `rotation` radians about +y,
    /// sampled on a grid of at most `resolution` columns.
    pub fn image(image: Arc<Image>, radiance: Color, rotation: f64, samples: u32, resolution: usize) -> Environment {
        let (w, h) = image.size();
        let (gw, gh) = grid_size(w, h, resolution);
        let texels: Vec<f32> = (0..w * h).map(|i| luminance(image.texel_color(i % w, i / w) * radiance).max(0.0) as f32).collect();
        let means: Vec<f64> = if gw == 2 * w {
            // A cell per quarter texel, at the brightest the lookup takes over it: around the sun,
            // 2.25× the mass the lookup sees rather than 4× by whole texels (on compare.py's sky,
            // the variance of a floor's sun-lit light samples 0.6 → 0.37 of its mean²).
            (0..gw * gh)
                .map(|i| {
                    let (gx, gy) = (i % gw, i / gw);
                    let toward = |g: usize| if g.is_multiple_of(2) { -1 } else { 1 };
                    quarter_max(&texels, w, h, (gx / 2, gy / 2), (toward(gx), toward(gy)))
                })
                .collect()
        } else {
            // Each cell: the mean of the texels' weights whose centres fall in it.
            let mut sums = vec![0.0f64; gw * gh];
            let mut counts = vec![0u32; gw * gh];
            for y in 0..h {
                let gy = y * gh / h;
                for x in 0..w {
                    let gx = x * gw / w;
                    sums[gy * gw + gx] += footprint_max(&texels, w, h, x, y);
                    counts[gy * gw + gx] += 1;
                }
            }
            sums.iter().zip(&counts).map(|(s, &n)| if n > 0 { s / f64::from(n) } else { 0.0 }).collect()
        };
        let mean = means.iter().sum::<f64>() / means.len() as f64;
        let floor = if mean.is_finite() { DENSITY_FLOOR * mean } else { 0.0 };
        let weights: Vec<f64> = means
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let theta = ((i / gw) as f64 + 0.5) / gh as f64 * PI;
                (m + floor) * theta.sin()
            })
            .collect();
        let density = Piecewise2d::new(&weights, gw, gh);
        let compensated = compensate(&means, gw, gh, floor).map(|w| Piecewise2d::new(&w, gw, gh));
        Environment {
            radiance,
            image: Some((image, density)),
            compensated,
            rotation: (rotation.cos(), rotation.sin()),
            samples: samples.max(1),
        }
    }

    /// The image coordinates (u right, v down from the top row, both in [0, 1]) of world
    /// direction `dir` (unit), and sin θ (θ from straight up).
    #[inline]
    fn to_uv(&self, dir: DVec3) -> (DVec2, f64) {
        let (c, s) = self.rotation;
        // Turned back by the rotation: local = R_y(−angle) · world.
        let local = DVec3::new(c * dir.x - s * dir.z, dir.y, s * dir.x + c * dir.z);
        let sin_theta = (local.x * local.x + local.z * local.z).sqrt();
        let u = 0.5 + atan2(local.x, -local.z) / TAU;
        let v = atan2(sin_theta, local.y) / PI;
        (DVec2::new(u, v), sin_theta)
    }

    /// The world direction of image coordinates `uv` (as [`Environment::to_uv`]), and sin θ.
    #[inline]
    fn direction_of(&self, uv: DVec2) -> (DVec3, f64) {
        let (sin_phi, cos_phi) = sin_cos((uv.x - 0.5) * TAU);
        let (sin_theta, cos_theta) = sin_cos(uv.y * PI);
        let local = DVec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi);
        let (c, s) = self.rotation;
        (DVec3::new(c * local.x + s * local.z, local.y, -s * local.x + c * local.z), sin_theta)
    }

    /// Radiance arriving from direction `dir` (a ray leaving the scene along it sees this).
    #[inline]
    fn radiance(&self, dir: DVec3) -> Color {
        match &self.image {
            None => self.radiance,
            Some((image, _)) => self.radiance_at(image, self.to_uv(dir).0),
        }
    }

    /// The image's radiance at image coordinates `uv` (as [`Environment::to_uv`]).
    #[inline]
    fn radiance_at(&self, image: &Image, uv: DVec2) -> Color {
        // The texture lookup's v points up (row 0 at v = 1); wrapped across the sides, held at
        // the top and bottom rows, bilinear.
        image.bilinear_repeat_clamp(DVec2::new(uv.x, 1.0 - uv.y)) * self.radiance
    }

    /// The density (per steradian) with which [`LightSource::illuminate`] picks direction `dir`.
    #[inline]
    fn density(&self, dir: DVec3) -> f64 {
        match &self.image {
            None => UNIFORM_DENSITY,
            Some((_, density)) => {
                let (uv, sin_theta) = self.to_uv(dir);
                Self::density_at(density, uv, sin_theta)
            }
        }
    }

    /// The density (per steradian) with which [`LightSource::illuminate_mis`] picks direction
    /// `dir` ([`LightSource::environment_pdf`]'s).
    #[cfg(test)]
    fn mis_density(&self, dir: DVec3) -> f64 {
        match &self.image {
            None => UNIFORM_DENSITY,
            Some((_, density)) => {
                let (uv, sin_theta) = self.to_uv(dir);
                Self::density_at(self.compensated.as_ref().unwrap_or(density), uv, sin_theta)
            }
        }
    }

    /// The image's sampling density per steradian at image coordinates `uv`, where sin θ is `sin_theta`.
    #[inline]
    fn density_at(density: &Piecewise2d, uv: DVec2, sin_theta: f64) -> f64 {
        // dω = sin θ dθ dφ = 2π² sin θ du dv; straight up or down (a set of no measure, where the
        // map is singular) is never sampled.
        if sin_theta > 0.0 { density.pdf(uv) / (2.0 * PI * PI * sin_theta) } else { 0.0 }
    }

    /// A sample drawn with `u` and its density ([`LightSource::illuminate_pdf`]); with `facing`,
    /// an image's radiance is looked up only for directions on that normal's side (elsewhere
    /// zero: [`LightSource::illuminate_facing`]).
    #[inline]
    /// `mis`: from the compensated density ([`LightSource::illuminate_mis`]).
    fn draw(&self, u: DVec2, facing: Option<DVec3>, mis: bool) -> Option<(LightSample, LightPdf)> {
        let (sample, pdf) = match &self.image {
            None => {
                // Uniform over the sphere.
                let z = 1.0 - 2.0 * u.y;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (s, c) = (TAU * u.x).sin_cos();
                let (cr, sr) = self.rotation;
                let local = DVec3::new(r * c, z, r * s);
                let dir = DVec3::new(cr * local.x + sr * local.z, local.y, -sr * local.x + cr * local.z);
                (self.sample(dir, self.radiance, UNIFORM_DENSITY), UNIFORM_DENSITY)
            }
            Some((image, density)) => {
                let density = if mis { self.compensated.as_ref().unwrap_or(density) } else { density };
                // The radiance at the drawn texel's coordinates and the density it was drawn
                // with: no round trip through the direction.
                let (uv, pdf_uv) = density.sample(u);
                let (dir, sin_theta) = self.direction_of(uv);
                let pdf = pdf_uv / (2.0 * PI * PI * sin_theta);
                let sample = match facing {
                    Some(n) if !(dir.dot(n) > 0.0) => LightSample { dir, distance: f64::INFINITY, intensity: Color::ZERO },
                    _ => self.sample(dir, self.radiance_at(image, uv), pdf),
                };
                (sample, pdf)
            }
        };
        Some((sample, LightPdf::SolidAngle(pdf)))
    }

    /// The sample for direction `dir` with density `pdf`: the light's whole contribution as one
    /// sample's intensity (radiance ÷ π·pdf, in the lights' intensity convention), zero where the
    /// density is not a finite positive number.
    #[inline]
    fn sample(&self, dir: DVec3, radiance: Color, pdf: f64) -> LightSample {
        let intensity = if pdf > 0.0 && pdf.is_finite() { radiance / (PI * pdf) } else { Color::ZERO };
        LightSample { dir, distance: f64::INFINITY, intensity }
    }
}

// The turns between directions and image coordinates, at every path vertex (a light sample's
// direction, each escaping ray's coordinates), without library calls: `atan2`, `acos` and
// `sin_cos` were a fifth of an image environment's cost per sample. Within a few 10⁻¹⁶ of the
// library's values (tested), and deterministic (multiplications and additions only).

/// `atan(t)` for `|t| ≤ tan(π/12)`: `t · P(t²)`, `P` the polynomial of degree 8 nearest
/// `atan(√z)/√z` over `z ∈ [0, tan²(π/12)]` (a Chebyshev fit; within 2·10⁻¹⁷ of it, below the
/// rounding of its evaluation; the Taylor series needs 14 terms for as much), by Horner's rule.
#[inline(always)]
fn atan_small(t: f64) -> f64 {
    /// P's coefficients, the constant first.
    const C: [f64; 9] = [
        1.0,
        -0.333_333_333_333_298_8,
        0.199_999_999_987_140_44,
        -0.142_857_141_011_126_37,
        0.111_110_978_044_861_84,
        -0.090_903_683_657_601_28,
        0.076_793_230_488_841_93,
        -0.064_828_027_107_193_4,
        0.044_375_920_079_045_915,
    ];
    let z = t * t;
    let mut p = C[8];
    for &c in C[..8].iter().rev() {
        p = c + z * p;
    }
    t * p
}

/// `atan2(y, x)` (the angle of (x, y) from +x, in [−π, π], with the library's signs of zero and
/// π): the smaller over the larger of |x| and |y| turned by π/6 into `atan_small`'s range.
#[inline(always)]
fn atan2(y: f64, x: f64) -> f64 {
    /// tan(π/12) = 2 − √3, and √3.
    const TAN_PI_12: f64 = 0.267_949_192_431_122_7;
    const SQRT_3: f64 = 1.732_050_807_568_877_2;
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay > ax { (ax, ay) } else { (ay, ax) };
    let t = if hi > 0.0 { lo / hi } else { 0.0 };
    // atan t = π/6 + atan((√3·t − 1) / (t + √3)), the argument within ±tan(π/12) for t ≤ 1.
    let a = if t > TAN_PI_12 { FRAC_PI_6 + atan_small((t * SQRT_3 - 1.0) / (t + SQRT_3)) } else { atan_small(t) };
    let a = if ay > ax { FRAC_PI_2 - a } else { a };
    let a = if x.is_sign_negative() { PI - a } else { a };
    a.copysign(y)
}

/// `(sin x, cos x)` for `|x| ≤ π` (a little beyond is fine): `x` less its nearest multiple of
/// π/2 (π/2 in two parts: exact for these quadrants), then [`sin_cos_octant`].
#[inline(always)]
fn sin_cos(x: f64) -> (f64, f64) {
    /// π/2 to twice a double's precision: the nearest double, and the rest.
    const PI_2_HIGH: f64 = FRAC_PI_2;
    const PI_2_LOW: f64 = 6.123_233_995_736_766e-17;
    let k = (x * FRAC_2_PI + 0.5f64.copysign(x)) as i64;
    let kf = k as f64;
    let (s, c) = sin_cos_octant((x - kf * PI_2_HIGH) - kf * PI_2_LOW);
    match k & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

impl LightSource for Environment {
    fn illuminate(&self, p: DVec3, u: DVec2) -> Option<LightSample> {
        self.illuminate_pdf(p, u).map(|(sample, _)| sample)
    }

    fn illuminate_pdf(&self, _p: DVec3, u: DVec2) -> Option<(LightSample, LightPdf)> {
        self.draw(u, None, false)
    }

    /// The image is looked up only for directions on `n`'s side.
    fn illuminate_facing(&self, _p: DVec3, n: DVec3, u: DVec2) -> Option<(LightSample, LightPdf)> {
        self.draw(u, Some(n), false)
    }

    /// From the compensated density: the cells brighter than the mean only.
    fn illuminate_mis(&self, _p: DVec3, facing: Option<DVec3>, u: DVec2) -> Option<(LightSample, LightPdf)> {
        self.draw(u, facing, true)
    }

    fn pdf(&self, _p: DVec3, sample: &LightSample) -> LightPdf {
        LightPdf::SolidAngle(self.density(sample.dir))
    }

    fn intersect(&self, ray: &Ray, t_max: f64) -> Option<LightSample> {
        // Only a ray that leaves the scene (nothing closer than infinity) reaches it.
        if t_max.is_finite() {
            return None;
        }
        Some(match &self.image {
            None => self.sample(ray.dir, self.radiance, UNIFORM_DENSITY),
            Some((image, density)) => {
                // One turn into image coordinates serves both the radiance and the density.
                let (uv, sin_theta) = self.to_uv(ray.dir);
                self.sample(ray.dir, self.radiance_at(image, uv), Self::density_at(density, uv, sin_theta))
            }
        })
    }

    fn sample_count(&self) -> u32 {
        self.samples
    }

    fn is_area(&self) -> bool {
        true
    }

    fn environment(&self, dir: DVec3) -> Option<Color> {
        Some(self.radiance(dir))
    }

    fn uniform(&self) -> bool {
        self.image.is_none()
    }

    fn environment_pdf(&self, _origin: DVec3, dir: DVec3) -> Option<(Color, f64)> {
        Some(match &self.image {
            None => (self.radiance, UNIFORM_DENSITY),
            Some((image, density)) => {
                // One turn into image coordinates serves both; the density of the samples this
                // ray is weighed against ([`LightSource::illuminate_mis`]).
                let (uv, sin_theta) = self.to_uv(dir);
                (self.radiance_at(image, uv), Self::density_at(self.compensated.as_ref().unwrap_or(density), uv, sin_theta))
            }
        })
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod trig_tests {
    use super::{atan2, sin_cos};
    use std::f64::consts::PI;

    /// How far the turns may be from the library's values (a few units in the last place of π).
    const TOLERANCE: f64 = 1.5e-15;

    /// Uniform numbers in [0, 1) from a fixed seed.
    fn numbers(n: usize) -> impl Iterator<Item = f64> {
        let mut z = 0x1234_5678_u64;
        (0..n).map(move |_| {
            z = z.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (z >> 11) as f64 / (1u64 << 53) as f64
        })
    }

    #[test]
    fn atan2_is_the_librarys_within_a_few_ulp() {
        let v: Vec<f64> = numbers(400_000).collect();
        for p in v.chunks_exact(2) {
            // Directions of every size, along and near the axes too.
            let (y, x) = ((p[0] - 0.5) * 10f64.powi((p[1] * 8.0) as i32 - 4), (p[1] - 0.5) * 10f64.powi((p[0] * 8.0) as i32 - 4));
            for (y, x) in [(y, x), (x, y), (y, 1.0), (1.0, y), (-1.0, y), (y, -1.0), (y * 1e-12, x)] {
                let (a, b) = (atan2(y, x), y.atan2(x));
                assert!((a - b).abs() <= TOLERANCE.max(4.0 * f64::EPSILON * b.abs()), "atan2({y:e}, {x:e}) = {a:e}, library {b:e}");
            }
        }
        for (y, x) in
            [(0.0, 1.0), (-0.0, 1.0), (0.0, -1.0), (-0.0, -1.0), (0.0, 0.0), (-0.0, -0.0), (1.0, 0.0), (-1.0, 0.0), (1.0, 1.0), (1.0, -1.0)]
        {
            let (a, b) = (atan2(y, x), f64::atan2(y, x));
            assert!(
                a == b && a.is_sign_negative() == b.is_sign_negative() || (a - b).abs() <= TOLERANCE,
                "atan2({y}, {x}) = {a}, library {b}"
            );
        }
        // Small angles keep their relative precision (the poles of the image's rows).
        let tiny = 1e-200;
        assert!((atan2(tiny, 1.0) - tiny).abs() <= f64::EPSILON * tiny);
    }

    #[test]
    fn sin_cos_is_the_librarys_within_a_few_ulp() {
        for u in numbers(200_000).chain([0.0, 0.25, 0.5, 0.75, 1.0 - f64::EPSILON / 2.0, 1.0]) {
            for x in [(2.0 * u - 1.0) * PI, u * PI, u * 1e-9] {
                let ((s, c), (ls, lc)) = (sin_cos(x), x.sin_cos());
                assert!(
                    (s - ls).abs() <= TOLERANCE && (c - lc).abs() <= TOLERANCE,
                    "sin_cos({x:e}) = ({s:e}, {c:e}), library ({ls:e}, {lc:e})"
                );
                // Near zero, sin x keeps its relative precision.
                if x.abs() < 1e-3 {
                    assert!((s - ls).abs() <= 4.0 * f64::EPSILON * ls.abs(), "sin({x:e})");
                }
            }
        }
    }
}
