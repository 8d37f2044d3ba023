//! How the object is posed and shaded: `t`, view, morph targets and their weights, the
//! transform, colour, light and shade mode.

use super::Object;
use crate::gpu::pipeline::{MorphPipeline, ShadeMode};
use crate::gpu::skin_probe::{probe, SkinnedPose};
use crate::gpu::GpuError;
use crate::morph::WeightTrack;

impl Object {
    /// Sets the blend parameter between `V(0)` (`t = 0`) and `V(1)` (`t = 1`), clamped to
    /// `[0, 1]` as the CPU runtime clamps it. NaN is [`GpuError::TimeNaN`] and changes nothing.
    pub fn set_t(&mut self, t: f32) -> Result<(), GpuError> {
        self.pose.set_t(t)
    }

    /// Sets the clip's phase of a skinned asset (`t ∈ [0, 1]`, clamped: the clip's time
    /// `t · duration`; NaN is [`GpuError::TimeNaN`]): the vertex stage blends the two baked
    /// keys around it (`docs/DESIGN.md`, "The GPU layout"). An unskinned object ignores it.
    pub fn set_clip_t(&mut self, t: f32) -> Result<(), GpuError> {
        self.pose.set_clip_t(t)
    }

    /// What the vertex stage of this skinned object computes for every vertex as of the last
    /// [`prepare`](Self::prepare) (object space, before the model transform): the same WGSL
    /// functions run in a compute pass over `V(0)`, `V(1)` and the surface, read back. How
    /// tests check the GPU's skinning against the CPU's ([`crate::skin::Skinning::pose_at`]);
    /// it waits for the GPU. `pipeline` is the one the object was made with; an object whose
    /// asset is not skinned is [`GpuError::NotSkinned`].
    pub fn skinned_pose(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &MorphPipeline,
    ) -> Result<SkinnedPose, GpuError> {
        if !self.asset.is_skinned() {
            return Err(GpuError::NotSkinned);
        }
        let pipelines = pipeline.skinned(device);
        probe(
            device,
            queue,
            pipelines,
            &self.asset,
            self.pose.bind_group(),
        )
    }

    /// Sets projection * view (world to clip space; wgpu clip space: z in [0, 1], y up).
    pub fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.pose.set_view_proj(view_proj);
    }

    /// Sets morph targets (one delta per vertex each) added to the blended pose with the
    /// weights of [`set_target_weights`](Self::set_target_weights), all 0 until then; an empty
    /// slice removes them. The object keeps the deltas on the CPU and the GPU holds one offset
    /// per vertex (12 bytes), re-summed and uploaded by `prepare` when the weights change.
    /// `pipeline` must be the one the object was made with. Nothing changes when an error is
    /// returned.
    pub fn set_targets(
        &mut self,
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        targets: &[Vec<[f32; 3]>],
    ) -> Result<(), GpuError> {
        self.pose
            .set_targets(device, pipeline, targets, &[], &self.asset)
    }

    /// As [`set_targets`](Self::set_targets), with each target's normal deltas (`normals`
    /// empty, or one array per target of one delta per vertex, on an object with a surface):
    /// the smooth modes draw `normalize(n0 + Σ_k w_k dN_k)`, the offsets summed on the CPU
    /// like the positions' (12 more bytes per vertex uploaded when the weights change).
    pub fn set_targets_with_normals(
        &mut self,
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        targets: &[Vec<[f32; 3]>],
        normals: &[Vec<[f32; 3]>],
    ) -> Result<(), GpuError> {
        self.pose
            .set_targets(device, pipeline, targets, normals, &self.asset)
    }

    /// Sets the pose at animation time `t` (clamped to `[0, 1]`; NaN is
    /// [`GpuError::TimeNaN`]): `mix(V(0), V(1), t)` for a two-pose object (`track` `None`),
    /// or `V(0)` plus the targets weighted by `track`'s offsets at `t`
    /// ([`WeightTrack::offsets_at`]) for an object whose targets came from that weight
    /// animation (see [`crate::morph::TargetBlend`]).
    pub fn set_pose(&mut self, t: f32, track: Option<&WeightTrack>) -> Result<(), GpuError> {
        self.pose.set_pose(t, track)
    }

    /// Sets the weight of every morph target (one per target of
    /// [`set_targets`](Self::set_targets), finite).
    pub fn set_target_weights(&mut self, weights: &[f32]) -> Result<(), GpuError> {
        self.pose.set_target_weights(weights)
    }

    /// Sets the object-to-world transform.
    pub fn set_model(&mut self, model: glam::Mat4) {
        self.pose.set_model(model);
    }

    /// Sets the object's colour (rgb stored in the target as is, alpha written as is), used by
    /// the faceted and smooth modes; the textured mode uses the material's base colour.
    pub fn set_color(&mut self, color: [f32; 4]) {
        self.pose.set_color(color);
    }

    /// Sets the world-space direction towards the light (finite, nonzero) and the ambient term
    /// (in `[0, 1]`).
    pub fn set_light(&mut self, towards_light: glam::Vec3, ambient: f32) -> Result<(), GpuError> {
        self.pose.set_light(towards_light, ambient)
    }

    /// Chooses how the object is shaded. An object without a surface draws
    /// [`ShadeMode::Smooth`] and [`ShadeMode::Textured`] as [`ShadeMode::Faceted`] (see
    /// [`shade_mode`](Self::shade_mode)). Strip colours read the record number, so while they
    /// are on the object draws one record per region (the indirect records are rewritten and
    /// uploaded once on each switch).
    pub fn set_shade_mode(&mut self, mode: ShadeMode) {
        let mode = mode.for_surface(self.has_surface());
        self.pose.set_mode(mode);
        self.shade = mode;
        self.relayout_records();
    }
}
