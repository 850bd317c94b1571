//! Result tables: the rows `lumen converge` measures, as CSV and Markdown.

use super::line_fit::{fit_loglog, tail_flattens, LineFit};

/// One render of a convergence study.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvergeRow {
    /// The device that rendered it, `cpu` or `gpu`; rows are grouped by it.
    pub device: String,
    /// Camera samples per pixel of the render.
    pub spp: u32,
    /// Wall time of the render call.
    pub seconds: f64,
    /// Mean squared error per channel against the reference image ([`mse`](super::mse)).
    pub mse: f64,
    /// Root of `mse`, in radiance units.
    pub rmse: f64,
    /// Relative MSE against the reference ([`rel_mse`](super::rel_mse)).
    pub rel_mse: f64,
}

impl ConvergeRow {
    /// Monte Carlo efficiency 1/(MSE·seconds): how much error a second buys, comparable
    /// across devices and sample counts (higher is better; infinite for an exact image).
    pub fn efficiency(&self) -> f64 {
        1.0 / (self.mse * self.seconds)
    }
}

/// The rows of a study, in the order they were measured.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConvergeTable {
    /// One row per render, in measuring order; [`devices`](Self::devices) and
    /// [`rows_of`](Self::rows_of) split them by device.
    pub rows: Vec<ConvergeRow>,
}

/// Column names shared by the CSV and Markdown forms.
const HEADERS: [&str; 7] = ["device", "spp", "seconds", "rmse", "mse", "rel_mse", "efficiency"];

impl ConvergeTable {
    /// Devices in first-seen order.
    pub fn devices(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        for r in &self.rows {
            if !out.contains(&r.device.as_str()) {
                out.push(&r.device);
            }
        }
        out
    }

    /// The rows of one device.
    pub fn rows_of<'a>(&'a self, device: &'a str) -> impl Iterator<Item = &'a ConvergeRow> + 'a {
        self.rows.iter().filter(move |r| r.device == device)
    }

    /// Fit of log MSE against log spp for `device` (≈ −1 for an unbiased renderer), and
    /// whether the last points flatten (see [`tail_flattens`]).
    pub fn mse_slope(&self, device: &str) -> Option<(LineFit, bool)> {
        let (spp, mse): (Vec<f64>, Vec<f64>) = self.rows_of(device).map(|r| (f64::from(r.spp), r.mse)).unzip();
        fit_loglog(&spp, &mse).map(|f| (f, tail_flattens(&spp, &mse)))
    }

    fn cells(r: &ConvergeRow) -> Vec<String> {
        vec![
            r.device.clone(),
            r.spp.to_string(),
            format!("{:.6}", r.seconds),
            format!("{:.6e}", r.rmse),
            format!("{:.6e}", r.mse),
            format!("{:.6e}", r.rel_mse),
            format!("{:.6e}", r.efficiency()),
        ]
    }

    /// Comma-separated values with a header line (device names never contain commas: they
    /// are `cpu` / `gpu`).
    pub fn to_csv(&self) -> String {
        let mut out = HEADERS.join(",");
        out.push('\n');
        for r in &self.rows {
            out.push_str(&Self::cells(r).join(","));
            out.push('\n');
        }
        out
    }

    /// A Markdown table with the same columns as the CSV.
    pub fn to_markdown(&self) -> String {
        let rows: Vec<Vec<String>> = self.rows.iter().map(Self::cells).collect();
        markdown_table(&HEADERS, &rows)
    }
}

/// A GitHub-flavoured Markdown table; `|` in cells is escaped.
pub fn markdown_table(headers: &[&str], rows: &[Vec<String>]) -> String {
    let line = |cells: &mut dyn Iterator<Item = String>| -> String {
        let cells: Vec<String> = cells.map(|c| c.replace('|', "\\|")).collect();
        format!("| {} |\n", cells.join(" | "))
    };
    let mut out = line(&mut headers.iter().map(|h| h.to_string()));
    out.push_str(&format!("|{}\n", "---|".repeat(headers.len())));
    for r in rows {
        out.push_str(&line(&mut r.iter().cloned()));
    }
    out
}

/// Seconds with a unit that keeps three significant digits readable (ns … s).
pub fn format_seconds(s: f64) -> String {
    if !s.is_finite() {
        "n/a".to_string()
    } else if s >= 1.0 {
        format!("{s:.3} s")
    } else if s >= 1e-3 {
        format!("{:.3} ms", s * 1e3)
    } else if s >= 1e-6 {
        format!("{:.3} µs", s * 1e6)
    } else {
        format!("{:.3} ns", s * 1e9)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(device: &str, spp: u32, seconds: f64, mse: f64) -> ConvergeRow {
        ConvergeRow { device: device.into(), spp, seconds, mse, rmse: mse.sqrt(), rel_mse: 2.0 * mse }
    }

    #[test]
    fn csv_and_markdown_hold_every_row() {
        let t = ConvergeTable { rows: vec![row("cpu", 1, 0.5, 0.04), row("gpu", 1, 0.25, 0.04)] };
        let csv = t.to_csv();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "device,spp,seconds,rmse,mse,rel_mse,efficiency");
        assert_eq!(lines.len(), 3);
        let cells: Vec<&str> = lines[1].split(',').collect();
        assert_eq!((cells[0], cells[1]), ("cpu", "1"));
        assert!((cells[3].parse::<f64>().unwrap() - 0.2).abs() < 1e-9);
        assert!((cells[6].parse::<f64>().unwrap() - 50.0).abs() < 1e-4); // 1/(0.04·0.5)
        let md = t.to_markdown();
        assert_eq!(md.lines().count(), 4);
        assert!(md.starts_with("| device | spp |") && md.lines().nth(1).unwrap() == "|---|---|---|---|---|---|---|");
        assert_eq!(t.devices(), vec!["cpu", "gpu"]);
    }

    #[test]
    fn slope_per_device() {
        let mut t = ConvergeTable::default();
        for s in [1, 4, 16, 64] {
            t.rows.push(row("cpu", s, 0.1 * f64::from(s), 0.5 / f64::from(s)));
            t.rows.push(row("gpu", s, 0.01 * f64::from(s), 0.5 / f64::from(s) + 0.05));
        }
        let (cpu, cpu_flat) = t.mse_slope("cpu").unwrap();
        assert!((cpu.slope + 1.0).abs() < 1e-12 && !cpu_flat);
        let (_, gpu_flat) = t.mse_slope("gpu").unwrap();
        assert!(gpu_flat);
        assert!(t.mse_slope("tpu").is_none());
    }

    #[test]
    fn markdown_escapes_pipes_and_seconds_pick_units() {
        assert_eq!(markdown_table(&["a"], &[vec!["x|y".into()]]), "| a |\n|---|\n| x\\|y |\n");
        assert_eq!(format_seconds(2.0), "2.000 s");
        assert_eq!(format_seconds(0.0015), "1.500 ms");
        assert_eq!(format_seconds(2.5e-8), "25.000 ns");
        assert_eq!(format_seconds(f64::NAN), "n/a");
    }
}
