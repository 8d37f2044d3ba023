//! The CPU mirror of an [`Object`](super::Object)'s index buffer, the word-level diff that
//! decides what [`Object::prepare`](super::Object::prepare) uploads (edits go to the mirror,
//! only the words whose value changed are marked), and the cost model that sends a frame's
//! changed spans as `queue.write_buffer` calls, as patches of the index scatter, or both
//! ([`plan_upload`]).

use std::ops::Range;

use super::scatter::{RUN_GROUP, RUN_WORDS};

/// Changed spans at most this many bytes apart are uploaded as one write when a frame goes by
/// writes only ([`Object::set_merge_gap`](super::Object::set_merge_gap) changes it), and
/// changed indirect records this close share a write.
///
/// Each `queue.write_buffer` allocates a staging buffer and records a copy, so re-sending a
/// few unchanged words beats a second call; but a frame switch rewrites whole strips, mostly
/// to the values they already had, and a large gap re-sends those. 32 bytes (8 indices) is
/// the trade-off measured in BENCHMARKS.md ("Figures behind constants"). A frame of many
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

/// The whole index buffer as the GPU will hold it after the next upload, and the words
/// changed since the last one.
pub(super) struct IndexMirror {
    /// CPU mirror of the whole index buffer (equal to the GPU after prepare).
    pub(super) indices: Vec<u32>,
    /// Spans of changed words (buffer positions) since the last prepare, unsorted; every
    /// word of a span changed.
    dirty: Vec<Range<u32>>,
    merge_gap_bytes: u64,
}

impl IndexMirror {
    pub(super) fn new(indices: Vec<u32>) -> Self {
        IndexMirror {
            indices,
            dirty: Vec::new(),
            merge_gap_bytes: MERGE_GAP_BYTES,
        }
    }

    pub(super) fn merge_gap_bytes(&self) -> u64 {
        self.merge_gap_bytes
    }

    pub(super) fn set_merge_gap(&mut self, bytes: u64) {
        self.merge_gap_bytes = bytes;
    }

    /// Writes `new(i)` at buffer positions `at..at + len` and marks the words that changed.
    pub(super) fn write(&mut self, at: u32, len: u32, new: impl Fn(usize) -> u32) {
        let span = at as usize..(at + len) as usize;
        diff_copy(&mut self.indices[span], at, &mut self.dirty, new);
    }

    /// Writes every `(at, values)` of `writes` as [`write`](Self::write) would, one after the
    /// other: the same mirror and the same changed spans in the same order. Writes that lie
    /// ascending and apart, of at least [`PARALLEL_WORDS`] words in all, are diffed in
    /// parallel (the calling thread and the pool's, `par::map`) in chunks of consecutive
    /// writes (one object's frame switch: a few hundred thousand words); each chunk collects
    /// its spans and they are appended in order.
    /// `writes` is walked once to count and once to write, and collected only for the pool:
    /// an ordinary frame allocates nothing here.
    pub(super) fn write_all<'a>(&mut self, writes: impl Iterator<Item = (u32, &'a [u32])> + Clone) {
        let threads = rayon::current_num_threads();
        // The words of `writes` where they go on the pool.
        let pooled = (threads > 1 && crate::par::may_split())
            .then(|| {
                let (mut words, mut apart, mut end) = (0usize, true, 0usize);
                for (at, values) in writes.clone() {
                    apart &= end <= at as usize;
                    end = at as usize + values.len();
                    words += values.len();
                }
                (apart && words >= PARALLEL_WORDS).then_some(words)
            })
            .flatten();
        if let Some(words) = pooled {
            let writes: Vec<(u32, &[u32])> = writes.collect();
            self.write_in_chunks(&writes, crate::par::piece_len(words, PARALLEL_WORDS / 4));
        } else {
            for (at, values) in writes {
                self.write(at, values.len() as u32, |i| values[i]);
            }
        }
    }

    /// [`write_all`](Self::write_all) of ascending, disjoint `writes` cut into chunks of
    /// consecutive writes of about `chunk_words` words, diffed in parallel.
    fn write_in_chunks(&mut self, writes: &[(u32, &[u32])], chunk_words: usize) {
        // Each chunk: its writes, and the part of the mirror from its first write's position
        // to its last write's end.
        let mut chunks = Vec::new();
        let (mut rest, mut base) = (&mut self.indices[..], 0usize);
        let mut first = 0;
        while first < writes.len() {
            let (mut last, mut words) = (first, 0);
            while last < writes.len() && (last == first || words < chunk_words) {
                words += writes[last].1.len();
                last += 1;
            }
            let from = writes[first].0 as usize;
            let (end_at, end_values) = writes[last - 1];
            let to = end_at as usize + end_values.len();
            let (_, tail) = std::mem::take(&mut rest).split_at_mut(from - base);
            let (part, tail) = tail.split_at_mut(to - from);
            chunks.push((&writes[first..last], from, part));
            (rest, base) = (tail, to);
            first = last;
        }
        let spans: Vec<Vec<Range<u32>>> = crate::par::map(chunks, |(writes, from, part)| {
            let mut spans = Vec::new();
            for &(at, values) in writes {
                let offset = at as usize - from;
                diff_copy(
                    &mut part[offset..offset + values.len()],
                    at,
                    &mut spans,
                    |i| values[i],
                );
            }
            spans
        });
        for chunk in spans {
            self.dirty.extend(chunk);
        }
    }

    /// The changed spans, sorted and merged where they overlap or touch; empties the list.
    pub(super) fn take_spans(&mut self) -> Vec<Range<u32>> {
        coalesce(&mut self.dirty, 0)
    }
}

