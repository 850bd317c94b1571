//! Helpers shared by integration tests (each test binary includes this module with
//! `mod common;` and uses what it needs).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use lumen::color::Color;
use lumen::scene::{Brdf, Material, MaterialId, Pigment, Renderer, Scene, SceneBuilder, DEFAULT_THRESHOLD_ANGLE_RAD};

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
