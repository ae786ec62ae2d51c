//! A small HTTP/1.1 server over `std::net` with a bound on everything a client controls: the
//! request line and headers ([`MAX_HEAD`], refused as soon as the bytes read pass it, before more
//! is buffered), the body ([`MAX_BODY`]), the connections open at once ([`MAX_CONNECTIONS`]),
//! the requests handled at once ([`MAX_ACTIVE`]), and the time a client may take to send its
//! request ([`HEAD_TIMEOUT`], [`BODY_TIMEOUT`]: a deadline for the whole, so a client sending a
//! byte a second is cut like an idle one) or to read the answer ([`WRITE_TIMEOUT`]).
//!
//! One thread per connection, one request per connection (every answer says
//! `Connection: close`): a slow or idle client holds only its own thread, for at most its
//! deadline; the accepting thread never reads from a client. Every answer, the server's own
//! refusals included, carries the security headers of [`SECURE_HEADERS`].

use std::io::{Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Longest request line and headers, blank line included (a browser's are 1–2 KiB; cookies set
/// for 127.0.0.1 by other local servers come along, hence the margin). Longer: 431.
pub const MAX_HEAD: usize = 32 * 1024;

/// Largest request body (the settings are a few hundred bytes). Larger: the handler is told,
/// and the body is not read.
pub const MAX_BODY: usize = 64 * 1024;

/// Most connections open at once; the next is answered 503 at once, without a thread.
pub const MAX_CONNECTIONS: usize = 96;

/// Most requests handled at once (each long poll holds one); the next is answered 503.
pub const MAX_ACTIVE: usize = 32;

/// Longest a client may take to send its request line and headers, from connecting: an idle
/// client and one sending a byte a second are both cut (408).
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// Longest a client may take to send its body, after its headers.
pub const BODY_TIMEOUT: Duration = Duration::from_secs(10);

/// Longest one write of an answer may wait for the client to read.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(30);

/// Most bytes of an unwanted body (or of a refused head) read and thrown away before closing,
/// so that the client reads the answer instead of a reset connection.
const DRAIN: usize = 1024 * 1024;

/// How long draining may take.
const DRAIN_TIMEOUT: Duration = Duration::from_secs(1);

/// Headers on every answer: no caching, no sniffing, no framing, no referrer (the token is in
/// the URL), and the page may load only its own scripts and styles.
pub const SECURE_HEADERS: [(&str, &str); 5] = [
    ("Cache-Control", "no-store"),
    ("X-Content-Type-Options", "nosniff"),
    ("X-Frame-Options", "DENY"),
    ("Referrer-Policy", "no-referrer"),
    (
        "Content-Security-Policy",
        "default-src 'self'; img-src 'self' data: blob:; connect-src 'self'; style-src 'self'; script-src 'self'; frame-ancestors 'none'",
    ),
];

/// A request's method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Get,
    Post,
    /// Any other method (answered by the handler, usually 404).
    Other,
}

/// A request's body, read whole when it is within [`MAX_BODY`].
#[derive(Debug, PartialEq, Eq)]
pub enum Body {
    Read(Vec<u8>),
    /// Its length is over [`MAX_BODY`]: not read.
    TooLarge,
}

/// A parsed request.
#[derive(Debug)]
pub struct Request {
    pub method: Method,
    /// The request target as sent: path and query.
    pub target: String,
    /// The `Host` header, if there was exactly one.
    pub host: Option<String>,
    pub body: Body,
}

/// An answer: status, headers beyond the server's own, body.
pub struct Response {
    pub status: u16,
    pub headers: Vec<(&'static str, String)>,
    pub body: Vec<u8>,
}

impl Response {
    pub fn new(status: u16, content_type: &str, body: impl Into<Vec<u8>>) -> Response {
        Response { status, headers: vec![("Content-Type", content_type.to_string())], body: body.into() }
    }

    pub fn text(status: u16, body: &str) -> Response {
        Response::new(status, "text/plain; charset=utf-8", body)
    }

    pub fn with_header(mut self, name: &'static str, value: impl Into<String>) -> Response {
        self.headers.push((name, value.into()));
        self
    }
}

/// Why a request was not handed to the handler: the status and sentence it is answered with.
#[derive(Debug, PartialEq, Eq)]
pub struct Refusal(pub u16, pub &'static str);

const HEAD_TOO_LONG: Refusal = Refusal(431, "the request line and headers are too long");
const TOO_SLOW: Refusal = Refusal(408, "the request took too long to arrive");
const MALFORMED: Refusal = Refusal(400, "malformed request");

/// The end of the head (the blank line) in `buf`, after the bytes of `from` on: the index just
/// past it.
fn head_end(buf: &[u8], from: usize) -> Option<usize> {
    let start = from.saturating_sub(3);
    (start..buf.len()).find_map(|i| {
        if buf[i..].starts_with(b"\r\n\r\n") {
            Some(i + 4)
        } else if buf[i..].starts_with(b"\n\n") {
            Some(i + 2)
        } else {
            None
        }
    })
}

/// Parses a request's head (request line and headers, without the blank line or body): the
/// request (with an empty body) and the body's length.
pub fn parse_head(head: &[u8]) -> Result<(Request, usize), Refusal> {
    let text = std::str::from_utf8(head).map_err(|_| MALFORMED)?;
    let mut lines = text.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l));
    let line = lines.next().ok_or(MALFORMED)?;
    let mut words = line.split(' ');
    let (Some(method), Some(target), Some(version), None) = (words.next(), words.next(), words.next(), words.next()) else {
        return Err(MALFORMED);
    };
    if !matches!(version, "HTTP/1.1" | "HTTP/1.0") {
        return Err(Refusal(505, "only HTTP/1.0 and HTTP/1.1 are served"));
    }
    if target.is_empty() || !target.bytes().all(|b| b.is_ascii_graphic()) {
        return Err(MALFORMED);
    }
    let method = match method {
        "GET" => Method::Get,
        "POST" => Method::Post,
        m if !m.is_empty() && m.bytes().all(|b| b.is_ascii_uppercase()) => Method::Other,
        _ => return Err(MALFORMED),
    };
    let (mut hosts, mut length) = (Vec::new(), None);
    for l in lines.filter(|l| !l.is_empty()) {
        let (name, value) = l.split_once(':').ok_or(MALFORMED)?;
        if name.is_empty() || name.bytes().any(|b| !b.is_ascii_graphic()) {
            return Err(MALFORMED);
        }
        let value = value.trim_matches([' ', '\t']);
        if name.eq_ignore_ascii_case("host") {
            hosts.push(value.to_string());
        } else if name.eq_ignore_ascii_case("content-length") {
            let n: usize = value.parse().map_err(|_| MALFORMED)?;
            if length.is_some_and(|m| m != n) {
                return Err(MALFORMED);
            }
            length = Some(n);
        } else if name.eq_ignore_ascii_case("transfer-encoding") {
            return Err(Refusal(411, "a body needs a Content-Length (no Transfer-Encoding)"));
        }
    }
    let host = if hosts.len() == 1 { hosts.pop() } else { None };
    Ok((Request { method, target: target.to_string(), host, body: Body::Read(Vec::new()) }, length.unwrap_or(0)))
}

/// Reads from `stream` into `buf` (at most `limit` bytes in all) until `done` says the bytes are
/// complete, or the deadline passes (`Err(TOO_SLOW)`), or the client closes (`Err(MALFORMED)`).
fn read_until(
    stream: &mut TcpStream,
    buf: &mut Vec<u8>,
    limit: usize,
    deadline: Instant,
    done: impl Fn(&[u8], usize) -> bool,
) -> Result<(), Refusal> {
    let mut chunk = [0u8; 4096];
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(TOO_SLOW);
        }
        stream.set_read_timeout(Some(left)).map_err(|_| MALFORMED)?;
        let want = chunk.len().min(limit - buf.len());
        let n = match stream.read(&mut chunk[..want]) {
            Ok(0) => return Err(MALFORMED),
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => return Err(TOO_SLOW),
            Err(_) => return Err(MALFORMED),
        };
        let before = buf.len();
        buf.extend_from_slice(&chunk[..n]);
        if done(buf, before) {
            return Ok(());
        }
        if buf.len() >= limit {
            return Err(HEAD_TOO_LONG);
        }
    }
}

