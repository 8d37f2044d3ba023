//! The LodStrips model for one collapse sequence over the common strips `S0`:
//! change lists recorded by replaying the sequence over the strips
//! ([`build`]), and the runtime that applies them in both directions to an
//! index buffer laid out as one fixed region per strip ([`runtime`]).
//!
//! Each LOD step `l` (collapse `u → w`) is recorded as
//! * rewrites: the positions in the strips that hold `u` at LOD `l`
//!   (coarsening writes `w` there, refining writes `u` back), and
//! * resizes: degenerate runs cut out of a strip, each replaced by at most three
//!   copies of its neighbours. Refining restores the run from the record.
//!
//! Why a resize keeps every drawn triangle (see [`build`] for the rule set):
//! a run is removed only if every window touching it is degenerate, the
//! replacement has the same length parity (so every later window keeps its
//! parity, hence its orientation), and every window created at the junction is
//! degenerate. Leading runs are removed in even lengths, trailing runs whole.
//!
//! The change stream is a flat `Vec<u8>` of LEB128 numbers: rewrite positions
//! delta-coded per strip, removed indices as zigzag differences to their left
//! neighbour. Each step ends with its own length, readable backward, so the
//! runtime walks the stream in both directions from a cursor without an
//! offset table.

mod build;
mod runtime;

pub use build::BuildError;
pub use runtime::{Dirty, DirtyRange, LodError, LodState};

use crate::strip::Strips;

/// Replacement kinds of a resize: the run `s[i..i+len]` is replaced by copies
/// of its neighbours `B = s[i-1]` and `C = s[i+len]`.
const KIND_NONE: u16 = 0;
const KIND_B: u16 = 1;
const KIND_C: u16 = 2;
const KIND_BC: u16 = 3;
const KIND_BCC: u16 = 4;

/// Number of indices a replacement kind writes.
fn kind_len(kind: u16) -> usize {
    match kind {
        KIND_NONE => 0,
        KIND_B | KIND_C => 1,
        KIND_BC => 2,
        _ => 3,
    }
}

/// The model: the region layout of `S0`, the collapse targets and the change stream.
#[derive(Clone, Debug, Default)]
pub struct LodStrips {
    /// Region `i` of the index buffer is `region_offsets[i]..region_offsets[i+1]`
    /// (the length of strip `i` in `S0`).
    region_offsets: Vec<u32>,
    /// `S0` itself: the buffer contents at LOD 0.
    s0: Vec<u32>,
    /// `(u, w)` of each step.
    collapses: Vec<[u32; 2]>,
    /// The change stream, see the module docs.
    stream: Vec<u8>,
    /// Triangles drawn at LOD 0.
    triangles_at_0: u32,
    /// Identifies the model a [`LodState`] was made for (clones share it).
    id: u64,
}

/// Source of model ids: a state must only follow the stream it was made for.
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

impl LodStrips {
    /// Records the change lists of `seq` over the strips `s0`.
    pub fn build(
        s0: &Strips,
        seq: &crate::collapse::CollapseSequence,
    ) -> Result<LodStrips, BuildError> {
        build::build(s0, seq)
    }

    /// The highest LOD (number of collapses).
    pub fn max_lod(&self) -> usize {
        self.collapses.len()
    }

    /// Number of strips, i.e. of index-buffer regions (one draw each).
    pub fn strip_count(&self) -> usize {
        self.region_offsets.len().saturating_sub(1)
    }

    /// Region offsets into the index buffer (`strip_count() + 1` entries).
    pub fn region_offsets(&self) -> &[u32] {
        &self.region_offsets
    }

    /// Bytes of the change lists alone (the stream).
    pub fn change_bytes(&self) -> usize {
        self.stream.len()
    }

    /// Bytes of the whole model: `S0`, its region table, the collapse targets
    /// and the change lists.
    pub fn byte_size(&self) -> usize {
        self.s0.len() * 4
            + self.region_offsets.len() * 4
            + self.collapses.len() * 8
            + self.change_bytes()
            + 4
    }
}

