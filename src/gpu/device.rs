//! Adapter selection and the logical device every GPU path shares.
//!
//! wgpu panics on validation errors by default; a renderer must instead report them. [`Gpu`]
//! installs an uncaptured-error handler and a device-lost callback that record what went
//! wrong, and [`Gpu::check`] / [`Gpu::scoped`] turn those records into [`GpuError`]s.

use std::fmt;
use std::sync::{Arc, Mutex, OnceLock};

use thiserror::Error;

/// Environment variable that selects an adapter when no `--adapter` is given.
pub const ADAPTER_ENV: &str = "LUMEN_ADAPTER";

/// Iterations the probe kernel asks for: more than llvmpipe's 65,535.
pub const LOOP_LIMITER_PROBE_TRIPS: u32 = 70_000;

/// Everything that can go wrong on the GPU side, as values rather than panics.
#[derive(Debug, Error)]
pub enum GpuError {
    /// wgpu found no adapter on any backend it tried: no GPU driver is installed, or
    /// `WGPU_BACKEND` names none that has one. The CPU renderer still works.
    #[error("no GPU adapter found ({})", no_adapter_hint())]
    NoAdapter,
    /// `--adapter` / `LUMEN_ADAPTER` names no adapter this machine has.
    #[error("no GPU adapter matches {wanted:?}; available adapters: {}", list_or_none(.available))]
    AdapterNotFound {
        /// The name asked for (matched as a case-insensitive substring).
        wanted: String,
        /// Every adapter found, best first, as [`AdapterDescription`] displays it.
        available: Vec<String>,
    },
    /// The adapter refused to open a device with its own limits and lumen's features.
    #[error("cannot open device on adapter {adapter:?}: {message}")]
    RequestDevice {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason.
        message: String,
    },
    /// naga could not parse or validate WGSL.
    #[error("shader {label:?} does not compile:\n{message}")]
    Shader {
        /// The shader's name; for an assembled program, the module file and line the error
        /// points at where naga gives one (`shaders/csg.wgsl:12`).
        label: String,
        /// naga's diagnostic, with an excerpt of the source.
        message: String,
    },
    /// A module has no `@compute` entry point of the name asked for.
    #[error("shader {label:?} has no compute entry point {entry:?}")]
    NoEntryPoint {
        /// The shader's name.
        label: String,
        /// The entry point asked for.
        entry: String,
    },
    /// A kernel declares a binding the compute runner cannot bind (only uniform and storage
    /// buffers and 2D `u32` textures are).
    #[error("shader {label:?}: binding @group({group}) @binding({binding}) is a {kind}, which the compute runner does not bind (only uniform and storage buffers and 2D u32 textures)")]
    UnsupportedBinding {
        /// The shader's name.
        label: String,
        /// The binding's `@group` index.
        group: u32,
        /// The binding's `@binding` index within its group.
        binding: u32,
        /// Its address space, as naga debug-prints it.
        kind: String,
    },
    /// A wgpu validation error, or a request lumen's GPU code refuses itself: bind groups that
    /// do not match a kernel's declarations, more bind groups or storage buffers than the
    /// adapter allows, a render plan out of range.
    #[error("GPU validation error: {0}")]
    Validation(String),
    /// wgpu could not allocate device memory (or a render its host-side accumulator).
    #[error("GPU out of memory: {0}")]
    OutOfMemory(String),
    /// wgpu's internal error, or an inconsistency in lumen's GPU code (a missing kernel,
    /// queue or bind group).
    #[error("GPU internal error: {0}")]
    Internal(String),
    /// The device was lost (driver reset, crash) or waiting on it failed: everything after
    /// is meaningless, so [`Gpu::check`] reports it before any other error.
    #[error("GPU device lost: {0}")]
    DeviceLost(String),
    /// Mapping a buffer for reading on the host failed, or a read asked for more than the
    /// buffer holds.
    #[error("reading a GPU buffer back failed: {0}")]
    Readback(String),
    /// Assembling a kernel's WGSL from `shaders/` failed.
    #[error(transparent)]
    Assemble(#[from] super::assemble::AssembleError),
    /// A buffer, texture or packed scene table exceeds one of the adapter's size limits (the
    /// path state of a batch is first retried with fewer slots).
    #[error("{what} needs {needed} bytes but this adapter allows at most {limit} bytes per {limit_name}")]
    TooLarge {
        /// The buffer's or texture's label, or the scene table's description.
        what: String,
        /// Bytes it needs.
        needed: u64,
        /// Bytes the limit allows.
        limit: u64,
        /// The wgpu limit that applies: "storage buffer binding", "buffer", "uniform buffer
        /// binding" or "2D texture".
        limit_name: &'static str,
    },
    /// The scene has what the GPU renderer cannot represent (more shapes or samples than
    /// its encodings address, a placement beyond f32's range): the CPU renderer, in f64 and
    /// without those encodings, renders it.
    #[error("the GPU renderer cannot take this scene: {0}")]
    Scene(super::pack::PackError),
    /// One camera sample's paths do not fit one batch: the GPU sums a sample's paths for a
    /// pixel within one batch (its film adds f32 values, [`MAX_PATHS_PER_PIXEL_PER_ROUND`]
    /// at most), and the scene's per-path state leaves fewer slots than that (a million
    /// point lights, each a shadow ray per path vertex), or `.n` asks for more. The message
    /// says which and why.
    ///
    /// [`MAX_PATHS_PER_PIXEL_PER_ROUND`]: crate::gpu::wavefront::MAX_PATHS_PER_PIXEL_PER_ROUND
    #[error("one camera sample's {paths} paths do not fit one GPU batch: {reason}")]
    SampleExceedsBatch {
        /// The renderer's paths per camera sample (`Renderer.PathTracer`'s `.n`).
        paths: u32,
        /// What limits the batch, in words with its figures.
        reason: String,
    },
    /// A ray passed more hidden crossings of a CSG tree than its kernels walk without the
    /// sweeps: the render starts again with them (`gpu::render`; never returned from it).
    #[error("a CSG query exceeded the walk budget of kernels without sweeps")]
    CsgSweepsNeeded,
}

/// What to do about [`GpuError::NoAdapter`]: install a driver, or, where `WGPU_BACKEND`
/// limits the backends wgpu tries (an unknown name leaves none), unset it.
fn no_adapter_hint() -> String {
    match std::env::var("WGPU_BACKEND") {
        Ok(v) if !v.trim().is_empty() => {
            format!("WGPU_BACKEND={v:?} limits the backends tried: unset it, or name vulkan, metal, dx12 or gl")
        }
        _ => "install a Vulkan, Metal or DX12 driver; on Linux Mesa's lavapipe works without a GPU".to_string(),
    }
}

fn list_or_none(names: &[String]) -> String {
    if names.is_empty() {
        "none".to_string()
    } else {
        names.iter().map(|n| format!("{n:?}")).collect::<Vec<_>>().join(", ")
    }
}

impl From<wgpu::Error> for GpuError {
    fn from(e: wgpu::Error) -> Self {
        match e {
            wgpu::Error::OutOfMemory { source } => GpuError::OutOfMemory(source.to_string()),
            wgpu::Error::Validation { description, .. } => GpuError::Validation(description),
            wgpu::Error::Internal { description, .. } => GpuError::Internal(description),
        }
    }
}

/// Which adapter to use: `None` picks the best one (discrete > integrated > virtual > CPU).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AdapterChoice {
    /// Case-insensitive substring of the adapter name (`lumen devices` lists names).
    pub name: Option<String>,
}

