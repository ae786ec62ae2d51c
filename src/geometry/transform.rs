//! Placing objects: affine transforms, their scene-file syntax, and [`Transformed`], the
//! geometry wrapper that puts any shape where a transform says (rpt's `Transformed<T>`).
//!
//! Any `[[object]]` may carry `transform`: a table applied as scale, then rotation, then
//! translation, or a list of such tables applied first to last, or a 4×4 `matrix`:
//!
//! ```toml
//! transform = { scale = 2, rotate = [0, 45, 0], translate = [1, 0, -3] }
//! transform = [{ rotate = { axis = [1, 1, 0], angle = 30 } }, { translate = [0, 2, 0] }]
//! transform = { matrix = [[1, 0, 0, 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]] }
//! ```
//!
//! Rays are carried into the shape's own frame, so a mesh placed several times is stored once.
//! Rounding errors are tracked through the transform (pbrt-v4 §6.8.6): hit points come back
//! with a conservative error bound, and the ray origin is moved past its own transformation
//! error, so secondary rays still never re-hit the surface they leave.

use crate::geometry::{Footprint, Geometry, Hit, Intersectable, Surface, SurfaceDerivatives, SurfacePdf, SurfaceSample, face_forward};
use crate::math::bounds::Aabb;
use crate::math::float::{DEGENERACY_TOLERANCE, gamma};
use crate::math::ray::Ray;
use crate::param::error::{Result, SceneError};
use crate::param::value::{Node, Value, vec3_of};
use glam::{DAffine3, DMat2, DMat3, DVec2, DVec3};

/// An invertible affine map from an object's own frame to the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    to_world: DAffine3,
    to_object: DAffine3,
    /// Inverse transpose of the linear part: maps normals to the world.
    normal_to_world: DMat3,
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Transform =
        Transform { to_world: DAffine3::IDENTITY, to_object: DAffine3::IDENTITY, normal_to_world: DMat3::IDENTITY };

    /// The transform with object-to-world map `m`, or `None` when `m` is singular or not finite
    /// (its determinant must exceed 10⁻¹² of its scale cubed).
    pub fn new(m: DAffine3) -> Option<Transform> {
        let l = m.matrix3;
        let scale = l.x_axis.length().max(l.y_axis.length()).max(l.z_axis.length());
        let det = l.determinant();
        if !(m.is_finite() && scale > 0.0 && det.abs() > DEGENERACY_TOLERANCE * scale * scale * scale) {
            return None;
        }
        let to_object = m.inverse();
        to_object.is_finite().then(|| Transform { to_world: m, to_object, normal_to_world: to_object.matrix3.transpose() })
    }

    /// The object-to-world map.
    pub fn matrix(&self) -> DAffine3 {
        self.to_world
    }

    /// The world-to-object map.
    pub fn inverse_matrix(&self) -> DAffine3 {
        self.to_object
    }

    /// `self` applied after `first`.
    pub fn then(&self, first: &Transform) -> Option<Transform> {
        Transform::new(self.to_world * first.to_world)
    }

    /// True for the identity.
    pub fn is_identity(&self) -> bool {
        self.to_world == DAffine3::IDENTITY
    }

    /// A point to the world.
    #[inline]
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.to_world.transform_point3(p)
    }

    /// A unit normal to the world (unit length).
    #[inline]
    pub fn normal(&self, n: DVec3) -> DVec3 {
        (self.normal_to_world * n).normalize()
    }

    /// True when the map keeps angles (a rotation, reflection and uniform scale, with any
    /// translation: `Lᵀ·L = s²·I` within [`SIMILARITY_TOLERANCE`]): solid angles seen from a
    /// point are then the same in both frames.
    pub fn is_similarity(&self) -> bool {
        let l = self.to_world.matrix3;
        let g = l.transpose() * l;
        let s2 = (g.x_axis.x + g.y_axis.y + g.z_axis.z) / 3.0;
        let off = g - DMat3::from_diagonal(DVec3::splat(s2));
        let worst = off.x_axis.abs().max(off.y_axis.abs()).max(off.z_axis.abs()).max_element();
        worst <= SIMILARITY_TOLERANCE * s2
    }

    /// How much the map stretches the area of a surface element with unit normal `n` (object
    /// frame): `|det L|·|L⁻ᵀ·n|`.
    #[inline]
    pub fn area_scale(&self, n: DVec3) -> f64 {
        self.to_world.matrix3.determinant().abs() * (self.normal_to_world * n).length()
    }

    /// A box to the world: the box around its eight transformed corners, widened by their
    /// rounding error.
    pub fn bounds(&self, b: Aabb) -> Aabb {
        if b.is_empty() {
            return b;
        }
        let mut out = Aabb::EMPTY;
        for i in 0..8 {
            let c = DVec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            let (p, e) = apply_point(&self.to_world, c, DVec3::ZERO);
            out = out.include(p - e).include(p + e);
        }
        out
    }
}

