//! The runtime state: the index buffer with one fixed region per strip, the
//! live length of each strip, the current LOD, and the log of what changed
//! since the GPU uploader last looked.
//!
//! `set_lod` walks the change stream from the current LOD to the requested one,
//! one step at a time: coarsening applies a step's rewrites then its resizes,
//! refining undoes its resizes in reverse order, then its rewrites. Nothing is
//! allocated per change; the scratch vectors are reused.

use super::packed::Narrow;
use super::{
    kind_len, read_group, read_header, read_resize_head, restore_removed, skip_removed,
    step_start_before, FrameChanges, LodStrips, StripLayout, DEATH_BLOCK, KIND_B, KIND_BC,
    KIND_BCC, KIND_C,
};
use crate::varint;
use std::sync::Arc;

/// Why a state cannot move.
#[derive(Debug, thiserror::Error, Clone, Copy, PartialEq, Eq)]
pub enum LodError {
    #[error("this StripsState was made for another LodStrips model; make one with StripsState::new(&model) for each model")]
    WrongModel,
}

/// Changed part of one strip's region: indices `start..end` relative to the
/// region start (coalesced over all changes since the last [`StripsState::take_dirty`]).
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

/// The current strips at some LOD of one [`LodStrips`] model.
#[derive(Clone, Debug)]
pub struct StripsState {
    model_id: u64,
    /// The layout's region table, shared.
    region_offsets: Arc<[u32]>,
    indices: Vec<u32>,
    lens: Vec<u32>,
    lod: usize,
    /// Stream position where step `lod` starts.
    cursor: usize,
    triangles: u32,
    log: DirtyLog,
    /// The live strips and indices of `lens`, kept as they change.
    live: Live,
    scratch: Vec<usize>,
    /// Strips of the current step's rewrite groups (resizes name strips by group).
    group_strips: Vec<u32>,
}

/// How many strips are live (length not 0) and their indices in all: what a copy of the live
/// strips packed one after another takes, which a crowd asks of every instance it patches.
/// Kept as lengths change rather than summed over every strip when asked.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Live {
    strips: u32,
    indices: u32,
}

impl Live {
    fn of(lens: &[u32]) -> Live {
        let mut live = Live::default();
        for &len in lens {
            live.change(0, len);
        }
        live
    }

    /// A strip's length went from `old` to `new`.
    #[inline]
    fn change(&mut self, old: u32, new: u32) {
        self.strips = self.strips + u32::from(new != 0) - u32::from(old != 0);
        self.indices = self.indices + new - old;
    }
}

/// The dirty log of a [`StripsState`]: per strip the span of positions written and whether
/// its live length changed, and one bit per strip for each, so that taking the log walks the
/// marked strips in ascending order without sorting them (a large object's frame marks
/// thousands of strips; sorting them was most of `take_dirty`).
#[derive(Clone, Debug)]
struct DirtyLog {
    /// Per strip the lowest and highest-plus-one position marked (`[u32::MAX, 0]`: none), side
    /// by side: a crowd's rebuild marks a few strips of each of hundreds of states, and one
    /// cache line per mark is what it pays.
    span: Vec<[u32; 2]>,
    /// Bit `s % 64` of word `s / 64`: strip `s` has positions marked.
    marked: Vec<u64>,
    /// The same for strips whose live length changed.
    len_marked: Vec<u64>,
    /// Bumped by every mark ([`StripsState::changes`]).
    changes: u64,
}

/// One mark a rebuild makes for a strip: its live length changed, or its positions
/// `start..end` did.
#[derive(Clone, Copy, Debug)]
enum Mark {
    Len(u32),
    Span(u32, u32, u32),
}

/// The strips `first..` of a [`DirtyLog`] (`first` a multiple of 64: whole words of its
/// bitsets) and the marks made through this part: what one chunk of a rebuild split over
/// threads marks on its own thread, so that the log is the one a single thread makes with
/// no marks collected and applied afterwards.
struct LogPart<'a> {
    first: usize,
    span: &'a mut [[u32; 2]],
    marked: &'a mut [u64],
    len_marked: &'a mut [u64],
    changes: u64,
}

