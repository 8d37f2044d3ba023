//! Bijective embedding of a closed, manifold, genus-0 triangle mesh on the
//! unit sphere, after Praun & Hoppe's progressive approach, one file a stage
//! (this file holds the entry points, [`embed`] and [`radial`], the final
//! check and the supermesh's stage 2, [`embed_both`]):
//!
//! 1. [`collapse_to_tetrahedron`] (`collapse.rs`): half-edge collapses,
//!    shortest edge first, each allowed only under the link condition, until
//!    four vertices remain (every triangulated sphere but the tetrahedron has
//!    a collapsible edge, so this always gets there);
//! 2. [`place_tetrahedron`] (`split.rs`) on the sphere, positively oriented;
//! 3. [`split_all`] (`split.rs`): the collapses undone in reverse, each split
//!    vertex placed strictly inside the kernel of its one-ring polygon
//!    (`kernel.rs`), then a few relaxation sweeps over its neighbourhood, and
//!    global sweeps each time the vertex count has doubled (many at coarse
//!    levels, few at fine ones);
//! 4. [`relax`] (`relax.rs`) over the whole mesh, then [`verify`] with exact
//!    predicates; [`quality`] (`quality.rs`) measures how even it is.
//!
//! The relaxation is area-proportional (`area_target` in `relax.rs`):
//! each vertex moves so that the triangles of its fan share the fan's
//! spherical area as their surface areas share the fan's surface. At a coarse
//! level a triangle's surface area is read from the masses of its corners,
//! each the surface area of every vertex collapsed into it, so a limb keeps
//! its share of the sphere from the first levels on instead of being squeezed
//! to a point (as the plain umbrella operator, a Tutte embedding, does: 1e-17
//! sr triangles on man.off).
//!
//! Every position change is a move along a chord from the old point to the new
//! one that is accepted only when every incident triangle is strictly
//! positively oriented at the new point (exact `orient3d`). A triangle's
//! orientation is linear along such a chord, so it stays positive on the whole
//! way: the embedding deforms continuously without ever degenerating, and its
//! degree (one) is kept. Thin limbs therefore cannot fold, however small their
//! triangles become.

mod collapse;
mod kernel;
mod quality;
mod relax;
mod split;
#[cfg(test)]
mod tests;

use std::time::Instant;

use glam::DVec3;

use super::sphere::check_embedding;
use super::{Side, Stage, SupermeshError, SupermeshOptions};
use crate::mesh::clean::Cleaned;
use crate::mesh::IndexedMesh;

pub(crate) use collapse::build_rings;
pub(crate) use quality::quality;
pub use quality::EmbeddingQuality;
pub(crate) use relax::{move_vertex, relax, relax_vertex};

use collapse::collapse_to_tetrahedron;
use split::{place_tetrahedron, split_all};

/// Why an embedding failed (only on input the checks should have rejected).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum EmbedError {
    /// A vertex's triangles do not form one closed fan.
    NotManifold { vertex: u32 },
    /// No edge satisfied the link condition before four vertices were left.
    Stuck { vertices: usize },
    /// No point of a split vertex's kernel was found in floating point.
    NoKernelPoint { vertex: u32 },
    /// The final check found folded faces or a wrong total area.
    Folded { folds: usize },
}

/// Sweeps over a split vertex's neighbourhood.
pub(super) const LOCAL_SWEEPS: usize = 2;
/// Global sweeps each time the vertex count has doubled: about
/// `LEVEL_BUDGET / vertices` (at least `LEVEL_SWEEPS`, at most
/// `MAX_LEVEL_SWEEPS`), so coarse levels, where area moves across the whole
/// sphere in few steps, converge, for a cost of about `LEVEL_BUDGET` vertex
/// moves per level; and at the end.
pub(super) const LEVEL_SWEEPS: usize = 3;
pub(super) const MAX_LEVEL_SWEEPS: usize = 200;
pub(super) const LEVEL_BUDGET: usize = 200_000;
const FINAL_SWEEPS: usize = 8;

