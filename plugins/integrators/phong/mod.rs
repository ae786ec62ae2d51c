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
//! With a material's `fresnel` on, `kr` and `kt` are weighted `F` and `1 − F` by the dielectric
//! reflectance for the angle of incidence ([`raylab::scene::material::Fresnel`]). With
//! `ambient = "first_hit"`, the ambient term is added only where the camera ray first hits (the
//! course's renderer from 2020 on) instead of at every hit of the recursion (the report).
//!
//! A light counts only from the viewer's side of the surface (`n·l > 0` with `n` facing the
//! viewer), so no light shines through an opaque wall. `shadow` is the product of the `kt` of
//! the surfaces between the point and the light. Refraction follows Snell's law at closed solids
//! (with total internal reflection); open surfaces transmit as thin sheets. Recursion stops at
//! `max_depth` or when a ray's accumulated weight (product of coefficients) falls below
//! `prune_threshold`. With `blur > 0` a material spreads `glossy_rays` jittered rays in a disc
//! around the ideal direction (the report's stage-D blurring).
//!
//! A ray that leaves the scene shows the background, or the environment light where the scene
//! has one ([`raylab::Scene::escaped`]): reflections and refractions see the sky. An environment
//! also lights the scene as an area light, its `samples` (16 by default, or `shadow_rays`)
//! stratified directions per shading point drawn by its luminance: each stands for the whole sky
//! (`I_L` = radiance ÷ (π·pdf)), so the diffuse term's mean is exactly the Lambertian response
//! to the sky, and 16 keep the noise of soft sky shadows low at a few samples per pixel. It is
//! never probed (`shadow_probes`): a sky has no extreme points whose agreement would mean that
//! the rest agrees.
//!
//! Emitting objects (material `emission`) are seen by the rays that meet them. With
//! `emitter_samples` > 0 they also light the scene as area lights: that many points per shading
//! point, each emitter chosen by power and the point by its shape's own sampling (a ball's visible
//! cone, flat shapes and meshes by area), stratified, each a sample of intensity radiance ÷
//! (π·pdf), so the diffuse term's mean is the Lambertian response to the emitters (`path`'s
//! direct light). Off by default: the report lights its scenes with lights, its emission is a
//! glow, and its images stay as they were. How many: each sample is one shadow ray, so the cost
//! per shading point grows with the count and the noise of emitter shadows falls as its square
//! root; 16, the environment's default, keeps soft shadows smooth at a few spp (a small bright
//! emitter needs fewer, a large one close by more). Shapes that offer no sampling (planes,
//! tubes) light nothing this way.
//!
//! The recursion lives here ([`Phong::shade`]); the light terms in [`direct`], the reflection and
//! refraction fans in [`fan`]. Every function is generic over a [`Recorder`]: rendering passes
//! [`NoRecord`] and pays nothing for `raylab trace`.

mod direct;
mod fan;

use raylab::Intersectable;
use raylab::geometry::differential::RaySpread;
use raylab::geometry::{Hit, PACKET};
use raylab::glam::DVec3;
use raylab::math::color::max_channel;
use raylab::param::error::Result;
use raylab::param::params::{Params, from_defaults};
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec, Reference};
use raylab::render::aov::{AovSample, GuideStep};
use raylab::render::integrator::explain_recursion;
use raylab::render::stats::{Counter, CounterKind};
use raylab::render::trace::{NoRecord, Recorder, Term};
use raylab::scene::interaction::Interaction;
use raylab::scene::material::{Coefficients, Fresnel};
use raylab::{Color, Integrator, LoadContext, PluginInfo, Ray, RayKind, RayStats, Sampler, Scene, TraceNode};
use std::cell::Cell;

pub use fan::{reflect, refract};

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
    /// Shadow rays per shading point toward points on the scene's emitting objects (material
    /// emission), which then light the scene as area lights; 0: they are only seen (the report).
    pub emitter_samples: u32,
    /// Adaptive soft shadows: trace this many probe rays to an area light first, and its full
    /// set of shadow rays only when the probes disagree (a penumbra). 0 = off.
    pub shadow_probes: u32,
    /// Skip work that cannot change the image (see the module docs). `false` does it anyway, for
    /// measuring what the skipping saves: the image stays bit-identical.
    pub avoid: bool,
    /// Add the ambient term only at the camera ray's first hit (the course's renderer from 2020
    /// on), not at every hit of the recursion (the report).
    pub ambient_first_hit: bool,
}

