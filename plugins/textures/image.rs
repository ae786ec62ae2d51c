//! `image`: a texture from an image file: PNG or JPEG (8 or 16 bits), Radiance `.hdr`, or
//! OpenEXR with the `exr` feature. Looked up at the surface's texture coordinates (`v` up: the image's bottom row at
//! `v = 0`), filtered bilinearly or by nearest texel, wrapped per axis.
//!
//! Over a pixel's footprint ([`TexturePoint::footprint`]) it is MIP-mapped: levels of half the
//! size each, box-filtered in linear values when the texture is built (their memory charged to
//! the budget like the image's), read trilinearly, anisotropically: several probes along a long
//! footprint ([`Image::lookup_filtered`]).
//!
//! Files are read through the scene's sandbox and size limit ([`LoadContext::read_file`]).
//! The header is read first: an image of more than [`raylab::param::limits::Limits::max_pixels`]
//! pixels, or wider or taller than `max_side`, is refused before anything is decoded (no
//! decompression bomb), and the decoded size is charged to the memory budget before it is
//! allocated. An image named by several textures, materials or mesh files is decoded once per
//! scene ([`raylab::load::context::AssetCache`]). 8-bit images keep 3 bytes per texel and are
//! decoded to linear through a table; others are kept as linear `f32`. Alpha is ignored, except by
//! cut-outs ([`ColorSpace::Alpha`]: a glTF base colour's alpha, an MTL `map_d`).

use raylab::glam::{DVec2, Vec3};
use raylab::math::color::srgb_decode;
use raylab::param::error::{Loc, Result, SceneError};
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::scene::texture::{Mapping, Probes, TRANSFORM_PARAM, Texture, TexturePoint};
use raylab::{Color, LoadContext, PluginInfo};
use std::io::Cursor;
use std::sync::{Arc, OnceLock};

/// The `image` texture's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "image",
    summary: "An image file (PNG, JPEG, Radiance .hdr; OpenEXR with the `exr` feature) over the surface's texture coordinates, v up (the image's bottom row at v = 0). 8-bit sRGB is decoded to linear; alpha is ignored. A file used several times is decoded once.",
    params: &[
        ParamSpec::new("file", ParamKind::Path, ParamDefault::Required, "the image, relative to the scene file"),
        ParamSpec::new(
            "wrap",
            ParamKind::Str,
            ParamDefault::Str("repeat"),
            "outside uv [0, 1]: \"repeat\" (tiles), \"clamp\" (the edge texels) or \"mirror\" (tiles flipped every other time)",
        ),
        ParamSpec::new(
            "filter",
            ParamKind::Str,
            ParamDefault::Str("bilinear"),
            "\"bilinear\" (blend of the 4 nearest texels) or \"nearest\"",
        ),
        ParamSpec::new(
            "colorspace",
            ParamKind::Str,
            ParamDefault::Str("auto"),
            "how the file's values become linear: \"auto\" (sRGB for PNG and JPEG, linear for EXR and .hdr), \"srgb\" or \"linear\" (data such as a gloss map)",
        ),
        ParamSpec::new(
            "scale",
            ParamKind::Color,
            ParamDefault::Float(1.0),
            "multiplies every texel (e.g. the strength of an emission map)",
        ),
        TRANSFORM_PARAM,
    ],
};

/// Builds an `image` texture.
pub fn build(p: &mut Params, ctx: &LoadContext) -> Result<Arc<dyn Texture>> {
    let (file, loc) = match p.node("file")? {
        Some(n) => match &n.value {
            raylab::param::value::Value::Str(s) => (s.clone(), n.loc.clone()),
            v => return Err(p.error_at("file", format_args!("expected a path (a string), found {}", v.type_name()))),
        },
        None => return Err(p.error("missing required parameter `file` (path)")),
    };
    let wrap = match p.choice("wrap", &["repeat", "clamp", "mirror"])?.as_str() {
        "clamp" => Wrap::Clamp,
        "mirror" => Wrap::Mirror,
        _ => Wrap::Repeat,
    };
    let filter = match p.choice("filter", &["bilinear", "nearest"])?.as_str() {
        "nearest" => Filter::Nearest,
        _ => Filter::Bilinear,
    };
    let space = match p.choice("colorspace", &["auto", "srgb", "linear"])?.as_str() {
        "srgb" => ColorSpace::Srgb,
        "linear" => ColorSpace::Linear,
        _ => ColorSpace::Auto,
    };
    let scale = p.color("scale")?;
    let mapping = Mapping::from_params(p)?;
    let image = load(ctx, &file, &loc, space).map_err(|e| e.context(p.what()))?;
    with_mip_maps(&image, ctx).map_err(|e| e.context(p.what()))?;
    Ok(Arc::new(ImageTexture { image, mapping, wrap: [wrap; 2], filter, scale }))
}

/// What happens outside texture coordinates [0, 1] (per axis).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles.
    Repeat,
    /// The edge texels continue.
    Clamp,
    /// The image tiles, flipped every other time.
    Mirror,
}

impl Wrap {
    /// The texel index for integer position `i` (any value, NaN included) in a row of `n ≥ 1`.
    #[inline(always)]
    fn index(self, i: f64, n: usize) -> usize {
        // `as` saturates (NaN → 0), so huge coordinates still land in the image.
        let (i, n) = (i as i64, n as i64);
        (match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m >= n { 2 * n - 1 - m } else { m }
            }
        }) as usize
    }
}

