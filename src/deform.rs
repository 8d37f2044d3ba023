//! The per-object LOD runtime of a deforming mesh: one [`StripLayout`] (`S0`
//! and its regions) shared by every sampled frame, one [`FrameChanges`] per
//! frame, and the state that [`DeformingState::set`] moves to any `(t, lod)`.
//!
//! This is its own module rather than part of [`lodstrips`](crate::lodstrips)
//! because it owns what only a deforming object has: an [`Asset`]'s validation,
//! the mapping from `t` to a frame, the LOD parameter ([`Lod`]) resolved
//! against per-frame tables, and the choice between the two ways to switch
//! frames. `lodstrips` stays the single-sequence model (change lists and how
//! to apply them), which this module drives.
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

use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;
use std::thread::JoinHandle;
use thiserror::Error;

use crate::asset::{Asset, DEFAULT_MAX_BYTES};
use crate::collapse::{CollapseSequence, SequenceError};
use crate::lodstrips::increasing::Increasing;
use crate::lodstrips::{ChangeListError, Dirty, FrameChanges, StripLayout, StripsState, Survivors};
use crate::par;
use crate::seams::{check_steps, SeamError, StepBoundaries, Wedges};

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
/// deform` (the figures are in BENCHMARKS.md, "Figures behind constants"), rounded
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

/// What equal frames must share (collapse count, first collapse): narrows the
/// by-value comparisons when frames are deduplicated.
type FrameKey = (usize, Option<(u32, u32)>);

/// One sampled frame: its change lists and its LOD tables.
#[derive(Clone, Debug)]
struct Frame {
    changes: FrameChanges,
    /// `errors[l]`, the largest collapse error among the first `l` as a
    /// distance (square root of the recorded mean squared distance), never
    /// decreases and `errors[0] = 0`; it is kept only where it grows: from LOD
    /// `error_steps[i]` on (up to the next entry) it is the square root of the
    /// recorded error whose `f32` bits are `error_keys[i] << error_shift`
    /// (both sequences strictly increasing, each in the smaller of an array and
    /// a bitmap over its range, [`Increasing`]).
    /// The recorded errors are positive there, so the keys grow with the
    /// errors; built assets round errors to bfloat16 (`quantize_error`), whose
    /// low 16 bits are zero, and then store the top 16 bits only
    /// (`error_shift = 16`); other errors keep all 32 (`error_shift = 0`).
    error_steps: Increasing,
    error_keys: Increasing,
    error_shift: u32,
    /// For an asset with a surface: the LODs that fall between two topology collapses,
    /// the only ones shown ([`crate::seams`]); `None`: every LOD.
    boundaries: Option<StepBoundaries>,
}

impl Frame {
    /// The distance an error key stands for (`errors[error_steps[i]]` for
    /// `error_keys[i]`, see the field docs).
    fn error_value(&self, key: u32) -> f32 {
        f32::from_bits(key << self.error_shift).sqrt()
    }

    /// The coarsest LOD whose collapse errors, as distances, are all `≤ e`
    /// (full detail when `e < 0`): the LOD before the first growth past `e`.
    fn coarsest_within(&self, e: f32) -> usize {
        if e.is_nan() || e < 0.0 {
            return 0;
        }
        // The largest key whose distance is within `e`, from the key of `e²` (at most a
        // rounding away), then the keys up to it: integer compares, no square root each.
        let max = u32::MAX >> self.error_shift;
        let mut key = ((e * e).to_bits() >> self.error_shift).min(max);
        // (Key 0 is the distance 0, within every `e` here.)
        while key > 0 && self.error_value(key) > e {
            key -= 1;
        }
        while key < max && self.error_value(key + 1) <= e {
            key += 1;
        }
        let lo = self.error_keys.count_at_most(key);
        if lo < self.error_steps.len() {
            self.error_steps.get(lo) as usize - 1
        } else {
            self.changes.max_lod()
        }
    }

    fn byte_size(&self) -> usize {
        self.changes.byte_size()
            + self.error_steps.byte_size()
            + self.error_keys.byte_size()
            + self
                .boundaries
                .as_ref()
                .map_or(0, StepBoundaries::byte_size)
    }
}

/// Every frame's LOD model over one shared `S0`.
#[derive(Clone, Debug)]
pub struct DeformingModel {
    layout: StripLayout,
    /// One entry per sampled frame; equal frames (same collapse sequence)
    /// share one `Frame`, so memory grows with the distinct frames of the
    /// file, not with its frame count (a repeated frame costs 2 bytes on disk).
    frames: Vec<Arc<Frame>>,
    id: u64,
}

impl DeformingModel {
    /// Validates `asset` (poses of one length and finite, `S0` well formed
    /// and in range, every frame's sequence valid for that vertex count, at
    /// least one frame) and builds every frame's change lists, in parallel, under the
    /// default memory budget ([`DEFAULT_MAX_BYTES`], see [`with_budget`](Self::with_budget)).
    pub fn new(asset: &Asset) -> Result<DeformingModel, DeformError> {
        DeformingModel::with_budget(asset, DEFAULT_MAX_BYTES)
    }

