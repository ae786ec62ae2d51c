//! The classic procedural patterns: `checker`, `stripes`, `gradient` and `ring`, over texture
//! coordinates or through the shape's own frame ([`Mapping`]), each with unit-sized cells
//! placed and sized by its `transform`.
//!
//! Each is band-limited: over a pixel's footprint ([`TexturePoint::footprint`]) it returns its
//! box-filtered mean in closed form (the share of odd cells, the blend's integral), so a
//! checkerboard toward the horizon turns to the mean of its colours instead of moiré. A cell
//! pattern's long, thin footprint (a grazing view) is split along its length ([`Probes`]) and
//! each piece box-filtered: the bounding box of the whole would blur it over its length in every
//! direction.
//!
//! Cells are decided by `floor`, so a surface lying exactly on a cell boundary in object
//! coordinates (a plane at y = 0 under a solid checker) shows rounding noise: move the pattern by
//! half a cell (`transform = { translate = [0, 0.5, 0] }`) or lay it over uv.

use raylab::glam::DVec3;
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::scene::texture::{COORDS_PARAM, Mapping, Probes, TRANSFORM_PARAM, Texture, TexturePoint};
use raylab::{Color, LoadContext, PluginInfo};
use std::sync::Arc;

const EVEN: ParamSpec = ParamSpec::new("even", ParamKind::Color, ParamDefault::Float(0.8), "colour of the even cells, linear RGB");
const ODD: ParamSpec = ParamSpec::new("odd", ParamKind::Color, ParamDefault::Float(0.1), "colour of the odd cells, linear RGB");
/// The parameters of every cell pattern (`checker`, `stripes`, `ring`).
const CELL_PARAMS: &[ParamSpec] = &[EVEN, ODD, COORDS_PARAM, TRANSFORM_PARAM];

/// The `checker` texture's description.
pub const CHECKER_INFO: PluginInfo = PluginInfo {
    name: "checker",
    summary: "A checkerboard of unit cells: `even` where ⌊x⌋ + ⌊y⌋ + ⌊z⌋ is even, `odd` elsewhere (squares over uv, cubes through an object).",
    params: CELL_PARAMS,
};

/// The `stripes` texture's description.
pub const STRIPES_INFO: PluginInfo = PluginInfo {
    name: "stripes",
    summary: "Stripes of unit width across x (across u over uv): `even` where ⌊x⌋ is even, `odd` elsewhere. Turn them with `transform`.",
    params: CELL_PARAMS,
};

/// The `ring` texture's description.
pub const RING_INFO: PluginInfo = PluginInfo {
    name: "ring",
    summary: "Concentric rings of unit width around the z axis (circles around uv (0, 0); cylinders through an object, as wood): `even` where ⌊√(x² + y²)⌋ is even, `odd` elsewhere.",
    params: CELL_PARAMS,
};

/// The `gradient` texture's description.
pub const GRADIENT_INFO: PluginInfo = PluginInfo {
    name: "gradient",
    summary: "A linear blend along x (along u over uv): `from` at x = 0 to `to` at x = 1, then clamped, repeated or mirrored.",
    params: &[
        ParamSpec::new("from", ParamKind::Color, ParamDefault::Float(0.0), "colour at x = 0, linear RGB"),
        ParamSpec::new("to", ParamKind::Color, ParamDefault::Float(1.0), "colour at x = 1, linear RGB"),
        ParamSpec::new(
            "repeat",
            ParamKind::Str,
            ParamDefault::Str("clamp"),
            "beyond [0, 1]: \"clamp\" (the end colours), \"repeat\" (sawtooth) or \"mirror\" (back and forth)",
        ),
        COORDS_PARAM,
        TRANSFORM_PARAM,
    ],
};

/// Which cell pattern a [`Cells`] texture draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellKind {
    /// ⌊x⌋ + ⌊y⌋ + ⌊z⌋.
    Checker,
    /// ⌊x⌋.
    Stripes,
    /// ⌊√(x² + y²)⌋.
    Ring,
}

/// Two colours alternating over integer cells of the pattern's coordinates.
#[derive(Clone, Debug)]
pub struct Cells {
    kind: CellKind,
    even: Color,
    odd: Color,
    mapping: Mapping,
}

impl Cells {
    /// `kind` in colours `even` and `odd`, laid over the surface by `mapping`.
    pub fn new(kind: CellKind, even: Color, odd: Color, mapping: Mapping) -> Self {
        Cells { kind, even, odd, mapping }
    }

