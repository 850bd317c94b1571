//! The stability cases (issue 7), shared by `tests/stability.rs` (which asserts them) and
//! `examples/stability_table.rs` (which prints the table of docs/STABILITY.md).
//!
//! Every case renders one or more small scenes on the CPU (f64 reference) and, when a GPU
//! is given, on the GPU (f32), and measures both against an answer that does not come
//! from either renderer: a closed form, an analytic classification of each camera sample,
//! or the image of the same scene at unit scale. Both renderers must report zero NaN/Inf
//! samples in every render (checked in [`render_both`]).

#![allow(dead_code)]

#[path = "../common/mod.rs"]
mod common;

use glam::DVec3;
use lumen::color::Color;
use lumen::cpu::{Progress, RenderOptions};
use lumen::gpu::render::{render as gpu_render, GpuRenderOptions};
use lumen::gpu::Gpu;
use lumen::image::HdrImage;
use lumen::prepare::pixel_samples::PixelSamples;
use lumen::scene::*;

use common::{agreement, mean_and_stderr, pt, Agreement, Tolerance};

/// The result of one case: its errors on each renderer against the expected answer.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub case: String,
    /// The expected answer, in words.
    pub expected: String,
    /// What the error numbers measure.
    pub metric: &'static str,
    /// Largest acceptable error, for the CPU and the GPU.
    pub cpu_tolerance: f64,
    pub gpu_tolerance: f64,
    pub cpu: f64,
    /// `None` without a GPU.
    pub gpu: Option<f64>,
    /// Share of pixels where the GPU image agrees with the CPU image (1e-3 relative or
    /// 1e-4 absolute), over every image the case rendered.
    pub gpu_agrees_with_cpu: Option<f64>,
    /// Smallest acceptable share of agreeing pixels.
    pub min_agreement: f64,
    /// The whole GPU-vs-CPU comparison, worst over the case's images: the share above, and
    /// how far off the other pixels and the image means are (each bounded by 2 % in
    /// [`Outcome::check`]).
    pub gpu_vs_cpu: Option<Agreement>,
    /// Extra facts for the table (sample counts, standard errors, …).
    pub note: String,
}

impl Outcome {
    /// A case with its expected answer and error measure, zero tolerances, a CPU error of 0,
    /// no GPU error and no agreement requirement: the methods below fill in the rest.
    pub fn new(case: impl Into<String>, expected: impl Into<String>, metric: &'static str) -> Self {
        Self {
            case: case.into(),
            expected: expected.into(),
            metric,
            cpu_tolerance: 0.0,
            gpu_tolerance: 0.0,
            cpu: 0.0,
            gpu: None,
            gpu_agrees_with_cpu: None,
            min_agreement: 0.0,
            gpu_vs_cpu: None,
            note: String::new(),
        }
    }

    /// Largest acceptable errors on the CPU and the GPU.
    pub fn tolerances(mut self, cpu: f64, gpu: f64) -> Self {
        (self.cpu_tolerance, self.gpu_tolerance) = (cpu, gpu);
        self
    }

    /// The measured errors.
    pub fn values(mut self, cpu: f64, gpu: Option<f64>) -> Self {
        (self.cpu, self.gpu) = (cpu, gpu);
        self
    }

    /// The errors as `err` measures the CPU image and, when there is one, the GPU image.
    pub fn errors(self, cpu: &HdrImage, gpu: Option<&HdrImage>, err: impl Fn(&HdrImage) -> f64) -> Self {
        let (c, g) = (err(cpu), gpu.map(&err));
        self.values(c, g)
    }

    /// [`Outcome::errors`] and [`Outcome::agreement`] of the same images.
    pub fn measure(self, cpu: &HdrImage, gpu: Option<&HdrImage>, err: impl Fn(&HdrImage) -> f64, min: f64) -> Self {
        self.errors(cpu, gpu, err).agreement(cpu, gpu, min)
    }

    /// GPU-vs-CPU agreement of one more pair of images (the worst over the case's images
    /// is kept), and the smallest acceptable share; nothing without a GPU image.
    pub fn agreement(self, cpu: &HdrImage, gpu: Option<&HdrImage>, min: f64) -> Self {
        self.agreement_of(gpu.map(|g| agreement(g, cpu)), min)
    }

    /// As [`Outcome::agreement`], from a comparison made elsewhere.
    pub fn agreement_of(mut self, a: Option<Agreement>, min: f64) -> Self {
        if let Some(a) = a {
            let worst = match self.gpu_vs_cpu.take() {
                None => a,
                Some(b) => Agreement {
                    share: a.share.min(b.share),
                    outlier_error: a.outlier_error.max(b.outlier_error),
                    mean_error: a.mean_error.max(b.mean_error),
                    worst: if a.share < b.share { a.worst } else { b.worst },
                },
            };
            self.gpu_agrees_with_cpu = Some(worst.share);
            self.gpu_vs_cpu = Some(worst);
        }
        self.min_agreement = min;
        self
    }

    pub fn note(mut self, note: impl Into<String>) -> Self {
        self.note = note.into();
        self
    }

    /// Panics with the whole outcome if any error exceeds its tolerance.
    pub fn check(&self) {
        println!("{self:#?}");
        assert!(self.cpu.is_finite() && self.cpu <= self.cpu_tolerance, "CPU: {self:#?}");
        if let Some(g) = self.gpu {
            assert!(g.is_finite() && g <= self.gpu_tolerance, "GPU: {self:#?}");
        }
        if let Some(a) = &self.gpu_vs_cpu {
            // The images are small (one pixel of 256 is 0.4 %), so a single hit/miss flip
            // between f32 and f64 moves the mean by ~0.5 % (lavapipe, the worst case): the
            // means get the outliers' 2 % rather than the default 1 %.
            let tol = Tolerance { max_mean_error: 0.02, ..Tolerance::share(self.min_agreement) };
            if let Err(e) = a.check(tol) {
                panic!("GPU vs CPU: {e}\n{self:#?}");
            }
        }
    }
}

// ------------------------------------------------------------------------ rendering

/// The CPU image and, with a GPU, the GPU image of `scene`; both must have no NaN/Inf
/// sample and the GPU must finish every sample.
pub fn render_both(gpu: Option<&Gpu>, scene: &Scene, spp: Option<u32>) -> (HdrImage, Option<HdrImage>) {
    let c = lumen::cpu::render(scene, &RenderOptions { spp, ..RenderOptions::default() }, Progress::Hidden);
    assert_eq!(c.stats.non_finite_samples, 0, "CPU reported NaN/Inf samples");
    assert!(c.image.pixels().iter().all(|p| p.r.is_finite() && p.g.is_finite() && p.b.is_finite()));
    let g = gpu.map(|gpu| {
        let out = gpu_render(gpu, scene, &GpuRenderOptions::fixed_passes(spp, 4)).expect("GPU render");
        assert_eq!(out.non_finite_samples, 0, "GPU reported NaN/Inf samples");
        assert_eq!(out.spp_done, out.spp_requested);
        assert!(out.image.pixels().iter().all(|p| p.r.is_finite() && p.g.is_finite() && p.b.is_finite()));
        out.image
    });
    (c.image, g)
}

/// An orthogonal camera whose screen is the square of half-side `half` (times the aspect
/// ratio horizontally) centred on `centre`'s y and z, with rays along +x starting at
/// `centre.x`.
fn ortho(centre: DVec3, half: f64, aspect: f64) -> Camera {
    Camera {
        projection: Projection::Orthogonal,
        aspect_ratio: aspect,
        transform: Transform::translation(centre + DVec3::new(half, 0.0, 0.0)) * Transform::scaling(DVec3::splat(half)),
    }
}

/// The f64 camera ray through the centre of pixel (col, row).
fn centre_ray(scene: &Scene, col: usize, row: usize) -> CameraRay {
    let u = (col as f64 + 0.5) / f64::from(scene.width);
    let v = 1.0 - (row as f64 + 0.5) / f64::from(scene.height);
    scene.camera.ray(u, v)
}

/// Largest relative error of the green channel against `expected`, over every pixel.
fn max_relative_error(img: &HdrImage, expected: f64) -> f64 {
    img.pixels().iter().map(|p| (f64::from(p.g) / expected - 1.0).abs()).fold(0.0, f64::max)
}

