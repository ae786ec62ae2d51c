//! `oren_nayar`: a rough diffuse material (Oren and Nayar 1994, the qualitative model pbrt
//! uses), the example material of docs/writing-a-plugin.md. A material plugin answers what
//! integrators ask: its Phong coefficients (for `phong`: the Lambertian `kd = albedo`), and the
//! BSDF at a hit for the path tracer:
//!
//! ```text
//! f = albedo/π · (A + B · max(0, cos(φi − φo)) · sin α · tan β),
//! A = 1 − σ²/(2(σ² + 0.33)),  B = 0.45 σ²/(σ² + 0.09),  α = max(θi, θo), β = min(θi, θo)
//! ```
//!
//! with σ the standard deviation of the facets' slope angle (`sigma`, degrees). σ = 0 is
//! Lambert's. Directions are sampled cosine-weighted (the χ² test in this crate's tests checks
//! the sampling against the density, with raylab's `chi2_bsdf`).

use raylab::glam::{DVec2, DVec3};
use raylab::math::sampler::{concentric_disc, orthonormal_basis};
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::scene::bsdf::{Bsdf, Lobe, MaterialModel, Scatter, Shading};
use raylab::scene::material::Model;
use raylab::scene::texture::TextureResolver;
use raylab::{Color, Material, PluginInfo, RayKind};
use std::f64::consts::FRAC_1_PI;
use std::sync::Arc;

/// The `oren_nayar` material's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "oren_nayar",
    summary: "Rough diffuse (Oren–Nayar): clay, concrete, the Moon, which stay bright toward their rims where Lambert darkens. phong sees it as kd = albedo.",
    params: &[
        ParamSpec::new("albedo", ParamKind::Color, ParamDefault::Float(0.8), "the reflectance, linear RGB in [0, 1]"),
        ParamSpec::new(
            "sigma",
            ParamKind::Float,
            ParamDefault::Float(20.0),
            "standard deviation of the facets' slope, degrees, 0..90 (0: Lambert)",
        ),
    ],
};

/// Builds an `oren_nayar` material.
pub fn build(p: &mut Params, _: &dyn TextureResolver) -> Result<Material> {
    let albedo = p.color("albedo")?;
    if albedo.max_element() > 1.0 {
        return Err(p.error_at("albedo", "expected a reflectance in [0, 1]"));
    }
    let sigma = p.float_in("sigma", 0.0..=90.0)?.to_radians();
    let s2 = sigma * sigma;
    let model = OrenNayar { albedo, a: 1.0 - s2 / (2.0 * (s2 + 0.33)), b: 0.45 * s2 / (s2 + 0.09) };
    Ok(Material { kd: albedo, model: Some(Model(Arc::new(model))), ..Material::default() })
}

/// The model: the albedo and the two constants of σ.
#[derive(Clone, Copy, Debug)]
pub struct OrenNayar {
    /// Reflectance.
    pub albedo: Color,
    /// `A` of σ.
    pub a: f64,
    /// `B` of σ.
    pub b: f64,
}

impl MaterialModel for OrenNayar {
    fn bsdf(&self, at: &dyn Shading, f: &mut dyn FnMut(&dyn Bsdf)) {
        f(&OrenNayarBsdf::new(*self, at.wo(), at.n(), at.ns()))
    }
}

/// The BSDF at one hit.
#[derive(Clone, Copy, Debug)]
pub struct OrenNayarBsdf {
    m: OrenNayar,
    /// Geometric and shading normals facing the viewer, and tangents of the shading frame.
    n: DVec3,
    frame: [DVec3; 3],
    /// The viewer's direction in the shading frame.
    wo: DVec3,
}

impl OrenNayarBsdf {
    /// The BSDF seen from unit `wo`, geometric normal `n` and shading normal `ns` facing it.
    pub fn new(m: OrenNayar, wo: DVec3, n: DVec3, ns: DVec3) -> Self {
        let (t, b) = orthonormal_basis(ns);
        OrenNayarBsdf { m, n, frame: [t, b, ns], wo: DVec3::new(wo.dot(t), wo.dot(b), wo.dot(ns)) }
    }

    fn local(&self, d: DVec3) -> DVec3 {
        DVec3::new(d.dot(self.frame[0]), d.dot(self.frame[1]), d.dot(self.frame[2]))
    }

