//! Numbers, rays, boxes, colours and deterministic sampling: the vocabulary every other part
//! speaks.

pub mod bounds;
pub mod color;
pub mod distribution;
pub mod float;
pub mod ray;
pub mod sampler;
