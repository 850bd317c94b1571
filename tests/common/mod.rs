//! Helpers shared by integration tests (each test binary includes this module with
//! `mod common;` and uses what it needs).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use glam::DVec3;
use lumen::color::Color;
use lumen::image::HdrImage;
use lumen::scene::{
    Brdf, Camera, Material, MaterialId, PathTracerSettings, PcgSeed, Pigment, PointLight, Projection, Renderer, Scene,
    SceneBuilder, Tracer, Transform, DEFAULT_THRESHOLD_ANGLE_RAD,
};

/// A small path-traced scene (sky sphere, checkered floor, red ball; 32×24, 1 spp) that
/// renders in milliseconds on the CPU: for tests through the binary.
pub const TINY_SKY_SL: &str = "\
SET
    sky   Material(Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)), Pigment.Uniform(<1, 0.95, 0.9>))
    red   Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.7, 0.2, 0.2>)))
    floor Material(.brdf Brdf.Diffuse(Pigment.Checkered(4, <0.6, 0.6, 0.6>, <0.2, 0.2, 0.2>)))
SPAWN
    Shape.Sphere(sky, SCALE 20)
    Shape.Plane(floor, TRANSLATE(.Z -1))
    Shape.Sphere(red, TRANSLATE(.X 2))
USING
    Camera.Perspective(.aspect_ratio 1.3333333, .screen_distance 1, .transformation TRANSLATE(.X -1))
    Renderer.PathTracer(.n 1, .max_depth 3)
    Image(32, 24)
    Tracer(.samples_per_side 1)
";

/// A diffuse floor (z = 0) of albedo `rho` seen from a camera at height 3 looking straight
/// down, 12×10 pixels, lit by a point light of intensity `intensity` at `light`
/// (linear_radius 1: falloff 1/d²).
pub fn lit_floor(rho: Color, light: DVec3, intensity: Color, renderer: Renderer) -> Scene {
    let mut b = SceneBuilder::new(12, 10);
    let m = b.diffuse(rho);
    let cam = Camera {
        projection: Projection::Perspective { screen_distance: 1.0 },
        aspect_ratio: 1.2,
        transform: Transform::translation(DVec3::new(0.3, -0.2, 3.0)) * Transform::rotation_y(90.0),
    };
    b.plane(Transform::IDENTITY, m)
        .camera(cam)
        .point_light(PointLight { position: light, color: intensity, linear_radius: 1.0 })
        .renderer(renderer);
    b.build().unwrap()
}

/// The radiance of `lit_floor`'s pixel (col, row) by the closed form ρ/π · I · cosθ / d²,
/// where the camera ray through the pixel centre meets z = 0 (at t = −o.z / d.z).
pub fn lit_floor_radiance(scene: &Scene, rho: Color, light: DVec3, intensity: Color, col: usize, row: usize) -> Color {
    let r = scene.camera.ray((col as f64 + 0.5) / 12.0, 1.0 - (row as f64 + 0.5) / 10.0);
    let p = r.origin - r.dir * (r.origin.z / r.dir.z);
    let to = light - p;
    let d2 = to.length_squared();
    let cos = to.z / d2.sqrt();
    rho * intensity * (cos / (std::f64::consts::PI * d2))
}

/// Every `.sl` script in `scenes/`, sorted by name.
pub fn example_scene_files() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "sl"))
        .collect();
    files.sort();
    assert!(files.len() >= 5, "{files:?}");
    files
}

