//! An asset's GPU index memory in a crowd: pages, each an index buffer with the draw records of
//! the instances it holds, from which every instance takes one area sized to what it draws
//! now (docs/DESIGN.md, "Crowds", "Index memory that follows the LOD").
//!
//! An instance drawn from its frame's tail list holds `4 × triangles` words, one drawn from a
//! compact copy of its live strips a little more than their packed count, and only one drawn
//! from its regions (close to the camera) holds the whole region layout. Areas come from an
//! offset allocator per page (the `offset-allocator` crate: Sebastian Aaltonen's two-level
//! segregated fit, O(1) with neighbours merged on free, the allocator Bevy's mesh slabs use),
//! in words. A page's buffer starts small and doubles, its contents copied on the GPU, up to the
//! device's limits (the scatter and the tail expansion bind a page whole, so a page never
//! passes `max_storage_buffer_binding_size`); past that a new page opens: more memory is never
//! refused and nothing drawn is cut. A page's records are drawn by one
//! `multi_draw_indexed_indirect` with its buffer bound: one draw per asset and page.
//!
//! An area freed by a move stays unused until the next `prepare` has recorded its copies (a
//! compact copy that outgrows its area is copied on the GPU into the new one, which reads the
//! old), so no words are read and written by one frame's copies, scatters and expansions.

use offset_allocator::{Allocation, Allocator};
use wgpu::util::DrawIndexedIndirectArgs;

use super::super::records::ARGS_BYTES;

/// Words an area's size is rounded up to: areas of a few sizes leave holes the next ones fit.
pub(super) const GRANULE: u32 = 16;

/// Words of a page's first buffer (1 MiB); it doubles as its areas reach past it.
const FIRST_WORDS: u64 = 1 << 18;

/// Areas a page tracks at most (its allocator's node table is made up front, 28 bytes a node):
/// a page with as many areas opens the next page.
const MAX_AREAS: u32 = 1 << 16;

/// Records a page's indirect buffer holds at first; it doubles as they pass it.
const FIRST_RECORDS: u64 = 256;

/// Words of a record (`DrawIndexedIndirectArgs`).
pub(super) const RECORD_WORDS: u32 = 5;

/// One instance's index memory: `words` words from `offset` of page `page`'s index buffer.
#[derive(Clone, Copy)]
pub(super) struct Area {
    pub(super) page: u32,
    pub(super) offset: u32,
    pub(super) words: u32,
    allocation: Allocation,
}

impl std::fmt::Debug for Area {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Area(page {}, {}..+{})",
            self.page, self.offset, self.words
        )
    }
}

/// Where an instance's draw record is: page and entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct RecordAt {
    pub(super) page: u32,
    pub(super) entry: u32,
}

/// One page: its allocator, its index buffer and the records drawn with it.
pub(super) struct Page {
    allocator: Allocator,
    /// One past the last word an area of the page has reached: what its buffer must hold.
    end: u32,
    /// The index buffer (`None` until the first `grow`).
    pub(super) indices: Option<wgpu::Buffer>,
    /// The draw records of the instances whose areas are in this page (free entries zero:
    /// they draw nothing), as the GPU holds them after the next prepare.
    pub(super) records: Vec<DrawIndexedIndirectArgs>,
    /// Free entries, reused lowest first (kept sorted, highest first).
    free_records: Vec<u32>,
    /// Records drawn: one past the highest entry in use.
    pub(super) drawn: u32,
    /// The indirect buffer (`None` until the first `grow`).
    pub(super) indirect: Option<wgpu::Buffer>,
    /// The record words changed since the last prepare, `[word, value]`.
    pub(super) record_patches: Vec<[u32; 2]>,
    /// Bumped whenever `indices` or `indirect` is made anew: bind groups over them are stale.
    pub(super) generation: u64,
}

impl Page {
    fn new(page_words: u32) -> Page {
        Page {
            allocator: Allocator::with_max_allocs(page_words, MAX_AREAS),
            end: 0,
            indices: None,
            records: Vec::new(),
            free_records: Vec::new(),
            drawn: 0,
            indirect: None,
            record_patches: Vec::new(),
            generation: 0,
        }
    }
}

/// The pages of one asset (see the module docs).
pub(super) struct Pool {
    pub(super) pages: Vec<Page>,
    /// The most words one page holds, and the most records (the scatter binds its indirect
    /// buffer whole too).
    page_words: u32,
    page_records: u32,
    /// Areas freed since the last prepare, given back to their allocators once its copies are
    /// recorded.
    freed: Vec<Area>,
    /// Scratch of the copies within one page (WebGPU copies between two buffers only).
    scratch: Option<wgpu::Buffer>,
}

