//! One deforming mesh on the GPU, laid out as DESIGN.md "GPU layout" says.
//!
//! * `V(0)` and `V(1)` live in two vertex buffers, uploaded once; the shader blends them with `t`.
//!   An object may also carry morph targets ([`Object::set_targets`]) in a storage buffer,
//!   added with per-frame weights: how a weight animation moves on the GPU.
//! * The index buffer is cut into fixed regions, one per strip of `S0`, each as long as that
//!   strip at full detail. A region's live indices are packed at its start; the rest is stale
//!   and never drawn.
//! * The indirect buffer holds one `DrawIndexedIndirectArgs` per region: `first_index` is the
//!   region's offset (fixed), `index_count` its live length (0 once the strip vanished).
//! * The CPU keeps a mirror of both buffers. Edits go to the mirror and record dirty spans;
//!   [`Object::prepare`] coalesces them into few `queue.write_buffer` calls, and
//!   [`Object::render`] issues one `multi_draw_indexed_indirect` over all regions.

use std::ops::Range;

use wgpu::util::{BufferInitDescriptor, DeviceExt, DrawIndexedIndirectArgs};

use super::pipeline::{MorphPipeline, ShadeMode, Uniforms};
use super::{GpuError, RESTART};
use crate::asset::MAX_TARGETS;
use crate::lodstrips::Dirty;
use crate::morph::WeightTrack;

/// Dirty spans closer than this many bytes are uploaded as one write by default. Each
/// `write_buffer` costs a staging allocation and a copy command; re-sending a few hundred
/// unchanged bytes is cheaper than a second call. [`Object::set_merge_gap`] changes it.
pub const MERGE_GAP_BYTES: u64 = 256;

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

/// What one [`Object::prepare`] sent to the GPU.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Upload {
    /// Byte ranges of the index buffer written, one per `write_buffer` call, ascending.
    pub index_ranges: Vec<Range<u64>>,
    /// Byte ranges of the indirect buffer written, one per `write_buffer` call, ascending.
    pub indirect_ranges: Vec<Range<u64>>,
    /// Bytes of uniforms written (0 or the whole block).
    pub uniform_bytes: u64,
}

impl Upload {
    /// Total bytes written.
    pub fn bytes(&self) -> u64 {
        self.geometry_bytes() + self.uniform_bytes
    }

    /// Bytes of index and indirect data written: what a LOD change cost, without the uniforms
    /// that every frame of an animation rewrites anyway.
    pub fn geometry_bytes(&self) -> u64 {
        let sum = |ranges: &[Range<u64>]| ranges.iter().map(|r| r.end - r.start).sum::<u64>();
        sum(&self.index_ranges) + sum(&self.indirect_ranges)
    }

