//! raylab's built-in plugins: the report's shapes, lights and recursive Phong integrator, plus
//! textures (procedural patterns and images), debug integrators, the reader of the report's XML scenes, and (feature `mesh`) triangle meshes
//! from OBJ and glTF files. They use only the public API of the `raylab` core crate, exactly as a
//! third-party plugin crate would.
//!
//! ```no_run
//! let registry = raylab_plugins::registry();
//! let job = raylab::load::loader::load_file(&registry, "scenes/showcase.toml".as_ref(), &Default::default()).unwrap();
//! ```

pub mod formats;
pub mod integrators;
pub mod lights;
pub mod materials;
#[cfg(feature = "mesh")]
pub mod mesh;
pub mod shapes;
pub mod textures;

use raylab::Registry;

/// The scene `raylab` renders when run without arguments (`scenes/showcase.toml`).
pub const DEFAULT_SCENE: (&str, &str) = ("scenes/showcase.toml", include_str!("../scenes/showcase.toml"));

/// Adds every built-in plugin to `r`.
pub fn register(r: &mut Registry) {
    shapes::register(r);
    textures::register(r);
    materials::register(r);
    lights::register(r);
    integrators::register(r);
    formats::register(r);
    #[cfg(feature = "mesh")]
    mesh::register(r);
    // Built without `mesh`: a `mesh` object or a model file says which feature it needs.
    #[cfg(not(feature = "mesh"))]
    for name in ["mesh", "obj", "gltf", "glb"] {
        r.add_absent(raylab::load::registry::Absent { name, feature: "mesh" });
    }
}

/// A registry holding every built-in plugin.
pub fn registry() -> Registry {
    let mut r = Registry::new();
    register(&mut r);
    r
}

/// The command line with the built-in plugins: what the `raylab` binary runs.
pub fn app() -> raylab::cli::App {
    raylab::cli::App { registry: registry(), default_scene: DEFAULT_SCENE }
}
