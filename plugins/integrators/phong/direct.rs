//! Direct light at a hit: the diffuse and specular terms of every light sample, shadowed, with
//! the work that cannot change the image skipped and counted, and adaptive soft shadows (probe
//! an area light first; take its full sample set only where the probes disagree).

use super::fan::reflect;
use super::{Branch, Ctx, Front, Phong, TAG_EMITTERS, TAG_LIGHTS, counter};
use raylab::glam::DVec2;
use raylab::math::color::max_channel;
use raylab::math::sampler::StratifiedSet;
use raylab::render::trace::{NoRecord, Recorder, Term, TraceLight};
use raylab::scene::emitters::Selection;
use raylab::scene::interaction::Interaction;
use raylab::scene::material::Coefficients;
use raylab::{Color, LightSample, LightSource, Sampler, Scene};
use std::f64::consts::PI;

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

impl LightSum {
    fn observe(&mut self, o: Outcome) {
        match self.first {
            None => self.first = Some(o),
            Some(f) => self.agree &= f == o,
        }
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

/// The samples of a light to take: which, the stratified set's `pattern`, and `u0`, the point of
/// a single sample.
#[derive(Clone, Copy)]
struct Draw {
    set: Samples,
    pattern: u32,
    u0: DVec2,
}

/// The sample square's corners, diagonal pairs first.
const PROBE_CORNERS: [DVec2; 4] = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0)];

/// What one light's samples at a shading point share.
struct Shade<'a> {
    si: &'a Interaction<'a>,
    /// Where its shadow rays start.
    front: &'a Front<'a>,
    /// The material's coefficients at the hit.
    m: &'a Coefficients,
    /// The ray's weight in the pixel.
    weight: Color,
    /// The light's full sample count (the pruning share divides by it).
    full: u32,
    /// Where the samples come from.
    light: Source<'a>,
    /// The surface has neither a diffuse nor a specular term.
    no_response: bool,
}

/// Where a shading point's light samples come from: one of the scene's lights, or one of its
/// emitting objects (`emitter_samples`).
#[derive(Clone, Copy)]
enum Source<'a> {
    /// The light at this index of the scene's lights.
    Light(usize, &'a dyn LightSource),
    /// The emitting object at this index of the scene's objects.
    Emitter(u32),
}

impl Source<'_> {
    /// The name a trace shows: the light's, or "emitter" and the object's.
    fn name(&self, scene: &Scene) -> String {
        match *self {
            Source::Light(index, _) => scene.light_names[index].clone(),
            Source::Emitter(object) => format!("emitter {}", scene.object_name(object)),
        }
    }
}

/// One light sample's terms before its shadow ray.
struct Terms {
    /// `ns·l` where the light is on the viewer's side of the surface, else 0.
    nl: f64,
    diffuse: Color,
    specular: Color,
    /// `diffuse + specular`.
    unshadowed: Color,
    /// `unshadowed` is black.
    dark: bool,
}

