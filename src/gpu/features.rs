//! What a scene needs from the GPU kernel, so the assembled WGSL holds nothing else.
//!
//! Specialising the kernel per scene keeps register pressure and compile time down (a
//! spheres-only scene never compiles CSG evaluation or texture lookups) and lets
//! fixed-size arrays (a CSG query's leaf spans, its walk's stack) be sized from the scene
//! instead of a worst case.

use super::tables::TableForms;
use crate::scene::{Environment, Pigment, Renderer, Scene, Shape, ShapeKind};

/// CSG bounds compiled into a full-featured kernel ([`FeatureSet::full_for`]): a general
/// kernel is sized for the worst scene it accepts; these cover every example scene, and a
/// scene with larger bounds raises them.
pub const FULL_CSG_MAX_LEAVES: u32 = 16;
/// The least CSG tree depth (CSG nodes on the longest root-to-leaf path) a full-featured
/// kernel's evaluation stack is sized for; see [`FULL_CSG_MAX_LEAVES`].
pub const FULL_CSG_MAX_DEPTH: u32 = 8;

/// Environment kinds, for specialisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum EnvKind {
    /// No environment: escaping rays see the renderer's background colour.
    #[default]
    Background,
    /// One colour in every direction (`Environment::Uniform`).
    Uniform,
    /// Zenith, horizon and nadir colours blended by direction (`Environment::Gradient`).
    Gradient,
    /// An equirectangular HDR image, looked up per direction and importance-sampled
    /// (`Environment::Image`).
    Image,
    /// Any of the above, chosen at run time by the packed `environment.kind` (the shaders
    /// already branch on it): what a full-featured kernel compiles, so one kernel per
    /// renderer serves every environment.
    All,
}

impl EnvKind {
    /// Whether a kernel compiled for `self` renders a scene whose environment is `scene`.
    /// Background and Uniform share one code path (the packer stores a uniform environment
    /// of the background colour).
    pub fn covers(self, scene: EnvKind) -> bool {
        use EnvKind::*;
        self == scene || self == All || matches!((self, scene), (Background, Uniform) | (Uniform, Background))
    }
}

/// What one BRDF kind's shading stage needs of the scene's shape and pigment kinds, and
/// whether it adds emission: a subset of [`KindUse::NAMES`]. The stage compiles only these
/// (`wavefront::Stage::names`): a mirror kernel in a scene whose checkered floor is diffuse
/// and whose only emitter is a diffuse sphere holds neither checkers, nor the floor's plane
/// nor emission's MIS (with its light densities). [`FeatureSet::of`] fills it per kind;
/// the default is every name (no restriction beyond the scene's own features), which is
/// what hand-made and full-featured sets get.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct KindUse {
    /// One bit per entry of [`KindUse::NAMES`].
    bits: u16,
}

impl Default for KindUse {
    fn default() -> Self {
        Self::ALL
    }
}

impl KindUse {
    /// The feature names a kind may do without. `EMISSION` (the emitted radiance at a hit
    /// and its MIS weight, `wf_shade.wgsl`) and `TEXTURED_EMISSION` (some such material's
    /// emission is checkered or an image: looked up at the hit's uv) are the shading stage's
    /// own, and so are `SPHERE_UV`, `CUBE_UV` and `CYLINDER_UV` (a material of the kind with
    /// a checkered or image pigment or emission sits on a shape of that kind, so the hit's
    /// surface coordinates are needed there: [`UV_SHAPES`]); the others are scene names
    /// ([`FeatureSet::names`]) that the stage keeps only when the kind needs them.
    pub const NAMES: [&'static str; 13] = [
        "SPHERE",
        "PLANE",
        "CUBE",
        "CYLINDER",
        "MESH",
        "PIGMENT_UNIFORM",
        "PIGMENT_CHECKERED",
        "PIGMENT_IMAGE",
        "EMISSION",
        "TEXTURED_EMISSION",
        "SPHERE_UV",
        "CUBE_UV",
        "CYLINDER_UV",
    ];
    /// Every name.
    pub const ALL: KindUse = KindUse { bits: (1 << Self::NAMES.len()) - 1 };
    /// No name.
    pub const NONE: KindUse = KindUse { bits: 0 };

    /// `self` with `name` (one of [`Self::NAMES`]) added.
    ///
    /// ```
    /// use lumen::gpu::features::KindUse;
    /// let u = KindUse::NONE.with("SPHERE").with("EMISSION");
    /// assert!(u.has("SPHERE") && u.has("EMISSION") && !u.has("PLANE"));
    /// assert!(KindUse::ALL.covers(u) && !u.covers(KindUse::ALL));
    /// ```
    pub fn with(self, name: &str) -> Self {
        let bit = Self::NAMES.iter().position(|n| *n == name).expect("a KindUse name");
        Self { bits: self.bits | 1 << bit }
    }

    /// Whether `name` is in the set (false for a name not in [`Self::NAMES`]).
    pub fn has(self, name: &str) -> bool {
        Self::NAMES.iter().position(|n| *n == name).is_some_and(|bit| self.bits & 1 << bit != 0)
    }

    /// Both sets together.
    pub fn union(self, other: KindUse) -> Self {
        Self { bits: self.bits | other.bits }
    }

    /// Whether `self` holds every name of `other`.
    pub fn covers(self, other: KindUse) -> bool {
        self.bits & other.bits == other.bits
    }

    /// Whether the set holds a pigment kind that varies over a surface (checkered or image).
    pub fn textured(self) -> bool {
        self.has("PIGMENT_CHECKERED") || self.has("PIGMENT_IMAGE")
    }

    fn with_pigment(self, p: &Pigment) -> Self {
        self.with(match p {
            Pigment::Uniform(_) => "PIGMENT_UNIFORM",
            Pigment::Checkered { .. } => "PIGMENT_CHECKERED",
            Pigment::Image { .. } => "PIGMENT_IMAGE",
        })
    }

    fn shape_name(kind: ShapeKind) -> &'static str {
        match kind {
            ShapeKind::Sphere => "SPHERE",
            ShapeKind::Plane => "PLANE",
            ShapeKind::Cube => "CUBE",
            ShapeKind::Cylinder => "CYLINDER",
        }
    }
}

