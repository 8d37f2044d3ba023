//! `KHR_mesh_quantization`: positions and their morph deltas as integers on one grid, normals,
//! normal deltas and UVs as normalized integers, and the quantisation error that leaves.
//!
//! Positions: one uniform grid for the whole morph (every LOD, every target), `p ≈ offset +
//! step · q` with `q` an `UNSIGNED_SHORT` in `0..2^bits`, the grid spanning the bounding box
//! of the base and of every target's pose at weight 1. The dequantising transform (translation
//! `offset`, uniform scale `step`) goes on the LOD nodes, or into the inverse bind matrices of
//! a skinned mesh (whose node transform glTF ignores); uniform, so it leaves normals' directions
//! alone. A target's deltas are the difference of grid points, `q(base + delta) − q(base)`
//! (`SHORT`), so each target's pose at weight 1 is a grid point exactly, and `base + Σ w·delta`
//! is the same weighted sum of grid points a reader computes from the integers.

use super::{ExportError, Lod};
use crate::morph::Morph;

/// Bit counts of the quantized attributes; the defaults are gltfpack's (`-vp 14 -vn 8 -vt 12`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QuantizeOptions {
    /// Bits per position component, 1 to 15 (deltas, differences of two positions, are
    /// `SHORT`s): the grid step is the largest extent of the morph's bounding box over
    /// `2^bits − 1`, the largest error half a step per component.
    pub position_bits: u32,
    /// Bits per normal component, 4 to 16: normals and normal deltas are normalized `BYTE`s
    /// up to 8 bits, `SHORT`s above (with compression, normals in the OCTAHEDRAL filter with
    /// this many bits per octahedral coordinate). A normal delta's components are clamped to
    /// `[-1, 1]`, what the type holds (past it, a normal turns by more than 90°).
    pub normal_bits: u32,
    /// Bits per texture coordinate, 1 to 16, stored as normalized `UNSIGNED_SHORT`s (UVs
    /// outside `[0, 1]` stay `FLOAT`).
    pub uv_bits: u32,
}

impl Default for QuantizeOptions {
    fn default() -> Self {
        QuantizeOptions {
            position_bits: 14,
            normal_bits: 8,
            uv_bits: 12,
        }
    }
}

impl QuantizeOptions {
    pub(super) fn check(&self) -> Result<(), ExportError> {
        let bad = |what: &'static str, bits: u32, range: (u32, u32)| ExportError::Bits {
            what,
            bits,
            min: range.0,
            max: range.1,
        };
        if !(1..=15).contains(&self.position_bits) {
            return Err(bad("position", self.position_bits, (1, 15)));
        }
        if !(4..=16).contains(&self.normal_bits) {
            return Err(bad("normal", self.normal_bits, (4, 16)));
        }
        if !(1..=16).contains(&self.uv_bits) {
            return Err(bad("uv", self.uv_bits, (1, 16)));
        }
        Ok(())
    }
}

/// The positions' grid: a position `p` is stored as `q = round((p − offset) / step)` and read
/// as `offset + step · q` (the LOD nodes' translation and uniform scale).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub offset: [f32; 3],
    pub step: f32,
    /// The largest `q`: `2^bits − 1`.
    pub max: u16,
}

impl Grid {
    /// The grid of `bits` over the bounding box of `morph`'s base and every target's pose at
    /// weight 1 (so every stored position and delta is in range).
    pub(super) fn new(morph: &Morph, bits: u32) -> Grid {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        let mut add = |p: [f32; 3]| {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        };
        for (v, &p) in morph.base().iter().enumerate() {
            add(p);
            for t in morph.targets() {
                add(pose(p, t.deltas[v]));
            }
        }
        let max = ((1u32 << bits) - 1) as u16;
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
        // A flat or single-point morph still gets a usable (unit) step.
        let step = if extent > 0.0 {
            extent / max as f32
        } else {
            1.0
        };
        let offset = if lo[0].is_finite() { lo } else { [0.0; 3] };
        Grid { offset, step, max }
    }

    /// The grid point nearest `p`, clamped to the grid (rounding can put the box's far side
    /// half an ulp past the last point).
    pub fn quantize(&self, p: [f32; 3]) -> [u16; 3] {
        std::array::from_fn(|k| {
            let q = ((p[k] as f64 - self.offset[k] as f64) / self.step as f64).round();
            q.clamp(0.0, self.max as f64) as u16
        })
    }

