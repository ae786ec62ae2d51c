//! `raylab bench`: how fast meshes load, index and trace, from a thousand triangles to millions.
//!
//! For each mesh (generated bumpy spheres of the sizes asked for, and any mesh files given), it
//! loads the mesh through the registry's `mesh` plugin, fits a camera to it, and times one primary
//! ray per pixel and then one shadow ray per hit toward a directional light, in parallel. It
//! reports load and BVH build time, primary, shadow and overall rays per second, and the bytes per
//! triangle of the triangle store plus its index. Timings are wall-clock on a possibly busy
//! machine: compare rows of one run, not runs.

use super::{App, Failure, si};
use crate::accel::AccelChoice;
use crate::geometry::Intersectable;
use crate::load::context::LoadOptions;
use crate::load::loader::load_str;
use crate::math::float::offset_ray_origin;
use crate::math::ray::Ray;
use clap::Args;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Largest image side `bench` renders, pixels (the scenes' default `--max-side`).
const MAX_SIDE: i128 = 1 << 15;

#[derive(Args, Debug)]
pub(crate) struct BenchArgs {
    /// Mesh files to benchmark (.obj, .gltf, .glb), besides the generated ones.
    meshes: Vec<PathBuf>,
    /// Triangle counts of the generated bumpy spheres (k and M suffixes allowed; none: `--sizes ""`).
    #[arg(long, value_delimiter = ',', default_value = "1k,10k,100k,1M", allow_hyphen_values = true)]
    sizes: Vec<String>,
    /// Image width (one primary ray per pixel).
    #[arg(long, default_value_t = 800, allow_hyphen_values = true, value_parser = super::int_in::<u32>(1, MAX_SIDE))]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 600, allow_hyphen_values = true, value_parser = super::int_in::<u32>(1, MAX_SIDE))]
    height: u32,
    /// Worker threads (default: all cores).
    #[arg(long, allow_hyphen_values = true, value_parser = super::int_in::<usize>(1, super::MAX_THREADS))]
    threads: Option<usize>,
    /// Spatial index for the triangles: `bvh`, `list` or `auto`.
    #[arg(long, value_parser = ["auto", "bvh", "list"], default_value = "auto")]
    accel: String,
    /// Print the table as Markdown.
    #[arg(long)]
    markdown: bool,
}

/// One benchmarked mesh.
struct Row {
    name: String,
    triangles: u64,
    accel: &'static str,
    load: f64,
    /// CPU time of loading and building, all threads.
    load_cpu: Option<f64>,
    build: f64,
    primary: (u64, f64),
    shadow: (u64, f64),
    bytes_per_triangle: f64,
    /// Fraction of the threads' wall time they spent on a CPU (below 1 on a busy machine).
    busy: Option<f64>,
    /// All rays per wall-clock second.
    wall_rate: f64,
}

/// CPU time of the calling thread (wall time where the platform does not tell).
fn thread_time() -> std::time::Duration {
    static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    crate::render::stats::thread_cpu_time().unwrap_or_else(|| START.get_or_init(Instant::now).elapsed())
}

pub(crate) fn run(app: &App, a: BenchArgs) -> Result<(), Failure> {
    if app.registry.geometry("mesh").is_none() {
        return Err(Failure::Other(format!(
            "`raylab bench` needs the `mesh` geometry (and a BVH, feature `bvh`); {}",
            crate::param::error::built_without("mesh")
        )));
    }
    let accel = AccelChoice::parse(&a.accel).unwrap_or_default();
    if accel == AccelChoice::Bvh && !crate::accel::build::BVH_AVAILABLE {
        return Err(Failure::Other(format!("--accel bvh needs the `bvh` feature; {}", crate::param::error::built_without("bvh"))));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .map_err(|e| Failure::Other(format!("cannot start the worker threads: {e}")))?;
    let dir = std::env::temp_dir().join(format!("raylab-bench-{}", std::process::id()));
    let mut cases: Vec<(String, PathBuf)> = Vec::new();
    for s in a.sizes.iter().filter(|s| !s.trim().is_empty()) {
        let n = parse_count(s).ok_or_else(|| Failure::Other(format!("--sizes: expected counts like 1k or 2M, found \"{s}\"")))?;
        std::fs::create_dir_all(&dir).map_err(|e| Failure::Other(format!("cannot create {}: {e}", dir.display())))?;
        let path = dir.join(format!("sphere-{n}.obj"));
        let tris = write_bumpy_sphere(&path, n).map_err(|e| Failure::Other(format!("cannot write {}: {e}", path.display())))?;
        cases.push((format!("bumpy sphere {}", si(tris as f64)), path));
    }
    for m in &a.meshes {
        let abs = std::fs::canonicalize(m).map_err(|e| Failure::Other(format!("cannot read {}: {e}", m.display())))?;
        cases.push((m.file_name().map_or_else(|| m.display().to_string(), |f| f.to_string_lossy().into_owned()), abs));
    }
    let threads = pool.current_num_threads();
    eprintln!("benchmarking {} meshes at {}×{} on {threads} threads…", cases.len(), a.width, a.height);
    let mut rows = Vec::new();
    for (name, path) in &cases {
        let row = pool.install(|| bench_one(app, name, path, accel, a.width, a.height));
        // Only the meshes generated here are removed; a user's --mesh file is never touched.
        if path.starts_with(&dir) {
            let _ = std::fs::remove_file(path);
        }
        rows.push(row?);
    }
    let _ = std::fs::remove_dir_all(&dir);
    print!("{}", table(&rows, a.markdown, threads));
    Ok(())
}

fn bench_one(app: &App, name: &str, path: &Path, accel: AccelChoice, width: u32, height: u32) -> Result<Row, Failure> {
    let quoted = path.display().to_string().replace('\\', "\\\\").replace('"', "\\\"");
    let scene = format!(
        "[render]\nwidth = {width}\nheight = {height}\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
         [[object]]\ntype = \"mesh\"\nfile = \"{quoted}\"\nmaterial = {{ kd = 0.8 }}\n"
    );
    let opts = LoadOptions { allow_outside_paths: true, accel, ..LoadOptions::default() };
    let t0 = Instant::now();
    let c0 = crate::render::stats::process_cpu_time();
    let mut job = load_str(&app.registry, name, &scene, Path::new("."), &opts)?;
    let load = t0.elapsed().as_secs_f64();
    let load_cpu = c0.zip(crate::render::stats::process_cpu_time()).map(|(a, b)| (b - a).as_secs_f64());
    let summary = job.scene.accel_summary();
    let built = summary.object_builds;
    // A camera fitted to the mesh: its bounding sphere fills most of the frame.
    let b = job.scene.bounds();
    let (center, radius) = (b.center(), (b.extent().length() * 0.5).max(1e-9));
    let dir = DVec3::new(0.3, 0.25, 1.0).normalize();
    job.scene.camera = crate::scene::camera::Camera::look_at(center + dir * radius * 2.6, center, DVec3::Y, 45.0, width, height)
        .map_err(|e| Failure::Other(e.to_string()))?;
    let scene = &job.scene;
    let to_light = DVec3::new(0.3, 1.0, 0.5).normalize();
    // Bands of rows: primary rays (closest hit), then one shadow ray (any hit) toward the light
    // from each hit. Each phase is timed by the CPU time of its thread, so other processes on a
    // busy machine do not count; the wall-clock total is reported beside it.
    let cpu0 = crate::render::stats::process_cpu_time();
    let t0 = Instant::now();
    let band = 8;
    let (primary_ns, shadow_ns, shadow_rays) = (0..height.div_ceil(band))
        .into_par_iter()
        .map_init(Vec::new, |hits, b| {
            let ta = thread_time();
            hits.clear();
            for y in b * band..((b + 1) * band).min(height) {
                for x in 0..width {
                    let film = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
                    let ray = scene.camera.ray_through(width, height, film, DVec2::ZERO);
                    if let Some(h) = scene.intersect(&ray, 0.0, f64::INFINITY) {
                        let n = scene.objects[h.object as usize].geometry().normal(&h, ray.dir);
                        hits.push((h.point, h.error, n));
                    }
                }
            }
            let tb = thread_time();
            let mut blocked = 0u32;
            for &(p, err, n) in hits.iter() {
                let ray = Ray { origin: offset_ray_origin(p, err, n, to_light), dir: to_light };
                blocked += u32::from(scene.occludes(&ray, 0.0, f64::INFINITY));
            }
            std::hint::black_box(blocked);
            let tc = thread_time();

            ((tb - ta).as_nanos() as u64, (tc - tb).as_nanos() as u64, hits.len() as u64)
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    let wall = t0.elapsed().as_secs_f64();
    let cpu = cpu0.zip(crate::render::stats::process_cpu_time()).map(|(a, b)| (b - a).as_secs_f64());
    let threads = rayon::current_num_threads() as f64;
    // Per-phase times summed over threads, as seconds of `threads` threads running at once.
    let primary = (u64::from(width) * u64::from(height), primary_ns as f64 * 1e-9 / threads);
    let shadow = (shadow_rays, shadow_ns as f64 * 1e-9 / threads);
    let busy = cpu.map(|c| c / (wall * threads));
    let wall_rate = (primary.0 + shadow.0) as f64 / wall.max(1e-9);
    let triangles = built.primitives.max(1);
    Ok(Row {
        name: name.to_string(),
        triangles: built.primitives,
        accel: if built.hierarchies > 0 { "bvh" } else { "list" },
        load: load - built.time.as_secs_f64() - summary.build.time.as_secs_f64(),
        load_cpu,
        build: built.time.as_secs_f64(),
        primary,
        shadow,
        bytes_per_triangle: built.bytes as f64 / triangles as f64,
        busy,
        wall_rate,
    })
}

fn table(rows: &[Row], markdown: bool, threads: usize) -> String {
    let head = [
        "mesh",
        "triangles",
        "index",
        "load s",
        "BVH build s",
        "load+build CPU s",
        "primary rays/s",
        "shadow rays/s",
        "all rays/s",
        "bytes/tri",
        "wall rays/s",
        "CPU busy",
    ];
    let cells: Vec<[String; 12]> = rows
        .iter()
        .map(|r| {
            let rate = |(n, s): (u64, f64)| si(n as f64 / s.max(1e-9));
            [
                r.name.clone(),
                r.triangles.to_string(),
                r.accel.to_string(),
                format!("{:.3}", r.load),
                format!("{:.3}", r.build),
                r.load_cpu.map_or_else(|| "?".into(), |c| format!("{c:.3}")),
                rate(r.primary),
                rate(r.shadow),
                rate((r.primary.0 + r.shadow.0, r.primary.1 + r.shadow.1)),
                format!("{:.0}", r.bytes_per_triangle),
                si(r.wall_rate),
                r.busy.map_or_else(|| "?".into(), |b| format!("{:.0}%", b * 100.0)),
            ]
        })
        .collect();
    let mut out = String::new();
    if markdown {
        out.push_str(&format!("| {} |\n|{}\n", head.join(" | "), "---|".repeat(head.len())));
        for c in &cells {
            out.push_str(&format!("| {} |\n", c.join(" | ")));
        }
    } else {
        let w: Vec<usize> = (0..head.len()).map(|i| cells.iter().map(|c| c[i].len()).chain([head[i].len()]).max().unwrap_or(0)).collect();
        let line =
            |c: &[String]| c.iter().enumerate().map(|(i, s)| format!("{s:>width$}", width = w[i])).collect::<Vec<_>>().join("  ") + "\n";
        out.push_str(&line(&head.map(String::from)));
        for c in &cells {
            out.push_str(&line(c));
        }
    }
    out.push_str(&format!(
        "({threads} threads; load and build are wall-clock, load excludes the BVH build; rays/s from the threads' CPU time, as if they had the cores to themselves; \
         wall rays/s is what this run got, with the threads on a CPU \"CPU busy\" of the time)\n"
    ));
    out
}

/// `1k` → 1000, `2.5M` → 2 500 000.
fn parse_count(s: &str) -> Option<u64> {
    let s = s.trim();
    let (num, mul) = match s.chars().last()? {
        'k' | 'K' => (&s[..s.len() - 1], 1e3),
        'm' | 'M' => (&s[..s.len() - 1], 1e6),
        _ => (s, 1.0),
    };
    let v = num.parse::<f64>().ok()? * mul;
    (8.0..=1e8).contains(&v).then_some(v.round() as u64)
}

/// Writes a sphere with bumps (so triangles vary in size and orientation) of about `n`
/// triangles as OBJ; returns the exact count.
fn write_bumpy_sphere(path: &Path, n: u64) -> std::io::Result<u64> {
    let rings = ((n as f64 / 4.0).sqrt().round() as u64).max(2);
    let segments = (n / (2 * rings)).max(3);
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    let radius = |th: f64, ph: f64| 1.0 + 0.08 * (7.0 * th).sin() * (5.0 * ph).cos() + 0.03 * (23.0 * th + 2.0).sin() * (19.0 * ph).sin();
    writeln!(f, "# bumpy sphere, {rings} rings × {segments} segments")?;
    for i in 1..rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let ph = std::f64::consts::TAU * j as f64 / segments as f64;
            let r = radius(th, ph);
            writeln!(f, "v {:.7} {:.7} {:.7}", r * th.sin() * ph.cos(), r * th.cos(), r * th.sin() * ph.sin())?;
        }
    }
    let (top, bottom) = ((rings - 1) * segments + 1, (rings - 1) * segments + 2);
    writeln!(f, "v 0 {:.7} 0\nv 0 {:.7} 0", radius(0.0, 0.0), -radius(std::f64::consts::PI, 0.0))?;
    let v = |i: u64, j: u64| (i - 1) * segments + (j % segments) + 1;
    let mut count = 0;
    for j in 0..segments {
        writeln!(f, "f {top} {} {}", v(1, j + 1), v(1, j))?;
        writeln!(f, "f {bottom} {} {}", v(rings - 1, j), v(rings - 1, j + 1))?;
        count += 2;
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            writeln!(f, "f {} {} {}\nf {} {} {}", v(i, j), v(i, j + 1), v(i + 1, j + 1), v(i, j), v(i + 1, j + 1), v(i + 1, j))?;
            count += 2;
        }
    }
    f.flush()?;
    Ok(count)
}
