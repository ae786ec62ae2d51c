//! Denoising with Intel Open Image Denoise (OIDN), the field's standard, run as its
//! `oidnDenoise` tool on PFM files: the colour (linear HDR) guided by the albedo and normal
//! layers ([`crate::render::aov`]). raylab neither builds nor links OIDN; the tool is found at
//! run time (see [`find_tool`]), so the default build needs nothing of it.
//!
//! Denoise a whole image, never a tile: the filter looks at each pixel's neighbourhood, so
//! tiles denoised apart would not merge to the image denoised whole.

use crate::image::reference::{decode_pfm, encode_pfm};
use crate::render::film::Film;
use std::path::PathBuf;
use std::process::{Command, Stdio};

/// The environment variable naming the `oidnDenoise` executable.
pub const TOOL_VAR: &str = "RAYLAB_OIDN";

/// How to get the tool, for messages.
pub const INSTALL_HINT: &str = "install Intel Open Image Denoise's `oidnDenoise` (`pip install pyoidn` ships it) or name it in RAYLAB_OIDN";

/// The `oidnDenoise` executable: `$RAYLAB_OIDN` if set; else `oidnDenoise` on the `PATH`; else
/// the one in the `pyoidn` Python package (`pip install pyoidn`), asked of `python3`.
pub fn find_tool() -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os(TOOL_VAR) {
        let p = PathBuf::from(p);
        return if p.is_file() { Ok(p) } else { Err(format!("{TOOL_VAR} names {}, which is not a file", p.display())) };
    }
    if let Some(path) = std::env::var_os("PATH") {
        for dir in std::env::split_paths(&path) {
            let p = dir.join("oidnDenoise");
            if p.is_file() {
                return Ok(p);
            }
        }
    }
    let script = "import os, pyoidn; print(os.path.join(os.path.dirname(pyoidn.__file__), 'oidn', 'bin', 'oidnDenoise'))";
    if let Ok(out) = Command::new("python3").args(["-c", script]).stdin(Stdio::null()).stderr(Stdio::null()).output()
        && out.status.success()
    {
        let p = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
        if p.is_file() {
            return Ok(p);
        }
    }
    Err(format!("no denoiser found: {INSTALL_HINT}"))
}

/// `color` denoised by OIDN's `RT` filter (HDR), guided by `albedo` and `normal` when given
/// (films of the same size as `color`; the normal guide needs the albedo guide, as OIDN asks).
/// With `clean_guides`, OIDN is told the guides have no noise (its `cleanAux`: it then follows
/// their edges instead of filtering them as it does the colour); raylab's are, unless the
/// camera has an aperture: they are the first surface each camera ray meets, averaged over the
/// pixel's samples, so they vary only where a pixel's samples meet different surfaces, which is
/// anti-aliasing, not noise ([`guides_are_clean`]).
///
/// With `emitted` (the emission layer: the radiance camera rays met directly, which has no noise
/// but anti-aliasing), only `color − emitted` is filtered and `emitted` is added back: a lamp
/// seen directly, hundreds of times brighter than what it lights, keeps its edge instead of
/// bleeding into its surroundings (on `path-cornell`, the denoised 256-spp image's error by a
/// quarter less, `benches/error`).
pub fn denoise(
    color: &Film,
    albedo: Option<&Film>,
    normal: Option<&Film>,
    emitted: Option<&Film>,
    clean_guides: bool,
) -> Result<Film, String> {
    for (name, g) in [("albedo", albedo), ("normal", normal), ("emission", emitted)] {
        if let Some(g) = g
            && (g.width, g.height) != (color.width, color.height)
        {
            return Err(format!("the {name} layer is {}×{}, the image {}×{}", g.width, g.height, color.width, color.height));
        }
    }
    if normal.is_some() && albedo.is_none() {
        return Err("a normal guide needs an albedo guide too (Open Image Denoise's rule)".into());
    }
    let tool = find_tool()?;
    let dir = TempDir::new()?;
    let write = |name: &str, film: &Film| -> Result<PathBuf, String> {
        let p = dir.0.join(name);
        std::fs::write(&p, encode_pfm(film)).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        Ok(p)
    };
    let mut cmd = Command::new(&tool);
    let filtered = match emitted {
        Some(e) => {
            let pixels = color.pixels.iter().zip(&e.pixels).map(|(&c, &e)| (c - e).max(glam::Vec3::ZERO)).collect();
            write("color.pfm", &Film { width: color.width, height: color.height, pixels })?
        }
        None => write("color.pfm", color)?,
    };
    cmd.arg("--hdr").arg(filtered);
    if let Some(a) = albedo {
        cmd.arg("--alb").arg(write("albedo.pfm", a)?);
    }
    if let Some(n) = normal {
        cmd.arg("--nrm").arg(write("normal.pfm", n)?);
    }
    if clean_guides && albedo.is_some() {
        cmd.arg("--clean_aux");
    }
    let out_path = dir.0.join("out.pfm");
    cmd.arg("-o").arg(&out_path).stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::piped());
    let out = cmd.output().map_err(|e| format!("cannot run {}: {e}", tool.display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(format!("{} failed ({}): {}", tool.display(), out.status, err.trim()));
    }
    let bytes = std::fs::read(&out_path).map_err(|e| format!("{} wrote no image: {e}", tool.display()))?;
    let mut film = decode_pfm(&bytes).map_err(|e| format!("{}'s output: {e}", tool.display()))?;
    if (film.width, film.height) != (color.width, color.height) {
        return Err(format!(
            "{} returned a {}×{} image for a {}×{} one",
            tool.display(),
            film.width,
            film.height,
            color.width,
            color.height
        ));
    }
    if film.pixels.iter().any(|p| !p.is_finite()) {
        return Err(format!("{} returned non-finite pixels", tool.display()));
    }
    if let Some(e) = emitted {
        for (p, &e) in film.pixels.iter_mut().zip(&e.pixels) {
            *p += e;
        }
    }
    Ok(film)
}