/// Reads one request from `stream`: its head within [`MAX_HEAD`] and [`HEAD_TIMEOUT`], then its
/// body within [`MAX_BODY`] and [`BODY_TIMEOUT`] (not read when longer).
fn read_request(stream: &mut TcpStream) -> Result<Request, Refusal> {
    let mut buf = Vec::with_capacity(4096);
    read_until(stream, &mut buf, MAX_HEAD, Instant::now() + HEAD_TIMEOUT, |b, from| head_end(b, from).is_some())?;
    let end = head_end(&buf, 0).ok_or(MALFORMED)?;
    let (mut request, length) = parse_head(&buf[..end])?;
    if length > MAX_BODY {
        request.body = Body::TooLarge;
        return Ok(request);
    }
    let mut body = buf.split_off(end);
    if body.len() < length {
        read_until(stream, &mut body, length, Instant::now() + BODY_TIMEOUT, |b, _| b.len() >= length)
            .map_err(|r| if r == HEAD_TOO_LONG { MALFORMED } else { r })?;
    }
    body.truncate(length);
    request.body = Body::Read(body);
    Ok(request)
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        408 => "Request Timeout",
        409 => "Conflict",
        411 => "Length Required",
        422 => "Unprocessable Entity",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "",
    }
}

/// Writes `response` with the server's headers, each write waiting at most `timeout` for the
/// client to read, and ends the sending side.
fn write(stream: &mut TcpStream, response: &Response, timeout: Duration) {
    let mut head = format!("HTTP/1.1 {} {}\r\n", response.status, reason(response.status));
    for (name, value) in SECURE_HEADERS.iter().copied().chain(response.headers.iter().map(|(n, v)| (*n, v.as_str()))) {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str(&format!("Content-Length: {}\r\nConnection: close\r\n\r\n", response.body.len()));
    let _ = stream.set_write_timeout(Some(timeout));
    let _ = stream.write_all(head.as_bytes()).and_then(|()| stream.write_all(&response.body)).and_then(|()| stream.flush());
    let _ = stream.shutdown(Shutdown::Write);
}

/// Writes `response` and closes the connection, first reading (and throwing away) what the
/// client still sends, a bounded amount, so that it reads the answer rather than a reset.
fn answer(mut stream: TcpStream, response: &Response) {
    write(&mut stream, response, WRITE_TIMEOUT);
    let deadline = Instant::now() + DRAIN_TIMEOUT;
    let (mut chunk, mut drained) = ([0u8; 4096], 0);
    while drained < DRAIN {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() || stream.set_read_timeout(Some(left)).is_err() {
            break;
        }
        match stream.read(&mut chunk) {
            Ok(0) | Err(_) => break,
            Ok(n) => drained += n,
        }
    }
}

/// One of a bounded number of places, given back when dropped.
struct Slot(Arc<AtomicUsize>);

impl Slot {
    /// Takes a place if fewer than `max` are taken.
    fn take(count: &Arc<AtomicUsize>, max: usize) -> Option<Slot> {
        count.fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| (n < max).then_some(n + 1)).ok().map(|_| Slot(count.clone()))
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::AcqRel);
    }
}

