//! The rays of an explained sample drawn over the image: each ray of the tree and each light test
//! as a segment between image positions (the camera's projection, [`Camera::project`]), clipped to
//! what lies in front of the eye and near the frame.

use crate::math::ray::RayKind;
use crate::render::trace::TraceNode;
use crate::scene::camera::Camera;
use glam::{DVec2, DVec3};
use serde::Serialize;

/// One mark over the image, in continuous pixel coordinates.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Mark {
    /// `reflection`, `refraction`, `shadow` (a child ray of that kind), `light` (a light test:
    /// `lit`, `blocked`, `partial` or `skipped` in `state`), or `hit` (a point).
    pub kind: &'static str,
    /// For light tests: `lit`, `blocked`, `partial` or `skipped`; for rays: `hit` or `miss`.
    pub state: &'static str,
    /// The tree node it belongs to: `0` for the camera ray, `0.1` for its second child, …
    pub node: String,
    /// Start (or the point).
    pub from: [f64; 2],
    /// End (equal to `from` for a point).
    pub to: [f64; 2],
}

/// Marks reach at most this many frame sizes beyond the frame (farther parts are cut off).
const MARGIN_FRAMES: f64 = 1.0;

/// Depths below this fraction of the camera's screen distance count as at the eye: segments are
/// cut there before projecting.
const NEAR_FRACTION: f64 = 1e-3;

/// Where a segment ends: a point, or infinitely far in a direction.
#[derive(Clone, Copy)]
enum End {
    Point(DVec3),
    Toward(DVec3),
}

struct View<'a> {
    camera: &'a Camera,
    width: u32,
    height: u32,
    near: f64,
}

impl View<'_> {
    fn depth(&self, p: DVec3) -> f64 {
        (p - self.camera.position).dot(self.camera.to)
    }

    /// The image segment of `a → end`, or `None` when none of it is in front of the eye or near
    /// the frame.
    fn segment(&self, a: DVec3, end: End) -> Option<([f64; 2], [f64; 2])> {
        let (mut a, da) = (a, self.depth(a));
        let (p, q) = match end {
            End::Point(b) => {
                let db = self.depth(b);
                if da < self.near && db < self.near {
                    return None;
                }
                let cut = |p: DVec3, dp: f64, q: DVec3, dq: f64| p + (q - p) * ((self.near - dp) / (dq - dp));
                let (a2, b2) = (if da < self.near { cut(a, da, b, db) } else { a }, if db < self.near { cut(b, db, a, da) } else { b });
                (self.project(a2)?, self.project(b2)?)
            }
            End::Toward(dir) => {
                let along = dir.dot(self.camera.to);
                if along > 0.0 {
                    // The far end is the direction's vanishing point.
                    if da < self.near {
                        a += dir * ((self.near - da) / along);
                    }
                    (self.project(a)?, self.project(self.camera.position + dir)?)
                } else {
                    if da < self.near {
                        return None;
                    }
                    // Toward the eye: as far as the near plane; parallel to the screen: far out.
                    let t = if along < 0.0 { (da - self.near) / -along } else { da / NEAR_FRACTION };
                    let b = a + dir * t;
                    (self.project(a)?, self.project(b)?)
                }
            }
        };
        self.clip(p, q)
    }

    fn project(&self, p: DVec3) -> Option<DVec2> {
        self.camera.project(self.width, self.height, p)
    }

    /// Liang–Barsky clipping of `p → q` to the frame grown by [`MARGIN_FRAMES`].
    fn clip(&self, p: DVec2, q: DVec2) -> Option<([f64; 2], [f64; 2])> {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let (lo, hi) = (DVec2::new(-w, -h) * MARGIN_FRAMES, DVec2::new(w, h) * (1.0 + MARGIN_FRAMES));
        let d = q - p;
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (dp, lo_gap, hi_gap) in [(d.x, p.x - lo.x, hi.x - p.x), (d.y, p.y - lo.y, hi.y - p.y)] {
            for (pk, qk) in [(-dp, lo_gap), (dp, hi_gap)] {
                if pk == 0.0 {
                    if qk < 0.0 {
                        return None;
                    }
                } else {
                    let r = qk / pk;
                    if pk < 0.0 {
                        t0 = t0.max(r);
                    } else {
                        t1 = t1.min(r);
                    }
                }
            }
        }
        if !(t0 <= t1) {
            return None;
        }
        let (a, b) = (p + d * t0, p + d * t1);
        Some((a.to_array(), b.to_array()))
    }
}

/// The marks of `trees` (one per camera ray of a sample) in an image of `width × height`.
pub fn marks(camera: &Camera, width: u32, height: u32, trees: &[TraceNode]) -> Vec<Mark> {
    let view = View { camera, width, height, near: camera.screen_distance * NEAR_FRACTION };
    let mut out = Vec::new();
    for (i, t) in trees.iter().enumerate() {
        walk(&view, t, &i.to_string(), &mut out);
    }
    out
}

