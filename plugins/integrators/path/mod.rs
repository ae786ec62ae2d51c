//! `path`: a unidirectional path tracer with next-event estimation and multiple importance
//! sampling.
//!
//! A camera ray's path scatters at each surface it meets by its material's BSDF
//! ([`raylab::scene::bsdf`]): a material plugin's own model (`pbr`: the glTF BRDF), or for the
//! report's coefficients the energy-conserving
//! [`PhongBsdf`](crate::materials::phong::PhongBsdf) (Lambertian `kd`, normalised Phong
//! `ks`, mirror or glossy `kr`, Fresnel dielectric `kt`). At each vertex with a smooth lobe, every light is sampled with a shadow ray
//! (next-event estimation, [`lights`]), and so are the emitting objects: `light_samples` points
//! (at least one) on emitters chosen by `light_selection` (by power through an alias table, or
//! uniformly), each on its shape's own sampling ([`raylab::Geometry::sample_surface`]: a sphere's
//! visible cone, flat shapes and meshes by area). The scattered ray also collects the lights it
//! meets and the emission of the surface it hits. Where both strategies can find the same light
//! (lights with an extent: `rect`, ball-shaped `point`/`spot`, any light that answers
//! [`raylab::LightSource::intersect`], and every sampled emitter) each is weighed by the power
//! heuristic, the ray's side with the density the light samples at the vertex it left would have
//! had; point, spot and directional lights are found only by sampling, emitters whose shape
//! offers no sampling (planes, tubes, third-party shapes without it) only by rays.
//!
//! How the scene's terms enter a physically based estimate:
//!
//! - **Light intensities** keep the report's convention, in which a white diffuse surface facing
//!   a light shows its intensity: a light sample of intensity `I` is irradiance `π·I`, so `path`
//!   and `phong` agree on direct diffuse light and differ where the models differ.
//! - **Emission** (material `emission`) is radiance, leaving the sides the object's
//!   `emission_sides` names: both by default (raylab's convention, the report's), `front` for
//!   the outward side only (Mitsuba's area emitters, glTF's single-sided materials).
//! - **Ambient lights** are the sky: a ray that leaves the scene after a diffuse or glossy
//!   bounce sees radiance `ambient` (the sum of the ambient lights' `color × ka`) from every
//!   direction. Rays that leave after only specular events (the camera ray, mirrors, glass) see
//!   the `background`, as in `phong`. A material's `ka` has no role: surfaces respond to the sky
//!   through their BRDF, and occluded points get less of it.
//! - **Environment lights** ([`raylab::LightSource::environment`]) are the surroundings: a ray
//!   that leaves the scene meets them like any light with an extent (in full after specular
//!   events, else weighed by MIS against their samples at the vertex it left), and they replace
//!   the background. One of a single radiance all around ([`raylab::LightSource::uniform`]: a
//!   constant colour) is not sampled at all: the BSDF's rays find it in full, which follows the
//!   surface's response × cosine better than any light sampling can (on compare.py's constant
//!   environment, 0.67× the samples for equal error, and no shadow ray). Ambient lights still add
//!   their sky after diffuse or glossy bounces.
//! - **Shadow rays** are blocked by every surface, glass included: light through glass arrives
//!   by refraction (caustics), which light sampling cannot aim at; from point-like lights it
//!   cannot arrive at all, as in every unidirectional path tracer.
//! - **Glass** (a smooth dielectric) reflects or refracts, chosen by the Fresnel term; with
//!   `split_glass` (the default) the branch not taken is followed one ray further: where it
//!   leaves the scene toward a bright part of an environment (the sun), that light counts by the
//!   branch's probability, and the taken branch's ray counts it by its own
//!   ([`PathTracer::other_escape`]): the sun reflected in a glass ball is its expectation in every
//!   sample instead of one sample in 25 worth 25 times its share.
//!
//! `max_bounces` limits the scattering events that light passes through after the first
//! surface: 0 is direct light (the lights and the emitters the first surface sees); the ray
//! scattered at the last vertex still collects the lights it meets, so the two strategies stay
//! balanced there. After `roulette_depth` diffuse or glossy bounces (specular events, which keep
//! the throughput, do not count), at every vertex but the last, Russian roulette ends a path
//! with probability `1 − min(1, throughput)` and reweights the survivors (unbiased).
//!
//! Every random number comes from a stream forked from the camera sample's by vertex and purpose
//! (light samples, lobe choice and direction, roulette, next vertex), so work skipped anywhere
//! never shifts the numbers used elsewhere. At vertices reached after fewer than `stratify` (2)
//! diffuse or glossy bounces each of these numbers is also stratified across the pixel's
//! samples ([`Sampler::pixel_2d`]): the pixel's samples take successive points of one
//! Owen-scrambled Sobol sequence per (vertex, purpose, draw), so every power-of-two prefix of
//! them (a pass, an error target's stop) covers, say, the first surface's light directions
//! evenly. Deeper vertices draw independent numbers: there stratification gains little (their
//! integrand has too many dimensions) for its ~60–100 instructions a draw. The recursion is written once, generic over a
//! [`Recorder`]: [`NoRecord`] renders, a [`TraceNode`] explains. No allocation per ray.

mod lights;

