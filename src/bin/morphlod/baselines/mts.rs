//! Multiresolution Triangle Strips (Belmonte et al., seeds 000 and 002): every strip a
//! directed graph holding all its levels of detail, traversed per extraction.
//!
//! Per strip (seed 002 §4.1, Listing 1): a column vector of nodes (`ColumnNode`: the vertex
//! it stands for, its adjacency list and `currentInd`, the next arc to try) and adjacency
//! lists of arcs (`RowNode`: `colIndex`, the node the arc leads to, and `res`, the coarsest
//! LOD at which the arc may be traversed). Arcs are sorted by the LOD at which they appeared,
//! so at LOD `L` the arcs of a node valid at `L` come, in the order the strip visits the node,
//! before any that appeared later; the traversal takes the first arc with `res ≥ L` from
//! `currentInd` (Listing 2). The list of strip beginnings is the adjacency list of node 0,
//! the `BEGIN` node; node 1 is the `EV` node (seed 002 §3.2: the strip is cut, the next arc
//! from `EV` names the vertex that starts the next part), drawn as a strip restart; the arc
//! target [`SEV`] ends the strip.
//!
//! The graph is built by replaying the collapse sequence over the strips: at every LOD where
//! a strip's display strip (`super::push_display_strip`) changes, the arcs that no longer
//! lead where the strip goes are closed (`res` set to the LOD before) and new ones appended.
//! Extraction follows the LodStrips paper's account of MTS [1]: only strips modified between
//! the previous and the demanded LOD are traversed again, from their beginning, every arc
//! tried in turn (hence `strip_changes`, the LODs at which each strip changes).

use std::collections::HashMap;

use super::{
    check_inputs, push_display_strip, Baseline, BaselineError, Primitive, Regions, RESTART,
};
use morphlod::collapse::CollapseSequence;
use morphlod::strip::Strips;

/// Arc target that ends the strip (seed 002's `SEV` node).
const SEV: u32 = u32::MAX;
/// Node 0 of every strip: its adjacency list is the list of strip beginnings.
const BEGIN: u32 = 0;
/// Node 1 of every strip: the `EV` node, a cut between two parts of the strip.
const EV: u32 = 1;
/// `res` of an arc not closed yet while building.
const OPEN: u32 = u32::MAX;

/// An MTS model over strips `S0` and its current LOD.
#[derive(Clone, Debug)]
pub struct Mts {
    max_lod: usize,
    /// Strip `s` owns nodes `node_start[s]..node_start[s + 1]`.
    node_start: Vec<u32>,
    /// `ColumnNode::vIndex`: the vertex of each node ([`RESTART`] for `BEGIN` and `EV`).
    node_vertex: Vec<u32>,
    /// `ColumnNode::neighbours`: node `n`'s arcs are `arc_start[n]..arc_start[n + 1]`.
    arc_start: Vec<u32>,
    /// `RowNode::colIndex` (a node of the same strip, or [`SEV`]) and `RowNode::res`.
    arc_target: Vec<u32>,
    arc_res: Vec<u32>,
    /// Strip `s` changes at the LODs `changes[change_start[s]..change_start[s + 1]]`
    /// (ascending): the display strip at LOD `l` differs from the one at `l - 1`.
    change_start: Vec<u32>,
    changes: Vec<u32>,
    /// Runtime state: `ColumnNode::currentInd` of every node, the LOD and the extracted
    /// strips (region `s` is as long as the longest strip `s` gets at any LOD).
    current_ind: Vec<u32>,
    lod: usize,
    regions: Regions,
}

/// One strip's graph while it is built.
#[derive(Default)]
struct GraphBuilder {
    /// Node of each vertex (nodes `BEGIN` and `EV` come first).
    node_of: HashMap<u32, u32>,
    vertex: Vec<u32>,
    /// Per node: its arcs as (target, res), in order of appearance.
    arcs: Vec<Vec<(u32, u32)>>,
    /// Per node: positions in `arcs[node]` of the arcs still open, in traversal order.
    open: Vec<Vec<u32>>,
    /// The nodes visited by the display strip now encoded.
    visited: Vec<u32>,
    /// Longest display strip so far.
    capacity: usize,
}

impl GraphBuilder {
    fn new() -> GraphBuilder {
        GraphBuilder {
            vertex: vec![RESTART, RESTART],
            arcs: vec![Vec::new(), Vec::new()],
            open: vec![Vec::new(), Vec::new()],
            ..GraphBuilder::default()
        }
    }