/// `path` loaded and shrunk to a thumbnail `width` wide (its aspect ratio kept, at most
/// `max_height` tall), with one path per camera sample, so that GPU tests stay short.
pub fn thumbnail(path: &Path, width: u32, max_height: u32) -> Scene {
    let mut scene = lumen::scenelang::load_file(path, &lumen::scenelang::LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let aspect = f64::from(scene.width) / f64::from(scene.height);
    scene.width = width;
    scene.height = ((f64::from(width) / aspect).round() as u32).clamp(1, max_height);
    if let Renderer::PathTracer(p) = &mut scene.renderer {
        p.n = 1;
    }
    scene
}

/// A diffuse material of albedo `rho` that emits `le` (grey).
pub fn emissive(b: &mut SceneBuilder, rho: f64, le: f64) -> MaterialId {
    b.material(Material::new(
        Brdf::Diffuse { pigment: Pigment::Uniform(Color::gray(rho)) },
        Pigment::Uniform(Color::gray(le)),
    ))
}

/// Clear glass of index 1.5.
pub fn glass(b: &mut SceneBuilder) -> MaterialId {
    dielectric(b, 1.5)
}

/// Clear glass of index `ior`.
pub fn dielectric(b: &mut SceneBuilder, ior: f64) -> MaterialId {
    b.material(Material::new(
        Brdf::Dielectric { pigment: Pigment::Uniform(Color::WHITE), ior, roughness: 0.0, multiple_scattering: true },
        Pigment::Uniform(Color::BLACK),
    ))
}

/// A rough glass floor (the plane z = 0, GGX α 0.3, index 1.5) seen from a camera at height 3
/// looking straight down, lit only from below, inside the glass at depth 1: by a point light
/// of intensity `intensity` (linear radius 1: falloff 1/d²), or, with `sphere_radius` r, by a
/// diffuse sphere of radius r and radiance I/(πr²) at the same place, whose irradiance at
/// distances d ≫ r is the point light's. Depth 1 and a black sky: all the camera sees is the
/// light transmitted at the first hit.
pub fn rough_glass_lit_from_below(sphere_radius: Option<f64>, intensity: f64) -> Scene {
    use lumen::scene::{Camera, Projection};
    let mut b = SceneBuilder::new(12, 10);
    let glass = b.material(Material::new(
        Brdf::Dielectric {
            pigment: Pigment::Uniform(Color::WHITE),
            ior: 1.5,
            roughness: 0.3,
            multiple_scattering: true,
        },
        Pigment::Uniform(Color::BLACK),
    ));
    let at = DVec3::new(0.4, -0.1, -1.0);
    match sphere_radius {
        Some(r) => {
            let lamp = emissive(&mut b, 0.0, intensity / (std::f64::consts::PI * r * r));
            b.sphere(Transform::translation(at) * Transform::scaling(DVec3::splat(r)), lamp);
        }
        None => {
            b.point_light(PointLight { position: at, color: Color::gray(intensity), linear_radius: 1.0 });
        }
    }
    b.plane(Transform::IDENTITY, glass)
        .camera(Camera {
            projection: Projection::Perspective { screen_distance: 1.0 },
            aspect_ratio: 1.2,
            transform: Transform::translation(DVec3::new(0.3, -0.2, 3.0)) * Transform::rotation_y(90.0),
        })
        .renderer(pt(1, 1, 10, true));
    b.build().unwrap()
}

/// The path tracer with `n` paths per camera sample, the other settings at their defaults.
pub fn pt(n: u32, max_depth: u32, roulette_depth: u32, nee: bool) -> Renderer {
    Renderer::PathTracer(PathTracerSettings { n, max_depth, roulette_depth, nee, ..Default::default() })
}

/// The camera inside a sphere of radius 10 that emits `le` and reflects diffusely with
/// albedo ρ, on a `size`×`size` image: every path's expectation is Le Σ ρᵏ.
pub fn furnace(size: u32, rho: f64, le: f64, renderer: Renderer) -> Scene {
    let mut b = SceneBuilder::new(size, size);
    let m = emissive(&mut b, rho, le);
    b.sphere(Transform::scaling(DVec3::splat(10.0)), m).renderer(renderer);
    b.build().unwrap()
}

/// Mean of the green channel over the selected pixels and the standard error of that mean
/// estimated from their spread (valid when they share one expected value).
pub fn mean_and_stderr(img: &HdrImage, select: impl Fn(usize, usize) -> bool) -> (f64, f64) {
    let mut v = Vec::new();
    for row in 0..img.height() {
        for col in 0..img.width() {
            if select(col, row) {
                v.push(f64::from(img.get(col, row).g));
            }
        }
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

// ------------------------------------------------------------------ image agreement

/// Whether two channel values agree: within 1e-3 relative or 1e-4 absolute.
pub fn close(a: f32, b: f32) -> bool {
    let d = (a - b).abs();
    d <= 1e-4 || d <= 1e-3 * a.abs().max(b.abs())
}

/// How closely an image (`got`, e.g. the f32 GPU render) agrees with a reference (`want`,
/// e.g. the f64 CPU render). The share of agreeing pixels alone lets the other pixels be
/// arbitrarily wrong, so two more numbers bound how far off they are.
#[derive(Debug, Clone)]
pub struct Agreement {
    /// Share of pixels whose three channels all agree ([`close`]).
    pub share: f64,
    /// Total absolute difference of the disagreeing channels over the reference's total
    /// (both summed over every channel of every pixel): 1 % of the pixels 10× too bright
    /// in a uniform image give 0.09.
    pub outlier_error: f64,
    /// Largest difference of the channel means (r, g, b), relative to the reference's mean.
    pub mean_error: f64,
    /// Up to eight disagreeing pixels, for messages.
    pub worst: String,
}

/// What [`Agreement::check`] accepts.
#[derive(Debug, Clone, Copy)]
pub struct Tolerance {
    pub min_share: f64,
    pub max_outlier_error: f64,
    pub max_mean_error: f64,
}

impl Tolerance {
    /// At least `min_share` of the pixels agree, the others add at most 2 % of the image's
    /// total, and the channel means agree within 1 %.
    pub fn share(min_share: f64) -> Self {
        Self { min_share, max_outlier_error: 0.02, max_mean_error: 0.01 }
    }
}

/// Compares `got` with the reference `want` (same size).
pub fn agreement(got: &HdrImage, want: &HdrImage) -> Agreement {
    assert_eq!((got.width(), got.height()), (want.width(), want.height()));
    let (mut good, mut outlier_sum, mut total) = (0usize, 0.0f64, 0.0f64);
    let (mut sum_got, mut sum_want) = ([0.0f64; 3], [0.0f64; 3]);
    let mut bad = Vec::new();
    for (i, (g, w)) in got.pixels().iter().zip(want.pixels()).enumerate() {
        let pairs = [(g.r, w.r), (g.g, w.g), (g.b, w.b)];
        for (k, &(a, b)) in pairs.iter().enumerate() {
            sum_got[k] += f64::from(a);
            sum_want[k] += f64::from(b);
            total += f64::from(b).abs();
            if !close(a, b) {
                outlier_sum += f64::from(a - b).abs();
            }
        }
        if pairs.iter().all(|&(a, b)| close(a, b)) {
            good += 1;
        } else if bad.len() < 8 {
            bad.push(format!("({}, {}): got {g:?} want {w:?}", i % got.width(), i / got.width()));
        }
    }
    let n = got.pixels().len() as f64;
    // An absolute floor of 1e-4 per channel (as in `close`), so that black images agree.
    let floor = 1e-4 * n;
    let mean_error =
        (0..3).map(|k| (sum_got[k] - sum_want[k]).abs() / sum_want[k].abs().max(floor)).fold(0.0, f64::max);
    Agreement {
        share: good as f64 / n,
        outlier_error: outlier_sum / total.max(3.0 * floor),
        mean_error,
        worst: bad.join("; "),
    }
}

impl std::fmt::Display for Agreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.2}% of pixels agree; the others add {:.3}% of the image; means differ by {:.3}%; outliers: {}",
            100.0 * self.share,
            100.0 * self.outlier_error,
            100.0 * self.mean_error,
            self.worst
        )
    }
}

