//! The stripifier: turns a triangle list into generalized triangle strips `S0`.
//!
//! Parity convention (`docs/DESIGN.md`, strip parity): window `j` of a strip `s` draws
//! `(s[j], s[j+1], s[j+2])` for even `j` and `(s[j+1], s[j], s[j+2])` for odd
//! `j`; a window with a repeated index draws nothing. With that convention two
//! consecutive windows of a strip draw triangles that share an edge in opposite
//! directions, so a path of triangles across *manifold* edges (opposite
//! half-edges) keeps every orientation by construction; only the first triangle
//! needs the right rotation. That is why strips only cross the edges that
//! [`triangle_neighbors`] reports; every other triangle (boundary, non-manifold,
//! duplicated) still appears exactly once, as the start of some strip.
//!
//! A strip whose next triangle turns the "wrong" way continues with a swap: the
//! second-to-last index is repeated (one degenerate window, one extra index),
//! which is much cheaper than a new strip (two extra indices and one more GPU
//! draw region for the LOD model). The cost of a triangle path is therefore
//! `triangles + 2 + swaps`, and a swap is needed exactly where two consecutive
//! turns go the same way, so the growth below prefers alternating turns.
//!
//! Greedy growth: start at the unvisited triangle with the fewest unvisited
//! neighbours (it would otherwise end up alone), grow forward as far as
//! possible, then grow backward from the start triangle, and emit the joined path.

use crate::mesh::adjacency::{triangle_neighbors, EdgeMap, NONE};

/// Triangle strips in flat arrays: strip `i` is `indices[offsets[i]..offsets[i+1]]`.
/// Strips contain no restart index; each starts with even parity.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Strips {
    pub indices: Vec<u32>,
    pub offsets: Vec<u32>,
}

impl Strips {
    /// Number of strips.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The indices of strip `i`, or `None` past the end.
    pub fn strip(&self, i: usize) -> Option<&[u32]> {
        let start = *self.offsets.get(i)? as usize;
        let end = *self.offsets.get(i + 1)? as usize;
        self.indices.get(start..end)
    }

    /// Every non-degenerate triangle drawn by all strips, with its orientation.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let mut out = Vec::new();
        for i in 0..self.len() {
            if let Some(s) = self.strip(i) {
                out.extend(strip_triangles(s));
            }
        }
        out
    }
}

/// The non-degenerate triangles one strip draws, oriented per the parity rule.
/// `0xFFFFFFFF` restarts the strip (parity starts again at even), so this also
/// reads index buffers that use primitive restart.
pub fn strip_triangles(strip: &[u32]) -> impl Iterator<Item = [u32; 3]> + '_ {
    strip
        .split(|&i| i == u32::MAX)
        .flat_map(|piece| piece.windows(3).enumerate())
        .filter_map(|(j, w)| {
            let t = if j % 2 == 0 {
                [w[0], w[1], w[2]]
            } else {
                [w[1], w[0], w[2]]
            };
            (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]).then_some(t)
        })
}

