//! A log-log line plot: axes with decade ticks, grid, labels, one coloured polyline with
//! markers per series and a legend. One layout drives two surfaces: an RGB buffer (PNG,
//! labels in the built-in bitmap font) and an SVG document (vector, for the docs and the
//! browser, same geometry, text as `<text>`). Enough for convergence plots without a
//! plotting dependency or a font file (docs/DESIGN.md, "Dependencies").

use ::image::{ImageFormat, Rgb, RgbImage};

use super::font::{draw_text, text_width, GLYPH_H};

/// One line of the plot.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Name shown in the legend next to the series' colour.
    pub label: String,
    /// (x, y) in data units; points that are not positive and finite are skipped.
    pub points: Vec<(f64, f64)>,
}

/// A log-log plot: title, axis labels and series.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Plot {
    /// Text centred above the axes (and the SVG's `<title>`).
    pub title: String,
    /// Caption centred under the x axis.
    pub x_label: String,
    /// Caption along the y axis, reading bottom to top.
    pub y_label: String,
    /// The lines to draw, coloured in order from a fixed palette of six that repeats.
    pub series: Vec<Series>,
}

const PALETTE: [[u8; 3]; 6] =
    [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189], [140, 86, 75]];
const BLACK: [u8; 3] = [0, 0, 0];
const GRID: [u8; 3] = [225, 225, 225];
const SCALE: u32 = 2;
const MARGIN_LEFT: u32 = 100;
const MARGIN_RIGHT: u32 = 24;
const MARGIN_TOP: u32 = 44;
const MARGIN_BOTTOM: u32 = 70;

/// The range of log10 values to show: whole decades around the data (one decade when the
/// data is a single point).
fn decade_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let logs: Vec<f64> = values.filter(|v| v.is_finite() && *v > 0.0).map(f64::log10).collect();
    let lo = logs.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if logs.is_empty() {
        return None;
    }
    let (lo, hi) = (lo.floor(), hi.ceil());
    Some(if hi > lo { (lo, hi) } else { (lo, lo + 1.0) })
}

/// Tick values (log10) in [lo, hi]: every decade, plus 2× and 5× when few decades show.
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let dense = hi - lo <= 2.0;
    let mut e = lo;
    while e <= hi + 1e-9 {
        out.push(e);
        if dense && e < hi {
            out.push(e + 2f64.log10());
            out.push(e + 5f64.log10());
        }
        e += 1.0;
    }
    out
}

/// A short tick label: plain decimals between 0.001 and 9999, else mantissa E exponent.
pub(crate) fn tick_label(log10: f64) -> String {
    let e = log10.floor();
    let m = (10f64.powf(log10 - e)).round() as i64;
    let e = e as i32;
    if (-3..=3).contains(&e) {
        let v = m as f64 * 10f64.powi(e);
        let decimals = (-e).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{m}E{e}")
    }
}

/// What the layout draws with, in pixel coordinates (y down).
trait Surface {
    /// `text` with its top-left corner at (x, y); `vertical` reads bottom to top with
    /// (x, y) as its bottom-left corner (as [`draw_text`]).
    fn text(&mut self, s: &str, x: i64, y: i64, vertical: bool, c: [u8; 3]);
    /// The filled rectangle with corners (x0, y0) and (x1, y1), both included.
    fn rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: [u8; 3]);
    /// A line `2·half + 1` pixels thick with square ends.
    fn line(&mut self, a: (i64, i64), b: (i64, i64), half: i64, c: [u8; 3]);
}

struct Canvas {
    img: RgbImage,
}

impl Canvas {
    fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < self.img.width() && (y as u32) < self.img.height() {
            self.img.put_pixel(x as u32, y as u32, Rgb(c));
        }
    }
}

impl Surface for Canvas {
    fn text(&mut self, s: &str, x: i64, y: i64, vertical: bool, c: [u8; 3]) {
        let mut lit = Vec::new();
        draw_text(s, x, y, SCALE, vertical, |px, py| lit.push((px, py)));
        for (px, py) in lit {
            self.set(px, py, c);
        }
    }

