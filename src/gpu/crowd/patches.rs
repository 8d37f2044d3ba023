//! The per-frame patch bookkeeping: what one piece of work of `set`'s passes made, the
//! patches waiting for the next `prepare`, patches as the scatter's runs, a record's
//! patches, and the range of instance blocks to write.

use wgpu::util::DrawIndexedIndirectArgs;

use super::pipeline::CrowdPath;
use super::slots::SlotRecord;
use crate::deform::Plan;
use crate::lodstrips::Dirty;

/// The patches an asset's instances made since the last prepare.
#[derive(Default)]
pub(super) struct Waiting {
    /// Index patches as runs: one list per piece of work of `set`'s passes, in the order made.
    pub(super) index_runs: Vec<PatchRuns>,
    /// Some word may be in two of `index_runs` (an instance patched by two `set`s): prepare
    /// then keeps its last value.
    pub(super) overlap: bool,
    /// Slots whose patches made before were voided (the instance removed, or its area made
    /// anew), each with the number of `index_runs` lists made before: those lists' runs of
    /// the slot are dropped (they name words of an area it no longer has).
    pub(super) withdrawn: Vec<(u32, usize)>,
    /// Slots whose instance moved in its frame's tail (maybe twice: `prepare` writes those
    /// still there, once).
    pub(super) tails: Vec<u32>,
    /// Slots whose instance moved in the current `set`: their areas and records are settled
    /// after its passes.
    pub(super) moved: Vec<u32>,
}

impl Waiting {
    /// Keeps the pieces' patches; returns their rebuilds, in slot order.
    pub(super) fn take(&mut self, pieces: Vec<(PatchRuns, Piece)>) -> Vec<(usize, Plan)> {
        let mut rebuilds = Vec::new();
        for (runs, piece) in pieces {
            rebuilds.extend_from_slice(&piece.rebuilds);
            if !runs.values.is_empty() {
                self.index_runs.push(runs);
            }
            self.tails.extend_from_slice(&piece.tails);
            self.moved.extend_from_slice(&piece.moved);
            self.overlap |= piece.again;
        }
        rebuilds
    }

    /// Whether list `list`'s runs of `slot` were withdrawn.
    pub(super) fn is_withdrawn(&self, slot: u32, list: usize) -> bool {
        (self.withdrawn.iter()).any(|&(s, lists)| s == slot && list < lists)
    }
}

/// Leaves one patch per word, the last pushed (a stable sort by word keeps each word's
/// patches in the order they were made).
pub(super) fn keep_last_per_word(patches: &mut Vec<[u32; 2]>) {
    patches.sort_by_key(|p| p[0]);
    let mut kept = 0;
    for i in 0..patches.len() {
        if patches
            .get(i + 1)
            .is_some_and(|next| next[0] == patches[i][0])
        {
            continue;
        }
        patches[kept] = patches[i];
        kept += 1;
    }
    patches.truncate(kept);
}

/// Whether no word is patched twice (a word sent twice is wasted bytes, and with two values
/// a race: the scatter's invocations run in any order).
pub(super) fn each_word_once(words: impl Iterator<Item = u32>) -> bool {
    let mut words: Vec<u32> = words.collect();
    words.sort_unstable();
    words.windows(2).all(|w| w[0] != w[1])
}

/// `[word, value]` patches: of an instance's area (words counted from its start) or of a
/// page's records.
pub(super) type Patches = Vec<[u32; 2]>;

/// An instance's patches as the scatter sends them: runs of consecutive words of its area,
/// each its owner's slot, its first word and the range of its values in `values` (the
/// patches' values in order).
#[derive(Default)]
pub(super) struct PatchRuns {
    pub(super) values: Vec<u32>,
    runs: Vec<(u32, u32, std::ops::Range<usize>)>,
}

impl PatchRuns {
    /// The runs of `patches`, whose `owners` are `(slot, end)`: the patches up to `end`
    /// (from the previous owner's end) are slot `slot`'s. Consecutive words of one owner make
    /// one run (a compact copy and a record are patched in order): 8 bytes of run list for a
    /// lone word, 8 plus 4 a word for a run.
    pub(super) fn of(patches: &[[u32; 2]], owners: &[(u32, usize)]) -> PatchRuns {
        let mut runs = PatchRuns::default();
        let mut start = 0;
        for &(slot, end) in owners {
            for (i, p) in (start..end).zip(&patches[start..end]) {
                match runs.runs.last_mut() {
                    Some((owner, first, values))
                        if *owner == slot
                            && i > start
                            && *first + (i - values.start) as u32 == p[0] =>
                    {
                        values.end = i + 1;
                    }
                    _ => runs.runs.push((slot, p[0], i..i + 1)),
                }
            }
            start = end;
        }
        runs.values.extend(patches[..start].iter().map(|p| p[1]));
        runs
    }

    /// Each run as its owner's slot, its first word and its values.
    pub(super) fn iter(&self) -> impl Iterator<Item = (u32, u32, &[u32])> + Clone {
        self.runs
            .iter()
            .map(|(slot, first, range)| (*slot, *first, &self.values[range.clone()]))
    }
}

