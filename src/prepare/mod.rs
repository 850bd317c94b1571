//! Scene preparation that both renderers use: what a scene needs before any ray is traced,
//! computed once in f64 from the scene model. The CPU reference consumes these directly;
//! the GPU packer converts them (`src/gpu/pack.rs`), so the two renderers agree on the BVH,
//! the lights, the environment's sampling tables, the placement of camera samples and the
//! CSG bounds by construction, not by two implementations kept alike.

pub mod mesh_bvh;
pub mod pixel_samples;
pub mod render_form;
pub mod round_spheres;
pub mod sample_range;

use glam::{DMat3, DVec3};

use crate::accel::{Bvh, BvhItem};
use crate::image::HdrImage;
use crate::sampling::Distribution2D;
use crate::scene::{Aabb, Environment, MaterialId, Scene, Shape, ShapeKind, Transform};

pub use mesh_bvh::{mesh_bvh, MeshBvhs};
pub use pixel_samples::{camera_strata_key, PixelSamples, CAMERA_STRATA_SALT};
pub use render_form::{render_form, source_shape};
pub use round_spheres::{all_round, RoundSphere, ROUND_SCALES};
pub use sample_range::{SampleRange, SampleRangeError};

/// Most top-level CSG trees whose evaluation a closest-hit query defers until the
/// traversal is over (more trees: each is evaluated where the traversal meets it).
///
/// Why defer: on SIMD software GPUs (lavapipe) the CSG code inside the traversal loop costs
/// on every iteration, even when no ray takes it (DESIGN.md, "Software adapters"); the GPU
/// evaluates the trees after the traversal, and the CPU does the same so that both
/// compare candidates in one order (ties between coincident surfaces resolve alike).
pub const CSG_DEFER_MAX: usize = 16;

/// The top-level shapes a ray can hit: the bounded ones in a BVH (ids index
/// `Scene::shapes`), the unbounded ones (planes, CSG trees with unbounded solids) in a list
/// that every ray tests. Shapes with empty bounds (an INTERSECT of disjoint solids) are in
/// neither.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneBvh {
    /// BVH over the world bounds of the bounded shapes.
    pub bvh: Bvh,
    /// Indices into `Scene::shapes` of the unbounded shapes, in scene order.
    pub unbounded: Vec<u32>,
}

/// Where [`SceneBvh`] puts a top-level shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Placement {
    /// In the BVH, with these (finite) bounds.
    Tree(Aabb),
    /// In the list every ray tests.
    Unbounded,
    /// Nowhere: its bounds are empty.
    Nowhere,
}

impl Placement {
    /// Where shape `s` goes, from its world bounds.
    pub fn of(s: &Shape) -> Self {
        let b = s.bounds();
        if b.is_empty() {
            Placement::Nowhere
        } else if b.is_finite() {
            Placement::Tree(b)
        } else {
            Placement::Unbounded
        }
    }
}

impl SceneBvh {
    /// Places each of `shapes` by [`Placement::of`] and builds the BVH over the bounded ones
    /// (index i in the list is id i).
    pub fn from_shapes(shapes: &[Shape]) -> Self {
        let mut items = Vec::new();
        let mut unbounded = Vec::new();
        for (i, s) in shapes.iter().enumerate() {
            match Placement::of(s) {
                Placement::Tree(bounds) => items.push(BvhItem { id: i as u32, bounds }),
                Placement::Unbounded => unbounded.push(i as u32),
                Placement::Nowhere => {}
            }
        }
        Self { bvh: Bvh::build(&items), unbounded }
    }
}

/// How far beyond a unit-cube face's plane (object space, where the cube is [−0.5, 0.5]³) a
/// shading point must lie for NEE to count it as in front of that face: 2⁻¹⁰, exact in f32
/// and f64. Points closer than that (a ceiling touching a lamp's top face, or rounding)
/// sample the face as if it were hidden; both renderers apply the same rule to the same
/// threshold, so f32 and f64 rounding of a point lying on the plane cannot choose
/// differently, and the choice is unbiased either way (MIS uses the same rule's density).
pub const CUBE_FACE_MARGIN: f64 = 1.0 / 1024.0;

/// The slope below which a ray counts as parallel to a plane (`|d.z| ≤ slope · max |dᵢ|` in
/// the plane's object space, where the plane is z = 0): 2⁻²⁰, exact in f32 and f64. A ray
/// parallel to a plane in exact arithmetic, as a mirror tilted 45° sends a horizontal one,
/// carries a d.z of a few rounding units, whose sign decides whether it meets the infinite
/// plane at a distance of 1/d.z, 1e7 in f32 and 1e16 in f64: the two renderers went opposite
/// ways (tests/gpu_random_scenes.rs, seed 45, scene 271: a wedge of two planes over a
/// mirror floor). Both now take such a ray as parallel, so the plane is all inside or all
/// outside it, as for d.z = 0. The angle, 1e-6 rad, is a few times f32's rounding of a
/// transformed direction and hides only hits beyond about a million times the ray's
/// height over the plane.
pub const PLANE_PARALLEL_SLOPE: f64 = 1.0 / 1_048_576.0;

