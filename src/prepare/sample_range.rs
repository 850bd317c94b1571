//! Which camera samples of a pixel's streams a render takes: `[begin, end)` of the
//! scene's sample layout. Renders of disjoint ranges of one layout are exact shards of the
//! render of their union (every (pixel, sample) draws the same numbers wherever it is
//! rendered), which is what `lumen render --samples/--shard` and `lumen merge` rely on.

use std::fmt;

/// Camera samples `[begin, end)` of every pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SampleRange {
    /// Index of the first camera sample taken in each pixel.
    pub begin: u32,
    /// Index one past the last camera sample taken (exclusive).
    pub end: u32,
}

/// Why a sample range or a shard cannot be had.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SampleRangeError {
    /// The text given for a sample range (`--samples`) is not `A:B` with A < B.
    #[error("{0:?} is not a sample range: expected A:B with whole numbers 0 ≤ A < B")]
    Syntax(String),
    /// The text given for a shard (`--shard`) is not `I/N` with I < N.
    #[error("{0:?} is not a shard: expected I/N with whole numbers 0 ≤ I < N")]
    ShardSyntax(String),
    /// The render has fewer samples per pixel than shards, so some shard would take none.
    #[error("shard {index}/{count} of {total} samples per pixel is empty (use at most {total} shards)")]
    EmptyShard {
        /// The shard asked for, from 0.
        index: u32,
        /// Number of shards the samples are split into.
        count: u32,
        /// Samples per pixel of the whole render.
        total: u32,
    },
    /// The range asked for ends past the samples per pixel of the scene's layout.
    #[error("samples {range} lie beyond the render's {total} samples per pixel")]
    Beyond {
        /// The range asked for.
        range: SampleRange,
        /// Samples per pixel of the whole render.
        total: u32,
    },
}

impl SampleRange {
    /// All `total` samples.
    pub fn all(total: u32) -> Self {
        Self { begin: 0, end: total }
    }

    /// Samples per pixel in the range.
    pub fn len(&self) -> u32 {
        self.end - self.begin
    }

    /// Whether the range holds no sample.
    pub fn is_empty(&self) -> bool {
        self.end <= self.begin
    }

    /// Parses `A:B` (0 ≤ A < B).
    ///
    /// ```
    /// use lumen::prepare::SampleRange;
    /// assert_eq!(SampleRange::parse("16:64").unwrap(), SampleRange { begin: 16, end: 64 });
    /// assert!(SampleRange::parse("5:3").is_err() && SampleRange::parse("4").is_err());
    /// ```
    pub fn parse(s: &str) -> Result<Self, SampleRangeError> {
        let bad = || SampleRangeError::Syntax(s.to_string());
        let (a, b) = s.split_once(':').ok_or_else(bad)?;
        let (begin, end) = (a.trim().parse::<u32>().map_err(|_| bad())?, b.trim().parse::<u32>().map_err(|_| bad())?);
        if begin >= end {
            return Err(bad());
        }
        Ok(Self { begin, end })
    }

    /// Shard `index` of `count` contiguous, nearly equal ranges covering `[0, total)`
    /// (the first `total mod count` shards are one sample longer). Every shard is non-empty:
    /// more shards than samples is an error, as is a shard that is not `0 ≤ index < count`.
    ///
    /// ```
    /// use lumen::prepare::{SampleRange, SampleRangeError};
    /// let shards: Vec<_> = (0..3).map(|i| SampleRange::shard(i, 3, 10).unwrap()).collect();
    /// assert_eq!(shards.iter().map(|r| (r.begin, r.end)).collect::<Vec<_>>(), [(0, 4), (4, 7), (7, 10)]);
    /// assert_eq!(SampleRange::shard(0, 11, 10), Err(SampleRangeError::EmptyShard { index: 0, count: 11, total: 10 }));
    /// assert_eq!(SampleRange::shard(3, 3, 10), Err(SampleRangeError::ShardSyntax("3/3".into())));
    /// ```
    pub fn shard(index: u32, count: u32, total: u32) -> Result<Self, SampleRangeError> {
        if count == 0 || index >= count {
            return Err(SampleRangeError::ShardSyntax(format!("{index}/{count}")));
        }
        if count > total {
            return Err(SampleRangeError::EmptyShard { index, count, total });
        }
        let (base, extra) = (total / count, total % count);
        let begin = index * base + index.min(extra);
        let end = begin + base + u32::from(index < extra);
        Ok(Self { begin, end })
    }

    /// Parses a shard `I/N` (0 ≤ I < N) into `(I, N)`.
    pub fn parse_shard(s: &str) -> Result<(u32, u32), SampleRangeError> {
        let bad = || SampleRangeError::ShardSyntax(s.to_string());
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (i, n) = (i.trim().parse::<u32>().map_err(|_| bad())?, n.trim().parse::<u32>().map_err(|_| bad())?);
        if i >= n {
            return Err(bad());
        }
        Ok((i, n))
    }

    /// This range, checked to lie within a layout of `total` samples.
    pub fn within(self, total: u32) -> Result<Self, SampleRangeError> {
        if self.end > total {
            return Err(SampleRangeError::Beyond { range: self, total });
        }
        Ok(self)
    }
}

impl fmt::Display for SampleRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.begin, self.end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_tile_the_range_without_gaps_or_overlaps() {
        for total in [1u32, 2, 7, 10, 64, 1000] {
            for count in 1..=total.min(9) {
                let mut next = 0;
                for i in 0..count {
                    let r = SampleRange::shard(i, count, total).unwrap();
                    assert_eq!(r.begin, next);
                    assert!(!r.is_empty());
                    assert!(r.len() == total / count || r.len() == total / count + 1);
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
        assert!(SampleRange::shard(0, 5, 4).is_err());
        assert!(SampleRange::shard(3, 3, 9).is_err());
        assert!(SampleRange::shard(0, 0, 9).is_err());
    }

    #[test]
    fn parsing_refuses_what_is_not_a_range() {
        for bad in ["", ":", "3:", ":4", "4:4", "5:3", "-1:3", "a:b", "1:2:3", "4294967296:4294967297"] {
            assert!(SampleRange::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(SampleRange::parse("0:1").unwrap().len(), 1);
        assert_eq!(SampleRange::parse_shard("2/7").unwrap(), (2, 7));
        for bad in ["", "1", "3/3", "4/3", "0/0", "a/2", "1/2/3", "-1/2"] {
            assert!(SampleRange::parse_shard(bad).is_err(), "{bad}");
        }
        assert!(SampleRange::parse("8:17").unwrap().within(16).is_err());
        assert_eq!(SampleRange::parse("8:16").unwrap().to_string(), "8:16");
    }
}
