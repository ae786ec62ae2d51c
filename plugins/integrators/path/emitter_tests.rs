//! The emitters' samples as the path tracer reads them: the radiance an emitter sample carries
//! (looked up without building the hit, where the emission is one constant) is what a ray from
//! the shaded point would see there.

use raylab::glam::{DVec2, DVec3};
use raylab::load::context::LoadOptions;
use raylab::param::limits::Limits;
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
    for k in 0..4000u32 {
        let f = |i: u32| f64::from((k.wrapping_mul(2_654_435_761).wrapping_add(i * 40_503)) % 10_007) / 10_007.0;
        let reference = DVec3::new(6.0 * f(1) - 3.0, 6.0 * f(2) - 3.0, 6.0 * f(3) - 3.0);
        for selection in [Selection::Power, Selection::Uniform] {
            let Some(es) = scene.emitters().sample(&scene.objects, reference, f(4), DVec2::new(f(5), f(6)), selection) else { continue };
            let o = &scene.objects[es.object as usize];
            let seen = Interaction::new(&Ray { origin: reference, dir: es.dir }, es.hit, o).emission();
            assert_eq!(es.radiance, seen, "emitter {} from {reference}", es.object);
            if seen == Color::ZERO { dark += 1 } else { lit += 1 }
        }
    }
    // Both sides of the one-sided emitters were sampled.
    assert!(lit > 1000 && dark > 1000, "{lit} lit, {dark} dark");
}