/// The solid angles (steradians) between which NEE samples a rectangular cube face by the
/// solid angle it subtends (`cpu::spherical_rectangle`) instead of by area: below, the face
/// is far enough for area sampling to be nearly as good (on cornell.sl a minimum of 1/16
/// leaves 0.7 % more variance than 1/128, 1/4 2 %, 1 13 %), and a bound that costs a cross
/// product (`spherical_rectangle::may_subtend`) spares most points the four arctangents
/// (cornell.sl's CPU render +2 % instead of +18 %; BENCHMARKS.md "Solid-angle sampling of
/// cube faces"), while f32 keeps Ω to a few 1e-5 there; above, the point nearly touches the
/// face. Powers of two and small integers, exact in f32 and f64, so both renderers compare
/// their own Ω with the same numbers; the rule is deterministic per (point, face), so it is
/// unbiased wherever it falls, and MIS applies it too.
pub const SOLID_ANGLE_MIN: f64 = 1.0 / 16.0;
/// The solid angle (steradians) above which a cube face is sampled by area again (see
/// [`SOLID_ANGLE_MIN`]).
pub const SOLID_ANGLE_MAX: f64 = 6.0;

/// One area light, with what sampling needs precomputed.
#[derive(Debug, Clone, PartialEq)]
pub struct AreaLight {
    /// Index of the shape in [`Scene::shapes`].
    pub shape: u32,
    /// Object-to-world transformation of the shape.
    pub transform: Transform,
    /// The shape's (emissive) material.
    pub material: MaterialId,
    /// The light's surface, with what sampling it needs.
    pub surface: LightSurface,
}

/// What an area light's surface is: the unit sphere or cube, or a mesh, under the light's
/// transformation.
#[derive(Debug, Clone, PartialEq)]
pub enum LightSurface {
    /// The unit sphere.
    Sphere {
        /// World centre and radius where the transformation is a similarity (a round
        /// sphere in the world), whose subtended cone NEE samples; `None` for an ellipsoid.
        round: Option<(DVec3, f64)>,
        /// |det| of the linear part of the transformation: with Nanson's formula it gives
        /// the world area density of object-uniform points, which varies over an
        /// ellipsoid (area sampling).
        det: f64,
    },
    /// The unit cube.
    Cube {
        /// World area of one face of each pair (±x, ±y, ±z; both faces of a pair have the
        /// same). NEE chooses among the faces a shading point is in front of by these
        /// (`cpu::area_light`, "visible faces").
        face_areas: [f64; 3],
        /// Per axis, whether that pair's faces are rectangles (the transform keeps the
        /// two edges orthogonal), which NEE may sample by solid angle.
        rectangular_faces: [bool; 3],
    },
    /// A mesh instance: its triangles and what sampling them needs.
    Mesh(MeshLight),
}

/// An emissive mesh instance, sampled uniformly over its world surface: a triangle by its
/// share of the world area, then a uniform point on it.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshLight {
    /// The instance's triangles, in object space (the light's `transform` places them).
    pub mesh: std::sync::Arc<crate::scene::TriangleMesh>,
    /// Cumulative world areas of the triangles (in the file's order) over the total: the
    /// last entry is 1.
    pub cdf: Vec<f64>,
    /// The instance's world surface area (sampling density 1 / area).
    pub area: f64,
}

