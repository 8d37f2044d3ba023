//! One deforming mesh on the GPU, laid out as DESIGN.md "GPU layout" says, its strips drawn in
//! groups behind primitive restart.
//!
//! * `V(0)` and `V(1)` live in two vertex buffers, uploaded once; the shader blends them with `t`.
//!   An object may also carry morph targets ([`Object::set_targets`]) in a storage buffer,
//!   added with per-frame weights: how a weight animation moves on the GPU.
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
//!   spans; [`Object::prepare`] coalesces them into few `queue.write_buffer` calls, and
//!   [`Object::render`] issues one `multi_draw_indexed_indirect` over all records.
//!
//! Why grouping draws exactly the strips' triangles, orientation included: a restart ends the
//! strip being assembled and the next index starts a new one at even parity — the same state a
//! separate draw starts in. Each region's live strip is preceded by a restart (the previous
//! region's separator) or by the start of its record, and followed by restarts (its tail and
//! separator), so no triangle window spans two regions, every strip keeps the parity of
//! DESIGN.md ("`0xFFFFFFFF` restarts a strip, parity starts again at even"), and restart runs
//! assemble nothing. The parity argument of the LOD runtime (each strip's triangles start at
//! even parity) is untouched.
//!
//! [`Topology::List`] objects have no restart to separate regions (a region's tail would be
//! read as triangles), so they always draw one record per region and keep stale tails, which
//! no record reads.

use std::ops::Range;

use wgpu::util::{BufferInitDescriptor, DeviceExt, DrawIndexedIndirectArgs};

use super::pipeline::{MorphPipeline, ShadeMode, Uniforms};
use super::{GpuError, RESTART};
use crate::asset::MAX_TARGETS;
use crate::lodstrips::Dirty;
use crate::morph::WeightTrack;

/// Changed spans at most this many bytes apart are uploaded as one write by default.
///
/// Each `queue.write_buffer` allocates a staging buffer and records a copy (the release bench
/// before this default measured 75 µs of `prepare` for 45 writes a frame), so re-sending a few
/// unchanged words beats a second call; but a
/// frame switch rewrites whole strips, mostly to the values they already had, and a large gap
/// re-sends those. Measured on makehuman_body (1,055 strips, 123,512-byte index buffer), 240
/// frames of the bench's exponential sweep, grouped draws, mean bytes per frame / writes per
/// frame: gap 0: 3.89% / 205; 16: 4.29% / 116; 32: 4.50% / 106; 64: 5.12% / 91;
/// 128: 6.81% / 69; 256: 10.39% / 45. 32 bytes (8 indices) keeps the upload under issue 5's
/// 5% goal with half the calls of gap 0. [`Object::set_merge_gap`] changes it.
pub const MERGE_GAP_BYTES: u64 = 32;

/// Index slots per draw record of [`Draws::Grouped`] by default: no limit, the whole object is
/// one record.
///
/// Measured on lavapipe (makehuman_body, 512×512, median GPU ms at LOD fraction 0 / 0.5 / 0.9 /
/// 0.99): one record per strip (1,055) 6.17 / 2.49 / 1.20 / 0.53; budget 256 slots (138
/// records) 5.80 / 2.19 / 1.04 / 0.47; 1,024 (33) 5.51 / 2.17 / 1.01 / 0.47; 4,096 (8)
/// 5.58 / 2.16 / 0.99 / 0.48; one record 5.52 / 2.15 / 0.98 / 0.46. Past a few dozen records
/// the count no longer matters, so the default takes the fewest. Reading the restart tails
/// costs little: at the coarsest level (4 triangles) one record ending at its last live index
/// took 0.352 ms, one spanning every tail 0.378 ms, the live strips packed with single
/// restarts 0.327 ms. (Unmeasured on a real GPU.)
pub const GROUP_INDICES: u32 = u32::MAX;

/// Size of one indirect draw record.
const ARGS_BYTES: u64 = size_of::<DrawIndexedIndirectArgs>() as u64;

/// How the indices of every region are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Topology {
    /// Generalized triangle strips; `0xFFFFFFFF` ([`super::RESTART`]) restarts a strip.
    Strip,
    /// Plain triangle lists (reference renders, list-vs-strip benchmarks).
    List,
}

/// How the regions of a [`Topology::Strip`] object are cut into indirect draw records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draws {
    /// One record per region: record `r` draws region `r` and carries `first_instance = r`
    /// (where the device allows it), as strip colouring needs.
    PerRegion,
    /// Consecutive regions share a record while their slots (capacity plus separator) add up
    /// to at most `max_indices`; a region larger than that gets a record of its own.
    /// [`GROUP_INDICES`] by default.
    Grouped { max_indices: u32 },
}

