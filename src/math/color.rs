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
    /// As `Linear`, but quantised by truncation, as the course's Java renderer wrote its 0–255
    /// values (`(int)` casts): its test images, matched bit for bit.
    #[serde(rename = "linear-truncated")]
    LinearTruncated,
}

/// What an 8-bit value truncated from `v × 255` may gain before its cast: the course's integer
/// values k arrive as `k / 255` rounded to `f32` (and multiplied back in `f32`), which can land
/// up to `255 · 2⁻²³ ≈ 3·10⁻⁵` below k; three times that keeps them from truncating to `k − 1`.
pub const TRUNCATION_SLACK: f32 = 1e-4;

impl Encoding {
    /// Every encoding's name, as [`Encoding::parse`] accepts it.
    pub const NAMES: [&'static str; 3] = ["srgb", "linear", "linear-truncated"];

    /// Parses `"srgb"`, `"linear"` or `"linear-truncated"`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "srgb" => Some(Encoding::Srgb),
            "linear" => Some(Encoding::Linear),
            "linear-truncated" => Some(Encoding::LinearTruncated),
            _ => None,
        }
    }

    /// The name accepted by [`Encoding::parse`].
    pub fn name(self) -> &'static str {
        match self {
            Encoding::Srgb => "srgb",
            Encoding::Linear => "linear",
            Encoding::LinearTruncated => "linear-truncated",
        }
    }

    /// Encodes one linear channel value to 0..=255 (NaN becomes 0): rounded, or truncated for
    /// [`Encoding::LinearTruncated`] (with [`TRUNCATION_SLACK`]).
    #[inline]
    pub fn to_u8(self, v: f32) -> u8 {
        match self {
            Encoding::LinearTruncated => (self.display(v) * 255.0 + TRUNCATION_SLACK).min(255.0) as u8,
            _ => (self.display(v) * 255.0 + 0.5) as u8,
        }
    }

    /// The displayed value of one linear channel: clamped to [0, 1] and encoded, before 8-bit
    /// quantisation (NaN becomes 0). Image comparisons and contrast tests work on this.
    #[inline]
    pub fn display(self, v: f32) -> f32 {
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        match self {
            Encoding::Srgb => srgb_encode(v),
            Encoding::Linear | Encoding::LinearTruncated => v,
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

/// Rec. 709 / sRGB luminance weights of linear R, G, B (they sum to 1).
pub const LUMINANCE: Color = Color::new(0.2126, 0.7152, 0.0722);

/// Luminance of linear RGB `c` (Rec. 709 / sRGB primaries; Y of CIE XYZ): what importance
/// sampling weighs colours by (lights by power) and what error estimates measure.
#[inline]
pub fn luminance(c: Color) -> f64 {
    c.dot(LUMINANCE)
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

    /// The course's `(int)` cast: a value just below a level stays below it, a level (as the
    /// `f32` the film holds, even computed in `f64` and multiplied back) stays itself.
    #[test]
    fn truncation_keeps_levels_and_drops_fractions() {
        let t = Encoding::LinearTruncated;
        assert_eq!(t.to_u8(0.5), 127, "127.5 truncates");
        assert_eq!(Encoding::Linear.to_u8(0.5), 128, "127.5 rounds");
        assert_eq!(t.to_u8(190.9 / 255.0), 190);
        assert_eq!((t.to_u8(2.0), t.to_u8(-1.0), t.to_u8(f32::NAN)), (255, 0, 0));
        for k in 0..=255u32 {
            let via_f64 = (f64::from(k) / 255.0 * 0.75 / 0.75) as f32;
            assert_eq!(u32::from(t.to_u8(k as f32 / 255.0)), k);
            assert_eq!(u32::from(t.to_u8(via_f64)), k);
        }
        assert_eq!(Encoding::parse(t.name()), Some(t));
    }
}
