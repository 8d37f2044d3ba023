//! Seams: how a collapse of the welded surface moves the attribute vertices on it.
//!
//! The simplifier works on topology vertices ([`TopologyMap`]); the index buffer addresses
//! attribute vertices, split where a UV (or normal) is discontinuous. A topology collapse
//! `u → w` moves every attribute vertex `a` of `u` onto the attribute vertex `b` of `w` on
//! the same side of each seam. [`SeamRule::map_collapse`] decides whether that is possible
//! and which `b` each `a` gets; the simplifier asks it before every collapse
//! ([`crate::simplify::simplify_with_seams`]) and [`expand`] asks it again to turn the
//! topology sequence into the attribute-level [`CollapseSequence`] the runtime plays, so the
//! rule exists once.
//!
//! # The rule (over the live triangles around `u`)
//!
//! * every triangle around `u` has three distinct topology vertices;
//! * for every attribute vertex `a` of `u`, the triangles with corner `a` that also hold `w`
//!   show one single attribute vertex `b` of `w`, and there is at least one such triangle;
//! * an attribute vertex of `u` that is in no live triangle (its wedge was collapsed away,
//!   or it never had one) follows the smallest attribute vertex of `u` that is: it draws
//!   nothing, but moves with its siblings so no LOD separates copies of one position;
//! * with UVs: no surviving triangle around `u` changes the sign of its UV-space area or
//!   gets area zero (one that already had zero area may do anything).
//!
//! Interior vertices pass (one attribute vertex, every edge shows the same `b`); a seam
//! vertex passes only along its seam, where both sides show `w`'s matching copies; a seam
//! junction or corner never finds a `w` that matches every copy. So no collapse tears a
//! seam, and every copy of a position moves in the same step.
//!
//! # Steps and boundaries
//!
//! A topology collapse `u → w` becomes, consecutively, `a_i → b_i` for every attribute
//! vertex `a_i` of `u` (ascending), all with the topology collapse's error. Only the LODs
//! between two such groups are shown: LOD `l` of an attribute sequence is a *step boundary*
//! iff `l == 0`, `l == len` or `topology[u_{l−1}] != topology[u_l]` ([`StepBoundaries`]).

use crate::collapse::{Collapse, CollapseSequence, SequenceError};
use crate::mesh::adjacency::NONE;
use crate::morph::TopologyMap;
use thiserror::Error;

/// Why [`SeamRule::map_collapse`] refuses a topology collapse.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// A triangle around `u` repeats a topology vertex (zero area, welded copies in one
    /// triangle): its corners stay put.
    Degenerate,
    /// Some attribute vertex of `u` has no single matching copy of `w`: the seam would tear.
    Tear,
    /// A surviving triangle's UV orientation would flip or vanish.
    UvFold,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Refusal::Degenerate => "a triangle around it repeats a topology vertex",
            Refusal::Tear => "it would tear a seam (no single matching copy of the target)",
            Refusal::UvFold => "it would flip or collapse a triangle in UV space",
        })
    }
}

/// Why an attribute-level sequence or a topology sequence does not fit a mesh's seams.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SeamError {
    #[error("the topology map has {found} vertices but the sequence is for {expected}")]
    VertexCount { expected: usize, found: usize },
    #[error(
        "a topology vertex index {vertex} is past the map's {topology_count} topology vertices"
    )]
    TopologyIndex { vertex: u32, topology_count: usize },
    #[error("the topology sequence is invalid: {0}")]
    Sequence(SequenceError),
    #[error("triangle {triangle} names vertex {vertex}, past the {vertices} vertices")]
    TriangleIndex {
        triangle: usize,
        vertex: u32,
        vertices: usize,
    },
    #[error("topology collapse {step} ({u} -> {w}) is refused: {refusal}")]
    Refused {
        step: usize,
        u: u32,
        w: u32,
        refusal: Refusal,
    },
    #[error("collapse {step} ({u} -> {w}) joins two copies of one topology vertex: collapses must move a topology vertex onto another")]
    WithinTopologyVertex { step: usize, u: u32, w: u32 },
    #[error("collapse {step} ({u} -> {w}) moves topology vertex {topology_u} onto {topology_w}, but its step (from collapse {start}) moves it onto {group_w}")]
    SplitTarget {
        step: usize,
        u: u32,
        w: u32,
        start: usize,
        topology_u: u32,
        topology_w: u32,
        group_w: u32,
    },
    #[error("the step from collapse {start} moves {moved} of topology vertex {topology}'s {copies} copies: every copy must move in one step, or a crack opens")]
    IncompleteStep {
        start: usize,
        topology: u32,
        moved: usize,
        copies: usize,
    },
}

