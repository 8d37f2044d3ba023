//! The CPU mirror of an [`Object`](super::Object)'s index buffer and the word-level diff that
//! decides what [`Object::prepare`](super::Object::prepare) uploads: edits go to the mirror,
//! only the words whose value changed are marked, and marked spans closer than the merge gap
//! (or, when turned on, than one call's cost in bytes, [`WRITE_CALL_BYTES`]) are sent as one
//! `queue.write_buffer`.

use std::ops::Range;

/// Changed spans at most this many bytes apart are uploaded as one write by default
/// ([`Object::set_merge_gap`](super::Object::set_merge_gap) changes it).
///
/// Each `queue.write_buffer` allocates a staging buffer and records a copy, so re-sending a
/// few unchanged words beats a second call; but a frame switch rewrites whole strips, mostly
/// to the values they already had, and a large gap re-sends those. 32 bytes (8 indices) is
/// the trade-off measured in BENCHMARKS.md ("Figures behind constants"); with
/// [`WRITE_CALL_BYTES`]'s joining on, gaps below that join anyway.
pub const MERGE_GAP_BYTES: u64 = 32;

/// What one `queue.write_buffer` call costs beyond the bytes it carries, in bytes:
/// [`Object::prepare`](super::Object::prepare)'s cost model for a buffer's changed spans.
///
/// A call costs a fixed `c` (wgpu creates and maps a staging buffer per call and records a
/// copy: about 2–3 µs on lavapipe, e.g. 1.5 ms of `prepare` for 707 writes, the median frame
/// without a switch of the man → camel bench) plus `b` per byte (the copy into the staging
/// memory and the GPU's copy, about 0.25 ns, i.e. 0.25 ms per MB). Joining two neighbouring
/// spans into one write re-sends the `g` unchanged bytes between them and saves a call, so it
/// pays when `g < c/b`; this constant is `c/b`, rounded down to a power of two. Dense spans (a
/// frame switch rewrites thousands spread over the buffer) become one write of at most the
/// buffer, O(bytes) instead of O(spans); an edit far from others keeps its exact bytes.
///
/// Off by default ([`Object::set_write_call_bytes`](super::Object::set_write_call_bytes)
/// turns it on): joined writes re-send unchanged words, 43% of the index buffer per frame on
/// the head's exponential sweep against issue 5's goal of at most 5%.
pub const WRITE_CALL_BYTES: u64 = 8 * 1024;

/// What one [`Object::prepare`](super::Object::prepare) sent to the GPU.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Upload {
    /// Byte ranges of the index buffer written, one per `write_buffer` call, ascending.
    pub index_ranges: Vec<Range<u64>>,
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

    /// Bytes of index and indirect data written: what a LOD change cost, without the uniforms
    /// that every frame of an animation rewrites anyway.
    pub fn geometry_bytes(&self) -> u64 {
        let sum = |ranges: &[Range<u64>]| ranges.iter().map(|r| r.end - r.start).sum::<u64>();
        sum(&self.index_ranges) + sum(&self.indirect_ranges)
    }

    /// Number of `queue.write_buffer` and `write_texture` calls.
    pub fn writes(&self) -> usize {
        self.index_ranges.len()
            + self.indirect_ranges.len()
            + usize::from(self.uniform_bytes > 0)
            + self.offset_writes
            + usize::from(self.texture_bytes > 0)
    }
}

/// The whole index buffer as the GPU will hold it after the next upload, and the spans
/// changed since the last one.
pub(super) struct IndexMirror {
    /// CPU mirror of the whole index buffer (equal to the GPU after prepare).
    pub(super) indices: Vec<u32>,
    /// Changed index spans (buffer positions) since the last prepare, unsorted.
    dirty: Vec<Range<u32>>,
    merge_gap_bytes: u64,
    /// A write call's cost in bytes for `plan_writes` (0: off).
    write_call_bytes: u64,
}

