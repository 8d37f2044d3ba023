//! The queue: one entry per vertex, its cheapest outgoing half-edge, in an indexed min-heap
//! updated in place (decrease/increase key) as fans and quadrics change.

use crate::mesh::adjacency::NONE;

/// Indexed binary min-heap of vertices keyed by `(cost, vertex)` (the vertex
/// breaks ties, so the result is deterministic), with each vertex's chosen
/// target beside it. A key is one integer, the cost's bits mapped so that
/// integer order is `f64::total_cmp` order, above the vertex: sifting compares
/// one `u128` per step instead of a float, a tie test and an index. Keys live
/// inside the heap array so sifting reads neighbouring memory instead of
/// chasing per-vertex arrays.
pub(super) struct Queue {
    heap: Vec<u128>,
    /// Position of each vertex in `heap`, or `NONE`.
    slot: Vec<u32>,
    pub(super) target: Vec<u32>,
}

/// The heap key of `(cost, v)`: the bit trick behind `f64::total_cmp`
/// (negative values reversed below positive ones), then the vertex.
pub(super) fn key(cost: f64, v: u32) -> u128 {
    let bits = cost.to_bits();
    let ordered = if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    };
    (ordered as u128) << 32 | v as u128
}

/// The cost a [`key`] was made from, bit for bit.
pub(super) fn key_cost(key: u128) -> f64 {
    let ordered = (key >> 32) as u64;
    f64::from_bits(if ordered >> 63 == 1 {
        ordered & !(1 << 63)
    } else {
        !ordered
    })
}

/// The vertex a [`key`] was made for.
pub(super) fn key_vertex(key: u128) -> u32 {
    key as u32
}

impl Queue {
    pub(super) fn new(n: usize) -> Self {
        Self {
            heap: Vec::with_capacity(n),
            slot: vec![NONE; n],
            target: vec![NONE; n],
        }
    }

    /// The queued cost of `v` (`None` when not queued).
    pub(super) fn cost(&self, v: u32) -> Option<f64> {
        match self.slot[v as usize] {
            NONE => None,
            i => Some(key_cost(self.heap[i as usize])),
        }
    }

    /// The vertex at the top of the queue.
    pub(super) fn top(&self) -> Option<u32> {
        self.heap.first().map(|&k| key_vertex(k))
    }

    /// Whether `(cost, v)` would come before everything queued.
    pub(super) fn beats_top(&self, cost: f64, v: u32) -> bool {
        self.heap.first().is_none_or(|&top| key(cost, v) <= top)
    }

    pub(super) fn set(&mut self, v: u32, cost: f64, target: u32) {
        self.target[v as usize] = target;
        let k = key(cost, v);
        match self.slot[v as usize] {
            NONE => {
                self.heap.push(k);
                self.sift_up(self.heap.len() - 1, k);
            }
            i => {
                let i = i as usize;
                if k < self.heap[i] {
                    self.sift_up(i, k);
                } else {
                    self.sift_down(i, k);
                }
            }
        }
    }

    pub(super) fn remove(&mut self, v: u32) {
        let i = self.slot[v as usize];
        if i == NONE {
            return;
        }
        self.slot[v as usize] = NONE;
        let Some(last) = self.heap.pop() else {
            return;
        };
        if key_vertex(last) != v {
            let i = i as usize;
            if last < self.heap[i] {
                self.sift_up(i, last);
            } else {
                self.sift_down(i, last);
            }
        }
    }

    /// Takes the cheapest vertex with its cost and target.
    pub(super) fn pop(&mut self) -> Option<(u32, f64, u32)> {
        let top = *self.heap.first()?;
        let v = key_vertex(top);
        self.remove(v);
        Some((v, key_cost(top), self.target[v as usize]))
    }

    /// Places key `e` at `i` or above it.
    fn sift_up(&mut self, mut i: usize, e: u128) {
        while i > 0 {
            let parent = (i - 1) / 2;
            let p = self.heap[parent];
            if e >= p {
                break;
            }
            self.heap[i] = p;
            self.slot[key_vertex(p) as usize] = i as u32;
            i = parent;
        }
        self.heap[i] = e;
        self.slot[key_vertex(e) as usize] = i as u32;
    }

    /// Places key `e` at `i` or below it.
    fn sift_down(&mut self, mut i: usize, e: u128) {
        let n = self.heap.len();
        loop {
            let left = 2 * i + 1;
            if left >= n {
                break;
            }
            let right = left + 1;
            let mut c = self.heap[left];
            let mut child = left;
            if right < n {
                // Which child is smaller is a coin toss: select, don't branch.
                let r = self.heap[right];
                child += (r < c) as usize;
                c = c.min(r);
            }
            if c >= e {
                break;
            }
            self.heap[i] = c;
            self.slot[key_vertex(c) as usize] = i as u32;
            i = child;
        }
        self.heap[i] = e;
        self.slot[key_vertex(e) as usize] = i as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heap_keys_order_like_total_cmp_then_vertex() {
        let costs = [
            f64::NEG_INFINITY,
            -1.5,
            -0.0,
            0.0,
            f64::MIN_POSITIVE,
            1e-300,
            0.25,
            0.25 + f64::EPSILON,
            7.0,
            f64::INFINITY,
            f64::NAN,
        ];
        let mut pairs = Vec::new();
        for &c in &costs {
            for v in [0u32, 1, 7, u32::MAX - 1] {
                pairs.push((c, v));
            }
        }
        for &(a, u) in &pairs {
            assert_eq!(key_cost(key(a, u)).to_bits(), a.to_bits());
            assert_eq!(key_vertex(key(a, u)), u);
            for &(b, v) in &pairs {
                let expected = a.total_cmp(&b).then(u.cmp(&v));
                assert_eq!(
                    key(a, u).cmp(&key(b, v)),
                    expected,
                    "({a}, {u}) vs ({b}, {v})"
                );
            }
        }
    }
}
