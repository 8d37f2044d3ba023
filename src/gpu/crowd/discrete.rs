//! The crowd bench's comparison: discrete LODs, what an engine does with `morphlod export`'s
//! output. A few levels of one collapse sequence shared by every pose (the export's: full
//! detail and the first step boundaries at ½, ¼ and ⅒ of the triangles), each instance
//! drawing the coarsest level whose error is within its LOD, the instances grouped per level
//! and drawn with one instanced `draw_indexed` per level; the morph is blended on the GPU by
//! the crowd's own vertex stage on its fast path (the first-instance entry points of
//! `shaders/crowd.wgsl`: poses and surface fetched as vertex buffers, the asset's number of
//! weight slots, `fs_plain` without a surface), reading the same shared [`GpuAsset`]. A
//! skinned asset is skinned there too (`shaders/crowd_skin.wgsl`, from the asset's baked
//! clip at each instance's phase): what Bevy, Unity and Unreal do with a skinned character.
//!
//! The instance reaches the vertex stage as `instance_index` (its block's number in the
//! level-sorted instance buffer): a direct draw keeps `first_instance` on every device, only
//! indirect draws need `INDIRECT_FIRST_INSTANCE` for it. The renderer is a benchmark's, not a general one: a
//! fixed list of instances of one asset, no adds or removes.

use std::ops::Range;
use std::sync::Arc;

use crate::par;
use thiserror::Error;
use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::add::mesh_buffer;
use super::cull::{outside, Frustum};
use super::pipeline::{InstanceBlock, PoseBlock, Variant};
use super::types::check_finite;
use super::{Crowd, CrowdError, CrowdPath, CrowdUpload};
use crate::asset::Asset;
use crate::collapse::CollapseSequence;
use crate::deform::{Lod, SetError};
use crate::gpu::pose::clamp_t;
use crate::gpu::{GpuAsset, GpuError};
use crate::seams::{step_for_error, step_for_fraction, StepBoundaries};

/// Why discrete levels could not be made.
#[derive(Debug, Error, PartialEq)]
pub enum LevelsError {
    /// Per-frame sequences: no one connectivity serves every pose.
    #[error("the asset has {distinct} different collapse sequences over its frames; discrete levels need one shared by every pose (the export's): build it with `--sequence shared`")]
    NotShared { distinct: usize },
    /// Fractions outside (0, 1) or not strictly decreasing.
    #[error(
        "level fractions must be in (0, 1) and strictly decreasing, as `export --lods`; got {0:?}"
    )]
    Fractions(Vec<f32>),
    /// Error bounds that are not positive and finite.
    #[error("level error bounds must be positive and finite distances; got {0:?}")]
    Errors(Vec<f32>),
    /// A level with no triangle left.
    #[error("the level at {fraction} of {triangles} triangles keeps none; ask a larger fraction")]
    Empty { fraction: f32, triangles: usize },
}

/// One discrete level.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscreteLevel {
    /// The fraction of the full triangles asked (1 for full detail).
    pub fraction: f32,
    /// Its step in the shared sequence (a step boundary).
    pub step: usize,
    /// Its error as a distance: the square root of the sequence's largest collapse error up
    /// to `step`, what the runtime compares a [`Lod::MaxError`] with.
    pub error: f32,
    /// The reference mesh at `step`, over the asset's vertices.
    pub triangles: Vec<[u32; 3]>,
}

/// The one collapse sequence of an asset built with one sequence for every pose
/// (`--sequence shared`, the export's), with the triangles and topology its levels are cut
/// from.
#[derive(Clone, Debug)]
pub struct SharedSequence {
    sequence: Arc<CollapseSequence>,
    triangles: Vec<[u32; 3]>,
    topology: Option<Vec<u32>>,
}

impl SharedSequence {
    /// The asset's one sequence, over its `S0`'s triangles; [`LevelsError::NotShared`] where
    /// its frames have several.
    pub fn from_asset(asset: &Asset) -> Result<SharedSequence, LevelsError> {
        let mut distinct: Vec<&Arc<CollapseSequence>> = Vec::new();
        for frame in &asset.frames {
            if !distinct
                .iter()
                .any(|d| Arc::ptr_eq(d, frame) || **d == *frame)
            {
                distinct.push(frame);
            }
        }
        let [sequence] = distinct[..] else {
            return Err(LevelsError::NotShared {
                distinct: distinct.len(),
            });
        };
        Ok(SharedSequence {
            sequence: Arc::clone(sequence),
            triangles: asset.s0.triangles(),
            topology: asset.surface.as_ref().map(|s| s.topology.clone()),
        })
    }

