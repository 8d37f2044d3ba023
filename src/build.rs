//! The per-frame builder: a [`Morph`] in, an [`Asset`] out.
//!
//! `S0` is stripified once, on the triangulation `T` shared by every pose;
//! each sampled frame `k` of `|r|` gets its own collapse sequence, computed by
//! the simplifier on the pose `V(t_k)`, `t_k = k / (|r| - 1)`; for a morph that loops (a
//! skinned clip that ends where it starts) `t_k = k / |r|`, since `t = 1` is the pose of
//! `t = 0` again. A skinned morph's pose is its skinned one ([`Morph::positions_at`]), and the
//! asset keeps the skin and clip once instead of the poses. Frames are
//! independent, so they run on the rayon pool, and the stripifier runs beside
//! them (`rayon::join`): on two cores the strips cost no wall time.
//!
//! A morph with vertex attributes (normals, UVs, colours) is simplified on its welded
//! surface ([`Morph::topology`]) under the seam rule ([`crate::seams`]), each frame's
//! topology sequence expanded to the attribute vertices, and the asset gets a
//! [`Surface`]; a position-only morph builds exactly as before, with no surface.
//!
//! Each collapse error is rounded to the precision the `.mlod` file keeps
//! ([`crate::asset::quantize_error`]), so a built asset equals the asset read
//! back from its file, bit for bit.

use crate::asset::{quantize_error, Asset, Surface};
use crate::collapse::CollapseSequence;
use crate::morph::{Morph, TargetBlend, TopologyMap, Weights};
use crate::seams::{expand, SeamError, SeamRule};
use crate::simplify::{
    simplify, simplify_poses, simplify_poses_with_seams, simplify_with_seams, PoseError,
    SimplifyOptions,
};
use crate::strip::{stripify, Strips};
use rayon::prelude::*;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use thiserror::Error;

/// Default number of sampled frames `|r|`.
pub const DEFAULT_FRAMES: usize = 32;

pub use crate::asset::MAX_FRAMES;

/// Why a build failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BuildError {
    #[error("{frames} frames requested: a build needs 1 to {max} frames (1 samples t = 0 only)", max = MAX_FRAMES)]
    FrameCount { frames: usize },
    #[error("triangle {triangle} repeats a vertex ({corners:?}): strips would drop it and no longer cover T; clean the mesh first (mesh::clean)")]
    DegenerateTriangle { triangle: usize, corners: [u32; 3] },
    #[error("the morph has {vertices} vertices; strips reserve index 0xFFFFFFFF, so at most 4294967295 fit")]
    TooManyVertices { vertices: usize },
    #[error("frame {frame} (t = {t}): vertex {vertex} of the pose is not finite ({value:?}); the morph's weights or targets overflow there")]
    NonFinitePose {
        frame: usize,
        t: f32,
        vertex: usize,
        value: [f32; 3],
    },
    #[error("the animation drives {targets} morph targets; the GPU blends at most {max}: bake some into the base mesh or split the animation", max = crate::asset::MAX_TARGETS)]
    TooManyTargets { targets: usize },
    #[error("frame {frame}: the simplifier made a collapse the seam rule refuses ({source}); this is a bug in morphlod, please report it with the input")]
    Seams { frame: usize, source: SeamError },
}

/// Which collapse sequences an asset gets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sequences {
    /// One sequence per sampled frame, each simplifying its own pose (the per-frame LOD model:
    /// coarse levels follow the shape at that moment; the runtime switches frames).
    #[default]
    PerFrame,
    /// One sequence for the whole morph, simplified over all sampled poses at once
    /// ([`simplify_poses`]): the asset has one frame, so the runtime never switches frames
    /// and keeps one change list, and every LOD is one connectivity valid at every `t`.
    Shared(PoseError),
}

/// How far a build is: sent after each finished frame, from worker threads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    pub frames_done: usize,
    pub frames: usize,
}

