//! What every integrator reads: the scene, its intersection world and its lights, plus
//! the ray counter the render loop reports.

use glam::DVec3;

use crate::scene::Scene;

use super::lights::Lights;
use super::{offset_origin, Ray, World};

/// Per-render, read-only state shared by all threads.
#[derive(Debug)]
pub struct Context<'a> {
    pub scene: &'a Scene,
    pub world: &'a World,
    pub lights: &'a Lights,
}

/// Counts accumulated by one thread's share of the work.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Closest-hit and shadow rays traced.
    pub rays: u64,
}

impl Context<'_> {
    /// Closest hit along `ray`, counted.
    pub fn intersect(&self, ray: &Ray, counters: &mut Counters) -> Option<super::Hit> {
        counters.rays += 1;
        self.world.intersect(ray)
    }

    /// True when nothing blocks the segment from surface point `x` (error scale `sx`,
    /// geometric normal `nx`) to `y`. With `ny` = (normal, error scale) of `y` on a surface
    /// both ends are offset off their surfaces and the ray stops at the offset end
    /// (DESIGN.md); a point light's `y` is used as is.
    pub fn segment_clear(
        &self,
        x: DVec3,
        sx: f64,
        nx: DVec3,
        y: DVec3,
        ny: Option<(DVec3, f64)>,
        counters: &mut Counters,
    ) -> bool {
        let o = offset_origin(x, sx, nx, y - x);
        let e = match ny {
            Some((n, sy)) => offset_origin(y, sy, n, x - y),
            None => y,
        };
        counters.rays += 1;
        !self.world.occluded(&Ray::new(o, e - o, 0.0, 1.0))
    }

    /// True when nothing blocks the ray from surface point `x` (error scale `sx`) toward
    /// infinity along `dir`.
    pub fn direction_clear(&self, x: DVec3, sx: f64, nx: DVec3, dir: DVec3, counters: &mut Counters) -> bool {
        counters.rays += 1;
        !self.world.occluded(&Ray::new(offset_origin(x, sx, nx, dir), dir, 0.0, f64::INFINITY))
    }
}
