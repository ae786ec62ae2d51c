//! A **PPM image writer**: the example of an output format a plugin registers (docs/writing-a-
//! plugin.md, "Formats"). Binary PPM (`P6`) holds 8-bit RGB after a short text header, so the
//! writer is the core's 8-bit conversion (clamped and encoded, with the grid if asked for) and a
//! few lines of bytes. Registered by one line: `r.add_output_format(ppm::format())`; then
//! `raylab-torus render scene.toml -o image.ppm` writes one, and `raylab-torus plugins` lists it.

use raylab::Film;
use raylab::image::output::{OutputFormat, WriteSettings, try_rgb8};
use raylab::image::write::{WriteError, write_atomically};
use std::path::Path;
use std::sync::Arc;

/// The `ppm` output format.
pub fn format() -> OutputFormat {
    OutputFormat {
        name: "ppm",
        extensions: &["ppm"],
        summary: "binary PPM (P6), 8 bits per channel: clamped and encoded like PNG (example plugin)",
        hdr: false,
        layers: false,
        write: Arc::new(write),
    }
}

/// Writes `film` as binary PPM to `path`, atomically.
pub fn write(path: &Path, film: &Film, s: &WriteSettings) -> Result<(), WriteError> {
    let rgb = try_rgb8(film, s.encoding, s.grid)?;
    write_atomically(path, |w| {
        write!(w, "P6\n{} {}\n255\n", film.width, film.height).map_err(|e| e.to_string())?;
        w.write_all(&rgb).map_err(|e| e.to_string())
    })
}
