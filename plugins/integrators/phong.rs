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

use raylab::geometry::Hit;
use raylab::glam::{DVec2, DVec3};
use raylab::input::error::Result;
use raylab::input::params::Params;
use raylab::input::spec::{Default, ParamKind, ParamSpec};
use raylab::math::color::max_channel;
use raylab::render::sampler::{concentric_disc, orthonormal_basis, stratified_2d};
use raylab::render::trace::{TraceHit, TraceLight};
use raylab::{Color, Integrator, LightSource, LoadContext, PluginInfo, Ray, RayKind, RayStats, Sampler, Scene, TraceNode};

/// The recursive Phong integrator.
#[derive(Clone, Debug)]
pub struct Phong {
    /// Most reflection/refraction bounces along a path (0 = direct light only).
    pub max_depth: u32,
    /// A secondary ray, or a light sample, whose weight in the pixel is below this is skipped.
    pub prune_threshold: f64,
    /// Rays per glossy reflection or blurry refraction (materials with `blur > 0`).
    pub glossy_rays: u32,
    /// Shadow rays per area light and shading point; 0 uses each light's own `samples`.
    pub shadow_rays: u32,
    /// Adaptive soft shadows: trace this many probe rays to an area light first, and its full
    /// set of shadow rays only when the probes disagree (a penumbra). 0 = off.
    pub shadow_probes: u32,
    /// Skip work that cannot change the image (see the module docs). `false` does it anyway, for
    /// measuring what the skipping saves: the image stays bit-identical.
    pub avoid: bool,
}

/// The `phong` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "phong",
    summary: "The report's recursive Phong model: emission, ambient, diffuse and specular per light with shadows (attenuated by transparent occluders), mirror reflection and Snell refraction with total internal reflection, glossy/blurry rays, soft shadows from area lights, recursion pruning.",
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
            "rays per glossy reflection / blurry refraction (materials with blur > 0), scaled by the fan's weight in the pixel (at least 1), ≥ 1",
        ),
        ParamSpec::new(
            "shadow_rays",
            ParamKind::Int,
            Default::Int(0),
            "shadow rays per area light and shading point (0 = each light's own `samples`), ≥ 0",
        ),
        ParamSpec::new(
            "shadow_probes",
            ParamKind::Int,
            Default::Int(0),
            "adaptive soft shadows: probe rays per area light (its corners or rim first); the full set only where they disagree (0 = off), ≥ 0",
        ),
        ParamSpec::new(
            "avoid",
            ParamKind::Bool,
            Default::Bool(true),
            "skip work that cannot change the image; false traces it anyway (same image, for measuring the saving)",
        ),
    ],
};

/// Builds the integrator from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Phong {
        max_depth: p.int_in("max_depth", 0..=1024)? as u32,
        prune_threshold: p.float_in("prune_threshold", 0.0..=1.0)?,
        glossy_rays: p.int_in("glossy_rays", 1..=65536)? as u32,
        shadow_rays: p.int_in("shadow_rays", 0..=65536)? as u32,
        shadow_probes: p.int_in("shadow_probes", 0..=65536)? as u32,
        avoid: p.bool("avoid")?,
    }))
}

impl std::default::Default for Phong {
    fn default() -> Self {
        Phong { max_depth: 3, prune_threshold: 0.001, glossy_rays: 16, shadow_rays: 0, shadow_probes: 0, avoid: true }
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

/// Sampler tags: each part of a hit's work draws from its own stream, so skipping one part never
/// changes the numbers another sees.
const TAG_LIGHTS: u64 = 1;
const TAG_REFLECTION: u64 = 2 << 32;
const TAG_REFRACTION: u64 = 3 << 32;
/// Offset (within a ray kind's tags) of the stream a glossy fan's pattern comes from.
const FAN_PATTERN: u64 = 0xFFFF_FFFF;

struct Ctx<'a> {
    scene: &'a Scene,
    stats: &'a mut RayStats,
}

/// How one light sample turned out, for the agreement test of adaptive soft shadows. Independent
/// of `avoid`, so the decision is the same whether or not exact skips happen.
#[derive(Clone, Copy, PartialEq)]
enum Outcome {
    /// Contributes exactly nothing (behind the surface, outside a cone, no response).
    Dark,
    /// Below the pruning threshold.
    Negligible,
    /// Lit, with this transmittance toward the light.
    Lit(Color),
}

/// The running result of one light's samples at a point.
struct LightSum {
    /// Sum of the samples' shadowed contributions at full intensity.
    sum: Color,
    /// Samples drawn (the divisor).
    n: u32,
    /// The first sample's outcome, and whether every later one matched it.
    first: Option<Outcome>,
    agree: bool,
}

impl Phong {
    /// Radiance along `ray` (with its own random stream `sampler`) and accumulated `weight`;
    /// records into `node` when explaining.
    fn li(&self, c: &mut Ctx, ray: &Ray, sampler: &Sampler, depth: u32, weight: Color, mut node: Option<&mut TraceNode>) -> Color {
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
            nd.hit = Some(TraceHit::new(scene, &hit, ray.dir));
            nd.emission = m.emission;
            nd.ambient = ambient;
        }

