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
