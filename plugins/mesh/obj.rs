//! Wavefront OBJ files, read by raylab (in chunks of lines, in parallel, with the result of one
//! pass over the bytes), and their MTL libraries, read by tobj.
//!
//! Faces with more than three corners are triangulated by raylab ([`super::triangulate`]: fans
//! for convex faces, ear clipping for concave ones); points and lines are ignored. Vertex normals
//! (`vn`) are used for smooth shading when every face has them. `v x y z w` divides by `w`;
//! `v x y z r g b` (vertex colours) keeps the position. Texture coordinates (`vt u [v [w]]`, `w`
//! ignored) are kept when every face has them. Faces that use texture coordinates (normals)
//! before the file's first `vt` (`vn`) line are read without them, with a warning. The MTL library is read relative to the OBJ file, through the scene's folder sandbox
//! and size limit, once however often the file names it; `usemtl` names a material of the
//! libraries read so far (an unknown name, or none, is the first material).
//!
//! MTL → raylab material:
//!
//! | MTL | raylab | note |
//! |---|---|---|
//! | `Kd` | `kd` | scaled by the dissolve `d` |
//! | `Ks` | `ks` | also `kr` (mirror) under `illum` 3, 5 and 7 |
//! | `Ns` | `shininess` | the Phong exponent |
//! | `d`, `Tr` (= 1 − d) | `kt = 1 − d` | transparency (a thin transmitting sheet); `Tf` is ignored |
//! | `map_d` | a cut-out ([`Cutout`]) | coverage `d` × the image's alpha (its grey value without alpha), stochastic: rays pass through where it is 0, and through a fraction 1 − coverage elsewhere; `kt` and the `d` scaling of `kd` are then dropped |
//! | `Ni` | `ior` | values ≤ 0 keep the default 1.5 |
//! | `Ke` | `emission` | |
//! | `Ka` | — | ignored: exporters write it inconsistently; `ka` keeps its default |
//! | `map_Kd`, `map_Ks`, `map_Ke` | textures multiplying `kd`, `ks`, `emission` | sRGB images, over the file's `vt`; options `-o` and `-s` (offset and scale of the texture coordinates) and `-clamp on`; others ignored with a warning |
//! | `bump`, `map_Bump` | a bump map ([`NormalMap`], [`NormalMapKind::Bump`]) | heights: the image's red channel (linear) × `-bm` (default 1), in scene units, over the file's `vt` |
//! | `norm` | a normal map ([`NormalMapKind::Tangent`]) | tangent-space normals (linear), `-bm` scaling their tilt; wins over `bump` (which is then a warning) |
//! | `map_Ka`, `disp`, … | — | other maps: ignored with a warning per material |
//!
//! Texture files are read relative to their MTL file, through the sandbox, once per scene, and
//! only for materials some face uses; one that cannot be read is a warning (the constant colour
//! is used).
//!
//! Every error names `file:line:col`. A face corner that refers to a vertex, texture coordinate or
//! normal the file does not define is found by a second pass over the text, only then: relative
//! (negative) indices count back from their line, positive vertex indices may refer ahead.

use super::triangle_mesh::MeshData;
use super::triangulate::triangulate_into;
use crate::textures::image::{self as image_texture, ColorSpace, Filter, ImageTexture, Wrap};
use raylab::glam::{DAffine3, DVec3, Vec3};
use raylab::param::error::{Loc, Result, SceneError};
use raylab::scene::material::{AlphaMode, Channel, Cutout, NormalMap, NormalMapKind, TextureMap};
use raylab::scene::texture::{Coords, Mapping};
use raylab::{Color, LoadContext, Material};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Bytes of text per chunk of a file read in parallel (chunks end at line ends). The chunks
/// depend on the file alone, and the result does not depend on them (see [`read_chunks`]).
const CHUNK_BYTES: usize = 1 << 20;

/// Reads the OBJ file `bytes` (named `path` in the scene, resolved to `full`), with its MTL
/// library unless `need_materials` is false.
pub fn read(ctx: &LoadContext, path: &str, full: &Path, bytes: &[u8], need_materials: bool, loc: &Loc) -> Result<MeshData> {
    read_in_chunks(ctx, path, full, bytes, need_materials, loc, CHUNK_BYTES)
}

/// [`read`], the text read in chunks of about `chunk_bytes` (any size gives the same result: the
/// `mesh_obj_chunks` fuzz target compares small chunks with the whole file).
pub fn read_in_chunks(
    ctx: &LoadContext,
    path: &str,
    full: &Path,
    bytes: &[u8],
    need_materials: bool,
    loc: &Loc,
    chunk_bytes: usize,
) -> Result<MeshData> {
    let name = full.display().to_string();
    let text = text_of(bytes, &name)?;
    let mut libraries = Libraries::new(ctx, path, loc, need_materials);
    let mut p = read_chunks(&name, text, chunk_bytes, &mut libraries)?;
    p.finish(&name, text)?;
    for (kind, (count, what)) in [(1, (p.texcoords.len(), "texture coordinates (`vt`)")), (2, (p.normals.len(), "normals (`vn`)"))] {
        if let Some(line) = p.ignored[kind]
            && count > 0
        {
            let msg = format!(
                "a face refers to {what} before the file defines any (it does later): OBJ indices refer back, so the faces before the first are read without them"
            );
            ctx.warn(SceneError::in_file(&name, Some((line, 1)), msg));
        }
    }
    if !p.polygons.is_empty() {
        triangulate_deferred(&mut p);
    }
    let (materials, maps) = libraries.finish(&name)?;
    let Parser {
        positions, triangles, normals, normal_indices, texcoords, texcoord_indices, material_ids, all_normals, all_texcoords, ..
    } = p;
    let many_materials = material_ids.iter().any(|&m| m != material_ids.first().copied().unwrap_or(0));
    let with_normals = all_normals && !normals.is_empty();
    let with_texcoords = all_texcoords && !texcoords.is_empty();
    let mut out = MeshData {
        positions,
        triangles,
        normal_indices: if with_normals { normal_indices } else { Vec::new() },
        normals: if with_normals { normals } else { Vec::new() },
        texcoord_indices: if with_texcoords { texcoord_indices } else { Vec::new() },
        texcoords: if with_texcoords { texcoords } else { Vec::new() },
        texcoords1: Vec::new(),
        material_ids: if many_materials || material_ids.first().is_some_and(|&m| m > 0) { material_ids } else { Vec::new() },
        materials,
        tangents: Vec::new(),
    };
    if out.triangles.is_empty() {
        return Err(SceneError::in_file(&name, None, "the file has no faces with three or more corners (points and lines are ignored)"));
    }
    // Texture maps, for the materials faces use.
    let mut used = out.material_ids.clone();
    if used.is_empty() {
        used.push(0);
    }
    used.sort_unstable();
    used.dedup();
    for id in used {
        let (Some((m, folder)), Some(out_m)) = (maps.get(id as usize), out.materials.get_mut(id as usize)) else { continue };
        attach_maps(ctx, m, folder, loc, out_m);
    }
    Ok(out)
}

/// The parser of the whole text: the text split into chunks at line ends, each chunk read on its
/// own (in parallel), then the chunks joined in order.
///
/// Each chunk is told what precedes it (lines, vertices, texture coordinates and normals: counted
/// first, in parallel), so relative indices and line numbers resolve as in one pass. Material
/// statements are replayed in file order as the chunks are joined (a chunk's faces name its
/// `usemtl` statements by their rank in the chunk), and a polygon whose corners are not all in its
/// own chunk waits for the end of the file, as one referring ahead does. The first error in file
/// order is returned, after the material libraries named before it were read: the result,
/// errors and warnings included, is that of one pass over the text.
fn read_chunks(name: &str, text: &str, chunk_bytes: usize, libraries: &mut Libraries) -> Result<Parser> {
    use rayon::prelude::*;
    let chunks = split(text, chunk_bytes);
    let census: Vec<Census> = chunks.par_iter().map(|c| Census::of(c)).collect();
    // The material statements are kept until the chunks are joined: charged before they are read.
    let events = census.iter().map(|c| c.events).sum::<u64>();
    if events > 0 {
        let what = format!("the {events} `usemtl` and `mtllib` statements of {name}");
        libraries.ctx.charge(events.saturating_mul(EVENT_BYTES), &what, Some(libraries.loc))?;
    }
    let mut at = Start::default();
    let starts: Vec<Start> = census
        .iter()
        .map(|c| {
            let start = Start { faces: c.faces, own: c.counts, ..at };
            at.line += c.lines;
            for (total, n) in at.counts.iter_mut().zip(c.counts) {
                *total += n;
            }
            start
        })
        .collect();
    let mut parts: Vec<Chunk> = chunks.par_iter().zip(&starts).map(|(c, start)| Chunk::read(name, c, start)).collect();
    // The material of each chunk's `usemtl` ranks: the one current before the chunk, then each
    // statement's, with the libraries named before it read; up to the first error.
    let mut materials = Vec::with_capacity(parts.len());
    for part in &mut parts {
        let mut ranks = vec![libraries.current];
        for event in &part.events {
            match *event {
                Event::Library(mtl) => libraries.load(mtl),
                Event::Select(material) => {
                    libraries.select(material);
                    ranks.push(libraries.current);
                }
            }
        }
        match part.failure.take() {
            Some(Failure::At(e)) => return Err(e),
            Some(Failure::Face(fallback)) => return Err(scan(name, text).unwrap_or(fallback)),
            None => materials.push(ranks),
        }
    }
    let mut parts: Vec<Parser> = parts.into_iter().map(|c| c.parser).collect();
    if parts.len() == 1
        && let Some(mut whole) = parts.pop()
    {
        // One chunk: the file, its ranks mapped in place.
        for m in whole.material_ids.iter_mut().chain(whole.polygons.iter_mut().map(|f| &mut f.material)) {
            *m = materials[0][*m as usize];
        }
        return Ok(whole);
    }
    // The large lists copied into place in parallel, the rest appended.
    let mut out = Parser {
        positions: gather(&parts, |p| &p.positions, |_, v| v),
        triangles: gather(&parts, |p| &p.triangles, |_, t| t),
        material_ids: gather(&parts, |p| &p.material_ids, |k, m| materials[k][m as usize]),
        all_normals: true,
        all_texcoords: true,
        ..Parser::default()
    };
    let mut at = 0;
    for (part, ranks) in parts.into_iter().zip(&materials) {
        let triangles = part.triangles.len();
        out.append(part, at, ranks);
        at += triangles;
    }
    Ok(out)
}

