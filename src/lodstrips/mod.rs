//! The LodStrips model over the common strips `S0`: change lists recorded by
//! replaying a collapse sequence over the strips (`build/`), and the runtime
//! that applies them in both directions to an index buffer laid out as one
//! fixed region per strip (`runtime/`).
//!
//! The data is split so that a deforming object shares everything it can:
//! [`StripLayout`] (`S0` and the region table) exists once per object, and
//! each sampled frame owns only a [`FrameChanges`] (its collapse pairs,
//! change stream, sampled triangle counts and the entry lifetimes of one-pass
//! rebuilds, in `u16` where the mesh allows). [`LodStrips`] pairs one layout
//! with one frame for a static mesh.
//!
//! Each LOD step `l` (collapse `u → w`) is recorded as
//! * rewrites: the positions in the strips that hold `u` at LOD `l`
//!   (coarsening writes `w` there, refining writes `u` back), and
//! * resizes: degenerate runs cut out of a strip, each replaced by at most three
//!   copies of its neighbours. Refining restores the run from the record.
//!
//! Why a resize keeps every drawn triangle (see `build/` for the rule set):
//! a run is removed only if every window touching it is degenerate, the
//! replacement has the same length parity (so every later window keeps its
//! parity, hence its orientation), and every window created at the junction is
//! degenerate. Leading runs are removed in even lengths, trailing runs whole.
//!
//! The change stream is a flat `Vec<u8>`, mostly LEB128 numbers: rewrite
//! positions delta-coded per strip; per cut a one-byte head (group, kind,
//! length) and its position, the removed indices as 2-bit symbols (repeat the
//! index before, the right neighbour, the index two before, or an escape to a
//! zigzag difference; see `push_resize`). Each step ends with its own length,
//! readable backward, so the runtime walks the stream in both directions from
//! a cursor without an offset table.

mod build;
pub(crate) mod increasing;
pub(crate) mod packed;
mod runtime;

pub use build::ChangeListError;
#[cfg(feature = "gpu")]
pub(crate) use runtime::dispatch;
#[cfg(feature = "gpu")]
pub(crate) use runtime::for_each_live;
pub(crate) use runtime::StripIndex;
pub(crate) use runtime::Survivors;
pub use runtime::PARALLEL_SLOTS;
pub use runtime::{Dirty, DirtyRange, IndexWidth, Indices, LodError, StripsState};

use crate::collapse::CollapseSequence;
use crate::strip::Strips;
use crate::varint;
use packed::Narrow;
use std::sync::Arc;

/// Replacement kinds of a resize: the run `s[i..i+len]` is replaced by copies
/// of its neighbours `B = s[i-1]` and `C = s[i+len]`.
const KIND_NONE: u16 = 0;
const KIND_B: u16 = 1;
const KIND_C: u16 = 2;
const KIND_BC: u16 = 3;
const KIND_BCC: u16 = 4;

/// Number of indices a replacement kind writes.
fn kind_len(kind: u16) -> usize {
    match kind {
        KIND_NONE => 0,
        KIND_B | KIND_C => 1,
        KIND_BC => 2,
        _ => 3,
    }
}

/// The index-buffer layout shared by every frame of a deforming object: `S0`
/// and its region table. Frames differ only in their [`FrameChanges`].
#[derive(Clone, Debug, Default)]
pub struct StripLayout {
    /// Region `i` of the index buffer is `region_offsets[i]..region_offsets[i+1]`
    /// (the length of strip `i` in `S0`). Shared with every state of the layout: a crowd's
    /// thousand instances read one warm table, not a copy each (4 KB per body instance).
    region_offsets: Arc<[u32]>,
    /// `S0` itself: the buffer contents at LOD 0.
    s0: Vec<u32>,
    /// Vertices the strips index into.
    vertex_count: u32,
    /// Triangles drawn at LOD 0.
    triangles_at_0: u32,
}

impl StripLayout {
    /// Checks `s0` (offsets well formed, every index below `vertex_count`) and
    /// takes it as the common layout.
    pub fn new(s0: &Strips, vertex_count: u32) -> Result<StripLayout, ChangeListError> {
        build::layout(s0, vertex_count)
    }