/// How texels are combined at a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// The 4 nearest texels, weighted by distance (texel values are exact at texel centres).
    Bilinear,
    /// The texel the point falls in.
    Nearest,
}

/// How a file's values become linear RGB.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ColorSpace {
    /// sRGB for PNG and JPEG, linear for OpenEXR and Radiance `.hdr`.
    Auto,
    /// The sRGB transfer curve (IEC 61966-2-1).
    Srgb,
    /// Values taken as they are (data maps; EXR).
    Linear,
    /// Coverage for cut-outs: the image's alpha channel (its grey value when it has none), in
    /// every channel.
    Alpha,
}

/// Texels of a decoded image, row by row, 3 values (R, G, B) a texel: the decoder's buffer
/// converted in place, so that decoding takes at most the decoded file plus what is kept.
enum Texels {
    /// 8-bit RGB, with the table mapping each value to linear.
    Eight { rgb: Vec<u8>, linear: Box<[f32; 256]> },
    /// Linear RGB.
    Float(Vec<f32>),
}

/// Bytes an image of `pixels` texels keeps ([`Image::memory_bytes`]), 8-bit or `f32`.
fn kept_bytes(pixels: u64, eight: bool) -> u64 {
    if eight { pixels * 3 + std::mem::size_of::<[f32; 256]>() as u64 } else { pixels * 3 * std::mem::size_of::<f32>() as u64 }
}

/// A decoded image: linear RGB texels, row 0 at the top; and, once built for a texture
/// ([`with_mip_maps`]), its MIP levels.
pub struct Image {
    width: usize,
    height: usize,
    /// Width and height as floats (a usize's conversion is a sequence on x86-64, at every lookup
    /// of an environment).
    size_f64: DVec2,
    texels: Texels,
    /// Levels 1, 2, … of the MIP pyramid (each half the size of the one before, down to 1×1),
    /// texels kept as level 0's (8-bit through the same table, or `f32`).
    mips: OnceLock<Box<[Image]>>,
}

impl std::fmt::Debug for Image {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let depth = if matches!(self.texels, Texels::Eight { .. }) { "8-bit" } else { "float" };
        write!(f, "Image({}×{}, {depth})", self.width, self.height)
    }
}

impl Image {
    /// An image of `width × height` linear RGB texels (`texels`: 3 values each, row 0 at the
    /// top); `None` when the sizes do not match or either is zero.
    pub fn from_linear(width: usize, height: usize, texels: Vec<f32>) -> Option<Image> {
        (width > 0 && height > 0 && texels.len() == width * height * 3).then(|| Image::new(width, height, Texels::Float(texels)))
    }

    fn new(width: usize, height: usize, texels: Texels) -> Image {
        Image { width, height, size_f64: DVec2::new(width as f64, height as f64), texels, mips: OnceLock::new() }
    }

    /// Width and height, texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Bytes the texels take.
    pub fn memory_bytes(&self) -> usize {
        kept_bytes((self.width * self.height) as u64, matches!(self.texels, Texels::Eight { .. })) as usize
    }

    /// The linear value of texel (`x`, `y`), row 0 at the top; both in range.
    #[inline(always)]
    fn texel(&self, x: usize, y: usize) -> Vec3 {
        let i = 3 * (y * self.width + x);
        match &self.texels {
            Texels::Eight { rgb, linear } => {
                let [r, g, b] = [rgb[i], rgb[i + 1], rgb[i + 2]];
                Vec3::new(linear[r as usize], linear[g as usize], linear[b as usize])
            }
            Texels::Float(t) => Vec3::new(t[i], t[i + 1], t[i + 2]),
        }
    }

    /// The linear value of texel (`x`, `y`), row 0 at the top; both in range.
    #[inline]
    pub fn texel_color(&self, x: usize, y: usize) -> Color {
        self.texel(x, y).as_dvec3()
    }

    /// The value at texture coordinates `uv` (v up) averaged over the footprint `(duv_dx,
    /// duv_dy)` (the uv moves one pixel over): anisotropic MIP mapping once the footprint is
    /// longer than a texel and the levels are built ([`with_mip_maps`]): the footprint split
    /// along its longer side into up to [`raylab::scene::texture::MAX_ANISOTROPY`] probes ([`Probes`]), each a trilinear
    /// lookup (pbrt-v3 §10.4.3) at the level of a probe's longer side, averaged. Below a texel,
    /// or without levels, [`Image::lookup`] at level 0, exactly.
    #[inline]
    pub fn lookup_filtered(&self, uv: DVec2, (duv_dx, duv_dy): (DVec2, DVec2), wrap: [Wrap; 2], filter: Filter) -> Color {
        let (Some(mips), true) = (self.mips.get(), duv_dx != DVec2::ZERO || duv_dy != DVec2::ZERO) else {
            return self.lookup(uv, wrap, filter);
        };
        let probes = self.probes((duv_dx, duv_dy));
        let level = Image::level_of(&probes);
        if probes.count == 1 {
            return self.trilinear(mips, uv, level, wrap, filter);
        }
        let size = DVec2::new(self.width as f64, self.height as f64);
        let sum: Color =
            (0..probes.count).map(|i| self.trilinear(mips, uv + probes.offset(i).truncate() / size, level, wrap, filter)).sum();
        sum / probes.count as f64
    }

