//! The supermesh of two closed genus-0 meshes of different connectivity: one
//! triangulation `T` with a pose `V(0)` that is exactly A's surface and a pose
//! `V(1)` that is exactly B's, so that a [`Morph`] can blend them (paper 004,
//! section 3.1; Kent et al. 1992, Alexa 1999).
//!
//! [`Supermesh::build`] runs these stages, each in its own file:
//!
//! 1. [`Stage::Check`] (`check.rs`): clean each mesh and require one closed,
//!    manifold, genus-0 surface; anything else is a typed [`SupermeshError`]
//!    that names the check and the fix.
//! 2. [`Stage::EmbedA`], [`Stage::EmbedB`] (`embed.rs`): a bijective embedding
//!    of each mesh on the unit sphere (collapse to a tetrahedron, split back
//!    with every step fold-rejecting by exact predicates). Both run at once.
//! 3. [`Stage::Align`] (`align.rs`): normalise both shapes, rotate B's sphere
//!    to match equal sphere points, optionally pull landmark pairs together.
//! 4. [`Stage::Overlay`] (`overlay.rs`): after a tiny seeded random rotation of
//!    B's sphere (so A and B points are practically in general position),
//!    intersect every A face with every B face it overlaps, exactly (with
//!    Simulation of Simplicity for what coincides), fan-triangulate the
//!    convex pieces, and merge coincident vertices.
//! 5. [`Stage::Positions`] (`positions.rs`): `V(0)` and `V(1)` of every
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
mod check;
mod embed;
mod overlay;
mod positions;
mod sphere;

use std::fmt;
use std::time::Instant;

use glam::{DMat3, DVec3};
use thiserror::Error;

pub use align::Residual;
pub use embed::EmbeddingQuality;

use crate::mesh::clean::Cleaned;
use crate::mesh::{IndexedMesh, MeshError};
use crate::morph::{Morph, MorphError};

use overlay::{Node, OverlayError};
use sphere::SphereMesh;

/// The supermesh algorithm's version: raised whenever the same inputs and options give a
/// different supermesh (2: the embedding rework with umbrella weight 1.0). Caches of built
/// supermesh morphs put it in their key.
pub const ALGORITHM_VERSION: u32 = 2;

/// How many random rotations the overlay tries before giving up on input
/// that stays degenerate.
pub const OVERLAY_ATTEMPTS: usize = 8;

/// Smallest angle (radians) of the random rotation of B's sphere; the angle
/// is drawn in `[MIN, 2 MIN)`. Small enough not to undo the alignment.
const PERTURBATION: f64 = 2e-3;

/// Which input mesh a message is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Side {
    A,
    B,
}

impl fmt::Display for Side {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Side::A => "A",
            Side::B => "B",
        })
    }
}

/// The stages of [`Supermesh::build`], in order, for progress and timing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    Check,
    EmbedA,
    EmbedB,
    Align,
    Overlay,
    Positions,
}

impl Stage {
    pub const ALL: [Stage; 6] = [
        Stage::Check,
        Stage::EmbedA,
        Stage::EmbedB,
        Stage::Align,
        Stage::Overlay,
        Stage::Positions,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Check => "check",
            Stage::EmbedA => "embed A",
            Stage::EmbedB => "embed B",
            Stage::Align => "align",
            Stage::Overlay => "overlay",
            Stage::Positions => "positions",
        }
    }
}

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

/// Choices for [`Supermesh::build`].
#[derive(Clone)]
pub struct SupermeshOptions<'a> {
    /// Pairs (vertex of A, vertex of B) pulled together on the sphere.
    pub landmarks: Vec<(u32, u32)>,
    /// Seed of the random rotation of B's sphere (deterministic).
    pub seed: u64,
    /// Whether B's sphere gets a tiny random rotation before the overlay
    /// (on by default; off keeps exact coincidences, which are merged).
    pub perturb: bool,
    /// Whether B's sphere is rotated to match the shapes (on by default).
    pub align: bool,
    /// Embed each mesh by central projection from the origin instead of
    /// the collapse-and-split embedding (off by default): for meshes that
    /// are star-shaped about the origin (every triangle positive seen from
    /// it, checked exactly; otherwise [`SupermeshError::Embedding`]), e.g. a
    /// mesh and its refinement, whose shared points then coincide exactly on
    /// the sphere.
    pub radial: bool,
    /// Called with each stage and its progress in `[0, 1]`; may be called
    /// from two threads at once (the embeddings run in parallel).
    pub progress: Option<&'a (dyn Fn(Stage, f32) + Sync)>,
}

