//! The index buffer's CPU mirror: writes diffed word by word against it (on the thread pool
//! for a large frame switch), the changed spans collected for the next upload.

use std::ops::Range;

use super::spans::coalesce;
use super::MERGE_GAP_BYTES;
use crate::lodstrips::StripIndex;

/// The whole index buffer as the GPU will hold it after the next upload, and the words
/// changed since the last one.
pub(in crate::gpu) struct IndexMirror {
    /// CPU mirror of the whole index buffer (equal to the GPU after prepare).
    pub(in crate::gpu) indices: Vec<u32>,
    /// Spans of changed words (buffer positions) since the last prepare, unsorted; every
    /// word of a span changed.
    dirty: Vec<Range<u32>>,
    merge_gap_bytes: u64,
}

impl IndexMirror {
    pub(in crate::gpu) fn new(indices: Vec<u32>) -> Self {
        IndexMirror {
            indices,
            dirty: Vec::new(),
            merge_gap_bytes: MERGE_GAP_BYTES,
        }
    }

    pub(in crate::gpu) fn merge_gap_bytes(&self) -> u64 {
        self.merge_gap_bytes
    }

    pub(in crate::gpu) fn set_merge_gap(&mut self, bytes: u64) {
        self.merge_gap_bytes = bytes;
    }

    /// Writes `new(i)` at buffer positions `at..at + len` and marks the words that changed.
    pub(in crate::gpu) fn write(&mut self, at: u32, len: u32, new: impl Fn(usize) -> u32) {
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
    /// The values are a runtime's words in its width, widened as they are copied.
    pub(in crate::gpu) fn write_all<'a, I: StripIndex>(
        &mut self,
        writes: impl Iterator<Item = (u32, &'a [I])> + Clone,
    ) {
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
            let writes: Vec<(u32, &[I])> = writes.collect();
            self.write_in_chunks(&writes, crate::par::piece_len(words, PARALLEL_WORDS / 4));
        } else {
            for (at, values) in writes {
                self.write(at, values.len() as u32, |i| values[i].into());
            }
        }
    }

    /// [`write_all`](Self::write_all) of ascending, disjoint `writes` cut into chunks of
    /// consecutive writes of about `chunk_words` words, diffed in parallel.
    fn write_in_chunks<I: StripIndex>(&mut self, writes: &[(u32, &[I])], chunk_words: usize) {
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
                    |i| values[i].into(),
                );
            }
            spans
        });
        for chunk in spans {
            self.dirty.extend(chunk);
        }
    }

    /// The changed spans, sorted and merged where they overlap or touch; empties the list.
    pub(in crate::gpu) fn take_spans(&mut self) -> Vec<Range<u32>> {
        coalesce(&mut self.dirty, 0)
    }
}

/// Words of one [`IndexMirror::write_all`] from which its diff is split over the thread
/// pool: below it (every frame without a switch) the diff takes well under 0.1 ms on one
/// thread and the split's tasks would cost what they save.
pub(in crate::gpu) const PARALLEL_WORDS: usize = 1 << 15;

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

#[cfg(test)]
mod tests {
    use super::{diff_copy, IndexMirror};
    use crate::random::next_below;

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
