//! Writing images safely: files replaced atomically (a failed write leaves the old file); an
//! image buffer's memory that could not be had ([`OutOfMemory`]) is reported as a write error.

use crate::render::film::OutOfMemory;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Error writing an image.
#[derive(Debug)]
pub struct WriteError(pub String);

impl std::fmt::Display for WriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for WriteError {}

impl From<OutOfMemory> for WriteError {
    fn from(e: OutOfMemory) -> Self {
        WriteError(e.0)
    }
}

/// Runs `write` into a temporary file beside `path`, flushes it to disk and renames it over
/// `path`. On any failure the temporary file is removed and `path` is untouched.
pub fn write_atomically(path: &Path, write: impl FnOnce(&mut dyn Write) -> Result<(), String>) -> Result<(), WriteError> {
    let tmp = temp_path(path);
    let result = (|| {
        let file = std::fs::File::create(&tmp).map_err(|e| format!("cannot create \"{}\": {e}", tmp.display()))?;
        let mut buf = std::io::BufWriter::new(file);
        write(&mut buf)?;
        let file = buf.into_inner().map_err(|e| e.to_string())?;
        file.sync_all().map_err(|e| e.to_string())?;
        std::fs::rename(&tmp, path).map_err(|e| format!("cannot rename to \"{}\": {e}", path.display()))
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        WriteError(format!("writing \"{}\" failed: {e}", path.display()))
    })
}

fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map_or_else(|| "image".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}
