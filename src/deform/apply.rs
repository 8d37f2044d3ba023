//! Carrying a plan out: by steps (across frames: refine to LOD 0, then coarsen) or by a
//! rebuild; a crowd's rebuilds grouped by frame, sharing the survivors of its collapses.

use super::model::DeformingModel;
use super::plan::Plan;
use super::{DeformingState, Strategy};
use crate::lodstrips::Survivors;
#[cfg(feature = "gpu")]
use crate::par;

impl DeformingState {
    /// Carries out `plan` (made by [`plan`](Self::plan) for this state and `model`); a
    /// rebuild takes its survivors from `anc`.
    pub(crate) fn apply<'a>(
        &mut self,
        model: &'a DeformingModel,
        plan: Plan,
        anc: &mut Survivors<'a>,
    ) {
        let frame = &model.frames[plan.frame].changes;
        if plan.strategy == Strategy::Rebuild {
            let from = &model.frames[self.frame].changes;
            self.state
                .rebuild(&model.layout, from, frame, plan.lod, anc);
        } else {
            if plan.frame != self.frame {
                self.state.step_to(&model.frames[self.frame].changes, 0);
            }
            self.state.step_to(frame, plan.lod);
        }
        self.frame = plan.frame;
    }
}

/// Carries out the rebuilds of many states of one model, each with its plan: sorted by
/// frame and LOD, cut into runs of one frame (at most `⌈states / (4 × threads)⌉` each, so
/// that the runs spread over the threads even when every state goes to one frame), the runs
/// in parallel. A run links each of its frame's collapses once for all its states
/// ([`Survivors`]) instead of once per state. `state` finds a job's state; `then` is called
/// on each job right after its rebuild, on the same thread (while the state is in that core's
/// cache), with one accumulator per run, and `finish` of each run's accumulator, made on that
/// thread too, is returned, in run order. The calling thread takes runs too ([`par::map`]).
/// (The crowd's; a crate without the renderer has no caller.)
#[cfg(feature = "gpu")]
pub(crate) fn rebuild_all<J: Send, A: Default, B: Send>(
    model: &DeformingModel,
    jobs: &mut [(Plan, J)],
    state: impl Fn(&mut J) -> &mut DeformingState + Sync,
    then: impl Fn(&mut J, &mut A) + Sync,
    finish: impl Fn(A) -> B + Sync,
) -> Vec<B> {
    jobs.sort_unstable_by_key(|(plan, _)| (plan.frame, plan.lod));
    let run = par::piece_len(jobs.len(), 1);
    let mut runs = Vec::new();
    let mut rest = jobs;
    while let Some((first, _)) = rest.first() {
        let frame = first.frame;
        let n = rest
            .iter()
            .take(run)
            .take_while(|(plan, _)| plan.frame == frame)
            .count();
        let (head, tail) = rest.split_at_mut(n);
        runs.push(head);
        rest = tail;
    }
    par::map(runs, |run| {
        let mut anc = Survivors::new();
        let mut acc = A::default();
        for (plan, job) in run.iter_mut() {
            state(job).apply(model, *plan, &mut anc);
            then(job, &mut acc);
        }
        finish(acc)
    })
}
