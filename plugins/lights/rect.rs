//! `rect`: a rectangular area light, for soft shadows: a point light spread uniformly over a
//! rectangle (as POV-Ray's `area_light`). Each sample takes a point of the rectangle and lights the
//! shaded point from there, with the point light's attenuation `I₀ / (kc + kl·d + kq·d²)`. It
//! shines to both sides. `phong` does not show lights to its rays; a path tracer's rays may meet
//! the rectangle ([`LightSource::intersect`]) and see the radiance its samples imply.

use super::point::{ATTENUATION, attenuation, samples};
use raylab::glam::{DVec2, DVec3};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::scene::light::LightBound;
use raylab::{Color, LightPdf, LightSample, LightSource, LoadContext, PluginInfo, Ray};

/// A rectangle `center + s·edge1 + t·edge2`, `s, t ∈ [−½, ½]`, of uniform intensity.
#[derive(Clone, Debug)]
pub struct RectLight {
    color: Color,
    corner: DVec3,
    edge1: DVec3,
    edge2: DVec3,
    /// Unit normal `edge1 × edge2 / area`.
    normal: DVec3,
    /// `1 / |edge1 × edge2|`: the samples' density per unit area, scene units⁻².
    per_area: f64,
    /// The dual basis of `edge1`, `edge2` in the plane, `edge2 × normal / area` and
    /// `normal × edge1 / area`: a point `corner + q` of the plane is at `q · dual.0` along
    /// `edge1` and `q · dual.1` along `edge2`.
    dual: (DVec3, DVec3),
    kc: f64,
    kl: f64,
    kq: f64,
    samples: u32,
}

/// The `rect` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "rect",
    summary: "A rectangular area light for soft shadows: a point light spread uniformly over a rectangle (both sides), sampled with `samples` shadow rays.",
    params: &[
        ParamSpec::new("color", ParamKind::Color, ParamDefault::Float(1.0), "intensity I₀ of the whole light, linear RGB"),
        ParamSpec::new("center", ParamKind::Vec3, ParamDefault::Required, "centre of the rectangle"),
        ParamSpec::new("edge1", ParamKind::Vec3, ParamDefault::Required, "first side, as a vector (its length is the side's length)"),
        ParamSpec::new("edge2", ParamKind::Vec3, ParamDefault::Required, "second side, as a vector, not parallel to edge1"),
        ATTENUATION[0],
        ATTENUATION[1],
        ATTENUATION[2],
        ParamSpec::new(
            "samples",
            ParamKind::Int,
            ParamDefault::Int(16),
            "shadow rays per shading point (the integrator's shadow_rays may override), ≥ 1",
        ),
    ],
};

/// Builds a rectangular light from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn LightSource>> {
    let color = p.color("color")?;
    let center = p.vec3("center")?;
    let (edge1, edge2) = (p.vec3("edge1")?, p.vec3("edge2")?);
    let area = edge1.cross(edge2).length();
    if !(area > 1e-12 * edge1.length_squared().max(edge2.length_squared())) {
        return Err(p.error_at("edge2", "edge1 and edge2 must be non-zero and not parallel (the rectangle has no area)"));
    }
    let (kc, kl, kq) = attenuation(p)?;
    let samples = samples(p)?;
    Ok(Box::new(RectLight::new(color, center, edge1, edge2, (kc, kl, kq), samples)))
}

impl RectLight {
    /// A rectangle centred at `center` with sides `edge1`, `edge2`, attenuation `(kc, kl, kq)`.
    pub fn new(color: Color, center: DVec3, edge1: DVec3, edge2: DVec3, (kc, kl, kq): (f64, f64, f64), samples: u32) -> Self {
        let cross = edge1.cross(edge2);
        let area = cross.length();
        let corner = center - 0.5 * (edge1 + edge2);
        let normal = cross / area;
        let dual = (edge2.cross(normal) / area, normal.cross(edge1) / area);
        RectLight { color, corner, edge1, edge2, normal, per_area: 1.0 / area, dual, kc, kl, kq, samples: samples.max(1) }
    }

    /// The sample from the point `d` away along unit `dir`.
    #[inline]
    fn sample(&self, dir: DVec3, d: f64) -> LightSample {
        let factor = 1.0 / (self.kc + self.kl * d + self.kq * d * d);
        LightSample { dir, distance: d, intensity: self.color * factor }
    }
}

impl LightSource for RectLight {
    #[inline]
    fn illuminate(&self, p: DVec3, u: DVec2) -> Option<LightSample> {
        let to_light = self.corner + u.x * self.edge1 + u.y * self.edge2 - p;
        let d = to_light.length();
        if !(d > 0.0) {
            return None;
        }
        Some(self.sample(to_light / d, d))
    }

