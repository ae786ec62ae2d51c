//! [`Object`]: a shape placed in a scene with its materials, as the loader assembles it.

use crate::geometry::{Geometry, Hit, Intersectable, PACKET};
use crate::math::color::Color;
use crate::math::ray::Ray;
use crate::scene::material::{Coefficients, CoefficientsAt, Material};
use crate::scene::texture::TexturePoint;
use std::sync::{Arc, OnceLock};

/// Which sides of an object's surface give off its material's `emission`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum EmissionSides {
    /// Both sides (raylab's convention, the report's: an emissive sheet glows on both faces).
    #[default]
    Both,
    /// The outward side only ([`crate::Geometry::outward_normal`]'s: out of a closed solid, a
    /// triangle's winding side): Mitsuba's and glTF's area emitters (`doubleSided = false`).
    Front,
    /// The inward side only (the inside of an emissive dome).
    Back,
}

impl EmissionSides {
    /// The scene file's names, in the order of the variants.
    pub const NAMES: [&'static str; 3] = ["both", "front", "back"];

    /// The sides a scene file names.
    pub fn parse(s: &str) -> Option<EmissionSides> {
        match s {
            "both" => Some(EmissionSides::Both),
            "front" => Some(EmissionSides::Front),
            "back" => Some(EmissionSides::Back),
            _ => None,
        }
    }

    /// Whether light leaves the side a ray arriving on the outward side (`front_face`) sees.
    #[inline]
    pub fn emits(self, front_face: bool) -> bool {
        match self {
            EmissionSides::Both => true,
            EmissionSides::Front => front_face,
            EmissionSides::Back => !front_face,
        }
    }

    /// How many sides emit.
    #[inline]
    pub fn count(self) -> u32 {
        if self == EmissionSides::Both { 2 } else { 1 }
    }
}

/// A scene object: a shape (already placed by its transform) and the materials its surface uses.
pub struct Object {
    /// Display name (the scene's `name`, or the type and index when unnamed).
    pub name: String,
    geometry: Box<dyn Geometry>,
    materials: Arc<[Material]>,
    /// Each material's [`Material::constants`], by slot: what hits on untextured materials borrow.
    constants: Box<[Coefficients]>,
    transmissive: bool,
    /// [`Geometry::is_closed`]: for a large mesh a pass over every edge, which only refraction
    /// needs; asked when the object is made if it transmits light, else on first use.
    closed: OnceLock<bool>,
    sides: EmissionSides,
    /// Whether some material has a normal or bump map (hits then tilt the shading normal).
    normal_mapped: bool,
    /// No material can emit: each has no model of its own, no texture and zero `emission`.
    dark: bool,
    /// [`Intersectable::is_flat`], asked once: the scene's lists read it per ray.
    flat: bool,
}

impl Object {
    /// `geometry` with `materials` (an empty list means the default material).
    pub fn new(name: impl Into<String>, geometry: Box<dyn Geometry>, materials: Arc<[Material]>) -> Object {
        let materials = if materials.is_empty() { Arc::from([Material::default()]) } else { materials };
        let transmissive = materials.iter().any(Material::is_transmissive);
        // Refraction at a transmissive surface needs it: answered now, not by the first ray.
        let closed = OnceLock::new();
        if transmissive {
            let _ = closed.set(geometry.is_closed());
        }
        let constants = materials.iter().map(Material::constants).collect();
        let normal_mapped = materials.iter().any(|m| m.normal_map.is_some());
        let dark = materials.iter().all(|m| m.model.is_none() && !m.is_textured() && m.emission == Color::ZERO);
        let flat = geometry.is_flat();
        Object {
            name: name.into(),
            geometry,
            materials,
            constants,
            transmissive,
            closed,
            sides: EmissionSides::Both,
            normal_mapped,
            dark,
            flat,
        }
    }

    /// `geometry` with one material.
    pub fn with_material(name: impl Into<String>, geometry: Box<dyn Geometry>, material: Material) -> Object {
        Object::new(name, geometry, Arc::from([material]))
    }

