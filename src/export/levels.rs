//! The levels: the step of the shared sequence each LOD stops at (a triangle fraction or an
//! error bound, moved to a step boundary), and each LOD's mesh in vertex-cache order.

use super::{ExportError, Lod};
use crate::collapse::CollapseSequence;
use crate::io::gltf::write::bounds;
use crate::seams::{step_for_fraction, StepBoundaries};

/// The length of the diagonal of `positions`' bounding box; 1 when that is 0 (one point, or
/// none), so relative and absolute errors agree on a degenerate mesh.
pub(super) fn diagonal(positions: &[[f32; 3]]) -> f32 {
    let (lo, hi) = bounds(positions);
    let d = (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f32>().sqrt();
    if d > 0.0 && d.is_finite() {
        d
    } else {
        1.0
    }
}

/// The first step boundary whose reference mesh has at most `fraction` of the triangles
/// ([`step_for_fraction`]); a LOD with no triangle left is refused.
pub(super) fn step_for(
    sequence: &CollapseSequence,
    boundaries: &StepBoundaries,
    triangles: &[[u32; 3]],
    fraction: f32,
) -> Result<usize, ExportError> {
    let step = step_for_fraction(sequence, boundaries, triangles, fraction);
    if sequence.reference_mesh(triangles, step).is_empty() {
        return Err(ExportError::Empty {
            fraction,
            triangles: triangles.len(),
        });
    }
    Ok(step)
}

/// The LOD of `mesh` (over source vertices): indices in vertex-cache order, then only the
/// vertices used, numbered by first use.
pub(super) fn compact(mesh: Vec<[u32; 3]>, fraction: f32, step: usize, error: f32) -> Lod {
    let flat: Vec<u32> = mesh.into_iter().flatten().collect();
    let vertex_bound = flat.iter().max().map_or(0, |&v| v as usize + 1);
    let ordered = meshopt::optimize_vertex_cache(&flat, vertex_bound);
    let mut new_of = vec![u32::MAX; vertex_bound];
    let mut source_vertex = Vec::new();
    let reindexed: Vec<u32> = ordered
        .iter()
        .map(|&v| {
            let slot = &mut new_of[v as usize];
            if *slot == u32::MAX {
                *slot = source_vertex.len() as u32;
                source_vertex.push(v);
            }
            *slot
        })
        .collect();
    Lod {
        fraction,
        error,
        step,
        source_vertex,
        triangles: reindexed
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        bytes: 0,
        quantization_error: 0.0,
    }
}
