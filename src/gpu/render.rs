//! The GPU renderer: pack the scene, assemble a kernel specialised to it, run progressive
//! passes, and return the mean image.
//!
//! The kernel computes exactly what the CPU reference computes (same random streams, same
//! integrator structure, function by function in `shaders/`), in f32 and relative to the
//! camera; GPU-vs-CPU tests in `tests/gpu_render.rs` hold the two together.

use std::time::Instant;

use super::features::FeatureSet;
use super::pack::{at_least_one, pack, PackedScene};
use super::{
    run_progressive, Assembled, ComputeKernel, Gpu, GpuError, KernelCache, PassOptions, ShaderLibrary, StopReason,
};
use crate::image::HdrImage;
use crate::scene::Scene;

/// Every WGSL module the renderer is assembled from (`shaders/smoke.wgsl` is not one).
const MODULES: [(&str, &str); 24] = [
    ("shaders/pass.wgsl", include_str!("../../shaders/pass.wgsl")),
    ("shaders/angles.wgsl", include_str!("../../shaders/angles.wgsl")),
    ("shaders/layout.wgsl", include_str!("../../shaders/layout.wgsl")),
    ("shaders/bindings.wgsl", include_str!("../../shaders/bindings.wgsl")),
    ("shaders/random.wgsl", include_str!("../../shaders/random.wgsl")),
    ("shaders/ray.wgsl", include_str!("../../shaders/ray.wgsl")),
    ("shaders/quadratic.wgsl", include_str!("../../shaders/quadratic.wgsl")),
    ("shaders/sphere.wgsl", include_str!("../../shaders/sphere.wgsl")),
    ("shaders/plane.wgsl", include_str!("../../shaders/plane.wgsl")),
    ("shaders/cube.wgsl", include_str!("../../shaders/cube.wgsl")),
    ("shaders/cylinder.wgsl", include_str!("../../shaders/cylinder.wgsl")),
    ("shaders/shapes.wgsl", include_str!("../../shaders/shapes.wgsl")),
    ("shaders/csg.wgsl", include_str!("../../shaders/csg.wgsl")),
    ("shaders/world.wgsl", include_str!("../../shaders/world.wgsl")),
    ("shaders/camera.wgsl", include_str!("../../shaders/camera.wgsl")),
    ("shaders/offset.wgsl", include_str!("../../shaders/offset.wgsl")),
    ("shaders/rescale.wgsl", include_str!("../../shaders/rescale.wgsl")),
    ("shaders/onb.wgsl", include_str!("../../shaders/onb.wgsl")),
    ("shaders/textures.wgsl", include_str!("../../shaders/textures.wgsl")),
    ("shaders/pigment.wgsl", include_str!("../../shaders/pigment.wgsl")),
    ("shaders/environment.wgsl", include_str!("../../shaders/environment.wgsl")),
    ("shaders/brdf.wgsl", include_str!("../../shaders/brdf.wgsl")),
    ("shaders/integrators.wgsl", include_str!("../../shaders/integrators.wgsl")),
    ("shaders/render.wgsl", include_str!("../../shaders/render.wgsl")),
];
const EXTRA_MODULES: [(&str, &str); 5] = [
    ("shaders/resume.wgsl", include_str!("../../shaders/resume.wgsl")),
    ("shaders/ray_count.wgsl", include_str!("../../shaders/ray_count.wgsl")),
    ("shaders/lights.wgsl", include_str!("../../shaders/lights.wgsl")),
    ("shaders/path_tracer.wgsl", include_str!("../../shaders/path_tracer.wgsl")),
    ("shaders/env_light.wgsl", include_str!("../../shaders/env_light.wgsl")),
];

/// Name of the kernel's entry point in `shaders/render.wgsl`.
pub const ENTRY_POINT: &str = "render";