/// Largest channel value over every pixel.
fn max_radiance(img: &HdrImage) -> f64 {
    img.pixels().iter().map(|p| f64::from(p.r.max(p.g).max(p.b))).fold(0.0, f64::max)
}

fn g(img: &HdrImage, col: usize, row: usize) -> f64 {
    f64::from(img.get(col, row).g)
}

// ------------------------------------------------------- analytic first hits (f64, exact)

/// Crossings of the ray with one leaf, in the ray's parameter, from its object-space solid.
fn leaf_crossings(kind: ShapeKind, to_world: &Transform, o: DVec3, d: DVec3) -> Vec<f64> {
    let inv = to_world.inverse();
    let (o, d) = (inv.point(o), inv.vector(d));
    match kind {
        ShapeKind::Sphere => {
            // Closest approach by the cross product (no cancellation), then the two roots.
            let a = d.length_squared();
            let tc = -o.dot(d) / a;
            let h2 = o.cross(d).length_squared() / a;
            if h2 >= 1.0 {
                return vec![];
            }
            let half = ((1.0 - h2) / a).sqrt();
            vec![tc - half, tc + half]
        }
        ShapeKind::Cube => {
            let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
            for i in 0..3 {
                if d[i] == 0.0 {
                    if o[i].abs() > 0.5 {
                        return vec![];
                    }
                    continue;
                }
                let (a, b) = ((-0.5 - o[i]) / d[i], (0.5 - o[i]) / d[i]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
            if t0 < t1 {
                vec![t0, t1]
            } else {
                vec![]
            }
        }
        k => panic!("analytic crossings of {k:?} are not needed here"),
    }
}

fn leaf_contains(kind: ShapeKind, to_world: &Transform, p: DVec3) -> bool {
    let q = to_world.inverse().point(p);
    match kind {
        ShapeKind::Sphere => q.length_squared() < 1.0,
        ShapeKind::Cube => q.abs().max_element() < 0.5,
        k => panic!("analytic membership of {k:?} is not needed here"),
    }
}

/// Point membership of a shape (CSG by set operations on the children).
fn contains(shape: &Shape, parent: &Transform, p: DVec3) -> bool {
    match shape {
        Shape::Primitive(pr) => leaf_contains(pr.kind, &(*parent * pr.transform), p),
        Shape::Mesh(_) => panic!("analytic membership of meshes is not needed here"),
        Shape::Csg(c) => {
            let t = *parent * c.transform;
            let mut inside = c.children.iter().map(|ch| contains(ch, &t, p));
            match c.op {
                CsgOp::Unite | CsgOp::Fuse => inside.any(|x| x),
                CsgOp::Intersect => inside.all(|x| x),
                CsgOp::Diff => inside.next().unwrap_or(false) && !inside.any(|x| x),
            }
        }
    }
}

/// The first point where the ray (t ≥ 1) enters `shape`, with the material of the leaf
/// whose surface it is: every leaf crossing, sorted; the first gap longer than `sliver`
/// (relative) whose midpoint lies inside the solid starts at the hit. Independent of the
/// renderers' interval lists.
fn first_entry(shape: &Shape, o: DVec3, d: DVec3, sliver: f64) -> Option<(f64, MaterialId)> {
    let mut ts: Vec<(f64, MaterialId)> = Vec::new();
    shape.for_each_primitive(&mut |p, t| {
        ts.extend(leaf_crossings(p.kind, t, o, d).into_iter().map(|x| (x, p.material)));
    });
    ts.retain(|x| x.0 >= 1.0);
    ts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut prev: Option<(f64, MaterialId)> = None;
    for &(t, m) in &ts {
        if let Some((t0, m0)) = prev {
            if t - t0 > sliver * t.abs().max(1.0) && contains(shape, &Transform::IDENTITY, o + d * (0.5 * (t0 + t))) {
                return Some((t0, m0));
            }
        }
        prev = Some((t, m));
    }
    None
}

/// The analytic first hit of the centre ray of pixel (col, row), or `None` for pixels
/// whose answer changes when the ray moves by `e` pixels: [`CPU_MARGIN`] for the f64
/// renderer, [`GPU_MARGIN`] for f32, whose coordinates (the camera-relative object
/// positions included) resolve only ~1e-7 relative.
fn analytic_material(scene: &Scene, shape: &Shape, col: usize, row: usize, e: f64) -> Option<Option<MaterialId>> {
    let (w, h) = (f64::from(scene.width), f64::from(scene.height));
    let at = |du: f64, dv: f64| {
        let r = scene.camera.ray((col as f64 + 0.5 + du) / w, 1.0 - (row as f64 + 0.5 + dv) / h);
        first_entry(shape, r.origin, r.dir, 1e-9).map(|x| x.1)
    };
    let m = at(0.0, 0.0);
    [(e, 0.0), (-e, 0.0), (0.0, e), (0.0, -e)].iter().all(|&(a, b)| at(a, b) == m).then_some(m)
}

/// Ambiguity margins (in pixels) of [`analytic_material`].
pub const CPU_MARGIN: f64 = 1e-4;
pub const GPU_MARGIN: f64 = 1e-2;

/// The most pixels of an image an analytic check may skip as ambiguous (within its margin
/// of an edge): a few per cent, so that a broken classifier cannot pass a case by calling
/// most of the image ambiguous.
fn check_ambiguous(scene: &Scene, ambiguous: usize) {
    let pixels = scene.width as usize * scene.height as usize;
    assert!(ambiguous * 20 <= pixels, "{ambiguous} of {pixels} pixels ambiguous");
}

/// Flat rendering: pixels whose colour is not that of the analytic first hit's material
/// (black for a miss), out of the unambiguous pixels; returns (mismatches, ambiguous).
fn flat_mismatches(scene: &Scene, img: &HdrImage, shape: &Shape, e: f64) -> (usize, usize) {
    let (mut bad, mut ambiguous) = (0, 0);
    for row in 0..scene.height as usize {
        for col in 0..scene.width as usize {
            let Some(m) = analytic_material(scene, shape, col, row, e) else {
                ambiguous += 1;
                continue;
            };
            let want = m.map_or(Color::BLACK, |m| scene.material(m).brdf.pigment().color_at(0.0, 0.0));
            let got: Color = img.get(col, row).into();
            if (got - want).max_component().abs() > 1e-6 || (want - got).max_component().abs() > 1e-6 {
                if std::env::var("STAB_DEBUG").is_ok() {
                    eprintln!("pixel ({col},{row}): got {got:?} want {want:?}");
                }
                bad += 1;
            }
        }
    }
    check_ambiguous(scene, ambiguous);
    (bad, ambiguous)
}

// ------------------------------------------------------------ 1. scale and translation

/// A small path-traced scene with every feature the scale must not change: a plane, a
/// diffuse sphere, a rotated cube, a glass sphere, a spherical area light, a point light
/// with linear falloff and a uniform environment.
pub fn unit_scene() -> Scene {
    let mut b = SceneBuilder::new(16, 16);
    let floor = b.diffuse(Color::gray(0.7));
    let red = b.diffuse(Color::new(0.8, 0.2, 0.1));
    let green = b.diffuse(Color::new(0.2, 0.7, 0.3));
    let lamp = common::emissive(&mut b, 0.0, 5.0);
    let clear = common::dielectric(&mut b, 1.5);
    b.plane(Transform::translation(DVec3::new(0.0, 0.0, -1.0)), floor)
        .sphere(Transform::translation(DVec3::new(4.0, 0.8, -0.3)) * Transform::scaling(DVec3::splat(0.7)), red)
        .cube(
            Transform::translation(DVec3::new(5.0, -1.2, -0.4))
                * Transform::rotation_z(30.0)
                * Transform::scaling(DVec3::splat(1.2)),
            green,
        )
        .sphere(Transform::translation(DVec3::new(3.0, -0.3, -0.6)) * Transform::scaling(DVec3::splat(0.4)), clear)
        .sphere(Transform::translation(DVec3::new(4.0, 0.5, 2.0)) * Transform::scaling(DVec3::splat(0.5)), lamp)
        .point_light(PointLight { position: DVec3::new(2.0, 2.0, 3.0), color: Color::gray(2.0), linear_radius: 1.5 })
        .environment(Environment::Uniform(Color::gray(0.2)))
        .renderer(pt(2, 3, 2, true))
        .tracer(Tracer { samples_per_side: 2, rng: PcgSeed { state: 3, inc: 5 } });
    b.build().unwrap()
}

/// `scene` with `t` applied to every shape, the camera and the point lights (whose linear
/// radius scales by `s`, the uniform scale factor of `t`).
pub fn placed(scene: &Scene, t: Transform, s: f64) -> Scene {
    let mut out = scene.clone();
    for sh in &mut out.shapes {
        match sh {
            Shape::Primitive(p) => p.transform = t * p.transform,
            Shape::Csg(c) => c.transform = t * c.transform,
            Shape::Mesh(m) => m.transform = t * m.transform,
        }
    }
    out.camera.transform = t * out.camera.transform;
    for l in &mut out.point_lights {
        l.position = t.point(l.position);
        l.linear_radius *= s;
    }
    out
}

/// Share of pixels that differ from the unit scene's f64 image.
pub fn transformed_scene(gpu: Option<&Gpu>, name: &str, t: Transform, s: f64) -> Outcome {
    let unit = unit_scene();
    let (unit_cpu, unit_gpu) = render_both(gpu, &unit, None);
    let scene = placed(&unit, t, s);
    let (cpu, gpu_img) = render_both(gpu, &scene, None);
    Outcome::new(format!("unit scene {name}"), "the unit scene's f64 image", "share of pixels off by > 1e-3 rel.")
        .tolerances(0.0, 0.02)
        .values(1.0 - agreement(&cpu, &unit_cpu).share, gpu_img.as_ref().map(|g| 1.0 - agreement(g, &unit_cpu).share))
        .agreement(&cpu, gpu_img.as_ref(), 0.98)
        .note(unit_gpu.map_or(String::new(), |u| {
            format!("GPU unit scene itself: {:.1}% of pixels off", 100.0 * (1.0 - agreement(&u, &unit_cpu).share))
        }))
}

pub fn scaled_down(gpu: Option<&Gpu>) -> Outcome {
    transformed_scene(gpu, "scaled by 1e-4", Transform::scaling(DVec3::splat(1e-4)), 1e-4)
}
pub fn scaled_up(gpu: Option<&Gpu>) -> Outcome {
    transformed_scene(gpu, "scaled by 1e4", Transform::scaling(DVec3::splat(1e4)), 1e4)
}
pub fn translated(gpu: Option<&Gpu>) -> Outcome {
    transformed_scene(gpu, "translated by 1e5", Transform::translation(DVec3::new(1e5, -1e5, 1e5)), 1.0)
}

// ------------------------------------------------------------------------ 2. grazing

/// A diffuse plane lit by a point light 2 cm above it, 20 m away (cos θ ≈ 1e-3), seen by a
/// camera 5 cm above it: every pixel against ρ/π · I · cos θ · (r/d)².
pub fn grazing_point_light(gpu: Option<&Gpu>) -> Outcome {
    let rho = 0.8;
    let light = PointLight { position: DVec3::new(20.0, 3.0, 0.02), color: Color::gray(50.0), linear_radius: 10.0 };
    let mut b = SceneBuilder::new(24, 24);
    let m = b.diffuse(Color::gray(rho));
    b.plane(Transform::IDENTITY, m)
        .point_light(light)
        .camera(Camera { transform: Transform::translation(DVec3::new(0.0, 0.0, 0.05)), ..Camera::default() })
        .renderer(Renderer::PointLight { background: Color::BLACK, ambient: Color::BLACK });
    let scene = b.build().unwrap();
    let (cpu, gpu_img) = render_both(gpu, &scene, None);
    let expected = |col: usize, row: usize| {
        let r = centre_ray(&scene, col, row);
        // Seen only beyond the screen (t ≥ 1).
        if r.dir.z >= 0.0 || -r.origin.z / r.dir.z < CAMERA_RAY_TMIN {
            return 0.0;
        }
        let p = r.origin - r.dir * (r.origin.z / r.dir.z);
        let to = light.position - p;
        let d2 = to.length_squared();
        rho / std::f64::consts::PI * 50.0 * (to.z / d2.sqrt()) * light.falloff(d2.sqrt())
    };
    let err = |img: &HdrImage| {
        let mut worst: f64 = 0.0;
        for row in 0..24 {
            for col in 0..24 {
                let e = expected(col, row);
                let v = g(img, col, row);
                worst = worst.max(if e == 0.0 { v.abs() } else { (v / e - 1.0).abs() });
            }
        }
        worst
    };
    Outcome::new(
        "diffuse plane, grazing point light and view",
        "ρ/π·I·cosθ·(r/d)² per pixel (cosθ down to 1e-3)",
        "max relative error",
    )
    .tolerances(1e-7, 1e-3)
    .measure(&cpu, gpu_img.as_ref(), err, 0.98)
}

/// Path tracer, no NEE, one bounce, under a uniform sky L: a pixel that sees a diffuse
/// surface of albedo ρ is exactly ρL (the bounce can only escape: convex or planar
/// surfaces), a pixel that sees the sky L. Self-intersection ("acne") makes it 0.
fn sky_lit_classified(
    gpu: Option<&Gpu>,
    scene: &Scene,
    rho: f64,
    sky: f64,
    hit: impl Fn(usize, usize, f64) -> Option<bool>,
) -> (f64, Option<f64>, Option<Agreement>, String) {
    let (cpu, gpu_img) = render_both(gpu, scene, None);
    let err = |img: &HdrImage, margin: f64, ambiguous: &mut usize| {
        let mut worst: f64 = 0.0;
        for row in 0..scene.height as usize {
            for col in 0..scene.width as usize {
                let Some(h) = hit(col, row, margin) else {
                    *ambiguous += 1;
                    continue;
                };
                let e = if h { rho * sky } else { sky };
                if (g(img, col, row) / e - 1.0).abs() > 1e-5 && std::env::var("STAB_DEBUG").is_ok() {
                    let r = centre_ray(scene, col, row);
                    eprintln!("pixel ({col},{row}) value {} expected {e} origin {:?}", g(img, col, row), r.origin);
                }
                worst = worst.max((g(img, col, row) / e - 1.0).abs());
            }
        }
        worst
    };
    let (mut ca, mut ga) = (0, 0);
    let c = err(&cpu, CPU_MARGIN, &mut ca);
    let gerr = gpu_img.as_ref().map(|i| err(i, GPU_MARGIN, &mut ga));
    check_ambiguous(scene, ca);
    check_ambiguous(scene, ga);
    let agree = gpu_img.as_ref().map(|g| agreement(g, &cpu));
    (c, gerr, agree, ambiguous_note(ca, gerr.map(|_| ga)))
}

fn ambiguous_note(cpu: usize, gpu: Option<usize>) -> String {
    format!("ambiguous pixels skipped: {cpu} (CPU){}", gpu.map_or(String::new(), |g| format!(", {g} (GPU)")))
}

fn sky_scene(mut b: SceneBuilder, sky: f64, camera: Camera) -> Scene {
    b.environment(Environment::Uniform(Color::gray(sky))).camera(camera).renderer(pt(8, 1, 100, false));
    b.build().unwrap()
}

/// A camera 1 cm above an infinite diffuse plane, looking along it.
pub fn grazing_plane_sky(gpu: Option<&Gpu>) -> Outcome {
    let (rho, sky) = (0.6, 1.5);
    let mut b = SceneBuilder::new(24, 24);
    let m = b.diffuse(Color::gray(rho));
    b.plane(Transform::rotation_x(0.0), m);
    let cam = Camera { transform: Transform::translation(DVec3::new(0.0, 0.0, 0.01)), ..Camera::default() };
    let scene = sky_scene(b, sky, cam);
    let (cpu, gpu_err, agree, amb) = sky_lit_classified(gpu, &scene, rho, sky, |c, r, margin| {
        let ray = centre_ray(&scene, c, r);
        let t = -ray.origin.z / ray.dir.z;
        ((t - CAMERA_RAY_TMIN).abs() > margin * 1e-3).then_some(t > CAMERA_RAY_TMIN)
    });
    Outcome::new(
        "diffuse plane seen at grazing angles, uniform sky",
        "ρL where the plane is seen, L elsewhere (exact per path)",
        "max relative error",
    )
    .tolerances(1e-7, 1e-5)
    .values(cpu, gpu_err)
    .agreement_of(agree, 1.0)
    .note(amb)
}

/// An orthogonal camera zoomed 500× on a unit sphere's silhouette (45° round its rim):
/// incidence angles up to ~89.5°.
pub fn sphere_silhouette(gpu: Option<&Gpu>) -> Outcome {
    let (rho, sky) = (0.6, 1.5);
    let mut b = SceneBuilder::new(32, 32);
    let m = b.diffuse(Color::gray(rho));
    b.sphere(Transform::IDENTITY, m);
    let rim = DVec3::new(-3.0, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2);
    let scene = sky_scene(b, sky, ortho(rim, 2e-3, 1.0));
    let shape = scene.shapes[0].clone();
    let (cpu, gpu_err, agree, amb) = sky_lit_classified(gpu, &scene, rho, sky, |c, r, e| {
        analytic_material(&scene, &shape, c, r, e).map(|m| m.is_some())
    });
    Outcome::new(
        "sphere silhouette (grazing hits and bounces)",
        "ρL on the sphere, L off it (exact per path)",
        "max relative error",
    )
    .tolerances(1e-7, 1e-5)
    .values(cpu, gpu_err)
    .agreement_of(agree, 0.99)
    .note(amb)
}

/// An orthogonal camera on a rotated cube's corner: three faces and three edges.
pub fn cube_edges(gpu: Option<&Gpu>) -> Outcome {
    let (rho, sky) = (0.6, 1.5);
    let mut b = SceneBuilder::new(32, 32);
    let m = b.diffuse(Color::gray(rho));
    let t =
        Transform::translation(DVec3::new(2.0, 0.3, -0.2)) * Transform::rotation_x(30.0) * Transform::rotation_z(40.0);
    b.cube(t, m);
    // The corner nearest the camera (smallest x).
    let corner = (0..8)
        .map(|i| t.point(DVec3::new(f64::from(i & 1) - 0.5, f64::from((i >> 1) & 1) - 0.5, f64::from(i >> 2) - 0.5)))
        .min_by(|a, b| a.x.total_cmp(&b.x))
        .unwrap();
    let scene = sky_scene(b, sky, ortho(DVec3::new(-1.0, corner.y, corner.z), 0.05, 1.0));
    let shape = scene.shapes[0].clone();
    let (cpu, gpu_err, agree, amb) = sky_lit_classified(gpu, &scene, rho, sky, |c, r, e| {
        analytic_material(&scene, &shape, c, r, e).map(|m| m.is_some())
    });
    Outcome::new("cube corner and edges", "ρL on the cube, L off it (exact per path)", "max relative error")
        .tolerances(1e-7, 1e-5)
        .values(cpu, gpu_err)
        .agreement_of(agree, 0.99)
        .note(amb)
}

/// A closed box of six abutting walls (shared seams along every edge) with the camera
/// inside looking into a corner; outside: a bright sky, a point light and a spherical area
/// light. Nothing can reach the inside. The camera is scaled by ½ so that its whole screen,
/// where camera rays start (t = 1), lies inside the box: at full size the screen's corners
/// reach √2 from the centre, past the walls (1.1), and a camera sample placed there sees
/// the sky without crossing any seam.
pub fn light_leak(gpu: Option<&Gpu>) -> Outcome {
    let mut b = SceneBuilder::new(16, 16);
    let white = b.diffuse(Color::gray(0.8));
    let lamp = common::emissive(&mut b, 0.0, 50.0);
    let slab = |centre: DVec3, size: DVec3| Transform::translation(centre) * Transform::scaling(size);
    let (i, w) = (1.0, 0.1); // inner half-size, wall thickness
    for s in [-1.0, 1.0] {
        let c = s * (i + w / 2.0);
        b.cube(slab(DVec3::new(c, 0.0, 0.0), DVec3::new(w, 2.0 * i, 2.0 * i)), white);
        b.cube(slab(DVec3::new(0.0, c, 0.0), DVec3::new(2.0 * (i + w), w, 2.0 * i)), white);
        b.cube(slab(DVec3::new(0.0, 0.0, c), DVec3::new(2.0 * (i + w), 2.0 * (i + w), w)), white);
    }
    b.sphere(Transform::translation(DVec3::new(0.0, 0.0, 3.0)) * Transform::scaling(DVec3::splat(0.5)), lamp)
        .point_light(PointLight { position: DVec3::new(1.3, 1.3, 1.3), color: Color::gray(100.0), linear_radius: 0.0 })
        .environment(Environment::Uniform(Color::gray(10.0)))
        .camera(Camera {
            transform: Transform::rotation_z(45.0)
                * Transform::rotation_y(-35.264)
                * Transform::scaling(DVec3::splat(0.5)),
            ..Camera::default()
        })
        .renderer(pt(8, 3, 2, true))
        .tracer(Tracer { samples_per_side: 2, rng: PcgSeed::default() });
    let scene = b.build().unwrap();
    let (cpu, gpu_img) = render_both(gpu, &scene, None);
    Outcome::new("closed box of abutting walls, lights outside", "black inside (exactly 0)", "max pixel radiance")
        .tolerances(0.0, 0.0)
        .measure(&cpu, gpu_img.as_ref(), max_radiance, 1.0)
        .note("sky 10, point light 100, area light Le 50; 16×16 × 4 spp × 8 paths")
}

// ------------------------------------------------------------------- 3. tiny and inside

/// A sphere of radius 1e-3 at 1e4 from the eye; OnOff, 4×4 strata per pixel. Every camera
/// sample is classified analytically (f64 distance from the sphere centre to the ray line);
/// the error is the number of samples classified differently.
fn tiny_sphere(gpu: Option<&Gpu>, name: &str, camera: Camera, centre: DVec3) -> Outcome {
    let r = 1e-3;
    let mut b = SceneBuilder::new(32, 32);
    let m = b.diffuse(Color::WHITE);
    b.sphere(Transform::translation(centre) * Transform::scaling(DVec3::splat(r)), m)
        .camera(camera)
        .renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK })
        .tracer(Tracer { samples_per_side: 4, rng: PcgSeed { state: 9, inc: 17 } });
    let scene = b.build().unwrap();
    let (cpu, gpu_img) = render_both(gpu, &scene, None);
    let layout = PixelSamples::Strata(4);
    let mut expected = vec![0.0; 32 * 32];
    let mut covered = 0usize;
    for row in 0..32u32 {
        for col in 0..32u32 {
            for j in 0..16 {
                let (upx, vpx) = layout.position(scene.tracer.rng, row * 32 + col, j);
                let ray = scene.camera.ray((f64::from(col) + upx) / 32.0, 1.0 - (f64::from(row) + vpx) / 32.0);
                let dist = (centre - ray.origin).cross(ray.dir).length() / ray.dir.length();
                if dist < r {
                    expected[(row * 32 + col) as usize] += 1.0 / 16.0;
                    covered += 1;
                }
            }
        }
    }
    // The analytic sample count itself must estimate the projected area π r² (within 3 %:
    // stratified sampling of a disk of ~200 pixels).
    let screen = {
        let a = scene.camera.ray(0.0, 0.0);
        let z = scene.camera.ray(1.0, 1.0);
        let at = |cr: CameraRay| cr.origin + cr.dir * ((centre.x - cr.origin.x) / cr.dir.x);
        let (p, q) = (at(a), at(z));
        ((p.y - q.y) * (p.z - q.z)).abs()
    };
    let area = covered as f64 / (32.0 * 32.0 * 16.0) * screen;
    let area_err = area / (std::f64::consts::PI * r * r) - 1.0;
    assert!(area_err.abs() < 0.03, "analytic coverage {area} vs π r² (error {area_err})");
    let err = |img: &HdrImage| {
        img.pixels().iter().zip(&expected).map(|(p, e)| (f64::from(p.g) - e).abs() * 16.0).sum::<f64>().round()
    };
    Outcome::new(
        format!("sphere r = 1e-3 at 1e4, {name}"),
        format!(
            "analytic coverage of each of 16384 samples ({covered} inside; area within {:.1}% of πr²)",
            area_err * 100.0
        ),
        "misclassified samples",
    )
    .tolerances(0.0, 2.0)
    .measure(&cpu, gpu_img.as_ref(), err, 0.98)
}

