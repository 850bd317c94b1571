//! Generates `scenes/spheres_10k.sl`: 10,000 small spheres on a jittered 100 × 100 grid
//! (SceneLang has no loops, so large scenes are written by a program). The output is
//! deterministic: positions, sizes and materials come from a fixed PCG32 seed.
//!
//! Run: `cargo run --release --example make_spheres -- scenes/spheres_10k.sl [side]`
//! (`side`² spheres; default 100).

use std::fmt::Write as _;
use std::path::PathBuf;

use lumen::sampling::Pcg32;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = PathBuf::from(args.next().unwrap_or_else(|| "scenes/spheres_10k.sl".into()));
    let side: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(100);
    let mut rng = Pcg32::new(2024, 7);
    let mut s = String::new();
    writeln!(s, "# {} spheres on a jittered {side} × {side} grid, written by", side * side)?;
    writeln!(s, "# `cargo run --release --example make_spheres` (do not edit by hand).")?;
    writeln!(s, "# A stress test for loading, BVH building and traversal.\n")?;
    s.push_str(
        "SET\n\
         \x20   floor Material(.brdf Brdf.Diffuse(Pigment.Checkered(.N 50, .color_on <0.6, 0.6, 0.6>, .color_off <0.35, 0.35, 0.35>)))\n\
         \x20   sun   Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)), .emitted_radiance Pigment.Uniform(<800, 750, 650>))\n\
         \x20   m0 Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.2, 0.15>)))\n\
         \x20   m1 Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.2, 0.7, 0.25>)))\n\
         \x20   m2 Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.15, 0.3, 0.8>)))\n\
         \x20   m3 Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.9, 0.75, 0.2>)))\n\
         \x20   m4 Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.7, 0.3, 0.7>)))\n\
         \x20   m5 Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.85, 0.85, 0.85>)))\n\
         \x20   m6 Material(.brdf Brdf.Specular(Pigment.Uniform(<0.9, 0.9, 0.9>)))\n\
         \x20   m7 Material(.brdf Brdf.Dielectric(.ior 1.5))\n\n\
         SPAWN\n\
         \x20   Shape.Plane(.material floor)\n\
         \x20   Shape.Sphere(.material sun, .transformation TRANSLATE(80, -60, 120) * SCALE 5)\n",
    );
    let extent = 25.0;
    let cell = 2.0 * extent / side as f64;
    for i in 0..side {
        for j in 0..side {
            let r = cell * (0.2 + 0.15 * rng.next_f64());
            let x = -extent + (i as f64 + 0.5) * cell + (rng.next_f64() - 0.5) * (cell - 2.0 * r);
            let y = -extent + (j as f64 + 0.5) * cell + (rng.next_f64() - 0.5) * (cell - 2.0 * r);
            let m = (rng.next_u32() % 8) as usize;
            writeln!(s, "    Shape.Sphere(m{m}, TRANSLATE({x:.3}, {y:.3}, {r:.3}) * SCALE {r:.3})")?;
        }
    }
    s.push_str(
        "\nUSING\n\
         \x20   Camera.Perspective(.aspect_ratio $16/9$, .screen_distance 1.6,\n\
         \x20                      .transformation TRANSLATE(-32, -6, 9) * ROTATE(.Z 10 * .Y 18))\n\
         \x20   Image(640, 360)\n\
         \x20   Renderer.PathTracer(.n 1, .max_depth 4)\n\
         \x20   Tracer(.samples_per_side 2)\n\
         \x20   Environment.Gradient(.zenith <0.3, 0.45, 0.9>, .horizon <0.9, 0.9, 0.95>, .nadir <0.2, 0.2, 0.2>)\n",
    );
    std::fs::write(&path, s)?;
    println!("wrote {} ({} spheres)", path.display(), side * side);
    Ok(())
}
