//! Whole-number command-line values (sizes, counts, seeds), parsed with messages a person
//! reads. clap's own integer parsers answer `--width 4.5` with Rust's "invalid digit found
//! in string" and `--spp 99999999999` with the integer type's range; and without
//! `allow_negative_numbers` on the argument, `--width -4` is taken for an unknown flag
//! with the advice to write `-- -4`. Arguments parsed by [`whole`] say what they accept;
//! [`finite`] does the same for real numbers (f64's parser takes `nan`, `inf` and `1e400`).

/// A clap value parser for whole numbers in `lo..=hi`, as `T` (which must hold `hi`). Give
/// the argument `allow_negative_numbers = true` too, so that a negative value reaches it.
///
/// ```
/// let spp = lumen::cli::number_args::whole::<u32>(1, 64);
/// assert_eq!(spp("16"), Ok(16));
/// assert_eq!(spp("4.5").unwrap_err(), "4.5 is not a whole number; expected one from 1 to 64");
/// assert_eq!(spp("-4").unwrap_err(), "-4 is negative; expected a whole number from 1 to 64");
/// assert_eq!(spp("0").unwrap_err(), "0 is not in 1..=64");
/// assert_eq!(spp("99999999999999999999").unwrap_err(), "99999999999999999999 is not in 1..=64");
/// assert_eq!(spp("x").unwrap_err(), "\"x\" is not a number; expected a whole number from 1 to 64");
/// ```
pub fn whole<T: TryFrom<u64>>(lo: u64, hi: u64) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        let t = s.trim();
        let value = match t.parse::<u64>() {
            Ok(v) => Some(v),
            // All digits but beyond u64: out of any range an argument has.
            Err(_) if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) => None,
            Err(_) => {
                return Err(match t.parse::<f64>() {
                    Ok(x) if x < 0.0 => format!("{t} is negative; expected a whole number from {lo} to {hi}"),
                    Ok(_) => format!("{t} is not a whole number; expected one from {lo} to {hi}"),
                    Err(_) => format!("{t:?} is not a number; expected a whole number from {lo} to {hi}"),
                })
            }
        };
        value
            .filter(|v| (lo..=hi).contains(v))
            .and_then(|v| T::try_from(v).ok())
            .ok_or(format!("{t} is not in {lo}..={hi}"))
    }
}

/// A clap value parser for a finite real number (`--time`). Give the argument
/// `allow_negative_numbers = true` too.
///
/// ```
/// use lumen::cli::number_args::finite;
/// assert_eq!(finite("-2.5"), Ok(-2.5));
/// assert_eq!(finite("nan").unwrap_err(), "nan is not a finite number");
/// assert_eq!(finite("1e400").unwrap_err(), "1e400 is beyond f64's range (±1.8e308)");
/// assert_eq!(finite("x").unwrap_err(), "\"x\" is not a number");
/// ```
pub fn finite(s: &str) -> Result<f64, String> {
    let t = s.trim();
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        // Written out in digits (not "inf"): a number too large for f64.
        Ok(_) if t.bytes().any(|b| b.is_ascii_digit()) => Err(format!("{t} is beyond f64's range (±1.8e308)")),
        Ok(_) => Err(format!("{t} is not a finite number")),
        Err(_) => Err(format!("{t:?} is not a number")),
    }
}
