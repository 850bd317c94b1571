//! `lumen converge SCENE.sl`: how fast does each device's error fall with samples and time?
//!
//! Renders the scene at increasing sample counts on every device, compares each image with
//! a reference (given, or rendered on the CPU at high spp with an independent seed so its
//! noise does not correlate with the estimates'), and writes `converge.csv`, `converge.md`
//! and `converge.png` (log-log RMSE against seconds) into the output directory. Each device
//! first renders one discarded 1-spp image so start-up costs are not timed.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context as _};
use clap::Args;

use super::number_args::whole;

use super::gpu_args::DeviceListArgs;
use super::script_args::{SceneOverrides, ScriptArgs, MAX_SPP};
use crate::analysis::{
    format_seconds, measure, ConvergeRow, ConvergeTable, ErrorMetrics, OpenDevice, Plot, Series, REL_MSE_EPSILON,
};
use crate::cpu::paths_per_sample;
use crate::image::{read_image, write_image, HdrImage, ToneMap};
use crate::scene::Scene;

/// The reference is rendered at this many times the largest spp unless told otherwise, so
/// its own variance adds at most 1/16 to the smallest MSE measured.
pub const REFERENCE_FACTOR: u32 = 16;
/// XOR-ed into the tracer's seed for the rendered reference: independent random streams.
const REFERENCE_SEED_MIX: u64 = 0x9E37_79B9_7F4A_7C15;

/// Arguments of `lumen converge`.
#[derive(Debug, Args)]
pub struct ConvergeArgs {
    /// The SceneLang script to study.
    pub scene: PathBuf,
    /// Reference image (PFM, EXR or HDR) of the scene at the same size, instead of rendering one.
    #[arg(long, conflicts_with = "reference_spp")]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of the CPU-rendered reference (default: 16 × the largest --spp).
    #[arg(long, value_parser = whole::<u32>(1, u64::from(MAX_SPP)), allow_negative_numbers = true)]
    pub reference_spp: Option<u32>,
    /// `--device` and `--adapter`: the devices measured, in turn.
    #[command(flatten)]
    pub devices: DeviceListArgs,
    /// Camera samples per pixel to measure (a list: each count is one measurement; one
    /// count is the `--spp` of the other commands), comma-separated (sorted ascending).
    #[arg(long, value_delimiter = ',', default_values_t = [1, 4, 16, 64, 256], value_parser = whole::<u32>(1, u64::from(MAX_SPP)), allow_negative_numbers = true)]
    pub spp: Vec<u32>,
    /// Directory for converge.csv, converge.md, converge.png and the rendered reference.
    #[arg(short = 'o', long = "output", default_value = "converge")]
    pub output: PathBuf,
    /// `--width`, `--height` and `--seed` of the scene (a `--reference` image must match the size).
    #[command(flatten)]
    pub overrides: SceneOverrides,
    /// `--time` and `--vars` of the script.
    #[command(flatten)]
    pub script: ScriptArgs,
}

fn check_spp(spp: u32, what: &str, scene: Option<&Scene>) -> anyhow::Result<()> {
    if spp == 0 || spp > MAX_SPP {
        bail!("{what} must be 1..={MAX_SPP}, got {spp}");
    }
    if let Some(scene) = scene {
        if u64::from(spp) * paths_per_sample(scene) > u64::from(u32::MAX) {
            bail!("{what} {spp} × {} paths per sample is too many (at most 2³² − 1)", paths_per_sample(scene));
        }
    }
    Ok(())
}

/// The reference image: read from `--reference`, or rendered on the CPU and saved as
/// `reference.pfm` in the output directory.
fn reference(args: &ConvergeArgs, scene: &Scene, max_spp: u32) -> anyhow::Result<(HdrImage, String)> {
    if let Some(path) = &args.reference {
        let img = read_image(path).with_context(|| format!("cannot read the reference {}", path.display()))?;
        if (img.width(), img.height()) != (scene.width as usize, scene.height as usize) {
            bail!(
                "reference {} is {}×{} but the scene renders at {}×{} (use --width/--height)",
                path.display(),
                img.width(),
                img.height(),
                scene.width,
                scene.height
            );
        }
        return Ok((img, format!("`{}`", path.display())));
    }
    let spp = args.reference_spp.unwrap_or(max_spp.saturating_mul(REFERENCE_FACTOR).min(MAX_SPP));
    if spp < max_spp.saturating_mul(REFERENCE_FACTOR) {
        crate::diag!("warning: reference spp {spp} is under {REFERENCE_FACTOR}× the largest spp {max_spp}: its noise will flatten the curve");
    }
    let mut ref_scene = scene.clone();
    ref_scene.tracer.rng.state ^= REFERENCE_SEED_MIX;
    crate::diag!("rendering the reference on the CPU at {spp} spp ...");
    let m = measure(&OpenDevice::Cpu, &ref_scene, spp, true).map_err(|e| anyhow!("{e}"))?;
    crate::diag!("reference: {} ({} spp)", format_seconds(m.seconds), spp);
    let path = args.output.join("reference.pfm");
    write_image(&path, &m.image, &ToneMap::default())?;
    Ok((m.image, format!("CPU, {spp} spp, independent seed ({:.1} s)", m.seconds)))
}

