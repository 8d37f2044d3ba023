//! Rebuilds: the strips set to any frame and LOD in one pass (in chunks on the pool for a
//! large state, from the frame's tail at its coarse LODs), and a switch to strips rebuilt on
//! another thread.

use super::dirty::Mark;
use super::entries::{empty_dead_strips, live_entries, live_mask, rebuild_strips, StripWriter};
use super::index::{dispatch, IndexBuf, StripIndex};
use super::survivors::{roots_backward, Survivors, TAIL_ROOTS};
use super::{Live, StripsState};
use crate::lodstrips::packed::Narrow;
use crate::lodstrips::{FrameChanges, StripLayout};

/// States at least this many slots of `S0` (about 1 MB of index buffer at 4 bytes a slot,
/// a 100k-vertex mesh) rebuild on several threads when they can. Below it a rebuild takes
/// under a millisecond on one thread, and the split's overhead (tasks, the log's parts)
/// would eat what the threads save.
pub const PARALLEL_SLOTS: usize = 1 << 16;

impl StripsState {
    /// Sets the state to `frame` at `lod` (clamped) in one pass, whatever
    /// frame and LOD it was at: every strip as its entries alive at `lod` mapped
    /// to their survivors (see [`FrameChanges`]), the survivors taken from `anc`
    /// (brought to `frame` at `lod` first, see [`Survivors`]). Strips with no
    /// entry alive at `lod` are emptied without reading their entries. The result
    /// is the very buffer that stepping from LOD 0 produces, so later steps can
    /// replay recorded positions.
    ///
    /// Only what differs from the buffer as it was is written and marked dirty:
    /// per strip the positions from the first to the last whose value changed,
    /// and the positions a strip grew by (a crowd's instances switching between
    /// neighbouring frames keep most of their indices, so uploads shrink).
    ///
    /// At the frame's coarse LODs (its tail, see `Tail`) the rebuild reads the tail alone and
    /// leaves `anc` as it is; `from`, the frame the state is at (its strips are `from`'s at
    /// the state's LOD), tells it which strips hold something before it. A large state rebuilt
    /// from scratch outside a parallel job (one object's frame switch; `par::may_split`) is
    /// split over the calling thread and the pool's ([`PARALLEL_SLOTS`]); a crowd's rebuilds,
    /// already spread by `deform::rebuild_all`, stay on their thread, whichever it is.
    pub(crate) fn rebuild<'a>(
        &mut self,
        layout: &StripLayout,
        from: &FrameChanges,
        frame: &'a FrameChanges,
        lod: usize,
        anc: &mut Survivors<'a>,
    ) {
        let lod = lod.min(frame.max_lod());
        if frame.rebuilds_from_tail(lod) {
            self.rebuild_from_tail(layout, from, frame, lod);
            return;
        }
        let threads = rayon::current_num_threads();
        let slots = layout.s0.len();
        let chunk = if threads > 1 && slots >= PARALLEL_SLOTS && crate::par::may_split() {
            crate::par::piece_len(slots, PARALLEL_SLOTS / 4)
        } else {
            usize::MAX
        };
        self.rebuild_in_chunks(layout, frame, lod, anc, chunk);
    }

    /// [`rebuild`](Self::rebuild) with the strips cut into chunks of about `chunk_slots`
    /// slots of `S0` (and a multiple of 64 strips, but the last) rebuilt in parallel
    /// (`usize::MAX`: on the calling thread). Chunks need
    /// a survivor table that is read-only ([`Survivors::flat`]); otherwise the rebuild stays on
    /// the calling thread. Either way the buffer and the dirty log are the same.
    pub(crate) fn rebuild_in_chunks<'a>(
        &mut self,
        layout: &StripLayout,
        frame: &'a FrameChanges,
        lod: usize,
        anc: &mut Survivors<'a>,
        chunk_slots: usize,
    ) {
        let lod = lod.min(frame.max_lod());
        anc.reach(layout.vertex_count as usize, frame, lod);
        // The buffer is taken out for the rebuild (which writes the lengths and the log
        // beside it), its width matched once.
        let mut indices = std::mem::take(&mut self.indices);
        dispatch!(IndexBuf, &mut indices, v => {
            self.rebuild_regions(layout, frame, lod as u32, anc, chunk_slots, v)
        });
        self.indices = indices;
        // A rebuild over the whole mesh reads every strip anyway: the counts are summed anew.
        self.live = Live::of(&self.lens);
        self.lod = lod;
        (self.cursor, self.triangles) = frame.seek(lod);
    }

    /// The strips and the log of [`rebuild_in_chunks`](Self::rebuild_in_chunks) at `l`
    /// collapses, written into `indices`, the state's buffer taken out of it.
    fn rebuild_regions<'a, I: StripIndex>(
        &mut self,
        layout: &StripLayout,
        frame: &'a FrameChanges,
        l: u32,
        anc: &mut Survivors<'a>,
        chunk_slots: usize,
        indices: &mut [I],
    ) {
        let strips = layout.strip_count();
        match anc.flat() {
            Some(root) if chunk_slots < layout.s0.len() => {
                // Cut the strips (and their regions, lengths and dirty log) into chunks at
                // strip bounds that are multiples of 64, so that each chunk marks its own
                // words of the log's bitsets.
                let mut chunks = Vec::new();
                let (mut indices, mut lens) = (indices, &mut self.lens[..]);
                let mut log = self.log.part();
                let mut first = 0;
                while first < strips {
                    let base = layout.region_offsets[first] as usize;
                    let mut last = first + 1;
                    while last < strips
                        && (layout.region_offsets[last] as usize - base < chunk_slots
                            || last % 64 != 0)
                    {
                        last += 1;
                    }
                    let slots = layout.region_offsets[last] as usize - base;
                    let (head, tail) = std::mem::take(&mut indices).split_at_mut(slots);
                    let (head_lens, tail_lens) =
                        std::mem::take(&mut lens).split_at_mut(last - first);
                    let (head_log, tail_log) = log.split_at(last - first);
                    chunks.push((first..last, head, head_lens, head_log));
                    (indices, lens, log) = (tail, tail_lens, tail_log);
                    first = last;
                }
                let changes: u64 = crate::par::map(chunks, |(range, indices, lens, mut log)| {
                    rebuild_strips(
                        layout,
                        frame,
                        l,
                        range,
                        indices,
                        lens,
                        |v| root[v as usize],
                        |m| log.apply(m),
                    );
                    log.changes
                })
                .into_iter()
                .sum();
                self.log.changes += changes;
            }
            _ => {
                let log = &mut self.log;
                rebuild_strips(
                    layout,
                    frame,
                    l,
                    0..strips,
                    indices,
                    &mut self.lens,
                    |v| anc.find(v),
                    |m| log.apply(m),
                );
            }
        }
    }

    /// [`rebuild`](Self::rebuild) at `lod` (not past `frame.max_lod()`) at or past the frame's
    /// tail: the tail's survivors at `lod` (its collapses up to `lod` walked backward over its
    /// vertices, as [`Survivors`] does from scratch), the strips empty at `lod` emptied, then
    /// every strip not empty there written from its tail entries alive at `lod`. The buffer
    /// and the dirty log are those of the full rebuild; its cost is the tail's size and the
    /// strips live before (those of `from`, the state's frame, at its LOD), whatever the
    /// mesh's.
    fn rebuild_from_tail(
        &mut self,
        layout: &StripLayout,
        from: &FrameChanges,
        frame: &FrameChanges,
        lod: usize,
    ) {
        let tail = &frame.tail;
        let l = lod as u32;
        let rel = l - tail.lod;
        let mut root = TAIL_ROOTS.take();
        roots_backward(&mut root, tail.vertices.len(), rel as usize, |j| {
            tail.collapse(j)
        });
        // A coarse state's live strips are a short prefix of its frame's strips by death
        // (a few dozen of a thousand): those are looked up, not every strip's length.
        let before = self.checked_live().strips as usize;
        debug_assert_eq!(
            before,
            from.strips_alive(self.lod as u32),
            "the state's strips are not those of `from` at its LOD"
        );
        let log = &mut self.log;
        let mut mark = |m| log.apply(m);
        if before * 4 < self.lens.len() {
            for j in 0..before {
                let s = from.strips_by_death.get(j) as usize;
                if frame.strip_death.get(s) <= l {
                    self.lens[s] = 0;
                    mark(Mark::Len(s as u32));
                }
            }
        } else {
            empty_dead_strips(frame, l, 0, &mut self.lens, &mut mark);
        }
        // Every strip not written below is empty now: the counts are those of the strips
        // written (counted without reading the emptied strips' lengths, cold lines).
        let mut indices = std::mem::take(&mut self.indices);
        self.live = dispatch!(IndexBuf, &mut indices, v => {
            write_tail_strips(layout, frame, rel, &root, v, &mut self.lens, &mut mark)
        });
        self.indices = indices;
        TAIL_ROOTS.set(root);
        self.lod = lod;
        (self.cursor, self.triangles) = frame.seek(lod);
    }

    /// Takes the strips of `built` (a state of the same model, at any frame and LOD) and
    /// leaves it this state's: their buffers, lengths and LODs are swapped, the dirty logs
    /// stay. This state's log marks every strip live in its new strips whole, and every
    /// strip whose length changed, as a rebuild writing each live position would: a frame
    /// built ahead on another thread ([`DeformingState::build_ahead`]) is taken for the cost
    /// of its marks, not a compare of both buffers (the uploader's diff against what the GPU
    /// holds is the one compare).
    ///
    /// [`DeformingState::build_ahead`]: crate::deform::DeformingState::build_ahead
    pub(crate) fn swap_strips(&mut self, built: &mut StripsState) {
        debug_assert_eq!(self.model_id, built.model_id, "a state of another model");
        std::mem::swap(&mut self.indices, &mut built.indices);
        std::mem::swap(&mut self.lens, &mut built.lens);
        std::mem::swap(&mut self.live, &mut built.live);
        std::mem::swap(&mut self.lod, &mut built.lod);
        std::mem::swap(&mut self.cursor, &mut built.cursor);
        std::mem::swap(&mut self.triangles, &mut built.triangles);
        let chunks = self.lens.chunks(16).zip(built.lens.chunks(16));
        for (c, (lens, old_lens)) in chunks.enumerate() {
            let mut live = live_mask(lens) | live_mask(old_lens);
            while live != 0 {
                let i = live.trailing_zeros() as usize;
                live &= live - 1;
                let s = 16 * c + i;
                if lens[i] != old_lens[i] {
                    self.log.mark_len(s);
                }
                self.log.mark(s, 0, lens[i]);
            }
        }
    }
}

