//! Triangle meshes (issue 13) against closed forms and the analytic sphere, on the CPU
//! reference and (where an adapter exists) the GPU.

mod common;

use std::path::Path;

use common::{inscribed_radius, mean_and_stderr, obj_text};
use glam::DVec3;
use lumen::cpu::{render, Progress, RenderOptions};
use lumen::scene::mesh::icosphere;
use lumen::scene::*;
use lumen::scenelang::{load_str, ErrorKind, LoadOptions};

/// The icosphere of `subdivisions` written as `name` into `dir` (with vertex normals when
/// `normals`).
fn write_icosphere(dir: &Path, name: &str, subdivisions: u32, normals: bool) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let (v, f) = icosphere(subdivisions);
    std::fs::write(dir.join(name), obj_text(&v, &f, normals)).unwrap();
    (v, f)
}

fn load(dir: &Path, src: &str) -> Scene {
    load_str(src, "t.sl", dir, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

const ONOFF: &str = "USING Camera.Perspective() Image(48, 48) Renderer.OnOff() Tracer(.samples_per_side 0)\n";

/// OnOff silhouettes of a tessellated unit sphere and the analytic one: the polyhedron lies
/// between the spheres of radius r_in (its smallest face distance) and 1, so every pixel
/// whose camera ray passes the centre closer than r_in sees both, every one passing farther
/// than 1 sees neither, and only the ring between may differ.
#[test]
fn a_tessellated_sphere_has_the_analytic_silhouette() {
    let dir = tempfile::tempdir().unwrap();
    let (v, f) = write_icosphere(dir.path(), "ball.obj", 3, false);
    let r_in = inscribed_radius(&v, &f);
    assert!(r_in > 0.99 && r_in < 1.0, "{r_in}");
    let place = ".transformation TRANSLATE(3, 0, 0)";
    let mesh = load(dir.path(), &format!("SPAWN Shape.Mesh(.file \"ball.obj\", {place})\n{ONOFF}"));
    let sphere = load(dir.path(), &format!("SPAWN Shape.Sphere({place})\n{ONOFF}"));
    let (a, b) = (
        render(&mesh, &RenderOptions::default(), Progress::Hidden).image,
        render(&sphere, &RenderOptions::default(), Progress::Hidden).image,
    );
    let centre = DVec3::new(3.0, 0.0, 0.0);
    let (mut checked, mut skipped) = (0, 0);
    for row in 0..48 {
        for col in 0..48 {
            let ray = sphere.camera.ray((col as f64 + 0.5) / 48.0, 1.0 - (row as f64 + 0.5) / 48.0);
            let d = ray.dir.normalize();
            let to_c = centre - ray.origin;
            let miss = (to_c - to_c.dot(d) * d).length();
            if miss < r_in - 1e-9 || miss > 1.0 + 1e-9 {
                assert_eq!(a.get(col, row), b.get(col, row), "pixel ({col}, {row}) at distance {miss}");
                assert_eq!(a.get(col, row).g, if miss < r_in { 1.0 } else { 0.0 });
                checked += 1;
            } else {
                skipped += 1;
            }
        }
    }
    assert!(checked > 2000 && skipped < 100, "{checked} checked, {skipped} in the ring");
}

/// Shaded: a smooth tessellated sphere and the analytic one under a point light (PointLight
/// renderer: each pixel is ρ/π·I·max(0, n·l)). Derived bound, for pixels whose camera ray
/// meets the sphere less than 60° from its normal: the interpolated normal lies in the
/// spherical triangle of its vertex normals, as does the true normal there, so they differ
/// by at most δ, the largest angle between two vertex normals of a triangle; the hit point
/// moves by at most (1 − r_in)/cos 60° along the ray, which turns the direction to a light
/// at distance ≥ D − 1 by at most that over D − 1. max(0, ·) is 1-Lipschitz, so
/// |Δ value| ≤ ρ/π·I·(δ + 2(1 − r_in)/(D − 1)).
#[test]
fn a_smooth_tessellated_sphere_shades_like_the_analytic_one() {
    let dir = tempfile::tempdir().unwrap();
    let (v, f) = write_icosphere(dir.path(), "ball.obj", 4, true);
    let r_in = inscribed_radius(&v, &f);
    let delta = f
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .map(|(a, b)| v[a as usize].dot(v[b as usize]).clamp(-1.0, 1.0).acos())
        .fold(0.0, f64::max);
    let (rho, intensity, light) = (0.8, 2.0, DVec3::new(0.0, 4.0, 5.0));
    let distance = (light - DVec3::new(3.0, 0.0, 0.0)).length();
    let bound = rho / std::f64::consts::PI * intensity * (delta + 2.0 * (1.0 - r_in) / (distance - 1.0));
    let settings = format!(
        "Light(.position {{{}, {}, {}}}, .color <{intensity}, {intensity}, {intensity}>)
         USING Camera.Perspective() Image(48, 48) Renderer.PointLight() Tracer(.samples_per_side 0)",
        light.x, light.y, light.z
    );
    let material = format!(".material Material(Brdf.Diffuse(<{rho}, {rho}, {rho}>))");
    let mesh = load(
        dir.path(),
        &format!("SPAWN Shape.Mesh(.file \"ball.obj\", {material}, .transformation TRANSLATE(3, 0, 0)) {settings}"),
    );
    let sphere =
        load(dir.path(), &format!("SPAWN Shape.Sphere({material}, .transformation TRANSLATE(3, 0, 0)) {settings}"));
    let a = render(&mesh, &RenderOptions::default(), Progress::Hidden).image;
    let b = render(&sphere, &RenderOptions::default(), Progress::Hidden).image;
    let centre = DVec3::new(3.0, 0.0, 0.0);
    let (mut checked, mut worst) = (0, 0.0f64);
    for row in 0..48 {
        for col in 0..48 {
            let ray = sphere.camera.ray((col as f64 + 0.5) / 48.0, 1.0 - (row as f64 + 0.5) / 48.0);
            let d = ray.dir.normalize();
            let to_c = centre - ray.origin;
            // sin of the angle between the ray and the sphere's normal at the hit.
            if (to_c - to_c.dot(d) * d).length() < r_in * (60f64).to_radians().sin() {
                let diff = (f64::from(a.get(col, row).g) - f64::from(b.get(col, row).g)).abs();
                worst = worst.max(diff);
                assert!(diff <= bound, "({col}, {row}): {diff} > {bound}");
                checked += 1;
            }
        }
    }
    println!("smooth icosphere vs sphere: worst {worst:.5}, bound {bound:.5} (δ {delta:.4}, r_in {r_in:.5})");
    assert!(checked > 80, "{checked}");
    // The same facets shaded flat are off by up to ~δ/2 in the normal: interpolation, not
    // the bound, is what makes the smooth image close.
    let flat = load(
        dir.path(),
        &format!("SPAWN Shape.Mesh(.file \"ball.obj\", {material}, .smooth 0, .transformation TRANSLATE(3, 0, 0)) {settings}"),
    );
    let c = render(&flat, &RenderOptions::default(), Progress::Hidden).image;
    let flat_worst = a
        .pixels()
        .iter()
        .zip(b.pixels())
        .zip(c.pixels())
        .fold(0.0f64, |m, ((_, s), f)| m.max((f64::from(f.g) - f64::from(s.g)).abs()));
    assert!(flat_worst > 10.0 * worst, "flat {flat_worst} vs smooth {worst}");
}

/// A convex diffuse polyhedron under a uniform sky, one bounce, no NEE: each path scatters
/// once and escapes (it cannot meet a convex surface again), so every pixel that sees it is
/// exactly ρL, as for the analytic sphere, flat or smooth.
#[test]
fn a_diffuse_mesh_under_a_uniform_sky_shows_albedo_times_sky() {
    let dir = tempfile::tempdir().unwrap();
    write_icosphere(dir.path(), "ball.obj", 2, true);
    for smooth in [0, 1] {
        let scene = load(
            dir.path(),
            &format!(
                "SPAWN Shape.Mesh(.file \"ball.obj\", .material Material(Brdf.Diffuse(<0.6, 0.6, 0.6>)),
                                  .transformation TRANSLATE(3, 0, 0), .smooth {smooth})
                 USING Camera.Perspective() Image(24, 24) Tracer(.samples_per_side 1)
                       Renderer.PathTracer(.n 4, .max_depth 3, .nee 0) Environment.Uniform(.color <2, 2, 2>)"
            ),
        );
        let img = render(&scene, &RenderOptions::default(), Progress::Hidden).image;
        let mut on = 0;
        for p in img.pixels() {
            let seen = (f64::from(p.g) - 1.2).abs() < 1e-6;
            // Smooth shading may drop a path whose sample leaves below the facet (shading
            // normals never send light through a surface): then less, never more.
            assert!(seen || (f64::from(p.g) - 2.0).abs() < 1e-6 || (smooth == 1 && p.g < 1.2), "{p:?}");
            on += usize::from(seen);
        }
        assert!(on > 20, "smooth {smooth}: {on} pixels see the ball");
    }
}

/// Closed furnace: the camera inside an emissive diffuse mesh sphere (Le 1, ρ 0.5, seen from
/// inside), flat-shaded: without roulette every path is Le Σ_{k≤20} ρᵏ exactly. (Smooth
/// shading would lose the samples that its normals aim through the facets: by design.)
#[test]
fn closed_furnace_of_an_emissive_mesh_sphere() {
    let dir = tempfile::tempdir().unwrap();
    write_icosphere(dir.path(), "room.obj", 2, true);
    let scene = load(
        dir.path(),
        "SPAWN Shape.Mesh(.file \"room.obj\", .transformation SCALE 10, .smooth 0,
                          .material Material(Brdf.Diffuse(<0.5, 0.5, 0.5>), <1, 1, 1>))
         USING Camera.Perspective() Image(8, 8) Tracer(.samples_per_side 1)
               Renderer.PathTracer(.n 2, .max_depth 20, .roulette_depth 1000, .nee 0)",
    );
    let expected = 2.0 * (1.0 - 0.5f64.powi(21));
    let img = render(&scene, &RenderOptions::default(), Progress::Hidden).image;
    let bad: Vec<_> = img
        .pixels()
        .iter()
        .enumerate()
        .filter(|(_, p)| (f64::from(p.g) / expected - 1.0).abs() >= 1e-6)
        .map(|(i, p)| (i, p.g))
        .collect();
    assert!(bad.is_empty(), "{bad:?}");
    // With NEE (the mesh is an area light) + MIS: unbiased, noisy.
    let nee = load(
        dir.path(),
        "SPAWN Shape.Mesh(.file \"room.obj\", .transformation SCALE 10, .smooth 0,
                          .material Material(Brdf.Diffuse(<0.5, 0.5, 0.5>), <1, 1, 1>))
         USING Camera.Perspective() Image(16, 16) Tracer(.samples_per_side 2)
               Renderer.PathTracer(.n 16, .max_depth 20, .roulette_depth 1000, .nee 1)",
    );
    let img = render(&nee, &RenderOptions::default(), Progress::Hidden).image;
    let (mean, se) = mean_and_stderr(&img, |_, _| true);
    println!("mesh furnace with NEE: {mean} ± {se} (expected {expected})");
    assert!(5.0 * se < 0.01 * expected, "test too weak: se {se}");
    assert!((mean / expected - 1.0).abs() < 0.01, "{mean} vs {expected}");
}