    /// The object with its emission leaving `sides` of the surface.
    pub fn with_emission_sides(mut self, sides: EmissionSides) -> Object {
        self.sides = sides;
        self
    }

    /// Which sides of the surface emit.
    #[inline]
    pub fn emission_sides(&self) -> EmissionSides {
        self.sides
    }

    /// The shape.
    #[inline]
    pub fn geometry(&self) -> &dyn Geometry {
        self.geometry.as_ref()
    }

    /// The materials, indexed by the shape's [`crate::geometry::Surface::material`] slot (a slot
    /// beyond the list uses the first). Never empty.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Whether some material may transmit light (shadow rays then walk through the object).
    #[inline]
    pub fn may_transmit(&self) -> bool {
        self.transmissive
    }

    /// Whether some material has a normal or bump map ([`Material::normal_map`]).
    #[inline]
    pub fn is_normal_mapped(&self) -> bool {
        self.normal_mapped
    }

    /// True when no point of the object emits: every material is the coefficients alone,
    /// untextured, with zero `emission` (a hit's [`crate::scene::interaction::Interaction::emission`]
    /// is then zero without looking).
    #[inline]
    pub fn is_dark(&self) -> bool {
        self.dark
    }

    /// Whether the shape encloses a volume ([`Geometry::is_closed`]): refraction bends rays only
    /// at closed surfaces.
    #[inline]
    pub fn is_closed(&self) -> bool {
        *self.closed.get_or_init(|| self.geometry.is_closed())
    }

    /// The material in slot `slot`.
    #[inline]
    pub fn material(&self, slot: u32) -> &Material {
        &self.materials[self.slot_index(slot)]
    }

    /// Index of the material in slot `slot`: the first one for a slot the object lacks.
    #[inline]
    fn slot_index(&self, slot: u32) -> usize {
        if (slot as usize) < self.materials.len() { slot as usize } else { 0 }
    }

    /// The coefficients of the material in slot `slot` at a surface point ([`Material::at`]):
    /// borrowed when the material is untextured, else evaluated at the texture point `at` gives.
    #[inline]
    pub fn coefficients_at(&self, slot: u32, at: impl FnOnce() -> TexturePoint) -> CoefficientsAt<'_> {
        // Out of line: an untextured hit's path stays small.
        #[inline(never)]
        fn textured(m: &Material, at: impl FnOnce() -> TexturePoint) -> CoefficientsAt<'static> {
            CoefficientsAt::Textured(m.at(at))
        }
        let slot = self.slot_index(slot);
        let m = &self.materials[slot];
        if m.is_textured() { textured(m, at) } else { CoefficientsAt::Constant(&self.constants[slot]) }
    }
}

impl Intersectable for Object {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        self.geometry.intersect(ray, t_min, t_max)
    }
    #[inline]
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.geometry.occludes(ray, t_min, t_max)
    }
    #[inline]
    fn occludes_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> bool {
        self.geometry.occludes_leaving(ray, t_min, t_max, prim)
    }
    #[inline]
    fn intersect_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> Option<Hit> {
        self.geometry.intersect_leaving(ray, t_min, t_max, prim)
    }
    #[inline]
    fn intersect_into(&self, ray: &Ray, t_min: f64, t_max: f64, hit: &mut Hit) -> bool {
        self.geometry.intersect_into(ray, t_min, t_max, hit)
    }
    /// The shape's answer, kept when the object was made.
    #[inline]
    fn is_flat(&self) -> bool {
        self.flat
    }
    #[inline]
    fn intersect_packet(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        self.geometry.intersect_packet(rays, live, t_min, t_max, out)
    }
    fn walks_packets(&self) -> bool {
        self.geometry.walks_packets()
    }
    #[inline]
    fn occludes_packet(
        &self,
        rays: &[Ray; PACKET],
        live: u32,
        t_min: f64,
        t_max: &[f64; PACKET],
        leaving: u32,
        prims: &[u32; PACKET],
    ) -> u32 {
        self.geometry.occludes_packet(rays, live, t_min, t_max, leaving, prims)
    }
}
