//! `raylab view`: the server's guards over plain HTTP, and the page in a real browser (headless
//! Chromium driven through chromedriver's WebDriver API): it loads, shows the finished image with
//! the bits `raylab render` writes, restarts when a knob changes, and explains a clicked pixel
//! with the tree `raylab trace --json` gives. Screenshots go to `target/tmp/view-browser/`.
//! The browser test is skipped, saying so, when Chromium or chromedriver is missing, and fails
//! then in CI (`CI` set: CI installs them).
#![cfg(feature = "view")]

use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{Guard, LiveView, denoiser_here, repo, start_view, temp_dir};

/// How long the page may take to reach a state (a loaded machine renders slowly).
const PATIENCE: Duration = Duration::from_secs(180);

/// One HTTP/1.1 request: status and body (read by its length or its chunks: chromedriver does not
/// close the connection after answering).
fn http(addr: &str, method: &str, path: &str, host: &str, body: Option<&Value>) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(PATIENCE)).unwrap();
    let body = body.map(|b| b.to_string()).unwrap_or_default();
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    s.write_all(head.as_bytes()).unwrap();
    s.write_all(body.as_bytes()).unwrap();
    let mut r = BufReader::new(s);
    let mut line = String::new();
    r.read_line(&mut line).unwrap();
    let status: u16 = line.split_whitespace().nth(1).unwrap_or_else(|| panic!("status line {line:?}")).parse().unwrap();
    let (mut length, mut chunked) = (None, false);
    loop {
        line.clear();
        r.read_line(&mut line).unwrap();
        let l = line.trim().to_ascii_lowercase();
        if l.is_empty() {
            break;
        }
        if let Some(v) = l.strip_prefix("content-length:") {
            length = Some(v.trim().parse::<usize>().unwrap());
        }
        chunked |= l.starts_with("transfer-encoding:") && l.contains("chunked");
    }
    let mut out = Vec::new();
    if chunked {
        loop {
            line.clear();
            r.read_line(&mut line).unwrap();
            let size = usize::from_str_radix(line.trim().split(';').next().unwrap(), 16).unwrap();
            let mut chunk = vec![0; size + 2];
            r.read_exact(&mut chunk).unwrap();
            if size == 0 {
                break;
            }
            out.extend_from_slice(&chunk[..size]);
        }
    } else if let Some(n) = length {
        out.resize(n, 0);
        r.read_exact(&mut out).unwrap();
    } else {
        r.read_to_end(&mut out).unwrap();
    }
    (status, out)
}

const SIZE: [&str; 4] = ["--width", "160", "--height", "120"];

