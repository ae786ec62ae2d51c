//! Light at a path vertex from the scene's lights: next-event estimation (a shadow ray toward a
//! sample of each light) and the lights a sampled ray meets on its way, the two strategies
//! weighed against each other by the power heuristic where both can find the same light.

use super::{Ctx, PathTracer, TAG_EMITTERS, TAG_LIGHTS, counter};
use raylab::glam::DVec3;
use raylab::math::color::max_channel;
use raylab::math::float::SHADOW_EPSILON;
use raylab::math::sampler::stratified_2d;
use raylab::render::trace::{Recorder, Term, TraceLight};
use raylab::scene::bsdf::Bsdf;
use raylab::scene::emitters::EmitterSample;
use raylab::scene::interaction::Interaction;
use raylab::scene::light::LightFacts;
use raylab::{Color, Intersectable, LightPdf, LightSample, LightSource, Ray, Sampler, Scene};
use std::f64::consts::PI;

/// Irradiance per unit of a light's `intensity`. raylab's lights follow the report: a white
/// diffuse surface facing a light shows the light's intensity (`phong`: kd·(n·l)·I). Under the
/// Lambertian BRDF kd/π that is irradiance π·I, so both integrators agree on direct diffuse light.
pub const IRRADIANCE_PER_INTENSITY: f64 = PI;

/// The power heuristic (Veach 1997, β = 2): the weight of a sample drawn with density `a` when
/// another strategy would draw it with density `b` (each already times its sample count).
/// Finite for any non-negative densities, infinite ones included: `w(a, b) + w(b, a) = 1`.
#[inline]
pub fn power_heuristic(a: f64, b: f64) -> f64 {
    if !(a > 0.0) {
        return 0.0;
    }
    let r = b / a;
    let w = 1.0 / (1.0 + r * r);
    if w.is_nan() { 0.5 } else { w }
}

/// A path vertex whose direct light is estimated: the hit and its BSDF.
#[derive(Clone, Copy)]
struct Vertex<'a> {
    si: &'a Interaction<'a>,
    bsdf: &'a dyn Bsdf,
}

/// Where a sample at a vertex comes from.
#[derive(Clone, Copy)]
enum Source {
    /// The scene's light of this index.
    Light(usize),
    /// The emitting object of this index.
    Emitter(u32),
}

/// What the trace of one light or emitter sample shows whatever became of it.
struct Traced<'a> {
    scene: &'a Scene,
    source: Source,
    dir: DVec3,
    distance: f64,
    intensity: Color,
    cos: f64,
}

impl Traced<'_> {
    /// The sample's record: `skipped` (why, or `None` when its shadow ray was traced), whether
    /// the light was `visible`, the `occluder` if not, its `terms`.
    fn record(&self, skipped: Option<&str>, visible: bool, occluder: Option<u32>, terms: &[Term]) -> TraceLight {
        let scene = self.scene;
        TraceLight {
            light: match self.source {
                Source::Light(index) => scene.light_names[index].clone(),
                Source::Emitter(object) => format!("emitter {}", scene.object_name(object)),
            },
            dir: self.dir,
            distance: self.distance,
            intensity: self.intensity,
            n_dot_l: self.cos,
            transmittance: if visible { Color::ONE } else { Color::ZERO },
            occluder: occluder.map(|o| scene.object_name(o).to_string()),
            terms: terms.to_vec(),
            skipped: skipped.map(str::to_string),
        }
    }
}

impl PathTracer {
    /// Shadow rays per sample of `light` at a vertex: [`PathTracer::light_samples`] for lights
    /// with an extent (0: the light's own count), one for point-like lights.
    pub(super) fn samples_for(&self, facts: LightFacts) -> u32 {
        match (facts.is_area, self.light_samples) {
            (false, _) => 1,
            (true, 0) => facts.sample_count.max(1),
            (true, n) => n,
        }
    }

    /// Emitter samples at each vertex: [`PathTracer::light_samples`] (at least one).
    pub(super) fn emitter_samples(&self) -> u32 {
        self.light_samples.max(1)
    }

    /// Whether this path tracer samples `scene`'s emitting objects as lights.
    pub(super) fn samples_emitters(&self, scene: &Scene) -> bool {
        self.sample_emitters && !scene.emitters().is_empty()
    }