/// Builds generalized strips covering every non-degenerate triangle of
/// `triangles` exactly once with its orientation. Degenerate input triangles
/// (a repeated index) draw nothing and are left out. `vertex_count` bounds the
/// indices; triangles naming a vertex at or past it are left out too (callers
/// validate meshes first, see `IndexedMesh::validate`).
pub fn stripify(triangles: &[[u32; 3]], vertex_count: usize) -> Strips {
    let usable = |t: &[u32; 3]| {
        t.iter().all(|&v| (v as usize) < vertex_count)
            && t[0] != t[1]
            && t[1] != t[2]
            && t[0] != t[2]
    };
    let edges = EdgeMap::new(triangles);
    let mut neighbors = triangle_neighbors(triangles, &edges);
    let mut visited: Vec<bool> = triangles.iter().map(|t| !usable(t)).collect();
    // Unusable triangles are never crossed into.
    for n in neighbors.iter_mut() {
        for x in n.iter_mut() {
            if *x != NONE && visited[*x as usize] {
                *x = NONE;
            }
        }
    }
    let mut degree: Vec<u8> = neighbors
        .iter()
        .map(|n| n.iter().filter(|&&x| x != NONE).count() as u8)
        .collect();
    // Buckets of candidate start triangles by unvisited-neighbour count, with
    // lazy deletion: an entry is stale if the triangle was visited or its
    // degree dropped (it was re-pushed into a lower bucket then).
    let mut buckets: [Vec<u32>; 4] = Default::default();
    for t in (0..triangles.len()).rev() {
        if !visited[t] {
            buckets[degree[t] as usize].push(t as u32);
        }
    }

    let mut grower = Grower {
        neighbors: &neighbors,
        visited: &mut visited,
        degree: &mut degree,
        buckets: &mut buckets,
    };
    let mut out = Strips {
        indices: Vec::with_capacity(triangles.len() * 3 / 2),
        offsets: vec![0],
    };
    let mut forward: Vec<u32> = Vec::new();
    let mut backward: Vec<u32> = Vec::new();
    let mut path: Vec<u32> = Vec::new();
    while let Some(start) = grower.next_start() {
        grower.visit(start);
        // First exit: the neighbour with the fewest unvisited neighbours, so
        // the strip heads away from the crowded side and leaves it for the
        // backward growth.
        let first_exit = (0..3u8)
            .filter(|&c| grower.free(neighbors[start as usize][c as usize]))
            .min_by_key(|&c| grower.degree[neighbors[start as usize][c as usize] as usize]);
        forward.clear();
        backward.clear();
        if let Some(c) = first_exit {
            grower.grow(start, c, None, &mut forward);
            // Backward: as if the strip entered `start` through its exit edge.
            grower.grow_from_entry(start, c, &mut backward);
        }
        path.clear();
        path.extend(backward.iter().rev());
        path.push(start);
        path.extend_from_slice(&forward);
        emit(triangles, &path, &mut out.indices);
        out.offsets.push(out.indices.len() as u32);
    }
    out
}

/// The corner `c` of triangle `a` whose edge `(a[c], a[c+1])` is shared with `b`.
fn shared_corner(triangles: &[[u32; 3]], a: u32, b: u32) -> u8 {
    let ta = triangles[a as usize];
    let tb = triangles[b as usize];
    (0..3u8)
        .find(|&c| {
            let (x, y) = (ta[c as usize], ta[(c as usize + 1) % 3]);
            tb.contains(&x) && tb.contains(&y)
        })
        .unwrap_or(0)
}

struct Grower<'a> {
    neighbors: &'a [[u32; 3]],
    visited: &'a mut [bool],
    degree: &'a mut [u8],
    buckets: &'a mut [Vec<u32>; 4],
}

impl Grower<'_> {
    fn free(&self, t: u32) -> bool {
        t != NONE && !self.visited[t as usize]
    }

    fn next_start(&mut self) -> Option<u32> {
        for b in 0..4 {
            while let Some(t) = self.buckets[b].pop() {
                if !self.visited[t as usize] && self.degree[t as usize] as usize == b {
                    return Some(t);
                }
            }
        }
        None
    }

    fn visit(&mut self, t: u32) {
        self.visited[t as usize] = true;
        for &n in &self.neighbors[t as usize] {
            if n != NONE && !self.visited[n as usize] {
                self.degree[n as usize] -= 1;
                self.buckets[self.degree[n as usize] as usize].push(n);
            }
        }
    }

    /// Grows a path out of `from` through its corner `exit`, appending the
    /// entered triangles. `last_turn` is the turn taken in `from` (None when
    /// `from` is the first triangle of the path).
    fn grow(&mut self, from: u32, exit: u8, last_turn: Option<u8>, path: &mut Vec<u32>) {
        let mut current = from;
        let mut exit = exit;
        let mut turn = last_turn;
        loop {
            let next = self.neighbors[current as usize][exit as usize];
            if !self.free(next) {
                return;
            }
            self.visit(next);
            // The corner of `next` across the shared edge.
            let entry = (0..3u8)
                .find(|&c| self.neighbors[next as usize][c as usize] == current)
                .unwrap_or(0);
            path.push(next);
            // Turn 1 exits through the edge after the entry edge, turn 2
            // through the one before; a sequential strip alternates them.
            let natural = match turn {
                Some(1) => 2,
                Some(_) => 1,
                None => 1,
            };
            let target = |k: u8| self.neighbors[next as usize][((entry + k) % 3) as usize];
            let (a, b) = (target(natural), target(3 - natural));
            // Prefer no swap, unless the swap side would be left with no free
            // neighbour at all: a lone triangle later costs a whole strip.
            let pick = match (self.free(a), self.free(b)) {
                (true, true) if self.degree[b as usize] == 0 && self.degree[a as usize] > 0 => {
                    Some(3 - natural)
                }
                (true, _) => Some(natural),
                (false, true) => Some(3 - natural),
                (false, false) => None,
            };
            match pick {
                Some(k) => {
                    turn = Some(k);
                    exit = (entry + k) % 3;
                    current = next;
                }
                None => return,
            }
        }
    }

    /// Grows the backward half: the strip "enters" `start` through corner
    /// `entry` (the forward exit) and leaves through one of the other two.
    fn grow_from_entry(&mut self, start: u32, entry: u8, path: &mut Vec<u32>) {
        for k in [1u8, 2] {
            let c = (entry + k) % 3;
            if self.free(self.neighbors[start as usize][c as usize]) {
                self.grow(start, c, Some(k), path);
                return;
            }
        }
    }
}