/// How to render on the GPU.
#[derive(Debug, Clone, Default)]
pub struct GpuRenderOptions {
    /// `--spp`: overrides the tracer's samples per pixel (a perfect square s² means s×s
    /// strata, any other count jitters over the whole pixel).
    pub spp: Option<u32>,
    /// Pass sizing, time limit, cancellation and progress display.
    pub passes: PassOptions,
    /// The kernel to compile instead of the scene's own (`None`): it must cover the scene's
    /// features ([`FeatureSet::covers`]), e.g. [`FeatureSet::full_for`], else the render is
    /// refused. For benchmarks and tests of specialisation; the image is the same.
    pub features: Option<FeatureSet>,
    /// Count closest-hit and shadow rays on the GPU ([`GpuRenderOutput::rays`]), as the CPU
    /// reference always does; a kernel variant with one atomic add per invocation and pass.
    pub count_rays: bool,
}

impl GpuRenderOptions {
    /// Options whose passes always hold `spp_per_pass` samples: the f32 pass sums, and so the
    /// image, are then bitwise reproducible (adaptive passes split samples by timing).
    pub fn fixed_passes(spp: Option<u32>, spp_per_pass: u32) -> Self {
        let passes = PassOptions {
            initial_spp_per_pass: spp_per_pass,
            max_spp_per_pass: spp_per_pass,
            target_pass_seconds: f64::MAX,
            ..PassOptions::default()
        };
        Self { spp, passes, ..Self::default() }
    }
}

/// What a GPU render produced.
#[derive(Debug, Clone)]
pub struct GpuRenderOutput {
    /// Per-pixel mean over `spp_done` camera samples.
    pub image: HdrImage,
    /// Camera samples per pixel taken (fewer than requested after a time limit or Ctrl-C).
    pub spp_done: u32,
    pub spp_requested: u32,
    /// Wall time, including packing and kernel compilation.
    pub seconds: f64,
    /// Path (or camera-sample) estimates that were NaN or infinite, written as 0.
    pub non_finite_samples: u64,
    pub stop: StopReason,
    /// Features the kernel was compiled for (the scene's, or the override).
    pub features: FeatureSet,
    /// Paths the driver's loop limiter cut even when run alone (counted as 0, so the
    /// image is not exact; see docs/DESIGN.md, "Loop limiter and path-granular passes").
    pub loop_limited_paths: u64,
    /// Kernel dispatches: one per pass, more when resumable passes were resumed.
    pub dispatches: u64,
    /// Closest-hit and shadow rays traced, when [`GpuRenderOptions::count_rays`] asked (the
    /// same count as the CPU reference's `RenderStats::rays` for the same samples).
    pub rays: Option<u64>,
}

/// The assembly feature of resumable, path-granular kernels (`shaders/resume.wgsl`), used
/// when [`Gpu::loop_limiter`] is set.
pub const LOOP_LIMITER: &str = "LOOP_LIMITER";

/// The assembly feature of kernels that count rays (`shaders/ray_count.wgsl`).
pub const COUNT_RAYS: &str = "COUNT_RAYS";

/// Variants of a scene's kernel chosen by the device or the caller, not by the scene.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KernelVariant {
    /// Resumable, path-granular passes ([`LOOP_LIMITER`]), for drivers with a loop limiter.
    pub loop_limiter: bool,
    /// Ray counting ([`COUNT_RAYS`]).
    pub count_rays: bool,
}

impl KernelVariant {
    /// The assembly feature names this variant adds to the scene's.
    pub fn names(&self) -> Vec<&'static str> {
        [(self.loop_limiter, LOOP_LIMITER), (self.count_rays, COUNT_RAYS)]
            .into_iter()
            .filter_map(|(on, name)| on.then_some(name))
            .collect()
    }
}

