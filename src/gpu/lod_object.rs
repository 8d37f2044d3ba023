//! A deforming LOD object on the GPU: the CPU runtime ([`DeformingState`]) and the GPU
//! [`Object`] it drives, behind the `set` / `prepare` / `render` calls an application makes.
//!
//! This is the one place that wires the two together (dirty log into
//! [`Object::apply_dirty`], `t` into the uniforms), so contact sheets, benchmarks and
//! applications drive an object the same way.
//!
//! The object holds its [`DeformingModel`] through an [`Arc`]: the model (every frame's change
//! lists, megabytes for a body) is read-only after it is built and shared by every instance of
//! an asset — a crowd of N objects holds one model and N small runtimes. An `Arc` instead of a
//! borrow keeps the object free of lifetimes, so it can live in an application's state next to
//! the device it was made on.

use std::sync::Arc;

use super::commands::RenderCommands;
use super::{Draws, GpuAsset, GpuError, MorphPipeline, Object, ShadeMode, Topology, Upload};
use crate::asset::Asset;
use crate::deform::{DeformingModel, DeformingState, Lod, SetError};
use crate::lodstrips::PARALLEL_SLOTS;
use crate::morph::WeightTrack;

/// One deforming mesh with continuous LOD, ready to draw with one multi-draw per frame.
pub struct LodObject {
    model: Arc<DeformingModel>,
    state: DeformingState,
    object: Object,
    /// The weight track of an asset made from a weight animation (its targets live on the GPU).
    track: Option<WeightTrack>,
    /// Whether the next frame is built ahead.
    build_ahead: BuildAhead,
    /// The `t` (clamped) and LOD (in steps of its frame) of the last [`set`](Self::set), from
    /// which the next ones are guessed.
    last: Option<(f32, usize)>,
}

/// Whether a [`LodObject`] builds the next frame's strips on a thread of their own while the
/// current frame is drawn ([`DeformingState::build_ahead`]), so that the `set` that switches
/// there does not rebuild them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BuildAhead {
    /// For models of at least [`PARALLEL_SLOTS`] slots of `S0` (a 100k-vertex mesh has
    /// 250k), where rayon's pool has two threads or more (`RAYON_NUM_THREADS=1` asks for one
    /// thread, and gets it): a rebuild there takes about a millisecond; a smaller model's
    /// costs less than starting the thread.
    #[default]
    Auto,
    /// Whatever the model's size and the pool's.
    Always,
    /// Never: every switch rebuilds in `set`, and the object keeps one buffer of strips.
    Never,
}

impl LodObject {
    /// Uploads the poses of `asset` and the strips `S0` of `model` (one region per strip) on
    /// `device`; the object starts at `t = 0`, full detail.
    ///
    /// `model` must be made from `asset` ([`DeformingModel::new`]); a model whose strips name
    /// vertices past the asset's poses is rejected with [`GpuError::IndexOutOfRange`]. An
    /// asset with morph targets ([`Asset::blend`]) uploads them too, and [`set`](Self::set)
    /// plays its weight animation on the GPU. An asset with a [`Asset::surface`] draws
    /// textured and smooth by default (see [`Object::from_asset`] and its errors).
    pub fn new(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        asset: &Asset,
        model: Arc<DeformingModel>,
    ) -> Result<LodObject, GpuError> {
        LodObject::with_asset(
            device,
            pipeline,
            GpuAsset::from_asset(device, asset)?,
            model,
        )
    }

    /// As [`new`](Self::new), over an asset already on the GPU and shared with other objects
    /// ([`GpuAsset::from_asset`] of the asset `model` was made from): the object then holds
    /// only its runtime, index and indirect buffers and uniforms (see [`Object::with_asset`]).
    pub fn with_asset(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        asset: Arc<GpuAsset>,
        model: Arc<DeformingModel>,
    ) -> Result<LodObject, GpuError> {
        let track = asset.track().cloned();
        let object = Object::with_asset(
            device,
            pipeline,
            Topology::Strip,
            asset,
            &s0_regions(&model),
        )?;
        let state = DeformingState::new(&model);
        Ok(LodObject {
            model,
            state,
            object,
            track,
            build_ahead: BuildAhead::Auto,
            last: None,
        })
    }

    /// Moves to time `t` at `lod`: runs the CPU model, hands its dirty log to the GPU object's
    /// mirror and sets the blend parameter (and a skinned asset's clip phase: the GPU skins
    /// at `t`, [`Object::set_clip_t`], while the strips are the frame `t` shows). `t` outside `[0, 1]` and LOD fractions outside
    /// `[0, 1]` are clamped (the CPU and the GPU side use the same `t`); a NaN `t` or LOD is
    /// refused with a [`SetError`] and nothing changes. Nothing is uploaded until
    /// [`prepare`](Self::prepare).
    ///
    /// Where `t` goes on as it came (this `t` plus the last step) into the next frame, the
    /// next frame's strips are built on a thread of their own while this one is drawn, and a
    /// `set` that switches there takes them (see [`BuildAhead`]; large models by default).
    pub fn set(&mut self, t: f32, lod: Lod) -> Result<(), SetError> {
        self.state.set(&self.model, t, lod)?;
        let dirty = self.state.take_dirty();
        // The object was made from this model's S0 and the weight track was checked against the
        // targets in `new`: neither call can fail for a state of this model.
        self.object
            .apply_own_dirty(&dirty, self.state.indices(), self.state.lengths())
            .expect("the object's regions are the model's strips");
        self.object
            .set_pose(t, self.track.as_ref())
            .expect("t is not NaN and the track matches the targets");
        // A skinned asset's clip plays on the same t (its joints at t · duration).
        self.object.set_clip_t(t).expect("t is not NaN");
        // Last, so that the build does not compete with this frame's own work.
        self.build_next(t, lod);
        Ok(())
    }

