//! The renderer's kernel sources: the WGSL modules in `shaders/`, the modules generated for
//! a scene (tags, constants, tables, wavefront state, unrolled lists), and each wavefront
//! stage's kernel assembled from them with only the features the scene uses
//! ([`assemble_stage`]). `gpu::render` creates and runs them; `lumen shader` prints them.

use std::collections::BTreeMap;

use super::features::FeatureSet;
use super::wavefront::{self, Stage};
use super::{Assembled, GpuError, ShaderLibrary};
use crate::scene::Scene;

/// Every WGSL module the kernels are assembled from (`shaders/smoke.wgsl` and
/// `shaders/loop_limiter.wgsl` are not).
const MODULES: [(&str, &str); 54] = [
    ("shaders/angles.wgsl", include_str!("../../shaders/angles.wgsl")),
    ("shaders/layout.wgsl", super::layout::LAYOUT_WGSL),
    ("shaders/bindings.wgsl", include_str!("../../shaders/bindings.wgsl")),
    ("shaders/random.wgsl", include_str!("../../shaders/random.wgsl")),
    ("shaders/permute.wgsl", include_str!("../../shaders/permute.wgsl")),
    ("shaders/strata.wgsl", include_str!("../../shaders/strata.wgsl")),
    ("shaders/ray.wgsl", include_str!("../../shaders/ray.wgsl")),
    ("shaders/quadratic.wgsl", include_str!("../../shaders/quadratic.wgsl")),
    ("shaders/sphere.wgsl", include_str!("../../shaders/sphere.wgsl")),
    ("shaders/plane.wgsl", include_str!("../../shaders/plane.wgsl")),
    ("shaders/cube.wgsl", include_str!("../../shaders/cube.wgsl")),
    ("shaders/cylinder.wgsl", include_str!("../../shaders/cylinder.wgsl")),
    ("shaders/triangle.wgsl", include_str!("../../shaders/triangle.wgsl")),
    ("shaders/mesh.wgsl", include_str!("../../shaders/mesh.wgsl")),
    ("shaders/shapes.wgsl", include_str!("../../shaders/shapes.wgsl")),
    ("shaders/nearest.wgsl", include_str!("../../shaders/nearest.wgsl")),
    ("shaders/csg.wgsl", include_str!("../../shaders/csg.wgsl")),
    ("shaders/world.wgsl", include_str!("../../shaders/world.wgsl")),
    ("shaders/camera.wgsl", include_str!("../../shaders/camera.wgsl")),
    ("shaders/offset.wgsl", include_str!("../../shaders/offset.wgsl")),
    ("shaders/float_index.wgsl", include_str!("../../shaders/float_index.wgsl")),
    ("shaders/cell_index.wgsl", include_str!("../../shaders/cell_index.wgsl")),
    ("shaders/divide.wgsl", include_str!("../../shaders/divide.wgsl")),
    ("shaders/rescale.wgsl", include_str!("../../shaders/rescale.wgsl")),
    ("shaders/normalize.wgsl", include_str!("../../shaders/normalize.wgsl")),
    ("shaders/onb.wgsl", include_str!("../../shaders/onb.wgsl")),
    ("shaders/textures.wgsl", include_str!("../../shaders/textures.wgsl")),
    ("shaders/pigment.wgsl", include_str!("../../shaders/pigment.wgsl")),
    ("shaders/environment.wgsl", include_str!("../../shaders/environment.wgsl")),
    ("shaders/finite.wgsl", include_str!("../../shaders/finite.wgsl")),
    ("shaders/warp.wgsl", include_str!("../../shaders/warp.wgsl")),
    ("shaders/fresnel.wgsl", include_str!("../../shaders/fresnel.wgsl")),
    ("shaders/ggx.wgsl", include_str!("../../shaders/ggx.wgsl")),
    ("shaders/microfacet.wgsl", include_str!("../../shaders/microfacet.wgsl")),
    ("shaders/brdf.wgsl", include_str!("../../shaders/brdf.wgsl")),
    ("shaders/integrators.wgsl", include_str!("../../shaders/integrators.wgsl")),
    ("shaders/point_lights.wgsl", include_str!("../../shaders/point_lights.wgsl")),
    ("shaders/spherical_rectangle.wgsl", include_str!("../../shaders/spherical_rectangle.wgsl")),
    ("shaders/lights.wgsl", include_str!("../../shaders/lights.wgsl")),
    ("shaders/env_light.wgsl", include_str!("../../shaders/env_light.wgsl")),
    ("shaders/mis.wgsl", include_str!("../../shaders/mis.wgsl")),
    ("shaders/wf_path.wgsl", include_str!("../../shaders/wf_path.wgsl")),
    ("shaders/wf_counting.wgsl", include_str!("../../shaders/wf_counting.wgsl")),
    ("shaders/wf_control.wgsl", include_str!("../../shaders/wf_control.wgsl")),
    ("shaders/wf_camera.wgsl", include_str!("../../shaders/wf_camera.wgsl")),
    ("shaders/wf_first_hit.wgsl", include_str!("../../shaders/wf_first_hit.wgsl")),
    ("shaders/wf_hit.wgsl", include_str!("../../shaders/wf_hit.wgsl")),
    ("shaders/wf_classify.wgsl", include_str!("../../shaders/wf_classify.wgsl")),
    ("shaders/wf_intersect.wgsl", include_str!("../../shaders/wf_intersect.wgsl")),
    ("shaders/wf_csg.wgsl", include_str!("../../shaders/wf_csg.wgsl")),
    ("shaders/wf_shade.wgsl", include_str!("../../shaders/wf_shade.wgsl")),
    ("shaders/wf_shadow_ray.wgsl", include_str!("../../shaders/wf_shadow_ray.wgsl")),
    ("shaders/wf_shadow.wgsl", include_str!("../../shaders/wf_shadow.wgsl")),
    ("shaders/wf_film.wgsl", include_str!("../../shaders/wf_film.wgsl")),
];

