//! What the test files share: running the `raylab` binary, a fresh folder per test, the
//! checkout's root, a live view started and its page's address, and ([`blocks`]) a block of
//! camera hits shaded together checked against the same hits shaded one by one. Each test file
//! takes the part it needs (`mod common;`), so the rest is unused there.
#![allow(dead_code)]

pub mod blocks;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

/// `raylab ARGS`, run in `dir`, to its end.
pub fn raylab(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raylab")).args(args).current_dir(dir).output().expect("raylab runs")
}

/// An empty folder of this test file's (`raylab-FILE-NAME-PID` in the system's temporary folder).
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("raylab-{}-{name}-{}", env!("CARGO_CRATE_NAME"), std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The checkout's root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// Output bytes as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Whether the denoiser's tool is here (else the test says it skips `what`; CI must have it).
pub fn denoiser_here(what: &str) -> bool {
    if raylab::image::denoise::available() {
        return true;
    }
    assert!(std::env::var_os("CI").is_none(), "CI must have the denoiser: {}", raylab::image::denoise::INSTALL_HINT);
    eprintln!("SKIPPED {what}: no oidnDenoise ({})", raylab::image::denoise::INSTALL_HINT);
    false
}

/// The RMSE of `image` against `reference` on displayed values (each channel clamped to 1: a
/// light's own pixels, far brighter, would decide alone).
pub fn displayed_rmse(image: &raylab::Film, reference: &raylab::Film) -> f64 {
    let one = raylab::glam::Vec3::ONE;
    let d = image.pixels.iter().zip(&reference.pixels).map(|(a, b)| (a.min(one) - b.min(one)).length_squared() as f64);
    (d.sum::<f64>() / image.pixels.len() as f64).sqrt()
}

/// Kills the process when dropped (a failed assertion must not leave a server behind).
pub struct Guard(pub Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A `raylab view` running: the process (killed when dropped) and where its page is.
pub struct LiveView {
    pub process: Guard,
    /// The page: `http://127.0.0.1:PORT/TOKEN/`.
    pub url: String,
    /// `127.0.0.1:PORT`.
    pub addr: String,
    /// The session's token (the first segment of every path).
    pub token: String,
}

/// Starts `raylab view SCENE --port 0 ARGS` in `dir` (its standard error shown with the test's)
/// and reads the page's URL from the first line it prints.
pub fn start_view(dir: &Path, scene: &Path, args: &[&str]) -> LiveView {
    let mut child = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["view", scene.to_str().unwrap(), "--port", "0"])
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("raylab view starts");
    // Guarded before reading: a server that prints no URL is still killed.
    let stdout = child.stdout.take().unwrap();
    let process = Guard(child);
    let mut line = String::new();
    BufReader::new(stdout).read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("http://")).unwrap_or_else(|| panic!("no URL in {line:?}")).to_string();
    let (addr, token) =
        url.strip_prefix("http://").and_then(|rest| rest.split_once('/')).unwrap_or_else(|| panic!("not a page's URL: {url}"));
    let (addr, token) = (addr.to_string(), token.trim_end_matches('/').to_string());
    LiveView { process, url, addr, token }
}
