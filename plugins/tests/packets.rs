//! Camera rays in packets through the scene's hierarchy of analytic shapes: every pixel is
//! exactly what the single-ray path (`render_pixel`) gives, at 1, 2 and 3 threads, in passes,
//! with layers, at one sample per pixel (8 pixels of a row a packet) and several (the samples of
//! one pixel a packet, with a short packet where `spp` is not a multiple of 8).

use raylab::Intersectable;
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::render::{RenderJob, RenderOptions, render, render_pixel, render_progressive};
use std::fmt::Write as _;

mod common;

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

/// A bundled Whitted speed scene (`scenes/<name>.toml`) at `width` × `height` and `spp`, every
/// ray to depth 5 (`prune_threshold = 0`, as `benches/peers/run.sh` renders it).
fn bundled(name: &str, width: u32, height: u32, spp: u32) -> RenderJob {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes").join(format!("{name}.toml"));
    let text = std::fs::read_to_string(&path).unwrap();
    for line in ["width = 800\n", "height = 600\n", "max_depth = 5\n"] {
        assert!(text.contains(line), "{name}.toml: no `{line}`");
    }
    let text = text
        .replace("width = 800\n", &format!("width = {width}\n"))
        .replace("height = 600\n", &format!("height = {height}\nspp = {spp}\n"))
        .replace("max_depth = 5\n", "max_depth = 5\nprune_threshold = 0\n");
    load_str(&raylab_plugins::registry(), &format!("{name}.toml"), &text, std::path::Path::new("."), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.report()))
}

/// The Whitted speed scenes, `dozen` (a dozen objects: a hierarchy with the `bvh` feature, whose
/// camera rays go in packets and whose camera hits are shaded as blocks; two point lights) and
/// `whitted` (three spheres: a list, one ray at a time; glass; a point and a spot light), every
/// ray to depth 5, render exactly what the single-ray path (`render_pixel`) renders, pixel for
/// pixel and counter for counter, at 1, 2 and 3 threads and in passes, at one sample per pixel
/// and several (the samples of a pixel a packet).
#[test]
fn whitted_scenes_render_what_single_rays_render() {
    for (name, spp) in [("dozen", 1), ("whitted", 1), ("dozen", 5), ("whitted", 3)] {
        let (width, height) = (45, 29);
        let job = bundled(name, width, height, spp);
        if name == "dozen" {
            assert_eq!(job.scene.walks_packets(), raylab::accel::BVH_AVAILABLE, "dozen: packets through its hierarchy");
        }
        let mut stats = raylab::RayStats::new(job.integrator.counters());
        let single: Vec<_> =
            (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| render_pixel(&job, x, y, &mut stats)).collect();
        let compare = |rendered: &raylab::render::Rendered, what: &str| {
            for (i, c) in single.iter().enumerate() {
                let (x, y) = (i as u32 % width, i as u32 / width);
                assert_eq!(rendered.film.get(x, y), *c, "{name}: pixel ({x}, {y}), {spp} spp, {what}");
            }
            assert_eq!(rendered.stats.camera_rays, stats.camera_rays, "{name}, {what}");
            for (i, c) in job.integrator.counters().iter().enumerate() {
                assert_eq!(rendered.stats.count(i), stats.count(i), "{name}, {what}: counter {}", c.name);
            }
        };
        assert!(stats.count(0) > u64::from(width * height * spp), "{name}: shadow rays");
        for threads in [1, 2, 3] {
            let options = RenderOptions { threads: Some(threads), layers: threads == 2, ..Default::default() };
            compare(&render(&job, &options, &|_, _| {}).unwrap(), &format!("{threads} thread(s)"));
        }
        let options = RenderOptions { threads: Some(2), ..Default::default() };
        let passes = render_progressive(&job, &options, &[1, 3, 8], &|_, _| {}, &mut |_| {}).unwrap();
        compare(&passes, "in passes");
    }
}

/// Phong's block of camera hits on the Whitted speed scenes (two one-sample lights each; mirrors
/// and glass, whose hits go through the recursion) gives each lane exactly what `radiance_from`
/// gives it lane by lane: colour, layers and every counter, under work budgets that run out
/// anywhere inside the block.
#[test]
fn a_block_of_whitted_camera_hits_shades_as_single_hits() {
    let mut blocks = 0;
    for name in ["dozen", "whitted"] {
        let (width, height) = (64, 48);
        let job = bundled(name, width, height, 1);
        for y in (0..height).step_by(5) {
            for x0 in (0..width).step_by(8) {
                for live in [0xff, 0b1011_0110] {
                    let allowances = (0..=40).step_by(3).chain([u64::MAX]);
                    blocks += common::blocks::assert_block_shades_as_single_hits(&job, name, (x0, y), live, allowances);
                }
            }
        }
    }
    assert!(blocks > 1000);
}