    /// Next-event estimation at `si`: every light sampled, each sample's contribution through
    /// the smooth lobes of `bsdf`, weighed against `bsdf`'s own sampling when the light has an
    /// extent; then the emitting objects, [`PathTracer::emitter_samples`] points chosen among
    /// them by [`PathTracer::light_selection`], each weighed against `bsdf`'s sampling.
    /// `sampler` is the vertex's stream, `depth` its diffuse or glossy bounces so far. Out of
    /// line, so its streams and samples are not part of every frame of the path's recursion.
    #[inline(never)]
    pub(super) fn direct<R: Recorder>(
        &self,
        c: &mut Ctx,
        si: &Interaction,
        bsdf: &dyn Bsdf,
        (sampler, depth): (&Sampler, u32),
        rec: &mut R,
    ) -> Color {
        let scene = c.scene;
        if !bsdf.has_smooth_lobes() {
            if !scene.lights.is_empty() || self.samples_emitters(scene) {
                c.stats.add(counter::SPECULAR_VERTICES, 1);
                rec.note(|| "only specular lobes here: no light samples (lights are found by the scattered ray)".into());
            }
            return Color::ZERO;
        }
        let v = Vertex { si, bsdf };
        let facts = scene.light_facts();
        let mut total = Color::ZERO;
        // Nothing to sample (no lights, or only uniform ones: a constant environment) and nothing
        // to explain: no streams, and none of the loop's set-up.
        let lights = if R::ON || facts.iter().any(|f| !f.uniform) { scene.lights.as_slice() } else { &[] };
        let streams = if lights.is_empty() { sampler.clone() } else { sampler.fork(TAG_LIGHTS) };
        for (index, light) in lights.iter().enumerate() {
            if facts[index].uniform {
                rec.note(|| {
                    format!("{}: one radiance all around: found by the BSDF's ray, in full (no light sample)", scene.light_names[index])
                });
                continue;
            }
            let n = self.samples_for(facts[index]);
            let mut stream = streams.fork(index as u64);
            // A single sample needs no pattern: its number is skipped, not drawn (the same
            // numbers after it).
            let pattern = if n > 1 {
                stream.next_pattern()
            } else {
                stream.skip_1d();
                0
            };
            let mut sum = Color::ZERO;
            for s in 0..n {
                // One sample: stratified across the pixel's samples (as `stratify` says); several:
                // across each other at this vertex.
                let u = if n == 1 { self.draw_2d(depth, &mut stream) } else { stratified_2d(s, n, pattern) };
                // No direction here (an ambient light): its light comes from escaping rays. An
                // environment says the density it drew with (finding it again from the direction
                // costs a turn and a lookup); other lights are asked only for samples that count.
                let sample = if facts[index].environment {
                    // Lit from `n`'s side only: a sample behind is skipped below, unseen (the
                    // explanation shows what it would have brought). Weighed against the BSDF's
                    // rays: drawn by the light's density for MIS (an image's above its mean).
                    let drawn = light.illuminate_mis(si.point(), (!R::ON).then_some(si.n), u);
                    drawn.map(|(ls, pdf)| (ls, Some(pdf)))
                } else {
                    light.illuminate(si.point(), u).map(|ls| (ls, None))
                };
                let Some((ls, pdf)) = sample else { break };
                sum += self.light_sample(c, v, (index, light.as_ref()), (&ls, pdf), n, rec);
            }
            total += sum / f64::from(n);
        }
        if self.samples_emitters(scene) {
            let n = self.emitter_samples();
            let mut stream = sampler.fork(TAG_EMITTERS);
            // One sample (the default): no loop, and its value as it is (the same bits as
            // divided by one).
            total += if n == 1 {
                self.emitter_draw(c, v, (&mut stream, depth), n, rec)
            } else {
                (0..n).fold(Color::ZERO, |sum, _| sum + self.emitter_draw(c, v, (&mut stream, depth), n, rec)) / f64::from(n)
            };
        }
        total
    }

