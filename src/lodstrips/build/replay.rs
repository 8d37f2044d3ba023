//! The replay of one collapse over the live strips: where the step starts, the rewrites of
//! `u` to `w`, the strip sets merged, the touched strips reduced, the step's record.

use super::reduce::{reduce, Region};
use super::{live_windows, Replay, Tokens};
use crate::collapse::{CollapseSequence, NEVER};
use crate::lodstrips::{push_footer, push_group, push_header, StripLayout, CURSOR_STRIDE};
use crate::varint;

impl<'a> Replay<'a> {
    /// The buffer at `S0`, every slot its own token, every vertex's strips.
    pub(super) fn new(layout: &'a StripLayout, seq: &CollapseSequence) -> Self {
        let region_offsets = &layout.region_offsets[..];
        let strips = region_offsets.len() - 1;
        let buf = layout.s0.clone();
        let total = buf.len();
        let lens: Vec<usize> = region_offsets
            .windows(2)
            .map(|w| (w[1] - w[0]) as usize)
            .collect();
        let mut tokens = Tokens {
            at: (0..total as u32).collect(),
            next: (1..=total as u32).collect(),
            death: vec![NEVER; total],
            copies: Vec::new(),
        };
        for w in region_offsets.windows(2) {
            if w[1] > w[0] {
                tokens.next[w[1] as usize - 1] = NEVER;
            }
        }
        let mut strips_of: Vec<Vec<u32>> = vec![Vec::new(); seq.vertex_count as usize];
        for s in 0..strips {
            let region = &buf[region_offsets[s] as usize..region_offsets[s + 1] as usize];
            for &v in region {
                let list = &mut strips_of[v as usize];
                if list.last() != Some(&(s as u32)) {
                    list.push(s as u32);
                }
            }
        }
        let mut triangles: Vec<u32> = Vec::with_capacity(seq.len() + 1);
        triangles.push(layout.triangles_at_0);
        Replay {
            region_offsets,
            buf,
            lens,
            tokens,
            strips_of,
            stream: Vec::new(),
            cursors: Vec::new(),
            triangles,
            rewrites: Vec::new(),
            resizes: Vec::new(),
            touched: Vec::new(),
            positions: Vec::new(),
            needed: Vec::new(),
            merged: Vec::new(),
        }
    }

    /// Every `CURSOR_STRIDE` steps, where the step starts in the stream.
    pub(super) fn mark_cursor(&mut self, step: usize) {
        if step.is_multiple_of(CURSOR_STRIDE) {
            self.cursors.push(self.stream.len() as u32);
        }
    }

    /// Every position holding `u` in the live strips becomes `w`, recorded as one rewrite
    /// group per strip; the strips touched are kept with their triangle counts before.
    pub(super) fn rewrite(&mut self, u: u32, w: u32) {
        self.rewrites.clear();
        self.resizes.clear();
        self.touched.clear();
        let mut previous = 0u32;
        for &s in &self.strips_of[u as usize] {
            let base = self.region_offsets[s as usize] as usize;
            let region = &mut self.buf[base..base + self.lens[s as usize]];
            self.positions.clear();
            self.positions.extend(
                region
                    .iter()
                    .enumerate()
                    .filter(|(_, &v)| v == u)
                    .map(|(p, _)| p as u32),
            );
            if self.positions.is_empty() {
                continue;
            }
            let before = live_windows(region);
            push_group(
                &mut self.rewrites,
                s - previous,
                self.positions.len() as u32,
            );
            previous = s;
            let mut last = 0u32;
            for &p in &self.positions {
                region[p as usize] = w;
                varint::put_u32(&mut self.rewrites, p - last);
                last = p;
            }
            self.touched.push((s, before));
        }
    }

    /// `u` is gone; the strips that held it now hold `w` (a sorted merge).
    pub(super) fn merge_strip_sets(&mut self, u: u32, w: u32) {
        self.merged.clear();
        let (mut a, mut b) = (0, 0);
        let touched = &self.touched;
        let into = &self.strips_of[w as usize];
        while a < touched.len() || b < into.len() {
            let x = touched.get(a).map_or(u32::MAX, |t| t.0);
            let y = into.get(b).copied().unwrap_or(u32::MAX);
            self.merged.push(x.min(y));
            a += usize::from(x <= y);
            b += usize::from(y <= x);
        }
        std::mem::swap(&mut self.strips_of[w as usize], &mut self.merged);
        self.strips_of[u as usize] = Vec::new();
    }

    /// Applies the reduction rules to every touched strip; returns the resize records
    /// written and the triangles the step removed.
    pub(super) fn reduce_touched(&mut self, step: usize) -> (u32, u32) {
        let mut resize_count = 0u32;
        let mut removed = 0u32;
        for (group, &(s, before)) in self.touched.iter().enumerate() {
            let base = self.region_offsets[s as usize] as usize;
            let cap = self.region_offsets[s as usize + 1] as usize;
            let live = self.lens[s as usize];
            let (new_live, count) = reduce(
                Region {
                    values: &mut self.buf[base..cap],
                    tokens: &mut self.tokens,
                    base,
                    death: step as u32 + 1,
                },
                live,
                group as u32,
                &mut self.needed,
                &mut self.resizes,
            );
            self.lens[s as usize] = new_live;
            resize_count += count;
            removed += before - live_windows(&self.buf[base..base + new_live]);
        }
        (resize_count, removed)
    }

    /// The step's record: header, rewrite groups, resizes, then the footer that lets the
    /// runtime walk the stream backward.
    pub(super) fn emit_step(&mut self, step: usize, resize_count: u32, removed: u32) {
        let start = self.stream.len();
        push_header(
            &mut self.stream,
            self.touched.len() as u32,
            resize_count,
            removed,
        );
        self.stream.extend_from_slice(&self.rewrites);
        self.stream.extend_from_slice(&self.resizes);
        let body = (self.stream.len() - start) as u32;
        push_footer(&mut self.stream, body);
        self.triangles.push(self.triangles[step] - removed);
    }
}
