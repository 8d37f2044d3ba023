//! What a collapse sequence means: the definitions of `docs/DESIGN.md` (the oracle) that every
//! test compares against.
//!
//! A sequence is an ordered list of half-edge collapses `u_i → w_i`: `u_i`
//! disappears into the existing vertex `w_i`, no new vertex is made. LOD `l` is
//! the mesh after the first `l` collapses. The survivor of `v` at LOD `l` is `v`
//! itself if `v` has not collapsed yet, else the survivor of the vertex it
//! collapsed into. The reference mesh maps every triangle through the survivors
//! and drops those with a repeated vertex, keeping orientation.

use bytemuck::{Pod, Zeroable};
use thiserror::Error;

/// One half-edge collapse: `u` merges into `w`, at the given quadric `error`
/// (object-space squared distance, as the simplifier measured it; on a mesh with
/// attributes it includes the attribute error, also a squared length).
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Collapse {
    pub u: u32,
    pub w: u32,
    pub error: f32,
}

/// Why a collapse sequence cannot be applied to a mesh.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SequenceError {
    #[error("collapse {step} names vertex {vertex}, but the mesh has {vertices} vertices")]
    VertexOutOfRange {
        step: usize,
        vertex: u32,
        vertices: usize,
    },
    #[error("collapse {step} collapses vertex {vertex} onto itself")]
    SelfCollapse { step: usize, vertex: u32 },
    #[error("collapse {step} uses vertex {vertex}, which already collapsed at step {earlier}")]
    AlreadyCollapsed {
        step: usize,
        vertex: u32,
        earlier: usize,
    },
}

/// An ordered list of half-edge collapses over a mesh of `vertex_count` vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CollapseSequence {
    pub vertex_count: u32,
    pub collapses: Vec<Collapse>,
}

/// Rank of a vertex that never collapses.
pub const NEVER: u32 = u32::MAX;

impl CollapseSequence {
    /// A sequence from `(u, w)` pairs with no recorded error (an order chosen by hand or by
    /// another tool; LOD selection by error then sees 0 everywhere). Check it with
    /// [`validate`](Self::validate) before use.
    pub fn from_pairs(vertex_count: u32, pairs: &[(u32, u32)]) -> CollapseSequence {
        CollapseSequence {
            vertex_count,
            collapses: pairs
                .iter()
                .map(|&(u, w)| Collapse { u, w, error: 0.0 })
                .collect(),
        }
    }

    /// The number of LOD steps: LODs run from 0 (full detail) to `len()`.
    pub fn len(&self) -> usize {
        self.collapses.len()
    }

    pub fn is_empty(&self) -> bool {
        self.collapses.is_empty()
    }

    /// Checks that every collapse names live, distinct vertices in range.
    pub fn validate(&self) -> Result<(), SequenceError> {
        let n = self.vertex_count as usize;
        let mut rank = vec![NEVER; n];
        for (step, c) in self.collapses.iter().enumerate() {
            for vertex in [c.u, c.w] {
                if vertex as usize >= n {
                    return Err(SequenceError::VertexOutOfRange {
                        step,
                        vertex,
                        vertices: n,
                    });
                }
                if rank[vertex as usize] != NEVER {
                    return Err(SequenceError::AlreadyCollapsed {
                        step,
                        vertex,
                        earlier: rank[vertex as usize] as usize,
                    });
                }
            }
            if c.u == c.w {
                return Err(SequenceError::SelfCollapse { step, vertex: c.u });
            }
            rank[c.u as usize] = step as u32;
        }
        Ok(())
    }

    /// `rank[v]` = the step at which `v` collapses, or [`NEVER`].
    pub fn ranks(&self) -> Vec<u32> {
        let mut rank = vec![NEVER; self.vertex_count as usize];
        for (i, c) in self.collapses.iter().enumerate() {
            rank[c.u as usize] = i as u32;
        }
        rank
    }

