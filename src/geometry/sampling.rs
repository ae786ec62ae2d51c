//! Points chosen on a surface ([`crate::Geometry::sample_surface`]), for integrators that sample
//! emitting surfaces as lights, and the conversions between the two measures their densities
//! come in: per unit area of the surface, or per unit solid angle seen from a reference point.

use crate::geometry::Hit;
use glam::{DVec2, DVec3};
use std::f64::consts::{PI, TAU};

/// The density of a surface sample, in the measure the shape chose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfacePdf {
    /// Per unit area of the surface, scene units⁻² (uniform points: `1 / area`).
    Area(f64),
    /// Per unit solid angle seen from the reference point, sr⁻¹ (a sphere's visible cone).
    SolidAngle(f64),
}

impl SurfacePdf {
    /// The density per unit solid angle seen from `reference`, of a point `point` with unit
    /// normal `normal` (either side): an area density times `distance² / |cos|`. Infinite where
    /// the surface is seen edge-on; 0 for a zero density.
    #[inline]
    pub fn solid_angle(self, reference: DVec3, point: DVec3, normal: DVec3) -> f64 {
        match self {
            SurfacePdf::SolidAngle(p) => p,
            SurfacePdf::Area(p) if p > 0.0 => {
                let d = point - reference;
                let d2 = d.length_squared();
                let cos = normal.dot(d).abs() / d2.sqrt();
                p * d2 / cos
            }
            SurfacePdf::Area(_) => 0.0,
        }
    }

    /// The density per unit area at `point` with unit `normal`, seen from `reference`: a solid
    /// angle density times `|cos| / distance²`.
    #[inline]
    pub fn area(self, reference: DVec3, point: DVec3, normal: DVec3) -> f64 {
        match self {
            SurfacePdf::Area(p) => p,
            SurfacePdf::SolidAngle(p) => {
                let d = point - reference;
                let d2 = d.length_squared();
                if !(d2 > 0.0) {
                    return 0.0;
                }
                p * normal.dot(d).abs() / (d2 * d2.sqrt())
            }
        }
    }

    /// The density scaled by `factor` (a probability of choosing this surface among others).
    #[inline]
    pub fn scaled(self, factor: f64) -> SurfacePdf {
        match self {
            SurfacePdf::Area(p) => SurfacePdf::Area(p * factor),
            SurfacePdf::SolidAngle(p) => SurfacePdf::SolidAngle(p * factor),
        }
    }
}

/// A point chosen on a surface by [`crate::Geometry::sample_surface`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSample {
    /// The point as a hit would report it: `point`, its `error` bound, and the `uv` and `prim`
    /// that [`crate::Geometry::surface`] and [`crate::Geometry::uv`] read (so the material, a
    /// texture and the side are evaluated there as for a ray's hit). `t` is the distance from the
    /// reference point; `object` is 0 (the scene fills it in).
    pub hit: Hit,
    /// Unit outward normal at the point ([`crate::Geometry::outward_normal`]).
    pub normal: DVec3,
    /// The density with which the point was chosen.
    pub pdf: SurfacePdf,
}

impl SurfaceSample {
    /// A sample at `point` with `normal`, chosen with `pdf`, seen from `reference`; `uv`, `prim`
    /// and `error` as given.
    #[inline]
    pub fn new(reference: DVec3, point: DVec3, error: DVec3, normal: DVec3, pdf: SurfacePdf) -> SurfaceSample {
        let t = (point - reference).length();
        SurfaceSample { hit: Hit::new(t, point, error), normal, pdf }
    }
}

/// A unit vector uniform on the sphere for `u` in `[0, 1)²` (density `1 / 4π`).
#[inline]
pub fn uniform_sphere(u: DVec2) -> DVec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (TAU * u.y).sin_cos();
    DVec3::new(r * c, r * s, z)
}

/// Barycentric coordinates `(b1, b2)` of a point uniform on a triangle for `u` in `[0, 1)²`
/// (Heitz 2019's low-distortion mapping: `p = (1 − b1 − b2)·p0 + b1·p1 + b2·p2`).
#[inline]
pub fn uniform_triangle(u: DVec2) -> DVec2 {
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    DVec2::new(b1, 1.0 - b0 - b1)
}

/// The solid angle of a cone of half-angle θ with `cos θ = cos_max`, `2π(1 − cos θ)`, written
/// from `sin² θ` (`sin2_max`) where the cone is narrow, where `1 − cos θ` would cancel.
#[inline]
pub fn cone_solid_angle(cos_max: f64, sin2_max: f64) -> f64 {
    // Below sin² θ of 1.5° the difference of ones loses digits; 1 − cos θ ≈ sin²θ / 2 then.
    if sin2_max < NARROW_CONE_SIN2 { PI * sin2_max * (1.0 + sin2_max / 4.0) } else { TAU * (1.0 - cos_max) }
}

