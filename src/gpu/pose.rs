//! What an [`Object`](super::Object) draws its vertices with: the uniform block (blend
//! parameter `t`, camera, model matrix, colour, light, shade mode), the morph targets with
//! their weights (summed on the CPU into one position offset and, with a surface, one normal
//! offset per vertex, uploaded as storage buffers), the surface (texture, sampler) and the
//! bind group over all of them.

use std::sync::Arc;

use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::asset::{GpuAsset, TargetDeltas};
use super::pipeline::{MorphPipeline, ShadeMode, Uniforms};
use super::surface::GpuSurface;
use super::GpuError;
use crate::morph::WeightTrack;

/// The uniforms and morph targets of one object, with their GPU buffers.
pub(super) struct Pose {
    vertex_count: u32,
    uniforms: Uniforms,
    /// The block changed since the last upload.
    dirty: bool,
    uniform_buffer: wgpu::Buffer,
    /// The morph-target offset of every vertex, or a 16-byte zero buffer while the object has
    /// no targets (a binding cannot be empty).
    offset_buffer: wgpu::Buffer,
    /// The same for the normal offsets (a zero buffer without a surface or normal deltas).
    normal_offset_buffer: wgpu::Buffer,
    targets: Targets,
    /// Whether the object's asset has a surface (normal deltas need one).
    has_surface: bool,
    bind_group: wgpu::BindGroup,
}

/// Bytes [`Pose::upload`] wrote.
pub(super) struct PoseUpload {
    pub(super) uniform_bytes: u64,
    /// Position and normal offsets.
    pub(super) offset_bytes: u64,
    pub(super) offset_writes: usize,
}

impl Pose {
    /// Default uniforms, no morph targets; with a surface, the textured mode when it has a
    /// texture and smooth otherwise, faceted without one.
    pub(super) fn new(device: &wgpu::Device, pipeline: &MorphPipeline, asset: &GpuAsset) -> Self {
        let surface = asset.surface();
        let mut uniforms = Uniforms::new();
        uniforms.encode_srgb = u32::from(pipeline.encodes_srgb());
        if let Some(surface) = surface {
            uniforms.base_color = surface.base_color;
        }
        uniforms.set_mode(default_mode(surface));
        let uniform_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod uniforms"),
            contents: bytemuck::bytes_of(&uniforms),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let offset_buffer = no_targets(device);
        let normal_offset_buffer = no_targets(device);
        Pose {
            vertex_count: asset.vertex_count(),
            uniforms,
            dirty: false,
            bind_group: bind_group(
                device,
                pipeline,
                &uniform_buffer,
                (&offset_buffer, &normal_offset_buffer),
                asset,
            ),
            uniform_buffer,
            offset_buffer,
            normal_offset_buffer,
            targets: Targets::default(),
            has_surface: surface.is_some(),
        }
    }

    fn rebind(&mut self, device: &wgpu::Device, pipeline: &MorphPipeline, asset: &GpuAsset) {
        self.bind_group = bind_group(
            device,
            pipeline,
            &self.uniform_buffer,
            (&self.offset_buffer, &self.normal_offset_buffer),
            asset,
        );
    }

    pub(super) fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// Writes the uniform block and the morph-target offsets when they changed.
    pub(super) fn upload(&mut self, queue: &wgpu::Queue) -> PoseUpload {
        let mut uniform_bytes = 0;
        if self.dirty {
            queue.write_buffer(&self.uniform_buffer, 0, bytemuck::bytes_of(&self.uniforms));
            self.dirty = false;
            uniform_bytes = size_of::<Uniforms>() as u64;
        }
        let (mut offset_bytes, mut offset_writes) = (0, 0);
        if self.targets.dirty {
            for (buffer, offsets) in [
                (&self.offset_buffer, &self.targets.offsets),
                (&self.normal_offset_buffer, &self.targets.normal_offsets),
            ] {
                if !offsets.is_empty() {
                    let bytes: &[u8] = bytemuck::cast_slice(offsets);
                    queue.write_buffer(buffer, 0, bytes);
                    offset_bytes += bytes.len() as u64;
                    offset_writes += 1;
                }
            }
            self.targets.dirty = false;
        }
        PoseUpload {
            uniform_bytes,
            offset_bytes,
            offset_writes,
        }
    }

    /// `t` clamped to `[0, 1]`; NaN is refused and changes nothing.
    pub(super) fn set_t(&mut self, t: f32) -> Result<(), GpuError> {
        self.uniforms.t = clamp_t(t)?;
        self.dirty = true;
        Ok(())
    }

    /// The clip's phase (skinned assets), clamped to `[0, 1]`; NaN is refused.
    pub(super) fn set_clip_t(&mut self, t: f32) -> Result<(), GpuError> {
        self.uniforms.clip_t = clamp_t(t)?;
        self.dirty = true;
        Ok(())
    }