/// The `phong` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "phong",
    summary: "The report's recursive Phong model: emission, ambient, diffuse and specular per light with shadows (attenuated by transparent occluders), mirror reflection and Snell refraction with total internal reflection, glossy/blurry rays, soft shadows from area lights, recursion pruning.",
    params: &[
        ParamSpec::new("max_depth", ParamKind::Int, ParamDefault::Int(3), "most reflection/refraction bounces along a path (the report: 3), ≥ 0")
            .depth(Reference::AtLeast(12.0)),
        ParamSpec::new(
            "prune_threshold",
            ParamKind::Float,
            ParamDefault::Float(0.001),
            "skip rays and light samples whose weight in the pixel is below this (0 = never), 0..1",
        )
        .quality(Reference::AtMost(1e-4)),
        ParamSpec::new(
            "glossy_rays",
            ParamKind::Int,
            ParamDefault::Int(16),
            "rays per glossy reflection / blurry refraction (materials with blur > 0), scaled by the fan's weight in the pixel (at least 1), ≥ 1",
        )
        .quality(Reference::Keep),
        ParamSpec::new(
            "shadow_rays",
            ParamKind::Int,
            ParamDefault::Int(0),
            "shadow rays per area light and shading point (0 = each light's own `samples`), ≥ 0",
        )
        .quality(Reference::Keep),
        ParamSpec::new(
            "emitter_samples",
            ParamKind::Int,
            ParamDefault::Int(0),
            "shadow rays per shading point toward points on the emitting objects (material emission), which then light the scene as area lights, chosen by power; 0 = off: emitters are only seen, as in the report (16: soft shadows at a few spp), 0..65536",
        )
        .quality(Reference::Keep),
        ParamSpec::new(
            "shadow_probes",
            ParamKind::Int,
            ParamDefault::Int(0),
            "adaptive soft shadows: probe rays per area light (its corners or rim first); the full set only where they disagree (0 = off), ≥ 0",
        )
        .quality(Reference::Exactly(ParamDefault::Int(0))),
        ParamSpec::new(
            "avoid",
            ParamKind::Bool,
            ParamDefault::Bool(true),
            "skip work that cannot change the image; false traces it anyway (same image, for measuring the saving)",
        ),
        ParamSpec::new(
            "ambient",
            ParamKind::Str,
            ParamDefault::Str("every_hit"),
            "where ambient light is added: \"every_hit\" of the recursion (the report) or only the camera ray's \"first_hit\" (the course from 2020 on)",
        ),
    ],
};

/// Builds the integrator from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(Phong::from_params(p)?))
}

impl Phong {
    /// The integrator its parameters describe.
    pub fn from_params(p: &mut Params) -> Result<Phong> {
        Ok(Phong {
            max_depth: p.int_in("max_depth", 0..=1024)? as u32,
            prune_threshold: p.float_in("prune_threshold", 0.0..=1.0)?,
            glossy_rays: p.int_in("glossy_rays", 1..=65536)? as u32,
            shadow_rays: p.int_in("shadow_rays", 0..=65536)? as u32,
            emitter_samples: p.int_in("emitter_samples", 0..=65536)? as u32,
            shadow_probes: p.int_in("shadow_probes", 0..=65536)? as u32,
            avoid: p.bool("avoid")?,
            ambient_first_hit: p.choice("ambient", &["every_hit", "first_hit"])? == "first_hit",
        })
    }
}

/// The defaults of [`INFO`]'s parameter table.
impl Default for Phong {
    fn default() -> Self {
        from_defaults("phong", INFO.params, Phong::from_params)
    }
}

