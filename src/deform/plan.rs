//! Planning a move: the request resolved to a frame and LOD of this state's model, and the
//! strategy that takes the state there, by the cost model ([`STEP_COST`]).

use super::model::DeformingModel;
use super::{DeformingState, Lod, SetError, Strategy, STEP_COST};

/// A checked move of a [`DeformingState`]: the frame and LOD it goes to, and the strategy
/// (`Steps` or `Rebuild`) that takes it there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Plan {
    pub(crate) frame: usize,
    pub(crate) lod: usize,
    pub(crate) strategy: Strategy,
}

impl Plan {
    /// Whether carrying it out reads a survivor table over `model`'s mesh (a rebuild finer
    /// than its frame's tail): such rebuilds go to [`rebuild_all`](super::rebuild_all),
    /// grouped by frame; the rest are cheapest where the state was just read.
    #[cfg(feature = "gpu")]
    pub(crate) fn links_survivors(self, model: &DeformingModel) -> bool {
        self.strategy == Strategy::Rebuild
            && !model.frames[self.frame]
                .changes
                .rebuilds_from_tail(self.lod)
    }
}

impl DeformingState {
    /// Where a move to `(t, lod)` goes and how (the request checked, nothing moved).
    pub(crate) fn plan(
        &self,
        model: &DeformingModel,
        t: f32,
        lod: Lod,
        strategy: Strategy,
    ) -> Result<Plan, SetError> {
        let (k, l) = self.resolve_move(model, t, lod)?;
        Ok(self.plan_at(model, k, l, strategy))
    }

    /// The frame and LOD (in steps of that frame) a move of this state to `(t, lod)` goes to,
    /// the request checked against `model`.
    pub(super) fn resolve_move(
        &self,
        model: &DeformingModel,
        t: f32,
        lod: Lod,
    ) -> Result<(usize, usize), SetError> {
        if self.state.model_id() != model.id {
            return Err(SetError::WrongModel);
        }
        let k = model.frame_at(t)?;
        Ok((k, model.resolve(k, lod)?))
    }

    /// What moving this state to frame `k` at LOD `l` costs in rebuild work units: by steps
    /// ([`STEP_COST`] each; back to LOD 0 of this frame first where `k` is another) and by a
    /// rebuild.
    pub(super) fn move_costs(&self, model: &DeformingModel, k: usize, l: usize) -> (usize, usize) {
        let steps = if k == self.frame {
            self.state.lod().abs_diff(l)
        } else {
            self.state.lod() + l
        };
        let rebuild = model.frames[k].changes.rebuild_work(&model.layout, l);
        (steps * STEP_COST, rebuild)
    }

    /// [`plan`](Self::plan) for frame `k` at LOD `l`, already resolved against `model` (this
    /// state's model): a crowd resolves every move first, to tell the instances drawn from a
    /// tail list.
    pub(crate) fn plan_at(
        &self,
        model: &DeformingModel,
        k: usize,
        l: usize,
        strategy: Strategy,
    ) -> Plan {
        let strategy = match strategy {
            Strategy::Auto => {
                let (steps, rebuild) = self.move_costs(model, k, l);
                if steps <= rebuild {
                    Strategy::Steps
                } else {
                    Strategy::Rebuild
                }
            }
            chosen => chosen,
        };
        Plan {
            frame: k,
            lod: l,
            strategy,
        }
    }
}
