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

/// Why a file could not be loaded.
#[derive(Debug, Error)]
pub enum LoadError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}