impl Agreement {
    /// `Err` with every number and the worst pixels when any bound of `tol` fails.
    pub fn check(&self, tol: Tolerance) -> Result<(), String> {
        // A NaN error is not within any bound.
        let within = |v: f64, max: f64| v <= max;
        let ok = self.share >= tol.min_share
            && within(self.outlier_error, tol.max_outlier_error)
            && within(self.mean_error, tol.max_mean_error);
        if !ok {
            Err(format!("{self} (outside {tol:?})"))
        } else {
            Ok(())
        }
    }
}

/// A mirror reflecting 80 %.
pub fn mirror(b: &mut SceneBuilder) -> MaterialId {
    b.material(Material::new(
        Brdf::Specular {
            pigment: Pigment::Uniform(Color::gray(0.8)),
            threshold_angle_rad: DEFAULT_THRESHOLD_ANGLE_RAD,
        },
        Pigment::Uniform(Color::BLACK),
    ))
}

/// Adds what GPU-vs-CPU path tests light and bounce off, in front of a camera at the origin
/// looking along +x: an emitting sphere (cone-sampled area light), a warm emitting cube
/// (area-sampled), a glass and a mirror sphere, and a point light.
pub fn add_lit_props(b: &mut SceneBuilder) {
    let lamp = emissive(b, 0.0, 4.0);
    let warm = b.material(Material::new(
        Brdf::Diffuse { pigment: Pigment::Uniform(Color::gray(0.5)) },
        Pigment::Uniform(Color::new(2.0, 1.0, 0.5)),
    ));
    let (glass, mirror) = (glass(b), mirror(b));
    b.sphere(Transform::translation(DVec3::new(4.0, 1.0, 1.6)) * Transform::scaling(DVec3::splat(0.4)), lamp)
        .cube(Transform::translation(DVec3::new(4.5, -1.5, 1.5)) * Transform::scaling(DVec3::new(0.6, 0.3, 0.2)), warm)
        .sphere(Transform::translation(DVec3::new(3.5, -0.6, -0.5)) * Transform::scaling(DVec3::splat(0.5)), glass)
        .sphere(Transform::translation(DVec3::new(4.5, 1.2, -0.4)) * Transform::scaling(DVec3::splat(0.6)), mirror)
        .point_light(PointLight { position: DVec3::new(2.0, 0.0, 2.5), color: Color::gray(0.5), linear_radius: 1.0 });
}

