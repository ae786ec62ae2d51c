//! [`Interaction`]: what an integrator needs at a hit, computed once: the object, the point and
//! its error bound, both normals facing the incoming ray, and the material evaluated there
//! (textures looked up at the hit's texture coordinates).

use crate::geometry::{Hit, Surface};
use crate::math::color::Color;
use crate::math::ray::Ray;
use crate::scene::bsdf::{MaterialModel, Shading};
use crate::scene::material::{CoefficientsAt, Material};
use crate::scene::object::Object;
use crate::scene::texture::TexturePoint;
use glam::{DVec2, DVec3};

/// A ray's hit on a scene object, with everything shading reads (see [`crate::Scene::trace`]).
#[derive(Clone, Copy)]
pub struct Interaction<'s> {
    /// Distance, point and its rounding-error bound, primitive and object index.
    pub hit: Hit,
    /// The object hit.
    pub object: &'s Object,
    /// Unit direction of the incoming ray.
    pub dir: DVec3,
    /// Unit geometric normal facing the incoming ray (`n · dir ≤ 0`): sides and ray offsets.
    pub n: DVec3,
    /// Unit shading normal facing the incoming ray: lighting.
    pub ns: DVec3,
    /// True when the ray arrived on the surface's outward side.
    pub front_face: bool,
    /// The material's coefficients at the hit (borrowed from the object when untextured).
    pub material: CoefficientsAt<'s>,
    /// Which of the object's materials applies ([`Surface::material`]).
    pub slot: u32,
}

impl<'s> Interaction<'s> {
    /// The interaction of `ray` with `object` at `hit`: the shape's surface answered once, the
    /// material evaluated once (texture coordinates computed only for a textured material).
    #[inline]
    pub fn new(ray: &Ray, hit: Hit, object: &'s Object) -> Self {
        Self::with(ray, &hit, object, |si| *si)
    }

    /// `f` of [`Interaction::new`]'s value, built where `f` reads it: an untextured material's
    /// interaction is assembled in place, where a returned one costs a copy of its whole
    /// coefficient block (176 bytes). For integrators' hot paths ([`crate::Scene::with_interaction`]).
    #[inline(always)]
    pub fn with<T>(ray: &Ray, hit: &Hit, object: &'s Object, f: impl FnOnce(&Interaction<'s>) -> T) -> T {
        let g = object.geometry();
        let s: Surface = g.surface(hit, ray.dir);
        let at = |material| Interaction {
            hit: *hit,
            object,
            dir: ray.dir,
            n: s.n,
            ns: s.ns,
            front_face: s.front_face,
            material,
            slot: s.material,
        };
        match object.coefficients_at(s.material, || g.uv(hit), s.local) {
            // (`black_box` hides that this rebuilds the same value, which the optimiser turned back
            // into the copy.)
            CoefficientsAt::Constant(m) => f(&at(CoefficientsAt::Constant(std::hint::black_box(m)))),
            textured => f(&at(textured)),
        }
    }

    /// The material plugin's scattering model at the hit (`None`: the coefficients alone).
    #[inline]
    pub fn model(&self) -> Option<&'s dyn MaterialModel> {
        self.object.material(self.slot).model.as_ref().map(|m| m.0.as_ref())
    }

    /// The whole material at the hit (its constants and textures, before evaluation).
    #[inline]
    pub fn material_def(&self) -> &'s Material {
        self.object.material(self.slot)
    }

    /// Where textures are looked up at the hit: its texture coordinates and its point in the
    /// shape's own frame (both computed on each call: for material models whose textures are
    /// read at the hit).
    pub fn texture_point(&self) -> TexturePoint {
        let g = self.object.geometry();
        TexturePoint { uv: g.uv(&self.hit), local: g.surface(&self.hit, self.dir).local }
    }

    /// The texture coordinates at the hit ([`crate::Geometry::uv`]; computed on each call).
    pub fn uv(&self) -> DVec2 {
        self.object.geometry().uv(&self.hit)
    }

    /// The light the surface gives off back along the ray: its material model's emission (or
    /// the coefficients' `emission`) if the object emits on the side the ray arrived at
    /// ([`crate::scene::object::EmissionSides`]).
    #[inline]
    pub fn emission(&self) -> Color {
        if !self.object.emission_sides().emits(self.front_face) {
            return Color::ZERO;
        }
        self.model().and_then(|m| m.emission(self)).unwrap_or(self.material.emission)
    }

    /// The hit point.
    #[inline]
    pub fn point(&self) -> DVec3 {
        self.hit.point
    }

    /// A secondary ray leaving the hit along unit `dir`, starting outside the point's error box
    /// on `dir`'s side of the surface ([`Hit::spawn_ray`]).
    #[inline(always)]
    pub fn spawn_ray(&self, dir: DVec3) -> Ray {
        self.hit.spawn_ray(self.n, dir)
    }

    /// A shadow ray toward a light `distance` away along unit `dir`, and its `t_max`
    /// ([`Hit::spawn_shadow_ray`]).
    #[inline(always)]
    pub fn spawn_shadow_ray(&self, dir: DVec3, distance: f64) -> (Ray, f64) {
        self.hit.spawn_shadow_ray(self.n, dir, distance)
    }
}

/// What material models read of the hit.
impl Shading for Interaction<'_> {
    #[inline]
    fn wo(&self) -> DVec3 {
        -self.dir
    }
    #[inline]
    fn n(&self) -> DVec3 {
        self.n
    }
    #[inline]
    fn ns(&self) -> DVec3 {
        self.ns
    }
    #[inline]
    fn front_face(&self) -> bool {
        self.front_face
    }
    fn texture_point(&self) -> TexturePoint {
        Interaction::texture_point(self)
    }
}