use crate::materials::phong::{PhongBsdf, fresnel_dielectric, with_phong_bsdf};
use raylab::geometry::Hit;
use raylab::geometry::differential::RaySpread;
use raylab::glam::{DVec2, DVec3};
use raylab::math::color::max_channel;
use raylab::param::error::Result;
use raylab::param::params::{Params, from_defaults};
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec, Reference};
use raylab::render::aov::{AovSample, GuideStep};
use raylab::render::integrator::explain_recursion;
use raylab::render::stats::{Counter, CounterKind};
use raylab::render::trace::{NoRecord, Recorder, Term};
use raylab::scene::bsdf::{Bsdf, Lobe, Scatter, with_bsdf};
use raylab::scene::emitters::Selection;
use raylab::scene::interaction::Interaction;
use raylab::{Color, Integrator, LightSource, LoadContext, PluginInfo, Ray, RayKind, RayStats, Sampler, Scene, TraceNode};

pub use lights::{IRRADIANCE_PER_INTENSITY, power_heuristic};

/// The path tracer.
#[derive(Clone, Debug)]
pub struct PathTracer {
    /// Most scattering events light passes through after the first surface (0 = direct light).
    pub max_bounces: u32,
    /// Diffuse or glossy bounces before Russian roulette may end a path (≥ `max_bounces`: never).
    pub roulette_depth: u32,
    /// Shadow rays per light with an extent at each vertex (0: each light's own `samples`).
    pub light_samples: u32,
    /// Whether emitting objects are sampled as lights (off: only rays find them).
    pub sample_emitters: bool,
    /// How an emitter is chosen for each emitter sample.
    pub light_selection: Selection,
    /// The path vertices whose numbers (light and emitter samples, lobe and direction,
    /// roulette) are stratified across the pixel's samples ([`Sampler::pixel_2d`]): those
    /// reached after fewer than this many diffuse or glossy bounces (specular ones do not
    /// count); later ones draw independent numbers (0: all do).
    pub stratify: u32,
    /// At glass, the bright environment the branch not taken sees is counted too
    /// ([`PathTracer::other_escape`]).
    pub split_glass: bool,
}

/// The `path` plugin's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "path",
    summary: "A unidirectional path tracer: an energy-conserving BRDF from the material coefficients (Lambertian kd, normalised Phong ks, mirror or glossy kr, Fresnel dielectric kt), next-event estimation to every light and to emitting objects (chosen by power) with multiple importance sampling, ambient lights as a uniform sky, Russian roulette.",
    params: &[
        ParamSpec::new(
            "max_bounces",
            ParamKind::Int,
            ParamDefault::Int(8),
            "most scattering events light passes through after the first surface (0 = direct light only), 0..1024",
        )
        .depth(Reference::AtLeast(32.0)),
        ParamSpec::new(
            "roulette_depth",
            ParamKind::Int,
            ParamDefault::Int(3),
            "diffuse or glossy bounces (specular ones do not count) before Russian roulette may end a path (survivors are reweighted: no bias, more noise); ≥ max_bounces turns it off, 0..1024",
        )
        .quality(Reference::Keep),
        ParamSpec::new(
            "light_samples",
            ParamKind::Int,
            ParamDefault::Int(1),
            "shadow rays per light with an extent at each path vertex (0 = each light's own `samples`); point-like lights take one, 0..4096",
        )
        .quality(Reference::Keep),
        ParamSpec::new(
            "sample_emitters",
            ParamKind::Bool,
            ParamDefault::Bool(true),
            "sample emitting objects (material emission) as lights at each vertex, weighed against the BSDF's rays by MIS; false: only rays find them",
        )
        .quality(Reference::Keep),
        ParamSpec::new(
            "light_selection",
            ParamKind::Str,
            ParamDefault::Str("power"),
            "how each emitter sample chooses among the emitting objects: \"power\" (emission × area: a dim one among bright ones costs almost nothing) or \"uniform\"",
        )
        .quality(Reference::Keep),
        ParamSpec::new(
            "stratify",
            ParamKind::Int,
            ParamDefault::Int(2),
            "path vertices whose light, emitter, BSDF and roulette numbers are stratified across the pixel's samples (each a padded, Owen-scrambled Sobol sequence over the sample index, as pbrt-v4's samplers do): those reached after fewer than this many diffuse or glossy bounces (specular ones do not count: the first surface and the one after it, seen directly or through glass, by default); later vertices draw independent numbers, where stratification gains little for its cost; 0 = none, 0..1024",
        )
        .quality(Reference::Keep),
        ParamSpec::new(
            "split_glass",
            ParamKind::Bool,
            ParamDefault::Bool(true),
            "at smooth glass, which reflects or refracts by the Fresnel term, also count the environment the branch not taken sees where its ray leaves the scene toward a bright part of it (where its light samples gather: the sun), weighed by that branch's probability, and the taken branch's ray that part by its own: the same mean, and the sun reflected in a glass ball is no longer one sample in 25 worth 25 times its share; false: only the branch taken",
        )
        .quality(Reference::Keep),
    ],
};

/// Builds the integrator from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Box<dyn Integrator>> {
    Ok(Box::new(PathTracer::from_params(p)?))
}

