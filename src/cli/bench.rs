//! `lumen bench`: throughput of every device on the example scenes, how the time per sample
//! grows with the number of objects (it should grow like log n, thanks to the BVH), peak
//! memory, and (`--shaders`) what specialising the GPU kernel to a scene buys.
//!
//! Output is Markdown on standard output (and in `-o FILE`); progress goes to standard error.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Context as _};
use clap::Args;

use super::number_args::whole;
use glam::DVec3;

use super::gpu_args::DeviceListArgs;
use super::script_args::{SceneOverrides, ScriptArgs, SppArgs, MAX_SPP};
use crate::analysis::{
    cores_busy, fit_line, fit_loglog, format_bytes, format_seconds, markdown_table, measure, measure_with,
    peak_memory_bytes, Device, Measurement, OpenDevice,
};
use crate::color::Color;
use crate::cpu::World;
use crate::gpu::features::{FeatureSet, FULL_CSG_MAX_DEPTH, FULL_CSG_MAX_LEAVES};
use crate::gpu::kernels::assemble_stages;
use crate::gpu::pack::pack;
use crate::gpu::render::{GpuRenderOptions, GpuRenderer, TwinUse};
use crate::gpu::{Gpu, Loops};
use crate::sampling::Pcg32;
use crate::scene::{Environment, PathTracerSettings, Renderer, Scene, SceneBuilder, Transform};

/// Object counts of the scaling study (cut at `--max-spheres`).
pub const SPHERE_COUNTS: [u32; 6] = [1, 10, 100, 1_000, 10_000, 100_000];
/// The most `--max-spheres` can ask for: the largest count of the study, so that a larger
/// value is refused rather than quietly cut to it.
pub const MAX_SPHERES: u32 = SPHERE_COUNTS[SPHERE_COUNTS.len() - 1];

/// Arguments of `lumen bench`. `--spp` applies to the scene table (default 16; the scaling
/// study takes 16× as many, so the GPU's kernel-creation jitter does not swamp the
/// difference); `--width` defaults to 160.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// `--device` and `--adapter`: the devices measured, in turn.
    #[command(flatten)]
    pub devices: DeviceListArgs,
    /// Scene scripts, or directories whose *.sl files are all benchmarked, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "scenes")]
    pub scenes: Vec<PathBuf>,
    /// `--spp`: samples per pixel of the per-scene measurements (default 16, 4 with `--quick`;
    /// at most `MAX_SPP / 16`, since the scaling study takes 16× as many).
    #[command(flatten)]
    pub spp: SppArgs,
    /// `--width` (default 160, 64 with `--quick`), `--height` and `--seed` of the scenes
    /// loaded from scripts (the scaling study's generated scenes keep their own size).
    #[command(flatten)]
    pub overrides: SceneOverrides,
    /// `--time` and `--vars` for every script (and for the `--cold-kernels` processes).
    #[command(flatten)]
    pub script: ScriptArgs,
    /// Small and fast: width 64, 4 spp, scaling up to 10 000 spheres.
    #[arg(long)]
    pub quick: bool,
    /// Largest sphere count of the scaling study, at most 100000 (0 skips it).
    #[arg(long, value_parser = whole::<u32>(0, u64::from(MAX_SPHERES)), allow_negative_numbers = true)]
    pub max_spheres: Option<u32>,
    /// Also compare the scene-specialised GPU kernel with a full-featured one (WGSL size,
    /// pipeline creation time, samples/s), and the BVH with a plain object list.
    #[arg(long)]
    pub shaders: bool,
    /// Also write the Markdown report to this file.
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Measure each scene this many times, the devices alternating, and report medians with
    /// each run's GPU/CPU ratio: side-by-side figures on a shared, noisy machine.
    #[arg(long, default_value_t = 1, value_parser = whole::<u32>(1, 100), allow_negative_numbers = true)]
    pub repeat: u32,
    /// Also time the GPU's kernel creation with every cache cold, `--repeat` times per
    /// scene: each time a new process of this program renders the scene at 8×8 and 1 spp
    /// with a new, empty Mesa shader cache (MESA_SHADER_CACHE_DIR), without lumen's
    /// pipeline cache (LUMEN_PIPELINE_CACHE=0) and without NVIDIA's shader disk cache
    /// (__GL_SHADER_DISK_CACHE=0).
    #[arg(long)]
    pub cold_kernels: bool,
    /// The process `--cold-kernels` starts: renders the one scene of `--scenes` at 8×8 and
    /// 1 spp on the GPU and prints the kernels it created and the seconds that took.
    #[arg(long, hide = true)]
    pub cold_kernels_child: bool,
}

/// Settings after `--quick` and the defaults are applied.
struct Plan {
    spp: u32,
    width: u32,
    /// `--height`, if given (else each scene's aspect ratio decides).
    height: Option<u32>,
    max_spheres: u32,
    script: ScriptArgs,
    seed: Option<u64>,
    /// Rounds of the scene table (`--repeat`).
    repeat: u32,
}

impl Plan {
    fn of(args: &BenchArgs) -> anyhow::Result<Self> {
        let (spp, width, max_spheres) = if args.quick { (4, 64, 10_000) } else { (16, 160, 100_000) };
        let o = &args.overrides;
        Ok(Plan {
            spp: args.spp.checked(MAX_SPP / 16)?.unwrap_or(spp),
            width: o.width.unwrap_or(width),
            height: o.height,
            max_spheres: args.max_spheres.unwrap_or(max_spheres),
            script: args.script.clone(),
            seed: o.seed,
            repeat: args.repeat.max(1),
        })
    }

