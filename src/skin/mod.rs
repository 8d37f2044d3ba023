//! Skinned deformation as glTF 2.0 defines it (§3.7.3 "Skins", §3.11 "Animations",
//! Appendix C): a skeleton of nodes, a clip moving them, and per vertex a few joints with
//! weights; the pose at time `τ` is linear blend skinning of the (morphed) bind pose
//!
//! ```text
//! jointMatrix(j) = G(node(j), τ) · IBM(j)                    G: the node's world matrix at τ
//! p'(v)          = (Σ_i w_i(v) · jointMatrix(j_i(v))) · (p(v), 1)
//! ```
//!
//! with `p(v) = base(v) + Σ_k w_k(τ) D_k(v)` (morph first, then skin) and the skinned mesh
//! node's own transform ignored, as the specification says. [`Skinning::pose_at`] is that
//! definition in code: the CPU reference every other skinning (the GPU's) is checked against.
//!
//! Everything is flat (`Vec<u32>`, `Vec<f32>`) so that buffers can be made from it as it is:
//! per vertex [`Skin::influences`] joints and weights, 16 floats per inverse bind matrix, and
//! [`Skinning::bake`] gives the joint matrices of any set of times (a clip's keys:
//! [`Clip::key_times`]) as one array.
//!
//! Files: `skeleton.rs` (the hierarchy, rest transforms, world matrices) → `clip.rs` (the
//! channels and their sampling) → this file (the skin, its checks, the pose) → `bake.rs` (the
//! joint matrices at uniform keys, what the GPU skins from: [`BakedClip`]).

mod bake;
mod clip;
mod skeleton;

pub use bake::{BakedClip, BAKE_RATE, BAKE_TOLERANCE, KEY_BUDGET, ROW_FLOATS};
pub use clip::{Clip, JointChannel, NodeProperty, NodeTrack};
pub use skeleton::{trs_matrix, Skeleton, NO_PARENT, TRS, UNIT_TOLERANCE};

use glam::{Mat4, Vec3, Vec4};
use thiserror::Error;

/// Most influences (joint and weight pairs) a vertex may have: four glTF JOINTS_n/WEIGHTS_n
/// sets.
pub const MAX_INFLUENCES: usize = 16;

/// How far from 1 a vertex's weights may sum in a skin ([`Skin::validate`]): f32 rounding of
/// weights that were normalised.
pub const SUM_TOLERANCE: f32 = 1e-4;

/// How far from 1 a file's weights may sum and still be renormalised
/// ([`Skin::normalize_weights`]) rather than refused: what rounding each of 4 to 16 weights to
/// 8 bits leaves (at most 16 · ½/255 ≈ 0.03), and the lax float sums exporters write. glTF
/// asks for sums of 1 (exactly, for normalized integers; "as close as reasonably possible" for
/// floats); further off, the weights mean something else and the file is refused.
pub const RENORMALIZE_TOLERANCE: f32 = 0.05;

/// Why a skin or a clip cannot be used.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SkinError {
    #[error(
        "the skeleton has {nodes} parents but {rest} rest values (10 a node) and {names} names"
    )]
    SkeletonSize {
        nodes: usize,
        rest: usize,
        names: usize,
    },
    #[error("node {node}'s parent is node {parent}, which does not come before it")]
    ParentOrder { node: usize, parent: u32 },
    #[error("node {node}: {problem}")]
    Rest { node: String, problem: String },
    #[error("the skin has no joints")]
    NoJoints,
    #[error("joint {joint} is node {node}, but the skeleton has {nodes} nodes")]
    JointNode {
        joint: usize,
        node: u32,
        nodes: usize,
    },
    #[error("{values} inverse bind matrix values for {joints} joints (16 a joint)")]
    InverseBindCount { values: usize, joints: usize },
    #[error("the inverse bind matrix of joint {joint} (node {node}) {problem}")]
    InverseBind {
        joint: usize,
        node: String,
        problem: &'static str,
    },
    #[error("{influences} influences a vertex; a skin has 1 to {MAX_INFLUENCES}")]
    Influences { influences: usize },
    #[error("{joints} joint indices and {weights} weights for {vertices} vertices of {influences} influences")]
    VertexData {
        joints: usize,
        weights: usize,
        vertices: usize,
        influences: usize,
    },
    #[error("vertex {vertex} names joint {joint} (influence {influence}), but the skin has {joints} joints")]
    JointOutOfRange {
        vertex: usize,
        influence: usize,
        joint: u32,
        joints: usize,
    },
    #[error("vertex {vertex} has weight {weight} (influence {influence}); weights must be finite and not negative")]
    BadWeight {
        vertex: usize,
        influence: usize,
        weight: f32,
    },
    #[error("vertex {vertex}'s weights sum to {sum}, not 1 (allowed: within {tolerance}); normalise the weights in the program that wrote the file")]
    WeightSum {
        vertex: usize,
        sum: f32,
        tolerance: f32,
    },
    #[error("channel {channel} drives node {node}, but the skeleton has {nodes} nodes")]
    ChannelNode {
        channel: usize,
        node: u32,
        nodes: usize,
    },
    #[error("channel {channel} (node {node}) {problem}")]
    Channel {
        channel: usize,
        node: String,
        problem: String,
    },
    #[error("the clip lasts {duration} s, but a key is at {last} s")]
    Duration { duration: f32, last: f32 },
}