/// All modules, in a library that knows every feature name.
pub fn shader_library() -> ShaderLibrary {
    let names: Vec<&str> = FeatureSet::ALL_NAMES.iter().copied().chain([LOOP_LIMITER, COUNT_RAYS]).collect();
    let mut lib = ShaderLibrary::new(&names);
    for (file, src) in MODULES.iter().chain(EXTRA_MODULES.iter()) {
        lib.add(file, src).unwrap_or_else(|e| panic!("built-in shader {file} is malformed: {e}"));
    }
    lib
}

/// Constants that depend on the scene rather than on a feature: the BVH stack size and
/// the CSG interval-list bound.
fn constants_module(features: &FeatureSet) -> String {
    let intervals = features.csg_max_intervals.max(1);
    let depth = features.csg_max_depth.max(1);
    format!(
        "// Scene-dependent constants, generated by src/gpu/render.rs.\n\
         const BVH_STACK_SIZE: u32 = {}u;\n\
         const CSG_NODE_BIT: u32 = 0x{:08X}u;\n\
         const CSG_MAX_INTERVALS: u32 = {}u;\n\
         const CSG_MAX_DEPTH: u32 = {}u;\n\
         const CSG_POOL_SIZE: u32 = {}u;\n\
         const CSG_DEFER: bool = {};\n\
         const CSG_DEFER_SLOTS: u32 = {}u;\n",
        crate::accel::MAX_DEPTH + 1,
        super::layout::CSG_NODE_BIT,
        intervals,
        depth,
        (2 * depth + 2) * intervals,
        features.csg_trees as usize <= crate::cpu::CSG_DEFER_MAX,
        features.csg_trees.clamp(1, crate::cpu::CSG_DEFER_MAX as u32),
    )
}

/// The render kernel assembled for `features` (validated with naga).
pub fn assemble(features: &FeatureSet) -> Result<Assembled, GpuError> {
    assemble_for(features, KernelVariant::default())
}

/// The render kernel for `features` in the given variant.
pub fn assemble_for(features: &FeatureSet, variant: KernelVariant) -> Result<Assembled, GpuError> {
    let mut lib = shader_library();
    lib.add("<generated constants>", &format!("// #provides constants\n{}", constants_module(features)))
        .map_err(|e| GpuError::Validation(e.to_string()))?;
    let mut names = features.assembly_features();
    for name in variant.names() {
        names.insert(name);
    }
    let assembled =
        lib.assemble(&["render"], &names).map_err(|e| GpuError::Validation(format!("shader assembly: {e}")))?;
    assembled.validate()?;
    Ok(assembled)
}

/// The WGSL of the kernel that renders `scene` (for `lumen shader`).
///
/// ```
/// use lumen::scene::*;
/// use lumen::color::Color;
/// let mut b = SceneBuilder::new(4, 4);
/// let m = b.diffuse(Color::gray(0.5));
/// b.sphere(Transform::IDENTITY, m);
/// let src = lumen::gpu::render::shader_source(&b.build().unwrap()).unwrap();
/// assert!(src.contains("fn sphere_span") && !src.contains("fn cylinder_span"));
/// ```
pub fn shader_source(scene: &Scene) -> Result<String, GpuError> {
    Ok(assemble(&FeatureSet::of(scene))?.source)
}

fn pack_error(e: super::pack::PackError) -> GpuError {
    GpuError::Validation(format!("cannot pack the scene for the GPU: {e}"))
}

/// Renders `scene` on `gpu`.
///
/// ```
/// use lumen::scene::*;
/// use lumen::color::Color;
/// use lumen::gpu::render::{render, GpuRenderOptions};
/// let Some(gpu) = lumen::gpu::gpu_for_tests("gpu_render_doc") else { return };
/// let mut b = SceneBuilder::new(5, 3);
/// let m = b.diffuse(Color::gray(0.5));
/// b.sphere(Transform::translation(glam::DVec3::new(3.0, 0.0, 0.0)), m)
///     .renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });
/// let out = render(&gpu, &b.build().unwrap(), &GpuRenderOptions::default()).unwrap();
/// assert_eq!(out.spp_done, 1);
/// assert_eq!(out.image.get(2, 1).r, 1.0); // the sphere covers the centre
/// assert_eq!(out.image.get(0, 0).r, 0.0);
/// ```
pub fn render(gpu: &Gpu, scene: &Scene, opts: &GpuRenderOptions) -> Result<GpuRenderOutput, GpuError> {
    GpuRenderer::new().render(gpu, scene, opts)
}