    fn rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: [u8; 3]) {
        for y in y0..=y1 {
            for x in x0..=x1 {
                self.set(x, y, c);
            }
        }
    }

    /// Bresenham with square pens.
    fn line(&mut self, (x0, y0): (i64, i64), (x1, y1): (i64, i64), half: i64, c: [u8; 3]) {
        let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
        let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
        let (mut x, mut y, mut err) = (x0, y0, dx + dy);
        loop {
            self.rect(x - half, y - half, x + half, y + half, c);
            if x == x1 && y == y1 {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }
}

/// The SVG surface: one element per primitive, coordinates in pixels of the same layout,
/// text in a monospace font stretched to the bitmap font's width.
struct Svg {
    body: String,
}

fn rgb(c: [u8; 3]) -> String {
    format!("rgb({},{},{})", c[0], c[1], c[2])
}

/// `s` with the five XML special characters escaped.
fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

impl Surface for Svg {
    fn text(&mut self, s: &str, x: i64, y: i64, vertical: bool, c: [u8; 3]) {
        if s.is_empty() {
            return;
        }
        // Drawn horizontally at the origin (baseline at the glyph height), then placed;
        // rotate(-90) maps (u, v) to (v, −u), as `draw_text` does for vertical labels.
        let h = GLYPH_H * SCALE;
        let rotate = if vertical { " rotate(-90)" } else { "" };
        self.body += &format!(
            "<text transform=\"translate({x},{y}){rotate}\" y=\"{h}\" font-size=\"{}\" textLength=\"{}\" \
             lengthAdjust=\"spacingAndGlyphs\" fill=\"{}\">{}</text>\n",
            h + 2,
            text_width(s, SCALE),
            rgb(c),
            xml_escape(s)
        );
    }

    fn rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: [u8; 3]) {
        self.body += &format!(
            "<rect x=\"{x0}\" y=\"{y0}\" width=\"{}\" height=\"{}\" fill=\"{}\"/>\n",
            x1 - x0 + 1,
            y1 - y0 + 1,
            rgb(c)
        );
    }

    fn line(&mut self, (x0, y0): (i64, i64), (x1, y1): (i64, i64), half: i64, c: [u8; 3]) {
        // Pixel centres, so a 1-pixel line covers the raster's pixels.
        let f = |v: i64| v as f64 + 0.5;
        self.body += &format!(
            "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"{}\"/>\n",
            f(x0),
            f(y0),
            f(x1),
            f(y1),
            rgb(c),
            2 * half + 1
        );
    }
}

/// Draws `plot` on a `width × height` image (at least 320 × 240). Series without a single
/// positive point are left out of the axes but stay in the legend.
pub fn plot_loglog(plot: &Plot, width: u32, height: u32) -> RgbImage {
    let (width, height) = (width.max(320), height.max(240));
    let mut cv = Canvas { img: RgbImage::from_pixel(width, height, Rgb([255, 255, 255])) };
    layout(plot, width, height, &mut cv);
    cv.img
}

/// `plot` as a standalone SVG document of `width × height` pixels (at least 320 × 240),
/// the same layout as [`plot_loglog`].
pub fn plot_loglog_svg(plot: &Plot, width: u32, height: u32) -> String {
    let (width, height) = (width.max(320), height.max(240));
    let mut svg = Svg { body: String::new() };
    layout(plot, width, height, &mut svg);
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
         <svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" \
         viewBox=\"0 0 {width} {height}\" font-family=\"DejaVu Sans Mono, Menlo, Consolas, monospace\" \
         stroke-linecap=\"square\">\n<title>{}</title>\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n{}</svg>\n",
        xml_escape(&plot.title),
        svg.body
    )
}

