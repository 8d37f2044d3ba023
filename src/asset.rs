//! The `.mlod` asset: everything the runtime needs for one deforming object,
//! and its file format.
//!
//! It stores the two GPU poses `V(0)`, `V(1)`, the common strips `S0` and one
//! collapse sequence per sampled frame. The change lists are not stored: they
//! are a deterministic function of `S0` and a frame's sequence, and replaying
//! a sequence at load time is cheap next to the storage the change lists would
//! take (see BENCHMARKS.md for both figures).
//!
//! # File layout (version 1, all integers little-endian)
//!
//! ```text
//! header (32 bytes)  magic "\x89MLD\r\n\x1a\n" | version u16 | flags u16 (0) |
//!                    section count u32 | body length u64 | CRC-32 of the body u32 | 0 u32
//! body               section table: per section  tag [u8; 4] | 0 u32 | offset u64 | length u64
//!                    (offsets from the body's start), then the sections:
//!   "V0  ", "V1  "   the poses, raw f32 x, y, z per vertex
//!   "S0  "           index count, offset count (strips + 1), offsets as LEB128
//!                    deltas, indices as zigzag LEB128 deltas to the previous index
//!   "FRMS"           frame count, then per frame its byte length and its bytes
//!   "TGTS"           optional, only for weight animations (see [`TargetBlend`]):
//!                    interpolation u8 (0 STEP, 1 LINEAR, 2 CUBICSPLINE) | target count K
//!                    LEB128 | keyframe count N LEB128 | N f32 times | the track's f32
//!                    values (N × K, × 3 for CUBICSPLINE) | K × vertices f32 x, y, z deltas
//! ```
//!
//! The magic is PNG's trick: the high byte catches 7-bit transfers, the
//! CR LF / LF pair catches newline translation, `^Z` stops DOS `type`.
//! Sections are found through the table, so a later minor addition (an extra
//! section) is skipped by this reader; an incompatible change bumps the version.
//! "TGTS" is such an addition: a reader that predates it draws the two-pose blend.
//!
//! # Frame coding
//!
//! A frame is either `0` (the same sequence as the previous frame: animations
//! that hold a pose cost one byte per frame) or `1` followed by a bit stream.
//! Each collapse `u → w` costs
//! * `u` in a fixed width (the bits of the largest vertex index): collapse
//!   orders are close to random permutations, which no cheap model predicts;
//! * `w` as the position, in `u`'s neighbour list in `S0`, of the first
//!   neighbour whose current survivor is `w` (exp-Golomb): the collapsed
//!   vertex `w` is almost always the survivor of one of `u`'s original
//!   neighbours, so this takes a few bits instead of a vertex index. The decoder
//!   tracks survivors with a union-find, which also keeps `w` alive by
//!   construction. When no neighbour leads to `w`, an escape symbol (the
//!   neighbour count) is followed by `w` in the fixed width;
//! * the error as bfloat16 (the top 16 bits of the f32: full exponent range,
//!   8 significant bits), zigzag delta to the previous collapse's error
//!   (exp-Golomb): greedy orders make errors grow slowly.
//!
//! Both exp-Golomb orders are chosen per frame (the smallest stream) and
//! stored in the frame's first bytes. On makehuman_body (13,380 vertices,
//! 32 frames) a collapse costs 2.66 bytes: 14 bits of `u`, about 7 bits for
//! `w` and the error together (the paper's per-frame data: ~45-48 bytes per
//! vertex).
//!
//! # Validation
//!
//! [`Asset::from_bytes`] checks the magic, version, flags, body length and
//! checksum before reading anything else, then every count against the bytes
//! left before allocating, every index against the vertex count, the strip
//! offsets, every collapse (in range, alive, not onto itself: the rules of
//! [`CollapseSequence::validate`]) and every error (finite, not negative).
//! Every failure is a typed [`AssetError`]; no input panics.

use crate::collapse::{Collapse, CollapseSequence, SequenceError, NEVER};
use crate::morph::{Interpolation, MorphError, TargetBlend, WeightTrack};
use crate::strip::{strip_triangles, Strips};
use rayon::prelude::*;
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// One deforming object's LOD data, as built by the per-frame builder and
/// stored in a `.mlod` file. Frame `k` of `frames.len()` samples `t_k = k / (|r| - 1)`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Asset {
    pub v0: Vec<[f32; 3]>,
    pub v1: Vec<[f32; 3]>,
    pub s0: Strips,
    pub frames: Vec<CollapseSequence>,
    /// For an asset made from a weight animation: the targets the GPU adds to `V(0)` so it
    /// draws the animation, not only the blend of its end poses. `None` for two-pose morphs.
    pub blend: Option<TargetBlend>,
}

/// Most morph targets an asset may blend on the GPU (the uniform block holds one weight per
/// target). More than any animation of one mesh drives; a file asking for more is refused.
pub const MAX_TARGETS: usize = 64;

/// The first 8 bytes of every `.mlod` file.
pub const MAGIC: [u8; 8] = *b"\x89MLD\r\n\x1a\n";
/// The format version this build writes and the newest it reads.
pub const VERSION: u16 = 1;
/// Most frames a file may hold. Repeated frames cost two bytes in the file
/// but a whole sequence in memory, so this bounds what a small file can make
/// the decoder allocate; it is far more than any animation needs.
pub const MAX_FRAMES: usize = 4096;
/// Size of the fixed header.
pub const HEADER_LEN: usize = 32;

const TAG_V0: [u8; 4] = *b"V0  ";
const TAG_V1: [u8; 4] = *b"V1  ";
const TAG_S0: [u8; 4] = *b"S0  ";
const TAG_FRAMES: [u8; 4] = *b"FRMS";
const TAG_TARGETS: [u8; 4] = *b"TGTS";
const SECTION_ENTRY_LEN: usize = 24;
/// More sections than any version will define: bounds the table before it is read.
const MAX_SECTIONS: u32 = 64;
const FRAME_REPEAT: u8 = 0;
const FRAME_CODED: u8 = 1;
/// Exp-Golomb prefixes longer than this cannot encode a value the format uses.
const MAX_PREFIX: u32 = 40;