/// The primitive kinds whose surface coordinates cost real work (arctangents, face tables),
/// as (shape name, [`KindUse`] name saying some textured material of the kind sits on such a
/// shape, the shading stage's name saying none does: its hits there skip the uv). Planes'
/// uv is two subtractions, meshes' an interpolation of the loaded vertices.
pub const UV_SHAPES: [(&str, &str, &str); 3] = [
    ("SPHERE", "SPHERE_UV", "SPHERE_UV_UNUSED"),
    ("CUBE", "CUBE_UV", "CUBE_UV_UNUSED"),
    ("CYLINDER", "CYLINDER_UV", "CYLINDER_UV_UNUSED"),
];

/// BRDF kinds (`layout::brdf_kind::COUNT`), one shading stage each.
pub const BRDF_KINDS: usize = 6;
const _: () = assert!(BRDF_KINDS == crate::gpu::layout::brdf_kind::COUNT as usize);

/// Integrator kinds, for specialisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum RendererKind {
    /// `on` colour where a camera ray hits anything, `off` elsewhere (`Renderer::OnOff`).
    OnOff,
    /// Emission plus pigment colour at the first hit (`Renderer::Flat`).
    Flat,
    /// Direct light from point lights plus an ambient term (`Renderer::PointLight`).
    PointLight,
    /// The Monte Carlo path tracer, with next-event estimation where enabled.
    #[default]
    PathTracer,
}

/// Everything the kernel can be specialised on. Derived from a scene by
/// [`FeatureSet::of`]; any value (even one no scene produces) assembles to valid WGSL.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct FeatureSet {
    /// Some primitive is a sphere (a CSG leaf included).
    pub sphere: bool,
    /// Some primitive is an infinite plane (a CSG leaf included).
    pub plane: bool,
    /// Some primitive is a cube (a CSG leaf included).
    pub cube: bool,
    /// Some primitive is a cylinder (a CSG leaf included).
    pub cylinder: bool,
    /// Some top-level shape is a CSG tree.
    pub csg: bool,
    /// Most leaves (primitives) of any CSG tree: the spans one CSG query stores; ≥ 1 when
    /// `csg`.
    pub csg_max_leaves: u32,
    /// Bound on the depth of any CSG tree (sizes the evaluation stack).
    pub csg_max_depth: u32,
    /// Most nodes (leaves included) of any tree with a sweep table (more than
    /// `layout::csg_sweep::MIN_LEAVES` leaves; 0 when there is none): the sweeps' per-node
    /// state in the CSG pool.
    pub csg_sweep_nodes: u32,
    /// The kernels classify crossings past their walk budget by sweeps (shaders/csg.wgsl).
    /// Never set by [`FeatureSet::of`]: a render sets it once a query of kernels without
    /// the sweeps exceeded that budget, so the sweeps' code (and compile time) reaches only
    /// the renders that need it.
    pub csg_sweeps: bool,
    /// Top-level CSG trees: up to `prepare::CSG_DEFER_MAX` of them are evaluated after the BVH
    /// traversal rather than inside it (as `cpu::World` does; DESIGN.md "Software adapters").
    pub csg_trees: u32,
    /// Some material in use has a uniform pigment (as its BRDF's colour or its emission);
    /// the pigment flags are off where the kernel reads no materials ([`Self::materials`]).
    pub pigment_uniform: bool,
    /// Some material in use has a checkered pigment (BRDF colour or emission).
    pub pigment_checkered: bool,
    /// Some material in use has an image pigment (BRDF colour or emission).
    pub pigment_image: bool,
    /// Some material in use is Lambertian diffuse. The BRDF flags are set only for
    /// integrators that evaluate BRDFs (path tracer, point lights).
    pub diffuse: bool,
    /// Some material in use is a perfect mirror (path tracer only: a delta BRDF adds nothing
    /// to point-light shading).
    pub specular: bool,
    /// Some material in use is a smooth dielectric (roughness 0; path tracer only, as for
    /// `specular`).
    pub dielectric: bool,
    /// GGX conductors (rough or smooth).
    pub conductor: bool,
    /// GGX dielectrics of roughness > 0.
    pub rough_dielectric: bool,
    /// Plastics (rough or smooth coat).
    pub plastic: bool,
    /// The scene has point lights and the renderer uses them (point-light renderer or path
    /// tracer).
    pub point_lights: bool,
    /// The path tracer samples emissive spheres, cubes or meshes as lights: `nee` is on and
    /// the scene has some such emitter.
    pub area_lights: bool,
    /// Some area light is a sphere (sampled by its cone, or uniformly from inside).
    pub sphere_lights: bool,
    /// Some area light is a cube (sampled by its faces' areas).
    pub cube_lights: bool,
    /// Some area light is a triangle mesh (sampled by its triangles' areas). Without
    /// sphere or cube lights, the primitive lights' code is left out (PRIMITIVE_LIGHTS).
    pub mesh_lights: bool,
    /// What escaping rays see; [`EnvKind::Background`] for the OnOff renderer, which shows
    /// no environment.
    pub environment: EnvKind,
    /// The integrator; a kernel holds exactly one.
    pub renderer: RendererKind,
    /// Triangle mesh instances (bottom-level BVHs under the top-level one).
    pub mesh: bool,
    /// Finite objects exist, traversed through the BVH (planes are tested separately).
    pub bvh: bool,
    /// The finite objects are walked (not `object_list`) and every one is a round sphere
    /// ([`crate::prepare::all_round`]), which a walk's leaf tests in the world from six
    /// words of its record (centre and a row of its `to_world`) instead of moving the ray
    /// into object space with the thirteen words of `to_object` and the kind, as the CPU
    /// reference does for such scenes (DESIGN.md "Round spheres"). It selects an algorithm,
    /// so a kernel covers only scenes that agree on it ([`Self::missing_for`]).
    pub round_spheres: bool,
    /// The finite objects are tested in turn, as a list behind the root box, instead of
    /// through a BVH walk ([`super::traversal::prefers_list`] decides).
    pub object_list: bool,
    /// The finite objects' references (in reference order), when there are at most
    /// [`UNROLLED_MAX`](super::traversal::UNROLLED_MAX): what an object list's kernels test,
    /// unrolled ([`super::traversal::Unrolled`]). Filled by [`super::pack::pack`] (it needs
    /// the packed tables); [`FeatureSet::of`] leaves it `None`, and without it the objects
    /// are walked through the BVH whatever `object_list` says.
    pub listed: Option<super::traversal::Unrolled>,
    /// The unbounded list (planes and unbounded CSG trees) when it has at most
    /// `UNROLLED_MAX` entries: tested unrolled (UNROLLED_PLANES), else in a loop. Filled by
    /// `pack` as `listed` is.
    pub planes_listed: Option<super::traversal::Unrolled>,
    /// Next-event estimation with MIS (path tracer with some non-delta material only: light
    /// sampling happens at diffuse and microfacet vertices).
    pub nee: bool,
    /// The tables read from uniform buffers or textures instead of storage buffers: chosen
    /// per render for the adapter ([`TableForms::choose`]); [`FeatureSet::of`] leaves it empty.
    pub tables: TableForms,
    /// Shards per queue (`wavefront::Control`): on llvmpipe one per driver thread, so that
    /// no two threads push to one queue length; 1 elsewhere. Chosen per render for the
    /// adapter ([`crate::gpu::wavefront::queue_shards`]); [`FeatureSet::of`] leaves 0,
    /// which counts as 1. The image is the same.
    pub queue_shards: u32,
    /// The path state's buffers of 16-byte elements, and the struct and vec4 tables in
    /// storage and uniform buffers, held as 64-bit words (`vec2<u64>`): on llvmpipe, where
    /// every word is a per-lane access with a bounds check (DESIGN.md "Wide words"). Chosen
    /// per render for the device ([`crate::gpu::wavefront::wide_words`]); [`FeatureSet::of`]
    /// leaves it off. The image is the same.
    pub wide_words: bool,
    /// Per BRDF kind (indexed by `layout::brdf_kind`), what the materials of that kind need
    /// in their shading stage: the shapes they sit on, their pigments, whether one emits.
    pub shade_use: [KindUse; BRDF_KINDS],
    /// What sampling the area lights needs beyond a kind's own use (their shapes' kinds and
    /// their emitted pigments), in the shading stages that sample lights.
    pub light_use: KindUse,
}

