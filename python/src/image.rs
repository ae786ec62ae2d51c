//! `raylab.Rendered`: a render's image, layers and counters; partial images and their merge;
//! image error against a reference.

use crate::runtime_error;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict};
use raylab::math::color::Encoding;
use raylab::render::RenderJob;
use raylab::render::aov::{Aov, AovLayers};
use raylab::render::film::Film;
use raylab::render::share::{ErrorEstimate, ShareSums};
use raylab::render::stats::RayStats;
use std::path::PathBuf;

/// What a partial image records besides its sums: the render's fingerprint and sampling.
#[derive(Clone)]
struct PartInfo {
    fingerprint: String,
    sampling: String,
}

/// A finished (or cancelled) render: the linear image, the layers asked for, the counters.
#[pyclass(frozen, module = "raylab._raylab")]
pub struct Rendered {
    film: Film,
    layers: Option<AovLayers>,
    /// The layers asked for (the render computes all three when any is asked for).
    aov: Vec<String>,
    stats: Option<RayStats>,
    seconds: f64,
    encoding: Encoding,
    complete: bool,
    /// The exact sums, for a part of a frame (a tile, crop or pass), to merge or save.
    part: Option<(ShareSums, PartInfo)>,
    /// The per-pixel standard error and samples per pixel, when the error layer was asked for.
    error: Option<(Vec<f32>, Vec<f32>)>,
    /// The image's estimated relative RMSE and mean samples per pixel, as the CLI's summary.
    estimate: Option<ErrorEstimate>,
    /// Under an error target: why the estimate may read low (`ShareSums::low_reading`: the share
    /// of the estimated variance in pixels whose light came from samples rarer than the first
    /// stop, and how many pixels it rests on), as the CLI's summary.
    low: Option<raylab::render::share::LowReading>,
}

impl Rendered {
    pub(crate) fn new(r: raylab::render::Rendered, job: &RenderJob, aov: Vec<String>, is_part: bool) -> Result<Rendered, String> {
        let info = PartInfo { fingerprint: job.fingerprint.clone(), sampling: job.settings.describe_sampling() };
        let error = if aov.iter().any(|s| Aov::parse(s) == Some(Aov::Error)) {
            Some(r.sums.error_layers().map_err(|e| e.to_string())?)
        } else {
            None
        };
        let estimate = r.sums.error_estimate();
        let low = job.settings.target.map(|t| r.sums.low_reading(&t));
        Ok(Rendered {
            film: r.film,
            layers: r.layers,
            aov,
            stats: Some(r.stats),
            seconds: r.elapsed.as_secs_f64(),
            encoding: job.settings.encoding,
            complete: r.complete,
            part: is_part.then_some((r.sums, info)),
            error,
            estimate,
            low,
        })
    }

    /// The layers the caller asked for, as the CLI's `write` keeps them.
    fn chosen_layers(&self) -> Option<AovLayers> {
        let asked = |l: Aov| self.aov.iter().any(|s| Aov::parse(s) == Some(l));
        self.layers.as_ref().map(|l| AovLayers {
            depth: l.depth.clone().filter(|_| asked(Aov::Depth)),
            normal: l.normal.clone().filter(|_| asked(Aov::Normal)),
            albedo: l.albedo.clone().filter(|_| asked(Aov::Albedo)),
            emitted: l.emitted.clone().filter(|_| asked(Aov::Emission)),
            ..AovLayers::default()
        })
    }
}

/// `values` as a bytearray of native-endian `f32` (NumPy's `float32` reads it in place).
fn f32_bytes<'py>(py: Python<'py>, n: usize, values: impl Iterator<Item = f32>) -> PyResult<Bound<'py, PyByteArray>> {
    PyByteArray::new_with(py, n * 4, |buf| {
        for (chunk, v) in buf.chunks_exact_mut(4).zip(values) {
            chunk.copy_from_slice(&v.to_ne_bytes());
        }
        Ok(())
    })
}