/// What a build did and how long each stage took.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuildReport {
    pub vertices: usize,
    /// Vertices of the welded surface the simplifier works on (equal to `vertices` for a
    /// morph without vertex attributes).
    pub topology_vertices: usize,
    /// Topology vertices with more than one vertex (split at a seam).
    pub seam_vertices: usize,
    pub triangles: usize,
    pub strips: usize,
    pub strip_indices: usize,
    /// Collapses (LOD steps) of each frame.
    pub collapses: Vec<usize>,
    /// Stripifying `T` (runs beside the frames).
    pub strip_time: Duration,
    /// Per frame: evaluating the pose and simplifying it, on its worker thread.
    pub frame_times: Vec<Duration>,
    /// Wall time of all frames together.
    pub frames_wall: Duration,
    /// Wall time of the whole build.
    pub wall: Duration,
    /// Worker threads in the rayon pool.
    pub threads: usize,
}

impl BuildReport {
    /// The summed thread time of all frames (the CPU cost, not the wall time).
    pub fn frames_cpu(&self) -> Duration {
        self.frame_times.iter().sum()
    }
}

/// Builds an [`Asset`] from a morph whose mesh is already cleaned (no
/// triangle repeating a vertex; see [`crate::mesh::clean`] and [`Morph::select`]).
pub struct Builder<'a> {
    morph: &'a Morph,
    frames: usize,
    sequences: Sequences,
    simplify: SimplifyOptions,
    progress: Option<&'a (dyn Fn(Progress) + Sync)>,
}

impl<'a> Builder<'a> {
    pub fn new(morph: &'a Morph) -> Self {
        Self {
            morph,
            frames: DEFAULT_FRAMES,
            sequences: Sequences::PerFrame,
            simplify: SimplifyOptions::default(),
            progress: None,
        }
    }

    /// The number of sampled frames `|r|` (default [`DEFAULT_FRAMES`]); 1
    /// samples `t = 0` only, which the runtime then uses for every `t`.
    pub fn frames(mut self, frames: usize) -> Self {
        self.frames = frames;
        self
    }

    /// Per-frame sequences (the default) or one shared sequence over all `frames` sampled
    /// poses ([`Sequences::Shared`]; the asset then has one frame).
    pub fn sequences(mut self, sequences: Sequences) -> Self {
        self.sequences = sequences;
        self
    }

    pub fn simplify_options(mut self, options: SimplifyOptions) -> Self {
        self.simplify = options;
        self
    }

    /// Called after each frame, from whichever thread finished it.
    pub fn progress(mut self, callback: &'a (dyn Fn(Progress) + Sync)) -> Self {
        self.progress = Some(callback);
        self
    }

    /// Builds the asset, one named stage after another: the input checked; on a morph with
    /// vertex attributes, the welded surface and its seam rule; the frames whose poses may
    /// equal an earlier frame's; then `S0` stripified beside the frames' sequences (on the
    /// rayon pool); each frame given its sequence (shared where poses are equal); the report
    /// and the asset.
    pub fn build(&self) -> Result<(Asset, BuildReport), BuildError> {
        let start = Instant::now();
        let morph = self.morph;
        let blend = self.check_input()?;

        // With vertex attributes the simplifier runs on the welded surface under the seam
        // rule; without, the identity map would change nothing but the time taken.
        let attributes = morph.attributes();
        let topology = attributes.has_vertex_attributes().then(|| morph.topology());
        // The attribute error reads the normals the asset gives: computed ones follow the
        // welded geometry, which the position quadrics already price.
        let rule = topology.as_ref().map(|map| {
            SeamRule::new(map, attributes.uvs.as_deref())
                .with_normals(attributes.normals.as_deref())
        });

        let candidate = self.pose_candidates();
        let ((s0, strip_time), (built, frames_wall)) = rayon::join(
            || self.strips(),
            || self.simplify_frames(rule.as_ref(), &candidate),
        );
        let (built, frame_times): (Vec<Built>, Vec<Duration>) = built?.into_iter().unzip();
        let sequences = share_sequences(built, self.frames);
        let n = morph.vertex_count();
        let triangles = morph.triangles();
        let report = BuildReport {
            vertices: n,
            topology_vertices: topology.as_ref().map_or(n, |map| map.topology_count),
            seam_vertices: topology.as_ref().map_or(0, TopologyMap::seam_vertices),
            triangles: triangles.len(),
            strips: s0.len(),
            strip_indices: s0.indices.len(),
            collapses: sequences.iter().map(|s| s.len()).collect(),
            strip_time,
            frame_times,
            frames_wall,
            wall: start.elapsed(),
            threads: rayon::current_num_threads(),
        };
        let asset = Asset {
            v0: morph.v0(),
            v1: morph.v1(),
            s0,
            frames: sequences,
            surface: topology.map(|map| surface(morph, map)),
            blend,
            skin: morph.skinning().cloned(),
        };
        Ok((asset, report))
    }