    /// Number of strips, i.e. of index-buffer regions (one draw each).
    pub fn strip_count(&self) -> usize {
        self.region_offsets.len().saturating_sub(1)
    }

    /// Region offsets into the index buffer (`strip_count() + 1` entries).
    pub fn region_offsets(&self) -> &[u32] {
        &self.region_offsets
    }

    /// `S0`: the index buffer at LOD 0, all regions full.
    pub fn s0(&self) -> &[u32] {
        &self.s0
    }

    pub fn vertex_count(&self) -> usize {
        self.vertex_count as usize
    }

    /// Triangles drawn at LOD 0.
    pub fn triangle_count(&self) -> usize {
        self.triangles_at_0 as usize
    }

    /// Bytes of `S0` and the region table.
    pub fn byte_size(&self) -> usize {
        (self.s0.len() + self.region_offsets.len()) * 4 + 8
    }
}

/// One collapse sequence's change lists over a [`StripLayout`]: what a frame
/// of a deforming object owns.
///
/// Besides the change stream it keeps the *entry lifetimes* that let a state
/// be rebuilt at any LOD in one pass (`runtime/`): every value the buffer
/// ever holds at LOD `l` is `anc_l` of an `S0` slot's value or of a copied
/// neighbour's value, and resizes only remove contiguous runs and put copies in
/// their place, so the buffer at LOD `l` is exactly the entries alive at `l`,
/// in a fixed order, mapped through `anc_l`.
///
/// Every table is stored in the narrowest of `u16` and `u32` that holds its
/// largest value (a vertex index, a LOD or an `S0` slot). The triangle count
/// per LOD is not kept: it is sampled beside the stream cursors and the steps
/// between two samples are read from the step headers, which hold the
/// triangles each step removes.
#[derive(Clone, Debug, Default)]
pub struct FrameChanges {
    /// `u` of step `j` at `2j`, `w` at `2j + 1`.
    collapses: Narrow,
    /// The change stream, see the module docs.
    stream: Vec<u8>,
    /// Stream position where step `min(j · CURSOR_STRIDE, max_lod)` starts.
    cursors: Vec<u32>,
    /// Triangles drawn at step `min(j · CURSOR_STRIDE, max_lod)`, beside `cursors`.
    triangle_samples: Vec<u32>,
    /// Per `S0` slot: the first LOD at which it is cut out (`max_lod + 1` if never).
    death: Narrow,
    /// A copy of a neighbour written by a resize (replacement kinds `B`, `C`,
    /// `BC`, `BCC`), one column each, sorted by `after` (then by order within
    /// the strip). Copy `i` lives in its strip for LODs
    /// `copy_birth[i]..copy_death[i]` and sits, in the strip's order of all
    /// entries ever alive, right after the `S0` slot `copy_after[i]` (and
    /// after earlier copies there). `copy_value[i]` is the neighbour's value
    /// when copied; at LOD `l ≥ birth` the entry holds `anc_l(value)` because
    /// every later rewrite maps it along.
    copy_after: Narrow,
    copy_value: Narrow,
    copy_birth: Narrow,
    copy_death: Narrow,
    /// Per strip, the first LOD at which none of its entries is alive (the largest death
    /// among its slots and copies): a rebuild at that LOD or coarser skips the strip
    /// without reading its entries.
    strip_death: Narrow,
    /// Per block of [`DEATH_BLOCK`] consecutive `S0` slots (block `k` holds slots
    /// `k · DEATH_BLOCK..`, across strip bounds), the largest death among its slots and the
    /// copies anchored at them: a rebuild at LOD `l` skips a block whose largest death is at
    /// most `l` without reading its slots, so at a coarse LOD it reads the few blocks that
    /// hold something alive, not the dead slots of long strips.
    block_death: Narrow,
    /// Per strip, its first copy (`strip count + 1` entries, the last the copy count): a
    /// strip's copies are `strip_copies[s]..strip_copies[s + 1]`.
    strip_copies: Narrow,
    /// The strips sorted by `strip_death`, latest first: those not empty at LOD `l` are a
    /// prefix.
    strips_by_death: Narrow,
    /// The entries still alive past a coarse LOD, for rebuilds there.
    tail: Tail,
}