impl IndexMirror {
    pub(super) fn new(indices: Vec<u32>) -> Self {
        IndexMirror {
            indices,
            dirty: Vec::new(),
            merge_gap_bytes: MERGE_GAP_BYTES,
            write_call_bytes: 0,
        }
    }

    pub(super) fn merge_gap_bytes(&self) -> u64 {
        self.merge_gap_bytes
    }

    pub(super) fn set_merge_gap(&mut self, bytes: u64) {
        self.merge_gap_bytes = bytes;
    }

    pub(super) fn write_call_bytes(&self) -> u64 {
        self.write_call_bytes
    }

    pub(super) fn set_write_call_bytes(&mut self, bytes: u64) {
        self.write_call_bytes = bytes;
    }

    /// The merge gap in indices.
    fn gap_indices(&self) -> u32 {
        u32::try_from(self.merge_gap_bytes / 4).unwrap_or(u32::MAX)
    }

    /// Writes `new(i)` at buffer positions `at..at + len` and marks the words that changed.
    pub(super) fn write(&mut self, at: u32, len: u32, new: impl Fn(usize) -> u32) {
        let gap = self.gap_indices();
        let span = at as usize..(at + len) as usize;
        diff_copy(&mut self.indices[span], at, gap, &mut self.dirty, new);
    }

    /// The changed spans, coalesced, as index ranges; empties the list.
    pub(super) fn take_spans(&mut self) -> Vec<Range<u32>> {
        let gap = self.gap_indices();
        coalesce(&mut self.dirty, gap)
    }
}

/// The part of `range` below `live` (empty when it starts past it).
pub(super) fn clip(range: Range<u32>, live: u32) -> Range<u32> {
    range.start.min(live)..range.end.min(live)
}

/// Writes `new(i)` into `mirror[i]` for every `i` and pushes the changed positions onto
/// `spans` as buffer positions (`at` is the buffer position of `mirror[0]`). A run of more
/// than `gap` unchanged words between two changes closes a span: a frame switch rewrites
/// whole strips, mostly to the values they had, and should upload the words that differ, not
/// everything from the first to the last. Runs of at most `gap` stay inside a span, as
/// [`coalesce`] would merge them anyway.
fn diff_copy(
    mirror: &mut [u32],
    at: u32,
    gap: u32,
    spans: &mut Vec<Range<u32>>,
    new: impl Fn(usize) -> u32,
) {
    // The open span, as positions in `mirror`: first and last changed.
    let mut open: Option<(usize, usize)> = None;
    for (i, slot) in mirror.iter_mut().enumerate() {
        let value = new(i);
        if *slot == value {
            continue;
        }
        *slot = value;
        open = match open {
            Some((first, last)) if i - last - 1 <= gap as usize => Some((first, i)),
            Some((first, last)) => {
                spans.push(at + first as u32..at + last as u32 + 1);
                Some((i, i))
            }
            None => Some((i, i)),
        };
    }
    if let Some((first, last)) = open {
        spans.push(at + first as u32..at + last as u32 + 1);
    }
}

/// The writes that send `spans` (ascending, disjoint, positions of `unit`-byte elements) at
/// the least cost under [`WRITE_CALL_BYTES`]'s model: two neighbouring spans become one write
/// when the unchanged elements between them cost less to re-send than the call they save.
/// Each gap is decided alone, so dense spans (a frame switch) join into one write from the
/// first to the last, while spans far apart keep their own writes and exact bytes.
/// `call_bytes` is the call's cost in bytes; 0 keeps every span its own write.
pub(super) fn plan_writes(
    mut spans: Vec<Range<u32>>,
    unit: u64,
    call_bytes: u64,
) -> Vec<Range<u32>> {
    // A gap of `g` elements joins when `g * unit < call_bytes`.
    let gap = u32::try_from(call_bytes.div_ceil(unit).saturating_sub(1)).unwrap_or(u32::MAX);
    coalesce(&mut spans, gap)
}

