//! The report's shapes: plane, sphere, hemisphere (bowl), triangle, quadrangle, convex polygon,
//! finite capped cylinder and infinite tube.

pub mod cylinder;
pub mod exact;
pub mod fuzz;
pub mod hemisphere;
pub mod plane;
pub mod polygon;
pub mod sphere;
pub mod triangle;
pub mod uv;

#[cfg(test)]
mod reintersect;
#[cfg(test)]
mod sampling;
#[cfg(test)]
mod test_support;

use raylab::Registry;

/// Registers every shape.
pub fn register(r: &mut Registry) {
    r.add_geometry(plane::INFO, plane::build);
    r.add_geometry(sphere::INFO, sphere::build);
    r.add_geometry(hemisphere::INFO, hemisphere::build);
    r.add_geometry(triangle::INFO, triangle::build);
    r.add_geometry(polygon::QUADRANGLE_INFO, polygon::build_quadrangle);
    r.add_geometry(polygon::INFO, polygon::build);
    r.add_geometry(cylinder::INFO, cylinder::build);
    r.add_geometry(cylinder::TUBE_INFO, cylinder::build_tube);
}
