//! The index scatter (`shaders/scatter.wgsl`): a list of patches, uploaded with one write,
//! applied by one compute dispatch. A [`super::Crowd`] patches its assets' index slots and
//! records with `[word, value]` pairs (`scatter`); an [`super::Object`] sends a frame's index
//! edits as runs of consecutive words (`scatter_runs`, [`super::Object::prepare`]).

/// The WGSL source of the index scatter (`shaders/scatter.wgsl`).
pub const SCATTER_WGSL: &str = include_str!("../../shaders/scatter.wgsl");

/// Patches one scatter workgroup applies (`@workgroup_size` of `scatter`); a list is
/// padded to whole workgroups by repeating its last patch.
pub(crate) const SCATTER_GROUP: u32 = 64;

/// Run headers one `scatter_runs` workgroup applies (its `@workgroup_size`): small, since the
/// list is padded to whole workgroups and an object's frame may have few runs.
pub(crate) const RUN_GROUP: u32 = 16;

/// The most words one run header covers (the stores one `scatter_runs` invocation makes).
pub(crate) const RUN_WORDS: u32 = 16;

/// The scatter's compute pipelines and the layout of their bind group (binding 0: the patches,
/// read-only storage of `[u32; 2]`; binding 1: the patched buffer, read-write storage of `u32`).
#[derive(Clone, Debug)]
pub(crate) struct Scatter {
    pub(crate) layout: wgpu::BindGroupLayout,
    /// `[word, value]` pairs, one invocation each.
    pub(crate) pipeline: wgpu::ComputePipeline,
    /// Runs of up to [`RUN_WORDS`] words, one invocation each.
    pub(crate) runs: wgpu::ComputePipeline,
}

impl Scatter {
    pub(crate) fn new(device: &wgpu::Device) -> Scatter {
        let storage = compute_storage;
        // Patches are [word, value] pairs: 8 bytes each.
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("morphlod scatter"),
            entries: &[storage(0, true, 8), storage(1, false, 4)],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("scatter.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SCATTER_WGSL.into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("morphlod scatter"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let entry = |name| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(name),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        Scatter {
            pipeline: entry("scatter"),
            runs: entry("scatter_runs"),
            layout,
        }
    }

    /// The bind group that applies the patches in `patches` to `target`.
    pub(crate) fn bind_group(
        &self,
        device: &wgpu::Device,
        label: &str,
        patches: &wgpu::Buffer,
        target: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: patches.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: target.as_entire_binding(),
                },
            ],
        })
    }

    /// The most bytes one `scatter_runs` list may have on this device: one storage binding,
    /// and no more headers (8 bytes each) than one dimension of workgroups dispatches.
    pub(crate) fn max_run_list_bytes(device: &wgpu::Device) -> u64 {
        let limits = device.limits();
        let by_dispatch =
            u64::from(limits.max_compute_workgroups_per_dimension) * u64::from(RUN_GROUP) * 8;
        limits.max_storage_buffer_binding_size.min(by_dispatch)
    }
}

/// A storage buffer binding of a compute stage, at least `size` bytes.
pub(crate) fn compute_storage(
    binding: u32,
    read_only: bool,
    size: u64,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size),
        },
        count: None,
    }
}
