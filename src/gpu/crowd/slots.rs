//! An instance's index slots in its asset's index buffer, and the patches that bring them from
//! what the GPU holds to the runtime's current strips.
//!
//! Every instance of an asset owns `per_instance` consecutive slots. First its regions: region
//! `r` (strip `r` of `S0`) at `starts[r]..starts[r] + capacity`, followed by one separator
//! slot that always holds [`RESTART`]: the layout of a strip [`Object`](super::super::Object),
//! so one record draws all its strips (restarts separate them), and patches keep it current
//! at O(changed indices). Then its compact area: where the instance's live strips fit in it
//! (a coarse LOD), they are copied there, each in a place of its own ([`Places`]) that it
//! keeps while it fits, and its record draws that copy instead of the regions, whose restart
//! tails would be most of what it reads.
//! The CPU keeps no mirror of the slots: what the GPU holds is known from the runtime's strips
//! as of the last upload, and the runtime's dirty log says which positions may differ since.
//! A patch is `[slot, value]`; a frame's patches of all instances are encoded as runs of
//! consecutive slots and applied by one scatter dispatch.

use crate::deform::{DeformingModel, DeformingState};
use crate::lodstrips::{for_each_live, Dirty, DirtyRange};

use super::super::scatter::RUN_WORDS;
use super::super::RESTART;

/// Where the regions of one instance lie, relative to its first slot.
pub(super) struct SlotLayout {
    /// Region r starts at `starts[r]`; `starts[regions]` is the slot count per instance.
    starts: Vec<u32>,
    /// Region r starts at `runtime[r]` in the runtime's packed buffer (no separators).
    runtime: Vec<u32>,
    /// `S0` with a separator after every region: what a new instance's regions hold.
    s0: Vec<u32>,
    /// Slots of the compact area, after the regions.
    compact: u32,
}

/// Which slots an instance's one draw record reads, relative to its first slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct SlotRecord {
    pub(super) first: u32,
    pub(super) count: u32,
    /// Reads the compact area (else the regions).
    pub(super) compact: bool,
}

/// Where an instance's live strips lie in its compact area, and whether its regions lag
/// behind its strips. Empty (no heap) until the instance is first drawn from its copy.
///
/// A strip with a place has `at..at + room` of the compact area, holding its `len` indices as
/// of the last upload and [`RESTART`] over the rest, followed by a separator slot that holds
/// [`RESTART`] (so a place starts after a restart, like a region: a strip decodes with the
/// same parity, and two never join). Places lie one after another from slot 0 up to `used`,
/// with abandoned places (all restarts) between them.
#[derive(Default)]
pub(super) struct Places {
    /// The strips that have a place and their places, sorted by strip: a copy holds a few
    /// dozen strips of a thousand, and the strips a move changed (sorted too) are found by
    /// walking both lists, a few cache lines read in order rather than a line of a per-strip
    /// table for each (most of a crowd's patch time went to those misses).
    placed: Vec<(u32, Place)>,
    /// Scratch of `move_places`: the strips given a first place, merged into `placed` after.
    born: Vec<(u32, Place)>,
    /// The end of the used part (the record reads within `0..used` of the compact area, from
    /// its first live index to its last).
    used: u32,
    /// The copy holds the strips as of the last upload (false while the regions are drawn:
    /// then the copy is repacked when a record reads it again).
    current: bool,
    /// The strips changed while the copy was drawn, so the regions lag behind them: the
    /// next upload that draws the regions sends every live strip whole. Which parts changed
    /// is not kept: a per-strip table of them cost a cold cache line per changed strip at
    /// every upload of a coarse instance, for a return to the regions that is rare and sends
    /// most of a strip anyway (BENCHMARKS.md, "Stale regions sent whole").
    stale: bool,
    /// Full rewrites of the copy (tests count them).
    #[cfg(test)]
    repacks: u32,
}

impl Places {
    /// Heap bytes of the table.
    pub(super) fn heap_bytes(&self) -> usize {
        (self.placed.capacity() + self.born.capacity()) * size_of::<(u32, Place)>()
    }