/// The lists `list(part)` of the parts one after the other, each element `e` of part `k` as
/// `map(k, e)`: copied into place in parallel.
fn gather<T: Copy + Sync, U: Clone + Default + Send>(
    parts: &[Parser],
    list: impl Fn(&Parser) -> &[T] + Sync,
    map: impl Fn(usize, T) -> U + Sync,
) -> Vec<U> {
    use rayon::prelude::*;
    let mut out = vec![U::default(); parts.iter().map(|p| list(p).len()).sum()];
    let mut places = Vec::with_capacity(parts.len());
    let mut rest = out.as_mut_slice();
    for p in parts {
        let (place, tail) = rest.split_at_mut(list(p).len());
        places.push(place);
        rest = tail;
    }
    places.into_par_iter().zip(parts).enumerate().for_each(|(k, (place, p))| {
        for (to, &from) in place.iter_mut().zip(list(p)) {
            *to = map(k, from);
        }
    });
    out
}

/// The text split after a line end at every `size` bytes or so (one chunk for a shorter text).
fn split(text: &str, size: usize) -> Vec<&str> {
    let mut chunks = Vec::with_capacity(text.len() / size.max(1) + 1);
    let mut rest = text;
    while rest.len() > size {
        let cut = rest.as_bytes()[size..].iter().position(|&b| b == b'\n').map_or(rest.len(), |p| size + p + 1);
        let (chunk, tail) = rest.split_at(cut);
        chunks.push(chunk);
        rest = tail;
    }
    if !rest.is_empty() || chunks.is_empty() {
        chunks.push(rest);
    }
    chunks
}

/// What precedes a chunk: lines and (positions, texture coordinates, normals); and the chunk's
/// own `f` lines and `v`, `vt` and `vn` lines (size hints).
#[derive(Clone, Copy, Default)]
struct Start {
    line: usize,
    counts: [u64; 3],
    faces: usize,
    own: [u64; 3],
}

/// A chunk's lines, `v`, `vt` and `vn` lines, `f` lines, and lines that may be `usemtl` or
/// `mtllib` statements (at least those that are).
struct Census {
    lines: usize,
    counts: [u64; 3],
    faces: usize,
    events: u64,
}

/// Bytes a `usemtl` or `mtllib` statement takes until the chunks are joined: its [`Event`] and
/// the material rank of a `usemtl`.
const EVENT_BYTES: u64 = (std::mem::size_of::<Event>() + std::mem::size_of::<u32>()) as u64;

impl Census {
    /// Counts the lines of `chunk` by their first word, as the parser reads them.
    fn of(chunk: &str) -> Census {
        let mut c = Census { lines: 0, counts: [0; 3], faces: 0, events: 0 };
        for line in Lines(chunk) {
            c.lines += 1;
            let b = line.as_bytes();
            let i = b.iter().position(|&c| c != b' ' && c != b'\t').unwrap_or(b.len());
            let space = |k: usize| matches!(b.get(i + k), Some(b' ' | b'\t'));
            // Spaces and tabs end a word both in ASCII lines and in others (split at Unicode
            // whitespace); anything unusual is left to the words of the line.
            let kind = match b.get(i) {
                None => None,
                Some(b'f') if space(1) => {
                    c.faces += 1;
                    None
                }
                Some(b'v') if space(1) => Some(0),
                Some(b'v') if b.get(i + 1) == Some(&b't') && space(2) => Some(1),
                Some(b'v') if b.get(i + 1) == Some(&b'n') && space(2) => Some(2),
                Some(b'u' | b'm') => {
                    c.events += u64::from(b[i..].starts_with(b"usemtl") || b[i..].starts_with(b"mtllib"));
                    None
                }
                Some(&c) if c != b'v' && c.is_ascii_graphic() => None,
                _ => match Words::new(line).next() {
                    Some("v") => Some(0),
                    Some("vt") => Some(1),
                    Some("vn") => Some(2),
                    Some("usemtl" | "mtllib") => {
                        c.events += 1;
                        None
                    }
                    _ => None,
                },
            };
            if let Some(k) = kind {
                c.counts[k] += 1;
            }
        }
        c
    }
}

/// A material statement of a chunk, replayed in file order when the chunks are joined.
enum Event<'a> {
    /// `mtllib`, with the rest of its line.
    Library(&'a str),
    /// `usemtl`, with the material's name.
    Select(&'a str),
}

/// Why a chunk stopped.
enum Failure {
    /// An error at a line.
    At(SceneError),
    /// A face corner that is malformed or refers to something not defined before it: the file's
    /// scan locates the first such corner (the error given is used if it finds none).
    Face(SceneError),
}

/// One chunk, read.
struct Chunk<'a> {
    /// Its vertices and faces; faces name materials by the rank of the `usemtl` before them in the
    /// chunk (0: the material current before the chunk).
    parser: Parser,
    events: Vec<Event<'a>>,
    /// The chunk's first error; nothing after it was read.
    failure: Option<Failure>,
}

impl<'a> Chunk<'a> {
    /// Reads the lines of `text`, a chunk of the file `name` preceded by `start`.
    fn read(name: &str, text: &'a str, start: &Start) -> Chunk<'a> {
        let mut p = Parser { all_normals: true, all_texcoords: true, base: start.counts, ..Parser::default() };
        // Room for the faces counted, but never more than valid `f a b c` lines of the chunk's
        // size hold (bare `f` lines would otherwise reserve five times the file's size).
        let faces = start.faces.min(text.len() / 8);
        p.triangles.reserve(faces);
        p.material_ids.reserve(faces);
        // The same for the vertices (valid `v x y z`, `vt u` and `vn x y z` lines have at least
        // 7, 4 and 8 bytes).
        let [v, vt, vn]: [usize; 3] =
            std::array::from_fn(|k| usize::try_from(start.own[k]).unwrap_or(usize::MAX).min(text.len() / [7, 4, 8][k]));
        p.positions.reserve(v);
        p.texcoords.reserve(vt);
        p.normals.reserve(vn);
        let mut chunk = Chunk { parser: p, events: Vec::new(), failure: None };
        chunk.failure = chunk.lines(name, text, start.line).err();
        chunk
    }

    /// Reads the lines of the chunk, the first being line `before + 1` of the file.
    fn lines(&mut self, name: &str, text: &'a str, before: usize) -> std::result::Result<(), Failure> {
        let p = &mut self.parser;
        let mut selection = 0;
        for (i, line) in Lines(text).enumerate() {
            let number = before + i + 1;
            // The plain forms of the lines that make up a large file, `v x y z` and `f a b c` with
            // integer corners, directly from the bytes; anything else by words.
            match fast::line(line.as_bytes(), &mut p.raw) {
                Some(fast::Line::Vertex(v)) => {
                    p.push_position(v, number);
                    continue;
                }
                Some(fast::Line::Face) if p.face(selection, number) => continue,
                _ => {}
            }
            let at = |key: &str, msg: String| SceneError::in_file(name, Some((number, line.find(key).unwrap_or(0) + 1)), msg);
            let mut words = Words::new(line);
            let Some(key) = words.next() else { continue };
            match key {
                "v" => {
                    let Some(mut v) = words.floats::<3>() else {
                        return Err(Failure::At(at(key, "expected a vertex `v x y z` with three numbers".into())));
                    };
                    // Then nothing, a weight w that divides x, y, z, or a colour r g b.
                    match (words.next(), words.next(), words.next(), words.next()) {
                        (None, ..) => {}
                        (Some(w), None, ..) => match w.parse::<f32>() {
                            Ok(w) if w != 0.0 => v = v.map(|c| c / w),
                            Ok(_) => return Err(Failure::At(at(key, "the vertex weight w is 0".into()))),
                            Err(_) => return Err(Failure::At(at(key, "expected a vertex `v x y z [w]` or `v x y z r g b`".into()))),
                        },
                        (Some(_), Some(_), Some(_), None) => {}
                        _ => return Err(Failure::At(at(key, "expected a vertex `v x y z [w]` or `v x y z r g b`".into()))),
                    }
                    p.push_position(v, number);
                }
                "vt" => {
                    // u, then optional v and w (w, and anything after it, ignored).
                    let bad = || Failure::At(at(key, "expected a texture coordinate `vt u [v [w]]`".into()));
                    let (mut v, mut n) = ([0.0f32; 3], 0);
                    for w in words.take(3) {
                        v[n] = parse_f32(w).ok_or_else(bad)?;
                        n += 1;
                    }
                    if n == 0 {
                        return Err(bad());
                    }
                    p.texcoords.push([v[0], v[1]]);
                }
                "vn" => match words.floats::<3>() {
                    Some(n) => p.normals.push(n),
                    None => return Err(Failure::At(at(key, "expected a normal `vn x y z` with three numbers".into()))),
                },
                "f" => {
                    let read = p.read_corners(words) && p.face(selection, number);
                    if !read {
                        return Err(Failure::Face(at(key, "malformed face".into())));
                    }
                }
                "mtllib" => self.events.push(Event::Library(line.trim_start()[key.len()..].trim())),
                "usemtl" => {
                    let material = line.trim_start()[key.len()..].trim();
                    if material.is_empty() {
                        return Err(Failure::At(at(key, "expected a material name after `usemtl`".into())));
                    }
                    self.events.push(Event::Select(material));
                    selection += 1;
                }
                _ => {}
            }
        }
        Ok(())
    }
}

/// The lines of a text, without their `\n` or `\r\n`.
struct Lines<'a>(&'a str);

