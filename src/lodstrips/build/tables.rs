//! The frame's tables from a finished replay: the copies in strip order, every entry's
//! death per strip and per block, the strips by death, the tail, each narrowed to the width
//! its values need.

use super::{Replay, Tokens};
use crate::collapse::{CollapseSequence, NEVER};
use crate::lodstrips::packed::Narrow;
use crate::lodstrips::{FrameChanges, StripLayout, Tail, CURSOR_STRIDE, DEATH_BLOCK, TAIL_SHARE};

impl Replay<'_> {
    /// Narrows the tables: collapse pairs and copy values to the vertex index
    /// width, LODs (deaths and births, `NEVER` as `max_lod + 1`) to the LOD
    /// width, copy anchors to the `S0` slot width; keeps the triangle counts
    /// only at the cursor samples.
    pub(super) fn finish(mut self, layout: &StripLayout, seq: &CollapseSequence) -> FrameChanges {
        self.cursors.push(self.stream.len() as u32);
        let total = self.buf.len();
        let max = seq.len();
        let never = as_lod(NEVER, max);
        let lod = |d| as_lod(d, max);
        let last_vertex = seq.vertex_count.saturating_sub(1);
        let copies = flatten_copies(self.region_offsets, &self.tokens);
        // Per strip, its first copy (copies are sorted by anchor, strip after strip).
        let mut first_copy = 0;
        let mut strip_copies = Vec::with_capacity(self.region_offsets.len());
        for &end in &self.region_offsets[1..] {
            strip_copies.push(first_copy as u32);
            first_copy += copies[first_copy..]
                .iter()
                .take_while(|c| c.after < end)
                .count();
        }
        strip_copies.push(first_copy as u32);
        // Per strip, the first LOD at which none of its entries (slots or copies) is alive.
        let strip_death: Vec<u32> = self
            .region_offsets
            .windows(2)
            .zip(strip_copies.windows(2))
            .map(|(slot_span, copy_span)| {
                let slots = &self.tokens.death[slot_span[0] as usize..slot_span[1] as usize];
                let copies = &copies[copy_span[0] as usize..copy_span[1] as usize];
                let slot_deaths = slots.iter().map(|&d| lod(d));
                slot_deaths
                    .chain(copies.iter().map(|c| lod(c.death)))
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        // Per block of `DEATH_BLOCK` slots, the largest death of its slots and their copies.
        let mut block_death: Vec<u32> = self.tokens.death[..total]
            .chunks(DEATH_BLOCK)
            .map(|block| block.iter().map(|&d| lod(d)).max().unwrap_or(0))
            .collect();
        for c in &copies {
            let block = &mut block_death[c.after as usize / DEATH_BLOCK];
            *block = (*block).max(lod(c.death));
        }
        let mut strips_by_death: Vec<u32> = (0..strip_death.len() as u32).collect();
        strips_by_death.sort_by_key(|&s| std::cmp::Reverse(strip_death[s as usize]));
        let deaths: Vec<u32> = self.tokens.death[..total].iter().map(|&d| lod(d)).collect();
        let tail = tail(
            layout,
            seq,
            &deaths,
            &copies,
            &strip_copies,
            &strip_death,
            &strips_by_death,
        );
        let triangle_samples = (0..self.cursors.len())
            .map(|j| self.triangles[(j * CURSOR_STRIDE).min(max)])
            .collect();
        self.stream.shrink_to_fit();
        self.cursors.shrink_to_fit();
        FrameChanges {
            collapses: Narrow::new(last_vertex, seq.collapses.iter().flat_map(|c| [c.u, c.w])),
            stream: self.stream,
            cursors: self.cursors,
            triangle_samples,
            death: Narrow::new(never, deaths),
            copy_after: Narrow::new(
                total.saturating_sub(1) as u32,
                copies.iter().map(|c| c.after),
            ),
            copy_value: Narrow::new(last_vertex, copies.iter().map(|c| c.value)),
            copy_birth: Narrow::new(never, copies.iter().map(|c| c.birth)),
            copy_death: Narrow::new(never, copies.iter().map(|c| lod(c.death))),
            strip_death: Narrow::new(never, strip_death),
            block_death: Narrow::new(never, block_death),
            strip_copies: Narrow::new(copies.len() as u32, strip_copies),
            strips_by_death: Narrow::new(
                strips_by_death.len().saturating_sub(1) as u32,
                strips_by_death,
            ),
            tail,
        }
    }
}

/// A death or birth as a LOD of a frame of `max_lod` steps: `NEVER` (alive at every LOD)
/// as `max_lod + 1`, the first LOD past the last.
fn as_lod(d: u32, max_lod: usize) -> u32 {
    if d == NEVER {
        max_lod as u32 + 1
    } else {
        d
    }
}

/// The frame's [`Tail`]: its LOD from the entries' deaths (`deaths` per `S0` slot and the
/// copies', `NEVER` already `max_lod + 1`), then its strips' entries in strip order with their
/// values mapped to their survivors there ([`CollapseSequence::survivors`]) and renumbered
/// among the vertices the tail names: the entries' values, then the vertices of the later
/// collapses.
fn tail(
    layout: &StripLayout,
    seq: &CollapseSequence,
    deaths: &[u32],
    copies: &[CopyEntry],
    strip_copies: &[u32],
    strip_death: &[u32],
    strips_by_death: &[u32],
) -> Tail {
    let max = seq.len();
    let never = as_lod(NEVER, max);
    let lod = |d| as_lod(d, max);
    // The finest LOD with at most `S0 / TAIL_SHARE` entries alive at it or later: entries
    // counted by death, added from the coarsest LOD down.
    let mut by_death = vec![0usize; max + 2];
    for &d in deaths {
        by_death[d as usize] += 1;
    }
    for c in copies {
        by_death[lod(c.death) as usize] += 1;
    }
    let budget = layout.s0.len() / TAIL_SHARE;
    let mut alive = by_death[max + 1];
    if alive > budget {
        return Tail {
            lod: never,
            ..Tail::default()
        };
    }
    let mut first = max;
    while first > 0 && alive + by_death[first] <= budget {
        alive += by_death[first];
        first -= 1;
    }
    let t = first as u32;
    let root = seq.survivors(first);
    let mut local = vec![u32::MAX; seq.vertex_count as usize];
    let mut vertices = Vec::new();
    let mut number = |v: u32| {
        let slot = &mut local[v as usize];
        if *slot == u32::MAX {
            *slot = vertices.len() as u32;
            vertices.push(v);
        }
        *slot
    };
    // The entries of the strips not empty at `t`, in strip order: each slot, then the copies
    // anchored at it.
    let strips = strips_by_death
        .iter()
        .take_while(|&&s| strip_death[s as usize] > t)
        .count();
    let (mut strip_entries, mut value, mut lifetimes) = (vec![0u32], Vec::new(), Vec::new());
    for &s in &strips_by_death[..strips] {
        let s = s as usize;
        let mut c = strip_copies[s] as usize;
        for p in layout.region_offsets[s] as usize..layout.region_offsets[s + 1] as usize {
            if deaths[p] > t {
                value.push(number(root[layout.s0[p] as usize]));
                lifetimes.extend([0, deaths[p] - t]);
            }
            while c < strip_copies[s + 1] as usize && copies[c].after as usize == p {
                let d = lod(copies[c].death);
                if d > t {
                    value.push(number(root[copies[c].value as usize]));
                    lifetimes.extend([copies[c].birth.saturating_sub(t), d - t]);
                }
                c += 1;
            }
        }
        strip_entries.push(value.len() as u32);
    }
    let collapses: Vec<u32> = seq.collapses[first..]
        .iter()
        .flat_map(|c| [number(c.u), number(c.w)])
        .collect();
    let tail_vertices = vertices.len() as u32;
    Tail {
        lod: t,
        vertices: Narrow::new(seq.vertex_count.saturating_sub(1), vertices),
        collapses: Narrow::new(tail_vertices.saturating_sub(1), collapses),
        strip_entries: Narrow::new(value.len() as u32, strip_entries),
        value: Narrow::new(tail_vertices.saturating_sub(1), value),
        lifetimes: Narrow::new(never - t, lifetimes),
    }
}

/// A copy of a neighbour written by a resize, as [`FrameChanges`] stores it
/// (one column per field there).
struct CopyEntry {
    after: u32,
    value: u32,
    birth: u32,
    death: u32,
}

/// The copies in the order of their strips' token lists, each placed after
/// the last `S0` slot that precedes it (a strip's list starts with its first
/// `S0` slot: copies are only ever linked after an existing token).
fn flatten_copies(region_offsets: &[u32], tokens: &Tokens) -> Vec<CopyEntry> {
    let s0_len = tokens.at.len() as u32;
    let mut out = Vec::with_capacity(tokens.copies.len());
    for w in region_offsets.windows(2) {
        if w[1] == w[0] {
            continue;
        }
        let mut t = w[0];
        let mut after = w[0];
        while t != NEVER {
            if t < s0_len {
                after = t;
            } else {
                let (value, birth) = tokens.copies[(t - s0_len) as usize];
                out.push(CopyEntry {
                    after,
                    value,
                    birth,
                    death: tokens.death[t as usize],
                });
            }
            t = tokens.next[t as usize];
        }
    }
    out
}