/// The attribute vertices of every topology vertex, ascending, in one flat array.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Wedges {
    start: Vec<u32>,
    vertices: Vec<u32>,
}

impl Wedges {
    /// Groups `of_vertex` into topology vertices `0..=max` of its entries (a number no
    /// vertex names gets no copies; [`TopologyMap`] numbers densely).
    pub fn new(of_vertex: &[u32]) -> Wedges {
        let topology_count = of_vertex.iter().max().map_or(0, |&t| t as usize + 1);
        let mut start = vec![0u32; topology_count + 1];
        for &t in of_vertex {
            start[t as usize + 1] += 1;
        }
        for i in 0..topology_count {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut vertices = vec![0u32; of_vertex.len()];
        for (v, &t) in of_vertex.iter().enumerate() {
            vertices[fill[t as usize] as usize] = v as u32;
            fill[t as usize] += 1;
        }
        Wedges { start, vertices }
    }

    /// The attribute vertices of topology vertex `t`, ascending.
    pub fn of(&self, t: u32) -> &[u32] {
        &self.vertices[self.start[t as usize] as usize..self.start[t as usize + 1] as usize]
    }

    pub fn topology_count(&self) -> usize {
        self.start.len() - 1
    }
}

/// The seam rule of the module docs over one mesh's attribute vertices.
#[derive(Clone, Debug)]
pub struct SeamRule<'a> {
    of_vertex: &'a [u32],
    wedges: Wedges,
    uvs: Option<&'a [[f32; 2]]>,
    normals: Option<&'a [[f32; 3]]>,
}

impl<'a> SeamRule<'a> {
    /// The rule for attribute vertices welded by `topology`, with their UVs if any (one per
    /// attribute vertex).
    pub fn new(topology: &'a TopologyMap, uvs: Option<&'a [[f32; 2]]>) -> SeamRule<'a> {
        SeamRule {
            of_vertex: &topology.of_vertex,
            wedges: Wedges::new(&topology.of_vertex),
            uvs,
            normals: None,
        }
    }

    /// The same rule, with the attribute vertices' normals (one per attribute vertex) for the
    /// simplifier's attribute error ([`crate::simplify::SimplifyOptions::normal_weight`]).
    /// The rule itself never reads them: normal splits are already seams of the map.
    pub fn with_normals(mut self, normals: Option<&'a [[f32; 3]]>) -> SeamRule<'a> {
        self.normals = normals;
        self
    }

    /// The UVs the rule was made with.
    pub fn uvs(&self) -> Option<&'a [[f32; 2]]> {
        self.uvs
    }

    /// The normals given by [`with_normals`](Self::with_normals).
    pub fn normals(&self) -> Option<&'a [[f32; 3]]> {
        self.normals
    }

    /// The topology vertex of attribute vertex `a`.
    pub fn topology_of(&self, a: u32) -> u32 {
        self.of_vertex[a as usize]
    }

    pub fn vertex_count(&self) -> usize {
        self.of_vertex.len()
    }

    pub fn topology_count(&self) -> usize {
        self.wedges.topology_count()
    }

    /// Decides the topology collapse `u → w` given the live attribute triangles around `u`
    /// (each holding an attribute vertex of `u`); on success `pairs` holds `(a, b)` for every
    /// attribute vertex `a` of `u`, ascending in `a`.
    pub fn map_collapse(
        &self,
        u: u32,
        w: u32,
        around: impl Iterator<Item = [u32; 3]> + Clone,
        pairs: &mut Vec<(u32, u32)>,
    ) -> Result<(), Refusal> {
        pairs.clear();
        for tri in around.clone() {
            let topo = tri.map(|a| self.of_vertex[a as usize]);
            if topo[0] == topo[1] || topo[1] == topo[2] || topo[0] == topo[2] {
                return Err(Refusal::Degenerate);
            }
            let Some(cu) = topo.iter().position(|&t| t == u) else {
                continue;
            };
            let b = topo.iter().position(|&t| t == w).map_or(NONE, |cw| tri[cw]);
            let a = tri[cu];
            match pairs.iter_mut().find(|(x, _)| *x == a) {
                None => pairs.push((a, b)),
                Some((_, old)) if *old == NONE => *old = b,
                Some((_, old)) if b != NONE && *old != b => return Err(Refusal::Tear),
                Some(_) => {}
            }
        }
        if pairs.is_empty() || pairs.iter().any(|&(_, b)| b == NONE) {
            return Err(Refusal::Tear);
        }
        pairs.sort_unstable();
        let (live, follow) = (pairs.len(), pairs[0].1);
        for &a in self.wedges.of(u) {
            if pairs[..live].binary_search_by_key(&a, |&(x, _)| x).is_err() {
                pairs.push((a, follow));
            }
        }
        pairs.sort_unstable();
        if let Some(uvs) = self.uvs {
            let moved = |a: u32| match pairs.binary_search_by_key(&a, |&(x, _)| x) {
                Ok(i) => pairs[i].1,
                Err(_) => a,
            };
            for tri in around {
                if tri.iter().any(|&a| self.of_vertex[a as usize] == w) {
                    continue;
                }
                let before = uv_area(uvs, tri);
                let after = uv_area(uvs, tri.map(moved));
                if before != 0.0 && (after == 0.0 || (after > 0.0) != (before > 0.0)) {
                    return Err(Refusal::UvFold);
                }
            }
        }
        Ok(())
    }
}