impl FeatureSet {
    /// The features `scene` uses, in its [`crate::prepare::render_form()`]. Only materials
    /// actually referenced by a shape count.
    pub fn of(scene: &Scene) -> Self {
        // What the kernels will see: top-level UNITEs split into their parts.
        let form = crate::prepare::render_form(scene);
        let scene = &*form;
        let mut f = FeatureSet { renderer: RendererKind::of(&scene.renderer), ..Default::default() };
        let mut used = vec![false; scene.materials.len()];
        // The shape kinds each material sits on.
        let mut carriers = vec![KindUse::NONE; scene.materials.len()];
        for shape in &scene.shapes {
            match shape {
                Shape::Mesh(m) => {
                    f.bvh = true;
                    f.mesh = true;
                    if let Some(u) = used.get_mut(m.material.0 as usize) {
                        *u = true;
                        carriers[m.material.0 as usize] = carriers[m.material.0 as usize].with("MESH");
                    }
                }
                Shape::Primitive(p) => {
                    if p.kind != ShapeKind::Plane {
                        f.bvh = true;
                    }
                }
                Shape::Csg(_) => {
                    f.csg = true;
                    f.bvh = true;
                    f.csg_trees += 1;
                    // Saturated, never truncated: pack refuses what the GPU cannot hold.
                    let leaves = u32::try_from(shape.leaf_count()).unwrap_or(u32::MAX);
                    f.csg_max_leaves = f.csg_max_leaves.max(leaves);
                    f.csg_max_depth = f.csg_max_depth.max(shape.csg_depth() as u32);
                    if leaves > crate::gpu::layout::csg_sweep::MIN_LEAVES {
                        let nodes = shape.leaf_count().saturating_add(shape.csg_node_count());
                        f.csg_sweep_nodes = f.csg_sweep_nodes.max(u32::try_from(nodes).unwrap_or(u32::MAX));
                    }
                }
            }
            shape.for_each_primitive(&mut |p, _| {
                match p.kind {
                    ShapeKind::Sphere => f.sphere = true,
                    ShapeKind::Plane => f.plane = true,
                    ShapeKind::Cube => f.cube = true,
                    ShapeKind::Cylinder => f.cylinder = true,
                }
                if let Some(u) = used.get_mut(p.material.0 as usize) {
                    *u = true;
                    let c = &mut carriers[p.material.0 as usize];
                    *c = c.with(KindUse::shape_name(p.kind));
                }
            });
        }
        let needs_shading = match f.renderer {
            RendererKind::OnOff => false,
            RendererKind::PointLight => !scene.point_lights.is_empty(),
            _ => true,
        };
        f.shade_use = [KindUse::NONE; BRDF_KINDS];
        f.light_use = KindUse::NONE;
        for ((m, _), carrier) in scene.materials.iter().zip(&used).zip(&carriers).filter(|((_, u), _)| **u) {
            if needs_shading {
                f.add_pigment(m.brdf.pigment());
                if m.is_emissive() {
                    f.add_pigment(&m.emitted);
                }
            }
            let kind = crate::gpu::layout::brdf_kind::of(&m.brdf);
            *f.brdf_flag(kind) = true;
            let mut u = f.shade_use[kind as usize].union(*carrier).with_pigment(m.brdf.pigment());
            let mut textured = !matches!(m.brdf.pigment(), Pigment::Uniform(_));
            if m.is_emissive() {
                u = u.with_pigment(&m.emitted).with("EMISSION");
                if !matches!(m.emitted, Pigment::Uniform(_)) {
                    u = u.with("TEXTURED_EMISSION");
                    textured = true;
                }
                f.light_use = f.light_use.with_pigment(&m.emitted);
            }
            // The material reads its surface's uv on every shape it sits on.
            for (shape, uv, _) in UV_SHAPES {
                if textured && carrier.has(shape) {
                    u = u.with(uv);
                }
            }
            f.shade_use[kind as usize] = u;
        }
        if f.renderer != RendererKind::PathTracer {
            // Only the path tracer has shading stages (the others shade in their first-hit
            // kernel, with the scene's names).
            f.shade_use = [KindUse::NONE; BRDF_KINDS];
        }
        // Only integrators that scatter need BRDF code.
        if !matches!(f.renderer, RendererKind::PathTracer | RendererKind::PointLight) {
            f.diffuse = false;
            f.specular = false;
            f.dielectric = false;
            f.conductor = false;
            f.rough_dielectric = false;
            f.plastic = false;
        }
        if f.renderer == RendererKind::PointLight {
            // Only BRDF values are evaluated; delta BRDFs contribute 0.
            f.specular = false;
            f.dielectric = false;
        }
        f.point_lights =
            !scene.point_lights.is_empty() && matches!(f.renderer, RendererKind::PointLight | RendererKind::PathTracer);
        if let Renderer::PathTracer(p) = &scene.renderer {
            // Light sampling happens only at non-delta vertices.
            f.nee = p.nee && f.non_delta();
            let lights = scene.area_lights();
            f.area_lights = f.nee && !lights.is_empty();
            let some_light =
                |is: &dyn Fn(&Shape) -> bool| f.area_lights && lights.iter().any(|l| is(&scene.shapes[l.shape]));
            let kind = |k: ShapeKind| move |s: &Shape| matches!(s, Shape::Primitive(p) if p.kind == k);
            f.sphere_lights = some_light(&kind(ShapeKind::Sphere));
            f.cube_lights = some_light(&kind(ShapeKind::Cube));
            f.mesh_lights = some_light(&|s| matches!(s, Shape::Mesh(_)));
            // A light's emission is looked up at its sampled point (uv from its shape).
            for (on, name) in [(f.sphere_lights, "SPHERE"), (f.cube_lights, "CUBE"), (f.mesh_lights, "MESH")] {
                if on {
                    f.light_use = f.light_use.with(name);
                }
            }
        }
        if !f.area_lights {
            // Nothing samples lights (the emitted pigments gathered above go unused).
            f.light_use = KindUse::NONE;
        }
        if f.renderer != RendererKind::OnOff {
            f.environment = match &scene.environment {
                None => EnvKind::Background,
                Some(Environment::Uniform(_)) => EnvKind::Uniform,
                Some(Environment::Gradient { .. }) => EnvKind::Gradient,
                Some(Environment::Image { .. }) => EnvKind::Image,
            };
        }
        // The objects of the top-level BVH, as `prepare::SceneBvh` places them (unbounded CSG
        // trees join the planes' list; empty ones are nowhere).
        let finite = scene
            .shapes
            .iter()
            .filter(|s| matches!(crate::prepare::Placement::of(s), crate::prepare::Placement::Tree(_)));
        f.object_list = super::traversal::prefers_list(&f, u32::try_from(finite.count()).unwrap_or(u32::MAX));
        // Listed objects load their records once per SIMD group: no gain to test there.
        f.round_spheres = f.bvh && !f.object_list && crate::prepare::all_round(&scene.shapes);
        f
    }

