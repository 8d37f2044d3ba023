//! Aligning B's sphere embedding with A's, so that equal sphere points carry
//! similar parts of the two shapes.
//!
//! 1. [`Frame`]: both shapes are normalised for position (area-weighted
//!    centroid), scale (RMS distance to it) and orientation (principal axes,
//!    each signed by its third moment, right-handed);
//! 2. [`search_rotation`]: the rotation `R` of B's sphere that minimises the
//!    mean distance between A's normalised vertices and B's normalised surface
//!    at the same sphere point: the 24 rotations of the cube, each also turned
//!    by 40° and 80° about z, then a local descent with halving angles from
//!    the best four;
//! 3. [`pull_landmarks`] (optional): each B landmark's sphere point walks
//!    toward its A partner's by fold-rejecting moves while every other B
//!    vertex relaxes with the landmarks pinned.
//!
//! B's surface at a sphere point is read from a cube map of its projective
//! barycentric interpolation ([`SurfaceLookup`]), so one candidate costs one
//! table read per sample.

use glam::{DMat3, DVec3};

use super::embed::relax_vertex;
use super::sphere::{orient, projective_barycentric, Location, SphereMesh};

/// Mean and largest distance between corresponding points.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Residual {
    pub mean: f64,
    pub max: f64,
}

/// A shape's normalising similarity: `q = axes · (p − centroid) / scale`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    centroid: DVec3,
    scale: f64,
    /// Rows are the principal axes, largest variance first.
    axes: DMat3,
}

