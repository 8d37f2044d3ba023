//! Recording the change lists: replay the collapse sequence over `S0`.
//!
//! Step `l` (collapse `u → w`): every position holding `u` in the live strips
//! is rewritten to `w` (and recorded), then every strip that held `u` is
//! reduced. The reduction rule set, with why each keeps the drawn multiset:
//!
//! * An index is *needed* if some non-degenerate window contains it. A maximal
//!   run of unneeded indices touches only degenerate windows, so cutting it
//!   destroys nothing drawn. What the cut can break is (a) the parity of every
//!   later window, which flips if the removed length is odd, and (b) the
//!   windows created across the junction.
//! * Trailing run: removed whole (no later windows, no junction).
//! * Leading run: removed in an even length (the kept odd index is unneeded,
//!   so the first window stays degenerate; later windows keep parity).
//! * Interior run `A B [run] C D`: replaced by `r` with `|r| ≡ |run| (mod 2)`
//!   and `|r| < |run|`, choosing the first of `[]`, `[B C]` (even) or `[B]`,
//!   `[C]`, `[B C C]` (odd) for which every window of `A B r C D` is
//!   degenerate. `[B C]` and `[B C C]` always are (`A B B C C D`); `[]` covers
//!   Skip Strips' `(ab)+ → ab` and `(aa)+ → aa`. Unneeded runs stay unneeded
//!   and needed indices stay needed, so one right-to-left pass suffices.
//!
//! The runtime applies these records blindly; the oracle (tests/suite/oracle.rs)
//! checks the drawn multiset against the reference mesh after every step.
//!
//! Alongside, the build tracks where every buffer entry comes from (`Tokens`):
//! an `S0` slot or a copy made by a resize, with the LOD range it is alive in
//! and one order per strip of every entry ever alive. That is what lets the
//! runtime rebuild any LOD of a frame in one pass, bit-identical to stepping
//! (tests/suite/oracle_deform.rs compares the two).

use crate::varint;
use thiserror::Error;

use super::packed::Narrow;
use super::runtime::cut;
use super::{
    kind_len, push_footer, push_group, push_header, push_resize, FrameChanges, ResizeRun,
    StripLayout, Tail, CURSOR_STRIDE, DEATH_BLOCK, KIND_B, KIND_BC, KIND_BCC, KIND_C, KIND_NONE,
    TAIL_SHARE,
};
use crate::collapse::{CollapseSequence, SequenceError, NEVER};
use crate::strip::Strips;

/// Why a model cannot be built from these strips and this sequence.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ChangeListError {
    #[error(transparent)]
    Sequence(#[from] SequenceError),
    #[error("strip offsets are malformed at entry {entry}: offsets must start at 0, never decrease and end at the index count {indices}; rebuild the strips with strip::stripify")]
    BadOffsets { entry: usize, indices: usize },
    #[error("strip index {index} at position {position} is not a vertex of the {vertices}-vertex mesh the sequence was built for; strips and sequence must come from the same mesh")]
    IndexOutOfRange {
        position: usize,
        index: u32,
        vertices: usize,
    },
    #[error("the collapse sequence is for {sequence} vertices but the strips index a {strips}-vertex mesh; build both from the same mesh")]
    VertexCount { sequence: usize, strips: usize },
    #[error("the vertex count is {vertices}, above the supported {limit}; split the mesh")]
    TooManyVertices { vertices: usize, limit: usize },
    #[error("the strip index count is {indices}, above the supported {limit}; split the mesh")]
    TooManyIndices { indices: usize, limit: usize },
}

/// Largest vertex count and strip length the change stream encodes.
const VERTEX_LIMIT: usize = 1 << 31;
const INDEX_LIMIT: usize = 1 << 28;

fn degenerate(a: u32, b: u32, c: u32) -> bool {
    a == b || b == c || a == c
}

fn live_windows(strip: &[u32]) -> u32 {
    strip
        .windows(3)
        .filter(|w| !degenerate(w[0], w[1], w[2]))
        .count() as u32
}