    /// Whether the scene has materials of BRDF kind `kind` (`layout::brdf_kind`).
    ///
    /// ```
    /// use lumen::gpu::features::FeatureSet;
    /// use lumen::gpu::layout::brdf_kind;
    /// let glass = FeatureSet { dielectric: true, ..FeatureSet::default() };
    /// assert!(glass.has_brdf_kind(brdf_kind::DIELECTRIC) && !glass.has_brdf_kind(brdf_kind::DIFFUSE));
    /// ```
    pub fn has_brdf_kind(&self, kind: u32) -> bool {
        let mut f = *self;
        *f.brdf_flag(kind)
    }

    fn brdf_flag(&mut self, kind: u32) -> &mut bool {
        use crate::gpu::layout::brdf_kind::*;
        match kind {
            DIFFUSE => &mut self.diffuse,
            SPECULAR => &mut self.specular,
            DIELECTRIC => &mut self.dielectric,
            CONDUCTOR => &mut self.conductor,
            ROUGH_DIELECTRIC => &mut self.rough_dielectric,
            _ => &mut self.plastic,
        }
    }

    fn add_pigment(&mut self, p: &Pigment) {
        match p {
            Pigment::Uniform(_) => self.pigment_uniform = true,
            Pigment::Checkered { .. } => self.pigment_checkered = true,
            Pigment::Image { .. } => self.pigment_image = true,
        }
    }

    /// True when the `floats` buffer is read for texels (image pigments or an image
    /// environment, with its sampling tables); the shading stages also read it for mesh
    /// lights' CDFs (`Stage::names`), and the energy rows have their own table
    /// ([`Self::energy_rows`]).
    pub fn textures(&self) -> bool {
        self.pigment_image || self.env_image()
    }

    /// Microfacet materials' energy rows (their own table: `tables::Table::Rows`).
    pub fn energy_rows(&self) -> bool {
        self.microfacet() && self.materials()
    }

    /// Some BRDF kind that uses GGX microfacets.
    pub fn microfacet(&self) -> bool {
        self.conductor || self.rough_dielectric || self.plastic
    }

    /// Some BRDF kind whose vertices sample lights (not a Dirac delta, or not always).
    pub fn non_delta(&self) -> bool {
        self.diffuse || self.microfacet()
    }

    fn env_image(&self) -> bool {
        matches!(self.environment, EnvKind::Image | EnvKind::All)
    }

    /// The full-featured kernel for scenes like this one: every shape, CSG (with bounds of
    /// at least [`FULL_CSG_MAX_LEAVES`] and [`FULL_CSG_MAX_DEPTH`]), pigment, BRDF and
    /// light kind and every environment ([`EnvKind::All`]), for this set's renderer.
    ///
    /// Four things stay the scene's, because they select an algorithm rather than add code:
    /// the renderer (one integrator per kernel), whether CSG
    /// trees are deferred past the BVH traversal (the CPU reference decides that from the
    /// tree count, `prepare::CSG_DEFER_MAX`; a deferring full kernel gets every deferral
    /// slot), whether the finite objects are walked through the BVH or tested as a list,
    /// and whether a walk's leaves are round spheres tested in the world.
    /// Run-time switches (`settings.nee`, light counts, `environment.kind`, pigment and
    /// shape kinds) choose among the compiled paths, so the result is the scene's image.
    pub fn full_for(&self) -> FeatureSet {
        let shading = self.shading();
        let path = self.renderer == RendererKind::PathTracer;
        let scatters = matches!(self.renderer, RendererKind::PathTracer | RendererKind::PointLight);
        let pigments = self.renderer != RendererKind::OnOff;
        let defer_max = crate::prepare::CSG_DEFER_MAX as u32;
        FeatureSet {
            sphere: true,
            plane: true,
            cube: true,
            cylinder: true,
            mesh: true,
            csg: true,
            csg_max_leaves: self.csg_max_leaves.max(FULL_CSG_MAX_LEAVES),
            csg_max_depth: self.csg_max_depth.max(FULL_CSG_MAX_DEPTH),
            csg_sweep_nodes: self.csg_sweep_nodes,
            csg_sweeps: self.csg_sweeps,
            csg_trees: if self.csg_trees > defer_max { self.csg_trees } else { defer_max },
            pigment_uniform: pigments,
            pigment_checkered: pigments,
            pigment_image: pigments,
            diffuse: scatters,
            specular: path,
            dielectric: path,
            conductor: scatters,
            rough_dielectric: scatters,
            plastic: scatters,
            point_lights: scatters,
            area_lights: path,
            sphere_lights: path,
            cube_lights: path,
            mesh_lights: path,
            environment: if shading { EnvKind::All } else { EnvKind::Background },
            renderer: self.renderer,
            bvh: true,
            object_list: self.object_list,
            round_spheres: self.round_spheres,
            listed: self.listed,
            planes_listed: self.planes_listed,
            nee: path,
            tables: self.tables,
            queue_shards: self.queue_shards,
            wide_words: self.wide_words,
            shade_use: [KindUse::ALL; BRDF_KINDS],
            light_use: KindUse::ALL,
        }
    }

