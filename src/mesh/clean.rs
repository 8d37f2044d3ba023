//! Cleaning a loaded mesh into what the simplifier and stripifier expect:
//! no triangle with a repeated vertex, no triangle twice, no unused vertex,
//! and optionally one vertex per position.
//!
//! A **triangle soup** (every triangle its own three vertices, as many DCC
//! exporters write meshes; see [`detect_soup`]) is welded by default: left
//! apart, each triangle is its own component with three boundary edges, and
//! the simplifier, which never crosses a boundary, shows holes at every coarse
//! LOD. Detection is strict (no vertex shared by two triangles), so no other
//! mesh is welded unless asked; [`CleanOptions::weld_soup`] turns it off.
//!
//! Cleaning is a stable compaction: surviving vertices and triangles keep
//! their relative order, and [`Cleaned::vertex_map`] says where every new
//! vertex came from. A morph needs that map to clean every pose the same way
//! ([`remap_positions`]); silently reordering would break the pose/vertex
//! correspondence.
//!
//! What is *not* dropped, on purpose:
//! - Zero-area triangles with three distinct vertices. In a morph a triangle
//!   flat in one pose is usually not flat in another, and the collapse oracle
//!   only drops combinatorially degenerate triangles; they are counted.
//! - Opposite-orientation twins `(a,b,c)` / `(a,c,b)`. They are a two-sided
//!   sheet (a leaf, a card), real visible geometry; dropping either one would
//!   change what is seen from one side. They make their edges non-manifold,
//!   which the topology report shows and the simplifier and stripifier already
//!   treat as borders; they are counted here so the cause is visible.

use super::{IndexedMesh, MeshError};
use crate::collapse::canonical;
use std::collections::{HashMap, HashSet};
use std::fmt;
use thiserror::Error;

/// What [`clean`] may change besides dropping degenerate, duplicate and unused elements.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CleanOptions {
    /// Merge vertices with identical positions (bit-identical, with -0.0
    /// equal to 0.0) into the first of them. Off by default because a file
    /// may split vertices on purpose (UV or normal seams, a morph whose poses
    /// separate the copies); on for files that just failed to share them.
    /// Only the positions of the mesh given (one pose) are compared: for a
    /// morph, [`clean_poses`] (or [`crate::morph::Morph::clean`]) welds only
    /// copies that coincide in every pose, so no pose tears.
    pub weld: bool,
    /// Weld a triangle soup ([`detect_soup`]) even when `weld` is off. On by
    /// default: a soup has no connectivity to keep, and every coarse LOD of
    /// it tears. Off keeps the file's vertices exactly (the soup is still
    /// reported in [`CleanReport::soup`]).
    pub weld_soup: bool,
}

impl Default for CleanOptions {
    fn default() -> Self {
        CleanOptions {
            weld: false,
            weld_soup: true,
        }
    }
}

/// A triangle soup found by [`detect_soup`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Soup {
    pub triangles: usize,
    /// Vertices at the position of an earlier vertex: what welding merges.
    pub shared_positions: usize,
}

/// Whether `mesh` is a triangle soup: more than one triangle, no vertex used
/// by two triangles (or twice by one), and at least one vertex at the
/// position of another, so that welding joins something. Strict on purpose:
/// a single shared vertex anywhere means the file has connectivity, and it
/// is kept. Indices out of range make it `None` (validation reports them).
pub fn detect_soup(mesh: &IndexedMesh) -> Option<Soup> {
    let n = mesh.positions.len();
    if mesh.triangles.len() < 2 {
        return None;
    }
    let mut used = vec![false; n];
    for &v in mesh.triangles.iter().flatten() {
        let slot = used.get_mut(v as usize)?;
        if *slot {
            return None;
        }
        *slot = true;
    }
    let mut seen: HashSet<[u32; 3]> = HashSet::with_capacity(n);
    let shared_positions = mesh
        .positions
        .iter()
        .filter(|p| !seen.insert(weld_key(p)))
        .count();
    (shared_positions > 0).then_some(Soup {
        triangles: mesh.triangles.len(),
        shared_positions,
    })
}

/// A position as welding compares it: bit-identical, with -0.0 equal to 0.0.
fn weld_key(p: &[f32; 3]) -> [u32; 3] {
    // `+ 0.0` turns -0.0 into 0.0: the same point, different bits.
    p.map(|c| (c + 0.0).to_bits())
}

