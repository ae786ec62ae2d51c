//! raylab from Python: the native half of the `raylab` package (`raylab._raylab`).
//!
//! Everything here calls the core's public API, the one the CLI calls: scenes are loaded by
//! [`raylab::load::loader`] with the same overrides, limits and sandbox, rendered by
//! [`raylab::render::render_progressive`], explained by [`raylab::render::explain_pixel`], split
//! into tiles by [`raylab::render::split`] and merged by [`raylab::render::share::merge`]. The
//! Python half (`raylab/__init__.py`) turns the buffers into NumPy arrays and keyword arguments
//! into these calls.
//!
//! A plugin crate exposes its plugins to Python by building its own extension module that calls
//! [`init`] with its registry (see `python/README.md`).

mod image;
mod scene;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use raylab::load::registry::Registry;
use raylab::param::error::Location;
use std::sync::OnceLock;

create_exception!(
    raylab,
    SceneError,
    PyException,
    "A scene that cannot be loaded: `file`, `line` and `column` say where (None when unknown), `message` what is wrong; str() is the report the CLI prints."
);

/// The plugins of this extension module (each module built from this crate has its own).
static REGISTRY: OnceLock<Registry> = OnceLock::new();

/// The registry [`init`] installed.
pub(crate) fn registry() -> PyResult<&'static Registry> {
    REGISTRY.get().ok_or_else(|| pyo3::exceptions::PyRuntimeError::new_err("raylab: the module was not initialised with a registry"))
}

/// A core scene error as `raylab.SceneError`, with its location as attributes.
pub(crate) fn scene_error(py: Python<'_>, e: &raylab::param::error::SceneError) -> PyErr {
    let err = SceneError::new_err(e.report());
    let (file, line_col) = match &e.location {
        Location::None => (None, None),
        Location::File { path, line_col } => (Some(path.clone()), *line_col),
        Location::Span(loc) => (Some(loc.source.name.clone()), Some(loc.source.line_col(loc.start))),
    };
    let v = err.value(py);
    let attrs = [
        v.setattr("file", file),
        v.setattr("line", line_col.map(|l| l.0)),
        v.setattr("column", line_col.map(|l| l.1)),
        v.setattr("message", e.message.clone()),
        v.setattr("help", e.help.clone()),
    ];
    match attrs.into_iter().find_map(Result::err) {
        Some(failed) => failed,
        None => err,
    }
}

/// A failure that is not the scene's (a render setting, a file to write) as `RuntimeError`.
pub(crate) fn runtime_error(e: impl std::fmt::Display) -> PyErr {
    pyo3::exceptions::PyRuntimeError::new_err(e.to_string())
}

/// Fills `m` with raylab's classes and functions, loading scenes through `registry`. The
/// `raylab._raylab` module calls it with the built-in plugins; a plugin crate's own module calls
/// it with a registry that adds its plugins (only once per process and module: the registry is
/// the module's for its lifetime).
pub fn init(m: &Bound<'_, PyModule>, registry: Registry) -> PyResult<()> {
    let _ = REGISTRY.set(registry);
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<image::Rendered>()?;
    m.add_function(wrap_pyfunction!(scene::load, m)?)?;
    m.add_function(wrap_pyfunction!(scene::loads, m)?)?;
    m.add_function(wrap_pyfunction!(plugins, m)?)?;
    m.add_function(wrap_pyfunction!(image::merge, m)?)?;
    m.add_function(wrap_pyfunction!(image::compare, m)?)?;
    m.add_function(wrap_pyfunction!(image::read_reference, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("FEATURES", ["mesh", "bvh", "exr"])?;
    Ok(())
}

/// Every registered type and its parameters, as JSON text (`raylab plugins --json`).
#[pyfunction]
fn plugins() -> PyResult<String> {
    Ok(registry()?.to_json().to_string())
}

/// The native module of the `raylab` package, with the built-in plugins.
#[pymodule]
fn _raylab(m: &Bound<'_, PyModule>) -> PyResult<()> {
    init(m, raylab_plugins::registry())
}
