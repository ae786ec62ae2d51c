//! `marble`: a solid texture, the example texture of docs/writing-a-plugin.md: veins where a
//! sine across the pattern's x, pushed about by turbulence (octaves of Perlin's improved
//! noise), comes near its trough.

use raylab::glam::DVec3;
use raylab::param::error::Result;
use raylab::param::params::Params;
use raylab::param::spec::{ParamDefault, ParamKind, ParamSpec};
use raylab::scene::texture::{Mapping, TRANSFORM_PARAM, Texture, TexturePoint};
use raylab::{Color, LoadContext, PluginInfo};
use std::sync::Arc;

/// The `marble` texture's description.
pub const INFO: PluginInfo = PluginInfo {
    name: "marble",
    summary: "Solid marble: veins of `vein` in `base`, one across every unit of the pattern's x, wandering by `turbulence`. Place and size it with `transform`.",
    params: &[
        ParamSpec::new("base", ParamKind::Color, ParamDefault::Vec3([0.9, 0.88, 0.84]), "the stone's colour, linear RGB"),
        ParamSpec::new("vein", ParamKind::Color, ParamDefault::Vec3([0.2, 0.18, 0.24]), "the veins' colour, linear RGB"),
        ParamSpec::new("turbulence", ParamKind::Float, ParamDefault::Float(3.0), "how far the veins wander, in vein spacings, ≥ 0"),
        ParamSpec::new("octaves", ParamKind::Int, ParamDefault::Int(5), "noise octaves summed for the turbulence, 1..=12"),
        ParamSpec::new("seed", ParamKind::Int, ParamDefault::Int(0), "which noise: another seed, another stone"),
        ParamSpec::new(
            "coords",
            ParamKind::Str,
            ParamDefault::Str("object"),
            "\"object\": through the shape's own frame (a solid texture); \"uv\": over texture coordinates",
        ),
        TRANSFORM_PARAM,
    ],
};

/// Builds a `marble` texture from its parameters.
pub fn build(p: &mut Params, _: &LoadContext) -> Result<Arc<dyn Texture>> {
    Ok(Arc::new(Marble {
        base: p.color("base")?,
        vein: p.color("vein")?,
        turbulence: p.non_negative("turbulence")?,
        octaves: p.int_in("octaves", 1..=12)? as u32,
        noise: Perlin::new(p.int_in("seed", 0..=i64::MAX)? as u64),
        mapping: Mapping::from_params(p)?,
    }))
}

/// Marble veins in a base colour.
#[derive(Clone, Debug)]
pub struct Marble {
    base: Color,
    vein: Color,
    turbulence: f64,
    octaves: u32,
    noise: Perlin,
    mapping: Mapping,
}

impl Texture for Marble {
    fn eval(&self, at: &TexturePoint) -> Color {
        let p = self.mapping.point(at);
        if !p.is_finite() {
            return self.base;
        }
        let phase = p.x + self.turbulence * self.noise.turbulence(p, self.octaves);
        // 0 in a vein's middle, 1 between veins; squared, so the veins stay thin.
        let between = 0.5 + 0.5 * (std::f64::consts::PI * phase).sin();
        self.vein.lerp(self.base, 1.0 - (1.0 - between).powi(3))
    }
}

/// Ken Perlin's improved noise (2002) over a permutation of 0..256 chosen by a seed.
#[derive(Clone, Debug)]
pub struct Perlin {
    perm: [u8; 512],
}

impl Perlin {
    /// The noise of `seed` (a Fisher–Yates shuffle driven by SplitMix64).
    pub fn new(seed: u64) -> Self {
        let mut p: [u8; 256] = std::array::from_fn(|i| i as u8);
        let mut state = seed;
        for i in (1..256).rev() {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let j = (raylab::math::sampler::mix64(state) % (i as u64 + 1)) as usize;
            p.swap(i, j);
        }
        Perlin { perm: std::array::from_fn(|i| p[i & 255]) }
    }

