//! The render pipelines for `shaders/morph.wgsl` and the uniform block they read.
//!
//! One [`MorphPipeline`] serves any number of objects: the bind group layout is shared and
//! each object owns its uniform buffer and bind group, so switching objects costs one
//! `set_bind_group` and no pipeline change.

use std::sync::OnceLock;

use bytemuck::{Pod, Zeroable};

use super::scatter::Scatter;

/// The WGSL source of the morph shader: `shaders/shade.wgsl` (the shading it shares with the
/// crowd), `shaders/skin.wgsl` (skinning from baked keys) and `shaders/morph.wgsl`.
pub const MORPH_WGSL: &str = concat!(
    include_str!("../../shaders/shade.wgsl"),
    include_str!("../../shaders/skin.wgsl"),
    include_str!("../../shaders/morph.wgsl")
);

/// How fragments are coloured and lit.
///
/// An object without a surface (positions only) has no normals or UVs: it draws
/// [`Smooth`](ShadeMode::Smooth) and [`Textured`](ShadeMode::Textured) as
/// [`Faceted`](ShadeMode::Faceted) ([`ShadeMode::for_surface`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadeMode {
    /// The object's colour ([`super::Object::set_color`]), lit with the normal of each drawn
    /// triangle (screen-space derivatives): flat, faceted shading, which shows the LOD's
    /// triangles. The default without a surface.
    Faceted,
    /// One colour per strip (region), faceted; needs `INDIRECT_FIRST_INSTANCE` on the device,
    /// otherwise every strip gets the colour of strip 0.
    StripColours,
    /// The object's colour, lit with the surface's normals blended with the pose:
    /// `normalize(mix(n0, n1, t) + Σ c_k dN_k)`.
    Smooth,
    /// Smooth, coloured with the material: base colour factor × base-colour texture at the
    /// vertex UVs × vertex colour (a missing texture or colour counts as white). The default
    /// with a surface. The texture is sRGB (sampled as linear values) and the lit colour is
    /// encoded to sRGB when the pipeline's colour format is linear, so the texture shows as
    /// authored; the other modes store their colours as is (see [`MorphPipeline::new`]).
    Textured,
}

impl ShadeMode {
    pub(crate) fn shader_value(self) -> u32 {
        match self {
            ShadeMode::Faceted => 0,
            ShadeMode::StripColours => 1,
            ShadeMode::Smooth => 2,
            ShadeMode::Textured => 3,
        }
    }

    /// What an object draws when asked for `self`: itself with a surface, and
    /// [`Faceted`](ShadeMode::Faceted) for the smooth modes without one.
    pub fn for_surface(self, has_surface: bool) -> ShadeMode {
        match self {
            ShadeMode::Smooth | ShadeMode::Textured if !has_surface => ShadeMode::Faceted,
            mode => mode,
        }
    }
}

/// The uniform block of `morph.wgsl`, byte for byte (WGSL uniform layout: three `mat4x4`,
/// three `vec4`, four 32-bit scalars).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Uniforms {
    pub view_proj: [[f32; 4]; 4],
    pub model: [[f32; 4]; 4],
    /// The inverse transpose of `model`'s upper 3x3 (in the xyz of the first three columns):
    /// takes normals to world space.
    pub normal_model: [[f32; 4]; 4],
    /// The object's colour (faceted and smooth modes).
    pub color: [f32; 4],
    /// The material's base colour factor, linear RGBA (textured mode).
    pub base_color: [f32; 4],
    /// xyz: world-space direction towards the light; w: ambient term.
    pub light: [f32; 4],
    pub t: f32,
    pub mode: u32,
    /// 1 when the textured mode encodes its colour to sRGB (a linear target format).
    pub encode_srgb: u32,
    /// The clip's phase in `[0, 1]`, for a skinned asset (`shaders/skin.wgsl`).
    pub clip_t: f32,
}

impl Uniforms {
    /// Identity camera and model, t = 0, light from +z (towards a camera looking down -z),
    /// ambient 0.2, a light grey colour, a white base colour factor, faceted, encoding to sRGB.
    pub fn new() -> Uniforms {
        Uniforms {
            view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            model: glam::Mat4::IDENTITY.to_cols_array_2d(),
            normal_model: glam::Mat4::IDENTITY.to_cols_array_2d(),
            color: [0.8, 0.8, 0.8, 1.0],
            base_color: [1.0; 4],
            light: [0.0, 0.0, 1.0, 0.2],
            t: 0.0,
            mode: ShadeMode::Faceted.shader_value(),
            encode_srgb: 1,
            clip_t: 0.0,
        }
    }

