//! The crowd's GPU programs and the blocks they read: the render pipelines of
//! `shaders/crowd.wgsl` (strips; one per vertex entry point in use), the scatter that applies a frame's index
//! patches (`shaders/scatter.wgsl`), the expansion of frames' tail lists into instances'
//! compact areas (`shaders/tail.wgsl`), the probe that writes an instance's blended positions
//! back, and the byte layouts of the scene, mesh and instance blocks.

use bytemuck::{Pod, Zeroable};

use crate::gpu::pipeline::texture_entries;
use crate::gpu::pipeline::{render_pipeline, vertex_buffers, Formats};
use crate::gpu::scatter::{compute_storage, Scatter};

use super::tail::TailJob;

/// The WGSL source of the crowd shader: `shaders/shade.wgsl` followed by `shaders/crowd.wgsl`.
pub const CROWD_WGSL: &str = concat!(
    include_str!("../../../shaders/shade.wgsl"),
    include_str!("../../../shaders/crowd.wgsl")
);

/// The WGSL source of a crowd's skinned assets: [`CROWD_WGSL`], `shaders/skin.wgsl` and
/// `shaders/crowd_skin.wgsl` (one module more, made on the first skinned asset).
pub const CROWD_SKIN_WGSL: &str = concat!(
    include_str!("../../../shaders/shade.wgsl"),
    include_str!("../../../shaders/crowd.wgsl"),
    include_str!("../../../shaders/skin.wgsl"),
    include_str!("../../../shaders/crowd_skin.wgsl")
);

pub use crate::gpu::scatter::SCATTER_WGSL;

/// The WGSL source of the tail expansion (`shaders/tail.wgsl`).
pub const TAIL_WGSL: &str = include_str!("../../../shaders/tail.wgsl");

/// The scene block (`Scene` in `crowd.wgsl`): camera and light, shared by every asset.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(super) struct SceneBlock {
    pub(super) view_proj: [[f32; 4]; 4],
    pub(super) light: [f32; 4],
    pub(super) encode_srgb: u32,
    /// The crowd's clock, in seconds ([`Crowd::set_clock`](super::Crowd::set_clock)): each
    /// instance is moved by its velocity times the seconds since its placement.
    pub(super) clock: f32,
    pub(super) _pad: [u32; 2],
}

/// The per-asset block (`Mesh` in `crowd.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(super) struct MeshBlock {
    pub(super) base_color: [f32; 4],
    pub(super) vertex_count: u32,
    pub(super) mode: u32,
    pub(super) _pad: [u32; 2],
}

/// Target slots per instance: the weights summed by the vertex stage.
pub const WEIGHT_SLOTS: usize = 8;

/// One instance's placement (`Placement` in `crowd.wgsl`): its transform, normal matrix,
/// motion and colour, 144 bytes, uploaded where they change.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(super) struct InstanceBlock {
    pub(super) model: [[f32; 4]; 4],
    /// The inverse transpose of `model`'s 3×3 (a WGSL `mat3x3`: columns padded to 4).
    pub(super) normal_model: [[f32; 4]; 3],
    /// xyz: its world-space velocity per second; w: the crowd clock at which `model` holds.
    /// The vertex stage adds `(clock - w) * xyz` to every world position (root motion, no
    /// upload while it walks).
    pub(super) motion: [f32; 4],
    pub(super) color: [f32; 4],
}

/// One instance's pose (`Pose` in `crowd.wgsl`): its 8 weight slots and their targets, `t`
/// and a skinned asset's clip phase; what a frame uploads per moved instance: 48 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub(super) struct PoseBlock {
    pub(super) weights: [f32; WEIGHT_SLOTS],
    /// One target number per byte, slot 0 in the low byte of `targets[0]`.
    pub(super) targets: [u32; 2],
    pub(super) t: f32,
    /// The clip's phase (`crowd_skin.wgsl` skins at it; unread without a skin).
    pub(super) clip_t: f32,
}