#[test]
fn the_server_answers_only_its_own_host_and_token() {
    let dir = temp_dir("guards");
    let LiveView { process: _view, url, addr, token } = start_view(&dir, &repo().join("scenes/showcase.toml"), &SIZE);
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");
    assert_eq!(token.len(), 32, "a 128-bit token");
    let (code, body) = http(&addr, "GET", &format!("/{token}/"), &addr, None);
    assert_eq!(code, 200);
    assert!(String::from_utf8_lossy(&body).contains("raylab live view"));
    for (path, host) in [
        ("/".to_string(), addr.clone()),
        ("/index.html".to_string(), addr.clone()),
        (format!("/{}/", &token[..31]), addr.clone()),
        (format!("/{token}x/"), addr.clone()),
        (format!("/{token}/"), "evil.example:80".to_string()),
        (format!("/{token}/"), format!("attacker.test:{}", addr.split(':').nth(1).unwrap())),
    ] {
        let (code, _) = http(&addr, "GET", &path, &host, None);
        assert_eq!(code, 403, "{path} with Host {host}");
    }
    let (code, _) = http(&addr, "GET", &format!("/{token}/../Cargo.toml"), &addr, None);
    assert!(code == 404 || code == 403, "nothing from disk: {code}");
    let (code, _) = http(&addr, "GET", &format!("/{token}/scenes/showcase.toml"), &addr, None);
    assert_eq!(code, 404, "nothing from disk");
    // Bad settings are refused; a bad value is an error on the page, located at the control.
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/settings"), &addr, Some(&json!({ "nonsense": 1 })));
    assert_eq!(code, 400);
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/settings"), &addr, Some(&json!({ "aa_threshold": 7.5, "params": {} })));
    assert_eq!(code, 200);
    let deadline = Instant::now() + PATIENCE;
    loop {
        let (_, body) = http(&addr, "GET", &format!("/{token}/api/updates?version=0&frame=0&seq=0&knobs=0"), &addr, None);
        let n = u32::from_le_bytes(body[4..8].try_into().unwrap()) as usize;
        let head: Value = serde_json::from_slice(&body[8..8 + n]).unwrap();
        if head["status"]["phase"] == "error" {
            let e = &head["status"]["error"];
            assert_eq!(e["file"], "page control \"aa_threshold\"", "{e}");
            assert!(e["message"].as_str().unwrap().contains("aa_threshold"), "{e}");
            break;
        }
        assert!(Instant::now() < deadline, "no error shown: {head}");
        std::thread::sleep(Duration::from_millis(100));
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// The status the page polls: waits for a change after `version` (a long poll) and returns the
/// answer's JSON head.
fn updates(addr: &str, token: &str, version: u64) -> Value {
    let (code, body) = http(addr, "GET", &format!("/{token}/api/updates?version={version}&frame=0&seq=0&knobs=0"), addr, None);
    assert_eq!(code, 200);
    let n = u32::from_le_bytes(body[4..8].try_into().unwrap()) as usize;
    serde_json::from_slice(&body[8..8 + n]).unwrap()
}

/// Polls until `ok` holds of the status (or PATIENCE runs out); returns the last head.
fn wait_for(addr: &str, token: &str, what: &str, ok: impl Fn(&Value) -> bool) -> Value {
    let deadline = Instant::now() + PATIENCE;
    let mut version = 0;
    loop {
        let head = updates(addr, token, version);
        if ok(&head["status"]) {
            return head;
        }
        assert!(Instant::now() < deadline, "{what}: not reached; the status is {}", head["status"]);
        assert_ne!(head["status"]["phase"], "error", "{what}: {}", head["status"]);
        version = head["version"].as_u64().unwrap();
    }
}

/// The path tracer keeps refining past the scene's samples, pass after pass, and the page's Stop
/// ends it with the refined image kept (and served by Save PNG); a setting starts it again.
#[test]
fn the_path_tracer_keeps_refining_until_stopped() {
    let dir = temp_dir("refine");
    let scene = repo().join("scenes/path-cornell.toml");
    let args = ["--width", "24", "--height", "24", "--spp", "2", "--threads", "2"];
    let LiveView { process: _view, addr, token, .. } = start_view(&dir, &scene, &args);
    // The scene's 2 samples, then more: a refined pass is shown once it has more than 2.
    let samples = |s: &Value| s["samples"][0].as_u64().unwrap();
    let first = wait_for(&addr, &token, "refining", |s| s["phase"] == "refining" && samples(s) > 2);
    let later = wait_for(&addr, &token, "a later pass", |s| s["phase"] == "refining" && samples(s) > samples(&first["status"]));
    assert!(samples(&later["status"]) >= 2 * samples(&first["status"]), "passes double: {} then {}", first["status"], later["status"]);
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/stop"), &addr, None);
    assert_eq!(code, 200);
    let done = wait_for(&addr, &token, "the stop", |s| s["phase"] == "done");
    let ended = done["status"]["ended"].as_str().unwrap();
    assert!(ended.starts_with("stopped refining, at ") && ended.ends_with(" samples per pixel"), "{ended}");
    // Save PNG: the refined image, not the scene's 2-spp one.
    let (code, png) = http(&addr, "GET", &format!("/{token}/api/image.png"), &addr, None);
    assert_eq!(code, 200);
    let served = image::load_from_memory(&png).unwrap().to_rgb8();
    let out = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", scene.to_str().unwrap(), "-o", "two.png", "-q"])
        .args(args)
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let two = image::open(dir.join("two.png")).unwrap().to_rgb8();
    assert_eq!(served.dimensions(), two.dimensions());
    assert!(served != two, "the saved image is the refined one");
    // A setting starts again (and refines again).
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/settings"), &addr, Some(&json!({ "spp": 4, "params": {} })));
    assert_eq!(code, 200);
    wait_for(&addr, &token, "refining after a restart", |s| {
        s["phase"] == "refining" && s["generation"].as_u64() > done["status"]["generation"].as_u64()
    });
    std::fs::remove_dir_all(dir).unwrap();
}

/// With an error target, refining goes on past the scene's samples (its `spp` cap) until every
/// pixel meets the target, continuing the scene's own sums, then ends by itself.
#[test]
fn refining_ends_when_every_pixel_meets_the_error_target() {
    let dir = temp_dir("refine-target");
    let scene = repo().join("scenes/path-cornell.toml");
    let LiveView { process: _view, addr, token, .. } =
        start_view(&dir, &scene, &["--width", "16", "--height", "16", "--spp", "16", "--target-error", "0.25", "--threads", "2"]);
    let done = wait_for(&addr, &token, "the end", |s| s["phase"] == "done");
    assert_eq!(done["status"]["ended"], "every pixel met the error target", "{}", done["status"]);
    std::fs::remove_dir_all(dir).unwrap();
}

/// The PNG `raylab render` writes of `scene` with `args`, as RGB.
fn render_png(dir: &Path, scene: &Path, args: &[&str]) -> image::RgbImage {
    let out = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", scene.to_str().unwrap(), "-o", "cli.png", "-q"])
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    image::open(dir.join("cli.png")).unwrap().to_rgb8()
}

/// The image the page's Save PNG serves.
fn served_png(addr: &str, token: &str) -> image::RgbImage {
    let (code, png) = http(addr, "GET", &format!("/{token}/api/image.png"), addr, None);
    assert_eq!(code, 200);
    image::load_from_memory(&png).unwrap().to_rgb8()
}

/// The page's error target: the view refines until every pixel meets it and ends with the image
/// `raylab render --target-error E` writes with the view's sample cap, whatever the scene's
/// samples (deterministic for a given target); clearing it goes back to refining without one.
#[test]
fn the_pages_error_target_ends_refining_at_the_image_render_makes_for_that_target() {
    let dir = temp_dir("page-target");
    let scene = repo().join("scenes/path-cornell.toml");
    let size = ["--width", "16", "--height", "16"];
    let LiveView { process: _view, addr, token, .. } = start_view(&dir, &scene, &[&size[..], &["--spp", "2", "--threads", "2"]].concat());
    let knobs = wait_for(&addr, &token, "the controls", |s| s["phase"] != "loading" && s["phase"] != "preview")["knobs"].clone();
    let knob =
        |key: &str| knobs.as_array().unwrap().iter().find(|k| k["key"] == key).cloned().unwrap_or_else(|| panic!("no {key} in {knobs}"));
    assert_eq!(knob("target_error")["value"], Value::Null, "no target in the scene");
    assert_eq!(knob("target_min_spp")["active"], false, "inactive without a target");
    // A target with fewer samples than are taken before the first test is refused at the control.
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/settings"), &addr, Some(&json!({ "target_error": 0.25, "params": {} })));
    assert_eq!(code, 200);
    let refused = wait_for_error(&addr, &token);
    assert!(refused["message"].as_str().unwrap().contains("target_min_spp"), "{refused}");
    assert!(refused["report"].as_str().unwrap().contains("page control \"target_error\""), "{refused}");
    // The page raises spp with the target (as its script does); 16 and 32 samples: the same end.
    let mut images = Vec::new();
    for spp in [16, 32] {
        let before = updates(&addr, &token, 0)["status"]["generation"].as_u64().unwrap();
        let settings = json!({ "target_error": 0.25, "spp": spp, "params": {} });
        let (code, _) = http(&addr, "POST", &format!("/{token}/api/settings"), &addr, Some(&settings));
        assert_eq!(code, 200);
        let done = wait_for(&addr, &token, "the target", |s| s["phase"] == "done" && s["generation"].as_u64() > Some(before));
        assert_eq!(done["status"]["ended"], "every pixel met the error target", "{}", done["status"]);
        assert_eq!(done["knobs"].as_array().map(|k| k.iter().any(|k| k["key"] == "target_error" && k["value"] == 0.25)), Some(true));
        images.push(served_png(&addr, &token));
    }
    assert!(images[0] == images[1], "the same target, the same image, whatever the scene's samples");
    let cap = raylab::view::session::REFINE_MAX_SPP.to_string();
    let cli =
        render_png(&dir, &scene, &[&size[..], &["--target-error", "0.25", "--spp", &cap, "--max-rays", &u64::MAX.to_string()]].concat());
    assert!(images[0] == cli, "the view's image is raylab render's for the target");
    std::fs::remove_dir_all(dir).unwrap();
}

/// Polls until the status is an error; returns it.
fn wait_for_error(addr: &str, token: &str) -> Value {
    let deadline = Instant::now() + PATIENCE;
    let mut version = 0;
    loop {
        let head = updates(addr, token, version);
        if head["status"]["phase"] == "error" {
            return head["status"]["error"].clone();
        }
        assert!(Instant::now() < deadline, "no error; the status is {}", head["status"]);
        version = head["version"].as_u64().unwrap();
    }
}

/// The page's Denoise control: the finished image is the one `raylab render --denoise` writes,
/// and refined passes are shown denoised too.
#[test]
fn the_denoise_control_shows_the_image_render_denoise_writes() {
    if !denoiser_here("the_denoise_control_shows_the_image_render_denoise_writes") {
        return;
    }
    let dir = temp_dir("denoise");
    let scene = repo().join("scenes/path-cornell.toml");
    let args = ["--width", "32", "--height", "32", "--spp", "4"];
    let LiveView { process: view, addr, token, .. } = start_view(&dir, &scene, &[&args[..], &["--threads", "2", "--no-refine"]].concat());
    let first = wait_for(&addr, &token, "the first render", |s| s["phase"] == "done");
    assert_eq!(first["status"]["denoised"], false);
    let noisy = served_png(&addr, &token);
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/settings"), &addr, Some(&json!({ "denoise": true, "params": {} })));
    assert_eq!(code, 200);
    let done = wait_for(&addr, &token, "the denoised render", |s| s["phase"] == "done" && s["denoised"] == true);
    assert!(done["status"]["generation"].as_u64() > first["status"]["generation"].as_u64());
    let denoised = served_png(&addr, &token);
    assert!(denoised != noisy, "denoising changed the image");
    assert!(denoised == render_png(&dir, &scene, &[&args[..], &["--denoise"]].concat()), "the view's image is raylab render --denoise's");
    drop(view);
    // At 32 spp `render --denoise` works on 2 × 2 sub-pixels of 8 spp: the view does too.
    let fine = ["--width", "32", "--height", "32", "--spp", "32"];
    let LiveView { process: view, addr, token, .. } = start_view(&dir, &scene, &[&fine[..], &["--threads", "2", "--no-refine"]].concat());
    wait_for(&addr, &token, "the first render at 32 spp", |s| s["phase"] == "done");
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/settings"), &addr, Some(&json!({ "denoise": true, "params": {} })));
    assert_eq!(code, 200);
    let done = wait_for(&addr, &token, "the denoised render at 32 spp", |s| s["phase"] == "done" && s["denoised"] == true);
    assert_eq!(done["status"]["samples"][0], 32, "{}", done["status"]);
    let grid = served_png(&addr, &token);
    assert!(
        grid == render_png(&dir, &scene, &[&fine[..], &["--denoise"]].concat()),
        "the view's image is raylab render --denoise's on 2 × 2"
    );
    drop(view);
    // Refining: each pass is shown denoised; Stop keeps the last one.
    let LiveView { process: _view, addr, token, .. } = start_view(&dir, &scene, &[&args[..], &["--threads", "2"]].concat());
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/settings"), &addr, Some(&json!({ "denoise": true, "params": {} })));
    assert_eq!(code, 200);
    wait_for(&addr, &token, "a denoised refined pass", |s| {
        s["phase"] == "refining" && s["denoised"] == true && s["samples"][0].as_u64() > Some(4)
    });
    let (code, _) = http(&addr, "POST", &format!("/{token}/api/stop"), &addr, None);
    assert_eq!(code, 200);
    let stopped = wait_for(&addr, &token, "the stop", |s| s["phase"] == "done");
    assert_eq!(stopped["status"]["denoised"], true, "{}", stopped["status"]);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn the_pages_samples_replace_the_command_lines_and_a_bad_count_is_located_at_its_control() {
    use raylab::load::context::{LoadOptions, Overrides};
    use raylab::view::knobs::{Settings, options};
    let registry = raylab_plugins::registry();
    let base = LoadOptions { overrides: Overrides { spp: Some(3), ..Overrides::default() }, ..LoadOptions::default() };
    let scene = "[render]\nspp = 2\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";
    let load = |spp| {
        let o = options(&base, &Settings { spp: Some(spp), ..Settings::default() }, &registry).unwrap();
        raylab::load::loader::load_str(&registry, "page.toml", scene, Path::new("."), &o)
    };
    assert_eq!(load(5).ok().map(|job| job.settings.spp), Some(5));
    let Err(e) = load(0) else { panic!("0 samples per pixel loaded") };
    assert!(e.to_string().contains("page control \"spp\""), "{e}");
}

/// The first program of `names` found on PATH.
fn which(names: &[&str]) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    names.iter().flat_map(|n| std::env::split_paths(&path).map(move |d| d.join(n))).find(|p| p.is_file())
}

/// A WebDriver session with chromedriver.
struct Browser {
    addr: String,
    session: String,
    _driver: Guard,
}

const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

impl Browser {
    fn start(chromium: &Path, chromedriver: &Path, profile: &Path) -> Browser {
        let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let driver =
            Guard(Command::new(chromedriver).arg(format!("--port={port}")).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap());
        let addr = format!("127.0.0.1:{port}");
        let deadline = Instant::now() + Duration::from_secs(60);
        while TcpStream::connect(&addr).is_err() {
            assert!(Instant::now() < deadline, "chromedriver did not start");
            std::thread::sleep(Duration::from_millis(100));
        }
        let caps = json!({ "capabilities": { "alwaysMatch": { "browserName": "chrome", "goog:chromeOptions": {
            "binary": chromium,
            "args": ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1500,1000",
                     "--force-device-scale-factor=1", format!("--user-data-dir={}", profile.display())]
        }}}});
        let (code, body) = http(&addr, "POST", "/session", &addr, Some(&caps));
        let v: Value = serde_json::from_slice(&body).unwrap();
        assert_eq!(code, 200, "new session: {v}");
        let session = v["value"]["sessionId"].as_str().unwrap().to_string();
        Browser { addr, session, _driver: driver }
    }

    fn call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
        eprintln!("webdriver: {method} {path}");
        let (code, out) = http(&self.addr, method, &format!("/session/{}{path}", self.session), &self.addr, body.as_ref());
        let v: Value = serde_json::from_slice(&out).unwrap_or(Value::Null);
        assert_eq!(code, 200, "{method} {path}: {v}");
        v["value"].clone()
    }

    fn script(&self, js: &str) -> Value {
        self.call("POST", "/execute/sync", Some(json!({ "script": js, "args": [] })))
    }

    fn element(&self, css: &str) -> String {
        self.call("POST", "/element", Some(json!({ "using": "css selector", "value": css })))[ELEMENT].as_str().unwrap().to_string()
    }

    /// Waits until `js` returns true.
    fn wait(&self, what: &str, js: &str) {
        let deadline = Instant::now() + PATIENCE;
        while self.script(js) != Value::Bool(true) {
            let state = self.script("return document.body.dataset.phase + ' ' + document.getElementById('phase').textContent");
            assert!(Instant::now() < deadline, "waited for {what}; the page shows: {state}");
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    fn screenshot(&self, path: &Path) {
        let b64 = self.call("GET", "/screenshot", None);
        std::fs::write(path, base64(b64.as_str().unwrap())).unwrap();
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = http(&self.addr, "DELETE", &format!("/session/{}", self.session), &self.addr, None);
    }
}

fn base64(s: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        _ => 63,
    };
    let digits: Vec<u8> = s.bytes().filter(|c| c.is_ascii_alphanumeric() || *c == b'+' || *c == b'/').map(value).collect();
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        let n = chunk.iter().enumerate().fold(0u32, |acc, (i, &d)| acc | (u32::from(d) << (18 - 6 * i)));
        out.extend(&n.to_be_bytes()[1..chunk.len()]);
    }
    out
}

