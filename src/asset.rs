//! The `.mlod` asset: everything the runtime needs for one deforming object.
//!
//! It stores the two GPU poses `V(0)`, `V(1)`, the common strips `S0` and one
//! collapse sequence per sampled frame. The change lists are not stored: they
//! are a deterministic function of `S0` and a frame's sequence, and replaying
//! a sequence at load time is cheap next to the storage the change lists would
//! take (see BENCHMARKS.md for both figures).

use crate::collapse::CollapseSequence;
use crate::strip::Strips;

/// One deforming object's LOD data, as built by the per-frame builder and
/// stored in a `.mlod` file. Frame `k` of `frames.len()` samples `t_k = k / (|r| - 1)`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Asset {
    pub v0: Vec<[f32; 3]>,
    pub v1: Vec<[f32; 3]>,
    pub s0: Strips,
    pub frames: Vec<CollapseSequence>,
}