/// The entries of a frame alive at its coarse LOD `lod` or later, for rebuilds at `lod` or
/// coarser (a crowd's distant instances): in the order of `strips_by_death`'s prefix of strips
/// not empty at `lod`, each strip's entries in strip order, with the survivor at `lod` of their
/// value, numbered among the few vertices the tail names, and their lifetimes counted from
/// `lod`. Such a rebuild reads these entries and links the tail's collapses over the tail's
/// vertices, instead of reading the strips' live blocks and linking every collapse over every
/// vertex. `lod` is the finest LOD at which at most `S0 / TAIL_SHARE` entries are alive then
/// or later (`max_lod + 1`: no tail, the tables empty).
#[derive(Clone, Debug, Default)]
pub(crate) struct Tail {
    lod: u32,
    /// Tail vertex → the mesh's vertex.
    vertices: Narrow,
    /// Steps `lod..max_lod` as tail vertices: `u` of step `lod + j` at `2j`, `w` at `2j + 1`.
    collapses: Narrow,
    /// Per strip of the prefix, its first entry (prefix length + 1 entries).
    strip_entries: Narrow,
    /// Per entry: its value's survivor at `lod` (a tail vertex).
    value: Narrow,
    /// Per entry at `2e` and `2e + 1`: the first LOD it is alive at and the first it is not,
    /// both minus `lod` (`0` for entries born by then); one table, so that a rebuild picks
    /// the widths of its loop once per strip.
    lifetimes: Narrow,
}

/// A frame keeps a [`Tail`] of at most `S0 / TAIL_SHARE` entries (about 6 bytes each, plus
/// its vertices and collapses).
pub(crate) const TAIL_SHARE: usize = 128;

impl Tail {
    fn byte_size(&self) -> usize {
        self.vertices.byte_size()
            + self.collapses.byte_size()
            + self.strip_entries.byte_size()
            + self.value.byte_size()
            + self.lifetimes.byte_size()
    }

    /// `(u, w)` of step `lod + j` in tail vertices.
    #[inline]
    fn collapse(&self, j: usize) -> (u32, u32) {
        (self.collapses.get(2 * j), self.collapses.get(2 * j + 1))
    }
}

/// `S0` slots per entry of a frame's `block_death`: 2 bytes per 16 slots (0.4 B per vertex on
/// the head) against the one order per entry (6 B per vertex) it replaced, at a rebuild cost
/// within noise of it (docs/benchmarks-log.md, "A frame's memory back to ~28.5 B").
pub(crate) const DEATH_BLOCK: usize = 16;

/// Every this many steps the stream position is kept, so a rebuilt state
/// finds its cursor by walking at most this many step footers backward.
const CURSOR_STRIDE: usize = 64;

impl FrameChanges {
    /// Records the change lists of `seq` over `layout`.
    pub fn build(
        layout: &StripLayout,
        seq: &CollapseSequence,
    ) -> Result<FrameChanges, ChangeListError> {
        build::frame(layout, seq)
    }

    /// The highest LOD (number of collapses).
    pub fn max_lod(&self) -> usize {
        self.collapses.len() / 2
    }

    /// `(u, w)` of step `step` (`step < max_lod()`).
    #[inline]
    pub(crate) fn collapse(&self, step: usize) -> (u32, u32) {
        (
            self.collapses.get(2 * step),
            self.collapses.get(2 * step + 1),
        )
    }

    /// Triangles drawn at LOD `lod` (clamped to `max_lod()`).
    pub fn triangles_at(&self, lod: usize) -> usize {
        self.seek(lod).1 as usize
    }

    /// Triangles drawn at each LOD `0..=max_lod()`; never increasing. Computed
    /// by one walk over the stream (the frame keeps only samples).
    pub fn triangle_counts(&self) -> Vec<u32> {
        let max = self.max_lod();
        let mut out = vec![0u32; max + 1];
        let mut at = self.stream.len();
        let mut tris = *self.triangle_samples.last().unwrap_or(&0);
        out[max] = tris;
        for step in (0..max).rev() {
            at = step_start_before(&self.stream, at);
            tris += step_removed(&self.stream, at);
            out[step] = tris;
        }
        out
    }

