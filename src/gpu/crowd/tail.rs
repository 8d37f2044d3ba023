//! Each frame's coarsest LODs as one triangle list per frame, shared by every instance of an
//! asset and expanded on the GPU (`shaders/tail.wgsl`) into an instance's compact area.
//!
//! A crowd's distant instances sit at the last few dozen LODs of their frame (31 of the body's
//! 26,756 triangles on average in the crowd bench), and each of their moves cost a rebuild of
//! the instance's strips from the frame's tail and a patch of its compact copy: most of the
//! crowd's CPU (docs/DESIGN.md, "Crowds"). From the finest LOD `lod` of frame `k` that draws at
//! most the budget's triangles on, the reference meshes are one list: the triangles of
//! `(k, lod)` in the tail's own vertex numbers, sorted by the LOD at which they become
//! degenerate (latest first), so the triangles of `(k, l)` are a prefix; each tail vertex
//! knows the step (counted from `lod`) at which it collapses and the tail vertex it falls
//! into. The triangles of `(k, l)` are then the prefix's corners walked along those collapses
//! while they are among the first `l`: the survivors of the DESIGN's oracle, since the corners
//! are already survivors at `lod`. An instance there keeps no runtime work: its move is a
//! frame and a LOD, and `prepare` sends one job (32 bytes) where they changed.

use crate::deform::DeformingModel;
use crate::strip::strip_triangles;

/// Vertex numbers a tail vertex does not have: a step of "never collapses".
const NEVER: u32 = u32::MAX;

/// Indices one tail triangle takes in the compact area: its three corners and a restart, so
/// each starts a strip at even parity and draws its corners' orientation.
pub(super) const TRIANGLE_SLOTS: u32 = 4;

/// Every frame's tail lists of one asset (see the module docs).
#[derive(Debug, Default)]
pub(super) struct TailLists {
    frames: Vec<FrameTail>,
    /// Triangles drawn per tail LOD: frame `f` at LOD `l ≥ f.lod` draws
    /// `alive[f.alive + l − f.lod]`.
    alive: Vec<u32>,
    /// What the GPU reads, one `u32` array: per frame its triangles (three tail vertices
    /// each, latest degenerate first), then its vertices (three words each: the mesh's
    /// vertex, the step counted from the frame's `lod` at which it collapses or [`NEVER`],
    /// the tail vertex it falls into). Emptied by [`take_words`](Self::take_words).
    words: Vec<u32>,
}

/// Where one frame's tail lies in a [`TailLists`].
#[derive(Clone, Copy, Debug, Default)]
struct FrameTail {
    /// The first LOD of the tail (`max_lod + 1`: none, the frame's coarsest LOD draws more
    /// than the budget).
    lod: u32,
    /// First word of its triangles and of its vertices in `words`.
    triangles: u32,
    vertices: u32,
    /// First entry of its counts in `alive`.
    alive: u32,
}

/// One expansion: the words `shaders/tail.wgsl`'s `Job` holds.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct TailJob {
    /// The index slot its first triangle goes to.
    pub(super) dst: u32,
    /// The frame's first word of triangles and of vertices.
    pub(super) triangles: u32,
    pub(super) vertices: u32,
    /// The LOD counted from the frame's tail LOD.
    pub(super) level: u32,
    /// Triangles to write.
    pub(super) count: u32,
    pub(super) _pad: [u32; 3],
}