    pub(super) fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.uniforms.view_proj = view_proj.to_cols_array_2d();
        self.dirty = true;
    }

    /// Sets morph targets from deltas given by the caller (checked and uploaded as a
    /// [`TargetDeltas`] of this object's own).
    pub(super) fn set_targets(
        &mut self,
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        targets: &[Vec<[f32; 3]>],
        normals: &[Vec<[f32; 3]>],
        asset: &GpuAsset,
    ) -> Result<(), GpuError> {
        let vertices = self.vertex_count as usize;
        let deltas = TargetDeltas::new(device, targets, normals, vertices, self.has_surface)?;
        self.share_targets(device, pipeline, Arc::new(deltas), asset);
        Ok(())
    }

    /// Sets the morph targets of a shared asset: the deltas stay the asset's, the object
    /// holds its weights and the offsets it sums from them.
    pub(super) fn share_targets(
        &mut self,
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        deltas: Arc<TargetDeltas>,
        asset: &GpuAsset,
    ) {
        let vertices = self.vertex_count as usize;
        let offsets = |present: bool| {
            if present {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("morphlod morph-target offsets"),
                    size: vertices as u64 * 12,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    // wgpu zero-initialises buffers: the offsets of all-zero weights.
                    mapped_at_creation: false,
                })
            } else {
                no_targets(device)
            }
        };
        let has_targets = deltas.count > 0;
        let has_normals = has_targets && !deltas.normals.is_empty();
        self.offset_buffer = offsets(has_targets);
        self.normal_offset_buffer = offsets(has_normals);
        self.rebind(device, pipeline, asset);
        let per_vertex = |present: bool| vec![[0.0; 3]; if present { vertices } else { 0 }];
        self.targets = Targets {
            weights: vec![0.0; deltas.count],
            offsets: per_vertex(has_targets),
            normal_offsets: per_vertex(has_normals),
            deltas: Some(deltas),
            dirty: false,
        };
    }

    pub(super) fn set_pose(&mut self, t: f32, track: Option<&WeightTrack>) -> Result<(), GpuError> {
        let t = clamp_t(t)?;
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

    pub(super) fn set_target_weights(&mut self, weights: &[f32]) -> Result<(), GpuError> {
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

    pub(super) fn set_model(&mut self, model: glam::Mat4) {
        self.uniforms.set_model(model);
        self.dirty = true;
    }

    pub(super) fn set_color(&mut self, color: [f32; 4]) {
        self.uniforms.color = color;
        self.dirty = true;
    }

    pub(super) fn set_light(
        &mut self,
        towards_light: glam::Vec3,
        ambient: f32,
    ) -> Result<(), GpuError> {
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
        self.dirty = true;
        Ok(())
    }

    pub(super) fn set_mode(&mut self, mode: ShadeMode) {
        self.uniforms.set_mode(mode);
        self.dirty = true;
    }
}

/// The one rule for the blend parameter, as on the CPU ([`crate::deform::DeformingModel::frame_at`]):
/// clamped to `[0, 1]`; NaN is [`GpuError::TimeNaN`].
pub(super) fn clamp_t(t: f32) -> Result<f32, GpuError> {
    if t.is_nan() {
        return Err(GpuError::TimeNaN);
    }
    Ok(t.clamp(0.0, 1.0))
}

/// An object's morph targets, weighted and summed on the CPU into one offset per vertex
/// (`shaders/morph.wgsl` says why the shader does not loop over them).
#[derive(Default)]
struct Targets {
    /// The deltas (shared with the asset, or the object's own from `set_targets`).
    deltas: Option<Arc<TargetDeltas>>,
    weights: Vec<f32>,
    /// `Σ_k weights[k] · deltas[k n + i]` for every vertex i (empty without targets).
    offsets: Vec<[f32; 3]>,
    /// `Σ_k weights[k] · normal_deltas[k n + i]` (empty without normal deltas).
    normal_offsets: Vec<[f32; 3]>,
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
        let Some(deltas) = &self.deltas else {
            return;
        };
        weighted_sum(&mut self.offsets, &deltas.positions, weights);
        weighted_sum(&mut self.normal_offsets, &deltas.normals, weights);
        self.dirty = true;
    }
}

/// `sums[i] = Σ_k weights[k] · deltas[k n + i]` with `n = sums.len()`; targets of weight 0 are
/// skipped. Nothing to do for an empty `sums` (no such offsets).
fn weighted_sum(sums: &mut [[f32; 3]], deltas: &[[f32; 3]], weights: &[f32]) {
    let n = sums.len();
    sums.fill([0.0; 3]);
    if n == 0 {
        return;
    }
    for (k, &w) in weights.iter().enumerate() {
        if w == 0.0 {
            continue;
        }
        for (sum, delta) in sums.iter_mut().zip(&deltas[k * n..(k + 1) * n]) {
            for c in 0..3 {
                sum[c] += w * delta[c];
            }
        }
    }
}

/// Textured when the surface has a texture, smooth with a surface without one, faceted
/// without a surface.
pub(super) fn default_mode(surface: Option<&GpuSurface>) -> ShadeMode {
    match surface {
        Some(surface) if surface.textured => ShadeMode::Textured,
        Some(_) => ShadeMode::Smooth,
        None => ShadeMode::Faceted,
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

/// The bind group of the plain layout, or of the surface layout when `asset` has a surface;
/// of the skinned one of either when it is skinned.
fn bind_group(
    device: &wgpu::Device,
    pipeline: &MorphPipeline,
    uniforms: &wgpu::Buffer,
    (targets, normal_targets): (&wgpu::Buffer, &wgpu::Buffer),
    asset: &GpuAsset,
) -> wgpu::BindGroup {
    let mut entries = vec![
        wgpu::BindGroupEntry {
            binding: 0,
            resource: uniforms.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 1,
            resource: targets.as_entire_binding(),
        },
    ];
    let layout = match asset.surface() {
        None => pipeline.bind_group_layout(),
        Some(surface) => {
            entries.extend([
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: normal_targets.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&surface.view),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::Sampler(&surface.sampler),
                },
            ]);
            pipeline.surface_bind_group_layout()
        }
    };
    let layout = match asset.skin() {
        None => layout,
        Some(skin) => {
            entries.push(wgpu::BindGroupEntry {
                binding: 5,
                resource: skin.buffer.as_entire_binding(),
            });
            let skinned = pipeline.skinned(device);
            let variant = if asset.has_surface() {
                &skinned.surface
            } else {
                &skinned.plain
            };
            &variant.bind_group_layout
        }
    };
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("morphlod uniforms and targets"),
        layout,
        entries: &entries,
    })
}