    /// The finest LOD that draws at most `budget` triangles (the coarsest LOD
    /// if even that draws more): a binary search over the samples, then a walk
    /// over at most `CURSOR_STRIDE` step headers.
    pub fn finest_within(&self, budget: usize) -> usize {
        let budget = u32::try_from(budget).unwrap_or(u32::MAX);
        let max = self.max_lod();
        let j = self.triangle_samples.partition_point(|&t| t > budget);
        if j == 0 {
            return 0;
        }
        if j == self.triangle_samples.len() {
            return max;
        }
        let mut step = (j * CURSOR_STRIDE).min(max);
        let mut at = self.cursors[j] as usize;
        let mut tris = self.triangle_samples[j];
        while step > (j - 1) * CURSOR_STRIDE {
            let start = step_start_before(&self.stream, at);
            let before = tris + step_removed(&self.stream, start);
            if before > budget {
                break;
            }
            (step, at, tris) = (step - 1, start, before);
        }
        step
    }

    /// Bytes of the change stream alone.
    pub fn change_bytes(&self) -> usize {
        self.stream.len()
    }

    /// Number of copy entries (see the type docs), for size reports.
    pub fn copy_count(&self) -> usize {
        self.copy_after.len()
    }

    /// Bytes this frame holds in RAM: collapse pairs, change stream, cursor
    /// and triangle samples and the entry lifetimes used by rebuilds.
    pub fn byte_size(&self) -> usize {
        self.collapses.byte_size()
            + self.stream.len()
            + (self.cursors.len() + self.triangle_samples.len()) * 4
            + self.death.byte_size()
            + self.copy_after.byte_size()
            + self.copy_value.byte_size()
            + self.copy_birth.byte_size()
            + self.copy_death.byte_size()
            + self.strip_death.byte_size()
            + self.block_death.byte_size()
            + self.strip_copies.byte_size()
            + self.strips_by_death.byte_size()
            + self.tail.byte_size()
    }

    /// How many strips are not empty at LOD `l` (the prefix of `strips_by_death`).
    fn strips_alive(&self, l: u32) -> usize {
        self.strips_by_death
            .partition_point(|s| self.strip_death.get(s as usize) > l)
    }

    /// Stream position where step `lod` starts and the triangles drawn there:
    /// from the next kept sample, walk back over step footers (at most
    /// `CURSOR_STRIDE - 1` of them), adding the triangles each step removed.
    fn seek(&self, lod: usize) -> (usize, u32) {
        let lod = lod.min(self.max_lod());
        let sample = lod.div_ceil(CURSOR_STRIDE);
        let (mut step, mut at, mut tris) = if sample * CURSOR_STRIDE <= self.max_lod() {
            (
                sample * CURSOR_STRIDE,
                self.cursors[sample] as usize,
                self.triangle_samples[sample],
            )
        } else {
            (
                self.max_lod(),
                self.stream.len(),
                *self.triangle_samples.last().unwrap_or(&0),
            )
        };
        while step > lod {
            at = step_start_before(&self.stream, at);
            tris += step_removed(&self.stream, at);
            step -= 1;
        }
        (at, tris)
    }

    /// Work units of a one-pass rebuild at `lod` from scratch (entries to visit plus
    /// survivors to link), for choosing between a rebuild and stepping. An upper bound:
    /// the rebuild skips strips that are empty at `lod`, and a crowd's rebuilds of one
    /// frame share the survivors. At the tail's LODs, the tail's entries, vertices and
    /// collapses to link.
    pub fn rebuild_work(&self, layout: &StripLayout, lod: usize) -> usize {
        let lod = lod.min(self.max_lod());
        if self.rebuilds_from_tail(lod) {
            let tail = &self.tail;
            return tail.value.len() + tail.vertices.len() + lod - tail.lod as usize;
        }
        self.death.len() + self.copy_count() + layout.vertex_count() + lod
    }

