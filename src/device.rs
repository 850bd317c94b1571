//! Where a render runs: the CPU reference renderer or a GPU through wgpu. One home for the
//! device choice and the opened device, used by `lumen render` and by the studies
//! (`lumen converge`, `lumen bench`, [`crate::analysis::measure`]).

use std::cell::RefCell;
use std::fmt;

use crate::gpu::render::GpuRenderer;
use crate::gpu::{AdapterChoice, Gpu, GpuError};

/// A device to measure (`lumen converge`, `lumen bench`: each is measured in turn).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Device {
    /// A GPU through wgpu (the adapter `--adapter` / $LUMEN_ADAPTER picks).
    Gpu,
    /// The f64 CPU reference renderer on every core.
    Cpu,
}

impl fmt::Display for Device {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Device::Gpu => "gpu",
            Device::Cpu => "cpu",
        })
    }
}

/// Where to render one image (`lumen render`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DeviceChoice {
    /// The f64 CPU reference renderer (all cores).
    Cpu,
    /// A GPU through wgpu; an error when none can be used.
    Gpu,
    /// The GPU when one can be used, else the CPU with a warning.
    Auto,
}

/// An opened device: the CPU, or a GPU with its open device and a renderer that keeps
/// compiled kernels, so only the first render of a kind of scene pays for kernel creation.
#[derive(Debug)]
pub enum OpenDevice {
    /// The f64 CPU reference renderer; nothing to open or keep.
    Cpu,
    /// A GPU opened through wgpu.
    Gpu {
        /// The open device on the chosen adapter (boxed, which keeps the enum small).
        gpu: Box<Gpu>,
        /// The renderer for this device, which keeps the kernels compiled by earlier renders; in
        /// a `RefCell` so that renders through a shared `&OpenDevice` can borrow it mutably.
        renderer: RefCell<GpuRenderer>,
    },
}

impl OpenDevice {
    /// The GPU with a fresh renderer.
    pub fn gpu(gpu: Gpu) -> Self {
        OpenDevice::Gpu { gpu: Box::new(gpu), renderer: RefCell::new(GpuRenderer::new()) }
    }

    /// The [`Device`] this is (CPU or GPU), without its opened state; [`open_devices`]
    /// compares it to drop duplicates.
    pub fn kind(&self) -> Device {
        match self {
            OpenDevice::Cpu => Device::Cpu,
            OpenDevice::Gpu { .. } => Device::Gpu,
        }
    }

    /// A name for tables: `cpu`, or `gpu` with the adapter's name.
    pub fn describe(&self) -> String {
        match self {
            OpenDevice::Cpu => format!("cpu ({} threads)", rayon::current_num_threads()),
            OpenDevice::Gpu { gpu, .. } => format!("gpu ({})", gpu.adapter_info.name),
        }
    }

    /// For a GPU, its backend and driver as wgpu reports them (`vulkan, llvmpipe Mesa
    /// 25.0.7 (LLVM 15.0.6)`): figures on a software adapter move with the driver's version
    /// (BENCHMARKS.md "Mesa 25 against Mesa 22 lavapipe"). `None` for the CPU.
    pub fn driver(&self) -> Option<String> {
        match self {
            OpenDevice::Cpu => None,
            OpenDevice::Gpu { gpu, .. } => Some(driver_text(&gpu.adapter_info)),
        }
    }
}

/// An adapter's backend and driver, as [`OpenDevice::driver`] reports them.
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
/// assert_eq!(lumen::device::driver_text(&info), "vulkan");
/// (info.driver, info.driver_info) = ("llvmpipe".into(), "Mesa 25.0.7 (LLVM 15.0.6)".into());
/// assert_eq!(lumen::device::driver_text(&info), "vulkan, llvmpipe Mesa 25.0.7 (LLVM 15.0.6)");
/// ```
pub fn driver_text(info: &wgpu::AdapterInfo) -> String {
    match crate::gpu::driver_name(info).as_str() {
        "" => info.backend.to_string(),
        d => format!("{}, {d}", info.backend),
    }
}

/// Opens each requested device once (duplicates dropped, order kept). A GPU that cannot be
/// opened is reported on standard error and skipped.
pub fn open_devices(devices: &[Device], adapter: &AdapterChoice) -> Vec<OpenDevice> {
    let mut out: Vec<OpenDevice> = Vec::new();
    for &d in devices {
        if out.iter().any(|o| o.kind() == d) {
            continue;
        }
        match d {
            Device::Cpu => out.push(OpenDevice::Cpu),
            Device::Gpu => match Gpu::new(adapter) {
                Ok(g) => out.push(OpenDevice::gpu(g)),
                Err(GpuError::NoAdapter) => crate::diag!("warning: skipping device gpu: no GPU adapter"),
                Err(e) => crate::diag!("warning: skipping device gpu: {e}"),
            },
        }
    }
    out
}