impl<'a> Iterator for Lines<'a> {
    type Item = &'a str;
    #[inline]
    fn next(&mut self) -> Option<&'a str> {
        if self.0.is_empty() {
            return None;
        }
        let end = self.0.bytes().position(|b| b == b'\n');
        let (line, rest) = match end {
            Some(e) => (&self.0[..e], &self.0[e + 1..]),
            None => (self.0, ""),
        };
        self.0 = rest;
        Some(line.strip_suffix('\r').unwrap_or(line))
    }
}

/// The whitespace-separated words of a line: split at ASCII whitespace, or for a line with other
/// characters at any Unicode whitespace.
#[derive(Clone)]
enum Words<'a> {
    Ascii { line: &'a str, at: usize },
    Unicode(std::str::SplitWhitespace<'a>),
}

impl<'a> Words<'a> {
    fn new(line: &'a str) -> Self {
        if line.is_ascii() { Words::Ascii { line, at: 0 } } else { Words::Unicode(line.split_whitespace()) }
    }

    /// The next `N` words as numbers.
    #[inline]
    fn floats<const N: usize>(&mut self) -> Option<[f32; N]> {
        let mut v = [0.0; N];
        for c in &mut v {
            *c = parse_f32(self.next()?)?;
        }
        Some(v)
    }
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a str;
    #[inline]
    fn next(&mut self) -> Option<&'a str> {
        match self {
            Words::Ascii { line, at } => {
                let b = line.as_bytes();
                let mut i = *at;
                while i < b.len() && b[i].is_ascii_whitespace() {
                    i += 1;
                }
                let start = i;
                while i < b.len() && !b[i].is_ascii_whitespace() {
                    i += 1;
                }
                *at = i;
                (i > start).then(|| &line[start..i])
            }
            Words::Unicode(w) => w.next(),
        }
    }
}

/// A number as `str::parse::<f32>` reads it (the same bits): plain decimals of up to seven digits
/// directly (both the digits and the power of ten are exact in `f32`, so one division rounds
/// correctly: Clinger's fast path), anything else by `str::parse`.
#[inline]
fn parse_f32(s: &str) -> Option<f32> {
    let b = s.as_bytes();
    let (neg, digits) = match b {
        [b'-', d @ ..] => (true, d),
        [b'+', d @ ..] => (false, d),
        d => (false, d),
    };
    let mut mantissa = 0u32;
    let (mut count, mut fraction, mut dot) = (0, 0, false);
    for &c in digits {
        match c {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u32::from(c - b'0');
                count += 1;
                fraction += i32::from(dot);
                if count > 7 {
                    return s.parse().ok();
                }
            }
            b'.' if !dot => dot = true,
            _ => return s.parse().ok(),
        }
    }
    if count == 0 {
        return s.parse().ok();
    }
    const POW10: [f32; 8] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7];
    let v = mantissa as f32 / POW10[fraction as usize];
    Some(if neg { -v } else { v })
}

/// The plain forms of `v` and `f` lines, read straight from the bytes (the same values as by
/// words; a line in any other form is left to the general reader).
mod fast {
    /// What a plain line holds.
    pub(super) enum Line {
        /// `v x y z`.
        Vertex([f32; 3]),
        /// `f` with its corners in the `raw` buffer.
        Face,
    }

    /// A plain `v x y z` line (numbers of up to seven digits and a point), or a plain `f` line
    /// (corners `v`, `v/vt`, `v//vn`, `v/vt/vn` of integers of up to 18 digits), its corners put
    /// in `raw`; `None` for anything else.
    #[inline]
    pub(super) fn line(b: &[u8], raw: &mut Vec<[Option<i64>; 3]>) -> Option<Line> {
        let mut i = 0;
        skip_space(b, &mut i);
        match (b.get(i), b.get(i + 1)) {
            (Some(b'v'), Some(b' ' | b'\t')) => {
                i += 1;
                let v = [number(b, &mut i)?, number(b, &mut i)?, number(b, &mut i)?];
                skip_space(b, &mut i);
                (i == b.len()).then_some(Line::Vertex(v))
            }
            (Some(b'f'), Some(b' ' | b'\t')) => {
                i += 1;
                raw.clear();
                loop {
                    skip_space(b, &mut i);
                    if i == b.len() {
                        return Some(Line::Face);
                    }
                    let mut c = [None; 3];
                    for (k, slot) in c.iter_mut().enumerate() {
                        *slot = integer(b, &mut i);
                        match b.get(i) {
                            Some(b'/') if k < 2 => i += 1,
                            Some(b' ' | b'\t') | None => break,
                            _ => return None,
                        }
                    }
                    if c[0].is_none() || !matches!(b.get(i), Some(b' ' | b'\t') | None) {
                        return None;
                    }
                    raw.push(c);
                }
            }
            _ => None,
        }
    }

    #[inline(always)]
    fn skip_space(b: &[u8], i: &mut usize) {
        while *i < b.len() && (b[*i] == b' ' || b[*i] == b'\t') {
            *i += 1;
        }
    }

    /// An optionally signed integer of 1 to 18 digits at `i`; `None` (and `i` unmoved) when
    /// there is none.
    #[inline(always)]
    fn integer(b: &[u8], i: &mut usize) -> Option<i64> {
        let neg = b.get(*i) == Some(&b'-');
        let mut j = *i + usize::from(neg);
        let (mut v, mut digits) = (0i64, 0);
        while j < b.len() && b[j].is_ascii_digit() {
            if digits < 18 {
                v = v * 10 + i64::from(b[j] - b'0');
            }
            digits += 1;
            j += 1;
        }
        if digits == 0 || digits > 18 {
            return None;
        }
        *i = j;
        Some(if neg { -v } else { v })
    }

    /// A number `[-]digits[.digits]` of up to seven digits after spaces, ended by a space or the
    /// line's end: digits and power of ten are exact in `f32`, so one division rounds correctly
    /// (Clinger's fast path), as `str::parse` does.
    #[inline(always)]
    fn number(b: &[u8], i: &mut usize) -> Option<f32> {
        skip_space(b, i);
        let neg = b.get(*i) == Some(&b'-');
        *i += usize::from(neg);
        let (mut mantissa, mut count, mut fraction, mut dot) = (0u32, 0u32, 0usize, false);
        while *i < b.len() {
            match b[*i] {
                c @ b'0'..=b'9' => {
                    mantissa = mantissa * 10 + u32::from(c - b'0');
                    count += 1;
                    fraction += usize::from(dot);
                    if count > 7 {
                        return None;
                    }
                }
                b'.' if !dot => dot = true,
                b' ' | b'\t' => break,
                _ => return None,
            }
            *i += 1;
        }
        if count == 0 {
            return None;
        }
        const POW10: [f32; 8] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7];
        let v = mantissa as f32 / POW10[fraction];
        Some(if neg { -v } else { v })
    }
}

/// A face of more than three corners with a corner outside its chunk's positions (one the chunk
/// had not read, ahead or in an earlier chunk), triangulated once the whole file is read.
struct Polygon {
    /// Where its triangles go in the triangle list.
    at: usize,
    /// Its corners: `corners` entries of [`Parser::deferred_corners`] from `first`.
    first: usize,
    corners: usize,
    material: u32,
}

/// What the pass over one chunk of the file collects (and, chunks joined, over the file).
#[derive(Default)]
struct Parser {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    texcoords: Vec<[f32; 2]>,
    triangles: Vec<[u32; 3]>,
    normal_indices: Vec<[u32; 3]>,
    texcoord_indices: Vec<[u32; 3]>,
    material_ids: Vec<u32>,
    /// Every corner so far has a normal index (then `normal_indices` has one per triangle).
    all_normals: bool,
    /// Every corner so far has a texture coordinate index (then `texcoord_indices` has one per
    /// triangle).
    all_texcoords: bool,
    /// Largest positive (1-based) vertex, texture and normal index seen, checked at the end.
    largest: [u64; 3],
    /// A texture or normal reference that is valid only if the file has none of its kind.
    unsure: [bool; 3],
    /// The first line of a face whose texture (1) or normal (2) references were ignored because
    /// no `vt` (`vn`) line came before it.
    ignored: [Option<usize>; 3],
    polygons: Vec<Polygon>,
    /// Vertex, texture coordinate and normal index of each corner of `polygons`, in order (one
    /// list, not one allocation per polygon).
    deferred_corners: Vec<[u32; 3]>,
    /// The first vertex with a non-finite coordinate, and its line.
    non_finite: Option<(usize, usize)>,
    /// Positions, texture coordinates and normals before the text read (another chunk's).
    base: [u64; 3],
    /// Scratch: the corners of the face being read, as written (vertex, texture, normal index),
    /// and resolved (vertex, texture, normal).
    raw: Vec<[Option<i64>; 3]>,
    corners: Vec<[u32; 3]>,
    /// Scratch for triangulating polygons.
    triangulator: Triangulator,
}

