//! # raylab-torus
//!
//! A plugin crate outside raylab's core, written as any third party would write one: it depends
//! on `raylab` (the traits, the registry, the CLI) and `raylab-plugins` (the built-in plugins),
//! implements the traits, and registers its types by name. Scene files then use them like any
//! built-in (`type = "torus"`), and the `raylab-torus` binary renders them with the same CLI.
//!
//! It adds a [`torus`] geometry (a quartic, solved robustly by [`roots`]), and the other
//! examples of `docs/writing-a-plugin.md`: a [`panel_light`] area light, an [`ao`] (ambient
//! occlusion) integrator, a [`marble`] texture, an [`oren_nayar`] (rough diffuse) material and a
//! [`ppm`] image writer.
//!
//! ```no_run
//! let registry = raylab_torus::registry();
//! let job = raylab::load::loader::load_file(&registry, "examples/torus/scenes/torus.toml".as_ref(), &Default::default()).unwrap();
//! ```

pub mod ao;
pub mod marble;
pub mod oren_nayar;
pub mod panel_light;
pub mod ppm;
pub mod roots;
pub mod torus;

use raylab::Registry;

/// The scene the `raylab-torus` binary renders when run without arguments.
pub const DEFAULT_SCENE: (&str, &str) = ("examples/torus/scenes/torus.toml", include_str!("../scenes/torus.toml"));

/// Adds this crate's plugins to `r`: `torus`, the `panel` light, the `ao` integrator, the
/// `marble` texture, the `oren_nayar` material and the `.ppm` output format.
pub fn register(r: &mut Registry) {
    r.add_geometry_with_samples(torus::INFO, torus::build, torus::SAMPLERS);
    r.add_texture(marble::INFO, marble::build);
    r.add_material(oren_nayar::INFO, oren_nayar::build);
    r.add_light(panel_light::INFO, panel_light::build);
    r.add_integrator(ao::INFO, ao::build);
    r.add_output_format(ppm::format());
}

/// Every built-in plugin plus this crate's.
pub fn registry() -> Registry {
    let mut r = raylab_plugins::registry();
    register(&mut r);
    r
}

/// raylab's command line with [`registry`]: what the `raylab-torus` binary runs.
pub fn app() -> raylab::cli::App {
    raylab::cli::App { registry: registry(), default_scene: DEFAULT_SCENE }
}