/// All modules, in a library that knows every feature name.
pub fn shader_library() -> ShaderLibrary {
    use super::tables::Table;
    let tables = Table::ALL.map(Table::feature).into_iter().chain(Table::ALL.map(Table::texture_feature));
    let names: Vec<&str> = FeatureSet::ALL_NAMES
        .iter()
        .chain(&Stage::NAMES)
        .chain(&FeatureSet::DEVICE_NAMES)
        .copied()
        .chain(tables)
        .collect();
    let mut lib = ShaderLibrary::new(&names);
    for (file, src) in &MODULES {
        lib.add(file, src).unwrap_or_else(|e| panic!("built-in shader {file} is malformed: {e}"));
    }
    lib
}

/// Constants that depend on the scene rather than on a feature: the BVH stack size (one
/// walk's region, and the regions of all: a mesh's walk has its own, shaders/world.wgsl)
/// and the CSG trees' size.
fn constants_module(features: &FeatureSet) -> String {
    let depth = features.csg_max_depth.max(1);
    format!(
        "// #provides constants\n// Scene-dependent constants, generated by src/gpu/kernels.rs.\n\
         const BVH_STACK_SIZE: u32 = {}u;\n\
         const BVH_STACK_WORDS: u32 = {}u;\n\
         const CSG_NODE_BIT: u32 = 0x{:08X}u;\n\
         const CSG_MAX_DEPTH: u32 = {}u;\n\
         const CSG_POOL_SIZE: u32 = {}u;\n\
         const CSG_POOL_LEAVES: u32 = {}u;\n\
         const CSG_DEFER: bool = {};\n\
         const CSG_DEFER_SLOTS: u32 = {}u;\n\
         const CONDUCTOR_NODES: u32 = {}u;\n\
         const DIELECTRIC_NODES: u32 = {}u;\n",
        crate::accel::MAX_DEPTH + 1,
        (crate::accel::MAX_DEPTH + 1) * if features.mesh { 2 } else { 1 },
        super::layout::CSG_NODE_BIT,
        depth,
        wavefront::csg_pool_entries(features),
        features.csg_max_leaves.max(1),
        features.csg_trees as usize <= crate::prepare::CSG_DEFER_MAX,
        features.csg_trees.clamp(1, crate::prepare::CSG_DEFER_MAX as u32),
        crate::optics::energy_tables::CONDUCTOR_NODES,
        crate::optics::energy_tables::DIELECTRIC_NODES,
    )
}

/// The kernel of `stage` for scenes with `features`, assembled but not yet validated: a
/// render validates each kernel it has not cached once, on the thread that creates its
/// pipeline ([`Assembled::validate`]), so that no source is parsed and validated twice
/// (naga's validation of the largest kernel was a tenth of the time before its
/// compilation could start).
pub fn assemble_stage(features: &FeatureSet, stage: Stage) -> Result<Assembled, GpuError> {
    let mut lib = shader_library();
    let buffers = stage.buffers(features);
    let generated = [
        ("<generated tags>", super::layout::tags_wgsl()),
        ("<generated constants>", constants_module(features)),
        ("<generated scene tables>", super::tables::tables_wgsl().to_string()),
        (
            "<generated wavefront state>",
            wavefront::wavefront_module(&buffers, wavefront::Control::new(features.queue_shards), features.wide_words),
        ),
        ("<generated unrolled lists>", super::traversal::unrolled_wgsl(features)),
    ];
    let mut accessors = wavefront::accessor_modules(&buffers, features.wide_words);
    accessors.extend(wavefront::wide_word_modules());
    let generated = generated.iter().map(|(name, text)| (*name, text.as_str()));
    for (name, text) in generated.chain(accessors.iter().map(|(name, text)| (name.as_str(), text.as_str()))) {
        lib.add(name, text).map_err(|e| GpuError::Validation(e.to_string()))?;
    }
    let names: Vec<&str> = stage.names(features);
    let roots = [stage.entry().0];
    let assembled = lib
        .assemble(&roots, &names.iter().copied().collect())
        .map_err(|e| GpuError::Validation(format!("shader assembly of the {} stage: {e}", stage.label())))?;
    Ok(assembled)
}