    /// [`new`](Self::new), refusing with [`DeformError::OverBudget`], before building any
    /// frame, a model whose estimated size exceeds `max_bytes`. Equal frames share one
    /// built frame, so the estimate counts each distinct frame once:
    /// `8 · S0 + Σ_distinct (16 · S0 + 64 · collapses + 256) + 8 · frames` bytes, with `S0`
    /// the strip entries; the per-collapse figure is above every frame measured
    /// (tests/asset_budget.rs checks the estimate against the built model).
    pub fn with_budget(asset: &Asset, max_bytes: u64) -> Result<DeformingModel, DeformError> {
        if asset.frames.is_empty() {
            return Err(DeformError::NoFrames);
        }
        let n = asset.v0.len();
        if asset.v1.len() != n {
            return Err(DeformError::PoseSizeMismatch {
                v0: n,
                v1: asset.v1.len(),
            });
        }
        for (pose, positions) in [("V(0)", &asset.v0), ("V(1)", &asset.v1)] {
            if let Some((vertex, &value)) = positions
                .iter()
                .enumerate()
                .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
            {
                return Err(DeformError::NonFinite {
                    pose,
                    vertex,
                    value,
                });
            }
        }
        let vertex_count =
            u32::try_from(n).map_err(|_| DeformError::TooManyVertices { vertices: n })?;
        let layout = StripLayout::new(&asset.s0, vertex_count).map_err(|e| match e {
            ChangeListError::TooManyVertices { .. } => DeformError::TooManyVertices { vertices: n },
            e => DeformError::Strips(e),
        })?;
        // Equal sequences are built once: `first[k]` is the first frame equal to frame k.
        // Compared by value (bit-equal errors included), grouped by length and first collapse
        // so that the comparisons stay few.
        let mut groups: HashMap<FrameKey, Vec<usize>> = HashMap::new();
        let mut first: Vec<usize> = Vec::with_capacity(asset.frames.len());
        for (k, seq) in asset.frames.iter().enumerate() {
            let key = (
                seq.collapses.len(),
                seq.collapses.first().map(|c| (c.u, c.w)),
            );
            let group = groups.entry(key).or_default();
            match group
                .iter()
                .find(|&&j| Arc::ptr_eq(&asset.frames[j], seq) || asset.frames[j] == *seq)
            {
                Some(&j) => first.push(j),
                None => {
                    group.push(k);
                    first.push(k);
                }
            }
        }
        let distinct: Vec<usize> = (0..first.len()).filter(|&k| first[k] == k).collect();
        let topology = match &asset.surface {
            Some(surface) => Some(seam_topology(&surface.topology, n)?),
            None => None,
        };
        let needed = estimate_bytes(asset, &distinct);
        if needed > max_bytes {
            return Err(DeformError::OverBudget {
                needed,
                budget: max_bytes,
            });
        }
        let built: Vec<Result<Arc<Frame>, DeformError>> = distinct
            .par_iter()
            .map(|&frame| {
                build_frame(&layout, frame, &asset.frames[frame], topology.as_ref()).map(Arc::new)
            })
            .collect();
        let mut shared: Vec<Option<Arc<Frame>>> = vec![None; first.len()];
        for (&k, frame) in distinct.iter().zip(built) {
            shared[k] = Some(frame?);
        }
        let frames: Vec<Arc<Frame>> = first
            .iter()
            .map(|&j| shared[j].clone().expect("every first frame was built"))
            .collect();
        Ok(DeformingModel {
            layout,
            frames,
            id: crate::lodstrips::next_id(),
        })
    }

    /// Number of sampled frames `|r|`.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// Number of distinct frames: what the model's memory grows with (equal
    /// frames share one copy of their change lists and tables).
    pub fn distinct_frames(&self) -> usize {
        let mut seen: Vec<*const Frame> = self.frames.iter().map(Arc::as_ptr).collect();
        seen.sort_unstable();
        seen.dedup();
        seen.len()
    }

    /// The shared layout: `S0` and the region table.
    pub fn layout(&self) -> &StripLayout {
        &self.layout
    }

    /// Frame `k`'s change lists, or `None` past the last frame.
    pub fn frame_changes(&self, k: usize) -> Option<&FrameChanges> {
        self.frames.get(k).map(|f| &f.changes)
    }

    /// The frame shown at time `t`: `round(t · (|r| − 1))`, `t` clamped to `[0, 1]`.
    pub fn frame_at(&self, t: f32) -> Result<usize, SetError> {
        if t.is_nan() {
            return Err(SetError::TimeNaN);
        }
        let last = self.frames.len() - 1;
        Ok(((t.clamp(0.0, 1.0) * last as f32).round() as usize).min(last))
    }

    /// `lod` as a step count of frame `k` (clamped to the last frame). For an asset with a
    /// surface the result is a step boundary ([`crate::seams`]): `Steps`, `Fraction` and
    /// `MaxError` round down to one, `Triangles` (the finest LOD within the budget) moves to
    /// the next one at or after the LOD it names.
    pub fn resolve(&self, k: usize, lod: Lod) -> Result<usize, SetError> {
        let frame = &self.frames[k.min(self.frames.len() - 1)];
        let max = frame.changes.max_lod();
        let l = match lod.check()? {
            Lod::Steps(l) => l.min(max),
            Lod::Fraction(f) => ((f.clamp(0.0, 1.0) * max as f32).round() as usize).min(max),
            Lod::Triangles(budget) => frame.changes.finest_within(budget),
            Lod::MaxError(e) => frame.coarsest_within(e),
        };
        Ok(match (&frame.boundaries, lod) {
            (None, _) => l,
            (Some(b), Lod::Triangles(_)) => b.ceil(l),
            (Some(b), _) => b.floor(l),
        })
    }

