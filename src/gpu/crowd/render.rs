//! Drawing and looking: `render` (one multi-draw per asset and page), where each instance
//! is, the buffers and figures, and the GPU probe of an instance's blended positions.

use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::pipeline::{CrowdPath, InstanceBlock, PoseBlock};
use super::pool::Page;
use super::slots::DrawnFrom;
use super::types::{AssetId, CrowdError, CrowdStats, InstanceAt, InstanceId};
use super::Crowd;
use crate::deform::DeformingState;
use crate::gpu::commands::RenderCommands;
use crate::gpu::records::ARGS_BYTES;

impl Crowd {
    /// Draws every asset's instances: per asset one bind group and, on the first-instance
    /// path, its vertex buffers (poses, surface); per page of its index memory (one holds a
    /// crowd of thousands) its index buffer and exactly one `multi_draw_indexed_indirect` over
    /// its records (free ones draw nothing). Sets its own pipelines (one per vertex entry point
    /// in use). Draws what the last [`prepare`](Self::prepare) uploaded.
    pub fn render(&self, pass: &mut (impl RenderCommands + ?Sized)) {
        let mut bound = None;
        for a in &self.assets {
            let Some(group) = &a.bind_group else {
                continue;
            };
            let pages = a.pool.pages.iter().filter_map(|page| match page {
                Page {
                    indices: Some(indices),
                    indirect: Some(indirect),
                    drawn,
                    ..
                } if *drawn > 0 => Some((indices, indirect, *drawn)),
                _ => None,
            });
            let mut pages = pages.peekable();
            if pages.peek().is_none() {
                continue;
            }
            if bound != Some(a.render) {
                pass.set_pipeline(self.pipeline.render(a.render));
                bound = Some(a.render);
            }
            pass.set_bind_group(0, group);
            if self.path == CrowdPath::FirstInstance {
                pass.set_vertex_buffer(0, a.gpu.v0());
                pass.set_vertex_buffer(1, a.gpu.v1());
                if let Some(surface) = a.gpu.surface() {
                    pass.set_vertex_buffer(2, &surface.buffer);
                }
            }
            for (indices, indirect, drawn) in pages {
                pass.set_index_buffer(indices, wgpu::IndexFormat::Uint32);
                pass.multi_draw_indexed_indirect(indirect, 0, drawn);
            }
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

    /// Pages of `asset`'s index memory (each drawn by one multi-draw).
    pub fn pages(&self, asset: AssetId) -> usize {
        self.assets
            .get(asset.0 as usize)
            .map_or(0, |a| a.pool.pages.len())
    }

    /// Page `page`'s index buffer of `asset` (`COPY_SRC`; none before the first prepare): the
    /// areas of the instances whose records are in the page's indirect buffer.
    pub fn index_buffer(&self, asset: AssetId, page: usize) -> Option<&wgpu::Buffer> {
        let a = self.assets.get(asset.0 as usize)?;
        a.pool.pages.get(page)?.indices.as_ref()
    }

    /// Page `page`'s indirect buffer of `asset` (`COPY_SRC`; none before the first prepare):
    /// one record per instance whose area is in the page (its `first_instance` or
    /// `base_vertex` names the instance's slot), free records zero.
    pub fn indirect_buffer(&self, asset: AssetId, page: usize) -> Option<&wgpu::Buffer> {
        let a = self.assets.get(asset.0 as usize)?;
        a.pool.pages.get(page)?.indirect.as_ref()
    }

    /// Records `render` draws from page `page` of `asset` (one past its highest in use).
    pub fn drawn_records(&self, asset: AssetId, page: usize) -> u32 {
        let a = self.assets.get(asset.0 as usize);
        a.and_then(|a| a.pool.pages.get(page))
            .map_or(0, |p| p.drawn)
    }

    /// The most words of an instance's compact copy for `asset`
    /// ([`CrowdRecords`](super::CrowdRecords)).
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

    /// Live instances, triangles drawn and bytes, over all assets.
    pub fn stats(&self) -> CrowdStats {
        let mut stats = CrowdStats::default();
        // An instance's placement and pose, on the GPU and mirrored on the host.
        let block = (size_of::<InstanceBlock>() + size_of::<PoseBlock>()) as u64;
        for a in &self.assets {
            for member in a.members.iter().flatten() {
                stats.instances += 1;
                match member.holds {
                    DrawnFrom::S0 => stats.from_s0 += 1,
                    DrawnFrom::Tail => stats.from_tails += 1,
                    DrawnFrom::Copy => stats.from_copies += 1,
                    DrawnFrom::Regions => stats.from_regions += 1,
                }
                let area = member.area.map_or(0, |area| u64::from(area.words) * 4);
                stats.instance_gpu_bytes += area + ARGS_BYTES + block;
                stats.instance_host_bytes += member.heap_bytes() as u64 + block;
                if member.hidden {
                    stats.culled += 1;
                    continue;
                }
                stats.triangles += a.at(member).triangles;
                let page = &a.pool.pages[member.record.page as usize];
                let record = page.records[member.record.entry as usize];
                stats.indices += u64::from(record.index_count);
            }
            // The records' mirrors, free ones included.
            let records: usize = a.pool.pages.iter().map(|p| p.records.len()).sum();
            stats.instance_host_bytes += (records as u64) * ARGS_BYTES;
            stats.spare_host_bytes += a.spares.heap_bytes() as u64;
            let shared = a.gpu.gpu_bytes() + a.tail_words.as_ref().map_or(0, |b| b.size());
            stats.shared_gpu_bytes += shared;
            let blocks = (a.instance_buffers.as_ref()).map_or(0, |(b, p)| b.size() + p.size());
            let scratch: u64 = (a.binds.iter())
                .map(|binds| {
                    let patches = binds.patches.iter().flatten();
                    let jobs = binds.tail_jobs.iter().map(|(buffer, _)| buffer.size());
                    patches.map(|p| p.buffer.size()).sum::<u64>() + jobs.sum::<u64>()
                })
                .sum();
            stats.scratch_gpu_bytes += scratch;
            stats.scratch_host_bytes += (a.run_list.capacity() * size_of::<u32>()) as u64;
            stats.gpu_bytes += shared + a.pool.gpu_bytes() + blocks + a.restarts.size() + scratch;
        }
        stats
    }

    /// The positions the vertex stage blends for an instance (object space, before its
    /// transform), computed on the GPU by the same WGSL function (`local_position`) and read
    /// back: how a test checks the GPU weight sum against the CPU. A skinned asset's are its
    /// skinned positions (`crowd_skin.wgsl`'s `skinned_position`: the morph, then the skin at
    /// the instance's clip phase). Uses the blocks as of the last [`prepare`](Self::prepare).
    pub fn blended_positions(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        id: InstanceId,
    ) -> Result<Vec<[f32; 3]>, CrowdError> {
        self.state(id)?;
        let a = &self.assets[id.asset as usize];
        let bind_group = a.bind_group.as_ref().ok_or(CrowdError::NotPrepared)?;
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
            pass.set_pipeline(&self.pipeline.module(a.variant).probe);
            pass.set_bind_group(0, bind_group, &[]);
            pass.set_bind_group(1, &group, &[]);
            pass.dispatch_workgroups(n.div_ceil(64), 1, 1);
        }
        let floats = crate::gpu::readback::read_back(device, queue, encoder, &probed)?;
        Ok(bytemuck::cast_slice::<u8, [f32; 3]>(&floats).to_vec())
    }
}
