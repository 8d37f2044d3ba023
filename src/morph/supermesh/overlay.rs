//! The overlay of two spherical triangulations: every non-empty intersection
//! of an A face `F` with a B face `G` is one convex spherical polygon of the
//! supermesh, fan-triangulated.
//!
//! Every topological decision is an exact orientation predicate on *input*
//! sphere points only (never on a constructed crossing point): which side of
//! an edge's great circle a vertex lies on, and whether two edges cross
//! (S2's four-orientation test, which also settles the antipodal ambiguity of
//! great circles). Polygon corners are named combinatorially (A vertex, B
//! vertex, or the crossing of an A edge with a B edge), so neighbouring
//! polygons share corners exactly and the result is a closed manifold.
//!
//! The B faces are visited breadth first and, for each, the A faces it
//! overlaps breadth first from the face holding one of its vertices (found by
//! walking), crossing only A edges that meet the inside of `G`.
//!
//! Input in general position is assumed: an orientation that is exactly zero
//! between an A point and B points (a B vertex on an A vertex or edge, or an
//! A vertex on a B edge) stops the overlay with [`OverlayError::Degenerate`];
//! the caller then turns B by another tiny random rotation and tries again.

use std::collections::{HashMap, VecDeque};

use glam::DVec3;

use super::sphere::{chord_parameter, orient, Location, SphereMesh};
use crate::mesh::adjacency::NONE;

/// Where a supermesh vertex comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Node {
    A(u32),
    B(u32),
    /// The crossing of A edge `a` (point `(1 − ta) a[0] + ta a[1]` of its chord)
    /// with B edge `b` (at `tb`); each edge is stored low index first.
    Crossing {
        a: [u32; 2],
        ta: f64,
        b: [u32; 2],
        tb: f64,
    },
}

pub(crate) struct Overlay {
    pub nodes: Vec<Node>,
    pub sphere: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// The B face that holds each A vertex.
    pub a_in_b: Vec<u32>,
    /// The A face that holds each B vertex.
    pub b_in_a: Vec<u32>,
    pub crossings: usize,
    /// Output triangles not strictly positive on the sphere (only possible
    /// through rounding of constructed crossing points; reported, expected 0).
    pub folds: usize,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum OverlayError {
    /// An exact zero orientation between A and B points.
    Degenerate,
    /// A polygon walk did not close (cannot happen in general position).
    Inconsistent { a_face: u32, b_face: u32 },
}

/// Everything the pair `(F, G)` needs, from 18 exact orientations.
struct Pair {
    /// `sa[i][j]`: side of F's corner `i` w.r.t. G's edge `j` (positive: inside).
    sa: [[f64; 3]; 3],
    /// `sb[i][j]`: side of G's corner `j` w.r.t. F's edge `i`.
    sb: [[f64; 3]; 3],
    in_g: [bool; 3],
    in_f: [bool; 3],
    cross: [[bool; 3]; 3],
}

impl Pair {
    fn new(f: [DVec3; 3], g: [DVec3; 3]) -> Result<Pair, OverlayError> {
        let mut sa = [[0.0; 3]; 3];
        let mut sb = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                sa[i][j] = orient(g[j], g[(j + 1) % 3], f[i]);
                sb[i][j] = orient(f[i], f[(i + 1) % 3], g[j]);
                if sa[i][j] == 0.0 || sb[i][j] == 0.0 {
                    return Err(OverlayError::Degenerate);
                }
            }
        }
        let in_g = [0, 1, 2].map(|i| sa[i].iter().all(|&s| s > 0.0));
        let in_f = [0, 1, 2].map(|j| (0..3).all(|i| sb[i][j] > 0.0));
        let mut cross = [[false; 3]; 3];
        for (i, row) in cross.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                // S2's crossing test on A = f[i], B = f[i+1], C = g[j], D = g[j+1]:
                // ACB, BDA, CBD, DAC all of one sign.
                let acb = -sb[i][j];
                let bda = sb[i][(j + 1) % 3];
                let cbd = -sa[(i + 1) % 3][j];
                let dac = sa[i][j];
                *c = (acb > 0.0) == (bda > 0.0)
                    && (acb > 0.0) == (cbd > 0.0)
                    && (acb > 0.0) == (dac > 0.0);
            }
        }
        Ok(Pair {
            sa,
            sb,
            in_g,
            in_f,
            cross,
        })
    }

    fn is_empty(&self) -> bool {
        !self.in_g.iter().any(|&x| x)
            && !self.in_f.iter().any(|&x| x)
            && !self.cross.iter().flatten().any(|&x| x)
    }

    /// Whether F's edge `i` meets the inside of G (so the A face across it overlaps G).
    fn edge_meets_g(&self, i: usize) -> bool {
        self.in_g[i] || self.in_g[(i + 1) % 3] || self.cross[i].iter().any(|&c| c)
    }

    /// The G edge where F's edge `i` leaves G.
    fn f_exit(&self, i: usize) -> Option<usize> {
        (0..3).find(|&j| self.cross[i][j] && self.sa[i][j] > 0.0)
    }

    /// The F edge where G's edge `j` leaves F.
    fn g_exit(&self, j: usize) -> Option<usize> {
        (0..3).find(|&i| self.cross[i][j] && self.sb[i][j] > 0.0)
    }
}

