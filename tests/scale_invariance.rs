//! Scale and translation invariance: a scene scaled uniformly by any factor from 10⁻⁴ to 10⁵, or
//! moved 10⁵ units from the origin, renders the same image as the original (the showcase, and the
//! Cornell box with meshes). Nothing in raylab may
//! depend on the scene's absolute size or position (no fixed epsilon).
//!
//! The scene description is transformed parameter by parameter: points `p → s·p + offset`, lengths
//! `→ s·length`, the point lights' attenuation `kl → kl/s`, `kq → kq/s²` (so that
//! `kc + kl·d + kq·d²` is unchanged), directions, colours, angles and counts unchanged. Every key is
//! classified: a new parameter that this test does not know fails it, rather than being left
//! unscaled.
//!
//! Tolerance: the images are compared in 8-bit sRGB, as written. Rounding moves a hit point by about
//! 1e-15 of the scene's magnitude, far below a pixel, so a shaded pixel changes by at most one 8-bit
//! level (rounding of the encode); only a ray that passes within rounding of a silhouette, a shadow
//! boundary or a polygon edge can change side and change its pixel completely. The test allows a
//! difference of at most 2 levels everywhere except at most 0.1 % of the pixels (14 of 14400 here),
//! and measures the mean difference (< 0.02 levels). Set `RAYLAB_SCALE_PNG=DIR` to write every
//! render there.

use raylab::glam::DVec3;
use raylab::load::context::LoadOptions;
use raylab::param::description::SceneDescription;
use raylab::param::toml::parse_toml;
use raylab::param::value::{Node, Table, Value};
use raylab::render::{RenderOptions, render};
use raylab::{LoadContext, Source};
use std::path::Path;

/// How a parameter changes when the scene is scaled by `s` and moved by `offset`.
enum Rule {
    Point,
    Length,
    PerLength,
    PerArea,
    Same,
}

fn rule(key: &str) -> Rule {
    match key {
        "center" | "position" | "point" | "base" | "p0" | "p1" | "p2" | "p3" | "vertices" | "look_at" => Rule::Point,
        "radius" | "height" | "screen_distance" | "screen_width" | "screen_height" | "aperture" | "focus_distance" | "far" => Rule::Length,
        // Inside an object's `transform` table (scale, then rotate, then translate): scaling the
        // world by s scales `scale` and `translate` by s; the offset is added to `translate`.
        "scale" => Rule::Length,
        "translate" => Rule::Point,
        "kl" => Rule::PerLength,
        "kq" => Rule::PerArea,
        "type" | "name" | "material" | "edges" | "file" | "mesh" | "normals" | "rotate" | "normal" | "axis" | "open" | "direction"
        | "to" | "up" | "color" | "kc" | "ka" | "kd" | "ks" | "kr" | "kt" | "shininess" | "ior" | "emission" | "blur" | "fov"
        | "exponent" | "cone_angle" | "background" | "max_depth" | "prune_threshold" | "glossy_rays" => Rule::Same,
        other => panic!("the scale test does not know how parameter `{other}` scales: classify it in rule()"),
    }
}

fn scale_number(n: &mut Node, f: impl Fn(f64) -> f64 + Copy) {
    match &mut n.value {
        Value::Float(x) => *x = f(*x),
        Value::Int(i) => n.value = Value::Float(f(*i as f64)),
        Value::Array(items) => items.iter_mut().for_each(|i| scale_number(i, f)),
        other => panic!("not a number: {other:?}"),
    }
}

fn move_point(n: &mut Node, s: f64, offset: DVec3) {
    match &mut n.value {
        Value::Array(items) if items.iter().all(|i| matches!(i.value, Value::Array(_))) => {
            items.iter_mut().for_each(|i| move_point(i, s, offset))
        }
        Value::Array(items) if items.len() == 3 => {
            for (axis, i) in items.iter_mut().enumerate() {
                scale_number(i, |x| s * x + offset[axis]);
            }
        }
        other => panic!("not a point: {other:?}"),
    }
}

/// Gives every mesh object a `transform` table (the identity) if it has none, so that scaling
/// and moving it can be written there: a mesh's vertices are in its file.
fn add_mesh_transforms(root: &mut Table) {
    let Some(Value::Array(objects)) = root.entries.iter_mut().find(|e| e.key == "object").map(|e| &mut e.value.value) else { return };
    for o in objects {
        let loc = o.loc.clone();
        let Value::Table(t) = &mut o.value else { continue };
        let is_mesh = matches!(t.get("type").map(|n| &n.value), Some(Value::Str(ty)) if ty == "mesh");
        if is_mesh && t.get("transform").is_none() {
            let number = |x: f64| Node { value: Value::Float(x), loc: loc.clone() };
            let mut identity = Table::default();
            identity.set("scale", loc.clone(), number(1.0));
            identity.set(
                "translate",
                loc.clone(),
                Node { value: Value::Array(vec![number(0.0), number(0.0), number(0.0)]), loc: loc.clone() },
            );
            t.set("transform", loc.clone(), Node { value: Value::Table(identity), loc: loc.clone() });
        }
        if let Some(Value::Table(_)) = t.get("transform").map(|n| &n.value) {
        } else if t.get("transform").is_some() {
            panic!("the scale test handles a `transform` table, not a list or a matrix");
        }
    }
}