/// What one [`Object::prepare`] sent to the GPU.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Upload {
    /// Byte ranges of the index buffer written, one per `write_buffer` call, ascending.
    pub index_ranges: Vec<Range<u64>>,
    /// Byte ranges of the indirect buffer written, one per `write_buffer` call, ascending.
    pub indirect_ranges: Vec<Range<u64>>,
    /// Bytes of uniforms written (0 or the whole block).
    pub uniform_bytes: u64,
    /// Bytes of morph-target offsets written (0, or 12 per vertex when the weights changed).
    pub offset_bytes: u64,
}

impl Upload {
    /// Total bytes written.
    pub fn bytes(&self) -> u64 {
        self.geometry_bytes() + self.uniform_bytes + self.offset_bytes
    }

    /// Bytes of index and indirect data written: what a LOD change cost, without the uniforms
    /// that every frame of an animation rewrites anyway.
    pub fn geometry_bytes(&self) -> u64 {
        let sum = |ranges: &[Range<u64>]| ranges.iter().map(|r| r.end - r.start).sum::<u64>();
        sum(&self.index_ranges) + sum(&self.indirect_ranges)
    }

    /// Number of `queue.write_buffer` calls.
    pub fn writes(&self) -> usize {
        self.index_ranges.len()
            + self.indirect_ranges.len()
            + usize::from(self.uniform_bytes > 0)
            + usize::from(self.offset_bytes > 0)
    }
}

