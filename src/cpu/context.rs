//! What every integrator reads: the scene, its intersection world and its lights, plus
//! the ray counter the render loop reports.

use glam::DVec3;

use crate::prepare::pixel_samples::PixelSamples;
use crate::sampling::seed_word;
use crate::scene::Scene;

use super::lights::Lights;
use super::{offset_origin, Ray, World};

/// Per-render, read-only state shared by all threads.
#[derive(Debug)]
pub struct Context<'a> {
    /// The scene being rendered: materials, camera, tracer and renderer settings.
    pub scene: &'a Scene,
    /// The scene's geometry prepared for closest-hit and occlusion queries.
    pub world: &'a World,
    /// The lights next-event estimation samples.
    pub lights: &'a Lights,
    /// log₂ of the strata per dimension of a path vertex (`sampling::strata_bits` of the
    /// pixel's samples of the whole render, not of one round or range).
    pub strata_bits: u32,
    /// `sampling::seed_word` of the tracer's seed.
    pub seed_word: u32,
}

/// Counts accumulated by one thread's share of the work.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Closest-hit and shadow rays traced.
    pub rays: u64,
}

impl<'a> Context<'a> {
    /// The context of a render whose pixels take `layout`'s camera samples.
    pub fn new(scene: &'a Scene, world: &'a World, lights: &'a Lights, layout: PixelSamples) -> Self {
        let strata_bits = layout.strata_bits(super::paths_per_sample(scene));
        Self { scene, world, lights, strata_bits, seed_word: seed_word(scene.tracer.rng) }
    }

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