    /// The cell index of pattern point `p` (its parity chooses the colour).
    #[inline]
    fn cell(&self, p: DVec3) -> i64 {
        // `as` saturates (and maps NaN to 0), so any point has a cell.
        let f = |v: f64| v.floor() as i64;
        match self.kind {
            CellKind::Checker => f(p.x).wrapping_add(f(p.y)).wrapping_add(f(p.z)),
            CellKind::Stripes => f(p.x),
            CellKind::Ring => f(p.x.hypot(p.y)),
        }
    }
}

impl Texture for Cells {
    #[inline]
    fn eval(&self, at: &TexturePoint) -> Color {
        let p = self.mapping.point(at);
        if !at.footprint.is_point() {
            let (dx, dy) = self.mapping.point_footprint(at);
            let probes = Probes::new(dx, dy, PROBE_SPACING);
            if probes.count == 1 {
                // The share of odd cells in the pixel's footprint: the pattern box-filtered.
                if let Some(f) = self.odd_share(p, (dx, dy)) {
                    return self.even * (1.0 - f) + self.odd * f;
                }
            } else {
                // A long footprint (a grazing view): its pieces box-filtered, averaged.
                let odd: f64 = (0..probes.count)
                    .map(|i| {
                        let q = p + probes.offset(i);
                        self.odd_share(q, (probes.step, probes.minor)).unwrap_or_else(|| (self.cell(q) & 1) as f64)
                    })
                    .sum();
                let f = odd / probes.count as f64;
                return self.even * (1.0 - f) + self.odd * f;
            }
        }
        if self.cell(p) & 1 == 0 { self.even } else { self.odd }
    }
}

/// The shortest piece (in cells) a cell pattern's footprint is split into ([`Probes::new`]'s
/// `unit`): a footprint shorter than this is filtered whole (its bounding box then overshoots it
/// by at most this much), and a thinner one is cut in pieces this long.
const PROBE_SPACING: f64 = 0.125;

impl Cells {
    /// The share of odd cells over the footprint of pattern point `p` (its moves `dx`, `dy` one
    /// pixel over): the cells' parity box-filtered over the footprint's bounding box, in closed
    /// form (pbrt-v3 §10.5.1; Apodaca and Gritz): a checker's parity is the product of its axes'
    /// `±1` parities, and a box is separable, so each axis is filtered alone. `None` when the
    /// footprint lies in one cell (the point's colour, exactly).
    #[inline]
    fn odd_share(&self, p: DVec3, (dx, dy): (DVec3, DVec3)) -> Option<f64> {
        // Half the footprint's extent along each axis.
        let half = 0.5 * (dx.abs() + dy.abs());
        let sign = match self.kind {
            CellKind::Checker => {
                let (sx, sy, sz) = (box_parity(p.x, half.x)?, box_parity(p.y, half.y)?, box_parity(p.z, half.z)?);
                if sx.is_none() && sy.is_none() && sz.is_none() {
                    return None;
                }
                let exact = |s: Option<f64>, v: f64| s.unwrap_or(if (v.floor() as i64) & 1 == 0 { 1.0 } else { -1.0 });
                exact(sx, p.x) * exact(sy, p.y) * exact(sz, p.z)
            }
            CellKind::Stripes => box_parity(p.x, half.x)??,
            CellKind::Ring => {
                let r = p.x.hypot(p.y);
                if !(r > 0.0) {
                    return None;
                }
                let grad = DVec3::new(p.x / r, p.y / r, 0.0);
                box_parity(r, 0.5 * (grad.dot(dx).abs() + grad.dot(dy).abs()))??
            }
        };
        Some((0.5 * (1.0 - sign)).clamp(0.0, 1.0))
    }
}

/// The mean of the parity `(−1)^⌊x⌋` over `[x − half, x + half]`: `Some(None)` when the box lies
/// in one cell (the parity is exact there), `None` when the input is not finite (the caller
/// falls back to the point's cell).
#[inline]
fn box_parity(x: f64, half: f64) -> Option<Option<f64>> {
    if !(x.is_finite() && half.is_finite()) {
        return None;
    }
    let (a, b) = (x - half, x + half);
    if a.floor() == b.floor() {
        return Some(None);
    }
    // ∫ (−1)^⌊t⌋ dt: a triangle wave between 0 and 1, rising on even cells.
    let integral = |t: f64| {
        let m = t - 2.0 * (0.5 * t).floor();
        if m < 1.0 { m } else { 2.0 - m }
    };
    let mean = (integral(b) - integral(a)) / (b - a);
    Some(Some(if mean.is_finite() { mean.clamp(-1.0, 1.0) } else { 0.0 }))
}

