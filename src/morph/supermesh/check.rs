//! The input checks: each mesh is validated, cleaned (degenerate, duplicate
//! and unused elements dropped; vertices never welded, so positions and their
//! order are kept) and must then be one closed, manifold, genus-0 surface.

use super::landmarks::map_landmarks;
use super::{Side, SupermeshError, SupermeshOptions};
use crate::mesh::clean::{clean, CleanOptions, Cleaned};
use crate::mesh::IndexedMesh;
use crate::topology::analyze;

/// The cleaned mesh, or the first check it fails, as a typed error.
pub(crate) fn prepare(mesh: &IndexedMesh, side: Side) -> Result<Cleaned, SupermeshError> {
    let cleaned = clean(mesh, &CleanOptions::default())
        .map_err(|source| SupermeshError::InvalidMesh { mesh: side, source })?;
    let dropped = cleaned.report.degenerate_triangles;
    let report = analyze(&cleaned.mesh)
        .map_err(|source| SupermeshError::InvalidMesh { mesh: side, source })?;
    let closed = report.is_closed_manifold();
    if !closed && dropped > 0 {
        return Err(SupermeshError::DegenerateTriangles {
            mesh: side,
            count: dropped,
        });
    }
    if report.components != 1 {
        return Err(SupermeshError::Components {
            mesh: side,
            components: report.components,
        });
    }
    if report.non_manifold_edges > 0 || report.non_manifold_vertices > 0 {
        return Err(SupermeshError::NonManifold {
            mesh: side,
            edges: report.non_manifold_edges,
            vertices: report.non_manifold_vertices,
        });
    }
    if report.boundary_loops > 0 || report.boundary_edges > 0 {
        return Err(SupermeshError::Open {
            mesh: side,
            loops: report.boundary_loops,
            edges: report.boundary_edges,
        });
    }
    match report.genus() {
        Some(0) => {}
        Some(genus) => return Err(SupermeshError::Genus { mesh: side, genus }),
        None => {
            return Err(SupermeshError::NonManifold {
                mesh: side,
                edges: report.non_manifold_edges,
                vertices: report.non_manifold_vertices,
            })
        }
    }
    // Two triangles back to back (3 vertices) are closed and genus 0 but flat.
    if cleaned.mesh.vertex_count() < 4 {
        return Err(SupermeshError::TooSmall {
            mesh: side,
            vertices: cleaned.mesh.vertex_count(),
        });
    }
    Ok(cleaned)
}

/// Stage 1: both meshes cleaned and checked, landmarks mapped to cleaned indices.
#[allow(clippy::type_complexity)]
pub(super) fn check_inputs(
    a: &IndexedMesh,
    b: &IndexedMesh,
    options: &SupermeshOptions,
) -> Result<(Cleaned, Cleaned, Vec<(u32, u32)>), SupermeshError> {
    let ca = prepare(a, Side::A)?;
    let cb = prepare(b, Side::B)?;
    let landmarks = map_landmarks(&options.landmarks, (a, &ca), (b, &cb))?;
    Ok((ca, cb, landmarks))
}
