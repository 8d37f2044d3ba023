//! A crowd: any number of instances of any number of assets, each instance at its own time,
//! LOD, transform and colour, drawn with one `multi_draw_indexed_indirect` per asset.
//!
//! What is shared and what is not (`docs/DESIGN.md`, "Crowds"):
//! * per asset, once: the [`GpuAsset`] (poses, surface, texture, target deltas), the
//!   [`DeformingModel`] (every frame's change lists), one index buffer with `capacity` ×
//!   slots-per-instance slots, one indirect buffer with one record per slot, one instance
//!   buffer with one [`InstanceBlock`](pipeline) per slot, and one bind group;
//! * per instance: its [`DeformingState`] (the runtime, which holds the current strips; none
//!   while it is drawn from a tail list), the lengths the GPU holds, one record and one
//!   192-byte block. No index mirror: the runtime's dirty log says what to upload.
//!
//! An instance's slots hold its strips in fixed regions (patched in place) and a compact area:
//! where its live strips fit there (a coarse LOD), its record draws their copy (each strip in
//! a place it keeps while it fits), so it reads the live indices and a few restarts, not the
//! restart tails of the regions ([`CrowdRecords`]). At a frame's coarsest LODs (a distant
//! instance) it is drawn from its frame's tail list instead: one triangle list per frame and
//! asset on the GPU, expanded into its compact area by a compute pass where its frame or LOD
//! changed, so that such an instance's move costs no rebuild and no patch (`tail.rs`).
//!
//! Per frame: [`set`](Crowd::set) moves every named instance in parallel (rayon) and, on the
//! same thread right after each move (while the instance's strips are in that core's cache),
//! makes its index patches (O(changed indices) for the regions and for the compact copy, whose
//! live indices only where it is repacked) and its record's; [`prepare`](Crowd::prepare)
//! uploads each asset's patches with one write and applies them with one compute dispatch,
//! does the same with the changed words of the records, and writes the changed instance
//! blocks as one contiguous range; [`render`](Crowd::render) binds each asset and issues its
//! one multi-draw. The caller owns device, queue and pass, as with an [`Object`](super::Object).
//!
//! The instance of a vertex reaches the shader one of two ways ([`CrowdPath`],
//! `shaders/crowd.wgsl`): as `first_instance` (the slot), with the poses and surface fetched
//! as vertex buffers, where the device has `wgpu::Features::INDIRECT_FIRST_INSTANCE` (without
//! it wgpu requires `first_instance = 0` in indirect draws); else through `base_vertex` (slot ×
//! vertex count), with every vertex pulled from storage buffers. Weight animations are summed
//! on the GPU from 8 weights per instance (the largest of the frame): exact for assets of at
//! most 8 targets, see [`WEIGHT_SLOTS`]; an asset without targets draws with an entry point
//! without the sum.
//!
//! Device features a crowd benefits from (the caller creates the device; [`super::Context`]
//! requests both where the adapter has them): `INDIRECT_FIRST_INSTANCE` (the first-instance
//! path, see [`CrowdPath`]) and, for the benchmark's GPU times, `TIMESTAMP_QUERY`.

mod bench;
mod cull;
mod discrete;
mod pipeline;
mod slots;
mod tail;

use std::sync::Arc;

use thiserror::Error;
use wgpu::util::{BufferInitDescriptor, DeviceExt, DrawIndexedIndirectArgs};

pub use self::bench::{
    run_crowd_bench, CrowdBenchOptions, CrowdBenchReport, FrameFigures, LevelFigures, ModeFigures,
    Stat,
};
pub use self::discrete::{DiscreteCrowd, DiscreteLevel, DiscreteLevels, LevelsError};
pub use self::pipeline::{CrowdPath, CROWD_WGSL, SCATTER_WGSL, TAIL_WGSL, WEIGHT_SLOTS};
use self::pipeline::{CrowdPipeline, InstanceBlock, MeshBlock, SceneBlock, Variant};
use self::slots::{Places, SlotLayout, SlotRecord};
use self::tail::{TailJob, TailLists, TRIANGLE_SLOTS};
use super::asset::GpuAsset;
use super::commands::RenderCommands;
use super::pose::{clamp_t, default_mode};
use super::records::ARGS_BYTES;
use super::scatter::{encode_runs, Dispatches, PatchBuffer, Scatter, RUN_GROUP};
use super::GpuError;
use crate::deform::{rebuild_all, DeformingModel, DeformingState, Lod, Plan, SetError, Strategy};
use crate::lodstrips::{Dirty, Survivors};
use crate::par;

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
    /// [`CrowdPath::FirstInstance`] asked of a device without `INDIRECT_FIRST_INSTANCE`.
    #[error("the first-instance path needs a device with wgpu::Features::INDIRECT_FIRST_INSTANCE; request it when creating the device, or use CrowdPath::BaseVertex")]
    NoFirstInstance,
    /// A capacity of 0, or one whose slots or vertex numbers do not fit the device or `u32`.
    #[error("a capacity of {capacity} instances does not fit: {why}")]
    Capacity { capacity: u32, why: String },
}

/// How much room an instance has for a compact copy of its live strips
/// ([`Crowd::set_records`]).
///
/// An instance's index slots hold its strips in fixed regions, one per strip of `S0` with room
/// for its full length (patched at O(changed indices)); at a coarse LOD most of those slots
/// are restarts. Each slot range also has a compact area of `compact_share` of the regions'
/// slots: where the live strips, one restart between two, fit in it, the crowd keeps a copy
/// of them there (each strip in a place it keeps while it fits, patched as it changes; packed
/// anew where the copy would read more than 1.5× the packed count) and the instance's one draw
/// record reads that copy, i.e. the live indices, a restart between two strips and the
/// restarts where strips shrank or left; otherwise it reads the regions from the first live
/// index to the last. The area shrinks (to nothing at most) where `capacity` slot ranges would pass the
/// device's buffer or storage binding size ([`Crowd::compact_slots`] says what an asset got;
/// llvmpipe binds 128 MiB: 1000 bodies keep 1,621 slots each). docs/DESIGN.md, "Crowds", has
/// the measurement behind the default.
///
/// At a frame's coarsest LODs, those that draw at most `tail_triangles` triangles (and fit the
/// compact area, 4 slots a triangle), an instance is drawn from its frame's tail list instead:
/// one triangle list per frame and asset, shared by every instance, which a compute pass
/// expands into the instance's compact area where its frame or LOD changed. Its runtime is
/// then not kept ([`Crowd::state`] gives `None`) and its moves cost no rebuild and no patch.
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

/// Where an instance is ([`Crowd::at`]).
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
pub struct AssetId(u32);

/// An instance of a crowd: its asset, its slot, and the slot's generation (a removed
/// instance's id stays invalid when the slot is reused).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct InstanceId {
    asset: u32,
    slot: u32,
    generation: u32,
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

/// What one [`Crowd::prepare`] sent to the GPU.
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
    fn write(&mut self, queue: &wgpu::Queue, buffer: &wgpu::Buffer, offset: u64, bytes: &[u8]) {
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
    /// Instances out of view as of the last prepare ([`Crowd::set_culling`]): their records
    /// draw nothing.
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
    /// GPU bytes shared per asset (the [`GpuAsset`]s), summed.
    pub shared_gpu_bytes: u64,
    /// Host bytes the instances hold: runtimes, GPU-side lengths, and their record and block
    /// mirrors.
    pub instance_host_bytes: u64,
}

