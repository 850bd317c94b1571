//! Image files end to end: the public `lumen::image` API and the `lumen tonemap` binary.
//! Expected values are hand-built bytes and hand-computed numbers, never files written by
//! the code under test and read back as the reference.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lumen::color::Rgb32;
use lumen::image::{is_hdr_path, read_image, write_image, HdrImage, ImageError, ToneMap};

/// Hand-built little-endian PFM: `width × height` pixels given top row first; the file
/// stores rows bottom to top.
fn pfm_bytes(width: usize, height: usize, top_first: &[[f32; 3]]) -> Vec<u8> {
    let mut out = format!("PF\n{width} {height}\n-1.0\n").into_bytes();
    for row in top_first.chunks(width).rev() {
        for px in row {
            for v in px {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    out
}

/// Raytracer.jl's 3×2 test image: (1,2,3), (4,5,6), …, (16,17,18), top row first.
fn raytracer_pixels() -> Vec<[f32; 3]> {
    (0..6).map(|i| [3.0 * i as f32 + 1.0, 3.0 * i as f32 + 2.0, 3.0 * i as f32 + 3.0]).collect()
}

fn lumen_with(input: &Path, output: &Path, opts: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumen"))
        .arg("tonemap")
        .arg(input)
        .arg(output)
        .args(opts)
        .output()
        .expect("run lumen")
}

fn lumen(input: &Path, output: &Path) -> Output {
    lumen_with(input, output, &[])
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn png_rgb8(path: &Path) -> Vec<u8> {
    image::open(path).expect("decode png").into_rgb8().into_raw()
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    v.sort();
    v
}

#[test]
fn api_reads_hand_built_pfm_top_row_first() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("in.pfm");
    std::fs::write(&path, pfm_bytes(3, 2, &raytracer_pixels())).unwrap();
    let img = read_image(&path).unwrap();
    assert_eq!((img.width(), img.height()), (3, 2));
    assert_eq!(img[(0, 0)], Rgb32::new(1.0, 2.0, 3.0));
    assert_eq!(img[(2, 1)], Rgb32::new(16.0, 17.0, 18.0));
}

#[test]
fn api_round_trips_pfm_and_exr_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let img = HdrImage::from_fn(7, 5, |c, r| Rgb32::new(c as f32 * 1e-3, (r * r) as f32 * 1e4, -0.5 + c as f32));
    for name in ["x.pfm", "x.EXR"] {
        let path = dir.path().join(name);
        assert!(is_hdr_path(&path));
        let report = write_image(&path, &img, &ToneMap::default()).unwrap();
        assert_eq!(report.non_finite, 0);
        assert_eq!(read_image(&path).unwrap(), img, "{name}");
    }
    assert_eq!(files_in(dir.path()).len(), 2, "no temporary files left");
}

#[test]
fn api_errors_carry_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("short.pfm");
    let mut bytes = pfm_bytes(3, 2, &raytracer_pixels());
    bytes.truncate(bytes.len() - 5);
    std::fs::write(&path, bytes).unwrap();
    match read_image(&path) {
        Err(e @ ImageError::Pfm { .. }) => {
            assert_eq!(e.path(), path);
            let msg = e.to_string();
            assert!(msg.contains("short.pfm") && msg.contains("67 bytes") && msg.contains("72"), "{msg}");
        }
        other => panic!("expected a PFM error, got {other:?}"),
    }
}

#[test]
fn tonemap_pfm_to_png_reproduces_raytracer_jl() {
    let dir = tempfile::tempdir().unwrap();
    let (input, output) = (dir.path().join("in.pfm"), dir.path().join("out.png"));
    std::fs::write(&input, pfm_bytes(3, 2, &raytracer_pixels())).unwrap();
    let o = lumen_with(&input, &output, &["--curve", "reinhard", "--alpha", "1", "--gamma", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
    let rgb = png_rgb8(&output);
    assert_eq!(rgb.len(), 18);
    // Raytracer.jl's first pixel after clamp, (0.11485995, 0.20605269, 0.28021002), × 255.
    assert_eq!(&rgb[..3], &[29, 53, 71]);
}

#[test]
fn tonemap_default_is_aces_srgb() {
    let dir = tempfile::tempdir().unwrap();
    let (input, output) = (dir.path().join("in.pfm"), dir.path().join("OUT.PNG"));
    std::fs::write(&input, pfm_bytes(2, 1, &[[1.0, 0.25, 4.0], [0.5, 0.0, 1e9]])).unwrap();
    let o = lumen(&input, &output);
    assert!(o.status.success(), "{}", stderr(&o));
    // Narkowicz(x) then sRGB, by hand: 1 → 0.80380 → 0.90823 → 232; 0.25 → 165; 4 → 252;
    // 0.5 → 206; 0 → 0; 1e9 → 1 → 255.
    assert_eq!(png_rgb8(&output), vec![232, 165, 252, 206, 0, 255]);
}

#[test]
fn tonemap_exposure_curve_and_jpeg_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.pfm");
    std::fs::write(&input, pfm_bytes(1, 1, &[[0.25, 1.0, 0.25]])).unwrap();
    let png = dir.path().join("e.png");
    let o = lumen_with(&input, &png, &["--curve", "exposure", "--exposure", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // 2 × 0.25 = 0.5 → sRGB 0.73536 → 188; 2 × 1 clips to 1 → 255.
    assert_eq!(png_rgb8(&png), vec![188, 255, 188]);
    let jpg = dir.path().join("e.jpeg");
    let o = lumen_with(&input, &jpg, &["--curve", "exposure", "--exposure", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = read_image(&jpg).unwrap();
    assert_eq!((back.width(), back.height()), (1, 1));
}

#[test]
fn tonemap_converts_between_hdr_formats() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.pfm");
    std::fs::write(&input, pfm_bytes(3, 2, &raytracer_pixels())).unwrap();
    let exr = dir.path().join("mid.exr");
    let o = lumen(&input, &exr);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = read_image(&exr).unwrap();
    assert_eq!(img[(1, 0)], Rgb32::new(4.0, 5.0, 6.0));
    let hdr = dir.path().join("mid.hdr");
    let o = lumen(&exr, &hdr);
    assert!(o.status.success(), "{}", stderr(&o));
    // 16, 17, 18 share one RGBE exponent (2^5): 8-bit mantissas are exact for integers < 32.
    assert_eq!(read_image(&hdr).unwrap()[(2, 1)], Rgb32::new(16.0, 17.0, 18.0));
    // Tone-mapping options make no sense for a linear output.
    let o = lumen_with(&input, &dir.path().join("x.pfm"), &["--curve", "aces"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("x.pfm"), "{}", stderr(&o));
}

#[test]
fn unknown_output_extension_fails_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.pfm");
    std::fs::write(&input, pfm_bytes(3, 2, &raytracer_pixels())).unwrap();
    let output = dir.path().join("out.tiff");
    let o = lumen(&input, &output);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("out.tiff") && err.contains(".tiff") && err.contains(".png"), "{err}");
    assert_eq!(files_in(dir.path()), vec![input], "no output and no temporary file");
}

#[test]
fn corrupt_input_fails_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.png");
    for (name, bytes) in [
        ("bad.pfm", b"PF\n3 2\n-1.0\n\x00\x00".to_vec()),
        ("bad.exr", b"v/1\x01garbage".to_vec()),
        ("bad.png", b"\x89PNG\r\n\x1a\n\x00".to_vec()),
        ("bad.hdr", b"#?RADIANCE\n".to_vec()),
    ] {
        let input = dir.path().join(name);
        std::fs::write(&input, bytes).unwrap();
        let o = lumen(&input, &output);
        assert_eq!(o.status.code(), Some(1), "{name}");
        let err = stderr(&o);
        assert!(err.contains(&*input.to_string_lossy()), "{name}: {err}");
        assert_eq!(err.lines().count(), 1, "one line: {err}");
        assert!(!output.exists());
    }
    let o = lumen(&dir.path().join("missing.pfm"), &output);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("missing.pfm"));
}

#[test]
fn non_finite_pixels_warn_once_and_come_out_black() {
    let dir = tempfile::tempdir().unwrap();
    let (input, output) = (dir.path().join("in.pfm"), dir.path().join("out.png"));
    let px = [[f32::NAN, 1.0, 1.0], [f32::INFINITY; 3], [1.0, 1.0, 1.0]];
    std::fs::write(&input, pfm_bytes(3, 1, &px)).unwrap();
    let o = lumen(&input, &output);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(err.matches("warning").count(), 1, "{err}");
    assert!(err.contains("2 of 3 pixels"), "{err}");
    assert_eq!(png_rgb8(&output), vec![0, 0, 0, 0, 0, 0, 232, 232, 232]);
}

#[test]
fn invalid_options_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.pfm");
    std::fs::write(&input, pfm_bytes(1, 1, &[[1.0; 3]])).unwrap();
    let output = dir.path().join("o.png");
    // A bad value is a usage error (clap, exit 2); a misplaced option is a run error (exit 1).
    let o = lumen_with(&input, &output, &["--curve", "reinhard", "--alpha", "-1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = lumen_with(&input, &output, &["--alpha", "0.5"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("reinhard"));
    assert!(!output.exists());
}

/// A hand-built run-length Radiance file of `width × height` pixels, all of one RGBE
/// value `rgbe`.
fn radiance_rle_bytes(width: usize, height: usize, rgbe: [u8; 4]) -> Vec<u8> {
    let mut out = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n").into_bytes();
    for _ in 0..height {
        out.extend_from_slice(&[2, 2, (width >> 8) as u8, (width & 0xff) as u8]);
        for value in rgbe {
            let mut left = width;
            while left > 0 {
                let run = left.min(127);
                out.extend_from_slice(&[128 + run as u8, value]);
                left -= run;
            }
        }
    }
    out
}

/// Images within lumen's limits (2¹⁶ per side, 2²⁸ pixels) are read whatever the `image`
/// crate's own cap (512 MiB per decode) would say: a 16384×8192 HDRI sky, 1.5 GiB as f32,
/// was refused with "Memory limit exceeded", though `lumen tonemap` writes such files.
/// Here 7,000² pixels (588 MB as f32) decode and read right; sizes past lumen's limits are
/// refused with those limits, from the header alone.
#[test]
fn images_within_lumens_limits_are_read_whatever_their_decoded_size() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.hdr");
    // RGBE (128, 64, 32, 129): mantissas over 256 times 2^(129 - 128).
    std::fs::write(&big, radiance_rle_bytes(7000, 7000, [128, 64, 32, 129])).unwrap();
    let img = read_image(&big).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((img.width(), img.height()), (7000, 7000));
    for p in [img.pixels()[0], img.pixels()[7000 * 7000 - 1]] {
        let want = [1.0, 0.5, 0.25];
        for (got, want) in [p.r, p.g, p.b].into_iter().zip(want) {
            assert!((got - want).abs() <= want * 0.01, "{p:?}");
        }
    }
    drop(img);
    let wide = dir.path().join("wide.hdr");
    std::fs::write(&wide, radiance_rle_bytes(1 << 17, 1, [1, 1, 1, 128])).unwrap();
    let e = read_image(&wide).unwrap_err().to_string();
    assert!(e.contains("image size 131072×1 is too large (at most 65536 per side"), "{e}");
}

/// A Radiance file as wide as a run-length scanline cannot describe (32768: its marker
/// holds the width in 15 bits) is written flat, 4 bytes a pixel; it was written with a
/// marker that readers take for a pixel, and reading it failed with "the file ends early".
#[test]
fn radiance_files_past_the_run_length_width_are_written_flat() {
    let dir = tempfile::tempdir().unwrap();
    // (1, 0.5, 0.25) is RGBE (128, 64, 32, 129); 1000 = 250/256·2¹⁰ is (250, 250, 250, 138).
    let pixel = |c: usize| if c % 3 == 0 { [1.0, 0.5, 0.25] } else { [1000.0; 3] };
    let rgbe = |c: usize| if c % 3 == 0 { [128, 64, 32, 129] } else { [250, 250, 250, 138] };
    for width in [32767, 32768, 32769] {
        let input = dir.path().join(format!("w{width}.pfm"));
        let output = dir.path().join(format!("w{width}.hdr"));
        std::fs::write(&input, pfm_bytes(width, 1, &(0..width).map(pixel).collect::<Vec<_>>())).unwrap();
        let o = lumen(&input, &output);
        assert!(o.status.success(), "{width}: {}", stderr(&o));
        let img = read_image(&output).unwrap_or_else(|e| panic!("{width}: {e}"));
        assert_eq!((img.width(), img.height()), (width, 1));
        for c in [0, 1, 2, 3, width / 2, width - 1] {
            assert_eq!(img.get(c, 0).to_array(), pixel(c), "width {width}, column {c}");
        }
        let o = lumen(&output, &dir.path().join(format!("w{width}.png")));
        assert!(o.status.success(), "{width}: {}", stderr(&o));
        if width > 32767 {
            let bytes = std::fs::read(&output).unwrap();
            let data = &bytes[bytes.len() - 4 * width..];
            let header = String::from_utf8(bytes[..bytes.len() - 4 * width].to_vec()).unwrap();
            assert!(header.ends_with(&format!("\n\n-Y 1 +X {width}\n")), "{header}");
            assert!(data.chunks(4).enumerate().all(|(c, p)| p == rgbe(c)), "width {width}: not flat RGBE");
        }
    }
}

/// A JPEG holds at most 65535 pixels a side: a wider image is refused in one line that
/// names the limit, not with the encoder's two-line "Format error encoding Jpeg:".
#[test]
fn jpeg_output_past_65535_pixels_a_side_is_refused_in_words() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("wide.pfm");
    std::fs::write(&input, pfm_bytes(65536, 1, &vec![[0.5; 3]; 65536])).unwrap();
    let output = dir.path().join("wide.jpg");
    let o = lumen(&input, &output);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("wide.jpg") && err.contains("65536×1 is too large for JPEG (at most 65535"), "{err}");
    assert_eq!(files_in(dir.path()), vec![input]);
}

