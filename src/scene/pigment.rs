//! Pigments: colours as functions of a surface's (u, v) coordinates.

use std::sync::Arc;

use crate::color::Color;
use crate::image::HdrImage;

/// How an image pigment reads between texel centres.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ImageFilter {
    /// Raytracer.jl's lookup: the texel containing (u, v).
    #[default]
    Nearest,
    /// Bilinear interpolation between the four nearest texel centres, wrapping in u and
    /// clamping in v.
    Bilinear,
}

/// A colour over the unit square of surface coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum Pigment {
    /// The same colour everywhere.
    Uniform(Color),
    /// `n × n` squares alternating `on` (where ⌊nu⌋ + ⌊nv⌋ is even) and `off`.
    Checkered {
        /// Squares along each side of the unit square (SceneLang's `.N`).
        n: u32,
        /// Colour of the squares where ⌊nu⌋ + ⌊nv⌋ is even (SceneLang's `.color_on`).
        on: Color,
        /// Colour of the other squares (SceneLang's `.color_off`).
        off: Color,
    },
    /// An image stretched over the unit square: u runs along the columns, v down the rows
    /// from row 0 at the top.
    Image {
        /// The texels, linear; shared, so that the GPU uploads each image once however many
        /// pigments use it.
        image: Arc<HdrImage>,
        /// Nearest texel (Raytracer.jl's lookup, the default) or bilinear (SceneLang's `.filter`).
        filter: ImageFilter,
    },
}

impl Default for Pigment {
    fn default() -> Self {
        Pigment::Uniform(Color::WHITE)
    }
}

impl Pigment {
    /// The colour at surface coordinates `(u, v)`, both nominally in `[0, 1]`.
    ///
    /// ```
    /// use lumen::scene::Pigment;
    /// use lumen::color::Color;
    /// let p = Pigment::Checkered { n: 2, on: Color::WHITE, off: Color::BLACK };
    /// assert_eq!(p.color_at(0.25, 0.25), Color::WHITE);
    /// assert_eq!(p.color_at(0.75, 0.25), Color::BLACK);
    /// ```
    pub fn color_at(&self, u: f64, v: f64) -> Color {
        match self {
            Pigment::Uniform(c) => *c,
            Pigment::Checkered { n, on, off } => {
                let n = f64::from(*n);
                let iu = (u * n).floor() as i64;
                let iv = (v * n).floor() as i64;
                if (iu + iv).rem_euclid(2) == 0 {
                    *on
                } else {
                    *off
                }
            }
            Pigment::Image { image, filter } => image_lookup(image, u, v, *filter),
        }
    }

    /// True when the pigment is black everywhere (lets emission be skipped).
    pub fn is_black(&self) -> bool {
        match self {
            Pigment::Uniform(c) => c.is_black(),
            Pigment::Checkered { on, off, .. } => on.is_black() && off.is_black(),
            Pigment::Image { image, .. } => image.pixels().iter().all(|p| p.is_black()),
        }
    }
}

/// Reads an image at (u, v) as Raytracer.jl does: column ⌊u·W⌋, row ⌊v·H⌋ with row 0 at
/// the top, clamped to the last texel. With the sphere's v = acos(z)/π this puts the top
/// of an equirectangular image at the north pole (+z).
fn image_lookup(img: &HdrImage, u: f64, v: f64, filter: ImageFilter) -> Color {
    let (w, h) = (img.width(), img.height());
    if w == 0 || h == 0 {
        return Color::BLACK;
    }
    match filter {
        ImageFilter::Nearest => {
            let col = ((u * w as f64).max(0.0) as usize).min(w - 1);
            let row = ((v * h as f64).max(0.0) as usize).min(h - 1);
            img.get(col, row).into()
        }
        ImageFilter::Bilinear => {
            let x = u * w as f64 - 0.5;
            let y = (v * h as f64 - 0.5).clamp(0.0, (h - 1) as f64);
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            let wrap = |c: f64| (c as i64).rem_euclid(w as i64) as usize;
            let (c0, c1) = (wrap(x0), wrap(x0 + 1.0));
            let r0 = y0 as usize;
            let r1 = (r0 + 1).min(h - 1);
            let p = |c: usize, r: usize| -> Color { img.get(c, r).into() };
            (p(c0, r0) * (1.0 - fx) + p(c1, r0) * fx) * (1.0 - fy) + (p(c0, r1) * (1.0 - fx) + p(c1, r1) * fx) * fy
        }
    }
}
