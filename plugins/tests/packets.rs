//! Camera rays in packets through the scene's hierarchy of analytic shapes: every pixel is
//! exactly what the single-ray path (`render_pixel`) gives, at 1, 2 and 3 threads, in passes,
//! with layers, at one sample per pixel (8 pixels of a row a packet) and several (the samples of
//! one pixel a packet, with a short packet where `spp` is not a multiple of 8).

use raylab::Intersectable;
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::render::{RenderJob, RenderOptions, render, render_pixel, render_progressive};
use std::fmt::Write as _;

/// Spheres in a grid over a ground plane, some mirrors, and two pairs of coincident spheres of
/// different colours (ties: the hierarchy's tie rule gives the smaller slot, whatever the order
/// in which a packet meets the leaves).
fn scene(width: u32, height: u32, spp: u32) -> RenderJob {
    let mut text = format!(
        "[render]\nwidth = {width}\nheight = {height}\nspp = {spp}\n\
         [camera]\nposition = [0.3, 2.5, 7]\nlook_at = [0, 0.4, 0]\nfov = 50\n\
         [integrator]\ntype = \"phong\"\nmax_depth = 2\n\
         [[object]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 1, 0]\nmaterial = {{ kd = 0.6, ka = 1 }}\n\
         [[light]]\ntype = \"directional\"\ndirection = [-0.4, -1, -0.6]\ncolor = 1\n\
         [[light]]\ntype = \"ambient\"\ncolor = 1\nka = 0.1\n"
    );
    for i in 0..5 {
        for j in 0..4 {
            let (x, z) = (f64::from(i) * 1.3 - 2.6, f64::from(j) * 1.4 - 3.0);
            let r = 0.3 + 0.05 * f64::from((i * 3 + j) % 4);
            let kr = if (i + j) % 3 == 0 { 0.4 } else { 0.0 };
            writeln!(
                text,
                "[[object]]\ntype = \"sphere\"\ncenter = [{x}, {r}, {z}]\nradius = {r}\nmaterial = {{ kd = {}, ka = 1, kr = {kr} }}",
                0.3 + 0.03 * f64::from(i * 4 + j)
            )
            .unwrap();
        }
    }
    for (x, kd) in [(-0.6, 0.9), (-0.6, 0.2), (0.7, 0.8), (0.7, 0.1)] {
        writeln!(text, "[[object]]\ntype = \"sphere\"\ncenter = [{x}, 0.5, 1.5]\nradius = 0.5\nmaterial = {{ kd = {kd}, ka = 1 }}")
            .unwrap();
    }
    load_str(&raylab_plugins::registry(), "packets.toml", &text, std::path::Path::new("."), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.report()))
}

fn check(width: u32, height: u32, spp: u32) {
    let job = scene(width, height, spp);
    assert!(job.integrator.takes_camera_hits());
    assert_eq!(job.scene.walks_packets(), raylab::accel::BVH_AVAILABLE, "the render takes packets through the scene's hierarchy");
    let mut stats = raylab::RayStats::new(job.integrator.counters());
    let single: Vec<_> =
        (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| render_pixel(&job, x, y, &mut stats)).collect();
    let compare = |film: &raylab::Film, what: &str| {
        let mut lit = 0;
        for (i, c) in single.iter().enumerate() {
            let (x, y) = (i as u32 % width, i as u32 / width);
            assert_eq!(film.get(x, y), *c, "pixel ({x}, {y}), {spp} spp, {what}");
            lit += usize::from(c.max_element() > 0.2);
        }
        assert!(lit > single.len() / 4, "{lit} lit pixels");
    };
    for threads in [1, 2, 3] {
        let options = RenderOptions { threads: Some(threads), layers: threads == 2, ..Default::default() };
        compare(&render(&job, &options, &|_, _| {}).unwrap().film, &format!("{threads} thread(s)"));
    }
    let options = RenderOptions { threads: Some(2), ..Default::default() };
    let passes = render_progressive(&job, &options, &[1, 3, 8], &|_, _| {}, &mut |_| {}).unwrap();
    compare(&passes.film, "in passes");
}

#[test]
fn packets_of_one_sample_per_pixel_render_what_single_rays_render() {
    check(61, 37, 1);
}

#[test]
fn packets_of_a_pixels_samples_render_what_single_rays_render() {
    check(23, 17, 16);
    check(19, 13, 5);
}
