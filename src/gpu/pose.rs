//! What an [`Object`](super::Object) draws its vertices with: the uniform block (blend
//! parameter `t`, camera, model matrix, colour, light, shade mode), the morph targets with
//! their weights (summed on the CPU into one position offset and, with a surface, one normal
//! offset per vertex, uploaded as storage buffers), the surface (texture, sampler) and the
//! bind group over all of them.

use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::pipeline::{MorphPipeline, ShadeMode, Uniforms};
use super::surface::GpuSurface;
use super::GpuError;
use crate::asset::MAX_TARGETS;
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
    surface: Option<GpuSurface>,
    bind_group: wgpu::BindGroup,
}

/// Bytes [`Pose::upload`] wrote.
pub(super) struct PoseUpload {
    pub(super) uniform_bytes: u64,
    /// Position and normal offsets.
    pub(super) offset_bytes: u64,
    pub(super) offset_writes: usize,
    pub(super) texture_bytes: u64,
}

impl Pose {
    /// Default uniforms, no morph targets; with a surface, the textured mode when it has a
    /// texture and smooth otherwise, faceted without one.
    pub(super) fn new(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        vertex_count: u32,
        surface: Option<GpuSurface>,
    ) -> Self {
        let mut uniforms = Uniforms::new();
        uniforms.encode_srgb = u32::from(pipeline.encodes_srgb());
        if let Some(surface) = &surface {
            uniforms.base_color = surface.base_color;
        }
        uniforms.set_mode(default_mode(surface.as_ref()));
        let uniform_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod uniforms"),
            contents: bytemuck::bytes_of(&uniforms),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let offset_buffer = no_targets(device);
        let normal_offset_buffer = no_targets(device);
        Pose {
            vertex_count,
            uniforms,
            dirty: false,
            bind_group: bind_group(
                device,
                pipeline,
                &uniform_buffer,
                &offset_buffer,
                &normal_offset_buffer,
                surface.as_ref(),
            ),
            uniform_buffer,
            offset_buffer,
            normal_offset_buffer,
            targets: Targets::default(),
            surface,
        }
    }

    /// The mode an object starts in.
    pub(super) fn default_mode(&self) -> ShadeMode {
        default_mode(self.surface.as_ref())
    }

    pub(super) fn surface(&self) -> Option<&GpuSurface> {
        self.surface.as_ref()
    }

    fn rebind(&mut self, device: &wgpu::Device, pipeline: &MorphPipeline) {
        self.bind_group = bind_group(
            device,
            pipeline,
            &self.uniform_buffer,
            &self.offset_buffer,
            &self.normal_offset_buffer,
            self.surface.as_ref(),
        );
    }

    pub(super) fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// Writes the uniform block, the morph-target offsets and the texture when they changed
    /// (the texture only the first time).
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
        let texture_bytes = self.surface.as_mut().map_or(0, |s| s.upload(queue));
        PoseUpload {
            uniform_bytes,
            offset_bytes,
            offset_writes,
            texture_bytes,
        }
    }

    /// `t` clamped to `[0, 1]`; NaN is refused and changes nothing.
    pub(super) fn set_t(&mut self, t: f32) -> Result<(), GpuError> {
        self.uniforms.t = clamp_t(t)?;
        self.dirty = true;
        Ok(())
    }

    pub(super) fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.uniforms.view_proj = view_proj.to_cols_array_2d();
        self.dirty = true;
    }

    pub(super) fn set_targets(
        &mut self,
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        targets: &[Vec<[f32; 3]>],
        normals: &[Vec<[f32; 3]>],
    ) -> Result<(), GpuError> {
        let vertices = self.vertex_count as usize;
        if targets.len() > MAX_TARGETS {
            return Err(GpuError::TargetCount {
                targets: targets.len(),
                max: MAX_TARGETS,
            });
        }
        if !normals.is_empty() && (normals.len() != targets.len() || self.surface.is_none()) {
            return Err(GpuError::InvalidParameter {
                what: "normal deltas",
                value: format!(
                    "{} arrays for {} targets on an object {} a surface",
                    normals.len(),
                    targets.len(),
                    if self.surface.is_some() {
                        "with"
                    } else {
                        "without"
                    }
                ),
                expected: "give none, or one per target on an object with a surface",
            });
        }
        for (target, deltas) in targets.iter().chain(normals).enumerate() {
            // Normal deltas are checked like the positions and named by their target.
            let target = target % targets.len().max(1);
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
        super::object::check_size("morph-target", bytes, max)?;
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
        let has_normals = !targets.is_empty() && !normals.is_empty();
        self.offset_buffer = offsets(!targets.is_empty());
        self.normal_offset_buffer = offsets(has_normals);
        self.rebind(device, pipeline);
        let per_vertex = |present: bool| vec![[0.0; 3]; if present { vertices } else { 0 }];
        self.targets = Targets {
            deltas: targets.iter().flatten().copied().collect(),
            normal_deltas: normals.iter().flatten().copied().collect(),
            weights: vec![0.0; targets.len()],
            offsets: per_vertex(!targets.is_empty()),
            normal_offsets: per_vertex(has_normals),
            dirty: false,
        };
        Ok(())
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
    /// Target k's delta for vertex i at `deltas[k n + i]`.
    deltas: Vec<[f32; 3]>,
    /// Target k's normal delta for vertex i at `normal_deltas[k n + i]` (empty without).
    normal_deltas: Vec<[f32; 3]>,
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
        weighted_sum(&mut self.offsets, &self.deltas, weights);
        weighted_sum(&mut self.normal_offsets, &self.normal_deltas, weights);
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
fn default_mode(surface: Option<&GpuSurface>) -> ShadeMode {
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

/// The bind group of the plain layout, or of the surface layout when there is a surface.
fn bind_group(
    device: &wgpu::Device,
    pipeline: &MorphPipeline,
    uniforms: &wgpu::Buffer,
    targets: &wgpu::Buffer,
    normal_targets: &wgpu::Buffer,
    surface: Option<&GpuSurface>,
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
    let layout = match surface {
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
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("morphlod uniforms and targets"),
        layout,
        entries: &entries,
    })
}