/// A corner of `F ∩ G`: F's corner, G's corner, or F edge × G edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Corner {
    A(usize),
    B(usize),
    X(usize, usize),
}

/// The corners of the convex polygon `F ∩ G`, counter-clockwise: its boundary
/// follows F's and G's edges in their own direction, switching at crossings.
fn polygon(p: &Pair) -> Option<Vec<Corner>> {
    let next = |c: Corner| -> Option<Corner> {
        let along_f = |i: usize| {
            if p.in_g[(i + 1) % 3] {
                Some(Corner::A((i + 1) % 3))
            } else {
                p.f_exit(i).map(|j| Corner::X(i, j))
            }
        };
        let along_g = |j: usize| {
            if p.in_f[(j + 1) % 3] {
                Some(Corner::B((j + 1) % 3))
            } else {
                p.g_exit(j).map(|i| Corner::X(i, j))
            }
        };
        match c {
            Corner::A(i) => along_f(i),
            Corner::B(j) => along_g(j),
            // F's edge enters G here (its start is outside G's edge j): go on along F.
            Corner::X(i, j) if p.sa[i][j] < 0.0 => along_f(i),
            Corner::X(_, j) => along_g(j),
        }
    };
    let start = (0..3)
        .find(|&i| p.in_g[i])
        .map(Corner::A)
        .or_else(|| (0..3).find(|&j| p.in_f[j]).map(Corner::B))
        .or_else(|| {
            (0..9)
                .find(|&k| p.cross[k / 3][k % 3])
                .map(|k| Corner::X(k / 3, k % 3))
        })?;
    let mut corners = vec![start];
    let mut at = start;
    loop {
        at = next(at)?;
        if at == start {
            break;
        }
        if corners.len() >= 9 || corners.contains(&at) {
            return None;
        }
        corners.push(at);
    }
    (corners.len() >= 3).then_some(corners)
}

struct Builder<'a> {
    ma: &'a SphereMesh<'a>,
    mb: &'a SphereMesh<'a>,
    out: Overlay,
    crossing_ids: HashMap<(u64, u64), u32>,
}

fn edge_key(a: u32, b: u32) -> u64 {
    ((a.min(b) as u64) << 32) | a.max(b) as u64
}

