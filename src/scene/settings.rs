//! Renderer (integrator), tracer (sampling) and random-number settings.

use crate::color::Color;

/// Seed of a PCG32 generator, as SceneLang's `Pcg(.state, .inc)` gives it. See
/// [`crate::sampling`] for how each (pixel, sample, bounce) derives its own stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PcgSeed {
    /// Initial state (`.state`): the PCG32 reference's `initstate`, which each stream
    /// offsets by its own key.
    pub state: u64,
    /// Stream selector (`.inc`): the reference's `initseq`; the generator's increment is
    /// `2·inc + 1`.
    pub inc: u64,
}

impl PcgSeed {
    /// The seed as four u32 words (state low, state high, inc low, inc high): how the GPU
    /// receives it (WGSL has no 64-bit integers) and what the strata's seed word hashes.
    ///
    /// ```
    /// use lumen::scene::PcgSeed;
    /// assert_eq!(PcgSeed { state: 1 << 32 | 2, inc: 3 }.words(), [2, 1, 3, 0]);
    /// ```
    pub fn words(&self) -> [u32; 4] {
        [self.state as u32, (self.state >> 32) as u32, self.inc as u32, (self.inc >> 32) as u32]
    }
}

impl Default for PcgSeed {
    fn default() -> Self {
        Self { state: 42, inc: 54 }
    }
}

/// Which integrator computes a camera ray's radiance.
#[derive(Debug, Clone, PartialEq)]
pub enum Renderer {
    /// `on` where a ray hits anything, `off` elsewhere.
    OnOff {
        /// Colour of pixels whose ray hits (SceneLang's `.on_color`).
        on: Color,
        /// Colour of escaping rays (SceneLang's `.off_color`); an environment is ignored.
        off: Color,
    },
    /// Emitted + pigment colour at the first hit.
    Flat {
        /// Colour of escaping rays when the scene has no environment.
        background: Color,
    },
    /// Direct light from point lights plus a constant ambient term.
    PointLight {
        /// Colour of escaping rays when the scene has no environment.
        background: Color,
        /// Radiance added at every hit, whatever the surface (not tinted by its pigment).
        ambient: Color,
    },
    /// Global illumination: Monte Carlo path tracing.
    PathTracer(PathTracerSettings),
}

impl Renderer {
    /// The variant's SceneLang name, as in `Renderer.<name>` (`OnOff`, `Flat`, `PointLight`,
    /// `PathTracer`); the CLI prints it.
    pub fn name(&self) -> &'static str {
        match self {
            Renderer::OnOff { .. } => "OnOff",
            Renderer::Flat { .. } => "Flat",
            Renderer::PointLight { .. } => "PointLight",
            Renderer::PathTracer(_) => "PathTracer",
        }
    }
    /// Colour of rays that escape when the scene has no environment.
    pub fn background(&self) -> Color {
        match self {
            Renderer::OnOff { off, .. } => *off,
            Renderer::Flat { background } | Renderer::PointLight { background, .. } => *background,
            Renderer::PathTracer(p) => p.background,
        }
    }
}

/// The settings of `Renderer.PathTracer`.
#[derive(Debug, Clone, PartialEq)]
pub struct PathTracerSettings {
    /// Colour of escaping rays when the scene has no environment; it lights the scene like
    /// a uniform environment.
    pub background: Color,
    /// Raytracer.jl's `.rng`: kept for DUMP; streams derive from the tracer's seed.
    pub rng: PcgSeed,
    /// Independent paths per camera sample.
    pub n: u32,
    /// Bounces: a path has at most `max_depth + 1` surface hits (camera hit = depth 0).
    pub max_depth: u32,
    /// Russian roulette applies at hits of depth ≥ this.
    pub roulette_depth: u32,
    /// Next-event estimation with MIS; `false` reproduces plain BSDF-only path tracing.
    pub nee: bool,
}

impl Default for PathTracerSettings {
    fn default() -> Self {
        Self { background: Color::BLACK, rng: PcgSeed::default(), n: 10, max_depth: 2, roulette_depth: 3, nee: true }
    }
}

/// How camera samples are placed in each pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Tracer {
    /// s > 0: s×s jittered (stratified) samples; 0: one ray through the pixel centre.
    pub samples_per_side: u32,
    /// Seed from which every random stream derives (camera jitter and path vertices alike).
    pub rng: PcgSeed,
}
