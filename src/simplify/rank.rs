//! Ranking: the targets a vertex may collapse onto, their costs, and the queue entry of its
//! cheapest; with the distance term, the lazy pricing of the vertices at the top.

use rayon::prelude::*;

use super::classify::Kind;
use super::queue::{key, key_cost, key_vertex};
use super::{after_before, holds, State};

/// What ranking and pricing a vertex ([`State::targets`], [`State::price`]) write to: one per
/// thread.
#[derive(Default)]
pub(super) struct PriceScratch {
    candidates: Vec<(f64, u32)>,
    /// The vertices near a candidate fan.
    near: Vec<u32>,
}

impl State<'_, '_, '_> {
    /// The cost of moving `u` onto `w`: each pose's quadric error of `u` at `w`'s position
    /// in that pose, combined over the poses, plus the attribute error in the first pose.
    pub(super) fn cost(&self, u: u32, w: u32) -> f64 {
        self.position_cost(u, w) + self.attribute_cost(u, w)
    }

    /// The attribute error of `u → w` in the first pose (0 without seams).
    pub(super) fn attribute_cost(&self, u: u32, w: u32) -> f64 {
        match &self.seams {
            Some(seams) => seams.attribute_cost(&self.tris, self.list(u), u, w, self.p(0, w)),
            None => 0.0,
        }
    }

    /// Prices `u` (just popped, not exact) and the vertices after it at the top of the
    /// queue that are not exact either, up to two per thread of the rayon pool, in parallel;
    /// marks them exact and queues each at its price. Pricing reads the state and changes
    /// nothing, and a price stays valid until the vertex is ranked again (`rerank`), so
    /// pricing a vertex before it reaches the top gives the order the one-at-a-time loop
    /// gives, bit for bit; a price that a collapse makes stale first is work lost.
    pub(super) fn price_batch(&mut self, u: u32) {
        let mut batch = std::mem::take(&mut self.batch);
        batch.clear();
        batch.push(u);
        // Two a thread: prices take unequal time, and more of them balance better.
        let width = 2 * rayon::current_num_threads();
        while batch.len() < width {
            match self.queue.top() {
                Some(v) if self.attached.as_ref().is_some_and(|a| !a.exact[v as usize]) => {
                    self.queue.remove(v);
                    batch.push(v);
                }
                _ => break,
            }
        }
        let prices: Vec<Option<(f64, u32)>> = if batch.len() == 1 {
            let mut scratch = std::mem::take(&mut self.pricing);
            let price = self.price(u, &mut scratch);
            self.pricing = scratch;
            vec![price]
        } else {
            let state = &*self;
            batch
                .par_iter()
                .map_init(PriceScratch::default, |scratch, &v| state.price(v, scratch))
                .collect()
        };
        for (&v, price) in batch.iter().zip(prices) {
            if let Some(attached) = &mut self.attached {
                attached.exact[v as usize] = true;
            }
            if let Some((cost, w)) = price {
                self.queue.set(v, cost, w);
            }
        }
        self.batch = batch;
    }

    /// `u`'s target of least [`exact_cost`](Self::exact_cost) among the allowed ones, valid
    /// or not, with that cost. The cheap costs bound the exact ones from below, so targets
    /// are priced cheapest first until none can win.
    fn price(&self, u: u32, scratch: &mut PriceScratch) -> Option<(f64, u32)> {
        let PriceScratch { candidates, near } = scratch;
        self.targets(u, candidates);
        candidates.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut best: Option<(f64, u32)> = None;
        for &(cheap, w) in candidates.iter() {
            if best.is_some_and(|(b, _)| cheap >= b) {
                break;
            }
            let cost = self.exact_cost(u, w, best.map_or(f64::INFINITY, |b| b.0), near);
            if best.is_none_or(|(b, bw)| cost.total_cmp(&b).then(w.cmp(&bw)).is_lt()) {
                best = Some((cost, w));
            }
        }
        best
    }

    /// Ranks `u` by cost alone and queues its cheapest allowed target.
    pub(super) fn rerank(&mut self, u: u32) {
        if let Some(attached) = &mut self.attached {
            attached.exact[u as usize] = false;
        }
        let mut scratch = std::mem::take(&mut self.pricing);
        self.targets(u, &mut scratch.candidates);
        match scratch
            .candidates
            .iter()
            .map(|&(cost, v)| key(cost, v))
            .min()
        {
            None => self.queue.remove(u),
            Some(best) => self.queue.set(u, key_cost(best), key_vertex(best)),
        }
        self.pricing = scratch;
    }

    /// The targets the vertex kinds allow for `u`, each with its cost, into `out`. A
    /// neighbour seen in exactly one of `u`'s triangles is across a boundary edge.
    fn targets(&self, u: u32, out: &mut Vec<(f64, u32)>) {
        out.clear();
        let kind = self.kind[u as usize];
        if !matches!(kind, Kind::Interior | Kind::Border) {
            return;
        }
        let fan = self.list(u);
        if kind == Kind::Interior {
            // A closed, consistently oriented fan: each neighbour follows u in
            // exactly one triangle, so it is visited once.
            for &t in fan {
                let v = after_before(self.tris[t as usize], u)[0];
                out.push((self.cost(u, v), v));
            }
            return;
        }
        // A border fan is small: count each neighbour's triangles by scanning it again
        // (no shared marks, so this runs on a shared `&self`).
        for (i, &t) in fan.iter().enumerate() {
            for v in self.tris[t as usize] {
                let first = !fan[..i].iter().any(|&e| holds(self.tris[e as usize], v));
                if v == u || !first || self.kind[v as usize] != Kind::Border {
                    continue;
                }
                let count = fan[i..]
                    .iter()
                    .filter(|&&e| holds(self.tris[e as usize], v))
                    .count();
                if count == 1 {
                    out.push((self.cost(u, v), v));
                }
            }
        }
    }

    /// The cheapest target of `u` that passes every check, if any.
    pub(super) fn best_valid(&mut self, u: u32) -> Option<(f64, u32)> {
        let mut scratch = std::mem::take(&mut self.pricing);
        let PriceScratch { candidates, near } = &mut scratch;
        self.targets(u, candidates);
        // Cheapest first. With the distance term the cost ranked by is a lower bound of the
        // exact one, so candidates are priced in that order until none can win, and only
        // one that would win is checked.
        candidates.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut best: Option<(f64, u32)> = None;
        for &(cheap, w) in candidates.iter() {
            if best.is_some_and(|(b, bw)| key(cheap, w) >= key(b, bw)) {
                break;
            }
            let cost = match self.attached {
                Some(_) => self.exact_cost(u, w, best.map_or(f64::INFINITY, |b| b.0), near),
                None => cheap,
            };
            let wins = best.is_none_or(|(b, bw)| key(cost, w) < key(b, bw));
            if wins && self.is_valid(u, w) {
                best = Some((cost, w));
            }
        }
        if let Some(attached) = &mut self.attached {
            attached.exact[u as usize] = true;
        }
        self.pricing = scratch;
        best
    }
}