    /// Every strip's place (`room = 0`: none), for tests to compare strip by strip.
    #[cfg(test)]
    fn dense(&self, strips: usize) -> Vec<Place> {
        let mut out = vec![Place::default(); strips];
        for &(r, place) in &self.placed {
            out[r as usize] = place;
        }
        out
    }

    /// The instance is drawn from elsewhere (its frame's tail list, written over its compact
    /// area): the copy is repacked and the regions get every live strip when a record reads
    /// them again.
    pub(super) fn leave(&mut self) {
        self.current = false;
        self.stale = true;
        // A repack places every strip anew: the list's memory is free until then.
        self.placed = Vec::new();
        self.born = Vec::new();
    }

    /// A dirty log that covers every change of the regions since they were last patched
    /// (the dirty log's contract), for strips of `lengths` whose regions hold `uploaded`:
    /// each strip live in both, whole, and each strip whose length differs. Clears `stale`.
    fn take_stale(&mut self, uploaded: &[u32], lengths: &[u32]) -> Dirty {
        self.stale = false;
        let mut out = Dirty::default();
        for (r, (&old, &new)) in uploaded.iter().zip(lengths).enumerate() {
            let kept = old.min(new);
            if kept > 0 {
                out.ranges.push(DirtyRange {
                    strip: r as u32,
                    start: 0,
                    end: kept,
                });
            }
            if old != new {
                out.lengths.push(r as u32);
            }
        }
        out
    }
}

/// Strip `r`'s place in `placed` (sorted by strip) and its index there, or no index and the
/// empty place (`room = 0`) where it has none, looking from `*k` on; `*k` moves past the
/// strips before `r`, so strips asked for in increasing order cost one walk of the list.
fn find(placed: &[(u32, Place)], k: &mut usize, r: usize) -> (Option<usize>, Place) {
    while *k < placed.len() && (placed[*k].0 as usize) < r {
        *k += 1;
    }
    match placed.get(*k) {
        Some(&(strip, place)) if strip as usize == r => (Some(*k), place),
        _ => (None, Place::default()),
    }
}

/// Where one strip lies in the compact area (see [`Places`]).
#[derive(Clone, Copy, Debug, Default)]
struct Place {
    at: u32,
    room: u32,
    len: u32,
}

/// The copy is repacked where its record would read more than this many times the packed
/// count (live indices and one restart between two strips), in eighths.
const READ_BOUND_EIGHTHS: u32 = 12;

/// Restarts after a strip in its place, in eighths of its length, so that it can grow there.
const SLACK_EIGHTHS: u32 = 0;

impl SlotLayout {
    /// The slots of `model`'s instances, with a compact area of `compact_share` (clamped to
    /// 0..=1) of the regions' slots.
    pub(super) fn new(model: &DeformingModel, compact_share: f32) -> SlotLayout {
        let layout = model.layout();
        let runtime = layout.region_offsets().to_vec();
        let s0 = layout.s0();
        let mut starts = Vec::with_capacity(runtime.len());
        let mut slots = Vec::with_capacity(s0.len() + runtime.len());
        starts.push(0);
        for w in runtime.windows(2) {
            slots.extend_from_slice(&s0[w[0] as usize..w[1] as usize]);
            slots.push(RESTART);
            starts.push(slots.len() as u32);
        }
        let regions = slots.len() as f32;
        let compact = (regions * compact_share.clamp(0.0, 1.0)).ceil() as u32;
        SlotLayout {
            starts,
            runtime,
            s0: slots,
            compact,
        }
    }

    /// Slots per instance: the regions (capacities plus separators) and the compact area.
    pub(super) fn per_instance(&self) -> u32 {
        self.regions() + self.compact
    }

    /// Shrinks the compact area (to nothing at most) so that an instance has at most
    /// `slots`.
    pub(super) fn fit(&mut self, slots: u64) {
        let room = slots.saturating_sub(u64::from(self.regions()));
        self.compact = self.compact.min(room.min(u64::from(u32::MAX)) as u32);
    }

    /// The record that reads the first `count` slots of the compact area (a frame's tail
    /// list written there).
    pub(super) fn tail_record(&self, count: u32) -> SlotRecord {
        SlotRecord {
            first: self.regions(),
            count,
            compact: true,
        }
    }

    /// Slots of the regions.
    fn regions(&self) -> u32 {
        *self.starts.last().unwrap_or(&0)
    }