    /// Bytes of the per-frame data in RAM (change lists, tables), per frame.
    pub fn frame_bytes(&self) -> Vec<usize> {
        self.frames.iter().map(|f| f.byte_size()).collect()
    }
}

/// The size [`DeformingModel::with_budget`] checks: see its docs.
fn estimate_bytes(asset: &Asset, distinct: &[usize]) -> u64 {
    let slots = asset.s0.indices.len() as u64;
    let frames: u64 = distinct
        .iter()
        .map(|&k| 16 * slots + 64 * asset.frames[k].collapses.len() as u64 + 256)
        .sum();
    8 * slots + frames + 8 * asset.frames.len() as u64
}

/// A surface's topology map, checked against `n` vertices, with its wedges.
fn seam_topology(of_vertex: &[u32], n: usize) -> Result<(&[u32], Wedges), DeformError> {
    if of_vertex.len() != n {
        return Err(DeformError::SurfaceSize {
            topology: of_vertex.len(),
            vertices: n,
        });
    }
    Ok((of_vertex, Wedges::new(of_vertex)))
}

fn build_frame(
    layout: &StripLayout,
    frame: usize,
    seq: &CollapseSequence,
    topology: Option<&(&[u32], Wedges)>,
) -> Result<Frame, DeformError> {
    if seq.vertex_count as usize != layout.vertex_count() {
        return Err(DeformError::FrameVertexCount {
            frame,
            sequence: seq.vertex_count as usize,
            vertices: layout.vertex_count(),
        });
    }
    seq.validate()
        .map_err(|source| DeformError::Sequence { frame, source })?;
    let changes =
        FrameChanges::build(layout, seq).map_err(|source| DeformError::Frame { frame, source })?;
    let boundaries = match topology {
        Some((of_vertex, wedges)) => {
            check_steps(seq, wedges, of_vertex)
                .map_err(|source| DeformError::Seams { frame, source })?;
            Some(StepBoundaries::new(seq, of_vertex))
        }
        None => None,
    };
    // The LODs where the running maximum grows (as a distance) and its recorded value there.
    let (mut steps, mut keys) = (Vec::new(), Vec::new());
    let mut distance = 0.0f32;
    for (l, e) in seq.errors().into_iter().enumerate().skip(1) {
        let d = e.max(0.0).sqrt();
        if d > distance {
            distance = d;
            steps.push(l as u32);
            keys.push(e.to_bits());
        }
    }
    let error_shift = if keys.iter().all(|k| k & 0xFFFF == 0) {
        16
    } else {
        0
    };
    Ok(Frame {
        changes,
        error_steps: Increasing::new(&steps),
        error_keys: Increasing::new(&keys.iter().map(|k| k >> error_shift).collect::<Vec<_>>()),
        error_shift,
        boundaries,
    })
}

/// A checked move of a [`DeformingState`]: the frame and LOD it goes to, and the strategy
/// (`Steps` or `Rebuild`) that takes it there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Plan {
    pub(crate) frame: usize,
    pub(crate) lod: usize,
    pub(crate) strategy: Strategy,
}

impl Plan {
    /// Whether carrying it out reads a survivor table over `model`'s mesh (a rebuild finer
    /// than its frame's tail): such rebuilds go to [`rebuild_all`], grouped by frame; the
    /// rest are cheapest where the state was just read.
    #[cfg(feature = "gpu")]
    pub(crate) fn links_survivors(self, model: &DeformingModel) -> bool {
        self.strategy == Strategy::Rebuild
            && !model.frames[self.frame]
                .changes
                .rebuilds_from_tail(self.lod)
    }
}