impl PathTracer {
    /// The integrator its parameters describe.
    pub fn from_params(p: &mut Params) -> Result<PathTracer> {
        Ok(PathTracer {
            max_bounces: p.int_in("max_bounces", 0..=1024)? as u32,
            roulette_depth: p.int_in("roulette_depth", 0..=1024)? as u32,
            light_samples: p.int_in("light_samples", 0..=4096)? as u32,
            sample_emitters: p.bool("sample_emitters")?,
            light_selection: Selection::parse(&p.choice("light_selection", &Selection::NAMES)?).unwrap_or_default(),
            stratify: p.int_in("stratify", 0..=1024)? as u32,
            split_glass: p.bool("split_glass")?,
        })
    }
}

/// The defaults of [`INFO`]'s parameter table.
impl Default for PathTracer {
    fn default() -> Self {
        from_defaults("path", INFO.params, PathTracer::from_params)
    }
}

/// The counters of [`COUNTERS`], by index.
pub mod counter {
    /// Shadow rays toward light samples.
    pub const SHADOW_RAYS: usize = 0;
    /// Rays scattered at surfaces.
    pub const BOUNCE_RAYS: usize = 1;
    /// Rays that met a light with an extent.
    pub const LIGHT_HITS: usize = 2;
    /// Rays that left the scene.
    pub const ESCAPED: usize = 3;
    /// Paths ended by Russian roulette.
    pub const ROULETTE_ENDED: usize = 4;
    /// Paths ended at a surface that scatters nothing, or by a direction into the surface.
    pub const ABSORBED: usize = 5;
    /// Paths ended at `max_bounces`.
    pub const DEPTH_LIMITED: usize = 6;
    /// Light samples skipped: the light is behind the surface as seen from the ray.
    pub const LIGHTS_BEHIND: usize = 7;
    /// Light samples skipped: no light arrives (outside a spot's cone, a panel's back).
    pub const LIGHTS_UNREACHABLE: usize = 8;
    /// Light samples skipped: the smooth lobes send nothing toward the light.
    pub const LIGHTS_NO_RESPONSE: usize = 9;
    /// Vertices with only specular lobes, where no light is sampled.
    pub const SPECULAR_VERTICES: usize = 10;
}

/// What `path` counts (printed by `--stats`).
pub const COUNTERS: &[Counter] = &[
    Counter::new("shadow_rays", CounterKind::Rays, "shadow rays"),
    Counter::new("bounce_rays", CounterKind::Rays, "bounce rays"),
    Counter::new("light_hits", CounterKind::Other, "rays meeting an area light"),
    Counter::new("escaped", CounterKind::Other, "rays leaving the scene"),
    Counter::new("roulette_ended", CounterKind::Other, "paths ended by roulette"),
    Counter::new("absorbed", CounterKind::Other, "paths absorbed"),
    Counter::new("depth_limited", CounterKind::Other, "limited: max bounces"),
    Counter::new("lights_behind", CounterKind::Avoided, "avoided: light behind surface"),
    Counter::new("lights_unreachable", CounterKind::Avoided, "avoided: no light arrives"),
    Counter::new("lights_no_response", CounterKind::Avoided, "avoided: no response to light"),
    Counter::new("specular_vertices", CounterKind::Avoided, "avoided: samples at specular"),
];

/// Sampler tags: each purpose at a vertex draws from its own stream.
const TAG_LIGHTS: u64 = 1;
const TAG_BSDF: u64 = 2;
const TAG_ROULETTE: u64 = 3;
const TAG_NEXT: u64 = 4;
const TAG_EMITTERS: u64 = 5;

/// What one camera ray's path shares: the scene and the counters, and what the camera ray
/// itself met emitted (the emission layer, [`AovSample::emitted`]).
struct Ctx<'a> {
    scene: &'a Scene,
    stats: &'a mut RayStats,
    emitted: Color,
    /// The camera ray's first surface has its branches followed together
    /// ([`PathTracer::specular_emission`]).
    split: bool,
}

/// The state a ray carries from the vertex that sent it, and its own random stream. Passed by
/// reference down the recursion (it is ~200 bytes with its spread: not copied at each call).
#[derive(Clone, Copy, Debug)]
struct PathState<'s> {
    /// The ray's random stream.
    sampler: &'s Sampler,
    /// Scattering events before this ray (0 for the camera ray).
    depth: u32,
    /// Those of them by a smooth (diffuse or glossy) lobe: Russian roulette counts only these.
    smooth_depth: u32,
    /// Throughput: how much the radiance this ray brings back counts in the pixel.
    beta: Color,
    /// Product of (η_t/η_i)² over the refractions so far: undoes their radiance scaling for
    /// Russian roulette, so paths through glass are not ended for it.
    eta_scale: f64,
    /// Density with which the previous vertex sampled this ray; `None` for the camera ray and
    /// after specular events (lights it meets then count in full).
    bsdf_pdf: Option<f64>,
    /// Only specular events so far: a ray that leaves the scene sees the background, not the sky.
    specular: bool,
    /// The camera ray's first surface was split ([`PathTracer::specular_emission`]) and this is
    /// the ray it sent: the lights it meets before a surface and that surface's emission were
    /// counted there, as their expectation.
    counted: bool,
    /// What the bright part of an environment this ray meets when it leaves the scene counts
    /// for: 1, or after glass the probability of the branch it took, the other branch's having
    /// been counted there ([`PathTracer::other_escape`]).
    escape_scale: f64,
    /// The point of the vertex that sent this ray (the camera ray: its origin): where its light
    /// samples were taken from, so an emitter it meets is weighed with the same density.
    from: DVec3,
    /// The ray's spread over the image, for texture footprints: the camera ray's differential,
    /// carried through specular events; after a diffuse or glossy one, the camera's approximation.
    spread: RaySpread,
}