impl TailLists {
    /// The tail lists of every frame of `model`, each from the finest LOD that draws at most
    /// `budget` triangles (no tail for a frame whose coarsest LOD draws more, and none at all
    /// for a budget of 0).
    pub(super) fn build(model: &DeformingModel, budget: usize) -> TailLists {
        let layout = model.layout();
        let offsets = layout.region_offsets();
        let s0 = layout.s0();
        // T, as S0's regions draw it at full detail (each triangle once, its orientation).
        let full: Vec<[u32; 3]> = (offsets.windows(2))
            .flat_map(|w| strip_triangles(&s0[w[0] as usize..w[1] as usize]))
            .collect();
        let n = layout.vertex_count();
        let mut anc: Vec<u32> = Vec::with_capacity(n);
        // Mesh vertex → tail vertex (NEVER: not in the tail), reset after each frame.
        let mut local = vec![NEVER; n];
        let mut out = TailLists::default();
        for k in 0..model.frame_count() {
            let frame = model.frame_changes(k).expect("k < frame_count");
            let max = frame.max_lod();
            let lod = frame.finest_within(budget);
            if budget == 0 || frame.triangles_at(lod) > budget {
                out.frames.push(FrameTail {
                    lod: max as u32 + 1,
                    ..FrameTail::default()
                });
                continue;
            }
            // survivors: anc at `lod`, the first `lod` collapses walked backward.
            anc.clear();
            anc.extend(0..n as u32);
            for step in (0..lod).rev() {
                let (u, w) = frame.collapse(step);
                anc[u as usize] = anc[w as usize];
            }
            // meshAtTail: T through the survivors, degenerate triangles left out.
            let mut triangles: Vec<[u32; 3]> = (full.iter())
                .map(|t| t.map(|v| anc[v as usize]))
                .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
                .collect();
            debug_assert_eq!(triangles.len(), frame.triangles_at(lod));
            // numberTailVertices: the corners in order met, then each later collapse's
            // target where its source is a tail vertex.
            let mut vertices: Vec<[u32; 3]> = Vec::new();
            for t in &mut triangles {
                *t = t.map(|v| number(&mut local, &mut vertices, v));
            }
            // fillDeaths: the later collapses applied to the corners; a triangle is
            // degenerate from the LOD after the step that joins two of its corners.
            let mut corners = triangles.clone();
            let mut death = vec![max as u32 + 1; triangles.len()];
            for step in lod..max {
                let (u, w) = frame.collapse(step);
                let lu = local[u as usize];
                if lu == NEVER {
                    continue;
                }
                let lw = number(&mut local, &mut vertices, w);
                vertices[lu as usize][1] = (step - lod) as u32;
                vertices[lu as usize][2] = lw;
                for (c, d) in corners.iter_mut().zip(&mut death) {
                    if *d <= max as u32 || !c.contains(&lu) {
                        continue;
                    }
                    *c = c.map(|v| if v == lu { lw } else { v });
                    if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] {
                        *d = step as u32 + 1;
                    }
                }
            }
            for v in &vertices {
                local[v[0] as usize] = NEVER;
            }
            // sortByDeath: the triangles of each LOD are a prefix.
            let mut order: Vec<usize> = (0..triangles.len()).collect();
            order.sort_by_key(|&i| std::cmp::Reverse(death[i]));
            let tail = FrameTail {
                lod: lod as u32,
                triangles: out.words.len() as u32,
                vertices: (out.words.len() + 3 * triangles.len()) as u32,
                alive: out.alive.len() as u32,
            };
            out.words.extend(order.iter().flat_map(|&i| triangles[i]));
            out.words.extend(vertices.iter().flatten());
            out.alive.extend(
                (lod..=max).map(|l| death.iter().filter(|&&d| d as usize > l).count() as u32),
            );
            out.frames.push(tail);
        }
        out
    }

    /// Triangles frame `k` draws at LOD `l`, where that LOD is in its tail.
    pub(super) fn triangles(&self, k: usize, l: usize) -> Option<u32> {
        let f = self.frames.get(k)?;
        let at = l.checked_sub(f.lod as usize)?;
        Some(self.alive[f.alive as usize + at])
    }

    /// The job that writes frame `k` at LOD `l` (in its tail) to the slots from `dst`.
    pub(super) fn job(&self, k: usize, l: usize, dst: u32) -> Option<TailJob> {
        let count = self.triangles(k, l)?;
        let f = self.frames[k];
        Some(TailJob {
            dst,
            triangles: f.triangles,
            vertices: f.vertices,
            level: l as u32 - f.lod,
            count,
            _pad: [0; 3],
        })
    }

    /// The words the GPU reads (once, when the asset is added): the lists keep their counts.
    pub(super) fn take_words(&mut self) -> Vec<u32> {
        std::mem::take(&mut self.words)
    }
}