fn d(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

impl Frame {
    pub fn new(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Frame {
        // Area-weighted moments over the triangles (vertex averages of each).
        let mut area_sum = 0.0;
        let mut centroid = DVec3::ZERO;
        for t in triangles {
            let [a, b, c] = t.map(|v| d(positions[v as usize]));
            let area = 0.5 * (b - a).cross(c - a).length();
            area_sum += area;
            centroid += area * (a + b + c) / 3.0;
        }
        let weight = |a: f64| if area_sum > 0.0 { a / area_sum } else { 0.0 };
        if area_sum > 0.0 {
            centroid /= area_sum;
        }
        let mut cov = [[0.0f64; 3]; 3];
        let mut sq = 0.0;
        for t in triangles {
            let [a, b, c] = t.map(|v| d(positions[v as usize]) - centroid);
            let w = weight(0.5 * (b - a).cross(c - a).length()) / 3.0;
            for p in [a, b, c] {
                let p = p.to_array();
                for (r, row) in cov.iter_mut().enumerate() {
                    for (s, x) in row.iter_mut().enumerate() {
                        *x += w * p[r] * p[s];
                    }
                }
                sq += w * (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
            }
        }
        let scale = if sq > 0.0 { sq.sqrt() } else { 1.0 };
        let mut axes = principal_axes(cov);
        // Sign each axis by the third moment, so mirror-images agree.
        for axis in axes.iter_mut().take(2) {
            let mut third = 0.0;
            for t in triangles {
                for &v in t {
                    third += (d(positions[v as usize]) - centroid).dot(*axis).powi(3);
                }
            }
            if third < 0.0 {
                *axis = -*axis;
            }
        }
        axes[2] = axes[0].cross(axes[1]);
        Frame {
            centroid,
            scale,
            axes: DMat3::from_cols(axes[0], axes[1], axes[2]).transpose(),
        }
    }

    pub fn apply(&self, p: [f32; 3]) -> DVec3 {
        self.axes * (d(p) - self.centroid) / self.scale
    }
}

/// Eigenvectors of a symmetric 3×3 matrix by cyclic Jacobi rotations,
/// sorted by decreasing eigenvalue.
#[allow(clippy::needless_range_loop)] // Jacobi rotations read clearer with indices.
fn principal_axes(m: [[f64; 3]; 3]) -> [DVec3; 3] {
    let mut a = m;
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..50 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off < 1e-30 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| a[j][j].total_cmp(&a[i][i]));
    order.map(|k| DVec3::new(v[0][k], v[1][k], v[2][k]).normalize_or(DVec3::X))
}

/// B's normalised surface sampled over a cube map of sphere directions.
pub(crate) struct SurfaceLookup {
    n: usize,
    values: Vec<DVec3>,
}

impl SurfaceLookup {
    const N: usize = 40;

    pub fn new(mesh: &SphereMesh, normalised: &[DVec3]) -> SurfaceLookup {
        let n = Self::N;
        let mut values = Vec::with_capacity(6 * n * n);
        let mut rng = 0x1234_u64;
        let mut face = 0u32;
        for side in 0..6 {
            for i in 0..n {
                for j in 0..n {
                    let p = Self::direction(n, side, i, j);
                    face = match mesh.locate(p, face, &mut rng) {
                        Location::Inside(f) | Location::Degenerate(f) => f,
                    };
                    let t = mesh.triangles[face as usize];
                    let [a, b, c] = t.map(|v| mesh.points[v as usize]);
                    let l = projective_barycentric(p, a, b, c);
                    let q = t.map(|v| normalised[v as usize]);
                    values.push(q[0] * l[0] + q[1] * l[1] + q[2] * l[2]);
                }
            }
        }
        SurfaceLookup { n, values }
    }

    fn direction(n: usize, side: usize, i: usize, j: usize) -> DVec3 {
        let u = 2.0 * (i as f64 + 0.5) / n as f64 - 1.0;
        let v = 2.0 * (j as f64 + 0.5) / n as f64 - 1.0;
        let s = if side.is_multiple_of(2) { 1.0 } else { -1.0 };
        match side / 2 {
            0 => DVec3::new(s, u, v),
            1 => DVec3::new(u, s, v),
            _ => DVec3::new(u, v, s),
        }
        .normalize()
    }

    pub fn at(&self, p: DVec3) -> DVec3 {
        let a = p.abs();
        let (side, u, v, m) = if a.x >= a.y && a.x >= a.z {
            (usize::from(p.x < 0.0), p.y, p.z, a.x)
        } else if a.y >= a.z {
            (2 + usize::from(p.y < 0.0), p.x, p.z, a.y)
        } else {
            (4 + usize::from(p.z < 0.0), p.x, p.y, a.z)
        };
        let n = self.n;
        let cell = |x: f64| (((x / m + 1.0) * 0.5 * n as f64) as usize).min(n - 1);
        self.values[(side * n + cell(u)) * n + cell(v)]
    }
}

/// Sample points of A: sphere point and normalised position.
pub(crate) fn samples(sphere: &[DVec3], normalised: &[DVec3], max: usize) -> Vec<(DVec3, DVec3)> {
    let step = sphere.len().div_ceil(max.max(1)).max(1);
    (0..sphere.len())
        .step_by(step)
        .map(|v| (sphere[v], normalised[v]))
        .collect()
}

/// Distances between A's samples and B's surface at `rotation`ᵀ of their sphere points.
pub(crate) fn residual(samples: &[(DVec3, DVec3)], b: &SurfaceLookup, rotation: DMat3) -> Residual {
    let inverse = rotation.transpose();
    let mut out = Residual::default();
    for &(s, q) in samples {
        let dist = (q - b.at(inverse * s)).length();
        out.mean += dist;
        out.max = out.max.max(dist);
    }
    out.mean /= samples.len().max(1) as f64;
    out
}

fn cost(samples: &[(DVec3, DVec3)], b: &SurfaceLookup, rotation: DMat3) -> f64 {
    residual(samples, b, rotation).mean
}

/// The 24 proper rotations of the cube, each composed with 0°, 40° and 80°
/// about z, so the coarse set has a rotation within some 40° of any other.
fn candidates() -> Vec<DMat3> {
    let mut out = Vec::new();
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for perm in perms {
        for signs in 0..8 {
            let mut cols = [DVec3::ZERO; 3];
            for (k, &p) in perm.iter().enumerate() {
                let s = if signs >> k & 1 == 1 { -1.0 } else { 1.0 };
                let mut e = DVec3::ZERO;
                e[p] = s;
                cols[k] = e;
            }
            let m = DMat3::from_cols(cols[0], cols[1], cols[2]);
            if m.determinant() > 0.0 {
                for turn in [0.0f64, 40.0, 80.0] {
                    out.push(DMat3::from_rotation_z(turn.to_radians()) * m);
                }
            }
        }
    }
    out
}

/// The rotation of B's sphere that best matches the shapes (see module docs).
pub(crate) fn search_rotation(samples: &[(DVec3, DVec3)], b: &SurfaceLookup) -> DMat3 {
    let mut scored: Vec<(f64, DMat3)> = candidates()
        .into_iter()
        .map(|r| (cost(samples, b, r), r))
        .collect();
    scored.sort_by(|x, y| x.0.total_cmp(&y.0));
    scored
        .into_iter()
        .take(4)
        .map(|(c, r)| descend(samples, b, r, c))
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, r)| r)
        .unwrap_or(DMat3::IDENTITY)
}

fn descend(
    samples: &[(DVec3, DVec3)],
    b: &SurfaceLookup,
    mut r: DMat3,
    mut c: f64,
) -> (f64, DMat3) {
    let mut angle = 20f64.to_radians();
    while angle > 0.25f64.to_radians() {
        let mut improved = false;
        for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
            for sign in [1.0, -1.0] {
                let trial = DMat3::from_axis_angle(axis, sign * angle) * r;
                let tc = cost(samples, b, trial);
                if tc < c {
                    (c, r) = (tc, trial);
                    improved = true;
                }
            }
        }
        if !improved {
            angle *= 0.5;
        }
    }
    (c, r)
}