impl AdapterChoice {
    /// The command line's `--adapter` if given, else the `LUMEN_ADAPTER` environment variable.
    pub fn new(cli: Option<String>) -> Self {
        Self::chosen(cli, std::env::var(ADAPTER_ENV).ok())
    }

    /// The rule of [`Self::new`] on given values: the command line's name over the
    /// environment's, a blank name (empty or spaces) counting as none.
    fn chosen(cli: Option<String>, env: Option<String>) -> Self {
        let given = |s: Option<String>| s.filter(|s| !s.trim().is_empty());
        Self { name: given(cli).or(given(env)) }
    }

    /// Only the environment (`LUMEN_ADAPTER`): what tests and library callers use.
    pub fn from_env() -> Self {
        Self::new(None)
    }
}

/// One adapter as `lumen devices` reports it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AdapterDescription {
    /// The adapter's name as the driver reports it (`llvmpipe (LLVM 15.0.6, 256 bits)`), which
    /// `--adapter` matches against.
    pub name: String,
    /// The graphics API wgpu reaches it through (Vulkan, Metal, DX12, OpenGL).
    pub backend: wgpu::Backend,
    /// Discrete, integrated, virtual, CPU (software) or other.
    pub device_type: wgpu::DeviceType,
    /// The driver's name (`llvmpipe`), possibly empty.
    pub driver: String,
    /// The driver's version details (`Mesa 25.0.7 (LLVM 15.0.6)`), possibly empty.
    pub driver_info: String,
}