    /// One of the `n` emitter samples at a vertex, its numbers from `stream` (before dividing
    /// by `n`): an emitter chosen by [`PathTracer::light_selection`], a point of it, its
    /// contribution.
    #[inline(always)]
    fn emitter_draw<R: Recorder>(&self, c: &mut Ctx, v: Vertex, (stream, depth): (&mut Sampler, u32), n: u32, rec: &mut R) -> Color {
        let scene = c.scene;
        let emitters = scene.emitters();
        // A lone emitter is chosen whatever the number: it is skipped, not drawn (the same
        // numbers after it).
        let pick = if emitters.len() == 1 {
            stream.skip_1d();
            0.0
        } else {
            self.draw_1d(depth, stream)
        };
        let Some(chosen) = emitters.choose(pick, self.light_selection) else {
            stream.skip_1d();
            stream.skip_1d();
            return Color::ZERO;
        };
        // A one-sided flat emitter seen from its dark side sends nothing from any point: none
        // is drawn, its pair of numbers skipped (the same numbers after it). Drawn in full
        // where the sample is explained.
        if !R::ON && emitters.dark_from(chosen.0, v.si.point()) {
            stream.skip_1d();
            stream.skip_1d();
            c.stats.add(counter::LIGHTS_UNREACHABLE, 1);
            return Color::ZERO;
        }
        let u = self.draw_2d(depth, stream);
        match emitters.sample_chosen(&scene.objects, chosen, v.si.point(), u) {
            Some(es) => self.emitter_sample(c, v, &es, n, rec),
            None => Color::ZERO,
        }
    }

    /// One emitter sample's contribution (before dividing by the `n` samples), weighed against
    /// `bsdf`'s sampling by the power heuristic.
    fn emitter_sample<R: Recorder>(&self, c: &mut Ctx, v: Vertex, es: &EmitterSample, n: u32, rec: &mut R) -> Color {
        let (scene, Vertex { si, bsdf }) = (c.scene, v);
        let cos = if si.n.dot(es.dir) > 0.0 { si.ns.dot(es.dir) } else { 0.0 };
        let traced = Traced { scene, source: Source::Emitter(es.object), dir: es.dir, distance: es.hit.t, intensity: es.radiance, cos };
        if !(cos > 0.0) {
            c.stats.add(counter::LIGHTS_BEHIND, 1);
            rec.light(|| traced.record(Some("the emitter's point is behind the surface as seen from the ray"), false, None, &[]));
            return Color::ZERO;
        }
        if !(max_channel(es.radiance) > 0.0 && es.pdf > 0.0 && es.pdf.is_finite()) {
            c.stats.add(counter::LIGHTS_UNREACHABLE, 1);
            rec.light(|| {
                traced.record(Some("no light leaves the emitter's point toward here (its back, or seen edge-on)"), false, None, &[])
            });
            return Color::ZERO;
        }
        let (f, q) = bsdf.eval_pdf(es.dir);
        if !(max_channel(f) > 0.0) {
            c.stats.add(counter::LIGHTS_NO_RESPONSE, 1);
            rec.light(|| traced.record(Some("the surface reflects nothing toward this emitter"), false, None, &[]));
            return Color::ZERO;
        }
        let p = es.pdf;
        let mis = power_heuristic(f64::from(n) * p, q);
        c.stats.add(counter::SHADOW_RAYS, 1);
        let (ray, t_max) = si.spawn_shadow_ray(es.dir, es.hit.t);
        // An emitter that cannot hide its point (convex, facing here) is not asked.
        let blocked = if es.clear_of_itself {
            scene.occludes_except(&ray, 0.0, t_max, es.object)
        } else {
            scene.occludes_leaving(&ray, t_max, &si.hit)
        };
        let visible = !blocked;
        let contribution = if visible { f * cos * es.radiance * (mis / p) } else { Color::ZERO };
        rec.light(|| {
            let occluder = if visible { None } else { scene.intersect(&ray, 0.0, t_max).map(|h| h.object) };
            let terms = [
                Term::color("bsdf", f),
                Term::color("radiance", es.radiance),
                Term::number("light pdf", p),
                Term::number("bsdf pdf", q),
                Term::number("mis", mis),
                Term::color("contribution", contribution / f64::from(n)),
            ];
            traced.record(None, visible, occluder, &terms)
        });
        contribution
    }

    /// The light `si`'s surface gives off back along the ray (its own side only,
    /// [`Interaction::emission`]): in full after a camera ray or a specular event, else weighed
    /// against the emitter samples at the vertex `from` that the ray left, which sampled it with
    /// density `bsdf_pdf`.
    pub(super) fn emission<R: Recorder>(&self, c: &mut Ctx, from: DVec3, si: &Interaction, bsdf_pdf: Option<f64>, rec: &mut R) -> Color {
        let emission = si.emission();
        if emission == Color::ZERO {
            return emission;
        }
        let scene = c.scene;
        let weighed = match bsdf_pdf {
            Some(q) if self.sample_emitters => {
                let p = f64::from(self.emitter_samples()) * scene.emitters().pdf(from, si, self.light_selection);
                (p > 0.0).then(|| (power_heuristic(q, p), p, q))
            }
            _ => None,
        };
        match weighed {
            Some((mis, p, q)) => {
                c.stats.add(counter::LIGHT_HITS, 1);
                rec.term(|| Term::color("emission", emission));
                rec.term(|| Term::number("light pdf", p));
                rec.term(|| Term::number("bsdf pdf", q));
                rec.term(|| Term::number("mis", mis));
                emission * mis
            }
            None => {
                rec.term(|| Term::color("emission", emission));
                emission
            }
        }
    }

