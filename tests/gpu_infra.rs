//! GPU infrastructure tests: device, compute runner, error capture. Every test skips
//! without an adapter unless LUMEN_REQUIRE_GPU=1 (see `lumen::gpu::gpu_for_tests`).

mod common;

use bytemuck::{Pod, Zeroable};
use lumen::gpu::{gpu_for_tests, gpu_required, GpuError};

const SMOKE: &str = include_str!("../shaders/smoke.wgsl");

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SmokeParams {
    count: u32,
    scale: f32,
}

#[test]
fn smoke_shader_matches_rust() {
    let Some(gpu) = gpu_for_tests("smoke_shader_matches_rust") else { return };
    // Not a multiple of the workgroup size, so the bounds check is exercised too.
    let n = 1000usize;
    let kernel = gpu.compute_kernel("smoke.wgsl", SMOKE, "main").unwrap();
    assert_eq!(kernel.workgroup_size, [64, 1, 1]);
    let params = gpu.uniform_buffer("params", &SmokeParams { count: n as u32, scale: 0.25 }).unwrap();
    let input: Vec<f32> = (0..n).map(|i| (i % 7) as f32 - 3.0).collect();
    let input_buf = gpu.storage_buffer("input", &input).unwrap();
    // One sentinel element past `count` must stay untouched.
    let out_u = gpu.storage_buffer("out_u", &vec![0xdead_beef_u32; n + 1]).unwrap();
    let out_f = gpu.storage_buffer("out_f", &vec![-7.0f32; n + 1]).unwrap();
    let group = kernel.bind_group(&gpu, 0, &[&params, &input_buf, &out_u, &out_f]).unwrap();
    gpu.dispatch(&kernel, &[&group], kernel.workgroups_for([n as u32, 1, 1])).unwrap();

    let got_u: Vec<u32> = gpu.read_buffer(&out_u, n + 1).unwrap();
    let got_f: Vec<f32> = gpu.read_buffer(&out_f, n + 1).unwrap();
    for i in 0..n {
        let iu = i as u32;
        assert_eq!(got_u[i], iu.wrapping_mul(iu) ^ 0x5bd1_e995, "u32 at {i}");
        assert_eq!(got_f[i], i as f32 * 0.25 + input[i], "f32 at {i}");
    }
    assert_eq!(got_u[n], 0xdead_beef);
    assert_eq!(got_f[n], -7.0);
    // Wrapping really happened for large i (65536² overflows u32).
    assert!(n * n > u16::MAX as usize);
}

#[test]
fn adapter_is_reported_and_opened_with_its_own_limits() {
    let Some(gpu) = gpu_for_tests("adapter_is_reported_and_opened_with_its_own_limits") else { return };
    assert!(!gpu.adapter_info.name.is_empty());
    assert!(lumen::gpu::list_adapters().iter().any(|a| a.name == gpu.adapter_info.name));
    // The device got the adapter's limits, which are never below WebGPU's defaults.
    assert_eq!(gpu.device.limits().max_storage_buffer_binding_size, gpu.limits.max_storage_buffer_binding_size);
    assert!(gpu.limits.max_storage_buffer_binding_size >= wgpu::Limits::default().max_storage_buffer_binding_size);
}

#[test]
fn shader_errors_are_values_with_locations() {
    let Some(gpu) = gpu_for_tests("shader_errors_are_values_with_locations") else { return };
    let src = "@compute @workgroup_size(1)\nfn main() {\n    let x: u32 = 1.5;\n}\n";
    let err = gpu.compute_kernel("bad.wgsl", src, "main").unwrap_err();
    assert!(matches!(err, GpuError::Shader { .. }), "{err}");
    assert!(err.to_string().contains("bad.wgsl:3"), "{err}");
    let err = gpu.compute_kernel("smoke.wgsl", SMOKE, "nope").unwrap_err();
    assert!(matches!(err, GpuError::NoEntryPoint { .. }), "{err}");
}

