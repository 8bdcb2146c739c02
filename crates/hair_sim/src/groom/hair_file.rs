//! Cem Yuksel's `.hair` files (<http://www.cemyuksel.com/research/hairmodels/>), the
//! exchange format of published hair models: a 128-byte header, then per-strand segment
//! counts and per-point positions (and optionally thickness, transparency and colour, which
//! are read past and not kept). Little-endian throughout.
//!
//! Reading checks every count against the file's length before allocating anything, so a
//! truncated or hostile file is an error, never a panic or an allocation of the claimed size.

use crate::math::Vec3;
use std::fmt;

const MAGIC: &[u8; 4] = b"HAIR";
const HEADER: usize = 128;
/// Header flags: which arrays follow.
const HAS_SEGMENTS: u32 = 1 << 0;
const HAS_POINTS: u32 = 1 << 1;
const HAS_THICKNESS: u32 = 1 << 2;
const HAS_TRANSPARENCY: u32 = 1 << 3;
const HAS_COLOR: u32 = 1 << 4;
/// Bytes of the header's free-text field.
const INFO: usize = 88;

/// Why a `.hair` file cannot be read or written.
#[derive(Clone, Debug, PartialEq)]
pub enum HairFileError {
    /// Shorter than the 128-byte header.
    NoHeader {
        /// Bytes given.
        bytes: usize,
    },
    /// The file does not start with `HAIR`.
    Magic([u8; 4]),
    /// The file has no point array: nothing to read.
    NoPoints,
    /// The header's counts disagree with each other (the segments add up to another number
    /// of points than the header says).
    Counts {
        /// Points the header announces.
        points: u64,
        /// Points the segment counts add up to.
        from_segments: u64,
    },
    /// The file ends before the arrays its header announces.
    Truncated {
        /// Bytes the header asks for.
        needed: u64,
        /// Bytes there are.
        bytes: usize,
    },
    /// A point is NaN or infinite.
    NonFinite {
        /// Its index.
        point: usize,
    },
    /// A strand to write has fewer than 2 points or more than 65,536 (the format counts
    /// segments in 16 bits).
    StrandLength {
        /// The strand.
        strand: usize,
        /// Its points.
        points: usize,
    },
}

impl fmt::Display for HairFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HairFileError::NoHeader { bytes } => {
                write!(f, "a .hair file needs a 128-byte header; this has {bytes} bytes")
            }
            HairFileError::Magic(m) => write!(f, "not a .hair file: it starts with {m:?}, not \"HAIR\""),
            HairFileError::NoPoints => write!(f, "the .hair file has no point array"),
            HairFileError::Counts { points, from_segments } => write!(
                f,
                "the .hair header announces {points} points but its strands' segments add up to {from_segments}"
            ),
            HairFileError::Truncated { needed, bytes } => {
                write!(f, "the .hair file is {bytes} bytes, but its header announces {needed}")
            }
            HairFileError::NonFinite { point } => write!(f, "point {point} of the .hair file is NaN or infinite"),
            HairFileError::StrandLength { strand, points } => {
                write!(f, "strand {strand} has {points} points; a .hair strand has 2 to 65,536")
            }
        }
    }
}

impl std::error::Error for HairFileError {}

/// A hair model read from a `.hair` file: strands as polylines, and the header's text.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HairFile {
    /// Each strand's points, root first, in the file's units and axes.
    pub strands: Vec<Vec<Vec3>>,
    /// The header's free text (up to 88 bytes, NUL-padded in the file).
    pub info: String,
}

/// Little-endian reader over a byte slice whose length is already checked.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn u32(&mut self) -> u32 {
        let v = u32::from_le_bytes(self.bytes[self.at..self.at + 4].try_into().expect("4 bytes"));
        self.at += 4;
        v
    }

    fn f32(&mut self) -> f32 {
        f32::from_bits(self.u32())
    }

    fn u16(&mut self) -> u16 {
        let v = u16::from_le_bytes(self.bytes[self.at..self.at + 2].try_into().expect("2 bytes"));
        self.at += 2;
        v
    }
}

impl HairFile {
    /// Reads a `.hair` file.
    pub fn read(bytes: &[u8]) -> Result<HairFile, HairFileError> {
        if bytes.len() < HEADER {
            return Err(HairFileError::NoHeader { bytes: bytes.len() });
        }
        let magic: [u8; 4] = bytes[..4].try_into().expect("4 bytes");
        if &magic != MAGIC {
            return Err(HairFileError::Magic(magic));
        }
        let mut header = Cursor { bytes, at: 4 };
        let (strands, points, flags, default_segments) =
            (header.u32() as u64, header.u32() as u64, header.u32(), header.u32() as u64);
        if flags & HAS_POINTS == 0 {
            return Err(HairFileError::NoPoints);
        }
        // Every array's size, in u64: no count can overflow it.
        let per_point: u64 = 12
            + if flags & HAS_THICKNESS != 0 { 4 } else { 0 }
            + if flags & HAS_TRANSPARENCY != 0 { 4 } else { 0 }
            + if flags & HAS_COLOR != 0 { 12 } else { 0 };
        let segment_bytes = if flags & HAS_SEGMENTS != 0 { 2 * strands } else { 0 };
        let needed = HEADER as u64 + segment_bytes + per_point * points;
        if (bytes.len() as u64) < needed {
            return Err(HairFileError::Truncated { needed, bytes: bytes.len() });
        }
        let info_bytes = &bytes[40..40 + INFO];
        let info_end = info_bytes.iter().position(|&b| b == 0).unwrap_or(INFO);
        let info = String::from_utf8_lossy(&info_bytes[..info_end]).into_owned();
        // The counts are now bounded by the file's length: safe to allocate.
        let mut cursor = Cursor { bytes, at: HEADER };
        let segments: Vec<u64> = if flags & HAS_SEGMENTS != 0 {
            (0..strands).map(|_| cursor.u16() as u64).collect()
        } else {
            vec![default_segments; strands.min(points) as usize]
        };
        let from_segments: u64 = segments.iter().map(|s| s + 1).sum();
        if from_segments != points || (flags & HAS_SEGMENTS == 0 && segments.len() as u64 != strands) {
            return Err(HairFileError::Counts { points, from_segments });
        }
        let mut all = Vec::with_capacity(points as usize);
        for point in 0..points as usize {
            let p = Vec3::new(cursor.f32(), cursor.f32(), cursor.f32());
            if !p.is_finite() {
                return Err(HairFileError::NonFinite { point });
            }
            all.push(p);
        }
        let mut rest = all.as_slice();
        let strands = segments
            .iter()
            .map(|&s| {
                let (strand, after) = rest.split_at(s as usize + 1);
                rest = after;
                strand.to_vec()
            })
            .collect();
        Ok(HairFile { strands, info })
    }

