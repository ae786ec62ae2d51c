//! The scene model: camera, background, objects, lights; and the ray queries integrators use.

pub mod bsdf;
pub mod camera;
pub mod emitters;
pub mod interaction;
pub mod light;
pub mod material;
pub mod normal_map;
pub mod object;
pub mod texture;

use crate::accel::{AccelChoice, BuildStats, ObjectAccel};
use crate::geometry::differential::{CameraSpread, RaySpread};
use crate::geometry::{Hit, Intersectable, PACKET};
use crate::math::bounds::Aabb;
use crate::math::color::Color;
use crate::math::float::offset_ray_origin;
use crate::math::ray::Ray;
use crate::scene::camera::Camera;
use crate::scene::emitters::Emitters;
use crate::scene::interaction::Interaction;
use crate::scene::light::{LightFacts, LightSource};
use crate::scene::material::Material;
use crate::scene::object::Object;
use glam::DVec3;

/// Most surfaces a shadow ray passes through before it is treated as blocked (guards against
/// pathological stacks of transparent sheets).
pub const MAX_TRANSPARENT_LAYERS: u32 = 64;

/// Everything the integrators see: camera, background, ambient light, objects and lights.
pub struct Scene {
    /// Name for messages (the file stem).
    pub name: String,
    /// The camera.
    pub camera: Camera,
    /// Colour of rays that hit nothing (linear RGB), where no environment light is
    /// ([`Scene::escaped`]).
    pub background: Color,
    /// Sum of the ambient terms of all lights (`colour × ka` of each ambient light).
    pub ambient: Color,
    /// The objects; [`Hit::object`] indexes them.
    pub objects: Vec<Object>,
    /// Names of the lights, parallel to `lights`.
    pub light_names: Vec<String>,
    /// The lights (ambient lights included; they return no samples). Read once when the scene
    /// is built (`ambient`, [`Scene::light_facts`]): not to be changed afterwards.
    pub lights: Vec<Box<dyn LightSource>>,
    /// [`LightFacts`] of each light, parallel to `lights`.
    light_facts: Vec<LightFacts>,
    /// Indices of the environment lights ([`LightFacts::environment`]).
    environments: Vec<usize>,
    /// Indices of the lights that illuminate, in order, when each of them gives one sample and
    /// is not an area light ([`Scene::one_sample_lights`]); `None` when some light has more.
    one_sample_lights: Option<Box<[usize]>>,
    /// The objects that emit and can be sampled as lights.
    emitters: Emitters,
    accel: ObjectAccel,
    opaque: ObjectAccel,
    transmissive: ObjectAccel,
    bounds: Aabb,
    build_stats: BuildStats,
    object_builds: BuildStats,
    /// Texture filtering ([`Scene::set_texture_filter`]): `None` when off or when no material is
    /// textured (no ray then computes a differential).
    filter: Option<TextureFilter>,
}

/// What a scene that filters its textures gives its rays: the film's moves one pixel right and
/// down (scaled by the spread of a pixel's samples) and the camera's spread derived from them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct TextureFilter {
    step: (DVec3, DVec3),
    spread: CameraSpread,
}

/// The smallest scale of a pixel's footprint for many samples per pixel (pbrt-v4: `max(1/8,
/// 1/√spp)`): each sample filters over its share of the pixel, but not below an eighth.
pub const MIN_FOOTPRINT_SCALE: f64 = 0.125;

/// How a scene's objects are arranged for ray queries, for the render summary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelSummary {
    /// True when the bounded objects are in a hierarchy (false: a list).
    pub bvh: bool,
    /// Objects with a bounding box.
    pub bounded: usize,
    /// Objects without one (planes, tubes), tested by every ray.
    pub unbounded: usize,
    /// Cost of building the scene-level hierarchies (zero for lists).
    pub build: BuildStats,
    /// Cost of the hierarchies objects built over their own parts (mesh triangles).
    pub object_builds: BuildStats,
}

