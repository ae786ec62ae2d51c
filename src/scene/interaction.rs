//! [`Interaction`]: what an integrator needs at a hit, computed once: the object, the point and
//! its error bound, both normals facing the incoming ray; and, on request, the material's
//! coefficients there ([`Interaction::coefficients`]: textures looked up at the hit's texture
//! coordinates).

use crate::geometry::differential::RaySpread;
use crate::geometry::{Hit, Surface};
use crate::math::color::Color;
use crate::math::float::offset_ray_origin;
use crate::math::ray::Ray;
use crate::scene::bsdf::{MaterialModel, Shading};
use crate::scene::material::{CoefficientsAt, Material};
use crate::scene::normal_map::{ensure_valid_reflection, shading_normal};
use crate::scene::object::Object;
use crate::scene::texture::TexturePoint;
use glam::{DVec2, DVec3};

/// A ray's hit on a scene object, with everything shading reads (see [`crate::Scene::trace`]).
///
/// Small on purpose: the material's coefficients are not part of it (a textured material's
/// block is 176 bytes); an integrator asks for them once per hit ([`Interaction::coefficients`])
/// and keeps them where it reads them.
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
    /// Unit shading normal facing the incoming ray: lighting. Tilted by the material's normal or
    /// bump map, if it has one ([`crate::scene::normal_map`]).
    pub ns: DVec3,
    /// The hit point in the shape's own frame ([`Surface::local`]): where solid textures are
    /// looked up.
    pub local: DVec3,
    /// True when the ray arrived on the surface's outward side.
    pub front_face: bool,
    /// Which of the object's materials applies ([`Surface::material`]).
    pub slot: u32,
    /// What the incoming ray knows of its spread over the image ([`RaySpread::Off`] unless the
    /// integrator gave it one, [`Interaction::with_spread`]): texture lookups filter over the
    /// footprint it gives.
    pub spread: RaySpread,
}

impl<'s> Interaction<'s> {
    /// The interaction of `ray` with `object` at `hit`: the shape's surface answered once.
    #[inline(always)]
    pub fn new(ray: &Ray, hit: Hit, object: &'s Object) -> Self {
        let s: Surface = object.geometry().surface(&hit, ray.dir);
        let mut ns = s.ns;
        if object.is_normal_mapped()
            && let Some(map) = &object.material(s.material).normal_map
            && let Some(tilted) = shading_normal(map, object.geometry(), &hit, &s, ray.dir)
        {
            ns = tilted;
        }
        Interaction {
            hit,
            object,
            dir: ray.dir,
            n: s.n,
            ns,
            local: s.local,
            front_face: s.front_face,
            slot: s.material,
            spread: RaySpread::Off,
        }
    }

    /// This interaction with the incoming ray's `spread` (its ray differential, or the camera's
    /// approximation): texture lookups then filter over the pixel's footprint.
    #[inline(always)]
    pub fn with_spread(mut self, spread: RaySpread) -> Self {
        self.spread = spread;
        self
    }