pub fn tiny_sphere_orthogonal(gpu: Option<&Gpu>) -> Outcome {
    let centre = DVec3::new(1e4, 3e-4, -2e-4);
    tiny_sphere(gpu, "orthogonal camera", ortho(DVec3::ZERO, 2e-3, 1.0), centre)
}

/// Perspective with a 0.02 mrad field of view: screen distance 5e6, eye at the origin, the
/// screen 1 cm before the sphere.
pub fn tiny_sphere_narrow(gpu: Option<&Gpu>) -> Outcome {
    let centre = DVec3::new(1e4, 3e-4, -2e-4);
    let d = 5e6;
    let k = (1e4 - 0.01) / d;
    let camera = Camera {
        projection: Projection::Perspective { screen_distance: d },
        aspect_ratio: 1.0,
        transform: Transform::translation(DVec3::new(k * d, 0.0, 0.0)) * Transform::scaling(DVec3::splat(k)),
    };
    tiny_sphere(gpu, "narrow perspective", camera, centre)
}

/// The camera inside an emitting diffuse closed shape (Le 1, ρ 0.5), path tracer without
/// NEE to depth 20: every path is exactly Σ_{k≤20} ρᵏ = 2(1 − 2⁻²¹).
fn inside(gpu: Option<&Gpu>, kind: ShapeKind) -> Outcome {
    let mut b = SceneBuilder::new(12, 12);
    let m = common::emissive(&mut b, 0.5, 1.0);
    b.shape(Shape::primitive(kind, Transform::rotation_z(20.0) * Transform::scaling(DVec3::splat(20.0)), m))
        .renderer(pt(2, 20, 1000, false));
    let scene = b.build().unwrap();
    let (cpu, gpu_img) = render_both(gpu, &scene, Some(1));
    let expected = 2.0 * (1.0 - 0.5f64.powi(21));
    let err = |img: &HdrImage| max_relative_error(img, expected);
    Outcome::new(
        format!("camera inside a {}: furnace", kind.name()),
        "2(1 − 2⁻²¹) exactly per path (ρ 0.5, Le 1, depth 20)",
        "max relative error",
    )
    .tolerances(1e-7, 2e-6)
    .measure(&cpu, gpu_img.as_ref(), err, 1.0)
}
pub fn inside_sphere(gpu: Option<&Gpu>) -> Outcome {
    inside(gpu, ShapeKind::Sphere)
}
pub fn inside_cube(gpu: Option<&Gpu>) -> Outcome {
    inside(gpu, ShapeKind::Cube)
}

