//! One deforming mesh on the GPU, laid out as `docs/DESIGN.md` ("GPU layout") says, its strips
//! drawn in groups behind primitive restart.
//!
//! * `V(0)` and `V(1)` live in two vertex buffers, uploaded once; the shader blends them with `t`.
//!   An object may also carry morph targets ([`Object::set_targets`]) in a storage buffer,
//!   added with per-frame weights: how a weight animation moves on the GPU.
//! * An object made with a [`Surface`](crate::asset::Surface) ([`Object::with_surface`],
//!   [`Object::from_asset`]) has a third vertex buffer (normals at `t = 0` and `t = 1`, UV, colour
//!   per vertex, uploaded once), the material's texture, and normal offsets beside the position
//!   offsets; it draws with the surface pipelines and any [`ShadeMode`].
//! * The index buffer is cut into fixed regions, one per strip of `S0`, each as long as that
//!   strip at full detail (its capacity). A region's live indices are packed at its start.
//! * In a [`Topology::Strip`] object the rest of a region (its tail, live length..capacity)
//!   holds [`RESTART`], and one separator slot after every region always holds [`RESTART`].
//!   Region `r` therefore starts at `r` slots past where a LOD runtime (which packs regions
//!   without separators) starts it. Any run of consecutive regions is then a valid index
//!   sequence by itself: every region's strip begins right after a restart.
//! * The indirect buffer holds one `DrawIndexedIndirectArgs` per draw record. With
//!   [`Draws::Grouped`] a record draws a group of consecutive regions (restarts separate their
//!   strips), so the whole object is a few records instead of one per strip; with
//!   [`Draws::PerRegion`] (and always while strips are coloured, which reads the record number
//!   as `first_instance`) a record draws one region. A record ends at the last live index of
//!   its group, so coarse levels do not read the restart tails after it.
//! * The CPU keeps a mirror of both buffers. Edits go to the mirror and record the changed
//!   words; [`Object::prepare`] sends them as a few `queue.write_buffer` calls and, in a frame
//!   of many spans, one list of runs applied by a compute scatter (the cost model of
//!   [`WRITE_CALL_BYTES`]), and [`Object::render`] issues one `multi_draw_indexed_indirect`
//!   over all records.
//!
//! The object composes four parts beside it in `gpu/`: the draw records (`records.rs`), the index
//! mirror and its upload diff (`upload/`), the uniforms and morph targets (`pose.rs`) and the
//! surface (`surface.rs`); this folder owns the buffers, the region layout and the edits, a file a
//! stage: `make.rs` (the buffers and regions made), `edit.rs` (a region written, the records
//! re-cut), `dirty.rs` (a LOD runtime's changes checked and applied), `posing.rs` (pose, targets,
//! transform, colour, light, shade mode) and `prepare.rs` (the upload); `mod.rs` holds the layout,
//! what it reads back and `render`.
//!
//! Why grouping draws exactly the strips' triangles, orientation included: a restart ends the
//! strip being assembled and the next index starts a new one at even parity — the same state a
//! separate draw starts in. Each region's live strip is preceded by a restart (the previous
//! region's separator) or by the start of its record, and followed by restarts (its tail and
//! separator), so no triangle window spans two regions, every strip keeps the parity of
//! `docs/DESIGN.md` ("`0xFFFFFFFF` restarts a strip, parity starts again at even"), and restart runs
//! assemble nothing. The parity argument of the LOD runtime (each strip's triangles start at
//! even parity) is untouched.
//!
//! [`Topology::List`] objects have no restart to separate regions (a region's tail would be
//! read as triangles), so they always draw one record per region and keep stale tails, which
//! no record reads.

mod dirty;
mod edit;
mod make;
mod posing;
mod prepare;

use std::ops::Range;
use std::sync::Arc;

use wgpu::util::DrawIndexedIndirectArgs;

use super::asset::GpuAsset;
use super::commands::RenderCommands;
use super::pipeline::ShadeMode;
use super::pose::Pose;
use super::records::DrawRecords;
use super::scatter::{PatchBuffer, Scatter};
use super::upload::IndexMirror;
use super::Draws;
#[allow(unused_imports)] // named in the docs
use super::{RESTART, WRITE_CALL_BYTES};

/// How the indices of every region are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Topology {
    /// Generalized triangle strips; `0xFFFFFFFF` ([`super::RESTART`]) restarts a strip.
    Strip,
    /// Plain triangle lists (reference renders, list-vs-strip benchmarks).
    List,
}

/// A morphing mesh on the GPU: poses, region-structured index buffer, indirect draws, uniforms.
pub struct Object {
    pipeline: wgpu::RenderPipeline,
    topology: Topology,
    vertex_count: u32,
    /// Poses, surface and morph targets, shared with every other user of the asset.
    asset: Arc<GpuAsset>,
    index_buffer: wgpu::Buffer,
    indirect_buffer: wgpu::Buffer,
    /// Region r owns slots `region_starts[r]..region_starts[r + 1]`: its capacity, then (in a
    /// strip object) its separator.
    region_starts: Vec<u32>,
    /// Live length of every region.
    lengths: Vec<u32>,
    /// The grouping asked for; what is drawn also depends on the shade mode and topology.
    draws: Draws,
    shade: ShadeMode,
    /// The index buffer's CPU mirror and its changed spans.
    mirror: IndexMirror,
    /// The indirect records, their CPU mirror and changed records.
    records: DrawRecords,
    /// Uniforms, morph targets and the bind group.
    pose: Pose,
    /// The index scatter, and what it needs to run in `prepare`.
    scatter: ObjectScatter,
}