impl<'a> LogPart<'a> {
    fn apply(&mut self, mark: Mark) {
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
    fn split_at(self, strips: usize) -> (LogPart<'a>, LogPart<'a>) {
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
    fn new(strips: usize) -> DirtyLog {
        DirtyLog {
            span: vec![[u32::MAX, 0]; strips],
            marked: vec![0; strips.div_ceil(64)],
            len_marked: vec![0; strips.div_ceil(64)],
            changes: 0,
        }
    }

    fn heap_bytes(&self) -> usize {
        self.span.capacity() * 8 + (self.marked.capacity() + self.len_marked.capacity()) * 8
    }

    /// The whole log as one part.
    fn part(&mut self) -> LogPart<'_> {
        LogPart {
            first: 0,
            span: &mut self.span,
            marked: &mut self.marked,
            len_marked: &mut self.len_marked,
            changes: 0,
        }
    }

    fn apply(&mut self, mark: Mark) {
        match mark {
            Mark::Len(s) => self.mark_len(s as usize),
            Mark::Span(s, start, end) => self.mark(s as usize, start, end),
        }
    }

    fn mark(&mut self, strip: usize, start: u32, end: u32) {
        let marked = mark_span(&mut self.span, &mut self.marked, strip, start, end);
        self.changes += u64::from(marked);
    }

    fn mark_len(&mut self, strip: usize) {
        mark_len(&mut self.len_marked, strip);
        self.changes += 1;
    }

    fn take(&mut self) -> Dirty {
        let mut out = Dirty::default();
        self.take_into(&mut out);
        out
    }

    fn take_into(&mut self, out: &mut Dirty) {
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

/// Fills `root` with the survivor of each of `vertices` vertices after the collapses
/// `collapse(0..steps)` (`(u, w)`: `u` into `w`), walked backward as
/// [`CollapseSequence::survivors`](crate::collapse::CollapseSequence::survivors) does (each `w`
/// outlives its step, so it is resolved when reached). The runtime's own copy: the oracle's
/// stays apart from the code it checks.
fn roots_backward(
    root: &mut Vec<u32>,
    vertices: usize,
    steps: usize,
    collapse: impl Fn(usize) -> (u32, u32),
) {
    root.clear();
    root.extend(0..vertices as u32);
    for step in (0..steps).rev() {
        let (u, w) = collapse(step);
        root[u as usize] = root[w as usize];
    }
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

thread_local! {
    /// The survivor forest of [`Survivors`] (4 bytes per vertex), one per thread rather than
    /// one per state: it lives only during rebuilds, so the states a thread moves (a crowd's
    /// instances, moved in parallel) share it, and an instance's footprint is its index
    /// buffer and per-strip bookkeeping only.
    static SURVIVORS: std::cell::Cell<Vec<u32>> = const { std::cell::Cell::new(Vec::new()) };
    /// The survivors of a rebuild from a frame's tail, one table per thread likewise.
    static TAIL_ROOTS: std::cell::Cell<Vec<u32>> = const { std::cell::Cell::new(Vec::new()) };
}

/// The survivor of every vertex after the first `lod` collapses of one frame, for rebuilds:
/// a forest over the vertices in which collapse `u → w` links `u` under `w` (`u` is a root
/// then: a vertex is removed once), so a vertex's root is its survivor. Reaching a coarser
/// LOD of the same frame only links the collapses in between, so rebuilds of one frame taken
/// in ascending LOD (a crowd's instances switching to that frame) link each collapse once;
/// a finer LOD or another frame starts over (4 bytes per vertex written, then the collapses
/// walked backward, which points every vertex straight at its root). Finding a root
/// halves the path as it goes: links only ever point at a vertex that was alive when they
/// were made, so a shortcut to a further ancestor stays an ancestor at every coarser LOD.
///
/// Its table is the calling thread's (taken on creation, handed back on drop), so the
/// allocation is reused by every rebuild on that thread.
pub(crate) struct Survivors<'a> {
    /// The frame the links are of (`None`: none yet).
    frame: Option<&'a FrameChanges>,
    /// Collapses linked.
    lod: usize,
    /// Whether every vertex points straight at its root (after a start from scratch, until
    /// collapses are linked forward).
    flat: bool,
    parent: Vec<u32>,
}

impl<'a> Survivors<'a> {
    /// No links yet, on the calling thread's table.
    pub(crate) fn new() -> Survivors<'a> {
        Survivors {
            frame: None,
            lod: 0,
            flat: false,
            parent: SURVIVORS.take(),
        }
    }

    /// Links the first `lod` collapses of `frame` over `vertices` vertices (only those not
    /// linked yet when the forest is at a finer LOD of the same frame).
    fn reach(&mut self, vertices: usize, frame: &'a FrameChanges, lod: usize) {
        let same = self.frame.is_some_and(|f| std::ptr::eq(f, frame));
        if !same || lod < self.lod || self.parent.len() != vertices {
            // From scratch: every vertex then points at its root, so a lone rebuild finds each
            // survivor in one step, for the same work as linking forward.
            roots_backward(&mut self.parent, vertices, lod, |step| frame.collapse(step));
            self.frame = Some(frame);
            self.lod = lod;
            self.flat = true;
        }
        if self.lod < lod {
            self.flat = false;
        }
        for step in self.lod..lod {
            let (u, w) = frame.collapse(step);
            self.parent[u as usize] = w;
        }
        self.lod = lod;
    }

    /// The survivor table when it is flat (every vertex's entry is its survivor, so it
    /// can be read from many threads at once), else `None`.
    fn flat(&self) -> Option<&[u32]> {
        self.flat.then_some(&self.parent[..])
    }

    /// The survivor of `v` at the LOD reached.
    #[inline]
    fn find(&mut self, v: u32) -> u32 {
        let parent = &mut self.parent;
        let mut v = v as usize;
        loop {
            let p = parent[v] as usize;
            if p == v {
                return v as u32;
            }
            let grand = parent[p];
            parent[v] = grand;
            v = grand as usize;
        }
    }
}

impl Drop for Survivors<'_> {
    fn drop(&mut self) {
        SURVIVORS.set(std::mem::take(&mut self.parent));
    }
}

impl StripsState {
    /// The state at LOD 0: the buffer holds `S0`, nothing is dirty.
    pub fn new(model: &LodStrips) -> StripsState {
        StripsState::at_s0(&model.layout, model.id)
    }

