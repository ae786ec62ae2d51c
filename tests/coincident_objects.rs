//! Degenerate geometry across scene objects: identical spheres, by the million through the API
//! and by the hundred thousand through scene text, build a hierarchy of bounded depth (once a
//! stack overflow, an abort) that finds the same closest hit as the list.

use raylab::Intersectable;
use raylab::Ray;
use raylab::accel::{AccelChoice, ObjectAccel};
use raylab::geometry::Geometry;
use raylab::glam::DVec3;
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab_plugins::shapes::sphere::Sphere;
use std::path::Path;

/// A ray from z = −10 toward the unit sphere at the origin (hit at t = 9), and one beside it.
fn rays() -> [Ray; 2] {
    [Ray::new(DVec3::new(0.0, 0.0, -10.0), DVec3::Z), Ray::new(DVec3::new(0.0, 1.5, -10.0), DVec3::Z)]
}

#[test]
fn a_million_identical_spheres_index_in_every_mode() {
    let n = 1_000_000;
    let mut spheres: Vec<Box<dyn Geometry>> = (0..n).map(|_| Box::new(Sphere::new(DVec3::ZERO, 1.0)) as _).collect();
    // One smaller sphere in front of them, the only closest hit along the axis.
    spheres.push(Box::new(Sphere::new(DVec3::new(0.0, 0.0, -2.0), 0.5)));
    let boxes: Vec<_> = spheres.iter().map(|g| g.bounds()).collect();
    let (list, _) = ObjectAccel::build(&boxes, |_| true, AccelChoice::List);
    let list = list.over(&spheres);
    for choice in [AccelChoice::Auto, AccelChoice::Bvh] {
        let (built, _) = ObjectAccel::build(&boxes, |_| true, choice);
        let accel = built.over(&spheres);
        assert_eq!(built.is_bvh(), raylab::accel::build::BVH_AVAILABLE, "{choice:?}");
        let [axis, beside] = rays();
        let hit = accel.intersect(&axis, 0.0, f64::INFINITY).expect("the front sphere");
        assert_eq!((hit.object, hit.t), (n, 7.5), "{choice:?}");
        assert!(accel.intersect(&beside, 0.0, f64::INFINITY).is_none(), "{choice:?}");
        // Off-axis, through the identical spheres only: the list's distance.
        let ray = Ray::new(DVec3::new(0.7, 0.0, -10.0), DVec3::Z);
        let (a, b) = (accel.intersect(&ray, 0.0, f64::INFINITY), list.intersect(&ray, 0.0, f64::INFINITY));
        assert_eq!(a.map(|h| h.t), b.map(|h| h.t), "{choice:?}");
        assert!(a.is_some_and(|h| h.object < n), "{choice:?}");
        assert!(accel.occludes(&ray, 0.0, f64::INFINITY), "{choice:?}");
    }
}

#[test]
fn a_scene_of_identical_spheres_loads_and_renders_the_same_hits() {
    let n = 100_000;
    let mut text = String::from("[camera]\nposition = [0, 0, -10]\nlook_at = [0, 0, 0]\n");
    for _ in 0..n {
        text.push_str("[[object]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n");
    }
    let registry = raylab_plugins::registry();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let load = |accel| load_str(&registry, "spheres.toml", &text, dir, &LoadOptions { accel, ..LoadOptions::default() }).unwrap();
    let list = load(AccelChoice::List);
    for choice in [AccelChoice::Auto, AccelChoice::Bvh] {
        let job = load(choice);
        assert_eq!(job.scene.accel_summary().bvh, raylab::accel::build::BVH_AVAILABLE, "{choice:?}");
        for ray in rays() {
            let (a, b) = (job.scene.intersect(&ray, 0.0, f64::INFINITY), list.scene.intersect(&ray, 0.0, f64::INFINITY));
            assert_eq!(a.map(|h| h.t), b.map(|h| h.t), "{choice:?} {ray:?}");
        }
        assert_eq!(job.scene.intersect(&rays()[0], 0.0, f64::INFINITY).map(|h| h.t), Some(9.0));
    }
}