impl<'s> PathState<'s> {
    /// The state of camera ray `ray` of `scene`, with its stream `sampler`.
    fn camera(ray: &Ray, sampler: &'s Sampler, scene: &Scene) -> Self {
        PathState {
            sampler,
            depth: 0,
            smooth_depth: 0,
            beta: Color::ONE,
            eta_scale: 1.0,
            bsdf_pdf: None,
            specular: true,
            counted: false,
            escape_scale: 1.0,
            from: ray.origin,
            spread: scene.camera_spread(ray),
        }
    }
}

impl PathTracer {
    /// The BSDF's numbers at a vertex after `depth` diffuse or glossy bounces (lobe choice,
    /// direction, Fresnel choice), from `sampler`'s [`TAG_BSDF`] stream. Out of line: the
    /// recursion's stack frames (1024 bounces on a render thread's default stack) stay as small
    /// as they were.
    /// Only the numbers the BSDF reads (`draws`) are computed; the others are passed over
    /// ([`Sampler::skip_1d`]) and given as 0.5, which the BSDF does not read: the same scatter.
    /// The stream is forked in each branch of [`PathTracer::stratify`]'s choice: a pixel draw
    /// reads only the fork's chain and a plain one only its key, so each computes only its own.
    #[inline(never)]
    fn bsdf_numbers(&self, depth: u32, sampler: &Sampler, draws: Draws) -> (f64, DVec2, f64) {
        const UNREAD: f64 = 0.5;
        if !(draws.pick || draws.dir || draws.fresnel) {
            return (UNREAD, DVec2::splat(UNREAD), UNREAD);
        }
        /// The numbers from `stream` by `draw_1d` and `draw_2d` (as [`PathTracer::draw_1d`]
        /// and [`PathTracer::draw_2d`] choose them).
        #[inline(always)]
        fn numbers(
            mut stream: Sampler,
            draws: Draws,
            draw_1d: impl Fn(&mut Sampler) -> f64,
            draw_2d: impl Fn(&mut Sampler) -> DVec2,
        ) -> (f64, DVec2, f64) {
            let pick = if draws.pick { draw_1d(&mut stream) } else { skip(&mut stream, 1, UNREAD) };
            let u = if draws.dir { draw_2d(&mut stream) } else { DVec2::splat(skip(&mut stream, 2, UNREAD)) };
            let fresnel = if draws.fresnel { draw_1d(&mut stream) } else { UNREAD };
            (pick, u, fresnel)
        }
        if depth < self.stratify {
            numbers(sampler.fork(TAG_BSDF), draws, Sampler::pixel_1d, Sampler::pixel_2d)
        } else {
            numbers(sampler.fork(TAG_BSDF), draws, Sampler::next_1d, Sampler::next_2d)
        }
    }

    /// The roulette's number at a vertex after `depth` diffuse or glossy bounces (out of line,
    /// as [`PathTracer::bsdf_numbers`]).
    #[inline(never)]
    fn roulette_number(&self, depth: u32, sampler: &Sampler) -> f64 {
        // Forked in each branch, as there.
        if depth < self.stratify { sampler.fork(TAG_ROULETTE).pixel_1d() } else { sampler.fork(TAG_ROULETTE).next_1d() }
    }

    /// The next number of `stream`, at a vertex after `depth` diffuse or glossy bounces:
    /// stratified across the pixel's samples there when [`PathTracer::stratify`] says, else
    /// independent (the same draws counted either way).
    #[inline(always)]
    fn draw_1d(&self, depth: u32, stream: &mut Sampler) -> f64 {
        if depth < self.stratify { stream.pixel_1d() } else { stream.next_1d() }
    }

    /// The next pair of `stream`, as [`PathTracer::draw_1d`].
    #[inline(always)]
    fn draw_2d(&self, depth: u32, stream: &mut Sampler) -> DVec2 {
        if depth < self.stratify { stream.pixel_2d() } else { stream.next_2d() }
    }

    /// Radiance arriving along `ray` (its state and stream `path`), spawned off the hit `from`.
    fn li<R: Recorder>(&self, c: &mut Ctx, ray: &Ray, from: &Hit, path: &PathState, rec: &mut R) -> Color {
        // The surface the ray leaves is not asked again where it is flat (the same hit).
        let mut hit = c.scene.trace_leaving(ray, from);
        set_spread(c.scene, &mut hit, &path.spread);
        match hit.as_ref().filter(|_| path.depth <= self.max_bounces) {
            Some(si) => at_bsdf(si, |bsdf, draws| self.arrive(c, ray, Some(si), Some((bsdf, draws)), path, rec)),
            None => self.arrive(c, ray, hit.as_ref(), None, path, rec),
        }
    }

