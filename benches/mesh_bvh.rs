//! Criterion benchmarks of meshes: BVH build time, primary (closest-hit) and shadow (any-hit)
//! rays per second, on bumpy spheres of 1k to 1M triangles, queried directly and as the one
//! bounded object of a scene (`scene_primary`, `scene_shadow`: through `ObjectAccel`).
//! `raylab bench` measures the same on any mesh file, as a table (docs/performance.md, "Speed of meshes and BVHs").
//! The ray groups are named after the traversal copy that runs (`rays-avx2`: 8-lane AVX2 slab
//! tests; `rays-baseline`: the same hierarchy in SSE2 halves, forced by `RAYLAB_SIMD=baseline`),
//! so criterion keeps separate histories for the two.
//!
//! `cargo bench -p raylab-plugins --features mesh,bvh`
//! `RAYLAB_SIMD=baseline cargo bench -p raylab-plugins --features mesh,bvh -- rays`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use raylab::Ray;
use raylab::accel::{AccelChoice, ObjectAccel};
use raylab::geometry::{Geometry, Intersectable};
use raylab::glam::DVec3;
use raylab::math::float::offset_ray_origin;
use raylab_plugins::mesh::MeshObject;
use raylab_plugins::mesh::triangle_mesh::{MeshData, Normals, TriangleMesh};
use std::hint::black_box;
use std::sync::Arc;

/// A sphere of about `n` triangles with bumps, so triangles vary in size and orientation.
fn bumpy_sphere(n: usize) -> MeshData {
    let rings = ((n as f64 / 4.0).sqrt().round() as u32).max(2);
    let segments = (n as u32 / (2 * rings)).max(3);
    let mut positions = Vec::new();
    for i in 0..=rings {
        let th = std::f64::consts::PI * f64::from(i) / f64::from(rings);
        for j in 0..segments {
            let ph = std::f64::consts::TAU * f64::from(j) / f64::from(segments);
            let r = 1.0 + 0.08 * (7.0 * th).sin() * (5.0 * ph).cos();
            positions.push([(r * th.sin() * ph.cos()) as f32, (r * th.cos()) as f32, (r * th.sin() * ph.sin()) as f32]);
        }
    }
    let v = |i: u32, j: u32| i * segments + j % segments;
    let mut triangles = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            triangles.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
            triangles.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    MeshData { positions, triangles, ..MeshData::default() }
}

/// Rays from a 64×48 pinhole camera looking at the unit sphere.
fn camera_rays() -> Vec<Ray> {
    let eye = DVec3::new(0.3, 0.25, 1.0).normalize() * 3.0;
    let (fwd, up) = (-eye.normalize(), DVec3::Y);
    let right = fwd.cross(up).normalize();
    let up = right.cross(fwd);
    (0..48)
        .flat_map(|y| (0..64).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (u, v) = ((f64::from(x) + 0.5) / 32.0 - 1.0, 1.0 - (f64::from(y) + 0.5) / 24.0);
            Ray::new(eye, fwd + right * u * 0.55 + up * v * 0.41)
        })
        .collect()
}

fn meshes(c: &mut Criterion) {
    let rays = camera_rays();
    let to_light = DVec3::new(0.3, 1.0, 0.5).normalize();
    for n in [1_000usize, 10_000, 100_000, 1_000_000] {
        let data = bumpy_sphere(n);
        let mut build = c.benchmark_group("bvh_build");
        build.sample_size(if n >= 100_000 { 10 } else { 30 });
        build.throughput(Throughput::Elements(data.triangles.len() as u64));
        build.bench_with_input(BenchmarkId::from_parameter(n), &data, |b, d| {
            b.iter(|| TriangleMesh::new(black_box(d.clone()), Normals::Flat, AccelChoice::Bvh).unwrap())
        });
        build.finish();
        let objects = [MeshObject::new(Arc::new(TriangleMesh::new(data, Normals::Flat, AccelChoice::Bvh).unwrap()))];
        let mesh = &objects[0];
        // The mesh as the one bounded object of a scene (a model on an infinite ground: the scene
        // query a render makes, the frame's corners missing the mesh's box).
        let (accel, _) = ObjectAccel::build(&[mesh.bounds()], |_| true, AccelChoice::Auto);
        let scene = accel.over(&objects);
        let shadow: Vec<Ray> = rays
            .iter()
            .filter_map(|r| mesh.intersect(r, 0.0, f64::INFINITY).map(|h| (h, r)))
            .map(|(h, r)| Ray { origin: offset_ray_origin(h.point, h.error, mesh.normal(&h, r.dir), to_light), dir: to_light })
            .collect();
        let mut g = c.benchmark_group(format!("rays-{}", raylab::accel::traversal_kernel()));
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(BenchmarkId::new("primary", n), |b| {
            b.iter(|| rays.iter().filter(|r| mesh.intersect(r, 0.0, f64::INFINITY).is_some()).count())
        });
        g.bench_function(BenchmarkId::new("scene_primary", n), |b| {
            b.iter(|| rays.iter().filter(|r| scene.intersect(r, 0.0, f64::INFINITY).is_some()).count())
        });
        g.throughput(Throughput::Elements(shadow.len() as u64));
        g.bench_function(BenchmarkId::new("shadow", n), |b| {
            b.iter(|| shadow.iter().filter(|r| mesh.occludes(r, 0.0, f64::INFINITY)).count())
        });
        g.bench_function(BenchmarkId::new("scene_shadow", n), |b| {
            b.iter(|| shadow.iter().filter(|r| scene.occludes(r, 0.0, f64::INFINITY)).count())
        });
        g.finish();
    }
}

criterion_group!(benches, meshes);
criterion_main!(benches);
