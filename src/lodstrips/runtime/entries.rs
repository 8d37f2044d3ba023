//! A rebuild's inner loops: every strip not empty at the LOD written from its entries alive
//! there (`S0` slots and copies, blocks with nothing alive skipped), the strips emptied,
//! what changed marked.

use super::dirty::Mark;
use super::index::StripIndex;
use crate::lodstrips::packed::Narrow;
use crate::lodstrips::{FrameChanges, StripLayout, DEATH_BLOCK};

/// The rebuild of strips `strips` (see [`StripsState::rebuild`](super::StripsState::rebuild))
/// over their regions `indices` (from the first strip's region start) and live lengths
/// `lens`, at `l` collapses of `frame`, the survivor of a vertex given by `find`; what changed
/// goes to `mark` (per strip its length, then its span).
///
/// Its work follows what is alive before and after, not the mesh: the strips empty at `l`
/// cost one look at their old length; when few strips are alive at `l` they are taken from
/// the frame's `strips_by_death` prefix rather than found by a pass over `strips`; and within a
/// strip the blocks of slots with nothing alive at `l` are skipped unread ([`rebuild_strip`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn rebuild_strips<I: StripIndex>(
    layout: &StripLayout,
    frame: &FrameChanges,
    l: u32,
    strips: std::ops::Range<usize>,
    indices: &mut [I],
    lens: &mut [u32],
    mut find: impl FnMut(u32) -> u32,
    mut mark: impl FnMut(Mark),
) {
    let first = strips.start;
    let base = layout.region_offsets[first] as usize;
    empty_dead_strips(frame, l, first, lens, &mut mark);
    let mut strip = |s: usize, ci: usize, lens: &mut [u32]| {
        let region = &mut indices[layout.region_offsets[s] as usize - base..];
        let len = &mut lens[s - first];
        rebuild_strip(layout, frame, l, s, ci, region, len, &mut find, &mut mark)
    };
    let alive = frame.strips_alive(l);
    if alive * 4 < strips.len() {
        for j in 0..alive {
            let s = frame.strips_by_death.get(j) as usize;
            if strips.contains(&s) {
                strip(s, frame.first_copy(s), lens);
            }
        }
    } else {
        for s in strips {
            if frame.strip_death.get(s) > l {
                strip(s, frame.first_copy(s), lens);
            }
        }
    }
}

/// Empties the strips of `lens` (strip `first` on) that hold something but nothing alive at
/// `l`, marking their lengths. Most strips are empty before and after: only the live ones are
/// looked up ([`live_mask`]).
pub(super) fn empty_dead_strips(
    frame: &FrameChanges,
    l: u32,
    first: usize,
    lens: &mut [u32],
    mark: &mut impl FnMut(Mark),
) {
    for (c, chunk) in lens.chunks_mut(16).enumerate() {
        let mut live = live_mask(chunk);
        while live != 0 {
            let i = live.trailing_zeros() as usize;
            let s = first + 16 * c + i;
            if frame.strip_death.get(s) <= l {
                chunk[i] = 0;
                mark(Mark::Len(s as u32));
            }
            live &= live - 1;
        }
    }
}

/// Calls `f(i, len)` for every strip `i` of `lengths` whose length `len` is not 0, in order.
/// A coarse state has a few dozen live strips among a thousand: the lengths are read 16 at a
/// time into a mask of the live ones ([`live_mask`]), and only its set bits are visited.
#[cfg(feature = "gpu")]
#[inline]
pub(crate) fn for_each_live(lengths: &[u32], mut f: impl FnMut(usize, u32)) {
    for (c, chunk) in lengths.chunks(16).enumerate() {
        let mut live = live_mask(chunk);
        while live != 0 {
            let i = live.trailing_zeros() as usize;
            f(16 * c + i, chunk[i]);
            live &= live - 1;
        }
    }
}

