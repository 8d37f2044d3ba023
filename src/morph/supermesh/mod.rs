//! The supermesh of two closed genus-0 meshes of different connectivity: one
//! triangulation `T` with a pose `V(0)` that is exactly A's surface and a pose
//! `V(1)` that is exactly B's, so that a [`Morph`] can blend them (paper 004,
//! section 3.1; Kent et al. 1992, Alexa 1999).
//!
//! When A and B share their connectivity (the same vertex count and the same
//! triangles, as two poses of one mesh: [`crate::morph::same_connectivity`]),
//! [`Supermesh::build`] uses it directly: the supermesh is A's triangulation
//! with `V(0) = A` and `V(1) = B` bit for bit, every vertex
//! [`Origin::Both`] with itself, and [`SupermeshReport::connectivity`] says
//! so ([`Connectivity::Same`]). The same triangles in another vertex order
//! are found after the alignment (`renumbered.rs`,
//! [`Connectivity::Renumbered`]). Otherwise it runs these stages, each in
//! its own file (this file holds the output types, the errors and the run of
//! the stages; `options.rs` the options and the stage names, `report.rs` the
//! report):
//!
//! 1. [`Stage::Check`] (`check.rs`): clean each mesh and require one closed,
//!    manifold, genus-0 surface; anything else is a typed [`SupermeshError`]
//!    that names the check and the fix. Landmark pairs are mapped to the
//!    cleaned meshes (`landmarks.rs`, which also reads the landmarks file).
//! 2. [`Stage::EmbedA`], [`Stage::EmbedB`] (`embed.rs`): a bijective embedding
//!    of each mesh on the unit sphere (collapse to a tetrahedron, split back
//!    with every step fold-rejecting by exact predicates). Both run at once.
//! 3. [`Stage::Align`] (`alignment.rs`, over `align.rs` and `mobius.rs`):
//!    normalise both shapes, rotate B's sphere to match equal sphere points,
//!    or move it by the Möbius map of a pairing of the limb tips when that
//!    matches better (`tips.rs`, [`TipReport`]), or map landmark pairs
//!    together.
//! 4. [`Stage::Refine`] (`refine.rs`, over `align.rs`'s `refine`): every
//!    vertex of either mesh slides on its sphere toward lower D (the
//!    correspondence measure's objective), fold-rejecting, landmarks pinned.
//! 5. [`Stage::Overlay`] (`overlay.rs`): after a tiny seeded random rotation of
//!    B's sphere (so A and B points are practically in general position),
//!    intersect every A face with every B face it overlaps, exactly (with
//!    Simulation of Simplicity for what coincides), fan-triangulate the
//!    convex pieces, and merge coincident vertices.
//! 6. [`Stage::Positions`] (`positions.rs`): `V(0)` and `V(1)` of every
//!    supermesh vertex by projective barycentrics (A's vertices keep their
//!    position bit for bit in `V(0)`, B's in `V(1)`).
//!
//! Vertex count: every A vertex, every B vertex and every crossing of an A
//! edge with a B edge is one supermesh vertex, except that a B vertex exactly
//! on an A vertex is one vertex with both origins ([`Origin::Both`]):
//! `V = V_A + V_B − coincident + crossings`. Coincidences are handled
//! exactly, not avoided: the overlay decides every orientation under
//! Simulation of Simplicity, then merges what the symbolic perturbation
//! separated (a B vertex on an A vertex, crossings at a vertex lying on the
//! other mesh's edge, crossings of overlapping edges) and flips away
//! zero-area triangles; so the same mesh overlaid on itself with
//! [`SupermeshOptions::perturb`] off is the mesh itself. The tiny random
//! rotation (on by default) just makes such cases rare on real input.
//! [`SupermeshError::Degenerate`] is left for a merge that cannot be
//! completed (not expected).

mod align;
mod alignment;
mod check;
mod embed;
mod landmarks;
mod measure;
mod mobius;
mod options;
mod overlay;
mod positions;
mod refine;
mod renumbered;
mod report;
mod sphere;
#[cfg(test)]
mod tests;
mod tips;

