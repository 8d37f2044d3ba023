//! Quadric error simplification (Garland–Heckbert) by half-edge collapses,
//! run to the end: the output is the whole [`CollapseSequence`], from full
//! detail down to the smallest mesh the topology rules allow.
//!
//! This module owns the collapse order and its validity rules. Only half-edge
//! collapses are made (`u` moves onto an existing neighbour `w`) because the
//! runtime shares one vertex buffer across every LOD and animation frame: no
//! collapse may invent a position.
//!
//! Choices follow meshoptimizer's `meshopt_simplify`, whose users expect its
//! quality:
//! * face planes are weighted by `sqrt(2 · area)`, so the error scales linearly
//!   with size (better silhouettes than plain area weights);
//! * every boundary edge adds a plane through the edge, perpendicular to its
//!   triangle, weighted by edge length × [`SimplifyOptions::boundary_weight`];
//!   on a mesh with seams each seam edge adds the same plane on each of its sides,
//!   weighted by edge length × half of [`SimplifyOptions::seam_weight`];
//! * the cost of `u → w` is `Q_u(p_w) / W_u`: the weighted mean squared distance
//!   from `p_w` to the planes that `u` stands for, in object units squared.
//!   That is the [`Collapse::error`](crate::collapse::Collapse) recorded.
//!
//! Unlike meshoptimizer (which collapses in independent batches) the order is
//! strictly greedy: an indexed min-heap holds one entry per vertex, its
//! cheapest outgoing half-edge, updated in place (decrease/increase key) when
//! its fan or quadric changes, so the heap never exceeds the vertex count and
//! holds no stale entries. Costs are cheap, validity checks are not, so a
//! candidate is only validated when it is popped (lazily: its 2-ring may have
//! changed since it was ranked).
//!
//! Topology rules (each checked on the current mesh before a collapse):
//! * an interior vertex may collapse onto any neighbour; a boundary vertex only
//!   along a boundary edge onto a boundary neighbour (so borders never merge,
//!   holes never close, and an interior edge between two boundary vertices is
//!   never collapsed); vertices that are not manifold never move;
//! * the link condition: `u` and `w` share no neighbour other than the apexes
//!   of the triangles on edge `uw` (this also stops a boundary loop of three
//!   edges from closing);
//! * no collapse creates a triangle that already exists (the tetrahedron case),
//!   or removes the last triangle of a component;
//! * no remaining triangle around `u` flips or degenerates: the cosine between
//!   its normals before and after must exceed
//!   [`SimplifyOptions::min_normal_cos`];
//! * on a mesh with seams ([`simplify_with_seams`]): the seam rule of
//!   [`crate::seams`] (no torn seam, no folded UV triangle).
//!
//! On a mesh with seams the cost also holds the attribute error of UVs and normals
//! (`AttributeMetric`, weighted by [`SimplifyOptions::uv_weight`] and
//! [`SimplifyOptions::normal_weight`]).
//!
//! With [`SimplifyOptions::distance_weight`] the position error is at least the distance
//! term (a Hausdorff-style distance between the coarse and the full surface, tracked as
//! collapses are made). It is far dearer than a quadric, so it is priced lazily: a vertex is
//! queued by its quadric cost (a lower bound), and priced with the term when it reaches the
//! top, then queued again; the order is the same as pricing every candidate eagerly. Pricing
//! only reads the state, so the vertices waiting at the top to be priced are priced together
//! on the rayon pool: the same sequence on any number of threads.

use glam::DVec3;
use rayon::prelude::*;

use crate::collapse::{Collapse, CollapseSequence};
use crate::mesh::adjacency::{VertexTriangles, NONE};
use crate::metrics::closest_point;
use crate::seams::SeamRule;

/// Tuning of the simplifier; `Default` matches meshoptimizer's choices.
#[derive(Clone, Debug, PartialEq)]
pub struct SimplifyOptions {
    /// Weight of a boundary edge's plane relative to the face planes (meshoptimizer uses 10):
    /// higher keeps open borders in place longer.
    pub boundary_weight: f32,
    /// A collapse is rejected when a remaining triangle's normal turns by more than
    /// `acos(min_normal_cos)` or degenerates. 0.25 (about 75°) as in meshoptimizer: the
    /// "pure" test (0, 90°) lets a series of near-90° collapses fold a surface over.
    pub min_normal_cos: f32,
    /// Weight of a seam edge's plane relative to the face planes ([`simplify_with_seams`]: an
    /// edge of the welded surface whose sides have different attribute vertices), half on
    /// each side as in meshoptimizer, which uses 1: keeps a UV seam's line in place, so the
    /// texture on either side of it stays where it was. 0 turns it off; default
    /// [`SEAM_WEIGHT`].
    pub seam_weight: f32,
    /// Weight of a point quadric at each vertex, relative to its plane weights. A tiny value
    /// only breaks ties on flat regions (shorter edges collapse first) without changing shape.
    pub regularization: f32,
    /// Weight of the UV term of the attribute error ([`simplify_with_seams`] on a mesh with
    /// UVs; meshes without attributes never use it). Moving an attribute vertex whose
    /// triangles cover area `A` (object units², growing as collapses merge them) so that its
    /// UV misses what its triangles interpolate by `d` texture units costs as much as moving
    /// a vertex `uv_weight × d × √A` off its planes. 0 turns the term off; default
    /// [`UV_WEIGHT`].
    pub uv_weight: f32,
    /// Weight of the normal term of the attribute error (the normals given by
    /// [`SeamRule::with_normals`]), as [`uv_weight`](Self::uv_weight) with `d` the length of
    /// the difference of unit normals (about the angle in radians when small). 0 turns the
    /// term off; default [`NORMAL_WEIGHT`].
    pub normal_weight: f32,
    /// Weight of the distance term, which prices how far a collapse takes the coarse surface
    /// from the full one, both ways (Hausdorff-style), where the quadrics price only a
    /// vertex's distance to the planes it stands for and underestimate the error once a few
    /// large triangles span a curved region or a gap:
    /// * every vertex a collapse removes stays attached to the nearest triangle of the fan
    ///   that replaced it, and its distance to that triangle counts;
    /// * 12 points of each new triangle (a grid of step 1/4) count by their distance to the
    ///   full-detail triangles around the nearest vertex (an upper bound of their distance
    ///   to the full surface).
    ///
    /// A collapse's position error becomes the larger of its quadric error and
    /// `distance_weight ×` the largest such squared distance (object units², the largest over
    /// the poses, scaled as the quadric errors are). So at every step of the sequence each
    /// removed vertex lies within `sqrt(error / distance_weight)` of the coarse surface in the
    /// first pose, where `error` is the largest collapse error so far. Costs build time (many
    /// times the quadric-only build; BENCHMARKS.md, "Distance term"). 0 (the default) turns
    /// it off; [`DISTANCE_WEIGHT`] is the measured choice.
    pub distance_weight: f32,
}

impl Default for SimplifyOptions {
    fn default() -> Self {
        Self {
            boundary_weight: 10.0,
            seam_weight: SEAM_WEIGHT,
            min_normal_cos: 0.25,
            regularization: 1e-7,
            uv_weight: UV_WEIGHT,
            normal_weight: NORMAL_WEIGHT,
            distance_weight: 0.0,
        }
    }
}

/// How [`simplify_poses`] combines a collapse's error over the poses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PoseError {
    /// The mean over the poses of each pose's quadric error (the sum of Mohr and Gleicher's
    /// "deformation sensitive decimation", divided by the pose count so errors stay squared
    /// distances).
    Mean,
    /// The largest of the poses' quadric errors: a collapse is as cheap as its worst pose, so
    /// no pose is given up for the others (lower error at the worst `t`; BENCHMARKS.md).
    #[default]
    Max,
}

/// Simplifies the mesh to the end and returns every collapse in order.
///
/// `positions` should be finite and `triangles` in range (see
/// [`IndexedMesh::validate`](crate::mesh::IndexedMesh::validate)); triangles
/// with an out-of-range or repeated index are ignored rather than trusted.
/// Non-manifold input does not fail: vertices on non-manifold edges or with
/// more than one fan stay put. Pure function, no shared state: safe to call
/// from many threads at once.
pub fn simplify(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    options: &SimplifyOptions,
) -> CollapseSequence {
    simplify_poses(&[positions], triangles, options, PoseError::default())
}

/// One collapse sequence for several poses of one triangulation (pose-aware simplification):
/// every vertex keeps one quadric per pose, a collapse `u → w` costs the [`PoseError`]
/// combination of each pose's error at `w`'s position in that pose, and is valid only if no
/// triangle flips or degenerates in any pose. With one pose this is [`simplify`].
///
/// Each pose's error is scaled to the first pose's size, by the squared ratio of the first
/// pose's bounding-box diagonal to its own, so a pose counts by its error relative to its size:
/// scaling one pose uniformly does not change the sequence, and a pose that shrinks the mesh is
/// not given up for the larger ones.
///
/// Every pose must have the vertex count of the first; no pose at all gives an empty
/// sequence. The reported errors are squared distances in the first pose's object units, like
/// [`simplify`]'s.
///
/// # Panics
/// If the poses differ in length.
pub fn simplify_poses(
    poses: &[&[[f32; 3]]],
    triangles: &[[u32; 3]],
    options: &SimplifyOptions,
    combine: PoseError,
) -> CollapseSequence {
    let Some(first) = poses.first() else {
        return CollapseSequence::default();
    };
    let n = first.len();
    assert!(
        poses.iter().all(|p| p.len() == n),
        "every pose needs one position per vertex"
    );
    let tris: Vec<[u32; 3]> = triangles
        .iter()
        .copied()
        .filter(|t| {
            t.iter().all(|&v| (v as usize) < n) && t[0] != t[1] && t[1] != t[2] && t[0] != t[2]
        })
        .collect();
    let mut state = State::new(poses, tris, &[], options, combine, None);
    state.run();
    CollapseSequence {
        vertex_count: n as u32,
        collapses: state.collapses,
    }
}

/// Simplifies a mesh with seams on its welded surface: `positions` and `triangles` are over
/// attribute vertices, `rule` welds them ([`SeamRule`]). The result is a sequence of
/// *topology* collapses (over `rule.topology_count()` vertices) that the seam rule accepts
/// at every step, on top of every rule of [`simplify`]; [`crate::seams::expand`] turns it
/// into the attribute-level sequence the runtime plays.
///
/// Welded copies must share their position (a [`crate::morph::TopologyMap`] guarantees it); each topology
/// vertex takes the position of its first copy. The cost of `u → w` adds the attribute error
/// of the rule's UVs and normals ([`SimplifyOptions::uv_weight`]) over the attribute
/// triangles, in the first pose. Triangles with an out-of-range or repeated
/// attribute index are ignored; a triangle whose corners weld into fewer than three topology
/// vertices (a sliver across a seam) is not simplified over, and its corners never move.
/// With an identity map, no UVs and no normals (or both weights 0) the sequence equals
/// [`simplify`]'s.
pub fn simplify_with_seams(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    rule: &SeamRule,
    options: &SimplifyOptions,
) -> CollapseSequence {
    simplify_poses_with_seams(&[positions], triangles, rule, options, PoseError::default())
}