impl AdapterDescription {
    fn from_info(info: &wgpu::AdapterInfo) -> Self {
        Self {
            name: info.name.clone(),
            backend: info.backend,
            device_type: info.device_type,
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
        }
    }

    /// The adapter information this description was made from (as [`on_adapter_chosen`]'s
    /// hook receives it).
    pub fn info(&self) -> wgpu::AdapterInfo {
        let mut info = wgpu::AdapterInfo::new(self.device_type, self.backend);
        (info.name, info.driver, info.driver_info) = (self.name.clone(), self.driver.clone(), self.driver_info.clone());
        info
    }

    /// A human word for the device type.
    pub fn device_type_name(&self) -> &'static str {
        device_type_name(self.device_type)
    }

    /// The driver's name and version, as [`driver_name`] gives them.
    pub fn driver_name(&self) -> String {
        join_driver(&self.driver, &self.driver_info)
    }
}

impl fmt::Display for AdapterDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}, {}", self.name, self.backend, self.device_type_name())?;
        match self.driver_name().as_str() {
            "" => write!(f, ")"),
            driver => write!(f, ", driver {driver})"),
        }
    }
}

/// An adapter's driver as wgpu reports it: its name and its version details joined
/// (`llvmpipe Mesa 25.0.7 (LLVM 15.0.6)`), empty where the driver says neither. What
/// `lumen devices` lists and the benchmark reports name.
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
/// assert_eq!(lumen::gpu::driver_name(&info), "");
/// info.driver_info = " Mesa 25.0.7 ".into();
/// assert_eq!(lumen::gpu::driver_name(&info), "Mesa 25.0.7");
/// ```
pub fn driver_name(info: &wgpu::AdapterInfo) -> String {
    join_driver(&info.driver, &info.driver_info)
}

fn join_driver(driver: &str, details: &str) -> String {
    [driver.trim(), details.trim()].join(" ").trim().to_string()
}

fn device_type_name(t: wgpu::DeviceType) -> &'static str {
    match t {
        wgpu::DeviceType::DiscreteGpu => "discrete GPU",
        wgpu::DeviceType::IntegratedGpu => "integrated GPU",
        wgpu::DeviceType::VirtualGpu => "virtual GPU",
        wgpu::DeviceType::Cpu => "CPU (software)",
        wgpu::DeviceType::Other => "other",
    }
}

/// Preference order when no name is given: real GPUs first, and among equals the primary
/// backends (Vulkan/Metal/DX12) before OpenGL, whose compute support is the weakest.
fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let ty = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let backend = u8::from(info.backend == wgpu::Backend::Gl);
    (ty, backend)
}

/// wgpu's instance flags for lumen: the build's defaults without indirect-call validation
/// (the `WGPU_*` variables still override each flag).
///
/// That validation runs an extra compute dispatch before every `dispatch_workgroups_indirect`
/// to clamp its arguments; the wavefront renderer makes most of its launches indirect, so on
/// lavapipe, where a launch costs about 50 µs whatever its size, it doubled their number for
/// nothing (skybox.sl rendered 10 % faster without it, DESIGN.md "Queues and launches").
/// lumen's indirect arguments are written only by the host and its own kernels (the pushes
/// of `shaders/wf_path.wgsl`), within the limits by construction: x ≤ `contract::MAX_GRID` =
/// 65,535 (WebGPU's minimum `max_compute_workgroups_per_dimension`; a batch has at most
/// 64 · 65,535 slots), y = z = 1. Without the validation D3D12 would report
/// `num_workgroups` as 0, so no kernel reads that builtin (every launch is one row, and
/// the slot an invocation takes comes from its workgroup's x: `wf_slot`, `wf_direct_slot`).
fn instance_flags() -> wgpu::InstanceFlags {
    wgpu::InstanceFlags::from_build_config() - wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL
}

