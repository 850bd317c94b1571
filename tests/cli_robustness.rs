//! The `lumen` binary under hostile conditions (issue 16): standard output full or closed,
//! no `XDG_RUNTIME_DIR`, memory limits, time limits on the CPU renderer, Ctrl-C before the
//! first sample, a second Ctrl-C while the outputs are written, control characters and
//! megabyte lines in what it quotes, every kind of line end.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

mod common;
use common::TINY_SKY_SL as SCENE;

/// A directory holding `tiny.sl`.
fn scene_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tiny.sl"), SCENE).unwrap();
    dir
}

fn lumen(dir: &Path) -> Command {
    let mut cmd = common::lumen_command();
    cmd.current_dir(dir);
    cmd
}

/// Every subcommand that writes results to standard output, with small arguments.
fn printing_commands() -> Vec<Vec<&'static str>> {
    vec![
        vec!["check", "tiny.sl"],
        vec!["devices"],
        vec!["shader", "tiny.sl"],
        vec!["converge", "tiny.sl", "--device", "cpu", "--spp", "1,2", "--reference-spp", "4", "-o", "conv"],
        vec!["bench", "--device", "cpu", "--scenes", "tiny.sl", "--spp", "1", "--width", "8", "--max-spheres", "0"],
        vec!["--help"],
        vec!["check", "--help"],
    ]
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_full_disk_on_stdout_is_one_error_line_and_a_failure() {
    let dir = scene_dir();
    for args in printing_commands() {
        let full = File::options().write(true).open("/dev/full").expect("/dev/full");
        let o = lumen(dir.path()).args(&args).stdout(Stdio::from(full)).output().unwrap();
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?} succeeded on a full disk: {err}");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(
            lines,
            ["error: cannot write to standard output: No space left on device (os error 28)"],
            "{args:?}: {err}"
        );
    }
}

/// The write end of a pipe whose read end is already closed, so that every write fails
/// with EPIPE whatever the timing: a FIFO opened read-write (Linux never blocks on that),
/// then write-only, after which the read-write handle is dropped.
fn closed_pipe(dir: &Path) -> File {
    let fifo: PathBuf = dir.join("fifo");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(made.success());
    let reader = File::options().read(true).write(true).open(&fifo).unwrap();
    let writer = File::options().write(true).open(&fifo).unwrap();
    drop(reader);
    std::fs::remove_file(&fifo).unwrap();
    writer
}

#[test]
fn a_closed_pipe_on_stdout_is_a_quiet_failure() {
    let dir = scene_dir();
    for args in printing_commands() {
        let o = lumen(dir.path()).args(&args).stdout(Stdio::from(closed_pipe(dir.path()))).output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(141), "{args:?}: {err}");
        assert!(!err.contains("panicked") && !err.contains("error"), "{args:?} is not quiet: {err}");
    }
}

#[test]
fn results_still_reach_a_working_stdout() {
    let dir = scene_dir();
    let o = lumen(dir.path()).args(["check", "tiny.sl"]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    assert!(out.starts_with("tiny.sl: ok\n") && out.contains("GPU kernel features:"), "{out}");
}

#[test]
fn no_runtime_dir_noise_on_a_headless_machine() {
    let dir = scene_dir();
    let tmp = tempfile::tempdir().unwrap();
    let o = lumen(dir.path()).arg("devices").env_remove("XDG_RUNTIME_DIR").env("TMPDIR", tmp.path()).output().unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("XDG_RUNTIME_DIR"), "Wayland noise on stderr: {err}");
    // The private runtime directory is gone after the run.
    let left: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    // A relative value is as unusable to libwayland as none.
    let o = lumen(dir.path()).arg("devices").env("XDG_RUNTIME_DIR", "relative").output().unwrap();
    assert!(!stderr(&o).contains("XDG_RUNTIME_DIR"), "{}", stderr(&o));
}

