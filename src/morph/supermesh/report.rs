//! What a build reports: the alignment, the limb-tip pairing, whether the connectivity was
//! shared, the counts, the embeddings' quality, the correspondence measure and the time of
//! each stage ([`SupermeshReport`]).

use std::fmt;

use super::align::Residual;
use super::embed::EmbeddingQuality;
use super::measure::Correspondence;
use super::Stage;

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

/// What [`Supermesh::build`](super::Supermesh::build) made and how long each stage took.
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
    /// B vertices exactly on an A vertex, merged with it ([`Origin::Both`](super::Origin::Both)):
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
    /// [`SupermeshOptions::tips`](super::SupermeshOptions::tips) and `align` on, `radial` off).
    pub tips: Option<TipReport>,
    /// Evenness of A's and B's sphere embeddings.
    pub embedding: [EmbeddingQuality; 2],
    /// How good the correspondence is ([`measure`](super::measure::measure) of `V(0)`, `V(1)`).
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
