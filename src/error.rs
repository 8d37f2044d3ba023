//! The crate-level error. Each stage owns a typed error of its own (loading,
//! mesh validation, ...); this enum wraps them so a caller that drives the whole
//! pipeline can use one `Result` type and still match on the stage that failed.

use thiserror::Error as ThisError;

/// Any error morphlod returns.
#[derive(Debug, ThisError)]
pub enum Error {
    /// Reading or parsing an input file failed.
    #[error(transparent)]
    Load(#[from] crate::io::LoadError),
    /// A mesh failed validation (NaN coordinates, indices out of range, ...).
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// Building a morph from its inputs failed (pose sizes or connectivity differ, ...).
    #[error(transparent)]
    Morph(#[from] crate::morph::MorphError),
    /// Building the per-frame LOD asset failed.
    #[error(transparent)]
    Build(#[from] crate::build::BuildError),
    /// Reading or writing a `.mlod` asset file failed.
    #[error(transparent)]
    Asset(#[from] crate::asset::AssetError),
    /// Creating, updating or reading back GPU resources failed.
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    /// An asset's data cannot make a deforming LOD model.
    #[error(transparent)]
    Deform(#[from] crate::deform::DeformError),
    /// A `(t, lod)` request was refused (NaN, or a state made for another model).
    #[error(transparent)]
    Set(#[from] crate::deform::SetError),
}
