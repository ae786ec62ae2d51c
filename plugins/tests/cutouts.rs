//! Cut-outs: a quad whose texture's alpha cuts it away in a checkerboard (an OBJ with its MTL's
//! `map_d`, a glTF with `alphaMode = MASK` and `BLEND`), made here: camera rays, secondary rays
//! and shadow rays pass through the holes, so the shadow on the floor is a checkerboard too.
#![cfg(feature = "mesh")]

use raylab::Ray;
use raylab::glam::DVec3;
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_file;
use raylab::render::RenderJob;
use std::path::{Path, PathBuf};

/// Cells of the checkerboard per side of the quad.
const CELLS: u32 = 4;

/// A fresh folder under the system's temporary one.
fn fresh_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("raylab-cutouts-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A 64 × 64 RGBA checkerboard of `CELLS`² cells: opaque red where the cell's column and row
/// (counted from the image's bottom left, as `v` runs up) add up to an even number, fully
/// transparent elsewhere.
fn checker_png() -> Vec<u8> {
    use image::ImageEncoder;
    let n = 64u32;
    let cell = n / CELLS;
    let mut px = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let (cu, cv) = (x / cell, (n - 1 - y) / cell);
            px.extend_from_slice(if (cu + cv) % 2 == 0 { &[220, 30, 30, 255] } else { &[0, 0, 0, 0] });
        }
    }
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out).write_image(&px, n, n, image::ExtendedColorType::Rgba8).unwrap();
    out
}

/// True where the checkerboard is opaque, at a point (x, z) over the quad (which spans
/// [-1, 1]² in x and z, with u along x and v along −z).
fn opaque_at(x: f64, z: f64) -> bool {
    let (u, v) = ((x + 1.0) / 2.0, (1.0 - z) / 2.0);
    let (cu, cv) = ((u * f64::from(CELLS)) as u32, (v * f64::from(CELLS)) as u32);
    (cu + cv) % 2 == 0
}

