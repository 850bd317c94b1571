//! `lumen merge -o OUT.exr PART.exr...`: combines renders of disjoint sample ranges of one
//! image (shards from `lumen render --samples/--shard`, on any devices and machines) into
//! the image one render of their union gives: the spp-weighted mean, in f64.
//!
//! Parts must be lumen EXR files with the same fingerprint (scene, size, settings, sample
//! layout, version) and size, ranges that do not overlap and finite pixels (lumen writes
//! no NaN or infinity, so one means a damaged file); anything else is refused
//! with the file's name and nothing is written. Gaps in the union are reported (the result
//! is still the exact mean of the samples present). Merged files carry the union's
//! metadata, so merges can be merged again. Parts are read one at a time into running
//! sums ([`Merge`]), so memory does not grow with their number.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _};
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

/// A merge in progress. Parts are added one at a time and only their spp-weighted sums are
/// kept, so a merge holds the sums and one part whatever the number of parts: holding every
/// part, as the first version did, made 256 shards of a 4K image need 27 GB.
///
/// ```
/// use lumen::cli::merge::Merge;
/// use lumen::color::Rgb32;
/// use lumen::image::{HdrImage, RenderMetadata};
/// use lumen::prepare::SampleRange;
/// use std::path::Path;
///
/// // Samples 0:1 saw 1.0 everywhere, samples 1:4 saw 3.0: the mean of the four is 2.5.
/// let part = |v: f32, begin, end| {
///     let meta = RenderMetadata::new(SampleRange { begin, end }, "scene".into(), "cpu", 0.0);
///     (HdrImage::from_fn(2, 1, |_, _| Rgb32::new(v, v, v)), meta)
/// };
/// let mut merge = Merge::new();
/// let (a, meta_a) = part(1.0, 0, 1);
/// merge.add(Path::new("a.exr"), &a, &meta_a).unwrap();
/// let (b, meta_b) = part(3.0, 1, 4);
/// merge.add(Path::new("b.exr"), &b, &meta_b).unwrap();
/// let (image, meta) = merge.finish().unwrap();
/// assert_eq!(image.pixels()[0], Rgb32::new(2.5, 2.5, 2.5));
/// assert_eq!(meta.ranges, [SampleRange { begin: 0, end: 4 }]);
/// ```
#[derive(Debug, Default)]
pub struct Merge {
    /// The first part's path, size and metadata: every later part must match them.
    first: Option<(PathBuf, usize, usize, RenderMetadata)>,
    /// Per pixel, the sum of every part's value times its samples per pixel.
    sums: Vec<[f64; 3]>,
    /// Every part's sample ranges, with the part they came from.
    ranges: Vec<(SampleRange, PathBuf)>,
    total_spp: u64,
    devices: Vec<String>,
    seconds: f64,
}

impl Merge {
    /// An empty merge.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the part read from `path`: refused, naming `path`, where it was rendered from
    /// other inputs or has another size than the first part, or holds a NaN or infinite
    /// pixel.
    pub fn add(&mut self, path: &Path, img: &HdrImage, meta: &RenderMetadata) -> anyhow::Result<()> {
        let (w, h) = (img.width(), img.height());
        // lumen writes NaN and infinite samples as black, so such pixels mean a damaged file;
        // merged, one would poison a pixel's mean (the merged file would show it black).
        let bad = img.non_finite_count();
        if bad > 0 {
            let (pixels, are) = if bad == 1 { ("pixel", "is") } else { ("pixels", "are") };
            bail!("{}: {bad} {pixels} {are} NaN or infinite, which lumen never writes: a damaged part", path.display());
        }
        match &self.first {
            None => {
                let bytes = (w * h * std::mem::size_of::<[f64; 3]>()) as u64;
                self.sums = crate::memory::try_filled(w * h, [0.0; 3], "the merge's sums", bytes)?;
                self.first = Some((path.to_path_buf(), w, h, meta.clone()));
            }
            Some((first_path, fw, fh, first_meta)) => {
                // The size first: it is one of the inputs the fingerprint covers, and the one
                // a person can see.
                if (w, h) != (*fw, *fh) {
                    bail!("{}: {w}×{h} pixels, but {} has {fw}×{fh}", path.display(), first_path.display());
                }
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
            }
        }
        let weight = meta.spp() as f64;
        for (s, p) in self.sums.iter_mut().zip(img.pixels()) {
            s[0] += f64::from(p.r) * weight;
            s[1] += f64::from(p.g) * weight;
            s[2] += f64::from(p.b) * weight;
        }
        self.ranges.extend(meta.ranges.iter().map(|r| (*r, path.to_path_buf())));
        self.total_spp += meta.spp();
        for d in meta.device.split(" + ") {
            if !self.devices.iter().any(|known| known == d) {
                self.devices.push(d.to_string());
            }
        }
        self.seconds += meta.seconds;
        Ok(())
    }

