//! Meshes: loading OBJ, MTL, glTF and GLB (with transforms and instancing), clear errors for
//! malformed files, watertightness, and hierarchy-versus-list agreement.
#![cfg(feature = "mesh")]

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use raylab::accel::AccelChoice;
use raylab::geometry::{Geometry, Intersectable};
use raylab::glam::DVec3;
use raylab::load::context::LoadOptions;
use raylab::load::loader::{load_file, load_str};
use raylab::math::float::offset_ray_origin;
use raylab::render::RenderJob;
use raylab::{Color, Ray};
use raylab_plugins::mesh::MeshObject;
use raylab_plugins::mesh::triangle_mesh::{MeshData, Normals, TriangleMesh};
use std::path::{Path, PathBuf};
use std::sync::Arc;

mod common;

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets")
}

fn options(accel: AccelChoice) -> LoadOptions {
    LoadOptions { accel, ..LoadOptions::default() }
}

/// Loads a TOML scene written in the test-assets folder.
fn scene(body: &str, accel: AccelChoice) -> Result<RenderJob, raylab::SceneError> {
    let text = format!("[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n{body}");
    load_str(&raylab_plugins::registry(), "test.toml", &text, &assets(), &options(accel))
}

/// The error of a load that must fail.
fn fails(r: Result<RenderJob, raylab::SceneError>) -> raylab::SceneError {
    match r {
        Ok(_) => panic!("the scene loaded, but should not"),
        Err(e) => e,
    }
}

fn down(job: &RenderJob, origin: DVec3, dir: DVec3) -> Option<raylab::Hit> {
    job.scene.intersect(&Ray::new(origin, dir), 0.0, f64::INFINITY)
}

/// The interaction of a ray from `origin` along `dir`.
fn look(job: &RenderJob, origin: DVec3, dir: DVec3) -> Option<raylab::scene::interaction::Interaction<'_>> {
    job.scene.trace(&Ray::new(origin, dir))
}

#[test]
fn obj_quads_are_triangulated_and_mtl_materials_mapped() {
    let job = scene("[[object]]\ntype = \"mesh\"\nfile = \"cube.obj\"\n", AccelChoice::Auto).unwrap();
    let o = &job.scene.objects[0];
    let si = look(&job, DVec3::new(0.3, 5.0, 0.6), -DVec3::Y).expect("top face");
    assert!((si.hit.t - 4.0).abs() < 1e-12 && (o.geometry().outward_normal(&si.hit) - DVec3::Y).length() < 1e-12);
    let glass = si.coefficients();
    assert_eq!((glass.kt, glass.ior), (Color::splat(0.75), 1.45f32 as f64), "d 0.25 → kt 0.75; Ni → ior");
    assert_eq!(glass.kr, glass.ks, "illum 7 mirrors with Ks");
    assert!((glass.kd - Color::splat(0.25)).length() < 1e-6, "Kd scaled by d");
    let red = look(&job, DVec3::new(0.3, 0.6, -5.0), DVec3::Z).expect("back face").coefficients();
    assert_eq!((red.kd.x as f32, red.shininess, red.emission.x as f32), (0.8, 40.0, 0.1));
    assert!(o.may_transmit() && o.is_closed(), "a cube of consistently wound quads is closed");
}

#[test]
fn concave_faces_stay_inside_their_outline_and_vertex_normals_shade() {
    let job = scene("[[object]]\ntype = \"mesh\"\nfile = \"concave.obj\"\n", AccelChoice::Auto).unwrap();
    // The notch of the L (x, z in (1, 2)) is empty; a fan from the first corner would cover it.
    assert!(down(&job, DVec3::new(1.5, 1.0, 1.5), -DVec3::Y).is_none());
    for (x, z) in [(0.5, 0.5), (1.5, 0.5), (0.5, 1.5)] {
        let si = look(&job, DVec3::new(x, 1.0, z), -DVec3::Y).expect("inside the L");
        assert!((si.ns - DVec3::Y).length() < 1e-6);
    }
}

#[test]
fn transforms_place_meshes_and_one_file_is_stored_once() {
    let body = "[[object]]\ntype = \"mesh\"\nfile = \"cube.obj\"\ntransform = { translate = [5, 0, 0] }\n\
                [[object]]\ntype = \"mesh\"\nfile = \"cube.obj\"\ntransform = [{ scale = [2, 1, 1] }, { rotate = [0, 90, 0] }]\n";
    let job = scene(body, AccelChoice::Bvh).unwrap();
    let a = job.scene.accel_summary();
    assert_eq!(a.object_builds.primitives, 12, "the cube's 12 triangles are indexed once for both objects");
    let h = down(&job, DVec3::new(5.5, 5.0, 0.5), -DVec3::Y).unwrap();
    assert_eq!((h.object, h.t), (0, 4.0));
    // Scaled ×2 along x, then turned 90° about y: x ∈ [0, 1], z ∈ [−2, 0].
    let h = down(&job, DVec3::new(0.5, 5.0, -1.9), -DVec3::Y).unwrap();
    assert_eq!(h.object, 1);
    assert!(down(&job, DVec3::new(0.5, 5.0, 0.5), -DVec3::Y).is_none());
    let g = job.scene.objects[1].geometry();
    let side = down(&job, DVec3::new(0.5, 0.5, -9.0), DVec3::Z).unwrap();
    assert!((g.outward_normal(&side) + DVec3::Z).length() < 1e-9, "normals follow the transform");
}