    /// A rebuild at `lod` reads the frame's [`Tail`] alone (no survivor table over the mesh:
    /// such rebuilds gain nothing from being grouped by frame).
    pub(crate) fn rebuilds_from_tail(&self, lod: usize) -> bool {
        lod.min(self.max_lod()) as u32 >= self.tail.lod
    }

    /// The first LOD of the frame's [`Tail`] (past `max_lod()`: it has none) and its entries.
    #[cfg(test)]
    pub(crate) fn tail_extent(&self) -> (usize, usize) {
        (self.tail.lod as usize, self.tail.value.len())
    }

    /// The first copy of strip `s` (its copies are sorted by anchor, after earlier strips').
    #[inline]
    fn first_copy(&self, s: usize) -> usize {
        self.strip_copies.get(s) as usize
    }
}

/// The model for one collapse sequence: its layout and its change lists.
#[derive(Clone, Debug, Default)]
pub struct LodStrips {
    layout: StripLayout,
    frame: FrameChanges,
    /// Identifies the model a [`StripsState`] was made for (clones share it).
    id: u64,
}

/// Source of model ids: a state must only follow the stream it was made for.
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// A fresh model id.
pub(crate) fn next_id() -> u64 {
    NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl LodStrips {
    /// Records the change lists of `seq` over the strips `s0`.
    pub fn build(s0: &Strips, seq: &CollapseSequence) -> Result<LodStrips, ChangeListError> {
        let layout = StripLayout::new(s0, seq.vertex_count)?;
        let frame = FrameChanges::build(&layout, seq)?;
        Ok(LodStrips {
            layout,
            frame,
            id: next_id(),
        })
    }

    /// The highest LOD (number of collapses).
    pub fn max_lod(&self) -> usize {
        self.frame.max_lod()
    }

    /// Number of strips, i.e. of index-buffer regions (one draw each).
    pub fn strip_count(&self) -> usize {
        self.layout.strip_count()
    }

    /// Region offsets into the index buffer (`strip_count() + 1` entries).
    pub fn region_offsets(&self) -> &[u32] {
        self.layout.region_offsets()
    }

    /// Bytes of the change lists alone (the stream).
    pub fn change_bytes(&self) -> usize {
        self.frame.change_bytes()
    }

    /// Bytes of the whole model: the layout and the frame's data.
    pub fn byte_size(&self) -> usize {
        self.layout.byte_size() + self.frame.byte_size()
    }
}

/// Step header: counts of rewrite groups, resizes and removed triangles. The
/// common small case (most collapses touch a few strips and remove two
/// triangles) fits one byte; `0xFF` escapes to three numbers.
fn push_header(out: &mut Vec<u8>, groups: u32, resizes: u32, removed: u32) {
    if groups < 15 && resizes < 4 && removed < 4 {
        out.push((groups | resizes << 4 | removed << 6) as u8);
    } else {
        out.push(0xFF);
        varint::put_u32(out, groups);
        varint::put_u32(out, resizes);
        varint::put_u32(out, removed);
    }
}

/// Triangles removed by the step whose header starts at `at`.
fn step_removed(stream: &[u8], at: usize) -> u32 {
    let mut at = at;
    read_header(stream, &mut at).2
}

fn read_header(stream: &[u8], at: &mut usize) -> (u32, u32, u32) {
    let h = stream[*at];
    *at += 1;
    if h != 0xFF {
        let h = u32::from(h);
        (h & 15, (h >> 4) & 3, h >> 6)
    } else {
        let groups = varint::read_u32(stream, at);
        let resizes = varint::read_u32(stream, at);
        (groups, resizes, varint::read_u32(stream, at))
    }
}

/// Rewrite group head: the strip as a difference to the previous group's,
/// and the position count folded into the low two bits (1 to 3, or 4 plus a
/// second number).
fn push_group(out: &mut Vec<u8>, strip_delta: u32, count: u32) {
    let c = (count - 1).min(3);
    varint::put_u32(out, strip_delta << 2 | c);
    if c == 3 {
        varint::put_u32(out, count - 4);
    }
}

fn read_group(stream: &[u8], at: &mut usize) -> (u32, u32) {
    let v = varint::read_u32(stream, at);
    let c = v & 3;
    let count = if c == 3 {
        4 + varint::read_u32(stream, at)
    } else {
        c + 1
    };
    (v >> 2, count)
}

/// Appends a resize record: its head, then the removed indices `values` (the
/// run `strip[at..at + len]` before the cut, `previous` the index before it or
/// 0, `right` the index after it unless the run ends the strip).
///
/// The head is one byte in the common case: the rewrite group in 2 bits, the
/// replacement kind in 3 and `len - 1` in 3, with 3 (group) and 7 (length)
/// escaping to a LEB128 number after the byte; then the position `at`.
///
/// Each removed index is a 2-bit symbol, four to a byte: 0 repeats the index
/// before it, 1 is the run's right neighbour, 2 repeats the index two before
/// it (degenerate runs are mostly `a a a` and `a b a b`), 3 escapes to a
/// zigzag difference to the index before it, stored after the symbols.
fn push_resize(out: &mut Vec<u8>, group: u32, at: u32, kind: u16, run: ResizeRun) {
    let len = run.values.len() as u32;
    let g = group.min(3);
    let l = (len - 1).min(7);
    out.push((g | u32::from(kind) << 2 | l << 5) as u8);
    if g == 3 {
        varint::put_u32(out, group - 3);
    }
    if l == 7 {
        varint::put_u32(out, len - 1 - 7);
    }
    varint::put_u32(out, at);
    let mut previous = run.previous;
    let mut symbols = 0u8;
    let escapes = out.len() + run.values.len().div_ceil(4);
    let mut escaped = Vec::new();
    for (k, &v) in run.values.iter().enumerate() {
        let two_back = match k {
            0 => run.before[0],
            1 => run.before[1],
            _ => Some(run.values[k - 2]),
        };
        let symbol = if v == previous {
            0
        } else if Some(v) == run.right {
            1
        } else if Some(v) == two_back {
            2
        } else {
            varint::put_u32(&mut escaped, zigzag(v, previous));
            3
        };
        symbols |= symbol << (2 * (k % 4));
        if k % 4 == 3 || k + 1 == run.values.len() {
            out.push(symbols);
            symbols = 0;
        }
        previous = v;
    }
    debug_assert_eq!(out.len(), escapes);
    out.extend_from_slice(&escaped);
}

/// The context [`push_resize`] codes a run's removed indices in.
struct ResizeRun<'a> {
    values: &'a [u32],
    /// The index before the run, or 0 at the strip's start.
    previous: u32,
    /// The indices two and one before the first removed one, where the strip has them.
    before: [Option<u32>; 2],
    /// The index after the run, unless the run ends the strip.
    right: Option<u32>,
}

