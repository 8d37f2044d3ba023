//! One deforming mesh on the GPU, laid out as `docs/DESIGN.md` ("GPU layout") says, its strips
//! drawn in groups behind primitive restart.
//!
//! * `V(0)` and `V(1)` live in two vertex buffers, uploaded once; the shader blends them with `t`.
//!   An object may also carry morph targets ([`Object::set_targets`]) in a storage buffer,
//!   added with per-frame weights: how a weight animation moves on the GPU.
//! * An object made with a [`Surface`] ([`Object::with_surface`], [`Object::from_asset`]) has
//!   a third vertex buffer (normals at `t = 0` and `t = 1`, UV, colour per vertex, uploaded
//!   once), the material's texture, and normal offsets beside the position offsets; it draws
//!   with the surface pipelines and any [`ShadeMode`].
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
//! The object composes four parts, one file each: the draw records (`records.rs`), the
//! index mirror and its upload diff (`upload.rs`), the uniforms and morph targets
//! (`pose.rs`) and the surface (`surface.rs`); this file owns the buffers, the region layout
//! and the edits.
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

use std::ops::Range;
use std::sync::Arc;

use wgpu::util::{BufferInitDescriptor, DeviceExt, DrawIndexedIndirectArgs};

use super::asset::GpuAsset;
use super::checks::{check_indices, check_size};
use super::commands::RenderCommands;
use super::pipeline::{MorphPipeline, ShadeMode};
use super::pose::{default_mode, Pose};
use super::records::{DrawRecords, ARGS_BYTES};
use super::scatter::{encode_runs, Dispatches, PatchBuffer, Scatter};
use super::upload::{clip, coalesce, plan_upload, run_list_bytes, IndexMirror};
use super::{Draws, GpuError, Upload, GROUP_INDICES, RESTART};
#[allow(unused_imports)] // named in the docs
use super::{MERGE_GAP_BYTES, WRITE_CALL_BYTES};
use crate::asset::{Asset, Surface};
use crate::lodstrips::Dirty;
use crate::morph::WeightTrack;

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
    /// Uploads the poses and the full-detail strips; region `r` gets capacity and initial live
    /// contents `regions[r]`.
    ///
    /// Every index must name a vertex (`< v0.len()`), or be [`super::RESTART`] in a
    /// [`Topology::Strip`] object. Strip objects start with [`Draws::Grouped`] at
    /// [`GROUP_INDICES`], list objects draw per region. The device's
    /// `INDIRECT_FIRST_INSTANCE` feature decides whether each record carries its number as
    /// `first_instance`.
    pub fn new(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        v0: &[[f32; 3]],
        v1: &[[f32; 3]],
        regions: &[Vec<u32>],
    ) -> Result<Object, GpuError> {
        let asset = GpuAsset::new(device, (v0, v1), None)?;
        Object::make(device, pipeline, topology, Arc::new(asset), regions)
    }

    /// As [`Object::new`], with `surface`'s normals, UVs, colours and material (one entry per
    /// vertex of `v0`, finite: [`GpuError::SurfaceLength`], [`GpuError::NonFiniteAttribute`]
    /// otherwise). The texture is decoded here ([`GpuError::TextureDecode`] when it does not
    /// decode: clear `material.texture` to draw the surface untextured) and uploaded by the
    /// first [`prepare`](Self::prepare). The object starts in [`ShadeMode::Textured`] when the
    /// material has a texture, [`ShadeMode::Smooth`] otherwise. Normal deltas of morph targets
    /// go with [`set_targets_with_normals`](Self::set_targets_with_normals).
    pub fn with_surface(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        (v0, v1): (&[[f32; 3]], &[[f32; 3]]),
        regions: &[Vec<u32>],
        surface: &Surface,
    ) -> Result<Object, GpuError> {
        let asset = GpuAsset::new(device, (v0, v1), Some(surface))?;
        Object::make(device, pipeline, topology, Arc::new(asset), regions)
    }

    /// An object drawing `asset`'s poses over `regions`, with its surface and its morph targets
    /// (position and normal deltas) when it has them: what [`super::LodObject`] and the
    /// benchmark draw an asset with. Pose it with [`set_pose`](Self::set_pose) and the
    /// asset's weight track.
    pub fn from_asset(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        asset: &Asset,
        regions: &[Vec<u32>],
    ) -> Result<Object, GpuError> {
        let shared = GpuAsset::from_asset(device, asset)?;
        Object::with_asset(device, pipeline, topology, shared, regions)
    }

    /// An object over an asset already on the GPU ([`GpuAsset::from_asset`]), sharing its
    /// poses, surface and morph-target deltas with every other object made from it: the object
    /// owns only its index and indirect buffers, its uniforms and (with targets) the offsets
    /// it sums. An asset of another device is [`GpuError::OtherDevice`].
    pub fn with_asset(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        asset: Arc<GpuAsset>,
        regions: &[Vec<u32>],
    ) -> Result<Object, GpuError> {
        if !asset.is_on(device) {
            return Err(GpuError::OtherDevice);
        }
        let mut object = Object::make(device, pipeline, topology, Arc::clone(&asset), regions)?;
        if let Some(deltas) = asset.targets() {
            object
                .pose
                .share_targets(device, pipeline, Arc::clone(deltas), asset.surface());
        }
        Ok(object)
    }

    fn make(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        asset: Arc<GpuAsset>,
        regions: &[Vec<u32>],
    ) -> Result<Object, GpuError> {
        let vertex_count = asset.vertex_count();
        let separator = separator_slots(topology);
        let total: usize = regions.iter().map(|r| r.len() + separator as usize).sum();
        let max_buffer = device.limits().max_buffer_size;
        check_size("index", total as u64 * 4, max_buffer)?;
        check_size("indirect", regions.len() as u64 * ARGS_BYTES, max_buffer)?;
        // first_index is a u32, so every region must start below 2^32 indices.
        if total > u32::MAX as usize {
            return Err(GpuError::BufferTooLarge {
                what: "index",
                bytes: total as u64 * 4,
                max: u64::from(u32::MAX) * 4,
            });
        }

        let mut region_starts = Vec::with_capacity(regions.len() + 1);
        let mut lengths = Vec::with_capacity(regions.len());
        let mut indices = Vec::with_capacity(total);
        region_starts.push(0);
        for (region, strip) in regions.iter().enumerate() {
            check_indices(region, strip, vertex_count, topology == Topology::Strip)?;
            indices.extend_from_slice(strip);
            if topology == Topology::Strip {
                indices.push(RESTART);
            }
            lengths.push(strip.len() as u32);
            region_starts.push(indices.len() as u32);
        }

        let draws = match topology {
            Topology::Strip => Draws::Grouped {
                max_indices: GROUP_INDICES,
            },
            Topology::List => Draws::PerRegion,
        };
        let first_instance = device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE);
        let records = DrawRecords::new(&region_starts, &lengths, draws, first_instance);

        // wgpu cannot bind an empty index buffer; an object without regions gets one unused
        // index so its (empty) multi-draw stays valid.
        let index_contents: &[u32] = if indices.is_empty() { &[0] } else { &indices };
        let index_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod indices"),
            contents: bytemuck::cast_slice(index_contents),
            // STORAGE: the scatter patches it; COPY_SRC: tests and tools can copy the buffer
            // back to check what the GPU holds.
            usage: wgpu::BufferUsages::INDEX
                | wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        });
        // Room for one record per region, the most any grouping needs (and at least one:
        // wgpu cannot bind an empty buffer); records past the ones drawn stay zero.
        let mut args_contents = records.args.clone();
        args_contents.resize(regions.len().max(1), DrawIndexedIndirectArgs::default());
        let indirect_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod indirect draws"),
            contents: bytemuck::cast_slice(&args_contents),
            usage: wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        });
        let render_pipeline = match (topology, asset.has_surface()) {
            (Topology::Strip, false) => pipeline.strip().clone(),
            (Topology::List, false) => pipeline.list().clone(),
            (Topology::Strip, true) => pipeline.surface_strip().clone(),
            (Topology::List, true) => pipeline.surface_list().clone(),
        };
        let pose = Pose::new(device, pipeline, vertex_count, asset.surface());
        let fits = index_buffer.size() <= device.limits().max_storage_buffer_binding_size;
        let scatter = ObjectScatter {
            device: device.clone(),
            scatter: pipeline.scatter().clone(),
            max_list_bytes: if fits {
                Scatter::max_run_list_bytes(device)
            } else {
                0
            },
            patch_buffer: None,
            list: Vec::new(),
        };
        Ok(Object {
            pipeline: render_pipeline,
            topology,
            vertex_count,
            shade: default_mode(asset.surface()),
            asset,
            index_buffer,
            indirect_buffer,
            region_starts,
            lengths,
            draws,
            mirror: IndexMirror::new(indices),
            records,
            pose,
            scatter,
        })
    }

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

    /// Chooses how regions are cut into draw records. A change of the records drawn rewrites
    /// the indirect mirror, uploaded once by the next prepare; the index buffer is untouched.
    /// List objects can only draw per region (nothing separates their regions):
    /// [`GpuError::GroupedList`] otherwise, and nothing changes.
    pub fn set_draws(&mut self, draws: Draws) -> Result<(), GpuError> {
        if self.topology == Topology::List && draws != Draws::PerRegion {
            return Err(GpuError::GroupedList);
        }
        self.draws = draws;
        self.relayout_records();
        Ok(())
    }

    /// What is drawn: per region while strips are coloured (the shader reads the record
    /// number), the asked-for grouping otherwise.
    fn drawn_as(&self) -> Draws {
        match self.shade {
            ShadeMode::StripColours => Draws::PerRegion,
            ShadeMode::Faceted | ShadeMode::Smooth | ShadeMode::Textured => self.draws,
        }
    }

    /// Re-cuts the records when what is drawn changed.
    fn relayout_records(&mut self) {
        let drawn = self.drawn_as();
        self.records
            .relayout(&self.region_starts, &self.lengths, drawn);
    }

    /// Sets the live length of `region` to `len` (at most its capacity): positions that join
    /// the live part take `live[position]`, positions that leave it take [`RESTART`] in a
    /// strip object (list objects never read their tails and leave them stale). `live` holds
    /// the region's new contents from its start, at least `len` long.
    fn resize(&mut self, region: usize, live: &[u32], len: u32) {
        let old = self.lengths[region];
        if old == len {
            return;
        }
        let start = self.region_starts[region];
        if len > old {
            let source = &live[old as usize..len as usize];
            self.mirror.write(start + old, len - old, |i| source[i]);
        } else if self.topology == Topology::Strip {
            self.mirror.write(start + len, old - len, |_| RESTART);
        }
        self.lengths[region] = len;
        self.records.touch_region(region);
    }

    /// Replaces the live indices of `region` (length 0 hides the strip).
    ///
    /// Only the positions whose value changed are marked for upload (see
    /// [`Object::set_merge_gap`] for how they are grouped into writes), so a caller may pass
    /// the whole live strip after a local edit and still upload only the changed words.
    /// Shrinking writes [`RESTART`] over the positions that leave the strip (strip objects)
    /// and may change the region's draw record. Nothing changes when an error is returned.
    pub fn write_region(&mut self, region: usize, live: &[u32]) -> Result<(), GpuError> {
        let range = self.region_range(region).ok_or(GpuError::NoSuchRegion {
            region,
            regions: self.region_count(),
        })?;
        let capacity = (range.end - range.start) as usize;
        if live.len() > capacity {
            return Err(GpuError::RegionOverflow {
                region,
                len: live.len(),
                capacity,
            });
        }
        check_indices(region, live, self.vertex_count, self.strips())?;

        let kept = live.len().min(self.lengths[region] as usize);
        self.mirror.write(range.start, kept as u32, |i| live[i]);
        self.resize(region, live, live.len() as u32);
        self.records
            .update_touched(&self.region_starts, &self.lengths);
        Ok(())
    }

    /// Applies what a LOD runtime changed since its last `take_dirty` (a [`Dirty`] from
    /// [`crate::lodstrips::StripsState::take_dirty`], or from any runtime with the same contract):
    /// `indices` is the runtime's whole index buffer and `lengths` the live length of every
    /// strip, with strip `r` owning this object's region `r` and the regions packed back to
    /// back in order, as [`crate::lodstrips::StripsState::indices`] / `lengths` are (no
    /// separators: region `r` of the runtime starts `r` slots before this object's in a strip
    /// object).
    ///
    /// The contract: every position of a live strip whose value changed lies in one of
    /// `dirty.ranges`, and every strip whose live length changed is in `dirty.lengths`.
    /// Only those ranges are read (plus the positions a strip grew by), not whole regions;
    /// each is clipped to the strip's live length and diffed against the mirror, and only the
    /// changed words are marked for upload (runs of unchanged words longer than the merge gap
    /// split a write): a step undone before this call (coarsen then refine) uploads nothing,
    /// a frame switch uploads the words that differ. A strip that shrank gets [`RESTART`]
    /// over the positions it left. Everything is checked before anything changes; on error
    /// the object is as before.
    pub fn apply_dirty(
        &mut self,
        dirty: &Dirty,
        indices: &[u32],
        lengths: &[u32],
    ) -> Result<(), GpuError> {
        self.check_layout(indices, lengths)?;
        self.check_dirty(dirty, indices, lengths)?;
        self.apply_checked(dirty, indices, lengths);
        Ok(())
    }

    /// [`apply_dirty`](Self::apply_dirty) for a runtime whose every index is known to be in
    /// range and every live length within its region: the state of the model this object was
    /// made from (its indices are `S0`'s, checked when the object was made, or their
    /// survivors; its strips never outgrow `S0`). Only the layout is checked; reading every
    /// changed index again (a quarter of `apply_dirty` at a frame switch) is left to debug
    /// builds.
    pub(crate) fn apply_own_dirty(
        &mut self,
        dirty: &Dirty,
        indices: &[u32],
        lengths: &[u32],
    ) -> Result<(), GpuError> {
        self.check_layout(indices, lengths)?;
        debug_assert!(
            self.check_dirty(dirty, indices, lengths).is_ok(),
            "a runtime of this object's model gave an index out of range"
        );
        self.apply_checked(dirty, indices, lengths);
        Ok(())
    }

    /// That a runtime's buffer and lengths have this object's layout.
    fn check_layout(&self, indices: &[u32], lengths: &[u32]) -> Result<(), GpuError> {
        let regions = self.region_count();
        let capacity =
            self.mirror.indices.len() - regions * separator_slots(self.topology) as usize;
        if indices.len() != capacity || lengths.len() != regions {
            return Err(GpuError::LayoutMismatch {
                indices: indices.len(),
                strips: lengths.len(),
                capacity,
                regions,
            });
        }
        Ok(())
    }

    /// The check pass of [`apply_dirty`](Self::apply_dirty), its layout checked: region
    /// numbers, capacities, and the indices each range will copy.
    fn check_dirty(&self, dirty: &Dirty, indices: &[u32], lengths: &[u32]) -> Result<(), GpuError> {
        for &strip in &dirty.lengths {
            let region = strip as usize;
            let (span, live) = self.check_live_length(region, lengths)?;
            let old = self.lengths[region];
            if live > old {
                let source = runtime_span(self.topology, region, span.start, old..live);
                check_indices(region, &indices[source], self.vertex_count, self.strips())?;
            }
        }
        for range in &dirty.ranges {
            let region = range.strip as usize;
            let (span, live) = self.check_live_length(region, lengths)?;
            if range.start > range.end || range.end > span.end - span.start {
                return Err(GpuError::DirtyRange {
                    region,
                    start: range.start,
                    end: range.end,
                    capacity: span.end - span.start,
                });
            }
            let copied = clip(range.start..range.end, live);
            let source = runtime_span(self.topology, region, span.start, copied);
            check_indices(region, &indices[source], self.vertex_count, self.strips())?;
        }
        Ok(())
    }

    /// The apply pass of [`apply_dirty`](Self::apply_dirty), on a checked `dirty`: nothing
    /// here can fail. The ranges' diffs go to the mirror together, on the thread pool at a
    /// large frame switch ([`IndexMirror::write_all`]).
    fn apply_checked(&mut self, dirty: &Dirty, indices: &[u32], lengths: &[u32]) {
        let regions = &self.region_starts;
        let topology = self.topology;
        let writes = dirty.ranges.iter().map(|range| {
            let region = range.strip as usize;
            let start = regions[region];
            let copied = clip(range.start..range.end, lengths[region]);
            (
                start + copied.start,
                &indices[runtime_span(topology, region, start, copied)],
            )
        });
        self.mirror.write_all(writes);
        for &strip in &dirty.lengths {
            let region = strip as usize;
            let start = self.region_starts[region];
            let capacity = self.region_starts[region + 1] - start - separator_slots(self.topology);
            let live = &indices[runtime_span(self.topology, region, start, 0..capacity)];
            self.resize(region, live, lengths[region]);
        }
        self.records
            .update_touched(&self.region_starts, &self.lengths);
    }

    /// The span of `region` and its new live length from `lengths`, checked against capacity.
    fn check_live_length(
        &self,
        region: usize,
        lengths: &[u32],
    ) -> Result<(Range<u32>, u32), GpuError> {
        let span = self.region_range(region).ok_or(GpuError::NoSuchRegion {
            region,
            regions: self.region_count(),
        })?;
        // `lengths` has one entry per region (checked by the caller), so this index exists.
        let live = lengths[region];
        let capacity = span.end - span.start;
        if live > capacity {
            return Err(GpuError::RegionOverflow {
                region,
                len: live as usize,
                capacity: capacity as usize,
            });
        }
        Ok((span, live))
    }

    /// Sets the blend parameter between `V(0)` (`t = 0`) and `V(1)` (`t = 1`), clamped to
    /// `[0, 1]` as the CPU runtime clamps it. NaN is [`GpuError::TimeNaN`] and changes nothing.
    pub fn set_t(&mut self, t: f32) -> Result<(), GpuError> {
        self.pose.set_t(t)
    }

    /// Sets projection * view (world to clip space; wgpu clip space: z in [0, 1], y up).
    pub fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.pose.set_view_proj(view_proj);
    }

    /// Sets morph targets (one delta per vertex each) added to the blended pose with the
    /// weights of [`set_target_weights`](Self::set_target_weights), all 0 until then; an empty
    /// slice removes them. The object keeps the deltas on the CPU and the GPU holds one offset
    /// per vertex (12 bytes), re-summed and uploaded by `prepare` when the weights change.
    /// `pipeline` must be the one the object was made with. Nothing changes when an error is
    /// returned.
    pub fn set_targets(
        &mut self,
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        targets: &[Vec<[f32; 3]>],
    ) -> Result<(), GpuError> {
        self.pose
            .set_targets(device, pipeline, targets, &[], self.asset.surface())
    }

    /// As [`set_targets`](Self::set_targets), with each target's normal deltas (`normals`
    /// empty, or one array per target of one delta per vertex, on an object with a surface):
    /// the smooth modes draw `normalize(n0 + Σ_k w_k dN_k)`, the offsets summed on the CPU
    /// like the positions' (12 more bytes per vertex uploaded when the weights change).
    pub fn set_targets_with_normals(
        &mut self,
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        targets: &[Vec<[f32; 3]>],
        normals: &[Vec<[f32; 3]>],
    ) -> Result<(), GpuError> {
        self.pose
            .set_targets(device, pipeline, targets, normals, self.asset.surface())
    }

    /// Sets the pose at animation time `t` (clamped to `[0, 1]`; NaN is
    /// [`GpuError::TimeNaN`]): `mix(V(0), V(1), t)` for a two-pose object (`track` `None`),
    /// or `V(0)` plus the targets weighted by `track`'s offsets at `t`
    /// ([`WeightTrack::offsets_at`]) for an object whose targets came from that weight
    /// animation (see [`crate::morph::TargetBlend`]).
    pub fn set_pose(&mut self, t: f32, track: Option<&WeightTrack>) -> Result<(), GpuError> {
        self.pose.set_pose(t, track)
    }

    /// Sets the weight of every morph target (one per target of
    /// [`set_targets`](Self::set_targets), finite).
    pub fn set_target_weights(&mut self, weights: &[f32]) -> Result<(), GpuError> {
        self.pose.set_target_weights(weights)
    }

    /// Sets the object-to-world transform.
    pub fn set_model(&mut self, model: glam::Mat4) {
        self.pose.set_model(model);
    }

    /// Sets the object's colour (rgb stored in the target as is, alpha written as is), used by
    /// the faceted and smooth modes; the textured mode uses the material's base colour.
    pub fn set_color(&mut self, color: [f32; 4]) {
        self.pose.set_color(color);
    }

    /// Sets the world-space direction towards the light (finite, nonzero) and the ambient term
    /// (in `[0, 1]`).
    pub fn set_light(&mut self, towards_light: glam::Vec3, ambient: f32) -> Result<(), GpuError> {
        self.pose.set_light(towards_light, ambient)
    }

    /// Chooses how the object is shaded. An object without a surface draws
    /// [`ShadeMode::Smooth`] and [`ShadeMode::Textured`] as [`ShadeMode::Faceted`] (see
    /// [`shade_mode`](Self::shade_mode)). Strip colours read the record number, so while they
    /// are on the object draws one record per region (the indirect records are rewritten and
    /// uploaded once on each switch).
    pub fn set_shade_mode(&mut self, mode: ShadeMode) {
        let mode = mode.for_surface(self.has_surface());
        self.pose.set_mode(mode);
        self.shade = mode;
        self.relayout_records();
    }

    /// The mode the object draws in.
    pub fn shade_mode(&self) -> ShadeMode {
        self.shade
    }

    /// Whether the object was made with a surface (normals, UVs, material).
    pub fn has_surface(&self) -> bool {
        self.asset.has_surface()
    }

    /// Sets how far apart (in bytes of one buffer) two changed spans may lie and still be
    /// sent as one write when [`prepare`](Self::prepare) sends a frame by writes only (a frame
    /// of few spans, or an index buffer larger than one storage binding), and two changed
    /// indirect records ([`MERGE_GAP_BYTES`] by default). 0 sends exactly the changed bytes in
    /// more calls; larger values send fewer, bigger writes.
    pub fn set_merge_gap(&mut self, bytes: u64) {
        self.mirror.set_merge_gap(bytes);
    }

    /// Uploads everything changed since the last call: the changed index words, the changed
    /// indirect records (coalesced by the merge gap, one `queue.write_buffer` each) and the
    /// uniforms. Call before the render pass that draws this object is submitted.
    ///
    /// The index words go by the cheaper of two plans under the cost model of
    /// [`WRITE_CALL_BYTES`]: a frame of few changed spans as writes (spans closer than the
    /// merge gap joined); a frame of many through the index scatter (`shaders/scatter.wgsl`,
    /// `scatter_runs`): runs of consecutive changed words (neighbouring spans joined where the
    /// words between them cost less than a run's header) listed as one header per run of up to
    /// 16 words and their values, uploaded with one write and applied by one compute dispatch,
    /// with only runs of more than ~16 k words still written directly. That dispatch is
    /// recorded here and **submitted on `queue`** in a small command buffer of its own, so
    /// queue order keeps every frame's edits in order whatever the caller submits next. Such a
    /// frame costs a few calls and O(changed words) of CPU whatever the number of spans, and
    /// sends at most about twice the changed words' bytes (a single word: 8 bytes). The
    /// [`Upload`] lists what was actually sent: the ranges written, the words sent through the
    /// scatter and the list's bytes.
    ///
    /// [`prepare_with`](Self::prepare_with) records the dispatch into the caller's encoder
    /// instead, saving the submission.
    pub fn prepare(&mut self, queue: &wgpu::Queue) -> Upload {
        let mut dispatches = Dispatches::Own(None);
        let upload = self.upload(queue, &mut dispatches);
        dispatches.submit_own(queue);
        upload
    }

    /// [`prepare`](Self::prepare), with the index scatter's dispatch (on a frame that has
    /// one) recorded into `encoder` instead of submitted on its own, so that any number of
    /// objects and the frame's passes go in one submission. Rules for the caller, as for
    /// egui-wgpu's `update_buffers`: record the render pass that draws this object into
    /// `encoder` after this call, and submit `encoder` on `queue` before this object's next
    /// `prepare` or `prepare_with` (that call rewrites the run list the recorded dispatch
    /// reads).
    pub fn prepare_with(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Upload {
        self.upload(queue, &mut Dispatches::Caller(encoder))
    }

    /// Both `prepare`s: every write, and the scatter's dispatch (on a frame that sends runs)
    /// recorded in `dispatches`.
    fn upload(&mut self, queue: &wgpu::Queue, dispatches: &mut Dispatches) -> Upload {
        let mut upload = Upload::default();
        let gap = u32::try_from(self.mirror.merge_gap_bytes() / 4).unwrap_or(u32::MAX);
        let spans = self.mirror.take_spans();
        let plan = plan_upload(&spans, gap, self.scatter.max_list_bytes);
        for span in plan.writes {
            let data = &self.mirror.indices[span.start as usize..span.end as usize];
            let bytes = u64::from(span.start) * 4..u64::from(span.end) * 4;
            queue.write_buffer(&self.index_buffer, bytes.start, bytemuck::cast_slice(data));
            upload.index_ranges.push(bytes);
        }
        if !plan.runs.is_empty() {
            self.scatter_runs(queue, &plan.runs, dispatches, &mut upload);
        }
        let args_gap =
            u32::try_from(self.mirror.merge_gap_bytes() / ARGS_BYTES).unwrap_or(u32::MAX);
        for span in coalesce(&mut self.records.dirty, args_gap) {
            let data = &self.records.args[span.start as usize..span.end as usize];
            let bytes = u64::from(span.start) * ARGS_BYTES..u64::from(span.end) * ARGS_BYTES;
            queue.write_buffer(
                &self.indirect_buffer,
                bytes.start,
                bytemuck::cast_slice(data),
            );
            upload.indirect_ranges.push(bytes);
        }
        let pose = self.pose.upload(queue);
        upload.uniform_bytes = pose.uniform_bytes;
        upload.offset_bytes = pose.offset_bytes;
        upload.offset_writes = pose.offset_writes;
        upload.texture_bytes = self.asset.upload(queue);
        upload
    }

    /// Writes the run list of `runs` (disjoint, their list within `max_list_bytes`; the list:
    /// [`encode_runs`]) for the scatter and records its dispatch in `dispatches`.
    fn scatter_runs(
        &mut self,
        queue: &wgpu::Queue,
        runs: &[Range<u32>],
        dispatches: &mut Dispatches,
        upload: &mut Upload,
    ) {
        let s = &mut self.scatter;
        let indices = &self.mirror.indices;
        let headers = encode_runs(
            runs.iter()
                .map(|r| (r.start, &indices[r.start as usize..r.end as usize])),
            &mut s.list,
        );
        // `plan_upload` priced this list with `run_list_bytes`; the encoding is its length.
        let bytes = s.list.len() as u64 * 4;
        debug_assert_eq!(bytes, run_list_bytes(runs));
        upload.scattered_words += runs.iter().map(|r| u64::from(r.end - r.start)).sum::<u64>();
        let patches = s.scatter.patch_buffer(
            &s.device,
            &mut s.patch_buffer,
            "morphlod index runs",
            &self.index_buffer,
            bytes,
        );
        queue.write_buffer(&patches.buffer, 0, bytemuck::cast_slice(&s.list));
        s.scatter.record(&s.device, dispatches, patches, headers);
        upload.scatter_bytes = bytes;
        upload.scatters = 1;
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

/// Positions `within` (relative to the region start) of `region` in a runtime's packed
/// buffer, given the region's start in an object of `topology`. A free function, so that
/// `apply_checked` can read the spans while it writes the mirror.
fn runtime_span(topology: Topology, region: usize, start: u32, within: Range<u32>) -> Range<usize> {
    let runtime_start = start - region as u32 * separator_slots(topology);
    (runtime_start + within.start) as usize..(runtime_start + within.end) as usize
}
