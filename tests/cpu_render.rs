//! The CPU reference renderer against analytic answers: furnaces, energy conservation,
//! point-light shading, NEE/MIS consistency, exact OnOff/Flat images, determinism.
//!
//! Every render uses a fixed seed, so results are deterministic; tolerances are still
//! chosen from each estimator's variance (estimated from the images themselves), so a
//! different seed would pass as well.

mod common;

use std::f64::consts::PI;

use common::{furnace, lit_floor, lit_floor_radiance, mean_and_stderr, pt};

use glam::DVec3;
use lumen::color::Color;
use lumen::cpu::{render, Progress, RenderOptions, RenderOutput};
use lumen::image::HdrImage;
use lumen::scene::*;

fn run(scene: &Scene, spp: Option<u32>) -> RenderOutput {
    let out = render(scene, &RenderOptions { spp, ..RenderOptions::default() }, Progress::Hidden);
    assert_eq!(out.stats.non_finite_samples, 0);
    out
}

fn px(img: &HdrImage, col: usize, row: usize) -> Color {
    img.get(col, row).into()
}

#[test]
fn closed_furnace_without_roulette() {
    // L = Le Σ ρᵏ for k ≤ max_depth: with max_depth 20 the truncation is ρ²¹ = 5e-7 relative.
    let expected = 1.0 / (1.0 - 0.5);
    // Without NEE every path is exactly Le Σ ρᵏ (cosine sampling, β = ρᵏ): no variance.
    let out = run(&furnace(16, 0.5, 1.0, pt(1, 20, 1000, false)), Some(1));
    for p in out.image.pixels() {
        assert!((f64::from(p.g) / expected - 1.0).abs() < 1e-5, "{p:?}");
    }
    // With NEE (area sampling from inside the light) + MIS: noisy, unbiased. 16×16 pixels
    // × 64 paths; the stated tolerance 0.5 % must exceed 5 standard errors.
    let out = run(&furnace(16, 0.5, 1.0, pt(16, 20, 1000, true)), Some(4));
    let (mean, se) = mean_and_stderr(&out.image, |_, _| true);
    eprintln!("furnace ρ 0.5 with NEE: {mean} ± {se} (expected {expected})");
    assert!(5.0 * se < 0.005 * expected, "test too weak: se {se}");
    assert!((mean / expected - 1.0).abs() < 0.005, "{mean} vs {expected} (se {se})");
}

#[test]
fn closed_furnace_with_roulette_is_unbiased() {
    // ρ = 0.9, roulette from depth 2 (q = 0.1); max_depth 300 truncates by 0.9³⁰¹ ≈ 1e-14.
    // A path's value has a standard deviation ≈ 7 (its length is geometric), so 5 standard
    // errors below 0.5 % of 10 need > 5·10⁵ paths: 16×16 pixels × 16 samples × 200 paths.
    let expected = 1.0 / (1.0 - 0.9);
    for nee in [false, true] {
        let out = run(&furnace(16, 0.9, 1.0, pt(200, 300, 2, nee)), Some(16));
        let (mean, se) = mean_and_stderr(&out.image, |_, _| true);
        eprintln!("furnace ρ 0.9 roulette, nee {nee}: {mean} ± {se} (expected {expected})");
        assert!(5.0 * se < 0.005 * expected, "test too weak: se {se} (nee {nee})");
        assert!((mean / expected - 1.0).abs() < 0.005, "nee {nee}: {mean} vs {expected} (se {se})");
    }
}

/// A sphere of `material` at (3, 0, 0) under a uniform environment, and the OnOff mask of
/// which pixels see it.
fn object_under_sky(brdf: Brdf, sky: f64, renderer: Renderer) -> (Scene, HdrImage) {
    let mut b = SceneBuilder::new(24, 24);
    let m = b.material(Material::new(brdf, Pigment::Uniform(Color::BLACK)));
    b.sphere(Transform::translation(DVec3::new(2.0, 0.0, 0.0)) * Transform::scaling(DVec3::splat(1.5)), m)
        .environment(Environment::Uniform(Color::gray(sky)))
        .renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });
    let mask = run(&b.build().unwrap(), None).image;
    b.renderer(renderer);
    (b.build().unwrap(), mask)
}

#[test]
fn convex_diffuse_object_under_uniform_sky_shows_albedo_times_sky() {
    let (rho, sky) = (0.6, 2.0);
    let brdf = Brdf::Diffuse { pigment: Pigment::Uniform(Color::gray(rho)) };
    // Without NEE: each path scatters once and escapes: exactly ρL (no variance).
    let (scene, mask) = object_under_sky(brdf.clone(), sky, pt(1, 3, 100, false));
    let out = run(&scene, None);
    let mut hits = 0;
    for row in 0..24 {
        for col in 0..24 {
            let expected = if mask.get(col, row).g > 0.5 { rho * sky } else { sky };
            hits += usize::from(mask.get(col, row).g > 0.5);
            assert!((px(&out.image, col, row).g / expected - 1.0).abs() < 1e-6, "({col},{row})");
        }
    }
    assert!(hits > 30, "the sphere covers {hits} pixels");
    // With NEE: MIS of uniform-sphere environment samples and cosine samples; pixel
    // centres only (the mask's), 1024 paths each; tolerance 1 % > 5 standard errors.
    let (scene, mask) = object_under_sky(brdf, sky, pt(1024, 3, 100, true));
    let out = run(&scene, None);
    let on = |c: usize, r: usize| mask.get(c, r).g > 0.5;
    let (mean, se) = mean_and_stderr(&out.image, on);
    eprintln!("diffuse ball under the sky with NEE: {mean} ± {se} (expected {})", rho * sky);
    assert!(5.0 * se < 0.01 * rho * sky, "test too weak: se {se}");
    assert!((mean / (rho * sky) - 1.0).abs() < 0.01, "{mean} (se {se})");
    let (bg, _) = mean_and_stderr(&out.image, |c, r| !on(c, r));
    assert!((bg / sky - 1.0).abs() < 1e-6);
}

#[test]
fn glass_sphere_under_uniform_sky_conserves_energy() {
    // A clear dielectric neither absorbs nor emits: every pixel sees L (the η² radiance
    // factors of entering and leaving cancel). No roulette; max_depth 64 leaves a path
    // inside only with probability ≲ F⁶⁴.
    let sky = 1.5;
    for nee in [false, true] {
        let brdf = Brdf::Dielectric {
            pigment: Pigment::Uniform(Color::WHITE),
            ior: 1.5,
            roughness: 0.0,
            multiple_scattering: true,
        };
        let (scene, mask) = object_under_sky(brdf, sky, pt(16, 64, 1000, nee));
        let out = run(&scene, None);
        let (mean, se) = mean_and_stderr(&out.image, |c, r| mask.get(c, r).g > 0.5);
        eprintln!("glass ball under the sky, nee {nee}: {mean} ± {se} (expected {sky})");
        assert!(5.0 * se < 0.005 * sky, "test too weak: se {se}");
        assert!((mean / sky - 1.0).abs() < 0.005, "nee {nee}: {mean} (se {se})");
    }
}