/// [`simplify_with_seams`] over several poses, as [`simplify_poses`] does for meshes without
/// seams: one topology sequence valid in every pose. The attribute error is the first pose's
/// (UVs do not change with the pose; what a pose does to the normals is its change of shape,
/// which each pose's position quadrics price).
///
/// # Panics
/// If the poses differ in length.
pub fn simplify_poses_with_seams(
    poses: &[&[[f32; 3]]],
    triangles: &[[u32; 3]],
    rule: &SeamRule,
    options: &SimplifyOptions,
    combine: PoseError,
) -> CollapseSequence {
    let Some(first) = poses.first() else {
        return CollapseSequence::default();
    };
    assert!(
        poses.iter().all(|p| p.len() == first.len()),
        "every pose needs one position per vertex"
    );
    let n = first.len().min(rule.vertex_count());
    let tn = rule.topology_count();
    let welded: Vec<Vec<[f32; 3]>> = poses
        .iter()
        .map(|positions| {
            let mut welded = vec![[0.0f32; 3]; tn];
            for v in (0..n as u32).rev() {
                welded[rule.topology_of(v) as usize] = positions[v as usize];
            }
            welded
        })
        .collect();
    let welded: Vec<&[[f32; 3]]> = welded.iter().map(Vec::as_slice).collect();
    let mut tris = Vec::with_capacity(triangles.len());
    let mut corners = Vec::with_capacity(triangles.len());
    let mut pinned = Vec::new();
    for &t in triangles {
        if !(t.iter().all(|&v| (v as usize) < n) && t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) {
            continue;
        }
        let topo = t.map(|v| rule.topology_of(v));
        if topo[0] == topo[1] || topo[1] == topo[2] || topo[0] == topo[2] {
            pinned.extend(topo);
            continue;
        }
        tris.push(topo);
        corners.push(t);
    }
    let metric = AttributeMetric::new(welded[0], &tris, &corners, rule, options);
    let seams = Seams {
        rule,
        corners,
        pairs: Vec::new(),
        metric,
    };
    let seam_edges = seam_edges(&tris, &seams.corners);
    let mut state = State::new(&welded, tris, &seam_edges, options, combine, Some(seams));
    for v in pinned {
        state.kind[v as usize] = Kind::Locked;
    }
    state.run();
    CollapseSequence {
        vertex_count: tn as u32,
        collapses: state.collapses,
    }
}

/// The simplifier's view of the seams: the rule, and per live triangle its attribute
/// corners (kept in step with the topology triangles as collapses re-point them).
struct Seams<'r, 'm> {
    rule: &'r SeamRule<'m>,
    corners: Vec<[u32; 3]>,
    /// Scratch for the rule's `(a, b)` pairs.
    pairs: Vec<(u32, u32)>,
    /// The attribute error, when the mesh has weighted attributes.
    metric: Option<AttributeMetric>,
}

impl Seams<'_, '_> {
    /// Folds the attribute error of every attribute vertex of the collapse being made (the
    /// pairs of the last [`allows`](Self::allows)) into its target.
    fn merge_metric(&mut self) {
        if let Some(metric) = &mut self.metric {
            for &(a, b) in &self.pairs {
                metric.merge(a, b);
            }
        }
    }

    /// The attribute error of `u → w` (0 without a metric): the sum over the attribute
    /// vertices of `u` on edge `uw` (in `fan`, the live triangles of `u` over `tris`) of
    /// moving each onto the copy of `w` across the edge, at `w`'s position `p`.
    fn attribute_cost(&self, tris: &[[u32; 3]], fan: &[u32], u: u32, w: u32, p: DVec3) -> f64 {
        let Some(metric) = &self.metric else {
            return 0.0;
        };
        // A manifold edge has two triangles; one attribute vertex of u on both counts once.
        let mut counted = [NONE; 2];
        let mut total = 0.0;
        for &t in fan {
            let tri = tris[t as usize];
            if !holds(tri, w) {
                continue;
            }
            let c = self.corners[t as usize];
            let (a, b) = (c[corner(tri, u)], c[corner(tri, w)]);
            if counted.contains(&a) {
                continue;
            }
            counted[(counted[0] != NONE) as usize] = a;
            total += metric.error(a, p, b);
        }
        total
    }

    /// Re-points the attribute corners of the surviving triangles `kept` by the pairs of
    /// the last [`allows`](Self::allows) (the collapse being made), as
    /// [`crate::seams::expand`] does.
    fn move_corners(&mut self, kept: &[u32]) {
        for &t in kept {
            let tri = &mut self.corners[t as usize];
            for a in tri.iter_mut() {
                if let Ok(i) = self.pairs.binary_search_by_key(a, |&(x, _)| x) {
                    *a = self.pairs[i].1;
                }
            }
        }
    }

    /// Asks the rule about `u → w` over `fan`, the live triangles of `u`.
    fn allows(&mut self, u: u32, w: u32, fan: &[u32]) -> bool {
        let corners = &self.corners;
        self.rule
            .map_collapse(
                u,
                w,
                fan.iter().map(|&t| corners[t as usize]),
                &mut self.pairs,
            )
            .is_ok()
    }
}

/// What a vertex may do, fixed at the start (valid collapses keep interior
/// vertices interior and boundary vertices on their boundary) until it
/// collapses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// One closed fan of manifold edges: may collapse onto any neighbour.
    Interior,
    /// One open fan with exactly two boundary edges: collapses along them only.
    Border,
    /// Non-manifold, several fans, or no triangle: never collapses (may be a target).
    Locked,
    /// Collapsed onto a neighbour: in no triangle, never a target.
    Collapsed,
}

/// Where a vertex's live triangles sit in [`State::pool`]: `len` entries at
/// `start`, room for `cap`. One record, so a visit costs one cache line.
#[derive(Clone, Copy, Debug)]
struct Span {
    start: usize,
    len: u32,
    cap: u32,
}

/// Symmetric 4×4 plane quadric `Σ w (n·p + d)²`, with the total weight `w`
/// kept so the error can be reported as a weighted mean.
#[derive(Clone, Copy, Debug, Default)]
struct Quadric {
    a00: f64,
    a11: f64,
    a22: f64,
    a10: f64,
    a20: f64,
    a21: f64,
    b0: f64,
    b1: f64,
    b2: f64,
    c: f64,
    w: f64,
}

impl Quadric {
    /// The plane `n·p + d = 0` (`n` unit length) with weight `w`.
    fn plane(n: DVec3, d: f64, w: f64) -> Self {
        Self {
            a00: n.x * n.x * w,
            a11: n.y * n.y * w,
            a22: n.z * n.z * w,
            a10: n.x * n.y * w,
            a20: n.x * n.z * w,
            a21: n.y * n.z * w,
            b0: n.x * d * w,
            b1: n.y * d * w,
            b2: n.z * d * w,
            c: d * d * w,
            w,
        }
    }

    /// Squared distance to the point `p`, times `w`.
    fn point(p: DVec3, w: f64) -> Self {
        Self {
            a00: w,
            a11: w,
            a22: w,
            a10: 0.0,
            a20: 0.0,
            a21: 0.0,
            b0: -p.x * w,
            b1: -p.y * w,
            b2: -p.z * w,
            c: p.length_squared() * w,
            w,
        }
    }

    fn add(&mut self, o: &Quadric) {
        self.a00 += o.a00;
        self.a11 += o.a11;
        self.a22 += o.a22;
        self.a10 += o.a10;
        self.a20 += o.a20;
        self.a21 += o.a21;
        self.b0 += o.b0;
        self.b1 += o.b1;
        self.b2 += o.b2;
        self.c += o.c;
        self.w += o.w;
    }

    /// `Q(p) / W`: weighted mean squared distance (object units²). `abs`
    /// because rounding can make a true zero slightly negative.
    fn error(&self, p: DVec3) -> f64 {
        if self.w > 0.0 {
            self.sum(p).abs() / self.w
        } else {
            0.0
        }
    }

    /// `Q(p)`, the weighted sum.
    fn sum(&self, p: DVec3) -> f64 {
        let rx = self.a00 * p.x + 2.0 * (self.a10 * p.y + self.a20 * p.z + self.b0);
        let ry = self.a11 * p.y + 2.0 * (self.a21 * p.z + self.b1);
        let rz = self.a22 * p.z + 2.0 * self.b2;
        self.c + rx * p.x + ry * p.y + rz * p.z
    }
}

/// [`SimplifyOptions::seam_weight`]'s default, meshoptimizer's.
pub const SEAM_WEIGHT: f32 = 1.0;

/// [`SimplifyOptions::uv_weight`]'s default: on makehuman_face at 10% it lowers the UV error's
/// 95th percentile by a fifth and the mean normal deviation by a tenth against both weights 0,
/// with the geometric error no larger (BENCHMARKS.md, "Attribute error").
pub const UV_WEIGHT: f32 = 4.0;
/// [`SimplifyOptions::normal_weight`]'s default (same measurement as [`UV_WEIGHT`]; 0.25 shaded
/// a little better and cost 40% more geometric error).
pub const NORMAL_WEIGHT: f32 = 0.1;

/// Where the distance term samples a new triangle: a grid of step `1 / FAR_STEPS`, corners
/// excluded (they are on the surface), as barycentric weights. (Centroid and edge midpoints
/// alone missed where large triangles leave the surface: 40% more Hausdorff error at 2% on
/// makehuman_face; step 1/6 was no better than 1/4.)
const FAR_STEPS: usize = 4;
const FAR_SAMPLES: [[f64; 3]; (FAR_STEPS + 1) * (FAR_STEPS + 2) / 2 - 3] = {
    let mut out = [[0.0; 3]; (FAR_STEPS + 1) * (FAR_STEPS + 2) / 2 - 3];
    let mut n = 0;
    let mut i = 0;
    while i <= FAR_STEPS {
        let mut j = 0;
        while i + j <= FAR_STEPS {
            let k = FAR_STEPS - i - j;
            if i != FAR_STEPS && j != FAR_STEPS && k != FAR_STEPS {
                let s = FAR_STEPS as f64;
                out[n] = [i as f64 / s, j as f64 / s, k as f64 / s];
                n += 1;
            }
            j += 1;
        }
        i += 1;
    }
    out
};