/// The record of the instance in `slot` that reads `what` of the words from `offset` of its
/// page (`path`: where the slot rides, `vertex_count`: the asset's); nothing drawn for no
/// words.
pub(super) fn draw_args(
    (path, vertex_count): (CrowdPath, u32),
    slot: u32,
    offset: u32,
    what: SlotRecord,
) -> DrawIndexedIndirectArgs {
    if what.count == 0 {
        return DrawIndexedIndirectArgs::default();
    }
    // The slot rides in first_instance or in base_vertex (checked to fit in `add`).
    let (base_vertex, first_instance) = match path {
        CrowdPath::FirstInstance => (0, slot),
        CrowdPath::BaseVertex => ((slot * vertex_count) as i32, 0),
    };
    DrawIndexedIndirectArgs {
        index_count: what.count,
        instance_count: 1,
        first_index: offset + what.first,
        base_vertex,
        first_instance,
    }
}

/// What one piece of work of `set`'s passes made: its rebuilds over the mesh (left to the
/// rebuild pass), its instances' index patches and the instances whose area may change.
#[derive(Default)]
pub(super) struct Piece {
    /// Scratch of the poses.
    pub(super) weights: Vec<f32>,
    pub(super) rebuilds: Vec<(usize, Plan)>,
    /// Scratch of the instances' dirty logs, reused from one to the next.
    pub(super) dirty: Dirty,
    /// Patches of the instances' areas, and whose they are: `(slot, end)`.
    pub(super) patches: Patches,
    pub(super) owners: Vec<(u32, usize)>,
    /// An instance patched a second time since the last prepare.
    pub(super) again: bool,
    /// Slots whose instance moved in its frame's tail.
    pub(super) tails: Vec<u32>,
    /// Slots whose instance needs its area and record settled.
    pub(super) moved: Vec<u32>,
}

impl Piece {
    /// Notes that the patches from `start` on are `slot`'s.
    pub(super) fn own(&mut self, slot: u32, start: usize) {
        if self.patches.len() > start {
            self.owners.push((slot, self.patches.len()));
        }
    }

    /// Its index patches as runs, made on the piece's thread: gathered on the calling thread
    /// they were most of the crowd's serial time (tens of thousands of patches a frame).
    pub(super) fn runs(self) -> (PatchRuns, Piece) {
        (PatchRuns::of(&self.patches, &self.owners), self)
    }
}

/// Unchanged slots a run of changed ones carries rather than be split in two writes: a
/// `write_buffer` call costs more than these ~1 KB of placements.
const RUN_GAP: u32 = 8;

/// Slots changed since the last upload, written as runs ([`take_runs`](Self::take_runs)):
/// a few instances changed far apart (walkers turned at a field's edges) cost their own
/// blocks, not the whole span between them.
#[derive(Clone, Debug, Default)]
pub(super) struct DirtySlots(Vec<u32>);

impl DirtySlots {
    pub(super) fn add(&mut self, slot: u32) {
        self.0.push(slot);
        // Bounded between uploads however often one slot changes.
        if self.0.len() >= 1 << 16 {
            self.0.sort_unstable();
            self.0.dedup();
        }
    }

    pub(super) fn clear(&mut self) {
        self.0.clear();
    }

    /// The changed slots as ascending, disjoint ranges (gaps of at most [`RUN_GAP`]
    /// unchanged slots merged), emptied.
    pub(super) fn take_runs(&mut self) -> Vec<std::ops::Range<u32>> {
        self.0.sort_unstable();
        self.0.dedup();
        let mut runs: Vec<std::ops::Range<u32>> = Vec::new();
        for &slot in &self.0 {
            match runs.last_mut() {
                Some(run) if slot - run.end <= RUN_GAP => run.end = slot + 1,
                _ => runs.push(slot..slot + 1),
            }
        }
        self.0.clear();
        runs
    }
}

/// A range of slots changed since the last upload (empty: `start >= end`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Span {
    pub(super) start: u32,
    pub(super) end: u32,
}

impl Span {
    pub(super) const EMPTY: Span = Span {
        start: u32::MAX,
        end: 0,
    };

    pub(super) fn add(&mut self, slot: u32) {
        self.start = self.start.min(slot);
        self.end = self.end.max(slot + 1);
    }

    pub(super) fn take(&mut self) -> Option<std::ops::Range<u32>> {
        let span = std::mem::replace(self, Span::EMPTY);
        (span.start < span.end).then_some(span.start..span.end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Changed slots come back sorted, once each, as runs that merge gaps of at most
    /// `RUN_GAP` unchanged slots and split larger ones; taking empties the set.
    #[test]
    fn dirty_slots_are_written_in_runs() {
        let mut dirty = DirtySlots::default();
        for slot in [
            9000,
            3,
            5,
            4,
            3,
            5 + RUN_GAP + 1,
            5 + RUN_GAP + 1 + RUN_GAP + 2,
            0,
        ] {
            dirty.add(slot);
        }
        let far = 5 + RUN_GAP + 1 + RUN_GAP + 2;
        assert_eq!(
            dirty.take_runs(),
            [0..RUN_GAP + 7, far..far + 1, 9000..9001]
        );
        assert!(dirty.take_runs().is_empty());
        // Bounded however often one slot changes.
        for _ in 0..(1 << 17) {
            dirty.add(7);
        }
        assert!(dirty.0.len() < 1 << 16);
        assert_eq!(dirty.take_runs(), vec![7..8]);
    }
}
