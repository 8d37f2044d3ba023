//! One instance: its runtime, what its area of index memory holds, and its patches after a
//! move, into or out of its frame's tail list; then (serially, after `set`'s passes) the area
//! and record the move needs.

use super::patches::{draw_args, Piece};
use super::pipeline::CrowdPath;
use super::pool::{Area, RecordAt};
use super::slots::{DrawnFrom, Need, Places, SlotLayout, SlotRecord};
use super::tail::TRIANGLE_SLOTS;
use super::types::InstanceAt;
use super::CrowdAsset;
use std::sync::Mutex;

use crate::deform::{DeformingModel, DeformingState, Lod};

/// One instance: its runtime and what its area on the GPU holds.
pub(super) struct Member {
    /// Its runtime; none until its first move out of the tail lists (it draws `S0` until its
    /// first move) and while it is drawn from a tail list (made anew, at full detail, when it
    /// leaves): a distant instance holds no strips.
    pub(super) state: Option<DeformingState>,
    /// Live length of every region as the GPU holds it, while its area holds regions (empty
    /// else): most of a crowd's instances never hold regions and never need the table.
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
    /// Whether patches of an earlier `set` since the last prepare wait in the asset's lists
    /// (as of its last move): an area made anew voids them.
    pub(super) earlier: bool,
    /// Frame and LOD while it is drawn from its frame's tail list (its runtime is left where
    /// it was), and whether its area holds them (written by a `prepare`).
    pub(super) tail: Option<(u32, u32)>,
    pub(super) expanded: bool,
    /// Whether its record's instance count is 0 on the GPU for being out of view (the
    /// mirror keeps the count it draws in view; `cull.rs`).
    pub(super) hidden: bool,
    /// Its area of index memory (none while it draws the asset's shared `S0`), what that
    /// holds, and what its record reads there.
    pub(super) area: Option<Area>,
    pub(super) holds: DrawnFrom,
    pub(super) reads: SlotRecord,
    /// Where its draw record is (in its area's page).
    pub(super) record: RecordAt,
    /// The area its last move needs, settled after `set`'s passes.
    pub(super) need: Option<Need>,
    /// What its area gets on the GPU before the next prepare's patches.
    pub(super) arrival: Arrival,
}

/// Runtimes given up by instances that entered a tail list, kept for the next ones that leave
/// one: a body's runtime is ~130 KB, which made anew costs page faults on every first touch,
/// and instances cross the view's sides (out of view they are parked in a tail list) every
/// frame the camera turns. At most [`SPARE_STATES`], so they cost a bounded share of host
/// memory.
#[derive(Default)]
pub(super) struct Spares(Mutex<Vec<DeformingState>>);

/// The most runtimes an asset keeps spare.
const SPARE_STATES: usize = 32;

impl Spares {
    /// Keeps `state` for a later instance, where there is room (its dirty log emptied: a new
    /// owner sends its strips from scratch).
    fn give(&self, mut state: DeformingState) {
        let mut spares = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if spares.len() < SPARE_STATES {
            state.take_dirty();
            spares.push(state);
        }
    }

    /// A spare runtime, else a new one at full detail.
    fn take(&self, model: &DeformingModel) -> DeformingState {
        let spare = self.0.lock().unwrap_or_else(|e| e.into_inner()).pop();
        spare.unwrap_or_else(|| DeformingState::new(model))
    }

    /// Heap bytes of the runtimes kept.
    pub(super) fn heap_bytes(&self) -> usize {
        let spares = self.0.lock().unwrap_or_else(|e| e.into_inner());
        spares.iter().map(DeformingState::heap_bytes).sum()
    }
}

/// What an instance's new area gets on the GPU before the patches apply.
#[derive(Clone, Copy, Debug)]
pub(super) enum Arrival {
    /// Nothing: the patches or the tail expansion write all it reads.
    Nothing,
    /// The first `words` of an area it held before (freed, not reused before this copy).
    Copy { from: Area, words: u32 },
    /// [`RESTART`](crate::gpu::RESTART) everywhere: new regions.
    Restarts,
}

impl Member {
    /// A new instance drawing the asset's shared `S0` (which `reads` of it) through its
    /// record at `record`.
    pub(super) fn new(record: RecordAt, reads: SlotRecord) -> Member {
        Member {
            state: None,
            uploaded: Vec::new(),
            places: Places::default(),
            changes: u64::MAX,
            pending: None,
            patched: u64::MAX,
            earlier: false,
            tail: None,
            expanded: false,
            hidden: false,
            area: None,
            holds: DrawnFrom::S0,
            reads,
            record,
            need: None,
            arrival: Arrival::Nothing,
        }
    }

    /// Where its strips changed since its last patches: appends to `piece` the patches that
    /// bring its area (slot `slot`'s, as `layout` lays it out) to them, and notes the area it
    /// needs: a compact copy (in the strips' places) where that is drawn, else its regions.
    /// While the compact copy is drawn the regions are not held: its `Places` notes that they
    /// lag, and when a record reads them again every live strip is sent whole.
    pub(super) fn patch(
        &mut self,
        layout: &SlotLayout,
        slot: u32,
        prepares: u64,
        piece: &mut Piece,
    ) {
        let state = self
            .state
            .as_mut()
            .expect("out of the tail lists: a runtime");
        // Unchanged strips keep their area, record and compact copy.
        let changes = state.changes();
        if changes == self.changes {
            return;
        }
        self.changes = changes;
        self.earlier = self.patched == prepares;
        piece.again |= self.earlier;
        self.patched = prepares;
        let held = (self.holds, self.area.map_or(0, |a| a.words));
        let start = piece.patches.len();
        let (reads, need) = layout.upload(
            held,
            state,
            &mut self.places,
            &mut self.uploaded,
            &mut piece.dirty,
            &mut piece.patches,
        );
        piece.own(slot, start);
        self.reads = reads;
        self.need = Some(need);
        piece.moved.push(slot);
    }