/// The [`SimplifyOptions::distance_weight`] to use when turning the term on: on the shared
/// sequences of makehuman_face and makehuman_body it gave the lowest Hausdorff error of the
/// weights tried (1, 2, 4, 6, 8, 16; higher weights leave the error to the sampled far side,
/// lower ones to the quadrics; BENCHMARKS.md).
pub const DISTANCE_WEIGHT: f32 = 4.0;

/// The attribute error (Hoppe 1999, "New quadric metric for simplifying meshes with
/// appearance attributes", in meshoptimizer's form): every triangle fits each attribute
/// channel `k` with the linear function `g_k · p + d_k` over its plane that takes the corner
/// values at the corners; attribute vertex `a` sums, area-weighted over its triangles,
/// `(g_k · p + d_k − x_k)²` over the channels. Moving `a` onto attribute vertex `b` at
/// position `p` costs that sum with `x` = `b`'s attributes: how far `b`'s values are from
/// what `a`'s triangles interpolate there. Channels are pre-scaled by their weight
/// ([`SimplifyOptions::uv_weight`]). Unlike the position error the sum is not divided by
/// the weight (as in meshoptimizer): area × deviation² is a squared length, so a deviation
/// costs in proportion to the size of the region it spans, and a shape whose attributes are
/// linear in position (normals on a sphere cost nothing) never becomes the cheapest thing to
/// destroy. Expanded, the terms without `x` are a position quadric and the rest need, per
/// channel, `Σ w g_k` and `Σ w d_k`.
struct AttributeMetric {
    channels: usize,
    /// Per attribute vertex, its `channels` scaled values.
    values: Vec<f64>,
    quadric: Vec<Quadric>,
    /// Per attribute vertex and channel, `[Σ w g_k, Σ w d_k]` (gradient x, y, z, offset).
    gradient: Vec<[f64; 4]>,
}

/// At most two UV and three normal channels.
const MAX_CHANNELS: usize = 5;

impl AttributeMetric {
    /// The metric of the attribute `corners` of the triangles `tris` over `pos` (topology
    /// positions), or `None` when no attribute has weight.
    fn new(
        pos: &[[f32; 3]],
        tris: &[[u32; 3]],
        corners: &[[u32; 3]],
        rule: &SeamRule,
        options: &SimplifyOptions,
    ) -> Option<Self> {
        let n = rule.vertex_count();
        let uv_scale = options.uv_weight as f64;
        let normal_scale = options.normal_weight as f64;
        let uvs = rule.uvs().filter(|_| uv_scale > 0.0);
        let normals = rule.normals().filter(|_| normal_scale > 0.0);
        let channels = uvs.map_or(0, |_| 2) + normals.map_or(0, |_| 3);
        if channels == 0 {
            return None;
        }
        let mut values = Vec::with_capacity(n * channels);
        for a in 0..n {
            if let Some(uvs) = uvs {
                values.extend(uvs[a].map(|x| x as f64 * uv_scale));
            }
            if let Some(normals) = normals {
                values.extend(normals[a].map(|x| x as f64 * normal_scale));
            }
        }
        let mut metric = AttributeMetric {
            channels,
            values,
            quadric: vec![Quadric::default(); n],
            gradient: vec![[0.0; 4]; n * channels],
        };
        for (&t, &c) in tris.iter().zip(corners) {
            metric.add_triangle(t.map(|v| dvec(pos[v as usize])), c);
        }
        Some(metric)
    }

    /// Adds the fitted functions of the triangle at positions `p` with attribute corners `c`
    /// to each corner, weighted by the triangle's area.
    fn add_triangle(&mut self, p: [DVec3; 3], c: [u32; 3]) {
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let w = 0.5 * e1.cross(e2).length();
        // The gradients of the barycentric coordinates of corners 1 and 2 within the plane
        // (from the Gram matrix of the edges); zero on a degenerate triangle, which has no
        // weight anyway.
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = d11 * d22 - d12 * d12;
        let inv = if det > 0.0 { 1.0 / det } else { 0.0 };
        let grad1 = (e1 * d22 - e2 * d12) * inv;
        let grad2 = (e2 * d11 - e1 * d12) * inv;
        let k = self.channels;
        let mut q = Quadric {
            w,
            ..Quadric::default()
        };
        let mut g = [[0.0f64; 4]; MAX_CHANNELS];
        for (ch, gk) in g.iter_mut().enumerate().take(k) {
            let x = c.map(|a| self.values[a as usize * k + ch]);
            let grad = grad1 * (x[1] - x[0]) + grad2 * (x[2] - x[0]);
            let d = x[0] - grad.dot(p[0]);
            // w (g·p + d)², with no share of the weight (that is the triangle's, once).
            let mut term = Quadric::plane(grad, d, w);
            term.w = 0.0;
            q.add(&term);
            *gk = [grad.x * w, grad.y * w, grad.z * w, d * w];
        }
        for a in c {
            self.quadric[a as usize].add(&q);
            let rows = &mut self.gradient[a as usize * k..(a as usize + 1) * k];
            for (row, gk) in rows.iter_mut().zip(&g) {
                for i in 0..4 {
                    row[i] += gk[i];
                }
            }
        }
    }

    /// The cost of moving attribute vertex `a` onto attribute vertex `b` at position `p`.
    fn error(&self, a: u32, p: DVec3, b: u32) -> f64 {
        let k = self.channels;
        let q = &self.quadric[a as usize];
        let mut sum = q.sum(p);
        let rows = &self.gradient[a as usize * k..(a as usize + 1) * k];
        for (row, &x) in rows
            .iter()
            .zip(&self.values[b as usize * k..(b as usize + 1) * k])
        {
            let fitted = row[0] * p.x + row[1] * p.y + row[2] * p.z + row[3];
            sum += x * (x * q.w - 2.0 * fitted);
        }
        // Rounding can make a true zero slightly negative.
        sum.abs()
    }

    /// Folds the error of attribute vertex `a` into `b` (a collapse moved `a` onto `b`).
    fn merge(&mut self, a: u32, b: u32) {
        let qa = self.quadric[a as usize];
        self.quadric[b as usize].add(&qa);
        let k = self.channels;
        for ch in 0..k {
            let ga = self.gradient[a as usize * k + ch];
            let gb = &mut self.gradient[b as usize * k + ch];
            for i in 0..4 {
                gb[i] += ga[i];
            }
        }
    }
}

/// Indexed binary min-heap of vertices keyed by `(cost, vertex)` (the vertex
/// breaks ties, so the result is deterministic), with each vertex's chosen
/// target beside it. A key is one integer, the cost's bits mapped so that
/// integer order is `f64::total_cmp` order, above the vertex: sifting compares
/// one `u128` per step instead of a float, a tie test and an index. Keys live
/// inside the heap array so sifting reads neighbouring memory instead of
/// chasing per-vertex arrays.
struct Queue {
    heap: Vec<u128>,
    /// Position of each vertex in `heap`, or `NONE`.
    slot: Vec<u32>,
    target: Vec<u32>,
}

/// The heap key of `(cost, v)`: the bit trick behind `f64::total_cmp`
/// (negative values reversed below positive ones), then the vertex.
fn key(cost: f64, v: u32) -> u128 {
    let bits = cost.to_bits();
    let ordered = if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    };
    (ordered as u128) << 32 | v as u128
}

/// The cost a [`key`] was made from, bit for bit.
fn key_cost(key: u128) -> f64 {
    let ordered = (key >> 32) as u64;
    f64::from_bits(if ordered >> 63 == 1 {
        ordered & !(1 << 63)
    } else {
        !ordered
    })
}

/// The vertex a [`key`] was made for.
fn key_vertex(key: u128) -> u32 {
    key as u32
}

impl Queue {
    fn new(n: usize) -> Self {
        Self {
            heap: Vec::with_capacity(n),
            slot: vec![NONE; n],
            target: vec![NONE; n],
        }
    }

    /// The queued cost of `v` (`None` when not queued).
    fn cost(&self, v: u32) -> Option<f64> {
        match self.slot[v as usize] {
            NONE => None,
            i => Some(key_cost(self.heap[i as usize])),
        }
    }

    /// The vertex at the top of the queue.
    fn top(&self) -> Option<u32> {
        self.heap.first().map(|&k| key_vertex(k))
    }

    /// Whether `(cost, v)` would come before everything queued.
    fn beats_top(&self, cost: f64, v: u32) -> bool {
        self.heap.first().is_none_or(|&top| key(cost, v) <= top)
    }

