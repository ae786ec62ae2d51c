//! The example scene, rendered in memory: the torus is where the scene puts it, and the `ao`
//! integrator and `panel` light work through the same loader as the built-ins.

use raylab::Intersectable;
use raylab::load::context::{LoadOptions, Overrides};
use raylab::load::loader::load_file;
use raylab::render::{RenderOptions, render};
use std::path::Path;

fn scene() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/torus.toml")
}

fn options(integrator: Option<&str>) -> LoadOptions {
    let overrides =
        Overrides { width: Some(80), height: Some(60), spp: Some(1), integrator: integrator.map(String::from), ..Overrides::default() };
    LoadOptions { overrides, ..LoadOptions::default() }
}

#[test]
fn the_scene_loads_every_plugin_of_the_crate() {
    let job = load_file(&raylab_torus::registry(), &scene(), &options(None)).unwrap_or_else(|e| panic!("{}", e.report()));
    let names: Vec<&str> = (0..job.scene.objects.len() as u32).map(|i| job.scene.object_name(i)).collect();
    assert!(names.contains(&"gold ring") && names.contains(&"glass ring"), "{names:?}");
    assert!(job.scene.light_names.iter().any(|n| n == "softbox"));
    assert!(job.scene.lights.iter().any(|l| l.sample_count() == 16), "the rect light asks for its samples");
}

#[test]
fn the_hole_of_the_gold_ring_shows_what_is_inside() {
    // Camera ray through the gold ring's centre from above hits the ball in the hole, not the ring.
    let job = load_file(&raylab_torus::registry(), &scene(), &options(Some("normals"))).unwrap();
    let ray = raylab::Ray::new(raylab::glam::DVec3::new(-1.3, 5.0, 0.2), raylab::glam::DVec3::NEG_Y);
    let hit = job.scene.intersect(&ray, 0.0, f64::INFINITY).expect("hit");
    assert_eq!(job.scene.object_name(hit.object), "ball in the hole");
    let ray = raylab::Ray::new(raylab::glam::DVec3::new(-0.3, 5.0, 0.2), raylab::glam::DVec3::NEG_Y);
    let hit = job.scene.intersect(&ray, 0.0, f64::INFINITY).expect("hit");
    assert_eq!(job.scene.object_name(hit.object), "gold ring");
    assert!((hit.point.y - 0.9).abs() < 1e-12, "top of the tube at 0.45 + 0.45, found {}", hit.point.y);
}

#[test]
fn ambient_occlusion_darkens_the_floor_under_the_ring() {
    // A plain floor: occlusion alone, without the marble's veins.
    let text = std::fs::read_to_string(scene()).unwrap().replace("kd = \"marble\"", "kd = 0.45");
    let dir = scene().parent().unwrap().to_path_buf();
    let job = raylab::load::loader::load_str(&raylab_torus::registry(), "torus.toml", &text, &dir, &options(Some("ao"))).unwrap();
    let film = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap().film;
    // Open floor near the bottom edge versus the floor right beside the gold ring.
    let open = film.get(40, 58).x;
    let near = (0..80).map(|x| film.get(x, 42).x).fold(f32::INFINITY, f32::min);
    assert!(open > 0.3 && near < 0.6 * open, "open floor {open}, darkest at the ring's foot {near}");
}

#[test]
fn the_panel_lights_samples_rays_and_densities_agree() {
    let job = load_file(&raylab_torus::registry(), &scene(), &options(None)).unwrap();
    let i = job.scene.light_names.iter().position(|n| n == "softbox").expect("the panel");
    let panel = job.scene.lights[i].as_ref();
    for p in [raylab::glam::DVec3::ZERO, raylab::glam::DVec3::new(3.0, 1.0, 2.0), raylab::glam::DVec3::new(-1.0, 4.5, 0.3)] {
        let (integral, mean) = raylab::scene::light::testing::check_light(panel, p, 1024, 1500, 0.01);
        assert!(mean.x > 0.0, "lit below the panel: {integral} vs {mean}");
    }
    // Above the panel, its dark side: no light, and no ray meets it.
    let (integral, mean) = raylab::scene::light::testing::check_light(panel, raylab::glam::DVec3::new(0.0, 6.0, 0.0), 16, 200, 0.01);
    assert_eq!((integral, mean), (raylab::Color::ZERO, raylab::Color::ZERO));
}

/// The panel's samples follow the density it gives the path tracer (a χ² test, as for the
/// built-in lights), seen from below, close by and obliquely.
#[test]
fn the_panel_lights_sampling_passes_the_chi2_test() {
    use raylab::testing::chi2::{Chi2Test, Sphere};
    let job = load_file(&raylab_torus::registry(), &scene(), &options(None)).unwrap();
    let i = job.scene.light_names.iter().position(|n| n == "softbox").expect("the panel");
    let panel = job.scene.lights[i].as_ref();
    let test = Chi2Test::new(Sphere).res(72, 36).tests(2);
    for p in [raylab::glam::DVec3::new(0.0, 3.5, 0.0), raylab::glam::DVec3::new(2.5, 3.0, 1.5)] {
        raylab::scene::light::testing::chi2_light(panel, p, &test).assert_passes(&format!("panel seen from {p}"));
    }
}

#[test]
fn the_path_tracer_renders_the_crates_scene() {
    // The built-in path tracer meets the crate's panel with its rays (multiple importance
    // sampling) and its torus with its scattered rays: every pixel finite, the floor lit.
    let mut opts = options(Some("path"));
    opts.overrides.spp = Some(4);
    let job = load_file(&raylab_torus::registry(), &scene(), &opts).unwrap();
    let out = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap();
    assert_eq!(out.stats.nonfinite_samples, 0);
    assert!(out.film.pixels.iter().all(|p| p.is_finite()));
    assert!(out.stats.get("light_hits") > 0, "rays met the panel");
    assert!(out.film.get(40, 58).x > 0.05, "the open floor is lit");
}
