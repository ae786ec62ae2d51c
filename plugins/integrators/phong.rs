//! `phong`: the report's recursive Phong/Whitted model.
//!
//! At each hit, with `n` the normal facing the viewer, `v` the ray direction and, per light,
//! `l` the direction to the light and `r` the reflection of the light's ray about `n`:
//!
//! ```text
//! I = emission + ka·ambient
//!   + Σ_lights (kd·(n·l) + ks·max(0, −v·r)^shininess) · I_L · shadow
//!   + kr · I(reflected) + kt · I(refracted)
//! ```
//!
//! A light counts only from the viewer's side of the surface (`n·l > 0` with `n` facing the
//! viewer), so no light shines through an opaque wall. `shadow` is the product of the `kt` of
//! the surfaces between the point and the light. Refraction follows Snell's law at closed solids
//! (with total internal reflection); open surfaces transmit as thin sheets. Recursion stops at
//! `max_depth` or when a ray's accumulated weight (product of coefficients) falls below
//! `prune_threshold`. With `blur > 0` a material spreads `glossy_rays` jittered rays in a disc
//! around the ideal direction (the report's stage-D blurring).

use raylab::color::max_channel;
use raylab::error::Result;
use raylab::geometry::Hit;
use raylab::glam::DVec3;
use raylab::params::{Default, ParamKind, ParamSpec, Params};
use raylab::sampler::{concentric_disc, stratified_2d};
use raylab::trace::{TraceHit, TraceLight};
use raylab::{Color, Integrator, LoadContext, PluginInfo, Ray, RayKind, RayStats, Sampler, Scene, TraceNode};

/// The recursive Phong integrator.
#[derive(Clone, Debug)]
pub struct Phong {
    /// Most reflection/refraction bounces along a path (0 = direct light only).
    pub max_depth: u32,
    /// A secondary ray, or a light sample, whose weight in the pixel is below this is skipped.
    pub prune_threshold: f64,
    /// Rays per glossy reflection or blurry refraction (materials with `blur > 0`).
    pub glossy_rays: u32,
}

/// The `phong` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "phong",
    summary: "The report's recursive Phong model: emission, ambient, diffuse and specular per light with shadows (attenuated by transparent occluders), mirror reflection and Snell refraction with total internal reflection, glossy/blurry rays, recursion pruning.",
    params: &[
        ParamSpec::new(
            "max_depth",
            ParamKind::Int,
            Default::Int(3),
            "most reflection/refraction bounces along a path (the report: 3), ≥ 0",
        ),
        ParamSpec::new(
            "prune_threshold",
            ParamKind::Float,
            Default::Float(0.001),
            "skip rays and light samples whose weight in the pixel is below this (0 = never), 0..1",
        ),
        ParamSpec::new(
            "glossy_rays",
            ParamKind::Int,
            Default::Int(16),
            "rays per glossy reflection / blurry refraction (materials with blur > 0), ≥ 1",
        ),
    ],
};

/// Builds the integrator from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Phong {
        max_depth: p.int_in("max_depth", 0..=1024)? as u32,
        prune_threshold: p.float_in("prune_threshold", 0.0..=1.0)?,
        glossy_rays: p.int_in("glossy_rays", 1..=65536)? as u32,
    }))
}

impl std::default::Default for Phong {
    fn default() -> Self {
        Phong { max_depth: 3, prune_threshold: 0.001, glossy_rays: 16 }
    }
}

/// Mirror reflection of direction `d` about unit normal `n`: `d − 2(d·n)n`.
#[inline]
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit direction `d` through a surface with unit normal `n` facing against `d`,
/// with `eta` = n_incident / n_transmitted. `None` on total internal reflection.
#[inline]
pub fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -n.dot(d);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((eta * d + (eta * cos_i - cos_t) * n).normalize())
}

/// An orthonormal pair perpendicular to unit `w` (Duff et al. 2017).
#[inline]
fn basis(w: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(w.z);
    let a = -1.0 / (sign + w.z);
    let b = w.x * w.y * a;
    (DVec3::new(1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x), DVec3::new(b, sign + w.y * w.y * a, -w.y))
}

struct Ctx<'a> {
    scene: &'a Scene,
    sampler: &'a mut Sampler,
    stats: &'a mut RayStats,
}