    fn set(&mut self, v: u32, cost: f64, target: u32) {
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

    fn remove(&mut self, v: u32) {
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
    fn pop(&mut self) -> Option<(u32, f64, u32)> {
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

struct State<'o, 'r, 'm> {
    options: &'o SimplifyOptions,
    /// `Some` when simplifying the welded surface of a mesh with seams.
    seams: Option<Seams<'r, 'm>>,
    /// The caller's poses, read as `f64` on use: half the cache
    /// footprint of a `DVec3` copy, and the collapse loop is memory bound.
    poses: &'o [&'o [[f32; 3]]],
    combine: PoseError,
    /// Per pose, the factor that puts its errors in the first pose's scale: the squared
    /// ratio of the first pose's bounding-box diagonal to this pose's (1 for the first).
    pose_scale: Vec<f64>,
    tris: Vec<[u32; 3]>,
    kind: Vec<Kind>,
    /// One quadric per vertex and pose, vertex-major (`v * poses.len() + pose`).
    quadric: Vec<Quadric>,
    /// Per-vertex list of its live triangles, at `span[v]` in `pool`. A list
    /// that outgrows its room moves to the end of the pool with double the
    /// room, so merges stay amortised O(degree).
    span: Vec<Span>,
    pool: Vec<u32>,
    /// Scratch marks for neighbour sets: `mark[v] == stamp` means "in the set".
    mark: Vec<u32>,
    stamp: u32,
    scratch: Vec<u32>,
    around: Vec<u32>,
    /// Scratch of ranking and pricing on this thread.
    pricing: PriceScratch,
    /// Scratch of [`State::price_batch`].
    batch: Vec<u32>,
    queue: Queue,
    collapses: Vec<Collapse>,
    /// The distance term, when [`SimplifyOptions::distance_weight`] is above 0.
    attached: Option<Attached>,
    /// With the distance term: whether a vertex stands still (the same position in every
    /// pose). A distance between still vertices is the first pose's times the largest pose
    /// scale, bit for bit, so it is measured once instead of once per pose.
    still: Vec<bool>,
    /// The largest of `pose_scale`.
    scale_max: f64,
}

/// What ranking and pricing a vertex ([`State::targets`], [`State::price`]) write to: one per
/// thread.
#[derive(Default)]
struct PriceScratch {
    candidates: Vec<(f64, u32)>,
    /// The vertices near a candidate fan.
    near: Vec<u32>,
}

/// The removed vertices of [`SimplifyOptions::distance_weight`], each attached to one live
/// triangle: per triangle a list threaded through the vertices (`head[t]`, then `next[v]`;
/// `NONE` ends it).
struct Attached {
    weight: f64,
    head: Vec<u32>,
    next: Vec<u32>,
    /// Scratch: the vertices a collapse detaches.
    loose: Vec<u32>,
    /// The full-detail triangles, and each vertex's among them.
    original: Vec<[u32; 3]>,
    ring: VertexTriangles,
    /// Whether a vertex's queued cost includes the distance term (it is priced lazily, when
    /// the cheaper cost without it reaches the top: the term only adds).
    exact: Vec<bool>,
    /// Per vertex, whether every vertex of its full-detail triangles stands still.
    ring_still: Vec<bool>,
}

impl<'o, 'r, 'm> State<'o, 'r, 'm> {
    fn new(
        poses: &'o [&'o [[f32; 3]]],
        tris: Vec<[u32; 3]>,
        seam_edges: &[[u32; 3]],
        options: &'o SimplifyOptions,
        combine: PoseError,
        seams: Option<Seams<'r, 'm>>,
    ) -> Self {
        let n = poses[0].len();
        let vt = VertexTriangles::new(&tris, n);
        let tris_len = tris.len();
        let original = tris.clone();
        let (kind, boundary_edges) = classify(&tris, &vt);
        let per_pose: Vec<Vec<Quadric>> = poses
            .iter()
            .map(|pos| quadrics(pos, &tris, &boundary_edges, seam_edges, options))
            .collect();
        let quadric = (0..n)
            .flat_map(|v| per_pose.iter().map(move |q| q[v]))
            .collect();
        let first = diagonal_squared(poses[0]);
        let pose_scale: Vec<f64> = poses
            .iter()
            .map(|pos| {
                let own = diagonal_squared(pos);
                if first > 0.0 && own > 0.0 && first != own {
                    first / own
                } else {
                    1.0
                }
            })
            .collect();

        let (still, ring_still): (Vec<bool>, Vec<bool>) = if options.distance_weight > 0.0 {
            let still: Vec<bool> = (0..n)
                .map(|v| poses.iter().all(|pose| pose[v] == poses[0][v]))
                .collect();
            let ring_still = (0..n as u32)
                .map(|v| {
                    vt.of(v)
                        .iter()
                        .all(|&t| tris[t as usize].iter().all(|&x| still[x as usize]))
                })
                .collect();
            (still, ring_still)
        } else {
            (Vec::new(), Vec::new())
        };
        let scale_max = pose_scale.iter().copied().fold(1.0, f64::max);
        let mut span = Vec::with_capacity(n);
        let mut pool = Vec::with_capacity(tris.len() * 3 * 3);
        for v in 0..n as u32 {
            let len = vt.of(v).len() as u32;
            span.push(Span {
                start: pool.len(),
                len,
                cap: len,
            });
            pool.extend_from_slice(vt.of(v));
        }
        Self {
            options,
            seams,
            poses,
            combine,
            pose_scale,
            tris,
            kind,
            quadric,
            span,
            pool,
            mark: vec![0; n],
            stamp: 0,
            scratch: Vec::new(),
            around: Vec::new(),
            pricing: PriceScratch::default(),
            batch: Vec::new(),
            queue: Queue::new(n),
            collapses: Vec::with_capacity(n),
            attached: (options.distance_weight > 0.0).then(|| Attached {
                weight: options.distance_weight as f64,
                head: vec![NONE; tris_len],
                next: vec![NONE; n],
                loose: Vec::new(),
                original,
                ring: vt,
                exact: vec![false; n],
                ring_still,
            }),
            still,
            scale_max,
        }
    }

    fn vertex_count(&self) -> usize {
        self.poses[0].len()
    }

    /// The position of `v` in pose `pose`.
    fn p(&self, pose: usize, v: u32) -> DVec3 {
        dvec(self.poses[pose][v as usize])
    }

    /// The cost of moving `u` onto `w`: each pose's quadric error of `u` at `w`'s position
    /// in that pose, combined over the poses, plus the attribute error in the first pose.
    fn cost(&self, u: u32, w: u32) -> f64 {
        self.position_cost(u, w) + self.attribute_cost(u, w)
    }

    /// The attribute error of `u → w` in the first pose (0 without seams).
    fn attribute_cost(&self, u: u32, w: u32) -> f64 {
        match &self.seams {
            Some(seams) => seams.attribute_cost(&self.tris, self.list(u), u, w, self.p(0, w)),
            None => 0.0,
        }
    }

    /// [`cost`](Self::cost) with the distance term: the position error is the larger of the
    /// quadric error and the distance term. Above `limit` the result is only a lower bound
    /// (the pricing stops as soon as it cannot come under `limit`).
    fn exact_cost(&self, u: u32, w: u32, limit: f64, near: &mut Vec<u32>) -> f64 {
        let position = self.position_cost(u, w);
        let cheap = position + self.attribute_cost(u, w);
        let distance = self.distance_cost(u, w, limit - cheap + position, near);
        cheap + (distance - position).max(0.0)
    }

    /// The distance term of `u → w` (0 when off), both ways, weighted:
    /// * near side: the largest squared distance from `u` and the vertices attached to its
    ///   triangles to the nearest triangle of the fan that replaces them (`u`'s triangles off
    ///   edge `uw`, with `w` for `u`);
    /// * far side: the largest squared distance from points of that fan ([`FAR_SAMPLES`]) to
    ///   the full-detail triangles around the nearest (in the first pose) of those vertices
    ///   and the fan's corners, which bounds the distance to the full surface from above.
    ///
    /// Each distance is the largest over the poses, scaled as the quadric errors are. Once
    /// the term exceeds `limit` it returns what it has (a lower bound).
    fn distance_cost(&self, u: u32, w: u32, limit: f64, near: &mut Vec<u32>) -> f64 {
        let Some(attached) = &self.attached else {
            return 0.0;
        };
        let weight = attached.weight;
        let limit = limit / weight;
        let fan = self.list(u);
        let shape =
            |tri: [u32; 3]| (!holds(tri, w)).then(|| tri.map(|v| if v == u { w } else { v }));
        near.clear();
        near.push(u);
        for &t in fan {
            let mut x = attached.head[t as usize];
            while x != NONE {
                near.push(x);
                x = attached.next[x as usize];
            }
        }
        let mut worst = 0.0f64;
        for &x in near.iter() {
            worst = worst.max(self.nearest(x, fan, w, shape, worst).0);
            if worst > limit {
                break;
            }
        }
        for &t in fan {
            if let Some(tri) = shape(self.tris[t as usize]) {
                near.extend(tri);
            }
        }
        'far: for &t in fan {
            let Some(tri) = shape(self.tris[t as usize]) else {
                continue;
            };
            for bary in FAR_SAMPLES {
                if worst > limit {
                    break 'far;
                }
                let at = |pose: usize| {
                    let [a, b, c] = tri.map(|v| self.p(pose, v));
                    a * bary[0] + b * bary[1] + c * bary[2]
                };
                let p0 = at(0);
                let mut closest = (f64::INFINITY, NONE);
                for &x in near.iter() {
                    let d = p0.distance_squared(self.p(0, x));
                    if d < closest.0 {
                        closest = (d, x);
                    }
                }
                let ring = attached.ring.of(closest.1);
                let (poses, scales) = if attached.ring_still[closest.1 as usize]
                    && tri.iter().all(|&v| self.still[v as usize])
                {
                    (1, std::slice::from_ref(&self.scale_max))
                } else {
                    (self.poses.len(), self.pose_scale.as_slice())
                };
                for (pose, &scale) in scales.iter().enumerate().take(poses) {
                    let q = at(pose);
                    // The least distance over the ring, but a pose whose distance cannot
                    // exceed `worst` is done as soon as that is known: at once when the
                    // ring's centre (on the ring) is that close, else at the first triangle.
                    let mut least = q.distance_squared(self.p(pose, closest.1)) * scale;
                    if least <= worst {
                        continue;
                    }
                    for &o in ring {
                        let [oa, ob, oc] = attached.original[o as usize].map(|v| self.p(pose, v));
                        least = least.min(q.distance_squared(closest_point(q, oa, ob, oc)) * scale);
                        if least <= worst {
                            break;
                        }
                    }
                    worst = worst.max(least);
                }
            }
        }
        worst * weight
    }

    /// The triangle of `fan` nearest to vertex `x`, with `x`'s squared distance to it (the
    /// largest over the poses, each scaled as the quadric errors are). `shape` gives a fan
    /// triangle's corners after the collapse, `None` for one that dies; with no triangle left
    /// `x` lands on `w` (a border vertex with one triangle) and the triangle is `NONE`. Stops
    /// at the first triangle within `enough`.
    fn nearest(
        &self,
        x: u32,
        fan: &[u32],
        w: u32,
        shape: impl Fn([u32; 3]) -> Option<[u32; 3]>,
        enough: f64,
    ) -> (f64, u32) {
        // x's distance to `tri` over the poses, given the first pose's `first`; stops once it
        // reaches `stop` (then it is only a lower bound, and loses).
        let over_poses = |tri: [u32; 3], first: f64, stop: f64| {
            let mut d = first;
            if !self.stand_still(x, tri) {
                for pose in 1..self.poses.len() {
                    if d >= stop {
                        break;
                    }
                    let [a, b, c] = tri.map(|v| self.p(pose, v));
                    let p = self.p(pose, x);
                    let scale = self.pose_scale[pose];
                    // A corner bounds the distance from above: within `enough` it decides
                    // the pose's part of the answer without the exact distance (if another
                    // pose exceeds `enough`, that one is the maximum).
                    let corner = p
                        .distance_squared(a)
                        .min(p.distance_squared(b))
                        .min(p.distance_squared(c))
                        * scale;
                    d = d.max(if corner <= enough {
                        corner
                    } else {
                        p.distance_squared(closest_point(p, a, b, c)) * scale
                    });
                }
            }
            d
        };
        // The first pose's distance (a lower bound of the largest over the poses) to every
        // triangle; a still triangle's is already the answer, scaled by the largest scale.
        let first = |tri: [u32; 3]| {
            let [a, b, c] = tri.map(|v| self.p(0, v));
            let p = self.p(0, x);
            let d = p.distance_squared(closest_point(p, a, b, c));
            if self.stand_still(x, tri) {
                d * self.scale_max
            } else {
                d
            }
        };
        // The triangle nearest in the first pose usually is the nearest over all of them:
        // price it fully first, then only the others that can still beat it.
        let mut lowest = (f64::INFINITY, NONE);
        for &t in fan {
            if let Some(tri) = shape(self.tris[t as usize]) {
                let d = first(tri);
                if d < lowest.0 {
                    lowest = (d, t);
                }
            }
        }
        let mut best = (f64::INFINITY, NONE);
        if lowest.1 != NONE {
            let tri = shape(self.tris[lowest.1 as usize]).unwrap_or_default();
            best = (over_poses(tri, lowest.0, f64::INFINITY), lowest.1);
            if best.0 > enough {
                for &t in fan {
                    if t == lowest.1 {
                        continue;
                    }
                    let Some(tri) = shape(self.tris[t as usize]) else {
                        continue;
                    };
                    let d = first(tri);
                    if d >= best.0 {
                        continue;
                    }
                    let d = over_poses(tri, d, best.0);
                    if d < best.0 {
                        best = (d, t);
                        if d <= enough {
                            break;
                        }
                    }
                }
            }
        }
        if best.1 == NONE {
            best.0 = (0..self.poses.len())
                .map(|pose| {
                    self.p(pose, x).distance_squared(self.p(pose, w)) * self.pose_scale[pose]
                })
                .fold(0.0, f64::max);
        }
        best
    }