    /// Loads a script at this width (and `--height`, `--seed`, `--vars`, `--time`).
    fn load_scene(&self, path: &Path, width: u32, height: Option<u32>) -> anyhow::Result<Scene> {
        self.load_scene_with_output(path, width, height, &mut std::io::stdout().lock())
    }

    /// [`Self::load_scene`] with the script's DUMP output written to `out`.
    fn load_scene_with_output(
        &self,
        path: &Path,
        width: u32,
        height: Option<u32>,
        out: &mut dyn std::io::Write,
    ) -> anyhow::Result<Scene> {
        let mut scene = self.script.load_at_with_output(path, self.script.time, out)?;
        SceneOverrides { width: Some(width), height, seed: self.seed }.apply(&mut scene)?;
        Ok(scene)
    }
}

/// The scripts named by `--scenes`: files as given, directories' `*.sl` sorted by name.
pub fn scene_files(list: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in list {
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("cannot list {}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.is_file() && f.extension().is_some_and(|e| e == "sl"))
                .collect();
            found.sort();
            out.extend(found);
        } else if p.is_file() {
            out.push(p.clone());
        } else {
            bail!("--scenes: {} is neither a file nor a directory", p.display());
        }
    }
    if out.is_empty() {
        bail!("--scenes: no .sl scripts found");
    }
    Ok(out)
}

/// Loads the scripts named on the command line (not those found in a directory), so that
/// a broken one fails the run before any measurement, with the script's own message and
/// location, rather than becoming a row of a report that then exits 0. A directory's
/// scripts may be anything that lies there: those that do not load are skipped with a
/// warning.
fn load_named_scripts(list: &[PathBuf], plan: &Plan) -> anyhow::Result<()> {
    for file in list.iter().filter(|p| !p.is_dir()) {
        // Its DUMP output is printed when it is measured, not here as well.
        plan.load_scene_with_output(file, plan.width, plan.height, &mut std::io::sink())?;
    }
    Ok(())
}

/// Text as one Markdown table cell: its first `most` non-empty lines, trimmed and joined
/// (a newline would end the table's row). `markdown_table` escapes `|`.
fn one_line(text: &str, most: usize) -> String {
    crate::printable::one_line(text, " ", most)
}

/// Lines of a script's load error a table cell keeps: the message and its file:line:column
/// (the excerpt under them, a source line and a caret, does not read as one line).
const SCRIPT_ERROR_LINES: usize = 2;

/// `n` diffuse spheres scattered in a cube in front of the default camera, under a uniform
/// sky. Radii shrink as n^(−1/3) so the cloud covers about the same part of the image at
/// every n: what grows is only the number of objects a ray must be tested against.
pub fn spheres_scene(n: u32, width: u32, height: u32) -> Scene {
    let mut b = SceneBuilder::new(width, height);
    let mut rng = Pcg32::new(42, 54);
    let side = 4.0;
    let spacing = side / f64::from(n).cbrt();
    let materials: Vec<_> =
        [Color::new(0.8, 0.3, 0.2), Color::new(0.2, 0.6, 0.3), Color::new(0.3, 0.4, 0.8)].map(|c| b.diffuse(c)).into();
    for i in 0..n {
        let p = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * side - DVec3::splat(side / 2.0);
        let t = Transform::translation(DVec3::new(5.0, 0.0, 0.0) + p) * Transform::scaling(DVec3::splat(0.3 * spacing));
        b.sphere(t, materials[i as usize % materials.len()]);
    }
    b.environment(Environment::Uniform(Color::gray(1.0)))
        .renderer(Renderer::PathTracer(PathTracerSettings { n: 1, ..PathTracerSettings::default() }));
    b.build().expect("generated spheres scene is valid")
}

/// Runs `lumen bench`.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let plan = Plan::of(&args)?;
    if args.cold_kernels_child {
        return cold_kernels_child(&args, &plan);
    }
    if let Some(path) = &args.output {
        crate::image::check_destination(path).with_context(|| format!("cannot write {}", path.display()))?;
    }
    let files = scene_files(&args.scenes)?;
    load_named_scripts(&args.scenes, &plan)?;
    let devices = args.devices.open()?;
    for d in &devices {
        crate::diag!("warming up {} ...", d.describe());
        measure(d, &spheres_scene(1, 8, 8), 1, false).map_err(|e| anyhow!("{}: {e}", d.kind()))?;
    }
    let mut report = format!(
        "Devices: {}. Scenes at width {} px, {} spp.\n\n{}\n\n",
        devices.iter().map(OpenDevice::describe).collect::<Vec<_>>().join(", "),
        plan.width,
        plan.spp,
        crate::analysis::machine_line(&devices)
    );
    report.push_str(&scenes_table(&files, &devices, &plan));
    if plan.max_spheres > 0 {
        report.push('\n');
        report.push_str(&scaling_table(&devices, &plan)?);
    }
    if args.shaders {
        report.push('\n');
        match devices.iter().find(|d| d.kind() == Device::Gpu) {
            Some(gpu) => {
                report.push_str(&shaders_table(gpu, &files, &plan)?);
                report.push('\n');
                report.push_str(&bvh_or_list_table(gpu, &files, &plan)?);
            }
            None => report.push_str("Shader comparison skipped: no GPU device.\n"),
        }
    }
    if args.cold_kernels {
        report.push('\n');
        if devices.iter().any(|d| d.kind() == Device::Gpu) {
            report.push_str(&cold_kernels_table(&files, &plan, &args)?);
        } else {
            report.push_str("Cold kernel creation skipped: no GPU device.\n");
        }
    }
    report.push_str(&format!("\nPeak resident memory of the whole run: {}\n", format_bytes(peak_memory_bytes())));
    // The file first: it is written even when nobody reads standard output.
    if let Some(path) = &args.output {
        crate::image::write_atomically(path, report.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
        crate::diag!("wrote {}", path.display());
    }
    Ok(super::output::print(format_args!("{report}\n"))?)
}