    /// The state at LOD 0 of any frame over `layout`, tagged with the id of
    /// the model that owns the layout.
    pub(crate) fn at_s0(layout: &StripLayout, model_id: u64) -> StripsState {
        let strips = layout.strip_count();
        let lens: Vec<u32> = layout
            .region_offsets
            .windows(2)
            .map(|w| w[1] - w[0])
            .collect();
        StripsState {
            model_id,
            region_offsets: Arc::clone(&layout.region_offsets),
            indices: layout.s0.clone(),
            live: Live::of(&lens),
            lens,
            lod: 0,
            cursor: 0,
            triangles: layout.triangles_at_0,
            log: DirtyLog::new(strips),
            scratch: Vec::new(),
            group_strips: Vec::new(),
        }
    }

    /// The id of the model this state follows.
    pub(crate) fn model_id(&self) -> u64 {
        self.model_id
    }

    pub fn lod(&self) -> usize {
        self.lod
    }

    /// Non-degenerate triangles the current strips draw.
    pub fn triangle_count(&self) -> usize {
        self.triangles as usize
    }

    /// The whole index buffer (all regions, live parts and stale tails).
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }

    /// Live length of every strip.
    pub fn lengths(&self) -> &[u32] {
        &self.lens
    }

    /// Live indices of strip `i`, or `None` past the last strip.
    pub fn strip(&self, i: usize) -> Option<&[u32]> {
        let base = *self.region_offsets.get(i)? as usize;
        self.indices.get(base..base + *self.lens.get(i)? as usize)
    }

