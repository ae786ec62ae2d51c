//! χ² tests of every built-in shape's surface sampling against its density
//! ([`raylab::geometry::sampling::check_surface_sampling`]), from outside, near and inside, and
//! placed by transforms (a similarity keeps solid angles; a stretch turns them into areas).

use super::cylinder::Cylinder;
use super::hemisphere::Hemisphere;
use super::polygon::Polygon;
use super::sphere::Sphere;
use super::triangle::Triangle;
use raylab::Geometry;
use raylab::geometry::sampling::{SamplingCheck, check_surface_sampling};
use raylab::geometry::transform::{Transform, Transformed};
use raylab::glam::{DAffine3, DMat3, DQuat, DVec2, DVec3};

/// Significance under which a χ² test fails (fixed seeds: a failure is reproducible).
const SIGNIFICANCE: f64 = 1e-4;
/// How far the densities' integral over all directions may stray from 1 (the expected counts
/// are integrated with 6×6 rays per cell).
const INTEGRAL_TOLERANCE: f64 = 2e-3;
/// Samples per check.
const SAMPLES: u32 = 100_000;

/// Uniform numbers in [0, 1): SplitMix64 (a counter through a strong mix, not a hash per
/// dimension: a χ² test of 10⁵ samples sees the difference).
pub(crate) fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn check(g: &dyn Geometry, reference: DVec3, seed: u64) -> SamplingCheck {
    let r = check_histogram(g, reference, seed);
    assert!((r.integral - 1.0).abs() < INTEGRAL_TOLERANCE, "from {reference}: {r:?}");
    r
}

/// The χ² test alone: for a shape whose density holds only for the points its samples can be
/// (a cone-sampled sphere under a stretch, whose density per area says nothing of its back).
fn check_histogram(g: &dyn Geometry, reference: DVec3, seed: u64) -> SamplingCheck {
    let mut next = rng(seed);
    let r = check_surface_sampling(g, reference, SAMPLES, (16, 32), || DVec2::new(next(), next()));
    assert!(r.p_value > SIGNIFICANCE, "from {reference}: {r:?}");
    r
}

#[test]
fn a_sphere_is_sampled_by_its_cone_and_from_inside_by_area() {
    let g = Sphere::new(DVec3::new(0.3, 1.0, -0.2), 0.7);
    for (i, p) in [DVec3::new(0.0, 5.0, 1.0), DVec3::new(1.2, 1.1, -0.3), DVec3::new(0.5, 0.8, 0.0), DVec3::new(40.0, 0.0, 3.0)]
        .into_iter()
        .enumerate()
    {
        check(&g, p, i as u64);
    }
}

#[test]
fn flat_shapes_are_sampled_by_area() {
    let t = Triangle::new(DVec3::ZERO, DVec3::new(1.0, 0.2, 0.0), DVec3::new(0.3, 0.1, 1.4)).unwrap();
    let quad =
        Polygon::new(vec![DVec3::new(-1.0, 0.0, -0.5), DVec3::new(1.0, 0.0, -0.5), DVec3::new(1.0, 0.0, 0.5), DVec3::new(-1.0, 0.0, 0.5)])
            .unwrap();
    let hexagon = Polygon::new(
        (0..6)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 6.0 + 0.1 * (k % 2) as f64;
                DVec3::new(a.cos() * (1.0 + 0.3 * (k % 3) as f64), 0.5, a.sin())
            })
            .collect(),
    )
    .unwrap();
    for (i, p) in [DVec3::new(0.2, 1.0, 0.3), DVec3::new(0.4, -0.6, 2.0), DVec3::new(3.0, 2.0, 0.0)].into_iter().enumerate() {
        check(&t, p, 10 + i as u64);
        check(&quad, p, 20 + i as u64);
        check(&hexagon, p, 30 + i as u64);
    }
}

