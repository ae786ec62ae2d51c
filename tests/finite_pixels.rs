//! No NaN or infinite pixel, ever: random valid scenes (every shape, light, material parameter and
//! integrator, at scales 10⁻⁴ to 10⁴, lights placed on surfaces, cameras inside objects) render to
//! finite pixels, and not one sample is non-finite. `render_pixel` drops and counts a non-finite
//! sample (`RayStats::nonfinite_samples`) as a last guard; this property requires the count to be 0.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use raylab::load::context::LoadOptions;
use raylab::load::loader::load_str;
use raylab::render::{RenderOptions, render};
use std::fmt::Write;
use std::path::Path;

fn config(cases: u32) -> Config {
    Config { cases, rng_seed: RngSeed::Fixed(0xf1_417e), failure_persistence: None, ..Config::default() }
}

fn v3(v: [f64; 3]) -> String {
    format!("[{:e}, {:e}, {:e}]", v[0], v[1], v[2])
}

fn vec3(range: f64) -> impl Strategy<Value = [f64; 3]> {
    prop::array::uniform3(-range..range)
}

/// A direction, never zero.
fn direction() -> impl Strategy<Value = [f64; 3]> {
    vec3(1.0).prop_filter("non-zero", |v| v.iter().map(|x| x * x).sum::<f64>() > 1e-6)
}

/// An inline material: any valid coefficients, blur, index of refraction (also below 1) and emission.
fn material() -> impl Strategy<Value = String> {
    (
        prop::array::uniform4(0.0..1.0f64),
        prop::sample::select(vec![0.0, 1.0, 20.0, 1000.0]),
        0.05..3.0f64,
        prop::sample::select(vec![0.0, 0.3, 1.0]),
        prop::sample::select(vec![0.0, 0.5]),
    )
        .prop_map(|([kd, ks, kr, kt], shininess, ior, blur, emission)| {
            format!("{{ kd = {kd}, ks = {ks}, kr = {kr}, kt = {kt}, shininess = {shininess}, ior = {ior}, blur = {blur}, emission = {emission} }}")
        })
}

/// One object of any built-in type, within `s` of the origin; also a point on its surface.
fn object(s: f64) -> impl Strategy<Value = (String, [f64; 3])> {
    (0..8usize, vec3(s), direction(), 0.01..1.0f64, 0.01..2.0f64, direction(), 3..9usize, material()).prop_map(
        move |(kind, c, d, r, h, e, sides, m)| {
            let r = r * s;
            let on = |v: [f64; 3]| -> [f64; 3] {
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                [c[0] + r * v[0] / n, c[1] + r * v[1] / n, c[2] + r * v[2] / n]
            };
            // Two unit vectors spanning the plane normal to d.
            let n = raylab::glam::DVec3::from_array(d).normalize();
            let (e1, e2) = n.any_orthonormal_pair();
            let at = |a: f64, b: f64| (raylab::glam::DVec3::from_array(c) + r * (a * e1 + b * e2)).to_array();
            let text = match kind {
                0 => format!("type = \"plane\"\npoint = {}\nnormal = {}", v3(c), v3(d)),
                1 => format!("type = \"sphere\"\ncenter = {}\nradius = {r:e}", v3(c)),
                2 => format!("type = \"hemisphere\"\ncenter = {}\nradius = {r:e}\nopen = {}", v3(c), v3(e)),
                3 => format!("type = \"triangle\"\np0 = {}\np1 = {}\np2 = {}", v3(at(0.0, 0.0)), v3(at(1.0, 0.1)), v3(at(0.2, 1.0))),
                4 => format!(
                    "type = \"quadrangle\"\np0 = {}\np1 = {}\np2 = {}\np3 = {}",
                    v3(at(-1.0, -1.0)),
                    v3(at(1.0, -1.0)),
                    v3(at(1.0, 1.0)),
                    v3(at(-1.0, 1.0))
                ),
                5 => {
                    let v: Vec<String> = (0..sides)
                        .map(|i| {
                            let a = std::f64::consts::TAU * i as f64 / sides as f64;
                            v3(at(a.cos(), a.sin()))
                        })
                        .collect();
                    format!("type = \"polygon\"\nvertices = [{}]", v.join(", "))
                }
                6 => format!("type = \"cylinder\"\nbase = {}\naxis = {}\nradius = {r:e}\nheight = {:e}", v3(c), v3(d), h * s),
                _ => format!("type = \"tube\"\npoint = {}\naxis = {}\nradius = {r:e}", v3(c), v3(d)),
            };
            let surface = match kind {
                0 => c,
                1 | 6 | 7 => on(e),
                _ => at(0.3, 0.3),
            };
            (format!("{text}\nmaterial = {m}\n"), surface)
        },
    )
}