/// A statistical furnace: relative error of the image mean; the test must be strong enough
/// (5 standard errors below the 1 % tolerance).
fn statistical_furnace(
    gpu: Option<&Gpu>,
    case: String,
    expected_text: String,
    scene: &Scene,
    expected: f64,
    spp: u32,
) -> Outcome {
    let (cpu, gpu_img) = render_both(gpu, scene, Some(spp));
    let (cm, cse) = mean_and_stderr(&cpu, |_, _| true);
    assert!(5.0 * cse < 0.01 * expected, "test too weak: CPU standard error {cse} of {expected}");
    let gm = gpu_img.as_ref().map(|g| mean_and_stderr(g, |_, _| true));
    if let Some((_, gse)) = gm {
        assert!(5.0 * gse < 0.01 * expected, "test too weak: GPU standard error {gse} of {expected}");
    }
    Outcome::new(case, expected_text, "relative error of the image mean")
        .tolerances(0.01, 0.01)
        .values((cm / expected - 1.0).abs(), gm.map(|(m, _)| (m / expected - 1.0).abs()))
        // Same random numbers: most pixels agree, but one f32/f64 branch flip anywhere in a
        // pixel's long paths moves it by more than 1e-3.
        .agreement(&cpu, gpu_img.as_ref(), 0.9)
        .note(format!(
            "standard error {:.2}% (CPU){}",
            100.0 * cse / expected,
            gm.map_or(String::new(), |(_, s)| format!(", {:.2}% (GPU)", 100.0 * s / expected))
        ))
}