/// Relative deviation of `Lᵀ·L` from a multiple of the identity under which a transform counts
/// as a similarity ([`Transform::is_similarity`]).
pub const SIMILARITY_TOLERANCE: f64 = 1e-9;

/// `m·p` for a point `p` with absolute error `err`, and the error bound of the result
/// (pbrt-v4's `Transform::operator()(Point3fi)`).
#[inline]
fn apply_point(m: &DAffine3, p: DVec3, err: DVec3) -> (DVec3, DVec3) {
    let q = m.transform_point3(p);
    let a = abs3(m.matrix3);
    let rounding = gamma(3) * (a * p.abs() + m.translation.abs());
    let carried = if err == DVec3::ZERO { DVec3::ZERO } else { (1.0 + gamma(3)) * (a * err) };
    (q, rounding + carried)
}

fn abs3(m: DMat3) -> DMat3 {
    DMat3::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs())
}

/// A geometry placed in the world by a [`Transform`]. The shape is tested in its own frame.
#[derive(Clone, Debug)]
pub struct Transformed<G> {
    inner: G,
    transform: Transform,
    bounds: Option<Aabb>,
    /// [`Transform::is_similarity`], asked once.
    similarity: bool,
}

impl<G: Geometry> Transformed<G> {
    /// `inner` placed by `transform`.
    pub fn new(inner: G, transform: Transform) -> Self {
        let bounds = inner.bounds().map(|b| transform.bounds(b));
        Transformed { inner, transform, bounds, similarity: transform.is_similarity() }
    }

    /// The shape in its own frame.
    pub fn inner(&self) -> &G {
        &self.inner
    }

    /// The placement.
    pub fn transform(&self) -> &Transform {
        &self.transform
    }

    /// The ray in the object's frame (unit direction, origin moved past its rounding error),
    /// the world-to-object scale of distances, and the object distance the origin moved.
    #[inline]
    fn object_ray(&self, ray: &Ray) -> Option<(Ray, f64, f64)> {
        let m = &self.transform.to_object;
        let (o, err) = apply_point(m, ray.origin, DVec3::ZERO);
        let d = m.transform_vector3(ray.dir);
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let dir = d / len;
        // Move the origin forward past its error box (pbrt-v4 §6.8.6).
        let shift = dir.abs().dot(err);
        Some((Ray { origin: o + dir * shift, dir }, len, shift))
    }

    /// The hit as the inner shape sees it (point carried back to the object frame).
    #[inline]
    fn object_hit(&self, at: &Hit) -> Hit {
        let (point, error) = apply_point(&self.transform.to_object, at.point, at.error);
        Hit { point, error, ..*at }
    }

    /// The world density of a point the inner shape chose with `pdf` at `p` (outward normal `n`),
    /// seen from `reference` (all in the object's frame): a solid angle density stays one under
    /// a similarity; otherwise the density per object area divided by the map's area scale there.
    #[inline]
    fn world_pdf(&self, reference: DVec3, p: DVec3, n: DVec3, pdf: SurfacePdf) -> SurfacePdf {
        match pdf {
            SurfacePdf::SolidAngle(_) if self.similarity => pdf,
            _ => SurfacePdf::Area(pdf.area(reference, p, n) / self.transform.area_scale(n)),
        }
    }
}

