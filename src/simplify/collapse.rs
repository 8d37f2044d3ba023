//! Making a collapse: the triangles on the edge die, the others are re-pointed, the quadrics
//! merge, and the queue is updated where costs or candidate sets changed.

use super::classify::Kind;
use super::{after_before, corner, holds, Span, State};
use crate::collapse::Collapse;

impl State<'_, '_, '_> {
    /// Applies `u → w`: kills the triangles on edge uw, re-points u's other
    /// triangles to w, merges the quadric, and updates the queue where costs or
    /// candidate sets changed: w (new quadric, new fan) and u's old neighbours
    /// (they lost u and gained w).
    pub(super) fn collapse(&mut self, u: u32, w: u32, cost: f64) {
        self.collapses.push(Collapse {
            u,
            w,
            error: cost as f32,
        });
        if let Some(seams) = &mut self.seams {
            // Fills the pairs `move_corners` applies below; `is_valid` passed, so it allows.
            let Span { start, len, .. } = self.span[u as usize];
            let allowed = seams.allows(u, w, &self.pool[start..start + len as usize]);
            debug_assert!(allowed, "{u} -> {w} was validated");
            seams.merge_metric();
        }
        let ku = self.kind[u as usize];
        self.kind[u as usize] = Kind::Collapsed;
        self.queue.remove(u);
        let count = self.poses.len();
        for pose in 0..count {
            let qu = self.quadric[u as usize * count + pose];
            self.quadric[w as usize * count + pose].add(&qu);
        }

        let mut moved = std::mem::take(&mut self.scratch);
        moved.clear();
        moved.extend_from_slice(self.list(u));
        // Detach u and what its triangles hold; they attach to the new fan below.
        self.detach(u, &moved);
        let mut around = std::mem::take(&mut self.around);
        around.clear();
        let seen = self.next_stamp();
        self.span[u as usize].len = 0;
        let mut kept = 0;
        for i in 0..moved.len() {
            let t = moved[i];
            let tri = self.tris[t as usize];
            let [a, b] = after_before(tri, u);
            if ku == Kind::Interior {
                // As in `targets`: each neighbour follows u exactly once.
                if a != w {
                    around.push(a);
                }
            } else {
                for v in [a, b] {
                    if v != w && self.mark[v as usize] != seen {
                        self.mark[v as usize] = seen;
                        around.push(v);
                    }
                }
            }
            if holds(tri, w) {
                // On edge uw: dies. Its other corners are w and an apex.
                self.remove_from_list(a, t);
                self.remove_from_list(b, t);
            } else {
                self.tris[t as usize][corner(tri, u)] = w;
                moved[kept] = t;
                kept += 1;
            }
        }
        moved.truncate(kept);
        if let Some(seams) = &mut self.seams {
            seams.move_corners(&moved);
        }
        // `moved` holds the re-pointed triangles already.
        self.reattach(w, &moved);
        self.append_to_list(w, &moved);
        self.scratch = moved;

        self.rerank(w);
        for &x in &around {
            // An interior neighbour whose queued target was not u keeps its other
            // costs: only the new edge x→w can lower its best. Anything else
            // (target u gone, border rules depend on the new edges, or not queued)
            // is ranked afresh.
            let xi = x as usize;
            let target = self.queue.target[xi];
            match self.queue.cost(x) {
                // With the distance term every cost of x can change: its triangles hold
                // other vertices now.
                Some(old)
                    if self.kind[xi] == Kind::Interior
                        && target != u
                        && self.attached.is_none() =>
                {
                    let c = self.cost(x, w);
                    if c.total_cmp(&old).then(w.cmp(&target)).is_lt() {
                        self.queue.set(x, c, w);
                    }
                }
                _ => self.rerank(x),
            }
        }
        self.around = around;
    }

    fn remove_from_list(&mut self, v: u32, t: u32) {
        let Span { start: s, len, .. } = self.span[v as usize];
        let l = len as usize;
        if let Some(i) = self.pool[s..s + l].iter().position(|&x| x == t) {
            self.pool.swap(s + i, s + l - 1);
            self.span[v as usize].len -= 1;
        }
    }

    fn append_to_list(&mut self, v: u32, add: &[u32]) {
        let mut span = self.span[v as usize];
        let l = span.len as usize;
        let need = l + add.len();
        if need > span.cap as usize {
            let new_start = self.pool.len();
            self.pool.extend_from_within(span.start..span.start + l);
            self.pool.resize(new_start + need * 2, 0);
            span.start = new_start;
            span.cap = (need * 2) as u32;
        }
        let s = span.start + l;
        self.pool[s..s + add.len()].copy_from_slice(add);
        span.len = need as u32;
        self.span[v as usize] = span;
    }
}