/// The environment of a `--cold-kernels` child: a new, empty Mesa shader cache in `cache`,
/// lumen's pipeline cache off, NVIDIA's shader disk cache off.
fn cold_environment(cache: &Path) -> [(&'static str, std::ffi::OsString); 3] {
    [
        ("MESA_SHADER_CACHE_DIR", cache.as_os_str().to_owned()),
        (crate::gpu::pipeline_cache::PIPELINE_CACHE_ENV, "0".into()),
        ("__GL_SHADER_DISK_CACHE", "0".into()),
    ]
}

/// Kernel creation of each scene with every cache cold (`--cold-kernels`), each run in a
/// process of its own: drivers read their cache settings when they load, once per process.
fn cold_kernels_table(files: &[PathBuf], plan: &Plan, args: &BenchArgs) -> anyhow::Result<String> {
    let mut rows = Vec::new();
    for file in files {
        let name = name_of(file);
        let mut kernels = String::new();
        let mut seconds = Vec::new();
        let mut error = None;
        for round in 0..plan.repeat {
            crate::diag!("{name}: cold kernel creation (run {} of {}) ...", round + 1, plan.repeat);
            let cache = tempfile::tempdir().context("cannot create a directory for a cold shader cache")?;
            let mut child =
                super::own_process::this_program().context("cannot find this program to start its cold runs")?;
            child.args(["bench", "--cold-kernels-child", "--device", "gpu", "--scenes"]).arg(file);
            child.arg("--time").arg(plan.script.time.to_string());
            for v in &plan.script.vars {
                child.arg("--vars").arg(v);
            }
            if let Some(a) = &args.devices.adapter.adapter {
                child.arg("--adapter").arg(a);
            }
            let out = child
                .envs(cold_environment(cache.path()))
                .stdin(std::process::Stdio::null())
                .output()
                .context("cannot start a cold kernel-creation run")?;
            let stdout = String::from_utf8_lossy(&out.stdout);
            let words: Vec<&str> = stdout.split_whitespace().collect();
            match (out.status.success(), &words[..]) {
                (true, [k, s]) if s.parse::<f64>().is_ok() => {
                    kernels = k.to_string();
                    seconds.push(s.parse::<f64>()?);
                }
                _ => {
                    // The error and its location: the child's first two lines (an error
                    // line, then for a script the file:line:col of the fault).
                    let said = one_line(&String::from_utf8_lossy(&out.stderr), SCRIPT_ERROR_LINES);
                    let said = if said.is_empty() { "no output".to_string() } else { said };
                    crate::diag!("warning: {name}: cold kernel creation failed: {said}");
                    error = Some(said);
                    break;
                }
            }
        }
        rows.push(match error {
            Some(e) => vec![name, e, String::new(), String::new()],
            None => vec![
                name,
                kernels,
                seconds.iter().map(|s| format!("{s:.2}")).collect::<Vec<_>>().join(", "),
                median(&seconds).map_or(String::new(), |m| format!("{m:.2}")),
            ],
        });
    }
    Ok(format!(
        "### Cold kernel creation\n\nEach run a new process renders the scene at 8×8 and 1 spp on the GPU with a new, \
         empty Mesa shader cache, without lumen's pipeline cache and without NVIDIA's shader disk cache; seconds = \
         the render's kernel creation (assembly, naga validation, pipeline creation and, on llvmpipe, the JIT \
         compilation of every kernel before the first round), as `lumen render` reports it.\n\n{}",
        markdown_table(&["scene", "kernels", "seconds (each run)", "median"], &rows)
    ))
}

/// The process of one `--cold-kernels` run: prints "<kernels created> <seconds>".
fn cold_kernels_child(args: &BenchArgs, plan: &Plan) -> anyhow::Result<()> {
    let files = scene_files(&args.scenes)?;
    let [file] = &files[..] else { bail!("--cold-kernels-child takes one scene, got {}", files.len()) };
    let scene = plan.load_scene(file, 8, Some(8))?;
    let gpu = Gpu::new(&args.devices.adapter.choice()).map_err(|e| anyhow!("{e}"))?;
    let opts = GpuRenderOptions { spp: Some(1), twin: TwinUse::Never, ..GpuRenderOptions::default() };
    let out = GpuRenderer::new().render(&gpu, &scene, &opts).map_err(|e| anyhow!("{e}"))?;
    Ok(super::output::print(format_args!("{} {:.6}\n", out.kernels_compiled, out.kernel_seconds))?)
}

/// Rates with an SI prefix: 1.23 M.
fn si(v: f64) -> String {
    match v {
        v if !v.is_finite() => "n/a".into(),
        v if v >= 1e9 => format!("{:.2} G", v / 1e9),
        v if v >= 1e6 => format!("{:.2} M", v / 1e6),
        v if v >= 1e3 => format!("{:.2} k", v / 1e3),
        v => format!("{v:.1}"),
    }
}

fn name_of(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| path.display().to_string())
}