#[test]
fn llvmpipe_gets_128_bit_vectors_unless_the_user_chose_a_width() {
    let dir = scene_dir();
    let devices = |width: Option<&str>| {
        let mut cmd = lumen(dir.path());
        cmd.arg("devices").env_remove("LP_NATIVE_VECTOR_WIDTH");
        if let Some(w) = width {
            cmd.env("LP_NATIVE_VECTOR_WIDTH", w);
        }
        let o = cmd.output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let default = devices(None);
    if !default.contains("llvmpipe") {
        eprintln!("skipped: no llvmpipe adapter ({default})");
        return;
    }
    // llvmpipe names its vector width in the adapter name: lumen's 128 bits, or the host's
    // width where lumen relaunched itself on a driver that runs faster so
    // (cli::software_driver).
    let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
    info.name = "llvmpipe".into();
    info.driver_info = default.lines().find(|l| l.contains("driver:")).unwrap_or_default().into();
    let bits = if lumen::gpu::llvmpipe_prefers_wide_vectors(&info) {
        lumen::cli::software_driver::host_vector_bits()
    } else {
        128
    };
    let want = format!(", {bits} bits)");
    assert!(default.contains("llvmpipe (LLVM") && default.contains(&want), "{default}");
    let chosen = devices(Some("256"));
    assert!(chosen.contains(", 256 bits)"), "{chosen}");
}

/// `lumen render` under a 4 GiB address-space limit (`ulimit -v`, as the issue's reproducer).
fn render_limited_to_4_gib(dir: &Path, args: &str) -> Output {
    let bin = env!("CARGO_BIN_EXE_lumen");
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v 4194304 && exec '{bin}' render {args}"))
        .current_dir(dir)
        .output()
        .unwrap()
}

#[test]
fn an_image_too_large_for_memory_is_refused_with_the_amount() {
    let dir = scene_dir();
    std::fs::write(
        dir.path().join("huge.sl"),
        "USING Camera.Perspective() Image(16384, 16384) Renderer.Flat() Tracer()\n",
    )
    .unwrap();
    // More pixels than an image file holds (2²⁸): refused at the script's Image, whatever
    // the memory, since the render could not be written.
    std::fs::write(
        dir.path().join("past.sl"),
        "USING Camera.Perspective() Image(32768, 32768) Renderer.Flat() Tracer()\n",
    )
    .unwrap();
    let cases = [
        ("tiny.sl --device cpu --width 16384 --height 16384 --spp 1 -o big.png", "15.00 GiB"),
        ("huge.sl --device cpu -o big.png", "15.00 GiB"),
        ("past.sl --device cpu -o big.png", "past.sl:1:28: error: image size 32768×32768 cannot be rendered"),
        ("tiny.sl --device cpu --width 32768 --height 32768 -o big.png", "at most 268435456 pixels in all"),
    ];
    for (args, needed) in cases {
        let o = render_limited_to_4_gib(dir.path(), args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args}: {err}");
        assert!(err.starts_with("error: ") && err.contains(needed), "{args}: {err}");
        assert!(!err.contains("panicked") && !err.contains("memory allocation"), "{args}: {err}");
        assert!(!dir.path().join("big.png").exists(), "{args} left an output file");
    }
}

/// The same on the GPU (issue 16's reproducer): the device-side state is bounded by the
/// batch whatever the image size, and the host's accumulation buffers are estimated
/// before they are allocated. Under `--device auto` the CPU then refuses alike.
#[test]
fn a_gpu_render_too_large_for_host_memory_is_refused_with_the_amount() {
    if lumen::gpu::gpu_for_tests("gpu_render_too_large").is_none() {
        return;
    }
    let dir = scene_dir();
    for device in ["gpu", "auto"] {
        let args = format!("tiny.sl --device {device} --width 16384 --height 16384 --spp 1 -o big.png");
        let o = render_limited_to_4_gib(dir.path(), &args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args}: {err}");
        assert!(err.contains("error: ") && err.contains("15.00 GiB"), "{args}: {err}");
        assert!(!err.contains("panicked") && !err.contains("memory allocation"), "{args}: {err}");
        assert!(!dir.path().join("big.png").exists(), "{args} left an output file");
    }
}

/// A sky whose tables outgrow the adapter's storage binding: `--device gpu` refuses it,
/// naming the table and pointing at the CPU, and `--device auto` renders it there.
#[test]
fn a_sky_too_large_for_the_gpu_is_refused_by_name_or_rendered_on_the_cpu() {
    let Some(gpu) = lumen::gpu::gpu_for_tests("sky_too_large_for_the_gpu") else { return };
    let limit = gpu.storage_limit().0;
    drop(gpu);
    // Texels alone (3 f32 each) just over the limit.
    let (width, height) = (4096, (limit / 12 / 4096 + 1) as usize);
    if width * height > 1 << 25 {
        println!("skipped: this adapter binds {limit} bytes; a sky beyond it is too large for a test");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut sky = lumen::image::HdrImage::new(width, height);
    sky.pixels_mut().iter_mut().for_each(|p| *p = lumen::color::Rgb32::new(0.5, 0.6, 0.9));
    lumen::image::write_image(&dir.path().join("sky.hdr"), &sky, &lumen::image::ToneMap::default()).unwrap();
    drop(sky);
    let script = SCENE.replace("USING", "SET\n    hdri LOAD \"sky.hdr\"\nUSING\n    Environment.Image(.image hdri)");
    std::fs::write(dir.path().join("sky.sl"), script).unwrap();
    let o = lumen(dir.path()).args(["render", "sky.sl", "--device", "gpu", "-o", "gpu.png"]).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let why = "the floats table (image texels and sampling tables) needs";
    assert!(err.contains(why) && err.contains("`--device cpu` (or `auto`) renders the scene on the CPU"), "{err}");
    assert!(!dir.path().join("gpu.png").exists());
    let o = lumen(dir.path()).args(["render", "sky.sl", "--device", "auto", "-o", "auto.png"]).output().unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains(&format!("warning: the GPU cannot render this scene: {why}")), "{err}");
    assert!(err.contains("on the CPU (") && dir.path().join("auto.png").exists(), "{err}");
}

#[test]
fn the_cpu_renderer_honours_the_time_limit() {
    let dir = scene_dir();
    // A zero limit has passed after the first round (1 sample per pixel), on any machine.
    let o = lumen(dir.path())
        .args(["render", "tiny.sl", "--device", "cpu", "--spp", "1000000", "--time-limit", "0", "-o", "t.pfm"])
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains(": 1 of 1000000 samples per pixel, 768 samples,"), "{err}");
    assert!(err.contains("note: stopped at the time limit with 1 sample per pixel"), "{err}");
    assert!(!err.contains("warning: --time-limit"), "{err}");
    let img = lumen::image::read_image(&dir.path().join("t.pfm")).unwrap();
    assert_eq!((img.width(), img.height()), (32, 24));
}