/// Renders several scenes (animation frames, re-renders) compiling each distinct kernel
/// once: kernels are cached by feature set and scene-dependent constants.
#[derive(Debug, Default)]
pub struct GpuRenderer {
    kernels: KernelCache,
}

impl GpuRenderer {
    pub fn new() -> Self {
        Self::default()
    }

    /// Kernels compiled so far.
    pub fn kernels_compiled(&self) -> usize {
        self.kernels.len()
    }

    /// Renders `scene` on `gpu`, like [`render`].
    pub fn render(&mut self, gpu: &Gpu, scene: &Scene, opts: &GpuRenderOptions) -> Result<GpuRenderOutput, GpuError> {
        let start = Instant::now();
        let packed = pack(scene, opts.spp).map_err(pack_error)?;
        self.render_from(gpu, scene, &packed, opts, start)
    }

    /// Renders `packed`, which [`pack`] made from `scene` with `opts.spp` (and a benchmark may
    /// have altered, e.g. [`PackedScene::flatten_bvh`]).
    pub fn render_packed(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        packed: &PackedScene,
        opts: &GpuRenderOptions,
    ) -> Result<GpuRenderOutput, GpuError> {
        self.render_from(gpu, scene, packed, opts, Instant::now())
    }

    fn render_from(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        packed: &PackedScene,
        opts: &GpuRenderOptions,
        start: Instant,
    ) -> Result<GpuRenderOutput, GpuError> {
        let f = &kernel_features(&packed.features, opts.features)?;
        // The cache key: the assembly features plus the generated constants.
        let variant = KernelVariant { loop_limiter: gpu.loop_limiter, count_rays: opts.count_rays };
        let key = f
            .assembly_features()
            .with(&format!("{variant:?}"))
            .with(&format!("csg_max_intervals={}", f.csg_max_intervals))
            .with(&format!("csg_max_depth={}", f.csg_max_depth))
            .with(&format!("csg_trees={}", f.csg_trees.min(crate::cpu::CSG_DEFER_MAX as u32 + 1)));
        let kernel = self.kernels.get_or_build(&key, ENTRY_POINT, || {
            let assembled = assemble_for(f, variant)?;
            check_binding_limits(gpu, &assembled)?;
            gpu.compute_kernel("render.wgsl (assembled)", &assembled.source, ENTRY_POINT)
        })?;
        let mut out = render_packed(gpu, &kernel, scene, packed, opts, start)?;
        out.features = *f;
        Ok(out)
    }
}

/// The scene's features, or the override when it covers them (a clear error otherwise:
/// a kernel lacking a feature would silently render the scene wrong).
fn kernel_features(scene: &FeatureSet, kernel: Option<FeatureSet>) -> Result<FeatureSet, GpuError> {
    let Some(kernel) = kernel else { return Ok(*scene) };
    let missing = kernel.missing_for(scene);
    if !missing.is_empty() {
        return Err(GpuError::Validation(format!(
            "the kernel feature override does not cover this scene; it lacks: {}",
            missing.join(", ")
        )));
    }
    Ok(kernel)
}

