//! A clip's joint matrices baked at uniformly spaced keys, for a GPU that skins from them
//! (`docs/DESIGN.md`, "The GPU layout": the clip buffer): the animation-texture approach of
//! Unity's Animation Instancing and the GPU-skinning crowd libraries. The joints' hierarchy
//! and the clip's sampling (slerp, splines, steps) run once here, on the CPU; a vertex then
//! needs only two keys of its joints' matrices and one blend factor.
//!
//! Keys sit at `τ_i = (i / N) · duration`, `i = 0..=N` (`N` [`BakedClip::intervals`]; a loop's
//! last key is its first pose again, so no key index ever wraps). At `t ∈ [0, 1]` the drawn
//! matrices are the linear blend of keys `i = min(⌊t N⌋, N − 1)` and `i + 1` by `t N − i`
//! ([`BakedClip::matrices_at`], the rule `shaders/skin.wgsl` follows). At a key that is the
//! reference's matrix; between keys a linear blend of matrices is not the hierarchy of
//! slerped rotations, and [`BakedClip::max_error`] measures by how much.

use super::{Clip, Skinning};

/// Least keys a second of clip a [`BakedClip`] is baked with ([`BakedClip::intervals_for`]):
/// at 60 keys a second (72 on its 1/24 s grid) the walker's `walk` drifts up to 2.1e-4 of its
/// diagonal between keys; [`BakedClip::intervals_within`] bakes finer where that passes
/// [`BAKE_TOLERANCE`] (the error falls with the square of the keys' spacing).
pub const BAKE_RATE: f32 = 60.0;

/// The most a vertex may drift between keys, as a share of the bind pose's diagonal, that
/// [`BakedClip::intervals_within`] bakes for: the GPU's skinned positions are to equal the
/// reference within 1e-5 of the diagonal at any time (issue 51), and 8e-6 leaves room for
/// the GPU's rounding and for the vertices the estimate does not probe.
pub const BAKE_TOLERANCE: f32 = 8e-6;

/// The most bytes a clip's keys take when [`BakedClip::intervals_within`] bakes them finer
/// than [`BakedClip::intervals_for`]: 1 MiB a clip (issue 51's budget for the clip data a
/// crowd shares). A clip that needs more for the tolerance keeps the finest count that fits.
pub const KEY_BUDGET: u64 = 1 << 20;

/// Vertices the drift between keys is estimated on: every `n / PROBED`-th (enough to find
/// the joints that move most; the GPU tests check every vertex).
const PROBED: usize = 2048;

/// Floats a joint takes per key: the three rows of its 3×4 matrix (`x`, `y`, `z` rows; a
/// joint matrix is affine, and the reference skins with its top three rows only).
pub const ROW_FLOATS: usize = 12;

/// A clip's joint matrices at `intervals + 1` uniformly spaced keys (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct BakedClip {
    /// `N`: keys sit at `τ_i = (i / N) · duration`, `i = 0..=N`.
    pub intervals: usize,
    pub joints: usize,
    /// Key `i`'s joint `j` at `rows[(i · joints + j) · 12 ..][..12]`: its matrix's rows
    /// (`m00 m01 m02 m03`, `m10 ..`, `m20 ..`), each as a `vec4` the GPU reads.
    pub rows: Vec<f32>,
}

impl BakedClip {
    /// The keys a clip is baked at: at least [`BAKE_RATE`] a second (1 for a clip without
    /// length), and a whole multiple of the clip's own key grid where its keys lie on one (a
    /// key every `duration / M` s, as exporters bake animations): then every key of the clip
    /// is a baked key. The walker's `walk` (1 s, keys every 1/24 s): 72.
    pub fn intervals_for(clip: &Clip) -> usize {
        let least = (clip.duration * BAKE_RATE).ceil().max(1.0) as usize;
        match key_grid(clip) {
            Some(m) => m * least.div_ceil(m),
            None => least,
        }
    }

