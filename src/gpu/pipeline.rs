//! The render pipelines for `shaders/morph.wgsl` and the uniform block they read.
//!
//! One [`MorphPipeline`] serves any number of objects: the bind group layout is shared and
//! each object owns its uniform buffer and bind group, so switching objects costs one
//! `set_bind_group` and no pipeline change.

use bytemuck::{Pod, Zeroable};

/// The WGSL source of the morph shader (`shaders/morph.wgsl`).
pub const MORPH_WGSL: &str = include_str!("../../shaders/morph.wgsl");

/// How fragments are coloured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadeMode {
    /// The object's base colour, lit.
    BaseColour,
    /// One colour per strip (region), lit; needs `INDIRECT_FIRST_INSTANCE` on the device,
    /// otherwise every strip gets the colour of strip 0.
    StripColours,
}

impl ShadeMode {
    fn shader_value(self) -> u32 {
        match self {
            ShadeMode::BaseColour => 0,
            ShadeMode::StripColours => 1,
        }
    }
}

/// The uniform block of `morph.wgsl`, byte for byte (WGSL uniform layout: two `mat4x4`, two
/// `vec4`, two 32-bit scalars, padded to 16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Uniforms {
    pub view_proj: [[f32; 4]; 4],
    pub model: [[f32; 4]; 4],
    pub color: [f32; 4],
    /// xyz: world-space direction towards the light; w: ambient term.
    pub light: [f32; 4],
    pub t: f32,
    pub mode: u32,
    /// WGSL rounds the struct up to a multiple of 16 bytes.
    pub _padding: [u32; 2],
}

impl Uniforms {
    /// Identity camera and model, t = 0, light from +z (towards a camera looking down -z),
    /// ambient 0.2, a light grey base colour.
    pub fn new() -> Uniforms {
        Uniforms {
            view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            model: glam::Mat4::IDENTITY.to_cols_array_2d(),
            color: [0.8, 0.8, 0.8, 1.0],
            light: [0.0, 0.0, 1.0, 0.2],
            t: 0.0,
            mode: ShadeMode::BaseColour.shader_value(),
            _padding: [0; 2],
        }
    }

    pub(crate) fn set_mode(&mut self, mode: ShadeMode) {
        self.mode = mode.shader_value();
    }
}

impl Default for Uniforms {
    fn default() -> Uniforms {
        Uniforms::new()
    }
}

/// The morph render pipelines (strip and list) sharing one layout.
pub struct MorphPipeline {
    bind_group_layout: wgpu::BindGroupLayout,
    strip: wgpu::RenderPipeline,
    list: wgpu::RenderPipeline,
}

impl MorphPipeline {
    /// Pipelines with back-face culling (counter-clockwise = front, as in the mesh definitions).
    ///
    /// `color_format` and `depth_format` must match the attachments of every pass the objects
    /// are drawn in ([`super::RenderTarget::COLOR_FORMAT`] / [`super::RenderTarget::DEPTH_FORMAT`] for an
    /// offscreen [`super::RenderTarget`]); wgpu rejects a mismatch when the pass is recorded.
    pub fn new(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        depth_format: Option<wgpu::TextureFormat>,
    ) -> MorphPipeline {
        MorphPipeline::with_cull_mode(device, color_format, depth_format, Some(wgpu::Face::Back))
    }