/// The counters of [`COUNTERS`], by index.
pub mod counter {
    /// Shadow rays toward lights.
    pub const SHADOW_RAYS: usize = 0;
    /// Reflection rays (mirror and glossy).
    pub const REFLECTION_RAYS: usize = 1;
    /// Transmission rays (refracted, or through thin sheets).
    pub const REFRACTION_RAYS: usize = 2;
    /// Light samples skipped: the light is behind the surface as seen from the ray.
    pub const LIGHTS_BEHIND: usize = 3;
    /// Light samples skipped: no light arrives (outside a spot's cone).
    pub const LIGHTS_UNREACHABLE: usize = 4;
    /// Light samples skipped: no diffuse or specular response.
    pub const LIGHTS_NO_RESPONSE: usize = 5;
    /// Reflection or refraction rays skipped: the coefficient is zero.
    pub const ZERO_COEFFICIENT_RAYS: usize = 6;
    /// Rays a glossy fan would have added at sharp surfaces (blur = 0).
    pub const GLOSSY_RAYS_SAVED: usize = 7;
    /// Light samples below the pruning threshold.
    pub const LIGHTS_NEGLIGIBLE: usize = 8;
    /// Secondary rays below the pruning threshold.
    pub const PRUNED_RAYS: usize = 9;
    /// Shadow rays not traced because an area light's probes agreed.
    pub const SHADOW_RAYS_SAVED: usize = 10;
    /// Secondary rays not traced at the depth limit.
    pub const DEPTH_LIMITED: usize = 11;
}

/// What `phong` counts (printed by `--stats`).
pub const COUNTERS: &[Counter] = &[
    Counter::new("shadow_rays", CounterKind::Rays, "shadow rays"),
    Counter::new("reflection_rays", CounterKind::Rays, "reflection rays"),
    Counter::new("refraction_rays", CounterKind::Rays, "refraction rays"),
    Counter::new("lights_behind", CounterKind::Avoided, "avoided: light behind surface"),
    Counter::new("lights_unreachable", CounterKind::Avoided, "avoided: light outside its cone"),
    Counter::new("lights_no_response", CounterKind::Avoided, "avoided: surface has no response"),
    Counter::new("zero_coefficient_rays", CounterKind::Avoided, "avoided: zero kr/kt rays"),
    Counter::new("glossy_rays_saved", CounterKind::Avoided, "avoided: glossy fans at sharp"),
    Counter::new("lights_negligible", CounterKind::Avoided, "pruned: light negligible"),
    Counter::new("pruned_rays", CounterKind::Avoided, "pruned: rays below threshold"),
    Counter::new("shadow_rays_saved", CounterKind::Avoided, "saved: adaptive shadow rays"),
    Counter::new("depth_limited", CounterKind::Other, "limited: max depth"),
];

/// Sampler tags: each part of a hit's work draws from its own stream, so skipping one part never
/// changes the numbers another sees.
const TAG_LIGHTS: u64 = 1;
const TAG_REFLECTION: u64 = 2 << 32;
const TAG_REFRACTION: u64 = 3 << 32;
const TAG_EMITTERS: u64 = 4 << 32;

/// What one camera ray's recursion shares: the scene and the counters.
struct Ctx<'a> {
    scene: &'a Scene,
    stats: &'a mut RayStats,
}

/// The origin of a shading point's rays that leave in front of its surface (shadow rays toward
/// lights on the viewer's side, the mirror ray), computed on first use and shared by them
/// ([`Interaction::front_origin`]: the same bits as each ray's own); rays that leave behind
/// (refraction) start where [`Interaction::spawn_ray`] puts them.
pub(crate) struct Front<'a> {
    si: &'a Interaction<'a>,
    origin: Cell<Option<DVec3>>,
}

impl<'a> Front<'a> {
    #[inline(always)]
    fn new(si: &'a Interaction<'a>) -> Self {
        Front { si, origin: Cell::new(None) }
    }

    #[inline(always)]
    fn origin(&self) -> DVec3 {
        match self.origin.get() {
            Some(o) => o,
            None => {
                let o = self.si.front_origin();
                self.origin.set(Some(o));
                o
            }
        }
    }

    /// [`Interaction::spawn_ray`] along `dir`.
    #[inline(always)]
    fn ray(&self, dir: DVec3) -> Ray {
        if self.si.leaves_front(dir) { Ray { origin: self.origin(), dir } } else { self.si.spawn_ray(dir) }
    }

    /// [`Interaction::spawn_shadow_ray`] along `dir` toward a light `distance` away.
    #[inline(always)]
    fn shadow_ray(&self, dir: DVec3, distance: f64) -> (Ray, f64) {
        if self.si.leaves_front(dir) {
            self.si.front_shadow_ray(self.origin(), dir, distance)
        } else {
            self.si.spawn_shadow_ray(dir, distance)
        }
    }
}

