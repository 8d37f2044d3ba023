//! Stepping: one recorded step at a time, coarsening (rewrites, then resizes) or refining
//! (resizes undone in reverse order, then rewrites).

use super::index::{dispatch, IndexBuf, StripIndex};
use super::StripsState;
use crate::lodstrips::{
    kind_len, read_group, read_header, read_resize_head, restore_removed, skip_removed,
    step_start_before, FrameChanges, KIND_B, KIND_BC, KIND_BCC, KIND_C,
};
use crate::varint;

impl StripsState {
    /// Moves to `lod` (clamped) by applying `frame`'s steps one at a time.
    /// The state must be at some LOD of `frame` (or at LOD 0 of any frame:
    /// `S0` is every frame's LOD 0).
    pub(crate) fn step_to(&mut self, frame: &FrameChanges, lod: usize) {
        let lod = lod.min(frame.max_lod());
        if lod == self.lod {
            return;
        }
        // The buffer is taken out for the steps (the rest of the state is theirs to change),
        // its width matched once.
        let mut indices = std::mem::take(&mut self.indices);
        dispatch!(IndexBuf, &mut indices, v => self.steps(frame, lod, v));
        self.indices = indices;
    }

    /// [`step_to`](Self::step_to) on the state's buffer `indices`, taken out of it.
    fn steps<I: StripIndex>(&mut self, frame: &FrameChanges, lod: usize, indices: &mut [I]) {
        while self.lod < lod {
            self.coarsen(frame, indices);
        }
        while self.lod > lod {
            self.refine(frame, indices);
        }
    }

    /// Applies step `self.lod`: rewrites `u → w`, then the resizes in order.
    fn coarsen<I: StripIndex>(&mut self, model: &FrameChanges, indices: &mut [I]) {
        let s = &model.stream;
        let (_, w) = model.collapse(self.lod);
        let mut at = self.cursor;
        let (groups, resizes, removed) = read_header(s, &mut at);
        at = self.rewrite(model, indices, at, groups, w);
        for _ in 0..resizes {
            let (group, i, len, kind) = read_resize_head(s, &mut at);
            let strip = self.group_strips[group as usize] as usize;
            skip_removed(s, &mut at, len);
            let base = self.region_offsets[strip] as usize;
            let live = self.lens[strip] as usize;
            let region = &mut indices[base..base + live];
            let new_live = cut(region, i, len, kind);
            self.live.change(live as u32, new_live as u32);
            self.lens[strip] = new_live as u32;
            self.log.mark(strip, i as u32, new_live as u32);
            self.log.mark_len(strip);
        }
        // Skip the footer, which holds the length just read.
        at += varint::len_u32((at - self.cursor) as u32);
        self.cursor = at;
        self.triangles -= removed;
        self.lod += 1;
    }

    /// Undoes step `self.lod - 1`: restores the resizes in reverse order, then
    /// writes `u` back.
    fn refine<I: StripIndex>(&mut self, model: &FrameChanges, indices: &mut [I]) {
        let s = &model.stream;
        let start = step_start_before(s, self.cursor);
        let (u, _) = model.collapse(self.lod - 1);
        let mut at = start;
        let (groups, resizes, removed) = read_header(s, &mut at);
        let rewrites = at;
        // Skip the rewrites to reach the resize records.
        self.group_strips.clear();
        let mut strip = 0u32;
        for _ in 0..groups {
            let (delta, count) = read_group(s, &mut at);
            strip += delta;
            self.group_strips.push(strip);
            for _ in 0..count {
                varint::read_u32(s, &mut at);
            }
        }
        self.scratch.clear();
        for _ in 0..resizes {
            self.scratch.push(at);
            let (_, _, len, _) = read_resize_head(s, &mut at);
            skip_removed(s, &mut at, len);
        }
        for k in (0..self.scratch.len()).rev() {
            let mut at = self.scratch[k];
            let (group, i, len, kind) = read_resize_head(s, &mut at);
            let strip = self.group_strips[group as usize] as usize;
            let base = self.region_offsets[strip] as usize;
            let live = self.lens[strip] as usize;
            let new_live = live + len - kind_len(kind);
            let region = &mut indices[base..base + new_live];
            region.copy_within(i + kind_len(kind)..live, i + len);
            restore_removed(s, &mut at, region, i, len);
            self.live.change(live as u32, new_live as u32);
            self.lens[strip] = new_live as u32;
            self.log.mark(strip, i as u32, new_live as u32);
            self.log.mark_len(strip);
        }
        self.rewrite(model, indices, rewrites, groups, u);
        self.cursor = start;
        self.triangles += removed;
        self.lod -= 1;
    }

    /// Writes `value` into `indices` at every position of the rewrite groups starting at
    /// `at`; returns the stream position after them.
    fn rewrite<I: StripIndex>(
        &mut self,
        model: &FrameChanges,
        indices: &mut [I],
        mut at: usize,
        groups: u32,
        value: u32,
    ) -> usize {
        let s = &model.stream;
        let value = I::of(value);
        let mut strip = 0usize;
        self.group_strips.clear();
        for _ in 0..groups {
            let (delta, count) = read_group(s, &mut at);
            strip += delta as usize;
            self.group_strips.push(strip as u32);
            let base = self.region_offsets[strip] as usize;
            let mut pos = 0u32;
            let mut lo = u32::MAX;
            for _ in 0..count {
                pos += varint::read_u32(s, &mut at);
                indices[base + pos as usize] = value;
                lo = lo.min(pos);
            }
            self.log.mark(strip, lo, pos + 1);
        }
        at
    }
}

/// Cuts `region[i..i+len]` (the live part of a strip is all of `region`),
/// writing the replacement `kind` made of the neighbours `B = region[i-1]`,
/// `C = region[i+len]`, and packing the tail; returns the new live length.
pub(in crate::lodstrips) fn cut<T: Copy>(
    region: &mut [T],
    i: usize,
    len: usize,
    kind: u16,
) -> usize {
    let live = region.len();
    let r = kind_len(kind);
    if r > 0 {
        let b = region[i - 1];
        let c = region[i + len];
        match kind {
            KIND_B => region[i] = b,
            KIND_C => region[i] = c,
            KIND_BC => {
                region[i] = b;
                region[i + 1] = c;
            }
            KIND_BCC => {
                region[i] = b;
                region[i + 1] = c;
                region[i + 2] = c;
            }
            _ => {}
        }
    }
    region.copy_within(i + len..live, i + r);
    live - len + r
}
