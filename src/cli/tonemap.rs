//! `lumen tonemap IN OUT`: converts between image formats, tone-mapping when the output
//! is 8-bit.

use std::path::PathBuf;

use anyhow::{bail, Context as _, Result};
use clap::Args;

use crate::image::{is_hdr_path, read_image, write_image, Curve, ImageFormat, ToneMap};

const AFTER_HELP: &str = "\
Formats (by extension, any case): .pfm .exr .hdr hold linear radiance; .png .jpg .jpeg hold
8-bit sRGB. An 8-bit output is tone-mapped; a linear output gets the pixels unchanged (a
format conversion; tone-mapping options are then refused). An 8-bit input is decoded from
sRGB to linear first. The output is written atomically; NaN or infinite pixels are written
as black, with one warning.

Curves:
  aces      (default) x = 2^E·c, Narkowicz's ACES fit x(2.51x+0.03)/(x(2.43x+0.59)+0.14)
            clamped to [0,1], then sRGB encoding. Independent of image statistics.
  exposure  x = 2^E·c, clipped to [0,1], then sRGB encoding.
  reinhard  Raytracer.jl's pipeline: x = α·c/L, where L is --luminosity or the image's
            log-average 10^(Σ log10(δ + lᵢ)/N) of pixel luminosities lᵢ = (max+min)/2
            (δ = f32 epsilon, NaN/Inf pixels left out); then x/(1+x); then x^(1/γ).
            Defaults α = 0.18, γ = 2.2 (a display gamma).

To reproduce Raytracer.jl exactly:
  lumen tonemap in.pfm out.png --curve reinhard --alpha 0.5 --gamma 1
(add --luminosity L to fix the normalisation instead of measuring it from the image).";

/// Tone-map or convert an image file (PFM, OpenEXR, Radiance HDR, PNG, JPEG).
#[derive(Debug, Args)]
#[command(after_long_help = AFTER_HELP)]
pub struct TonemapArgs {
    /// Input image (.pfm, .exr, .hdr, .png, .jpg, .jpeg)
    pub input: PathBuf,
    /// Output image; .png/.jpg/.jpeg are tone-mapped, .pfm/.exr/.hdr get linear values
    pub output: PathBuf,
    /// Tone-mapping curve [default: aces]
    #[arg(long, value_enum)]
    pub curve: Option<Curve>,
    /// Reinhard only: key α the image luminosity is normalised to [default: 0.18]
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub alpha: Option<f32>,
    /// Reinhard only: encode with x^(1/γ); 1 = no encoding [default: 2.2]
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub gamma: Option<f32>,
    /// Reinhard only: normalise by this luminosity instead of the image's log-average
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub luminosity: Option<f32>,
    /// Aces and exposure only: exposure in stops; pixels are scaled by 2^E [default: 0]
    #[arg(long, value_parser = finite, allow_hyphen_values = true)]
    pub exposure: Option<f32>,
}

/// Parses `s` as f32, saying why a number it does not take is refused: one past f32's
/// range (`1e39`, which f32 parses as infinity) is "too large", not "not finite", and a
/// positive one that f32 rounds to 0 (`1e-50`) is "too small", not "not > 0".
fn number(s: &str, positive: bool) -> Result<f32, String> {
    let t = s.trim();
    // Digits: a number written out (`1e400`, infinite as f64 too), not "inf".
    let written_out = t.bytes().any(|b| b.is_ascii_digit());
    let (range, wanted) = if positive {
        ("> 0 and at most 3.4e38", "a finite number > 0")
    } else {
        ("from -3.4e38 to 3.4e38", "a finite number")
    };
    match (t.parse::<f32>(), t.parse::<f64>()) {
        (Ok(v), _) if v.is_finite() && (!positive || v > 0.0) => Ok(v),
        (_, Ok(x)) if written_out && x.abs() > f64::from(f32::MAX) && (!positive || x > 0.0) => {
            Err(format!("{t} is too large; expected a number {range} (f32's range)"))
        }
        // Here a positive x under 1 is one that f32 rounded to 0.
        (_, Ok(x)) if positive && x > 0.0 && x < 1.0 => {
            Err(format!("{t} is too small; expected a number > 0 and at least 1.4e-45 (f32's range)"))
        }
        _ => Err(format!("expected {wanted}, got {s:?}")),
    }
}

fn finite(s: &str) -> Result<f32, String> {
    number(s, false)
}

/// A tone-mapping number > 0 within f32's range (also `lumen render`'s `--alpha` and
/// `--gamma`), refused in [`number`]'s words.
pub(super) fn positive(s: &str) -> Result<f32, String> {
    number(s, true)
}