#[test]
fn tinted_mirror_under_uniform_sky_shows_tint_times_sky() {
    // Every path reflects once off the convex mirror and escapes: exactly tint·L, with or
    // without NEE (after a delta bounce the escape has full weight).
    let tint = Color::new(0.9, 0.6, 0.3);
    for nee in [false, true] {
        let brdf = Brdf::Specular { pigment: Pigment::Uniform(tint), threshold_angle_rad: DEFAULT_THRESHOLD_ANGLE_RAD };
        let (scene, mask) = object_under_sky(brdf, 2.0, pt(2, 4, 100, nee));
        let img = run(&scene, None).image;
        for row in 0..24 {
            for col in 0..24 {
                let e = if mask.get(col, row).g > 0.5 { tint * 2.0 } else { Color::gray(2.0) };
                assert!(px(&img, col, row).approx_eq(e, 1e-6), "({col},{row})");
            }
        }
    }
}

#[test]
fn point_light_on_a_diffuse_plane_matches_the_closed_form_pixel_by_pixel() {
    let rho = Color::new(0.8, 0.5, 0.2);
    let light = DVec3::new(1.0, 0.5, 2.0);
    let intensity = Color::new(10.0, 20.0, 5.0);
    for renderer in [Renderer::PointLight { background: Color::BLACK, ambient: Color::BLACK }, pt(1, 1, 10, true)] {
        let scene = lit_floor(rho, light, intensity, renderer);
        let img = run(&scene, None).image;
        for row in 0..10 {
            for col in 0..12 {
                let expected = lit_floor_radiance(&scene, rho, light, intensity, col, row);
                let got = px(&img, col, row);
                for (g, e) in got.to_array().into_iter().zip(expected.to_array()) {
                    assert!((g / e - 1.0).abs() < 1e-6, "({col},{row}): {got:?} vs {expected:?}");
                }
            }
        }
    }
}

/// A point light behind a surface that transmits (rough glass) lights it through the
/// interface, as a sphere light of the same intensity and vanishing size does (a different
/// estimator: NEE on an area light, MIS-weighted against BSDF sampling), pixel by pixel
/// (the same camera samples; the sphere's size shows at the transmitted lobe's sharp
/// peak, 0.8 % at radius 0.002).
#[test]
fn a_point_light_behind_rough_glass_shines_through_it() {
    let point = run(&common::rough_glass_lit_from_below(None, 4.0), Some(256)).image;
    let sphere = run(&common::rough_glass_lit_from_below(Some(0.002), 4.0), Some(256)).image;
    let (mut sum_p, mut sum_s) = (0.0, 0.0);
    for row in 0..10 {
        for col in 0..12 {
            let (p, s) = (px(&point, col, row).g, px(&sphere, col, row).g);
            assert!((p / s - 1.0).abs() < 0.02, "({col},{row}): point light {p}, sphere light {s}");
            sum_p += p;
            sum_s += s;
        }
    }
    assert!((sum_p / sum_s - 1.0).abs() < 0.01, "image means: point {sum_p}, sphere {sum_s}");
    // The light reaches the camera: the old front-only rule gave a black image here.
    assert!(sum_p > 0.1, "{sum_p}");
}

#[test]
fn point_light_renderer_adds_ambient_and_respects_shadows() {
    // A small sphere half-way between the light and the floor point seen by pixel (2, 5)
    // puts that point in shadow (ambient only) without hiding it from the camera above.
    let light = DVec3::new(1.5, -0.2, 2.0);
    let ambient = Color::gray(0.01);
    let mut scene =
        lit_floor(Color::gray(0.5), light, Color::WHITE, Renderer::PointLight { background: Color::BLACK, ambient });
    let floor_point = |col: usize, row: usize| {
        let r = scene.camera.ray((col as f64 + 0.5) / 12.0, 1.0 - (row as f64 + 0.5) / 10.0);
        r.origin - r.dir * (r.origin.z / r.dir.z)
    };
    let q = floor_point(2, 5);
    let Shape::Primitive(p) = scene.shapes[0].clone() else { unreachable!() };
    scene.shapes.push(Shape::primitive(
        ShapeKind::Sphere,
        Transform::translation((light + q) / 2.0) * Transform::scaling(DVec3::splat(0.1)),
        p.material,
    ));
    let img = run(&scene, None).image;
    assert!(px(&img, 2, 5).approx_eq(ambient, 1e-9));
    // A corner is lit: ambient + ρ/π · cos θ / d².
    let to = light - floor_point(0, 0);
    let expected = 0.01 + 0.5 / PI * (to.z / to.length()) / to.length_squared();
    assert!((px(&img, 0, 0).g / expected - 1.0).abs() < 1e-6);
}

#[test]
fn nee_on_and_off_converge_to_the_same_image() {
    // Floor, a diffuse ball, a spherical lamp (cone sampling), an ellipsoidal one (area
    // sampling) and an emissive stretched cube (checkered, so sampled points must read the
    // right uv), under a dim gradient sky: every light kind NEE handles. Camera rays go
    // through pixel centres, so the two seeds differ only in the paths and their
    // difference measures path variance.
    let scene = |nee: bool, seed: u64| {
        let mut b = SceneBuilder::new(16, 12);
        let floor = b.diffuse(Color::new(0.7, 0.6, 0.5));
        let ball = b.diffuse(Color::new(0.3, 0.8, 0.4));
        let lamp = b.material(Material::new(Brdf::default(), Pigment::Uniform(Color::gray(6.0))));
        let panel = b.material(Material::new(
            Brdf::default(),
            Pigment::Checkered { n: 3, on: Color::new(2.0, 1.5, 0.5), off: Color::new(0.5, 0.3, 2.0) },
        ));
        b.plane(Transform::IDENTITY, floor)
            .sphere(Transform::translation(DVec3::new(4.0, 0.5, 0.6)) * Transform::scaling(DVec3::splat(0.6)), ball)
            .sphere(Transform::translation(DVec3::new(3.0, -1.0, 2.2)) * Transform::scaling(DVec3::splat(0.4)), lamp)
            .sphere(
                Transform::translation(DVec3::new(5.0, -2.0, 0.6)) * Transform::scaling(DVec3::new(0.3, 0.6, 0.3)),
                lamp,
            )
            .cube(
                Transform::translation(DVec3::new(5.5, 1.5, 1.0)) * Transform::scaling(DVec3::new(0.3, 1.0, 2.0)),
                panel,
            )
            .environment(Environment::Gradient {
                zenith: Color::new(0.2, 0.3, 0.5),
                horizon: Color::gray(0.3),
                nadir: Color::BLACK,
            })
            .camera(Camera {
                aspect_ratio: 16.0 / 12.0,
                transform: Transform::translation(DVec3::new(0.0, 0.0, 1.0)),
                ..Camera::default()
            })
            .tracer(Tracer { samples_per_side: 0, rng: PcgSeed { state: seed, inc: 54 } })
            .renderer(pt(512, 3, 2, nee));
        b.build().unwrap()
    };
    let (v_on, v_off) = assert_nee_agrees(scene);
    // NEE must actually reduce the variance on this scene.
    assert!(v_on < v_off, "NEE variance {v_on} vs BSDF-only {v_off}");
}