/// Scratch space of polygon triangulation, reused from polygon to polygon.
#[derive(Default)]
struct Triangulator {
    points: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

impl Triangulator {
    /// The triangles of the polygon `corners` (vertex, texture coordinate and normal index of
    /// each), as indices into `corners`: `corners.len() − 2` of them. `position` gives a vertex
    /// index's position.
    fn run(&mut self, corners: &[[u32; 3]], position: impl Fn(u32) -> [f32; 3]) -> &[[u32; 3]] {
        self.points.clear();
        self.points.extend(corners.iter().map(|c| Vec3::from(position(c[0])).as_dvec3()));
        self.triangles.clear();
        triangulate_into(&self.points, &mut self.triangles);
        &self.triangles
    }
}

/// Index of a missing texture coordinate or normal in a corner.
const NONE: u32 = u32::MAX;

impl Parser {
    /// Reads the corners of an `f` line into `raw`; false when one is malformed.
    fn read_corners<'a>(&mut self, words: impl Iterator<Item = &'a str>) -> bool {
        self.raw.clear();
        for corner in words {
            let mut c = [None; 3];
            let mut parts = corner.as_bytes().split(|&b| b == b'/');
            for slot in &mut c {
                match parts.next() {
                    Some([]) | None => {}
                    Some(part) => match parse_i64(part) {
                        Some(k) => *slot = Some(k),
                        None => return false,
                    },
                }
            }
            if c[0].is_none() || parts.next().is_some() {
                return false;
            }
            self.raw.push(c);
        }
        true
    }

    /// Adds a vertex position read at `line`.
    #[inline]
    fn push_position(&mut self, v: [f32; 3], line: usize) {
        if self.non_finite.is_none() && !v.iter().all(|c| c.is_finite()) {
            self.non_finite = Some((self.base[0] as usize + self.positions.len(), line));
        }
        self.positions.push(v);
    }

    /// Positions, texture coordinates and normals defined so far, those before the text included.
    fn counts(&self) -> [u64; 3] {
        [self.base[0] + self.positions.len() as u64, self.base[1] + self.texcoords.len() as u64, self.base[2] + self.normals.len() as u64]
    }

    /// Adds the face whose corners are in `raw`, read at `line`; false when one refers to something
    /// not defined before it (the caller then locates the error).
    fn face(&mut self, material: u32, line: usize) -> bool {
        self.corners.clear();
        let counts = self.counts();
        for raw in &self.raw {
            let mut resolved = [0u32, NONE, NONE];
            for (kind, (slot, &k)) in resolved.iter_mut().zip(raw).enumerate() {
                let Some(k) = k else { continue };
                // A texture or normal reference in a file without any is ignored; whether the
                // file has any is known at its end.
                if kind > 0 && counts[kind] == 0 {
                    self.ignored[kind].get_or_insert(line);
                    if k <= 0 || k > i64::from(u32::MAX) {
                        self.unsure[kind] = true;
                    } else {
                        self.largest[kind] = self.largest[kind].max(k as u64);
                    }
                    continue;
                }
                let index = if k < 0 {
                    let back = k.unsigned_abs();
                    if back > counts[kind] {
                        return false;
                    }
                    counts[kind] - back
                } else if k == 0 || k > i64::from(u32::MAX) {
                    return false;
                } else {
                    self.largest[kind] = self.largest[kind].max(k as u64);
                    k as u64 - 1
                };
                *slot = index as u32;
            }
            self.corners.push(resolved);
        }
        let n = self.corners.len();
        if n < 3 {
            return true; // a point or a line
        }
        if self.corners.iter().any(|c| c[2] == NONE) && self.all_normals {
            self.all_normals = false;
            self.normal_indices = Vec::new();
        }
        if self.corners.iter().any(|c| c[1] == NONE) && self.all_texcoords {
            self.all_texcoords = false;
            self.texcoord_indices = Vec::new();
        }
        if n == 3 {
            let c = &self.corners;
            self.triangles.push([c[0][0], c[1][0], c[2][0]]);
            if self.all_normals {
                self.normal_indices.push([c[0][2], c[1][2], c[2][2]]);
            }
            if self.all_texcoords {
                self.texcoord_indices.push([c[0][1], c[1][1], c[2][1]]);
            }
            self.material_ids.push(material);
            return true;
        }
        // A polygon is triangulated over its corners' positions: those of this text only.
        let here = self.base[0]..counts[0];
        if self.corners.iter().any(|c| !here.contains(&u64::from(c[0]))) {
            let first = self.deferred_corners.len();
            self.deferred_corners.extend_from_slice(&self.corners);
            self.polygons.push(Polygon { at: self.triangles.len(), first, corners: n, material });
        } else {
            let corners = std::mem::take(&mut self.corners);
            self.push_polygon(&corners, material);
            self.corners = corners;
        }
        true
    }

    /// Appends the triangles of a polygon whose corners are all read.
    fn push_polygon(&mut self, corners: &[[u32; 3]], material: u32) {
        let (positions, base) = (&self.positions, self.base[0]);
        for &t in self.triangulator.run(corners, |v| positions[(u64::from(v) - base) as usize]) {
            self.triangles.push(t.map(|k| corners[k as usize][0]));
            if self.all_normals {
                self.normal_indices.push(t.map(|k| corners[k as usize][2]));
            }
            if self.all_texcoords {
                self.texcoord_indices.push(t.map(|k| corners[k as usize][1]));
            }
            self.material_ids.push(material);
        }
    }

    /// Appends the lists of the chunk read after this one but its positions, triangles and
    /// material ids (gathered apart), its first triangle being number `at`, its `usemtl` ranks
    /// mapped to `materials`.
    fn append(&mut self, mut next: Parser, at: usize, materials: &[u32]) {
        self.normals.extend_from_slice(&next.normals);
        self.texcoords.extend_from_slice(&next.texcoords);
        if !next.all_normals {
            self.all_normals = false;
            self.normal_indices = Vec::new();
        }
        if self.all_normals {
            self.normal_indices.append(&mut next.normal_indices);
        }
        if !next.all_texcoords {
            self.all_texcoords = false;
            self.texcoord_indices = Vec::new();
        }
        if self.all_texcoords {
            self.texcoord_indices.append(&mut next.texcoord_indices);
        }
        let first = self.deferred_corners.len();
        self.deferred_corners.extend_from_slice(&next.deferred_corners);
        self.polygons.extend(next.polygons.into_iter().map(|f| Polygon {
            at: at + f.at,
            first: first + f.first,
            material: materials[f.material as usize],
            ..f
        }));
        for k in 0..3 {
            self.largest[k] = self.largest[k].max(next.largest[k]);
            self.unsure[k] |= next.unsure[k];
            self.ignored[k] = self.ignored[k].or(next.ignored[k]);
        }
        self.non_finite = self.non_finite.or(next.non_finite);
    }

    /// Checks what could only be checked once the whole file was read: positive indices, and
    /// finite vertices.
    fn finish(&self, name: &str, text: &str) -> Result<()> {
        let counts = [self.positions.len() as u64, self.texcoords.len() as u64, self.normals.len() as u64];
        if (0..3).any(|k| (self.largest[k] > counts[k] || self.unsure[k]) && (k == 0 || counts[k] > 0)) {
            return Err(
                scan(name, text).unwrap_or_else(|| SceneError::in_file(name, None, "a face refers to a vertex the file does not define"))
            );
        }
        if let Some((vertex, line)) = self.non_finite {
            return Err(SceneError::in_file(name, Some((line, 1)), format!("vertex {vertex} has a coordinate that is NaN or infinite")));
        }
        Ok(())
    }
}

/// Polygons triangulated by one task of [`triangulate_deferred`] (the tasks depend on the
/// number of polygons alone).
const DEFERRED_POLYGONS_PER_TASK: usize = 1 << 12;