    /// Whether vertex `x` and the corners of `tri` stand still in every pose (see `still`).
    fn stand_still(&self, x: u32, tri: [u32; 3]) -> bool {
        self.still[x as usize] && tri.iter().all(|&v| self.still[v as usize])
    }

    fn position_cost(&self, u: u32, w: u32) -> f64 {
        let count = self.poses.len();
        let quadrics = &self.quadric[u as usize * count..(u as usize + 1) * count];
        let mut errors = quadrics
            .iter()
            .enumerate()
            .map(|(pose, q)| q.error(self.p(pose, w)) * self.pose_scale[pose]);
        let first = errors.next().unwrap_or(0.0);
        match self.combine {
            PoseError::Mean => errors.fold(first, |a, e| a + e) / count as f64,
            PoseError::Max => errors.fold(first, f64::max),
        }
    }

    fn list(&self, v: u32) -> &[u32] {
        let Span { start, len, .. } = self.span[v as usize];
        &self.pool[start..start + len as usize]
    }

    /// A fresh mark value; clears the marks when the counter wraps.
    fn next_stamp(&mut self) -> u32 {
        if self.stamp >= u32::MAX - 2 {
            self.mark.fill(0);
            self.stamp = 0;
        }
        self.stamp += 1;
        self.stamp
    }

    fn run(&mut self) {
        for v in 0..self.vertex_count() as u32 {
            self.rerank(v);
        }
        loop {
            while let Some((u, cost, w)) = self.queue.pop() {
                if self.attached.as_ref().is_some_and(|a| !a.exact[u as usize]) {
                    // Ranked without the distance term: price it, then queue u again.
                    self.price_batch(u);
                    continue;
                }
                if self.is_valid(u, w) {
                    self.collapse(u, w, cost);
                    continue;
                }
                // The cheapest target went invalid (its 2-ring changed since it was
                // ranked): fall back to the cheapest valid one, at once if it still
                // beats everything queued. Without one, u waits until its fan changes.
                if let Some((cost, w)) = self.best_valid(u) {
                    if self.queue.beats_top(cost, u) {
                        self.collapse(u, w, cost);
                    } else {
                        self.queue.set(u, cost, w);
                    }
                }
            }
            // The queue ran dry. A vertex without a valid target left the queue
            // and returns only when its own fan changes, but later collapses in
            // its 2-ring can unblock it: sweep once more so the sequence really
            // runs to the end.
            let mut progress = false;
            for v in 0..self.vertex_count() as u32 {
                if !matches!(self.kind[v as usize], Kind::Interior | Kind::Border) {
                    continue;
                }
                if let Some((cost, w)) = self.best_valid(v) {
                    self.queue.set(v, cost, w);
                    progress = true;
                }
            }
            if !progress {
                break;
            }
        }
    }

