//! Numbers, rays, boxes and colours: the vocabulary every other part speaks.

pub mod bounds;
pub mod color;
pub mod distribution;
pub mod float;
pub mod ray;
