//! Images: the film a render accumulates into, the formats it is written in, reference images
//! the error metrics that compare two images, and live display in the tev viewer.

pub mod denoise;
#[cfg(feature = "exr")]
pub mod exr;
pub mod film;
pub mod layers;
pub mod metrics;
pub mod output;
#[cfg(feature = "exr")]
pub mod partial;
pub mod reference;
pub mod tev;
pub mod tonemap;
pub mod write;