#[test]
fn wgpu_validation_errors_become_gpu_errors_not_panics() {
    let Some(gpu) = gpu_for_tests("wgpu_validation_errors_become_gpu_errors_not_panics") else { return };
    let kernel = gpu.compute_kernel("smoke.wgsl", SMOKE, "main").unwrap();
    let a = gpu.storage_buffer("a", &[0u32; 4]).unwrap();
    // Wrong count of buffers: caught by the runner itself.
    assert!(matches!(kernel.bind_group(&gpu, 0, &[&a]), Err(GpuError::Validation(_))));
    // A storage buffer where the layout wants a uniform: caught by wgpu, returned as a value.
    let err = kernel.bind_group(&gpu, 0, &[&a, &a, &a, &a]).unwrap_err();
    assert!(matches!(err, GpuError::Validation(_)), "{err}");
    // The device still works afterwards.
    gpu.check().unwrap();
    let params = gpu.uniform_buffer("params", &SmokeParams { count: 1, scale: 1.0 }).unwrap();
    let group = kernel.bind_group(&gpu, 0, &[&params, &a, &a, &a]);
    // Same buffer bound as read-only and read-write in one dispatch is a usage conflict.
    let dispatched = group.and_then(|g| gpu.dispatch(&kernel, &[&g], [1, 1, 1]));
    assert!(matches!(dispatched, Err(GpuError::Validation(_))), "{dispatched:?}");
}

#[test]
fn oversized_buffers_are_refused_with_the_limit() {
    let Some(gpu) = gpu_for_tests("oversized_buffers_are_refused_with_the_limit") else { return };
    let too_big = gpu.limits.max_storage_buffer_binding_size + 4;
    let err = gpu.storage_buffer_zeroed("huge", too_big).unwrap_err();
    assert!(matches!(err, GpuError::TooLarge { .. }), "{err}");
    assert!(err.to_string().contains("huge"));
    // A table texture one row too tall: its size and the texture's, in bytes.
    let rows = u64::from(gpu.limits.max_texture_dimension_2d);
    let err = gpu.u32_texture("tall", &vec![0u8; 32 * (rows as usize + 1)], 2).unwrap_err();
    let sizes = match &err {
        GpuError::TooLarge { needed, limit, .. } => (*needed, *limit),
        _ => panic!("{err}"),
    };
    assert_eq!(sizes, (32 * (rows + 1), 32 * rows), "{err}");
    assert!(err.to_string().ends_with(&format!("at most {} bytes per 2D texture", 32 * rows)), "{err}");
}

/// A mesh whose normals and uvs outgrow a storage binding still renders on a software
/// adapter: the path tracer's shading stages read them from a texture, which holds more,
/// so the packer checks only the triangles' vertices, which the BVH walks read.
#[test]
fn a_mesh_whose_shading_table_outgrows_a_storage_binding_renders_from_a_texture() {
    use glam::DVec3;
    use lumen::scene::mesh::{MeshParts, TriangleMesh};
    use lumen::scene::{Renderer, SceneBuilder, Shape, Transform};
    let Some(gpu) = gpu_for_tests("a_mesh_whose_shading_table_outgrows_a_storage_binding_renders_from_a_texture")
    else {
        return;
    };
    let limit = gpu.storage_limit().0;
    // Five vec4 of normals and uvs per triangle (80 bytes) past the limit, three of
    // vertices (48 bytes) within it.
    let triangles = (limit / 80 + 1) as usize;
    if gpu.adapter_info.device_type != wgpu::DeviceType::Cpu || triangles > 4 << 20 {
        println!("skipped: not a software adapter with a small binding ({limit} bytes)");
        return;
    }
    // A strip of thin triangles across the view, one above the next.
    let mut parts = MeshParts::default();
    for k in 0..=triangles {
        let z = -0.5 + k as f64 / triangles as f64;
        parts.positions.extend([DVec3::new(0.0, -0.5, z), DVec3::new(0.0, 0.5, z)]);
    }
    for k in 0..triangles as u32 {
        let (a, b) = (2 * (k / 2), 2 * (k / 2) + 1);
        parts.triangles.push(if k % 2 == 0 { [a, b, a + 2] } else { [b, b + 2, a + 2] });
    }
    let mesh = std::sync::Arc::new(TriangleMesh::from_parts("strip", parts).unwrap());
    let mut b = SceneBuilder::new(8, 8);
    let lamp = common::emissive(&mut b, 0.5, 1.0);
    b.shape(Shape::mesh(mesh, "strip", Transform::translation(DVec3::new(2.0, 0.0, 0.0)), lamp, false));
    b.renderer(Renderer::PathTracer(lumen::scene::PathTracerSettings { max_depth: 1, ..Default::default() }));
    let out = lumen::gpu::render::render(&gpu, &b.build().unwrap(), &Default::default()).unwrap();
    use lumen::gpu::tables::{Table, TableForm};
    assert_eq!(out.tables.form(Table::TriShading), TableForm::Texture);
    // The strip covers the middle of the view: an emitter of radiance 1.
    assert_eq!(out.image.get(4, 4).g, 1.0, "{:?}", out.image.get(4, 4));
}