/// Instances of several assets drawn together: `add`/`remove` at run time, `set` per frame,
/// `prepare`, `render`.
pub struct Crowd {
    path: CrowdPath,
    pipeline: CrowdPipeline,
    scene: SceneBlock,
    scene_buffer: wgpu::Buffer,
    scene_dirty: bool,
    /// What assets without a texture bind: a white texel and a sampler.
    white: (wgpu::Texture, wgpu::TextureView, wgpu::Sampler),
    white_pending: bool,
    /// The compact area of the assets added from now on.
    records: CrowdRecords,
    /// Whether instances out of view draw nothing ([`Crowd::set_culling`]).
    culling: bool,
    assets: Vec<CrowdAsset>,
}

/// One asset of a crowd and its instances.
struct CrowdAsset {
    gpu: Arc<GpuAsset>,
    model: Arc<DeformingModel>,
    layout: SlotLayout,
    capacity: u32,
    index_buffer: wgpu::Buffer,
    indirect_buffer: wgpu::Buffer,
    instance_buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Its render pipeline (number in the crowd's [`CrowdPipeline`]) and vertex entry point.
    render: usize,
    variant: Variant,
    /// The patch lists' GPU buffers, for the index buffer and for the indirect buffer, with
    /// the scatter's bind group over each; grown on demand.
    patch_buffers: [Option<PatchBuffer>; 2],
    /// Instance of each slot (`None`: free).
    members: Vec<Option<Member>>,
    /// Generation of each slot, bumped when its instance is removed.
    generations: Vec<u32>,
    /// Free slots, reused lowest first.
    free: Vec<u32>,
    /// Records drawn: one past the highest slot in use.
    drawn: u32,
    /// Mirror of the indirect buffer: one record per slot.
    records: Vec<DrawIndexedIndirectArgs>,
    blocks: Vec<InstanceBlock>,
    dirty_blocks: Span,
    /// The patches made since the last prepare.
    waiting: Waiting,
    /// Scratch of a scatter: the encoded run list.
    run_list: Vec<u32>,
    /// Slots added to since the last prepare, once per add: a slot listed that holds an
    /// instance holds one added since (a slot is added to only while free), whose regions
    /// get `S0`.
    fresh: Vec<u32>,
    /// Prepares so far (a [`Member`] notes the one its patches wait for).
    prepares: u64,
    /// Scratch of prepare: the record runs, kept with their capacity between frames.
    record_runs: PatchRuns,
    /// Its frames' tail lists, their words on the GPU (none where no frame has a tail), and
    /// the job list's buffer and bind group (grown on demand).
    tails: TailLists,
    tail_words: Option<wgpu::Buffer>,
    tail_jobs: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    /// Scratch of prepare: the jobs.
    jobs: Vec<TailJob>,
}

/// The patches an asset's instances made since the last prepare.
#[derive(Default)]
struct Waiting {
    /// Index patches as runs: one list per piece of work of `set`'s passes, in the order made.
    index_runs: Vec<PatchRuns>,
    /// The record words changed, as `[word, value]` patches of the indirect buffer.
    records: Patches,
    /// Some word may be in two of `index_runs` (an instance moved by two `set`s, or one
    /// removed after its patches were made): prepare then merges them first.
    overlap: bool,
    /// Slots whose instance was removed after its patches were made, each with the number of
    /// `index_runs` lists made before: those lists' patches of the slot are dropped (the slot
    /// may hold a new instance by then, written `S0` before the patches apply).
    withdrawn: Vec<(u32, usize)>,
    /// Slots whose instance moved in its frame's tail (maybe twice: `prepare` writes those
    /// still there, once).
    tails: Vec<u32>,
}

impl Waiting {
    /// Keeps the pieces' patches; returns their rebuilds, in slot order.
    fn take(&mut self, pieces: Vec<(PatchRuns, Piece)>) -> Vec<(usize, Plan)> {
        let mut rebuilds = Vec::new();
        for (runs, piece) in pieces {
            rebuilds.extend_from_slice(&piece.rebuilds);
            if !runs.values.is_empty() {
                self.index_runs.push(runs);
            }
            self.records.extend_from_slice(&piece.records);
            self.tails.extend_from_slice(&piece.tails);
            self.overlap |= piece.again;
        }
        rebuilds
    }

    /// Merges the index patches into one list where each word has its last value, less the
    /// withdrawn slots' patches made before their removal (`per`: slots per instance).
    fn merge(&mut self, per: u32) {
        let mut patches = Vec::new();
        for (list, runs) in self.index_runs.iter().enumerate() {
            for (first, values) in runs.iter() {
                for (word, &value) in (first..).zip(values) {
                    let withdrawn = (self.withdrawn.iter())
                        .any(|&(slot, lists)| list < lists && word / per == slot);
                    if !withdrawn {
                        patches.push([word, value]);
                    }
                }
            }
        }
        keep_last_per_word(&mut patches);
        self.index_runs = vec![PatchRuns::of(&patches)];
        self.withdrawn.clear();
        self.overlap = false;
    }
}

/// Leaves one patch per word, the last pushed (a stable sort by word keeps each word's
/// patches in the order they were made).
fn keep_last_per_word(patches: &mut Vec<[u32; 2]>) {
    patches.sort_by_key(|p| p[0]);
    let mut kept = 0;
    for i in 0..patches.len() {
        if patches
            .get(i + 1)
            .is_some_and(|next| next[0] == patches[i][0])
        {
            continue;
        }
        patches[kept] = patches[i];
        kept += 1;
    }
    patches.truncate(kept);
}

/// Whether no word is patched twice (a word sent twice is wasted bytes, and with two values
/// a race: the scatter's invocations run in any order).
fn each_word_once(words: impl Iterator<Item = u32>) -> bool {
    let mut words: Vec<u32> = words.collect();
    words.sort_unstable();
    words.windows(2).all(|w| w[0] != w[1])
}

/// `[slot, value]` patches of the index buffer, or `[word, value]` of the indirect buffer.
type Patches = Vec<[u32; 2]>;

/// Patches as the scatter sends them: runs of consecutive words, each its first word and the
/// range of its values in `values` (the patches' values in order).
#[derive(Default)]
struct PatchRuns {
    values: Vec<u32>,
    runs: Vec<(u32, std::ops::Range<usize>)>,
}

impl PatchRuns {
    /// The runs of `patches`: consecutive words in the list make one run (a compact copy and a
    /// record are patched in order): 8 bytes of run list for a lone word, 8 plus 4 a word for
    /// a run.
    fn of(patches: &[[u32; 2]]) -> PatchRuns {
        let mut runs = PatchRuns::default();
        runs.refill(patches);
        runs
    }

    /// [`of`](Self::of), into this list's storage.
    fn refill(&mut self, patches: &[[u32; 2]]) {
        self.runs.clear();
        for (i, p) in patches.iter().enumerate() {
            match self.runs.last_mut() {
                Some((first, values)) if *first + (i - values.start) as u32 == p[0] => {
                    values.end = i + 1;
                }
                _ => self.runs.push((p[0], i..i + 1)),
            }
        }
        self.values.clear();
        self.values.extend(patches.iter().map(|p| p[1]));
    }

    /// Each run as its first word and its values.
    fn iter(&self) -> impl Iterator<Item = (u32, &[u32])> + Clone {
        self.runs
            .iter()
            .map(|(first, range)| (*first, &self.values[range.clone()]))
    }
}

/// Fewest slots per piece of work of `set`'s parallel pass: a moved instance there costs a
/// pose and a plan, one that steps or switches to its frame's tail a few microseconds more
/// (the move and its patches), so that smaller pieces cost more in handing out and in
/// patch lists than they gain.
const MOVES_PER_PIECE: usize = 16;

/// Which buffer of an asset a scatter patches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Patched {
    Indices,
    Records,
}