#[test]
fn nee_on_and_off_agree_under_an_image_environment() {
    // A diffuse ball on a floor under a dim equirectangular sky with one bright "sun"
    // texel: the importance-sampled environment is the only light.
    let mut sky = HdrImage::new(16, 8);
    for row in 0..8 {
        for col in 0..16 {
            sky.set(col, row, lumen::color::Rgb32::new(0.2, 0.25 + 0.02 * col as f32, 0.4 - 0.04 * row as f32));
        }
    }
    sky.set(5, 2, lumen::color::Rgb32::new(30.0, 28.0, 25.0));
    let sky = std::sync::Arc::new(sky);
    let scene = |nee: bool, seed: u64| {
        let mut b = SceneBuilder::new(16, 12);
        let floor = b.diffuse(Color::gray(0.5));
        let ball = b.diffuse(Color::new(0.8, 0.3, 0.3));
        b.plane(Transform::IDENTITY, floor)
            .sphere(Transform::translation(DVec3::new(4.0, 0.0, 0.8)) * Transform::scaling(DVec3::splat(0.8)), ball)
            .environment(Environment::Image { image: sky.clone(), intensity: 1.0, rotation_deg: 40.0 })
            .camera(Camera {
                aspect_ratio: 16.0 / 12.0,
                transform: Transform::translation(DVec3::new(0.0, 0.0, 1.0)),
                ..Camera::default()
            })
            .tracer(Tracer { samples_per_side: 0, rng: PcgSeed { state: seed, inc: 7 } })
            .renderer(pt(512, 2, 5, nee));
        b.build().unwrap()
    };
    let (v_on, v_off) = assert_nee_agrees(scene);
    assert!(v_on < v_off, "NEE variance {v_on} vs BSDF-only {v_off}");
}

#[test]
fn on_off_and_flat_are_pixel_exact() {
    // 4×4 pixels, default camera at (−1,0,0); a sphere of radius 1.5 at (3,0,0) subtends
    // sin θ = 1.5/4 → tan θ = 0.405. Pixel centres have direction (1, ±0.25|±0.75, ±0.25|±0.75):
    // only the central 2×2 (tan = √0.125 = 0.354) hit it.
    let mut b = SceneBuilder::new(4, 4);
    let m = b.material(Material::new(
        Brdf::Diffuse { pigment: Pigment::Uniform(Color::new(0.5, 0.25, 0.125)) },
        Pigment::Uniform(Color::new(0.1, 0.2, 0.3)),
    ));
    b.sphere(Transform::translation(DVec3::new(3.0, 0.0, 0.0)) * Transform::scaling(DVec3::splat(1.5)), m)
        .renderer(Renderer::OnOff { on: Color::new(1.0, 2.0, 3.0), off: Color::new(0.5, 0.0, 0.25) });
    let img = run(&b.build().unwrap(), None).image;
    let inside = |c: usize, r: usize| (1..3).contains(&c) && (1..3).contains(&r);
    for r in 0..4 {
        for c in 0..4 {
            let e = if inside(c, r) { Color::new(1.0, 2.0, 3.0) } else { Color::new(0.5, 0.0, 0.25) };
            assert_eq!(px(&img, c, r), e);
        }
    }
    // Flat: emitted + pigment on the sphere; the gradient sky elsewhere, at z of the unit
    // direction (1, 1−2u, 2v−1)/|·|.
    let (zen, hor, nad) = (Color::new(0.0, 0.0, 1.0), Color::new(1.0, 1.0, 1.0), Color::new(1.0, 0.0, 0.0));
    b.renderer(Renderer::Flat { background: Color::gray(9.0) }).environment(Environment::Gradient {
        zenith: zen,
        horizon: hor,
        nadir: nad,
    });
    let img = run(&b.build().unwrap(), None).image;
    for r in 0..4 {
        for c in 0..4 {
            let e = if inside(c, r) {
                Color::new(0.6, 0.45, 0.425)
            } else {
                let (y, z) = (1.0 - 2.0 * (c as f64 + 0.5) / 4.0, 2.0 * (1.0 - (r as f64 + 0.5) / 4.0) - 1.0);
                let z = z / (1.0 + y * y + z * z).sqrt();
                if z >= 0.0 {
                    hor * (1.0 - z) + zen * z
                } else {
                    hor * (1.0 + z) + nad * (-z)
                }
            };
            assert!(px(&img, c, r).approx_eq(e, 1e-6), "({c},{r}) {:?} vs {e:?}", px(&img, c, r));
        }
    }
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    let scene = furnace(16, 0.7, 1.0, pt(3, 8, 2, true));
    let opts = RenderOptions { spp: Some(3), ..RenderOptions::default() };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let a = one.install(|| render(&scene, &opts, Progress::Hidden));
    let b = render(&scene, &opts, Progress::Hidden);
    assert_eq!(a.image, b.image);
    assert_eq!(a.stats.rays, b.stats.rays);
    assert_eq!(a.stats.samples, 16 * 16 * 3 * 3);
}

#[test]
fn non_finite_samples_are_counted_and_dropped() {
    let mut b = SceneBuilder::new(4, 4);
    let m = b.material(Material::new(Brdf::default(), Pigment::Uniform(Color::gray(f64::INFINITY))));
    b.sphere(Transform::translation(DVec3::new(3.0, 0.0, 0.0)) * Transform::scaling(DVec3::splat(1.5)), m)
        .renderer(Renderer::Flat { background: Color::gray(0.5) });
    let out = render(&b.build().unwrap(), &RenderOptions::default(), Progress::Hidden);
    assert_eq!(out.stats.non_finite_samples, 4);
    assert_eq!(px(&out.image, 1, 1), Color::BLACK);
    assert_eq!(px(&out.image, 0, 0), Color::gray(0.5));
}