/// Landmark residual: angles between each pair's sphere points (radians).
pub(crate) fn landmark_angles(a: &[DVec3], b: &[DVec3], pairs: &[(u32, u32)]) -> Residual {
    let mut out = Residual::default();
    for &(la, lb) in pairs {
        let angle = a[la as usize].angle_between(b[lb as usize]);
        out.mean += angle;
        out.max = out.max.max(angle);
    }
    out.mean /= pairs.len().max(1) as f64;
    out
}

/// Rings around each landmark that relax while it moves.
const NEIGHBOURHOOD: u32 = 4;

/// Pulls B's landmark vertices toward their A partners' sphere points (see
/// module docs). Every move keeps every triangle strictly positive.
pub(crate) fn pull_landmarks(
    rings: &[Vec<u32>],
    b: &mut [DVec3],
    a: &[DVec3],
    pairs: &[(u32, u32)],
    iterations: usize,
) {
    if pairs.is_empty() {
        return;
    }
    let mut pinned = vec![false; b.len()];
    for &(_, lb) in pairs {
        pinned[lb as usize] = true;
    }
    // Only the landmarks' neighbourhoods (a few rings) relax: a global
    // umbrella relaxation with a few pinned points drifts toward a cluster.
    let mut depth = vec![u32::MAX; b.len()];
    let mut queue: std::collections::VecDeque<u32> = pairs.iter().map(|p| p.1).collect();
    for &v in &queue {
        depth[v as usize] = 0;
    }
    while let Some(v) = queue.pop_front() {
        if depth[v as usize] >= NEIGHBOURHOOD {
            continue;
        }
        for &n in &rings[v as usize] {
            if depth[n as usize] == u32::MAX {
                depth[n as usize] = depth[v as usize] + 1;
                queue.push_back(n);
            }
        }
    }
    let free: Vec<u32> = (0..b.len() as u32)
        .filter(|&v| !pinned[v as usize] && depth[v as usize] != u32::MAX)
        .collect();
    let max_step = 0.1;
    for _ in 0..iterations {
        let mut remaining = 0.0f64;
        for &(la, lb) in pairs {
            let goal = a[la as usize];
            let at = b[lb as usize];
            let angle = at.angle_between(goal);
            remaining = remaining.max(angle);
            if angle < 1e-9 {
                continue;
            }
            let s = (max_step / angle).min(1.0);
            let target = slerp(at, goal, s);
            relax_vertex(rings, b, lb, Some(target));
        }
        if remaining < 1e-6 {
            break;
        }
        for &v in &free {
            relax_vertex(rings, b, v, None);
        }
    }
}

fn slerp(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    let (a, b) = (a.normalize(), b.normalize());
    let angle = a.angle_between(b);
    if angle < 1e-12 {
        return b;
    }
    let s = angle.sin();
    if s.abs() < 1e-12 {
        // Antipodal: any great circle will do; go through a perpendicular.
        let perp = a.any_orthonormal_vector();
        return (a * (t * std::f64::consts::PI).cos() + perp * (t * std::f64::consts::PI).sin())
            .normalize();
    }
    (a * ((1.0 - t) * angle).sin() / s + b * (t * angle).sin() / s).normalize()
}

/// Rotates sphere points; `false` when rounding folded a triangle (the
/// points are then left rotated: the caller retries or gives up).
pub(crate) fn rotate(points: &mut [DVec3], triangles: &[[u32; 3]], rotation: DMat3) -> bool {
    for p in points.iter_mut() {
        *p = rotation * *p;
    }
    triangles.iter().all(|t| {
        let [a, b, c] = t.map(|v| points[v as usize]);
        orient(a, b, c) > 0.0
    })
}

/// A rotation by a random angle in `[min, 2 min)` about a random axis (seeded).
pub(crate) fn random_rotation(seed: u64, min_angle: f64) -> DMat3 {
    use super::sphere::next_unit;
    let mut state = seed ^ 0xa076_1d64_78bd_642f;
    let z = 2.0 * next_unit(&mut state) - 1.0;
    let phi = std::f64::consts::TAU * next_unit(&mut state);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let axis = DVec3::new(r * phi.cos(), r * phi.sin(), z);
    let angle = min_angle * (1.0 + next_unit(&mut state));
    DMat3::from_axis_angle(axis.normalize_or(DVec3::Z), angle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_are_rotations() {
        let c = candidates();
        assert_eq!(c.len(), 72);
        for m in c {
            assert!((m.determinant() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn principal_axes_of_diagonal_sorted() {
        let axes = principal_axes([[1.0, 0.0, 0.0], [0.0, 5.0, 0.0], [0.0, 0.0, 3.0]]);
        assert!((axes[0].y.abs() - 1.0).abs() < 1e-12);
        assert!((axes[1].z.abs() - 1.0).abs() < 1e-12);
        assert!((axes[2].x.abs() - 1.0).abs() < 1e-12);
    }
}