fn walk(view: &View, node: &TraceNode, id: &str, out: &mut Vec<Mark>) {
    // A camera ray projects to a point: its hit marks it. Other rays are segments.
    if node.depth > 0 || node.kind != RayKind::Camera {
        let end = match &node.hit {
            Some(h) => End::Point(h.point),
            None => End::Toward(node.ray.dir),
        };
        if let Some((from, to)) = view.segment(node.ray.origin, end) {
            let kind = match node.kind {
                RayKind::Camera => "camera",
                RayKind::Reflection => "reflection",
                RayKind::Refraction => "refraction",
                RayKind::Shadow => "shadow",
            };
            out.push(Mark { kind, state: if node.hit.is_some() { "hit" } else { "miss" }, node: id.to_string(), from, to });
        }
    }
    if let Some(h) = &node.hit {
        for l in &node.lights {
            let end = if l.distance.is_finite() { End::Point(h.point + l.dir * l.distance) } else { End::Toward(l.dir) };
            let state = match (&l.skipped, l.transmittance.max_element()) {
                (Some(_), _) => "skipped",
                (None, t) if t <= 0.0 => "blocked",
                (None, t) if t < 1.0 => "partial",
                _ => "lit",
            };
            if let Some((from, to)) = view.segment(h.point, end) {
                out.push(Mark { kind: "light", state, node: id.to_string(), from, to });
            }
        }
        if let Some(p) = view.project(h.point).filter(|_| view.depth(h.point) >= view.near) {
            out.push(Mark { kind: "hit", state: "hit", node: id.to_string(), from: p.to_array(), to: p.to_array() });
        }
    }
    for (i, c) in node.children.iter().enumerate() {
        walk(view, c, &format!("{id}.{i}"), out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::color::Color;
    use crate::math::ray::Ray;

    fn camera() -> Camera {
        Camera::look_at(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, DVec3::Y, 60.0, 200, 100).unwrap()
    }

    #[test]
    fn a_segment_in_view_projects_to_its_endpoints() {
        let cam = camera();
        let v = View { camera: &cam, width: 200, height: 100, near: cam.screen_distance * NEAR_FRACTION };
        let (a, b) = (DVec3::new(-1.0, 0.5, 0.0), DVec3::new(2.0, -1.0, -3.0));
        let (p, q) = v.segment(a, End::Point(b)).unwrap();
        assert_eq!(p, cam.project(200, 100, a).unwrap().to_array());
        assert_eq!(q, cam.project(200, 100, b).unwrap().to_array());
    }

    #[test]
    fn rays_behind_the_eye_are_cut_and_rays_away_end_at_their_vanishing_point() {
        let cam = camera();
        let v = View { camera: &cam, width: 200, height: 100, near: cam.screen_distance * NEAR_FRACTION };
        assert!(v.segment(DVec3::new(0.0, 0.0, 11.0), End::Point(DVec3::new(1.0, 0.0, 12.0))).is_none(), "wholly behind");
        // Straight away from the eye along the view: the whole segment is the image centre.
        let (p, q) = v.segment(DVec3::ZERO, End::Toward(DVec3::new(0.0, 0.0, -1.0))).unwrap();
        assert!((DVec2::from(p) - DVec2::new(100.0, 50.0)).length() < 1e-9 && (DVec2::from(q) - DVec2::new(100.0, 50.0)).length() < 1e-9);
        // Toward the camera and past it: cut at the near plane, then at the frame's margin.
        let (p, q) = v.segment(DVec3::new(1.0, 0.0, 0.0), End::Toward(DVec3::new(0.3, 0.0, 1.0))).unwrap();
        assert_eq!(p, cam.project(200, 100, DVec3::new(1.0, 0.0, 0.0)).unwrap().to_array());
        assert!(q[0] <= 400.0 + 1e-9 && q[0] > p[0], "{q:?}");
    }

    #[test]
    fn a_tree_gives_its_hit_its_child_ray_and_its_light_tests() {
        let cam = camera();
        let mut root = TraceNode::new(RayKind::Camera, Ray::new(cam.position, -cam.position), 0, Color::ONE);
        root.hit = Some(crate::render::trace::TraceHit {
            object: 0,
            name: "ball".into(),
            t: 9.0,
            point: DVec3::new(0.0, 0.0, 1.0),
            normal: DVec3::Z,
            shading_normal: DVec3::Z,
            front_face: true,
        });
        root.lights.push(crate::render::trace::TraceLight {
            light: "sun".into(),
            dir: DVec3::new(0.0, 1.0, 0.0),
            distance: f64::INFINITY,
            intensity: Color::ONE,
            n_dot_l: 0.5,
            transmittance: Color::ZERO,
            occluder: Some("wall".into()),
            terms: Vec::new(),
            skipped: None,
        });
        root.children.push(TraceNode::new(
            RayKind::Reflection,
            Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::new(1.0, 0.0, -1.0)),
            1,
            Color::ONE,
        ));
        let m = marks(&cam, 200, 100, &[root]);
        let kinds: Vec<(&str, &str, &str)> = m.iter().map(|m| (m.kind, m.state, m.node.as_str())).collect();
        assert_eq!(kinds, vec![("light", "blocked", "0"), ("hit", "hit", "0"), ("reflection", "miss", "0.0")]);
        assert!((DVec2::from(m[1].from) - DVec2::new(100.0, 50.0)).length() < 1e-9, "the hit is at the image centre");
    }
}