    /// One light sample's contribution (before dividing by the light's `n` samples), with the
    /// density it was drawn with when the light said it (`None`: asked here, when needed). A
    /// sample of a delta light, or of a light no ray can meet (one that does not answer
    /// [`LightSource::intersect`]), counts in full: no other strategy finds that light.
    fn light_sample<R: Recorder>(
        &self,
        c: &mut Ctx,
        v: Vertex,
        (index, light): (usize, &dyn LightSource),
        (ls, pdf): (&LightSample, Option<LightPdf>),
        n: u32,
        rec: &mut R,
    ) -> Color {
        let (scene, Vertex { si, bsdf }) = (c.scene, v);
        // Lit only from the ray's side of the geometric surface; shaded with `ns`.
        let cos = if si.n.dot(ls.dir) > 0.0 { si.ns.dot(ls.dir) } else { 0.0 };
        let traced = Traced { scene, source: Source::Light(index), dir: ls.dir, distance: ls.distance, intensity: ls.intensity, cos };
        if !(cos > 0.0) {
            c.stats.add(counter::LIGHTS_BEHIND, 1);
            rec.light(|| traced.record(Some("the light is behind the surface as seen from the ray"), false, None, &[]));
            return Color::ZERO;
        }
        if !(max_channel(ls.intensity) > 0.0) {
            c.stats.add(counter::LIGHTS_UNREACHABLE, 1);
            rec.light(|| traced.record(Some("no light arrives here"), false, None, &[]));
            return Color::ZERO;
        }
        // An environment's sample (it says its density) is weighed against the BSDF's rays,
        // every one of which that leaves the scene meets it, and so is the sample of a light
        // that says rays meet its samples: the BSDF's value and density in one call.
        let met = scene.light_facts()[index].environment || light.meets_its_samples();
        let (f, q) = if met { bsdf.eval_pdf(ls.dir) } else { (bsdf.eval(ls.dir), f64::NAN) };
        if !(max_channel(f) > 0.0) {
            c.stats.add(counter::LIGHTS_NO_RESPONSE, 1);
            rec.light(|| traced.record(Some("the surface reflects nothing toward this light"), false, None, &[]));
            return Color::ZERO;
        }
        // Weighed against the BSDF's own rays where they can meet the light too (an environment,
        // or a light that says so, is not asked).
        let can_meet = |light: &dyn LightSource| met || light.intersect(&Ray { origin: si.point(), dir: ls.dir }, f64::INFINITY).is_some();
        let (mis, pdfs) = match pdf.unwrap_or_else(|| light.pdf(si.point(), ls)) {
            LightPdf::SolidAngle(p) if can_meet(light) => {
                let q = if met { q } else { bsdf.pdf(ls.dir) };
                (power_heuristic(f64::from(n) * p, q), Some((p, q)))
            }
            _ => (1.0, None),
        };
        c.stats.add(counter::SHADOW_RAYS, 1);
        let (ray, t_max) = si.spawn_shadow_ray(ls.dir, ls.distance);
        // The flat primitive the ray leaves is not asked (it cannot block: the same answer).
        let visible = !scene.occludes_leaving(&ray, t_max, &si.hit);
        let contribution = if visible { f * cos * IRRADIANCE_PER_INTENSITY * ls.intensity * mis } else { Color::ZERO };
        rec.light(|| {
            let occluder = if visible { None } else { scene.intersect(&ray, 0.0, t_max).map(|h| h.object) };
            let mut terms = vec![Term::color("bsdf", f)];
            if let Some((p, q)) = pdfs {
                terms.extend([Term::number("light pdf", p), Term::number("bsdf pdf", q), Term::number("mis", mis)]);
            }
            terms.push(Term::color("contribution", contribution / f64::from(n)));
            traced.record(None, visible, occluder, &terms)
        });
        contribution
    }