/// One scene on one device over the rounds of the scene table.
#[derive(Debug, Default)]
struct Rounds {
    /// Samples per second of each round (`None`: timing noise swamped the difference).
    rates: Vec<Option<f64>>,
    rays: Vec<f64>,
    /// Cores busy in each round (`Differential::cores_busy`).
    cores: Vec<Cores>,
    seconds: Vec<f64>,
    spp: u32,
    error: Option<String>,
}

/// The median of `v` (the mean of the middle two for an even count), `None` if empty.
fn median(v: &[f64]) -> Option<f64> {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    (n > 0).then(|| if n % 2 == 1 { s[n / 2] } else { (s[n / 2 - 1] + s[n / 2]) / 2.0 })
}

/// Each round's GPU rate over the same round's CPU rate (rounds where both were measured).
fn round_ratios(gpu: &Rounds, cpu: &Rounds) -> Vec<f64> {
    gpu.rates.iter().zip(&cpu.rates).filter_map(|(g, c)| Some(g.as_ref()? / c.as_ref()?)).collect()
}

fn scenes_table(files: &[PathBuf], devices: &[OpenDevice], plan: &Plan) -> String {
    let headers = ["scene", "device", "size", "spp", "seconds", "samples/s", "rays/s", "cores busy", "peak memory"];
    let mut rows = Vec::new();
    let mut ratio_rows = Vec::new();
    for file in files {
        let name = name_of(file);
        let scene = match plan.load_scene(file, plan.width, plan.height) {
            Ok(s) => s,
            Err(e) => {
                crate::diag!("warning: skipping {name}: {e}");
                rows.push(vec![
                    name.clone(),
                    "-".into(),
                    one_line(&format!("error: {e}"), SCRIPT_ERROR_LINES),
                    "".into(),
                    "".into(),
                    "".into(),
                    "".into(),
                    "".into(),
                    "".into(),
                ]);
                continue;
            }
        };
        let size = format!("{}×{}", scene.width, scene.height);
        // Devices alternate within each round, so a slow spell of a shared machine falls on
        // both alike.
        let mut runs: Vec<Rounds> = devices.iter().map(|_| Rounds::default()).collect();
        for round in 0..plan.repeat {
            for (d, r) in devices.iter().zip(runs.iter_mut()) {
                if r.error.is_some() {
                    continue;
                }
                crate::diag!("{name} on {} (round {} of {}) ...", d.kind(), round + 1, plan.repeat);
                match Differential::run(d, &scene, plan.spp) {
                    Ok(diff) => {
                        r.rates.push(diff.per_sample().map(|t| 1.0 / t));
                        r.rays.extend(diff.rays_per_second());
                        r.cores.push(diff.cores_busy());
                        r.seconds.push(diff.more.seconds);
                        r.spp = diff.more.spp;
                    }
                    Err(e) => {
                        crate::diag!("warning: {name} on {}: {e}", d.kind());
                        r.error = Some(one_line(&format!("error: {e}"), usize::MAX));
                    }
                }
            }
        }
        for (d, r) in devices.iter().zip(&runs) {
            let noise = || "n/a (timing noise)".to_string();
            let measured = match &r.error {
                Some(msg) => [msg.clone(), String::new(), String::new(), String::new(), String::new(), String::new()],
                None => [
                    r.spp.to_string(),
                    median(&r.seconds).map_or(String::new(), |s| format!("{s:.3}")),
                    median(&r.rates.iter().flatten().copied().collect::<Vec<_>>()).map_or_else(noise, si),
                    median(&r.rays).map_or_else(noise, si),
                    cores_cell(&r.cores),
                    format_bytes(peak_memory_bytes()),
                ],
            };
            let mut cells = vec![name.clone(), d.kind().to_string(), size.clone()];
            cells.extend(measured);
            rows.push(cells);
        }
        let of = |k: Device| devices.iter().position(|d| d.kind() == k).map(|i| &runs[i]);
        if let (Some(gpu), Some(cpu)) = (of(Device::Gpu), of(Device::Cpu)) {
            let ratios = round_ratios(gpu, cpu);
            let range = |v: &[f64]| {
                let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                format!("{lo:.2}–{hi:.2}")
            };
            ratio_rows.push(match median(&ratios) {
                Some(m) => vec![name.clone(), format!("{m:.2}"), range(&ratios), ratios.len().to_string()],
                None => vec![name.clone(), "n/a".into(), "".into(), "0".into()],
            });
        }
    }
    let rounds = if plan.repeat > 1 {
        format!(" Each device measured {} times, the devices alternating; the rows give the medians.", plan.repeat)
    } else {
        String::new()
    };
    let mut out = format!(
        "### Scenes\n\nEach scene is rendered at 1 spp and at 1 + {} spp; seconds = the second render's wall time, \
             samples/s and rays/s = the extra samples (rays) over the extra time, which leaves out fixed costs (BVH \
             build, packing, kernel creation); both devices count every closest-hit and shadow ray they trace. \
             Cores busy = the process's extra CPU seconds (every thread, the driver's included) over the extra \
             time: on a software GPU, how much of the machine the kernels kept working. \
             Peak memory = VmHWM of the process so far.{rounds}\n\n{}",
        plan.spp,
        markdown_table(&headers, &rows)
    );
    if !ratio_rows.is_empty() {
        out.push_str(&format!(
            "\n### GPU over CPU\n\nEach measurement's GPU samples/s over the CPU's of the same round: the median \
             and the range over the rounds (`--repeat`).\n\n{}",
            markdown_table(&["scene", "GPU/CPU", "range", "rounds"], &ratio_rows)
        ));
    }
    out
}

