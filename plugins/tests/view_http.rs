//! `raylab view` over plain HTTP: every header and limit the live view promises (README, "The
//! live view", Safety), on every kind of answer: the security headers (Content-Security-Policy,
//! nosniff, frame options, referrer, caching), the Host check (no Host, `localhost:PORT`), the
//! settings body limit, and `api/image.png`.
#![cfg(feature = "view")]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

mod common;
use common::{LiveView, repo, start_view};

/// How long a state may take to come (a loaded machine renders slowly).
const PATIENCE: Duration = Duration::from_secs(180);

/// Starts `raylab view` on the showcase at 64 × 48, stopping at the scene's samples (no
/// refining: the finished image is then `raylab render`'s).
fn start() -> LiveView {
    start_view(Path::new("."), &repo().join("scenes/showcase.toml"), &["--width", "64", "--height", "48", "--no-refine"])
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

/// Waits until the render is finished; returns the session's version then.
fn finished(addr: &str, token: &str) -> u64 {
    let deadline = Instant::now() + PATIENCE;
    loop {
        if get(addr, &format!("/{token}/api/image.png"), Some(addr)).status == 200 {
            let a = get(addr, &format!("/{token}/api/updates?version=0"), Some(addr));
            let len = u32::from_le_bytes(a.body[4..8].try_into().unwrap()) as usize;
            let head: serde_json::Value = serde_json::from_slice(&a.body[8..8 + len]).unwrap();
            return head["version"].as_u64().unwrap();
        }
        assert!(Instant::now() < deadline, "the render did not finish");
        // Wait for the next change of state (a long poll), not a fixed time.
        let _ = get(addr, &format!("/{token}/api/updates?version=0"), Some(addr));
    }
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
    let LiveView { process: _view, addr, token, .. } = start();
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
    let LiveView { process: _view, addr, token, .. } = start();
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
    let LiveView { process: _view, addr, token, .. } = start();
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

/// The limit on requests handled at once answers the next one at once: with 32 long polls
/// waiting for a change that does not come (the render is finished), a 33rd request is answered
/// 503, with the security headers, long before the polls end; a poll ended, requests are served
/// again.
#[test]
fn a_request_beyond_the_active_limit_is_answered_503_at_once() {
    const MAX_ACTIVE: usize = 32;
    let LiveView { process: _view, addr, token, .. } = start();
    // Wait for the render to finish, so that no poll is answered early by a change.
    let version = finished(&addr, &token);
    let poll = format!("GET /{token}/api/updates?version={version} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
    let polls: Vec<TcpStream> = (0..MAX_ACTIVE)
        .map(|_| {
            let mut s = TcpStream::connect(&addr).unwrap();
            s.write_all(poll.as_bytes()).unwrap();
            s
        })
        .collect();
    // Each poll holds its place once its request is read; until all 32 do, the 33rd may be served.
    let started = Instant::now();
    let busy = loop {
        let a = get(&addr, &format!("/{token}/view.css"), Some(&addr));
        assert_secure(&a, "while the polls wait");
        if a.status == 503 {
            break a;
        }
        assert_eq!(a.status, 200);
        assert!(started.elapsed() < Duration::from_secs(15), "no 503 while {MAX_ACTIVE} polls wait");
    };
    assert!(String::from_utf8_lossy(&busy.body).contains("too many requests"), "{}", String::from_utf8_lossy(&busy.body));
    // The polls were still waiting (they end after 20 s with no change): the 503 came first.
    for mut s in polls {
        s.set_nonblocking(true).unwrap();
        let mut b = [0u8; 1];
        assert!(matches!(s.read(&mut b), Err(e) if e.kind() == std::io::ErrorKind::WouldBlock), "a poll was answered early");
    }
    // The polls closed, their places are given back.
    let deadline = Instant::now() + PATIENCE;
    while get(&addr, &format!("/{token}/view.css"), Some(&addr)).status != 200 {
        assert!(Instant::now() < deadline, "the places were not given back");
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// The resident memory of process `pid`, in bytes (Linux: `VmRSS` of `/proc/PID/status`).
#[cfg(target_os = "linux")]
fn resident(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let kb = status.lines().find_map(|l| l.strip_prefix("VmRSS:")).unwrap().trim().trim_end_matches("kB").trim();
    kb.parse::<u64>().unwrap() * 1024
}

/// The request line and headers are bounded (32 KiB) before they are buffered: a head one byte
/// too long is answered 431, one that fits is served; a 200 MB header is cut after its first
/// bytes and the server's memory does not grow by its size (before the bound, it grew by 203 MB);
/// a body announced at 1 GB is refused without being read.
#[cfg(target_os = "linux")]
#[test]
fn an_oversized_header_is_refused_before_it_is_held() {
    const MAX_HEAD: usize = 32 * 1024;
    let LiveView { process: view, addr, token, .. } = start();
    let _ = finished(&addr, &token);
    // A head of exactly the limit (blank line included) is served; one byte more is not.
    let head = |len: usize| {
        let start = format!("GET /{token}/view.css HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nX-Pad: ");
        let mut h = start.into_bytes();
        h.resize(len - 4, b'p');
        h.extend_from_slice(b"\r\n\r\n");
        h
    };
    assert_eq!(send(&addr, &head(MAX_HEAD)).status, 200);
    let a = send(&addr, &head(MAX_HEAD + 1));
    assert_eq!(a.status, 431, "{}", String::from_utf8_lossy(&a.body));
    assert_secure(&a, "431");

    let before = resident(view.0.id());
    let mut s = TcpStream::connect(&addr).unwrap();
    s.set_write_timeout(Some(PATIENCE)).unwrap();
    s.write_all(format!("GET /{token}/view.css HTTP/1.1\r\nHost: {addr}\r\nX-Big: ").as_bytes()).unwrap();
    let chunk = vec![b'x'; 1 << 20];
    let mut sent = 0usize;
    while sent < 200 << 20 && s.write_all(&chunk).is_ok() {
        sent += chunk.len();
    }
    let grown = resident(view.0.id()).saturating_sub(before);
    assert!(sent < 200 << 20, "the server read all 200 MB of header");
    assert!(grown < 16 << 20, "the server grew by {grown} bytes for a header it refused");
    drop(s);

    // A body beyond the limit is refused from its length, at once.
    let a = send(&addr, format!("POST /{token}/api/settings HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 1000000000\r\n\r\n").as_bytes());
    assert_eq!(a.status, 400);
    assert!(String::from_utf8_lossy(&a.body).contains("too large"));
    // Still serving.
    assert_eq!(get(&addr, &format!("/{token}/view.css"), Some(&addr)).status, 200);
}

/// Slow and idle clients hold only their own connection, for a bounded time: with 40 clients
/// connected that send part of a request and wait (more than the 32 requests handled at once),
/// and one sending a byte a second, the page is served; the slow client is cut with 408 once its
/// 10 s to send a request are over, long before it would have finished.
#[test]
fn slow_and_idle_clients_do_not_block_others() {
    let LiveView { process: _view, addr, token, .. } = start();
    let idle: Vec<TcpStream> = (0..40)
        .map(|_| {
            let mut s = TcpStream::connect(&addr).unwrap();
            s.write_all(b"GET /").unwrap();
            s
        })
        .collect();
    let request = format!("GET /{token}/view.css HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
    let slow = {
        let (addr, request) = (addr.clone(), request.clone());
        std::thread::spawn(move || {
            let mut s = TcpStream::connect(&addr).unwrap();
            let started = Instant::now();
            let mut sent = 0;
            for b in request.bytes() {
                if s.write_all(&[b]).is_err() {
                    break;
                }
                sent += 1;
                std::thread::sleep(Duration::from_secs(1));
                let mut peek = [0u8; 1];
                s.set_nonblocking(true).unwrap();
                let answered = !matches!(s.peek(&mut peek), Err(e) if e.kind() == std::io::ErrorKind::WouldBlock);
                s.set_nonblocking(false).unwrap();
                if answered {
                    break;
                }
            }
            s.set_read_timeout(Some(PATIENCE)).unwrap();
            let mut answer = Vec::new();
            let _ = s.read_to_end(&mut answer);
            (sent, started.elapsed(), String::from_utf8_lossy(&answer).into_owned())
        })
    };
    for _ in 0..3 {
        let a = get(&addr, &format!("/{token}/view.css"), Some(&addr));
        assert_eq!(a.status, 200, "{}", String::from_utf8_lossy(&a.body));
    }
    let (sent, took, answer) = slow.join().unwrap();
    assert!(answer.starts_with("HTTP/1.1 408 "), "the slow client got {answer:?} after {took:?}");
    assert!(sent < request.len(), "the slow client sent its whole request ({sent} bytes in {took:?})");
    drop(idle);
}