    /// The lookup at `uv` on (fractional) MIP level `level`: the two nearest levels' bilinear
    /// lookups blended (≤ 0: level 0; at or beyond the last, the last).
    #[inline]
    fn trilinear(&self, mips: &[Image], uv: DVec2, level: f64, wrap: [Wrap; 2], filter: Filter) -> Color {
        if !(level > 0.0) {
            return self.lookup(uv, wrap, filter);
        }
        let at = |l: usize| if l == 0 { self.lookup(uv, wrap, filter) } else { mips[(l - 1).min(mips.len() - 1)].lookup(uv, wrap, filter) };
        let top = mips.len() as f64;
        if filter == Filter::Nearest || level >= top {
            return at(level.round().min(top) as usize);
        }
        let l0 = level.floor();
        let t = level - l0;
        let l0 = l0 as usize;
        at(l0) * (1.0 - t) + at(l0 + 1) * t
    }

    /// The probes of footprint `(duv_dx, duv_dy)`, in texels.
    #[inline]
    fn probes(&self, (duv_dx, duv_dy): (DVec2, DVec2)) -> Probes {
        let size = DVec2::new(self.width as f64, self.height as f64);
        Probes::new((duv_dx * size).extend(0.0), (duv_dy * size).extend(0.0), 1.0)
    }

    /// The MIP level of probes' lookups: the log2 of a probe's longer side in texels.
    #[inline]
    fn level_of(probes: &Probes) -> f64 {
        let width = probes.step.length().max(probes.minor.length());
        if width.is_finite() { width.log2() } else { 0.0 }
    }

    /// The MIP level a footprint `(duv_dx, duv_dy)` reads (fractional; ≤ 0: level 0): the log2 of
    /// a probe's width in texels, its longer side (a pixel covering `k × k` texels reads level
    /// `log2 k`, where texels are as large as the pixel; a footprint `a` texels long and `b < a`
    /// wide, level `log2 max(b, a / 16)`).
    #[inline]
    pub fn mip_level(&self, footprint: (DVec2, DVec2)) -> f64 {
        Image::level_of(&self.probes(footprint))
    }

    /// The number of MIP levels built beyond level 0 (0 before [`with_mip_maps`]).
    pub fn mip_levels(&self) -> usize {
        self.mips.get().map_or(0, |m| m.len())
    }

    /// The filtered value at texture coordinates `uv` (v up), wrapped per axis by `wrap`.
    #[inline]
    pub fn lookup(&self, uv: DVec2, wrap: [Wrap; 2], filter: Filter) -> Color {
        self.lookup_inlined(uv, wrap, filter)
    }

    /// [`Image::lookup`], always inlined: a caller whose `wrap` and `filter` are constants (an
    /// environment's lookups, one or two at every path vertex) gets the lookup compiled for them
    /// alone, with no call.
    #[inline(always)]
    pub fn lookup_inlined(&self, uv: DVec2, wrap: [Wrap; 2], filter: Filter) -> Color {
        let uv = if uv.is_finite() { uv } else { DVec2::ZERO };
        let x = uv.x * self.width as f64;
        let y = (1.0 - uv.y) * self.height as f64;
        let (column, row) = (|i: f64| wrap[0].index(i, self.width), |j: f64| wrap[1].index(j, self.height));
        match filter {
            Filter::Nearest => self.texel(column(floor(x)), row(floor(y))).as_dvec3(),
            Filter::Bilinear => {
                let (x, y) = (x - 0.5, y - 0.5);
                let (x0, y0) = (floor(x), floor(y));
                let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
                // Each of the four texels' column and row wrapped once.
                let (c0, c1, r0, r1) = (column(x0), column(x0 + 1.0), row(y0), row(y0 + 1.0));
                let [t00, t10, t01, t11] = self.texels([c0, c1], [r0, r1]);
                let top = t00.lerp(t10, fx);
                let bottom = t01.lerp(t11, fx);
                top.lerp(bottom, fy).as_dvec3()
            }
        }
    }

    /// [`Image::lookup_inlined`] for `[Wrap::Repeat, Wrap::Clamp]` and [`Filter::Bilinear`] (an
    /// environment's lookups: one or two at every path vertex), to the bit: within the image
    /// (every coordinate an environment asks for) the four texels' columns and rows come from
    /// comparisons, not a remainder and a clamp each, and the floors from one truncation each.
    #[inline(always)]
    pub fn bilinear_repeat_clamp(&self, uv: DVec2) -> Color {
        let (w, h) = (self.size_f64.x, self.size_f64.y);
        let x = uv.x * w - 0.5;
        let y = (1.0 - uv.y) * h - 0.5;
        // Outside (NaN included): the general lookup.
        if !(x >= -1.0 && x < w && y >= -1.0 && y < h) {
            return self.lookup_inlined(uv, [Wrap::Repeat, Wrap::Clamp], Filter::Bilinear);
        }
        // floor(x) ∈ [−1, w − 1]: the truncation, less one where it rounded up (below zero).
        let floor_of = |x: f64| {
            let t = x as i64;
            if t as f64 > x { t - 1 } else { t }
        };
        let (x0, y0) = (floor_of(x), floor_of(y));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        // Columns wrap (−1 is the last, w the first), rows are held at the first and last.
        let (width, height) = (self.width as i64, self.height as i64);
        let c0 = if x0 < 0 { width - 1 } else { x0 } as usize;
        let c1 = if x0 + 1 >= width { 0 } else { x0 + 1 } as usize;
        let r0 = y0.max(0) as usize;
        let r1 = (y0 + 1).min(height - 1) as usize;
        let [t00, t10, t01, t11] = self.texels([c0, c1], [r0, r1]);
        let top = t00.lerp(t10, fx);
        let bottom = t01.lerp(t11, fx);
        top.lerp(bottom, fy).as_dvec3()
    }