impl InstanceBlock {
    /// `model` as given, grey.
    pub(super) fn new(model: glam::Mat4) -> InstanceBlock {
        let mut block = InstanceBlock::zeroed();
        block.set_model(model);
        block.color = [0.8, 0.8, 0.8, 1.0];
        block
    }

    /// Sets `model` and its normal matrix (the rule of [`super::super::Uniforms`]).
    pub(super) fn set_model(&mut self, model: glam::Mat4) {
        let mut uniforms = super::super::Uniforms::new();
        uniforms.set_model(model);
        self.model = uniforms.model;
        let [x, y, z, _] = uniforms.normal_model;
        self.normal_model = [x, y, z];
    }

    /// Its world-space offset at crowd clock `clock`: what the vertex stage adds.
    pub(super) fn offset_at(&self, clock: f32) -> glam::Vec3 {
        let [x, y, z, since] = self.motion;
        (clock - since) * glam::Vec3::new(x, y, z)
    }

    /// Its object-to-world transform at crowd clock `clock`: `model` moved by its offset.
    pub(super) fn model_at(&self, clock: f32) -> glam::Mat4 {
        glam::Mat4::from_translation(self.offset_at(clock))
            * glam::Mat4::from_cols_array_2d(&self.model)
    }
}

impl PoseBlock {
    /// Sets the pose at time `t` (clamped, not NaN): for an asset with a weight `track`, its
    /// weights at `t` in the slots and `t = 0`; else `t` and no weights. The clip phase is `t`
    /// (as [`LodObject::set`](crate::gpu::LodObject::set) plays a skinned asset's clip). `scratch` holds the
    /// weights on the way (one per thread, not one allocation per instance and frame).
    pub(super) fn set_pose(
        &mut self,
        track: Option<&crate::morph::WeightTrack>,
        t: f32,
        scratch: &mut Vec<f32>,
    ) {
        self.clip_t = t;
        match track {
            Some(track) => {
                track.offsets_at(t, scratch);
                self.set_weights(scratch);
                self.t = 0.0;
            }
            None => self.t = t,
        }
    }

    /// Fills the weight slots with the `WEIGHT_SLOTS` weights of largest magnitude of
    /// `weights` (one per target), in ascending target order, the rest at weight 0.
    pub(super) fn set_weights(&mut self, weights: &[f32]) {
        let nonzero = (0..weights.len() as u32).filter(|&k| weights[k as usize] != 0.0);
        // At most WEIGHT_SLOTS nonzero (every asset of at most 8 targets): all of them, in
        // order, without an allocation.
        let mut few = [0u32; WEIGHT_SLOTS];
        let mut count = 0;
        let mut many: Vec<u32> = Vec::new();
        for k in nonzero.clone() {
            if count == WEIGHT_SLOTS {
                many = nonzero.collect();
                break;
            }
            few[count] = k;
            count += 1;
        }
        if !many.is_empty() {
            // Largest magnitude first, lower target first on ties: deterministic.
            many.sort_by(|&a, &b| {
                let (wa, wb) = (weights[a as usize].abs(), weights[b as usize].abs());
                wb.total_cmp(&wa).then(a.cmp(&b))
            });
            many.truncate(WEIGHT_SLOTS);
            many.sort_unstable();
        }
        let order = if many.is_empty() {
            &few[..count]
        } else {
            &many[..]
        };
        self.weights = [0.0; WEIGHT_SLOTS];
        self.targets = [0; 2];
        for (slot, &k) in order.iter().enumerate() {
            self.weights[slot] = weights[k as usize];
            self.targets[slot / 4] |= k << (8 * (slot % 4));
        }
    }

    /// The target of weight slot `slot` (`< WEIGHT_SLOTS`), as [`set_weights`](Self::set_weights)
    /// packed it.
    pub(super) fn target(&self, slot: usize) -> u32 {
        (self.targets[slot / 4] >> (8 * (slot % 4))) & 0xFF
    }
}