        color += self.direct(c, ray, &hit, n, sampler, weight, node.as_deref_mut());

        for kind in [RayKind::Reflection, RayKind::Refraction] {
            let (coef, what) = if kind == RayKind::Reflection { (m.kr, "reflection") } else { (m.kt, "refraction") };
            if self.avoid && max_channel(coef) <= 0.0 {
                c.stats.zero_coefficient_rays += 1;
                continue;
            }
            if depth >= self.max_depth {
                c.stats.depth_limited += 1;
                if let Some(nd) = node.as_deref_mut() {
                    nd.notes.push(format!("max depth {} reached: no {what} ray", self.max_depth));
                }
                continue;
            }
            let w = weight * coef;
            if max_channel(w) < self.prune_threshold {
                c.stats.pruned_rays += 1;
                if let Some(nd) = node.as_deref_mut() {
                    nd.notes.push(format!("{what} pruned: weight {:.3e} < threshold {}", max_channel(w), self.prune_threshold));
                }
                continue;
            }
            let (dir, side, tag) = if kind == RayKind::Reflection {
                (reflect(ray.dir, n), n, TAG_REFLECTION)
            } else if g.is_closed() {
                let eta = if front { 1.0 / m.ior } else { m.ior };
                match refract(ray.dir, n, eta) {
                    Some(t) => (t, -n, TAG_REFRACTION),
                    None => {
                        if let Some(nd) = node.as_deref_mut() {
                            nd.notes.push("total internal reflection: the transmitted ray reflects".into());
                        }
                        (reflect(ray.dir, n), n, TAG_REFRACTION)
                    }
                }
            } else {
                (ray.dir, -n, TAG_REFRACTION)
            };
            let fan = Fan { ideal: dir, side, blur: m.blur, kind, tag };
            color += coef * self.spread(c, &hit, n, &fan, sampler, depth, w, node.as_deref_mut());
        }
        if let Some(nd) = node {
            nd.color = color;
        }
        color
    }

    /// Direct light at `hit`: diffuse and specular from every light, shadowed.
    #[allow(clippy::too_many_arguments)]
    fn direct(
        &self,
        c: &mut Ctx,
        ray: &Ray,
        hit: &Hit,
        n: DVec3,
        sampler: &Sampler,
        weight: Color,
        mut node: Option<&mut TraceNode>,
    ) -> Color {
        let scene = c.scene;
        let g = &scene.geometries[hit.object as usize];
        let m = g.material_at(hit);
        let no_response = max_channel(m.kd) <= 0.0 && max_channel(m.ks) <= 0.0;
        let ns = g.shading_normal(hit, ray.dir);
        let streams = sampler.fork(TAG_LIGHTS);
        let mut total = Color::ZERO;
        for (li, light) in scene.lights.iter().enumerate() {
            let full = match light.is_area() && self.shadow_rays > 0 {
                true => self.shadow_rays,
                false => light.sample_count().max(1),
            };
            let mut stream = streams.fork(li as u64);
            let probes = if light.is_area() && self.shadow_probes > 0 && self.shadow_probes < full { self.shadow_probes } else { 0 };
            let mut acc = LightSum { sum: Color::ZERO, n: 0, first: None, agree: true };
            let shade = Shade { ray, hit, n, ns, weight, full, li, no_response };
            let first_set = if probes > 0 { Samples::Probes(probes) } else { Samples::Stratified(full) };
            let pattern = stream.next_pattern();
            let u0 = stream.next_2d();
            if !self.light_samples(c, &shade, light.as_ref(), first_set, pattern, u0, &mut acc, node.as_deref_mut()) {
                continue;
            }
            if probes > 0 {
                if acc.agree {
                    c.stats.shadow_rays_saved += u64::from(full - probes);
                } else {
                    if let Some(nd) = node.as_deref_mut() {
                        nd.notes.push(format!("{}: the {probes} probe rays disagree; {full} more samples", scene.light_names[li]));
                    }
                    let pattern = stream.next_pattern();
                    self.light_samples(c, &shade, light.as_ref(), Samples::Stratified(full), pattern, u0, &mut acc, node.as_deref_mut());
                }
            }
            if acc.n > 0 {
                total += acc.sum / f64::from(acc.n);
            }
        }
        total
    }