/// What [`clean`] found and did; counts of the input unless said otherwise.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanReport {
    pub input_vertices: usize,
    pub input_triangles: usize,
    /// Vertices merged into an earlier vertex at the same position (with `weld`).
    pub welded_vertices: usize,
    /// Vertices no kept triangle uses, dropped.
    pub unreferenced_vertices: usize,
    /// Triangles with a repeated vertex (after welding), dropped.
    pub degenerate_triangles: usize,
    /// Triangles equal to an earlier one up to rotation (after welding), dropped.
    pub duplicate_triangles: usize,
    /// Kept triangles whose reverse `(a,c,b)` was kept before them.
    pub opposite_twins: usize,
    /// Kept triangles with three distinct vertices but zero area.
    pub zero_area_triangles: usize,
    /// The input is a triangle soup ([`detect_soup`]).
    pub soup: Option<Soup>,
    /// The soup was welded because of [`CleanOptions::weld_soup`] (not `weld`).
    pub soup_welded: bool,
    pub output_vertices: usize,
    pub output_triangles: usize,
}

impl CleanReport {
    /// Whether cleaning changed nothing.
    pub fn is_unchanged(&self) -> bool {
        self.input_vertices == self.output_vertices && self.input_triangles == self.output_triangles
    }
}

impl fmt::Display for CleanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "  vertices          {} -> {}",
            self.input_vertices, self.output_vertices
        )?;
        writeln!(
            f,
            "  triangles         {} -> {}",
            self.input_triangles, self.output_triangles
        )?;
        writeln!(
            f,
            "  welded            {} vertices (same position)",
            self.welded_vertices
        )?;
        writeln!(
            f,
            "  unreferenced      {} vertices dropped",
            self.unreferenced_vertices
        )?;
        writeln!(
            f,
            "  degenerate        {} triangles dropped (repeated vertex)",
            self.degenerate_triangles
        )?;
        writeln!(
            f,
            "  duplicate         {} triangles dropped (same triangle again)",
            self.duplicate_triangles
        )?;
        writeln!(
            f,
            "  opposite twins    {} triangles kept (two-sided sheets, non-manifold edges)",
            self.opposite_twins
        )?;
        write!(
            f,
            "  zero area         {} triangles kept (may not be flat in other poses)",
            self.zero_area_triangles
        )?;
        if let Some(soup) = self.soup {
            write!(
                f,
                "\n  triangle soup     {} triangles share no vertex ({} vertices at an earlier vertex's position): ",
                soup.triangles, soup.shared_positions
            )?;
            if self.soup_welded {
                write!(f, "welded (keep it apart with --no-weld)")?;
            } else if self.welded_vertices > 0 {
                write!(f, "welded")?;
            } else {
                write!(
                    f,
                    "NOT welded: every triangle is its own piece and coarse LODs show holes; drop --no-weld to join it"
                )?;
            }
        }
        Ok(())
    }
}

/// A cleaned mesh and how it relates to the input.
#[derive(Clone, Debug, PartialEq)]
pub struct Cleaned {
    pub mesh: IndexedMesh,
    /// New vertex `i` is old vertex `vertex_map[i]`; increasing, so the order is kept.
    pub vertex_map: Vec<u32>,
    pub report: CleanReport,
}

/// A pose too short for a vertex map made on another pose.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("the vertex map uses vertex {index}, but the pose has {vertices} vertices: every pose must have the vertex count of the mesh that was cleaned")]
pub struct PoseTooShort {
    pub index: u32,
    pub vertices: usize,
}

/// Cleans `mesh` (see the module docs for what is dropped and what is kept).
/// Fails only if the mesh is invalid (`IndexedMesh::validate`), since every
/// step indexes positions by the triangles' indices.
pub fn clean(mesh: &IndexedMesh, options: &CleanOptions) -> Result<Cleaned, MeshError> {
    clean_poses(mesh, &[], options)
}

