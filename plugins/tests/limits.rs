//! Limits for untrusted scenes that need meshes: the triangle limit, checked before a mesh's index
//! and hierarchy are built (for glTF, from its accessors before any data is decoded), and raised
//! by `--max-triangles`; and meshes whose coordinates are too large for a hierarchy.
#![cfg(feature = "mesh")]

use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::param::limits::Limits;
use std::path::{Path, PathBuf};
use std::process::Command;

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets")
}

fn load(file: &str, max_triangles: u64) -> Result<raylab::RenderJob, raylab::SceneError> {
    let text = format!("[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"mesh\"\nfile = \"{file}\"\n");
    let options = LoadOptions { limits: Limits { max_triangles, ..Limits::default() }, ..LoadOptions::default() };
    load_str(&raylab_plugins::registry(), "limits.toml", &text, &assets(), &options)
}

#[test]
fn meshes_over_the_triangle_limit_are_refused_with_the_flag_to_raise_it() {
    for file in ["cube.obj", "Box.gltf", "Box.glb"] {
        assert!(load(file, 12).is_ok(), "{file} has 12 triangles");
        let e = load(file, 11).err().unwrap_or_else(|| panic!("{file} loaded over the limit"));
        assert!(e.message.contains("12 triangles, over the limit of 11"), "{file}: {}", e.report());
        assert!(e.help.as_deref().unwrap_or("").contains("--max-triangles"), "{file}: {}", e.report());
    }
}

/// Writes `many.gltf` (and its buffer) into `dir`: the test box's mesh placed by 4096 nodes.
fn write_box_placed_4096_times(dir: &std::path::Path) {
    std::fs::create_dir_all(dir).unwrap();
    let box_gltf = std::fs::read_to_string(assets().join("Box.gltf")).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&box_gltf).unwrap();
    let mesh_node = doc["nodes"].as_array().unwrap().iter().position(|n| n.get("mesh").is_some()).unwrap();
    let nodes: Vec<serde_json::Value> =
        (0..4096).map(|i| serde_json::json!({ "mesh": doc["nodes"][mesh_node]["mesh"], "translation": [i, 0, 0] })).collect();
    doc["nodes"] = serde_json::Value::Array(nodes);
    doc["scenes"] = serde_json::json!([{ "nodes": (0..4096).collect::<Vec<_>>() }]);
    doc["scene"] = serde_json::json!(0);
    std::fs::write(dir.join("many.gltf"), doc.to_string()).unwrap();
    std::fs::copy(assets().join("Box0.bin"), dir.join("Box0.bin")).unwrap();
}

/// A glTF file placing one mesh from 4096 nodes: counted before the copies are made.
#[test]
fn instanced_gltf_meshes_are_counted_before_they_are_copied() {
    let dir = std::env::temp_dir().join(format!("raylab-limits-{}", std::process::id()));
    write_box_placed_4096_times(&dir);
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"mesh\"\nfile = \"many.gltf\"\n";
    let options = LoadOptions { limits: Limits { max_triangles: 10_000, ..Limits::default() }, ..LoadOptions::default() };
    let e = load_str(&raylab_plugins::registry(), "many.toml", text, &dir, &options).err().expect("over the limit");
    assert!(e.message.contains("49152 triangles, over the limit of 10000"), "{}", e.report());
    std::fs::remove_dir_all(dir).unwrap();
}

/// The same file rendered as a scene: its instances are charged to the memory budget before its
/// description is built.
#[test]
fn a_gltf_scene_with_many_instances_is_refused_by_the_memory_budget() {
    let dir = std::env::temp_dir().join(format!("raylab-limits-mem-{}", std::process::id()));
    write_box_placed_4096_times(&dir);
    let registry = raylab_plugins::registry();
    let load = |max_memory| {
        let options = LoadOptions { limits: Limits { max_memory, ..Limits::default() }, ..LoadOptions::default() };
        raylab::load::loader::load_file(&registry, &dir.join("many.gltf"), &options)
    };
    let e = load(4 << 20).err().expect("4096 instances over a 4 MiB budget");
    assert!(e.message.contains("4096 mesh instances") && e.message.contains("over the limit of 4 MB"), "{}", e.report());
    assert!(e.help.as_deref().unwrap_or("").contains("--max-memory"), "{}", e.report());
    assert!(e.report().contains("many.gltf"), "{}", e.report());
    assert!(load(Limits::default().max_memory).is_ok());
    std::fs::remove_dir_all(dir).unwrap();
}

/// A glTF rendered as a scene whose 4096 nodes place one mesh: its file is looked up in the file
/// system once per load, not twice per instance (3·10⁵ instances made 1.2 M `getcwd` calls).
#[test]
fn a_file_placed_by_many_instances_is_resolved_once_per_load() {
    let dir = std::env::temp_dir().join(format!("raylab-limits-resolve-{}", std::process::id()));
    write_box_placed_4096_times(&dir);
    let registry = raylab_plugins::registry();
    let options = LoadOptions::default();
    let desc = raylab::load::loader::read_file(&registry, &dir.join("many.gltf"), &options).unwrap();
    let ctx = raylab::load::context::LoadContext::new(&dir, &options);
    let job = raylab::load::loader::build(&registry, &desc, &ctx).unwrap();
    assert_eq!(job.scene.objects.len(), 4096);
    // The glTF file and its buffer.
    assert!(ctx.path_resolutions() <= 2, "{} resolutions for 4096 instances", ctx.path_resolutions());
    std::fs::remove_dir_all(dir).unwrap();
}

