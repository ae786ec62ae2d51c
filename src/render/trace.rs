//! Explanations: the tree of hits, light tests and child rays an integrator followed for one
//! ray, as `raylab trace` prints it (text or JSON) and the live view draws it.
//!
//! Integrators record through a [`Recorder`]: [`TraceNode`] builds the tree, [`NoRecord`] does
//! nothing and costs nothing (its methods are empty and inlined; closures that build records are
//! never called). An integrator writes its recursion once, generic over the recorder, and calls
//! it with [`NoRecord`] to render and with a [`TraceNode`] to explain.

use crate::math::color::Color;
use crate::math::ray::{Ray, RayKind};
use crate::scene::interaction::Interaction;
use glam::DVec3;
use serde::Serialize;
use std::fmt::{self, Write};

/// Most rays one explanation may trace (`raylab trace`, the live view's ray tree): its tree is
/// kept in memory, and one beyond this is neither readable nor small. An integrator whose rays
/// branch gives its explanation this allowance ([`crate::render::stats::RayStats::set_allowance`])
/// and notes where it stopped. It is no budget of the frame: one pixel is never refused for the
/// whole render's cost.
pub const MAX_EXPLAINED_RAYS: u64 = 1 << 16;

/// A named value in an explanation: a colour (a term of the result) or a number (a cosine, a
/// probability density, a weight). The integrator chooses the names.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Term {
    /// What it is (`emission`, `diffuse`, `pdf`, …).
    pub name: &'static str,
    /// Its value.
    pub value: TermValue,
}

/// The value of a [`Term`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum TermValue {
    /// Linear RGB.
    Color(Color),
    /// A number.
    Number(f64),
}

impl Term {
    /// A colour term.
    pub fn color(name: &'static str, value: Color) -> Self {
        Term { name, value: TermValue::Color(value) }
    }

    /// A number term.
    pub fn number(name: &'static str, value: f64) -> Self {
        Term { name, value: TermValue::Number(value) }
    }
}

/// One traced ray and everything computed from it.
#[derive(Clone, Debug, Serialize)]
pub struct TraceNode {
    /// What the ray is for.
    pub kind: RayKind,
    /// The ray.
    pub ray: Ray,
    /// Recursion depth (0 for the camera ray).
    pub depth: u32,
    /// How much this ray's colour counts in the pixel (the product of weights along its path).
    pub weight: Color,
    /// What the ray hit, or `None` (the background).
    pub hit: Option<TraceHit>,
    /// Terms at the hit that do not depend on a light (emission, ambient, …).
    pub terms: Vec<Term>,
    /// Light tests at the hit point, one per light sample.
    pub lights: Vec<TraceLight>,
    /// Child rays (reflection, refraction, bounces), each with its own subtree.
    pub children: Vec<TraceNode>,
    /// The colour this ray returns (before its parent weights it).
    pub color: Color,
    /// Remarks: pruning, depth limit, total internal reflection, …
    pub notes: Vec<String>,
}

impl TraceNode {
    /// A node for `ray` before anything is known about it.
    pub fn new(kind: RayKind, ray: Ray, depth: u32, weight: Color) -> Self {
        TraceNode {
            kind,
            ray,
            depth,
            weight,
            hit: None,
            terms: Vec::new(),
            lights: Vec::new(),
            children: Vec::new(),
            color: Color::ZERO,
            notes: Vec::new(),
        }
    }
}

/// A hit in the explanation.
#[derive(Clone, Debug, Serialize)]
pub struct TraceHit {
    /// Index of the object in the scene.
    pub object: usize,
    /// The object's name (or its type and index when unnamed).
    pub name: String,
    /// Distance along the ray.
    pub t: f64,
    /// The hit point.
    pub point: DVec3,
    /// The geometric normal, facing the incoming ray.
    pub normal: DVec3,
    /// The shading normal, facing the incoming ray.
    pub shading_normal: DVec3,
    /// True when the ray hit the surface's outside.
    pub front_face: bool,
}

impl TraceHit {
    /// The explanation of the interaction `si`.
    pub fn new(si: &Interaction) -> Self {
        TraceHit {
            object: si.hit.object as usize,
            name: si.object.name.clone(),
            t: si.hit.t,
            point: si.hit.point,
            normal: si.n,
            shading_normal: si.ns,
            front_face: si.front_face,
        }
    }
}

/// One light sample's test at a hit point.
#[derive(Clone, Debug, Serialize)]
pub struct TraceLight {
    /// The light's name.
    pub light: String,
    /// Direction from the point toward the light.
    pub dir: DVec3,
    /// Distance to the light (infinite for directional lights, written as null in JSON).
    pub distance: f64,
    /// Intensity arriving at the point before shadowing.
    pub intensity: Color,
    /// Cosine between the shading normal and the direction to the light (0 when the light is
    /// behind the surface as seen from the ray).
    pub n_dot_l: f64,
    /// Fraction of the light that passes occluders (0 = fully shadowed, 1 = unshadowed).
    pub transmittance: Color,
    /// Name of the first occluder, if any.
    pub occluder: Option<String>,
    /// The integrator's terms for this sample (`diffuse`, `specular`; `bsdf`, `pdf`, `mis`, …).
    pub terms: Vec<Term>,
    /// Why no shadow ray was traced, when none was.
    pub skipped: Option<String>,
}