/// Bit `i` set where `chunk[i]` (at most 32 lengths) is not 0. Most chunks of a coarse state
/// are all 0: one OR of the chunk (which the compiler vectorises) answers them.
#[inline]
pub(super) fn live_mask(chunk: &[u32]) -> u32 {
    if chunk.iter().fold(0, |a, &n| a | n) == 0 {
        return 0;
    }
    chunk
        .iter()
        .enumerate()
        .fold(0, |m, (i, &n)| m | u32::from(n != 0) << i)
}

/// A strip's rebuilt entries written over its old ones, one after another: only the values
/// that differ are written, and the span from the first to the last of them (and the
/// positions past the old live length) is marked.
pub(super) struct StripWriter {
    old: usize,
    q: usize,
    lo: usize,
    hi: usize,
}

impl StripWriter {
    /// Before the first entry of a strip whose live length was `old`.
    pub(super) fn new(old: u32) -> StripWriter {
        StripWriter {
            old: old as usize,
            q: 0,
            lo: usize::MAX,
            hi: 0,
        }
    }

    /// Writes `v` at the next position of `region` (the strip's region and on).
    #[inline]
    pub(super) fn put<I: StripIndex>(&mut self, region: &mut [I], v: u32) {
        let q = self.q;
        let v = I::of(v);
        if q >= self.old || region[q] != v {
            region[q] = v;
            self.lo = self.lo.min(q);
            self.hi = q + 1;
        }
        self.q += 1;
    }

    /// Sets strip `s`'s live length `len` to the entries written, marking it if it changed,
    /// then the changed span.
    pub(super) fn finish(self, s: usize, len: &mut u32, mark: &mut impl FnMut(Mark)) {
        if self.q as u32 != *len {
            *len = self.q as u32;
            mark(Mark::Len(s as u32));
        }
        if self.lo < self.hi {
            mark(Mark::Span(s as u32, self.lo as u32, self.hi as u32));
        }
    }
}

/// Rebuilds strip `s` (not empty at `l`, its first copy `ci`) in `region` (its region and
/// on) at `l` collapses of `frame`, `len` its live length.
///
/// The strip's entries are read in order, slots and the copies after their anchor slots,
/// except in blocks of `S0` slots ([`DEATH_BLOCK`]) whose largest death is at most `l`:
/// those hold nothing alive and are skipped with their copies. At a coarse LOD a long strip
/// costs a compare per block (64 to a mask) and the few live blocks' slots.
#[allow(clippy::too_many_arguments)]
fn rebuild_strip<I: StripIndex>(
    layout: &StripLayout,
    frame: &FrameChanges,
    l: u32,
    s: usize,
    ci: usize,
    region: &mut [I],
    len: &mut u32,
    find: &mut impl FnMut(u32) -> u32,
    mark: &mut impl FnMut(Mark),
) {
    let start = layout.region_offsets[s] as usize;
    let end = layout.region_offsets[s + 1] as usize;
    let mut out = StripWriter::new(*len);
    let copies = frame.copy_count();
    // The anchor of copy `c` (past the last copy: beyond every slot).
    let anchor = |c: usize| {
        if c < copies {
            frame.copy_after.get(c) as usize
        } else {
            usize::MAX
        }
    };
    let mut ci = ci;
    let mut next_after = anchor(ci);
    // The runs of blocks holding something alive at `l`, read slot by slot; the dead blocks
    // between runs, and their copies, are skipped unread.
    let blocks = start / DEATH_BLOCK..(end - 1) / DEATH_BLOCK + 1;
    alive_runs(&frame.block_death, blocks, l, |first, last| {
        let mut p = (first * DEATH_BLOCK).max(start);
        let live_end = (last * DEATH_BLOCK).min(end);
        while next_after < p {
            ci += 1;
            next_after = anchor(ci);
        }
        while p < live_end {
            // `S0` slots up to the next copy anchor, then its copies.
            let stop = if next_after < live_end {
                next_after + 1
            } else {
                live_end
            };
            // The deaths read as a slice of their width, not matched per slot: the loop
            // most of a large rebuild's time goes to.
            let s0 = &layout.s0[p..stop];
            let mut live = |v: u32| out.put(region, find(v));
            match &frame.death {
                Narrow::U16(death) => live_slots(&death[p..stop], s0, l, &mut live),
                Narrow::U32(death) => live_slots(&death[p..stop], s0, l, &mut live),
            }
            p = stop;
            while next_after == stop - 1 {
                if frame.copy_birth.get(ci) <= l && l < frame.copy_death.get(ci) {
                    out.put(region, find(frame.copy_value.get(ci)));
                }
                ci += 1;
                next_after = anchor(ci);
            }
        }
    });
    out.finish(s, len, mark);
}