fn build_cells(kind: CellKind, p: &mut Params) -> Result<Arc<dyn Texture>> {
    let (even, odd) = (p.color("even")?, p.color("odd")?);
    Ok(Arc::new(Cells::new(kind, even, odd, Mapping::from_params(p)?)))
}

/// Builds a `checker` texture.
pub fn build_checker(p: &mut Params, _: &LoadContext) -> Result<Arc<dyn Texture>> {
    build_cells(CellKind::Checker, p)
}

/// Builds a `stripes` texture.
pub fn build_stripes(p: &mut Params, _: &LoadContext) -> Result<Arc<dyn Texture>> {
    build_cells(CellKind::Stripes, p)
}

/// Builds a `ring` texture.
pub fn build_ring(p: &mut Params, _: &LoadContext) -> Result<Arc<dyn Texture>> {
    build_cells(CellKind::Ring, p)
}

/// What a gradient does beyond [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Repeat {
    /// The end colours.
    Clamp,
    /// Starts again at `from` (a sawtooth).
    Repeat,
    /// Runs back to `from`, then forth again.
    Mirror,
}

/// A linear blend of two colours along the pattern's x.
#[derive(Clone, Debug)]
pub struct Gradient {
    from: Color,
    to: Color,
    repeat: Repeat,
    mapping: Mapping,
}

impl Gradient {
    /// From `from` at x = 0 to `to` at x = 1, laid over the surface by `mapping`.
    pub fn new(from: Color, to: Color, repeat: Repeat, mapping: Mapping) -> Self {
        Gradient { from, to, repeat, mapping }
    }
}

impl Texture for Gradient {
    #[inline]
    fn eval(&self, at: &TexturePoint) -> Color {
        let x = self.mapping.point(at).x;
        if !at.footprint.is_point() {
            let (dx, dy) = self.mapping.point_footprint(at);
            if let Some(t) = self.box_mean(x, 0.5 * (dx.x.abs() + dy.x.abs())) {
                return self.from + (self.to - self.from) * t;
            }
        }
        let t = match self.repeat {
            Repeat::Clamp => x.clamp(0.0, 1.0),
            Repeat::Repeat => x - x.floor(),
            Repeat::Mirror => 1.0 - ((x - 2.0 * (0.5 * x).floor()) - 1.0).abs(),
        };
        // NaN (a degenerate hit) and what rounding leaves outside [0, 1] go to the ends.
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        self.from + (self.to - self.from) * t
    }
}

impl Gradient {
    /// The blend's mean over `[x − half, x + half]` (box-filtered, in closed form); `None` for an
    /// empty or non-finite box (the point's value is used).
    #[inline]
    fn box_mean(&self, x: f64, half: f64) -> Option<f64> {
        if !(half > 0.0 && half.is_finite() && x.is_finite()) {
            return None;
        }
        // The blend's antiderivative.
        let integral = |t: f64| match self.repeat {
            Repeat::Clamp => {
                if t <= 0.0 {
                    0.0
                } else if t >= 1.0 {
                    t - 0.5
                } else {
                    0.5 * t * t
                }
            }
            Repeat::Repeat => {
                let (k, f) = (t.floor(), t - t.floor());
                0.5 * k + 0.5 * f * f
            }
            Repeat::Mirror => {
                let (k, f) = ((0.5 * t).floor(), t - 2.0 * (0.5 * t).floor());
                let within = if f < 1.0 { 0.5 * f * f } else { 0.5 + (f - 1.0) - 0.5 * (f - 1.0) * (f - 1.0) };
                k + within
            }
        };
        let (a, b) = (x - half, x + half);
        let mean = (integral(b) - integral(a)) / (b - a);
        mean.is_finite().then(|| mean.clamp(0.0, 1.0))
    }
}