    /// Prices `u` (just popped, not exact) and the vertices after it at the top of the
    /// queue that are not exact either, up to two per thread of the rayon pool, in parallel;
    /// marks them exact and queues each at its price. Pricing reads the state and changes
    /// nothing, and a price stays valid until the vertex is ranked again (`rerank`), so
    /// pricing a vertex before it reaches the top gives the order the one-at-a-time loop
    /// gives, bit for bit; a price that a collapse makes stale first is work lost.
    fn price_batch(&mut self, u: u32) {
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
    fn rerank(&mut self, u: u32) {
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
    fn best_valid(&mut self, u: u32) -> Option<(f64, u32)> {
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

    /// Every rule in the module docs, on the current mesh.
    fn is_valid(&mut self, u: u32, w: u32) -> bool {
        let ku = self.kind[u as usize];
        if !matches!(ku, Kind::Interior | Kind::Border) || self.kind[w as usize] == Kind::Collapsed
        {
            return false;
        }
        // The triangles on edge uw: their apexes, and whether the edge is
        // traversed once each way (manifold) or once (boundary). Meanwhile mark
        // u's neighbours for the link condition below.
        let stamp = self.next_stamp();
        let mut shared = 0usize;
        let mut apex = [NONE; 2];
        let mut forward = [false; 2];
        let (su, lu) = (
            self.span[u as usize].start,
            self.span[u as usize].len as usize,
        );
        let (sw, lw) = (
            self.span[w as usize].start,
            self.span[w as usize].len as usize,
        );
        for i in su..su + lu {
            let tri = self.tris[self.pool[i] as usize];
            for v in tri {
                self.mark[v as usize] = stamp;
            }
            if holds(tri, w) {
                if shared == 2 {
                    return false;
                }
                let (cu, cw) = (corner(tri, u), corner(tri, w));
                apex[shared] = tri[3 - cu - cw];
                forward[shared] = (cu + 1) % 3 == cw;
                shared += 1;
            }
        }
        let edge_ok = match ku {
            Kind::Interior => shared == 2 && forward[0] != forward[1],
            Kind::Border => shared == 1 && self.kind[w as usize] == Kind::Border,
            Kind::Locked | Kind::Collapsed => false,
        };
        if !edge_ok {
            return false;
        }
        if lu + lw <= 2 * shared {
            // Nothing would remain of this component.
            return false;
        }

        // Link condition: no neighbour of u that w also reaches through a
        // triangle not on edge uw. Tested without branches (`&`, `|`): the
        // outcome per corner is unpredictable and almost always "fine".
        let mut linked = false;
        for i in sw..sw + lw {
            let tri = self.tris[self.pool[i] as usize];
            let off_edge = !holds(tri, u);
            for v in tri {
                linked |= off_edge
                    & (v != w)
                    & (self.mark[v as usize] == stamp)
                    & (v != apex[0])
                    & (v != apex[1]);
            }
        }
        if linked {
            return false;
        }

        let min_cos = self.options.min_normal_cos as f64;
        for i in su..su + lu {
            let tri = self.tris[self.pool[i] as usize];
            if holds(tri, w) {
                continue;
            }
            let [a, b] = after_before(tri, u);
            // A triangle whose other corners are both apexes becomes (w, a, b):
            // if w already has that triangle the collapse squashes a tetrahedron.
            let both_apex = ((a == apex[0]) | (a == apex[1])) & ((b == apex[0]) | (b == apex[1]));
            if both_apex && self.has_triangle(w, a, b) {
                return false;
            }
            for pose in 0..self.poses.len() {
                let (pu, pw) = (self.p(pose, u), self.p(pose, w));
                let (pa, pb) = (self.p(pose, a), self.p(pose, b));
                let before = (pa - pu).cross(pb - pu);
                let after = (pa - pw).cross(pb - pw);
                let limit = min_cos * (before.length_squared() * after.length_squared()).sqrt();
                // Anything but "greater" rejects, NaN (non-finite input) included.
                if before.dot(after).partial_cmp(&limit) != Some(std::cmp::Ordering::Greater) {
                    return false;
                }
            }
        }
        match &mut self.seams {
            Some(seams) => seams.allows(u, w, &self.pool[su..su + lu]),
            None => true,
        }
    }

    /// Whether a live triangle of `w` uses exactly the vertices `{w, a, b}`.
    fn has_triangle(&self, w: u32, a: u32, b: u32) -> bool {
        self.list(w).iter().any(|&t| {
            let tri = self.tris[t as usize];
            holds(tri, a) & holds(tri, b)
        })
    }

    /// Applies `u → w`: kills the triangles on edge uw, re-points u's other
    /// triangles to w, merges the quadric, and updates the queue where costs or
    /// candidate sets changed: w (new quadric, new fan) and u's old neighbours
    /// (they lost u and gained w).
    fn collapse(&mut self, u: u32, w: u32, cost: f64) {
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
        if let Some(attached) = &mut self.attached {
            attached.loose.clear();
            attached.loose.push(u);
            for &t in &moved {
                let mut x = std::mem::replace(&mut attached.head[t as usize], NONE);
                while x != NONE {
                    attached.loose.push(x);
                    x = attached.next[x as usize];
                }
            }
        }
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
        if let Some(mut attached) = self.attached.take() {
            for &x in &attached.loose {
                // `moved` holds the re-pointed triangles already.
                let (_, t) = self.nearest(x, &moved, w, Some, 0.0);
                let t = if t == NONE {
                    self.list(w).first().copied().unwrap_or(NONE)
                } else {
                    t
                };
                if t != NONE {
                    attached.next[x as usize] = attached.head[t as usize];
                    attached.head[t as usize] = x;
                }
            }
            self.attached = Some(attached);
        }
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

fn dvec(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// What one vertex's fan says about the edge to a neighbour `x`: how many of
/// the fan's triangles hold the half-edge `v→x` (`out`) and `x→v` (`inn`),
/// and the fan position of a triangle holding `x→v`.
#[derive(Clone, Copy)]
struct Link {
    out: u32,
    inn: u32,
    at: u32,
}

const NO_LINK: Link = Link {
    out: 0,
    inn: 0,
    at: NONE,
};

/// Tags each vertex by walking its fan across manifold edges: one closed fan
/// is interior, one open fan with two boundary edges is a border vertex,
/// anything else (non-manifold edges, bow-ties, isolated) is locked. Also
/// returns every boundary half-edge as `[from, to, triangle]`, sorted by the
/// undirected edge `(min, max)` (the order the boundary quadrics are summed in).
///
/// Every edge at `v` lies in a triangle of `v`'s fan, so counting the
/// half-edges around each fan classifies all edges without a global edge
/// table: `(out, inn) == (1, 1)` is a manifold interior edge, `(1, 0)` or
/// `(0, 1)` a boundary edge, anything else non-manifold.
fn classify(tris: &[[u32; 3]], vt: &VertexTriangles) -> (Vec<Kind>, Vec<[u32; 3]>) {
    let n = vt.vertex_count();
    let mut link = vec![NO_LINK; n];
    let mut boundary_edges = Vec::new();
    // Per fan triangle: the corners after and before v.
    let mut ring: Vec<[u32; 2]> = Vec::new();
    let kind = (0..n as u32)
        .map(|v| {
            let fan = vt.of(v);
            ring.clear();
            // Reset the entries this fan uses, then count: cheaper than
            // testing per entry whether it is stale.
            for &t in fan {
                let [a, b] = after_before(tris[t as usize], v);
                ring.push([a, b]);
                link[a as usize] = NO_LINK;
                link[b as usize] = NO_LINK;
            }
            for (i, &[a, b]) in ring.iter().enumerate() {
                link[a as usize].out += 1;
                let l = &mut link[b as usize];
                l.inn += 1;
                l.at = i as u32;
            }
            let mut boundary = 0;
            let mut nonmanifold = false;
            // Where the edge coming into v is the boundary: the start of an open fan.
            let mut open_at = NONE;
            for (i, &[a, b]) in ring.iter().enumerate() {
                let (la, lb) = (link[a as usize], link[b as usize]);
                match (la.out, la.inn) {
                    (1, 1) => {}
                    (1, 0) => {
                        boundary += 1;
                        boundary_edges.push([v, a, fan[i]]);
                    }
                    _ => nonmanifold = true,
                }
                // A boundary edge into v is counted here and recorded from its
                // start vertex's fan.
                match (lb.out, lb.inn) {
                    (1, 1) => {}
                    (0, 1) => {
                        boundary += 1;
                        if open_at == NONE {
                            open_at = i as u32;
                        }
                    }
                    _ => nonmanifold = true,
                }
            }
            if fan.is_empty() || nonmanifold {
                return Kind::Locked;
            }
            let (first, kind) = match (boundary, open_at) {
                (0, _) => (0, Kind::Interior),
                (2, i) if i != NONE => (i, Kind::Border),
                _ => return Kind::Locked,
            };
            // Across the outgoing edge v→a lies the triangle holding a→v.
            let mut i = first;
            let mut visited = 0;
            loop {
                visited += 1;
                let l = link[ring[i as usize][0] as usize];
                i = if (l.out, l.inn) == (1, 1) { l.at } else { NONE };
                if i == NONE || i == first || visited > fan.len() {
                    break;
                }
            }
            let closed = i == first;
            if visited == fan.len() && closed == (kind == Kind::Interior) {
                kind
            } else {
                Kind::Locked
            }
        })
        .collect();
    boundary_edges.sort_unstable_by_key(|&[a, b, _]| (a.min(b), a.max(b)));
    (kind, boundary_edges)
}

// Corner lookups without branches: which corner holds a vertex is
// unpredictable, and these run for every triangle the simplifier visits.
// Triangles hold three distinct vertices (`simplify` drops the rest).

/// Whether triangle `t` holds `v`.
fn holds(t: [u32; 3], v: u32) -> bool {
    (t[0] == v) | (t[1] == v) | (t[2] == v)
}

/// The corner of `t` that holds `v` (0 when none does).
fn corner(t: [u32; 3], v: u32) -> usize {
    (t[1] == v) as usize | ((t[2] == v) as usize) << 1
}

/// The corners after and before `v` in triangle `t` (which holds `v`),
/// picked by all-ones/all-zero masks.
fn after_before(t: [u32; 3], v: u32) -> [u32; 2] {
    let m = t.map(|x| 0u32.wrapping_sub((x == v) as u32));
    [
        (t[1] & m[0]) | (t[2] & m[1]) | (t[0] & m[2]),
        (t[2] & m[0]) | (t[0] & m[1]) | (t[1] & m[2]),
    ]
}

/// Face quadrics, boundary edge quadrics and the regularizing point quadric of every vertex.
/// Both sides of every seam edge of the welded surface `tris` (`[from, to, triangle]`, one
/// entry per triangle on the edge): an edge with two triangles whose attribute `corners` at
/// either end differ. Border and non-manifold edges are not seams.
fn seam_edges(tris: &[[u32; 3]], corners: &[[u32; 3]]) -> Vec<[u32; 3]> {
    // Per directed edge `a → b`: its triangle and the attribute vertices at `a` and `b`.
    let mut half = std::collections::HashMap::with_capacity(tris.len() * 3);
    let mut repeated = std::collections::HashSet::new();
    for (i, (t, c)) in tris.iter().zip(corners).enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if half
                .insert((a, b), (i as u32, c[k], c[(k + 1) % 3]))
                .is_some()
            {
                repeated.insert((a.min(b), a.max(b)));
            }
        }
    }
    let mut out = Vec::new();
    for (&(a, b), &(i, ca, cb)) in &half {
        if a > b || repeated.contains(&(a, b)) {
            continue;
        }
        if let Some(&(j, cb2, ca2)) = half.get(&(b, a)) {
            if ca != ca2 || cb != cb2 {
                out.push([a, b, i]);
                out.push([b, a, j]);
            }
        }
    }
    // The quadrics are sums: a fixed order keeps them bit-reproducible.
    out.sort_unstable();
    out
}

/// The squared diagonal of the bounding box of `pos` (0 for no vertex or a non-finite one).
fn diagonal_squared(pos: &[[f32; 3]]) -> f64 {
    let (lo, hi) = pos.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(dvec(p)), hi.max(dvec(p))),
    );
    let d = (hi - lo).length_squared();
    if d.is_finite() {
        d
    } else {
        0.0
    }
}

fn quadrics(
    pos: &[[f32; 3]],
    tris: &[[u32; 3]],
    boundary_edges: &[[u32; 3]],
    seam_edges: &[[u32; 3]],
    options: &SimplifyOptions,
) -> Vec<Quadric> {
    let mut q = vec![Quadric::default(); pos.len()];
    let face = |t: [u32; 3], weight: f64| {
        let [p0, p1, p2] = t.map(|v| dvec(pos[v as usize]));
        let cross = (p1 - p0).cross(p2 - p0);
        let double_area = cross.length();
        let n = if double_area > 0.0 {
            cross / double_area
        } else {
            DVec3::ZERO
        };
        Quadric::plane(n, -n.dot(p0), double_area.sqrt() * weight)
    };
    for &t in tris {
        let f = face(t, 1.0);
        for v in t {
            q[v as usize].add(&f);
        }
    }
    // Border edges, and each side of a seam edge (half the seam weight, so a seam edge as a
    // whole weighs `seam_weight`).
    let bw = options.boundary_weight as f64;
    let sw = 0.5 * options.seam_weight as f64;
    let edges = boundary_edges
        .iter()
        .map(|e| (e, bw))
        .chain(seam_edges.iter().map(|e| (e, sw)))
        .filter(|&(_, weight)| weight > 0.0);
    for (&[from, to, tri], weight) in edges {
        let t = tris[tri as usize];
        // The corner that is neither end: xor cancels the two ends out.
        let apex = t[0] ^ t[1] ^ t[2] ^ from ^ to;
        let (p0, p1, p2) = (
            dvec(pos[from as usize]),
            dvec(pos[to as usize]),
            dvec(pos[apex as usize]),
        );
        let edge = p1 - p0;
        // The plane holds the edge and is perpendicular to the triangle: its
        // normal is the component of (p2 - p0) perpendicular to the edge.
        let perp =
            (p2 - p0) - edge * ((p2 - p0).dot(edge) / edge.length_squared().max(f64::MIN_POSITIVE));
        let perp = perp.normalize_or_zero();
        let mut e = Quadric::plane(perp, -perp.dot(p0), edge.length() * weight);
        // The face plane too, with the same weight but no share of the mean
        // (meshoptimizer: stabilises collapses along the border both ways).
        let mut f = face(t, weight);
        f.w = 0.0;
        e.add(&f);
        q[from as usize].add(&e);
        q[to as usize].add(&e);
    }
    let r = options.regularization as f64;
    for (v, qv) in q.iter_mut().enumerate() {
        let p = Quadric::point(dvec(pos[v]), qv.w * r);
        qv.add(&p);
    }
    q
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::collections::HashMap;

    /// An `n`×`n` grid of quads over `[0,1]²` at height `z` (a disk: one boundary loop).
    pub(crate) fn grid(n: u32, z: f32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut pos = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                pos.push([i as f32 / n as f32, j as f32 / n as f32, z]);
            }
        }
        let mut tris = Vec::new();
        let row = n + 1;
        for j in 0..n {
            for i in 0..n {
                let v = j * row + i;
                tris.push([v, v + 1, v + row + 1]);
                tris.push([v, v + row + 1, v + row]);
            }
        }
        (pos, tris)
    }

    /// A UV sphere of radius 1 around `center`, outward-facing, with pole vertices.
    fn sphere(stacks: u32, slices: u32, center: [f32; 3]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut pos = vec![[center[0], center[1], center[2] + 1.0]];
        for i in 1..stacks {
            let theta = std::f32::consts::PI * i as f32 / stacks as f32;
            for j in 0..slices {
                let phi = 2.0 * std::f32::consts::PI * j as f32 / slices as f32;
                pos.push([
                    center[0] + theta.sin() * phi.cos(),
                    center[1] + theta.sin() * phi.sin(),
                    center[2] + theta.cos(),
                ]);
            }
        }
        let south = pos.len() as u32;
        pos.push([center[0], center[1], center[2] - 1.0]);
        let ring = |i: u32, j: u32| 1 + (i - 1) * slices + j % slices;
        let mut tris = Vec::new();
        for j in 0..slices {
            tris.push([0, ring(1, j), ring(1, j + 1)]);
            tris.push([south, ring(stacks - 1, j + 1), ring(stacks - 1, j)]);
        }
        for i in 1..stacks - 1 {
            for j in 0..slices {
                let (a, b, c, d) = (
                    ring(i, j),
                    ring(i, j + 1),
                    ring(i + 1, j),
                    ring(i + 1, j + 1),
                );
                tris.push([a, c, d]);
                tris.push([a, d, b]);
            }
        }
        (pos, tris)
    }