/// `sin²` of 1.5°: under it a cone is narrow ([`cone_solid_angle`], the sphere's cone sampling).
pub const NARROW_CONE_SIN2: f64 = 0.000_685_23;

/// What [`check_surface_sampling`] found: the χ² statistic, its degrees of freedom and
/// p-value, and the integral of the densities over all directions (1 when they are right).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingCheck {
    /// Pearson's χ² of the samples' directions against the densities.
    pub chi_square: f64,
    /// Its degrees of freedom.
    pub dof: usize,
    /// The probability of a χ² at least this large if the samples follow the densities.
    pub p_value: f64,
    /// ∫ of the solid-angle density over the sphere of directions, every surface a ray crosses
    /// counted for a density per area (should be 1 when the shape may sample each of them).
    pub integral: f64,
    /// The fraction of samples hidden behind another part of the shape from the reference.
    pub hidden: f64,
}

/// Relative gap in distance under which two points along a ray from the reference are one
/// ([`check_surface_sampling`]: a sample is hidden when the ray meets the shape before it).
const HIDDEN_TOLERANCE: f64 = 1e-7;

/// Sub-cells per side over which [`check_surface_sampling`] integrates a cell's density.
const CHECK_SUBCELLS: u32 = 8;
/// How many times finer cells at an edge of the density are integrated.
const CHECK_REFINE: u32 = 8;
/// Cells of [`check_surface_sampling`] expected to hold fewer samples than this are pooled.
const MIN_EXPECTED: f64 = 5.0;
/// Ratio of largest to smallest density within a cell beyond which it is at an edge.
const EDGE_RATIO: f64 = 1.5;

/// One cell's integrals ([`check_surface_sampling`]): of the density at the first surface, at
/// every surface, and the least and greatest density at the first surface met within it.
#[derive(Clone, Copy)]
struct Cell {
    first: f64,
    all: f64,
    low: f64,
    high: f64,
}

