//! The checks every GPU-side constructor and edit shares: a buffer's size against the device's
//! limit, and the indices of a region against the vertex count. A file of its own, below
//! `object`, `pose`, `surface` and `asset`, so none of them imports another for a helper.

use super::{GpuError, RESTART};
use crate::lodstrips::StripIndex;

/// [`GpuError::BufferTooLarge`] when `bytes` exceed `max`.
pub(super) fn check_size(what: &'static str, bytes: u64, max: u64) -> Result<(), GpuError> {
    if bytes > max {
        return Err(GpuError::BufferTooLarge { what, bytes, max });
    }
    Ok(())
}

/// Every index of `indices` (region `region`) names one of `vertices` vertices, or is
/// [`RESTART`] where `restart_allowed` (strip topology): [`GpuError::IndexOutOfRange`] at the
/// first that does not.
pub(super) fn check_indices<I: StripIndex>(
    region: usize,
    indices: &[I],
    vertices: u32,
    restart_allowed: bool,
) -> Result<(), GpuError> {
    let bad = indices.iter().position(|&i| {
        let i: u32 = i.into();
        i >= vertices && !(restart_allowed && i == RESTART)
    });
    match bad {
        Some(position) => Err(GpuError::IndexOutOfRange {
            region,
            position,
            index: indices[position].into(),
            vertices,
            restart_allowed,
        }),
        None => Ok(()),
    }
}
