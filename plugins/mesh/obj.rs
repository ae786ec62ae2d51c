//! Wavefront OBJ and MTL files, read by tobj.
//!
//! Faces with more than three corners are triangulated by raylab ([`super::triangulate`]: fans
//! for convex faces, ear clipping for concave ones); points and lines are ignored. Vertex normals
//! (`vn`) are used for smooth shading when every face of a group has them. The MTL library is
//! read relative to the OBJ file, through the scene's folder sandbox and size limit, once
//! however often the file names it.
//!
//! MTL → raylab material:
//!
//! | MTL | raylab | note |
//! |---|---|---|
//! | `Kd` | `kd` | scaled by the dissolve `d` |
//! | `Ks` | `ks` | also `kr` (mirror) under `illum` 3, 5 and 7 |
//! | `Ns` | `shininess` | the Phong exponent |
//! | `d`, `Tr` (= 1 − d) | `kt = 1 − d` | transparency; `Tf` is ignored |
//! | `Ni` | `ior` | values ≤ 0 keep the default 1.5 |
//! | `Ke` | `emission` | |
//! | `Ka` | — | ignored: exporters write it inconsistently; `ka` keeps its default |
//! | `map_Kd`, `map_Ks`, `map_Ke` | textures multiplying `kd`, `ks`, `emission` | sRGB images, over the file's `vt`; options `-o` and `-s` (offset and scale of the texture coordinates) and `-clamp on`; others ignored with a warning |
//! | `bump`, `map_d`, … | — | other maps: ignored with a warning per material |
//!
//! Texture files are read relative to their MTL file, through the sandbox, once per scene, and
//! only for materials some face uses; one that cannot be read is a warning (the constant colour
//! is used).
//!
//! tobj reports errors without a line number; raylab then finds the offending line itself, so
//! every error names `file:line:col`.