#[test]
fn gltf_and_glb_give_the_same_scene_with_camera_light_and_instances() {
    let reg = raylab_plugins::registry();
    let a = load_file(&reg, &assets().join("pyramids.gltf"), &LoadOptions::default()).unwrap();
    let b = load_file(&reg, &assets().join("pyramids.glb"), &LoadOptions::default()).unwrap();
    for job in [&a, &b] {
        assert_eq!(job.scene.objects.len(), 2);
        assert_eq!(job.scene.accel_summary().object_builds.primitives, 6, "one pyramid, placed twice");
        assert_eq!((job.settings.width, job.settings.height), (800, 533));
        assert!((job.scene.camera.position - DVec3::new(0.0, 1.5, 8.0)).length() < 1e-9);
        assert_eq!(job.scene.light_names.len(), 1);
        // The parent's scale (×2 in y) reaches the child: its apex is at y = 3.
        let si = look(job, DVec3::new(1.5, 10.0, 0.0), -DVec3::Y).unwrap();
        assert!((si.hit.point.y - 3.0).abs() < 1e-6, "{}", si.hit.point);
        assert_eq!(si.coefficients().kd, Color::ZERO, "a metal has no diffuse term");
        assert!(job.scene.objects[0].is_closed());
    }
    for (ga, gb) in a.scene.objects.iter().zip(&b.scene.objects) {
        assert_eq!(ga.geometry().bounds(), gb.geometry().bounds());
    }
}

#[test]
fn a_gltf_file_is_also_one_object_in_a_raylab_scene() {
    let job = scene("[[object]]\ntype = \"mesh\"\nfile = \"pyramids.glb\"\ntransform = { translate = [0, -10, 0] }\n", AccelChoice::Auto)
        .unwrap();
    assert_eq!(job.scene.objects.len(), 1);
    let h = down(&job, DVec3::new(1.5, 0.0, 0.0), -DVec3::Y).unwrap();
    assert!((h.point.y + 7.0).abs() < 1e-6);
    let job = scene("[[object]]\ntype = \"mesh\"\nfile = \"Box.gltf\"\nmesh = 0\nmaterial = { kd = 0.5 }\n", AccelChoice::Auto).unwrap();
    assert_eq!(job.scene.objects[0].materials()[0].kd, Color::splat(0.5));
    let e = fails(scene("[[object]]\ntype = \"mesh\"\nfile = \"Box.gltf\"\nmesh = 7\n", AccelChoice::Auto));
    assert!(e.message.contains("no mesh 7"), "{e}");
}

/// Loads `file` from the malformed folder as a mesh object.
fn malformed(file: &str) -> Result<RenderJob, raylab::SceneError> {
    let text = format!("[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"mesh\"\nfile = \"{file}\"\n");
    load_str(&raylab_plugins::registry(), "test.toml", &text, &assets().join("malformed"), &LoadOptions::default())
}

