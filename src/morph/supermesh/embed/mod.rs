//! Bijective embedding of a closed, manifold, genus-0 triangle mesh on the
//! unit sphere, after Praun & Hoppe's progressive approach:
//!
//! 1. [`collapse_to_tetrahedron`]: half-edge collapses, shortest edge first,
//!    each allowed only under the link condition, until four vertices remain
//!    (every triangulated sphere but the tetrahedron has a collapsible edge, so
//!    this always gets there);
//! 2. [`place_tetrahedron`] on the sphere, positively oriented;
//! 3. [`split_all`]: the collapses undone in reverse, each split vertex placed
//!    strictly inside the kernel of its one-ring polygon, then a few relaxation
//!    sweeps over its neighbourhood, and global sweeps each time the vertex
//!    count has doubled (many at coarse levels, few at fine ones);
//! 4. [`relax`] over the whole mesh, then [`verify`] with exact predicates.
//!
//! The relaxation is area-proportional ([`area_target`]): each vertex moves
//! so that the triangles of its fan share the fan's spherical area as their
//! surface areas share the fan's surface. At a coarse level a triangle's
//! surface area is read from the masses of its corners, each the surface area
//! of every vertex collapsed into it, so a limb keeps its share of the sphere
//! from the first levels on instead of being squeezed to a point (as the
//! plain umbrella operator, a Tutte embedding, does: 1e-17 sr triangles on
//! man.off).
//!
//! Every position change is a move along a chord from the old point to the new
//! one that is accepted only when every incident triangle is strictly
//! positively oriented at the new point (exact `orient3d`). A triangle's
//! orientation is linear along such a chord, so it stays positive on the whole
//! way: the embedding deforms continuously without ever degenerating, and its
//! degree (one) is kept. Thin limbs therefore cannot fold, however small their
//! triangles become.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::Instant;

use glam::DVec3;

use super::sphere::{check_embedding, orient};
use super::{Side, Stage, SupermeshError, SupermeshOptions};
use crate::mesh::clean::Cleaned;
use crate::mesh::IndexedMesh;

/// Why an embedding failed (only on input the checks should have rejected).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum EmbedError {
    /// A vertex's triangles do not form one closed fan.
    NotManifold { vertex: u32 },
    /// No edge satisfied the link condition before four vertices were left.
    Stuck { vertices: usize },
    /// No point of a split vertex's kernel was found in floating point.
    NoKernelPoint { vertex: u32 },
    /// The final check found folded faces or a wrong total area.
    Folded { folds: usize },
}

/// Sweeps over a split vertex's neighbourhood.
const LOCAL_SWEEPS: usize = 2;
/// Global sweeps each time the vertex count has doubled: about
/// `LEVEL_BUDGET / vertices` (at least `LEVEL_SWEEPS`, at most
/// `MAX_LEVEL_SWEEPS`), so coarse levels, where area moves across the whole
/// sphere in few steps, converge, for a cost of about `LEVEL_BUDGET` vertex
/// moves per level; and at the end.
const LEVEL_SWEEPS: usize = 3;
const MAX_LEVEL_SWEEPS: usize = 200;
const LEVEL_BUDGET: usize = 200_000;
const FINAL_SWEEPS: usize = 8;