    /// The merged image and its metadata; refused, naming both parts, where two parts'
    /// sample ranges overlap.
    pub fn finish(mut self) -> anyhow::Result<(HdrImage, RenderMetadata)> {
        let Some((_, w, h, first_meta)) = self.first.take() else { bail!("nothing to merge") };
        self.ranges.sort_by_key(|(r, _)| (r.begin, r.end));
        for pair in self.ranges.windows(2) {
            let ((a, pa), (b, pb)) = (&pair[0], &pair[1]);
            if b.begin < a.end {
                bail!("{}: samples {b} overlap samples {a} of {}", pb.display(), pa.display());
            }
        }
        // The union, contiguous runs joined.
        let mut union: Vec<SampleRange> = Vec::new();
        for (r, _) in &self.ranges {
            match union.last_mut() {
                Some(last) if last.end == r.begin => last.end = r.end,
                _ => union.push(*r),
            }
        }
        let n = self.total_spp as f64;
        let sums = &self.sums;
        let image = HdrImage::from_fn(w, h, |x, y| {
            let s = sums[y * w + x];
            Rgb32::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32)
        });
        let meta = RenderMetadata {
            ranges: union,
            fingerprint: first_meta.fingerprint,
            device: self.devices.join(" + "),
            seconds: self.seconds,
            version: first_meta.version,
        };
        Ok((image, meta))
    }
}

/// The merge of `parts` (image and metadata, with the path each was read from, for
/// messages): [`Merge`] over them in order.
pub fn merge(parts: &[(PathBuf, HdrImage, RenderMetadata)]) -> anyhow::Result<(HdrImage, RenderMetadata)> {
    let mut merge = Merge::new();
    for (path, img, meta) in parts {
        merge.add(path, img, meta)?;
    }
    merge.finish()
}

/// Runs `lumen merge`.
pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    if ImageFormat::from_path(&args.output).ok() != Some(ImageFormat::Exr) {
        bail!("{}: the merged image must be .exr (it carries the sample ranges)", args.output.display());
    }
    crate::image::check_destination(&args.output).with_context(|| format!("cannot write {}", args.output.display()))?;
    // One part in memory at a time, beside the sums.
    let mut merge = Merge::new();
    for p in &args.parts {
        let (img, meta) = read_render_part(p)?;
        merge.add(p, &img, &meta)?;
    }
    let parts = args.parts.len();
    let (image, meta) = merge.finish()?;
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
        parts,
        if parts == 1 { "" } else { "s" },
        meta.spp(),
        meta.ranges_text(),
        args.output.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A part with a NaN or infinite pixel (lumen writes none, so the file is damaged) is
    /// refused by name; the parts before it do not make a result.
    #[test]
    fn a_part_with_non_finite_pixels_is_refused() {
        let meta = |begin, end| RenderMetadata::new(SampleRange { begin, end }, "scene".into(), "cpu", 0.0);
        let good = HdrImage::from_fn(2, 2, |_, _| Rgb32::new(1.0, 1.0, 1.0));
        for bad_value in [f32::NAN, f32::INFINITY] {
            let bad =
                HdrImage::from_fn(2, 2, |x, y| Rgb32::new(if (x, y) == (1, 0) { bad_value } else { 1.0 }, 1.0, 1.0));
            let mut merge = Merge::new();
            merge.add(Path::new("a.exr"), &good, &meta(0, 1)).unwrap();
            let e = merge.add(Path::new("b.exr"), &bad, &meta(1, 2)).unwrap_err().to_string();
            assert_eq!(e, "b.exr: 1 pixel is NaN or infinite, which lumen never writes: a damaged part");
        }
    }
}
