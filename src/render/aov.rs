//! Arbitrary output variables: per-pixel depth, normal and albedo, the extra layers a denoiser
//! (Intel Open Image Denoise, OptiX) or a compositor wants beside the colour.
//!
//! They come from a separate pass over the same camera rays as the render (same sample
//! positions, [`crate::render::camera_ray`]), each the mean over the pixel's samples:
//!
//! - `depth` (`Z`): distance along the camera ray to the first surface, scene units, over the
//!   samples that hit one; +∞ where none does.
//! - `normal` (`normal.X/Y/Z`): the shading normal at the first surface, world space, facing the
//!   camera; zero for misses.
//! - `albedo` (`albedo.R/G/B`): `min(1, kd + kr + kt)` of the first surface: the diffuse colour of
//!   matte surfaces and about 1 for mirrors and glass, as the denoisers ask; the background colour
//!   (clamped to 1) for misses.

use crate::image::output::WriteError;
use crate::math::color::Color;
use crate::render::{RenderJob, camera_ray};
use glam::Vec3;
use rayon::prelude::*;

/// An extra output layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    /// Distance to the first surface.
    Depth,
    /// Shading normal at the first surface.
    Normal,
    /// Reflectance of the first surface.
    Albedo,
}

impl Aov {
    /// Parses `depth`, `normal` or `albedo`.
    pub fn parse(s: &str) -> Option<Aov> {
        match s {
            "depth" => Some(Aov::Depth),
            "normal" => Some(Aov::Normal),
            "albedo" => Some(Aov::Albedo),
            _ => None,
        }
    }
}

/// The extra layers of an image, row-major like [`crate::image::film::Film`]; each present if asked for.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Aovs {
    /// Distance per pixel (+∞: nothing hit).
    pub depth: Option<Vec<f32>>,
    /// Mean shading normal per pixel.
    pub normal: Option<Vec<Vec3>>,
    /// Mean albedo per pixel.
    pub albedo: Option<Vec<Vec3>>,
}

/// Computes the layers in `which` for `job` (in parallel on the current rayon pool). The size
/// was budgeted at load ([`crate::input::limits::Limits::max_image_bytes`]); see [`try_render_aovs`].
pub fn render_aovs(job: &RenderJob, which: &[Aov]) -> Aovs {
    try_render_aovs(job, which).unwrap_or_else(|e| panic!("{e}"))
}

/// [`render_aovs`], or an error if the layers' memory cannot be had (instead of aborting).
pub fn try_render_aovs(job: &RenderJob, which: &[Aov]) -> Result<Aovs, WriteError> {
    let s = job.settings;
    let (w, h) = (s.width as usize, s.height as usize);
    let mut pixels: Vec<(f32, Vec3, Vec3)> = Vec::new();
    pixels.try_reserve_exact(w * h).map_err(|_| WriteError(format!("out of memory for the extra layers of a {w}×{h} image")))?;
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let (mut depth, mut hits) = (0.0, 0u32);
            let (mut normal, mut albedo) = (Color::ZERO, Color::ZERO);
            for k in 0..s.spp {
                let ray = camera_ray(job, x, y, k);
                match job.scene.intersect(&ray, 0.0, f64::INFINITY) {
                    Some(hit) => {
                        let g = &job.scene.geometries[hit.object as usize];
                        let m = g.material_at(&hit);
                        depth += hit.t;
                        hits += 1;
                        normal += g.shading_normal(&hit, ray.dir);
                        albedo += (m.kd + m.kr + m.kt).min(Color::ONE);
                    }
                    None => albedo += job.scene.background.min(Color::ONE),
                }
            }
            let n = f64::from(s.spp.max(1));
            let depth = if hits == 0 { f32::INFINITY } else { (depth / f64::from(hits)) as f32 };
            (depth, (normal / n).as_vec3(), (albedo / n).as_vec3())
        })
        .collect_into_vec(&mut pixels);
    let has = |a: Aov| which.contains(&a);
    let layer = |a: Aov, name: &str, f: &dyn Fn(&(f32, Vec3, Vec3)) -> Vec3| -> Result<Option<Vec<Vec3>>, WriteError> {
        if !has(a) {
            return Ok(None);
        }
        let mut v = Vec::new();
        v.try_reserve_exact(pixels.len()).map_err(|_| WriteError(format!("out of memory for the {name} layer")))?;
        v.extend(pixels.iter().map(f));
        Ok(Some(v))
    };
    let depth = if has(Aov::Depth) {
        let mut v = Vec::new();
        v.try_reserve_exact(pixels.len()).map_err(|_| WriteError("out of memory for the depth layer".into()))?;
        v.extend(pixels.iter().map(|p| p.0));
        Some(v)
    } else {
        None
    };
    Ok(Aovs { depth, normal: layer(Aov::Normal, "normal", &|p| p.1)?, albedo: layer(Aov::Albedo, "albedo", &|p| p.2)? })
}
