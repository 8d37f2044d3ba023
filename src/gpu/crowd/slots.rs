//! An instance's index slots in its asset's index buffer, and the patches that bring them from
//! what the GPU holds to the runtime's current strips.
//!
//! Every instance of an asset owns `per_instance` consecutive slots: region `r` (strip `r` of
//! `S0`) at `starts[r]..starts[r] + capacity`, followed by one separator slot that always holds
//! [`RESTART`]: the layout of a strip [`Object`](super::super::Object), so one record per
//! instance draws all its strips (restarts separate them). The CPU keeps no mirror of the
//! slots: what the GPU holds is known from the runtime's strips as of the last upload, and the
//! runtime's dirty log says which positions may differ since. A patch is `[slot, value]`;
//! a frame's patches of all instances are applied by one scatter dispatch.

use crate::deform::{DeformingModel, DeformingState};
use crate::lodstrips::Dirty;

use super::super::RESTART;

/// Where the regions of one instance lie, relative to its first slot.
pub(super) struct SlotLayout {
    /// Region r starts at `starts[r]`; `starts[regions]` is the slot count per instance.
    starts: Vec<u32>,
    /// Region r starts at `runtime[r]` in the runtime's packed buffer (no separators).
    runtime: Vec<u32>,
    /// `S0` with a separator after every region: what a new instance's slots hold.
    s0: Vec<u32>,
}

impl SlotLayout {
    pub(super) fn new(model: &DeformingModel) -> SlotLayout {
        let layout = model.layout();
        let runtime = layout.region_offsets().to_vec();
        let s0 = layout.s0();
        let mut starts = Vec::with_capacity(runtime.len());
        let mut slots = Vec::with_capacity(s0.len() + runtime.len());
        starts.push(0);
        for w in runtime.windows(2) {
            slots.extend_from_slice(&s0[w[0] as usize..w[1] as usize]);
            slots.push(RESTART);
            starts.push(slots.len() as u32);
        }
        SlotLayout {
            starts,
            runtime,
            s0: slots,
        }
    }

    /// Slots per instance (capacities plus separators).
    pub(super) fn per_instance(&self) -> u32 {
        *self.starts.last().unwrap_or(&0)
    }

    /// The slots of a new instance (`S0`, separators).
    pub(super) fn s0(&self) -> &[u32] {
        &self.s0
    }

