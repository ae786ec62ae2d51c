//! The explanation of one ray: the tree of hits, light tests and child rays an integrator
//! followed, as printed by `raylab trace` (as text, or as JSON).

use crate::math::color::Color;
use crate::math::ray::{Ray, RayKind};
use glam::DVec3;
use serde::Serialize;
use std::fmt::{self, Write};

/// One traced ray and everything computed from it.
#[derive(Clone, Debug, Serialize)]
pub struct TraceNode {
    /// What the ray is for.
    pub kind: RayKind,
    /// The ray.
    pub ray: Ray,
    /// Recursion depth (0 for the camera ray).
    pub depth: u32,
    /// The product of coefficients along the path to this ray: how much its colour counts in the pixel.
    pub weight: Color,
    /// What the ray hit, or `None` (the background).
    pub hit: Option<TraceHit>,
    /// Light tests at the hit point, one per light sample.
    pub lights: Vec<TraceLight>,
    /// Emission of the hit surface.
    pub emission: Color,
    /// Ambient term at the hit point.
    pub ambient: Color,
    /// Child rays (reflection, refraction), each with its own subtree.
    pub children: Vec<TraceNode>,
    /// The colour this ray returns (before its parent multiplies it by its coefficient).
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
            lights: Vec::new(),
            emission: Color::ZERO,
            ambient: Color::ZERO,
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
    /// The direction-aware normal used for shading (faces the incoming ray).
    pub normal: DVec3,
    /// True when the ray hit the surface's outside.
    pub front_face: bool,
}

impl TraceHit {
    /// The explanation of `hit` in `scene` as seen along direction `dir`.
    pub fn new(scene: &crate::scene::Scene, hit: &crate::geometry::Hit, dir: DVec3) -> Self {
        let g = &scene.geometries[hit.object as usize];
        TraceHit {
            object: hit.object as usize,
            name: scene.object_name(hit.object).to_string(),
            t: hit.t,
            point: hit.point,
            normal: g.normal(hit, dir),
            front_face: g.outward_normal(hit).dot(dir) < 0.0,
        }
    }
}

/// One light's contribution at a hit point.
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
    /// `n · l` with the shading normal.
    pub n_dot_l: f64,
    /// Fraction of the light that passes occluders (0 = fully shadowed, 1 = unshadowed).
    pub transmittance: Color,
    /// Name of the first occluder, if any.
    pub occluder: Option<String>,
    /// Diffuse term `kd · (n·l) · I_L · shadow`.
    pub diffuse: Color,
    /// Specular term `ks · max(0, −v·r)^shininess · I_L · shadow`.
    pub specular: Color,
    /// Why no shadow ray was traced, when none was.
    pub skipped: Option<String>,
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
            None => writeln!(out, "{indent}  miss → background {}", v(self.color))?,
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
                writeln!(out, "{indent}    emission {}  ambient {}", v(self.emission), v(self.ambient))?;
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
                        "n·l = {}, distance {}, I = {}, {shadow}\n{indent}      diffuse {}  specular {}",
                        g(l.n_dot_l),
                        g(l.distance),
                        v(l.intensity),
                        v(l.diffuse),
                        v(l.specular)
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
