//! Loading meshes and morphs from files: Wavefront OBJ, OFF, PLY (ASCII and
//! binary little-endian) and glTF 2.0 / GLB. Every loader returns a typed
//! [`LoadError`] naming the file and the line or element at fault; none may
//! panic on any input, and none trusts a count in a file before checking it
//! against the bytes that are actually there.

pub mod gltf;
pub mod obj;
pub mod off;
pub mod ply;

use std::fmt;
use std::path::PathBuf;
use thiserror::Error;

use crate::mesh::MeshError;

/// Where in a file a problem is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// 1-based line of a text format.
    Line(usize),
    /// Byte offset into a binary format.
    Byte(u64),
    /// A numbered element, e.g. `("vertex", 12)` or `("accessor", 3)`.
    Element(&'static str, usize),
    /// The file as a whole (a header, a missing section).
    File,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(n) => write!(f, "line {n}"),
            Location::Byte(n) => write!(f, "byte {n}"),
            Location::Element(kind, n) => write!(f, "{kind} {n}"),
            Location::File => write!(f, "file"),
        }
    }
}

/// Why a file could not be loaded. The message says what is wrong and, where
/// there is one, what to do about it.
#[derive(Debug, Error)]
pub enum LoadError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}, {location}: {message}")]
    Parse {
        path: PathBuf,
        location: Location,
        message: String,
    },
    #[error("{path}: {what} is not supported: {hint}")]
    Unsupported {
        path: PathBuf,
        what: String,
        hint: String,
    },
    #[error("{path}: the file ends early: {message}; the file is truncated or corrupt, export it again")]
    Truncated { path: PathBuf, message: String },
    #[error("{path}: {source}")]
    InvalidMesh {
        path: PathBuf,
        #[source]
        source: MeshError,
    },
    #[error("{path}: unknown mesh format (extension {extension:?}); use .obj, .off, .ply, .gltf or .glb")]
    UnknownFormat { path: PathBuf, extension: String },
}

impl LoadError {
    /// Shorthand for the most common error: a parse problem at a location.
    pub fn parse(path: impl Into<PathBuf>, location: Location, message: impl Into<String>) -> Self {
        LoadError::Parse {
            path: path.into(),
            location,
            message: message.into(),
        }
    }
}