    /// A torus (genus 1, closed) with radii 1 and 0.35.
    fn torus(major: u32, minor: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut pos = Vec::new();
        for i in 0..major {
            let a = 2.0 * std::f32::consts::PI * i as f32 / major as f32;
            for j in 0..minor {
                let b = 2.0 * std::f32::consts::PI * j as f32 / minor as f32;
                let r = 1.0 + 0.35 * b.cos();
                pos.push([r * a.cos(), r * a.sin(), 0.35 * b.sin()]);
            }
        }
        let id = |i: u32, j: u32| (i % major) * minor + j % minor;
        let mut tris = Vec::new();
        for i in 0..major {
            for j in 0..minor {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        (pos, tris)
    }

    /// A grid with the middle quads removed: an annulus, two boundary loops.
    fn annulus() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let (pos, tris) = grid(9, 0.0);
        let tris = tris
            .into_iter()
            .filter(|t| {
                let c = t.iter().fold([0.0f32; 2], |s, &v| {
                    [
                        s[0] + pos[v as usize][0] / 3.0,
                        s[1] + pos[v as usize][1] / 3.0,
                    ]
                });
                !((0.34..0.66).contains(&c[0]) && (0.34..0.66).contains(&c[1]))
            })
            .collect();
        (pos, tris)
    }

    /// Appends mesh `b` to mesh `a` as a second component.
    fn join(
        a: (Vec<[f32; 3]>, Vec<[u32; 3]>),
        b: (Vec<[f32; 3]>, Vec<[u32; 3]>),
    ) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let (mut pos, mut tris) = a;
        let base = pos.len() as u32;
        pos.extend(b.0);
        tris.extend(b.1.iter().map(|t| t.map(|v| v + base)));
        (pos, tris)
    }

    /// Topology of a triangle list, measured from scratch (the oracle side).
    #[derive(Debug, PartialEq)]
    struct Topology {
        euler: i64,
        components: usize,
        boundary_loops: usize,
    }

    fn find(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }

    /// Panics (naming the LOD) unless the mesh is edge-manifold, consistently
    /// oriented and free of duplicate triangles; returns its topology.
    fn inspect(n: usize, tris: &[[u32; 3]], lod: usize) -> Topology {
        let mut half: HashMap<(u32, u32), u32> = HashMap::new();
        let mut faces: HashMap<[u32; 3], u32> = HashMap::new();
        for t in tris {
            assert!(
                t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
                "LOD {lod}: degenerate {t:?}"
            );
            for c in 0..3 {
                *half.entry((t[c], t[(c + 1) % 3])).or_default() += 1;
            }
            let mut key = *t;
            key.sort_unstable();
            let dup = faces.entry(key).or_default();
            *dup += 1;
            assert_eq!(*dup, 1, "LOD {lod}: duplicate triangle {t:?}");
        }
        let mut edges = 0i64;
        let mut component = (0..n as u32).collect::<Vec<_>>();
        let mut boundary = (0..n as u32).collect::<Vec<_>>();
        let mut on_boundary = vec![false; n];
        for (&(a, b), &k) in &half {
            assert_eq!(k, 1, "LOD {lod}: half-edge {a}->{b} used {k} times");
            let opposite = half.contains_key(&(b, a));
            if !opposite || a < b {
                edges += 1;
            }
            let (ra, rb) = (find(&mut component, a), find(&mut component, b));
            component[ra as usize] = rb;
            if !opposite {
                on_boundary[a as usize] = true;
                on_boundary[b as usize] = true;
                let (ra, rb) = (find(&mut boundary, a), find(&mut boundary, b));
                boundary[ra as usize] = rb;
            }
        }
        let mut used = vec![false; n];
        for t in tris {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let vertices = used.iter().filter(|&&u| u).count() as i64;
        let components = (0..n as u32)
            .filter(|&v| used[v as usize] && find(&mut component, v) == v)
            .count();
        let boundary_loops = (0..n as u32)
            .filter(|&v| on_boundary[v as usize] && find(&mut boundary, v) == v)
            .count();
        Topology {
            euler: vertices - edges + tris.len() as i64,
            components,
            boundary_loops,
        }
    }

    /// Simplifies to the end and checks every LOD against the input topology.
    /// Returns the sequence and the final (vertex, triangle) counts.
    fn check_run(pos: &[[f32; 3]], tris: &[[u32; 3]]) -> (CollapseSequence, usize, usize) {
        let seq = simplify(pos, tris, &SimplifyOptions::default());
        seq.validate().unwrap();
        assert_eq!(seq.vertex_count as usize, pos.len());
        let start = inspect(pos.len(), tris, 0);
        for lod in 1..=seq.len() {
            let mesh = seq.reference_mesh(tris, lod);
            assert_eq!(inspect(pos.len(), &mesh, lod), start, "LOD {lod}");
        }
        let last = seq.reference_mesh(tris, seq.len());
        let mut used: Vec<u32> = last.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        (seq, used.len(), last.len())
    }

    #[test]
    fn sphere_runs_to_a_tetrahedron_without_flips() {
        let (pos, tris) = sphere(10, 16, [0.0; 3]);
        let (seq, v, t) = check_run(&pos, &tris);
        assert_eq!((v, t), (4, 4));
        assert_eq!(seq.len(), pos.len() - 4);
        // Every vertex stays on the convex sphere, so an outward-facing
        // triangle is one whose normal points away from the centre.
        for lod in 0..=seq.len() {
            for tri in seq.reference_mesh(&tris, lod) {
                let [a, b, c] = tri.map(|v| {
                    let p = pos[v as usize];
                    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
                });
                let outward = (b - a).cross(c - a).dot(a + b + c);
                assert!(outward > 0.0, "LOD {lod}: triangle {tri:?} faces inward");
            }
        }
        // Costs are non-negative mean squared distances; a flat-ish start is cheap.
        assert!(seq.collapses.iter().all(|c| c.error >= 0.0));
        assert!(seq.collapses[0].error < seq.collapses[seq.len() - 1].error);
    }

    #[test]
    fn disk_keeps_its_boundary_and_ends_at_one_triangle() {
        let (pos, tris) = grid(6, 0.0);
        let (_, v, t) = check_run(&pos, &tris);
        assert_eq!((v, t), (3, 1));
    }

    #[test]
    fn flat_interior_collapses_before_the_boundary_moves() {
        // Interior vertices of a flat grid cost nothing; border vertices pay
        // their edge planes unless collinear. So all 25 interior vertices and
        // the 20 non-corner border vertices (collinear, also free) go first,
        // and no corner moves before every free vertex is gone.
        let (pos, tris) = grid(6, 0.0);
        let seq = simplify(&pos, &tris, &SimplifyOptions::default());
        let corners = [0u32, 6, 42, 48];
        let first_corner = seq
            .collapses
            .iter()
            .position(|c| corners.contains(&c.u))
            .unwrap();
        assert!(first_corner >= 45, "a corner moved at step {first_corner}");
        assert!(seq.collapses[..45].iter().all(|c| c.error < 1e-6));
    }

    #[test]
    fn annulus_keeps_both_loops() {
        let (pos, tris) = annulus();
        let (seq, v, _) = check_run(&pos, &tris);
        assert!(!seq.is_empty());
        // Two loops of at least three vertices each survive.
        assert!(v >= 6, "{v} vertices left");
    }

    #[test]
    fn torus_keeps_its_genus() {
        let (pos, tris) = torus(16, 8);
        let (seq, v, _) = check_run(&pos, &tris);
        assert!(seq.len() > pos.len() / 2, "only {} collapses", seq.len());
        assert!(v >= 7, "a torus needs at least 7 vertices, {v} left");
    }

    #[test]
    fn components_end_separately() {
        let mesh = join(
            sphere(6, 10, [0.0; 3]),
            join(sphere(5, 8, [3.0, 0.0, 0.0]), grid(4, 5.0)),
        );
        let (_, v, t) = check_run(&mesh.0, &mesh.1);
        assert_eq!((v, t), (4 + 4 + 3, 4 + 4 + 1));
    }

    #[test]
    fn non_manifold_and_degenerate_input_does_not_panic() {
        // A fin (three triangles on one edge), a repeated-index triangle, an
        // out-of-range index and a duplicated triangle, next to a clean grid.
        let (mut pos, mut tris) = grid(4, 0.0);
        let base = pos.len() as u32;
        pos.extend([
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [0.5, 1.0, 1.0],
            [0.5, -1.0, 1.0],
            [0.5, 0.0, 2.0],
        ]);
        tris.extend([
            [base, base + 1, base + 2],
            [base + 1, base, base + 3],
            [base, base + 1, base + 4],
            [base, base, base + 1],
            [base, base + 1, 999],
            [0, 1, 6],
        ]);
        let seq = simplify(&pos, &tris, &SimplifyOptions::default());
        seq.validate().unwrap();
        // The fin's edge vertices are non-manifold and never move.
        assert!(seq.collapses.iter().all(|c| c.u != base && c.u != base + 1));
    }

    #[test]
    fn real_meshes_run_to_a_tetrahedron() {
        // Both are closed genus-0 surfaces: the topology must hold at every LOD
        // checked (every 16th and the last 64) and the sequence must reach the
        // minimum, a tetrahedron.
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
        for mesh in [
            crate::io::obj::load(&dir.join("bunny.obj")),
            crate::io::off::load(&dir.join("cow.off")),
        ] {
            let mesh = mesh.unwrap();
            let (pos, tris) = (&mesh.positions, &mesh.triangles);
            let seq = simplify(pos, tris, &SimplifyOptions::default());
            seq.validate().unwrap();
            let start = inspect(pos.len(), tris, 0);
            assert_eq!(
                (start.euler, start.components, start.boundary_loops),
                (2, 1, 0)
            );
            for lod in (0..=seq.len()).filter(|l| l % 16 == 0 || l + 64 > seq.len()) {
                let lod_mesh = seq.reference_mesh(tris, lod);
                assert_eq!(inspect(pos.len(), &lod_mesh, lod), start, "LOD {lod}");
            }
            assert_eq!(seq.reference_mesh(tris, seq.len()).len(), 4);
        }
    }

    /// With the distance term, at every LOD each vertex removed so far lies within
    /// `sqrt(error / distance_weight)` of the coarse surface, `error` the largest collapse
    /// error so far: a collapse prices the distance of every vertex it moves before it is
    /// made and attaches each to a live triangle. On the bunny (a real scan, curved and
    /// noisy) and a bumped disk (a boundary). Fails if the term is left out of the cost, or a
    /// collapse forgets a vertex its triangles held.
    #[test]
    fn distance_term_bounds_how_far_removed_vertices_are() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
        let bunny = crate::io::obj::load(&dir.join("bunny.obj")).unwrap();
        let (mut disk, disk_tris) = grid(24, 0.0);
        for p in &mut disk {
            p[2] = 0.2 * (6.0 * p[0]).sin() * (5.0 * p[1]).cos();
        }
        let options = SimplifyOptions {
            distance_weight: DISTANCE_WEIGHT,
            ..SimplifyOptions::default()
        };
        for (pos, tris) in [(&bunny.positions, &bunny.triangles), (&disk, &disk_tris)] {
            let seq = simplify(pos, tris, &options);
            seq.validate().unwrap();
            let step = (seq.len() / 10).max(1);
            for lod in (step..=seq.len()).step_by(step) {
                let largest = seq.collapses[..lod]
                    .iter()
                    .map(|c| c.error as f64)
                    .fold(0.0, f64::max);
                // The recorded error is an f32.
                let bound = (largest / DISTANCE_WEIGHT as f64).sqrt() * (1.0 + 1e-5) + 1e-12;
                let surface =
                    crate::metrics::SurfaceIndex::new(pos, &seq.reference_mesh(tris, lod)).unwrap();
                let farthest = pos
                    .iter()
                    .map(|&p| surface.distance_squared(dvec(p)).sqrt())
                    .fold(0.0, f64::max);
                assert!(
                    farthest <= bound,
                    "LOD {lod}: a removed vertex is {farthest} from the surface, bound {bound}"
                );
            }
        }
    }