    /// The material's coefficients at the hit, evaluated on each call: borrowed from the object
    /// when the material is untextured (nothing computed or copied), else its textures looked up
    /// at the hit (texture coordinates and footprint computed only then). Ask once per hit and
    /// keep the value.
    #[inline]
    pub fn coefficients(&self) -> CoefficientsAt<'s> {
        self.object.coefficients_at(self.slot, || self.texture_point())
    }

    /// How the hit moves on its tangent plane from one pixel to the next (`∂p/∂x`, `∂p/∂y`), from
    /// the incoming ray's spread; `None` when it has none.
    #[inline]
    pub fn pixel_moves(&self) -> Option<(DVec3, DVec3)> {
        self.spread.on_surface(self.hit.point, self.dir, self.hit.t, self.n)
    }

    /// The spread of the ray mirrored at the hit into unit direction `wi`: the incoming ray's
    /// differential reflected (Igehy), with the normal's turn where the shape gives it; a ray
    /// without an exact differential keeps what it has.
    #[inline]
    pub fn reflected_spread(&self, wi: DVec3) -> RaySpread {
        let _ = wi;
        match self.spread {
            RaySpread::Differential(d) => {
                let dp = d.on_plane(self.dir, self.hit.t, self.n);
                RaySpread::Differential(d.reflect(self.dir, self.ns, dp, self.normal_turn(dp)))
            }
            s => s,
        }
    }

    /// The spread of the ray refracted at the hit into unit direction `wi`, `eta` being the ratio
    /// of refractive indices (incident over transmitted side; 1 through a thin sheet).
    #[inline]
    pub fn refracted_spread(&self, wi: DVec3, eta: f64) -> RaySpread {
        match self.spread {
            RaySpread::Differential(d) => {
                let dp = d.on_plane(self.dir, self.hit.t, self.n);
                RaySpread::Differential(d.refract(self.dir, self.ns, wi, eta, dp, self.normal_turn(dp)))
            }
            s => s,
        }
    }

    /// How the facing normal turns with the moves `dp` ([`crate::Geometry::derivatives`]; zero
    /// where the shape does not say).
    fn normal_turn(&self, (dpdx, dpdy): (DVec3, DVec3)) -> (DVec3, DVec3) {
        match self.object.geometry().derivatives(&self.hit) {
            Some(d) => {
                let s = if self.front_face { 1.0 } else { -1.0 };
                (s * d.normal_change(dpdx), s * d.normal_change(dpdy))
            }
            None => (DVec3::ZERO, DVec3::ZERO),
        }
    }

    /// The normal perfect specular events (mirrors, refraction) turn about: the shading normal
    /// [`Interaction::ns`] (an interpolated vertex normal, a normal map's tilt), bent toward the
    /// geometric normal just enough that the mirror reflection of the incoming ray stays above
    /// the geometric surface ([`ensure_valid_reflection`], Cycles'
    /// `ensure_valid_specular_reflection`); `ns` itself wherever it already does, and `n` on
    /// flat surfaces. A smooth-shaded mesh then mirrors as the smooth surface its normals
    /// describe, not facet by facet, and no reflected ray leaves into the surface.
    #[inline]
    pub fn specular_normal(&self) -> DVec3 {
        if self.ns == self.n { self.n } else { ensure_valid_reflection(self.n, -self.dir, self.ns) }
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

    /// Where textures are looked up at the hit: its texture coordinates, its point in the
    /// shape's own frame and, when the ray has a spread, the pixel's footprint (computed on each
    /// call: for material models whose textures are read at the hit).
    pub fn texture_point(&self) -> TexturePoint {
        let g = self.object.geometry();
        let (at, second) = TexturePoint::at_hit(g, &self.hit, self.local);
        match self.pixel_moves() {
            Some((dpdx, dpdy)) => {
                let f = g.footprint(&self.hit, dpdx, dpdy);
                at.with_footprint(match second {
                    Some(j) => f.with_second_set(j),
                    None => f,
                })
            }
            None => at,
        }
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
        if self.object.is_dark() || !self.object.emission_sides().emits(self.front_face) {
            return Color::ZERO;
        }
        self.model().and_then(|m| m.emission(self)).unwrap_or_else(|| self.coefficients().emission)
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

    /// The origin [`Interaction::spawn_ray`] gives every ray leaving on the geometric normal's
    /// side (`dir · n ≥ 0`, [`Interaction::leaves_front`]): [`offset_ray_origin`] reads a ray's
    /// direction only for the side it leaves by, so a shading point whose shadow rays and mirror
    /// ray all leave in front can compute it once for all of them, with the same bits.
    #[inline(always)]
    pub fn front_origin(&self) -> DVec3 {
        offset_ray_origin(self.hit.point, self.hit.error, self.n, self.n)
    }

    /// Whether a ray along `dir` leaves on the geometric normal's side, where it starts at
    /// [`Interaction::front_origin`] (`dir · n` not negative, as [`offset_ray_origin`] decides).
    #[inline(always)]
    pub fn leaves_front(&self, dir: DVec3) -> bool {
        !(dir.dot(self.n) < 0.0)
    }

    /// [`Interaction::spawn_shadow_ray`] for a `dir` that [leaves in front](Interaction::leaves_front),
    /// from its [`Interaction::front_origin`] `front`: the same ray and `t_max`.
    #[inline(always)]
    pub fn front_shadow_ray(&self, front: DVec3, dir: DVec3, distance: f64) -> (Ray, f64) {
        self.hit.shadow_ray_from(Ray { origin: front, dir }, distance)
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
