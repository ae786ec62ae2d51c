//! Textures: colours that vary over a surface. A material colour (`kd`, `ks`, …) may name a
//! texture instead of a constant ([`crate::scene::material::TextureMap`]); the texture is looked
//! up where a ray hits, at the surface's texture coordinates or its position in the shape's own
//! frame ([`TexturePoint`]).
//!
//! Texture types are plugins, registered by name like shapes
//! ([`crate::Registry::add_texture`]). [`Mapping`] is what procedural patterns share: which
//! coordinates they are laid over and where they are placed (the `coords` and `transform`
//! parameters).

pub use crate::geometry::differential::Footprint;
use crate::geometry::transform::parse_transform;
use crate::math::color::Color;
use crate::param::error::Result;
use crate::param::params::Params;
use crate::param::spec::{ParamDefault, ParamKind, ParamSpec};
use crate::param::value::Node;
use glam::{DAffine3, DMat2, DVec2, DVec3};
use std::sync::Arc;

/// Where a texture is looked up, and over what area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexturePoint {
    /// The surface's texture coordinates ([`crate::Geometry::uv`]).
    pub uv: DVec2,
    /// Its second set of texture coordinates ([`crate::Geometry::uv1`]: a glTF mesh's
    /// `TEXCOORD_1`); `uv` where the shape has one set.
    pub uv1: DVec2,
    /// The point in the shape's own frame (before the object's transform): solid textures move
    /// with the object.
    pub local: DVec3,
    /// How `uv` and `local` change from one pixel to the next (ray differentials): a texture
    /// filters over this footprint ([`Footprint::POINT`] when filtering is off or unknown: a
    /// point lookup). Non-finite values never reach a texture.
    pub footprint: Footprint,
}

impl TexturePoint {
    /// A point lookup at texture coordinates `uv` (both sets) and shape-frame point `local`.
    #[inline]
    pub const fn new(uv: DVec2, local: DVec3) -> TexturePoint {
        TexturePoint { uv, uv1: uv, local, footprint: Footprint::POINT }
    }

    /// The point lookup at `hit` of `geometry` (its texture coordinates, both sets), at
    /// shape-frame point `local`; with the second set's derivatives along the first
    /// ([`crate::Geometry::uv1`]) where the shape has a second set, for its footprint
    /// ([`Footprint::with_second_set`]).
    #[inline]
    pub fn at_hit(geometry: &dyn crate::Geometry, hit: &crate::geometry::Hit, local: DVec3) -> (TexturePoint, Option<DMat2>) {
        let mut at = TexturePoint::new(geometry.uv(hit), local);
        let j = geometry.uv1(hit).map(|(uv1, j)| {
            at.uv1 = uv1;
            j
        });
        (at, j)
    }

    /// This lookup over `footprint`.
    #[inline]
    pub const fn with_footprint(mut self, footprint: Footprint) -> TexturePoint {
        self.footprint = footprint;
        self
    }
}

/// A colour that varies over a surface.
///
/// Evaluated once per textured coefficient at every hit of a textured material, from many
/// threads: it must not allocate, and must return finite values ≥ 0 for any input (texture
/// coordinates may be huge, negative or NaN on degenerate hits).
///
/// A texture should return its average over the pixel's footprint ([`TexturePoint::footprint`],
/// zero for a point lookup): MIP maps for images, a band-limited (box-filtered) pattern for
/// procedural ones, so that detail finer than a pixel turns to its mean instead of aliasing.
/// One that ignores the footprint is point-sampled, as before filtering existed.
pub trait Texture: Send + Sync + std::fmt::Debug {
    /// The colour (linear RGB, finite, ≥ 0) at `at`, averaged over its footprint.
    fn eval(&self, at: &TexturePoint) -> Color;
}

/// The most probes an anisotropic lookup ([`Probes`]) takes along its footprint's longer side
/// (GPUs' 16×): a footprint longer than this many times its width is widened to it.
pub const MAX_ANISOTROPY: usize = 16;

/// An anisotropic lookup's probes (the GPUs' way, pbrt-v3 §10.4.4's alternative to EWA): the
/// footprint, the parallelogram `p ± dx/2 ± dy/2` around the lookup's point, split along its
/// longer side into `count` equal parallelograms, each `step` by `minor`, laid end to end. A
/// texture filters each one isotropically (a MIP level as wide as its longer side, a box over
/// its bounding box) and averages them: a long thin footprint (a surface seen at a grazing
/// angle) is then blurred along its length only, not over a square as wide as it is long.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probes {
    /// How many (1 ..= [`MAX_ANISOTROPY`]).
    pub count: usize,
    /// One probe's side along the footprint's longer side (the longer side / `count`).
    pub step: DVec3,
    /// The footprint's shorter side (every probe's other side).
    pub minor: DVec3,
}