    /// Region offsets into [`indices`](Self::indices): strip `i` owns
    /// `region_offsets()[i]..region_offsets()[i+1]`.
    pub fn region_offsets(&self) -> &[u32] {
        &self.region_offsets
    }

    /// Bytes this state holds on the heap (its buffers' capacities): what one more instance
    /// of a model costs, which a crowd's memory budget adds up.
    pub fn heap_bytes(&self) -> usize {
        let words = self.indices.capacity() + self.lens.capacity() + self.group_strips.capacity();
        words * 4 + self.log.heap_bytes() + self.scratch.capacity() * size_of::<usize>()
    }

    /// Total live indices over all strips.
    pub fn index_count(&self) -> usize {
        self.checked_live().indices as usize
    }

    /// Strips whose live length is not 0.
    pub fn live_strip_count(&self) -> usize {
        self.checked_live().strips as usize
    }

    fn checked_live(&self) -> Live {
        debug_assert_eq!(self.live, Live::of(&self.lens), "live counts drifted");
        self.live
    }

    /// Moves to LOD `lod` (clamped to `model.max_lod()`), applying only the
    /// recorded changes between the current LOD and `lod`. `model` must be the
    /// one this state was made from.
    pub fn set_lod(&mut self, model: &LodStrips, lod: usize) -> Result<(), LodError> {
        if model.id != self.model_id {
            return Err(LodError::WrongModel);
        }
        self.step_to(&model.frame, lod);
        Ok(())
    }

