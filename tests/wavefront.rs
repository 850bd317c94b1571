//! The wavefront renderer's own guarantees (docs/DESIGN.md "Wavefront renderer"): no
//! invocation runs long enough for a driver's loop limiter to cut it, so paths that the
//! old megakernel could not finish in one invocation are exact; images do not depend on
//! the batch size; Ctrl-C and time limits keep whole rounds.

mod common;

use common::{agreement, emissive, Tolerance};
use glam::DVec3;
use lumen::color::Color;
use lumen::cpu::{Progress, RenderOptions};
use lumen::gpu::render::{render, GpuRenderOptions, GpuRenderOutput};
use lumen::gpu::{gpu_for_tests, probe_loop_limiter, Gpu, StopReason, LOOP_LIMITER_PROBE_TRIPS};
use lumen::scene::*;

/// The path tracer without roulette (every path has its full length).
fn pt(n: u32, max_depth: u32, nee: bool) -> Renderer {
    common::pt(n, max_depth, 1000, nee)
}

/// The camera inside `shells` concentric emitting spheres (ρ 0.5, Le 1, radii 10 to 11):
/// every path bounces inside the innermost one and is worth exactly Σ_(k≤depth) 0.5ᵏ, while
/// every traversal visits all the spheres (each bounding box holds the ray's origin), so
/// a path's loop iterations grow with `shells × depth`.
fn shells(shells: usize, n: u32, depth: u32) -> Scene {
    let mut b = SceneBuilder::new(2, 2);
    let m = emissive(&mut b, 0.5, 1.0);
    for k in 0..shells {
        b.sphere(Transform::scaling(DVec3::splat(10.0 + k as f64 / shells as f64)), m);
    }
    b.renderer(pt(n, depth, false));
    b.build().unwrap()
}

fn gpu_render(gpu: &Gpu, scene: &Scene, spp: u32, batch_paths: u32) -> GpuRenderOutput {
    let mut opts = GpuRenderOptions::fixed_passes(Some(spp), 4);
    opts.passes.batch_paths = batch_paths;
    let out = render(gpu, scene, &opts).unwrap();
    assert_eq!(out.non_finite_samples, 0);
    assert_eq!(out.spp_done, spp);
    out
}

fn bits(img: &lumen::image::HdrImage) -> Vec<[u32; 3]> {
    img.pixels().iter().map(|p| [p.r.to_bits(), p.g.to_bits(), p.b.to_bits()]).collect()
}

/// A rough metal (a conductor of grey reflectance, roughness 0.3) that emits nothing.
fn rough_metal(b: &mut SceneBuilder) -> MaterialId {
    b.material(Material::new(
        Brdf::Conductor {
            pigment: Pigment::Uniform(Color::gray(0.9)),
            roughness: 0.3,
            fresnel: None,
            multiple_scattering: true,
        },
        Pigment::Uniform(Color::BLACK),
    ))
}

/// Diffuse, glass and mirror surfaces, an emitting sphere and cube (NEE), a point light
/// and a plane: every stage the path tracer has.
fn mixed_scene(renderer: Renderer) -> Scene {
    let mut b = SceneBuilder::new(12, 9);
    let white = b.diffuse(Color::gray(0.7));
    b.plane(Transform::translation(DVec3::new(0.0, 0.0, -1.0)), white);
    common::add_lit_props(&mut b);
    b.camera(Camera { aspect_ratio: 12.0 / 9.0, ..Camera::default() })
        .environment(Environment::Uniform(Color::new(0.1, 0.1, 0.2)))
        .renderer(renderer);
    b.build().unwrap()
}

/// [`mixed_scene`] under each renderer, the path tracer as `path_tracer`.
fn mixed_scenes(path_tracer: Renderer) -> Vec<Scene> {
    [
        path_tracer,
        Renderer::OnOff { on: Color::WHITE, off: Color::BLACK },
        Renderer::Flat { background: Color::gray(0.2) },
        Renderer::PointLight { background: Color::gray(0.1), ambient: Color::gray(0.05) },
    ]
    .into_iter()
    .map(mixed_scene)
    .collect()
}

/// Paths of 1,000 shells × 60 bounces (more than 65,535 loop iterations each, which
/// llvmpipe's limiter cut in the megakernel even when run alone) and 600 × 30 (cut in
/// company): in the wavefront each invocation runs one query, so every path is exact.
#[test]
fn paths_longer_than_the_loop_limiter_are_exact() {
    let Some(gpu) = gpu_for_tests("paths_longer_than_the_loop_limiter") else { return };
    let probe = probe_loop_limiter(&gpu).unwrap();
    println!("{}: loop limiter probe {probe} of {LOOP_LIMITER_PROBE_TRIPS}", gpu.description());
    for (count, n, depth) in [(600, 4, 30), (1000, 2, 60)] {
        let scene = shells(count, n, depth);
        let out = gpu_render(&gpu, &scene, 1, 0);
        let expected = 2.0 * (1.0 - 0.5f64.powi(depth as i32 + 1));
        for p in out.image.pixels() {
            assert!((f64::from(p.g) / expected - 1.0).abs() < 2e-6, "{count} shells, depth {depth}: {p:?}");
        }
    }
}