use std::time::Instant;

use glam::DVec3;
use thiserror::Error;

pub use align::Residual;
pub use alignment::limb_tips;
pub use embed::EmbeddingQuality;
pub use landmarks::{parse_landmarks, LandmarkParseError, Landmarks};
pub use measure::{fit_b_onto_a, measure, Correspondence, Distortion, Placement, MEASURED_T};
pub use options::{Side, Stage, SupermeshOptions};
pub use overlay::OVERLAY_ATTEMPTS;
pub use report::{AlignmentReport, Connectivity, SupermeshReport, TipPair, TipReport};

use crate::mesh::clean::Cleaned;
use crate::mesh::{IndexedMesh, MeshError};
use crate::morph::{same_connectivity, Morph, MorphError};

use alignment::{align_b, final_residual, input_indices, Tables};
use check::check_inputs;
use embed::{embed_both, Embedded};
use overlay::overlay_with_retries;
use positions::assemble;
use refine::refine_alignment;

/// The supermesh algorithm's version: raised whenever the same inputs and options give a
/// different supermesh (2: the embedding rework with umbrella weight 1.0; 3: Möbius
/// normalisation, rotation scored by D, Möbius landmark fit; 4: a shared
/// connectivity used directly, the embeddings relaxed after the landmark
/// drag; 5: Möbius maps applied to all vertices at once, the landmarks'
/// Möbius fit applied whole, the refinement stage; 6: limb tips paired,
/// the best pairings' Möbius maps descended by D against the rotation
/// search). Caches of built supermesh morphs put it in their key.
pub const ALGORITHM_VERSION: u32 = 6;

/// Where a supermesh vertex comes from; indices are those of the input meshes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// Vertex of A: `v0` is its A position, bit for bit.
    A(u32),
    /// Vertex of B: `v1` is its B position, bit for bit.
    B(u32),
    /// Vertex `a` of A and vertex `b` of B at exactly the same sphere point,
    /// merged: `v0` is A's position and `v1` B's, both bit for bit.
    Both { a: u32, b: u32 },
    /// Crossing of A's edge `a_edge` with B's edge `b_edge` (low index first).
    Crossing { a_edge: [u32; 2], b_edge: [u32; 2] },
}

/// Why no supermesh was built. Each message names the check that failed and
/// what to do about it.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SupermeshError {
    #[error("mesh {mesh} is not a valid mesh: {source}")]
    InvalidMesh {
        mesh: Side,
        #[source]
        source: MeshError,
    },
    #[error("mesh {mesh} is open: {loops} boundary loop(s), {edges} boundary edges; a supermesh needs closed surfaces: fill the holes (e.g. in MeshLab, Filters > Remeshing > Close Holes) before morphing")]
    Open {
        mesh: Side,
        loops: usize,
        edges: usize,
    },
    #[error("mesh {mesh} has genus {genus} ({genus} handle(s)); the spherical embedding needs genus 0: close the handles or use a sphere-like mesh")]
    Genus { mesh: Side, genus: i64 },
    #[error("mesh {mesh} is not manifold: {edges} non-manifold edge(s), {vertices} non-manifold vertex(es); split or remove the offending triangles so every edge has two triangles and every vertex one fan")]
    NonManifold {
        mesh: Side,
        edges: usize,
        vertices: usize,
    },
    #[error("mesh {mesh} has {components} connected components; a supermesh needs one closed surface: keep one component or merge them into one surface")]
    Components { mesh: Side, components: usize },
    #[error("mesh {mesh} has {count} degenerate triangle(s) (a repeated vertex); cleaning drops them, but what is left is not a closed surface: rebuild those triangles in the source file")]
    DegenerateTriangles { mesh: Side, count: usize },
    #[error("mesh {mesh} has only {vertices} vertices; a closed surface needs at least 4 (a tetrahedron)")]
    TooSmall { mesh: Side, vertices: usize },
    #[error("landmark pair {pair}: vertex {vertex} of mesh {mesh} is out of range (it has {vertices} vertices); landmark indices count from 0 in the file's vertex order")]
    LandmarkOutOfRange {
        pair: usize,
        mesh: Side,
        vertex: u32,
        vertices: usize,
    },
    #[error("landmark pair {pair}: vertex {vertex} of mesh {mesh} is used by no triangle; pick a vertex of the surface")]
    LandmarkUnused {
        pair: usize,
        mesh: Side,
        vertex: u32,
    },
    #[error("landmark pairs {first} and {second} use {mesh} vertex {vertex} twice; a vertex can correspond to one vertex of the other mesh only: drop or fix one of the pairs")]
    LandmarkRepeated {
        first: usize,
        second: usize,
        mesh: Side,
        vertex: u32,
    },
    #[error("landmark pair {pair} could not be brought onto its partner without folding B's embedding (still {angle:.3} rad apart on the sphere): the pairs contradict each other (their order around a neighbouring pair differs between the meshes, or two pairs are swapped); check this pair and its neighbours, or drop it")]
    LandmarkUnreached { pair: usize, angle: f64 },
    #[error(
        "the spherical embedding of mesh {mesh} failed ({what}); please report this with the mesh"
    )]
    Embedding { mesh: Side, what: String },
    #[error("coincident A and B points could not be merged in {attempts} attempt(s); turn the random rotation on (SupermeshOptions::perturb) or change its seed, and please report this with the meshes")]
    Degenerate { attempts: usize },
    #[error("the overlay did not close between A face {a_face} and B face {b_face}; please report this with the meshes")]
    Overlay { a_face: u32, b_face: u32 },
}