/// How a crowd's vertex stage learns the instance of a vertex (`shaders/crowd.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CrowdPath {
    /// Slot `s`'s record has `first_instance = s` and `base_vertex = 0`; the poses and the
    /// surface attributes are vertex buffers (fixed-function fetch) and the instance block is
    /// read by `instance_index`. Needs `wgpu::Features::INDIRECT_FIRST_INSTANCE` (without it
    /// wgpu requires `first_instance = 0` in indirect draws).
    FirstInstance,
    /// Slot `s`'s record has `base_vertex = s × vertex count`; the vertex stage splits
    /// `vertex_index` into slot and vertex and pulls poses and surface from storage buffers.
    /// Any device; `capacity × vertex count` must stay below 2³¹.
    BaseVertex,
}

/// Which entry points of `crowd.wgsl` draw an asset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) struct Variant {
    path: CrowdPath,
    /// Reads and interpolates the surface attributes (else faceted: position and colour only).
    surface: bool,
    /// Weight slots summed: 0 (no targets), 4 (at most 4 targets), 8.
    slots: u8,
    /// Skins after the morph (`crowd_skin.wgsl`'s entry points, a skinned asset).
    pub(super) skinned: bool,
}

impl Variant {
    /// The variant of an asset with or without a surface and with `targets` morph targets.
    /// An asset of at most 4 targets fills only slots 0..4 ([`InstanceBlock::set_weights`]
    /// keeps the nonzero weights in ascending target order), so the first 4 slots are its
    /// whole sum. A `skinned` variant draws with the same entry point's skinned twin.
    pub(super) fn new(path: CrowdPath, surface: bool, targets: usize, skinned: bool) -> Variant {
        Variant {
            path,
            surface,
            skinned,
            slots: match targets {
                0 => 0,
                1..=4 => 4,
                _ => WEIGHT_SLOTS as u8,
            },
        }
    }

    /// The vertex entry point: per path, surface and slots the unskinned one and its skinned
    /// twin.
    pub(super) fn entry_point(self) -> &'static str {
        use CrowdPath::{BaseVertex, FirstInstance};
        let [plain, skinned] = match (self.path, self.surface, self.slots) {
            (BaseVertex, true, 0) => ["vs_pull_surface", "vs_pull_surface_skinned"],
            (BaseVertex, true, 4) => [
                "vs_pull_surface_targets4",
                "vs_pull_surface_targets4_skinned",
            ],
            (BaseVertex, true, _) => [
                "vs_pull_surface_targets8",
                "vs_pull_surface_targets8_skinned",
            ],
            (BaseVertex, false, 0) => ["vs_pull_plain", "vs_pull_plain_skinned"],
            (BaseVertex, false, 4) => ["vs_pull_plain_targets4", "vs_pull_plain_targets4_skinned"],
            (BaseVertex, false, _) => ["vs_pull_plain_targets8", "vs_pull_plain_targets8_skinned"],
            (FirstInstance, true, 0) => ["vs_fetch_surface", "vs_fetch_surface_skinned"],
            (FirstInstance, true, 4) => [
                "vs_fetch_surface_targets4",
                "vs_fetch_surface_targets4_skinned",
            ],
            (FirstInstance, true, _) => [
                "vs_fetch_surface_targets8",
                "vs_fetch_surface_targets8_skinned",
            ],
            (FirstInstance, false, 0) => ["vs_fetch_plain", "vs_fetch_plain_skinned"],
            (FirstInstance, false, 4) => {
                ["vs_fetch_plain_targets4", "vs_fetch_plain_targets4_skinned"]
            }
            (FirstInstance, false, _) => {
                ["vs_fetch_plain_targets8", "vs_fetch_plain_targets8_skinned"]
            }
        };
        if self.skinned {
            skinned
        } else {
            plain
        }
    }

    /// The fragment entry point.
    fn fragment(self) -> &'static str {
        if self.surface {
            "fs_surface"
        } else {
            "fs_plain"
        }
    }
}

