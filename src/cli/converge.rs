//! `lumen converge SCENE.sl`: how fast does each device's error fall with samples and time?
//!
//! Renders the scene at increasing sample counts on every device, compares each image with
//! a reference (given, or rendered on the CPU at high spp with an independent seed so its
//! noise does not correlate with the estimates'), and writes `converge.csv`, `converge.md`,
//! and `converge.png` and `converge.svg` (log-log RMSE against seconds) into the output
//! directory. Each device
//! first renders one discarded 1-spp image so start-up costs are not timed.
//!
//! Every output is checked before the work, as `render` checks its own, and the results
//! are written as a set (`image::write_set_atomically`): a run that fails leaves no half of it.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context as _};
use clap::Args;

use super::number_args::whole;

use super::gpu_args::DeviceListArgs;
use super::script_args::{SceneOverrides, ScriptArgs, MAX_SPP};
use crate::analysis::{
    format_seconds, measure, plot_loglog_svg, ConvergeRow, ConvergeTable, ErrorMetrics, OpenDevice, Plot, Series,
    REL_MSE_EPSILON,
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
    /// Directory for converge.csv, converge.md, converge.png, converge.svg and the rendered
    /// reference.
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

/// The `--reference` image, if given, read and checked against the scene's size before any
/// output is made.
fn given_reference(args: &ConvergeArgs, scene: &Scene) -> anyhow::Result<Option<(HdrImage, String)>> {
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
        return Ok(Some((img, format!("`{}`", path.display()))));
    }
    Ok(None)
}

/// The reference rendered on the CPU and saved as `reference.pfm` in the output directory.
fn rendered_reference(args: &ConvergeArgs, scene: &Scene, max_spp: u32) -> anyhow::Result<(HdrImage, String)> {
    let spp = args.reference_spp.unwrap_or(max_spp.saturating_mul(REFERENCE_FACTOR).min(MAX_SPP));
    if spp < max_spp.saturating_mul(REFERENCE_FACTOR) {
        crate::diag!("warning: reference spp {spp} is under {REFERENCE_FACTOR}× the largest spp {max_spp}: its noise will flatten the curve");
    }
    let mut ref_scene = scene.clone();
    ref_scene.tracer.rng.state ^= REFERENCE_SEED_MIX;
    crate::diag!("rendering the reference on the CPU at {spp} spp ...");
    let m = measure(&OpenDevice::Cpu, &ref_scene, spp, true).map_err(|e| anyhow!("{e}"))?;
    crate::diag!("reference: {} ({} spp)", format_seconds(m.seconds), spp);
    write_image(&args.output.join(REFERENCE_FILE), &m.image, &ToneMap::default())?;
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
    let given = given_reference(&args, &scene)?;
    let mut output = OutputDir::prepare(&args.output, given.is_none())?;
    let devices = args.devices.open()?;
    let (reference, reference_note) = match given {
        Some(r) => r,
        None => {
            let r = rendered_reference(&args, &scene, max_spp)?;
            output.keep();
            r
        }
    };

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
    write_results(&args, &scene, &table, &reference_note, &descriptions, &machine, &mut output)
}

/// The reference `converge` renders, in the output directory (not written with `--reference`).
const REFERENCE_FILE: &str = "reference.pfm";
/// The result files, in the output directory.
const RESULT_FILES: [&str; 4] = ["converge.csv", "converge.md", "converge.png", "converge.svg"];

/// The output directory, made ready before the work: created if missing (the directories
/// this run created are removed again if it fails before writing anything into them, so a
/// failed run leaves no empty directory behind), and every file it will hold checked as
/// `render` checks its outputs.
#[derive(Debug)]
struct OutputDir {
    /// The directories this run created, outermost first; empty once a file was written.
    created: Vec<PathBuf>,
}

impl OutputDir {
    fn prepare(dir: &Path, with_reference: bool) -> anyhow::Result<Self> {
        let out = OutputDir { created: create_dirs(dir)? };
        let files = RESULT_FILES.iter().chain(with_reference.then_some(&REFERENCE_FILE));
        for path in files.map(|f| dir.join(f)) {
            // On an error `out` is dropped, which removes what this run created.
            crate::image::check_destination(&path).with_context(|| format!("cannot write {}", path.display()))?;
        }
        Ok(out)
    }