impl SupermeshError {
    /// The landmark pair (0-based, in the order given) an error is about.
    pub fn landmark_pair(&self) -> Option<usize> {
        match *self {
            SupermeshError::LandmarkOutOfRange { pair, .. }
            | SupermeshError::LandmarkUnused { pair, .. }
            | SupermeshError::LandmarkUnreached { pair, .. } => Some(pair),
            SupermeshError::LandmarkRepeated { second, .. } => Some(second),
            _ => None,
        }
    }
}

/// One triangulation with a pose on A and a pose on B.
#[derive(Clone, Debug, PartialEq)]
pub struct Supermesh {
    pub triangles: Vec<[u32; 3]>,
    /// Positions on A (`t = 0`).
    pub v0: Vec<[f32; 3]>,
    /// Positions on B (`t = 1`).
    pub v1: Vec<[f32; 3]>,
    pub origins: Vec<Origin>,
    /// Each vertex's point on the sphere (A's embedding; B's as overlaid);
    /// empty when A and B share their connectivity (nothing is embedded).
    pub sphere: Vec<DVec3>,
}

/// Wall-clock per stage and the progress callback.
struct Stages<'a> {
    progress: Option<&'a (dyn Fn(Stage, f32) + Sync)>,
    seconds: Vec<(Stage, f64)>,
}

impl Stages<'_> {
    fn run<T>(&mut self, stage: Stage, f: impl FnOnce() -> T) -> T {
        self.report(stage, 0.0);
        let start = Instant::now();
        let out = f();
        self.seconds.push((stage, start.elapsed().as_secs_f64()));
        self.report(stage, 1.0);
        out
    }

    fn report(&self, stage: Stage, fraction: f32) {
        if let Some(p) = self.progress {
            p(stage, fraction);
        }
    }
}

