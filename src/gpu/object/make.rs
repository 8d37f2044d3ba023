//! An object made: its poses (or a shared asset), the regions laid out with their
//! separators, the index and indirect buffers, the pose and the scatter.

use std::sync::Arc;

use wgpu::util::{BufferInitDescriptor, DeviceExt, DrawIndexedIndirectArgs};

use super::{separator_slots, Object, ObjectScatter, Topology};
use crate::asset::{Asset, Surface};
use crate::gpu::asset::GpuAsset;
use crate::gpu::checks::{check_indices, check_size};
use crate::gpu::pipeline::MorphPipeline;
use crate::gpu::pose::{default_mode, Pose};
use crate::gpu::records::{DrawRecords, ARGS_BYTES};
use crate::gpu::scatter::Scatter;
use crate::gpu::upload::IndexMirror;
use crate::gpu::{Draws, GpuError, GROUP_INDICES, RESTART};

impl Object {
    /// Uploads the poses and the full-detail strips; region `r` gets capacity and initial live
    /// contents `regions[r]`.
    ///
    /// Every index must name a vertex (`< v0.len()`), or be [`super::RESTART`] in a
    /// [`Topology::Strip`] object. Strip objects start with [`Draws::Grouped`] at
    /// [`GROUP_INDICES`], list objects draw per region. The device's
    /// `INDIRECT_FIRST_INSTANCE` feature decides whether each record carries its number as
    /// `first_instance`.
    pub fn new(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        v0: &[[f32; 3]],
        v1: &[[f32; 3]],
        regions: &[Vec<u32>],
    ) -> Result<Object, GpuError> {
        let asset = GpuAsset::new(device, (v0, v1), None)?;
        Object::make(device, pipeline, topology, Arc::new(asset), regions)
    }

    /// As [`Object::new`], with `surface`'s normals, UVs, colours and material (one entry per
    /// vertex of `v0`, finite: [`GpuError::SurfaceLength`], [`GpuError::NonFiniteAttribute`]
    /// otherwise). The texture is decoded here ([`GpuError::TextureDecode`] when it does not
    /// decode: clear `material.texture` to draw the surface untextured) and uploaded by the first
    /// [`prepare`](Self::prepare). The object starts in
    /// [`ShadeMode::Textured`](crate::gpu::ShadeMode::Textured) when the material has a texture,
    /// [`ShadeMode::Smooth`](crate::gpu::ShadeMode::Smooth) otherwise. Normal deltas of morph
    /// targets go with [`set_targets_with_normals`](Self::set_targets_with_normals).
    pub fn with_surface(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        (v0, v1): (&[[f32; 3]], &[[f32; 3]]),
        regions: &[Vec<u32>],
        surface: &Surface,
    ) -> Result<Object, GpuError> {
        let asset = GpuAsset::new(device, (v0, v1), Some(surface))?;
        Object::make(device, pipeline, topology, Arc::new(asset), regions)
    }

    /// An object drawing `asset`'s poses over `regions`, with its surface and its morph targets
    /// (position and normal deltas) when it has them: what
    /// [`super::LodObject`](crate::gpu::LodObject) and the benchmark draw an asset with. Pose it
    /// with [`set_pose`](Self::set_pose) and the asset's weight track.
    pub fn from_asset(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        asset: &Asset,
        regions: &[Vec<u32>],
    ) -> Result<Object, GpuError> {
        let shared = GpuAsset::from_asset(device, asset)?;
        Object::with_asset(device, pipeline, topology, shared, regions)
    }

    /// An object over an asset already on the GPU ([`GpuAsset::from_asset`]), sharing its
    /// poses, surface and morph-target deltas with every other object made from it: the object
    /// owns only its index and indirect buffers, its uniforms and (with targets) the offsets
    /// it sums. An asset of another device is [`GpuError::OtherDevice`].
    pub fn with_asset(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        asset: Arc<GpuAsset>,
        regions: &[Vec<u32>],
    ) -> Result<Object, GpuError> {
        if !asset.is_on(device) {
            return Err(GpuError::OtherDevice);
        }
        let mut object = Object::make(device, pipeline, topology, Arc::clone(&asset), regions)?;
        if let Some(deltas) = asset.targets() {
            object
                .pose
                .share_targets(device, pipeline, Arc::clone(deltas), &asset);
        }
        Ok(object)
    }

