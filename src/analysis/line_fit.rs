//! Least-squares straight lines, and the log-log slope that tells how error falls with
//! samples (−1 for the MSE of an unbiased Monte Carlo estimator).

/// y ≈ intercept + slope·x, with the coefficient of determination.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFit {
    /// Change in y per unit of x (for [`fit_loglog`], the power-law exponent).
    pub slope: f64,
    /// y at x = 0 (for [`fit_loglog`], log10 of y at x = 1).
    pub intercept: f64,
    /// 1 − residual / total sum of squares (1 for collinear points; 1 when y is constant).
    pub r2: f64,
}

/// Ordinary least squares over finite points; `None` with fewer than two distinct x.
pub fn fit_line(xs: &[f64], ys: &[f64]) -> Option<LineFit> {
    let pts: Vec<(f64, f64)> =
        xs.iter().zip(ys).map(|(&x, &y)| (x, y)).filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
    let n = pts.len() as f64;
    if pts.len() < 2 {
        return None;
    }
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let syy: f64 = pts.iter().map(|p| (p.1 - my).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let residual: f64 = pts.iter().map(|p| (p.1 - intercept - slope * p.0).powi(2)).sum();
    let r2 = if syy > 0.0 { 1.0 - residual / syy } else { 1.0 };
    Some(LineFit { slope, intercept, r2 })
}

/// Fit of log10 y against log10 x over the points where both are positive: `slope` is the
/// exponent of a power law y ∝ x^slope.
pub fn fit_loglog(xs: &[f64], ys: &[f64]) -> Option<LineFit> {
    let (lx, ly): (Vec<f64>, Vec<f64>) =
        xs.iter().zip(ys).filter(|(&x, &y)| x > 0.0 && y > 0.0).map(|(x, y)| (x.log10(), y.log10())).unzip();
    fit_line(&lx, &ly)
}

/// True when the last segment of a log-log curve falls at less than half the rate of the
/// whole fit: the error has stopped following the power law (bias in the renderer, or the
/// reference's own noise or accumulation error becoming the floor). Needs ≥ 3 points and a
/// falling overall trend.
pub fn tail_flattens(xs: &[f64], ys: &[f64]) -> bool {
    let Some(all) = fit_loglog(xs, ys) else { return false };
    let n = xs.len().min(ys.len());
    if n < 3 || all.slope >= 0.0 {
        return false;
    }
    match fit_loglog(&xs[n - 2..n], &ys[n - 2..n]) {
        Some(tail) => tail.slope > 0.5 * all.slope,
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_line() {
        let f = fit_line(&[0.0, 1.0, 2.0, 3.0], &[1.0, 3.0, 5.0, 7.0]).unwrap();
        assert!((f.slope - 2.0).abs() < 1e-12 && (f.intercept - 1.0).abs() < 1e-12 && (f.r2 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn hand_computed_noisy_line() {
        // x = 0,1,2; y = 0,2,1: mean x 1, mean y 1, sxy = 1, sxx = 2 → slope 1/2, intercept 1/2;
        // residuals −1/2, 1, −1/2 → 1.5 of syy 2 → r² = 1/4.
        let f = fit_line(&[0.0, 1.0, 2.0], &[0.0, 2.0, 1.0]).unwrap();
        assert!((f.slope - 0.5).abs() < 1e-12 && (f.intercept - 0.5).abs() < 1e-12 && (f.r2 - 0.25).abs() < 1e-12);
    }

    #[test]
    fn mse_inversely_proportional_to_spp_has_slope_minus_one() {
        let spp = [1.0, 4.0, 16.0, 64.0, 256.0];
        let mse: Vec<f64> = spp.iter().map(|s| 0.07 / s).collect();
        let f = fit_loglog(&spp, &mse).unwrap();
        assert!((f.slope + 1.0).abs() < 1e-12, "{f:?}");
        assert!((f.intercept - 0.07f64.log10()).abs() < 1e-12);
        assert!(!tail_flattens(&spp, &mse));
        // RMSE falls as spp^(-1/2).
        let rmse: Vec<f64> = mse.iter().map(|m| m.sqrt()).collect();
        assert!((fit_loglog(&spp, &rmse).unwrap().slope + 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_floor_is_a_plateau() {
        let spp = [1.0, 4.0, 16.0, 64.0, 256.0];
        let mse: Vec<f64> = spp.iter().map(|s| 0.1 / s + 0.01).collect();
        assert!(tail_flattens(&spp, &mse));
    }

    #[test]
    fn degenerate_input() {
        assert_eq!(fit_line(&[1.0], &[2.0]), None);
        assert_eq!(fit_line(&[1.0, 1.0], &[2.0, 3.0]), None);
        assert_eq!(fit_loglog(&[1.0, 2.0], &[0.0, -1.0]), None);
        assert_eq!(fit_line(&[0.0, 1.0, f64::NAN], &[1.0, 1.0, 5.0]).unwrap().slope, 0.0);
        assert!(!tail_flattens(&[1.0, 2.0], &[1.0, 0.5]));
    }
}