/// A light of any type; `on` is a point on some surface, where a light may sit.
fn light(s: f64, on: [f64; 3]) -> impl Strategy<Value = String> {
    (0..6usize, vec3(3.0 * s), direction(), prop::array::uniform3(0.0..2.0f64), any::<bool>(), 0.0..50.0f64, 1.0..90.0f64, 0.01..1.0f64)
        .prop_map(move |(kind, p, d, [kc, kl, kq], on_surface, exponent, cone, size)| {
            let p = if on_surface { on } else { p };
            let kc = if kl + kq > 0.0 { kc } else { kc + 0.1 };
            let attenuation = format!("kc = {kc}\nkl = {:e}\nkq = {:e}\n", kl / s, kq / (s * s));
            match kind {
                0 => format!("type = \"ambient\"\nka = {}\n", kc),
                1 => format!("type = \"directional\"\ndirection = {}\n", v3(d)),
                2 => format!("type = \"point\"\nposition = {}\n{attenuation}", v3(p)),
                3 => format!(
                    "type = \"spot\"\nposition = {}\ndirection = {}\nexponent = {exponent}\ncone_angle = {cone}\n{attenuation}",
                    v3(p),
                    v3(d)
                ),
                // Lights with an extent: a ball, and a rectangle through the point (on a surface, or not).
                4 => format!("type = \"point\"\nposition = {}\nradius = {:e}\nsamples = 2\n{attenuation}", v3(p), size * s),
                _ => {
                    let (e1, e2) = raylab::glam::DVec3::from_array(d).normalize().any_orthonormal_pair();
                    let (e1, e2) = ((e1 * size * s).to_array(), (e2 * s).to_array());
                    format!("type = \"rect\"\ncenter = {}\nedge1 = {}\nedge2 = {}\nsamples = 2\n{attenuation}", v3(p), v3(e1), v3(e2))
                }
            }
        })
}

/// A whole scene as TOML text.
fn scene() -> impl Strategy<Value = String> {
    prop::sample::select(vec![1e-4, 1e-2, 1.0, 1e2, 1e4])
        .prop_flat_map(|s| (Just(s), prop::collection::vec(object(s), 1..6)))
        .prop_flat_map(|(s, objects)| {
            let on = objects[0].1;
            (
                Just(objects),
                prop::collection::vec(light(s, on), 0..4),
                vec3(4.0 * s),
                vec3(s),
                1.0..170.0f64,
                prop::sample::select(vec![0.0, 0.1 * s]),
                (0..4usize, 0..6u32, 1..4u32, 1..4u32),
            )
        })
        .prop_map(|(objects, lights, eye, target, fov, aperture, (integrator, depth, glossy, spp))| {
            let mut t = String::new();
            writeln!(t, "background = [0.1, 0.2, 0.3]\n[render]\nwidth = 8\nheight = 6\nspp = {spp}").unwrap();
            writeln!(t, "[camera]\nposition = {}\nlook_at = {}\nfov = {fov}\naperture = {aperture:e}", v3(eye), v3(target)).unwrap();
            let integ = ["phong", "normals", "depth", "path"][integrator];
            writeln!(t, "[integrator]\ntype = \"{integ}\"").unwrap();
            if integ == "phong" {
                writeln!(t, "max_depth = {depth}\nglossy_rays = {glossy}\nprune_threshold = 0").unwrap();
            }
            if integ == "path" {
                writeln!(t, "max_bounces = {depth}\nroulette_depth = {}\nlight_samples = {glossy}", depth / 2).unwrap();
            }
            for (o, _) in &objects {
                writeln!(t, "[[object]]\n{o}").unwrap();
            }
            for l in &lights {
                writeln!(t, "[[light]]\n{l}").unwrap();
            }
            t
        })
}

proptest! {
    #![proptest_config(config(1024))]

    #[test]
    fn every_pixel_of_a_random_valid_scene_is_finite(text in scene()) {
        let job = match load_str(&raylab_plugins::registry(), "random.toml", &text, Path::new("."), &LoadOptions::default()) {
            Ok(job) => job,
            // Only a camera looking straight along `up` is refused: the generator is otherwise valid.
            Err(e) => {
                prop_assert!(e.message.contains("parallel"), "a valid scene was refused: {}\n{text}", e.report());
                return Ok(());
            }
        };
        let rendered = render(&job, &RenderOptions { threads: Some(1), ..RenderOptions::default() }, &|_, _| {}).unwrap();
        prop_assert_eq!(rendered.stats.nonfinite_samples, 0, "non-finite samples in:\n{}", text);
        prop_assert!(rendered.film.pixels.iter().all(|p| p.is_finite()), "non-finite pixel in:\n{}", text);
    }
}

/// Every bundled scene rendered by the path tracer (small, few samples): not one non-finite
/// sample. The path tracer divides by densities, meets lights placed in walls and on the camera's
/// side, and runs deep inside glass; none of it may leak a NaN.
#[test]
fn the_path_tracer_renders_every_bundled_scene_finite() {
    let registry = raylab_plugins::registry();
    let meshes = registry.geometry("mesh").is_some();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut scenes: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    scenes.sort();
    let mut rendered = 0;
    for scene in scenes {
        if !meshes && std::fs::read_to_string(&scene).is_ok_and(|t| t.contains("type = \"mesh\"")) {
            continue;
        }
        let overrides = raylab::load::context::Overrides {
            width: Some(40),
            height: Some(30),
            spp: Some(4),
            integrator: Some("path".into()),
            ..Default::default()
        };
        let job = raylab::load::loader::load_file(&registry, &scene, &LoadOptions { overrides, ..LoadOptions::default() })
            .unwrap_or_else(|e| panic!("{}", e.report()));
        let out = render(&job, &RenderOptions::default(), &|_, _| {}).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0, "{}", scene.display());
        assert!(out.film.pixels.iter().all(|p| p.is_finite()), "{}", scene.display());
        rendered += 1;
    }
    assert!(rendered >= 14, "only {rendered} scenes");
}