/// The stability suite's case (docs/STABILITY.md): inside an emitting cube, 256 paths of
/// depth 50 per camera sample, every path exactly Σ_(k≤50) 0.5ᵏ, in one batch per round
/// and without any resumption (the megakernel summed only 129 of them on lavapipe).
#[test]
fn the_256_path_furnace_is_exact() {
    let Some(gpu) = gpu_for_tests("the_256_path_furnace") else { return };
    let mut b = SceneBuilder::new(4, 4);
    let m = emissive(&mut b, 0.5, 1.0);
    b.cube(Transform::scaling(DVec3::splat(5.0)), m).renderer(pt(256, 50, false));
    let scene = b.build().unwrap();
    let out = gpu_render(&gpu, &scene, 1, 0);
    let expected = 2.0 * (1.0 - 0.5f64.powi(51));
    assert!(out.image.pixels().iter().all(|p| (f64::from(p.g) / expected - 1.0).abs() < 2e-6));
    assert_eq!(out.batches, 1);
}

/// Whatever the batch size (a few slots, a pixel's worth, many pixels), every renderer
/// gives bit for bit the same image, and the path tracer's matches the CPU reference.
#[test]
fn images_do_not_depend_on_the_batch_size() {
    let Some(gpu) = gpu_for_tests("images_do_not_depend_on_the_batch_size") else { return };
    for renderer in [
        pt(3, 5, true),
        pt(2, 4, false),
        Renderer::OnOff { on: Color::WHITE, off: Color::BLACK },
        Renderer::Flat { background: Color::gray(0.2) },
        Renderer::PointLight { background: Color::gray(0.1), ambient: Color::gray(0.05) },
    ] {
        let scene = mixed_scene(renderer);
        let whole = gpu_render(&gpu, &scene, 4, 0);
        let name = scene.renderer.name();
        for batch in [12, 97, 400] {
            let out = gpu_render(&gpu, &scene, 4, batch);
            assert!(
                out.batches > whole.batches,
                "{name}: batch {batch} ran {} batches of {}",
                out.batches,
                out.batch_paths
            );
            assert!(bits(&out.image) == bits(&whole.image), "{name}: batches of {batch} slots change the image");
        }
        let cpu =
            lumen::cpu::render(&scene, &RenderOptions { spp: Some(4), ..RenderOptions::default() }, Progress::Hidden);
        let agree = agreement(&whole.image, &cpu.image);
        agree.check(Tolerance::share(0.99)).unwrap_or_else(|e| panic!("{name} against the CPU: {e}"));
    }
}

/// Queue shards (`GpuRenderOptions::queue_shards`, `wavefront::Control`) move where a
/// path's queue entries live and which workgroup runs it, never what is computed: one,
/// two and five shards give the same bits and ray counts for every renderer, with CSG
/// trees met by closest-hit and shadow rays (the CSG stage's two queues), in whole batches
/// and in batches that end mid-block (97 and 1,000 slots: shards of unequal length).
#[test]
fn queue_shards_give_the_same_bits() {
    let Some(gpu) = gpu_for_tests("queue_shards_give_the_same_bits") else { return };
    let csg = {
        let mut b = SceneBuilder::new(12, 9);
        let m = b.diffuse(Color::new(0.7, 0.5, 0.3));
        let at = |x: f64, r: f64| Transform::translation(DVec3::new(x, 0.0, 0.0)) * Transform::scaling(DVec3::splat(r));
        let ball = |x, r| Shape::primitive(ShapeKind::Sphere, at(x, r), m);
        b.shape(Shape::csg(CsgOp::Diff, vec![ball(4.0, 1.0), ball(3.4, 0.6)], Transform::IDENTITY));
        common::add_lit_props(&mut b);
        b.camera(Camera { aspect_ratio: 12.0 / 9.0, ..Camera::default() }).renderer(pt(2, 4, true));
        b.build().unwrap()
    };
    let scenes = [
        mixed_scene(pt(3, 5, true)),
        mixed_scene(Renderer::PointLight { background: Color::gray(0.1), ambient: Color::gray(0.05) }),
        csg,
    ];
    for scene in &scenes {
        let name = scene.renderer.name();
        for batch in [0, 97, 1000] {
            let mut outs = Vec::new();
            for shards in [1, 2, 5] {
                let mut opts =
                    GpuRenderOptions { queue_shards: Some(shards), ..GpuRenderOptions::fixed_passes(Some(4), 4) };
                opts.passes.batch_paths = batch;
                let out = render(&gpu, scene, &opts).unwrap();
                assert_eq!((out.spp_done, out.non_finite_samples, out.queue_shards), (4, 0, shards));
                outs.push(out);
            }
            for (out, shards) in outs[1..].iter().zip([2, 5]) {
                assert!(bits(&out.image) == bits(&outs[0].image), "{name}, batches of {batch}: {shards} shards");
                assert_eq!(out.rays, outs[0].rays, "{name}, batches of {batch}: {shards} shards");
            }
        }
    }
}