impl Probes {
    /// The probes of footprint `(dx, dy)` (in the texture's own units: texels, a pattern's
    /// cells): as many as the longer side is long in widths of the shorter, the width counted as
    /// `unit` at least (an image's texel: probes closer than a texel would read the same texels),
    /// at most [`MAX_ANISOTROPY`]. One probe, the footprint itself, when it is not longer than
    /// `unit`, or not finite.
    #[inline]
    pub fn new(dx: DVec3, dy: DVec3, unit: f64) -> Probes {
        let (lx, ly) = (dx.length(), dy.length());
        let (major, minor, long, short) = if lx >= ly { (dx, dy, lx, ly) } else { (dy, dx, ly, lx) };
        let n = (long / short.max(unit)).ceil();
        // `as` saturates: huge ratios are capped below; NaN (a non-finite footprint) is one probe.
        let count = if n >= 1.0 { (n as usize).min(MAX_ANISOTROPY) } else { 1 };
        Probes { count, step: major / count as f64, minor }
    }

    /// Probe `i`'s centre, from the footprint's centre (`i` in `0..count`).
    #[inline]
    pub fn offset(&self, i: usize) -> DVec3 {
        self.step * (i as f64 + 0.5 - 0.5 * self.count as f64)
    }
}

/// Where the texture a material's colour names comes from while a scene loads: the loader's
/// texture library ([`crate::load::textures::TextureLibrary`]), which builds them through the
/// registry. The scene layer names only this.
pub trait TextureResolver {
    /// The texture `node` names: the name of a `[textures.NAME]` table, or an inline table with a
    /// `type`. `what` names the colour in messages.
    fn resolve(&self, node: &Node, what: &str) -> Result<Arc<dyn Texture>>;
}

/// Which coordinates a pattern is laid over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coords {
    /// The surface's texture coordinates, as the point `(u, v, 0)`.
    Uv,
    /// The surface's second set of texture coordinates ([`TexturePoint::uv1`]; the first set
    /// where it has one), as the point `(u, v, 0)`: glTF's `texCoord: 1`.
    Uv1,
    /// The point in the shape's own frame (a solid texture: patterns run through the object).
    Object,
}

/// The `coords` parameter of patterns.
pub const COORDS_PARAM: ParamSpec = ParamSpec::new(
    "coords",
    ParamKind::Str,
    ParamDefault::Str("uv"),
    "\"uv\": over the surface's texture coordinates, as the point (u, v, 0); \"uv1\": over its second set (a glTF mesh's TEXCOORD_1; the first where it has one); \"object\": through the shape's own frame (a solid pattern)",
);

/// The `transform` parameter of patterns and images.
pub const TRANSFORM_PARAM: ParamSpec = ParamSpec::new(
    "transform",
    ParamKind::Any,
    ParamDefault::Optional,
    "places the pattern, as an object's transform places a shape: { scale = 0.25 } makes it four times smaller (tiles it 4× over uv [0, 1])",
);

/// How a pattern is laid over a surface: the coordinates ([`Coords`]) and the pattern's
/// placement, read from the [`COORDS_PARAM`] and [`TRANSFORM_PARAM`] parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mapping {
    coords: Coords,
    /// The inverse of the pattern's placement (the identity when it has none).
    to_pattern: DAffine3,
    placed: bool,
}

impl Mapping {
    /// Over `coords`, unplaced.
    pub const fn new(coords: Coords) -> Mapping {
        Mapping { coords, to_pattern: DAffine3::IDENTITY, placed: false }
    }

    /// Over `coords`, showing the pattern at `to_pattern(p)` for a point `p` (the inverse of a
    /// placement: a file format's texture-coordinate transform).
    pub fn with_inverse(coords: Coords, to_pattern: DAffine3) -> Mapping {
        Mapping { coords, to_pattern, placed: to_pattern != DAffine3::IDENTITY }
    }