/// A ray's place in the recursion: its own random stream, its depth (0: a camera ray) and its
/// weight in the pixel (what pruning compares with the threshold).
#[derive(Clone, Copy)]
struct Branch<'s> {
    sampler: &'s Sampler,
    depth: u32,
    weight: Color,
    /// The ray's spread over the image (texture footprints).
    spread: RaySpread,
}

impl Phong {
    /// Radiance along `ray`, at its place `b` in the recursion.
    fn li<R: Recorder>(&self, c: &mut Ctx, ray: &Ray, b: Branch, rec: &mut R) -> Color {
        match c.scene.intersect(ray, 0.0, f64::INFINITY) {
            Some(hit) => {
                // The spread set in place: `with_spread` copied the whole interaction.
                let mut si = c.scene.interaction(ray, hit);
                si.spread = b.spread;
                self.shade(c, &si, &si.coefficients(), b, rec)
            }
            None => {
                let seen = c.scene.escaped(ray.dir);
                rec.color(seen);
                seen
            }
        }
    }

    /// Radiance leaving the hit `si` (with its material's coefficients `m`) back along its ray
    /// (at `b` in the recursion): emission, ambient, direct light, and the reflected and
    /// refracted rays.
    fn shade<R: Recorder>(&self, c: &mut Ctx, si: &Interaction, m: &Coefficients, b: Branch, rec: &mut R) -> Color {
        let Branch { depth, weight, .. } = b;
        rec.hit(si);
        // The work budget is spent: this sample is discarded, so nothing more is traced for it.
        if c.stats.exhausted() {
            rec.note(|| format!("stopped: the rays allowed ({} traced) are spent", c.stats.rays()));
            rec.color(Color::ZERO);
            return Color::ZERO;
        }
        let ambient = if self.ambient_first_hit && depth > 0 { Color::ZERO } else { m.ka * c.scene.ambient };
        rec.term(|| Term::color("emission", m.emission));
        rec.term(|| Term::color("ambient", ambient));
        let mut color = m.emission + ambient;
        let front = Front::new(si);
        color += self.direct(c, si, m, b, &front, rec);
        // (Without Fresnel, its weights without the call.)
        let (kr, kt) = if m.fresnel == Fresnel::Off { (m.kr, m.kt) } else { fan::fresnel_weights(si, m, rec) };
        for kind in [RayKind::Reflection, RayKind::Refraction] {
            let (coef, what) = if kind == RayKind::Reflection { (kr, "reflection") } else { (kt, "refraction") };
            if self.avoid && max_channel(coef) <= 0.0 {
                c.stats.add(counter::ZERO_COEFFICIENT_RAYS, 1);
                continue;
            }
            if depth >= self.max_depth {
                c.stats.add(counter::DEPTH_LIMITED, 1);
                rec.note(|| format!("max depth {} reached: no {what} ray", self.max_depth));
                continue;
            }
            let w = weight * coef;
            if max_channel(w) < self.prune_threshold {
                c.stats.add(counter::PRUNED_RAYS, 1);
                rec.note(|| format!("{what} pruned: weight {:.3e} < threshold {}", max_channel(w), self.prune_threshold));
                continue;
            }
            let fan = fan::Fan::new(si, m, kind, rec);
            color += coef * self.spread(c, si, &fan, Branch { weight: w, ..b }, &front, rec);
        }
        rec.color(color);
        color
    }

    /// The whole recursion for a camera ray, recorded into `rec`; `aov` gets the first surface.
    /// `given`: the ray's closest hit when the caller found it (`None`: found here).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn camera<R: Recorder>(
        &self,
        scene: &Scene,
        ray: &Ray,
        given: Option<Option<&Hit>>,
        sampler: &Sampler,
        stats: &mut RayStats,
        aov: &mut AovSample,
        rec: &mut R,
    ) -> Color {
        let c = &mut Ctx { scene, stats };
        let found = match given {
            Some(hit) => hit.copied(),
            None => scene.intersect(ray, 0.0, f64::INFINITY),
        };
        let Some(hit) = found else {
            let seen = scene.escaped(ray.dir);
            aov.escape(scene, ray.dir);
            rec.color(seen);
            return seen;
        };
        let mut si = scene.interaction(ray, hit);
        si.spread = scene.camera_spread(ray);
        let m = si.coefficients();
        aov.set_surface(&si, m.kd + m.kr + m.kt);
        aov.emitted = m.emission;
        aov.look_through(scene, &si, guide_step);
        self.shade(c, &si, &m, Branch { sampler, depth: 0, weight: Color::ONE, spread: si.spread }, rec)
    }
}