    /// Whether a kernel compiled for `self` renders every scene whose features are `scene`
    /// exactly as `scene`'s own kernel does: every feature on, CSG bounds at least as large,
    /// the same renderer and CSG deferral mode, and an environment that covers the scene's.
    pub fn covers(&self, scene: &FeatureSet) -> bool {
        self.missing_for(scene).is_empty()
    }

    /// What `self` lacks to cover `scene` (see [`Self::covers`]), in words; empty when it covers.
    pub fn missing_for(&self, scene: &FeatureSet) -> Vec<String> {
        // How the objects are gone through (a walk, unrolled lists) is not a capability:
        // every way finds the same hits.
        let strategy = ["OBJECT_LIST", "UNROLLED_PLANES", "BVH_WALK"];
        let mut missing: Vec<String> = scene
            .names()
            .into_iter()
            .filter(|n| !self.names().contains(n) && !strategy.contains(n))
            .map(|n| format!("feature {n}"))
            .collect();
        if self.renderer != scene.renderer {
            missing.push(format!("renderer {:?} (kernel: {:?})", scene.renderer, self.renderer));
        }
        // Round spheres' world-space test is wrong for other shapes and rounds differently
        // from the object-space one: the kernel must agree with the scene.
        if self.round_spheres != scene.round_spheres {
            missing.push(format!("round spheres {} (kernel: {})", scene.round_spheres, self.round_spheres));
        }
        for (k, (kernel, needed)) in self.shade_use.iter().zip(&scene.shade_use).enumerate() {
            if !kernel.covers(*needed) {
                missing.push(format!("shading names of BRDF kind {k}"));
            }
        }
        if !self.light_use.covers(scene.light_use) {
            missing.push("light sampling names".to_string());
        }
        if scene.shading() && !self.environment.covers(scene.environment) {
            missing.push(format!("environment {:?} (kernel: {:?})", scene.environment, self.environment));
        }
        if scene.csg {
            if self.csg_max_leaves < scene.csg_max_leaves
                || self.csg_max_depth < scene.csg_max_depth
                || self.csg_sweep_nodes < scene.csg_sweep_nodes
            {
                missing.push(format!(
                    "CSG bounds {} leaves, depth {}, {} swept nodes (kernel: {}, {}, {})",
                    scene.csg_max_leaves,
                    scene.csg_max_depth,
                    scene.csg_sweep_nodes,
                    self.csg_max_leaves,
                    self.csg_max_depth,
                    self.csg_sweep_nodes
                ));
            }
            let defer_max = crate::prepare::CSG_DEFER_MAX as u32;
            let (kernel_defers, scene_defers) = (self.csg_trees <= defer_max, scene.csg_trees <= defer_max);
            if kernel_defers != scene_defers || (kernel_defers && self.csg_trees < scene.csg_trees) {
                missing.push(format!("{} top-level CSG trees (kernel: {})", scene.csg_trees, self.csg_trees));
            }
        }
        missing
    }

    /// True when escaping rays see the environment (every renderer but OnOff).
    pub fn shading(&self) -> bool {
        self.renderer != RendererKind::OnOff
    }

    /// True when rays can hit anything (the scene has finite objects or planes): the
    /// `GEOMETRY` feature. Without it every ray escapes.
    pub fn geometry(&self) -> bool {
        self.bvh || self.plane
    }

    /// True when the kernel reads materials (not OnOff, nor PointLight without lights).
    pub fn materials(&self) -> bool {
        match self.renderer {
            RendererKind::OnOff => false,
            RendererKind::PointLight => self.point_lights,
            _ => true,
        }
    }

    /// Every feature name a shader may test that the scene decides (see [`Self::names`]; the
    /// table placements' names are [`super::tables::Table::feature`]).
    pub const ALL_NAMES: [&'static str; 40] = [
        "MATERIALS",
        "GEOMETRY",
        "SHADOWS",
        "SPHERE",
        "PLANE",
        "CUBE",
        "CYLINDER",
        "MESH",
        "CSG",
        "BVH",
        "ROUND_SPHERES",
        "OBJECT_LIST",
        "UNROLLED_PLANES",
        "BVH_WALK",
        "SHADING",
        "PIGMENT_UNIFORM",
        "PIGMENT_CHECKERED",
        "PIGMENT_IMAGE",
        "TEXTURES",
        "ENERGY_ROWS",
        "DIFFUSE",
        "SPECULAR",
        "DIELECTRIC",
        "CONDUCTOR",
        "ROUGH_DIELECTRIC",
        "PLASTIC",
        "POINT_LIGHTS",
        "AREA_LIGHTS",
        "SPHERE_LIGHTS",
        "CUBE_LIGHTS",
        "MESH_LIGHTS",
        "PRIMITIVE_LIGHTS",
        "NEE",
        "ENV_UNIFORM",
        "ENV_GRADIENT",
        "ENV_IMAGE",
        "ONOFF",
        "FLAT",
        "POINTLIGHT",
        "PATHTRACER",
    ];