impl Phong {
    /// Direct light at `si` (met by the ray at `b` in the recursion): diffuse and specular from
    /// every light, shadowed.
    pub(super) fn direct<R: Recorder>(
        &self,
        c: &mut Ctx,
        si: &Interaction,
        m: &Coefficients,
        b: Branch,
        front: &Front,
        rec: &mut R,
    ) -> Color {
        let Branch { sampler, weight, .. } = b;
        let scene = c.scene;
        let no_response = max_channel(m.kd) <= 0.0 && max_channel(m.ks) <= 0.0;
        if let Some(lights) = scene.one_sample_lights() {
            // The common case (point, spot, directional lights): each light's one sample, in the
            // order of the general loop below, which would take the same `single_sample` path
            // for each; without that loop's area-light machinery in the way.
            let mut total = Color::ZERO;
            for &li in lights {
                let light = Source::Light(li, scene.lights[li].as_ref());
                total += self.single_sample(c, &Shade { si, front, m, weight, full: 1, light, no_response }, rec);
            }
            if self.emitter_samples > 0 && !scene.emitters().is_empty() {
                total += self.emitters(c, si, m, b, front, no_response, rec);
            }
            return total;
        }
        // Random streams only for lights whose samples depend on them (area lights): a point,
        // spot or directional light ignores its sample position, so drawing none changes nothing.
        let mut streams = None;
        let mut total = Color::ZERO;
        for (li, (light, facts)) in scene.lights.iter().zip(scene.light_facts()).enumerate() {
            if !facts.illuminates {
                // No sample to shade or record (an ambient light: `Phong::shade` adds it).
                continue;
            }
            let area = facts.is_area;
            if !area && facts.sample_count <= 1 {
                // One sample at u = (0, 0), no stream, no probes: the stratified set of one
                // without its bookkeeping (same numbers, same counters).
                total += self.single_sample(
                    c,
                    &Shade { si, front, m, weight, full: 1, light: Source::Light(li, light.as_ref()), no_response },
                    rec,
                );
                continue;
            }
            let full = match area && self.shadow_rays > 0 {
                true => self.shadow_rays,
                false => facts.sample_count.max(1),
            };
            // An environment has no extreme points to probe: its samples are always taken in full.
            let probes =
                if area && !facts.environment && self.shadow_probes > 0 && self.shadow_probes < full { self.shadow_probes } else { 0 };
            if !no_response && let Some(why) = self.light_out_of_reach(si, m, light.as_ref(), weight, full) {
                // What the samples would have counted: the first set, each skipped; its
                // (agreeing) probes save the full set.
                let first = if probes > 0 { probes } else { full };
                c.stats.add(why, u64::from(first));
                if probes > 0 {
                    c.stats.add(counter::SHADOW_RAYS_SAVED, u64::from(full - probes));
                }
                rec.note(|| match why {
                    counter::LIGHTS_BEHIND => format!("{}: the whole light is behind the surface; no samples", scene.light_names[li]),
                    _ => format!("{}: no sample can reach the pruning threshold; no samples", scene.light_names[li]),
                });
                continue;
            }
            let mut stream = area.then(|| streams.get_or_insert_with(|| sampler.fork(TAG_LIGHTS)).fork(li as u64));
            let mut acc = LightSum { sum: Color::ZERO, n: 0, first: None, agree: true };
            let shade = Shade { si, front, m, weight, full, light: Source::Light(li, light.as_ref()), no_response };
            let first_set = if probes > 0 { Samples::Probes(probes) } else { Samples::Stratified(full) };
            let (pattern, u0) = match &mut stream {
                Some(s) => (s.next_pattern(), s.next_2d()),
                None => (0, DVec2::ZERO),
            };
            if !self.light_samples(c, &shade, Draw { set: first_set, pattern, u0 }, &mut acc, rec) {
                continue;
            }
            if probes > 0 {
                if acc.agree {
                    c.stats.add(counter::SHADOW_RAYS_SAVED, u64::from(full - probes));
                } else {
                    rec.note(|| format!("{}: the {probes} probe rays disagree; {full} more samples", scene.light_names[li]));
                    let pattern = stream.as_mut().map_or(0, Sampler::next_pattern);
                    self.light_samples(c, &shade, Draw { set: Samples::Stratified(full), pattern, u0 }, &mut acc, rec);
                }
            }
            // (A division by 1 changes no bit: skipped.)
            match acc.n {
                0 => {}
                1 => total += acc.sum,
                n => total += acc.sum / f64::from(n),
            }
        }
        if self.emitter_samples > 0 && !scene.emitters().is_empty() {
            total += self.emitters(c, si, m, b, front, no_response, rec);
        }
        total
    }