pub(super) fn layout(s0: &Strips, vertex_count: u32) -> Result<StripLayout, ChangeListError> {
    let vertices = vertex_count as usize;
    if vertices > VERTEX_LIMIT {
        return Err(ChangeListError::TooManyVertices {
            vertices,
            limit: VERTEX_LIMIT,
        });
    }
    let total = s0.indices.len();
    if total > INDEX_LIMIT {
        return Err(ChangeListError::TooManyIndices {
            indices: total,
            limit: INDEX_LIMIT,
        });
    }
    match s0.offsets.first() {
        Some(0) => {}
        None if total == 0 => {}
        _ => {
            return Err(ChangeListError::BadOffsets {
                entry: 0,
                indices: total,
            })
        }
    }
    for (entry, w) in s0.offsets.windows(2).enumerate() {
        if w[1] < w[0] {
            return Err(ChangeListError::BadOffsets {
                entry: entry + 1,
                indices: total,
            });
        }
    }
    if let Some(&last) = s0.offsets.last() {
        if last as usize != total {
            return Err(ChangeListError::BadOffsets {
                entry: s0.offsets.len() - 1,
                indices: total,
            });
        }
    }
    if let Some(position) = s0.indices.iter().position(|&v| v as usize >= vertices) {
        return Err(ChangeListError::IndexOutOfRange {
            position,
            index: s0.indices[position],
            vertices,
        });
    }
    let region_offsets = if s0.offsets.is_empty() {
        vec![0]
    } else {
        s0.offsets.clone()
    };
    let triangles_at_0: u32 = region_offsets
        .windows(2)
        .map(|w| live_windows(&s0.indices[w[0] as usize..w[1] as usize]))
        .sum();
    Ok(StripLayout {
        region_offsets: region_offsets.into(),
        s0: s0.indices.clone(),
        vertex_count,
        triangles_at_0,
    })
}

/// The build's view of entry lifetimes: a token per strip entry (`S0` slots
/// are tokens `0..|S0|`, copies follow), kept parallel to the live strips, and
/// the order of all tokens ever alive as a linked list per strip. A copy is
/// linked right after the last token of the run it replaces: every token
/// between there and the run's right neighbour is dead for good, so the order
/// of the tokens alive at any LOD is the strip's order at that LOD.
struct Tokens {
    /// Token at each buffer position (same layout as the buffer).
    at: Vec<u32>,
    /// Next token in the strip's order, or `NEVER` at the end.
    next: Vec<u32>,
    /// Death LOD of every token (`NEVER` while alive).
    death: Vec<u32>,
    /// `(value, birth)` of the copy tokens: token `|S0| + i` is `copies[i]`.
    copies: Vec<(u32, u32)>,
}

/// The change lists of one frame: replay `seq` over `S0`, one named stage after another
/// per collapse (the module docs give the rules each stage follows).
pub(super) fn frame(
    layout: &StripLayout,
    seq: &CollapseSequence,
) -> Result<FrameChanges, ChangeListError> {
    check_sequence(layout, seq)?;
    let mut replay = Replay::new(layout, seq);
    for (step, c) in seq.collapses.iter().enumerate() {
        replay.mark_cursor(step);
        replay.rewrite(c.u, c.w);
        replay.merge_strip_sets(c.u, c.w);
        let (resizes, removed) = replay.reduce_touched(step);
        replay.emit_step(step, resizes, removed);
    }
    Ok(replay.finish(layout, seq))
}

/// A sequence valid on its own and made for the layout's vertex count.
fn check_sequence(layout: &StripLayout, seq: &CollapseSequence) -> Result<(), ChangeListError> {
    seq.validate()?;
    if seq.vertex_count != layout.vertex_count {
        return Err(ChangeListError::VertexCount {
            sequence: seq.vertex_count as usize,
            strips: layout.vertex_count as usize,
        });
    }
    Ok(())
}

/// The state of one frame's replay over `S0`: the live strips, where each entry came from,
/// and the stream recorded so far, with scratch buffers reused from step to step.
struct Replay<'a> {
    region_offsets: &'a [u32],
    /// The index buffer (all regions at their `S0` capacity).
    buf: Vec<u32>,
    /// Live length of each strip.
    lens: Vec<usize>,
    tokens: Tokens,
    /// Vertex → sorted strips that may hold it (a superset: merged on collapse).
    strips_of: Vec<Vec<u32>>,
    stream: Vec<u8>,
    cursors: Vec<u32>,
    /// Triangles drawn after each step (`triangles[0]`: at `S0`).
    triangles: Vec<u32>,
    /// This step's rewrite groups and resize records.
    rewrites: Vec<u8>,
    resizes: Vec<u8>,
    /// This step's strips that held `u`, with their live triangles before the step.
    touched: Vec<(u32, u32)>,
    positions: Vec<u32>,
    needed: Vec<bool>,
    merged: Vec<u32>,
}