// ------------------------------------------------------------------ meshes

/// OBJ text of a mesh; with `normals`, the vertex positions (unit sphere) as normals too.
pub fn obj_text(v: &[DVec3], f: &[[u32; 3]], normals: bool) -> String {
    let mut s = String::new();
    for p in v {
        s += &format!("v {} {} {}\n", p.x, p.y, p.z);
        if normals {
            s += &format!("vn {} {} {}\n", p.x, p.y, p.z);
        }
    }
    for [a, b, c] in f {
        if normals {
            s += &format!("f {0}//{0} {1}//{1} {2}//{2}\n", a + 1, b + 1, c + 1);
        } else {
            s += &format!("f {} {} {}\n", a + 1, b + 1, c + 1);
        }
    }
    s
}

/// The smallest distance from the origin to the plane of any triangle: the polyhedron lies
/// between the spheres of this radius and of radius 1 (its vertices are on the unit sphere),
/// the bound the tessellation tests derive their tolerances from.
pub fn inscribed_radius(v: &[DVec3], f: &[[u32; 3]]) -> f64 {
    f.iter()
        .map(|&[a, b, c]| {
            let (a, b, c) = (v[a as usize], v[b as usize], v[c as usize]);
            let n = (b - a).cross(c - a).normalize();
            n.dot(a).abs()
        })
        .fold(f64::INFINITY, f64::min)
}

/// A small HDR image with distinct texels (and one bright spot for importance sampling).
pub fn test_image(w: usize, h: usize) -> std::sync::Arc<HdrImage> {
    let mut img = HdrImage::new(w, h);
    for row in 0..h {
        for col in 0..w {
            img.set(col, row, lumen::color::Rgb32::new(0.1 + col as f32 * 0.1, 0.2 + row as f32 * 0.15, 0.5));
        }
    }
    img.set(w / 3, h / 4, lumen::color::Rgb32::new(40.0, 30.0, 20.0));
    std::sync::Arc::new(img)
}

/// Lambert's projected solid angle ∫ cos θ dω of a planar polygon (world vertices in order
/// around it) seen from `x` with unit normal `n`, the polygon lying wholly above x's
/// tangent plane: ½ |Σ over edges of θ_e · n · (r_i × r_j)/|r_i × r_j||, r the unit
/// directions to the vertices and θ_e the angle between an edge's two.
pub fn lambert_polygon(x: DVec3, n: DVec3, vertices: &[DVec3]) -> f64 {
    let r: Vec<DVec3> = vertices.iter().map(|v| (*v - x).normalize()).collect();
    let mut sum = 0.0;
    for i in 0..r.len() {
        let (a, b) = (r[i], r[(i + 1) % r.len()]);
        sum += a.dot(b).clamp(-1.0, 1.0).acos() * n.dot(a.cross(b).normalize());
    }
    0.5 * sum.abs()
}

