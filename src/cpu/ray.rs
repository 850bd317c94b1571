//! Rays in f64.

use glam::DVec3;

/// The segment `origin + t·dir` for `t ∈ (tmin, tmax)`, open at both ends. `dir` need not be unit length
/// (camera rays keep Raytracer.jl's parameterisation, with t = 1 at the screen).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Start point, in world space for the renderer's queries.
    pub origin: DVec3,
    /// Direction, not necessarily unit length: t counts multiples of it.
    pub dir: DVec3,
    /// Lower end of the range; queries accept hits with t in the open range (tmin, tmax).
    pub tmin: f64,
    /// Upper end of the range; `f64::INFINITY` for an unbounded ray.
    pub tmax: f64,
}

impl Ray {
    /// The ray `origin + t·dir` restricted to t in `(tmin, tmax)`; nothing is checked.
    pub fn new(origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Self {
        Self { origin, dir, tmin, tmax }
    }
    /// The point `origin + t·dir`, for any t (not clamped to the ray's range).
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}

/// The power of two 2⁻ᵉ that brings `m` (a vector's largest |component|) into [1, 2), the
/// exponent clamped to ±1022 so that 2⁻ᵉ is itself a normal number (a subnormal `m` then
/// lands at ≥ 2⁻⁵², far from underflow when squared). Multiplying by it is exact, so a
/// vector can be rescaled before squaring its length (which under- or overflows for
/// shapes scaled beyond ~1e±154) without changing any digit of what follows. Built from
/// the exponent bits, as `pow2_rescale` in shaders/ray.wgsl does in f32.
pub fn pow2_rescale(m: f64) -> f64 {
    let e = ((m.to_bits() >> 52) & 0x7ff) as i64 - 1023;
    let e = e.clamp(-1022, 1022);
    f64::from_bits(((1023 - e) as u64) << 52)
}

/// `v / |v|` for any finite `v` (zero for zero): rescaled by [`pow2_rescale`] first, so a
/// normal leaving an object scaled by 1e300 (length 1e-300) keeps its direction. In range
/// the result is bit for bit `v.normalize_or_zero()`.
pub fn normalize_scaled(v: DVec3) -> DVec3 {
    (v * pow2_rescale(v.abs().max_element())).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rescaling_is_a_power_of_two_into_one_to_two() {
        assert_eq!(pow2_rescale(1.5), 1.0);
        assert_eq!(pow2_rescale(0.3), 4.0);
        assert_eq!(pow2_rescale(3e300) * 3e300, 3e300 / 2f64.powi(998));
        assert_eq!(pow2_rescale(1e-320), 2f64.powi(1022));
        assert_eq!(pow2_rescale(0.0), 2f64.powi(1022));
    }

    #[test]
    fn normalizes_at_any_scale() {
        let v = DVec3::new(0.3, -0.4, 1.2);
        for s in [1e-300, 1e-160, 1.0, 1e160, 1e300] {
            let n = normalize_scaled(v * s);
            assert!((n - v.normalize()).length() < 1e-15, "{s}: {n}");
        }
        assert_eq!(normalize_scaled(v), v.normalize_or_zero());
        assert_eq!(normalize_scaled(DVec3::ZERO), DVec3::ZERO);
    }
}