/// Why a `.mlod` file could not be read or written.
#[derive(Debug, Error)]
pub enum AssetError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "not a .mlod file: it starts with {found:02x?} instead of the .mlod magic {MAGIC:02x?}"
    )]
    WrongMagic { found: Vec<u8> },
    #[error("the file is {length} bytes, shorter than the {HEADER_LEN}-byte .mlod header: it was cut off")]
    TruncatedHeader { length: usize },
    #[error("the file is format version {found}, newer than version {VERSION} that this morphlod reads: upgrade morphlod")]
    NewerVersion { found: u16 },
    #[error("the file claims format version {found}, which never existed (the first is 1): the file is damaged")]
    UnknownVersion { found: u16 },
    #[error("the file sets flags {flags:#06x} that this morphlod does not know: it was written by a newer morphlod, upgrade")]
    UnknownFlags { flags: u16 },
    #[error("the header announces a {expected}-byte body but only {found} bytes follow: the file was cut off")]
    TruncatedBody { expected: u64, found: u64 },
    #[error("the header announces a {expected}-byte body but {found} bytes follow: the file has trailing data")]
    TrailingBytes { expected: u64, found: u64 },
    #[error("checksum mismatch: the header says CRC-32 {stored:#010x}, the body has {computed:#010x}: the file is damaged")]
    Checksum { stored: u32, computed: u32 },
    #[error(
        "the section table lists {count} sections (at most {MAX_SECTIONS}) in a {body}-byte body"
    )]
    SectionTable { count: u32, body: u64 },
    #[error("section '{tag}' spans bytes {offset}..{offset}+{length}, outside the body's section area ({start}..{body})")]
    SectionOutOfRange {
        tag: String,
        offset: u64,
        length: u64,
        start: u64,
        body: u64,
    },
    #[error("section '{tag}' appears twice")]
    DuplicateSection { tag: String },
    #[error("the required section '{tag}' is missing")]
    MissingSection { tag: String },
    #[error("section '{tag}' is {length} bytes, not a whole number of {unit}-byte records")]
    SectionSize { tag: String, length: u64, unit: u64 },
    #[error("V0 has {v0} vertices but V1 has {v1}: the poses must match")]
    PoseSizeMismatch { v0: usize, v1: usize },
    #[error("the poses have {vertices} vertices, more than 32-bit indices address")]
    TooManyVertices { vertices: usize },
    #[error("{pose}: vertex {vertex} is not finite ({value:?})")]
    NonFinitePosition {
        pose: &'static str,
        vertex: usize,
        value: [f32; 3],
    },
    #[error("section '{tag}' ends in the middle of {what}: the file is damaged")]
    Truncated { tag: &'static str, what: String },
    #[error("section '{tag}': {what} is a number longer than 64 bits")]
    BadNumber { tag: &'static str, what: String },
    #[error("section '{tag}': {what} is {count}, more than the {limit} the data allows")]
    CountTooLarge {
        tag: &'static str,
        what: String,
        count: u64,
        limit: u64,
    },
    #[error("S0 index {position} is {index}, but the asset has {vertices} vertices")]
    StripIndex {
        position: usize,
        index: u64,
        vertices: usize,
    },
    #[error("S0 offset {strip} is {offset} after {previous} (of {indices} indices): offsets must start at 0, never decrease and end at the index count")]
    StripOffsets {
        strip: usize,
        offset: u64,
        previous: u64,
        indices: usize,
    },
    #[error("frame {frame} has mode {mode}, which is neither 0 (repeat) nor 1 (coded)")]
    FrameMode { frame: usize, mode: u8 },
    #[error("frame 0 says it repeats the previous frame, but there is none")]
    RepeatFirstFrame,
    #[error("the asset has no frames; it needs at least one collapse sequence")]
    NoFrames,
    #[error("frame {frame}: {source}")]
    Sequence { frame: usize, source: SequenceError },
    #[error("frame {frame}, collapse {step}: neighbour symbol {symbol} is past vertex {vertex}'s {neighbours} neighbours and the escape")]
    NeighbourSymbol {
        frame: usize,
        step: usize,
        vertex: u32,
        symbol: u64,
        neighbours: usize,
    },
    #[error(
        "frame {frame}, collapse {step}: the error {value} is not a finite, non-negative number"
    )]
    BadError {
        frame: usize,
        step: usize,
        value: f32,
    },
    #[error("frame {frame} is {declared} bytes but its data ends after {used}")]
    FrameLength {
        frame: usize,
        declared: usize,
        used: usize,
    },
    #[error("section 'TGTS' holds {targets} morph targets; it must hold 1 to {MAX_TARGETS}")]
    TargetCount { targets: usize },
    #[error("section 'TGTS' names interpolation {code}, which is none of 0 (STEP), 1 (LINEAR), 2 (CUBICSPLINE)")]
    TargetInterpolation { code: u8 },
    #[error("section 'TGTS' is {length} bytes, but {targets} targets with {keyframes} keyframes over {vertices} vertices take {expected}: the file is damaged")]
    TargetSize {
        length: usize,
        targets: usize,
        keyframes: usize,
        vertices: usize,
        expected: u64,
    },
    #[error("section 'TGTS': the weight track is invalid: {source}")]
    TargetTrack { source: MorphError },
    #[error("section 'TGTS': target {target}, vertex {vertex} has a delta that is not finite ({value:?})")]
    NonFiniteDelta {
        target: usize,
        vertex: usize,
        value: [f32; 3],
    },
    #[error("section '{tag}' is {length} bytes but its data ends after {used}")]
    SectionTrailing {
        tag: &'static str,
        length: usize,
        used: usize,
    },
}

/// One section of a file, for [`AssetInfo`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SectionInfo {
    pub tag: String,
    pub bytes: usize,
}

/// One frame of a file, for [`AssetInfo`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameInfo {
    /// LOD steps (collapses).
    pub collapses: usize,
    /// Encoded bytes, including its length prefix.
    pub bytes: usize,
    /// Stored as "same as the previous frame".
    pub repeat: bool,
}