/// A cube lamp emitting Le from every face beside the view of a diffuse floor, seen from
/// straight above through pixel centres; direct light only (max_depth 1: NEE on the lamp,
/// MIS-weighted against BSDF sampling, 2048 paths per pixel). `sheared`: a parallelepiped
/// (sheared, rotated, stretched) some way off, whose faces NEE samples by area; otherwise a
/// rotated box lying low beside the view, whose rectangular faces the floor's nearer points
/// see large enough to be sampled by solid angle (the farther ones still by area). Returns
/// the scene and each pixel's closed form, row by row: ρ/π · Le · Σ, over the lamp faces
/// the floor point is in front of (which together make up the lamp's silhouette), of
/// Lambert's projected solid angle of the face.
pub fn cube_lamp_over_a_floor(sheared: bool) -> (Scene, Vec<Color>) {
    let (w, h) = (12u32, 10u32);
    let rho = Color::new(0.8, 0.5, 0.2);
    let le = Color::new(3.0, 2.0, 1.0);
    let (lamp_t, camera_height) = if sheared {
        let shear = Transform::from_matrix(glam::DMat4::from_cols(
            glam::DVec4::X,
            glam::DVec4::Y,
            glam::DVec4::new(0.3, 0.1, 1.0, 0.0),
            glam::DVec4::W,
        ))
        .unwrap();
        let t = Transform::translation(DVec3::new(4.5, 0.5, 1.3))
            * Transform::rotation_z(25.0)
            * Transform::rotation_x(10.0)
            * shear
            * Transform::scaling(DVec3::new(1.0, 0.6, 0.2));
        (t, 3.0)
    } else {
        let t = Transform::translation(DVec3::new(2.6, 0.3, 0.45))
            * Transform::rotation_z(25.0)
            * Transform::rotation_x(10.0)
            * Transform::scaling(DVec3::new(1.0, 0.6, 0.2));
        (t, 1.2)
    };
    let mut b = SceneBuilder::new(w, h);
    let floor = b.diffuse(rho);
    let lamp = b.material(Material::new(Brdf::default(), Pigment::Uniform(le)));
    b.plane(Transform::IDENTITY, floor)
        .cube(lamp_t, lamp)
        .camera(Camera {
            projection: Projection::Perspective { screen_distance: 1.0 },
            aspect_ratio: 1.2,
            transform: Transform::translation(DVec3::new(0.3, -0.2, camera_height)) * Transform::rotation_y(90.0),
        })
        .tracer(Tracer { samples_per_side: 0, rng: PcgSeed { state: 5, inc: 8 } })
        .renderer(pt(2048, 1, 10, true));
    let scene = b.build().unwrap();
    // The lamp's faces in world space, each with its outward normal.
    let faces: Vec<(Vec<DVec3>, DVec3)> = (0..6)
        .map(|f| {
            let (axis, s) = (f / 2, if f % 2 == 0 { 0.5 } else { -0.5 });
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f64, b: f64| {
                let mut p = DVec3::ZERO;
                p[axis] = s;
                p[u] = a;
                p[v] = b;
                lamp_t.point(p)
            };
            let quad = vec![corner(-0.5, -0.5), corner(0.5, -0.5), corner(0.5, 0.5), corner(-0.5, 0.5)];
            let mut n = DVec3::ZERO;
            n[axis] = s;
            (quad, lamp_t.normal(n).normalize())
        })
        .collect();
    let mut want = Vec::new();
    for row in 0..h {
        for col in 0..w {
            let r =
                scene.camera.ray((f64::from(col) + 0.5) / f64::from(w), 1.0 - (f64::from(row) + 0.5) / f64::from(h));
            let p = r.origin - r.dir * (r.origin.z / r.dir.z);
            let seen: f64 = faces
                .iter()
                .filter(|(quad, n)| (p - quad[0]).dot(*n) > 0.0)
                .map(|(quad, _)| lambert_polygon(p, DVec3::Z, quad))
                .sum();
            want.push(rho * le * (seen / std::f64::consts::PI));
        }
    }
    (scene, want)
}

/// `img` against a closed-form image (row by row): every channel of every pixel within
/// `pixel` (relative), and the green channel's image total within `total`.
pub fn assert_close_to_closed_form(img: &HdrImage, want: &[Color], pixel: f64, total: f64) {
    let (mut sum_got, mut sum_want) = (0.0, 0.0);
    for (i, w) in want.iter().enumerate() {
        let (col, row) = (i % img.width(), i / img.width());
        let got: Color = img.get(col, row).into();
        for (g, e) in got.to_array().into_iter().zip(w.to_array()) {
            assert!((g / e - 1.0).abs() < pixel, "({col},{row}): {got:?} vs {w:?}");
        }
        sum_got += got.g;
        sum_want += w.g;
    }
    assert!((sum_got / sum_want - 1.0).abs() < total, "image total {sum_got} vs {sum_want}");
}

/// A command that starts the `lumen` binary the way this test process was started: through
/// the same dynamic loader, with its arguments, where a cargo runner started the tests
/// through one (`scripts/newer_lavapipe.sh`'s `run`, README "How it is checked"), so that
/// `lumen` reaches the same GPU driver as the test.
pub fn lumen_command() -> std::process::Command {
    // (Cargo defines the binary's path for integration tests, not for the example that
    // shares this module and never calls this.)
    let lumen = option_env!("CARGO_BIN_EXE_lumen").unwrap_or("lumen");
    lumen::cli::own_process::through_own_loader(Path::new(lumen))
}