/// A morphing mesh on the GPU: poses, region-structured index buffer, indirect draws, uniforms.
pub struct Object {
    pipeline: wgpu::RenderPipeline,
    topology: Topology,
    vertex_count: u32,
    v0: wgpu::Buffer,
    v1: wgpu::Buffer,
    index_buffer: wgpu::Buffer,
    indirect_buffer: wgpu::Buffer,
    uniform_buffer: wgpu::Buffer,
    /// The morph-target offset of every vertex, or a 16-byte zero buffer while the object has
    /// no targets (a binding cannot be empty).
    offset_buffer: wgpu::Buffer,
    targets: Targets,
    bind_group: wgpu::BindGroup,
    /// Region r owns slots `region_starts[r]..region_starts[r + 1]`: its capacity, then (in a
    /// strip object) its separator.
    region_starts: Vec<u32>,
    /// Live length of every region.
    lengths: Vec<u32>,
    /// Whether records carry their number as `first_instance` (`INDIRECT_FIRST_INSTANCE`).
    first_instance: bool,
    /// The grouping asked for; what is drawn also depends on the shade mode and topology.
    draws: Draws,
    shade: ShadeMode,
    /// Which regions each draw record covers.
    records: Records,
    /// CPU mirror of the whole index buffer (equal to the GPU after prepare).
    indices: Vec<u32>,
    /// CPU mirror of the indirect buffer's records in use (the buffer has room for one per
    /// region, the most any grouping needs).
    args: Vec<DrawIndexedIndirectArgs>,
    /// Changed index spans (buffer positions) since the last prepare, unsorted.
    dirty_indices: Vec<Range<u32>>,
    /// Changed records since the last prepare, unsorted.
    dirty_args: Vec<Range<u32>>,
    /// Scratch: records whose regions changed length in one call.
    touched_records: Vec<u32>,
    uniforms: Uniforms,
    uniforms_dirty: bool,
    draw_calls: u64,
    merge_gap_bytes: u64,
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
        if v0.len() != v1.len() {
            return Err(GpuError::PoseSizeMismatch {
                v0: v0.len(),
                v1: v1.len(),
            });
        }
        // RESTART itself must never be a vertex number.
        let max_vertices = RESTART as usize;
        if v0.is_empty() || v0.len() >= max_vertices {
            return Err(GpuError::VertexCount {
                count: v0.len(),
                max: max_vertices - 1,
            });
        }
        let vertex_count = v0.len() as u32;
        let separator = separator_slots(topology);
        let total: usize = regions.iter().map(|r| r.len() + separator as usize).sum();
        let max_buffer = device.limits().max_buffer_size;
        check_size("vertex", v0.len() as u64 * 12, max_buffer)?;
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
            check_indices(region, strip, vertex_count, topology)?;
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
        let mut records = Records {
            starts: Vec::new(),
            of_region: Vec::new(),
        };
        records.cut(&region_starts, draws);
        let first_instance = device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE);
        let args: Vec<DrawIndexedIndirectArgs> = (0..records.starts.len().saturating_sub(1))
            .map(|record| {
                record_args(
                    &records.starts,
                    &region_starts,
                    &lengths,
                    record,
                    first_instance,
                )
            })
            .collect();

        let vertex_buffer = |label, pose: &[[f32; 3]]| {
            device.create_buffer_init(&BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(pose),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            })
        };
        let v0_buffer = vertex_buffer("morphlod V(0)", v0);
        let v1_buffer = vertex_buffer("morphlod V(1)", v1);
        // wgpu cannot bind an empty index buffer; an object without regions gets one unused
        // index so its (empty) multi-draw stays valid.
        let index_contents: &[u32] = if indices.is_empty() { &[0] } else { &indices };
        let index_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod indices"),
            contents: bytemuck::cast_slice(index_contents),
            // COPY_SRC: tests and tools can copy the buffer back to check what the GPU holds.
            usage: wgpu::BufferUsages::INDEX
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        });
        // Room for one record per region, the most any grouping needs (and at least one:
        // wgpu cannot bind an empty buffer); records past the ones drawn stay zero.
        let mut args_contents = args.clone();
        args_contents.resize(regions.len().max(1), DrawIndexedIndirectArgs::default());
        let indirect_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod indirect draws"),
            contents: bytemuck::cast_slice(&args_contents),
            usage: wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        });
        let uniforms = Uniforms::new();
        let uniform_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod uniforms"),
            contents: bytemuck::bytes_of(&uniforms),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let offset_buffer = no_targets(device);
        let bind_group = bind_group(device, pipeline, &uniform_buffer, &offset_buffer);
        let render_pipeline = match topology {
            Topology::Strip => pipeline.strip().clone(),
            Topology::List => pipeline.list().clone(),
        };
        Ok(Object {
            pipeline: render_pipeline,
            topology,
            vertex_count,
            v0: v0_buffer,
            v1: v1_buffer,
            index_buffer,
            indirect_buffer,
            uniform_buffer,
            offset_buffer,
            targets: Targets::default(),
            bind_group,
            region_starts,
            lengths,
            first_instance,
            draws,
            shade: ShadeMode::BaseColour,
            records,
            indices,
            args,
            dirty_indices: Vec::new(),
            dirty_args: Vec::new(),
            touched_records: Vec::new(),
            uniforms,
            uniforms_dirty: false,
            draw_calls: 0,
            merge_gap_bytes: MERGE_GAP_BYTES,
        })
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
        self.indices
            .get(range.start as usize..(range.start + live) as usize)
    }

    /// The live length of every region.
    pub fn lengths(&self) -> &[u32] {
        &self.lengths
    }

    /// The whole index buffer as the GPU will hold it after the next prepare: live strips,
    /// restart tails and separators (strip objects), stale tails (list objects).
    pub fn index_mirror(&self) -> &[u32] {
        &self.indices
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
        &self.args
    }

    /// Record `g` draws regions `record_regions()[g]..record_regions()[g + 1]`.
    pub fn record_regions(&self) -> &[u32] {
        &self.records.starts
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
            ShadeMode::BaseColour => self.draws,
        }
    }

    /// Re-cuts the records when what is drawn changed.
    fn relayout_records(&mut self) {
        let drawn = self.drawn_as();
        if self.records.cut(&self.region_starts, drawn) {
            self.rewrite_records();
        }
    }

    /// Rebuilds every record from the lengths and marks them all for upload.
    fn rewrite_records(&mut self) {
        let count = self.records.starts.len().saturating_sub(1);
        self.args.clear();
        for record in 0..count {
            let args = self.record(record);
            self.args.push(args);
        }
        self.dirty_args.clear();
        if count > 0 {
            self.dirty_args.push(0..count as u32);
        }
    }

    /// Record `record` from the current lengths.
    fn record(&self, record: usize) -> DrawIndexedIndirectArgs {
        record_args(
            &self.records.starts,
            &self.region_starts,
            &self.lengths,
            record,
            self.first_instance,
        )
    }

    /// Recomputes the records of the regions in `self.touched_records` and marks the ones
    /// that changed; empties the list.
    fn update_touched_records(&mut self) {
        let mut touched = std::mem::take(&mut self.touched_records);
        touched.sort_unstable();
        touched.dedup();
        for &record in &touched {
            let args = self.record(record as usize);
            // Lengths only move a record's end; its start and number stay.
            if self.args[record as usize].index_count != args.index_count {
                self.args[record as usize] = args;
                self.dirty_args.push(record..record + 1);
            }
        }
        touched.clear();
        self.touched_records = touched;
    }

    /// The merge gap in indices.
    fn gap_indices(&self) -> u32 {
        u32::try_from(self.merge_gap_bytes / 4).unwrap_or(u32::MAX)
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
        let gap = self.gap_indices();
        if len > old {
            let joined = (start + old) as usize..(start + len) as usize;
            let source = &live[old as usize..len as usize];
            diff_copy(
                &mut self.indices[joined],
                start + old,
                gap,
                &mut self.dirty_indices,
                |i| source[i],
            );
        } else if self.topology == Topology::Strip {
            let left = (start + len) as usize..(start + old) as usize;
            diff_copy(
                &mut self.indices[left],
                start + len,
                gap,
                &mut self.dirty_indices,
                |_| RESTART,
            );
        }
        self.lengths[region] = len;
        self.touched_records.push(self.records.of_region[region]);
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
        check_indices(region, live, self.vertex_count, self.topology)?;

        let start = range.start as usize;
        let kept = live.len().min(self.lengths[region] as usize);
        let gap = self.gap_indices();
        diff_copy(
            &mut self.indices[start..start + kept],
            range.start,
            gap,
            &mut self.dirty_indices,
            |i| live[i],
        );
        self.resize(region, live, live.len() as u32);
        self.update_touched_records();
        Ok(())
    }

    /// Applies what a LOD runtime changed since its last `take_dirty` (a [`Dirty`] from
    /// [`crate::lodstrips::LodState::take_dirty`], or from any runtime with the same contract):
    /// `indices` is the runtime's whole index buffer and `lengths` the live length of every
    /// strip, with strip `r` owning this object's region `r` and the regions packed back to
    /// back in order, as [`crate::lodstrips::LodState::indices`] / `lengths` are (no
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
        let regions = self.region_count();
        let capacity = self.indices.len() - regions * separator_slots(self.topology) as usize;
        if indices.len() != capacity || lengths.len() != regions {
            return Err(GpuError::LayoutMismatch {
                indices: indices.len(),
                strips: lengths.len(),
                capacity,
                regions,
            });
        }
        // Check pass: region numbers, capacities, and the indices each range will copy.
        for &strip in &dirty.lengths {
            let region = strip as usize;
            let (span, live) = self.check_live_length(region, lengths)?;
            let old = self.lengths[region];
            if live > old {
                let source = self.runtime_span(region, span.start, old..live);
                check_indices(region, &indices[source], self.vertex_count, self.topology)?;
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
            let source = self.runtime_span(region, span.start, copied);
            check_indices(region, &indices[source], self.vertex_count, self.topology)?;
        }
        // Apply pass: nothing below can fail.
        let gap = self.gap_indices();
        for range in &dirty.ranges {
            let region = range.strip as usize;
            let start = self.region_starts[region];
            let copied = clip(range.start..range.end, lengths[region]);
            let source = &indices[self.runtime_span(region, start, copied.clone())];
            let span = (start + copied.start) as usize..(start + copied.end) as usize;
            diff_copy(
                &mut self.indices[span],
                start + copied.start,
                gap,
                &mut self.dirty_indices,
                |i| source[i],
            );
        }
        for &strip in &dirty.lengths {
            let region = strip as usize;
            let start = self.region_starts[region];
            let capacity = self.region_starts[region + 1] - start - separator_slots(self.topology);
            let live = &indices[self.runtime_span(region, start, 0..capacity)];
            self.resize(region, live, lengths[region]);
        }
        self.update_touched_records();
        Ok(())
    }

    /// Positions `within` (relative to the region start) of `region` in a runtime's packed
    /// buffer, given the region's start in this object.
    fn runtime_span(&self, region: usize, start: u32, within: Range<u32>) -> Range<usize> {
        let runtime_start = start - region as u32 * separator_slots(self.topology);
        (runtime_start + within.start) as usize..(runtime_start + within.end) as usize
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

    /// Sets the blend parameter between `V(0)` (`t = 0`) and `V(1)` (`t = 1`).
    pub fn set_t(&mut self, t: f32) -> Result<(), GpuError> {
        check_t(t)?;
        self.uniforms.t = t;
        self.uniforms_dirty = true;
        Ok(())
    }

    /// Sets projection * view (world to clip space; wgpu clip space: z in [0, 1], y up).
    pub fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.uniforms.view_proj = view_proj.to_cols_array_2d();
        self.uniforms_dirty = true;
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
        let vertices = self.vertex_count as usize;
        if targets.len() > MAX_TARGETS {
            return Err(GpuError::TargetCount {
                targets: targets.len(),
                max: MAX_TARGETS,
            });
        }
        for (target, deltas) in targets.iter().enumerate() {
            if deltas.len() != vertices {
                return Err(GpuError::TargetLength {
                    target,
                    len: deltas.len(),
                    vertices,
                });
            }
            if let Some((vertex, &value)) = deltas
                .iter()
                .enumerate()
                .find(|(_, d)| !d.iter().all(|c| c.is_finite()))
            {
                return Err(GpuError::NonFiniteDelta {
                    target,
                    vertex,
                    value,
                });
            }
        }
        let bytes = (targets.len() * vertices * 12) as u64;
        let limits = device.limits();
        let max = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        check_size("morph-target", bytes, max)?;
        self.offset_buffer = if targets.is_empty() {
            no_targets(device)
        } else {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("morphlod morph-target offsets"),
                size: vertices as u64 * 12,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                // wgpu zero-initialises buffers: the offsets of all-zero weights.
                mapped_at_creation: false,
            })
        };
        self.bind_group = bind_group(device, pipeline, &self.uniform_buffer, &self.offset_buffer);
        self.targets = Targets {
            deltas: targets.iter().flatten().copied().collect(),
            weights: vec![0.0; targets.len()],
            offsets: vec![[0.0; 3]; if targets.is_empty() { 0 } else { vertices }],
            dirty: false,
        };
        Ok(())
    }

    /// Sets the pose at animation time `t ∈ [0, 1]`: `mix(V(0), V(1), t)` for a two-pose
    /// object (`track` `None`), or `V(0)` plus the targets weighted by `track`'s offsets at `t`
    /// ([`WeightTrack::offsets_at`]) for an object whose targets came from that weight
    /// animation (see [`crate::morph::TargetBlend`]).
    pub fn set_pose(&mut self, t: f32, track: Option<&WeightTrack>) -> Result<(), GpuError> {
        check_t(t)?;
        match track {
            Some(track) => {
                let mut offsets = Vec::with_capacity(track.targets());
                track.offsets_at(t, &mut offsets);
                self.set_target_weights(&offsets)?;
                self.set_t(0.0)
            }
            None => self.set_t(t),
        }
    }

    /// Sets the weight of every morph target (one per target of
    /// [`set_targets`](Self::set_targets), finite).
    pub fn set_target_weights(&mut self, weights: &[f32]) -> Result<(), GpuError> {
        if weights.len() != self.targets.weights.len() {
            return Err(GpuError::InvalidParameter {
                what: "morph-target weights",
                value: format!("{} weights", weights.len()),
                expected: "give one weight per morph target of set_targets",
            });
        }
        if let Some(w) = weights.iter().find(|w| !w.is_finite()) {
            return Err(GpuError::InvalidParameter {
                what: "morph-target weight",
                value: w.to_string(),
                expected: "weights must be finite",
            });
        }
        self.targets.set_weights(weights);
        Ok(())
    }

    /// Sets the object-to-world transform.
    pub fn set_model(&mut self, model: glam::Mat4) {
        self.uniforms.model = model.to_cols_array_2d();
        self.uniforms_dirty = true;
    }

    /// Sets the base colour (linear rgb, alpha written as is).
    pub fn set_color(&mut self, color: [f32; 4]) {
        self.uniforms.color = color;
        self.uniforms_dirty = true;
    }

    /// Sets the world-space direction towards the light and the ambient term.
    pub fn set_light(&mut self, towards_light: glam::Vec3, ambient: f32) -> Result<(), GpuError> {
        if !towards_light.is_finite() || towards_light.length_squared() == 0.0 {
            return Err(GpuError::InvalidParameter {
                what: "light direction",
                value: format!("{towards_light}"),
                expected: "the direction must be finite and nonzero",
            });
        }
        if !(0.0..=1.0).contains(&ambient) {
            return Err(GpuError::InvalidParameter {
                what: "ambient term",
                value: ambient.to_string(),
                expected: "ambient must lie in [0, 1]",
            });
        }
        self.uniforms.light = [towards_light.x, towards_light.y, towards_light.z, ambient];
        self.uniforms_dirty = true;
        Ok(())
    }

    /// Chooses base colour or one colour per strip. Strip colours read the record number, so
    /// while they are on the object draws one record per region (the indirect records are
    /// rewritten and uploaded once on each switch).
    pub fn set_shade_mode(&mut self, mode: ShadeMode) {
        self.uniforms.set_mode(mode);
        self.uniforms_dirty = true;
        self.shade = mode;
        self.relayout_records();
    }

    /// Sets how far apart (in bytes of one buffer) two changed spans may lie and still be sent
    /// as one `write_buffer` ([`MERGE_GAP_BYTES`] by default); it applies to changes made
    /// after the call. 0 sends exactly the changed bytes in more calls; larger values send
    /// fewer, bigger writes.
    pub fn set_merge_gap(&mut self, bytes: u64) {
        self.merge_gap_bytes = bytes;
    }

    /// Uploads everything changed since the last call: coalesced index spans, coalesced
    /// indirect records and the uniforms, each with `queue.write_buffer`. Call before the
    /// render pass that draws this object is submitted.
    pub fn prepare(&mut self, queue: &wgpu::Queue) -> Upload {
        let mut upload = Upload::default();
        let args_gap = u32::try_from(self.merge_gap_bytes / ARGS_BYTES).unwrap_or(u32::MAX);
        let index_gap = self.gap_indices();
        for span in coalesce(&mut self.dirty_indices, index_gap) {
            let data = &self.indices[span.start as usize..span.end as usize];
            let bytes = u64::from(span.start) * 4..u64::from(span.end) * 4;
            queue.write_buffer(&self.index_buffer, bytes.start, bytemuck::cast_slice(data));
            upload.index_ranges.push(bytes);
        }
        for span in coalesce(&mut self.dirty_args, args_gap) {
            let data = &self.args[span.start as usize..span.end as usize];
            let bytes = u64::from(span.start) * ARGS_BYTES..u64::from(span.end) * ARGS_BYTES;
            queue.write_buffer(
                &self.indirect_buffer,
                bytes.start,
                bytemuck::cast_slice(data),
            );
            upload.indirect_ranges.push(bytes);
        }
        if self.uniforms_dirty {
            queue.write_buffer(&self.uniform_buffer, 0, bytemuck::bytes_of(&self.uniforms));
            upload.uniform_bytes = size_of::<Uniforms>() as u64;
            self.uniforms_dirty = false;
        }
        if self.targets.dirty {
            let offsets: &[u8] = bytemuck::cast_slice(&self.targets.offsets);
            queue.write_buffer(&self.offset_buffer, 0, offsets);
            upload.offset_bytes = offsets.len() as u64;
            self.targets.dirty = false;
        }
        upload
    }

    /// Draws every record with exactly one `multi_draw_indexed_indirect`. Sets its own
    /// pipeline, bind group, vertex and index buffers, so objects can be drawn in any order in
    /// one pass.
    pub fn render(&mut self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.v0.slice(..));
        pass.set_vertex_buffer(1, self.v1.slice(..));
        pass.set_index_buffer(self.index_buffer.slice(..), wgpu::IndexFormat::Uint32);
        pass.multi_draw_indexed_indirect(&self.indirect_buffer, 0, self.args.len() as u32);
        self.draw_calls += 1;
    }

    /// How many draw calls [`Object::render`] has issued so far (one per render).
    pub fn draw_calls(&self) -> u64 {
        self.draw_calls
    }
}

