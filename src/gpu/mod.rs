//! Rendering with wgpu: the GPU side of a morphlod object.
//!
//! This module owns everything that touches a `wgpu::Device`:
//!
//! * [`Context`] — a headless instance/adapter/device/queue (no window), and the policy GPU tests
//!   use when no adapter exists ([`test_context`]).
//! * [`MorphPipeline`] — the render pipelines for `shaders/morph.wgsl` (triangle strips with
//!   primitive restart, and triangle lists for reference renders). Many objects share one.
//! * [`Object`] — one deforming mesh on the GPU: poses `V(0)`, `V(1)` uploaded once, an index
//!   buffer cut into fixed regions (one per strip of `S0`) separated by restarts, and
//!   `DrawIndexedIndirectArgs` records that each draw a group of consecutive regions
//!   ([`Draws`]). The CPU edits regions; [`Object::prepare`] uploads only the changed byte
//!   ranges and [`Object::render`] draws every record with exactly one
//!   `multi_draw_indexed_indirect`.
//!   An object made from an asset with a [`crate::asset::Surface`] also carries per-vertex
//!   normals, UVs and colours and the material's base-colour texture, and shades in any
//!   [`ShadeMode`] (textured and smooth by default); one without draws faceted, as always.
//! * [`LodObject`] — an [`Object`] driven by its CPU LOD runtime: `set(t, lod)`, `prepare`,
//!   `render`; what applications use.
//! * [`RenderTarget`] — an offscreen colour + depth target and its readback into an
//!   `image::RgbaImage`, and [`save_png`].
//! * [`camera`] — a view and projection fitted to an object's bounds or to both poses of an
//!   asset.
//!
//! Only with the `gpu` feature (on by default). The tools built on this module — the
//! frame-rate benchmark, contact sheets and plots — live with the `morphlod` binary
//! (`src/bin/morphlod/`, feature `cli`).
//!
//! `t` outside `[0, 1]` is clamped, as on the CPU ([`crate::deform::DeformingModel::frame_at`]);
//! NaN is [`GpuError::TimeNaN`] and changes nothing.
//!
//! The caller owns the device, queue and render pass (the `prepare` / `render` split of
//! egui-wgpu and glyphon), so an object drops into any existing wgpu renderer.
//!
//! # Driving an object from the LOD runtime
//!
//! Make the object from the runtime's LOD-0 strips (region `r` = strip `r` of `S0`; the object
//! adds its separators itself), then per
//! frame: move the runtime (`set_lod`), hand its `take_dirty()` with its `indices()` and
//! `lengths()` to [`Object::apply_dirty`], call [`Object::prepare`] and [`Object::render`].
//! Only the dirty ranges are read and uploaded.
//!
//! # A crowd: many objects, one pipeline
//!
//! Any number of objects share one [`MorphPipeline`] (created once per colour/depth format and
//! cull mode) and, made with [`Object::with_asset`] / [`LodObject::with_asset`], one
//! [`GpuAsset`] per asset (poses, surface, texture, target deltas uploaded once). Each [`Object`]
//! owns its index and indirect buffers, uniforms and bind group: a pass draws N objects with N
//! multi-draws. For many instances, [`Crowd`] draws every instance of an asset with one
//! `multi_draw_indexed_indirect`, blends weight animations on the GPU from per-instance weights
//! and uploads a frame's index edits with one write and one scatter dispatch per asset
//! (`docs/DESIGN.md`, "Crowds").

mod asset;
pub mod camera;
mod checks;
mod commands;
mod context;
mod crowd;
mod lod_object;
mod object;
mod pipeline;
mod pose;
mod readback;
mod records;
mod render_target;
mod scatter;
mod skin;
mod skin_probe;
mod surface;
mod upload;