/// Renders a 16×12 scene with NEE on and off, two seeds each, and checks that the two
/// estimators agree: over the image mean and on each 4×4 block, within 5 (5.5 for the 12
/// blocks) standard errors estimated from the seed-to-seed differences. Returns the mean
/// per-pixel variances (NEE, BSDF only).
fn assert_nee_agrees(scene: impl Fn(bool, u64) -> Scene) -> (f64, f64) {
    let imgs: Vec<HdrImage> = [(true, 1), (true, 2), (false, 1), (false, 2)]
        .iter()
        .map(|&(nee, s)| run(&scene(nee, s), None).image)
        .collect();
    assert_eq!((imgs[0].width(), imgs[0].height()), (16, 12));
    // Per-pixel variance of each estimator from its two independent renders.
    let n = imgs[0].pixels().len() as f64;
    let var = |a: &HdrImage, b: &HdrImage| {
        a.pixels().iter().zip(b.pixels()).map(|(x, y)| f64::from(x.g - y.g).powi(2) / 2.0).sum::<f64>() / n
    };
    let mean = |a: &HdrImage| a.pixels().iter().map(|p| f64::from(p.g)).sum::<f64>() / n;
    let (v_on, v_off) = (var(&imgs[0], &imgs[1]), var(&imgs[2], &imgs[3]));
    // Image means (each over both seeds): difference has variance (v_on + v_off) / (2n).
    let m_on = (mean(&imgs[0]) + mean(&imgs[1])) / 2.0;
    let m_off = (mean(&imgs[2]) + mean(&imgs[3])) / 2.0;
    let se = ((v_on + v_off) / (2.0 * n)).sqrt();
    eprintln!("NEE {m_on} vs BSDF-only {m_off} ± {se}; pixel variances {v_on} vs {v_off}");
    assert!(se < 0.01 * m_on, "test too weak: se {se} mean {m_on}");
    assert!((m_on - m_off).abs() < 5.0 * se, "NEE {m_on} vs no NEE {m_off} (se {se})");
    // Blocks of 4×4 pixels: each block's difference within 5 standard errors.
    for by in 0..3 {
        for bx in 0..4 {
            let block = |img: &HdrImage| {
                let mut s = 0.0;
                for r in 0..4 {
                    for c in 0..4 {
                        s += f64::from(img.get(bx * 4 + c, by * 4 + r).g);
                    }
                }
                s / 16.0
            };
            let on = (block(&imgs[0]) + block(&imgs[1])) / 2.0;
            let off = (block(&imgs[2]) + block(&imgs[3])) / 2.0;
            // Block-local variance estimated the same way.
            let mut v = 0.0;
            for (a, b) in [(0, 1), (2, 3)] {
                for r in 0..4 {
                    for c in 0..4 {
                        let (x, y) = (bx * 4 + c, by * 4 + r);
                        v += f64::from(imgs[a].get(x, y).g - imgs[b].get(x, y).g).powi(2) / 2.0;
                    }
                }
            }
            let se_block = (v / 16.0 / (2.0 * 16.0)).sqrt().max(1e-6 * on.abs());
            assert!((on - off).abs() < 5.5 * se_block, "block ({bx},{by}): {on} vs {off} (se {se_block})");
        }
    }
    (v_on, v_off)
}

/// `lumen render` end to end on a tiny script.
mod cli {
    use std::path::Path;
    use std::process::Command;