    /// Sets `model` and the normal matrix that goes with it.
    pub(crate) fn set_model(&mut self, model: glam::Mat4) {
        self.model = model.to_cols_array_2d();
        let linear = glam::Mat3::from_mat4(model);
        // A singular model flattens the mesh and has no inverse: its own 3x3 keeps the normals
        // finite (the shader renormalises them).
        let normal = if linear.determinant().is_normal() {
            linear.inverse().transpose()
        } else {
            linear
        };
        self.normal_model = glam::Mat4::from_mat3(normal).to_cols_array_2d();
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

/// Bytes per vertex of an object's surface buffer (slot 2): normal at `t = 0`, at `t = 1`
/// (3 × f32 each), UV (2 × f32), colour (4 × f32).
pub(crate) const SURFACE_STRIDE: u64 = 48;

/// The vertex buffers of a mesh: `V(0)` in slot 0 (location 0) and `V(1)` in slot 1
/// (location 1), and with `surface` the interleaved surface attributes in slot 2 (locations
/// 2..6: n0, n1, uv, colour; [`SURFACE_STRIDE`]). An object and a crowd's first-instance path
/// read them alike.
///
/// Two pose buffers, not one interleaved: V(0) and V(1) are uploaded once each and a
/// pose-only update (a different morph target) rewrites one buffer. The surface attributes
/// never change after upload, so they share one interleaved buffer.
pub(crate) fn vertex_buffers(surface: bool) -> Vec<Option<wgpu::VertexBufferLayout<'static>>> {
    const V0: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x3];
    const V1: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![1 => Float32x3];
    const SURFACE: [wgpu::VertexAttribute; 4] = wgpu::vertex_attr_array![
        2 => Float32x3, 3 => Float32x3, 4 => Float32x2, 5 => Float32x4
    ];
    let buffer = |array_stride, attributes: &'static [wgpu::VertexAttribute]| {
        Some(wgpu::VertexBufferLayout {
            array_stride,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes,
        })
    };
    let mut buffers = vec![buffer(12, &V0), buffer(12, &V1)];
    if surface {
        buffers.push(buffer(SURFACE_STRIDE, &SURFACE));
    }
    buffers
}

/// The morph render pipelines: for position-only objects and for objects with a surface, each
/// for triangle strips and lists; the same for skinned assets, made when the first skinned
/// object is; and the index scatter their objects upload with.
pub struct MorphPipeline {
    plain: Variant,
    surface: Variant,
    /// The skinned variants and their probe, made on first use (most applications draw no
    /// skinned asset, and every pipeline costs a compile).
    skinned: OnceLock<SkinnedPipelines>,
    shader: wgpu::ShaderModule,
    formats: Formats,
    scatter: Scatter,
    /// The colour format is not sRGB: the textured mode encodes its output itself.
    encode_srgb: bool,
}

/// The pipelines of one vertex layout and their bind group layout.
pub(super) struct Variant {
    pub(super) bind_group_layout: wgpu::BindGroupLayout,
    pub(super) strip: wgpu::RenderPipeline,
    pub(super) list: wgpu::RenderPipeline,
}

/// Which vertex layout, bindings and entry points a pipeline uses: `V(0)`, `V(1)` and bindings
/// 0 and 1 always (`vs_main`, `fs_main`); with `surface` also the surface buffer and bindings
/// 2 to 4 (`vs_surface`, `fs_surface`); with `skinned` also binding 5, the clip's keys and the
/// vertices' joints and weights, and every buffer visible to the probe's compute stage too
/// (`vs_skinned`, `vs_skinned_surface`).
#[derive(Clone, Copy)]
pub(super) struct Layout {
    pub(super) surface: bool,
    pub(super) skinned: bool,
}

