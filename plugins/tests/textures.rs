//! Textures in scene files: named and inline, read only when a material uses them and once
//! however often they are used, through the sandbox and the limits, with errors that name the
//! file, the texture and the material colour.

use raylab::load::context::LoadOptions;
use raylab::load::loader::load_file;
use raylab::param::files::OpenLog;
use raylab::{RenderJob, SceneError};
use std::path::{Path, PathBuf};

const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";

/// A fresh folder under the system's temporary one.
fn fresh_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("raylab-textures-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A `w`×`h` PNG of one colour.
fn png(w: u32, h: u32, rgb: [u8; 3]) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    let pixels: Vec<u8> = (0..w * h).flat_map(|_| rgb).collect();
    image::codecs::png::PngEncoder::new(&mut out).write_image(&pixels, w, h, image::ExtendedColorType::Rgb8).unwrap();
    out
}

/// Loads `scene` (TOML, the camera added) written into `dir`, logging the files opened.
fn load(dir: &Path, scene: &str, options: LoadOptions) -> (Result<RenderJob, SceneError>, Vec<PathBuf>) {
    std::fs::write(dir.join("scene.toml"), format!("{CAMERA}{scene}")).unwrap();
    let log = OpenLog::default();
    let options = LoadOptions { open_log: Some(log.clone()), ..options };
    let job = load_file(&raylab_plugins::registry(), &dir.join("scene.toml"), &options);
    let opened = log.lock().unwrap().clone();
    (job, opened)
}

fn error(dir: &Path, scene: &str) -> String {
    match load(dir, scene, LoadOptions::default()).0 {
        Ok(_) => panic!("expected an error for:\n{scene}"),
        Err(e) => e.report(),
    }
}