    /// Noise at `p`, in about [−1, 1]; 0 at integer points. `p` must be finite.
    pub fn noise(&self, p: DVec3) -> f64 {
        let cell = p.floor();
        let [x, y, z] = (p - cell).to_array();
        // Wrapped into 0..256 (`as` saturates huge cells, which stay in range after the mask).
        let [xi, yi, zi] = cell.to_array().map(|c| (c as i64 & 255) as usize);
        let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let (u, v, w) = (fade(x), fade(y), fade(z));
        let h = |i: usize, j: usize, k: usize| self.perm[self.perm[self.perm[xi + i] as usize + yi + j] as usize + zi + k];
        let g = |hash: u8, x: f64, y: f64, z: f64| {
            let hash = hash & 15;
            let a = if hash < 8 { x } else { y };
            let b = if hash < 4 {
                y
            } else if hash == 12 || hash == 14 {
                x
            } else {
                z
            };
            (if hash & 1 == 0 { a } else { -a }) + (if hash & 2 == 0 { b } else { -b })
        };
        let lerp = |t: f64, a: f64, b: f64| a + t * (b - a);
        lerp(
            w,
            lerp(
                v,
                lerp(u, g(h(0, 0, 0), x, y, z), g(h(1, 0, 0), x - 1.0, y, z)),
                lerp(u, g(h(0, 1, 0), x, y - 1.0, z), g(h(1, 1, 0), x - 1.0, y - 1.0, z)),
            ),
            lerp(
                v,
                lerp(u, g(h(0, 0, 1), x, y, z - 1.0), g(h(1, 0, 1), x - 1.0, y, z - 1.0)),
                lerp(u, g(h(0, 1, 1), x, y - 1.0, z - 1.0), g(h(1, 1, 1), x - 1.0, y - 1.0, z - 1.0)),
            ),
        )
    }

    /// Turbulence: `Σ |noise(2ⁱ·p)| / 2ⁱ` over `octaves`, in about [0, 2).
    pub fn turbulence(&self, p: DVec3, octaves: u32) -> f64 {
        (0..octaves).map(|i| f64::from(1u32 << i)).map(|f| self.noise(p * f).abs() / f).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raylab::glam::DVec2;
    use raylab::scene::texture::Coords;

    #[test]
    fn noise_is_zero_on_the_lattice_bounded_and_seeded() {
        let n = Perlin::new(7);
        for p in [DVec3::ZERO, DVec3::new(3.0, -4.0, 17.0), DVec3::splat(1e9)] {
            assert_eq!(n.noise(p), 0.0, "{p}");
        }
        let mut differ = 0;
        for i in 0..1000 {
            let p = DVec3::new(i as f64 * 0.37, (i as f64 * 0.11).sin() * 9.0, i as f64 * -0.013);
            let v = n.noise(p);
            assert!(v.abs() <= 1.1, "{p}: {v}");
            differ += usize::from(v != Perlin::new(8).noise(p));
        }
        assert!(differ > 900, "another seed, another noise");
    }

    #[test]
    fn marble_blends_its_two_colours_and_survives_any_point() {
        let m = Marble {
            base: Color::ONE,
            vein: Color::ZERO,
            turbulence: 2.0,
            octaves: 4,
            noise: Perlin::new(0),
            mapping: Mapping::new(Coords::Object),
        };
        let mut lo: f64 = 1.0;
        let mut hi: f64 = 0.0;
        for i in 0..2000 {
            let local = DVec3::new(i as f64 * 0.0173, 0.3, (i as f64 * 0.05).cos());
            let c = m.eval(&TexturePoint::new(DVec2::ZERO, local));
            assert!(c.min_element() >= 0.0 && c.max_element() <= 1.0 && c.x == c.y);
            lo = lo.min(c.x);
            hi = hi.max(c.x);
        }
        assert!(lo < 0.05 && hi > 0.95, "veins and stone both appear: {lo}..{hi}");
        for bad in [DVec3::NAN, DVec3::INFINITY] {
            assert_eq!(m.eval(&TexturePoint::new(DVec2::ZERO, bad)), Color::ONE);
        }
    }
}
