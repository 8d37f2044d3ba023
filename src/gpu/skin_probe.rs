//! The probe of a skinned object (issue 51): the vertex stage's skinning run in a compute pass
//! (`cs_skinned`, `cs_skinned_surface`, the same WGSL functions `vs_skinned` calls) and read
//! back ([`Object::skinned_pose`](super::Object::skinned_pose)), so tests check the code that
//! draws.

use super::asset::GpuAsset;
use super::pipeline::SkinnedPipelines;
use super::GpuError;

/// What a skinned object's vertex stage computes for every vertex, object space (before the
/// model transform): [`Object::skinned_pose`](super::Object::skinned_pose).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinnedPose {
    /// The morphed position, skinned.
    pub positions: Vec<[f32; 3]>,
    /// The morphed normal skinned by the skin matrix's 3×3 part, before normalisation; zero
    /// for an asset without a surface.
    pub normals: Vec<[f32; 3]>,
}

/// Runs the probe of `asset` (skinned) with the object's bind group `group` (uniforms as of its
/// last upload) and reads every vertex's position and normal back.
pub(super) fn probe(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipelines: &SkinnedPipelines,
    asset: &GpuAsset,
    group: &wgpu::BindGroup,
) -> Result<SkinnedPose, GpuError> {
    let n = asset.vertex_count();
    let probed = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("morph skin probe"),
        size: u64::from(n) * 24,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let surface = asset.surface().map_or(asset.v0(), |s| &s.buffer);
    let buffers = [asset.v0(), asset.v1(), surface, &probed];
    let entries: Vec<wgpu::BindGroupEntry> = (0u32..)
        .zip(buffers)
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    let probe_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("morph skin probe"),
        layout: &pipelines.probe_layout,
        entries: &entries,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(if asset.has_surface() {
            &pipelines.probe_surface
        } else {
            &pipelines.probe_plain
        });
        pass.set_bind_group(0, group, &[]);
        pass.set_bind_group(1, &probe_group, &[]);
        pass.dispatch_workgroups(n.div_ceil(64), 1, 1);
    }
    let bytes = super::readback::read_back(device, queue, encoder, &probed)?;
    let floats: &[[f32; 3]] = bytemuck::cast_slice(&bytes);
    Ok(SkinnedPose {
        positions: floats.iter().step_by(2).copied().collect(),
        normals: floats.iter().skip(1).step_by(2).copied().collect(),
    })
}