/// A listening server.
pub struct Server {
    listener: TcpListener,
}

impl Server {
    /// Binds 127.0.0.1:`port` (0: any free port).
    pub fn bind(port: u16) -> std::io::Result<Server> {
        Ok(Server { listener: TcpListener::bind(("127.0.0.1", port))? })
    }

    /// The port it listens on.
    pub fn port(&self) -> std::io::Result<u16> {
        Ok(self.listener.local_addr()?.port())
    }

    /// Serves requests with `handle` until the process ends.
    pub fn serve(&self, handle: Arc<dyn Fn(Request) -> Response + Send + Sync>) {
        let (connections, active) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
        for stream in self.listener.incoming() {
            let Ok(mut stream) = stream else { continue };
            let Some(connection) = Slot::take(&connections, MAX_CONNECTIONS) else {
                // No thread for it: take what it has sent so far without waiting, answer, close.
                let _ = stream.set_nonblocking(true);
                let mut chunk = [0u8; 4096];
                for _ in 0..4 {
                    if !matches!(stream.read(&mut chunk), Ok(n) if n > 0) {
                        break;
                    }
                }
                let _ = stream.set_nonblocking(false);
                write(&mut stream, &Response::text(503, "too many connections at once"), Duration::from_millis(100));
                continue;
            };
            let (handle, active) = (handle.clone(), active.clone());
            let _ = std::thread::Builder::new().name("raylab-view-connection".into()).spawn(move || {
                // The places are given back however this ends, a panic included.
                let _connection = connection;
                let response = match read_request(&mut stream) {
                    Err(Refusal(status, why)) => Response::text(status, why),
                    Ok(request) => match Slot::take(&active, MAX_ACTIVE) {
                        None => Response::text(503, "too many requests at once"),
                        Some(_busy) => handle(request),
                    },
                };
                answer(stream, &response);
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heads_parse_and_bad_ones_are_refused() {
        let (r, n) = parse_head(b"POST /t/api/settings?x=1 HTTP/1.1\r\nhost: 127.0.0.1:80\r\nContent-Length: 12\r\n").unwrap();
        assert_eq!((r.method, r.target.as_str(), r.host.as_deref(), n), (Method::Post, "/t/api/settings?x=1", Some("127.0.0.1:80"), 12));
        let (r, n) = parse_head(b"GET / HTTP/1.0\nHost: a\nHost: b\n").unwrap();
        assert_eq!((r.method, r.host, n), (Method::Get, None, 0), "two Hosts are none");
        assert_eq!(parse_head(b"DELETE / HTTP/1.1\r\n").unwrap().0.method, Method::Other);
        for bad in [
            &b""[..],
            b"GET / HTTP/1.1 x\r\n",
            b"GET  HTTP/1.1\r\n",
            b"GET /\x01 HTTP/1.1\r\n",
            b"get / HTTP/1.1\r\n",
            b"GET / HTTP/1.1\r\nno colon\r\n",
            b"GET / HTTP/1.1\r\nContent-Length: -1\r\n",
            b"GET / HTTP/1.1\r\nContent-Length: 1\r\nContent-Length: 2\r\n",
            b"GET / HTTP/1.1\r\n\xff: x\r\n",
        ] {
            assert_eq!(parse_head(bad).unwrap_err(), MALFORMED, "{:?}", String::from_utf8_lossy(bad));
        }
        assert_eq!(parse_head(b"GET / HTTP/2\r\n").unwrap_err().0, 505);
        assert_eq!(parse_head(b"POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n").unwrap_err().0, 411);
    }

    #[test]
    fn the_end_of_a_head_is_found_across_reads() {
        let b = b"GET / HTTP/1.1\r\nHost: x\r\n\r\nbody";
        assert_eq!(head_end(b, 0), Some(b.len() - 4));
        for from in 0..b.len() - 4 {
            assert_eq!(head_end(b, from), Some(b.len() - 4), "{from}");
        }
        assert_eq!(head_end(b"GET / HTTP/1.1\r\n", 0), None);
        assert_eq!(head_end(b"GET / HTTP/1.1\n\n", 10), Some(16));
    }
}