impl Scene {
    /// A scene from its parts; `lights` are (name, light) pairs. The objects are arranged for
    /// ray queries as [`AccelChoice::Auto`] decides.
    pub fn new(
        name: impl Into<String>,
        camera: Camera,
        background: Color,
        objects: Vec<Object>,
        lights: Vec<(String, Box<dyn LightSource>)>,
    ) -> Scene {
        Scene::with_accel(name, camera, background, objects, lights, AccelChoice::Auto)
    }

    /// [`Scene::new`] with the choice of list or hierarchy for the objects.
    pub fn with_accel(
        name: impl Into<String>,
        camera: Camera,
        background: Color,
        objects: Vec<Object>,
        lights: Vec<(String, Box<dyn LightSource>)>,
        choice: AccelChoice,
    ) -> Scene {
        let (light_names, lights): (Vec<_>, Vec<_>) = lights.into_iter().unzip();
        let boxes: Vec<Option<Aabb>> = objects.iter().map(|o| o.geometry().bounds()).collect();
        let transmits: Vec<bool> = objects.iter().map(Object::may_transmit).collect();
        let (accel, mut build_stats) = ObjectAccel::build(&boxes, |_| true, choice);
        let (opaque, transmissive) = if transmits.iter().any(|&t| t) {
            let (o, so) = ObjectAccel::build(&boxes, |i| !transmits[i], choice);
            let (t, st) = ObjectAccel::build(&boxes, |i| transmits[i], choice);
            build_stats += so;
            build_stats += st;
            (o, t)
        } else {
            (ObjectAccel::default(), ObjectAccel::default())
        };
        let bounds = boxes.iter().flatten().fold(Aabb::EMPTY, |a, b| a.union(*b));
        let ambient = lights.iter().map(|l| l.ambient()).sum();
        let light_facts: Vec<LightFacts> = lights.iter().map(|l| LightFacts::of(l.as_ref())).collect();
        let environments = (0..lights.len()).filter(|&i| light_facts[i].environment).collect();
        let one_sample_lights = light_facts
            .iter()
            .all(|f| !f.illuminates || (!f.is_area && f.sample_count <= 1))
            .then(|| (0..lights.len()).filter(|&i| light_facts[i].illuminates).collect());
        let emitters = Emitters::new(&objects);
        Scene {
            name: name.into(),
            camera,
            background,
            ambient,
            objects,
            light_names,
            lights,
            light_facts,
            environments,
            one_sample_lights,
            emitters,
            accel,
            opaque,
            transmissive,
            bounds,
            build_stats,
            object_builds: BuildStats::default(),
            filter: None,
        }
    }

    /// Whether some material looks up a texture (its colours, or its model's parameters).
    pub fn has_textures(&self) -> bool {
        self.objects.iter().flat_map(|o| o.materials()).any(Material::looks_up_textures)
    }

    /// Turns texture filtering on (`on`) or off for an `nx × ny` image at `spp` samples per
    /// pixel (each sample's footprint is `max(1/8, 1/√spp)` of a pixel). Decided once per scene:
    /// when no material is textured it stays off, and no ray computes a differential.
    pub fn set_texture_filter(&mut self, on: bool, nx: u32, ny: u32, spp: u32) {
        self.filter = (on && self.has_textures()).then(|| {
            let scale = (1.0 / f64::from(spp.max(1)).sqrt()).max(MIN_FOOTPRINT_SCALE);
            let step = self.camera.pixel_step(nx, ny, scale);
            TextureFilter { step, spread: self.camera.spread(step) }
        });
    }

    /// Whether textures are filtered ([`Scene::set_texture_filter`]).
    #[inline]
    pub fn filters_textures(&self) -> bool {
        self.filter.is_some()
    }

