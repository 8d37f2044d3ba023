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
//! Coincidences (a B vertex on an A vertex or edge, an A vertex on a B edge,
//! overlapping edges) are decided by Simulation of Simplicity
//! ([`orient_sos`]): every orientation is answered as for one infinitesimally
//! perturbed configuration in general position, so the logic above runs
//! unchanged, and [`resolve_coincidences`] then merges the nodes the
//! perturbation pulled apart and flips away zero-area triangles.

use std::collections::{HashMap, VecDeque};

use glam::DVec3;

use super::align;
use super::sphere::{chord_parameter, orient, orient_sos, same_direction, Location, SphereMesh};
use super::{Stage, SupermeshError, SupermeshOptions};
use crate::mesh::adjacency::NONE;
use crate::mesh::IndexedMesh;

/// Where a supermesh vertex comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Node {
    A(u32),
    B(u32),
    /// A vertex and a B vertex at exactly the same sphere point.
    Both(u32, u32),
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
    /// B vertices exactly on an A vertex (merged into one node each).
    pub coincident: usize,
    /// Output triangles not strictly positive on the sphere (only possible
    /// through rounding of constructed crossing points; reported, expected 0).
    pub folds: usize,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum OverlayError {
    /// Coincident points that could not be merged into a valid triangulation.
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
    /// `fi`, `gi`: the corners' global indices for [`orient_sos`] (A's
    /// vertex indices, B's offset by A's vertex count).
    fn new(f: [DVec3; 3], g: [DVec3; 3], fi: [u32; 3], gi: [u32; 3]) -> Result<Pair, OverlayError> {
        let mut sa = [[0.0; 3]; 3];
        let mut sb = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                let (j1, i1) = ((j + 1) % 3, (i + 1) % 3);
                sa[i][j] = orient_sos([g[j], g[j1], f[i]], [gi[j], gi[j1], fi[i]]);
                sb[i][j] = orient_sos([f[i], f[i1], g[j]], [fi[i], fi[i1], gi[j]]);
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
            let na = self.ma.points.len() as u32;
            let p = Pair::new(
                self.ma.corners(f),
                gc,
                self.ma.triangles[f as usize],
                gt.map(|v| v + na),
            )?;
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
            coincident: 0,
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
                    Location::Degenerate(_) => {
                        locate_sos(ma, mb.points[gt[0] as usize], na as u32 + gt[0])
                            .ok_or(OverlayError::Degenerate)?
                    }
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
    let mut out = builder.out;
    resolve_coincidences(ma, mb, &mut out)?;
    Ok(out)
}

/// The A face that holds B point `p` (global index `id`) under the
/// symbolic perturbation, by a scan.
fn locate_sos(ma: &SphereMesh, p: DVec3, id: u32) -> Option<u32> {
    (0..ma.triangles.len() as u32).find(|&t| {
        let v = ma.triangles[t as usize];
        let c = ma.corners(t);
        (0..3).all(|i| {
            let i1 = (i + 1) % 3;
            orient_sos([c[i], c[i1], p], [v[i], v[i1], id]) > 0.0
        })
    })
}

/// Undoes the symbolic perturbation where it made something of nothing.
///
/// Under [`orient_sos`] a B vertex exactly on an A vertex is a separate
/// node a zero distance away, a B vertex exactly on an A edge is crossed by
/// that edge's neighbouring B edges at itself, and two overlapping edges
/// cross somewhere along their overlap; each such crossing and such B
/// vertex is merged into the node it coincides with (contracting
/// zero-length edges of the overlay), triangles left with a repeated corner
/// are dropped, and zero-area triangles whose three corners lie on one
/// great circle are flipped away against their neighbour across the long
/// edge. Exact: the coincidences are decided by exact orientations of input
/// points.
#[allow(clippy::needless_range_loop)] // Node ids index several arrays.
fn resolve_coincidences(
    ma: &SphereMesh,
    mb: &SphereMesh,
    out: &mut Overlay,
) -> Result<(), OverlayError> {
    let na = ma.points.len() as u32;
    let n = out.nodes.len();
    let mut target: Vec<u32> = (0..n as u32).collect();
    let mut any = false;
    // B vertices on A vertices: the B node goes into the A node.
    for (b, &f) in out.b_in_a.iter().enumerate() {
        let pb = mb.points[b];
        if let Some(&a) = ma.triangles[f as usize]
            .iter()
            .find(|&&a| same_direction(ma.points[a as usize], pb))
        {
            target[na as usize + b] = a;
            out.nodes[a as usize] = Node::Both(a, b as u32);
            out.coincident += 1;
            any = true;
        }
    }
    // Crossings at an endpoint, or of overlapping edges.
    for k in 0..n {
        let Node::Crossing { a, b, .. } = out.nodes[k] else {
            continue;
        };
        let pa = a.map(|v| ma.points[v as usize]);
        let pb = b.map(|v| mb.points[v as usize]);
        let a_on = [0, 1].map(|i| orient(pb[0], pb[1], pa[i]) == 0.0);
        let b_on = [0, 1].map(|j| orient(pa[0], pa[1], pb[j]) == 0.0);
        let to = if a_on[0] && a_on[1] {
            // Overlapping edges on one great circle: the endpoint inside
            // the overlap nearest to where the crossing was put.
            let inside = |p: DVec3, q: [DVec3; 2]| {
                let (u, w) = (q[0].cross(p), p.cross(q[1]));
                let axis = q[0].cross(q[1]);
                u.dot(axis) >= 0.0 && w.dot(axis) >= 0.0
            };
            let at = out.sphere[k];
            let mut best: Option<(f64, u32)> = None;
            for i in 0..2 {
                if inside(pa[i], pb) {
                    let d = (pa[i].normalize() - at).length();
                    if best.is_none_or(|(e, _)| d < e) {
                        best = Some((d, a[i]));
                    }
                }
                if inside(pb[i], pa) {
                    let d = (pb[i].normalize() - at).length();
                    if best.is_none_or(|(e, _)| d < e) {
                        best = Some((d, na + b[i]));
                    }
                }
            }
            best.map(|(_, v)| v)
        } else if let Some(i) = (0..2).find(|&i| a_on[i]) {
            Some(a[i])
        } else {
            (0..2).find(|&j| b_on[j]).map(|j| na + b[j])
        };
        if let Some(v) = to {
            target[k] = v;
            out.crossings -= 1;
            any = true;
        }
    }
    if !any {
        return Ok(());
    }
    // Follow chains (a crossing into a B vertex into an A vertex).
    let find = |mut v: u32, target: &[u32]| {
        while target[v as usize] != v {
            v = target[v as usize];
        }
        v
    };
    let mut index = vec![NONE; n];
    let (mut nodes, mut sphere) = (Vec::new(), Vec::new());
    for k in 0..n {
        if find(k as u32, &target) == k as u32 {
            index[k] = nodes.len() as u32;
            nodes.push(out.nodes[k]);
            sphere.push(out.sphere[k]);
        }
    }
    let mut triangles: Vec<[u32; 3]> = out
        .triangles
        .iter()
        .map(|t| t.map(|v| index[find(v, &target) as usize]))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
        .collect();
    flip_collinear(&sphere, &mut triangles)?;
    out.nodes = nodes;
    out.sphere = sphere;
    out.triangles = triangles;
    Ok(())
}

/// Removes zero-area triangles `(p, m, r)` whose corners lie on one great
/// circle with `m` between `p` and `r`: with the neighbour `(r, p, s)`
/// across the long edge they become `(p, m, s)` and `(m, r, s)`.
fn flip_collinear(sphere: &[DVec3], triangles: &mut [[u32; 3]]) -> Result<(), OverlayError> {
    let mut edges: HashMap<(u32, u32), usize> = HashMap::new();
    for (k, t) in triangles.iter().enumerate() {
        for i in 0..3 {
            edges.insert((t[i], t[(i + 1) % 3]), k);
        }
    }
    let flat = |t: [u32; 3]| {
        orient(
            sphere[t[0] as usize],
            sphere[t[1] as usize],
            sphere[t[2] as usize],
        ) == 0.0
    };
    let mut todo: Vec<usize> = (0..triangles.len())
        .filter(|&k| flat(triangles[k]))
        .collect();
    let mut budget = 16 * todo.len() + 16;
    while let Some(k) = todo.pop() {
        let t = triangles[k];
        if !flat(t) {
            continue;
        }
        budget = budget.checked_sub(1).ok_or(OverlayError::Degenerate)?;
        // The middle corner: the one its two neighbours lie on either side of.
        let p = t.map(|v| sphere[v as usize].normalize());
        let Some(i) = (0..3).find(|&i| {
            let (a, b) = (p[(i + 2) % 3] - p[i], p[(i + 1) % 3] - p[i]);
            a.dot(b) < 0.0
        }) else {
            return Err(OverlayError::Degenerate);
        };
        let (m, r, pp) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
        // t = (pp, m, r) cyclically; the long edge r → pp.
        let Some(&j) = edges.get(&(pp, r)) else {
            return Err(OverlayError::Degenerate);
        };
        let u = triangles[j];
        let s = u[(u.iter().position(|&x| x == pp).unwrap() + 2) % 3];
        for tri in [t, u] {
            for e in 0..3 {
                edges.remove(&(tri[e], tri[(e + 1) % 3]));
            }
        }
        triangles[k] = [pp, m, s];
        triangles[j] = [m, r, s];
        for kk in [k, j] {
            let tri = triangles[kk];
            for e in 0..3 {
                edges.insert((tri[e], tri[(e + 1) % 3]), kk);
            }
            if flat(tri) {
                todo.push(kk);
            }
        }
    }
    Ok(())
}

/// How many random rotations the overlay tries before giving up on input
/// that stays degenerate.
pub const OVERLAY_ATTEMPTS: usize = 8;

/// Smallest angle (radians) of the random rotation of B's sphere; the angle
/// is drawn in `[MIN, 2 MIN)`. Small enough not to undo the alignment.
const PERTURBATION: f64 = 2e-3;

/// Stage 5: the overlay under a tiny random rotation of B, again under
/// another one while A and B points are degenerate.
pub(super) fn overlay_with_retries(
    a: &IndexedMesh,
    a_sphere: &[DVec3],
    b: &IndexedMesh,
    b_sphere: Vec<DVec3>,
    landmarks: bool,
    options: &SupermeshOptions,
) -> Result<(Overlay, Vec<DVec3>, usize), SupermeshError> {
    let ma = SphereMesh::new(a_sphere, &a.triangles);
    let attempts = if options.perturb { OVERLAY_ATTEMPTS } else { 1 };
    let mut progress = |f: f32| {
        if let Some(p) = options.progress {
            p(Stage::Overlay, f);
        }
    };
    for attempt in 0..attempts {
        let mut points = b_sphere.clone();
        // Landmark pairs sit on exactly one sphere point each: the first try
        // keeps them there (the overlay merges them), later tries perturb.
        if options.perturb && !(landmarks && attempt == 0) {
            let r = align::random_rotation(options.seed.wrapping_add(attempt as u64), PERTURBATION);
            if !align::rotate(&mut points, &b.triangles, r) {
                continue;
            }
        }
        let mb = SphereMesh::new(&points, &b.triangles);
        match overlay(&ma, &mb, &mut progress) {
            Ok(o) => return Ok((o, points, attempt + 1)),
            Err(OverlayError::Degenerate) => continue,
            Err(OverlayError::Inconsistent { a_face, b_face }) => {
                return Err(SupermeshError::Overlay { a_face, b_face })
            }
        }
    }
    Err(SupermeshError::Degenerate { attempts })
}
