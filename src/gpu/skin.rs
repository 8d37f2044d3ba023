//! Skinned assets on the GPU (issue 51): the clip's joint matrices baked once per asset
//! ([`BakedClip`]: 3×4 rows per joint per key) and per vertex its 4 joints (`u16`) and weights
//! (`f32`), in one storage buffer shared by every object drawing the asset
//! (`shaders/skin.wgsl` lays it out); the
//! skinned pipelines (`vs_skinned`, `vs_skinned_surface`, made on first use); and the probe
//! that runs the vertex stage's skinning in a compute pass and reads it back
//! ([`Object::skinned_pose`](super::Object::skinned_pose)), so tests check the code that draws.
//!
//! Per object only the clip's phase is the object's (a float in its uniforms): nothing of the
//! skeleton is uploaded per frame.

use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::asset::GpuAsset;
use super::pipeline::{Formats, Layout, Variant};
use super::GpuError;
use crate::skin::{BakedClip, Skinning};

/// Influences a vertex has on the GPU: one `vec4` of weights.
pub const GPU_INFLUENCES: usize = 4;

/// Most joints a skin may have on the GPU: its joint indices are `u16`.
pub const GPU_JOINTS: usize = 1 << 16;

/// Words of vertex skin data a vertex takes: 4 `u16` joints in 2, 4 `f32` weights.
const VERTEX_WORDS: usize = 6;

/// Words of the buffer's header: `intervals`, `joints`, where the vertex skin starts, a pad.
const HEADER_WORDS: usize = 4;

/// A skinned asset's clip and vertex skin on the GPU.
pub(super) struct GpuSkin {
    /// `N`: the clip is baked at `N + 1` keys, at `t = i / N`.
    pub(super) intervals: u32,
    /// The header, every key's joint rows, then per vertex its joints and weights
    /// ([`VERTEX_WORDS`] words): `shaders/skin.wgsl`'s `skin_data`.
    pub(super) buffer: wgpu::Buffer,
    /// Bytes of the baked keys (the clip's share of the buffer).
    pub(super) clip_bytes: u64,
}

impl GpuSkin {
    /// Checks `skinning` for `vertices` vertices and the device, bakes its clip
    /// ([`BakedClip::intervals_for`]) and uploads it with the vertex skin. A skin or clip that
    /// does not fit the mesh or each other is [`GpuError::Skin`]; more than
    /// [`GPU_INFLUENCES`] influences [`GpuError::SkinInfluences`]; more than [`GPU_JOINTS`]
    /// joints [`GpuError::SkinJoints`]; keys that with the vertex skin pass one storage
    /// binding [`GpuError::ClipTooLarge`] (checked before anything is baked).
    pub(super) fn new(
        device: &wgpu::Device,
        skinning: &Skinning,
        vertices: usize,
    ) -> Result<GpuSkin, GpuError> {
        skinning
            .validate(vertices)
            .map_err(|source| GpuError::Skin { source })?;
        let skin = &skinning.skin;
        if skin.influences > GPU_INFLUENCES {
            return Err(GpuError::SkinInfluences {
                influences: skin.influences,
                max: GPU_INFLUENCES,
            });
        }
        let joints = skin.joint_count();
        if joints > GPU_JOINTS {
            return Err(GpuError::SkinJoints {
                joints,
                max: GPU_JOINTS,
            });
        }
        let limits = device.limits();
        let max = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let intervals = BakedClip::intervals_for(&skinning.clip);
        let clip_bytes = 4 * BakedClip::floats(intervals, joints);
        let vertex_bytes = (vertices * VERTEX_WORDS * 4) as u64;
        let bytes = 4 * HEADER_WORDS as u64 + clip_bytes + vertex_bytes;
        // Word addresses are u32 in the shader.
        if bytes > max || bytes / 4 > u64::from(u32::MAX) {
            return Err(GpuError::ClipTooLarge {
                keys: intervals as u64 + 1,
                joints,
                bytes,
                max,
            });
        }
        let baked = BakedClip::bake(skinning, intervals);
        let vertex_start = (HEADER_WORDS + baked.rows.len()) as u32;
        let mut words: Vec<u32> = Vec::with_capacity(bytes as usize / 4);
        words.extend([intervals as u32, joints as u32, vertex_start, 0]);
        words.extend(baked.rows.iter().map(|r| r.to_bits()));
        push_vertex_words(skinning, vertices, &mut words);
        let buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod skin"),
            contents: bytemuck::cast_slice(&words),
            usage: wgpu::BufferUsages::STORAGE,
        });
        Ok(GpuSkin {
            intervals: intervals as u32,
            buffer,
            clip_bytes,
        })
    }

    pub(super) fn gpu_bytes(&self) -> u64 {
        self.buffer.size()
    }
}

/// Per vertex its joints as `u16` pairs and its weights' bits, 4 influences (the unused ones
/// joint 0 at weight 0), onto `words`.
fn push_vertex_words(skinning: &Skinning, vertices: usize, words: &mut Vec<u32>) {
    let skin = &skinning.skin;
    let i = skin.influences;
    for v in 0..vertices {
        let joint = |k: usize| if k < i { skin.joints[v * i + k] } else { 0 };
        let weight = |k: usize| if k < i { skin.weights[v * i + k] } else { 0.0 };
        words.extend([joint(0) | joint(1) << 16, joint(2) | joint(3) << 16]);
        words.extend((0..GPU_INFLUENCES).map(|k| weight(k).to_bits()));
    }
}

/// The skinned pipelines of a [`super::MorphPipeline`] and its probe.
pub(crate) struct SkinnedPipelines {
    pub(super) plain: Variant,
    pub(super) surface: Variant,
    /// Group 1 of the probe: V(0), V(1), the surface, the output.
    probe_layout: wgpu::BindGroupLayout,
    probe_plain: wgpu::ComputePipeline,
    probe_surface: wgpu::ComputePipeline,
}

impl SkinnedPipelines {
    pub(super) fn new(
        device: &wgpu::Device,
        shader: &wgpu::ShaderModule,
        formats: Formats,
    ) -> SkinnedPipelines {
        let layout = |surface| Layout {
            surface,
            skinned: true,
        };
        let plain = Variant::new(device, shader, formats, layout(false));
        let surface = Variant::new(device, shader, formats, layout(true));
        let buffer = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: wgpu::BufferSize::new(4),
            },
            count: None,
        };
        let probe_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("morph skin probe"),
            entries: &[
                buffer(0, true),
                buffer(1, true),
                buffer(2, true),
                buffer(3, false),
            ],
        });
        let probe = |variant: &Variant, entry| {
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("morph skin probe"),
                bind_group_layouts: &[Some(&variant.bind_group_layout), Some(&probe_layout)],
                immediate_size: 0,
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&layout),
                module: shader,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        SkinnedPipelines {
            probe_plain: probe(&plain, "cs_skinned"),
            probe_surface: probe(&surface, "cs_skinned_surface"),
            plain,
            surface,
            probe_layout,
        }
    }
}

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