/// Every distinct kernel that renders scenes with `features`, by the stage it is assembled
/// for: a stage that launches another stage's kernel ([`Stage::kernel_stage`]: the shading
/// kinds that share a kernel) is not assembled again.
pub fn assemble_stages(features: &FeatureSet) -> Result<Vec<(Stage, Assembled)>, GpuError> {
    Stage::for_scene(features)
        .into_iter()
        .filter(|s| s.kernel_stage(features) == *s)
        .map(|s| Ok((s, assemble_stage(features, s)?)))
        .collect()
}

/// The WGSL of the kernels that render `scene` with every table in storage buffers, stage
/// by stage ([`kernel_listing`]).
///
/// ```
/// use lumen::scene::*;
/// use lumen::color::Color;
/// let mut b = SceneBuilder::new(4, 4);
/// let m = b.diffuse(Color::gray(0.5));
/// b.sphere(Transform::IDENTITY, m);
/// let src = lumen::gpu::kernels::shader_source(&b.build().unwrap()).unwrap();
/// assert!(src.contains("fn sphere_span") && !src.contains("fn cylinder_span"));
/// assert!(src.contains("fn intersect_stage") && !src.contains("fn csg_stage"));
/// ```
pub fn shader_source(scene: &Scene) -> Result<String, GpuError> {
    let packed = super::pack::pack(scene, None).map_err(super::render::pack_error)?;
    kernel_listing(&packed.features)
}

