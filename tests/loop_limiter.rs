//! Resumable, path-granular passes for drivers with a loop limiter (docs/DESIGN.md, "Loop
//! limiter and path-granular passes"): resumed passes sum bit for bit what undivided ones
//! do, paths that the limiter cuts are re-run on a fresh limiter, and a path that is cut
//! even alone is counted, never silently wrong.

mod common;

use common::emissive;
use glam::DVec3;
use lumen::color::Color;
use lumen::cpu::{Progress, RenderOptions};
use lumen::gpu::render::{render, GpuRenderOptions, GpuRenderOutput};
use lumen::gpu::{gpu_for_tests, probe_loop_limiter, Gpu, LOOP_LIMITER_PROBE_TRIPS};
use lumen::scene::*;

fn pt(n: u32, max_depth: u32, nee: bool) -> Renderer {
    Renderer::PathTracer(PathTracerSettings { n, max_depth, roulette_depth: 1000, nee, ..Default::default() })
}

/// The camera inside `shells` concentric emitting spheres (ρ 0.5, Le 1, radii 1 to 1.1):
/// every path bounces inside the innermost one and is worth exactly Σ_(k≤depth) 0.5ᵏ, while
/// every traversal visits all the spheres (each bounding box holds the ray's origin), so
/// the loop iterations per path grow with `shells × depth`.
fn shells(shells: usize, n: u32, depth: u32) -> Scene {
    let mut b = SceneBuilder::new(2, 2);
    let m = emissive(&mut b, 0.5, 1.0);
    for k in 0..shells {
        b.sphere(Transform::scaling(DVec3::splat(10.0 + k as f64 / shells as f64)), m);
    }
    b.renderer(pt(n, depth, false));
    b.build().unwrap()
}

fn gpu_render(gpu: &Gpu, scene: &Scene, spp: u32, budget: u32) -> GpuRenderOutput {
    let mut opts = GpuRenderOptions::fixed_passes(Some(spp), 4);
    opts.passes.path_budget = budget;
    let out = render(gpu, scene, &opts).unwrap();
    assert_eq!(out.non_finite_samples, 0);
    assert_eq!(out.spp_done, spp);
    out
}

/// Whether this device's driver has a loop limiter (the probe stops short).
fn driver_has_limiter(gpu: &Gpu) -> bool {
    probe_loop_limiter(gpu).unwrap() < LOOP_LIMITER_PROBE_TRIPS
}

fn bits(img: &lumen::image::HdrImage) -> Vec<[u32; 3]> {
    img.pixels().iter().map(|p| [p.r.to_bits(), p.g.to_bits(), p.b.to_bits()]).collect()
}

/// Share of pixels whose channels agree within 1e-3 relative or 1e-4 absolute.
fn agreement(a: &lumen::image::HdrImage, b: &lumen::image::HdrImage) -> f64 {
    let close = |x: f32, y: f32| (x - y).abs() <= 1e-4 || (x - y).abs() <= 1e-3 * x.abs().max(y.abs());
    let good = a.pixels().iter().zip(b.pixels()).filter(|(p, q)| close(p.r, q.r) && close(p.g, q.g) && close(p.b, q.b));
    good.count() as f64 / a.pixels().len() as f64
}

/// Diffuse, glass and mirror surfaces, an emitting sphere and cube (NEE), a point light
/// and a plane: every kind of loop the kernel has.
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

