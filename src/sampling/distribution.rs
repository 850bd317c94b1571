//! Piecewise-constant 1-D and 2-D distributions: importance sampling of environment
//! images by luminance × sin θ.
//!
//! The tables are plain vectors so the GPU packer uploads exactly the arrays the CPU
//! samples from; the sampling functions are short loops (binary search, one division)
//! that the WGSL port mirrors line by line.

/// A piecewise-constant density on [0, 1) with `n` equal cells.
///
/// `func[i]` is the (unnormalised, non-negative) value of cell i; `cdf` has `n + 1`
/// entries from 0 to 1. A function that is zero everywhere samples uniformly (its pdf is
/// then 1), so callers never divide by zero.
#[derive(Debug, Clone, PartialEq)]
pub struct Distribution1D {
    /// The cells' values, negative and non-finite ones replaced by 0.
    pub func: Vec<f64>,
    /// Normalised running sums of `func`: `cdf[i]` is the probability of cells below i.
    pub cdf: Vec<f64>,
    /// ∫ func over [0, 1) = mean of `func`.
    pub integral: f64,
}

/// A sample drawn from a [`Distribution1D`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample1D {
    /// Position in [0, 1).
    pub x: f64,
    /// Density at `x` with respect to dx.
    pub pdf: f64,
    /// Cell index containing `x`.
    pub cell: usize,
}

impl Distribution1D {
    /// Builds the table. Negative or non-finite values count as 0 (they cannot be radiance
    /// anyway, and must not poison the CDF). Panics on an empty slice.
    pub fn new(values: &[f64]) -> Self {
        Self::from_values(values.to_vec())
    }

    /// [`Self::new`], taking the values as the cell values' storage.
    pub fn from_values(mut func: Vec<f64>) -> Self {
        assert!(!func.is_empty(), "a distribution needs at least one cell");
        let n = func.len();
        for v in &mut func {
            if !(v.is_finite() && *v > 0.0) {
                *v = 0.0;
            }
        }
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0);
        for (i, f) in func.iter().enumerate() {
            cdf.push(cdf[i] + f / n as f64);
        }
        let integral = cdf[n];
        if integral > 0.0 {
            for c in cdf.iter_mut().skip(1) {
                *c /= integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f64 / n as f64;
            }
        }
        cdf[n] = 1.0;
        Self { func, cdf, integral }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.func.len()
    }
    /// Whether there are no cells: never for a table from [`Self::new`] or
    /// [`Self::from_values`], which panic on zero cells.
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Density at cell `i` with respect to dx on [0, 1).
    pub fn pdf_cell(&self, i: usize) -> f64 {
        if self.integral > 0.0 {
            self.func[i] / self.integral
        } else {
            1.0
        }
    }

    /// The cell i with `cdf[i] ≤ u < cdf[i + 1]`, skipping empty cells (binary search).
    pub fn find_cell(&self, u: f64) -> usize {
        let (mut lo, mut hi) = (0usize, self.len());
        // Invariant: cdf[lo] ≤ u and the answer is < hi.
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if self.cdf[mid] <= u {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// Inverts the CDF continuously for `u` ∈ [0, 1).
    pub fn sample(&self, u: f64) -> Sample1D {
        let cell = self.find_cell(u);
        let width = self.cdf[cell + 1] - self.cdf[cell];
        let du = if width > 0.0 { ((u - self.cdf[cell]) / width).clamp(0.0, 1.0) } else { 0.0 };
        let n = self.len() as f64;
        // Keep x strictly inside [0, 1) so the cell lookup of x gives `cell` back.
        let x = ((cell as f64 + du) / n).min((cell as f64 + 1.0) / n - f64::EPSILON).max(cell as f64 / n);
        Sample1D { x, pdf: self.pdf_cell(cell), cell }
    }

    /// Density at x ∈ [0, 1).
    pub fn pdf(&self, x: f64) -> f64 {
        let n = self.len();
        let i = ((x * n as f64).max(0.0) as usize).min(n - 1);
        self.pdf_cell(i)
    }
}

/// A piecewise-constant density on [0, 1)² over a `width × height` grid, row-major with
/// row 0 first: a marginal distribution over rows and one conditional per row.
#[derive(Debug, Clone, PartialEq)]
pub struct Distribution2D {
    /// Cells per row (columns, along u).
    pub width: usize,
    /// Number of rows (along v).
    pub height: usize,
    /// One distribution over u per row.
    pub conditional: Vec<Distribution1D>,
    /// Distribution over v of each row's integral.
    pub marginal: Distribution1D,
}

/// A sample drawn from a [`Distribution2D`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample2D {
    /// Position along a row, in [0, 1).
    pub u: f64,
    /// Position across the rows, in [0, 1) (row 0 at v = 0).
    pub v: f64,
    /// Density with respect to du dv.
    pub pdf: f64,
    /// The cell (column, row) holding (u, v).
    pub col: usize,
    /// Row of the cell holding (u, v).
    pub row: usize,
}

