//! The seeds' other multiresolution models, rebuilt as baselines for `morphlod bench
//! --baselines` (issue 26): Progressive Meshes (Hoppe 1996), Multiresolution Triangle Strips
//! (MTS, seeds 000 and 002) and Skip Strips (seed 003), beside the library's LodStrips (001).
//!
//! Every baseline is built from the same [`CollapseSequence`] and (where it uses strips) the
//! same strips `S0` as our LodStrips, so a comparison measures the data structure and nothing
//! else: the same LOD draws the same triangles in every model (the reference mesh of
//! docs/DESIGN.md, checked by `tests/suite/baselines.rs`).
//!
//! The module is the bench's, not the library's: it only reads `morphlod`'s public API, and the
//! test suite compiles it by path. Each model keeps its data in flat `Vec<u32>` columns and its
//! runtime state beside them, as its paper does (each model edits its own structure per
//! extraction); [`Baseline`] is what the bench and the tests drive.

/// The [`Baseline`] region methods of a model whose [`Regions`] are the field `$field`.
macro_rules! region_methods {
    ($field:ident) => {
        fn region_count(&self) -> usize {
            self.$field.count()
        }

        fn region_capacity(&self, r: usize) -> usize {
            self.$field.span(r).len()
        }

        fn region(&self, r: usize) -> morphlod::lodstrips::Indices<'_> {
            self.$field.get(r).into()
        }

        fn take_changed(&mut self) -> Vec<u32> {
            self.$field.take_changed()
        }
    };
}

pub mod mts;
pub mod pm;
pub mod skip_strips;

use morphlod::collapse::{CollapseSequence, SequenceError};
use morphlod::lodstrips::Indices;
use morphlod::strip::Strips;

/// The strip restart index: in a region of a strip model it ends one strip and starts the
/// next at even parity (as on the GPU).
pub const RESTART: u32 = u32::MAX;

/// Bytes of one vertex position in every model (three `f32`): the papers count the vertices
/// in each model's size, so Table 1 does too.
pub const POSITION_BYTES: usize = 12;

/// What a baseline refused.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum BaselineError {
    #[error("LOD {lod} is out of range: this model has LODs 0..={max}; ask for one of those")]
    LodOutOfRange { lod: usize, max: usize },
    #[error(
        "the collapse sequence is invalid ({0}); build it for this mesh with morphlod::simplify"
    )]
    Sequence(#[from] SequenceError),
    #[error("{what} names vertex {vertex}, but the mesh has {vertices} vertices; build the strips, triangles and sequence from the same mesh")]
    VertexOutOfRange {
        what: &'static str,
        vertex: u32,
        vertices: usize,
    },
    #[error("{positions} positions were given for a mesh of {vertices} vertices; pass the positions of the mesh the model was built from")]
    PositionCount { positions: usize, vertices: usize },
    #[error("the strips' offsets are not increasing from 0 to the index count; build them with morphlod::strip::stripify")]
    BadStrips,
}

/// How a model's regions are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primitive {
    /// Generalized triangle strips, [`RESTART`] between strips of one region.
    Strips,
    /// Plain triangle lists.
    Triangles,
}

/// A multiresolution model with its runtime state: what the bench times and the tests walk.
///
/// The model draws regions (a fixed index-buffer span each, `region_capacity` long);
/// after [`set_lod`](Self::set_lod) a region's live contents are [`region`](Self::region),
/// and every region whose contents changed since the last
/// [`take_changed`](Self::take_changed) is in its answer.
pub trait Baseline {
    /// The model's name in tables.
    fn name(&self) -> &'static str;
    fn primitive(&self) -> Primitive;
    /// The coarsest LOD (number of collapses); LOD 0 is full detail.
    fn max_lod(&self) -> usize;
    fn lod(&self) -> usize;
    /// Extracts LOD `lod`: the work the papers time as extraction ("% rec").
    fn set_lod(&mut self, lod: usize) -> Result<(), BaselineError>;
    fn region_count(&self) -> usize;
    /// Largest live length region `r` ever has (its span in an index buffer).
    fn region_capacity(&self, r: usize) -> usize;
    /// Live contents of region `r` at the current LOD.
    fn region(&self, r: usize) -> Indices<'_>;
    /// Regions changed since the last call (each once, ascending).
    fn take_changed(&mut self) -> Vec<u32>;
    /// Bytes of the model shared by every instance (positions not included).
    fn model_bytes(&self) -> usize;
    /// Bytes of one instance's runtime state (live buffers, cursors, flags).
    fn state_bytes(&self) -> usize;
}

/// The baselines' runtime index buffer, behind their [`Baseline`] region methods: region `r`
/// is `live[start[r]..start[r + 1]]`, of which the first `lengths[r]` indices are drawn, and
/// the regions rewritten since the last [`take_changed`](Self::take_changed).
#[derive(Clone, Debug)]
pub struct Regions {
    pub start: Vec<u32>,
    pub live: Vec<u32>,
    lengths: Vec<u32>,
    changed: Vec<u32>,
}

impl Regions {
    /// Regions of the given offsets (`start[0] = 0`, increasing), empty and unchanged.
    pub fn new(start: Vec<u32>) -> Regions {
        let total = start.last().copied().unwrap_or(0) as usize;
        Regions {
            lengths: vec![0; start.len().saturating_sub(1)],
            live: vec![RESTART; total],
            start,
            changed: Vec::new(),
        }
    }

