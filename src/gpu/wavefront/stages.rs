//! The stages of the wavefront renderer: which kernels a scene gets, and what each holds.
//!
//! A stage is one compute kernel assembled from `shaders/` with the scene's feature names
//! *filtered to what that stage does* (the shading stage of the dielectric kind has no
//! traversal, CSG or diffuse code; the closest-hit stage has no materials beyond the BRDF
//! tag it sorts by), plus names that select the shared helpers the stage calls. So every
//! kernel holds only its own code: the call-graph test below checks that every function and
//! global of every stage is used, for a covering set of scenes.

use crate::gpu::features::{FeatureSet, KindUse, RendererKind, UV_SHAPES};
use crate::gpu::layout::brdf_kind;

use super::contract::StateBuffer;

/// One kernel of the wavefront renderer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stage {
    /// Camera rays and path start (path tracer).
    Camera,
    /// The whole estimate of OnOff, Flat and PointLight: one closest-hit query and the
    /// point lights' shadow rays per camera sample.
    FirstHit,
    /// Closest hit over the BVH and planes; CSG trees met go to the CSG queue.
    Intersect,
    /// Deferred CSG trees of the rays that met some.
    Csg,
    /// One path vertex at a surface of one BRDF kind (`Material::brdf`), over that kind's
    /// queue. Every kind of a scene launches one shared kernel ([`Stage::kernel_kinds`]).
    Shade(u32),
    /// Shadow rays, any-hit, with their deferred contributions.
    Shadow,
    /// Per-pixel sums of the batch's paths in a fixed order.
    Film,
    /// After the shadow stage: the closest-hit CSG work of the bounce is done; its queue is
    /// emptied so that the CSG stage's second launch covers the shadow rays' trees.
    ShadowCsgArgs,
    /// End of a bounce: count rays, empty the consumed queues and their launches.
    Advance,
}

impl Stage {
    /// The kernels that render a scene with features `f`, in no particular order.
    pub fn for_scene(f: &FeatureSet) -> Vec<Stage> {
        if f.renderer != RendererKind::PathTracer {
            return vec![Stage::FirstHit, Stage::Film];
        }
        let mut stages = vec![Stage::Camera, Stage::Intersect];
        if csg_queue(f) {
            stages.push(Stage::Csg);
        }
        stages.extend(shade_kinds(f).into_iter().map(Stage::Shade));
        if has_shadow_rays(f) {
            stages.push(Stage::Shadow);
            if csg_queue(f) {
                stages.push(Stage::ShadowCsgArgs);
            }
        }
        stages.extend([Stage::Film, Stage::Advance]);
        stages
    }

    /// The queue a shading stage drains (`shade_queue.x` in its WGSL: each shading stage
    /// binds its own small uniform holding it).
    pub fn shade_queue(self) -> Option<u32> {
        match self {
            Stage::Shade(kind) => Some(super::queue::shade(kind)),
            _ => None,
        }
    }

    /// The BRDF kinds whose code a shading stage's kernel holds: every kind of the scene.
    /// Kernels of their own would each hold the same path-state, stream, surface, pigment
    /// and (for the kinds that sample lights) light code, most of a shading kernel, around
    /// a few lines of BSDF (docs/DESIGN.md "One shading kernel"), so the kinds share one
    /// kernel, compiled once and launched once per kind over that kind's queue: the kind
    /// is the same in every lane of a launch, so the other kinds' code is skipped there.
    /// Empty for other stages.
    pub fn kernel_kinds(self, f: &FeatureSet) -> Vec<u32> {
        match self {
            Stage::Shade(_) => shade_kinds(f),
            _ => Vec::new(),
        }
    }

    /// The stage whose kernel this stage launches: the first of its kernel's kinds for a
    /// shading stage ([`Stage::kernel_kinds`]), itself for every other stage. Only those
    /// stages are assembled and compiled (`gpu::kernels::assemble_stages`).
    pub fn kernel_stage(self, f: &FeatureSet) -> Stage {
        match (self, self.kernel_kinds(f).first()) {
            (Stage::Shade(_), Some(&first)) => Stage::Shade(first),
            _ => self,
        }
    }

    /// The root module and entry point.
    pub fn entry(self) -> (&'static str, &'static str) {
        match self {
            Stage::Camera => ("wf_camera", "camera_stage"),
            Stage::FirstHit => ("wf_first_hit", "first_hit_stage"),
            Stage::Intersect => ("wf_intersect", "intersect_stage"),
            Stage::Csg => ("wf_csg", "csg_stage"),
            Stage::Shade(_) => ("wf_shade", "shade_stage"),
            Stage::Shadow => ("wf_shadow", "shadow_stage"),
            Stage::Film => ("wf_film", "film_stage"),
            Stage::ShadowCsgArgs => ("wf_control", "shadow_csg_args"),
            Stage::Advance => ("wf_control", "advance"),
        }
    }

