//! A minimal wgpu loop, no morphlod code: does the driver keep host memory per draw when the
//! vertex shader has a loop?
//!
//! Draws a 64 × 64 grid (one indexed draw, submit, wait) `DRAWS` times with a vertex shader
//! that blends two vertex inputs and loops over a uniform count (0 iterations: the loop does no
//! work), then again with the same shader without the loop, and prints the resident set growth
//! of each. On lavapipe (Mesa 22.3.6, LLVM 15) the loop costs about 0.25 MB of host memory per
//! draw that is only given back when the device is dropped; without the loop the resident set
//! stays flat. (With a single vertex input the loop does not leak.) This is why
//! `shaders/morph.wgsl` has no loop: the morph-target sum is done on the CPU.
//!
//! ```sh
//! cargo run --release --example driver_leak            # default adapter
//! WGPU_ADAPTER_NAME=llvmpipe cargo run --release --example driver_leak
//! ```

use wgpu::util::DeviceExt;

/// Draws per shader.
const DRAWS: usize = 1000;

/// `LOOP` is replaced by the loop, or by nothing.
const SHADER: &str = r#"
struct U { view_proj: mat4x4<f32>, model: mat4x4<f32>, count: vec4<u32> }
@group(0) @binding(0) var<uniform> u: U;
struct Out { @builtin(position) clip: vec4<f32>, @location(0) world: vec3<f32> }
@vertex fn vs(@location(0) p: vec3<f32>, @location(1) q: vec3<f32>) -> Out {
    var local = mix(p, q, 0.5);
    LOOP
    let world = u.model * vec4<f32>(local, 1.0);
    var out: Out;
    out.clip = u.view_proj * world;
    out.world = world.xyz;
    return out;
}
@fragment fn fs(in: Out) -> @location(0) vec4<f32> { return vec4<f32>(in.world, 1.0); }
"#;

/// Resident set size in MB (Linux `/proc/self/statm`; 0 elsewhere).
fn resident_mb() -> f64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    let pages: f64 = statm
        .split_whitespace()
        .nth(1)
        .and_then(|p| p.parse().ok())
        .unwrap_or(0.0);
    pages * 4096.0 / 1e6
}

fn main() {
    // The instance, adapter and device: WGPU_BACKEND / WGPU_ADAPTER_NAME pick them as usual.
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .expect("no adapter: install a Vulkan driver (lavapipe: mesa-vulkan-drivers)");
    let info = adapter.get_info();
    println!("{} ({:?}, {})", info.name, info.backend, info.driver_info);
    let (device, queue) =
        pollster::block_on(adapter.request_device(&Default::default())).expect("device");

    // A 256 × 256 colour target to draw into.
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d {
            width: 256,
            height: 256,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());

    // The grid: 4,096 vertices in [-0.9, 0.9]², two triangles per cell.
    let vertices: Vec<[f32; 3]> = (0..4096u32)
        .map(|i| {
            [
                (i % 64) as f32 / 35.0 - 0.9,
                (i / 64) as f32 / 35.0 - 0.9,
                0.5,
            ]
        })
        .collect();
    let mut indices: Vec<u32> = Vec::new();
    for row in 0..63u32 {
        for col in 0..63u32 {
            let a = row * 64 + col;
            indices.extend_from_slice(&[a, a + 1, a + 64, a + 1, a + 65, a + 64]);
        }
    }
    let vertex_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&vertices),
        usage: wgpu::BufferUsages::VERTEX,
    });
    let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&indices),
        usage: wgpu::BufferUsages::INDEX,
    });
    // Identity matrices and a loop count of 0.
    let mut uniforms = [0f32; 36];
    for i in 0..4 {
        uniforms[i * 5] = 1.0;
        uniforms[16 + i * 5] = 1.0;
    }
    let uniform_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&uniforms),
        usage: wgpu::BufferUsages::UNIFORM,
    });

    for (name, body) in [
        (
            "with a loop",
            "for (var k = 0u; k < u.count.x; k++) { local.x += 0.001; }",
        ),
        ("without the loop", ""),
    ] {
        // The pipeline for this variant of the shader (layout derived from the shader).
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: None,
            source: wgpu::ShaderSource::Wgsl(SHADER.replace("LOOP", body).into()),
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: None,
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
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
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::TextureFormat::Rgba8Unorm.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform_buffer.as_entire_binding(),
            }],
        });

        // One draw per submission, waited for, like a frame; the first 100 warm up.
        let draw = || {
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: None,
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.set_vertex_buffer(0, vertex_buffer.slice(..));
                pass.set_vertex_buffer(1, vertex_buffer.slice(..));
                pass.set_index_buffer(index_buffer.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..indices.len() as u32, 0, 0..1);
            }
            queue.submit([encoder.finish()]);
            device
                .poll(wgpu::PollType::wait_indefinitely())
                .expect("poll");
        };
        (0..100).for_each(|_| draw());
        let before = resident_mb();
        (0..DRAWS).for_each(|_| draw());
        let growth = resident_mb() - before;
        println!(
            "{name:>16}: resident set +{growth:.1} MB over {DRAWS} draws ({:.3} MB per draw)",
            growth / DRAWS as f64
        );
    }
}