#[pymethods]
impl Rendered {
    /// Width, pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.film.width
    }

    /// Height, pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.film.height
    }

    /// False when the render was cancelled before every pixel had its samples.
    #[getter]
    fn complete(&self) -> bool {
        self.complete
    }

    /// The 8-bit encoding of the scene (for PNG and the error metrics).
    #[getter]
    fn encoding(&self) -> &'static str {
        self.encoding.name()
    }

    /// Whether this is a part of a frame (a tile, crop or sample pass) to merge.
    #[getter]
    fn is_part(&self) -> bool {
        self.part.is_some()
    }

    /// The linear RGB image, row by row from the top-left, as `height × width × 3` native-endian
    /// `f32` (the numbers of the CLI's EXR).
    fn rgb_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyByteArray>> {
        f32_bytes(py, self.film.pixels.len() * 3, self.film.pixels.iter().flat_map(|p| p.to_array()))
    }

    /// A layer asked for (`depth`: `height × width` values; `normal`, `albedo`, `emission`: `× 3`) as
    /// native-endian `f32`, and its channel count; None when it was not asked for.
    fn layer_bytes<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Option<(Bound<'py, PyByteArray>, usize)>> {
        let Some(aov) = Aov::parse(name) else {
            return Err(PyValueError::new_err(format!("expected depth, normal, albedo, emission, error or spp, found \"{name}\"")));
        };
        if aov == Aov::Error {
            // `error` (also `variance`): each pixel's standard error of its mean luminance (NaN
            // below two rays); `spp`: its samples. The CLI's EXR channels of the same names.
            return self
                .error
                .as_ref()
                .map(|(error, spp)| {
                    let v = if name == "spp" { spp } else { error };
                    f32_bytes(py, v.len(), v.iter().copied()).map(|b| (b, 1))
                })
                .transpose();
        }
        let Some(layers) = self.chosen_layers() else { return Ok(None) };
        Ok(match aov {
            Aov::Depth => layers.depth.map(|d| f32_bytes(py, d.len(), d.iter().copied()).map(|b| (b, 1))).transpose()?,
            Aov::Normal => {
                layers.normal.map(|v| f32_bytes(py, v.len() * 3, v.iter().flat_map(|p| p.to_array())).map(|b| (b, 3))).transpose()?
            }
            Aov::Albedo => {
                layers.albedo.map(|v| f32_bytes(py, v.len() * 3, v.iter().flat_map(|p| p.to_array())).map(|b| (b, 3))).transpose()?
            }
            Aov::Emission => {
                layers.emitted.map(|v| f32_bytes(py, v.len() * 3, v.iter().flat_map(|p| p.to_array())).map(|b| (b, 3))).transpose()?
            }
            Aov::Error => None,
        })
    }

    /// The image's estimated relative RMSE of luminance against the converged image, and the
    /// mean samples per pixel (the CLI's `estimated error` line); None below two samples a pixel.
    fn estimated_error(&self) -> Option<(f64, f64)> {
        self.estimate.map(|e| (e.relative_rmse, e.mean_spp))
    }

    /// Whether the estimate may read high: fewer than `ErrorEstimate::FEW_SPP` samples a pixel on
    /// average without an error target (the CLI's "may read high"); None without an estimate.
    fn estimate_reads_high(&self) -> Option<bool> {
        self.estimate.map(|e| e.reads_high)
    }

    /// Under an error target, when the estimate may read low (the CLI's "may read low":
    /// `LowReading::flagged`), the share of the estimated variance held by pixels lit by samples
    /// rarer than the target's first stop (flagged from `ErrorTarget::RARE_SHARE`, or below it
    /// when the estimate rests on fewer than `LowReading::FEW_PIXELS` pixels). None otherwise.
    fn estimate_reads_low(&self) -> Option<f64> {
        self.low.filter(|l| l.flagged()).map(|l| l.rare_share)
    }

    /// The image as PNG bytes: clamped and encoded as the CLI's PNG (the scene's encoding).
    fn png<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let rgb = raylab::image::output::try_rgb8(&self.film, self.encoding, None).map_err(runtime_error)?;
        let mut out = Vec::new();
        raylab::image::output::encode_rgb8(&mut out, &rgb, self.film.width, self.film.height, raylab::image::output::ImageKind::Png)
            .map_err(runtime_error)?;
        Ok(PyBytes::new(py, &out))
    }

    /// The counters: camera rays, the integrator's counters by name, rays in all, non-finite
    /// samples, seconds of tracing and rays per second (None for a merged image).
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(st) = &self.stats else { return Ok(None) };
        let d = PyDict::new(py);
        d.set_item("camera_rays", st.camera_rays)?;
        let counters = PyDict::new(py);
        for (c, n) in st.counters() {
            counters.set_item(c.name, n)?;
        }
        d.set_item("counters", counters)?;
        d.set_item("rays", st.total_rays())?;
        d.set_item("nonfinite_samples", st.nonfinite_samples)?;
        d.set_item("seconds", self.seconds)?;
        d.set_item("rays_per_second", st.total_rays() as f64 / self.seconds.max(1e-9))?;
        Ok(Some(d))
    }

    /// Writes the image as the CLI's `render -o PATH` does, by extension: `.png`/`.jpg` (8-bit,
    /// the scene's encoding), `.exr` (linear floats with the layers asked for; `half`: 16-bit),
    /// `.pfm`. A part of a frame is written as a partial EXR for `raylab merge`.
    #[pyo3(signature = (path, *, half=false))]
    fn save(&self, py: Python<'_>, path: PathBuf, half: bool) -> PyResult<()> {
        let registry = crate::registry()?;
        py.detach(|| -> Result<(), String> {
            if let Some((sums, info)) = &self.part {
                let info = raylab::image::partial::PartialInfo {
                    fingerprint: info.fingerprint.clone(),
                    sampling: info.sampling.clone(),
                    encoding: self.encoding.name().to_string(),
                    resume: None,
                };
                return raylab::image::partial::write_partial(&path, sums, &info).map_err(|e| e.to_string());
            }
            let format = registry.output_format_for(&path).map_err(|e| e.to_string())?;
            let layers = self.chosen_layers();
            let settings = raylab::image::output::WriteSettings { encoding: self.encoding, grid: None, layers: layers.as_ref(), half };
            format.write(&path, &self.film, &settings).map_err(|e| e.to_string())
        })
        .map_err(runtime_error)
    }
}