fn render_packed(
    gpu: &Gpu,
    kernel: &ComputeKernel,
    scene: &Scene,
    packed: &PackedScene,
    opts: &GpuRenderOptions,
    start: Instant,
) -> Result<GpuRenderOutput, GpuError> {
    let buffers = SceneBuffers::upload(gpu, kernel, packed)?;
    let group = kernel.bind_group(gpu, 1, &buffers.refs())?;
    let paths_per_pass = u64::from(packed.settings.paths_per_sample.max(1)) * u64::from(opts.passes.max_spp_per_pass);
    if gpu.loop_limiter && paths_per_pass > u64::from(super::MAX_RESUMABLE_PATHS_PER_PASS) {
        return Err(GpuError::Validation(format!(
            "{paths_per_pass} paths per pass (paths per sample × max samples per pass) exceed the {} a resumable \
             pass can count",
            super::MAX_RESUMABLE_PATHS_PER_PASS
        )));
    }
    let acc = run_progressive(gpu, kernel, &[&group], scene.width, scene.height, packed.settings.spp, &opts.passes)?;
    let nan: Vec<u32> = gpu.read_buffer(&buffers.buffers[buffers.nan_count], 1)?;
    let rays = match buffers.ray_count {
        Some(k) => {
            let words: Vec<u32> = gpu.read_buffer(&buffers.buffers[k], 2)?;
            Some(u64::from(words[0]) | (u64::from(words[1]) << 32))
        }
        None => None,
    };
    Ok(GpuRenderOutput {
        image: acc.image,
        spp_done: acc.spp_done,
        spp_requested: packed.settings.spp,
        seconds: start.elapsed().as_secs_f64(),
        non_finite_samples: u64::from(nan[0]) + acc.nonfinite,
        stop: acc.stop,
        features: packed.features,
        loop_limited_paths: acc.loop_limited_paths,
        dispatches: acc.dispatches,
        rays,
    })
}

/// A clear error when the kernel needs more storage buffers than the adapter allows.
fn check_binding_limits(gpu: &Gpu, assembled: &Assembled) -> Result<(), GpuError> {
    let module = assembled.validate()?.module;
    let storage =
        module.global_variables.iter().filter(|(_, v)| matches!(v.space, naga::AddressSpace::Storage { .. })).count()
            as u32;
    let limit = gpu.limits.max_storage_buffers_per_shader_stage;
    if storage > limit {
        return Err(GpuError::Validation(format!(
            "this scene's kernel needs {storage} storage buffers; the adapter allows {limit} per shader stage"
        )));
    }
    Ok(())
}

/// Binding number of the NaN/∞ counter in `shaders/bindings.wgsl`.
const NAN_COUNT_BINDING: u32 = 2;
/// Binding number of the ray counter in `shaders/ray_count.wgsl`.
const RAY_COUNT_BINDING: u32 = 13;

/// The uploaded scene: a buffer for each binding the kernel declares (buffers a kernel
/// does not read, such as texels in an OnOff render, are never uploaded). A full-featured
/// kernel declares buffers the scene leaves empty: those get one zeroed element, since a
/// binding must hold at least one element of its array type (it is never read: counts are 0).
struct SceneBuffers {
    /// In the kernel's binding order.
    buffers: Vec<wgpu::Buffer>,
    nan_count: usize,
    /// The ray counter, in kernels that count rays.
    ray_count: Option<usize>,
}