    /// Its levels at `fractions` ([`DiscreteLevels::new`]).
    pub fn levels(&self, fractions: &[f32]) -> Result<DiscreteLevels, LevelsError> {
        let topology = self.topology.as_deref();
        DiscreteLevels::new(&self.sequence, &self.triangles, topology, fractions)
    }

    /// Its levels within error `bounds` ([`DiscreteLevels::within`]).
    pub fn levels_within(&self, bounds: &[f32]) -> Result<DiscreteLevels, LevelsError> {
        let topology = self.topology.as_deref();
        DiscreteLevels::within(&self.sequence, &self.triangles, topology, bounds)
    }
}

/// `sequence`'s step boundaries by `topology` (`None`: every step is one), handed to `f`.
fn with_boundaries<T>(
    sequence: &CollapseSequence,
    topology: Option<&[u32]>,
    f: impl FnOnce(&StepBoundaries) -> T,
) -> T {
    let identity: Vec<u32>;
    let of_vertex = match topology {
        Some(map) => map,
        None => {
            identity = (0..sequence.vertex_count).collect();
            &identity
        }
    };
    f(&StepBoundaries::new(sequence, of_vertex))
}

/// The levels of discrete LODs, finest first.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscreteLevels {
    levels: Vec<DiscreteLevel>,
    /// Collapses of the sequence (where `Lod::Fraction(1)` lands).
    max_step: usize,
}

impl DiscreteLevels {
    /// The fractions `morphlod export` writes by default below the full mesh.
    pub const FRACTIONS: [f32; 3] = [0.5, 0.25, 0.1];

    /// Full detail and, per fraction, the first step boundary of `sequence` whose reference
    /// mesh of `triangles` has at most that share of them (as `morphlod export --lods`).
    /// `topology` is the asset's topology map (step boundaries keep seams closed); `None`:
    /// every step is a boundary.
    pub fn new(
        sequence: &CollapseSequence,
        triangles: &[[u32; 3]],
        topology: Option<&[u32]>,
        fractions: &[f32],
    ) -> Result<DiscreteLevels, LevelsError> {
        let ordered = fractions.windows(2).all(|w| w[0] > w[1]);
        if !ordered || fractions.iter().any(|&f| !(f > 0.0 && f < 1.0)) {
            return Err(LevelsError::Fractions(fractions.to_vec()));
        }
        with_boundaries(sequence, topology, |boundaries| {
            let steps = fractions.iter().map(|&fraction| {
                (
                    fraction,
                    step_for_fraction(sequence, boundaries, triangles, fraction),
                )
            });
            DiscreteLevels::at_steps(sequence, triangles, steps)
        })
    }

    /// Full detail and, per error bound (a distance, as [`DiscreteLevel::error`]), the
    /// coarsest step boundary of `sequence` whose error is within it (as `morphlod export
    /// --error`, and gltfpack's `-si` chains): the levels a scene that needs those errors
    /// draws. Bounds in any order; levels that land on one step are one level.
    pub fn within(
        sequence: &CollapseSequence,
        triangles: &[[u32; 3]],
        topology: Option<&[u32]>,
        bounds: &[f32],
    ) -> Result<DiscreteLevels, LevelsError> {
        if bounds.iter().any(|&e| !(e > 0.0 && e.is_finite())) {
            return Err(LevelsError::Errors(bounds.to_vec()));
        }
        with_boundaries(sequence, topology, |boundaries| {
            let errors = sequence.errors();
            let mut steps: Vec<usize> = (bounds.iter())
                .map(|&bound| step_for_error(&errors, boundaries, bound))
                .filter(|&step| step > 0)
                .collect();
            steps.sort_unstable();
            steps.dedup();
            let fraction = |step: usize| {
                let kept = sequence.reference_mesh(triangles, step).len();
                kept as f32 / triangles.len().max(1) as f32
            };
            let levels = steps.into_iter().map(|step| (fraction(step), step));
            DiscreteLevels::at_steps(sequence, triangles, levels)
        })
    }