/// One image named by a texture two materials use and by an inline texture is read once; a
/// texture no material uses is not read at all (its file may be missing), with a warning.
#[test]
fn images_are_read_once_and_only_when_used() {
    let dir = fresh_dir("once");
    std::fs::write(dir.join("red.png"), png(2, 2, [255, 0, 0])).unwrap();
    let scene = r#"
[textures.red]
type = "image"
file = "red.png"
[textures.unused]
type = "image"
file = "missing.png"
[materials.a]
kd = "red"
[materials.b]
ks = "red"
[[object]]
type = "sphere"
material = "a"
[[object]]
type = "sphere"
center = [3, 0, 0]
material = { emission = { type = "image", file = "red.png", scale = 2 } }
"#;
    let (job, opened) = load(&dir, scene, LoadOptions::default());
    let job = job.unwrap_or_else(|e| panic!("{}", e.report()));
    let reads = opened.iter().filter(|p| p.ends_with("red.png")).count();
    assert_eq!(reads, 1, "{opened:?}");
    assert!(!opened.iter().any(|p| p.ends_with("missing.png")));
    let warnings: Vec<String> = job.warnings.iter().map(SceneError::report).collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains("texture \"unused\" is not used by any material"), "{}", warnings[0]);
    // The textured material multiplies its constant (1 for a named texture) by the texels.
    let m = &job.scene.objects[0].materials()[0];
    let c = m.at(|| raylab::scene::texture::TexturePoint::new(raylab::glam::DVec2::new(0.5, 0.5), raylab::glam::DVec3::ZERO));
    assert_eq!(c.kd, raylab::glam::DVec3::X);
    let e = &job.scene.objects[1].materials()[0];
    assert_eq!(
        e.at(|| raylab::scene::texture::TexturePoint::new(raylab::glam::DVec2::ZERO, raylab::glam::DVec3::ZERO)).emission,
        raylab::glam::DVec3::new(2.0, 0.0, 0.0)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Every mistake names where it was made and what was expected.
#[test]
fn texture_errors_name_the_texture_the_colour_and_the_file() {
    let dir = fresh_dir("errors");
    std::fs::write(dir.join("notes.png"), "not an image").unwrap();
    let sphere = |material: &str| format!("[[object]]\ntype = \"sphere\"\nmaterial = {material}\n");
    let cases: Vec<(String, &[&str])> = vec![
        (
            format!("[textures.tiles]\ntype = \"checker\"\n{}", sphere("{ kd = \"tile\" }")),
            &["no texture named \"tile\"", "did you mean \"tiles\"", "parameter `kd`", "scene.toml:"],
        ),
        (sphere("{ kd = \"wood\" }"), &["no texture named \"wood\"", "no textures are defined"]),
        (sphere("{ kd = { type = \"chequer\" } }"), &["unknown texture type \"chequer\"", "did you mean \"checker\""]),
        (sphere("{ kd = { even = 1 } }"), &["has no `type`", "texture types: checker, gradient, image, ring, stripes"]),
        (sphere("{ kd = { type = \"checker\", evn = 1 } }"), &["unknown parameter `evn`", "did you mean `even`"]),
        (sphere("{ kd = { type = \"image\", file = \"gone.png\" } }"), &["gone.png", "No such file"]),
        (sphere("{ kd = { type = \"image\", file = \"../outside.png\" } }"), &["leaves the scene's folder"]),
        (sphere("{ kd = { type = \"image\", file = \"notes.png\" } }"), &["notes.png", "not a PNG, JPEG, OpenEXR or Radiance .hdr image"]),
        (
            sphere("{ kd = { type = \"image\", file = \"notes.png\", wrap = \"tile\" } }"),
            &["unknown value \"tile\"", "repeat, clamp, mirror"],
        ),
        (sphere("{ kd = { type = \"ring\", coords = \"world\" } }"), &["unknown value \"world\"", "uv, uv1, object"]),
        (sphere("{ kd = { type = \"checker\", transform = { scale = 0 } } }"), &["`scale` must not be zero", "inline texture (checker)"]),
        (sphere("{ kd = true }"), &["expected a colour [r, g, b], a number, a texture name or an inline texture table"]),
        ("[textures]\nwood = 3\n".to_string(), &["texture \"wood\" must be a table"]),
        (sphere("{ fresnel = \"fast\" }"), &["unknown value \"fast\"", "off, schlick, exact"]),
        (sphere("{ fresnel = 1 }"), &["expected \"off\", \"schlick\", \"exact\" or true/false"]),
    ];
    for (scene, needles) in cases {
        let e = error(&dir, &scene);
        for n in needles {
            assert!(e.contains(n), "expected \"{n}\" in:\n{e}\nfor:\n{scene}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An image's size is checked from its header against the pixel limit, and its texels are
/// charged to the memory budget before they are decoded.
#[test]
fn images_stay_within_the_limits() {
    let dir = fresh_dir("limits");
    std::fs::write(dir.join("big.png"), png(300, 200, [9, 9, 9])).unwrap();
    let scene =
        "[render]\nwidth = 8\nheight = 8\n[[object]]\ntype = \"sphere\"\nmaterial = { kd = { type = \"image\", file = \"big.png\" } }\n";
    let mut options = LoadOptions::default();
    options.limits.max_pixels = 50_000;
    let e = load(&dir, scene, options.clone()).0.err().unwrap().report();
    assert!(e.contains("300×200 = 60000 pixels, over the limit of 50000 pixels"), "{e}");
    assert!(e.contains("--max-pixels"), "{e}");
    options.limits.max_pixels = 1 << 26;
    // A budget that holds a tiny film and the scene, not the image's 2 × 180 kB.
    options.limits.max_memory = 200_000;
    let e = load(&dir, scene, options).0.err().unwrap().report();
    assert!(e.contains("big.png") && e.contains("(300×200)") && e.contains("--max-memory"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `raylab plugins` lists the texture types with their parameters.
#[test]
fn the_plugin_listing_has_the_textures() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raylab")).arg("plugins").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let section = text.split("TEXTURES").nth(1).expect("a TEXTURES section");
    for t in ["checker", "stripes", "gradient", "ring", "image", "coords", "transform", "wrap", "colorspace"] {
        assert!(section.contains(t), "{t} missing from:\n{section}");
    }
}

/// An MTL's map outside the scene's folder is refused like any other file (a warning: the
/// material keeps its colour), and so is one that is not an image.
#[cfg(feature = "mesh")]
#[test]
fn mtl_maps_go_through_the_sandbox() {
    let root = fresh_dir("mtl");
    let dir = root.join("scene");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("outside.png"), png(1, 1, [1, 2, 3])).unwrap();
    std::fs::write(dir.join("m.obj"), "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n").unwrap();
    std::fs::write(dir.join("m.mtl"), "newmtl a\nKd 0.5 0.5 0.5\nmap_Kd ../outside.png\n").unwrap();
    let (job, opened) = load(&dir, "[[object]]\ntype = \"mesh\"\nfile = \"m.obj\"\n", LoadOptions::default());
    let job = job.unwrap_or_else(|e| panic!("{}", e.report()));
    assert!(!opened.iter().any(|p| p.ends_with("outside.png")), "{opened:?}");
    let w: Vec<String> = job.warnings.iter().map(SceneError::report).collect();
    assert!(w.iter().any(|w| w.contains("map_Kd ../outside.png") && w.contains("leaves the scene's folder")), "{w:?}");
    assert!(job.scene.objects[0].materials()[0].textures.is_empty());
    std::fs::remove_dir_all(&root).unwrap();
}

/// The `texture_image` fuzz corpus's seeds read as they should under the fuzz target's limits:
/// valid PNG, JPEG and OpenEXR files of every layout decode to their size with finite,
/// non-negative texels; a header declaring too large an image is refused from the header; other
/// malformed files are errors naming the file (the replay of every file is in
/// `tests/fuzz_corpus.rs`).
#[test]
fn the_texture_fuzz_seeds_decode_or_fail_as_expected() {
    use raylab::LoadContext;
    use raylab_plugins::textures::image::{ColorSpace, decode};
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus/texture_image");
    let options = LoadOptions { limits: raylab_plugins::textures::fuzz::limits(), ..LoadOptions::default() };
    let read = |name: &str| {
        let ctx = LoadContext::new(Path::new("."), &options);
        decode(&std::fs::read(dir.join(name)).unwrap(), name, ColorSpace::Auto, &ctx)
    };
    let mut valid = vec![
        ("png-rgb8-4x3.png", (4, 3)),
        ("png-rgba8-2x2.png", (2, 2)),
        ("png-gray8-3x1.png", (3, 1)),
        ("png-gray16-2x2.png", (2, 2)),
        ("png-rgb16-2x2.png", (2, 2)),
        ("png-palette-2x2.png", (2, 2)),
        ("png-1bit-9x2.png", (9, 2)),
        ("png-interlaced-5x5.png", (5, 5)),
        ("png-zlib-bomb-1024x1024-rgba16.png", (1024, 1024)),
        ("jpeg-baseline-16x8.jpg", (16, 8)),
        ("jpeg-progressive-16x8.jpg", (16, 8)),
        ("jpeg-gray-8x8.jpg", (8, 8)),
        ("jpeg-subsampled-odd-7x5.jpg", (7, 5)),
        ("hdr-flat-2x2.hdr", (2, 2)),
        ("hdr-rle-16x4.hdr", (16, 4)),
    ];
    if cfg!(feature = "exr") {
        valid.extend([("exr-half-rgb-2x2.exr", (2, 2)), ("exr-float-rgb-2x2.exr", (2, 2)), ("exr-nan-inf-negative.exr", (2, 2))]);
    }
    for (name, size) in valid {
        let image = read(name).unwrap_or_else(|e| panic!("{name}: {}", e.report()));
        assert_eq!(image.size(), size, "{name}");
        assert!(raylab_plugins::textures::fuzz::check_bytes(&std::fs::read(dir.join(name)).unwrap()).is_ok(), "{name}");
    }
    let mut too_large = vec![
        ("png-huge-100000x100000.png", "100000×100000 = 10000000000 pixels, over the limit"),
        ("png-huge-side-65536x1.png", "65536×1 = 65536 pixels, over the limit"),
        ("png-over-pixels-2048x2048.png", "2048×2048 = 4194304 pixels, over the limit"),
        ("jpeg-huge-65535x65535.jpg", "65535×65535 = 4294836225 pixels, over the limit"),
    ];
    if cfg!(feature = "exr") {
        too_large.extend([
            ("exr-huge-data-window.exr", "100000×100000 = 10000000000 pixels, over the limit"),
            ("exr-over-pixels-2048x2048.exr", "2048×2048 = 4194304 pixels, over the limit"),
        ]);
    }
    for (name, want) in too_large {
        let e = read(name).err().unwrap_or_else(|| panic!("{name} was read"));
        assert!(e.report().contains(want), "{name}: {}", e.report());
    }
    for name in ["png-bad-ihdr-crc.png", "png-truncated-header.png", "png-zero-width.png", "jpeg-bad-marker.jpg", "jpeg-only-soi.jpg"] {
        let e = read(name).err().unwrap_or_else(|| panic!("{name} was read"));
        assert!(e.where_().is_some_and(|w| w.starts_with(name)), "{name}: {}", e.report());
    }
}
