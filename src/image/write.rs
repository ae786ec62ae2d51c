//! Writing images safely: files replaced atomically (a failed write leaves the old file), and
//! image buffers allocated without aborting the process when memory runs out.

use std::io::Write;
use std::path::{Path, PathBuf};

/// A vector of `n` copies of `value`, or an error naming `what` if the memory cannot be had
/// (instead of aborting the process).
pub fn try_filled<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, WriteError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| WriteError(format!("out of memory for the {what} ({n} values)")))?;
    v.resize(n, value);
    Ok(v)
}

/// Error writing an image.
#[derive(Debug)]
pub struct WriteError(pub String);

impl std::fmt::Display for WriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for WriteError {}

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