impl Distribution2D {
    /// Builds the tables from `values[row * width + col]`. Panics if the size is wrong or
    /// zero.
    pub fn new(values: &[f64], width: usize, height: usize) -> Self {
        assert!(width > 0 && height > 0 && values.len() == width * height, "distribution size mismatch");
        Self::from_rows(width, height, |row| values[row * width..][..width].to_vec())
    }

    /// Builds the tables from each row's `width` values, `row(r)`, computed in parallel
    /// (each row on its own, so the tables do not depend on the threads) and kept as the
    /// rows' cell values, with no image-sized array of values beside them: a 16384×8192
    /// sky's tables took 3 s on one core and 1 GB more memory that way. Panics if a row's
    /// length is not `width` or a size is zero.
    ///
    /// ```
    /// use lumen::sampling::distribution::Distribution2D;
    /// let d = Distribution2D::from_rows(2, 2, |row| vec![1.0, 3.0 * row as f64]);
    /// assert_eq!(d, Distribution2D::new(&[1.0, 0.0, 1.0, 3.0], 2, 2));
    /// // Row 1 holds 2 of the marginal's 1.25, and its cell 1 holds 3 of the row's 2.
    /// assert_eq!(d.pdf(0.75, 0.75), (2.0 / 1.25) * (3.0 / 2.0));
    /// ```
    pub fn from_rows(width: usize, height: usize, row: impl Fn(usize) -> Vec<f64> + Sync) -> Self {
        use rayon::prelude::*;
        assert!(width > 0 && height > 0, "distribution size mismatch");
        let conditional: Vec<Distribution1D> = (0..height)
            .into_par_iter()
            .map(|r| {
                let values = row(r);
                assert_eq!(values.len(), width, "distribution size mismatch");
                Distribution1D::from_values(values)
            })
            .collect();
        let row_integrals: Vec<f64> = conditional.iter().map(|d| d.integral).collect();
        let marginal = Distribution1D::new(&row_integrals);
        Self { width, height, conditional, marginal }
    }

    /// Draws (u, v): v from the marginal with `xi_v`, then u from that row with `xi_u`.
    pub fn sample(&self, xi_u: f64, xi_v: f64) -> Sample2D {
        let v = self.marginal.sample(xi_v);
        let u = self.conditional[v.cell].sample(xi_u);
        Sample2D { u: u.x, v: v.x, pdf: u.pdf * v.pdf, col: u.cell, row: v.cell }
    }

    /// Density at (u, v) with respect to du dv.
    pub fn pdf(&self, u: f64, v: f64) -> f64 {
        let row = ((v * self.height as f64).max(0.0) as usize).min(self.height - 1);
        self.marginal.pdf_cell(row) * self.conditional[row].pdf(u)
    }

    /// Words of [`Self::packed`] for a `width × height` grid: the marginal's table, then
    /// each row's ([`packed::len`]).
    pub const fn packed_len(width: usize, height: usize) -> usize {
        packed::len(height) + height * packed::len(width)
    }

    /// Where row `row`'s table starts in [`Self::packed`] of a `width × height` grid.
    pub const fn packed_row(row: usize, width: usize, height: usize) -> usize {
        packed::len(height) + row * packed::len(width)
    }

    /// The tables as one run of words, in the [`packed`] layout: the marginal's table, then
    /// each row's, row 0 first. The GPU uploads this (as f32) and samples from it at the
    /// offsets of [`packed`], [`Self::packed_row`] and their generated WGSL constants, so
    /// both renderers draw from the same numbers.
    pub fn packed(&self) -> impl Iterator<Item = f64> + '_ {
        std::iter::once(&self.marginal).chain(&self.conditional).flat_map(Distribution1D::packed)
    }
}

impl Distribution1D {
    /// The table as a run of [`packed::len`] words: the integral, the cell values, the CDF.
    pub fn packed(&self) -> impl Iterator<Item = f64> + '_ {
        std::iter::once(self.integral).chain(self.func.iter().copied()).chain(self.cdf.iter().copied())
    }
}

/// Offsets within the packed table of a [`Distribution1D`] of `n` cells
/// ([`Distribution1D::packed`]): its integral, then its `n` cell values, then its `n + 1`
/// CDF entries. The WGSL that reads such tables gets these numbers as generated constants
/// (`gpu::layout::tags_wgsl`: `DIST1D_*`), never typed out again.
pub mod packed {
    /// Offset of the integral.
    pub const INTEGRAL: usize = 0;
    /// Offset of the first cell value.
    pub const VALUES: usize = 1;