impl MeshLight {
    /// The triangle ξ falls in, and ξ rescaled to [0, 1) within it.
    pub fn choose(&self, xi: f64) -> (usize, f64) {
        let n = self.cdf.len();
        let i = self.cdf.partition_point(|&c| c <= xi).min(n - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let width = self.cdf[i] - lo;
        let u = if width > 0.0 { ((xi - lo) / width).clamp(0.0, 1.0) } else { 0.5 };
        (i, u)
    }
}

impl AreaLight {
    /// The light for `Scene::shapes[shape]`, a sphere or cube primitive or a mesh instance;
    /// `None` for any other shape and for a mesh whose placed area is 0 or not finite.
    pub fn new(scene: &Scene, shape: usize) -> Option<Self> {
        if let Shape::Mesh(m) = &scene.shapes[shape] {
            let mut sum = 0.0;
            let mut cdf: Vec<f64> = (0..m.mesh.triangle_count())
                .map(|i| {
                    let [a, b, c] = m.mesh.triangle(i).map(|p| m.transform.point(p));
                    sum += 0.5 * (b - a).cross(c - a).length();
                    sum
                })
                .collect();
            if !(sum > 0.0 && sum.is_finite()) {
                return None;
            }
            cdf.iter_mut().for_each(|c| *c /= sum);
            return Some(Self {
                shape: shape as u32,
                transform: m.transform,
                material: m.material,
                surface: LightSurface::Mesh(MeshLight { mesh: m.mesh.clone(), cdf, area: sum }),
            });
        }
        let Shape::Primitive(p) = &scene.shapes[shape] else { return None };
        let lin = DMat3::from_mat4(p.transform.matrix());
        let det = lin.determinant().abs();
        let surface = match p.kind {
            ShapeKind::Sphere => {
                let round = similarity_scale(lin).map(|r| (p.transform.point(DVec3::ZERO), r));
                LightSurface::Sphere { round, det }
            }
            ShapeKind::Cube => {
                // World area of one unit face per axis (Nanson: |det M| · |M⁻ᵀ e_i|).
                let face_areas = [DVec3::X, DVec3::Y, DVec3::Z].map(|e| det * p.transform.normal(e).length());
                let rectangular_faces = [0, 1, 2].map(|axis| {
                    let (a, b) = (lin.col((axis + 1) % 3), lin.col((axis + 2) % 3));
                    a.dot(b).abs() <= 1e-9 * a.length() * b.length()
                });
                LightSurface::Cube { face_areas, rectangular_faces }
            }
            _ => return None,
        };
        Some(Self { shape: shape as u32, transform: p.transform, material: p.material, surface })
    }
}

/// Uniform radius of a linear map that is a rotation times a uniform scale, else `None`.
fn similarity_scale(m: DMat3) -> Option<f64> {
    let s = m.x_axis.length();
    let g = m.transpose() * m;
    let ok = (g - DMat3::from_diagonal(DVec3::splat(s * s))).to_cols_array().iter().all(|v| v.abs() <= 1e-12 * s * s);
    ok.then_some(s)
}

/// What escaping rays see, as a light for NEE: the scene's environment, else a uniform one
/// of the renderer's background colour; `None` when that is black (nothing to sample).
pub fn escape_light(scene: &Scene) -> Option<Environment> {
    let environment = match &scene.environment {
        Some(e) => e.clone(),
        None => Environment::Uniform(scene.renderer.background()),
    };
    (!environment_is_black(&environment)).then_some(environment)
}

fn environment_is_black(e: &Environment) -> bool {
    match e {
        Environment::Uniform(c) => c.is_black(),
        Environment::Gradient { zenith, horizon, nadir } => zenith.is_black() && horizon.is_black() && nadir.is_black(),
        Environment::Image { image, intensity, .. } => *intensity == 0.0 || image.pixels().iter().all(|p| p.is_black()),
    }
}

/// The texel weights luminance × sin θ (θ at the row centre), row 0 at the zenith.
pub fn image_distribution(image: &HdrImage) -> Distribution2D {
    let (w, h) = (image.width(), image.height());
    Distribution2D::from_rows(w, h, |row| {
        let sin_theta = (std::f64::consts::PI * (row as f64 + 0.5) / h as f64).sin();
        (0..w).map(|col| f64::from(image.get(col, row).luminance()).max(0.0) * sin_theta).collect()
    })
}

#[cfg(test)]
mod tests {
    /// The GPU side reads scene preparation from here, never from the CPU renderer
    /// (`src/gpu/` does not import `crate::cpu`), so neither renderer's internals leak into
    /// the other's.
    #[test]
    fn the_gpu_renderer_does_not_depend_on_the_cpu_renderer() {
        fn rust_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
            for e in std::fs::read_dir(dir).unwrap().flatten() {
                let p = e.path();
                if p.is_dir() {
                    rust_files(&p, out);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    out.push(p);
                }
            }
        }
        /// Whether Rust source names the `cpu` module: `crate::cpu`, a `super::` chain
        /// ending in it, or `cpu` inside a `crate::{...}` group (nested groups included).
        fn names_cpu(text: &str) -> bool {
            let compact: String = text.chars().filter(|c| !c.is_whitespace()).collect();
            let word = |s: &str| s.split(|c: char| !(c.is_alphanumeric() || c == '_')).any(|w| w == "cpu");
            let in_group = compact.match_indices("crate::{").any(|(i, m)| {
                let rest = &compact[i + m.len()..];
                let mut depth = 1;
                let end = rest
                    .char_indices()
                    .find(|&(_, c)| {
                        depth += i32::from(c == '{') - i32::from(c == '}');
                        depth == 0
                    })
                    .map_or(rest.len(), |(j, _)| j);
                word(&rest[..end])
            });
            compact.contains("crate::cpu") || compact.contains("super::cpu") || in_group
        }
        for (text, names) in [
            ("use crate::cpu::Ray;", true),
            ("use crate::{\n    cpu,\n    gpu };", true),
            ("use crate::{gpu::{pack, cpu::x}};", true),
            ("use super::super::cpu;", true),
            ("use crate::{cpus, gpu};", false),
            ("use crate::prepare::{cpu_like};", false),
        ] {
            assert_eq!(names_cpu(text), names, "{text}");
        }
        let mut files = Vec::new();
        rust_files(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/gpu"), &mut files);
        assert!(files.len() > 10, "{files:?}");
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap();
            assert!(!names_cpu(&text), "{} imports the CPU renderer", f.display());
        }
    }
}
