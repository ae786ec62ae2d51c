//! The watertightness campaign: rays from random points inside closed, randomly perturbed meshes,
//! aimed exactly at their vertices, at points on their edges and inside their triangles, never
//! escape. 10⁶ rays per mesh through the hierarchy (a torus, not star-shaped, and a box whose
//! faces are perturbed grids), at scales 10⁻³ to 10³ and 10³ sizes from the origin; fewer through
//! a flat list. pbrt-v4 has this test but keeps it switched off; here it runs on every test run.
#![cfg(feature = "mesh")]

use raylab::Ray;
use raylab::accel::AccelChoice;
use raylab::geometry::{Geometry, Intersectable};
use raylab::glam::DVec3;
use raylab::math::sampler::mix64;
use raylab_plugins::mesh::MeshObject;
use raylab_plugins::mesh::triangle_mesh::{MeshData, Normals, TriangleMesh};
use std::f64::consts::TAU;
use std::sync::Arc;

/// A deterministic stream of uniform numbers in `[0, 1)` (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        (mix64(self.0) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    fn signed(&mut self) -> f64 {
        2.0 * self.next() - 1.0
    }
}

/// A closed mesh, placed at `scale` around `center`, with a sampler of its interior.
struct Closed {
    data: MeshData,
    /// A point strictly inside, from three uniform numbers.
    inside: Box<dyn Fn(&mut Rng) -> DVec3>,
}

/// A torus (major radius 1, minor 0.35) of `nu × nv` quads split in two, each vertex moved along
/// its tube's radius by up to ±15 %.
fn torus(nu: u32, nv: u32, scale: f64, center: DVec3, r: &mut Rng) -> Closed {
    let (big, small) = (1.0, 0.35);
    let mut positions = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (u, v) = (TAU * f64::from(i) / f64::from(nu), TAU * f64::from(j) / f64::from(nv));
            let rho = small * (1.0 + 0.15 * r.signed());
            let ring = DVec3::new(u.cos(), u.sin(), 0.0);
            let p = (big + rho * v.cos()) * ring + DVec3::new(0.0, 0.0, rho * v.sin());
            positions.push((center + scale * p).as_vec3().to_array());
        }
    }
    let at = |i: u32, j: u32| (i % nu) * nv + (j % nv);
    let mut triangles = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            triangles.extend([[a, b, c], [a, c, d]]);
        }
    }
    let inside = move |r: &mut Rng| {
        // Within 0.5 of the smallest tube radius (0.85 · 0.35) of the centre circle.
        let u = TAU * r.next();
        let (rho, v) = (0.5 * 0.85 * small * r.next().sqrt(), TAU * r.next());
        let ring = DVec3::new(u.cos(), u.sin(), 0.0);
        center + scale * ((big + rho * v.cos()) * ring + DVec3::new(0.0, 0.0, rho * v.sin()))
    };
    Closed { data: MeshData { positions, triangles, ..MeshData::default() }, inside: Box::new(inside) }
}

/// The cube [−1, 1]³ with each face an `n × n` grid, every vertex moved by up to ±0.3 grid cells
/// in each direction (edges and corners shared, so the mesh stays closed).
fn bumpy_box(n: u32, scale: f64, center: DVec3, r: &mut Rng) -> Closed {
    let mut index = std::collections::HashMap::new();
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut triangles = Vec::new();
    let cell = 2.0 / f64::from(n);
    // Each face: an axis, a sign, and two in-face axes ordered for an outward winding.
    for (axis, sign) in [(0usize, 1.0f64), (0, -1.0), (1, 1.0), (1, -1.0), (2, 1.0), (2, -1.0)] {
        let (a1, a2) = if sign > 0.0 { ((axis + 1) % 3, (axis + 2) % 3) } else { ((axis + 2) % 3, (axis + 1) % 3) };
        let mut vertex = |i: u32, j: u32, positions: &mut Vec<[f32; 3]>, r: &mut Rng| -> u32 {
            let mut key = [0i64; 3];
            key[axis] = if sign > 0.0 { i64::from(n) } else { 0 };
            key[a1] = i64::from(i);
            key[a2] = i64::from(j);
            *index.entry(key).or_insert_with(|| {
                let p = DVec3::from_array(key.map(|k| -1.0 + cell * k as f64 + 0.3 * cell * r.signed()));
                positions.push((center + scale * p).as_vec3().to_array());
                positions.len() as u32 - 1
            })
        };
        for i in 0..n {
            for j in 0..n {
                let a = vertex(i, j, &mut positions, r);
                let b = vertex(i + 1, j, &mut positions, r);
                let c = vertex(i + 1, j + 1, &mut positions, r);
                let d = vertex(i, j + 1, &mut positions, r);
                triangles.extend([[a, b, c], [a, c, d]]);
            }
        }
    }
    let margin = 1.0 - 0.31 * cell;
    let inside = move |r: &mut Rng| center + scale * margin * 0.9 * DVec3::new(r.signed(), r.signed(), r.signed());
    Closed { data: MeshData { positions, triangles, ..MeshData::default() }, inside: Box::new(inside) }
}