/// A scene whose sky outgrows what one binding holds is refused by the packer at the texels,
/// before their conversion and the sampling tables (10 s and 6 GB for a 16384×8192 sky on
/// lavapipe, which binds 128 MiB, when it was refused at the upload instead).
#[test]
fn a_table_beyond_the_adapters_binding_is_refused_before_it_is_packed() {
    use lumen::scene::{Environment, SceneBuilder, Transform};
    let Some(gpu) = gpu_for_tests("a_table_beyond_the_adapters_binding_is_refused_before_it_is_packed") else {
        return;
    };
    let limit = gpu.storage_limit().0;
    // Just over the limit in texels (3 f32 each).
    let pixels = limit / 12 + 1;
    if pixels > 1 << 26 {
        println!("skipped: this adapter binds {limit} bytes; a sky beyond it is too large for a test");
        return;
    }
    let width = 4096;
    let height = pixels.div_ceil(width) as usize;
    let mut b = SceneBuilder::new(4, 4);
    let m = b.diffuse(lumen::color::Color::gray(0.5));
    let image = std::sync::Arc::new(lumen::image::HdrImage::new(width as usize, height));
    b.sphere(Transform::IDENTITY, m).environment(Environment::Image { image, intensity: 1.0, rotation_deg: 0.0 });
    let err = lumen::gpu::render::render(&gpu, &b.build().unwrap(), &Default::default()).unwrap_err();
    let texels = 12 * width * height as u64;
    match &err {
        GpuError::TooLarge { what, needed, limit: l, .. } => {
            let floats = "the floats table (image texels and sampling tables)";
            assert_eq!((what.as_str(), *needed, *l), (floats, texels, limit), "{err}");
        }
        _ => panic!("expected the floats table to be refused, got {err}"),
    }
}

/// A camera sample's paths are summed within one batch (the film adds a pixel's paths in
/// f32), so a batch must hold them all. A scene whose per-path state leaves fewer slots
/// (point lights: a shadow ray each per path vertex) is refused with what takes the room and
/// the limit; one that just fits renders, though the launch bound
/// (`wavefront::bounded_by_launch_rays`) alone would leave fewer slots than the sample's
/// paths (a "validation error" with --device gpu, a fallback to the CPU with auto, before).
#[test]
fn a_camera_samples_paths_that_cannot_share_a_batch_are_refused_with_the_reason() {
    use glam::DVec3;
    use lumen::gpu::wavefront::MAX_PATHS_PER_PIXEL_PER_ROUND;
    use lumen::scene::{PathTracerSettings, PointLight, Renderer, Scene, SceneBuilder, Transform};
    let name = "a_camera_samples_paths_that_cannot_share_a_batch_are_refused_with_the_reason";
    let Some(gpu) = gpu_for_tests(name) else { return };
    let limit = gpu.storage_limit().0;
    let n = MAX_PATHS_PER_PIXEL_PER_ROUND;
    // Shadow rays (48 bytes each) a slot may hold when n slots share the binding.
    let room = limit / (48 * u64::from(n));
    if !(2..=20_000).contains(&room) {
        println!("skipped: this adapter binds {limit} bytes; {room} shadow rays per path is not a test-sized scene");
        return;
    }
    // One pixel, one camera sample of `paths` paths, a grey plane under `lights` point lights;
    // with NEE a vertex queues a shadow ray per light and one for light sampling.
    let scene = |paths: u32, lights: u64| -> Scene {
        let mut b = SceneBuilder::new(1, 1);
        let grey = b.diffuse(lumen::color::Color::gray(0.5));
        b.plane(Transform::translation(DVec3::new(0.0, 0.0, -1.0)), grey);
        for i in 0..lights {
            let x = (i % 100) as f64 * 0.1;
            b.point_light(PointLight {
                position: DVec3::new(x, 0.0, 2.0),
                color: lumen::color::Color::gray(1e-3),
                linear_radius: 0.0,
            });
        }
        let pt = PathTracerSettings { n: paths, max_depth: 1, ..Default::default() };
        b.renderer(Renderer::PathTracer(pt))
            .camera(lumen::scene::Camera { transform: Transform::rotation_y(60.0), ..Default::default() });
        b.build().unwrap()
    };
    let opts = Default::default();
    // One light too many: room + 1 shadow rays per path.
    let err = lumen::gpu::render::render(&gpu, &scene(n, room), &opts).unwrap_err();
    match &err {
        GpuError::SampleExceedsBatch { paths, reason } => {
            assert_eq!(*paths, n, "{err}");
            let bytes = 48 * (room + 1);
            for part in [format!("{bytes} bytes"), format!("{} shadow rays", room + 1), format!("({limit} bytes)")] {
                assert!(reason.contains(&part), "{part:?} missing from: {err}");
            }
        }
        _ => panic!("expected the sample's paths to be refused, got {err}"),
    }
    // Exactly room: every path of the sample in one batch, each pixel value finite.
    let out = lumen::gpu::render::render(&gpu, &scene(n, room - 1), &opts).unwrap();
    let c = out.image.get(0, 0);
    assert!(c.r.is_finite() && c.r > 0.0, "{c:?}");
    // More paths than the film sums per pixel in a batch, whatever the memory.
    let err = lumen::gpu::render::render(&gpu, &scene(n + 1, 0), &opts).unwrap_err();
    assert!(
        matches!(&err, GpuError::SampleExceedsBatch { paths, reason } if *paths == n + 1 && reason.contains(&n.to_string())),
        "{err}"
    );
}