/// Writes the indices of a triangle path. The first triangle is rotated so
/// that its last two indices are the edge shared with the second; after that
/// each triangle adds its third vertex, preceded by a swap (the second-to-last
/// index repeated) when the path leaves through the other edge.
fn emit(triangles: &[[u32; 3]], path: &[u32], out: &mut Vec<u32>) {
    let Some(&first) = path.first() else {
        return;
    };
    let t0 = triangles[first as usize];
    let (mut p, mut q) = match path.get(1) {
        Some(&next) => {
            let c = shared_corner(triangles, first, next) as usize;
            let (x, y, z) = (t0[(c + 2) % 3], t0[c], t0[(c + 1) % 3]);
            out.extend_from_slice(&[x, y, z]);
            (y, z)
        }
        None => {
            out.extend_from_slice(&t0);
            return;
        }
    };
    for (i, &step) in path.iter().enumerate().skip(1) {
        let t = triangles[step as usize];
        let w = t
            .iter()
            .copied()
            .find(|&v| v != p && v != q)
            .unwrap_or(t[0]);
        if let Some(&next) = path.get(i + 1) {
            let tn = triangles[next as usize];
            if tn.contains(&q) && tn.contains(&w) {
                out.push(w);
                (p, q) = (q, w);
            } else {
                out.extend_from_slice(&[p, w]);
                q = w;
            }
        } else {
            out.push(w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collapse::canonical_multiset;

    fn check(tris: &[[u32; 3]], n: usize) -> Strips {
        let s = stripify(tris, n);
        let expected = canonical_multiset(
            tris.iter()
                .copied()
                .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]),
        );
        assert_eq!(canonical_multiset(s.triangles()), expected);
        assert!(!s.indices.contains(&u32::MAX));
        s
    }

    fn grid(w: u32, h: u32) -> Vec<[u32; 3]> {
        let mut t = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let a = y * (w + 1) + x;
                let b = a + 1;
                let c = a + w + 1;
                let d = c + 1;
                t.push([a, b, d]);
                t.push([a, d, c]);
            }
        }
        t
    }

    #[test]
    fn parity_definition() {
        let s = [0u32, 1, 2, 3, 3, 4];
        let t: Vec<_> = strip_triangles(&s).collect();
        assert_eq!(t, vec![[0, 1, 2], [2, 1, 3]]);
        let r = [0u32, 1, 2, u32::MAX, 3, 4, 5];
        let t: Vec<_> = strip_triangles(&r).collect();
        assert_eq!(t, vec![[0, 1, 2], [3, 4, 5]]);
    }

    #[test]
    fn grid_is_one_long_strip_per_row_or_better() {
        let s = check(&grid(8, 8), 81);
        assert!(s.indices.len() as f64 / 128.0 < 1.6, "{:?}", s);
    }

    #[test]
    fn odd_inputs_keep_every_triangle() {
        // Duplicated triangle, a flipped neighbour, a non-manifold fan, a
        // degenerate triangle and an isolated one.
        let tris = [
            [0, 1, 2],
            [0, 1, 2],
            [2, 1, 3],
            [1, 2, 4],
            [1, 2, 5],
            [6, 6, 7],
            [8, 9, 10],
            [10, 9, 11],
        ];
        let s = check(&tris, 12);
        assert!(s.len() >= 4);
        check(&[], 0);
    }
}