    /// A file was written: the directory stays whatever happens next.
    fn keep(&mut self) {
        self.created.clear();
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        // Innermost first; `remove_dir` removes only an empty directory, so nothing that
        // appeared in one meanwhile is lost.
        for d in self.created.iter().rev() {
            if std::fs::remove_dir(d).is_err() {
                break;
            }
        }
    }
}

/// Creates `dir` and any missing parents, returning those it created (outermost first). An
/// existing file in the way is named in words, not as "File exists (os error 17)".
fn create_dirs(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut missing = Vec::new();
    for d in dir.ancestors().filter(|d| !d.as_os_str().is_empty()) {
        match std::fs::metadata(d) {
            Ok(m) if m.is_dir() => break,
            Ok(_) if d == dir => bail!("cannot write into {}: it is not a directory", dir.display()),
            Ok(_) => bail!("cannot create {}: {} is not a directory", dir.display(), d.display()),
            // NotADirectory: a file further up, which a later step names.
            Err(e) if matches!(e.kind(), std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory) => {
                missing.push(d.to_path_buf())
            }
            Err(e) => return Err(e).with_context(|| format!("cannot create {}", dir.display())),
        }
    }
    let mut created = Vec::new();
    for d in missing.into_iter().rev() {
        match std::fs::create_dir(&d) {
            Ok(()) => created.push(d),
            // Made by someone else meanwhile: theirs, not ours to remove.
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && d.is_dir() => {}
            Err(e) => {
                drop(OutputDir { created });
                return Err(e).with_context(|| format!("cannot create {}", d.display()));
            }
        }
    }
    Ok(created)
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
    output: &mut OutputDir,
) -> anyhow::Result<()> {
    let dir = &args.output;
    let slopes = slope_lines(table);
    let mut out = super::output::Lines::default();
    for l in &slopes {
        out.line(l);
    }
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
    let (width, height) = (800, 560);
    let contents = [
        table.to_csv().into_bytes(),
        md.into_bytes(),
        plot.png(width, height).context("cannot encode the plot as PNG")?,
        plot_loglog_svg(&plot, width, height).into_bytes(),
    ];
    let files: Vec<(PathBuf, Vec<u8>)> = RESULT_FILES.iter().map(|f| dir.join(f)).zip(contents).collect();
    let names = |paths: &mut dyn Iterator<Item = &PathBuf>| {
        paths.map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    };
    if let Err(crate::image::SetWriteError { path: failed, cause: e, renamed: written }) =
        crate::image::write_set_atomically(&files)
    {
        if !written.is_empty() {
            output.keep();
        }
        let kept = if written.is_empty() {
            "none of the results was written".to_string()
        } else {
            format!("only {} were written", names(&mut written.iter()))
        };
        let reference = if args.reference.is_none() {
            format!(" ({} was, before the measurements)", dir.join(REFERENCE_FILE).display())
        } else {
            String::new()
        };
        crate::diag!("{kept}{reference}");
        return Err(e).with_context(|| format!("cannot write {}", failed.display()));
    }
    output.keep();
    crate::diag!("wrote {}", names(&mut files.iter().map(|(p, _)| p)));
    // Last: the files are written even when nobody reads standard output.
    Ok(out.print()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        v.sort();
        v
    }

    /// The directories a run creates go again if it fails before writing into them, and
    /// stay once it has; a directory that was there before is never removed.
    #[test]
    fn only_the_directories_a_run_created_and_left_empty_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let deep = dir.path().join("a/b/c");
        drop(OutputDir::prepare(&deep, true).unwrap());
        assert!(names(dir.path()).is_empty());
        let mut kept = OutputDir::prepare(&deep, true).unwrap();
        std::fs::write(deep.join(REFERENCE_FILE), b"x").unwrap();
        kept.keep();
        drop(kept);
        assert!(deep.join(REFERENCE_FILE).is_file());
        drop(OutputDir::prepare(dir.path(), false).unwrap());
        assert!(dir.path().is_dir());
        // In a directory that was there, a blocked output fails and nothing is removed.
        std::fs::create_dir(dir.path().join("converge.md")).unwrap();
        let e = OutputDir::prepare(dir.path(), false).unwrap_err();
        assert_eq!(
            format!("{e:#}"),
            format!("cannot write {}: it is a directory", dir.path().join("converge.md").display())
        );
        assert_eq!(names(dir.path()), ["a", "converge.md"]);
        // A file in the way is said in words.
        let file = dir.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        let e = OutputDir::prepare(&file.join("x/y"), true).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("cannot create {}: {} is not a directory", file.join("x/y").display(), file.display())
        );
    }
}
