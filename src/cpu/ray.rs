//! Rays in f64.

use glam::DVec3;

/// The segment `origin + t·dir` for `t ∈ [tmin, tmax]`. `dir` need not be unit length
/// (camera rays keep Raytracer.jl's parameterisation, with t = 1 at the screen).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
    pub tmin: f64,
    pub tmax: f64,
}

impl Ray {
    pub fn new(origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Self {
        Self { origin, dir, tmin, tmax }
    }
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}
