//! The per-object LOD runtime of a deforming mesh: one
//! [`StripLayout`](crate::lodstrips::StripLayout) (`S0` and its regions) shared by every
//! sampled frame, one [`FrameChanges`](crate::lodstrips::FrameChanges) per frame, and the
//! state that [`DeformingState::set`] moves to any `(t, lod)`.
//!
//! This is its own module rather than part of [`lodstrips`](crate::lodstrips) because it
//! owns what only a deforming object has: an [`Asset`](crate::asset::Asset)'s validation,
//! the mapping from `t` to a frame, the LOD parameter ([`Lod`]) resolved against per-frame
//! tables, and the choice between the two ways to switch frames. `lodstrips` stays the
//! single-sequence model (change lists and how to apply them), which this module drives.
//!
//! A move to `(k', l')` from `(k, l)` costs either
//! * stepping: `|l − l'|` steps inside a frame, or `l + l'` steps across frames
//!   (refine to LOD 0, where every frame's buffer is `S0`, then coarsen under
//!   the new frame); or
//! * a rebuild: one pass over the entries of the strips not empty at `l'` plus
//!   the survivors of the first `l'` collapses (`FrameChanges::rebuild_work`
//!   bounds it); a crowd's rebuilds to one frame share the survivors
//!   (`gpu::Crowd::set`).
//!
//! [`Strategy::Auto`] takes the cheaper by [`STEP_COST`], the measured cost of
//! one step in rebuild work units (`cargo bench --bench deform`). Both produce
//! the identical buffer (tests/suite/oracle_deform.rs checks it), so the choice is
//! invisible except in time and in how much the dirty log holds.
//!
//! One file a stage, in the order a move runs (this file holds the LOD parameter, the
//! strategies, the errors, the state and its entry points, [`DeformingState::set`]):
//! * `frame`: one sampled frame's change lists and LOD tables, built and checked;
//! * `model`: [`DeformingModel`], the asset validated, equal frames shared, a request's
//!   time and LOD resolved against a frame's tables;
//! * `plan`: a move's frame, LOD and strategy, by the cost model;
//! * `apply`: carrying a plan out by steps or a rebuild (a crowd's rebuilds grouped by
//!   frame);
//! * `ahead`: frames built on a thread of their own ahead of a switch, and the switches
//!   that take them.

mod ahead;
mod apply;
mod frame;
mod model;
mod plan;
#[cfg(test)]
mod tests;

use thiserror::Error;

use crate::collapse::SequenceError;
use crate::lodstrips::{ChangeListError, Dirty, IndexWidth, Indices, StripsState, Survivors};
use crate::seams::SeamError;
use ahead::Ahead;
#[cfg(feature = "gpu")]
pub(crate) use apply::rebuild_all;
pub use model::DeformingModel;
#[cfg(feature = "gpu")]
pub(crate) use plan::Plan;

/// The level of detail to show, resolved against the current frame's tables.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lod {
    /// This many collapses (clamped to the frame's count); 0 = full detail.
    Steps(usize),
    /// The paper's parameter in `[0, 1]` (clamped): 0 = full detail, 1 = the
    /// coarsest LOD; `round(f · max_lod)` collapses.
    Fraction(f32),
    /// A triangle budget: the finest LOD drawing at most this many triangles
    /// (the coarsest LOD if even that draws more).
    Triangles(usize),
    /// An object-space error bound, in the mesh's units (a distance): the
    /// coarsest LOD whose collapses all have an error of at most this. The
    /// simplifier records a mean squared distance, plus the attribute error on
    /// a mesh with attributes (see [`Collapse::error`](crate::collapse::Collapse));
    /// it is compared as its square root. Negative bounds give full detail.
    MaxError(f32),
}

impl Lod {
    /// The object-space error that projects to `pixels` on screen at
    /// `distance` from a perspective camera with vertical field of view
    /// `fov_y` (radians) and a viewport `viewport_height` pixels tall: one
    /// pixel spans `2 · distance · tan(fov_y / 2) / viewport_height` units.
    pub fn screen_error(pixels: f32, distance: f32, fov_y: f32, viewport_height: f32) -> Lod {
        let units_per_pixel = 2.0 * distance * (fov_y * 0.5).tan() / viewport_height;
        Lod::MaxError(pixels * units_per_pixel)
    }