    /// Number of `queue.write_buffer` calls.
    pub fn writes(&self) -> usize {
        self.index_ranges.len() + self.indirect_ranges.len() + usize::from(self.uniform_bytes > 0)
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
    /// Morph-target deltas, or a 16-byte placeholder while the object has none (a binding
    /// cannot be empty).
    target_buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Region r spans indices `region_starts[r]..region_starts[r + 1]`.
    region_starts: Vec<u32>,
    /// CPU mirror of the whole index buffer, stale tails included (equal to the GPU after prepare).
    indices: Vec<u32>,
    /// CPU mirror of the indirect buffer.
    args: Vec<DrawIndexedIndirectArgs>,
    /// Changed index spans (in indices) since the last prepare, unsorted.
    dirty_indices: Vec<Range<u32>>,
    /// Changed indirect records (region numbers) since the last prepare, unsorted.
    dirty_args: Vec<Range<u32>>,
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
    /// [`Topology::Strip`] object. The device's `INDIRECT_FIRST_INSTANCE` feature decides
    /// whether each region's draw carries its region number as `first_instance`.
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
        let total: usize = regions.iter().map(Vec::len).sum();
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

        let first_instance = device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE);
        let mut region_starts = Vec::with_capacity(regions.len() + 1);
        let mut indices = Vec::with_capacity(total);
        let mut args = Vec::with_capacity(regions.len());
        region_starts.push(0);
        for (region, strip) in regions.iter().enumerate() {
            check_indices(region, strip, vertex_count, topology)?;
            args.push(DrawIndexedIndirectArgs {
                index_count: strip.len() as u32,
                instance_count: 1,
                first_index: indices.len() as u32,
                base_vertex: 0,
                first_instance: if first_instance { region as u32 } else { 0 },
            });
            indices.extend_from_slice(strip);
            region_starts.push(indices.len() as u32);
        }

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
            usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
        });
        let empty_args = [DrawIndexedIndirectArgs::default()];
        let args_contents: &[DrawIndexedIndirectArgs] =
            if args.is_empty() { &empty_args } else { &args };
        let indirect_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod indirect draws"),
            contents: bytemuck::cast_slice(args_contents),
            usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
        });
        let uniforms = Uniforms::new();
        let uniform_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod uniforms"),
            contents: bytemuck::bytes_of(&uniforms),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let target_buffer = no_targets(device);
        let bind_group = bind_group(device, pipeline, &uniform_buffer, &target_buffer);
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
            target_buffer,
            bind_group,
            region_starts,
            indices,
            args,
            dirty_indices: Vec::new(),
            dirty_args: Vec::new(),
            uniforms,
            uniforms_dirty: false,
            draw_calls: 0,
            merge_gap_bytes: MERGE_GAP_BYTES,
        })
    }

    /// Number of regions (strips of `S0`).
    pub fn region_count(&self) -> usize {
        self.args.len()
    }

    /// The fixed span of region `region` in the index buffer, in indices (offset..offset + capacity).
    pub fn region_range(&self, region: usize) -> Option<Range<u32>> {
        let start = *self.region_starts.get(region)?;
        let end = *self.region_starts.get(region + 1)?;
        Some(start..end)
    }

    /// The live indices of region `region` (what its indirect draw reads).
    pub fn live_indices(&self, region: usize) -> Option<&[u32]> {
        let range = self.region_range(region)?;
        let live = self.args.get(region)?.index_count;
        self.indices
            .get(range.start as usize..(range.start + live) as usize)
    }

    /// The indirect draw records as the GPU will see them after the next prepare.
    pub fn indirect_args(&self) -> &[DrawIndexedIndirectArgs] {
        &self.args
    }

    /// Replaces the live indices of `region` (length 0 hides the strip).
    ///
    /// Only the positions whose value changed are marked for upload, so a caller may pass the
    /// whole live strip after a local edit and still upload only the changed span; a changed
    /// length marks the region's indirect record. Nothing changes when an error is returned.
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
        let mirror = &mut self.indices[start..start + live.len()];
        let first = mirror.iter().zip(live).position(|(old, new)| old != new);
        if let Some(first) = first {
            // `first` exists, so a last differing position exists too (at worst `first`).
            let last = mirror
                .iter()
                .zip(live)
                .rposition(|(old, new)| old != new)
                .unwrap_or(first);
            mirror[first..=last].copy_from_slice(&live[first..=last]);
            self.dirty_indices
                .push(range.start + first as u32..range.start + last as u32 + 1);
        }
        let count = live.len() as u32;
        if self.args[region].index_count != count {
            self.args[region].index_count = count;
            self.dirty_args.push(region as u32..region as u32 + 1);
        }
        Ok(())
    }

    /// Applies what a LOD runtime changed since its last `take_dirty` (a [`Dirty`] from
    /// [`crate::lodstrips::LodState::take_dirty`], or from any runtime with the same contract):
    /// `indices` is the runtime's whole index buffer and `lengths` the live length of every
    /// strip, laid out exactly like this object's regions (region `r` of both starts at the same
    /// offset), as [`crate::lodstrips::LodState::indices`] / `lengths` are.
    ///
    /// The contract: every position of a live strip whose value changed lies in one of
    /// `dirty.ranges`, and every strip whose live length changed is in `dirty.lengths`.
    /// Only those ranges are read, not whole regions, and each is clipped to the strip's live
    /// length (stale tails are never drawn) and trimmed of unchanged ends before it is marked
    /// for upload: a step that was undone before this call (coarsen then refine) uploads
    /// nothing. Everything is checked before anything changes; on error the object is as before.
    pub fn apply_dirty(
        &mut self,
        dirty: &Dirty,
        indices: &[u32],
        lengths: &[u32],
    ) -> Result<(), GpuError> {
        if indices.len() != self.indices.len() || lengths.len() != self.args.len() {
            return Err(GpuError::LayoutMismatch {
                indices: indices.len(),
                strips: lengths.len(),
                capacity: self.indices.len(),
                regions: self.args.len(),
            });
        }
        // Check pass: region numbers, capacities, and the indices each range will copy.
        for &strip in &dirty.lengths {
            self.check_live_length(strip as usize, lengths)?;
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
            let source =
                &indices[(span.start + copied.start) as usize..(span.start + copied.end) as usize];
            check_indices(region, source, self.vertex_count, self.topology)?;
        }
        // Apply pass: nothing below can fail.
        for range in &dirty.ranges {
            let region = range.strip as usize;
            let start = self.region_starts[region];
            let copied = clip(range.start..range.end, lengths[region]);
            let span = (start + copied.start) as usize..(start + copied.end) as usize;
            let (mirror, source) = (&mut self.indices[span.clone()], &indices[span]);
            let Some(first) = mirror.iter().zip(source).position(|(old, new)| old != new) else {
                continue;
            };
            // `first` differs, so a last differing position exists (at worst `first`).
            let last = mirror
                .iter()
                .zip(source)
                .rposition(|(old, new)| old != new)
                .unwrap_or(first);
            mirror[first..=last].copy_from_slice(&source[first..=last]);
            let at = start + copied.start;
            self.dirty_indices
                .push(at + first as u32..at + last as u32 + 1);
        }
        for &strip in &dirty.lengths {
            let region = strip as usize;
            if self.args[region].index_count != lengths[region] {
                self.args[region].index_count = lengths[region];
                self.dirty_args.push(strip..strip + 1);
            }
        }
        Ok(())
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

    /// Uploads morph targets (one delta per vertex each) that the shader adds to the blended
    /// pose with the weights of [`set_target_weights`](Self::set_target_weights), all 0 until
    /// then; an empty slice removes them. `pipeline` must be the one the object was made with.
    /// Nothing changes when an error is returned.
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
        self.target_buffer = if targets.is_empty() {
            no_targets(device)
        } else {
            let flat: Vec<[f32; 3]> = targets.iter().flatten().copied().collect();
            device.create_buffer_init(&BufferInitDescriptor {
                label: Some("morphlod morph targets"),
                contents: bytemuck::cast_slice(&flat),
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        self.bind_group = bind_group(device, pipeline, &self.uniform_buffer, &self.target_buffer);
        self.uniforms.target_count = targets.len() as u32;
        self.uniforms.vertex_count = self.vertex_count;
        self.uniforms.target_weights = [[0.0; 4]; MAX_TARGETS / 4];
        self.uniforms_dirty = true;
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
        if weights.len() != self.uniforms.target_count as usize {
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
        let mut packed = [[0.0; 4]; MAX_TARGETS / 4];
        for (k, &w) in weights.iter().enumerate() {
            packed[k / 4][k % 4] = w;
        }
        self.uniforms.target_weights = packed;
        self.uniforms_dirty = true;
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

    /// Chooses base colour or one colour per strip.
    pub fn set_shade_mode(&mut self, mode: ShadeMode) {
        self.uniforms.set_mode(mode);
        self.uniforms_dirty = true;
    }

    /// Sets how far apart (in bytes of one buffer) two dirty spans may lie and still be sent
    /// as one `write_buffer` ([`MERGE_GAP_BYTES`] by default). 0 sends exactly the changed
    /// bytes in more calls; larger values send fewer, bigger writes.
    pub fn set_merge_gap(&mut self, bytes: u64) {
        self.merge_gap_bytes = bytes;
    }

    /// Uploads everything changed since the last call: coalesced index spans, coalesced
    /// indirect records and the uniforms, each with `queue.write_buffer`. Call before the
    /// render pass that draws this object is submitted.
    pub fn prepare(&mut self, queue: &wgpu::Queue) -> Upload {
        let mut upload = Upload::default();
        let gap = |unit: u64| u32::try_from(self.merge_gap_bytes / unit).unwrap_or(u32::MAX);
        let (index_gap, args_gap) = (gap(4), gap(ARGS_BYTES));
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
        upload
    }

    /// Draws every region with exactly one `multi_draw_indexed_indirect`. Sets its own pipeline,
    /// bind group, vertex and index buffers, so objects can be drawn in any order in one pass.
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

/// The binding of an object without morph targets: never read (the shader loops over zero
/// targets), but a bind group cannot leave it empty.
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
    use super::coalesce;

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
}