impl<'a> ResizeRun<'a> {
    /// The run of `len` indices at `at` in `strip` (the strip before the cut), with its
    /// context.
    fn new(strip: &'a [u32], at: usize, len: usize) -> Self {
        ResizeRun {
            values: &strip[at..at + len],
            previous: if at > 0 { strip[at - 1] } else { 0 },
            before: [
                at.checked_sub(2).map(|k| strip[k]),
                at.checked_sub(1).map(|k| strip[k]),
            ],
            right: strip.get(at + len).copied(),
        }
    }
}

/// Reads a resize head: `(group, at, len, kind)`.
fn read_resize_head(stream: &[u8], at: &mut usize) -> (u32, usize, usize, u16) {
    let b = u32::from(stream[*at]);
    *at += 1;
    let mut group = b & 3;
    let kind = ((b >> 2) & 7) as u16;
    let mut len = (b >> 5) + 1;
    if group == 3 {
        group += varint::read_u32(stream, at);
    }
    if len == 8 {
        len += varint::read_u32(stream, at);
    }
    let i = varint::read_u32(stream, at) as usize;
    (group, i, len as usize, kind)
}

/// Skips the removed indices of a `len`-index resize record.
fn skip_removed(stream: &[u8], at: &mut usize, len: usize) {
    let bytes = len.div_ceil(4);
    let mut escapes = 0;
    for k in 0..len {
        escapes += usize::from((stream[*at + k / 4] >> (2 * (k % 4))) & 3 == 3);
    }
    *at += bytes;
    for _ in 0..escapes {
        varint::read_u32(stream, at);
    }
}