/// Adapters to choose from, best first.
///
/// Vulkan/Metal/DX12 are enumerated first and OpenGL only when none of those has an
/// adapter: probing EGL on a headless machine prints noise and GL compute is the weakest
/// backend. `WGPU_BACKEND` (e.g. `gl`, `vulkan`) overrides the set, for debugging.
fn enumerate() -> Vec<wgpu::Adapter> {
    let probe = |backends: wgpu::Backends| {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        desc.flags = instance_flags();
        let desc = desc.with_env();
        let instance = wgpu::Instance::new(desc);
        let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
        // The no-op backend (if compiled in) is not a device anyone wants to render on.
        adapters.retain(|a| a.get_info().backend != wgpu::Backend::Noop);
        adapters
    };
    let mut adapters = match wgpu::Backends::from_env() {
        Some(forced) => probe(forced),
        None => {
            let primary = probe(wgpu::Backends::PRIMARY);
            if primary.is_empty() {
                probe(wgpu::Backends::SECONDARY)
            } else {
                primary
            }
        }
    };
    adapters.sort_by_key(|a| rank(&a.get_info()));
    adapters
}

/// Whether `info` is Mesa's llvmpipe (through Vulkan, where it is lavapipe, or OpenGL): the
/// software adapter whose compilation, loop limits and speed lumen plans around.
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
/// info.name = "llvmpipe (LLVM 15.0.6, 128 bits)".into();
/// assert!(lumen::gpu::is_llvmpipe(&info));
/// info.name = "SwiftShader Device".into();
/// assert!(!lumen::gpu::is_llvmpipe(&info));
/// ```
pub fn is_llvmpipe(info: &wgpu::AdapterInfo) -> bool {
    info.name.to_ascii_lowercase().contains("llvmpipe")
}

/// llvmpipe's SIMD width in bits, from its adapter name ("llvmpipe (LLVM 19.1.7, 256 bits)").
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
/// info.name = "llvmpipe (LLVM 19.1.7, 256 bits)".into();
/// assert_eq!(lumen::gpu::llvmpipe_vector_bits(&info), Some(256));
/// info.name = "NVIDIA H100".into();
/// assert_eq!(lumen::gpu::llvmpipe_vector_bits(&info), None);
/// ```
pub fn llvmpipe_vector_bits(info: &wgpu::AdapterInfo) -> Option<u32> {
    if !is_llvmpipe(info) {
        return None;
    }
    let words: Vec<&str> = info.name.split(|c: char| c.is_whitespace() || c == ',' || c == '(' || c == ')').collect();
    words.windows(2).find(|w| w[1] == "bits").and_then(|w| w[0].parse().ok())
}

/// The Mesa release (major, minor) of a Mesa driver, from the driver information its
/// adapter reports ("Mesa 26.1.6-1~bpo13+1 (LLVM 19.1.7)" on Vulkan, "4.5 (Core Profile)
/// Mesa 25.0.7" on OpenGL).
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
/// info.driver_info = "Mesa 26.1.6-1~bpo13+1 (LLVM 19.1.7)".into();
/// assert_eq!(lumen::gpu::mesa_version(&info), Some((26, 1)));
/// info.driver_info = "580.159.04".into();
/// assert_eq!(lumen::gpu::mesa_version(&info), None);
/// ```
pub fn mesa_version(info: &wgpu::AdapterInfo) -> Option<(u32, u32)> {
    let (_, rest) = info.driver_info.split_once("Mesa ")?;
    let mut parts = rest.split(|c: char| !c.is_ascii_digit());
    let major = parts.next()?.parse().ok()?;
    let minor = parts.next()?.parse().ok()?;
    Some((major, minor))
}

/// The first Mesa release whose llvmpipe was measured to run lumen's kernels faster with
/// 256-bit vectors than with 128: it compiles lane-divergent loads into gathers
/// (BENCHMARKS.md "Mesa 26.1 lavapipe on an Intel host"; Mesa 25.0 does not, and the
/// releases between were not tried).
pub const WIDE_VECTORS_FROM_MESA: (u32, u32) = (26, 1);