    /// The checks made before any work, in this order: the frame count, the vertex count, no
    /// triangle repeating a vertex, at most [`MAX_TARGETS`](crate::asset::MAX_TARGETS)
    /// driven targets. Returns the targets' blend the asset gets.
    fn check_input(&self) -> Result<Option<TargetBlend>, BuildError> {
        let morph = self.morph;
        let frames = self.frames;
        if frames == 0 || frames > MAX_FRAMES {
            return Err(BuildError::FrameCount { frames });
        }
        let n = morph.vertex_count();
        if n >= u32::MAX as usize {
            return Err(BuildError::TooManyVertices { vertices: n });
        }
        let triangles = morph.triangles();
        if let Some((triangle, &corners)) = triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
        {
            return Err(BuildError::DegenerateTriangle { triangle, corners });
        }
        let blend = morph.target_blend();
        if let Some(targets) = blend.as_ref().map(|b| b.deltas.len()) {
            if targets > crate::asset::MAX_TARGETS {
                return Err(BuildError::TooManyTargets { targets });
            }
        }
        Ok(blend)
    }

    /// The time of sampled frame `k`: `k / (|r| − 1)`, or 0 when there is one frame; for a
    /// morph that loops `k / |r|` (module docs).
    fn time_of(&self, k: usize) -> f32 {
        if self.morph.looping() {
            k as f32 / self.frames as f32
        } else if self.frames == 1 {
            0.0
        } else {
            k as f32 / (self.frames - 1) as f32
        }
    }

    /// Equal poses make equal sequences (the simplifier is deterministic), so a frame
    /// whose sampled positions equal an earlier frame's bit for bit shares that frame's
    /// sequence instead of simplifying again (held poses, a mesh morphed to itself).
    /// `candidate[k]`: the first frame whose pose hashes like frame k's; the poses are
    /// compared in full before sharing ([`simplify_frame`](Self::simplify_frame)).
    fn pose_candidates(&self) -> Vec<usize> {
        let hashes: Vec<u64> = (0..self.frames)
            .into_par_iter()
            .map(|k| pose_hash(&self.morph.positions_at(self.time_of(k))))
            .collect();
        let mut first_by_hash: HashMap<u64, usize> = HashMap::new();
        hashes
            .iter()
            .enumerate()
            .map(|(k, &h)| *first_by_hash.entry(h).or_insert(k))
            .collect()
    }

    /// `S0`: the triangulation `T` stripified (runs beside the frames), and the time taken.
    fn strips(&self) -> (Strips, Duration) {
        let begin = Instant::now();
        let morph = self.morph;
        (
            stripify(morph.triangles(), morph.vertex_count()),
            begin.elapsed(),
        )
    }

    /// What each frame is built from, as [`Sequences`] asks: per frame on the rayon pool, or
    /// the one shared sequence; with the wall time of all frames together.
    fn simplify_frames(
        &self,
        rule: Option<&SeamRule>,
        candidate: &[usize],
    ) -> (Result<Vec<(Built, Duration)>, BuildError>, Duration) {
        let begin = Instant::now();
        let done = AtomicUsize::new(0);
        let built: Result<Vec<_>, BuildError> = match self.sequences {
            Sequences::PerFrame => (0..self.frames)
                .into_par_iter()
                .map(|k| self.simplify_frame(k, rule, candidate, &done))
                .collect(),
            Sequences::Shared(combine) => self.simplify_shared(combine, rule),
        };
        (built, begin.elapsed())
    }

