//! Debug views: `normals` (the shading normal as a colour) and `depth` (distance as grey).

use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::render::aov::AovSample;
use raylab::render::trace::{NoRecord, Recorder};
use raylab::scene::interaction::Interaction;
use raylab::{Color, Integrator, LoadContext, PluginInfo, Ray, RayKind, RayStats, Sampler, Scene, TraceNode};

/// Shows the direction-aware normal: `(n + 1) / 2` as RGB (x → red, y → green, z → blue).
#[derive(Clone, Debug, Default)]
pub struct Normals;

/// The `normals` plugin's description.
pub const NORMALS_INFO: PluginInfo = PluginInfo {
    name: "normals",
    summary: "Debug view: the shading normal (facing the camera) as colour, (n + 1)/2; background black.",
    params: &[],
};

/// Builds the normals view.
pub fn build_normals(_: &mut Params, _: &LoadContext) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Normals))
}

/// Shows distance from the ray origin: white at the origin fading to black at `far`.
#[derive(Clone, Debug)]
pub struct Depth {
    far: Option<f64>,
}

/// The `depth` plugin's description.
pub const DEPTH_INFO: PluginInfo = PluginInfo {
    name: "depth",
    summary: "Debug view: distance along the camera ray as grey, 1 at the camera to 0 at `far`; background black.",
    params: &[ParamSpec::new(
        "far",
        ParamKind::Float,
        ParamDefault::Optional,
        "distance shown as black, scene units; default: the farthest corner of the scene's bounded objects",
    )],
};

/// Builds the depth view.
pub fn build_depth(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Integrator>> {
    let far = p.float_opt("far")?;
    if far.is_some_and(|f| !(f > 0.0)) {
        return Err(p.error_at("far", "expected a distance > 0"));
    }
    Ok(Box::new(Depth { far }))
}

/// One hit, coloured by `color(scene, interaction)`: the whole of both views, for rendering and
/// explaining alike.
fn first_hit<R: Recorder>(scene: &Scene, ray: &Ray, aov: &mut AovSample, rec: &mut R, color: impl Fn(&Interaction) -> Color) -> Color {
    let Some(si) = scene.trace(ray) else {
        rec.color(Color::ZERO);
        return Color::ZERO;
    };
    let c = color(&si);
    *aov = AovSample::surface(&si, c);
    rec.hit(&si);
    rec.color(c);
    c
}

fn explain_one(scene: &Scene, ray: &Ray, color: impl Fn(&Interaction) -> Color) -> TraceNode {
    let mut node = TraceNode::new(RayKind::Camera, *ray, 0, Color::ONE);
    first_hit(scene, ray, &mut AovSample::miss(scene.background), &mut node, color);
    node
}

impl Integrator for Normals {
    fn radiance(&self, scene: &Scene, ray: &Ray, _: &mut Sampler, _: &mut RayStats, aov: &mut AovSample) -> Color {
        first_hit(scene, ray, aov, &mut NoRecord, |si| (si.ns + Color::ONE) * 0.5)
    }
    fn explain(&self, scene: &Scene, ray: &Ray, _: &mut Sampler) -> Option<TraceNode> {
        Some(explain_one(scene, ray, |si| (si.ns + Color::ONE) * 0.5))
    }
    fn worst_case_rays(&self, _: &Scene) -> f64 {
        1.0
    }
}

impl Depth {
    fn far(&self, scene: &Scene) -> f64 {
        self.far.unwrap_or_else(|| {
            let b = scene.bounds();
            if b.is_empty() {
                return 100.0;
            }
            let eye = scene.camera.position;
            let mut far: f64 = 0.0;
            for i in 0..8 {
                let corner = raylab::glam::DVec3::new(
                    if i & 1 == 0 { b.min.x } else { b.max.x },
                    if i & 2 == 0 { b.min.y } else { b.max.y },
                    if i & 4 == 0 { b.min.z } else { b.max.z },
                );
                far = far.max((corner - eye).length());
            }
            if far > 0.0 { far } else { 1.0 }
        })
    }

    fn shade(&self, scene: &Scene, t: f64) -> Color {
        Color::splat((1.0 - t / self.far(scene)).clamp(0.0, 1.0))
    }
}

impl Integrator for Depth {
    fn radiance(&self, scene: &Scene, ray: &Ray, _: &mut Sampler, _: &mut RayStats, aov: &mut AovSample) -> Color {
        first_hit(scene, ray, aov, &mut NoRecord, |si| self.shade(scene, si.hit.t))
    }
    fn explain(&self, scene: &Scene, ray: &Ray, _: &mut Sampler) -> Option<TraceNode> {
        Some(explain_one(scene, ray, |si| self.shade(scene, si.hit.t)))
    }
    fn worst_case_rays(&self, _: &Scene) -> f64 {
        1.0
    }
    fn describe(&self) -> String {
        self.far.map_or_else(|| "far auto".into(), |f| format!("far {f}"))
    }
}