    /// Starts building the next frame's strips where the animation goes on as it came: `t`
    /// plus its last step, at `lod` resolved there plus the LOD's last step (a camera
    /// closing in moves both).
    fn build_next(&mut self, t: f32, lod: Lod) {
        let build = match self.build_ahead {
            BuildAhead::Auto => {
                self.model.layout().s0().len() >= PARALLEL_SLOTS && rayon::current_num_threads() > 1
            }
            BuildAhead::Always => true,
            BuildAhead::Never => false,
        };
        if !build {
            return;
        }
        // Clamped as the frame is chosen, so that `next` is finite (an infinite `t` is
        // accepted).
        let now = (t.clamp(0.0, 1.0), self.state.lod());
        let Some(last) = self.last.replace(now) else {
            return;
        };
        let next = now.0 + (now.0 - last.0);
        // `t` and `lod` were just accepted, so neither can be refused here.
        let k = self.model.frame_at(next).expect("t is not NaN");
        if k == self.state.frame() {
            return;
        }
        let l = self.model.resolve(k, lod).expect("lod is not NaN");
        // Resolved again: the step added may pass the frame's coarsest LOD or a shared
        // sequence's boundary.
        let steps = Lod::Steps((l + now.1).saturating_sub(last.1));
        let l = self.model.resolve(k, steps).expect("a count of steps");
        self.state.build_ahead_at(&self.model, k, l);
    }

    /// Whether the next frame's strips are built ahead of a switch to it (default
    /// [`BuildAhead::Auto`]). Taking effect at the next [`set`](Self::set); a build under way
    /// is not stopped.
    pub fn set_build_ahead(&mut self, build_ahead: BuildAhead) {
        self.build_ahead = build_ahead;
    }

    /// Uploads what changed since the last call (index words, indirect records, uniforms; see
    /// [`Object::prepare`], which may submit the index scatter on `queue`).
    pub fn prepare(&mut self, queue: &wgpu::Queue) -> Upload {
        self.object.prepare(queue)
    }

    /// [`prepare`](Self::prepare) with the index scatter recorded into `encoder` (see
    /// [`Object::prepare_with`], whose rules apply: draw after it in `encoder`, submit
    /// `encoder` before this object's next `prepare`).
    pub fn prepare_with(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Upload {
        self.object.prepare_with(queue, encoder)
    }

    /// Draws the object with exactly one `multi_draw_indexed_indirect` (see
    /// [`Object::render`]).
    pub fn render(&self, pass: &mut (impl RenderCommands + ?Sized)) {
        self.object.render(pass);
    }

    /// Sets projection * view (see [`Object::set_view_proj`]).
    pub fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.object.set_view_proj(view_proj);
    }

    /// Sets the object-to-world transform.
    pub fn set_model(&mut self, model: glam::Mat4) {
        self.object.set_model(model);
    }

    /// Sets the object's colour (faceted and smooth modes, see [`Object::set_color`]).
    pub fn set_color(&mut self, color: [f32; 4]) {
        self.object.set_color(color);
    }

    /// Sets the world-space direction towards the light and the ambient term.
    pub fn set_light(&mut self, towards_light: glam::Vec3, ambient: f32) -> Result<(), GpuError> {
        self.object.set_light(towards_light, ambient)
    }

    /// Chooses the shade mode (see [`Object::set_shade_mode`]; strip colours draw one record
    /// per strip, smooth and textured need a surface).
    pub fn set_shade_mode(&mut self, mode: ShadeMode) {
        self.object.set_shade_mode(mode);
    }

    /// Chooses how strips are cut into draw records (see [`Object::set_draws`]).
    pub fn set_draws(&mut self, draws: Draws) -> Result<(), GpuError> {
        self.object.set_draws(draws)
    }

    /// The CPU runtime: current frame, LOD, triangle and index counts, live strips.
    pub fn state(&self) -> &DeformingState {
        &self.state
    }

    /// The GPU object (region layout, indirect records, draw count).
    pub fn object(&self) -> &Object {
        &self.object
    }

    /// Mutable access to the GPU object, e.g. to draw it in a pass with other objects through
    /// [`super::RenderTarget::render`].
    pub fn object_mut(&mut self) -> &mut Object {
        &mut self.object
    }

    /// The model this object runs.
    pub fn model(&self) -> &Arc<DeformingModel> {
        &self.model
    }
}

/// The strips of `S0` as `model`'s runtime lays them out: region `r` = strip `r`, so the
/// runtime's dirty logs address the object's regions directly. What [`Object::new`] takes to
/// draw the model's strips.
pub fn s0_regions(model: &DeformingModel) -> Vec<Vec<u32>> {
    let layout = model.layout();
    let s0 = layout.s0();
    // The layout checked its offsets against S0 when it was made; `get` keeps this total anyway.
    layout
        .region_offsets()
        .windows(2)
        .map(|w| s0.get(w[0] as usize..w[1] as usize).unwrap_or(&[]).to_vec())
        .collect()
}