impl Supermesh {
    /// Builds the supermesh of `a` and `b` (see the module docs for the
    /// stages), or takes their shared connectivity as it is.
    pub fn build(
        a: &IndexedMesh,
        b: &IndexedMesh,
        options: &SupermeshOptions,
    ) -> Result<(Supermesh, SupermeshReport), SupermeshError> {
        if options.reuse_connectivity
            && options.landmarks.iter().all(|&(la, lb)| la == lb)
            && same_connectivity(a, b).is_ok()
        {
            return Supermesh::shared(a, b);
        }
        let mut stages = Stages {
            progress: options.progress,
            seconds: Vec::new(),
        };
        let (ca, cb, landmarks) = stages.run(Stage::Check, || check_inputs(a, b, options))?;
        let mut embedded = embed_both(&ca, &cb, options, &mut stages.seconds)?;
        // The same triangles in another vertex order: the renumbering, from
        // the landmarks, or else from the aligned embeddings.
        let same_size = options.reuse_connectivity
            && ca.mesh.vertex_count() == cb.mesh.vertex_count()
            && ca.mesh.triangle_count() == cb.mesh.triangle_count();
        let agrees = |map: &Vec<u32>| landmarks.iter().all(|&(la, lb)| map[la as usize] == lb);
        if same_size && !landmarks.is_empty() {
            let seeds: Vec<(u32, Vec<u32>)> =
                landmarks.iter().map(|&(la, lb)| (la, vec![lb])).collect();
            if let Some(map) = renumbered::find(&ca.mesh, &cb.mesh, &seeds).filter(agrees) {
                let alignment = AlignmentReport::default();
                return Ok(renumbered_supermesh(
                    &ca,
                    &cb,
                    &embedded,
                    &map,
                    alignment,
                    stages.seconds,
                ));
            }
        }
        let (tables, (mut b_aligned, mut alignment, turn, mut tips)) =
            stages.run(Stage::Align, || {
                let tables = [
                    Tables::new(&ca.mesh, Side::A)?,
                    Tables::new(&cb.mesh, Side::B)?,
                ];
                let [ta, tb] = &tables;
                let aligned = align_b(
                    (&ca.mesh, ta),
                    (&cb.mesh, tb),
                    &mut embedded,
                    &landmarks,
                    options,
                )?;
                Ok::<_, SupermeshError>((tables, aligned))
            })?;
        let [ta, tb] = &tables;
        if let Some(tips) = &mut tips {
            input_indices(tips, &ca, &cb);
        }
        if same_size && landmarks.is_empty() {
            let mut seeds = renumbered::colour_seeds(&ca.mesh, &cb.mesh);
            seeds.extend(renumbered::sphere_seeds(&embedded.a, &b_aligned));
            if let Some(map) = renumbered::find(&ca.mesh, &cb.mesh, &seeds) {
                alignment.after = final_residual((ta, &embedded.a), (&cb.mesh, tb, &b_aligned));
                let (supermesh, report) =
                    renumbered_supermesh(&ca, &cb, &embedded, &map, alignment, stages.seconds);
                return Ok((supermesh, SupermeshReport { tips, ..report }));
            }
        }
        if options.align && !options.radial {
            stages.run(Stage::Refine, || {
                refine_alignment(
                    (&ca.mesh, ta, &mut embedded.a),
                    (&cb.mesh, tb, &mut b_aligned),
                    &landmarks,
                    turn,
                )
            });
        }
        let (overlay, b_sphere, attempts) = stages.run(Stage::Overlay, || {
            overlay_with_retries(
                &ca.mesh,
                &embedded.a,
                &cb.mesh,
                b_aligned,
                !landmarks.is_empty(),
                options,
            )
        })?;
        alignment.after = final_residual((ta, &embedded.a), (&cb.mesh, tb, &b_sphere));
        if !landmarks.is_empty() {
            alignment.landmarks_after =
                Some(align::landmark_angles(&embedded.a, &b_sphere, &landmarks));
        }
        let supermesh = stages.run(Stage::Positions, || {
            assemble(&ca, &cb, &embedded.a, &b_sphere, &overlay)
        });
        let report = SupermeshReport {
            crossings: overlay.crossings,
            coincident: overlay.coincident,
            overlay_attempts: attempts,
            alignment,
            tips,
            stage_seconds: stages.seconds,
            ..report(&ca, &cb, &embedded, &supermesh)
        };
        Ok((supermesh, report))
    }