/// Cores busy over a round's extra samples.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Cores {
    Busy(f64),
    /// Timing noise swamped the figure.
    Noise,
    /// No CPU time to count (not Unix).
    Unknown,
}

/// Shortest extra wall time whose cores busy is reported. The extra CPU seconds and wall
/// seconds are each the difference of two renders, and the thread pool's work around a
/// render (its workers spin a while before they sleep) falls in one or the other: over a
/// few hundred microseconds that gave 51.30 cores on a 2-CPU machine.
const CORES_MIN_SECONDS: f64 = 0.01;

impl Cores {
    /// `cpu_seconds` over `wall_seconds` on a machine of `cpus` logical CPUs; noise where
    /// the wall time is too short to tell, or the figure is more CPUs than there are.
    fn of(cpu_seconds: Option<f64>, wall_seconds: f64, cpus: usize) -> Self {
        if cpu_seconds.is_none() {
            return Cores::Unknown;
        }
        match cores_busy(cpu_seconds, wall_seconds) {
            Some(c) if wall_seconds >= CORES_MIN_SECONDS && c <= cpus as f64 => Cores::Busy(c),
            _ => Cores::Noise,
        }
    }
}

/// The scene table's "cores busy": the median of the rounds measured, else why there is none.
fn cores_cell(rounds: &[Cores]) -> String {
    let busy: Vec<f64> = rounds.iter().filter_map(|c| if let Cores::Busy(c) = c { Some(*c) } else { None }).collect();
    match median(&busy) {
        Some(c) => format!("{c:.2}"),
        None if rounds.contains(&Cores::Noise) => "n/a (timing noise)".into(),
        None => "n/a".into(),
    }
}

/// Two renders whose difference removes fixed costs (loading the BVH, packing, kernel
/// creation): one at 1 spp and one at `1 + spp`.
struct Differential {
    more: Measurement,
    extra_samples: f64,
    extra_seconds: f64,
    extra_rays: f64,
    extra_cpu_seconds: Option<f64>,
}

impl Differential {
    fn run(d: &OpenDevice, scene: &Scene, spp: u32) -> anyhow::Result<Self> {
        Self::run_with(d, scene, spp, None)
    }

    /// [`Self::run`] with a GPU kernel override (`GpuRenderOptions::features`).
    /// On the GPU a first 1-spp render is thrown away: it compiles (and caches) the kernel,
    /// which would otherwise be inside the 1-spp time and make the difference too small.
    fn run_with(d: &OpenDevice, scene: &Scene, spp: u32, kernel: Option<FeatureSet>) -> anyhow::Result<Self> {
        if d.kind() == Device::Gpu {
            measure_with(d, scene, 1, false, kernel).map_err(|e| anyhow!("{e}"))?;
        }
        let one = measure_with(d, scene, 1, false, kernel).map_err(|e| anyhow!("{e}"))?;
        let more = measure_with(d, scene, 1 + spp, true, kernel).map_err(|e| anyhow!("{e}"))?;
        Ok(Self {
            extra_samples: more.samples.saturating_sub(one.samples) as f64,
            extra_seconds: more.seconds - one.seconds,
            extra_rays: more.rays.saturating_sub(one.rays) as f64,
            extra_cpu_seconds: one.cpu_seconds.zip(more.cpu_seconds).map(|(a, b)| b - a),
            more,
        })
    }

    /// Seconds per radiance sample, `None` when timing noise swamped the difference.
    fn per_sample(&self) -> Option<f64> {
        (self.extra_seconds > 0.0 && self.extra_samples > 0.0).then(|| self.extra_seconds / self.extra_samples)
    }

    /// Cores kept busy by the extra samples: their CPU seconds over their wall seconds.
    fn cores_busy(&self) -> Cores {
        let cpus = std::thread::available_parallelism().map_or(1, usize::from);
        Cores::of(self.extra_cpu_seconds, self.extra_seconds, cpus)
    }

    fn rays_per_second(&self) -> Option<f64> {
        (self.extra_seconds > 0.0).then(|| self.extra_rays / self.extra_seconds)
    }
}