/// What a `.mlod` file holds and where its bytes go.
#[derive(Clone, Debug, PartialEq)]
pub struct AssetInfo {
    pub version: u16,
    pub file_bytes: usize,
    pub header_bytes: usize,
    /// The section table itself.
    pub table_bytes: usize,
    pub sections: Vec<SectionInfo>,
    pub vertices: usize,
    /// Triangles drawn by `S0` at full detail.
    pub triangles: usize,
    pub strips: usize,
    pub strip_indices: usize,
    pub frames: Vec<FrameInfo>,
    /// Morph targets blended on the GPU (0 for a two-pose asset).
    pub targets: usize,
}

impl AssetInfo {
    /// Frame bytes (all frames) per vertex per frame: the per-frame CPU data figure.
    pub fn frame_bytes_per_vertex(&self) -> f64 {
        let bytes: usize = self.frames.iter().map(|f| f.bytes).sum();
        bytes as f64 / (self.vertices.max(1) * self.frames.len().max(1)) as f64
    }

    /// Size of the plain indexed mesh (one f32x3 pose, u32 triangle list).
    pub fn indexed_mesh_bytes(&self) -> usize {
        self.vertices * 12 + self.triangles * 12
    }
}

impl fmt::Display for AssetInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let collapses: Vec<usize> = self.frames.iter().map(|f| f.collapses).collect();
        let repeats = self.frames.iter().filter(|f| f.repeat).count();
        writeln!(f, "  format version    {}", self.version)?;
        writeln!(
            f,
            "  mesh              {} vertices, {} triangles, {} strips ({} indices, {:.3} per triangle)",
            self.vertices,
            self.triangles,
            self.strips,
            self.strip_indices,
            self.strip_indices as f64 / self.triangles.max(1) as f64
        )?;
        writeln!(
            f,
            "  frames            {} ({} stored as repeats)",
            self.frames.len(),
            repeats
        )?;
        if self.targets > 0 {
            writeln!(
                f,
                "  GPU targets       {} (weight animation blended on the GPU)",
                self.targets
            )?;
        }
        writeln!(
            f,
            "  LODs per frame    min {}, max {}, mean {:.1}",
            collapses.iter().min().map_or(0, |&c| c + 1),
            collapses.iter().max().map_or(0, |&c| c + 1),
            collapses.iter().sum::<usize>() as f64 / collapses.len().max(1) as f64 + 1.0
        )?;
        writeln!(f, "  sizes")?;
        writeln!(f, "    header          {:>10} B", self.header_bytes)?;
        writeln!(f, "    section table   {:>10} B", self.table_bytes)?;
        for s in &self.sections {
            writeln!(f, "    {:<15} {:>10} B", s.tag.trim_end(), s.bytes)?;
        }
        writeln!(f, "    total           {:>10} B", self.file_bytes)?;
        writeln!(
            f,
            "  frame data        {:.3} B per vertex per frame, {:.3} B per collapse",
            self.frame_bytes_per_vertex(),
            self.frames.iter().map(|f| f.bytes).sum::<usize>() as f64
                / collapses.iter().sum::<usize>().max(1) as f64
        )?;
        write!(
            f,
            "  vs indexed mesh   {:.2}x the plain indexed mesh ({} B: f32 positions + u32 triangles)",
            self.file_bytes as f64 / self.indexed_mesh_bytes().max(1) as f64,
            self.indexed_mesh_bytes()
        )
    }
}

/// Rounds a collapse error to what the file keeps: bfloat16 (round to
/// nearest even), clamped to `[0, largest finite]`; NaN reads as 0. The
/// builder applies it so a built asset survives its file unchanged.
pub fn quantize_error(error: f32) -> f32 {
    let e = error.max(0.0);
    let bits = e.to_bits();
    let rounded = bits.wrapping_add(0x7FFF + ((bits >> 16) & 1)) & 0xFFFF_0000;
    let q = f32::from_bits(rounded);
    if q.is_finite() {
        q
    } else {
        f32::from_bits(0x7F7F_0000)
    }
}

impl Asset {
    /// The file bytes. Never fails: an asset that breaks the format's rules
    /// (a collapse out of range, decreasing strip offsets, ...) is written as
    /// is and refused by [`Asset::from_bytes`] with the matching error. Errors
    /// are kept at bfloat16 precision (see [`quantize_error`]); frames store
    /// the vertex count of `v0`.
    pub fn to_bytes(&self) -> Vec<u8> {
        let n = self.v0.len();
        let neighbours = Neighbours::new(&self.s0, n);
        let frames: Vec<Vec<u8>> = self
            .frames
            .par_iter()
            .enumerate()
            .map(|(k, seq)| {
                if k > 0 && self.frames[k - 1] == *seq {
                    vec![FRAME_REPEAT]
                } else {
                    encode_frame(seq, n, &neighbours)
                }
            })
            .collect();
        let mut frames_section = Vec::new();
        put_varint(&mut frames_section, frames.len() as u64);
        for f in &frames {
            put_varint(&mut frames_section, f.len() as u64);
            frames_section.extend_from_slice(f);
        }
        let mut sections: Vec<([u8; 4], Vec<u8>)> = vec![
            (TAG_V0, pose_bytes(&self.v0)),
            (TAG_V1, pose_bytes(&self.v1)),
            (TAG_S0, encode_strips(&self.s0)),
            (TAG_FRAMES, frames_section),
        ];
        if let Some(blend) = &self.blend {
            sections.push((TAG_TARGETS, encode_targets(blend)));
        }

        let mut body = Vec::new();
        let mut offset = (sections.len() * SECTION_ENTRY_LEN) as u64;
        for (tag, data) in &sections {
            body.extend_from_slice(tag);
            body.extend_from_slice(&0u32.to_le_bytes());
            body.extend_from_slice(&offset.to_le_bytes());
            body.extend_from_slice(&(data.len() as u64).to_le_bytes());
            offset += data.len() as u64;
        }
        for (_, data) in &sections {
            body.extend_from_slice(data);
        }
        let mut out = Vec::with_capacity(HEADER_LEN + body.len());
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        out.extend_from_slice(&(sections.len() as u32).to_le_bytes());
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&body);
        out
    }

    /// Reads and validates a whole file image (see the module docs).
    pub fn from_bytes(bytes: &[u8]) -> Result<Asset, AssetError> {
        Ok(inspect(bytes)?.0)
    }

    /// Writes the file atomically (see [`save_bytes`]).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), AssetError> {
        save_bytes(path.as_ref(), &self.to_bytes())
    }

    /// Reads and validates a `.mlod` file.
    pub fn load(path: impl AsRef<Path>) -> Result<Asset, AssetError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| AssetError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Asset::from_bytes(&bytes)
    }
}