/// Runs `lumen converge`.
pub fn run(args: ConvergeArgs) -> anyhow::Result<()> {
    let mut spp = args.spp.clone();
    spp.sort_unstable();
    spp.dedup();
    if spp.is_empty() {
        bail!("--spp needs at least one sample count");
    }
    for &s in &spp {
        check_spp(s, "--spp", None)?;
    }
    if let Some(r) = args.reference_spp {
        check_spp(r, "--reference-spp", None)?;
    }
    let mut scene = args.script.load(&args.scene)?;
    args.overrides.apply(&mut scene)?;
    let max_spp = *spp.last().unwrap_or(&1);
    check_spp(max_spp, "--spp", Some(&scene))?;
    if let Some(r) = args.reference_spp {
        check_spp(r, "--reference-spp", Some(&scene))?;
    }
    std::fs::create_dir_all(&args.output).with_context(|| format!("cannot create {}", args.output.display()))?;
    let devices = args.devices.open();
    if devices.is_empty() {
        bail!("none of the requested devices is available");
    }
    let (reference, reference_note) = reference(&args, &scene, max_spp)?;

    let mut table = ConvergeTable::default();
    let total = devices.len() * spp.len();
    for device in &devices {
        // One discarded 1-spp render first, so one-off costs (driver start-up, kernel
        // creation, which the GPU renderer then caches) do not land on the first row.
        crate::diag!("warming up {} ...", device.kind());
        measure(device, &scene, 1, false).map_err(|e| anyhow!("{}: {e}", device.kind()))?;
        for &s in &spp {
            let step = table.rows.len() + 1;
            crate::diag!("[{step}/{total}] {} at {s} spp ...", device.kind());
            let m = measure(device, &scene, s, true).map_err(|e| anyhow!("{} at {s} spp: {e}", device.kind()))?;
            if m.non_finite_samples > 0 {
                crate::diag!("warning: {} NaN or infinite samples were counted as black", m.non_finite_samples);
            }
            if m.spp != s {
                bail!("{} stopped after {} of {s} spp", device.kind(), m.spp);
            }
            let e =
                ErrorMetrics::of(&m.image, &reference).ok_or_else(|| anyhow!("image and reference sizes differ"))?;
            crate::diag!(
                "[{step}/{total}] {} {s} spp: {}  RMSE {:.4e}  relMSE {:.4e}",
                device.kind(),
                format_seconds(m.seconds),
                e.rmse,
                e.rel_mse
            );
            table.rows.push(ConvergeRow {
                device: device.kind().to_string(),
                spp: s,
                seconds: m.seconds,
                mse: e.mse,
                rmse: e.rmse,
                rel_mse: e.rel_mse,
            });
        }
    }
    let descriptions: Vec<String> = devices.iter().map(OpenDevice::describe).collect();
    let machine = crate::analysis::machine_line(&devices);
    write_results(&args, &scene, &table, &reference_note, &descriptions, &machine)
}

/// One line per device: the fitted slope of log MSE against log spp, and a plateau note.
fn slope_lines(table: &ConvergeTable) -> Vec<String> {
    table
        .devices()
        .into_iter()
        .map(|d| match table.mse_slope(d) {
            Some((fit, flat)) => format!(
                "{d}: slope of log MSE vs log spp = {:.3} (r² = {:.3}; −1 for an unbiased renderer){}",
                fit.slope,
                fit.r2,
                if flat { "; plateau: bias or accumulation error?" } else { "" }
            ),
            None => format!("{d}: slope n/a (needs two sample counts with non-zero error)"),
        })
        .collect()
}

fn write_results(
    args: &ConvergeArgs,
    scene: &Scene,
    table: &ConvergeTable,
    reference_note: &str,
    devices: &[String],
    machine: &str,
) -> anyhow::Result<()> {
    let dir = &args.output;
    let slopes = slope_lines(table);
    let mut out = super::output::Lines::default();
    for l in &slopes {
        out.line(l);
    }
    let csv = dir.join("converge.csv");
    crate::image::write_atomically(&csv, table.to_csv().as_bytes())
        .with_context(|| format!("cannot write {}", csv.display()))?;
    let name = args.scene.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let md = format!(
        "# lumen converge {name}\n\n{}×{} pixels, {} renderer; reference: {reference_note}; devices: {}.\n{machine}\n\
         relMSE = mean((x − r)² / (r² + {REL_MSE_EPSILON})); efficiency = 1 / (MSE · seconds); seconds are the \
         wall time of each render call (GPU: including packing; its kernel is compiled once, in a discarded warm-up render).\n\n{}\n{}\n",
        scene.width,
        scene.height,
        scene.renderer.name(),
        devices.join(", "),
        table.to_markdown(),
        slopes.iter().map(|l| format!("- {l}\n")).collect::<String>()
    );
    let md_path = dir.join("converge.md");
    crate::image::write_atomically(&md_path, md.as_bytes())
        .with_context(|| format!("cannot write {}", md_path.display()))?;
    let plot = Plot {
        title: format!("{name}: error vs time"),
        x_label: "seconds".into(),
        y_label: "RMSE".into(),
        series: table
            .devices()
            .into_iter()
            .map(|d| Series { label: d.to_string(), points: table.rows_of(d).map(|r| (r.seconds, r.rmse)).collect() })
            .collect(),
    };
    let png = dir.join("converge.png");
    plot.write_png(&png, 800, 560).with_context(|| format!("cannot write {}", png.display()))?;
    let svg = dir.join("converge.svg");
    plot.write_svg(&svg, 800, 560).with_context(|| format!("cannot write {}", svg.display()))?;
    crate::diag!("wrote {}, {}, {} and {}", csv.display(), md_path.display(), png.display(), svg.display());
    // Last: the files are written even when nobody reads standard output.
    Ok(out.print()?)
}