/// Restores the removed indices of a resize record into `region[i..i + len]`:
/// the strip's indices from the region's start, with the run's right neighbour
/// already moved to `region[i + len]` (if the run did not end the strip).
fn restore_removed<I: StripIndex>(
    stream: &[u8],
    at: &mut usize,
    region: &mut [I],
    i: usize,
    len: usize,
) {
    let symbols = *at;
    *at += len.div_ceil(4);
    let mut previous = if i > 0 { region[i - 1] } else { I::of(0) };
    for k in 0..len {
        let v = match (stream[symbols + k / 4] >> (2 * (k % 4))) & 3 {
            0 => previous,
            1 => region[i + len],
            2 => region[i + k - 2],
            _ => I::of(unzigzag(varint::read_u32(stream, at), previous.into())),
        };
        region[i + k] = v;
        previous = v;
    }
}

/// A removed index stored as the zigzag difference to the index before it:
/// degenerate runs repeat their neighbours, so this is mostly 0 (one byte).
fn zigzag(value: u32, previous: u32) -> u32 {
    varint::zigzag32(value.wrapping_sub(previous) as i32)
}

fn unzigzag(z: u32, previous: u32) -> u32 {
    previous.wrapping_add(varint::unzigzag32(z) as u32)
}

/// Appends a step footer: the step's length in bytes, footer excluded, as
/// LEB128 groups written high first, so that it reads backward from the end:
/// the last byte holds the low group, its top bit says whether more precede.
fn push_footer(out: &mut Vec<u8>, len: u32) {
    let groups = varint::len_u32(len);
    for g in (0..groups).rev() {
        let bits = ((len >> (7 * g)) & 0x7F) as u8;
        out.push(if g + 1 < groups { bits | 0x80 } else { bits });
    }
}

/// Reads the footer that ends just before `end`; returns the start of the step.
fn step_start_before(stream: &[u8], end: usize) -> usize {
    let mut at = end - 1;
    let mut len = 0usize;
    let mut shift = 0;
    loop {
        let b = stream[at];
        len |= usize::from(b & 0x7F) << shift;
        if b & 0x80 == 0 {
            return at - len;
        }
        shift += 7;
        at -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Resize records round-trip through the one-byte head (group and length escapes
    /// included) and the removed-index symbols (every symbol, escapes, runs at the strip's
    /// start and end), and `skip_removed` lands where `restore_removed` does.
    #[test]
    fn resize_records_round_trip() {
        let mut seed = 12345u32;
        let mut next = |m: u32| {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) % m
        };
        for case in 0..2000 {
            let live = 1 + next(40) as usize;
            let strip: Vec<u32> = (0..live)
                .map(|_| if next(3) == 0 { next(1 << 20) } else { next(4) })
                .collect();
            let at = next(live as u32) as usize;
            let len = 1 + next((live - at) as u32) as usize;
            let kind = next(5) as u16;
            let group = next(if case % 2 == 0 { 5 } else { 300 });
            let mut out = vec![0xAB];
            push_resize(
                &mut out,
                group,
                at as u32,
                kind,
                ResizeRun::new(&strip, at, len),
            );
            out.push(0xCD);
            let mut p = 1;
            assert_eq!(read_resize_head(&out, &mut p), (group, at, len, kind));
            let mut skipped = p;
            skip_removed(&out, &mut skipped, len);
            assert_eq!(out[skipped], 0xCD, "case {case}");
            // The strip as refining finds it: the run cut out, its right part moved back.
            let mut region = strip.clone();
            region[at..at + len].fill(u32::MAX);
            restore_removed(&out, &mut p, &mut region, at, len);
            assert_eq!(p, skipped, "case {case}");
            assert_eq!(region, strip, "case {case}");
        }
    }
}