/// What [`Object::prepare`] sends index runs with: the device (to make the list's buffer and
/// record the dispatch), the scatter pipelines, the list's buffer and its bind group over the
/// index buffer (made on the first frame that scatters, grown on demand).
struct ObjectScatter {
    device: wgpu::Device,
    scatter: Scatter,
    /// The largest run list one dispatch may carry; 0 where the index buffer is larger than
    /// one storage binding (the scatter binds it whole): writes only.
    max_list_bytes: u64,
    patch_buffer: Option<PatchBuffer>,
    /// The frame's run list (scratch): headers, then values.
    list: Vec<u32>,
}

impl Object {
    /// The shared vertex data the object draws.
    pub fn asset(&self) -> &Arc<GpuAsset> {
        &self.asset
    }

    /// Number of regions (strips of `S0`).
    pub fn region_count(&self) -> usize {
        self.lengths.len()
    }

    /// The fixed span of region `region` in the index buffer, in indices (offset..offset +
    /// capacity; a strip object's separator slot follows it).
    pub fn region_range(&self, region: usize) -> Option<Range<u32>> {
        let start = *self.region_starts.get(region)?;
        let end = *self.region_starts.get(region + 1)?;
        Some(start..end - separator_slots(self.topology))
    }

    /// The live indices of region `region`.
    pub fn live_indices(&self, region: usize) -> Option<&[u32]> {
        let range = self.region_range(region)?;
        let live = *self.lengths.get(region)?;
        self.mirror
            .indices
            .get(range.start as usize..(range.start + live) as usize)
    }

    /// The live length of every region.
    pub fn lengths(&self) -> &[u32] {
        &self.lengths
    }

    /// The whole index buffer as the GPU will hold it after the next prepare: live strips,
    /// restart tails and separators (strip objects), stale tails (list objects).
    pub fn index_mirror(&self) -> &[u32] {
        &self.mirror.indices
    }

    /// The GPU index buffer (`Uint32`; created with `COPY_SRC`, so it can be copied back to
    /// check what the GPU holds after [`Object::prepare`]).
    pub fn index_buffer(&self) -> &wgpu::Buffer {
        &self.index_buffer
    }

    /// The GPU indirect buffer: room for one `DrawIndexedIndirectArgs` per region, of which
    /// the first [`Object::indirect_args`]`.len()` are drawn (created with `COPY_SRC`).
    pub fn indirect_buffer(&self) -> &wgpu::Buffer {
        &self.indirect_buffer
    }

    /// The indirect draw records as the GPU will see them after the next prepare, one per
    /// record drawn (see [`Object::record_regions`]).
    pub fn indirect_args(&self) -> &[DrawIndexedIndirectArgs] {
        &self.records.args
    }

    /// Record `g` draws regions `record_regions()[g]..record_regions()[g + 1]`.
    pub fn record_regions(&self) -> &[u32] {
        self.records.starts()
    }

    /// The grouping asked for with [`Object::set_draws`]. While strips are coloured
    /// ([`ShadeMode::StripColours`]) the object draws per region whatever this says.
    pub fn draws(&self) -> Draws {
        self.draws
    }

    /// The mode the object draws in.
    pub fn shade_mode(&self) -> ShadeMode {
        self.shade
    }

    /// Whether the object was made with a surface (normals, UVs, material).
    pub fn has_surface(&self) -> bool {
        self.asset.has_surface()
    }

    /// Draws every record with exactly one `multi_draw_indexed_indirect` (the indirect buffer
    /// from offset 0, one record per entry of [`indirect_args`](Self::indirect_args)). Sets
    /// its own pipeline, bind group, vertex and index buffers, so objects can be drawn in any
    /// order in one pass. `pass` is a `wgpu::RenderPass` or anything else implementing
    /// [`RenderCommands`] (wrap it in a [`DrawCounter`](super::DrawCounter) to count draws).
    pub fn render(&self, pass: &mut (impl RenderCommands + ?Sized)) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, self.pose.bind_group());
        pass.set_vertex_buffer(0, self.asset.v0());
        pass.set_vertex_buffer(1, self.asset.v1());
        if let Some(surface) = self.asset.surface() {
            pass.set_vertex_buffer(2, &surface.buffer);
        }
        pass.set_index_buffer(&self.index_buffer, wgpu::IndexFormat::Uint32);
        pass.multi_draw_indexed_indirect(&self.indirect_buffer, 0, self.records.args.len() as u32);
    }
}

impl Object {
    /// Whether the object draws strips (where [`RESTART`] is a valid index).
    fn strips(&self) -> bool {
        self.topology == Topology::Strip
    }
}

/// Slots after each region that always hold [`RESTART`]: one in strip objects, none in lists.
fn separator_slots(topology: Topology) -> u32 {
    match topology {
        Topology::Strip => 1,
        Topology::List => 0,
    }
}
