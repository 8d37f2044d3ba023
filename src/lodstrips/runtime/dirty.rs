//! The dirty log: per strip the span of positions written and whether its live length
//! changed, marked as the strips change and taken by the uploader.

/// Changed part of one strip's region: indices `start..end` relative to the region start
/// (coalesced over all changes since the last
/// [`StripsState::take_dirty`](crate::lodstrips::StripsState::take_dirty)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DirtyRange {
    pub strip: u32,
    pub start: u32,
    pub end: u32,
}

/// What the uploader must write: the index ranges, and the strips whose live
/// length (draw `index_count`) changed.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Dirty {
    pub ranges: Vec<DirtyRange>,
    pub lengths: Vec<u32>,
}

/// The dirty log of a [`StripsState`](super::StripsState): per strip the span of positions
/// written and whether its live length changed, and one bit per strip for each, so that
/// taking the log walks the marked strips in ascending order without sorting them (a large
/// object's frame marks thousands of strips; sorting them was most of `take_dirty`).
#[derive(Clone, Debug)]
pub(super) struct DirtyLog {
    /// Per strip the lowest and highest-plus-one position marked (`[u32::MAX, 0]`: none), side
    /// by side: a crowd's rebuild marks a few strips of each of hundreds of states, and one
    /// cache line per mark is what it pays.
    span: Vec<[u32; 2]>,
    /// Bit `s % 64` of word `s / 64`: strip `s` has positions marked.
    marked: Vec<u64>,
    /// The same for strips whose live length changed.
    len_marked: Vec<u64>,
    /// Bumped by every mark ([`StripsState::changes`](super::StripsState::changes)).
    pub(super) changes: u64,
}

/// One mark a rebuild makes for a strip: its live length changed, or its positions
/// `start..end` did.
#[derive(Clone, Copy, Debug)]
pub(super) enum Mark {
    Len(u32),
    Span(u32, u32, u32),
}

/// The strips `first..` of a [`DirtyLog`] (`first` a multiple of 64: whole words of its
/// bitsets) and the marks made through this part: what one chunk of a rebuild split over
/// threads marks on its own thread, so that the log is the one a single thread makes with
/// no marks collected and applied afterwards.
pub(super) struct LogPart<'a> {
    first: usize,
    span: &'a mut [[u32; 2]],
    marked: &'a mut [u64],
    len_marked: &'a mut [u64],
    pub(super) changes: u64,
}

impl<'a> LogPart<'a> {
    pub(super) fn apply(&mut self, mark: Mark) {
        match mark {
            Mark::Len(s) => {
                mark_len(self.len_marked, s as usize - self.first);
                self.changes += 1;
            }
            Mark::Span(s, start, end) => {
                let s = s as usize - self.first;
                self.changes += u64::from(mark_span(self.span, self.marked, s, start, end));
            }
        }
    }

    /// This part cut after its first `strips` strips (a multiple of 64, or all of them).
    pub(super) fn split_at(self, strips: usize) -> (LogPart<'a>, LogPart<'a>) {
        let words = strips.div_ceil(64);
        let (span, span_rest) = self.span.split_at_mut(strips);
        let (marked, marked_rest) = self.marked.split_at_mut(words);
        let (len_marked, len_rest) = self.len_marked.split_at_mut(words);
        let head = LogPart {
            first: self.first,
            span,
            marked,
            len_marked,
            changes: 0,
        };
        let tail = LogPart {
            first: self.first + strips,
            span: span_rest,
            marked: marked_rest,
            len_marked: len_rest,
            changes: 0,
        };
        (head, tail)
    }
}

impl DirtyLog {
    pub(super) fn new(strips: usize) -> DirtyLog {
        DirtyLog {
            span: vec![[u32::MAX, 0]; strips],
            marked: vec![0; strips.div_ceil(64)],
            len_marked: vec![0; strips.div_ceil(64)],
            changes: 0,
        }
    }

    pub(super) fn heap_bytes(&self) -> usize {
        self.span.capacity() * 8 + (self.marked.capacity() + self.len_marked.capacity()) * 8
    }