impl Phong {
    /// The counter a reflection or refraction fan of coefficient `coef` at a camera hit is
    /// skipped under (the tests of [`Phong::shade`], in its order, at depth 0 with weight 1), or
    /// `None` where the ray is traced.
    #[inline(always)]
    fn camera_fan_skipped(&self, coef: Color) -> Option<usize> {
        if self.avoid && max_channel(coef) <= 0.0 {
            return Some(counter::ZERO_COEFFICIENT_RAYS);
        }
        if self.max_depth == 0 {
            return Some(counter::DEPTH_LIMITED);
        }
        if max_channel(Color::ONE * coef) < self.prune_threshold {
            return Some(counter::PRUNED_RAYS);
        }
        None
    }

    /// [`Phong::camera`] for the camera rays of a block with their hits
    /// ([`Integrator::radiance_packet`]). Where the scene has one light that illuminates, with one
    /// sample (point, spot, directional) and no emitter samples, a hit whose material neither
    /// reflects nor transmits (no fan is traced there, Fresnel off) is shaded up to its shadow
    /// ray, and the block's shadow rays are traced together
    /// ([`Scene::transmittance_packet_leaving`]); every other hit by [`Phong::shade`]. Each lane is
    /// taken in order (its camera ray counted, its shadow ray counted as it is made, the work
    /// budget checked where `shade` checks it), so the counters any check sees, the colours and
    /// the layers are those of the lanes shaded one by one.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn camera_block(
        &self,
        scene: &Scene,
        rays: &[Ray; PACKET],
        (live, hits): (u32, u32),
        hit: &[Hit; PACKET],
        samplers: &[Sampler; PACKET],
        stats: &mut RayStats,
        aovs: &mut [AovSample; PACKET],
        out: &mut [Color; PACKET],
    ) {
        let light = match scene.one_sample_lights() {
            Some(&[light]) if self.emitter_samples == 0 || scene.emitters().is_empty() => light,
            _ => {
                let mut m = live;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    stats.camera_rays += 1;
                    let h = (hits >> k & 1 != 0).then_some(&hit[k]);
                    out[k] = self.camera(scene, &rays[k], Some(h), &samplers[k], stats, &mut aovs[k], &mut NoRecord);
                }
                return;
            }
        };
        let c = &mut Ctx { scene, stats };
        // The block's shadow rays (lanes of `traced`), and what the lanes shaded here add.
        let mut shadow = [Ray { origin: DVec3::ZERO, dir: DVec3::Z }; PACKET];
        let mut t_max = [0.0; PACKET];
        let mut unshadowed = [Color::ZERO; PACKET];
        let mut base = [Color::ZERO; PACKET];
        let (mut traced, mut block) = (0u32, 0u32);
        let mut m = live;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            c.stats.camera_rays += 1;
            let ray = &rays[k];
            let aov = &mut aovs[k];
            if hits >> k & 1 == 0 {
                let seen = scene.escaped(ray.dir);
                aov.escape(scene, ray.dir);
                out[k] = seen;
                continue;
            }
            // As `camera` does.
            let mut si = scene.interaction(ray, hit[k]);
            si.spread = scene.camera_spread(ray);
            let m = si.coefficients();
            aov.set_surface(&si, m.kd + m.kr + m.kt);
            aov.emitted = m.emission;
            aov.look_through(scene, &si, guide_step);
            let fans = match m.fresnel {
                Fresnel::Off => self.camera_fan_skipped(m.kr).zip(self.camera_fan_skipped(m.kt)),
                _ => None,
            };
            let Some((skip_r, skip_t)) = fans else {
                let b = Branch { sampler: &samplers[k], depth: 0, weight: Color::ONE, spread: si.spread };
                out[k] = self.shade(c, &si, &m, b, &mut NoRecord);
                continue;
            };
            // `shade` up to its shadow ray.
            if c.stats.exhausted() {
                out[k] = Color::ZERO;
                continue;
            }
            base[k] = m.emission + m.ka * scene.ambient;
            block |= 1 << k;
            if let Some((r, t, u)) = self.block_light(c, &si, &m, light) {
                (shadow[k], t_max[k], unshadowed[k]) = (r, t, u);
                traced |= 1 << k;
            }
            c.stats.add(skip_r, 1);
            c.stats.add(skip_t, 1);
        }
        let mut tr = [Color::ZERO; PACKET];
        scene.transmittance_packet_leaving(&shadow, traced, &t_max, hit, &mut tr);
        let mut m = block;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            // `direct`'s total over the one light, then `shade`'s sum.
            let mut total = Color::ZERO;
            total += if traced >> k & 1 != 0 { unshadowed[k] * tr[k] } else { Color::ZERO };
            let mut color = base[k];
            color += total;
            out[k] = color;
        }
    }
}

