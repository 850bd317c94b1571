//! scripts/device_check.sh (issue 12, goal 4: the hardware-GPU figures in one run) keeps
//! working while no hardware GPU is lent: run small (`QUICK=1`, which accepts a software
//! adapter) with this build's binary, it writes every report it promises, and every step
//! ends well. The same for the other device scripts (the tests' runner, the side by side).

use std::path::Path;
use std::process::Command;

#[test]
fn the_device_check_writes_every_report() {
    if lumen::gpu::gpu_for_tests("the_device_check_writes_every_report").is_none() {
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/device_check.sh");
    let o = Command::new("bash")
        .arg(&script)
        .arg(out.path())
        .env("QUICK", "1")
        .env("LUMEN_BIN", env!("CARGO_BIN_EXE_lumen"))
        // No megakernel step, even where a build of it lies at the default path.
        .env("MEGAKERNEL_BIN", "/nonexistent/lumen-megakernel")
        .output()
        .unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{said}");
    let read = |name: &str| std::fs::read_to_string(out.path().join(name)).unwrap_or_default();
    let log = read("log.txt");
    for step in ["bench", "bench_large", "cornell", "batch 4096", "shards 1", "shards 8", "shards 32"] {
        assert!(log.lines().any(|l| l.starts_with(&format!("{step}: exit 0 "))), "{step}: {log}\n{said}");
    }
    assert!(read("device.txt").contains("type: "), "{}", read("device.txt"));
    // Both devices in the bench, the GPU alone in the large one.
    let bench = read("bench.md");
    assert!(bench.contains("| gpu |") && bench.contains("| cpu |") && bench.contains("cornell.sl"), "{bench}");
    let large = read("bench_large.md");
    assert!(large.contains("| gpu |") && !large.contains("| cpu |"), "{large}");
    // The render's summary, the stage profile with the busy fraction, the process's time
    // to its end (the device closed).
    let cornell = read("cornell.txt");
    let wanted = [
        "16 of 16 samples per pixel",
        "device busy",
        "s waiting for read-backs",
        "process: render",
        "process: closing",
    ];
    for want in wanted.into_iter().chain(["wall "]) {
        assert!(cornell.contains(want), "{want}: {cornell}");
    }
    // One line per scene in the log, each scene's table in the bench reports.
    for scene in ["cornell.sl", "spheres_10k.sl"] {
        assert!(log.contains(&format!("bench_large {scene}: exit 0 ")), "{scene}: {log}");
        assert!(large.contains(&format!("| {scene} | gpu |")), "{scene}: {large}");
    }
    // The batch sweep's render ran with the size it names.
    let batch = read("batch.txt");
    assert!(batch.contains("--batch-paths 4096") && batch.contains("4 of 4 samples per pixel"), "{batch}");
    // Each shard count's render, profiled, with the shards it names.
    let shards = read("shards.txt");
    for n in [1, 8, 32] {
        let s = if n == 1 { "" } else { "s" };
        assert!(shards.contains(&format!("--queue-shards {n}\n")), "{shards}");
        assert!(shards.contains(&format!(", {n} queue shard{s}):")), "{n}: {shards}");
    }
    assert_eq!(shards.matches("4 of 4 samples per pixel").count(), 3, "{shards}");
    // Nothing but the reports: the render's image went to a scratch directory.
    let mut files: Vec<String> =
        std::fs::read_dir(out.path()).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
    files.sort();
    assert_eq!(
        files,
        ["batch.txt", "bench.md", "bench_large.md", "cornell.txt", "device.txt", "log.txt", "shards.txt", "stderr.txt"]
    );
}

/// scripts/device_tests.sh (the GPU tests on a lent hardware GPU) refuses a wrong verb with
/// its usage, and `run` without a pack fails instead of reporting nothing as a pass.
#[test]
fn the_device_tests_script_refuses_what_it_cannot_do() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/device_tests.sh");
    let o = Command::new("bash").arg(&script).arg("frobnicate").output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("usage: scripts/device_tests.sh pack | run"));
    // A copy of the script in a checkout with no target/devcarry.
    let root = tempfile::tempdir().unwrap();
    std::fs::create_dir(root.path().join("scripts")).unwrap();
    std::fs::copy(&script, root.path().join("scripts/device_tests.sh")).unwrap();
    let out = root.path().join("out");
    let o =
        Command::new("bash").arg(root.path().join("scripts/device_tests.sh")).arg("run").arg(&out).output().unwrap();
    assert!(!o.status.success(), "{o:?}");
    assert_eq!(std::fs::read_to_string(out.join("summary.txt")).unwrap(), "");
}

/// scripts/device_ab.sh (two builds side by side on a lent GPU) run small with this build
/// as both sides: each report holds a row per build and round, and a missing binary is
/// refused before anything runs.
#[test]
fn the_side_by_side_script_reports_both_builds() {
    if lumen::gpu::gpu_for_tests("the_side_by_side_script_reports_both_builds").is_none() {
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/device_ab.sh");
    let lumen = env!("CARGO_BIN_EXE_lumen");
    let o = Command::new("bash")
        .arg(&script)
        .arg(out.path())
        .arg("glass")
        .envs([("QUICK", "1"), ("ROUNDS", "2"), ("LUMEN_A", lumen), ("LUMEN_B", lumen)])
        .output()
        .unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{said}");
    let read = |name: &str| std::fs::read_to_string(out.path().join(name)).unwrap_or_default();
    let cornell = read("cornell.txt");
    assert_eq!(cornell.matches("16 of 16 samples per pixel").count(), 4, "{cornell}");
    assert_eq!(cornell.matches("wall ").count(), 4, "{cornell}");
    let bench = read("bench.txt");
    assert_eq!(bench.matches("| glass.sl | gpu |").count(), 4, "{bench}");
    let profile = read("profile.txt");
    assert_eq!(profile.matches("device busy").count(), 2, "{profile}");
    let o = Command::new("bash")
        .arg(&script)
        .arg(out.path())
        .env("LUMEN_A", "/nonexistent/lumen")
        .env("LUMEN_B", lumen)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no binary at /nonexistent/lumen"), "{o:?}");
}