    /// Frame `k`: its pose simplified (on the welded surface under `rule`, then expanded to
    /// the attribute vertices, where there is one), or the earlier frame whose pose equals
    /// its own bit for bit; with the time taken on its worker thread. `done` counts the
    /// frames finished, for [`progress`](Self::progress).
    fn simplify_frame(
        &self,
        k: usize,
        rule: Option<&SeamRule>,
        candidate: &[usize],
        done: &AtomicUsize,
    ) -> Result<(Built, Duration), BuildError> {
        let begin = Instant::now();
        let morph = self.morph;
        let triangles = morph.triangles();
        let t = self.time_of(k);
        let pose = morph.positions_at(t);
        let j = candidate[k];
        let same = j != k && {
            let earlier = morph.positions_at(self.time_of(j));
            bit_equal(&pose, &earlier)
        };
        let built = if same {
            Built::SameAs(j)
        } else {
            check_finite_pose(k, t, &pose)?;
            let sequence = match rule {
                None => simplify(&pose, triangles, &self.simplify),
                Some(rule) => {
                    let welded = simplify_with_seams(&pose, triangles, rule, &self.simplify);
                    expand(&welded, triangles, rule)
                        .map_err(|source| BuildError::Seams { frame: k, source })?
                }
            };
            Built::Sequence(Arc::new(quantize_errors(sequence)))
        };
        let elapsed = begin.elapsed();
        let frames_done = done.fetch_add(1, Ordering::Relaxed) + 1;
        self.report_progress(frames_done, self.frames);
        Ok((built, elapsed))
    }

    /// The shared sequence: every sampled pose at once, one frame.
    fn simplify_shared(
        &self,
        combine: PoseError,
        rule: Option<&SeamRule>,
    ) -> Result<Vec<(Built, Duration)>, BuildError> {
        let begin = Instant::now();
        let morph = self.morph;
        let triangles = morph.triangles();
        let poses: Vec<Vec<[f32; 3]>> = (0..self.frames)
            .into_par_iter()
            .map(|k| morph.positions_at(self.time_of(k)))
            .collect();
        for (k, pose) in poses.iter().enumerate() {
            check_finite_pose(k, self.time_of(k), pose)?;
        }
        let views: Vec<&[[f32; 3]]> = poses.iter().map(Vec::as_slice).collect();
        let sequence = match rule {
            None => simplify_poses(&views, triangles, &self.simplify, combine),
            Some(rule) => {
                let welded =
                    simplify_poses_with_seams(&views, triangles, rule, &self.simplify, combine);
                expand(&welded, triangles, rule)
                    .map_err(|source| BuildError::Seams { frame: 0, source })?
            }
        };
        let sequence = quantize_errors(sequence);
        self.report_progress(1, 1);
        Ok(vec![(Built::Sequence(Arc::new(sequence)), begin.elapsed())])
    }

    /// Tells the [`progress`](Self::progress) callback, if any.
    fn report_progress(&self, frames_done: usize, frames: usize) {
        if let Some(report) = self.progress {
            report(Progress {
                frames_done,
                frames,
            });
        }
    }
}

/// `sequence` with each collapse error rounded to the precision the `.mlod` file keeps
/// ([`quantize_error`]).
fn quantize_errors(mut sequence: CollapseSequence) -> CollapseSequence {
    for c in &mut sequence.collapses {
        c.error = quantize_error(c.error);
    }
    sequence
}

/// Each frame's sequence from what it was built from: its own, or that of the earlier frame
/// whose pose it shares.
fn share_sequences(built: Vec<Built>, frames: usize) -> Vec<Arc<CollapseSequence>> {
    let mut sequences: Vec<Arc<CollapseSequence>> = Vec::with_capacity(frames);
    for b in built {
        // `j < k` and frame j simplified its own pose (it is the first of its hash).
        let sequence = match b {
            Built::Sequence(sequence) => sequence,
            Built::SameAs(j) => sequences[j].clone(),
        };
        sequences.push(sequence);
    }
    sequences
}