/// [`clean`] for a mesh with more poses (a morph's other poses, or its
/// targets' offsets): a weld merges two vertices only where they coincide in
/// `mesh` *and* in every pose of `also`, so no pose tears. Each pose of `also`
/// needs one entry per vertex of `mesh` ([`MeshError::PoseSize`] otherwise).
pub fn clean_poses(
    mesh: &IndexedMesh,
    also: &[&[[f32; 3]]],
    options: &CleanOptions,
) -> Result<Cleaned, MeshError> {
    mesh.validate()?;
    let n = mesh.positions.len();
    if let Some((pose, p)) = also.iter().enumerate().find(|(_, p)| p.len() != n) {
        return Err(MeshError::PoseSize {
            pose,
            vertices: p.len(),
            expected: n,
        });
    }
    let soup = detect_soup(mesh);
    let soup_welded = !options.weld && options.weld_soup && soup.is_some();
    let mut report = CleanReport {
        input_vertices: n,
        input_triangles: mesh.triangles.len(),
        soup,
        soup_welded,
        ..CleanReport::default()
    };

    // `rep[v]`: the vertex that stands for `v` (itself unless welded). The
    // first vertex at a position wins, so welding never moves a vertex later.
    let rep: Vec<u32> = if (options.weld || soup_welded) && also.is_empty() {
        let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(n);
        (0..n as u32)
            .zip(&mesh.positions)
            .map(|(v, p)| *first.entry(weld_key(p)).or_insert(v))
            .collect()
    } else if options.weld || soup_welded {
        let mut first: HashMap<Vec<u32>, u32> = HashMap::with_capacity(n);
        (0..n)
            .map(|v| {
                let key: Vec<u32> = std::iter::once(&mesh.positions[v])
                    .chain(also.iter().map(|pose| &pose[v]))
                    .flat_map(weld_key)
                    .collect();
                *first.entry(key).or_insert(v as u32)
            })
            .collect()
    } else {
        (0..n as u32).collect()
    };
    report.welded_vertices = rep
        .iter()
        .enumerate()
        .filter(|&(v, &r)| r as usize != v)
        .count();

    let mut kept: Vec<[u32; 3]> = Vec::with_capacity(mesh.triangles.len());
    let mut seen: HashSet<[u32; 3]> = HashSet::with_capacity(mesh.triangles.len());
    for tri in &mesh.triangles {
        let t = tri.map(|v| rep[v as usize]);
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            report.degenerate_triangles += 1;
            continue;
        }
        if !seen.insert(canonical(t)) {
            report.duplicate_triangles += 1;
            continue;
        }
        if seen.contains(&canonical([t[0], t[2], t[1]])) {
            report.opposite_twins += 1;
        }
        if is_zero_area(&mesh.positions, t) {
            report.zero_area_triangles += 1;
        }
        kept.push(t);
    }

    // Stable compaction: used vertices in their old order.
    let mut used = vec![false; n];
    for t in &kept {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let mut new_index = vec![u32::MAX; n];
    let mut vertex_map = Vec::with_capacity(n);
    for (v, &is_used) in used.iter().enumerate() {
        if is_used {
            new_index[v] = vertex_map.len() as u32;
            vertex_map.push(v as u32);
        } else if rep[v] as usize == v {
            report.unreferenced_vertices += 1;
        }
    }
    let triangles: Vec<[u32; 3]> = kept
        .iter()
        .map(|t| t.map(|v| new_index[v as usize]))
        .collect();
    let positions: Vec<[f32; 3]> = vertex_map
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    report.output_vertices = positions.len();
    report.output_triangles = triangles.len();
    Ok(Cleaned {
        mesh: IndexedMesh::new(positions, triangles),
        vertex_map,
        report,
    })
}

/// Applies a [`Cleaned::vertex_map`] to another pose of the same mesh.
pub fn remap_positions(
    positions: &[[f32; 3]],
    vertex_map: &[u32],
) -> Result<Vec<[f32; 3]>, PoseTooShort> {
    vertex_map
        .iter()
        .map(|&v| {
            positions.get(v as usize).copied().ok_or(PoseTooShort {
                index: v,
                vertices: positions.len(),
            })
        })
        .collect()
}