/// The resumable kernel, stopped after every path (budget 1) or every 3 paths, sums bit
/// for bit what it sums undivided, and what the plain kernel sums (same additions in the
/// same order), for every renderer; and it matches the CPU reference.
#[test]
fn resumed_passes_sum_bit_for_bit_like_undivided_ones() {
    let Some(mut gpu) = gpu_for_tests("resumed_passes_sum_bit_for_bit") else { return };
    for renderer in [
        pt(3, 5, true),
        pt(2, 4, false),
        Renderer::OnOff { on: Color::WHITE, off: Color::gray(0.2) },
        Renderer::Flat { background: Color::BLACK },
        Renderer::PointLight { background: Color::BLACK, ambient: Color::gray(0.01) },
    ] {
        let scene = mixed_scene(renderer);
        let n = match &scene.renderer {
            Renderer::PathTracer(p) => u64::from(p.n),
            _ => 1,
        };
        gpu.loop_limiter = false;
        let plain = gpu_render(&gpu, &scene, 4, 0);
        assert_eq!(plain.dispatches, 1);
        gpu.loop_limiter = true;
        let whole = gpu_render(&gpu, &scene, 4, 0);
        let by_one = gpu_render(&gpu, &scene, 4, 1);
        let by_three = gpu_render(&gpu, &scene, 4, 3);
        // One pass of 4 samples × n paths: one dispatch per path, or per 3 paths.
        assert_eq!(by_one.dispatches, 4 * n, "{}", scene.renderer.name());
        assert_eq!(by_three.dispatches, (4 * n).div_ceil(3), "{}", scene.renderer.name());
        for out in [&whole, &by_one, &by_three] {
            assert_eq!(out.loop_limited_paths, 0);
            assert!(bits(&out.image) == bits(&plain.image), "{}: resumed sums differ", scene.renderer.name());
        }
        let cpu = lumen::cpu::render(&scene, &RenderOptions { spp: Some(4) }, Progress::Hidden);
        let agree = agreement(&by_one.image, &cpu.image);
        assert!(agree >= 0.99, "{}: {:.1}% of pixels agree with the CPU", scene.renderer.name(), agree * 100.0);
    }
}

/// Paths that fit the limiter alone but not together: each dispatch sums the paths that
/// ran before the limiter fired, and the next resumes at the one it cut. Every path is
/// exactly Σ_(k≤30) 0.5ᵏ; the plain kernel loses paths where the driver has a limiter.
#[test]
fn paths_cut_in_company_are_rerun_and_exact() {
    let Some(mut gpu) = gpu_for_tests("paths_cut_in_company") else { return };
    let scene = shells(600, 4, 30);
    let expected = 2.0 * (1.0 - 0.5f64.powi(31));
    gpu.loop_limiter = true;
    let out = gpu_render(&gpu, &scene, 1, 0);
    assert_eq!(out.loop_limited_paths, 0);
    for p in out.image.pixels() {
        assert!((f64::from(p.g) / expected - 1.0).abs() < 2e-6, "{p:?}");
    }
    let cpu = lumen::cpu::render(&scene, &RenderOptions { spp: Some(1) }, Progress::Hidden);
    assert_eq!(agreement(&out.image, &cpu.image), 1.0);
    if driver_has_limiter(&gpu) {
        // ~40,000 loop iterations per path here: one path per dispatch.
        assert!(out.dispatches > 1, "{} dispatches", out.dispatches);
        gpu.loop_limiter = false;
        let plain = gpu_render(&gpu, &scene, 1, 0);
        assert!(plain.image.pixels().iter().all(|p| f64::from(p.g) < 0.9 * expected), "the plain kernel was not cut");
    }
}

/// A path longer than the limiter allows (1,000 shells × 60 bounces, > 65,535 loop
/// iterations) is cut even when run alone: it is dropped (counted as 0) and counted, so
/// `lumen render` can warn. Without a limiter every path is exact.
#[test]
fn a_path_cut_even_alone_is_counted() {
    let Some(mut gpu) = gpu_for_tests("a_path_cut_even_alone") else { return };
    let scene = shells(1000, 2, 60);
    gpu.loop_limiter = true;
    let out = gpu_render(&gpu, &scene, 1, 0);
    if driver_has_limiter(&gpu) {
        assert_eq!(out.loop_limited_paths, 2 * 2 * 2, "4 pixels × 1 sample × 2 paths");
        assert!(out.image.pixels().iter().all(|p| p.g == 0.0));
        // Per path index: the dispatch that cut it in every pixel, then a solo dispatch per
        // pixel; then one that finds every pixel done.
        assert_eq!(out.dispatches, 2 * (1 + 4) + 1);
    } else {
        assert_eq!(out.loop_limited_paths, 0);
        let expected = 2.0 * (1.0 - 0.5f64.powi(61));
        assert!(out.image.pixels().iter().all(|p| (f64::from(p.g) / expected - 1.0).abs() < 2e-6));
    }
}

