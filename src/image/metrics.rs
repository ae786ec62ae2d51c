//! Image error against a reference: RMSE, PSNR and SSIM, on the image as displayed.
//!
//! Both images are clamped to [0, 1] and encoded with the render's encoding (sRGB by default)
//! before comparing, but not quantised to 8 bits, so the figures describe what a viewer sees
//! without an 8-bit noise floor. SSIM is the structural similarity index of Wang, Bovik, Sheikh
//! and Simoncelli (2004): an 11 × 11 Gaussian window (σ = 1.5), `K1 = 0.01`, `K2 = 0.03`, dynamic
//! range 1, population covariances, averaged over the positions where the window fits and over
//! the three channels. That is scikit-image's `structural_similarity(..., gaussian_weights=True,
//! sigma=1.5, use_sample_covariance=False, data_range=1, channel_axis=-1)`, which the tests
//! reproduce. 1 − SSIM (DSSIM) is the perceptual error the sweep reports.

use crate::math::color::Encoding;
use crate::render::film::Film;
use serde::Serialize;

/// Errors of one image against a reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ImageError {
    /// Root-mean-square difference of displayed values (0..1), over all pixels and channels.
    pub rmse: f64,
    /// Peak signal-to-noise ratio, dB: `20·log10(1 / rmse)` (infinite for identical images).
    pub psnr: f64,
    /// Mean structural similarity, ≤ 1 (1 = identical).
    pub ssim: f64,
}

impl ImageError {
    /// The perceptual error `1 − SSIM` (0 = identical).
    pub fn dssim(&self) -> f64 {
        1.0 - self.ssim
    }
}

/// Compares `image` with `reference` (same size), both displayed with `encoding`.
pub fn compare(image: &Film, reference: &Film, encoding: Encoding) -> Result<ImageError, String> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(format!("the image is {}×{} but the reference is {}×{}", image.width, image.height, reference.width, reference.height));
    }
    let a = displayed(image, encoding);
    let b = displayed(reference, encoding);
    let rmse = rmse(&a, &b);
    Ok(ImageError { rmse, psnr: psnr(rmse), ssim: ssim(&a, &b, image.width as usize, image.height as usize) })
}

/// The film's displayed values (clamped, encoded), as three planes R, G, B.
pub fn displayed(film: &Film, encoding: Encoding) -> [Vec<f32>; 3] {
    let plane = |c: usize| film.pixels.iter().map(|p| encoding.display(p[c])).collect();
    [plane(0), plane(1), plane(2)]
}

/// Root-mean-square difference over all planes.
pub fn rmse(a: &[Vec<f32>; 3], b: &[Vec<f32>; 3]) -> f64 {
    let mut sum = 0.0;
    let mut n = 0usize;
    for (pa, pb) in a.iter().zip(b) {
        sum += pa.iter().zip(pb).map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2)).sum::<f64>();
        n += pa.len();
    }
    if n == 0 { 0.0 } else { (sum / n as f64).sqrt() }
}

/// PSNR in dB for a peak of 1: `20·log10(1 / rmse)`; infinite when `rmse` is 0.
pub fn psnr(rmse: f64) -> f64 {
    if rmse > 0.0 { -20.0 * rmse.log10() } else { f64::INFINITY }
}

/// Gaussian window radius (11 × 11 window) and standard deviation, pixels.
const SSIM_RADIUS: usize = 5;
const SSIM_SIGMA: f64 = 1.5;
const SSIM_C1: f64 = 0.01 * 0.01;
const SSIM_C2: f64 = 0.03 * 0.03;

/// Mean SSIM of two `width × height` images given as planes, averaged over the planes. Images
/// smaller than the window are compared with one window covering the whole image (uniform
/// weights).
pub fn ssim(a: &[Vec<f32>; 3], b: &[Vec<f32>; 3], width: usize, height: usize) -> f64 {
    let planes: Vec<f64> = a.iter().zip(b).map(|(pa, pb)| ssim_plane(pa, pb, width, height)).collect();
    planes.iter().sum::<f64>() / planes.len() as f64
}

fn ssim_index(mx: f64, my: f64, vx: f64, vy: f64, cxy: f64) -> f64 {
    ((2.0 * mx * my + SSIM_C1) * (2.0 * cxy + SSIM_C2)) / ((mx * mx + my * my + SSIM_C1) * (vx + vy + SSIM_C2))
}

