//! Loading meshes and morphs from files (every file → [`IndexedMesh`] and file →
//! [`Morph`](crate::Morph) conversion lives here; `mesh` and `morph` know no file formats): Wavefront OBJ, OFF, PLY (ASCII and
//! binary little-endian) and glTF 2.0 / GLB. Every loader returns a typed
//! [`LoadError`] naming the file and the line or element at fault; none may
//! panic on any input.
//!
//! Loaders return the mesh as the file indexes it (no welding, no dropping of
//! degenerate triangles: that is [`crate::mesh::clean`], which reports what it
//! changed), but always validated, so every later stage can index without checks.
//!
//! Vertex attributes (normals, texture coordinates, colours) and the material come with
//! [`load_morph`] (glTF) and [`load_attributed`] (every format, as [`AttributedMesh`]:
//! OBJ corners split into attribute vertices at seams); [`load_mesh`] stays position-only.
//! UVs follow glTF's convention (`v` down), OBJ and PLY ones are flipped to it. A texture
//! image is kept encoded; its header is checked at load time ([`image_size`]), so an image
//! that is not a PNG or JPEG, or a missing external one, is a typed error
//! ([`LoadError::GltfImage`], [`LoadError::GltfImageExternal`]) rather than a silent
//! fallback to an untextured surface.

mod attributed;
pub mod gltf;
mod image_header;
pub mod obj;
pub mod off;
pub mod ply;
mod polygon;
mod text;

pub use attributed::{morph_from_pair, AttributeSummary, AttributedMesh, TextureSummary};
pub use gltf::{load_morph, load_morph_noted, MorphSource};
pub use image_header::image_size;
pub use polygon::MAX_EAR_CLIPPED_CORNERS;

use crate::mesh::{IndexedMesh, MeshError};
use crate::morph::{Attributes, MorphError};
use std::fmt;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Where in a file an error was found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// A 1-based line of a text file (OBJ, OFF, ASCII PLY, the PLY header).
    Line(usize),
    /// Record `index` (0-based) of a PLY element; binary files have no lines,
    /// so the element and record are the only useful coordinates there.
    Record {
        element: String,
        index: usize,
        line: Option<usize>,
    },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(line) => write!(f, "line {line}"),
            Location::Record {
                element,
                index,
                line: Some(line),
            } => write!(f, "line {line} ({element} {index})"),
            Location::Record {
                element,
                index,
                line: None,
            } => write!(f, "{element} {index}"),
        }
    }
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
    /// The text does not follow the format (bad header, unparsable number, missing field).
    #[error("{}: {at}: {message}", .path.display())]
    Syntax {
        path: PathBuf,
        at: Location,
        message: String,
    },
    /// A coordinate is NaN or infinite (or overflows f32); later stages
    /// (quadrics, bounds, the GPU) cannot work with it.
    #[error("{}: {at}: coordinate {value} is not finite: fix or remove that vertex", .path.display())]
    NonFinite {
        path: PathBuf,
        at: Location,
        value: f64,
    },
    /// A face names a vertex that does not exist. `index` is as written in
    /// the file (1-based or negative for OBJ, 0-based for OFF and PLY).
    #[error("{}: {at}: vertex index {index} is out of range: the file has {vertices} vertices", .path.display())]
    IndexOutOfRange {
        path: PathBuf,
        at: Location,
        index: i64,
        vertices: usize,
    },
    /// OBJ counts vertices from 1 (or from -1 backwards); 0 names nothing.
    #[error("{}: {at}: OBJ vertex index 0 names no vertex (indices start at 1, negative ones count back from the last vertex)", .path.display())]
    ZeroIndex { path: PathBuf, at: Location },
    #[error("{}: {at}: a face needs at least 3 vertices, this one has {corners}", .path.display())]
    FaceTooSmall {
        path: PathBuf,
        at: Location,
        corners: usize,
    },
    /// A non-convex polygon too large to ear-clip (see [`MAX_EAR_CLIPPED_CORNERS`]).
    #[error("{}: {at}: a non-convex polygon of {corners} corners: morphlod ear-clips non-convex polygons of up to {limit} corners; triangulate it in the program that wrote the file", .path.display())]
    PolygonTooLarge {
        path: PathBuf,
        at: Location,
        corners: usize,
        limit: usize,
    },
    /// The file ends before the records its header announced.
    #[error("{}: the file ends before {expected}: it is truncated, or its header counts are wrong", .path.display())]
    Truncated { path: PathBuf, expected: String },
    #[error("{}: {what} is not supported: {hint}", .path.display())]
    Unsupported {
        path: PathBuf,
        what: String,
        hint: String,
    },
    /// The file parsed but the mesh is unusable (no triangles, too many vertices).
    #[error("{}: {source}", .path.display())]
    InvalidMesh {
        path: PathBuf,
        #[source]
        source: MeshError,
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
    /// A buffer view compressed with `EXT_meshopt_compression` that does not decode: its
    /// extension object breaks the extension's rules, or its data is corrupt.
    #[error("{path}: buffer view {view} (EXT_meshopt_compression): {message}")]
    GltfCompressed {
        path: PathBuf,
        view: usize,
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
    /// A texture image that is not a PNG or JPEG (by its bytes), or whose header is corrupt.
    #[error("{path}: image {image} {message}")]
    GltfImage {
        path: PathBuf,
        image: usize,
        message: String,
    },
    #[error("{path}: image {image} refers to the external file {file}, which cannot be read ({source}); keep the texture images beside the .gltf, or embed them")]
    GltfImageExternal {
        path: PathBuf,
        image: usize,
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
    /// The glTF mesh has no morph targets to make a morph from.
    #[error("{path}: mesh '{mesh}' has no morph targets")]
    NoTargets { path: PathBuf, mesh: String },
    #[error("{path}: no morph target '{wanted}'; the file has: {available}")]
    NoSuchTarget {
        path: PathBuf,
        wanted: String,
        available: String,
    },
    #[error("{path}: no animation '{wanted}'; the file has: {available}")]
    NoSuchAnimation {
        path: PathBuf,
        wanted: String,
        available: String,
    },
    #[error(
        "{path}: animation '{animation}' has no channel animating the weights of mesh '{mesh}'"
    )]
    NoWeightChannel {
        path: PathBuf,
        animation: String,
        mesh: String,
    },
    /// A skin or its animation is unusable (joints out of range, weights that are negative or
    /// far from summing to 1, a singular or non-finite inverse bind matrix, a channel that
    /// cannot be played; see [`crate::skin::SkinError`]).
    #[error("{path}: {skin}: {source}")]
    GltfSkin {
        path: PathBuf,
        skin: String,
        #[source]
        source: crate::skin::SkinError,
    },
    #[error("{path}: mesh '{mesh}' is not skinned (its node has no skin, or its primitives no JOINTS_0 and WEIGHTS_0): {what} needs a skinned mesh")]
    NotSkinned {
        path: PathBuf,
        mesh: String,
        what: String,
    },
    /// The file's data makes no valid morph (see [`MorphError`]).
    #[error(transparent)]
    Morph(#[from] MorphError),
}

/// Choices that only some formats use.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Which glTF mesh to load: its name or its index; `None` is the first mesh.
    pub gltf_mesh: Option<String>,
    /// Whether glTF node transforms are applied to the positions.
    pub apply_transforms: bool,
}

