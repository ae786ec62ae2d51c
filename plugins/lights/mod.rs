//! The report's lights: ambient, directional, point and spot; a rectangular area light; and the
//! environment (the scene's surroundings).

pub mod ambient;
pub mod directional;
pub mod environment;
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
    r.add_light(environment::INFO, environment::build);
}

#[cfg(test)]
mod tests {
    use super::*;
    use raylab::glam::{DVec2, DVec3};
    use raylab::{Color, LightSource};

    /// `illuminates` is false exactly for the lights whose `illuminate` gives no sample anywhere
    /// (integrators skip those when they gather direct light).
    #[test]
    fn illuminates_says_whether_samples_come() {
        let lights: Vec<Box<dyn LightSource>> = vec![
            Box::new(ambient::Ambient::new(Color::ONE, 0.1)),
            Box::new(directional::Directional::new(Color::ONE, DVec3::new(0.3, -1.0, 0.2))),
            Box::new(point::PointLight::new(Color::ONE, DVec3::new(0.0, 4.0, 0.0), 1.0, 0.0, 0.0)),
            Box::new(point::PointLight::new(Color::ONE, DVec3::new(0.0, 4.0, 0.0), 1.0, 0.0, 0.0).with_radius(0.5, 4)),
            Box::new(rect::RectLight::new(Color::ONE, DVec3::new(0.0, 4.0, 0.0), DVec3::X, DVec3::Z, (1.0, 0.0, 0.0), 4)),
        ];
        let points = [DVec3::ZERO, DVec3::new(2.5, -1.0, 7.0), DVec3::new(-30.0, 3.9, 0.1)];
        for (i, light) in lights.iter().enumerate() {
            for p in points {
                for u in [DVec2::ZERO, DVec2::new(0.3, 0.8), DVec2::ONE] {
                    assert_eq!(light.illuminate(p, u).is_some(), light.illuminates(), "light {i} at {p}, u = {u}");
                }
            }
        }
    }
}