    /// The group-0 buffers the stage binds.
    pub fn buffers(self, f: &FeatureSet) -> Vec<StateBuffer> {
        use StateBuffer::*;
        let mut buffers = self.buffers_with_pool(f);
        if csg_pool_private(f) {
            buffers.retain(|b| *b != CsgPool);
        }
        buffers
    }

    fn buffers_with_pool(self, f: &FeatureSet) -> Vec<StateBuffer> {
        use StateBuffer::*;
        let mut buffers = match self {
            Stage::Camera => vec![Batch, Paths],
            Stage::FirstHit if f.csg => vec![Batch, Control, Paths, CsgPool],
            Stage::FirstHit => vec![Batch, Control, Paths],
            Stage::Intersect if csg_queue(f) => vec![Batch, Control, Queues, Paths, Words, DeferredRefs],
            // Trees evaluated where the traversal meets them.
            Stage::Intersect if f.csg => vec![Batch, Control, Queues, Paths, Words, CsgPool],
            Stage::Intersect if f.geometry() => vec![Batch, Control, Queues, Paths, Words],
            // Nothing to hit: every ray escapes and no hit is recorded.
            Stage::Intersect => vec![Batch, Control, Queues, Paths],
            Stage::Csg if has_shadow_rays(f) => {
                vec![Batch, Control, Queues, Paths, Words, Shadow, DeferredRefs, CsgPool]
            }
            Stage::Csg => vec![Batch, Control, Queues, Paths, Words, DeferredRefs, CsgPool],
            // A kernel's buffers are those of all its kinds (Stage::kernel_kinds).
            Stage::Shade(kind)
                if self.kernel_kinds(f).into_iter().chain([kind]).any(casts_shadow_rays) && has_shadow_rays(f) =>
            {
                vec![Batch, Control, Queues, Paths, Words, Shadow]
            }
            Stage::Shade(_) => vec![Batch, Control, Queues, Paths, Words],
            // Trees met are handed to the CSG stage.
            Stage::Shadow if csg_queue(f) => vec![Batch, Control, Queues, Paths, Shadow, DeferredRefs],
            Stage::Shadow if f.csg => vec![Batch, Control, Queues, Paths, Shadow, CsgPool],
            Stage::Shadow => vec![Batch, Control, Queues, Paths, Shadow],
            Stage::Film => vec![Batch, Control, Paths, Film],
            Stage::ShadowCsgArgs | Stage::Advance => vec![Control],
        };
        if matches!(self, Stage::Shade(_)) {
            buffers.push(ShadeQueue);
        }
        // The launch arguments of the queues the stage pushes to (or, for the control
        // kernels, empties). In binding order: bind groups pair buffers with bindings by
        // position (ComputeKernel::bind_group).
        buffers.extend(self.launch_args_written(f));
        buffers.sort();
        buffers
    }

    /// The buffers of launch arguments this stage writes: those of the queues it pushes to
    /// (never the one it is launched from: contract::launch_args), or, for the control
    /// kernels, of the queues they empty.
    fn launch_args_written(self, f: &FeatureSet) -> Vec<StateBuffer> {
        use StateBuffer::*;
        match self {
            Stage::Intersect if csg_queue(f) => vec![ArgsHits, ArgsCsg],
            Stage::Intersect if !f.geometry() => vec![],
            Stage::Intersect | Stage::Csg => vec![ArgsHits],
            Stage::Shade(_) => vec![ArgsRays],
            Stage::Shadow if csg_queue(f) => vec![ArgsCsg],
            // The control kernels share one module (wf_control.wgsl), so one set of bindings.
            Stage::ShadowCsgArgs | Stage::Advance if csg_queue(f) => vec![ArgsRays, ArgsHits, ArgsCsg],
            Stage::ShadowCsgArgs | Stage::Advance => vec![ArgsRays, ArgsHits],
            _ => vec![],
        }
    }