impl Default for SupermeshOptions<'_> {
    fn default() -> Self {
        Self {
            landmarks: Vec::new(),
            seed: 0x6d6f_7270_686c_6f64,
            perturb: true,
            align: true,
            radial: false,
            progress: None,
        }
    }
}

impl fmt::Debug for SupermeshOptions<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SupermeshOptions")
            .field("landmarks", &self.landmarks)
            .field("seed", &self.seed)
            .field("perturb", &self.perturb)
            .field("align", &self.align)
            .field("radial", &self.radial)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

/// Alignment quality: distances between A's normalised vertices and B's
/// normalised surface at the same sphere point (units: the RMS radius of each
/// normalised shape), before any rotation and as overlaid; for landmarks, the
/// angles (radians) between each pair's sphere points, before any rotation
/// and after the pull (before the overlay's tiny random rotation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AlignmentReport {
    pub before: Residual,
    pub after: Residual,
    pub landmarks_before: Option<Residual>,
    pub landmarks_after: Option<Residual>,
}

/// What [`Supermesh::build`] made and how long each stage took.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SupermeshReport {
    pub a_vertices: usize,
    pub a_triangles: usize,
    pub b_vertices: usize,
    pub b_triangles: usize,
    pub vertices: usize,
    pub triangles: usize,
    /// Supermesh vertices on an A edge and a B edge.
    pub crossings: usize,
    /// B vertices exactly on an A vertex, merged with it ([`Origin::Both`]):
    /// `vertices = V_A + V_B − coincident + crossings`.
    pub coincident: usize,
    /// Supermesh triangles not strictly positive on the sphere (exact); 0.
    pub fold_overs: usize,
    /// Sum of the supermesh triangles' spherical areas (4π when bijective).
    pub sphere_area: f64,
    /// Random rotations the overlay needed (1 unless input was degenerate).
    pub overlay_attempts: usize,
    pub alignment: AlignmentReport,
    /// Evenness of A's and B's sphere embeddings.
    pub embedding: [EmbeddingQuality; 2],
    /// Wall time of each stage in seconds (the two embeddings run at once).
    pub stage_seconds: Vec<(Stage, f64)>,
}

impl SupermeshReport {
    /// `V_A + V_B + 6.6 √(V_A V_B)`: the expected size for near-uniform inputs.
    pub fn estimated_vertices(&self) -> f64 {
        let (a, b) = (self.a_vertices as f64, self.b_vertices as f64);
        a + b + 6.6 * (a * b).sqrt()
    }
}

impl fmt::Display for SupermeshReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "  A                 {} vertices, {} triangles",
            self.a_vertices, self.a_triangles
        )?;
        writeln!(
            f,
            "  B                 {} vertices, {} triangles",
            self.b_vertices, self.b_triangles
        )?;
        writeln!(
            f,
            "  supermesh         {} vertices, {} triangles (estimate {:.0} vertices)",
            self.vertices,
            self.triangles,
            self.estimated_vertices()
        )?;
        writeln!(
            f,
            "  crossings         {} (coincident vertices merged: {})",
            self.crossings, self.coincident
        )?;
        writeln!(
            f,
            "  fold-overs        {} (sphere area {:.9} = 4π · {:.9})",
            self.fold_overs,
            self.sphere_area,
            self.sphere_area / (4.0 * std::f64::consts::PI)
        )?;
        for (side, q) in ["A", "B"].iter().zip(&self.embedding) {
            writeln!(
                f,
                "  embedding {side}       min triangle {:.2e} sr (mean {:.2e}), area distortion p5 {:.3} p50 {:.3} p95 {:.3}",
                q.min_area, q.mean_area, q.distortion[0], q.distortion[1], q.distortion[2]
            )?;
        }
        let a = &self.alignment;
        writeln!(
            f,
            "  alignment         mean {:.4} max {:.4} before, mean {:.4} max {:.4} after (RMS radius units)",
            a.before.mean, a.before.max, a.after.mean, a.after.max
        )?;
        if let (Some(b), Some(c)) = (a.landmarks_before, a.landmarks_after) {
            writeln!(
                f,
                "  landmarks         mean {:.4} max {:.4} rad before, mean {:.4} max {:.4} rad after",
                b.mean, b.max, c.mean, c.max
            )?;
        }
        write!(f, "  stages           ")?;
        for (stage, s) in &self.stage_seconds {
            write!(f, " {} {:.3} s,", stage.name(), s)?;
        }
        write!(f, " overlay attempts {}", self.overlay_attempts)
    }
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
    #[error("landmark pairs {first} and {second} use B vertex {vertex} twice; each vertex can be pulled toward one place only")]
    LandmarkRepeated {
        first: usize,
        second: usize,
        vertex: u32,
    },
    #[error(
        "the spherical embedding of mesh {mesh} failed ({what}); please report this with the mesh"
    )]
    Embedding { mesh: Side, what: String },
    #[error("coincident A and B points could not be merged in {attempts} attempt(s); turn the random rotation on (SupermeshOptions::perturb) or change its seed, and please report this with the meshes")]
    Degenerate { attempts: usize },
    #[error("the overlay did not close between A face {a_face} and B face {b_face}; please report this with the meshes")]
    Overlay { a_face: u32, b_face: u32 },
}