fn ssim_plane(a: &[f32], b: &[f32], w: usize, h: usize) -> f64 {
    let n = w * h;
    if n == 0 {
        return 1.0;
    }
    let (a, b): (Vec<f64>, Vec<f64>) = (a.iter().map(|&v| f64::from(v)).collect(), b.iter().map(|&v| f64::from(v)).collect());
    let d = 2 * SSIM_RADIUS + 1;
    if w < d || h < d {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / n as f64;
        let (mx, my) = (mean(&a), mean(&b));
        let (mut vx, mut vy, mut cxy) = (0.0, 0.0, 0.0);
        for (x, y) in a.iter().zip(&b) {
            vx += (x - mx) * (x - mx);
            vy += (y - my) * (y - my);
            cxy += (x - mx) * (y - my);
        }
        return ssim_index(mx, my, vx / n as f64, vy / n as f64, cxy / n as f64);
    }
    let kernel: Vec<f64> = {
        let k: Vec<f64> = (0..d).map(|i| (-0.5 * ((i as f64 - SSIM_RADIUS as f64) / SSIM_SIGMA).powi(2)).exp()).collect();
        let s: f64 = k.iter().sum();
        k.into_iter().map(|v| v / s).collect()
    };
    // Filtered moments at the positions where the window fits: ow × oh outputs.
    let (ow, oh) = (w - 2 * SSIM_RADIUS, h - 2 * SSIM_RADIUS);
    let blur = |f: &dyn Fn(usize) -> f64| -> Vec<f64> {
        let mut rows = vec![0.0; ow * h];
        for y in 0..h {
            for x in 0..ow {
                rows[y * ow + x] = (0..d).map(|k| kernel[k] * f(y * w + x + k)).sum();
            }
        }
        let mut out = vec![0.0; ow * oh];
        for y in 0..oh {
            for x in 0..ow {
                out[y * ow + x] = (0..d).map(|k| kernel[k] * rows[(y + k) * ow + x]).sum();
            }
        }
        out
    };
    let mx = blur(&|i| a[i]);
    let my = blur(&|i| b[i]);
    let mxx = blur(&|i| a[i] * a[i]);
    let myy = blur(&|i| b[i] * b[i]);
    let mxy = blur(&|i| a[i] * b[i]);
    let mut sum = 0.0;
    for i in 0..ow * oh {
        sum += ssim_index(mx[i], my[i], mxx[i] - mx[i] * mx[i], myy[i] - my[i] * my[i], mxy[i] - mx[i] * my[i]);
    }
    sum / (ow * oh) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic test pattern: a gradient with a disc and noise, values in [0, 1].
    fn pattern(w: usize, h: usize, seed: u64) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let disc = if (x - 12.0).powi(2) + (y - 9.0).powi(2) < 30.0 { 0.5 } else { 0.0 };
                let noise = (crate::math::sampler::mix64(i as u64 ^ seed) >> 40) as f64 / (1u64 << 24) as f64;
                ((x / w as f64) * 0.4 + disc + 0.1 * noise) as f32
            })
            .collect()
    }

    #[test]
    fn identical_images_have_no_error() {
        let p = pattern(24, 20, 1);
        let a = [p.clone(), p.clone(), p.clone()];
        assert_eq!(rmse(&a, &a), 0.0);
        assert_eq!(psnr(0.0), f64::INFINITY);
        assert!((ssim(&a, &a, 24, 20) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn rmse_and_psnr_of_a_constant_offset() {
        let a = [vec![0.25f32; 12], vec![0.25; 12], vec![0.25; 12]];
        let b = [vec![0.5f32; 12], vec![0.5; 12], vec![0.5; 12]];
        assert!((rmse(&a, &b) - 0.25).abs() < 1e-12);
        assert!((psnr(0.1) - 20.0).abs() < 1e-12);
    }

    /// The value scikit-image 0.26 gives for the same two patterns (rebuilt in Python from the same
    /// hash, rounded to f32): `structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
    /// use_sample_covariance=False, data_range=1.0)`.
    #[test]
    fn ssim_matches_scikit_image() {
        let (w, h) = (24, 20);
        let a = pattern(w, h, 1);
        let b = pattern(w, h, 2);
        let s = ssim(&[a.clone(), a.clone(), a.clone()], &[b.clone(), b.clone(), b.clone()], w, h);
        assert!((s - SKIMAGE_SSIM_1_2).abs() < 1e-9, "ssim {s}, scikit-image {SKIMAGE_SSIM_1_2}");
    }

    const SKIMAGE_SSIM_1_2: f64 = 0.952_888_755_448_580_2;

    #[test]
    fn ssim_falls_as_noise_grows_and_is_symmetric() {
        let (w, h) = (32, 32);
        let a = pattern(w, h, 7);
        let noisy = |amp: f32| -> Vec<f32> { a.iter().zip(pattern(w, h, 9)).map(|(v, n)| v + amp * (n - 0.5)).collect() };
        let planes = |v: &Vec<f32>| [v.clone(), v.clone(), v.clone()];
        let s1 = ssim(&planes(&a), &planes(&noisy(0.05)), w, h);
        let s2 = ssim(&planes(&a), &planes(&noisy(0.2)), w, h);
        assert!(1.0 > s1 && s1 > s2, "{s1} {s2}");
        assert!((ssim(&planes(&noisy(0.2)), &planes(&a), w, h) - s2).abs() < 1e-12);
    }
}