/// The file formats [`load_mesh`] recognises, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Obj,
    Off,
    Ply,
    Gltf,
}

impl Format {
    /// The format for a path's extension (case-insensitive), or `None`.
    pub fn from_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(Format::Obj),
            "off" => Some(Format::Off),
            "ply" => Some(Format::Ply),
            "gltf" | "glb" => Some(Format::Gltf),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Format::Obj => "Wavefront OBJ",
            Format::Off => "OFF",
            Format::Ply => "PLY",
            Format::Gltf => "glTF",
        }
    }
}

/// Loads one mesh, choosing the loader by the file's extension.
pub fn load_mesh(path: &Path, options: &LoadOptions) -> Result<IndexedMesh, LoadError> {
    // A directory has no extension to dispatch on; say what it is.
    if path.is_dir() {
        return Err(LoadError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "it is a directory, not a mesh file",
            ),
        });
    }
    match Format::from_path(path) {
        Some(Format::Obj) => obj::load(path),
        Some(Format::Off) => off::load(path),
        Some(Format::Ply) => ply::load(path),
        Some(Format::Gltf) => gltf::load_mesh(path, options),
        None => Err(LoadError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "the extension {:?}",
                path.extension()
                    .map(|e| e.to_string_lossy().into_owned())
                    .unwrap_or_default()
            ),
            hint: "give a .obj, .off, .ply, .gltf or .glb file".into(),
        }),
    }
}

/// Loads one mesh with its vertex attributes, choosing the loader by the file's extension
/// (OBJ `vt`/`vn`, PLY normals and UVs, glTF NORMAL/TEXCOORD/COLOR_0 and material; OFF has
/// none). For glTF the mesh is placed by `options` as [`load_mesh`] does, and its
/// morph targets are not read.
pub fn load_attributed(path: &Path, options: &LoadOptions) -> Result<AttributedMesh, LoadError> {
    match Format::from_path(path) {
        Some(Format::Obj) => obj::load_attributed(path),
        Some(Format::Ply) => ply::load_attributed(path),
        Some(Format::Gltf) => gltf::load_attributed(path, options),
        Some(Format::Off) | None => Ok(AttributedMesh::unsplit(
            load_mesh(path, options)?,
            Attributes::default(),
        )),
    }
}

/// Reads a whole file, mapping the failure to [`LoadError::Io`].
fn read(path: &Path) -> Result<Vec<u8>, LoadError> {
    std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Validates a freshly parsed mesh, so callers never get one that later stages reject.
fn validated(mesh: IndexedMesh, path: &Path) -> Result<IndexedMesh, LoadError> {
    match mesh.validate() {
        Ok(()) => Ok(mesh),
        Err(source) => Err(LoadError::InvalidMesh {
            path: path.to_path_buf(),
            source,
        }),
    }
}
