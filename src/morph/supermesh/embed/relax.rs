//! The area-proportional relaxation ([`relax`], toward [`area_target`]) and the
//! fold-rejecting vertex moves it and the alignment make ([`move_vertex`], [`relax_vertex`]).

use glam::DVec3;

use super::super::sphere::spherical_area;
use super::kernel::{fan_positive, kernel_centre};

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
            let area = spherical_area(p, points[a], points[b]);
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
/// embeddings (0.1: 2.6×; figures in docs/benchmarks-log.md, "After the embedding rework
/// (area-proportional relaxation, umbrella weight 1.0)").
const UMBRELLA_WEIGHT: f64 = 1.0;

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
