//! An instance's index slots in its asset's index buffer, and the patches that bring them from
//! what the GPU holds to the runtime's current strips.
//!
//! Every instance of an asset owns `per_instance` consecutive slots. First its regions: region
//! `r` (strip `r` of `S0`) at `starts[r]..starts[r] + capacity`, followed by one separator
//! slot that always holds [`RESTART`]: the layout of a strip [`Object`](super::super::Object),
//! so one record draws all its strips (restarts separate them), and patches keep it current
//! at O(changed indices). Then its compact area: where the instance's live strips fit in it
//! (a coarse LOD), they are copied there packed, one restart between two, and its record
//! draws that copy instead of the regions, whose restart tails would be most of what it reads.
//! The CPU keeps no mirror of the slots: what the GPU holds is known from the runtime's strips
//! as of the last upload, and the runtime's dirty log says which positions may differ since.
//! A patch is `[slot, value]`; a frame's patches of all instances are encoded as runs of
//! consecutive slots and applied by one scatter dispatch.

use crate::deform::{DeformingModel, DeformingState};
use crate::lodstrips::Dirty;

use super::super::RESTART;

/// Where the regions of one instance lie, relative to its first slot.
pub(super) struct SlotLayout {
    /// Region r starts at `starts[r]`; `starts[regions]` is the slot count per instance.
    starts: Vec<u32>,
    /// Region r starts at `runtime[r]` in the runtime's packed buffer (no separators).
    runtime: Vec<u32>,
    /// `S0` with a separator after every region: what a new instance's regions hold.
    s0: Vec<u32>,
    /// Slots of the compact area, after the regions.
    compact: u32,
}

/// Which slots an instance's one draw record reads, relative to its first slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct SlotRecord {
    pub(super) first: u32,
    pub(super) count: u32,
    /// Reads the compact area (else the regions).
    pub(super) compact: bool,
}

impl SlotLayout {
    /// The slots of `model`'s instances, with a compact area of `compact_share` (clamped to
    /// 0..=1) of the regions' slots.
    pub(super) fn new(model: &DeformingModel, compact_share: f32) -> SlotLayout {
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
        let regions = slots.len() as f32;
        let compact = (regions * compact_share.clamp(0.0, 1.0)).ceil() as u32;
        SlotLayout {
            starts,
            runtime,
            s0: slots,
            compact,
        }
    }

    /// Slots per instance: the regions (capacities plus separators) and the compact area.
    pub(super) fn per_instance(&self) -> u32 {
        self.regions() + self.compact
    }

    /// Shrinks the compact area (to nothing at most) so that an instance has at most
    /// `slots`.
    pub(super) fn fit(&mut self, slots: u64) {
        let room = slots.saturating_sub(u64::from(self.regions()));
        self.compact = self.compact.min(room.min(u64::from(u32::MAX)) as u32);
    }

    /// Slots of the regions.
    fn regions(&self) -> u32 {
        *self.starts.last().unwrap_or(&0)
    }

    /// Slots of the compact area.
    pub(super) fn compact_slots(&self) -> u32 {
        self.compact
    }

    /// The regions of a new instance (`S0`, separators).
    pub(super) fn s0(&self) -> &[u32] {
        &self.s0
    }