/// Rebuilds the triangle lists of the whole file `p` with the triangles of the polygons that
/// waited for its end, each where its face was in the file: in parallel, in runs of polygons
/// whose triangles go to disjoint stretches of the lists (a polygon of `n` corners gives `n − 2`
/// triangles, so every stretch is known before triangulating).
fn triangulate_deferred(p: &mut Parser) {
    use rayon::prelude::*;
    let polygons = std::mem::take(&mut p.polygons);
    let corners = std::mem::take(&mut p.deferred_corners);
    let old = [std::mem::take(&mut p.triangles), std::mem::take(&mut p.normal_indices), std::mem::take(&mut p.texcoord_indices)];
    let old_materials = std::mem::take(&mut p.material_ids);
    let total = old[0].len() + polygons.iter().map(|f| f.corners - 2).sum::<usize>();
    // Lists of one entry per triangle while every face had normals (texture coordinates).
    let kept = [true, p.all_normals, p.all_texcoords];
    let mut lists: [Vec<[u32; 3]>; 3] = kept.map(|k| if k { vec![[0; 3]; total] } else { Vec::new() });
    let mut materials = vec![0u32; total];
    // Each task: its polygons, the old triangles from before its first polygon up to the next
    // task's first polygon, and its places in the new lists.
    let runs: Vec<&[Polygon]> = polygons.chunks(DEFERRED_POLYGONS_PER_TASK).collect();
    let mut tasks = Vec::with_capacity(runs.len());
    let (mut rest, mut rest_materials) = (lists.each_mut().map(|l| l.as_mut_slice()), materials.as_mut_slice());
    let mut from = 0;
    for (k, run) in runs.iter().enumerate() {
        let to = runs.get(k + 1).map_or(old[0].len(), |r| r[0].at);
        let len = to - from + run.iter().map(|f| f.corners - 2).sum::<usize>();
        let mut place: [&mut [[u32; 3]]; 3] = Default::default();
        for (slot, list) in place.iter_mut().zip(rest.iter_mut()) {
            let whole = std::mem::take(list);
            let (head, tail) = whole.split_at_mut(if whole.is_empty() { 0 } else { len });
            *slot = head;
            *list = tail;
        }
        let (head, tail) = std::mem::take(&mut rest_materials).split_at_mut(len);
        rest_materials = tail;
        tasks.push((*run, from..to, place, head));
        from = to;
    }
    let positions = &p.positions;
    tasks.into_par_iter().for_each_init(Triangulator::default, |triangulator, (run, old_range, mut place, place_materials)| {
        let mut o = 0;
        let copy = |place: &mut [&mut [[u32; 3]]; 3], place_materials: &mut [u32], range: std::ops::Range<usize>, o: &mut usize| {
            let n = range.len();
            for (to, from) in place.iter_mut().zip(&old) {
                if !to.is_empty() {
                    to[*o..*o + n].copy_from_slice(&from[range.clone()]);
                }
            }
            place_materials[*o..*o + n].copy_from_slice(&old_materials[range]);
            *o += n;
        };
        let mut next = old_range.start;
        for f in run {
            copy(&mut place, place_materials, next..f.at, &mut o);
            next = f.at;
            let face = &corners[f.first..f.first + f.corners];
            for &t in triangulator.run(face, |v| positions[v as usize]) {
                for (kind, to) in [0, 2, 1].into_iter().zip(place.iter_mut()) {
                    if !to.is_empty() {
                        to[o] = t.map(|k| face[k as usize][kind]);
                    }
                }
                place_materials[o] = f.material;
                o += 1;
            }
        }
        copy(&mut place, place_materials, next..old_range.end, &mut o);
    });
    [p.triangles, p.normal_indices, p.texcoord_indices] = lists;
    p.material_ids = materials;
}

/// An MTL material as written, and the folder (relative to the scene) of its library.
type MaterialSource = (tobj::Material, PathBuf);

/// The MTL libraries an OBJ file names, each read once, and its `usemtl` selection.
struct Libraries<'a> {
    ctx: &'a LoadContext<'a>,
    loc: &'a Loc,
    /// The OBJ file's folder, relative to the scene.
    base: PathBuf,
    need: bool,
    materials: Vec<Material>,
    /// Each material's MTL statement and the folder (relative to the scene) of its library, for
    /// its texture maps.
    sources: Vec<MaterialSource>,
    by_name: HashMap<String, u32>,
    /// Whether each library, by the name as written and by the file it resolves to, was read.
    seen_names: HashMap<String, bool>,
    seen_files: HashMap<PathBuf, bool>,
    error: Option<SceneError>,
    /// The material of the faces that follow.
    current: u32,
}

impl<'a> Libraries<'a> {
    fn new(ctx: &'a LoadContext<'a>, path: &str, loc: &'a Loc, need: bool) -> Self {
        Libraries {
            ctx,
            loc,
            base: Path::new(path).parent().map(Path::to_path_buf).unwrap_or_default(),
            need,
            materials: Vec::new(),
            sources: Vec::new(),
            by_name: HashMap::new(),
            seen_names: HashMap::new(),
            seen_files: HashMap::new(),
            error: None,
            current: 0,
        }
    }

    /// Reads the library `mtl` (the rest of an `mtllib` line: a name may contain spaces), unless
    /// it was read before however spelled, or materials are not needed.
    fn load(&mut self, mtl: &str) {
        if !self.need {
            return;
        }
        let rel = self.base.join(mtl).to_string_lossy().into_owned();
        if self.seen_names.contains_key(&rel) {
            return;
        }
        let file = self.ctx.resolve_path(&rel, self.loc).map(|f| f.canonicalize().unwrap_or(f));
        if let Some(&ok) = file.as_ref().ok().and_then(|f| self.seen_files.get(f)) {
            self.seen_names.insert(rel, ok);
            return;
        }
        let ok = match self.ctx.read_file(&rel, self.loc) {
            Ok((_, data)) => match tobj::load_mtl_buf(&mut data.as_slice()) {
                Ok((list, _)) => {
                    warn_ignored_maps(self.ctx, &rel, &list);
                    let folder = Path::new(&rel).parent().map(Path::to_path_buf).unwrap_or_default();
                    for m in list {
                        self.by_name.insert(m.name.clone(), self.materials.len() as u32);
                        self.materials.push(material(&m));
                        self.sources.push((m, folder.clone()));
                    }
                    true
                }
                Err(e) => {
                    self.error.get_or_insert(SceneError::in_file(&rel, None, format!("cannot read the material library: {e}")));
                    false
                }
            },
            Err(e) => {
                self.error.get_or_insert(e);
                false
            }
        };
        if let Ok(f) = file {
            self.seen_files.insert(f, ok);
        }
        self.seen_names.insert(rel, ok);
    }

    /// `usemtl name`: the faces that follow use that material (the first when it is unknown).
    fn select(&mut self, name: &str) {
        self.current = self.by_name.get(name).copied().unwrap_or(0);
    }

    /// The materials read, with their MTL statements and folders; an error when a library named
    /// could not be read and none was.
    fn finish(self, name: &str) -> Result<(Vec<Material>, Vec<MaterialSource>)> {
        match self.error {
            Some(e) if self.materials.is_empty() => Err(e
                .context(format!("{name}: its material library"))
                .with_help("fix or add the .mtl file, or give the object a `material` to render without the file's materials")),
            _ => Ok((self.materials, self.sources)),
        }
    }
}

