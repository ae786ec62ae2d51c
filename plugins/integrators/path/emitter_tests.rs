//! The emitters' samples as the path tracer reads them: the radiance an emitter sample carries
//! (looked up without building the hit, where the emission is one constant) is what a ray from
//! the shaded point would see there.

use raylab::glam::DVec3;
use raylab::load::context::LoadOptions;
use raylab::param::limits::Limits;
use raylab::scene::bsdf::testing::TestRng;
use raylab::scene::emitters::Selection;
use raylab::scene::interaction::Interaction;
use raylab::{Color, Ray, RenderJob};
use std::path::Path;

fn load(text: &str) -> RenderJob {
    let options = LoadOptions { limits: Limits::unlimited(), ..LoadOptions::default() };
    raylab::load::loader::load_str(&crate::registry(), "test.toml", text, Path::new("."), &options)
        .unwrap_or_else(|e| panic!("{}", e.report()))
}

/// Emitters of every kind of side, flat and round, placed by a transform, one textured (its
/// emission read at the point), seen from points all around them.
#[test]
fn an_emitter_samples_radiance_is_what_a_ray_sees_there() {
    let job = load(
        "[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 8]\nlook_at = [0, 0, 0]\n[integrator]\ntype = \"path\"\n\
         [textures.c]\ntype = \"checker\"\neven = 1\nodd = 0.25\n\
         [[object]]\ntype = \"sphere\"\ncenter = [-2, 0, 0]\nradius = 0.5\nmaterial = { kd = 0, emission = [3, 2, 1] }\nemission_sides = \"front\"\n\
         [[object]]\ntype = \"quadrangle\"\np0 = [1, -1, 0]\np1 = [2, -1, 0]\np2 = [2, 0, 1]\np3 = [1, 0, 1]\nmaterial = { kd = 0, emission = 2 }\nemission_sides = \"back\"\n\
         [[object]]\ntype = \"triangle\"\np0 = [0, 2, 0]\np1 = [1, 2, 0]\np2 = [0, 2, 1]\nmaterial = { kd = 0, emission = [1, 4, 1] }\nemission_sides = \"front\"\n\
         [[object]]\ntype = \"cylinder\"\nbase = [0, -2, 0]\naxis = [0, 1, 0]\nradius = 0.3\nheight = 0.5\nmaterial = { kd = 0, emission = 5 }\n\
         transform = { scale = 1.5, rotate = [20, 0, 30], translate = [0, 0, -1] }\nemission_sides = \"front\"\n\
         [[object]]\ntype = \"sphere\"\ncenter = [2, 2, 0]\nradius = 0.4\nmaterial = { kd = 0, emission = \"c\" }\nemission_sides = \"front\"\n",
    );
    let scene = &job.scene;
    assert_eq!(scene.emitters().len(), 5);
    let (mut lit, mut dark) = (0, 0);
    let mut rng = TestRng::new(5);
    for _ in 0..4000 {
        let reference = DVec3::new(6.0 * rng.uniform() - 3.0, 6.0 * rng.uniform() - 3.0, 6.0 * rng.uniform() - 3.0);
        for selection in [Selection::Power, Selection::Uniform] {
            let (pick, u) = (rng.uniform(), rng.next_2d());
            let Some(es) = scene.emitters().sample(&scene.objects, reference, pick, u, selection) else { continue };
            let o = &scene.objects[es.object as usize];
            let seen = Interaction::new(&Ray { origin: reference, dir: es.dir }, es.hit, o).emission();
            assert_eq!(es.radiance, seen, "emitter {} from {reference}", es.object);
            if seen == Color::ZERO { dark += 1 } else { lit += 1 }
        }
    }
    // Both sides of the one-sided emitters were sampled.
    assert!(lit > 1000 && dark > 1000, "{lit} lit, {dark} dark");
}