    /// The feature names a shader may test that the device decides (beyond the tables'
    /// forms, [`super::tables::Table::feature`]): `WIDE_WORDS`, [`Self::wide_words`].
    pub const DEVICE_NAMES: [&'static str; 1] = ["WIDE_WORDS"];

    /// The names of the `// #if NAME` blocks enabled for this set.
    pub fn names(&self) -> Vec<&'static str> {
        let flags = [
            (self.materials(), "MATERIALS"),
            (self.geometry(), "GEOMETRY"),
            (self.renderer == RendererKind::OnOff || self.point_lights || self.nee, "SHADOWS"),
            (self.sphere, "SPHERE"),
            (self.plane, "PLANE"),
            (self.cube, "CUBE"),
            (self.cylinder, "CYLINDER"),
            (self.mesh, "MESH"),
            (self.csg, "CSG"),
            (self.bvh, "BVH"),
            (self.bvh && self.round_spheres, "ROUND_SPHERES"),
            (self.lists_objects(), "OBJECT_LIST"),
            (self.unrolls_planes(), "UNROLLED_PLANES"),
            // Meshes walk their bottom-level BVHs whatever the top level does.
            ((self.bvh && !self.lists_objects()) || self.mesh, "BVH_WALK"),
            (self.shading(), "SHADING"),
            (self.pigment_uniform, "PIGMENT_UNIFORM"),
            (self.pigment_checkered, "PIGMENT_CHECKERED"),
            (self.pigment_image, "PIGMENT_IMAGE"),
            (self.textures(), "TEXTURES"),
            (self.energy_rows(), "ENERGY_ROWS"),
            (self.diffuse, "DIFFUSE"),
            (self.specular, "SPECULAR"),
            (self.dielectric, "DIELECTRIC"),
            (self.conductor, "CONDUCTOR"),
            (self.rough_dielectric, "ROUGH_DIELECTRIC"),
            (self.plastic, "PLASTIC"),
            (self.point_lights, "POINT_LIGHTS"),
            (self.area_lights, "AREA_LIGHTS"),
            (self.area_lights && self.sphere_lights, "SPHERE_LIGHTS"),
            (self.area_lights && self.cube_lights, "CUBE_LIGHTS"),
            (self.area_lights && self.mesh && self.mesh_lights, "MESH_LIGHTS"),
            // The sphere and cube lights' shared code, left out only when every area light
            // is known to be a mesh.
            (
                self.area_lights && (self.sphere_lights || self.cube_lights || !(self.mesh && self.mesh_lights)),
                "PRIMITIVE_LIGHTS",
            ),
            (self.nee, "NEE"),
            (
                matches!(self.environment, EnvKind::Uniform | EnvKind::Background | EnvKind::All) && self.shading(),
                "ENV_UNIFORM",
            ),
            (matches!(self.environment, EnvKind::Gradient | EnvKind::All), "ENV_GRADIENT"),
            (self.env_image(), "ENV_IMAGE"),
            (self.renderer == RendererKind::OnOff, "ONOFF"),
            (self.renderer == RendererKind::Flat, "FLAT"),
            (self.renderer == RendererKind::PointLight, "POINTLIGHT"),
            (self.renderer == RendererKind::PathTracer, "PATHTRACER"),
        ];
        let mut names: Vec<&'static str> = flags.iter().filter(|(on, _)| *on).map(|(_, n)| *n).collect();
        names.extend(self.tables.names());
        names
    }

    /// Whether the kernels test the finite objects as an unrolled list: `object_list`, the
    /// list known (`listed`) and no mesh (a mesh instance's test is a walk of its own BVH,
    /// which the top-level walk skips wherever the ray misses its box; a list forced on a
    /// scene with meshes is walked).
    pub fn lists_objects(&self) -> bool {
        self.bvh && self.object_list && self.listed.is_some() && !self.mesh
    }

    /// Whether the kernels test the planes' list unrolled (`planes_listed` known).
    pub fn unrolls_planes(&self) -> bool {
        self.plane && self.planes_listed.is_some()
    }

    /// `self` with the unrolled lists of `packed` (a packed scene's features): what a kernel
    /// override ([`super::render::GpuRenderOptions::features`]) cannot know beforehand.
    pub fn with_lists_of(self, packed: &FeatureSet) -> FeatureSet {
        FeatureSet { listed: packed.listed, planes_listed: packed.planes_listed, ..self }
    }
}