fn scaling_table(devices: &[OpenDevice], plan: &Plan) -> anyhow::Result<String> {
    let (w, h) = (96, 72);
    let spp = 16 * plan.spp;
    let headers = ["spheres", "device", "BVH build (CPU)", "time per sample", "samples/s"];
    let mut rows = Vec::new();
    let mut series: Vec<(Device, Vec<f64>, Vec<f64>)> = devices.iter().map(|d| (d.kind(), vec![], vec![])).collect();
    for &n in SPHERE_COUNTS.iter().filter(|&&n| n <= plan.max_spheres) {
        let scene = spheres_scene(n, w, h);
        let start = Instant::now();
        let world = World::new(&scene);
        let build = start.elapsed().as_secs_f64();
        drop(world);
        for (d, (_, ns, ts)) in devices.iter().zip(series.iter_mut()) {
            crate::diag!("{n} spheres on {} ...", d.kind());
            let diff = Differential::run(d, &scene, spp).with_context(|| format!("{n} spheres on {}", d.kind()))?;
            let t = diff.per_sample().unwrap_or(0.0);
            if t > 0.0 {
                ns.push(f64::from(n));
                ts.push(t);
            }
            rows.push(vec![
                n.to_string(),
                d.kind().to_string(),
                format_seconds(build),
                if t > 0.0 { format_seconds(t) } else { "n/a (timing noise)".into() },
                if t > 0.0 { si(1.0 / t) } else { "n/a".into() },
            ]);
        }
    }
    let mut out = format!(
        "### Scaling with object count\n\n{w}×{h} px, path tracer (1 path per sample, depth 2) under a uniform sky; \
         time per sample = (t(1 + {spp} spp) − t(1 spp)) / extra samples, so set-up and kernel creation cancel.\n\n{}\n",
        markdown_table(&headers, &rows)
    );
    for (d, ns, ts) in &series {
        out.push_str(&growth_line(*d, ns, ts));
        out.push('\n');
    }
    for line in out.lines().filter(|l| l.starts_with("- ")) {
        crate::diag!("{line}");
    }
    Ok(out)
}

/// How time per sample grows with n: per decade (log n model) and as a power law.
fn growth_line(d: Device, ns: &[f64], ts: &[f64]) -> String {
    let logn: Vec<f64> = ns.iter().map(|n| n.log10()).collect();
    match (fit_line(&logn, ts), fit_loglog(ns, ts)) {
        (Some(lin), Some(pow)) => format!(
            "- {d}: time per sample ≈ {} + {} × log10(n) (r² = {:.3}); as a power law ∝ n^{:.3} \
             (0 = flat, 1 = linear: a BVH gives a small exponent)",
            format_seconds(lin.intercept),
            format_seconds(lin.slope),
            lin.r2,
            pow.slope
        ),
        _ => format!("- {d}: growth n/a (fewer than two usable points)"),
    }
}

/// WGSL size and pipeline creation time (naga validation + driver compile, one stage after
/// the other) of the stage kernels.
fn kernel_cost(gpu: &Gpu, features: &FeatureSet) -> anyhow::Result<(usize, usize, f64)> {
    let stages = assemble_stages(features).map_err(|e| anyhow!("{e}"))?;
    let start = Instant::now();
    let (mut bytes, mut lines) = (0, 0);
    for (stage, a) in &stages {
        let kernel = gpu
            .kernel_with_loops("bench kernel", &a.source, stage.entry().1, Loops::Unbounded)
            .map_err(|e| anyhow!("{e}"))?;
        drop(kernel);
        bytes += a.source.len();
        lines += a.source.lines().count();
    }
    gpu.wait_idle().map_err(|e| anyhow!("{e}"))?;
    Ok((bytes, lines, start.elapsed().as_secs_f64()))
}

fn shaders_table(device: &OpenDevice, files: &[PathBuf], plan: &Plan) -> anyhow::Result<String> {
    let OpenDevice::Gpu { gpu, .. } = device else { bail!("the shader comparison needs a GPU device") };
    let headers = ["scene", "kernel", "features", "WGSL bytes", "WGSL lines", "pipeline creation", "samples/s"];
    let mut scenes =
        vec![("1000 spheres only (generated)".to_string(), spheres_scene(1000, plan.width, plan.width * 3 / 4))];
    for file in files {
        match plan.load_scene(file, plan.width, plan.height) {
            Ok(s) => scenes.push((name_of(file), s)),
            Err(e) => crate::diag!("warning: skipping {}: {e}", name_of(file)),
        }
    }
    let mut rows = Vec::new();
    for (name, scene) in &scenes {
        let spec = FeatureSet::of(scene);
        for (kind, f) in [("specialised", spec), ("full-featured", spec.full_for())] {
            crate::diag!("{name}: {kind} kernel ...");
            let (bytes, lines, secs) = kernel_cost(gpu, &f).with_context(|| format!("{name}: {kind} kernel"))?;
            // The same differential method for both kernels; the override only swaps the kernel.
            let rate = Differential::run_with(device, scene, plan.spp, Some(f))
                .with_context(|| format!("{name} on the GPU, {kind} kernel"))?
                .per_sample()
                .map_or("n/a (timing noise)".into(), |t| si(1.0 / t));
            rows.push(vec![
                name.clone(),
                kind.into(),
                f.names().len().to_string(),
                bytes.to_string(),
                lines.to_string(),
                format_seconds(secs),
                rate,
            ]);
        }
    }
    Ok(format!(
        "### Specialised vs full-featured GPU kernel\n\nfeatures = number of `// #if` feature flags on; full-featured = \
         every shape, CSG ({FULL_CSG_MAX_LEAVES} leaves, depth {FULL_CSG_MAX_DEPTH}), pigment, BRDF and light \
         kind and every environment, with the scene's renderer (`FeatureSet::full_for`). samples/s as in the scene \
         table (after a throw-away render that compiles the kernel), each kernel rendering the same scene. Pipeline creation = naga validation + \
         `create_compute_pipeline` until the device is idle.\n\n{}",
        markdown_table(&headers, &rows)
    ))
}