/// The [`Surface`] of a morph with vertex attributes, welded by `topology`.
fn surface(morph: &Morph, topology: TopologyMap) -> Surface {
    let normals = morph.normals();
    // `base + Σ w_k(t) D_k`, left unnormalised so the GPU can blend and normalise.
    let normals_at = |t: f32| {
        let mut out = normals.base.clone();
        for (deltas, &w) in normals.deltas.iter().zip(&morph.weights_at(t)) {
            if w == 0.0 {
                continue;
            }
            for (n, d) in out.iter_mut().zip(deltas) {
                n[0] += w * d[0];
                n[1] += w * d[1];
                n[2] += w * d[2];
            }
        }
        out
    };
    // The targets `Morph::target_blend` keeps (those the animation drives), in its order.
    let normal_deltas = match morph.weights() {
        Weights::Animated(track) => (0..morph.targets().len())
            .filter(|&k| track.drives(k))
            .map(|k| normals.deltas[k].clone())
            .collect(),
        Weights::TwoPose { .. } => Vec::new(),
    };
    let attributes = morph.attributes();
    Surface {
        topology: topology.of_vertex,
        n0: normals_at(0.0),
        n1: normals_at(1.0),
        normal_deltas,
        uvs: attributes.uvs.clone(),
        colors: attributes.colors.clone(),
        material: attributes.material.clone(),
    }
}

/// What the builder made of one frame.
enum Built {
    Sequence(Arc<CollapseSequence>),
    /// The pose equals this earlier frame's, bit for bit: share its sequence.
    SameAs(usize),
}

fn check_finite_pose(frame: usize, t: f32, pose: &[[f32; 3]]) -> Result<(), BuildError> {
    match pose
        .iter()
        .enumerate()
        .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
    {
        Some((vertex, &value)) => Err(BuildError::NonFinitePose {
            frame,
            t,
            vertex,
            value,
        }),
        None => Ok(()),
    }
}

fn pose_hash(pose: &[[f32; 3]]) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for p in pose {
        p.map(f32::to_bits).hash(&mut h);
    }
    h.finish()
}