    /// Radiance arriving along `ray`, which meets `hit` (or leaves the scene): the lights met on
    /// the way, then the surface's emission, and, given the hit's `bsdf` (`None`: the path is
    /// at its bounce limit), its light samples and its scattered ray.
    fn arrive<R: Recorder>(
        &self,
        c: &mut Ctx,
        ray: &Ray,
        hit: Option<&Interaction>,
        bsdf: Option<(&dyn Bsdf, Draws)>,
        path: &PathState,
        rec: &mut R,
    ) -> Color {
        let t_hit = hit.map_or(f64::INFINITY, |si| si.hit.t);
        let counted = path.counted && hit.is_some();
        let mut radiance = if counted { Color::ZERO } else { self.emitters(c, ray, t_hit, path.bsdf_pdf, path.escape_scale, rec) };
        let Some(si) = hit else {
            c.stats.add(counter::ESCAPED, 1);
            // An environment light replaces the background: it was met above, like any light.
            let (name, sky) = match (path.specular, c.scene.has_environment()) {
                (true, false) => ("background", c.scene.background),
                (true, true) => ("background (an environment light instead)", Color::ZERO),
                (false, _) => ("ambient sky", c.scene.ambient),
            };
            if sky != Color::ZERO || !c.scene.has_environment() {
                rec.term(|| Term::color(name, sky));
            }
            radiance += sky;
            rec.color(radiance);
            return radiance;
        };
        rec.hit(si);
        if !counted {
            radiance += self.emission(c, path.from, si, path.bsdf_pdf, rec);
        }
        if path.depth == 0 {
            c.emitted = radiance;
        }
        if let Some((bsdf, draws)) = bsdf {
            radiance += self.direct(c, si, bsdf, (path.sampler, path.smooth_depth), rec);
            radiance += self.scatter(c, si, (bsdf, draws), path, rec);
        } else {
            c.stats.add(counter::DEPTH_LIMITED, 1);
            rec.note(|| format!("max_bounces {} reached: only the emitters this ray meets count", self.max_bounces));
        }
        rec.color(radiance);
        radiance
    }

    /// The light brought back by one ray scattered at `si` by `bsdf`, times its weight; zero
    /// when the path ends here (absorbed, or by Russian roulette).
    fn scatter<R: Recorder>(
        &self,
        c: &mut Ctx,
        si: &Interaction,
        (bsdf, draws): (&dyn Bsdf, Draws),
        path: &PathState,
        rec: &mut R,
    ) -> Color {
        let sampler = path.sampler;
        let d = path.smooth_depth;
        let (pick, u, fresnel) = self.bsdf_numbers(d, sampler, draws);
        let Some(s) = bsdf.sample(pick, u, fresnel) else {
            c.stats.add(counter::ABSORBED, 1);
            rec.note(|| "absorbed: the surface scatters nothing in the sampled direction".into());
            return Color::ZERO;
        };
        let mut weight = s.weight;
        let (escaped, escape_scale) =
            if s.pdf.is_none() && self.split_glass && draws.fresnel && c.scene.light_facts().iter().any(|f| f.environment && !f.uniform) {
                self.other_escape(c, si, (bsdf, draws), &s)
            } else {
                (Color::ZERO, 1.0)
            };
        if escaped != Color::ZERO {
            rec.term(|| Term::color("the branch not taken leaves the scene: its sky × its probability", escaped));
        }
        let eta_scale = path.eta_scale * s.eta_squared;
        rec.note(|| format!("scatters by the {} lobe{}", s.lobe.name(), if s.pdf.is_none() { " (specular)" } else { "" }));
        rec.term(|| Term::color("bsdf·cos/pdf", s.weight));
        if let Some(q) = s.pdf {
            rec.term(|| Term::number("bsdf pdf", q));
        }
        // The last vertex's ray only collects emitters: no roulette there.
        // Specular events (mirrors, glass) keep the throughput: only smooth ones count toward
        // `roulette_depth`, so a surface seen through glass is not gambled on sooner.
        if path.smooth_depth >= self.roulette_depth && path.depth < self.max_bounces {
            let survive = (max_channel(path.beta * weight) * eta_scale).min(1.0);
            if !(self.roulette_number(d, sampler) < survive) {
                c.stats.add(counter::ROULETTE_ENDED, 1);
                rec.note(|| format!("Russian roulette ends the path (survival probability {survive:.4})"));
                // The branch not taken was counted at this vertex, before the gamble: it stays.
                return escaped;
            }
            weight /= survive;
            rec.term(|| Term::number("survival", survive));
        }
        c.stats.add(counter::BOUNCE_RAYS, 1);
        let ray = si.spawn_ray(s.dir);
        let next_sampler = sampler.fork(TAG_NEXT);
        let next = PathState {
            sampler: &next_sampler,
            depth: path.depth + 1,
            smooth_depth: path.smooth_depth + u32::from(s.pdf.is_some()),
            beta: path.beta * weight,
            eta_scale,
            bsdf_pdf: s.pdf,
            specular: path.specular && s.pdf.is_none(),
            counted: path.depth == 0 && c.split,
            escape_scale,
            from: si.point(),
            // Spreads are all `Off` where the scene filters no texture: nothing to carry.
            spread: match (s.pdf, s.kind) {
                _ if !c.scene.filters_textures() => RaySpread::Off,
                (None, RayKind::Refraction) => si.refracted_spread(s.dir, 1.0 / s.eta_squared.sqrt()),
                (None, _) => si.reflected_spread(s.dir),
                (Some(_), _) => c.scene.scattered_spread(si.spread),
            },
        };
        let mut child = rec.child(s.kind, &ray, next.depth, next.beta);
        let li = self.li(c, &ray, &si.hit, &next, &mut child);
        rec.adopt(child);
        weight * li + escaped
    }