/// A shadow ray toward a point an emitter cannot hide ([`raylab::scene::emitters::EmitterSample::clear_of_itself`]:
/// a convex shape, the point facing the shaded point) is never stopped by the emitter itself,
/// so path leaves the emitter out of it; concave meshes are not convex.
#[cfg(feature = "mesh")]
#[test]
fn an_emitter_never_hides_a_point_it_says_it_cannot() {
    use raylab::Intersectable;
    let dir = std::env::temp_dir().join(format!("raylab-emitters-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // An octahedron (convex, outward windings), a flat square facing down, a strip folded into
    // a valley, its windings' normals into it (concave).
    let mut obj = String::new();
    for v in [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]] {
        obj += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    for (sx, sy, sz) in [(1, 1, 1), (1, 1, -1), (1, -1, 1), (1, -1, -1), (-1, 1, 1), (-1, 1, -1), (-1, -1, 1), (-1, -1, -1)] {
        let (a, b, c) = (if sx > 0 { 1 } else { 2 }, if sy > 0 { 3 } else { 4 }, if sz > 0 { 5 } else { 6 });
        obj += &if sx * sy * sz > 0 { format!("f {a} {b} {c}\n") } else { format!("f {a} {c} {b}\n") };
    }
    std::fs::write(dir.join("octahedron.obj"), obj).unwrap();
    std::fs::write(dir.join("square.obj"), "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 2 3\nf 1 3 4\n").unwrap();
    std::fs::write(dir.join("fold.obj"), "v 0 0 0\nv 0 0 1\nv 1 1 0\nv 1 1 1\nv -1 1 0\nv -1 1 1\nf 1 2 3\nf 2 4 3\nf 1 5 2\nf 2 5 6\n")
        .unwrap();
    let mesh = |file: &str, at: [f64; 3]| {
        format!(
            "[[object]]\ntype = \"mesh\"\nfile = \"{file}\"\nnormals = \"flat\"\nmaterial = {{ kd = 0, emission = 2 }}\n\
             transform = {{ scale = 0.5, translate = {at:?} }}\n"
        )
    };
    let text = format!(
        "[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 8]\nlook_at = [0, 0, 0]\n[integrator]\ntype = \"path\"\n\
         [[object]]\ntype = \"sphere\"\ncenter = [-2, 0, 0]\nradius = 0.5\nmaterial = {{ kd = 0, emission = 1 }}\n\
         [[object]]\ntype = \"quadrangle\"\np0 = [1, -1, 0]\np1 = [2, -1, 0]\np2 = [2, 0, 1]\np3 = [1, 0, 1]\nmaterial = {{ kd = 0, emission = 2 }}\n\
         [[object]]\ntype = \"cylinder\"\nbase = [0, -2, 0]\nradius = 0.3\nheight = 0.5\nmaterial = {{ kd = 0, emission = 5 }}\n\
         transform = {{ scale = [1.5, 1, 0.5], rotate = [20, 0, 30], translate = [0, 0, -1] }}\n\
         [[object]]\ntype = \"hemisphere\"\ncenter = [2, 2, 0]\nradius = 0.4\nopen = [0, 1, 0]\nmaterial = {{ kd = 0, emission = 1 }}\n{}{}{}",
        mesh("octahedron.obj", [0.0, 2.0, 0.0]),
        mesh("square.obj", [-2.0, 2.0, 0.0]),
        mesh("fold.obj", [2.0, -2.0, 0.0]),
    );
    let options = LoadOptions { limits: Limits::unlimited(), ..LoadOptions::default() };
    let job =
        raylab::load::loader::load_str(&crate::registry(), "test.toml", &text, &dir, &options).unwrap_or_else(|e| panic!("{}", e.report()));
    std::fs::remove_dir_all(&dir).ok();
    let scene = &job.scene;
    let convex: Vec<bool> = scene.objects.iter().map(|o| o.geometry().is_convex()).collect();
    assert_eq!(convex, [true, true, true, true, true, true, false], "sphere, quadrangle, cylinder, bowl, octahedron, square, fold");
    let mut clear = [0u32; 7];
    let mut rng = TestRng::new(7);
    for _ in 0..20_000 {
        let reference = DVec3::new(8.0 * rng.uniform() - 4.0, 8.0 * rng.uniform() - 4.0, 8.0 * rng.uniform() - 4.0);
        let (pick, u) = (rng.uniform(), rng.next_2d());
        let Some(es) = scene.emitters().sample(&scene.objects, reference, pick, u, Selection::Uniform) else {
            continue;
        };
        let o = &scene.objects[es.object as usize];
        assert!(!es.clear_of_itself || convex[es.object as usize]);
        if es.clear_of_itself {
            clear[es.object as usize] += 1;
            let ray = Ray { origin: reference, dir: es.dir };
            // The whole segment up to the point, less a shadow ray's margin.
            let t_max = es.hit.t * (1.0 - raylab::math::float::SHADOW_EPSILON);
            assert!(!o.occludes(&ray, 0.0, t_max), "emitter {} hides its own point from {reference}", es.object);
        }
    }
    assert!(clear[..6].iter().all(|&n| n > 300), "{clear:?}");
}

/// A flat one-sided emitter seen from its dark side ([`raylab::scene::emitters::Emitters::dark_from`],
/// which lets the path tracer draw no point) gives no sample with light: every point drawn
/// from there has zero radiance, near its plane and far from it, for polygons, triangles, and
/// both placed by a similarity; emitters that emit on both sides, or are round, are never dark.
#[test]
fn a_flat_emitter_is_dark_from_its_back_exactly_where_its_samples_are() {
    let job = load(
        "[render]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 8]\nlook_at = [0, 0, 0]\n[integrator]\ntype = \"path\"\n\
         [[object]]\ntype = \"quadrangle\"\np0 = [-0.25, 1.999, -0.25]\np1 = [0.25, 1.999, -0.25]\np2 = [0.25, 1.999, 0.25]\np3 = [-0.25, 1.999, 0.25]\nmaterial = { kd = 0, emission = 3 }\nemission_sides = \"front\"\n\
         [[object]]\ntype = \"quadrangle\"\np0 = [1, -1, 0]\np1 = [2, -1, 0]\np2 = [2, 0, 1]\np3 = [1, 0, 1]\nmaterial = { kd = 0, emission = 2 }\nemission_sides = \"back\"\n\
         [[object]]\ntype = \"triangle\"\np0 = [0, -2, 0]\np1 = [1, -2, 0]\np2 = [0, -2, 1]\nmaterial = { kd = 0, emission = [1, 4, 1] }\nemission_sides = \"front\"\n\
         [[object]]\ntype = \"polygon\"\nvertices = [[0, 0, 0], [1, 0, 0], [1.3, 0, 0.7], [0.5, 0, 1.2], [-0.2, 0, 0.6]]\nmaterial = { kd = 0, emission = 1 }\nemission_sides = \"front\"\n\
         transform = { scale = 1.5, rotate = [20, 40, 30], translate = [-2, 1, 0.5] }\n\
         [[object]]\ntype = \"quadrangle\"\np0 = [-3, 0, -3]\np1 = [-2, 0, -3]\np2 = [-2, 0, -2]\np3 = [-3, 0, -2]\nmaterial = { kd = 0, emission = 1 }\n\
         [[object]]\ntype = \"sphere\"\ncenter = [2, 2, 0]\nradius = 0.4\nmaterial = { kd = 0, emission = 1 }\nemission_sides = \"front\"\n",
    );
    let scene = &job.scene;
    let emitters = scene.emitters();
    assert_eq!(emitters.len(), 6);
    let mut dark = [0u32; 6];
    let mut rng = TestRng::new(11);
    for k in 0..20_000 {
        // Half of the points in a thin slab around the ceiling light's plane (y = 1.999).
        let y = if k % 2 == 0 { 1.999 + 1e-3 * (2.0 * rng.uniform() - 1.0) } else { 6.0 * rng.uniform() - 3.0 };
        let reference = DVec3::new(6.0 * rng.uniform() - 3.0, y, 6.0 * rng.uniform() - 3.0);
        for (e, count) in dark.iter_mut().enumerate() {
            if !emitters.dark_from(e, reference) {
                continue;
            }
            *count += 1;
            for _ in 0..4 {
                let pmf = emitters.choose((e as f64 + 0.5) / 6.0, Selection::Uniform).unwrap().1;
                let Some(es) = emitters.sample_chosen(&scene.objects, (e, pmf), reference, rng.next_2d()) else { continue };
                assert_eq!(es.radiance, Color::ZERO, "emitter {e} from {reference}");
            }
        }
    }
    // The one-sided flat ones are dark from a good share of the points (the tilted one from
    // ~18 %: the slab's points all lie on its lit side); the others never.
    assert!(dark[..4].iter().all(|&n| n > 2000), "{dark:?}");
    assert_eq!(dark[4..], [0, 0], "{dark:?}");
    // And not dark from the lit side: a point just below the ceiling light sees its front.
    assert!(!emitters.dark_from(0, DVec3::new(0.0, 1.99, 0.0)) && emitters.dark_from(0, DVec3::new(0.0, 2.0, 0.0)));
}