    fn node(&mut self, v: u32) -> u32 {
        if v == RESTART {
            return EV;
        }
        let next = self.vertex.len() as u32;
        *self.node_of.entry(v).or_insert_with(|| {
            self.vertex.push(v);
            self.arcs.push(Vec::new());
            self.open.push(Vec::new());
            next
        })
    }

    /// Makes `display` the strip from LOD `lod` on: per node, the open arcs that still lead
    /// where the strip goes next (a common prefix) stay, the others are closed at `lod - 1`
    /// and the rest of the path is appended as arcs appearing at `lod`.
    fn encode(&mut self, display: &[u32], lod: u32) {
        self.capacity = self.capacity.max(display.len());
        let mut desired: HashMap<u32, Vec<u32>> = HashMap::new();
        let mut path = Vec::with_capacity(display.len() + 1);
        if !display.is_empty() {
            path.push(BEGIN);
            for &v in display {
                path.push(self.node(v));
            }
            for pair in path.windows(2) {
                desired.entry(pair[0]).or_default().push(pair[1]);
            }
            desired
                .entry(*path.last().expect("not empty"))
                .or_default()
                .push(SEV);
        }
        let mut touched = std::mem::take(&mut self.visited);
        touched.extend(desired.keys().copied());
        touched.sort_unstable();
        touched.dedup();
        for &node in &touched {
            let want = desired.get(&node).map_or(&[][..], Vec::as_slice);
            let n = node as usize;
            let keep = self.open[n]
                .iter()
                .zip(want)
                .take_while(|(&a, &t)| self.arcs[n][a as usize].0 == t)
                .count();
            for &a in &self.open[n][keep..] {
                self.arcs[n][a as usize].1 = lod - 1;
            }
            self.open[n].truncate(keep);
            for &t in &want[keep..] {
                self.open[n].push(self.arcs[n].len() as u32);
                self.arcs[n].push((t, OPEN));
            }
        }
        self.visited = desired.into_keys().collect();
    }
}

impl Mts {
    /// Builds the graphs of `s0`'s strips under `seq`.
    pub fn build(s0: &Strips, seq: &CollapseSequence) -> Result<Mts, BaselineError> {
        check_inputs(s0, seq)?;
        let strips = s0.len();
        let max = seq.len();
        // The strips with every vertex mapped to its survivor, and where each vertex sits.
        let mut mapped = s0.indices.clone();
        let mut strip_of = vec![0u32; mapped.len()];
        for s in 0..strips {
            let r = s0.offsets[s] as usize..s0.offsets[s + 1] as usize;
            strip_of[r].fill(s as u32);
        }
        let mut occurrences: Vec<Vec<u32>> = vec![Vec::new(); seq.vertex_count as usize];
        for (p, &v) in mapped.iter().enumerate() {
            occurrences[v as usize].push(p as u32);
        }
        let strip_range = |s: usize| s0.offsets[s] as usize..s0.offsets[s + 1] as usize;
        let mut graphs: Vec<GraphBuilder> = (0..strips).map(|_| GraphBuilder::new()).collect();
        let mut displays: Vec<Vec<u32>> = vec![Vec::new(); strips];
        let mut changes: Vec<Vec<u32>> = vec![Vec::new(); strips];
        for s in 0..strips {
            push_display_strip(&mapped[strip_range(s)], &mut displays[s]);
            graphs[s].encode(&displays[s], 0);
        }
        let mut display = Vec::new();
        let mut touched = Vec::new();
        for (j, c) in seq.collapses.iter().enumerate() {
            let lod = j as u32 + 1;
            let moved = std::mem::take(&mut occurrences[c.u as usize]);
            touched.clear();
            for &p in &moved {
                mapped[p as usize] = c.w;
                touched.push(strip_of[p as usize]);
            }
            occurrences[c.w as usize].extend(moved);
            touched.sort_unstable();
            touched.dedup();
            for &s in &touched {
                let s = s as usize;
                display.clear();
                push_display_strip(&mapped[strip_range(s)], &mut display);
                if display != displays[s] {
                    graphs[s].encode(&display, lod);
                    std::mem::swap(&mut displays[s], &mut display);
                    changes[s].push(lod);
                }
            }
        }

        let mut mts = Mts {
            max_lod: max,
            node_start: vec![0],
            node_vertex: Vec::new(),
            arc_start: vec![0],
            arc_target: Vec::new(),
            arc_res: Vec::new(),
            change_start: vec![0],
            changes: Vec::new(),
            current_ind: Vec::new(),
            lod: 0,
            regions: Regions::new(Vec::new()),
        };
        let mut region_start = vec![0];
        for (graph, strip_changes) in graphs.into_iter().zip(changes) {
            mts.node_vertex.extend_from_slice(&graph.vertex);
            mts.node_start.push(mts.node_vertex.len() as u32);
            for arcs in graph.arcs {
                for (target, res) in arcs {
                    mts.arc_target.push(target);
                    mts.arc_res.push(if res == OPEN { max as u32 } else { res });
                }
                mts.arc_start.push(mts.arc_target.len() as u32);
            }
            mts.changes.extend(strip_changes);
            mts.change_start.push(mts.changes.len() as u32);
            let end = region_start.last().copied().unwrap_or(0) + graph.capacity as u32;
            region_start.push(end);
        }
        mts.current_ind = mts.arc_start[..mts.node_vertex.len()].to_vec();
        mts.regions = Regions::new(region_start);
        for s in 0..strips {
            mts.extract(s);
        }
        mts.regions.clear_changed();
        Ok(mts)
    }