    /// The assembly feature names of this stage for a scene with features `f`.
    pub fn names(self, f: &FeatureSet) -> Vec<&'static str> {
        let kinds = self.kernel_kinds(f);
        if kinds.len() > 1 {
            // A shared shading kernel: every kind's names, but a shape's "uv unused" only
            // where no kind reads it.
            let lists: Vec<Vec<&'static str>> = kinds.iter().map(|&k| Stage::Shade(k).kind_names(f)).collect();
            let mut names = lists.concat();
            names.sort();
            names.dedup();
            names.retain(|n| {
                !UV_SHAPES.iter().any(|&(_, _, unused)| unused == *n) || lists.iter().all(|l| l.contains(n))
            });
            return names;
        }
        self.kind_names(f)
    }

    /// [`Stage::names`] for a stage of one kind.
    fn kind_names(self, f: &FeatureSet) -> Vec<&'static str> {
        let scene = f.names();
        let keep = |allowed: &[&'static str]| -> Vec<&'static str> {
            scene.iter().copied().filter(|n| allowed.contains(n)).collect()
        };
        const SHAPES: [&str; 6] = ["GEOMETRY", "SPHERE", "PLANE", "CUBE", "CYLINDER", "MESH"];
        let mut names: Vec<&'static str> = match self {
            Stage::Camera => vec!["CAMERA", "WF_RAY_STORE", "WF_PATH_ID"],
            Stage::FirstHit => {
                let mut n = scene.clone();
                n.extend(["CAMERA", "WF_PATH_ID", "WF_COUNT", "TRAVERSE", "SPANS"]);
                if f.renderer != RendererKind::OnOff {
                    n.push("FIRST_HIT");
                }
                if f.materials() {
                    n.push("PIGMENTS");
                }
                n
            }
            Stage::Intersect => {
                let mut n = keep(
                    &[
                        &SHAPES[..],
                        &["CSG", "BVH", "ROUND_SPHERES", "OBJECT_LIST", "UNROLLED_PLANES", "BVH_WALK", "MATERIALS"],
                    ]
                    .concat(),
                );
                n.extend(["WF_QUEUED", "WF_RAY_LOAD", "TRAVERSE", "SPANS"]);
                if f.geometry() {
                    // Rays that hit something go on to a queue (with nothing to hit,
                    // every path ends here).
                    n.push("WF_PUSH");
                }
                if csg_queue(f) {
                    n.extend(["CSG_QUEUE", "WF_DEFERRED"]);
                }
                n
            }
            Stage::Csg => {
                // Meshes are never CSG operands: no mesh code here.
                let mut n = keep(&[&SHAPES[..5], &["CSG", "MATERIALS"]].concat());
                n.extend(["WF_QUEUED", "WF_PUSH", "WF_RAY_LOAD", "SPANS", "WF_DEFERRED"]);
                if has_shadow_rays(f) {
                    n.push("WF_SHADOW_CSG");
                }
                n
            }
            Stage::Shade(kind) => {
                let mut allowed = vec![
                    "MATERIALS",
                    "SHADING",
                    "PIGMENT_UNIFORM",
                    "PIGMENT_CHECKERED",
                    "PIGMENT_IMAGE",
                    "AREA_LIGHTS",
                    "SPHERE_LIGHTS",
                    "CUBE_LIGHTS",
                    "MESH_LIGHTS",
                    "PRIMITIVE_LIGHTS",
                    "NEE",
                ];
                allowed.extend(SHAPES);
                allowed.push(kind_name(kind));
                // The kinds whose vertices this stage shades: its own, and smooth glass in the
                // rough-dielectric stage of a scene with both (glass_shaded_as_rough).
                let mut used = f.shade_use[kind as usize];
                if kind == brdf_kind::ROUGH_DIELECTRIC && glass_shaded_as_rough(f) {
                    allowed.push(kind_name(brdf_kind::DIELECTRIC));
                    used = used.union(f.shade_use[brdf_kind::DIELECTRIC as usize]);
                }
                if microfacet_kind(kind) {
                    // Their energy rows (tables::Table::Rows).
                    allowed.push("ENERGY_ROWS");
                }
                if casts_shadow_rays(kind) {
                    allowed.push("POINT_LIGHTS");
                    if f.nee {
                        allowed.extend(["ENV_UNIFORM", "ENV_GRADIENT", "ENV_IMAGE"]);
                    }
                    if has_shadow_rays(f) {
                        allowed.push("SHADOWS");
                    }
                }
                let mut n = keep(&allowed);
                // Only what this kind's materials sit on and read, and where the stage
                // samples lights, what the lights need (features::KindUse).
                if casts_shadow_rays(kind) && n.contains(&"NEE") {
                    used = used.union(f.light_use);
                }
                n.retain(|x| !KindUse::NAMES.contains(x) || used.has(x));
                let samples_lights = casts_shadow_rays(kind) && n.contains(&"NEE") && n.contains(&"SHADOWS");
                if samples_lights && f.light_use.textured() {
                    // Some light's emission varies over its surface: NEE finds the uv at
                    // the sampled point (else it reads the uniform colour).
                    n.push("TEXTURED_LIGHTS");
                }
                // Shapes on which no material of the stage reads a pigment at the hit's uv
                // skip computing it (a textured light's sampled point still needs it).
                for (shape, uv, unused) in UV_SHAPES {
                    if n.contains(&shape) && !used.has(uv) && !n.contains(&"TEXTURED_LIGHTS") {
                        n.push(unused);
                    }
                }
                if used.has("EMISSION") || n.contains(&"TEXTURED_LIGHTS") {
                    // The lights' object normals: for emission's MIS density, and for the
                    // face of a textured light's sampled point.
                    n.push("LIGHT_NORMALS");
                }
                if used.has("EMISSION") {
                    n.push("EMISSION");
                    if used.has("TEXTURED_EMISSION") {
                        n.push("TEXTURED_EMISSION");
                    }
                } else if !casts_shadow_rays(kind) {
                    // Neither emission's MIS nor light sampling: no light code at all.
                    n.retain(|x| !LIGHT_NAMES.contains(x));
                }
                if !casts_shadow_rays(kind) && !n.contains(&"AREA_LIGHTS") {
                    // Only emitters hit after a non-delta vertex need NEE's densities here.
                    n.retain(|x| *x != "NEE");
                }
                // Sampling mesh lights reads their triangle tables in `floats`.
                let mesh_lights = ["MESH_LIGHTS", "SHADOWS"].iter().all(|x| n.contains(x));
                if n.contains(&"PIGMENT_IMAGE") || n.contains(&"ENV_IMAGE") || mesh_lights {
                    n.push("TEXTURES");
                }
                n.extend([
                    "PIGMENTS",
                    "WF_QUEUED",
                    "WF_PUSH",
                    "WF_RAY_LOAD",
                    "WF_BETA_LOAD",
                    "WF_RAY_STORE",
                    "WF_PATH_ID",
                ]);
                if n.contains(&"EMISSION") {
                    n.push("WF_RADIANCE_ADD");
                }
                n
            }
            Stage::Shadow => {
                let mut n = keep(
                    &[&SHAPES[..], &["CSG", "BVH", "ROUND_SPHERES", "OBJECT_LIST", "UNROLLED_PLANES", "BVH_WALK"]]
                        .concat(),
                );
                n.extend(["SHADOWS", "WF_QUEUED", "TRAVERSE", "SPANS"]);
                if !shadow_rays_counted_by_queue(f) {
                    n.push("WF_COUNT");
                }
                if csg_queue(f) {
                    n.extend(["CSG_QUEUE", "WF_DEFERRED", "WF_PUSH"]);
                }
                n
            }
            Stage::Advance if shadow_rays_counted_by_queue(f) => vec!["WF_SHADOW_COUNT"],
            Stage::Film | Stage::ShadowCsgArgs | Stage::Advance => vec![],
        };
        // Queue lengths are read by the queued stages and reset by the control kernels.
        if names.contains(&"WF_QUEUED") || matches!(self, Stage::ShadowCsgArgs | Stage::Advance) {
            names.push("WF_LENGTHS");
        }
        // A path's queue shard: where it is pushed, whose shadow-ray counter it adds to.
        if names.contains(&"WF_PUSH") || names.contains(&"WF_COUNT") {
            names.push("WF_SHARD");
        }
        // Launches over all of the batch's slots, shard by shard.
        if matches!(self, Stage::Camera | Stage::FirstHit | Stage::Intersect) {
            names.push("WF_DIRECT");
        }
        // Where the tables are read from (their bindings are declared only where used).
        names.extend(f.tables.for_stage(self.hot()).names());
        // The path state's and the buffer tables' 16-byte elements as 64-bit words.
        if f.wide_words {
            names.push(FeatureSet::DEVICE_NAMES[0]);
        }
        if !f.geometry() {
            // Nothing to intersect: no spans or traversal helpers to call.
            names.retain(|n| !["SPANS", "TRAVERSE"].contains(n));
            if self == Stage::Intersect {
                names.retain(|n| *n != "MATERIALS");
            }
        }
        // How the traversing stages go through the scene: a walk of the BVH, a loop over the
        // planes (both bounded by settings), or unrolled lists only.
        let walks = names.contains(&"BVH") && !names.contains(&"OBJECT_LIST");
        let plane_loop = names.contains(&"PLANE") && !names.contains(&"UNROLLED_PLANES");
        // A walk over round spheres tests its leaves in the world, without spans.
        let span_leaves = walks && !names.contains(&"ROUND_SPHERES");
        // CSG trees evaluated in this stage (not handed to the CSG stage's queue).
        let evaluates_csg = names.contains(&"CSG") && !names.contains(&"CSG_QUEUE");
        // Finite shapes' spans: for BVH leaves, listed objects and CSG leaves (planes alone
        // cross by their own test).
        let listed = names.contains(&"BVH") && !walks;
        if names.contains(&"SPANS") && (span_leaves || listed || evaluates_csg) {
            names.push("SHAPE_SPANS");
        }
        // Placed shapes and the camera transform points; nothing else does.
        let geometry = f.geometry();
        // The hit record: stored where a query ends (if anything can be hit), read back by
        // the CSG and shading stages.
        if geometry && matches!(self, Stage::Intersect | Stage::Csg) {
            names.push("WF_HIT_STORE");
        }
        // Where a query ends (classify), smooth glass goes to the rough-dielectric stage's
        // queue in a scene with both kinds of glass.
        if matches!(self, Stage::Intersect | Stage::Csg) && glass_shaded_as_rough(f) {
            names.push("SMOOTH_GLASS_AS_ROUGH");
        }
        if matches!(self, Stage::Csg | Stage::Shade(_)) {
            names.push("WF_HIT_LOAD");
        }
        if matches!(self, Stage::Camera | Stage::FirstHit)
            || (geometry && matches!(self, Stage::Intersect | Stage::Csg | Stage::Shade(_) | Stage::Shadow))
        {
            names.push("AFFINE");
        }
        // Where a closest-hit query ends (classify), a ray that hit nothing adds the
        // environment's radiance, MIS-weighted, and its path ends there: no escape stage.
        if matches!(self, Stage::Intersect | Stage::Csg) {
            names.extend(scene.iter().copied().filter(|n| ESCAPE_NAMES.contains(n)));
            if names.contains(&"ENV_IMAGE") {
                names.push("TEXTURES");
            }
            names.extend(["WF_BETA_LOAD", "WF_RADIANCE_ADD", "ESCAPES"]);
        }
        // The settings uniform, for the stages that read it.
        let settings = match self {
            Stage::Camera | Stage::FirstHit | Stage::Shade(_) => true,
            Stage::Intersect | Stage::Shadow => geometry && (walks || plane_loop),
            _ => false,
        } || (names.contains(&"ESCAPES") && names.contains(&"NEE"));
        if settings {
            names.push("SETTINGS");
        }
        // The environment uniform: escaped rays, and NEE (light count, environment samples).
        let environment = match self {
            Stage::Intersect | Stage::Csg => true,
            Stage::FirstHit => scene.contains(&"SHADING"),
            Stage::Shade(_) => names.contains(&"NEE"),
            _ => false,
        };
        if environment {
            names.push("ENVIRONMENT");
        }
        names.push(self.stage_name());
        if f.renderer == RendererKind::PathTracer && self != Stage::FirstHit {
            names.push("PATHTRACER");
        }
        // The microfacet kinds' shared code (microfacet.wgsl, which brdf.wgsl dispatches to),
        // wherever one of them is shaded; in the shading stage their sampled direction is
        // evaluated in the loop over directions (wf_shade.wgsl, BsdfSample::pending).
        if (0..brdf_kind::COUNT).any(|k| microfacet_kind(k) && names.contains(&kind_name(k))) {
            names.push("MICROFACET");
        }
        if names.contains(&"CSG") && csg_pool_private(f) {
            names.push("CSG_POOL_PRIVATE");
        }
        if names.contains(&"CSG") && csg_sweepable(f) && f.csg_sweeps {
            names.push("CSG_SWEEPS");
        }
        // The tree records: where trees are evaluated, and where an object list reads
        // their bounds.
        if names.contains(&"CSG") && (!names.contains(&"CSG_QUEUE") || names.contains(&"OBJECT_LIST")) {
            names.push("CSG_TREES");
        }
        // The object references (`indices`): read by the BVH walk, the planes' loop and CSG
        // evaluation; unrolled lists hold theirs as constants.
        if names.contains(&"SPANS") && (walks || plane_loop || evaluates_csg) {
            names.push("OBJECT_REFS");
        }
        // Spans of shapes known only by an index at run time (walks' leaves, CSG leaves).
        if names.contains(&"SHAPE_SPANS") && (span_leaves || evaluates_csg) {
            names.push("INDEXED_SHAPES");
        }
        names.sort();
        names.dedup();
        names
    }

    fn stage_name(self) -> &'static str {
        match self {
            Stage::Camera => "STAGE_CAMERA",
            Stage::FirstHit => "STAGE_FIRST_HIT",
            Stage::Intersect => "STAGE_INTERSECT",
            Stage::Csg => "STAGE_CSG",
            Stage::Shade(_) => "STAGE_SHADE",
            Stage::Shadow => "STAGE_SHADOW",
            Stage::Film => "STAGE_FILM",
            Stage::ShadowCsgArgs | Stage::Advance => "STAGE_CONTROL",
        }
    }

    /// Every name [`Self::names`] may add beyond the scene's.
    pub const NAMES: [&'static str; 49] = [
        "ESCAPES",
        "SPHERE_UV_UNUSED",
        "CUBE_UV_UNUSED",
        "CYLINDER_UV_UNUSED",
        "MICROFACET",
        "CSG_SWEEPS",
        "EMISSION",
        "TEXTURED_EMISSION",
        "TEXTURED_LIGHTS",
        "LIGHT_NORMALS",
        "CSG_POOL_PRIVATE",
        "CSG_TREES",
        "WF_HIT_STORE",
        "WF_HIT_LOAD",
        "AFFINE",
        "ENVIRONMENT",
        "SETTINGS",
        "STAGE_CONTROL",
        "CAMERA",
        "FIRST_HIT",
        "PIGMENTS",
        "TRAVERSE",
        "SPANS",
        "SHAPE_SPANS",
        "OBJECT_REFS",
        "INDEXED_SHAPES",
        "CSG_QUEUE",
        "WF_QUEUED",
        "WF_LENGTHS",
        "WF_SHARD",
        "WF_DIRECT",
        "WF_SHADOW_COUNT",
        "WF_PUSH",
        "WF_RAY_LOAD",
        "WF_BETA_LOAD",
        "WF_RAY_STORE",
        "WF_PATH_ID",
        "WF_RADIANCE_ADD",
        "WF_COUNT",
        "WF_DEFERRED",
        "WF_SHADOW_CSG",
        "SMOOTH_GLASS_AS_ROUGH",
        "STAGE_CAMERA",
        "STAGE_FIRST_HIT",
        "STAGE_INTERSECT",
        "STAGE_CSG",
        "STAGE_SHADE",
        "STAGE_SHADOW",
        "STAGE_FILM",
    ];

    /// Whether the stage walks the BVH or evaluates CSG trees, reading the scene's tables
    /// many times per ray: there a texel fetch (a call on llvmpipe) costs more run time
    /// than a storage load, so the large tables stay storage buffers
    /// (`tables::TableForms::for_stage`).
    pub fn hot(self) -> bool {
        matches!(self, Stage::FirstHit | Stage::Intersect | Stage::Csg | Stage::Shadow)
    }

    /// A short name for labels and reports.
    pub fn label(self) -> String {
        match self {
            Stage::Shade(k) => format!("shade[{}]", kind_name(k).to_lowercase()),
            other => format!("{other:?}").to_lowercase(),
        }
    }
}