/// A private folder for the denoiser's files, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Result<TempDir, String> {
        use std::sync::atomic::{AtomicU64, Ordering};
        static COUNT: AtomicU64 = AtomicU64::new(0);
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
        let name = format!("raylab-denoise-{}-{}-{nanos}", std::process::id(), COUNT.fetch_add(1, Ordering::Relaxed));
        let p = std::env::temp_dir().join(name);
        // `create_dir` fails if the name exists: the folder is ours alone.
        std::fs::create_dir(&p)
            .map_err(|e| format!("cannot create a folder for the denoiser in {}: {e}", std::env::temp_dir().display()))?;
        Ok(TempDir(p))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Whether `job`'s albedo and normal layers are free of noise (OIDN's `cleanAux`): always but
/// under depth of field, where a pixel's camera rays through distinct lens points meet distinct
/// surfaces at random (then OIDN filters the guides itself). Measured on `path-cornell` at 64²
/// (`benches/error/run.py`): the displayed RMSE of the image denoised at 256 spp falls from
/// 0.0142 (guides filtered as noisy) to 0.0118, at 1024 spp from 0.0101 to 0.0080.
pub fn guides_are_clean(job: &crate::render::job::RenderJob) -> bool {
    !(job.scene.camera.aperture > 0.0)
}

/// A finished render's `film` denoised whole, guided by the albedo and normal of its `layers`,
/// its emission left out of the filter (`clean_guides`: see [`denoise`] and
/// [`guides_are_clean`]).
pub fn denoise_guided(film: &Film, layers: Option<&crate::render::aov::AovLayers>, clean_guides: bool) -> Result<Film, String> {
    let layers = layers.ok_or("the render took no albedo and normal layers to guide the denoiser")?;
    let (width, height) = (film.width, film.height);
    let guide = |v: &Option<Vec<glam::Vec3>>| v.as_ref().map(|p| Film { width, height, pixels: p.clone() });
    denoise(film, guide(&layers.albedo).as_ref(), guide(&layers.normal).as_ref(), guide(&layers.emitted).as_ref(), clean_guides)
}