impl Phong {
    /// Radiance along `ray` with accumulated `weight`; records into `node` when explaining.
    fn li(&self, c: &mut Ctx, ray: &Ray, depth: u32, weight: Color, mut node: Option<&mut TraceNode>) -> Color {
        let scene = c.scene;
        let Some(hit) = scene.intersect(ray, 0.0, f64::INFINITY) else {
            if let Some(nd) = node {
                nd.color = scene.background;
            }
            return scene.background;
        };
        let g = &scene.geometries[hit.object as usize];
        let m = g.material();
        let n = g.normal(&hit, ray.dir);
        let outward = g.outward_normal(&hit);
        let front = outward.dot(ray.dir) < 0.0;
        let ambient = m.ka * scene.ambient;
        let mut color = m.emission + ambient;
        if let Some(nd) = node.as_deref_mut() {
            nd.hit = Some(TraceHit::new(scene, &hit, ray.dir));
            nd.emission = m.emission;
            nd.ambient = ambient;
        }

        color += self.direct(c, ray, &hit, n, weight, node.as_deref_mut());

        let secondary = m.is_reflective() || m.is_transmissive();
        if secondary && depth >= self.max_depth {
            c.stats.depth_limited += u64::from(m.is_reflective()) + u64::from(m.is_transmissive());
            if let Some(nd) = node.as_deref_mut() {
                nd.notes.push(format!("max depth {} reached: no reflection/refraction rays", self.max_depth));
            }
        } else if secondary {
            if m.is_reflective() {
                let w = weight * m.kr;
                if max_channel(w) < self.prune_threshold {
                    c.stats.pruned_rays += 1;
                    if let Some(nd) = node.as_deref_mut() {
                        nd.notes.push(format!("reflection pruned: weight {:.3e} < threshold {}", max_channel(w), self.prune_threshold));
                    }
                } else {
                    let ideal = reflect(ray.dir, n);
                    color += m.kr * self.spread(c, &hit, n, ideal, n, m.blur, RayKind::Reflection, depth, w, node.as_deref_mut());
                }
            }
            if m.is_transmissive() {
                let w = weight * m.kt;
                if max_channel(w) < self.prune_threshold {
                    c.stats.pruned_rays += 1;
                    if let Some(nd) = node.as_deref_mut() {
                        nd.notes.push(format!("refraction pruned: weight {:.3e} < threshold {}", max_channel(w), self.prune_threshold));
                    }
                } else {
                    let (dir, side) = if g.is_closed() {
                        let eta = if front { 1.0 / m.ior } else { m.ior };
                        match refract(ray.dir, n, eta) {
                            Some(t) => (t, -n),
                            None => {
                                if let Some(nd) = node.as_deref_mut() {
                                    nd.notes.push("total internal reflection: the transmitted ray reflects".into());
                                }
                                (reflect(ray.dir, n), n)
                            }
                        }
                    } else {
                        (ray.dir, -n)
                    };
                    color += m.kt * self.spread(c, &hit, n, dir, side, m.blur, RayKind::Refraction, depth, w, node.as_deref_mut());
                }
            }
        }
        if let Some(nd) = node {
            nd.color = color;
        }
        color
    }

