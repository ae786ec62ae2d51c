//! Doing only what a scene requires: the skipped work is counted, and skipping it changes no bit
//! of the image.

use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::render::{RenderOptions, render};
use std::path::Path;

/// Every exact avoidance must happen here: a light below the floor (behind every upward
/// surface), a narrow spot (most points outside its cone), a black-body mirror (no diffuse or
/// specular response), opaque matte objects (zero kr and kt), a sharp mirror (no glossy fan), and
/// randomness downstream of all of it (a glossy sphere and a rectangular area light).
fn scene(avoid: bool) -> String {
    format!(
        r#"
background = [0.2, 0.3, 0.4]
[render]
width = 24
height = 18
spp = 2
[camera]
position = [0, 2, 7]
look_at = [0, 0.8, 0]
fov = 45
[integrator]
max_depth = 3
prune_threshold = 0
glossy_rays = 3
avoid = {avoid}
[[object]]
type = "plane"
point = [0, 0, 0]
normal = [0, 1, 0]
material = {{ kd = 0.6 }}
[[object]]
type = "sphere"
center = [-1.3, 1, 0]
radius = 1
material = {{ kd = 0, ks = 0, kr = 0.9 }}
[[object]]
type = "sphere"
center = [1.3, 0.8, 0.3]
radius = 0.8
material = {{ kd = [0.7, 0.3, 0.2], ks = 0.3, kr = 0.3, blur = 0.2 }}
[[object]]
type = "sphere"
center = [0.2, 0.4, 1.6]
radius = 0.4
material = {{ kd = 0.1, kt = 0.8, kr = 0.1, ior = 1.4 }}
[[light]]
type = "point"
position = [0, -3, 0]
[[light]]
type = "spot"
position = [2, 4, 2]
direction = [-0.3, -1, -0.4]
cone_angle = 12
exponent = 4
[[light]]
type = "rect"
center = [-2, 5, 3]
edge1 = [1.5, 0, 0]
edge2 = [0, 0, 1]
samples = 4
"#
    )
}

#[test]
fn avoided_work_is_counted_and_changes_no_pixel() {
    let reg = raylab_plugins::registry();
    let load = |avoid| load_str(&reg, "avoid.toml", &scene(avoid), Path::new("."), &LoadOptions::default()).unwrap();
    let on = render(&load(true), &RenderOptions::default(), &|_, _| {}).unwrap();
    let off = render(&load(false), &RenderOptions::default(), &|_, _| {}).unwrap();
    let s = on.stats;
    assert!(s.get("lights_behind") > 0, "{s:?}");
    assert!(s.get("lights_unreachable") > 0, "{s:?}");
    assert!(s.get("lights_no_response") > 0, "{s:?}");
    assert!(s.get("zero_coefficient_rays") > 0, "{s:?}");
    assert!(s.get("glossy_rays_saved") > 0, "{s:?}");
    let o = off.stats;
    assert_eq!(
        (
            o.get("lights_behind"),
            o.get("lights_unreachable"),
            o.get("lights_no_response"),
            o.get("zero_coefficient_rays"),
            o.get("glossy_rays_saved")
        ),
        (0, 0, 0, 0, 0)
    );
    assert!(
        o.get("shadow_rays") > s.get("shadow_rays")
            && o.get("reflection_rays") > s.get("reflection_rays")
            && o.get("refraction_rays") > s.get("refraction_rays")
    );
    assert_eq!(on.film, off.film, "skipping work that cannot contribute must not change the image");
}
