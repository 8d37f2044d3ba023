//! What an instance's area of index memory ([`super::pool`]) holds, and the patches that bring
//! it from what the GPU holds to the runtime's current strips.
//!
//! Where its live strips are few (a coarse LOD: their packed count within the compact share of
//! the regions), the area holds a compact copy of them, each in a place of its own
//! ([`Places`]) that it keeps while it fits, and the instance's record reads that copy: the
//! live indices and a few restarts. Else (close to the camera) the area holds its regions:
//! region `r` (strip `r` of `S0`) at `starts[r]..starts[r] + capacity`, followed by one
//! separator slot that always holds [`RESTART`]: the layout of a strip
//! [`Object`](super::super::Object), so one record draws all its strips (restarts separate
//! them), and patches keep it current at O(changed indices). Each upload says what area it
//! needs ([`Need`]): a copy that outgrows its area moves to a larger one (its used part copied
//! on the GPU), a repacked copy takes an area of its size, regions take the whole layout.
//! The CPU keeps no mirror of the slots: what the GPU holds is known from the runtime's strips
//! as of the last upload, and the runtime's dirty log says which positions may differ since.
//! A patch is `[word, value]`, the word counted from the start of the instance's area; a
//! frame's patches of all instances are encoded as runs of consecutive words and applied by
//! one scatter dispatch per page.

use crate::deform::{DeformingModel, DeformingState};
use crate::lodstrips::{for_each_live, Dirty, DirtyRange};

pub(super) use super::types::DrawnFrom;

use super::super::scatter::RUN_WORDS;
use super::super::RESTART;
use super::pool::GRANULE;

/// Where the regions of one instance lie, relative to the start of its area.
pub(super) struct SlotLayout {
    /// Region r starts at `starts[r]`; `starts[regions]` is the words of the regions.
    starts: Vec<u32>,
    /// Region r starts at `runtime[r]` in the runtime's packed buffer (no separators).
    runtime: Vec<u32>,
    /// `S0` with a separator after every region: what the asset's shared `S0` area holds.
    s0: Vec<u32>,
    /// The most words of a compact copy (the compact share of the regions').
    compact: u32,
}

/// Which words of its area (or of the shared `S0`) an instance's one draw record reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct SlotRecord {
    pub(super) first: u32,
    pub(super) count: u32,
}

/// The area an instance needs after a move: holding `holds`, at least `min` words. Its area is
/// kept where it holds the same and has at most `max` words (and at least `min`); else it gets
/// a new one of `room` words (at least `min`), holding the first `keep` words of the old one
/// (copied on the GPU: a compact copy grown past its area, whose places keep their words) or,
/// for regions, [`RESTART`] everywhere, which the patches then fill.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Need {
    pub(super) holds: DrawnFrom,
    pub(super) min: u32,
    pub(super) max: u32,
    pub(super) room: u32,
    pub(super) keep: u32,
}

/// The most words an area may keep for a need of `words`: three times that (so that an area
/// is made anew, and the old one freed, where what the instance draws fell to a third), and
/// never less than a new area's room of 1.5 times, rounded up to the pool's granule.
pub(super) fn most_words(words: u32) -> u32 {
    (3 * words).max(words + words / 2 + 2 * GRANULE)
}

impl Need {
    /// The regions: `words` of them, patched where they are (any area holding them is kept:
    /// the patches are made against what it holds).
    pub(super) fn regions(words: u32) -> Need {
        Need {
            holds: DrawnFrom::Regions,
            min: words,
            max: u32::MAX,
            room: words,
            keep: 0,
        }
    }

    /// Whether an area of `words` (rounded up to the pool's granule) holding `holds` serves
    /// this need as it is.
    pub(super) fn keeps(&self, holds: DrawnFrom, words: u32) -> bool {
        let max = self
            .max
            .checked_next_multiple_of(GRANULE)
            .unwrap_or(u32::MAX);
        holds == self.holds && (self.min..=max).contains(&words)
    }

    /// An area for `words` of `holds` written anew, with room to grow by half (at most to
    /// `largest`): the current one is kept from `words` to [`most_words`].
    pub(super) fn with_headroom(holds: DrawnFrom, words: u32, largest: u32) -> Need {
        let room = (words + words / 2).min(largest).max(words);
        Need {
            holds,
            min: words,
            max: most_words(words),
            room,
            keep: 0,
        }
    }
}