/// Points a ray must not slip past: every vertex exactly, edge midpoints, points at random
/// fractions of every edge, and random points inside every triangle.
fn targets(data: &MeshData, r: &mut Rng) -> Vec<DVec3> {
    let v = |i: u32| DVec3::from(data.positions[i as usize].map(f64::from));
    let mut out: Vec<DVec3> = (0..data.positions.len() as u32).map(v).collect();
    for t in &data.triangles {
        for k in 0..3 {
            let (a, b) = (v(t[k]), v(t[(k + 1) % 3]));
            out.extend([a + 0.5 * (b - a), a + r.next() * (b - a)]);
        }
        let (x, y) = (r.next(), r.next());
        let (x, y) = if x + y > 1.0 { (1.0 - x, 1.0 - y) } else { (x, y) };
        out.push(v(t[0]) + x * (v(t[1]) - v(t[0])) + y * (v(t[2]) - v(t[0])));
    }
    out
}

/// Shoots at least `rays` rays from random interior points of closed meshes made by `make` (a new
/// random mesh every few origins, at a random scale and position) toward their targets, through
/// `accel`; returns (rays, escapes, examples). `closed`: whether the meshes are closed.
fn campaign(
    make: &dyn Fn(f64, DVec3, &mut Rng) -> Closed,
    accel: AccelChoice,
    rays: u64,
    seed: u64,
    closed: bool,
) -> (u64, u64, Vec<String>) {
    let mut r = Rng(seed);
    let (mut shot, mut escapes, mut examples) = (0u64, 0u64, Vec::new());
    while shot < rays {
        let scale = [1e-3, 1.0, 1e3][(r.next() * 3.0) as usize];
        let center = if r.next() < 0.5 { DVec3::ZERO } else { 1e3 * scale * DVec3::new(r.signed(), r.signed(), r.signed()) };
        let shape = make(scale, center, &mut r);
        let mesh = TriangleMesh::new(shape.data.clone(), Normals::Flat, accel).expect("a valid mesh");
        let g = MeshObject::new(Arc::new(mesh));
        assert_eq!(g.is_closed(), closed, "the test mesh's closedness");
        let targets = targets(&shape.data, &mut r);
        for _ in 0..4 {
            let origin = (shape.inside)(&mut r);
            for &target in &targets {
                let ray = Ray::new(origin, target - origin);
                shot += 1;
                if g.intersect(&ray, 0.0, f64::INFINITY).is_none() || !g.occludes(&ray, 0.0, f64::INFINITY) {
                    escapes += 1;
                    if examples.len() < 5 {
                        examples.push(format!("scale {scale:e}, centre {center}: ray from {origin} toward {target} escaped"));
                    }
                }
            }
        }
    }
    (shot, escapes, examples)
}

fn check(name: &str, make: &dyn Fn(f64, DVec3, &mut Rng) -> Closed, accel: AccelChoice, rays: u64) {
    let (shot, escapes, examples) = campaign(make, accel, rays, 0x7a7e_47f1 ^ rays, true);
    eprintln!("{name} ({accel:?}): {shot} rays, {escapes} escapes");
    assert!(shot >= rays);
    assert_eq!(escapes, 0, "{name} ({accel:?}): {escapes} of {shot} rays escaped, e.g.\n{}", examples.join("\n"));
}

#[test]
fn no_ray_escapes_a_closed_torus_million_rays() {
    check("torus", &|s, c, r| torus(48, 24, s, c, r), AccelChoice::Auto, 1_000_000);
    check("torus", &|s, c, r| torus(12, 8, s, c, r), AccelChoice::List, 20_000);
}

#[test]
fn no_ray_escapes_a_closed_bumpy_box_million_rays() {
    check("bumpy box", &|s, c, r| bumpy_box(12, s, c, r), AccelChoice::Auto, 1_000_000);
    check("bumpy box", &|s, c, r| bumpy_box(3, s, c, r), AccelChoice::List, 20_000);
}

/// The campaign can fail: a mesh with one triangle missing lets rays through the hole.
#[test]
fn the_campaign_finds_a_hole() {
    let holed = |s: f64, c: DVec3, r: &mut Rng| {
        let mut m = torus(12, 8, s, c, r);
        m.data.triangles.remove(5);
        m
    };
    let (shot, escapes, _) = campaign(&holed, AccelChoice::Auto, 5_000, 1, false);
    assert!(escapes > 0, "no ray of {shot} found the missing triangle");
}