    /// Takes the samples `set` of `light` (stratified with `pattern`; `u0` for a single sample)
    /// and adds them to `acc`. False when the light has no direction here (ambient).
    #[allow(clippy::too_many_arguments)]
    fn light_samples(
        &self,
        c: &mut Ctx,
        sh: &Shade,
        light: &dyn LightSource,
        set: Samples,
        pattern: u32,
        u0: DVec2,
        acc: &mut LightSum,
        mut node: Option<&mut TraceNode>,
    ) -> bool {
        let scene = c.scene;
        let (hit, n, ray) = (sh.hit, sh.n, sh.ray);
        let m = scene.geometries[hit.object as usize].material_at(hit);
        let count = match set {
            Samples::Stratified(n) | Samples::Probes(n) => n,
        };
        for s in 0..count {
            let u = match set {
                Samples::Probes(_) if s < 4 => PROBE_CORNERS[s as usize],
                Samples::Probes(n) => stratified_2d(s - 4, n - 4, pattern),
                Samples::Stratified(1) => u0,
                Samples::Stratified(n) => stratified_2d(s, n, pattern),
            };
            let Some(ls) = light.illuminate(hit.point, u) else { return false };
            acc.n += 1;
            if self.avoid && sh.no_response {
                c.stats.lights_no_response += u64::from(count - s);
                acc.n += count - s - 1;
                acc.first.get_or_insert(Outcome::Dark);
                if let Some(nd) = node.as_deref_mut() {
                    nd.notes.push(format!("{}: the surface has no diffuse or specular term; no shadow rays", scene.light_names[sh.li]));
                }
                return true;
            }
            // Lit only from the viewer's side of the geometric surface; shaded with `ns`.
            let nl = if n.dot(ls.dir) > 0.0 { sh.ns.dot(ls.dir) } else { 0.0 };
            // The explanation record, built only when a trace asks for one.
            let record = |node: Option<&mut TraceNode>,
                          skipped: Option<&str>,
                          transmittance: Color,
                          occluder: Option<u32>,
                          terms: (Color, Color)| {
                if let Some(nd) = node {
                    nd.lights.push(TraceLight {
                        light: scene.light_names[sh.li].clone(),
                        dir: ls.dir,
                        distance: ls.distance,
                        intensity: ls.intensity,
                        n_dot_l: nl,
                        transmittance,
                        occluder: occluder.map(|o| scene.object_name(o).to_string()),
                        diffuse: terms.0,
                        specular: terms.1,
                        skipped: skipped.map(str::to_string),
                    });
                }
            };
            let none = (Color::ZERO, Color::ZERO);
            if self.avoid && nl <= 0.0 {
                c.stats.lights_behind += 1;
                acc.observe(Outcome::Dark);
                record(node.as_deref_mut(), Some("the light is behind the surface as seen from the ray"), Color::ZERO, None, none);
                continue;
            }
            if self.avoid && max_channel(ls.intensity) <= 0.0 {
                c.stats.lights_unreachable += 1;
                acc.observe(Outcome::Dark);
                record(node.as_deref_mut(), Some("no light arrives here (outside the cone)"), Color::ZERO, None, none);
                continue;
            }
            let lit = nl > 0.0;
            let r = reflect(-ls.dir, sh.ns);
            let vr = -ray.dir.dot(r);
            let spec = if lit && vr > 0.0 && max_channel(m.ks) > 0.0 { vr.powf(m.shininess) } else { 0.0 };
            let diffuse = m.kd * nl.max(0.0) * ls.intensity;
            let specular = m.ks * spec * ls.intensity;
            let unshadowed = diffuse + specular;
            let dark = max_channel(unshadowed) <= 0.0;
            if self.avoid && dark {
                c.stats.lights_no_response += 1;
                acc.observe(Outcome::Dark);
                record(node.as_deref_mut(), Some("no diffuse or specular response toward this light"), Color::ZERO, None, none);
                continue;
            }
            let share = max_channel(unshadowed * sh.weight) / f64::from(sh.full);
            if share < self.prune_threshold {
                c.stats.lights_negligible += 1;
                acc.observe(if dark { Outcome::Dark } else { Outcome::Negligible });
                if node.is_some() {
                    record(
                        node.as_deref_mut(),
                        Some(&format!("contribution {share:.3e} below the pruning threshold")),
                        Color::ZERO,
                        None,
                        none,
                    );
                }
                continue;
            }
            c.stats.shadow_rays += 1;
            let (shadow_ray, t_max) = hit.spawn_shadow_ray(n, ls.dir, ls.distance);
            let tr = if node.is_some() {
                let (tr, occ) = scene.transmittance_and_occluder(&shadow_ray, t_max);
                record(node.as_deref_mut(), None, tr, occ, (diffuse * tr / f64::from(count), specular * tr / f64::from(count)));
                tr
            } else {
                scene.transmittance(&shadow_ray, t_max)
            };
            acc.sum += unshadowed * tr;
            acc.observe(if dark { Outcome::Dark } else { Outcome::Lit(tr) });
        }
        true
    }