/// Whether `info` is an llvmpipe of Mesa [`WIDE_VECTORS_FROM_MESA`] or later, whatever
/// width it runs at now.
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
/// info.name = "llvmpipe (LLVM 19.1.7, 128 bits)".into();
/// info.driver_info = "Mesa 26.1.6 (LLVM 19.1.7)".into();
/// assert!(lumen::gpu::llvmpipe_prefers_wide_vectors(&info));
/// info.driver_info = "Mesa 25.0.7 (LLVM 15.0.6)".into();
/// assert!(!lumen::gpu::llvmpipe_prefers_wide_vectors(&info));
/// ```
pub fn llvmpipe_prefers_wide_vectors(info: &wgpu::AdapterInfo) -> bool {
    is_llvmpipe(info) && mesa_version(info).is_some_and(|v| v >= WIDE_VECTORS_FROM_MESA)
}

/// Whether lumen reads scene tables through `textureLoad` on this adapter (software
/// adapters only place tables in textures at all: `tables::TableForms::choose`).
///
/// Mesa 26.1's llvmpipe fetches texels wrongly or crashes, at every vector width on some
/// host: on an Intel host at 256 bits the one-invocation kernel of `Gpu::u32_texture`'s
/// example crashed in the JIT code and renders with texture tables disagreed with the CPU
/// on a sixth of their pixels (BENCHMARKS.md "Mesa 26.1 lavapipe on an Intel host"), and at
/// 256 and 512 bits a spheres_10k.sl render with its tables in textures died of SIGSEGV
/// ("512-bit vectors on Mesa 26.1"); on an AMD Zen 4 host at 128 bits, the width that had
/// passed every test on Intel, spheres_10k.sl and meshes.sl died of SIGSEGV with lumen's
/// own placement and every example scene with `--tables texture` ("Zen 4", 2026-12-06).
/// The same kernels with the tables in uniform or storage buffers were right everywhere.
/// So on llvmpipe only Mesa up to 25.0, which passed every test at every width on both
/// hosts, reads tables from textures; later releases keep them in buffers until one is
/// measured.
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
/// info.name = "llvmpipe (LLVM 19.1.7, 128 bits)".into();
/// info.driver_info = "Mesa 26.1.6 (LLVM 19.1.7)".into();
/// assert!(!lumen::gpu::texel_fetches_trusted(&info));
/// info.name = "llvmpipe (LLVM 15.0.6, 128 bits)".into();
/// info.driver_info = "Mesa 25.0.7 (LLVM 15.0.6)".into();
/// assert!(lumen::gpu::texel_fetches_trusted(&info));
/// ```
pub fn texel_fetches_trusted(info: &wgpu::AdapterInfo) -> bool {
    !is_llvmpipe(info) || mesa_version(info).is_some_and(|v| v <= (25, 0))
}

/// The function [`Gpu::new`] calls with the adapter it chose, before opening it.
static ADAPTER_HOOK: OnceLock<fn(&wgpu::AdapterInfo)> = OnceLock::new();

/// Registers `hook`, called with the adapter every [`Gpu::new`] chooses before the device
/// is opened; only the first registration counts. The `lumen` program relaunches itself
/// there when the driver would run its kernels faster with settings it reads only at
/// start-up (`cli::software_driver`); a library cannot do that on its own behalf.
///
/// ```
/// fn show(info: &wgpu::AdapterInfo) {
///     eprintln!("opening {}", info.name);
/// }
/// lumen::gpu::on_adapter_chosen(show);
/// ```
pub fn on_adapter_chosen(hook: fn(&wgpu::AdapterInfo)) {
    let _ = ADAPTER_HOOK.set(hook);
}

/// All adapters this machine offers, best first.
///
/// ```
/// for a in lumen::gpu::list_adapters() {
///     println!("{a}");
/// }
/// ```
pub fn list_adapters() -> Vec<AdapterDescription> {
    enumerate().iter().map(|a| AdapterDescription::from_info(&a.get_info())).collect()
}