    /// The position a reader computes from grid coordinates `q` (which sums of deltas may
    /// take past the grid's range), in `f32` as a renderer does: `step · q + offset`.
    pub fn dequantize(&self, q: [i32; 3]) -> [f32; 3] {
        std::array::from_fn(|k| self.step * q[k] as f32 + self.offset[k])
    }

    /// The grid delta of a target at a vertex: `q(base + delta) − q(base)`.
    pub fn delta(&self, base: [f32; 3], delta: [f32; 3]) -> [i16; 3] {
        let (a, b) = (self.quantize(base), self.quantize(pose(base, delta)));
        // Both in 0..2^15, so the difference fits.
        std::array::from_fn(|k| (b[k] as i32 - a[k] as i32) as i16)
    }
}

/// `base + delta`, in `f32` as the morph's pose at weight 1.
fn pose(base: [f32; 3], delta: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|k| base[k] + delta[k])
}

/// A value in `[-1, 1]` as a normalized integer of `bits` bits, scaled to the full range of
/// its component (`BYTE` up to 8 bits, `SHORT` above), so a reader's `c / 127` or `c / 32767`
/// gives the value to `bits` bits.
pub(super) fn snorm(x: f32, bits: u32) -> i16 {
    let levels = ((1i32 << (bits - 1)) - 1) as f32;
    let full = if bits <= 8 { 127.0 } else { 32767.0 };
    let q = (x.clamp(-1.0, 1.0) * levels).round();
    (q * (full / levels)).round() as i16
}

/// A value in `[0, 1]` to `bits` bits, as a normalized `UNSIGNED_SHORT`.
pub(super) fn unorm16(x: f32, bits: u32) -> u16 {
    let levels = ((1u32 << bits) - 1) as f32;
    let q = (x.clamp(0.0, 1.0) * levels).round();
    (q * (65535.0 / levels)).round() as u16
}

/// Per source vertex, the largest distance over `poses` (target weights) between the pose
/// the morph describes (`base + Σ w·delta`, in `f64`) and the one a reader computes from the
/// quantized integers (`offset + step · (q_base + Σ w·q_delta)`). `grid_deltas[k][v]`:
/// target `k`'s grid delta at vertex `v`.
pub(super) fn vertex_errors(
    morph: &Morph,
    grid: &Grid,
    grid_deltas: &[Vec<[i16; 3]>],
    poses: &[Vec<f32>],
) -> Vec<f64> {
    let mut worst = vec![0.0f64; morph.vertex_count()];
    for weights in poses {
        for (v, (&base, worst)) in morph.base().iter().zip(&mut worst).enumerate() {
            let mut exact = base.map(f64::from);
            let mut stored = grid.quantize(base).map(f64::from);
            for ((t, deltas), &w) in morph.targets().iter().zip(grid_deltas).zip(weights) {
                if w == 0.0 {
                    continue;
                }
                for k in 0..3 {
                    exact[k] += w as f64 * t.deltas[v][k] as f64;
                    stored[k] += w as f64 * deltas[v][k] as f64;
                }
            }
            let d2: f64 = (0..3)
                .map(|k| {
                    let read = grid.offset[k] as f64 + grid.step as f64 * stored[k];
                    (read - exact[k]).powi(2)
                })
                .sum();
            *worst = worst.max(d2.sqrt());
        }
    }
    worst
}

/// The largest of `errors` over `lod`'s vertices, relative to `diagonal`.
pub(super) fn lod_error(errors: &[f64], lod: &Lod, diagonal: f32) -> f32 {
    let worst = lod
        .source_vertex
        .iter()
        .map(|&v| errors[v as usize])
        .fold(0.0, f64::max);
    (worst / diagonal as f64) as f32
}

/// The poses the quantisation error is measured over: `samples` weights evenly over the
/// morph's `t ∈ [0, 1]`, the default weights, and each target alone at weight 1.
pub(super) fn error_poses(morph: &Morph, samples: usize, default_weights: &[f32]) -> Vec<Vec<f32>> {
    let n = morph.targets().len();
    let mut poses: Vec<Vec<f32>> = (0..samples.max(2))
        .map(|i| morph.weights_at(i as f32 / (samples.max(2) - 1) as f32))
        .collect();
    poses.push(default_weights.to_vec());
    poses.extend((0..n).map(|k| {
        let mut w = vec![0.0; n];
        w[k] = 1.0;
        w
    }));
    poses
}