    /// `f` for a local `wi` above the surface.
    fn f(&self, wi: DVec3) -> Color {
        let (wo, m) = (self.wo, self.m);
        let sin_i = (1.0 - wi.z * wi.z).max(0.0).sqrt();
        let sin_o = (1.0 - wo.z * wo.z).max(0.0).sqrt();
        // cos(φi − φo), from the directions' projections onto the surface.
        let cos_dphi = if sin_i > 1e-9 && sin_o > 1e-9 { ((wi.x * wo.x + wi.y * wo.y) / (sin_i * sin_o)).max(0.0) } else { 0.0 };
        // sin α · tan β, with α the larger polar angle (smaller cosine).
        let (sin_a, tan_b) = if wi.z.abs() > wo.z.abs() { (sin_o, sin_i / wi.z.abs()) } else { (sin_i, sin_o / wo.z.abs().max(1e-12)) };
        m.albedo * FRAC_1_PI * (m.a + m.b * cos_dphi * sin_a * tan_b)
    }
}

impl Bsdf for OrenNayarBsdf {
    fn eval(&self, wi: DVec3) -> Color {
        if !(self.n.dot(wi) > 0.0 && self.frame[2].dot(wi) > 0.0 && self.wo.z > 0.0) {
            return Color::ZERO;
        }
        self.f(self.local(wi))
    }

    fn pdf(&self, wi: DVec3) -> f64 {
        let c = self.frame[2].dot(wi);
        if self.n.dot(wi) > 0.0 && c > 0.0 { c * FRAC_1_PI } else { 0.0 }
    }

    fn sample(&self, _pick: f64, u: DVec2, _fresnel: f64) -> Option<Scatter> {
        let d = concentric_disc(u);
        let z = (1.0 - d.length_squared()).max(0.0).sqrt();
        let dir = d.x * self.frame[0] + d.y * self.frame[1] + z * self.frame[2];
        let pdf = self.pdf(dir);
        let f = self.eval(dir);
        if !(pdf > 0.0) || f.max_element() <= 0.0 {
            return None;
        }
        Some(Scatter {
            dir,
            weight: f * self.frame[2].dot(dir) / pdf,
            pdf: Some(pdf),
            lobe: Lobe::Diffuse,
            kind: RayKind::Reflection,
            eta_squared: 1.0,
        })
    }

    fn has_smooth_lobes(&self) -> bool {
        true
    }

    fn albedo(&self) -> Color {
        self.m.albedo
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raylab::scene::bsdf::testing::{chi2_bsdf, quadrature_albedo, sampled_albedo};
    use raylab::testing::chi2::{Chi2Test, Sphere};

    fn model(sigma_deg: f64) -> OrenNayar {
        let s2 = sigma_deg.to_radians().powi(2);
        OrenNayar { albedo: Color::ONE, a: 1.0 - s2 / (2.0 * (s2 + 0.33)), b: 0.45 * s2 / (s2 + 0.09) }
    }

    #[test]
    fn sampling_follows_the_density_and_energy_is_kept() {
        for sigma in [0.0, 20.0, 60.0] {
            for theta in [0.1f64, 0.8, 1.4] {
                let wo = DVec3::new(theta.sin(), 0.0, theta.cos());
                let b = OrenNayarBsdf::new(model(sigma), wo, DVec3::Z, DVec3::Z);
                let test = Chi2Test::new(Sphere).samples(100_000).res(32, 16).tests(9);
                chi2_bsdf(&b, DVec3::Z, &test).assert_passes(&format!("σ {sigma}, θ {theta}"));
                let (e, err) = sampled_albedo(&b, 100_000, 2);
                let q = quadrature_albedo(&b, DVec3::Z, 400);
                assert!((e - q).abs().max_element() < 4.0 * err + 2e-3, "{e} vs {q}");
                assert!(e.max_element() <= 1.0 + 4.0 * err, "σ {sigma}: reflects {e}");
            }
        }
    }

    #[test]
    fn sigma_zero_is_lambert_and_the_model_is_reciprocal() {
        let wo = DVec3::new(0.6, 0.0, 0.8);
        let b = OrenNayarBsdf::new(model(0.0), wo, DVec3::Z, DVec3::Z);
        assert!((b.eval(DVec3::new(0.0, 0.6, 0.8)) - Color::splat(FRAC_1_PI)).abs().max_element() < 1e-15);
        let (a, c) = (DVec3::new(0.3, 0.2, 0.93).normalize(), DVec3::new(-0.5, 0.4, 0.3).normalize());
        let m = model(30.0);
        let ac = OrenNayarBsdf::new(m, a, DVec3::Z, DVec3::Z).eval(c);
        let ca = OrenNayarBsdf::new(m, c, DVec3::Z, DVec3::Z).eval(a);
        assert!((ac - ca).abs().max_element() < 1e-12, "{ac} vs {ca}");
    }
}