    fn make(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        topology: Topology,
        asset: Arc<GpuAsset>,
        regions: &[Vec<u32>],
    ) -> Result<Object, GpuError> {
        let vertex_count = asset.vertex_count();
        let separator = separator_slots(topology);
        let total: usize = regions.iter().map(|r| r.len() + separator as usize).sum();
        let max_buffer = device.limits().max_buffer_size;
        check_size("index", total as u64 * 4, max_buffer)?;
        check_size("indirect", regions.len() as u64 * ARGS_BYTES, max_buffer)?;
        // first_index is a u32, so every region must start below 2^32 indices.
        if total > u32::MAX as usize {
            return Err(GpuError::BufferTooLarge {
                what: "index",
                bytes: total as u64 * 4,
                max: u64::from(u32::MAX) * 4,
            });
        }

        let mut region_starts = Vec::with_capacity(regions.len() + 1);
        let mut lengths = Vec::with_capacity(regions.len());
        let mut indices = Vec::with_capacity(total);
        region_starts.push(0);
        for (region, strip) in regions.iter().enumerate() {
            check_indices(region, strip, vertex_count, topology == Topology::Strip)?;
            indices.extend_from_slice(strip);
            if topology == Topology::Strip {
                indices.push(RESTART);
            }
            lengths.push(strip.len() as u32);
            region_starts.push(indices.len() as u32);
        }

        let draws = match topology {
            Topology::Strip => Draws::Grouped {
                max_indices: GROUP_INDICES,
            },
            Topology::List => Draws::PerRegion,
        };
        let first_instance = device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE);
        let records = DrawRecords::new(&region_starts, &lengths, draws, first_instance);

        // wgpu cannot bind an empty index buffer; an object without regions gets one unused
        // index so its (empty) multi-draw stays valid.
        let index_contents: &[u32] = if indices.is_empty() { &[0] } else { &indices };
        let index_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod indices"),
            contents: bytemuck::cast_slice(index_contents),
            // STORAGE: the scatter patches it; COPY_SRC: tests and tools can copy the buffer
            // back to check what the GPU holds.
            usage: wgpu::BufferUsages::INDEX
                | wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        });
        // Room for one record per region, the most any grouping needs (and at least one:
        // wgpu cannot bind an empty buffer); records past the ones drawn stay zero.
        let mut args_contents = records.args.clone();
        args_contents.resize(regions.len().max(1), DrawIndexedIndirectArgs::default());
        let indirect_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod indirect draws"),
            contents: bytemuck::cast_slice(&args_contents),
            usage: wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        });
        let variants = asset.is_skinned().then(|| pipeline.skinned(device));
        let render_pipeline = match (topology, asset.has_surface(), variants) {
            (Topology::Strip, false, None) => pipeline.strip().clone(),
            (Topology::List, false, None) => pipeline.list().clone(),
            (Topology::Strip, true, None) => pipeline.surface_strip().clone(),
            (Topology::List, true, None) => pipeline.surface_list().clone(),
            (topology, surface, Some(skinned)) => {
                let variant = if surface {
                    &skinned.surface
                } else {
                    &skinned.plain
                };
                match topology {
                    Topology::Strip => variant.strip.clone(),
                    Topology::List => variant.list.clone(),
                }
            }
        };
        let pose = Pose::new(device, pipeline, &asset);
        let fits = index_buffer.size() <= device.limits().max_storage_buffer_binding_size;
        let scatter = ObjectScatter {
            device: device.clone(),
            scatter: pipeline.scatter().clone(),
            max_list_bytes: if fits {
                Scatter::max_run_list_bytes(device)
            } else {
                0
            },
            patch_buffer: None,
            list: Vec::new(),
        };
        Ok(Object {
            pipeline: render_pipeline,
            topology,
            vertex_count,
            shade: default_mode(asset.surface()),
            asset,
            index_buffer,
            indirect_buffer,
            region_starts,
            lengths,
            draws,
            mirror: IndexMirror::new(indices),
            records,
            pose,
            scatter,
        })
    }
}