impl<G: Geometry> Intersectable for Transformed<G> {
    #[inline]
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let (r, len, shift) = self.object_ray(ray)?;
        let h = self.inner.intersect(&r, (t_min * len - shift).max(0.0), t_max * len - shift)?;
        let t = (h.t + shift) / len;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let (point, error) = apply_point(&self.transform.to_world, h.point, h.error);
        Some(Hit { t, point, error, ..h })
    }

    #[inline]
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        match self.object_ray(ray) {
            Some((r, len, shift)) => self.inner.occludes(&r, (t_min * len - shift).max(0.0), t_max * len - shift),
            None => false,
        }
    }

    /// The inner shape's primitives are the same under the map, and a plane maps to a plane.
    #[inline]
    fn occludes_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> bool {
        match self.object_ray(ray) {
            Some((r, len, shift)) => self.inner.occludes_leaving(&r, (t_min * len - shift).max(0.0), t_max * len - shift, prim),
            None => false,
        }
    }

    /// A plane maps to a plane.
    #[inline]
    fn is_flat(&self) -> bool {
        self.inner.is_flat()
    }

    /// [`Transformed::intersect`] asking the inner shape [`Intersectable::intersect_leaving`],
    /// as `occludes_leaving` does.
    #[inline]
    fn intersect_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> Option<Hit> {
        let (r, len, shift) = self.object_ray(ray)?;
        let h = self.inner.intersect_leaving(&r, (t_min * len - shift).max(0.0), t_max * len - shift, prim)?;
        let t = (h.t + shift) / len;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let (point, error) = apply_point(&self.transform.to_world, h.point, h.error);
        Some(Hit { t, point, error, ..h })
    }
}

impl<G: Geometry> Geometry for Transformed<G> {
    fn outward_normal(&self, at: &Hit) -> DVec3 {
        self.transform.normal(self.inner.outward_normal(&self.object_hit(at)))
    }
    /// The inner shape's surface, with the point carried into its frame once and the normals
    /// carried out once.
    #[inline]
    fn surface(&self, at: &Hit, dir: DVec3) -> Surface {
        let s = self.inner.surface(&self.object_hit(at), self.transform.to_object.transform_vector3(dir));
        // The inner shape faced its normals against the object-frame direction; the map keeps
        // sides, and `face_forward` keeps them exact under rounding.
        let n = face_forward(self.transform.normal(s.n), dir);
        let ns = if s.ns == s.n { n } else { face_forward(self.transform.normal(s.ns), dir) };
        Surface { n, ns, ..s }
    }
    #[inline]
    fn uv(&self, at: &Hit) -> DVec2 {
        self.inner.uv(&self.object_hit(at))
    }
    fn uv1(&self, at: &Hit) -> Option<(DVec2, DMat2)> {
        self.inner.uv1(&self.object_hit(at))
    }
    /// The inner shape's, carried out: tangents by the linear part, the normal's change by the
    /// derivative of the normalised inverse transpose.
    fn derivatives(&self, at: &Hit) -> Option<SurfaceDerivatives> {
        let h = self.object_hit(at);
        let d = self.inner.derivatives(&h)?;
        let l = self.transform.to_world.matrix3;
        let nm = self.transform.normal_to_world;
        let m = nm * self.inner.outward_normal(&h);
        let len = m.length();
        let n = m / len;
        let turn = |dn: DVec3| {
            let v = nm * dn;
            (v - n * n.dot(v)) / len
        };
        Some(SurfaceDerivatives { dpdu: l * d.dpdu, dpdv: l * d.dpdv, dndu: turn(d.dndu), dndv: turn(d.dndv) })
    }
    /// The inner shape's footprint of the moves carried into its frame.
    fn footprint(&self, at: &Hit, dpdx: DVec3, dpdy: DVec3) -> Footprint {
        let m = &self.transform.to_object;
        self.inner.footprint(&self.object_hit(at), m.transform_vector3(dpdx), m.transform_vector3(dpdy))
    }
    /// The inner shape's derivatives, carried out as vectors.
    fn tangents(&self, at: &Hit) -> Option<[DVec3; 2]> {
        let d = self.inner.tangents(&self.object_hit(at))?;
        Some(d.map(|v| self.transform.to_world.transform_vector3(v)))
    }
    fn bounds(&self) -> Option<Aabb> {
        self.bounds
    }
    fn is_closed(&self) -> bool {
        self.inner.is_closed()
    }
    /// An affine map keeps a convex body convex and its outward side outward.
    fn is_convex(&self) -> bool {
        self.inner.is_convex()
    }
    /// Exact under a similarity; otherwise the inner area times `|det L|^⅔` (the area scale of
    /// a uniform stretch of the same volume), an estimate that only weighs emitters.
    fn area(&self) -> Option<f64> {
        let a = self.inner.area()?;
        let l = self.transform.to_world.matrix3;
        let scale = if self.similarity { l.x_axis.length_squared() } else { l.determinant().abs().powf(2.0 / 3.0) };
        Some(a * scale)
    }
    /// The inner shape's plane carried out under a similarity: its point mapped, its normal as
    /// the samples' and hits' normals are. (A stretch keeps it flat, but could carry the inner
    /// shape's small distances from its plane out beyond the tolerance: `None`.)
    fn plane(&self) -> Option<(DVec3, DVec3)> {
        if !self.similarity {
            return None;
        }
        let (point, normal) = self.inner.plane()?;
        Some((self.transform.to_world.transform_point3(point), self.transform.normal(normal)))
    }
    /// The inner shape's sample, seen from the reference carried into its frame, carried out.
    fn sample_surface(&self, reference: DVec3, u: DVec2) -> Option<SurfaceSample> {
        let r = self.transform.to_object.transform_point3(reference);
        let s = self.inner.sample_surface(r, u)?;
        let (point, error) = apply_point(&self.transform.to_world, s.hit.point, s.hit.error);
        let pdf = self.world_pdf(r, s.hit.point, s.normal, s.pdf);
        let hit = Hit { t: (point - reference).length(), point, error, ..s.hit };
        Some(SurfaceSample { hit, normal: self.transform.normal(s.normal), pdf })
    }
    fn surface_pdf(&self, reference: DVec3, at: &Hit) -> SurfacePdf {
        let r = self.transform.to_object.transform_point3(reference);
        let h = self.object_hit(at);
        match self.inner.surface_pdf(r, &h) {
            pdf @ SurfacePdf::SolidAngle(_) if self.similarity => pdf,
            pdf => self.world_pdf(r, h.point, self.inner.outward_normal(&h), pdf),
        }
    }
}