    /// Offset of the first CDF entry: after the `n` values.
    pub const fn cdf(n: usize) -> usize {
        VALUES + n
    }

    /// Words in the whole table: the CDF has one entry more than there are cells.
    pub const fn len(n: usize) -> usize {
        cdf(n) + n + 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_d_cdf_and_inversion_are_exact() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        assert_eq!(d.cdf, vec![0.0, 0.25, 0.25, 1.0]);
        assert!((d.integral - 4.0 / 3.0).abs() < 1e-15);
        // u = 0.125 is half-way through cell 0.
        let s = d.sample(0.125);
        assert_eq!(s.cell, 0);
        assert!((s.x - 1.0 / 6.0).abs() < 1e-15);
        assert!((s.pdf - 0.75).abs() < 1e-15);
        // The empty cell is never chosen, even at its exact CDF value.
        let s = d.sample(0.25);
        assert_eq!(s.cell, 2);
        assert!((s.x - 2.0 / 3.0).abs() < 1e-15);
        assert!((s.pdf - 2.25).abs() < 1e-15);
        assert_eq!(d.pdf(0.5), 0.0);
        // The density integrates to 1.
        let total: f64 = (0..3).map(|i| d.pdf_cell(i) / 3.0).sum();
        assert!((total - 1.0).abs() < 1e-15);
    }

    #[test]
    fn all_zero_and_bad_values_sample_uniformly() {
        let d = Distribution1D::new(&[0.0, f64::NAN, -1.0, 0.0]);
        assert_eq!(d.integral, 0.0);
        let s = d.sample(0.6);
        assert_eq!(s.cell, 2);
        assert!((s.x - 0.6).abs() < 1e-15);
        assert_eq!(s.pdf, 1.0);
    }

    #[test]
    fn two_d_sample_frequencies_match_the_pdf() {
        // 3 × 2 grid; stratified uniforms give cell frequencies equal to the cell masses.
        let vals = [1.0, 2.0, 3.0, 0.0, 4.0, 2.0];
        let d = Distribution2D::new(&vals, 3, 2);
        let total: f64 = vals.iter().sum();
        let n = 300;
        let mut counts = [0usize; 6];
        for i in 0..n {
            for j in 0..n {
                let s = d.sample((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let col = (s.u * 3.0) as usize;
                let row = (s.v * 2.0) as usize;
                counts[row * 3 + col] += 1;
                assert!((s.pdf - d.pdf(s.u, s.v)).abs() < 1e-12);
                assert!((s.pdf - vals[row * 3 + col] / total * 6.0).abs() < 1e-12);
            }
        }
        for (c, v) in counts.iter().zip(vals) {
            let expected = v / total;
            assert!((*c as f64 / (n * n) as f64 - expected).abs() < 2.0 / n as f64, "{c} vs {expected}");
        }
    }

    /// The packed words at the `packed` offsets, worked out by hand for a 4 × 2 grid whose
    /// sums are exact in binary: the layout's one description agrees with what `packed`
    /// writes.
    #[test]
    fn packed_tables_sit_at_their_offsets() {
        let vals = [1.0, 1.0, 2.0, 4.0, 0.0, 4.0, 2.0, 2.0];
        let d = Distribution2D::new(&vals, 4, 2);
        let words: Vec<f64> = d.packed().collect();
        assert_eq!(words.len(), Distribution2D::packed_len(4, 2));
        assert_eq!(words.len(), (1 + 2 + 3) + 2 * (1 + 4 + 5));
        // The marginal: both rows' integrals (means) are 2.
        assert_eq!(words[packed::INTEGRAL], 2.0);
        assert_eq!(&words[packed::VALUES..][..2], &[2.0, 2.0]);
        assert_eq!(&words[packed::cdf(2)..][..3], &[0.0, 0.5, 1.0]);
        let rows =
            [([1.0, 1.0, 2.0, 4.0], [0.0, 0.125, 0.25, 0.5, 1.0]), ([0.0, 4.0, 2.0, 2.0], [0.0, 0.0, 0.5, 0.75, 1.0])];
        for (row, (values, cdf)) in rows.iter().enumerate() {
            let base = Distribution2D::packed_row(row, 4, 2);
            assert_eq!(words[base + packed::INTEGRAL], 2.0);
            assert_eq!(&words[base + packed::VALUES..][..4], values);
            assert_eq!(&words[base + packed::cdf(4)..][..5], cdf);
        }
    }
}