    /// Moves to `lod` (clamped) by applying `frame`'s steps one at a time.
    /// The state must be at some LOD of `frame` (or at LOD 0 of any frame:
    /// `S0` is every frame's LOD 0).
    pub(crate) fn step_to(&mut self, frame: &FrameChanges, lod: usize) {
        let lod = lod.min(frame.max_lod());
        while self.lod < lod {
            self.coarsen(frame);
        }
        while self.lod > lod {
            self.refine(frame);
        }
    }

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
        let l = lod as u32;
        let strips = layout.strip_count();
        match anc.flat() {
            Some(root) if chunk_slots < layout.s0.len() => {
                // Cut the strips (and their regions, lengths and dirty log) into chunks at
                // strip bounds that are multiples of 64, so that each chunk marks its own
                // words of the log's bitsets.
                let mut chunks = Vec::new();
                let (mut indices, mut lens) = (&mut self.indices[..], &mut self.lens[..]);
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
                    &mut self.indices,
                    &mut self.lens,
                    |v| anc.find(v),
                    |m| log.apply(m),
                );
            }
        }
        // A rebuild over the whole mesh reads every strip anyway: the counts are summed anew.
        self.live = Live::of(&self.lens);
        self.lod = lod;
        (self.cursor, self.triangles) = frame.seek(lod);
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
        let mut counts = Live::default();
        for j in 0..frame.strips_alive(l) {
            let s = frame.strips_by_death.get(j) as usize;
            // The layout's region table, shared by every state (warm in the cache when a
            // crowd rebuilds hundreds), not this state's copy.
            let region = &mut self.indices[layout.region_offsets[s] as usize..];
            let mut out = StripWriter::new(self.lens[s]);
            let entries =
                tail.strip_entries.get(j) as usize..tail.strip_entries.get(j + 1) as usize;
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
            out.finish(s, &mut self.lens[s], &mut mark);
            counts.change(0, self.lens[s]);
        }
        self.live = counts;
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

    /// Hands the dirty log to the uploader and clears it.
    pub fn take_dirty(&mut self) -> Dirty {
        self.log.take()
    }

    /// [`take_dirty`](Self::take_dirty) into `out`, whose lists are cleared and reused: an
    /// uploader that takes the logs of many states keeps one `Dirty` and allocates nothing.
    pub fn take_dirty_into(&mut self, out: &mut Dirty) {
        self.log.take_into(out);
    }

    /// A count that grows whenever the dirty log gets a position or a length, taken or not:
    /// two equal readings mean the strips did not change in between, so an uploader can leave
    /// the dirty log to accumulate (it coalesces per strip) and still know whether anything
    /// changed since its last look.
    pub fn changes(&self) -> u64 {
        self.log.changes
    }

    /// Applies step `self.lod`: rewrites `u → w`, then the resizes in order.
    fn coarsen(&mut self, model: &FrameChanges) {
        let s = &model.stream;
        let (_, w) = model.collapse(self.lod);
        let mut at = self.cursor;
        let (groups, resizes, removed) = read_header(s, &mut at);
        at = self.rewrite(model, at, groups, w);
        for _ in 0..resizes {
            let (group, i, len, kind) = read_resize_head(s, &mut at);
            let strip = self.group_strips[group as usize] as usize;
            skip_removed(s, &mut at, len);
            let base = self.region_offsets[strip] as usize;
            let live = self.lens[strip] as usize;
            let region = &mut self.indices[base..base + live];
            let new_live = cut(region, i, len, kind);
            self.live.change(live as u32, new_live as u32);
            self.lens[strip] = new_live as u32;
            self.log.mark(strip, i as u32, new_live as u32);
            self.log.mark_len(strip);
        }
        // Skip the footer, which holds the length just read.
        at += varint::len_u32((at - self.cursor) as u32);
        self.cursor = at;
        self.triangles -= removed;
        self.lod += 1;
    }

    /// Undoes step `self.lod - 1`: restores the resizes in reverse order, then
    /// writes `u` back.
    fn refine(&mut self, model: &FrameChanges) {
        let s = &model.stream;
        let start = step_start_before(s, self.cursor);
        let (u, _) = model.collapse(self.lod - 1);
        let mut at = start;
        let (groups, resizes, removed) = read_header(s, &mut at);
        let rewrites = at;
        // Skip the rewrites to reach the resize records.
        self.group_strips.clear();
        let mut strip = 0u32;
        for _ in 0..groups {
            let (delta, count) = read_group(s, &mut at);
            strip += delta;
            self.group_strips.push(strip);
            for _ in 0..count {
                varint::read_u32(s, &mut at);
            }
        }
        self.scratch.clear();
        for _ in 0..resizes {
            self.scratch.push(at);
            let (_, _, len, _) = read_resize_head(s, &mut at);
            skip_removed(s, &mut at, len);
        }
        for k in (0..self.scratch.len()).rev() {
            let mut at = self.scratch[k];
            let (group, i, len, kind) = read_resize_head(s, &mut at);
            let strip = self.group_strips[group as usize] as usize;
            let base = self.region_offsets[strip] as usize;
            let live = self.lens[strip] as usize;
            let new_live = live + len - kind_len(kind);
            let region = &mut self.indices[base..base + new_live];
            region.copy_within(i + kind_len(kind)..live, i + len);
            restore_removed(s, &mut at, region, i, len);
            self.live.change(live as u32, new_live as u32);
            self.lens[strip] = new_live as u32;
            self.log.mark(strip, i as u32, new_live as u32);
            self.log.mark_len(strip);
        }
        self.rewrite(model, rewrites, groups, u);
        self.cursor = start;
        self.triangles += removed;
        self.lod -= 1;
    }

    /// Writes `value` at every position of the rewrite groups starting at
    /// `at`; returns the stream position after them.
    fn rewrite(&mut self, model: &FrameChanges, mut at: usize, groups: u32, value: u32) -> usize {
        let s = &model.stream;
        let mut strip = 0usize;
        self.group_strips.clear();
        for _ in 0..groups {
            let (delta, count) = read_group(s, &mut at);
            strip += delta as usize;
            self.group_strips.push(strip as u32);
            let base = self.region_offsets[strip] as usize;
            let mut pos = 0u32;
            let mut lo = u32::MAX;
            for _ in 0..count {
                pos += varint::read_u32(s, &mut at);
                self.indices[base + pos as usize] = value;
                lo = lo.min(pos);
            }
            self.log.mark(strip, lo, pos + 1);
        }
        at
    }
}

