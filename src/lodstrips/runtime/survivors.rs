//! The survivor of every vertex at a LOD of a frame, for rebuilds: a forest linked collapse
//! by collapse, on a table each thread keeps.

use crate::lodstrips::FrameChanges;

/// Fills `root` with the survivor of each of `vertices` vertices after the collapses
/// `collapse(0..steps)` (`(u, w)`: `u` into `w`), walked backward as
/// [`CollapseSequence::survivors`](crate::collapse::CollapseSequence::survivors) does (each `w`
/// outlives its step, so it is resolved when reached). The runtime's own copy: the oracle's
/// stays apart from the code it checks.
pub(super) fn roots_backward(
    root: &mut Vec<u32>,
    vertices: usize,
    steps: usize,
    collapse: impl Fn(usize) -> (u32, u32),
) {
    root.clear();
    root.extend(0..vertices as u32);
    for step in (0..steps).rev() {
        let (u, w) = collapse(step);
        root[u as usize] = root[w as usize];
    }
}

thread_local! {
    /// The survivor forest of [`Survivors`] (4 bytes per vertex), one per thread rather than
    /// one per state: it lives only during rebuilds, so the states a thread moves (a crowd's
    /// instances, moved in parallel) share it, and an instance's footprint is its index
    /// buffer and per-strip bookkeeping only.
    static SURVIVORS: std::cell::Cell<Vec<u32>> = const { std::cell::Cell::new(Vec::new()) };
    /// The survivors of a rebuild from a frame's tail, one table per thread likewise.
    pub(super) static TAIL_ROOTS: std::cell::Cell<Vec<u32>> = const { std::cell::Cell::new(Vec::new()) };
}

/// The survivor of every vertex after the first `lod` collapses of one frame, for rebuilds:
/// a forest over the vertices in which collapse `u → w` links `u` under `w` (`u` is a root
/// then: a vertex is removed once), so a vertex's root is its survivor. Reaching a coarser
/// LOD of the same frame only links the collapses in between, so rebuilds of one frame taken
/// in ascending LOD (a crowd's instances switching to that frame) link each collapse once;
/// a finer LOD or another frame starts over (4 bytes per vertex written, then the collapses
/// walked backward, which points every vertex straight at its root). Finding a root
/// halves the path as it goes: links only ever point at a vertex that was alive when they
/// were made, so a shortcut to a further ancestor stays an ancestor at every coarser LOD.
///
/// Its table is the calling thread's (taken on creation, handed back on drop), so the
/// allocation is reused by every rebuild on that thread.
pub(crate) struct Survivors<'a> {
    /// The frame the links are of (`None`: none yet).
    frame: Option<&'a FrameChanges>,
    /// Collapses linked.
    lod: usize,
    /// Whether every vertex points straight at its root (after a start from scratch, until
    /// collapses are linked forward).
    flat: bool,
    parent: Vec<u32>,
}

impl<'a> Survivors<'a> {
    /// No links yet, on the calling thread's table.
    pub(crate) fn new() -> Survivors<'a> {
        Survivors {
            frame: None,
            lod: 0,
            flat: false,
            parent: SURVIVORS.take(),
        }
    }

    /// Links the first `lod` collapses of `frame` over `vertices` vertices (only those not
    /// linked yet when the forest is at a finer LOD of the same frame).
    pub(super) fn reach(&mut self, vertices: usize, frame: &'a FrameChanges, lod: usize) {
        let same = self.frame.is_some_and(|f| std::ptr::eq(f, frame));
        if !same || lod < self.lod || self.parent.len() != vertices {
            // From scratch: every vertex then points at its root, so a lone rebuild finds each
            // survivor in one step, for the same work as linking forward.
            roots_backward(&mut self.parent, vertices, lod, |step| frame.collapse(step));
            self.frame = Some(frame);
            self.lod = lod;
            self.flat = true;
        }
        if self.lod < lod {
            self.flat = false;
        }
        for step in self.lod..lod {
            let (u, w) = frame.collapse(step);
            self.parent[u as usize] = w;
        }
        self.lod = lod;
    }

    /// The survivor table when it is flat (every vertex's entry is its survivor, so it
    /// can be read from many threads at once), else `None`.
    pub(super) fn flat(&self) -> Option<&[u32]> {
        self.flat.then_some(&self.parent[..])
    }

    /// The survivor of `v` at the LOD reached.
    #[inline]
    pub(super) fn find(&mut self, v: u32) -> u32 {
        let parent = &mut self.parent;
        let mut v = v as usize;
        loop {
            let p = parent[v] as usize;
            if p == v {
                return v as u32;
            }
            let grand = parent[p];
            parent[v] = grand;
            v = grand as usize;
        }
    }
}

impl Drop for Survivors<'_> {
    fn drop(&mut self) {
        SURVIVORS.set(std::mem::take(&mut self.parent));
    }
}