/// Index of the adapter `choice` selects in `adapters` (ordered best first, as
/// [`list_adapters`] returns them): the first one whose name contains the wanted name,
/// ignoring case, or the first one when no name is given.
///
/// ```
/// use lumen::gpu::{select_adapter, AdapterChoice, AdapterDescription};
/// let a = |name: &str| AdapterDescription {
///     name: name.into(),
///     backend: wgpu::Backend::Vulkan,
///     device_type: wgpu::DeviceType::DiscreteGpu,
///     driver: String::new(),
///     driver_info: String::new(),
/// };
/// let list = [a("NVIDIA GeForce RTX 4090"), a("llvmpipe (LLVM 15)")];
/// assert_eq!(select_adapter(&list, &AdapterChoice { name: None }).unwrap(), 0);
/// assert_eq!(select_adapter(&list, &AdapterChoice { name: Some("LLVM".into()) }).unwrap(), 1);
/// assert!(select_adapter(&list, &AdapterChoice { name: Some("radeon".into()) }).is_err());
/// ```
pub fn select_adapter(adapters: &[AdapterDescription], choice: &AdapterChoice) -> Result<usize, GpuError> {
    if adapters.is_empty() {
        return Err(GpuError::NoAdapter);
    }
    let Some(wanted) = &choice.name else { return Ok(0) };
    let needle = wanted.to_lowercase();
    adapters.iter().position(|a| a.name.to_lowercase().contains(&needle)).ok_or_else(|| GpuError::AdapterNotFound {
        wanted: wanted.clone(),
        available: adapters.iter().map(|a| a.to_string()).collect(),
    })
}

/// Errors recorded by wgpu's callbacks, outside any error scope.
#[derive(Debug, Default)]
struct ErrorSink {
    errors: Vec<GpuError>,
}

/// An open device on one adapter, plus what a renderer needs to know about it.
#[derive(Debug)]
pub struct Gpu {
    /// The logical device: creates buffers, textures and pipelines. Its uncaptured errors and
    /// loss are recorded for [`Gpu::check`] instead of panicking.
    pub device: wgpu::Device,
    /// The device's only queue, which every submission goes through.
    pub queue: wgpu::Queue,
    /// What the chosen adapter reports of itself: name, backend, type, driver.
    pub adapter_info: wgpu::AdapterInfo,
    /// The limits the device was opened with: the adapter's own, not wgpu's defaults, so
    /// that large scenes (big storage buffers) fit wherever the hardware allows.
    pub limits: wgpu::Limits,
    /// Driver pipeline binaries kept across runs, where wgpu supports it (Vulkan); see
    /// `src/gpu/pipeline_cache.rs`.
    pub(crate) pipeline_cache: Option<super::pipeline_cache::DiskPipelineCache>,
    sink: Arc<Mutex<ErrorSink>>,
}

impl Gpu {
    /// Opens the chosen adapter (see [`AdapterChoice`]) with its full limits.
    ///
    /// ```
    /// use lumen::gpu::{AdapterChoice, Gpu, GpuError};
    /// match Gpu::new(&AdapterChoice::from_env()) {
    ///     Ok(gpu) => println!("rendering on {}", gpu.description()),
    ///     Err(GpuError::NoAdapter) => println!("no GPU adapter: use the CPU renderer"),
    ///     Err(e) => panic!("{e}"),
    /// }
    /// ```
    pub fn new(choice: &AdapterChoice) -> Result<Gpu, GpuError> {
        let adapters = enumerate();
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        let descriptions: Vec<AdapterDescription> =
            adapters.iter().map(|a| AdapterDescription::from_info(&a.get_info())).collect();
        let index = select_adapter(&descriptions, choice)?;
        let adapter = adapters.into_iter().nth(index).ok_or(GpuError::NoAdapter)?;
        if let Some(hook) = ADAPTER_HOOK.get() {
            hook(&adapter.get_info());
        }
        Self::open(adapter)
    }

    /// A second device on this device's adapter, opened through a wgpu instance of its own
    /// and without the pipeline cache file: for work that must not share this device's
    /// queue (`parallel_jit`). `None` when the adapter is no longer found.
    pub(crate) fn twin(&self) -> Option<Gpu> {
        let adapter = enumerate().into_iter().find(|a| a.get_info() == self.adapter_info)?;
        Self::open_with(adapter, false).ok()
    }

