//! A LOD runtime's changes (its [`Dirty`] log) checked against the object's layout and
//! applied to the index mirror.

use std::ops::Range;

use super::{separator_slots, Object, Topology};
use crate::gpu::checks::check_indices;
use crate::gpu::upload::clip;
use crate::gpu::GpuError;
use crate::lodstrips::{dispatch, Dirty, Indices, StripIndex};

impl Object {
    /// Applies what a LOD runtime changed since its last `take_dirty` (a [`Dirty`] from
    /// [`crate::lodstrips::StripsState::take_dirty`], or from any runtime with the same contract):
    /// `indices` is the runtime's whole index buffer (`&[u32]`, `&[u16]` or a state's
    /// [`Indices`]) and `lengths` the live length of every strip, with strip `r` owning this object's region `r` and the regions packed back to
    /// back in order, as [`crate::lodstrips::StripsState::indices`] / `lengths` are (no
    /// separators: region `r` of the runtime starts `r` slots before this object's in a strip
    /// object).
    ///
    /// The contract: every position of a live strip whose value changed lies in one of
    /// `dirty.ranges`, and every strip whose live length changed is in `dirty.lengths`. Only those
    /// ranges are read (plus the positions a strip grew by), not whole regions; each is clipped to
    /// the strip's live length and diffed against the mirror, and only the changed words are marked
    /// for upload (runs of unchanged words longer than the merge gap split a write): a step undone
    /// before this call (coarsen then refine) uploads nothing, a frame switch uploads the words
    /// that differ. A strip that shrank gets [`RESTART`](crate::gpu::RESTART) over the positions it
    /// left. Everything is checked before anything changes; on error the object is as before.
    pub fn apply_dirty<'a>(
        &mut self,
        dirty: &Dirty,
        indices: impl Into<Indices<'a>>,
        lengths: &[u32],
    ) -> Result<(), GpuError> {
        dispatch!(Indices, indices.into(), indices => {
            self.check_layout(indices.len(), lengths)?;
            self.check_dirty(dirty, indices, lengths)?;
            self.apply_checked(dirty, indices, lengths);
        });
        Ok(())
    }

    /// [`apply_dirty`](Self::apply_dirty) for a runtime whose every index is known to be in
    /// range and every live length within its region: the state of the model this object was
    /// made from (its indices are `S0`'s, checked when the object was made, or their
    /// survivors; its strips never outgrow `S0`). Only the layout is checked; reading every
    /// changed index again (a quarter of `apply_dirty` at a frame switch) is left to debug
    /// builds.
    pub(crate) fn apply_own_dirty(
        &mut self,
        dirty: &Dirty,
        indices: Indices<'_>,
        lengths: &[u32],
    ) -> Result<(), GpuError> {
        dispatch!(Indices, indices, indices => {
            self.check_layout(indices.len(), lengths)?;
            debug_assert!(
                self.check_dirty(dirty, indices, lengths).is_ok(),
                "a runtime of this object's model gave an index out of range"
            );
            self.apply_checked(dirty, indices, lengths);
        });
        Ok(())
    }

    /// That a runtime's buffer (of `indices` words) and lengths have this object's layout.
    fn check_layout(&self, indices: usize, lengths: &[u32]) -> Result<(), GpuError> {
        let regions = self.region_count();
        let capacity =
            self.mirror.indices.len() - regions * separator_slots(self.topology) as usize;
        if indices != capacity || lengths.len() != regions {
            return Err(GpuError::LayoutMismatch {
                indices,
                strips: lengths.len(),
                capacity,
                regions,
            });
        }
        Ok(())
    }

    /// The check pass of [`apply_dirty`](Self::apply_dirty), its layout checked: region
    /// numbers, capacities, and the indices each range will copy.
    fn check_dirty<I: StripIndex>(
        &self,
        dirty: &Dirty,
        indices: &[I],
        lengths: &[u32],
    ) -> Result<(), GpuError> {
        for &strip in &dirty.lengths {
            let region = strip as usize;
            let (span, live) = self.check_live_length(region, lengths)?;
            let old = self.lengths[region];
            if live > old {
                let source = runtime_span(self.topology, region, span.start, old..live);
                check_indices(region, &indices[source], self.vertex_count, self.strips())?;
            }
        }
        for range in &dirty.ranges {
            let region = range.strip as usize;
            let (span, live) = self.check_live_length(region, lengths)?;
            if range.start > range.end || range.end > span.end - span.start {
                return Err(GpuError::DirtyRange {
                    region,
                    start: range.start,
                    end: range.end,
                    capacity: span.end - span.start,
                });
            }
            let copied = clip(range.start..range.end, live);
            let source = runtime_span(self.topology, region, span.start, copied);
            check_indices(region, &indices[source], self.vertex_count, self.strips())?;
        }
        Ok(())
    }

    /// The apply pass of [`apply_dirty`](Self::apply_dirty), on a checked `dirty`: nothing here can
    /// fail. The ranges' diffs go to the mirror together, on the thread pool at a large frame
    /// switch ([`IndexMirror::write_all`](crate::gpu::upload::IndexMirror::write_all)).
    fn apply_checked<I: StripIndex>(&mut self, dirty: &Dirty, indices: &[I], lengths: &[u32]) {
        let regions = &self.region_starts;
        let topology = self.topology;
        let writes = dirty.ranges.iter().map(|range| {
            let region = range.strip as usize;
            let start = regions[region];
            let copied = clip(range.start..range.end, lengths[region]);
            (
                start + copied.start,
                &indices[runtime_span(topology, region, start, copied)],
            )
        });
        self.mirror.write_all(writes);
        for &strip in &dirty.lengths {
            let region = strip as usize;
            let start = self.region_starts[region];
            let capacity = self.region_starts[region + 1] - start - separator_slots(self.topology);
            let live = &indices[runtime_span(self.topology, region, start, 0..capacity)];
            self.resize(region, live, lengths[region]);
        }
        self.records
            .update_touched(&self.region_starts, &self.lengths);
    }

    /// The span of `region` and its new live length from `lengths`, checked against capacity.
    fn check_live_length(
        &self,
        region: usize,
        lengths: &[u32],
    ) -> Result<(Range<u32>, u32), GpuError> {
        let span = self.region_range(region).ok_or(GpuError::NoSuchRegion {
            region,
            regions: self.region_count(),
        })?;
        // `lengths` has one entry per region (checked by the caller), so this index exists.
        let live = lengths[region];
        let capacity = span.end - span.start;
        if live > capacity {
            return Err(GpuError::RegionOverflow {
                region,
                len: live as usize,
                capacity: capacity as usize,
            });
        }
        Ok((span, live))
    }
}

/// Positions `within` (relative to the region start) of `region` in a runtime's packed
/// buffer, given the region's start in an object of `topology`. A free function, so that
/// `apply_checked` can read the spans while it writes the mirror.
fn runtime_span(topology: Topology, region: usize, start: u32, within: Range<u32>) -> Range<usize> {
    let runtime_start = start - region as u32 * separator_slots(topology);
    (runtime_start + within.start) as usize..(runtime_start + within.end) as usize
}