/// The fewest samples a sub-pixel takes when the denoiser works on a finer grid ([`grid`]).
/// Measured on `path-cornell` at 64² over six seeds (benches/error/RESULTS.md, 2026-11-28),
/// displayed RMSE of the denoised image: at 128 spp 0.0109 on the pixel grid, 0.0095 on 2 × 2
/// (32 a sub-pixel), 0.0089 on 4 × 4 (8), 0.0081 on 8 × 8 (2); at 32 spp 0.0166, 0.0149 (8),
/// 0.0137 on 4 × 4 (2); at 16 spp 0.0210, 0.0193 on 2 × 2 (4), 0.0220 on 4 × 4 (1). So at equal
/// samples the finest grid with 2 a sub-pixel wins; but the denoiser costs about three samples'
/// CPU per sub-pixel, and at equal CPU this count's grids win (4 × 4 at 160 spp reaches the
/// noisy 1024-spp error in 0.24× its time, 2 × 2 at ~220 in 0.26×, 8 × 8 at 128 not quite, in
/// 0.34×).
pub const MIN_GRID_SPP: u32 = 8;

/// The most sub-pixels a finer grid may have ([`grid`]): its sums take about 200 bytes each
/// while rendering (a 2²² grid, 2048², about 0.8 GB).
pub const MAX_GRID_PIXELS: u64 = 1 << 22;

/// The finest grid `render --denoise` renders and denoises on, as sub-pixels per pixel side
/// (1: the pixel grid). The denoiser then works on `k × k` sub-pixels of `spp / k²` samples each
/// (the same camera rays), and its result is averaged back over each pixel (the box filter the
/// pixels have). Open Image Denoise removes more noise from more pixels at fewer samples than
/// from fewer at more: on `path-cornell` at 64² the denoised image reaches the noisy 1024-spp
/// error from about 160 spp on a 4 × 4 grid, against ~410 on the pixel grid. `k` is the largest
/// of 4 and 2 that divides the samples evenly (`spp` a multiple of `k²`), leaves each sub-pixel
/// at least [`MIN_GRID_SPP`], and keeps the grid within [`MAX_GRID_PIXELS`]. Under an error target
/// the samples counted are those of a pixel's first possible stop ([`ErrorTarget::floor_spp`]:
/// a loose target that stops pixels at 16 samples stays on the pixel grid), under a time
/// budget the most a pixel takes; each pixel's `k × k` sub-pixels then stop together
/// ([`crate::render::job::RenderSettings::subpixels`]). Not under adaptive anti-aliasing.
///
/// [`ErrorTarget::floor_spp`]: crate::render::job::ErrorTarget::floor_spp
pub fn grid(settings: &crate::render::job::RenderSettings) -> u32 {
    use crate::render::job::Antialiasing;
    if !matches!(settings.aa, Antialiasing::Stratified) {
        return 1;
    }
    let pixels = u64::from(settings.width) * u64::from(settings.height);
    // The first stop is a power of two of min_spp: from there every tested count divides as it does.
    let first = settings.target.map_or(settings.spp, |t| t.floor_spp().min(settings.spp));
    [4u32, 2]
        .into_iter()
        .find(|&k| {
            settings.spp.is_multiple_of(k * k)
                && first.is_multiple_of(k * k)
                && first / (k * k) >= MIN_GRID_SPP
                && pixels * u64::from(k * k) <= MAX_GRID_PIXELS
        })
        .unwrap_or(1)
}

/// `settings` on a grid `k` times finer: `k ×` the width and height, `spp / k²` samples a
/// sub-pixel, the sub-pixels of each pixel deciding together under an error target or a time
/// budget (see [`grid`]).
pub fn fine_settings(settings: &crate::render::job::RenderSettings, k: u32) -> crate::render::job::RenderSettings {
    crate::render::job::RenderSettings {
        width: settings.width * k,
        height: settings.height * k,
        spp: settings.spp / (k * k),
        subpixels: k,
        ..*settings
    }
}

/// A map of samples per pixel of the frame (`width` pixels a row; under a time budget, the `spp`
/// layer of a render denoised on [`grid`] `k`, which holds each pixel's samples, all its
/// sub-pixels' together) as the map of its finer grid: each sub-pixel `1 / k²` of its pixel's.
pub fn fine_spp_map(map: &[u32], width: u32, k: u32) -> Result<Vec<u32>, String> {
    let (w, kk) = (width as usize, k * k);
    if let Some((i, m)) = map.iter().enumerate().find(|(_, m)| !m.is_multiple_of(kk)) {
        return Err(format!(
            "the map gives pixel ({}, {}) {m} samples, which its {k} × {k} sub-pixels cannot share evenly: it is not of a render denoised on that grid",
            i % w.max(1),
            i / w.max(1)
        ));
    }
    let fw = w * k as usize;
    let mut fine = Vec::new();
    fine.try_reserve_exact(map.len() * kk as usize).map_err(|_| "out of memory for the map of samples per pixel".to_string())?;
    fine.resize(map.len() * kk as usize, 0);
    for (i, f) in fine.iter_mut().enumerate() {
        let (x, y) = (i % fw / k as usize, i / fw / k as usize);
        *f = map[y * w + x] / kk;
    }
    Ok(fine)
}

