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
//! its own file:
//!
//! 1. [`Stage::Check`] (`check.rs`): clean each mesh and require one closed,
//!    manifold, genus-0 surface; anything else is a typed [`SupermeshError`]
//!    that names the check and the fix.
//! 2. [`Stage::EmbedA`], [`Stage::EmbedB`] (`embed.rs`): a bijective embedding
//!    of each mesh on the unit sphere (collapse to a tetrahedron, split back
//!    with every step fold-rejecting by exact predicates). Both run at once.
//! 3. [`Stage::Align`] (`align.rs`): normalise both shapes, rotate B's sphere
//!    to match equal sphere points, or move it by the Möbius map of a
//!    pairing of the limb tips when that matches better (`tips.rs`,
//!    [`TipReport`]), or map landmark pairs together.
//! 4. [`Stage::Refine`] (`align.rs`, `refine`): every vertex of either mesh
//!    slides on its sphere toward lower D (the correspondence measure's
//!    objective), fold-rejecting, landmarks pinned.
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
mod check;
mod embed;
mod measure;
mod mobius;
mod overlay;
mod positions;
mod renumbered;
mod sphere;
mod tips;

use std::fmt;
use std::time::Instant;

use glam::{DMat3, DVec3};
use thiserror::Error;

pub use align::Residual;
pub use embed::EmbeddingQuality;
pub use measure::{fit_b_onto_a, measure, Correspondence, Distortion, Placement, MEASURED_T};

use crate::mesh::clean::Cleaned;
use crate::mesh::{IndexedMesh, MeshError};
use crate::morph::{same_connectivity, Morph, MorphError};

use overlay::{Node, OverlayError};
use sphere::SphereMesh;

/// The supermesh algorithm's version: raised whenever the same inputs and options give a
/// different supermesh (2: the embedding rework with umbrella weight 1.0; 3: Möbius
/// normalisation, rotation scored by D, Möbius landmark fit; 4: a shared
/// connectivity used directly, the embeddings relaxed after the landmark
/// drag; 5: Möbius maps applied to all vertices at once, the landmarks'
/// Möbius fit applied whole, the refinement stage; 6: limb tips paired,
/// the best pairings' Möbius maps descended by D against the rotation
/// search). Caches of built supermesh morphs put it in their key.
pub const ALGORITHM_VERSION: u32 = 6;

/// Sweeps of area-proportional relaxation of both embeddings after the
/// landmark drag (man stood up → camel with the shipped landmarks: 0 → 30
/// → 150 → 500 sweeps give 180.8k → 159.0k → 138.8k → 132.0k supermesh
/// vertices and s(½) 0.897 → 0.901 → 0.905 → 0.907; 150 costs about a
/// second in the dev profile).
const LANDMARK_RELAX_SWEEPS: usize = 150;

/// Steps along the path from the identity to the landmarks' Möbius map
/// ([`mobius::warp`]).
const MOBIUS_STEPS: usize = 32;

/// The largest stretch ([`mobius::Mobius::stretch`]) of a tip pairing's
/// Möbius map that is scored: past it the fit is near singular (tips nearly
/// on one point of either sphere), not a correspondence.
const MAX_TIP_STRETCH: f64 = 100.0;

/// The best tip pairings (by their fit's score) that get a local descent
/// over Möbius maps ([`mobius::descend`]) before the comparison with the
/// rotation search.
const TIP_DESCENTS: usize = 2;

/// Rounds of [`refine_alignment`] (man stood up → camel with the shipped
/// landmarks: 0 / 5 / 20 rounds give s(½) 0.891 / 0.897 / 0.906).
const REFINE_ROUNDS: usize = 20;

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
    Refine,
    Overlay,
    Positions,
}

impl Stage {
    pub const ALL: [Stage; 7] = [
        Stage::Check,
        Stage::EmbedA,
        Stage::EmbedB,
        Stage::Align,
        Stage::Refine,
        Stage::Overlay,
        Stage::Positions,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Check => "check",
            Stage::EmbedA => "embed A",
            Stage::EmbedB => "embed B",
            Stage::Align => "align",
            Stage::Refine => "refine",
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
    /// Whether triangles that A and B share (the same, or the same up to a
    /// renumbering of B's vertices) are used as they are instead of
    /// overlaying the embeddings (on by default; see [`Connectivity::Same`]
    /// and [`Connectivity::Renumbered`]). Off, the overlay runs anyway (its
    /// own tests overlay a mesh on itself).
    pub reuse_connectivity: bool,
    /// Embed each mesh by central projection from the origin instead of
    /// the collapse-and-split embedding (off by default): for meshes that
    /// are star-shaped about the origin (every triangle positive seen from
    /// it, checked exactly; otherwise [`SupermeshError::Embedding`]), e.g. a
    /// mesh and its refinement, whose shared points then coincide exactly on
    /// the sphere.
    pub radial: bool,
    /// Whether, without landmarks, the limb tips of A and B are paired and
    /// each pairing's Möbius map competes with the rotation search (on by
    /// default; see [`TipReport`] and docs/DESIGN.md, "Alignment").
    pub tips: bool,
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
            reuse_connectivity: true,
            radial: false,
            tips: true,
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
            .field("reuse_connectivity", &self.reuse_connectivity)
            .field("radial", &self.radial)
            .field("tips", &self.tips)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

/// Alignment quality: distances between A's normalised vertices and B's
/// normalised surface at the same sphere point (units: the RMS radius of each
/// normalised shape), after the Möbius normalisation and as overlaid; for
/// landmarks, the angles (radians) between each pair's sphere points before
/// any alignment, after the Möbius fit, and as overlaid (0: every pair on
/// one sphere point, one supermesh vertex).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AlignmentReport {
    pub before: Residual,
    pub after: Residual,
    /// Distance of A's area centroid on the sphere from its centre, before
    /// and after the Möbius normalisation (0 when not normalised).
    pub centroid_a: (f64, f64),
    pub centroid_b: (f64, f64),
    pub landmarks_before: Option<Residual>,
    /// After the least-squares Möbius fit, before the pull.
    pub landmarks_fit: Option<Residual>,
    /// B vertices that the warp by the landmarks' Möbius map left short of
    /// their image (0: the map carried through whole).
    pub mobius_unreached: Option<usize>,
    pub landmarks_after: Option<Residual>,
}

/// One pair of limb tips: the vertex of A and of B (input indices) and
/// their positions.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TipPair {
    pub a: u32,
    pub b: u32,
    pub a_position: [f32; 3],
    pub b_position: [f32; 3],
}