/// An object's morph targets, weighted and summed on the CPU into one offset per vertex
/// (`shaders/morph.wgsl` says why the shader does not loop over them).
#[derive(Default)]
struct Targets {
    /// Target k's delta for vertex i at `deltas[k n + i]`.
    deltas: Vec<[f32; 3]>,
    weights: Vec<f32>,
    /// `Σ_k weights[k] · deltas[k n + i]` for every vertex i (empty without targets).
    offsets: Vec<[f32; 3]>,
    /// The offsets changed since the last upload.
    dirty: bool,
}

impl Targets {
    /// Re-sums the offsets when `weights` (one per target, finite) differ from the current ones;
    /// targets of weight 0 cost nothing.
    fn set_weights(&mut self, weights: &[f32]) {
        if weights == self.weights.as_slice() {
            return;
        }
        self.weights.copy_from_slice(weights);
        let n = self.offsets.len();
        self.offsets.fill([0.0; 3]);
        for (k, &w) in weights.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            for (offset, delta) in self
                .offsets
                .iter_mut()
                .zip(&self.deltas[k * n..(k + 1) * n])
            {
                for c in 0..3 {
                    offset[c] += w * delta[c];
                }
            }
        }
        self.dirty = true;
    }
}

/// The offsets of an object without morph targets: zeros, and every out-of-range read of a
/// storage buffer returns a value from inside it or zero (WebGPU), so every vertex reads 0.
fn no_targets(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer_init(&BufferInitDescriptor {
        label: Some("morphlod no targets"),
        contents: &[0; 16],
        usage: wgpu::BufferUsages::STORAGE,
    })
}