/// States at least this many slots of `S0` (about 1 MB of index buffer at 4 bytes a slot,
/// a 100k-vertex mesh) rebuild on several threads when they can. Below it a rebuild takes
/// under a millisecond on one thread, and the split's overhead (tasks, the log's parts)
/// would eat what the threads save.
pub const PARALLEL_SLOTS: usize = 1 << 16;

/// The rebuild of strips `strips` (see [`StripsState::rebuild`]) over their regions
/// `indices` (from the first strip's region start) and live lengths `lens`, at `l` collapses
/// of `frame`, the survivor of a vertex given by `find`; what changed goes to `mark` (per
/// strip its length, then its span).
///
/// Its work follows what is alive before and after, not the mesh: the strips empty at `l`
/// cost one look at their old length; when few strips are alive at `l` they are taken from
/// the frame's `strips_by_death` prefix rather than found by a pass over `strips`; and within a
/// strip the blocks of slots with nothing alive at `l` are skipped unread ([`rebuild_strip`]).
#[allow(clippy::too_many_arguments)]
fn rebuild_strips(
    layout: &StripLayout,
    frame: &FrameChanges,
    l: u32,
    strips: std::ops::Range<usize>,
    indices: &mut [u32],
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
fn empty_dead_strips(
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
fn live_mask(chunk: &[u32]) -> u32 {
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
struct StripWriter {
    old: usize,
    q: usize,
    lo: usize,
    hi: usize,
}

impl StripWriter {
    /// Before the first entry of a strip whose live length was `old`.
    fn new(old: u32) -> StripWriter {
        StripWriter {
            old: old as usize,
            q: 0,
            lo: usize::MAX,
            hi: 0,
        }
    }

    /// Writes `v` at the next position of `region` (the strip's region and on).
    #[inline]
    fn put(&mut self, region: &mut [u32], v: u32) {
        let q = self.q;
        if q >= self.old || region[q] != v {
            region[q] = v;
            self.lo = self.lo.min(q);
            self.hi = q + 1;
        }
        self.q += 1;
    }

    /// Sets strip `s`'s live length `len` to the entries written, marking it if it changed,
    /// then the changed span.
    fn finish(self, s: usize, len: &mut u32, mark: &mut impl FnMut(Mark)) {
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
fn rebuild_strip(
    layout: &StripLayout,
    frame: &FrameChanges,
    l: u32,
    s: usize,
    ci: usize,
    region: &mut [u32],
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
fn live_entries<L: Copy + Into<u32>, V: Copy + Into<u32>>(
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

/// Cuts `region[i..i+len]` (the live part of a strip is all of `region`),
/// writing the replacement `kind` made of the neighbours `B = region[i-1]`,
/// `C = region[i+len]`, and packing the tail; returns the new live length.
pub(super) fn cut(region: &mut [u32], i: usize, len: usize, kind: u16) -> usize {
    let live = region.len();
    let r = kind_len(kind);
    if r > 0 {
        let b = region[i - 1];
        let c = region[i + len];
        match kind {
            KIND_B => region[i] = b,
            KIND_C => region[i] = c,
            KIND_BC => {
                region[i] = b;
                region[i + 1] = c;
            }
            KIND_BCC => {
                region[i] = b;
                region[i + 1] = c;
                region[i + 2] = c;
            }
            _ => {}
        }
    }
    region.copy_within(i + len..live, i + r);
    live - len + r
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