impl MorphPipeline {
    /// Pipelines with back-face culling (counter-clockwise = front, as in the mesh definitions).
    ///
    /// `color_format` and `depth_format` must match the attachments of every pass the objects
    /// are drawn in ([`super::RenderTarget::COLOR_FORMAT`] / [`super::RenderTarget::DEPTH_FORMAT`] for an
    /// offscreen [`super::RenderTarget`]); wgpu rejects a mismatch when the pass is recorded.
    /// Colours are written as the shader computes them; with a linear (non-sRGB) format, the
    /// [`ShadeMode::Textured`] mode encodes its linear result to sRGB itself, so a texture
    /// looks as authored in either kind of format.
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
        let formats = Formats {
            color: color_format,
            depth: depth_format,
            cull_mode,
        };
        let layout = |surface| Layout {
            surface,
            skinned: false,
        };
        MorphPipeline {
            plain: Variant::new(device, &shader, formats, layout(false)),
            surface: Variant::new(device, &shader, formats, layout(true)),
            skinned: OnceLock::new(),
            shader,
            formats,
            scatter: Scatter::new(device),
            encode_srgb: !color_format.is_srgb(),
        }
    }

    /// The pipelines of skinned objects, made on the first call (on `device`, the one this
    /// pipeline was made on).
    pub(crate) fn skinned(&self, device: &wgpu::Device) -> &SkinnedPipelines {
        self.skinned
            .get_or_init(|| SkinnedPipelines::new(device, &self.shader, self.formats))
    }

    /// The layout of the bind group of a position-only object (binding 0: [`Uniforms`],
    /// binding 1: morph-target offsets).
    pub fn bind_group_layout(&self) -> &wgpu::BindGroupLayout {
        &self.plain.bind_group_layout
    }

    /// The layout of the bind group of an object with a surface: as
    /// [`bind_group_layout`](Self::bind_group_layout), plus binding 2: normal offsets,
    /// 3: the base-colour texture, 4: its sampler.
    pub fn surface_bind_group_layout(&self) -> &wgpu::BindGroupLayout {
        &self.surface.bind_group_layout
    }

    /// The triangle-strip pipeline (primitive restart at `0xFFFFFFFF`) of position-only objects.
    pub fn strip(&self) -> &wgpu::RenderPipeline {
        &self.plain.strip
    }

    /// The triangle-list pipeline of position-only objects, for reference renders and
    /// list-vs-strip comparisons.
    pub fn list(&self) -> &wgpu::RenderPipeline {
        &self.plain.list
    }

    /// The triangle-strip pipeline of objects with a surface.
    pub fn surface_strip(&self) -> &wgpu::RenderPipeline {
        &self.surface.strip
    }

    /// The triangle-list pipeline of objects with a surface.
    pub fn surface_list(&self) -> &wgpu::RenderPipeline {
        &self.surface.list
    }

    /// The index scatter ([`super::Object::prepare`] sends scattered words through it).
    pub(crate) fn scatter(&self) -> &Scatter {
        &self.scatter
    }

    /// Whether the textured mode encodes to sRGB (the colour format is linear).
    pub(crate) fn encodes_srgb(&self) -> bool {
        self.encode_srgb
    }
}

/// The attachment formats and culling every pipeline of a [`MorphPipeline`] (or of a crowd)
/// shares.
#[derive(Clone, Copy)]
pub(super) struct Formats {
    pub(super) color: wgpu::TextureFormat,
    pub(super) depth: Option<wgpu::TextureFormat>,
    pub(super) cull_mode: Option<wgpu::Face>,
}

/// A render pipeline of `shader`: entry points `vs` and `fs` over the vertex `buffers` (none
/// for vertex pulling), depth test `Less` when there is a depth format, strips restarting at
/// 0xFFFFFFFF (WebGPU requires the index format up front for strips).
pub(super) fn render_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    shader: &wgpu::ShaderModule,
    (label, vs, fs): (&str, &str, &str),
    buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
    topology: wgpu::PrimitiveTopology,
    formats: Formats,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module: shader,
            entry_point: Some(vs),
            compilation_options: Default::default(),
            buffers,
        },
        primitive: wgpu::PrimitiveState {
            topology,
            strip_index_format: (topology == wgpu::PrimitiveTopology::TriangleStrip)
                .then_some(wgpu::IndexFormat::Uint32),
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: formats.cull_mode,
            ..Default::default()
        },
        depth_stencil: formats.depth.map(|format| wgpu::DepthStencilState {
            format,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        }),
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: shader,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: formats.color,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl Variant {
    pub(super) fn new(
        device: &wgpu::Device,
        shader: &wgpu::ShaderModule,
        formats: Formats,
        layout: Layout,
    ) -> Variant {
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(match (layout.surface, layout.skinned) {
                (false, false) => "morph uniforms",
                (true, false) => "morph uniforms and surface",
                (false, true) => "morph uniforms and skin",
                (true, true) => "morph uniforms, surface and skin",
            }),
            entries: &bind_group_entries(layout),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("morph"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let (vs, fs) = match (layout.surface, layout.skinned) {
            (false, false) => ("vs_main", "fs_main"),
            (true, false) => ("vs_surface", "fs_surface"),
            (false, true) => ("vs_skinned", "fs_main"),
            (true, true) => ("vs_skinned_surface", "fs_surface"),
        };
        let buffers = vertex_buffers(layout.surface);
        let build = |label: &str, topology| {
            render_pipeline(
                device,
                &pipeline_layout,
                shader,
                (label, vs, fs),
                &buffers,
                topology,
                formats,
            )
        };
        // Strips restart at 0xFFFFFFFF: WebGPU requires the index format up front for strips.
        let strip = build("morph strips", wgpu::PrimitiveTopology::TriangleStrip);
        let list = build("morph lists", wgpu::PrimitiveTopology::TriangleList);
        Variant {
            bind_group_layout,
            strip,
            list,
        }
    }
}

/// The bindings of one layout: uniforms and offsets for every object; normal offsets, texture
/// and sampler for objects with a surface; the clip's keys and the vertex skin for skinned
/// objects, whose buffers the probe's compute stage reads too.
fn bind_group_entries(layout: Layout) -> Vec<wgpu::BindGroupLayoutEntry> {
    let compute = if layout.skinned {
        wgpu::ShaderStages::COMPUTE
    } else {
        wgpu::ShaderStages::NONE
    };
    let storage = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX | compute,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(4),
        },
        count: None,
    };
    let mut entries = vec![
        wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | compute,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: wgpu::BufferSize::new(size_of::<Uniforms>() as u64),
            },
            count: None,
        },
        // The morph-target offset of every vertex (f32 x, y, z), read by vertex index;
        // objects without targets bind a small zero buffer.
        storage(1),
    ];
    if layout.surface {
        // The normal offsets, laid out and bound like the position offsets.
        entries.push(storage(2));
        entries.extend(texture_entries(3));
    }
    if layout.skinned {
        entries.push(storage(5));
    }
    entries
}