    /// The whole log as one part.
    pub(super) fn part(&mut self) -> LogPart<'_> {
        LogPart {
            first: 0,
            span: &mut self.span,
            marked: &mut self.marked,
            len_marked: &mut self.len_marked,
            changes: 0,
        }
    }

    pub(super) fn apply(&mut self, mark: Mark) {
        match mark {
            Mark::Len(s) => self.mark_len(s as usize),
            Mark::Span(s, start, end) => self.mark(s as usize, start, end),
        }
    }

    pub(super) fn mark(&mut self, strip: usize, start: u32, end: u32) {
        let marked = mark_span(&mut self.span, &mut self.marked, strip, start, end);
        self.changes += u64::from(marked);
    }

    pub(super) fn mark_len(&mut self, strip: usize) {
        mark_len(&mut self.len_marked, strip);
        self.changes += 1;
    }

    pub(super) fn take(&mut self) -> Dirty {
        let mut out = Dirty::default();
        self.take_into(&mut out);
        out
    }

    pub(super) fn take_into(&mut self, out: &mut Dirty) {
        out.ranges.clear();
        out.lengths.clear();
        out.ranges.reserve(ones(&self.marked));
        out.lengths.reserve(ones(&self.len_marked));
        take_ones(&mut self.marked, |s| {
            let [start, end] = std::mem::replace(&mut self.span[s], [u32::MAX, 0]);
            out.ranges.push(DirtyRange {
                strip: s as u32,
                start,
                end,
            });
        });
        take_ones(&mut self.len_marked, |s| out.lengths.push(s as u32));
    }
}

/// Marks positions `start..end` of strip `s` in a dirty log's (or part's) span table and
/// bitset; false (nothing marked) where the span is empty.
#[inline]
fn mark_span(span: &mut [[u32; 2]], marked: &mut [u64], s: usize, start: u32, end: u32) -> bool {
    if start >= end {
        return false;
    }
    marked[s / 64] |= 1 << (s % 64);
    span[s] = [span[s][0].min(start), span[s][1].max(end)];
    true
}

/// Marks strip `s`'s live length as changed in a dirty log's (or part's) bitset.
#[inline]
fn mark_len(len_marked: &mut [u64], s: usize) {
    len_marked[s / 64] |= 1 << (s % 64);
}

/// Bits set in `bits`.
fn ones(bits: &[u64]) -> usize {
    bits.iter().map(|w| w.count_ones() as usize).sum()
}

/// Calls `f` with the number of every set bit of `bits`, ascending, and clears them.
fn take_ones(bits: &mut [u64], mut f: impl FnMut(usize)) {
    for (w, word) in bits.iter_mut().enumerate() {
        let mut rest = std::mem::take(word);
        while rest != 0 {
            f(w * 64 + rest.trailing_zeros() as usize);
            rest &= rest - 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// The dirty log, marked in any order (strips past a 64-bit word, empty spans, the
        /// same strip again), hands out each marked strip once, ascending, with the lowest
        /// start and highest end of its spans, and the length-marked strips ascending; taken,
        /// it starts afresh (two rounds of marks, a take after each); every mark that records
        /// something moves the change counter.
        #[test]
        fn dirty_log_takes_each_marked_strip_once_in_order(
            rounds in proptest::collection::vec(
                proptest::collection::vec(
                    (0usize..150, 0u32..40, 0u32..40, proptest::bool::ANY),
                    0..60,
                ),
                2,
            ),
        ) {
            let mut log = DirtyLog::new(150);
            let mut counted = 0;
            for marks in &rounds {
                let mut spans = std::collections::BTreeMap::new();
                let mut lengths = std::collections::BTreeSet::new();
                for &(strip, start, end, len) in marks {
                    if len {
                        log.mark_len(strip);
                        lengths.insert(strip as u32);
                        counted += 1;
                    } else {
                        log.mark(strip, start, end);
                        if start < end {
                            let span = spans.entry(strip as u32).or_insert((start, end));
                            *span = (span.0.min(start), span.1.max(end));
                            counted += 1;
                        }
                    }
                }
                proptest::prop_assert_eq!(log.changes, counted);
                let expected = Dirty {
                    ranges: spans
                        .iter()
                        .map(|(&strip, &(start, end))| DirtyRange { strip, start, end })
                        .collect(),
                    lengths: lengths.into_iter().collect(),
                };
                proptest::prop_assert_eq!(log.take(), expected);
            }
            proptest::prop_assert_eq!(log.take(), Dirty::default());
        }
    }
}