/// Object counts of the BVH-or-list study: either side of `traversal::MAX_LIST_OBJECTS`.
pub const LIST_COUNTS: [u32; 8] = [2, 3, 4, 6, 8, 10, 12, 16];
/// Most finite top-level objects an example scene may have to enter the BVH-or-list study.
const LIST_MAX_OBJECTS: u32 = 16;

/// Samples per second of `scene` on the GPU, its finite objects walked through the BVH or
/// (`list`) tested as a list (`FeatureSet::object_list`, whatever `pack` chose); the
/// difference of a 1-spp and a (1 + spp)-spp render, as in the scene table. `None`: noise.
fn packed_rate(device: &OpenDevice, scene: &Scene, spp: u32, list: bool) -> anyhow::Result<Option<f64>> {
    let OpenDevice::Gpu { gpu, renderer } = device else { bail!("the BVH-or-list study needs a GPU device") };
    let time = |spp: u32| -> anyhow::Result<(f64, u32)> {
        let mut packed = pack(scene, Some(spp)).map_err(|e| anyhow!("{e}"))?;
        packed.features.object_list = list;
        let opts = GpuRenderOptions { spp: Some(spp), ..GpuRenderOptions::default() };
        let start = Instant::now();
        let out = renderer.borrow_mut().render_packed(gpu, scene, &packed, &opts).map_err(|e| anyhow!("{e}"))?;
        Ok((start.elapsed().as_secs_f64(), out.spp_done))
    };
    let (t1, s1) = time(1)?;
    let (t2, s2) = time(1 + spp)?;
    let samples = (f64::from(scene.width) * f64::from(scene.height))
        * f64::from(s2.saturating_sub(s1))
        * crate::cpu::paths_per_sample(scene) as f64;
    Ok((t2 > t1 && samples > 0.0).then(|| samples / (t2 - t1)))
}

