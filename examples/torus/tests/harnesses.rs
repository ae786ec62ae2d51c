//! The torus put through raylab's shape harnesses ([`raylab::geometry::samples`]) from its
//! registration line alone, as the built-in shapes are: the property check over random instances
//! and rays, and the `intersect` fuzz target's check over random bytes. (Its form is not convex,
//! so the reintersection campaign makes no claim; `tests/torus.rs` checks its secondary rays.)

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use raylab::Registry;
use raylab::geometry::samples::{ShapeSampler, check_bytes, check_sample};

/// The shape samplers this crate registers (not the built-in ones).
fn samplers() -> Vec<ShapeSampler> {
    let mut r = Registry::new();
    raylab_torus::register(&mut r);
    r.shape_samplers()
}

fn config(name: &str) -> ProptestConfig {
    ProptestConfig {
        cases: 8192,
        failure_persistence: None,
        rng_seed: RngSeed::Fixed(raylab::testing::seed(name)),
        ..ProptestConfig::default()
    }
}

#[test]
fn the_torus_registers_its_sampler() {
    let names: Vec<&str> = samplers().iter().map(|s| s.name).collect();
    assert_eq!(names, ["torus"]);
}

proptest! {
    #![proptest_config(config("torus harnesses"))]

    #[test]
    fn every_shape_of_the_crate_keeps_every_contract(seed in any::<u64>()) {
        for sampler in samplers() {
            check_sample(&sampler, seed).map_err(|v| TestCaseError::fail(v.to_string()))?;
        }
    }

    #[test]
    fn arbitrary_rays_on_arbitrary_shapes_of_the_crate_keep_every_contract(data in prop::collection::vec(any::<u8>(), 0..160)) {
        check_bytes(&samplers(), &data).map_err(|v| TestCaseError::fail(v.to_string()))?;
    }
}