/// Whether a scene's CSG trees are small enough to keep their leaves' spans in private
/// memory (at most [`super::contract::CSG_PRIVATE_POOL_MAX`] per path): faster than the
/// storage pool on SIMD software GPUs, and bounded, so kernels still do not grow with a scene.
pub fn csg_pool_private(f: &FeatureSet) -> bool {
    f.csg && super::contract::csg_pool_entries(f) <= super::contract::CSG_PRIVATE_POOL_MAX
}

/// Whether a tree has a sweep table and its spans live in the shared pool: then its queries
/// either give up after their walk budget (kernels without `FeatureSet::csg_sweeps`) or go
/// on with the sweeps (shaders/csg.wgsl).
pub fn csg_sweepable(f: &FeatureSet) -> bool {
    f.csg_sweep_nodes > 0 && !csg_pool_private(f)
}

/// Whether CSG trees are evaluated in a stage of their own: the scene has CSG and few
/// enough trees to defer them (`prepare::CSG_DEFER_MAX`, as `cpu::World` decides); otherwise
/// the traversal evaluates each tree where it meets it.
pub fn csg_queue(f: &FeatureSet) -> bool {
    f.csg && f.csg_trees as usize <= crate::prepare::CSG_DEFER_MAX
}

/// Whether path vertices queue shadow rays (point lights or NEE, at non-delta vertices);
/// how many per vertex is a run-time value (`BatchUniform::shadow_rays`), so kernel code
/// does not grow with the number of lights.
pub fn has_shadow_rays(f: &FeatureSet) -> bool {
    f.renderer == RendererKind::PathTracer && f.non_delta() && (f.point_lights || f.nee)
}