fn bind_group(
    device: &wgpu::Device,
    pipeline: &MorphPipeline,
    uniforms: &wgpu::Buffer,
    targets: &wgpu::Buffer,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("morphlod uniforms and targets"),
        layout: pipeline.bind_group_layout(),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: targets.as_entire_binding(),
            },
        ],
    })
}

/// The blend parameter must lie in `[0, 1]` (NaN does not).
pub(crate) fn check_t(t: f32) -> Result<(), GpuError> {
    if !(0.0..=1.0).contains(&t) {
        return Err(GpuError::InvalidParameter {
            what: "blend parameter t",
            value: t.to_string(),
            expected: "t must lie in [0, 1]",
        });
    }
    Ok(())
}

/// Record `record` of `record_starts`: from the start of its first region to the last live
/// index of its last non-empty region (nothing when all are empty). Ending at the last live
/// index, not at the group's end, keeps coarse levels from reading the restart tails after it.
fn record_args(
    record_starts: &[u32],
    region_starts: &[u32],
    lengths: &[u32],
    record: usize,
    first_instance: bool,
) -> DrawIndexedIndirectArgs {
    let (first, end) = (
        record_starts[record] as usize,
        record_starts[record + 1] as usize,
    );
    let first_index = region_starts[first];
    let last_live = (first..end)
        .rev()
        .find(|&r| lengths[r] > 0)
        .map_or(first_index, |r| region_starts[r] + lengths[r]);
    DrawIndexedIndirectArgs {
        index_count: last_live - first_index,
        instance_count: 1,
        first_index,
        base_vertex: 0,
        first_instance: if first_instance { record as u32 } else { 0 },
    }
}