/// The tail vertex of mesh vertex `v`, numbered next where it has none (`local`: mesh vertex
/// → tail vertex; `vertices`: the tail's, each as the mesh's vertex, its step and target).
fn number(local: &mut [u32], vertices: &mut Vec<[u32; 3]>, v: u32) -> u32 {
    if local[v as usize] == NEVER {
        local[v as usize] = vertices.len() as u32;
        vertices.push([v, NEVER, NEVER]);
    }
    local[v as usize]
}

/// What `expand_tails` writes for `job` over `words` (the lists' words), into `out` at
/// `job.dst`: the same walk, on the CPU, for tests.
#[cfg(test)]
pub(super) fn expand(words: &[u32], job: &TailJob, out: &mut [u32]) {
    for t in 0..job.count as usize {
        for c in 0..3 {
            let mut v = words[job.triangles as usize + 3 * t + c];
            loop {
                let at = job.vertices as usize + 3 * v as usize;
                if words[at + 1] >= job.level {
                    break;
                }
                v = words[at + 2];
            }
            out[job.dst as usize + 4 * t + c] = words[job.vertices as usize + 3 * v as usize];
        }
        out[job.dst as usize + 4 * t + 3] = super::super::RESTART;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every LOD of every frame's tail expands to the reference mesh of the DESIGN's oracle
    /// (T through the survivors of the frame's collapse sequence), on a grid morph of four
    /// frames, for budgets from none to all of T.
    #[test]
    fn tail_lists_expand_to_the_reference_meshes() {
        let (asset, model) = super::super::grid_model(9);
        let triangles = asset.s0.triangles();
        let canonical = |tris: Vec<[u32; 3]>| {
            let mut out: Vec<[u32; 3]> = (tris.into_iter())
                .map(|t| {
                    let m = (0..3).min_by_key(|&k| t[k]).expect("three");
                    [t[m], t[(m + 1) % 3], t[(m + 2) % 3]]
                })
                .collect();
            out.sort_unstable();
            out
        };
        let mut checked = 0;
        for budget in [0usize, 1, 7, 40, 1000] {
            let mut lists = TailLists::build(&model, budget);
            let words = lists.take_words();
            for (k, frame) in asset.frames.iter().enumerate() {
                let max = model.frame_changes(k).expect("frame").max_lod();
                let first = lists.frames[k].lod as usize;
                if budget == 0 {
                    assert_eq!(first, max + 1, "no tail without a budget");
                }
                for l in 0..=max {
                    let Some(job) = lists.job(k, l, 5) else {
                        assert!(l < first, "frame {k}, LOD {l}: in the tail");
                        continue;
                    };
                    assert!(job.count as usize <= budget, "frame {k}, LOD {l}");
                    let mut out = vec![0u32; 5 + 4 * job.count as usize + 3];
                    expand(&words, &job, &mut out);
                    assert_eq!(&out[..5], &[0; 5], "nothing before dst");
                    assert_eq!(&out[out.len() - 3..], &[0; 3], "nothing past the count");
                    let drawn: Vec<[u32; 3]> = strip_triangles(&out[5..]).collect();
                    let reference = frame.reference_mesh(&triangles, l);
                    // Every triangle written draws: none degenerate in the count.
                    assert_eq!(job.count as usize, reference.len(), "frame {k}, LOD {l}");
                    assert_eq!(
                        canonical(drawn),
                        canonical(reference),
                        "budget {budget}, frame {k}, LOD {l}"
                    );
                    checked += 1;
                }
                if budget >= 1000 {
                    assert_eq!(first, 0, "a budget above T covers every LOD");
                }
            }
        }
        assert!(checked > 100, "{checked} LODs checked");
    }
}
