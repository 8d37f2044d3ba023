//! Stage 4 as [`Supermesh::build`](super::Supermesh::build) runs it: the alignment refined
//! for `D` ([`refine_alignment`], over [`align::refine`] and the embedding's relaxation).

use glam::{DMat3, DVec3};

use super::alignment::{free_vertices, Tables};
use super::{align, embed};
use crate::mesh::IndexedMesh;

/// Rounds of [`refine_alignment`] (man stood up → camel with the shipped
/// landmarks: 0 / 5 / 20 rounds give s(½) 0.891 / 0.897 / 0.906).
const REFINE_ROUNDS: usize = 20;

/// Stage 4: the alignment refined for D. The rotation (or the landmarks'
/// Möbius map) lines up the shapes as a whole, not their parts: in each of
/// [`REFINE_ROUNDS`] rounds every vertex of B, then of A, slides on its
/// sphere toward the other shape's point that matches it better (lowering
/// its term of D, [`align::refine`]), by fold-rejecting moves with the
/// landmarks pinned, then one relaxation sweep of each embedding keeps it
/// even (without them the map's angle distortion p95 went from 65 to 1271
/// on man stood up → camel with the shipped landmarks).
///
/// `turn` takes A's normalised shape into B's frame (the identity unless B
/// is placed differently, see [`align_b`](super::alignment::align_b)).
pub(super) fn refine_alignment(
    (a, ta, a_sphere): (&IndexedMesh, &Tables, &mut [DVec3]),
    (b, tb, b_sphere): (&IndexedMesh, &Tables, &mut [DVec3]),
    landmarks: &[(u32, u32)],
    turn: DMat3,
) {
    let (rings_a, rings_b) = (&ta.rings, &tb.rings);
    let (mass_a, mass_b) = (&ta.mass, &tb.mass);
    let qa: Vec<DVec3> = ta.normalised.iter().map(|&q| turn * q).collect();
    let qb = &tb.normalised;
    let (free_a, free_b) = free_vertices(a_sphere.len(), b_sphere.len(), landmarks);
    let pinned = |n: usize, free: &[u32]| {
        let mut out = vec![true; n];
        for &v in free {
            out[v as usize] = false;
        }
        out
    };
    let (pinned_a, pinned_b) = (
        pinned(a_sphere.len(), &free_a),
        pinned(b_sphere.len(), &free_b),
    );
    let (mut hints_a, mut hints_b) = (
        vec![u32::MAX; a_sphere.len()],
        vec![u32::MAX; b_sphere.len()],
    );
    for _ in 0..REFINE_ROUNDS {
        let surface_a = align::Surface::new(a_sphere, &a.triangles, &qa);
        align::refine(b_sphere, rings_b, qb, &surface_a, &pinned_b, &mut hints_b);
        let surface_b = align::Surface::new(b_sphere, &b.triangles, qb);
        align::refine(a_sphere, rings_a, &qa, &surface_b, &pinned_a, &mut hints_a);
        embed::relax(mass_a, rings_a, a_sphere, &free_a, 1);
        embed::relax(mass_b, rings_b, b_sphere, &free_b, 1);
    }
}
