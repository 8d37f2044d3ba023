//! Recording the change lists: replay the collapse sequence over `S0`.
//!
//! Step `l` (collapse `u → w`): every position holding `u` in the live strips
//! is rewritten to `w` (and recorded), then every strip that held `u` is
//! reduced. The reduction rule set, with why each keeps the drawn multiset:
//!
//! * An index is *needed* if some non-degenerate window contains it. A maximal
//!   run of unneeded indices touches only degenerate windows, so cutting it
//!   destroys nothing drawn. What the cut can break is (a) the parity of every
//!   later window, which flips if the removed length is odd, and (b) the
//!   windows created across the junction.
//! * Trailing run: removed whole (no later windows, no junction).
//! * Leading run: removed in an even length (the kept odd index is unneeded,
//!   so the first window stays degenerate; later windows keep parity).
//! * Interior run `A B [run] C D`: replaced by `r` with `|r| ≡ |run| (mod 2)`
//!   and `|r| < |run|`, choosing the first of `[]`, `[B C]` (even) or `[B]`,
//!   `[C]`, `[B C C]` (odd) for which every window of `A B r C D` is
//!   degenerate. `[B C]` and `[B C C]` always are (`A B B C C D`); `[]` covers
//!   Skip Strips' `(ab)+ → ab` and `(aa)+ → aa`. Unneeded runs stay unneeded
//!   and needed indices stay needed, so one right-to-left pass suffices.
//!
//! The runtime applies these records blindly; the oracle (tests/suite/oracle.rs)
//! checks the drawn multiset against the reference mesh after every step.
//!
//! Alongside, the build tracks where every buffer entry comes from (`Tokens`):
//! an `S0` slot or a copy made by a resize, with the LOD range it is alive in
//! and one order per strip of every entry ever alive. That is what lets the
//! runtime rebuild any LOD of a frame in one pass, bit-identical to stepping
//! (tests/suite/oracle_deform.rs compares the two).
//!
//! One file a stage, in the order they run (this file holds the errors, the replay's state
//! and its loop, [`frame`]):
//! * `layout`: `S0` checked and taken as the layout;
//! * `reduce`: the reduction rule set, one strip's unneeded runs cut and recorded;
//! * `replay`: one collapse replayed over the live strips (rewrites, strip sets, reductions,
//!   the step's record);
//! * `tables`: the frame's tables from the replay (lifetimes, deaths, the tail), narrowed.

mod layout;
mod reduce;
mod replay;
mod tables;
#[cfg(test)]
mod tests;

use thiserror::Error;

use super::{FrameChanges, StripLayout};
use crate::collapse::{CollapseSequence, SequenceError};
pub(super) use layout::layout;

/// Why a model cannot be built from these strips and this sequence.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ChangeListError {
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    #[error("strip offsets are malformed at entry {entry}: offsets must start at 0, never decrease and end at the index count {indices}; rebuild the strips with strip::stripify")]
    BadOffsets { entry: usize, indices: usize },
    #[error("strip index {index} at position {position} is not a vertex of the {vertices}-vertex mesh the sequence was built for; strips and sequence must come from the same mesh")]
    IndexOutOfRange {
        position: usize,
        index: u32,
        vertices: usize,
    },
    #[error("the collapse sequence is for {sequence} vertices but the strips index a {strips}-vertex mesh; build both from the same mesh")]
    VertexCount { sequence: usize, strips: usize },
    #[error("the vertex count is {vertices}, above the supported {limit}; split the mesh")]
    TooManyVertices { vertices: usize, limit: usize },
    #[error("the strip index count is {indices}, above the supported {limit}; split the mesh")]
    TooManyIndices { indices: usize, limit: usize },
}

fn degenerate(a: u32, b: u32, c: u32) -> bool {
    a == b || b == c || a == c
}

fn live_windows(strip: &[u32]) -> u32 {
    strip
        .windows(3)
        .filter(|w| !degenerate(w[0], w[1], w[2]))
        .count() as u32
}

/// The build's view of entry lifetimes: a token per strip entry (`S0` slots
/// are tokens `0..|S0|`, copies follow), kept parallel to the live strips, and
/// the order of all tokens ever alive as a linked list per strip. A copy is
/// linked right after the last token of the run it replaces: every token
/// between there and the run's right neighbour is dead for good, so the order
/// of the tokens alive at any LOD is the strip's order at that LOD.
struct Tokens {
    /// Token at each buffer position (same layout as the buffer).
    at: Vec<u32>,
    /// Next token in the strip's order, or `NEVER` at the end.
    next: Vec<u32>,
    /// Death LOD of every token (`NEVER` while alive).
    death: Vec<u32>,
    /// `(value, birth)` of the copy tokens: token `|S0| + i` is `copies[i]`.
    copies: Vec<(u32, u32)>,
}

/// The change lists of one frame: replay `seq` over `S0`, one named stage after another
/// per collapse (the module docs give the rules each stage follows).
pub(super) fn frame(
    layout: &StripLayout,
    seq: &CollapseSequence,
) -> Result<FrameChanges, ChangeListError> {
    check_sequence(layout, seq)?;
    let mut replay = Replay::new(layout, seq);
    for (step, c) in seq.collapses.iter().enumerate() {
        replay.mark_cursor(step);
        replay.rewrite(c.u, c.w);
        replay.merge_strip_sets(c.u, c.w);
        let (resizes, removed) = replay.reduce_touched(step);
        replay.emit_step(step, resizes, removed);
    }
    Ok(replay.finish(layout, seq))
}

/// A sequence valid on its own and made for the layout's vertex count.
fn check_sequence(layout: &StripLayout, seq: &CollapseSequence) -> Result<(), ChangeListError> {
    seq.validate()?;
    if seq.vertex_count != layout.vertex_count {
        return Err(ChangeListError::VertexCount {
            sequence: seq.vertex_count as usize,
            strips: layout.vertex_count as usize,
        });
    }
    Ok(())
}

/// The state of one frame's replay over `S0`: the live strips, where each entry came from,
/// and the stream recorded so far, with scratch buffers reused from step to step.
struct Replay<'a> {
    region_offsets: &'a [u32],
    /// The index buffer (all regions at their `S0` capacity).
    buf: Vec<u32>,
    /// Live length of each strip.
    lens: Vec<usize>,
    tokens: Tokens,
    /// Vertex → sorted strips that may hold it (a superset: merged on collapse).
    strips_of: Vec<Vec<u32>>,
    stream: Vec<u8>,
    cursors: Vec<u32>,
    /// Triangles drawn after each step (`triangles[0]`: at `S0`).
    triangles: Vec<u32>,
    /// This step's rewrite groups and resize records.
    rewrites: Vec<u8>,
    resizes: Vec<u8>,
    /// This step's strips that held `u`, with their live triangles before the step.
    touched: Vec<(u32, u32)>,
    positions: Vec<u32>,
    needed: Vec<bool>,
    merged: Vec<u32>,
}
