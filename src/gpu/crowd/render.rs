//! Drawing and looking: `render` (one multi-draw per asset), where each instance is, the
//! buffers and figures, and the GPU probe of an instance's blended positions.

use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::member::Member;
use super::pipeline::{CrowdPath, InstanceBlock};
use super::types::{AssetId, CrowdError, CrowdStats, InstanceAt, InstanceId};
use super::Crowd;
use crate::deform::DeformingState;
use crate::gpu::commands::RenderCommands;
use crate::gpu::records::ARGS_BYTES;

impl Crowd {
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

    /// The runtime of an instance (frame, LOD, triangles, strips), or `None` where it has none:
    /// while it is drawn from its frame's tail list ([`CrowdRecords`](super::CrowdRecords)), and
    /// before its first move (it draws `S0`, frame 0 at full detail).
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
    /// slot range, [`CrowdRecords`](super::CrowdRecords)).
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
        let floats = crate::gpu::readback::read_back(device, queue, encoder, &probed)?;
        Ok(bytemuck::cast_slice::<u8, [f32; 3]>(&floats).to_vec())
    }
}