/// Calls `f(first, end)`, in order, for each run `first..end` of the blocks in `blocks` (of a
/// frame's `block_death`) whose largest death lies past `l` collapses: the blocks that hold
/// an entry alive at `l`. A run is cut at every 64th block; none is empty. The blocks are
/// compared 64 at a time into a mask (one branch-free pass over the table's width), so a
/// long strip's dead blocks cost a compare each.
#[inline]
fn alive_runs(
    deaths: &Narrow,
    blocks: std::ops::Range<usize>,
    l: u32,
    mut f: impl FnMut(usize, usize),
) {
    fn mask<D: Copy + Into<u32>>(deaths: &[D], l: u32) -> u64 {
        deaths
            .iter()
            .enumerate()
            .fold(0, |m, (i, &d)| m | u64::from(d.into() > l) << i)
    }
    let mut block = blocks.start;
    while block < blocks.end {
        let n = (blocks.end - block).min(64);
        let mut alive = match deaths {
            Narrow::U16(d) => mask(&d[block..block + n], l),
            Narrow::U32(d) => mask(&d[block..block + n], l),
        };
        while alive != 0 {
            let first = alive.trailing_zeros() as usize;
            let run = (alive >> first).trailing_ones() as usize;
            // Clear the run's bits (a shift by 64 when it ends at the mask's last bit).
            alive &= u64::MAX.checked_shl((first + run) as u32).unwrap_or(0);
            f(block + first, block + first + run);
        }
        block += n;
    }
}

/// Calls `f` with the vertex of every slot of `s0` whose death (`deaths`, one per slot, `u16`
/// or `u32`: one loop for either width) lies past `l` collapses, in order.
#[inline]
fn live_slots<D: Copy + Into<u32>>(deaths: &[D], s0: &[u32], l: u32, f: &mut impl FnMut(u32)) {
    for (&death, &v) in deaths.iter().zip(s0) {
        if death.into() > l {
            f(v);
        }
    }
}

/// Calls `f` with the value of every tail entry alive at `rel` steps past the tail's LOD, in
/// order: `values` one per entry, `lifetimes` its birth and death (each width, `u16` or `u32`,
/// one loop).
#[inline]
pub(super) fn live_entries<L: Copy + Into<u32>, V: Copy + Into<u32>>(
    lifetimes: &[L],
    values: &[V],
    rel: u32,
    f: &mut impl FnMut(u32),
) {
    for (life, &v) in lifetimes.chunks_exact(2).zip(values) {
        if life[0].into() <= rel && rel < life[1].into() {
            f(v.into());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// `alive_runs` over any range of a block table (longer than a 64-block mask, both
        /// widths) gives, in order and without overlap, exactly the blocks whose death lies
        /// past `l`, with no run empty or across a 64-block cut.
        #[test]
        fn alive_runs_are_the_blocks_alive(
            deaths in proptest::collection::vec(0u32..6, 1..300),
            from in 0usize..300,
            l in 0u32..6,
            wide in proptest::bool::ANY,
        ) {
            let from = from % deaths.len();
            let table = Narrow::new(if wide { 1 << 20 } else { 5 }, deaths.iter().copied());
            let mut seen = Vec::new();
            alive_runs(&table, from..deaths.len(), l, |first, end| {
                assert!(first < end && (end - 1 - from) / 64 == (first - from) / 64);
                seen.extend(first..end);
            });
            let alive: Vec<usize> = (from..deaths.len()).filter(|&b| deaths[b] > l).collect();
            proptest::prop_assert_eq!(seen, alive);
        }
    }
}