/// Builds a `gradient` texture.
pub fn build_gradient(p: &mut Params, _: &LoadContext) -> Result<Arc<dyn Texture>> {
    let (from, to) = (p.color("from")?, p.color("to")?);
    let repeat = match p.choice("repeat", &["clamp", "repeat", "mirror"])?.as_str() {
        "repeat" => Repeat::Repeat,
        "mirror" => Repeat::Mirror,
        _ => Repeat::Clamp,
    };
    Ok(Arc::new(Gradient::new(from, to, repeat, Mapping::from_params(p)?)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use raylab::glam::DVec2;
    use raylab::scene::texture::Coords;

    fn at_uv(u: f64, v: f64) -> TexturePoint {
        TexturePoint::new(DVec2::new(u, v), DVec3::ZERO)
    }

    fn at_local(p: DVec3) -> TexturePoint {
        TexturePoint::new(DVec2::ZERO, p)
    }

    #[test]
    fn cells_alternate_over_uv_and_through_objects() {
        let (a, b) = (Color::ONE, Color::ZERO);
        let c = Cells::new(CellKind::Checker, a, b, Mapping::new(Coords::Uv));
        assert_eq!(c.eval(&at_uv(0.5, 0.5)), a);
        assert_eq!(c.eval(&at_uv(1.5, 0.5)), b);
        assert_eq!(c.eval(&at_uv(-0.5, 0.5)), b, "cells continue below zero");
        assert_eq!(c.eval(&at_uv(1.5, 1.5)), a);
        let solid = Cells::new(CellKind::Checker, a, b, Mapping::new(Coords::Object));
        assert_eq!(solid.eval(&at_local(DVec3::new(0.5, 0.5, 1.5))), b);
        let s = Cells::new(CellKind::Stripes, a, b, Mapping::new(Coords::Uv));
        assert_eq!((s.eval(&at_uv(0.2, 7.0)), s.eval(&at_uv(1.2, -3.0))), (a, b));
        let r = Cells::new(CellKind::Ring, a, b, Mapping::new(Coords::Object));
        assert_eq!(r.eval(&at_local(DVec3::new(0.9, 0.8, 9.0))), b, "radius 1.2: ring 1");
        assert_eq!(r.eval(&at_local(DVec3::new(0.3, 0.3, 9.0))), a);
        // Any input has a colour.
        for v in [f64::NAN, f64::INFINITY, -1e300] {
            let x = c.eval(&at_uv(v, v));
            assert!(x == a || x == b);
        }
    }

    #[test]
    fn gradients_blend_and_wrap() {
        let g = |repeat| Gradient::new(Color::ZERO, Color::ONE, repeat, Mapping::new(Coords::Uv));
        assert_eq!(g(Repeat::Clamp).eval(&at_uv(0.25, 0.0)).x, 0.25);
        assert_eq!(g(Repeat::Clamp).eval(&at_uv(7.0, 0.0)).x, 1.0);
        assert_eq!(g(Repeat::Repeat).eval(&at_uv(1.25, 0.0)).x, 0.25);
        assert_eq!(g(Repeat::Mirror).eval(&at_uv(1.25, 0.0)).x, 0.75);
        assert_eq!(g(Repeat::Mirror).eval(&at_uv(-0.25, 0.0)).x, 0.25);
        for repeat in [Repeat::Clamp, Repeat::Repeat, Repeat::Mirror] {
            for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300] {
                let x = g(repeat).eval(&at_uv(v, 0.0)).x;
                assert!((0.0..=1.0).contains(&x), "{repeat:?} at {v}: {x}");
            }
        }
    }

    /// A long thin footprint across a checker at a slant: the probes' mean is much nearer the
    /// footprint's true mean (supersampled) than the box over its bounding box, which is grey.
    #[test]
    fn a_long_slanted_footprint_is_filtered_along_its_length() {
        use raylab::scene::texture::Footprint;
        let c = Cells::new(CellKind::Checker, Color::ZERO, Color::ONE, Mapping::new(Coords::Uv));
        let p = DVec3::new(0.3, 0.1, 0.0);
        let (dx, dy) = (DVec3::new(0.03, -0.04, 0.0), DVec3::new(6.0, 5.0, 0.0));
        let (nx, ny) = (40, 4000);
        let mut odd = 0.0;
        for i in 0..nx {
            for j in 0..ny {
                let q = p + dx * ((i as f64 + 0.5) / nx as f64 - 0.5) + dy * ((j as f64 + 0.5) / ny as f64 - 0.5);
                odd += (c.cell(q) & 1) as f64;
            }
        }
        let truth = odd / (nx * ny) as f64;
        let footprint = Footprint { duv_dx: dx.truncate(), duv_dy: dy.truncate(), ..Footprint::POINT };
        let probes = c.eval(&at_uv(p.x, p.y).with_footprint(footprint)).x;
        let bounding_box = c.odd_share(p, (dx, dy)).unwrap();
        assert!((probes - truth).abs() < 0.4 * (bounding_box - truth).abs(), "truth {truth}, probes {probes}, bounding box {bounding_box}");
        // A footprint inside one cell is still the cell's colour, exactly.
        let small = Footprint { duv_dx: DVec2::new(0.01, 0.0), duv_dy: DVec2::new(0.0, 0.2), ..Footprint::POINT };
        assert_eq!(c.eval(&at_uv(0.5, 0.5).with_footprint(small)), Color::ZERO);
    }
}
