//! Aligning B's sphere embedding with A's, so that equal sphere points carry
//! similar parts of the two shapes (issue 25).
//!
//! 1. Möbius normalisation of both embeddings ([`super::mobius::centre`]):
//!    each surface's area centroid, carried to its sphere, goes to the
//!    sphere's centre, so the two differ by about a rotation;
//! 2. [`Frame`]: both shapes centred and scaled to unit RMS radius, as the
//!    correspondence measure does ([`super::measure`]);
//! 3. without landmarks, [`search_rotation`]: the rotation `R` of B's sphere
//!    that minimises the measure's objective `D = Σ w ‖q_A − q_B‖²` over A's
//!    area-weighted vertex samples and B's normalised surface at the same
//!    sphere point. Candidates: the first-order guesses [`moment_candidates`]
//!    (each embedding's best rotation from sphere to shape, composed with the
//!    24 rotations of the cube), and the 24 rotations of the cube each also
//!    turned by 0°, 40° and 80° about z; then a local descent with halving
//!    angles (20° down to 0.1°) from the best six;
//! 4. with landmarks, the least-squares Möbius map of B's landmark sphere
//!    points onto A's ([`super::mobius::Mobius::fit`], exact for three), then
//!    [`pull_landmarks`]: each B landmark walks the rest of the way onto its
//!    A partner, dragging a cap of its neighbours along by fold-rejecting
//!    moves, and lands on exactly its partner's point.
//!
//! B's surface at a sphere point is read from a cube map of its projective
//! barycentric interpolation ([`SurfaceLookup`]), so one candidate costs one
//! table read per sample.

use glam::{DMat3, DVec3};

use super::sphere::{orient, projective_barycentric, Location, SphereMesh};

/// Mean and largest distance between corresponding points.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Residual {
    pub mean: f64,
    pub max: f64,
}

/// A shape's normalisation, as in the correspondence measure
/// ([`super::measure`]): `q = (p − centroid) / scale`, centred on its
/// area-weighted centroid and scaled to unit RMS radius, not rotated (D
/// counts orientation as placed).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    centroid: DVec3,
    scale: f64,
}