/// Appends `v` as LEB128: 7 bits per byte, low group first, top bit set on
/// every byte but the last. Positions and deltas are mostly below 128, so
/// most numbers take one byte.
fn push_var(out: &mut Vec<u8>, mut v: u32) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Reads a number written by [`push_var`] at `*at`, advancing `*at`.
fn read_var(stream: &[u8], at: &mut usize) -> u32 {
    let mut v = 0u32;
    let mut shift = 0;
    loop {
        let b = stream[*at];
        *at += 1;
        v |= u32::from(b & 0x7F) << shift;
        if b & 0x80 == 0 {
            return v;
        }
        shift += 7;
    }
}

/// Step header: counts of rewrite groups, resizes and removed triangles. The
/// common small case (most collapses touch a few strips and remove two
/// triangles) fits one byte; `0xFF` escapes to three numbers.
fn push_header(out: &mut Vec<u8>, groups: u32, resizes: u32, removed: u32) {
    if groups < 15 && resizes < 4 && removed < 4 {
        out.push((groups | resizes << 4 | removed << 6) as u8);
    } else {
        out.push(0xFF);
        push_var(out, groups);
        push_var(out, resizes);
        push_var(out, removed);
    }
}

fn read_header(stream: &[u8], at: &mut usize) -> (u32, u32, u32) {
    let h = stream[*at];
    *at += 1;
    if h != 0xFF {
        let h = u32::from(h);
        (h & 15, (h >> 4) & 3, h >> 6)
    } else {
        let groups = read_var(stream, at);
        let resizes = read_var(stream, at);
        (groups, resizes, read_var(stream, at))
    }
}

/// Rewrite group head: the strip as a difference to the previous group's,
/// and the position count folded into the low two bits (1 to 3, or 4 plus a
/// second number).
fn push_group(out: &mut Vec<u8>, strip_delta: u32, count: u32) {
    let c = (count - 1).min(3);
    push_var(out, strip_delta << 2 | c);
    if c == 3 {
        push_var(out, count - 4);
    }
}

fn read_group(stream: &[u8], at: &mut usize) -> (u32, u32) {
    let v = read_var(stream, at);
    let c = v & 3;
    let count = if c == 3 {
        4 + read_var(stream, at)
    } else {
        c + 1
    };
    (v >> 2, count)
}

/// Bytes [`push_var`] and [`push_footer`] take for `v`.
fn var_len(v: u32) -> usize {
    (32 - (v | 1).leading_zeros() as usize).div_ceil(7)
}

/// A removed index stored as the zigzag difference to the index before it:
/// degenerate runs repeat their neighbours, so this is mostly 0 (one byte).
fn zigzag(value: u32, previous: u32) -> u32 {
    let d = value.wrapping_sub(previous) as i32;
    ((d << 1) ^ (d >> 31)) as u32
}

fn unzigzag(z: u32, previous: u32) -> u32 {
    let d = ((z >> 1) as i32) ^ -((z & 1) as i32);
    previous.wrapping_add(d as u32)
}

/// Appends a step footer: the step's length in bytes, footer excluded, as
/// LEB128 groups written high first, so that it reads backward from the end:
/// the last byte holds the low group, its top bit says whether more precede.
fn push_footer(out: &mut Vec<u8>, len: u32) {
    let groups = var_len(len);
    for g in (0..groups).rev() {
        let bits = ((len >> (7 * g)) & 0x7F) as u8;
        out.push(if g + 1 < groups { bits | 0x80 } else { bits });
    }
}

/// Reads the footer that ends just before `end`; returns the start of the step.
fn step_start_before(stream: &[u8], end: usize) -> usize {
    let mut at = end - 1;
    let mut len = 0usize;
    let mut shift = 0;
    loop {
        let b = stream[at];
        len |= usize::from(b & 0x7F) << shift;
        if b & 0x80 == 0 {
            return at - len;
        }
        shift += 7;
        at -= 1;
    }
}