/// Merges parts of one frame (`Rendered` parts, or partial EXR files written by `raylab render
/// --tile/--crop/--pass` or `Rendered.save`) into one image: the same bits as one whole render.
#[pyfunction]
#[pyo3(signature = (parts, *, allow_partial=false, max_pixels=1 << 26, max_file_bytes=1 << 32))]
pub fn merge(
    py: Python<'_>,
    parts: Vec<Bound<'_, PyAny>>,
    allow_partial: bool,
    max_pixels: u64,
    max_file_bytes: u64,
) -> PyResult<Rendered> {
    let mut merged = Vec::with_capacity(parts.len());
    let mut encoding = None;
    for (i, p) in parts.iter().enumerate() {
        if let Ok(r) = p.cast::<Rendered>() {
            let r = r.get();
            let Some((sums, info)) = &r.part else {
                return Err(PyValueError::new_err(format!(
                    "part {i} is a whole image, not a part of a frame (render it with tile=, crop= or pass_=)"
                )));
            };
            encoding.get_or_insert(r.encoding);
            merged.push(raylab::render::share::Part {
                name: format!("part {i}"),
                sums: sums.clone(),
                fingerprint: info.fingerprint.clone(),
            });
            continue;
        }
        let path: PathBuf = p.extract()?;
        let name = path.display().to_string();
        let (sums, info) = py
            .detach(|| -> Result<_, String> {
                let bytes = raylab::load::context::read_user_file(&path, "partial image", max_file_bytes, None).map_err(|e| e.report())?;
                raylab::image::partial::read_partial(&bytes, &name, max_pixels).map_err(|e| e.to_string())
            })
            .map_err(runtime_error)?;
        encoding.get_or_insert(Encoding::parse(&info.encoding).unwrap_or_default());
        merged.push(raylab::render::share::Part { name, sums, fingerprint: info.fingerprint });
    }
    let (film, layers, estimate, low) = py
        .detach(|| -> Result<_, String> {
            let whole = raylab::render::share::merge(&merged, allow_partial)?;
            let low = whole.sampling.target.map(|t| whole.low_reading(&t));
            Ok((whole.film().map_err(|e| e.to_string())?, whole.aovs().map_err(|e| e.to_string())?, whole.error_estimate(), low))
        })
        .map_err(runtime_error)?;
    let aov = if layers.is_some() { vec!["depth".into(), "normal".into(), "albedo".into(), "emission".into()] } else { Vec::new() };
    Ok(Rendered {
        film,
        layers,
        aov,
        stats: None,
        seconds: 0.0,
        encoding: encoding.unwrap_or_default(),
        complete: true,
        part: None,
        error: None,
        estimate,
        low,
    })
}

