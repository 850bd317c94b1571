//! Random scenes on both renderers. The example scenes and the hand-made ones of
//! `gpu_render.rs` reach a few dozen combinations of lumen's features, but the GPU's kernels
//! are assembled per scene from only the features it uses (shape kinds, CSG, meshes, BRDF
//! kinds, textured and emissive pigments, light kinds, environments, renderers), so a
//! combination no test renders could compile a kernel that misses a piece, or that takes a
//! branch another combination never does. Here seeded proptest strategies write valid
//! SceneLang scripts that mix those features at random, and each scene must:
//!
//! - render bit for bit the same with its own specialised kernels as with the full-featured
//!   kernels of its renderer (`FeatureSet::full_for`, as `gpu_specialised.rs` does for the
//!   example scenes): specialisation only removes code that the scene never runs (to 1e-5
//!   where the two traverse differently, list against walk: see the comparison);
//! - render bit for bit the same with one of the settings `GpuRenderOptions` documents as
//!   leaving the image unchanged (table placement, queue shards, 32-bit path words);
//! - agree with the f64 CPU reference pixel by pixel (the same random numbers for the same
//!   pixel, sample and bounce): 90 % of the pixels within 1e-3, the others adding at most
//!   2 % of the image, the means within 1 % (`Tolerance::share`), at the script's size
//!   (8–24 × 6–18) or, where that misses, at 4× its width and height (see [`MIN_SHARE`]),
//!   with no NaN or infinity.
//!
//! Each scene renders at 1 to 4 samples per pixel, in one round or one round per sample.
//!
//! The seed and the case count are fixed, so CI renders the same scenes every run, and
//! between them they enable every `#if` name a scene decides (`FeatureSet::ALL_NAMES`);
//! `LUMEN_RANDOM_SCENES_SEED=n` and `LUMEN_RANDOM_SCENES=k` (cases) hunt further. A failure
//! prints the script and its sample count (and the scene's own triangle soup, if it has
//! one, with the path the script names): saved in `scenes/` (it reads meshes and `sky.hdr`
//! from there), `lumen render --spp N` with `--device gpu` and `--device cpu` reproduces it. Skips without a GPU
//! adapter (fails instead with LUMEN_REQUIRE_GPU=1).

mod common;

use std::collections::BTreeSet;
use std::path::Path;

use common::{agreement, Tolerance};
use lumen::cpu::{render as cpu_render, Progress, RenderOptions};
use lumen::gpu::features::FeatureSet;
use lumen::gpu::gpu_for_tests;
use lumen::gpu::render::{GpuRenderOptions, GpuRenderer};
use lumen::gpu::tables::TablePlacement;
use lumen::scenelang::{load_str, LoadOptions};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// Share of pixels that must agree with the CPU (the other bounds: `Tolerance::share`). Where
/// glass lies on every path (a glass ball around the camera), f32 and f64 send a few paths
/// different ways (Fresnel's choice, a texture's edge): scene 0 of seed 3 agreed on 94.8 %
/// of its pixels, its means within 0.02 %. Against the CPU a bug shows in the means and the
/// outliers' share of the image (DESIGN.md "Random feature combinations": a slip in WGSL
/// put the means 3-44 % off), while a path that f32 and f64 send different ways can hold a
/// percent of a 16×12 image's light: a miss there is confirmed at 4× the width and height
/// before it counts.
const MIN_SHARE: f64 = 0.9;
/// The scenes CI renders: the strategies' first CASES scenes of SEED.
const SEED: u64 = 2;
const CASES: u64 = 24;

/// A number with two decimals in [lo, hi].
fn num(lo: f64, hi: f64) -> impl Strategy<Value = String> {
    (lo..=hi).prop_map(|v| format!("{v:.2}"))
}

fn colour(lo: f64, hi: f64) -> impl Strategy<Value = String> {
    (num(lo, hi), num(lo, hi), num(lo, hi)).prop_map(|(r, g, b)| format!("<{r}, {g}, {b}>"))
}

/// A reflectance pigment: uniform, or where `textured`, also checkered or the sky image.
fn pigment(textured: bool) -> BoxedStrategy<String> {
    let uniform = colour(0.05, 0.95).prop_map(|c| format!("Pigment.Uniform({c})"));
    if !textured {
        return uniform.boxed();
    }
    prop_oneof![
        4 => uniform,
        2 => (1u32..8, colour(0.05, 0.95), colour(0.05, 0.95))
            .prop_map(|(n, a, b)| format!("Pigment.Checkered(.N {n}, .color_on {a}, .color_off {b})")),
        1 => prop::sample::select(vec!["nearest", "bilinear"])
            .prop_map(|f| format!("Pigment.Image(.image sky, .filter \"{f}\")")),
    ]
    .boxed()
}