    pub fn count(&self) -> usize {
        self.lengths.len()
    }

    /// Region `r`'s span of `live`: its capacity.
    pub fn span(&self, r: usize) -> std::ops::Range<usize> {
        self.start[r] as usize..self.start[r + 1] as usize
    }

    /// Marks region `r` rewritten, its first `len` indices live.
    pub fn set_len(&mut self, r: usize, len: usize) {
        self.lengths[r] = len as u32;
        self.changed.push(r as u32);
    }

    /// Region `r` becomes `indices` (at most its capacity).
    pub fn write(&mut self, r: usize, indices: &[u32]) {
        let start = self.start[r] as usize;
        self.live[start..start + indices.len()].copy_from_slice(indices);
        self.set_len(r, indices.len());
    }

    /// Region `r`'s live indices.
    pub fn get(&self, r: usize) -> &[u32] {
        let start = self.start[r] as usize;
        &self.live[start..start + self.lengths[r] as usize]
    }

    /// Regions changed since the last call (each once, ascending).
    pub fn take_changed(&mut self) -> Vec<u32> {
        let mut changed = std::mem::take(&mut self.changed);
        changed.sort_unstable();
        changed.dedup();
        changed
    }

    /// Forgets the changes so far (after a model's initial extraction).
    pub fn clear_changed(&mut self) {
        self.changed.clear();
    }

    /// Bytes of the live buffer, the lengths and the pending changes.
    pub fn state_bytes(&self) -> usize {
        4 * (self.live.len() + self.lengths.len() + self.changed.len())
    }
}

/// Checks what every strip baseline is built from: `s0`'s offsets and indices, and `seq`.
pub(crate) fn check_inputs(s0: &Strips, seq: &CollapseSequence) -> Result<(), BaselineError> {
    seq.validate()?;
    check_strips(s0)?;
    let vertices = seq.vertex_count as usize;
    match s0.indices.iter().find(|&&v| v as usize >= vertices) {
        Some(&vertex) => Err(BaselineError::VertexOutOfRange {
            what: "a strip",
            vertex,
            vertices,
        }),
        None => Ok(()),
    }
}

fn check_strips(s0: &Strips) -> Result<(), BaselineError> {
    let ok = s0.offsets.first() == Some(&0)
        && s0.offsets.windows(2).all(|w| w[0] <= w[1])
        && s0.offsets.last().map(|&l| l as usize) == Some(s0.indices.len());
    if ok {
        Ok(())
    } else {
        Err(BaselineError::BadStrips)
    }
}

/// A degenerate-window run inside a strip is cut (the strip split in two) only when it is
/// at least this long: keeping a run of `d` windows costs `d` indices, a cut costs the
/// restart, the two vertices the second strip repeats and at most one parity pad, so 4.
const SPLIT_RUN: usize = 5;

/// Appends the display strip(s) of `mapped` (an original strip with every vertex replaced by
/// its survivor) to `out`: leading and trailing degenerate windows dropped, inner runs of at
/// least [`SPLIT_RUN`] degenerate windows cut out (a [`RESTART`] between the parts), every
/// other window kept where it is. A part that starts at an odd window repeats its first vertex
/// so each drawn window keeps its parity, hence its orientation: the parts draw exactly the
/// non-degenerate windows of `mapped`. Returns the number of parts.
///
/// MTS splits strips the same way when a collapse disconnects them (its `EV` nodes, seed
/// 002 §3.2) and Skip Strips regenerate modified display strips from the original strip
/// (seed 003 §4.2.2); both use this one rule, so they draw the same index streams.
pub(crate) fn push_display_strip(mapped: &[u32], out: &mut Vec<u32>) -> usize {
    let windows = mapped.len().saturating_sub(2);
    let real = |j: usize| {
        let (a, b, c) = (mapped[j], mapped[j + 1], mapped[j + 2]);
        a != b && b != c && a != c
    };
    let mut parts = 0;
    let mut j = 0;
    while j < windows {
        if !real(j) {
            j += 1;
            continue;
        }
        let start = j;
        let mut last = j;
        let mut next = j + 1;
        loop {
            while next < windows && !real(next) {
                next += 1;
            }
            // `next - last - 1` degenerate windows lie between the two real ones.
            if next == windows || next - last > SPLIT_RUN {
                break;
            }
            last = next;
            next += 1;
        }
        if parts > 0 {
            out.push(RESTART);
        }
        if start % 2 == 1 {
            out.push(mapped[start]);
        }
        out.extend_from_slice(&mapped[start..last + 3]);
        parts += 1;
        j = last + 1;
    }
    parts
}

/// Strips (parts between restarts) and vertices (indices other than [`RESTART`]) in `live`.
pub fn strips_and_vertices(live: Indices) -> (usize, usize) {
    if live.is_empty() {
        return (0, 0);
    }
    // A `u16` runtime (the LodStrips state of a small mesh) holds no restart (`u32::MAX`).
    let restarts = match live {
        Indices::U32(live) => live.iter().filter(|&&v| v == RESTART).count(),
        Indices::U16(_) => 0,
    };
    (restarts + 1, live.len() - restarts)
}