/// Draws every element of the plot on `cv`.
fn layout(plot: &Plot, width: u32, height: u32, cv: &mut impl Surface) {
    let all = || plot.series.iter().flat_map(|s| s.points.iter()).filter(|(x, y)| *x > 0.0 && *y > 0.0);
    let (xr, yr) = (decade_range(all().map(|p| p.0)), decade_range(all().map(|p| p.1)));
    let (x0, y0) = (i64::from(MARGIN_LEFT), i64::from(MARGIN_TOP));
    let (x1, y1) = (i64::from(width - MARGIN_RIGHT), i64::from(height - MARGIN_BOTTOM));
    let glyph_h = i64::from(GLYPH_H * SCALE);
    let to_px = |lx: f64, ly: f64, (xlo, xhi): (f64, f64), (ylo, yhi): (f64, f64)| -> (i64, i64) {
        let px = x0 as f64 + (lx - xlo) / (xhi - xlo) * (x1 - x0) as f64;
        let py = y1 as f64 - (ly - ylo) / (yhi - ylo) * (y1 - y0) as f64;
        (px.round() as i64, py.round() as i64)
    };
    if let (Some(xr), Some(yr)) = (xr, yr) {
        for t in ticks(xr.0, xr.1) {
            let (px, _) = to_px(t, yr.0, xr, yr);
            cv.line((px, y0), (px, y1), 0, GRID);
            cv.line((px, y1), (px, y1 + 5), 0, BLACK);
            let label = tick_label(t);
            cv.text(&label, px - i64::from(text_width(&label, SCALE)) / 2, y1 + 10, false, BLACK);
        }
        for t in ticks(yr.0, yr.1) {
            let (_, py) = to_px(xr.0, t, xr, yr);
            cv.line((x0, py), (x1, py), 0, GRID);
            cv.line((x0 - 5, py), (x0, py), 0, BLACK);
            let label = tick_label(t);
            cv.text(&label, x0 - 10 - i64::from(text_width(&label, SCALE)), py - glyph_h / 2, false, BLACK);
        }
        for (i, s) in plot.series.iter().enumerate() {
            let c = PALETTE[i % PALETTE.len()];
            let pts: Vec<(i64, i64)> = s
                .points
                .iter()
                .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
                .map(|(x, y)| to_px(x.log10(), y.log10(), xr, yr))
                .collect();
            for w in pts.windows(2) {
                cv.line(w[0], w[1], 1, c);
            }
            for &(px, py) in &pts {
                cv.rect(px - 4, py - 4, px + 4, py + 4, c);
            }
        }
    }
    // Axes over the grid.
    cv.line((x0, y0), (x0, y1), 0, BLACK);
    cv.line((x0, y1), (x1, y1), 0, BLACK);
    cv.line((x1, y0), (x1, y1), 0, BLACK);
    cv.line((x0, y0), (x1, y0), 0, BLACK);
    let centred = |s: &str, from: i64, to: i64| (from + to) / 2 - i64::from(text_width(s, SCALE)) / 2;
    cv.text(&plot.title, centred(&plot.title, 0, i64::from(width)), 12, false, BLACK);
    cv.text(&plot.x_label, centred(&plot.x_label, x0, x1), y1 + 22 + glyph_h, false, BLACK);
    let yl = i64::from(text_width(&plot.y_label, SCALE));
    cv.text(&plot.y_label, 14, (y0 + y1) / 2 + yl / 2, true, BLACK);
    // Legend, top right inside the axes.
    let widest = plot.series.iter().map(|s| text_width(&s.label, SCALE)).max().unwrap_or(0);
    let (lw, row_h) = (i64::from(widest) + 56, glyph_h + 10);
    let (lx, ly) = (x1 - lw - 10, y0 + 10);
    if !plot.series.is_empty() {
        cv.rect(lx, ly, lx + lw, ly + row_h * plot.series.len() as i64 + 8, [255, 255, 255]);
        let lh = row_h * plot.series.len() as i64 + 8;
        cv.line((lx, ly), (lx + lw, ly), 0, BLACK);
        cv.line((lx, ly + lh), (lx + lw, ly + lh), 0, BLACK);
        cv.line((lx, ly), (lx, ly + lh), 0, BLACK);
        cv.line((lx + lw, ly), (lx + lw, ly + lh), 0, BLACK);
    }
    for (i, s) in plot.series.iter().enumerate() {
        let c = PALETTE[i % PALETTE.len()];
        let ry = ly + 9 + row_h * i as i64;
        cv.line((lx + 8, ry + glyph_h / 2), (lx + 38, ry + glyph_h / 2), 1, c);
        cv.rect(lx + 19, ry + glyph_h / 2 - 4, lx + 27, ry + glyph_h / 2 + 4, c);
        cv.text(&s.label, lx + 46, ry, false, BLACK);
    }
}