/// Ctrl-C before the first sample per pixel is complete: one clear error and a failure, no
/// output, and (with `--device auto`) no second try on the CPU, which the user did not ask
/// for. Until 2026-12-07 the GPU reported it as a validation error, which `auto` took for a
/// scene the GPU cannot render and answered by starting over on the CPU.
#[cfg(unix)]
#[test]
fn a_ctrl_c_before_the_first_sample_writes_nothing_and_tries_no_other_device() {
    // 1.5 billion paths in the first round: minutes on lavapipe or two cores, seconds on a
    // datacenter GPU. Each renderer stops within a batch of paths of the signal.
    let scene = "SPAWN Shape.Sphere(.material Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.8, 0.8>))))\n\
                 USING Camera.Perspective(.transformation TRANSLATE(.X -3)) Image(2000, 1500)\n\
                 Renderer.PathTracer(.n 512, .max_depth 8) Tracer() Environment.Uniform(<1, 1, 1>)\n";
    for device in ["auto", "cpu"] {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("s.sl"), scene).unwrap();
        let mut child = lumen(dir.path())
            .args(["render", "s.sl", "--device", device, "--spp", "1", "-o", "out.png"])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The render installs its Ctrl-C handler when it starts, a fraction of a second in
        // (the CPU renderer prints nothing before its summary, so there is no line to wait for).
        std::thread::sleep(std::time::Duration::from_millis(1500));
        // SAFETY: kill(2) on our own child, which has not been waited for.
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
        let mut text = String::new();
        std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut text).unwrap();
        let exit = child.wait().unwrap();
        assert_eq!(exit.code(), Some(1), "{device}: {text}");
        assert!(text.contains("error: stopped before any sample was complete; nothing to write"), "{device}: {text}");
        assert!(text.contains(": 0 of 1 samples per pixel"), "{device}: {text}");
        for wrong in ["validation", "warning", "instead", "keeping the 0"] {
            assert!(!text.contains(wrong), "{device}: {wrong:?} in {text}");
        }
        assert!(!dir.path().join("out.png").exists(), "{device}");
    }
}

/// A mistyped output path fails before any work: no device opened, nothing rendered or
/// benchmarked, and the error names the file and the missing directory.
#[test]
fn an_output_in_a_missing_directory_fails_before_the_work() {
    let dir = scene_dir();
    // tonemap and merge check their output before reading inputs (missing here, so that an
    // input read first would name them instead; until 2026-12-07 they said only
    // "No such file or directory (os error 2)" when writing).
    let commands: [&[&str]; 5] = [
        &["render", "tiny.sl", "--device", "cpu", "-o", "no/such/dir/out.png"],
        &["render", "tiny.sl", "--device", "cpu", "-o", "ok.pfm", "-o", "no/out.png", "--frames", "0:1:2"],
        &["bench", "--device", "cpu", "--scenes", "tiny.sl", "--spp", "1", "--max-spheres", "0", "-o", "no/b.md"],
        &["tonemap", "missing.pfm", "no/out.png"],
        &["merge", "-o", "no/m.exr", "missing.exr"],
    ];
    for args in commands {
        let o = lumen(dir.path()).args(args).output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("error: cannot write no/") && err.contains("does not exist"), "{args:?}: {err}");
        assert!(!err.contains("samples per pixel") && !err.contains("warming up"), "{args:?} worked first: {err}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "only tiny.sl is left");
}

/// A second Ctrl-C exits at once, also while the outputs are being written: each output is
/// then whole or absent, never half-written, and no temporary file is left (the writes in
/// progress are abandoned first: `image::abandon_writes`), nor the private runtime
/// directory. The second signal is sent the moment a temporary file appears, so it meets a
/// write in progress.
#[cfg(unix)]
#[test]
fn a_second_ctrl_c_while_writing_leaves_whole_outputs_or_none() {
    signalled_while_writing(Some(libc::SIGINT), libc::SIGINT, 130);
}

/// SIGTERM and SIGHUP (a scheduler's or a closed terminal's end) leave as little as a
/// second Ctrl-C does, with the status shells report for the signal.
#[cfg(unix)]
#[test]
fn termination_signals_while_writing_leave_whole_outputs_or_none() {
    signalled_while_writing(None, libc::SIGTERM, 143);
    signalled_while_writing(None, libc::SIGHUP, 129);
}

/// Starts `cmd` with `signal` ignored, as `nohup` does for SIGHUP.
#[cfg(unix)]
fn ignored_in_child(cmd: &mut Command, signal: libc::c_int) {
    use std::os::unix::process::CommandExt;
    // SAFETY: only an async-signal-safe call (signal) between fork and exec.
    unsafe {
        cmd.pre_exec(move || {
            libc::signal(signal, libc::SIG_IGN);
            Ok(())
        });
    }
}

/// A SIGHUP inherited as ignored (`nohup`) stays ignored: the render goes on to its end.
#[cfg(unix)]
#[test]
fn an_ignored_sighup_stays_ignored() {
    let dir = scene_dir();
    let mut cmd = lumen(dir.path());
    cmd.args(["render", "tiny.sl", "--device", "cpu", "--spp", "1000000", "--time-limit", "1", "-o", "n.pfm"]);
    ignored_in_child(&mut cmd, libc::SIGHUP);
    let child = cmd.stderr(Stdio::piped()).spawn().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300));
    // SAFETY: kill(2) on our own child, which has not been waited for.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGHUP) };
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    lumen::image::read_image(&dir.path().join("n.pfm")).unwrap();
}

