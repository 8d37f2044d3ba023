//! Stages 2 and 3 of the embedding: the tetrahedron placed on the sphere
//! ([`place_tetrahedron`]), then every collapse undone, each split vertex placed in its
//! kernel and relaxed, with global sweeps each time the vertex count has doubled
//! ([`split_all`]).

use glam::DVec3;

use super::super::sphere::orient;
use super::collapse::{split, Hierarchy};
use super::kernel::kernel_point;
use super::relax::relax;
use super::{EmbedError, LEVEL_BUDGET, LEVEL_SWEEPS, LOCAL_SWEEPS, MAX_LEVEL_SWEEPS};

/// The four remaining vertices at the corners of a regular tetrahedron,
/// mirrored if needed so that its triangles are positively oriented.
pub(crate) fn place_tetrahedron(rings: &[Vec<u32>], _hierarchy: &Hierarchy, points: &mut [DVec3]) {
    let corners = [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(-1.0, -1.0, 1.0),
    ];
    let live: Vec<u32> = (0..rings.len() as u32)
        .filter(|&v| !rings[v as usize].is_empty())
        .collect();
    for (&v, c) in live.iter().zip(corners) {
        points[v as usize] = c.normalize();
    }
    if let Some(&v) = live.first() {
        let r = &rings[v as usize];
        let o = orient(
            points[v as usize],
            points[r[0] as usize],
            points[r[1] as usize],
        );
        if o < 0.0 {
            points.swap(live[0] as usize, live[1] as usize);
        }
    }
}

/// Undoes every collapse, placing each split vertex in its kernel and relaxing.
pub(super) fn split_all(
    mass: &mut [f64],
    rings: &mut [Vec<u32>],
    hierarchy: &Hierarchy,
    points: &mut [DVec3],
    progress: &mut dyn FnMut(f32),
) -> Result<(), EmbedError> {
    let total = hierarchy.records.len();
    let mut live: Vec<u32> = (0..rings.len() as u32)
        .filter(|&v| !rings[v as usize].is_empty())
        .collect();
    let mut next_level = 8;
    let mut neighbourhood = Vec::new();
    for k in (0..total).rev() {
        let (u, ring) = hierarchy.ring(k);
        split(rings, u, ring);
        mass[ring[0] as usize] -= mass[u as usize];
        points[u as usize] = kernel_point(points, u, ring)?;
        live.push(u);
        neighbourhood.clear();
        neighbourhood.push(u);
        neighbourhood.extend_from_slice(ring);
        relax(mass, rings, points, &neighbourhood, LOCAL_SWEEPS);
        if live.len() >= next_level {
            let sweeps = (LEVEL_BUDGET / live.len()).clamp(LEVEL_SWEEPS, MAX_LEVEL_SWEEPS);
            relax(mass, rings, points, &live, sweeps);
            next_level *= 2;
        }
        if k.is_multiple_of(4096) {
            progress(0.25 + 0.65 * (total - k) as f32 / total.max(1) as f32);
        }
    }
    Ok(())
}