/// Glass clear two times in three, else tinted (the pigment scales what passes through).
fn tint() -> impl Strategy<Value = String> {
    prop_oneof![2 => Just(String::new()), 1 => colour(0.3, 1.0).prop_map(|c| format!(", .pigment {c}"))]
}

/// Energy compensation of the rough conductor and dielectric: on, but off one time in four.
fn multiple_scattering() -> impl Strategy<Value = String> {
    prop_oneof![3 => Just(String::new()), 1 => Just(", .multiple_scattering 0".to_string())]
}

/// GGX roughness: smooth half of the time.
fn roughness() -> impl Strategy<Value = String> {
    prop_oneof![Just("0".to_string()), num(0.02, 1.0)]
}

fn brdf(textured: bool) -> impl Strategy<Value = String> {
    prop_oneof![
        4 => pigment(textured).prop_map(|p| format!("Brdf.Diffuse({p})")),
        1 => pigment(textured).prop_map(|p| format!("Brdf.Specular({p})")),
        2 => (num(1.2, 1.8), roughness(), tint(), multiple_scattering())
            .prop_map(|(ior, r, t, ms)| format!("Brdf.Dielectric(.ior {ior}, .roughness {r}{t}{ms})")),
        1 => (pigment(textured), roughness(), multiple_scattering())
            .prop_map(|(p, r, ms)| format!("Brdf.Conductor(.pigment {p}, .roughness {r}{ms})")),
        1 => (prop::sample::select(vec!["Au", "Ag", "Cu", "Al"]), roughness(), multiple_scattering())
            .prop_map(|(m, r, ms)| format!("Brdf.Conductor(.metal \"{m}\", .roughness {r}{ms})")),
        1 => (colour(0.1, 3.0), colour(0.0, 5.0), roughness(), multiple_scattering())
            .prop_map(|(eta, k, r, ms)| format!("Brdf.Conductor(.eta {eta}, .k {k}, .roughness {r}{ms})")),
        1 => (pigment(textured), num(1.3, 1.7), roughness())
            .prop_map(|(p, ior, r)| format!("Brdf.Plastic(.pigment {p}, .ior {ior}, .roughness {r})")),
    ]
}

/// A material; a third of them emit. Where `textured`, its pigments may be checkered or
/// the sky image, its emission too (a fifth of the emitters each); otherwise all uniform,
/// as planes need (see [`plane_material`]).
fn material(textured: bool) -> impl Strategy<Value = String> {
    let uniform = colour(1.0, 6.0).prop_map(|c| format!(", .emitted_radiance Pigment.Uniform({c})"));
    let emission = if textured {
        prop_oneof![
            10 => Just(String::new()),
            3 => uniform,
            1 => (1u32..6, colour(1.0, 6.0))
                .prop_map(|(n, c)| format!(", .emitted_radiance Pigment.Checkered(.N {n}, .color_on {c}, .color_off <0, 0, 0>)")),
            1 => prop::sample::select(vec!["nearest", "bilinear"])
                .prop_map(|f| format!(", .emitted_radiance Pigment.Image(.image sky, .filter \"{f}\")")),
        ]
        .boxed()
    } else {
        prop_oneof![2 => Just(String::new()), 1 => uniform].boxed()
    };
    (brdf(textured), emission).prop_map(|(b, e)| format!("Material(.brdf {b}{e})"))
}

/// A placement in the box the camera looks at, |x|, |y| ≤ 1.5 and 0 ≤ z ≤ 1.5, at a size of
/// a fraction of it, turned about two axes.
fn placement() -> impl Strategy<Value = String> {
    let scale = prop_oneof![
        num(0.4, 1.0).prop_map(|s| format!("SCALE {s}")),
        (num(0.3, 1.0), num(0.3, 1.0), num(0.3, 1.0)).prop_map(|(x, y, z)| format!("SCALE({x}, {y}, {z})")),
    ];
    // A shear now and then: normals then need the inverse transpose, and cube faces are
    // no longer rectangles (area sampling instead of solid angle).
    let shear = prop_oneof![
        3 => Just(String::new()),
        1 => num(-0.8, 0.8).prop_map(|k| format!(" * Transformation([1, {k}, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])")),
    ];
    (num(-1.5, 1.5), num(-1.5, 1.5), num(0.0, 1.5), 0u32..360, 0u32..360, shear, scale).prop_map(
        |(x, y, z, a, b, k, s)| format!("frame * TRANSLATE({x}, {y}, {z}) * ROTATE(.Z {a} * .X {b}){k} * {s}"),
    )
}

