//! `raylab view` over plain HTTP: every header and limit the live view promises (README, "The
//! live view", Safety), on every kind of answer: the security headers (Content-Security-Policy,
//! nosniff, frame options, referrer, caching), the Host check (no Host, `localhost:PORT`), the
//! settings body limit, and `api/image.png`.
#![cfg(feature = "view")]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// How long a state may take to come (a loaded machine renders slowly).
const PATIENCE: Duration = Duration::from_secs(180);

/// Kills the server when dropped.
struct Guard(Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// Starts `raylab view` on the showcase at 64 × 48; returns it, `127.0.0.1:PORT` and the token.
fn start() -> (Guard, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["view", repo().join("scenes/showcase.toml").to_str().unwrap(), "--port", "0", "--width", "64", "--height", "48"])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("http://")).unwrap_or_else(|| panic!("no URL in {line:?}")).to_string();
    let (addr, token) = url.strip_prefix("http://").unwrap().split_once('/').unwrap();
    (Guard(child), addr.to_string(), token.trim_end_matches('/').to_string())
}

/// An answer: status, headers (lower-case names), body.
struct Answer {
    status: u16,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl Answer {
    fn header(&self, name: &str) -> Option<&str> {
        self.headers.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
    }
}

/// Sends raw `request` bytes and reads the answer (by its length, or to the end).
fn send(addr: &str, request: &[u8]) -> Answer {
    let mut s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(PATIENCE)).unwrap();
    s.write_all(request).unwrap();
    let mut r = BufReader::new(s);
    let mut line = String::new();
    r.read_line(&mut line).unwrap();
    let status = line.split_whitespace().nth(1).unwrap_or_else(|| panic!("status line {line:?}")).parse().unwrap();
    let mut headers = Vec::new();
    loop {
        line.clear();
        r.read_line(&mut line).unwrap();
        let l = line.trim_end();
        if l.is_empty() {
            break;
        }
        let (n, v) = l.split_once(':').unwrap();
        headers.push((n.trim().to_ascii_lowercase(), v.trim().to_string()));
    }
    let mut body = Vec::new();
    match headers.iter().find(|(n, _)| n == "content-length").map(|(_, v)| v.parse::<usize>().unwrap()) {
        Some(n) => {
            body.resize(n, 0);
            r.read_exact(&mut body).unwrap();
        }
        None => {
            r.read_to_end(&mut body).unwrap();
        }
    }
    Answer { status, headers, body }
}

fn get(addr: &str, path: &str, host: Option<&str>) -> Answer {
    let host = host.map(|h| format!("Host: {h}\r\n")).unwrap_or_default();
    send(addr, format!("GET {path} HTTP/1.1\r\n{host}Connection: close\r\n\r\n").as_bytes())
}

fn post(addr: &str, path: &str, body: &[u8]) -> Answer {
    let mut req = format!(
        "POST {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n",
        body.len()
    )
    .into_bytes();
    req.extend_from_slice(body);
    send(addr, &req)
}

/// The headers on every answer, whatever its status.
fn assert_secure(a: &Answer, what: &str) {
    let csp = a.header("content-security-policy").unwrap_or_else(|| panic!("{what}: no Content-Security-Policy"));
    for directive in ["default-src 'self'", "script-src 'self'", "style-src 'self'", "connect-src 'self'", "frame-ancestors 'none'"] {
        assert!(csp.split(';').any(|d| d.trim() == directive), "{what}: CSP {csp:?} lacks {directive:?}");
    }
    assert!(!csp.contains("unsafe-inline") && !csp.contains("unsafe-eval") && !csp.contains('*'), "{what}: CSP {csp:?} opens a door");
    assert_eq!(a.header("x-content-type-options"), Some("nosniff"), "{what}");
    assert_eq!(a.header("x-frame-options"), Some("DENY"), "{what}");
    assert_eq!(a.header("referrer-policy"), Some("no-referrer"), "{what}");
    assert_eq!(a.header("cache-control"), Some("no-store"), "{what}");
}