fn d(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

impl Frame {
    /// From each vertex's surface area `mass` (a third of its triangles').
    pub fn new(positions: &[[f32; 3]], mass: &[f64]) -> Frame {
        let total: f64 = mass.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return Frame {
                centroid: DVec3::ZERO,
                scale: 1.0,
            };
        }
        let centroid = positions
            .iter()
            .zip(mass)
            .map(|(&p, &m)| d(p) * m)
            .sum::<DVec3>()
            / total;
        let sq: f64 = positions
            .iter()
            .zip(mass)
            .map(|(&p, &m)| m * (d(p) - centroid).length_squared())
            .sum::<f64>()
            / total;
        let scale = if sq > 0.0 { sq.sqrt() } else { 1.0 };
        Frame { centroid, scale }
    }

    pub fn apply(&self, p: [f32; 3]) -> DVec3 {
        (d(p) - self.centroid) / self.scale
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

/// One sample of A: sphere point, normalised position, weight (its share
/// of the surface, the samples' summing to 1).
pub(crate) type Sample = (DVec3, DVec3, f64);

/// Up to `max` samples of A (every k-th vertex), weighted by surface area.
pub(crate) fn samples(
    sphere: &[DVec3],
    normalised: &[DVec3],
    mass: &[f64],
    max: usize,
) -> Vec<Sample> {
    let step = sphere.len().div_ceil(max.max(1)).max(1);
    let mut out: Vec<Sample> = (0..sphere.len())
        .step_by(step)
        .map(|v| (sphere[v], normalised[v], mass[v]))
        .collect();
    let total: f64 = out.iter().map(|s| s.2).sum();
    for s in &mut out {
        s.2 = if total > 0.0 {
            s.2 / total
        } else {
            1.0 / step as f64
        };
    }
    out
}

/// Distances between A's samples and B's surface at `rotation`ᵀ of their sphere points.
pub(crate) fn residual(samples: &[Sample], b: &SurfaceLookup, rotation: DMat3) -> Residual {
    let inverse = rotation.transpose();
    let mut out = Residual::default();
    for &(s, q, _) in samples {
        let dist = (q - b.at(inverse * s)).length();
        out.mean += dist;
        out.max = out.max.max(dist);
    }
    out.mean /= samples.len().max(1) as f64;
    out
}

/// The correspondence objective `D = Σ w ‖q_A − q_B‖²` over A's samples
/// (see [`super::measure`]), B read at `back(x)` for each sample's point `x`.
pub(crate) fn cost_by(samples: &[Sample], b: &SurfaceLookup, back: impl Fn(DVec3) -> DVec3) -> f64 {
    samples
        .iter()
        .map(|&(s, q, w)| w * (q - b.at(back(s))).length_squared())
        .sum()
}

/// `D` both ways, halved: A's samples against B's surface at `back(x)` for
/// each sample's point `x`, and B's samples against A's surface at
/// `forth(y)`, A's normalised shape turned by `turn` (the identity unless B
/// is placed differently). One-way, a map that squeezes part of B away
/// (a Möbius map through badly paired points) goes unseen.
pub(crate) fn two_way_cost(
    (a_samples, a): (&[Sample], &SurfaceLookup),
    (b_samples, b): (&[Sample], &SurfaceLookup),
    turn: DMat3,
    back: &dyn Fn(DVec3) -> DVec3,
    forth: &dyn Fn(DVec3) -> DVec3,
) -> f64 {
    let ab: f64 = a_samples
        .iter()
        .map(|&(s, q, w)| w * (turn * q - b.at(back(s))).length_squared())
        .sum();
    let ba: f64 = b_samples
        .iter()
        .map(|&(s, q, w)| w * (q - turn * a.at(forth(s))).length_squared())
        .sum();
    0.5 * (ab + ba)
}

/// [`cost_by`] with B's sphere turned by `rotation`; `turned`: with A's
/// normalised samples first turned by [`shape_turn`] (D as it would be
/// after fitting B onto A, blind to how B is placed).
pub(crate) fn cost(samples: &[Sample], b: &SurfaceLookup, rotation: DMat3, turned: bool) -> f64 {
    let inverse = rotation.transpose();
    if !turned {
        return cost_by(samples, b, |x| inverse * x);
    }
    let turn = shape_turn(samples, b, rotation);
    samples
        .iter()
        .map(|&(s, q, w)| w * (b.at(inverse * s) - turn * q).length_squared())
        .sum()
}

/// The rotation that best takes A's normalised samples onto B's surface at
/// the same sphere points (B's sphere turned by `rotation`; Kabsch).
pub(crate) fn shape_turn(samples: &[Sample], b: &SurfaceLookup, rotation: DMat3) -> DMat3 {
    let inverse = rotation.transpose();
    nearest_rotation(correlation(
        samples.iter().map(|&(s, q, w)| (b.at(inverse * s) * w, q)),
    ))
}

/// The 24 proper rotations of the cube (signed axis permutations).
fn cube_rotations() -> Vec<DMat3> {
    candidates().into_iter().step_by(3).collect()
}

/// The rotation nearest to `m` (the orthogonal factor of its polar
/// decomposition, with the reflection removed: Kabsch), from the
/// eigenvectors of `mᵀm`; the identity when `m` has rank below 2.
pub(crate) fn nearest_rotation(m: DMat3) -> DMat3 {
    let s = m.transpose() * m;
    let cols = [
        s.x_axis.to_array(),
        s.y_axis.to_array(),
        s.z_axis.to_array(),
    ];
    let rows = [0, 1, 2].map(|r| [0, 1, 2].map(|c| cols[c][r]));
    let v = principal_axes(rows);
    let sigma = v.map(|x| (x.dot(s * x)).max(0.0).sqrt());
    if sigma[1].partial_cmp(&(1e-12 * sigma[0].max(1e-300))) != Some(std::cmp::Ordering::Greater) {
        return DMat3::IDENTITY;
    }
    let u0 = (m * v[0] / sigma[0]).normalize();
    let u1 = (m * v[1] / sigma[1]).normalize();
    let u1 = (u1 - u0 * u0.dot(u1)).normalize();
    let u2 = u0.cross(u1);
    let v2 = v[0].cross(v[1]);
    let u = DMat3::from_cols(u0, u1, u2);
    let w = DMat3::from_cols(v[0], v[1], v2);
    u * w.transpose()
}

/// `Σ x yᵀ` over pairs.
fn correlation(pairs: impl Iterator<Item = (DVec3, DVec3)>) -> DMat3 {
    let mut m = DMat3::ZERO;
    for (x, y) in pairs {
        m += DMat3::from_cols(x * y.x, x * y.y, x * y.z);
    }
    m
}

/// First-order guesses: each shape's best rotation from sphere to shape
/// (`U`, nearest to `Σ q sᵀ`), so `R = U_Aᵀ C U_B` for each rotation `C` of
/// the cube (the principal axes' order and signs may differ).
pub(crate) fn moment_candidates(a: &[Sample], b: &[Sample]) -> Vec<DMat3> {
    let ua = nearest_rotation(correlation(a.iter().map(|&(s, q, w)| (q * w, s))));
    let ub = nearest_rotation(correlation(b.iter().map(|&(s, q, w)| (q * w, s))));
    cube_rotations()
        .into_iter()
        .map(|c| ua.transpose() * c * ub)
        .collect()
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
/// `turned`: scored by D after the best turn of A's shape ([`cost`]).
pub(crate) fn search_rotation(
    samples: &[Sample],
    b: &SurfaceLookup,
    extra: &[DMat3],
    turned: bool,
) -> DMat3 {
    let mut scored: Vec<(f64, DMat3)> = candidates()
        .into_iter()
        .chain(extra.iter().copied())
        .map(|r| (cost(samples, b, r, turned), r))
        .collect();
    scored.sort_by(|x, y| x.0.total_cmp(&y.0));
    scored
        .into_iter()
        .take(6)
        .map(|(c, r)| descend(samples, b, r, c, turned))
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, r)| r)
        .unwrap_or(DMat3::IDENTITY)
}

fn descend(
    samples: &[Sample],
    b: &SurfaceLookup,
    mut r: DMat3,
    mut c: f64,
    turned: bool,
) -> (f64, DMat3) {
    let mut angle = 20f64.to_radians();
    while angle > 0.1f64.to_radians() {
        let mut improved = false;
        for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
            for sign in [1.0, -1.0] {
                let trial = DMat3::from_axis_angle(axis, sign * angle) * r;
                let tc = cost(samples, b, trial, turned);
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

/// Largest angle (radians) a landmark moves in one iteration.
const LANDMARK_STEP: f64 = 0.04;

/// Pulls B's landmark vertices onto their A partners' sphere points: each
/// iteration turns a cap around each landmark toward its goal by a smooth
/// field (the landmark by up to [`LANDMARK_STEP`], its neighbours less and
/// less out to the cap's rim, front first), every vertex by a fold-rejecting
/// move, then relaxes the cap (area-proportional, landmarks pinned). The cap
/// (the landmark's two rings and whatever lies within 0.8 of the way to the
/// nearest other landmark) fades to nothing at the other landmarks, which
/// stay put: two near pairs moved in turn would otherwise drag each other
/// back and forth without ever closing. When the straight way is blocked the
/// landmark veers off by up to ±1.2 rad.
pub(crate) fn pull_landmarks(
    mass: &[f64],
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
    let mut mark = vec![u32::MAX; b.len()];
    let mut stamp = 0u32;
    let mut cap: Vec<u32> = Vec::new();
    let mut free: Vec<u32> = Vec::new();
    for _ in 0..iterations {
        let mut remaining = false;
        for (k, &(la, lb)) in pairs.iter().enumerate() {
            // The partner's point itself, so the pair ends on one point exactly.
            let target = a[la as usize];
            if b[lb as usize] == target {
                continue;
            }
            remaining = true;
            let goal = target.normalize();
            let at = b[lb as usize].normalize();
            let angle = at.angle_between(goal);
            if angle <= LANDMARK_STEP && super::embed::move_vertex(rings, b, lb, target) {
                continue;
            }
            let step = angle.min(LANDMARK_STEP);
            let toward = (goal - at * at.dot(goal))
                .try_normalize()
                .unwrap_or_else(|| at.any_orthonormal_vector());
            let nearest = pairs
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != k)
                .map(|(_, p)| at.angle_between(b[p.1 as usize]))
                .fold(f64::INFINITY, f64::min);
            let radius = (2.0 * angle).clamp(0.3, 1.2).min(0.8 * nearest);
            let others: Vec<DVec3> = pairs
                .iter()
                .enumerate()
                .filter(|&(j, p)| j != k && p.1 != lb)
                .map(|(_, p)| b[p.1 as usize])
                .collect();
            // The cap: the landmark's two rings and the vertices within
            // `radius` of it, by a walk.
            stamp += 1;
            cap.clear();
            mark[lb as usize] = stamp;
            let mut depth = vec![(lb, 0u32)];
            while let Some((v, level)) = depth.pop() {
                cap.push(v);
                for &n in &rings[v as usize] {
                    if mark[n as usize] != stamp
                        && (level < 2 || at.angle_between(b[n as usize]) < radius)
                    {
                        mark[n as usize] = stamp;
                        depth.push((n, level + 1));
                    }
                }
            }
            let radius = cap
                .iter()
                .map(|&v| 1.05 * at.angle_between(b[v as usize]))
                .fold(radius, f64::max);
            // Straight toward the goal, or when something is in the way
            // (another landmark, a fan that would fold), veering off.
            for detour in [0.0f64, 0.6, -0.6, 1.2, -1.2] {
                let direction = toward * detour.cos() + at.cross(toward) * detour.sin();
                let axis = at.cross(direction).normalize();
                cap.sort_by(|&x, &y| {
                    direction
                        .dot(b[y as usize])
                        .total_cmp(&direction.dot(b[x as usize]))
                });
                for &v in &cap {
                    let r = at.angle_between(b[v as usize]) / radius;
                    // Flat in the middle so the landmark's fan moves with it.
                    let falloff = if r < 0.4 {
                        1.0
                    } else {
                        let x = ((r - 0.4) / 0.6).min(1.0);
                        1.0 - x * x * (3.0 - 2.0 * x)
                    };
                    // Other landmarks stay where they are, and the field fades
                    // toward them, so two near pairs do not pull each other
                    // back and forth.
                    let other = others
                        .iter()
                        .map(|&o| b[v as usize].angle_between(o))
                        .fold(f64::INFINITY, f64::min);
                    let x = (other / (0.5 * nearest)).min(1.0);
                    let falloff = falloff * x * x * (3.0 - 2.0 * x);
                    let turn = DMat3::from_axis_angle(axis, step * falloff);
                    super::embed::move_vertex(rings, b, v, turn * b[v as usize]);
                }
                if b[lb as usize].normalize().angle_between(at) > 0.25 * step {
                    break;
                }
            }
            free.clear();
            free.extend(cap.iter().copied().filter(|&v| !pinned[v as usize]));
            super::embed::relax(mass, rings, b, &free, 2);
        }
        if !remaining {
            break;
        }
    }
}

/// The other shape's normalised surface at sphere points, located by walks
/// from the last face found for each vertex.
pub(crate) struct Surface<'a> {
    mesh: SphereMesh<'a>,
    normalised: &'a [DVec3],
}

impl<'a> Surface<'a> {
    pub fn new(points: &'a [DVec3], triangles: &'a [[u32; 3]], normalised: &'a [DVec3]) -> Self {
        Surface {
            mesh: SphereMesh::new(points, triangles),
            normalised,
        }
    }

    pub fn at(&self, p: DVec3, hint: &mut u32, rng: &mut u64) -> DVec3 {
        *hint = match self.mesh.locate(p, *hint, rng) {
            Location::Inside(f) | Location::Degenerate(f) => f,
        };
        let t = self.mesh.triangles[*hint as usize];
        let [a, b, c] = t.map(|v| self.mesh.points[v as usize]);
        let l = projective_barycentric(p, a, b, c);
        let q = t.map(|v| self.normalised[v as usize]);
        q[0] * l[0] + q[1] * l[1] + q[2] * l[2]
    }
}

/// Lowers each free vertex's term of D, `‖q_v − other(x_v)‖²` (its
/// normalised position against the other shape's surface at its sphere
/// point): each vertex tries steps of a third of the way to
/// its nearest neighbour in four directions and takes the one that lowers its
/// term most, by a fold-rejecting move (so the embedding stays bijective and
/// pinned vertices stay where they are). `hints`: each vertex's last face
/// of `other` (`u32::MAX`: none yet, start from the previous vertex's), kept
/// between calls so that each lookup is a short walk.
pub(crate) fn refine(
    points: &mut [DVec3],
    rings: &[Vec<u32>],
    normalised: &[DVec3],
    other: &Surface,
    pinned: &[bool],
    hints: &mut [u32],
) {
    let mut rng = 0x5eed_u64;
    let mut last = 0u32;
    for v in 0..points.len() {
        if pinned[v] || rings[v].is_empty() {
            continue;
        }
        if hints[v] == u32::MAX {
            hints[v] = last;
        }
        let x = points[v].normalize();
        let step = rings[v]
            .iter()
            .map(|&r| x.angle_between(points[r as usize]))
            .fold(f64::INFINITY, f64::min)
            / 3.0;
        let mut term =
            |p: DVec3| (normalised[v] - other.at(p, &mut hints[v], &mut rng)).length_squared();
        let current = term(points[v]);
        let e1 = x.any_orthonormal_vector();
        let e2 = x.cross(e1);
        let mut best = (current, x);
        for dir in [e1, -e1, e2, -e2] {
            let trial = (x + dir * step).normalize();
            let t = term(trial);
            if t < best.0 {
                best = (t, trial);
            }
        }
        if best.0 < current {
            super::embed::move_vertex(rings, points, v as u32, best.1);
        }
        last = hints[v];
    }
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
    use crate::random::next_unit;
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
    fn nearest_rotation_recovers_a_rotation() {
        let r = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 2.0);
        let n = nearest_rotation(r * DMat3::from_diagonal(DVec3::new(3.0, 2.0, 0.5)));
        assert!(
            (n - r).abs_diff_eq(DMat3::ZERO, 1e-9) || n.abs_diff_eq(r, 1e-9),
            "{n} {r}"
        );
        assert_eq!(cube_rotations().len(), 24);
    }

    #[test]
    fn principal_axes_of_diagonal_sorted() {
        let axes = principal_axes([[1.0, 0.0, 0.0], [0.0, 5.0, 0.0], [0.0, 0.0, 3.0]]);
        assert!((axes[0].y.abs() - 1.0).abs() < 1e-12);
        assert!((axes[1].z.abs() - 1.0).abs() < 1e-12);
        assert!((axes[2].x.abs() - 1.0).abs() < 1e-12);
    }
}
