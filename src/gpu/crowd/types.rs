//! The crowd's public types: why a call was refused, the compact area and tail options,
//! where an instance is, the ids, and the figures of an upload and of the crowd.

use thiserror::Error;

use crate::deform::SetError;
use crate::gpu::GpuError;

/// Why a crowd call was refused; nothing changed.
#[derive(Debug, Error)]
pub enum CrowdError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A NaN time or LOD.
    #[error(transparent)]
    Set(#[from] SetError),
    /// An asset number this crowd never gave out.
    #[error("asset {0} is not in this crowd; use the AssetId that add_asset returned")]
    UnknownAsset(u32),
    /// An instance that was removed, or never existed.
    #[error("instance {0:?} is not in the crowd (removed, or of another crowd)")]
    UnknownInstance(InstanceId),
    /// The asset holds the most instances the device can draw: their blocks fill one storage
    /// binding, or (base-vertex path) `slot × vertex count` would pass 2³¹.
    #[error("asset {asset} holds the {most} instances the device can draw ({why}); remove one")]
    Full {
        asset: u32,
        most: u32,
        why: &'static str,
    },
    /// A transform or colour with a NaN or infinite entry.
    #[error("the {what} {value} is not finite; pass finite numbers")]
    NonFinite { what: &'static str, value: String },
    /// A model that was not made from the GPU asset's poses.
    #[error(
        "the model has {model} vertices but the GPU asset {asset}; make both from the same asset"
    )]
    ModelMismatch { model: usize, asset: u32 },
    /// [`CrowdPath::FirstInstance`](super::CrowdPath::FirstInstance) asked of a device without
    /// `INDIRECT_FIRST_INSTANCE`.
    #[error("the first-instance path needs a device with wgpu::Features::INDIRECT_FIRST_INSTANCE; request it when creating the device, or use CrowdPath::BaseVertex")]
    NoFirstInstance,
    /// One instance's full-detail index memory (its regions) passes what one buffer of the
    /// device may hold and bind: such an asset cannot be drawn close up.
    #[error("one instance of the asset needs {need} bytes of indices at full detail, but the device's buffers hold at most {limit} bytes (max_buffer_size, max_storage_buffer_binding_size); request larger limits or simplify the asset")]
    TooLarge { need: u64, limit: u64 },
    /// The discrete levels of a bench could not be made.
    #[error(transparent)]
    Levels(#[from] super::LevelsError),
    /// A [`DiscreteCrowd`](super::DiscreteCrowd)'s fixed list of instances: none, more blocks
    /// than one binding holds, or more moves than instances.
    #[error("{capacity} instances do not fit: {why}")]
    Capacity { capacity: u32, why: String },
    /// A read-back before the first [`prepare`](super::Crowd::prepare) made the buffers.
    #[error("the crowd's buffers are made by prepare; call it first")]
    NotPrepared,
}

/// What an instance's index memory holds by distance
/// ([`Crowd::set_records`](super::Crowd::set_records)).
///
/// Each instance holds one area of its asset's index memory, sized to what it draws now
/// (docs/DESIGN.md, "Crowds"). Close up it holds its regions: one per strip of `S0` with room
/// for its full length (patched at O(changed indices)). Where its live strips, one restart
/// between two, are at most `compact_share` of the regions' words (a coarse LOD), it holds a
/// compact copy of them instead (each strip in a place it keeps while it fits, patched as it
/// changes; packed anew where the copy would read more than 1.5× the packed count), a little
/// more than their packed count, and its one draw record reads the live indices, a restart
/// between two strips and the restarts where strips shrank or left. docs/DESIGN.md, "Crowds",
/// has the measurement behind the default.
///
/// At a frame's coarsest LODs, those that draw at most `tail_triangles` triangles (and fit the
/// compact share, 4 words a triangle), an instance is drawn from its frame's tail list instead:
/// one triangle list per frame and asset, shared by every instance, which a compute pass
/// expands into the instance's area (4 words a triangle) where its frame or LOD changed. Its
/// runtime is then not kept ([`Crowd::state`](super::Crowd::state) gives `None`) and its
/// moves cost no rebuild and no patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrowdRecords {
    /// The largest compact copy as a share of the regions' words, in 0..=1 (clamped): 0 never
    /// copies, 1 always does.
    pub compact_share: f32,
    /// The most triangles a frame's tail list holds (0: no tail lists). The GPU work of an
    /// instance's expansion and the asset's tail lists grow with it.
    pub tail_triangles: u32,
}

impl Default for CrowdRecords {
    fn default() -> Self {
        CrowdRecords {
            compact_share: 0.25,
            tail_triangles: 2048,
        }
    }
}

/// Where an instance is ([`Crowd::at`](super::Crowd::at)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InstanceAt {
    /// Its frame and its LOD (steps of that frame).
    pub frame: usize,
    pub lod: usize,
    /// The triangles it draws.
    pub triangles: usize,
    /// What it is drawn from, which its area holds.
    pub from: DrawnFrom,
    /// Words of index memory its area holds (0 while it draws the shared `S0`).
    pub words: u32,
    /// Out of view as of the last prepare ([`Crowd::set_culling`](super::Crowd::set_culling)):
    /// it draws nothing.
    pub culled: bool,
}