/// Checks a shape's [`crate::Geometry::sample_surface`] from `reference` against its
/// [`crate::Geometry::surface_pdf`], as Mitsuba tests its sampling routines: `n` samples' directions
/// from `reference` are counted in a grid of `rows × cols` cells (equal solid angle, in the cone
/// around the shape's bounding sphere, or over the whole sphere from inside it), and each cell's
/// expected count is the density at the first surface rays cast through the cell meet,
/// integrated over it. Samples hidden from the reference by the shape itself (the back of a
/// cylinder sampled by area) are counted apart, against what the first surfaces leave. `u` gives the uniform numbers (a caller's generator: fixed seeds make a
/// failure reproducible).
pub fn check_surface_sampling(
    g: &dyn crate::Geometry,
    reference: DVec3,
    n: u32,
    (rows, cols): (u32, u32),
    mut u: impl FnMut() -> DVec2,
) -> SamplingCheck {
    // The samples' directions first: the cells span the cone that holds them (around the
    // direction to the shape's box), so a small shape far away still covers many cells.
    let b = g.bounds().expect("a sampled shape is bounded");
    let to = (b.min + b.max) / 2.0 - reference;
    let axis = to.try_normalize().unwrap_or(DVec3::Z);
    let mut hidden = 0.0;
    let mut dirs = Vec::with_capacity(n as usize);
    for _ in 0..n {
        let Some(s) = g.sample_surface(reference, u()) else { continue };
        let Some(d) = (s.hit.point - reference).try_normalize() else { continue };
        // Hidden when the ray toward it meets the shape clearly before it.
        match g.intersect(&crate::Ray { origin: reference, dir: d }, 0.0, f64::INFINITY) {
            Some(h) if h.t < s.hit.t * (1.0 - HIDDEN_TOLERANCE) => hidden += 1.0,
            _ => dirs.push(d),
        }
    }
    let widest = dirs.iter().map(|d| d.dot(axis)).fold(1.0f64, f64::min);
    // 5 % wider in 1 − cos θ than the widest sample, and the whole sphere past a hemisphere.
    let cos_max = if widest > 0.0 { (1.0 - 1.05 * (1.0 - widest)).max(0.0) } else { -1.0 };
    let (e1, e2) = {
        let a = if axis.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        let e1 = axis.cross(a).normalize();
        (e1, axis.cross(e1))
    };
    // Cell coordinates: s = (1 − cos θ)/(1 − cos_max) ∈ [0, 1), φ/2π ∈ [0, 1).
    let span = 1.0 - cos_max;
    let direction = |s: f64, t: f64| {
        let cos = 1.0 - s * span;
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let (sp, cp) = (TAU * t).sin_cos();
        (e1 * cp + e2 * sp) * sin + axis * cos
    };
    let cell_of = |d: DVec3| -> Option<usize> {
        let cos = d.dot(axis).clamp(-1.0, 1.0);
        let s = (1.0 - cos) / span;
        if !(0.0..1.0).contains(&s) {
            return None;
        }
        let t = (d.dot(e2).atan2(d.dot(e1)) / TAU).rem_euclid(1.0);
        let (r, c) = (((s * f64::from(rows)) as u32).min(rows - 1), ((t * f64::from(cols)) as u32).min(cols - 1));
        Some((r * cols + c) as usize)
    };
    let cells = (rows * cols) as usize;
    let mut observed = vec![0.0; cells];
    let mut outside = 0.0;
    for &d in &dirs {
        match cell_of(d) {
            Some(c) => observed[c] += 1.0,
            None => outside += 1.0,
        }
    }
    // Expected counts: the density along rays through each sub-cell, times its solid angle;
    // cells at an edge of the density (a silhouette, a fold) and their neighbours again, finer.
    let integrate = |c: usize, sub: u32| -> Cell {
        let (r, col) = (c as u32 / cols, c as u32 % cols);
        let sub_solid_angle = TAU * span / f64::from(rows * cols * sub * sub);
        let mut cell = Cell { first: 0.0, all: 0.0, low: f64::INFINITY, high: 0.0 };
        for i in 0..sub * sub {
            let s = (f64::from(r) + (f64::from(i / sub) + 0.5) / f64::from(sub)) / f64::from(rows);
            let t = (f64::from(col) + (f64::from(i % sub) + 0.5) / f64::from(sub)) / f64::from(cols);
            let ray = crate::Ray { origin: reference, dir: direction(s, t) };
            let (mut t_min, mut first) = (0.0, true);
            let mut seen = 0.0;
            while let Some(h) = g.intersect(&ray, t_min, f64::INFINITY) {
                let pdf = g.surface_pdf(reference, &h);
                let density = pdf.solid_angle(reference, h.point, g.outward_normal(&h));
                if density.is_finite() {
                    cell.all += density * sub_solid_angle;
                    if first {
                        cell.first += density * sub_solid_angle;
                        seen = density;
                    }
                }
                if matches!(pdf, SurfacePdf::SolidAngle(_)) {
                    break;
                }
                (t_min, first) = (h.t * (1.0 + HIDDEN_TOLERANCE), false);
            }
            (cell.low, cell.high) = (cell.low.min(seen), cell.high.max(seen));
        }
        cell
    };
    let coarse: Vec<Cell> = (0..cells).map(|c| integrate(c, CHECK_SUBCELLS)).collect();
    let edge = |c: &Cell| c.high > 0.0 && !(c.low > 0.0 && c.high <= EDGE_RATIO * c.low);
    let near_edge = |c: usize| {
        let (r, col) = ((c as u32 / cols) as i64, (c as u32 % cols) as i64);
        (-1..=1).any(|dr| {
            (-1..=1).any(|dc| {
                let (rr, cc) = (r + dr, (col + dc).rem_euclid(i64::from(cols)));
                (0..i64::from(rows)).contains(&rr) && edge(&coarse[(rr * i64::from(cols) + cc) as usize])
            })
        })
    };
    let mut expected = vec![0.0; cells];
    let (mut integral, mut visible) = (0.0, 0.0);
    for (c, e) in expected.iter_mut().enumerate() {
        let cell = if near_edge(c) { integrate(c, CHECK_SUBCELLS * CHECK_REFINE) } else { coarse[c] };
        integral += cell.all;
        visible += cell.first;
        *e = cell.first * f64::from(n);
    }
    let mut obs = observed;
    obs.extend([outside, hidden]);
    expected.extend([0.0, (1.0 - visible).max(0.0) * f64::from(n)]);
    let r = crate::testing::chi2::pearson(&obs, &expected, MIN_EXPECTED);
    SamplingCheck { chi_square: r.statistic, dof: r.dof as usize, p_value: r.p_value(), integral, hidden: hidden / f64::from(n) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measures_convert_both_ways() {
        let (r, p, n) = (DVec3::ZERO, DVec3::new(0.0, 2.0, 0.0), DVec3::new(0.0, -1.0, 1.0).normalize());
        let a = SurfacePdf::Area(0.25);
        let sa = a.solid_angle(r, p, n);
        assert!((sa - 0.25 * 4.0 / (0.5f64).sqrt()).abs() < 1e-12);
        assert!((SurfacePdf::SolidAngle(sa).area(r, p, n) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn narrow_cones_keep_their_digits() {
        let theta: f64 = 1e-5;
        let exact = TAU * 2.0 * (theta / 2.0).sin().powi(2);
        let got = cone_solid_angle(theta.cos(), theta.sin().powi(2));
        assert!((got / exact - 1.0).abs() < 1e-9, "{got} vs {exact}");
        let wide: f64 = 0.7;
        assert!((cone_solid_angle(wide.cos(), wide.sin().powi(2)) - TAU * (1.0 - wide.cos())).abs() < 1e-15);
    }

    #[test]
    fn triangle_points_stay_inside() {
        for i in 0..64 {
            for j in 0..64 {
                let b = uniform_triangle(DVec2::new(i as f64 / 64.0, j as f64 / 64.0));
                assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-15, "{b}");
            }
        }
    }
}