/// Inside an emitting cube with NEE + MIS (area sampling of the cube from inside it).
pub fn inside_cube_nee(gpu: Option<&Gpu>) -> Outcome {
    let mut b = SceneBuilder::new(12, 12);
    let m = common::emissive(&mut b, 0.5, 1.0);
    b.cube(Transform::rotation_z(20.0) * Transform::scaling(DVec3::splat(20.0)), m).renderer(pt(8, 20, 1000, true));
    let scene = b.build().unwrap();
    statistical_furnace(
        gpu,
        "camera inside a cube: furnace with NEE + MIS".into(),
        "2(1 − 2⁻²¹) in expectation".into(),
        &scene,
        2.0 * (1.0 - 0.5f64.powi(21)),
        4,
    )
}

/// Closed-box furnace, albedo 0.99, Russian roulette from depth 10 (q = 0.05), depth ≤ 50:
/// E = Σ_{k≤50} 0.99ᵏ whatever the roulette does.
pub fn furnace_roulette(gpu: Option<&Gpu>) -> Outcome {
    let (rho, max_depth, rr) = (0.99, 50, 10);
    let mut b = SceneBuilder::new(16, 16);
    let m = common::emissive(&mut b, rho, 1.0);
    // Few paths per camera sample, many samples: see `many_paths_per_sample` for why.
    b.cube(Transform::scaling(DVec3::new(3.0, 4.0, 5.0)), m).renderer(pt(16, max_depth, rr, false));
    let scene = b.build().unwrap();
    let expected: f64 = (0..=max_depth).map(|k| rho.powi(k as i32)).sum();
    statistical_furnace(
        gpu,
        "closed-box furnace, albedo 0.99, roulette".into(),
        format!("Σ_(k≤{max_depth}) 0.99ᵏ = {expected:.4}"),
        &scene,
        expected,
        64,
    )
}

/// The camera inside an emitting cube (ρ 0.5, Le 1, no NEE, depth 50) with 256 paths per
/// camera sample: every path is exactly Σ_{k≤50} 0.5ᵏ, so every pixel must be too. On
/// lavapipe, Mesa's loop limiter stops all loops of an invocation after 65,535 iterations
/// in total: the megakernel counted only the first 129 of the 256 paths (see
/// docs/STABILITY.md, "Fixed by this suite"); the wavefront renderer runs one vertex per
/// invocation.
pub fn many_paths_per_sample(gpu: Option<&Gpu>) -> Outcome {
    let mut b = SceneBuilder::new(4, 4);
    let m = common::emissive(&mut b, 0.5, 1.0);
    b.cube(Transform::scaling(DVec3::splat(5.0)), m).renderer(pt(256, 50, 1000, false));
    let scene = b.build().unwrap();
    let (cpu, gpu_img) = render_both(gpu, &scene, Some(1));
    let expected = 2.0 * (1.0 - 0.5f64.powi(51));
    let err = |img: &HdrImage| max_relative_error(img, expected);
    Outcome::new(
        "256 paths × 51 vertices per camera sample (furnace)",
        "2(1 − 2⁻⁵¹) exactly per path",
        "max relative error",
    )
    .tolerances(1e-7, 2e-6)
    .measure(&cpu, gpu_img.as_ref(), err, 1.0)
}

// ------------------------------------------------------------------------- 4. glass