    /// Whether strip `s` changes at a LOD in `lo + 1..=hi`.
    fn changes_between(&self, s: usize, lo: usize, hi: usize) -> bool {
        let list = &self.changes[self.change_start[s] as usize..self.change_start[s + 1] as usize];
        let first_after = list.partition_point(|&c| c as usize <= lo);
        list.get(first_after).is_some_and(|&c| c as usize <= hi)
    }

    /// Listing 2 of seed 000: reset `currentInd`, find the first beginning valid at the LOD,
    /// then follow at every node the first arc from `currentInd` with `res ≥ LOD`.
    fn extract(&mut self, s: usize) {
        let lod = self.lod as u32;
        let first = self.node_start[s] as usize;
        let nodes = first..self.node_start[s + 1] as usize;
        self.current_ind[nodes.clone()].copy_from_slice(&self.arc_start[nodes]);
        let region = self.regions.span(s);
        let capacity = region.len();
        let mut len = 0;
        let mut node = first + BEGIN as usize;
        loop {
            let end = self.arc_start[node + 1];
            let mut a = self.current_ind[node];
            while a < end && self.arc_res[a as usize] < lod {
                a += 1;
            }
            // No beginning valid at this LOD: the strip is gone. (A well-built graph never
            // runs out of arcs elsewhere, nor past the region; the bounds keep a bad one safe.)
            if a == end || len == capacity {
                break;
            }
            self.current_ind[node] = a + 1;
            let target = self.arc_target[a as usize];
            if target == SEV {
                break;
            }
            node = first + target as usize;
            self.regions.live[region.start + len] = self.node_vertex[node];
            len += 1;
        }
        self.regions.set_len(s, len);
    }
}

impl Baseline for Mts {
    fn name(&self) -> &'static str {
        "MTS"
    }

    fn primitive(&self) -> Primitive {
        Primitive::Strips
    }

    fn max_lod(&self) -> usize {
        self.max_lod
    }

    fn lod(&self) -> usize {
        self.lod
    }

    fn set_lod(&mut self, lod: usize) -> Result<(), BaselineError> {
        if lod > self.max_lod {
            return Err(BaselineError::LodOutOfRange {
                lod,
                max: self.max_lod,
            });
        }
        let (lo, hi) = (self.lod.min(lod), self.lod.max(lod));
        self.lod = lod;
        if lo == hi {
            return Ok(());
        }
        for s in 0..self.regions.count() {
            if self.changes_between(s, lo, hi) {
                self.extract(s);
            }
        }
        Ok(())
    }

    region_methods!(regions);

    fn model_bytes(&self) -> usize {
        4 * (self.node_start.len()
            + self.node_vertex.len()
            + self.arc_start.len()
            + self.arc_target.len()
            + self.arc_res.len()
            + self.change_start.len()
            + self.changes.len()
            + self.regions.start.len())
    }

    fn state_bytes(&self) -> usize {
        4 * self.current_ind.len() + self.regions.state_bytes() + 8
    }
}