    /// Draws it from frame `k`'s tail list at LOD `l` (`count` triangles, in an area of 4
    /// words a triangle): from the next `prepare` on, which writes them there. Its runtime is
    /// dropped. Its copy and its regions no longer hold what it draws: the copy is repacked
    /// and the regions get every live strip when it leaves the tail.
    pub(super) fn enter_tail(
        &mut self,
        slot: u32,
        (k, l, count): (usize, usize, u32),
        (prepares, spares): (u64, &Spares),
        piece: &mut Piece,
    ) {
        if self.tail == Some((k as u32, l as u32)) {
            return;
        }
        if self.tail.is_none() {
            self.places.leave();
            if let Some(state) = self.state.take() {
                spares.give(state);
            }
            self.uploaded = Vec::new();
        }
        self.tail = Some((k as u32, l as u32));
        self.expanded = false;
        self.earlier = self.patched == prepares;
        piece.tails.push(slot);
        // The expansion writes `a b c restart` a triangle; the record reads up to the last
        // triangle's corners (it ends on an index, not a restart).
        let words = count * TRIANGLE_SLOTS;
        self.reads = SlotRecord {
            first: 0,
            count: words.saturating_sub(1),
        };
        self.need = Some(Need::with_headroom(DrawnFrom::Tail, words.max(1), u32::MAX));
        piece.moved.push(slot);
    }

    /// Its runtime where it leaves the tail list it was drawn from (or has none yet): one an
    /// instance gave up on entering a tail list where one waits (at its own frame and LOD,
    /// which the move then leaves), else made anew at full detail. Its next patch sends its
    /// strips from scratch (a repacked copy, or every live strip to new regions).
    pub(super) fn leave_tail(
        &mut self,
        model: &DeformingModel,
        spares: &Spares,
    ) -> &mut DeformingState {
        if self.tail.take().is_some() {
            self.changes = u64::MAX;
        }
        self.state.get_or_insert_with(|| spares.take(model))
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
    /// Gives the instance in `slot` the area its last move needs (`lists`: the patch lists
    /// made before that `set`) and sets its record: its area is kept where it holds the same
    /// and has the words the need allows; else a new one is taken from the pool (in the same
    /// page where it fits), the old one freed, and the new one gets, before the next prepare's
    /// patches, the old one's words the need keeps (a compact copy grown: copied on the GPU,
    /// its places keep their words) or restarts (new regions); patches of an earlier `set`
    /// that named the old area are withdrawn where nothing is kept. A record follows its area
    /// to another page.
    pub(super) fn settle(&mut self, path: CrowdPath, slot: u32, lists: usize) {
        let key = (path, self.gpu.vertex_count());
        let Some(member) = self.members[slot as usize].as_mut() else {
            return;
        };
        let Some(need) = member.need.take() else {
            return;
        };
        let kept = (member.area).is_some_and(|area| need.keeps(member.holds, area.words));
        if !kept {
            let area = self.pool.alloc(need.room.max(need.min), member.record.page);
            member.arrival = match (member.arrival, member.area) {
                _ if need.keep == 0 && need.holds == DrawnFrom::Regions => Arrival::Restarts,
                _ if need.keep == 0 => Arrival::Nothing,
                // Moved twice since the last prepare: the first area is what the GPU holds.
                (Arrival::Copy { from, words }, _) => Arrival::Copy {
                    from,
                    words: words.min(need.keep),
                },
                (_, Some(from)) => Arrival::Copy {
                    from,
                    words: need.keep,
                },
                (_, None) => Arrival::Nothing,
            };
            if need.keep == 0 && member.earlier {
                self.waiting.withdrawn.push((slot, lists));
            }
            if !matches!(member.arrival, Arrival::Nothing) {
                self.arriving.push(slot);
            }
            if let Some(old) = member.area.replace(area) {
                self.pool.free(old);
            }
            if area.page != member.record.page {
                self.pool.remove_record(member.record);
                member.record = self.pool.add_record(area.page);
            }
        }
        member.holds = need.holds;
        let offset = member.area.map_or(self.s0.offset, |area| area.offset);
        let args = draw_args(key, slot, offset, member.reads);
        self.pool.set_record(member.record, args);
    }

    /// Where `member` (one of this asset's) is: from its runtime, its frame's tail list, or
    /// `S0` before its first move.
    pub(super) fn at(&self, member: &Member) -> InstanceAt {
        let (frame, lod, triangles) = match (&member.state, member.tail) {
            (Some(state), _) => (state.frame(), state.lod(), state.triangle_count()),
            (None, None) => (0, 0, self.model.layout().triangle_count()),
            (None, Some((k, l))) => {
                let triangles = self.tails.triangles(k as usize, l as usize);
                let triangles = triangles.expect("a tail member's LOD is in its frame's tail");
                (k as usize, l as usize, triangles as usize)
            }
        };
        InstanceAt {
            frame,
            lod,
            triangles,
            from: member.holds,
            words: member.area.map_or(0, |area| area.words),
            culled: member.hidden,
        }
    }
}