    /// Traces the child ray(s) around `fan.ideal`: one ray, or `glossy_rays` jittered in a disc
    /// of radius `blur`, each flipped onto the `side` hemisphere if jitter pushed it through the
    /// surface. Returns their mean radiance. At a sharp surface with `avoid` off, the fan is
    /// `glossy_rays` copies of the one ideal ray (same stream, same weight).
    #[allow(clippy::too_many_arguments)]
    fn spread(
        &self,
        c: &mut Ctx,
        hit: &Hit,
        n: DVec3,
        fan: &Fan,
        sampler: &Sampler,
        depth: u32,
        weight: Color,
        mut node: Option<&mut TraceNode>,
    ) -> Color {
        let sharp = fan.blur <= 0.0;
        // A fan gets rays in proportion to its weight in the pixel (at least one), so nested
        // glossy bounces cost about `glossy_rays` per sample instead of `glossy_rays^depth`.
        let fan_size = ((f64::from(self.glossy_rays) * max_channel(weight)).ceil() as u32).clamp(1, self.glossy_rays);
        let count = if sharp && self.avoid { 1 } else { fan_size };
        if sharp && self.avoid {
            c.stats.glossy_rays_saved += u64::from(fan_size - 1);
        }
        let pattern = if sharp { 0 } else { sampler.fork(fan.tag | FAN_PATTERN).next_pattern() };
        let (b1, b2) = orthonormal_basis(fan.ideal);
        let child_weight = if sharp { weight } else { weight / f64::from(count) };
        let mut mean = Color::ZERO;
        for i in 0..count {
            let mut dir = fan.ideal;
            if !sharp {
                let d = concentric_disc(stratified_2d(i, count, pattern)) * fan.blur;
                dir = (fan.ideal + d.x * b1 + d.y * b2).normalize();
                if dir.dot(fan.side) < 0.0 {
                    dir = reflect(dir, fan.side);
                }
            }
            match fan.kind {
                RayKind::Reflection => c.stats.reflection_rays += 1,
                _ => c.stats.refraction_rays += 1,
            }
            let ray = hit.spawn_ray(n, dir);
            let child_sampler = sampler.fork(fan.tag | if sharp { 0 } else { u64::from(i) });
            let li = match node.as_deref_mut() {
                None => self.li(c, &ray, &child_sampler, depth + 1, child_weight, None),
                Some(nd) => {
                    let mut child = TraceNode::new(fan.kind, ray, depth + 1, child_weight);
                    let li = self.li(c, &ray, &child_sampler, depth + 1, child_weight, Some(&mut child));
                    nd.children.push(child);
                    li
                }
            };
            // Running mean: copies of one ray average to exactly that ray's value.
            mean += (li - mean) / f64::from(i + 1);
        }
        mean
    }
}