/// Words of one [`IndexMirror::write_all`] from which its diff is split over the thread
/// pool: below it (every frame without a switch) the diff takes well under 0.1 ms on one
/// thread and the split's tasks would cost what they save.
pub(super) const PARALLEL_WORDS: usize = 1 << 15;

/// Spans from which [`coalesce`] sorts on the thread pool, where it has at least
/// [`PARALLEL_SORT_THREADS`] threads.
const PARALLEL_SPANS: usize = 1 << 14;

/// Threads from which [`coalesce`]'s large sorts go on the pool. A switch's 18 k spans (a few
/// ascending runs) sorted in 108 µs on one thread of the 2-core machine and in 192–299 µs
/// on its pool of 2 (rayon's merge sort, after a wake); on the H200's 16 the pool's sort took
/// ~65 µs where one thread had taken 0.15–1 ms. 4 to 8 threads are not measured.
const PARALLEL_SORT_THREADS: usize = 4;

/// The part of `range` below `live` (empty when it starts past it).
pub(super) fn clip(range: Range<u32>, live: u32) -> Range<u32> {
    range.start.min(live)..range.end.min(live)
}

/// Writes `new(i)` into `mirror[i]` for every `i` and pushes every run of changed positions
/// onto `spans` as buffer positions (`at` is the buffer position of `mirror[0]`): a frame
/// switch rewrites whole strips, mostly to the values they had, and only the words that
/// differ are uploaded. Unchanged words are skipped [`DIFF_BLOCK`] at a time by one
/// branch-free comparison (the bulk of a switch's words); a block that differs is walked
/// word by word.
fn diff_copy(mirror: &mut [u32], at: u32, spans: &mut Vec<Range<u32>>, new: impl Fn(usize) -> u32) {
    let n = mirror.len();
    let mut i = 0;
    while i < n {
        if i + DIFF_BLOCK <= n
            && (0..DIFF_BLOCK).fold(0, |differ, k| differ | (mirror[i + k] ^ new(i + k))) == 0
        {
            i += DIFF_BLOCK;
            continue;
        }
        let block_end = (i + DIFF_BLOCK).min(n);
        while i < block_end {
            if mirror[i] == new(i) {
                i += 1;
                continue;
            }
            // A run of changed words, which may go on past the block.
            let first = i;
            while i < n && mirror[i] != new(i) {
                mirror[i] = new(i);
                i += 1;
            }
            spans.push(at + first as u32..at + i as u32);
        }
    }
}