    /// Reads `coords` (when the plugin declares it; else texture coordinates) and `transform`.
    pub fn from_params(p: &mut Params) -> Result<Mapping> {
        let coords = match p.declares("coords") {
            true => match p.choice("coords", &["uv", "uv1", "object"])?.as_str() {
                "object" => Coords::Object,
                "uv1" => Coords::Uv1,
                _ => Coords::Uv,
            },
            false => Coords::Uv,
        };
        let mut m = Mapping::new(coords);
        if let Some(n) = p.node("transform")? {
            let t = parse_transform(n).map_err(|e| e.context(p.what()))?;
            if !t.is_identity() {
                m.to_pattern = t.inverse_matrix();
                m.placed = true;
            }
        }
        Ok(m)
    }

    /// Which coordinates the pattern is laid over.
    pub fn coords(&self) -> Coords {
        self.coords
    }

    /// The point of the (unplaced) pattern that `at` shows.
    #[inline]
    pub fn point(&self, at: &TexturePoint) -> DVec3 {
        let p = match self.coords {
            Coords::Uv => at.uv.extend(0.0),
            Coords::Uv1 => at.uv1.extend(0.0),
            Coords::Object => at.local,
        };
        if self.placed { self.to_pattern.transform_point3(p) } else { p }
    }

    /// The texture coordinates of the (unplaced) image that `at` shows.
    #[inline]
    pub fn uv(&self, at: &TexturePoint) -> DVec2 {
        let uv = if self.coords == Coords::Uv1 { at.uv1 } else { at.uv };
        if self.placed { self.to_pattern.transform_point3(uv.extend(0.0)).truncate() } else { uv }
    }

    /// How the pattern point ([`Mapping::point`]) changes from one pixel to the next: `(∂/∂x,
    /// ∂/∂y)` of `at`'s footprint, carried through the placement.
    #[inline]
    pub fn point_footprint(&self, at: &TexturePoint) -> (DVec3, DVec3) {
        let f = &at.footprint;
        let (dx, dy) = match self.coords {
            Coords::Uv => (f.duv_dx.extend(0.0), f.duv_dy.extend(0.0)),
            Coords::Uv1 => (f.duv1_dx.extend(0.0), f.duv1_dy.extend(0.0)),
            Coords::Object => (f.dlocal_dx, f.dlocal_dy),
        };
        if self.placed { (self.to_pattern.transform_vector3(dx), self.to_pattern.transform_vector3(dy)) } else { (dx, dy) }
    }

    /// How the image's texture coordinates ([`Mapping::uv`]) change from one pixel to the next.
    #[inline]
    pub fn uv_footprint(&self, at: &TexturePoint) -> (DVec2, DVec2) {
        let f = &at.footprint;
        let (dx, dy) = if self.coords == Coords::Uv1 { (f.duv1_dx, f.duv1_dy) } else { (f.duv_dx, f.duv_dy) };
        if self.placed {
            let t = |v: DVec2| self.to_pattern.transform_vector3(v.extend(0.0)).truncate();
            (t(dx), t(dy))
        } else {
            (dx, dy)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Probes tile the footprint's longer side: as many as it is long in widths (the width at
    /// least `unit`), at most [`MAX_ANISOTROPY`], centred on the footprint.
    #[test]
    fn probes_split_the_longer_side() {
        let p = Probes::new(DVec3::new(0.0, 0.5, 0.0), DVec3::new(3.0, 0.0, 0.0), 0.1);
        assert_eq!((p.count, p.step, p.minor), (6, DVec3::new(0.5, 0.0, 0.0), DVec3::new(0.0, 0.5, 0.0)));
        assert_eq!((p.offset(0), p.offset(5)), (DVec3::new(-1.25, 0.0, 0.0), DVec3::new(1.25, 0.0, 0.0)));
        assert_eq!(Probes::new(DVec3::X, DVec3::Y, 1.0).count, 1, "square: one probe");
        assert_eq!(Probes::new(DVec3::X * 0.5, DVec3::ZERO, 1.0).count, 1, "shorter than the unit: one");
        assert_eq!(Probes::new(DVec3::X * 1e9, DVec3::Y, 1.0).count, MAX_ANISOTROPY);
        assert_eq!(Probes::new(DVec3::X * f64::NAN, DVec3::Y, 1.0).count, 1, "not finite: one");
        assert_eq!(Probes::new(DVec3::new(f64::INFINITY, 0.0, 0.0), DVec3::Y, 1.0).count, MAX_ANISOTROPY);
    }
}
