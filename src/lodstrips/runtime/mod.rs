//! The runtime state: the index buffer with one fixed region per strip, the
//! live length of each strip, the current LOD, and the log of what changed
//! since the GPU uploader last looked.
//!
//! `set_lod` walks the change stream from the current LOD to the requested one,
//! one step at a time: coarsening applies a step's rewrites then its resizes,
//! refining undoes its resizes in reverse order, then its rewrites. Nothing is
//! allocated per change; the scratch vectors are reused.
//!
//! One file a stage, in the order a move runs (this file holds the state, its reads and
//! its entry point [`StripsState::set_lod`]):
//! * `index`: the index buffer in its model's width (`u16` or `u32`), and its reads;
//! * `dirty`: the dirty log, what the uploader takes;
//! * `survivors`: each vertex's survivor at a LOD, for rebuilds;
//! * `step`: stepping, one recorded step at a time, coarser or finer;
//! * `entries`: a rebuild's inner loops, each strip written from its entries alive at the
//!   LOD;
//! * `rebuild`: a rebuild in one pass (in chunks on the pool, or from a frame's tail), and
//!   a switch to strips rebuilt elsewhere.

mod dirty;
mod entries;
mod index;
mod rebuild;
mod step;
mod survivors;

use std::sync::Arc;

use super::{LodStrips, StripLayout};
use dirty::DirtyLog;
pub use dirty::{Dirty, DirtyRange};
#[cfg(feature = "gpu")]
pub(crate) use entries::for_each_live;
#[cfg(feature = "gpu")]
pub(crate) use index::dispatch;
use index::IndexBuf;
pub(crate) use index::StripIndex;
pub use index::{IndexWidth, Indices};
pub use rebuild::PARALLEL_SLOTS;
pub(in crate::lodstrips) use step::cut;
pub(crate) use survivors::Survivors;

/// Why a state cannot move.
#[derive(Debug, thiserror::Error, Clone, Copy, PartialEq, Eq)]
pub enum LodError {
    #[error("this StripsState was made for another LodStrips model; make one with StripsState::new(&model) for each model")]
    WrongModel,
}

/// The current strips at some LOD of one [`LodStrips`] model.
#[derive(Clone, Debug)]
pub struct StripsState {
    model_id: u64,
    /// The layout's region table, shared.
    region_offsets: Arc<[u32]>,
    /// In the model's width ([`IndexWidth::for_vertices`]).
    indices: IndexBuf,
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
            indices: IndexBuf::new(&layout.s0, IndexWidth::for_vertices(layout.vertex_count)),
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

    /// The whole index buffer (all regions, live parts and stale tails), in its width.
    pub fn indices(&self) -> Indices<'_> {
        self.indices.view()
    }

    /// The width the indices are stored in: `u16` where the model has at most 65,536
    /// vertices, chosen when the state is made.
    pub fn index_width(&self) -> IndexWidth {
        self.indices.view().width()
    }

    /// Live length of every strip.
    pub fn lengths(&self) -> &[u32] {
        &self.lens
    }

    /// Live indices of strip `i`, or `None` past the last strip.
    pub fn strip(&self, i: usize) -> Option<Indices<'_>> {
        let base = *self.region_offsets.get(i)? as usize;
        self.indices()
            .get_range(base..base + *self.lens.get(i)? as usize)
    }

    /// Region offsets into [`indices`](Self::indices): strip `i` owns
    /// `region_offsets()[i]..region_offsets()[i+1]`.
    pub fn region_offsets(&self) -> &[u32] {
        &self.region_offsets
    }

    /// Bytes this state holds on the heap (its buffers' capacities): what one more instance
    /// of a model costs, which a crowd's memory budget adds up.
    pub fn heap_bytes(&self) -> usize {
        let words = self.lens.capacity() + self.group_strips.capacity();
        self.indices.heap_bytes()
            + words * 4
            + self.log.heap_bytes()
            + self.scratch.capacity() * size_of::<usize>()
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
}