/// Renders to four outputs, sends `first` (if any) once the render is done, then `then`
/// the moment a write's temporary file appears, and checks what is left: whole outputs or
/// none, no temporary file, no runtime directory, and at least one run in five caught
/// mid-write (exit `status`, the output whose temporary file was seen absent).
#[cfg(unix)]
fn signalled_while_writing(first: Option<libc::c_int>, then: libc::c_int, status: i32) {
    use std::io::{BufRead, BufReader};
    let scene = "SPAWN Shape.Sphere(.material Material(.brdf Brdf.Diffuse(Pigment.Checkered(64))))\n\
                 USING Camera.Perspective() Image(32, 24) Renderer.Flat() Tracer()\n";
    let outputs = ["a.exr", "b.png", "c.pfm", "d.hdr"];
    let mut caught = 0;
    for _ in 0..5 {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("s.sl"), scene).unwrap();
        let names = || -> Vec<String> {
            std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect()
        };
        // Without XDG_RUNTIME_DIR the process makes a private one (cli::headless), here.
        let mut child = lumen(dir.path())
            .args(["render", "s.sl", "--device", "cpu", "--width", "2400", "--height", "1800", "--spp", "1"])
            .args(outputs.iter().flat_map(|o| ["-o", o]))
            .env_remove("XDG_RUNTIME_DIR")
            .env("TMPDIR", dir.path())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The summary line comes after the render and before the first write.
        let mut err = BufReader::new(child.stderr.take().unwrap());
        let mut text = String::new();
        while !text.contains("samples per pixel") {
            assert!(err.read_line(&mut text).unwrap() > 0, "no summary line: {text}");
        }
        let pid = child.id() as libc::pid_t;
        if let Some(signal) = first {
            // SAFETY: kill(2) on our own child, which has not been waited for.
            unsafe { libc::kill(pid, signal) };
        }
        let seen = loop {
            if let Some(tmp) = names().into_iter().find(|n| n.ends_with(".lumen.tmp")) {
                break Some(tmp);
            }
            if child.try_wait().unwrap().is_some() {
                break None;
            }
        };
        // SAFETY: as above.
        unsafe { libc::kill(pid, then) };
        let exit = child.wait().unwrap();
        std::io::Read::read_to_string(&mut err, &mut text).unwrap();
        let left = names();
        assert!(!left.iter().any(|n| n.ends_with(".tmp")), "{left:?} after {seen:?}\n{text}");
        assert!(!left.iter().any(|n| n.starts_with("lumen-runtime-")), "{left:?}\n{text}");
        for name in outputs {
            let path = dir.path().join(name);
            if path.exists() {
                let img = lumen::image::read_image(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
                assert_eq!((img.width(), img.height()), (2400, 1800), "{name}");
            }
        }
        // Caught mid-write: the output whose temporary file was seen is absent.
        let target = seen.as_deref().and_then(|t| t.strip_prefix('.')).and_then(|t| t.split_once(".lumen.tmp"));
        if let Some(target) = target.and_then(|(t, _)| t.rsplit_once('.')).map(|(t, _)| t) {
            if exit.code() == Some(status) && !left.iter().any(|n| n == target) {
                caught += 1;
            }
        }
    }
    assert!(caught > 0, "no signal {then} met a write in progress in 5 tries");
}

/// `WGPU_BACKEND` naming no backend this machine has leaves wgpu no adapter: the error
/// says that variable is why, not that a driver is missing.
#[test]
fn a_wgpu_backend_with_no_adapter_is_named_in_the_error() {
    let dir = scene_dir();
    let o = lumen(dir.path())
        .args(["render", "tiny.sl", "--device", "gpu", "-o", "t.pfm"])
        .env("WGPU_BACKEND", "nonsense")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("no GPU adapter found (WGPU_BACKEND=\"nonsense\" limits the backends tried"), "{err}");
    assert!(!dir.path().join("t.pfm").exists());
}

/// An endless script (`/dev/zero`) is refused once it passes the size limit, with a clear
/// error, instead of being read until memory runs out.
#[cfg(unix)]
#[test]
fn an_endless_script_is_refused_at_the_size_limit() {
    let dir = scene_dir();
    let o = lumen(dir.path()).args(["check", "/dev/zero"]).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("/dev/zero") && err.contains("cannot read script: it is larger than 1024 MiB"), "{err}");
}

