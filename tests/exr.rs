//! EXR output: linear unclamped floats that agree with the 8-bit image after clamping and
//! encoding, optional half floats, and the depth/normal/albedo layers.
#![cfg(feature = "exr")]

use raylab::load::context::{LoadOptions, Overrides};
use raylab::load::loader::load_str;
use raylab::render::{RenderOptions, render};
use std::path::Path;

fn showcase() -> raylab::RenderJob {
    let (name, text) = raylab_plugins::DEFAULT_SCENE;
    let overrides = Overrides { width: Some(64), height: Some(48), spp: Some(2), ..Overrides::default() };
    let opts = LoadOptions { overrides, ..LoadOptions::default() };
    match load_str(&raylab_plugins::registry(), name, text, Path::new("."), &opts) {
        Ok(j) => j,
        Err(e) => panic!("{}", e.report()),
    }
}

#[test]
fn exr_and_png_of_one_render_agree_after_clamping_and_encoding() {
    let job = showcase();
    let film = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap().film;
    assert!(film.pixels.iter().any(|p| p.max_element() > 1.0), "the showcase has highlights above 1: a real HDR test");
    let dir = std::env::temp_dir().join(format!("raylab-exr-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (png, exr, half) = (dir.join("a.png"), dir.join("a.exr"), dir.join("h.exr"));
    raylab::image::output::write_image(&png, &film, job.settings.encoding, None).unwrap();
    raylab::image::exr::write_exr(&exr, &film, &Default::default(), false).unwrap();
    raylab::image::exr::write_exr(&half, &film, &Default::default(), true).unwrap();
    let png = image::open(&png).unwrap().to_rgb8();
    for (path, tolerance) in [(&exr, 0), (&half, 1)] {
        let (w, h, px) = raylab::image::exr::read_exr_rgb(&std::fs::read(path).unwrap()).unwrap();
        assert_eq!((w as u32, h as u32), (film.width, film.height));
        for (i, (p, q)) in px.iter().zip(png.pixels()).enumerate() {
            if tolerance == 0 {
                let f = film.pixels[i];
                assert_eq!(*p, [f.x, f.y, f.z], "32-bit EXR holds the film exactly, unclamped");
            }
            for c in 0..3 {
                let e = job.settings.encoding.to_u8(p[c]);
                assert!(e.abs_diff(q[c]) <= tolerance, "pixel {i} channel {c}: EXR {} → {e}, PNG {}", p[c], q[c]);
            }
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn layers_hold_depth_normal_and_albedo() {
    let job = showcase();
    let film = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap().film;
    let with_layers = render(&job, &RenderOptions { layers: true, ..RenderOptions::default() }, &|_, _| {}).unwrap();
    assert_eq!(with_layers.film, film, "the layers come from the same samples and do not change the image");
    let aovs = with_layers.layers.expect("layers were asked for");
    let (depth, normal, albedo) = (aovs.depth.as_ref().unwrap(), aovs.normal.as_ref().unwrap(), aovs.albedo.as_ref().unwrap());
    let n = film.pixels.len();
    assert_eq!((depth.len(), normal.len(), albedo.len()), (n, n, n));
    assert!(depth.iter().any(|d| d.is_finite() && *d > 0.0) && albedo.iter().all(|a| a.max_element() <= 1.0 && a.min_element() >= 0.0));
    assert!(normal.iter().filter(|v| v.length() > 0.0).all(|v| v.length() <= 1.0 + 1e-5));
    let bytes = raylab::image::exr::encode_exr(&film, &aovs, false).unwrap();
    use exr::prelude::*;
    let image = read().no_deep_data().largest_resolution_level().all_channels().first_valid_layer().all_attributes();
    let image = image.from_buffered(std::io::Cursor::new(bytes)).unwrap();
    let names: Vec<String> = image.layer_data.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    for expect in ["R", "G", "B", "Z", "normal.X", "normal.Y", "normal.Z", "albedo.R", "albedo.G", "albedo.B"] {
        assert!(names.iter().any(|n| n == expect), "{expect} missing from {names:?}");
    }
}

/// The layers against closed forms, pixel by pixel: one sample per pixel at its centre, a camera
/// looking down −z at a plane 5 units away (depth `5 / cos` of the ray's angle to the axis,
/// normal +z, albedo its `kd`) with a sphere in front of it (depth from the ray–sphere quadratic,
/// normal `(p − c) / r`, albedo its `kd`; `ks` is no part of phong's albedo).
#[test]
fn layers_match_closed_forms_on_a_plane_and_a_sphere() {
    use raylab::glam::{DVec2, DVec3, Vec3};
    const SCENE: &str = r#"
[render]
width = 40
height = 30
spp = 1
[camera]
position = [0, 0, 0]
look_at = [0, 0, -1]
fov = 60
[[object]]
type = "plane"
point = [0, 0, -5]
normal = [0, 0, 1]
material = { kd = [0.2, 0.5, 0.7] }
[[object]]
type = "sphere"
center = [0.8, 0.4, -3]
radius = 0.9
material = { kd = [0.9, 0.1, 0.3], ks = 0.5, shininess = 20 }
[[light]]
type = "directional"
direction = [0.2, -0.3, -1]
"#;
    let mut job = load_str(&raylab_plugins::registry(), "layers.toml", SCENE, Path::new("."), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.report()));
    job.settings.aa = raylab::render::Antialiasing::Stratified;
    job.settings.spp = 1;
    let (w, h) = (job.settings.width, job.settings.height);
    let aovs = render(&job, &RenderOptions { layers: true, ..RenderOptions::default() }, &|_, _| {}).unwrap().layers.unwrap();
    let (depth, normal, albedo) = (aovs.depth.unwrap(), aovs.normal.unwrap(), aovs.albedo.unwrap());
    let (centre, radius) = (DVec3::new(0.8, 0.4, -3.0), 0.9);
    let (mut on_sphere, mut on_plane) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let ray = job.scene.camera.ray_through(w, h, DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5), DVec2::ZERO);
            let (o, d) = (ray.origin, ray.dir.normalize());
            // The sphere: |o + t d − c|² = r², nearest root; rays grazing it are left out.
            let oc = o - centre;
            let (b, c) = (oc.dot(d), oc.length_squared() - radius * radius);
            let disc = b * b - c;
            let i = (y * w + x) as usize;
            let (want_depth, want_normal, want_albedo) = if disc > 1e-3 {
                let t = -b - disc.sqrt();
                on_sphere += 1;
                (t, (o + d * t - centre) / radius, Vec3::new(0.9, 0.1, 0.3))
            } else if disc < -1e-3 {
                on_plane += 1;
                ((-5.0 - o.z) / d.z, DVec3::Z, Vec3::new(0.2, 0.5, 0.7))
            } else {
                continue;
            };
            let at = format!("pixel ({x}, {y})");
            assert!((f64::from(depth[i]) - want_depth).abs() <= 1e-5 * want_depth, "{at}: depth {} vs {want_depth}", depth[i]);
            assert!((normal[i].as_dvec3() - want_normal).length() <= 1e-5, "{at}: normal {} vs {want_normal}", normal[i]);
            assert!((albedo[i] - want_albedo).abs().max_element() <= 1e-6, "{at}: albedo {} vs {want_albedo}", albedo[i]);
        }
    }
    assert!(on_sphere > 50 && on_plane > 500, "{on_sphere} pixels on the sphere, {on_plane} on the plane");
}