    /// The keys to bake `skinning`'s clip at so that a vertex drifts between keys by at most
    /// `tolerance` of the diagonal of `bind` (the pose the skin applies to; a fraction, e.g.
    /// [`BAKE_TOLERANCE`]), the keys taking at most [`KEY_BUDGET`] bytes: at least
    /// [`intervals_for`](Self::intervals_for) and a multiple of the clip's key grid. The drift
    /// falls with the square of the spacing: from the base count's drift (measured on up to
    /// 2,048 vertices at a quarter, half and three quarters of every interval) the count that
    /// meets the tolerance is estimated, measured again, and refined at most 4 times. The
    /// walker's `walk`: 72 intervals drift 2.1e-4, its 384 drift 7.3e-6 (979 KB of keys).
    pub fn intervals_within(skinning: &Skinning, bind: &[[f32; 3]], tolerance: f32) -> usize {
        let base = Self::intervals_for(&skinning.clip);
        let grid = key_grid(&skinning.clip).unwrap_or(1);
        let joints = skinning.skin.joint_count().max(1);
        // The largest multiple of the grid whose keys fit the budget.
        let most = (KEY_BUDGET / (4 * ROW_FLOATS as u64 * joints as u64)).saturating_sub(1);
        let most = (most as usize / grid) * grid;
        let diagonal = crate::mesh::bounds(bind)
            .map(|(lo, hi)| glam::Vec3::from(hi).distance(glam::Vec3::from(lo)))
            .filter(|d| d.is_finite() && *d > 0.0);
        // Nothing to refine: a bind pose without size, no tolerance, or base keys already
        // past the budget (a long clip; the caller checks them against its buffer limits
        // before anything is baked).
        let (Some(diagonal), true) = (diagonal, tolerance > 0.0 && base < most) else {
            return base;
        };
        // probeVertices: every k-th vertex, with its weights.
        let every = bind.len().div_ceil(PROBED).max(1);
        let picked: Vec<u32> = (0..bind.len() as u32).step_by(every).collect();
        let probe = Skinning {
            skin: skinning.skin.select(&picked),
            clip: skinning.clip.clone(),
        };
        let probe_bind: Vec<[f32; 3]> = picked.iter().map(|&v| bind[v as usize]).collect();
        // refineKeys: measure, estimate the count the tolerance needs, measure again.
        let mut n = base;
        for _ in 0..4 {
            let drift = Self::bake(&probe, n).max_error(&probe, &probe_bind, 4 * n + 1) / diagonal;
            if drift.is_nan() || drift <= tolerance {
                break;
            }
            let wanted = (n as f32 * (drift / tolerance).sqrt() * 1.05).ceil() as usize;
            let next = (grid * wanted.div_ceil(grid)).min(most);
            if next <= n {
                break;
            }
            n = next;
        }
        n
    }

    /// Floats the keys of `intervals` intervals take for `joints` joints (computed before
    /// anything is baked, to check against a buffer limit).
    pub fn floats(intervals: usize, joints: usize) -> u64 {
        (intervals as u64 + 1) * joints as u64 * ROW_FLOATS as u64
    }

    /// The joint matrices of `skinning` at `intervals + 1` keys (`intervals` at least 1).
    pub fn bake(skinning: &Skinning, intervals: usize) -> BakedClip {
        let intervals = intervals.max(1);
        let joints = skinning.skin.joint_count();
        // The times the reference poses `t_i = i / N` at (`Asset::pose_at`: t · duration).
        let times: Vec<f32> = (0..=intervals)
            .map(|i| i as f32 / intervals as f32 * skinning.clip.duration)
            .collect();
        // Column-major matrices to 3×4 rows: row r is m[r], m[4 + r], m[8 + r], m[12 + r].
        let rows = (skinning.bake(&times).chunks_exact(16))
            .flat_map(|m| (0..3).flat_map(move |r| [m[r], m[4 + r], m[8 + r], m[12 + r]]))
            .collect();
        BakedClip {
            intervals,
            joints,
            rows,
        }
    }

    /// The keys blended at `t` (clamped to `[0, 1]`): the earlier key and the weight of the
    /// later one.
    pub fn keys_at(&self, t: f32) -> (usize, f32) {
        let f = t.clamp(0.0, 1.0) * self.intervals as f32;
        let key = (f as usize).min(self.intervals - 1);
        (key, f - key as f32)
    }

    /// The joint matrices drawn at `t` (16 floats a joint, column-major, as
    /// [`Skinning::joint_matrices`] gives them): the linear blend of the two keys around it.
    pub fn matrices_at(&self, t: f32, out: &mut Vec<f32>) {
        let (key, s) = self.keys_at(t);
        let size = self.joints * ROW_FLOATS;
        let (a, b) = (
            &self.rows[key * size..][..size],
            &self.rows[(key + 1) * size..][..size],
        );
        out.clear();
        for (a, b) in a.chunks_exact(ROW_FLOATS).zip(b.chunks_exact(ROW_FLOATS)) {
            let row = |r: usize, c: usize| a[4 * r + c] + s * (b[4 * r + c] - a[4 * r + c]);
            for c in 0..4 {
                out.extend([
                    row(0, c),
                    row(1, c),
                    row(2, c),
                    if c == 3 { 1.0 } else { 0.0 },
                ]);
            }
        }
    }