/// The assembled kernels of a render with features `f`, stage by stage (`lumen shader`):
/// each stage's header (entry point and assembly features) and source; a stage that launches
/// another stage's kernel (shading kinds that share one) names that stage instead. Each kernel
/// is validated first, so that nothing naga rejects is printed.
pub fn kernel_listing(f: &FeatureSet) -> Result<String, GpuError> {
    let kernels: BTreeMap<Stage, Assembled> = assemble_stages(f)?.into_iter().collect();
    for a in kernels.values() {
        a.validate()?;
    }
    let mut out = String::new();
    for stage in Stage::for_scene(f) {
        match kernels.get(&stage) {
            Some(a) => out.push_str(&format!(
                "\n// ===== stage {} (entry point {}; features: {}) =====\n{}",
                stage.label(),
                stage.entry().1,
                stage.names(f).join(" "),
                a.source
            )),
            None => out.push_str(&format!(
                "\n// ===== stage {}: the kernel of {} =====\n",
                stage.label(),
                stage.kernel_stage(f).label()
            )),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use super::*;
    use crate::gpu::features::{EnvKind, KindUse, RendererKind};
    use crate::gpu::tables::{Table, TableForm, TableForms};
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

    /// Asserts every stage kernel holds nothing its stage does not need: every function is
    /// reachable from an entry point and every global (buffer or private array) is used by
    /// one. Returns the modules by stage.
    fn assert_minimal(features: &FeatureSet) -> Vec<(Stage, naga::Module)> {
        let mut out = Vec::new();
        for (stage, assembled) in assemble_stages(features).unwrap_or_else(|e| panic!("{features:?}: {e}")) {
            let v = assembled.validate().unwrap();
            let all = function_names(&v.module);
            let reachable = reachable_functions(&v.module);
            let unused: Vec<_> = all.difference(&reachable).collect();
            assert!(unused.is_empty(), "{} stage of {features:?}: unused functions {unused:?}", stage.label());
            for (h, g) in v.module.global_variables.iter() {
                let used = (0..v.module.entry_points.len()).any(|i| !v.info.get_entry_point(i)[h].is_empty());
                assert!(used, "{} stage of {features:?}: unused global {:?}", stage.label(), g.name);
            }
            out.push((stage, v.module));
        }
        out
    }

    /// A random feature set respecting the invariants `FeatureSet::of` guarantees.
    fn random_features(rng: &mut Pcg32, renderer: RendererKind, environment: EnvKind) -> FeatureSet {
        let mut b = || rng.next_u32() % 2 == 0;
        let mut f = FeatureSet {
            sphere: b(),
            plane: b(),
            cube: b(),
            cylinder: b(),
            mesh: b(),
            csg: b(),
            pigment_uniform: b(),
            pigment_checkered: b(),
            pigment_image: b(),
            diffuse: b(),
            specular: b(),
            dielectric: b(),
            conductor: b(),
            rough_dielectric: b(),
            plastic: b(),
            point_lights: b(),
            area_lights: b(),
            nee: b(),
            object_list: b(),
            renderer,
            environment,
            ..FeatureSet::default()
        };
        for t in Table::ALL {
            if b() {
                let form = if b() { TableForm::Uniform } else { TableForm::Texture };
                f.tables = f.tables.with(t, form);
            }
        }
        // What each BRDF kind's shading stage and light sampling keep (FeatureSet::of
        // leaves out what a kind's materials do not use).
        let mut some_use =
            || KindUse::NAMES.iter().fold(KindUse::NONE, |u, n| if rng.next_u32() % 2 == 0 { u.with(n) } else { u });
        f.shade_use = std::array::from_fn(|_| some_use());
        f.light_use = some_use();
        if f.csg && !(f.sphere || f.plane || f.cube || f.cylinder) {
            // A CSG tree's leaves are primitives (FeatureSet::of sets their kinds).
            f.sphere = true;
        }
        f.bvh = f.csg || f.sphere || f.cube || f.cylinder || f.mesh;
        // Round spheres: only spheres among the finite objects (FeatureSet::of).
        f.round_spheres = f.sphere && !(f.cube || f.cylinder || f.mesh || f.csg) && rng.next_u32() % 2 == 0;
        if !f.bvh && !f.plane {
            // Only materials of some shape count.
            (f.diffuse, f.specular, f.dielectric) = (false, false, false);
            (f.conductor, f.rough_dielectric, f.plastic) = (false, false, false);
        }
        if f.csg {
            f.csg_max_leaves = 1 + rng.next_u32() % 6;
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
            (f.conductor, f.rough_dielectric, f.plastic) = (false, false, false);
        }
        if renderer == RendererKind::PointLight {
            (f.specular, f.dielectric) = (false, false);
        }
        f.nee = f.nee && f.non_delta() && renderer == RendererKind::PathTracer;
        f.area_lights = f.area_lights && f.nee;
        f.sphere_lights = f.area_lights && f.sphere && rng.next_u32() % 2 == 0;
        f.cube_lights = f.area_lights && f.cube && rng.next_u32() % 2 == 0;
        f.mesh_lights = f.area_lights && f.mesh && rng.next_u32() % 2 == 0;
        if f.area_lights && !(f.sphere_lights || f.cube_lights || f.mesh_lights) {
            // Area lights are spheres, cubes or meshes of the scene.
            (f.sphere_lights, f.sphere, f.bvh) = (true, true, true);
        }
        // Light sampling keeps the lights' shape kinds, as FeatureSet::of records them.
        for (on, name) in [(f.sphere_lights, "SPHERE"), (f.cube_lights, "CUBE"), (f.mesh_lights, "MESH")] {
            if on {
                f.light_use = f.light_use.with(name);
            }
        }
        with_random_lists(rng, f)
    }

    /// `f` with unrolled lists as `pack` would give a scene of its features, or none (where
    /// a list would be too long): an object list holds one shape of each finite kind (never
    /// a mesh: FeatureSet::lists_objects), a plane list one plane, and one of the two a CSG
    /// tree when the scene has some.
    fn with_random_lists(rng: &mut Pcg32, mut f: FeatureSet) -> FeatureSet {
        use crate::gpu::layout::{shape_kind, Shape, CSG_NODE_BIT};
        use crate::gpu::traversal::Unrolled;
        let mut shapes: Vec<Shape> = Vec::new();
        let mut push = |kind: u32| {
            let mut s: Shape = bytemuck::Zeroable::zeroed();
            s.kind = kind;
            shapes.push(s);
            shapes.len() as u32 - 1
        };
        let finite: Vec<u32> =
            [(f.sphere, shape_kind::SPHERE), (f.cube, shape_kind::CUBE), (f.cylinder, shape_kind::CYLINDER)]
                .into_iter()
                .filter(|(on, _)| *on)
                .map(|(_, k)| push(k))
                .collect();
        let planes: Vec<u32> = if f.plane { vec![push(shape_kind::PLANE)] } else { vec![] };
        let tree_in_list = rng.next_u32() % 2 == 0 || !f.plane;
        let with_tree = |mut refs: Vec<u32>, here: bool| {
            if f.csg && here {
                refs.push(CSG_NODE_BIT); // tree 0
            }
            refs
        };
        let list = with_tree(finite, tree_in_list);
        let planes = with_tree(planes, !tree_in_list);
        if rng.next_u32() % 2 == 0 && !list.is_empty() {
            f.listed = Unrolled::of(&list, &shapes);
        }
        if rng.next_u32() % 2 == 0 && !planes.is_empty() {
            f.planes_listed = Unrolled::of(&planes, &shapes);
        }
        f
    }

    /// A random feature set with every primitive kind, CSG and a BVH on.
    fn everything_on(rng: &mut Pcg32, renderer: RendererKind, environment: EnvKind) -> FeatureSet {
        let mut all = random_features(rng, renderer, environment);
        (all.sphere, all.plane, all.cube, all.cylinder, all.csg, all.bvh) = (true, true, true, true, true, true);
        with_random_lists(rng, all)
    }

    #[test]
    fn a_covering_set_of_feature_sets_assembles_to_minimal_valid_wgsl() {
        let mut rng = Pcg32::new(3, 5);
        let mut count = 0;
        for renderer in [RendererKind::OnOff, RendererKind::Flat, RendererKind::PointLight, RendererKind::PathTracer] {
            for environment in [EnvKind::Background, EnvKind::Uniform, EnvKind::Gradient, EnvKind::Image] {
                // Everything on, nothing on, and random subsets.
                let mut all = everything_on(&mut rng, renderer, environment);
                all.csg_max_leaves = 4;
                all.csg_max_depth = 3;
                // Both packed forms, each with every table.
                let form = if environment == EnvKind::Image { TableForm::Texture } else { TableForm::Uniform };
                all.tables = TableForms::all(form);
                let none = random_features(&mut Pcg32::new(0, 0), renderer, environment);
                let none = FeatureSet { renderer, environment: none.environment, ..FeatureSet::default() };
                assert_minimal(&none);
                assert_minimal(&all);
                // Queues in shards (llvmpipe's threads), and in one.
                assert_minimal(&FeatureSet { queue_shards: 3, ..all });
                assert_minimal(&FeatureSet { queue_shards: 2, ..none });
                // 64-bit words, for the path state and for the storage tables.
                assert_minimal(&FeatureSet { wide_words: true, tables: TableForms::NONE, ..all });
                assert_minimal(&FeatureSet { wide_words: true, ..none });
                // A tree too large for private memory, whose queries give up after their
                // walk budget, or go on with the sweeps.
                for csg_sweeps in [false, true] {
                    assert_minimal(&FeatureSet { csg_max_leaves: 100, csg_sweep_nodes: 180, csg_sweeps, ..all });
                }
                for _ in 0..6 {
                    assert_minimal(&random_features(&mut rng, renderer, environment));
                    count += 1;
                }
            }
        }
        assert_eq!(count, 96);
    }

    /// The unrolled lists hold the objects' references and kinds, not their records, in
    /// reference order (not the BVH's, which moves with the objects): a scene whose objects
    /// move keeps its kernels (an animation's frames compile once), and one whose objects
    /// change kind or number gets its own.
    #[test]
    fn moving_listed_objects_keeps_the_kernels() {
        use crate::scene::{ShapeKind, Transform};
        let room = |x: f64, kind: ShapeKind| {
            let mut b = crate::scene::SceneBuilder::new(4, 4);
            let m = b.diffuse(crate::color::Color::gray(0.5));
            b.shape(crate::scene::Shape::primitive(kind, Transform::translation(glam::DVec3::new(x, 0.0, 0.0)), m));
            b.sphere(Transform::translation(glam::DVec3::new(3.0, 1.0, 0.0)), m).plane(Transform::IDENTITY, m);
            b.build().unwrap()
        };
        let here = shader_source(&room(2.0, ShapeKind::Cube)).unwrap();
        assert!(here.contains("fn listed_nearest") && here.contains("fn unrolled_planes"));
        assert_eq!(here, shader_source(&room(5.0, ShapeKind::Cube)).unwrap());
        assert_ne!(here, shader_source(&room(2.0, ShapeKind::Cylinder)).unwrap());
    }

    /// Mesa inlines every call, so each call site of the world query compiles the
    /// traversal (and a scene's CSG evaluation) once more: the PointLight kernel queries the
    /// camera ray and the shadow rays through one call (streetlamp.sl's cold kernel creation
    /// 3.45 s → 1.7 s on lavapipe), and so does every path-tracer stage that traces rays.
    #[test]
    fn the_world_is_queried_from_one_call_site_per_kernel() {
        use crate::scene::{CsgOp, PointLight, Renderer, Shape, ShapeKind, Transform};
        let mut b = crate::scene::SceneBuilder::new(4, 4);
        let m = b.diffuse(crate::color::Color::gray(0.5));
        let s = |x: f64| Shape::primitive(ShapeKind::Sphere, Transform::translation(glam::DVec3::new(x, 0.0, 0.0)), m);
        b.shape(Shape::csg(CsgOp::Diff, vec![s(0.0), s(0.5)], Transform::IDENTITY)).plane(Transform::IDENTITY, m);
        b.point_light(PointLight::default()).point_light(PointLight::default());
        for renderer in [
            Renderer::PointLight { background: crate::color::Color::BLACK, ambient: crate::color::Color::BLACK },
            Renderer::PathTracer(crate::scene::PathTracerSettings::default()),
        ] {
            b.renderer(renderer);
            for (stage, a) in assemble_stages(&FeatureSet::of(&b.build().unwrap())).unwrap() {
                let calls = a.source.matches("world_first(").count().saturating_sub(1);
                let traversals = a.source.matches("traverse(").count().saturating_sub(1);
                assert!(
                    calls <= 1 && traversals <= 1,
                    "{}: {calls} world_first and {traversals} traverse calls",
                    stage.label()
                );
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
        let modules = assert_minimal(&features);
        let stages: Vec<Stage> = modules.iter().map(|(s, _)| *s).collect();
        assert!(
            !stages.contains(&Stage::Csg) && !stages.contains(&Stage::Shade(crate::gpu::layout::brdf_kind::DIELECTRIC))
        );
        let mut all = BTreeSet::new();
        for (stage, module) in &modules {
            let names = function_names(module);
            for bad in [
                "csg",
                "cylinder",
                "cube",
                "plane",
                "texel",
                "image",
                "dielectric",
                "fresnel",
                "refract",
                "checker",
                "ggx",
                "conductor",
                "plastic",
                "albedo_row",
                "triangle",
                "mesh",
            ] {
                assert!(!names.iter().any(|n| n.contains(bad)), "{bad} in the {} stage: {names:?}", stage.label());
            }
            let globals: Vec<_> = module.global_variables.iter().filter_map(|(_, g)| g.name.clone()).collect();
            for bad in
                ["csg_trees", "floats", "point_lights", "area_lights", "csg_pool", "tri_positions", "tri_shading"]
            {
                assert!(!globals.iter().any(|g| g == bad), "{bad} bound in the {} stage: {globals:?}", stage.label());
            }
            all.extend(names);
        }
        assert!(all.contains("sphere_span") && all.contains("sample_diffuse"), "{all:?}");
        // The closest-hit stage has no shading code; the shading stage no traversal.
        let names_of = |s: Stage| function_names(&modules.iter().find(|(x, _)| *x == s).unwrap().1);
        let intersect = names_of(Stage::Intersect);
        assert!(
            intersect.contains("traverse")
                && !intersect.contains("sample_bsdf")
                && !intersect.contains("pigment_color")
        );
        let shade = names_of(Stage::Shade(crate::gpu::layout::brdf_kind::DIFFUSE));
        assert!(shade.contains("sample_diffuse") && !shade.contains("traverse") && !shade.contains("sphere_span"));
    }

    /// Issue 12, goal 3: kernel code and private memory must not grow with a scene's size.
    /// A FUSE of 1,000 spheres gets the same kernels as a FUSE of 100 but for the value of
    /// the span-pool size, which sizes no array (the spans live in the storage pool, whose
    /// size the host picks); only trees of at most `CSG_PRIVATE_POOL_MAX` leaves keep their
    /// spans in a private array.
    #[test]
    fn csg_kernels_do_not_grow_with_the_tree() {
        use crate::scene::{CsgOp, Shape, ShapeKind, Transform};
        let fuse = |n: usize| {
            let mut b = crate::scene::SceneBuilder::new(4, 4);
            let m = b.diffuse(crate::color::Color::gray(0.5));
            let spheres = (0..n)
                .map(|i| {
                    let at = glam::DVec3::new(i as f64 * 0.1, 0.0, 0.0);
                    Shape::primitive(ShapeKind::Sphere, Transform::translation(at), m)
                })
                .collect();
            // FUSE: a top-level UNITE would be stored as its spheres.
            b.shape(Shape::csg(CsgOp::Fuse, spheres, Transform::IDENTITY));
            b.point_light(crate::scene::PointLight {
                position: glam::DVec3::new(0.0, 0.0, 5.0),
                color: crate::color::Color::WHITE,
                linear_radius: 0.0,
            });
            FeatureSet::of(&b.build().unwrap())
        };
        // A small tree's spans stay in a bounded private array (no pool binding).
        let tiny = assemble_stages(&fuse(2)).unwrap();
        let (csg_stage, private) = tiny.iter().find(|(s, _)| *s == Stage::Csg).unwrap();
        assert!(
            private.source.contains("var<private> csg_pool")
                && !private.source.contains("var<storage, read_write> csg_pool"),
            "{csg_stage:?}"
        );
        assert!(wavefront::csg_pool_entries(&fuse(2)) <= wavefront::CSG_PRIVATE_POOL_MAX);
        let (small, large) = (fuse(100), fuse(1000));
        assert_eq!((small.csg_max_leaves, large.csg_max_leaves), (100, 1000));
        let bound_free = |src: &str| -> String {
            src.lines().filter(|l| !l.starts_with("const CSG_POOL_")).collect::<Vec<_>>().join("\n")
        };
        let (a, b) = (assemble_stages(&small).unwrap(), assemble_stages(&large).unwrap());
        assert_eq!(a.len(), b.len());
        let mut csg_stages = 0;
        for ((stage, x), (_, y)) in a.iter().zip(&b) {
            assert_eq!(bound_free(&x.source), bound_free(&y.source), "{stage:?}");
            for line in y.source.lines().filter(|l| l.contains("array<")) {
                assert!(!line.contains("CSG_POOL_"), "{stage:?}: {line}");
            }
            if y.source.contains("fn csg_first") {
                csg_stages += 1;
                // The pool's element is the size the host allocates by.
                let module = y.validate().unwrap().module;
                let ty = module.types.iter().find(|(_, t)| t.name.as_deref() == Some("CsgPoolEntry")).unwrap().1;
                let naga::TypeInner::Struct { span, .. } = ty.inner else { panic!("CsgPoolEntry is not a struct") };
                assert_eq!(u64::from(span), wavefront::CSG_POOL_ENTRY_BYTES);
            }
        }
        assert_eq!(csg_stages, 1, "only the CSG stage evaluates trees (shadow rays' too)");
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

    /// Whether `line` assigns to the variable `var` (`=`, `+=`, `-=`, `++`, `--`).
    fn assigns(line: &str, var: &str) -> bool {
        let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
        line.match_indices(var).any(|(i, _)| {
            let before = line[..i].chars().next_back();
            let after = line[i + var.len()..].trim_start();
            !before.is_some_and(ident)
                && !after.starts_with(ident)
                && ["=", "+=", "-=", "++", "--"].iter().any(|op| after.starts_with(op))
                && !after.starts_with("==")
        })
    }

    /// Every loop of the shader modules ends by construction, which is what lets the stage
    /// kernels go without wgpu's hidden loop bound (`Loops::Unbounded`; DESIGN.md "Loops
    /// that end"): each `for` counts a variable its body leaves alone up to a bound, each
    /// `while` or `loop` is one of the audited ones below, and the generated modules have no
    /// loop. A loop of another kind fails here until it is audited, listed, and described
    /// in DESIGN.md.
    #[test]
    fn every_shader_loop_is_one_that_ends() {
        // (module, function): why each ends.
        let audited: BTreeSet<(&str, &str)> = [
            // The walked node's index grows (children follow their parent in the
            // flattened tree, accel::quantized) until a leaf.
            ("shaders/world.wgsl", "bvh_descend"),
            // The stack's top falls by one per pass.
            ("shaders/world.wgsl", "bvh_pop"),
            // Each pass descends to a leaf not visited before, or pops; a node is pushed
            // at most once per walk.
            ("shaders/world.wgsl", "traverse"),
            ("shaders/mesh.wgsl", "mesh_first_crossing"),
            // Binary searches: the interval [lo, hi) shrinks every pass.
            ("shaders/env_light.wgsl", "dist1d_find_cell"),
            ("shaders/lights.wgsl", "light_sample_mesh"),
            // Two passes (row, then column): the second breaks (its exit also holds for a
            // NaN).
            ("shaders/env_light.wgsl", "env_sample"),
            // Cycle walking over a permutation: the cycle through i < n comes back below n
            // (i = a sample's cell, < s by PixelSamples).
            ("shaders/permute.wgsl", "permute_below"),
            // Each run takes the next crossings strictly after the last in (t, key) order
            // (csg_offer), and a tree has 2 per leaf.
            ("shaders/csg.wgsl", "csg_first"),
            // Heap sort: the build's start or the heap's size falls every pass, a sift's
            // hole index grows below the heap's size.
            ("shaders/csg.wgsl", "csg_sort_ends"),
            // Walks up the sweep table's parents (a tree lumen packs) to the root.
            ("shaders/csg.wgsl", "csg_leaf_changed"),
            ("shaders/csg.wgsl", "csg_sweep_classify"),
            // Every pass moves one of the sorted ends' cursors forward (each at most n).
            ("shaders/csg.wgsl", "csg_sweep_first"),
        ]
        .into_iter()
        .collect();
        let mut found = BTreeSet::new();
        for (file, src) in MODULES {
            let lines: Vec<&str> = src.lines().map(|l| l.split("//").next().unwrap_or("").trim()).collect();
            let mut function = "";
            for (n, &code) in lines.iter().enumerate() {
                let at = format!("{file}:{}", n + 1);
                if let Some(rest) = code.strip_prefix("fn ") {
                    function = rest.split('(').next().unwrap_or("");
                }
                if code.starts_with("while ") || code.starts_with("while(") || code.starts_with("loop ") {
                    found.insert((file, function));
                }
                let Some(head) = code.strip_prefix("for (") else { continue };
                // for (var i = a; i < b; i++) {
                let parts: Vec<&str> = head.split(';').map(str::trim).collect();
                let var = parts[0].strip_prefix("var ").and_then(|p| p.split(" = ").next()).unwrap_or("");
                assert!(
                    parts.len() == 3
                        && !var.is_empty()
                        && parts[1].starts_with(&format!("{var} < "))
                        && parts[2] == format!("{var}++) {{"),
                    "{at}: not a counted loop: {code}"
                );
                // The body, to the brace that closes the header's, leaves the counter alone.
                let mut depth = 1i32;
                for body in &lines[n + 1..] {
                    depth += body.matches('{').count() as i32 - body.matches('}').count() as i32;
                    if depth <= 0 {
                        break;
                    }
                    assert!(!assigns(body, var), "{at}: the body of a counted loop sets {var}: {body}");
                }
            }
        }
        assert_eq!(found, audited, "loops found (left) against the audited list (right)");
        // The generated modules (tables, tags, unrolled lists, wavefront state) have none.
        let mut rng = Pcg32::new(7, 1);
        for renderer in [RendererKind::OnOff, RendererKind::Flat, RendererKind::PointLight, RendererKind::PathTracer] {
            for environment in [EnvKind::Background, EnvKind::Uniform, EnvKind::Gradient, EnvKind::Image] {
                for (stage, assembled) in assemble_stages(&everything_on(&mut rng, renderer, environment)).unwrap() {
                    let mut generated = false;
                    for line in assembled.source.lines() {
                        if line.starts_with("// ---- module ") {
                            generated = line.contains("(<generated");
                        }
                        let code = line.trim();
                        let looping = ["for (", "while ", "loop "].iter().any(|k| code.starts_with(k));
                        assert!(!(generated && looping), "{stage:?}: a loop in generated code: {line}");
                    }
                }
            }
        }
        assert!(assigns("    k += 1u;", "k") && assigns("k++;", "k") && !assigns("if (k == n) {", "k"));
        assert!(!assigns("let kk = 1u;", "k") && !assigns("x.k = 2u;", "x"));
    }

    /// Tags reach WGSL only through the constants `layout::tags_wgsl` generates: no shader
    /// compares a tag field with a number or switches over tags with numeric cases, so a
    /// tag that changes in Rust changes in every kernel.
    #[test]
    fn shaders_name_tags_only_through_generated_constants() {
        const FIELDS: [&str; 8] =
            [".kind", ".brdf", ".projection", ".jitter", ".image_filter", ".light", "kind", " op"];
        for (file, src) in MODULES {
            let mut tag_switch = false;
            for (n, line) in src.lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                for op in ["==", "!="] {
                    for (i, _) in code.match_indices(op) {
                        let (lhs, rhs) = (code[..i].trim_end(), code[i + 2..].trim_start());
                        let tagged = FIELDS.iter().any(|f| lhs.ends_with(f.trim_start()));
                        assert!(
                            !(tagged && rhs.starts_with(|c: char| c.is_ascii_digit())),
                            "{file}:{}: a tag compared with a number: {line}",
                            n + 1
                        );
                    }
                }
                let t = code.trim();
                if t.starts_with("switch ") {
                    tag_switch = t.contains("kind") || t.contains(" op");
                }
                if tag_switch && t.starts_with("case ") {
                    assert!(
                        !t[5..].starts_with(|c: char| c.is_ascii_digit()),
                        "{file}:{}: a numeric tag case: {line}",
                        n + 1
                    );
                }
            }
        }
        // The generated constants carry Rust's values.
        let tags = crate::gpu::layout::tags_wgsl();
        assert!(tags.contains(&format!("const BRDF_DIELECTRIC: u32 = {}u;", crate::gpu::layout::brdf_kind::DIELECTRIC)));
        assert!(tags.contains(&format!("const CSG_FUSE: u32 = {}u;", crate::gpu::layout::csg_op::FUSE)));
    }
}
