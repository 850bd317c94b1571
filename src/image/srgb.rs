//! The sRGB transfer function (IEC 61966-2-1), used to decode 8-bit textures to linear
//! values and to encode tone-mapped values for 8-bit files.

/// sRGB-encoded value in [0, 1] → linear value in [0, 1].
///
/// ```
/// use lumen::image::{linear_to_srgb, srgb_to_linear};
/// assert_eq!(srgb_to_linear(1.0), 1.0);
/// assert!((srgb_to_linear(linear_to_srgb(0.18)) - 0.18).abs() < 1e-6);
/// ```
pub fn srgb_to_linear(v: f32) -> f32 {
    let v = f64::from(v);
    let l = if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) };
    l as f32
}

/// Linear value → sRGB-encoded value; the input is clamped to [0, 1] first.
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = f64::from(v.clamp(0.0, 1.0));
    let e = if v <= 0.0031308 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    e as f32
}

/// A value in [0, 1] → the nearest 8-bit code (values outside are clamped, NaN → 0).
pub fn quantize_u8(v: f32) -> u8 {
    if v.is_nan() {
        0
    } else {
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_standard_at_known_points() {
        // Linear segment below the knee, power segment above (values from IEC 61966-2-1).
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-9);
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-7);
        assert!((linear_to_srgb(0.214_041_14) - 0.5).abs() < 1e-6);
        assert!((linear_to_srgb(0.002) - 0.02584).abs() < 1e-6);
        assert_eq!(linear_to_srgb(-1.0), 0.0);
        assert_eq!(linear_to_srgb(7.0), 1.0);
    }

    #[test]
    fn round_trips_every_8bit_code() {
        for code in 0..=255u8 {
            let v = f32::from(code) / 255.0;
            assert_eq!(quantize_u8(linear_to_srgb(srgb_to_linear(v))), code);
        }
    }

    #[test]
    fn quantizes_with_rounding_and_clamping() {
        assert_eq!(quantize_u8(0.5), 128);
        assert_eq!(quantize_u8(0.498), 127);
        assert_eq!(quantize_u8(-3.0), 0);
        assert_eq!(quantize_u8(2.0), 255);
        assert_eq!(quantize_u8(f32::NAN), 0);
    }
}
