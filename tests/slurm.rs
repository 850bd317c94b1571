//! Issue 15: a sharded render through a real Slurm. The test starts a single-node cluster
//! on localhost (scripts/slurm/local_cluster.sh: munged, slurmctld, slurmd, stopped again
//! by pid), submits a 4-task job array and its dependent merge job with
//! scripts/slurm/submit.sh, waits for the merge, and checks the merged image against one
//! render of all the samples.
//!
//! Needs Debian's slurm-wlm and munge. Without them it prints that it was skipped, unless
//! LUMEN_REQUIRE_SLURM is set (as .ci/run sets it, after installing them): then it fails.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn scripts() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/slurm")
}

fn have(program: &str) -> bool {
    ["/usr/sbin", "/usr/bin", "/sbin", "/bin", "/usr/local/sbin", "/usr/local/bin"]
        .iter()
        .any(|d| Path::new(d).join(program).exists())
}

/// The cluster's daemons, stopped when dropped (also when the test fails).
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        let o = Command::new(scripts().join("local_cluster.sh")).arg("start").arg(dir).output().unwrap();
        assert!(
            o.status.success(),
            "the local Slurm cluster did not start:\n{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        Cluster { dir: dir.to_path_buf(), conf: dir.join("slurm.conf") }
    }

    fn command(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf).env("PATH", format!("{}:/usr/sbin:/sbin", std::env::var("PATH").unwrap()));
        c
    }

    /// Daemon and job logs, for failure messages.
    fn logs(&self, out: &Path) -> String {
        let mut s = String::new();
        let daemon = Command::new(scripts().join("local_cluster.sh")).arg("logs").arg(&self.dir).output();
        if let Ok(o) = daemon {
            s.push_str(&String::from_utf8_lossy(&o.stdout));
        }
        for e in std::fs::read_dir(out.join("logs")).into_iter().flatten().flatten() {
            s.push_str(&format!(
                "--- {}\n{}",
                e.path().display(),
                std::fs::read_to_string(e.path()).unwrap_or_default()
            ));
        }
        s
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(scripts().join("local_cluster.sh")).arg("stop").arg(&self.dir).status();
    }
}

#[test]
fn a_slurm_job_array_renders_shards_and_a_dependent_job_merges_them() {
    if !(have("slurmctld") && have("slurmd") && have("munged") && have("sbatch")) {
        assert!(
            std::env::var_os("LUMEN_REQUIRE_SLURM").is_none(),
            "LUMEN_REQUIRE_SLURM is set but slurm-wlm and munge are not installed"
        );
        println!("skipped: slurm-wlm and munge are not installed (apt install slurm-wlm munge)");
        return;
    }
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    std::fs::write(w.join("tiny.sl"), common::TINY_SKY_SL).unwrap();
    let cluster = Cluster::start(&w.join("cluster"));
    let lumen = env!("CARGO_BIN_EXE_lumen");
    let render = ["--device", "cpu", "--width", "16", "--spp", "12"];

    let submitted = cluster
        .command(scripts().join("submit.sh"))
        .current_dir(w)
        .env("LUMEN", lumen)
        .args(["tiny.sl", "4", "parts", "merged.exr"])
        .args(render)
        .output()
        .unwrap();
    assert!(submitted.status.success(), "submit.sh: {}", String::from_utf8_lossy(&submitted.stderr));
    let ids = String::from_utf8_lossy(&submitted.stdout).trim().to_string();
    let merge_id = ids.split_whitespace().nth(1).unwrap_or_else(|| panic!("submit.sh printed {ids:?}")).to_string();

    // The merge job leaves the queue once it has run (or was cancelled by a failed shard).
    let deadline = Instant::now() + Duration::from_secs(150);
    loop {
        let q = cluster.command("squeue").args(["-h", "-j", &merge_id, "-o", "%T"]).output().unwrap();
        let state = String::from_utf8_lossy(&q.stdout).trim().to_string();
        if q.status.success() && state.is_empty() {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the merge job is still {state:?} after 150 s\n{}",
            cluster.logs(&w.join("parts"))
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    let merged = w.join("merged.exr");
    assert!(merged.exists(), "no merged image\n{}", cluster.logs(&w.join("parts")));
    let parts = std::fs::read_dir(w.join("parts"))
        .unwrap()
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "exr"))
        .count();
    assert_eq!(parts, 4);

    // One render of all twelve samples, outside Slurm.
    let o = Command::new(lumen)
        .current_dir(w)
        .args(["render", "tiny.sl"])
        .args(render)
        .args(["-o", "whole.exr"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let whole = lumen::image::read_image(&w.join("whole.exr")).unwrap();
    let (img, meta) = lumen::image::read_render_part(&merged).unwrap();
    assert_eq!(meta.ranges, [lumen::prepare::SampleRange::all(12)]);
    for (g, want) in img.pixels().iter().zip(whole.pixels()) {
        for (a, b) in [(g.r, want.r), (g.g, want.g), (g.b, want.b)] {
            assert!(a.to_bits().abs_diff(b.to_bits()) <= 2, "merged {g:?} vs one render {want:?}");
        }
    }
    drop(cluster);
}