/// Record boundaries over regions.
struct Records {
    /// Record g draws regions `starts[g]..starts[g + 1]`.
    starts: Vec<u32>,
    /// The record of every region.
    of_region: Vec<u32>,
}

impl Records {
    /// Cuts the regions of `region_starts` into records as `draws` says; returns whether the
    /// boundaries changed.
    fn cut(&mut self, region_starts: &[u32], draws: Draws) -> bool {
        let regions = region_starts.len().saturating_sub(1);
        let mut starts = Vec::with_capacity(regions + 1);
        starts.push(0u32);
        if let Draws::Grouped { max_indices } = draws {
            let mut group_start = 0usize;
            for region in 1..regions {
                // Slots from the group's first region to the end of `region`.
                let slots = region_starts[region + 1] - region_starts[group_start];
                if slots > max_indices {
                    starts.push(region as u32);
                    group_start = region;
                }
            }
        } else {
            starts.extend(1..regions as u32);
        }
        if regions > 0 {
            starts.push(regions as u32);
        }
        if starts == self.starts {
            return false;
        }
        self.of_region.clear();
        for (record, w) in starts.windows(2).enumerate() {
            self.of_region
                .extend(std::iter::repeat_n(record as u32, (w[1] - w[0]) as usize));
        }
        self.starts = starts;
        true
    }
}

