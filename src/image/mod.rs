//! Images: the formats a film is written in, reference images, the error metrics that compare
//! two images, and live display in the tev viewer.

pub mod denoise;
#[cfg(feature = "exr")]
pub mod exr;
pub mod metrics;
pub mod output;
#[cfg(feature = "exr")]
pub mod partial;
pub mod reference;
pub mod tev;
pub mod tonemap;
pub mod write;