    const SCRIPT: &str = r#"
        SET lamp Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)), .emitted_radiance Pigment.Uniform(<0.25, 0.5, 2>))
        SPAWN Shape.Sphere(.material lamp, .transformation TRANSLATE(.X 3) * SCALE 1.5)
        USING Camera.Perspective() Image(4, 4) Renderer.Flat(.background_color <1, 0, 0>) Tracer()
    "#;

    fn lumen(dir: &Path, args: &[&str]) -> std::process::Output {
        std::fs::write(dir.join("tiny.sl"), SCRIPT).unwrap();
        crate::common::lumen_command().current_dir(dir).arg("render").arg("tiny.sl").args(args).output().unwrap()
    }

    #[test]
    fn writes_pfm_and_png() {
        let dir = tempfile::tempdir().unwrap();
        let out = lumen(dir.path(), &["-o", "out.pfm", "-o", "out.png", "--device", "cpu", "--width", "8"]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        // --width 8 alone: the height follows from the camera's aspect ratio 1.
        let img = lumen::image::read_image(&dir.path().join("out.pfm")).unwrap();
        assert_eq!((img.width(), img.height()), (8, 8));
        // Flat: the sphere's emission (its pigment is black) in the middle, background at
        // the corners, exactly (linear radiance in the PFM).
        assert_eq!(img.get(4, 4), lumen::color::Rgb32::new(0.25, 0.5, 2.0));
        assert_eq!(img.get(0, 0), lumen::color::Rgb32::new(1.0, 0.0, 0.0));
        let png = lumen::image::read_image(&dir.path().join("out.png")).unwrap();
        assert_eq!((png.width(), png.height()), (8, 8));
    }

    /// The default device is the GPU; its image is the CPU's (Flat is exact in f32 here).
    #[test]
    fn renders_on_the_gpu_by_default() {
        if lumen::gpu::gpu_for_tests("cli_renders_on_the_gpu_by_default").is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let out = lumen(dir.path(), &["-o", "gpu.pfm", "--width", "8"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(stderr.contains("on the GPU"), "{stderr}");
        let out = lumen(dir.path(), &["-o", "cpu.pfm", "--width", "8", "--device", "cpu"]);
        assert!(out.status.success());
        let gpu = lumen::image::read_image(&dir.path().join("gpu.pfm")).unwrap();
        let cpu = lumen::image::read_image(&dir.path().join("cpu.pfm")).unwrap();
        assert_eq!(gpu.pixels(), cpu.pixels());
        assert_eq!(gpu.get(4, 4), lumen::color::Rgb32::new(0.25, 0.5, 2.0));
    }

    /// Compiled pipelines persist across runs in `$LUMEN_PIPELINE_CACHE` (one file per
    /// adapter and driver) where the device supports wgpu's pipeline cache (Vulkan), the
    /// next run reads it back and renders the same image, and `LUMEN_PIPELINE_CACHE=0`
    /// writes nothing (not even to `$XDG_CACHE_HOME`).
    #[test]
    fn pipeline_cache_persists_across_runs_and_can_be_disabled() {
        let Some(gpu) = lumen::gpu::gpu_for_tests("cli_pipeline_cache") else { return };
        let supported = gpu.device.features().contains(wgpu::Features::PIPELINE_CACHE);
        let dir = tempfile::tempdir().unwrap();
        let (cache, xdg) = (dir.path().join("cache"), dir.path().join("xdg"));
        // `cache`: the value of LUMEN_PIPELINE_CACHE, or unset.
        let render = |out: &str, cache: Option<&Path>| {
            std::fs::write(dir.path().join("tiny.sl"), SCRIPT).unwrap();
            let mut cmd = crate::common::lumen_command();
            cmd.current_dir(dir.path()).env_remove("LUMEN_PIPELINE_CACHE").env("XDG_CACHE_HOME", &xdg);
            if let Some(c) = cache {
                cmd.env("LUMEN_PIPELINE_CACHE", c);
            }
            let o = cmd.args(["render", "tiny.sl", "--device", "gpu", "--width", "8", "-o", out]).output().unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            lumen::image::read_image(&dir.path().join(out)).unwrap()
        };
        let files = |d: &Path| std::fs::read_dir(d).map(|r| r.count()).unwrap_or(0);
        let first = render("a.pfm", Some(&cache));
        assert_eq!(files(&cache), usize::from(supported), "one cache file iff the device supports it");
        let second = render("b.pfm", Some(&cache));
        assert_eq!(first.pixels(), second.pixels());
        // A damaged file only costs the compile time it would have saved: cut, extended,
        // overwritten, a byte flipped (the envelope's checksum refuses it before the driver
        // sees it), or whole but naming another device in wgpu's header (wgpu refuses that
        // even with `fallback`; the cache then starts empty). Each run rewrites it whole.
        if supported {
            let file = std::fs::read_dir(&cache).unwrap().next().unwrap().unwrap().path();
            let good = std::fs::read(&file).unwrap();
            let data = lumen::gpu::pipeline_cache::unwrap(&good).expect("a whole cache file").to_vec();
            let mut other_device = data.clone();
            other_device[20] ^= 0x5a; // in wgpu's adapter key (its header's bytes 17-31)
            let mut flipped = good.clone();
            flipped[40] ^= 1;
            let damaged = [
                good[..good.len() / 2].to_vec(),
                [good.clone(), vec![0; 9]].concat(),
                vec![0xA5; good.len()],
                flipped,
                lumen::gpu::pipeline_cache::wrap(&other_device),
                data,
            ];
            for (k, bytes) in damaged.iter().enumerate() {
                std::fs::write(&file, bytes).unwrap();
                let again = render(&format!("damaged{k}.pfm"), Some(&cache));
                assert_eq!(first.pixels(), again.pixels(), "damaged file {k}");
                assert!(lumen::gpu::pipeline_cache::unwrap(&std::fs::read(&file).unwrap()).is_some(), "{k}");
            }
        }
        render("c.pfm", Some(Path::new("0")));
        assert_eq!(files(&xdg.join("lumen")), 0, "disabled, yet written");
        // Unset, it defaults to $XDG_CACHE_HOME/lumen.
        render("d.pfm", None);
        assert_eq!(files(&xdg.join("lumen")), usize::from(supported));
    }

    /// `lumen shader` prints a kernel specialised to the script; `lumen check` its features.
    #[test]
    fn shader_and_check_show_the_specialised_kernel() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("tiny.sl"), SCRIPT).unwrap();
        let run = |args: &[&str]| crate::common::lumen_command().current_dir(dir.path()).args(args).output();
        let out = run(&["shader", "tiny.sl", "-o", "tiny.wgsl"]).unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let wgsl = std::fs::read_to_string(dir.path().join("tiny.wgsl")).unwrap();
        // Stage by stage (the first-hit integrators are one stage and the film).
        let stages: Vec<&str> = wgsl.split("\n// ===== stage ").skip(1).collect();
        assert_eq!(stages.len(), 2, "{wgsl}");
        let module =
            naga::front::wgsl::parse_str(stages[0].split_once('\n').unwrap().1).expect("the first stage parses");
        let has = |name: &str| module.functions.iter().any(|(_, f)| f.name.as_deref() == Some(name));
        assert!(has("sphere_span") && has("radiance_flat"), "the kernel lacks what the scene needs");
        assert!(!has("cylinder_span") && !has("sample_bsdf"), "the kernel holds what the scene does not use");
        assert!(stages[1].starts_with("film"), "{}", &stages[1][..40]);
        // The storage placement by default (hardware GPUs); the software adapters' on request.
        assert!(wgsl.contains("var<storage, read> shapes: array<Shape>;") && !wgsl.contains("var<uniform> shapes"));
        let out = run(&["shader", "tiny.sl", "--tables", "uniform", "-o", "uniform.wgsl"]).unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let wgsl = std::fs::read_to_string(dir.path().join("uniform.wgsl")).unwrap();
        assert!(wgsl.contains("var<uniform> shapes: array<Shape, UNIFORM_SHAPES_LEN>;"), "{wgsl}");
        assert!(!wgsl.contains("var<storage, read> shapes"));
        let out = run(&["shader", "tiny.sl", "--tables", "texture", "-o", "texture.wgsl"]).unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let wgsl = std::fs::read_to_string(dir.path().join("texture.wgsl")).unwrap();
        assert!(wgsl.contains("var shapes: texture_2d<u32>;") && wgsl.contains("fn shape_at(k: u32) -> Shape {"));
        assert!(!wgsl.contains("var<storage, read> shapes") && !wgsl.contains("var<uniform> shapes"));
        let out = run(&["check", "tiny.sl"]).unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("GPU kernel features:") && stdout.contains(" SPHERE ") && stdout.contains("FLAT"));
        assert!(!stdout.contains("CYLINDER"), "{stdout}");
        let out = run(&["shader", "missing.sl"]).unwrap();
        assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("missing.sl"));
        // GPU-only options under --device cpu: rendered, with a note that they are ignored.
        let dir = tempfile::tempdir().unwrap();
        let out = lumen(dir.path(), &["-o", "o.pfm", "--device", "cpu", "--batch-paths", "4096"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success()
                && stderr.contains("note: --batch-paths only applies to GPU renders; --device cpu ignores it"),
            "{stderr}"
        );
        // An output in a missing directory is said in words, before the work.
        let out = run(&["shader", "tiny.sl", "-o", "nodir/x.wgsl"]).unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains("cannot write nodir/x.wgsl") && stderr.contains("directory nodir does not exist"),
            "{stderr}"
        );
    }

    /// `--frames` renders TIME over the range into numbered files, and an mp4 with ffmpeg.
    #[test]
    fn frames_render_time_into_numbered_files() {
        let dir = tempfile::tempdir().unwrap();
        let script = SCRIPT.replace("TRANSLATE(.X 3)", "TRANSLATE(.X 3, .Y $4*TIME$)");
        std::fs::write(dir.path().join("anim.sl"), script).unwrap();
        let out = crate::common::lumen_command()
            .current_dir(dir.path())
            .args(["render", "anim.sl", "--device", "cpu", "--frames", "0:1:3", "-o", "f.pfm", "-o", "f.png"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        let frame = |k: u32| lumen::image::read_image(&dir.path().join(format!("f_000{k}.pfm"))).unwrap();
        // TIME 0: the sphere fills the centre; TIME 1: it has moved 4 units to the side.
        assert_eq!(frame(1).get(2, 2), lumen::color::Rgb32::new(0.25, 0.5, 2.0));
        assert_eq!(frame(3).get(2, 2), lumen::color::Rgb32::new(1.0, 0.0, 0.0));
        assert!(dir.path().join("f_0003.png").exists() && !dir.path().join("f_0004.png").exists());
        // The video exists exactly when ffmpeg does.
        let ffmpeg = Command::new("ffmpeg").arg("-version").output().is_ok();
        assert_eq!(dir.path().join("f.mp4").exists(), ffmpeg, "{stderr}");
        if !ffmpeg {
            assert!(stderr.contains("ffmpeg is not on PATH"), "{stderr}");
        }
        // TIME may start below 0 (clap took `-1:0:2` for a flag until 2026-12-07).
        let out = crate::common::lumen_command()
            .current_dir(dir.path())
            .args(["render", "anim.sl", "--device", "cpu", "--frames", "-1:0:2", "-o", "g.pfm"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let frame = |k: u32| lumen::image::read_image(&dir.path().join(format!("g_000{k}.pfm"))).unwrap();
        assert_eq!(frame(1).get(2, 2), lumen::color::Rgb32::new(1.0, 0.0, 0.0)); // moved 4 units away
        assert_eq!(frame(2).get(2, 2), lumen::color::Rgb32::new(0.25, 0.5, 2.0));
    }

    /// What would fail after some frames were rendered is checked before the first: a frame's
    /// output that is a directory, the script at a later TIME, the video's destination; and
    /// the video holds this animation's frames only, whatever the name (`%` included) and
    /// whatever numbered files a longer animation left.
    #[test]
    fn an_animation_checks_every_frame_before_the_first() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("anim.sl"), SCRIPT).unwrap();
        // Infinite at TIME = 1, the second of two frames.
        let late = SCRIPT.replace("TRANSLATE(.X 3)", "TRANSLATE(.X 3) * SCALE $1/(1-TIME)$");
        assert_ne!(late, SCRIPT);
        std::fs::write(dir.path().join("late.sl"), late).unwrap();
        let run = |args: &[&str]| {
            crate::common::lumen_command()
                .current_dir(dir.path())
                .args(["render", "--device", "cpu"])
                .args(args)
                .output()
                .unwrap()
        };
        let names = || {
            let mut n: Vec<String> =
                std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
            n.sort();
            n
        };
        std::fs::create_dir(dir.path().join("out_0002.png")).unwrap();
        let out = run(&["anim.sl", "--frames", "0:1:3", "-o", "out.png"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("cannot write out_0002.png") && stderr.contains("it is a directory"), "{stderr}");
        let out = run(&["late.sl", "--frames", "0:1:2", "-o", "late.png"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("frame 2 of 2 (TIME = 1)") && stderr.contains("late.sl:"), "{stderr}");
        assert_eq!(names(), ["anim.sl", "late.sl", "out_0002.png"], "nothing rendered: {stderr}");
        if Command::new("ffmpeg").arg("-version").output().is_err() {
            println!("ffmpeg is not on PATH: the video's checks are skipped");
            return;
        }
        std::fs::create_dir(dir.path().join("v.mp4")).unwrap();
        let out = run(&["anim.sl", "--frames", "0:1:2", "-o", "v.png"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.code() == Some(1) && stderr.contains("cannot write v.mp4"), "{stderr}");
        assert!(!dir.path().join("v_0001.png").exists(), "{stderr}");
        // Three frames, then two under the same name: the video has two.
        for (frames, want) in [("0:1:3", "3"), ("0:1:2", "2")] {
            let out = run(&["anim.sl", "--width", "8", "--frames", frames, "-o", "p%d.png"]);
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            let Ok(probe) = Command::new("ffprobe")
                .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
                .args(["-show_entries", "stream=nb_read_frames", "-of", "csv=p=0"])
                .arg(dir.path().join("p%d.mp4"))
                .output()
            else {
                return;
            };
            assert_eq!(String::from_utf8_lossy(&probe.stdout).trim(), want, "{frames}");
        }
    }

    /// A CSG tree past the GPU's span pool (a chain of FUSEs of 2¹⁷ spheres): `lumen check`
    /// says the GPU renderer cannot take it, naming the tree's SPAWN position and leaves,
    /// before any render finds it.
    #[test]
    fn check_says_what_the_gpu_renderer_refuses() {
        let dir = tempfile::tempdir().unwrap();
        let mut script = String::from("SET c0 FUSE(Shape.Sphere(), Shape.Sphere(.transformation TRANSLATE(.X 0.5)))\n");
        for i in 1..=16 {
            script += &format!("SET c{i} FUSE(c{}, c{})\n", i - 1, i - 1);
        }
        script += "SPAWN Shape.Plane(.transformation TRANSLATE(.Z -2))\n  c16\nUSING Camera.Perspective() Image(8, 8) Renderer.Flat() Tracer()\n";
        std::fs::write(dir.path().join("chain.sl"), &script).unwrap();
        let out = crate::common::lumen_command().current_dir(dir.path()).args(["check", "chain.sl"]).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let refusal = "GPU renderer: cannot take this scene: shape 2 in spawn order (a CSG tree of 131072 leaves, written at chain.sl:19:3)";
        assert!(stdout.contains(refusal), "{stdout}");
        // One leaf fewer per FUSE level: no refusal.
        std::fs::write(dir.path().join("ok.sl"), script.replace("c16\n", "c15\n")).unwrap();
        let out = crate::common::lumen_command().current_dir(dir.path()).args(["check", "ok.sl"]).output().unwrap();
        assert!(
            !String::from_utf8_lossy(&out.stdout).contains("GPU renderer"),
            "{}",
            String::from_utf8_lossy(&out.stdout)
        );
    }

    /// An ffmpeg that fails after writing part of the video (a stand-in on PATH) leaves no
    /// video and no temporary file: the error names the video, the frames stay.
    #[cfg(unix)]
    #[test]
    fn a_failed_video_assembly_leaves_no_partial_video() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let bin = dir.path().join("bin");
        std::fs::create_dir(&bin).unwrap();
        let fake = bin.join("ffmpeg");
        // `-version` succeeds; an assembly writes half a file at its last argument and fails.
        std::fs::write(
            &fake,
            "#!/bin/sh\n[ \"$1\" = -version ] && exit 0\nfor a; do last=$a; done\necho partial > \"$last\"\nexit 1\n",
        )
        .unwrap();
        std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
        let work = dir.path().join("work");
        std::fs::create_dir(&work).unwrap();
        std::fs::write(work.join("anim.sl"), SCRIPT).unwrap();
        let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
        let out = crate::common::lumen_command()
            .current_dir(&work)
            .env("PATH", path)
            .args(["render", "anim.sl", "--device", "cpu", "--frames", "0:1:2", "-o", "f.png"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("cannot assemble f.mp4") && stderr.contains("ffmpeg failed"), "{stderr}");
        let mut names: Vec<String> =
            std::fs::read_dir(&work).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        names.sort();
        assert_eq!(names, ["anim.sl", "f_0001.png", "f_0002.png"]);
    }

    #[test]
    fn bad_arguments_fail_without_output() {
        let dir = tempfile::tempdir().unwrap();
        for args in [
            &["-o", "out.png", "--spp", "0"][..],
            &["-o", "out.png", "--width", "0"],
            &["-o", "out.png", "--height", "100000"],
            &["-o", "out.png", "--device", "gpu", "--adapter", "no-such-adapter-xyz"],
            &["-o", "out.png", "--device", "auto", "--adapter", "no-such-adapter-xyz"],
            &["-o", "out.png", "--time-limit", "-1"],
            &["-o", "out.png", "--alpha", "-1"],
            &["-o", "out.png", "--frames", "0:1:0"],
            &["-o", "out.png", "-o", "out.txt"],
            &["-o", "out.png", "--vars", "x <1, 2>"],
            &["-o", "out.png", "-o", "./out.png"],
        ] {
            let out = lumen(dir.path(), args);
            assert!(!out.status.success(), "{args:?} succeeded");
            assert!(!String::from_utf8_lossy(&out.stderr).is_empty());
            assert!(!dir.path().join("out.png").exists(), "{args:?} left an output");
        }
        let out =
            crate::common::lumen_command().args(["render", "missing.sl"]).current_dir(dir.path()).output().unwrap();
        assert!(!out.status.success());
    }

    /// A malformed value is a usage error (exit 2) whatever the option, as clap's own are:
    /// `--time nan`, `--frames`, `--shard` and `--samples` exited 1 after the script loaded.
    #[test]
    fn malformed_values_are_usage_errors() {
        let dir = tempfile::tempdir().unwrap();
        for (option, value, said) in [
            ("--time", "nan", "nan is not a finite number"),
            ("--time", "1e400", "beyond f64's range"),
            ("--frames", "0:nan:2", "END: nan is not a finite number"),
            ("--frames", "0:1", "expected START:END:COUNT"),
            ("--shard", "0/0", "is not a shard"),
            ("--samples", "2:2", "is not a sample range"),
            ("--alpha", "1e39", "f32's range"),
        ] {
            let out = lumen(dir.path(), &["--device", "cpu", "-o", "out.png", option, value]);
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{option} {value}: {err}");
            assert!(err.contains(option) && err.contains(said), "{option} {value}: {err}");
            assert!(!dir.path().join("out.png").exists());
        }
    }
}

/// Rounds of samples (issue 16, item 5): time limits and cancellation keep the same number
/// of samples in every pixel, and the split into rounds never changes an image.
mod rounds {
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    use std::time::Duration;

    use lumen::cpu::{add_samples, context::Context, lights::Lights, render_limited, Limits, World};
    use lumen::stop::StopReason;

    use super::*;

    /// A path-traced furnace with 2 paths per sample: every sample's value differs.
    fn scene() -> Scene {
        let mut s = furnace(12, 0.7, 1.0, pt(2, 6, 2, true));
        s.height = 10;
        s
    }

    fn limited(scene: &Scene, spp: u32, limits: Limits) -> RenderOutput {
        render_limited(scene, &RenderOptions { spp: Some(spp), ..RenderOptions::default() }, &limits, Progress::Hidden)
            .unwrap()
    }

    fn bits(img: &HdrImage) -> Vec<[u32; 3]> {
        img.pixels().iter().map(|p| [p.r.to_bits(), p.g.to_bits(), p.b.to_bits()]).collect()
    }

    /// The mean of samples `0..spp` of every pixel (of the scene's `total`-sample layout),
    /// summed in one go.
    fn one_pass_mean(scene: &Scene, total: u32, spp: u32) -> HdrImage {
        let (world, lights) = (World::new(scene), Lights::new(scene));
        let layout = lumen::prepare::pixel_samples::PixelSamples::new(&scene.tracer, Some(total));
        let ctx = Context::new(scene, &world, &lights, layout);
        let n = f64::from(spp) * lumen::cpu::paths_per_sample(scene) as f64;
        HdrImage::from_fn(scene.width as usize, scene.height as usize, |c, r| {
            let mut sum = Color::BLACK;
            add_samples(&ctx, layout, c as u32, r as u32, 0..spp, &mut sum, &mut Default::default(), &mut 0);
            (sum / n).into()
        })
    }

    #[test]
    fn splitting_into_rounds_does_not_change_a_bit() {
        let s = scene();
        let whole = limited(&s, 9, Limits { round_spp: Some(9), ..Limits::default() });
        assert_eq!((whole.stats.rounds, whole.stats.spp, whole.stats.stop), (1, 9, StopReason::Completed));
        assert_eq!(bits(&whole.image), bits(&one_pass_mean(&s, 9, 9)));
        assert_eq!(
            whole.image,
            render(&s, &RenderOptions { spp: Some(9), ..RenderOptions::default() }, Progress::Hidden).image
        );
        for round in [1, 2, 4] {
            let split = limited(&s, 9, Limits { round_spp: Some(round), ..Limits::default() });
            assert_eq!(split.stats.rounds, 9u32.div_ceil(round));
            assert_eq!(bits(&split.image), bits(&whole.image), "rounds of {round} spp");
            assert_eq!((split.stats.rays, split.stats.samples), (whole.stats.rays, whole.stats.samples));
        }
    }

    #[test]
    fn a_time_limit_stops_between_rounds_with_uniform_spp() {
        let s = scene();
        // A zero limit has passed after the first round, whatever the machine's speed.
        for (round, want) in [(None, 1), (Some(3), 3)] {
            let limits = Limits { time_limit: Some(Duration::ZERO), round_spp: round, ..Limits::default() };
            let out = limited(&s, 9, limits);
            assert_eq!((out.stats.stop, out.stats.spp, out.stats.spp_requested), (StopReason::TimeLimit, want, 9));
            assert_eq!(out.stats.samples, 12 * 10 * want * 2);
            // Every pixel holds exactly samples 0..want.
            assert_eq!(bits(&out.image), bits(&one_pass_mean(&s, 9, want as u32)), "{round:?}");
        }
        // A limit that is never reached takes every sample.
        let limits = Limits { time_limit: Some(Duration::from_secs(3600)), ..Limits::default() };
        assert_eq!(limited(&s, 4, limits).stats.stop, StopReason::Completed);
    }

    #[test]
    fn a_cancel_flag_set_before_the_start_renders_nothing() {
        let s = scene();
        let limits = Limits { cancel: Some(Arc::new(AtomicBool::new(true))), ..Limits::default() };
        let out = limited(&s, 9, limits);
        assert_eq!(
            (out.stats.stop, out.stats.spp, out.stats.samples, out.stats.rays),
            (StopReason::Interrupted, 0, 0, 0)
        );
        assert!(out.image.pixels().iter().all(|p| *p == lumen::color::Rgb32::BLACK));
    }

    #[test]
    fn a_cancel_during_the_render_keeps_only_whole_rounds() {
        let s = scene();
        // A machine slow enough to take 30 ms over the first round stops with nothing to
        // compare; then the render is tried again.
        for _ in 0..10 {
            let flag = Arc::new(AtomicBool::new(false));
            let setter = {
                let flag = Arc::clone(&flag);
                std::thread::spawn(move || {
                    std::thread::sleep(Duration::from_millis(30));
                    flag.store(true, std::sync::atomic::Ordering::SeqCst);
                })
            };
            // Rounds of 1 spp over 65,536 spp: the flag lands during some round, whenever it comes.
            let limits = Limits { cancel: Some(flag), round_spp: Some(1), ..Limits::default() };
            let out = limited(&s, 1 << 16, limits);
            setter.join().unwrap();
            let done = out.stats.spp;
            assert_eq!((out.stats.stop, u64::from(out.stats.rounds)), (StopReason::Interrupted, done));
            assert_eq!(out.stats.samples, 12 * 10 * done * 2);
            if done > 0 {
                // Every pixel holds exactly samples 0..done.
                assert_eq!(bits(&out.image), bits(&one_pass_mean(&s, 1 << 16, done as u32)));
                return;
            }
        }
        panic!("in 10 tries the cancel always came before the first round was complete");
    }
}

#[test]
fn rough_materials_under_uniform_sky_conserve_energy() {
    // An F = 1 GGX sphere, rough clear glass and a white plastic neither absorb nor emit:
    // with the multiple-scattering compensation every pixel sees the sky (1 %), with or
    // without NEE (which exercises eval and pdf through MIS). The BSDF-level furnace
    // (cpu::microfacet) checks 1 %; here 2 % covers four standard errors.
    let sky = 1.5;
    let white = Pigment::Uniform(Color::WHITE);
    let brdfs = [
        Brdf::Conductor { pigment: white.clone(), roughness: 0.8, fresnel: None, multiple_scattering: true },
        Brdf::Dielectric { pigment: white.clone(), ior: 1.5, roughness: 0.5, multiple_scattering: true },
        Brdf::Plastic { pigment: white, ior: 1.5, roughness: 0.3 },
    ];
    for brdf in brdfs {
        for nee in [false, true] {
            let (scene, mask) = object_under_sky(brdf.clone(), sky, pt(256, 48, 1000, nee));
            let out = run(&scene, None);
            let (mean, se) = mean_and_stderr(&out.image, |c, r| mask.get(c, r).g > 0.5);
            eprintln!("{brdf:?} under the sky, nee {nee}: {mean} ± {se} (expected {sky})");
            assert!(4.0 * se < 0.02 * sky, "test too weak: se {se}");
            assert!((mean / sky - 1.0).abs() < 0.02, "{brdf:?} nee {nee}: {mean} (se {se})");
        }
    }
}

/// Stratified vertex draws (DESIGN.md "Random numbers"): a wall lit directly by a sphere
/// lamp out of view, 64 samples per pixel. With independent draws the variance of a pixel's
/// mean over seeds is its one-sample variance over 64; the camera's strata alone bring it
/// to about 0.73 of that here (measured with the vertex strata turned off), the light
/// point and the BSDF direction spread over an 8 × 8 grid to about 0.09.
#[test]
fn stratified_draws_cut_the_variance_of_direct_light() {
    let script = "\
SET
    lamp Material(Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)), Pigment.Uniform(<4, 4, 4>))
    wall Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.8, 0.8>)))