    /// Direct light from the scene's emitting objects as area lights: `emitter_samples` points on
    /// them (the object chosen by power, the point by its shape's own sampling, stratified), each
    /// a light sample of intensity radiance ÷ (π·pdf), so that its diffuse term's mean is the
    /// Lambertian response to the emitters, as an environment's samples are.
    #[allow(clippy::too_many_arguments)]
    fn emitters<R: Recorder>(
        &self,
        c: &mut Ctx,
        si: &Interaction,
        m: &Coefficients,
        b: Branch,
        front: &Front,
        no_response: bool,
        rec: &mut R,
    ) -> Color {
        let scene = c.scene;
        let n = self.emitter_samples;
        if self.avoid && no_response {
            c.stats.add(counter::LIGHTS_NO_RESPONSE, u64::from(n));
            rec.note(|| "emitters: the surface has no diffuse or specular term; no shadow rays".into());
            return Color::ZERO;
        }
        let mut stream = b.sampler.fork(TAG_EMITTERS);
        let points = StratifiedSet::new(n, stream.next_pattern());
        let mut sum = Color::ZERO;
        for s in 0..n {
            let pick = stream.next_1d();
            let Some(es) = scene.emitters().sample(&scene.objects, si.hit.point, pick, points.point(s), Selection::Power) else { continue };
            let intensity = if es.pdf > 0.0 && es.pdf.is_finite() { es.radiance / (PI * es.pdf) } else { Color::ZERO };
            let ls = LightSample { dir: es.dir, distance: es.hit.t, intensity };
            let sh = Shade { si, front, m, weight: b.weight, full: n, light: Source::Emitter(es.object), no_response };
            if let Ok(t) = self.unshadowed(c, &sh, &ls, rec) {
                sum += t.unshadowed * self.shadowed(c, &sh, &ls, &t, n, rec);
            }
        }
        sum / f64::from(n)
    }

    /// Why every sample of `light` (of `full`) at `si` would be skipped, from the light's
    /// [`LightSource::bound`]: the counter of the skip (behind the surface, with `avoid`, or below
    /// the pruning threshold), or `None` when some sample may count. Sound with rounding: the
    /// bound is widened by [`BOUND_SLACK`] relative to the sizes involved, far more than the
    /// few ulp the samples' own arithmetic can err by.
    #[inline]
    fn light_out_of_reach(&self, si: &Interaction, m: &Coefficients, light: &dyn LightSource, weight: Color, full: u32) -> Option<usize> {
        let b = light.bound(si.hit.point)?;
        let to_centre = b.centre - si.hit.point;
        // Every sample point q is within `radius` of the centre: n·(q − p) ≤ n·to_centre + radius.
        let reach = b.radius + (to_centre.length() + b.radius) * BOUND_SLACK;
        if self.avoid && si.n.dot(to_centre) + reach * si.n.length() < 0.0 {
            return Some(counter::LIGHTS_BEHIND);
        }
        // Each channel of a sample's unshadowed term is at most (|kd|·|n·l| + |ks|·spec)·|I|, with
        // |n·l| ≤ 1 and spec = (v·r)^shininess ≤ 1 (v·r ≤ 1 + a few ulp, raised to at most
        // MAX_BOUNDED_SHININESS: within the slack).
        if self.prune_threshold > 0.0 && m.shininess <= MAX_BOUNDED_SHININESS {
            let most = max_channel((m.kd.abs() + m.ks.abs()) * b.intensity.abs() * weight.abs()) * (1.0 + BOUND_SLACK);
            if most / f64::from(full) < self.prune_threshold {
                return Some(counter::LIGHTS_NEGLIGIBLE);
            }
        }
        None
    }

    /// The one sample of a point-like light (`sample_count` 1): what [`Phong::light_samples`]
    /// adds for `Samples::Stratified(1)`, without the agreement bookkeeping only probes read.
    /// Always inlined: called from two loops, it went out of line (a call per light sample).
    #[inline(always)]
    fn single_sample<R: Recorder>(&self, c: &mut Ctx, sh: &Shade, rec: &mut R) -> Color {
        match self.single_terms(c, sh, rec) {
            Some((ls, t)) => t.unshadowed * self.shadowed(c, sh, &ls, &t, 1, rec),
            None => Color::ZERO,
        }
    }