/// Writes `bytes` atomically: a temporary file in the same directory,
/// flushed, then renamed over `path`, so readers see the old file or the
/// whole new one, never a half-written one.
pub fn save_bytes(path: &Path, bytes: &[u8]) -> Result<(), AssetError> {
    let name = path
        .file_name()
        .map_or_else(|| "asset".into(), |n| n.to_string_lossy().into_owned());
    let temp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let written = std::fs::File::create(&temp).and_then(|mut file| {
        file.write_all(bytes)?;
        file.sync_all()
    });
    if let Err(source) = written.and_then(|()| std::fs::rename(&temp, path)) {
        // Best effort: the temporary may not exist if creating it failed.
        let _ = std::fs::remove_file(&temp);
        return Err(AssetError::Io {
            path: path.to_path_buf(),
            source,
        });
    }
    Ok(())
}

/// Reads and validates a file image like [`Asset::from_bytes`], and says
/// where its bytes went.
pub fn inspect(bytes: &[u8]) -> Result<(Asset, AssetInfo), AssetError> {
    let (count, body) = check_header(bytes)?;
    let table = read_section_table(body, count)?;
    let section = |tag: [u8; 4]| -> Result<&[u8], AssetError> {
        table
            .iter()
            .find(|s| s.tag == tag)
            .map(|s| &body[s.start..s.end])
            .ok_or_else(|| AssetError::MissingSection { tag: tag_name(tag) })
    };
    let v0 = decode_pose(section(TAG_V0)?, "V0")?;
    let v1 = decode_pose(section(TAG_V1)?, "V1")?;
    if v0.len() != v1.len() {
        return Err(AssetError::PoseSizeMismatch {
            v0: v0.len(),
            v1: v1.len(),
        });
    }
    let n = v0.len();
    if n >= u32::MAX as usize {
        return Err(AssetError::TooManyVertices { vertices: n });
    }
    let s0 = decode_strips(section(TAG_S0)?, n)?;
    let neighbours = Neighbours::new(&s0, n);
    let (frames, frame_infos) = decode_frames(section(TAG_FRAMES)?, n, &neighbours)?;
    let blend = match section(TAG_TARGETS) {
        Ok(data) => Some(decode_targets(data, n)?),
        Err(_) => None,
    };

    let info = AssetInfo {
        version: VERSION,
        file_bytes: bytes.len(),
        header_bytes: HEADER_LEN,
        table_bytes: table.len() * SECTION_ENTRY_LEN,
        sections: table
            .iter()
            .map(|s| SectionInfo {
                tag: tag_name(s.tag),
                bytes: s.end - s.start,
            })
            .collect(),
        vertices: n,
        triangles: (0..s0.len())
            .filter_map(|i| s0.strip(i))
            .map(|s| strip_triangles(s).count())
            .sum(),
        strips: s0.len(),
        strip_indices: s0.indices.len(),
        frames: frame_infos,
        targets: blend.as_ref().map_or(0, |b| b.deltas.len()),
    };
    let asset = Asset {
        v0,
        v1,
        s0,
        frames,
        blend,
    };
    Ok((asset, info))
}

fn tag_name(tag: [u8; 4]) -> String {
    String::from_utf8_lossy(&tag).into_owned()
}

fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from(u32_at(b, at)) | (u64::from(u32_at(b, at + 4)) << 32)
}

/// Magic, version, flags, length and checksum; returns the section count
/// and the body.
fn check_header(bytes: &[u8]) -> Result<(u32, &[u8]), AssetError> {
    let magic_len = bytes.len().min(MAGIC.len());
    if bytes[..magic_len] != MAGIC[..magic_len] {
        return Err(AssetError::WrongMagic {
            found: bytes[..magic_len].to_vec(),
        });
    }
    if bytes.len() < HEADER_LEN {
        return Err(AssetError::TruncatedHeader {
            length: bytes.len(),
        });
    }
    let version = u16_at(bytes, 8);
    if version > VERSION {
        return Err(AssetError::NewerVersion { found: version });
    }
    if version == 0 {
        return Err(AssetError::UnknownVersion { found: version });
    }
    let flags = u16_at(bytes, 10);
    if flags != 0 {
        return Err(AssetError::UnknownFlags { flags });
    }
    let expected = u64_at(bytes, 16);
    let found = (bytes.len() - HEADER_LEN) as u64;
    if found < expected {
        return Err(AssetError::TruncatedBody { expected, found });
    }
    if found > expected {
        return Err(AssetError::TrailingBytes { expected, found });
    }
    let body = &bytes[HEADER_LEN..];
    let stored = u32_at(bytes, 24);
    let computed = crc32fast::hash(body);
    if stored != computed {
        return Err(AssetError::Checksum { stored, computed });
    }
    Ok((u32_at(bytes, 12), body))
}

/// One entry of the section table: the tag and the byte range in the body.
struct Section {
    tag: [u8; 4],
    start: usize,
    end: usize,
}

