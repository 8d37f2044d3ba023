//! The topology report: components, boundaries, manifoldness, Euler
//! characteristic and genus, computed from [`crate::mesh::adjacency`].
//!
//! It tells a user why a mesh simplifies or strips the way it does: the
//! simplifier and stripifier treat boundary and non-manifold edges as borders
//! they never cross, so those counts predict where they stop. Meant for
//! cleaned meshes ([`crate::mesh::clean`]); on raw input a degenerate triangle
//! shows up as a non-manifold edge rather than being hidden.

use crate::mesh::adjacency::{
    is_manifold_pair, triangle_neighbors, EdgeMap, VertexTriangles, NONE,
};
use crate::mesh::{IndexedMesh, MeshError};
use std::fmt;

/// Counts describing a mesh's topology.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TopologyReport {
    pub vertices: usize,
    /// Vertices no triangle uses (left out of components and χ).
    pub isolated_vertices: usize,
    pub triangles: usize,
    /// Undirected edges.
    pub edges: usize,
    /// Vertex-connected components of the triangles.
    pub components: usize,
    /// Edges with one half-edge.
    pub boundary_edges: usize,
    /// Closed walks of boundary half-edges.
    pub boundary_loops: usize,
    /// Edges that are neither boundary nor an opposite half-edge pair: three
    /// or more triangles, or two with inconsistent orientation.
    pub non_manifold_edges: usize,
    /// Vertices whose edges are all manifold but whose triangles form more
    /// than one fan (a pinch, like two cones touching at the tip).
    pub non_manifold_vertices: usize,
    /// χ = V − E + F over the used vertices.
    pub euler_characteristic: i64,
    /// Components without boundary, non-manifold edges or non-manifold vertices.
    pub closed_components: usize,
    /// The genus `(2 − χ_c) / 2` of each closed component, in component order
    /// (components are numbered by their lowest vertex).
    pub closed_genus: Vec<i64>,
}

impl TopologyReport {
    /// The genus of the whole mesh when it is one closed manifold surface.
    pub fn genus(&self) -> Option<i64> {
        match self.closed_genus.as_slice() {
            [g] if self.components == 1 => Some(*g),
            _ => None,
        }
    }

    /// A closed, orientable 2-manifold: no boundary, nothing non-manifold.
    pub fn is_closed_manifold(&self) -> bool {
        self.components > 0 && self.closed_components == self.components
    }
}

impl fmt::Display for TopologyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "  vertices          {} ({} isolated)",
            self.vertices, self.isolated_vertices
        )?;
        writeln!(f, "  triangles         {}", self.triangles)?;
        writeln!(f, "  edges             {}", self.edges)?;
        writeln!(
            f,
            "  components        {} ({} closed)",
            self.components, self.closed_components
        )?;
        writeln!(
            f,
            "  boundary          {} edges in {} loops",
            self.boundary_edges, self.boundary_loops
        )?;
        writeln!(
            f,
            "  non-manifold      {} edges, {} vertices",
            self.non_manifold_edges, self.non_manifold_vertices
        )?;
        writeln!(f, "  Euler char.       {}", self.euler_characteristic)?;
        write!(f, "  genus             ")?;
        match (self.genus(), self.closed_genus.len()) {
            (Some(g), _) => write!(f, "{g}"),
            (None, 0) => write!(f, "- (no closed component)"),
            (None, _) => write!(f, "{:?} (per closed component)", self.closed_genus),
        }
    }
}

