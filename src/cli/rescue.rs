//! A render's outputs written, and the render kept when one cannot be.
//!
//! `lumen render` checks its outputs before it starts (`image::check_destination`), but
//! some failures come only at the write, hours later: the disk fills, the directory is
//! removed or unmounted meanwhile, a network share goes away. Losing the render then would
//! waste all of it, so every output is tried, and when one fails and no other holds the
//! radiance (an EXR, PFM or HDR output that was written), the image is kept as an EXR with
//! its render metadata in the temporary directory (`$TMPDIR`, else `/tmp`), and the error
//! says where and how to make the output from it (`lumen tonemap`). EXR, whatever the lost
//! output's format: it holds the linear radiance, from which `lumen tonemap` makes any
//! format with any tone mapping, and the sample range `lumen merge` needs.

use std::path::{Path, PathBuf};

use anyhow::anyhow;

use crate::image::{is_hdr_path, write_image_with, HdrImage, RenderMetadata, ToneMap};

/// Writes `image` to every path of `outputs` (each with `tm` where it is LDR, and `meta`),
/// saying `wrote PATH` for each. Where some cannot be written, the render is kept (see the
/// module documentation) in `rescue_dir` unless a written output holds its radiance; every
/// failure but the last is said at once, and the error is the last one, with where the
/// render is and how to make the lost output from it.
pub fn write_outputs(
    outputs: &[PathBuf],
    image: &HdrImage,
    tm: &ToneMap,
    meta: &RenderMetadata,
    rescue_dir: &Path,
) -> anyhow::Result<()> {
    let mut failed = Vec::new();
    let mut radiance = None;
    for o in outputs {
        match write_image_with(o, image, tm, Some(meta)) {
            Ok(_) => {
                crate::diag!("wrote {}", o.display());
                if radiance.is_none() && is_hdr_path(o) {
                    radiance = Some(o.clone());
                }
            }
            Err(e) => failed.push((o, e)),
        }
    }
    let Some((last, last_error)) = failed.pop() else { return Ok(()) };
    for (_, e) in &failed {
        // Every image error names the file (image::ImageError).
        crate::diag!("error: {e}");
    }
    let convert = |from: &Path| format!("`lumen tonemap {} {}` makes it", from.display(), last.display());
    if let Some(kept) = radiance {
        return Err(anyhow!("{last_error}; the render's radiance is in {} ({})", kept.display(), convert(&kept)));
    }
    let kept = rescue_path(rescue_dir, last);
    match write_image_with(&kept, image, tm, Some(meta)) {
        Ok(_) => Err(anyhow!("{last_error}; the render is kept in {} ({})", kept.display(), convert(&kept))),
        Err(e) => Err(anyhow!("{last_error}; the render could not be kept either ({e})")),
    }
}

/// Where the render of the lost output `output` is kept: `lumen-rescue-PID-NAME.exr` in
/// `dir`, NAME being the output's file name (a process's outputs have different paths, and
/// different names but for outputs of one name in two directories, which then share the
/// one image they would have held).
fn rescue_path(dir: &Path, output: &Path) -> PathBuf {
    let name = output.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "render".into());
    let stem = if is_hdr_path(output) && name.to_ascii_lowercase().ends_with(".exr") {
        name.clone()
    } else {
        format!("{name}.exr")
    };
    dir.join(format!("lumen-rescue-{}-{stem}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Rgb32;
    use crate::image::read_image;
    use crate::prepare::SampleRange;

    fn image() -> HdrImage {
        let mut img = HdrImage::new(3, 2);
        for (i, p) in img.pixels_mut().iter_mut().enumerate() {
            *p = Rgb32::new(i as f32, 0.5, 2.0);
        }
        img
    }

    fn meta() -> RenderMetadata {
        RenderMetadata::new(SampleRange { begin: 0, end: 4 }, "scene".into(), "cpu", 1.0)
    }

    /// The error of writing the test image to `outputs`, keeping it in `rescue_dir`.
    fn failure(outputs: &[PathBuf], rescue_dir: &Path) -> String {
        write_outputs(outputs, &image(), &ToneMap::default(), &meta(), rescue_dir).unwrap_err().to_string()
    }

    /// An output in a directory that is gone: the others are written, the render is kept
    /// as an EXR that holds its radiance, and the error says where and how to convert it.
    #[test]
    fn a_lost_output_keeps_the_render() {
        let dir = tempfile::tempdir().unwrap();
        let rescue = tempfile::tempdir().unwrap();
        let lost = dir.path().join("gone/x.png");
        let ok = dir.path().join("ok.png");
        let e = failure(&[lost.clone(), ok.clone()], rescue.path());
        assert!(ok.exists());
        let kept = rescue.path().join(format!("lumen-rescue-{}-x.png.exr", std::process::id()));
        assert_eq!(read_image(&kept).unwrap().pixels(), image().pixels());
        let said =
            format!("cannot write {}: No such file or directory (os error 2); the render is kept in ", lost.display());
        assert!(e.starts_with(&said), "{e}");
        assert!(e.ends_with(&format!("(`lumen tonemap {} {}` makes it)", kept.display(), lost.display())), "{e}");
        assert_eq!(crate::image::read_render_part(&kept).unwrap().1.spp(), 4, "the metadata is kept");
    }

    /// Where a written output holds the radiance, it is named instead of keeping a copy;
    /// where the render cannot be kept either, the error says so; all written: no error.
    #[test]
    fn a_written_hdr_output_is_the_rescue() {
        let dir = tempfile::tempdir().unwrap();
        let lost = dir.path().join("gone/x.png");
        let exr = dir.path().join("y.exr");
        let e = failure(&[lost.clone(), exr.clone()], dir.path());
        assert!(e.contains(&format!("the render's radiance is in {}", exr.display())), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no copy: only y.exr");
        let e = failure(&[lost], &dir.path().join("none"));
        assert!(e.contains("(os error 2); the render could not be kept either (cannot write "), "{e}");
        write_outputs(&[dir.path().join("z.png")], &image(), &ToneMap::default(), &meta(), dir.path()).unwrap();
        assert_eq!(
            rescue_path(Path::new("/t"), Path::new("a/b.EXR")),
            PathBuf::from(format!("/t/lumen-rescue-{}-b.EXR", std::process::id()))
        );
    }
}