    /// Two poses of one connectivity: A's triangles, `V(0) = A`, `V(1) = B`.
    fn shared(
        a: &IndexedMesh,
        b: &IndexedMesh,
    ) -> Result<(Supermesh, SupermeshReport), SupermeshError> {
        for (mesh, side) in [(a, Side::A), (b, Side::B)] {
            mesh.validate()
                .map_err(|source| SupermeshError::InvalidMesh { mesh: side, source })?;
        }
        let n = a.vertex_count() as u32;
        let supermesh = Supermesh {
            triangles: a.triangles.clone(),
            v0: a.positions.clone(),
            v1: b.positions.clone(),
            origins: (0..n).map(|v| Origin::Both { a: v, b: v }).collect(),
            sphere: Vec::new(),
        };
        let report = SupermeshReport {
            connectivity: Connectivity::Same,
            a_vertices: a.vertex_count(),
            a_triangles: a.triangle_count(),
            b_vertices: b.vertex_count(),
            b_triangles: b.triangle_count(),
            vertices: a.vertex_count(),
            triangles: a.triangle_count(),
            coincident: a.vertex_count(),
            correspondence: measure(&supermesh.triangles, &supermesh.v0, &supermesh.v1),
            ..SupermeshReport::default()
        };
        Ok((supermesh, report))
    }

    pub fn vertex_count(&self) -> usize {
        self.v0.len()
    }

    /// The two-pose morph `V(t) = (1 − t) V(0) + t V(1)` over the supermesh.
    pub fn to_morph(&self) -> Result<Morph, MorphError> {
        Morph::from_poses(self.triangles.clone(), self.v0.clone(), self.v1.clone())
    }
}

/// The report's fields that follow from the inputs, the embeddings and the
/// supermesh (the overlay's counts, the alignment and the times left at 0).
fn report(
    ca: &Cleaned,
    cb: &Cleaned,
    embedded: &Embedded,
    supermesh: &Supermesh,
) -> SupermeshReport {
    let (fold_overs, sphere_area) =
        sphere::check_embedding(&supermesh.sphere, &supermesh.triangles);
    SupermeshReport {
        a_vertices: ca.mesh.vertex_count(),
        a_triangles: ca.mesh.triangle_count(),
        b_vertices: cb.mesh.vertex_count(),
        b_triangles: cb.mesh.triangle_count(),
        vertices: supermesh.v0.len(),
        triangles: supermesh.triangles.len(),
        fold_overs,
        sphere_area,
        embedding: [
            embed::quality(&embedded.a, &ca.mesh.positions, &ca.mesh.triangles),
            embed::quality(&embedded.b, &cb.mesh.positions, &cb.mesh.triangles),
        ],
        correspondence: measure(&supermesh.triangles, &supermesh.v0, &supermesh.v1),
        ..SupermeshReport::default()
    }
}

/// A's triangulation with B's vertices renumbered by `map` (A vertex `i` is
/// B vertex `map[i]`, cleaned indices): `V(0) = A`, `V(1) = B` bit for bit,
/// every vertex of both ([`Origin::Both`]), on A's sphere embedding.
fn renumbered_supermesh(
    ca: &Cleaned,
    cb: &Cleaned,
    embedded: &Embedded,
    map: &[u32],
    alignment: AlignmentReport,
    stage_seconds: Vec<(Stage, f64)>,
) -> (Supermesh, SupermeshReport) {
    let supermesh = Supermesh {
        triangles: ca.mesh.triangles.clone(),
        v0: ca.mesh.positions.clone(),
        v1: map.iter().map(|&m| cb.mesh.positions[m as usize]).collect(),
        origins: map
            .iter()
            .enumerate()
            .map(|(i, &m)| Origin::Both {
                a: ca.vertex_map[i],
                b: cb.vertex_map[m as usize],
            })
            .collect(),
        sphere: embedded.a.clone(),
    };
    let report = SupermeshReport {
        connectivity: Connectivity::Renumbered,
        coincident: map.len(),
        alignment,
        stage_seconds,
        ..report(ca, cb, embedded, &supermesh)
    };
    (supermesh, report)
}