/// One shader module of a crowd with its bind group layout (group 0), its render pipelines'
/// layout and its probe: `crowd.wgsl`'s, and the skinned assets' (`crowd_skin.wgsl`).
pub(super) struct CrowdModule {
    pub(super) layout: wgpu::BindGroupLayout,
    render_layout: wgpu::PipelineLayout,
    shader: wgpu::ShaderModule,
    pub(super) probe: wgpu::ComputePipeline,
}

impl CrowdModule {
    /// `source` compiled with `entries` as group 0 and the probe's group 1; its probe
    /// `probe_entry`.
    fn new(
        device: &wgpu::Device,
        (label, source): (&str, &str),
        entries: &[wgpu::BindGroupLayoutEntry],
        probe_layout: &wgpu::BindGroupLayout,
        probe_entry: &str,
    ) -> CrowdModule {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries,
        });
        let render_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let probe = compute(
            device,
            label,
            &[&layout, probe_layout],
            &shader,
            probe_entry,
        );
        CrowdModule {
            layout,
            render_layout,
            shader,
            probe,
        }
    }
}

/// The pipelines and layouts a crowd draws and edits with. Render pipelines are made when the
/// first asset that needs their entry point is added, the skinned module with the first
/// skinned asset.
pub(super) struct CrowdPipeline {
    pub(super) plain: CrowdModule,
    skinned: Option<CrowdModule>,
    /// Colour and depth formats and culling every render pipeline of this crowd uses.
    formats: Formats,
    renders: Vec<(Variant, wgpu::RenderPipeline)>,
    pub(super) scatter: Scatter,
    /// `expand_tails` and its bind group's layout (jobs, tail lists, index slots).
    pub(super) tail_layout: wgpu::BindGroupLayout,
    pub(super) tail: wgpu::ComputePipeline,
    pub(super) probe_layout: wgpu::BindGroupLayout,
}

impl CrowdPipeline {
    pub(super) fn new(
        device: &wgpu::Device,
        color: wgpu::TextureFormat,
        depth: Option<wgpu::TextureFormat>,
        cull_mode: Option<wgpu::Face>,
    ) -> CrowdPipeline {
        let probe_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("crowd probe"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: wgpu::BufferSize::new(4),
                    },
                    count: None,
                },
                compute_storage(1, false, 4),
            ],
        });
        let plain = CrowdModule::new(
            device,
            ("crowd.wgsl", CROWD_WGSL),
            &crowd_entries(false),
            &probe_layout,
            "cs_positions",
        );
        let tail_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("crowd tails"),
            entries: &[
                compute_storage(0, true, size_of::<TailJob>() as u64),
                compute_storage(1, true, 4),
                compute_storage(2, false, 4),
            ],
        });
        let tail_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("tail.wgsl"),
            source: wgpu::ShaderSource::Wgsl(TAIL_WGSL.into()),
        });
        let tail = compute(
            device,
            "crowd tails",
            &[&tail_layout],
            &tail_module,
            "expand_tails",
        );
        CrowdPipeline {
            plain,
            skinned: None,
            formats: Formats {
                color,
                depth,
                cull_mode,
            },
            renders: Vec::new(),
            scatter: Scatter::new(device),
            tail_layout,
            tail,
            probe_layout,
        }
    }

    /// The module `variant` draws with (the skinned one made now if no skinned asset used it
    /// before).
    fn module_for(&mut self, device: &wgpu::Device, variant: Variant) -> &CrowdModule {
        if !variant.skinned {
            return &self.plain;
        }
        self.skinned.get_or_insert_with(|| {
            CrowdModule::new(
                device,
                ("crowd_skin.wgsl", CROWD_SKIN_WGSL),
                &crowd_entries(true),
                &self.probe_layout,
                "cs_skinned_positions",
            )
        })
    }

    /// The module of `variant`, made by [`render_for`](Self::render_for).
    pub(super) fn module(&self, variant: Variant) -> &CrowdModule {
        match (variant.skinned, &self.skinned) {
            (true, Some(skinned)) => skinned,
            _ => &self.plain,
        }
    }

    /// The number of `variant`'s render pipeline, made now if no asset used it before.
    pub(super) fn render_for(&mut self, device: &wgpu::Device, variant: Variant) -> usize {
        if let Some(at) = self.renders.iter().position(|(v, _)| *v == variant) {
            return at;
        }
        // The first-instance path fetches the poses (and surface) as attributes; the
        // base-vertex path has no vertex buffers (crowd.wgsl says why).
        let buffers = match variant.path {
            CrowdPath::FirstInstance => vertex_buffers(variant.surface),
            CrowdPath::BaseVertex => Vec::new(),
        };
        let formats = self.formats;
        let module = self.module_for(device, variant);
        let entry = variant.entry_point();
        let render = render_pipeline(
            device,
            &module.render_layout,
            &module.shader,
            (entry, entry, variant.fragment()),
            &buffers,
            wgpu::PrimitiveTopology::TriangleStrip,
            formats,
        );
        self.renders.push((variant, render));
        self.renders.len() - 1
    }

    /// Render pipeline number `at` (from [`render_for`](Self::render_for)).
    pub(super) fn render(&self, at: usize) -> &wgpu::RenderPipeline {
        &self.renders[at].1
    }
}

