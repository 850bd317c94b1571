//! `lumen merge -o OUT.exr PART.exr...`: combines renders of disjoint sample ranges of one
//! image (shards from `lumen render --samples/--shard`, on any devices and machines) into
//! the image one render of their union gives: the spp-weighted mean, in f64.
//!
//! Parts must be lumen EXR files with the same fingerprint (scene, size, settings, sample
//! layout, version) and size, and ranges that do not overlap; anything else is refused
//! with the file's name and nothing is written. Gaps in the union are reported (the result
//! is still the exact mean of the samples present). Merged files carry the union's
//! metadata, so merges can be merged again.

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;

use crate::color::Rgb32;
use crate::image::{read_render_part, write_image_with, HdrImage, ImageFormat, RenderMetadata, ToneMap};
use crate::prepare::SampleRange;

/// Arguments of `lumen merge`.
#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The merged image (.exr).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// The parts: EXR files written by `lumen render` (or by an earlier merge).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
}

/// The merge of `parts` (image and metadata, read from `paths` for messages).
pub fn merge(parts: &[(PathBuf, HdrImage, RenderMetadata)]) -> anyhow::Result<(HdrImage, RenderMetadata)> {
    let Some((first_path, first, first_meta)) = parts.first() else { bail!("nothing to merge") };
    let (w, h) = (first.width(), first.height());
    let mut ranges: Vec<(SampleRange, &PathBuf)> = Vec::new();
    for (path, img, meta) in parts {
        if meta.fingerprint != first_meta.fingerprint {
            bail!(
                "{}: rendered from other inputs than {} (fingerprint {} vs {}): a different scene, size, \
                 settings, sample layout or lumen version",
                path.display(),
                first_path.display(),
                meta.fingerprint,
                first_meta.fingerprint
            );
        }
        if (img.width(), img.height()) != (w, h) {
            bail!(
                "{}: {}×{} pixels, but {} has {w}×{h}",
                path.display(),
                img.width(),
                img.height(),
                first_path.display()
            );
        }
        ranges.extend(meta.ranges.iter().map(|r| (*r, path)));
    }
    ranges.sort_by_key(|(r, _)| (r.begin, r.end));
    for pair in ranges.windows(2) {
        let ((a, pa), (b, pb)) = (pair[0], pair[1]);
        if b.begin < a.end {
            bail!("{}: samples {b} overlap samples {a} of {}", pb.display(), pa.display());
        }
    }
    // The union, contiguous runs joined.
    let mut union: Vec<SampleRange> = Vec::new();
    for (r, _) in &ranges {
        match union.last_mut() {
            Some(last) if last.end == r.begin => last.end = r.end,
            _ => union.push(*r),
        }
    }
    let total: u64 = parts.iter().map(|(_, _, m)| m.spp()).sum();
    let mut sums = vec![[0.0f64; 3]; w * h];
    for (_, img, meta) in parts {
        let weight = meta.spp() as f64;
        for (s, p) in sums.iter_mut().zip(img.pixels()) {
            s[0] += f64::from(p.r) * weight;
            s[1] += f64::from(p.g) * weight;
            s[2] += f64::from(p.b) * weight;
        }
    }
    let n = total as f64;
    let image = HdrImage::from_fn(w, h, |x, y| {
        let s = sums[y * w + x];
        Rgb32::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32)
    });
    let mut devices: Vec<&str> = Vec::new();
    for (_, _, m) in parts {
        for d in m.device.split(" + ") {
            if !devices.contains(&d) {
                devices.push(d);
            }
        }
    }
    let meta = RenderMetadata {
        ranges: union,
        fingerprint: first_meta.fingerprint.clone(),
        device: devices.join(" + "),
        seconds: parts.iter().map(|(_, _, m)| m.seconds).sum(),
        version: first_meta.version.clone(),
    };
    Ok((image, meta))
}

/// Runs `lumen merge`.
pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    if ImageFormat::from_path(&args.output).ok() != Some(ImageFormat::Exr) {
        bail!("{}: the merged image must be .exr (it carries the sample ranges)", args.output.display());
    }
    let mut parts = Vec::new();
    for p in &args.parts {
        let (img, meta) = read_render_part(p)?;
        parts.push((p.clone(), img, meta));
    }
    let (image, meta) = merge(&parts)?;
    if meta.ranges.len() > 1 || meta.ranges[0].begin != 0 {
        let gaps: Vec<String> = std::iter::once(0)
            .chain(meta.ranges.iter().map(|r| r.end))
            .zip(meta.ranges.iter().map(|r| r.begin))
            .filter(|(a, b)| a < b)
            .map(|(a, b)| format!("{a}:{b}"))
            .collect();
        crate::diag!(
            "note: samples {} are missing from the parts; the image is the mean of {}",
            gaps.join(", "),
            meta.ranges_text()
        );
    }
    // Every image error names the file (image::ImageError).
    write_image_with(&args.output, &image, &ToneMap::default(), Some(&meta))?;
    crate::diag!(
        "merged {} part{} ({} samples per pixel: {}) into {}",
        parts.len(),
        if parts.len() == 1 { "" } else { "s" },
        meta.spp(),
        meta.ranges_text(),
        args.output.display()
    );
    Ok(())
}
