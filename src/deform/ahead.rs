//! Frames built ahead: a frame's strips rebuilt on a thread of their own before a switch to
//! it, and the switches that take them (a swap of buffers, then a few steps).

use std::sync::Arc;
use std::thread::JoinHandle;

use super::model::DeformingModel;
use super::plan::Plan;
use super::{DeformingState, Lod, SetError, Strategy, STEP_COST};
use crate::lodstrips::{StripsState, Survivors};
use crate::par;

/// A frame's strips rebuilt on a thread of their own ahead of a switch to it
/// ([`DeformingState::build_ahead`]), and the state they are built in.
#[derive(Debug, Default)]
pub(super) struct Ahead {
    /// The build under way, whose thread returns its frame and state.
    pending: Option<JoinHandle<(usize, StripsState)>>,
    /// The last build's frame and state (after a switch took it, still a valid state of its
    /// frame): the next build rebuilds it in place, so a state allocates its second buffer
    /// once.
    pub(super) built: Option<(usize, StripsState)>,
    /// Switches that took a build ([`DeformingState::switches_built_ahead`]).
    taken: u64,
}

impl Ahead {
    /// Takes the build under way into `built` if it is done; never waits.
    fn collect(&mut self) {
        if self.pending.as_ref().is_some_and(JoinHandle::is_finished) {
            self.finish();
        }
    }

    /// Waits for the build under way, if any, and takes it into `built` (nothing where its
    /// thread panicked).
    fn finish(&mut self) {
        if let Some(pending) = self.pending.take() {
            self.built = pending.join().ok();
        }
    }
}

impl Clone for Ahead {
    /// Nothing built: a clone starts its own builds.
    fn clone(&self) -> Ahead {
        Ahead::default()
    }
}

impl DeformingState {
    /// Starts rebuilding the strips at `(t, lod)` on a thread of its own when `t` is in another
    /// frame than this state's and stepping there from the state's LOD would cost at least a
    /// quarter of a rebuild ([`STEP_COST`]). A later [`set`](Self::set) to that frame takes
    /// the strips built, stepped to its own LOD, where that costs less than its own plan,
    /// instead of rebuilding (or stepping) on the calling thread: what is left of the switch
    /// is a swap of buffers and those steps. An application calls it with where it expects
    /// to be next (an animation's next `t`); [`LodObject`](crate::gpu::LodObject) does by
    /// itself. Returns whether a build started.
    ///
    /// Nothing starts while an earlier build is under way (one at a time), or where the
    /// strips built last are of that frame and LOD already. From the first build on the state
    /// keeps a second buffer of its own size (1.2 MB for a 100k-vertex mesh, see
    /// [`heap_bytes`](Self::heap_bytes)). A `set` to another frame, or made before the build
    /// is done, moves as if nothing were built and never waits. Worth it for large models (a
    /// rebuild of [`PARALLEL_SLOTS`](crate::lodstrips::PARALLEL_SLOTS) slots of `S0` takes
    /// about a millisecond); a small one's rebuild costs less than starting the thread. `t`
    /// and `lod` are checked as `set` checks them.
    pub fn build_ahead(
        &mut self,
        model: &Arc<DeformingModel>,
        t: f32,
        lod: Lod,
    ) -> Result<bool, SetError> {
        let (k, l) = self.resolve_move(model, t, lod)?;
        Ok(self.build_ahead_at(model, k, l))
    }

    /// Switches that took strips built ahead ([`build_ahead`](Self::build_ahead)) since the
    /// state was made: against the frame switches made, how often the builds came in time.
    pub fn switches_built_ahead(&self) -> u64 {
        self.ahead.as_ref().map_or(0, |a| a.taken)
    }

    /// [`build_ahead`](Self::build_ahead) for frame `k` at LOD `l`, resolved against `model`
    /// (this state's model).
    pub(crate) fn build_ahead_at(
        &mut self,
        model: &Arc<DeformingModel>,
        k: usize,
        l: usize,
    ) -> bool {
        if k == self.frame {
            return false;
        }
        // Not where stepping there costs under a quarter of a rebuild (near full detail): the
        // switch steps whatever is built. Between that and where `Auto` rebuilds, it may go
        // either way by the time it comes.
        let (steps, rebuild) = self.move_costs(model, k, l);
        if 4 * steps < rebuild {
            return false;
        }
        let ahead = self.ahead.get_or_insert_with(Box::default);
        ahead.collect();
        let built_already = matches!(&ahead.built, Some((f, built)) if *f == k && built.lod() == l);
        if ahead.pending.is_some() || built_already {
            return false;
        }
        let built = ahead.built.take();
        let model = Arc::clone(model);
        // A thread of its own, its rebuild on that thread alone: on the pool, the threads
        // that wake for it and look for more work took the cores from the caller's thread
        // for milliseconds on 2 cores (docs/benchmarks-log.md, "One 100k-vertex object: the
        // next frame built ahead").
        let build = move || {
            par::alone(|| {
                let (from, mut state) =
                    built.unwrap_or_else(|| (0, StripsState::at_s0(&model.layout, model.id)));
                let frames = &model.frames;
                let (from, to) = (&frames[from].changes, &frames[k].changes);
                state.rebuild(&model.layout, from, to, l, &mut Survivors::new());
                (k, state)
            })
        };
        let thread = std::thread::Builder::new().name("morphlod-ahead".into());
        match thread.spawn(build) {
            Ok(pending) => {
                ahead.pending = Some(pending);
                true
            }
            // No thread to be had: the switch rebuilds as usual.
            Err(_) => false,
        }
    }

    /// Whether a build started by [`build_ahead`](Self::build_ahead) is still running. A
    /// caller that wants every switch to take its build (a test, an offline render) waits
    /// for it to turn false before the move; an interactive one never needs to.
    pub fn building_ahead(&self) -> bool {
        let pending = self.ahead.as_ref().and_then(|a| a.pending.as_ref());
        pending.is_some_and(|p| !p.is_finished())
    }

    /// Waits for the build under way, if any.
    #[cfg(test)]
    pub(super) fn wait_ahead(&mut self) {
        if let Some(ahead) = self.ahead.as_deref_mut() {
            ahead.finish();
        }
    }

    /// Carries out `plan`, a switch to another frame, from the strips built ahead for its
    /// frame, if they are ready and stepping from their LOD to the plan's costs less than the
    /// plan (its steps or its rebuild): swapped in (every live strip marked), then stepped to
    /// the plan's LOD. False (nothing done) otherwise. Builds are of this state's model
    /// (`build_ahead` checks it, a `LodObject` builds with its own, `swap_strips` asserts it).
    pub(super) fn take_ahead(&mut self, model: &DeformingModel, plan: Plan) -> bool {
        let (steps, rebuild) = self.move_costs(model, plan.frame, plan.lod);
        let planned = match plan.strategy {
            Strategy::Rebuild => rebuild,
            _ => steps,
        };
        let Some(ahead) = self.ahead.as_deref_mut() else {
            return false;
        };
        ahead.collect();
        match &mut ahead.built {
            Some((k, built))
                if *k == plan.frame && built.lod().abs_diff(plan.lod) * STEP_COST < planned =>
            {
                self.state.swap_strips(built);
                // What is left behind is this state's old strips, of its old frame.
                *k = self.frame;
                self.state
                    .step_to(&model.frames[plan.frame].changes, plan.lod);
                self.frame = plan.frame;
                ahead.taken += 1;
                true
            }
            _ => false,
        }
    }
}
