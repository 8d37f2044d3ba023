//! The CPU mirror of an [`Object`](super::Object)'s index buffer, the word-level diff that
//! decides what [`Object::prepare`](super::Object::prepare) uploads (edits go to the mirror,
//! only the words whose value changed are marked), and the cost model that sends a frame's
//! changed spans as `queue.write_buffer` calls, as patches of the index scatter, or both
//! ([`plan_upload`]).
//!
//! One file a stage: `spans.rs` (span arithmetic: clip, sort and merge, join), `mirror.rs`
//! (the mirror and its diff, which collects the changed spans), `plan.rs` (the cost model's
//! choice of writes and scatter runs); this file holds the model's constants and [`Upload`].

mod mirror;
mod plan;
mod spans;

use std::ops::Range;

pub(super) use self::mirror::IndexMirror;
pub(super) use self::plan::{plan_upload, run_list_bytes};
pub(super) use self::spans::{clip, coalesce};

/// Changed spans at most this many bytes apart are uploaded as one write when a frame goes by
/// writes only ([`Object::set_merge_gap`](super::Object::set_merge_gap) changes it), and
/// changed indirect records this close share a write.
///
/// Each `queue.write_buffer` allocates a staging buffer and records a copy, so re-sending a
/// few unchanged words beats a second call; but a frame switch rewrites whole strips, mostly
/// to the values they already had, and a large gap re-sends those. 32 bytes (8 indices) is
/// the trade-off measured in docs/benchmarks-log.md, "Figures behind constants". A frame of many
/// spans goes through the scatter instead, which sends exactly the changed words.
pub const MERGE_GAP_BYTES: u64 = 32;

/// What one `queue.write_buffer` call costs beyond the bytes it carries, in bytes: the
/// constant of [`Object::prepare`](super::Object::prepare)'s cost model.
///
/// A call costs a fixed `c` (wgpu creates and maps a staging buffer per call and records a
/// copy: about 2–3 µs on lavapipe, e.g. 1.5 ms of `prepare` for 707 writes, the median frame
/// without a switch of the man → camel bench) plus `b` per byte (the copy into the staging
/// memory and the GPU's copy, about 0.25 ns, i.e. 0.25 ms per MB); this constant is `c/b`,
/// rounded down to a power of two. A word sent through the scatter costs 4 bytes plus its
/// run's header (8 bytes per run of up to 16 words; a single word 8 bytes in all) and no
/// call, a word inside a write 4 bytes and the call, so a write pays only for a run of more
/// than about 16,000 words.
pub const WRITE_CALL_BYTES: u64 = 8 * 1024;

/// What a frame's scatter costs beyond its run list, in bytes of the same model: the list's
/// own write plus a command buffer (encoder, one dispatch, `queue.submit`), taken as one more
/// call. A frame of one or two spans therefore goes by writes only.
pub(super) const SCATTER_CALL_BYTES: u64 = 2 * WRITE_CALL_BYTES;

/// Bytes of one run header (`scatter_runs`: `[first word, value offset and length]`, or a
/// single word and its value).
pub(super) const RUN_HEADER_BYTES: u64 = 8;

/// What one [`Object::prepare`](super::Object::prepare) sent to the GPU.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Upload {
    /// Byte ranges of the index buffer written directly, one per `write_buffer` call,
    /// ascending (words sent as patches are not in them).
    pub index_ranges: Vec<Range<u64>>,
    /// Index words sent through the scatter: the changed words of its runs, and the unchanged
    /// words between spans that a run joined (see [`WRITE_CALL_BYTES`]).
    pub scattered_words: u64,
    /// Bytes of the scatter's run list written: 8 per header (one per run of up to 16 words,
    /// padded to whole workgroups of 16 by repeating the last) and 4 per value (a single
    /// word's value rides in its header); 0 without a scatter.
    pub scatter_bytes: u64,
    /// Scatter dispatches, each after one `write_buffer` of its run list and submitted in its
    /// own command buffer by `prepare` (0 or 1).
    pub scatters: usize,
    /// Byte ranges of the indirect buffer written, one per `write_buffer` call, ascending.
    pub indirect_ranges: Vec<Range<u64>>,
    /// Bytes of uniforms written (0 or the whole block).
    pub uniform_bytes: u64,
    /// Bytes of morph-target offsets written (0, or when the weights changed 12 per vertex,
    /// 24 with normal deltas).
    pub offset_bytes: u64,
    /// `write_buffer` calls of the offsets: 0, 1 (positions), or 2 (and normals).
    pub offset_writes: usize,
    /// Bytes of texture written (the decoded base-colour texture, on the first prepare only).
    pub texture_bytes: u64,
}

impl Upload {
    /// Total bytes written.
    pub fn bytes(&self) -> u64 {
        self.geometry_bytes() + self.uniform_bytes + self.offset_bytes + self.texture_bytes
    }

    /// Bytes of index and indirect data written, patch lists included: what a LOD change
    /// cost, without the uniforms that every frame of an animation rewrites anyway.
    pub fn geometry_bytes(&self) -> u64 {
        let sum = |ranges: &[Range<u64>]| ranges.iter().map(|r| r.end - r.start).sum::<u64>();
        sum(&self.index_ranges) + sum(&self.indirect_ranges) + self.scatter_bytes
    }

    /// Number of `write_buffer` calls of index and indirect data, patch lists included.
    pub fn geometry_writes(&self) -> usize {
        self.index_ranges.len() + self.indirect_ranges.len() + self.scatters
    }

    /// Number of `queue.write_buffer` and `write_texture` calls.
    pub fn writes(&self) -> usize {
        self.geometry_writes()
            + usize::from(self.uniform_bytes > 0)
            + self.offset_writes
            + usize::from(self.texture_bytes > 0)
    }
}