// ---- shader assembly ----------------------------------------------------------------

use lumen::gpu::{FeatureNames, KernelCache, ShaderLibrary};

#[test]
fn assembled_kernels_run_and_are_cached_by_source() {
    let Some(gpu) = gpu_for_tests("assembled_kernels_run_and_are_cached_by_source") else { return };
    let mut lib = ShaderLibrary::new(&["bright", "unused"]);
    lib.add(
        "value.wgsl",
        "fn sample_value(j: u32) -> f32 {\n// #if bright\n    return 2.0 + f32(j & 1u);\n// #else\n    return 1.0;\n// #endif\n}",
    )
    .unwrap();
    lib.add(
        "main.wgsl",
        "// #requires value\n\
         @group(0) @binding(0) var<storage, read_write> out: array<f32>;\n\
         @compute @workgroup_size(8)\n\
         fn main(@builtin(global_invocation_id) gid: vec3<u32>) {\n\
             if (gid.x < arrayLength(&out)) { out[gid.x] = sample_value(gid.x); }\n\
         }",
    )
    .unwrap();
    let mut cache = KernelCache::new();
    let plain = FeatureNames::new();
    let bright = FeatureNames::new().with("bright");
    // Values alternate 2, 3 with `bright`.
    for (features, want) in
        [(&plain, [1.0f32, 1.0]), (&bright, [2.0, 3.0]), (&plain, [1.0, 1.0]), (&bright, [2.0, 3.0])]
    {
        let source = lib.assemble(&["main"], features).unwrap().source;
        let kernel = cache.get_or_build(&source, "main", || gpu.compute_kernel("main.wgsl", &source, "main")).unwrap();
        let buffer = gpu.storage_buffer("out", &[0f32; 16]).unwrap();
        let group = kernel.bind_group(&gpu, 0, &[&buffer]).unwrap();
        gpu.dispatch(&kernel, &[&group], [2, 1, 1]).unwrap();
        let values = gpu.read_buffer::<f32>(&buffer, 16).unwrap();
        assert!(values.chunks(2).all(|c| c == want), "{features}: {values:?}");
    }
    assert_eq!(cache.len(), 2);
}

#[test]
fn a_lost_device_is_an_error_not_a_panic() {
    let Some(gpu) = gpu_for_tests("a_lost_device_is_an_error_not_a_panic") else { return };
    let kernel = gpu.compute_kernel("smoke.wgsl", SMOKE, "main").unwrap();
    let data = gpu.storage_buffer("data", &[1u32; 8]).unwrap();
    // Destroying the device is the one portable way to lose it on purpose.
    gpu.device.destroy();
    let err = gpu.storage_buffer("after", &[1u32; 4]).unwrap_err();
    assert!(matches!(err, GpuError::DeviceLost(_)), "{err}");
    assert!(gpu.read_buffer::<u32>(&data, 8).is_err());
    let params = gpu.uniform_buffer("params", &SmokeParams { count: 1, scale: 1.0 });
    let run = params.and_then(|p| {
        let g = kernel.bind_group(&gpu, 0, &[&p, &data, &data, &data])?;
        gpu.dispatch(&kernel, &[&g], [1, 1, 1])
    });
    assert!(run.is_err());
}