    fn open(adapter: wgpu::Adapter) -> Result<Gpu, GpuError> {
        Self::open_with(adapter, true)
    }

    fn open_with(adapter: wgpu::Adapter, pipeline_cache: bool) -> Result<Gpu, GpuError> {
        let adapter_info = adapter.get_info();
        let limits = adapter.limits();
        let desc = wgpu::DeviceDescriptor {
            label: Some("lumen"),
            // Only to keep compiled pipelines across runs, timestamps for profiled renders
            // (`GpuRenderOptions::profile`) and, on llvmpipe, 64-bit integers for the path
            // state's words (`wavefront::wide_words`), where the adapter offers them.
            required_features: adapter.features()
                & (wgpu::Features::PIPELINE_CACHE
                    | super::wavefront::profile::FEATURES
                    | super::wavefront::wide_words_features(&adapter_info)),
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&desc))
            .map_err(|e| GpuError::RequestDevice { adapter: adapter_info.name.clone(), message: e.to_string() })?;
        let sink = Arc::new(Mutex::new(ErrorSink::default()));
        let s = Arc::clone(&sink);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut sink) = s.lock() {
                sink.errors.push(e.into());
            }
        }));
        let s = Arc::clone(&sink);
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut sink) = s.lock() {
                sink.errors.push(GpuError::DeviceLost(format!("{reason:?}: {message}")));
            }
        });
        let pipeline_cache = super::pipeline_cache::cache_dir_from_env()
            .filter(|_| pipeline_cache)
            .and_then(|dir| super::pipeline_cache::DiskPipelineCache::open(&device, &adapter_info, &dir));
        Ok(Gpu { device, queue, adapter_info, limits, pipeline_cache, sink })
    }

    /// This device's adapter, as `lumen devices` would print it.
    pub fn description(&self) -> AdapterDescription {
        AdapterDescription::from_info(&self.adapter_info)
    }

    /// Returns (and clears) the first error wgpu reported outside an error scope since the
    /// last check (a device loss before any other): validation errors, out-of-memory.
    pub fn check(&self) -> Result<(), GpuError> {
        let mut sink = self.sink.lock().unwrap_or_else(|p| p.into_inner());
        // A lost device explains every later error, so it is reported first.
        let lost = sink.errors.iter().position(|e| matches!(e, GpuError::DeviceLost(_)));
        match lost.or((!sink.errors.is_empty()).then_some(0)) {
            None => Ok(()),
            Some(i) => {
                let e = sink.errors.swap_remove(i);
                sink.errors.clear();
                Err(e)
            }
        }
    }

    /// Runs `f` inside validation and out-of-memory error scopes and returns the first error
    /// either caught (or one already pending from [`Self::check`]).
    ///
    /// Error scopes are per thread in wgpu, so `f` must do its GPU calls on this thread.
    pub fn scoped<T>(&self, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let value = f();
        let v = pollster::block_on(validation.pop());
        let o = pollster::block_on(oom.pop());
        // A device loss explains the scope's errors ("buffer is invalid"): report it first.
        // The loss callback runs from a poll; a non-blocking one is cheap.
        if v.is_some() || o.is_some() {
            let _ = self.device.poll(wgpu::PollType::Poll);
        }
        self.check()?;
        match v.or(o) {
            Some(e) => Err(e.into()),
            None => Ok(value),
        }
    }

    /// Waits for all submitted work, turning a timeout or loss into an error.
    pub fn wait_idle(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::DeviceLost(e.to_string()))?;
        self.check()
    }
}