/// Per vertex its joints and weights, the joints' nodes in a [`Skeleton`] and their inverse
/// bind matrices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skin {
    pub skeleton: Skeleton,
    /// Per joint, the skeleton node it is.
    pub joint_nodes: Vec<u32>,
    /// Per joint its inverse bind matrix, 16 floats, column-major (the identity where the
    /// file gives none, as glTF says).
    pub inverse_binds: Vec<f32>,
    /// Joint and weight pairs per vertex, 1 to [`MAX_INFLUENCES`] (4 per glTF set).
    pub influences: usize,
    /// Per vertex `influences` joint indices (into `joint_nodes`).
    pub joints: Vec<u32>,
    /// Per vertex `influences` weights: finite, not negative, summing to 1 within
    /// [`SUM_TOLERANCE`].
    pub weights: Vec<f32>,
}

/// What [`Skin::normalize_weights`] changed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Renormalized {
    /// Vertices whose weights were divided by their sum.
    pub vertices: usize,
    /// The sum furthest from 1 among them (1 when there are none).
    pub worst_sum: f32,
}

/// What [`Skinning::reduce_influences`] dropped.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reduction {
    /// Vertices that had more nonzero influences than kept.
    pub vertices: usize,
    /// The largest weight sum dropped from one vertex (before renormalising the rest).
    pub max_dropped_weight: f32,
    /// The largest distance a vertex moved, over the clip's key times, between the pose with
    /// every influence and the reduced one (the positions' units).
    pub max_displacement: f32,
}

impl Skin {
    pub fn joint_count(&self) -> usize {
        self.joint_nodes.len()
    }

    /// Checks everything [`Skinning::pose_at`] relies on, for `vertices` vertices: the
    /// skeleton ([`Skeleton::validate`]); at least one joint, each a node of it; one finite,
    /// invertible inverse bind matrix per joint; 1 to [`MAX_INFLUENCES`] influences, every
    /// joint index in range, every weight finite and not negative, each vertex's summing to 1
    /// within [`SUM_TOLERANCE`].
    pub fn validate(&self, vertices: usize) -> Result<(), SkinError> {
        self.skeleton.validate()?;
        let joints = self.joint_count();
        if joints == 0 {
            return Err(SkinError::NoJoints);
        }
        let nodes = self.skeleton.node_count();
        if let Some((joint, &node)) = self
            .joint_nodes
            .iter()
            .enumerate()
            .find(|(_, &n)| n as usize >= nodes)
        {
            return Err(SkinError::JointNode { joint, node, nodes });
        }
        if self.inverse_binds.len() != 16 * joints {
            return Err(SkinError::InverseBindCount {
                values: self.inverse_binds.len(),
                joints,
            });
        }
        for (joint, m) in self.inverse_binds.chunks_exact(16).enumerate() {
            if let Some(problem) = inverse_bind_problem(m) {
                return Err(SkinError::InverseBind {
                    joint,
                    node: self.skeleton.display(self.joint_nodes[joint] as usize),
                    problem,
                });
            }
        }
        let i = self.influences;
        if i == 0 || i > MAX_INFLUENCES {
            return Err(SkinError::Influences { influences: i });
        }
        if self.joints.len() != vertices * i || self.weights.len() != vertices * i {
            return Err(SkinError::VertexData {
                joints: self.joints.len(),
                weights: self.weights.len(),
                vertices,
                influences: i,
            });
        }
        if let Some(at) = self.joints.iter().position(|&j| j as usize >= joints) {
            return Err(SkinError::JointOutOfRange {
                vertex: at / i,
                influence: at % i,
                joint: self.joints[at],
                joints,
            });
        }
        self.check_weights(SUM_TOLERANCE)
    }