    /// Direct light at `hit`: diffuse and specular from every light, shadowed.
    fn direct(&self, c: &mut Ctx, ray: &Ray, hit: &Hit, n: DVec3, weight: Color, mut node: Option<&mut TraceNode>) -> Color {
        let scene = c.scene;
        let m = scene.geometries[hit.object as usize].material();
        let mut sum = Color::ZERO;
        if max_channel(m.kd) <= 0.0 && max_channel(m.ks) <= 0.0 {
            return sum;
        }
        for (li, light) in scene.lights.iter().enumerate() {
            let count = light.sample_count().max(1);
            let pattern = if count > 1 { c.sampler.next_pattern() } else { 0 };
            for s in 0..count {
                let u = if count > 1 { stratified_2d(s, count, pattern) } else { c.sampler.next_2d() };
                let Some(ls) = light.illuminate(hit.point, u) else { continue };
                let name = || scene.light_names[li].clone();
                let nl = n.dot(ls.dir);
                let mut rec = node.as_deref_mut().map(|_| TraceLight {
                    light: name(),
                    dir: ls.dir,
                    distance: ls.distance,
                    intensity: ls.intensity,
                    n_dot_l: nl,
                    transmittance: Color::ZERO,
                    occluder: None,
                    diffuse: Color::ZERO,
                    specular: Color::ZERO,
                    skipped: None,
                });
                if nl <= 0.0 {
                    c.stats.lights_behind += 1;
                    if let (Some(nd), Some(mut r)) = (node.as_deref_mut(), rec.take()) {
                        r.skipped = Some("the light is behind the surface as seen from the ray".into());
                        nd.lights.push(r);
                    }
                    continue;
                }
                let r = reflect(-ls.dir, n);
                let vr = -ray.dir.dot(r);
                let spec = if vr > 0.0 && max_channel(m.ks) > 0.0 { vr.powf(m.shininess) } else { 0.0 };
                let scale = ls.intensity / f64::from(count);
                let diffuse = m.kd * nl * scale;
                let specular = m.ks * spec * scale;
                let unshadowed = diffuse + specular;
                if max_channel(unshadowed * weight) < self.prune_threshold || max_channel(unshadowed) <= 0.0 {
                    c.stats.lights_negligible += 1;
                    if let (Some(nd), Some(mut r)) = (node.as_deref_mut(), rec.take()) {
                        r.skipped = Some(format!("contribution {:.3e} below the pruning threshold", max_channel(unshadowed * weight)));
                        nd.lights.push(r);
                    }
                    continue;
                }
                c.stats.shadow_rays += 1;
                let (shadow_ray, t_max) = hit.spawn_shadow_ray(n, ls.dir, ls.distance);
                let tr = match (node.as_deref_mut(), rec.as_mut()) {
                    (Some(_), Some(r)) => {
                        let (tr, occ) = scene.transmittance_and_occluder(&shadow_ray, t_max);
                        r.transmittance = tr;
                        r.occluder = occ.map(|o| scene.object_name(o).to_string());
                        tr
                    }
                    _ => scene.transmittance(&shadow_ray, t_max),
                };
                sum += unshadowed * tr;
                if let (Some(nd), Some(mut r)) = (node.as_deref_mut(), rec) {
                    r.diffuse = diffuse * tr;
                    r.specular = specular * tr;
                    nd.lights.push(r);
                }
            }
        }
        sum
    }

    /// Traces the child ray(s) around `ideal`: one ray, or `glossy_rays` jittered in a disc of
    /// radius `blur`, each flipped onto the `side` hemisphere if jitter pushed it through the
    /// surface. Returns their mean radiance.
    #[allow(clippy::too_many_arguments)]
    fn spread(
        &self,
        c: &mut Ctx,
        hit: &Hit,
        n: DVec3,
        ideal: DVec3,
        side: DVec3,
        blur: f64,
        kind: RayKind,
        depth: u32,
        weight: Color,
        mut node: Option<&mut TraceNode>,
    ) -> Color {
        let count = if blur > 0.0 { self.glossy_rays } else { 1 };
        let pattern = if count > 1 { c.sampler.next_pattern() } else { 0 };
        let (b1, b2) = basis(ideal);
        let child_weight = weight / f64::from(count);
        let mut sum = Color::ZERO;
        for i in 0..count {
            let mut dir = ideal;
            if count > 1 {
                let d = concentric_disc(stratified_2d(i, count, pattern)) * blur;
                dir = (ideal + d.x * b1 + d.y * b2).normalize();
                if dir.dot(side) < 0.0 {
                    dir = reflect(dir, side);
                }
            }
            match kind {
                RayKind::Reflection => c.stats.reflection_rays += 1,
                _ => c.stats.refraction_rays += 1,
            }
            let ray = hit.spawn_ray(n, dir);
            match node.as_deref_mut() {
                None => sum += self.li(c, &ray, depth + 1, child_weight, None),
                Some(nd) => {
                    let mut child = TraceNode::new(kind, ray, depth + 1, child_weight);
                    sum += self.li(c, &ray, depth + 1, child_weight, Some(&mut child));
                    nd.children.push(child);
                }
            }
        }
        sum / f64::from(count)
    }
}

impl Integrator for Phong {
    fn radiance(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler, stats: &mut RayStats) -> Color {
        self.li(&mut Ctx { scene, sampler, stats }, ray, 0, Color::ONE, None)
    }