/// Whether `advance` counts the shadow rays by the shadow queue's length: without point
/// lights a vertex queues at most its one NEE ray. With them a path may queue several, and
/// the shadow stage counts what it traces (`WF_COUNT`, an atomic per invocation).
fn shadow_rays_counted_by_queue(f: &FeatureSet) -> bool {
    has_shadow_rays(f) && !f.point_lights
}

/// The BRDF kinds a scene shades, each with its own kernel and queue (smooth glass has
/// none where `glass_shaded_as_rough`).
pub fn shade_kinds(f: &FeatureSet) -> Vec<u32> {
    (0..brdf_kind::COUNT)
        .filter(|&k| f.has_brdf_kind(k) && !(k == brdf_kind::DIELECTRIC && glass_shaded_as_rough(f)))
        .collect()
}

/// Whether smooth glass is shaded by the rough-dielectric stage, as a delta at run time
/// (as a smooth conductor is in the conductor stage): where a scene has both kinds of
/// glass, a stage of its own would compile the path state, stream and surface code a second
/// time for the few lines of a Fresnel choice. A scene with smooth glass alone keeps its
/// small stage, without GGX.
pub fn glass_shaded_as_rough(f: &FeatureSet) -> bool {
    f.renderer == RendererKind::PathTracer && f.dielectric && f.rough_dielectric
}