impl TonemapArgs {
    /// The tone map the options describe, refusing options that the chosen curve (or a
    /// linear output) would silently ignore.
    pub fn tone_map(&self) -> Result<ToneMap> {
        let reinhard_opts = self.alpha.is_some() || self.gamma.is_some() || self.luminosity.is_some();
        let any_opts = reinhard_opts || self.curve.is_some() || self.exposure.is_some();
        if any_opts && is_hdr_path(&self.output) {
            bail!(
                "{}: a linear HDR output is not tone-mapped, so --curve, --alpha, --gamma, --luminosity and \
                 --exposure do not apply (write .png or .jpg to tone-map)",
                self.output.display()
            );
        }
        let base = ToneMap::default();
        let curve = self.curve.unwrap_or(base.curve);
        if reinhard_opts && curve != Curve::Reinhard {
            bail!("--alpha, --gamma and --luminosity apply only to --curve reinhard");
        }
        if self.exposure.is_some() && curve == Curve::Reinhard {
            bail!("--exposure does not apply to --curve reinhard (use --alpha or --luminosity)");
        }
        Ok(ToneMap {
            curve,
            alpha: self.alpha.unwrap_or(base.alpha),
            gamma: self.gamma.unwrap_or(base.gamma),
            luminosity: self.luminosity,
            exposure: self.exposure.unwrap_or(base.exposure),
        })
    }
}

/// Reads, tone-maps (for 8-bit outputs) and writes; warns once about NaN/Inf pixels.
pub fn run(args: TonemapArgs) -> Result<()> {
    // Refuse a bad output name or place before spending time on the input.
    ImageFormat::from_path(&args.output)?;
    crate::image::check_destination(&args.output).with_context(|| format!("cannot write {}", args.output.display()))?;
    let tm = args.tone_map()?;
    let img = read_image(&args.input)?;
    let report = write_image(&args.output, &img, &tm)?;
    if report.non_finite > 0 {
        crate::diag!(
            "warning: {} of {} pixels in {} are NaN or infinite; they were written as black",
            report.non_finite,
            img.pixels().len(),
            args.input.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        args: TonemapArgs,
    }

    fn parse(argv: &[&str]) -> Result<ToneMap> {
        let w = Wrap::try_parse_from(std::iter::once("tonemap").chain(argv.iter().copied()))?;
        w.args.tone_map()
    }

    #[test]
    fn defaults_are_the_library_defaults() {
        assert_eq!(parse(&["a.pfm", "b.png"]).unwrap(), ToneMap::default());
    }

    #[test]
    fn raytracer_jl_recipe_from_the_help_is_exact() {
        let tm = parse(&["a.pfm", "b.png", "--curve", "reinhard", "--alpha", "0.5", "--gamma", "1"]).unwrap();
        assert_eq!(tm, ToneMap::raytracer_jl());
    }

    #[test]
    fn options_are_parsed() {
        let tm = parse(&["a.pfm", "b.png", "--curve", "exposure", "--exposure", "-1.5"]).unwrap();
        assert_eq!((tm.curve, tm.exposure), (Curve::Exposure, -1.5));
        let tm = parse(&["a.pfm", "b.png", "--curve", "reinhard", "--luminosity", "3"]).unwrap();
        assert_eq!(tm.luminosity, Some(3.0));
    }

    #[test]
    fn misplaced_or_invalid_options_are_refused() {
        assert!(parse(&["a.pfm", "b.png", "--alpha", "0.5"]).is_err());
        assert!(parse(&["a.pfm", "b.png", "--curve", "reinhard", "--exposure", "1"]).is_err());
        assert!(parse(&["a.pfm", "b.exr", "--curve", "aces"]).is_err());
        assert!(parse(&["a.pfm", "b.png", "--curve", "reinhard", "--alpha", "0"]).is_err());
        assert!(parse(&["a.pfm", "b.png", "--curve", "reinhard", "--gamma", "nan"]).is_err());
        assert!(parse(&["a.pfm", "b.png", "--curve", "filmic"]).is_err());
        assert!(parse(&["a.pfm", "b.exr"]).is_ok());
    }

    #[test]
    fn numbers_past_f32s_range_say_so() {
        // Finite numbers that f32 parses as infinity or rounds to 0 were "not finite" or "not > 0".
        for (value, says) in [
            ("1e39", "1e39 is too large; expected a number > 0 and at most 3.4e38 (f32's range)"),
            ("3.5e38", "3.5e38 is too large; expected a number > 0 and at most 3.4e38 (f32's range)"),
            ("1e300", "1e300 is too large; expected a number > 0 and at most 3.4e38 (f32's range)"),
            ("1e400", "1e400 is too large; expected a number > 0 and at most 3.4e38 (f32's range)"),
            ("1e-50", "1e-50 is too small; expected a number > 0 and at least 1.4e-45 (f32's range)"),
            ("-1e39", "expected a finite number > 0, got \"-1e39\""),
            ("inf", "expected a finite number > 0, got \"inf\""),
        ] {
            assert_eq!(positive(value).unwrap_err(), says, "{value}");
        }
        assert_eq!(
            finite("-1e39").unwrap_err(),
            "-1e39 is too large; expected a number from -3.4e38 to 3.4e38 (f32's range)"
        );
        assert_eq!(finite("NaN").unwrap_err(), "expected a finite number, got \"NaN\"");
        assert_eq!(finite("1e-50"), Ok(0.0));
        assert_eq!(positive("3.4028235e38"), Ok(f32::MAX));
        assert_eq!(finite(" -2.5 "), Ok(-2.5));
        let e = parse(&["a.pfm", "b.png", "--curve", "reinhard", "--alpha", "1e39"]).unwrap_err().to_string();
        assert!(e.contains("1e39 is too large") && e.contains("3.4e38"), "{e}");
    }
}