    fn explain(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler) -> Option<TraceNode> {
        let mut stats = RayStats::default();
        let mut root = TraceNode::new(RayKind::Camera, *ray, 0, Color::ONE);
        self.li(&mut Ctx { scene, sampler, stats: &mut stats }, ray, 0, Color::ONE, Some(&mut root));
        Some(root)
    }

    fn describe(&self) -> String {
        format!("max_depth {}, prune {}, glossy {}", self.max_depth, self.prune_threshold, self.glossy_rays)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::{ambient::Ambient, directional::Directional, point::PointLight, point::Spot};
    use crate::shapes::{plane::Plane, sphere::Sphere};
    use raylab::{Camera, Geometry, LightSource, Material};

    const EPS: f64 = 1e-12;

    fn scene(objects: Vec<Box<dyn Geometry>>, lights: Vec<Box<dyn LightSource>>, background: Color) -> Scene {
        let cam = Camera::look_at(DVec3::new(0.0, 5.0, 5.0), DVec3::ZERO, DVec3::Y, 45.0, 4, 4).unwrap();
        let objects = objects.into_iter().enumerate().map(|(i, g)| (format!("object {i}"), g)).collect();
        let lights = lights.into_iter().enumerate().map(|(i, l)| (format!("light {i}"), l)).collect();
        Scene::new("test", cam, background, objects, lights)
    }

    fn floor(m: Material) -> Box<dyn Geometry> {
        Box::new(Plane::new(DVec3::ZERO, DVec3::Y, m))
    }

    fn shade(s: &Scene, integrator: &Phong, ray: &Ray) -> (Color, RayStats) {
        let mut stats = RayStats::default();
        let c = integrator.radiance(s, ray, &mut Sampler::new(0, 0, 0), &mut stats);
        (c, stats)
    }

    /// The camera ray of every light test: from (0, 5, 5) to the origin on the floor.
    fn down_ray() -> Ray {
        Ray::new(DVec3::new(0.0, 5.0, 5.0), DVec3::new(0.0, -5.0, -5.0))
    }

    fn lambert_phong() -> Material {
        Material {
            ka: DVec3::new(0.5, 0.4, 0.3),
            kd: DVec3::new(0.5, 0.25, 0.125),
            ks: DVec3::splat(0.3),
            shininess: 10.0,
            emission: DVec3::new(0.01, 0.02, 0.03),
            ..Material::default()
        }
    }

    /// `emission + ka·ambient + (kd·(n·l) + ks·(−v·r)^n)·I` written out for the floor at the origin,
    /// seen along `down_ray`, with `l` the unit direction to the light.
    fn expected(m: &Material, ambient: Color, l: DVec3, intensity: Color) -> Color {
        let n = DVec3::Y;
        let v = DVec3::new(0.0, -1.0, -1.0) / 2f64.sqrt();
        let nl = n.dot(l);
        let r = -l + 2.0 * nl * n;
        let spec = (-v.dot(r)).max(0.0).powf(m.shininess);
        m.emission + m.ka * ambient + (m.kd * nl + m.ks * spec) * intensity
    }

    fn assert_close(a: Color, b: Color) {
        assert!((a - b).abs().max_element() < EPS, "{a} vs {b}");
    }

    #[test]
    fn ambient_and_emission_alone() {
        let m = lambert_phong();
        let s = scene(vec![floor(m.clone())], vec![Box::new(Ambient::new(DVec3::new(1.0, 0.5, 0.25), 0.1))], Color::ZERO);
        let (c, _) = shade(&s, &Phong::default(), &down_ray());
        assert_close(c, m.emission + m.ka * DVec3::new(0.1, 0.05, 0.025));
    }

    #[test]
    fn directional_light_terms() {
        let m = lambert_phong();
        let travel = DVec3::new(1.0, -2.0, 0.0).normalize();
        let i = DVec3::new(0.9, 0.8, 0.7);
        let s = scene(
            vec![floor(m.clone())],
            vec![Box::new(Directional::new(i, travel)), Box::new(Ambient::new(DVec3::ONE, 0.1))],
            Color::ZERO,
        );
        let (c, stats) = shade(&s, &Phong::default(), &down_ray());
        // l = (−1, 2, 0)/√5: n·l = 2/√5; r = (1, 2, 0)/√5; −v·r = 2/√10.
        let spec = (2.0 / 10f64.sqrt()).powi(10);
        let by_hand = m.emission + m.ka * 0.1 + (m.kd * (2.0 / 5f64.sqrt()) + m.ks * spec) * i;
        assert_close(c, by_hand);
        assert_close(c, expected(&m, DVec3::splat(0.1), -travel, i));
        assert_eq!(stats.shadow_rays, 1);
    }

    #[test]
    fn point_light_attenuates_with_distance() {
        let m = lambert_phong();
        let pos = DVec3::new(1.0, 3.0, 0.0);
        let (kc, kl, kq) = (1.0, 0.1, 0.01);
        let i0 = DVec3::new(2.0, 1.5, 1.0);
        let s = scene(vec![floor(m.clone())], vec![Box::new(PointLight::new(i0, pos, kc, kl, kq))], Color::ZERO);
        let (c, _) = shade(&s, &Phong::default(), &down_ray());
        let d = 10f64.sqrt();
        let by_hand = expected(&m, Color::ZERO, pos / d, i0 / (kc + kl * d + kq * d * d));
        assert_close(c, by_hand);
    }

    #[test]
    fn spot_light_narrows_by_its_exponent() {
        let m = lambert_phong();
        let pos = DVec3::new(2.0, 4.0, 0.0);
        let axis = DVec3::new(-1.0, -1.0, 0.0).normalize();
        let i0 = DVec3::splat(3.0);
        let spot = Spot { direction: axis, exponent: 2.0, cos_cutoff: 0.0 };
        let s = scene(vec![floor(m.clone())], vec![Box::new(PointLight::spot(i0, pos, 1.0, 0.0, 0.05, spot))], Color::ZERO);
        let (c, _) = shade(&s, &Phong::default(), &down_ray());
        let d = 20f64.sqrt();
        let l_from_light = -pos / d;
        // D·L = (1/√2)(2/√20 + 4/√20) = 6/√40
        let dl: f64 = 6.0 / 40f64.sqrt();
        assert!((axis.dot(l_from_light) - dl).abs() < EPS);
        let by_hand = expected(&m, Color::ZERO, pos / d, i0 * dl.powi(2) / (1.0 + 0.05 * d * d));
        assert_close(c, by_hand);
        // Outside the cone (the spot points away): no light and no shadow ray.
        let away = Spot { direction: -axis, exponent: 2.0, cos_cutoff: 0.0 };
        let s = scene(vec![floor(m.clone())], vec![Box::new(PointLight::spot(i0, pos, 1.0, 0.0, 0.05, away))], Color::ZERO);
        let (c, stats) = shade(&s, &Phong::default(), &down_ray());
        assert_close(c, m.emission);
        assert_eq!(stats.shadow_rays, 0);
    }

    #[test]
    fn no_light_through_an_opaque_wall() {
        // Light under the floor, viewer above: n·l and n·v disagree, so no contribution.
        let m = lambert_phong();
        let s = scene(
            vec![floor(m.clone())],
            vec![Box::new(PointLight::new(DVec3::ONE, DVec3::new(0.0, -3.0, 0.0), 1.0, 0.0, 0.0))],
            Color::ZERO,
        );
        let (c, stats) = shade(&s, &Phong::default(), &down_ray());
        assert_close(c, m.emission);
        assert_eq!((stats.lights_behind, stats.shadow_rays), (1, 0));
    }

    #[test]
    fn shadows_block_and_transparent_occluders_attenuate() {
        let m = lambert_phong();
        let light = || -> Box<dyn LightSource> { Box::new(PointLight::new(DVec3::ONE, DVec3::new(0.0, 6.0, 0.0), 1.0, 0.0, 0.0)) };
        let blocker = |kt: f64| -> Box<dyn Geometry> {
            Box::new(Sphere::new(DVec3::new(0.0, 3.0, 0.0), 1.0, Material { kt: DVec3::splat(kt), ..Material::default() }))
        };
        let lit = expected(&m, Color::ZERO, DVec3::Y, DVec3::ONE);
        let open = scene(vec![floor(m.clone())], vec![light()], Color::ZERO);
        assert_close(shade(&open, &Phong::default(), &down_ray()).0, lit);
        let opaque = scene(vec![floor(m.clone()), blocker(0.0)], vec![light()], Color::ZERO);
        assert_close(shade(&opaque, &Phong::default(), &down_ray()).0, m.emission);
        // A shadow ray crosses the glass sphere twice: kt².
        let glass = scene(vec![floor(m.clone()), blocker(0.5)], vec![light()], Color::ZERO);
        let (c, _) = shade(&glass, &Phong::default(), &down_ray());
        assert_close(c, m.emission + (lit - m.emission) * 0.25);
    }

    #[test]
    fn mirror_reflects_the_background() {
        let mirror = Material { ka: DVec3::ZERO, kd: DVec3::ZERO, kr: DVec3::new(0.9, 0.8, 0.7), ..Material::default() };
        let bg = DVec3::new(0.2, 0.4, 0.6);
        let s = scene(vec![floor(mirror)], vec![], bg);
        let (c, stats) = shade(&s, &Phong::default(), &down_ray());
        assert_close(c, DVec3::new(0.9, 0.8, 0.7) * bg);
        assert_eq!(stats.reflection_rays, 1);
        let tree = Phong::default().explain(&s, &down_ray(), &mut Sampler::new(0, 0, 0)).unwrap();
        let child = &tree.children[0];
        assert!((child.ray.dir - DVec3::new(0.0, 1.0, -1.0).normalize()).length() < EPS);
    }

    #[test]
    fn refraction_follows_snell_and_total_internal_reflection() {
        let glass = Material { ka: DVec3::ZERO, kd: DVec3::ZERO, kt: DVec3::ONE, ior: 1.5, ..Material::default() };
        let s = scene(vec![Box::new(Sphere::new(DVec3::ZERO, 1.0, glass))], vec![], DVec3::new(0.3, 0.3, 0.3));
        // Enter at 30° from the normal at the top of the sphere.
        let hit = DVec3::new(0.0, 1.0, 0.0);
        let incoming = DVec3::new(30f64.to_radians().sin(), -30f64.to_radians().cos(), 0.0);
        let ray = Ray::new(hit - 3.0 * incoming, incoming);
        let tree = Phong::default().explain(&s, &ray, &mut Sampler::new(0, 0, 0)).unwrap();
        let inside = &tree.children[0];
        let sin_t = inside.ray.dir.cross(-DVec3::Y).length();
        assert!((sin_t - 0.5 / 1.5).abs() < 1e-9, "Snell: sin θt = sin θi / n, got {sin_t}");
        assert!(tree.hit.as_ref().unwrap().front_face && !inside.hit.as_ref().unwrap().front_face);
        // Inside, beyond the critical angle (sin θ > 1/1.5): total internal reflection.
        let inside_ray = Ray::new(DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0));
        let grazing = Ray::new(DVec3::new(0.9, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0));
        let t = Phong::default().explain(&s, &grazing, &mut Sampler::new(0, 0, 0)).unwrap();
        assert!(t.notes.iter().any(|n| n.contains("total internal reflection")), "{}", t.to_text());
        let t = Phong::default().explain(&s, &inside_ray, &mut Sampler::new(0, 0, 0)).unwrap();
        assert!(t.notes.iter().all(|n| !n.contains("total internal")));
    }

