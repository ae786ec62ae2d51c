//! The report's lights: ambient, directional, point and spot; and a rectangular area light.

pub mod ambient;
pub mod directional;
pub mod point;
pub mod rect;

use raylab::Registry;

/// Registers every light.
pub fn register(r: &mut Registry) {
    r.add_light(ambient::INFO, ambient::build);
    r.add_light(directional::INFO, directional::build);
    r.add_light(point::INFO, point::build);
    r.add_light(point::SPOT_INFO, point::build_spot);
    r.add_light(rect::INFO, rect::build);
}
