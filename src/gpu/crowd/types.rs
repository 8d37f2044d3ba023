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
    /// Every slot of the asset holds an instance.
    #[error("asset {asset} holds its capacity of {capacity} instances; remove one or add the asset again with a larger capacity")]
    Full { asset: u32, capacity: u32 },
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
    /// A capacity of 0, or one whose slots or vertex numbers do not fit the device or `u32`.
    #[error("a capacity of {capacity} instances does not fit: {why}")]
    Capacity { capacity: u32, why: String },
}

/// How much room an instance has for a compact copy of its live strips
/// ([`Crowd::set_records`](super::Crowd::set_records)).
///
/// An instance's index slots hold its strips in fixed regions, one per strip of `S0` with room for
/// its full length (patched at O(changed indices)); at a coarse LOD most of those slots are
/// restarts. Each slot range also has a compact area of `compact_share` of the regions' slots:
/// where the live strips, one restart between two, fit in it, the crowd keeps a copy of them there
/// (each strip in a place it keeps while it fits, patched as it changes; packed anew where the copy
/// would read more than 1.5× the packed count) and the instance's one draw record reads that copy,
/// i.e. the live indices, a restart between two strips and the restarts where strips shrank or
/// left; otherwise it reads the regions from the first live index to the last. The area shrinks (to
/// nothing at most) where `capacity` slot ranges would pass the device's buffer or storage binding
/// size ([`Crowd::compact_slots`](super::Crowd::compact_slots) says what an asset got; llvmpipe
/// binds 128 MiB: 1000 bodies keep 1,621 slots each). docs/DESIGN.md, "Crowds", has the measurement
/// behind the default.
///
/// At a frame's coarsest LODs, those that draw at most `tail_triangles` triangles (and fit the
/// compact area, 4 slots a triangle), an instance is drawn from its frame's tail list instead: one
/// triangle list per frame and asset, shared by every instance, which a compute pass expands into
/// the instance's compact area where its frame or LOD changed. Its runtime is then not kept
/// ([`Crowd::state`](super::Crowd::state) gives `None`) and its moves cost no rebuild and no patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrowdRecords {
    /// The compact area's share of the regions' slots, in 0..=1 (clamped): 0 never copies, 1
    /// always does.
    pub compact_share: f32,
    /// The most triangles a frame's tail list holds (0: no tail lists). The GPU work of an
    /// instance's expansion and the asset's tail lists grow with it.
    pub tail_triangles: u32,
}

impl Default for CrowdRecords {
    fn default() -> Self {
        CrowdRecords {
            compact_share: 0.125,
            tail_triangles: 1024,
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
    /// Drawn from its frame's tail list (see [`CrowdRecords`]).
    pub from_tail: bool,
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
    /// The instance's slot in its asset's buffers (index slots `slot × per_instance ..`, record
    /// `slot`, instance block `slot`).
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
    /// Bytes written: run lists of index slots and of record words (8 per lone word, 8 per run
    /// of up to 16 consecutive words plus 4 a word, headers padded to whole workgroups), new
    /// instances' `S0`, instance blocks, the scene block and textures.
    pub bytes: u64,
    /// `queue.write_buffer` and `write_texture` calls.
    pub writes: usize,
    /// Compute dispatches: the scatters (per asset one for index patches and one for record
    /// patches where it has them; more when a frame's patches pass a binding's size limit)
    /// and one per asset with tail expansions.
    pub dispatches: usize,
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
    /// GPU bytes one instance slot costs in its asset's buffers (index slots, record, block),
    /// summed over assets' slots in use.
    pub instance_gpu_bytes: u64,
    /// GPU bytes shared per asset (the [`GpuAsset`](crate::gpu::GpuAsset)s), summed.
    pub shared_gpu_bytes: u64,
    /// Host bytes the instances hold: runtimes, GPU-side lengths, and their record and block
    /// mirrors.
    pub instance_host_bytes: u64,
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