    #[test]
    fn pruning_and_depth_limit_skip_rays() {
        let mirror = Material { kd: DVec3::ZERO, kr: DVec3::splat(0.5), ..Material::default() };
        // Two parallel mirrors: the ray bounces until depth or pruning stops it.
        let planes: Vec<Box<dyn Geometry>> =
            vec![floor(mirror.clone()), Box::new(Plane::new(DVec3::new(0.0, 10.0, 0.0), -DVec3::Y, mirror))];
        let s = scene(planes, vec![], DVec3::ONE);
        let ray = Ray::new(DVec3::new(0.0, 5.0, 0.0), DVec3::new(0.0, -1.0, 0.01));
        let deep = Phong { max_depth: 100, prune_threshold: 0.01, glossy_rays: 1 };
        let (c, st) = shade(&s, &deep, &ray);
        // 0.5^7 = 0.0078 < 0.01: the 7th reflection is pruned.
        assert_eq!((st.reflection_rays, st.pruned_rays, st.depth_limited), (6, 1, 0));
        // Between two infinite mirrors no ray ever escapes to the background.
        assert_eq!(c, Color::ZERO);
        let shallow = Phong { max_depth: 2, prune_threshold: 0.0, glossy_rays: 1 };
        let (_, st) = shade(&s, &shallow, &ray);
        assert_eq!((st.reflection_rays, st.pruned_rays, st.depth_limited), (2, 0, 1));
    }
}