/// The texture maps raylab samples: statement, the material's text of it, and the colour it
/// multiplies.
fn sampled_maps(m: &tobj::Material) -> [(&'static str, Option<&String>, Channel); 3] {
    [
        ("map_Kd", m.diffuse_texture.as_ref(), Channel::Kd),
        ("map_Ks", m.specular_texture.as_ref(), Channel::Ks),
        ("map_Ke", m.unknown_param.get("map_Ke"), Channel::Emission),
    ]
}

/// Gives `out` (the raylab material of MTL material `m`, defined in the library in `folder`)
/// the textures of its `map_Kd`, `map_Ks` and `map_Ke`, and its cut-out (`map_d`); a map that
/// cannot be read, and options raylab ignores, are warnings.
fn attach_maps(ctx: &LoadContext, m: &tobj::Material, folder: &Path, loc: &Loc, out: &mut Material) {
    let coverage = m.dissolve_texture.as_ref().map(|s| ("map_d", Some(s), Use::Coverage));
    let colours = sampled_maps(m).map(|(key, statement, channel)| (key, statement, Use::Colour(channel)));
    // A tangent-space `norm` map wins over a height map (`bump`, `map_Bump`), which is then ignored.
    let normals = match (m.unknown_param.get("norm"), m.normal_texture.as_ref()) {
        (Some(n), bump) => {
            if let Some(b) = bump {
                ctx.warn(SceneError::msg(format!("material \"{}\": bump {b}: ignored, its norm map is used", m.name)));
            }
            Some(("norm", Some(n), Use::Normal(NormalMapKind::Tangent)))
        }
        (None, Some(b)) => Some(("bump", Some(b), Use::Normal(NormalMapKind::Bump))),
        (None, None) => None,
    };
    for (key, statement, usage) in colours.into_iter().chain(coverage).chain(normals) {
        let Some(statement) = statement else { continue };
        let map = MapStatement::parse(statement);
        let what = || format!("material \"{}\": {key} {statement}", m.name);
        if !map.ignored.is_empty() {
            ctx.warn(SceneError::msg(format!("{}: options ignored: {}", what(), map.ignored.join(", "))));
        }
        let Some(file) = map.file else {
            ctx.warn(SceneError::msg(format!("{}: names no file", what())));
            continue;
        };
        let path = folder.join(&file);
        let space = match usage {
            Use::Colour(_) => ColorSpace::Srgb,
            Use::Coverage => ColorSpace::Alpha,
            Use::Normal(_) => ColorSpace::Linear,
        };
        match image_texture::load(ctx, &path.to_string_lossy(), loc, space) {
            Ok(image) => {
                // Over the memory budget: a warning, and the map is looked up at points.
                if space != ColorSpace::Alpha
                    && let Err(e) = image_texture::with_mip_maps(&image, ctx)
                {
                    ctx.warn(e);
                }
                let wrap = if map.clamp { Wrap::Clamp } else { Wrap::Repeat };
                let mapping = Mapping::with_inverse(Coords::Uv, map.lookup);
                let texture = std::sync::Arc::new(ImageTexture::new(image, mapping, [wrap; 2], Filter::Bilinear, Color::ONE));
                match usage {
                    Use::Colour(channel) => out.textures.push(TextureMap { channel, texture }),
                    // The dissolve `d` is the coverage constant (`material` left `kd` and `kt`
                    // alone for it).
                    Use::Coverage => out.cutout = Cutout::new(dissolve(m), Some(texture), AlphaMode::Blend),
                    Use::Normal(kind) => out.normal_map = Some(NormalMap { texture, kind, scale: map.bm }),
                }
            }
            Err(e) => ctx.warn(e.context(format!("{} is not sampled (the constant colour is used)", what()))),
        }
    }
}

/// What an MTL texture map is for.
#[derive(Clone, Copy)]
enum Use {
    /// A colour it multiplies (`map_Kd`, `map_Ks`, `map_Ke`): sRGB.
    Colour(Channel),
    /// The cut-out's coverage (`map_d`).
    Coverage,
    /// Normals (`norm`) or heights (`bump`, `map_Bump`): linear data, `-bm` their strength.
    Normal(NormalMapKind),
}

/// An MTL texture statement's file and options (`map_Kd -s 2 2 -clamp on wood.png`).
#[derive(Debug, PartialEq)]
struct MapStatement {
    /// The file name (the words after the options, joined by single spaces).
    file: Option<String>,
    /// Texture coordinates to the map's: `-s` scales them, then `-o` offsets them.
    lookup: DAffine3,
    /// `-clamp on`.
    clamp: bool,
    /// `-bm`: the bump multiplier (of `bump`, `map_Bump` and `norm`; 1 without).
    bm: f64,
    /// Options raylab ignores, as written.
    ignored: Vec<String>,
}

impl MapStatement {
    fn parse(text: &str) -> MapStatement {
        let words: Vec<&str> = text.split_whitespace().collect();
        let (mut offset, mut scale) = (DVec3::ZERO, DVec3::ONE);
        let (mut clamp, mut ignored, mut bm) = (false, Vec::new(), 1.0);
        let mut i = 0;
        while i < words.len() && words[i].starts_with('-') && words[i].len() > 1 {
            let option = words[i];
            i += 1;
            // Numbers following an option (up to `max`).
            let mut numbers = |max: usize| {
                let mut v = Vec::new();
                while v.len() < max && i < words.len() {
                    match words[i].parse::<f64>() {
                        Ok(x) if x.is_finite() => v.push(x),
                        _ => break,
                    }
                    i += 1;
                }
                v
            };
            match option {
                "-o" | "-s" => {
                    let v = numbers(3);
                    let target = if option == "-o" { &mut offset } else { &mut scale };
                    for (k, x) in v.into_iter().enumerate() {
                        target[k] = x;
                    }
                }
                "-clamp" => {
                    clamp = words.get(i) == Some(&"on");
                    i += 1;
                }
                "-bm" => {
                    if let Some(&x) = numbers(1).first() {
                        bm = x;
                    }
                }
                "-mm" => {
                    numbers(2);
                    ignored.push(option.to_string());
                }
                "-t" => {
                    numbers(3);
                    ignored.push(option.to_string());
                }
                _ => {
                    // -blendu, -blendv, -boost, -cc, -imfchan, -texres, -type: one value.
                    i += 1;
                    ignored.push(option.to_string());
                }
            }
        }
        let file = (i < words.len()).then(|| words[i..].join(" "));
        let lookup = DAffine3::from_translation(offset) * DAffine3::from_scale(scale);
        MapStatement { file, lookup, clamp, bm, ignored }
    }
}

/// The file as UTF-8 text, or an error naming the first bad line.
fn text_of<'a>(bytes: &'a [u8], name: &str) -> Result<&'a str> {
    if bytes.starts_with(&[0xFE, 0xFF]) || bytes.starts_with(&[0xFF, 0xFE]) {
        return Err(SceneError::in_file(name, Some((1, 1)), "the file is UTF-16 text; OBJ files must be ASCII or UTF-8"));
    }
    // A UTF-8 byte-order mark would otherwise make the first line's keyword unknown.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        let col = at - bytes[..at].iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1) + 1;
        SceneError::in_file(name, Some((line, col)), "the file is not UTF-8 text")
    })
}

/// An MTL material as a raylab material (see the module's table).
fn material(m: &tobj::Material) -> Material {
    let rgb = |c: Option<[f32; 3]>| c.map(|c| Vec3::from(c).as_dvec3()).filter(|c| c.is_finite()).map(|c| c.max(DVec3::ZERO));
    let mut out = Material::default();
    // With `map_d`, the dissolve is the cut-out's coverage ([`attach_maps`]), not transmission.
    let d = if m.dissolve_texture.is_some() { 1.0 } else { dissolve(m) };
    if let Some(kd) = rgb(m.diffuse) {
        out.kd = kd * d;
    }
    if let Some(ks) = rgb(m.specular) {
        out.ks = ks;
        if matches!(m.illumination_model, Some(3 | 5 | 7)) {
            out.kr = ks;
        }
    }
    if let Some(ns) = m.shininess.filter(|s| s.is_finite() && *s >= 0.0) {
        out.shininess = f64::from(ns);
    }
    out.kt = Color::splat(1.0 - d);
    if let Some(ni) = m.optical_density.filter(|n| n.is_finite() && *n > 0.0) {
        out.ior = f64::from(ni);
    }
    if let Some(ke) = rgb(m.emissive) {
        out.emission = ke;
    }
    out
}

/// The dissolve `d` of an MTL material in [0, 1] (1: opaque).
fn dissolve(m: &tobj::Material) -> f64 {
    f64::from(m.dissolve.unwrap_or(1.0)).clamp(0.0, 1.0)
}

/// Most materials of one MTL library warned about by name for their ignored texture maps; the
/// rest are counted in one more warning.
pub const MAX_MAP_WARNINGS: usize = 8;

/// Warns, once per material of the library `file`, about the texture maps it names that raylab
/// does not sample (all but `map_Kd`, `map_Ks` and `map_Ke`).
fn warn_ignored_maps(ctx: &LoadContext, file: &str, materials: &[tobj::Material]) {
    let mut warned = 0;
    for m in materials {
        let known = [("map_Ka", &m.ambient_texture), ("map_Ns", &m.shininess_texture)];
        let mut maps: Vec<String> = known.iter().filter_map(|(k, v)| v.as_ref().map(|v| format!("{k} {v}"))).collect();
        let mut other: Vec<String> = m
            .unknown_param
            .iter()
            .filter(|(k, _)| (k.starts_with("map_") && k.as_str() != "map_Ke") || matches!(k.as_str(), "disp" | "decal" | "refl"))
            .map(|(k, v)| format!("{k} {v}"))
            .collect();
        other.sort();
        maps.extend(other);
        if maps.is_empty() {
            continue;
        }
        warned += 1;
        if warned <= MAX_MAP_WARNINGS {
            ctx.warn(SceneError::in_file(
                file,
                None,
                format!("material \"{}\": texture maps raylab does not sample, ignored: {}", m.name, maps.join(", ")),
            ));
        }
    }
    if warned > MAX_MAP_WARNINGS {
        ctx.warn(SceneError::in_file(file, None, format!("{} more materials name texture maps, ignored too", warned - MAX_MAP_WARNINGS)));
    }
}

