//! Images: the film a render accumulates into, the formats it is written in, reference images
//! and the error metrics that compare two images.

#[cfg(feature = "exr")]
pub mod exr;
pub mod film;
pub mod layers;
pub mod metrics;
pub mod output;
#[cfg(feature = "exr")]
pub mod partial;
pub mod reference;
pub mod write;
