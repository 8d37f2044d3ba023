//! Classification, before anything is priced: what each vertex may do ([`Kind`], read off
//! its fan), the boundary edges, and the seam edges of a welded surface.

use super::after_before;
use crate::mesh::adjacency::{VertexTriangles, NONE};

/// What a vertex may do, fixed at the start (valid collapses keep interior
/// vertices interior and boundary vertices on their boundary) until it
/// collapses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    /// One closed fan of manifold edges: may collapse onto any neighbour.
    Interior,
    /// One open fan with exactly two boundary edges: collapses along them only.
    Border,
    /// Non-manifold, several fans, or no triangle: never collapses (may be a target).
    Locked,
    /// Collapsed onto a neighbour: in no triangle, never a target.
    Collapsed,
}

/// What one vertex's fan says about the edge to a neighbour `x`: how many of
/// the fan's triangles hold the half-edge `v→x` (`out`) and `x→v` (`inn`),
/// and the fan position of a triangle holding `x→v`.
#[derive(Clone, Copy)]
struct Link {
    out: u32,
    inn: u32,
    at: u32,
}

const NO_LINK: Link = Link {
    out: 0,
    inn: 0,
    at: NONE,
};

/// Tags each vertex by walking its fan across manifold edges: one closed fan
/// is interior, one open fan with two boundary edges is a border vertex,
/// anything else (non-manifold edges, bow-ties, isolated) is locked. Also
/// returns every boundary half-edge as `[from, to, triangle]`, sorted by the
/// undirected edge `(min, max)` (the order the boundary quadrics are summed in).
///
/// Every edge at `v` lies in a triangle of `v`'s fan, so counting the
/// half-edges around each fan classifies all edges without a global edge
/// table: `(out, inn) == (1, 1)` is a manifold interior edge, `(1, 0)` or
/// `(0, 1)` a boundary edge, anything else non-manifold.
pub(super) fn classify(tris: &[[u32; 3]], vt: &VertexTriangles) -> (Vec<Kind>, Vec<[u32; 3]>) {
    let n = vt.vertex_count();
    let mut link = vec![NO_LINK; n];
    let mut boundary_edges = Vec::new();
    // Per fan triangle: the corners after and before v.
    let mut ring: Vec<[u32; 2]> = Vec::new();
    let kind = (0..n as u32)
        .map(|v| {
            let fan = vt.of(v);
            ring.clear();
            // Reset the entries this fan uses, then count: cheaper than
            // testing per entry whether it is stale.
            for &t in fan {
                let [a, b] = after_before(tris[t as usize], v);
                ring.push([a, b]);
                link[a as usize] = NO_LINK;
                link[b as usize] = NO_LINK;
            }
            for (i, &[a, b]) in ring.iter().enumerate() {
                link[a as usize].out += 1;
                let l = &mut link[b as usize];
                l.inn += 1;
                l.at = i as u32;
            }
            let mut boundary = 0;
            let mut nonmanifold = false;
            // Where the edge coming into v is the boundary: the start of an open fan.
            let mut open_at = NONE;
            for (i, &[a, b]) in ring.iter().enumerate() {
                let (la, lb) = (link[a as usize], link[b as usize]);
                match (la.out, la.inn) {
                    (1, 1) => {}
                    (1, 0) => {
                        boundary += 1;
                        boundary_edges.push([v, a, fan[i]]);
                    }
                    _ => nonmanifold = true,
                }
                // A boundary edge into v is counted here and recorded from its
                // start vertex's fan.
                match (lb.out, lb.inn) {
                    (1, 1) => {}
                    (0, 1) => {
                        boundary += 1;
                        if open_at == NONE {
                            open_at = i as u32;
                        }
                    }
                    _ => nonmanifold = true,
                }
            }
            if fan.is_empty() || nonmanifold {
                return Kind::Locked;
            }
            let (first, kind) = match (boundary, open_at) {
                (0, _) => (0, Kind::Interior),
                (2, i) if i != NONE => (i, Kind::Border),
                _ => return Kind::Locked,
            };
            // Across the outgoing edge v→a lies the triangle holding a→v.
            let mut i = first;
            let mut visited = 0;
            loop {
                visited += 1;
                let l = link[ring[i as usize][0] as usize];
                i = if (l.out, l.inn) == (1, 1) { l.at } else { NONE };
                if i == NONE || i == first || visited > fan.len() {
                    break;
                }
            }
            let closed = i == first;
            if visited == fan.len() && closed == (kind == Kind::Interior) {
                kind
            } else {
                Kind::Locked
            }
        })
        .collect();
    boundary_edges.sort_unstable_by_key(|&[a, b, _]| (a.min(b), a.max(b)));
    (kind, boundary_edges)
}

