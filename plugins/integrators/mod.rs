//! Integrators: the report's recursive `phong` model, the `path` tracer, and the `normals` and
//! `depth` debug views.

pub mod debug;
pub mod path;
pub mod phong;

use raylab::Registry;

/// Registers every integrator; `phong` is the default.
pub fn register(r: &mut Registry) {
    r.add_integrator(phong::INFO, phong::build);
    r.add_integrator(path::INFO, path::build);
    r.add_integrator(debug::NORMALS_INFO, debug::build_normals);
    r.add_integrator(debug::DEPTH_INFO, debug::build_depth);
    r.set_default_integrator("phong");
}
