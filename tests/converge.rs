//! `lumen converge` through the binary: a tiny path-traced scene on the CPU, whose MSE must
//! fall like 1/spp, and argument errors that must fail before any rendering.

use std::path::Path;
use std::process::Output;

mod common;
use common::TINY_SKY_SL as SCENE;

fn lumen(dir: &Path, args: &[&str]) -> Output {
    let scene = dir.join("tiny.sl");
    std::fs::write(&scene, SCENE).unwrap();
    common::lumen_command().arg("converge").arg(&scene).args(args).current_dir(dir).output().expect("run lumen")
}

#[test]
fn cpu_error_falls_like_one_over_spp() {
    let dir = tempfile::tempdir().unwrap();
    let out = lumen(
        dir.path(),
        &[
            "--device",
            "cpu",
            "--spp",
            "16,1,4",
            "--reference-spp",
            "256",
            "--width",
            "16",
            "--height",
            "12",
            "-o",
            "res",
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let csv = std::fs::read_to_string(dir.path().join("res/converge.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "device,spp,seconds,rmse,mse,rel_mse,efficiency");
    assert_eq!(lines.len(), 4, "{csv}");
    let rows: Vec<Vec<&str>> = lines[1..].iter().map(|l| l.split(',').collect()).collect();
    let spp: Vec<f64> = rows.iter().map(|r| r[1].parse().unwrap()).collect();
    assert_eq!(spp, vec![1.0, 4.0, 16.0]); // sorted
    assert!(rows.iter().all(|r| r[0] == "cpu"));
    let rmse: Vec<f64> = rows.iter().map(|r| r[3].parse().unwrap()).collect();
    let mse: Vec<f64> = rows.iter().map(|r| r[4].parse().unwrap()).collect();
    assert!(rmse[0] > rmse[1] && rmse[1] > rmse[2], "{rmse:?}");
    for (r, m) in rmse.iter().zip(&mse) {
        assert!((r * r - m).abs() <= 1e-5 * m, "rmse² ≠ mse: {r} {m}");
    }
    // Least-squares slope of log MSE against log spp, computed here independently.
    let (lx, ly): (Vec<f64>, Vec<f64>) = spp.iter().zip(&mse).map(|(s, m)| (s.ln(), m.ln())).unzip();
    let (mx, my) = (lx.iter().sum::<f64>() / 3.0, ly.iter().sum::<f64>() / 3.0);
    let slope = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
        / lx.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
    assert!((-1.4..=-0.6).contains(&slope), "slope {slope}");
    // The printed slope is the same fit.
    let stdout = String::from_utf8_lossy(&out.stdout);
    let printed: f64 = stdout
        .split("slope of log MSE vs log spp = ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no slope in {stdout}"));
    assert!((printed - slope).abs() < 2e-3, "{printed} vs {slope}");
    let md = std::fs::read_to_string(dir.path().join("res/converge.md")).unwrap();
    assert_eq!(md.lines().filter(|l| l.starts_with("| cpu |")).count(), 3);
    assert!(md.contains(&format!("\nMachine: {}.\n", lumen::analysis::Host::detect())), "{md}");
    let png = image::open(dir.path().join("res/converge.png")).unwrap();
    assert!(png.width() >= 320 && png.height() >= 240);
    // The same plot as a vector image, with the devices in its legend.
    let svg = std::fs::read_to_string(dir.path().join("res/converge.svg")).unwrap();
    assert!(svg.starts_with("<?xml") && svg.contains("<svg") && svg.contains(">cpu</text>"), "{svg}");
    assert!(dir.path().join("res/reference.pfm").exists());
}

#[test]
fn a_given_reference_of_the_wrong_size_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let ok = lumen(dir.path(), &["--device", "cpu", "--spp", "1", "--reference-spp", "4", "-o", "a", "--width", "8"]);
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    let out = lumen(dir.path(), &["--device", "cpu", "--spp", "1", "--reference", "a/reference.pfm", "-o", "b"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("reference") && err.contains("8×6") && err.contains("32×24"), "{err}");
    // The same reference at the matching size is accepted.
    let out = lumen(
        dir.path(),
        &["--device", "cpu", "--spp", "1,4", "--reference", "a/reference.pfm", "-o", "c", "--width", "8"],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn an_unavailable_gpu_is_skipped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let args =
        ["--device", "gpu,cpu", "--adapter", "no-such-adapter-xyz", "--spp", "1,4", "--reference-spp", "16", "-o", "r"];
    let out = lumen(dir.path(), &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("warning: skipping device gpu"), "{err}");
    let csv = std::fs::read_to_string(dir.path().join("r/converge.csv")).unwrap();
    assert_eq!(csv.lines().skip(1).map(|l| l.split(',').next().unwrap()).collect::<Vec<_>>(), ["cpu", "cpu"]);
    // With no device left, the command fails.
    let out = lumen(dir.path(), &["--device", "gpu", "--adapter", "no-such-adapter-xyz", "-o", "s"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("none of the requested devices is available"), "{err}");
}

#[test]
fn bad_arguments_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 5] = [
        (&["--device", "cpu", "--spp", "0"], "'--spp <SPP>': 0 is not in 1..=1048576"),
        (&["--device", "tpu"], "tpu"),
        (&["--device", "cpu", "--reference-spp", "0"], "'--reference-spp <REFERENCE_SPP>': 0 is not in 1..=1048576"),
        (&["--device", "cpu", "--spp", "4,x"], "\"x\" is not a number; expected a whole number from 1 to 1048576"),
        (&["--device", "cpu", "--reference", "missing.pfm"], "missing.pfm"),
    ];
    for (args, expect) in cases {
        let out = lumen(dir.path(), args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(err.contains(expect), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    assert!(!dir.path().join("converge/converge.csv").exists());
}

fn lumen_bench(dir: &Path, args: &[&str]) -> Output {
    std::fs::write(dir.join("tiny.sl"), SCENE).unwrap();
    common::lumen_command().arg("bench").args(args).current_dir(dir).output().expect("run lumen")
}

#[test]
fn bench_reports_scenes_and_sphere_scaling_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let out = lumen_bench(
        dir.path(),
        &[
            "--device",
            "cpu",
            "--scenes",
            "tiny.sl",
            "--spp",
            "1",
            "--width",
            "16",
            "--max-spheres",
            "100",
            "-o",
            "b.md",
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let md = std::fs::read_to_string(dir.path().join("b.md")).unwrap();
    assert_eq!(md, String::from_utf8_lossy(&out.stdout).trim_end_matches('\n').to_string() + "\n");
    let row = md.lines().find(|l| l.starts_with("| tiny.sl | cpu | 16×12 | 2 |")).unwrap_or_else(|| panic!("{md}"));
    assert_eq!(row.matches('|').count(), 10, "{row}");
    // Cores busy: the extra CPU seconds over the extra time, a non-negative number, or
    // n/a where noise swamps renders this small (analysis::cpu_time tests the clock).
    let cores = row.split('|').nth(8).unwrap().trim();
    assert!(cores.starts_with("n/a") || cores.parse::<f64>().is_ok_and(|c| c >= 0.0), "cores busy {cores:?} in {row}");
    for n in ["| 1 | cpu |", "| 10 | cpu |", "| 100 | cpu |"] {
        assert!(md.contains(n), "{n} missing in {md}");
    }
    assert!(!md.contains("| 1000 |"));
    assert!(md.contains("- cpu: ") && md.contains("Peak resident memory"));
    // The machine the figures belong to (no GPU measured, so no driver).
    let machine = format!("\nMachine: {}.\n", lumen::analysis::Host::detect());
    assert!(md.contains(&machine), "{machine} missing in {md}");
}

#[test]
fn bench_bad_arguments_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 4] = [
        (&["--device", "cpu", "--spp", "0"], "0 is not in 1..=1048576"),
        (&["--device", "cpu", "--spp", "100000"], "--spp must be 1..=65536, got 100000"),
        (&["--device", "cpu", "--scenes", "nowhere"], "nowhere"),
        (&["--device", "gpu,dsp"], "dsp"),
    ];
    for (args, expect) in cases {
        let out = lumen_bench(dir.path(), args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(err.contains(expect) && !err.contains("panicked"), "{args:?}: {err}");
    }
}

/// `--cold-kernels`: a table with each run's kernel creation, every run a new process that
/// created every stage kernel of the scene (which caches it runs with: a unit test of
/// `cold_environment` in src/cli/bench.rs).
#[test]
fn bench_times_cold_kernel_creation_in_new_processes() {
    let Some(gpu) = lumen::gpu::gpu_for_tests("bench_times_cold_kernel_creation_in_new_processes") else { return };
    let dir = tempfile::tempdir().unwrap();
    let args =
        ["--device", "gpu", "--scenes", "tiny.sl", "--spp", "1", "--width", "8", "--max-spheres", "0", "--repeat", "2"];
    let out = lumen_bench(dir.path(), &[&args[..], &["--cold-kernels"]].concat());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let md = String::from_utf8_lossy(&out.stdout);
    // The report names the machine, the GPU's driver included.
    let machine = format!(
        "\nMachine: {}; GPU driver: {}.\n",
        lumen::analysis::Host::detect(),
        lumen::device::driver_text(&gpu.adapter_info)
    );
    assert!(md.contains(&machine), "{machine} missing in {md}");
    let table = md.split("### Cold kernel creation").nth(1).unwrap_or_else(|| panic!("{md}"));
    let row = table.lines().find(|l| l.starts_with("| tiny.sl |")).unwrap_or_else(|| panic!("{md}"));
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    let kernels: usize = cells[2].parse().unwrap_or_else(|_| panic!("{row}"));
    assert!(kernels >= 2, "a path tracer has a camera, closest-hit, shading and film stage at least: {row}");
    let runs: Vec<f64> = cells[3].split(", ").map(|s| s.parse().unwrap()).collect();
    assert_eq!(runs.len(), 2, "{row}");
    assert!(runs.iter().all(|&s| s > 0.0 && s < 120.0), "{row}");
    // Without the flag there is no such table.
    let plain = lumen_bench(dir.path(), &args);
    assert!(plain.status.success() && !String::from_utf8_lossy(&plain.stdout).contains("Cold kernel creation"));
    // A scene of a listed directory that does not load gets its error and location in the
    // row; the others still run (a script named on the command line is an error instead).
    let scenes = dir.path().join("scenes");
    std::fs::create_dir(&scenes).unwrap();
    std::fs::copy(dir.path().join("tiny.sl"), scenes.join("tiny.sl")).unwrap();
    std::fs::write(scenes.join("bad.sl"), "SPAWN\n    Shape.Sphere(.material nothere)\n").unwrap();
    let with_bad = ["--device", "gpu", "--scenes", "scenes", "--spp", "1", "--width", "8", "--max-spheres", "0"];
    let out = lumen_bench(dir.path(), &[&with_bad[..], &["--cold-kernels"]].concat());
    let md = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let table = md.split("### Cold kernel creation").nth(1).unwrap_or_else(|| panic!("{md}"));
    assert!(table.lines().any(|l| l.starts_with("| tiny.sl | ")), "{table}");
    let bad = table.lines().find(|l| l.starts_with("| bad.sl |")).unwrap_or_else(|| panic!("{table}"));
    assert!(bad.contains("does not load") && bad.contains("bad.sl:2:"), "{bad}");
}