fn material_name() -> impl Strategy<Value = String> {
    (0u32..4).prop_map(|i| format!("m{i}"))
}

/// The material of a plane (the floor, a half-space in CSG): `m0` or `m1`, untextured. An
/// infinite plane is met far away, where f32 holds a hit point only to ~1e-7 of its
/// distance: a lookup in a 1024-texel image moves by thousandths of a texel, a checker's
/// edge by as much, and paths that meet such planes at every bounce put whole regions a few
/// 1e-3 off the f64 image, while the means agree (seed 20's scene 48: the sky image emitted
/// by the floor under a rough glass ball around the camera, 88 % of the pixels within 1e-3
/// at 64×48, the means within 0.09 %; seed 21's scene 179: textured FUSEs of tilted
/// half-spaces, 90 %, 0.16 %; both 99.5 % with uniform pigments on the planes). f32's
/// limit, not a bug: docs/STABILITY.md "Found by tests/gpu_random_scenes.rs".
fn plane_material() -> impl Strategy<Value = String> {
    (0u32..2).prop_map(|i| format!("m{i}"))
}

fn primitive() -> impl Strategy<Value = String> {
    (prop::sample::select(vec!["Sphere", "Cube", "Cylinder"]), material_name(), placement())
        .prop_map(|(k, m, t)| format!("Shape.{k}(.material {m}, .transformation {t})"))
}

/// A CSG operand: a primitive near the tree's origin (so that the operands overlap), or a
/// half-space (a plane in CSG) through it now and then.
fn operand() -> impl Strategy<Value = String> {
    let half_space = (plane_material(), num(-0.3, 0.3), 0u32..360).prop_map(|(m, z, a)| {
        format!("Shape.Plane(.material {m}, .transformation TRANSLATE(0, 0, {z}) * ROTATE(.X {a}))")
    });
    prop_oneof![6 => solid_operand(), 1 => half_space]
}

fn solid_operand() -> impl Strategy<Value = String> {
    (
        prop::sample::select(vec!["Sphere", "Cube", "Cylinder"]),
        material_name(),
        num(-0.5, 0.5),
        num(-0.5, 0.5),
        0u32..90,
    )
        .prop_map(|(k, m, x, y, a)| {
            format!("Shape.{k}(.material {m}, .transformation TRANSLATE({x}, {y}, 0) * ROTATE(.Z {a}) * SCALE 0.7)")
        })
}

fn csg_node() -> impl Strategy<Value = String> {
    csg_node_of(vec!["UNITE", "INTERSECT", "DIFF", "FUSE"])
}

fn csg_node_of(ops: Vec<&'static str>) -> impl Strategy<Value = String> {
    (prop::sample::select(ops), prop::collection::vec(operand(), 2..4))
        .prop_map(|(op, kids)| format!("{op}({})", kids.join(", ")))
}

fn csg() -> impl Strategy<Value = String> {
    // A nested tree now and then (the outer node evaluates the inner one as a CSG operand).
    let tree = prop_oneof![
        3 => csg_node(),
        1 => (prop::sample::select(vec!["UNITE", "INTERSECT", "DIFF", "FUSE"]), csg_node(), operand())
            .prop_map(|(op, inner, leaf)| format!("{op}({inner}, {leaf})")),
    ];
    (tree, num(-1.2, 1.2), num(-1.2, 1.2), num(0.3, 1.2), 0u32..360).prop_map(|(t, x, y, z, a)| {
        let end = t.len() - 1;
        format!("{}, .transformation frame * TRANSLATE({x}, {y}, {z}) * ROTATE(.Z {a}) * SCALE 0.8)", &t[..end])
    })
}

/// A mesh: one of scenes/meshes, or half of the time the scene's own triangle soup
/// ([`soup`]).
fn mesh() -> impl Strategy<Value = String> {
    let file = prop_oneof![
        prop::sample::select(vec!["meshes/icosphere.ply", "meshes/torus_knot.obj", "meshes/panel.ply"]),
        Just(SOUP),
    ];
    (file, material_name(), 0u32..2, placement()).prop_map(|(f, m, smooth, t)| {
        format!("Shape.Mesh(.file \"{f}\", .material {m}, .smooth {smooth}, .transformation {t})")
    })
}

/// What a script writes for its triangle soup's file; the test writes the soup to a
/// temporary directory and puts the path there.
const SOUP: &str = "SOUP";