/// Slots after each region that always hold [`RESTART`]: one in strip objects, none in lists.
fn separator_slots(topology: Topology) -> u32 {
    match topology {
        Topology::Strip => 1,
        Topology::List => 0,
    }
}

fn check_size(what: &'static str, bytes: u64, max: u64) -> Result<(), GpuError> {
    if bytes > max {
        return Err(GpuError::BufferTooLarge { what, bytes, max });
    }
    Ok(())
}

fn check_indices(
    region: usize,
    indices: &[u32],
    vertices: u32,
    topology: Topology,
) -> Result<(), GpuError> {
    let restart_allowed = topology == Topology::Strip;
    let bad = indices
        .iter()
        .position(|&i| i >= vertices && !(restart_allowed && i == RESTART));
    match bad {
        Some(position) => Err(GpuError::IndexOutOfRange {
            region,
            position,
            index: indices[position],
            vertices,
            restart_allowed,
        }),
        None => Ok(()),
    }
}

/// The part of `range` below `live` (empty when it starts past it).
fn clip(range: Range<u32>, live: u32) -> Range<u32> {
    range.start.min(live)..range.end.min(live)
}

/// Writes `new(i)` into `mirror[i]` for every `i` and pushes the changed positions onto
/// `spans` as buffer positions (`at` is the buffer position of `mirror[0]`). A run of more
/// than `gap` unchanged words between two changes closes a span: a frame switch rewrites
/// whole strips, mostly to the values they had, and should upload the words that differ, not
/// everything from the first to the last. Runs of at most `gap` stay inside a span, as
/// [`coalesce`] would merge them anyway.
fn diff_copy(
    mirror: &mut [u32],
    at: u32,
    gap: u32,
    spans: &mut Vec<Range<u32>>,
    new: impl Fn(usize) -> u32,
) {
    // The open span, as positions in `mirror`: first and last changed.
    let mut open: Option<(usize, usize)> = None;
    for (i, slot) in mirror.iter_mut().enumerate() {
        let value = new(i);
        if *slot == value {
            continue;
        }
        *slot = value;
        open = match open {
            Some((first, last)) if i - last - 1 <= gap as usize => Some((first, i)),
            Some((first, last)) => {
                spans.push(at + first as u32..at + last as u32 + 1);
                Some((i, i))
            }
            None => Some((i, i)),
        };
    }
    if let Some((first, last)) = open {
        spans.push(at + first as u32..at + last as u32 + 1);
    }
}