    /// The linear values of the four texels a bilinear lookup blends, at columns `c0`, `c1` of
    /// rows `r0`, `r1` (as [`Image::texel`]'s; in the order (c0, r0), (c1, r0), (c0, r1),
    /// (c1, r1)), the storage matched once for all four. Written out for the four rather than
    /// mapped over an array: the map was a call of its own at every lookup.
    #[inline(always)]
    fn texels(&self, [c0, c1]: [usize; 2], [r0, r1]: [usize; 2]) -> [Vec3; 4] {
        let w = self.width;
        let at = [3 * (r0 * w + c0), 3 * (r0 * w + c1), 3 * (r1 * w + c0), 3 * (r1 * w + c1)];
        match &self.texels {
            Texels::Eight { rgb, linear } => {
                let one = |i: usize| {
                    let t = &rgb[i..i + 3];
                    Vec3::new(linear[t[0] as usize], linear[t[1] as usize], linear[t[2] as usize])
                };
                [one(at[0]), one(at[1]), one(at[2]), one(at[3])]
            }
            Texels::Float(texels) => {
                let one = |i: usize| {
                    let t = &texels[i..i + 3];
                    Vec3::new(t[0], t[1], t[2])
                };
                [one(at[0]), one(at[1]), one(at[2]), one(at[3])]
            }
        }
    }
}

/// `x.floor()`, to the bit (`-0.0`, infinities and NaN included), without the library call it
/// is on x86-64 without SSE4.1: below 2⁵² through the integer part; from there on every float
/// is whole. Cell patterns' filters use it too (a dozen floors a probe).
#[inline(always)]
pub(crate) fn floor(x: f64) -> f64 {
    if !(x.abs() < 4_503_599_627_370_496.0) {
        return x;
    }
    let t = x as i64 as f64;
    if t == x {
        x
    } else if t > x {
        t - 1.0
    } else {
        t
    }
}

/// Bytes the MIP levels of a `width × height` image take, as [`with_mip_maps`] keeps them.
fn mip_bytes(mut width: usize, mut height: usize, eight: bool) -> u64 {
    let mut total = 0;
    while width > 1 || height > 1 {
        (width, height) = ((width / 2).max(1), (height / 2).max(1));
        total += if eight { width * height * 3 } else { width * height * 12 };
    }
    total as u64
}

/// The level after `image`: half its size (a side of 1 stays 1), each texel the box-filtered
/// mean of the 2 × 2 texels it covers, in linear values; along an odd side the last texel takes
/// the mean of three (so every texel of the level above counts). Inside the image: no wrapping.
fn half_level(image: &Image) -> Image {
    let (w, h) = ((image.width / 2).max(1), (image.height / 2).max(1));
    // The source texels and weights of output index `i` along a side of `n`.
    let taps = |i: usize, n: usize, out: usize| -> (usize, usize) {
        if n == 1 {
            (0, 1)
        } else if i == out - 1 && n % 2 == 1 {
            (2 * i, 3)
        } else {
            (2 * i, 2)
        }
    };
    let mut sums = Vec::with_capacity(w * h);
    for y in 0..h {
        let (y0, ny) = taps(y, image.height, h);
        for x in 0..w {
            let (x0, nx) = taps(x, image.width, w);
            let mut s = Vec3::ZERO;
            for j in y0..y0 + ny {
                for i in x0..x0 + nx {
                    s += image.texel(i, j);
                }
            }
            sums.push(s / (nx * ny) as f32);
        }
    }
    let texels = match &image.texels {
        Texels::Eight { linear, .. } => {
            // Back to 8 bits through the same table: the nearest of its (increasing) values.
            let code = |v: f32| {
                let i = linear.partition_point(|&t| t < v).min(255);
                if i > 0 && (v - linear[i - 1]) <= (linear[i] - v) { (i - 1) as u8 } else { i as u8 }
            };
            let rgb = sums.iter().flat_map(|s| [code(s.x), code(s.y), code(s.z)]).collect();
            Texels::Eight { rgb, linear: linear.clone() }
        }
        Texels::Float(_) => Texels::Float(sums.iter().flat_map(|s| [s.x, s.y, s.z]).collect()),
    };
    Image::new(w, h, texels)
}