/// The quad at height 1 facing up, as OBJ + MTL (`map_d`) and as glTF (`alpha_mode`, with
/// `extra` material JSON), its texture the checkerboard; written into `dir`.
fn write_assets(dir: &Path, alpha_mode: &str, extra: &str) {
    std::fs::write(dir.join("checker.png"), checker_png()).unwrap();
    std::fs::write(dir.join("quad.mtl"), "newmtl holes\nKd 1 1 1\nmap_Kd checker.png\nmap_d checker.png\n").unwrap();
    std::fs::write(
        dir.join("quad.obj"),
        "mtllib quad.mtl\nv -1 1 1\nv 1 1 1\nv 1 1 -1\nv -1 1 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl holes\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    // glTF's v runs down: (u, 1 − v) of the OBJ's coordinates.
    let mut blob = Vec::new();
    for p in [[-1.0f32, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, -1.0], [-1.0, 1.0, -1.0]] {
        p.iter().for_each(|c| blob.extend_from_slice(&c.to_le_bytes()));
    }
    for t in [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]] {
        t.iter().for_each(|c| blob.extend_from_slice(&c.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        blob.extend_from_slice(&i.to_le_bytes());
    }
    let data = base64(&blob);
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":0}}]}}],
"materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}},"metallicFactor":0}},"alphaMode":"{alpha_mode}"{extra}}}],
"textures":[{{"source":0}}],"images":[{{"uri":"checker.png"}}],
"buffers":[{{"byteLength":{len},"uri":"data:application/octet-stream;base64,{data}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},{{"buffer":0,"byteOffset":80,"byteLength":12}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,1,-1],"max":[1,1,1]}},
{{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},{{"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#,
        len = blob.len()
    );
    std::fs::write(dir.join("quad.gltf"), gltf).unwrap();
}

/// Standard base64 with padding.
fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk.iter().enumerate().fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for k in 0..4 {
            out.push(if k <= chunk.len() { ABC[(n >> (18 - 6 * k) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

/// A scene of the quad in `file` above a floor (y = 0), lit by a sun shining straight down.
fn load(dir: &Path, file: &str) -> RenderJob {
    let scene = format!(
        "[camera]\nposition = [0, 5, 0.01]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"plane\"\n\
         [[object]]\ntype = \"mesh\"\nfile = \"{file}\"\n[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\n"
    );
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    let job = load_file(&raylab_plugins::registry(), &dir.join("scene.toml"), &LoadOptions::default());
    job.unwrap_or_else(|e| panic!("{}", e.report()))
}

/// Points over the quad, at the centres of a fine grid (away from the cells' edges).
fn grid() -> impl Iterator<Item = (f64, f64)> {
    let n = 4 * CELLS;
    (0..n * n).map(move |k| {
        let (i, j) = (k % n, k / n);
        (-1.0 + (f64::from(i) + 0.5) * 2.0 / f64::from(n), -1.0 + (f64::from(j) + 0.5) * 2.0 / f64::from(n))
    })
}

/// Camera rays from above meet the quad on its opaque cells and the floor through its holes;
/// shadow rays from the floor toward the sun are blocked under the opaque cells only: the shadow
/// has the checkerboard's holes. For the OBJ's `map_d` and glTF's MASK alike.
#[test]
fn rays_of_every_kind_pass_through_the_holes_and_shadows_show_them() {
    let dir = fresh_dir("mask");
    write_assets(&dir, "MASK", ",\"alphaCutoff\":0.5");
    for file in ["quad.obj", "quad.gltf"] {
        let job = load(&dir, file);
        let warnings: Vec<String> = job.warnings.iter().map(|w| w.report()).filter(|w| !w.contains("has no lights")).collect();
        assert!(warnings.is_empty(), "{file}: {warnings:?}");
        let (mut holes, mut cells) = (0, 0);
        for (x, z) in grid() {
            let opaque = opaque_at(x, z);
            let hit = job.scene.trace(&Ray::new(DVec3::new(x, 3.0, z), -DVec3::Y)).expect("the floor is everywhere");
            let expected = if opaque { 2.0 } else { 3.0 };
            assert!((hit.hit.t - expected).abs() < 1e-9, "{file}: camera ray at ({x}, {z}): t = {}", hit.hit.t);
            // The shadow ray of the floor point below, and one from below the floor's side.
            let shadow = Ray::new(DVec3::new(x, 1e-9, z), DVec3::Y);
            let light = job.scene.transmittance(&shadow, f64::INFINITY);
            assert_eq!(light.x, if opaque { 0.0 } else { 1.0 }, "{file}: shadow ray at ({x}, {z})");
            // A secondary ray from beside the quad, obliquely through it, agrees with the test.
            let origin = DVec3::new(x - 0.5, 1.5, z);
            let through = Ray::new(origin, (DVec3::new(x, 1.0, z) - origin).normalize());
            let hit = job.scene.trace(&through).expect("quad or floor");
            assert_eq!(hit.hit.point.y.abs() > 0.5, opaque, "{file}: oblique ray toward ({x}, {z})");
            if opaque { cells += 1 } else { holes += 1 }
        }
        assert!(holes > 50 && cells > 50, "{holes} holes, {cells} cells");
    }
}

/// BLEND is stochastic transparency: a surface of coverage 0.3 (everywhere on the opaque cells:
/// the base colour factor's alpha) stops about 30 % of the rays, always the same ones for the
/// same ray, and none through the holes.
#[test]
fn blend_stops_a_fraction_of_rays_given_by_coverage_and_always_the_same() {
    let dir = fresh_dir("blend");
    write_assets(&dir, "BLEND", "");
    let text = std::fs::read_to_string(dir.join("quad.gltf")).unwrap();
    std::fs::write(dir.join("quad.gltf"), text.replace("\"metallicFactor\":0", "\"metallicFactor\":0,\"baseColorFactor\":[1,1,1,0.3]"))
        .unwrap();
    let job = load(&dir, "quad.gltf");
    let (mut stopped, mut tried) = (0u32, 0u32);
    for k in 0..20_000u32 {
        // Points spread over the opaque cells and holes alike, away from the cells' edges (where
        // the filtered coverage is between 0 and 1).
        let inner = |i: u32, n: u32| {
            let cell = f64::from(i % CELLS);
            -1.0 + 2.0 * (cell + 0.2 + 0.6 * f64::from(i / CELLS) / f64::from(n / CELLS)) / f64::from(CELLS)
        };
        let (x, z) = (inner(k % 200, 200), inner(k / 200, 100));
        let shadow = Ray::new(DVec3::new(x, 1e-9, z), DVec3::Y);
        let light = job.scene.transmittance(&shadow, f64::INFINITY).x;
        assert_eq!(light, job.scene.transmittance(&shadow, f64::INFINITY).x, "the same ray, the same answer");
        if !opaque_at(x, z) {
            assert_eq!(light, 1.0, "a hole at ({x}, {z})");
            continue;
        }
        tried += 1;
        stopped += u32::from(light == 0.0);
    }
    let fraction = f64::from(stopped) / f64::from(tried);
    // Binomial: 3σ of 10 000 trials at p = 0.3 is 0.014.
    assert!((fraction - 0.3).abs() < 0.014, "{stopped} of {tried} stopped: {fraction}");
}