/// Carries out the rebuilds of many states of one model, each with its plan: sorted by
/// frame and LOD, cut into runs of one frame (at most `⌈states / (4 × threads)⌉` each, so
/// that the runs spread over the threads even when every state goes to one frame), the runs
/// in parallel. A run links each of its frame's collapses once for all its states
/// ([`Survivors`]) instead of once per state. `state` finds a job's state; `then` is called
/// on each job right after its rebuild, on the same thread (while the state is in that core's
/// cache), with one accumulator per run, and `finish` of each run's accumulator, made on that
/// thread too, is returned, in run order. The calling thread takes runs too ([`par::map`]).
/// (The crowd's; a crate without the renderer has no caller.)
#[cfg(feature = "gpu")]
pub(crate) fn rebuild_all<J: Send, A: Default, B: Send>(
    model: &DeformingModel,
    jobs: &mut [(Plan, J)],
    state: impl Fn(&mut J) -> &mut DeformingState + Sync,
    then: impl Fn(&mut J, &mut A) + Sync,
    finish: impl Fn(A) -> B + Sync,
) -> Vec<B> {
    jobs.sort_unstable_by_key(|(plan, _)| (plan.frame, plan.lod));
    let run = par::piece_len(jobs.len(), 1);
    let mut runs = Vec::new();
    let mut rest = jobs;
    while let Some((first, _)) = rest.first() {
        let frame = first.frame;
        let n = rest
            .iter()
            .take(run)
            .take_while(|(plan, _)| plan.frame == frame)
            .count();
        let (head, tail) = rest.split_at_mut(n);
        runs.push(head);
        rest = tail;
    }
    par::map(runs, |run| {
        let mut anc = Survivors::new();
        let mut acc = A::default();
        for (plan, job) in run.iter_mut() {
            state(job).apply(model, *plan, &mut anc);
            then(job, &mut acc);
        }
        finish(acc)
    })
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

/// A frame's strips rebuilt on a thread of their own ahead of a switch to it
/// ([`DeformingState::build_ahead`]), and the state they are built in.
#[derive(Debug, Default)]
struct Ahead {
    /// The build under way, whose thread returns its frame and state.
    pending: Option<JoinHandle<(usize, StripsState)>>,
    /// The last build's frame and state (after a switch took it, still a valid state of its
    /// frame): the next build rebuilds it in place, so a state allocates its second buffer
    /// once.
    built: Option<(usize, StripsState)>,
    /// Switches that took a build ([`DeformingState::switches_built_ahead`]).
    taken: u64,
}

impl Ahead {
    /// Takes the build under way into `built` if it is done; never waits.
    fn collect(&mut self) {
        if self.pending.as_ref().is_some_and(JoinHandle::is_finished) {
            self.finish();
        }
    }

    /// Waits for the build under way, if any, and takes it into `built` (nothing where its
    /// thread panicked).
    fn finish(&mut self) {
        if let Some(pending) = self.pending.take() {
            self.built = pending.join().ok();
        }
    }
}

impl Clone for Ahead {
    /// Nothing built: a clone starts its own builds.
    fn clone(&self) -> Ahead {
        Ahead::default()
    }
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

    /// Starts rebuilding the strips at `(t, lod)` on a thread of its own when `t` is in another
    /// frame than this state's and stepping there from the state's LOD would cost at least a
    /// quarter of a rebuild ([`STEP_COST`]). A later [`set`](Self::set) to that frame takes
    /// the strips built, stepped to its own LOD, where that costs less than its own plan,
    /// instead of rebuilding (or stepping) on the calling thread: what is left of the switch
    /// is a swap of buffers and those steps. An application calls it with where it expects
    /// to be next (an animation's next `t`); [`LodObject`](crate::gpu::LodObject) does by
    /// itself. Returns whether a build started.
    ///
    /// Nothing starts while an earlier build is under way (one at a time), or where the
    /// strips built last are of that frame and LOD already. From the first build on the state
    /// keeps a second buffer of its own size (1.2 MB for a 100k-vertex mesh, see
    /// [`heap_bytes`](Self::heap_bytes)). A `set` to another frame, or made before the build
    /// is done, moves as if nothing were built and never waits. Worth it for large models (a
    /// rebuild of [`PARALLEL_SLOTS`](crate::lodstrips::PARALLEL_SLOTS) slots of `S0` takes
    /// about a millisecond); a small one's rebuild costs less than starting the thread. `t`
    /// and `lod` are checked as `set` checks them.
    pub fn build_ahead(
        &mut self,
        model: &Arc<DeformingModel>,
        t: f32,
        lod: Lod,
    ) -> Result<bool, SetError> {
        let (k, l) = self.resolve_move(model, t, lod)?;
        Ok(self.build_ahead_at(model, k, l))
    }

    /// Switches that took strips built ahead ([`build_ahead`](Self::build_ahead)) since the
    /// state was made: against the frame switches made, how often the builds came in time.
    pub fn switches_built_ahead(&self) -> u64 {
        self.ahead.as_ref().map_or(0, |a| a.taken)
    }

    /// [`build_ahead`](Self::build_ahead) for frame `k` at LOD `l`, resolved against `model`
    /// (this state's model).
    pub(crate) fn build_ahead_at(
        &mut self,
        model: &Arc<DeformingModel>,
        k: usize,
        l: usize,
    ) -> bool {
        if k == self.frame {
            return false;
        }
        // Not where stepping there costs under a quarter of a rebuild (near full detail): the
        // switch steps whatever is built. Between that and where `Auto` rebuilds, it may go
        // either way by the time it comes.
        let (steps, rebuild) = self.move_costs(model, k, l);
        if 4 * steps < rebuild {
            return false;
        }
        let ahead = self.ahead.get_or_insert_with(Box::default);
        ahead.collect();
        let built_already = matches!(&ahead.built, Some((f, built)) if *f == k && built.lod() == l);
        if ahead.pending.is_some() || built_already {
            return false;
        }
        let built = ahead.built.take();
        let model = Arc::clone(model);
        // A thread of its own, its rebuild on that thread alone: on the pool, the threads
        // that wake for it and look for more work took the cores from the caller's thread
        // for milliseconds on 2 cores (BENCHMARKS.md, "Frames built ahead").
        let build = move || {
            par::alone(|| {
                let (from, mut state) =
                    built.unwrap_or_else(|| (0, StripsState::at_s0(&model.layout, model.id)));
                let frames = &model.frames;
                let (from, to) = (&frames[from].changes, &frames[k].changes);
                state.rebuild(&model.layout, from, to, l, &mut Survivors::new());
                (k, state)
            })
        };
        let thread = std::thread::Builder::new().name("morphlod-ahead".into());
        match thread.spawn(build) {
            Ok(pending) => {
                ahead.pending = Some(pending);
                true
            }
            // No thread to be had: the switch rebuilds as usual.
            Err(_) => false,
        }
    }

    /// Whether a build started by [`build_ahead`](Self::build_ahead) is still running. A
    /// caller that wants every switch to take its build (a test, an offline render) waits
    /// for it to turn false before the move; an interactive one never needs to.
    pub fn building_ahead(&self) -> bool {
        let pending = self.ahead.as_ref().and_then(|a| a.pending.as_ref());
        pending.is_some_and(|p| !p.is_finished())
    }

    /// Waits for the build under way, if any.
    #[cfg(test)]
    fn wait_ahead(&mut self) {
        if let Some(ahead) = self.ahead.as_deref_mut() {
            ahead.finish();
        }
    }

    /// Carries out `plan`, a switch to another frame, from the strips built ahead for its
    /// frame, if they are ready and stepping from their LOD to the plan's costs less than the
    /// plan (its steps or its rebuild): swapped in (every live strip marked), then stepped to
    /// the plan's LOD. False (nothing done) otherwise. Builds are of this state's model
    /// (`build_ahead` checks it, a `LodObject` builds with its own, `swap_strips` asserts it).
    fn take_ahead(&mut self, model: &DeformingModel, plan: Plan) -> bool {
        let (steps, rebuild) = self.move_costs(model, plan.frame, plan.lod);
        let planned = match plan.strategy {
            Strategy::Rebuild => rebuild,
            _ => steps,
        };
        let Some(ahead) = self.ahead.as_deref_mut() else {
            return false;
        };
        ahead.collect();
        match &mut ahead.built {
            Some((k, built))
                if *k == plan.frame && built.lod().abs_diff(plan.lod) * STEP_COST < planned =>
            {
                self.state.swap_strips(built);
                // What is left behind is this state's old strips, of its old frame.
                *k = self.frame;
                self.state
                    .step_to(&model.frames[plan.frame].changes, plan.lod);
                self.frame = plan.frame;
                ahead.taken += 1;
                true
            }
            _ => false,
        }
    }

    /// Where a move to `(t, lod)` goes and how (the request checked, nothing moved).
    pub(crate) fn plan(
        &self,
        model: &DeformingModel,
        t: f32,
        lod: Lod,
        strategy: Strategy,
    ) -> Result<Plan, SetError> {
        let (k, l) = self.resolve_move(model, t, lod)?;
        Ok(self.plan_at(model, k, l, strategy))
    }

    /// The frame and LOD (in steps of that frame) a move of this state to `(t, lod)` goes to,
    /// the request checked against `model`.
    fn resolve_move(
        &self,
        model: &DeformingModel,
        t: f32,
        lod: Lod,
    ) -> Result<(usize, usize), SetError> {
        if self.state.model_id() != model.id {
            return Err(SetError::WrongModel);
        }
        let k = model.frame_at(t)?;
        Ok((k, model.resolve(k, lod)?))
    }

    /// What moving this state to frame `k` at LOD `l` costs in rebuild work units: by steps
    /// ([`STEP_COST`] each; back to LOD 0 of this frame first where `k` is another) and by a
    /// rebuild.
    fn move_costs(&self, model: &DeformingModel, k: usize, l: usize) -> (usize, usize) {
        let steps = if k == self.frame {
            self.state.lod().abs_diff(l)
        } else {
            self.state.lod() + l
        };
        let rebuild = model.frames[k].changes.rebuild_work(&model.layout, l);
        (steps * STEP_COST, rebuild)
    }

    /// [`plan`](Self::plan) for frame `k` at LOD `l`, already resolved against `model` (this
    /// state's model): a crowd resolves every move first, to tell the instances drawn from a
    /// tail list.
    pub(crate) fn plan_at(
        &self,
        model: &DeformingModel,
        k: usize,
        l: usize,
        strategy: Strategy,
    ) -> Plan {
        let strategy = match strategy {
            Strategy::Auto => {
                let (steps, rebuild) = self.move_costs(model, k, l);
                if steps <= rebuild {
                    Strategy::Steps
                } else {
                    Strategy::Rebuild
                }
            }
            chosen => chosen,
        };
        Plan {
            frame: k,
            lod: l,
            strategy,
        }
    }

    /// Carries out `plan` (made by [`plan`](Self::plan) for this state and `model`); a
    /// rebuild takes its survivors from `anc`.
    pub(crate) fn apply<'a>(
        &mut self,
        model: &'a DeformingModel,
        plan: Plan,
        anc: &mut Survivors<'a>,
    ) {
        let frame = &model.frames[plan.frame].changes;
        if plan.strategy == Strategy::Rebuild {
            let from = &model.frames[self.frame].changes;
            self.state
                .rebuild(&model.layout, from, frame, plan.lod, anc);
        } else {
            if plan.frame != self.frame {
                self.state.step_to(&model.frames[self.frame].changes, 0);
            }
            self.state.step_to(frame, plan.lod);
        }
        self.frame = plan.frame;
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

    /// The whole index buffer (all regions, live parts and stale tails).
    pub fn indices(&self) -> &[u32] {
        self.state.indices()
    }

    /// Live length of every strip (its draw's `index_count`).
    pub fn lengths(&self) -> &[u32] {
        self.state.lengths()
    }

    /// Live indices of strip `i`, or `None` past the last strip.
    pub fn strip(&self, i: usize) -> Option<&[u32]> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::{simplify, SimplifyOptions};
    use crate::strip::stripify;

    /// A grid of `n × n` quads, a wave that grows from `t = 0` to `t = 1`, sampled at
    /// `frames` frames: each frame's sequence differs, so a frame switch rewrites most strips.
    fn wave_asset(n: u32, frames: usize) -> Asset {
        wave_tiles(1, n, frames)
    }

    /// [`wave_asset`] as `tiles` separate grids of `n` × `n` quads side by side, so that a
    /// small mesh has many strips (a few a tile).
    fn wave_tiles(tiles: u32, n: u32, frames: usize) -> Asset {
        let pos = |x: u32, y: u32, t: f32| {
            let (fx, fy) = (x as f32, y as f32);
            [
                fx,
                fy,
                t * (0.7 * fx).sin() * (0.5 * fy).cos() + 0.02 * fx * fy,
            ]
        };
        let side = n + 1;
        let tile = side * side;
        let mut tris = Vec::new();
        for first in (0..tiles).map(|k| k * tile) {
            for y in 0..n {
                for x in 0..n {
                    let a = first + y * side + x;
                    tris.push([a, a + 1, a + side + 1]);
                    tris.push([a, a + side + 1, a + side]);
                }
            }
        }
        // Tile k lies `k (side + 1)` along x, one column apart from the tile before.
        let at = |t: f32| -> Vec<[f32; 3]> {
            (0..tiles * tile)
                .map(|i| {
                    let (k, j) = (i / tile, i % tile);
                    pos(k * (side + 1) + j % side, j / side, t)
                })
                .collect()
        };
        let vertices = (tiles * tile) as usize;
        Asset {
            v0: at(0.0),
            v1: at(1.0),
            s0: stripify(&tris, vertices),
            frames: (0..frames)
                .map(|k| {
                    let t = k as f32 / (frames - 1) as f32;
                    Arc::new(simplify(&at(t), &tris, &SimplifyOptions::default()))
                })
                .collect(),
            blend: None,
            surface: None,
        }
    }

    /// Two rebuilds of one move left the same buffer (stale tails included), lengths, LOD,
    /// triangle count and dirty log (both taken).
    fn same_rebuild(a: &mut DeformingState, b: &mut DeformingState, at: &str) {
        assert_eq!(a.indices(), b.indices(), "{at}");
        assert_eq!(a.lengths(), b.lengths(), "{at}");
        assert_eq!(
            (a.lod(), a.triangle_count()),
            (b.lod(), b.triangle_count()),
            "{at}"
        );
        assert_eq!(a.take_dirty(), b.take_dirty(), "{at}");
    }

    /// A rebuild cut into chunks on the thread pool (what one large object's frame switch
    /// does) leaves the buffer, lengths and dirty log of a rebuild on one thread, and the
    /// buffer of stepping there, over a random walk of frame switches and LOD jumps. The
    /// mesh has 240 strips (60 tiles) and chunks of 1–1500 slots, cut at multiples of 64
    /// strips: two to four chunks, which start at empty strips or live ones; every third
    /// move reuses one survivor table, which is not flat after it links forward (that
    /// rebuild stays on one thread and must give the same).
    #[test]
    fn chunked_rebuild_equals_one_thread_and_steps() {
        let asset = wave_tiles(60, 4, 5);
        let model = DeformingModel::new(&asset).expect("model builds");
        let (mut one, mut chunked, mut steps) = (
            DeformingState::new(&model),
            DeformingState::new(&model),
            DeformingState::new(&model),
        );
        let mut seed = 0x2545_f491_u64;
        let mut unit = || crate::random::next_unit(&mut seed) as f32;
        let mut shared = Survivors::new();
        let mut switches = 0;
        for step in 0..150 {
            let t = unit();
            let lod = match step % 7 {
                0 => Lod::Fraction(0.0),
                1 => Lod::Fraction(1.0),
                _ => Lod::Fraction(unit()),
            };
            let plan = one
                .plan(&model, t, lod, Strategy::Rebuild)
                .expect("valid request");
            switches += usize::from(plan.frame != one.frame());
            one.apply(&model, plan, &mut Survivors::new());
            let frame = &model.frames[plan.frame].changes;
            let chunk = 1 + (unit() * 1500.0) as usize;
            let mut fresh = Survivors::new();
            let anc = if step % 3 == 0 {
                &mut shared
            } else {
                &mut fresh
            };
            chunked
                .state
                .rebuild_in_chunks(&model.layout, frame, plan.lod, anc, chunk);
            chunked.frame = plan.frame;
            steps
                .set_with(&model, t, lod, Strategy::Steps)
                .expect("valid request");
            same_rebuild(&mut chunked, &mut one, &format!("step {step}"));
            assert_eq!(chunked.changes(), one.changes(), "step {step}");
            // Stepping leaves other values in the regions' tails; the live strips are equal.
            assert_eq!(steps.lengths(), one.lengths(), "step {step}");
            for s in 0..one.lengths().len() {
                assert_eq!(steps.strip(s), one.strip(s), "step {step}, strip {s}");
            }
        }
        assert!(switches > 50, "{switches} frame switches");
    }

    /// A rebuild at a frame's coarse LODs reads the frame's tail alone; it leaves the buffer,
    /// lengths, dirty log, LOD and triangle count of the full rebuild, at every LOD from just
    /// before the tail to the coarsest, whatever frame and LOD the state was at. Fails when the
    /// tail is missing an entry or maps a value to the wrong survivor. (The wave's tails hold
    /// no copy born inside them; the walks over the head and body in the suite's
    /// `oracle_deform` do, and fail when a tail loses a copy's birth.)
    #[test]
    fn tail_rebuild_equals_full_rebuild() {
        // A larger wave than `wave_model`'s, so that each frame's tail spans a few dozen LODs.
        let model = &DeformingModel::new(&wave_asset(48, 3)).expect("model builds");
        let mut seed = 0x9e37_79b9_u64;
        let mut covered = 0;
        for (k, frame) in model.frames.iter().map(|f| &f.changes).enumerate() {
            let ((tail, entries), max) = (frame.tail_extent(), frame.max_lod());
            assert!(tail < max, "frame {k}: tail at {tail} of {max}");
            assert!(
                entries <= model.layout.s0().len() / crate::lodstrips::TAIL_SHARE,
                "frame {k}: tail holds {entries} entries"
            );
            for l in tail.saturating_sub(2)..=max {
                // From another frame at a random LOD, or this frame at a random LOD.
                let from = crate::random::next_unit(&mut seed);
                let other = (k + 1 + (from * 4.0) as usize) % model.frames.len();
                let start = model.frames[other].changes.max_lod() as f64 * from;
                let mut full = DeformingState::new(model);
                let plan = full
                    .plan(model, 0.0, Lod::Steps(0), Strategy::Rebuild)
                    .expect("valid request");
                let at = Plan {
                    frame: if l % 2 == 0 { other } else { k },
                    lod: start as usize,
                    ..plan
                };
                full.apply(model, at, &mut Survivors::new());
                full.take_dirty();
                let mut from_tail = full.clone();
                full.state.rebuild_in_chunks(
                    &model.layout,
                    frame,
                    l,
                    &mut Survivors::new(),
                    usize::MAX,
                );
                let from = &model.frames[from_tail.frame].changes;
                from_tail
                    .state
                    .rebuild(&model.layout, from, frame, l, &mut Survivors::new());
                same_rebuild(&mut from_tail, &mut full, &format!("frame {k}, LOD {l}"));
                covered += usize::from(l >= tail);
            }
        }
        assert!(covered > 20, "{covered} LODs rebuilt from a tail");
    }

    /// Checks that `state`, just moved to `(t, lod)`, equals a fresh state stepped there
    /// from `S0`, and that its dirty log replayed onto `mirror` (its buffer and lengths as
    /// of the last take) gives its strips; takes the log.
    fn same_as_stepped(
        state: &mut DeformingState,
        model: &DeformingModel,
        t: f32,
        lod: Lod,
        mirror: &mut (Vec<u32>, Vec<u32>),
        at: &str,
    ) {
        let mut fresh = DeformingState::new(model);
        fresh
            .set_with(model, t, lod, Strategy::Steps)
            .expect("valid request");
        assert_eq!(state.frame(), fresh.frame(), "{at}");
        assert_eq!(
            (state.lod(), state.triangle_count()),
            (fresh.lod(), fresh.triangle_count()),
            "{at}"
        );
        assert_eq!(state.lengths(), fresh.lengths(), "{at}");
        let offsets = state.region_offsets().to_vec();
        for s in 0..offsets.len() - 1 {
            assert_eq!(state.strip(s), fresh.strip(s), "{at}, strip {s}");
        }
        let dirty = state.take_dirty();
        let (indices, lens) = mirror;
        for r in &dirty.ranges {
            let o = offsets[r.strip as usize] as usize;
            let span = o + r.start as usize..o + r.end as usize;
            indices[span.clone()].copy_from_slice(&state.indices()[span]);
        }
        for &s in &dirty.lengths {
            lens[s as usize] = state.lengths()[s as usize];
        }
        assert_eq!(&lens[..], state.lengths(), "{at}");
        for s in 0..offsets.len() - 1 {
            let live = offsets[s] as usize..(offsets[s] + lens[s]) as usize;
            assert_eq!(Some(&indices[live]), state.strip(s), "{at}, strip {s}");
        }
    }

    /// Switches that take a frame built ahead (at the LOD they go to, or at another one they
    /// step from; built from `S0` or from the last build, of any frame) leave the strips of
    /// stepping from `S0`, and a dirty log that takes the old strips to them; builds for a
    /// frame the walk does not go to, or made while another is under way, change nothing.
    /// Fails when the swap marks a strip's old live length instead of its new one, leaves
    /// unmarked a strip the build emptied, or files the strips left behind under the frame
    /// built (the next build then rebuilds them as if they were of that frame).
    #[test]
    fn switches_to_frames_built_ahead_equal_stepping_from_s0() {
        let model = Arc::new(DeformingModel::new(&wave_asset(24, 6)).expect("model builds"));
        let frames = model.frame_count();
        let mut state = DeformingState::new(&model);
        let mut mirror = (state.indices().to_vec(), state.lengths().to_vec());
        let mut seed = 0x51_7cc1_b727_u64;
        let mut unit = || crate::random::next_unit(&mut seed) as f32;
        let (mut started, mut elsewhere, mut f) = (0, 0, 0.5);
        for i in 0..240 {
            let k = state.frame();
            let frame = match i % 5 {
                0 | 1 => (k + 1) % frames,
                2 => k.saturating_sub(1),
                3 => k,
                _ => (unit() * frames as f32) as usize % frames,
            };
            // The LOD drifts as a camera's would, with a jump now and then, and the coarsest
            // (a frame's tail) every seventh move.
            f = if i % 11 == 0 {
                unit()
            } else {
                (f + 0.03 * (unit() - 0.5)).clamp(0.0, 1.0)
            };
            let lod = Lod::Fraction(if i % 7 == 0 { 1.0 } else { f });
            // The build: at the LOD the move goes to, near it, far from it, or for another
            // frame than the move's.
            let (to, ahead) = match i % 4 {
                0 => (frame, Lod::Fraction(f)),
                1 => (frame, Lod::Fraction((f + 0.02 * unit()).min(1.0))),
                2 => (frame, Lod::Fraction(unit())),
                _ => ((frame + 1) % frames, lod),
            };
            let l = model.resolve(to, ahead).expect("valid LOD");
            // Every third run of three moves builds nothing: the strips a switch left behind
            // stay as they were filed, and a later switch to their frame may take them.
            let build = (i / 3) % 3 != 2;
            if build && state.build_ahead_at(&model, to, l) {
                started += 1;
                elsewhere += usize::from(to != frame);
                // Most builds finish before the move; a few are left running, so that the
                // move may go on without them (and the build, taken after it, is of a frame
                // the state is no longer at).
                if i % 9 != 0 {
                    state.wait_ahead();
                }
            }
            let t = frame as f32 / (frames - 1) as f32;
            state.set(&model, t, lod).expect("valid request");
            state.wait_ahead();
            same_as_stepped(
                &mut state,
                &model,
                t,
                lod,
                &mut mirror,
                &format!("move {i}"),
            );
        }
        let taken = state.switches_built_ahead();
        assert!(taken > 30, "{taken} of {started} builds taken");
        assert!(elsewhere > 10, "{elsewhere} builds for frames not gone to");
        // The build's buffer counts in the state's bytes.
        assert!(state.heap_bytes() > 2 * state.indices().len() * 4);
    }

    /// The wave model of `wave_asset(24, 6)`, built once for the property test.
    fn wave_model() -> &'static DeformingModel {
        static MODEL: std::sync::OnceLock<DeformingModel> = std::sync::OnceLock::new();
        MODEL.get_or_init(|| DeformingModel::new(&wave_asset(24, 6)).expect("model builds"))
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(24))]

        /// Over a random walk of frame switches (the same frame, a neighbour up or down, a
        /// jump) at LODs from full detail to the coarsest, rebuilt or moved the cheaper way,
        /// every state equals a fresh one stepped from `S0` to its frame and LOD, and its
        /// dirty log replayed onto a copy of its buffer gives its strips: rebuilds that read
        /// only the strips and entries alive before and after leave nothing out.
        #[test]
        fn frame_switch_walks_equal_stepping_from_s0(
            moves in proptest::collection::vec(
                (0u8..4, 0u8..64, 0.0f32..1.0, proptest::bool::weighted(0.8)),
                1..40,
            )
        ) {
            let model = wave_model();
            let frames = model.frame_count();
            let mut state = DeformingState::new(model);
            let mut mirror = (state.indices().to_vec(), state.lengths().to_vec());
            for (i, &(kind, pick, f, rebuild)) in moves.iter().enumerate() {
                let k = state.frame();
                let frame = match kind {
                    0 => k,
                    1 => (k + 1).min(frames - 1),
                    2 => k.saturating_sub(1),
                    _ => pick as usize % frames,
                };
                let t = frame as f32 / (frames - 1) as f32;
                let lod = match pick % 4 {
                    0 => Lod::Fraction(0.0),
                    1 => Lod::Fraction(1.0),
                    2 => Lod::Fraction(f),
                    _ => Lod::Fraction(1.0 - 0.1 * f),
                };
                let strategy = if rebuild { Strategy::Rebuild } else { Strategy::Auto };
                state.set_with(model, t, lod, strategy).expect("valid request");
                proptest::prop_assert_eq!(state.frame(), frame);
                same_as_stepped(&mut state, model, t, lod, &mut mirror, &format!("move {i}"));
            }
        }
    }
}