#[test]
fn curved_open_and_capped_shapes_are_sampled_by_area() {
    let c = Cylinder::new(DVec3::new(0.0, -0.5, 0.0), DVec3::new(0.0, 0.6, 0.8), 0.4, Some(1.3));
    let bowl = Hemisphere::new(DVec3::new(0.2, 0.0, 0.0), 0.8, DVec3::Y);
    for (i, p) in [DVec3::new(2.0, 1.0, 0.2), DVec3::new(0.0, 0.1, 0.2), DVec3::new(0.1, 3.0, -0.2)].into_iter().enumerate() {
        check(&c, p, 40 + i as u64);
    }
    // The bowl from inside its sphere and from above its opening (seen from outside, the density per solid angle is singular at its outline, which the integration cannot follow).
    for (i, p) in [DVec3::new(0.3, 0.2, 0.1), DVec3::new(0.1, 3.0, -0.2)].into_iter().enumerate() {
        check(&bowl, p, 50 + i as u64);
    }
}

#[test]
fn transformed_shapes_keep_their_densities() {
    let rotate = DMat3::from_quat(DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.8));
    let similar = Transform::new(DAffine3::from_mat3_translation(rotate * 1.7, DVec3::new(0.5, -1.0, 2.0))).unwrap();
    let stretch = Transform::new(DAffine3::from_mat3_translation(
        rotate * DMat3::from_diagonal(DVec3::new(2.0, 0.5, 1.0)),
        DVec3::new(0.0, 1.0, 0.0),
    ))
    .unwrap();
    assert!(similar.is_similarity() && !stretch.is_similarity());
    let sphere = || Sphere::new(DVec3::new(0.1, 0.2, 0.0), 0.6);
    let quad = || {
        Polygon::new(vec![DVec3::new(-1.0, 0.0, -0.5), DVec3::new(1.0, 0.0, -0.5), DVec3::new(1.0, 0.0, 0.5), DVec3::new(-1.0, 0.0, 0.5)])
            .unwrap()
    };
    for (i, p) in [DVec3::new(3.0, 2.0, 4.0), DVec3::new(0.3, 1.4, 2.2)].into_iter().enumerate() {
        let seed = 60 + 4 * i as u64;
        check(&Transformed::new(sphere(), similar), p, seed);
        check_histogram(&Transformed::new(sphere(), stretch), p, seed + 1);
        check(&Transformed::new(quad(), similar), p, seed + 2);
        check(&Transformed::new(quad(), stretch), p, seed + 3);
    }
    // Areas: exact under a similarity.
    let a = Transformed::new(sphere(), similar).area().unwrap();
    assert!((a / (4.0 * std::f64::consts::PI * 0.36 * 1.7 * 1.7) - 1.0).abs() < 1e-12);
}

/// The check can fail: a sphere whose density claims the wrong cone.
#[test]
fn the_check_rejects_a_wrong_density() {
    struct Lying(Sphere);
    impl raylab::Intersectable for Lying {
        fn intersect(&self, ray: &raylab::Ray, t_min: f64, t_max: f64) -> Option<raylab::Hit> {
            self.0.intersect(ray, t_min, t_max)
        }
    }
    impl Geometry for Lying {
        fn outward_normal(&self, at: &raylab::Hit) -> DVec3 {
            self.0.outward_normal(at)
        }
        fn bounds(&self) -> Option<raylab::Aabb> {
            self.0.bounds()
        }
        fn area(&self) -> Option<f64> {
            self.0.area()
        }
        /// The cone's samples squeezed toward its axis.
        fn sample_surface(&self, r: DVec3, u: DVec2) -> Option<raylab::geometry::SurfaceSample> {
            self.0.sample_surface(r, DVec2::new(u.x * (0.9 + 0.1 * u.x), u.y))
        }
        fn surface_pdf(&self, r: DVec3, at: &raylab::Hit) -> raylab::geometry::SurfacePdf {
            self.0.surface_pdf(r, at)
        }
    }
    let g = Lying(Sphere::new(DVec3::ZERO, 1.0));
    let mut next = rng(1);
    let r = check_surface_sampling(&g, DVec3::new(0.0, 0.0, 2.5), SAMPLES, (16, 32), || DVec2::new(next(), next()));
    assert!(r.p_value < SIGNIFICANCE, "{r:?}");
}