/// A finished render on a grid `k` times finer than `settings` ([`fine_settings`]) denoised
/// there, whole, and brought to `settings`' pixels: the denoised image averaged over each
/// pixel's `k × k` sub-pixels, the sums, layers and error estimate those of all their samples
/// ([`crate::render::share::ShareSums::downsample`]). With `k` = 1, [`denoise_guided`] in place.
pub fn denoise_rendered(
    rendered: &mut crate::render::Rendered,
    settings: &crate::render::job::RenderSettings,
    k: u32,
    clean_guides: bool,
) -> Result<(), String> {
    let denoised = denoise_guided(&rendered.film, rendered.layers.as_ref(), clean_guides)?;
    if k == 1 {
        rendered.film = denoised;
        return Ok(());
    }
    let sums = rendered.sums.downsample(k, settings)?;
    rendered.layers = sums.aovs().map_err(|e| e.to_string())?;
    rendered.sums = sums;
    rendered.film = box_down(&denoised, k)?;
    Ok(())
}

/// `film` averaged over blocks of `k × k` pixels (its sides multiples of `k`; `k` = 1: `film`
/// as it is), the box filter a frame's pixels have over their sub-pixels.
pub fn box_down(film: &Film, k: u32) -> Result<Film, String> {
    if k == 1 {
        return Ok(film.clone());
    }
    if k == 0 || !(film.width.is_multiple_of(k) && film.height.is_multiple_of(k)) {
        return Err(format!("a {}×{} image is not made of {k} × {k} blocks", film.width, film.height));
    }
    let mut out = Film::new(film.width / k, film.height / k).map_err(|e| e.to_string())?;
    let (w, cw) = (film.width as usize, out.width as usize);
    let mut sums = vec![glam::DVec3::ZERO; out.pixels.len()];
    for (i, p) in film.pixels.iter().enumerate() {
        sums[(i / w) / k as usize * cw + (i % w) / k as usize] += p.as_dvec3();
    }
    let n = f64::from(k * k);
    for (o, s) in out.pixels.iter_mut().zip(sums) {
        *o = (s / n).as_vec3();
    }
    Ok(out)
}

/// An image's colour and the layers [`denoise`] reads.
#[derive(Clone, Debug)]
pub struct Layers {
    /// The noisy colour.
    pub color: Film,
    /// The albedo guide.
    pub albedo: Option<Film>,
    /// The normal guide.
    pub normal: Option<Film>,
    /// The radiance camera rays met directly, left out of the filter.
    pub emitted: Option<Film>,
}

/// Pixels a denoiser cannot take: a channel NaN, infinite or negative (what `raylab denoise`
/// counts and warns of before [`Layers::clear_unfilterable`] sets them to 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unfilterable {
    /// How many pixels have such a channel.
    pub pixels: usize,
    /// The first of them, row by row from the top left: (x, y), 0-based.
    pub first: (u32, u32),
}

impl Layers {
    /// Sets every channel of the colour and emission layers (radiance, ≥ 0) that is NaN,
    /// infinite or negative to 0, as Open Image Denoise would take it without a word (a NaN
    /// from another renderer, a negative lobe of a filter), so that raylab, not the tool, decides
    /// and can say so: returns, per layer that had any, its name and the pixels it had.
    pub fn clear_unfilterable(&mut self) -> Vec<(&'static str, Unfilterable)> {
        let mut found = Vec::new();
        for (name, film) in [("colour", Some(&mut self.color)), ("emission", self.emitted.as_mut())] {
            let Some(film) = film else { continue };
            let width = film.width.max(1) as usize;
            let mut bad: Option<Unfilterable> = None;
            for (i, p) in film.pixels.iter_mut().enumerate() {
                let ok = p.to_array().map(|c| c.is_finite() && c >= 0.0);
                if ok != [true; 3] {
                    *p = glam::Vec3::select(glam::BVec3::from(ok), *p, glam::Vec3::ZERO);
                    let b = bad.get_or_insert(Unfilterable { pixels: 0, first: ((i % width) as u32, (i / width) as u32) });
                    b.pixels += 1;
                }
            }
            found.extend(bad.map(|b| (name, b)));
        }
        found
    }
}