#[test]
fn malformed_files_load_or_fail_clearly_and_never_panic() {
    // (file, None when it must load, else words the error must contain)
    let cases: &[(&str, Option<&str>)] = &[
        ("box_UTF16BE.obj", Some("UTF-16")),
        ("box_longline.obj", None),
        ("box_without_lineending.obj", None),
        ("invalid-face-definition.obj", Some("no faces with three or more corners")),
        ("invalid-relative-texture-index.obj", Some("refers to vertex 1, but only 0 are defined")),
        ("invalid-relative-vertex-index.obj", Some("refers to vertex -4")),
        ("issue-140-zero-face-idx.obj", Some("refers to vertex 0")),
        ("issue-161-inconsistent-f.obj", Some("cube.mtl")), // its `mtllib` names a file that is not there
        ("issue-295-trianguation-failure.obj", None),
        ("missing_material_file.obj", None),         // `mtllib` commented out: the default material
        ("test-nan.obj", Some("test-nan.obj:14:1")), // `v 1.#IND …` is no number
        ("tobj-invalid_index.obj", Some("refers to vertex 7")),
        ("AllIndicesOutOfRange.gltf", Some("out of range")),
        ("IndexOutOfRange.gltf", Some("out of range")),
        ("BoxWithInfinites.glb", Some("POSITION\"].min: Missing data")),
        ("missing-bin/MissingBin-BoxTextured.gltf", Some("buffer 0 (\"BoxTextured0.bin\")")),
        ("badArray.gltf", Some("invalid glTF")),
        ("badExtension.gltf", None), // a malformed texture transform: a warning, the texture untransformed
        ("badNumber.gltf", Some("invalid glTF")),
        ("badObject.gltf", Some("invalid glTF")),
        ("badString.gltf", Some("invalid glTF")),
        ("badUint.gltf", Some("invalid glTF")),
        ("minimal_accessor_invalid.gltf", Some("invalid glTF")),
        ("non_sparse_accessor_without_buffer_view.gltf", Some("")),
        ("sceneWrongType.gltf", Some("invalid glTF")),
    ];
    let mut wrong = Vec::new();
    for (file, expect) in cases {
        let r = std::panic::catch_unwind(|| malformed(file));
        let Ok(r) = r else {
            wrong.push(format!("{file}: panicked"));
            continue;
        };
        let stem = file.rsplit_once('.').map_or(*file, |(s, _)| s).rsplit('/').next().unwrap_or(file);
        match (expect, r) {
            (None, Ok(job)) => assert!(job.scene.accel_summary().object_builds.primitives > 0, "{file}"),
            (None, Err(e)) => wrong.push(format!("{file} should load: {}", e.report())),
            (Some(_), Ok(_)) => wrong.push(format!("{file} should be an error")),
            (Some(words), Err(e)) => {
                let report = e.report();
                // The error names the mesh file (as its location, or in the message when the
                // location is the scene line that names it).
                if !report.contains(words) || !report.contains(stem) || e.where_().is_none() {
                    wrong.push(format!("{file}: expected \"{words}\" and the file's name: {report}"));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    // OBJ errors name the line.
    let e = fails(malformed("issue-140-zero-face-idx.obj"));
    assert!(e.where_().unwrap().ends_with("issue-140-zero-face-idx.obj:16:1"), "{}", e.report());
    // A material override makes a missing library irrelevant.
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"mesh\"\nfile = \"issue-161-inconsistent-f.obj\"\nmaterial = { kd = 0.5 }\n";
    load_str(&raylab_plugins::registry(), "t.toml", text, &assets().join("malformed"), &LoadOptions::default()).unwrap();
}

/// The fuzz targets' corpora (`fuzz/corpus/mesh_*`): every file loads or fails with a located
/// error, without panicking (what `cargo fuzz run mesh_obj` checks at length).
#[test]
fn fuzz_corpora_load_or_fail_cleanly() {
    let options = LoadOptions::default();
    let dir = assets();
    let ctx = raylab::LoadContext::new(&dir, &options);
    for (target, ext) in [("mesh_obj", "obj"), ("mesh_gltf", "gltf")] {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus").join(target);
        let files: Vec<PathBuf> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
        assert!(files.len() >= 5, "{}: corpus too small", dir.display());
        for f in files {
            let bytes = std::fs::read(&f).unwrap();
            let r =
                std::panic::catch_unwind(|| raylab_plugins::mesh::mesh_from_bytes(&ctx, "fuzz", ext, &bytes).map(|m| m.triangle_count()));
            match r {
                Err(_) => panic!("{}: panicked", f.display()),
                Ok(Err(e)) => assert!(e.where_().is_some(), "{}: error without a location: {e}", f.display()),
                Ok(Ok(n)) => assert!(n > 0),
            }
        }
    }
}

#[test]
fn files_outside_the_scene_folder_and_unknown_formats_are_refused() {
    let e = fails(scene("[[object]]\ntype = \"mesh\"\nfile = \"../scenes/assets/teapot.obj\"\n", AccelChoice::Auto));
    assert!(e.message.contains("leaves the scene's folder"), "{e}");
    let e = fails(scene("[[object]]\ntype = \"mesh\"\nfile = \"cube.stl\"\n", AccelChoice::Auto));
    assert!(e.message.contains("unknown mesh format"), "{e}");
    let e = fails(scene("[[object]]\ntype = \"mesh\"\nfile = \"cube.obj\"\nnormals = \"smoth\"\n", AccelChoice::Auto));
    assert!(e.help.unwrap().contains("smooth"));
}

/// A closed, star-shaped mesh: an icosphere refined `levels` times, each vertex moved radially
/// by a random factor in [0.8, 1.2].
fn perturbed_sphere(levels: u32, seed: u64) -> MeshData {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut p: Vec<DVec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&v| DVec3::from(v).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for [a, b, c] in f {
            let mut m = |i: u32, j: u32| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    p.push(((p[i as usize] + p[j as usize]) * 0.5).normalize());
                    p.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    let mut rng = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let positions = p
        .iter()
        .map(|v| {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let k = 0.8 + 0.4 * ((rng >> 11) as f64 / (1u64 << 53) as f64);
            (*v * k).as_vec3().to_array()
        })
        .collect();
    MeshData { positions, triangles: f, ..MeshData::default() }
}

fn sphere_mesh(levels: u32, seed: u64, accel: AccelChoice) -> (Arc<MeshObject>, MeshData) {
    let data = perturbed_sphere(levels, seed);
    let mesh = TriangleMesh::new(data.clone(), Normals::Flat, accel).unwrap();
    (Arc::new(MeshObject::new(Arc::new(mesh))), data)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, rng_seed: RngSeed::Fixed(raylab::testing::seed("mesh.rs: watertight and spawned rays")), ..ProptestConfig::default() })]

    /// Rays from inside a closed mesh always hit it, including rays aimed exactly at its vertices
    /// and at points on its edges (where two triangles meet), with a hierarchy and with a list.
    #[test]
    fn closed_meshes_are_watertight(seed in any::<u64>(), inside in prop::array::uniform3(-0.5f64..0.5), scale in prop::sample::select(vec![1e-4, 1.0, 1e4])) {
        for accel in [AccelChoice::Bvh, AccelChoice::List] {
            let (g, data) = sphere_mesh(2, seed, accel);
            prop_assert!(g.is_closed());
            let o = DVec3::from(inside) * 0.6;
            let v = |i: u32| DVec3::from(data.positions[i as usize].map(f64::from));
            let mut targets: Vec<DVec3> = data.positions.iter().map(|q| DVec3::from(q.map(f64::from))).collect();
            for t in &data.triangles {
                for k in 0..3 {
                    let (a, b) = (v(t[k]), v(t[(k + 1) % 3]));
                    targets.extend([a + (b - a) * 0.5, a + (b - a) * 0.25]);
                }
            }
            for target in targets {
                // The whole configuration scaled: watertightness must not depend on the scale.
                let t = Transform3 { s: scale };
                let ray = Ray::new(t.p(o), target - o);
                let hit = t.mesh_hit(&g, &ray);
                prop_assert!(hit.is_some(), "ray from {o} toward {target} escaped (scale {scale}, {accel:?})");
            }
        }
    }

    /// A ray leaving a hit point (offset by its error bound) never reports its own triangle, in
    /// either direction; inward it meets the far side of the closed mesh. The hits spread over
    /// the surface (rays from anywhere inside, in any direction) and the mesh is placed at scales
    /// 10⁻⁴, 1 and 10⁴ (through a transform, so rounding happens at that scale).
    #[test]
    fn spawned_rays_never_rehit_their_own_triangle(
        seed in any::<u64>(),
        inside in prop::array::uniform3(-0.5f64..0.5),
        dir in prop::array::uniform3(-1.0f64..1.0),
        scale in prop::sample::select(vec![1e-4, 1.0, 1e4]),
    ) {
        let (g, _) = sphere_mesh(2, seed, AccelChoice::Bvh);
        let placed = raylab::Transformed::new(g, raylab::Transform::new(raylab::glam::DAffine3::from_scale(DVec3::splat(scale))).unwrap());
        let d = DVec3::from(dir).try_normalize().unwrap_or(DVec3::Z);
        let o = DVec3::from(inside) * 0.6 * scale;
        let h = placed.intersect(&Ray::new(o, d), 0.0, f64::INFINITY).unwrap();
        let n = placed.outward_normal(&h);
        let out = offset_ray_origin(h.point, h.error, n, d);
        prop_assert!(placed.intersect(&Ray::new(out, d), 0.0, f64::INFINITY).is_none(), "outward ray re-hit the mesh (scale {scale}, from {o})");
        let back = offset_ray_origin(h.point, h.error, n, -d);
        let h2 = placed.intersect(&Ray::new(back, -d), 0.0, f64::INFINITY).unwrap();
        prop_assert!(
            h2.prim != h.prim && h2.t > 0.05 * scale,
            "inward ray hit prim {} at t {} (own {}, scale {scale}, from {o})", h2.prim, h2.t, h.prim
        );
        // Shadow rays that skip the triangle they leave answer as those that test it: free
        // outward, blocked by the far side inward.
        for (origin, dir, blocked) in [(out, d, false), (back, -d, true)] {
            let ray = Ray::new(origin, dir);
            prop_assert_eq!(placed.occludes(&ray, 0.0, f64::INFINITY), blocked);
            prop_assert_eq!(placed.occludes_leaving(&ray, 0.0, f64::INFINITY, h.prim), blocked, "scale {}, from {}", scale, o);
        }
    }
}

/// Uniform scaling of a test configuration (tests the scale independence of watertightness).
struct Transform3 {
    s: f64,
}

impl Transform3 {
    fn p(&self, v: DVec3) -> DVec3 {
        v * self.s
    }
    fn mesh_hit(&self, g: &Arc<MeshObject>, ray: &Ray) -> Option<raylab::Hit> {
        if self.s == 1.0 {
            return g.intersect(ray, 0.0, f64::INFINITY);
        }
        // Same mesh scaled through a transform wrapper, so rounding happens at the new scale.
        let t = raylab::Transform::new(raylab::glam::DAffine3::from_scale(DVec3::splat(self.s))).unwrap();
        let placed = raylab::Transformed::new(g.clone(), t);
        placed.intersect(ray, 0.0, f64::INFINITY)
    }
}

/// A random scene of spheres, triangles, a plane and a mesh, as TOML.
fn random_scene(seed: u64, n: usize) -> String {
    let mut rng = seed | 1;
    let mut r = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0
    };
    let mut s = String::from("[[object]]\ntype = \"plane\"\npoint = [0, -12, 0]\nnormal = [0, 1, 0]\n");
    s.push_str("[[object]]\ntype = \"mesh\"\nfile = \"cube.obj\"\ntransform = { scale = 3, translate = [1, 2, 3] }\n");
    for _ in 0..n {
        let (x, y, z, rad) = (r(), r(), r(), r().abs() * 0.1 + 0.1);
        s.push_str(&format!("[[object]]\ntype = \"sphere\"\ncenter = [{x}, {y}, {z}]\nradius = {rad}\n"));
        let (a, b, c) = ([r(), r(), r()], [r(), r(), r()], [r(), r(), r()]);
        s.push_str(&format!("[[object]]\ntype = \"triangle\"\np0 = {a:?}\np1 = {b:?}\np2 = {c:?}\n"));
    }
    s
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, rng_seed: RngSeed::Fixed(raylab::testing::seed("hierarchy_and_list_agree")), ..ProptestConfig::default() })]

    /// The hierarchy and the list find the same closest hit and the same occlusion.
    #[test]
    fn hierarchy_and_list_agree(seed in any::<u64>(), n in 1usize..60, rays in prop::collection::vec((prop::array::uniform3(-15.0f64..15.0), prop::array::uniform3(-1.0f64..1.0)), 40)) {
        let body = random_scene(seed, n);
        let bvh = scene(&body, AccelChoice::Bvh).unwrap();
        let list = scene(&body, AccelChoice::List).unwrap();
        prop_assert!(bvh.scene.accel_summary().bvh && !list.scene.accel_summary().bvh);
        // Every other ray is aimed at the mesh (a cube of side 3 at (1, 2, 3)): the property
        // must not pass because every ray missed. Hits on anything but the plane are counted.
        let mut met = 0;
        let count = rays.len();
        for (i, (o, d)) in rays.into_iter().enumerate() {
            let (o, d) = (DVec3::from(o), DVec3::from(d));
            let d = if i % 2 == 0 { DVec3::new(1.0, 2.0, 3.0) + d - o } else { d };
            let Some(d) = d.try_normalize() else { continue };
            let ray = Ray::new(o, d);
            let (a, b) = (bvh.scene.intersect(&ray, 0.0, f64::INFINITY), list.scene.intersect(&ray, 0.0, f64::INFINITY));
            met += usize::from(a.is_some_and(|h| h.object != 0));
            prop_assert_eq!(a.map(|h| (h.t, h.object)), b.map(|h| (h.t, h.object)), "ray {:?}", ray);
            for t_max in [1.0, 5.0, f64::INFINITY] {
                prop_assert_eq!(bvh.scene.occludes(&ray, 0.0, t_max), list.scene.occludes(&ray, 0.0, t_max));
            }
        }
        prop_assert!(met * 10 >= count, "only {met} of {count} rays met an object other than the plane");
    }
}

