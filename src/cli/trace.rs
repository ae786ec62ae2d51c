//! `raylab trace`: explain one pixel or one ray as a tree of hits, light tests and child rays.

use super::{App, Failure, SceneArgs};
use crate::math::ray::Ray;
use crate::render::sampler::Sampler;
use clap::Args;
use glam::DVec3;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub(crate) struct TraceArgs {
    /// Scene file.
    scene: PathBuf,
    /// The pixel to explain, as X,Y (column, row from the top-left, from 0).
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true, conflicts_with = "ray", required_unless_present = "ray")]
    pixel: Option<String>,
    /// A ray to explain, as OX,OY,OZ:DX,DY,DZ (origin and direction).
    #[arg(long, value_name = "OX,OY,OZ:DX,DY,DZ", allow_hyphen_values = true)]
    ray: Option<String>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    scene_args: SceneArgs,
}

pub(crate) fn run(app: &App, a: TraceArgs) -> Result<(), Failure> {
    let (job, _) = super::load(app, Some(&a.scene), &a.scene_args, crate::image::output::ImagePlan::EIGHT_BIT)?;
    let s = job.settings;
    let (ray, pixel) = if let Some(p) = &a.pixel {
        let bad = || Failure::Other(format!("--pixel: expected X,Y inside the {}×{} image, found \"{p}\"", s.width, s.height));
        let (x, y) = p.split_once(',').ok_or_else(bad)?;
        let (x, y): (u32, u32) = (x.trim().parse().map_err(|_| bad())?, y.trim().parse().map_err(|_| bad())?);
        if x >= s.width || y >= s.height {
            return Err(bad());
        }
        (job.scene.camera.construct_ray_through_pixel(s.width, s.height, f64::from(x), f64::from(y)), Some((x, y)))
    } else {
        let r = a.ray.as_deref().unwrap_or_default();
        let (o, d) = r.split_once(':').ok_or_else(|| Failure::Other(format!("--ray: expected OX,OY,OZ:DX,DY,DZ, found \"{r}\"")))?;
        let (o, d) = (parse_vec3(o, "--ray origin")?, parse_vec3(d, "--ray direction")?);
        let dir = d.try_normalize().ok_or_else(|| Failure::Other("--ray: the direction must not be zero".into()))?;
        (Ray { origin: o, dir }, None)
    };
    let index = pixel.map_or(0, |(x, y)| u64::from(y) * u64::from(s.width) + u64::from(x));
    let mut sampler = Sampler::new(index, 0, s.seed);
    let tree = job
        .integrator
        .explain(&job.scene, &ray, &mut sampler)
        .ok_or_else(|| Failure::Other(format!("the integrator \"{}\" cannot explain rays", job.integrator_name)))?;
    let c = tree.color;
    let rgb8 = [c.x, c.y, c.z].map(|v| s.encoding.to_u8(v as f32));
    if a.json {
        let out = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "pixel": pixel,
            "integrator": job.integrator_name,
            "color": c,
            "rgb8": rgb8,
            "encoding": s.encoding,
            "tree": tree,
        });
        println!("{}", serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?);
    } else {
        if let Some((x, y)) = pixel {
            println!("pixel ({x}, {y}) of {}×{}, integrator {}", s.width, s.height, job.integrator_name);
        }
        print!("{}", tree.to_text());
        println!("final colour ({:.6}, {:.6}, {:.6})  → {} 8-bit {:?}", c.x, c.y, c.z, s.encoding.name(), rgb8);
    }
    Ok(())
}

fn parse_vec3(s: &str, what: &str) -> Result<DVec3, Failure> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || Failure::Other(format!("{what}: expected three comma-separated finite numbers, found \"{s}\""));
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut v = [0.0; 3];
    for (slot, p) in v.iter_mut().zip(parts) {
        *slot = p.parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(bad)?;
    }
    Ok(DVec3::from(v))
}
