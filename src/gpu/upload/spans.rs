//! Span arithmetic of the upload: a range clipped to a live length, spans sorted and merged
//! ([`coalesce`], on the thread pool for a large frame switch), ascending spans joined
//! ([`joined`]).

use std::ops::Range;

/// Spans from which [`coalesce`] sorts on the thread pool, where it has at least
/// [`PARALLEL_SORT_THREADS`] threads.
const PARALLEL_SPANS: usize = 1 << 14;

/// Threads from which [`coalesce`]'s large sorts go on the pool. A switch's 18 k spans (a few
/// ascending runs) sorted in 108 µs on one thread of the 2-core machine and in 192–299 µs
/// on its pool of 2 (rayon's merge sort, after a wake); on the H200's 16 the pool's sort took
/// ~65 µs where one thread had taken 0.15–1 ms. 4 to 8 threads are not measured.
const PARALLEL_SORT_THREADS: usize = 4;

/// The part of `range` below `live` (empty when it starts past it).
pub(in crate::gpu) fn clip(range: Range<u32>, live: u32) -> Range<u32> {
    range.start.min(live)..range.end.min(live)
}

/// `spans` (ascending, disjoint) with those at most `gap` words apart joined into one: what
/// [`coalesce`] makes of them, without sorting or allocating.
pub(super) fn joined(spans: &[Range<u32>], gap: u32) -> impl Iterator<Item = Range<u32>> + '_ {
    let mut rest = spans.iter().peekable();
    std::iter::from_fn(move || {
        let mut span = rest.next()?.clone();
        while let Some(next) = rest.next_if(|next| next.start <= span.end.saturating_add(gap)) {
            span.end = span.end.max(next.end);
        }
        Some(span)
    })
}

/// Sorts and merges spans that overlap or lie at most `gap` elements apart, and empties `spans`.
pub(in crate::gpu) fn coalesce(spans: &mut Vec<Range<u32>>, gap: u32) -> Vec<Range<u32>> {
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
    use super::{coalesce, joined, merge_spans};
    use crate::random::next_below;
    use std::ops::Range;

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
}
