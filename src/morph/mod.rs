//! The supermesh: one triangulation `T` with poses `V(t)`, `t ∈ [0, 1]`.

use thiserror::Error;

/// A deforming mesh over one triangulation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Morph {
    pub triangles: Vec<[u32; 3]>,
}

/// Why a morph could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MorphError {
    #[error("the poses have {a} and {b} vertices; a morph needs one vertex count")]
    PoseSizeMismatch { a: usize, b: usize },
}
