//! The live view's routes, served by [`super::server`] (bounded in head, body, connections and
//! time): bound to 127.0.0.1 only, every path under a random token (`/TOKEN/…`), requests with
//! any other `Host` than this address refused (no DNS rebinding), and nothing served from disk:
//! the page is three files embedded in the binary.
//!
//! API (all under `/TOKEN/api/`):
//! - `GET updates?version=V&frame=F&seq=S&knobs=K`: waits until something changed after version
//!   `V` (at most [`POLL_TIMEOUT`]), then answers `RLV1`, a little-endian `u32` length, that many
//!   bytes of JSON (status, settings, the tiles that follow, the controls when newer than `K`),
//!   and each listed tile's RGBA bytes, row by row.
//! - `POST settings` (JSON [`Settings`]): the page's settings; the render starts again.
//! - `POST stop`: stops rendering or refining; the image shown stays.
//! - `GET explain?x=X&y=Y&fx=FX&fy=FY[&sample=K]`: the ray tree of the pixel's sample nearest
//!   (`FX`, `FY`) (or sample `K`), as `raylab trace --json` gives it, with the rays' marks over the
//!   image and the pixel's samples.
//! - `GET image.png`: the image shown once the scene's samples are done (then the image
//!   `raylab render` writes), while refining, and after: the latest refined pass.

use super::knobs::Settings;
use super::server::{Body, Method, Request, Response, Server};
use super::session::{Phase, Session};
use crate::render::RenderJob;
use crate::render::explain::{SampleRef, explanation_json};
use crate::render::sample::film_position;
use crate::render::{explain_sample, pixel_samples};
use std::io::Read;
use std::sync::Arc;
use std::time::Duration;

const INDEX_HTML: &str = include_str!("page/index.html");
const VIEW_JS: &str = include_str!("page/view.js");
const VIEW_CSS: &str = include_str!("page/view.css");

/// Longest a poll for updates waits before answering with no change.
pub const POLL_TIMEOUT: Duration = Duration::from_secs(20);

/// After a change, how long a poll waits for more changes to send together (a frame's tiles
/// finish hundreds a second).
const COALESCE: Duration = Duration::from_millis(40);

/// A random token of 128 bits, as 32 hex digits: from the operating system's random source where
/// there is one, else from the standard library's randomly keyed hasher.
pub fn random_token() -> String {
    let mut bytes = [0u8; 16];
    let from_os = std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut bytes)).is_ok();
    if !from_os {
        use std::hash::{BuildHasher, Hasher};
        for (i, chunk) in bytes.chunks_mut(8).enumerate() {
            let mut h = std::collections::hash_map::RandomState::new().build_hasher();
            h.write_usize(i);
            h.write_u128(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos()));
            chunk.copy_from_slice(&h.finish().to_le_bytes());
        }
    }
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A running server: its address and token.
pub struct Running {
    server: Server,
    /// The port it listens on (127.0.0.1).
    pub port: u16,
    /// The token every path starts with.
    pub token: String,
}

impl Running {
    /// The page's address.
    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}/{}/", self.port, self.token)
    }

    /// Serves requests until the process ends.
    pub fn serve(&self, session: Arc<Session>) {
        let hosts = [format!("127.0.0.1:{}", self.port), format!("localhost:{}", self.port)];
        let token = self.token.clone();
        self.server.serve(Arc::new(move |request| handle(request, &session, &hosts, &token)));
    }
}

/// Binds 127.0.0.1:`port` (0: any free port).
pub fn bind(port: u16) -> Result<Running, String> {
    let server = Server::bind(port).map_err(|e| format!("cannot listen on 127.0.0.1:{port}: {e}"))?;
    let port = server.port().map_err(|e| format!("the server has no address: {e}"))?;
    Ok(Running { server, port, token: random_token() })
}

fn text(code: u16, body: &str) -> Response {
    Response::text(code, body)
}

fn typed(body: impl Into<Vec<u8>>, content_type: &str) -> Response {
    Response::new(200, content_type, body)
}

