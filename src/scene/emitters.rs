//! Emitting objects as lights: every object whose material emits and whose shape can be sampled
//! ([`crate::Geometry::sample_surface`]) is an emitter. An integrator picks one (by power, in
//! constant time, or uniformly), samples a point of it seen from the shaded point, and asks for
//! the same density when one of its own rays meets the emitter (multiple importance sampling).
//! Objects whose shape offers no sampling still emit: only rays find them.

use crate::geometry::{Hit, PLANE_TOLERANCE, SurfacePdf};
use crate::math::color::{Color, luminance};
use crate::math::distribution::AliasTable;
use crate::math::ray::Ray;
use crate::scene::interaction::Interaction;
use crate::scene::object::{EmissionSides, Object};
use glam::{DVec2, DVec3};
use std::f64::consts::PI;

/// How an emitter is chosen for a light sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Selection {
    /// In proportion to each emitter's power (emission × area × sides): a dim emitter among
    /// bright ones costs almost no samples.
    #[default]
    Power,
    /// Every emitter equally often.
    Uniform,
}

impl Selection {
    /// The names a scene file uses, in the order of the variants.
    pub const NAMES: [&'static str; 2] = ["power", "uniform"];

    /// The selection a scene file names.
    pub fn parse(s: &str) -> Option<Selection> {
        match s {
            "power" => Some(Selection::Power),
            "uniform" => Some(Selection::Uniform),
            _ => None,
        }
    }
}

/// Marks an object that is not an emitter in [`Emitters`]'s index.
const NOT_AN_EMITTER: u32 = u32::MAX;

/// The scene's emitters (built with the scene, see the module docs).
#[derive(Clone, Debug, Default)]
pub struct Emitters {
    /// The object index of each emitter.
    objects: Vec<u32>,
    /// Each emitter's power, `π × luminance of its brightest emission × area × sides`.
    power: Vec<f64>,
    /// The emitter index of each object ([`NOT_AN_EMITTER`]: none).
    of_object: Vec<u32>,
    /// Each emitter's emission where it is one constant over its surface (every material
    /// untextured, without a model of its own, of the same `emission`): a sample's radiance is
    /// then this or zero, by side, without building the hit's [`Interaction`]. `None`: asked
    /// at the point ([`Interaction::emission`]).
    constant: Vec<Option<Color>>,
    /// Each emitter's [`crate::Geometry::is_convex`].
    convex: Vec<bool>,
    /// Each emitter's dark side where it is flat and emits on one side only ([`DarkSide`]).
    dark: Vec<Option<DarkSide>>,
    /// The emitters by power; `None` when there is none.
    table: Option<AliasTable>,
}

/// The side of a flat emitter that gives off no light ([`crate::Geometry::plane`]): a point
/// there, farther than the margin from the plane, sees only the emitter's back.
#[derive(Clone, Copy, Debug)]
struct DarkSide {
    /// A point of the plane.
    point: DVec3,
    /// Unit normal of the plane toward its dark side.
    toward: DVec3,
    /// The emitter's magnitude (largest coordinate of its bounds).
    magnitude: f64,
}

impl DarkSide {
    /// Whether `reference` lies on the dark side, beyond the points' distances from the plane
    /// and any rounding of a sample's side test ([`PLANE_TOLERANCE`] of the magnitudes).
    #[inline]
    fn holds(&self, reference: DVec3) -> bool {
        let margin = PLANE_TOLERANCE * (self.magnitude + reference.abs().max_element());
        (reference - self.point).dot(self.toward) > margin
    }
}

/// A point of an emitter chosen to light a point ([`Emitters::sample`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterSample {
    /// The object chosen.
    pub object: u32,
    /// The point as a hit of the ray from the shaded point toward it (`t` its distance).
    pub hit: Hit,
    /// Unit direction from the shaded point to the emitter's point.
    pub dir: DVec3,
    /// Radiance the point sends toward the shaded point (zero from a side that does not emit).
    pub radiance: Color,
    /// Density per unit solid angle of this direction, the emitter's choice included; infinite
    /// where the emitter is seen edge-on.
    pub pdf: f64,
    /// The emitter cannot hide the point from the shaded point: its shape is convex
    /// ([`crate::Geometry::is_convex`]) and the point's outward side faces the shaded point. A
    /// shadow ray toward it need not test the emitter itself ([`crate::Scene::occludes_except`]).
    pub clear_of_itself: bool,
}

