//! The report's shapes: plane, sphere, hemisphere (bowl), triangle, quadrangle, convex polygon,
//! finite capped cylinder and infinite tube.

pub mod cylinder;
pub mod fuzz;
pub mod hemisphere;
pub mod plane;
pub mod polygon;
pub mod sphere;
pub mod triangle;
pub mod uv;

#[cfg(test)]
mod properties;
#[cfg(test)]
mod reintersect;
#[cfg(test)]
mod sampling;
#[cfg(test)]
mod test_support;

use raylab::Registry;

/// Registers every shape.
pub fn register(r: &mut Registry) {
    r.add_geometry_with_samples(plane::INFO, plane::build, plane::SAMPLERS);
    r.add_geometry_with_samples(sphere::INFO, sphere::build, sphere::SAMPLERS);
    r.add_geometry_with_samples(hemisphere::INFO, hemisphere::build, hemisphere::SAMPLERS);
    r.add_geometry_with_samples(triangle::INFO, triangle::build, triangle::SAMPLERS);
    r.add_geometry_with_samples(polygon::QUADRANGLE_INFO, polygon::build_quadrangle, polygon::QUADRANGLE_SAMPLERS);
    r.add_geometry_with_samples(polygon::INFO, polygon::build, polygon::SAMPLERS);
    r.add_geometry_with_samples(cylinder::INFO, cylinder::build, cylinder::SAMPLERS);
    r.add_geometry_with_samples(cylinder::TUBE_INFO, cylinder::build_tube, cylinder::TUBE_SAMPLERS);
}