/// Regression: `raylab bench --mesh FILE` once deleted FILE after benchmarking it (the clean-up
/// of its generated meshes removed every input). A user's mesh must survive the bench.
#[test]
fn bench_never_deletes_the_meshes_it_is_given() {
    let dir = std::env::temp_dir().join(format!("raylab-bench-input-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = dir.join("cube.obj");
    std::fs::copy(assets().join("cube.obj"), &mesh).unwrap();
    let before = std::fs::read(&mesh).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["bench", "--sizes", "", "--width", "16", "--height", "12", "--threads", "1"])
        .arg(&mesh)
        .output()
        .expect("raylab runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(std::fs::read(&mesh).expect("the input mesh still exists"), before);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Regression: a mesh of one triangle repeated 10⁶ times once overflowed the stack (an abort)
/// while building its hierarchy. Every mode indexes it, and finds the list's closest hit.
#[test]
fn a_million_coincident_triangles_index_in_every_mode() {
    let n = 1_000_000;
    let mut triangles = vec![[0u32, 1, 2]; n];
    // One triangle in front of the others, the only closest hit at its centre.
    triangles.push([3, 4, 5]);
    let data = MeshData {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [0.5, 0.0, -1.0], [0.0, 0.5, -1.0]],
        triangles,
        ..MeshData::default()
    };
    let list = TriangleMesh::new(data.clone(), Normals::Flat, AccelChoice::List).unwrap();
    let l = MeshObject::new(Arc::new(list));
    for accel in [AccelChoice::Auto, AccelChoice::Bvh] {
        let mesh = TriangleMesh::new(data.clone(), Normals::Flat, accel).unwrap();
        assert_eq!(mesh.is_bvh(), raylab::accel::build::BVH_AVAILABLE);
        let g = MeshObject::new(Arc::new(mesh));
        for (origin, t) in [(DVec3::new(0.1, 0.1, -5.0), 4.0), (DVec3::new(0.6, 0.2, -5.0), 5.0)] {
            let ray = Ray::new(origin, DVec3::Z);
            let (a, b) = (g.intersect(&ray, 0.0, f64::INFINITY), l.intersect(&ray, 0.0, f64::INFINITY));
            assert_eq!(a.map(|h| h.t), Some(t), "{accel:?} {origin}");
            assert_eq!(a.map(|h| h.t), b.map(|h| h.t));
        }
    }
}

/// The same through the OBJ loader: one triangle on 10⁵ face lines.
#[test]
fn an_obj_repeating_one_triangle_loads_with_a_hierarchy() {
    let n = 100_000;
    let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    obj.push_str(&"f 1 2 3\n".repeat(n));
    for accel in [AccelChoice::Auto, AccelChoice::Bvh] {
        let options = options(accel);
        let dir = assets();
        let ctx = raylab::LoadContext::new(&dir, &options);
        let mesh = raylab_plugins::mesh::mesh_from_bytes(&ctx, "repeat.obj", "obj", obj.as_bytes()).unwrap();
        assert_eq!((mesh.triangle_count(), mesh.is_bvh()), (n, raylab::accel::build::BVH_AVAILABLE));
        let g = MeshObject::new(Arc::new(mesh));
        let hit = g.intersect(&Ray::new(DVec3::new(0.25, 0.25, -2.0), DVec3::Z), 0.0, f64::INFINITY);
        assert_eq!(hit.map(|h| h.t), Some(2.0), "{accel:?}");
    }
}

/// A shadow query that leaves a triangle skips that triangle only: a ray through one of two
/// stacked triangles is blocked by the other, and by neither when it is said to leave the only
/// one in its way.
#[test]
fn occludes_leaving_skips_the_own_triangle_only() {
    let data = MeshData {
        positions: vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0], [-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [0.0, 1.0, 1.0]],
        triangles: vec![[0, 1, 2], [3, 4, 5]],
        ..MeshData::default()
    };
    for accel in [AccelChoice::Bvh, AccelChoice::List] {
        let g = MeshObject::new(Arc::new(TriangleMesh::new(data.clone(), Normals::Flat, accel).unwrap()));
        let ray = Ray::new(DVec3::new(0.0, 0.0, -1.0), DVec3::Z);
        let near = g.intersect(&ray, 0.0, f64::INFINITY).unwrap();
        let far = g.intersect(&ray, 0.0, 1.5).filter(|h| h.prim != near.prim);
        assert!(far.is_none(), "the near triangle is the closest hit");
        // Only the near triangle is within t < 1.5; both within t < 3.
        assert!(g.occludes(&ray, 0.0, 1.5) && g.occludes_leaving(&ray, 0.0, 3.0, near.prim), "{accel:?}");
        assert!(!g.occludes_leaving(&ray, 0.0, 1.5, near.prim), "the skipped triangle still blocks ({accel:?})");
        let far = g.intersect(&ray, 1.5, 3.0).unwrap();
        assert!(g.occludes_leaving(&ray, 0.0, 1.5, far.prim), "{accel:?}");
    }
}

/// A lumpy sphere of 9k triangles (radius 1 ± 0.08) as OBJ text: its bumps shadow each other.
fn lumpy_obj() -> String {
    use std::fmt::Write as _;
    let mut obj = String::new();
    let (nu, nv) = (96u32, 48u32);
    for j in 0..=nv {
        for i in 0..nu {
            let (th, ph) = (std::f64::consts::PI * f64::from(j) / f64::from(nv), std::f64::consts::TAU * f64::from(i) / f64::from(nu));
            let r = 1.0 + 0.08 * (7.0 * th).sin() * (5.0 * ph).cos();
            writeln!(obj, "v {} {} {}", r * th.sin() * ph.cos(), r * th.cos(), r * th.sin() * ph.sin()).unwrap();
        }
    }
    for j in 0..nv {
        for i in 0..nu {
            let (a, b) = (j * nu + i + 1, j * nu + (i + 1) % nu + 1);
            let (c, d) = (a + nu, b + nu);
            writeln!(obj, "f {a} {c} {d}\nf {a} {d} {b}").unwrap();
        }
    }
    obj
}

/// Camera rays traced in packets (8 pixels of a row walked together through a mesh's hierarchy,
/// their hits shaded as a block with their shadow rays walked together) give every pixel exactly
/// the colour of the single-ray path (`render_pixel`), and the same counters, with layers, at 1
/// and 2 threads: a lumpy sphere of 9k triangles over a ground plane, a width that leaves a short
/// packet at each tile's end; the sphere reflecting (shaded hit by hit) and not (as a block).
#[test]
fn packets_of_camera_rays_render_what_single_rays_render() {
    let dir = std::env::temp_dir().join(format!("raylab-packets-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("lumpy.obj"), lumpy_obj()).unwrap();
    let scene = "[render]\nwidth = 75\nheight = 41\nspp = 1\n\
                 [camera]\nposition = [0.4, 0.8, 3.2]\nlook_at = [0, 0, 0]\nfov = 45\n\
                 [integrator]\ntype = \"phong\"\nmax_depth = 2\n\
                 [[object]]\ntype = \"mesh\"\nfile = \"lumpy.obj\"\nmaterial = { kd = 0.7, ka = 1, kr = 0.3 }\n\
                 [[object]]\ntype = \"plane\"\npoint = [0, -1.1, 0]\nnormal = [0, 1, 0]\nmaterial = { kd = 0.5, ka = 1 }\n\
                 [[light]]\ntype = \"directional\"\ndirection = [-0.3, -1, -0.5]\ncolor = 1\n\
                 [[light]]\ntype = \"ambient\"\ncolor = 1\nka = 0.1\n";
    // The reflecting mesh is shaded hit by hit, the plane as a block (its shadow rays traced
    // together); with `kr = 0` both are, and the mesh shadows itself.
    for (name, scene) in [("packets", scene.to_string()), ("plain", scene.replace(", kr = 0.3", ""))] {
        std::fs::write(dir.join(format!("{name}.toml")), scene).unwrap();
        packets_render_single_rays(&dir.join(format!("{name}.toml")));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The checks of [`packets_of_camera_rays_render_what_single_rays_render`] for the scene at
/// `path` (75×41): the same pixels and the same counters as `render_pixel`, pixel by pixel.
fn packets_render_single_rays(path: &Path) {
    let job = load_file(&raylab_plugins::registry(), path, &options(AccelChoice::Auto)).unwrap_or_else(|e| panic!("{}", e.report()));
    assert!(job.integrator.takes_camera_hits());
    assert_eq!(job.scene.walks_packets(), raylab::accel::BVH_AVAILABLE, "the render takes packets through the mesh's hierarchy");
    let mut stats = raylab::RayStats::new(job.integrator.counters());
    let single: Vec<_> =
        (0..41).flat_map(|y| (0..75).map(move |x| (x, y))).map(|(x, y)| raylab::render::render_pixel(&job, x, y, &mut stats)).collect();
    for threads in [1, 2] {
        let options = raylab::render::RenderOptions { threads: Some(threads), layers: true, ..Default::default() };
        let rendered = raylab::render::render(&job, &options, &|_, _| {}).unwrap();
        let film = rendered.film;
        let mut hits = 0;
        for (i, c) in single.iter().enumerate() {
            let (x, y) = (i as u32 % 75, i as u32 / 75);
            assert_eq!(film.get(x, y), *c, "pixel ({x}, {y}), {threads} thread(s), {}", path.display());
            hits += usize::from(c.max_element() > 0.2);
        }
        assert!(hits > 1000, "{hits} lit pixels");
        assert_eq!(rendered.stats.camera_rays, stats.camera_rays);
        for (i, c) in job.integrator.counters().iter().enumerate() {
            assert_eq!(rendered.stats.count(i), stats.count(i), "counter {}, {}", c.name, path.display());
        }
    }
}

/// Phong's block of camera hits (`Integrator::radiance_packet`: plain hits shaded up to their
/// shadow rays, which are traced together; other hits by `shade`) gives each lane exactly what
/// `radiance_from` gives it lane by lane (colour, layers, every counter), under work budgets
/// that run out anywhere inside the block, with a plain mesh and a reflecting one, a point light
/// (finite shadow rays) and a highlight.
#[test]
fn a_block_of_camera_hits_shades_as_single_hits() {
    let dir = std::env::temp_dir().join(format!("raylab-block-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("lumpy.obj"), lumpy_obj()).unwrap();
    let scene = "[render]\nwidth = 64\nheight = 40\nspp = 1\n\
                 [camera]\nposition = [0.4, 0.8, 3.2]\nlook_at = [0, 0, 0]\nfov = 45\n\
                 [integrator]\ntype = \"phong\"\nmax_depth = 2\n\
                 [[object]]\ntype = \"mesh\"\nfile = \"lumpy.obj\"\nmaterial = { kd = 0.7, ka = 1, ks = 0.4, shininess = 12, kr = 0.3 }\n\
                 [[object]]\ntype = \"plane\"\npoint = [0, -1.1, 0]\nnormal = [0, 1, 0]\nmaterial = { kd = 0.5, ka = 1 }\n\
                 [[light]]\ntype = \"point\"\nposition = [-2, 4, 3]\ncolor = 20\n\
                 [[light]]\ntype = \"ambient\"\ncolor = 1\nka = 0.1\n";
    let mut blocks = 0;
    for (name, scene) in [("plain", scene.replace(", kr = 0.3", "")), ("mirror", scene.to_string())] {
        std::fs::write(dir.join(format!("{name}.toml")), scene).unwrap();
        let job = load_file(&raylab_plugins::registry(), &dir.join(format!("{name}.toml")), &options(AccelChoice::Auto))
            .unwrap_or_else(|e| panic!("{}", e.report()));
        for y in (0..40).step_by(3) {
            for x0 in (0..64).step_by(8) {
                // Every lane, and a gap.
                for live in [0xff, 0b1101_1011] {
                    blocks += common::blocks::assert_block_shades_as_single_hits(&job, name, (x0, y), live, (0..=24).chain([u64::MAX]));
                }
            }
        }
    }
    assert!(blocks > 1000);
    std::fs::remove_dir_all(&dir).ok();
}

/// Shadow rays of a packet (8 rays toward one light from points on a lumpy mesh, some leaving
/// their own triangle, some not, some stopped short) get exactly the single rays' answers, with
/// a hierarchy and as a list; so do packets whose directions differ (walked ray by ray).
#[test]
fn packets_of_shadow_rays_answer_as_single_rays() {
    let dir = assets();
    for accel in [AccelChoice::Auto, AccelChoice::List] {
        let options = options(accel);
        let ctx = raylab::LoadContext::new(&dir, &options);
        let mesh = raylab_plugins::mesh::mesh_from_bytes(&ctx, "lumpy.obj", "obj", lumpy_obj().as_bytes()).unwrap();
        let g = MeshObject::new(Arc::new(mesh));
        let (mut blocked, mut open) = (0, 0);
        for p in 0..400u32 {
            // Camera rays of 8 neighbouring pixels, their hits' shadow rays toward one light.
            let light = if p % 5 == 4 { DVec3::new(0.2, 1.0, 0.1) } else { DVec3::new(0.3, 1.0, 0.5) }.normalize();
            let mut rays = [Ray::new(DVec3::ZERO, light); 8];
            let (mut live, mut leaving, mut prims, mut t_max) = (0u32, 0u32, [0u32; 8], [f64::INFINITY; 8]);
            for k in 0..8 {
                let (u, v) = (f64::from(p % 20) / 10.0 - 1.0 + f64::from(k as u32) * 0.004, f64::from(p / 20) / 10.0 - 1.0);
                let camera = Ray::new(DVec3::new(0.4, 0.8, 3.2), (DVec3::new(u, v, 0.0) - DVec3::new(0.4, 0.8, 3.2)).normalize());
                let Some(h) = g.intersect(&camera, 0.0, f64::INFINITY) else { continue };
                let n = g.normal(&h, camera.dir);
                // A few rays of mixed directions (lanes of another light).
                let dir = if p % 7 == 6 && k % 2 == 1 { DVec3::new(-0.3, 1.0, -0.5).normalize() } else { light };
                rays[k] = Ray::new(offset_ray_origin(h.point, h.error, n, dir), dir);
                live |= 1 << k;
                leaving |= u32::from(k % 3 != 2) << k;
                prims[k] = h.prim;
                if k % 4 == 3 {
                    t_max[k] = 0.05;
                }
            }
            let got = g.occludes_packet(&rays, live, 0.0, &t_max, leaving, &prims);
            assert_eq!(got & !live, 0, "lanes not asked are not answered");
            for k in (0..8).filter(|k| live >> k & 1 != 0) {
                let single = match leaving >> k & 1 != 0 {
                    true => g.occludes_leaving(&rays[k], 0.0, t_max[k], prims[k]),
                    false => g.occludes(&rays[k], 0.0, t_max[k]),
                };
                assert_eq!(got >> k & 1 != 0, single, "packet {p}, lane {k}, {accel:?}");
                if single { blocked += 1 } else { open += 1 }
            }
        }
        assert!(blocked > 200 && open > 200, "{blocked} blocked, {open} open");
    }
}

/// A path's next ray finds the same closest hit through `Scene::trace_leaving` (the surface it
/// leaves asked `intersect_leaving`, flat ones skipped) as through `Scene::trace`: rays spawned
/// off hits of quadrangles, a plane, a triangle, a transformed quadrangle, a flat mesh, a cube
/// mesh and spheres, to both sides of each surface (into the spheres, where the far side is met), in a
/// list of objects, a hierarchy and with one bounded object.
#[test]
fn rays_leaving_a_hit_find_what_trace_finds() {
    let mut body = String::from(
        "[[object]]\ntype = \"plane\"\npoint = [0, -2, 0]\nnormal = [0, 1, 0]\n\
         [[object]]\ntype = \"quadrangle\"\np0 = [-2, -2, -2]\np1 = [2, -2, -2]\np2 = [2, 2, -2]\np3 = [-2, 2, -2]\n\
         [[object]]\ntype = \"quadrangle\"\np0 = [-2, -2, -2]\np1 = [-2, 2, -2]\np2 = [-2, 2, 2]\np3 = [-2, -2, 2]\n\
         [[object]]\ntype = \"triangle\"\np0 = [2, -2, -2]\np1 = [2, 2, 0]\np2 = [2, -2, 2]\n\
         [[object]]\ntype = \"quadrangle\"\np0 = [-1, -1, 0]\np1 = [1, -1, 0]\np2 = [1, 1, 0]\np3 = [-1, 1, 0]\n\
         transform = { rotate = [20, 30, 0], translate = [0, 1.2, -1] }\n\
         [[object]]\ntype = \"sphere\"\ncenter = [-0.8, -1.2, 0.5]\nradius = 0.7\n\
         [[object]]\ntype = \"sphere\"\ncenter = [0.9, -1.4, 0.8]\nradius = 0.5\n",
    );
    // A flat mesh (an L-shaped ceiling tile) and a closed one (a cube).
    body.push_str(
        "[[object]]\ntype = \"mesh\"\nfile = \"concave.obj\"\nnormals = \"flat\"\ntransform = { scale = 2, translate = [-2, 2, -2] }\n\
         [[object]]\ntype = \"mesh\"\nfile = \"cube.obj\"\ntransform = { scale = 0.6, translate = [0.5, -0.6, -1.2] }\n",
    );
    let lone = "[[object]]\ntype = \"plane\"\npoint = [0, -2, 0]\nnormal = [0, 1, 0]\n\
                [[object]]\ntype = \"sphere\"\ncenter = [0, -1, 0]\nradius = 1\n";
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let mut uniform = move || {
        rng = raylab::math::sampler::mix64(rng.wrapping_add(0x9e37_79b9_7f4a_7c15));
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    for (text, accels) in [(body.as_str(), [AccelChoice::List, AccelChoice::Bvh]), (lone, [AccelChoice::List, AccelChoice::List])] {
        for accel in accels {
            let job = scene(text, accel).unwrap_or_else(|e| panic!("{}", e.report()));
            let scene = &job.scene;
            let (mut leaving, mut met) = (std::collections::HashSet::new(), 0);
            for _ in 0..3000 {
                let dir = |u: &mut dyn FnMut() -> f64| {
                    let z = 2.0 * u() - 1.0;
                    let phi = std::f64::consts::TAU * u();
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    DVec3::new(r * phi.cos(), r * phi.sin(), z)
                };
                let origin = DVec3::new(0.3 * uniform() - 0.15, 0.5 * uniform(), 1.5 + uniform());
                let Some(si) = scene.trace(&Ray::new(origin, dir(&mut uniform))) else { continue };
                for _ in 0..4 {
                    let ray = si.spawn_ray(dir(&mut uniform));
                    let expected = scene.trace(&ray).map(|s| s.hit);
                    assert_eq!(scene.trace_leaving(&ray, &si.hit).map(|s| s.hit), expected, "{accel:?}, leaving {:?}", si.hit);
                    leaving.insert(si.hit.object);
                    met += usize::from(expected.is_some());
                }
            }
            assert!(
                leaving.len() == scene.objects.len() && met > 400,
                "{accel:?}: left {leaving:?} of {}, {met} hits",
                scene.objects.len()
            );
        }
    }
}
