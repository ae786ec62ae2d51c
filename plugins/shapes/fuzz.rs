//! Arbitrary bytes → a registered shape and a few rays, each checked against the shape's exact
//! surface: the body of the `intersect` fuzz target (`fuzz/fuzz_targets/intersect.rs`), also run
//! over its checked-in corpus by `tests/fuzz_corpus.rs`. The decoding and the checks are
//! [`raylab::geometry::samples::check_bytes`], over every shape sampler the built-in registry
//! holds ([`crate::registry`]), in registration order: a shape registered with
//! [`raylab::Registry::add_geometry_with_samples`] is fuzzed from that line.

use raylab::geometry::samples::ShapeSampler;
use raylab::geometry::testing::Violation;
use std::sync::OnceLock;

/// The shape samplers of the built-in registry, in registration order.
pub fn samplers() -> &'static [ShapeSampler] {
    static SAMPLERS: OnceLock<Vec<ShapeSampler>> = OnceLock::new();
    SAMPLERS.get_or_init(|| crate::registry().shape_samplers())
}

/// Decodes `data` into a shape and up to four rays and checks every hit of every ray
/// ([`raylab::geometry::samples::check_bytes`]). Inputs that decode to a shape the loader would
/// refuse pass trivially.
pub fn check_bytes(data: &[u8]) -> Result<(), Violation> {
    raylab::geometry::samples::check_bytes(samplers(), data).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::test_support::{CASES, config};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(config(CASES))]

        /// The fuzz target's check, over random inputs with the shapes' fixed seed.
        #[test]
        fn arbitrary_rays_on_arbitrary_shapes_keep_every_contract(data in prop::collection::vec(any::<u8>(), 0..160)) {
            check_bytes(&data).map_err(crate::shapes::test_support::fail)?;
        }
    }
}