    /// The rectangle's circumscribed ball; the intensity unattenuated beyond its nearest point.
    fn bound(&self, p: DVec3) -> Option<LightBound> {
        let centre = self.corner + 0.5 * (self.edge1 + self.edge2);
        let radius = 0.5 * (self.edge1 + self.edge2).length().max((self.edge1 - self.edge2).length());
        let d = ((centre - p).length() - radius).max(0.0);
        let attenuation = self.kc + self.kl * d + self.kq * d * d;
        Some(LightBound { centre, radius, intensity: self.color.abs() / attenuation })
    }

    /// Uniform over the rectangle.
    fn pdf(&self, _: DVec3, sample: &LightSample) -> LightPdf {
        LightPdf::from_area(self.per_area, sample.distance, sample.dir.dot(self.normal))
    }

    /// The rectangle, from either side.
    fn intersect(&self, ray: &Ray, t_max: f64) -> Option<LightSample> {
        let facing = ray.dir.dot(self.normal);
        let t = (self.corner - ray.origin).dot(self.normal) / facing;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        // Coordinates along the edges (the dual basis of edge1, edge2 in the plane).
        let q = ray.at(t) - self.corner;
        let (a, b) = (q.dot(self.dual.0), q.dot(self.dual.1));
        if !((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)) {
            return None;
        }
        Some(self.sample(ray.dir, t))
    }

    /// Its samples lie on the rectangle (`u` ∈ [0, 1]²), which [`LightSource::intersect`] meets.
    fn meets_its_samples(&self) -> bool {
        true
    }

    fn sample_count(&self) -> u32 {
        self.samples
    }

    fn is_area(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_cover_the_rectangle() {
        let l = RectLight::new(Color::ONE, DVec3::new(0.0, 5.0, 0.0), DVec3::X * 2.0, DVec3::Z, (1.0, 0.0, 0.0), 4);
        let p = DVec3::ZERO;
        let at = |u: DVec2| {
            let s = l.illuminate(p, u).unwrap();
            p + s.dir * s.distance
        };
        assert!((at(DVec2::ZERO) - DVec3::new(-1.0, 5.0, -0.5)).length() < 1e-12);
        assert!((at(DVec2::splat(0.5)) - DVec3::new(0.0, 5.0, 0.0)).length() < 1e-12);
        assert!((at(DVec2::new(1.0, 1.0)) - DVec3::new(1.0, 5.0, 0.5)).length() < 1e-12);
        assert!(l.is_area() && l.sample_count() == 4);
    }

    #[test]
    fn samples_rays_and_densities_agree() {
        // A parallelogram (edges not perpendicular), attenuated, seen from both sides and edge-on.
        let l = RectLight::new(
            Color::new(1.0, 0.5, 0.2),
            DVec3::new(0.3, 2.0, -0.1),
            DVec3::new(1.5, 0.2, 0.0),
            DVec3::new(0.3, 0.1, 1.0),
            (0.5, 0.1, 0.3),
            16,
        );
        for p in [DVec3::ZERO, DVec3::new(1.0, 4.0, 1.0), DVec3::new(3.0, 2.3, -0.1)] {
            raylab::scene::light::testing::check_light(&l, p, 64, 1500, 0.01);
        }
    }

    /// The directions of the samples follow the density `pdf` claims: a square seen head-on from
    /// close by, a parallelogram obliquely and nearly edge-on.
    #[test]
    fn sampling_passes_the_chi2_test() {
        use raylab::testing::chi2::{Chi2Test, Sphere};
        let test = Chi2Test::new(Sphere).res(72, 36).tests(3);
        let square = RectLight::new(Color::ONE, DVec3::new(0.0, 1.0, 0.0), DVec3::X * 2.0, DVec3::Z * 2.0, (1.0, 0.0, 0.0), 1);
        let slanted = RectLight::new(
            Color::ONE,
            DVec3::new(0.3, 1.0, -0.1),
            DVec3::new(1.5, 0.6, 0.0),
            DVec3::new(0.3, 0.1, 1.0),
            (1.0, 0.0, 0.0),
            1,
        );
        for (name, light, p) in [
            ("square", &square, DVec3::ZERO),
            ("parallelogram", &slanted, DVec3::new(-0.4, 0.2, 0.5)),
            ("edge-on", &slanted, DVec3::new(-1.6, 0.6, 0.0)),
        ] {
            raylab::scene::light::testing::chi2_light(light, p, &test).assert_passes(name);
        }
    }
}