impl SceneBuffers {
    fn upload(gpu: &Gpu, kernel: &ComputeKernel, p: &PackedScene) -> Result<Self, GpuError> {
        let declared = kernel.bindings.get(1).map(Vec::as_slice).unwrap_or(&[]);
        let mut buffers = Vec::with_capacity(declared.len());
        let mut nan_count = None;
        let mut ray_count = None;
        for &(binding, _) in declared {
            buffers.push(match binding {
                0 => gpu.uniform_buffer("settings", &p.settings)?,
                1 => gpu.uniform_buffer("camera", &p.camera)?,
                NAN_COUNT_BINDING => {
                    nan_count = Some(buffers.len());
                    gpu.storage_buffer("nan_count", &[0u32])?
                }
                3 => gpu.storage_buffer("shapes", &at_least_one(&p.shapes))?,
                4 => gpu.storage_buffer("indices", &at_least_one(&p.indices))?,
                5 => gpu.storage_buffer("bvh_nodes", &at_least_one(&p.bvh_nodes))?,
                6 => gpu.storage_buffer("csg_nodes", &at_least_one(&p.csg_nodes))?,
                7 => gpu.storage_buffer("materials", &at_least_one(&p.materials))?,
                8 => gpu.storage_buffer("pigments", &at_least_one(&p.pigments))?,
                9 => gpu.uniform_buffer("environment", &p.environment)?,
                10 => gpu.storage_buffer("floats (texels and environment tables)", &at_least_one(&p.floats))?,
                11 => gpu.storage_buffer("point_lights", &at_least_one(&p.point_lights))?,
                12 => gpu.storage_buffer("area_lights", &at_least_one(&p.area_lights))?,
                RAY_COUNT_BINDING => {
                    ray_count = Some(buffers.len());
                    gpu.storage_buffer("ray_count", &[0u32; 2])?
                }
                b => {
                    return Err(GpuError::Validation(format!("render kernel declares unknown @group(1) @binding({b})")))
                }
            });
        }
        let nan_count =
            nan_count.ok_or_else(|| GpuError::Validation("render kernel does not declare the NaN counter".into()))?;
        Ok(Self { buffers, nan_count, ray_count })
    }