/// The central projection from the origin: each vertex's position as its
/// sphere direction, unnormalised (so points on a straight edge stay exactly
/// on its great circle). `Err(folds)` when some triangle is not strictly
/// positive seen from the origin or the total area is not 4π.
pub(crate) fn radial(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Result<Vec<DVec3>, usize> {
    let points: Vec<DVec3> = positions.iter().map(|&p| d3(p)).collect();
    let (folds, area) = check_embedding(&points, triangles);
    let four_pi = 4.0 * std::f64::consts::PI;
    if folds > 0 || (area - four_pi).abs() > 1e-6 * four_pi {
        return Err(folds.max(1));
    }
    Ok(points)
}

/// Each vertex's surface area: a third of the areas of its triangles.
pub(crate) fn vertex_masses(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<f64> {
    let mut mass = vec![0.0f64; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|v| d3(positions[v as usize]));
        let third = (b - a).cross(c - a).length() / 6.0;
        for &v in t {
            mass[v as usize] += third;
        }
    }
    mass
}

/// The sphere points of every vertex (unused vertices get the north pole).
pub(crate) fn embed(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    progress: &mut dyn FnMut(f32),
) -> Result<Vec<DVec3>, EmbedError> {
    let mut rings = build_rings(positions.len(), triangles)?;
    let hierarchy = collapse_to_tetrahedron(positions, &mut rings)?;
    progress(0.25);
    // Each vertex's surface area (a third of its triangles'), and while
    // collapsed, the sum over the vertices collapsed into it: the surface
    // each vertex of every level stands for.
    let mut mass = vertex_masses(positions, triangles);
    for k in 0..hierarchy.records.len() {
        let (u, ring) = hierarchy.ring(k);
        mass[ring[0] as usize] += mass[u as usize];
    }
    let mut points = vec![DVec3::Z; positions.len()];
    place_tetrahedron(&rings, &hierarchy, &mut points);
    split_all(&mut mass, &mut rings, &hierarchy, &mut points, progress)?;
    let all: Vec<u32> = (0..positions.len() as u32)
        .filter(|&v| !rings[v as usize].is_empty())
        .collect();
    relax(&mass, &rings, &mut points, &all, FINAL_SWEEPS);
    progress(1.0);
    verify(&points, triangles)?;
    Ok(points)
}

/// Each vertex's neighbours in counter-clockwise order: vertex `v` has the
/// triangles `(v, ring[j], ring[j + 1])`.
pub(crate) fn build_rings(n: usize, triangles: &[[u32; 3]]) -> Result<Vec<Vec<u32>>, EmbedError> {
    // (next, after) pairs per vertex: triangle (a, b, c) gives a: b → c.
    let mut pairs: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
    for t in triangles {
        for i in 0..3 {
            pairs[t[i] as usize].push((t[(i + 1) % 3], t[(i + 2) % 3]));
        }
    }
    let mut rings = vec![Vec::new(); n];
    for (v, list) in pairs.iter().enumerate() {
        if list.is_empty() {
            continue;
        }
        let ring: &mut Vec<u32> = &mut rings[v];
        let first = list[0].0;
        let mut at = first;
        loop {
            ring.push(at);
            let next = match list.iter().find(|p| p.0 == at) {
                Some(p) => p.1,
                None => return Err(EmbedError::NotManifold { vertex: v as u32 }),
            };
            if next == first {
                break;
            }
            if ring.len() >= list.len() {
                return Err(EmbedError::NotManifold { vertex: v as u32 });
            }
            at = next;
        }
        if ring.len() != list.len() || ring.len() < 3 {
            return Err(EmbedError::NotManifold { vertex: v as u32 });
        }
    }
    Ok(rings)
}

/// The collapses in order: `u` disappeared with the ring `ring[start..start+len]`
/// (counter-clockwise, beginning with the vertex `w` it collapsed onto).
pub(crate) struct Hierarchy {
    pub records: Vec<(u32, u32, u32)>,
    pub ring_store: Vec<u32>,
}

impl Hierarchy {
    fn ring(&self, record: usize) -> (u32, &[u32]) {
        let (u, start, len) = self.records[record];
        (u, &self.ring_store[start as usize..(start + len) as usize])
    }
}

fn edge_key(positions: &[[f32; 3]], a: u32, b: u32) -> Reverse<(u64, u32, u32)> {
    let pa = positions[a as usize].map(f64::from);
    let pb = positions[b as usize].map(f64::from);
    let d2 = (pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2) + (pa[2] - pb[2]).powi(2);
    // Non-negative finite doubles order like their bit patterns.
    Reverse((d2.to_bits(), a.min(b), a.max(b)))
}

/// Collapses shortest edges first (under the link condition) until four
/// vertices are left; `rings` ends as the tetrahedron.
pub(crate) fn collapse_to_tetrahedron(
    positions: &[[f32; 3]],
    rings: &mut [Vec<u32>],
) -> Result<Hierarchy, EmbedError> {
    let mut alive = rings.iter().filter(|r| !r.is_empty()).count();
    let mut hierarchy = Hierarchy {
        records: Vec::with_capacity(alive.saturating_sub(4)),
        ring_store: Vec::with_capacity(alive.saturating_sub(4) * 7),
    };
    let mut heap = BinaryHeap::new();
    for (a, ring) in rings.iter().enumerate() {
        for &b in ring {
            if (a as u32) < b {
                heap.push(edge_key(positions, a as u32, b));
            }
        }
    }
    let mut failed: Vec<(u32, u32)> = Vec::new();
    let mut collapsed_since_refill = true;
    while alive > 4 {
        let Some(Reverse((_, a, b))) = heap.pop() else {
            if !collapsed_since_refill {
                return Err(EmbedError::Stuck { vertices: alive });
            }
            collapsed_since_refill = false;
            for (a, b) in failed.drain(..) {
                heap.push(edge_key(positions, a, b));
            }
            continue;
        };
        if rings[a as usize].is_empty() || !rings[a as usize].contains(&b) {
            continue;
        }
        // Remove the vertex with the smaller ring: a shorter record.
        let (u, w) = if rings[a as usize].len() <= rings[b as usize].len() {
            (a, b)
        } else {
            (b, a)
        };
        if !link_condition(rings, u, w) {
            failed.push((a, b));
            continue;
        }
        collapse(rings, u, w, &mut hierarchy);
        alive -= 1;
        collapsed_since_refill = true;
        let (_, ring) = hierarchy.ring(hierarchy.records.len() - 1);
        // The new edges: w to the ring's middle vertices.
        for &r in &ring[2..ring.len() - 1] {
            heap.push(edge_key(positions, w, r));
        }
    }
    Ok(hierarchy)
}

/// `ring(u)` rotated to start at `w`.
fn ring_from(rings: &[Vec<u32>], u: u32, w: u32) -> Vec<u32> {
    let ring = &rings[u as usize];
    let i = ring.iter().position(|&x| x == w).unwrap_or(0);
    ring[i..].iter().chain(&ring[..i]).copied().collect()
}

/// The link condition of edge `uw` on a closed surface: the only common
/// neighbours are the two apexes of the edge's triangles.
fn link_condition(rings: &[Vec<u32>], u: u32, w: u32) -> bool {
    let ring = ring_from(rings, u, w);
    let d = ring.len();
    let ring_w = &rings[w as usize];
    ring[2..d - 1].iter().all(|r| !ring_w.contains(r))
}

/// Half-edge collapse `u → w`, recorded in `hierarchy`.
fn collapse(rings: &mut [Vec<u32>], u: u32, w: u32, hierarchy: &mut Hierarchy) {
    let ring = ring_from(rings, u, w);
    let d = ring.len();
    let (r1, rl) = (ring[1], ring[d - 1]);
    // ring(w) = [.., r1, u, rl, ..]: u becomes r2 .. r_{d-2}.
    let rw = &mut rings[w as usize];
    let i = rw.iter().position(|&x| x == u).expect("u in ring(w)");
    rw.splice(i..i + 1, ring[2..d - 1].iter().copied());
    remove(&mut rings[r1 as usize], u);
    remove(&mut rings[rl as usize], u);
    for &r in &ring[2..d - 1] {
        replace(&mut rings[r as usize], u, w);
    }
    rings[u as usize].clear();
    hierarchy
        .records
        .push((u, hierarchy.ring_store.len() as u32, d as u32));
    hierarchy.ring_store.extend_from_slice(&ring);
}

/// Undoes [`collapse`] of `u` with its recorded ring `[w, r1, .., rl]`.
fn split(rings: &mut [Vec<u32>], u: u32, ring: &[u32]) {
    let d = ring.len();
    let (w, r1, rl) = (ring[0], ring[1], ring[d - 1]);
    let rw = &mut rings[w as usize];
    let i = rw.iter().position(|&x| x == r1).expect("r1 in ring(w)");
    // The d − 3 vertices after r1 (cyclically) go back to u.
    let n = rw.len();
    let middle = d - 3;
    if i + 1 + middle <= n {
        rw.splice(i + 1..i + 1 + middle, [u]);
    } else {
        let wrap = i + 1 + middle - n;
        rw.truncate(i + 1);
        rw.drain(..wrap);
        rw.push(u);
    }
    // ring(r1) = [.., r2, u, w, ..]: u goes back before w.
    let r = &mut rings[r1 as usize];
    let j = r.iter().position(|&x| x == w).expect("w in ring(r1)");
    r.insert(j, u);
    // ring(rl) = [.., w, u, r_{d-2}, ..]: u goes back after w.
    let r = &mut rings[rl as usize];
    let j = r.iter().position(|&x| x == w).expect("w in ring(rl)");
    r.insert(j + 1, u);
    for &m in &ring[2..d - 1] {
        replace(&mut rings[m as usize], w, u);
    }
    rings[u as usize] = ring.to_vec();
}

fn remove(ring: &mut Vec<u32>, x: u32) {
    if let Some(i) = ring.iter().position(|&y| y == x) {
        ring.remove(i);
    }
}

fn replace(ring: &mut [u32], from: u32, to: u32) {
    if let Some(y) = ring.iter_mut().find(|y| **y == from) {
        *y = to;
    }
}

/// The four remaining vertices at the corners of a regular tetrahedron,
/// mirrored if needed so that its triangles are positively oriented.
pub(crate) fn place_tetrahedron(rings: &[Vec<u32>], _hierarchy: &Hierarchy, points: &mut [DVec3]) {
    let corners = [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(-1.0, -1.0, 1.0),
    ];
    let live: Vec<u32> = (0..rings.len() as u32)
        .filter(|&v| !rings[v as usize].is_empty())
        .collect();
    for (&v, c) in live.iter().zip(corners) {
        points[v as usize] = c.normalize();
    }
    if let Some(&v) = live.first() {
        let r = &rings[v as usize];
        let o = orient(
            points[v as usize],
            points[r[0] as usize],
            points[r[1] as usize],
        );
        if o < 0.0 {
            points.swap(live[0] as usize, live[1] as usize);
        }
    }
}

/// Undoes every collapse, placing each split vertex in its kernel and relaxing.
fn split_all(
    mass: &mut [f64],
    rings: &mut [Vec<u32>],
    hierarchy: &Hierarchy,
    points: &mut [DVec3],
    progress: &mut dyn FnMut(f32),
) -> Result<(), EmbedError> {
    let total = hierarchy.records.len();
    let mut live: Vec<u32> = (0..rings.len() as u32)
        .filter(|&v| !rings[v as usize].is_empty())
        .collect();
    let mut next_level = 8;
    let mut neighbourhood = Vec::new();
    for k in (0..total).rev() {
        let (u, ring) = hierarchy.ring(k);
        split(rings, u, ring);
        mass[ring[0] as usize] -= mass[u as usize];
        points[u as usize] = kernel_point(points, u, ring)?;
        live.push(u);
        neighbourhood.clear();
        neighbourhood.push(u);
        neighbourhood.extend_from_slice(ring);
        relax(mass, rings, points, &neighbourhood, LOCAL_SWEEPS);
        if live.len() >= next_level {
            let sweeps = (LEVEL_BUDGET / live.len()).clamp(LEVEL_SWEEPS, MAX_LEVEL_SWEEPS);
            relax(mass, rings, points, &live, sweeps);
            next_level *= 2;
        }
        if k.is_multiple_of(4096) {
            progress(0.25 + 0.65 * (total - k) as f32 / total.max(1) as f32);
        }
    }
    Ok(())
}

fn fan_positive(points: &[DVec3], p: DVec3, ring: &[u32]) -> bool {
    let d = ring.len();
    (0..d).all(|j| {
        let a = points[ring[j] as usize];
        let b = points[ring[(j + 1) % d] as usize];
        orient(p, a, b) > 0.0
    })
}

/// A point strictly inside the kernel of the polygon `ring` (which starts at
/// `w`, the vertex `u` was collapsed onto): the ring's centroid when it is in
/// the kernel; else the point that maximises the smallest distance to the
/// polygon's edge circles ([`kernel_centre`]), started near `w` on the
/// bisector of the kernel's corner there (which is in the kernel for a step
/// small enough); else that bisector point itself, closer and closer to `w`.
fn kernel_point(points: &[DVec3], u: u32, ring: &[u32]) -> Result<DVec3, EmbedError> {
    let centroid = ring
        .iter()
        .map(|&r| points[r as usize])
        .sum::<DVec3>()
        .normalize_or_zero();
    if centroid != DVec3::ZERO && fan_positive(points, centroid, ring) {
        return Ok(centroid);
    }
    let d = ring.len();
    let w = points[ring[0] as usize];
    let tangent = |p: DVec3| (p - w * p.dot(w)).normalize_or_zero();
    let t1 = tangent(points[ring[1] as usize]);
    let t2 = tangent(points[ring[d - 1] as usize]);
    let angle = {
        let a = t1.cross(t2).dot(w).atan2(t1.dot(t2));
        if a <= 0.0 {
            a + std::f64::consts::TAU
        } else {
            a
        }
    };
    let half = 0.5 * angle;
    let direction = half.cos() * t1 + half.sin() * w.cross(t1);
    let scale = ring[1..]
        .iter()
        .map(|&r| (points[r as usize] - w).length())
        .fold(f64::INFINITY, f64::min);
    let mut step = 0.5 * scale;
    for _ in 0..60 {
        let p = (w + direction * step).normalize();
        if fan_positive(points, p, ring) {
            let centre = kernel_centre(points, ring, p, scale);
            if fan_positive(points, centre, ring) {
                return Ok(centre);
            }
            return Ok(p);
        }
        step *= 0.5;
    }
    Err(EmbedError::NoKernelPoint { vertex: u })
}

/// Ascent from `start` (inside the kernel of the closed polygon `ring`)
/// toward the point farthest from the polygon's edge circles: a few
/// subgradient steps on `min_j n_j · x` (unit edge-circle normals `n_j`),
/// each kept only if it raises that minimum.
fn kernel_centre(points: &[DVec3], ring: &[u32], start: DVec3, scale: f64) -> DVec3 {
    let d = ring.len();
    let normals: Vec<DVec3> = (0..d)
        .map(|j| {
            points[ring[j] as usize]
                .cross(points[ring[(j + 1) % d] as usize])
                .normalize_or_zero()
        })
        .collect();
    let margin = |x: DVec3| {
        normals
            .iter()
            .map(|n| n.dot(x))
            .fold(f64::INFINITY, f64::min)
    };
    let mut x = start;
    let mut best = margin(x);
    let mut step = 0.5 * scale;
    for _ in 0..64 {
        let worst = normals
            .iter()
            .min_by(|a, b| a.dot(x).total_cmp(&b.dot(x)))
            .copied()
            .unwrap_or(DVec3::ZERO);
        let trial = (x + worst * step).normalize();
        let m = margin(trial);
        if m > best {
            (x, best) = (trial, m);
        } else {
            step *= 0.5;
            if step < 1e-3 * scale {
                break;
            }
        }
    }
    x
}

/// Gauss–Seidel sweeps over `vertices`: each moves toward its
/// [`area_target`] (or half, or a quarter of the way) only where every
/// incident triangle stays strictly positive (see the module docs for why
/// that keeps the embedding bijective).
pub(crate) fn relax(
    mass: &[f64],
    rings: &[Vec<u32>],
    points: &mut [DVec3],
    vertices: &[u32],
    sweeps: usize,
) {
    for _ in 0..sweeps {
        for &v in vertices {
            match area_target(mass, rings, points, v) {
                Some(target) => {
                    relax_vertex(rings, points, v, Some(target));
                }
                None => {
                    guarded_umbrella(mass, rings, points, v);
                }
            }
        }
    }
}

/// The fan's area energy on the sphere, `Σ_t A_t² / S_t` (spherical areas
/// `A_t`, surface areas `S_t` from the masses), with `v` at `p`: smallest
/// when the fan's spherical area is shared as its surface area is.
fn fan_energy(mass: &[f64], ring: &[u32], points: &[DVec3], v: u32, p: DVec3) -> f64 {
    let d = ring.len();
    let mv = mass[v as usize];
    (0..d)
        .map(|j| {
            let (a, b) = (ring[j] as usize, ring[(j + 1) % d] as usize);
            let area = super::sphere::spherical_area(p, points[a], points[b]);
            let s = (mv + mass[a] + mass[b]).max(1e-300);
            area * area / s
        })
        .sum()
}

/// Where a ring is too wide for [`area_target`]'s chart (coarse levels): a
/// fold-rejecting move toward the neighbours' mean, or a half or a quarter
/// of the way, kept only if it lowers the fan's spherical [`fan_energy`]
/// (the spherical umbrella operator alone collapses coarse meshes).
fn guarded_umbrella(mass: &[f64], rings: &[Vec<u32>], points: &mut [DVec3], v: u32) -> bool {
    let ring = &rings[v as usize];
    if ring.is_empty() {
        return false;
    }
    let old = points[v as usize];
    let target = ring.iter().map(|&r| points[r as usize]).sum::<DVec3>();
    let Some(mut candidate) = target.try_normalize() else {
        return false;
    };
    let before = fan_energy(mass, ring, points, v, old);
    for _ in 0..3 {
        if fan_positive(points, candidate, ring)
            && fan_energy(mass, ring, points, v, candidate) < before
        {
            points[v as usize] = candidate;
            return true;
        }
        match (old + candidate).try_normalize() {
            Some(c) => candidate = c,
            None => return false,
        }
    }
    false
}

/// Weight of the umbrella (shape) term against the area term in
/// [`area_target`]: it keeps triangles from getting needle-thin where pure
/// area matching would allow it, and limbs of the two meshes from being
/// stretched in different directions (which multiplies the crossings). 1.0
/// puts man → camel at 0.88× the supermesh size expected of near-uniform
/// embeddings (0.1: 2.6×; figures in BENCHMARKS.md).
const UMBRELLA_WEIGHT: f64 = 1.0;

fn d3(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// Where `v` should go so that each triangle of its fan gets a share of the
/// fan's spherical area proportional to its share of the fan's surface area
/// (area-proportional, after Praun & Hoppe's and Yoshizawa et al.'s
/// stretch-driven relaxation): in the gnomonic chart at `v` (central
/// projection onto the tangent plane, which maps great arcs to lines, so the
/// chart's triangle areas are linear in `v`'s chart position `x`), the
/// minimiser of
///
/// `Σ_t (A_t(x)/P − S_t/F)² · F/S_t  +  μ Σ_j |x − q_j|² / Σ_j |q_j|²`
///
/// (`A_t`: chart area of fan triangle `t`, `P` their sum, which moving `v`
/// does not change; `S_t`: surface area, `F` their sum; `q_j`: the
/// neighbours in the chart; `μ` = [`UMBRELLA_WEIGHT`]), a 2×2 linear solve.
/// `None` (plain umbrella) when a neighbour is too far for the chart.
fn area_target(mass: &[f64], rings: &[Vec<u32>], points: &[DVec3], v: u32) -> Option<DVec3> {
    let ring = &rings[v as usize];
    let d = ring.len();
    let o = points[v as usize].normalize();
    let e1 = o.any_orthonormal_vector();
    let e2 = o.cross(e1);
    let mut q = [glam::DVec2::ZERO; 64];
    let mut s = [0.0f64; 64];
    if d > q.len() {
        return None;
    }
    let mv = mass[v as usize];
    let mut radius = 0.0;
    for (j, &r) in ring.iter().enumerate() {
        let p = points[r as usize];
        let h = p.dot(o);
        if h <= 0.25 * p.length() {
            return None;
        }
        let c = p / h - o;
        q[j] = glam::DVec2::new(c.dot(e1), c.dot(e2));
        radius += q[j].length_squared();
    }
    let mut f = 0.0;
    for j in 0..d {
        s[j] = mv + mass[ring[j] as usize] + mass[ring[(j + 1) % d] as usize];
        f += s[j];
    }
    if f.is_nan() || radius.is_nan() || f <= 0.0 || radius <= 0.0 {
        return None;
    }
    let floor = 1e-4 * f / d as f64;
    let mut area = 0.0;
    for j in 0..d {
        s[j] = s[j].max(floor) / f;
        area += 0.5 * q[j].perp_dot(q[(j + 1) % d]);
    }
    if area.is_nan() || area <= 0.0 {
        return None;
    }
    // A_t(x) = ½ (q_j × q_{j+1} + x × (q_j − q_{j+1})) = c_t + g_t · x.
    let mu = UMBRELLA_WEIGHT / radius;
    let (mut m00, mut m01, mut m11) = (mu * d as f64, 0.0, mu * d as f64);
    let mut rhs = q[..d].iter().sum::<glam::DVec2>() * mu;
    for j in 0..d {
        let (a, b) = (q[j], q[(j + 1) % d]);
        let c = 0.5 * a.perp_dot(b) / area;
        let e = a - b;
        let g = glam::DVec2::new(e.y, -e.x) * (0.5 / area);
        let w = 1.0 / s[j];
        m00 += w * g.x * g.x;
        m01 += w * g.x * g.y;
        m11 += w * g.y * g.y;
        rhs += g * (w * (s[j] - c));
    }
    let det = m00 * m11 - m01 * m01;
    if det.is_nan() || det <= 0.0 {
        return None;
    }
    let x = glam::DVec2::new(m11 * rhs.x - m01 * rhs.y, m00 * rhs.y - m01 * rhs.x) / det;
    let target = o + e1 * x.x + e2 * x.y;
    target.is_finite().then_some(target)
}

/// Moves `v` to `target` (kept as given, so a vertex can land on exactly
/// another mesh's point), or a half or a quarter of the way there (along the
/// chord), whichever first keeps its fan strictly positive. Returns whether
/// it moved.
pub(crate) fn move_vertex(rings: &[Vec<u32>], points: &mut [DVec3], v: u32, target: DVec3) -> bool {
    let ring = &rings[v as usize];
    let old = points[v as usize];
    if !target.is_finite() || target.try_normalize().is_none() {
        return false;
    }
    let mut candidate = target;
    for _ in 0..3 {
        if fan_positive(points, candidate, ring) {
            points[v as usize] = candidate;
            return true;
        }
        match (old + candidate).try_normalize() {
            Some(c) => candidate = c,
            None => return false,
        }
    }
    false
}

/// One fold-rejecting move of `v` toward `target` (default: its neighbours'
/// mean). Returns whether it moved.
pub(crate) fn relax_vertex(
    rings: &[Vec<u32>],
    points: &mut [DVec3],
    v: u32,
    target: Option<DVec3>,
) -> bool {
    let ring = &rings[v as usize];
    if ring.is_empty() {
        return false;
    }
    let old = points[v as usize];
    let target = match target {
        Some(t) => t,
        None => ring.iter().map(|&r| points[r as usize]).sum::<DVec3>(),
    };
    let Some(target) = target.try_normalize() else {
        return false;
    };
    let mut candidate = target;
    for _ in 0..3 {
        if fan_positive(points, candidate, ring) {
            points[v as usize] = candidate;
            return true;
        }
        match (old + candidate).try_normalize() {
            Some(c) => candidate = c,
            None => return false,
        }
    }
    // The neighbours' mean is outside the kernel (a cramped fan): move
    // toward the kernel's centre instead, which only widens the fan.
    let scale = ring
        .iter()
        .map(|&r| (points[r as usize] - old).length())
        .fold(f64::INFINITY, f64::min);
    let centre = kernel_centre(points, ring, old, scale);
    if centre != old && fan_positive(points, centre, ring) {
        points[v as usize] = centre;
        return true;
    }
    false
}

/// Exact final check: no folded face and a total area of 4π (degree one).
pub(crate) fn verify(points: &[DVec3], triangles: &[[u32; 3]]) -> Result<(), EmbedError> {
    let (folds, area) = check_embedding(points, triangles);
    let four_pi = 4.0 * std::f64::consts::PI;
    if folds > 0 || (area - four_pi).abs() > 1e-6 * four_pi {
        return Err(EmbedError::Folded {
            folds: folds.max(1),
        });
    }
    Ok(())
}

/// How even an embedding is: the smallest spherical triangle area and the
/// spread of each triangle's area distortion, its share of the sphere's
/// area over its share of the surface's (1 everywhere for an
/// area-proportional map).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EmbeddingQuality {
    /// Smallest spherical triangle area (steradians).
    pub min_area: f64,
    /// Mean spherical triangle area, `4π / triangles` (for scale).
    pub mean_area: f64,
    /// 5th, 50th and 95th percentiles of the area distortion.
    pub distortion: [f64; 3],
}

pub(crate) fn quality(
    points: &[DVec3],
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
) -> EmbeddingQuality {
    let surface: Vec<f64> = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| d3(positions[v as usize]));
            0.5 * (b - a).cross(c - a).length()
        })
        .collect();
    let total: f64 = surface.iter().sum();
    let four_pi = 4.0 * std::f64::consts::PI;
    let mut min_area = f64::INFINITY;
    let mut ratios: Vec<f64> = triangles
        .iter()
        .zip(&surface)
        .map(|(t, &s)| {
            let [a, b, c] = t.map(|v| points[v as usize]);
            let area = super::sphere::spherical_area(a, b, c);
            min_area = min_area.min(area);
            (area / four_pi) / (s / total).max(f64::MIN_POSITIVE)
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let at = |f: f64| {
        ratios
            .get(((ratios.len() as f64 - 1.0) * f).round() as usize)
            .copied()
            .unwrap_or(0.0)
    };
    EmbeddingQuality {
        min_area,
        mean_area: four_pi / triangles.len().max(1) as f64,
        distortion: [at(0.05), at(0.5), at(0.95)],
    }
}

/// Both embeddings with their meshes.
pub(super) struct Embedded {
    pub(super) a: Vec<DVec3>,
    pub(super) b: Vec<DVec3>,
}

/// Stage 2: both embeddings, in parallel, each timed on its own.
pub(super) fn embed_both(
    ca: &Cleaned,
    cb: &Cleaned,
    options: &SupermeshOptions,
    seconds: &mut Vec<(Stage, f64)>,
) -> Result<Embedded, SupermeshError> {
    let progress = options.progress;
    let radial = options.radial;
    let one = |mesh: &IndexedMesh, stage: Stage, side: Side| {
        let start = Instant::now();
        let mut report = |f: f32| {
            if let Some(p) = progress {
                p(stage, f);
            }
        };
        report(0.0);
        let out = if radial {
            self::radial(&mesh.positions, &mesh.triangles).map_err(|folds| {
                SupermeshError::Embedding {
                    mesh: side,
                    what: format!(
                        "central projection from the origin folds {folds} triangle(s): the mesh is not star-shaped about the origin; turn SupermeshOptions::radial off"
                    ),
                }
            })
        } else {
            embed(&mesh.positions, &mesh.triangles, &mut report).map_err(|e| {
                SupermeshError::Embedding {
                    mesh: side,
                    what: format!("{e:?}"),
                }
            })
        };
        report(1.0);
        (out, start.elapsed().as_secs_f64())
    };
    let ((a, ta), (b, tb)) = rayon::join(
        || one(&ca.mesh, Stage::EmbedA, Side::A),
        || one(&cb.mesh, Stage::EmbedB, Side::B),
    );
    seconds.push((Stage::EmbedA, ta));
    seconds.push((Stage::EmbedB, tb));
    Ok(Embedded { a: a?, b: b? })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        (
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
        )
    }

    fn cube() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for i in 0..8 {
            p.push([(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32]);
        }
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let mut t = Vec::new();
        for q in quads {
            t.push([q[0], q[1], q[2]]);
            t.push([q[0], q[2], q[3]]);
        }
        (p, t)
    }

    /// A closed capped cylinder of radius `r` and length `len` along x,
    /// `segments` around and `rings` along.
    pub(crate) fn finger(
        r: f32,
        len: f32,
        segments: u32,
        rings: u32,
    ) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for i in 0..=rings {
            let x = len * i as f32 / rings as f32;
            for j in 0..segments {
                let a = std::f32::consts::TAU * j as f32 / segments as f32;
                p.push([x, r * a.cos(), r * a.sin()]);
            }
        }
        let cap0 = p.len() as u32;
        p.push([-r, 0.0, 0.0]);
        let cap1 = p.len() as u32;
        p.push([len + r, 0.0, 0.0]);
        let id = |i: u32, j: u32| i * segments + j % segments;
        let mut t = Vec::new();
        for i in 0..rings {
            for j in 0..segments {
                t.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
            }
        }
        for j in 0..segments {
            t.push([cap0, id(0, j + 1), id(0, j)]);
            t.push([cap1, id(rings, j), id(rings, j + 1)]);
        }
        (p, t)
    }

    fn embeds(p: &[[f32; 3]], t: &[[u32; 3]]) {
        let r = crate::topology::analyze(&crate::mesh::IndexedMesh::new(p.to_vec(), t.to_vec()))
            .unwrap();
        assert_eq!(r.genus(), Some(0), "{r}");
        let points = embed(p, t, &mut |_| {}).expect("embeds");
        println!("{:?}", quality(&points, p, t));
        let (folds, area) = check_embedding(&points, t);
        assert_eq!(folds, 0);
        assert!((area - 4.0 * std::f64::consts::PI).abs() < 1e-9);
    }

    #[test]
    fn tetrahedron_embeds() {
        let (p, t) = tetrahedron();
        embeds(&p, &t);
    }

    #[test]
    fn cube_embeds() {
        let (p, t) = cube();
        embeds(&p, &t);
    }

    #[test]
    fn thin_finger_embeds() {
        // 1:50 aspect, 12 around, 300 along.
        let (p, t) = finger(0.01, 1.0, 12, 300);
        embeds(&p, &t);
    }

    /// A Möbius map carried through whole on a thin limb's embedding, whose
    /// tip cap has triangles far smaller than the map moves them: one vertex
    /// at a time (fold-rejecting moves, the whole, half or a quarter of the
    /// way, in Gauss–Seidel sweeps) the cap stays behind, as every move
    /// folds a fan against its unmoved neighbours; all at once
    /// ([`super::super::mobius::warp`]) it moves with its vertices. Likewise
    /// the Möbius centring reaches the centre.
    #[test]
    fn mobius_maps_carry_a_thin_limb_through() {
        use super::super::mobius::{centre, warp, Mobius};
        let (p, t) = finger(0.01, 1.0, 12, 120);
        let points = embed(&p, &t, &mut |_| {}).expect("embeds");
        let rings = build_rings(p.len(), &t).unwrap();
        let map = Mobius::small([0.36, 0.16, -0.28, 0.12, 0.2, -0.24]);
        let mut one_by_one = points.clone();
        for k in 1..=8 {
            let m = map.power(k as f64 / 8.0);
            for _ in 0..4 {
                for (v, &x) in points.iter().enumerate() {
                    move_vertex(&rings, &mut one_by_one, v as u32, m.apply(x));
                }
            }
        }
        let behind = (0..p.len())
            .filter(|&v| one_by_one[v] != map.apply(points[v]))
            .count();
        assert!(behind > p.len() / 2, "{behind}");
        let mut warped = points.clone();
        assert_eq!(warp(&rings, &t, &mut warped, &map, 8, 4), 0);
        assert_eq!(check_embedding(&warped, &t).0, 0);
        let mass = vertex_masses(&p, &t);
        let mut centred = points.clone();
        let (before, after) = centre(&rings, &mut centred, &mass, &t);
        assert!(before > 0.1 && after < 1e-6, "{before} -> {after}");
        assert_eq!(check_embedding(&centred, &t).0, 0);
    }

    #[test]
    fn collapse_and_split_are_inverse() {
        let (p, t) = finger(0.1, 1.0, 8, 10);
        let original = build_rings(p.len(), &t).unwrap();
        let mut rings = original.clone();
        let h = collapse_to_tetrahedron(&p, &mut rings).unwrap();
        assert_eq!(rings.iter().filter(|r| !r.is_empty()).count(), 4);
        for k in (0..h.records.len()).rev() {
            let (u, ring) = h.ring(k);
            split(&mut rings, u, ring);
        }
        // Same cyclic rings.
        for (a, b) in rings.iter().zip(&original) {
            assert_eq!(a.len(), b.len());
            let i = a.iter().position(|&x| x == b[0]).unwrap();
            let rotated: Vec<u32> = a[i..].iter().chain(&a[..i]).copied().collect();
            assert_eq!(&rotated, b);
        }
    }
}