/// Which samples of a light to take.
#[derive(Clone, Copy)]
enum Samples {
    /// `n` stratified over the light.
    Stratified(u32),
    /// Probes for adaptive soft shadows: the light's corners (the sample square's corners, which
    /// lights map to their extreme points: a rectangle's corners, a ball's rim), then `n − 4`
    /// stratified points. A straight occluder edge across the light separates its corners.
    Probes(u32),
}

/// The sample square's corners, diagonal pairs first.
const PROBE_CORNERS: [DVec2; 4] = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0)];

/// What a shading point's light samples share.
struct Shade<'a> {
    ray: &'a Ray,
    hit: &'a Hit,
    /// Geometric normal facing the ray: sides and ray offsets.
    n: DVec3,
    /// Shading normal facing the ray: lighting (the interpolated normal of a smooth mesh).
    ns: DVec3,
    weight: Color,
    /// The light's full sample count (the pruning share divides by it).
    full: u32,
    li: usize,
    no_response: bool,
}

/// A reflection or refraction fan: the ideal direction, the side it must stay on, the blur.
struct Fan {
    ideal: DVec3,
    side: DVec3,
    blur: f64,
    kind: RayKind,
    tag: u64,
}

impl LightSum {
    fn observe(&mut self, o: Outcome) {
        match self.first {
            None => self.first = Some(o),
            Some(f) => self.agree &= f == o,
        }
    }
}

impl Integrator for Phong {
    fn radiance(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler, stats: &mut RayStats) -> Color {
        self.li(&mut Ctx { scene, stats }, ray, sampler, 0, Color::ONE, None)
    }

    fn explain(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler) -> Option<TraceNode> {
        let mut stats = RayStats::default();
        let mut root = TraceNode::new(RayKind::Camera, *ray, 0, Color::ONE);
        self.li(&mut Ctx { scene, stats: &mut stats }, ray, sampler, 0, Color::ONE, Some(&mut root));
        Some(root)
    }

    /// Every hit of a path tree up to `max_depth` has a reflection and a refraction fan and
    /// takes every light's probes and samples. A fan has at most `ceil(glossy_rays × w)` rays for
    /// its weight `w`, and its rays share `w` (coefficients ≤ 1), so the weights at one depth sum
    /// to at most 2^depth; with `avoid` off, every fan has `glossy_rays` rays at full weight.
    fn worst_case_rays(&self, scene: &Scene) -> f64 {
        let per_hit: f64 = scene
            .lights
            .iter()
            .map(|l| {
                let full = if l.is_area() && self.shadow_rays > 0 { self.shadow_rays } else { l.sample_count().max(1) };
                let probes = if l.is_area() && self.shadow_probes < full { self.shadow_probes } else { 0 };
                f64::from(full) + f64::from(probes)
            })
            .sum();
        let g = f64::from(self.glossy_rays);
        let (mut hits, mut level, mut weight) = (1.0, 1.0, 1.0);
        for _ in 0..self.max_depth {
            let full = 2.0 * g * level;
            level = if self.avoid { full.min(2.0 * g * weight + 2.0 * level) } else { full };
            weight *= 2.0;
            hits += level;
        }
        hits * (1.0 + per_hit)
    }

    fn describe(&self) -> String {
        let mut s = format!("max_depth {}, prune {}, glossy {}", self.max_depth, self.prune_threshold, self.glossy_rays);
        if self.shadow_rays > 0 {
            s += &format!(", shadow rays {}", self.shadow_rays);
        }
        if self.shadow_probes > 0 {
            s += &format!(", shadow probes {}", self.shadow_probes);
        }
        if !self.avoid {
            s += ", avoid off";
        }
        s
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
        let deep = Phong { max_depth: 100, prune_threshold: 0.01, glossy_rays: 1, ..Phong::default() };
        let (c, st) = shade(&s, &deep, &ray);
        // 0.5^7 = 0.0078 < 0.01: the 7th reflection is pruned.
        assert_eq!((st.reflection_rays, st.pruned_rays, st.depth_limited), (6, 1, 0));
        // Between two infinite mirrors no ray ever escapes to the background.
        assert_eq!(c, Color::ZERO);
        let shallow = Phong { max_depth: 2, prune_threshold: 0.0, glossy_rays: 1, ..Phong::default() };
        let (_, st) = shade(&s, &shallow, &ray);
        assert_eq!((st.reflection_rays, st.pruned_rays, st.depth_limited), (2, 0, 1));
    }
}
