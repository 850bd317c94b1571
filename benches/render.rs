//! Criterion benches: BVH build over generated spheres and a small CPU render.
//! Run with `cargo bench --bench render`; `cargo test` does not build them.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use lumen::cli::bench::spheres_scene;
use lumen::cpu::{render, Progress, RenderOptions, World};

fn bvh_build(c: &mut Criterion) {
    let mut group = c.benchmark_group("bvh_build");
    group.sample_size(10);
    for n in [1_000u32, 10_000] {
        let scene = spheres_scene(n, 8, 8);
        group.bench_function(format!("{n}_spheres"), |b| b.iter(|| World::new(black_box(&scene))));
    }
    group.finish();
}

fn cpu_render(c: &mut Criterion) {
    let mut group = c.benchmark_group("cpu_render");
    group.sample_size(10);
    let scene = spheres_scene(100, 32, 24);
    group.bench_function("100_spheres_32x24_4spp", |b| {
        b.iter(|| {
            render(black_box(&scene), &RenderOptions { spp: Some(4), ..RenderOptions::default() }, Progress::Hidden)
        })
    });
    group.finish();
}

criterion_group!(benches, bvh_build, cpu_render);
criterion_main!(benches);