    /// Every weight finite and not negative, and each vertex's sum within `tolerance` of 1.
    fn check_weights(&self, tolerance: f32) -> Result<(), SkinError> {
        let i = self.influences;
        if let Some(at) = self.weights.iter().position(|w| !w.is_finite() || *w < 0.0) {
            return Err(SkinError::BadWeight {
                vertex: at / i,
                influence: at % i,
                weight: self.weights[at],
            });
        }
        for (vertex, w) in self.weights.chunks_exact(i).enumerate() {
            let sum: f32 = w.iter().sum();
            if (sum - 1.0).abs() > tolerance {
                return Err(SkinError::WeightSum {
                    vertex,
                    sum,
                    tolerance,
                });
            }
        }
        Ok(())
    }

    /// Divides each vertex's weights by their sum where it is further from 1 than the Khronos
    /// validator allows (`2e-7` per nonzero weight, its f32 rounding); refuses a file whose
    /// sums are further than [`RENORMALIZE_TOLERANCE`] from 1, or a weight that is negative
    /// or not finite. Call before [`validate`](Self::validate) on weights as a file gives them.
    pub fn normalize_weights(&mut self) -> Result<Renormalized, SkinError> {
        self.check_weights(RENORMALIZE_TOLERANCE)?;
        let mut changed = Renormalized {
            vertices: 0,
            worst_sum: 1.0,
        };
        for w in self.weights.chunks_exact_mut(self.influences) {
            let sum: f32 = w.iter().sum();
            let nonzero = w.iter().filter(|&&x| x != 0.0).count();
            if (sum - 1.0).abs() <= 2e-7 * nonzero as f32 {
                continue;
            }
            changed.vertices += 1;
            if (sum - 1.0).abs() > (changed.worst_sum - 1.0).abs() {
                changed.worst_sum = sum;
            }
            w.iter_mut().for_each(|x| *x /= sum);
        }
        Ok(changed)
    }

    /// The same skin on a subset of the vertices, renumbered: new vertex `i` is old vertex
    /// `vertex_map[i]` (every entry in range: [`crate::morph::Morph::select`] checks).
    pub fn select(&self, vertex_map: &[u32]) -> Skin {
        fn gather<T: Copy>(values: &[T], vertex_map: &[u32], i: usize) -> Vec<T> {
            vertex_map
                .iter()
                .flat_map(|&v| values[v as usize * i..(v as usize + 1) * i].iter().copied())
                .collect()
        }
        Skin {
            joints: gather(&self.joints, vertex_map, self.influences),
            weights: gather(&self.weights, vertex_map, self.influences),
            ..self.clone()
        }
    }

    /// The linear blend skinning of `positions` with the joint matrices `matrices` (16 floats
    /// per joint, [`Skinning::joint_matrices`]) into `out`: per vertex the weighted sum of its
    /// joints' matrices applied to the position, as glTF's reference shader does.
    pub fn deform(&self, matrices: &[f32], positions: &[[f32; 3]], out: &mut Vec<[f32; 3]>) {
        let i = self.influences;
        out.clear();
        out.extend(positions.iter().enumerate().map(|(v, p)| {
            let mut skin = [Vec4::ZERO; 4];
            for (&j, &w) in self.joints[v * i..(v + 1) * i]
                .iter()
                .zip(&self.weights[v * i..(v + 1) * i])
            {
                if w == 0.0 {
                    continue;
                }
                let m = &matrices[j as usize * 16..j as usize * 16 + 16];
                for (c, column) in skin.iter_mut().enumerate() {
                    *column += w * Vec4::from_slice(&m[4 * c..4 * c + 4]);
                }
            }
            let [x, y, z] = *p;
            (skin[0] * x + skin[1] * y + skin[2] * z + skin[3])
                .truncate()
                .to_array()
        }));
    }
}

/// Why an inverse bind matrix cannot be one: a value that is not finite, or a linear part
/// that is singular (its determinant under `1e-6` of the product of its column lengths: it
/// flattens the mesh, and the joint's bind pose cannot be recovered).
fn inverse_bind_problem(m: &[f32]) -> Option<&'static str> {
    if m.iter().any(|v| !v.is_finite()) {
        return Some("has a value that is not finite");
    }
    let columns = [0, 4, 8].map(|c| Vec3::from_slice(&m[c..c + 3]));
    let det = glam::Mat3::from_cols(columns[0], columns[1], columns[2]).determinant();
    let scale: f32 = columns.iter().map(|c| c.length()).product();
    if scale == 0.0 || det.abs() <= 1e-6 * scale {
        return Some("is singular (it flattens the mesh)");
    }
    None
}

/// A skin and the clip that moves it: a skinned deformation over time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skinning {
    pub skin: Skin,
    pub clip: Clip,
}

