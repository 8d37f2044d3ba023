//! One instance: its runtime, what its slots on the GPU hold, and its patches after a move,
//! into or out of its frame's tail list.

use wgpu::util::DrawIndexedIndirectArgs;

use super::patches::{set_record, Piece};
use super::pipeline::CrowdPath;
use super::slots::{Places, SlotLayout};
use super::tail::TRIANGLE_SLOTS;
use super::types::InstanceAt;
use super::CrowdAsset;
use crate::deform::{DeformingModel, DeformingState, Lod};

/// One instance: its runtime and what its slots on the GPU hold.
pub(super) struct Member {
    /// Its runtime; none until its first move out of the tail lists (it draws `S0` until its
    /// first move) and while it is drawn from a tail list (made anew, at full detail, when it
    /// leaves): a distant instance holds no strips.
    pub(super) state: Option<DeformingState>,
    /// Live length of every region as the GPU holds it; empty while that is `S0`'s (the
    /// regions of a new instance, not patched since): most of a crowd's instances are drawn
    /// from their compact copies from their first upload on and never need the table.
    pub(super) uploaded: Vec<u32>,
    /// Its strips' places in the compact copy, and whether its regions lag behind.
    pub(super) places: Places,
    /// The runtime's [`DeformingState::changes`] as of the last upload of its strips (to the
    /// regions or to the compact copy).
    pub(super) changes: u64,
    /// A move asked by `set`, applied by its parallel pass.
    pub(super) pending: Option<(f32, Lod)>,
    /// The asset's prepare count when its last patches were made: equal to the current
    /// count, they wait in the asset's lists.
    pub(super) patched: u64,
    /// Frame and LOD while it is drawn from its frame's tail list (its runtime is left where
    /// it was), and whether its compact area holds them (written by a `prepare`).
    pub(super) tail: Option<(u32, u32)>,
    pub(super) expanded: bool,
    /// Whether its record's instance count is 0 on the GPU for being out of view (the
    /// mirror keeps the count it draws in view; `cull.rs`).
    pub(super) hidden: bool,
}

impl Member {
    /// Where its strips changed since its last patches: appends to `piece` the patches that
    /// bring its slots (at `slot` of `layout`) and its record to them: those of its compact
    /// copy where that is drawn (in the strips' places), else of its regions. While the
    /// compact copy is drawn the regions are not read nor patched: its `Places` notes that
    /// they lag, and when a record reads them again every live strip is sent whole.
    pub(super) fn patch(
        &mut self,
        layout: &SlotLayout,
        key: (CrowdPath, u32, u32),
        slot: u32,
        record: &mut DrawIndexedIndirectArgs,
        prepares: u64,
        piece: &mut Piece,
    ) {
        let state = self
            .state
            .as_mut()
            .expect("out of the tail lists: a runtime");
        // Unchanged strips keep their slots, record and compact copy.
        let changes = state.changes();
        if changes == self.changes {
            return;
        }
        self.changes = changes;
        piece.again |= self.patched == prepares;
        self.patched = prepares;
        let drawn = layout.upload(
            slot * key.2,
            state,
            &mut self.places,
            &mut self.uploaded,
            &mut piece.dirty,
            &mut piece.patches,
        );
        set_record(key, slot, Some(drawn), record, &mut piece.records);
    }

    /// Draws it from frame `k`'s tail list at LOD `l` (`count` triangles, in its compact
    /// area): from the next `prepare` on, which writes them there. Its runtime is dropped. Its
    /// copy and its regions no longer hold what it draws: the copy is repacked and the regions
    /// get every live strip when it leaves the tail.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn enter_tail(
        &mut self,
        layout: &SlotLayout,
        key: (CrowdPath, u32, u32),
        slot: u32,
        (k, l, count): (usize, usize, u32),
        record: &mut DrawIndexedIndirectArgs,
        piece: &mut Piece,
    ) {
        if self.tail == Some((k as u32, l as u32)) {
            return;
        }
        if self.tail.is_none() {
            self.places.leave();
            self.state = None;
        }
        self.tail = Some((k as u32, l as u32));
        self.expanded = false;
        piece.tails.push(slot);
        // Up to the last triangle's corners: a record ends on an index, not a restart.
        let drawn = layout.tail_record((count * TRIANGLE_SLOTS).saturating_sub(1));
        set_record(key, slot, Some(drawn), record, &mut piece.records);
    }

    /// Its runtime, made anew at full detail where it leaves the tail list it was drawn from:
    /// its next patch then sends its strips from scratch (a repacked copy, or every live strip
    /// to the regions).
    pub(super) fn leave_tail(&mut self, model: &DeformingModel) -> &mut DeformingState {
        if self.tail.take().is_some() {
            self.changes = u64::MAX;
        }
        self.state.get_or_insert_with(|| DeformingState::new(model))
    }

    /// Heap bytes of the instance: its runtime and lengths, and itself.
    pub(super) fn heap_bytes(&self) -> usize {
        size_of::<Member>()
            + self.state.as_ref().map_or(0, DeformingState::heap_bytes)
            + self.uploaded.capacity() * 4
            + self.places.heap_bytes()
    }
}

impl CrowdAsset {
    /// Where `member` (one of this asset's) is: from its runtime, its frame's tail list, or
    /// `S0` before its first move.
    pub(super) fn at(&self, member: &Member) -> InstanceAt {
        match (&member.state, member.tail) {
            (Some(state), _) => InstanceAt {
                frame: state.frame(),
                lod: state.lod(),
                triangles: state.triangle_count(),
                from_tail: false,
            },
            (None, None) => InstanceAt {
                frame: 0,
                lod: 0,
                triangles: self.model.layout().triangle_count(),
                from_tail: false,
            },
            (None, Some((k, l))) => {
                let triangles = self.tails.triangles(k as usize, l as usize);
                InstanceAt {
                    frame: k as usize,
                    lod: l as usize,
                    triangles: triangles.expect("a tail member's LOD is in its frame's tail")
                        as usize,
                    from_tail: true,
                }
            }
        }
    }
}
