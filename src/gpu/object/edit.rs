//! The edits of the regions by hand: a region's live indices written, and the draw records
//! re-cut when the grouping or the shade mode changes what is drawn.

use super::{Object, Topology};
use crate::gpu::checks::check_indices;
use crate::gpu::pipeline::ShadeMode;
use crate::gpu::{Draws, GpuError, RESTART};
use crate::lodstrips::{dispatch, Indices, StripIndex};

impl Object {
    /// Chooses how regions are cut into draw records. A change of the records drawn rewrites
    /// the indirect mirror, uploaded once by the next prepare; the index buffer is untouched.
    /// List objects can only draw per region (nothing separates their regions):
    /// [`GpuError::GroupedList`] otherwise, and nothing changes.
    pub fn set_draws(&mut self, draws: Draws) -> Result<(), GpuError> {
        if self.topology == Topology::List && draws != Draws::PerRegion {
            return Err(GpuError::GroupedList);
        }
        self.draws = draws;
        self.relayout_records();
        Ok(())
    }

    /// What is drawn: per region while strips are coloured (the shader reads the record
    /// number), the asked-for grouping otherwise.
    fn drawn_as(&self) -> Draws {
        match self.shade {
            ShadeMode::StripColours => Draws::PerRegion,
            ShadeMode::Faceted | ShadeMode::Smooth | ShadeMode::Textured => self.draws,
        }
    }

    /// Re-cuts the records when what is drawn changed.
    pub(super) fn relayout_records(&mut self) {
        let drawn = self.drawn_as();
        self.records
            .relayout(&self.region_starts, &self.lengths, drawn);
    }

    /// Sets the live length of `region` to `len` (at most its capacity): positions that join
    /// the live part take `live[position]`, positions that leave it take [`RESTART`] in a
    /// strip object (list objects never read their tails and leave them stale). `live` holds
    /// the region's new contents from its start, at least `len` long.
    pub(super) fn resize<I: StripIndex>(&mut self, region: usize, live: &[I], len: u32) {
        let old = self.lengths[region];
        if old == len {
            return;
        }
        let start = self.region_starts[region];
        if len > old {
            let source = &live[old as usize..len as usize];
            self.mirror
                .write(start + old, len - old, |i| source[i].into());
        } else if self.topology == Topology::Strip {
            self.mirror.write(start + len, old - len, |_| RESTART);
        }
        self.lengths[region] = len;
        self.records.touch_region(region);
    }

    /// Replaces the live indices of `region` (length 0 hides the strip).
    ///
    /// Only the positions whose value changed are marked for upload (see
    /// [`Object::set_merge_gap`] for how they are grouped into writes), so a caller may pass
    /// the whole live strip after a local edit and still upload only the changed words.
    /// Shrinking writes [`RESTART`] over the positions that leave the strip (strip objects)
    /// and may change the region's draw record. Nothing changes when an error is returned.
    /// `live` is a `&[u32]`, a `&[u16]` or a runtime's [`Indices`].
    pub fn write_region<'a>(
        &mut self,
        region: usize,
        live: impl Into<Indices<'a>>,
    ) -> Result<(), GpuError> {
        dispatch!(Indices, live.into(), live => self.write_region_of(region, live))
    }

    /// [`write_region`](Self::write_region) in the width of `live`.
    fn write_region_of<I: StripIndex>(
        &mut self,
        region: usize,
        live: &[I],
    ) -> Result<(), GpuError> {
        let range = self.region_range(region).ok_or(GpuError::NoSuchRegion {
            region,
            regions: self.region_count(),
        })?;
        let capacity = (range.end - range.start) as usize;
        if live.len() > capacity {
            return Err(GpuError::RegionOverflow {
                region,
                len: live.len(),
                capacity,
            });
        }
        check_indices(region, live, self.vertex_count, self.strips())?;

        let kept = live.len().min(self.lengths[region] as usize);
        self.mirror
            .write(range.start, kept as u32, |i| live[i].into());
        self.resize(region, live, live.len() as u32);
        self.records
            .update_touched(&self.region_starts, &self.lengths);
        Ok(())
    }
}
