//! Adding assets (their pool, templates and tail lists) and adding and removing instances.

use std::sync::Arc;

use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::member::{Member, Spares};
use super::patches::{draw_args, DirtySlots, Span, Waiting};
use super::pipeline::{CrowdPath, InstanceBlock, MeshBlock, PoseBlock, Variant};
use super::pool::{Pool, GRANULE};
use super::slots::SlotLayout;
use super::tail::{TailLists, TRIANGLE_SLOTS};
use super::types::{check_finite, AssetId, CrowdError, InstanceId};
use super::{Crowd, CrowdAsset};
use crate::deform::DeformingModel;
use crate::gpu::asset::{storage_or_zero, GpuAsset};
use crate::gpu::pose::default_mode;
use crate::gpu::{GpuError, RESTART};

impl Crowd {
    /// Adds an asset. Its buffers grow with its instances from the next prepare on (room for
    /// `capacity` instance blocks is reserved on the host now): no instance count is refused,
    /// but on the base-vertex path ([`CrowdError::Full`]). `model` must be made from the asset
    /// `gpu` was uploaded from ([`CrowdError::ModelMismatch`]), `gpu` on `device`
    /// ([`GpuError::OtherDevice`]); one instance's full-detail indices must fit one of the
    /// device's buffers ([`CrowdError::TooLarge`]).
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
        // A page is bound whole by the scatter and the tail expansion: at most one buffer and
        // one storage binding of the device.
        let limits = device.limits();
        let limit = limits
            .max_buffer_size
            .min(limits.max_storage_buffer_binding_size);
        let layout = SlotLayout::new(&model, self.records.compact_share);
        let need = u64::from(layout.regions()) * 4;
        let mut pool = Pool::new(limit);
        if layout.regions().next_multiple_of(GRANULE) > pool.page_words() {
            return Err(CrowdError::TooLarge { need, limit });
        }
        // A tail list's LODs fit the largest compact copy.
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
        // The instance blocks are one storage binding; on the base-vertex path base_vertex
        // (an i32) is slot × n, and slot × n + index is the vertex_index (a u32).
        let blocks = limits.max_storage_buffer_binding_size / size_of::<InstanceBlock>() as u64;
        let numbered = i32::MAX as u64 / u64::from(n.max(1));
        let most = match self.path {
            CrowdPath::BaseVertex if numbered < blocks => (numbered, "slot times the asset's vertex count passes 2^31 on the base-vertex path; a device with INDIRECT_FIRST_INSTANCE has no such limit"),
            _ => (blocks, "their instance blocks fill max_storage_buffer_binding_size"),
        };
        let most = (most.0 < u64::from(u32::MAX)).then_some((most.0 as u32, most.1));
        let s0 = pool.alloc(layout.regions(), 0);
        let restarts = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("crowd restarts"),
            contents: bytemuck::cast_slice(&vec![RESTART; layout.regions() as usize]),
            usage: wgpu::BufferUsages::COPY_SRC,
        });
        let mesh = mesh_buffer(device, &gpu);
        let variant = Variant::new(
            self.path,
            gpu.has_surface(),
            gpu.target_count(),
            gpu.is_skinned(),
        );
        let render = self.pipeline.render_for(device, variant);
        let id = self.assets.len() as u32;
        let capacity = capacity as usize;
        self.assets.push(CrowdAsset {
            gpu,
            model,
            layout,
            pool,
            s0,
            s0_written: false,
            restarts,
            binds: Vec::new(),
            mesh,
            instance_buffers: None,
            bind_group: None,
            render,
            variant,
            members: Vec::with_capacity(capacity),
            generations: Vec::with_capacity(capacity),
            free: Vec::new(),
            blocks: Vec::with_capacity(capacity),
            poses: Vec::with_capacity(capacity),
            dirty_blocks: DirtySlots::default(),
            dirty_poses: Span::EMPTY,
            waiting: Waiting::default(),
            arriving: Vec::new(),
            run_list: Vec::new(),
            prepares: 0,
            spares: Spares::default(),
            tails,
            tail_words,
            most,
        });
        Ok(AssetId(id))
    }

    /// The bind group of an asset drawn as `variant` (a skinned one binds the asset's skin
    /// too).
    pub(super) fn bind_group(
        &self,
        device: &wgpu::Device,
        (gpu, variant): (&GpuAsset, Variant),
        mesh: &wgpu::Buffer,
        (placements, poses): (&wgpu::Buffer, &wgpu::Buffer),
    ) -> wgpu::BindGroup {
        let zero = || storage_or_zero(device, "crowd zero", &[]);
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
            placements,
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
        entries.push(wgpu::BindGroupEntry {
            binding: 10,
            resource: poses.as_entire_binding(),
        });
        if let Some(skin) = gpu.skin().filter(|_| variant.skinned) {
            entries.push(wgpu::BindGroupEntry {
                binding: 11,
                resource: skin.buffer.as_entire_binding(),
            });
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("crowd asset"),
            layout: &self.pipeline.module(variant).layout,
            entries: &entries,
        })
    }

    /// Adds an instance of `asset` at full detail, time 0, with transform `model` (finite),
    /// in the lowest free slot; drawn from the next prepare (from the asset's shared `S0`
    /// until its first move: it uploads its record and block, nothing else).
    pub fn add(&mut self, asset: AssetId, model: glam::Mat4) -> Result<InstanceId, CrowdError> {
        check_finite("transform", &model.to_cols_array())?;
        let path = self.path;
        let a = self
            .assets
            .get_mut(asset.0 as usize)
            .ok_or(CrowdError::UnknownAsset(asset.0))?;
        let n = a.gpu.vertex_count();
        let slot = match a.free.last() {
            Some(&slot) => slot,
            None => a.members.len() as u32,
        };
        if let Some((most, why)) = a.most.filter(|&(most, _)| slot >= most) {
            return Err(CrowdError::Full {
                asset: asset.0,
                most,
                why,
            });
        }
        // Until its first move it draws the S0 of page 0, with its record there.
        if !a.pool.record_room(a.s0.page as usize) {
            return Err(CrowdError::Full {
                asset: asset.0,
                most: a.members.iter().flatten().count() as u32,
                why: "the new ones' records fill a storage binding of their page; move some first",
            });
        }
        if a.free.pop().is_none() {
            a.members.push(None);
            a.generations.push(0);
            a.blocks.push(InstanceBlock::new(glam::Mat4::IDENTITY));
            a.poses.push(PoseBlock::default());
        }
        // Its runtime is made by its first move out of the tail lists (most of a crowd's
        // instances are distant: their first move takes them to one), its area by its first
        // move.
        let reads = a.layout.region_record(&a.layout.s0_lengths());
        let record = a.pool.add_record(a.s0.page);
        let args = draw_args((path, n), slot, a.s0.offset, reads);
        a.pool.set_record(record, args);
        a.blocks[slot as usize] = InstanceBlock::new(model);
        a.poses[slot as usize] = PoseBlock::default();
        a.dirty_blocks.add(slot);
        a.dirty_poses.add(slot);
        a.members[slot as usize] = Some(Member::new(record, reads));
        Ok(InstanceId {
            asset: asset.0,
            slot,
            generation: a.generations[slot as usize],
        })
    }

    /// Removes an instance: its record draws nothing from the next prepare, its area is freed
    /// and its slot is reused by a later [`add`](Self::add); its id is refused from now on.
    pub fn remove(&mut self, id: InstanceId) -> Result<(), CrowdError> {
        let a = self.member_asset(id)?;
        let slot = id.slot as usize;
        let member = a.members[slot].take().expect("checked live");
        if member.patched == a.prepares {
            (a.waiting.withdrawn).push((id.slot, a.waiting.index_runs.len()));
        }
        if let Some(area) = member.area {
            a.pool.free(area);
        }
        a.pool.remove_record(member.record);
        a.generations[slot] = a.generations[slot].wrapping_add(1);
        // Lowest slot reused first: keeps the instance blocks dense.
        let at = a.free.partition_point(|&s| s > id.slot);
        a.free.insert(at, id.slot);
        Ok(())
    }
}

/// The asset's block (`Mesh` in `crowd.wgsl`): base colour, vertex count, shade mode.
pub(super) fn mesh_buffer(device: &wgpu::Device, gpu: &GpuAsset) -> wgpu::Buffer {
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
