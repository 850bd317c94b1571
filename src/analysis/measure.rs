//! One timed render on a chosen device, with what `lumen converge` and `lumen bench` need
//! from it; devices that cannot be opened are skipped with a warning rather than failing a
//! whole study.

use crate::cpu::{self, paths_per_sample, Limits, Progress, RenderOptions};
pub use crate::device::{open_devices, Device, OpenDevice};
use crate::gpu::render::GpuRenderOptions;
use crate::gpu::PassOptions;
use crate::image::HdrImage;
use crate::scene::Scene;

/// What one render produced and cost.
#[derive(Debug, Clone)]
pub struct Measurement {
    /// The rendered image, linear radiance per pixel.
    pub image: HdrImage,
    /// Camera samples per pixel actually taken.
    pub spp: u32,
    /// Wall time of the whole render call (the GPU's includes packing, and kernel creation
    /// the first time a kernel is needed).
    pub seconds: f64,
    /// Radiance samples: pixels × spp × paths per sample.
    pub samples: u64,
    /// Rays traced: closest-hit and shadow rays, counted alike by both renderers.
    pub rays: u64,
    /// Samples whose radiance was NaN or infinite; the renderers count each as black.
    pub non_finite_samples: u64,
    /// CPU seconds of the whole process (every thread, the driver's included) during the
    /// render call ([`process_cpu_seconds`](super::process_cpu_seconds)); `None` where not
    /// known.
    pub cpu_seconds: Option<f64>,
}

impl Measurement {
    /// Radiance samples per wall-clock second ([`samples`](Self::samples) over
    /// [`seconds`](Self::seconds), the time clamped to at least 1e-12 s).
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-12)
    }
    /// Rays traced per wall-clock second (the time clamped as in [`Self::samples_per_second`]).
    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-12)
    }
}

/// Renders `scene` with `spp` camera samples per pixel on `device`.
///
/// ```
/// use lumen::analysis::{measure, open_devices, Device};
/// use lumen::color::Color;
/// use lumen::gpu::AdapterChoice;
/// use lumen::scene::{Renderer, SceneBuilder, Transform};
///
/// let mut b = SceneBuilder::new(4, 4);
/// let m = b.diffuse(Color::WHITE);
/// b.sphere(Transform::translation(glam::DVec3::new(3.0, 0.0, 0.0)), m)
///     .renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });
/// let scene = b.build().unwrap();
/// for device in open_devices(&[Device::Cpu], &AdapterChoice::new(None)) {
///     let m = measure(&device, &scene, 2, false).unwrap();
///     assert_eq!(m.samples, 4 * 4 * 2);
///     println!("{}: {:.0} samples/s", device.describe(), m.samples_per_second());
/// }
/// ```
pub fn measure(device: &OpenDevice, scene: &Scene, spp: u32, progress: bool) -> anyhow::Result<Measurement> {
    measure_with(device, scene, spp, progress, None)
}

/// [`measure`] with a GPU kernel override (`GpuRenderOptions::features`; the CPU ignores it).
pub fn measure_with(
    device: &OpenDevice,
    scene: &Scene,
    spp: u32,
    progress: bool,
    kernel: Option<crate::gpu::features::FeatureSet>,
) -> anyhow::Result<Measurement> {
    let cpu_before = super::process_cpu_seconds();
    let mut m = render_on(device, scene, spp, progress, kernel)?;
    m.cpu_seconds = cpu_before.zip(super::process_cpu_seconds()).map(|(a, b)| (b - a).max(0.0));
    Ok(m)
}

fn render_on(
    device: &OpenDevice,
    scene: &Scene,
    spp: u32,
    progress: bool,
    kernel: Option<crate::gpu::features::FeatureSet>,
) -> anyhow::Result<Measurement> {
    match device {
        OpenDevice::Cpu => {
            let bar = if progress { Progress::Bar } else { Progress::Hidden };
            let out = cpu::render_limited(
                scene,
                &RenderOptions { spp: Some(spp), ..RenderOptions::default() },
                &Limits::default(),
                bar,
            )?;
            Ok(Measurement {
                image: out.image,
                spp: out.stats.spp as u32,
                seconds: out.stats.seconds,
                samples: out.stats.samples,
                rays: out.stats.rays,
                non_finite_samples: out.stats.non_finite_samples,
                cpu_seconds: None,
            })
        }
        OpenDevice::Gpu { gpu, renderer } => {
            let opts = GpuRenderOptions {
                spp: Some(spp),
                passes: PassOptions { progress, ..PassOptions::default() },
                features: kernel,
                // A short render sets up what a longer one of the scene uses (a twin
                // device), so that a difference of two renders leaves fixed costs out.
                twin: crate::gpu::render::TwinUse::Warm,
                ..GpuRenderOptions::default()
            };
            let out = renderer.borrow_mut().render(gpu, scene, &opts)?;
            let pixels = u64::from(scene.width) * u64::from(scene.height);
            Ok(Measurement {
                image: out.image,
                spp: out.spp_done,
                seconds: out.seconds,
                samples: pixels * u64::from(out.spp_done) * paths_per_sample(scene),
                rays: out.rays,
                non_finite_samples: out.non_finite_samples,
                cpu_seconds: None,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Color;
    use crate::gpu::AdapterChoice;
    use crate::scene::{Renderer, SceneBuilder, Transform};

    #[test]
    fn cpu_measurement_counts_samples_and_rays() {
        let mut b = SceneBuilder::new(6, 4);
        let m = b.diffuse(Color::WHITE);
        b.sphere(Transform::translation(glam::DVec3::new(3.0, 0.0, 0.0)), m)
            .renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });
        let scene = b.build().unwrap();
        let devices = open_devices(&[Device::Cpu, Device::Cpu], &AdapterChoice::new(None));
        assert_eq!(devices.len(), 1);
        let m = measure(&devices[0], &scene, 4, false).unwrap();
        assert_eq!((m.spp, m.samples), (4, 6 * 4 * 4));
        // OnOff traces exactly one camera ray per sample.
        assert_eq!(m.rays, 6 * 4 * 4);
        // The render's own CPU time, where the platform tells it.
        if let Some(c) = m.cpu_seconds {
            assert!(c >= 0.0 && c.is_finite(), "{c}");
        }
        assert_eq!(m.image.width(), 6);
        assert_eq!(Device::Gpu.to_string(), "gpu");
    }
}