    /// The live length of every region at `S0`.
    pub(super) fn s0_lengths(&self) -> Vec<u32> {
        self.runtime.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// Cuts an instance's live strips (regions of `lengths`) into at most `budget` draw
    /// records, each `(first, count)` relative to the instance's first slot, appended to `out`
    /// in slot order. A record starts at a non-empty region and ends at the last live index of
    /// a non-empty region; between two non-empty regions lie the separator and the restart tail
    /// of the first and any empty regions (the gap). Every gap of more than `min_gap` slots
    /// is cut (the record ends before it, the next starts after it), the largest first, while
    /// the budget lasts; the gaps left inside records are read as restarts. `gaps` is scratch.
    pub(super) fn records(
        &self,
        lengths: &[u32],
        budget: usize,
        min_gap: u32,
        gaps: &mut Vec<(u32, u32)>,
        out: &mut Vec<(u32, u32)>,
    ) {
        // Gaps as (size, the start of the non-empty region after it).
        gaps.clear();
        let (mut first, mut end) = (None, 0u32);
        for (r, &len) in lengths.iter().enumerate().filter(|(_, &len)| len > 0) {
            let start = self.starts[r];
            match first {
                None => first = Some(start),
                Some(_) if start - end > min_gap => gaps.push((start - end, start)),
                Some(_) => {}
            }
            end = start + len;
        }
        let Some(first) = first else { return };
        let cuts = budget.max(1) - 1;
        if gaps.len() > cuts {
            // The largest gaps are cut; ties by position, so the cut is deterministic.
            gaps.select_nth_unstable_by(cuts, |a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
            gaps.truncate(cuts);
        }
        gaps.sort_unstable_by_key(|&(_, at)| at);
        let mut from = first;
        for &(size, at) in gaps.iter() {
            out.push((from, at - size - from));
            from = at;
        }
        out.push((from, end - from));
    }

    /// Appends to `out` the patches that take the slots at `base` from what the GPU holds
    /// (the strips of `uploaded` lengths, as of the last upload) to `state`'s current strips,
    /// given `dirty`, everything the runtime changed since (its contract: every changed
    /// position of a live strip lies in a range, every strip whose length changed is listed).
    /// Updates `uploaded`. Positions a strip left get [`RESTART`]; a position never gets two
    /// different values, so the patches may be applied in any order.
    pub(super) fn patches(
        &self,
        base: u32,
        state: &DeformingState,
        dirty: &Dirty,
        uploaded: &mut [u32],
        out: &mut Vec<[u32; 2]>,
    ) {
        let (indices, lengths) = (state.indices(), state.lengths());
        let copy = |r: usize, from: u32, to: u32, out: &mut Vec<[u32; 2]>| {
            let (slot, source) = (base + self.starts[r], self.runtime[r]);
            out.extend((from..to).map(|i| [slot + i, indices[(source + i) as usize]]));
        };
        for range in &dirty.ranges {
            let r = range.strip as usize;
            let live = lengths[r];
            copy(r, range.start.min(live), range.end.min(live), out);
        }
        for &strip in &dirty.lengths {
            let r = strip as usize;
            let (old, new) = (uploaded[r], lengths[r]);
            if new > old {
                copy(r, old, new, out);
            } else {
                let slot = base + self.starts[r];
                out.extend((new..old).map(|i| [slot + i, RESTART]));
            }
            uploaded[r] = new;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deform::Lod;
    use crate::{Builder, Morph};

    /// A small grid morph with a few frames, so the walk switches frames.
    fn model() -> DeformingModel {
        let n = 7u32;
        let (mut v0, mut v1) = (Vec::new(), Vec::new());
        for y in 0..n {
            for x in 0..n {
                let (fx, fy) = (x as f32 / 6.0, y as f32 / 6.0);
                let z = 0.05 * (7.0 * fx + 3.0 * fy).sin();
                v0.push([fx, fy, z]);
                v1.push([fx, fy, z + 0.3 * (3.0 * fx).sin() * fy]);
            }
        }
        let mut triangles = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let i = y * n + x;
                triangles.push([i, i + 1, i + n]);
                triangles.push([i + 1, i + n + 1, i + n]);
            }
        }
        let morph = Morph::from_poses(triangles, v0, v1).expect("grid morph");
        let asset = Builder::new(&morph).frames(4).build().expect("builds").0;
        DeformingModel::new(&asset).expect("model")
    }

    /// The slots as built from scratch from the state's strips.
    fn from_scratch(layout: &SlotLayout, state: &DeformingState) -> Vec<u32> {
        let mut slots = vec![RESTART; layout.per_instance() as usize];
        for r in 0..state.lengths().len() {
            let strip = state.strip(r).expect("strip");
            let start = layout.starts[r] as usize;
            slots[start..start + strip.len()].copy_from_slice(strip);
        }
        slots
    }

    /// Over a walk with frame switches and LOD jumps, applying the patches in reverse order
    /// (any order must do) to the previous slots gives the slots built from scratch.
    #[test]
    fn patches_bring_the_slots_to_the_current_strips() {
        let model = model();
        let layout = SlotLayout::new(&model);
        let mut state = DeformingState::new(&model);
        let base = 3 * layout.per_instance();
        let mut gpu = vec![0u32; base as usize];
        gpu.extend_from_slice(layout.s0());
        assert_eq!(
            &gpu[base as usize..],
            from_scratch(&layout, &state).as_slice()
        );
        let mut uploaded = layout.s0_lengths();
        let walk = [
            (0.0, 0.5),
            (0.0, 0.9),
            (0.7, 0.9),
            (0.7, 0.1),
            (1.0, 1.0),
            (0.2, 0.0),
            (0.4, 0.6),
        ];
        for (step, &(t, lod)) in walk.iter().enumerate() {
            state.set(&model, t, Lod::Fraction(lod)).expect("set");
            // Every other step moves twice before the upload: the dirty log accumulates.
            if step % 2 == 1 {
                state.set(&model, 1.0 - t, Lod::Fraction(0.3)).expect("set");
            }
            let dirty = state.take_dirty();
            let mut patches = Vec::new();
            layout.patches(base, &state, &dirty, &mut uploaded, &mut patches);
            for &[slot, value] in patches.iter().rev() {
                gpu[slot as usize] = value;
            }
            assert!(
                gpu[..base as usize].iter().all(|&w| w == 0),
                "other slots untouched"
            );
            assert_eq!(
                &gpu[base as usize..],
                from_scratch(&layout, &state).as_slice(),
                "step {step}"
            );
            assert_eq!(uploaded, state.lengths());
            // Records cut at every gap (min_gap 0) read exactly the live indices; keeping
            // the separators (min_gap 1) reads them and no restart tail; after the last
            // record, only restarts.
            let (mut gaps, mut records) = (Vec::new(), Vec::new());
            let live: u32 = state.lengths().iter().sum();
            let strips = state.lengths().iter().filter(|&&len| len > 0).count();
            layout.records(state.lengths(), usize::MAX, 0, &mut gaps, &mut records);
            assert_eq!(records.len(), strips);
            assert_eq!(records.iter().map(|&(_, count)| count).sum::<u32>(), live);
            records.clear();
            layout.records(state.lengths(), usize::MAX, 1, &mut gaps, &mut records);
            let read: u32 = records.iter().map(|&(_, count)| count).sum();
            assert_eq!(read - live, (strips - records.len()) as u32, "step {step}");
            for &(first, count) in &records {
                let slots = &gpu[(base + first) as usize..(base + first + count) as usize];
                assert!(slots.first() != Some(&RESTART) && slots.last() != Some(&RESTART));
                assert!(
                    slots.windows(2).all(|w| w != [RESTART, RESTART]),
                    "a tail read"
                );
            }
            // A budget of 2 cuts the largest gap only.
            records.clear();
            layout.records(state.lengths(), 2, 1, &mut gaps, &mut records);
            assert!(records.len() <= 2.min(strips));
            let end = records.last().map_or(0, |&(first, count)| first + count) as usize;
            assert!(gpu[base as usize + end..].iter().all(|&w| w == RESTART));
        }
    }
}