/// The path state and the struct tables (in uniform and storage buffers) held in 64-bit
/// words (`GpuRenderOptions::wide_words`, DESIGN.md "Wide words") are the same bytes as in
/// 32-bit words, read and written through the same accessors: every renderer, CSG trees met
/// by closest-hit and shadow rays, textures, rough materials, meshes and a mesh light (their
/// BVH and triangle tables in storage buffers where the adapter's placement leaves them
/// there) give the same bits and ray counts either way. Where the device cannot hold 64-bit words (no 64-bit
/// integers, or an adapter lumen does not widen for) the render uses 32-bit words whatever
/// it asks.
#[test]
fn wide_and_narrow_words_give_the_same_bits() {
    let Some(gpu) = gpu_for_tests("wide_and_narrow_words_give_the_same_bits") else { return };
    let can_widen = lumen::gpu::wavefront::wide_words(&gpu);
    if lumen::gpu::is_llvmpipe(&gpu.adapter_info) {
        assert!(can_widen, "lavapipe has 64-bit integers: its renders hold their words wide");
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut scenes = mixed_scenes(pt(3, 5, true));
    for name in ["csg.sl", "glass.sl", "meshes.sl", "materials.sl"] {
        scenes.push(common::thumbnail(&root.join("scenes").join(name), 12, 8));
    }
    for (k, scene) in scenes.iter().enumerate() {
        let render_with = |wide: bool| {
            let opts = GpuRenderOptions { wide_words: Some(wide), ..GpuRenderOptions::fixed_passes(Some(4), 4) };
            let out = render(&gpu, scene, &opts).unwrap();
            assert_eq!((out.spp_done, out.non_finite_samples), (4, 0), "scene {k}");
            out
        };
        let (narrow, wide) = (render_with(false), render_with(true));
        assert!(!narrow.wide_words);
        assert_eq!(wide.wide_words, can_widen, "scene {k}");
        assert!(bits(&wide.image) == bits(&narrow.image), "scene {k}: 64-bit words change the image");
        assert_eq!(wide.rays, narrow.rays, "scene {k}");
    }
}

/// A twin device (llvmpipe: `wavefront::twin`, DESIGN.md "Twin devices") renders its share
/// of the batches bit for bit as the render's own device would: every renderer, the twin
/// forced on (`TwinUse::Always`, the host waiting until it is set up) and off, in batches of
/// 97 slots, one renderer keeping its twin from scene to scene. Where a twin can run
/// (llvmpipe through Vulkan, two cores or more) it must have run some of them; elsewhere
/// none.
#[test]
fn a_twin_device_renders_the_same_bits() {
    use lumen::gpu::render::{GpuRenderer, TwinUse};
    let Some(gpu) = gpu_for_tests("a_twin_device_renders_the_same_bits") else { return };
    let kept = std::cell::RefCell::new(GpuRenderer::new());
    let info = &gpu.adapter_info;
    let twin_can_run = info.backend == wgpu::Backend::Vulkan
        && info.name.to_ascii_lowercase().contains("llvmpipe")
        && std::thread::available_parallelism().map_or(1, |n| n.get()) >= 2;
    for renderer in [
        pt(3, 5, true),
        Renderer::OnOff { on: Color::WHITE, off: Color::BLACK },
        Renderer::PointLight { background: Color::gray(0.1), ambient: Color::gray(0.05) },
    ] {
        let scene = mixed_scene(renderer);
        let name = scene.renderer.name();
        let with = |twin: TwinUse| {
            let mut opts = GpuRenderOptions { twin, ..GpuRenderOptions::fixed_passes(Some(8), 4) };
            opts.passes.batch_paths = 97;
            let out = kept.borrow_mut().render(&gpu, &scene, &opts).unwrap();
            assert_eq!((out.spp_done, out.non_finite_samples), (8, 0), "{name}");
            out
        };
        let (alone, shared) = (with(TwinUse::Never), with(TwinUse::Always));
        assert_eq!(alone.twin_batches, 0, "{name}");
        if twin_can_run {
            assert!(
                shared.twin_batches > 0,
                "{name}: the twin ran {} of {} batches",
                shared.twin_batches,
                shared.batches
            );
        } else {
            assert_eq!(shared.twin_batches, 0, "{name}");
        }
        assert!(bits(&shared.image) == bits(&alone.image), "{name}: the twin's batches change the image");
        assert_eq!(shared.rays, alone.rays, "{name}: rays counted on both devices");
    }
}

/// The film's compensated sum makes a pixel's value independent of how its samples are
/// split into rounds (what lets shards merge into the one-render image): 16 samples in one
/// round, in rounds of 5, 5, 5, 1 and one by one give the same f32 image but for the rare
/// final rounding of an exact tie. A plain f32 sum (or a TwoSum the shader compiler folds
/// away) differs in the last bits on most pixels.
#[test]
fn round_sizes_do_not_change_the_image() {
    let Some(gpu) = gpu_for_tests("round_sizes_do_not_change_the_image") else { return };
    let scene = mixed_scene(pt(3, 5, true));
    let image = |per_round: u32| {
        let out = render(&gpu, &scene, &GpuRenderOptions::fixed_passes(Some(16), per_round)).unwrap();
        assert_eq!(out.spp_done, 16);
        bits(&out.image)
    };
    let whole = image(16);
    for per_round in [5, 1] {
        let split = image(per_round);
        let mut differing = 0;
        for (p, (a, b)) in whole.iter().zip(&split).enumerate() {
            for c in 0..3 {
                let ulps = a[c].abs_diff(b[c]);
                assert!(ulps <= 1, "pixel {p} channel {c}: {ulps} ulp apart with {per_round} spp per round");
                differing += usize::from(ulps > 0);
            }
        }
        assert!(differing * 100 <= whole.len() * 3, "{differing} channels differ with {per_round} spp per round");
    }
}

/// Ctrl-C (the cancel flag) before the first round ends drops it: nothing is kept.
#[test]
fn cancel_drops_the_unfinished_round() {
    let Some(gpu) = gpu_for_tests("wavefront_cancel") else { return };
    let scene = mixed_scene(pt(3, 5, true));
    let mut opts = GpuRenderOptions::fixed_passes(Some(4), 4);
    opts.passes.cancel = Some(std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true)));
    let out = render(&gpu, &scene, &opts).unwrap();
    assert_eq!((out.stop, out.spp_done, out.batches), (StopReason::Interrupted, 0, 1));
    assert!(out.image.pixels().iter().all(|p| p.r == 0.0 && p.g == 0.0 && p.b == 0.0));
}

