//! Tone mapping: linear radiance → display values in [0, 1] for 8-bit files.
//!
//! Three curves, each a scale step, a compression curve and an encoding:
//!
//! | curve | scale | curve | encoding |
//! |---|---|---|---|
//! | [`Curve::Reinhard`] | `α / L̄` (L̄ = `luminosity` or the image's log-average) | `x / (1 + x)` | `x^(1/γ)` |
//! | [`Curve::Aces`] | `2^exposure` | Narkowicz's ACES fit, clamped to [0, 1] | sRGB |
//! | [`Curve::Exposure`] | `2^exposure` | clamp to [0, 1] | sRGB |
//!
//! `Reinhard` is Raytracer.jl's pipeline, step for step ([`ToneMap::raytracer_jl`]); its
//! `alpha`, `gamma` and `luminosity` apply to it only, `exposure` to the other two only.
//! Non-finite pixels are counted and treated as black: they are left out of the luminosity
//! average and come out black. Negative channels (only difference images have them) are
//! treated as 0.

use thiserror::Error;

use super::srgb::{linear_to_srgb, quantize_u8};
use super::HdrImage;
use crate::color::Rgb32;

/// δ in the log-average luminosity, as in Raytracer.jl: keeps black pixels finite.
pub const LUMINOSITY_DELTA: f32 = f32::EPSILON;

/// The compression curve of a [`ToneMap`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Curve {
    /// Raytracer.jl: normalise to key α by the image luminosity, x/(1+x), x^(1/γ).
    Reinhard,
    /// Narkowicz's fit of the ACES filmic curve after 2^exposure, then sRGB.
    #[default]
    Aces,
    /// 2^exposure, clip to [0, 1], then sRGB.
    Exposure,
}

/// How to turn linear radiance into display values.
///
/// ```
/// use lumen::image::{HdrImage, ToneMap};
/// use lumen::color::Rgb32;
/// let img = HdrImage::from_fn(3, 2, |c, r| {
///     let k = (3 * (c + 3 * r)) as f32; // pixels (1,2,3), (4,5,6), … row-major
///     Rgb32::new(k + 1.0, k + 2.0, k + 3.0)
/// });
/// let out = ToneMap { alpha: 1.0, ..ToneMap::raytracer_jl() }.apply(&img).unwrap();
/// assert!(out.image[(0, 0)].approx_eq(Rgb32::new(0.11485995, 0.20605269, 0.28021002), 1e-6));
/// assert_eq!(out.non_finite, 0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToneMap {
    /// Which pipeline runs; it decides which of the fields below are used.
    pub curve: Curve,
    /// Reinhard only: the key the image luminosity is normalised to (> 0).
    pub alpha: f32,
    /// Reinhard only: the encoding is `x^(1/gamma)` (> 0; 1 = none).
    pub gamma: f32,
    /// Reinhard only: the luminosity to normalise by (> 0); `None` = the image's
    /// log-average [`average_luminosity`]. Fix it to tone-map an animation consistently.
    pub luminosity: Option<f32>,
    /// Aces and Exposure only: exposure in stops, the image is scaled by `2^exposure`.
    pub exposure: f32,
}

impl Default for ToneMap {
    /// ACES filmic at exposure 0, sRGB-encoded: independent of image statistics (so dark
    /// backgrounds do not blow the rest out, as they do with a log-average key), soft
    /// highlights, correct for sRGB displays. The Reinhard fields hold Reinhard's own
    /// defaults (key 0.18, display gamma 2.2) for when the curve is switched.
    fn default() -> Self {
        Self { curve: Curve::Aces, alpha: 0.18, gamma: 2.2, luminosity: None, exposure: 0.0 }
    }
}

/// Why a [`ToneMap`] was refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ToneMapError {
    /// Reinhard's key `alpha` (the value given) is not a finite number above zero.
    #[error("alpha must be a finite number > 0, got {0}")]
    Alpha(f32),
    /// Reinhard's `gamma` (the value given) is not a finite number above zero.
    #[error("gamma must be a finite number > 0, got {0}")]
    Gamma(f32),
    /// A fixed Reinhard `luminosity` (the value given) is not a finite number above zero.
    #[error("luminosity must be a finite number > 0, got {0}")]
    Luminosity(f32),
    /// The ACES or Exposure curve's `exposure` (the value given, in stops) is NaN or infinite.
    #[error("exposure must be a finite number of stops, got {0}")]
    Exposure(f32),
}