/// Zero area: the cross product of two edges vanishes, computed in f64 so
/// that f32 rounding of a thin but real triangle does not count it. Only a
/// report figure (such triangles are kept), so no tolerance is needed.
fn is_zero_area(positions: &[[f32; 3]], t: [u32; 3]) -> bool {
    let [a, b, c] = t.map(|v| positions[v as usize].map(f64::from));
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let cross = [
        u[1] * w[2] - u[2] * w[1],
        u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0],
    ];
    cross == [0.0; 3]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::off;
    use std::path::Path;

    fn quad() -> Vec<[f32; 3]> {
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]
    }

    #[test]
    fn drops_degenerate_duplicate_and_unused_keeping_order() {
        let mut positions = quad();
        positions.insert(0, [5.0, 5.0, 5.0]); // unused vertex 0
        positions.push([2.0, 0.0, 0.0]); // vertex 5: on the line through 1 and 2
        let mesh = IndexedMesh::new(
            positions,
            vec![
                [1, 2, 3],
                [1, 1, 3], // degenerate
                [2, 3, 1], // duplicate of the first (rotation)
                [1, 3, 4],
                [1, 4, 3], // opposite twin of the previous: kept
                [1, 2, 5], // (0,0,0) (1,0,0) (2,0,0): zero area, kept
            ],
        );
        let cleaned = clean(&mesh, &CleanOptions::default()).unwrap();
        let r = cleaned.report;
        assert_eq!(
            (
                r.degenerate_triangles,
                r.duplicate_triangles,
                r.opposite_twins,
                r.zero_area_triangles
            ),
            (1, 1, 1, 1)
        );
        assert_eq!(r.unreferenced_vertices, 1);
        assert_eq!(cleaned.vertex_map, vec![1, 2, 3, 4, 5]);
        // Old vertex v is new v - 1; triangle order kept.
        assert_eq!(
            cleaned.mesh.triangles,
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 2], [0, 1, 4]]
        );
        assert_eq!(cleaned.mesh.positions[0], [0.0, 0.0, 0.0]);
        assert_eq!((r.output_vertices, r.output_triangles), (5, 4));
    }

    #[test]
    fn weld_merges_into_first_and_redrops() {
        let mut positions = quad();
        positions.push([1.0, 0.0, 0.0]); // 4 = copy of 1
        positions.push([-0.0, 0.0, 0.0]); // 5 = copy of 0 up to the sign of zero
        let mesh = IndexedMesh::new(positions, vec![[0, 1, 2], [5, 4, 2], [0, 2, 3], [1, 4, 3]]);
        let unwelded = clean(&mesh, &CleanOptions::default()).unwrap();
        assert!(unwelded.report.is_unchanged());
        let welded = clean(
            &mesh,
            &CleanOptions {
                weld: true,
                ..CleanOptions::default()
            },
        )
        .unwrap();
        let r = welded.report;
        assert_eq!(r.welded_vertices, 2);
        assert_eq!(r.duplicate_triangles, 1); // [5,4,2] became [0,1,2]
        assert_eq!(r.degenerate_triangles, 1); // [1,4,3] became [1,1,3]
        assert_eq!(welded.vertex_map, vec![0, 1, 2, 3]);
        assert_eq!(welded.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        let pose: Vec<[f32; 3]> = (0..6).map(|i| [i as f32; 3]).collect();
        assert_eq!(
            remap_positions(&pose, &welded.vertex_map).unwrap(),
            vec![[0.0; 3], [1.0; 3], [2.0; 3], [3.0; 3]]
        );
        assert_eq!(
            remap_positions(&pose[..2], &welded.vertex_map),
            Err(PoseTooShort {
                index: 2,
                vertices: 2
            })
        );
    }

    #[test]
    fn invalid_mesh_is_an_error() {
        let mesh = IndexedMesh::new(quad(), vec![[0, 1, 9]]);
        assert!(matches!(
            clean(&mesh, &CleanOptions::default()),
            Err(MeshError::IndexOutOfRange { index: 9, .. })
        ));
    }

    #[test]
    fn cow_has_one_weldable_pair() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cow.off");
        let cow = off::load(&path).unwrap();
        let plain = clean(&cow, &CleanOptions::default()).unwrap();
        assert!(plain.report.is_unchanged(), "{}", plain.report);
        assert_eq!(plain.mesh, cow);
        let welded = clean(
            &cow,
            &CleanOptions {
                weld: true,
                ..CleanOptions::default()
            },
        )
        .unwrap();
        assert_eq!(welded.report.welded_vertices, 1, "{}", welded.report);
        assert_eq!(welded.mesh.vertex_count(), 2903);
        assert_eq!(welded.mesh.triangle_count(), 5804);
        // Every kept triangle is the input triangle mapped through the weld.
        let pos = remap_positions(&cow.positions, &welded.vertex_map).unwrap();
        assert_eq!(pos, welded.mesh.positions);
    }
}