/// Builds `image`'s MIP levels once (a file shared by several textures shares them), charging
/// their memory to the scene's budget first. Levels are what a footprint wider than a texel
/// reads ([`Image::lookup_filtered`]).
pub fn with_mip_maps(image: &Image, ctx: &LoadContext) -> Result<()> {
    if image.mips.get().is_some() {
        return Ok(());
    }
    let eight = matches!(image.texels, Texels::Eight { .. });
    ctx.charge(mip_bytes(image.width, image.height, eight), &format!("the MIP maps of a {}×{} image", image.width, image.height), None)?;
    let mut levels: Vec<Image> = Vec::new();
    while levels.last().unwrap_or(image).size() != (1, 1) {
        let next = half_level(levels.last().unwrap_or(image));
        levels.push(next);
    }
    let _ = image.mips.set(levels.into_boxed_slice());
    Ok(())
}

/// An image over a surface's texture coordinates.
#[derive(Clone, Debug)]
pub struct ImageTexture {
    image: Arc<Image>,
    mapping: Mapping,
    wrap: [Wrap; 2],
    filter: Filter,
    scale: Color,
}

impl ImageTexture {
    /// `image` placed by `mapping`, wrapped per axis (u, v), filtered, its texels times `scale`.
    pub fn new(image: Arc<Image>, mapping: Mapping, wrap: [Wrap; 2], filter: Filter, scale: Color) -> Self {
        ImageTexture { image, mapping, wrap, filter, scale }
    }
}

impl Texture for ImageTexture {
    #[inline]
    fn eval(&self, at: &TexturePoint) -> Color {
        let uv = self.mapping.uv(at);
        if at.footprint.is_point() {
            return self.image.lookup(uv, self.wrap, self.filter) * self.scale;
        }
        self.image.lookup_filtered(uv, self.mapping.uv_footprint(at), self.wrap, self.filter) * self.scale
    }
}

/// The image file `path` (as written in the scene, at `loc`), decoded once per scene and
/// colour space.
pub fn load(ctx: &LoadContext, path: &str, loc: &Loc, space: ColorSpace) -> Result<Arc<Image>> {
    let full = ctx.resolve_path(path, loc)?;
    ctx.assets.get_or_load(&format!("image:{}:{space:?}", full.display()), || {
        let (full, bytes) = ctx.read_file(path, loc)?;
        decode(&bytes, &full.display().to_string(), space, ctx)
    })
}

/// Decodes image file `bytes` (named `name` in messages): the header is checked against the
/// size limits and the decoded size charged to the memory budget before decoding. Never panics.
pub fn decode(bytes: &[u8], name: &str, space: ColorSpace, ctx: &LoadContext) -> Result<Image> {
    use raylab::param::limits::Limits;
    let fail = |msg: String| SceneError::in_file(name, None, msg);
    let reader =
        image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| fail(format!("cannot read the image: {e}")))?;
    let format = match reader.format() {
        Some(f @ (image::ImageFormat::Png | image::ImageFormat::Jpeg | image::ImageFormat::OpenExr | image::ImageFormat::Hdr)) => f,
        Some(f) => return Err(fail(format!("{f:?} images are not supported; expected PNG, JPEG, OpenEXR or Radiance .hdr"))),
        None => return Err(fail("not a PNG, JPEG, OpenEXR or Radiance .hdr image (unrecognised signature)".into())),
    };
    if format == image::ImageFormat::OpenExr && !cfg!(feature = "exr") {
        return Err(fail(format!("OpenEXR textures need the `exr` feature; {}", raylab::param::error::built_without("exr"))));
    }
    let space = match space {
        ColorSpace::Auto if matches!(format, image::ImageFormat::OpenExr | image::ImageFormat::Hdr) => ColorSpace::Linear,
        ColorSpace::Auto => ColorSpace::Srgb,
        s => s,
    };
    let limits: &Limits = &ctx.options.limits;
    let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| -> Result<image::DynamicImage> {
        use image::ImageDecoder;
        let mut reader = reader;
        let mut image_limits = image::Limits::default();
        // The decoder's own allocations stay within the memory budget's remainder.
        image_limits.max_alloc = Some(limits.max_memory.saturating_sub(ctx.charged()));
        reader.limits(image_limits);
        let decoder = reader.into_decoder().map_err(|e| fail(format!("cannot read the image's header: {e}")))?;
        let (w, h) = decoder.dimensions();
        let pixels = u64::from(w) * u64::from(h);
        if w == 0 || h == 0 {
            return Err(fail(format!("the image is {w}×{h}: it has no texels")));
        }
        if w.max(h) > limits.max_side || pixels > limits.max_pixels {
            return Err(fail(format!(
                "the image is {w}×{h} = {pixels} pixels, over the limit of {} pixels and {} per side",
                limits.max_pixels, limits.max_side
            ))
            .with_help("raise the limits with --max-pixels and --max-side"));
        }
        let eight = decoder.color_type().bytes_per_pixel() == decoder.color_type().channel_count();
        let buffers = if format == image::ImageFormat::OpenExr { exr_block_buffers(bytes) } else { 0 };
        ctx.charge(
            decoder.total_bytes().saturating_add(kept_bytes(pixels, eight)).saturating_add(buffers),
            &format!("the image ({w}×{h})"),
            None,
        )
        .map_err(|e| SceneError { help: e.help, ..fail(e.message) })?;
        image::DynamicImage::from_decoder(decoder).map_err(|e| fail(format!("cannot decode the image: {e}")))
    }));
    let img = match decoded {
        Ok(r) => r?,
        Err(_) => return Err(fail("the image decoder failed on this file (it is malformed)".into())),
    };
    let (width, height) = (img.width() as usize, img.height() as usize);
    let eight = img.color().bytes_per_pixel() == img.color().channel_count();
    let texels = if space == ColorSpace::Alpha {
        // Kept as 8 bits whatever the file's depth (coverage needs no more).
        let alpha: Vec<u8> = if img.color().has_alpha() {
            img.into_rgba8().into_raw().chunks_exact(4).map(|p| p[3]).collect()
        } else {
            img.into_luma8().into_raw()
        };
        let rgb = alpha.iter().flat_map(|&a| [a; 3]).collect();
        let mut linear = Box::new([0.0f32; 256]);
        for (i, v) in linear.iter_mut().enumerate() {
            *v = i as f32 / 255.0;
        }
        Texels::Eight { rgb, linear }
    } else if eight {
        let rgb = img.into_rgb8().into_raw();
        let mut linear = Box::new([0.0f32; 256]);
        for (i, v) in linear.iter_mut().enumerate() {
            let x = i as f32 / 255.0;
            *v = if space == ColorSpace::Srgb { srgb_decode(x) } else { x };
        }
        Texels::Eight { rgb, linear }
    } else {
        let to_linear = |v: f32| {
            let v = if v.is_finite() { v.max(0.0) } else { 0.0 };
            if space == ColorSpace::Srgb { srgb_decode(v.min(1.0)) } else { v }
        };
        let mut rgb = img.into_rgb32f().into_raw();
        rgb.iter_mut().for_each(|v| *v = to_linear(*v));
        Texels::Float(rgb)
    };
    Ok(Image::new(width, height, texels))
}

