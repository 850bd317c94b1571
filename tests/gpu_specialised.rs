//! Specialisation does not change the image: every example scene rendered by its own
//! (specialised) kernel and by the full-featured kernel of its renderer
//! (`FeatureSet::full_for`, through `GpuRenderOptions::features`) gives the same pixels, and a
//! kernel override that lacks a feature the scene needs is refused. Skips without a GPU
//! adapter (fails instead with LUMEN_REQUIRE_GPU=1).

mod common;

use lumen::color::Color;
use lumen::gpu::features::{EnvKind, FeatureSet};
use lumen::gpu::gpu_for_tests;
use lumen::gpu::render::{render, GpuRenderOptions, GpuRenderOutput, GpuRenderer};
use lumen::gpu::Gpu;
use lumen::scene::{CsgOp, Environment, Renderer, Scene, SceneBuilder, Shape, ShapeKind, Transform};

fn example_scenes() -> Vec<(String, Scene)> {
    common::example_scene_files()
        .into_iter()
        .map(|path| (path.file_name().unwrap().to_string_lossy().into_owned(), common::thumbnail(&path, 16, 24)))
        .collect()
}

/// The scene, plus variants that reach the run-time switches a full kernel must obey: the
/// path tracer without NEE (NEE code compiled in, `settings.nee` = 0) and the first-hit
/// renderers absent from scenes/ (Flat, OnOff), on a few scenes that cover the area lights,
/// the environment light, image textures and CSG (every variant costs two kernel compiles,
/// minutes on a software adapter).
fn variants(name: &str, scene: &Scene) -> Vec<(String, Scene)> {
    let mut out = vec![(name.to_string(), scene.clone())];
    if let Renderer::PathTracer(p) = &scene.renderer {
        if ["cornell.sl", "skybox.sl", "csg.sl"].contains(&name) {
            let mut s = scene.clone();
            s.renderer = Renderer::PathTracer(lumen::scene::PathTracerSettings { nee: false, ..p.clone() });
            out.push((format!("{name} without NEE"), s));
        }
    }
    if ["skybox.sl", "csg.sl"].contains(&name) {
        for r in
            [Renderer::Flat { background: Color::gray(0.2) }, Renderer::OnOff { on: Color::WHITE, off: Color::BLACK }]
        {
            let mut s = scene.clone();
            s.renderer = r;
            out.push((format!("{name} {}", s.renderer.name()), s));
        }
    }
    out
}

/// Fixed passes of 2 samples: the f32 pass sums, and so the images, are reproducible. One
/// renderer (kernel cache) for all: each full kernel is compiled once per renderer kind.
fn run(gpu: &Gpu, r: &mut GpuRenderer, scene: &Scene, kernel: Option<FeatureSet>) -> GpuRenderOutput {
    let opts = GpuRenderOptions { features: kernel, ..GpuRenderOptions::fixed_passes(Some(2), 2) };
    r.render(gpu, scene, &opts).unwrap_or_else(|e| panic!("{e}"))
}