/// Sets `record` (slot `slot`'s) to read `what` of its slots (`path`: where the slot rides,
/// `vertex_count`: the asset's) and appends to `patches` one `[word, value]` patch of the
/// indirect buffer per word that changed.
fn set_record(
    (path, vertex_count, per_instance): (CrowdPath, u32, u32),
    slot: u32,
    what: Option<SlotRecord>,
    record: &mut DrawIndexedIndirectArgs,
    patches: &mut Vec<[u32; 2]>,
) {
    // The slot rides in first_instance or in base_vertex (checked to fit in add_asset).
    let (base_vertex, first_instance) = match path {
        CrowdPath::FirstInstance => (0, slot),
        CrowdPath::BaseVertex => ((slot * vertex_count) as i32, 0),
    };
    let new = what
        .filter(|w| w.count > 0)
        .map_or_else(Default::default, |w| DrawIndexedIndirectArgs {
            index_count: w.count,
            instance_count: 1,
            first_index: slot * per_instance + w.first,
            base_vertex,
            first_instance,
        });
    let old: [u32; 5] = bytemuck::cast(*record);
    let now: [u32; 5] = bytemuck::cast(new);
    let first_word = slot * 5;
    for (w, (&o, &v)) in (0u32..).zip(old.iter().zip(&now)) {
        if o != v {
            patches.push([first_word + w, v]);
        }
    }
    *record = new;
}

/// One instance: its runtime and what its slots on the GPU hold.
struct Member {
    /// Its runtime; none until its first move out of the tail lists (it draws `S0` until its
    /// first move) and while it is drawn from a tail list (made anew, at full detail, when it
    /// leaves): a distant instance holds no strips.
    state: Option<DeformingState>,
    /// Live length of every region as the GPU holds it; empty while that is `S0`'s (the
    /// regions of a new instance, not patched since): most of a crowd's instances are drawn
    /// from their compact copies from their first upload on and never need the table.
    uploaded: Vec<u32>,
    /// Its strips' places in the compact copy, and whether its regions lag behind.
    places: Places,
    /// The runtime's [`DeformingState::changes`] as of the last upload of its strips (to the
    /// regions or to the compact copy).
    changes: u64,
    /// A move asked by `set`, applied by its parallel pass.
    pending: Option<(f32, Lod)>,
    /// The asset's prepare count when its last patches were made: equal to the current
    /// count, they wait in the asset's lists.
    patched: u64,
    /// Frame and LOD while it is drawn from its frame's tail list (its runtime is left where
    /// it was), and whether its compact area holds them (written by a `prepare`).
    tail: Option<(u32, u32)>,
    expanded: bool,
    /// Whether its record's instance count is 0 on the GPU for being out of view (the
    /// mirror keeps the count it draws in view; `cull.rs`).
    hidden: bool,
}

impl Member {
    /// Where its strips changed since its last patches: appends to `piece` the patches that
    /// bring its slots (at `slot` of `layout`) and its record to them: those of its compact
    /// copy where that is drawn (in the strips' places), else of its regions. While the
    /// compact copy is drawn the regions are not read nor patched: its `Places` notes that
    /// they lag, and when a record reads them again every live strip is sent whole.
    fn patch(
        &mut self,
        layout: &SlotLayout,
        key: (CrowdPath, u32, u32),
        slot: u32,
        record: &mut DrawIndexedIndirectArgs,
        prepares: u64,
        piece: &mut Piece,
    ) {
        let state = self
            .state
            .as_mut()
            .expect("out of the tail lists: a runtime");
        // Unchanged strips keep their slots, record and compact copy.
        let changes = state.changes();
        if changes == self.changes {
            return;
        }
        self.changes = changes;
        piece.again |= self.patched == prepares;
        self.patched = prepares;
        let drawn = layout.upload(
            slot * key.2,
            state,
            &mut self.places,
            &mut self.uploaded,
            &mut piece.dirty,
            &mut piece.patches,
        );
        set_record(key, slot, Some(drawn), record, &mut piece.records);
    }

    /// Draws it from frame `k`'s tail list at LOD `l` (`count` triangles, in its compact
    /// area): from the next `prepare` on, which writes them there. Its runtime is dropped. Its
    /// copy and its regions no longer hold what it draws: the copy is repacked and the regions
    /// get every live strip when it leaves the tail.
    #[allow(clippy::too_many_arguments)]
    fn enter_tail(
        &mut self,
        layout: &SlotLayout,
        key: (CrowdPath, u32, u32),
        slot: u32,
        (k, l, count): (usize, usize, u32),
        record: &mut DrawIndexedIndirectArgs,
        piece: &mut Piece,
    ) {
        if self.tail == Some((k as u32, l as u32)) {
            return;
        }
        if self.tail.is_none() {
            self.places.leave();
            self.state = None;
        }
        self.tail = Some((k as u32, l as u32));
        self.expanded = false;
        piece.tails.push(slot);
        // Up to the last triangle's corners: a record ends on an index, not a restart.
        let drawn = layout.tail_record((count * TRIANGLE_SLOTS).saturating_sub(1));
        set_record(key, slot, Some(drawn), record, &mut piece.records);
    }

    /// Its runtime, made anew at full detail where it leaves the tail list it was drawn from:
    /// its next patch then sends its strips from scratch (a repacked copy, or every live strip
    /// to the regions).
    fn leave_tail(&mut self, model: &DeformingModel) -> &mut DeformingState {
        if self.tail.take().is_some() {
            self.changes = u64::MAX;
        }
        self.state.get_or_insert_with(|| DeformingState::new(model))
    }

    /// Heap bytes of the instance: its runtime and lengths, and itself.
    fn heap_bytes(&self) -> usize {
        size_of::<Member>()
            + self.state.as_ref().map_or(0, DeformingState::heap_bytes)
            + self.uploaded.capacity() * 4
            + self.places.heap_bytes()
    }
}

/// What one piece of work of `set`'s passes made: its rebuilds over the mesh (left to the
/// rebuild pass), its instances' index and record patches.
#[derive(Default)]
struct Piece {
    /// Scratch of the poses.
    weights: Vec<f32>,
    rebuilds: Vec<(usize, Plan)>,
    /// Scratch of the instances' dirty logs, reused from one to the next.
    dirty: Dirty,
    patches: Patches,
    records: Patches,
    /// An instance patched a second time since the last prepare.
    again: bool,
    /// Slots whose instance moved in its frame's tail.
    tails: Vec<u32>,
}

impl Piece {
    /// Its index patches as runs, made on the piece's thread: gathered on the calling thread
    /// they were most of the crowd's serial time (tens of thousands of patches a frame).
    fn runs(self) -> (PatchRuns, Piece) {
        (PatchRuns::of(&self.patches), self)
    }
}

/// A range of slots changed since the last upload (empty: `start >= end`).
#[derive(Clone, Copy, Debug)]
struct Span {
    start: u32,
    end: u32,
}

impl Span {
    const EMPTY: Span = Span {
        start: u32::MAX,
        end: 0,
    };

    fn add(&mut self, slot: u32) {
        self.start = self.start.min(slot);
        self.end = self.end.max(slot + 1);
    }

    fn take(&mut self) -> Option<std::ops::Range<u32>> {
        let span = std::mem::replace(self, Span::EMPTY);
        (span.start < span.end).then_some(span.start..span.end)
    }
}