/// What an OpenEXR decoder holds besides the image while it decodes: a block of the file as
/// stored and the same block uncompressed, each up to every channel's bytes (not only those read)
/// for a block's pixels (a tile, or up to 256 rows of the layer's width), the largest over the
/// file's parts. The header alone decides it and can make it far larger than the image: the
/// `texture_image` fuzz target found a 7.5 KB file of a 24×16 image whose decoder reserved 1.75 GB
/// for one block. 0 when the header does not read (the decoder then fails).
#[cfg(feature = "exr")]
fn exr_block_buffers(bytes: &[u8]) -> u64 {
    let Ok(meta) = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false) else { return 0 };
    let block = |h: &exr::meta::header::Header| {
        let pixels = match h.blocks {
            exr::meta::BlockDescription::Tiles(t) => (t.tile_size.0 as u64).saturating_mul(t.tile_size.1 as u64),
            exr::meta::BlockDescription::ScanLines => {
                (h.compression.scan_lines_per_block() as u64).saturating_mul(h.layer_size.width() as u64)
            }
        };
        (h.channels.bytes_per_pixel as u64).saturating_mul(pixels)
    };
    meta.headers.iter().map(block).max().unwrap_or(0).saturating_mul(2)
}

/// Without the `exr` feature OpenEXR files are refused before decoding.
#[cfg(not(feature = "exr"))]
fn exr_block_buffers(_: &[u8]) -> u64 {
    0
}

#[cfg(test)]
mod tests {
    use super::*;
    use raylab::LoadOptions;

    #[test]
    fn the_environments_bilinear_lookup_is_the_general_one_to_the_bit() {
        // Both storages, sizes down to one texel, coordinates within, at and beyond the edges.
        let mut z = 0x2545_f491_u64;
        let mut next = move || {
            z = z.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (z >> 11) as f64 / (1u64 << 53) as f64
        };
        for (w, h) in [(1, 1), (2, 1), (1, 3), (7, 4), (16, 8)] {
            let floats: Vec<f32> = (0..w * h * 3).map(|_| (next() * 4.0) as f32).collect();
            let bytes: Vec<u8> = (0..w * h * 3).map(|_| (next() * 255.0) as u8).collect();
            let linear: [f32; 256] = std::array::from_fn(|i| (i as f32 / 255.0).powf(2.2));
            for image in [Image::new(w, h, Texels::Float(floats)), Image::new(w, h, Texels::Eight { rgb: bytes, linear: Box::new(linear) })]
            {
                let mut uvs: Vec<DVec2> = (0..4000).map(|_| DVec2::new(next() * 1.4 - 0.2, next() * 1.4 - 0.2)).collect();
                for k in 0..=2 * w.max(h) {
                    let e = k as f64 / (2 * w.max(h)) as f64;
                    uvs.extend([DVec2::new(e, 0.5), DVec2::new(0.5, e), DVec2::new(e, e), DVec2::new(1.0 - e, e)]);
                }
                uvs.extend([DVec2::new(f64::NAN, 0.5), DVec2::new(0.5, f64::INFINITY), DVec2::new(-1e300, 1e300), DVec2::ZERO, DVec2::ONE]);
                for uv in uvs {
                    let (a, b) = (image.bilinear_repeat_clamp(uv), image.lookup(uv, [Wrap::Repeat, Wrap::Clamp], Filter::Bilinear));
                    assert!(a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits), "{w}×{h} at {uv}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn floor_is_the_library_floor_to_the_bit() {
        let two52 = 4_503_599_627_370_496.0;
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.5,
            -2.5,
            1e-300,
            -1e-300,
            f64::MIN_POSITIVE / 2.0,
            -f64::MIN_POSITIVE / 2.0,
            two52 - 0.5,
            -(two52 - 0.5),
            two52,
            -two52,
            two52 + 1.0,
            1e300,
            -1e300,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            9.3e18,
            -9.3e18,
        ];
        let mut z = 1u64;
        for _ in 0..10_000 {
            z = z.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let u = (z >> 11) as f64 / (1u64 << 53) as f64;
            values.push((u - 0.5) * 2f64.powi((z % 120) as i32 - 40));
        }
        for x in values {
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x:e}");
        }
        assert!(floor(f64::NAN).is_nan());
    }

    fn png(w: u32, h: u32, rgb: &[u8]) -> Vec<u8> {
        use image::ImageEncoder;
        let mut out = Vec::new();
        image::codecs::png::PngEncoder::new(&mut out).write_image(rgb, w, h, image::ExtendedColorType::Rgb8).unwrap();
        out
    }

    /// CRC-32 (ISO-HDLC), as PNG chunks carry it.
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    }