    /// Pipelines with the given culling; `None` draws both sides (the image test uses it to
    /// check that culling hides nothing, i.e. that no triangle is flipped).
    pub fn with_cull_mode(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        depth_format: Option<wgpu::TextureFormat>,
        cull_mode: Option<wgpu::Face>,
    ) -> MorphPipeline {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("morph.wgsl"),
            source: wgpu::ShaderSource::Wgsl(MORPH_WGSL.into()),
        });
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("morph uniforms"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: wgpu::BufferSize::new(size_of::<Uniforms>() as u64),
                    },
                    count: None,
                },
                // The morph-target offset of every vertex (f32 x, y, z), read by vertex index;
                // objects without targets bind a small zero buffer.
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: wgpu::BufferSize::new(4),
                    },
                    count: None,
                },
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("morph"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let build = |label: &str, topology, strip_index_format| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    // Two buffers, not one interleaved: V(0) and V(1) are uploaded once each
                    // and a pose-only update (a different morph target) rewrites one buffer.
                    buffers: &[
                        Some(wgpu::VertexBufferLayout {
                            array_stride: 12,
                            step_mode: wgpu::VertexStepMode::Vertex,
                            attributes: &wgpu::vertex_attr_array![0 => Float32x3],
                        }),
                        Some(wgpu::VertexBufferLayout {
                            array_stride: 12,
                            step_mode: wgpu::VertexStepMode::Vertex,
                            attributes: &wgpu::vertex_attr_array![1 => Float32x3],
                        }),
                    ],
                },
                primitive: wgpu::PrimitiveState {
                    topology,
                    strip_index_format,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode,
                    ..Default::default()
                },
                depth_stencil: depth_format.map(|format| wgpu::DepthStencilState {
                    format,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: wgpu::StencilState::default(),
                    bias: wgpu::DepthBiasState::default(),
                }),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: color_format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        // Strips restart at 0xFFFFFFFF: WebGPU requires the index format up front for strips.
        let strip = build(
            "morph strips",
            wgpu::PrimitiveTopology::TriangleStrip,
            Some(wgpu::IndexFormat::Uint32),
        );
        let list = build("morph lists", wgpu::PrimitiveTopology::TriangleList, None);
        MorphPipeline {
            bind_group_layout,
            strip,
            list,
        }
    }

    /// The layout of the per-object bind group (binding 0: [`Uniforms`]).
    pub fn bind_group_layout(&self) -> &wgpu::BindGroupLayout {
        &self.bind_group_layout
    }

    /// The triangle-strip pipeline (primitive restart at `0xFFFFFFFF`).
    pub fn strip(&self) -> &wgpu::RenderPipeline {
        &self.strip
    }

    /// The triangle-list pipeline, for reference renders and list-vs-strip comparisons.
    pub fn list(&self) -> &wgpu::RenderPipeline {
        &self.list
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shader must parse and validate without a GPU, so a broken shader fails `cargo test`
    /// on any machine instead of only where an adapter exists.
    #[test]
    fn morph_wgsl_validates_with_naga() {
        let module = match naga::front::wgsl::parse_str(MORPH_WGSL) {
            Ok(module) => module,
            Err(error) => panic!("{}", error.emit_to_string(MORPH_WGSL)),
        };
        let mut validator = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        );
        if let Err(error) = validator.validate(&module) {
            panic!("morph.wgsl does not validate: {error:?}");
        }
        let entry_points: Vec<&str> = module
            .entry_points
            .iter()
            .map(|e| e.name.as_str())
            .collect();
        assert_eq!(entry_points, ["vs_main", "fs_main"]);
    }

    /// The Rust uniform struct and the WGSL struct must have the same size, or the bind group
    /// would fail validation (min_binding_size) or read garbage.
    #[test]
    fn uniforms_match_wgsl_layout() {
        let module = match naga::front::wgsl::parse_str(MORPH_WGSL) {
            Ok(module) => module,
            Err(error) => panic!("{}", error.emit_to_string(MORPH_WGSL)),
        };
        let uniforms = module
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some("Uniforms"));
        let Some((_, ty)) = uniforms else {
            panic!("morph.wgsl has no struct Uniforms");
        };
        let naga::TypeInner::Struct { ref members, span } = ty.inner else {
            panic!("Uniforms is not a struct");
        };
        assert_eq!(span as usize, size_of::<Uniforms>());
        let offsets: Vec<(String, u32)> = members
            .iter()
            .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
            .collect();
        let expected = [
            ("view_proj", std::mem::offset_of!(Uniforms, view_proj)),
            ("model", std::mem::offset_of!(Uniforms, model)),
            ("color", std::mem::offset_of!(Uniforms, color)),
            ("light", std::mem::offset_of!(Uniforms, light)),
            ("t", std::mem::offset_of!(Uniforms, t)),
            ("mode", std::mem::offset_of!(Uniforms, mode)),
        ];
        let expected: Vec<(String, u32)> = expected
            .iter()
            .map(|(name, offset)| (name.to_string(), *offset as u32))
            .collect();
        assert_eq!(offsets, expected);
    }
}