/// A scene's own OBJ triangle soup, in the unit cube: loose triangles (each with its own
/// uvs), a 4×4 height field (neighbours share their edges' end points exactly), exact
/// duplicates of loose triangles with other uvs (coincident faces within one mesh: which
/// one a ray reports must agree), and slivers (a vertex within 1e-3 of the opposite edge's
/// midpoint); per-vertex normals of any direction (many against their facet, whose
/// samples through it are dropped) or none.
fn soup() -> impl Strategy<Value = String> {
    let coord = || -0.5f64..0.5;
    let loose = (prop::array::uniform9(coord()), prop::array::uniform6(0.0f64..1.0));
    (
        prop::collection::vec(loose, 2..12),
        prop::collection::vec(-0.2f64..0.2, 16),
        (0usize..4, prop::array::uniform6(0.0f64..1.0)),
        prop::collection::vec((prop::array::uniform6(coord()), -1e-3f64..1e-3), 0..3),
        prop::option::weighted(0.6, prop::collection::vec(prop::array::uniform3(-1.0f64..1.0), 16)),
    )
        .prop_map(|(loose, heights, (copies, other_uvs), slivers, normals)| {
            // Triangles as corner lists of (position, uv).
            let mut tris: Vec<[([f64; 3], [f64; 2]); 3]> = Vec::new();
            for (p, uv) in &loose {
                tris.push([0, 1, 2].map(|k| ([p[3 * k], p[3 * k + 1], p[3 * k + 2]], [uv[2 * k], uv[2 * k + 1]])));
            }
            for (p, _) in loose.iter().take(copies) {
                tris.push(
                    [0, 1, 2]
                        .map(|k| ([p[3 * k], p[3 * k + 1], p[3 * k + 2]], [other_uvs[2 * k], other_uvs[2 * k + 1]])),
                );
            }
            let grid = |i: usize, j: usize| {
                ([i as f64 / 3.0 - 0.5, j as f64 / 3.0 - 0.5, heights[4 * i + j]], [i as f64 / 3.0, j as f64 / 3.0])
            };
            for i in 0..3 {
                for j in 0..3 {
                    tris.push([grid(i, j), grid(i + 1, j), grid(i + 1, j + 1)]);
                    tris.push([grid(i, j), grid(i + 1, j + 1), grid(i, j + 1)]);
                }
            }
            for (p, off) in &slivers {
                let (a, b) = ([p[0], p[1], p[2]], [p[3], p[4], p[5]]);
                let mid = [0, 1, 2].map(|k| 0.5 * (a[k] + b[k]) + off);
                tris.push([(a, [0.0, 0.0]), (b, [1.0, 0.0]), (mid, [0.5, 1.0])]);
            }
            let mut text = String::new();
            for t in &tris {
                for (p, uv) in t {
                    text += &format!("v {} {} {}\nvt {} {}\n", p[0], p[1], p[2], uv[0], uv[1]);
                }
            }
            if let Some(ns) = &normals {
                for k in 0..3 * tris.len() {
                    let n = ns[k % ns.len()];
                    text += &format!("vn {} {} {}\n", n[0], n[1], n[2]);
                }
            }
            for t in 0..tris.len() {
                let corner = |k: usize| {
                    let i = 3 * t + k + 1;
                    if normals.is_some() {
                        format!("{i}/{i}/{i}")
                    } else {
                        format!("{i}/{i}")
                    }
                };
                text += &format!("f {} {} {}\n", corner(0), corner(1), corner(2));
            }
            text
        })
}

/// A small object of the box the camera looks at, at `SCALE 0.1`–`0.3`.
fn small(kinds: Vec<&'static str>) -> impl Strategy<Value = String> {
    (prop::sample::select(kinds), material_name(), num(-1.5, 1.5), num(-1.5, 1.5), num(0.0, 1.5), num(0.1, 0.3))
        .prop_map(|(k, m, x, y, z, r)| {
            format!("Shape.{k}(.material {m}, .transformation frame * TRANSLATE({x}, {y}, {z}) * SCALE {r})")
        })
}

