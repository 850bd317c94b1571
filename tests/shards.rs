//! Issue 15: renders of sample ranges (shards) merge into the one-render image exactly, on
//! both devices, in any order; `lumen merge` refuses parts that do not belong together and
//! then writes nothing.

mod common;

use std::path::{Path, PathBuf};

use common::add_lit_props;
use glam::DVec3;
use lumen::cli::merge::merge;
use lumen::color::Color;
use lumen::cpu::{Progress, RenderOptions};
use lumen::gpu::gpu_for_tests;
use lumen::gpu::render::{render, GpuRenderOptions};
use lumen::image::{HdrImage, RenderMetadata};
use lumen::prepare::SampleRange;
use lumen::scene::*;

/// Diffuse, glass, mirror, emitters, a point light and a plane, under a uniform sky; the
/// path tracer with n = 2 paths per camera sample.
fn scene() -> Scene {
    let mut b = SceneBuilder::new(10, 8);
    let white = b.diffuse(Color::gray(0.7));
    b.plane(Transform::translation(DVec3::new(0.0, 0.0, -1.0)), white);
    add_lit_props(&mut b);
    b.camera(Camera { aspect_ratio: 10.0 / 8.0, ..Camera::default() })
        .environment(Environment::Uniform(Color::new(0.2, 0.2, 0.3)))
        .renderer(common::pt(2, 5, 3, true));
    b.build().unwrap()
}

/// |a − b| in units in the last place (for finite values of one sign, as radiance is).
fn ulps(a: f32, b: f32) -> u32 {
    if a == b {
        return 0;
    }
    assert!(a >= 0.0 && b >= 0.0, "{a} {b}");
    a.to_bits().abs_diff(b.to_bits())
}

fn assert_within_2_ulp(got: &HdrImage, want: &HdrImage, what: &str) {
    for (i, (g, w)) in got.pixels().iter().zip(want.pixels()).enumerate() {
        let worst = ulps(g.r, w.r).max(ulps(g.g, w.g)).max(ulps(g.b, w.b));
        assert!(worst <= 2, "{what}: pixel {i}: {g:?} vs {w:?} ({worst} ulp)");
    }
}

/// The shards of `total` samples in `count` parts, rendered by `render`, merged in the
/// given order of shard indices.
fn merged(
    count: u32,
    total: u32,
    order: &[u32],
    render: &dyn Fn(SampleRange) -> HdrImage,
) -> (HdrImage, RenderMetadata) {
    let parts: Vec<(PathBuf, HdrImage, RenderMetadata)> = order
        .iter()
        .map(|&i| {
            let r = SampleRange::shard(i, count, total).unwrap();
            let meta = RenderMetadata::new(r, "same inputs".into(), "test", 0.0);
            (PathBuf::from(format!("shard{i}.exr")), render(r), meta)
        })
        .collect();
    merge(&parts).unwrap()
}

fn orders(count: u32) -> Vec<Vec<u32>> {
    let forward: Vec<u32> = (0..count).collect();
    let mut backward = forward.clone();
    backward.reverse();
    // Odd indices first, then even ones.
    let mut mixed: Vec<u32> = forward.iter().copied().filter(|i| i % 2 == 1).collect();
    mixed.extend(forward.iter().copied().filter(|i| i % 2 == 0));
    vec![forward, backward, mixed]
}

#[test]
fn cpu_shards_merge_into_the_one_render_image() {
    let scene = scene();
    // 14 samples: jittered (not a square); 16: 4 × 4 strata, which every shard keeps.
    for total in [14u32, 16] {
        let opts = |samples| RenderOptions { spp: Some(total), samples };
        let whole = lumen::cpu::render(&scene, &opts(None), Progress::Hidden).image;
        let render = |r: SampleRange| lumen::cpu::render(&scene, &opts(Some(r)), Progress::Hidden).image;
        for count in [1u32, 2, 3, 7] {
            for order in orders(count) {
                let (img, meta) = merged(count, total, &order, &render);
                assert_eq!(meta.ranges, [SampleRange::all(total)]);
                assert_within_2_ulp(&img, &whole, &format!("CPU, {total} spp in {count} shards, order {order:?}"));
            }
        }
    }
}