/// Sorts and merges spans that overlap or lie at most `gap` elements apart, and empties `spans`.
fn coalesce(spans: &mut Vec<Range<u32>>, gap: u32) -> Vec<Range<u32>> {
    spans.sort_unstable_by_key(|span| span.start);
    let mut merged: Vec<Range<u32>> = Vec::with_capacity(spans.len());
    for span in spans.drain(..) {
        match merged.last_mut() {
            Some(last) if span.start <= last.end.saturating_add(gap) => {
                last.end = last.end.max(span.end);
            }
            _ => merged.push(span),
        }
    }
    merged
}

#[cfg(test)]
mod tests {
    use super::{coalesce, diff_copy, Draws, Records};

    #[test]
    fn coalesce_merges_overlapping_and_close_spans_only() {
        let mut spans = vec![10..12, 0..4, 3..6, 30..31, 12..13];
        assert_eq!(coalesce(&mut spans, 0), vec![0..6, 10..13, 30..31]);
        assert!(spans.is_empty());
        let mut spans = vec![10..12, 0..4, 30..31];
        assert_eq!(coalesce(&mut spans, 6), vec![0..12, 30..31]);
        let mut spans = vec![5..9, 6..7];
        assert_eq!(coalesce(&mut spans, 0), vec![5..9]);
    }

    #[test]
    fn diff_copy_splits_at_unchanged_runs_longer_than_the_gap() {
        let old = [0u32, 1, 2, 3, 4, 5, 6, 7, 8, 9];
        let new = [0u32, 9, 2, 9, 4, 5, 6, 9, 8, 0];
        // Spans as (start, end) buffer positions.
        let expected: [(u32, &[(u32, u32)]); 3] = [
            (0, &[(101, 102), (103, 104), (107, 108), (109, 110)]),
            (1, &[(101, 104), (107, 110)]),
            (3, &[(101, 110)]),
        ];
        for (gap, expected) in expected {
            let mut mirror = old;
            let mut spans = Vec::new();
            diff_copy(&mut mirror, 100, gap, &mut spans, |i| new[i]);
            assert_eq!(mirror, new);
            let spans: Vec<(u32, u32)> = spans.iter().map(|s| (s.start, s.end)).collect();
            assert_eq!(spans, expected, "gap {gap}");
        }
        let mut mirror = old;
        let mut spans = Vec::new();
        diff_copy(&mut mirror, 0, 0, &mut spans, |i| old[i]);
        assert!(spans.is_empty(), "an unchanged copy marks nothing");
    }

    #[test]
    fn records_group_consecutive_regions_by_slots() {
        // Four regions of 3, 5, 2 and 9 slots (separators included).
        let starts = [0u32, 3, 8, 10, 19];
        let mut records = Records {
            starts: Vec::new(),
            of_region: Vec::new(),
        };
        assert!(records.cut(&starts, Draws::Grouped { max_indices: 10 }));
        assert_eq!(records.starts, [0, 3, 4]);
        assert_eq!(records.of_region, [0, 0, 0, 1]);
        assert!(!records.cut(&starts, Draws::Grouped { max_indices: 10 }));
        // A region larger than the budget gets a record of its own; budget 0 is per region.
        assert!(records.cut(&starts, Draws::Grouped { max_indices: 8 }));
        assert_eq!(records.starts, [0, 2, 3, 4]);
        assert!(records.cut(&starts, Draws::Grouped { max_indices: 0 }));
        assert_eq!(records.starts, [0, 1, 2, 3, 4]);
        assert!(!records.cut(&starts, Draws::PerRegion));
        assert!(records.cut(
            &starts,
            Draws::Grouped {
                max_indices: u32::MAX
            }
        ));
        assert_eq!(records.starts, [0, 4]);
        assert!(records.cut(&[0], Draws::PerRegion));
        assert_eq!(records.starts, [0]);
        assert!(records.of_region.is_empty());
    }
}