/// A copy of an area's first `words` into another (a compact copy moved to a larger area).
#[derive(Clone, Copy, Debug)]
pub(super) struct Move {
    pub(super) from: Area,
    pub(super) to: Area,
    pub(super) words: u32,
}

impl Pool {
    /// A pool of pages whose buffers hold at most `bytes` each (a page at least [`GRANULE`]
    /// words, below 2³¹: the scatter's run headers name a word in 31 bits).
    pub(super) fn new(bytes: u64) -> Pool {
        let words = (bytes / 4).clamp(u64::from(GRANULE), 1 << 31) as u32;
        Pool {
            pages: Vec::new(),
            page_words: words / GRANULE * GRANULE,
            page_records: (bytes / ARGS_BYTES).clamp(1, u64::from(u32::MAX)) as u32,
            freed: Vec::new(),
            scratch: None,
        }
    }

    /// The most words one area may have.
    pub(super) fn page_words(&self) -> u32 {
        self.page_words
    }

    /// An area of at least `words` words (rounded up to [`GRANULE`]; at most
    /// [`page_words`](Self::page_words), which the caller checks) for an instance whose record
    /// is in page `near`: there where it fits, else in the first page where it fits and that
    /// has room for its record, else in a new page.
    pub(super) fn alloc(&mut self, words: u32, near: u32) -> Area {
        let words = words.max(1).next_multiple_of(GRANULE);
        debug_assert!(words <= self.page_words, "an area larger than a page");
        let pages = self.pages.len();
        for p in std::iter::once(near as usize).chain(0..pages) {
            if p >= pages || (p != near as usize && !self.record_room(p)) {
                continue;
            }
            if let Some(area) = self.alloc_in(p, words) {
                return area;
            }
        }
        self.pages.push(Page::new(self.page_words));
        let last = self.pages.len() - 1;
        self.alloc_in(last, words)
            .expect("an empty page holds any area up to its size")
    }

    /// Whether page `p` can take one more record.
    pub(super) fn record_room(&self, p: usize) -> bool {
        let page = &self.pages[p];
        !page.free_records.is_empty() || (page.records.len() as u32) < self.page_records
    }

    fn alloc_in(&mut self, p: usize, words: u32) -> Option<Area> {
        let page = &mut self.pages[p];
        let allocation = page.allocator.allocate(words)?;
        page.end = page.end.max(allocation.offset + words);
        Some(Area {
            page: p as u32,
            offset: allocation.offset,
            words,
            allocation,
        })
    }

    /// Frees `area` from the next prepare on (its words may be read by this frame's copies).
    pub(super) fn free(&mut self, area: Area) {
        self.freed.push(area);
    }

    /// A record entry in page `page` (drawing nothing until set), which has
    /// [`record_room`](Self::record_room).
    pub(super) fn add_record(&mut self, page: u32) -> RecordAt {
        let p = &mut self.pages[page as usize];
        let entry = p.free_records.pop().unwrap_or_else(|| {
            p.records.push(DrawIndexedIndirectArgs::default());
            p.records.len() as u32 - 1
        });
        p.drawn = p.drawn.max(entry + 1);
        RecordAt { page, entry }
    }

    /// Sets the record at `at` to `args`: a patch per word that changed.
    pub(super) fn set_record(&mut self, at: RecordAt, args: DrawIndexedIndirectArgs) {
        let p = &mut self.pages[at.page as usize];
        let record = &mut p.records[at.entry as usize];
        let old: [u32; 5] = bytemuck::cast(*record);
        let now: [u32; 5] = bytemuck::cast(args);
        let first = at.entry * RECORD_WORDS;
        for (w, (&o, &v)) in (0u32..).zip(old.iter().zip(&now)) {
            if o != v {
                p.record_patches.push([first + w, v]);
            }
        }
        *record = args;
    }

    /// Frees the record at `at`: it draws nothing from the next prepare.
    pub(super) fn remove_record(&mut self, at: RecordAt) {
        self.set_record(at, DrawIndexedIndirectArgs::default());
        let p = &mut self.pages[at.page as usize];
        let i = p.free_records.partition_point(|&e| e > at.entry);
        p.free_records.insert(i, at.entry);
        while p.drawn > 0 && p.free_records.first() == Some(&(p.drawn - 1)) {
            // The highest free entry is the drawn range's last: both shrink.
            p.free_records.remove(0);
            p.records.pop();
            p.drawn -= 1;
        }
    }

