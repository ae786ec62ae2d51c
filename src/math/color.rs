//! Linear RGB colour and its encodings.
//!
//! Colours are linear, unclamped floating-point RGB throughout rendering (HDR). They are clamped
//! and encoded only when an 8-bit image is written ([`Encoding`]).

use glam::DVec3;

/// Linear RGB radiance or reflectance, one `f64` per channel. Unbounded above (HDR); never negative
/// in a valid scene.
pub type Color = DVec3;

/// How linear values become 8-bit pixel values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Encoding {
    /// Clamp to [0, 1] and apply the sRGB transfer curve (IEC 61966-2-1). The default.
    #[default]
    Srgb,
    /// Clamp to [0, 1] and write values straight, as the report's renderer did; scenes authored
    /// for it look right only so.
    Linear,
}

impl Encoding {
    /// Parses `"srgb"` or `"linear"`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "srgb" => Some(Encoding::Srgb),
            "linear" => Some(Encoding::Linear),
            _ => None,
        }
    }

    /// The name accepted by [`Encoding::parse`].
    pub fn name(self) -> &'static str {
        match self {
            Encoding::Srgb => "srgb",
            Encoding::Linear => "linear",
        }
    }

    /// Encodes one linear channel value to 0..=255 (NaN becomes 0).
    #[inline]
    pub fn to_u8(self, v: f32) -> u8 {
        (self.display(v) * 255.0 + 0.5) as u8
    }

    /// The displayed value of one linear channel: clamped to [0, 1] and encoded, before 8-bit
    /// quantisation (NaN becomes 0). Image comparisons and contrast tests work on this.
    #[inline]
    pub fn display(self, v: f32) -> f32 {
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        match self {
            Encoding::Srgb => srgb_encode(v),
            Encoding::Linear => v,
        }
    }
}

/// The sRGB transfer function for one channel in [0, 1].
#[inline]
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

/// Inverse of [`srgb_encode`].
#[inline]
pub fn srgb_decode(v: f32) -> f32 {
    if v <= 0.040_45 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

/// Largest channel: the magnitude used when deciding whether a contribution is negligible.
#[inline]
pub fn max_channel(c: Color) -> f64 {
    c.max_element()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodings_clamp_and_round() {
        assert_eq!(Encoding::Linear.to_u8(0.5), 128);
        assert_eq!(Encoding::Srgb.to_u8(0.5), 188);
        assert_eq!(Encoding::Srgb.to_u8(2.0), 255);
        assert_eq!(Encoding::Srgb.to_u8(-1.0), 0);
        assert_eq!(Encoding::Srgb.to_u8(f32::NAN), 0);
        for i in 0..=255u8 {
            let lin = srgb_decode(i as f32 / 255.0);
            assert_eq!(Encoding::Srgb.to_u8(lin), i);
        }
    }
}