    /// The distance term's prices are made on the rayon pool, several at a time: the sequence
    /// is the same collapse for collapse, error for error, on one thread and on four. Two
    /// poses of a bumped disk (a border, so both kinds of targets are priced). Fails if a
    /// price lands on another vertex, or if pricing changed what a later price reads.
    #[test]
    fn the_distance_term_gives_one_sequence_on_any_number_of_threads() {
        let (flat, tris) = grid(24, 0.0);
        let bumped = |a: f32, b: f32| -> Vec<[f32; 3]> {
            flat.iter()
                .map(|&[x, y, _]| [x, y, 0.2 * (a * x).sin() * (b * y).cos()])
                .collect()
        };
        let (p0, p1) = (bumped(6.0, 5.0), bumped(3.0, 7.0));
        let options = SimplifyOptions {
            distance_weight: DISTANCE_WEIGHT,
            ..SimplifyOptions::default()
        };
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let seq = pool.install(|| simplify_poses(&[&p0, &p1], &tris, &options, PoseError::Max));
            seq.collapses
                .iter()
                .map(|c| (c.u, c.w, c.error.to_bits()))
                .collect::<Vec<_>>()
        };
        let one = on(1);
        assert!(one.len() > 500, "{} collapses", one.len());
        assert_eq!(one, on(4));
    }

    /// The distance term lowers the symmetric Hausdorff error of the bunny at 2% and 5% of its
    /// triangles by a fifth or more against the quadrics alone (measured: see BENCHMARKS.md).
    #[test]
    fn distance_term_lowers_the_hausdorff_error() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
        let bunny = crate::io::obj::load(&dir.join("bunny.obj")).unwrap();
        let (pos, tris) = (&bunny.positions, &bunny.triangles);
        let quadrics = simplify(pos, tris, &SimplifyOptions::default());
        let distance = simplify(
            pos,
            tris,
            &SimplifyOptions {
                distance_weight: DISTANCE_WEIGHT,
                ..SimplifyOptions::default()
            },
        );
        for percent in [5, 2] {
            let target = tris.len() * percent / 100;
            let error = |seq: &CollapseSequence| {
                let lod = (0..=seq.len())
                    .find(|&l| seq.reference_mesh(tris, l).len() <= target)
                    .unwrap();
                let mesh = seq.reference_mesh(tris, lod);
                crate::metrics::hausdorff(pos, tris, pos, &mesh, 20_000)
                    .unwrap()
                    .hausdorff
            };
            let (q, d) = (error(&quadrics), error(&distance));
            eprintln!("bunny {percent}%: Hausdorff {d:.5} with the term, {q:.5} without");
            assert!(d <= 0.8 * q, "{percent}%: {d} with the term vs {q} without");
        }
    }

    /// A 4×4 grid whose column x = 2 is a seam (cells right of it use copies of that column's
    /// vertices): the seam edges are exactly the column's 4 edges, once from each side, and
    /// border edges (one triangle) and edges whose ends agree on both sides are not seams.
    #[test]
    fn seam_edges_are_the_edges_whose_sides_differ_in_attributes() {
        let (n, k) = (4u32, 2u32);
        let row = n + 1;
        let (pos, tris) = grid(n, 0.0);
        let copy = |v: u32| {
            if v % row == k {
                pos.len() as u32 + v / row
            } else {
                v
            }
        };
        let corners: Vec<[u32; 3]> = tris
            .iter()
            .enumerate()
            // Cell of triangle i: (i / 2) % n; right of the seam when the cell's x ≥ k.
            .map(|(i, t)| {
                if (i as u32 / 2) % n >= k {
                    t.map(copy)
                } else {
                    *t
                }
            })
            .collect();
        let found = seam_edges(&tris, &corners);
        let mut want = Vec::new();
        for j in 0..n {
            let (low, high) = (j * row + k, (j + 1) * row + k);
            let left = (j * n + k - 1) * 2; // [v, v+1, v+row+1] of the cell left of the seam
            let right = (j * n + k) * 2 + 1; // [v, v+row+1, v+row] of the cell right of it
            want.push([low, high, left]);
            want.push([high, low, right]);
        }
        want.sort_unstable();
        assert_eq!(found, want);
        assert!(seam_edges(&tris, &tris).is_empty(), "no copies, no seams");
    }

    #[test]
    fn classify_reads_kinds_and_boundary_edges_off_the_fans() {
        // A 2×2 grid (centre 4 interior, the rest border), a bow-tie at 9 (two
        // fans), a fin on edge 14-15 (three triangles), and 19 in no triangle.
        let (_, mut tris) = grid(2, 0.0);
        tris.extend([
            [9, 10, 11],
            [9, 12, 13],
            [14, 15, 16],
            [15, 14, 17],
            [14, 15, 18],
        ]);
        let n = 20;
        let (kind, boundary) = classify(&tris, &VertexTriangles::new(&tris, n));
        let mut expected = vec![Kind::Border; n];
        expected[4] = Kind::Interior;
        for v in [9, 14, 15, 19] {
            expected[v] = Kind::Locked;
        }
        assert_eq!(kind, expected);
        // Oracle: every half-edge alone on its undirected edge, in (min, max) order.
        let undirected = |t: &[u32; 3], c: usize| {
            let (a, b) = (t[c], t[(c + 1) % 3]);
            (a.min(b), a.max(b))
        };
        let mut count: HashMap<(u32, u32), usize> = HashMap::new();
        for t in &tris {
            for c in 0..3 {
                *count.entry(undirected(t, c)).or_default() += 1;
            }
        }
        let mut want = Vec::new();
        for (i, t) in tris.iter().enumerate() {
            for c in 0..3 {
                if count[&undirected(t, c)] == 1 {
                    want.push([t[c], t[(c + 1) % 3], i as u32]);
                }
            }
        }
        want.sort_unstable_by_key(|&[a, b, _]| (a.min(b), a.max(b)));
        assert_eq!(boundary, want);
    }

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

    /// The attribute error against its definition: for each triangle of the attribute vertex,
    /// area × Σ over the weighted channels of (the triangle's interpolation at `p`'s projection
    /// onto its plane − the target's value)², summed; merged vertices sum both triangle sets.
    #[test]
    fn attribute_error_is_the_area_weighted_interpolation_misfit() {
        let mut rng = 0x1234_5678_u64;
        let mut unit = move || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let n = 6;
        let pos: Vec<[f32; 3]> = (0..n).map(|_| [unit(), unit(), unit()]).collect();
        let uvs: Vec<[f32; 2]> = (0..n).map(|_| [unit(), unit()]).collect();
        let normals: Vec<[f32; 3]> = (0..n).map(|_| [unit(), unit(), unit()]).collect();
        let tris = [[0u32, 1, 2], [0, 2, 3], [0, 3, 4], [5, 1, 0]];
        let map = crate::morph::TopologyMap::identity(n);
        let rule = SeamRule::new(&map, Some(&uvs)).with_normals(Some(&normals));
        let options = SimplifyOptions {
            uv_weight: 2.0,
            normal_weight: 0.5,
            ..Default::default()
        };
        let mut metric = AttributeMetric::new(&pos, &tris, &tris, &rule, &options).unwrap();
        let values = |v: u32| {
            let (uv, nm) = (uvs[v as usize], normals[v as usize]);
            [
                uv[0] * 2.0,
                uv[1] * 2.0,
                nm[0] * 0.5,
                nm[1] * 0.5,
                nm[2] * 0.5,
            ]
            .map(f64::from)
        };
        let misfit = |t: [u32; 3], p: DVec3, b: u32| {
            let [a, bb, c] = t.map(|v| dvec(pos[v as usize]));
            let normal = (bb - a).cross(c - a);
            let q = p - normal * (p - a).dot(normal) / normal.length_squared();
            let whole = normal.length();
            let l1 = (q - a).cross(c - a).dot(normal) / (whole * whole);
            let l2 = (bb - a).cross(q - a).dot(normal) / (whole * whole);
            let x = [values(t[0]), values(t[1]), values(t[2])];
            let target = values(b);
            0.5 * whole
                * (0..5)
                    .map(|k| {
                        let fitted = x[0][k] * (1.0 - l1 - l2) + x[1][k] * l1 + x[2][k] * l2;
                        (fitted - target[k]).powi(2)
                    })
                    .sum::<f64>()
        };
        let oracle = |of: &[u32], p: DVec3, b: u32| {
            tris.iter()
                .flat_map(|&t| of.iter().filter(move |&&a| holds(t, a)).map(move |_| t))
                .map(|t| misfit(t, p, b))
                .sum::<f64>()
        };
        let close = |got: f64, want: f64| (got - want).abs() <= 1e-9 * (1.0 + want.abs());
        for a in 0..n as u32 {
            for b in 0..n as u32 {
                let p = DVec3::new(unit() as f64, unit() as f64, unit() as f64);
                let (got, want) = (metric.error(a, p, b), oracle(&[a], p, b));
                assert!(close(got, want), "{a} -> {b} at {p}: {got} vs {want}");
            }
        }
        metric.merge(0, 1);
        let p = DVec3::new(0.3, 0.7, 0.2);
        let (got, want) = (metric.error(1, p, 4), oracle(&[0, 1], p, 4));
        assert!(close(got, want), "merged: {got} vs {want}");
    }

    #[test]
    fn empty_input() {
        let seq = simplify(&[], &[], &SimplifyOptions::default());
        assert!(seq.is_empty());
        assert_eq!(seq.vertex_count, 0);
    }
}