    /// At glass (a surface whose only event is a reflection or a refraction, chosen by the Fresnel
    /// term) where the path took `s`: what the branch not taken sees of the environments' bright
    /// parts ([`split_radiance`]) if its ray leaves the scene, times its probability and weight,
    /// and the share of those parts the taken branch's ray counts if it leaves (its probability).
    /// Each branch's escape toward the sun then counts as its expectation, whichever branch the
    /// path took: same mean, and the sun reflected in a glass ball (4 % of the samples, each
    /// worth 25 times its share) no longer varies. Where the branches' values are alike (the dim
    /// sky) splitting would add variance (they are anticorrelated): those escapes stay unsplit.
    /// Costs a shadow-like ray per glass vertex, none for a branch into the inside of a solid
    /// (it meets the solid again). `(0, 1)` where there is nothing to split.
    #[inline(never)]
    fn other_escape(&self, c: &mut Ctx, si: &Interaction, (bsdf, draws): (&dyn Bsdf, Draws), s: &Scatter) -> (Color, f64) {
        const NONE: (Color, f64) = (Color::ZERO, 1.0);
        let scene = c.scene;
        // Glass alone ([`PhongBsdf::numbers_read`]: only the Fresnel number): its other branch is
        // at the other end of that number, its probability the Fresnel term (the model built
        // again here, at glass only, so the vertices' `Draws` stay three flags).
        let glass = if !draws.pick && !draws.dir && si.model().is_none() { PhongBsdf::new(si).dielectric_branches() } else { None };
        let (taken, other, closed) = match glass {
            Some((reflect, closed)) => {
                let reflected = s.kind == RayKind::Reflection;
                match bsdf.sample(0.5, DVec2::splat(0.5), if reflected { BELOW_ONE } else { 0.0 }) {
                    Some(o) if o.kind != s.kind => (if reflected { reflect } else { 1.0 - reflect }, o, closed),
                    _ => return NONE,
                }
            }
            // Any other model: its branches found by probing (none where it has smooth lobes).
            None => {
                let Some((b, 2)) = delta_branches(bsdf, -si.dir) else { return NONE };
                match (b[0].1.dir == s.dir, b[1].1.dir == s.dir) {
                    (true, false) => (b[0].0, b[1].1, false),
                    (false, true) => (b[1].0, b[0].1, false),
                    _ => return NONE,
                }
            }
        };
        let outward = if si.front_face { si.n } else { -si.n };
        if closed && !(other.dir.dot(outward) > 0.0) {
            return (Color::ZERO, taken);
        }
        let ray = si.spawn_ray(other.dir);
        if scene.occludes_leaving(&ray, f64::INFINITY, &si.hit) {
            return (Color::ZERO, taken);
        }
        let mut seen = Color::ZERO;
        for (light, facts) in scene.lights.iter().zip(scene.light_facts()) {
            if facts.environment && !facts.uniform {
                seen += split_radiance(light.as_ref(), ray.origin, other.dir).unwrap_or(Color::ZERO);
            }
        }
        ((1.0 - taken) * other.weight * seen, taken)
    }

    /// The whole path of a camera ray, recorded into `rec`; `aov` gets the first surface.
    fn camera<R: Recorder>(
        &self,
        scene: &Scene,
        ray: &Ray,
        sampler: &Sampler,
        stats: &mut RayStats,
        aov: &mut AovSample,
        rec: &mut R,
    ) -> Color {
        let c = &mut Ctx { scene, stats, emitted: Color::ZERO, split: false };
        let path = &PathState::camera(ray, sampler, scene);
        let mut hit = scene.trace(ray);
        set_spread(scene, &mut hit, &path.spread);
        // A camera ray is always within the bounce limit (depth 0).
        let color = match &hit {
            Some(si) => at_bsdf(si, |bsdf, draws| {
                aov.set_surface(si, bsdf.albedo());
                aov.look_through(scene, si, |s| at_bsdf(s, |b, _| guide_step(b)));
                // With the guides, what a mirror or glass shows of the emitters is counted as its
                // expectation, into the emission layer.
                let branches = if aov.guides { delta_branches(bsdf, -ray.dir) } else { None };
                c.split = branches.is_some();
                let color = self.arrive(c, ray, Some(si), Some((bsdf, draws)), path, rec);
                let Some(branches) = branches else { return color };
                let seen = self.specular_emission(c, si, &branches);
                c.emitted += seen;
                color + seen
            }),
            None => {
                aov.escape(scene, ray.dir);
                self.arrive(c, ray, None, None, path, rec)
            }
        };
        aov.emitted = c.emitted;
        color
    }
}

/// Gives the hit the incoming ray's `spread` where `scene` filters textures; elsewhere every
/// spread is `Off`, as the hit's already is, and nothing is copied.
#[inline(always)]
fn set_spread(scene: &Scene, hit: &mut Option<Interaction>, spread: &RaySpread) {
    if scene.filters_textures()
        && let Some(si) = hit
    {
        si.spread = *spread;
    }
}