/// Fresnel's amplitude reflection coefficients (r_s, r_p) of a dielectric interface for
/// the incidence cosine `cos_i` and relative index `eta` = n_t / n_i, from his sine and
/// tangent laws with the refraction angle from Snell's law (Born & Wolf, *Principles of
/// Optics*, §1.5.2): r_s = −sin(θᵢ − θₜ) / sin(θᵢ + θₜ), r_p = tan(θᵢ − θₜ) / tan(θᵢ + θₜ).
/// `None` under total internal reflection. Works with angles, not with the cosines of
/// `cpu::fresnel` (the renderer's form), so the expectation is derived independently;
/// `tests/stability.rs` checks it against textbook identities.
pub fn fresnel_amplitudes(cos_i: f64, eta: f64) -> Option<(f64, f64)> {
    let theta_i = cos_i.clamp(0.0, 1.0).acos();
    let sin_t = theta_i.sin() / eta;
    if sin_t >= 1.0 {
        return None;
    }
    let theta_t = sin_t.asin();
    if theta_i == 0.0 {
        // The limit of both laws at normal incidence (0/0 above): r = ∓(η − 1)/(η + 1).
        let r = (eta - 1.0) / (eta + 1.0);
        return Some((-r, r));
    }
    let (d, s) = (theta_i - theta_t, theta_i + theta_t);
    Some((-d.sin() / s.sin(), d.tan() / s.tan()))
}

/// Unpolarised reflectance: the mean of |r_s|² and |r_p|², 1 under total internal
/// reflection.
pub fn fresnel(cos_i: f64, eta: f64) -> f64 {
    fresnel_amplitudes(cos_i, eta).map_or(1.0, |(rs, rp)| 0.5 * (rs * rs + rp * rp))
}

/// A clear glass sphere (ior 1.5) under a uniform sky, seen near its rim (incidence 72° to
/// 89°) by an orthogonal camera, one path per sample, path depth `max_depth`.
///
/// Inside a sphere every chord meets the surface at the refraction angle, where the
/// reflectance is F (the entry reflectance, by reciprocity); each internal reflection is
/// one more vertex. A path is worth exactly L when it leaves within `max_depth` vertices
/// (the η² factors cancel), else 0: the pixel's expectation is
/// L·(1 − (1 − F)·F^(max_depth − 1)). Error: pooled z-score of all pixels (binomial
/// variance), and no pixel may exceed L (energy).
fn glass_rim(gpu: Option<&Gpu>, max_depth: u32) -> Outcome {
    let (sky, ior, n) = (1.5, 1.5, 256);
    let mut b = SceneBuilder::new(32, 4);
    let m = common::dielectric(&mut b, ior);
    b.sphere(Transform::IDENTITY, m)
        .environment(Environment::Uniform(Color::gray(sky)))
        .camera(ortho(DVec3::new(-3.0, 0.975, 0.0), 0.003, 8.0))
        .renderer(pt(n, max_depth, 1000, false));
    let scene = b.build().unwrap();
    let (cpu, gpu_img) = render_both(gpu, &scene, None);
    let mut p_hit = vec![1.0; 32 * 4];
    let mut min_cos: f64 = 1.0;
    for row in 0..4 {
        for col in 0..32 {
            let r = centre_ray(&scene, col, row);
            let b2 = r.origin.y * r.origin.y + r.origin.z * r.origin.z;
            if b2 < 1.0 {
                let cos_i = (1.0 - b2).sqrt();
                min_cos = min_cos.min(cos_i);
                let f = fresnel(cos_i, ior);
                p_hit[row * 32 + col] = 1.0 - (1.0 - f) * f.powi(max_depth as i32 - 1);
            }
        }
    }
    let err = |img: &HdrImage| {
        let (mut dev, mut var) = (0.0, 0.0);
        for (px, &p) in img.pixels().iter().zip(&p_hit) {
            let v = f64::from(px.g) / sky;
            assert!(v <= 1.0 + 1e-5, "a pixel exceeds the sky: {v}");
            dev += (v - p) * f64::from(n);
            var += f64::from(n) * p * (1.0 - p);
        }
        (dev / var.sqrt().max(1e-300)).abs()
    };
    Outcome::new(
        format!("glass sphere rim under a sky, depth {max_depth}"),
        format!(
            "L·(1 − (1−F)·F^{}) per pixel, F = Fresnel(θᵢ), θᵢ up to {:.1}°",
            max_depth - 1,
            min_cos.acos().to_degrees()
        ),
        "abs. pooled z-score (binomial)",
    )
    .tolerances(4.5, 4.5)
    // Per-pixel agreement: near the rim f32 and f64 geometry differ enough to change about
    // one path in 2,500 (each such pixel is off by 1/256 of L), so about a tenth of the
    // pixels differ. Over twelve seeds the share agreeing was 0.86–0.94 (mean 0.90) with the
    // strata permutation of either 2026-12-05 form: 0.8 is far below chance, while a
    // systematic GPU error would change most pixels.
    .measure(&cpu, gpu_img.as_ref(), err, 0.8)
    .note(format!("{n} paths per pixel, 128 pixels"))
}
pub fn glass_rim_depth_3(gpu: Option<&Gpu>) -> Outcome {
    glass_rim(gpu, 3)
}
pub fn glass_rim_depth_64(gpu: Option<&Gpu>) -> Outcome {
    glass_rim(gpu, 64)
}

/// Where the line o + t·d (t > 1e-9) first meets the surface of the unit cube
/// [−0.5, 0.5]³, from outside or inside: (t, outward normal).
fn unit_cube_next(o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    let (mut n0, mut n1) = (DVec3::ZERO, DVec3::ZERO);
    for i in 0..3 {
        if d[i] == 0.0 {
            if o[i].abs() > 0.5 {
                return None;
            }
            continue;
        }
        let (a, b) = ((-0.5 - o[i]) / d[i], (0.5 - o[i]) / d[i]);
        let (near, far) = if a < b { (a, b) } else { (b, a) };
        let mut axis = DVec3::ZERO;
        axis[i] = 1.0;
        if near > t0 {
            t0 = near;
            n0 = axis * -d[i].signum();
        }
        if far < t1 {
            t1 = far;
            n1 = axis * d[i].signum();
        }
    }
    if t0 >= t1 {
        return None;
    }
    if t0 > 1e-9 {
        Some((t0, n0))
    } else if t1 > 1e-9 {
        Some((t1, n1))
    } else {
        None
    }
}

/// Probability that a path through a clear glass unit cube (index `ior`) escapes within
/// `max_depth` vertices, starting with a ray at iteration `b`: a hit at iteration
/// `max_depth` ends the path; at every other hit the path reflects with the Fresnel
/// probability (1 under total internal reflection) or refracts (written out here, not the
/// renderer's code).
fn glass_cube_escape(o: DVec3, d: DVec3, inside: bool, b: u32, ior: f64, max_depth: u32) -> f64 {
    let Some((t, n_out)) = unit_cube_next(o, d) else { return 1.0 };
    if b == max_depth {
        return 0.0;
    }
    let p = o + d * t;
    let d = d.normalize();
    let n = if d.dot(n_out) < 0.0 { n_out } else { -n_out };
    let eta = if inside { 1.0 / ior } else { ior };
    let cos_i = -d.dot(n);
    let f = fresnel(cos_i, eta);
    let reflected = glass_cube_escape(p, d + n * (2.0 * cos_i), inside, b + 1, ior, max_depth);
    if f >= 1.0 {
        return reflected;
    }
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    let refracted = d / eta + n * (cos_i / eta - (1.0 - sin2_t).sqrt());
    f * reflected + (1.0 - f) * glass_cube_escape(p, refracted, !inside, b + 1, ior, max_depth)
}