/// A sentence for settings the page sent that do not parse: which control, and what it needs
/// (serde's own message names a Rust type and a JSON column).
fn settings_error(e: &serde_json::Error) -> String {
    let text = e.to_string();
    let field = text.split('`').nth(1).filter(|_| text.starts_with("unknown field")).map(str::to_string);
    let what = if let Some(f) = field {
        format!("the page sent a setting raylab does not know (\"{f}\")")
    } else if text.contains("expected u32") || text.contains("expected i64") || text.contains("expected u64") {
        "a control that takes a whole number got something else".to_string()
    } else if text.contains("expected f64") {
        "a control that takes a number got something else".to_string()
    } else if text.contains("expected a boolean") {
        "a switch got something other than on or off".to_string()
    } else {
        "the page sent settings raylab cannot read".to_string()
    };
    format!("{what}; the render keeps its previous settings. Reload the page if this persists.")
}

fn json(code: u16, v: &serde_json::Value) -> Response {
    Response::new(code, "application/json", v.to_string())
}

/// Equal strings, compared in time independent of where they differ.
fn same_secret(a: &str, b: &str) -> bool {
    a.len() == b.len() && a.bytes().zip(b.bytes()).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// The query's value of `key`.
fn query<'a>(q: &'a str, key: &str) -> Option<&'a str> {
    q.split('&').filter_map(|kv| kv.split_once('=')).find(|(k, _)| *k == key).map(|(_, v)| v)
}

fn number<T: std::str::FromStr>(q: &str, key: &str) -> Result<T, String> {
    let v = query(q, key).ok_or_else(|| format!("missing `{key}`"))?;
    v.parse().map_err(|_| format!("`{key}`: not a number: {v}"))
}

fn handle(request: Request, session: &Session, hosts: &[String], token: &str) -> Response {
    if !request.host.as_deref().is_some_and(|h| hosts.iter().any(|a| a.eq_ignore_ascii_case(h))) {
        return text(403, "refused: this server answers only requests for 127.0.0.1 or localhost at its own port");
    }
    let url = request.target.as_str();
    let (path, q) = url.split_once('?').unwrap_or((url, ""));
    let rest = path.strip_prefix('/').and_then(|p| p.split_once('/')).filter(|(t, _)| same_secret(t, token)).map(|(_, r)| r);
    let Some(rest) = rest else {
        return text(403, "refused: open the address `raylab view` printed (it holds a token)");
    };
    match (request.method, rest) {
        (Method::Get, "" | "index.html") => typed(INDEX_HTML, "text/html; charset=utf-8"),
        (Method::Get, "view.js") => typed(VIEW_JS, "text/javascript; charset=utf-8"),
        (Method::Get, "view.css") => typed(VIEW_CSS, "text/css; charset=utf-8"),
        (Method::Get, "api/updates") => updates(session, q),
        (Method::Get, "api/explain") => match explain(session, q) {
            Ok(v) => json(200, &v),
            Err((code, e)) => json(code, &serde_json::json!({ "error": e })),
        },
        (Method::Get, "api/image.png") => image_png(session),
        (Method::Post, "api/stop") => {
            session.stop();
            json(200, &serde_json::json!({ "ok": true }))
        }
        (Method::Post, "api/settings") => match &request.body {
            Body::Read(body) => match serde_json::from_slice::<Settings>(body) {
                Ok(s) => {
                    session.apply(s);
                    json(200, &serde_json::json!({ "ok": true }))
                }
                Err(e) => json(400, &serde_json::json!({ "error": settings_error(&e) })),
            },
            Body::TooLarge => json(400, &serde_json::json!({ "error": "the request body is too large" })),
        },
        _ => text(404, "not found"),
    }
}