    /// The largest distance, over `samples` uniformly spaced `t` in `[0, 1]` (at least 2),
    /// between `bind` skinned with the blended keys and with the reference
    /// ([`Skinning::pose_at`]): the error baking adds. Morph offsets are left out (a
    /// morphed pose moves with the same matrices).
    pub fn max_error(&self, skinning: &Skinning, bind: &[[f32; 3]], samples: usize) -> f32 {
        let samples = samples.max(2);
        let (mut matrices, mut drawn) = (Vec::new(), Vec::new());
        let mut worst = 0.0f32;
        for k in 0..samples {
            let t = k as f32 / (samples - 1) as f32;
            self.matrices_at(t, &mut matrices);
            skinning.skin.deform(&matrices, bind, &mut drawn);
            let exact = skinning.pose_at(bind, t * skinning.clip.duration);
            for (p, q) in drawn.iter().zip(&exact) {
                let d = glam::Vec3::from(*p).distance(glam::Vec3::from(*q));
                worst = worst.max(d);
            }
        }
        worst
    }
}

/// `M` where every key of `clip` lies on the grid `k · duration / M` (within a thousandth of
/// a step), `M` the number of steps between its first and last key times; `None` otherwise
/// (or for a clip of fewer than two key times).
fn key_grid(clip: &Clip) -> Option<usize> {
    let times = clip.key_times();
    let steps = times.len().checked_sub(1).filter(|&m| m > 0)?;
    let step = clip.duration / steps as f32;
    let on_grid = times
        .iter()
        .enumerate()
        .all(|(k, &t)| (t - k as f32 * step).abs() <= 1e-3 * step);
    on_grid.then_some(steps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::morph::Interpolation;
    use crate::skin::{JointChannel, NodeProperty, NodeTrack, Skeleton, Skin};

    /// One joint turning a quarter turn about z over 1 s (LINEAR, keys every 0.25 s), a
    /// vertex at x = 1 bound to it.
    fn turning() -> Skinning {
        // Half the angle of a quarter turn: the quaternion's.
        let half = std::f32::consts::FRAC_PI_4;
        let values = (0..5)
            .flat_map(|k| {
                let a = half * k as f32 / 4.0;
                [0.0, 0.0, a.sin(), a.cos()]
            })
            .collect();
        Skinning {
            skin: Skin {
                skeleton: Skeleton {
                    parents: vec![crate::skin::NO_PARENT],
                    rest: vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0],
                    names: vec!["j".into()],
                },
                joint_nodes: vec![0],
                inverse_binds: glam::Mat4::IDENTITY.to_cols_array().to_vec(),
                influences: 1,
                joints: vec![0],
                weights: vec![1.0],
            },
            clip: Clip {
                name: "turn".into(),
                duration: 1.0,
                looping: false,
                channels: vec![JointChannel {
                    node: 0,
                    track: NodeTrack {
                        property: NodeProperty::Rotation,
                        interpolation: Interpolation::Linear,
                        times: vec![0.0, 0.25, 0.5, 0.75, 1.0],
                        values,
                    },
                }],
            },
        }
    }

    /// The density follows the clip's key grid; baked keys are the reference's matrices; the
    /// blend between keys cuts the arc's chord (error ≈ 1 − cos(Δθ / 2) at x = 1), smaller
    /// with denser keys; a step past the end clamps.
    #[test]
    fn baked_keys_are_the_reference_and_blends_cut_the_chord() {
        let skinning = turning();
        assert_eq!(BakedClip::intervals_for(&skinning.clip), 60);
        let mut off_grid = skinning.clip.clone();
        off_grid.channels[0].track.times[1] = 0.3;
        assert_eq!(BakedClip::intervals_for(&off_grid), 60);
        let mut slow = skinning.clip.clone();
        slow.duration = 1.01;
        assert_eq!(BakedClip::intervals_for(&slow), 61);

        let coarse = BakedClip::bake(&skinning, 4);
        assert_eq!(coarse.rows.len() as u64, BakedClip::floats(4, 1));
        let (mut baked, mut exact) = (Vec::new(), Vec::new());
        for i in 0..=4 {
            let t = i as f32 / 4.0;
            coarse.matrices_at(t, &mut baked);
            skinning.joint_matrices(t, &mut exact);
            for (a, b) in baked.iter().zip(&exact) {
                assert!((a - b).abs() <= 1e-6, "key {i}: {baked:?} != {exact:?}");
            }
        }
        assert_eq!(coarse.keys_at(2.0), (3, 1.0));
        let bind = [[1.0, 0.0, 0.0]];
        // 4 keys over a quarter turn: π/8 between keys.
        let step = std::f32::consts::FRAC_PI_8;
        let chord = 1.0 - (step / 2.0).cos();
        let error = coarse.max_error(&skinning, &bind, 201);
        assert!((error - chord).abs() <= 0.05 * chord, "{error} vs {chord}");
        let dense = BakedClip::bake(&skinning, 60).max_error(&skinning, &bind, 201);
        assert!(dense < error / 100.0, "60 keys: {dense}, 4 keys: {error}");
    }
}