/// The result of [`ToneMap::apply`].
#[derive(Debug, Clone, PartialEq)]
pub struct ToneMapped {
    /// Display values in [0, 1], already encoded (gamma or sRGB): quantise and store.
    pub image: HdrImage,
    /// How many input pixels were NaN or infinite (they come out black).
    pub non_finite: usize,
    /// Reinhard only: the luminosity L the image was normalised by (given or measured);
    /// pass it back as [`ToneMap::luminosity`] to map other frames identically.
    pub luminosity: Option<f32>,
}

impl ToneMapped {
    /// The image as 8-bit RGB bytes, row-major from the top-left.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.image.pixels().iter().flat_map(|c| c.to_array().map(quantize_u8)).collect()
    }
}

impl ToneMap {
    /// Raytracer.jl's tone mapping exactly: α = 0.5, γ = 1, luminosity from the image,
    /// Reinhard clamp.
    pub fn raytracer_jl() -> Self {
        Self { curve: Curve::Reinhard, alpha: 0.5, gamma: 1.0, luminosity: None, exposure: 0.0 }
    }

    /// Checks the parameters the chosen curve uses.
    pub fn validate(&self) -> Result<(), ToneMapError> {
        let positive = |v: f32| v.is_finite() && v > 0.0;
        match self.curve {
            Curve::Reinhard => {
                if !positive(self.alpha) {
                    return Err(ToneMapError::Alpha(self.alpha));
                }
                if !positive(self.gamma) {
                    return Err(ToneMapError::Gamma(self.gamma));
                }
                match self.luminosity {
                    Some(l) if !positive(l) => Err(ToneMapError::Luminosity(l)),
                    _ => Ok(()),
                }
            }
            Curve::Aces | Curve::Exposure if !self.exposure.is_finite() => Err(ToneMapError::Exposure(self.exposure)),
            Curve::Aces | Curve::Exposure => Ok(()),
        }
    }

    /// Tone-maps `img` to display values in [0, 1].
    pub fn apply(&self, img: &HdrImage) -> Result<ToneMapped, ToneMapError> {
        self.validate()?;
        let non_finite = img.non_finite_count();
        let mut luminosity = None;
        let image = match self.curve {
            Curve::Reinhard => {
                let lum = self.luminosity.map_or_else(|| average_luminosity_f64(img), f64::from);
                luminosity = Some(lum as f32);
                let scale = f64::from(self.alpha) / lum;
                let inv_gamma = 1.0 / f64::from(self.gamma);
                map_finite(img, |v| reinhard(v * scale).powf(inv_gamma))
            }
            Curve::Aces => {
                let scale = f64::from(self.exposure).exp2();
                map_finite(img, |v| f64::from(linear_to_srgb(aces_narkowicz(v * scale) as f32)))
            }
            Curve::Exposure => {
                let scale = f64::from(self.exposure).exp2();
                map_finite(img, |v| f64::from(linear_to_srgb((v * scale).min(1.0) as f32)))
            }
        };
        Ok(ToneMapped { image, non_finite, luminosity })
    }
}

/// Applies `f` (in f64) to each channel of each finite pixel, with negative channels as 0;
/// non-finite pixels become black.
fn map_finite(img: &HdrImage, f: impl Fn(f64) -> f64) -> HdrImage {
    img.map(|c| if c.is_finite() { c.map(|v| f(f64::from(v.max(0.0))) as f32) } else { Rgb32::BLACK })
}

/// Reinhard's (and Raytracer.jl's) clamp `x / (1 + x)`: maps [0, ∞) onto [0, 1).
pub fn reinhard(x: f64) -> f64 {
    x / (1.0 + x)
}

