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
//! The change stream is a flat `Vec<u16>` of variable-length numbers (one
//! `u16` below `0x8000`, else two); each step ends with its own length so the
//! runtime can walk the stream backward from its cursor without an offset table.

mod build;
mod runtime;

pub use build::BuildError;
pub use runtime::{Dirty, DirtyRange, LodState};

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
    stream: Vec<u16>,
    /// Triangles drawn at LOD 0.
    triangles_at_0: u32,
}

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
        self.stream.len() * 2
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

/// Appends `v` (below `2^31`) as one `u16` if it is below `0x8000`, else as
/// two, high part first with the top bit set.
fn push_var(out: &mut Vec<u16>, v: u32) {
    if v < 0x8000 {
        out.push(v as u16);
    } else {
        out.push(0x8000 | (v >> 16) as u16);
        out.push(v as u16);
    }
}

/// Reads a number written by [`push_var`] at `*at`, advancing `*at`.
fn read_var(stream: &[u16], at: &mut usize) -> u32 {
    let a = stream[*at];
    *at += 1;
    if a & 0x8000 == 0 {
        u32::from(a)
    } else {
        let b = stream[*at];
        *at += 1;
        (u32::from(a & 0x7FFF) << 16) | u32::from(b)
    }
}

/// Appends a step footer (the step's length in `u16`s, footer excluded),
/// readable backward: one `u16` below `0x8000`, else low part then high part
/// with the top bit set.
fn push_footer(out: &mut Vec<u16>, len: u32) {
    if len < 0x8000 {
        out.push(len as u16);
    } else {
        out.push(len as u16);
        out.push(0x8000 | (len >> 16) as u16);
    }
}

/// Reads the footer that ends just before `end`; returns the start of the step.
fn step_start_before(stream: &[u16], end: usize) -> usize {
    let last = stream[end - 1];
    if last & 0x8000 == 0 {
        end - 1 - last as usize
    } else {
        let len = ((u32::from(last & 0x7FFF)) << 16) | u32::from(stream[end - 2]);
        end - 2 - len as usize
    }
}