impl Builder<'_> {
    /// The supermesh vertex of a polygon corner, created on first sight.
    fn node(&mut self, f: u32, g: u32, p: &Pair, c: Corner) -> u32 {
        let na = self.ma.points.len() as u32;
        let ft = self.ma.triangles[f as usize];
        let gt = self.mb.triangles[g as usize];
        match c {
            Corner::A(i) => ft[i],
            Corner::B(j) => na + gt[j],
            Corner::X(i, j) => {
                let (a0, a1) = (ft[i], ft[(i + 1) % 3]);
                let (b0, b1) = (gt[j], gt[(j + 1) % 3]);
                let key = (edge_key(a0, a1), edge_key(b0, b1));
                if let Some(&id) = self.crossing_ids.get(&key) {
                    return id;
                }
                // Chord parameters from the low-index end, from the sides
                // already computed: linear along a chord.
                let (da0, da1) = (p.sa[i][j], p.sa[(i + 1) % 3][j]);
                let (db0, db1) = (p.sb[i][j], p.sb[i][(j + 1) % 3]);
                let (a, ta) = if a0 < a1 {
                    ([a0, a1], chord_parameter(da0, da1))
                } else {
                    ([a1, a0], chord_parameter(da1, da0))
                };
                let (b, tb) = if b0 < b1 {
                    ([b0, b1], chord_parameter(db0, db1))
                } else {
                    ([b1, b0], chord_parameter(db1, db0))
                };
                let pa0 = self.ma.points[a[0] as usize];
                let pa1 = self.ma.points[a[1] as usize];
                let point = (pa0 * (1.0 - ta) + pa1 * ta).normalize();
                let id = self.out.nodes.len() as u32;
                self.out.nodes.push(Node::Crossing { a, ta, b, tb });
                self.out.sphere.push(point);
                self.out.crossings += 1;
                self.crossing_ids.insert(key, id);
                id
            }
        }
    }

    /// Fan-triangulates a convex polygon from the first corner whose fan is
    /// strictly positive on the sphere (every fan is, in exact arithmetic).
    fn emit(&mut self, ids: &[u32]) {
        let k = ids.len();
        let pos = |v: u32| self.out.sphere[v as usize];
        let fan_ok = |s: usize| {
            (1..k - 1).all(|m| {
                orient(
                    pos(ids[s]),
                    pos(ids[(s + m) % k]),
                    pos(ids[(s + m + 1) % k]),
                ) > 0.0
            })
        };
        let apex = (0..k).find(|&s| fan_ok(s));
        let s = apex.unwrap_or(0);
        for m in 1..k - 1 {
            let t = [ids[s], ids[(s + m) % k], ids[(s + m + 1) % k]];
            if apex.is_none() && orient(pos(t[0]), pos(t[1]), pos(t[2])) <= 0.0 {
                self.out.folds += 1;
            }
            self.out.triangles.push(t);
        }
    }

    /// Handles every A face that `F ∩ G` reaches for one B face `g`.
    fn b_face(&mut self, g: u32, start: u32, seen: &mut Vec<u32>) -> Result<(), OverlayError> {
        let gc = self.mb.corners(g);
        let gt = self.mb.triangles[g as usize];
        seen.clear();
        seen.push(start);
        let mut stack = vec![start];
        while let Some(f) = stack.pop() {
            let p = Pair::new(self.ma.corners(f), gc)?;
            if p.is_empty() {
                continue;
            }
            let ft = self.ma.triangles[f as usize];
            for i in 0..3 {
                if p.in_g[i] {
                    self.out.a_in_b[ft[i] as usize] = g;
                }
                if p.in_f[i] {
                    self.out.b_in_a[gt[i] as usize] = f;
                }
            }
            let corners = polygon(&p).ok_or(OverlayError::Inconsistent {
                a_face: f,
                b_face: g,
            })?;
            let ids: Vec<u32> = corners.iter().map(|&c| self.node(f, g, &p, c)).collect();
            self.emit(&ids);
            for i in 0..3 {
                let n = self.ma.neighbors[f as usize][i];
                if p.edge_meets_g(i) && n != NONE && !seen.contains(&n) {
                    seen.push(n);
                    stack.push(n);
                }
            }
        }
        Ok(())
    }
}

/// Overlays `a` and `b` (both bijective on the sphere, in one frame).
pub(crate) fn overlay(
    ma: &SphereMesh,
    mb: &SphereMesh,
    progress: &mut dyn FnMut(f32),
) -> Result<Overlay, OverlayError> {
    let (na, nb) = (ma.points.len(), mb.points.len());
    let mut builder = Builder {
        ma,
        mb,
        out: Overlay {
            nodes: (0..na as u32)
                .map(Node::A)
                .chain((0..nb as u32).map(Node::B))
                .collect(),
            sphere: ma.points.iter().chain(mb.points).copied().collect(),
            triangles: Vec::with_capacity(2 * (ma.triangles.len() + mb.triangles.len()) * 3),
            a_in_b: vec![NONE; na],
            b_in_a: vec![NONE; nb],
            crossings: 0,
            folds: 0,
        },
        crossing_ids: HashMap::new(),
    };
    let faces = mb.triangles.len();
    let mut visited = vec![false; faces];
    let mut queue = VecDeque::new();
    let mut rng = 0x5eed_u64;
    let mut hint = 0u32;
    let mut seen = Vec::new();
    let mut done = 0usize;
    for root in 0..faces as u32 {
        if visited[root as usize] {
            continue;
        }
        visited[root as usize] = true;
        queue.push_back(root);
        while let Some(g) = queue.pop_front() {
            let gt = mb.triangles[g as usize];
            let start = match gt
                .iter()
                .map(|&v| builder.out.b_in_a[v as usize])
                .find(|&f| f != NONE)
            {
                Some(f) => f,
                None => match ma.locate(mb.points[gt[0] as usize], hint, &mut rng) {
                    Location::Inside(f) => f,
                    Location::Degenerate(_) => return Err(OverlayError::Degenerate),
                },
            };
            builder.b_face(g, start, &mut seen)?;
            hint = start;
            for &n in &mb.neighbors[g as usize] {
                if n != NONE && !visited[n as usize] {
                    visited[n as usize] = true;
                    queue.push_back(n);
                }
            }
            done += 1;
            if done.is_multiple_of(8192) {
                progress(done as f32 / faces as f32);
            }
        }
    }
    if builder.out.a_in_b.contains(&NONE) || builder.out.b_in_a.contains(&NONE) {
        return Err(OverlayError::Inconsistent {
            a_face: NONE,
            b_face: NONE,
        });
    }
    Ok(builder.out)
}
