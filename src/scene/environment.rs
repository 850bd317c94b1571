//! What rays that leave the scene see (SceneLang extension `Environment`).

use std::f64::consts::PI;
use std::sync::Arc;

use glam::DVec3;

use crate::color::Color;
use crate::image::HdrImage;

/// Radiance arriving from infinitely far away, as a function of world direction (z up):
/// what escaping rays see, and a light the path tracer samples with next-event estimation.
#[derive(Debug, Clone, PartialEq)]
pub enum Environment {
    /// The same radiance from every direction.
    Uniform(Color),
    /// Blends zenith → horizon for directions above the horizon and horizon → nadir below,
    /// linearly in the direction's z component.
    Gradient {
        /// Radiance straight up (+z).
        zenith: Color,
        /// Radiance along the horizon (z = 0).
        horizon: Color,
        /// Radiance straight down (−z).
        nadir: Color,
    },
    /// Equirectangular image, z up: u = atan2(y, x)/2π (wrapped to [0, 1)) after rotating
    /// by `rotation_deg` about z, v = acos(z)/π with row 0 at the zenith.
    Image {
        /// The map, in linear radiance (before `intensity`).
        image: Arc<HdrImage>,
        /// Factor on every texel (SceneLang's `.intensity`, default 1).
        intensity: f64,
        /// Turn of the map about +z, in degrees (SceneLang's `.rotation`).
        rotation_deg: f64,
    },
}

impl Environment {
    /// Radiance arriving along the escaping direction `dir` (any length).
    pub fn radiance(&self, dir: DVec3) -> Color {
        let d = dir.normalize();
        match self {
            Environment::Uniform(c) => *c,
            Environment::Gradient { zenith, horizon, nadir } => {
                if d.z >= 0.0 {
                    *horizon * (1.0 - d.z) + *zenith * d.z
                } else {
                    *horizon * (1.0 + d.z) + *nadir * (-d.z)
                }
            }
            Environment::Image { image, intensity, rotation_deg } => {
                let (u, v) = equirect_uv(d, *rotation_deg);
                let (w, h) = (image.width(), image.height());
                let col = ((u * w as f64) as usize).min(w - 1);
                let row = ((v * h as f64) as usize).min(h - 1);
                texel_radiance(image, *intensity, col, row)
            }
        }
    }
}

/// An image environment's radiance over texel (`col`, `row`): what every direction in the
/// texel sees (the lookup is nearest-texel).
pub fn texel_radiance(image: &HdrImage, intensity: f64, col: usize, row: usize) -> Color {
    Color::from(image.get(col, row)) * intensity
}

/// (u, v) of a unit direction on the equirectangular map, rotated by `rotation_deg` about z.
pub fn equirect_uv(d: DVec3, rotation_deg: f64) -> (f64, f64) {
    let mut u = (d.y.atan2(d.x) - rotation_deg.to_radians()) / (2.0 * PI);
    u -= u.floor();
    if u >= 1.0 {
        u = 0.0;
    }
    let v = d.z.clamp(-1.0, 1.0).acos() / PI;
    (u, v)
}
