//! The properties every registered shape is held to, from its registration line alone: for each
//! shape sampler of the built-in registry, [`CASES`] random instances, each with a random ray aimed
//! at it whose every hit is checked against the shape's exact surface, three `t` windows, and a ray
//! leaving its bounds that must miss ([`raylab::geometry::samples::check_sample`]). The shapes'
//! own files add the properties only their geometry has (hit counts, exact distances, grazing rays).
//! A sphere whose hits are late by 10⁻⁶ of their distance fails both checks (the last test).

use crate::shapes::fuzz::samplers;
use crate::shapes::test_support::{CASES, config, fail};
use proptest::prelude::*;
use raylab::geometry::samples::{ShapeSampler, check_bytes, check_sample};
use raylab::glam::DVec3;
use raylab::math::sampler::mix64;
use raylab::{Aabb, Geometry, Hit, Intersectable, Ray};

proptest! {
    #![proptest_config(config(CASES))]

    #[test]
    fn every_registered_shape_keeps_every_contract(seed in any::<u64>()) {
        prop_assert!(!samplers().is_empty());
        for (i, sampler) in samplers().iter().enumerate() {
            check_sample(sampler, mix64(seed ^ i as u64)).map_err(fail)?;
        }
    }
}

/// A shape whose hits are reported 10⁻⁶ of their distance late, beyond its surface.
struct Late(Box<dyn Geometry>);

impl Intersectable for Late {
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let mut h = self.0.intersect(ray, t_min, t_max)?;
        h.t *= 1.0 + 1e-6;
        h.point = ray.at(h.t);
        Some(h)
    }
}

impl Geometry for Late {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        self.0.outward_normal(at)
    }
    fn bounds(&self) -> Option<Aabb> {
        self.0.bounds()
    }
}

/// The registered sphere's instances, with late hits.
const LATE_SPHERE: ShapeSampler = ShapeSampler {
    name: "late sphere",
    sample: |d, center, s| {
        let mut sample = (crate::shapes::sphere::SAMPLERS[0].sample)(d, center, s)?;
        sample.geometry = Box::new(Late(sample.geometry));
        Some(sample)
    },
};

#[test]
fn the_property_and_fuzz_checks_catch_a_shape_whose_hits_are_off_its_surface() {
    let failures: Vec<_> = (0..256).filter_map(|seed| check_sample(&LATE_SPHERE, seed).err()).collect();
    assert!(failures.len() > 128, "only {} of 256 cases failed", failures.len());
    assert!(failures[0].what.starts_with("late sphere (scale "), "{}", failures[0]);
    let fuzzed = (0..256u64)
        .filter(|&i| {
            let data: Vec<u8> = (0..160).map(|j| mix64(i << 8 | j) as u8).collect();
            check_bytes(&[LATE_SPHERE], &data).is_err()
        })
        .count();
    assert!(fuzzed > 64, "only {fuzzed} of 256 fuzz inputs failed");
}

/// Every built-in geometry but the mesh (tested by its own property and watertightness tests)
/// registers samplers, so the harnesses above check it: registering a new shape without them
/// fails here.
#[test]
fn every_built_in_shape_registers_its_samplers() {
    let registry = crate::registry();
    let unsampled: Vec<&str> = registry.unsampled_geometries().filter(|name| *name != "mesh").collect();
    assert!(unsampled.is_empty(), "registered without samplers (add_geometry_with_samples): {unsampled:?}");
}
