//! The indirect draw records of an [`Object`](super::Object): how its regions are cut into
//! `DrawIndexedIndirectArgs` records ([`Draws`]), each record's extent from the live lengths,
//! and the CPU mirror of the indirect buffer with its changed records.

use std::ops::Range;

use wgpu::util::DrawIndexedIndirectArgs;

/// Index slots per draw record of [`Draws::Grouped`] by default: no limit, the whole object is
/// one record. Past a few dozen records the count no longer matters to the GPU (the figures
/// are in docs/benchmarks-log.md, "Figures behind constants"), so the default takes the fewest.
pub const GROUP_INDICES: u32 = u32::MAX;

/// Size of one indirect draw record.
pub(super) const ARGS_BYTES: u64 = size_of::<DrawIndexedIndirectArgs>() as u64;

/// How the regions of a [`Topology::Strip`](super::Topology::Strip) object are cut into
/// indirect draw records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draws {
    /// One record per region: record `r` draws region `r` and carries `first_instance = r`
    /// (where the device allows it), as strip colouring needs.
    PerRegion,
    /// Consecutive regions share a record while their slots (capacity plus separator) add up
    /// to at most `max_indices`; a region larger than that gets a record of its own.
    /// [`GROUP_INDICES`] by default.
    Grouped { max_indices: u32 },
}

/// The records of one object: their region boundaries, the mirror of the indirect buffer's
/// records in use (the buffer has room for one per region, the most any grouping needs) and
/// the records changed since the last upload.
pub(super) struct DrawRecords {
    /// Whether records carry their number as `first_instance` (`INDIRECT_FIRST_INSTANCE`).
    first_instance: bool,
    /// Which regions each record covers.
    records: Records,
    /// CPU mirror of the records drawn.
    pub(super) args: Vec<DrawIndexedIndirectArgs>,
    /// Changed records since the last upload, unsorted.
    pub(super) dirty: Vec<Range<u32>>,
    /// Scratch: records whose regions changed length in one call.
    touched: Vec<u32>,
}

impl DrawRecords {
    /// The records of `drawn` over the regions of `region_starts` with live `lengths`.
    pub(super) fn new(
        region_starts: &[u32],
        lengths: &[u32],
        drawn: Draws,
        first_instance: bool,
    ) -> Self {
        let mut records = Records {
            starts: Vec::new(),
            of_region: Vec::new(),
        };
        records.cut(region_starts, drawn);
        let args = (0..records.starts.len().saturating_sub(1))
            .map(|record| {
                record_args(
                    &records.starts,
                    region_starts,
                    lengths,
                    record,
                    first_instance,
                )
            })
            .collect();
        DrawRecords {
            first_instance,
            records,
            args,
            dirty: Vec::new(),
            touched: Vec::new(),
        }
    }

    /// Record `g` draws regions `starts()[g]..starts()[g + 1]`.
    pub(super) fn starts(&self) -> &[u32] {
        &self.records.starts
    }

    /// Re-cuts the records as `drawn` says; when the boundaries change, rebuilds every record
    /// from the lengths and marks them all for upload.
    pub(super) fn relayout(&mut self, region_starts: &[u32], lengths: &[u32], drawn: Draws) {
        if !self.records.cut(region_starts, drawn) {
            return;
        }
        let count = self.records.starts.len().saturating_sub(1);
        self.args.clear();
        for record in 0..count {
            let args = self.record(region_starts, lengths, record);
            self.args.push(args);
        }
        self.dirty.clear();
        if count > 0 {
            self.dirty.push(0..count as u32);
        }
    }

    /// Notes that `region` changed its live length: its record is recomputed by the next
    /// [`update_touched`](Self::update_touched).
    pub(super) fn touch_region(&mut self, region: usize) {
        self.touched.push(self.records.of_region[region]);
    }

    /// Recomputes the records of the touched regions and marks the ones that changed.
    pub(super) fn update_touched(&mut self, region_starts: &[u32], lengths: &[u32]) {
        let mut touched = std::mem::take(&mut self.touched);
        touched.sort_unstable();
        touched.dedup();
        for &record in &touched {
            let args = self.record(region_starts, lengths, record as usize);
            // Lengths only move a record's end; its start and number stay.
            if self.args[record as usize].index_count != args.index_count {
                self.args[record as usize] = args;
                self.dirty.push(record..record + 1);
            }
        }
        touched.clear();
        self.touched = touched;
    }