/// Reads a `transform` value: a table (scale, then rotate, then translate; or `matrix`), or a
/// list of tables applied first to last.
pub fn parse_transform(node: &Node) -> Result<Transform> {
    let steps: Vec<&Node> = match &node.value {
        Value::Table(_) => vec![node],
        Value::Array(items) if !items.is_empty() => items.iter().collect(),
        _ => {
            return Err(SceneError::at(
                &node.loc,
                format!("`transform` must be a table or a list of tables, found {}", node.value.type_name()),
            )
            .with_help("e.g. transform = { scale = 2, rotate = [0, 90, 0], translate = [1, 0, 0] }"));
        }
    };
    let mut m = DAffine3::IDENTITY;
    for step in steps {
        m = parse_step(step)? * m;
    }
    Transform::new(m).ok_or_else(|| SceneError::at(&node.loc, "the transform is singular (it flattens the object) or not finite"))
}

/// The keys of one transform table.
const STEP_KEYS: &[&str] = &["scale", "rotate", "translate", "matrix"];

fn parse_step(node: &Node) -> Result<DAffine3> {
    let Value::Table(t) = &node.value else {
        return Err(SceneError::at(&node.loc, format!("each transform step must be a table, found {}", node.value.type_name())));
    };
    for e in &t.entries {
        if !STEP_KEYS.contains(&e.key.as_str()) {
            let hint = crate::param::error::did_you_mean(&e.key, STEP_KEYS.iter().copied())
                .map_or_else(|| format!("transform keys: {}", STEP_KEYS.join(", ")), |m| format!("did you mean `{m}`?"));
            return Err(SceneError::at(&e.key_loc, format!("unknown transform key `{}`", e.key)).with_help(hint));
        }
    }
    if let Some(mn) = t.get("matrix") {
        if let Some(other) = t.entries.iter().find(|e| e.key != "matrix") {
            return Err(SceneError::at(&other.key_loc, "`matrix` cannot be combined with scale, rotate or translate in one step")
                .with_help("write a list: transform = [{ matrix = ... }, { translate = ... }]"));
        }
        return parse_matrix(mn);
    }
    let mut m = DAffine3::IDENTITY;
    if let Some(s) = t.get("scale") {
        let v = match s.value {
            Value::Int(_) | Value::Float(_) => DVec3::splat(number(s)?),
            _ => vec3_of(s).map_err(|e| SceneError::at(&s.loc, format!("`scale`: {e} (or one number)")))?,
        };
        if v.cmpeq(DVec3::ZERO).any() {
            return Err(SceneError::at(&s.loc, "`scale` must not be zero on any axis"));
        }
        m = DAffine3::from_scale(v);
    }
    if let Some(r) = t.get("rotate") {
        m = DAffine3::from_mat3(parse_rotation(r)?) * m;
    }
    if let Some(tr) = t.get("translate") {
        let v = vec3_of(tr).map_err(|e| SceneError::at(&tr.loc, format!("`translate`: {e}")))?;
        m = DAffine3::from_translation(v) * m;
    }
    Ok(m)
}