/// Writes every strip of `frame` not empty at `rel` steps past its tail's LOD into `indices`
/// (a state's buffer; `lens` its lengths) from its tail entries alive there, the survivors
/// given by `root` (over the tail's vertices); what changed goes to `mark`. Returns the live
/// counts of the strips written.
fn write_tail_strips<I: StripIndex>(
    layout: &StripLayout,
    frame: &FrameChanges,
    rel: u32,
    root: &[u32],
    indices: &mut [I],
    lens: &mut [u32],
    mark: &mut impl FnMut(Mark),
) -> Live {
    let tail = &frame.tail;
    let mut counts = Live::default();
    for j in 0..frame.strips_alive(tail.lod + rel) {
        let s = frame.strips_by_death.get(j) as usize;
        // The layout's region table, shared by every state (warm in the cache when a
        // crowd rebuilds hundreds), not this state's copy.
        let region = &mut indices[layout.region_offsets[s] as usize..];
        let mut out = StripWriter::new(lens[s]);
        let entries = tail.strip_entries.get(j) as usize..tail.strip_entries.get(j + 1) as usize;
        let lifetimes = 2 * entries.start..2 * entries.end;
        let mut live = |v: u32| out.put(region, tail.vertices.get(root[v as usize] as usize));
        match (&tail.lifetimes, &tail.value) {
            (Narrow::U16(t), Narrow::U16(v)) => {
                live_entries(&t[lifetimes], &v[entries], rel, &mut live)
            }
            (Narrow::U16(t), Narrow::U32(v)) => {
                live_entries(&t[lifetimes], &v[entries], rel, &mut live)
            }
            (Narrow::U32(t), Narrow::U16(v)) => {
                live_entries(&t[lifetimes], &v[entries], rel, &mut live)
            }
            (Narrow::U32(t), Narrow::U32(v)) => {
                live_entries(&t[lifetimes], &v[entries], rel, &mut live)
            }
        }
        out.finish(s, &mut lens[s], mark);
        counts.change(0, lens[s]);
    }
    counts
}
