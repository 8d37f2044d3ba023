//! The cost model's choice for a frame's changed spans: writes only, or the cheapest split
//! into scatter runs and writes.

use std::ops::Range;

use super::spans::joined;
use super::{RUN_HEADER_BYTES, SCATTER_CALL_BYTES, WRITE_CALL_BYTES};
use crate::gpu::scatter::{RUN_GROUP, RUN_WORDS};

/// How a frame's changed index words go to the GPU: `writes` (ascending, disjoint ranges of
/// positions, one `write_buffer` each) and `runs` (ascending, disjoint ranges sent through the
/// scatter, each as headers of up to [`RUN_WORDS`] words); both may include unchanged words
/// between the spans they join (sent with their current value, which the GPU already holds).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(in crate::gpu) struct UploadPlan {
    pub(in crate::gpu) writes: Vec<Range<u32>>,
    pub(in crate::gpu) runs: Vec<Range<u32>>,
    /// The plan's cost in bytes of the model ([`WRITE_CALL_BYTES`] per write,
    /// [`SCATTER_CALL_BYTES`] for a scatter, bytes sent).
    pub(in crate::gpu) cost: u64,
}

/// Bytes a scatter's list takes for `runs`: headers (padded to whole workgroups) and values.
pub(in crate::gpu) fn run_list_bytes(runs: &[Range<u32>]) -> u64 {
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
/// [`IndexMirror::take_spans`](super::IndexMirror::take_spans)), under the model of
/// [`WRITE_CALL_BYTES`]:
///
/// * **writes only**: the spans merged where at most `gap` words apart (the merge gap), one
///   write each: what a frame of one or two spans costs least as;
/// * **hybrid** ([`cheapest_split`]): runs of neighbouring spans sent through the scatter or
///   written, whichever the model finds cheaper, plus one scatter.
///
/// `max_list_bytes` is the largest run list one scatter may carry
/// ([`Scatter::max_run_list_bytes`](crate::gpu::scatter::Scatter::max_run_list_bytes); 0: no
/// scatter, writes only).
pub(in crate::gpu) fn plan_upload(
    spans: &[Range<u32>],
    gap: u32,
    max_list_bytes: u64,
) -> UploadPlan {
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
pub(in crate::gpu) fn cheapest_split(spans: &[Range<u32>]) -> (UploadPlan, u64) {
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

#[cfg(test)]
mod tests {
    use super::{
        cheapest_split, hybrid_plan, plan_upload, run_list_bytes, split_floor, UploadPlan,
    };
    use crate::gpu::upload::{SCATTER_CALL_BYTES, WRITE_CALL_BYTES};
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
}