    /// Full detail and the levels at `steps` (each with the fraction it stands for).
    fn at_steps(
        sequence: &CollapseSequence,
        triangles: &[[u32; 3]],
        steps: impl Iterator<Item = (f32, usize)>,
    ) -> Result<DiscreteLevels, LevelsError> {
        let errors = sequence.errors();
        let mut levels = Vec::new();
        for (fraction, step) in std::iter::once((1.0, 0)).chain(steps) {
            let mesh = sequence.reference_mesh(triangles, step);
            if mesh.is_empty() {
                return Err(LevelsError::Empty {
                    fraction,
                    triangles: triangles.len(),
                });
            }
            levels.push(DiscreteLevel {
                fraction,
                step,
                error: errors[step].max(0.0).sqrt(),
                triangles: mesh,
            });
        }
        Ok(DiscreteLevels {
            levels,
            max_step: sequence.len(),
        })
    }

    /// The levels of an asset built with one sequence for every frame (`--sequence shared`,
    /// the export's), over its `S0`'s triangles.
    pub fn from_asset(asset: &Asset, fractions: &[f32]) -> Result<DiscreteLevels, LevelsError> {
        SharedSequence::from_asset(asset)?.levels(fractions)
    }

    /// The levels, finest (full detail) first.
    pub fn levels(&self) -> &[DiscreteLevel] {
        &self.levels
    }

    /// The level an instance at `lod` draws, mapped as the runtime maps a LOD onto a frame's
    /// steps: `MaxError(e)` the coarsest level whose error is at most `e` (full detail when
    /// `e < 0`), `Steps(l)` and `Fraction(f)` the coarsest level at or below that step,
    /// `Triangles(n)` the finest level within `n` triangles (the coarsest if none is). NaN is
    /// refused.
    pub fn level_for(&self, lod: Lod) -> Result<usize, SetError> {
        let coarsest = |within: &dyn Fn(&DiscreteLevel) -> bool| {
            // Full detail (error 0, step 0) is within every bound that is not negative.
            self.levels.iter().rposition(within).unwrap_or(0)
        };
        let steps = |l: usize| coarsest(&|level| level.step <= l);
        Ok(match lod {
            Lod::MaxError(e) | Lod::Fraction(e) if e.is_nan() => return Err(SetError::LodNaN(lod)),
            Lod::MaxError(e) => coarsest(&|level| level.error <= e),
            Lod::Steps(l) => steps(l),
            Lod::Fraction(f) => steps((f.clamp(0.0, 1.0) * self.max_step as f32).round() as usize),
            Lod::Triangles(n) => self
                .levels
                .iter()
                .position(|level| level.triangles.len() <= n)
                .unwrap_or(self.levels.len() - 1),
        })
    }
}

/// Instances of one asset drawn as discrete LODs (module docs): `set` per frame, `prepare`,
/// `render`.
pub struct DiscreteCrowd {
    /// The scene block, white texel, pipelines and bind group layout, shared with the crowd
    /// (it holds no asset).
    base: Crowd,
    pipeline: wgpu::RenderPipeline,
    gpu: Arc<GpuAsset>,
    levels: DiscreteLevels,
    /// Every level's triangles, one after the other.
    index_buffer: wgpu::Buffer,
    /// Index range of each level in `index_buffer`.
    ranges: Vec<Range<u32>>,
    /// The placements and poses, grouped by level, on the GPU.
    instance_buffers: (wgpu::Buffer, wgpu::Buffer),
    bind_group: wgpu::BindGroup,
    /// Per instance, in the caller's order: its placement, pose and level (none: out of
    /// view).
    own: Vec<(InstanceBlock, PoseBlock)>,
    chosen: Vec<Option<usize>>,
    /// Whether instances out of view draw nothing (as a crowd's, `Crowd::set_culling`).
    culling: bool,
    /// The placements and poses grouped by level, as uploaded; level `l`'s are
    /// `first[l]..first[l + 1]`.
    grouped: (Vec<InstanceBlock>, Vec<PoseBlock>),
    first: Vec<u32>,
    dirty: bool,
}

