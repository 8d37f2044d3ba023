//! Every way a `.mlod` file can fail to load or save: [`AssetError`].

use super::{HEADER_LEN, MAGIC, MAX_SECTIONS, MAX_TARGETS, VERSION};
use crate::collapse::SequenceError;
use crate::morph::MorphError;
use crate::seams::SeamError;
use crate::skin::SkinError;
use std::path::PathBuf;
use thiserror::Error;

/// Why a `.mlod` file could not be read or written.
#[derive(Debug, Error)]
pub enum AssetError {
    #[error("loading this file needs up to {needed} bytes of memory, over the {budget}-byte budget: raise the budget (`--memory-budget MB` on the command line, `AssetLoadOptions::max_bytes` in code) if the file is trusted")]
    OverBudget { needed: u64, budget: u64 },
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
    #[error("section '{tag}': checksum mismatch, it says CRC-32 {stored:#010x} but holds {computed:#010x}: the section is damaged")]
    SectionChecksum {
        tag: &'static str,
        stored: u32,
        computed: u32,
    },
    #[error("section '{tag}' has format version {found}; this morphlod reads versions 1 to {newest}: upgrade morphlod (0 never existed: the file is damaged)")]
    SectionVersion {
        tag: &'static str,
        found: u8,
        newest: u8,
    },
    #[error(
        "section 'SURF' sets flags {flags:#04x} that this morphlod does not know: upgrade morphlod"
    )]
    SurfaceFlags { flags: u8 },
    #[error(
        "section 'SURF': vertex {vertex} names topology vertex {topology}, but there are {count}"
    )]
    SurfaceTopology {
        vertex: usize,
        topology: u64,
        count: usize,
    },
    #[error("section 'SURF': {attribute} of vertex {vertex} is not finite")]
    NonFiniteAttribute {
        attribute: &'static str,
        vertex: usize,
    },
    #[error("section 'SURF' holds normal deltas for {found} targets, but the asset blends {targets}: the file is damaged")]
    NormalDeltaCount { found: usize, targets: usize },
    #[error("section 'SURF': the material name is not UTF-8")]
    MaterialName,
    #[error("section 'SURF': vertex {vertex} is a copy of vertex {first} (one topology vertex) but moves differently: a seam would open; rebuild the asset")]
    SurfaceWeld { vertex: usize, first: usize },
    #[error("frame {frame} does not fit the surface's seams: {source}; rebuild the asset")]
    SurfaceSteps { frame: usize, source: SeamError },
    #[error("section 'TEXR' names image format {code}, which is neither 0 (PNG) nor 1 (JPEG)")]
    TextureFormat { code: u8 },
    #[error("the file has a texture ('TEXR') but no surface ('SURF') to map it with: the file is damaged")]
    TextureWithoutSurface,
    #[error(
        "section 'SKIN' sets flags {flags:#04x} that this morphlod does not know: upgrade morphlod"
    )]
    SkinFlags { flags: u8 },
    #[error("section 'SKIN': {what} is code {code}, which names nothing: the file is damaged")]
    SkinCode { what: &'static str, code: u8 },
    #[error("section 'SKIN': {what} is not UTF-8: the file is damaged")]
    SkinName { what: String },
    #[error("section 'SKIN': {source}; rebuild the asset")]
    Skin { source: SkinError },
}
