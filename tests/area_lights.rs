//! Soft shadows from area lights: the penumbra has the visible fraction of the light, and
//! adaptive shadow rays save work outside penumbrae.

use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::render::{RenderJob, RenderOptions, render};
use std::path::Path;

/// A floor lit by a 2 × 2 rectangle 4 above the origin; optionally a half-plane at height 2
/// covering x < 0, whose edge the line from the origin to the light's centre crosses: the
/// origin sees exactly the half of the light with x ≥ 0.
fn scene(occluder: bool, light: &str, size: (u32, u32), extra: &str) -> RenderJob {
    let occ = if occluder {
        "[[object]]\ntype = \"quadrangle\"\np0 = [-10, 2, -10]\np1 = [0, 2, -10]\np2 = [0, 2, 10]\np3 = [-10, 2, 10]\nmaterial = { kd = 0.5 }\n"
    } else {
        ""
    };
    let text = format!(
        r#"
[render]
width = {}
height = {}
encoding = "linear"
[camera]
position = [0, 1, 3]
look_at = [0, 0, 0]
fov = {}
[integrator]
prune_threshold = 0
{extra}
[[object]]
type = "plane"
point = [0, 0, 0]
normal = [0, 1, 0]
material = {{ ka = 0, kd = 1 }}
{occ}
[[light]]
{light}
"#,
        size.0,
        size.1,
        if size.0 == 1 { 1 } else { 60 }
    );
    load_str(&raylab_plugins::registry(), "soft.toml", &text, Path::new("."), &LoadOptions::default()).unwrap()
}

const RECT: &str = "type = \"rect\"\ncenter = [0, 4, 0]\nedge1 = [2, 0, 0]\nedge2 = [0, 0, 2]\nsamples = 64";
const BALL: &str = "type = \"point\"\nposition = [0, 4, 0]\nradius = 1\nsamples = 64";

fn pixel(job: &RenderJob) -> f32 {
    render(job, &RenderOptions::default(), &|_, _| {}).unwrap().film.get(0, 0).x
}

#[test]
fn half_occluded_area_lights_give_half_the_light() {
    for light in [RECT, BALL] {
        let open = pixel(&scene(false, light, (1, 1), ""));
        let half = pixel(&scene(true, light, (1, 1), ""));
        let ratio = half / open;
        assert!((ratio - 0.5).abs() < 0.03, "{light}: visible fraction {ratio}, expected 0.5");
    }
}

#[test]
fn a_zero_radius_ball_is_the_point_light() {
    let point = "type = \"point\"\nposition = [0, 4, 0]";
    let ball = "type = \"point\"\nposition = [0, 4, 0]\nradius = 0\nsamples = 64";
    let a = render(&scene(true, point, (16, 12), ""), &RenderOptions::default(), &|_, _| {}).unwrap();
    let b = render(&scene(true, ball, (16, 12), ""), &RenderOptions::default(), &|_, _| {}).unwrap();
    assert_eq!(a.film, b.film);
    assert_eq!(a.stats.get("shadow_rays"), b.stats.get("shadow_rays"), "a point light takes one shadow ray");
}

#[test]
fn adaptive_shadow_rays_save_work_outside_penumbrae() {
    let full = render(&scene(true, RECT, (32, 24), ""), &RenderOptions::default(), &|_, _| {}).unwrap();
    let adaptive = render(&scene(true, RECT, (32, 24), "shadow_probes = 4"), &RenderOptions::default(), &|_, _| {}).unwrap();
    assert!(adaptive.stats.get("shadow_rays_saved") > 0);
    assert!(
        adaptive.stats.get("shadow_rays") * 4 < full.stats.get("shadow_rays") * 3,
        "{} vs {}",
        adaptive.stats.get("shadow_rays"),
        full.stats.get("shadow_rays")
    );
    let worst = full.film.pixels.iter().zip(&adaptive.film.pixels).map(|(a, b)| (*a - *b).abs().max_element()).fold(0f32, f32::max);
    let brightest = full.film.pixels.iter().map(|p| p.max_element()).fold(0f32, f32::max);
    assert!(worst < 0.1 * brightest, "adaptive shadows differ by {worst} (brightest {brightest})");
    // The override of each light's own count.
    let overridden = render(&scene(true, RECT, (32, 24), "shadow_rays = 8"), &RenderOptions::default(), &|_, _| {}).unwrap();
    assert!(overridden.stats.get("shadow_rays") * 4 < full.stats.get("shadow_rays"));
}