    /// Makes or grows every page's buffers to hold what is allocated (doubling, copying the old
    /// contents on the GPU in `encoder`; bind groups over a page made anew are stale, see
    /// [`Page::generation`]). Returns the copies recorded.
    pub(super) fn grow(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
    ) -> usize {
        let max = u64::from(self.page_words) * 4;
        let mut copies = 0;
        for page in &mut self.pages {
            let need = u64::from(page.end.max(1)) * 4;
            let grown = grow_buffer(
                device,
                encoder,
                &mut page.indices,
                need,
                (FIRST_WORDS * 4).min(max),
                max,
                "crowd indices",
                // STORAGE: the scatter and the tail expansion write it; COPY_SRC: tests read
                // the areas back, and a grown page is copied.
                wgpu::BufferUsages::INDEX
                    | wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            );
            let need = page.records.len().max(1) as u64 * ARGS_BYTES;
            let most = u64::from(self.page_records) * ARGS_BYTES;
            let grown_records = grow_buffer(
                device,
                encoder,
                &mut page.indirect,
                need,
                (FIRST_RECORDS * ARGS_BYTES).min(most),
                most,
                "crowd records",
                // Zeroed records draw nothing. STORAGE: the scatter writes changed words.
                wgpu::BufferUsages::INDIRECT
                    | wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            );
            if grown.is_some() || grown_records.is_some() {
                page.generation += 1;
            }
            copies += usize::from(grown == Some(true)) + usize::from(grown_records == Some(true));
        }
        copies
    }

    /// Records `moves` (each area's first words into another) in `encoder`: directly between
    /// pages, through a scratch buffer within one (WebGPU copies between two buffers only).
    /// Their sources are freed areas and their targets new ones, so no copy reads what another
    /// writes.
    pub(super) fn record_moves(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        moves: &[Move],
    ) {
        let buffer = |pool: &Pool, area: &Area| {
            pool.pages[area.page as usize]
                .indices
                .clone()
                .expect("grown before the moves")
        };
        let within: u64 = (moves.iter())
            .filter(|m| m.from.page == m.to.page)
            .map(|m| u64::from(m.words) * 4)
            .sum();
        if within > 0 && self.scratch.as_ref().is_none_or(|s| s.size() < within) {
            self.scratch = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("crowd moves"),
                size: within.next_power_of_two(),
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let mut at = 0;
        for m in moves.iter().filter(|m| m.words > 0) {
            let (from, to) = (buffer(self, &m.from), buffer(self, &m.to));
            let bytes = u64::from(m.words) * 4;
            let (src, dst) = (u64::from(m.from.offset) * 4, u64::from(m.to.offset) * 4);
            if m.from.page == m.to.page {
                let scratch = self.scratch.as_ref().expect("made above");
                encoder.copy_buffer_to_buffer(&from, src, scratch, at, bytes);
                at += bytes;
            } else {
                encoder.copy_buffer_to_buffer(&from, src, &to, dst, bytes);
            }
        }
        let mut at = 0;
        for m in moves
            .iter()
            .filter(|m| m.words > 0 && m.from.page == m.to.page)
        {
            let to = buffer(self, &m.to);
            let bytes = u64::from(m.words) * 4;
            let scratch = self.scratch.as_ref().expect("made above");
            encoder.copy_buffer_to_buffer(scratch, at, &to, u64::from(m.to.offset) * 4, bytes);
            at += bytes;
        }
    }

    /// Gives the areas freed before this call back to their pages (after the prepare that
    /// recorded their copies).
    pub(super) fn release(&mut self) {
        for area in self.freed.drain(..) {
            let page = &mut self.pages[area.page as usize];
            page.allocator.free(area.allocation);
        }
    }

    /// GPU bytes of the pages' buffers (index and indirect), as made.
    pub(super) fn gpu_bytes(&self) -> u64 {
        (self.pages.iter())
            .map(|p| {
                p.indices.as_ref().map_or(0, wgpu::Buffer::size)
                    + p.indirect.as_ref().map_or(0, wgpu::Buffer::size)
            })
            .sum()
    }
}

/// Makes `buffer` hold at least `need` bytes: made at `first` (or `need`, if more) and doubled
/// up to `max`, its old contents copied in `encoder`. Where it was made anew: whether its
/// old contents were copied.
#[allow(clippy::too_many_arguments)]
fn grow_buffer(
    device: &wgpu::Device,
    encoder: &mut wgpu::CommandEncoder,
    buffer: &mut Option<wgpu::Buffer>,
    need: u64,
    first: u64,
    max: u64,
    label: &str,
    usage: wgpu::BufferUsages,
) -> Option<bool> {
    let have = buffer.as_ref().map_or(0, wgpu::Buffer::size);
    if need <= have {
        return None;
    }
    let size = need.max(first).next_power_of_two().min(max).max(need);
    let new = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage,
        mapped_at_creation: false,
    });
    let copied = buffer.as_ref().map(|old| {
        encoder.copy_buffer_to_buffer(old, 0, &new, 0, old.size());
    });
    *buffer = Some(new);
    Some(copied.is_some())
}