/// What the scene is made of: a few shapes of every kind (primitives, CSG trees, meshes),
/// or one of the layouts that switch the kernels' algorithms: ten to twenty objects walked
/// through a BVH (round spheres only, tested in the world, or mixed kinds), more CSG trees
/// than the traversal defers (`prepare::CSG_DEFER_MAX`), or one tree of seventy leaves (a
/// sweep table; DESIGN.md "CSG").
fn shapes() -> impl Strategy<Value = Vec<String>> {
    // (Not UNITE: a UNITE spawned at the top level renders as its separate parts.)
    let forest = prop::collection::vec(
        (csg_node_of(vec!["INTERSECT", "DIFF", "FUSE"]), num(-1.5, 1.5), num(-1.5, 1.5), num(0.0, 1.5)).prop_map(
            |(t, x, y, z)| {
                format!("{}, .transformation frame * TRANSLATE({x}, {y}, {z}) * SCALE 0.3)", &t[..t.len() - 1])
            },
        ),
        17..21,
    );
    let big_tree =
        (prop::sample::select(vec!["UNITE", "DIFF", "FUSE"]), prop::collection::vec(small(vec!["Sphere"]), 70))
            .prop_map(|(op, leaves)| {
                vec![format!("{op}(Shape.Sphere(.material m0, .transformation frame), {})", leaves.join(", "))]
            });
    prop_oneof![
        8 => prop::collection::vec(shape(), 1..5),
        2 => prop::collection::vec(small(vec!["Sphere"]), 10..20),
        1 => prop::collection::vec(small(vec!["Sphere", "Cube", "Cylinder"]), 10..20),
        1 => forest,
        1 => big_tree,
    ]
}

fn shape() -> impl Strategy<Value = String> {
    prop_oneof![4 => primitive(), 2 => csg(), 2 => mesh(), 1 => group()]
}

/// A UNITE spawned at the top level, which renders as its parts (each a top-level object
/// under the UNITE's transformation, an emitter among them an area light): primitives
/// placed as any others, the whole turned about z.
fn group() -> impl Strategy<Value = String> {
    (prop::collection::vec(primitive(), 2..4), 0u32..360)
        .prop_map(|(parts, a)| format!("UNITE({}, .transformation ROTATE(.Z {a}))", parts.join(", ")))
}

/// A point light in the scene's unit frame: position, colour and linear radius (none one
/// time in four: then the light does not fall off with distance, as in Raytracer.jl).
fn point_light() -> impl Strategy<Value = ([f64; 3], String, Option<f64>)> {
    let radius = prop_oneof![3 => (0.5..=3.0).prop_map(|r: f64| Some((r * 100.0).round() / 100.0)), 1 => Just(None)];
    (num(-2.0, 2.0), num(-2.0, 2.0), num(1.5, 4.0), colour(0.5, 3.0), radius)
        .prop_map(|(x, y, z, c, r)| ([x.parse().unwrap(), y.parse().unwrap(), z.parse().unwrap()], c, r))
}

/// A camera and its eye's position (`TRANSLATE(x, y, z)`, in the scene's unit frame).
fn camera() -> impl Strategy<Value = (String, String)> {
    prop_oneof![
        3 => (num(1.0, 2.0), num(-3.6, -2.6), num(-0.5, 0.5), num(1.0, 2.0), num(8.0, 20.0)).prop_map(
            |(d, x, y, z, tilt)| (format!(
                "Camera.Perspective(.aspect_ratio 1.333, .screen_distance {d}, .transformation frame * TRANSLATE({x}, {y}, {z}) * ROTATE(.Y {tilt}))"
            ), format!("TRANSLATE({x}, {y}, {z})"))
        ),
        // Tilted as the perspective camera is: parallel rays straight along x, through a
        // glass slab, leave it along x again, exactly on the sky image's middle row
        // boundary, where f32 and f64 round to either side (a whole region of one texel
        // against the other, not a bug).
        1 => (num(1.2, 2.5), num(8.0, 20.0)).prop_map(|(s, tilt)| (format!(
            "Camera.Orthogonal(.aspect_ratio 1.333, .transformation frame * TRANSLATE(-4, 0, 0.8) * ROTATE(.Y {tilt}) * SCALE {s})"
        ), "TRANSLATE(-4, 0, 0.8)".to_string())),
    ]
}

fn renderer() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (1u32..3, 1u32..6, 1u32..4, 0u32..2).prop_map(|(n, d, r, nee)| format!(
            "Renderer.PathTracer(.n {n}, .max_depth {d}, .roulette_depth {r}, .nee {nee})"
        )),
        1 => (colour(0.0, 0.5), 1u32..4).prop_map(|(c, d)| format!("Renderer.PathTracer(.background_color {c}, .max_depth {d})")),
        1 => colour(0.0, 0.5).prop_map(|c| format!("Renderer.Flat(.background_color {c})")),
        1 => prop_oneof![
            Just("Renderer.OnOff()".to_string()),
            (colour(0.0, 1.0), colour(0.0, 1.0)).prop_map(|(on, off)| format!("Renderer.OnOff(.on_color {on}, .off_color {off})")),
        ],
        1 => (colour(0.0, 0.3), colour(0.0, 0.2))
            .prop_map(|(b, a)| format!("Renderer.PointLight(.background_color {b}, .ambient_color {a})")),
    ]
}