/// What the hit `si` is to the denoiser's guides ([`AovSample::look_through`]): a surface with a
/// diffuse or highlight response (`kd`, `ks`) or a blurred reflection or refraction stops them
/// (albedo `kd + kr + kt`, as at the first surface); a sharp mirror or glass sends them on along
/// its heavier ray, reflected or refracted (weights as the recursion's, Fresnel included),
/// tinted by `kr + kt`.
fn guide_step(si: &Interaction) -> GuideStep {
    let m = si.coefficients();
    let albedo = m.kr + m.kt;
    if max_channel(m.kd + m.ks) > 0.0 || m.blur > 0.0 {
        return GuideStep::Surface(m.kd + albedo);
    }
    let (kr, kt) = fan::fresnel_weights(si, &m, &mut NoRecord);
    let sum = |c: Color| c.x + c.y + c.z;
    if !(sum(kr) + sum(kt) > 0.0) {
        return GuideStep::Surface(albedo);
    }
    let kind = if sum(kt) > sum(kr) { RayKind::Refraction } else { RayKind::Reflection };
    GuideStep::Specular { dir: fan::Fan::new(si, &m, kind, &mut NoRecord).ideal(), tint: albedo }
}

impl Integrator for Phong {
    fn radiance(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler, stats: &mut RayStats, aov: &mut AovSample) -> Color {
        self.camera(scene, ray, None, sampler, stats, aov, &mut NoRecord)
    }

    fn radiance_from(
        &self,
        scene: &Scene,
        ray: &Ray,
        hit: Option<&Hit>,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        aov: &mut AovSample,
    ) -> Color {
        self.camera(scene, ray, Some(hit), sampler, stats, aov, &mut NoRecord)
    }

    fn radiance_packet(
        &self,
        scene: &Scene,
        rays: &[Ray; PACKET],
        live: u32,
        hits: u32,
        hit: &[Hit; PACKET],
        samplers: &mut [Sampler; PACKET],
        stats: &mut RayStats,
        aovs: &mut [AovSample; PACKET],
        out: &mut [Color; PACKET],
    ) {
        self.camera_block(scene, rays, (live, hits), hit, samplers, stats, aovs, out);
    }

    fn takes_camera_hits(&self) -> bool {
        true
    }

    fn explain(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler) -> Option<TraceNode> {
        explain_recursion(scene, ray, COUNTERS, |stats, aov, root| self.camera(scene, ray, None, sampler, stats, aov, root))
    }