fn updates(session: &Session, q: &str) -> Response {
    let seen: u64 = number(q, "version").unwrap_or(0);
    let frame_id: u64 = number(q, "frame").unwrap_or(0);
    let seq: u64 = number(q, "seq").unwrap_or(0);
    let knobs_seen: u64 = number(q, "knobs").unwrap_or(0);
    let changed = session.wait_for_change(seen, POLL_TIMEOUT).version > seen;
    if changed {
        std::thread::sleep(COALESCE);
    }
    let st = session.lock();
    let mut tiles = Vec::new();
    let mut pixels = Vec::new();
    let (frame, seq_now) = match &st.frame {
        Some(f) => {
            let mut rects = if f.id == frame_id { f.changed_since(seq) } else { Vec::new() };
            let all = f.tile_seq.len();
            if f.id != frame_id || rects.len() * 2 > all {
                rects = vec![crate::render::share::Rect::frame(f.width, f.height)];
            }
            for r in &rects {
                tiles.push([r.x0, r.y0, r.width(), r.height()]);
                f.bytes_of(*r, &mut pixels);
            }
            (serde_json::json!({ "id": f.id, "width": f.width, "height": f.height }), f.tile_seq.iter().copied().max().unwrap_or(0))
        }
        None => (serde_json::Value::Null, 0),
    };
    let mut head = serde_json::json!({
        "version": st.version,
        "frame": frame,
        "seq": seq_now.max(seq),
        "tiles": tiles,
        "status": st.status,
        "settings": st.settings,
        "knobs_version": st.knobs_version,
    });
    if st.knobs_version != knobs_seen {
        head["knobs"] = serde_json::to_value(&st.knobs).unwrap_or_default();
    }
    drop(st);
    let head = head.to_string().into_bytes();
    let mut body = Vec::with_capacity(8 + head.len() + pixels.len());
    body.extend_from_slice(b"RLV1");
    body.extend_from_slice(&(head.len() as u32).to_le_bytes());
    body.extend_from_slice(&head);
    body.extend_from_slice(&pixels);
    typed(body, "application/octet-stream")
}

fn explain(session: &Session, q: &str) -> Result<serde_json::Value, (u16, String)> {
    let (job, generation) = {
        let st = session.lock();
        (st.job.clone(), st.status.generation)
    };
    let job = job.ok_or((409, "nothing is rendered yet".to_string()))?;
    let mut v = explain_job(&job, &session.scene_name(), q)?;
    v["generation"] = generation.into();
    Ok(v)
}

/// The answer to `api/explain?QUERY` for `job`: the query read (any text: an error with the
/// status to answer otherwise), the pixel's sample explained, its samples and the overlay's marks.
pub fn explain_job(job: &RenderJob, scene_name: &str, q: &str) -> Result<serde_json::Value, (u16, String)> {
    let bad = |e: String| (400, e);
    let (x, y): (u32, u32) = (number(q, "x").map_err(bad)?, number(q, "y").map_err(bad)?);
    let s = job.settings;
    if x >= s.width || y >= s.height {
        return Err((400, format!("pixel ({x}, {y}) is outside the {}×{} image", s.width, s.height)));
    }
    let cursor = glam::DVec2::new(
        number::<f64>(q, "fx").ok().filter(|v| v.is_finite()).unwrap_or(f64::from(x) + 0.5),
        number::<f64>(q, "fy").ok().filter(|v| v.is_finite()).unwrap_or(f64::from(y) + 0.5),
    );
    let samples = pixel_samples(job, x, y);
    let at: Vec<glam::DVec2> = samples.iter().map(|(id, _)| film_position(job, *id)).collect();
    let index =
        match query(q, "sample") {
            Some(k) => k.parse::<usize>().ok().filter(|&k| k < samples.len()).ok_or_else(|| {
                (400, format!("`sample`: pixel ({x}, {y}) has {} samples (0..{}), not {k}", samples.len(), samples.len()))
            })?,
            None => (0..at.len()).min_by(|&a, &b| at[a].distance_squared(cursor).total_cmp(&at[b].distance_squared(cursor))).unwrap_or(0),
        };
    let (id, weight) = *samples.get(index).ok_or((500, "the pixel has no samples".to_string()))?;
    let trees = explain_sample(job, id).ok_or_else(|| (422, format!("the integrator \"{}\" cannot explain rays", job.integrator_name)))?;
    let sample = SampleRef { index: index as u32, of: samples.len(), id, weight };
    let mut v = explanation_json(job, scene_name, Some((x, y)), Some(sample), &trees);
    v["samples"] = samples
        .iter()
        .zip(&at)
        .enumerate()
        .map(|(k, ((_, w), p))| serde_json::json!({ "index": k, "weight": w, "at": [p.x, p.y] }))
        .collect();
    v["marks"] = serde_json::to_value(super::overlay::marks(&job.scene.camera, s.width, s.height, &trees)).unwrap_or_default();
    Ok(v)
}