    /// `lod`, or [`SetError::LodNaN`] where it holds NaN: the one LOD
    /// [`DeformingModel::resolve`] refuses (so a caller can check a move
    /// without resolving it).
    pub(crate) fn check(self) -> Result<Lod, SetError> {
        match self {
            Lod::Fraction(v) | Lod::MaxError(v) if v.is_nan() => Err(SetError::LodNaN(self)),
            lod => Ok(lod),
        }
    }
}

/// How [`DeformingState::set_with`] reaches the requested state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// The cheaper of the two below, by the cost model (module docs).
    Auto,
    /// Apply recorded steps (across frames: refine to 0, then coarsen).
    Steps,
    /// Rebuild all strips in one pass.
    Rebuild,
}

/// Cost of one incremental step in rebuild work units (one entry visited or
/// one survivor resolved), used by [`Strategy::Auto`]. Set from `cargo bench --bench
/// deform` (the figures are in docs/benchmarks-log.md, "Figures behind constants"), rounded
/// toward stepping, whose dirty log is smaller.
pub const STEP_COST: usize = 50;

/// Why a [`DeformingModel`] cannot be made from an asset.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DeformError {
    #[error("the asset has no frames; build it with at least one sampled frame")]
    NoFrames,
    #[error("V(0) has {v0} vertices but V(1) has {v1}; both poses must come from one morph")]
    PoseSizeMismatch { v0: usize, v1: usize },
    #[error(
        "{pose} vertex {vertex} is not finite ({value:?}); rebuild the asset from clean input"
    )]
    NonFinite {
        pose: &'static str,
        vertex: usize,
        value: [f32; 3],
    },
    #[error("the asset has {vertices} vertices, more than the 2^31 the strips can index; split the mesh")]
    TooManyVertices { vertices: usize },
    #[error("the strips S0 are invalid: {0}")]
    Strips(ChangeListError),
    #[error("frame {frame}'s collapse sequence is for {sequence} vertices, the poses have {vertices}; rebuild the asset")]
    FrameVertexCount {
        frame: usize,
        sequence: usize,
        vertices: usize,
    },
    #[error("frame {frame}'s collapse sequence is invalid: {source}; rebuild the asset")]
    Sequence { frame: usize, source: SequenceError },
    #[error("the model needs about {needed} bytes of memory, over the {budget}-byte budget: raise the budget (`--memory-budget MB` on the command line, `DeformingModel::with_budget` in code) if the asset is trusted")]
    OverBudget { needed: u64, budget: u64 },
    #[error("frame {frame}'s change lists cannot be built: {source}")]
    Frame {
        frame: usize,
        source: ChangeListError,
    },
    #[error("the surface's topology has {topology} entries, the poses have {vertices} vertices; rebuild the asset")]
    SurfaceSize { topology: usize, vertices: usize },
    #[error("frame {frame} does not move whole topology vertices: {source}; rebuild the asset")]
    Seams { frame: usize, source: SeamError },
}

/// Why [`DeformingState::set`] refused a request (the state is unchanged).
#[derive(Debug, Error, Clone, Copy, PartialEq)]
pub enum SetError {
    #[error("t is NaN; pass a time in [0, 1]")]
    TimeNaN,
    #[error("the LOD {0:?} holds NaN; pass a number")]
    LodNaN(Lod),
    #[error("this DeformingState was made for another DeformingModel; make one with DeformingState::new(&model) per model")]
    WrongModel,
}

/// The strips of one [`DeformingModel`] at some `(frame, lod)`, with the log
/// of what changed since the GPU uploader last looked.
#[derive(Clone, Debug)]
pub struct DeformingState {
    state: StripsState,
    frame: usize,
    /// Frames built on another thread ahead of a switch ([`build_ahead`](Self::build_ahead)); none
    /// until the first build (a crowd's instances never make one).
    ahead: Option<Box<Ahead>>,
}