/// The fragment stage's base colour texture (binding `first`, filterable 2D) and its sampler
/// (`first + 1`), as the object's and the crowd's bind groups lay them out.
pub(crate) fn texture_entries(first: u32) -> [wgpu::BindGroupLayoutEntry; 2] {
    [
        wgpu::BindGroupLayoutEntry {
            binding: first,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: true },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        },
        wgpu::BindGroupLayoutEntry {
            binding: first + 1,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        },
    ]
}

/// The skinned pipelines of a [`super::MorphPipeline`] and its probe.
pub(crate) struct SkinnedPipelines {
    pub(super) plain: Variant,
    pub(super) surface: Variant,
    /// Group 1 of the probe: V(0), V(1), the surface, the output.
    pub(super) probe_layout: wgpu::BindGroupLayout,
    pub(super) probe_plain: wgpu::ComputePipeline,
    pub(super) probe_surface: wgpu::ComputePipeline,
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

/// `source` parsed and validated by naga, for the shader tests of the object and the crowd
/// pipelines (a broken shader fails `cargo test` without a GPU); panics with naga's message.
#[cfg(test)]
pub(crate) fn validated_wgsl(source: &str) -> naga::Module {
    let module = match naga::front::wgsl::parse_str(source) {
        Ok(module) => module,
        Err(error) => panic!("{}", error.emit_to_string(source)),
    };
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    );
    if let Err(error) = validator.validate(&module) {
        panic!("the shader does not validate: {error:?}");
    }
    module
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shader must parse and validate without a GPU, so a broken shader fails `cargo test`
    /// on any machine instead of only where an adapter exists.
    #[test]
    fn morph_wgsl_validates_with_naga() {
        let module = validated_wgsl(MORPH_WGSL);
        let entry_points: Vec<&str> = module
            .entry_points
            .iter()
            .map(|e| e.name.as_str())
            .collect();
        assert_eq!(
            entry_points,
            [
                "vs_main",
                "vs_surface",
                "vs_skinned",
                "vs_skinned_surface",
                "fs_main",
                "fs_surface",
                "cs_skinned",
                "cs_skinned_surface"
            ]
        );
    }

    /// The Rust uniform struct and the WGSL struct must have the same size, or the bind group
    /// would fail validation (min_binding_size) or read garbage.
    #[test]
    fn uniforms_match_wgsl_layout() {
        let module = validated_wgsl(MORPH_WGSL);
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
            ("normal_model", std::mem::offset_of!(Uniforms, normal_model)),
            ("color", std::mem::offset_of!(Uniforms, color)),
            ("base_color", std::mem::offset_of!(Uniforms, base_color)),
            ("light", std::mem::offset_of!(Uniforms, light)),
            ("t", std::mem::offset_of!(Uniforms, t)),
            ("mode", std::mem::offset_of!(Uniforms, mode)),
            ("encode_srgb", std::mem::offset_of!(Uniforms, encode_srgb)),
            ("clip_t", std::mem::offset_of!(Uniforms, clip_t)),
        ];
        let expected: Vec<(String, u32)> = expected
            .iter()
            .map(|(name, offset)| (name.to_string(), *offset as u32))
            .collect();
        assert_eq!(offsets, expected);
    }
}