/// An environment. The image's rotation has two decimals: with whole degrees, parallel
/// rays (the orthogonal camera) off a mirror face turned by whole degrees can all leave
/// along one direction exactly on a texel column's boundary (seed 2's scene 7: faces turned
/// by 77° and 271°, the sky by 336°, so 2·348° ≡ 336°, u = 0.5 exactly), where f32 and f64
/// round to opposite columns: a whole region of one texel against its neighbour, not a bug.
fn environment() -> impl Strategy<Value = String> {
    prop_oneof![
        1 => Just(String::new()),
        2 => colour(0.1, 1.0).prop_map(|c| format!("Environment.Uniform(.color {c})")),
        2 => (colour(0.1, 1.0), colour(0.1, 1.0), colour(0.0, 0.5))
            .prop_map(|(z, h, n)| format!("Environment.Gradient(.zenith {z}, .horizon {h}, .nadir {n})")),
        3 => (num(0.3, 1.5), num(0.0, 359.99))
            .prop_map(|(i, r)| format!("Environment.Image(.image sky, .intensity {i}, .rotation {r})")),
    ]
}

/// Now and then an object around the camera's eye (written at `EYE`), so that camera rays
/// start inside it: a box or a ball around the whole scene (a closed room, or a glass ball
/// whose inside refracts outward), a small ball or box, or a small CSG tree (the eye inside
/// an INTERSECT, or in the hollow a DIFF carves).
fn enclosure() -> impl Strategy<Value = Option<String>> {
    let around = prop_oneof![
        2 => Just("Shape.Cube(.material {m}, .transformation frame * TRANSLATE(0, 0, 1) * SCALE 9)"),
        2 => Just("Shape.Sphere(.material {m}, .transformation frame * TRANSLATE(0, 0, 1) * SCALE 6)"),
        1 => Just("Shape.Sphere(.material {m}, .transformation frame * EYE * SCALE 0.4)"),
        1 => Just("Shape.Cube(.material {m}, .transformation frame * EYE * ROTATE(.Z 30) * SCALE 0.7)"),
        1 => Just("INTERSECT(Shape.Sphere(.material {m}), Shape.Cube(.material {m}, .transformation ROTATE(.X 20) * SCALE 1.6), .transformation frame * EYE * SCALE 0.5)"),
        1 => Just("DIFF(Shape.Cube(.material {m}), Shape.Sphere(.material {m}, .transformation SCALE 0.6), .transformation frame * EYE * SCALE 0.8)"),
    ];
    let room = (around, material_name()).prop_map(|(shape, m)| shape.replace("{m}", &m));
    prop::option::weighted(0.25, room)
}

/// The scene's frame, in which the strategies place everything (`SET frame`): the unit
/// frame mostly, else the whole scene, camera and lights included, shrunk by 1000, grown
/// by 1000 or moved 1000 away from the origin. Radiance is the same at every scale, and the
/// two renderers must still agree: offsets, epsilons and bounds that assume a unit scene
/// fail here (docs/STABILITY.md tests the same on one hand-made scene).
fn frame() -> impl Strategy<Value = (String, f64, [f64; 3])> {
    prop_oneof![
        6 => Just(("SCALE 1".to_string(), 1.0, [0.0; 3])),
        1 => Just(("SCALE 0.001".to_string(), 0.001, [0.0; 3])),
        1 => Just(("SCALE 1000".to_string(), 1000.0, [0.0; 3])),
        1 => Just(("TRANSLATE(1000, -1000, 500)".to_string(), 1.0, [1000.0, -1000.0, 500.0])),
    ]
}

