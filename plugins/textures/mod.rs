//! Textures: the classic procedural patterns ([`patterns`]: checker, stripes, gradient, ring) and
//! image files ([`image`]), registered by name for `[textures.NAME]` tables and inline textures.

pub mod fuzz;
pub mod image;
pub mod patterns;

use raylab::Registry;

/// Registers every texture type.
pub fn register(r: &mut Registry) {
    r.add_texture(patterns::CHECKER_INFO, patterns::build_checker);
    r.add_texture(patterns::STRIPES_INFO, patterns::build_stripes);
    r.add_texture(patterns::GRADIENT_INFO, patterns::build_gradient);
    r.add_texture(patterns::RING_INFO, patterns::build_ring);
    r.add_texture(image::INFO, image::build);
}