    /// [`Phong::single_sample`] up to its shadow ray: the light sample and its terms where a
    /// shadow ray is to be traced, `None` where the sample adds nothing (skips counted and
    /// recorded here).
    #[inline(always)]
    fn single_terms<R: Recorder>(&self, c: &mut Ctx, sh: &Shade, rec: &mut R) -> Option<(LightSample, Terms)> {
        let scene = c.scene;
        let si = sh.si;
        let Source::Light(_, light) = sh.light else { return None };
        let ls = light.illuminate(si.hit.point, DVec2::ZERO)?;
        if self.avoid && sh.no_response {
            c.stats.add(counter::LIGHTS_NO_RESPONSE, 1);
            rec.note(|| format!("{}: the surface has no diffuse or specular term; no shadow rays", sh.light.name(scene)));
            return None;
        }
        self.unshadowed(c, sh, &ls, rec).ok().map(|t| (ls, t))
    }

    /// The camera hit `si` (with its material's coefficients `m`) lit by the one-sample light
    /// `light` alone, up to its shadow ray: what [`Phong::direct`] computes there before tracing
    /// it. `Some((shadow ray, t_max, unshadowed term))` where it traces one (counted here, as
    /// [`Phong::shadowed`] counts it), `None` where the light adds nothing. The caller traces the
    /// shadow rays of a block together and adds `unshadowed × transmittance` to a zero total,
    /// as `direct` does.
    #[inline(always)]
    pub(super) fn block_light(&self, c: &mut Ctx, si: &Interaction, m: &Coefficients, light: usize) -> Option<(raylab::Ray, f64, Color)> {
        let no_response = max_channel(m.kd) <= 0.0 && max_channel(m.ks) <= 0.0;
        let source = Source::Light(light, c.scene.lights[light].as_ref());
        let front = Front::new(si);
        let sh = Shade { si, front: &front, m, weight: Color::ONE, full: 1, light: source, no_response };
        let (ls, t) = self.single_terms(c, &sh, &mut NoRecord)?;
        c.stats.add(counter::SHADOW_RAYS, 1);
        let (ray, t_max) = si.spawn_shadow_ray(ls.dir, ls.distance);
        Some((ray, t_max, t.unshadowed))
    }

    /// Takes the samples `draw` of the light `sh.source` and adds them to `acc`. False when the
    /// light has no direction here (ambient).
    fn light_samples<R: Recorder>(&self, c: &mut Ctx, sh: &Shade, draw: Draw, acc: &mut LightSum, rec: &mut R) -> bool {
        let scene = c.scene;
        let si = sh.si;
        let Draw { set, pattern, u0 } = draw;
        let Source::Light(_, light) = sh.light else { return false };
        let count = match set {
            Samples::Stratified(n) | Samples::Probes(n) => n,
        };
        // The stratified points, past the probes' corners (none for one sample: `u0`).
        let points = match set {
            Samples::Probes(n) => StratifiedSet::new(n.saturating_sub(4), pattern),
            Samples::Stratified(1) => StratifiedSet::new(1, 0),
            Samples::Stratified(n) => StratifiedSet::new(n, pattern),
        };
        for s in 0..count {
            let u = match set {
                Samples::Probes(_) if s < 4 => PROBE_CORNERS[s as usize],
                Samples::Probes(_) => points.point(s - 4),
                Samples::Stratified(1) => u0,
                Samples::Stratified(_) => points.point(s),
            };
            let Some(ls) = light.illuminate(si.hit.point, u) else { return false };
            acc.n += 1;
            if self.avoid && sh.no_response {
                c.stats.add(counter::LIGHTS_NO_RESPONSE, u64::from(count - s));
                acc.n += count - s - 1;
                acc.first.get_or_insert(Outcome::Dark);
                rec.note(|| format!("{}: the surface has no diffuse or specular term; no shadow rays", sh.light.name(scene)));
                return true;
            }
            match self.unshadowed(c, sh, &ls, rec) {
                Ok(t) => {
                    let tr = self.shadowed(c, sh, &ls, &t, count, rec);
                    acc.sum += t.unshadowed * tr;
                    acc.observe(if t.dark { Outcome::Dark } else { Outcome::Lit(tr) });
                }
                Err(o) => acc.observe(o),
            }
        }
        true
    }