/// A whole script: four materials, the shapes, a floor three times in four, an object
/// around the eye one time in four, up to two point lights, at 8–24 × 6–18 pixels, in a random
/// frame.
fn script() -> impl Strategy<Value = String> {
    let size = (8u32..=24, 6u32..=18);
    (
        (material(false), material(false), material(true), material(true)).prop_map(|(a, b, c, d)| vec![a, b, c, d]),
        shapes(),
        prop::option::weighted(0.75, plane_material()),
        prop::collection::vec(point_light(), 0..3),
        (camera(), renderer(), environment()),
        (0u64..1 << 40, 0u64..1 << 40),
        enclosure(),
        (frame(), size),
    )
        .prop_map(|(materials, shapes, floor, lights, ((camera, eye), renderer, env), (state, inc), room, (frame, (w, h)))| {
            let (frame, scale, offset) = frame;
            let mut spawn = shapes;
            if let Some(m) = floor {
                spawn.push(format!("Shape.Plane(.material {m}, .transformation frame)"));
            }
            spawn.extend(room.map(|r| r.replace("EYE", &eye)));
            for (p, c, r) in lights {
                let [x, y, z] = [0, 1, 2].map(|i| p[i] * scale + offset[i]);
                let radius = r.map(|r| format!(", .linear_radius {}", r * scale)).unwrap_or_default();
                spawn.push(format!("Light(.position {{{x}, {y}, {z}}}, .color {c}{radius})"));
            }
            let set: Vec<String> = materials.iter().enumerate().map(|(i, m)| format!("m{i} {m}")).collect();
            format!(
                "SET\n    sky LOAD \"sky.hdr\"\n    frame {frame}\n    {}\nSPAWN\n    {}\nUSING\n    {camera}\n    Image({w}, {h})\n    {renderer}\n    Tracer(.samples_per_side 1, .rng Pcg(.state {state}, .inc {inc}))\n    {env}\n",
                set.join("\n    "),
                spawn.join("\n    "),
            )
        })
}

/// Scene `case`'s second comparison: a setting that `GpuRenderOptions` documents as leaving
/// the image the same (each table in storage buffers, uniform buffers or textures; one
/// queue shard or three; 32-bit words), which the scene must then render bit for bit as its
/// own kernels do.
fn invariant(case: u64, opts: &GpuRenderOptions) -> (&'static str, GpuRenderOptions) {
    let opts = opts.clone();
    match case % 6 {
        0 => ("tables in storage buffers", GpuRenderOptions { tables: TablePlacement::Storage, ..opts }),
        1 => ("tables in uniform buffers", GpuRenderOptions { tables: TablePlacement::Uniform, ..opts }),
        2 => ("tables in textures", GpuRenderOptions { tables: TablePlacement::Texture, ..opts }),
        3 => ("one queue shard", GpuRenderOptions { queue_shards: Some(1), ..opts }),
        4 => ("three queue shards", GpuRenderOptions { queue_shards: Some(3), ..opts }),
        _ => ("32-bit path words", GpuRenderOptions { wide_words: Some(false), ..opts }),
    }
}

