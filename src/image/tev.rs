//! Streaming a render to the [tev](https://github.com/Tom94/tev) image viewer over its TCP
//! protocol (`raylab render --display-server HOST:PORT`, as pbrt-v4's `--display-server`).
//!
//! The protocol: each packet is a little-endian `u32` length (the whole packet, these four bytes
//! included), a type byte, then fields: booleans as one byte, strings NUL-terminated, integers
//! little-endian, pixel values as `f32`. raylab sends *create image* (type 4: grab focus, name,
//! width, height, channel count, channel names) once per connection and *update image, version 3*
//! (type 6: grab focus, name, channel count, channel names, x, y, width, height, one `i64` offset
//! and one `i64` stride per channel, then the values) for each finished tile, interleaved RGB
//! (offsets 0, 1, 2; stride 3). Creating an image that exists replaces it, so a new render of the
//! same output shows in place. The image stays in tev when the render ends.
//!
//! A [`Display`] runs a thread that owns the connection: the render hands it tiles and never
//! waits for the network. If tev is not there yet (or goes away) the thread tries again about
//! every second and, once connected, sends the whole image so far.

use crate::render::share::Rect;
use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Packet type: create an empty image.
pub const CREATE_IMAGE: u8 = 4;
/// Packet type: update a rectangle of an image (version 3: offsets and strides per channel).
pub const UPDATE_IMAGE_V3: u8 = 6;

/// The channels raylab sends.
pub const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Rows per packet when the whole image is sent (after a (re)connection).
const BAND_ROWS: u32 = 64;

/// How long between attempts to reach the viewer, and how long one send may block.
const RETRY: Duration = Duration::from_secs(1);
const SEND_TIMEOUT: Duration = Duration::from_secs(3);

fn finish(mut p: Vec<u8>) -> Vec<u8> {
    let n = u32::try_from(p.len()).unwrap_or(u32::MAX);
    p[..4].copy_from_slice(&n.to_le_bytes());
    p
}

fn string(p: &mut Vec<u8>, s: &str) {
    p.extend(s.bytes().filter(|&b| b != 0));
    p.push(0);
}

/// The *create image* packet for a `width × height` RGB image called `name`.
pub fn create_image(name: &str, width: u32, height: u32) -> Vec<u8> {
    let mut p = vec![0, 0, 0, 0, CREATE_IMAGE, 1];
    string(&mut p, name);
    for v in [width as i32, height as i32, CHANNELS.len() as i32] {
        p.extend_from_slice(&v.to_le_bytes());
    }
    for c in CHANNELS {
        string(&mut p, c);
    }
    finish(p)
}

/// The *update image* packet for rectangle `r` of image `name`: `rgb` holds its pixels row by
/// row, three values each (`3 · r.pixels()` values).
pub fn update_image(name: &str, r: Rect, rgb: &[f32]) -> Vec<u8> {
    debug_assert_eq!(rgb.len() as u64, 3 * r.pixels());
    let mut p = Vec::with_capacity(64 + name.len() + 4 * rgb.len());
    p.extend_from_slice(&[0, 0, 0, 0, UPDATE_IMAGE_V3, 0]);
    string(&mut p, name);
    p.extend_from_slice(&(CHANNELS.len() as i32).to_le_bytes());
    for c in CHANNELS {
        string(&mut p, c);
    }
    for v in [r.x0, r.y0, r.width(), r.height()] {
        p.extend_from_slice(&(v as i32).to_le_bytes());
    }
    for offset in 0..CHANNELS.len() as i64 {
        p.extend_from_slice(&offset.to_le_bytes());
    }
    for _ in CHANNELS {
        p.extend_from_slice(&(CHANNELS.len() as i64).to_le_bytes());
    }
    for v in rgb {
        p.extend_from_slice(&v.to_le_bytes());
    }
    finish(p)
}

/// A finished tile: its rectangle and its linear RGB values, row by row.
pub type Tile = (Rect, Vec<f32>);

/// A live display of one render in tev: tiles go to a thread that sends them.
pub struct Display {
    tiles: Sender<Tile>,
    thread: Option<JoinHandle<Report>>,
}

/// What the display thread managed, for the render's summary.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Whether it ever reached the viewer.
    pub connected: bool,
    /// Packets sent.
    pub packets: u64,
    /// The last failure, if any.
    pub error: Option<String>,
}

impl Display {
    /// Starts streaming a `width × height` image called `name` to the viewer at `address`
    /// (`HOST:PORT`). Fails only if the address cannot be resolved or the image's copy cannot be
    /// had; an absent viewer is tried again while the render runs.
    pub fn start(address: &str, name: &str, width: u32, height: u32) -> Result<Display, String> {
        let addrs: Vec<_> = address
            .to_socket_addrs()
            .map_err(|e| format!("--display-server {address}: expected HOST:PORT of a running tev ({e})"))?
            .collect();
        if addrs.is_empty() {
            return Err(format!("--display-server {address}: the name resolves to no address"));
        }
        let image = crate::render::film::try_filled(3 * width as usize * height as usize, 0.0f32, "the display server's copy of the image")
            .map_err(|e| e.to_string())?;
        let (tiles, rx) = channel();
        let mut link = Link {
            addrs,
            name: name.to_string(),
            width,
            height,
            image,
            stream: None,
            last_try: None,
            stored: false,
            report: Report::default(),
        };
        let thread = std::thread::Builder::new()
            .name("raylab-display".into())
            .spawn(move || {
                link.run(rx);
                link.report
            })
            .map_err(|e| format!("cannot start the display thread: {e}"))?;
        Ok(Display { tiles, thread: Some(thread) })
    }