#[test]
fn every_answer_carries_the_security_headers_and_the_host_rules_hold() {
    let (_view, addr, token) = start();
    let port = addr.split(':').nth(1).unwrap();
    let page = format!("/{token}/");
    for (path, kind) in
        [(page.clone(), "text/html"), (format!("{page}view.js"), "text/javascript"), (format!("{page}view.css"), "text/css")]
    {
        let a = get(&addr, &path, Some(&addr));
        assert_eq!(a.status, 200, "{path}");
        assert!(a.header("content-type").is_some_and(|t| t.starts_with(kind)), "{path}: {:?}", a.header("content-type"));
        assert_secure(&a, &path);
    }
    // localhost at the server's port is the same server; no Host, or another port, is refused.
    let a = get(&addr, &page, Some(&format!("localhost:{port}")));
    assert_eq!(a.status, 200, "Host localhost:{port}");
    assert_secure(&a, "localhost");
    for host in [None, Some("localhost"), Some("127.0.0.1"), Some("localhost:1"), Some("127.0.0.1.evil.test")] {
        let a = get(&addr, &page, host);
        assert_eq!(a.status, 403, "Host {host:?}");
        assert_secure(&a, &format!("403 for Host {host:?}"));
    }
    let a = get(&addr, &format!("{page}nothing-here"), Some(&addr));
    assert_eq!(a.status, 404);
    assert_secure(&a, "404");
    let a = get(&addr, "/", Some(&addr));
    assert_eq!(a.status, 403);
    assert_secure(&a, "403 without the token");
}

/// The settings body is read up to 64 KiB: a valid body padded to the limit is taken, one byte
/// more is refused (400, nothing applied).
#[test]
fn the_settings_body_is_limited_to_64_kib() {
    const MAX_BODY: usize = 64 * 1024;
    let (_view, addr, token) = start();
    let path = format!("/{token}/api/settings");
    let body = |len: usize| {
        let mut b = br#"{"params": {}}"#.to_vec();
        b.resize(len, b' ');
        b
    };
    let a = post(&addr, &path, &body(MAX_BODY));
    assert_eq!(a.status, 200, "{}", String::from_utf8_lossy(&a.body));
    assert_secure(&a, "settings taken");
    let a = post(&addr, &path, &body(MAX_BODY + 1));
    assert_eq!(a.status, 400, "{}", String::from_utf8_lossy(&a.body));
    assert!(String::from_utf8_lossy(&a.body).contains("too large"), "{}", String::from_utf8_lossy(&a.body));
    assert_secure(&a, "settings too large");
}

/// `api/image.png`: 409 until the render is done, then the image `raylab render` writes, as a
/// PNG download.
#[test]
fn the_finished_image_is_the_renders_png() {
    let (_view, addr, token) = start();
    let deadline = Instant::now() + PATIENCE;
    let a = loop {
        let a = get(&addr, &format!("/{token}/api/image.png"), Some(&addr));
        assert_secure(&a, "image.png");
        if a.status == 200 {
            break a;
        }
        assert_eq!(a.status, 409, "{}", String::from_utf8_lossy(&a.body));
        assert!(Instant::now() < deadline, "the render did not finish");
        // Wait for the next change of state (a long poll), not a fixed time.
        let _ = get(&addr, &format!("/{token}/api/updates?version=0"), Some(&addr));
    };
    assert_eq!(a.header("content-type"), Some("image/png"));
    assert!(a.header("content-disposition").is_some_and(|d| d.starts_with("attachment")), "{:?}", a.header("content-disposition"));
    let dir = std::env::temp_dir().join(format!("raylab-view-http-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", repo().join("scenes/showcase.toml").to_str().unwrap(), "--width", "64", "--height", "48", "-q", "-o"])
        .arg(dir.join("r.png"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let rendered = image::open(dir.join("r.png")).unwrap().to_rgb8();
    let served = image::load_from_memory(&a.body).unwrap().to_rgb8();
    assert!(rendered == served, "the served image differs from raylab render's");
    std::fs::remove_dir_all(dir).unwrap();
}