fn bit_equal(a: &[[f32; 3]], b: &[[f32; 3]]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x.map(f32::to_bits) == y.map(f32::to_bits))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collapse::canonical_multiset;

    /// A 3×3 grid of vertices (8 triangles) whose middle row rises with `t`.
    fn grid_morph() -> Morph {
        let mut v0 = Vec::new();
        let mut v1 = Vec::new();
        for y in 0..3 {
            for x in 0..3 {
                v0.push([x as f32, y as f32, 0.0]);
                v1.push([x as f32, y as f32, if y == 1 { 1.0 } else { 0.0 }]);
            }
        }
        let mut tris = Vec::new();
        for y in 0..2u32 {
            for x in 0..2u32 {
                let a = y * 3 + x;
                tris.push([a, a + 1, a + 4]);
                tris.push([a, a + 4, a + 3]);
            }
        }
        Morph::from_poses(tris, v0, v1).unwrap()
    }

    /// Frame k of 3 is the simplifier's sequence of the pose at t = k / 2, written out here
    /// (the middle row at height 0, 0.5, 1), with each error rounded to bfloat16 (low 16 bits
    /// zero, within half a bfloat16 step of the simplifier's value).
    #[test]
    fn frames_sample_their_poses() {
        let morph = grid_morph();
        let (asset, report) = Builder::new(&morph).frames(3).build().unwrap();
        assert_eq!(asset.frames.len(), 3);
        assert_eq!(report.frame_times.len(), 3);
        assert_eq!(asset.v0, morph.v0());
        assert_eq!(asset.v1, morph.v1());
        for (k, (seq, height)) in asset.frames.iter().zip([0.0f32, 0.5, 1.0]).enumerate() {
            let pose: Vec<[f32; 3]> = (0..9)
                .map(|v| {
                    let (x, y) = ((v % 3) as f32, (v / 3) as f32);
                    [x, y, if v / 3 == 1 { height } else { 0.0 }]
                })
                .collect();
            let raw = simplify(&pose, morph.triangles(), &SimplifyOptions::default());
            let pairs = |s: &CollapseSequence| -> Vec<(u32, u32)> {
                s.collapses.iter().map(|c| (c.u, c.w)).collect()
            };
            assert_eq!(pairs(seq), pairs(&raw), "frame {k}: collapse order");
            for (i, (c, r)) in seq.collapses.iter().zip(&raw.collapses).enumerate() {
                assert_eq!(
                    c.error.to_bits() & 0xFFFF,
                    0,
                    "frame {k} collapse {i}: bfloat16"
                );
                let e = r.error.max(0.0);
                assert!(
                    (c.error - e).abs() <= e * (1.0 / 256.0),
                    "frame {k} collapse {i}: stored {} for {e}",
                    c.error
                );
            }
            seq.validate().unwrap();
        }
        assert_eq!(
            canonical_multiset(asset.s0.triangles()),
            canonical_multiset(morph.triangles().iter().copied())
        );
    }

    #[test]
    fn one_frame_is_t_zero_and_zero_frames_fail() {
        let morph = grid_morph();
        let (asset, _) = Builder::new(&morph).frames(1).build().unwrap();
        assert_eq!(asset.frames.len(), 1);
        assert!(matches!(
            Builder::new(&morph).frames(0).build(),
            Err(BuildError::FrameCount { frames: 0 })
        ));
    }

    #[test]
    fn progress_reaches_every_frame() {
        let morph = grid_morph();
        let seen = AtomicUsize::new(0);
        let callback = |p: Progress| {
            assert_eq!(p.frames, 5);
            seen.fetch_max(p.frames_done, Ordering::Relaxed);
        };
        Builder::new(&morph)
            .frames(5)
            .progress(&callback)
            .build()
            .unwrap();
        assert_eq!(seen.load(Ordering::Relaxed), 5);
    }

    /// The surface of an animated morph with vertex colours: `n0`, `n1` are the source's
    /// normals blended with the weights at 0 and 1, unnormalised, and the normal deltas are
    /// those of the blended targets, in `blend.deltas` order.
    #[test]
    fn surfaces_carry_the_blended_normals() {
        use crate::morph::{Attributes, Interpolation, MorphTarget, WeightTrack};
        let grid = grid_morph();
        let n = grid.vertex_count();
        let lift = |z: f32| MorphTarget {
            name: format!("lift {z}"),
            deltas: (0..n)
                .map(|v| [0.0, 0.0, if v % 3 == 1 { z } else { 0.0 }])
                .collect(),
            normal_deltas: None,
        };
        // Target 0 is never driven, targets 1 and 2 are (weights from 0.25 to 1 and 0 to 0.5).
        let track = WeightTrack::new(
            Interpolation::Linear,
            vec![0.0, 1.0],
            vec![0.0, 0.25, 0.0, 0.0, 1.0, 0.5],
            3,
        )
        .unwrap();
        let morph = Morph::from_parts(
            grid.triangles().to_vec(),
            grid.base().to_vec(),
            vec![lift(2.0), lift(1.0), lift(-1.0)],
            Weights::Animated(track),
        )
        .unwrap()
        .with_attributes(Attributes {
            colors: Some(vec![[0.5; 4]; n]),
            ..Default::default()
        })
        .unwrap();
        let (asset, report) = Builder::new(&morph).frames(3).build().unwrap();
        let surface = asset.surface.unwrap();
        let normals = morph.normals();
        assert_eq!(surface.normal_deltas, normals.deltas[1..].to_vec());
        assert_eq!(asset.blend.unwrap().deltas.len(), 2);
        for (got, w) in [(&surface.n0, [0.25f32, 0.0]), (&surface.n1, [1.0, 0.5])] {
            for (v, got) in got.iter().enumerate() {
                let want: [f32; 3] = std::array::from_fn(|i| {
                    normals.base[v][i]
                        + w[0] * normals.deltas[1][v][i]
                        + w[1] * normals.deltas[2][v][i]
                });
                for i in 0..3 {
                    assert!(
                        (got[i] - want[i]).abs() < 1e-6,
                        "vertex {v}: {got:?} vs {want:?}"
                    );
                }
            }
        }
        assert_eq!(surface.colors, Some(vec![[0.5; 4]; n]));
        assert_eq!(surface.topology, (0..n as u32).collect::<Vec<_>>());
        assert_eq!((report.topology_vertices, report.seam_vertices), (n, 0));
    }

    #[test]
    fn degenerate_triangles_are_refused() {
        let v = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let morph = Morph::from_poses(vec![[0, 1, 2], [0, 1, 1]], v.clone(), v).unwrap();
        assert!(matches!(
            Builder::new(&morph).build(),
            Err(BuildError::DegenerateTriangle { triangle: 1, .. })
        ));
    }
}