impl Skinning {
    /// Checks the skin for `vertices` vertices ([`Skin::validate`]) and the clip on its
    /// skeleton ([`Clip::validate`]).
    pub fn validate(&self, vertices: usize) -> Result<(), SkinError> {
        self.skin.validate(vertices)?;
        self.clip.validate(&self.skin.skeleton)
    }

    /// Every joint's matrix at `time` (seconds): the world matrix of its node at that time
    /// times its inverse bind matrix, 16 floats per joint, column-major, into `out`.
    pub fn joint_matrices(&self, time: f32, out: &mut Vec<f32>) {
        let skin = &self.skin;
        let mut locals = Vec::with_capacity(skin.skeleton.rest.len());
        self.clip.locals_at(&skin.skeleton, time, &mut locals);
        let mut globals = Vec::with_capacity(skin.skeleton.node_count());
        skin.skeleton.globals(&locals, &mut globals);
        out.clear();
        for (&node, ibm) in skin
            .joint_nodes
            .iter()
            .zip(skin.inverse_binds.chunks_exact(16))
        {
            let m = globals[node as usize] * Mat4::from_cols_slice(ibm);
            out.extend_from_slice(&m.to_cols_array());
        }
    }

    /// The joint matrices at each of `times` (seconds), one after the other: `times.len() ×
    /// joints × 16` floats, what a GPU buffer of baked keys holds.
    pub fn bake(&self, times: &[f32]) -> Vec<f32> {
        let mut out = Vec::with_capacity(times.len() * self.skin.joint_count() * 16);
        let mut one = Vec::new();
        for &time in times {
            self.joint_matrices(time, &mut one);
            out.extend_from_slice(&one);
        }
        out
    }

    /// The skinned pose at `time` (seconds) of the bind-space positions `bind` (the morphed
    /// base: morph first, then skin): the CPU reference (module docs).
    pub fn pose_at(&self, bind: &[[f32; 3]], time: f32) -> Vec<[f32; 3]> {
        let mut matrices = Vec::new();
        self.joint_matrices(time, &mut matrices);
        let mut out = Vec::with_capacity(bind.len());
        self.skin.deform(&matrices, bind, &mut out);
        out
    }

    /// Keeps at most `max` influences a vertex (1 to [`MAX_INFLUENCES`]): its joints merged
    /// (a joint named twice counts once, weights summed), the `max` largest weights kept and
    /// renormalised, the influence count set to `max`. Returns what was dropped, the
    /// displacement measured on `bind` at every key time of the clip.
    pub fn reduce_influences(&mut self, max: usize, bind: &[[f32; 3]]) -> Reduction {
        let max = max.clamp(1, MAX_INFLUENCES);
        let before = self.clone();
        let skin = &mut self.skin;
        let i = skin.influences;
        let mut reduction = Reduction::default();
        let mut joints = Vec::with_capacity(bind.len() * max);
        let mut weights = Vec::with_capacity(bind.len() * max);
        let mut pairs: Vec<(u32, f32)> = Vec::with_capacity(i);
        for v in 0..skin.joints.len() / i {
            pairs.clear();
            for (&j, &w) in skin.joints[v * i..(v + 1) * i]
                .iter()
                .zip(&skin.weights[v * i..(v + 1) * i])
            {
                match pairs.iter_mut().find(|(k, _)| *k == j) {
                    Some(pair) => pair.1 += w,
                    None => pairs.push((j, w)),
                }
            }
            pairs.retain(|&(_, w)| w > 0.0);
            // Largest first; equal weights keep the lower joint, so reductions repeat.
            pairs.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            let dropped: f32 = pairs.iter().skip(max).map(|p| p.1).sum();
            if pairs.len() > max {
                reduction.vertices += 1;
                reduction.max_dropped_weight = reduction.max_dropped_weight.max(dropped);
            }
            pairs.truncate(max);
            let kept: f32 = pairs.iter().map(|p| p.1).sum();
            for slot in 0..max {
                let (j, w) = pairs.get(slot).copied().unwrap_or((0, 0.0));
                joints.push(j);
                weights.push(if kept > 0.0 { w / kept } else { w });
            }
        }
        skin.influences = max;
        skin.joints = joints;
        skin.weights = weights;
        if reduction.vertices > 0 {
            for time in self.clip.key_times() {
                let (a, b) = (before.pose_at(bind, time), self.pose_at(bind, time));
                for (p, q) in a.iter().zip(&b) {
                    let d = Vec3::from(*p).distance(Vec3::from(*q));
                    reduction.max_displacement = reduction.max_displacement.max(d);
                }
            }
        }
        reduction
    }
}

#[cfg(test)]
mod tests;
