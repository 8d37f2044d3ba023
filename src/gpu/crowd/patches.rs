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
    /// The record words changed, as `[word, value]` patches of the indirect buffer.
    pub(super) records: Patches,
    /// Some word may be in two of `index_runs` (an instance moved by two `set`s, or one
    /// removed after its patches were made): prepare then merges them first.
    pub(super) overlap: bool,
    /// Slots whose instance was removed after its patches were made, each with the number of
    /// `index_runs` lists made before: those lists' patches of the slot are dropped (the slot
    /// may hold a new instance by then, written `S0` before the patches apply).
    pub(super) withdrawn: Vec<(u32, usize)>,
    /// Slots whose instance moved in its frame's tail (maybe twice: `prepare` writes those
    /// still there, once).
    pub(super) tails: Vec<u32>,
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
            self.records.extend_from_slice(&piece.records);
            self.tails.extend_from_slice(&piece.tails);
            self.overlap |= piece.again;
        }
        rebuilds
    }

    /// Merges the index patches into one list where each word has its last value, less the
    /// withdrawn slots' patches made before their removal (`per`: slots per instance).
    pub(super) fn merge(&mut self, per: u32) {
        let mut patches = Vec::new();
        for (list, runs) in self.index_runs.iter().enumerate() {
            for (first, values) in runs.iter() {
                for (word, &value) in (first..).zip(values) {
                    let withdrawn = (self.withdrawn.iter())
                        .any(|&(slot, lists)| list < lists && word / per == slot);
                    if !withdrawn {
                        patches.push([word, value]);
                    }
                }
            }
        }
        keep_last_per_word(&mut patches);
        self.index_runs = vec![PatchRuns::of(&patches)];
        self.withdrawn.clear();
        self.overlap = false;
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

/// `[slot, value]` patches of the index buffer, or `[word, value]` of the indirect buffer.
type Patches = Vec<[u32; 2]>;

/// Patches as the scatter sends them: runs of consecutive words, each its first word and the
/// range of its values in `values` (the patches' values in order).
#[derive(Default)]
pub(super) struct PatchRuns {
    pub(super) values: Vec<u32>,
    runs: Vec<(u32, std::ops::Range<usize>)>,
}

impl PatchRuns {
    /// The runs of `patches`: consecutive words in the list make one run (a compact copy and a
    /// record are patched in order): 8 bytes of run list for a lone word, 8 plus 4 a word for
    /// a run.
    fn of(patches: &[[u32; 2]]) -> PatchRuns {
        let mut runs = PatchRuns::default();
        runs.refill(patches);
        runs
    }

    /// [`of`](Self::of), into this list's storage.
    pub(super) fn refill(&mut self, patches: &[[u32; 2]]) {
        self.runs.clear();
        for (i, p) in patches.iter().enumerate() {
            match self.runs.last_mut() {
                Some((first, values)) if *first + (i - values.start) as u32 == p[0] => {
                    values.end = i + 1;
                }
                _ => self.runs.push((p[0], i..i + 1)),
            }
        }
        self.values.clear();
        self.values.extend(patches.iter().map(|p| p[1]));
    }

    /// Each run as its first word and its values.
    pub(super) fn iter(&self) -> impl Iterator<Item = (u32, &[u32])> + Clone {
        self.runs
            .iter()
            .map(|(first, range)| (*first, &self.values[range.clone()]))
    }
}

/// Sets `record` (slot `slot`'s) to read `what` of its slots (`path`: where the slot rides,
/// `vertex_count`: the asset's) and appends to `patches` one `[word, value]` patch of the
/// indirect buffer per word that changed.
pub(super) fn set_record(
    (path, vertex_count, per_instance): (CrowdPath, u32, u32),
    slot: u32,
    what: Option<SlotRecord>,
    record: &mut DrawIndexedIndirectArgs,
    patches: &mut Vec<[u32; 2]>,
) {
    // The slot rides in first_instance or in base_vertex (checked to fit in add_asset).
    let (base_vertex, first_instance) = match path {
        CrowdPath::FirstInstance => (0, slot),
        CrowdPath::BaseVertex => ((slot * vertex_count) as i32, 0),
    };
    let new = what
        .filter(|w| w.count > 0)
        .map_or_else(Default::default, |w| DrawIndexedIndirectArgs {
            index_count: w.count,
            instance_count: 1,
            first_index: slot * per_instance + w.first,
            base_vertex,
            first_instance,
        });
    let old: [u32; 5] = bytemuck::cast(*record);
    let now: [u32; 5] = bytemuck::cast(new);
    let first_word = slot * 5;
    for (w, (&o, &v)) in (0u32..).zip(old.iter().zip(&now)) {
        if o != v {
            patches.push([first_word + w, v]);
        }
    }
    *record = new;
}

/// What one piece of work of `set`'s passes made: its rebuilds over the mesh (left to the
/// rebuild pass), its instances' index and record patches.
#[derive(Default)]
pub(super) struct Piece {
    /// Scratch of the poses.
    pub(super) weights: Vec<f32>,
    pub(super) rebuilds: Vec<(usize, Plan)>,
    /// Scratch of the instances' dirty logs, reused from one to the next.
    pub(super) dirty: Dirty,
    pub(super) patches: Patches,
    pub(super) records: Patches,
    /// An instance patched a second time since the last prepare.
    pub(super) again: bool,
    /// Slots whose instance moved in its frame's tail.
    pub(super) tails: Vec<u32>,
}

impl Piece {
    /// Its index patches as runs, made on the piece's thread: gathered on the calling thread
    /// they were most of the crowd's serial time (tens of thousands of patches a frame).
    pub(super) fn runs(self) -> (PatchRuns, Piece) {
        (PatchRuns::of(&self.patches), self)
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