fn number(n: &Node) -> Result<f64> {
    let v = match n.value {
        Value::Int(i) => i as f64,
        Value::Float(f) => f,
        _ => return Err(SceneError::at(&n.loc, format!("expected a number, found {}", n.value.type_name()))),
    };
    if v.is_finite() { Ok(v) } else { Err(SceneError::at(&n.loc, format!("expected a finite number, found {v}"))) }
}

/// `[x, y, z]` degrees about the fixed x, then y, then z axes; or `{ axis = [..], angle = deg }`.
fn parse_rotation(n: &Node) -> Result<DMat3> {
    match &n.value {
        Value::Array(_) => {
            let a = vec3_of(n).map_err(|e| SceneError::at(&n.loc, format!("`rotate`: {e} (degrees about x, y, z)")))?;
            Ok(DMat3::from_rotation_z(a.z.to_radians())
                * DMat3::from_rotation_y(a.y.to_radians())
                * DMat3::from_rotation_x(a.x.to_radians()))
        }
        Value::Table(t) => {
            for e in &t.entries {
                if e.key != "axis" && e.key != "angle" {
                    return Err(SceneError::at(&e.key_loc, format!("unknown rotation key `{}`; expected `axis` and `angle`", e.key)));
                }
            }
            let (Some(axis), Some(angle)) = (t.get("axis"), t.get("angle")) else {
                return Err(SceneError::at(&n.loc, "a rotation table needs `axis` and `angle` (degrees)"));
            };
            let v = vec3_of(axis).map_err(|e| SceneError::at(&axis.loc, format!("`axis`: {e}")))?;
            let v = v.try_normalize().ok_or_else(|| SceneError::at(&axis.loc, "`axis` must not be zero"))?;
            Ok(DMat3::from_axis_angle(v, number(angle)?.to_radians()))
        }
        _ => {
            Err(SceneError::at(&n.loc, format!("`rotate`: expected [x, y, z] degrees or {{ axis, angle }}, found {}", n.value.type_name())))
        }
    }
}