pub use asset::GpuAsset;
pub use commands::{DrawCounter, RenderCommands};
pub use context::{test_context, Context};
pub use crowd::{
    run_crowd_bench, AssetId, Crowd, CrowdBenchOptions, CrowdBenchReport, CrowdBenchScene,
    CrowdError, CrowdPath, CrowdRecords, CrowdScene, CrowdStats, CrowdUpload, DiscreteChoice,
    DiscreteCrowd, DiscreteLevel, DiscreteLevels, DiscreteOptions, DrawnFrom, FrameFigures,
    InstanceAt, InstanceId, LevelFigures, LevelsError, ModeFigures, SharedSequence, Stat,
    CROWD_BENCH_WARM_FRAMES, CROWD_WGSL, SCATTER_WGSL, TAIL_WGSL, WEIGHT_SLOTS,
};
pub use lod_object::{s0_regions, BuildAhead, LodObject};
pub use object::{Object, Topology};
pub use pipeline::{MorphPipeline, ShadeMode, Uniforms, MORPH_WGSL};
pub use records::{Draws, GROUP_INDICES};
pub use render_target::{save_png, RenderTarget};
pub use skin::{GPU_INFLUENCES, GPU_JOINTS};
pub use skin_probe::SkinnedPose;
pub use surface::decode_texture;
pub use upload::{Upload, MERGE_GAP_BYTES, WRITE_CALL_BYTES};

use std::path::PathBuf;
use thiserror::Error;

/// The index that restarts a triangle strip (`strip_index_format` is `Uint32`).
pub const RESTART: u32 = u32::MAX;

