//! Skinned assets on the GPU (issue 51): the clip's joint matrices baked once per asset
//! ([`BakedClip`]: 3×4 rows per joint per key) and per vertex its 4 joints (`u16`) and weights
//! (`f32`), in one storage buffer shared by every object drawing the asset
//! (`shaders/skin.wgsl` lays it out). The skinned pipelines (`vs_skinned`,
//! `vs_skinned_surface`, made on first use) are the morph pipeline's
//! (`pipeline::SkinnedPipelines`); the probe that reads the vertex stage's skinning back is
//! `skin_probe.rs`. This file is below both: the asset holds its [`GpuSkin`].
//!
//! Per object only the clip's phase is the object's (a float in its uniforms): nothing of the
//! skeleton is uploaded per frame.

use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::GpuError;
use crate::skin::{BakedClip, Skinning, BAKE_TOLERANCE};

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
    /// Checks `skinning` for the `bind` pose's vertices and the device, bakes its clip at
    /// keys close enough for [`BAKE_TOLERANCE`] of `bind`'s diagonal
    /// ([`BakedClip::intervals_within`]) and uploads it with the vertex skin. A skin or clip that
    /// does not fit the mesh or each other is [`GpuError::Skin`]; more than
    /// [`GPU_INFLUENCES`] influences [`GpuError::SkinInfluences`]; more than [`GPU_JOINTS`]
    /// joints [`GpuError::SkinJoints`]; keys that with the vertex skin pass one storage
    /// binding [`GpuError::ClipTooLarge`] (checked before anything is baked). The baked clip
    /// comes back too (a crowd's culling sphere holds its keys' poses).
    pub(super) fn new(
        device: &wgpu::Device,
        skinning: &Skinning,
        bind: &[[f32; 3]],
    ) -> Result<(GpuSkin, BakedClip), GpuError> {
        let vertices = bind.len();
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
        let intervals = BakedClip::intervals_within(skinning, bind, BAKE_TOLERANCE);
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
        let skin = GpuSkin {
            intervals: intervals as u32,
            buffer,
            clip_bytes,
        };
        Ok((skin, baked))
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
