//! The layout: `S0` checked (sizes, offsets, indices in range) and taken, with the
//! triangles it draws.

use super::{live_windows, ChangeListError};
use crate::lodstrips::StripLayout;
use crate::strip::Strips;

/// Largest vertex count and strip length the change stream encodes.
const VERTEX_LIMIT: usize = 1 << 31;
const INDEX_LIMIT: usize = 1 << 28;

pub(in crate::lodstrips) fn layout(
    s0: &Strips,
    vertex_count: u32,
) -> Result<StripLayout, ChangeListError> {
    let vertices = vertex_count as usize;
    if vertices > VERTEX_LIMIT {
        return Err(ChangeListError::TooManyVertices {
            vertices,
            limit: VERTEX_LIMIT,
        });
    }
    let total = s0.indices.len();
    if total > INDEX_LIMIT {
        return Err(ChangeListError::TooManyIndices {
            indices: total,
            limit: INDEX_LIMIT,
        });
    }
    match s0.offsets.first() {
        Some(0) => {}
        None if total == 0 => {}
        _ => {
            return Err(ChangeListError::BadOffsets {
                entry: 0,
                indices: total,
            })
        }
    }
    for (entry, w) in s0.offsets.windows(2).enumerate() {
        if w[1] < w[0] {
            return Err(ChangeListError::BadOffsets {
                entry: entry + 1,
                indices: total,
            });
        }
    }
    if let Some(&last) = s0.offsets.last() {
        if last as usize != total {
            return Err(ChangeListError::BadOffsets {
                entry: s0.offsets.len() - 1,
                indices: total,
            });
        }
    }
    if let Some(position) = s0.indices.iter().position(|&v| v as usize >= vertices) {
        return Err(ChangeListError::IndexOutOfRange {
            position,
            index: s0.indices[position],
            vertices,
        });
    }
    let region_offsets = if s0.offsets.is_empty() {
        vec![0]
    } else {
        s0.offsets.clone()
    };
    let triangles_at_0: u32 = region_offsets
        .windows(2)
        .map(|w| live_windows(&s0.indices[w[0] as usize..w[1] as usize]))
        .sum();
    Ok(StripLayout {
        region_offsets: region_offsets.into(),
        s0: s0.indices.clone(),
        vertex_count,
        triangles_at_0,
    })
}