/// Twice the signed UV-space area of a triangle.
fn uv_area(uvs: &[[f32; 2]], t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|v| uvs[v as usize].map(f64::from));
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// The attribute-level sequence of a topology sequence (module docs, "Steps and
/// boundaries"), replaying it over the attribute `triangles` and asking the rule at every
/// step; a collapse the rule refuses is an error.
pub fn expand(
    topology: &CollapseSequence,
    triangles: &[[u32; 3]],
    rule: &SeamRule,
) -> Result<CollapseSequence, SeamError> {
    let n = rule.vertex_count();
    let tn = rule.topology_count();
    if topology.vertex_count as usize != tn {
        return Err(SeamError::VertexCount {
            expected: topology.vertex_count as usize,
            found: tn,
        });
    }
    topology.validate().map_err(SeamError::Sequence)?;
    // The live attribute triangles around each topology vertex (once per distinct corner).
    let mut corners: Vec<[u32; 3]> = triangles.to_vec();
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); tn];
    for (t, tri) in triangles.iter().enumerate() {
        if let Some(&vertex) = tri.iter().find(|&&a| a as usize >= n) {
            return Err(SeamError::TriangleIndex {
                triangle: t,
                vertex,
                vertices: n,
            });
        }
        let topo = tri.map(|a| rule.topology_of(a));
        for (i, &x) in topo.iter().enumerate() {
            if !topo[..i].contains(&x) {
                around[x as usize].push(t as u32);
            }
        }
    }
    let mut out = Vec::with_capacity(n);
    let mut pairs = Vec::new();
    for (step, c) in topology.collapses.iter().enumerate() {
        let (u, w) = (c.u, c.w);
        let fan = std::mem::take(&mut around[u as usize]);
        rule.map_collapse(u, w, fan.iter().map(|&t| corners[t as usize]), &mut pairs)
            .map_err(|refusal| SeamError::Refused {
                step,
                u,
                w,
                refusal,
            })?;
        out.extend(pairs.iter().map(|&(a, b)| Collapse {
            u: a,
            w: b,
            error: c.error,
        }));
        for &t in &fan {
            let tri = corners[t as usize];
            if tri.iter().any(|&a| rule.topology_of(a) == w) {
                // On edge uw: dies. Its other corners forget it.
                for a in tri {
                    let x = rule.topology_of(a) as usize;
                    if x != u as usize {
                        around[x].retain(|&s| s != t);
                    }
                }
            } else {
                let moved = tri.map(|a| match pairs.binary_search_by_key(&a, |&(x, _)| x) {
                    Ok(i) => pairs[i].1,
                    Err(_) => a,
                });
                corners[t as usize] = moved;
                around[w as usize].push(t);
            }
        }
    }
    Ok(CollapseSequence {
        vertex_count: n as u32,
        collapses: out,
    })
}

