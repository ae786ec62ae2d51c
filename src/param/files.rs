//! Reading files a user or a scene names: regular files only, never more bytes than a limit.
//!
//! Every such read (the scene file, meshes, glTF buffers, MTL libraries, reference images) goes
//! through [`read_regular`], so a FIFO cannot block the load, a device (`/dev/zero`) cannot feed
//! bytes without end, and a file that grows after its size was checked is still cut at the limit.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Where the files opened by a load are recorded, by their real path (for tests that check
/// which files a scene made raylab open).
pub type OpenLog = Arc<Mutex<Vec<PathBuf>>>;

/// Why a file was not read.
#[derive(Debug)]
pub enum ReadError {
    /// The file could not be opened or read.
    Io(std::io::Error),
    /// Not a regular file; what it is instead ("a directory", "a FIFO", …).
    NotRegular(&'static str),
    /// More bytes than the limit: `size` from the file's metadata when it told, else unknown.
    TooLarge { size: Option<u64>, limit: u64 },
}

impl ReadError {
    /// The message for this failure on the file called `what` (e.g. `"m.obj"` quoted, or `scene`).
    pub fn message(&self, what: &str) -> String {
        match self {
            ReadError::Io(e) => format!("cannot read {what}: {e}"),
            ReadError::NotRegular(kind) => format!("{what} is {kind}, expected a regular file"),
            ReadError::TooLarge { size: Some(size), limit } => format!("{what} is {size} bytes, over the limit of {limit}"),
            ReadError::TooLarge { size: None, limit } => format!("{what} holds more than {limit} bytes, over the limit"),
        }
    }

    /// How the user may get past it, when a flag can.
    pub fn help(&self) -> Option<&'static str> {
        matches!(self, ReadError::TooLarge { .. }).then_some("raise it with --max-file-bytes")
    }
}

/// A file opened for reading, known to be a regular file.
pub struct Opened {
    file: File,
    /// The file's real path (of the open descriptor where the system tells it), if known.
    pub real_path: Option<PathBuf>,
}

/// Opens `path` (following symbolic links) only if it is a regular file, without blocking on a
/// FIFO, and records its real path in `log`.
pub fn open_regular(path: &Path, log: Option<&OpenLog>) -> Result<Opened, ReadError> {
    // Checked before opening, so a FIFO or device is never opened …
    let meta = std::fs::metadata(path).map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind(&meta.file_type())));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // … and opened without blocking should it have been replaced by a FIFO since.
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(ReadError::Io)?;
    let real_path = real_path(&file, path);
    if let Some(log) = log {
        log.lock().unwrap_or_else(|e| e.into_inner()).push(real_path.clone().unwrap_or_else(|| path.to_path_buf()));
    }
    // The opened handle decides: what was checked above may have been swapped.
    let meta = file.metadata().map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind(&meta.file_type())));
    }
    Ok(Opened { file, real_path })
}

impl Opened {
    /// All the file's bytes, refusing it once more than `limit` come (whatever its metadata
    /// said).
    pub fn read_to_end(self, limit: u64) -> Result<Vec<u8>, ReadError> {
        let declared = self.file.metadata().map(|m| m.len()).unwrap_or(0);
        if declared > limit {
            return Err(ReadError::TooLarge { size: Some(declared), limit });
        }
        let mut bytes = Vec::new();
        // The declared size only sizes the first allocation; the limit bounds the read.
        let _ = bytes.try_reserve_exact(usize::try_from(declared).unwrap_or(0));
        self.file.take(limit.saturating_add(1)).read_to_end(&mut bytes).map_err(ReadError::Io)?;
        if bytes.len() as u64 > limit {
            return Err(ReadError::TooLarge { size: None, limit });
        }
        Ok(bytes)
    }
}

/// Reads the regular file `path`, at most `limit` bytes (see [`open_regular`]).
pub fn read_regular(path: &Path, limit: u64, log: Option<&OpenLog>) -> Result<Vec<u8>, ReadError> {
    open_regular(path, log)?.read_to_end(limit)
}

/// True when `a` and `b` name one existing file, however each is spelled: the same canonical path
/// (relative or absolute, with `./` or `..`, through a symbolic link) or, on Unix, the same device
/// and inode (a hard link). A path that does not exist names no file. Every command that writes
/// a file checks it against each file it reads with this ([`overwritten_input`]).
pub fn same_file(a: &Path, b: &Path) -> bool {
    if let (Ok(x), Ok(y)) = (a.canonicalize(), b.canonicalize())
        && x == y
    {
        return true;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    false
}

/// The first of `inputs` that writing `output` would overwrite ([`same_file`]).
pub fn overwritten_input<'a>(output: &Path, inputs: impl IntoIterator<Item = &'a Path>) -> Option<&'a Path> {
    inputs.into_iter().find(|i| same_file(output, i))
}

/// What a file that is not regular is, in words.
fn kind(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() { "a directory" } else { "not a regular file" }
}

/// The real path of the open `file` (named `path`): on Linux the descriptor's own, elsewhere
/// `path` canonicalised.
fn real_path(file: &File, path: &Path) -> Option<PathBuf> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        if let Ok(p) = std::fs::read_link(format!("/proc/self/fd/{}", file.as_raw_fd())) {
            return Some(p);
        }
    }
    let _ = file;
    path.canonicalize().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("raylab-files-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn reads_regular_files_up_to_the_limit_and_records_their_real_path() {
        let dir = temp_dir("regular");
        let f = dir.join("a.txt");
        std::fs::write(&f, b"12345").unwrap();
        let log = OpenLog::default();
        assert_eq!(read_regular(&f, 5, Some(&log)).unwrap(), b"12345");
        assert_eq!(log.lock().unwrap().as_slice(), [f.canonicalize().unwrap()]);
        let e = read_regular(&f, 4, None).unwrap_err();
        assert_eq!(e.message("\"a.txt\""), "\"a.txt\" is 5 bytes, over the limit of 4");
        assert_eq!(e.help(), Some("raise it with --max-file-bytes"));
        let e = read_regular(&dir, 100, None).unwrap_err();
        assert_eq!(e.message("it"), "it is a directory, expected a regular file");
        assert!(read_regular(&dir.join("missing"), 100, None).unwrap_err().message("it").starts_with("cannot read it: "));
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_fifos_are_refused_without_reading() {
        let dir = temp_dir("special");
        let e = read_regular(Path::new("/dev/zero"), u64::MAX, None).unwrap_err();
        assert_eq!(e.message("it"), "it is a device, expected a regular file");
        std::os::unix::fs::symlink("/dev/zero", dir.join("zero")).unwrap();
        assert!(matches!(read_regular(&dir.join("zero"), u64::MAX, None), Err(ReadError::NotRegular("a device"))));
        let fifo = dir.join("fifo");
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        assert!(matches!(read_regular(&fifo, u64::MAX, None), Err(ReadError::NotRegular("a FIFO"))));
        std::fs::remove_dir_all(dir).unwrap();
    }
}
