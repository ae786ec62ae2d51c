//! Normal and bump maps through the `raylab` binary: a strongly normal-mapped sphere filling the
//! frame (phong coefficients, a rough `pbr` dielectric, a smooth `pbr` metal), its silhouette
//! seen at grazing angles, renders with no black and no non-finite pixel in the path tracer and
//! in phong; a flat normal map renders byte for byte as no map at all; the
//! bundled normal-map scene (glTF normalTexture with MikkTSpace tangents, a `sphere` with
//! `normal_map`, an OBJ `bump` map) loads without a warning.

mod common;

use common::{raylab, repo, temp_dir, text};
use std::path::Path;

/// A white sphere of radius 1 at the origin filling most of a 96 × 96 frame, its material
/// `material`, under a white sky (path) or a light from the camera and an ambient term (phong).
fn sphere_scene(material: &str) -> String {
    format!(
        "background = 1.0\n[render]\nwidth = 96\nheight = 96\nspp = 8\n\
         [camera]\nposition = [0, 0, 3.2]\nlook_at = [0, 0, 0]\nfov = 40\n\
         [textures.tiles]\ntype = \"image\"\nfile = \"tiles-normal.png\"\ncolorspace = \"linear\"\n\
         [textures.flat]\ntype = \"checker\"\neven = [0.5, 0.5, 1]\nodd = [0.5, 0.5, 1]\n\
         [[object]]\ntype = \"sphere\"\nradius = 1\nmaterial = {material}\n\
         [[light]]\ntype = \"directional\"\ndirection = [0, 0, -1]\ncolor = 0.5\n\
         [[light]]\ntype = \"ambient\"\nka = 0.2\n"
    )
}

/// A fresh folder holding the bundled scenes' normal map.
fn folder(name: &str) -> std::path::PathBuf {
    let dir = temp_dir(name);
    std::fs::copy(repo().join("scenes/assets/tiles-normal.png"), dir.join("tiles-normal.png")).unwrap();
    dir
}

/// Renders `scene` (written into `dir` as `name.toml`) with `integrator` to `name.png`: its
/// pixels, and the binary's report.
fn render(dir: &Path, name: &str, scene: &str, integrator: &str) -> (image::RgbImage, String) {
    std::fs::write(dir.join(format!("{name}.toml")), scene).unwrap();
    let out = raylab(dir, &["render", &format!("{name}.toml"), "--integrator", integrator, "-o", &format!("{name}.png")]);
    let report = text(&out.stderr) + &text(&out.stdout);
    assert!(out.status.success(), "{report}");
    (image::open(dir.join(format!("{name}.png"))).unwrap().to_rgb8(), report)
}

/// Pixels well inside the sphere's silhouette (the frame's pixel centres whose camera ray meets
/// the sphere of radius 0.97: away from the anti-aliased rim).
fn inside(x: u32, y: u32) -> bool {
    let half = (40f64.to_radians() / 2.0).tan();
    let (px, py) = ((f64::from(x) + 0.5) / 48.0 - 1.0, 1.0 - (f64::from(y) + 0.5) / 48.0);
    let d = [px * half, py * half, -1.0];
    let len = (d[0] * d[0] + d[1] * d[1] + 1.0f64).sqrt();
    let dir = d.map(|c| c / len);
    // |o + t·dir|² = r² with o = (0, 0, 3.2): discriminant of the quadratic.
    let b = 3.2 * dir[2];
    b * b - (3.2 * 3.2 - 0.97 * 0.97) > 0.0
}

#[test]
fn strongly_normal_mapped_spheres_have_no_black_or_non_finite_pixel() {
    let dir = folder("grazing");
    // phong's coefficients, and `pbr`: a rough dielectric and a smooth metal (GGX lobes around
    // the bent normal).
    let materials = [
        "kd = 0.8, ks = 0.3, shininess = 20",
        "type = \"pbr\", base_color = 0.8, metallic = 0, roughness = 0.6",
        "type = \"pbr\", base_color = 0.9, metallic = 1, roughness = 0.05",
    ];
    for scale in [1.0, 4.0] {
        for base in materials {
            let material = format!("{{ {base}, normal_map = \"tiles\", normal_scale = {scale} }}");
            for integrator in ["path", "phong"] {
                let (img, report) = render(&dir, &format!("grazing-{integrator}"), &sphere_scene(&material), integrator);
                assert!(report.contains(" 0 non-finite samples"), "{integrator}, {base}, scale {scale}: {report}");
                let mut count = 0;
                for (x, y, p) in img.enumerate_pixels() {
                    if inside(x, y) {
                        count += 1;
                        assert!(p.0.iter().any(|&c| c > 8), "{integrator}, {base}, scale {scale}: pixel ({x}, {y}) is black: {p:?}");
                    }
                }
                assert!(count > 3000, "the sphere fills the frame ({count} pixels)");
            }
        }
    }
}