impl DeformingState {
    /// Frame 0 at LOD 0: the buffer holds `S0`, nothing is dirty.
    pub fn new(model: &DeformingModel) -> DeformingState {
        DeformingState {
            state: StripsState::at_s0(&model.layout, model.id),
            frame: 0,
            ahead: None,
        }
    }

    /// Moves to time `t` (frame `round(t · (|r| − 1))`, `t` clamped to
    /// `[0, 1]`) at `lod` resolved in that frame, the cheaper way: a switch to a frame
    /// built ahead ([`build_ahead`](Self::build_ahead)) takes its strips if they are ready.
    pub fn set(&mut self, model: &DeformingModel, t: f32, lod: Lod) -> Result<(), SetError> {
        self.set_with(model, t, lod, Strategy::Auto).map(|_| ())
    }

    /// [`set`](Self::set) with the strategy chosen by the caller; returns the
    /// one used (`Steps` or `Rebuild`).
    pub fn set_with(
        &mut self,
        model: &DeformingModel,
        t: f32,
        lod: Lod,
        strategy: Strategy,
    ) -> Result<Strategy, SetError> {
        let plan = self.plan(model, t, lod, strategy)?;
        // A switch under `Auto` takes the strips built ahead for its frame where they are
        // ready and cheaper than the plan; a strategy the caller chose is carried out as asked.
        if strategy == Strategy::Auto && plan.frame != self.frame && self.take_ahead(model, plan) {
            return Ok(Strategy::Rebuild);
        }
        self.apply(model, plan, &mut Survivors::new());
        Ok(plan.strategy)
    }

    /// The current frame.
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// The current LOD in steps of the current frame.
    pub fn lod(&self) -> usize {
        self.state.lod()
    }

    /// Non-degenerate triangles the current strips draw.
    pub fn triangle_count(&self) -> usize {
        self.state.triangle_count()
    }

    /// Total live indices over all strips.
    pub fn index_count(&self) -> usize {
        self.state.index_count()
    }

    /// Strips whose live length is not 0.
    pub fn live_strip_count(&self) -> usize {
        self.state.live_strip_count()
    }

    /// The whole index buffer (all regions, live parts and stale tails), in its width.
    pub fn indices(&self) -> Indices<'_> {
        self.state.indices()
    }

    /// The width the indices are stored in (see [`StripsState::index_width`]).
    pub fn index_width(&self) -> IndexWidth {
        self.state.index_width()
    }

    /// Live length of every strip (its draw's `index_count`).
    pub fn lengths(&self) -> &[u32] {
        self.state.lengths()
    }

    /// Live indices of strip `i`, or `None` past the last strip.
    pub fn strip(&self, i: usize) -> Option<Indices<'_>> {
        self.state.strip(i)
    }

    /// Region offsets into [`indices`](Self::indices) (`strip count + 1` entries).
    pub fn region_offsets(&self) -> &[u32] {
        self.state.region_offsets()
    }

    /// Bytes this state holds on the heap (see [`StripsState::heap_bytes`]), the strips built
    /// ahead ([`build_ahead`](Self::build_ahead)) included.
    pub fn heap_bytes(&self) -> usize {
        let ahead = self.ahead.as_ref().and_then(|a| a.built.as_ref());
        self.state.heap_bytes() + ahead.map_or(0, |(_, built)| built.heap_bytes())
    }

    /// A count that grows whenever the strips change (see [`StripsState::changes`]): equal
    /// readings mean nothing changed in between, whether or not the dirty log was taken.
    pub fn changes(&self) -> u64 {
        self.state.changes()
    }

    /// Hands the dirty log to the uploader and clears it. After a rebuild it
    /// names, per strip, the span of the positions whose value changed and the
    /// strips whose length changed; after a switch that took a frame built ahead
    /// ([`build_ahead`](Self::build_ahead)), every live strip whole.
    pub fn take_dirty(&mut self) -> Dirty {
        self.state.take_dirty()
    }

    /// [`take_dirty`](Self::take_dirty) into `out`, whose lists are cleared and reused.
    pub fn take_dirty_into(&mut self, out: &mut Dirty) {
        self.state.take_dirty_into(out);
    }
}