/// A clear glass cube (ior 1.5) under a uniform sky, seen by an orthogonal camera at 80°
/// from its top face's normal: rays refract to 41°, and those that reach a side face meet
/// it at 49°, beyond the critical angle (41.8°): total internal reflection. Each pixel's
/// expectation is L · P(escape within `max_depth` vertices), from an f64 branching trace of
/// the exact Fresnel/TIR tree in the test; error: the pooled z-score (binomial).
pub fn glass_cube_tir(gpu: Option<&Gpu>) -> Outcome {
    let (sky, ior, n, max_depth) = (1.5, 1.5, 256, 4);
    let mut b = SceneBuilder::new(16, 16);
    let m = common::dielectric(&mut b, ior);
    let dir = Transform::rotation_y(10.0).vector(DVec3::X);
    let centre = DVec3::new(0.0, 0.0, 0.5) - dir * 3.0;
    b.cube(Transform::IDENTITY, m)
        .environment(Environment::Uniform(Color::gray(sky)))
        .camera(Camera {
            projection: Projection::Orthogonal,
            aspect_ratio: 1.0,
            transform: Transform::translation(centre + dir * 0.08)
                * Transform::rotation_y(10.0)
                * Transform::scaling(DVec3::splat(0.08)),
        })
        .renderer(pt(n, max_depth, 1000, false));
    let scene = b.build().unwrap();
    let (cpu, gpu_img) = render_both(gpu, &scene, None);
    let mut p_escape = Vec::new();
    for row in 0..16 {
        for col in 0..16 {
            let r = centre_ray(&scene, col, row);
            let start = r.origin + r.dir * CAMERA_RAY_TMIN;
            p_escape.push(glass_cube_escape(start, r.dir, false, 0, ior, max_depth));
        }
    }
    let lost = p_escape.iter().filter(|&&p| p < 1.0).count();
    assert!(lost > 100, "only {lost} pixels can lose paths: the case no longer tests internal reflection");
    let err = |img: &HdrImage| {
        let (mut dev, mut var) = (0.0, 0.0);
        for (px, &p) in img.pixels().iter().zip(&p_escape) {
            let v = f64::from(px.g) / sky;
            assert!(v <= 1.0 + 1e-5, "a pixel exceeds the sky: {v}");
            dev += (v - p) * f64::from(n);
            var += f64::from(n) * p * (1.0 - p);
        }
        (dev / var.sqrt().max(1e-300)).abs()
    };
    let mean_p = p_escape.iter().sum::<f64>() / p_escape.len() as f64;
    Outcome::new(
        format!("glass cube at 80° incidence (TIR on the sides), depth {max_depth}"),
        format!("L·P(escape within {max_depth} vertices) per pixel, exact Fresnel/TIR tree (mean P {mean_p:.4})"),
        "abs. pooled z-score (binomial)",
    )
    .tolerances(4.5, 4.5)
    .measure(&cpu, gpu_img.as_ref(), err, 0.9)
    .note(format!("{n} paths per pixel, {lost} of 256 pixels below L"))
}

// --------------------------------------------------------------------------- 5. CSG

fn flat_case(gpu: Option<&Gpu>, case: String, expected: String, scene: &Scene, shape: &Shape) -> Outcome {
    let (cpu, gpu_img) = render_both(gpu, scene, None);
    let (c, amb) = flat_mismatches(scene, &cpu, shape, CPU_MARGIN);
    let g = gpu_img.as_ref().map(|i| flat_mismatches(scene, i, shape, GPU_MARGIN));
    Outcome::new(case, expected, "pixels of the wrong colour")
        .tolerances(0.0, 0.0)
        .values(c as f64, g.map(|x| x.0 as f64))
        .agreement(&cpu, gpu_img.as_ref(), 0.99)
        .note(ambiguous_note(amb, g.map(|x| x.1)))
}

/// Nine spheres of nine colours combined by eight nested CSG nodes (UNITE, DIFF,
/// INTERSECT, FUSE in turn), each node with its own similarity transform.
pub fn csg_nested_8(gpu: Option<&Gpu>) -> Outcome {
    let mut b = SceneBuilder::new(32, 32);
    let mats: Vec<MaterialId> = (0..9)
        .map(|k| {
            let h = f64::from(k) / 9.0;
            b.diffuse(Color::new(0.1 + 0.8 * h, 0.9 - 0.8 * h, 0.2 + 0.05 * f64::from(k)))
        })
        .collect();
    let sphere = |k: usize| {
        let a = k as f64 * 1.3;
        let c = DVec3::new(0.3 * (a * 0.7).sin(), 0.7 * a.cos(), 0.5 * a.sin());
        Shape::primitive(
            ShapeKind::Sphere,
            Transform::translation(c) * Transform::scaling(DVec3::splat(0.6 + 0.05 * k as f64)),
            mats[k],
        )
    };
    let ops = [CsgOp::Unite, CsgOp::Diff, CsgOp::Intersect, CsgOp::Fuse];
    let mut node = sphere(0);
    for k in 1..=8 {
        let t = Transform::rotation_z(7.0 * k as f64)
            * Transform::translation(DVec3::new(0.01 * k as f64, -0.02, 0.015))
            * Transform::scaling(DVec3::splat(1.01));
        let child = if ops[k % 4] == CsgOp::Intersect {
            // A big sphere, so INTERSECT trims without emptying.
            Shape::primitive(
                ShapeKind::Sphere,
                Transform::translation(DVec3::new(0.0, 0.2, 0.1)) * Transform::scaling(DVec3::splat(1.3)),
                mats[k],
            )
        } else {
            sphere(k)
        };
        node = Shape::csg(ops[k % 4], vec![node, child], t);
    }
    assert_eq!(node.csg_depth(), 8);
    b.shape(node.clone())
        .camera(Camera {
            projection: Projection::Perspective { screen_distance: 2.0 },
            aspect_ratio: 1.0,
            transform: Transform::translation(DVec3::new(-2.5, 0.0, 0.0)),
        })
        .renderer(Renderer::Flat { background: Color::BLACK });
    let scene = b.build().unwrap();
    flat_case(
        gpu,
        "CSG nested 8 deep (9 spheres)".into(),
        "colour of the analytic first hit (set membership)".into(),
        &scene,
        &node,
    )
}

/// DIFF of a cube by a box that shares four side faces with it (it removes the cube's top
/// half): the side faces above the cut are coincident in both operands. With `rotated`
/// the cutter is also turned by 90° about z, the same box mathematically, but its faces
/// now agree with the cube's only up to rounding (cos 90° = 6e-17 in floating point).
pub fn csg_coincident_sides(gpu: Option<&Gpu>, rotated: bool) -> Outcome {
    let mut b = SceneBuilder::new(32, 32);
    let (a, c) = (b.diffuse(Color::new(0.8, 0.2, 0.1)), b.diffuse(Color::new(0.1, 0.3, 0.9)));
    let turn = if rotated { Transform::rotation_z(90.0) } else { Transform::IDENTITY };
    let cut = Transform::translation(DVec3::new(0.0, 0.0, 0.5)) * turn;
    let diff = Shape::csg(
        CsgOp::Diff,
        vec![Shape::primitive(ShapeKind::Cube, Transform::IDENTITY, a), Shape::primitive(ShapeKind::Cube, cut, c)],
        Transform::translation(DVec3::new(3.0, 0.1, -0.2))
            * Transform::rotation_z(33.0)
            * Transform::rotation_x(11.0)
            * Transform::scaling(DVec3::splat(1.7)),
    );
    b.shape(diff.clone())
        .camera(Camera {
            transform: Transform::translation(DVec3::new(0.0, 0.0, 1.2)) * Transform::rotation_y(25.0),
            ..Camera::default()
        })
        .renderer(Renderer::Flat { background: Color::BLACK });
    let scene = b.build().unwrap();
    flat_case(
        gpu,
        format!(
            "CSG DIFF sharing four faces (cube minus its top half){}",
            if rotated { ", cutter turned 90°" } else { "" }
        ),
        "half a cube: carved face in the cutter's colour, no speckles".into(),
        &scene,
        &diff,
    )
}

/// DIFF of a cube by a copy translated by one side: they touch along a whole face, which
/// must stay closed (same colours, so only holes or stray surfaces count).
pub fn csg_touching_face(gpu: Option<&Gpu>) -> Outcome {
    let mut b = SceneBuilder::new(32, 32);
    let a = b.diffuse(Color::new(0.8, 0.6, 0.1));
    let diff = Shape::csg(
        CsgOp::Diff,
        vec![
            Shape::primitive(ShapeKind::Cube, Transform::IDENTITY, a),
            Shape::primitive(ShapeKind::Cube, Transform::translation(DVec3::new(0.0, 0.0, 1.0)), a),
        ],
        Transform::translation(DVec3::new(3.0, 0.0, -0.3))
            * Transform::rotation_z(21.0)
            * Transform::rotation_y(-9.0)
            * Transform::scaling(DVec3::splat(1.3)),
    );
    b.shape(diff.clone())
        .camera(Camera {
            transform: Transform::translation(DVec3::new(0.0, 0.0, 1.5)) * Transform::rotation_y(30.0),
            ..Camera::default()
        })
        .renderer(Renderer::Flat { background: Color::BLACK });
    let scene = b.build().unwrap();
    flat_case(gpu, "CSG DIFF touching along a face".into(), "the whole cube, closed".into(), &scene, &diff)
}