impl Crowd {
    /// An empty crowd drawing into passes of `color_format` and `depth_format` (as
    /// [`super::MorphPipeline::new`]), back faces culled, on the first-instance path where
    /// `device` has `INDIRECT_FIRST_INSTANCE` and the base-vertex path elsewhere.
    pub fn new(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        depth_format: Option<wgpu::TextureFormat>,
    ) -> Crowd {
        let path = if device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
        {
            CrowdPath::FirstInstance
        } else {
            CrowdPath::BaseVertex
        };
        Crowd::on_path(device, color_format, depth_format, path)
    }

    /// [`new`](Self::new) on the given path: [`CrowdPath::BaseVertex`] works on any device
    /// (tests and benchmarks force it to compare), [`CrowdPath::FirstInstance`] needs
    /// `INDIRECT_FIRST_INSTANCE` ([`CrowdError::NoFirstInstance`]).
    pub fn with_path(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        depth_format: Option<wgpu::TextureFormat>,
        path: CrowdPath,
    ) -> Result<Crowd, CrowdError> {
        let has = device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE);
        if path == CrowdPath::FirstInstance && !has {
            return Err(CrowdError::NoFirstInstance);
        }
        Ok(Crowd::on_path(device, color_format, depth_format, path))
    }

    fn on_path(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        depth_format: Option<wgpu::TextureFormat>,
        path: CrowdPath,
    ) -> Crowd {
        let pipeline =
            CrowdPipeline::new(device, color_format, depth_format, Some(wgpu::Face::Back));
        let uniforms = super::Uniforms::new();
        let scene = SceneBlock {
            view_proj: uniforms.view_proj,
            light: uniforms.light,
            encode_srgb: u32::from(!color_format.is_srgb()),
            _pad: [0; 3],
        };
        let scene_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("crowd scene"),
            contents: bytemuck::bytes_of(&scene),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let white = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("crowd white texel"),
            size: wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let view = white.create_view(&Default::default());
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor::default());
        Crowd {
            path,
            pipeline,
            scene,
            scene_buffer,
            scene_dirty: false,
            white: (white, view, sampler),
            white_pending: true,
            records: CrowdRecords::default(),
            culling: true,
            assets: Vec::new(),
        }
    }

    /// The compact area of the assets added from now on (assets added before keep theirs);
    /// [`CrowdRecords::default`] until set.
    pub fn set_records(&mut self, records: CrowdRecords) {
        self.records = records;
    }

    /// Adds an asset with room for `capacity` instances: its index buffer (`capacity` × the
    /// slots of `S0` plus one separator per strip), indirect and instance buffers are made
    /// now. `model` must be made from the asset `gpu` was uploaded from
    /// ([`CrowdError::ModelMismatch`]), `gpu` on `device` ([`GpuError::OtherDevice`]).
    pub fn add_asset(
        &mut self,
        device: &wgpu::Device,
        gpu: Arc<GpuAsset>,
        model: Arc<DeformingModel>,
        capacity: u32,
    ) -> Result<AssetId, CrowdError> {
        if !gpu.is_on(device) {
            return Err(GpuError::OtherDevice.into());
        }
        let n = gpu.vertex_count();
        if model.layout().vertex_count() != n as usize {
            return Err(CrowdError::ModelMismatch {
                model: model.layout().vertex_count(),
                asset: n,
            });
        }
        let limits = device.limits();
        let refuse = |why: String| Err(CrowdError::Capacity { capacity, why });
        if capacity == 0 {
            return refuse("give room for at least one instance".into());
        }
        // The compact area gives way where the slots would pass the device's limits (the
        // scatter binds the whole index buffer).
        let max_bytes = limits
            .max_buffer_size
            .min(limits.max_storage_buffer_binding_size);
        let mut layout = SlotLayout::new(&model, self.records.compact_share);
        layout.fit(max_bytes / 4 / u64::from(capacity));
        // A tail list's LODs fit the compact area.
        let budget = (self.records.tail_triangles).min(layout.compact_slots() / TRIANGLE_SLOTS);
        let mut tails = TailLists::build(&model, budget as usize);
        let words = tails.take_words();
        let tail_words = (!words.is_empty()).then(|| {
            device.create_buffer_init(&BufferInitDescriptor {
                label: Some("crowd tail lists"),
                contents: bytemuck::cast_slice(&words),
                usage: wgpu::BufferUsages::STORAGE,
            })
        });
        let per = u64::from(layout.per_instance().max(1));
        // base_vertex (an i32) is slot × n, and slot × n + index is the vertex_index (a u32).
        if self.path == CrowdPath::BaseVertex
            && u64::from(capacity) * u64::from(n) > i32::MAX as u64
        {
            return refuse(format!(
                "{n} vertices times the capacity passes 2^31 (base_vertex)"
            ));
        }
        let index_bytes = u64::from(capacity) * per * 4;
        if u64::from(capacity) * per > u64::from(u32::MAX) || index_bytes > max_bytes {
            return refuse(format!(
                "{index_bytes} bytes of index slots pass the device's buffer limit"
            ));
        }
        let block_bytes = u64::from(capacity) * size_of::<InstanceBlock>() as u64;
        if block_bytes > limits.max_storage_buffer_binding_size {
            return refuse(format!(
                "{block_bytes} bytes of instance blocks pass the device's binding limit"
            ));
        }
        let record_bytes = u64::from(capacity) * ARGS_BYTES;
        if record_bytes > limits.max_storage_buffer_binding_size {
            return refuse(format!(
                "{record_bytes} bytes of draw records pass the device's binding limit"
            ));
        }

        let index_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crowd indices"),
            size: index_bytes,
            // STORAGE: the scatter writes the patches; COPY_SRC: tests read the slots back.
            usage: wgpu::BufferUsages::INDEX
                | wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        // Zeroed records draw nothing (index and instance counts 0). STORAGE: the scatter
        // writes the changed record words.
        let indirect_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crowd records"),
            size: record_bytes,
            usage: wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let instance_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crowd instances"),
            size: block_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mesh_buffer = mesh_buffer(device, &gpu);
        let bind_group = self.bind_group(device, &gpu, &mesh_buffer, &instance_buffer);
        let variant = Variant::new(self.path, gpu.has_surface(), gpu.target_count());
        let render = self.pipeline.render_for(device, variant);
        let id = self.assets.len() as u32;
        self.assets.push(CrowdAsset {
            gpu,
            model,
            layout,
            capacity,
            index_buffer,
            indirect_buffer,
            instance_buffer,
            bind_group,
            render,
            variant,
            patch_buffers: [None, None],
            members: (0..capacity).map(|_| None).collect(),
            generations: vec![0; capacity as usize],
            free: (0..capacity).rev().collect(),
            drawn: 0,
            records: vec![DrawIndexedIndirectArgs::default(); capacity as usize],
            blocks: vec![InstanceBlock::new(glam::Mat4::IDENTITY); capacity as usize],
            dirty_blocks: Span::EMPTY,
            waiting: Waiting::default(),
            run_list: Vec::new(),
            fresh: Vec::new(),
            prepares: 0,
            record_runs: PatchRuns::default(),
            tails,
            tail_words,
            tail_jobs: None,
            jobs: Vec::new(),
        });
        Ok(AssetId(id))
    }

    fn bind_group(
        &self,
        device: &wgpu::Device,
        gpu: &GpuAsset,
        mesh: &wgpu::Buffer,
        instances: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let zero = || super::asset::storage_or_zero(device, "crowd zero", &[]);
        let (deltas, normal_deltas) = match gpu.targets() {
            Some(t) => (t.position_buffer.clone(), t.normal_buffer.clone()),
            None => (zero(), zero()),
        };
        let surface = gpu.surface();
        let attributes = surface.map_or_else(zero, |s| s.buffer.clone());
        let (view, sampler) = match surface {
            Some(s) => (&s.view, &s.sampler),
            None => (&self.white.1, &self.white.2),
        };
        let buffers = [
            &self.scene_buffer,
            mesh,
            instances,
            gpu.v0(),
            gpu.v1(),
            &deltas,
            &attributes,
            &normal_deltas,
        ];
        let mut entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding: binding as u32,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        entries.push(wgpu::BindGroupEntry {
            binding: 8,
            resource: wgpu::BindingResource::TextureView(view),
        });
        entries.push(wgpu::BindGroupEntry {
            binding: 9,
            resource: wgpu::BindingResource::Sampler(sampler),
        });
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("crowd asset"),
            layout: &self.pipeline.layout,
            entries: &entries,
        })
    }

    /// Adds an instance of `asset` at full detail, time 0, with transform `model` (finite),
    /// in the lowest free slot; drawn from the next prepare.
    pub fn add(&mut self, asset: AssetId, model: glam::Mat4) -> Result<InstanceId, CrowdError> {
        check_finite("transform", &model.to_cols_array())?;
        let a = self
            .assets
            .get_mut(asset.0 as usize)
            .ok_or(CrowdError::UnknownAsset(asset.0))?;
        let slot = a.free.pop().ok_or(CrowdError::Full {
            asset: asset.0,
            capacity: a.capacity,
        })?;
        // Its compact area holds nothing of it yet: the record reads S0 from the regions. Its
        // runtime is made by its first move out of the tail lists (most of a crowd's
        // instances are distant: their first move takes them to one).
        let record = a.layout.region_record(&a.layout.s0_lengths());
        let key = (self.path, a.gpu.vertex_count(), a.layout.per_instance());
        set_record(
            key,
            slot,
            Some(record),
            &mut a.records[slot as usize],
            &mut a.waiting.records,
        );
        a.blocks[slot as usize] = InstanceBlock::new(model);
        a.dirty_blocks.add(slot);
        a.members[slot as usize] = Some(Member {
            changes: u64::MAX,
            state: None,
            uploaded: Vec::new(),
            places: Places::default(),
            pending: None,
            patched: u64::MAX,
            tail: None,
            expanded: false,
            hidden: false,
        });
        a.fresh.push(slot);
        a.drawn = a.drawn.max(slot + 1);
        Ok(InstanceId {
            asset: asset.0,
            slot,
            generation: a.generations[slot as usize],
        })
    }

    /// Removes an instance: its record draws nothing from the next prepare and its slot is
    /// reused by a later [`add`](Self::add); its id is refused from now on.
    pub fn remove(&mut self, id: InstanceId) -> Result<(), CrowdError> {
        let path = self.path;
        let a = self.member_asset(id)?;
        let slot = id.slot as usize;
        if a.members[slot]
            .take()
            .is_some_and(|m| m.patched == a.prepares)
        {
            (a.waiting.withdrawn).push((id.slot, a.waiting.index_runs.len()));
            a.waiting.overlap = true;
        }
        a.generations[slot] = a.generations[slot].wrapping_add(1);
        let key = (path, a.gpu.vertex_count(), a.layout.per_instance());
        set_record(
            key,
            id.slot,
            None,
            &mut a.records[slot],
            &mut a.waiting.records,
        );
        // Lowest slot reused first: keeps the drawn records dense.
        let at = a.free.partition_point(|&s| s > id.slot);
        a.free.insert(at, id.slot);
        while a.drawn > 0 && a.members[a.drawn as usize - 1].is_none() {
            a.drawn -= 1;
        }
        Ok(())
    }

    /// The asset of a live instance, checked.
    fn member_asset(&mut self, id: InstanceId) -> Result<&mut CrowdAsset, CrowdError> {
        let a = self
            .assets
            .get_mut(id.asset as usize)
            .ok_or(CrowdError::UnknownInstance(id))?;
        let live = a.generations.get(id.slot as usize) == Some(&id.generation)
            && a.members[id.slot as usize].is_some();
        if live {
            Ok(a)
        } else {
            Err(CrowdError::UnknownInstance(id))
        }
    }

    /// Moves every instance of `moves` to its `(t, lod)` (as [`DeformingState::set`]: `t` and
    /// LOD clamped, NaN refused), all in parallel, and sets its pose: `mix(V(0), V(1), t)`, or
    /// for an asset with a weight animation the track's weights at `t` (the 8 largest, see
    /// [`WEIGHT_SLOTS`]), and makes the patches of its slots that the next `prepare` uploads.
    /// Everything is checked first: on error nothing moved. An instance
    /// named twice takes its last move.
    pub fn set(&mut self, moves: &[(InstanceId, f32, Lod)]) -> Result<(), CrowdError> {
        // What a move can be refused for (the LOD is resolved once, in the parallel pass).
        for &(id, t, lod) in moves {
            let a = self.member_asset(id)?;
            a.model.frame_at(t)?;
            lod.check()?;
        }
        let mut moved = vec![false; self.assets.len()];
        for &(id, t, lod) in moves {
            let a = &mut self.assets[id.asset as usize];
            if let Some(member) = &mut a.members[id.slot as usize] {
                member.pending = Some((t, lod));
            }
            a.dirty_blocks.add(id.slot);
            moved[id.asset as usize] = true;
        }
        let path = self.path;
        for (a, _) in self.assets.iter_mut().zip(moved).filter(|(_, m)| *m) {
            let (model, track, layout, tails) = (&a.model, a.gpu.track(), &a.layout, &a.tails);
            let key = (path, a.gpu.vertex_count(), layout.per_instance());
            let prepares = a.prepares;
            // In parallel, in pieces of consecutive slots (a few a thread, so that pieces
            // with many frame switches even out): every moved instance's pose and plan; the
            // moves into a frame's tail list take its record only; the moves that step or
            // rebuild from a frame's tail are made here, and the instance's patches right
            // after them; the rebuilds over the mesh are gathered.
            let per = par::piece_len(a.members.len(), MOVES_PER_PIECE);
            let parts: Vec<_> = (a.members.chunks_mut(per))
                .zip(a.blocks.chunks_mut(per))
                .zip(a.records.chunks_mut(per))
                .enumerate()
                .collect();
            let pieces = par::map(parts, |(k, ((members, blocks), records))| {
                let mut piece = Piece::default();
                let slots = (k * per..).zip(members.iter_mut().zip(blocks).zip(records));
                for (slot, ((member, block), record)) in slots {
                    let Some(member) = member.as_mut() else {
                        continue;
                    };
                    let Some((t, lod)) = member.pending.take() else {
                        continue;
                    };
                    let t = clamp_t(t).expect("checked time");
                    block.set_pose(track, t, &mut piece.weights);
                    // Checked above: cannot fail.
                    let k = model.frame_at(t).expect("checked time");
                    let l = model.resolve(k, lod).expect("checked LOD");
                    if let Some(count) = tails.triangles(k, l) {
                        let at = (k, l, count);
                        member.enter_tail(layout, key, slot as u32, at, record, &mut piece);
                        continue;
                    }
                    let state = member.leave_tail(model);
                    let plan = state.plan_at(model, k, l, Strategy::Auto);
                    if plan.links_survivors(model) {
                        piece.rebuilds.push((slot, plan));
                        continue;
                    }
                    state.apply(model, plan, &mut Survivors::new());
                    member.patch(layout, key, slot as u32, record, prepares, &mut piece);
                }
                piece.runs()
            });
            let rebuilds = a.waiting.take(pieces);
            if rebuilds.is_empty() {
                continue;
            }
            // The rebuilds over the mesh, by frame (instances switching to one frame share
            // its survivors), each instance's patches right after its rebuild.
            let mut plans = rebuilds.into_iter().peekable();
            let mut jobs = Vec::with_capacity(plans.len());
            for (slot, (member, record)) in a.members.iter_mut().zip(&mut a.records).enumerate() {
                if let (Some(member), Some(&(s, plan))) = (member, plans.peek()) {
                    if s == slot {
                        jobs.push((plan, (slot as u32, member, record)));
                        plans.next();
                    }
                }
            }
            let pieces = rebuild_all(
                model,
                &mut jobs,
                |(_, member, _)| member.state.as_mut().expect("moved out of the tail lists"),
                |(slot, member, record), piece: &mut Piece| {
                    member.patch(layout, key, *slot, record, prepares, piece);
                },
                Piece::runs,
            );
            a.waiting.take(pieces);
        }
        Ok(())
    }

    /// Sets an instance's object-to-world transform (finite).
    pub fn set_transform(&mut self, id: InstanceId, model: glam::Mat4) -> Result<(), CrowdError> {
        check_finite("transform", &model.to_cols_array())?;
        let a = self.member_asset(id)?;
        a.blocks[id.slot as usize].set_model(model);
        a.dirty_blocks.add(id.slot);
        Ok(())
    }

    /// Sets an instance's colour (faceted and smooth modes; finite).
    pub fn set_color(&mut self, id: InstanceId, color: [f32; 4]) -> Result<(), CrowdError> {
        check_finite("colour", &color)?;
        let a = self.member_asset(id)?;
        a.blocks[id.slot as usize].color = color;
        a.dirty_blocks.add(id.slot);
        Ok(())
    }

    /// Sets projection * view for every instance.
    pub fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.scene.view_proj = view_proj.to_cols_array_2d();
        self.scene_dirty = true;
    }

    /// Whether an instance out of view draws nothing (default: on). From the next prepare on,
    /// every prepare tests each instance's bounding sphere (its asset's poses, grown by its
    /// weights' reach, under its transform) against the view's clip volume and gives the
    /// record of an instance wholly outside it an instance count of 0 on the GPU. The test
    /// never culls an instance with a point in view, so the pixels do not change; the GPU
    /// skips the vertices. Its CPU moves (`set`) still apply, so an instance that comes back
    /// into view draws its current frame and LOD. Off: every record as [`Crowd::at`] says.
    pub fn set_culling(&mut self, on: bool) {
        self.culling = on;
    }

    /// The runtime of an instance (frame, LOD, triangles, strips), or `None` where it has none:
    /// while it is drawn from its frame's tail list ([`CrowdRecords`]), and before its first
    /// move (it draws `S0`, frame 0 at full detail).
    pub fn state(&self, id: InstanceId) -> Result<Option<&DeformingState>, CrowdError> {
        let member = self.member(id)?;
        Ok(member.state.as_ref())
    }

    /// Where an instance is: its frame, LOD and triangles, from its runtime or its frame's
    /// tail list.
    pub fn at(&self, id: InstanceId) -> Result<InstanceAt, CrowdError> {
        let member = self.member(id)?;
        Ok(self.assets[id.asset as usize].at(member))
    }

    /// A live instance, checked.
    fn member(&self, id: InstanceId) -> Result<&Member, CrowdError> {
        let a = self
            .assets
            .get(id.asset as usize)
            .ok_or(CrowdError::UnknownInstance(id))?;
        match (
            a.generations.get(id.slot as usize),
            a.members.get(id.slot as usize),
        ) {
            (Some(&g), Some(Some(member))) if g == id.generation => Ok(member),
            _ => Err(CrowdError::UnknownInstance(id)),
        }
    }

    /// Uploads what changed since the last call: per asset the new instances' `S0` (one write
    /// each), the index patches `set` made (one write and one scatter dispatch,
    /// submitted here on `queue`), the changed records and instance blocks (one contiguous
    /// write each); the scene block and textures. Call before submitting the pass that
    /// renders the crowd.
    pub fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> CrowdUpload {
        let mut dispatches = Dispatches::Own(None);
        let upload = self.upload(device, queue, &mut dispatches);
        dispatches.submit_own(queue);
        upload
    }

    /// [`prepare`](Self::prepare), with the scatter dispatches recorded into `encoder` instead
    /// of submitted on their own, so that the crowd's uploads and the frame's passes go in one
    /// submission (a frame whose patches pass one binding still submits its full lists here).
    /// Rules for the caller, as for egui-wgpu's `update_buffers`: record the pass that renders
    /// the crowd into `encoder` after this call, and submit `encoder` on `queue` before the
    /// crowd's next `prepare` or `prepare_with` (that call rewrites the patch lists the
    /// recorded dispatches read).
    pub fn prepare_with(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
    ) -> CrowdUpload {
        self.upload(device, queue, &mut Dispatches::Caller(encoder))
    }

    /// Both `prepare`s: every write, and the scatter dispatches recorded in `dispatches`.
    fn upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        dispatches: &mut Dispatches,
    ) -> CrowdUpload {
        let mut upload = CrowdUpload::default();
        if std::mem::take(&mut self.white_pending) {
            queue.write_texture(
                self.white.0.as_image_copy(),
                &[255; 4],
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4),
                    rows_per_image: Some(1),
                },
                self.white.0.size(),
            );
        }
        if std::mem::take(&mut self.scene_dirty) {
            upload.write(
                queue,
                &self.scene_buffer,
                0,
                bytemuck::bytes_of(&self.scene),
            );
        }
        let view_proj = glam::Mat4::from_cols_array_2d(&self.scene.view_proj);
        let frustum = self.culling.then(|| cull::Frustum::new(view_proj));
        for a in &mut self.assets {
            let texture = a.gpu.upload(queue);
            upload.bytes += texture;
            upload.writes += usize::from(texture > 0);
            // New instances' regions get S0 (written before this frame's scatter runs, so
            // patches made since their add land on it).
            // A slot removed and added to again is listed twice and written once.
            let per = a.layout.per_instance();
            a.fresh.sort_unstable();
            a.fresh.dedup();
            for slot in a.fresh.drain(..) {
                if a.members[slot as usize].is_some() {
                    let offset = u64::from(slot * per) * 4;
                    upload.write(
                        queue,
                        &a.index_buffer,
                        offset,
                        bytemuck::cast_slice(a.layout.s0()),
                    );
                }
            }
            if a.waiting.overlap {
                a.waiting.merge(per);
            }
            a.prepares += 1;
            let index_runs = std::mem::take(&mut a.waiting.index_runs);
            upload.patches += index_runs
                .iter()
                .map(|r| r.values.len() as u64)
                .sum::<u64>();
            // The scatter's invocations run in any order on a real GPU (lavapipe runs them in
            // order, NVIDIA does not), so a word may get only one value a frame. Index patches
            // name each word once by construction (`SlotLayout::upload`; merged above where an
            // instance was patched by two `set`s); a slot's record can
            // change several times between two prepares (removed, then added again), so its
            // words keep their last value. Both checked in debug builds, which the tests run
            // on lavapipe.
            a.cull(frustum.as_ref());
            keep_last_per_word(&mut a.waiting.records);
            let mut record_runs = std::mem::take(&mut a.record_runs);
            record_runs.refill(&a.waiting.records);
            a.waiting.records.clear();
            for (what, runs) in [
                (Patched::Indices, &index_runs[..]),
                (Patched::Records, std::slice::from_ref(&record_runs)),
            ] {
                debug_assert!(
                    each_word_once(
                        runs.iter()
                            .flat_map(|r| r.iter())
                            .flat_map(|(first, values)| first..first + values.len() as u32)
                    ),
                    "{what:?}: a word patched twice"
                );
                a.scatter(
                    device,
                    queue,
                    &self.pipeline,
                    what,
                    runs,
                    dispatches,
                    &mut upload,
                );
            }
            a.record_runs = record_runs;
            // After the index scatter, which may have patched a slot range before its
            // instance moved into a tail list.
            a.expand_tails(device, queue, &self.pipeline, dispatches, &mut upload);
            if let Some(range) = a.dirty_blocks.take() {
                let blocks = &a.blocks[range.start as usize..range.end as usize];
                let offset = u64::from(range.start) * size_of::<InstanceBlock>() as u64;
                upload.write(
                    queue,
                    &a.instance_buffer,
                    offset,
                    bytemuck::cast_slice(blocks),
                );
            }
        }
        upload
    }

    /// Draws every asset's instances: per asset one bind group, on the first-instance path its
    /// vertex buffers (poses, surface), its index buffer and exactly one
    /// `multi_draw_indexed_indirect` over its records (one per slot up to the highest in use;
    /// free slots draw nothing). Sets its own pipelines (one per vertex entry point in use).
    pub fn render(&self, pass: &mut (impl RenderCommands + ?Sized)) {
        let mut bound = None;
        for a in self.assets.iter().filter(|a| a.drawn > 0) {
            if bound != Some(a.render) {
                pass.set_pipeline(self.pipeline.render(a.render));
                bound = Some(a.render);
            }
            pass.set_bind_group(0, &a.bind_group);
            if self.path == CrowdPath::FirstInstance {
                pass.set_vertex_buffer(0, a.gpu.v0());
                pass.set_vertex_buffer(1, a.gpu.v1());
                if let Some(surface) = a.gpu.surface() {
                    pass.set_vertex_buffer(2, &surface.buffer);
                }
            }
            pass.set_index_buffer(&a.index_buffer, wgpu::IndexFormat::Uint32);
            pass.multi_draw_indexed_indirect(&a.indirect_buffer, 0, a.drawn);
        }
    }

    /// The index buffer of `asset` (`COPY_SRC`): instance slot `s` owns indices
    /// `s × slots_per_instance ..`.
    pub fn index_buffer(&self, asset: AssetId) -> Option<&wgpu::Buffer> {
        self.assets.get(asset.0 as usize).map(|a| &a.index_buffer)
    }

    /// The indirect buffer of `asset` (`COPY_SRC`): record `s` draws slot `s`.
    pub fn indirect_buffer(&self, asset: AssetId) -> Option<&wgpu::Buffer> {
        self.assets
            .get(asset.0 as usize)
            .map(|a| &a.indirect_buffer)
    }

    /// Records `render` draws for `asset` (one past its highest slot in use).
    pub fn drawn_records(&self, asset: AssetId) -> u32 {
        self.assets.get(asset.0 as usize).map_or(0, |a| a.drawn)
    }

    /// Index slots of the compact area of each instance of `asset` (the last ones of its
    /// slot range, [`CrowdRecords`]).
    pub fn compact_slots(&self, asset: AssetId) -> u32 {
        self.assets
            .get(asset.0 as usize)
            .map_or(0, |a| a.layout.compact_slots())
    }

    /// The path this crowd draws on.
    pub fn path(&self) -> CrowdPath {
        self.path
    }

    /// The vertex entry point of `shaders/crowd.wgsl` that draws `asset`: by path, surface
    /// (first-instance path) and whether it has morph targets.
    pub fn vertex_entry_point(&self, asset: AssetId) -> Option<&'static str> {
        self.assets
            .get(asset.0 as usize)
            .map(|a| a.variant.entry_point())
    }

    /// Index slots per instance of `asset`.
    pub fn slots_per_instance(&self, asset: AssetId) -> u32 {
        self.assets
            .get(asset.0 as usize)
            .map_or(0, |a| a.layout.per_instance())
    }

    /// Live instances, triangles drawn and bytes, over all assets.
    pub fn stats(&self) -> CrowdStats {
        let mut stats = CrowdStats::default();
        for a in &self.assets {
            let live = a.members.iter().flatten();
            let count = live.clone().count();
            stats.instances += count;
            stats.culled += live.clone().filter(|m| m.hidden).count();
            let shown = live.filter(|m| !m.hidden);
            stats.triangles += shown.map(|m| a.at(m).triangles).sum::<usize>();
            stats.indices += (a.records.iter().zip(&a.members))
                .filter(|(_, m)| m.as_ref().is_some_and(|m| !m.hidden))
                .map(|(r, _)| u64::from(r.index_count))
                .sum::<u64>();
            let per_slot = u64::from(a.layout.per_instance()) * 4
                + ARGS_BYTES
                + size_of::<InstanceBlock>() as u64;
            stats.instance_gpu_bytes += per_slot * count as u64;
            let mirrors = (ARGS_BYTES as usize + size_of::<InstanceBlock>()) * count;
            let members: usize = a.members.iter().flatten().map(Member::heap_bytes).sum();
            stats.instance_host_bytes += (members + mirrors) as u64;
            stats.shared_gpu_bytes +=
                a.gpu.gpu_bytes() + a.tail_words.as_ref().map_or(0, |b| b.size());
        }
        stats
    }

    /// The positions the vertex stage blends for an instance (object space, before its
    /// transform), computed on the GPU by the same WGSL function (`local_position`) and read
    /// back: how a test checks the GPU weight sum against the CPU. Uses the blocks as of the
    /// last [`prepare`](Self::prepare).
    pub fn blended_positions(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        id: InstanceId,
    ) -> Result<Vec<[f32; 3]>, CrowdError> {
        self.state(id)?;
        let a = &self.assets[id.asset as usize];
        let n = a.gpu.vertex_count();
        let bytes = u64::from(n) * 12;
        let probed = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crowd probe"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let probe = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("crowd probe slot"),
            contents: bytemuck::bytes_of(&[id.slot, 0, 0, 0]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("crowd probe"),
            layout: &self.pipeline.probe_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: probe.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: probed.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline.probe);
            pass.set_bind_group(0, &a.bind_group, &[]);
            pass.set_bind_group(1, &group, &[]);
            pass.dispatch_workgroups(n.div_ceil(64), 1, 1);
        }
        let floats = super::readback::read_back(device, queue, encoder, &probed)?;
        Ok(bytemuck::cast_slice::<u8, [f32; 3]>(&floats).to_vec())
    }
}