impl RendererKind {
    /// The kind of the scene's renderer, without its settings.
    pub fn of(r: &Renderer) -> Self {
        match r {
            Renderer::OnOff { .. } => RendererKind::OnOff,
            Renderer::Flat { .. } => RendererKind::Flat,
            Renderer::PointLight { .. } => RendererKind::PointLight,
            Renderer::PathTracer(_) => RendererKind::PathTracer,
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::color::Color;
    use crate::scene::{Brdf, CsgOp, Material, PathTracerSettings, PointLight, SceneBuilder, Transform};

    /// Round spheres: only when the finite objects are walked and every one is a sphere
    /// placed by a similarity of scale within prepare::ROUND_SCALES (planes beside them allowed); a
    /// kernel and a scene must agree on it.
    #[test]
    fn round_spheres_need_a_walk_over_similarity_spheres_only() {
        let scene = |extra: &dyn Fn(&mut SceneBuilder, crate::scene::MaterialId), count: u32| {
            let mut b = SceneBuilder::new(4, 4);
            let m = b.diffuse(Color::gray(0.5));
            b.plane(Transform::IDENTITY, m);
            for i in 0..count {
                let at = Transform::translation(DVec3::new(f64::from(i), 0.0, 1.0));
                let turn = Transform::rotation_z(10.0 * f64::from(i)) * Transform::rotation_x(33.0);
                b.sphere(at * turn * Transform::scaling(DVec3::new(-0.3, 0.3, 0.3)), m);
            }
            extra(&mut b, m);
            FeatureSet::of(&b.build().unwrap())
        };
        let none = |_: &mut SceneBuilder, _| {};
        let round = scene(&none, 12);
        assert!(round.round_spheres && !round.object_list && round.names().contains(&"ROUND_SPHERES"));
        // A few spheres are tested as a list: nothing to walk.
        assert!(!scene(&none, 3).round_spheres);
        // An ellipsoid, a cube, or a radius outside ROUND_SCALES among them.
        let ellipsoid = |b: &mut SceneBuilder, m| {
            b.sphere(Transform::scaling(DVec3::new(1.0, 1.0, 1.001)), m);
        };
        let cube = |b: &mut SceneBuilder, m| {
            b.shape(Shape::primitive(ShapeKind::Cube, Transform::IDENTITY, m));
        };
        let tiny = |b: &mut SceneBuilder, m| {
            b.sphere(Transform::scaling(DVec3::splat(0.5 * crate::prepare::ROUND_SCALES.start())), m);
        };
        let huge = |b: &mut SceneBuilder, m| {
            b.sphere(Transform::scaling(DVec3::splat(2.0 * crate::prepare::ROUND_SCALES.end())), m);
        };
        for extra in [&ellipsoid as &dyn Fn(&mut SceneBuilder, crate::scene::MaterialId), &cube, &tiny, &huge] {
            assert!(!scene(extra, 12).round_spheres);
        }
        // Kernels and scenes must agree: either test on the other's scene is refused.
        let other = FeatureSet { round_spheres: false, ..round };
        assert!(!other.covers(&round) && !round.covers(&other) && round.full_for().covers(&round));
        assert!(other.missing_for(&round).iter().any(|m| m.contains("round spheres")));
    }

    /// Each BRDF kind records the shapes its materials sit on, their pigments and whether
    /// one emits; the lights add theirs; a kernel that keeps less for a kind is refused.
    #[test]
    fn each_brdf_kind_records_what_its_materials_use() {
        use crate::gpu::layout::brdf_kind::{DIFFUSE, SPECULAR};
        let mut b = SceneBuilder::new(2, 2);
        let clay = b.diffuse(Color::gray(0.5));
        let checkers = Pigment::Checkered { n: 2, on: Color::WHITE, off: Color::gray(2.0) };
        let mirror = b.material(Material::new(
            Brdf::Specular { pigment: Pigment::default(), threshold_angle_rad: 0.0 },
            checkers,
        ));
        b.sphere(Transform::IDENTITY, clay).cube(Transform::translation(DVec3::X * 3.0), mirror);
        let f = FeatureSet::of(&b.build().unwrap());
        // Only the path tracer has shading stages.
        let flat = FeatureSet::of(&b.renderer(Renderer::Flat { background: Color::BLACK }).build().unwrap());
        assert_eq!((flat.shade_use, flat.light_use), ([KindUse::NONE; BRDF_KINDS], KindUse::NONE));
        let uniform = KindUse::NONE.with("PIGMENT_UNIFORM");
        assert_eq!(f.shade_use[DIFFUSE as usize], uniform.with("SPHERE"));
        // The mirror's checkered emission is looked up at the cube's uv; the clay sphere's
        // uniform pigment needs no uv.
        let mirror_use =
            uniform.with("CUBE").with("PIGMENT_CHECKERED").with("EMISSION").with("TEXTURED_EMISSION").with("CUBE_UV");
        assert_eq!(f.shade_use[SPECULAR as usize], mirror_use);
        // The emitting cube is the one area light: its shape and emitted pigment.
        assert_eq!(f.light_use, KindUse::NONE.with("CUBE").with("PIGMENT_CHECKERED"));
        for k in 2..BRDF_KINDS {
            assert_eq!(f.shade_use[k], KindUse::NONE, "kind {k}");
        }
        let full = f.full_for();
        assert!(full.covers(&f));
        let mut narrow = full;
        narrow.shade_use[SPECULAR as usize] = uniform.with("CUBE").with("PIGMENT_CHECKERED");
        assert_eq!(narrow.missing_for(&f), vec![format!("shading names of BRDF kind {SPECULAR}")]);
        narrow = full;
        narrow.light_use = KindUse::NONE.with("CUBE");
        assert_eq!(narrow.missing_for(&f), vec!["light sampling names".to_string()]);
    }

    #[test]
    fn features_follow_what_the_scene_uses() {
        let mut b = SceneBuilder::new(4, 4);
        let diffuse = b.diffuse(Color::gray(0.5));
        let glass = b.material(Material::new(
            Brdf::Dielectric {
                pigment: Pigment::Checkered { n: 2, on: Color::WHITE, off: Color::BLACK },
                ior: 1.5,
                roughness: 0.0,
                multiple_scattering: true,
            },
            Pigment::Uniform(Color::BLACK),
        ));
        // A material nobody uses does not count.
        b.material(Material::new(
            Brdf::Specular { pigment: Pigment::default(), threshold_angle_rad: 0.0 },
            Pigment::default(),
        ));
        let leaf = |k, m| Shape::primitive(k, Transform::translation(DVec3::X), m);
        let inner = Shape::csg(
            CsgOp::Diff,
            vec![leaf(ShapeKind::Cube, glass), leaf(ShapeKind::Cylinder, glass)],
            Transform::IDENTITY,
        );
        b.shape(Shape::csg(CsgOp::Fuse, vec![inner, leaf(ShapeKind::Sphere, diffuse)], Transform::IDENTITY))
            .plane(Transform::IDENTITY, diffuse)
            .point_light(PointLight::default());
        let f = FeatureSet::of(&b.build().unwrap());
        assert!(f.sphere && f.cube && f.cylinder && f.plane && f.csg && f.bvh);
        assert_eq!((f.csg_max_depth, f.csg_max_leaves), (2, 3));
        assert!(f.diffuse && f.dielectric && !f.specular);
        assert!(f.pigment_uniform && f.pigment_checkered && !f.pigment_image && !f.textures());
        assert!(f.point_lights && f.nee && !f.area_lights);
        assert_eq!((f.renderer, f.environment), (RendererKind::PathTracer, EnvKind::Background));
        let names = f.names();
        assert!(names.contains(&"ENV_UNIFORM") && names.contains(&"SHADOWS") && !names.contains(&"ONOFF"));
        assert!(names.iter().all(|n| FeatureSet::ALL_NAMES.contains(n)));

        // OnOff needs no materials, pigments, BRDFs, lights or environment.
        b.renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });
        let f = FeatureSet::of(&b.build().unwrap());
        assert!(!f.materials() && !f.diffuse && !f.pigment_uniform && !f.point_lights && !f.shading());
        // Without NEE the path tracer samples no lights but still visits point lights.
        b.renderer(Renderer::PathTracer(PathTracerSettings { nee: false, ..Default::default() }));
        let f = FeatureSet::of(&b.build().unwrap());
        assert!(!f.nee && f.point_lights);
    }