    fn refs(&self) -> Vec<&wgpu::Buffer> {
        self.buffers.iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use super::*;
    use crate::gpu::features::{EnvKind, RendererKind};
    use crate::sampling::Pcg32;

    /// Names of the functions reachable from the entry point (by naga's call statements).
    fn reachable_functions(module: &naga::Module) -> BTreeSet<String> {
        fn walk(block: &naga::Block, module: &naga::Module, seen: &mut BTreeSet<String>) {
            for st in block.iter() {
                match st {
                    naga::Statement::Call { function, .. } => {
                        let f = &module.functions[*function];
                        if seen.insert(f.name.clone().unwrap_or_default()) {
                            walk(&f.body, module, seen);
                        }
                    }
                    naga::Statement::Block(b) => walk(b, module, seen),
                    naga::Statement::If { accept, reject, .. } => {
                        walk(accept, module, seen);
                        walk(reject, module, seen);
                    }
                    naga::Statement::Switch { cases, .. } => cases.iter().for_each(|c| walk(&c.body, module, seen)),
                    naga::Statement::Loop { body, continuing, .. } => {
                        walk(body, module, seen);
                        walk(continuing, module, seen);
                    }
                    _ => {}
                }
            }
        }
        let mut seen = BTreeSet::new();
        for ep in &module.entry_points {
            walk(&ep.function.body, module, &mut seen);
        }
        seen
    }

    fn function_names(module: &naga::Module) -> BTreeSet<String> {
        module.functions.iter().map(|(_, f)| f.name.clone().unwrap_or_default()).collect()
    }

    /// Asserts the assembled kernel holds nothing the features do not need: every function
    /// is reachable from the entry point and every global (buffer or private array) is used.
    fn assert_minimal(features: &FeatureSet) -> naga::Module {
        assert_minimal_with(features, KernelVariant::default())
    }

    fn assert_minimal_with(features: &FeatureSet, variant: KernelVariant) -> naga::Module {
        let assembled = assemble_for(features, variant).unwrap_or_else(|e| panic!("{features:?}: {e}"));
        let v = assembled.validate().unwrap();
        let all = function_names(&v.module);
        let reachable = reachable_functions(&v.module);
        let unused: Vec<_> = all.difference(&reachable).collect();
        assert!(unused.is_empty(), "{features:?}: unused functions {unused:?}");
        let ep = v.info.get_entry_point(0);
        for (h, g) in v.module.global_variables.iter() {
            assert!(!ep[h].is_empty(), "{features:?}: unused global {:?}", g.name);
        }
        v.module
    }

    /// A random feature set respecting the invariants `FeatureSet::of` guarantees.
    fn random_features(rng: &mut Pcg32, renderer: RendererKind, environment: EnvKind) -> FeatureSet {
        let mut b = || rng.next_u32() % 2 == 0;
        let mut f = FeatureSet {
            sphere: b(),
            plane: b(),
            cube: b(),
            cylinder: b(),
            csg: b(),
            pigment_uniform: b(),
            pigment_checkered: b(),
            pigment_image: b(),
            diffuse: b(),
            specular: b(),
            dielectric: b(),
            point_lights: b(),
            area_lights: b(),
            nee: b(),
            renderer,
            environment,
            ..FeatureSet::default()
        };
        f.bvh = f.csg || f.sphere || f.cube || f.cylinder;
        if f.csg {
            f.csg_max_intervals = 1 + rng.next_u32() % 6;
            f.csg_max_depth = 1 + rng.next_u32() % 3;
        }
        if renderer == RendererKind::PointLight && !f.point_lights || renderer == RendererKind::OnOff {
            f.pigment_uniform = false;
            f.pigment_checkered = false;
            f.pigment_image = false;
        }
        if renderer == RendererKind::OnOff {
            f.environment = EnvKind::Background;
        }
        if !matches!(renderer, RendererKind::PathTracer | RendererKind::PointLight) {
            (f.diffuse, f.specular, f.dielectric, f.point_lights) = (false, false, false, false);
        }
        if renderer == RendererKind::PointLight {
            (f.specular, f.dielectric) = (false, false);
        }
        f.nee = f.nee && f.diffuse && renderer == RendererKind::PathTracer;
        f.area_lights = f.area_lights && f.nee;
        f
    }

    #[test]
    fn a_covering_set_of_feature_sets_assembles_to_minimal_valid_wgsl() {
        let mut rng = Pcg32::new(3, 5);
        let mut count = 0;
        for renderer in [RendererKind::OnOff, RendererKind::Flat, RendererKind::PointLight, RendererKind::PathTracer] {
            for environment in [EnvKind::Background, EnvKind::Uniform, EnvKind::Gradient, EnvKind::Image] {
                // Everything on, nothing on, and random subsets.
                let mut all = random_features(&mut rng, renderer, environment);
                (all.sphere, all.plane, all.cube, all.cylinder, all.csg, all.bvh) =
                    (true, true, true, true, true, true);
                all.csg_max_intervals = 4;
                all.csg_max_depth = 3;
                let none = random_features(&mut Pcg32::new(0, 0), renderer, environment);
                let none = FeatureSet { renderer, environment: none.environment, ..FeatureSet::default() };
                assert_minimal(&none);
                assert_minimal(&all);
                for _ in 0..6 {
                    assert_minimal(&random_features(&mut rng, renderer, environment));
                    count += 1;
                }
            }
        }
        assert_eq!(count, 96);
    }

    /// Kernel variants (resumable passes, docs/DESIGN.md "Loop limiter and path-granular
    /// passes"; ray counting) for every renderer, alone and together: valid, minimal, with
    /// their own globals; the plain kernels have none of them.
    #[test]
    fn kernel_variants_assemble_to_minimal_valid_wgsl() {
        let mut rng = Pcg32::new(7, 9);
        for renderer in [RendererKind::OnOff, RendererKind::Flat, RendererKind::PointLight, RendererKind::PathTracer] {
            let f = random_features(&mut rng, renderer, EnvKind::Uniform);
            for loop_limiter in [false, true] {
                for count_rays in [false, true] {
                    let m = assert_minimal_with(&f, KernelVariant { loop_limiter, count_rays });
                    let has = |name: &str| m.global_variables.iter().any(|(_, g)| g.name.as_deref() == Some(name));
                    assert_eq!(has("pass_state"), loop_limiter, "{f:?}");
                    assert_eq!(has("ray_count") && has("rays_traced"), count_rays, "{f:?}");
                }
            }
        }
    }

    #[test]
    fn a_spheres_only_kernel_has_no_csg_cylinder_texture_or_dielectric_code() {
        let mut b = crate::scene::SceneBuilder::new(4, 4);
        let m = b.diffuse(crate::color::Color::gray(0.5));
        b.sphere(crate::scene::Transform::IDENTITY, m);
        let scene = b.build().unwrap();
        let features = FeatureSet::of(&scene);
        let module = assert_minimal(&features);
        let names = function_names(&module);
        assert!(names.contains("sphere_span") && names.contains("radiance_path"), "{names:?}");
        for bad in ["csg", "cylinder", "cube", "plane", "texel", "image", "dielectric", "fresnel", "refract", "checker"]
        {
            assert!(!names.iter().any(|n| n.contains(bad)), "{bad} in {names:?}");
        }
        let globals: Vec<_> = module.global_variables.iter().filter_map(|(_, g)| g.name.clone()).collect();
        for bad in ["csg_nodes", "floats", "point_lights", "area_lights", "csg_pool"] {
            assert!(!globals.iter().any(|g| g == bad), "{bad} bound: {globals:?}");
        }
    }

    /// `shaders/angles.wgsl` against f64 atan2 on the device: every octant, both signed
    /// zeros, tiny and huge magnitudes, and the polar angle near the poles.
    #[test]
    fn precise_atan2_on_the_device_is_within_2e_7_rad_plus_an_ulp() {
        let Some(gpu) = crate::gpu::gpu_for_tests("precise_atan2") else { return };
        let mut rng = Pcg32::new(5, 7);
        let mut inputs: Vec<[f32; 2]> =
            vec![[0.0, 1.0], [1.0, 0.0], [0.0, -1.0], [-1.0, 0.0], [1.0, 1.0], [-1e-30, -1.0]];
        inputs.extend([[0.0, 0.0], [0.0, -0.0], [3e-39, 1.0], [1e30, -1e30], [1.0, 1e-7]]);
        for _ in 0..4096 {
            let scale = 10f32.powf(rng.next_f32() * 8.0 - 4.0);
            inputs.push([(rng.next_f32() * 2.0 - 1.0) * scale, (rng.next_f32() * 2.0 - 1.0) * scale]);
        }
        let src = format!(
            "{}\n{}\n@group(0) @binding(0) var<storage, read_write> io: array<vec2<f32>>;\n\
             @compute @workgroup_size(64)\n\
             fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{\n\
                 if (gid.x < arrayLength(&io)) {{ let p = io[gid.x]; io[gid.x] = vec2<f32>(atan2_precise(p.x, p.y), 0.0); }}\n\
             }}",
            "const PI: f32 = 3.14159265358979;",
            include_str!("../../shaders/angles.wgsl")
        );
        let kernel = gpu.compute_kernel("angles test", &src, "main").unwrap();
        let buffer = gpu.storage_buffer("io", &inputs).unwrap();
        let group = kernel.bind_group(&gpu, 0, &[&buffer]).unwrap();
        gpu.dispatch(&kernel, &[&group], [(inputs.len() as u32).div_ceil(64), 1, 1]).unwrap();
        let out: Vec<[f32; 2]> = gpu.read_buffer(&buffer, inputs.len()).unwrap();
        for (&[y, x], &[a, _]) in inputs.iter().zip(&out) {
            let want = f64::from(y).atan2(f64::from(x));
            // Zero vectors: the sign of y is dropped (documented); only |atan2| matters.
            let want = if y == 0.0 && x == 0.0 { want.abs() } else { want };
            // The fit's 1.1e-7, π's rounding in f32, and one ulp of the f32 result.
            let ulp = f64::from((want.abs() as f32).max(f32::MIN_POSITIVE)) * f64::from(f32::EPSILON);
            let err = (f64::from(a) - want).abs();
            assert!(err < 2e-7 + ulp, "atan2({y:e}, {x:e}) = {a} on the device, {want} in f64 (error {err:e})");
        }
    }
}