/// The central projection from the origin: each vertex's position as its
/// sphere direction, unnormalised (so points on a straight edge stay exactly
/// on its great circle). `Err(folds)` when some triangle is not strictly
/// positive seen from the origin or the total area is not 4π.
pub(crate) fn radial(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Result<Vec<DVec3>, usize> {
    let points: Vec<DVec3> = positions.iter().map(|&p| d3(p)).collect();
    let (folds, area) = check_embedding(&points, triangles);
    let four_pi = 4.0 * std::f64::consts::PI;
    if folds > 0 || (area - four_pi).abs() > 1e-6 * four_pi {
        return Err(folds.max(1));
    }
    Ok(points)
}

/// Each vertex's surface area: a third of the areas of its triangles.
pub(crate) fn vertex_masses(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<f64> {
    let mut mass = vec![0.0f64; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|v| d3(positions[v as usize]));
        let third = (b - a).cross(c - a).length() / 6.0;
        for &v in t {
            mass[v as usize] += third;
        }
    }
    mass
}

/// The sphere points of every vertex (unused vertices get the north pole).
pub(crate) fn embed(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    progress: &mut dyn FnMut(f32),
) -> Result<Vec<DVec3>, EmbedError> {
    let mut rings = build_rings(positions.len(), triangles)?;
    let hierarchy = collapse_to_tetrahedron(positions, &mut rings)?;
    progress(0.25);
    // Each vertex's surface area (a third of its triangles'), and while
    // collapsed, the sum over the vertices collapsed into it: the surface
    // each vertex of every level stands for.
    let mut mass = vertex_masses(positions, triangles);
    for k in 0..hierarchy.records.len() {
        let (u, ring) = hierarchy.ring(k);
        mass[ring[0] as usize] += mass[u as usize];
    }
    let mut points = vec![DVec3::Z; positions.len()];
    place_tetrahedron(&rings, &hierarchy, &mut points);
    split_all(&mut mass, &mut rings, &hierarchy, &mut points, progress)?;
    let all: Vec<u32> = (0..positions.len() as u32)
        .filter(|&v| !rings[v as usize].is_empty())
        .collect();
    relax(&mass, &rings, &mut points, &all, FINAL_SWEEPS);
    progress(1.0);
    verify(&points, triangles)?;
    Ok(points)
}

/// Exact final check: no folded face and a total area of 4π (degree one).
pub(crate) fn verify(points: &[DVec3], triangles: &[[u32; 3]]) -> Result<(), EmbedError> {
    let (folds, area) = check_embedding(points, triangles);
    let four_pi = 4.0 * std::f64::consts::PI;
    if folds > 0 || (area - four_pi).abs() > 1e-6 * four_pi {
        return Err(EmbedError::Folded {
            folds: folds.max(1),
        });
    }
    Ok(())
}

pub(super) fn d3(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// Both embeddings with their meshes.
pub(super) struct Embedded {
    pub(super) a: Vec<DVec3>,
    pub(super) b: Vec<DVec3>,
}

/// Stage 2: both embeddings, in parallel, each timed on its own.
pub(super) fn embed_both(
    ca: &Cleaned,
    cb: &Cleaned,
    options: &SupermeshOptions,
    seconds: &mut Vec<(Stage, f64)>,
) -> Result<Embedded, SupermeshError> {
    let progress = options.progress;
    let radial = options.radial;
    let one = |mesh: &IndexedMesh, stage: Stage, side: Side| {
        let start = Instant::now();
        let mut report = |f: f32| {
            if let Some(p) = progress {
                p(stage, f);
            }
        };
        report(0.0);
        let out = if radial {
            self::radial(&mesh.positions, &mesh.triangles).map_err(|folds| {
                SupermeshError::Embedding {
                    mesh: side,
                    what: format!(
                        "central projection from the origin folds {folds} triangle(s): the mesh is not star-shaped about the origin; turn SupermeshOptions::radial off"
                    ),
                }
            })
        } else {
            embed(&mesh.positions, &mesh.triangles, &mut report).map_err(|e| {
                SupermeshError::Embedding {
                    mesh: side,
                    what: format!("{e:?}"),
                }
            })
        };
        report(1.0);
        (out, start.elapsed().as_secs_f64())
    };
    let ((a, ta), (b, tb)) = rayon::join(
        || one(&ca.mesh, Stage::EmbedA, Side::A),
        || one(&cb.mesh, Stage::EmbedB, Side::B),
    );
    seconds.push((Stage::EmbedA, ta));
    seconds.push((Stage::EmbedB, tb));
    Ok(Embedded { a: a?, b: b? })
}