    /// The spread of camera ray `ray` ([`RaySpread::Off`] when textures are not filtered).
    #[inline]
    pub fn camera_spread(&self, ray: &Ray) -> RaySpread {
        match &self.filter {
            None => RaySpread::Off,
            Some(f) => RaySpread::Differential(self.camera.differential(ray, f.step)),
        }
    }

    /// The spread of a ray scattered diffusely or glossily after a ray with `spread`: pbrt-v4's
    /// approximation from the camera ([`RaySpread::Camera`]), or off.
    #[inline]
    pub fn scattered_spread(&self, spread: RaySpread) -> RaySpread {
        spread.scattered(self.filter.map(|f| f.spread))
    }

    /// What each light says of itself ([`LightFacts`]), parallel to [`Scene::lights`]: asked once
    /// when the scene was built.
    #[inline]
    pub fn light_facts(&self) -> &[LightFacts] {
        &self.light_facts
    }

    /// When every light that illuminates gives one sample per point and is not an area light
    /// (point, spot and directional lights; [`LightFacts`]): their indices into
    /// [`Scene::lights`], in order, so an integrator can take the common case without the
    /// machinery of area lights (streams, stratified sets, probes). `None` otherwise.
    #[inline]
    pub fn one_sample_lights(&self) -> Option<&[usize]> {
        self.one_sample_lights.as_deref()
    }

    /// Whether the scene has an environment light ([`crate::LightSource::environment`]).
    #[inline]
    pub fn has_environment(&self) -> bool {
        !self.environments.is_empty()
    }

    /// What a ray leaving the scene along unit `dir` sees: the environment lights' radiance
    /// (summed), or the background where the scene has none.
    #[inline]
    pub fn escaped(&self, dir: DVec3) -> Color {
        if self.environments.is_empty() {
            return self.background;
        }
        self.environments.iter().filter_map(|&i| self.lights[i].environment(dir)).sum()
    }

    /// The objects that emit and can be sampled as lights ([`Emitters`]).
    #[inline]
    pub fn emitters(&self) -> &Emitters {
        &self.emitters
    }

    /// Records the cost of the hierarchies the objects built over their own parts (reported by
    /// the loader from [`crate::load::context::AssetCache::build_stats`]).
    pub fn record_object_builds(&mut self, stats: BuildStats) {
        self.object_builds += stats;
    }

    /// How the objects are arranged for ray queries.
    pub fn accel_summary(&self) -> AccelSummary {
        let (bounded, unbounded) = self.accel.counts();
        AccelSummary { bvh: self.accel.is_bvh(), bounded, unbounded, build: self.build_stats, object_builds: self.object_builds }
    }