/// The assembly name of a BRDF kind's code.
pub fn kind_name(kind: u32) -> &'static str {
    match kind {
        brdf_kind::DIFFUSE => "DIFFUSE",
        brdf_kind::SPECULAR => "SPECULAR",
        brdf_kind::DIELECTRIC => "DIELECTRIC",
        brdf_kind::CONDUCTOR => "CONDUCTOR",
        brdf_kind::ROUGH_DIELECTRIC => "ROUGH_DIELECTRIC",
        _ => "PLASTIC",
    }
}

/// The scene's names (FeatureSet::names) that the escaped rays' code reads: the environment's
/// kind and NEE (the MIS weight).
const ESCAPE_NAMES: [&str; 4] = ["ENV_UNIFORM", "ENV_GRADIENT", "ENV_IMAGE", "NEE"];

/// The area lights' names (FeatureSet::names): a shading stage that neither samples lights
/// nor weighs emission against them leaves them out.
const LIGHT_NAMES: [&str; 5] = ["AREA_LIGHTS", "SPHERE_LIGHTS", "CUBE_LIGHTS", "MESH_LIGHTS", "PRIMITIVE_LIGHTS"];

/// Kinds whose vertices may sample lights (a smooth conductor is a delta, decided per
/// material at run time; the mirror and smooth glass never).
fn casts_shadow_rays(kind: u32) -> bool {
    !matches!(kind, brdf_kind::SPECULAR | brdf_kind::DIELECTRIC)
}

