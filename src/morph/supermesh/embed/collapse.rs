//! Stage 1 of the embedding: each vertex's ring of neighbours ([`build_rings`]), then
//! half-edge collapses, shortest edge first under the link condition, down to a tetrahedron
//! ([`collapse_to_tetrahedron`]), recorded in a [`Hierarchy`]; [`split`] undoes one.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::EmbedError;

/// Each vertex's neighbours in counter-clockwise order: vertex `v` has the
/// triangles `(v, ring[j], ring[j + 1])`.
pub(crate) fn build_rings(n: usize, triangles: &[[u32; 3]]) -> Result<Vec<Vec<u32>>, EmbedError> {
    // (next, after) pairs per vertex: triangle (a, b, c) gives a: b → c.
    let mut pairs: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
    for t in triangles {
        for i in 0..3 {
            pairs[t[i] as usize].push((t[(i + 1) % 3], t[(i + 2) % 3]));
        }
    }
    let mut rings = vec![Vec::new(); n];
    for (v, list) in pairs.iter().enumerate() {
        if list.is_empty() {
            continue;
        }
        let ring: &mut Vec<u32> = &mut rings[v];
        let first = list[0].0;
        let mut at = first;
        loop {
            ring.push(at);
            let next = match list.iter().find(|p| p.0 == at) {
                Some(p) => p.1,
                None => return Err(EmbedError::NotManifold { vertex: v as u32 }),
            };
            if next == first {
                break;
            }
            if ring.len() >= list.len() {
                return Err(EmbedError::NotManifold { vertex: v as u32 });
            }
            at = next;
        }
        if ring.len() != list.len() || ring.len() < 3 {
            return Err(EmbedError::NotManifold { vertex: v as u32 });
        }
    }
    Ok(rings)
}

/// The collapses in order: `u` disappeared with the ring `ring[start..start+len]`
/// (counter-clockwise, beginning with the vertex `w` it collapsed onto).
pub(crate) struct Hierarchy {
    pub records: Vec<(u32, u32, u32)>,
    pub ring_store: Vec<u32>,
}

impl Hierarchy {
    pub(super) fn ring(&self, record: usize) -> (u32, &[u32]) {
        let (u, start, len) = self.records[record];
        (u, &self.ring_store[start as usize..(start + len) as usize])
    }
}

fn edge_key(positions: &[[f32; 3]], a: u32, b: u32) -> Reverse<(u64, u32, u32)> {
    let pa = positions[a as usize].map(f64::from);
    let pb = positions[b as usize].map(f64::from);
    let d2 = (pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2) + (pa[2] - pb[2]).powi(2);
    // Non-negative finite doubles order like their bit patterns.
    Reverse((d2.to_bits(), a.min(b), a.max(b)))
}

/// Collapses shortest edges first (under the link condition) until four
/// vertices are left; `rings` ends as the tetrahedron.
pub(crate) fn collapse_to_tetrahedron(
    positions: &[[f32; 3]],
    rings: &mut [Vec<u32>],
) -> Result<Hierarchy, EmbedError> {
    let mut alive = rings.iter().filter(|r| !r.is_empty()).count();
    let mut hierarchy = Hierarchy {
        records: Vec::with_capacity(alive.saturating_sub(4)),
        ring_store: Vec::with_capacity(alive.saturating_sub(4) * 7),
    };
    let mut heap = BinaryHeap::new();
    for (a, ring) in rings.iter().enumerate() {
        for &b in ring {
            if (a as u32) < b {
                heap.push(edge_key(positions, a as u32, b));
            }
        }
    }
    let mut failed: Vec<(u32, u32)> = Vec::new();
    let mut collapsed_since_refill = true;
    while alive > 4 {
        let Some(Reverse((_, a, b))) = heap.pop() else {
            if !collapsed_since_refill {
                return Err(EmbedError::Stuck { vertices: alive });
            }
            collapsed_since_refill = false;
            for (a, b) in failed.drain(..) {
                heap.push(edge_key(positions, a, b));
            }
            continue;
        };
        if rings[a as usize].is_empty() || !rings[a as usize].contains(&b) {
            continue;
        }
        // Remove the vertex with the smaller ring: a shorter record.
        let (u, w) = if rings[a as usize].len() <= rings[b as usize].len() {
            (a, b)
        } else {
            (b, a)
        };
        if !link_condition(rings, u, w) {
            failed.push((a, b));
            continue;
        }
        collapse(rings, u, w, &mut hierarchy);
        alive -= 1;
        collapsed_since_refill = true;
        let (_, ring) = hierarchy.ring(hierarchy.records.len() - 1);
        // The new edges: w to the ring's middle vertices.
        for &r in &ring[2..ring.len() - 1] {
            heap.push(edge_key(positions, w, r));
        }
    }
    Ok(hierarchy)
}