    /// The lights `ray` meets before the surface it hits at `t_hit` (∞: none): their radiance,
    /// weighed against light sampling at the vertex the ray left when it was sampled there with
    /// density `bsdf_pdf` (`None`: a camera ray or a specular event, which light samples cannot
    /// find, so the light counts in full). Lights do not block each other or rays. A scene
    /// without lights (lit by its emitters) answers here, inline, without a call.
    #[inline(always)]
    pub(super) fn emitters<R: Recorder>(
        &self,
        c: &mut Ctx,
        ray: &Ray,
        t_hit: f64,
        bsdf_pdf: Option<f64>,
        escape_scale: f64,
        rec: &mut R,
    ) -> Color {
        if c.scene.lights.is_empty() {
            return Color::ZERO;
        }
        self.lights_met(c, ray, t_hit, bsdf_pdf, escape_scale, rec)
    }

    /// [`PathTracer::emitters`] where the scene has lights.
    #[inline(never)]
    fn lights_met<R: Recorder>(&self, c: &mut Ctx, ray: &Ray, t_hit: f64, bsdf_pdf: Option<f64>, escape_scale: f64, rec: &mut R) -> Color {
        let scene = c.scene;
        // A ray that meets a surface meets no surroundings: where they are the only lights (a
        // sky, an image around the scene), it meets none, and the loop is not set up.
        if t_hit.is_finite() && scene.light_facts().iter().all(|f| f.environment) {
            return Color::ZERO;
        }
        // A light counts when no surface is closer than it by more than a shadow ray's margin.
        let t_max = if t_hit.is_finite() { t_hit / (1.0 - SHADOW_EPSILON) } else { f64::INFINITY };
        let mut total = Color::ZERO;
        for (index, light) in scene.lights.iter().enumerate() {
            let facts = scene.light_facts()[index];
            let (radiance, p, distance) = if facts.environment {
                // Only a ray that leaves the scene meets the surroundings, which say their
                // radiance themselves (exactly what a camera ray shows of them) and its density
                // in one lookup.
                if t_max.is_finite() {
                    continue;
                }
                // A camera ray, or one after specular events, counts it in full: no density.
                if bsdf_pdf.is_none() {
                    // After glass whose other branch was counted there, the bright part by the
                    // taken branch's probability ([`PathTracer::other_escape`]).
                    let split = if escape_scale < 1.0 && !facts.uniform {
                        super::split_radiance(light.as_ref(), ray.origin, ray.dir)
                    } else {
                        None
                    };
                    if split.is_some() {
                        rec.note(|| format!("the sky here is bright: counted × {escape_scale:.4}, the glass's branch taken (the other one was counted there)"));
                    }
                    let radiance = split.map(|r| r * escape_scale).or_else(|| light.environment(ray.dir));
                    let Some(radiance) = radiance.filter(|&r| max_channel(r) > 0.0) else { continue };
                    (radiance, f64::NAN, f64::INFINITY) // no density: never weighed
                } else {
                    let Some((radiance, p)) = light.environment_pdf(ray.origin, ray.dir) else { continue };
                    if !(p > 0.0 && p.is_finite() && max_channel(radiance) > 0.0) {
                        continue;
                    }
                    (radiance, p, f64::INFINITY)
                }
            } else {
                let Some(ls) = light.intersect(ray, t_max) else { continue };
                let Some(p) = light.pdf(ray.origin, &ls).solid_angle() else { continue };
                if !(p > 0.0 && p.is_finite() && max_channel(ls.intensity) > 0.0) {
                    continue;
                }
                (IRRADIANCE_PER_INTENSITY * ls.intensity * p, p, ls.distance)
            };
            c.stats.add(counter::LIGHT_HITS, 1);
            // A uniform light is never sampled at a vertex ([`PathTracer::direct`]): its rays count in full.
            let mis = match bsdf_pdf {
                Some(q) if !facts.uniform => power_heuristic(q, f64::from(self.samples_for(facts)) * p),
                _ => 1.0,
            };
            rec.note(|| {
                let (name, r) = (&scene.light_names[index], radiance);
                let head = if distance.is_finite() {
                    format!("meets light {name} at t = {distance:.4}: radiance ({:.4}, {:.4}, {:.4})", r.x, r.y, r.z)
                } else {
                    format!("leaves the scene and sees light {name}: radiance ({:.4}, {:.4}, {:.4})", r.x, r.y, r.z)
                };
                match bsdf_pdf {
                    Some(q) => format!("{head}, light pdf {p:.4}, bsdf pdf {q:.4}, mis {mis:.4}"),
                    None => format!("{head}, in full (a camera ray, or after a specular event: no light sample finds this path)"),
                }
            });
            total += radiance * mis;
        }
        if total != Color::ZERO {
            rec.term(|| Term::color("lights met", total));
        }
        total
    }
}