    /// Writes the strands as a `.hair` file: segment counts and points, with `info` in the
    /// header (cut to 88 bytes).
    pub fn write(&self) -> Result<Vec<u8>, HairFileError> {
        for (strand, points) in self.strands.iter().enumerate() {
            if !(2..=65_536).contains(&points.len()) {
                return Err(HairFileError::StrandLength { strand, points: points.len() });
            }
        }
        let points: usize = self.strands.iter().map(Vec::len).sum();
        let mut out = Vec::with_capacity(HEADER + 2 * self.strands.len() + 12 * points);
        out.extend_from_slice(MAGIC);
        for v in [self.strands.len() as u32, points as u32, HAS_SEGMENTS | HAS_POINTS, 0] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        // Default thickness, transparency and colour: unused, the arrays are absent.
        for v in [1.0f32, 0.0, 1.0, 1.0, 1.0] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        let mut info = [0u8; INFO];
        let text = self.info.as_bytes();
        info[..text.len().min(INFO)].copy_from_slice(&text[..text.len().min(INFO)]);
        out.extend_from_slice(&info);
        debug_assert_eq!(out.len(), HEADER);
        for strand in &self.strands {
            out.extend_from_slice(&((strand.len() - 1) as u16).to_le_bytes());
        }
        for p in self.strands.iter().flatten() {
            for c in p.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_strands() -> HairFile {
        HairFile {
            strands: vec![
                vec![Vec3::ZERO, Vec3::new(0.0, -0.01, 0.0), Vec3::new(0.001, -0.02, 0.0)],
                vec![Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.1, 0.19, 0.3)],
            ],
            info: "bevy_hair test".into(),
        }
    }

    #[test]
    fn writes_and_reads_back_the_same_points() {
        let file = two_strands();
        let bytes = file.write().unwrap();
        assert_eq!(bytes.len(), 128 + 2 * 2 + 12 * 5);
        assert_eq!(&bytes[..4], b"HAIR");
        assert_eq!(HairFile::read(&bytes).unwrap(), file);
    }

    #[test]
    fn optional_arrays_are_read_past_and_default_segments_used() {
        // No segment array (every strand 1 segment), a thickness and a colour per point.
        let mut bytes = b"HAIR".to_vec();
        for v in [2u32, 4, HAS_POINTS | HAS_THICKNESS | HAS_COLOR, 1] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.resize(HEADER, 0);
        let points = [[0.0f32, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        for p in points.iter().flatten() {
            bytes.extend_from_slice(&p.to_le_bytes());
        }
        bytes.extend_from_slice(&[0u8; 4 * 4 + 12 * 4]);
        let file = HairFile::read(&bytes).unwrap();
        assert_eq!(file.strands.len(), 2);
        assert_eq!(file.strands[1], [Vec3::X, Vec3::new(1.0, 1.0, 0.0)]);
    }

    #[test]
    fn bad_files_are_errors_without_allocating_what_they_claim() {
        let good = two_strands().write().unwrap();
        assert_eq!(HairFile::read(&good[..100]), Err(HairFileError::NoHeader { bytes: 100 }));
        let mut magic = good.clone();
        magic[..4].copy_from_slice(b"HAIZ");
        assert!(matches!(HairFile::read(&magic), Err(HairFileError::Magic(_))));
        assert!(matches!(HairFile::read(&good[..good.len() - 1]), Err(HairFileError::Truncated { .. })));
        // Counts that would overflow 32 bits or claim gigabytes: refused before allocating.
        let mut huge = good.clone();
        huge[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        huge[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(HairFile::read(&huge), Err(HairFileError::Truncated { .. })));
        let mut counts = good.clone();
        counts[8..12].copy_from_slice(&4u32.to_le_bytes());
        assert_eq!(HairFile::read(&counts), Err(HairFileError::Counts { points: 4, from_segments: 5 }));
        let mut nan = good.clone();
        nan[128 + 4 + 12..128 + 4 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(HairFile::read(&nan), Err(HairFileError::NonFinite { point: 1 }));
        let mut no_points = good;
        no_points[12..16].copy_from_slice(&HAS_SEGMENTS.to_le_bytes());
        assert_eq!(HairFile::read(&no_points), Err(HairFileError::NoPoints));
        let lone = HairFile { strands: vec![vec![Vec3::ZERO]], info: String::new() };
        assert_eq!(lone.write(), Err(HairFileError::StrandLength { strand: 0, points: 1 }));
    }
}