fn env_number(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

#[test]
fn random_scenes_agree_with_the_cpu_and_the_full_kernels() {
    let Some(gpu) = gpu_for_tests("random_scenes_agree_with_the_cpu_and_the_full_kernels") else { return };
    let seed = env_number("LUMEN_RANDOM_SCENES_SEED", SEED);
    let cases = env_number("LUMEN_RANDOM_SCENES", CASES);
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    let mut runner = TestRunner::new_with_rng(Config::default(), TestRng::from_seed(RngAlgorithm::ChaCha, &key));
    let scenes_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let strategy = script();
    let soups = soup();
    let soup_dir = tempfile::tempdir().expect("temporary directory");
    let mut with_soup = 0;
    let mut renderer = GpuRenderer::new();
    let mut failures = Vec::new();
    let mut mostly_lit = 0;
    let mut reached = BTreeSet::new();
    for case in 0..cases {
        let mut text = strategy.new_tree(&mut runner).expect("strategy").current();
        // The scene's own triangle soup, where it uses one (printed with a failure).
        let mut soup_text = String::new();
        if text.contains(SOUP) {
            with_soup += 1;
            soup_text = soups.new_tree(&mut runner).expect("soup").current();
            let path = soup_dir.path().join(format!("soup{case}.obj"));
            std::fs::write(&path, &soup_text).expect("write the soup");
            text = text.replace(&format!("\"{SOUP}\""), &format!("{:?}", path.display().to_string()));
            soup_text = format!("\n{} holds:\n{soup_text}", path.display());
        }
        // 1-4 samples per pixel, in one round or one round per sample (the host's f64 sums
        // of the rounds' f32 films).
        let spp = 1 + runner.rng().next_u32() % 4;
        let per_round = if runner.rng().next_u32() % 2 == 0 { spp } else { 1 };
        let opts = GpuRenderOptions::fixed_passes(Some(spp), per_round);
        let cpu_opts = RenderOptions { spp: Some(spp), ..RenderOptions::default() };
        let name = format!("random scene {case} (seed {seed}, {spp} spp in rounds of {per_round})");
        let scene = load_str(&text, &name, &scenes_dir, &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{name} does not load: {e}\n{text}{soup_text}"));
        let spec = FeatureSet::of(&scene);
        let gpu_own = renderer.render(&gpu, &scene, &opts).unwrap_or_else(|e| panic!("{name}: {e}\n{text}{soup_text}"));
        let mut why = Vec::new();
        // The full kernels, then one of the settings documented not to change the image.
        let (label, other) = invariant(case, &opts);
        for (label, other) in
            [("the full kernels", GpuRenderOptions { features: Some(spec.full_for()), ..opts.clone() }), (label, other)]
        {
            let out = renderer
                .render(&gpu, &scene, &other)
                .unwrap_or_else(|e| panic!("{name}, {label}: {e}\n{text}{soup_text}"));
            // Bit for bit, but where the full kernels walk the BVH and the scene's own test
            // its objects as a list (a full kernel holds the meshes' code, and lists hold no
            // meshes): the two traversals compile to different code, and there scene 14 of
            // seed 1 moved a channel of two pixels by an ulp (rounding: multiply-adds that
            // LLVM fuses in one kernel and not the other); agreement to 1e-5 there.
            let same_code = out.features.lists_objects() == gpu_own.features.lists_objects();
            let agree = |a: f32, b: f32| {
                if same_code {
                    a.to_bits() == b.to_bits()
                } else {
                    (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1e-3)
                }
            };
            let differing = gpu_own
                .image
                .pixels()
                .iter()
                .zip(out.image.pixels())
                .filter(|(p, q)| !(agree(p.r, q.r) && agree(p.g, q.g) && agree(p.b, q.b)))
                .count();
            if differing > 0 {
                why.push(format!("{differing} pixels differ with {label}"));
            }
        }
        let cpu = cpu_render(&scene, &cpu_opts, Progress::Hidden);
        let a = agreement(&gpu_own.image, &cpu.image);
        reached.extend(gpu_own.features.names());
        let lit = cpu.image.pixels().iter().filter(|p| p.r + p.g + p.b > 0.0).count();
        if 2 * lit >= cpu.image.pixels().len() {
            mostly_lit += 1;
        }
        println!("{name}: {a}; {lit} pixels not black; {label}");
        if gpu_own.non_finite_samples > 0 {
            why.push(format!("{} non-finite GPU samples", gpu_own.non_finite_samples));
        }
        if a.check(Tolerance::share(MIN_SHARE)).is_err() {
            // Confirmed at 4× the width and height before it counts: a path that f32 and
            // f64 send different ways (mirror balls, glass) can hold a percent of a
            // 192-pixel image's light, a sixteenth of that at 4×, where a bug's error stays
            // (scene 206 of seed 10: means 1.02 % apart at 16×12, 0.0003 % at 64×48).
            let mut large = scene.clone();
            (large.width, large.height) = (4 * scene.width, 4 * scene.height);
            let g =
                renderer.render(&gpu, &large, &opts).unwrap_or_else(|e| panic!("{name} at 4×: {e}\n{text}{soup_text}"));
            let c = cpu_render(&large, &cpu_opts, Progress::Hidden);
            if let Err(e) = agreement(&g.image, &c.image).check(Tolerance::share(MIN_SHARE)) {
                let (w, h) = (scene.width, scene.height);
                why.push(format!("GPU vs CPU ({a} at {w}×{h}), at {}×{}: {e}", large.width, large.height));
            }
        }
        if !why.is_empty() {
            failures.push(format!("{name}: {}\n{text}{soup_text}", why.join("; ")));
        }
    }
    println!(
        "{} kernel sets compiled for {cases} scenes, {with_soup} with their own triangle soup",
        renderer.kernels_compiled()
    );
    let missed: Vec<&str> = FeatureSet::ALL_NAMES.iter().copied().filter(|n| !reached.contains(n)).collect();
    println!("kernel features no scene reached: {missed:?}");
    // The default run reaches every feature a scene decides, so a change of the strategies
    // that loses one fails here (choose another SEED or more CASES then).
    if seed == SEED && cases >= CASES {
        assert!(missed.is_empty(), "no scene reached {missed:?}");
    }
    // The comparisons prove little on black images: most scenes must show something.
    assert!(2 * mostly_lit >= cases, "only {mostly_lit} of {cases} scenes are at least half lit");
    assert!(failures.is_empty(), "{} of {cases} random scenes failed:\n\n{}", failures.len(), failures.join("\n\n"));
}