/// Bitwise equal images, no tolerance. Both kernels run the same WGSL functions on the same
/// inputs with the same random draws; the full kernel only adds branches that the scene's
/// run-time kinds, counts and `settings.nee` never take. (A driver that optimised float
/// arithmetic differently in the larger kernel, e.g. contracting other multiply-adds, could
/// break bitwise equality; lavapipe does not, and a difference here would first have to be
/// shown to be such rounding before a tolerance is added.)
#[test]
fn specialised_and_full_featured_kernels_give_the_same_image() {
    let Some(gpu) = gpu_for_tests("specialised_and_full_featured_kernels_give_the_same_image") else { return };
    let mut renderer = GpuRenderer::new();
    let mut checked = 0;
    for (file, scene) in example_scenes() {
        for (name, scene) in variants(&file, &scene) {
            let spec = FeatureSet::of(&scene);
            let full = spec.full_for();
            assert!(full.covers(&spec) && full != spec, "{name}");
            let a = run(&gpu, &mut renderer, &scene, None);
            let b = run(&gpu, &mut renderer, &scene, Some(full));
            // The kernels also hold the packed scene's unrolled lists (FeatureSet::listed).
            let lists = lumen::gpu::pack::pack(&scene, None).unwrap().features;
            assert_eq!((a.features, b.features), (spec.with_lists_of(&lists), full.with_lists_of(&lists)), "{name}");
            assert_eq!((a.spp_done, b.spp_done), (2, 2), "{name}");
            assert_eq!(a.non_finite_samples, b.non_finite_samples, "{name}");
            let (w, h) = (scene.width as usize, scene.height as usize);
            let differing: Vec<String> = (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let (p, q) = (a.image.get(x, y), b.image.get(x, y));
                    [p.r, p.g, p.b].map(f32::to_bits) != [q.r, q.g, q.b].map(f32::to_bits)
                })
                .map(|(x, y)| format!("({x}, {y}): {:?} vs {:?}", a.image.get(x, y), b.image.get(x, y)))
                .collect();
            println!("{name}: {} of {} pixels differ", differing.len(), w * h);
            assert!(differing.is_empty(), "{name}: {} pixels differ: {:?}", differing.len(), &differing[..1]);
            // The image is not trivially black (the comparison would prove nothing).
            assert!(a.image.pixels().iter().any(|p| p.r + p.g + p.b > 0.0), "{name}: black image");
            checked += 1;
        }
    }
    assert!(checked >= 15, "{checked}");
    // Four renderer kinds and two CSG deferral modes at most; far fewer than the renders.
    println!("{} kernels compiled for {checked} scenes", renderer.kernels_compiled());
}

/// A kernel that lacks a shape, the renderer or the environment the scene needs is refused
/// with an error that names what is missing; the scene's own features and a covering
/// superset are accepted.
#[test]
fn a_kernel_override_that_does_not_cover_the_scene_is_refused() {
    let Some(gpu) = gpu_for_tests("a_kernel_override_that_does_not_cover_the_scene_is_refused") else { return };
    let mut b = SceneBuilder::new(6, 4);
    let m = b.diffuse(Color::gray(0.5));
    let sphere = |x: f64| Shape::primitive(ShapeKind::Sphere, Transform::translation(glam::DVec3::new(x, 0.0, 0.0)), m);
    b.sphere(Transform::translation(glam::DVec3::new(4.0, 1.0, 0.0)), m).environment(Environment::Gradient {
        zenith: Color::WHITE,
        horizon: Color::gray(0.5),
        nadir: Color::BLACK,
    });
    let spheres = b.build().unwrap();
    let spheres_only = FeatureSet::of(&spheres);
    b.shape(Shape::csg(CsgOp::Diff, vec![sphere(4.0), sphere(3.5)], Transform::IDENTITY));
    let with_csg = b.build().unwrap();

    let refused = |scene: &Scene, kernel: FeatureSet, what: &str| {
        let opts = GpuRenderOptions { features: Some(kernel), ..GpuRenderOptions::fixed_passes(Some(1), 1) };
        let err = render(&gpu, scene, &opts).expect_err(what).to_string();
        assert!(err.contains("does not cover") && err.contains(what), "{what}: {err}");
    };
    refused(&with_csg, spheres_only, "feature CSG");
    let mut uniform_sky = spheres_only;
    uniform_sky.environment = EnvKind::Uniform;
    refused(&spheres, uniform_sky, "environment Gradient");
    let mut flat = FeatureSet::of(&spheres).full_for();
    flat.renderer = lumen::gpu::features::RendererKind::Flat;
    refused(&spheres, flat, "renderer PathTracer");
    let mut small_csg = FeatureSet::of(&with_csg);
    small_csg.csg_max_leaves = 1;
    refused(&with_csg, small_csg, "CSG bounds");

    for (scene, kernel) in [(&spheres, spheres_only), (&with_csg, spheres_only.full_for())] {
        let opts = GpuRenderOptions { features: Some(kernel), ..GpuRenderOptions::fixed_passes(Some(1), 1) };
        let lists = lumen::gpu::pack::pack(scene, None).unwrap().features;
        assert_eq!(render(&gpu, scene, &opts).unwrap().features, kernel.with_lists_of(&lists));
    }
}