use super::triangle_mesh::MeshData;
use super::triangulate::triangulate;
use crate::textures::image::{self as image_texture, ColorSpace, Filter, ImageTexture, Wrap};
use raylab::glam::{DAffine3, DVec3, Vec3};
use raylab::input::error::{Loc, Result, SceneError};
use raylab::scene::material::{Channel, TextureMap};
use raylab::scene::texture::{Coords, Mapping};
use raylab::{Color, LoadContext, Material};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Reads the OBJ file `bytes` (named `path` in the scene, resolved to `full`), with its MTL
/// library unless `need_materials` is false.
pub fn read(ctx: &LoadContext, path: &str, full: &Path, bytes: &[u8], need_materials: bool, loc: &Loc) -> Result<MeshData> {
    let name = full.display().to_string();
    let text = text_of(bytes, &name)?;
    let opts = tobj::LoadOptions { triangulate: false, single_index: false, ignore_points: true, ignore_lines: true };
    let mtl_error: RefCell<Option<SceneError>> = RefCell::new(None);
    let base = Path::new(path).parent().map(Path::to_path_buf).unwrap_or_default();
    // Each distinct library is read once, however often and however spelled the file names it:
    // by the name as written, then by the file it resolves to. tobj appends what the loader
    // returns at every `mtllib` line, so a repeat returns nothing (its materials are known).
    let seen_names: RefCell<HashMap<String, bool>> = RefCell::new(HashMap::new());
    let seen_files: RefCell<HashMap<PathBuf, bool>> = RefCell::new(HashMap::new());
    // The folder (relative to the scene) of the library that defined each material, for its maps.
    let folders: RefCell<HashMap<String, PathBuf>> = RefCell::new(HashMap::new());
    let repeat =
        |ok: bool| -> tobj::MTLLoadResult { if ok { Ok((Vec::new(), Default::default())) } else { Err(tobj::LoadError::OpenFileFailed) } };
    let load_mtl = |mtl: &Path| -> tobj::MTLLoadResult {
        if !need_materials {
            return Err(tobj::LoadError::GenericFailure);
        }
        let rel: PathBuf = base.join(mtl);
        let rel = rel.to_string_lossy().into_owned();
        if let Some(&ok) = seen_names.borrow().get(&rel) {
            return repeat(ok);
        }
        let file = ctx.resolve_path(&rel, loc).map(|f| f.canonicalize().unwrap_or(f));
        if let Some(&ok) = file.as_ref().ok().and_then(|f| seen_files.borrow().get(f).copied()).as_ref() {
            seen_names.borrow_mut().insert(rel, ok);
            return repeat(ok);
        }
        let result = match ctx.read_file(&rel, loc) {
            Ok((_, data)) => match tobj::load_mtl_buf(&mut data.as_slice()) {
                Ok(r) => {
                    warn_ignored_maps(ctx, &rel, &r.0);
                    let folder = Path::new(&rel).parent().map(Path::to_path_buf).unwrap_or_default();
                    for m in &r.0 {
                        folders.borrow_mut().entry(m.name.clone()).or_insert_with(|| folder.clone());
                    }
                    Ok(r)
                }
                Err(e) => {
                    mtl_error.borrow_mut().get_or_insert(SceneError::in_file(&rel, None, format!("cannot read the material library: {e}")));
                    Err(e)
                }
            },
            Err(e) => {
                mtl_error.borrow_mut().get_or_insert(e);
                Err(tobj::LoadError::OpenFileFailed)
            }
        };
        if let Ok(f) = file {
            seen_files.borrow_mut().insert(f, result.is_ok());
        }
        seen_names.borrow_mut().insert(rel, result.is_ok());
        result
    };
    if !indices_certainly_valid(text.as_bytes())
        && let Some(e) = scan(&name, text, None)
    {
        return Err(e);
    }
    let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| tobj::load_obj_buf(&mut text.as_bytes(), &opts, load_mtl)));
    let (models, materials) = match parsed {
        Ok(Ok(r)) => r,
        Ok(Err(e)) => return Err(located(&name, text, &e)),
        Err(_) => return Err(SceneError::in_file(&name, None, "the OBJ reader failed on this file (it is malformed)")),
    };
    let library = match materials {
        Ok(m) => m,
        Err(_) if !need_materials => Vec::new(),
        Err(_) => match mtl_error.into_inner() {
            Some(e) => {
                return Err(e
                    .context(format!("{name}: its material library"))
                    .with_help("fix or add the .mtl file, or give the object a `material` to render without the file's materials"));
            }
            None => Vec::new(), // no `mtllib` line: the default material
        },
    };
    let materials = library.iter().map(material).collect();
    let mut out = MeshData { materials, ..MeshData::default() };
    let mut any_normals = true;
    let mut any_texcoords = true;
    for model in &models {
        let m = &model.mesh;
        let base_vertex = out.positions.len() as u32;
        out.positions.extend(m.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        let has_normals = !m.normals.is_empty() && m.normal_indices.len() == m.indices.len();
        any_normals &= has_normals;
        let base_normal = out.normals.len() as u32;
        if has_normals {
            out.normals.extend(m.normals.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        }
        let has_texcoords = !m.texcoords.is_empty() && m.texcoord_indices.len() == m.indices.len();
        any_texcoords &= has_texcoords;
        let base_texcoord = out.texcoords.len() as u32;
        if has_texcoords {
            out.texcoords.extend(m.texcoords.chunks_exact(2).map(|c| [c[0], c[1]]));
        }
        let material = m.material_id.map_or(0, |i| i as u32);
        // Corners of each face, then its triangles.
        let arities: Vec<u32> = if m.face_arities.is_empty() { vec![3; m.indices.len() / 3] } else { m.face_arities.clone() };
        let mut start = 0usize;
        for &k in &arities {
            let k = k as usize;
            let Some(corners) = m.indices.get(start..start + k) else { break };
            let position = |i: u32| {
                let p = m.positions.get(3 * i as usize..3 * i as usize + 3).unwrap_or(&[0.0; 3]);
                Vec3::new(p[0], p[1], p[2]).as_dvec3()
            };
            let tris = if k == 3 { vec![[0, 1, 2]] } else { triangulate(&corners.iter().map(|&i| position(i)).collect::<Vec<DVec3>>()) };
            for t in tris {
                out.triangles.push(t.map(|c| base_vertex + corners[c as usize]));
                if has_normals {
                    out.normal_indices.push(t.map(|c| base_normal + m.normal_indices[start + c as usize]));
                }
                if has_texcoords {
                    out.texcoord_indices.push(t.map(|c| base_texcoord + m.texcoord_indices[start + c as usize]));
                }
                out.material_ids.push(material);
            }
            start += k;
        }
    }
    if !any_normals {
        out.normals.clear();
        out.normal_indices.clear();
    }
    if !any_texcoords {
        out.texcoords.clear();
        out.texcoord_indices.clear();
    }
    if out.triangles.is_empty() {
        return Err(SceneError::in_file(&name, None, "the file has no faces with three or more corners (points and lines are ignored)"));
    }
    // Texture maps, for the materials faces use.
    let mut used = out.material_ids.clone();
    used.sort_unstable();
    used.dedup();
    let folders = folders.into_inner();
    for id in used {
        let (Some(m), Some(out_m)) = (library.get(id as usize), out.materials.get_mut(id as usize)) else { continue };
        let folder = folders.get(&m.name).cloned().unwrap_or_default();
        attach_maps(ctx, m, &folder, loc, out_m);
    }
    Ok(out)
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
/// the textures of its `map_Kd`, `map_Ks` and `map_Ke`; a map that cannot be read, and options
/// raylab ignores, are warnings.
fn attach_maps(ctx: &LoadContext, m: &tobj::Material, folder: &Path, loc: &Loc, out: &mut Material) {
    for (key, statement, channel) in sampled_maps(m) {
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
        match image_texture::load(ctx, &path.to_string_lossy(), loc, ColorSpace::Srgb) {
            Ok(image) => {
                let wrap = if map.clamp { Wrap::Clamp } else { Wrap::Repeat };
                let mapping = Mapping::with_inverse(Coords::Uv, map.lookup);
                let texture = std::sync::Arc::new(ImageTexture::new(image, mapping, [wrap; 2], Filter::Bilinear, Color::ONE));
                out.textures.push(TextureMap { channel, texture });
            }
            Err(e) => ctx.warn(e.context(format!("{} is not sampled (the constant colour is used)", what()))),
        }
    }
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
    /// Options raylab ignores, as written.
    ignored: Vec<String>,
}

impl MapStatement {
    fn parse(text: &str) -> MapStatement {
        let words: Vec<&str> = text.split_whitespace().collect();
        let (mut offset, mut scale) = (DVec3::ZERO, DVec3::ONE);
        let (mut clamp, mut ignored) = (false, Vec::new());
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
                "-mm" => {
                    numbers(2);
                    ignored.push(option.to_string());
                }
                "-t" => {
                    numbers(3);
                    ignored.push(option.to_string());
                }
                _ => {
                    // -blendu, -blendv, -bm, -boost, -cc, -imfchan, -texres, -type: one value.
                    i += 1;
                    ignored.push(option.to_string());
                }
            }
        }
        let file = (i < words.len()).then(|| words[i..].join(" "));
        let lookup = DAffine3::from_translation(offset) * DAffine3::from_scale(scale);
        MapStatement { file, lookup, clamp, ignored }
    }
}