impl CrowdAsset {
    /// Where `member` (one of this asset's) is: from its runtime, its frame's tail list, or
    /// `S0` before its first move.
    fn at(&self, member: &Member) -> InstanceAt {
        match (&member.state, member.tail) {
            (Some(state), _) => InstanceAt {
                frame: state.frame(),
                lod: state.lod(),
                triangles: state.triangle_count(),
                from_tail: false,
            },
            (None, None) => InstanceAt {
                frame: 0,
                lod: 0,
                triangles: self.model.layout().triangle_count(),
                from_tail: false,
            },
            (None, Some((k, l))) => {
                let triangles = self.tails.triangles(k as usize, l as usize);
                InstanceAt {
                    frame: k as usize,
                    lod: l as usize,
                    triangles: triangles.expect("a tail member's LOD is in its frame's tail")
                        as usize,
                    from_tail: true,
                }
            }
        }
    }

    /// Writes the tail lists of the instances that moved in them since the last prepare and
    /// are still there (once each), into their compact areas: the jobs in one write, one
    /// dispatch of a workgroup per job recorded in `dispatches`.
    fn expand_tails(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &CrowdPipeline,
        dispatches: &mut Dispatches,
        upload: &mut CrowdUpload,
    ) {
        let mut slots = std::mem::take(&mut self.waiting.tails);
        slots.sort_unstable();
        slots.dedup();
        self.jobs.clear();
        let per = self.layout.per_instance();
        let compact = self.layout.tail_record(0).first;
        for &slot in &slots {
            let Some(member) = &mut self.members[slot as usize] else {
                continue;
            };
            if let (Some((k, l)), false) = (member.tail, member.expanded) {
                member.expanded = true;
                let dst = slot * per + compact;
                let job = self.tails.job(k as usize, l as usize, dst);
                self.jobs
                    .push(job.expect("a tail member's LOD is in its frame's tail"));
            }
        }
        slots.clear();
        self.waiting.tails = slots;
        let (Some(last), Some(words)) = (self.jobs.last().copied(), &self.tail_words) else {
            return;
        };
        upload.tail_jobs += self.jobs.len();
        // Workgroups in a rectangle of at most the device's per-dimension limit, the jobs
        // padded to fill it with the last one (the same writes again).
        let wide = device.limits().max_compute_workgroups_per_dimension as usize;
        let x = self.jobs.len().min(wide);
        let y = self.jobs.len().div_ceil(x);
        self.jobs.resize(x * y, last);
        let bytes = (self.jobs.len() * size_of::<TailJob>()) as u64;
        if self
            .tail_jobs
            .as_ref()
            .is_none_or(|(b, _)| b.size() < bytes)
        {
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("crowd tail jobs"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("crowd tails"),
                layout: &pipeline.tail_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: buffer.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: words.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: self.index_buffer.as_entire_binding(),
                    },
                ],
            });
            self.tail_jobs = Some((buffer, group));
        }
        let (buffer, group) = self.tail_jobs.as_ref().expect("made above");
        upload.write(queue, buffer, 0, bytemuck::cast_slice(&self.jobs));
        let mut pass =
            dispatches
                .encoder(device)
                .begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("crowd tails"),
                    timestamp_writes: None,
                });
        pass.set_pipeline(&pipeline.tail);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(x as u32, y as u32, 1);
        upload.dispatches += 1;
    }

    /// Applies this frame's patches of `what` (the runs of each piece in turn): written to its
    /// patch buffer and scattered by one dispatch, recorded in `dispatches` (one submission
    /// for every asset and both kinds of patches: each kind has its own patch buffer).
    #[allow(clippy::too_many_arguments)]
    fn scatter(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &CrowdPipeline,
        what: Patched,
        pieces: &[PatchRuns],
        dispatches: &mut Dispatches,
        upload: &mut CrowdUpload,
    ) {
        let runs = pieces.iter().flat_map(PatchRuns::iter);
        // A frame that moves many instances far (the first LOD frame of a crowd) can pass one
        // binding's or one dispatch's limit: then it goes in lists of at most `chunk` words
        // (runs cut where a list fills), each full one written and submitted in a command
        // buffer of its own before the next reuses the buffer; the last goes with the frame's
        // other dispatches. A word takes at most 8 bytes of a run list, plus the headers'
        // padding.
        let chunk = ((Scatter::max_run_list_bytes(device) / 8) as usize)
            .saturating_sub(RUN_GROUP as usize)
            .max(1);
        let words: usize = pieces.iter().map(|p| p.values.len()).sum();
        if words <= chunk {
            self.dispatch_runs(device, queue, pipeline, what, runs, dispatches, upload);
            return;
        }
        let mut list: Vec<(u32, &[u32])> = Vec::new();
        let mut listed = 0;
        for (first, values) in runs {
            let mut at = 0;
            while at < values.len() {
                let take = (chunk - listed).min(values.len() - at);
                list.push((first + at as u32, &values[at..at + take]));
                (at, listed) = (at + take, listed + take);
                if listed == chunk {
                    let full = list.iter().copied();
                    let mut own = Dispatches::Own(None);
                    self.dispatch_runs(device, queue, pipeline, what, full, &mut own, upload);
                    own.submit_own(queue);
                    list.clear();
                    listed = 0;
                }
            }
        }
        if !list.is_empty() {
            let rest = list.iter().copied();
            self.dispatch_runs(device, queue, pipeline, what, rest, dispatches, upload);
        }
    }

    /// Encodes `runs` as one run list, writes it to the patch buffer of `what` and records its
    /// dispatch in `dispatches`.
    #[allow(clippy::too_many_arguments)]
    fn dispatch_runs<'a>(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &CrowdPipeline,
        what: Patched,
        runs: impl Iterator<Item = (u32, &'a [u32])> + Clone,
        dispatches: &mut Dispatches,
        upload: &mut CrowdUpload,
    ) {
        let headers = encode_runs(runs, &mut self.run_list);
        if headers == 0 {
            return;
        }
        let bytes = 4 * self.run_list.len() as u64;
        let (slot, target) = match what {
            Patched::Indices => (0, &self.index_buffer),
            Patched::Records => (1, &self.indirect_buffer),
        };
        let patches = (pipeline.scatter).patch_buffer(
            device,
            &mut self.patch_buffers[slot],
            "crowd patches",
            target,
            bytes,
        );
        upload.write(
            queue,
            &patches.buffer,
            0,
            bytemuck::cast_slice(&self.run_list),
        );
        pipeline
            .scatter
            .record(device, dispatches, patches, headers);
        upload.dispatches += 1;
    }
}