/// Words [`diff_copy`] compares at once where nothing changed.
const DIFF_BLOCK: usize = 8;

/// How a frame's changed index words go to the GPU: `writes` (ascending, disjoint ranges of
/// positions, one `write_buffer` each) and `runs` (ascending, disjoint ranges sent through the
/// scatter, each as headers of up to [`RUN_WORDS`] words); both may include unchanged words
/// between the spans they join (sent with their current value, which the GPU already holds).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(super) struct UploadPlan {
    pub(super) writes: Vec<Range<u32>>,
    pub(super) runs: Vec<Range<u32>>,
    /// The plan's cost in bytes of the model ([`WRITE_CALL_BYTES`] per write,
    /// [`SCATTER_CALL_BYTES`] for a scatter, bytes sent).
    pub(super) cost: u64,
}

/// Bytes a scatter's list takes for `runs`: headers (padded to whole workgroups) and values.
pub(super) fn run_list_bytes(runs: &[Range<u32>]) -> u64 {
    let (mut headers, mut values) = (0u64, 0u64);
    for run in runs {
        let len = u64::from(run.end - run.start);
        headers += len.div_ceil(u64::from(RUN_WORDS));
        // A single word rides in its header.
        values += if len == 1 { 0 } else { len };
    }
    RUN_HEADER_BYTES * headers.next_multiple_of(u64::from(RUN_GROUP))
        + 4 * values.next_multiple_of(2)
}

/// The cheaper of two plans for `spans` (ascending, disjoint, not touching:
/// [`IndexMirror::take_spans`]), under the model of [`WRITE_CALL_BYTES`]:
///
/// * **writes only**: the spans merged where at most `gap` words apart (the merge gap), one
///   write each: what a frame of one or two spans costs least as;
/// * **hybrid** ([`cheapest_split`]): runs of neighbouring spans sent through the scatter or
///   written, whichever the model finds cheaper, plus one scatter.
///
/// `max_list_bytes` is the largest run list one scatter may carry
/// ([`super::scatter::Scatter::max_run_list_bytes`]; 0: no scatter, writes only).
pub(super) fn plan_upload(spans: &[Range<u32>], gap: u32, max_list_bytes: u64) -> UploadPlan {
    // The writes-only plan is built only where it wins, and priced only as far as a
    // comparison needs: a frame of a moving LOD has hundreds of spans, goes through the
    // scatter and never needs it, and a frame switch's ~15 k spans make hundreds of writes
    // whose price passes the alternative's after the first few (pricing them all took a
    // fifth of the plan).
    let writes_only = |cost| UploadPlan {
        writes: joined(spans, gap).collect(),
        runs: Vec::new(),
        cost,
    };
    // The writes' cost where it is at most `bound`.
    let writes_within = |bound: u64| {
        let mut cost = 0u64;
        for w in joined(spans, gap) {
            cost += WRITE_CALL_BYTES + 4 * u64::from(w.end - w.start);
            if cost > bound {
                return None;
            }
        }
        Some(cost)
    };
    let all_writes = || writes_within(u64::MAX).expect("no bound");
    if max_list_bytes == 0 || spans.len() < 2 {
        return writes_only(all_writes());
    }
    // No split costs less than `split_floor`: where the writes cost no more, they win without
    // pricing the split (a frame switch of the 100k object: ~100 k spans, whose split took
    // ~2 ms of one thread on the H200, to choose one write).
    if let Some(cost) = writes_within(split_floor(spans)) {
        return writes_only(cost);
    }
    let hybrid = hybrid_plan(spans);
    // A list past one binding (millions of changed words in a frame): writes only.
    if run_list_bytes(&hybrid.runs) > max_list_bytes {
        return writes_only(all_writes());
    }
    match writes_within(hybrid.cost) {
        Some(cost) => writes_only(cost),
        None => hybrid,
    }
}

