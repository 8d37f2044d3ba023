//! A point strictly inside the kernel of a vertex's ring polygon on the sphere: where a split
//! vertex is placed ([`kernel_point`]), and where a cramped fan's vertex moves
//! ([`kernel_centre`]).

use glam::DVec3;

use super::super::sphere::orient;
use super::EmbedError;

pub(super) fn fan_positive(points: &[DVec3], p: DVec3, ring: &[u32]) -> bool {
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
pub(super) fn kernel_point(points: &[DVec3], u: u32, ring: &[u32]) -> Result<DVec3, EmbedError> {
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
pub(super) fn kernel_centre(points: &[DVec3], ring: &[u32], start: DVec3, scale: f64) -> DVec3 {
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