/// Why a GPU operation failed.
#[derive(Debug, Error)]
pub enum GpuError {
    /// No adapter (GPU or software rasterizer) is visible to wgpu.
    #[error(
        "no GPU adapter found ({source}); on Debian/Ubuntu install the lavapipe software \
         Vulkan driver with `apt-get install mesa-vulkan-drivers libvulkan1`"
    )]
    NoAdapter {
        #[source]
        source: wgpu::RequestAdapterError,
    },
    /// The adapter exists but refused to create a device.
    #[error("the adapter {adapter:?} could not create a device: {source}")]
    RequestDevice {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
    /// The two poses of an object have different vertex counts.
    #[error("pose V(0) has {v0} vertices and pose V(1) has {v1}; both poses need one vertex per mesh vertex")]
    PoseSizeMismatch { v0: usize, v1: usize },
    /// An object needs at least one vertex, and fewer than `RESTART` of them.
    #[error("an object needs between 1 and {max} vertices, got {count}")]
    VertexCount { count: usize, max: usize },
    /// A buffer would exceed the device's `max_buffer_size`.
    #[error("the {what} buffer needs {bytes} bytes but the device allows at most {max}; split the mesh into several objects")]
    BufferTooLarge {
        what: &'static str,
        bytes: u64,
        max: u64,
    },
    /// A region number past the last region.
    #[error("region {region} does not exist; the object has {regions} regions")]
    NoSuchRegion { region: usize, regions: usize },
    /// A LOD runtime's buffers do not have this object's region layout.
    #[error("the LOD runtime has {indices} indices and {strips} strips but the object was made with {capacity} indices in {regions} regions; make the object from the same S0 as the runtime")]
    LayoutMismatch {
        indices: usize,
        strips: usize,
        capacity: usize,
        regions: usize,
    },
    /// A dirty range that does not lie inside its region.
    #[error("dirty range {start}..{end} of region {region} does not fit its capacity of {capacity} indices")]
    DirtyRange {
        region: usize,
        start: u32,
        end: u32,
        capacity: u32,
    },
    /// Grouped draws asked of a triangle-list object.
    #[error("a triangle-list object draws one record per region: no restart separates its regions, so they cannot be grouped; use Draws::PerRegion or a strip object")]
    GroupedList,
    /// More live indices than the region's fixed capacity (its `S0` strip length).
    #[error("region {region} holds at most {capacity} indices, got {len}")]
    RegionOverflow {
        region: usize,
        len: usize,
        capacity: usize,
    },
    /// An index that names no vertex (or a restart in a triangle-list object).
    #[error("index {index} at position {position} of region {region} is out of range: the object has {vertices} vertices{restart}",
        restart = if *.restart_allowed { " (0xFFFFFFFF restarts a strip)" } else { " and draws triangle lists, where restart is not allowed" })]
    IndexOutOfRange {
        region: usize,
        position: usize,
        index: u32,
        vertices: u32,
        restart_allowed: bool,
    },
    /// More morph targets than the uniform block has weights for.
    #[error("{targets} morph targets given; an object blends at most {max}")]
    TargetCount { targets: usize, max: usize },
    /// An asset whose weight track and morph targets disagree in number.
    #[error("the asset's weight track drives {track} targets but it holds {targets} delta arrays; rebuild the asset")]
    TrackMismatch { track: usize, targets: usize },
    /// A morph target whose delta array does not have one entry per vertex.
    #[error("morph target {target} has {len} deltas but the object has {vertices} vertices; give one delta per vertex")]
    TargetLength {
        target: usize,
        len: usize,
        vertices: usize,
    },
    /// A morph-target delta that is NaN or infinite.
    #[error("morph target {target}, vertex {vertex}: the delta {value:?} is not finite")]
    NonFiniteDelta {
        target: usize,
        vertex: usize,
        value: [f32; 3],
    },
    /// A shading or blending parameter that would make the shader produce NaN.
    #[error("invalid {what}: {value}; {expected}")]
    InvalidParameter {
        what: &'static str,
        value: String,
        expected: &'static str,
    },
    /// An offscreen render target of zero size or larger than the device allows.
    #[error(
        "a {width}x{height} target is not possible: each side must be between 1 and {max} pixels"
    )]
    RenderTargetSize { width: u32, height: u32, max: u32 },
    /// A surface attribute that does not have one entry per vertex.
    #[error("the surface's {attribute} has {len} entries but the object has {vertices} vertices; give one per vertex (rebuild the asset)")]
    SurfaceLength {
        attribute: &'static str,
        len: usize,
        vertices: usize,
    },
    /// A surface attribute that is NaN or infinite.
    #[error("the surface's {attribute} of vertex {vertex} is not finite; fix the source mesh's attribute")]
    NonFiniteAttribute {
        attribute: &'static str,
        vertex: usize,
    },
    /// The material's base-colour texture does not decode.
    #[error("the base-colour texture ({mime_type}) does not decode: {source}; re-encode it as PNG or JPEG, or remove it from the material (`material.texture = None`) to draw untextured")]
    TextureDecode {
        mime_type: &'static str,
        #[source]
        source: image::ImageError,
    },
    /// A texture larger than the device allows.
    #[error("the base-colour texture is {width}x{height} but the device allows at most {max} pixels a side; downscale it")]
    TextureSize { width: u32, height: u32, max: u32 },
    /// A skinned asset whose skin or clip does not fit its mesh or each other.
    #[error("the asset's skin cannot be drawn: {source}; rebuild the asset from its source")]
    Skin {
        #[source]
        source: crate::skin::SkinError,
    },
    /// More influences a vertex than the GPU skins with.
    #[error("the skin has {influences} influences a vertex but the GPU skins with at most {max}; rebuild the asset with `morphlod build --max-influences {max}`")]
    SkinInfluences { influences: usize, max: usize },
    /// More joints than the GPU's 16-bit joint indices name.
    #[error("the skin has {joints} joints but the GPU names at most {max} (16-bit joint indices); split the skeleton")]
    SkinJoints { joints: usize, max: usize },
    /// A clip whose baked keys do not fit one storage buffer.
    #[error("the clip's baked keys need {bytes} bytes ({keys} keys x {joints} joints x 48 bytes) but the device allows at most {max} in one storage buffer; shorten the clip or skin fewer joints")]
    ClipTooLarge {
        keys: u64,
        joints: usize,
        bytes: u64,
        max: u64,
    },
    /// A skinned operation on an object whose asset has no skin.
    #[error("the object's asset is not skinned")]
    NotSkinned,
    /// The blend parameter `t` is NaN (values outside `[0, 1]` are clamped).
    #[error("t is NaN; pass a time in [0, 1]")]
    TimeNaN,
    /// Nothing to frame: the asset has no vertices.
    #[error("the asset has no vertices to frame")]
    NoVertices,
    /// A shared asset made on another device than the one drawing it.
    #[error("the GPU asset was uploaded to another device; make it with GpuAsset::from_asset on the device that draws it")]
    OtherDevice,
    /// Waiting for the GPU failed (device lost, timeout).
    #[error("waiting for the GPU failed: {0}")]
    Poll(#[from] wgpu::PollError),
    /// Mapping the readback buffer failed.
    #[error("mapping the readback buffer failed: {0}")]
    Map(String),
    /// Writing a PNG failed.
    #[error("cannot write PNG {path}: {source}")]
    Png {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
}