/// Where an integrator records what it does, for explanations. [`NoRecord`] records nothing;
/// [`TraceNode`] builds the tree. Closures passed in are called only when recording.
pub trait Recorder: Sized {
    /// False for [`NoRecord`]: work done only for the explanation can be skipped with
    /// `if R::ON { … }`, and the compiler removes it.
    const ON: bool;
    /// A recorder for a child ray of this one.
    fn child(&self, kind: RayKind, ray: &Ray, depth: u32, weight: Color) -> Self;
    /// Adds a finished child's record under this one.
    fn adopt(&mut self, child: Self);
    /// The ray hit `si`.
    fn hit(&mut self, si: &Interaction);
    /// A term of the result at the hit (`emission`, `ambient`, …).
    fn term(&mut self, term: impl FnOnce() -> Term);
    /// A light sample's test.
    fn light(&mut self, light: impl FnOnce() -> TraceLight);
    /// A remark (pruning, depth limit, …).
    fn note(&mut self, note: impl FnOnce() -> String);
    /// The colour the ray returns.
    fn color(&mut self, c: Color);
}

/// The recorder that records nothing, at no cost.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoRecord;

impl Recorder for NoRecord {
    const ON: bool = false;
    #[inline(always)]
    fn child(&self, _: RayKind, _: &Ray, _: u32, _: Color) -> Self {
        NoRecord
    }
    #[inline(always)]
    fn adopt(&mut self, _: Self) {}
    #[inline(always)]
    fn hit(&mut self, _: &Interaction) {}
    #[inline(always)]
    fn term(&mut self, _: impl FnOnce() -> Term) {}
    #[inline(always)]
    fn light(&mut self, _: impl FnOnce() -> TraceLight) {}
    #[inline(always)]
    fn note(&mut self, _: impl FnOnce() -> String) {}
    #[inline(always)]
    fn color(&mut self, _: Color) {}
}

impl Recorder for TraceNode {
    const ON: bool = true;
    fn child(&self, kind: RayKind, ray: &Ray, depth: u32, weight: Color) -> Self {
        TraceNode::new(kind, *ray, depth, weight)
    }
    fn adopt(&mut self, child: Self) {
        self.children.push(child);
    }
    fn hit(&mut self, si: &Interaction) {
        self.hit = Some(TraceHit::new(si));
    }
    fn term(&mut self, term: impl FnOnce() -> Term) {
        self.terms.push(term());
    }
    fn light(&mut self, light: impl FnOnce() -> TraceLight) {
        self.lights.push(light());
    }
    fn note(&mut self, note: impl FnOnce() -> String) {
        self.notes.push(note());
    }
    fn color(&mut self, c: Color) {
        self.color = c;
    }
}

fn v(c: DVec3) -> String {
    format!("({}, {}, {})", g(c.x), g(c.y), g(c.z))
}

fn g(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if x.is_infinite() {
        if x > 0.0 { "∞".into() } else { "-∞".into() }
    } else if x.abs() >= 1e-3 && x.abs() < 1e6 {
        let s = format!("{x:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{x:.4e}")
    }
}

/// Terms as `name value  name value`.
fn terms(ts: &[Term]) -> String {
    let parts: Vec<String> = ts
        .iter()
        .map(|t| match t.value {
            TermValue::Color(c) => format!("{} {}", t.name, v(c)),
            TermValue::Number(x) => format!("{} {}", t.name, g(x)),
        })
        .collect();
    parts.join("  ")
}

impl TraceNode {
    fn write_tree(&self, out: &mut String, indent: &str) -> fmt::Result {
        let kind = match self.kind {
            RayKind::Camera => "camera ray",
            RayKind::Reflection => "reflection ray",
            RayKind::Refraction => "refraction ray",
            RayKind::Shadow => "shadow ray",
        };
        writeln!(out, "{kind}  depth {}  weight {}", self.depth, v(self.weight))?;
        writeln!(out, "{indent}  origin {}  dir {}", v(self.ray.origin), v(self.ray.dir))?;
        match &self.hit {
            None => writeln!(out, "{indent}  miss (leaves the scene) → {}", v(self.color))?,
            Some(h) => {
                writeln!(
                    out,
                    "{indent}  hit {} (#{}) at t = {}  {} face",
                    h.name,
                    h.object,
                    g(h.t),
                    if h.front_face { "front" } else { "back" }
                )?;
                writeln!(out, "{indent}    point {}  normal {}", v(h.point), v(h.normal))?;
                if !self.terms.is_empty() {
                    writeln!(out, "{indent}    {}", terms(&self.terms))?;
                }
                for l in &self.lights {
                    write!(out, "{indent}    light {}: ", l.light)?;
                    if let Some(why) = &l.skipped {
                        writeln!(out, "skipped ({why})")?;
                        continue;
                    }
                    let shadow = match (&l.occluder, l.transmittance.max_element()) {
                        (None, _) => "unshadowed".to_string(),
                        (Some(o), 0.0) => format!("shadowed by {o}"),
                        (Some(o), _) => format!("partly shadowed by {o}, transmittance {}", v(l.transmittance)),
                    };
                    writeln!(
                        out,
                        "n·l = {}, distance {}, I = {}, {shadow}\n{indent}      {}",
                        g(l.n_dot_l),
                        g(l.distance),
                        v(l.intensity),
                        terms(&l.terms)
                    )?;
                }
            }
        }
        for n in &self.notes {
            writeln!(out, "{indent}  note: {n}")?;
        }
        let count = self.children.len();
        for (i, c) in self.children.iter().enumerate() {
            let last = i + 1 == count;
            write!(out, "{indent}  {}", if last { "└─ " } else { "├─ " })?;
            let child_indent = format!("{indent}  {}", if last { "   " } else { "│  " });
            c.write_tree(out, &child_indent)?;
        }
        if self.hit.is_some() {
            writeln!(out, "{indent}  = colour {}", v(self.color))?;
        }
        Ok(())
    }

    /// The tree as indented text.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        self.write_tree(&mut s, "").expect("writing to a String cannot fail");
        s
    }
}