    /// The diffuse and specular terms of light sample `ls` before its shadow ray, or how it was
    /// skipped (counted and recorded here): behind the surface, outside a cone, no response, or
    /// below the pruning threshold.
    #[inline(always)]
    fn unshadowed<R: Recorder>(&self, c: &mut Ctx, sh: &Shade, ls: &LightSample, rec: &mut R) -> Result<Terms, Outcome> {
        let scene = c.scene;
        let (si, m) = (sh.si, sh.m);
        // Lit only from the viewer's side of the geometric surface; shaded with `ns`.
        let nl = if si.n.dot(ls.dir) > 0.0 { si.ns.dot(ls.dir) } else { 0.0 };
        let skipped = |why: &str| TraceLight { skipped: Some(why.to_string()), ..light_record(scene, sh.light, ls, nl) };
        if self.avoid && nl <= 0.0 {
            c.stats.add(counter::LIGHTS_BEHIND, 1);
            rec.light(|| skipped("the light is behind the surface as seen from the ray"));
            return Err(Outcome::Dark);
        }
        if self.avoid && max_channel(ls.intensity) <= 0.0 {
            c.stats.add(counter::LIGHTS_UNREACHABLE, 1);
            rec.light(|| skipped("no light arrives here (outside the cone)"));
            return Err(Outcome::Dark);
        }
        let spec = if nl > 0.0 && max_channel(m.ks) > 0.0 {
            let vr = -si.dir.dot(reflect(-ls.dir, si.ns));
            if vr > 0.0 { shininess_power(vr, m.shininess) } else { 0.0 }
        } else {
            0.0
        };
        let diffuse = m.kd * nl.max(0.0) * ls.intensity;
        let specular = m.ks * spec * ls.intensity;
        let unshadowed = diffuse + specular;
        let dark = max_channel(unshadowed) <= 0.0;
        if self.avoid && dark {
            c.stats.add(counter::LIGHTS_NO_RESPONSE, 1);
            rec.light(|| skipped("no diffuse or specular response toward this light"));
            return Err(Outcome::Dark);
        }
        // (A division by 1 changes no bit: skipped.)
        let share = match sh.full {
            1 => max_channel(unshadowed * sh.weight),
            full => max_channel(unshadowed * sh.weight) / f64::from(full),
        };
        if share < self.prune_threshold {
            c.stats.add(counter::LIGHTS_NEGLIGIBLE, 1);
            rec.light(|| skipped(&format!("contribution {share:.3e} below the pruning threshold")));
            return Err(if dark { Outcome::Dark } else { Outcome::Negligible });
        }
        Ok(Terms { nl, diffuse, specular, unshadowed, dark })
    }

