//! Whole-number command-line values (sizes, counts, seeds), parsed with messages a person
//! reads. clap's own integer parsers answer `--width 4.5` with Rust's "invalid digit found
//! in string" and `--spp 99999999999` with the integer type's range; and without
//! `allow_negative_numbers` on the argument, `--width -4` is taken for an unknown flag
//! with the advice to write `-- -4`. Arguments parsed by [`whole`] say what they accept.

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