/// Runs `shaders/loop_limiter.wgsl`: one invocation counts a loop of
/// [`LOOP_LIMITER_PROBE_TRIPS`] iterations and returns how far it got (65,535 on llvmpipe,
/// all of them on a GPU without a limiter). A few milliseconds, once per device.
pub fn probe_loop_limiter(gpu: &Gpu) -> Result<u32, GpuError> {
    let src = include_str!("../../shaders/loop_limiter.wgsl");
    let kernel = gpu.compute_kernel("shaders/loop_limiter.wgsl", src, "main")?;
    let buffer = gpu.storage_buffer("loop limiter probe", &[LOOP_LIMITER_PROBE_TRIPS, 0])?;
    let group = kernel.bind_group(gpu, 0, &[&buffer])?;
    gpu.dispatch(&kernel, &[&group], [1, 1, 1])?;
    Ok(gpu.read_buffer::<u32>(&buffer, 2)?[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The probe sees llvmpipe's limiter where it exists (Mesa 22 and older: 65,535
    /// iterations, all loops of an invocation together; Mesa 25 has none) and reports either
    /// the limit or the whole loop, never anything between.
    #[test]
    fn the_probe_detects_llvmpipes_loop_limiter() {
        let Some(gpu) = crate::gpu::gpu_for_tests("loop_limiter_probe") else { return };
        let count = probe_loop_limiter(&gpu).unwrap();
        println!("{}: the probe counted {count} of {LOOP_LIMITER_PROBE_TRIPS}", gpu.description());
        assert!(count == 65_535 || count == LOOP_LIMITER_PROBE_TRIPS, "{count}");
        let llvmpipe = is_llvmpipe(&gpu.adapter_info);
        if llvmpipe && mesa_major(&gpu.adapter_info.driver_info).is_some_and(|m| m <= 22) {
            assert_eq!(count, 65_535, "{}", gpu.description());
        }
    }

    /// The major version in a driver string such as "llvmpipe Mesa 22.3.6 (LLVM 15.0.6)".
    fn mesa_major(driver_info: &str) -> Option<u32> {
        let rest = &driver_info[driver_info.find("Mesa ")? + 5..];
        rest.split('.').next()?.parse().ok()
    }

    #[test]
    fn mesa_versions_are_read_from_the_driver_string() {
        assert_eq!(mesa_major("llvmpipe Mesa 22.3.6 (LLVM 15.0.6)"), Some(22));
        assert_eq!(mesa_major("llvmpipe Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"), Some(25));
        assert_eq!(mesa_major("NVIDIA 550.54"), None);
    }

    #[test]
    fn cli_choice_overrides_environment_and_blank_means_none() {
        // The rule on given values: tests must not mutate the process environment.
        let name =
            |cli: Option<&str>, env: Option<&str>| AdapterChoice::chosen(cli.map(Into::into), env.map(Into::into)).name;
        assert_eq!(name(Some("LLVMpipe"), Some("nvidia")).as_deref(), Some("LLVMpipe"));
        assert_eq!(name(None, Some("nvidia")).as_deref(), Some("nvidia"));
        assert_eq!(name(Some("  "), Some("nvidia")).as_deref(), Some("nvidia"));
        assert_eq!(name(Some("LLVMpipe"), Some(" ")).as_deref(), Some("LLVMpipe"));
        assert_eq!(name(Some(""), Some("\t")), None);
        assert_eq!(name(None, None), None);
        // `new` reads the real environment through the same rule.
        assert_eq!(AdapterChoice::new(Some("LLVMpipe".into())).name.as_deref(), Some("LLVMpipe"));
    }

    #[test]
    fn unknown_adapter_is_an_error_listing_the_available_ones() {
        let err = Gpu::new(&AdapterChoice { name: Some("no-such-adapter-xyzzy".into()) }).unwrap_err();
        match &err {
            GpuError::AdapterNotFound { wanted, available } => {
                assert_eq!(wanted, "no-such-adapter-xyzzy");
                assert_eq!(available.len(), list_adapters().len());
                assert!(err.to_string().contains("available adapters"));
            }
            // No adapter at all: a skip, unless GPU tests are required.
            GpuError::NoAdapter => assert!(!crate::gpu::gpu_required(), "{err}"),
            other => panic!("unexpected error {other}"),
        }
    }

    #[test]
    fn ranking_prefers_real_gpus_and_primary_backends() {
        let mk = wgpu::AdapterInfo::new;
        let discrete_gl = mk(wgpu::DeviceType::DiscreteGpu, wgpu::Backend::Gl);
        let cpu_vk = mk(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
        let cpu_gl = mk(wgpu::DeviceType::Cpu, wgpu::Backend::Gl);
        assert!(rank(&discrete_gl) < rank(&cpu_vk));
        assert!(rank(&cpu_vk) < rank(&cpu_gl));
    }
}