fn microfacet_kind(kind: u32) -> bool {
    matches!(kind, brdf_kind::CONDUCTOR | brdf_kind::ROUGH_DIELECTRIC | brdf_kind::PLASTIC)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::wavefront::contract::{launch_args, queue};

    /// The queues a stage's launches cover (`Runner::bounce`).
    fn launched_from(stage: Stage) -> Vec<u32> {
        match stage {
            Stage::Intersect => vec![queue::RAY, queue::RAY + 1],
            Stage::Csg => vec![queue::CSG, queue::SHADOW_CSG],
            Stage::Shade(kind) => vec![queue::shade(kind)],
            Stage::Shadow => vec![queue::SHADOW],
            _ => vec![],
        }
    }

    /// Smooth glass has a shading stage of its own unless the scene also has rough glass;
    /// then the rough-dielectric stage holds the smooth kind's code too, and the closest-hit
    /// stages queue smooth glass there.
    #[test]
    fn smooth_glass_goes_to_the_rough_stage_only_beside_rough_glass() {
        let glass = |rough: bool| FeatureSet {
            sphere: true,
            bvh: true,
            diffuse: true,
            dielectric: true,
            rough_dielectric: rough,
            nee: true,
            area_lights: true,
            renderer: RendererKind::PathTracer,
            ..FeatureSet::default()
        };
        let alone = glass(false);
        assert!(!glass_shaded_as_rough(&alone));
        assert!(Stage::for_scene(&alone).contains(&Stage::Shade(brdf_kind::DIELECTRIC)));
        assert!(!Stage::Intersect.names(&alone).contains(&"SMOOTH_GLASS_AS_ROUGH"));
        let both = glass(true);
        assert!(glass_shaded_as_rough(&both));
        let stages = Stage::for_scene(&both);
        assert!(!stages.contains(&Stage::Shade(brdf_kind::DIELECTRIC)));
        assert!(stages.contains(&Stage::Shade(brdf_kind::ROUGH_DIELECTRIC)));
        let rough = Stage::Shade(brdf_kind::ROUGH_DIELECTRIC).names(&both);
        assert!(rough.contains(&"DIELECTRIC") && rough.contains(&"ROUGH_DIELECTRIC"), "{rough:?}");
        // One shading kernel, which holds smooth glass's code for the rough stage, or beside
        // smooth glass alone for its own stage, without GGX.
        assert_eq!(Stage::Shade(brdf_kind::DIFFUSE).names(&both), rough);
        let diffuse = Stage::Shade(brdf_kind::DIFFUSE).names(&alone);
        assert!(diffuse.contains(&"DIELECTRIC") && !diffuse.contains(&"MICROFACET"), "{diffuse:?}");
        assert!(Stage::Intersect.names(&both).contains(&"SMOOTH_GLASS_AS_ROUGH"));
        let with_csg = FeatureSet { csg: true, csg_trees: 1, csg_max_leaves: 2, ..both };
        assert!(csg_queue(&with_csg) && Stage::Csg.names(&with_csg).contains(&"SMOOTH_GLASS_AS_ROUGH"));
    }

    /// Every kind shares one shading kernel, with every kind's code and one copy of the
    /// light code: its stages assemble to the same source, which `stage_kernels` compiles
    /// once, and bind the same buffers (the shadow rays', which the delta kinds never write).
    #[test]
    fn every_kind_shares_one_shading_kernel() {
        let f = FeatureSet {
            sphere: true,
            bvh: true,
            pigment_uniform: true,
            diffuse: true,
            conductor: true,
            plastic: true,
            specular: true,
            dielectric: true,
            nee: true,
            area_lights: true,
            sphere_lights: true,
            renderer: RendererKind::PathTracer,
            ..FeatureSet::default()
        };
        let kinds =
            [brdf_kind::DIFFUSE, brdf_kind::SPECULAR, brdf_kind::DIELECTRIC, brdf_kind::CONDUCTOR, brdf_kind::PLASTIC];
        let mut sorted = kinds.to_vec();
        sorted.sort();
        for kind in kinds {
            assert_eq!(Stage::Shade(kind).kernel_kinds(&f), sorted);
            assert_eq!(Stage::Shade(kind).buffers(&f), Stage::Shade(brdf_kind::DIFFUSE).buffers(&f));
        }
        assert!(Stage::Shade(brdf_kind::SPECULAR).buffers(&f).contains(&StateBuffer::Shadow));
        let mirror_only = FeatureSet { dielectric: false, diffuse: false, conductor: false, plastic: false, ..f };
        assert_eq!(Stage::Shade(brdf_kind::SPECULAR).kernel_kinds(&mirror_only), vec![brdf_kind::SPECULAR]);
        assert!(!Stage::Shade(brdf_kind::SPECULAR).buffers(&mirror_only).contains(&StateBuffer::Shadow));
        assert!(Stage::Intersect.kernel_kinds(&f).is_empty());
        let shared = Stage::Shade(brdf_kind::SPECULAR).names(&f);
        for name in ["DIFFUSE", "SPECULAR", "DIELECTRIC", "CONDUCTOR", "PLASTIC", "NEE", "SHADOWS", "MICROFACET"] {
            assert!(shared.contains(&name), "{name} missing from {shared:?}");
        }
        // A mirror alone samples no lights: no shadow rays, no microfacet code.
        let mirror = Stage::Shade(brdf_kind::SPECULAR).names(&mirror_only);
        assert!(!mirror.contains(&"SHADOWS") && !mirror.contains(&"MICROFACET"), "{mirror:?}");
        let source = |kind| crate::gpu::kernels::assemble_stage(&f, Stage::Shade(kind)).unwrap().source;
        for kind in kinds {
            assert_eq!(source(kind), source(brdf_kind::DIFFUSE));
        }
    }

    /// A shading stage skips a shape kind's uv where none of its materials on that kind
    /// reads a textured pigment and no textured light is sampled: a checkered floor under
    /// plain spheres keeps the plane's uv only; a checkered sphere, or a checkered light,
    /// keeps the sphere's.
    #[test]
    fn shading_stages_skip_the_uv_no_pigment_reads() {
        use crate::color::Color;
        use crate::scene::{Brdf, Material, Pigment, SceneBuilder, Transform};
        let checkers = Pigment::Checkered { n: 4, on: Color::WHITE, off: Color::BLACK };
        let diffuse_names = |checkered_sphere: bool, checkered_light: bool| {
            let mut b = SceneBuilder::new(2, 2);
            let plain = b.diffuse(Color::gray(0.5));
            let floor = b.material(Material::new(Brdf::Diffuse { pigment: checkers.clone() }, Pigment::default()));
            let emitted = if checkered_light { checkers.clone() } else { Pigment::Uniform(Color::WHITE) };
            let lamp = b.material(Material::new(Brdf::Diffuse { pigment: Pigment::default() }, emitted));
            b.plane(Transform::IDENTITY, floor).cube(Transform::translation(glam::DVec3::Z * 5.0), lamp);
            b.sphere(Transform::translation(glam::DVec3::Z), if checkered_sphere { floor } else { plain });
            Stage::Shade(brdf_kind::DIFFUSE).names(&FeatureSet::of(&b.build().unwrap()))
        };
        let plain = diffuse_names(false, false);
        assert!(plain.contains(&"SPHERE_UV_UNUSED") && !plain.contains(&"PIGMENT_IMAGE"), "{plain:?}");
        // The lamp's cube is diffuse too, but emits a uniform colour.
        assert!(plain.contains(&"CUBE_UV_UNUSED") && !plain.contains(&"CYLINDER_UV_UNUSED"), "{plain:?}");
        let textured = diffuse_names(true, false);
        assert!(!textured.contains(&"SPHERE_UV_UNUSED") && textured.contains(&"CUBE_UV_UNUSED"), "{textured:?}");
        let lit = diffuse_names(false, true);
        assert!(lit.contains(&"TEXTURED_LIGHTS"), "{lit:?}");
        assert!(!lit.iter().any(|n| n.ends_with("_UV_UNUSED")), "{lit:?}");
    }

    /// wgpu refuses a dispatch that uses one buffer both as its indirect arguments and as
    /// writable storage, and bind groups pair buffers with bindings by position: so no
    /// stage may bind the arguments it is launched from, and every stage lists its buffers
    /// in binding order. Over scenes with and without CSG (deferred or not) and shadow rays.
    #[test]
    fn no_stage_writes_the_launch_arguments_it_is_launched_from() {
        let mut cases = Vec::new();
        for (csg, trees) in [(false, 0), (true, 3), (true, crate::prepare::CSG_DEFER_MAX as u32 + 1)] {
            for (nee, point_lights) in [(false, false), (true, false), (false, true)] {
                cases.push(FeatureSet {
                    sphere: true,
                    bvh: true,
                    csg,
                    csg_trees: trees,
                    csg_max_leaves: if csg { 2 } else { 0 },
                    diffuse: true,
                    dielectric: true,
                    nee,
                    point_lights,
                    area_lights: nee,
                    renderer: RendererKind::PathTracer,
                    ..FeatureSet::default()
                });
            }
        }
        for f in &cases {
            for stage in Stage::for_scene(f) {
                let buffers = stage.buffers(f);
                assert!(buffers.windows(2).all(|w| w[0].binding() < w[1].binding()), "{stage:?}: {buffers:?}");
                for q in launched_from(stage) {
                    assert!(!buffers.contains(&launch_args(q)), "{stage:?} binds the arguments of queue {q}");
                }
            }
        }
    }
}
