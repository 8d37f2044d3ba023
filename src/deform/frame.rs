//! One sampled frame: its change lists over the shared layout and its LOD tables (the
//! running maximum error, the step boundaries of a surface), built from its collapse
//! sequence and checked against the poses.

use super::DeformError;
use crate::collapse::CollapseSequence;
use crate::lodstrips::increasing::Increasing;
use crate::lodstrips::{FrameChanges, StripLayout};
use crate::seams::{check_steps, StepBoundaries, Wedges};

/// One sampled frame: its change lists and its LOD tables.
#[derive(Clone, Debug)]
pub(super) struct Frame {
    pub(super) changes: FrameChanges,
    /// `errors[l]`, the largest collapse error among the first `l` as a
    /// distance (square root of the recorded mean squared distance), never
    /// decreases and `errors[0] = 0`; it is kept only where it grows: from LOD
    /// `error_steps[i]` on (up to the next entry) it is the square root of the
    /// recorded error whose `f32` bits are `error_keys[i] << error_shift`
    /// (both sequences strictly increasing, each in the smaller of an array and
    /// a bitmap over its range, [`Increasing`]).
    /// The recorded errors are positive there, so the keys grow with the
    /// errors; built assets round errors to bfloat16 (`quantize_error`), whose
    /// low 16 bits are zero, and then store the top 16 bits only
    /// (`error_shift = 16`); other errors keep all 32 (`error_shift = 0`).
    error_steps: Increasing,
    error_keys: Increasing,
    error_shift: u32,
    /// For an asset with a surface: the LODs that fall between two topology collapses,
    /// the only ones shown ([`crate::seams`]); `None`: every LOD.
    pub(super) boundaries: Option<StepBoundaries>,
}

impl Frame {
    /// The distance an error key stands for (`errors[error_steps[i]]` for
    /// `error_keys[i]`, see the field docs).
    fn error_value(&self, key: u32) -> f32 {
        f32::from_bits(key << self.error_shift).sqrt()
    }

    /// The largest collapse error among the first `l` as a distance (`errors[l]` of the
    /// field docs): what a [`Lod::MaxError`](super::Lod::MaxError) is compared with.
    pub(super) fn error_at(&self, l: usize) -> f32 {
        let l = u32::try_from(l).unwrap_or(u32::MAX);
        match self.error_steps.count_at_most(l) {
            0 => 0.0,
            i => self.error_value(self.error_keys.get(i - 1)),
        }
    }

    /// The coarsest LOD whose collapse errors, as distances, are all `≤ e`
    /// (full detail when `e < 0`): the LOD before the first growth past `e`.
    pub(super) fn coarsest_within(&self, e: f32) -> usize {
        if e.is_nan() || e < 0.0 {
            return 0;
        }
        // The largest key whose distance is within `e`, from the key of `e²` (at most a
        // rounding away), then the keys up to it: integer compares, no square root each.
        let max = u32::MAX >> self.error_shift;
        let mut key = ((e * e).to_bits() >> self.error_shift).min(max);
        // (Key 0 is the distance 0, within every `e` here.)
        while key > 0 && self.error_value(key) > e {
            key -= 1;
        }
        while key < max && self.error_value(key + 1) <= e {
            key += 1;
        }
        let lo = self.error_keys.count_at_most(key);
        if lo < self.error_steps.len() {
            self.error_steps.get(lo) as usize - 1
        } else {
            self.changes.max_lod()
        }
    }

    pub(super) fn byte_size(&self) -> usize {
        self.changes.byte_size()
            + self.error_steps.byte_size()
            + self.error_keys.byte_size()
            + self
                .boundaries
                .as_ref()
                .map_or(0, StepBoundaries::byte_size)
    }
}

pub(super) fn build_frame(
    layout: &StripLayout,
    frame: usize,
    seq: &CollapseSequence,
    topology: Option<&(&[u32], Wedges)>,
) -> Result<Frame, DeformError> {
    if seq.vertex_count as usize != layout.vertex_count() {
        return Err(DeformError::FrameVertexCount {
            frame,
            sequence: seq.vertex_count as usize,
            vertices: layout.vertex_count(),
        });
    }
    seq.validate()
        .map_err(|source| DeformError::Sequence { frame, source })?;
    let changes =
        FrameChanges::build(layout, seq).map_err(|source| DeformError::Frame { frame, source })?;
    let boundaries = match topology {
        Some((of_vertex, wedges)) => {
            check_steps(seq, wedges, of_vertex)
                .map_err(|source| DeformError::Seams { frame, source })?;
            Some(StepBoundaries::new(seq, of_vertex))
        }
        None => None,
    };
    // The LODs where the running maximum grows (as a distance) and its recorded value there.
    let (mut steps, mut keys) = (Vec::new(), Vec::new());
    let mut distance = 0.0f32;
    for (l, e) in seq.errors().into_iter().enumerate().skip(1) {
        let d = e.max(0.0).sqrt();
        if d > distance {
            distance = d;
            steps.push(l as u32);
            keys.push(e.to_bits());
        }
    }
    let error_shift = if keys.iter().all(|k| k & 0xFFFF == 0) {
        16
    } else {
        0
    };
    Ok(Frame {
        changes,
        error_steps: Increasing::new(&steps),
        error_keys: Increasing::new(&keys.iter().map(|k| k >> error_shift).collect::<Vec<_>>()),
        error_shift,
        boundaries,
    })
}