/// A line of a landmarks file that is not `vertex_in_a vertex_in_b`.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
#[error("landmarks line {line}: expected two vertex indices `vertex_in_a vertex_in_b` (non-negative integers, `#` starts a comment), found {found:?}")]
pub struct LandmarkParseError {
    /// 1-based line number.
    pub line: usize,
    pub found: String,
}

/// Parses a landmarks file: one pair `vertex_in_a vertex_in_b` a line,
/// whitespace-separated; blank lines and everything after `#` are ignored.
pub fn parse_landmarks(text: &str) -> Result<Vec<(u32, u32)>, LandmarkParseError> {
    let mut pairs = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let parsed = match fields.as_slice() {
            [a, b] => a.parse::<u32>().ok().zip(b.parse::<u32>().ok()),
            _ => None,
        };
        match parsed {
            Some(pair) => pairs.push(pair),
            None => {
                return Err(LandmarkParseError {
                    line: k + 1,
                    found: raw.trim().to_string(),
                })
            }
        }
    }
    Ok(pairs)
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
    /// Each vertex's point on the sphere (A's embedding; B's as overlaid).
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

/// Both embeddings with their meshes.
struct Embedded {
    a: Vec<DVec3>,
    b: Vec<DVec3>,
}

impl Supermesh {
    /// Builds the supermesh of `a` and `b` (see the module docs for the stages).
    pub fn build(
        a: &IndexedMesh,
        b: &IndexedMesh,
        options: &SupermeshOptions,
    ) -> Result<(Supermesh, SupermeshReport), SupermeshError> {
        let mut stages = Stages {
            progress: options.progress,
            seconds: Vec::new(),
        };
        let (ca, cb, landmarks) = stages.run(Stage::Check, || check_inputs(a, b, options))?;
        let embedded = embed_both(&ca, &cb, options, &mut stages.seconds)?;
        let (b_aligned, mut alignment) = stages.run(Stage::Align, || {
            align_b(&ca.mesh, &cb.mesh, &embedded, &landmarks, options)
        })?;
        let (overlay, b_sphere, attempts) = stages.run(Stage::Overlay, || {
            overlay_with_retries(&ca.mesh, &embedded.a, &cb.mesh, b_aligned, options)
        })?;
        alignment.after = final_residual(&ca.mesh, &cb.mesh, &embedded.a, &b_sphere);
        let supermesh = stages.run(Stage::Positions, || {
            assemble(&ca, &cb, &embedded.a, &b_sphere, &overlay)
        });
        let (fold_overs, sphere_area) =
            sphere::check_embedding(&supermesh.sphere, &supermesh.triangles);
        let report = SupermeshReport {
            a_vertices: ca.mesh.vertex_count(),
            a_triangles: ca.mesh.triangle_count(),
            b_vertices: cb.mesh.vertex_count(),
            b_triangles: cb.mesh.triangle_count(),
            vertices: supermesh.v0.len(),
            triangles: supermesh.triangles.len(),
            crossings: overlay.crossings,
            coincident: overlay.coincident,
            fold_overs,
            sphere_area,
            overlay_attempts: attempts,
            alignment,
            embedding: [
                embed::quality(&embedded.a, &ca.mesh.positions, &ca.mesh.triangles),
                embed::quality(&embedded.b, &cb.mesh.positions, &cb.mesh.triangles),
            ],
            stage_seconds: stages.seconds,
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

/// Stage 1: both meshes cleaned and checked, landmarks mapped to cleaned indices.
#[allow(clippy::type_complexity)]
fn check_inputs(
    a: &IndexedMesh,
    b: &IndexedMesh,
    options: &SupermeshOptions,
) -> Result<(Cleaned, Cleaned, Vec<(u32, u32)>), SupermeshError> {
    let ca = check::prepare(a, Side::A)?;
    let cb = check::prepare(b, Side::B)?;
    let landmarks = map_landmarks(&options.landmarks, (a, &ca), (b, &cb))?;
    Ok((ca, cb, landmarks))
}

fn map_landmarks(
    pairs: &[(u32, u32)],
    a: (&IndexedMesh, &Cleaned),
    b: (&IndexedMesh, &Cleaned),
) -> Result<Vec<(u32, u32)>, SupermeshError> {
    let inverse = |input: &IndexedMesh, cleaned: &Cleaned| {
        let mut map = vec![u32::MAX; input.vertex_count()];
        for (new, &old) in cleaned.vertex_map.iter().enumerate() {
            map[old as usize] = new as u32;
        }
        map
    };
    let (ia, ib) = (inverse(a.0, a.1), inverse(b.0, b.1));
    let mut out = Vec::with_capacity(pairs.len());
    let mut used_b: std::collections::HashMap<u32, usize> = Default::default();
    for (pair, &(va, vb)) in pairs.iter().enumerate() {
        let mut mapped = [0u32; 2];
        for (k, (side, v, map)) in [(Side::A, va, &ia), (Side::B, vb, &ib)]
            .into_iter()
            .enumerate()
        {
            let Some(&m) = map.get(v as usize) else {
                return Err(SupermeshError::LandmarkOutOfRange {
                    pair,
                    mesh: side,
                    vertex: v,
                    vertices: map.len(),
                });
            };
            if m == u32::MAX {
                return Err(SupermeshError::LandmarkUnused {
                    pair,
                    mesh: side,
                    vertex: v,
                });
            }
            mapped[k] = m;
        }
        if let Some(&first) = used_b.get(&vb) {
            return Err(SupermeshError::LandmarkRepeated {
                first,
                second: pair,
                vertex: vb,
            });
        }
        used_b.insert(vb, pair);
        out.push((mapped[0], mapped[1]));
    }
    Ok(out)
}

/// Stage 2: both embeddings, in parallel, each timed on its own.
fn embed_both(
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
            embed::radial(&mesh.positions, &mesh.triangles).map_err(|folds| {
                SupermeshError::Embedding {
                    mesh: side,
                    what: format!(
                        "central projection from the origin folds {folds} triangle(s): the mesh is not star-shaped about the origin; turn SupermeshOptions::radial off"
                    ),
                }
            })
        } else {
            embed::embed(&mesh.positions, &mesh.triangles, &mut report).map_err(|e| {
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

fn normalised(mesh: &IndexedMesh) -> Vec<DVec3> {
    let frame = align::Frame::new(&mesh.positions, &mesh.triangles);
    mesh.positions.iter().map(|&p| frame.apply(p)).collect()
}

/// Stage 3: B's sphere rotated (and its landmarks pulled) to match A's.
fn align_b(
    a: &IndexedMesh,
    b: &IndexedMesh,
    embedded: &Embedded,
    landmarks: &[(u32, u32)],
    options: &SupermeshOptions,
) -> Result<(Vec<DVec3>, AlignmentReport), SupermeshError> {
    let (qa, qb) = (normalised(a), normalised(b));
    let samples = align::samples(&embedded.a, &qa, 4000);
    let lookup = align::SurfaceLookup::new(&SphereMesh::new(&embedded.b, &b.triangles), &qb);
    let before = align::residual(&samples, &lookup, DMat3::IDENTITY);
    let landmark_rotation = align::landmark_rotation(&embedded.a, &embedded.b, landmarks);
    let rotation = match (options.align, landmark_rotation) {
        (false, _) => DMat3::IDENTITY,
        (true, Some(r)) => r,
        (true, None) => {
            let b_samples = align::samples(&embedded.b, &qb, 4000);
            let extra = align::moment_candidates(&samples, &b_samples);
            align::search_rotation(&samples, &lookup, &extra)
        }
    };
    let mut points = embedded.b.clone();
    if !align::rotate(&mut points, &b.triangles, rotation) {
        return Err(SupermeshError::Embedding {
            mesh: Side::B,
            what: "rounding of the alignment rotation folded a triangle".into(),
        });
    }
    let mut report = AlignmentReport {
        before,
        after: before,
        ..AlignmentReport::default()
    };
    if !landmarks.is_empty() {
        report.landmarks_before = Some(align::landmark_angles(&embedded.a, &embedded.b, landmarks));
        let rings = embed::build_rings(points.len(), &b.triangles).map_err(|e| {
            SupermeshError::Embedding {
                mesh: Side::B,
                what: format!("{e:?}"),
            }
        })?;
        let mass = embed::vertex_masses(&b.positions, &b.triangles);
        align::pull_landmarks(&mass, &rings, &mut points, &embedded.a, landmarks, 400);
        report.landmarks_after = Some(align::landmark_angles(&embedded.a, &points, landmarks));
    }
    Ok((points, report))
}

/// Stage 4: the overlay under a tiny random rotation of B, again under
/// another one while A and B points are degenerate.
fn overlay_with_retries(
    a: &IndexedMesh,
    a_sphere: &[DVec3],
    b: &IndexedMesh,
    b_sphere: Vec<DVec3>,
    options: &SupermeshOptions,
) -> Result<(overlay::Overlay, Vec<DVec3>, usize), SupermeshError> {
    let ma = SphereMesh::new(a_sphere, &a.triangles);
    let attempts = if options.perturb { OVERLAY_ATTEMPTS } else { 1 };
    let mut progress = |f: f32| {
        if let Some(p) = options.progress {
            p(Stage::Overlay, f);
        }
    };
    for attempt in 0..attempts {
        let mut points = b_sphere.clone();
        if options.perturb {
            let r = align::random_rotation(options.seed.wrapping_add(attempt as u64), PERTURBATION);
            if !align::rotate(&mut points, &b.triangles, r) {
                continue;
            }
        }
        let mb = SphereMesh::new(&points, &b.triangles);
        match overlay::overlay(&ma, &mb, &mut progress) {
            Ok(o) => return Ok((o, points, attempt + 1)),
            Err(OverlayError::Degenerate) => continue,
            Err(OverlayError::Inconsistent { a_face, b_face }) => {
                return Err(SupermeshError::Overlay { a_face, b_face })
            }
        }
    }
    Err(SupermeshError::Degenerate { attempts })
}

/// The alignment residual as overlaid (after landmarks and perturbation).
fn final_residual(
    a: &IndexedMesh,
    b: &IndexedMesh,
    a_sphere: &[DVec3],
    b_sphere: &[DVec3],
) -> Residual {
    let (qa, qb) = (normalised(a), normalised(b));
    let samples = align::samples(a_sphere, &qa, 4000);
    let lookup = align::SurfaceLookup::new(&SphereMesh::new(b_sphere, &b.triangles), &qb);
    align::residual(&samples, &lookup, DMat3::IDENTITY)
}

/// Stage 5: poses and origins (in input indices).
fn assemble(
    ca: &Cleaned,
    cb: &Cleaned,
    a_sphere: &[DVec3],
    b_sphere: &[DVec3],
    overlay: &overlay::Overlay,
) -> Supermesh {
    let surface_a = positions::Surface {
        positions: &ca.mesh.positions,
        triangles: &ca.mesh.triangles,
        sphere: a_sphere,
    };
    let surface_b = positions::Surface {
        positions: &cb.mesh.positions,
        triangles: &cb.mesh.triangles,
        sphere: b_sphere,
    };
    let (v0, v1) = positions::poses(overlay, &surface_a, &surface_b);
    let (ma, mb) = (&ca.vertex_map, &cb.vertex_map);
    let origins = overlay
        .nodes
        .iter()
        .map(|n| match *n {
            Node::A(v) => Origin::A(ma[v as usize]),
            Node::B(v) => Origin::B(mb[v as usize]),
            Node::Both(a, b) => Origin::Both {
                a: ma[a as usize],
                b: mb[b as usize],
            },
            Node::Crossing { a, b, .. } => Origin::Crossing {
                a_edge: a.map(|v| ma[v as usize]),
                b_edge: b.map(|v| mb[v as usize]),
            },
        })
        .collect();
    Supermesh {
        triangles: overlay.triangles.clone(),
        v0,
        v1,
        origins,
        sphere: overlay.sphere.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn landmarks_parse_with_comments_and_name_the_bad_line() {
        let text = "# pairs\n0 5\n\n  12\t7  # nose\n";
        assert_eq!(parse_landmarks(text).unwrap(), vec![(0, 5), (12, 7)]);
        let err = parse_landmarks("0 5\n1 x\n").unwrap_err();
        assert_eq!(err.line, 2);
        assert!(err.to_string().contains("line 2"), "{err}");
        assert!(parse_landmarks("1 2 3").is_err());
        assert!(parse_landmarks("-1 2").is_err());
    }
}