    /// Record `record` from the current lengths.
    fn record(
        &self,
        region_starts: &[u32],
        lengths: &[u32],
        record: usize,
    ) -> DrawIndexedIndirectArgs {
        record_args(
            &self.records.starts,
            region_starts,
            lengths,
            record,
            self.first_instance,
        )
    }
}

/// Record `record` of `record_starts`: from the start of its first region to the last live
/// index of its last non-empty region (nothing when all are empty). Ending at the last live
/// index, not at the group's end, keeps coarse levels from reading the restart tails after it.
fn record_args(
    record_starts: &[u32],
    region_starts: &[u32],
    lengths: &[u32],
    record: usize,
    first_instance: bool,
) -> DrawIndexedIndirectArgs {
    let (first, end) = (
        record_starts[record] as usize,
        record_starts[record + 1] as usize,
    );
    let first_index = region_starts[first];
    let last_live = (first..end)
        .rev()
        .find(|&r| lengths[r] > 0)
        .map_or(first_index, |r| region_starts[r] + lengths[r]);
    DrawIndexedIndirectArgs {
        index_count: last_live - first_index,
        instance_count: 1,
        first_index,
        base_vertex: 0,
        first_instance: if first_instance { record as u32 } else { 0 },
    }
}

/// Record boundaries over regions.
struct Records {
    /// Record g draws regions `starts[g]..starts[g + 1]`.
    starts: Vec<u32>,
    /// The record of every region.
    of_region: Vec<u32>,
}

impl Records {
    /// Cuts the regions of `region_starts` into records as `draws` says; returns whether the
    /// boundaries changed.
    fn cut(&mut self, region_starts: &[u32], draws: Draws) -> bool {
        let regions = region_starts.len().saturating_sub(1);
        let mut starts = Vec::with_capacity(regions + 1);
        starts.push(0u32);
        if let Draws::Grouped { max_indices } = draws {
            let mut group_start = 0usize;
            for region in 1..regions {
                // Slots from the group's first region to the end of `region`.
                let slots = region_starts[region + 1] - region_starts[group_start];
                if slots > max_indices {
                    starts.push(region as u32);
                    group_start = region;
                }
            }
        } else {
            starts.extend(1..regions as u32);
        }
        if regions > 0 {
            starts.push(regions as u32);
        }
        if starts == self.starts {
            return false;
        }
        self.of_region.clear();
        for (record, w) in starts.windows(2).enumerate() {
            self.of_region
                .extend(std::iter::repeat_n(record as u32, (w[1] - w[0]) as usize));
        }
        self.starts = starts;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::{Draws, Records};

    #[test]
    fn records_group_consecutive_regions_by_slots() {
        // Four regions of 3, 5, 2 and 9 slots (separators included).
        let starts = [0u32, 3, 8, 10, 19];
        let mut records = Records {
            starts: Vec::new(),
            of_region: Vec::new(),
        };
        assert!(records.cut(&starts, Draws::Grouped { max_indices: 10 }));
        assert_eq!(records.starts, [0, 3, 4]);
        assert_eq!(records.of_region, [0, 0, 0, 1]);
        assert!(!records.cut(&starts, Draws::Grouped { max_indices: 10 }));
        // A region larger than the budget gets a record of its own; budget 0 is per region.
        assert!(records.cut(&starts, Draws::Grouped { max_indices: 8 }));
        assert_eq!(records.starts, [0, 2, 3, 4]);
        assert!(records.cut(&starts, Draws::Grouped { max_indices: 0 }));
        assert_eq!(records.starts, [0, 1, 2, 3, 4]);
        assert!(!records.cut(&starts, Draws::PerRegion));
        assert!(records.cut(
            &starts,
            Draws::Grouped {
                max_indices: u32::MAX
            }
        ));
        assert_eq!(records.starts, [0, 4]);
        assert!(records.cut(&[0], Draws::PerRegion));
        assert_eq!(records.starts, [0]);
        assert!(records.of_region.is_empty());
    }
}