    /// `anc_l(v)` for every vertex, in O(n + l): walking the first `l`
    /// collapses backwards, the target `w_i` is already resolved because it
    /// outlives step `i`.
    pub fn survivors(&self, lod: usize) -> Vec<u32> {
        let mut anc: Vec<u32> = (0..self.vertex_count).collect();
        for c in self.collapses[..lod.min(self.collapses.len())].iter().rev() {
            anc[c.u as usize] = anc[c.w as usize];
        }
        anc
    }

    /// The reference mesh at LOD `lod`: `triangles` mapped through the
    /// survivors, degenerate ones dropped, orientation and order kept.
    pub fn reference_mesh(&self, triangles: &[[u32; 3]], lod: usize) -> Vec<[u32; 3]> {
        let anc = self.survivors(lod);
        triangles
            .iter()
            .map(|t| t.map(|v| anc[v as usize]))
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect()
    }

    /// The object-space error of each LOD: `errors()[l]` is the largest
    /// collapse error among the first `l` collapses (0 at full detail), so it
    /// never decreases and a maximum-error LOD can be found by binary search.
    pub fn errors(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.collapses.len() + 1);
        let mut worst = 0.0f32;
        out.push(worst);
        for c in &self.collapses {
            worst = worst.max(c.error);
            out.push(worst);
        }
        out
    }
}

/// A triangle with its vertices rotated so the smallest index comes first:
/// the canonical form for comparing oriented triangles as a multiset.
pub fn canonical(t: [u32; 3]) -> [u32; 3] {
    let m = if t[0] <= t[1] && t[0] <= t[2] {
        0
    } else if t[1] <= t[2] {
        1
    } else {
        2
    };
    [t[m], t[(m + 1) % 3], t[(m + 2) % 3]]
}

/// Sorted canonical triangles: two meshes draw the same oriented triangles,
/// as a multiset, exactly when these are equal.
pub fn canonical_multiset(triangles: impl IntoIterator<Item = [u32; 3]>) -> Vec<[u32; 3]> {
    let mut v: Vec<[u32; 3]> = triangles.into_iter().map(canonical).collect();
    v.sort_unstable();
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seq(n: u32, pairs: &[(u32, u32)]) -> CollapseSequence {
        CollapseSequence::from_pairs(n, pairs)
    }

    #[test]
    fn survivors_follow_chains() {
        // 0 → 1, then 1 → 2: at LOD 2, vertex 0 survives as 2.
        let s = seq(4, &[(0, 1), (1, 2)]);
        assert_eq!(s.survivors(0), vec![0, 1, 2, 3]);
        assert_eq!(s.survivors(1), vec![1, 1, 2, 3]);
        assert_eq!(s.survivors(2), vec![2, 2, 2, 3]);
        s.validate().unwrap();
    }

    #[test]
    fn reference_drops_degenerate_and_keeps_orientation() {
        let tris = [[0, 1, 2], [0, 2, 3]];
        let s = seq(4, &[(3, 0)]);
        assert_eq!(s.reference_mesh(&tris, 1), vec![[0, 1, 2]]);
        let s = seq(4, &[(1, 3)]);
        assert_eq!(s.reference_mesh(&tris, 1), vec![[0, 3, 2], [0, 2, 3]]);
    }

    #[test]
    fn validate_rejects_bad_sequences() {
        assert!(matches!(
            seq(3, &[(0, 1), (1, 0)]).validate(),
            Err(SequenceError::AlreadyCollapsed { step: 1, .. })
        ));
        assert!(matches!(
            seq(3, &[(0, 5)]).validate(),
            Err(SequenceError::VertexOutOfRange { .. })
        ));
        assert!(matches!(
            seq(3, &[(2, 2)]).validate(),
            Err(SequenceError::SelfCollapse { .. })
        ));
    }

    #[test]
    fn canonical_rotation() {
        assert_eq!(canonical([5, 2, 9]), [2, 9, 5]);
        assert_eq!(canonical([2, 9, 5]), [2, 9, 5]);
        assert_ne!(canonical([2, 5, 9]), canonical([2, 9, 5]));
    }
}