/// The section table: each section's tag and byte range in the body, all
/// after the table. Unknown tags are kept (and skipped by the caller).
fn read_section_table(body: &[u8], count: u32) -> Result<Vec<Section>, AssetError> {
    let table_len = count as usize * SECTION_ENTRY_LEN;
    if count > MAX_SECTIONS || table_len > body.len() {
        return Err(AssetError::SectionTable {
            count,
            body: body.len() as u64,
        });
    }
    let mut table: Vec<Section> = Vec::with_capacity(count as usize);
    for entry in body[..table_len].chunks_exact(SECTION_ENTRY_LEN) {
        let tag = [entry[0], entry[1], entry[2], entry[3]];
        let offset = u64_at(entry, 8);
        let length = u64_at(entry, 16);
        let end = offset.checked_add(length);
        if offset < table_len as u64 || end.is_none_or(|e| e > body.len() as u64) {
            return Err(AssetError::SectionOutOfRange {
                tag: tag_name(tag),
                offset,
                length,
                start: table_len as u64,
                body: body.len() as u64,
            });
        }
        if table.iter().any(|s| s.tag == tag) {
            return Err(AssetError::DuplicateSection { tag: tag_name(tag) });
        }
        // Both fit in the body, so in usize.
        table.push(Section {
            tag,
            start: offset as usize,
            end: (offset + length) as usize,
        });
    }
    Ok(table)
}