/// Two `Shape.Mesh` of one file share one triangle set (stored once) and render as two
/// copies of the file under different names do.
#[test]
fn instances_share_one_mesh_and_render_as_copies() {
    let dir = tempfile::tempdir().unwrap();
    write_icosphere(dir.path(), "a.obj", 2, true);
    write_icosphere(dir.path(), "b.obj", 2, true);
    let scene = |second: &str| {
        load(
            dir.path(),
            &format!(
                "SET m Material(Brdf.Diffuse(<0.7, 0.4, 0.2>))
                 SPAWN Shape.Mesh(.file \"a.obj\", .material m, .transformation TRANSLATE(4, 1.2, 0))
                       Shape.Mesh(.file \"{second}\", .material m, .transformation TRANSLATE(4, -1.2, 0) * SCALE 0.8)
                       Shape.Plane(.transformation TRANSLATE(.Z -1))
                 USING Camera.Perspective() Image(24, 16) Tracer(.samples_per_side 1)
                       Renderer.PathTracer(.n 2, .max_depth 3) Environment.Uniform(.color <1, 1, 1>)"
            ),
        )
    };
    let (shared, copies) = (scene("a.obj"), scene("b.obj"));
    let mesh = |s: &Scene, i: usize| match &s.shapes[i] {
        Shape::Mesh(m) => m.mesh.clone(),
        other => panic!("{other:?}"),
    };
    assert!(std::sync::Arc::ptr_eq(&mesh(&shared, 0), &mesh(&shared, 1)), "one file, one mesh");
    let summary = lumen::scenelang::SceneSummary::of(&shared);
    assert_eq!((summary.mesh_instances, summary.meshes.len(), summary.meshes[0].instances), (2, 1, 2));
    assert_eq!((summary.meshes[0].triangles, summary.meshes[0].vertices), (320, 162));
    assert!(summary.to_string().contains("a.obj: 320 triangles, 162 vertices, normals, ×2"), "{summary}");
    assert!(!std::sync::Arc::ptr_eq(&mesh(&copies, 0), &mesh(&copies, 1)));
    let a = render(&shared, &RenderOptions::default(), Progress::Hidden).image;
    let b = render(&copies, &RenderOptions::default(), Progress::Hidden).image;
    assert_eq!(a.pixels(), b.pixels());
}

#[test]
fn meshes_in_csg_and_bad_mesh_files_are_located_errors() {
    let dir = tempfile::tempdir().unwrap();
    write_icosphere(dir.path(), "ball.obj", 1, false);
    std::fs::write(dir.path().join("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap();
    let err = |src: &str| {
        load_str(&format!("{src}\n{ONOFF}"), "t.sl", dir.path(), &LoadOptions::default()).expect_err("an error")
    };
    let e = err("SPAWN UNITE(Shape.Sphere(), Shape.Mesh(.file \"ball.obj\"))");
    assert_eq!(e.kind, ErrorKind::WrongType);
    assert!(e.to_string().contains("cannot be a CSG operand") && e.to_string().contains("t.sl:1:"), "{e}");
    let e = err("SPAWN Shape.Mesh(.file \"missing.obj\")");
    assert_eq!(e.kind, ErrorKind::MeshFile);
    assert!(e.to_string().contains("missing.obj") && e.to_string().contains("t.sl:1:24"), "{e}");
    assert!(e.to_string().contains("expected: a readable .obj or .ply file"), "{e}");
    // A readable file's error is not answered with "a readable file" (until 2026-12-07 it was).
    let e = err("SPAWN Shape.Mesh(.file \"bad.obj\")");
    assert!(e.to_string().contains("bad.obj") && e.to_string().contains("line 3"), "{e}");
    assert!(e.to_string().contains("expected: faces that refer only to what the file defines"), "{e}");
    let e = err("SPAWN Shape.Mesh(.material Material())");
    assert!(e.to_string().contains("needs a `.file`"), "{e}");
}

/// The bottom-level BVH finds what testing every triangle finds.
#[test]
fn mesh_bvh_queries_match_brute_force() {
    let (v, f) = icosphere(3);
    let parts = MeshParts { positions: v, normals: None, uvs: None, triangles: f, dropped_faces: 0 };
    let mesh = std::sync::Arc::new(TriangleMesh::from_parts("ball", parts).unwrap());
    let to_world_shape =
        Transform::translation(DVec3::new(0.3, -0.2, 0.1)) * Transform::scaling(DVec3::new(1.0, 2.0, 0.5));
    let world =
        lumen::cpu::World::from_shapes(&[Shape::mesh(mesh.clone(), "ball", to_world_shape, MaterialId(0), false)]);
    let to_world = Transform::translation(DVec3::new(0.3, -0.2, 0.1)) * Transform::scaling(DVec3::new(1.0, 2.0, 0.5));
    let inv = to_world.inverse_matrix();
    let mut rng = lumen::sampling::Pcg32::new(1, 2);
    let mut hits = 0;
    for _ in 0..2000 {
        let o = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 6.0 - 3.0;
        let d = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - 1.0;
        let ray = lumen::cpu::Ray::new(o, d, 0.0, f64::INFINITY);
        let (lo, ld) = (inv.transform_point3(o), inv.transform_vector3(d));
        let brute = (0..mesh.triangle_count())
            .filter_map(|i| {
                let [a, b, c] = mesh.triangle(i);
                lumen::accel::intersect_triangle(lo, ld, a, b, c, f64::INFINITY).map(|h| h.t)
            })
            .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.min(t))));
        assert_eq!(world.intersect(&ray).map(|h| h.t), brute, "{o} {d}");
        hits += usize::from(brute.is_some());
    }
    assert!(hits > 50, "{hits}");
}

// ---- The GPU ----

use lumen::gpu::gpu_for_tests;
use lumen::gpu::render::{render as gpu_render, GpuRenderOptions};

/// GPU vs CPU on `scene`: at least `min_share` of the pixels agree, the rest add little.
fn gpu_matches_cpu(gpu: &lumen::gpu::Gpu, scene: &Scene, min_share: f64) -> lumen::image::HdrImage {
    let g = gpu_render(gpu, scene, &GpuRenderOptions::default()).unwrap();
    let c = render(scene, &RenderOptions::default(), Progress::Hidden);
    let a = common::agreement(&g.image, &c.image);
    println!("{a}");
    a.check(common::Tolerance::share(min_share)).unwrap_or_else(|e| panic!("GPU vs CPU: {e}"));
    assert_eq!(g.non_finite_samples, 0);
    g.image
}

/// A mesh scene on both devices: a smooth icosphere with uvs (a checkered pigment reads
/// them), a flat one, a rough conductor mesh, on a plane, under a point light, a sky and an
/// emissive mesh (an area light with a checkered emission, sampled by NEE); path traced with
/// NEE and without, and by the three simple renderers; with NEE also beside an emissive
/// cube (kernels then hold both kinds of light, else only the mesh lights' code).
#[test]
fn mesh_scenes_render_on_the_gpu_as_on_the_cpu() {
    let Some(gpu) = gpu_for_tests("mesh_scenes_render_on_the_gpu_as_on_the_cpu") else { return };
    let dir = tempfile::tempdir().unwrap();
    let (v, f) = icosphere(2);
    // uvs from the longitude and latitude of each vertex.
    let mut text = String::new();
    for p in &v {
        text += &format!("v {} {} {}\nvn {} {} {}\n", p.x, p.y, p.z, p.x, p.y, p.z);
        text += &format!(
            "vt {} {}\n",
            0.5 + p.y.atan2(p.x) / std::f64::consts::TAU,
            0.5 + p.z.asin() / std::f64::consts::PI
        );
    }
    for [a, b, c] in &f {
        text += &format!("f {0}/{0}/{0} {1}/{1}/{1} {2}/{2}/{2}\n", a + 1, b + 1, c + 1);
    }
    std::fs::write(dir.path().join("ball.obj"), text).unwrap();
    let nee = "Renderer.PathTracer(.n 4, .max_depth 4, .roulette_depth 2, .nee 1)";
    let cube_lamp = "Shape.Cube(.material Material(Brdf.Diffuse(<0, 0, 0>), <4, 4, 3>),
                                .transformation TRANSLATE(3, -2, 2.5) * SCALE 0.4)";
    let cases = [
        (nee, ""),
        (nee, cube_lamp),
        ("Renderer.PathTracer(.n 4, .max_depth 4, .roulette_depth 2, .nee 0)", ""),
        ("Renderer.OnOff()", ""),
        ("Renderer.Flat()", ""),
        ("Renderer.PointLight(.ambient_color <0.02, 0.02, 0.02>)", ""),
    ];
    for (renderer, extra) in cases {
        let scene = load(
            dir.path(),
            &format!(
                "SET check Material(Brdf.Diffuse(Pigment.Checkered(6, <0.8, 0.7, 0.2>, <0.1, 0.2, 0.6>)))
                 SPAWN Shape.Mesh(.file \"ball.obj\", .material check, .transformation TRANSLATE(4, 1.3, 0) * ROTATE(.Z 30))
                       Shape.Mesh(.file \"ball.obj\", .smooth 0, .material Material(Brdf.Diffuse(<0.6, 0.3, 0.3>)),
                                  .transformation TRANSLATE(4, -1.3, 0) * SCALE(1, 0.7, 1.2))
                       Shape.Mesh(.file \"ball.obj\", .material Material(Brdf.Conductor(.metal \"Au\", .roughness 0.3)),
                                  .transformation TRANSLATE(6, 0, 0.5) * SCALE 0.8)
                       Shape.Plane(.material Material(Brdf.Diffuse(<0.5, 0.5, 0.5>)), .transformation TRANSLATE(.Z -1))
                       Shape.Mesh(.file \"ball.obj\", .transformation TRANSLATE(4, 0, 2.6) * SCALE(0.6, 0.8, 0.05),
                                  .material Material(Brdf.Diffuse(<0, 0, 0>), Pigment.Checkered(4, <6, 5, 4>, <1, 1, 2>)))
                       {extra}
                       Light(.position {{1, 2, 4}}, .color <3, 3, 3>)
                 USING Camera.Perspective(.aspect_ratio 1.5) Image(30, 20) Tracer(.samples_per_side 2) {renderer}
                       Environment.Gradient(<0.3, 0.4, 0.8>, <0.6, 0.6, 0.6>, <0.1, 0.1, 0.1>)"
            ),
        );
        println!("{renderer} {extra}");
        let names = lumen::gpu::features::FeatureSet::of(&scene).names();
        if renderer == nee {
            assert!(names.contains(&"MESH_LIGHTS"));
            assert_eq!(names.contains(&"PRIMITIVE_LIGHTS"), !extra.is_empty(), "{names:?}");
        }
        gpu_matches_cpu(&gpu, &scene, 0.99);
    }
}

/// Meshes of one to five triangles, whose bottom-level trees are a single leaf or a root
/// over two leaves (the GPU's quantized walk gives a one-leaf tree a root of its own and
/// reads leaf ranges from the parent: accel::quantized), alone and as twelve instances (a
/// top-level walk over many small trees), on the GPU as on the CPU.
#[test]
fn meshes_of_a_few_triangles_render_on_the_gpu_as_on_the_cpu() {
    let Some(gpu) = gpu_for_tests("meshes_of_a_few_triangles_render_on_the_gpu_as_on_the_cpu") else { return };
    let dir = tempfile::tempdir().unwrap();
    let fan = |n: usize| {
        // A fan of n triangles around the origin in the x = 0 plane, facing -x.
        let mut v = vec![DVec3::ZERO];
        v.extend((0..=n).map(|k| {
            let a = k as f64 * std::f64::consts::PI / 3.0;
            DVec3::new(0.0, a.cos(), a.sin())
        }));
        let f: Vec<[u32; 3]> = (0..n as u32).map(|k| [0, k + 1, k + 2]).collect();
        (v, f)
    };
    for n in [1, 2, 3, 5] {
        let (v, f) = fan(n);
        std::fs::write(dir.path().join(format!("fan{n}.obj")), obj_text(&v, &f, false)).unwrap();
    }
    let renderers = ["Renderer.Flat()", "Renderer.PathTracer(.n 2, .max_depth 3, .roulette_depth 2, .nee 1)"];
    for renderer in renderers {
        let mut spawn = String::new();
        for (k, n) in [1, 2, 3, 5].into_iter().enumerate() {
            let y = k as f64 * 2.2 - 3.3;
            spawn += &format!(
                "Shape.Mesh(.file \"fan{n}.obj\", .material Material(Brdf.Diffuse(<0.7, 0.5, 0.3>)),
                            .transformation TRANSLATE(5, {y}, 1.2))\n"
            );
            for j in 0..3 {
                let z = -0.6 - 1.1 * j as f64;
                spawn += &format!(
                    "Shape.Mesh(.file \"fan{n}.obj\", .material Material(Brdf.Diffuse(<0.3, 0.6, 0.4>)),
                                .transformation TRANSLATE(5.5, {y}, {z}) * SCALE 0.5)\n"
                );
            }
        }
        let scene = load(
            dir.path(),
            &format!(
                "SPAWN {spawn}
                       Shape.Plane(.material Material(Brdf.Diffuse(<0.5, 0.5, 0.5>)), .transformation TRANSLATE(.Z -3))
                       Light(.position {{0, 0, 4}}, .color <3, 3, 3>)
                 USING Camera.Perspective(.aspect_ratio 1.5) Image(36, 24) Tracer(.samples_per_side 2) {renderer}
                       Environment.Uniform(<0.4, 0.5, 0.6>)"
            ),
        );
        println!("{renderer}");
        gpu_matches_cpu(&gpu, &scene, 0.99);
    }
}