#[test]
fn a_flat_normal_map_changes_no_pixel() {
    let dir = folder("flat");
    for integrator in ["path", "phong"] {
        let (plain, _) = render(&dir, &format!("plain-{integrator}"), &sphere_scene("{ kd = 0.8, ks = 0.3, shininess = 20 }"), integrator);
        let (flat, _) = render(
            &dir,
            &format!("flat-{integrator}"),
            &sphere_scene("{ kd = 0.8, ks = 0.3, shininess = 20, normal_map = \"flat\" }"),
            integrator,
        );
        assert!(plain.as_raw() == flat.as_raw(), "{integrator}: a flat normal map changed the image");
        // And a real one does change it (the test can fail).
        let (tiles, _) = render(
            &dir,
            &format!("tiles-{integrator}"),
            &sphere_scene("{ kd = 0.8, ks = 0.3, shininess = 20, normal_map = \"tiles\" }"),
            integrator,
        );
        assert!(plain.as_raw() != tiles.as_raw(), "{integrator}: the tiles' normal map changed nothing");
    }
}

#[test]
fn a_material_has_a_normal_map_or_a_bump_map_not_both() {
    let dir = folder("both");
    let scene = sphere_scene("{ kd = 0.8, normal_map = \"tiles\", bump_map = \"tiles\" }");
    std::fs::write(dir.join("both.toml"), scene).unwrap();
    let out = raylab(&dir, &["render", "both.toml", "-o", "both.png"]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("not both"), "{}", text(&out.stderr));
}

#[cfg(feature = "mesh")]
#[test]
fn the_normal_map_scene_loads_without_warnings() {
    let dir = temp_dir("scene");
    let scene = repo().join("scenes/normal-map.toml");
    let out = raylab(&dir, &["render", &scene.to_string_lossy(), "--width", "160", "--height", "100", "--spp", "1", "-o", "small.png"]);
    let report = text(&out.stderr) + &text(&out.stdout);
    assert!(out.status.success(), "{report}");
    assert!(!report.to_lowercase().contains("warning"), "{report}");
    assert!(report.contains(" 0 non-finite samples"), "{report}");
}

/// The bundled glTF sphere has no TANGENTs: its MikkTSpace tangents lie in the tangent plane of
/// the vertex normal, along +u (as each triangle's own derivative along u points), with the
/// bitangent along +v (the normal map's green channel, up the image).
#[cfg(feature = "mesh")]
#[test]
fn mikktspace_tangents_follow_the_texture_coordinates() {
    use raylab::geometry::Hit;
    use raylab::glam::{DVec2, DVec3};
    let dir = temp_dir("mikk");
    let options = raylab::load::context::LoadOptions::default();
    let ctx = raylab::LoadContext::new(&dir, &options);
    let text = std::fs::read_to_string(repo().join("scenes/assets/tiles.gltf")).unwrap();
    let plain = text.replace("\"normalTexture\"", "\"unusedTexture\"");
    let mikk = raylab_plugins::mesh::mesh_from_bytes(&ctx, "tiles.gltf", "gltf", text.as_bytes()).unwrap();
    let own = raylab_plugins::mesh::mesh_from_bytes(&ctx, "tiles.gltf", "gltf", plain.as_bytes()).unwrap();
    let mut checked = 0;
    for slot in 0..mikk.triangle_count() as u32 {
        let mut hit = Hit::new(1.0, DVec3::ZERO, DVec3::ZERO);
        (hit.prim, hit.uv) = (slot, DVec2::splat(1.0 / 3.0));
        // Slots are the index's order, padding included (none there).
        let (Some([t, b]), Some([du, dv])) = (mikk.tangents(&hit), own.tangents(&hit)) else { continue };
        let n = mikk.interpolated_normal(&hit).unwrap();
        assert!(t.normalize().dot(n).abs() < 0.02, "slot {slot}: tangent {t} off the tangent plane of {n}");
        assert!((b.length() - t.length()).abs() < 0.02 * t.length() && b.dot(n).abs() < 0.02, "slot {slot}: {t} {b}");
        assert!(t.normalize().dot(du.normalize()) > 0.9, "slot {slot}: tangent {t} vs ∂p/∂u {du}");
        assert!(b.normalize().dot(dv.normalize()) > 0.9, "slot {slot}: bitangent {b} vs ∂p/∂v {dv}");
        checked += 1;
    }
    assert!(checked > mikk.triangle_count() * 9 / 10, "{checked} of {}", mikk.triangle_count());
}