/// The hybrid plan of `spans` ([`cheapest_split`]) with its cost: its writes, and its run
/// list plus the scatter's call where it has runs.
fn hybrid_plan(spans: &[Range<u32>]) -> UploadPlan {
    let (mut hybrid, _) = cheapest_split(spans);
    let list = run_list_bytes(&hybrid.runs);
    hybrid.cost = hybrid
        .writes
        .iter()
        .map(|w| WRITE_CALL_BYTES + 4 * u64::from(w.end - w.start))
        .sum::<u64>()
        + if hybrid.runs.is_empty() {
            0
        } else {
            SCATTER_CALL_BYTES + list
        };
    hybrid
}

/// A floor under the cost of any plan with runs or several pieces: every word sent costs 4
/// bytes and every piece (a single word, a run, a write) at least 4 more; the unchanged words
/// between two spans are either sent (at least one) or start a new piece, so each of the
/// `n - 1` gaps adds at least 4: `4 (changed words + n)`.
fn split_floor(spans: &[Range<u32>]) -> u64 {
    let changed: u64 = spans.iter().map(|s| u64::from(s.end - s.start)).sum();
    4 * (changed + spans.len() as u64)
}

/// `spans` (ascending, disjoint) with those at most `gap` words apart joined into one: what
/// [`coalesce`] makes of them, without sorting or allocating.
fn joined(spans: &[Range<u32>], gap: u32) -> impl Iterator<Item = Range<u32>> + '_ {
    let mut rest = spans.iter().peekable();
    std::iter::from_fn(move || {
        let mut span = rest.next()?.clone();
        while let Some(next) = rest.next_if(|next| next.start <= span.end.saturating_add(gap)) {
            span.end = span.end.max(next.end);
        }
        Some(span)
    })
}

/// The cheapest split of `spans` into runs sent through the scatter and writes, each joining
/// consecutive spans (with the unchanged words between them), before the scatter's fixed cost;
/// returns it with its cost in half-bytes of the model. A run of `L` words is priced
/// `8 + 4.5 L` bytes (its headers, at most `8 ⌈L/16⌉ ≤ 8 + L/2`, and its values), a single
/// word 8, a write `c + 4 L`. Dynamic programming over the spans: `best[j]` is the least
/// cost of the first `j`; span `j` is a single word, or ends a run or a write that starts at
/// span `i ≤ j`, whose cost splits into a part of `j` and a part of `i`, so the best `i` of
/// each is a running minimum: O(spans). Joining spans pays where the unchanged words between
/// them cost less than a header (runs) or a call (writes); a single word or a short run
/// costs at most twice its changed words' 4 bytes, and a join is taken only where cheaper
/// than the parts, so a frame sends at most about twice its changed bytes.
pub(super) fn cheapest_split(spans: &[Range<u32>]) -> (UploadPlan, u64) {
    // Half-bytes, so that 4.5 bytes a word is whole.
    const WRITE: i64 = 2 * WRITE_CALL_BYTES as i64;
    const HEADER: i64 = 2 * RUN_HEADER_BYTES as i64;
    // How span j (1-based) is sent, in one word: the span its run or write starts from (a
    // single word is a run from j itself), with `BY_WRITE` set for a write. Only the choices
    // are kept; the costs are needed one span back. Words rather than an enum, and every
    // choice below a select of two integers, so that the loop compiles without branches on
    // the data (which mispredicted on most spans: 8 ns a span).
    const BY_WRITE: u32 = 1 << 31;
    let n = spans.len();
    // Spans are disjoint and apart, and a scatter binds the whole index buffer (at most
    // `max_storage_buffer_binding_size`, under 2³² bytes): fewer than 2²⁹ of them.
    debug_assert!(n < BY_WRITE as usize, "{n} spans do not fit a choice");
    let mut choice = Vec::with_capacity(n + 1);
    choice.push(0);
    // best[j − 1], and min over i ≤ j of best[i − 1] − k start_i (k = 9 for runs, 8 for
    // writes) with the first i that reaches it.
    let mut best = 0i64;
    let (mut run_from, mut i_run) = (i64::MAX, 0u32);
    let (mut write_from, mut i_write) = (i64::MAX, 0u32);
    // A running minimum and where it was reached: `candidate` from span `j` where lower.
    fn lower_from(candidate: i64, j: u32, (from, i): (i64, u32)) -> (i64, u32) {
        let lower = candidate < from;
        (
            if lower { candidate } else { from },
            if lower { j } else { i },
        )
    }
    for (j, span) in (1u32..).zip(spans) {
        let (start, end) = (i64::from(span.start), i64::from(span.end));
        (run_from, i_run) = lower_from(best - 9 * start, j, (run_from, i_run));
        (write_from, i_write) = lower_from(best - 8 * start, j, (write_from, i_write));
        let run = HEADER + 9 * end + run_from;
        let write = WRITE + 8 * end + write_from;
        let by_write = write < run;
        let mut cost = if by_write { write } else { run };
        let mut pick = if by_write { BY_WRITE | i_write } else { i_run };
        let single = end - start == 1 && best + HEADER < cost;
        cost = if single { best + HEADER } else { cost };
        pick = if single { j } else { pick };
        best = cost;
        choice.push(pick);
    }
    let mut plan = UploadPlan::default();
    let mut j = n;
    while j > 0 {
        let i = (choice[j] & !BY_WRITE) as usize;
        let into = if choice[j] & BY_WRITE != 0 {
            &mut plan.writes
        } else {
            &mut plan.runs
        };
        into.push(spans[i - 1].start..spans[j - 1].end);
        j = i - 1;
    }
    plan.writes.reverse();
    plan.runs.reverse();
    (plan, best as u64)
}