/// What `bsdf` is to the denoiser's guides ([`AovSample::look_through`]): a surface with smooth
/// lobes stops them; one with only specular events sends them on its most likely one (the median
/// of each choice: the heavier lobe, glass's larger Fresnel branch), tinted by its albedo. Two
/// directions drawn with different numbers agree only for a delta event: a blurred one (frosted
/// glass) stops the guides too.
fn guide_step(bsdf: &dyn Bsdf) -> GuideStep {
    let albedo = bsdf.albedo();
    if bsdf.has_smooth_lobes() {
        return GuideStep::Surface(albedo);
    }
    match (bsdf.sample(0.5, DVec2::splat(0.25), 0.5), bsdf.sample(0.5, DVec2::splat(0.75), 0.5)) {
        (Some(a), Some(b)) if a.pdf.is_none() && a.dir == b.dir => GuideStep::Specular { dir: a.dir, tint: albedo },
        _ => GuideStep::Surface(albedo),
    }
}

impl PathTracer {
    /// The emitters a camera ray sees through its first surface `si` when that surface only
    /// reflects or refracts specularly, as their expectation: its `branches` ([`delta_branches`]:
    /// glass's reflection and refraction) followed together, weighed by their probabilities,
    /// each counting the lights its ray meets before the surface it hits and that surface's
    /// emission, in full (no light sample finds them), and nothing where it leaves the scene (the
    /// sky stays sampled). The camera ray's own path leaves out what it would have met there at
    /// random ([`PathState::counted`]): the same mean, without the noise of the branch choice.
    /// A render that takes the denoiser's guides does this and puts it in the emission layer,
    /// which the denoiser leaves out of its filter: the lamp a glass ball reflects is no longer
    /// a few bright sub-pixels the filter takes for fireflies (`benches/error/RESULTS.md`).
    fn specular_emission(&self, c: &mut Ctx, si: &Interaction, branches: &Branches) -> Color {
        let mut total = Color::ZERO;
        for &(p, s) in &branches.0[..branches.1] {
            let ray = si.spawn_ray(s.dir);
            let spread = match s.kind {
                RayKind::Refraction => si.refracted_spread(s.dir, 1.0 / s.eta_squared.sqrt()),
                _ => si.reflected_spread(s.dir),
            };
            let Some(hit) = c.scene.trace(&ray).map(|h| h.with_spread(spread)) else { continue };
            let seen =
                self.emitters(c, &ray, hit.hit.t, None, 1.0, &mut NoRecord) + self.emission(c, si.point(), &hit, None, &mut NoRecord);
            total += p * s.weight * seen;
        }
        total
    }
}

/// A specular surface's branches, each with its probability, and how many there are
/// ([`delta_branches`]).
type Branches = ([(f64, Scatter); 2], usize);

/// Halvings that place the boundary between two branches where the Fresnel term does not
/// (a thin slab): 2⁻⁴⁰ of the range of the numbers.
const BRANCH_BISECTIONS: u32 = 40;

/// How far either side of the Fresnel term the two branches are checked
/// ([`delta_branches`]): the boundary is placed within it.
const BRANCH_MARGIN: f64 = 1e-10;

/// The largest number below 1 (the numbers are in [0, 1)).
const BELOW_ONE: f64 = 1.0 - f64::EPSILON / 2.0;

/// The branches of a surface that only reflects or refracts specularly, seen along `-wo`, each
/// with its probability: one (a mirror, total internal reflection), or two (glass), the
/// reflection for `fresnel` below a boundary and the refraction above it, the boundary found at
/// the Fresnel term (checked on both sides) or else by halving. Its lobe choice `pick` must not
/// matter and its `u` must not move the direction. `None` for any other surface (smooth lobes,
/// a blurred direction, lobes to choose from): its events are not split.
fn delta_branches(bsdf: &dyn Bsdf, wo: DVec3) -> Option<Branches> {
    if bsdf.has_smooth_lobes() {
        return None;
    }
    let (u0, u1) = (DVec2::splat(0.25), DVec2::splat(0.75));
    let key = |s: &Option<Scatter>| s.map(|s| (s.dir.to_array().map(f64::to_bits), s.weight.to_array().map(f64::to_bits), s.pdf.is_none()));
    let at = |f: f64| bsdf.sample(0.5, u0, f);
    let (first, last) = (at(0.0), at(BELOW_ONE));
    for (f, s) in [(0.0, &first), (BELOW_ONE, &last)] {
        let same = |pick: f64| key(&bsdf.sample(pick, u1, f)) == key(s);
        if s.is_some_and(|s| s.pdf.is_some()) || !same(0.0) || !same(BELOW_ONE) {
            return None;
        }
    }
    let empty = Scatter { dir: DVec3::Z, weight: Color::ZERO, pdf: None, lobe: Lobe::Mirror, kind: RayKind::Reflection, eta_squared: 1.0 };
    let mut out = ([(0.0, empty); 2], 0);
    let mut push = |p: f64, s: Option<Scatter>| {
        if let Some(s) = s {
            out.0[out.1] = (p, s);
            out.1 += 1;
        }
    };
    if key(&first) == key(&last) {
        push(1.0, first);
        return Some(out);
    }
    let (below, above) = (key(&first), key(&last));
    // Glass reflects for `fresnel` below its Fresnel term: try it, from the two directions.
    let guess = match (first, last) {
        (Some(r), Some(t)) if r.kind == RayKind::Reflection && t.kind == RayKind::Refraction => {
            let m = (r.dir + wo).normalize_or_zero();
            fresnel_dielectric(wo.dot(m), t.eta_squared.sqrt())
        }
        _ => f64::NAN,
    };
    let boundary = if guess.is_finite() && key(&at(guess - BRANCH_MARGIN)) == below && key(&at(guess + BRANCH_MARGIN)) == above {
        guess
    } else {
        let (mut a, mut b) = (0.0, BELOW_ONE);
        for _ in 0..BRANCH_BISECTIONS {
            let m = 0.5 * (a + b);
            if key(&at(m)) == below { a = m } else { b = m }
        }
        b
    };
    push(boundary, first);
    push(1.0 - boundary, last);
    Some(out)
}