    fn ctx_decode(bytes: &[u8], space: ColorSpace, options: &LoadOptions) -> Result<Image> {
        let ctx = LoadContext::new(std::path::Path::new(""), options);
        decode(bytes, "t.png", space, &ctx)
    }

    /// A 2×2 image: red, green (top row), blue, white (bottom row).
    fn quad() -> Vec<u8> {
        png(2, 2, &[255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255])
    }

    #[test]
    fn texels_are_exact_at_their_centres_and_v_points_up() {
        let img = ctx_decode(&quad(), ColorSpace::Auto, &LoadOptions::default()).unwrap();
        let at = |u: f64, v: f64| img.lookup(DVec2::new(u, v), [Wrap::Clamp; 2], Filter::Bilinear);
        assert_eq!(at(0.25, 0.75), Color::new(1.0, 0.0, 0.0), "top left is red");
        assert_eq!(at(0.75, 0.75), Color::new(0.0, 1.0, 0.0));
        assert_eq!(at(0.25, 0.25), Color::new(0.0, 0.0, 1.0), "bottom left (v = 0) is blue");
        let mid = at(0.5, 0.75);
        assert!((mid - Color::new(0.5, 0.5, 0.0)).abs().max_element() < 1e-6, "{mid}");
        let near = img.lookup(DVec2::new(0.6, 0.3), [Wrap::Repeat; 2], Filter::Nearest);
        assert_eq!(near, Color::ONE);
    }

    #[test]
    fn srgb_is_decoded_to_linear_unless_asked_not_to() {
        let grey = png(1, 1, &[128, 128, 128]);
        let srgb = ctx_decode(&grey, ColorSpace::Auto, &LoadOptions::default()).unwrap();
        let v = srgb.lookup(DVec2::ZERO, [Wrap::Repeat; 2], Filter::Bilinear).x;
        assert!((v - 0.2158605).abs() < 1e-6, "{v}");
        let lin = ctx_decode(&grey, ColorSpace::Linear, &LoadOptions::default()).unwrap();
        assert_eq!(lin.lookup(DVec2::ZERO, [Wrap::Repeat; 2], Filter::Bilinear).x, f64::from(128.0f32 / 255.0));
    }