    #[test]
    fn each_kind_of_area_light_is_compiled_only_where_the_scene_has_one() {
        let mut b = SceneBuilder::new(4, 4);
        let lamp = b.material(Material::new(Brdf::default(), Pigment::Uniform(Color::WHITE)));
        let wall = b.diffuse(Color::gray(0.5));
        b.sphere(Transform::IDENTITY, wall).cube(Transform::translation(DVec3::X * 3.0), lamp);
        let f = FeatureSet::of(&b.build().unwrap());
        assert!(f.area_lights && f.cube_lights && !f.sphere_lights);
        assert!(f.names().contains(&"CUBE_LIGHTS") && !f.names().contains(&"SPHERE_LIGHTS"));
        b.sphere(Transform::translation(DVec3::Y * 3.0), lamp);
        let f = FeatureSet::of(&b.build().unwrap());
        assert!(f.cube_lights && f.sphere_lights);
        assert!(f.names().contains(&"PRIMITIVE_LIGHTS") && !f.names().contains(&"MESH_LIGHTS"));
        // Without NEE no light is sampled: neither kind's code.
        b.renderer(Renderer::PathTracer(PathTracerSettings { nee: false, ..Default::default() }));
        let names = FeatureSet::of(&b.build().unwrap()).names();
        assert!(!names.contains(&"CUBE_LIGHTS") && !names.contains(&"SPHERE_LIGHTS"));
        assert!(!names.contains(&"PRIMITIVE_LIGHTS"));

        // A mesh light alone: only the mesh lights' code; beside a sphere light, both.
        let triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let mesh = std::sync::Arc::new(crate::scene::TriangleMesh::from_obj_bytes("t", triangle.as_bytes()).unwrap());
        let mut b = SceneBuilder::new(4, 4);
        let lamp = b.material(Material::new(Brdf::default(), Pigment::Uniform(Color::WHITE)));
        let wall = b.diffuse(Color::gray(0.5));
        b.sphere(Transform::IDENTITY, wall).shape(Shape::mesh(mesh, "t", Transform::IDENTITY, lamp, false));
        let names = FeatureSet::of(&b.build().unwrap()).names();
        assert!(names.contains(&"MESH_LIGHTS") && !names.contains(&"PRIMITIVE_LIGHTS"), "{names:?}");
        b.sphere(Transform::translation(DVec3::Y * 3.0), lamp);
        let names = FeatureSet::of(&b.build().unwrap()).names();
        assert!(names.contains(&"MESH_LIGHTS") && names.contains(&"PRIMITIVE_LIGHTS"), "{names:?}");
    }

    #[test]
    fn the_full_kernel_covers_every_scene_of_its_renderer_and_assembles() {
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        b.sphere(Transform::IDENTITY, m);
        let spheres = FeatureSet::of(&b.build().unwrap());
        for r in [
            Renderer::OnOff { on: Color::WHITE, off: Color::BLACK },
            Renderer::Flat { background: Color::BLACK },
            Renderer::PointLight { background: Color::BLACK, ambient: Color::BLACK },
            Renderer::PathTracer(PathTracerSettings::default()),
        ] {
            b.renderer(r);
            let spec = FeatureSet::of(&b.build().unwrap());
            let renderer = spec.renderer;
            let full = spec.full_for();
            assert!(full.covers(&spec) && !spec.covers(&full), "{renderer:?}");
            // The same kernel for every scene of the renderer and traversal: it does not
            // depend on the scene's contents.
            assert!(spec.object_list, "one sphere is a list");
            assert_eq!(full, FeatureSet { renderer, object_list: true, ..FeatureSet::default() }.full_for());
            assert_eq!(full.environment == EnvKind::All, renderer != RendererKind::OnOff);
            let source: String = crate::gpu::kernels::assemble_stages(&full)
                .unwrap_or_else(|e| panic!("{renderer:?}: {e}"))
                .into_iter()
                .map(|(_, a)| a.source)
                .collect();
            for env in ["fn escape_radiance", "environment.kind == ENV_GRADIENT", "environment.kind == ENV_IMAGE"] {
                assert_eq!(source.contains(env), renderer != RendererKind::OnOff, "{renderer:?}: {env}");
            }
            let other = if renderer == RendererKind::Flat { RendererKind::OnOff } else { RendererKind::Flat };
            assert!(!full.covers(&FeatureSet { renderer: other, ..spheres }));
        }
        // Environments: All covers each; Background and Uniform share their code path.
        for e in [EnvKind::Background, EnvKind::Uniform, EnvKind::Gradient, EnvKind::Image, EnvKind::All] {
            assert!(EnvKind::All.covers(e) && e.covers(e));
            assert_eq!(e.covers(EnvKind::All), e == EnvKind::All);
        }
        assert!(EnvKind::Uniform.covers(EnvKind::Background) && !EnvKind::Gradient.covers(EnvKind::Image));
        let gradient = FeatureSet { environment: EnvKind::Gradient, ..spheres };
        assert_eq!(
            spheres.missing_for(&gradient),
            vec!["feature ENV_GRADIENT", "environment Gradient (kernel: Background)"]
                .into_iter()
                .map(String::from)
                .collect::<Vec<_>>()
        );

        // CSG: larger bounds are raised, and the deferral mode (chosen from the tree count,
        // as the CPU reference chooses it) is kept: a deferring kernel cannot take a scene
        // with more trees than its slots, nor a non-deferring one a scene the CPU defers.
        let max = crate::prepare::CSG_DEFER_MAX as u32;
        let csg = |trees, leaves| {
            let mut f = spheres;
            (f.csg, f.csg_trees, f.csg_max_leaves, f.csg_max_depth) = (true, trees, leaves, 1);
            f
        };
        let full = csg(2, 40).full_for();
        assert_eq!((full.csg_trees, full.csg_max_leaves, full.csg_max_depth), (max, 40, FULL_CSG_MAX_DEPTH));
        assert!(full.covers(&csg(max, 40)) && !full.covers(&csg(max + 1, 2)) && !full.covers(&csg(1, 41)));
        let many = csg(max + 5, 2).full_for();
        assert_eq!(many.csg_trees, max + 5);
        assert!(many.covers(&csg(max + 100, 2)) && !many.covers(&csg(1, 2)));
    }

    /// Issue 16's reproducer: an INTERSECT of 32 two-sphere UNITEs, whose interval lists
    /// could hold 2³² intervals along a ray, once compiled a kernel with room for one
    /// interval and was later refused. The GPU now stores one span per leaf: 64, and the
    /// scene packs (tests/gpu_render.rs renders one against the CPU).
    #[test]
    fn an_intersect_of_many_unites_needs_one_span_per_leaf() {
        let mut b = SceneBuilder::new(2, 2);
        let m = b.diffuse(Color::gray(0.5));
        let sphere = |x: f64| Shape::primitive(ShapeKind::Sphere, Transform::translation(DVec3::new(x, 0.0, 0.0)), m);
        let unite = || Shape::csg(CsgOp::Unite, vec![sphere(0.0), sphere(0.5)], Transform::IDENTITY);
        b.shape(Shape::csg(CsgOp::Intersect, (0..32).map(|_| unite()).collect(), Transform::IDENTITY));
        let scene = b.build().unwrap();
        assert_eq!(FeatureSet::of(&scene).csg_max_leaves, 64);
        assert!(crate::gpu::pack::pack(&scene, None).is_ok());
    }
}