/// The limb-tip pairing of the automatic alignment (docs/DESIGN.md,
/// "Alignment"): the tips found, how many pairings were scored, which one
/// was kept (or none, when the rotation search's result scored better), and
/// the scores: `D` both ways over the alignment's samples (A's against B's
/// surface and B's against A's, halved), before the refinement.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TipReport {
    /// A's and B's tips (input vertex indices), most prominent first.
    pub tips_a: Vec<u32>,
    pub tips_b: Vec<u32>,
    /// Pairings scored (each by its Möbius fit; the best two also after a
    /// descent over Möbius maps), besides the rotation.
    pub candidates: usize,
    /// The pairs kept; empty when the rotation search's result was kept.
    pub pairs: Vec<TipPair>,
    /// The kept alignment's score (the warped map's when a pairing won).
    pub d: f64,
    /// The rotation search's score.
    pub rotation_d: f64,
    /// The best score of the alignments not kept (the rotation's, a
    /// pairing's fit, or the best pairing as warped); `None` with nothing
    /// else scored.
    pub runner_up_d: Option<f64>,
    /// The kept pairing's Möbius stretch, after the descent (0 when none
    /// was kept).
    pub stretch: f64,
}

impl fmt::Display for TipReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "  limb tips         A {} {:?}, B {} {:?}; {} pairing(s) scored; ",
            self.tips_a.len(),
            self.tips_a,
            self.tips_b.len(),
            self.tips_b,
            self.candidates
        )?;
        if self.pairs.is_empty() {
            write!(f, "none: rotation search kept")?;
        } else {
            write!(f, "paired (Möbius stretch {:.2})", self.stretch)?;
        }
        let runner_up = self
            .runner_up_d
            .map_or("none".to_string(), |d| format!("{d:.4}"));
        write!(
            f,
            "; D both ways {:.4} (runner-up {runner_up}, rotation search {:.4})",
            self.d, self.rotation_d
        )?;
        for p in &self.pairs {
            let [x, y, z] = p.a_position;
            let [u, v, w] = p.b_position;
            write!(
                f,
                "\n    tip A {} ({x:.3}, {y:.3}, {z:.3}) -> B {} ({u:.3}, {v:.3}, {w:.3})",
                p.a, p.b
            )?;
        }
        Ok(())
    }
}

/// How the supermesh's triangulation was made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Connectivity {
    /// A and B differ: the overlay of their embeddings.
    #[default]
    Overlaid,
    /// A and B have the same vertex count and triangles, and every landmark
    /// pair (if any) is a vertex with itself: A's triangulation is used
    /// directly (no check, embedding, alignment or overlay ran, and the
    /// sphere fields are empty or zero).
    Same,
    /// A and B have the same triangles up to a renumbering of B's vertices
    /// (a posed copy written in another vertex order), found from the
    /// aligned embeddings (or the landmarks, which it must agree with) and
    /// checked triangle by triangle: A's triangulation is used with B's
    /// vertices renumbered, the exact identity map (no overlay ran).
    Renumbered,
}

/// What [`Supermesh::build`] made and how long each stage took.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SupermeshReport {
    /// Whether the supermesh is an overlay or A's own connectivity.
    pub connectivity: Connectivity,
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
    /// The limb-tip pairing, when it ran (automatic alignment: no landmarks,
    /// [`SupermeshOptions::tips`] and `align` on, `radial` off).
    pub tips: Option<TipReport>,
    /// Evenness of A's and B's sphere embeddings.
    pub embedding: [EmbeddingQuality; 2],
    /// How good the correspondence is ([`measure`] of `V(0)`, `V(1)`).
    pub correspondence: Correspondence,
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
        if self.connectivity == Connectivity::Same {
            writeln!(
                f,
                "  connectivity      the same: A's triangulation used directly, V(0) = A, V(1) = B (no embedding, alignment or overlay)"
            )?;
            writeln!(f, "{}", self.correspondence)?;
            return write!(f, "  stages            none");
        }
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
        if self.connectivity == Connectivity::Renumbered {
            writeln!(
                f,
                "  connectivity      the same up to B's vertex order: A's triangulation used with B's vertices renumbered (no overlay)"
            )?;
        }
        let a = &self.alignment;
        writeln!(
            f,
            "  alignment         mean {:.4} max {:.4} before, mean {:.4} max {:.4} after (RMS radius units)",
            a.before.mean, a.before.max, a.after.mean, a.after.max
        )?;
        writeln!(
            f,
            "  Möbius centring   area centroid A {:.2e} → {:.2e}, B {:.2e} → {:.2e}",
            a.centroid_a.0, a.centroid_a.1, a.centroid_b.0, a.centroid_b.1
        )?;
        if let Some(tips) = &self.tips {
            writeln!(f, "{tips}")?;
        }
        if let (Some(b), Some(c)) = (a.landmarks_before, a.landmarks_after) {
            let fit = a.landmarks_fit.unwrap_or_default();
            writeln!(
                f,
                "  landmarks         residual mean {:.4} max {:.4} rad before, {:.4} / {:.4} after the Möbius fit ({} vertices short), {:.2e} / {:.2e} as overlaid",
                b.mean,
                b.max,
                fit.mean,
                fit.max,
                a.mobius_unreached.unwrap_or(0),
                c.mean,
                c.max
            )?;
        }
        writeln!(f, "{}", self.correspondence)?;
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