#[test]
fn gpu_shards_merge_into_the_one_render_image() {
    let Some(gpu) = gpu_for_tests("gpu_shards_merge") else { return };
    let scene = scene();
    let total = 14;
    let opts = |samples| GpuRenderOptions { spp: Some(total), samples, ..GpuRenderOptions::default() };
    let whole = render(&gpu, &scene, &opts(None)).unwrap();
    assert_eq!(whole.spp_done, total);
    let run = |r: SampleRange| {
        let out = render(&gpu, &scene, &opts(Some(r))).unwrap();
        assert_eq!((out.spp_done, out.spp_requested), (r.len(), r.len()));
        out.image
    };
    for count in [1u32, 2, 3, 7] {
        let (img, _) = merged(count, total, &orders(count)[2], &run);
        assert_within_2_ulp(&img, &whole.image, &format!("GPU, {count} shards"));
    }
    // A GPU shard and CPU shards of one render merge too (within the devices' agreement).
    let cpu_part = |r: SampleRange| {
        lumen::cpu::render(&scene, &RenderOptions { spp: Some(total), samples: Some(r) }, Progress::Hidden).image
    };
    let mixed = |r: SampleRange| if r.begin == 0 { run(r) } else { cpu_part(r) };
    let (img, _) = merged(3, total, &[0, 1, 2], &mixed);
    common::agreement(&img, &whole.image).check(common::Tolerance::share(0.97)).unwrap();
}

// ---------------------------------------------------------------- the command line

fn lumen(dir: &Path, args: &[&str]) -> std::process::Output {
    common::lumen_command().current_dir(dir).args(args).output().unwrap()
}

fn ok(dir: &Path, args: &[&str]) {
    let o = lumen(dir, args);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

/// Fails with one error line naming `names`, writes no `out.exr`, never panics.
fn refused(dir: &Path, args: &[&str], names: &str) {
    let o = lumen(dir, args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{args:?} succeeded: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert!(err.contains(names), "{args:?}: {err} does not name {names}");
    assert!(!dir.join("out.exr").exists(), "{args:?} wrote out.exr");
}

#[test]
fn the_cli_renders_shards_merges_them_and_refuses_parts_that_do_not_belong() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("tiny.sl"), common::TINY_SKY_SL).unwrap();
    let render = ["render", "tiny.sl", "--device", "cpu", "--width", "12", "--spp", "9"];
    ok(d, &[&render[..], &["-o", "whole.exr"]].concat());
    for i in 0..3 {
        let (shard, out) = (format!("{i}/3"), format!("p{i}.exr"));
        ok(d, &[&render[..], &["--shard", &shard, "-o", &out]].concat());
    }
    ok(d, &[&render[..], &["--samples", "0:4", "-o", "a.exr"]].concat());
    ok(d, &[&render[..], &["--samples", "4:9", "-o", "b.exr"]].concat());
    ok(d, &["merge", "-o", "m.exr", "p2.exr", "p0.exr", "p1.exr"]);
    ok(d, &["merge", "-o", "ab.exr", "b.exr", "a.exr"]);
    // A merge of merges: p0 + p1, then with p2.
    ok(d, &["merge", "-o", "m01.exr", "p0.exr", "p1.exr"]);
    ok(d, &["merge", "-o", "mm.exr", "m01.exr", "p2.exr"]);
    let whole = lumen::image::read_image(&d.join("whole.exr")).unwrap();
    for f in ["m.exr", "ab.exr", "mm.exr"] {
        let (img, meta) = lumen::image::read_render_part(&d.join(f)).unwrap();
        assert_eq!(meta.ranges, [SampleRange::all(9)], "{f}");
        assert_within_2_ulp(&img, &whole, f);
    }
    // A gap is reported, and the mean of what is there written.
    let o = lumen(d, &["merge", "-o", "gap.exr", "p0.exr", "p2.exr"]);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stderr).contains("samples 3:6 are missing"));

    // Parts that do not belong together.
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "a.exr"], "overlap");
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "p0.exr"], "overlap");
    ok(d, &["render", "tiny.sl", "--device", "cpu", "--width", "13", "--spp", "9", "--shard", "1/3", "-o", "w13.exr"]);
    // Another size is named as such (the fingerprint, which also covers it, says less).
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "w13.exr"], "w13.exr: 13×");
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "w13.exr"], "pixels, but p0.exr has 12×");
    ok(d, &["render", "tiny.sl", "--device", "cpu", "--width", "12", "--spp", "16", "--shard", "1/3", "-o", "s16.exr"]);
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "s16.exr"], "s16.exr: rendered from other inputs");
    ok(d, &["tonemap", "whole.exr", "plain.exr"]);
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "plain.exr"], "plain.exr: not written by lumen render");
    ok(d, &[&render[..], &["--shard", "1/3", "-o", "p1.pfm"]].concat());
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "p1.pfm"], "p1.pfm: a PFM file cannot carry");
    let bytes = std::fs::read(d.join("p1.exr")).unwrap();
    std::fs::write(d.join("cut.exr"), &bytes[..bytes.len() / 2]).unwrap();
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "cut.exr"], "cut.exr");
    refused(d, &["merge", "-o", "out.exr", "p0.exr", "missing.exr"], "missing.exr");
    refused(d, &["merge", "-o", "out.pfm", "p0.exr"], "must be .exr");

    // With --frames, --shard splits the frames: shard 1 of 2 of five frames is frames 4 and 5.
    ok(
        d,
        &[
            "render", "tiny.sl", "--device", "cpu", "--width", "8", "--spp", "1", "--frames", "0:1:5", "--shard",
            "1/2", "-o", "f.png",
        ],
    );
    let frames: Vec<bool> = (1..=5).map(|k| d.join(format!("f_{k:04}.png")).exists()).collect();
    assert_eq!(frames, [false, false, false, true, true]);
    refused(d, &["render", "tiny.sl", "--frames", "0:1:2", "--shard", "0/3", "-o", "out.exr"], "--shard");
    refused(d, &["render", "tiny.sl", "--frames", "0:1:2", "--samples", "0:1", "-o", "out.exr"], "--samples");

    // Bad ranges and shards: malformed ones are usage errors (exit 2, as any bad value),
    // those beyond the scene's 9 samples fail once it is loaded (exit 1).
    for (flag, value, code) in [
        ("--samples", "5:3", 2),
        ("--samples", "4:4", 2),
        ("--samples", "3", 2),
        ("--samples", "0:10", 1),
        ("--shard", "3/3", 2),
        ("--shard", "0/0", 2),
        ("--shard", "0/10", 1),
        ("--shard", "x/2", 2),
    ] {
        let o = lumen(d, &[&render[..], &[flag, value, "-o", "out.exr"]].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{flag} {value}: {err}");
        assert!(!err.contains("panicked") && err.contains(flag), "{flag} {value}: {err}");
        assert!(!d.join("out.exr").exists());
    }
}

