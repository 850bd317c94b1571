//! Prints the table of docs/STABILITY.md: every case of the stability suite with its CPU
//! (f64) and GPU (f32) error against the expected answer.
//!
//! `cargo run --release --example stability_table` (set `LUMEN_ADAPTER` to pick the GPU;
//! without an adapter the GPU column says "no GPU").

#[path = "../tests/stability/cases.rs"]
mod cases;

use std::panic::{catch_unwind, AssertUnwindSafe};

fn num(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if x.fract() == 0.0 && x.abs() < 1e6 {
        format!("{x}")
    } else {
        format!("{x:.2e}")
    }
}

fn main() {
    let gpu = lumen::gpu::Gpu::new(&lumen::gpu::AdapterChoice::from_env()).ok();
    if let Some(g) = &gpu {
        eprintln!("GPU: {:?}", (&g.adapter_info.name, &g.adapter_info.driver_info));
    }
    type Case = fn(Option<&lumen::gpu::Gpu>) -> cases::Outcome;
    let list: Vec<(&str, Case)> = vec![
        ("scaled_down", cases::scaled_down),
        ("scaled_up", cases::scaled_up),
        ("translated", cases::translated),
        ("grazing_point_light", cases::grazing_point_light),
        ("grazing_plane_sky", cases::grazing_plane_sky),
        ("sphere_silhouette", cases::sphere_silhouette),
        ("cube_edges", cases::cube_edges),
        ("light_leak", cases::light_leak),
        ("tiny_sphere_orthogonal", cases::tiny_sphere_orthogonal),
        ("tiny_sphere_narrow", cases::tiny_sphere_narrow),
        ("inside_sphere", cases::inside_sphere),
        ("inside_cube", cases::inside_cube),
        ("inside_cube_nee", cases::inside_cube_nee),
        ("furnace_roulette", cases::furnace_roulette),
        ("many_paths_per_sample", cases::many_paths_per_sample),
        ("glass_rim_depth_3", cases::glass_rim_depth_3),
        ("glass_rim_depth_64", cases::glass_rim_depth_64),
        ("glass_cube_tir", cases::glass_cube_tir),
        ("csg_nested_8", cases::csg_nested_8),
        ("csg_coincident_sides", |g| cases::csg_coincident_sides(g, false)),
        ("csg_coincident_sides rotated", |g| cases::csg_coincident_sides(g, true)),
        ("csg_touching_face", cases::csg_touching_face),
        ("degenerate_scripts", |_| cases::degenerate_scripts()),
        ("extreme_transforms", cases::extreme_transforms),
        ("extreme_script_scales 1e18", |g| cases::extreme_script_scales(g, "1e18")),
        ("extreme_script_scales 1e30", |g| cases::extreme_script_scales(g, "1e30")),
        ("extreme_script_scales 1e300", |g| cases::extreme_script_scales(g, "1e300")),
    ];
    println!("| case | expected | error measure | CPU f64 | GPU f32 | tol. CPU / GPU | GPU ≈ CPU pixels | notes |");
    println!("|---|---|---|---|---|---|---|---|");
    for (name, case) in list {
        match catch_unwind(AssertUnwindSafe(|| case(gpu.as_ref()))) {
            Ok(o) => {
                let pass = o.cpu <= o.cpu_tolerance && o.gpu.is_none_or(|g| g <= o.gpu_tolerance);
                println!(
                    "| {} | {} | {} | {} | {} | {} / {} | {} | {}{} |",
                    o.case,
                    o.expected,
                    o.metric,
                    num(o.cpu),
                    o.gpu.map_or("no GPU".into(), num),
                    num(o.cpu_tolerance),
                    num(o.gpu_tolerance),
                    o.gpu_agrees_with_cpu.map_or("–".into(), |a| format!("{:.1}%", 100.0 * a)),
                    o.note,
                    if pass { "" } else { " **FAILS**" }
                );
            }
            Err(_) => println!("| {name} | | | | | | | **panicked** (see stderr) |"),
        }
    }
}