    /// Hands a finished tile to the display (never blocks on the network).
    pub fn send(&self, tile: Tile) {
        let _ = self.tiles.send(tile);
    }

    /// Sends what is left and closes the connection.
    pub fn finish(mut self) -> Report {
        let (tx, _) = channel();
        drop(std::mem::replace(&mut self.tiles, tx));
        self.thread.take().and_then(|t| t.join().ok()).unwrap_or_default()
    }
}

/// The display thread's state: where tev is, the image so far and the connection.
struct Link {
    addrs: Vec<std::net::SocketAddr>,
    name: String,
    width: u32,
    height: u32,
    image: Vec<f32>,
    stream: Option<TcpStream>,
    last_try: Option<Instant>,
    /// Whether any tile has come (then a new connection gets the image so far).
    stored: bool,
    report: Report,
}

impl Link {
    fn run(&mut self, rx: Receiver<Tile>) {
        self.connected();
        loop {
            match rx.recv_timeout(RETRY) {
                Ok((r, rgb)) => {
                    self.store(r, &rgb);
                    if self.connected() {
                        let p = update_image(&self.name, r, &rgb);
                        self.write(&p);
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    self.connected();
                }
                Err(RecvTimeoutError::Disconnected) => break,
            }
        }
        // The render is over: one last try to show the finished image, then close.
        if self.stream.is_none() {
            self.last_try = None;
            self.connected();
        }
        if let Some(s) = self.stream.take() {
            let _ = s.shutdown(std::net::Shutdown::Both);
        }
    }

    fn store(&mut self, r: Rect, rgb: &[f32]) {
        self.stored = true;
        let w = r.width() as usize;
        for (row, y) in (r.y0..r.y1).enumerate() {
            let at = 3 * (y as usize * self.width as usize + r.x0 as usize);
            self.image[at..at + 3 * w].copy_from_slice(&rgb[3 * w * row..3 * w * (row + 1)]);
        }
    }

    /// Whether a connection is open, trying to open one (at most once per [`RETRY`]) if not; a
    /// new connection gets the image created and everything so far.
    fn connected(&mut self) -> bool {
        if self.stream.is_some() {
            return true;
        }
        if self.last_try.is_some_and(|t| t.elapsed() < RETRY) {
            return false;
        }
        self.last_try = Some(Instant::now());
        let stream = self.addrs.iter().find_map(|a| TcpStream::connect_timeout(a, SEND_TIMEOUT).ok());
        let Some(stream) = stream else {
            self.report.error = Some(format!("nothing answers at {}", self.addrs[0]));
            return false;
        };
        let _ = stream.set_write_timeout(Some(SEND_TIMEOUT));
        let _ = stream.set_nodelay(true);
        self.stream = Some(stream);
        self.report.connected = true;
        // The whole image so far is sent again below: nothing was missed.
        self.report.error = None;
        self.write(&create_image(&self.name, self.width, self.height));
        if !self.stored {
            return self.stream.is_some();
        }
        for y0 in (0..self.height).step_by(BAND_ROWS as usize) {
            let r = Rect { x0: 0, y0, x1: self.width, y1: (y0 + BAND_ROWS).min(self.height) };
            let at = 3 * y0 as usize * self.width as usize;
            let p = update_image(&self.name, r, &self.image[at..at + 3 * r.pixels() as usize]);
            self.write(&p);
        }
        self.stream.is_some()
    }

    fn write(&mut self, packet: &[u8]) {
        let Some(s) = self.stream.as_mut() else { return };
        match s.write_all(packet) {
            Ok(()) => self.report.packets += 1,
            Err(e) => {
                self.report.error = Some(format!("sending to {} failed: {e}", self.addrs[0]));
                self.stream = None;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packets_have_their_length_first_and_the_fields_in_protocol_order() {
        let p = create_image("a.png", 3, 2);
        assert_eq!(u32::from_le_bytes(p[..4].try_into().unwrap()) as usize, p.len());
        assert_eq!(&p[4..6], &[CREATE_IMAGE, 1]);
        assert_eq!(&p[6..12], b"a.png\0");
        assert_eq!(&p[12..24], &[3, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0]);
        assert_eq!(&p[24..], b"R\0G\0B\0");
        let r = Rect { x0: 1, y0: 0, x1: 3, y1: 1 };
        let u = update_image("a.png", r, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(u32::from_le_bytes(u[..4].try_into().unwrap()) as usize, u.len());
        assert_eq!(&u[4..6], &[UPDATE_IMAGE_V3, 0]);
        let after_names = 6 + 6 + 4 + 6;
        assert_eq!(&u[after_names..after_names + 16], &[1, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0]);
        let values = &u[u.len() - 24..];
        assert_eq!(f32::from_le_bytes(values[20..24].try_into().unwrap()), 6.0);
        assert_eq!(u.len(), after_names + 16 + 48 + 24);
    }
}