/// A 4×4 (last row `[0, 0, 0, 1]`) or 3×4 matrix, given row by row.
fn parse_matrix(n: &Node) -> Result<DAffine3> {
    let bad = || SceneError::at(&n.loc, "`matrix` must be 3 or 4 rows of 4 numbers (row-major; the last row [0, 0, 0, 1])");
    let Value::Array(rows) = &n.value else { return Err(bad()) };
    if rows.len() != 3 && rows.len() != 4 {
        return Err(bad());
    }
    let mut m = [[0.0; 4]; 4];
    for (r, row) in rows.iter().enumerate() {
        let Value::Array(cols) = &row.value else { return Err(bad()) };
        if cols.len() != 4 {
            return Err(bad());
        }
        for (c, v) in cols.iter().enumerate() {
            m[r][c] = number(v)?;
        }
    }
    if rows.len() == 4 && m[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(SceneError::at(&rows[3].loc, "the last row of a transform matrix must be [0, 0, 0, 1] (no projection)"));
    }
    let col = |c: usize| DVec3::new(m[0][c], m[1][c], m[2][c]);
    Ok(DAffine3::from_cols(col(0), col(1), col(2), col(3)))
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Ball;
    impl Intersectable for Ball {
        fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
            let (t0, t1) = crate::math::float::solve_quadratic(1.0, 2.0 * ray.origin.dot(ray.dir), ray.origin.length_squared() - 1.0)?;
            let t = [t0, t1].into_iter().find(|&t| t > t_min && t < t_max)?;
            let p = ray.at(t).normalize();
            Some(Hit::new(t, p, DVec3::splat(1e-12)))
        }
    }
    impl Geometry for Ball {
        fn outward_normal(&self, at: &Hit) -> DVec3 {
            at.point.normalize()
        }
        fn bounds(&self) -> Option<Aabb> {
            Some(Aabb::new(-DVec3::ONE, DVec3::ONE))
        }
    }

    #[test]
    fn a_scaled_and_moved_ball_is_an_ellipsoid_with_world_distances() {
        let m = DAffine3::from_translation(DVec3::new(0.0, 0.0, -10.0)) * DAffine3::from_scale(DVec3::new(2.0, 1.0, 1.0));
        let g = Transformed::new(Ball, Transform::new(m).unwrap());
        let h = g.intersect(&Ray::new(DVec3::new(-5.0, 0.0, -10.0), DVec3::X), 0.0, f64::INFINITY).unwrap();
        assert!((h.t - 3.0).abs() < 1e-12 && (h.point - DVec3::new(-2.0, 0.0, -10.0)).length() < 1e-12, "{h:?}");
        assert!((g.outward_normal(&h) + DVec3::X).length() < 1e-12);
        // A tilted ray: the normal is the inverse transpose, not the transformed normal.
        let h = g.intersect(&Ray::new(DVec3::new(1.0, 5.0, -10.0), -DVec3::Y), 0.0, f64::INFINITY).unwrap();
        let n = g.outward_normal(&h);
        let expect = DVec3::new(h.point.x / 4.0, h.point.y, 0.0).normalize();
        assert!((n - expect).length() < 1e-9, "{n} vs {expect}");
        let b = g.bounds().unwrap();
        assert!((b.min - DVec3::new(-2.0, -1.0, -11.0)).abs().max_element() < 1e-9);
    }

    #[test]
    fn parsing_covers_every_form_and_rejects_nonsense() {
        let parse = |text: &str| {
            let src = crate::param::error::Source::new("t.toml", format!("t = {text}"));
            let node = crate::param::toml::parse_toml_value(&src, 4..src.text.len()).unwrap();
            parse_transform(&node)
        };
        let t = parse("{ scale = 2, rotate = [0, 90, 0], translate = [1, 0, 0] }").unwrap();
        let p = t.point(DVec3::X);
        assert!((p - DVec3::new(1.0, 0.0, -2.0)).length() < 1e-12, "{p}");
        let t = parse("[{ translate = [1, 0, 0] }, { rotate = { axis = [0, 0, 1], angle = 90 } }]").unwrap();
        assert!((t.point(DVec3::ZERO) - DVec3::Y).length() < 1e-12);
        let t = parse("{ matrix = [[1, 0, 0, 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]] }").unwrap();
        assert_eq!(t.point(DVec3::ZERO), DVec3::new(5.0, 0.0, 0.0));
        for bad in [
            "{ scale = 0 }",
            "{ scael = 2 }",
            "{ matrix = [[1, 0, 0]] }",
            "{ matrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[1,0,0,1]] }",
            "3",
            "{ rotate = { axis = [0, 0, 0], angle = 3 } }",
            "{ matrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0]], translate = [1, 2, 3] }",
        ] {
            assert!(parse(bad).is_err(), "{bad}");
        }
        assert!(parse("{ scael = 2 }").unwrap_err().help.unwrap().contains("scale"));
    }
}