/// Both sides of every seam edge of the welded surface `tris` (`[from, to, triangle]`, one
/// entry per triangle on the edge): an edge with two triangles whose attribute `corners` at
/// either end differ. Border and non-manifold edges are not seams.
pub(super) fn seam_edges(tris: &[[u32; 3]], corners: &[[u32; 3]]) -> Vec<[u32; 3]> {
    // Per directed edge `a → b`: its triangle and the attribute vertices at `a` and `b`.
    let mut half = std::collections::HashMap::with_capacity(tris.len() * 3);
    let mut repeated = std::collections::HashSet::new();
    for (i, (t, c)) in tris.iter().zip(corners).enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if half
                .insert((a, b), (i as u32, c[k], c[(k + 1) % 3]))
                .is_some()
            {
                repeated.insert((a.min(b), a.max(b)));
            }
        }
    }
    let mut out = Vec::new();
    for (&(a, b), &(i, ca, cb)) in &half {
        if a > b || repeated.contains(&(a, b)) {
            continue;
        }
        if let Some(&(j, cb2, ca2)) = half.get(&(b, a)) {
            if ca != ca2 || cb != cb2 {
                out.push([a, b, i]);
                out.push([b, a, j]);
            }
        }
    }
    // The quadrics are sums: a fixed order keeps them bit-reproducible.
    out.sort_unstable();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::tests::grid;
    use std::collections::HashMap;

    /// A 4×4 grid whose column x = 2 is a seam (cells right of it use copies of that column's
    /// vertices): the seam edges are exactly the column's 4 edges, once from each side, and
    /// border edges (one triangle) and edges whose ends agree on both sides are not seams.
    #[test]
    fn seam_edges_are_the_edges_whose_sides_differ_in_attributes() {
        let (n, k) = (4u32, 2u32);
        let row = n + 1;
        let (pos, tris) = grid(n, 0.0);
        let copy = |v: u32| {
            if v % row == k {
                pos.len() as u32 + v / row
            } else {
                v
            }
        };
        let corners: Vec<[u32; 3]> = tris
            .iter()
            .enumerate()
            // Cell of triangle i: (i / 2) % n; right of the seam when the cell's x ≥ k.
            .map(|(i, t)| {
                if (i as u32 / 2) % n >= k {
                    t.map(copy)
                } else {
                    *t
                }
            })
            .collect();
        let found = seam_edges(&tris, &corners);
        let mut want = Vec::new();
        for j in 0..n {
            let (low, high) = (j * row + k, (j + 1) * row + k);
            let left = (j * n + k - 1) * 2; // [v, v+1, v+row+1] of the cell left of the seam
            let right = (j * n + k) * 2 + 1; // [v, v+row+1, v+row] of the cell right of it
            want.push([low, high, left]);
            want.push([high, low, right]);
        }
        want.sort_unstable();
        assert_eq!(found, want);
        assert!(seam_edges(&tris, &tris).is_empty(), "no copies, no seams");
    }

    #[test]
    fn classify_reads_kinds_and_boundary_edges_off_the_fans() {
        // A 2×2 grid (centre 4 interior, the rest border), a bow-tie at 9 (two
        // fans), a fin on edge 14-15 (three triangles), and 19 in no triangle.
        let (_, mut tris) = grid(2, 0.0);
        tris.extend([
            [9, 10, 11],
            [9, 12, 13],
            [14, 15, 16],
            [15, 14, 17],
            [14, 15, 18],
        ]);
        let n = 20;
        let (kind, boundary) = classify(&tris, &VertexTriangles::new(&tris, n));
        let mut expected = vec![Kind::Border; n];
        expected[4] = Kind::Interior;
        for v in [9, 14, 15, 19] {
            expected[v] = Kind::Locked;
        }
        assert_eq!(kind, expected);
        // Oracle: every half-edge alone on its undirected edge, in (min, max) order.
        let undirected = |t: &[u32; 3], c: usize| {
            let (a, b) = (t[c], t[(c + 1) % 3]);
            (a.min(b), a.max(b))
        };
        let mut count: HashMap<(u32, u32), usize> = HashMap::new();
        for t in &tris {
            for c in 0..3 {
                *count.entry(undirected(t, c)).or_default() += 1;
            }
        }
        let mut want = Vec::new();
        for (i, t) in tris.iter().enumerate() {
            for c in 0..3 {
                if count[&undirected(t, c)] == 1 {
                    want.push([t[c], t[(c + 1) % 3], i as u32]);
                }
            }
        }
        want.sort_unstable_by_key(|&[a, b, _]| (a.min(b), a.max(b)));
        assert_eq!(boundary, want);
    }
}
