//! Criterion benchmarks: whole frames of the bundled scenes, and single-ray intersection per shape.
//! Run: `cargo bench --bench render` (compare runs made in one session; machines are noisy).

use criterion::{Criterion, criterion_group, criterion_main};
use raylab::glam::DVec3;
use raylab::load::context::{LoadOptions, Overrides};
use raylab::{Intersectable, Ray};
use std::hint::black_box;
use std::path::Path;

fn frames(c: &mut Criterion) {
    let registry = raylab_plugins::registry();
    let mut g = c.benchmark_group("frame 200x150 1spp");
    g.sample_size(20);
    for scene in ["dozen", "showcase", "report-reflection-refraction"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{scene}.toml"));
        let opts = LoadOptions { overrides: Overrides { width: Some(200), height: Some(150), ..Default::default() }, ..Default::default() };
        let job = raylab::load::loader::load_file(&registry, &path, &opts).expect("scene loads");
        g.bench_function(scene, |b| b.iter(|| raylab::render::render(&job, &Default::default(), &|_, _| {}).unwrap()));
    }
    g.finish();
}

fn intersections(c: &mut Criterion) {
    use raylab_plugins::shapes::{cylinder::Cylinder, plane::Plane, sphere::Sphere, triangle::Triangle};
    let shapes: Vec<(&str, Box<dyn Intersectable>)> = vec![
        ("sphere", Box::new(Sphere::new(DVec3::ZERO, 1.0))),
        ("plane", Box::new(Plane::new(DVec3::ZERO, DVec3::Z))),
        ("triangle", Box::new(Triangle::new(DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, -1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)).unwrap())),
        ("cylinder", Box::new(Cylinder::new(DVec3::new(0.0, -1.0, 0.0), DVec3::Y, 1.0, Some(2.0)))),
    ];
    // 1024 rays from z = 5 toward a 3×3 square at z = 0: about half hit each shape.
    let rays: Vec<Ray> = (0..1024)
        .map(|i| {
            let (x, y) = ((i % 32) as f64 / 31.0 * 3.0 - 1.5, (i / 32) as f64 / 31.0 * 3.0 - 1.5);
            Ray::new(DVec3::new(0.1, 0.2, 5.0), DVec3::new(x, y, 0.0) - DVec3::new(0.1, 0.2, 5.0))
        })
        .collect();
    let mut g = c.benchmark_group("intersect 1024 rays");
    for (name, shape) in &shapes {
        g.bench_function(*name, |b| b.iter(|| rays.iter().filter(|r| shape.intersect(black_box(r), 0.0, f64::INFINITY).is_some()).count()));
    }
    g.finish();
}

criterion_group!(benches, frames, intersections);
criterion_main!(benches);