/// Decoders' messages are said as what they mean, in one line and never in Rust's debug
/// form.
#[test]
fn decoder_messages_are_words() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.pfm");
    // A PNG with one chunk, IHDR, then one whose name is not a PNG chunk's (byte 40 of a
    // PNG whose IDAT follows IHDR).
    let mut png = b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x02\x00\x00\x00".to_vec();
    png.extend_from_slice(&[0x90, 0x77, 0x53, 0xde]); // IHDR's CRC
    png.extend_from_slice(b"\x00\x00\x00\x00IDA\xab\x00\x00\x00\x00");
    for (name, bytes, says) in [
        (
            "cut.hdr",
            b"#?RADIANCE\nFORMAT=32".to_vec(),
            "the file ends early (cut short, or not a whole Radiance HDR file)",
        ),
        ("cut2.hdr", b"#?RADIANCE\n# Rust HD".to_vec(), "the file ends early"),
        ("bad.png", png, "an unknown critical chunk \"IDA\\xAB\""),
    ] {
        let input = dir.path().join(name);
        std::fs::write(&input, bytes).unwrap();
        let o = lumen(&input, &output);
        assert_eq!(o.status.code(), Some(1), "{name}");
        let err = stderr(&o);
        assert!(err.contains(says) && err.lines().count() == 1, "{name}: {err}");
    }
}

/// `--alpha 1e39` is finite, but past f32's range: it was "expected a finite number".
#[test]
fn option_values_past_f32s_range_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.pfm");
    std::fs::write(&input, pfm_bytes(1, 1, &[[1.0; 3]])).unwrap();
    for value in ["1e39", "3.5e38", "1e300"] {
        let o = lumen_with(&input, &dir.path().join("o.png"), &["--curve", "reinhard", "--alpha", value]);
        assert_eq!(o.status.code(), Some(2), "{value}");
        let err = stderr(&o);
        assert!(err.contains(&format!("{value} is too large")) && err.contains("at most 3.4e38"), "{value}: {err}");
    }
}