    /// The transmittance toward light sample `ls` along its shadow ray (counted, and recorded with
    /// the terms `t` as one of `count` samples).
    #[inline(always)]
    fn shadowed<R: Recorder>(&self, c: &mut Ctx, sh: &Shade, ls: &LightSample, t: &Terms, count: u32, rec: &mut R) -> Color {
        let scene = c.scene;
        c.stats.add(counter::SHADOW_RAYS, 1);
        let (shadow_ray, t_max) = sh.front.shadow_ray(ls.dir, ls.distance);
        if R::ON {
            let (tr, occ) = scene.transmittance_and_occluder(&shadow_ray, t_max);
            let k = f64::from(count);
            let terms = [Term::color("diffuse", t.diffuse * tr / k), Term::color("specular", t.specular * tr / k)];
            rec.light(|| TraceLight {
                transmittance: tr,
                occluder: occ.map(|o| scene.object_name(o).to_string()),
                terms: terms.to_vec(),
                ..light_record(scene, sh.light, ls, t.nl)
            });
            tr
        } else {
            // The ray leaves the hit's own primitive: a flat one need not be tested again.
            scene.transmittance_leaving(&shadow_ray, t_max, &sh.si.hit)
        }
    }
}

/// The explanation of light sample `ls` of `light`, with `n·l` = `nl`, before its shadow ray:
/// no transmittance, occluder or terms yet, not skipped.
fn light_record(scene: &Scene, light: Source, ls: &LightSample, nl: f64) -> TraceLight {
    TraceLight {
        light: light.name(scene),
        dir: ls.dir,
        distance: ls.distance,
        intensity: ls.intensity,
        n_dot_l: nl,
        transmittance: Color::ZERO,
        occluder: None,
        terms: Vec::new(),
        skipped: None,
    }
}

/// Relative widening of a light's bound against rounding in its samples (which err by a few ulp,
/// 10⁻¹⁵ relative).
const BOUND_SLACK: f64 = 1e-6;

/// Largest shininess for which a light's bound is used: `(1 + 10⁻¹⁵)^shininess` stays within
/// [`BOUND_SLACK`].
const MAX_BOUNDED_SHININESS: f64 = 1e8;

/// Largest whole Phong exponent raised by repeated squaring.
const MAX_WHOLE_SHININESS: f64 = 1024.0;

/// `x^shininess` for `0 < x ≤ 1`: a whole exponent `n` up to [`MAX_WHOLE_SHININESS`] by repeated
/// squaring (at most 20 multiplications; a rounding in `x^(2^k)` is raised to the remaining
/// `n / 2^k`, so the result is within about `n` ulp of `powf`: 10⁻¹⁴ relative at n = 50, 10⁻¹³ at
/// 1024, which no 8-bit image shows), at a tenth of `powf`'s cost; any other exponent by `powf`.
#[inline]
fn shininess_power(x: f64, shininess: f64) -> f64 {
    // Whole and in range, tested without `fract` (a library call on x86-64 without SSE4.1):
    // `as u32` truncates, so the round trip is exact only for whole values (NaN fails).
    let whole = shininess as u32;
    if !(f64::from(whole) == shininess && shininess <= MAX_WHOLE_SHININESS) {
        return x.powf(shininess);
    }
    let (mut n, mut base, mut result) = (whole, x, 1.0);
    while n > 0 {
        if n & 1 == 1 {
            result *= base;
        }
        n >>= 1;
        if n > 0 {
            base *= base;
        }
    }
    result
}

#[cfg(test)]
mod shininess_tests {
    use super::shininess_power;

    /// Whole exponents `n` agree with `powf` to `n` ulp (above the subnormal range); others are
    /// `powf`.
    #[test]
    fn whole_exponents_match_powf() {
        for s in [0.0, 1.0, 2.0, 3.0, 7.0, 32.0, 50.0, 100.0, 1000.0, 1024.0] {
            for k in 1..=1000 {
                let x = f64::from(k) / 1000.0;
                let (a, b) = (shininess_power(x, s), x.powf(s));
                assert!((a - b).abs() <= s.max(1.0) * f64::EPSILON * b + 1e-300, "{x}^{s}: {a} vs {b}");
            }
        }
        assert_eq!(shininess_power(0.3, 2.5), 0.3f64.powf(2.5));
        assert_eq!(shininess_power(0.3, 2000.0), 0.3f64.powf(2000.0));
    }
}