/// `f` of the BSDF at `si` and the numbers its sampling reads: its material's model's (all
/// of them), or the coefficients' ([`with_phong_bsdf`]; a lone diffuse
/// lobe's as a [`LambertBsdf`](crate::materials::phong::LambertBsdf), the same answers).
#[inline]
fn at_bsdf<T>(si: &Interaction, f: impl FnOnce(&dyn Bsdf, Draws) -> T) -> T {
    match si.model() {
        Some(m) => with_bsdf(m, si, |b| f(b, Draws::ALL)),
        None => with_phong_bsdf(si, |bsdf, (pick, dir, fresnel)| f(bsdf, Draws { pick, dir, fresnel })),
    }
}

/// Which of [`Bsdf::sample`]'s numbers a vertex's BSDF reads: the lobe choice, the direction's
/// pair, the Fresnel choice. The path tracer computes only these ([`PathTracer::bsdf_numbers`]).
#[derive(Clone, Copy, Debug)]
struct Draws {
    pick: bool,
    dir: bool,
    fresnel: bool,
}

impl Draws {
    /// Every number (a material model's BSDF, which does not say).
    const ALL: Draws = Draws { pick: true, dir: true, fresnel: true };
}

/// The radiance of environment `light` along `dir` from `origin` when a ray leaving the scene
/// there has its escape split ([`PathTracer::other_escape`]): where the light's density for MIS
/// is above the uniform one (its light samples gather there: the sun, its glow); `None`
/// elsewhere (the dim sky, whose split would cost more variance than it saves: the branches'
/// values are anticorrelated).
#[inline]
pub(crate) fn split_radiance(light: &dyn LightSource, origin: DVec3, dir: DVec3) -> Option<Color> {
    let (radiance, p) = light.environment_pdf(origin, dir)?;
    (p > SPLIT_DENSITY).then_some(radiance)
}

/// See [`split_radiance`]: the density over the sphere of directions drawn uniformly.
const SPLIT_DENSITY: f64 = 1.0 / (4.0 * std::f64::consts::PI);

/// Passes `stream` over `n` numbers ([`Sampler::skip_1d`]) and returns `unread`.
#[inline(always)]
fn skip(stream: &mut Sampler, n: u32, unread: f64) -> f64 {
    for _ in 0..n {
        stream.skip_1d();
    }
    unread
}

impl Integrator for PathTracer {
    fn radiance(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler, stats: &mut RayStats, aov: &mut AovSample) -> Color {
        self.camera(scene, ray, sampler, stats, aov, &mut NoRecord)
    }

    fn explain(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler) -> Option<TraceNode> {
        explain_recursion(scene, ray, COUNTERS, |stats, aov, root| self.camera(scene, ray, sampler, stats, aov, root))
    }

    fn counters(&self) -> &'static [Counter] {
        COUNTERS
    }

    /// A path is a chain: the camera ray and at most `max_bounces + 1` scattered rays, and at
    /// each of its `max_bounces + 1` vertices with light samples every light's shadow rays.
    fn worst_case_rays(&self, scene: &Scene) -> f64 {
        let mut shadow: f64 = scene.light_facts().iter().map(|&l| f64::from(self.samples_for(l))).sum();
        if self.samples_emitters(scene) {
            shadow += f64::from(self.emitter_samples());
        }
        let vertices = f64::from(self.max_bounces) + 1.0;
        1.0 + vertices * (1.0 + shadow)
    }

    fn describe(&self) -> String {
        let roulette = if self.roulette_depth >= self.max_bounces { "off".to_string() } else { format!("after {}", self.roulette_depth) };
        let samples = if self.light_samples == 0 { "the lights' own".to_string() } else { self.light_samples.to_string() };
        let emitters = match (self.sample_emitters, self.light_selection) {
            (false, _) => "found by rays only",
            (true, Selection::Power) => "sampled by power",
            (true, Selection::Uniform) => "sampled uniformly",
        };
        format!("max_bounces {}, roulette {roulette}, light samples {samples}, emitters {emitters}", self.max_bounces)
    }
}

#[cfg(test)]
mod emitter_tests;
#[cfg(test)]
mod tests;
