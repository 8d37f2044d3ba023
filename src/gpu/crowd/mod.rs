//! A crowd: any number of instances of any number of assets, each instance at its own time,
//! LOD, transform and colour, drawn with one `multi_draw_indexed_indirect` per asset (and page
//! of its index memory).
//!
//! What is shared and what is not (`docs/DESIGN.md`, "Crowds"):
//! * per asset, once: the [`GpuAsset`] (poses, surface, texture, target deltas), the
//!   [`DeformingModel`] (every frame's change lists), its index memory (pages: index buffers
//!   that grow, each with the indirect buffer of the records drawn from it), one instance
//!   buffer with one [`InstanceBlock`](pipeline) per slot, and one bind group;
//! * per instance: its [`DeformingState`](crate::deform::DeformingState) (the runtime, which
//!   holds the current strips; none while it is drawn from a tail list), one area of index
//!   memory sized to what it draws now, one record and one 192-byte block. No index mirror:
//!   the runtime's dirty log says what to upload.
//!
//! An instance's area holds what it draws (`pool.rs`, `slots.rs`): far away its frame's tail
//! list (one triangle list per frame and asset on the GPU, expanded into the area by a compute
//! pass where its frame or LOD changed, so that such an instance's move costs no rebuild and no
//! patch: `tail.rs`), 4 words a triangle; at coarse LODs a compact copy of its live strips
//! (each strip in a place it keeps while it fits), a little more than their packed count; close
//! up its regions (the strips in fixed regions, patched in place). A new instance holds none:
//! it draws the asset's one shared `S0` until its first move. Areas move to new ones when what
//! the instance draws changes enough; a growing copy is copied on the GPU, never re-uploaded.
//!
//! Per frame: [`set`](Crowd::set) moves every named instance in parallel (rayon) and, on the
//! same thread right after each move (while the instance's strips are in that core's cache),
//! makes its index patches (O(changed indices) for the regions and for the compact copy, whose
//! live indices only where it is repacked), words of its area; then it settles each moved
//! instance's area and record; [`prepare`](Crowd::prepare) grows the pages and copies the
//! areas that moved, uploads each page's patches with one write and applies them with one
//! compute dispatch, does the same with the changed words of the records, expands the tail
//! lists and writes the changed instance blocks as one contiguous range;
//! [`render`](Crowd::render) binds each asset and issues one multi-draw per page (one page
//! holds a crowd of thousands). The caller owns device, queue and pass, as with an
//! [`Object`](super::Object).
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

mod add;
mod bench;
mod cull;
mod discrete;
mod member;
mod patches;
mod pipeline;
mod pool;
mod prepare;
mod render;
mod set;
mod slots;
mod tail;
mod types;

use std::sync::Arc;

use wgpu::util::{BufferInitDescriptor, DeviceExt};

pub use self::bench::{
    run_crowd_bench, CrowdBenchOptions, CrowdBenchReport, CrowdBenchScene, CrowdScene,
    DiscreteChoice, DiscreteOptions, FrameFigures, LevelFigures, ModeFigures, Stat,
    CROWD_BENCH_WARM_FRAMES,
};
pub use self::discrete::{
    DiscreteCrowd, DiscreteLevel, DiscreteLevels, LevelsError, SharedSequence,
};
use self::member::{Member, Spares};
use self::patches::{DirtySlots, Span, Waiting};
pub use self::pipeline::{CrowdPath, CROWD_WGSL, SCATTER_WGSL, TAIL_WGSL, WEIGHT_SLOTS};
use self::pipeline::{CrowdPipeline, InstanceBlock, PoseBlock, SceneBlock, Variant};
use self::pool::{Area, Pool};
use self::slots::SlotLayout;
use self::tail::TailLists;
pub use self::types::{
    AssetId, CrowdError, CrowdRecords, CrowdStats, CrowdUpload, DrawnFrom, InstanceAt, InstanceId,
};
use super::asset::GpuAsset;
use super::scatter::PatchBuffer;
use crate::deform::DeformingModel;

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
    /// Its index memory: pages of areas, each page with the records drawn from it.
    pool: Pool,
    /// `S0` in page 0 (the regions at full detail), read by the instances not moved yet;
    /// written by the first prepare.
    s0: Area,
    s0_written: bool,
    /// Restarts over the regions' words: what new regions are copied from.
    restarts: wgpu::Buffer,
    /// Per page, the scatter's and the tail expansion's buffers and bind groups over it.
    binds: Vec<PageBinds>,
    /// The asset's block (base colour, vertex count, shade mode), the instances' placements
    /// and poses on the GPU (grown by prepare) and the bind group over them (none before the
    /// first prepare).
    mesh: wgpu::Buffer,
    instance_buffers: Option<(wgpu::Buffer, wgpu::Buffer)>,
    bind_group: Option<wgpu::BindGroup>,
    /// Its render pipeline (number in the crowd's [`CrowdPipeline`]) and vertex entry point.
    render: usize,
    variant: Variant,
    /// Instance of each slot (`None`: free).
    members: Vec<Option<Member>>,
    /// Generation of each slot, bumped when its instance is removed.
    generations: Vec<u32>,
    /// Free slots, reused lowest first (sorted, highest first).
    free: Vec<u32>,
    /// Each slot's placement and pose, and the slots changed since the last prepare.
    blocks: Vec<InstanceBlock>,
    poses: Vec<PoseBlock>,
    dirty_blocks: DirtySlots,
    dirty_poses: Span,
    /// The patches made since the last prepare.
    waiting: Waiting,
    /// Slots whose areas get contents on the GPU at the next prepare (moved or new regions).
    arriving: Vec<u32>,
    /// Scratch of a scatter: the encoded run list.
    run_list: Vec<u32>,
    /// Prepares so far (a [`Member`] notes the one its patches wait for).
    prepares: u64,
    /// Runtimes kept for instances that leave a tail list.
    spares: Spares,
    /// Its frames' tail lists and their words on the GPU (none where no frame has a tail).
    tails: TailLists,
    tail_words: Option<wgpu::Buffer>,
    /// The most instances the device can draw, and why (none: more than slots number).
    most: Option<(u32, &'static str)>,
}

/// What one page's scatters and tail expansion bind, made for one generation of its buffers.
#[derive(Default)]
struct PageBinds {
    generation: u64,
    /// The patch lists of its indices and of its records, with the scatter's bind groups.
    patches: [Option<PatchBuffer>; 2],
    /// The tail jobs' buffer and the expansion's bind group.
    tail_jobs: Option<(wgpu::Buffer, wgpu::BindGroup)>,
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
            clock: 0.0,
            _pad: [0; 2],
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