/// A launch traces about as many rays as a launch of the default batch at eight rays per
/// path, however many point lights each path traces in it (the point-light renderer's
/// first-hit launch, the path tracer's shadow launch): 4,000 lights make batches smaller
/// (on lavapipe 262 slots instead of the image's 1,024), never a launch 4,000 times longer,
/// and the image stays the CPU's.
#[test]
fn many_point_lights_make_batches_smaller_not_launches_longer() {
    let Some(gpu) = gpu_for_tests("many_point_lights_make_batches_smaller_not_launches_longer") else { return };
    const LIGHTS: u32 = 4000;
    for renderer in [Renderer::PointLight { background: Color::gray(0.1), ambient: Color::gray(0.05) }, pt(1, 2, true)]
    {
        let mut b = SceneBuilder::new(32, 32);
        let m = b.diffuse(Color::gray(0.6));
        b.sphere(Transform::IDENTITY, m).plane(Transform::translation(DVec3::new(0.0, 0.0, -1.0)), m);
        for k in 0..LIGHTS {
            let a = f64::from(k) * 2.399_963; // the golden angle: lights spread on a disc
            let r = 3.0 * (f64::from(k) / f64::from(LIGHTS)).sqrt();
            b.point_light(PointLight {
                position: DVec3::new(-1.0 + r * a.cos(), r * a.sin(), 4.0),
                color: Color::gray(4.0 / f64::from(LIGHTS)),
                linear_radius: 0.0,
            });
        }
        b.renderer(renderer)
            .camera(Camera { transform: Transform::translation(DVec3::new(-2.0, 0.0, 0.5)), ..Camera::default() });
        let scene = b.build().unwrap();
        let name = scene.renderer.name();
        let out = render(&gpu, &scene, &GpuRenderOptions { spp: Some(1), ..GpuRenderOptions::default() }).unwrap();
        let budget = u64::from(lumen::gpu::wavefront::default_slots(&gpu))
            * u64::from(lumen::gpu::wavefront::LAUNCH_RAYS_PER_SLOT);
        let per_launch = u64::from(out.batch_paths) * u64::from(LIGHTS + 1);
        assert!(
            per_launch <= budget.max(u64::from(lumen::gpu::wavefront::MIN_BOUNDED_SLOTS) * u64::from(LIGHTS + 1)),
            "{name}: {} slots",
            out.batch_paths
        );
        let cpu =
            lumen::cpu::render(&scene, &RenderOptions { spp: Some(1), ..RenderOptions::default() }, Progress::Hidden);
        agreement(&out.image, &cpu.image).check(Tolerance::share(0.99)).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// A time limit that has passed after the first round keeps exactly that round.
#[test]
fn a_time_limit_keeps_whole_rounds() {
    let Some(gpu) = gpu_for_tests("wavefront_time_limit") else { return };
    let scene = mixed_scene(pt(1, 3, true));
    let mut opts = GpuRenderOptions::fixed_passes(Some(64), 3);
    opts.passes.time_limit = Some(std::time::Duration::ZERO);
    let out = render(&gpu, &scene, &opts).unwrap();
    assert_eq!((out.stop, out.spp_done), (StopReason::TimeLimit, 3));
}

/// A device lost in the middle of a render (destroyed from another thread) ends it with an
/// error, not a panic or a hang (`lumen render --device auto` then renders on the CPU).
#[test]
fn a_device_lost_mid_render_is_an_error() {
    let Some(gpu) = gpu_for_tests("wavefront_device_lost") else { return };
    let scene = mixed_scene(pt(2, 8, true));
    let opts = GpuRenderOptions { spp: Some(1 << 16), ..GpuRenderOptions::default() };
    let result = std::thread::scope(|s| {
        s.spawn(|| {
            std::thread::sleep(std::time::Duration::from_millis(300));
            gpu.device.destroy();
        });
        render(&gpu, &scene, &opts)
    });
    let err = result.expect_err("65,536 spp cannot finish in 0.3 s");
    assert!(matches!(err, lumen::gpu::GpuError::DeviceLost(_)), "{err}");
}

/// Issue 12, goal 3: a FUSE of 1,000 overlapping spheres (interval bound 1,000) renders on
/// the GPU and agrees with the CPU reference. Its interval lists live in the storage pool
/// (which bounds the batch), so the kernels are those of any CSG scene; batches of a few
/// slots give the same image bit for bit. (A top-level UNITE of them would be stored as
/// 1,000 spheres, Shape::top_level_parts, and is tested by the same block below.)
#[test]
fn a_fuse_of_1000_spheres_renders_like_the_cpu() {
    let Some(gpu) = gpu_for_tests("a_fuse_of_1000_spheres") else { return };
    // A 10 × 10 × 10 block of spheres of radius 0.12 on a 0.2 grid (neighbours overlap),
    // alternating materials, just behind the screen (the camera looks along +x), joined by
    // `op`.
    let block = |op: CsgOp| {
        let mut b = SceneBuilder::new(16, 12);
        let grey = b.diffuse(Color::gray(0.6));
        let red = b.diffuse(Color::new(0.7, 0.2, 0.1));
        let spheres = (0..1000)
            .map(|i| {
                let (x, y, z) = ((i % 10) as f64, ((i / 10) % 10) as f64, (i / 100) as f64);
                let at = DVec3::new(0.2 + 0.2 * x, -0.9 + 0.2 * y, -0.9 + 0.2 * z);
                let m = if i % 2 == 0 { grey } else { red };
                Shape::primitive(
                    ShapeKind::Sphere,
                    Transform::translation(at) * Transform::scaling(DVec3::splat(0.12)),
                    m,
                )
            })
            .collect();
        b.shape(Shape::csg(op, spheres, Transform::IDENTITY));
        b.point_light(PointLight { position: DVec3::new(2.0, 3.0, 4.0), color: Color::gray(20.0), linear_radius: 0.0 });
        b.camera(Camera { aspect_ratio: 16.0 / 12.0, ..Camera::default() })
            .environment(Environment::Uniform(Color::new(0.3, 0.35, 0.4)))
            .renderer(pt(1, 3, true));
        b.build().unwrap()
    };
    let scene = block(CsgOp::Fuse);
    let f = lumen::gpu::features::FeatureSet::of(&scene);
    assert!(f.csg && f.csg_max_leaves == 1000, "{f:?}");
    let whole = gpu_render(&gpu, &scene, 2, 0);
    // No query passes the walk budget (a FUSE shows its first crossing), so the kernels
    // never needed the sweeps.
    assert!(!whole.features.csg_sweeps);
    let few = gpu_render(&gpu, &scene, 2, 7);
    assert!(few.batches > whole.batches);
    assert!(bits(&few.image) == bits(&whole.image), "batches of 7 slots change the image");
    let cpu = lumen::cpu::render(&scene, &RenderOptions { spp: Some(2), ..RenderOptions::default() }, Progress::Hidden);
    let covered = cpu.image.pixels().iter().filter(|p| (p.r - 0.3).abs() > 1e-3).count();
    assert!(covered > 60, "the block should fill much of the view ({covered} of 192 pixels)");
    agreement(&whole.image, &cpu.image).check(Tolerance::share(0.97)).unwrap_or_else(|e| panic!("{e}"));
    // The same block as a top-level UNITE: 1,000 spheres in the BVH, no CSG code at all.
    let scene = block(CsgOp::Unite);
    assert!(
        lumen::prepare::render_form(&scene).shapes.len() == 1000 && !lumen::gpu::features::FeatureSet::of(&scene).csg
    );
    let unite = gpu_render(&gpu, &scene, 2, 0);
    let cpu = lumen::cpu::render(&scene, &RenderOptions { spp: Some(2), ..RenderOptions::default() }, Progress::Hidden);
    agreement(&unite.image, &cpu.image).check(Tolerance::share(0.97)).unwrap_or_else(|e| panic!("{e}"));
}

/// `GpuRenderOptions::profile`: the timestamps change nothing in the image, every stage the
/// scene has is timed, each as often as the schedule launches it (camera and film once per
/// batch; closest hit once per bounce and once more for the last one), and the device
/// time, like the host's recording and waiting, fits in the wall time of the rounds.
#[test]
fn a_profiled_render_times_every_stage_and_keeps_the_image() {
    let Some(gpu) = gpu_for_tests("a_profiled_render") else { return };
    let depth = 4;
    let scene = mixed_scene(pt(2, depth, true));
    let mut opts = GpuRenderOptions::fixed_passes(Some(4), 2);
    opts.passes.batch_paths = 100;
    let plain = render(&gpu, &scene, &opts).unwrap();
    opts.profile = true;
    let timed = render(&gpu, &scene, &opts).unwrap();
    assert!(bits(&timed.image) == bits(&plain.image), "timestamps changed the image");
    assert!(plain.profile.is_none());
    let Some(p) = timed.profile else {
        assert!(!gpu.device.features().contains(lumen::gpu::wavefront::profile::FEATURES));
        println!("skipped: {} has no timestamp queries inside passes", gpu.adapter_info.name);
        return;
    };
    println!("{}", p.table());
    let launched: std::collections::BTreeSet<String> = p.stages.keys().cloned().collect();
    let expected: std::collections::BTreeSet<String> =
        lumen::gpu::wavefront::Stage::for_scene(&timed.features).into_iter().map(|s| s.label()).collect();
    assert_eq!(launched, expected);
    let launches = |s: &str| p.stages[s].launches;
    assert!(timed.batches > 1);
    assert_eq!((launches("camera"), launches("film")), (timed.batches, timed.batches));
    assert_eq!(launches("intersect"), timed.batches * u64::from(depth + 1));
    assert_eq!(p.untimed_launches, 0);
    assert!(p.stages.values().all(|t| t.seconds.is_finite() && t.seconds >= 0.0));
    let busy = p.busy_fraction();
    assert!(p.device_seconds() > 0.0 && busy > 0.0 && busy <= 1.0 + 1e-6, "busy {busy}");
    // The host recorded every batch and waited for each read-back, within the rounds.
    let host = p.host_submit_seconds + p.host_wait_seconds;
    assert!(p.host_submit_seconds > 0.0 && p.host_wait_seconds > 0.0, "{p:?}");
    assert!(host <= p.wall_seconds, "host {host} s in rounds of {} s", p.wall_seconds);
}

/// Where the scene's tables live (`GpuRenderOptions::tables`, DESIGN.md "Scene tables")
/// changes how the kernels load them, never what they load: uniform, texture and storage
/// placement give the same bits for every renderer, with CSG trees (their nodes and
/// children), when a table is too large for a uniform buffer (600 shapes: shapes in
/// storage, the BVH and materials in uniform buffers), with texels, sampling tables and
/// energy rows, and with meshes and a mesh light (whose triangle tables exceed 64 KiB).
#[test]
fn uniform_and_storage_tables_give_the_same_bits() {
    use lumen::gpu::tables::{Table, TableForm, TableForms, TablePlacement};
    let Some(gpu) = gpu_for_tests("uniform_and_storage_tables_give_the_same_bits") else { return };
    let render_with = |scene: &Scene, tables: TablePlacement| {
        let opts = GpuRenderOptions { tables, ..GpuRenderOptions::fixed_passes(Some(4), 4) };
        let out = render(&gpu, scene, &opts).unwrap();
        assert_eq!((out.spp_done, out.non_finite_samples), (4, 0));
        out
    };
    let csg = {
        let mut b = SceneBuilder::new(12, 9);
        let m = b.diffuse(Color::new(0.7, 0.5, 0.3));
        let at = |x: f64, r: f64| Transform::translation(DVec3::new(x, 0.0, 0.0)) * Transform::scaling(DVec3::splat(r));
        let ball = |x, r| Shape::primitive(ShapeKind::Sphere, at(x, r), m);
        let carved = Shape::csg(CsgOp::Diff, vec![ball(4.0, 1.0), ball(3.4, 0.6)], Transform::IDENTITY);
        b.shape(Shape::csg(CsgOp::Intersect, vec![carved, ball(4.0, 0.95)], Transform::IDENTITY));
        common::add_lit_props(&mut b);
        b.camera(Camera { aspect_ratio: 12.0 / 9.0, ..Camera::default() }).renderer(pt(2, 4, true));
        b.build().unwrap()
    };
    let many = {
        let mut b = SceneBuilder::new(12, 9);
        let m = b.diffuse(Color::gray(0.6));
        for i in 0..600 {
            let at = DVec3::new(3.0 + (i / 30) as f64 * 0.1, -1.5 + (i % 30) as f64 * 0.1, 0.0);
            b.sphere(Transform::translation(at) * Transform::scaling(DVec3::splat(0.06)), m);
        }
        b.point_light(PointLight { position: DVec3::new(0.0, 0.0, 3.0), color: Color::gray(9.0), linear_radius: 0.0 });
        b.camera(Camera { aspect_ratio: 12.0 / 9.0, ..Camera::default() }).renderer(pt(2, 3, true));
        b.build().unwrap()
    };
    // Texels, an image environment's sampling tables and a rough metal's energy rows, all
    // in `floats`.
    let textured = {
        let img = common::test_image(8, 6);
        let mut b = SceneBuilder::new(12, 9);
        let pigment = Pigment::Image { image: img.clone(), filter: ImageFilter::Bilinear };
        let wall = b.material(Material::new(Brdf::Diffuse { pigment }, Pigment::Uniform(Color::BLACK)));
        let metal = rough_metal(&mut b);
        b.sphere(Transform::translation(DVec3::new(4.0, 0.8, 0.0)), wall)
            .sphere(Transform::translation(DVec3::new(4.0, -1.2, 0.0)) * Transform::scaling(DVec3::splat(0.8)), metal)
            .camera(Camera { aspect_ratio: 12.0 / 9.0, ..Camera::default() })
            .environment(Environment::Image { image: img, intensity: 0.7, rotation_deg: 30.0 })
            .renderer(pt(2, 4, true));
        b.build().unwrap()
    };
    let mut scenes = mixed_scenes(pt(2, 4, true));
    scenes.extend([csg, many, textured]);
    // Triangle meshes (their triangles and bottom-level BVHs), a mesh light, an image sky,
    // a checkered floor and rough metal and plastic: scenes/meshes.sl in miniature.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    scenes.push(common::thumbnail(&root.join("scenes/meshes.sl"), 12, 8));
    for (k, scene) in scenes.iter().enumerate() {
        let storage = render_with(scene, TablePlacement::Storage);
        assert_eq!(storage.tables, TableForms::NONE);
        let uniform = render_with(scene, TablePlacement::Uniform);
        let placed = uniform.tables;
        let uniform_held = |t| placed.form(t) == TableForm::Uniform;
        assert!(uniform_held(Table::BvhNodes) || k == 7, "scene {k}: {placed:?}");
        assert!(uniform_held(Table::Floats) || k == 7, "scene {k}: {placed:?}");
        assert_eq!(uniform_held(Table::Shapes), k != 5, "scene {k}: {placed:?}");
        assert!(bits(&uniform.image) == bits(&storage.image), "scene {k}: uniform tables change the image");
        // (No texture anywhere where the adapter's texel fetches are not trusted.)
        let texture = render_with(scene, TablePlacement::Texture);
        let textures = lumen::gpu::texel_fetches_trusted(&gpu.adapter_info);
        let asked =
            if textures { TableForms::all(TableForm::Texture) } else { TableForms::NONE.with_hot_textures(true) };
        assert_eq!(texture.tables, asked, "scene {k}");
        assert!(bits(&texture.image) == bits(&storage.image), "scene {k}: table textures change the image");
        // The adapter's own choice: on a software adapter the 600 shapes and the meshes'
        // triangles are textures in the shading stages and storage buffers in the stages
        // that walk the BVH, both bound in one render.
        let auto = render_with(scene, TablePlacement::Auto);
        if gpu.adapter_info.device_type == wgpu::DeviceType::Cpu && textures && (k == 5 || k == 7) {
            let forms = auto.tables;
            assert!(Table::ALL.iter().any(|&t| forms.form(t) == TableForm::Texture), "scene {k}: {forms:?}");
        }
        assert!(bits(&auto.image) == bits(&storage.image), "scene {k}: the adapter's placement changes the image");
    }
}

/// A scene of a handful of plain objects is rendered with its objects tested as a list
/// (`gpu::traversal::prefers_list`); walking its BVH instead must give the same image, bit
/// for bit, with every renderer: both find the same nearest hit with the same arithmetic.
/// A scene beyond the list's size walks the tree, and forcing a list there changes nothing
/// either, the walk's world-space test of round spheres turned off; with it on (lumen's
/// choice there) the image agrees with the list's to rounding.
#[test]
fn a_list_and_a_walk_give_the_same_image() {
    use lumen::gpu::pack::pack;
    use lumen::gpu::render::GpuRenderer;
    let Some(gpu) = gpu_for_tests("a_list_and_a_walk_give_the_same_image") else { return };
    let mut renderer = GpuRenderer::new();
    // A walk over round spheres tests them in the world (FeatureSet::round_spheres), a list
    // in object space: `round` false turns the world-space test off for a like-for-like walk.
    let mut render_with = |scene: &Scene, list: bool, round: bool| {
        let opts = GpuRenderOptions::fixed_passes(Some(4), 4);
        let mut packed = pack(scene, opts.spp).unwrap();
        let chosen = (packed.features.object_list, packed.features.round_spheres);
        packed.features.object_list = list;
        packed.features.round_spheres &= round;
        let out = renderer.render_packed(&gpu, scene, &packed, &opts).unwrap();
        assert_eq!((out.spp_done, out.non_finite_samples), (4, 0));
        (chosen, out.image)
    };
    let spread = {
        let mut b = SceneBuilder::new(12, 9);
        let m = b.diffuse(Color::gray(0.6));
        for i in 0..12 {
            let at = DVec3::new(3.0 + (i / 4) as f64 * 0.7, -1.2 + (i % 4) as f64 * 0.8, 0.0);
            b.sphere(Transform::translation(at) * Transform::scaling(DVec3::splat(0.3)), m);
        }
        b.camera(Camera { aspect_ratio: 12.0 / 9.0, ..Camera::default() })
            .environment(Environment::Uniform(Color::gray(0.8)))
            .renderer(pt(2, 3, true));
        b.build().unwrap()
    };
    let mut scenes: Vec<(Scene, bool)> = [
        pt(2, 4, true),
        Renderer::OnOff { on: Color::WHITE, off: Color::BLACK },
        Renderer::Flat { background: Color::gray(0.2) },
        Renderer::PointLight { background: Color::gray(0.1), ambient: Color::gray(0.05) },
    ]
    .into_iter()
    .map(|r| (mixed_scene(r), true))
    .collect();
    scenes.push((spread, false));
    // CSG trees in a list go on to the CSG stage (path tracer) or are evaluated in place
    // (PointLight) only where the ray crosses their boxes.
    for renderer in [pt(2, 4, true), Renderer::PointLight { background: Color::gray(0.1), ambient: Color::gray(0.05) }]
    {
        let mut b = SceneBuilder::new(12, 9);
        let m = b.diffuse(Color::new(0.7, 0.5, 0.3));
        let at = |x: f64, y: f64, r: f64| {
            Transform::translation(DVec3::new(x, y, 0.0)) * Transform::scaling(DVec3::splat(r))
        };
        let ball = |x, y, r| Shape::primitive(ShapeKind::Sphere, at(x, y, r), m);
        let carved = Shape::csg(CsgOp::Diff, vec![ball(4.0, -0.8, 1.0), ball(3.4, -0.8, 0.6)], Transform::IDENTITY);
        b.shape(Shape::csg(CsgOp::Intersect, vec![carved, ball(4.0, -0.8, 0.95)], Transform::IDENTITY));
        b.shape(Shape::csg(CsgOp::Unite, vec![ball(5.0, 1.2, 0.5), ball(5.3, 1.2, 0.5)], Transform::IDENTITY));
        common::add_lit_props(&mut b);
        b.camera(Camera { aspect_ratio: 12.0 / 9.0, ..Camera::default() }).renderer(renderer);
        scenes.push((b.build().unwrap(), true));
    }
    for (k, (scene, listed)) in scenes.iter().enumerate() {
        let ((chosen, round), list) = render_with(scene, true, false);
        let (_, walk) = render_with(scene, false, false);
        assert_eq!(chosen, *listed, "scene {k}: lumen's choice");
        assert!(bits(&list) == bits(&walk), "scene {k}: a list and a walk give different images");
        // The spread spheres are round: lumen's own walk tests them in the world, which
        // rounds differently, so its image is the list's up to paths that rounding turns.
        assert_eq!(round, !listed, "scene {k}: round spheres");
        if round {
            let (_, world) = render_with(scene, false, true);
            let a = common::agreement(&world, &list);
            println!("scene {k}, walk in the world against the list: {a}");
            a.check(common::Tolerance::share(0.95)).unwrap_or_else(|e| panic!("scene {k}: {e}"));
        }
    }
}

/// `GpuRenderOutput::kernel_seconds` and `kernels_compiled`: a renderer's first render of a
/// scene creates every stage kernel, within the render's wall time; a second render of the
/// same scene finds them all in the renderer's cache and creates none.
#[test]
fn kernel_creation_is_counted_once_per_renderer() {
    use lumen::gpu::render::GpuRenderer;
    let Some(gpu) = gpu_for_tests("kernel_creation_is_counted_once_per_renderer") else { return };
    let scene = mixed_scene(pt(1, 3, true));
    let opts = GpuRenderOptions::fixed_passes(Some(1), 1);
    let mut renderer = GpuRenderer::new();
    let first = renderer.render(&gpu, &scene, &opts).unwrap();
    // One kernel per stage, but the shading stages (here the mirror's, the glass's and the
    // diffuse surfaces') share one (Stage::kernel_kinds).
    use lumen::gpu::{layout::brdf_kind, wavefront::Stage};
    let stages = Stage::for_scene(&first.features);
    let shading = |stages: &[Stage]| stages.iter().filter(|s| matches!(s, Stage::Shade(_))).count();
    assert!([brdf_kind::SPECULAR, brdf_kind::DIELECTRIC].iter().all(|&k| stages.contains(&Stage::Shade(k))));
    assert!(shading(&stages) >= 2);
    assert_eq!(first.kernels_compiled, stages.len() - shading(&stages) + 1);
    assert!(
        first.kernel_seconds > 0.0 && first.kernel_seconds <= first.seconds,
        "{} of {} s",
        first.kernel_seconds,
        first.seconds
    );
    let second = renderer.render(&gpu, &scene, &opts).unwrap();
    assert_eq!(second.kernels_compiled, 0);
    assert!(second.kernel_seconds < first.kernel_seconds);
    assert!(bits(&first.image) == bits(&second.image));
    // With a rough metal beside the diffuse surfaces and the props' mirror and glass, four
    // kinds share the one shading kernel, created once.
    let mut b = SceneBuilder::new(12, 9);
    let white = b.diffuse(Color::gray(0.7));
    let metal = rough_metal(&mut b);
    b.plane(Transform::translation(DVec3::new(0.0, 0.0, -1.0)), white);
    b.sphere(Transform::translation(DVec3::new(2.0, 0.5, 0.0)) * Transform::scaling(DVec3::splat(0.5)), metal);
    common::add_lit_props(&mut b);
    b.camera(Camera { aspect_ratio: 12.0 / 9.0, ..Camera::default() }).renderer(pt(1, 3, true));
    let metal_scene = b.build().unwrap();
    let shared = GpuRenderer::new().render(&gpu, &metal_scene, &opts).unwrap();
    let stages = Stage::for_scene(&shared.features);
    assert!(stages.contains(&Stage::Shade(brdf_kind::CONDUCTOR)) && shading(&stages) == 4);
    assert_eq!(shared.kernels_compiled, stages.len() - 3);
}