/// Transforms every parameter of `t` (a table of the scene, at any depth). With `faulty`, lengths
/// are left unscaled (to show that the comparison notices).
fn transform(t: &mut Table, s: f64, offset: DVec3, faulty: bool) {
    for e in &mut t.entries {
        if let Value::Table(sub) = &mut e.value.value {
            // Image settings and inline materials hold no geometry.
            if e.key != "material" && e.key != "render" {
                transform(sub, s, offset, faulty);
            }
            continue;
        }
        if let Value::Array(items) = &mut e.value.value
            && items.iter().all(|i| matches!(i.value, Value::Table(_)))
            && !items.is_empty()
        {
            for i in items {
                let Value::Table(sub) = &mut i.value else { unreachable!() };
                transform(sub, s, offset, faulty);
            }
            continue;
        }
        match rule(&e.key) {
            Rule::Point => move_point(&mut e.value, s, offset),
            Rule::Length if faulty => {}
            Rule::Length => scale_number(&mut e.value, |x| s * x),
            Rule::PerLength => scale_number(&mut e.value, |x| x / s),
            Rule::PerArea => scale_number(&mut e.value, |x| x / (s * s)),
            Rule::Same => {}
        }
    }
}

/// The scene at `path`, transformed, rendered at `width × height` to 8-bit sRGB.
fn render_transformed(path: &str, s: f64, offset: DVec3, faulty: bool, width: u32, height: u32) -> Vec<u8> {
    let full = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    let text = std::fs::read_to_string(&full).unwrap();
    let mut desc: SceneDescription = parse_toml(&Source::new(path, text), "scene".into()).unwrap();
    add_mesh_transforms(&mut desc.root);
    transform(&mut desc.root, s, offset, faulty);
    let mut options = LoadOptions::default();
    options.overrides.width = Some(width);
    options.overrides.height = Some(height);
    let ctx = LoadContext::new(full.parent().unwrap(), &options);
    let job = raylab::load::loader::build(&raylab_plugins::registry(), &desc, &ctx).unwrap_or_else(|e| panic!("{}", e.report()));
    let rendered = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap();
    assert_eq!(rendered.stats.nonfinite_samples, 0, "scale {s:e}, offset {offset}: NaN or infinite samples");
    if let Ok(dir) = std::env::var("RAYLAB_SCALE_PNG") {
        let name = format!("{dir}/{}-{s:e}-{}.png", Path::new(path).file_stem().unwrap().to_string_lossy(), offset.x);
        raylab::image::output::write_image(Path::new(&name), &rendered.film, job.settings.encoding, None).unwrap();
    }
    raylab::image::output::to_rgb8(&rendered.film, job.settings.encoding, None)
}

/// (pixels differing by more than 2 levels, mean absolute difference in levels).
fn compare(a: &[u8], b: &[u8]) -> (usize, f64) {
    let mut far = 0;
    let mut sum = 0u64;
    for (pa, pb) in a.chunks(3).zip(b.chunks(3)) {
        let d = pa.iter().zip(pb).map(|(x, y)| x.abs_diff(*y)).max().unwrap();
        far += usize::from(d > 2);
        sum += pa.iter().zip(pb).map(|(x, y)| u64::from(x.abs_diff(*y))).sum::<u64>();
    }
    (far, sum as f64 / a.len() as f64)
}

fn check_invariance(path: &str) {
    let (w, h) = (160, 90);
    let reference = render_transformed(path, 1.0, DVec3::ZERO, false, w, h);
    let allowed = (w * h) as usize / 1000;
    let mut report = String::new();
    let cases = [
        (1e-4, DVec3::ZERO),
        (1e-2, DVec3::ZERO),
        (0.37, DVec3::ZERO),
        (1e2, DVec3::ZERO),
        (1e5, DVec3::ZERO),
        (1.0, DVec3::new(1e5, 0.0, 0.0)),
        (1.0, DVec3::new(-7e4, 7e4, 1e5)),
        (1e-3, DVec3::new(1e5, -1e5, 0.0)),
        (1e-4, DVec3::new(1e5, 1e5, 1e5)),
    ];
    for (s, offset) in cases {
        let img = render_transformed(path, s, offset, false, w, h);
        let (far, mean) = compare(&reference, &img);
        eprintln!("{path} scale {s:e} offset {offset}: {far} pixels differ by > 2 levels, mean difference {mean:.6} levels");
        if far > allowed || mean >= 0.02 {
            report += &format!("scale {s:e} offset {offset}: {far} pixels differ by > 2 levels (allowed {allowed}), mean {mean:.4}\n");
        }
    }
    assert!(report.is_empty(), "{path}:\n{report}");
    // The comparison has teeth: a transform that forgets the lengths changes the image.
    let wrong = render_transformed(path, 1.5, DVec3::ZERO, true, w, h);
    let (far, _) = compare(&reference, &wrong);
    assert!(far > 10 * allowed, "{path}: unscaled radii changed only {far} pixels");
}

#[test]
fn the_showcase_renders_the_same_at_any_scale_and_position() {
    check_invariance("scenes/showcase.toml");
}

/// The Cornell box (an OBJ with its materials), a torus knot placed by a transform, a glass
/// sphere: meshes, their hierarchy and their transforms at any scale. Needs the `mesh` feature.
#[test]
fn the_mesh_scene_renders_the_same_at_any_scale_and_position() {
    if raylab_plugins::registry().geometry("mesh").is_some() {
        check_invariance("scenes/cornell.toml");
    }
}