/// 10⁶ inline spheres: refused by a small budget before the text is parsed, naming the flag.
#[test]
fn a_million_spheres_are_refused_by_a_small_memory_budget() {
    let mut text = String::from("[camera]\nposition = [0, 0, -10]\nlook_at = [0, 0, 0]\n");
    for i in 0..1_000_000 {
        text.push_str(&format!("[[object]]\ntype=\"sphere\"\ncenter=[{},{},0]\nradius=0.3\n", i % 1000, i / 1000));
    }
    let estimate = raylab::param::limits::toml_memory_estimate(text.as_bytes());
    assert!(estimate > 2_000_000_000, "a million spheres peaked at 2.3 GB while parsed (1.4 GB in parts), estimated {estimate}");
    let options = LoadOptions { limits: Limits { max_memory: 1 << 30, ..Limits::default() }, ..LoadOptions::default() };
    let e = load_str(&raylab_plugins::registry(), "spheres.toml", &text, Path::new("."), &options).err().expect("over 1 GiB");
    assert!(e.message.contains("the scene description") && e.message.contains("over the limit of 1024 MB"), "{}", e.report());
    assert!(e.help.as_deref().unwrap_or("").contains("--max-memory"), "{}", e.report());
}

/// Every object is charged as it is built: a budget the description fits in but its objects do
/// not is refused at the object that crosses it.
#[test]
fn objects_are_charged_as_they_are_built() {
    let mut text = String::from("[render]\nwidth = 8\nheight = 8\n[camera]\nposition = [0, 0, -10]\nlook_at = [0, 0, 0]\n");
    for i in 0..1000 {
        text.push_str(&format!("[[object]]\ntype=\"sphere\"\ncenter=[{i},0,0]\nradius=0.3\n"));
    }
    let registry = raylab_plugins::registry();
    let image = raylab::image::output::image_bytes(64, &raylab::image::output::ImagePlan::default());
    let fits = raylab::param::limits::toml_memory_estimate(text.as_bytes()) + image;
    let load = |max_memory| {
        let options = LoadOptions { limits: Limits { max_memory, ..Limits::default() }, ..LoadOptions::default() };
        load_str(&registry, "spheres.toml", &text, Path::new("."), &options)
    };
    let e = load(fits + 500 * raylab::param::limits::OBJECT_BYTES).err().expect("1000 objects over the budget");
    assert!(e.message.contains("object #500 (sphere)"), "{}", e.report());
    assert!(load(fits + 1000 * raylab::param::limits::OBJECT_BYTES).is_ok());
}

#[test]
fn the_command_line_flag_raises_the_limit() {
    let scene = std::env::temp_dir().join(format!("raylab-limits-cli-{}.toml", std::process::id()));
    let cube = assets().join("cube.obj");
    std::fs::write(
        &scene,
        format!("[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"mesh\"\nfile = \"{}\"\n", cube.display()),
    )
    .unwrap();
    let out_png = scene.with_extension("png");
    let run = |extra: &[&str]| {
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out_png.to_str().unwrap(), "--width", "8", "--height", "8", "-q"];
        args.extend(["--allow-outside-paths"]);
        args.extend(extra);
        Command::new(env!("CARGO_BIN_EXE_raylab")).args(&args).output().unwrap()
    };
    let refused = run(&["--max-triangles", "11"]);
    assert_eq!(refused.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("over the limit of 11"));
    let allowed = run(&["--max-triangles", "12"]);
    assert!(allowed.status.success(), "{}", String::from_utf8_lossy(&allowed.stderr));
    let _ = std::fs::remove_file(&scene);
    let _ = std::fs::remove_file(&out_png);
}

/// Found by the `mesh_obj` fuzz target: a vertex at 1e34 made obvhs' single-precision build fail
/// an assertion (a crash). The mesh's index is built without crashing (boxes beyond
/// `raylab::accel::bvh::MAX_BVH_COORDINATE` go to a list), and the object is then refused as reaching
/// beyond `raylab::math::bounds::MAX_COORDINATE`, where it would silently vanish.
#[test]
fn a_mesh_reaching_1e34_is_built_without_crashing_and_refused_as_out_of_range() {
    let text = "[camera]\nposition = [0.5, 0.5, 10]\nlook_at = [0.5, 0.5, 0]\n[[object]]\ntype = \"mesh\"\nfile = \"far-vertex.obj\"\n";
    let options = LoadOptions { accel: raylab::accel::AccelChoice::Bvh, ..LoadOptions::default() };
    let e = load_str(&raylab_plugins::registry(), "far.toml", text, &assets(), &options).err().expect("refused");
    assert!(e.message.contains("reaches 1.000e34 from the origin, beyond the 1e30 raylab represents"), "{}", e.report());
}

/// A symbolic link inside the scene's folder that leads out of it is refused like `..`, unless
/// the user allows paths outside the folder.
#[cfg(unix)]
#[test]
fn a_symbolic_link_out_of_the_scene_folder_is_refused() {
    let dir = std::env::temp_dir().join(format!("raylab-symlink-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::os::unix::fs::symlink(assets().join("cube.obj"), dir.join("link.obj")).unwrap();
    let text =
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"mesh\"\nfile = \"link.obj\"\nmaterial = { kd = 0.5 }\n";
    let e = load_str(&raylab_plugins::registry(), "s.toml", text, &dir, &LoadOptions::default()).err().expect("refused");
    assert!(e.message.contains("resolves outside the scene's folder"), "{}", e.report());
    assert_eq!(e.where_().as_deref(), Some("s.toml:6:8"));
    let allowed = LoadOptions { allow_outside_paths: true, ..LoadOptions::default() };
    assert!(load_str(&raylab_plugins::registry(), "s.toml", text, &dir, &allowed).is_ok());
    std::fs::remove_dir_all(dir).unwrap();
}
