//! BVH build over triangle meshes (issue 13): `Bvh::build` over one item per triangle of
//! generated tori of 1 k, 10 k, 100 k and 1 M triangles, with the build rate and the memory
//! of the nodes and primitive indices.
//!
//! - `cargo bench --bench mesh_bvh`: criterion (10 samples, flat sampling, short
//!   measurement), then one timed build per size on stderr (triangles/s, bytes).
//! - `LUMEN_BENCH_QUICK=1 cargo bench --bench mesh_bvh`: no criterion; one build per size,
//!   printed as a Markdown table (for BENCHMARKS.md).
//!
//! Only the build is timed: the items (triangle bounds) are made beforehand, as a mesh
//! loader would hand them over. The mesh is a torus of `rings × sides` quads (two triangles
//! each), so every size is an exact triangle count, the surface is curved and closed like a
//! real model, and its triangles are evenly sized (the SAH's easy-to-reason-about case).

use std::f64::consts::TAU;
use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, SamplingMode};
use glam::DVec3;
use lumen::accel::{Bvh, BvhItem};
use lumen::scene::Aabb;

/// (triangles, rings, sides): triangles = 2 · rings · sides.
const SIZES: [(usize, usize, usize); 4] =
    [(1_000, 25, 20), (10_000, 100, 50), (100_000, 250, 200), (1_000_000, 1000, 500)];

/// The triangles of a torus (major radius 1, minor 0.35, z up), as vertex triples.
fn torus(rings: usize, sides: usize) -> Vec<[DVec3; 3]> {
    let point = |i: usize, j: usize| {
        let (u, v) = (TAU * (i % rings) as f64 / rings as f64, TAU * (j % sides) as f64 / sides as f64);
        let r = 1.0 + 0.35 * v.cos();
        DVec3::new(r * u.cos(), r * u.sin(), 0.35 * v.sin())
    };
    let mut tris = Vec::with_capacity(2 * rings * sides);
    for i in 0..rings {
        for j in 0..sides {
            let (a, b, c, d) = (point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    tris
}

/// One item per triangle, its bounds the triangle's min/max.
fn items(tris: &[[DVec3; 3]]) -> Vec<BvhItem> {
    tris.iter()
        .enumerate()
        .map(|(i, [a, b, c])| BvhItem { id: i as u32, bounds: Aabb::new(a.min(*b).min(*c), a.max(*b).max(*c)) })
        .collect()
}

/// Bytes of the BVH's nodes and primitive indices.
fn bvh_bytes(bvh: &Bvh) -> usize {
    std::mem::size_of_val(bvh.nodes()) + std::mem::size_of_val(bvh.prim_indices())
}

/// One timed build: (seconds, the BVH).
fn time_once(items: &[BvhItem]) -> (f64, Bvh) {
    let start = Instant::now();
    let bvh = Bvh::build(black_box(items));
    (start.elapsed().as_secs_f64(), bvh)
}

fn quick_report(meshes: &[(usize, Vec<BvhItem>)]) {
    println!("| triangles | build (s) | Mtriangles/s | bytes/triangle | nodes | depth |");
    println!("|---:|---:|---:|---:|---:|---:|");
    for (n, items) in meshes {
        let (secs, bvh) = time_once(items);
        assert_eq!(bvh.prim_indices().len(), *n);
        println!(
            "| {n} | {secs:.4} | {:.2} | {:.1} | {} | {} |",
            *n as f64 / secs / 1e6,
            bvh_bytes(&bvh) as f64 / *n as f64,
            bvh.nodes().len(),
            bvh.depth()
        );
    }
}

fn criterion_bench(c: &mut Criterion, meshes: &[(usize, Vec<BvhItem>)]) {
    let mut group = c.benchmark_group("mesh_bvh_build");
    group.sample_size(10).sampling_mode(SamplingMode::Flat).warm_up_time(Duration::from_millis(300));
    for (n, items) in meshes {
        // Flat sampling with 10 samples runs ≥ 10 builds: allow ~2 µs per triangle (the 1 M
        // build takes ~1.6 s on a 2-core CI machine), so criterion does not warn.
        group.measurement_time(Duration::from_secs_f64((*n as f64 * 2e-6 * 10.0).clamp(1.0, 25.0)));
        group.bench_function(format!("{n}_triangles"), |b| b.iter(|| Bvh::build(black_box(items))));
    }
    group.finish();
    for (n, items) in meshes {
        let (secs, bvh) = time_once(items);
        eprintln!(
            "mesh_bvh: {n} triangles: {:.2} Mtriangles/s (one build, {secs:.4} s), nodes + indices {:.1} MB per million triangles",
            *n as f64 / secs / 1e6,
            bvh_bytes(&bvh) as f64 / *n as f64, // bytes per triangle = MB per million triangles
        );
    }
}

fn main() {
    let meshes: Vec<(usize, Vec<BvhItem>)> = SIZES
        .iter()
        .map(|&(n, rings, sides)| {
            let tris = torus(rings, sides);
            assert_eq!(tris.len(), n);
            (n, items(&tris))
        })
        .collect();
    if std::env::var("LUMEN_BENCH_QUICK").is_ok_and(|v| v == "1") {
        quick_report(&meshes);
        return;
    }
    let mut c = Criterion::default().configure_from_args();
    criterion_bench(&mut c, &meshes);
    c.final_summary();
}