/// The first face corner that is not a number or refers to a vertex, texture coordinate or normal
/// the file does not define (a relative index: not defined before it), located. Only run when the
/// pass over the file found such a corner.
fn scan(name: &str, text: &str) -> Option<SceneError> {
    let mut total = [0i64; 3];
    for line in text.lines() {
        match Words::new(line).next() {
            Some("v") => total[0] += 1,
            Some("vt") => total[1] += 1,
            Some("vn") => total[2] += 1,
            _ => {}
        }
    }
    let mut count = [0i64; 3];
    for (i, line) in text.lines().enumerate() {
        let mut words = Words::new(line);
        let Some(key) = words.next() else { continue };
        let at = |msg: String| SceneError::in_file(name, Some((i + 1, line.find(key).unwrap_or(0) + 1)), msg);
        match key {
            "v" => count[0] += 1,
            "vt" => count[1] += 1,
            "vn" => count[2] += 1,
            "f" => {
                for corner in words {
                    let malformed = || at(format!("malformed face corner \"{corner}\": expected v, v/vt, v//vn or v/vt/vn indices"));
                    let parts: Vec<&str> = corner.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Some(malformed());
                    }
                    for (kind, s) in parts.iter().enumerate() {
                        let what = ["vertex", "texture coordinate", "normal"][kind];
                        if s.is_empty() {
                            continue;
                        }
                        let Some(k) = parse_i64(s.as_bytes()) else { return Some(malformed()) };
                        // A file without texture coordinates (or normals) may still name them;
                        // raylab ignores such references.
                        if kind > 0 && total[kind] == 0 {
                            continue;
                        }
                        // Relative (negative) indices count back from this line; positive ones may
                        // refer ahead, to anything the file defines.
                        let (resolved, defined, place) =
                            if k < 0 { (count[kind] + k + 1, count[kind], "before this line") } else { (k, total[kind], "in the file") };
                        if !(1..=defined).contains(&resolved) {
                            return Some(at(format!(
                                "face corner \"{corner}\" refers to {what} {k}, but only {defined} are defined {place} (indices start at 1)"
                            )));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

/// A decimal integer with an optional sign, as `str::parse::<i64>` reads it; `None` otherwise.
fn parse_i64(s: &[u8]) -> Option<i64> {
    let (neg, digits) = match s {
        [b'-', d @ ..] => (true, d),
        [b'+', d @ ..] => (false, d),
        d => (false, d),
    };
    if digits.is_empty() {
        return None;
    }
    let mut v: i64 = 0;
    for &b in digits {
        if !b.is_ascii_digit() {
            return None;
        }
        // Accumulated negatively so that i64::MIN parses, as in `str::parse`.
        v = v.checked_mul(10)?.checked_sub(i64::from(b - b'0'))?;
    }
    if neg { Some(v) } else { v.checked_neg() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn here() -> Loc {
        Loc::new(&raylab::param::error::Source::new("scene.toml", "file = \"m.obj\""), 7..14)
    }

    /// A fresh folder under the system's temporary one holding `files`.
    fn folder(name: &str, files: &[(&str, &[u8])]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("raylab-obj-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for (f, bytes) in files {
            std::fs::write(dir.join(f), bytes).unwrap();
        }
        dir
    }

    /// 10⁶ `mtllib` lines (each once took a read and a merge of the library: 20–50 s at 10⁵)
    /// load the library once: each material once, one warning about the maps raylab does not
    /// sample, and one about each sampled map whose file is missing.
    #[test]
    fn a_million_mtllib_lines_read_the_library_once() {
        let mtl = b"newmtl wood\nKd 0.5 0.25 0.125\nmap_Kd wood.png\nmap_Ka wood-a.png\nmap_Ke glow.png\nnewmtl plain\nKd 1 1 1\n";
        let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
        for i in 0..1_000_000 {
            obj.push_str(if i % 2 == 0 { "mtllib m.mtl\n" } else { "mtllib ./m.mtl\n" });
        }
        obj.push_str("usemtl wood\nf 1 2 3\n");
        let dir = folder("mtllib", &[("m.mtl", mtl), ("m.obj", obj.as_bytes())]);
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        let data = read(&ctx, "m.obj", &dir.join("m.obj"), obj.as_bytes(), true, &here()).unwrap();
        assert_eq!(data.materials.len(), 2, "each material once");
        assert!(data.material_ids.iter().all(|&m| m == 0), "{:?}", data.material_ids);
        assert_eq!(data.materials[0].kd, DVec3::new(0.5, 0.25, 0.125));
        let warnings: Vec<String> = ctx.take_warnings().iter().map(|w| w.report()).collect();
        assert_eq!(warnings.len(), 3, "{warnings:?}");
        for part in ["m.mtl", "\"wood\"", "map_Ka wood-a.png"] {
            assert!(warnings[0].contains(part), "{part} not in {}", warnings[0]);
        }
        assert!(!warnings[0].contains("map_Kd") && !warnings[0].contains("map_Ke"), "sampled maps are not ignored: {}", warnings[0]);
        assert!(warnings[1].contains("map_Kd wood.png") && warnings[1].contains("not sampled"), "{}", warnings[1]);
        assert!(warnings[2].contains("map_Ke glow.png"), "{}", warnings[2]);
        // A library that is missing is reported once, however often it is named.
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nmtllib gone.mtl\nmtllib gone.mtl\nf 1 2 3\n";
        let e = read(&ctx, "m.obj", &dir.join("m.obj"), obj.as_bytes(), true, &here()).unwrap_err();
        assert!(e.report().contains("gone.mtl"), "{}", e.report());
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// `usemtl` statements are kept until the chunks are joined: they are charged to the memory
    /// limit first, so a file of nothing else is refused before they are read.
    #[test]
    fn material_statements_are_charged_before_they_are_read() {
        let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        for _ in 0..200_000 {
            obj.push_str("usemtl a\n");
        }
        obj.push_str(" mtllib m.mtl\n\x0cusemtl b\n");
        let limits = raylab::param::limits::Limits { max_memory: 1 << 20, ..Default::default() };
        let options = raylab::load::context::LoadOptions { limits, ..Default::default() };
        let ctx = LoadContext::new(Path::new("."), &options);
        let e = read(&ctx, "m.obj", Path::new("m.obj"), obj.as_bytes(), false, &here()).unwrap_err().report();
        assert!(e.contains("200002 `usemtl` and `mtllib` statements") && e.contains("--max-memory"), "{e}");
        assert_eq!(ctx.charged(), 0, "nothing counted");
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(Path::new("."), &options);
        read(&ctx, "m.obj", Path::new("m.obj"), obj.as_bytes(), false, &here()).unwrap();
        assert_eq!(ctx.charged(), 200_002 * EVENT_BYTES);
    }

    /// Polygons deferred to the end of the file, thousands of them (several parallel runs)
    /// between triangles and concave faces, with texture coordinates and normals, and some
    /// referring ahead: read in chunks, they give what the whole file read as one chunk gives
    /// (where most are triangulated in place), and each lands where its face was.
    #[test]
    fn many_deferred_polygons_keep_their_places() {
        let n = 80;
        let corner = |i: usize, j: usize| j * (n + 1) + i + 1;
        let mut text = String::new();
        let vertex = |text: &mut String, k: usize| {
            let (i, j) = ((k - 1) % (n + 1), (k - 1) / (n + 1));
            text.push_str(&format!("v {i} {j} {}\nvt {i} {j}\nvn 0 0 1\n", (i * j) % 3));
        };
        let half = (n + 1) * (n / 2);
        for k in 1..=half {
            vertex(&mut text, k);
        }
        for j in 0..n {
            for i in 0..n {
                let [a, b, c, d] = [corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1)];
                let f = |v: &[usize]| v.iter().map(|k| format!(" {k}/{k}/{k}")).collect::<String>();
                text.push_str(&match (i + j) % 5 {
                    0 => format!("f{}\nf{}\n", f(&[a, b, c]), f(&[a, c, d])),
                    1 => format!("f{}\n", f(&[a, b, c, a, d])),
                    _ => format!("f{}\n", f(&[a, b, c, d])),
                });
            }
            if j == n / 2 + 2 {
                for k in half + 1..=(n + 1) * (n + 1) {
                    vertex(&mut text, k);
                }
            }
        }
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(Path::new("."), &options);
        let read = |chunk: usize| {
            let d = read_in_chunks(&ctx, "m.obj", Path::new("m.obj"), text.as_bytes(), false, &here(), chunk).unwrap();
            (format!("{d:?}"), d.triangles.len(), d.normal_indices.len(), d.texcoord_indices.len())
        };
        let whole = read(usize::MAX);
        assert!(whole.1 > 2 * n * n && whole.1 == whole.2 && whole.1 == whole.3, "{:?}", (whole.1, whole.2, whole.3));
        for chunk in [1 << 10, 1 << 14, 1 << 17] {
            assert!(read(chunk) == whole, "chunks of {chunk} bytes");
        }
        assert!(ctx.take_warnings().is_empty());
    }

    /// A byte-order mark does not hide the first line, and a quad whose corners are all read is
    /// triangulated in place (only faces that refer ahead wait for the end of the file).
    #[test]
    fn a_byte_order_mark_keeps_the_first_vertex_and_quads_come_in_file_order() {
        let obj = "\u{feff}v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 2 5\nf 1 2 3 5\nv 0 0 1\n";
        let dir = folder("bom", &[("m.obj", obj.as_bytes())]);
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        let data = read(&ctx, "m.obj", &dir.join("m.obj"), obj.as_bytes(), false, &here()).unwrap();
        assert_eq!(data.positions.len(), 5, "the first line is a vertex");
        assert_eq!(data.triangles.len(), 5);
        assert_eq!(data.triangles[2], [0, 1, 4], "the triangle after the first quad");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Materials with texture maps beyond [`MAX_MAP_WARNINGS`] are counted, not listed.
    #[test]
    fn texture_map_warnings_are_bounded_per_library() {
        let mtl: String = (0..100).map(|i| format!("newmtl m{i}\nmap_Ns t.png\n")).collect();
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m3\nf 1 2 3\n";
        let dir = folder("maps", &[("m.mtl", mtl.as_bytes())]);
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        read(&ctx, "m.obj", &dir.join("m.obj"), obj.as_bytes(), true, &here()).unwrap();
        let warnings: Vec<String> = ctx.take_warnings().iter().map(|w| w.report()).collect();
        assert_eq!(warnings.len(), MAX_MAP_WARNINGS + 1, "{warnings:?}");
        assert!(warnings[MAX_MAP_WARNINGS].contains(&format!("{} more materials", 100 - MAX_MAP_WARNINGS)));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The one pass over the file and the scan that locates its errors agree: the fuzz corpus
    /// (every OBJ that once failed) and hand-made cases either load, or fail with the scan's error
    /// when the scan finds one; and references ahead, relative references and polygons whose
    /// corners come later load as the file means.
    #[test]
    fn the_pass_and_the_scan_agree() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus/mesh_obj");
        let mut texts: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| std::fs::read(e.unwrap().path()).ok())
            .filter_map(|b| String::from_utf8(b).ok())
            .collect();
        assert!(texts.len() >= 20, "corpus too small");
        let cases = [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -3\n",
            "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n",
            "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/9 2/9 3/9\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/-1 2/-1 3/-1\nvt 0 0\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 +3\r\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967297\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/2/3/4 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n\u{a0}f 1 2 4\n",
            "v 0 0 0\nv 1 0 0\nf 1 2 3 4\nv 1 1 0\nv 0 1 0\n",
        ];
        texts.extend(cases.iter().map(|c| c.to_string()));
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(Path::new("."), &options);
        for t in &texts {
            let read = read(&ctx, "t.obj", Path::new("t.obj"), t.as_bytes(), false, &here());
            if let Some(e) = scan("t.obj", t) {
                assert_eq!(read.err().map(|r| r.report()), Some(e.report()), "{t}");
            }
        }
        // Forward and relative references, and a quad whose last corners come after it.
        let data = read(&ctx, "t.obj", Path::new("t.obj"), cases[4].as_bytes(), false, &here()).unwrap();
        assert_eq!(data.triangles, vec![[0, 1, 2]]);
        let data = read(&ctx, "t.obj", Path::new("t.obj"), cases[2].as_bytes(), false, &here()).unwrap();
        assert_eq!(data.triangles, vec![[2, 1, 0]]);
        let data = read(&ctx, "t.obj", Path::new("t.obj"), cases[15].as_bytes(), false, &here()).unwrap();
        assert_eq!(data.triangles.len(), 2);
        assert!(data.triangles.iter().flatten().all(|&v| v < 4));
        // A texture reference in a file without texture coordinates is ignored; with one, a
        // relative reference before it is an error.
        assert!(read(&ctx, "t.obj", Path::new("t.obj"), cases[6].as_bytes(), false, &here()).is_ok());
        assert!(read(&ctx, "t.obj", Path::new("t.obj"), cases[7].as_bytes(), false, &here()).is_err());
        for t in ["0", "-0", "+7", "-9223372036854775808", "9223372036854775807", "9223372036854775808", "-", "+", "", "1x", "--1", " 1"] {
            assert_eq!(parse_i64(t.as_bytes()), t.parse::<i64>().ok(), "{t:?}");
        }
    }

    /// Read in chunks of any size, down to a line each, a file gives what it gives read whole:
    /// relative indices, polygons and `usemtl` across chunk ends, the warnings, and errors located
    /// on a later chunk's line; the fuzz corpus likewise.
    #[test]
    fn texture_coordinates_defined_after_the_faces_that_use_them_are_a_warning() {
        let dir = folder("vt-after", &[]);
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1 2/2/1 3/3/1\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\n";
        let data = read(&ctx, "m.obj", &dir.join("m.obj"), text.as_bytes(), false, &here()).unwrap();
        assert_eq!(data.triangles.len(), 2);
        let warnings: Vec<String> = ctx.take_warnings().iter().map(|w| w.report()).collect();
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        for (w, what) in warnings.iter().zip(["texture coordinates (`vt`)", "normals (`vn`)"]) {
            assert!(w.contains("m.obj:4:1") && w.contains(what), "{w}");
        }
        // A file without any is read without them, silently.
        read(&ctx, "m.obj", &dir.join("m.obj"), b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1 2/2/1 3/3/1\n", false, &here()).unwrap();
        assert!(ctx.take_warnings().is_empty());
    }

    #[test]
    fn chunks_read_as_the_whole_file() {
        let mtl = "newmtl red\nKd 1 0 0\nmap_Ks gone.png\nnewmtl blue\nKd 0 0 1\n";
        let good = [
            "# quads, relative corners, materials",
            "mtllib m.mtl",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0",
            "vt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1",
            "usemtl red",
            "f 1/1/1 2/2/1 3/3/1",
            "f -4/-3/-1 -3/-2/-1 -1/-1/-1",
            "v 0 0 1",
            "usemtl blue",
            "f -1/1/1 1/2/1 2/3/1 4/1/1",
            "f 1/1/1 2/2/1 6/3/1 5/1/1",
            "v 1 0 1",
            "f 2/1/1 3/2/1 4/3/1 -2/1/1 -1/2/-1",
            "usemtl nothing",
            "f 1/1/1 3/1/1 6/1/1",
        ]
        .join("\n");
        let lines = |text: &str, n: usize| text.lines().nth(n - 1).unwrap().to_string();
        let bad_vertex = format!("{good}\nv 1 2\n");
        let bad_face = format!("{good}\nf 1 2 -7\n");
        let bad_ahead = format!("{good}\nf 1 2 70\n");
        let non_finite = format!("{good}\nv 1 inf 2\n");
        let dir = folder("chunks", &[("m.mtl", mtl.as_bytes())]);
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        let read = |text: &str, chunk: usize| {
            let r = read_in_chunks(&ctx, "m.obj", &dir.join("m.obj"), text.as_bytes(), true, &here(), chunk);
            let warnings: Vec<String> = ctx.take_warnings().iter().map(|w| w.report()).collect();
            (r.map(|d| format!("{d:?}")).map_err(|e| e.report()), warnings)
        };
        let whole = read(&good, usize::MAX);
        let data = whole.0.clone().unwrap();
        assert!(data.contains("material_ids: [0, 0, 1, 1, 1, 1, 1, 1, 1, 0]"), "{data}");
        assert_eq!(whole.1.len(), 1, "the missing map: {:?}", whole.1);
        for (text, line) in [(&bad_vertex, 22), (&bad_face, 22), (&bad_ahead, 22), (&non_finite, 22)] {
            let e = read(text, usize::MAX).0.unwrap_err();
            assert!(e.contains(&format!(":{line}:")), "{} at line {line}: {e}", lines(text, line));
        }
        for text in [&good, &bad_vertex, &bad_face, &bad_ahead, &non_finite] {
            let whole = read(text, usize::MAX);
            for chunk in [0, 1, 9, 20, 64, 100] {
                assert_eq!(read(text, chunk), whole, "chunks of {chunk} bytes:\n{text}");
            }
        }
        let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus/mesh_obj");
        for file in std::fs::read_dir(corpus).unwrap() {
            let bytes = std::fs::read(file.unwrap().path()).unwrap();
            let Ok(text) = String::from_utf8(bytes) else { continue };
            let whole = read(&text, usize::MAX);
            for chunk in [0, 100, 4096] {
                assert_eq!(read(&text, chunk), whole, "chunks of {chunk} bytes");
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A texture statement's options place the map (`-s`, then `-o`) or clamp it; the rest of the
    /// line, spaces and all, is the file; options raylab does not apply are named.
    #[test]
    fn map_statements_read_their_options_and_file() {
        let m = MapStatement::parse("-s 2 3 -o 0.5 -clamp on -bm 0.4 my wood.png");
        assert_eq!(m.file.as_deref(), Some("my wood.png"));
        assert!(m.clamp);
        assert!(m.ignored.is_empty(), "{:?}", m.ignored);
        assert_eq!(m.bm, 0.4);
        assert_eq!(MapStatement::parse("-bm x.png").bm, 1.0, "no number: the default");
        let p = m.lookup.transform_point3(DVec3::new(0.25, 0.5, 0.0));
        assert_eq!(p, DVec3::new(1.0, 1.5, 0.0), "scaled by (2, 3), then offset by 0.5 in u");
        assert_eq!(MapStatement::parse("plain.png").lookup, DAffine3::IDENTITY);
        assert_eq!(MapStatement::parse("-clamp off").file, None);
    }

    /// `vt` and `map_Kd`: the faces keep their texture coordinates (v up) and the material its
    /// map, which reads the image (relative to the MTL's folder) through the sandbox.
    #[test]
    fn texture_coordinates_and_the_diffuse_map_are_read() {
        let png = {
            let mut out = Vec::new();
            image::ImageEncoder::write_image(
                image::codecs::png::PngEncoder::new(&mut out),
                &[255, 0, 0, 0, 0, 255],
                2,
                1,
                image::ExtendedColorType::Rgb8,
            )
            .unwrap();
            out
        };
        let obj = "mtllib lib/m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.5\nvt 0.75 0.5\nvt 0.25 1\nusemtl red\nf 1/1 2/2 3/3\n";
        let dir = folder("vt", &[("m.obj", obj.as_bytes())]);
        std::fs::create_dir_all(dir.join("lib")).unwrap();
        std::fs::write(dir.join("lib/m.mtl"), "newmtl red\nKd 0.5 0.5 0.5\nmap_Kd -s 1 1 tex.png\n").unwrap();
        std::fs::write(dir.join("lib/tex.png"), png).unwrap();
        let options = raylab::load::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        let data = read(&ctx, "m.obj", &dir.join("m.obj"), obj.as_bytes(), true, &here()).unwrap();
        assert!(ctx.take_warnings().is_empty());
        assert_eq!((data.texcoords.len(), data.texcoord_indices), (3, vec![[0, 1, 2]]));
        assert_eq!(data.texcoords[1], [0.75, 0.5]);
        let m = &data.materials[0];
        assert_eq!((m.kd, m.textures.len(), m.textures[0].channel), (DVec3::splat(0.5), 1, Channel::Kd));
        let at =
            |u: f64| m.textures[0].texture.eval(&raylab::scene::texture::TexturePoint::new(raylab::glam::DVec2::new(u, 0.5), DVec3::ZERO));
        assert_eq!((at(0.25), at(0.75)), (DVec3::X, DVec3::Z), "left texel red, right blue");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