    /// Slots of the compact area.
    pub(super) fn compact_slots(&self) -> u32 {
        self.compact
    }

    /// The regions of a new instance (`S0`, separators).
    pub(super) fn s0(&self) -> &[u32] {
        &self.s0
    }

    /// The live length of every region at `S0`.
    pub(super) fn s0_lengths(&self) -> Vec<u32> {
        self.runtime.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// Takes `state`'s dirty log (into `dirty`, scratch reused), appends to `out` the patches
    /// that bring the slots at `base` to its current strips and returns the record that draws
    /// them. Where the live strips and one restart between two fit the compact area, the
    /// record reads the copy: moves are patched in the strips' places at O(changed) (a strip
    /// that grew past its room moves to the end of the used part), and the copy is rewritten
    /// packed where it was not current, would pass the area or the record would read more than
    /// [`READ_BOUND_EIGHTHS`]/8 of the packed count; the regions are left behind (`places`
    /// notes it). Else the record reads the regions from the first live index to the last,
    /// brought up to date (`uploaded`: their lengths, empty while they are `S0`'s; every live
    /// strip whole after they were left behind).
    pub(super) fn upload(
        &self,
        base: u32,
        state: &mut DeformingState,
        places: &mut Places,
        uploaded: &mut Vec<u32>,
        dirty: &mut Dirty,
        out: &mut Vec<[u32; 2]>,
    ) -> SlotRecord {
        state.take_dirty_into(dirty);
        let dirty = &*dirty;
        let lengths = state.lengths();
        let packed = packed(state);
        if packed > 0 && packed <= self.compact {
            places.stale = true;
            let mark = out.len();
            // Moved in their places where that fits and sends fewer bytes than a repack.
            if !(places.current
                && self.move_places(base, state, dirty, places, packed, out)
                && run_bytes(&out[mark..]) <= run_bytes_of_one(packed))
            {
                out.truncate(mark);
                self.repack(base, state, places, packed, out);
            }
            // From the first live index of the copy to the last (every live strip has a
            // place holding its length).
            let (mut first, mut end) = (u32::MAX, 0);
            for (_, place) in places.placed.iter().filter(|(_, p)| p.len > 0) {
                first = first.min(place.at);
                end = end.max(place.at + place.len);
            }
            return SlotRecord {
                first: self.regions() + first,
                count: end - first,
                compact: true,
            };
        }
        places.current = false;
        if uploaded.is_empty() {
            *uploaded = self.s0_lengths();
        }
        if places.stale {
            let stale = places.take_stale(uploaded, lengths);
            self.patches(base, state, &stale, uploaded, out);
        } else {
            self.patches(base, state, dirty, uploaded, out);
        }
        self.region_record(lengths)
    }

    /// Appends the patches of `dirty` (the changes since the copy of the instance at `base`
    /// was last written) to `out`, each strip in its place or moved to the end of the used
    /// part; false where the used part would pass the compact area or the read bound (the
    /// caller then repacks; `places` and `out` are left partly written).
    fn move_places(
        &self,
        base: u32,
        state: &DeformingState,
        dirty: &Dirty,
        places: &mut Places,
        packed: u32,
        out: &mut Vec<[u32; 2]>,
    ) -> bool {
        let (indices, lengths) = (state.indices(), state.lengths());
        let area = base + self.regions();
        let bound = (packed * READ_BOUND_EIGHTHS / 8).min(self.compact);
        let copy = |r: usize, from: u32, to: u32, at: u32, out: &mut Vec<[u32; 2]>| {
            let source = self.runtime[r];
            out.extend((from..to).map(|i| [area + at + i, indices[(source + i) as usize]]));
        };
        let restarts = |from: u32, to: u32, out: &mut Vec<[u32; 2]>| {
            out.extend((area + from..area + to).map(|slot| [slot, RESTART]));
        };
        // The strips that outgrow their room move to the end of the used part: their rooms
        // summed first, and where they cannot fit the copy is repacked without the moves
        // being written first.
        let (mut end, mut k) = (places.used, 0);
        for (r, _, _) in by_strip(dirty) {
            let new = lengths[r];
            if new > find(&places.placed, &mut k, r).1.room {
                end += u32::from(end > 0) + new + new * SLACK_EIGHTHS / 8;
            }
        }
        if end > bound {
            return false;
        }
        let mut k = 0;
        places.born.clear();
        for (r, range, resized) in by_strip(dirty) {
            let (index, Place { at, room, len: old }) = find(&places.placed, &mut k, r);
            let new = lengths[r];
            if new <= room {
                // Past the shorter of the two lengths the growth or the restarts below write
                // every position; in slot order, so that a range and the growth after it make
                // one run.
                if let Some((start, end)) = range {
                    let kept = new.min(old);
                    copy(r, start.min(kept), end.min(kept), at, out);
                }
                if new > old {
                    copy(r, old, new, at, out);
                } else {
                    restarts(at + new, at + old, out);
                }
            } else {
                // Grown past its room (or born; its length changed, so `resized`): its old
                // place becomes restarts, it moves to the end, after a separator.
                debug_assert!(resized);
                restarts(at, at + old, out);
                let room = new + new * SLACK_EIGHTHS / 8;
                let start = if places.used > 0 { places.used + 1 } else { 0 };
                if start + room > bound {
                    return false;
                }
                if start > 0 {
                    restarts(start - 1, start, out);
                }
                copy(r, 0, new, start, out);
                restarts(start + new, start + room, out);
                let place = Place {
                    at: start,
                    room,
                    len: new,
                };
                match index {
                    Some(i) => places.placed[i].1 = place,
                    None => places.born.push((r as u32, place)),
                }
                places.used = start + room;
                continue;
            }
            if let Some(i) = index {
                places.placed[i].1.len = new;
            }
        }
        if !places.born.is_empty() {
            let Places { placed, born, .. } = places;
            placed.append(born);
            placed.sort_unstable_by_key(|&(r, _)| r);
        }
        places.used <= bound
    }

    /// Appends to `out` the patches that write `state`'s live strips packed into the compact
    /// area of the instance at `base`, each in a new place (with [`SLACK_EIGHTHS`] of room to
    /// grow where that fits the area and the read bound); `packed` (their packed count) fits.
    fn repack(
        &self,
        base: u32,
        state: &DeformingState,
        places: &mut Places,
        packed: u32,
        out: &mut Vec<[u32; 2]>,
    ) {
        let (indices, lengths) = (state.indices(), state.lengths());
        let slack = lengths
            .iter()
            .map(|&len| len * SLACK_EIGHTHS / 8)
            .sum::<u32>();
        let bound = (packed * READ_BOUND_EIGHTHS / 8).min(self.compact);
        let slack_eighths = if packed + slack <= bound {
            SLACK_EIGHTHS
        } else {
            0
        };
        places.placed.clear();
        let area = base + self.regions();
        let mut at = 0;
        for_each_live(lengths, |r, len| {
            if at > 0 {
                out.push([area + at, RESTART]);
                at += 1;
            }
            let room = len + len * slack_eighths / 8;
            let source = self.runtime[r] as usize;
            let strip = &indices[source..source + len as usize];
            out.extend(strip.iter().zip(area + at..).map(|(&v, slot)| [slot, v]));
            out.extend((area + at + len..area + at + room).map(|slot| [slot, RESTART]));
            // In strip order: the list stays sorted.
            places.placed.push((r as u32, Place { at, room, len }));
            at += room;
        });
        places.used = at;
        places.current = true;
        #[cfg(test)]
        {
            places.repacks += 1;
        }
    }

    /// The record that reads the regions of strips of `lengths` from the first live index to
    /// the last.
    pub(super) fn region_record(&self, lengths: &[u32]) -> SlotRecord {
        let first = lengths.iter().position(|&len| len > 0);
        let last = lengths.iter().rposition(|&len| len > 0);
        let (first, end) = match (first, last) {
            (Some(f), Some(l)) => (self.starts[f], self.starts[l] + lengths[l]),
            _ => (0, 0),
        };
        SlotRecord {
            first,
            count: end - first,
            compact: false,
        }
    }

    /// Appends to `out` the patches that take the slots at `base` from what the GPU holds
    /// (the strips of `uploaded` lengths, as of the last upload) to `state`'s current strips,
    /// given `dirty`, everything the runtime changed since (its contract: every changed
    /// position of a live strip lies in a range, every strip whose length changed is listed).
    /// Updates `uploaded`. Positions a strip left get [`RESTART`]; a position gets at most one
    /// patch (so the patches may be applied in any order, and no word is sent twice).
    pub(super) fn patches(
        &self,
        base: u32,
        state: &DeformingState,
        dirty: &Dirty,
        uploaded: &mut [u32],
        out: &mut Vec<[u32; 2]>,
    ) {
        let (indices, lengths) = (state.indices(), state.lengths());
        let copy = |r: usize, from: u32, to: u32, out: &mut Vec<[u32; 2]>| {
            let (slot, source) = (base + self.starts[r], self.runtime[r]);
            out.extend((from..to).map(|i| [slot + i, indices[(source + i) as usize]]));
        };
        for (r, range, _) in by_strip(dirty) {
            let (old, new) = (uploaded[r], lengths[r]);
            // Past the shorter of the two lengths the growth or the restarts below write every
            // position; in slot order, so that a range and the growth after it make one run.
            if let Some((start, end)) = range {
                let kept = new.min(old);
                copy(r, start.min(kept), end.min(kept), out);
            }
            if new > old {
                copy(r, old, new, out);
            } else {
                let slot = base + self.starts[r];
                out.extend((new..old).map(|i| [slot + i, RESTART]));
            }
            uploaded[r] = new;
        }
    }
}

/// Bytes of `patches` in the scatter's run list, where consecutive slots in the list make a
/// run ([`super::super::scatter::encode_runs`]: 8 for a lone word; 8 per [`RUN_WORDS`] words
/// and 4 a word for a longer run).
fn run_bytes(patches: &[[u32; 2]]) -> u32 {
    let mut bytes = 0;
    let mut run = 0;
    for (i, p) in patches.iter().enumerate() {
        if i > 0 && patches[i - 1][0] + 1 != p[0] {
            bytes += run_bytes_of_one(run);
            run = 0;
        }
        run += 1;
    }
    bytes + run_bytes_of_one(run)
}

/// Bytes of one run of `words` consecutive words.
fn run_bytes_of_one(words: u32) -> u32 {
    match words {
        0 => 0,
        1 => 8,
        n => 8 * n.div_ceil(RUN_WORDS) + 4 * n,
    }
}

/// Every strip `dirty` names, in ascending order, once: its changed range (if any) and
/// whether its length changed. (Its lists are sorted; were they not, each strip would still
/// come once per list, only not merged.)
fn by_strip(dirty: &Dirty) -> impl Iterator<Item = (usize, Option<(u32, u32)>, bool)> + '_ {
    let mut ranges = dirty.ranges.iter().peekable();
    let mut lengths = dirty.lengths.iter().peekable();
    std::iter::from_fn(move || {
        let (range, length) = (ranges.peek().map(|r| r.strip), lengths.peek().copied());
        let strip = match (range, length) {
            (None, None) => return None,
            (Some(a), Some(&b)) => a.min(b),
            (Some(a), None) => a,
            (None, Some(&b)) => b,
        };
        let range = ranges
            .next_if(|r| r.strip == strip)
            .map(|r| (r.start, r.end));
        let resized = lengths.next_if(|&&l| l == strip).is_some();
        Some((strip as usize, range, resized))
    })
}