impl<'a> Replay<'a> {
    /// The buffer at `S0`, every slot its own token, every vertex's strips.
    fn new(layout: &'a StripLayout, seq: &CollapseSequence) -> Self {
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
    fn mark_cursor(&mut self, step: usize) {
        if step.is_multiple_of(CURSOR_STRIDE) {
            self.cursors.push(self.stream.len() as u32);
        }
    }

    /// Every position holding `u` in the live strips becomes `w`, recorded as one rewrite
    /// group per strip; the strips touched are kept with their triangle counts before.
    fn rewrite(&mut self, u: u32, w: u32) {
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
    fn merge_strip_sets(&mut self, u: u32, w: u32) {
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
    fn reduce_touched(&mut self, step: usize) -> (u32, u32) {
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
    fn emit_step(&mut self, step: usize, resize_count: u32, removed: u32) {
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

    /// Narrows the tables: collapse pairs and copy values to the vertex index
    /// width, LODs (deaths and births, `NEVER` as `max_lod + 1`) to the LOD
    /// width, copy anchors to the `S0` slot width; keeps the triangle counts
    /// only at the cursor samples.
    fn finish(mut self, layout: &StripLayout, seq: &CollapseSequence) -> FrameChanges {
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

/// A strip's region of the build buffer with the token bookkeeping beside it.
struct Region<'a> {
    values: &'a mut [u32],
    tokens: &'a mut Tokens,
    /// Start of the region in the whole buffer (and in `tokens.at`).
    base: usize,
    /// The LOD from which this step's cuts hold (the step index + 1).
    death: u32,
}

impl Region<'_> {
    /// Cuts `values[i..i+len]` of the live `values[..live]` like
    /// [`cut`], and records the lifetimes: the run's tokens die, the
    /// replacement's copies are born and linked after the run's last token.
    fn cut(&mut self, live: usize, i: usize, len: usize, kind: u16) -> usize {
        let at = &mut self.tokens.at[self.base..self.base + live];
        let mut link = at[i + len - 1];
        let after_run = self.tokens.next[link as usize];
        for &t in &at[i..i + len] {
            self.tokens.death[t as usize] = self.death;
        }
        let copy_count = kind_len(kind);
        for k in 0..copy_count {
            // Cuts write B copies first, then C copies (see `cut`).
            let from = if k == 0 && kind != KIND_C {
                i - 1
            } else {
                i + len
            };
            let id = (self.tokens.death.len()) as u32;
            self.tokens.copies.push((self.values[from], self.death));
            self.tokens.death.push(NEVER);
            self.tokens.next.push(after_run);
            self.tokens.next[link as usize] = id;
            link = id;
            at[i + k] = id;
        }
        at.copy_within(i + len..live, i + copy_count);
        cut(&mut self.values[..live], i, len, kind)
    }
}

/// Cuts the unneeded runs of the strip `region[..live]` right to left,
/// appending one record per cut; returns the new live length and the count.
/// Records name the strip by its rewrite group in this step (`group`): a
/// strip is only reduced where the step rewrote it, and the index is smaller.
fn reduce(
    mut region: Region,
    live: usize,
    group: u32,
    needed: &mut Vec<bool>,
    out: &mut Vec<u8>,
) -> (usize, u32) {
    needed.clear();
    needed.resize(live, false);
    for k in 0..live.saturating_sub(2) {
        if !degenerate(region.values[k], region.values[k + 1], region.values[k + 2]) {
            needed[k..k + 3].fill(true);
        }
    }
    let mut current = live;
    let mut count = 0;
    let mut j = live;
    while j > 0 {
        if needed[j - 1] {
            j -= 1;
            continue;
        }
        let mut i = j;
        while i > 0 && !needed[i - 1] {
            i -= 1;
        }
        let cut_at = if j == current {
            Some((i, j - i, KIND_NONE))
        } else if i == 0 {
            let len = j & !1;
            (len > 0).then_some((0, len, KIND_NONE))
        } else {
            junction(&region.values[..current], i, j).map(|kind| (i, j - i, kind))
        };
        if let Some((at, len, kind)) = cut_at {
            let values = &region.values[..current];
            push_resize(out, group, at as u32, kind, ResizeRun::new(values, at, len));
            current = region.cut(current, at, len, kind);
            count += 1;
        }
        j = i;
    }
    (current, count)
}

/// The shortest replacement for the interior run `strip[i..j]` that keeps
/// length parity and leaves every junction window degenerate, if shorter.
fn junction(strip: &[u32], i: usize, j: usize) -> Option<u16> {
    let len = j - i;
    let b = strip[i - 1];
    let c = strip[j];
    let a = i.checked_sub(2).map(|k| strip[k]);
    let d = strip.get(j + 1).copied();
    let candidates: &[u16] = if len.is_multiple_of(2) {
        &[KIND_NONE, KIND_BC]
    } else {
        &[KIND_B, KIND_C, KIND_BCC]
    };
    candidates.iter().copied().find(|&kind| {
        if kind_len(kind) >= len {
            return false;
        }
        let mut seq = [0u32; 7];
        let mut n = 0;
        let mut put = |v: u32| {
            seq[n] = v;
            n += 1;
        };
        if let Some(a) = a {
            put(a);
        }
        put(b);
        match kind {
            KIND_B => put(b),
            KIND_C => put(c),
            KIND_BC => {
                put(b);
                put(c);
            }
            KIND_BCC => {
                put(b);
                put(c);
                put(c);
            }
            _ => {}
        }
        put(c);
        if let Some(d) = d {
            put(d);
        }
        seq[..n].windows(3).all(|w| degenerate(w[0], w[1], w[2]))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collapse::canonical_multiset;
    use crate::lodstrips::{LodError, LodStrips, StripsState};
    use crate::strip::strip_triangles;

    fn seq(n: u32, pairs: &[(u32, u32)]) -> CollapseSequence {
        CollapseSequence::from_pairs(n, pairs)
    }

    fn drawn(model: &LodStrips, state: &StripsState) -> Vec<[u32; 3]> {
        let mut t = Vec::new();
        for s in 0..model.strip_count() {
            t.extend(strip_triangles(state.strip(s).unwrap_or_default()));
        }
        canonical_multiset(t)
    }

    #[test]
    fn rejects_bad_inputs() {
        let strips = Strips {
            indices: vec![0, 1, 2],
            offsets: vec![0, 3],
        };
        let bad = Strips {
            indices: vec![0, 1, 2],
            offsets: vec![0, 2],
        };
        assert!(matches!(
            LodStrips::build(&bad, &seq(3, &[])),
            Err(ChangeListError::BadOffsets { .. })
        ));
        assert!(matches!(
            LodStrips::build(&strips, &seq(2, &[])),
            Err(ChangeListError::IndexOutOfRange { index: 2, .. })
        ));
        assert!(matches!(
            LodStrips::build(&strips, &seq(3, &[(0, 0)])),
            Err(ChangeListError::Sequence(_))
        ));
    }

    #[test]
    fn junctions_never_join_vertices_into_a_new_triangle() {
        // Strip 0: collapsing 3 → 2 and 4 → 5 leaves `0 1 2 2 5 5 6 7`; the
        // middle `2 5` is unneeded, but cutting it would draw (1, 2, 5) and
        // (2, 5, 6). Strip 1: `8 9 10 10 10 10 11 12` after 13, 14 → 10 may
        // lose two 10s (`(aa)+ → aa`), never three (the trap described in `docs/DESIGN.md`).
        let indices = vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 13, 14, 10, 11, 12];
        let strips = Strips {
            indices: indices.clone(),
            offsets: vec![0, 8, 16],
        };
        let tris = strips.triangles();
        let s = seq(15, &[(3, 2), (4, 5), (13, 10), (14, 10)]);
        let model = LodStrips::build(&strips, &s).unwrap();
        let mut state = StripsState::new(&model);
        for l in [2, 4, 1, 3, 0, 4, 2, 0] {
            state.set_lod(&model, l).unwrap();
            assert_eq!(
                drawn(&model, &state),
                canonical_multiset(s.reference_mesh(&tris, l))
            );
            assert_eq!(state.triangle_count(), s.reference_mesh(&tris, l).len());
        }
        state.set_lod(&model, 4).unwrap();
        assert_eq!(state.strip(0).unwrap(), &[0, 1, 2, 2, 5, 5, 6, 7]);
        assert_eq!(state.strip(1).unwrap(), &[8, 9, 10, 10, 11, 12]);
    }

    #[test]
    fn dead_strip_vanishes_and_comes_back() {
        let strips = Strips {
            indices: vec![0, 1, 2, 3],
            offsets: vec![0, 4],
        };
        let s = seq(4, &[(3, 2), (2, 1)]);
        let model = LodStrips::build(&strips, &s).unwrap();
        let mut state = StripsState::new(&model);
        state.set_lod(&model, 2).unwrap();
        assert_eq!(state.index_count(), 0);
        state.set_lod(&model, 0).unwrap();
        assert_eq!(state.strip(0).unwrap_or_default(), &[0, 1, 2, 3]);
        let dirty = state.take_dirty();
        assert_eq!(dirty.lengths, vec![0]);
        assert_eq!(state.strip(1), None);
        let other = LodStrips::build(&strips, &s).unwrap();
        assert_eq!(state.set_lod(&other, 1), Err(LodError::WrongModel));
    }
}
