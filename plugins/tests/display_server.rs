//! `raylab render --display-server`: a small listener speaking tev's side of its TCP protocol
//! (written here from the protocol, not from raylab's sender) receives the render and rebuilds the
//! image from the packets; it must equal the image raylab writes, bit for bit.

use std::io::Read;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("raylab-tev-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A packet as tev reads it.
#[derive(Debug)]
enum Packet {
    Create { name: String, width: i32, height: i32, channels: Vec<String> },
    Update { name: String, channels: Vec<String>, x: i32, y: i32, w: i32, h: i32, values: Vec<Vec<f32>> },
}

/// Reads fields off a packet's bytes.
struct Fields<'a>(&'a [u8]);

impl Fields<'_> {
    fn take(&mut self, n: usize) -> &[u8] {
        assert!(self.0.len() >= n, "packet too short");
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        a
    }
    fn u8(&mut self) -> u8 {
        self.take(1)[0]
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let end = self.0.iter().position(|&b| b == 0).expect("NUL-terminated string");
        let s = String::from_utf8(self.0[..end].to_vec()).unwrap();
        self.0 = &self.0[end + 1..];
        s
    }
}

fn decode(bytes: &[u8]) -> Packet {
    let mut f = Fields(bytes);
    let kind = f.u8();
    match kind {
        4 => {
            let _grab = f.u8();
            let name = f.string();
            let (width, height, n) = (f.i32(), f.i32(), f.i32());
            let channels = (0..n).map(|_| f.string()).collect();
            assert!(f.0.is_empty(), "trailing bytes in CreateImage");
            Packet::Create { name, width, height, channels }
        }
        6 => {
            let _grab = f.u8();
            let name = f.string();
            let n = f.i32() as usize;
            let channels: Vec<String> = (0..n).map(|_| f.string()).collect();
            let (x, y, w, h) = (f.i32(), f.i32(), f.i32(), f.i32());
            let offsets: Vec<i64> = (0..n).map(|_| f.i64()).collect();
            let strides: Vec<i64> = (0..n).map(|_| f.i64()).collect();
            let data: Vec<f32> = f.0.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
            let pixels = (w * h) as usize;
            let values = (0..n).map(|c| (0..pixels).map(|p| data[(offsets[c] + p as i64 * strides[c]) as usize]).collect()).collect();
            Packet::Update { name, channels, x, y, w, h, values }
        }
        k => panic!("raylab sent a packet of type {k}; it sends only 4 (create) and 6 (update)"),
    }
}

/// Accepts one connection and reads its packets until the sender closes it.
fn listen(listener: TcpListener) -> Vec<Packet> {
    let (mut s, _) = listener.accept().unwrap();
    let mut bytes = Vec::new();
    s.read_to_end(&mut bytes).unwrap();
    let mut packets = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let n = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        assert!(n >= 5 && at + n <= bytes.len(), "packet length {n} at {at} of {}", bytes.len());
        packets.push(decode(&bytes[at + 4..at + n]));
        at += n;
    }
    packets
}

fn read_pfm(path: &Path) -> (usize, usize, Vec<f32>) {
    let b = std::fs::read(path).unwrap();
    let text = String::from_utf8_lossy(&b[..32.min(b.len())]).into_owned();
    let mut it = text.split_ascii_whitespace();
    assert_eq!(it.next(), Some("PF"));
    let (w, h): (usize, usize) = (it.next().unwrap().parse().unwrap(), it.next().unwrap().parse().unwrap());
    let data = &b[b.len() - w * h * 12..];
    let mut rgb = vec![0.0; w * h * 3];
    for row in 0..h {
        for i in 0..w * 3 {
            let at = 4 * (row * w * 3 + i);
            rgb[(h - 1 - row) * w * 3 + i] = f32::from_le_bytes(data[at..at + 4].try_into().unwrap());
        }
    }
    (w, h, rgb)
}

#[test]
fn a_render_streams_to_a_tev_listener_and_the_packets_rebuild_the_image() {
    let dir = temp("stream");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || listen(listener));
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/showcase.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", scene.to_str().unwrap(), "-o", "out.pfm", "-q", "--width", "70", "--height", "45"])
        .args(["--aa", "stratified", "--spp", "3", "--display-server", &addr])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning"), "{}", String::from_utf8_lossy(&out.stderr));
    let packets = server.join().unwrap();

    let Some(Packet::Create { name, width, height, channels }) = packets.first() else { panic!("first packet: {:?}", packets.first()) };
    assert_eq!((name.as_str(), *width, *height), ("out.pfm", 70, 45));
    assert_eq!(channels, &["R", "G", "B"]);
    let (w, h, expected) = read_pfm(&dir.join("out.pfm"));
    assert_eq!((w, h), (70, 45));
    // Replay the updates in order, as tev does; every pixel must be covered.
    let mut image = vec![f32::NAN; w * h * 3];
    let mut updates = 0;
    for p in &packets[1..] {
        let Packet::Update { name, channels, x, y, w: tw, h: th, values } = p else { panic!("unexpected packet {p:?}") };
        assert_eq!((name.as_str(), channels.len()), ("out.pfm", 3));
        assert!(*x >= 0 && *y >= 0 && x + tw <= 70 && y + th <= 45, "tile {x},{y} {tw}×{th} outside the image");
        for ty in 0..*th as usize {
            for tx in 0..*tw as usize {
                for c in 0..3 {
                    image[3 * ((*y as usize + ty) * w + *x as usize + tx) + c] = values[c][ty * *tw as usize + tx];
                }
            }
        }
        updates += 1;
    }
    // Passes at 1, 2 and 3 spp: every 16×16 tile (5 × 3) updated once per pass.
    assert_eq!(updates, 3 * 15, "one update per tile and pass");
    let same = image.iter().zip(&expected).all(|(a, b)| a.to_bits() == b.to_bits());
    assert!(same, "the streamed image differs from the written one");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn an_absent_display_server_is_a_warning_and_the_render_goes_on() {
    let dir = temp("absent");
    // A port nothing listens on: bind one, note it, close it.
    let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let out = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", "-o", "x.png", "-q", "--width", "40", "--height", "30", "--display-server", &format!("127.0.0.1:{port}")])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("warning: no display server (tev) reached at 127.0.0.1:"), "{err}");
    assert!(dir.join("x.png").is_file());
    let bad = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", "-o", "y.png", "-q", "--width", "8", "--height", "8", "--display-server", "no-port-here"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("expected HOST:PORT"), "{}", String::from_utf8_lossy(&bad.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}
