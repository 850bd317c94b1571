//! Generates `scenes/sky.hdr`, the equirectangular environment that `scenes/skybox.sl`
//! reflects: a blue sky graded to a pale horizon, a bright sun, and a tiled ground that
//! shows off reflections and refractions.
//!
//! Run: `cargo run --release --example make_sky -- scenes/sky.hdr [width]` (height = width/2).
//! The map is equirectangular with z up, as lumen's `Environment.Image` reads it: column u
//! is the azimuth atan2(y, x)/2π, row v the polar angle acos(z)/π, row 0 at the zenith.

use std::f64::consts::PI;
use std::path::PathBuf;

use glam::DVec3;
use lumen::color::{Color, Rgb32};
use lumen::image::{write_image, HdrImage, ToneMap};

/// Direction of the sun: azimuth 40°, elevation 35°.
fn sun_dir() -> DVec3 {
    let (az, el) = (40f64.to_radians(), 35f64.to_radians());
    DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin())
}

fn radiance(d: DVec3) -> Color {
    let horizon = Color::new(0.95, 0.9, 0.85);
    if d.z >= 0.0 {
        let zenith = Color::new(0.18, 0.35, 0.85);
        let t = d.z.powf(0.6);
        let sky = horizon * (1.0 - t) + zenith * t;
        let cos_sun = d.dot(sun_dir());
        // A disc of about 4° across (about eleven texels wide at 1024 columns) and a soft halo.
        let disc = if cos_sun > 2f64.to_radians().cos() { 400.0 } else { 0.0 };
        let halo = 2.0 * cos_sun.max(0.0).powi(64);
        sky + Color::new(1.0, 0.95, 0.85) * (disc + halo)
    } else {
        // A tiled floor one unit below the viewer, fading into haze towards the horizon.
        let p = d * (-1.0 / d.z);
        let tile = (p.x.floor() as i64 + p.y.floor() as i64).rem_euclid(2) == 0;
        let ground = if tile { Color::new(0.45, 0.4, 0.33) } else { Color::new(0.1, 0.09, 0.08) };
        let haze = (-d.z * 4.0).min(1.0);
        horizon * 0.6 * (1.0 - haze) + ground * haze
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = PathBuf::from(args.next().unwrap_or_else(|| "scenes/sky.hdr".into()));
    let width: usize = args.next().map(|w| w.parse()).transpose()?.unwrap_or(1024);
    let height = (width / 2).max(1);
    // 4×4 supersampling per texel keeps the tile edges and the sun from aliasing.
    const S: usize = 4;
    let img = HdrImage::from_fn(width, height, |col, row| {
        let mut sum = Color::BLACK;
        for k in 0..S * S {
            let u = (col as f64 + ((k % S) as f64 + 0.5) / S as f64) / width as f64;
            let v = (row as f64 + ((k / S) as f64 + 0.5) / S as f64) / height as f64;
            let (phi, theta) = (2.0 * PI * u, PI * v);
            let d = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            sum += radiance(d);
        }
        Rgb32::from(sum / (S * S) as f64)
    });
    write_image(&path, &img, &ToneMap::default())?;
    println!("wrote {} ({width}×{height})", path.display());
    Ok(())
}
