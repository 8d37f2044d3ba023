//! The flat indexed triangle mesh every stage works on, its validation,
//! cleaning ([`clean`]) and adjacency ([`adjacency`]).
//!
//! Positions and triangles are plain arrays (`Vec<[f32; 3]>`, `Vec<[u32; 3]>`)
//! so they cast to GPU buffers with `bytemuck` and stay cache-friendly; no
//! stage builds a pointer-based half-edge graph.

pub mod adjacency;
pub mod clean;

use thiserror::Error;

/// A triangle mesh: vertex positions and counter-clockwise (front-facing) triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndexedMesh {
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// Why a mesh is not usable. Every variant names the offending element.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MeshError {
    #[error("the mesh is empty ({vertices} vertices, {triangles} triangles): give a file with at least one triangle")]
    Empty { vertices: usize, triangles: usize },
    #[error("vertex {vertex} has a non-finite coordinate {position:?}: fix or remove it in the source file")]
    NonFinite { vertex: usize, position: [f32; 3] },
    #[error("triangle {triangle} uses vertex {index}, but there are only {vertices} vertices")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertices: usize,
    },
    /// A pose given beside the mesh (for example to weld only copies that
    /// coincide in every pose) has another vertex count.
    #[error("pose {pose} has {vertices} vertices, but the mesh has {expected}: every pose needs one position per vertex")]
    PoseSize {
        pose: usize,
        vertices: usize,
        expected: usize,
    },
    #[error("the mesh has {vertices} vertices; morphlod indexes with u32 and reserves 0xFFFFFFFF as the strip restart, so at most 4294967294 are supported")]
    TooManyVertices { vertices: usize },
}

impl IndexedMesh {
    pub fn new(positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>) -> Self {
        Self {
            positions,
            triangles,
        }
    }

    /// The unit sphere around the origin as an icosahedron whose triangles are split in four
    /// `subdivisions` times, each new vertex pushed out onto the sphere: `10 · 4^s + 2`
    /// vertices, `20 · 4^s` triangles, counter-clockwise seen from outside, closed, genus 0.
    /// Memory grows fourfold per level (`s = 8`: 1.3 M triangles, ~25 MB).
    pub fn icosphere(subdivisions: u8) -> IndexedMesh {
        let phi = (1.0 + 5f64.sqrt()) / 2.0;
        let mut p: Vec<glam::DVec3> = [
            [-1.0, phi, 0.0],
            [1.0, phi, 0.0],
            [-1.0, -phi, 0.0],
            [1.0, -phi, 0.0],
            [0.0, -1.0, phi],
            [0.0, 1.0, phi],
            [0.0, -1.0, -phi],
            [0.0, 1.0, -phi],
            [phi, 0.0, -1.0],
            [phi, 0.0, 1.0],
            [-phi, 0.0, -1.0],
            [-phi, 0.0, 1.0],
        ]
        .map(|c| glam::DVec3::from_array(c).normalize())
        .to_vec();
        let mut t: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions {
            // One vertex per edge, shared by the edge's two triangles.
            let mut mid = std::collections::HashMap::new();
            let mut next = Vec::with_capacity(4 * t.len());
            for tri in &t {
                let m = [0, 1, 2].map(|i| {
                    let (a, b) = (tri[i].min(tri[(i + 1) % 3]), tri[i].max(tri[(i + 1) % 3]));
                    *mid.entry((a, b)).or_insert_with(|| {
                        p.push((p[a as usize] + p[b as usize]).normalize());
                        p.len() as u32 - 1
                    })
                });
                next.push([tri[0], m[0], m[2]]);
                next.push([m[0], tri[1], m[1]]);
                next.push([m[2], m[1], tri[2]]);
                next.push(m);
            }
            t = next;
        }
        IndexedMesh::new(p.iter().map(|q| q.as_vec3().to_array()).collect(), t)
    }

    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Checks what every later stage relies on: at least one triangle, finite
    /// coordinates, indices in range, and room for the strip restart index.
    /// Degenerate or duplicate triangles are not errors here; [`clean`] removes them.
    pub fn validate(&self) -> Result<(), MeshError> {
        if self.triangles.is_empty() || self.positions.is_empty() {
            return Err(MeshError::Empty {
                vertices: self.positions.len(),
                triangles: self.triangles.len(),
            });
        }
        if self.positions.len() >= u32::MAX as usize {
            return Err(MeshError::TooManyVertices {
                vertices: self.positions.len(),
            });
        }
        validate_positions(&self.positions)?;
        validate_indices(&self.triangles, self.positions.len())
    }

    /// Axis-aligned bounds `(min, max)`; `None` for a mesh without vertices.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        bounds(&self.positions)
    }
}

/// Fails on the first non-finite coordinate.
pub fn validate_positions(positions: &[[f32; 3]]) -> Result<(), MeshError> {
    match positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        Some(vertex) => Err(MeshError::NonFinite {
            vertex,
            position: positions[vertex],
        }),
        None => Ok(()),
    }
}

/// Fails on the first triangle with an index `>= vertex_count` (the error names it).
pub fn validate_indices(triangles: &[[u32; 3]], vertex_count: usize) -> Result<(), MeshError> {
    for (t, tri) in triangles.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertex_count) {
            return Err(MeshError::IndexOutOfRange {
                triangle: t,
                index,
                vertices: vertex_count,
            });
        }
    }
    Ok(())
}

/// Axis-aligned bounds `(min, max)` of a point set; `None` when it is empty.
pub fn bounds(positions: &[[f32; 3]]) -> Option<([f32; 3], [f32; 3])> {
    let first = *positions.first()?;
    Some(positions.iter().fold((first, first), |(lo, hi), p| {
        (
            [lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])],
            [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])],
        )
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Counts, a closed genus-0 surface on the unit sphere, wound outward (positive volume).
    #[test]
    fn icosphere_is_a_closed_unit_sphere_wound_outward() {
        for s in 0..4u8 {
            let mesh = IndexedMesh::icosphere(s);
            let k = 4usize.pow(u32::from(s));
            assert_eq!(
                (mesh.vertex_count(), mesh.triangle_count()),
                (10 * k + 2, 20 * k)
            );
            let report = crate::topology::analyze(&mesh).expect("valid mesh");
            assert!(report.is_closed_manifold(), "level {s}");
            assert_eq!(report.genus(), Some(0), "level {s}");
            for p in &mesh.positions {
                let r = glam::Vec3::from_array(*p).length();
                assert!((r - 1.0).abs() < 1e-6, "level {s}: radius {r}");
            }
            let volume: f32 = mesh
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| glam::Vec3::from_array(mesh.positions[i as usize]));
                    a.dot(b.cross(c)) / 6.0
                })
                .sum();
            // Below the ball's 4π/3 (the chords cut inside), above the icosahedron's 2.53.
            assert!(volume > 2.5 && volume < 4.19, "level {s}: volume {volume}");
        }
    }
}