/// The slots of `state`'s live strips packed: their lengths and one restart between two.
fn packed(state: &DeformingState) -> u32 {
    (state.index_count() + state.live_strip_count()).saturating_sub(1) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deform::Lod;

    /// A small grid morph with a few frames, so the walk switches frames.
    fn model() -> DeformingModel {
        super::super::grid_model(7).1
    }

    /// The regions as built from scratch from the state's strips.
    fn from_scratch(layout: &SlotLayout, state: &DeformingState) -> Vec<u32> {
        let mut slots = vec![RESTART; layout.regions() as usize];
        for r in 0..state.lengths().len() {
            let strip = state.strip(r).expect("strip");
            let start = layout.starts[r] as usize;
            slots[start..start + strip.len()].copy_from_slice(strip);
        }
        slots
    }

    /// The triangles `words` draw as triangle strips cut by [`RESTART`] (odd triangles of a
    /// strip flipped), degenerate ones left out, each turned to start at its least index
    /// (orientation kept), sorted.
    fn triangles(words: &[u32]) -> Vec<[u32; 3]> {
        let mut out = Vec::new();
        for strip in words.split(|&w| w == RESTART) {
            for (i, w) in strip.windows(3).enumerate() {
                let t = if i % 2 == 0 {
                    [w[0], w[1], w[2]]
                } else {
                    [w[1], w[0], w[2]]
                };
                if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                    continue;
                }
                let m = (0..3).min_by_key(|&k| t[k]).expect("three");
                out.push([t[m], t[(m + 1) % 3], t[(m + 2) % 3]]);
            }
        }
        out.sort_unstable();
        out
    }

    /// The triangles of the state's strips, each decoded on its own.
    fn reference(state: &DeformingState) -> Vec<[u32; 3]> {
        let mut out: Vec<[u32; 3]> = (0..state.lengths().len())
            .flat_map(|r| triangles(state.strip(r).expect("strip")))
            .collect();
        out.sort_unstable();
        out
    }

    /// One instance's slots on a simulated GPU (its neighbours' slots must stay 0).
    struct Gpu {
        words: Vec<u32>,
        base: u32,
        end: u32,
        /// The dirty-log scratch, reused over a walk as a crowd's piece reuses it.
        dirty: Dirty,
    }

    impl Gpu {
        fn new(layout: &SlotLayout) -> Gpu {
            let base = 3 * layout.per_instance();
            let end = base + layout.per_instance();
            // The compact area starts as 0s: a word read but never written draws vertex 0.
            let mut words = vec![0u32; end as usize + 5];
            words[base as usize..(base + layout.regions()) as usize].copy_from_slice(layout.s0());
            Gpu {
                words,
                base,
                end,
                dirty: Dirty::default(),
            }
        }

        /// Applies `patches` in reverse order (any order must do), each word once.
        fn apply(&mut self, patches: &[[u32; 2]]) {
            let mut slots: Vec<u32> = patches.iter().map(|p| p[0]).collect();
            slots.sort_unstable();
            slots.dedup();
            assert_eq!(slots.len(), patches.len(), "a slot patched twice");
            for &[slot, value] in patches.iter().rev() {
                self.words[slot as usize] = value;
            }
            let (base, end) = (self.base as usize, self.end as usize);
            assert!(
                self.words[..base]
                    .iter()
                    .chain(&self.words[end..])
                    .all(|&w| w == 0),
                "other slots untouched"
            );
        }

        fn read(&self, record: SlotRecord) -> &[u32] {
            &self.words[(self.base + record.first) as usize..][..record.count as usize]
        }
    }

    /// One upload of `state`'s changes, checked: the record draws exactly the state's
    /// triangles (with parity); where it reads the regions they are the regions built from
    /// scratch, with nothing before the first live index or after the last; it reads the
    /// compact copy exactly where the packed strips fit, and then at most the read bound.
    fn upload_checked(
        layout: &SlotLayout,
        state: &mut DeformingState,
        places: &mut Places,
        uploaded: &mut Vec<u32>,
        gpu: &mut Gpu,
        step: usize,
    ) -> SlotRecord {
        let mut patches = Vec::new();
        let record = layout.upload(
            gpu.base,
            state,
            places,
            uploaded,
            &mut gpu.dirty,
            &mut patches,
        );
        gpu.apply(&patches);
        let read = gpu.read(record);
        assert_eq!(triangles(read), reference(state), "step {step}");
        // The packed count from the lengths themselves, not the state's running counts.
        let lengths = state.lengths();
        let packed = (lengths
            .iter()
            .filter(|&&n| n != 0)
            .map(|&n| n + 1)
            .sum::<u32>())
        .saturating_sub(1);
        assert_eq!(packed, super::packed(state));
        assert_eq!(
            record.compact,
            packed > 0 && packed <= layout.compact_slots()
        );
        if record.compact {
            assert!(record.first >= layout.regions());
            assert!(record.count >= packed);
            assert!(
                record.count <= packed * READ_BOUND_EIGHTHS / 8,
                "step {step}"
            );
        } else {
            let (base, regions) = (gpu.base as usize, (gpu.base + layout.regions()) as usize);
            assert_eq!(
                &gpu.words[base..regions],
                from_scratch(layout, state).as_slice(),
                "step {step}"
            );
            assert_eq!(uploaded.as_slice(), state.lengths());
        }
        assert!(read.first() != Some(&RESTART) && read.last() != Some(&RESTART));
        record
    }

    /// Over a walk with frame switches and LOD jumps (moves accumulating between uploads),
    /// the record draws the state's strips: from the compact copy exactly where they fit it,
    /// else from the regions, which are then those built from scratch.
    #[test]
    fn patches_bring_the_slots_to_the_current_strips() {
        let model = model();
        for share in [0.0, 0.3, 1.0] {
            let layout = SlotLayout::new(&model, share);
            let mut state = DeformingState::new(&model);
            let mut gpu = Gpu::new(&layout);
            let mut places = Places::default();
            // As `Crowd::add` makes it: empty while the regions hold S0.
            let mut uploaded = Vec::new();
            let walk = [
                (0.0, 0.5),
                (0.0, 0.9),
                (0.7, 0.9),
                (0.7, 0.1),
                (1.0, 1.0),
                (0.2, 0.0),
                (0.4, 0.6),
            ];
            let mut compacted = 0;
            for (step, &(t, lod)) in walk.iter().enumerate() {
                state.set(&model, t, Lod::Fraction(lod)).expect("set");
                // Every other step moves twice before the upload: the dirty log accumulates.
                if step % 2 == 1 {
                    state.set(&model, 1.0 - t, Lod::Fraction(0.3)).expect("set");
                }
                let record = upload_checked(
                    &layout,
                    &mut state,
                    &mut places,
                    &mut uploaded,
                    &mut gpu,
                    step,
                );
                compacted += usize::from(record.compact);
            }
            // Without a compact area never; with one as large as the regions always.
            assert_eq!(compacted == 0, share == 0.0);
            if share == 1.0 {
                assert_eq!(compacted, walk.len());
            }
        }
    }

    /// Over a long random walk (small LOD steps up and down, jumps, frame switches) every
    /// way a strip of the compact copy moves happens, each upload checked as above: a move
    /// within its room, to the end of the used part, a death, a birth, a repack, and records
    /// going back to the regions and to the copy again.
    #[test]
    fn places_follow_a_long_random_walk() {
        let model = model();
        let layout = SlotLayout::new(&model, 0.6);
        let mut state = DeformingState::new(&model);
        let mut gpu = Gpu::new(&layout);
        let mut places = Places::default();
        let mut uploaded = Vec::new();
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut random = move || crate::random::next_unit(&mut seed) as f32;
        let (mut t, mut lod) = (0.0f32, 0.5f32);
        let (mut within, mut to_end, mut deaths, mut births, mut back) = (0, 0, 0, 0, 0);
        let mut was_compact = false;
        for step in 0..400 {
            let roll = random();
            if roll < 0.1 {
                lod = random();
            } else {
                lod = (lod + 0.08 * (random() - 0.5)).clamp(0.0, 1.0);
            }
            if roll > 0.7 {
                t = random();
            }
            state.set(&model, t, Lod::Fraction(lod)).expect("set");
            let strips = state.lengths().len();
            let before = places.dense(strips);
            let (repacks, current) = (places.repacks, places.current);
            let record = upload_checked(
                &layout,
                &mut state,
                &mut places,
                &mut uploaded,
                &mut gpu,
                step,
            );
            back += usize::from(was_compact && !record.compact);
            was_compact = record.compact;
            if !(record.compact && current && places.repacks == repacks) {
                continue;
            }
            for (old, now) in before.iter().zip(&places.dense(strips)) {
                let (at, len, new) = (old.at, old.len, now.len);
                within += usize::from(at == now.at && len != new && len > 0 && new > 0);
                to_end += usize::from(at != now.at && len > 0);
                deaths += usize::from(len > 0 && new == 0);
                births += usize::from(len == 0 && new > 0);
            }
        }
        let counts = [
            within,
            to_end,
            deaths,
            births,
            places.repacks as usize,
            back,
        ];
        assert!(counts.iter().all(|&n| n > 0), "{counts:?}");
    }
}