/// Whether the tool can be found (for tests that need it).
pub fn available() -> bool {
    find_tool().is_ok()
}

/// The films of `path`'s colour, albedo, normal and emission layers for [`denoise`] (an EXR
/// raylab wrote with `--aov albedo,normal,emission`; all but the colour are optional).
#[cfg(feature = "exr")]
pub fn read_exr_layers(path: &std::path::Path, bytes: &[u8]) -> Result<Layers, String> {
    use crate::image::tonemap::{Layer, read_layer};
    let at = |e: String| format!("{}: {e}", path.display());
    let color = read_layer(bytes, "exr", Layer::Color).map_err(at)?;
    let albedo = read_layer(bytes, "exr", Layer::Albedo).ok();
    let normal = read_layer(bytes, "exr", Layer::Normal).ok();
    let normal = if albedo.is_some() { normal } else { None };
    let emitted = read_layer(bytes, "exr", Layer::Emission).ok();
    Ok(Layers { color, albedo, normal, emitted })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A noisy grey image denoised comes closer to its mean (skipped with a message where the
    /// tool is missing; CI installs it).
    #[test]
    fn denoising_reduces_the_noise_of_a_flat_image() {
        if !available() {
            assert!(std::env::var_os("CI").is_none(), "CI must have the denoiser: {INSTALL_HINT}");
            eprintln!("SKIPPED: no oidnDenoise ({INSTALL_HINT})");
            return;
        }
        let (w, h) = (64, 48);
        let mut noisy = Film::new(w, h).unwrap();
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for p in &mut noisy.pixels {
            state = crate::math::sampler::mix64(state);
            let u = (state >> 40) as f32 / (1u64 << 24) as f32;
            *p = Vec3::splat(0.5 + (u - 0.5) * 0.6);
        }
        let albedo = Film { width: w, height: h, pixels: vec![Vec3::splat(0.5); (w * h) as usize] };
        let normal = Film { width: w, height: h, pixels: vec![Vec3::Z; (w * h) as usize] };
        let clean = denoise(&noisy, Some(&albedo), Some(&normal), None, true).unwrap();
        let rms = |f: &Film| (f.pixels.iter().map(|p| (p.x - 0.5).powi(2)).sum::<f32>() / f.pixels.len() as f32).sqrt();
        assert!(rms(&clean) < 0.5 * rms(&noisy), "noise {} → {}", rms(&noisy), rms(&clean));
    }

    /// A lamp seen directly: a square 200 times brighter than the noisy grey around it. Given as
    /// the emission layer it is left out of the filter and added back, so the grey next to it
    /// stays grey; filtered with the rest, it bleeds into its surroundings (OIDN's HDR filter
    /// cannot tell its edge from noise without a guide that shows it).
    #[test]
    fn the_emission_layer_keeps_a_lamps_edge() {
        if !available() {
            assert!(std::env::var_os("CI").is_none(), "CI must have the denoiser: {INSTALL_HINT}");
            eprintln!("SKIPPED: no oidnDenoise ({INSTALL_HINT})");
            return;
        }
        let (w, h) = (48, 48);
        let lamp = |x: u32, y: u32| (16..32).contains(&x) && (16..24).contains(&y);
        let mut emitted = Film::new(w, h).unwrap();
        let mut noisy = Film::new(w, h).unwrap();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for y in 0..h {
            for x in 0..w {
                state = crate::math::sampler::mix64(state);
                let u = (state >> 40) as f32 / (1u64 << 24) as f32;
                let e = if lamp(x, y) { Vec3::splat(100.0) } else { Vec3::ZERO };
                emitted.pixels[(y * w + x) as usize] = e;
                noisy.pixels[(y * w + x) as usize] = e + Vec3::splat(0.5 + (u - 0.5) * 0.6);
            }
        }
        let albedo = Film { width: w, height: h, pixels: vec![Vec3::splat(0.5); (w * h) as usize] };
        let normal = Film { width: w, height: h, pixels: vec![Vec3::Z; (w * h) as usize] };
        // The worst error of the grey around the lamp, within two pixels of its edge.
        let bleed = |f: &Film| {
            let mut worst = 0.0f32;
            for y in 14..26 {
                for x in 14..34 {
                    if !lamp(x, y) {
                        worst = worst.max((f.get(x, y).x - 0.5).abs());
                    }
                }
            }
            worst
        };
        let kept = denoise(&noisy, Some(&albedo), Some(&normal), Some(&emitted), true).unwrap();
        let blurred = denoise(&noisy, Some(&albedo), Some(&normal), None, true).unwrap();
        assert!(bleed(&kept) < 0.2, "next to the lamp, left out of the filter: off by {}", bleed(&kept));
        assert!(bleed(&kept) < 0.5 * bleed(&blurred), "bleeding {} left out, {} filtered", bleed(&kept), bleed(&blurred));
        assert!((16..32).all(|x| kept.get(x, 20).x > 100.0), "the lamp is added back whole");
    }

    /// The finer grid: 4 × 4 where the samples divide evenly and leave each sub-pixel
    /// `MIN_GRID_SPP`, else 2 × 2, else the pixels; under a target, by the samples of the first
    /// possible stop, under a time budget by the most a pixel takes; never under adaptive
    /// anti-aliasing, nor beyond `MAX_GRID_PIXELS`.
    #[test]
    fn the_grid_divides_the_samples_evenly() {
        use crate::render::job::{Antialiasing, ErrorTarget, RenderSettings};
        let at = |spp| grid(&RenderSettings::new(64, 64, spp));
        assert_eq!([at(1), at(16), at(24), at(32), at(48), at(64), at(100), at(128), at(144), at(1024)], [1, 1, 1, 2, 2, 2, 2, 4, 4, 4]);
        let fine = fine_settings(&RenderSettings::new(64, 48, 128), 4);
        assert_eq!((fine.width, fine.height, fine.spp, fine.subpixels), (256, 192, 8, 4));
        // Error targets: first stops at 128 (4 × 4), 64 and 32 (2 × 2), 16 (the pixels).
        let target = |error, min_spp, spp| {
            let mut s = RenderSettings::new(64, 64, spp);
            s.target = Some(ErrorTarget { error, min_spp });
            (s.target.unwrap().floor_spp(), grid(&s))
        };
        assert_eq!(target(0.01, 16, 4096), (128, 4));
        assert_eq!(target(0.025, 16, 4096), (64, 2));
        assert_eq!(target(0.05, 16, 4096), (32, 2));
        assert_eq!(target(0.2, 16, 4096), (16, 1));
        assert_eq!(target(0.01, 16, 64), (128, 2), "the cap is the first stop");
        assert_eq!(target(0.01, 12, 4096), (96, 2), "96 leaves 4 × 4 sub-pixels 6 each");
        let s = RenderSettings { time_budget: Some(std::time::Duration::from_secs(1)), ..RenderSettings::new(64, 64, 128) };
        assert_eq!(grid(&s), 4);
        let s = RenderSettings {
            aa: Antialiasing::Adaptive(crate::render::job::AdaptiveSettings::new(0.1, 2)),
            ..RenderSettings::new(64, 64, 128)
        };
        assert_eq!(grid(&s), 1);
        assert_eq!(grid(&RenderSettings::new(1024, 1024, 128)), 2, "4 × 4 would be 2²⁴ sub-pixels");
        assert_eq!(grid(&RenderSettings::new(4096, 4096, 128)), 1);
    }

    #[test]
    fn mismatched_guides_are_refused_before_running_anything() {
        let c = Film::new(4, 4).unwrap();
        let a = Film::new(2, 2).unwrap();
        assert!(denoise(&c, Some(&a), None, None, true).unwrap_err().contains("albedo layer is 2×2"));
        assert!(denoise(&c, None, None, Some(&a), true).unwrap_err().contains("emission layer is 2×2"));
        assert!(denoise(&c, None, Some(&c), None, true).unwrap_err().contains("needs an albedo guide"));
    }
}
