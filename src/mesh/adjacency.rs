//! Adjacency in flat arrays: vertex → incident triangles (CSR), and the
//! undirected edges with the half-edges on them. Every stage that needs
//! neighbourhoods (topology report, simplifier, stripifier) builds from these
//! instead of a pointer graph.

/// Marks "no neighbour" in [`triangle_neighbors`].
pub const NONE: u32 = u32::MAX;

/// Vertex → incident triangles, in compressed sparse row form.
#[derive(Clone, Debug, Default)]
pub struct VertexTriangles {
    offsets: Vec<u32>,
    triangles: Vec<u32>,
}

impl VertexTriangles {
    /// `vertex_count` must exceed every index in `triangles` (see `IndexedMesh::validate`).
    pub fn new(triangles: &[[u32; 3]], vertex_count: usize) -> Self {
        let mut offsets = vec![0u32; vertex_count + 1];
        for tri in triangles {
            for &v in tri {
                offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..vertex_count {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut list = vec![0u32; triangles.len() * 3];
        for (t, tri) in triangles.iter().enumerate() {
            for &v in tri {
                list[fill[v as usize] as usize] = t as u32;
                fill[v as usize] += 1;
            }
        }
        Self {
            offsets,
            triangles: list,
        }
    }

    /// The triangles that use vertex `v` (a triangle that uses `v` twice appears twice).
    pub fn of(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.triangles[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    pub fn vertex_count(&self) -> usize {
        self.offsets.len() - 1
    }
}

/// One directed edge of a triangle: corner `corner` of triangle `triangle`,
/// going from `tri[corner]` to `tri[(corner + 1) % 3]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HalfEdge {
    pub from: u32,
    pub to: u32,
    pub triangle: u32,
    pub corner: u8,
}

impl HalfEdge {
    /// The undirected edge as `(min, max)`.
    pub fn key(&self) -> (u32, u32) {
        (self.from.min(self.to), self.from.max(self.to))
    }
}

/// All half-edges sorted by undirected edge, so the half-edges of one edge are
/// contiguous. An edge with one half-edge is a boundary edge, two opposite
/// half-edges make an interior manifold edge, anything else is non-manifold.
#[derive(Clone, Debug, Default)]
pub struct EdgeMap {
    half_edges: Vec<HalfEdge>,
}

impl EdgeMap {
    pub fn new(triangles: &[[u32; 3]]) -> Self {
        // Counting sort by the smaller endpoint, then a stable sort by the
        // larger one inside each (small) bucket: O(n) instead of a comparison
        // sort of all half-edges, which dominated the simplifier's setup.
        // Half-edges enter their bucket in (triangle, corner) order, so the
        // result is ordered by (key, triangle, corner) as before.
        let half_edge = |t: usize, c: usize| HalfEdge {
            from: triangles[t][c],
            to: triangles[t][(c + 1) % 3],
            triangle: t as u32,
            corner: c as u8,
        };
        let vertex_count = triangles
            .iter()
            .flatten()
            .max()
            .map_or(0, |&m| m as usize + 1);
        let mut offsets = vec![0usize; vertex_count + 1];
        for t in 0..triangles.len() {
            for c in 0..3 {
                offsets[half_edge(t, c).key().0 as usize + 1] += 1;
            }
        }
        for i in 0..vertex_count {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let empty = HalfEdge {
            from: 0,
            to: 0,
            triangle: 0,
            corner: 0,
        };
        let mut half_edges = vec![empty; triangles.len() * 3];
        for t in 0..triangles.len() {
            for c in 0..3 {
                let h = half_edge(t, c);
                let bucket = &mut fill[h.key().0 as usize];
                half_edges[*bucket] = h;
                *bucket += 1;
            }
        }
        for bucket in offsets.windows(2) {
            half_edges[bucket[0]..bucket[1]].sort_by_key(|h| h.key().1);
        }
        Self { half_edges }
    }

    /// Groups of half-edges that share one undirected edge, in edge order.
    pub fn edges(&self) -> impl Iterator<Item = &[HalfEdge]> {
        self.half_edges.chunk_by(|a, b| a.key() == b.key())
    }
}

/// Whether a group from [`EdgeMap::edges`] is an interior manifold edge:
/// exactly two half-edges running in opposite directions.
pub fn is_manifold_pair(group: &[HalfEdge]) -> bool {
    group.len() == 2 && group[0].from == group[1].to && group[0].to == group[1].from
}

/// For each triangle and corner `c`, the triangle across edge
/// `(tri[c], tri[c+1])`, or [`NONE`] where that edge is a boundary or
/// non-manifold (strips and collapses never cross those).
pub fn triangle_neighbors(triangles: &[[u32; 3]], edges: &EdgeMap) -> Vec<[u32; 3]> {
    let mut neighbors = vec![[NONE; 3]; triangles.len()];
    for group in edges.edges() {
        if is_manifold_pair(group) && group[0].triangle != group[1].triangle {
            let (a, b) = (group[0], group[1]);
            neighbors[a.triangle as usize][a.corner as usize] = b.triangle;
            neighbors[b.triangle as usize][b.corner as usize] = a.triangle;
        }
    }
    neighbors
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_adjacency() {
        // Two triangles sharing the diagonal 0-2 of a quad.
        let tris = [[0, 1, 2], [0, 2, 3]];
        let vt = VertexTriangles::new(&tris, 4);
        assert_eq!(vt.of(0), &[0, 1]);
        assert_eq!(vt.of(1), &[0]);
        assert_eq!(vt.of(3), &[1]);
        let edges = EdgeMap::new(&tris);
        assert_eq!(edges.edges().count(), 5);
        assert_eq!(edges.edges().filter(|g| g.len() == 1).count(), 4);
        let n = triangle_neighbors(&tris, &edges);
        assert_eq!(n[0], [NONE, NONE, 1]);
        assert_eq!(n[1], [0, NONE, NONE]);
    }

    #[test]
    fn edges_sorted_by_key_then_triangle() {
        let tris = [[3, 1, 0], [0, 1, 2], [2, 1, 3], [0, 2, 3]];
        let edges = EdgeMap::new(&tris);
        let mut expected: Vec<(u32, u32, u32, u8)> = Vec::new();
        for (t, tri) in tris.iter().enumerate() {
            for c in 0..3 {
                let (a, b) = (tri[c], tri[(c + 1) % 3]);
                expected.push((a.min(b), a.max(b), t as u32, c as u8));
            }
        }
        expected.sort_unstable();
        let got: Vec<(u32, u32, u32, u8)> = edges
            .edges()
            .flatten()
            .map(|h| (h.key().0, h.key().1, h.triangle, h.corner))
            .collect();
        assert_eq!(got, expected);
        assert_eq!(EdgeMap::new(&[]).edges().count(), 0);
    }

    #[test]
    fn same_direction_pair_is_not_manifold() {
        // Two triangles with inconsistent orientation across edge 0-1.
        let tris = [[0, 1, 2], [0, 1, 3]];
        let edges = EdgeMap::new(&tris);
        let n = triangle_neighbors(&tris, &edges);
        assert_eq!(n, vec![[NONE; 3]; 2]);
    }
}