SPAWN
    Shape.Plane(wall, TRANSLATE(.X 3) * ROTATE(.Y 90))
    Shape.Sphere(lamp, TRANSLATE(1.5, 2.5, 0.5) * SCALE 0.6)
USING
    Camera.Perspective(.screen_distance 2)
    Renderer.PathTracer(.n 1, .max_depth 1)
    Image(16, 16)
    Tracer(.samples_per_side 8)
";
    let base =
        lumen::scenelang::load_str(script, "lit_wall.sl", std::path::Path::new("."), &Default::default()).unwrap();
    // Per-pixel variance over `seeds` renders of `spp` samples, averaged over the pixels.
    let variance = |spp: u32, seeds: u64| -> f64 {
        let images: Vec<Vec<f64>> = (0..seeds)
            .map(|k| {
                let mut s = base.clone();
                s.tracer.rng = PcgSeed { state: 0x1234_5678 + 977 * k, inc: 54 };
                let out = render(&s, &RenderOptions { spp: Some(spp), ..RenderOptions::default() }, Progress::Hidden);
                out.image.pixels().iter().map(|p| f64::from(p.g)).collect()
            })
            .collect();
        let pixels = images[0].len();
        let mut total = 0.0;
        for i in 0..pixels {
            let xs: Vec<f64> = images.iter().map(|im| im[i]).collect();
            let mean = xs.iter().sum::<f64>() / xs.len() as f64;
            total += xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (xs.len() - 1) as f64;
        }
        total / pixels as f64
    };
    let one = variance(1, 200);
    let many = variance(64, 24);
    assert!(one > 1e-4, "the one-sample estimate should be noisy: variance {one}");
    let ratio = many * 64.0 / one;
    assert!(ratio < 0.25, "64 stratified samples: {ratio:.3} of the independent variance");
}

/// A cube lamp beside the view lights a diffuse floor, direct light only
/// (`common::cube_lamp_over_a_floor`): the image is Lambert's closed form. NEE samples only
/// the lamp faces a point is in front of (cpu::area_light), by area on a parallelepiped and
/// by solid angle on a box's faces seen close by: a face skipped where it shows, or a
/// density that disagrees with the sampling (in NEE or in MIS), would bias it.
#[test]
fn a_cube_lamp_lights_a_diffuse_floor_as_lamberts_formula_says() {
    for sheared in [true, false] {
        let (scene, want) = common::cube_lamp_over_a_floor(sheared);
        let img = run(&scene, None).image;
        common::assert_close_to_closed_form(&img, &want, 0.05, 0.005);
    }
}