// ----------------------------------------------------------------------- 6. degenerate

/// Scripts with a zero, non-finite, underflowing or overflowing scale or a NaN anywhere:
/// each must be a located load error. Error: scripts that loaded.
pub fn degenerate_scripts() -> Outcome {
    use lumen::scenelang::{load_str, LoadOptions};
    let using = "USING Camera.Perspective() Image(4, 4) Renderer.OnOff() Tracer()";
    let bad = [
        "SPAWN Shape.Sphere(.transformation SCALE 0)",
        "SPAWN Shape.Sphere(.transformation SCALE(1, 0, 1))",
        "SPAWN Shape.Sphere(.transformation SCALE $0/0$)",
        "SPAWN Shape.Sphere(.transformation SCALE $1/0$)",
        "SPAWN Shape.Sphere(.transformation SCALE $sqrt(-1)$)",
        "SPAWN Shape.Sphere(.transformation SCALE 1e999)",
        "SPAWN Shape.Sphere(.transformation TRANSLATE(.X $1e308 * 10$))",
        "SPAWN Shape.Cube(.transformation Transformation([1,0,0,0, 0,1,0,0, 0,0,0,0, 0,0,0,1]))",
        "SPAWN Shape.Sphere(.material Material(.brdf Brdf.Diffuse(Pigment.Uniform(<$0/0$, 0, 0>))))",
        "SPAWN Shape.Sphere(.material Material(.emitted_radiance Pigment.Uniform(<1, $2^2000$, 0>)))",
        "SPAWN Light(.position {$0/0$, 0, 0})",
    ];
    let mut loaded = 0;
    let mut lines = Vec::new();
    for body in bad {
        let src = format!("# degenerate\n{body}\n{using}\n");
        match load_str(&src, "degenerate.sl", std::path::Path::new("."), &LoadOptions::default()) {
            Ok(_) => {
                println!("loaded without error: {body}");
                loaded += 1;
            }
            Err(e) => {
                assert_eq!(e.line, 2, "{e}");
                lines.push(format!("{:?}", e.kind));
            }
        }
    }
    Outcome::new(
        "degenerate scripts (zero, NaN, ∞ or overflowing scale; singular matrix; NaN colour or position)",
        format!("{} located load errors", bad.len()),
        "scripts that loaded",
    )
    .tolerances(0.0, 0.0)
    .values(f64::from(loaded), None)
    .note(lines.join(", "))
}

/// Valid but extreme transforms (a sphere flattened by 1e-30, a cube stretched by 1e15,
/// a sphere of radius 1e-12 near the eye): renders without a NaN/Inf sample anywhere.
/// Beyond the non-finite count (asserted zero in `render_both`), every pixel must lie in
/// [0, L]: one diffuse bounce under a sky of radiance L can reach no more.
pub fn extreme_transforms(gpu: Option<&Gpu>) -> Outcome {
    let (rho, sky) = (0.5, 2.0);
    let mut b = SceneBuilder::new(16, 16);
    let m = b.diffuse(Color::gray(rho));
    b.sphere(Transform::translation(DVec3::new(3.0, 0.5, 0.0)) * Transform::scaling(DVec3::new(1.0, 1.0, 1e-30)), m)
        .cube(Transform::translation(DVec3::new(4.0, -0.5, 0.3)) * Transform::scaling(DVec3::new(1e15, 0.3, 0.2)), m)
        .sphere(Transform::translation(DVec3::new(0.5, 0.0, 0.0)) * Transform::scaling(DVec3::splat(1e-12)), m);
    let scene = sky_scene(b, sky, Camera::default());
    let (cpu, gpu_img) = render_both(gpu, &scene, Some(4));
    let err = |img: &HdrImage| {
        img.pixels()
            .iter()
            .map(|p| {
                let v = f64::from(p.g);
                (-v).max(v - sky).max(0.0) / sky
            })
            .fold(0.0, f64::max)
    };
    Outcome::new(
        "extreme but valid scales (1e-30, 1e15, 1e-12)",
        "no NaN/Inf; every pixel within [0, L]",
        "distance outside [0, L] / L",
    )
    .tolerances(1e-12, 1e-6)
    .measure(&cpu, gpu_img.as_ref(), err, 0.95)
}

/// Scales that SceneLang accepts (finite, non-zero, invertible in f64), loaded from a
/// script: a sphere scaled by 1e-300 in front of the camera (below f32's range) and one
/// scaled by `big` that encloses everything. No NaN/Inf sample on either renderer; the
/// camera is inside the huge diffuse sphere (ρ 0.5) with nothing emitting, so every pixel
/// must be exactly 0.
pub fn extreme_script_scales(gpu: Option<&Gpu>, big: &str) -> Outcome {
    use lumen::scenelang::{load_str, LoadOptions};
    let src = format!(
        "SET grey Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.5, 0.5, 0.5>)))
SPAWN Shape.Sphere(.material grey, .transformation TRANSLATE(.X 2) * SCALE 1e-300)
SPAWN Shape.Sphere(.material grey, .transformation SCALE {big})
USING Camera.Perspective() Image(8, 8) Renderer.PathTracer(.n 2, .max_depth 3)
      Tracer(.samples_per_side 2) Environment.Uniform(.color <1, 1, 1>)
"
    );
    let scene = load_str(&src, "extreme.sl", std::path::Path::new("."), &LoadOptions::default())
        .expect("finite, invertible scales load");
    // f32 cannot hold a transform beyond ±3.4e38: the GPU must refuse such a scene clearly
    // (`lumen render --device auto` then renders it on the CPU) rather than render garbage.
    let beyond_f32 = big.parse::<f64>().unwrap() > f64::from(f32::MAX);
    let mut note = String::new();
    let gpu = match gpu {
        Some(g) if beyond_f32 => {
            let err = gpu_render(g, &scene, &GpuRenderOptions::fixed_passes(None, 4))
                .expect_err("the GPU must refuse a shape beyond f32's range");
            let msg = err.to_string();
            // The second shape the script spawns, at the third line's SPAWN item.
            let shape = "shape 2 in spawn order (sphere, written at extreme.sl:3:7)";
            assert!(msg.contains(shape) && msg.contains("beyond f32's range"), "{msg}");
            note = "GPU refuses the scene: shape 2 (sphere) beyond f32's range".into();
            None
        }
        g => g,
    };
    let (cpu, gpu_img) = render_both(gpu, &scene, None);
    Outcome::new(
        format!("script scales 1e-300 and {big} (enclosing)"),
        "no NaN/Inf; black (inside a non-emitting sphere)",
        "max pixel radiance",
    )
    .tolerances(0.0, 0.0)
    .measure(&cpu, gpu_img.as_ref(), max_radiance, 1.0)
    .note(note)
}

/// Every case, in table order (the GPU may be absent).
pub fn all(gpu: Option<&Gpu>) -> Vec<Outcome> {
    vec![
        scaled_down(gpu),
        scaled_up(gpu),
        translated(gpu),
        grazing_point_light(gpu),
        grazing_plane_sky(gpu),
        sphere_silhouette(gpu),
        cube_edges(gpu),
        light_leak(gpu),
        tiny_sphere_orthogonal(gpu),
        tiny_sphere_narrow(gpu),
        inside_sphere(gpu),
        inside_cube(gpu),
        inside_cube_nee(gpu),
        furnace_roulette(gpu),
        many_paths_per_sample(gpu),
        glass_rim_depth_3(gpu),
        glass_rim_depth_64(gpu),
        glass_cube_tir(gpu),
        csg_nested_8(gpu),
        csg_coincident_sides(gpu, false),
        csg_coincident_sides(gpu, true),
        csg_touching_face(gpu),
        degenerate_scripts(),
        extreme_transforms(gpu),
        extreme_script_scales(gpu, "1e18"),
        extreme_script_scales(gpu, "1e30"),
        extreme_script_scales(gpu, "1e300"),
    ]
}