/// The stability suite's case (docs/STABILITY.md): inside an emitting cube, 256 paths of
/// depth 50 per camera sample, every path exactly Σ_(k≤50) 0.5ᵏ. With a limiter the pass
/// is resumed (the plain kernel summed only the first 129 paths on lavapipe).
#[test]
fn the_256_path_furnace_is_resumed_where_the_driver_has_a_limiter() {
    let Some(mut gpu) = gpu_for_tests("the_256_path_furnace") else { return };
    gpu.loop_limiter = true;
    let mut b = SceneBuilder::new(4, 4);
    let m = emissive(&mut b, 0.5, 1.0);
    b.cube(Transform::scaling(DVec3::splat(5.0)), m).renderer(pt(256, 50, false));
    let scene = b.build().unwrap();
    let out = gpu_render(&gpu, &scene, 1, 0);
    println!("{} dispatches for 1 pass", out.dispatches);
    let expected = 2.0 * (1.0 - 0.5f64.powi(51));
    assert!(out.image.pixels().iter().all(|p| (f64::from(p.g) / expected - 1.0).abs() < 2e-6));
    assert_eq!(out.loop_limited_paths, 0);
    assert_eq!(driver_has_limiter(&gpu), out.dispatches > 1, "resumed exactly when the driver has a limiter");
}

/// `lumen render` says how many paths the limiter cut even alone (here all 2×2 pixels × 2
/// paths of the camera inside 1,000 concentric emitting spheres at depth 60).
#[test]
fn lumen_render_warns_about_paths_cut_even_alone() {
    let Some(gpu) = gpu_for_tests("lumen_render_warns") else { return };
    if !driver_has_limiter(&gpu) {
        println!("skipped lumen_render_warns: {} has no loop limiter", gpu.description());
        return;
    }
    let mut script = String::from(
        "SET\n    m Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.5, 0.5, 0.5>)), \
         .emitted_radiance Pigment.Uniform(<1, 1, 1>))\nSPAWN\n",
    );
    for k in 0..1000 {
        script += &format!("    Shape.Sphere(.material m, .transformation SCALE {})\n", 10.0 + f64::from(k) / 1000.0);
    }
    script += "USING\n    Camera.Perspective()\n    Image(2, 2)\n    \
               Renderer.PathTracer(.n 2, .max_depth 60, .roulette_depth 1000)\n    Tracer(.samples_per_side 1)\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("shells.sl");
    std::fs::write(&path, script).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lumen"))
        .args(["render", "--device", "gpu", "-o"])
        .arg(dir.path().join("shells.pfm"))
        .arg(&path)
        .env("LUMEN_LOOP_LIMITER", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("warning: 8 paths ran longer than this driver's loop limiter allows"), "{stderr}");
}

/// Ctrl-C (the cancel flag) is honoured between the dispatches of a resumed pass: the
/// unfinished round is dropped, as between passes.
#[test]
fn cancel_stops_a_resumed_pass_between_dispatches() {
    let Some(mut gpu) = gpu_for_tests("cancel_between_dispatches") else { return };
    gpu.loop_limiter = true;
    let scene = mixed_scene(pt(3, 5, true));
    let mut opts = GpuRenderOptions::fixed_passes(Some(4), 4);
    opts.passes.path_budget = 1;
    opts.passes.cancel = Some(std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true)));
    let out = render(&gpu, &scene, &opts).unwrap();
    assert_eq!(out.stop, lumen::gpu::StopReason::Interrupted);
    assert_eq!((out.spp_done, out.dispatches), (0, 1));
    assert!(out.image.pixels().iter().all(|p| p.r == 0.0 && p.g == 0.0 && p.b == 0.0));
}
