//! The properties every registered shape is held to, from its registration line alone: for each
//! shape sampler of the built-in registry, [`CASES`] random instances, each with a random ray aimed
//! at it whose every hit is checked against the shape's exact surface, three `t` windows, and a ray
//! leaving its bounds that must miss ([`raylab::geometry::samples::check_sample`]). The shapes'
//! own files add the properties only their geometry has (hit counts, exact distances, grazing rays).

use crate::shapes::fuzz::samplers;
use crate::shapes::test_support::{CASES, config, fail};
use proptest::prelude::*;
use raylab::geometry::samples::check_sample;
use raylab::math::sampler::mix64;

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