/// Sorts and merges spans that overlap or lie at most `gap` elements apart, and empties `spans`.
pub(super) fn coalesce(spans: &mut Vec<Range<u32>>, gap: u32) -> Vec<Range<u32>> {
    // A frame switch of the 100k object brings ~100 k spans: sorted on one thread they took
    // ~1 ms on the H200, so from `PARALLEL_SPANS` on they are sorted on a pool of several
    // threads.
    let pooled = spans.len() >= PARALLEL_SPANS
        && rayon::current_num_threads() >= PARALLEL_SORT_THREADS
        && crate::par::may_split();
    merge_spans(spans, gap, pooled)
}

/// [`coalesce`], its sort on the pool or not.
fn merge_spans(spans: &mut Vec<Range<u32>>, gap: u32, pooled: bool) -> Vec<Range<u32>> {
    // A stable sort merges the ascending runs it finds in linear time: the spans of a frame
    // arrive as a few such runs (the dirty ranges in strip order, then the resizes), which
    // an unstable sort sorts from scratch. Equal starts merge below either way (the pool's
    // sort is stable likewise).
    if pooled {
        use rayon::slice::ParallelSliceMut;
        spans.par_sort_by_key(|span| span.start);
    } else {
        spans.sort_by_key(|span| span.start);
    }
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
    use super::{
        cheapest_split, coalesce, diff_copy, hybrid_plan, joined, merge_spans, plan_upload,
        run_list_bytes, split_floor, IndexMirror, UploadPlan, SCATTER_CALL_BYTES, WRITE_CALL_BYTES,
    };
    use crate::random::next_below;
    use std::ops::Range;

    fn words(ranges: &[Range<u32>]) -> u64 {
        ranges.iter().map(|r| u64::from(r.end - r.start)).sum()
    }

    /// Every changed word is sent once: runs and writes are disjoint and cover every span.
    fn assert_covers(plan: &UploadPlan, spans: &[Range<u32>]) {
        let within = |ranges: &[Range<u32>], span: &Range<u32>| {
            ranges
                .iter()
                .any(|r| r.start <= span.start && span.end <= r.end)
        };
        for span in spans {
            assert!(
                within(&plan.runs, span) != within(&plan.writes, span),
                "{span:?} sent once: {plan:?}"
            );
        }
        for w in &plan.writes {
            assert!(
                !plan.runs.iter().any(|p| p.start < w.end && w.start < p.end),
                "a write over a run: {plan:?}"
            );
        }
    }

    /// The writes-only plan joins `take_spans`' ascending spans as `coalesce` does, unsorted.
    #[test]
    fn joined_is_coalesce_of_ascending_spans() {
        let mut seed = 0x51ed_270b_u64;
        for _ in 0..300 {
            let mut spans = Vec::new();
            let mut at = 0;
            for _ in 0..next_below(&mut seed, 12) {
                at += 1 + next_below(&mut seed, 20);
                let len = 1 + next_below(&mut seed, 10);
                spans.push(at..at + len);
                at += len;
            }
            let gap = next_below(&mut seed, 12);
            assert_eq!(
                joined(&spans, gap).collect::<Vec<_>>(),
                coalesce(&mut spans.clone(), gap),
                "{spans:?}, gap {gap}"
            );
        }
    }

    #[test]
    fn few_spans_go_by_writes_merged_by_the_gap() {
        assert_eq!(plan_upload(&[], 8, 1 << 20), UploadPlan::default());
        let plan = plan_upload(&[3..5, 9..10], 8, 1 << 20);
        assert_eq!(plan.writes, vec![3..10]);
        assert!(plan.runs.is_empty());
        let plan = plan_upload(&[3..5, 20..21], 8, 1 << 20);
        assert_eq!(plan.writes, vec![3..5, 20..21]);
        assert_eq!(plan.cost, 2 * WRITE_CALL_BYTES + 12);
    }

    #[test]
    fn many_spans_go_through_the_scatter_and_huge_runs_are_written() {
        // 500 single words 100 apart: one scatter of 500 headers (values inline), not 500
        // calls.
        let spans: Vec<Range<u32>> = (0..500).map(|i| i * 100..i * 100 + 1).collect();
        let plan = plan_upload(&spans, 8, 1 << 20);
        assert!(plan.writes.is_empty(), "{:?}", plan.writes);
        assert_eq!(plan.runs, spans);
        assert_eq!(run_list_bytes(&plan.runs), 8 * 512);
        assert_eq!(plan.cost, SCATTER_CALL_BYTES + 8 * 512);
        // Without a scatter, or past its list size: one write per span.
        assert_eq!(plan_upload(&spans, 8, 0).writes.len(), 500);
        assert_eq!(plan_upload(&spans, 8, 8 * 511).writes.len(), 500);
        // Spans of 3 words 1 apart join into runs (the unchanged word costs 4 bytes, a
        // header 8); runs of 3 words 3 apart do not.
        for (apart, joined) in [(1, true), (3, false)] {
            let dense: Vec<Range<u32>> = (0..100)
                .map(|i| (3 + apart) * i..(3 + apart) * i + 3)
                .collect();
            let plan = plan_upload(&dense, 0, 1 << 20);
            assert!(plan.writes.is_empty());
            assert_covers(&plan, &dense);
            assert_eq!(plan.runs.len() == 1, joined, "{apart}: {:?}", plan.runs);
        }
        // A run of 20,000 changed words among them is cheaper as a write (80 KB + a call
        // against 90 KB through the scatter); one of 10,000 is not.
        for (run, written) in [(20_000u32, true), (10_000, false)] {
            let mut spans = spans.clone();
            spans.push(60_000..60_000 + run);
            let plan = plan_upload(&spans, 8, 1 << 20);
            assert_covers(&plan, &spans);
            let one_write = plan.writes.len() == 1 && plan.writes[0] == (60_000..60_000 + run);
            assert_eq!(one_write, written, "{run}: {:?}", plan.writes);
        }
    }

    #[test]
    fn the_split_is_the_cheapest_and_sends_about_twice_the_changed_words_at_most() {
        // Against every split of a few spans: each span is a single word (if it is one),
        // opens a run, opens a write, or extends the open run or write.
        let mut seed = 0x9E37_79B9_u64;
        let mut next = |below| next_below(&mut seed, below);
        for case in 0..300 {
            let n = 1 + next(6) as usize;
            let mut spans = Vec::new();
            let mut at = 0u32;
            for _ in 0..n {
                // Gaps and lengths around the break-even points (a header, a call).
                at += 1 + next([3, 40, 6000][case % 3]);
                let len = 1 + next([3, 30, 20_000][case % 3]);
                spans.push(at..at + len);
                at += len;
            }
            let (plan, cost) = cheapest_split(&spans);
            assert_covers(&plan, &spans);
            // Half-bytes: a run 16 + 9 per word, a single word 16, a write 2c + 8 per word.
            let price = |kind: u32, range: &Range<u32>| {
                let len = u64::from(range.end - range.start);
                match kind {
                    0 => 16,
                    1 => 16 + 9 * len,
                    _ => 2 * WRITE_CALL_BYTES + 8 * len,
                }
            };
            let mut least = u64::MAX;
            for code in 0..5u32.pow(n as u32) {
                let (mut total, mut c) = (0u64, code);
                let mut open: Option<(u32, Range<u32>)> = None;
                let mut valid = true;
                for span in &spans {
                    let pick = c % 5;
                    c /= 5;
                    match (pick, open.as_mut()) {
                        (3 | 4, Some((kind, range))) if *kind == pick - 2 => range.end = span.end,
                        (3 | 4, _) => valid = false,
                        (0, _) if span.end - span.start != 1 => valid = false,
                        _ => {
                            total += open.take().map_or(0, |(k, r)| price(k, &r));
                            if pick == 0 {
                                total += price(0, span);
                            } else {
                                open = Some((pick, span.clone()));
                            }
                        }
                    }
                }
                total += open.map_or(0, |(k, r)| price(k, &r));
                if valid {
                    least = least.min(total);
                }
            }
            assert_eq!(cost, least, "case {case}: {spans:?}");
            let changed = words(&spans);
            let sent = 4 * words(&plan.writes) + run_list_bytes(&plan.runs);
            // Twice the changed bytes, plus the padding of the headers (at most 15) and values.
            assert!(
                sent <= 8 * changed + 15 * 8 + 4,
                "case {case}: {sent} bytes for {changed} changed words: {plan:?}"
            );
        }
    }

    /// `plan_upload` chooses the writes without pricing the split where they cost no more
    /// than `split_floor`: no split costs less, over random frames of few and of many spans,
    /// sparse and dense (a split below the floor would be a split the shortcut misses).
    #[test]
    fn no_split_costs_less_than_the_floor() {
        let mut seed = 0x5eed_f100_u64;
        for frame in 0..400 {
            let n = 2 + next_below(&mut seed, if frame % 4 == 0 { 3000 } else { 60 }) as usize;
            let spread = 1 + next_below(&mut seed, 40);
            let mut spans = Vec::with_capacity(n);
            let mut at = next_below(&mut seed, 100);
            for _ in 0..n {
                let long = 1 + next_below(&mut seed, 30);
                let len = 1 + next_below(&mut seed, long);
                spans.push(at..at + len);
                at += len + 1 + next_below(&mut seed, spread);
            }
            let hybrid = hybrid_plan(&spans);
            assert!(
                hybrid.cost >= split_floor(&spans),
                "frame {frame}: split {} under the floor {}",
                hybrid.cost,
                split_floor(&spans)
            );
        }
    }

    #[test]
    fn coalesce_merges_overlapping_and_close_spans_only() {
        let mut spans = vec![10..12, 0..4, 3..6, 30..31, 12..13];
        assert_eq!(coalesce(&mut spans, 0), vec![0..6, 10..13, 30..31]);
        // Past `PARALLEL_SPANS` (sorted on a pool of several threads, or not): as a plain
        // sort and `joined` make them.
        let mut seed = 0xc0a1_e5ce_u64;
        let mut many: Vec<Range<u32>> = (0..3 * super::PARALLEL_SPANS)
            .map(|_| {
                let start = next_below(&mut seed, 1 << 20);
                start..start + 1 + next_below(&mut seed, 8)
            })
            .collect();
        let mut sorted = many.clone();
        sorted.sort_by_key(|span| span.start);
        let expected: Vec<Range<u32>> = joined(&sorted, 0).collect();
        assert_eq!(merge_spans(&mut many.clone(), 0, true), expected);
        assert_eq!(coalesce(&mut many, 0), expected);
        assert!(many.is_empty());
        assert!(spans.is_empty());
        let mut spans = vec![10..12, 0..4, 30..31];
        assert_eq!(coalesce(&mut spans, 6), vec![0..12, 30..31]);
        let mut spans = vec![5..9, 6..7];
        assert_eq!(coalesce(&mut spans, 0), vec![5..9]);
    }

    /// The diff split over the pool in chunks (a large frame switch's) leaves the mirror and
    /// the changed spans, in order, of the writes made one after the other, over random
    /// ascending writes (some empty, some touching) of values mostly equal to the mirror's,
    /// cut into chunks of 1 to 300 words; and `write_all` itself, whichever way it goes.
    #[test]
    fn chunked_writes_equal_writes_one_after_the_other() {
        let mut seed = 0x2545_f491_u64;
        let mut next = |below| next_below(&mut seed, below);
        for case in 0..200 {
            let size = 50 + next(3000) as usize;
            let old: Vec<u32> = (0..size).map(|_| next(8)).collect();
            let new: Vec<u32> = old
                .iter()
                .map(|&v| if next(4) == 0 { next(8) } else { v })
                .collect();
            let mut writes: Vec<(u32, &[u32])> = Vec::new();
            let mut at = next(20) as usize;
            while at < size {
                let len = (next(60) as usize).min(size - at);
                writes.push((at as u32, &new[at..at + len]));
                at += len + next(3) as usize * next(30) as usize;
            }
            let mut serial = IndexMirror::new(old.clone());
            for &(at, values) in &writes {
                serial.write(at, values.len() as u32, |i| values[i]);
            }
            let mut chunked = IndexMirror::new(old.clone());
            chunked.write_in_chunks(&writes, 1 + next(300) as usize);
            assert_eq!(chunked.indices, serial.indices, "case {case}");
            assert_eq!(chunked.dirty, serial.dirty, "case {case}");
            let mut all = IndexMirror::new(old.clone());
            all.write_all(writes.iter().copied());
            assert_eq!(
                (all.indices, all.dirty),
                (serial.indices, serial.dirty),
                "case {case}"
            );
        }
    }

    #[test]
    fn diff_copy_marks_exactly_the_changed_words() {
        let old = [0u32, 1, 2, 3, 4, 5, 6, 7, 8, 9];
        let new = [0u32, 9, 9, 3, 4, 5, 6, 9, 8, 0];
        let mut mirror = old;
        let mut spans = Vec::new();
        diff_copy(&mut mirror, 100, &mut spans, |i| new[i]);
        assert_eq!(mirror, new);
        assert_eq!(spans, vec![101..103, 107..108, 109..110]);
        let mut mirror = old;
        let mut spans = Vec::new();
        diff_copy(&mut mirror, 0, &mut spans, |i| old[i]);
        assert!(spans.is_empty(), "an unchanged copy marks nothing");
        // Random lengths and change patterns (sparse, dense, runs across block edges) against
        // the word-by-word definition: every maximal run of differing positions, in order.
        let mut state = 24u64;
        let mut random = || crate::random::next_random(&mut state);
        for case in 0..2000 {
            let len = (random() % 40) as usize;
            let density = random() % 4;
            let old: Vec<u32> = (0..len).map(|_| (random() % 3) as u32).collect();
            let new: Vec<u32> = old
                .iter()
                .map(|&v| if random() % 4 < density { v + 1 } else { v })
                .collect();
            let mut expected = Vec::new();
            let mut k = 0;
            while k < len {
                if old[k] == new[k] {
                    k += 1;
                    continue;
                }
                let first = k;
                while k < len && old[k] != new[k] {
                    k += 1;
                }
                expected.push(7 + first as u32..7 + k as u32);
            }
            let mut mirror = old.clone();
            let mut spans = Vec::new();
            diff_copy(&mut mirror, 7, &mut spans, |i| new[i]);
            assert_eq!(mirror, new, "case {case}");
            assert_eq!(spans, expected, "case {case}: {old:?} -> {new:?}");
        }
    }
}