/// `ring(u)` rotated to start at `w`.
fn ring_from(rings: &[Vec<u32>], u: u32, w: u32) -> Vec<u32> {
    let ring = &rings[u as usize];
    let i = ring.iter().position(|&x| x == w).unwrap_or(0);
    ring[i..].iter().chain(&ring[..i]).copied().collect()
}

/// The link condition of edge `uw` on a closed surface: the only common
/// neighbours are the two apexes of the edge's triangles.
fn link_condition(rings: &[Vec<u32>], u: u32, w: u32) -> bool {
    let ring = ring_from(rings, u, w);
    let d = ring.len();
    let ring_w = &rings[w as usize];
    ring[2..d - 1].iter().all(|r| !ring_w.contains(r))
}

/// Half-edge collapse `u → w`, recorded in `hierarchy`.
fn collapse(rings: &mut [Vec<u32>], u: u32, w: u32, hierarchy: &mut Hierarchy) {
    let ring = ring_from(rings, u, w);
    let d = ring.len();
    let (r1, rl) = (ring[1], ring[d - 1]);
    // ring(w) = [.., r1, u, rl, ..]: u becomes r2 .. r_{d-2}.
    let rw = &mut rings[w as usize];
    let i = rw.iter().position(|&x| x == u).expect("u in ring(w)");
    rw.splice(i..i + 1, ring[2..d - 1].iter().copied());
    remove(&mut rings[r1 as usize], u);
    remove(&mut rings[rl as usize], u);
    for &r in &ring[2..d - 1] {
        replace(&mut rings[r as usize], u, w);
    }
    rings[u as usize].clear();
    hierarchy
        .records
        .push((u, hierarchy.ring_store.len() as u32, d as u32));
    hierarchy.ring_store.extend_from_slice(&ring);
}

/// Undoes [`collapse`] of `u` with its recorded ring `[w, r1, .., rl]`.
pub(super) fn split(rings: &mut [Vec<u32>], u: u32, ring: &[u32]) {
    let d = ring.len();
    let (w, r1, rl) = (ring[0], ring[1], ring[d - 1]);
    let rw = &mut rings[w as usize];
    let i = rw.iter().position(|&x| x == r1).expect("r1 in ring(w)");
    // The d − 3 vertices after r1 (cyclically) go back to u.
    let n = rw.len();
    let middle = d - 3;
    if i + 1 + middle <= n {
        rw.splice(i + 1..i + 1 + middle, [u]);
    } else {
        let wrap = i + 1 + middle - n;
        rw.truncate(i + 1);
        rw.drain(..wrap);
        rw.push(u);
    }
    // ring(r1) = [.., r2, u, w, ..]: u goes back before w.
    let r = &mut rings[r1 as usize];
    let j = r.iter().position(|&x| x == w).expect("w in ring(r1)");
    r.insert(j, u);
    // ring(rl) = [.., w, u, r_{d-2}, ..]: u goes back after w.
    let r = &mut rings[rl as usize];
    let j = r.iter().position(|&x| x == w).expect("w in ring(rl)");
    r.insert(j + 1, u);
    for &m in &ring[2..d - 1] {
        replace(&mut rings[m as usize], w, u);
    }
    rings[u as usize] = ring.to_vec();
}

fn remove(ring: &mut Vec<u32>, x: u32) {
    if let Some(i) = ring.iter().position(|&y| y == x) {
        ring.remove(i);
    }
}

fn replace(ring: &mut [u32], from: u32, to: u32) {
    if let Some(y) = ring.iter_mut().find(|y| **y == from) {
        *y = to;
    }
}
