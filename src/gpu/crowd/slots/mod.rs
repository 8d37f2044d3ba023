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
    /// most of a strip anyway (docs/benchmarks-log.md, "Stale regions sent whole").
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
            let words = (source + from) as usize..(source + to) as usize;
            let word = at + from;
            indices
                .slice(words)
                .extend_mapped(out, |k, v| [word + k as u32, v]);
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
            let strip = indices.slice(source..source + len as usize);
            strip.extend_mapped(out, |k, v| [at + k as u32, v]);
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
            let words = (source + from) as usize..(source + to) as usize;
            let word = slot + from;
            indices
                .slice(words)
                .extend_mapped(out, |k, v| [word + k as u32, v]);
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
mod tests;
