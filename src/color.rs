//! Linear RGB colours, generic over the float type.
//!
//! The scene model and the CPU reference work in `f64` ([`Color`]); images store `f32`
//! ([`Rgb32`]). One generic type keeps the arithmetic written once.

use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Sub};

/// A linear (not gamma-encoded), unbounded RGB triple.
///
/// ```
/// use lumen::color::Color;
/// let c = Color::new(1.0, 2.0, 3.0) * 2.0 + Color::gray(1.0);
/// assert_eq!(c, Color::new(3.0, 5.0, 7.0));
/// assert_eq!(c.max_component(), 7.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C)]
pub struct Rgb<T> {
    /// Red channel, linear.
    pub r: T,
    /// Green channel, linear.
    pub g: T,
    /// Blue channel, linear.
    pub b: T,
}

// SAFETY: three f32 fields under repr(C): no padding, and every bit pattern is a value.
// (Images are hashed and written as their pixels' bytes.)
unsafe impl bytemuck::Zeroable for Rgb<f32> {}
unsafe impl bytemuck::Pod for Rgb<f32> {}

/// Double-precision colour used by the scene model and the CPU reference.
pub type Color = Rgb<f64>;
/// Single-precision colour stored in images and on the GPU.
pub type Rgb32 = Rgb<f32>;

impl<T> Rgb<T> {
    /// A colour from its three linear channels, in red, green, blue order.
    pub const fn new(r: T, g: T, b: T) -> Self {
        Self { r, g, b }
    }
}

impl<T: Copy> Rgb<T> {
    /// The same value in all three channels.
    pub const fn gray(v: T) -> Self {
        Self { r: v, g: v, b: v }
    }
    /// Applies `f` to each channel.
    pub fn map<U>(self, f: impl Fn(T) -> U) -> Rgb<U> {
        Rgb::new(f(self.r), f(self.g), f(self.b))
    }
    /// Combines two colours channel by channel.
    pub fn zip_with<U, V>(self, o: Rgb<U>, f: impl Fn(T, U) -> V) -> Rgb<V> {
        Rgb::new(f(self.r, o.r), f(self.g, o.g), f(self.b, o.b))
    }
    /// The channels as `[r, g, b]`, for indexing a channel by number.
    pub fn to_array(self) -> [T; 3] {
        [self.r, self.g, self.b]
    }
}

macro_rules! float_rgb {
    ($t:ty) => {
        impl Rgb<$t> {
            /// Zero in every channel: no light.
            pub const BLACK: Self = Self::new(0.0, 0.0, 0.0);
            /// One in every channel: a white reflectance, or unit radiance.
            pub const WHITE: Self = Self::new(1.0, 1.0, 1.0);
            /// The largest of the three channels.
            pub fn max_component(self) -> $t {
                self.r.max(self.g).max(self.b)
            }
            /// The smallest of the three channels.
            pub fn min_component(self) -> $t {
                self.r.min(self.g).min(self.b)
            }
            /// Raytracer.jl's pixel luminosity: (max + min) / 2.
            pub fn luminosity(self) -> $t {
                (self.max_component() + self.min_component()) / 2.0
            }
            /// Rec. 709 luminance, used for importance sampling images.
            pub fn luminance(self) -> $t {
                0.2126 * self.r + 0.7152 * self.g + 0.0722 * self.b
            }
            /// True when no channel is NaN or infinite.
            pub fn is_finite(self) -> bool {
                self.r.is_finite() && self.g.is_finite() && self.b.is_finite()
            }
            /// True when every channel is exactly zero (negative zero included).
            pub fn is_black(self) -> bool {
                self.r == 0.0 && self.g == 0.0 && self.b == 0.0
            }
            /// True when every channel differs by at most `eps`.
            pub fn approx_eq(self, o: Self, eps: $t) -> bool {
                (self.r - o.r).abs() <= eps && (self.g - o.g).abs() <= eps && (self.b - o.b).abs() <= eps
            }
        }
        impl Add for Rgb<$t> {
            type Output = Self;
            fn add(self, o: Self) -> Self {
                self.zip_with(o, |a, b| a + b)
            }
        }
        impl AddAssign for Rgb<$t> {
            fn add_assign(&mut self, o: Self) {
                *self = *self + o;
            }
        }
        impl Sub for Rgb<$t> {
            type Output = Self;
            fn sub(self, o: Self) -> Self {
                self.zip_with(o, |a, b| a - b)
            }
        }
        impl Mul for Rgb<$t> {
            type Output = Self;
            fn mul(self, o: Self) -> Self {
                self.zip_with(o, |a, b| a * b)
            }
        }
        impl MulAssign for Rgb<$t> {
            fn mul_assign(&mut self, o: Self) {
                *self = *self * o;
            }
        }
        impl Mul<$t> for Rgb<$t> {
            type Output = Self;
            fn mul(self, s: $t) -> Self {
                self.map(|a| a * s)
            }
        }
        impl Mul<Rgb<$t>> for $t {
            type Output = Rgb<$t>;
            fn mul(self, c: Rgb<$t>) -> Rgb<$t> {
                c * self
            }
        }
        impl MulAssign<$t> for Rgb<$t> {
            fn mul_assign(&mut self, s: $t) {
                *self = *self * s;
            }
        }
        impl Div<$t> for Rgb<$t> {
            type Output = Self;
            fn div(self, s: $t) -> Self {
                self.map(|a| a / s)
            }
        }
    };
}
float_rgb!(f32);
float_rgb!(f64);

impl From<Rgb32> for Color {
    fn from(c: Rgb32) -> Self {
        c.map(f64::from)
    }
}
impl From<Color> for Rgb32 {
    fn from(c: Color) -> Self {
        c.map(|v| v as f32)
    }
}