/// Issue 6: "BVH or not (a handful of shapes may be faster without it — measure and
/// decide)", and the data behind `gpu::traversal::prefers_list`. Each scene is timed with
/// its objects walked through the BVH and tested as a list, the two alternating `ROUNDS`
/// times; the best rate of each is kept (other processes on a shared machine only ever slow
/// a render down).
fn bvh_or_list_table(device: &OpenDevice, files: &[PathBuf], plan: &Plan) -> anyhow::Result<String> {
    const ROUNDS: usize = 3;
    let (w, h) = (96, 72);
    // Renders of a few spheres at 2·16 spp took 10 ms, whose timings varied by ±50 %.
    let spp = 8 * plan.spp;
    let mut scenes: Vec<(String, Scene)> =
        LIST_COUNTS.iter().map(|&n| (format!("{n} spheres (generated)"), spheres_scene(n, w, h))).collect();
    for file in files {
        match plan.load_scene(file, w, None) {
            Ok(s) => scenes.push((name_of(file), s)),
            Err(e) => crate::diag!("warning: skipping {}: {e}", name_of(file)),
        }
    }
    let headers = [
        "scene",
        "finite objects",
        "BVH nodes",
        "samples/s with BVH",
        "samples/s as a list",
        "list / BVH",
        "lumen's choice",
    ];
    let mut rows = Vec::new();
    for (name, scene) in &scenes {
        let packed = pack(scene, Some(1)).map_err(|e| anyhow!("{e}"))?;
        let finite = packed.settings.plane_offset;
        // Meshes are always walked (FeatureSet::lists_objects).
        if finite > LIST_MAX_OBJECTS || packed.features.mesh {
            continue;
        }
        crate::diag!("{name}: BVH or list ...");
        let (mut bvh, mut list) = (0.0f64, 0.0f64);
        // Compiles both kernels outside the timings.
        packed_rate(device, scene, 1, false)?;
        packed_rate(device, scene, 1, true)?;
        for _ in 0..ROUNDS {
            bvh = bvh.max(packed_rate(device, scene, spp, false)?.unwrap_or(0.0));
            list = list.max(packed_rate(device, scene, spp, true)?.unwrap_or(0.0));
        }
        let ok = |r: f64| if r > 0.0 { si(r) } else { "n/a (timing noise)".into() };
        rows.push(vec![
            name.clone(),
            finite.to_string(),
            packed.settings.bvh_node_count.to_string(),
            ok(bvh),
            ok(list),
            if bvh > 0.0 && list > 0.0 { format!("{:.2}", list / bvh) } else { "n/a".into() },
            if packed.features.object_list { "list" } else { "BVH" }.into(),
        ]);
    }
    Ok(format!(
        "### BVH or a list of objects

{w}×{h} px (example scenes with at most {LIST_MAX_OBJECTS} finite objects, at width {w}), {} + 1 spp, the \
         scene's own kernel but for the traversal: *with BVH* walks the tree, *as a list* tests every finite \
         object in turn behind the root box (`OBJECT_LIST`). Kernels compiled beforehand; best of {ROUNDS} \
         alternating runs each. *lumen's choice* is `gpu::traversal::prefers_list`.\n\n{}",
        spp,
        markdown_table(&headers, &rows)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::paths_per_sample;

    /// A cold run's caches: Mesa's in the given (new, empty) directory, lumen's and NVIDIA's
    /// off, under the names those programs read.
    #[test]
    fn cold_runs_start_with_every_cache_empty_or_off() {
        let env = cold_environment(Path::new("/tmp/x"));
        let get = |k: &str| env.iter().find(|(n, _)| *n == k).map(|(_, v)| v.to_str().unwrap().to_string());
        assert_eq!(get("MESA_SHADER_CACHE_DIR").as_deref(), Some("/tmp/x"));
        assert_eq!(get("LUMEN_PIPELINE_CACHE").as_deref(), Some("0"));
        assert_eq!(get("__GL_SHADER_DISK_CACHE").as_deref(), Some("0"));
    }

    #[test]
    fn spheres_scene_has_n_spheres_in_view() {
        for n in [1, 1000] {
            let mut s = spheres_scene(n, 32, 24);
            assert_eq!(s.shapes.len(), n as usize);
            assert_eq!(paths_per_sample(&s), 1);
            // The cloud covers a similar, partial share of the image at every n.
            s.renderer = Renderer::OnOff { on: Color::WHITE, off: Color::BLACK };
            let img = crate::cpu::render(&s, &crate::cpu::RenderOptions::default(), crate::cpu::Progress::Hidden).image;
            let covered = img.mean().r;
            assert!((0.005..0.9).contains(&covered), "{n} spheres cover {covered}");
        }
    }

    #[test]
    fn full_features_contain_the_specialised_ones() {
        let s = spheres_scene(3, 4, 4);
        let spec = FeatureSet::of(&s);
        let full = spec.full_for();
        let (a, b) = (spec.names(), full.names());
        assert!(a.iter().all(|n| b.contains(n)), "{a:?} ⊄ {b:?}");
        assert!(b.len() > a.len() && b.contains(&"CSG") && b.contains(&"DIELECTRIC"));
        assert!(full.covers(&spec) && !spec.covers(&full));
        // Both assemble to valid WGSL, the full one larger.
        let size = |f| -> usize { assemble_stages(f).unwrap().iter().map(|(_, a)| a.source.len()).sum() };
        assert!(size(&full) > size(&spec));
    }

    #[test]
    fn scene_lists_and_plan() {
        let dir = tempfile::tempdir().unwrap();
        for f in ["b.sl", "a.sl", "c.txt"] {
            std::fs::write(dir.path().join(f), "").unwrap();
        }
        let files = scene_files(&[dir.path().to_path_buf()]).unwrap();
        assert_eq!(files.iter().map(|f| name_of(f)).collect::<Vec<_>>(), vec!["a.sl", "b.sl"]);
        assert!(scene_files(&[dir.path().join("none")]).is_err());
        assert_eq!(si(1.5e6), "1.50 M");
        assert_eq!(si(12.0), "12.0");
        assert_eq!(growth_line(Device::Cpu, &[1.0], &[1.0]), "- cpu: growth n/a (fewer than two usable points)");
    }

    /// Cores busy is a figure only where the wall time is long enough to tell and the figure
    /// is one the machine can give: 0.02 CPU seconds over 0.39 ms had been "51.30" on 2 CPUs.
    #[test]
    fn cores_busy_is_noise_where_it_cannot_be_told() {
        assert_eq!(Cores::of(Some(0.02), 0.00039, 2), Cores::Noise);
        assert_eq!(Cores::of(Some(0.5), 0.2, 2), Cores::Noise, "2.5 cores of 2");
        assert_eq!(Cores::of(Some(0.375), 0.25, 2), Cores::Busy(1.5));
        assert_eq!(Cores::of(Some(0.3), 0.0, 2), Cores::Noise);
        assert_eq!(Cores::of(None, 0.2, 2), Cores::Unknown);
        assert_eq!(cores_cell(&[Cores::Busy(1.0), Cores::Noise, Cores::Busy(2.0)]), "1.50");
        assert_eq!(cores_cell(&[Cores::Noise]), "n/a (timing noise)");
        assert_eq!(cores_cell(&[Cores::Unknown]), "n/a");
    }

    /// A table cell is one line: a script's error keeps its message and location.
    #[test]
    fn errors_in_table_cells_are_one_line() {
        let e = "error: the scene does not load\nbad.sl:1:20: error: unknown keyword\n 1 | SPAWN\n   |  ^^\n";
        assert_eq!(
            one_line(e, SCRIPT_ERROR_LINES),
            "error: the scene does not load bad.sl:1:20: error: unknown keyword"
        );
        assert_eq!(one_line("a\r\n\n  b \nc", usize::MAX), "a b c");
        let table = markdown_table(&["scene", "error"], &[vec!["x".into(), one_line(e, usize::MAX)]]);
        assert_eq!(table.lines().count(), 3, "{table}");
    }

    #[test]
    fn medians_and_per_round_ratios() {
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), Some(2.5));
        // A round where either device's rate was lost to timing noise gives no ratio; the
        // others pair each GPU rate with the CPU rate of its own round.
        let gpu = Rounds { rates: vec![Some(2.0), None, Some(9.0), Some(4.0)], ..Rounds::default() };
        let cpu = Rounds { rates: vec![Some(1.0), Some(5.0), None, Some(8.0)], ..Rounds::default() };
        assert_eq!(round_ratios(&gpu, &cpu), vec![2.0, 0.5]);
    }
}
