//! A sample explained for people and programs: the JSON of its ray trees that `raylab trace
//! --json` prints and the live view shows.

use crate::math::color::Color;
use crate::render::job::RenderJob;
use crate::render::sample::SampleId;
use crate::render::trace::TraceNode;

/// Which sample of a pixel an explanation is of.
#[derive(Clone, Copy, Debug)]
pub struct SampleRef {
    /// Its index among the pixel's samples ([`crate::render::pixel_samples`]).
    pub index: u32,
    /// How many samples the pixel has.
    pub of: usize,
    /// The sample.
    pub id: SampleId,
    /// Its weight in the pixel's colour.
    pub weight: f64,
}

/// The colour of a sample explained by `trees` (one per camera ray): the mean of the finite ones,
/// as the render averages them.
pub fn sample_color(trees: &[TraceNode]) -> Color {
    let finite: Vec<Color> = trees.iter().map(|t| t.color).filter(|c| c.is_finite()).collect();
    if finite.is_empty() { Color::ZERO } else { finite.iter().sum::<Color>() / finite.len() as f64 }
}

/// The explanation of one sample (or one ray) of `job` as JSON: what `raylab trace --json` prints
/// and the live view shows. `trees` holds one tree per camera ray.
pub fn explanation_json(
    job: &RenderJob,
    scene: &str,
    pixel: Option<(u32, u32)>,
    sample: Option<SampleRef>,
    trees: &[TraceNode],
) -> serde_json::Value {
    let s = &job.settings;
    let c = sample_color(trees);
    let rgb8 = [c.x, c.y, c.z].map(|v| s.encoding.to_u8(v as f32));
    serde_json::json!({
        "scene": scene,
        "pixel": pixel,
        "sample": sample.map(|r| serde_json::json!({ "index": r.index, "of": r.of, "id": r.id, "weight": r.weight })),
        "sampling": s.describe_sampling(),
        "integrator": job.integrator_name,
        "color": c,
        "rgb8": rgb8,
        "encoding": s.encoding,
        "tree": trees.first(),
        "lens_rays": if trees.len() > 1 { serde_json::to_value(trees).unwrap_or_default() } else { serde_json::Value::Null },
    })
}