impl CrowdPipeline {
    /// The discrete-LOD renderer's pipeline: the crowd's shader (the skinned one for a
    /// skinned `variant`, made now if no asset used it before), bind group layout, formats
    /// and `variant`'s entry points and vertex buffers, over triangle lists. On the
    /// first-instance path the instance comes from `instance_index`, which a direct instanced
    /// draw sets on every device.
    pub(super) fn levels_pipeline(
        &mut self,
        device: &wgpu::Device,
        variant: Variant,
    ) -> wgpu::RenderPipeline {
        let entry = variant.entry_point();
        let formats = self.formats;
        let module = self.module_for(device, variant);
        render_pipeline(
            device,
            &module.render_layout,
            &module.shader,
            (entry, entry, variant.fragment()),
            &vertex_buffers(variant.surface),
            wgpu::PrimitiveTopology::TriangleList,
            formats,
        )
    }
}

fn compute(
    device: &wgpu::Device,
    label: &str,
    layouts: &[&wgpu::BindGroupLayout],
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().copied().map(Some).collect();
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// Bindings 0..=10 of `crowd.wgsl`'s group 0, and where `skinned` binding 11
/// (`crowd_skin.wgsl`'s `skin_data`).
fn crowd_entries(skinned: bool) -> Vec<wgpu::BindGroupLayoutEntry> {
    let all =
        wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let pulled = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE;
    let uniform = |binding, size: usize| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: all,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size as u64),
        },
        count: None,
    };
    // The smallest binding is one element: an instance block, or one f32.
    let storage = |binding, size: usize| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: pulled,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size as u64),
        },
        count: None,
    };
    let mut entries = vec![
        uniform(0, size_of::<SceneBlock>()),
        uniform(1, size_of::<MeshBlock>()),
        storage(2, size_of::<InstanceBlock>()),
    ];
    entries.extend((3..8).map(|binding| storage(binding, 4)));
    entries.extend(texture_entries(8));
    entries.push(storage(10, size_of::<PoseBlock>()));
    if skinned {
        entries.push(storage(11, 16));
    }
    entries
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::pipeline::validated_wgsl;

    /// The crowd's shaders parse and validate without a GPU, the Rust blocks have the WGSL
    /// structs' sizes, and every entry point a crowd may pick is there (the skinned ones in
    /// the skinned module).
    #[test]
    fn crowd_wgsl_validates_and_blocks_match() {
        let crowd = validated_wgsl(CROWD_WGSL);
        let skinned = validated_wgsl(CROWD_SKIN_WGSL);
        validated_wgsl(SCATTER_WGSL);
        let tail = validated_wgsl(TAIL_WGSL);
        let job = tail
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some("Job"));
        match job.map(|(_, ty)| &ty.inner) {
            Some(naga::TypeInner::Struct { span, .. }) => {
                assert_eq!(*span as usize, size_of::<TailJob>())
            }
            _ => panic!("tail.wgsl has no struct Job"),
        }
        let size = |name: &str| {
            let (_, ty) = crowd
                .types
                .iter()
                .find(|(_, ty)| ty.name.as_deref() == Some(name))
                .unwrap_or_else(|| panic!("crowd.wgsl has no struct {name}"));
            match ty.inner {
                naga::TypeInner::Struct { span, .. } => span as usize,
                _ => panic!("{name} is not a struct"),
            }
        };
        assert_eq!(size("Scene"), size_of::<SceneBlock>());
        assert_eq!(size("Mesh"), size_of::<MeshBlock>());
        assert_eq!(size("Placement"), size_of::<InstanceBlock>());
        // The placement's members where the Rust block has them (the normal matrix a padded
        // mat3x3, the motion after it).
        let placement = crowd
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some("Placement"));
        let Some(naga::TypeInner::Struct { members, .. }) = placement.map(|(_, ty)| &ty.inner)
        else {
            panic!("crowd.wgsl has no struct Placement");
        };
        let offsets: Vec<(&str, usize)> = (members.iter())
            .map(|m| (m.name.as_deref().unwrap_or(""), m.offset as usize))
            .collect();
        assert_eq!(
            offsets,
            [
                ("model", std::mem::offset_of!(InstanceBlock, model)),
                (
                    "normal_model",
                    std::mem::offset_of!(InstanceBlock, normal_model)
                ),
                ("motion", std::mem::offset_of!(InstanceBlock, motion)),
                ("color", std::mem::offset_of!(InstanceBlock, color)),
            ]
        );
        assert_eq!(size("Pose"), size_of::<PoseBlock>());
        // Every variant's vertex entry point exists.
        let cases = [CrowdPath::FirstInstance, CrowdPath::BaseVertex]
            .into_iter()
            .flat_map(|path| [false, true].map(|surface| (path, surface)))
            .flat_map(|(path, surface)| [0, 3, 4, 5, 8].map(|targets| (path, surface, targets)));
        for (path, surface, targets) in cases {
            for (skin, module) in [(false, &crowd), (true, &skinned)] {
                let variant = Variant::new(path, surface, targets, skin);
                for (entry, stage) in [
                    (variant.entry_point(), naga::ShaderStage::Vertex),
                    (variant.fragment(), naga::ShaderStage::Fragment),
                ] {
                    assert!(
                        module
                            .entry_points
                            .iter()
                            .any(|e| e.name == entry && e.stage == stage),
                        "the crowd's shader has no {stage:?} entry point {entry}"
                    );
                }
            }
        }
        assert!(skinned
            .entry_points
            .iter()
            .any(|e| e.name == "cs_skinned_positions"));
    }

    #[test]
    fn weight_slots_keep_the_largest_in_target_order() {
        let mut block = PoseBlock::default();
        block.set_weights(&[0.0, 0.5, 0.0, -0.25]);
        assert_eq!(block.weights[..3], [0.5, -0.25, 0.0]);
        assert_eq!(block.targets, [1 | (3 << 8), 0]);
        // Ten targets: the two smallest magnitudes (targets 0 and 9) are dropped.
        let weights: Vec<f32> = (0..10)
            .map(|k| match k {
                0 => 0.01,
                9 => -0.02,
                k => k as f32,
            })
            .collect();
        block.set_weights(&weights);
        assert_eq!(block.weights, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        assert_eq!(
            block.targets,
            [
                1 | 2 << 8 | 3 << 16 | 4 << 24,
                5 | 6 << 8 | 7 << 16 | 8 << 24
            ]
        );
    }
}