/// The file as UTF-8 text, or an error naming the first bad line.
fn text_of<'a>(bytes: &'a [u8], name: &str) -> Result<&'a str> {
    if bytes.starts_with(&[0xFE, 0xFF]) || bytes.starts_with(&[0xFF, 0xFE]) {
        return Err(SceneError::in_file(name, Some((1, 1)), "the file is UTF-16 text; OBJ files must be ASCII or UTF-8"));
    }
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
    let d = f64::from(m.dissolve.unwrap_or(1.0)).clamp(0.0, 1.0);
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

/// Most materials of one MTL library warned about by name for their ignored texture maps; the
/// rest are counted in one more warning.
pub const MAX_MAP_WARNINGS: usize = 8;

/// Warns, once per material of the library `file`, about the texture maps it names that raylab
/// does not sample (all but `map_Kd`, `map_Ks` and `map_Ke`).
fn warn_ignored_maps(ctx: &LoadContext, file: &str, materials: &[tobj::Material]) {
    let mut warned = 0;
    for m in materials {
        let known =
            [("map_Ka", &m.ambient_texture), ("map_Ns", &m.shininess_texture), ("bump", &m.normal_texture), ("map_d", &m.dissolve_texture)];
        let mut maps: Vec<String> = known.iter().filter_map(|(k, v)| v.as_ref().map(|v| format!("{k} {v}"))).collect();
        let mut other: Vec<String> = m
            .unknown_param
            .iter()
            .filter(|(k, _)| (k.starts_with("map_") && k.as_str() != "map_Ke") || matches!(k.as_str(), "disp" | "decal" | "refl" | "norm"))
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

/// A tobj error with the line it is about, found by scanning the file the way tobj reads it.
fn located(name: &str, text: &str, e: &tobj::LoadError) -> SceneError {
    scan(name, text, Some(e)).unwrap_or_else(|| SceneError::in_file(name, None, format!("malformed OBJ file: {e}")))
}

/// The first face corner that is not a number or refers to a vertex, texture coordinate or normal
/// the file does not define (a relative index: not defined before it), and, when tobj reported a
/// parse error `e`, the first line of that kind that does not parse. Run before tobj too: it
/// overflows on such indices.
fn scan(name: &str, text: &str, e: Option<&tobj::LoadError>) -> Option<SceneError> {
    use tobj::LoadError as E;
    let mut total = [0i64; 3];
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => total[0] += 1,
            Some("vt") => total[1] += 1,
            Some("vn") => total[2] += 1,
            _ => {}
        }
    }
    let (mut v, mut vt, mut vn) = (0i64, 0i64, 0i64);
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let at = |msg: String| SceneError::in_file(name, Some((i + 1, line.find(key).unwrap_or(0) + 1)), msg);
        let numbers = |n: usize| words.clone().take(n).all(|w| w.parse::<f32>().is_ok()) && words.clone().count() >= n;
        match key {
            "v" => {
                if matches!(e, Some(E::PositionParseError)) && !numbers(3) {
                    return Some(at("expected a vertex `v x y z` with three numbers".into()));
                }
                v += 1;
            }
            "vt" => {
                if matches!(e, Some(E::TexcoordParseError)) && !numbers(1) {
                    return Some(at("expected a texture coordinate `vt u [v]`".into()));
                }
                vt += 1;
            }
            "vn" => {
                if matches!(e, Some(E::NormalParseError)) && !numbers(3) {
                    return Some(at("expected a normal `vn x y z` with three numbers".into()));
                }
                vn += 1;
            }
            "f" => {
                for corner in words {
                    let mut parts = corner.split('/');
                    for (i_what, (slot, count, what)) in
                        [(parts.next(), v, "vertex"), (parts.next(), vt, "texture coordinate"), (parts.next(), vn, "normal")]
                            .into_iter()
                            .enumerate()
                    {
                        let Some(s) = slot.filter(|s| !s.is_empty()) else { continue };
                        // A file without texture coordinates (or normals) may still name them;
                        // tobj ignores such references, and so does raylab.
                        if i_what > 0 && total[i_what] == 0 {
                            continue;
                        }
                        let Ok(k) = s.parse::<i64>() else {
                            return Some(at(format!("malformed face corner \"{corner}\": expected v, v/vt, v//vn or v/vt/vn indices")));
                        };
                        // Relative (negative) indices count back from this line; positive ones may
                        // refer ahead, as tobj resolves them once the whole file is read.
                        let (resolved, defined, place) =
                            if k < 0 { (count + k + 1, count, "before this line") } else { (k, total[i_what], "in the file") };
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

/// The fast check [`scan`] makes before tobj runs, on bytes: true when every face corner is an
/// integer naming a vertex, texture coordinate or normal the file defines (relative indices:
/// before its line), so [`scan`] would find nothing. False when one does not, or when the file
/// is not ASCII (whose Unicode whitespace only [`scan`] splits like tobj): then [`scan`] decides.
fn indices_certainly_valid(bytes: &[u8]) -> bool {
    if !bytes.is_ascii() {
        return false;
    }
    let mut total = [0i64; 3];
    for line in bytes.split(|&b| b == b'\n') {
        if let k @ 1..=3 = keyword(line).0 {
            total[k - 1] += 1;
        }
    }
    let mut count = [0i64; 3];
    for line in bytes.split(|&b| b == b'\n') {
        match keyword(line) {
            (k @ 1..=3, _) => count[k - 1] += 1,
            (4, rest) => {
                for corner in rest.split(|b| b.is_ascii_whitespace()).filter(|w| !w.is_empty()) {
                    for (kind, part) in corner.split(|&b| b == b'/').take(3).enumerate() {
                        if part.is_empty() || (kind > 0 && total[kind] == 0) {
                            continue;
                        }
                        let Some(k) = parse_i64(part) else { return false };
                        let (resolved, defined) = if k < 0 { (count[kind] + k + 1, count[kind]) } else { (k, total[kind]) };
                        if !(1..=defined).contains(&resolved) {
                            return false;
                        }
                    }
                }
            }
            _ => {}
        }
    }
    true
}

/// A line's first word as 1 (`v`), 2 (`vt`), 3 (`vn`), 4 (`f`) or 0 (anything else), and the rest
/// of the line.
fn keyword(line: &[u8]) -> (usize, &[u8]) {
    let start = line.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(line.len());
    let line = &line[start..];
    let end = line.iter().position(|b| b.is_ascii_whitespace()).unwrap_or(line.len());
    let kind = match &line[..end] {
        b"v" => 1,
        b"vt" => 2,
        b"vn" => 3,
        b"f" => 4,
        _ => 0,
    };
    (kind, &line[end..])
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

/// The first `v` line with a non-finite coordinate, for the error about it.
pub fn non_finite_line(bytes: &[u8]) -> Option<(usize, usize)> {
    let text = std::str::from_utf8(bytes).ok()?;
    text.lines().enumerate().find_map(|(i, l)| {
        let mut w = l.split_whitespace();
        (w.next() == Some("v") && w.take(3).any(|x| x.parse::<f32>().is_ok_and(|f| !f.is_finite()))).then_some((i + 1, 1))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn here() -> Loc {
        Loc::new(&raylab::input::error::Source::new("scene.toml", "file = \"m.obj\""), 7..14)
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
        let mtl = b"newmtl wood\nKd 0.5 0.25 0.125\nmap_Kd wood.png\nbump wood-n.png\nmap_Ke glow.png\nnewmtl plain\nKd 1 1 1\n";
        let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
        for i in 0..1_000_000 {
            obj.push_str(if i % 2 == 0 { "mtllib m.mtl\n" } else { "mtllib ./m.mtl\n" });
        }
        obj.push_str("usemtl wood\nf 1 2 3\n");
        let dir = folder("mtllib", &[("m.mtl", mtl), ("m.obj", obj.as_bytes())]);
        let options = raylab::input::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        let data = read(&ctx, "m.obj", &dir.join("m.obj"), obj.as_bytes(), true, &here()).unwrap();
        assert_eq!(data.materials.len(), 2, "each material once");
        assert_eq!(data.material_ids, vec![0]);
        assert_eq!(data.materials[0].kd, DVec3::new(0.5, 0.25, 0.125));
        let warnings: Vec<String> = ctx.take_warnings().iter().map(|w| w.report()).collect();
        assert_eq!(warnings.len(), 3, "{warnings:?}");
        for part in ["m.mtl", "\"wood\"", "bump wood-n.png"] {
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

    /// Materials with texture maps beyond [`MAX_MAP_WARNINGS`] are counted, not listed.
    #[test]
    fn texture_map_warnings_are_bounded_per_library() {
        let mtl: String = (0..100).map(|i| format!("newmtl m{i}\nmap_Ns t.png\n")).collect();
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m3\nf 1 2 3\n";
        let dir = folder("maps", &[("m.mtl", mtl.as_bytes())]);
        let options = raylab::input::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        read(&ctx, "m.obj", &dir.join("m.obj"), obj.as_bytes(), true, &here()).unwrap();
        let warnings: Vec<String> = ctx.take_warnings().iter().map(|w| w.report()).collect();
        assert_eq!(warnings.len(), MAX_MAP_WARNINGS + 1, "{warnings:?}");
        assert!(warnings[MAX_MAP_WARNINGS].contains(&format!("{} more materials", 100 - MAX_MAP_WARNINGS)));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The fast check never passes a file the exact scan refuses: the fuzz corpus (every OBJ that
    /// once failed) and hand-made cases.
    #[test]
    fn the_fast_index_check_passes_only_what_the_scan_passes() {
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
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 +3\r\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n\u{a0}f 1 2 4\n",
        ];
        texts.extend(cases.iter().map(|c| c.to_string()));
        let mut passed = 0;
        for t in &texts {
            if indices_certainly_valid(t.as_bytes()) {
                passed += 1;
                assert!(scan("t.obj", t, None).is_none(), "fast check passed what the scan refuses:\n{t}");
            }
        }
        assert!(passed >= 5, "the fast check passed only {passed} files");
        assert!(indices_certainly_valid(cases[0].as_bytes()) && !indices_certainly_valid(cases[1].as_bytes()));
        for t in ["0", "-0", "+7", "-9223372036854775808", "9223372036854775807", "9223372036854775808", "-", "+", "", "1x", "--1", " 1"] {
            assert_eq!(parse_i64(t.as_bytes()), t.parse::<i64>().ok(), "{t:?}");
        }
    }

    /// A texture statement's options place the map (`-s`, then `-o`) or clamp it; the rest of the
    /// line, spaces and all, is the file; options raylab does not apply are named.
    #[test]
    fn map_statements_read_their_options_and_file() {
        let m = MapStatement::parse("-s 2 3 -o 0.5 -clamp on -bm 0.4 my wood.png");
        assert_eq!(m.file.as_deref(), Some("my wood.png"));
        assert!(m.clamp);
        assert_eq!(m.ignored, vec!["-bm".to_string()]);
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
        let options = raylab::input::context::LoadOptions::default();
        let ctx = LoadContext::new(&dir, &options);
        let data = read(&ctx, "m.obj", &dir.join("m.obj"), obj.as_bytes(), true, &here()).unwrap();
        assert!(ctx.take_warnings().is_empty());
        assert_eq!((data.texcoords.len(), data.texcoord_indices), (3, vec![[0, 1, 2]]));
        assert_eq!(data.texcoords[1], [0.75, 0.5]);
        let m = &data.materials[0];
        assert_eq!((m.kd, m.textures.len(), m.textures[0].channel), (DVec3::splat(0.5), 1, Channel::Kd));
        let at = |u: f64| {
            m.textures[0].texture.eval(&raylab::scene::texture::TexturePoint { uv: raylab::glam::DVec2::new(u, 0.5), local: DVec3::ZERO })
        };
        assert_eq!((at(0.25), at(0.75)), (DVec3::X, DVec3::Z), "left texel red, right blue");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