/// A landmarks file that cannot be read.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum LandmarkParseError {
    #[error("landmarks line {line}: expected two vertex indices `vertex_in_a vertex_in_b` (non-negative integers, `#` starts a comment), found {found:?}")]
    Line {
        /// 1-based line number.
        line: usize,
        found: String,
    },
    #[error("the landmarks file has no pairs (only blank lines and comments): give at least one `vertex_in_a vertex_in_b` line, or leave the landmarks out")]
    Empty,
}

/// Landmark pairs read from a file, with the line each came from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Landmarks {
    /// `(vertex of A, vertex of B)`, 0-based in each file's vertex order.
    pub pairs: Vec<(u32, u32)>,
    /// The 1-based line of each pair.
    pub lines: Vec<usize>,
}

impl Landmarks {
    /// `error`, prefixed with the line of the landmark pair it is about.
    pub fn explain(&self, error: &SupermeshError) -> String {
        match error.landmark_pair().and_then(|p| self.lines.get(p)) {
            Some(line) => format!("landmarks line {line}: {error}"),
            None => error.to_string(),
        }
    }
}

/// Parses a landmarks file (format in docs/DESIGN.md, "Landmarks"): one pair
/// `vertex_in_a vertex_in_b` a line, whitespace-separated, 0-based indices in
/// each mesh file's vertex order; blank lines and everything after `#` are
/// ignored; at least one pair.
pub fn parse_landmarks(text: &str) -> Result<Landmarks, LandmarkParseError> {
    let mut out = Landmarks::default();
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
            Some(pair) => {
                out.pairs.push(pair);
                out.lines.push(k + 1);
            }
            None => {
                return Err(LandmarkParseError::Line {
                    line: k + 1,
                    found: raw.trim().to_string(),
                })
            }
        }
    }
    if out.pairs.is_empty() {
        return Err(LandmarkParseError::Empty);
    }
    Ok(out)
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