/// What an instance is drawn from: what its area of index memory holds ([`CrowdRecords`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DrawnFrom {
    /// No area: its record reads the asset's shared `S0` (a new instance, before its first
    /// move).
    S0,
    /// Its frame's tail list at its LOD, written by the expansion (far away).
    Tail,
    /// A compact copy of its live strips (coarse LODs).
    Copy,
    /// Its regions (close up).
    Regions,
}

/// An asset of a crowd.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AssetId(pub(super) u32);

/// An instance of a crowd: its asset, its slot, and the slot's generation (a removed
/// instance's id stays invalid when the slot is reused).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct InstanceId {
    pub(super) asset: u32,
    pub(super) slot: u32,
    pub(super) generation: u32,
}

impl InstanceId {
    /// The instance's slot: its instance block's number, what its draw record carries as
    /// `first_instance` (first-instance path) or as `base_vertex / vertex count` (base-vertex
    /// path). Its indices and record lie wherever its area is.
    pub fn slot(&self) -> u32 {
        self.slot
    }

    /// Its asset.
    pub fn asset(&self) -> AssetId {
        AssetId(self.asset)
    }
}

/// What one [`Crowd::prepare`](super::Crowd::prepare) sent to the GPU.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CrowdUpload {
    /// Index slots patched (by the scatter), over all assets; record words not counted.
    pub patches: u64,
    /// Bytes written: run lists of index words and of record words (8 per lone word, 8 per run
    /// of up to 16 consecutive words plus 4 a word, headers padded to whole workgroups), tail
    /// jobs, an asset's shared `S0` (once), instance blocks, the scene block and textures.
    pub bytes: u64,
    /// `queue.write_buffer` and `write_texture` calls.
    pub writes: usize,
    /// Compute dispatches: the scatters (per asset and page one for index patches and one for
    /// record patches where it has them; more when a frame's patches pass a binding's size
    /// limit) and one per asset and page with tail expansions.
    pub dispatches: usize,
    /// GPU copies: areas moved to larger ones (a compact copy grown), new regions filled with
    /// restarts, buffers grown (their old contents copied).
    pub copies: usize,
    /// Instances written from their frame's tail list (32 bytes of job each).
    pub tail_jobs: usize,
}

impl CrowdUpload {
    /// Writes `bytes` at `offset` of `buffer` and counts them.
    pub(super) fn write(
        &mut self,
        queue: &wgpu::Queue,
        buffer: &wgpu::Buffer,
        offset: u64,
        bytes: &[u8],
    ) {
        if !bytes.is_empty() {
            queue.write_buffer(buffer, offset, bytes);
            self.bytes += bytes.len() as u64;
            self.writes += 1;
        }
    }
}

/// Figures of a crowd, for budgets and benchmarks.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CrowdStats {
    pub instances: usize,
    /// Instances out of view as of the last prepare
    /// ([`Crowd::set_culling`](super::Crowd::set_culling)): their records draw nothing.
    pub culled: usize,
    /// Triangles the instances in view draw.
    pub triangles: usize,
    /// Indices the records of the instances in view read, restarts included (as of the last
    /// prepare): an instance drawn from its compact copy reads its live indices, one restart
    /// between two strips and the restarts of its strips' places (at most 1.5× the first two),
    /// one drawn from its regions also the restart tails between its first and last live index.
    pub indices: u64,
    /// Instances by what their area holds (docs/DESIGN.md, "Crowds"): the asset's shared `S0`
    /// (not moved yet), their regions (close up), a compact copy of their live strips, their
    /// frame's tail list (far).
    pub from_s0: usize,
    pub from_regions: usize,
    pub from_copies: usize,
    pub from_tails: usize,
    /// GPU bytes the instances hold: their areas of index memory, records and blocks.
    pub instance_gpu_bytes: u64,
    /// GPU bytes of every buffer the crowd made: index memory (pages as grown), records,
    /// instance blocks, tail lists and templates, the shared assets, and the scratch below.
    pub gpu_bytes: u64,
    /// Of `gpu_bytes`, the scratch `prepare` keeps between frames: per page the scatters'
    /// patch lists and the tail jobs, each as large as the largest frame's since the page
    /// last grew (the frame that spawns thousands of instances sets it).
    pub scratch_gpu_bytes: u64,
    /// Host bytes of the scratch `prepare` keeps between frames: the encoded run list, as
    /// large as the largest frame's.
    pub scratch_host_bytes: u64,
    /// GPU bytes shared per asset (the [`GpuAsset`](crate::gpu::GpuAsset)s), summed.
    pub shared_gpu_bytes: u64,
    /// Host bytes the instances hold: runtimes, GPU-side lengths, and their record and block
    /// mirrors.
    pub instance_host_bytes: u64,
    /// Host bytes of the runtimes each asset keeps for the instances that leave a tail list
    /// (at most 32 an asset: not per instance).
    pub spare_host_bytes: u64,
}

pub(super) fn check_finite(what: &'static str, values: &[f32]) -> Result<(), CrowdError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(CrowdError::NonFinite {
            what,
            value: format!("{values:?}"),
        })
    }
}