    /// The live length of every region at `S0`.
    pub(super) fn s0_lengths(&self) -> Vec<u32> {
        self.runtime.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// The record of an instance whose strips have `lengths`: the compact copy where its live
    /// strips and the restarts between them fit the compact area, else the regions from the
    /// first live index to the last (restart tails between them included), which must then
    /// hold those strips.
    pub(super) fn record(&self, lengths: &[u32]) -> SlotRecord {
        let live = lengths.iter().filter(|&&len| len > 0);
        let packed = live
            .clone()
            .map(|&len| len + 1)
            .sum::<u32>()
            .saturating_sub(1);
        if packed > 0 && packed <= self.compact {
            return SlotRecord {
                first: self.regions(),
                count: packed,
                compact: true,
            };
        }
        self.region_record(lengths)
    }

    /// The record that reads the regions of strips of `lengths` from the first live index to
    /// the last.
    pub(super) fn region_record(&self, lengths: &[u32]) -> SlotRecord {
        let first = lengths.iter().position(|&len| len > 0);
        let last = lengths.iter().rposition(|&len| len > 0);
        let (first, end) = match (first, last) {
            (Some(f), Some(l)) => (self.starts[f], self.starts[l] + lengths[l]),
            _ => (0, 0),
        };
        SlotRecord {
            first,
            count: end - first,
            compact: false,
        }
    }

    /// Appends to `out` the patches that write `state`'s live strips packed into the compact
    /// area of the instance at `base` (one restart between two strips; the caller checked
    /// that they fit, [`record`](Self::record)).
    pub(super) fn compact_patches(
        &self,
        base: u32,
        state: &DeformingState,
        out: &mut Vec<[u32; 2]>,
    ) {
        let (indices, lengths) = (state.indices(), state.lengths());
        let mut at = base + self.regions();
        for (r, &len) in lengths.iter().enumerate().filter(|(_, &len)| len > 0) {
            if at > base + self.regions() {
                out.push([at, RESTART]);
                at += 1;
            }
            let source = self.runtime[r] as usize;
            let strip = &indices[source..source + len as usize];
            out.extend(strip.iter().zip(at..).map(|(&v, slot)| [slot, v]));
            at += len;
        }
    }

    /// Appends to `out` the patches that take the slots at `base` from what the GPU holds
    /// (the strips of `uploaded` lengths, as of the last upload) to `state`'s current strips,
    /// given `dirty`, everything the runtime changed since (its contract: every changed
    /// position of a live strip lies in a range, every strip whose length changed is listed).
    /// Updates `uploaded`. Positions a strip left get [`RESTART`]; a position gets at most one
    /// patch (so the patches may be applied in any order, and no word is sent twice).
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
            // Past the shorter of the two lengths the loop below writes every position (the
            // growth, or restarts over what the strip left): each position once.
            let kept = lengths[r].min(uploaded[r]);
            copy(r, range.start.min(kept), range.end.min(kept), out);
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

    /// The regions as built from scratch from the state's strips.
    fn from_scratch(layout: &SlotLayout, state: &DeformingState) -> Vec<u32> {
        let mut slots = vec![RESTART; layout.regions() as usize];
        for r in 0..state.lengths().len() {
            let strip = state.strip(r).expect("strip");
            let start = layout.starts[r] as usize;
            slots[start..start + strip.len()].copy_from_slice(strip);
        }
        slots
    }

    /// Over a walk with frame switches and LOD jumps, applying the patches in reverse order
    /// (any order must do) to the previous slots gives the regions built from scratch; the
    /// record reads the live strips and the restarts between them only where they fit the
    /// compact area (its copy), else from the first live index to the last.
    #[test]
    fn patches_bring_the_slots_to_the_current_strips() {
        let model = model();
        for share in [0.0, 0.3, 1.0] {
            let layout = SlotLayout::new(&model, share);
            let mut state = DeformingState::new(&model);
            let base = 3 * layout.per_instance();
            let (regions, end) = (base + layout.regions(), base + layout.per_instance());
            let mut gpu = vec![0u32; end as usize + 5];
            gpu[base as usize..regions as usize].copy_from_slice(layout.s0());
            assert_eq!(
                &gpu[base as usize..regions as usize],
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
            let mut compacted = 0;
            for (step, &(t, lod)) in walk.iter().enumerate() {
                state.set(&model, t, Lod::Fraction(lod)).expect("set");
                // Every other step moves twice before the upload: the dirty log accumulates.
                if step % 2 == 1 {
                    state.set(&model, 1.0 - t, Lod::Fraction(0.3)).expect("set");
                }
                let dirty = state.take_dirty();
                let mut patches = Vec::new();
                layout.patches(base, &state, &dirty, &mut uploaded, &mut patches);
                let record = layout.record(&uploaded);
                if record.compact {
                    layout.compact_patches(base, &state, &mut patches);
                    compacted += 1;
                }
                let mut slots: Vec<u32> = patches.iter().map(|p| p[0]).collect();
                slots.sort_unstable();
                slots.dedup();
                assert_eq!(
                    slots.len(),
                    patches.len(),
                    "step {step}: a slot patched twice"
                );
                for &[slot, value] in patches.iter().rev() {
                    gpu[slot as usize] = value;
                }
                assert!(
                    gpu[..base as usize]
                        .iter()
                        .chain(&gpu[end as usize..])
                        .all(|&w| w == 0),
                    "other slots untouched"
                );
                assert_eq!(
                    &gpu[base as usize..regions as usize],
                    from_scratch(&layout, &state).as_slice(),
                    "step {step}"
                );
                assert_eq!(uploaded, state.lengths());
                // What the record reads draws the strips; it starts and ends at a live index.
                let read = &gpu[(base + record.first) as usize..][..record.count as usize];
                let strips: Vec<&[u32]> = (0..uploaded.len())
                    .filter_map(|r| state.strip(r).filter(|s| !s.is_empty()))
                    .collect();
                let drawn: Vec<&[u32]> = read
                    .split(|&w| w == RESTART)
                    .filter(|s| !s.is_empty())
                    .collect();
                assert_eq!(drawn, strips, "share {share}, step {step}");
                assert!(read.first() != Some(&RESTART) && read.last() != Some(&RESTART));
                let live: u32 = uploaded.iter().sum();
                let packed = live + strips.len().saturating_sub(1) as u32;
                assert_eq!(
                    record.compact,
                    packed > 0 && packed <= layout.compact_slots()
                );
                if record.compact {
                    // Nothing but the live indices and one restart between two strips.
                    assert_eq!(record.count, packed);
                }
            }
            // Without a compact area never; with one as large as the regions always.
            assert_eq!(compacted == 0, share == 0.0);
            if share == 1.0 {
                assert_eq!(compacted, walk.len());
            }
        }
    }
}