/// Both embeddings with their meshes.
struct Embedded {
    a: Vec<DVec3>,
    b: Vec<DVec3>,
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
    let mut used: [std::collections::HashMap<u32, usize>; 2] = Default::default();
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
        for (used, mesh, v) in used
            .iter_mut()
            .zip([(Side::A, va), (Side::B, vb)])
            .map(|(u, (m, v))| (u, m, v))
        {
            if let Some(&first) = used.get(&v) {
                return Err(SupermeshError::LandmarkRepeated {
                    first,
                    second: pair,
                    mesh,
                    vertex: v,
                });
            }
            used.insert(v, pair);
        }
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

fn normalised(mesh: &IndexedMesh, mass: &[f64]) -> Vec<DVec3> {
    let frame = align::Frame::new(&mesh.positions, mass);
    mesh.positions.iter().map(|&p| frame.apply(p)).collect()
}

/// What the alignment and the refinement read of one cleaned mesh, built
/// once: its vertex rings, vertex masses (a third of each triangle's area)
/// and normalised positions (as in the correspondence measure).
struct Tables {
    rings: Vec<Vec<u32>>,
    mass: Vec<f64>,
    normalised: Vec<DVec3>,
}

impl Tables {
    fn new(mesh: &IndexedMesh, side: Side) -> Result<Tables, SupermeshError> {
        let rings = rings_of(mesh, side)?;
        let mass = embed::vertex_masses(&mesh.positions, &mesh.triangles);
        let normalised = normalised(mesh, &mass);
        Ok(Tables {
            rings,
            mass,
            normalised,
        })
    }
}

/// Each vertex's ring of neighbours; a mesh whose rings cannot be built
/// was not embeddable either.
fn rings_of(mesh: &IndexedMesh, side: Side) -> Result<Vec<Vec<u32>>, SupermeshError> {
    embed::build_rings(mesh.vertex_count(), &mesh.triangles).map_err(|e| {
        SupermeshError::Embedding {
            mesh: side,
            what: format!("{e:?}"),
        }
    })
}

/// Stage 3: both embeddings Möbius-normalised, then B's sphere rotated to
/// the smallest `D`, or with landmarks mapped by their least-squares Möbius
/// fit and its landmarks pulled exactly onto A's (see `align.rs`).
fn align_b(
    (a, ta): (&IndexedMesh, &Tables),
    (b, tb): (&IndexedMesh, &Tables),
    embedded: &mut Embedded,
    landmarks: &[(u32, u32)],
    options: &SupermeshOptions,
) -> Result<Aligned, SupermeshError> {
    let (mass_a, mass_b) = (&ta.mass, &tb.mass);
    let (rings_a, rings) = (&ta.rings, &tb.rings);
    let mut report = AlignmentReport::default();
    // Centring moves shared points of radial embeddings apart: kept as they are.
    if options.align && !options.radial {
        report.centroid_a = mobius::centre(rings_a, &mut embedded.a, mass_a, &a.triangles);
        report.centroid_b = mobius::centre(rings, &mut embedded.b, mass_b, &b.triangles);
    }
    let (qa, qb) = (&ta.normalised, &tb.normalised);
    let samples = align::samples(&embedded.a, qa, mass_a, 4000);
    let lookup = align::SurfaceLookup::new(&SphereMesh::new(&embedded.b, &b.triangles), qb);
    report.before = align::residual(&samples, &lookup, DMat3::IDENTITY);
    report.after = report.before;
    let mut points = embedded.b.clone();
    // The rotation with the smallest D as placed, unless the one with the
    // smallest D after turning A's shape (blind to placement) is under half
    // of it: then B is placed differently (man.off is z-up, makehuman's
    // body y-up: D 1.27 as placed, 0.17 turned), and the correspondence
    // follows the shapes; the refinement then works in the turned frame.
    let (rotation, turn) = if options.align {
        let b_samples = align::samples(&embedded.b, qb, mass_b, 4000);
        let extra = align::moment_candidates(&samples, &b_samples);
        let placed = align::search_rotation(&samples, &lookup, &extra, false);
        let turned = align::search_rotation(&samples, &lookup, &extra, true);
        if align::cost(&samples, &lookup, turned, true)
            < 0.5 * align::cost(&samples, &lookup, placed, false)
        {
            (turned, align::shape_turn(&samples, &lookup, turned))
        } else {
            (placed, DMat3::IDENTITY)
        }
    } else {
        (DMat3::IDENTITY, DMat3::IDENTITY)
    };
    let mut tips = None;
    if landmarks.is_empty() && options.tips && options.align && !options.radial {
        let (warped, tip_report) =
            pair_tips((a, ta, &embedded.a), (b, tb, &embedded.b), rotation, turn);
        tips = Some(tip_report);
        if let Some(warped) = warped {
            return Ok((warped, report, turn, tips));
        }
    }
    if !align::rotate(&mut points, &b.triangles, rotation) {
        return Err(SupermeshError::Embedding {
            mesh: Side::B,
            what: "rounding of the alignment rotation folded a triangle".into(),
        });
    }
    if landmarks.is_empty() {
        return Ok((points, report, turn, tips));
    }
    // Landmarks: from the automatic alignment, the landmarks' least-squares
    // Möbius map (exact for three pairs), then the drag for what it leaves.
    report.landmarks_before = Some(align::landmark_angles(&embedded.a, &points, landmarks));
    let (from, to): (Vec<DVec3>, Vec<DVec3>) = landmarks
        .iter()
        .map(|&(la, lb)| (points[lb as usize], embedded.a[la as usize]))
        .unzip();
    let fit = mobius::Mobius::fit(&from, &to);
    report.mobius_unreached = Some(mobius::warp(
        rings,
        &b.triangles,
        &mut points,
        &fit,
        MOBIUS_STEPS,
        4,
    ));
    report.landmarks_fit = Some(align::landmark_angles(&embedded.a, &points, landmarks));
    // The pairs meet halfway (each embedding dragged half as far), then
    // whatever is left is closed from B's side, then from A's.
    let goals: Vec<DVec3> = landmarks
        .iter()
        .map(|&(la, lb)| {
            let (x, y) = (embedded.a[la as usize], points[lb as usize]);
            (x.normalize() + y.normalize()).normalize_or(x)
        })
        .collect();
    let index = |side: usize| -> Vec<(u32, u32)> {
        landmarks
            .iter()
            .enumerate()
            .map(|(k, &p)| (k as u32, if side == 0 { p.0 } else { p.1 }))
            .collect()
    };
    let (pairs_a, pairs_b) = (index(0), index(1));
    align::pull_landmarks(mass_a, rings_a, &mut embedded.a, &goals, &pairs_a, 400);
    align::pull_landmarks(mass_b, rings, &mut points, &goals, &pairs_b, 400);
    align::pull_landmarks(mass_b, rings, &mut points, &embedded.a, landmarks, 400);
    let swapped: Vec<(u32, u32)> = landmarks.iter().map(|&(la, lb)| (lb, la)).collect();
    align::pull_landmarks(mass_a, rings_a, &mut embedded.a, &points, &swapped, 400);
    if let Some((pair, &(la, lb))) = landmarks
        .iter()
        .enumerate()
        .find(|(_, &(la, lb))| points[lb as usize] != embedded.a[la as usize])
    {
        return Err(SupermeshError::LandmarkUnreached {
            pair,
            angle: points[lb as usize].angle_between(embedded.a[la as usize]),
        });
    }
    // The drag squeezes and stretches caps around the landmarks, which makes
    // the overlay cross more and blends the wrong points near them: both
    // embeddings relaxed toward area-proportional again, landmarks pinned
    // (fold-rejecting, so every pair stays on one point).
    let (free_a, free_b) = free_vertices(embedded.a.len(), points.len(), landmarks);
    embed::relax(
        mass_a,
        rings_a,
        &mut embedded.a,
        &free_a,
        LANDMARK_RELAX_SWEEPS,
    );
    embed::relax(mass_b, rings, &mut points, &free_b, LANDMARK_RELAX_SWEEPS);
    report.landmarks_after = Some(align::landmark_angles(&embedded.a, &points, landmarks));
    // The landmarks say which parts correspond, whatever the placement.
    Ok((points, report, DMat3::IDENTITY, None))
}

/// What [`align_b`] gives: B's aligned sphere points, the report, the turn
/// of A's normalised shape into B's frame (the identity unless B is placed
/// differently) and the limb-tip pairing's report (cleaned indices).
type Aligned = (Vec<DVec3>, AlignmentReport, DMat3, Option<TipReport>);

/// The limb-tip pairing (`tips.rs`; docs/DESIGN.md, "Alignment"): every
/// candidate pairing's least-squares Möbius map of B's tip sphere points
/// onto A's, scored by `D` both ways without moving a vertex (B's surface
/// read at the map's inverse); the best [`TIP_DESCENTS`] then descend over
/// Möbius maps by that score ([`mobius::descend`], on 1000 samples a side,
/// within [`MAX_TIP_STRETCH`]); the best, if it scores under the rotation
/// search's `rotation`, is warped whole ([`mobius::warp`]) and scored again
/// as warped. Returns B's warped sphere points when that still beats the
/// rotation, and the report (cleaned vertex indices).
fn pair_tips(
    (a, ta, a_sphere): (&IndexedMesh, &Tables, &[DVec3]),
    (b, tb, b_sphere): (&IndexedMesh, &Tables, &[DVec3]),
    rotation: DMat3,
    turn: DMat3,
) -> (Option<Vec<DVec3>>, TipReport) {
    let tips_a = tips::find(&a.positions, &ta.rings, &ta.mass);
    let tips_b = tips::find(&b.positions, &tb.rings, &tb.mass);
    let pa: Vec<DVec3> = tips_a
        .iter()
        .map(|&v| turn * ta.normalised[v as usize])
        .collect();
    let pb: Vec<DVec3> = tips_b.iter().map(|&v| tb.normalised[v as usize]).collect();
    let candidates = tips::pairings(&pa, &pb);
    let samples_a = align::samples(a_sphere, &ta.normalised, &ta.mass, 4000);
    let samples_b = align::samples(b_sphere, &tb.normalised, &tb.mass, 4000);
    let surface = |sphere: &[DVec3], mesh: &IndexedMesh, t: &Tables| {
        align::SurfaceLookup::new(&SphereMesh::new(sphere, &mesh.triangles), &t.normalised)
    };
    let (lookup_a, lookup_b) = (surface(a_sphere, a, ta), surface(b_sphere, b, tb));
    let score = |back: &dyn Fn(DVec3) -> DVec3, forth: &dyn Fn(DVec3) -> DVec3| {
        align::two_way_cost(
            (&samples_a, &lookup_a),
            (&samples_b, &lookup_b),
            turn,
            back,
            forth,
        )
    };
    let inverse = rotation.transpose();
    let rotation_d = score(&|x| inverse * x, &|y| rotation * y);
    let mut scored: Vec<(f64, mobius::Mobius, usize)> = candidates
        .iter()
        .enumerate()
        .filter_map(|(k, pairs)| {
            let (from, to): (Vec<DVec3>, Vec<DVec3>) = pairs
                .iter()
                .map(|&(i, j)| (b_sphere[tips_b[j] as usize], a_sphere[tips_a[i] as usize]))
                .unzip();
            let map = mobius::Mobius::fit(&from, &to);
            let stretch = map.stretch();
            if stretch.is_nan() || stretch > MAX_TIP_STRETCH {
                return None;
            }
            let back = map.inverse();
            let d = score(&|x| back.apply(x), &|y| map.apply(y));
            (!d.is_nan()).then_some((d, map, k))
        })
        .collect();
    scored.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
    // The fit lines up the tips, not the shapes between them: the best few
    // descend by D (on fewer samples), within the stretch cap.
    let few_a = align::samples(a_sphere, &ta.normalised, &ta.mass, 1000);
    let few_b = align::samples(b_sphere, &tb.normalised, &tb.mass, 1000);
    for entry in scored.iter_mut().take(TIP_DESCENTS) {
        let (_, map) = mobius::descend(entry.1, 0.1, |m| {
            if m.stretch() > MAX_TIP_STRETCH {
                return f64::INFINITY;
            }
            let back = m.inverse();
            align::two_way_cost(
                (&few_a, &lookup_a),
                (&few_b, &lookup_b),
                turn,
                &|x| back.apply(x),
                &|y| m.apply(y),
            )
        });
        let back = map.inverse();
        let d = score(&|x| back.apply(x), &|y| map.apply(y));
        if d < entry.0 {
            (entry.0, entry.1) = (d, map);
        }
    }
    scored.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
    let mut report = TipReport {
        tips_a: tips_a.clone(),
        tips_b: tips_b.clone(),
        candidates: candidates.len(),
        d: rotation_d,
        rotation_d,
        runner_up_d: scored.first().map(|s| s.0),
        ..TipReport::default()
    };
    let Some(&(fit_d, map, k)) = scored.first() else {
        return (None, report);
    };
    if fit_d >= rotation_d {
        return (None, report);
    }
    let mut warped = b_sphere.to_vec();
    mobius::warp(&tb.rings, &b.triangles, &mut warped, &map, MOBIUS_STEPS, 4);
    let samples_w = align::samples(&warped, &tb.normalised, &tb.mass, 4000);
    let lookup_w = surface(&warped, b, tb);
    let warped_d = align::two_way_cost(
        (&samples_a, &lookup_a),
        (&samples_w, &lookup_w),
        turn,
        &|x| x,
        &|y| y,
    );
    if warped_d.is_nan() || warped_d >= rotation_d {
        report.runner_up_d = Some(warped_d);
        return (None, report);
    }
    report.d = warped_d;
    report.runner_up_d = Some(scored.get(1).map_or(rotation_d, |s| s.0.min(rotation_d)));
    report.stretch = map.stretch();
    report.pairs = candidates[k]
        .iter()
        .map(|&(i, j)| {
            let (va, vb) = (tips_a[i], tips_b[j]);
            TipPair {
                a: va,
                b: vb,
                a_position: a.positions[va as usize],
                b_position: b.positions[vb as usize],
            }
        })
        .collect();
    (Some(warped), report)
}

/// The tip report's vertices in the input meshes' indices.
fn input_indices(report: &mut TipReport, ca: &Cleaned, cb: &Cleaned) {
    for v in &mut report.tips_a {
        *v = ca.vertex_map[*v as usize];
    }
    for v in &mut report.tips_b {
        *v = cb.vertex_map[*v as usize];
    }
    for p in &mut report.pairs {
        p.a = ca.vertex_map[p.a as usize];
        p.b = cb.vertex_map[p.b as usize];
    }
}

/// The limb tips of a mesh (docs/DESIGN.md, "Alignment"): the prominent
/// local maxima of its average geodesic distance, most prominent first, at
/// most eight; input vertex indices. A sphere-like mesh has one (its
/// global maximum). The mesh must pass the supermesh's checks (closed,
/// manifold, genus 0, one component); its errors name mesh A.
pub fn limb_tips(mesh: &IndexedMesh) -> Result<Vec<u32>, SupermeshError> {
    let cleaned = check::prepare(mesh, Side::A)?;
    let tables = Tables::new(&cleaned.mesh, Side::A)?;
    Ok(
        tips::find(&cleaned.mesh.positions, &tables.rings, &tables.mass)
            .into_iter()
            .map(|v| cleaned.vertex_map[v as usize])
            .collect(),
    )
}

/// The vertices of A and of B in no landmark pair.
fn free_vertices(na: usize, nb: usize, landmarks: &[(u32, u32)]) -> (Vec<u32>, Vec<u32>) {
    let free = |n: usize, side: &dyn Fn(&(u32, u32)) -> u32| -> Vec<u32> {
        let mut pinned = vec![false; n];
        for p in landmarks {
            pinned[side(p) as usize] = true;
        }
        (0..n as u32).filter(|&v| !pinned[v as usize]).collect()
    };
    (free(na, &|p| p.0), free(nb, &|p| p.1))
}

/// Stage 4: the alignment refined for D. The rotation (or the landmarks'
/// Möbius map) lines up the shapes as a whole, not their parts: in each of
/// [`REFINE_ROUNDS`] rounds every vertex of B, then of A, slides on its
/// sphere toward the other shape's point that matches it better (lowering
/// its term of D, [`align::refine`]), by fold-rejecting moves with the
/// landmarks pinned, then one relaxation sweep of each embedding keeps it
/// even (without them the map's angle distortion p95 went from 65 to 1271
/// on man stood up → camel with the shipped landmarks).
///
/// `turn` takes A's normalised shape into B's frame (the identity unless B
/// is placed differently, see [`align_b`]).
fn refine_alignment(
    (a, ta, a_sphere): (&IndexedMesh, &Tables, &mut [DVec3]),
    (b, tb, b_sphere): (&IndexedMesh, &Tables, &mut [DVec3]),
    landmarks: &[(u32, u32)],
    turn: DMat3,
) {
    let (rings_a, rings_b) = (&ta.rings, &tb.rings);
    let (mass_a, mass_b) = (&ta.mass, &tb.mass);
    let qa: Vec<DVec3> = ta.normalised.iter().map(|&q| turn * q).collect();
    let qb = &tb.normalised;
    let (free_a, free_b) = free_vertices(a_sphere.len(), b_sphere.len(), landmarks);
    let pinned = |n: usize, free: &[u32]| {
        let mut out = vec![true; n];
        for &v in free {
            out[v as usize] = false;
        }
        out
    };
    let (pinned_a, pinned_b) = (
        pinned(a_sphere.len(), &free_a),
        pinned(b_sphere.len(), &free_b),
    );
    let (mut hints_a, mut hints_b) = (
        vec![u32::MAX; a_sphere.len()],
        vec![u32::MAX; b_sphere.len()],
    );
    for _ in 0..REFINE_ROUNDS {
        let surface_a = align::Surface::new(a_sphere, &a.triangles, &qa);
        align::refine(b_sphere, rings_b, qb, &surface_a, &pinned_b, &mut hints_b);
        let surface_b = align::Surface::new(b_sphere, &b.triangles, qb);
        align::refine(a_sphere, rings_a, &qa, &surface_b, &pinned_a, &mut hints_a);
        embed::relax(mass_a, rings_a, a_sphere, &free_a, 1);
        embed::relax(mass_b, rings_b, b_sphere, &free_b, 1);
    }
}

/// Stage 4: the overlay under a tiny random rotation of B, again under
/// another one while A and B points are degenerate.
fn overlay_with_retries(
    a: &IndexedMesh,
    a_sphere: &[DVec3],
    b: &IndexedMesh,
    b_sphere: Vec<DVec3>,
    landmarks: bool,
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
        // Landmark pairs sit on exactly one sphere point each: the first try
        // keeps them there (the overlay merges them), later tries perturb.
        if options.perturb && !(landmarks && attempt == 0) {
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
    (ta, a_sphere): (&Tables, &[DVec3]),
    (b, tb, b_sphere): (&IndexedMesh, &Tables, &[DVec3]),
) -> Residual {
    let samples = align::samples(a_sphere, &ta.normalised, &ta.mass, 4000);
    let lookup =
        align::SurfaceLookup::new(&SphereMesh::new(b_sphere, &b.triangles), &tb.normalised);
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
        let parsed = parse_landmarks(text).unwrap();
        assert_eq!(parsed.pairs, vec![(0, 5), (12, 7)]);
        assert_eq!(parsed.lines, vec![2, 4]);
        let e = SupermeshError::LandmarkUnused {
            pair: 1,
            mesh: Side::A,
            vertex: 12,
        };
        assert!(
            parsed.explain(&e).starts_with("landmarks line 4: "),
            "{}",
            parsed.explain(&e)
        );
        let err = parse_landmarks("0 5\n1 x\n").unwrap_err();
        assert!(matches!(err, LandmarkParseError::Line { line: 2, .. }));
        assert!(err.to_string().contains("line 2"), "{err}");
        assert_eq!(
            parse_landmarks("# none\n\n"),
            Err(LandmarkParseError::Empty)
        );
        assert!(parse_landmarks("1 2 3").is_err());
        assert!(parse_landmarks("-1 2").is_err());
    }

    /// A star-shaped blob: an icosphere (4 → 1 splits) pushed in and out.
    fn blob(level: u32, seed: u64) -> IndexedMesh {
        let sphere = IndexedMesh::icosphere(level as u8);
        let mut state = seed;
        let positions = sphere
            .positions
            .iter()
            .map(|&q| {
                let r = 1.0 + 0.3 * (crate::random::next_unit(&mut state) - 0.5);
                let q = DVec3::from_array(q.map(f64::from));
                (q * r * DVec3::new(2.0, 1.0, 0.6)).as_vec3().to_array()
            })
            .collect();
        IndexedMesh::new(positions, sphere.triangles)
    }

    /// An icosphere with spikes out of the icosahedron's vertices `at`
    /// (lengths 1.0, 1.3, …, so no turn of the sphere maps the spikes onto
    /// each other), a little radial noise.
    fn spiked(level: u32, seed: u64, at: &[usize]) -> IndexedMesh {
        let mut mesh = blob(level, seed);
        let dir = |p: [f32; 3]| DVec3::from_array(p.map(f64::from)).normalize();
        let spikes: Vec<DVec3> = at.iter().map(|&v| dir(mesh.positions[v])).collect();
        let mut state = seed;
        for p in &mut mesh.positions {
            let q = dir(*p);
            let bump: f64 = spikes
                .iter()
                .enumerate()
                .map(|(k, &d)| {
                    let x = (1.0 - q.angle_between(d) / 0.5).max(0.0);
                    (1.0 + 0.3 * k as f64) * x * x
                })
                .sum();
            let noise = 0.02 * (crate::random::next_unit(&mut state) - 0.5);
            *p = (q * (1.0 + noise + bump)).as_vec3().to_array();
        }
        mesh
    }

    /// The limb-tip pairing on a spiked mesh and a scaled copy with its
    /// vertices shuffled whose sphere embedding is the mesh's under a Möbius
    /// warp and a rotation, against a wrong rotation: every tip is paired
    /// with its twin, and the warped map is the identity correspondence
    /// (D ≈ 0, each vertex on its twin's sphere point).
    #[test]
    fn tip_pairing_recovers_the_identity_of_a_warped_shuffled_copy() {
        let a = spiked(3, 5, &[0, 3, 5, 8, 10]);
        let n = a.vertex_count();
        // B vertex i is A vertex order[i].
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut state = 99u64;
        for i in (1..n).rev() {
            let j = (crate::random::next_unit(&mut state) * (i + 1) as f64) as usize % (i + 1);
            order.swap(i, j);
        }
        let mut twin = vec![0u32; n];
        for (new, &old) in order.iter().enumerate() {
            twin[old as usize] = new as u32;
        }
        let b = IndexedMesh::new(
            order
                .iter()
                .map(|&v| a.positions[v as usize].map(|c| 2.0 * c - 0.5))
                .collect(),
            a.triangles
                .iter()
                .map(|t| t.map(|v| twin[v as usize]))
                .collect(),
        );
        let sa = embed::embed(&a.positions, &a.triangles, &mut |_| {}).unwrap();
        let mut sb: Vec<DVec3> = order.iter().map(|&v| sa[v as usize]).collect();
        let rings = embed::build_rings(n, &b.triangles).unwrap();
        let warp = mobius::Mobius::small([0.3, -0.1, 0.2, 0.2, -0.1, 0.3]);
        assert_eq!(mobius::warp(&rings, &b.triangles, &mut sb, &warp, 8, 4), 0);
        assert!(align::rotate(
            &mut sb,
            &b.triangles,
            align::random_rotation(3, 1.0)
        ));
        let (ta, tb) = (
            Tables::new(&a, Side::A).unwrap(),
            Tables::new(&b, Side::B).unwrap(),
        );
        let wrong = DMat3::from_rotation_x(1.5);
        let (warped, report) = pair_tips((&a, &ta, &sa), (&b, &tb, &sb), wrong, DMat3::IDENTITY);
        println!("{report}");
        assert!(
            report.tips_a.len() >= 5 && report.tips_b.len() >= 5,
            "{report}"
        );
        assert!(report.pairs.len() >= 5, "{report}");
        for p in &report.pairs {
            assert_eq!(p.b, twin[p.a as usize], "{report}");
        }
        assert!(report.d < 1e-3 && report.rotation_d > 0.1, "{report}");
        let warped = warped.expect("the pairing beats a wrong rotation");
        let mean: f64 = (0..n)
            .map(|v| sa[v].angle_between(warped[twin[v] as usize]))
            .sum::<f64>()
            / n as f64;
        assert!(mean < 1e-3, "mean angle between twins {mean}");
    }

    /// Each side's vertices against the other's surface at their sphere
    /// points: `Σ m ‖q − other(x)‖² / Σ m` over A's and over B's vertices.
    fn vertex_d(a: &IndexedMesh, b: &IndexedMesh, sa: &[DVec3], sb: &[DVec3]) -> f64 {
        let one = |m: &IndexedMesh, s: &[DVec3], o: &IndexedMesh, so: &[DVec3]| {
            let (mm, mo) = (
                embed::vertex_masses(&m.positions, &m.triangles),
                embed::vertex_masses(&o.positions, &o.triangles),
            );
            let (q, qo) = (normalised(m, &mm), normalised(o, &mo));
            let surface = align::Surface::new(so, &o.triangles, &qo);
            let (mut hint, mut rng) = (0, 1);
            let sum: f64 = (0..s.len())
                .map(|v| mm[v] * (q[v] - surface.at(s[v], &mut hint, &mut rng)).length_squared())
                .sum();
            sum / mm.iter().sum::<f64>()
        };
        one(a, sa, b, sb) + one(b, sb, a, sa)
    }

    /// The refinement stage lowers D on two shapes of different
    /// connectivity, keeps both embeddings bijective and the landmarks where
    /// they are.
    #[test]
    fn refinement_lowers_d_and_keeps_embeddings_and_landmarks() {
        let (a, b) = (blob(3, 5), blob(2, 11));
        let mut embedded = Embedded {
            a: embed::embed(&a.positions, &a.triangles, &mut |_| {}).unwrap(),
            b: embed::embed(&b.positions, &b.triangles, &mut |_| {}).unwrap(),
        };
        let landmarks = [(0, 0), (40, 17)];
        let options = SupermeshOptions::default();
        let (ta, tb) = (
            Tables::new(&a, Side::A).unwrap(),
            Tables::new(&b, Side::B).unwrap(),
        );
        let (mut sb, _, turn, _) =
            align_b((&a, &ta), (&b, &tb), &mut embedded, &landmarks, &options).unwrap();
        let before = vertex_d(&a, &b, &embedded.a, &sb);
        let pins = landmarks.map(|(la, lb)| (embedded.a[la as usize], sb[lb as usize]));
        refine_alignment(
            (&a, &ta, &mut embedded.a),
            (&b, &tb, &mut sb),
            &landmarks,
            turn,
        );
        let after = vertex_d(&a, &b, &embedded.a, &sb);
        println!("D over both sides' vertices {before:.4} -> {after:.4}");
        assert!(after < 0.8 * before, "{before} -> {after}");
        assert_eq!(sphere::check_embedding(&embedded.a, &a.triangles).0, 0);
        assert_eq!(sphere::check_embedding(&sb, &b.triangles).0, 0);
        for ((la, lb), (pa, pb)) in landmarks.into_iter().zip(pins) {
            assert_eq!((embedded.a[la as usize], sb[lb as usize]), (pa, pb));
            assert_eq!(pa, pb);
        }
    }

    /// A mesh and a scaled, moved copy whose sphere embedding is the mesh's
    /// under a Möbius warp and a rotation: the alignment recovers the
    /// identity correspondence (each vertex on its twin, D ≈ 0).
    #[test]
    fn alignment_recovers_the_identity_under_a_mobius_warp_and_rotation() {
        let a = blob(3, 5);
        let mut b = a.clone();
        for p in &mut b.positions {
            *p = p.map(|c| 3.0 * c + 1.5);
        }
        let sphere = embed::embed(&a.positions, &a.triangles, &mut |_| {}).unwrap();
        for (k, boost) in [
            [0.2, 0.1, -0.3, 0.2, 0.1, 0.0],
            [0.0, 0.5, 0.3, -0.1, 0.2, 0.4],
        ]
        .into_iter()
        .enumerate()
        {
            let warp = mobius::Mobius::small(boost);
            let mut warped = sphere.clone();
            let rings = embed::build_rings(warped.len(), &b.triangles).unwrap();
            assert_eq!(
                mobius::warp(&rings, &b.triangles, &mut warped, &warp, 8, 4),
                0
            );
            let rotation = align::random_rotation(k as u64, 1.0);
            assert!(align::rotate(&mut warped, &b.triangles, rotation));
            let mut embedded = Embedded {
                a: sphere.clone(),
                b: warped,
            };
            let before: f64 = embedded
                .a
                .iter()
                .zip(&embedded.b)
                .map(|(x, y)| x.angle_between(*y))
                .sum::<f64>()
                / sphere.len() as f64;
            let (ta, tb) = (
                Tables::new(&a, Side::A).unwrap(),
                Tables::new(&b, Side::B).unwrap(),
            );
            let (points, _, _, _) = align_b(
                (&a, &ta),
                (&b, &tb),
                &mut embedded,
                &[],
                &SupermeshOptions::default(),
            )
            .unwrap();
            let after: f64 = embedded
                .a
                .iter()
                .zip(&points)
                .map(|(x, y)| x.angle_between(*y))
                .sum::<f64>()
                / sphere.len() as f64;
            println!("mean angle between twins {before:.4} -> {after:.4} rad");
            assert!(before > 0.3, "{before}");
            assert!(after < 0.01, "{before} -> {after}");
        }
    }
}