/// What lumen tells a user who renders on a software adapter (`None` on hardware): that the
/// CPU renderer comes close on some scenes (on Mesa 25's Vulkan lavapipe at lumen's 128
/// bits the GPU led every example scene, by the least on spheres_10k.sl, skybox.sl and
/// glass.sl: medians 1.37–2.61× on a 2-core AMD Zen 3 VM, 1.27–2.90× on a 2-core Intel Xeon
/// VM; BENCHMARKS.md "Wide uniform tables", "An Intel host, and kernel creation's
/// timeline", "Random scenes, the closest-hit rule and the goals"; at slow hours of the Zen 3 VM spheres_10k.sl had read 0.95–1.14× before the
/// wide words; other software adapters are unmeasured), except on an llvmpipe of Mesa 26.1 or later with
/// vectors wider than 256 bits, which ran every example scene 1.3–4.7× faster than the CPU
/// renderer on the AVX-512 hosts measured (BENCHMARKS.md "512-bit vectors on Mesa 26.1",
/// "An AMD Zen 4 host"). At 256 bits it does not always: on the Zen 3 host spheres_10k.sl
/// stayed at parity (0.98–1.01×). And, where wgpu reached Mesa's llvmpipe through OpenGL
/// (no Vulkan driver installed), that Mesa's Vulkan driver runs the same kernels faster
/// (1.05–1.5× on the example scenes, Mesa 25.0 both ways, side by side: BENCHMARKS.md "BVH
/// stacks out of the walk's struct").
///
/// ```
/// use lumen::device::software_adapter_note;
/// let vk = wgpu::AdapterInfo { name: "llvmpipe (LLVM 15.0.6, 128 bits)".into(), ..wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan) };
/// assert!(software_adapter_note(&vk).unwrap().contains("--device cpu"));
/// let wide = wgpu::AdapterInfo {
///     name: "llvmpipe (LLVM 19.1.7, 512 bits)".into(),
///     driver_info: "Mesa 26.1.6 (LLVM 19.1.7)".into(),
///     ..vk.clone()
/// };
/// assert!(!software_adapter_note(&wide).unwrap().contains("--device cpu"));
/// let avx2 = wgpu::AdapterInfo { name: "llvmpipe (LLVM 19.1.7, 256 bits)".into(), ..wide.clone() };
/// assert!(software_adapter_note(&avx2).unwrap().contains("--device cpu"));
/// let gl = wgpu::AdapterInfo { backend: wgpu::Backend::Gl, ..vk.clone() };
/// assert!(software_adapter_note(&gl).unwrap().contains("mesa-vulkan-drivers"));
/// let hw = wgpu::AdapterInfo::new(wgpu::DeviceType::DiscreteGpu, wgpu::Backend::Vulkan);
/// assert!(software_adapter_note(&hw).is_none());
/// ```
pub fn software_adapter_note(info: &wgpu::AdapterInfo) -> Option<String> {
    if info.device_type != wgpu::DeviceType::Cpu {
        return None;
    }
    let mut note = format!("note: {} is a software adapter (the GPU API emulated on the CPU)", info.name);
    let outruns_the_cpu = crate::gpu::llvmpipe_prefers_wide_vectors(info)
        && crate::gpu::llvmpipe_vector_bits(info).is_some_and(|bits| bits > 256);
    if !outruns_the_cpu {
        note.push_str("; lumen's own CPU renderer (--device cpu) comes close on some scenes");
    }
    if info.backend == wgpu::Backend::Gl && crate::gpu::is_llvmpipe(info) {
        note.push_str(
            "\nnote: it is reached through OpenGL; Mesa's Vulkan driver (lavapipe: Debian's and Ubuntu's \
             mesa-vulkan-drivers and libvulkan1) runs lumen's kernels faster",
        );
    }
    Some(note)
}

/// Opens the device `choice` asks for. `Auto` falls back to the CPU, with a warning, when no
/// GPU can be opened; an adapter asked for by name that does not exist is an error even
/// then (the user wanted that one).
pub fn open_device(choice: DeviceChoice, adapter: &AdapterChoice) -> Result<OpenDevice, GpuError> {
    let gpu_device = |g: Gpu| {
        if let Some(note) = software_adapter_note(&g.adapter_info) {
            crate::diag!("{note}");
        }
        OpenDevice::gpu(g)
    };
    match choice {
        DeviceChoice::Cpu => Ok(OpenDevice::Cpu),
        DeviceChoice::Gpu => Gpu::new(adapter).map(gpu_device),
        DeviceChoice::Auto => match Gpu::new(adapter) {
            Ok(g) => Ok(gpu_device(g)),
            Err(e @ GpuError::AdapterNotFound { .. }) => Err(e),
            Err(e) => {
                crate::diag!("warning: {e}");
                crate::diag!("warning: rendering on the CPU reference renderer instead (slower; --device cpu says so)");
                Ok(OpenDevice::Cpu)
            }
        },
    }
}
