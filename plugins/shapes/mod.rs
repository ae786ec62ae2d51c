//! The report's shapes: plane, sphere, hemisphere (bowl), triangle, quadrangle, convex polygon,
//! finite capped cylinder and infinite tube.

/// The two `*_leaving` queries of [`raylab::geometry::Intersectable`] for a flat shape (plane,
/// polygon, triangle), inside its `impl`: a ray leaving its plane, on either side, never meets
/// it again at `t > 0`, so there is nothing to test (`intersect` and `occludes` would find nothing).
macro_rules! flat_leaving {
    () => {
        /// A ray leaving the flat shape, on either side, does not meet it again.
        #[inline]
        fn occludes_leaving(&self, _: &raylab::Ray, _: f64, _: f64, _: u32) -> bool {
            false
        }
        /// As `occludes_leaving`: nothing to find on the primitive the ray leaves.
        #[inline]
        fn intersect_leaving(&self, _: &raylab::Ray, _: f64, _: f64, _: u32) -> Option<raylab::geometry::Hit> {
            None
        }
    };
}

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