impl Plot {
    /// The plot drawn ([`plot_loglog`]) and encoded as a PNG file's bytes.
    pub fn png(&self, width: u32, height: u32) -> Result<Vec<u8>, ::image::ImageError> {
        let mut bytes = std::io::Cursor::new(Vec::new());
        plot_loglog(self, width, height).write_to(&mut bytes, ImageFormat::Png)?;
        Ok(bytes.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot() -> Plot {
        Plot {
            title: "error vs time".into(),
            x_label: "seconds".into(),
            y_label: "RMSE".into(),
            series: vec![
                Series { label: "cpu".into(), points: vec![(0.01, 1.0), (0.1, 0.3), (1.0, 0.1)] },
                Series { label: "gpu".into(), points: vec![(0.001, 1.0), (0.01, 0.3), (0.0, 5.0)] },
            ],
        }
    }

    #[test]
    fn ranges_and_ticks() {
        assert_eq!(decade_range([0.02, 3.0].into_iter()), Some((-2.0, 1.0)));
        assert_eq!(decade_range([1.0].into_iter()), Some((0.0, 1.0)));
        assert_eq!(decade_range([0.0, -1.0, f64::NAN].into_iter()), None);
        assert_eq!(ticks(-3.0, 1.0), vec![-3.0, -2.0, -1.0, 0.0, 1.0]);
        assert_eq!(ticks(0.0, 1.0).len(), 4); // 1, 2, 5, 10
        assert_eq!(tick_label(0.0), "1");
        assert_eq!(tick_label(-2.0), "0.01");
        assert_eq!(tick_label(2f64.log10() - 1.0), "0.2");
        assert_eq!(tick_label(3.0), "1000");
        assert_eq!(tick_label(-6.0), "1E-6");
        assert_eq!(tick_label(5f64.log10() + 5.0), "5E5");
    }

    #[test]
    fn series_are_drawn_in_their_colours_at_their_points() {
        let p = plot();
        let img = plot_loglog(&p, 640, 480);
        assert_eq!((img.width(), img.height()), (640, 480));
        let count = |c: [u8; 3]| img.pixels().filter(|px| px.0 == c).count();
        assert!(count(PALETTE[0]) > 100 && count(PALETTE[1]) > 100);
        // x spans 1e-3..1 (3 decades), y 0.1..1 (1 decade): cpu's last point (1, 0.1) is the
        // bottom-right corner of the axes, gpu's first (0.001, 1) the top-left.
        assert_eq!(img.get_pixel(640 - MARGIN_RIGHT - 2, 480 - MARGIN_BOTTOM - 2).0, PALETTE[0]);
        assert_eq!(img.get_pixel(MARGIN_LEFT + 2, MARGIN_TOP + 2).0, PALETTE[1]);
        // Text is black: labels exist left of the axis and below it.
        let black_left = (0..MARGIN_LEFT).flat_map(|x| (0..480).map(move |y| (x, y)));
        assert!(black_left.filter(|&(x, y)| img.get_pixel(x, y).0 == BLACK).count() > 50);
    }

    /// The SVG has the same layout as the PNG: every series' polyline and markers in its
    /// colour at the raster's pixel positions, every label as escaped text, and it parses
    /// as balanced XML elements.
    #[test]
    fn svg_has_the_png_layout() {
        let mut p = plot();
        p.title = "a < b & \"c\"".into();
        let svg = plot_loglog_svg(&p, 640, 480);
        assert!(svg.starts_with("<?xml") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains(r#"width="640" height="480""#));
        assert!(svg.contains("a &lt; b &amp; &quot;c&quot;") && !svg.contains("a < b"));
        for label in ["seconds", "RMSE", "cpu", "gpu", "0.01"] {
            assert!(svg.contains(&format!(">{label}</text>")), "{label}");
        }
        // cpu's last point (1, 0.1) is the axes' bottom-right corner: its marker is the
        // 9-pixel square centred there, as in the raster test above.
        let (x, y) = (640 - MARGIN_RIGHT as i64, 480 - MARGIN_BOTTOM as i64);
        assert!(svg.contains(&format!(
            r#"<rect x="{}" y="{}" width="9" height="9" fill="rgb(31,119,180)"/>"#,
            x - 4,
            y - 4
        )));
        assert!(svg.matches("rgb(255,127,14)").count() >= 4, "gpu: 2 points, a segment, the legend");
        // Balanced: every opened element is closed or self-closing.
        let opened = svg.matches("<text").count();
        assert_eq!(opened, svg.matches("</text>").count());
        assert_eq!(svg.matches("<svg").count(), 1);
        assert!(plot_loglog_svg(&p, 400, 300).contains(r#"viewBox="0 0 400 300""#));
    }

    #[test]
    fn empty_plot_still_draws_axes_and_png_round_trips() {
        let p = Plot { series: vec![], ..plot() };
        let img = plot_loglog(&p, 10, 10);
        assert_eq!((img.width(), img.height()), (320, 240));
        let back = ::image::load_from_memory(&plot().png(400, 300).unwrap()).unwrap();
        assert_eq!((back.width(), back.height()), (400, 300));
    }
}