/// Where an instance's live strips lie in its compact copy, and whether its regions lag
/// behind its strips. Empty (no heap) until the instance is first drawn from its copy.
///
/// A strip with a place has `at..at + room` of the copy's area, holding its `len` indices as
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
    /// The end of the used part (the record reads within `0..used` of the area, from its
    /// first live index to its last).
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

    /// The instance is drawn from elsewhere (its frame's tail list, written over its area):
    /// the copy is repacked and the regions get every live strip when a record reads them
    /// again.
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

/// Where one strip lies in the compact copy (see [`Places`]).
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
    /// The regions of `model`'s instances, and compact copies of at most `compact_share`
    /// (clamped to 0..=1) of the regions' words.
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

    /// Words of the regions.
    pub(super) fn regions(&self) -> u32 {
        *self.starts.last().unwrap_or(&0)
    }

    /// The most words of a compact copy.
    pub(super) fn compact_slots(&self) -> u32 {
        self.compact
    }

    /// The regions at `S0` (separators included): the asset's shared `S0` area.
    pub(super) fn s0(&self) -> &[u32] {
        &self.s0
    }

    /// The live length of every region at `S0`.
    pub(super) fn s0_lengths(&self) -> Vec<u32> {
        self.runtime.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// Takes `state`'s dirty log (into `dirty`, scratch reused), appends to `out` the patches
    /// that bring its area (which `held` holds, of `words` words) to its current strips and
    /// returns the record that draws them and the area that needs. Where the live strips and
    /// one restart between two fit the compact share, the area holds a copy of them: moves are
    /// patched in the strips' places at O(changed) (a strip that grew past its room moves to
    /// the end of the used part, and the area grows, copied on the GPU, where that passes
    /// it), and the copy is rewritten packed into an area of its size where it was not
    /// current, the record would read more than [`READ_BOUND_EIGHTHS`]/8 of the packed count
    /// or the moves would send more bytes; the regions are given up (`places` notes that
    /// they lag, `uploaded` is emptied). Else the area holds the regions, read from the first
    /// live index to the last and brought up to date (`uploaded`: their lengths; every live
    /// strip whole into new regions, which hold restarts, or after they were left behind).
    pub(super) fn upload(
        &self,
        (held, words): (DrawnFrom, u32),
        state: &mut DeformingState,
        places: &mut Places,
        uploaded: &mut Vec<u32>,
        dirty: &mut Dirty,
        out: &mut Vec<[u32; 2]>,
    ) -> (SlotRecord, Need) {
        state.take_dirty_into(dirty);
        let dirty = &*dirty;
        let lengths = state.lengths();
        let packed = packed(state);
        if packed <= self.compact {
            places.stale = true;
            if held == DrawnFrom::Regions {
                *uploaded = Vec::new();
            }
            let mark = out.len();
            let used = places.used;
            // Moved in their places where that fits the read bound and sends fewer bytes
            // than a repack; the area grows where the moved strips pass it.
            let moved = held == DrawnFrom::Copy
                && places.current
                && self.move_places(state, dirty, places, packed, out)
                && run_bytes(&out[mark..]) <= run_bytes_of_one(packed);
            let need = if moved {
                // Grown past its area: twice the area or half again the used part, its used
                // part copied; shrunk to a third: half again the used part, copied too.
                let grown = if places.used > words { 2 * words } else { 0 };
                let room = (places.used + places.used / 2)
                    .max(grown)
                    .min(self.compact)
                    .max(places.used);
                Need {
                    holds: DrawnFrom::Copy,
                    min: places.used,
                    max: most_words(packed).max(places.used),
                    room,
                    keep: used,
                }
            } else {
                out.truncate(mark);
                self.repack(state, places, packed, out);
                Need::with_headroom(DrawnFrom::Copy, packed, self.compact)
            };
            // From the first live index of the copy to the last (every live strip has a
            // place holding its length).
            let (mut first, mut end) = (u32::MAX, 0);
            for (_, place) in places.placed.iter().filter(|(_, p)| p.len > 0) {
                first = first.min(place.at);
                end = end.max(place.at + place.len);
            }
            let record = SlotRecord {
                first: first.min(end),
                count: end.saturating_sub(first),
            };
            return (record, need);
        }
        places.current = false;
        if held != DrawnFrom::Regions {
            // New regions hold restarts: every live strip goes whole.
            *uploaded = vec![0; lengths.len()];
            places.stale = true;
        }
        if places.stale {
            let stale = places.take_stale(uploaded, lengths);
            self.patches(state, &stale, uploaded, out);
        } else {
            self.patches(state, dirty, uploaded, out);
        }
        let need = Need::regions(self.regions());
        (self.region_record(lengths), need)
    }

    /// Appends the patches of `dirty` (the changes since the copy was last written) to `out`,
    /// each strip in its place or moved to the end of the used part; false where the used
    /// part would pass the compact share or the read bound (the caller then repacks;
    /// `places` and `out` are left partly written).
    fn move_places(
        &self,
        state: &DeformingState,
        dirty: &Dirty,
        places: &mut Places,
        packed: u32,
        out: &mut Vec<[u32; 2]>,
    ) -> bool {
        let (indices, lengths) = (state.indices(), state.lengths());
        let bound = (packed * READ_BOUND_EIGHTHS / 8).min(self.compact);
        let copy = |r: usize, from: u32, to: u32, at: u32, out: &mut Vec<[u32; 2]>| {
            let source = self.runtime[r];
            out.extend((from..to).map(|i| [at + i, indices[(source + i) as usize]]));
        };
        let restarts = |from: u32, to: u32, out: &mut Vec<[u32; 2]>| {
            out.extend((from..to).map(|word| [word, RESTART]));
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

    /// Appends to `out` the patches that write `state`'s live strips packed from the start of
    /// the area, each in a new place (with [`SLACK_EIGHTHS`] of room to grow where that fits
    /// the compact share and the read bound); `packed` (their packed count) fits.
    fn repack(
        &self,
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
        let mut at = 0;
        for_each_live(lengths, |r, len| {
            if at > 0 {
                out.push([at, RESTART]);
                at += 1;
            }
            let room = len + len * slack_eighths / 8;
            let source = self.runtime[r] as usize;
            let strip = &indices[source..source + len as usize];
            out.extend(strip.iter().zip(at..).map(|(&v, word)| [word, v]));
            out.extend((at + len..at + room).map(|word| [word, RESTART]));
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
        }
    }

    /// Appends to `out` the patches that take the regions from what the GPU holds
    /// (the strips of `uploaded` lengths, as of the last upload) to `state`'s current strips,
    /// given `dirty`, everything the runtime changed since (its contract: every changed
    /// position of a live strip lies in a range, every strip whose length changed is listed).
    /// Updates `uploaded`. Positions a strip left get [`RESTART`]; a position gets at most one
    /// patch (so the patches may be applied in any order, and no word is sent twice).
    pub(super) fn patches(
        &self,
        state: &DeformingState,
        dirty: &Dirty,
        uploaded: &mut [u32],
        out: &mut Vec<[u32; 2]>,
    ) {
        let (indices, lengths) = (state.indices(), state.lengths());
        let copy = |r: usize, from: u32, to: u32, out: &mut Vec<[u32; 2]>| {
            let (slot, source) = (self.starts[r], self.runtime[r]);
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
                let slot = self.starts[r];
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

    /// Never written: a word read but never written would draw this vertex.
    const POISON: u32 = 0xDEAD_BEEF;

    /// One instance's area on a simulated page: moved to a new area (after a gap) wherever an
    /// upload needs one, as the crowd's pool does; words outside its area stay [`POISON`].
    struct Gpu {
        words: Vec<u32>,
        /// Its area's first word and words, and what it holds.
        area: Option<(u32, u32)>,
        holds: DrawnFrom,
        /// The dirty-log scratch, reused over a walk as a crowd's piece reuses it.
        dirty: Dirty,
        /// Areas made anew that kept words of the old one (a copy grown past its area).
        grown: usize,
    }

    impl Gpu {
        fn new() -> Gpu {
            Gpu {
                words: Vec::new(),
                area: None,
                holds: DrawnFrom::S0,
                dirty: Dirty::default(),
                grown: 0,
            }
        }

        fn held(&self) -> (DrawnFrom, u32) {
            (self.holds, self.area.map_or(0, |(_, words)| words))
        }

        /// What the crowd does with `need` before the patches apply: the area is kept where
        /// it holds the same and has `min..=max` words; else a new one of `room` words takes
        /// the old one's first `keep` words (restarts everywhere for regions), and the old
        /// one's words are poisoned (freed).
        fn settle(&mut self, need: Need) {
            assert!(need.min <= need.room && need.min <= need.max, "{need:?}");
            let fits = self
                .area
                .is_some_and(|(_, words)| need.keeps(self.holds, words));
            if !fits {
                // The pool rounds areas up to its granule.
                let room = need.room.next_multiple_of(GRANULE);
                let at = self.words.len() as u32 + 7;
                self.words.resize((at + room) as usize, POISON);
                let new = at as usize..(at + room) as usize;
                if need.holds == DrawnFrom::Regions {
                    self.words[new.clone()].fill(RESTART);
                }
                if let Some((old, words)) = self.area {
                    assert!(need.keep <= words, "{need:?}: keeps more than the old area");
                    let old = old as usize..(old + words) as usize;
                    let keep = need.keep as usize;
                    self.words
                        .copy_within(old.start..old.start + keep, new.start);
                    self.grown += usize::from(keep > 0);
                    self.words[old].fill(POISON);
                } else {
                    assert_eq!(need.keep, 0, "nothing to keep");
                }
                self.area = Some((at, room));
            }
            self.holds = need.holds;
        }

        /// Applies `patches` (words of the area) in reverse order (any order must do), each
        /// word once, every one within the area.
        fn apply(&mut self, patches: &[[u32; 2]]) {
            let mut words: Vec<u32> = patches.iter().map(|p| p[0]).collect();
            words.sort_unstable();
            words.dedup();
            assert_eq!(words.len(), patches.len(), "a word patched twice");
            let (at, size) = self.area.expect("an area");
            for &[word, value] in patches.iter().rev() {
                assert!(word < size, "word {word} past the area's {size}");
                self.words[(at + word) as usize] = value;
            }
        }

        fn read(&self, record: SlotRecord) -> &[u32] {
            let (at, size) = self.area.expect("an area");
            assert!(
                record.first + record.count <= size,
                "{record:?} past the area"
            );
            &self.words[(at + record.first) as usize..][..record.count as usize]
        }
    }

    /// One upload of `state`'s changes, checked: the area is settled and patched as the crowd
    /// does, and the record draws exactly the state's triangles (with parity) and no word
    /// never written; where the area holds the regions they are the regions built from
    /// scratch, with nothing before the first live index or after the last; it holds the
    /// compact copy exactly where the packed strips fit the share, and the record then reads
    /// at most the read bound.
    fn upload_checked(
        layout: &SlotLayout,
        state: &mut DeformingState,
        places: &mut Places,
        uploaded: &mut Vec<u32>,
        gpu: &mut Gpu,
        step: usize,
    ) -> DrawnFrom {
        let mut patches = Vec::new();
        let (record, need) = layout.upload(
            gpu.held(),
            state,
            places,
            uploaded,
            &mut gpu.dirty,
            &mut patches,
        );
        gpu.settle(need);
        gpu.apply(&patches);
        let read = gpu.read(record);
        assert!(!read.contains(&POISON), "step {step}: a word never written");
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
        let compact = need.holds == DrawnFrom::Copy;
        assert_eq!(compact, packed <= layout.compact_slots());
        if compact {
            assert!(record.count >= packed);
            assert!(
                record.count <= packed * READ_BOUND_EIGHTHS / 8,
                "step {step}"
            );
            assert!(uploaded.is_empty(), "regions given up");
        } else {
            let (at, size) = gpu.area.expect("an area");
            assert!(size >= layout.regions());
            let regions = &gpu.words[at as usize..(at + layout.regions()) as usize];
            assert_eq!(
                regions,
                from_scratch(layout, state).as_slice(),
                "step {step}"
            );
            assert_eq!(uploaded.as_slice(), state.lengths());
        }
        assert!(read.first() != Some(&RESTART) && read.last() != Some(&RESTART));
        need.holds
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
            let mut gpu = Gpu::new();
            let mut places = Places::default();
            // As `Crowd::add` makes it: no regions.
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
                let holds = upload_checked(
                    &layout,
                    &mut state,
                    &mut places,
                    &mut uploaded,
                    &mut gpu,
                    step,
                );
                compacted += usize::from(holds == DrawnFrom::Copy);
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
        let mut gpu = Gpu::new();
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
            let compact = upload_checked(
                &layout,
                &mut state,
                &mut places,
                &mut uploaded,
                &mut gpu,
                step,
            ) == DrawnFrom::Copy;
            back += usize::from(was_compact && !compact);
            was_compact = compact;
            if !(compact && current && places.repacks == repacks) {
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
            gpu.grown,
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