    #[test]
    fn wrap_modes_map_any_index_into_the_image() {
        assert_eq!([-1.0, 0.0, 3.0, 4.0].map(|i| Wrap::Repeat.index(i, 4)), [3, 0, 3, 0]);
        assert_eq!([-1.0, 0.0, 3.0, 4.0].map(|i| Wrap::Clamp.index(i, 4)), [0, 0, 3, 3]);
        assert_eq!([-1.0, 0.0, 3.0, 4.0, 8.0].map(|i| Wrap::Mirror.index(i, 4)), [0, 0, 3, 3, 0]);
        for w in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror] {
            for i in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300, 9.2e18] {
                assert!(w.index(i, 3) < 3, "{w:?} {i}");
            }
        }
        let img = ctx_decode(&quad(), ColorSpace::Auto, &LoadOptions::default()).unwrap();
        for uv in [DVec2::NAN, DVec2::INFINITY, DVec2::splat(-1e300), DVec2::new(1e15, -7.3)] {
            for f in [Filter::Bilinear, Filter::Nearest] {
                assert!(img.lookup(uv, [Wrap::Mirror, Wrap::Repeat], f).is_finite());
            }
        }
    }

    /// A tiny file declaring a huge image is refused from its header, before decoding.
    #[test]
    fn a_decompression_bomb_is_refused_from_its_header() {
        let mut bomb = png(1, 1, &[0, 0, 0]);
        // IHDR: type at 12..16, width and height at 16..24, its CRC at 29..33.
        bomb[16..20].copy_from_slice(&30_000u32.to_be_bytes());
        bomb[20..24].copy_from_slice(&30_000u32.to_be_bytes());
        let crc = crc32(&bomb[12..29]);
        bomb[29..33].copy_from_slice(&crc.to_be_bytes());
        let e = ctx_decode(&bomb, ColorSpace::Auto, &LoadOptions::default()).unwrap_err();
        assert!(e.report().contains("30000×30000 = 900000000 pixels, over the limit"), "{}", e.report());
        // Within the pixel limit but over the memory budget: refused by the charge.
        let big = png(64, 64, &[7; 64 * 64 * 3]);
        let mut options = LoadOptions::default();
        options.limits.max_memory = 1000;
        let e = ctx_decode(&big, ColorSpace::Auto, &options).unwrap_err();
        assert!(e.report().contains("over the limit"), "{}", e.report());
        options.limits = raylab::param::limits::Limits { max_pixels: 100, ..Default::default() };
        let e = ctx_decode(&big, ColorSpace::Auto, &options).unwrap_err();
        assert!(e.report().contains("64×64 = 4096 pixels, over the limit of 100"), "{}", e.report());
    }

    /// An OpenEXR file's block buffers are charged with its image, before decoding: a 7.5 KB file
    /// of a 24×16 image whose header declares huge blocks had its decoder reserve 1.75 GB for one,
    /// beyond the budget (found by the `texture_image` fuzz target).
    #[cfg(feature = "exr")]
    #[test]
    fn an_exr_whose_blocks_exceed_the_budget_is_refused_before_decoding() {
        let file = include_bytes!("../../fuzz/corpus/texture_image/crash-exr-24x16-block-of-1.75GB.exr");
        assert!(exr_block_buffers(file) > 1 << 30, "{}", exr_block_buffers(file));
        let options = LoadOptions { limits: crate::textures::fuzz::limits(), ..LoadOptions::default() };
        let e = ctx_decode(file, ColorSpace::Auto, &options).unwrap_err();
        assert!(e.report().contains("needs about") && e.report().contains("over the limit of 64 MB"), "{}", e.report());
        // A well-formed EXR's blocks are small: the image crate writes 64×64 tiles.
        let (w, h) = (64, 16);
        let img = image::Rgb32FImage::from_fn(w, h, |x, y| image::Rgb([x as f32, y as f32, 1.0]));
        let mut exr = Vec::new();
        image::DynamicImage::ImageRgb32F(img).write_to(&mut std::io::Cursor::new(&mut exr), image::ImageFormat::OpenExr).unwrap();
        let buffers = exr_block_buffers(&exr);
        assert!(buffers > 0 && buffers <= 2 * 16 * 64 * 64, "{buffers}");
    }

    /// What an image keeps (texels and, for 8 bits, the table to linear) is charged in full;
    /// found by the `texture_image` fuzz target (a 3×1 grey PNG kept 1033 bytes, charged 12).
    #[test]
    fn the_charge_covers_what_the_image_keeps() {
        let options = LoadOptions::default();
        let ctx = LoadContext::new(std::path::Path::new(""), &options);
        let image = decode(&png(3, 1, &[1, 2, 3, 4, 5, 6, 7, 8, 9]), "t.png", ColorSpace::Auto, &ctx).unwrap();
        assert_eq!(image.memory_bytes(), 3 * 3 + 1024);
        assert!(ctx.charged() >= image.memory_bytes() as u64, "{} charged", ctx.charged());
    }

    #[test]
    fn garbage_and_truncated_files_are_errors() {
        let options = LoadOptions::default();
        for bytes in [&b""[..], b"not an image", &quad()[..40], b"\x89PNG\r\n\x1a\n"] {
            assert!(ctx_decode(bytes, ColorSpace::Auto, &options).is_err());
        }
    }

    /// Stripes 4 texels wide seen along their length (a footprint 16 texels long, 1 wide, at a
    /// white stripe's centre): the anisotropic lookup keeps the stripe (its probes read level 0),
    /// where one square as wide as the footprint is long (level 4) would be the grey mean.
    #[test]
    fn a_long_footprint_along_stripes_keeps_them() {
        let n = 64;
        let texels = (0..n * n).flat_map(|i| [if (i % n) / 4 % 2 == 0 { 1.0f32 } else { 0.0 }; 3]).collect();
        let image = Image::from_linear(n, n, texels).unwrap();
        let options = LoadOptions::default();
        with_mip_maps(&image, &LoadContext::new(std::path::Path::new(""), &options)).unwrap();
        let texel = 1.0 / n as f64;
        let footprint = (DVec2::new(texel, 0.0), DVec2::new(0.0, 16.0 * texel));
        assert_eq!(image.mip_level(footprint), 0.0);
        let uv = DVec2::new(2.0 * texel, 0.5);
        let v = image.lookup_filtered(uv, footprint, [Wrap::Repeat; 2], Filter::Bilinear).x;
        assert!((v - 1.0).abs() < 1e-6, "{v}");
        // Square footprints are as before: level log2 of their side.
        let square = (DVec2::new(4.0 * texel, 0.0), DVec2::new(0.0, 4.0 * texel));
        assert!((image.mip_level(square) - 2.0).abs() < 1e-12);
        // Longer than 16 widths: widened to a sixteenth of its length (level log2(64 / 16)).
        let longer = (DVec2::new(texel, 0.0), DVec2::new(0.0, 64.0 * texel));
        assert!((image.mip_level(longer) - 2.0).abs() < 1e-12);
    }
}