    fn counters(&self) -> &'static [Counter] {
        COUNTERS
    }

    /// The rays of a path tree as the scene's materials and the pruning threshold allow them
    /// ([`Bounces`]): a ray's weight is the product of the coefficients along its path, so with
    /// pruning no branch goes deeper than the depth at which the largest coefficient's powers
    /// fall below the threshold; the weights of one depth's fans sum to at most `gain^depth`,
    /// and with pruning each fan carries at least the threshold, so there are at most
    /// `gain^depth / threshold` of them; a hit has two fans only where a material both reflects
    /// and transmits, and a fan has more than one ray only at a blurred material (at most
    /// `ceil(glossy_rays × w)` for its weight `w`). Every hit takes every light's probes and
    /// samples. With `avoid` off, every hit has both fans and every fan is `glossy_rays` wide.
    fn worst_case_rays(&self, scene: &Scene) -> f64 {
        let per_hit: f64 = scene
            .lights
            .iter()
            .map(|l| {
                let full = if l.is_area() && self.shadow_rays > 0 { self.shadow_rays } else { l.sample_count().max(1) };
                let probes = if l.is_area() && self.shadow_probes < full { self.shadow_probes } else { 0 };
                f64::from(full) + f64::from(probes)
            })
            .sum::<f64>()
            + if scene.emitters().is_empty() { 0.0 } else { f64::from(self.emitter_samples) };
        let b = Bounces::of(scene);
        let g = if b.blurred || !self.avoid { f64::from(self.glossy_rays) } else { 1.0 };
        let fans_per_hit: f64 = if b.splits || !self.avoid { 2.0 } else { 1.0 };
        let p = self.prune_threshold;
        let depth = f64::from(self.max_depth).min(b.reach(p));
        let (mut hits, mut level, mut mass) = (1.0, 1.0, 1.0);
        let mut d = 0.0;
        while d < depth && level > 0.0 {
            mass *= b.gain;
            let fans = if p > 0.0 { (fans_per_hit * level).min(mass / p) } else { fans_per_hit * level };
            level = if g > 1.0 { (g * fans).min(g * mass + fans) } else { fans };
            hits += level;
            d += 1.0;
        }
        hits * (1.0 + per_hit)
    }

    fn describe(&self) -> String {
        let mut s = format!("max_depth {}, prune {}, glossy {}", self.max_depth, self.prune_threshold, self.glossy_rays);
        if self.shadow_rays > 0 {
            s += &format!(", shadow rays {}", self.shadow_rays);
        }
        if self.emitter_samples > 0 {
            s += &format!(", emitter samples {}", self.emitter_samples);
        }
        if self.shadow_probes > 0 {
            s += &format!(", shadow probes {}", self.shadow_probes);
        }
        if !self.avoid {
            s += ", avoid off";
        }
        if self.ambient_first_hit {
            s += ", ambient at the first hit";
        }
        s
    }
}

/// What the scene's materials let a path tree do (textured channels bounded by their
/// constants, texture values being at most 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounces {
    /// The most weight a hit passes on to its reflected and transmitted rays together: the
    /// largest `kr + kt` (each its largest channel), or with Fresnel the largest `max(kr, kt)`
    /// (`F·kr + (1 − F)·kt` is at most that).
    pub gain: f64,
    /// The largest coefficient one child ray gets: the largest `kr` or `kt` (largest channel).
    pub largest: f64,
    /// Some material both reflects and transmits: a hit there splits its ray in two.
    pub splits: bool,
    /// Some material is blurred (`blur > 0`): its fans hold several rays.
    pub blurred: bool,
}

impl Bounces {
    /// What the materials of `scene` allow.
    pub fn of(scene: &Scene) -> Bounces {
        let mut b = Bounces { gain: 0.0, largest: 0.0, splits: false, blurred: false };
        for m in scene.objects.iter().flat_map(|o| o.materials()) {
            let (kr, kt) = (max_channel(m.kr.abs()), max_channel(m.kt.abs()));
            let gain = if m.fresnel == raylab::scene::material::Fresnel::Off { kr + kt } else { kr.max(kt) };
            b.gain = b.gain.max(gain);
            b.largest = b.largest.max(kr).max(kt);
            b.splits |= kr > 0.0 && kt > 0.0;
            b.blurred |= m.blur > 0.0 && kr + kt > 0.0;
        }
        b
    }

    /// The deepest a branch can go under the pruning threshold `p`: a ray at depth `d` weighs at
    /// most `largest^d`, and is traced only if that is at least `p`. Infinite without pruning
    /// or when a coefficient of 1 or more lets a weight keep up.
    pub fn reach(&self, p: f64) -> f64 {
        if !(p > 0.0) || self.largest >= 1.0 {
            return f64::INFINITY;
        }
        if self.largest <= 0.0 {
            return 0.0;
        }
        // The largest whole `d` with `largest^d ≥ p`, safe against rounding of the logarithms.
        let mut d = (p.ln() / self.largest.ln()).floor().max(0.0);
        while self.largest.powf(d + 1.0) >= p {
            d += 1.0;
        }
        while d > 0.0 && self.largest.powf(d) < p {
            d -= 1.0;
        }
        d
    }
}

#[cfg(test)]
mod tests;