/// The closed furnace of a flat emissive mesh sphere, and the tessellated sphere's
/// silhouette, on the GPU: the same closed forms as the CPU tests above.
#[test]
fn mesh_furnace_and_silhouette_on_the_gpu() {
    let Some(gpu) = gpu_for_tests("mesh_furnace_and_silhouette_on_the_gpu") else { return };
    let dir = tempfile::tempdir().unwrap();
    let (v, f) = write_icosphere(dir.path(), "ball.obj", 3, false);
    let scene = load(
        dir.path(),
        "SPAWN Shape.Mesh(.file \"ball.obj\", .transformation SCALE 10,
                          .material Material(Brdf.Diffuse(<0.5, 0.5, 0.5>), <1, 1, 1>))
         USING Camera.Perspective() Image(8, 8) Tracer(.samples_per_side 1)
               Renderer.PathTracer(.n 2, .max_depth 20, .roulette_depth 1000, .nee 0)",
    );
    let expected = 2.0 * (1.0 - 0.5f64.powi(21));
    let img = gpu_render(&gpu, &scene, &GpuRenderOptions::default()).unwrap().image;
    for p in img.pixels() {
        assert!((f64::from(p.g) / expected - 1.0).abs() < 2e-6, "{p:?}");
    }
    // With NEE: the mesh is an area light (triangles sampled by area), MIS-weighted.
    let nee = load(
        dir.path(),
        "SPAWN Shape.Mesh(.file \"ball.obj\", .transformation SCALE 10,
                          .material Material(Brdf.Diffuse(<0.5, 0.5, 0.5>), <1, 1, 1>))
         USING Camera.Perspective() Image(12, 12) Tracer(.samples_per_side 2)
               Renderer.PathTracer(.n 8, .max_depth 20, .roulette_depth 1000, .nee 1)",
    );
    let img = gpu_render(&gpu, &nee, &GpuRenderOptions::default()).unwrap().image;
    let (mean, se) = mean_and_stderr(&img, |_, _| true);
    println!("GPU mesh furnace with NEE: {mean} ± {se} (expected {expected})");
    assert!(5.0 * se < 0.01 * expected, "test too weak: se {se}");
    assert!((mean / expected - 1.0).abs() < 0.01, "{mean} vs {expected}");
    let r_in = inscribed_radius(&v, &f);
    let mesh =
        load(dir.path(), &format!("SPAWN Shape.Mesh(.file \"ball.obj\", .transformation TRANSLATE(3, 0, 0))\n{ONOFF}"));
    let img = gpu_render(&gpu, &mesh, &GpuRenderOptions::default()).unwrap().image;
    let centre = DVec3::new(3.0, 0.0, 0.0);
    let mut checked = 0;
    for row in 0..48 {
        for col in 0..48 {
            let ray = mesh.camera.ray((col as f64 + 0.5) / 48.0, 1.0 - (row as f64 + 0.5) / 48.0);
            let d = ray.dir.normalize();
            let to_c = centre - ray.origin;
            let miss = (to_c - to_c.dot(d) * d).length();
            // f32 on the GPU: a margin of 1e-5 around the ring.
            if miss < r_in - 1e-5 || miss > 1.0 + 1e-5 {
                assert_eq!(img.get(col, row).g, if miss < r_in { 1.0 } else { 0.0 }, "({col}, {row}) at {miss}");
                checked += 1;
            }
        }
    }
    assert!(checked > 2000, "{checked}");
}