impl DiscreteCrowd {
    /// One instance per transform (finite), at full detail and time 0, drawing `levels` of
    /// `gpu` into passes of `color_format` and `depth_format`, back faces culled.
    pub fn new(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        depth_format: Option<wgpu::TextureFormat>,
        gpu: Arc<GpuAsset>,
        levels: DiscreteLevels,
        transforms: &[glam::Mat4],
    ) -> Result<DiscreteCrowd, CrowdError> {
        if !gpu.is_on(device) {
            return Err(GpuError::OtherDevice.into());
        }
        let n = gpu.vertex_count();
        let needed = levels
            .levels
            .iter()
            .flat_map(|l| l.triangles.iter().flatten())
            .max()
            .map_or(0, |&v| v + 1);
        if needed > n {
            return Err(CrowdError::ModelMismatch {
                model: needed as usize,
                asset: n,
            });
        }
        let capacity = transforms.len() as u32;
        let block_bytes = u64::from(capacity) * size_of::<InstanceBlock>() as u64;
        if capacity == 0 || block_bytes > device.limits().max_storage_buffer_binding_size {
            return Err(CrowdError::Capacity {
                capacity,
                why: format!(
                    "give 1 to {} transforms",
                    device.limits().max_storage_buffer_binding_size
                        / size_of::<InstanceBlock>() as u64
                ),
            });
        }
        let mut own = Vec::with_capacity(transforms.len());
        for model in transforms {
            check_finite("transform", &model.to_cols_array())?;
            own.push((InstanceBlock::new(*model), PoseBlock::default()));
        }
        let mut base = Crowd::new(device, color_format, depth_format);
        // The crowd's fast path (fixed-function fetch, the asset's weight slots), whatever
        // the device: direct draws carry the first instance everywhere. A skinned asset is
        // skinned by the crowd's skinned twin of it, from the same baked clip: the engine way
        // (discrete levels, instanced, GPU skinning).
        let variant = Variant::new(
            CrowdPath::FirstInstance,
            gpu.has_surface(),
            gpu.target_count(),
            gpu.is_skinned(),
        );
        let pipeline = base.pipeline.levels_pipeline(device, variant);
        let mut indices: Vec<u32> = Vec::new();
        let mut ranges = Vec::with_capacity(levels.levels.len());
        for level in &levels.levels {
            let start = indices.len() as u32;
            indices.extend(level.triangles.iter().flatten());
            ranges.push(start..indices.len() as u32);
        }
        let index_buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("discrete levels"),
            contents: bytemuck::cast_slice(&indices),
            // COPY_SRC: tests read the levels back.
            usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_SRC,
        });
        let [placements, poses] = [
            ("discrete placements", size_of::<InstanceBlock>()),
            ("discrete poses", size_of::<PoseBlock>()),
        ]
        .map(|(label, size)| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: u64::from(capacity) * size as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        let mesh = mesh_buffer(device, &gpu);
        let bind_group = base.bind_group(device, (&gpu, variant), &mesh, (&placements, &poses));
        let mut first = vec![capacity; levels.levels.len() + 1];
        first[0] = 0;
        Ok(DiscreteCrowd {
            base,
            pipeline,
            gpu,
            levels,
            index_buffer,
            ranges,
            instance_buffers: (placements, poses),
            bind_group,
            grouped: own.iter().copied().unzip(),
            chosen: vec![Some(0); own.len()],
            culling: true,
            own,
            first,
            dirty: true,
        })
    }

    /// Sets projection * view for every instance.
    pub fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.base.set_view_proj(view_proj);
    }

    /// Whether an instance out of view draws nothing (default: on), tested as a crowd tests
    /// it ([`Crowd::set_culling`]) by each `set` against the view of the last
    /// [`set_view_proj`](Self::set_view_proj).
    pub fn set_culling(&mut self, on: bool) {
        self.culling = on;
    }

    /// Moves instance `i` to `moves[i]` (as [`Crowd::set`]: `t` clamped, the pose from the
    /// asset's weight track or `mix(V(0), V(1), t)`; the level by
    /// [`DiscreteLevels::level_for`]), instances past the end of `moves` stay as they are,
    /// leaves out the instances out of view (where culling is on) and groups the others per
    /// level. Checked first: on error nothing moved.
    pub fn set(&mut self, moves: &[(f32, Lod)]) -> Result<(), CrowdError> {
        if moves.len() > self.own.len() {
            return Err(CrowdError::Capacity {
                capacity: self.own.len() as u32,
                why: format!("{} moves for as many instances", moves.len()),
            });
        }
        let mut levels = Vec::with_capacity(moves.len());
        for &(t, lod) in moves {
            clamp_t(t)?;
            levels.push(self.levels.level_for(lod)?);
        }
        let track = self.gpu.track();
        let view_proj = glam::Mat4::from_cols_array_2d(&self.base.scene.view_proj);
        let frustum = (self.culling).then(|| Frustum::new(view_proj, self.base.scene.clock));
        let reach = (self.gpu.targets()).map_or(&[][..], |targets| targets.reach.as_slice());
        // A skinned asset's bound holds its poses skinned at every baked key.
        let (bound, reach) = (self.gpu.bound(), (reach, self.gpu.stretch()));
        // In pieces, a few a thread (the calling thread takes pieces too): the poses, then
        // which instances are out of view.
        let per = par::piece_len(moves.len(), 64);
        let parts: Vec<_> = (self.own.chunks_mut(per))
            .zip(self.chosen.chunks_mut(per))
            .zip(moves.chunks(per).zip(levels.chunks(per)))
            .collect();
        par::map(parts, |((own, chosen), (moves, levels))| {
            let mut weights = Vec::new();
            let each = own.iter_mut().zip(chosen).zip(moves.iter().zip(levels));
            for (((block, pose), chosen), (&(t, _), &level)) in each {
                pose.set_pose(track, clamp_t(t).expect("checked time"), &mut weights);
                let hidden = frustum
                    .as_ref()
                    .is_some_and(|f| outside(f, (block, pose), bound, reach));
                *chosen = (!hidden).then_some(level);
            }
        });
        // A counting sort: the blocks of level l at first[l]..first[l + 1].
        let mut at = vec![0u32; self.levels.levels.len() + 1];
        for &l in self.chosen.iter().flatten() {
            at[l + 1] += 1;
        }
        for l in 1..at.len() {
            at[l] += at[l - 1];
        }
        self.first.copy_from_slice(&at);
        for (&(block, pose), &l) in self.own.iter().zip(&self.chosen) {
            if let Some(l) = l {
                self.grouped.0[at[l] as usize] = block;
                self.grouped.1[at[l] as usize] = pose;
                at[l] += 1;
            }
        }
        self.dirty = true;
        Ok(())
    }

    /// Uploads the scene block and, when they changed, every instance block (one write).
    pub fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> CrowdUpload {
        let mut upload = self.base.prepare(device, queue);
        let texture = self.gpu.upload(queue);
        upload.bytes += texture;
        upload.writes += usize::from(texture > 0);
        if std::mem::take(&mut self.dirty) {
            let (placements, poses) = &self.instance_buffers;
            upload.write(queue, placements, 0, bytemuck::cast_slice(&self.grouped.0));
            upload.write(queue, poses, 0, bytemuck::cast_slice(&self.grouped.1));
        }
        upload
    }

    /// Draws every instance: one bind group, one index buffer, one instanced `draw_indexed`
    /// per level that has instances.
    pub fn render(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.gpu.v0().slice(..));
        pass.set_vertex_buffer(1, self.gpu.v1().slice(..));
        if let Some(surface) = self.gpu.surface() {
            pass.set_vertex_buffer(2, surface.buffer.slice(..));
        }
        pass.set_index_buffer(self.index_buffer.slice(..), wgpu::IndexFormat::Uint32);
        for (l, range) in self.ranges.iter().enumerate() {
            let instances = self.first[l]..self.first[l + 1];
            if !instances.is_empty() {
                pass.draw_indexed(range.clone(), 0, instances);
            }
        }
    }

    /// The levels drawn.
    pub fn levels(&self) -> &DiscreteLevels {
        &self.levels
    }

    /// Each instance's level, in the order of the transforms (none: out of view).
    pub fn instance_levels(&self) -> &[Option<usize>] {
        &self.chosen
    }

    /// The index buffer (`COPY_SRC`): level `l`'s triangles at [`level_ranges`](Self::level_ranges)`[l]`.
    pub fn index_buffer(&self) -> &wgpu::Buffer {
        &self.index_buffer
    }

    /// Each level's range of indices in the index buffer.
    pub fn level_ranges(&self) -> &[Range<u32>] {
        &self.ranges
    }

    /// Triangles drawn: each instance's in view, its level's.
    pub fn triangles(&self) -> usize {
        (self.chosen.iter().flatten())
            .map(|&l| self.levels.levels[l].triangles.len())
            .sum()
    }

    /// GPU bytes it draws from: the levels' indices, the instances' placements and poses,
    /// the asset.
    pub fn gpu_bytes(&self) -> u64 {
        let (placements, poses) = &self.instance_buffers;
        self.index_buffer.size() + placements.size() + poses.size() + self.gpu.gpu_bytes()
    }

    /// Draw calls `render` issues: the levels with instances.
    pub fn draws(&self) -> usize {
        self.first.windows(2).filter(|w| w[1] > w[0]).count()
    }
}