/// A film from `height × width × 3` native-endian `f32` bytes.
fn film_of(bytes: &[u8], width: u32, height: u32) -> PyResult<Film> {
    let n = width as usize * height as usize;
    if bytes.len() != n * 12 {
        return Err(PyValueError::new_err(format!("expected {width}×{height}×3 float32 values, found {} bytes", bytes.len())));
    }
    let mut film = Film::new(width, height).map_err(|e| pyo3::exceptions::PyMemoryError::new_err(e.to_string()))?;
    for (p, c) in film.pixels.iter_mut().zip(bytes.chunks_exact(12)) {
        let f = |k: usize| f32::from_ne_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
        *p = glam::Vec3::new(f(0), f(4), f(8));
    }
    Ok(film)
}

/// The error of an image against a reference (both `height × width × 3` float32 bytes), on the
/// displayed values as `raylab sweep` and `render --reference` measure it: (RMSE, PSNR dB, SSIM).
#[pyfunction]
pub fn compare(py: Python<'_>, image: Vec<u8>, reference: Vec<u8>, width: u32, height: u32, encoding: &str) -> PyResult<(f64, f64, f64)> {
    let enc = Encoding::parse(encoding).ok_or_else(|| PyValueError::new_err(format!("unknown encoding \"{encoding}\"")))?;
    let (a, b) = (film_of(&image, width, height)?, film_of(&reference, width, height)?);
    let e = py.detach(|| raylab::image::metrics::compare(&a, &b, enc)).map_err(PyValueError::new_err)?;
    Ok((e.rmse, e.psnr, e.ssim))
}

/// A reference image file (`.pfm`, or `.png` decoded with `encoding`) as `(width, height,
/// float32 bytes)`, read as `raylab sweep --reference` reads it.
#[pyfunction]
pub fn read_reference<'py>(py: Python<'py>, path: PathBuf, encoding: &str) -> PyResult<(u32, u32, Bound<'py, PyByteArray>)> {
    let enc = Encoding::parse(encoding).ok_or_else(|| PyValueError::new_err(format!("unknown encoding \"{encoding}\"")))?;
    let film = py.detach(|| raylab::image::reference::read(&path, enc)).map_err(runtime_error)?;
    let bytes = f32_bytes(py, film.pixels.len() * 3, film.pixels.iter().flat_map(|p| p.to_array()))?;
    Ok((film.width, film.height, bytes))
}