/// wgpu's OpenGL backend (EGL, here on Mesa's llvmpipe) runs the same kernels translated to
/// GLSL, for machines whose GPU has no Vulkan, Metal or DirectX 12 driver: it renders the
/// example scenes as the Vulkan backend does (not bit for bit: another shader compiler),
/// through the command line with `WGPU_BACKEND=gl`, which restricts wgpu to that backend.
#[test]
fn the_opengl_backend_renders_as_vulkan_does() {
    if gpu_for_tests("the_opengl_backend_renders_as_vulkan_does").is_none() {
        return;
    }
    let lumen = |gl: bool| {
        let mut cmd = common::lumen_command();
        if gl {
            cmd.env("WGPU_BACKEND", "gl");
        } else {
            cmd.env_remove("WGPU_BACKEND");
        }
        cmd
    };
    let devices = lumen(true).arg("devices").output().unwrap();
    if !String::from_utf8_lossy(&devices.stdout).contains("backend: gl") {
        assert!(!gpu_required(), "no OpenGL adapter (`WGPU_BACKEND=gl lumen devices`): {devices:?}");
        println!("skipped the_opengl_backend_renders_as_vulkan_does: no OpenGL adapter");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    // wgpu's OpenGL backend cannot build compute pipelines on NVIDIA's EGL driver: it picks
    // a GLSL version without compute shaders (gfx-rs/wgpu#4751; seen on an H200,
    // 2026-12-04). lumen reports that as an error; there is nothing to compare. Mesa's
    // driver, the one CI runs, must not fail so.
    let listed = String::from_utf8_lossy(&devices.stdout).into_owned();
    let probe = lumen(true)
        .arg("render")
        .arg(scenes.join("cornell.sl"))
        .args(["--device", "gpu", "--width", "8", "--spp", "1", "-o"])
        .arg(dir.path().join("probe.pfm"))
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&probe.stderr);
    if !probe.status.success() && said.contains("doesn't support Features") && !listed.contains("llvmpipe") {
        println!("skipped the_opengl_backend_renders_as_vulkan_does: wgpu's GL backend has no compute here: {said}");
        return;
    }
    for scene in ["cornell", "csg", "materials", "meshes", "skybox"] {
        let render = |gl: bool| {
            let out = dir.path().join(format!("{scene}-{gl}.pfm"));
            let o = lumen(gl)
                .arg("render")
                .arg(scenes.join(format!("{scene}.sl")))
                .args(["--device", "gpu", "--width", "48", "--spp", "4", "-o"])
                .arg(&out)
                .output()
                .unwrap();
            assert!(o.status.success(), "{scene} (gl: {gl}): {}", String::from_utf8_lossy(&o.stderr));
            lumen::image::read_image(&out).unwrap()
        };
        let a = common::agreement(&render(true), &render(false));
        println!("{scene}: {a}");
        a.check(common::Tolerance::share(0.99)).unwrap_or_else(|e| panic!("{scene}, OpenGL vs Vulkan: {e}"));
    }
}

/// On an llvmpipe of Mesa 26.1 or later `lumen` relaunches itself with the host's vector
/// width (256 or 512 bits) when the width was its own choice, and keeps a width that was set
/// (cli::software_driver, DESIGN.md "Vector width"). Only such a driver shows it: with
/// another adapter (CI's Mesa 25) the test says it was skipped; run it through
/// scripts/newer_lavapipe.sh's runner (README "How it is checked").
#[cfg(target_arch = "x86_64")]
#[test]
fn lumen_widens_llvmpipe_vectors_where_the_driver_gains() {
    let Some(gpu) = lumen::gpu::gpu_for_tests("lumen_widens_llvmpipe_vectors_where_the_driver_gains") else {
        return;
    };
    let host_bits = lumen::cli::software_driver::host_vector_bits();
    if !lumen::gpu::llvmpipe_prefers_wide_vectors(&gpu.adapter_info) || host_bits == 128 {
        println!("skipped: {} is not an llvmpipe that runs faster with wider vectors", gpu.adapter_info.name);
        return;
    }
    let devices = |width: Option<&str>| {
        let mut cmd = common::lumen_command();
        cmd.arg("devices");
        match width {
            Some(w) => cmd.env("LP_NATIVE_VECTOR_WIDTH", w),
            None => cmd.env_remove("LP_NATIVE_VECTOR_WIDTH"),
        };
        let out = cmd.output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    let chosen = devices(None);
    let want = format!("{host_bits} bits");
    assert!(chosen.lines().next().is_some_and(|l| l.contains(&want)), "{chosen}");
    let set = devices(Some("128"));
    assert!(set.lines().next().is_some_and(|l| l.contains("128 bits")), "{set}");
}