/// Krzysztof Narkowicz's 2016 fit of the ACES RRT+ODT curve,
/// `x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)` clamped to [0, 1], applied to the exposed
/// value as it is (Narkowicz pre-scales by 0.6 to match ACES's reference exposure: that is
/// `exposure = log2(0.6) ≈ -0.737`).
pub fn aces_narkowicz(x: f64) -> f64 {
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// Raytracer.jl's image luminosity: the log-average `10^(Σ log10(δ + lᵢ) / N)` of the
/// pixel luminosities `lᵢ = (max + min) / 2`, with δ = [`LUMINOSITY_DELTA`]. Non-finite
/// pixels are left out (N counts the others); negative luminosities count as 0. Returns δ
/// for an image with no finite pixel.
pub fn average_luminosity(img: &HdrImage) -> f32 {
    average_luminosity_f64(img) as f32
}

fn average_luminosity_f64(img: &HdrImage) -> f64 {
    let delta = f64::from(LUMINOSITY_DELTA);
    let (sum, n) = img
        .pixels()
        .iter()
        .filter(|c| c.is_finite())
        .fold((0.0f64, 0usize), |(s, n), c| (s + (delta + f64::from(c.luminosity()).max(0.0)).log10(), n + 1));
    if n == 0 {
        delta
    } else {
        10f64.powf(sum / n as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Raytracer.jl's test image: 3×2, pixels (1,2,3), (4,5,6), …, (16,17,18) row-major.
    fn raytracer_image() -> HdrImage {
        HdrImage::from_fn(3, 2, |c, r| {
            let k = (3 * (c + 3 * r)) as f32;
            Rgb32::new(k + 1.0, k + 2.0, k + 3.0)
        })
    }

    fn close(a: Rgb32, b: Rgb32) -> bool {
        a.approx_eq(b, 1e-6)
    }

    #[test]
    fn average_luminosity_matches_raytracer_jl() {
        // Luminosities 2, 5, 8, 11, 14, 17: geometric mean (209440)^(1/6).
        let l = average_luminosity(&raytracer_image());
        assert!((l - 7.706255).abs() < 1e-5, "{l}");
        assert!((f64::from(l) - 209_440f64.powf(1.0 / 6.0)).abs() < 1e-5);
    }

    /// The order Raytracer.jl's documented numbers fix: normalise, then clamp, then
    /// `x^(1/γ)` (γ = 0.8 gives values *below* the γ = 1 ones, so the exponent is 1/γ).
    #[test]
    fn reinhard_steps_match_raytracer_jl() {
        let img = raytracer_image();
        let lum = f64::from(average_luminosity(&img));
        let normalised = img.get(0, 0).map(|v| (f64::from(v) / lum) as f32);
        assert!(close(normalised, Rgb32::new(0.12976472, 0.25952944, 0.38929415)), "{normalised:?}");

        let tm = |gamma| ToneMap { alpha: 1.0, gamma, ..ToneMap::raytracer_jl() }.apply(&img).unwrap();
        assert!(close(tm(1.0).image[(0, 0)], Rgb32::new(0.11485995, 0.20605269, 0.28021002)));
        assert!(close(tm(0.8).image[(0, 0)], Rgb32::new(0.06686684, 0.13882665, 0.20387058)));
    }

    #[test]
    fn given_luminosity_replaces_the_average() {
        let img = raytracer_image();
        let tm = ToneMap { alpha: 1.0, luminosity: Some(2.0), ..ToneMap::raytracer_jl() };
        // Pixel (4,5,6) / 2 = (2, 2.5, 3) → x/(1+x).
        let want = Rgb32::new(2.0 / 3.0, 2.5 / 3.5, 3.0 / 4.0);
        let out = tm.apply(&img).unwrap();
        assert!(close(out.image[(1, 0)], want));
        assert_eq!(out.luminosity, Some(2.0));
        let measured = ToneMap::raytracer_jl().apply(&img).unwrap().luminosity.unwrap();
        assert!((measured - 7.706255).abs() < 1e-5);
        assert_eq!(ToneMap::default().apply(&img).unwrap().luminosity, None);
    }

    #[test]
    fn raytracer_jl_uses_key_one_half() {
        let img = raytracer_image();
        let x = 0.5 * 1.0 / f64::from(average_luminosity(&img));
        let got = ToneMap::raytracer_jl().apply(&img).unwrap().image[(0, 0)].r;
        assert!((f64::from(got) - x / (1.0 + x)).abs() < 1e-6);
    }

    #[test]
    fn non_finite_pixels_are_black_and_excluded_from_the_average() {
        let mut img = raytracer_image();
        img[(1, 1)] = Rgb32::new(f32::NAN, 1.0, 1.0);
        img[(2, 1)] = Rgb32::gray(f32::INFINITY);
        // The four finite pixels have luminosities 2, 5, 8, 11.
        let want = (2.0f64 * 5.0 * 8.0 * 11.0).powf(0.25);
        assert!((f64::from(average_luminosity(&img)) - want).abs() < 1e-5);
        for tm in
            [ToneMap::raytracer_jl(), ToneMap::default(), ToneMap { curve: Curve::Exposure, ..ToneMap::default() }]
        {
            let out = tm.apply(&img).unwrap();
            assert_eq!(out.non_finite, 2);
            assert_eq!(out.image[(1, 1)], Rgb32::BLACK);
            assert_eq!(out.image[(2, 1)], Rgb32::BLACK);
            assert!(out.image.pixels().iter().all(|c| c.is_finite()));
        }
    }

    #[test]
    fn degenerate_images_do_not_produce_nan() {
        let black = HdrImage::new(2, 2);
        assert_eq!(average_luminosity(&black), LUMINOSITY_DELTA);
        let out = ToneMap::raytracer_jl().apply(&black).unwrap();
        assert!(out.image.pixels().iter().all(|&c| c == Rgb32::BLACK));
        let nan = HdrImage::from_pixels(1, 1, vec![Rgb32::gray(f32::NAN)]).unwrap();
        assert_eq!(average_luminosity(&nan), LUMINOSITY_DELTA);
        let neg = HdrImage::from_pixels(1, 1, vec![Rgb32::new(-1.0, 0.5, 2.0)]).unwrap();
        let out = ToneMap::raytracer_jl().apply(&neg).unwrap();
        assert!(out.image[(0, 0)].is_finite() && out.image[(0, 0)].r == 0.0);
    }

    #[test]
    fn aces_curve_values() {
        assert_eq!(aces_narkowicz(0.0), 0.0);
        // 1·(2.51 + 0.03) / (1·(2.43 + 0.59) + 0.14) = 2.54 / 3.16.
        assert!((aces_narkowicz(1.0) - 2.54 / 3.16).abs() < 1e-12);
        assert_eq!(aces_narkowicz(1e6), 1.0);
        let img = HdrImage::from_pixels(1, 1, vec![Rgb32::new(0.5, 1.0, 0.0)]).unwrap();
        let out = ToneMap { exposure: 1.0, ..ToneMap::default() }.apply(&img).unwrap().image[(0, 0)];
        let want = linear_to_srgb((2.54 / 3.16) as f32);
        assert!((out.r - want).abs() < 1e-6 && out.b == 0.0);
        assert!(out.g > out.r && out.g <= 1.0);
    }

    #[test]
    fn exposure_curve_is_scale_clip_srgb() {
        let img = HdrImage::from_pixels(1, 1, vec![Rgb32::new(0.1, 0.3, 4.0)]).unwrap();
        let tm = ToneMap { curve: Curve::Exposure, exposure: 1.0, ..ToneMap::default() };
        let out = tm.apply(&img).unwrap().image[(0, 0)];
        assert!(close(out, Rgb32::new(linear_to_srgb(0.2), linear_to_srgb(0.6), 1.0)));
    }

    #[test]
    fn to_rgb8_quantises_with_rounding() {
        let img = HdrImage::from_pixels(2, 1, vec![Rgb32::new(1.0, 0.5, 0.0), Rgb32::gray(f32::NAN)]).unwrap();
        let tm = ToneMap { curve: Curve::Reinhard, alpha: 1.0, gamma: 1.0, luminosity: Some(1.0), exposure: 0.0 };
        // 1 → 1/2 → 128; 0.5 → 1/3 → 85.
        assert_eq!(tm.apply(&img).unwrap().to_rgb8(), vec![128, 85, 0, 0, 0, 0]);
    }

    #[test]
    fn invalid_parameters_are_refused() {
        let r = ToneMap::raytracer_jl();
        assert_eq!(ToneMap { alpha: 0.0, ..r }.validate(), Err(ToneMapError::Alpha(0.0)));
        assert_eq!(ToneMap { gamma: -1.0, ..r }.validate(), Err(ToneMapError::Gamma(-1.0)));
        assert!(matches!(ToneMap { luminosity: Some(f32::NAN), ..r }.validate(), Err(ToneMapError::Luminosity(_))));
        let a = ToneMap::default();
        assert!(matches!(ToneMap { exposure: f32::INFINITY, ..a }.validate(), Err(ToneMapError::Exposure(_))));
        // Parameters of other curves are not checked.
        assert!(ToneMap { alpha: -1.0, ..a }.validate().is_ok());
    }
}
