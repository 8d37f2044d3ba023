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
//!
//! One file a stage, in the order they run (this file holds the options, the entry points,
//! the state they share and the loop):
//! * `classify`: what each vertex may do, read off its fan; the boundary and seam edges;
//! * `quadric`: the position quadrics (faces, boundary and seam edges, regularization);
//!   `attributes`: the attribute error; `poses`: one quadric per pose, each pose's error
//!   scaled to the first pose's size and combined;
//! * `rank`: each vertex's allowed targets and their costs, its entry in the `queue`;
//!   `distance` prices the distance term lazily, at the top of the queue;
//! * `rules`: the topology rules (and the seam rule, through `seams`) on the current mesh;
//! * `collapse`: makes a collapse and updates the queue where costs changed.

mod attributes;
mod classify;
mod collapse;
mod distance;
mod poses;
mod quadric;
mod queue;
mod rank;
mod rules;
mod seams;
#[cfg(test)]
pub(crate) mod tests;

use glam::DVec3;

use crate::collapse::{Collapse, CollapseSequence};
use crate::mesh::adjacency::VertexTriangles;
use crate::seams::SeamRule;
use attributes::AttributeMetric;
use classify::{classify, seam_edges, Kind};
use distance::{standing_still, Attached};
use poses::pose_scales;
use quadric::{quadrics, Quadric};
use queue::Queue;
use rank::PriceScratch;
use seams::Seams;

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
    /// times the quadric-only build; docs/benchmarks-log.md, "Distance term"). 0 (the
    /// default) turns it off; [`DISTANCE_WEIGHT`] is the measured choice.
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
    /// no pose is given up for the others (lower error at the worst `t`; docs/benchmarks-log.md,
    /// "One sequence for every pose (issue 12, item 1)").
    #[default]
    Max,
}

/// [`SimplifyOptions::seam_weight`]'s default, meshoptimizer's.
pub const SEAM_WEIGHT: f32 = 1.0;

/// [`SimplifyOptions::uv_weight`]'s default: on makehuman_face at 10% it lowers the UV error's
/// 95th percentile by a fifth and the mean normal deviation by a tenth against both weights 0,
/// with the geometric error no larger (docs/benchmarks-log.md, "Attribute error").
pub const UV_WEIGHT: f32 = 4.0;
/// [`SimplifyOptions::normal_weight`]'s default (same measurement as [`UV_WEIGHT`]; 0.25 shaded
/// a little better and cost 40% more geometric error).
pub const NORMAL_WEIGHT: f32 = 0.1;

/// The [`SimplifyOptions::distance_weight`] to use when turning the term on: on the shared
/// sequences of makehuman_face and makehuman_body it gave the lowest Hausdorff error of the
/// weights tried (1, 2, 4, 6, 8, 16; higher weights leave the error to the sampled far side,
/// lower ones to the quadrics; docs/benchmarks-log.md, "The distance term: (d), what `export`
/// builds by default (2026-11-24)").
pub const DISTANCE_WEIGHT: f32 = 4.0;

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

/// The simplifier's state: the live mesh (triangles, each vertex's kind and live triangles),
/// the quadrics, the queue and the collapses made so far. Each stage adds its methods in its
/// own file.
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

/// Where a vertex's live triangles sit in [`State::pool`]: `len` entries at
/// `start`, room for `cap`. One record, so a visit costs one cache line.
#[derive(Clone, Copy, Debug)]
struct Span {
    start: usize,
    len: u32,
    cap: u32,
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
        // Classify, then the quadrics of every pose (vertex-major) and the poses' scales.
        let vt = VertexTriangles::new(&tris, n);
        let (kind, boundary_edges) = classify(&tris, &vt);
        let per_pose: Vec<Vec<Quadric>> = poses
            .iter()
            .map(|pos| quadrics(pos, &tris, &boundary_edges, seam_edges, options))
            .collect();
        let quadric = (0..n)
            .flat_map(|v| per_pose.iter().map(move |q| q[v]))
            .collect();
        let pose_scale = pose_scales(poses);
        let scale_max = pose_scale.iter().copied().fold(1.0, f64::max);
        let (still, ring_still) = if options.distance_weight > 0.0 {
            standing_still(poses, &tris, &vt)
        } else {
            (Vec::new(), Vec::new())
        };
        // Each vertex's live triangles, in the pool.
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
        let attached = (options.distance_weight > 0.0)
            .then(|| Attached::new(options, tris.clone(), vt, ring_still));
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
            attached,
            still,
            scale_max,
        }
    }

    fn vertex_count(&self) -> usize {
        self.poses[0].len()
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
}

fn dvec(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
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