/// Computes the report. Fails only on an invalid mesh (indices out of range).
pub fn analyze(mesh: &IndexedMesh) -> Result<TopologyReport, MeshError> {
    mesh.validate()?;
    let n = mesh.positions.len();
    let triangles = &mesh.triangles;
    let vertex_triangles = VertexTriangles::new(triangles, n);
    let edge_map = EdgeMap::new(triangles);
    let neighbors = triangle_neighbors(triangles, &edge_map);

    // Components by union-find over vertices; a triangle joins its three.
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for t in triangles {
        union(&mut parent, t[0], t[1]);
        union(&mut parent, t[0], t[2]);
    }
    // Component id per root, numbered in vertex order (so by lowest vertex).
    let mut component_of = vec![NONE; n];
    let mut components = 0usize;
    let mut isolated_vertices = 0usize;
    for v in 0..n as u32 {
        if vertex_triangles.of(v).is_empty() {
            isolated_vertices += 1;
            continue;
        }
        let root = find(&mut parent, v) as usize;
        if component_of[root] == NONE {
            component_of[root] = components as u32;
            components += 1;
        }
        component_of[v as usize] = component_of[root];
    }

    // Per component: V, E, F for χ_c, and whether anything makes it open.
    let mut counts = vec![[0i64; 3]; components];
    let mut open = vec![false; components];
    for &c in &component_of {
        // Isolated vertices have no component (NONE) and are skipped here.
        if let Some(c) = counts.get_mut(c as usize) {
            c[0] += 1;
        }
    }
    for t in triangles {
        counts[component_of[t[0] as usize] as usize][2] += 1;
    }

    let mut boundary_edges = 0usize;
    let mut non_manifold_edges = 0usize;
    let mut edges = 0usize;
    // Vertices on a non-manifold edge: their fans are not counted again.
    let mut on_non_manifold_edge = vec![false; n];
    let mut boundary: Vec<(u32, u32)> = Vec::new();
    for group in edge_map.edges() {
        edges += 1;
        let (a, b) = group[0].key();
        let c = component_of[a as usize] as usize;
        counts[c][1] += 1;
        if group.len() == 1 {
            boundary_edges += 1;
            boundary.push((group[0].from, group[0].to));
            open[c] = true;
        } else if !is_manifold_pair(group) {
            non_manifold_edges += 1;
            on_non_manifold_edge[a as usize] = true;
            on_non_manifold_edge[b as usize] = true;
            open[c] = true;
        }
    }

    let mut non_manifold_vertices = 0usize;
    let mut ring: Vec<u32> = Vec::new();
    let mut stack: Vec<u32> = Vec::new();
    for v in 0..n as u32 {
        let around = vertex_triangles.of(v);
        if around.is_empty() || on_non_manifold_edge[v as usize] {
            continue;
        }
        if fans(v, around, triangles, &neighbors, &mut ring, &mut stack) > 1 {
            non_manifold_vertices += 1;
            open[component_of[v as usize] as usize] = true;
        }
    }

    let closed_genus: Vec<i64> = counts
        .iter()
        .zip(&open)
        .filter(|(_, &is_open)| !is_open)
        .map(|(&[v, e, f], _)| (2 - (v - e + f)) / 2)
        .collect();
    let used = (n - isolated_vertices) as i64;
    Ok(TopologyReport {
        vertices: n,
        isolated_vertices,
        triangles: triangles.len(),
        edges,
        components,
        boundary_edges,
        boundary_loops: boundary_loops(boundary),
        non_manifold_edges,
        non_manifold_vertices,
        euler_characteristic: used - edges as i64 + triangles.len() as i64,
        closed_components: closed_genus.len(),
        closed_genus,
    })
}

/// The number of edge-connected fans the triangles `around` vertex `v`
/// form, linking two triangles only across a manifold edge at `v`
/// (`neighbors`). A manifold vertex has one fan (a disk, or a half-disk on
/// the boundary).
fn fans(
    v: u32,
    around: &[u32],
    triangles: &[[u32; 3]],
    neighbors: &[[u32; 3]],
    ring: &mut Vec<u32>,
    stack: &mut Vec<u32>,
) -> usize {
    // `ring` holds the triangles not reached yet; rings are a handful of
    // triangles, so linear search beats any hashing here.
    ring.clear();
    ring.extend_from_slice(around);
    ring.dedup();
    let mut count = 0;
    while let Some(start) = ring.pop() {
        count += 1;
        stack.clear();
        stack.push(start);
        while let Some(t) = stack.pop() {
            let tri = triangles[t as usize];
            for c in 0..3 {
                // Edge c runs tri[c] -> tri[c+1]; it touches v if either end is v.
                if tri[c] != v && tri[(c + 1) % 3] != v {
                    continue;
                }
                let next = neighbors[t as usize][c];
                if let Some(i) = ring.iter().position(|&r| r == next) {
                    ring.swap_remove(i);
                    stack.push(next);
                }
            }
        }
    }
    count
}

/// Counts closed walks over the boundary half-edges: from each unused
/// half-edge, keep taking an unused one that starts where the last ended,
/// until the walk is back at its first vertex. On a manifold boundary every
/// vertex has one outgoing boundary half-edge, so the walks are exactly the
/// loops. Where loops touch at a vertex (a pinch) the walk may take either
/// way out; stopping at the start vertex separates loops pinched there, but
/// a walk that crosses a pinch in its middle can join two loops into one,
/// so pinched boundaries may be undercounted (the pinch itself is reported
/// as a non-manifold vertex).
fn boundary_loops(mut boundary: Vec<(u32, u32)>) -> usize {
    boundary.sort_unstable();
    let mut used = vec![false; boundary.len()];
    // First unused outgoing half-edge of a vertex: binary search to the
    // vertex's run, then skip the used ones (runs are a few half-edges).
    let next_from = |used: &[bool], from: u32| -> Option<usize> {
        let start = boundary.partition_point(|&(a, _)| a < from);
        (start..boundary.len())
            .take_while(|&i| boundary[i].0 == from)
            .find(|&i| !used[i])
    };
    let mut loops = 0;
    for first in 0..boundary.len() {
        if used[first] {
            continue;
        }
        loops += 1;
        let start = boundary[first].0;
        let mut at = first;
        loop {
            used[at] = true;
            let to = boundary[at].1;
            if to == start {
                break;
            }
            match next_from(&used, to) {
                Some(next) => at = next,
                None => break,
            }
        }
    }
    loops
}

fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        // Path halving keeps the trees shallow without recursion.
        let grand = parent[parent[v as usize] as usize];
        parent[v as usize] = grand;
        v = grand;
    }
    v
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // The smaller root wins, so roots stay deterministic.
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi as usize] = lo;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{obj, off};
    use crate::mesh::clean::{clean, CleanOptions};
    use std::path::Path;

    fn mesh(n: usize, triangles: Vec<[u32; 3]>) -> IndexedMesh {
        IndexedMesh::new((0..n).map(|i| [i as f32, 0.0, 0.0]).collect(), triangles)
    }

    fn tetrahedron() -> Vec<[u32; 3]> {
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]]
    }

    #[test]
    fn tetrahedron_is_closed_genus_zero() {
        let r = analyze(&mesh(4, tetrahedron())).unwrap();
        assert_eq!(
            (r.edges, r.euler_characteristic, r.genus()),
            (6, 2, Some(0))
        );
        assert_eq!(
            (r.boundary_edges, r.boundary_loops, r.non_manifold_edges),
            (0, 0, 0)
        );
        assert!(r.is_closed_manifold());
    }

    #[test]
    fn open_quad_strip_and_isolated_vertex() {
        // Two quads side by side: one boundary loop of 6 edges; vertex 6 unused.
        let r = analyze(&mesh(7, vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]])).unwrap();
        assert_eq!((r.boundary_edges, r.boundary_loops), (6, 1));
        assert_eq!(
            (r.isolated_vertices, r.components, r.closed_components),
            (1, 1, 0)
        );
        assert_eq!(r.euler_characteristic, 1);
        assert_eq!(r.genus(), None);
    }

    #[test]
    fn bowtie_is_a_non_manifold_vertex_with_two_loops() {
        // Two triangles sharing only vertex 0.
        let r = analyze(&mesh(5, vec![[0, 1, 2], [0, 3, 4]])).unwrap();
        assert_eq!((r.non_manifold_vertices, r.non_manifold_edges), (1, 0));
        assert_eq!(
            (r.boundary_edges, r.boundary_loops, r.components),
            (6, 2, 1)
        );
    }

    #[test]
    fn three_triangles_on_an_edge_and_two_tetrahedra() {
        let fin = analyze(&mesh(5, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]])).unwrap();
        assert_eq!(fin.non_manifold_edges, 1);
        assert_eq!(fin.non_manifold_vertices, 0);
        let mut two = tetrahedron();
        two.extend(tetrahedron().iter().map(|t| t.map(|v| v + 4)));
        let r = analyze(&mesh(8, two)).unwrap();
        assert_eq!(
            (r.components, r.closed_genus.clone(), r.genus()),
            (2, vec![0, 0], None)
        );
        assert_eq!(r.euler_characteristic, 4);
    }

    #[test]
    fn torus_has_genus_one() {
        // A 4 x 4 grid with both directions wrapped.
        let k = 4u32;
        let id = |i: u32, j: u32| (i % k) * k + (j % k);
        let mut tris = Vec::new();
        for i in 0..k {
            for j in 0..k {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let r = analyze(&mesh(16, tris)).unwrap();
        assert_eq!((r.euler_characteristic, r.genus()), (0, Some(1)));
    }

    #[test]
    fn real_assets() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
        for (name, v, t) in [
            ("bunny.obj", 1839, 3674),
            ("cow.off", 2904, 5804),
            ("man.off", 17_495, 34_986),
            ("camel.off", 9_770, 19_536),
            ("bull.off", 6_200, 12_396),
        ] {
            let path = dir.join(name);
            let raw = if name.ends_with(".obj") {
                obj::load(&path)
            } else {
                off::load(&path)
            }
            .unwrap();
            let r = analyze(&raw).unwrap();
            assert_eq!((r.vertices, r.triangles), (v, t), "{name}");
            assert_eq!(r.genus(), Some(0), "{name}:\n{r}");
            assert_eq!(r.edges * 2, t * 3, "{name}: closed means E = 3F/2");
        }
        // Welding the cow's two coincident vertices pinches the surface there.
        let cow = off::load(&dir.join("cow.off")).unwrap();
        let welded = clean(
            &cow,
            &CleanOptions {
                weld: true,
                ..CleanOptions::default()
            },
        )
        .unwrap();
        let r = analyze(&welded.mesh).unwrap();
        assert_eq!(r.vertices, 2903);
        assert_eq!(r.non_manifold_vertices, 1, "{r}");
    }
}