fn pose_bytes(pose: &[[f32; 3]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(pose.len() * 12);
    for p in pose {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

fn decode_pose(data: &[u8], pose: &'static str) -> Result<Vec<[f32; 3]>, AssetError> {
    if !data.len().is_multiple_of(12) {
        return Err(AssetError::SectionSize {
            tag: pose.to_string(),
            length: data.len() as u64,
            unit: 12,
        });
    }
    data.chunks_exact(12)
        .enumerate()
        .map(|(vertex, c)| {
            let value = [0, 4, 8].map(|at| f32::from_bits(u32_at(c, at)));
            if value.iter().all(|x| x.is_finite()) {
                Ok(value)
            } else {
                Err(AssetError::NonFinitePosition {
                    pose,
                    vertex,
                    value,
                })
            }
        })
        .collect()
}

fn encode_targets(blend: &TargetBlend) -> Vec<u8> {
    let track = &blend.track;
    let mut out = vec![match track.interpolation() {
        Interpolation::Step => 0,
        Interpolation::Linear => 1,
        Interpolation::CubicSpline => 2,
    }];
    put_varint(&mut out, blend.deltas.len() as u64);
    put_varint(&mut out, track.keyframes() as u64);
    for v in track.times().iter().chain(track.values()) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for deltas in &blend.deltas {
        out.extend_from_slice(&pose_bytes(deltas));
    }
    out
}

/// The "TGTS" section: every size is fixed by the two counts and the vertex count, so the
/// whole length is checked before anything is allocated.
fn decode_targets(data: &[u8], n: usize) -> Result<TargetBlend, AssetError> {
    let mut r = Reader::new(data, "TGTS");
    let interpolation = match r.byte(&|| "the interpolation".into())? {
        0 => Interpolation::Step,
        1 => Interpolation::Linear,
        2 => Interpolation::CubicSpline,
        code => return Err(AssetError::TargetInterpolation { code }),
    };
    let targets = r.count(&|| "the target count".into(), MAX_TARGETS)?;
    if targets == 0 {
        return Err(AssetError::TargetCount { targets });
    }
    let keyframes = r.count(&|| "the keyframe count".into(), r.remaining() / 4)?;
    let per_key = if interpolation == Interpolation::CubicSpline {
        3 * targets
    } else {
        targets
    };
    // keyframes ≤ bytes / 4 and targets ≤ 64 keep these products far below u64's range.
    let floats = keyframes as u64 * (1 + per_key as u64) + targets as u64 * n as u64 * 3;
    if floats * 4 != r.remaining() as u64 {
        return Err(AssetError::TargetSize {
            length: data.len(),
            targets,
            keyframes,
            vertices: n,
            expected: (data.len() - r.remaining()) as u64 + floats * 4,
        });
    }
    let mut floats = |count: usize, what: &'static str| -> Result<Vec<f32>, AssetError> {
        let bytes = r.bytes(count * 4, &|| what.into())?;
        Ok(bytes
            .chunks_exact(4)
            .map(|c| f32::from_bits(u32_at(c, 0)))
            .collect())
    };
    let times = floats(keyframes, "the keyframe times")?;
    let values = floats(keyframes * per_key, "the track values")?;
    let track = WeightTrack::new(interpolation, times, values, targets)
        .map_err(|source| AssetError::TargetTrack { source })?;
    let deltas = (0..targets)
        .map(|target| {
            let bytes = r.bytes(n * 12, &|| format!("the deltas of target {target}"))?;
            decode_pose(bytes, "TGTS").map_err(|e| match e {
                AssetError::NonFinitePosition { vertex, value, .. } => AssetError::NonFiniteDelta {
                    target,
                    vertex,
                    value,
                },
                other => other,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    r.finish()?;
    Ok(TargetBlend { deltas, track })
}

fn put_varint(out: &mut Vec<u8>, mut value: u64) {
    while value >= 0x80 {
        out.push(value as u8 | 0x80);
        value >>= 7;
    }
    out.push(value as u8);
}

fn zigzag(delta: i64) -> u64 {
    ((delta << 1) ^ (delta >> 63)) as u64
}

fn unzigzag(value: u64) -> i64 {
    (value >> 1) as i64 ^ -((value & 1) as i64)
}

/// A cursor over one section's bytes; errors name the section.
struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    tag: &'static str,
}

impl<'a> Reader<'a> {
    fn new(data: &'a [u8], tag: &'static str) -> Self {
        Self { data, pos: 0, tag }
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn varint(&mut self, what: &dyn Fn() -> String) -> Result<u64, AssetError> {
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            let Some(&byte) = self.data.get(self.pos) else {
                return Err(AssetError::Truncated {
                    tag: self.tag,
                    what: what(),
                });
            };
            self.pos += 1;
            let bits = u64::from(byte & 0x7F);
            if shift == 63 && bits > 1 {
                break;
            }
            value |= bits << shift;
            if byte < 0x80 {
                return Ok(value);
            }
        }
        Err(AssetError::BadNumber {
            tag: self.tag,
            what: what(),
        })
    }

    /// A count that must not exceed `limit` (what the bytes or the vertex
    /// count justify), checked before anything is allocated for it.
    fn count(&mut self, what: &dyn Fn() -> String, limit: usize) -> Result<usize, AssetError> {
        let count = self.varint(what)?;
        if count > limit as u64 {
            return Err(AssetError::CountTooLarge {
                tag: self.tag,
                what: what(),
                count,
                limit: limit as u64,
            });
        }
        Ok(count as usize)
    }

    fn byte(&mut self, what: &dyn Fn() -> String) -> Result<u8, AssetError> {
        let byte = self
            .data
            .get(self.pos)
            .copied()
            .ok_or_else(|| AssetError::Truncated {
                tag: self.tag,
                what: what(),
            })?;
        self.pos += 1;
        Ok(byte)
    }

    fn bytes(&mut self, len: usize, what: &dyn Fn() -> String) -> Result<&'a [u8], AssetError> {
        let out = self
            .data
            .get(self.pos..)
            .and_then(|rest| rest.get(..len))
            .ok_or_else(|| AssetError::Truncated {
                tag: self.tag,
                what: what(),
            })?;
        self.pos += len;
        Ok(out)
    }

    fn finish(&self) -> Result<(), AssetError> {
        if self.pos == self.data.len() {
            Ok(())
        } else {
            Err(AssetError::SectionTrailing {
                tag: self.tag,
                length: self.data.len(),
                used: self.pos,
            })
        }
    }
}

/// Offsets as deltas (wrapping, so any `Strips` encodes; the decoder refuses
/// decreasing ones), indices as zigzag deltas: consecutive strip indices are
/// neighbours, usually numbered close together.
fn encode_strips(s0: &Strips) -> Vec<u8> {
    let mut out = Vec::with_capacity(s0.indices.len() * 2);
    put_varint(&mut out, s0.indices.len() as u64);
    put_varint(&mut out, s0.offsets.len() as u64);
    let mut prev = 0u32;
    for &o in &s0.offsets {
        put_varint(&mut out, u64::from(o.wrapping_sub(prev)));
        prev = o;
    }
    let mut prev = 0i64;
    for &i in &s0.indices {
        put_varint(&mut out, zigzag(i64::from(i) - prev));
        prev = i64::from(i);
    }
    out
}

fn decode_strips(data: &[u8], n: usize) -> Result<Strips, AssetError> {
    let mut r = Reader::new(data, "S0");
    // Every index and offset takes at least one byte.
    let index_count = r.count(&|| "the index count".into(), data.len())?;
    let offset_count = r.count(&|| "the offset count".into(), r.remaining())?;
    let mut offsets = Vec::with_capacity(offset_count);
    let mut prev = 0u64;
    for strip in 0..offset_count {
        let delta = r.varint(&|| format!("offset {strip}"))?;
        // Deltas wrap at 32 bits (see `encode_strips`): undo that to report the offset written.
        let offset = (prev + delta) & 0xFFFF_FFFF;
        let first_nonzero = strip == 0 && offset != 0;
        if delta > u64::from(u32::MAX)
            || offset < prev
            || offset > index_count as u64
            || first_nonzero
        {
            return Err(AssetError::StripOffsets {
                strip,
                offset,
                previous: prev,
                indices: index_count,
            });
        }
        offsets.push(offset as u32);
        prev = offset;
    }
    if prev != index_count as u64 {
        return Err(AssetError::StripOffsets {
            strip: offset_count,
            offset: prev,
            previous: prev,
            indices: index_count,
        });
    }
    if index_count > r.remaining() {
        return Err(AssetError::CountTooLarge {
            tag: "S0",
            what: "the index count".into(),
            count: index_count as u64,
            limit: r.remaining() as u64,
        });
    }
    let mut indices = Vec::with_capacity(index_count);
    let mut prev = 0i64;
    for position in 0..index_count {
        let delta = unzigzag(r.varint(&|| format!("index {position}"))?);
        let index = prev.wrapping_add(delta);
        if index < 0 || index >= n as i64 {
            return Err(AssetError::StripIndex {
                position,
                index: index as u64,
                vertices: n,
            });
        }
        indices.push(index as u32);
        prev = index;
    }
    r.finish()?;
    Ok(Strips { indices, offsets })
}

/// Each vertex's neighbours in the triangles `S0` draws, sorted, in CSR
/// form: the alphabet of the `w` symbols. Encoder and decoder build it from
/// the same strips, so it only has to be deterministic, not "the" mesh adjacency.
struct Neighbours {
    offsets: Vec<u32>,
    list: Vec<u32>,
}

impl Neighbours {
    fn new(s0: &Strips, n: usize) -> Self {
        let triangles: Vec<[u32; 3]> = s0
            .triangles()
            .into_iter()
            .filter(|t| t.iter().all(|&v| (v as usize) < n))
            .collect();
        let mut start = vec![0usize; n + 1];
        for t in &triangles {
            for &v in t {
                start[v as usize + 1] += 2;
            }
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut all = vec![0u32; start[n]];
        for t in &triangles {
            for c in 0..3 {
                let v = t[c] as usize;
                all[fill[v]] = t[(c + 1) % 3];
                all[fill[v] + 1] = t[(c + 2) % 3];
                fill[v] += 2;
            }
        }
        let mut offsets = Vec::with_capacity(n + 1);
        let mut list = Vec::with_capacity(all.len());
        offsets.push(0);
        for v in 0..n {
            let fan = &mut all[start[v]..start[v + 1]];
            fan.sort_unstable();
            let from = list.len();
            list.extend_from_slice(fan);
            let mut kept = from;
            for i in from..list.len() {
                if i == from || list[i] != list[kept - 1] {
                    list[kept] = list[i];
                    kept += 1;
                }
            }
            list.truncate(kept);
            offsets.push(list.len() as u32);
        }
        Self { offsets, list }
    }

    /// Neighbours of `v`; empty for a vertex out of range.
    fn of(&self, v: u32) -> &[u32] {
        let v = v as usize;
        match (self.offsets.get(v), self.offsets.get(v + 1)) {
            (Some(&a), Some(&b)) => &self.list[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// The survivor of `x`: union-find root with path halving. Every link goes
/// from a vertex that collapses to one still alive, so the forest has no cycle.
fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let grand = parent[parent[x as usize] as usize];
        parent[x as usize] = grand;
        x = grand;
    }
    x
}

struct BitWriter {
    out: Vec<u8>,
    acc: u64,
    bits: u32,
}

impl BitWriter {
    /// Appends the low `count` bits of `value`, `count <= 56`.
    fn put(&mut self, value: u64, count: u32) {
        self.acc |= (value & ((1u64 << count) - 1)) << self.bits;
        self.bits += count;
        while self.bits >= 8 {
            self.out.push(self.acc as u8);
            self.acc >>= 8;
            self.bits -= 8;
        }
    }

    /// Exp-Golomb of order `k`: `x + 2^k` in binary, after as many zero bits
    /// as it has digits beyond `k + 1`.
    fn exp_golomb(&mut self, x: u64, k: u32) {
        let v = x + (1u64 << k);
        let digits = 64 - v.leading_zeros();
        let zeros = digits - 1 - k;
        self.put(1u64 << zeros, zeros + 1);
        self.put(v, digits - 1);
    }

    fn finish(mut self) -> Vec<u8> {
        if self.bits > 0 {
            self.out.push(self.acc as u8);
        }
        self.out
    }
}

fn exp_golomb_len(x: u64, k: u32) -> u64 {
    let digits = u64::from(64 - (x + (1u64 << k)).leading_zeros());
    2 * digits - 1 - u64::from(k)
}

struct BitReader<'a> {
    data: &'a [u8],
    pos: usize,
    acc: u64,
    bits: u32,
    frame: usize,
}

impl BitReader<'_> {
    fn truncated(&self) -> AssetError {
        AssetError::Truncated {
            tag: "FRMS",
            what: format!("frame {}'s collapses", self.frame),
        }
    }

    /// The next `count <= 56` bits.
    fn get(&mut self, count: u32) -> Result<u64, AssetError> {
        while self.bits < count {
            let Some(&byte) = self.data.get(self.pos) else {
                return Err(self.truncated());
            };
            self.acc |= u64::from(byte) << self.bits;
            self.pos += 1;
            self.bits += 8;
        }
        let value = self.acc & ((1u64 << count) - 1);
        self.acc >>= count;
        self.bits -= count;
        Ok(value)
    }

    fn exp_golomb(&mut self, k: u32) -> Result<u64, AssetError> {
        let mut zeros = 0;
        while self.get(1)? == 0 {
            zeros += 1;
            if zeros > MAX_PREFIX {
                return Err(AssetError::BadNumber {
                    tag: "FRMS",
                    what: format!("a number in frame {}", self.frame),
                });
            }
        }
        let rest = self.get(zeros + k)?;
        Ok(((1u64 << (zeros + k)) | rest) - (1u64 << k))
    }
}

/// Largest exp-Golomb orders tried for the two symbol streams.
const MAX_ORDER_W: u32 = 8;
const MAX_ORDER_ERROR: u32 = 16;

fn best_order(values: &[u64], max: u32) -> u32 {
    (0..=max)
        .min_by_key(|&k| values.iter().map(|&x| exp_golomb_len(x, k)).sum::<u64>())
        .unwrap_or(0)
}

/// A coded frame (see the module docs). Replays the survivors so that `w`
/// can be named by a neighbour of `u`; collapses that break the sequence
/// rules are written with escapes and left for the decoder to refuse.
fn encode_frame(seq: &CollapseSequence, n: usize, neighbours: &Neighbours) -> Vec<u8> {
    let largest = seq
        .collapses
        .iter()
        .map(|c| c.u.max(c.w))
        .chain([n.saturating_sub(1) as u32])
        .max()
        .unwrap_or(0);
    let width = (32 - largest.leading_zeros()).max(1);
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut symbols = Vec::with_capacity(seq.len());
    let mut errors = Vec::with_capacity(seq.len());
    let mut prev_error = 0i64;
    for c in &seq.collapses {
        let fan = neighbours.of(c.u);
        let valid = (c.u as usize) < n
            && (c.w as usize) < n
            && c.u != c.w
            && parent[c.u as usize] == c.u
            && parent[c.w as usize] == c.w;
        let symbol = if valid {
            fan.iter()
                .position(|&y| find(&mut parent, y) == c.w)
                .unwrap_or(fan.len())
        } else {
            fan.len()
        };
        if valid {
            parent[c.u as usize] = c.w;
        }
        symbols.push(symbol as u64);
        let bits = i64::from(quantize_error(c.error).to_bits() >> 16);
        errors.push(zigzag(bits - prev_error));
        prev_error = bits;
    }
    let order_w = best_order(&symbols, MAX_ORDER_W);
    let order_error = best_order(&errors, MAX_ORDER_ERROR);
    let mut head = vec![FRAME_CODED, width as u8, order_w as u8, order_error as u8];
    put_varint(&mut head, seq.len() as u64);
    let mut w = BitWriter {
        out: head,
        acc: 0,
        bits: 0,
    };
    for ((c, &symbol), &error) in seq.collapses.iter().zip(&symbols).zip(&errors) {
        w.put(u64::from(c.u), width);
        w.exp_golomb(symbol, order_w);
        if symbol as usize == neighbours.of(c.u).len() {
            w.put(u64::from(c.w), width);
        }
        w.exp_golomb(error, order_error);
    }
    w.finish()
}

fn decode_frame(
    data: &[u8],
    frame: usize,
    n: usize,
    neighbours: &Neighbours,
) -> Result<CollapseSequence, AssetError> {
    let mut r = Reader::new(data, "FRMS");
    let header = |name: &'static str| move || format!("frame {frame}'s {name}");
    let width = u32::from(r.byte(&header("index width"))?);
    let order_w = u32::from(r.byte(&header("neighbour code order"))?);
    let order_error = u32::from(r.byte(&header("error code order"))?);
    for (value, limit, name) in [
        (width, 32, "index width"),
        (order_w, MAX_ORDER_W, "neighbour code order"),
        (order_error, MAX_ORDER_ERROR, "error code order"),
    ] {
        if value > limit || (name == "index width" && value == 0) {
            return Err(AssetError::CountTooLarge {
                tag: "FRMS",
                what: header(name)(),
                count: u64::from(value),
                limit: u64::from(limit),
            });
        }
    }
    // Each vertex collapses at most once, and each collapse takes at least
    // `width` bits for `u` and one bit for each of its two codes.
    let count = r.varint(&header("collapse count"))?;
    let limit = n.min(r.remaining() * 8 / (width as usize + 2));
    if count > limit as u64 {
        return Err(AssetError::CountTooLarge {
            tag: "FRMS",
            what: header("collapse count")(),
            count,
            limit: limit as u64,
        });
    }
    let count = count as usize;
    let sequence_error = |source| AssetError::Sequence { frame, source };
    let mut bits = BitReader {
        data: &data[r.pos..],
        pos: 0,
        acc: 0,
        bits: 0,
        frame,
    };
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut rank = vec![NEVER; n];
    let mut collapses = Vec::with_capacity(count);
    let mut prev_error = 0i64;
    for step in 0..count {
        // Both ends of an explicit collapse must name a vertex that is still alive: the
        // union-find below indexes with them.
        let live = |vertex: u32, rank: &[u32]| match rank.get(vertex as usize) {
            None => Err(sequence_error(SequenceError::VertexOutOfRange {
                step,
                vertex,
                vertices: n,
            })),
            Some(&r) if r != NEVER => Err(sequence_error(SequenceError::AlreadyCollapsed {
                step,
                vertex,
                earlier: r as usize,
            })),
            Some(_) => Ok(vertex),
        };
        let u = live(bits.get(width)? as u32, &rank)?;
        let fan = neighbours.of(u);
        let symbol = bits.exp_golomb(order_w)?;
        let w = match fan.get(symbol as usize) {
            Some(&y) => find(&mut parent, y),
            None if symbol as usize == fan.len() => live(bits.get(width)? as u32, &rank)?,
            None => {
                return Err(AssetError::NeighbourSymbol {
                    frame,
                    step,
                    vertex: u,
                    symbol,
                    neighbours: fan.len(),
                })
            }
        };
        if w == u {
            return Err(sequence_error(SequenceError::SelfCollapse {
                step,
                vertex: u,
            }));
        }
        let error_bits = prev_error.wrapping_add(unzigzag(bits.exp_golomb(order_error)?));
        // 0x7F7F is the largest finite bfloat16 with the sign bit clear.
        if !(0..=0x7F7F).contains(&error_bits) {
            return Err(AssetError::BadError {
                frame,
                step,
                value: f32::from_bits((error_bits as u32) << 16),
            });
        }
        prev_error = error_bits;
        parent[u as usize] = w;
        rank[u as usize] = step as u32;
        collapses.push(Collapse {
            u,
            w,
            error: f32::from_bits((error_bits as u32) << 16),
        });
    }
    let used = r.pos + bits.pos;
    if used != data.len() {
        return Err(AssetError::FrameLength {
            frame,
            declared: data.len(),
            used,
        });
    }
    Ok(CollapseSequence {
        vertex_count: n as u32,
        collapses,
    })
}

/// The frames section: every frame's bytes are delimited first, so coded
/// frames decode in parallel; repeats are resolved in order afterwards.
fn decode_frames(
    data: &[u8],
    n: usize,
    neighbours: &Neighbours,
) -> Result<(Vec<CollapseSequence>, Vec<FrameInfo>), AssetError> {
    let mut r = Reader::new(data, "FRMS");
    // Each frame takes at least its length byte and its mode byte.
    let count = r.count(
        &|| "the frame count".into(),
        (data.len() / 2).min(MAX_FRAMES),
    )?;
    if count == 0 {
        return Err(AssetError::NoFrames);
    }
    let mut parts = Vec::with_capacity(count);
    for frame in 0..count {
        let start = r.pos;
        // The limit is what remains before the length itself is read, so the
        // read of the frame's bytes below checks again.
        let len = r.count(&|| format!("frame {frame}'s length"), r.remaining())?;
        let bytes = r.bytes(len, &|| format!("frame {frame}'s {len} bytes"))?;
        parts.push((bytes, r.pos - start));
    }
    r.finish()?;
    let decoded: Vec<Result<Option<CollapseSequence>, AssetError>> = parts
        .par_iter()
        .enumerate()
        .map(|(frame, (bytes, _))| match bytes.split_first() {
            Some((&FRAME_REPEAT, [])) => Ok(None),
            Some((&FRAME_CODED, rest)) => decode_frame(rest, frame, n, neighbours).map(Some),
            Some((&FRAME_REPEAT, _)) => Err(AssetError::FrameLength {
                frame,
                declared: bytes.len(),
                used: 1,
            }),
            Some((&mode, _)) => Err(AssetError::FrameMode { frame, mode }),
            None => Err(AssetError::Truncated {
                tag: "FRMS",
                what: format!("frame {frame}'s mode"),
            }),
        })
        .collect();
    let mut frames: Vec<CollapseSequence> = Vec::with_capacity(count);
    let mut infos = Vec::with_capacity(count);
    for (result, &(_, bytes)) in decoded.into_iter().zip(&parts) {
        let repeat = matches!(result, Ok(None));
        let sequence = match result? {
            Some(sequence) => sequence,
            None => frames.last().cloned().ok_or(AssetError::RepeatFirstFrame)?,
        };
        infos.push(FrameInfo {
            collapses: sequence.len(),
            bytes,
            repeat,
        });
        frames.push(sequence);
    }
    Ok((frames, infos))
}