fn image_png(session: &Session) -> Response {
    let st = session.lock();
    let (Some(film), Some(job), Phase::Done | Phase::Refining) = (&st.film, &st.job, st.status.phase) else {
        return text(409, "the image is not finished yet");
    };
    let rgb = crate::image::output::to_rgb8(film, job.settings.encoding, None);
    let (w, h) = (film.width, film.height);
    drop(st);
    let mut png = Vec::new();
    match crate::image::output::encode_rgb8(&mut png, &rgb, w, h, crate::image::output::ImageKind::Png) {
        Ok(()) => typed(png, "image/png").with_header("Content-Disposition", "attachment; filename=\"raylab-view.png\""),
        Err(e) => text(500, &e),
    }
}

/// What the fuzz target `view_request` (and the replay of its corpus in `tests/fuzz_corpus.rs`)
/// checks of arbitrary bytes: the first byte picks the parser, the rest is its input. 0: a
/// request's head ([`super::server::parse_head`]); 1: the page's settings (JSON, then over
/// `base`, then the scene `scene` loaded with them through `load`); 2: an explain query against
/// `job` (an answer, or 400 or 422). Never a panic; `Err` names what broke.
pub fn fuzz_request(
    data: &[u8],
    registry: &crate::load::registry::Registry,
    base: &crate::load::context::LoadOptions,
    load: &dyn Fn(&crate::load::context::LoadOptions) -> crate::param::error::Result<RenderJob>,
    job: &RenderJob,
) -> Result<(), String> {
    let Some((&which, rest)) = data.split_first() else { return Ok(()) };
    match which % 3 {
        0 => {
            if let Ok((r, _)) = super::server::parse_head(rest)
                && (r.target.is_empty()
                    || !rest.starts_with(r.target.as_bytes()) && !rest.windows(r.target.len()).any(|w| w == r.target.as_bytes()))
            {
                return Err(format!("parsed to {r:?}, a target not in the request"));
            }
        }
        1 => {
            if let Ok(settings) = serde_json::from_slice::<Settings>(rest)
                && let Ok(options) = super::knobs::options(base, &settings, registry)
            {
                let _ = load(&options);
            }
        }
        _ => {
            let q = String::from_utf8_lossy(rest);
            if let Err((code, e)) = explain_job(job, "fuzz", &q)
                && code != 400
                && code != 422
            {
                return Err(format!("explain?{q}: {code} {e}"));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the page shows when its settings do not parse is a sentence, not serde's message.
    #[test]
    fn unreadable_settings_are_a_sentence() {
        for (body, start) in [
            (r#"{"aa_edges": 3}"#, "a switch got something other than on or off"),
            (r#"{"aa_threshold": "x"}"#, "a control that takes a number got"),
            (r#"{"aa_depth": 1.5}"#, "a control that takes a whole number got"),
            (r#"{"sppp": 4}"#, "the page sent a setting raylab does not know (\"sppp\")"),
        ] {
            let e = serde_json::from_str::<Settings>(body).unwrap_err();
            let m = settings_error(&e);
            assert!(m.starts_with(start), "{body}: {m}");
            assert!(!m.contains("line 1 column") && !m.contains("expected"), "{body}: {m}");
        }
        // A number out of a control's range reaches the loader, which names the control.
        let s: Settings = serde_json::from_str(r#"{"spp": -1}"#).unwrap();
        assert_eq!(s.spp, Some(-1));
    }
}