impl Emitters {
    /// The emitters among `objects`.
    pub fn new(objects: &[Object]) -> Emitters {
        let mut e = Emitters { of_object: vec![NOT_AN_EMITTER; objects.len()], ..Emitters::default() };
        for (i, o) in objects.iter().enumerate() {
            let brightest = o.materials().iter().map(|m| luminance(m.emission.max(Color::ZERO))).fold(0.0, f64::max);
            let sides = f64::from(o.emission_sides().count());
            // An object that emits nothing is not asked its area: a mesh builds a table of its
            // triangles' areas to answer (tens of MB for a million triangles), which only an
            // emitter needs.
            if !(brightest * sides > 0.0) {
                continue;
            }
            let Some(area) = o.geometry().area() else { continue };
            let power = PI * brightest * area * sides;
            if power > 0.0 && power.is_finite() && e.objects.len() < NOT_AN_EMITTER as usize {
                e.of_object[i] = e.objects.len() as u32;
                e.objects.push(i as u32);
                e.power.push(power);
                e.constant.push(constant_emission(o));
                e.convex.push(o.geometry().is_convex());
                e.dark.push(dark_side(o));
            }
        }
        e.table = AliasTable::new(&e.power);
        e
    }

    /// Number of emitters.
    #[inline]
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// True when no object can be sampled as a light.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// The object index and power of each emitter.
    pub fn iter(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        self.objects.iter().copied().zip(self.power.iter().copied())
    }

    /// The probability that `selection` chooses the emitter of object `object` (0 for an object
    /// that is not an emitter).
    #[inline]
    pub fn choice_pmf(&self, object: u32, selection: Selection) -> f64 {
        let Some(&e) = self.of_object.get(object as usize).filter(|&&e| e != NOT_AN_EMITTER) else { return 0.0 };
        match (selection, &self.table) {
            (Selection::Power, Some(t)) => t.pmf(e as usize),
            (Selection::Power, None) => 0.0,
            (Selection::Uniform, _) => 1.0 / self.objects.len() as f64,
        }
    }

    /// An emitter chosen by `selection` with `pick` uniform in `[0, 1)`, and a point of it seen
    /// from `reference` for `u` uniform in `[0, 1)²`. `None` when there is no emitter or its shape
    /// gives no point there. ([`Emitters::choose`], then [`Emitters::sample_chosen`].)
    #[inline]
    pub fn sample(&self, objects: &[Object], reference: DVec3, pick: f64, u: DVec2, selection: Selection) -> Option<EmitterSample> {
        let chosen = self.choose(pick, selection)?;
        self.sample_chosen(objects, chosen, reference, u)
    }

    /// The emitter `selection` chooses with `pick` uniform in `[0, 1)`: its index among the
    /// emitters and the probability of the choice. `None` when there is no emitter.
    #[inline]
    pub fn choose(&self, pick: f64, selection: Selection) -> Option<(usize, f64)> {
        Some(match selection {
            // A lone emitter is chosen with probability 1, which is its table's pmf exactly.
            Selection::Power if self.objects.len() == 1 => (0, 1.0),
            Selection::Power => {
                let (e, pmf, _) = self.table.as_ref()?.sample(pick);
                (e, pmf)
            }
            Selection::Uniform => {
                let n = self.objects.len();
                (((pick * n as f64) as usize).min(n.checked_sub(1)?), 1.0 / n as f64)
            }
        })
    }

    /// Whether no point of emitter `e` (an index [`Emitters::choose`] gives) sends light toward
    /// `reference`: a flat emitter ([`crate::Geometry::plane`]) that emits on one side only,
    /// seen from the other side, clear of its plane. Every sample of it from there has zero
    /// radiance ([`Emitters::sample_chosen`]); a caller may skip drawing one. False where unsure.
    #[inline]
    pub fn dark_from(&self, e: usize, reference: DVec3) -> bool {
        matches!(self.dark.get(e), Some(Some(d)) if d.holds(reference))
    }

