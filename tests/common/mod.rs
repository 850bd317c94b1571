//! Helpers shared by integration tests (each test binary includes this module with
//! `mod common;` and uses what it needs).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use glam::DVec3;
use lumen::color::Color;
use lumen::scene::{
    Brdf, Material, MaterialId, Pigment, PointLight, Renderer, Scene, SceneBuilder, Transform,
    DEFAULT_THRESHOLD_ANGLE_RAD,
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
    b.material(Material::new(
        Brdf::Dielectric { pigment: Pigment::Uniform(Color::WHITE), ior: 1.5 },
        Pigment::Uniform(Color::BLACK),
    ))
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
