//! # morphlod
//!
//! Continuous level of detail for deforming (morphing) triangle meshes, after
//! *"LOD triangle strips for deforming meshes"* (built on LodStrips).
//!
//! The data flows through the modules in this order:
//!
//! ```text
//! io ─► mesh / morph ─► simplify (collapse sequence per frame) ─┐
//!                    └► strip (S0, the common strips) ─────────┴► lodstrips (change lists, runtime)
//!                                                                  └► gpu (wgpu buffers, one multi-draw)
//! ```
//!
//! * [`io`] reads OBJ, OFF, PLY and glTF/GLB into an [`IndexedMesh`] or a [`Morph`].
//! * [`mesh`] owns the flat indexed mesh, its validation, cleaning and adjacency.
//! * [`topology`] reports components, boundaries, manifoldness and genus.
//! * [`morph`] owns the supermesh `T` with poses `V(0)`, `V(1)` (and glTF weight animations).
//! * [`simplify`] produces a quadric-error half-edge [`CollapseSequence`].
//! * [`seams`] is the rule for collapses across UV seams and the expansion of a welded
//!   surface's sequence to the attribute vertices the GPU draws.
//! * [`collapse`] defines what a collapse sequence means: survivors and the reference mesh
//!   at any LOD, the oracle every test compares against.
//! * [`build`] runs the per-frame builder: a [`Morph`] to an [`Asset`] (`.mlod`, see [`asset`]).
//! * [`strip`] turns triangles into generalized triangle strips `S0`.
//! * [`lodstrips`] records the change lists and applies them at run time.
//! * [`deform`] is the per-object runtime of a deforming mesh: every sampled frame's change
//!   lists over one shared `S0`, `set(t, lod)` with frame switches.
//! * [`metrics`] measures geometric error (Hausdorff / RMS by surface sampling).
//! * [`gpu`] renders with wgpu: the caller owns the device, queue and render pass (feature
//!   `gpu`).
//! * [`ci`] is the one rule by which a test that lacks a GPU or a tool fails under CI
//!   instead of skipping.
//!
//! # Features
//!
//! * `gpu` (default): the [`gpu`] module (wgpu, pollster, image).
//! * `cli` (default, implies `gpu`): the `morphlod` binary and the demos (clap, indicatif,
//!   plotters); nothing in the library.
//!
//! `morphlod = { default-features = false }` compiles everything but [`gpu`]: an asset
//! pipeline loads meshes, builds and reads `.mlod` files without wgpu or a command line.
//!
//! The definitions the tests check (reference mesh, strip parity, the correctness invariant),
//! the data flow and the file format are described in `docs/DESIGN.md`.

pub mod asset;
pub mod build;
pub mod ci;
pub mod collapse;
pub mod deform;
pub mod error;
#[cfg(feature = "export")]
pub mod export;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod io;
mod keyframes;
pub mod lodstrips;
pub mod mesh;
pub mod metrics;
pub mod morph;
mod par;
mod random;
pub mod seams;
pub mod simplify;
pub mod skin;
pub mod strip;
pub mod topology;
mod varint;

pub use asset::Asset;
pub use build::Builder;
pub use collapse::{Collapse, CollapseSequence};
pub use deform::{DeformingModel, DeformingState, Lod};
pub use error::Error;
pub use mesh::IndexedMesh;
pub use morph::Morph;