/// Checks that an attribute-level sequence (valid on its own, see
/// [`CollapseSequence::validate`]) moves whole topology vertices: every maximal run of
/// consecutive collapses whose `u` share a topology vertex moves all of that vertex's
/// copies, onto copies of one other topology vertex. What a loader checks of every frame
/// of an asset with a surface. `wedges` must be `Wedges::new(of_vertex)`.
pub fn check_steps(
    seq: &CollapseSequence,
    wedges: &Wedges,
    of_vertex: &[u32],
) -> Result<(), SeamError> {
    if seq.vertex_count as usize != of_vertex.len() {
        return Err(SeamError::VertexCount {
            expected: seq.vertex_count as usize,
            found: of_vertex.len(),
        });
    }
    let topo = |v: u32| of_vertex[v as usize];
    let mut start = 0;
    while start < seq.collapses.len() {
        let first = seq.collapses[start];
        let (tu, tw) = (topo(first.u), topo(first.w));
        let mut end = start;
        while end < seq.collapses.len() && topo(seq.collapses[end].u) == tu {
            let c = seq.collapses[end];
            if topo(c.w) == tu {
                return Err(SeamError::WithinTopologyVertex {
                    step: end,
                    u: c.u,
                    w: c.w,
                });
            }
            if topo(c.w) != tw {
                return Err(SeamError::SplitTarget {
                    step: end,
                    u: c.u,
                    w: c.w,
                    start,
                    topology_u: tu,
                    topology_w: topo(c.w),
                    group_w: tw,
                });
            }
            end += 1;
        }
        let copies = wedges.of(tu).len();
        if end - start != copies {
            return Err(SeamError::IncompleteStep {
                start,
                topology: tu,
                moved: end - start,
                copies,
            });
        }
        start = end;
    }
    Ok(())
}

/// The step boundaries of one attribute-level sequence (module docs), as a bitset over
/// LODs `0..=len`: the LODs the runtime may show.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StepBoundaries {
    bits: Vec<u64>,
    len: usize,
}

impl StepBoundaries {
    /// The boundaries of `seq` under `of_vertex` (one topology vertex per attribute vertex
    /// of `seq`; indices are trusted to be in range, see [`CollapseSequence::validate`]).
    pub fn new(seq: &CollapseSequence, of_vertex: &[u32]) -> StepBoundaries {
        let len = seq.collapses.len();
        let mut bits = vec![0u64; len / 64 + 1];
        let mut set = |l: usize| bits[l / 64] |= 1 << (l % 64);
        set(0);
        set(len);
        for (l, pair) in seq.collapses.windows(2).enumerate() {
            if of_vertex[pair[0].u as usize] != of_vertex[pair[1].u as usize] {
                set(l + 1);
            }
        }
        StepBoundaries { bits, len }
    }

    pub fn is_boundary(&self, l: usize) -> bool {
        l <= self.len && self.bits[l / 64] >> (l % 64) & 1 == 1
    }

    /// The largest boundary at or below `l` (`l` clamped to the length).
    pub fn floor(&self, l: usize) -> usize {
        let l = l.min(self.len);
        let mut word = l / 64;
        let mut bits = self.bits[word] & (u64::MAX >> (63 - l % 64));
        while bits == 0 {
            // LOD 0 is a boundary, so some word below holds one.
            word -= 1;
            bits = self.bits[word];
        }
        word * 64 + 63 - bits.leading_zeros() as usize
    }

    /// The smallest boundary at or above `l` (`l` clamped to the length).
    pub fn ceil(&self, l: usize) -> usize {
        let l = l.min(self.len);
        let mut word = l / 64;
        let mut bits = self.bits[word] & (u64::MAX << (l % 64));
        while bits == 0 {
            // LOD `len` is a boundary, so some word above holds one.
            word += 1;
            bits = self.bits[word];
        }
        word * 64 + bits.trailing_zeros() as usize
    }

    /// Bytes held.
    pub fn byte_size(&self) -> usize {
        self.bits.len() * 8
    }
}