/// Files read whole (images to tone-map or merge, a mesh, the pipeline cache) that are not
/// regular files are refused at once: a FIFO without a writer hung the read, and an
/// endless device (a `.pfm` link to `/dev/zero`) was read until memory ran out.
#[cfg(unix)]
#[test]
fn special_files_are_refused_not_read() {
    use std::time::{Duration, Instant};
    let dir = scene_dir();
    let d = dir.path();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.pfm")).unwrap();
    let fifo = |name: &str| {
        let c = std::ffi::CString::new(d.join(name).to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
    };
    fifo("part.exr");
    fifo("mesh.obj");
    std::fs::write(
        d.join("mesh.sl"),
        "SPAWN Shape.Mesh(.file \"mesh.obj\")\nUSING Camera.Perspective() Image(4, 3) Renderer.Flat() Tracer()\n",
    )
    .unwrap();
    let cache = d.join("cache");
    std::fs::create_dir(&cache).unwrap();
    // The first render writes the pipeline cache's file (where the device has one); the
    // loop then turns it into a FIFO, which the second render must not wait on.
    let commands: [(&[&str], &str); 5] = [
        (&["tonemap", "zero.pfm", "t.png"], "cannot read zero.pfm: it is not a regular file"),
        (&["merge", "part.exr", "-o", "m.exr"], "cannot read part.exr: it is not a regular file"),
        (&["render", "mesh.sl", "--device", "cpu", "-o", "m.pfm"], "mesh.obj"),
        (&["render", "tiny.sl", "--width", "8", "-o", "c.pfm"], ""),
        (&["render", "tiny.sl", "--width", "8", "-o", "d.pfm"], ""),
    ];
    for (args, says) in commands {
        let mut child = lumen(d)
            .args(args)
            .env("LUMEN_PIPELINE_CACHE", &cache)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while child.try_wait().unwrap().is_none() {
            if start.elapsed() > Duration::from_secs(60) {
                let _ = child.kill();
                panic!("{args:?} hung");
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let o = child.wait_with_output().unwrap();
        let err = stderr(&o);
        if says.is_empty() {
            assert!(o.status.success(), "{args:?}: {err}");
        } else {
            assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
            assert!(err.contains(says), "{args:?}: {err}");
        }
        // A cache file written is replaced by a FIFO of its name.
        if let Some(Ok(entry)) = std::fs::read_dir(&cache).unwrap().next() {
            if entry.file_type().unwrap().is_file() {
                let name = entry.file_name().into_string().unwrap();
                std::fs::remove_file(entry.path()).unwrap();
                fifo(&format!("cache/{name}"));
            }
        }
    }
}

/// An output the file system will not take (here past `RLIMIT_FSIZE`, as a full disk
/// would) is one error line naming the file once, and nothing is left: no image, no
/// temporary file. The outputs before it are whole. The render cannot be kept either
/// (the same limit), and the line says so.
#[cfg(unix)]
#[test]
fn an_output_the_disk_refuses_is_one_clear_error_and_no_file() {
    use std::os::unix::process::CommandExt;
    let dir = scene_dir();
    let rescue = tempfile::tempdir().unwrap();
    let mut cmd = lumen(dir.path());
    cmd.args(["render", "tiny.sl", "--device", "cpu", "--width", "64", "-o", "small.png", "-o", "big.pfm"]);
    cmd.env("TMPDIR", rescue.path());
    // Past the limit a write fails with EFBIG instead of raising SIGXFSZ.
    ignored_in_child(&mut cmd, libc::SIGXFSZ);
    // SAFETY: only async-signal-safe calls (setrlimit) between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            let rl = libc::rlimit { rlim_cur: 20_000, rlim_max: 20_000 };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &rl) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let o = cmd.output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let errors: Vec<&str> = err.lines().filter(|l| l.contains("error")).collect();
    assert_eq!(errors.len(), 1, "{err}");
    let lost =
        "error: cannot write big.pfm: File too large (os error 27); the render could not be kept either (cannot write ";
    let kept = format!("{}/lumen-rescue-", rescue.path().display());
    assert!(errors[0].starts_with(&format!("{lost}{kept}")), "{err}");
    assert!(errors[0].ends_with("-big.pfm.exr: File too large (os error 27))"), "{err}");
    assert_eq!(std::fs::read_dir(rescue.path()).unwrap().count(), 0, "no partial rescue");
    let mut names: Vec<String> =
        std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    assert_eq!(names, ["small.png", "tiny.sl"], "{err}");
    lumen::image::read_image(&dir.path().join("small.png")).unwrap();
}

/// Standard error on a full disk or a pipe nobody reads: diagnostics are best effort, so
/// a render still writes its image and succeeds, and a failing command still fails with
/// status 1, never the panic status 101 (`eprintln!` panicked on such a stderr).
#[cfg(unix)]
#[test]
fn an_unwritable_stderr_changes_no_outcome() {
    let dir = scene_dir();
    let stderrs: [fn(&Path) -> Stdio; 2] =
        [|_| Stdio::from(File::options().write(true).open("/dev/full").expect("/dev/full")), |d| closed_pipe(d).into()];
    for (k, make) in stderrs.iter().enumerate() {
        let out = format!("ok{k}.pfm");
        let o = lumen(dir.path())
            .args(["render", "tiny.sl", "--device", "cpu", "-o", &out])
            .stderr(make(dir.path()))
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0), "stderr {k}");
        lumen::image::read_image(&dir.path().join(&out)).unwrap();
        let o = lumen(dir.path()).args(["render", "missing.sl"]).stderr(make(dir.path())).output().unwrap();
        assert_eq!(o.status.code(), Some(1), "stderr {k}");
    }
}

/// A size outside 1..=32768 is a usage error of every command that takes one, before any
/// work (`bench` reported a 0-pixel size per scene and succeeded).
#[test]
fn sizes_out_of_range_are_usage_errors_for_every_command() {
    let dir = scene_dir();
    let commands: [&[&str]; 3] = [
        &["render", "tiny.sl", "--device", "cpu"],
        &["bench", "--device", "cpu", "--scenes", "tiny.sl", "--max-spheres", "0"],
        &["converge", "tiny.sl", "--device", "cpu", "--spp", "1", "--reference-spp", "2"],
    ];
    for args in commands {
        for (flag, value) in [("--width", "0"), ("--height", "32769")] {
            let o = lumen(dir.path()).args(args).args([flag, value]).output().unwrap();
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{args:?} {flag} {value}: {err}");
            assert!(err.contains(&format!("{value} is not in 1..=32768")), "{args:?}: {err}");
        }
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "only tiny.sl is left");
}

/// Whole-number arguments say what they accept: a negative value is not taken for an
/// unknown flag (clap advised `-- -4`), a fraction or a word is not met with Rust's
/// "invalid digit found in string", and a huge count hears the argument's range, not u32's.
#[test]
fn whole_number_arguments_say_what_they_accept() {
    let dir = scene_dir();
    for (args, says) in [
        (&["--width", "-4"][..], "-4 is negative; expected a whole number from 1 to 32768"),
        (&["--width", "4.5"], "4.5 is not a whole number; expected one from 1 to 32768"),
        (&["--spp", "99999999999"], "99999999999 is not in 1..=1048576"),
        (&["--spp", "-1"], "-1 is negative; expected a whole number from 1 to 1048576"),
        (&["--seed", "abc"], "\"abc\" is not a number; expected a whole number from 0 to 18446744073709551615"),
        (&["--queue-shards", "40"], "40 is not in 1..=32"),
        (&["--time-limit", "-1"], "the time limit must be a finite number of seconds ≥ 0"),
    ] {
        let o = lumen(dir.path())
            .args(["render", "tiny.sl", "--device", "cpu", "-o", "t.png"])
            .args(args)
            .output()
            .unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("invalid digit") && !err.contains("unexpected argument"), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "only tiny.sl is left");
}

/// What lumen prints quotes its input, and a terminal obeys the control characters it is
/// sent: a script's `ESC [ 2 J` cleared the screen when its line was quoted in an error.
/// Now no control character but tab and newline reaches standard error or output (they are
/// shown as U+2400-block pictures), and an error in a one-line script of a megabyte quotes
/// a window around its culprit instead of the whole line.
#[test]
fn quoted_input_cannot_drive_the_terminal() {
    let dir = scene_dir();
    let obeyed = |bytes: &[u8]| bytes.iter().any(|&b| b < 0x20 && b != b'\n' && b != b'\t' || b == 0x7f);
    // The culprit's line, the message (a file name) and a note all quote hostile bytes.
    std::fs::write(dir.path().join("esc.sl"), "# \x1b]0;owned\x07 title\nSET x 1 \x1b[2J\x1b[31m\n").unwrap();
    std::fs::write(dir.path().join("bell.sl"), "SET s LOAD \"\x07\x1b[2J.pfm\"\n").unwrap();
    for (script, shown) in [("esc.sl", "2 | SET x 1 ␛[2J␛[31m"), ("bell.sl", "image file ␇␛[2J.pfm not found")]
    {
        let o = lumen(dir.path()).args(["check", script]).output().unwrap();
        assert_eq!(o.status.code(), Some(1), "{script}");
        assert!(!obeyed(&o.stderr), "{script}: {:?}", stderr(&o));
        assert!(stderr(&o).contains(shown), "{script}: {}", stderr(&o));
    }
    // A usage error quotes the command line, whose words may be file names from anywhere.
    for args in [&["render", "tiny.sl", "--width", "1\r\x1b[2J"][..], &["check", "tiny.sl", "--vars", "\x1b]0;x\x07"]] {
        let o = lumen(dir.path()).args(args).output().unwrap();
        assert!(o.status.code().is_some_and(|c| c != 0), "{args:?}");
        assert!(!obeyed(&o.stderr), "{args:?}: {:?}", stderr(&o));
    }
    // Standard output: `check` names a mesh by its file name.
    let mesh = "tri\x1b[2J\u{202e}.obj";
    std::fs::write(dir.path().join(mesh), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let script = SCENE.replace("SPAWN\n", &format!("SPAWN\n    Shape.Mesh(.file \"{mesh}\", .material red)\n"));
    std::fs::write(dir.path().join("mesh.sl"), script).unwrap();
    let o = lumen(dir.path()).args(["check", "mesh.sl"]).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(!obeyed(&o.stdout) && !out.contains('\u{202e}'), "{out}");
    assert!(out.contains("tri␛[2J\u{fffd}.obj"), "{out}");
    // A megabyte on one line, the culprit in its middle.
    let names = |from: usize| (from..from + 60_000).map(|i| format!("a{i} 1 ")).collect::<String>();
    let line = format!("SET {}?{}", names(0), names(60_000));
    std::fs::write(dir.path().join("long.sl"), &line).unwrap();
    let o = lumen(dir.path()).args(["check", "long.sl"]).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(err.len() < 2_000, "{} bytes: {}", err.len(), &err[..2_000.min(err.len())]);
    let col = line.find('?').unwrap() + 1;
    assert!(err.contains(&format!("long.sl:1:{col}: ")), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    let at = lines.iter().position(|l| l.starts_with(" 1 | ")).expect("the excerpt");
    let (text, caret) =
        (lines[at].chars().skip(5).collect::<String>(), lines[at + 1].chars().skip(5).collect::<String>());
    assert!(text.starts_with('…') && text.ends_with('…'), "{text}");
    assert_eq!(
        text.chars().nth(caret.find('^').unwrap()),
        Some('?'),
        "the caret is under the culprit:\n{text}\n{caret}"
    );
}

/// A script's lines may end in `\n`, `\r\n` or classic Mac OS's lone `\r`: with the last, a
/// comment ran to the end of the file and took the scene with it ("the script never sets
/// the camera"), and every error was on line 1.
#[test]
fn every_line_end_loads_the_same_scene() {
    let dir = scene_dir();
    let commented = format!("# a comment\n{SCENE}");
    let mut summaries = Vec::new();
    for (name, end) in [("lf.sl", "\n"), ("crlf.sl", "\r\n"), ("cr.sl", "\r")] {
        std::fs::write(dir.path().join(name), commented.replace('\n', end)).unwrap();
        let o = lumen(dir.path()).args(["check", name]).output().unwrap();
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        let summary = String::from_utf8(o.stdout).unwrap();
        summaries.push(summary.replacen(name, "SCRIPT", 1));
        let broken = commented.replace("red   Material", "red   Materail").replace('\n', end);
        std::fs::write(dir.path().join(name), broken).unwrap();
        let o = lumen(dir.path()).args(["check", name]).output().unwrap();
        assert!(stderr(&o).contains(&format!("{name}:4:11: error: unknown type `Materail`")), "{name}: {}", stderr(&o));
    }
    assert!(summaries.iter().all(|s| *s == summaries[0]), "{summaries:?}");
}

/// An output whose directory is removed during the render (as a full disk or a lost share
/// fails only at the write, after the checks before the render passed): the render is not
/// lost but kept as an EXR in `$TMPDIR`, and the error says where and how to convert it.
#[test]
fn an_output_lost_after_the_render_keeps_the_render() {
    let dir = scene_dir();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let rescue = tempfile::tempdir().unwrap();
    let child = lumen(dir.path())
        .args(["render", "tiny.sl", "--device", "cpu", "--spp", "1000000", "--time-limit", "3", "-o", "out/x.png"])
        .env("TMPDIR", rescue.path())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    std::fs::remove_dir(&out).unwrap();
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let kept = rescue.path().join(format!("lumen-rescue-{pid}-x.png.exr"));
    let said = format!(
        "error: cannot write out/x.png: No such file or directory (os error 2); the render is kept in {}",
        kept.display()
    );
    assert!(err.contains(&said), "{err}");
    assert!(err.contains(&format!("`lumen tonemap {} out/x.png` makes it", kept.display())), "{err}");
    let (image, meta) = lumen::image::read_render_part(&kept).unwrap();
    assert_eq!((image.width(), image.height()), (32, 24));
    assert!(meta.spp() >= 1, "{err}");
}

/// `converge` checks every file it will write before the work, as `render` does: an output
/// that is a directory fails at once, with nothing rendered and nothing written (it had
/// rendered everything, then written the CSV, the Markdown and the reference before the
/// PNG failed). A file given as the output directory is named as not a directory, and a
/// run that fails before writing leaves no directory it created behind.
#[test]
fn converge_checks_its_outputs_before_the_work_and_leaves_nothing_on_failure() {
    let dir = scene_dir();
    let converge = |out: &str| {
        let args = ["converge", "tiny.sl", "--device", "cpu", "--spp", "1,2", "--reference-spp", "4", "-o", out];
        lumen(dir.path()).args(args).output().unwrap()
    };
    for blocked in ["converge.png", "converge.csv", "converge.svg", "reference.pfm"] {
        let cv = dir.path().join("cv");
        std::fs::create_dir_all(cv.join(blocked)).unwrap();
        let o = converge("cv");
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{blocked}: {err}");
        assert!(
            err.contains(&format!("error: cannot write cv/{blocked}")) && err.contains("it is a directory"),
            "{err}"
        );
        assert!(
            !err.contains("rendering the reference") && !err.contains("warming up"),
            "{blocked}: worked first: {err}"
        );
        let left: Vec<_> = std::fs::read_dir(&cv).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left, [blocked], "{blocked}: nothing is written");
        std::fs::remove_dir_all(&cv).unwrap();
    }
    std::fs::write(dir.path().join("afile"), b"x").unwrap();
    for (out, said) in [
        ("afile", "error: cannot write into afile: it is not a directory"),
        ("afile/sub", "error: cannot create afile/sub: afile is not a directory"),
    ] {
        let o = converge(out);
        assert_eq!(o.status.code(), Some(1), "{out}");
        assert!(stderr(&o).contains(said) && !stderr(&o).contains("os error"), "{out}: {}", stderr(&o));
    }
    // A 1×1 reference, which the scene's size does not match, fails before any output.
    let mut pfm = b"PF\n1 1\n-1.0\n".to_vec();
    pfm.extend([0.5f32; 3].iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(dir.path().join("ref.pfm"), pfm).unwrap();
    let o = lumen(dir.path())
        .args(["converge", "tiny.sl", "--device", "cpu", "--spp", "1", "--reference", "ref.pfm", "-o", "new/deep"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("reference ref.pfm is 1×1"), "{}", stderr(&o));
    assert!(!dir.path().join("new").exists(), "the directories it created are removed");
    // A good run still writes the whole set into a directory it creates.
    let o = converge("made/here");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut made: Vec<_> =
        std::fs::read_dir(dir.path().join("made/here")).unwrap().map(|e| e.unwrap().file_name()).collect();
    made.sort();
    assert_eq!(made, ["converge.csv", "converge.md", "converge.png", "converge.svg", "reference.pfm"]);
}

/// `bench` loads every script named on its command line before it measures anything, and a
/// broken one is an error with the script's message and location (it was a warning after
/// the other scenes were measured, the multi-line error pasted into the Markdown table,
/// splitting it, and the run exited 0). A directory's scripts that do not load are skipped
/// with a warning, their error on the one line of their row. A sphere count past the
/// scaling study's largest is refused, not quietly cut.
#[test]
fn bench_refuses_a_named_broken_script_before_measuring() {
    let dir = scene_dir();
    std::fs::write(dir.path().join("bad.sl"), "SPAWN Shape.Sphere(.bogus 1)\n").unwrap();
    let bench = |scenes: &str, more: &[&str]| {
        let args = [&["bench", "--device", "cpu", "--scenes", scenes, "--quick", "--max-spheres", "0"], more];
        lumen(dir.path()).args(args.concat()).output().unwrap()
    };
    let o = bench("tiny.sl,bad.sl", &["-o", "r.md"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("bad.sl:1:20: error: unknown keyword `.bogus`"), "{err}");
    assert!(!err.contains("warming up") && !err.contains("tiny.sl on cpu"), "measured first: {err}");
    assert!(o.stdout.is_empty() && !dir.path().join("r.md").exists());

    let scenes = dir.path().join("scenes");
    std::fs::create_dir(&scenes).unwrap();
    std::fs::write(scenes.join("tiny.sl"), SCENE).unwrap();
    std::fs::write(scenes.join("bad.sl"), "SPAWN Shape.Sphere(.bogus 1)\n").unwrap();
    std::fs::write(scenes.join("pi|pe.sl"), "SPAWN\n  Shape.Sphere(.material |x)\n").unwrap();
    let o = bench("scenes", &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("warning: skipping bad.sl"), "{err}");
    let md = String::from_utf8(o.stdout).unwrap();
    let table: Vec<&str> =
        md.split("| scene | device |").nth(1).unwrap().lines().skip(1).take_while(|l| !l.is_empty()).collect();
    assert_eq!(table.len(), 4, "a separator and one row per script: {md}");
    for row in &table {
        assert!(row.starts_with('|') && row.ends_with('|'), "{row} in {md}");
        assert_eq!(row.replace("\\|", "").matches('|').count(), 10, "{row}");
    }
    assert!(table.iter().any(|r| r.contains("bad.sl:1:20: error: unknown keyword")), "{md}");
    assert!(table.iter().any(|r| r.starts_with("| pi\\|pe.sl |") && r.contains("pi\\|pe.sl:2:")), "{md}");
    // Cores busy is a figure the machine can give, or n/a.
    let cpus = std::thread::available_parallelism().map_or(1, usize::from) as f64;
    let tiny = table.iter().find(|r| r.starts_with("| tiny.sl |")).unwrap();
    let cores = tiny.split('|').nth(8).unwrap().trim();
    assert!(cores.starts_with("n/a") || cores.parse::<f64>().is_ok_and(|c| c <= cpus), "cores busy {cores}");

    let o = lumen(dir.path()).args(["bench", "--device", "cpu", "--max-spheres", "100000000"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("100000000 is not in 0..=100000"), "{}", stderr(&o));
}
