//! `raylab trace`: explain one pixel or one ray as a tree of hits, light tests and child rays.

use super::{App, Failure, SceneArgs};
use crate::math::ray::Ray;
use crate::render::explain::{explanation_json, sample_color};
use crate::render::sample::SampleId;
use crate::render::{explain_pixel, explain_ray};
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
    /// Which of the pixel's samples to explain (0-based): a stratified sample under `--aa
    /// stratified` (0..spp), or the K-th lattice point the adaptive scheme traced for the pixel.
    /// The explanation is the computation the render did for that sample, bit for bit.
    #[arg(long, value_name = "K", default_value_t = 0, allow_hyphen_values = true, value_parser = super::int_in::<u32>(0, u32::MAX.into()))]
    sample: u32,
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
    let cannot = || Failure::Other(format!("the integrator \"{}\" cannot explain rays", job.integrator_name));
    // A pixel: the sample's camera rays (one per lens point), exactly as the render traced them.
    let (trees, pixel, sample) = if let Some(p) = &a.pixel {
        let bad = || Failure::Other(format!("--pixel: expected X,Y inside the {}×{} image, found \"{p}\"", s.width, s.height));
        let (x, y) = p.split_once(',').ok_or_else(bad)?;
        let (x, y): (u32, u32) = (x.trim().parse().map_err(|_| bad())?, y.trim().parse().map_err(|_| bad())?);
        if x >= s.width || y >= s.height {
            return Err(bad());
        }
        let (trees, sample) =
            explain_pixel(&job, x, y, a.sample).map_err(|e| Failure::Other(if e.starts_with("sample ") { format!("--{e}") } else { e }))?;
        (trees, Some((x, y)), Some(sample))
    } else {
        let r = a.ray.as_deref().unwrap_or_default();
        let (o, d) = r.split_once(':').ok_or_else(|| Failure::Other(format!("--ray: expected OX,OY,OZ:DX,DY,DZ, found \"{r}\"")))?;
        let (o, d) = (parse_vec3(o, "--ray origin")?, parse_vec3(d, "--ray direction")?);
        let dir = d.try_normalize().ok_or_else(|| Failure::Other("--ray: the direction must not be zero".into()))?;
        let tree = explain_ray(&job, &Ray { origin: o, dir }).ok_or_else(cannot)?;
        (vec![tree], None, None)
    };
    let c = sample_color(&trees);
    let rgb8 = [c.x, c.y, c.z].map(|v| s.encoding.to_u8(v as f32));
    if a.json {
        let out = explanation_json(&job, &a.scene.display().to_string(), pixel, sample, &trees);
        println!("{}", serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?);
    } else {
        if let (Some((x, y)), Some(sample)) = (pixel, sample) {
            let (weight, count) = (sample.weight, sample.of);
            let which = match sample.id {
                SampleId::Pixel { .. } => format!("sample {} of {count}", a.sample),
                SampleId::Lattice { x, y, depth } => {
                    format!("adaptive lattice point {} of {count} at ({x}, {y})/{}, weight {weight:.4}", a.sample, 1u64 << depth)
                }
                SampleId::Cell { x, y, depth, index, count: n } => format!(
                    "adaptive sample {} of {count}: point {index} of {n} in the lattice cell at ({x}, {y})/{}, weight {weight:.4}",
                    a.sample,
                    1u64 << depth
                ),
            };
            println!(
                "pixel ({x}, {y}) of {}×{}, {which} ({}), integrator {}",
                s.width,
                s.height,
                s.describe_sampling(),
                job.integrator_name
            );
        }
        for (l, tree) in trees.iter().enumerate() {
            if trees.len() > 1 {
                println!("lens ray {l} of {}:", trees.len());
            }
            print!("{}", tree.to_text());
        }
        println!("sample colour ({:.6}, {:.6}, {:.6})  → {} 8-bit {:?}", c.x, c.y, c.z, s.encoding.name(), rgb8);
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
