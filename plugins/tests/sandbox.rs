//! The scene's folder is a sandbox that fails closed: whatever the layout of links, FIFOs,
//! devices and folders around a scene, and however the scene is named on the command line,
//! nothing outside its folder is opened, and only regular files are read, never blocking.
#![cfg(all(feature = "mesh", unix))]

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_file;
use raylab::param::files::OpenLog;
use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How long a CLI child may run before the test kills it and fails (a hang, not a slow machine).
const HANG_BOUND: Duration = Duration::from_secs(30);

const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";
const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
const MTL: &str = "newmtl red\nKd 1 0 0\n";

/// Three `f32` vertices of one triangle, the buffer [`gltf`] describes.
fn triangle_bin() -> Vec<u8> {
    [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect()
}

/// A glTF file of one triangle whose 36-byte buffer is the file `uri`.
fn gltf(uri: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"buffers":[{{"byteLength":36,"uri":"{uri}"}}],"bufferViews":[{{"buffer":0,"byteLength":36}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","max":[1,1,0],"min":[0,0,0]}}]}}"#
    )
}

fn mesh_scene(file: &str) -> String {
    format!("{CAMERA}[[object]]\ntype = \"mesh\"\nfile = \"{file}\"\n")
}

fn fresh_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("raylab-sandbox-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn mkfifo(p: &Path) {
    assert!(Command::new("mkfifo").arg(p).status().expect("mkfifo runs").success(), "mkfifo {}", p.display());
}

/// Runs `raylab args…` in `cwd`; its exit code and standard error. Fails the test if it had to be
/// killed after [`HANG_BOUND`].
fn raylab(cwd: &Path, args: &[&str]) -> (Option<i32>, String) {
    let err_path = std::env::temp_dir().join(format!("raylab-sandbox-stderr-{}-{:?}", std::process::id(), std::thread::current().id()));
    let err_file = std::fs::File::create(&err_path).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(err_file)
        .spawn()
        .expect("raylab runs");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > HANG_BOUND {
            let _ = child.kill();
            let _ = child.wait();
            panic!("raylab {args:?} in {} still ran after {HANG_BOUND:?}: killed", cwd.display());
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = std::fs::read_to_string(&err_path).unwrap();
    let _ = std::fs::remove_file(&err_path);
    (status.code(), err)
}

/// The kinds of path a scene makes raylab read.
#[derive(Clone, Copy, Debug)]
enum PathKind {
    Mesh,
    Buffer,
    Mtllib,
}

impl PathKind {
    /// Lays out `scene/` for this kind with the linked file (`m.obj`, `b.bin` or `m.mtl`) a
    /// symbolic link to `target`; the scene file is `scene/scene.toml`.
    fn lay_out(self, scene: &Path, target: &Path) {
        let (scene_file, link) = match self {
            PathKind::Mesh => ("m.obj", "m.obj"),
            PathKind::Buffer => {
                std::fs::write(scene.join("t.gltf"), gltf("b.bin")).unwrap();
                ("t.gltf", "b.bin")
            }
            PathKind::Mtllib => {
                std::fs::write(scene.join("m.obj"), format!("mtllib m.mtl\nusemtl red\n{TRIANGLE_OBJ}")).unwrap();
                ("m.obj", "m.mtl")
            }
        };
        std::fs::write(scene.join("scene.toml"), mesh_scene(scene_file)).unwrap();
        symlink(target, scene.join(link)).unwrap();
    }

    /// A valid file of the linked kind.
    fn contents(self) -> Vec<u8> {
        match self {
            PathKind::Mesh => TRIANGLE_OBJ.into(),
            PathKind::Buffer => triangle_bin(),
            PathKind::Mtllib => MTL.into(),
        }
    }
}

/// The ways a scene is named: (working folder, scene argument), for a layout with `root/scene/`
/// and `root/other/`.
fn namings(root: &Path) -> Vec<(PathBuf, String)> {
    let scene = root.join("scene");
    vec![
        (scene.clone(), "scene.toml".into()),
        (scene.clone(), "./scene.toml".into()),
        (root.to_path_buf(), scene.join("scene.toml").display().to_string()),
        (root.join("other"), "../scene/scene.toml".into()),
    ]
}

#[test]
fn links_out_of_the_folder_are_refused_and_links_inside_accepted_however_the_scene_is_named() {
    for kind in [PathKind::Mesh, PathKind::Buffer, PathKind::Mtllib] {
        for inside in [false, true] {
            let root = fresh_dir(&format!("links-{kind:?}-{inside}"));
            let scene = root.join("scene");
            std::fs::create_dir_all(scene.join("sub")).unwrap();
            std::fs::create_dir_all(root.join("other")).unwrap();
            std::fs::write(root.join("other/secret"), kind.contents()).unwrap();
            std::fs::write(scene.join("sub/real"), kind.contents()).unwrap();
            let target = if inside { PathBuf::from("sub/real") } else { root.join("other/secret") };
            kind.lay_out(&scene, &target);
            let out = root.join("out.png");
            for (cwd, arg) in namings(&root) {
                let (code, err) = raylab(&cwd, &["render", &arg, "-o", out.to_str().unwrap(), "--width", "8", "--height", "8", "-q"]);
                let case = format!("{kind:?}, link {}, `raylab render {arg}` in {}", target.display(), cwd.display());
                if inside {
                    assert_eq!(code, Some(0), "{case}: {err}");
                } else {
                    assert_eq!(code, Some(1), "{case}: {err}");
                    assert!(err.contains("resolves outside the scene's folder"), "{case}: {err}");
                }
            }
            std::fs::remove_dir_all(root).unwrap();
        }
    }
}

#[test]
fn a_fifo_as_scene_mesh_or_buffer_is_refused_at_once() {
    let root = fresh_dir("fifo");
    mkfifo(&root.join("fifo.toml"));
    mkfifo(&root.join("m.obj"));
    mkfifo(&root.join("b.bin"));
    std::fs::write(root.join("mesh.toml"), mesh_scene("m.obj")).unwrap();
    std::fs::write(root.join("t.gltf"), gltf("b.bin")).unwrap();
    std::fs::write(root.join("buffer.toml"), mesh_scene("t.gltf")).unwrap();
    for (scene, what) in [("fifo.toml", "fifo.toml: scene file"), ("mesh.toml", "\"m.obj\""), ("buffer.toml", "\"b.bin\"")] {
        let (code, err) = raylab(&root, &["render", scene, "-q", "-o", "x.png"]);
        assert_eq!(code, Some(1), "{scene}: {err}");
        assert!(err.contains(&format!("{what} is a FIFO, expected a regular file")), "{scene}: {err}");
    }
    std::fs::remove_dir_all(root).unwrap();
}

#[test]
fn a_link_to_a_device_is_refused_as_mesh_and_as_scene() {
    let root = fresh_dir("device");
    symlink("/dev/zero", root.join("zero.toml")).unwrap();
    symlink("/dev/zero", root.join("z.obj")).unwrap();
    std::fs::write(root.join("mesh.toml"), mesh_scene("z.obj")).unwrap();
    let (code, err) = raylab(&root, &["render", "zero.toml", "-q", "-o", "x.png"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("zero.toml: scene file is a device, expected a regular file"), "{err}");
    let (code, err) = raylab(&root, &["render", "mesh.toml", "-q", "-o", "x.png"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("resolves outside the scene's folder"), "{err}");
    // Allowed out of the folder, the link still leads to no regular file.
    let (code, err) = raylab(&root, &["render", "mesh.toml", "-q", "-o", "x.png", "--allow-outside-paths"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("\"z.obj\" is a device, expected a regular file"), "{err}");
    std::fs::remove_dir_all(root).unwrap();
}

/// What one name in a random layout is.
#[derive(Clone, Debug)]
enum Entry {
    /// A valid file of the kind its name says; an OBJ or glTF refers to the name given (as
    /// `mtllib` or buffer `uri`).
    File(Option<String>),
    Folder,
    /// A symbolic link to another name of the layout (possibly absent: dangling).
    LinkInside(String),
    /// A symbolic link to a file or folder outside (`Outside`).
    LinkOutside(Outside),
    Fifo,
    LinkToDevice,
}

#[derive(Clone, Copy, Debug)]
enum Outside {
    SiblingFile,
    SiblingFolder,
    EtcPasswd,
    Etc,
    Relative,
}

/// Names a layout may hold (those under `sub/` exist only when `sub` is a real folder).
const NAMES: &[&str] = &["a.obj", "b.obj", "c.gltf", "d.bin", "e.mtl", "sub", "sub/f.obj", "sub/g.gltf", "sub/h.bin", "sub/i.mtl"];

/// Paths a scene, OBJ or glTF may name: the layout's, and ones that try to leave the folder.
const REFERENCES: &[&str] = &[
    "a.obj",
    "b.obj",
    "c.gltf",
    "d.bin",
    "e.mtl",
    "sub/f.obj",
    "sub/g.gltf",
    "sub/h.bin",
    "sub/i.mtl",
    "sub",
    "missing.obj",
    "../outside/secret",
    "/etc/passwd",
    "sub/../a.obj",
];

fn entry() -> impl Strategy<Value = Entry> {
    let reference = proptest::sample::select(REFERENCES).prop_map(String::from);
    let outside = prop_oneof![
        Just(Outside::SiblingFile),
        Just(Outside::SiblingFolder),
        Just(Outside::EtcPasswd),
        Just(Outside::Etc),
        Just(Outside::Relative)
    ];
    prop_oneof![
        3 => proptest::option::of(reference.clone()).prop_map(Entry::File),
        1 => Just(Entry::Folder),
        2 => reference.prop_map(Entry::LinkInside),
        2 => outside.prop_map(Entry::LinkOutside),
        1 => Just(Entry::Fifo),
        1 => Just(Entry::LinkToDevice),
    ]
}

/// Creates `name` in `scene` as `entry` says; `outside` is a sibling folder of `scene`.
fn create(scene: &Path, outside: &Path, name: &str, entry: &Entry) {
    let p = scene.join(name);
    match entry {
        Entry::File(reference) => {
            let r = reference.as_deref().unwrap_or("d.bin");
            let bytes: Vec<u8> = match Path::new(name).extension().and_then(|e| e.to_str()) {
                Some("obj") => match reference {
                    Some(r) => format!("mtllib {r}\nusemtl red\n{TRIANGLE_OBJ}").into(),
                    None => TRIANGLE_OBJ.into(),
                },
                Some("gltf") => gltf(r).into(),
                Some("bin") => triangle_bin(),
                Some("mtl") => MTL.into(),
                _ => return std::fs::create_dir_all(&p).unwrap(), // `sub`
            };
            std::fs::write(&p, bytes).unwrap();
        }
        Entry::Folder => std::fs::create_dir_all(&p).unwrap(),
        Entry::LinkInside(target) => {
            // Relative to the link's own folder, as a user would write it.
            let up = "../".repeat(Path::new(name).components().count() - 1);
            symlink(format!("{up}{target}"), &p).unwrap();
        }
        Entry::LinkOutside(o) => {
            let target = match o {
                Outside::SiblingFile => outside.join("secret"),
                Outside::SiblingFolder => outside.to_path_buf(),
                Outside::EtcPasswd => PathBuf::from("/etc/passwd"),
                Outside::Etc => PathBuf::from("/etc"),
                Outside::Relative => PathBuf::from("../".repeat(Path::new(name).components().count()) + "outside/secret"),
            };
            symlink(target, &p).unwrap();
        }
        Entry::Fifo => mkfifo(&p),
        Entry::LinkToDevice => symlink("/dev/zero", &p).unwrap(),
    }
}

/// Serialises the tests that change the working folder.
static CWD: Mutex<()> = Mutex::new(());

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, rng_seed: RngSeed::Fixed(raylab::testing::seed("no_layout_makes_a_load_open_a_file_outside_the_scene_folder")), ..ProptestConfig::default() })]

    /// Whatever lies in and around the scene's folder, and however the scene is named, every file
    /// the load opens is inside the folder (the load itself may fail).
    #[test]
    fn no_layout_makes_a_load_open_a_file_outside_the_scene_folder(
        entries in proptest::collection::vec(entry(), NAMES.len()),
        objects in proptest::collection::vec(proptest::sample::select(REFERENCES), 1..4),
        naming in 0usize..4,
    ) {
        let _cwd = CWD.lock().unwrap_or_else(|e| e.into_inner());
        let root = fresh_dir("layout");
        let (scene, outside) = (root.join("scene"), root.join("outside"));
        std::fs::create_dir_all(&scene).unwrap();
        std::fs::create_dir_all(&outside).unwrap();
        std::fs::write(outside.join("secret"), TRIANGLE_OBJ).unwrap();
        let mut sub_is_folder = false;
        for (name, e) in NAMES.iter().zip(&entries) {
            if name.starts_with("sub/") && !sub_is_folder {
                continue;
            }
            create(&scene, &outside, name, e);
            if *name == "sub" {
                sub_is_folder = matches!(e, Entry::Folder | Entry::File(_));
            }
        }
        let mut text = CAMERA.to_string();
        for o in &objects {
            text += &format!("[[object]]\ntype = \"mesh\"\nfile = \"{o}\"\n");
        }
        std::fs::write(scene.join("scene.toml"), text).unwrap();
        std::fs::create_dir_all(root.join("other")).unwrap();
        let (cwd, arg) = namings(&root).swap_remove(naming);
        let log = OpenLog::default();
        let options = LoadOptions { open_log: Some(log.clone()), ..LoadOptions::default() };
        let here = std::env::current_dir().unwrap();
        std::env::set_current_dir(&cwd).unwrap();
        // On a thread, so a load that blocks fails the test instead of hanging it.
        let (send, receive) = std::sync::mpsc::channel();
        let path = PathBuf::from(&arg);
        std::thread::spawn(move || {
            let _ = send.send(load_file(&raylab_plugins::registry(), &path, &options).err().map(|e| e.report()));
        });
        let outcome = receive.recv_timeout(HANG_BOUND);
        std::env::set_current_dir(here).unwrap();
        prop_assert!(outcome.is_ok(), "loading {arg} in {} still ran after {HANG_BOUND:?}", cwd.display());
        let folder = scene.canonicalize().unwrap();
        let opened = log.lock().unwrap().clone();
        for p in &opened {
            prop_assert!(p.starts_with(&folder), "opened {} outside {} (entries {entries:?}, objects {objects:?}, {arg}): {:?}",
                p.display(), folder.display(), outcome);
        }
        prop_assert!(opened.first().is_some_and(|p| p.ends_with("scene.toml")), "the scene file itself is recorded: {opened:?}");
        std::fs::remove_dir_all(root).unwrap();
    }
}
