//! Adding assets (their buffers, bind group and tail lists) and adding and removing
//! instances.

use std::sync::Arc;

use wgpu::util::{BufferInitDescriptor, DeviceExt, DrawIndexedIndirectArgs};

use super::member::Member;
use super::patches::{set_record, PatchRuns, Span, Waiting};
use super::pipeline::{CrowdPath, InstanceBlock, MeshBlock, Variant};
use super::slots::{Places, SlotLayout};
use super::tail::{TailLists, TRIANGLE_SLOTS};
use super::types::{check_finite, AssetId, CrowdError, InstanceId};
use super::{Crowd, CrowdAsset};
use crate::deform::DeformingModel;
use crate::gpu::asset::{storage_or_zero, GpuAsset};
use crate::gpu::pose::default_mode;
use crate::gpu::records::ARGS_BYTES;
use crate::gpu::GpuError;

impl Crowd {
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

    pub(super) fn bind_group(
        &self,
        device: &wgpu::Device,
        gpu: &GpuAsset,
        mesh: &wgpu::Buffer,
        instances: &wgpu::Buffer,
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
