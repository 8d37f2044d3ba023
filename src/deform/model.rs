//! The model: an asset validated, its frames built (equal frames once, in parallel, under a
//! memory budget), and a request's time and LOD resolved against a frame's tables.

use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;

use super::frame::{build_frame, Frame};
use super::{DeformError, Lod, SetError};
use crate::asset::{Asset, DEFAULT_MAX_BYTES};
use crate::lodstrips::{ChangeListError, FrameChanges, StripLayout};
use crate::seams::Wedges;

/// What equal frames must share (collapse count, first collapse): narrows the
/// by-value comparisons when frames are deduplicated.
type FrameKey = (usize, Option<(u32, u32)>);

/// Every frame's LOD model over one shared `S0`.
#[derive(Clone, Debug)]
pub struct DeformingModel {
    pub(super) layout: StripLayout,
    /// One entry per sampled frame; equal frames (same collapse sequence)
    /// share one `Frame`, so memory grows with the distinct frames of the
    /// file, not with its frame count (a repeated frame costs 2 bytes on disk).
    pub(super) frames: Vec<Arc<Frame>>,
    pub(super) id: u64,
    /// The asset loops ([`Asset::looping`]): `t` wraps from the last frame to the first.
    looping: bool,
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
            looping: asset.looping(),
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

    /// The frame shown at time `t`: `round(t · (|r| − 1))`, `t` clamped to `[0, 1]`. For an
    /// asset that loops ([`Asset::looping`], frames at `t_k = k / |r|`) `round(t · |r|) mod
    /// |r|`: each frame shows around its own time, and the last half step before `t = 1`
    /// (the pose of `t = 0` again) shows frame 0, so the switch at the wrap is no switch.
    pub fn frame_at(&self, t: f32) -> Result<usize, SetError> {
        if t.is_nan() {
            return Err(SetError::TimeNaN);
        }
        let count = self.frames.len();
        if self.looping {
            return Ok((t.clamp(0.0, 1.0) * count as f32).round() as usize % count);
        }
        let last = count - 1;
        Ok(((t.clamp(0.0, 1.0) * last as f32).round() as usize).min(last))
    }

    /// Whether the model loops ([`frame_at`](Self::frame_at)).
    pub fn looping(&self) -> bool {
        self.looping
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

    /// The error of frame `k` (clamped to the last frame) at LOD `l` (clamped to its
    /// coarsest): its largest collapse error among the first `l`, as a distance in the
    /// poses' units, the quantity a [`Lod::MaxError`] bounds; 0 at full detail. Over the size
    /// of a pixel at a distance, the screen error an object drawn there makes.
    pub fn error_at(&self, k: usize, l: usize) -> f32 {
        let frame = &self.frames[k.min(self.frames.len() - 1)];
        frame.error_at(l.min(frame.changes.max_lod()))
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