/// FNV-1a over RGBA bytes (the page computes the same over its canvas).
fn fnv(bytes: &[u8]) -> u32 {
    bytes.iter().fold(0x811c_9dc5u32, |h, &b| (h ^ u32::from(b)).wrapping_mul(0x0100_0193))
}

const CANVAS_HASH: &str = "const c = document.getElementById('image'); \
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; let h = 0x811c9dc5; \
    for (let i = 0; i < d.length; i++) { h = Math.imul(h ^ d[i], 0x01000193) >>> 0; } return h;";

/// The hash of `raylab render` of `scene` with `args`, as RGBA.
fn render_hash(dir: &Path, scene: &Path, args: &[&str]) -> u32 {
    let out = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", scene.to_str().unwrap(), "-o", "cli.png", "-q"])
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    fnv(image::open(dir.join("cli.png")).unwrap().to_rgba8().as_raw())
}

/// Numbers compared as numbers (JavaScript writes 1.0 as 1).
fn same_json(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => x.as_f64() == y.as_f64(),
        (Value::Array(x), Value::Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same_json(p, q)),
        (Value::Object(x), Value::Object(y)) => x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| same_json(v, w))),
        _ => a == b,
    }
}

#[test]
fn the_page_renders_restarts_on_a_knob_and_explains_a_clicked_pixel() {
    let (Some(chromium), Some(chromedriver)) =
        (which(&["chromium", "chromium-browser", "google-chrome"]), which(&["chromedriver", "chromium-driver"]))
    else {
        raylab::testing::missing_tool(
            "the_page_renders_restarts_on_a_knob_and_explains_a_clicked_pixel",
            "Chromium or chromedriver",
            "apt-get install chromium chromium-driver",
        );
        return;
    };
    let dir = temp_dir("browser");
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view-browser");
    std::fs::create_dir_all(&shots).unwrap();
    let scene = dir.join("showcase.toml");
    let original = std::fs::read_to_string(repo().join("scenes/showcase.toml")).unwrap();
    std::fs::write(&scene, &original).unwrap();
    // Without refining, each render ends at the scene's samples: the image `raylab render` writes.
    let LiveView { process: _view, url, .. } = start_view(&dir, &scene, &[&SIZE[..], &["--threads", "2", "--no-refine"]].concat());
    let profile = dir.join("chromium-profile");
    let b = Browser::start(&chromium, &chromedriver, &profile);
    b.call("POST", "/url", Some(json!({ "url": url })));

    // 1. Loaded: the finished image has the bits `raylab render` writes.
    b.wait("the first render", "return document.body.dataset.phase === 'done'");
    assert_eq!(b.script("return document.title"), "raylab live view");
    assert_eq!(b.script(CANVAS_HASH).as_u64().unwrap() as u32, render_hash(&dir, &scene, &SIZE), "the page's image equals raylab render's");
    let knobs = b.script("return window.raylab.knobs.map(k => k.key).join(' ')");
    for k in [
        "aa",
        "spp",
        "aa_threshold",
        "aa_depth",
        "aa_edges",
        "aa_signature",
        "aa_cell_samples",
        "aa_coarse",
        "lens_samples",
        "integrator",
        "params.max_depth",
        "params.prune_threshold",
        "params.glossy_rays",
    ] {
        assert!(knobs.as_str().unwrap().split(' ').any(|x| x == k), "control {k} in {knobs}");
    }
    b.screenshot(&shots.join("1-loaded.png"));

    // 2. Knobs: stratified, then 4 spp: each restarts the render.
    let option = b.element("#knob-aa option[value=stratified]");
    b.call("POST", &format!("/element/{option}/click"), Some(json!({})));
    b.wait("the stratified render", "return window.raylab.status.sampling === '1 spp' && document.body.dataset.phase === 'done'");
    let spp = b.element("#knob-spp");
    b.call("POST", &format!("/element/{spp}/clear"), Some(json!({})));
    b.call("POST", &format!("/element/{spp}/value"), Some(json!({ "text": "4\u{E007}" })));
    b.wait("the 4-spp render", "return window.raylab.status.sampling === '4 spp' && document.body.dataset.phase === 'done'");
    assert!(b.script("return Number(document.body.dataset.generation)").as_u64().unwrap() >= 3, "two restarts");
    let four = [&SIZE[..], &["--aa", "stratified", "--spp", "4"]].concat();
    assert_eq!(b.script(CANVAS_HASH).as_u64().unwrap() as u32, render_hash(&dir, &scene, &four), "the 4-spp image equals raylab render's");
    assert!(b.script("return document.getElementById('stats').textContent").as_str().unwrap().contains("rays/s"));
    b.screenshot(&shots.join("2-knob-changed.png"));

    // 3. Click a pixel on the glass ball (image pixel 66, 82 of 160×120): its tree, as trace gives it.
    let (px, py) = (66.0, 82.0);
    let at = b.script(&format!(
        "const r = document.getElementById('image').getBoundingClientRect(); \
         return [({px} + 0.5) * r.width / 160 - r.width / 2, ({py} + 0.5) * r.height / 120 - r.height / 2];"
    ));
    let (dx, dy) = (at[0].as_f64().unwrap().round() as i64, at[1].as_f64().unwrap().round() as i64);
    let canvas = b.element("#image");
    let origin = json!({ ELEMENT: canvas });
    b.call(
        "POST",
        "/actions",
        Some(json!({ "actions": [{ "type": "pointer", "id": "mouse", "parameters": { "pointerType": "mouse" }, "actions": [
            { "type": "pointerMove", "duration": 0, "origin": origin, "x": dx, "y": dy },
            { "type": "pointerDown", "button": 0 }, { "type": "pointerUp", "button": 0 }
        ]}]})),
    );
    b.wait("the explanation", "return !!(window.raylab.explained && window.raylab.explained.tree)");
    let shown = b.script("return window.raylab.explained");
    let (x, y) = (shown["pixel"][0].as_u64().unwrap(), shown["pixel"][1].as_u64().unwrap());
    assert_eq!((x, y), (px as u64, py as u64), "the clicked pixel");
    assert_eq!(shown["tree"]["hit"]["name"], "glass ball", "{}", shown["tree"]);
    assert!(shown["marks"].as_array().unwrap().iter().any(|m| m["kind"] == "refraction"), "the refraction ray is drawn");
    let tree_text = b.script("return document.getElementById('tree').textContent").as_str().unwrap().to_string();
    assert!(tree_text.contains("camera ray → hit glass ball") && tree_text.contains("refraction ray"), "{tree_text}");
    let k = shown["sample"]["index"].as_u64().unwrap().to_string();
    let trace = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["trace", scene.to_str().unwrap(), "--pixel", &format!("{x},{y}"), "--sample", &k, "--json"])
        .args(&four)
        .output()
        .unwrap();
    assert!(trace.status.success(), "{}", String::from_utf8_lossy(&trace.stderr));
    let cli: Value = serde_json::from_slice(&trace.stdout).unwrap();
    for key in ["tree", "color", "rgb8", "sample", "sampling", "integrator"] {
        assert!(same_json(&shown[key], &cli[key]), "{key}: the page shows {}\n raylab trace gives {}", shown[key], cli[key]);
    }
    b.screenshot(&shots.join("3-pixel-explained.png"));

    // 4. The scene file is watched: an error is shown with its line and column, a fix renders again.
    std::fs::write(&scene, original.replace("radius = 1.0\n", "radius = \"big\"\n")).unwrap();
    b.wait("the scene error", "return document.body.dataset.phase === 'error'");
    let place = b.script("return document.getElementById('error-where').textContent").as_str().unwrap().to_string();
    let line = original.lines().position(|l| l == "radius = 1.0").unwrap() + 1;
    assert!(place.contains("showcase.toml") && place.contains(&format!("line {line}, column 10")), "{place}");
    b.screenshot(&shots.join("4-scene-error.png"));
    std::fs::write(&scene, &original).unwrap();
    b.wait("the render after the fix", "return document.body.dataset.phase === 'done' && document.getElementById('error').hidden");

    // 5. The error target (the page's settings are still stratified, 4 spp) and the denoiser.
    assert_eq!(b.script("return window.raylab.status.sampling"), "4 spp");
    let field = b.element("#knob-target_error");
    b.call("POST", &format!("/element/{field}/value"), Some(json!({ "text": "0.2\u{E007}" })));
    // The page raises the samples to those taken before the first test (16), the target's least.
    b.wait(
        "the render to the target",
        "return window.raylab.status.sampling === 'to error 0.2 (16..16 spp)' && document.body.dataset.phase === 'done'",
    );
    let target = [&SIZE[..], &["--aa", "stratified", "--spp", "16", "--target-error", "0.2"]].concat();
    assert_eq!(
        b.script(CANVAS_HASH).as_u64().unwrap() as u32,
        render_hash(&dir, &scene, &target),
        "the target's image equals raylab render's"
    );
    if raylab::image::denoise::available() {
        let toggle = b.element("#knob-denoise");
        b.call("POST", &format!("/element/{toggle}/click"), Some(json!({})));
        b.wait("the denoised image", "return window.raylab.status.denoised && document.body.dataset.phase === 'done'");
        assert!(b.script("return document.getElementById('phase').textContent").as_str().unwrap().contains("denoised"));
        let denoised = [&target[..], &["--denoise"]].concat();
        assert_eq!(
            b.script(CANVAS_HASH).as_u64().unwrap() as u32,
            render_hash(&dir, &scene, &denoised),
            "the page's denoised image is raylab render --denoise's"
        );
    } else {
        assert!(std::env::var_os("CI").is_none(), "CI must have the denoiser: {}", raylab::image::denoise::INSTALL_HINT);
        assert_eq!(b.script("return document.getElementById('knob-denoise').disabled"), true, "no denoiser: the control is inactive");
    }
    b.script("window.scrollTo(0, 0); return true");
    b.screenshot(&shots.join("5-target-denoised.png"));
    eprintln!("screenshots in {}", shots.display());
    drop(b);
    std::fs::remove_dir_all(dir).unwrap();
}