/// `lumen merge` holds the running sums and one part, whatever the number of parts: it
/// held every part, so 256 shards of a 4K image needed 27 GB. 128 parts of 400×400 pixels
/// (1.9 MB each as f32, 246 MB together) merge into their exact mean with a peak resident
/// size under 100 MB: the child's `VmHWM`, read while it runs (its `wait4` figure would
/// include this test process's size at the spawn, which Linux counts for the child).
#[cfg(target_os = "linux")]
#[test]
fn a_merge_holds_one_part_at_a_time() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h, count) = (400, 400, 128u32);
    let mut args = vec!["merge".to_string(), "-o".into(), "out.exr".into()];
    for k in 0..count {
        // Part k: every pixel (k, 2k, 1) over one sample.
        let img = HdrImage::from_fn(w, h, |_, _| lumen::color::Rgb32::new(k as f32, 2.0 * k as f32, 1.0));
        let meta = RenderMetadata::new(SampleRange { begin: k, end: k + 1 }, "same inputs".into(), "test", 0.0);
        let name = format!("p{k}.exr");
        lumen::image::write_image_with(&dir.path().join(&name), &img, &lumen::image::ToneMap::default(), Some(&meta))
            .unwrap();
        args.push(name);
    }
    let mut child = common::lumen_command().current_dir(dir.path()).args(&args).spawn().unwrap();
    let status_file = format!("/proc/{}/status", child.id());
    // The high-water mark only grows: the last reading before the exit is the least peak.
    let mut peak_kb = 0u64;
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        let hwm = std::fs::read_to_string(&status_file).ok().and_then(|t| {
            let line = t.lines().find(|l| l.starts_with("VmHWM:"))?.to_string();
            line.split_whitespace().nth(1)?.parse::<u64>().ok()
        });
        peak_kb = peak_kb.max(hwm.unwrap_or(0));
        std::thread::sleep(std::time::Duration::from_millis(2));
    };
    assert!(status.success());
    let peak_mb = peak_kb as f64 / 1024.0;
    assert!(peak_mb > 0.0 && peak_mb < 100.0, "peak resident size {peak_mb:.0} MB");
    let (img, meta) = lumen::image::read_render_part(&dir.path().join("out.exr")).unwrap();
    assert_eq!(meta.ranges, [SampleRange::all(count)]);
    // The mean of k over 0..128 is 63.5, exact in f32.
    assert!(img.pixels().iter().all(|p| (p.r, p.g, p.b) == (63.5, 127.0, 1.0)), "{:?}", img.pixels()[0]);
}
