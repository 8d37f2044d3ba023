//! What the caller chooses and names: which input mesh ([`Side`]), the stages of
//! [`Supermesh::build`](super::Supermesh::build) for progress and timing ([`Stage`]), and the
//! options ([`SupermeshOptions`]).

use std::fmt;

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

/// The stages of [`Supermesh::build`](super::Supermesh::build), in order, for progress and timing.
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

/// Choices for [`Supermesh::build`](super::Supermesh::build).
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
    /// overlaying the embeddings (on by default; see [`Connectivity::Same`](super::Connectivity::Same)
    /// and [`Connectivity::Renumbered`](super::Connectivity::Renumbered)). Off, the overlay runs anyway (its
    /// own tests overlay a mesh on itself).
    pub reuse_connectivity: bool,
    /// Embed each mesh by central projection from the origin instead of
    /// the collapse-and-split embedding (off by default): for meshes that
    /// are star-shaped about the origin (every triangle positive seen from
    /// it, checked exactly; otherwise [`SupermeshError::Embedding`](super::SupermeshError::Embedding)), e.g. a
    /// mesh and its refinement, whose shared points then coincide exactly on
    /// the sphere.
    pub radial: bool,
    /// Whether, without landmarks, the limb tips of A and B are paired and
    /// each pairing's Möbius map competes with the rotation search (on by
    /// default; see [`TipReport`](super::TipReport) and docs/DESIGN.md, "Alignment").
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