/// Sorts and merges spans that overlap or lie at most `gap` elements apart, and empties `spans`.
pub(super) fn coalesce(spans: &mut Vec<Range<u32>>, gap: u32) -> Vec<Range<u32>> {
    spans.sort_unstable_by_key(|span| span.start);
    let mut merged: Vec<Range<u32>> = Vec::with_capacity(spans.len());
    for span in spans.drain(..) {
        match merged.last_mut() {
            Some(last) if span.start <= last.end.saturating_add(gap) => {
                last.end = last.end.max(span.end);
            }
            _ => merged.push(span),
        }
    }
    merged
}

#[cfg(test)]
mod tests {
    use super::{coalesce, diff_copy, plan_writes, WRITE_CALL_BYTES};

    #[test]
    fn plan_writes_joins_spans_only_when_a_call_costs_more_than_the_gap() {
        assert_eq!(plan_writes(vec![], 4, WRITE_CALL_BYTES), vec![]);
        // 0: off, every span is its own write.
        assert_eq!(plan_writes(vec![0..1, 2..3], 4, 0), vec![0..1, 2..3]);
        assert_eq!(
            plan_writes(vec![3..5, 5000..5001], 4, WRITE_CALL_BYTES),
            vec![3..5, 5000..5001]
        );
        // 4-byte indices: a gap of one call's worth of bytes stays (equal cost keeps the exact
        // bytes), one index less joins.
        let call = (WRITE_CALL_BYTES / 4) as u32;
        assert_eq!(
            plan_writes(vec![0..1, 1 + call..2 + call], 4, WRITE_CALL_BYTES),
            vec![0..1, 1 + call..2 + call]
        );
        assert_eq!(
            plan_writes(
                vec![0..1, call..1 + call, 2 * call..1 + 2 * call],
                4,
                WRITE_CALL_BYTES
            ),
            vec![0..1 + 2 * call]
        );
        // 20-byte records: WRITE_CALL_BYTES / 20 = 409.6, so 410 records apart stay apart.
        assert_eq!(
            plan_writes(vec![0..1, 411..412], 20, WRITE_CALL_BYTES),
            vec![0..1, 411..412]
        );
        assert_eq!(
            plan_writes(vec![0..1, 410..411], 20, WRITE_CALL_BYTES),
            vec![0..411]
        );
    }

    #[test]
    fn coalesce_merges_overlapping_and_close_spans_only() {
        let mut spans = vec![10..12, 0..4, 3..6, 30..31, 12..13];
        assert_eq!(coalesce(&mut spans, 0), vec![0..6, 10..13, 30..31]);
        assert!(spans.is_empty());
        let mut spans = vec![10..12, 0..4, 30..31];
        assert_eq!(coalesce(&mut spans, 6), vec![0..12, 30..31]);
        let mut spans = vec![5..9, 6..7];
        assert_eq!(coalesce(&mut spans, 0), vec![5..9]);
    }

    #[test]
    fn diff_copy_splits_at_unchanged_runs_longer_than_the_gap() {
        let old = [0u32, 1, 2, 3, 4, 5, 6, 7, 8, 9];
        let new = [0u32, 9, 2, 9, 4, 5, 6, 9, 8, 0];
        // Spans as (start, end) buffer positions.
        let expected: [(u32, &[(u32, u32)]); 3] = [
            (0, &[(101, 102), (103, 104), (107, 108), (109, 110)]),
            (1, &[(101, 104), (107, 110)]),
            (3, &[(101, 110)]),
        ];
        for (gap, expected) in expected {
            let mut mirror = old;
            let mut spans = Vec::new();
            diff_copy(&mut mirror, 100, gap, &mut spans, |i| new[i]);
            assert_eq!(mirror, new);
            let spans: Vec<(u32, u32)> = spans.iter().map(|s| (s.start, s.end)).collect();
            assert_eq!(spans, expected, "gap {gap}");
        }
        let mut mirror = old;
        let mut spans = Vec::new();
        diff_copy(&mut mirror, 0, 0, &mut spans, |i| old[i]);
        assert!(spans.is_empty(), "an unchanged copy marks nothing");
    }
}