    /// A point of emitter `e`, chosen with probability `pmf` ([`Emitters::choose`]), seen from
    /// `reference`, for `u` uniform in `[0, 1)²`. `None` when its shape gives no point there.
    #[inline]
    pub fn sample_chosen(&self, objects: &[Object], (e, pmf): (usize, f64), reference: DVec3, u: DVec2) -> Option<EmitterSample> {
        let object = self.objects[e];
        let o = &objects[object as usize];
        let s = o.geometry().sample_surface(reference, u)?;
        let to = s.hit.point - reference;
        let d2 = to.length_squared();
        let distance = d2.sqrt();
        if !(distance > 0.0 && distance.is_finite()) {
            return None;
        }
        let dir = to / distance;
        // `SurfacePdf::solid_angle` from the distance already found (the same operations).
        let pdf = pmf
            * match s.pdf {
                SurfacePdf::Area(p) if p > 0.0 => p * d2 / (s.normal.dot(to).abs() / distance),
                pdf => pdf.solid_angle(reference, s.hit.point, s.normal),
            };
        let hit = Hit { t: distance, object, ..s.hit };
        // The emission as a ray from the reference would see it there (side, textures): one
        // constant by the side the ray arrives at (the outward normal's, as `Geometry::surface`
        // decides it), or asked of the hit.
        let front_face = s.normal.dot(dir) < 0.0;
        let radiance = match self.constant[e] {
            Some(emission) => {
                if o.emission_sides().emits(front_face) {
                    emission
                } else {
                    Color::ZERO
                }
            }
            None => Interaction::new(&Ray { origin: reference, dir }, hit, o).emission(),
        };
        Some(EmitterSample { object, hit, dir, radiance, pdf, clear_of_itself: front_face && self.convex[e] })
    }

    /// The density per unit solid angle with which [`Emitters::sample`] from `reference` gives the
    /// point of `si` (a ray's first hit from `reference`), the emitter's choice included; 0 when
    /// its object is not an emitter.
    pub fn pdf(&self, reference: DVec3, si: &Interaction, selection: Selection) -> f64 {
        let pmf = self.choice_pmf(si.hit.object, selection);
        if !(pmf > 0.0) {
            return 0.0;
        }
        let g = si.object.geometry();
        let pdf: SurfacePdf = g.surface_pdf(reference, &si.hit);
        pmf * pdf.solid_angle(reference, si.hit.point, g.outward_normal(&si.hit))
    }
}

/// The dark side of `o` where it is flat and emits on one side only ([`Emitters::dark`]).
fn dark_side(o: &Object) -> Option<DarkSide> {
    let g = o.geometry();
    let (point, outward) = g.plane()?;
    let toward = match o.emission_sides() {
        EmissionSides::Front => -outward,
        EmissionSides::Back => outward,
        EmissionSides::Both => return None,
    };
    let b = g.bounds()?;
    let magnitude = b.min.abs().max(b.max.abs()).max_element();
    (point.is_finite() && toward.is_finite() && magnitude.is_finite()).then_some(DarkSide { point, toward, magnitude })
}

/// The emission of every point of `o`, when it is one constant ([`Emitters::constant`]).
fn constant_emission(o: &Object) -> Option<Color> {
    let first = o.materials().first()?.emission;
    let plain =
        |m: &crate::scene::material::Material| m.model.is_none() && !m.is_textured() && m.normal_map.is_none() && m.emission == first;
    o.materials().iter().all(plain).then_some(first)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Geometry, Intersectable};
    use crate::math::bounds::Aabb;
    use crate::scene::material::Material;
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A unit square that counts how often it is asked its area.
    struct Counted(Arc<AtomicUsize>);
    impl Intersectable for Counted {
        fn intersect(&self, _: &Ray, _: f64, _: f64) -> Option<Hit> {
            None
        }
    }
    impl Geometry for Counted {
        fn outward_normal(&self, _: &Hit) -> DVec3 {
            DVec3::Z
        }
        fn bounds(&self) -> Option<Aabb> {
            Some(Aabb::new(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0)))
        }
        fn area(&self) -> Option<f64> {
            self.0.fetch_add(1, Ordering::Relaxed);
            Some(1.0)
        }
    }

    /// A mesh answers `area` by building a table over its triangles (tens of MB for a million
    /// of them: the 1.1M-triangle OBJ's peak memory grew by a third when every object was asked):
    /// only an object that emits is asked.
    #[test]
    fn only_emitting_objects_are_asked_their_area() {
        let (dark, bright) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
        let lamp = Material { emission: Color::new(1.0, 1.0, 1.0), ..Material::default() };
        let objects = [
            Object::with_material("dark", Box::new(Counted(dark.clone())), Material::default()),
            Object::with_material("lamp", Box::new(Counted(bright.clone())), lamp),
        ];
        let e = Emitters::new(&objects);
        assert_eq!(e.iter().map(|(o, _)| o).collect::<Vec<_>>(), [1]);
        assert_eq!((dark.load(Ordering::Relaxed), bright.load(Ordering::Relaxed)), (0, 1));
    }
}