    /// Box around all bounded objects (empty when there are none).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The closest surface along `ray` (`0 < t`), with everything shading needs, computed once.
    ///
    /// The one way to a hit's [`Interaction`]. Always inlined (the traversal behind it is not):
    /// the interaction is built in the caller's frame.
    #[inline(always)]
    pub fn trace(&self, ray: &Ray) -> Option<Interaction<'_>> {
        let mut hit = Hit::new(0.0, DVec3::ZERO, DVec3::ZERO);
        if !self.closest_hit(ray, &mut hit) {
            return None;
        }
        Some(self.interaction(ray, hit))
    }

    /// The closest hit along `ray` (`0 < t`) into `hit` (written only when there is one, and then
    /// true): [`Scene::trace`]'s traversal, kept out of line, its hit written where the caller
    /// keeps it.
    #[inline(never)]
    fn closest_hit(&self, ray: &Ray, hit: &mut Hit) -> bool {
        self.accel.over(&self.objects).intersect_into(ray, 0.0, f64::INFINITY, hit)
    }

    /// [`Scene::trace`] for a ray spawned off the hit `from` (a path's next ray, from
    /// [`Interaction::spawn_ray`]): the same interaction, for less work where `from`'s primitive
    /// is flat ([`Intersectable::intersect_leaving`]: its object is not tested again).
    #[inline(always)]
    pub fn trace_leaving(&self, ray: &Ray, from: &Hit) -> Option<Interaction<'_>> {
        let mut hit = Hit::new(0.0, DVec3::ZERO, DVec3::ZERO);
        if !self.closest_hit_leaving(ray, from, &mut hit) {
            return None;
        }
        Some(self.interaction(ray, hit))
    }

    /// The closest hit along `ray` (`0 < t`) leaving `from`, into `hit` as
    /// [`Scene::closest_hit`]: [`Scene::trace_leaving`]'s traversal, kept out of line.
    #[inline(never)]
    fn closest_hit_leaving(&self, ray: &Ray, from: &Hit, hit: &mut Hit) -> bool {
        self.accel.over(&self.objects).intersect_leaving_into(ray, 0.0, f64::INFINITY, from, hit)
    }

    /// The interaction of `ray` at `hit` (a hit of this scene: [`Hit::object`] indexes `objects`).
    /// Always inlined, as [`Scene::trace`]: the interaction is built where it is used.
    #[inline(always)]
    pub fn interaction(&self, ray: &Ray, hit: Hit) -> Interaction<'_> {
        Interaction::new(ray, hit, &self.objects[hit.object as usize])
    }

    /// The fraction of light that travels along `ray` for `0 < t < t_max`: the product of the
    /// `kt` of every surface crossed, zero if any opaque surface is in the way. Opaque objects are
    /// tested first with the cheap any-hit query; only then are transparent ones walked.
    #[inline]
    pub fn transmittance(&self, ray: &Ray, t_max: f64) -> Color {
        if self.transmissive.is_empty() {
            return if self.accel.over(&self.objects).occludes(ray, 0.0, t_max) { Color::ZERO } else { Color::ONE };
        }
        if self.opaque.over(&self.objects).occludes(ray, 0.0, t_max) {
            return Color::ZERO;
        }
        self.walk(&self.transmissive, ray, t_max).0
    }

    /// [`Scene::transmittance`] for a shadow ray leaving the hit `from` (spawned off it, as
    /// [`Interaction::spawn_shadow_ray`] does): the opaque objects' any-hit query may skip the
    /// primitive the ray leaves where that is flat ([`Intersectable::occludes_leaving`]). The same
    /// answer as [`Scene::transmittance`], for less work. Always inlined, as `transmittance` is
    /// (called out of line, its call cost a third of what the skip saves).
    #[inline(always)]
    pub fn transmittance_leaving(&self, ray: &Ray, t_max: f64, from: &Hit) -> Color {
        if self.transmissive.is_empty() {
            return if self.accel.over(&self.objects).occludes_leaving(ray, 0.0, t_max, from) { Color::ZERO } else { Color::ONE };
        }
        let opaque = self.opaque.over(&self.objects);
        // A transmissive object is not among the opaque ones.
        let blocked = if self.objects[from.object as usize].may_transmit() {
            opaque.occludes(ray, 0.0, t_max)
        } else {
            opaque.occludes_leaving(ray, 0.0, t_max, from)
        };
        if blocked {
            return Color::ZERO;
        }
        self.walk(&self.transmissive, ray, t_max).0
    }

    /// [`Scene::transmittance_leaving`] for the shadow rays `rays[k]` of mask `live`, ray `k` up
    /// to `t_max[k]` and leaving the hit `from[k]`, into `out[k]` (other lanes left alone): the
    /// same colours. Where no object transmits, the rays' any-hit queries are asked together
    /// ([`crate::accel::Accelerated::occludes_packet_leaving`]); otherwise ray by ray.
    #[inline]
    pub fn transmittance_packet_leaving(
        &self,
        rays: &[Ray; PACKET],
        live: u32,
        t_max: &[f64; PACKET],
        from: &[Hit; PACKET],
        out: &mut [Color; PACKET],
    ) {
        if self.transmissive.is_empty() {
            let blocked = self.accel.over(&self.objects).occludes_packet_leaving(rays, live, 0.0, t_max, from);
            let mut m = live;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                out[k] = if blocked >> k & 1 != 0 { Color::ZERO } else { Color::ONE };
            }
            return;
        }
        let mut m = live;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            out[k] = self.transmittance_leaving(&rays[k], t_max[k], &from[k]);
        }
    }

    /// Whether anything is hit along a shadow ray leaving the hit `from` (spawned off it, as
    /// [`Interaction::spawn_shadow_ray`] does) with `0 < t < t_max`: [`Intersectable::occludes`]
    /// that may skip the flat primitive the ray leaves ([`Intersectable::occludes_leaving`]).
    /// The same answer, for less work; every surface blocks, transmissive ones included (the
    /// path tracer's shadow rays).
    #[inline(always)]
    pub fn occludes_leaving(&self, ray: &Ray, t_max: f64, from: &Hit) -> bool {
        self.accel.over(&self.objects).occludes_leaving(ray, 0.0, t_max, from)
    }

    /// Whether anything but object `skip` is hit along `ray` with `t_min < t < t_max`
    /// ([`Intersectable::occludes`] without that object): a shadow ray toward a point of an
    /// emitter that cannot hide it ([`crate::scene::emitters::EmitterSample::clear_of_itself`]).
    #[inline]
    pub fn occludes_except(&self, ray: &Ray, t_min: f64, t_max: f64, skip: u32) -> bool {
        self.accel.over(&self.objects).occludes_except(ray, t_min, t_max, skip)
    }

    /// Like [`Scene::transmittance`], also naming the first surface crossed (for explanations).
    pub fn transmittance_and_occluder(&self, ray: &Ray, t_max: f64) -> (Color, Option<u32>) {
        self.walk(&self.accel, ray, t_max)
    }

    /// Walks the surfaces of `list` along the ray, multiplying their `kt`.
    fn walk(&self, list: &ObjectAccel, ray: &Ray, t_max: f64) -> (Color, Option<u32>) {
        let surfaces = list.over(&self.objects);
        // Most shadow rays cross nothing: asked before the walk's set-up.
        let Some(mut h) = surfaces.intersect(ray, 0.0, t_max) else { return (Color::ONE, None) };
        let first = Some(h.object);
        let mut tr = Color::ONE;
        let mut r = *ray;
        let target = t_max.is_finite().then(|| ray.at(t_max));
        let mut t_max = t_max;
        for layer in 0..MAX_TRANSPARENT_LAYERS {
            if layer > 0 {
                let Some(next) = surfaces.intersect(&r, 0.0, t_max) else { return (tr, first) };
                h = next;
            }
            let si = self.interaction(&r, h);
            tr *= si.coefficients().kt;
            if tr.max_element() <= 0.0 {
                return (Color::ZERO, first);
            }
            r.origin = offset_ray_origin(h.point, h.error, si.n, r.dir);
            if let Some(target) = target {
                t_max = (target - r.origin).dot(r.dir);
                if t_max <= 0.0 {
                    return (tr, first);
                }
            }
        }
        (Color::ZERO, first)
    }

    /// The display name of object `i`.
    pub fn object_name(&self, i: u32) -> &str {
        self.objects.get(i as usize).map_or("?", |o| o.name.as_str())
    }
}

/// The scene answers the same ray queries as its objects and their hierarchies:
/// [`Hit::object`] indexes [`Scene::objects`].
impl Intersectable for Scene {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        self.accel.over(&self.objects).intersect(ray, t_min, t_max)
    }
    #[inline]
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.accel.over(&self.objects).occludes(ray, t_min, t_max)
    }
    #[inline]
    fn intersect_packet(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        self.accel.over(&self.objects).intersect_packet(rays, live, t_min, t_max, out)
    }
    fn walks_packets(&self) -> bool {
        self.accel.over(&self.objects).walks_packets()
    }
}
