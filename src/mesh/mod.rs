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
