//! Loading meshes and morphs from files: Wavefront OBJ, OFF, PLY (ASCII and
//! binary little-endian) and glTF 2.0 / GLB. Every loader returns a typed
//! [`LoadError`] naming the file and the line or element at fault; none may
//! panic on any input.

pub mod gltf;
pub mod obj;
pub mod off;
pub mod ply;

use std::path::PathBuf;
use thiserror::Error;

/// Choices a loader needs beyond the path. Only glTF reads them today: a glTF
/// file holds many meshes placed by a node hierarchy, the other formats one mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// The glTF mesh to load, by name or index; `None` loads the first mesh.
    pub gltf_mesh: Option<String>,
    /// Apply the world matrix of the first node that instances the mesh.
    pub apply_transforms: bool,
}

/// Why a file could not be loaded.
#[derive(Debug, Error)]
pub enum LoadError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not a valid GLB container: {message}")]
    GltfContainer { path: PathBuf, message: String },
    #[error("{path}: invalid glTF JSON: {message}")]
    GltfJson { path: PathBuf, message: String },
    /// An element's data is inconsistent (out of its buffer, index out of range,
    /// non-finite, counts that disagree). `element` names it as in the JSON.
    #[error("{path}: {element}: {message}")]
    GltfData {
        path: PathBuf,
        element: String,
        message: String,
    },
    #[error("{path}: {element}: {what} is not supported by morphlod")]
    GltfUnsupported {
        path: PathBuf,
        element: String,
        what: String,
    },
    #[error("{path}: buffer {buffer} refers to the external file {file}, which cannot be read ({source}); keep the .bin files beside the .gltf")]
    GltfExternal {
        path: PathBuf,
        buffer: usize,
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: no {kind} '{wanted}'; the file has: {available}")]
    GltfNotFound {
        path: PathBuf,
        kind: &'static str,
        wanted: String,
        available: String,
    },
}
