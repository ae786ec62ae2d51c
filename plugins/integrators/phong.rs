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
use raylab::float::{SHADOW_EPSILON, offset_ray_origin};
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
        let m = g.material_at(&hit);
        let n = g.normal(&hit, ray.dir);
        let outward = g.outward_normal(&hit);
        let front = outward.dot(ray.dir) < 0.0;
        let ambient = m.ka * scene.ambient;
        let mut color = m.emission + ambient;
        if let Some(nd) = node.as_deref_mut() {
            nd.hit = Some(TraceHit {
                object: hit.object as usize,
                name: scene.object_name(hit.object).to_string(),
                t: hit.t,
                point: hit.point,
                normal: n,
                front_face: front,
            });
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
        let g = &scene.geometries[hit.object as usize];
        let m = g.material_at(hit);
        let mut sum = Color::ZERO;
        if max_channel(m.kd) <= 0.0 && max_channel(m.ks) <= 0.0 {
            return sum;
        }
        // Lighting uses the shading normal; sides and ray offsets the geometric `n`.
        let ns = g.shading_normal(hit, ray.dir);
        for (li, light) in scene.lights.iter().enumerate() {
            let count = light.sample_count().max(1);
            let pattern = if count > 1 { c.sampler.next_pattern() } else { 0 };
            for s in 0..count {
                let u = if count > 1 { stratified_2d(s, count, pattern) } else { c.sampler.next_2d() };
                let Some(ls) = light.illuminate(hit.point, u) else { continue };
                let name = || scene.light_names[li].clone();
                let nl = if n.dot(ls.dir) > 0.0 { ns.dot(ls.dir) } else { 0.0 };
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
                let r = reflect(-ls.dir, ns);
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
                let origin = offset_ray_origin(hit.point, hit.error, n, ls.dir);
                let shadow_ray = Ray { origin, dir: ls.dir };
                let t_max = if ls.distance.is_finite() {
                    (ls.distance - (origin - hit.point).length()) * (1.0 - SHADOW_EPSILON)
                } else {
                    f64::INFINITY
                };
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
            let ray = Ray { origin: offset_ray_origin(hit.point, hit.error, n, dir), dir };
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