/// The asset's block (`Mesh` in `crowd.wgsl`): base colour, vertex count, shade mode.
fn mesh_buffer(device: &wgpu::Device, gpu: &GpuAsset) -> wgpu::Buffer {
    let mesh = MeshBlock {
        base_color: gpu.surface().map_or([1.0; 4], |s| s.base_color),
        vertex_count: gpu.vertex_count(),
        mode: default_mode(gpu.surface()).shader_value(),
        _pad: [0; 2],
    };
    device.create_buffer_init(&BufferInitDescriptor {
        label: Some("crowd mesh"),
        contents: bytemuck::bytes_of(&mesh),
        usage: wgpu::BufferUsages::UNIFORM,
    })
}

/// A grid morph of `n × n` vertices (a bump rising on one side) built with four frames, for
/// the tests of the slots and the tail lists: small, and its frames switch.
#[cfg(test)]
fn grid_model(n: u32) -> (crate::Asset, DeformingModel) {
    let (flat, triangles) = crate::simplify::tests::grid(n - 1, 0.0);
    let z = |x: f32, y: f32| 0.05 * (7.0 * x + 3.0 * y).sin();
    let v0: Vec<[f32; 3]> = flat.iter().map(|&[x, y, _]| [x, y, z(x, y)]).collect();
    let v1: Vec<[f32; 3]> = (flat.iter())
        .map(|&[x, y, _]| [x, y, z(x, y) + 0.3 * (3.0 * x).sin() * y])
        .collect();
    let morph = crate::Morph::from_poses(triangles, v0, v1).expect("grid morph");
    let asset = crate::Builder::new(&morph)
        .frames(4)
        .build()
        .expect("builds")
        .0;
    let model = DeformingModel::new(&asset).expect("model");
    (asset, model)
}

fn check_finite(what: &'static str, values: &[f32]) -> Result<(), CrowdError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(CrowdError::NonFinite {
            what,
            value: format!("{values:?}"),
        })
    }
}