/// The first step boundary whose reference mesh has at most `fraction` of `triangles`: the
/// fewest collapses that reach `floor(fraction · triangles)` (binary search, the count never
/// grows with the step), moved up to a boundary so no seam is torn. How `morphlod export`
/// chooses its LODs, and the crowd bench its discrete levels.
pub fn step_for_fraction(
    sequence: &CollapseSequence,
    boundaries: &StepBoundaries,
    triangles: &[[u32; 3]],
    fraction: f32,
) -> usize {
    let goal = (fraction as f64 * triangles.len() as f64).floor() as usize;
    let count = |l: usize| sequence.reference_mesh(triangles, l).len();
    let (mut lo, mut hi) = (0, sequence.len());
    while lo < hi {
        let mid = (lo + hi) / 2;
        if count(mid) <= goal {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    boundaries.ceil(lo)
}

/// The coarsest step boundary whose collapse errors, as distances, are all within `bound`:
/// how `morphlod export --error` chooses its LODs, and the crowd bench its discrete levels by
/// error. `errors` is the sequence's ([`CollapseSequence::errors`]).
pub fn step_for_error(errors: &[f32], boundaries: &StepBoundaries, bound: f32) -> usize {
    let within = errors.partition_point(|&e| e.max(0.0).sqrt() <= bound);
    // errors[0] = 0 is always within, so `within` ≥ 1.
    boundaries.floor(within - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seq(n: u32, pairs: &[(u32, u32)]) -> CollapseSequence {
        CollapseSequence::from_pairs(n, pairs)
    }

    #[test]
    fn boundaries_floor_and_ceil() {
        // Topology: 0,1 -> T0; 2 -> T1; 3,4 -> T2; 5 -> T3.
        let of_vertex = [0, 0, 1, 2, 2, 3];
        let s = seq(6, &[(0, 2), (1, 2), (3, 5), (4, 5)]);
        let b = StepBoundaries::new(&s, &of_vertex);
        let want = [true, false, true, false, true];
        for (l, &w) in want.iter().enumerate() {
            assert_eq!(b.is_boundary(l), w, "LOD {l}");
        }
        assert_eq!(
            (0..=5).map(|l| b.floor(l)).collect::<Vec<_>>(),
            [0, 0, 2, 2, 4, 4]
        );
        assert_eq!(
            (0..=5).map(|l| b.ceil(l)).collect::<Vec<_>>(),
            [0, 2, 2, 4, 4, 4]
        );
    }

    #[test]
    fn boundaries_across_words() {
        // 200 collapses in groups of 3 (topology vertex = vertex / 3).
        let n = 201u32;
        let of_vertex: Vec<u32> = (0..n + 3).map(|v| v / 3).collect();
        let pairs: Vec<(u32, u32)> = (0..n - 3).map(|v| (v, v + 3)).collect();
        let s = seq(n + 3, &pairs);
        let b = StepBoundaries::new(&s, &of_vertex);
        for l in 0..=s.len() {
            let floor = (0..=l).rev().find(|&x| x % 3 == 0 || x == s.len()).unwrap();
            let ceil = (l..=s.len()).find(|&x| x % 3 == 0 || x == s.len()).unwrap();
            assert_eq!((b.floor(l), b.ceil(l)), (floor, ceil), "LOD {l}");
        }
    }

    #[test]
    fn check_steps_finds_split_and_incomplete_steps() {
        let of_vertex = [0, 0, 1, 1, 2];
        let wedges = Wedges::new(&of_vertex);
        check_steps(&seq(5, &[(0, 2), (1, 3)]), &wedges, &of_vertex).unwrap();
        assert!(matches!(
            check_steps(&seq(5, &[(0, 2), (1, 4)]), &wedges, &of_vertex),
            Err(SeamError::SplitTarget { step: 1, .. })
        ));
        assert!(matches!(
            check_steps(&seq(5, &[(0, 2), (2, 4)]), &wedges, &of_vertex),
            Err(SeamError::IncompleteStep {
                start: 0,
                moved: 1,
                copies: 2,
                ..
            })
        ));
        assert!(matches!(
            check_steps(&seq(5, &[(0, 1)]), &wedges, &of_vertex),
            Err(SeamError::WithinTopologyVertex { step: 0, .. })
        ));
    }
}
