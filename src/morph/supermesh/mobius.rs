//! Möbius transformations of the sphere (orientation-preserving conformal
//! maps: rotations and "boosts", six real degrees of freedom), used to move
//! one spherical embedding over the other without folding it:
//!
//! * [`centre`]: Möbius normalisation (Baden, Crane & Kazhdan, "Möbius
//!   Registration", SGP 2018): the hyperbolic translation that takes the
//!   centroid of the surface's area, carried to the sphere, to the sphere's
//!   centre, so two embeddings of similar shapes differ by about a rotation;
//! * [`Mobius::fit`]: the least-squares Möbius map of landmark pairs (exact
//!   for three pairs, as three points fix a Möbius map);
//! * [`Mobius::power`]: the fraction `Mˢ` of a map, `s ∈ [0, 1]`;
//! * [`warp`]: moves a mesh's sphere points toward their images under a map
//!   by fold-rejecting moves (the great arcs between mapped vertices only
//!   approximate the mapped circular arcs, so a coarse triangle could fold).
//!
//! A sphere point is the complex line `[w₁ : w₂]` of its stereographic
//! coordinate `ζ = (x + iy)/(1 − z) = (1 + z)/(x − iy)`; a map is a 2×2
//! complex matrix of determinant 1 acting on it.

use glam::DVec3;

use super::sphere::orient;

/// A complex number (only what the maps need).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct C {
    re: f64,
    im: f64,
}

impl C {
    const ZERO: C = C { re: 0.0, im: 0.0 };
    const ONE: C = C { re: 1.0, im: 0.0 };

    fn new(re: f64, im: f64) -> C {
        C { re, im }
    }
    fn conj(self) -> C {
        C::new(self.re, -self.im)
    }
    fn norm2(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    fn scale(self, s: f64) -> C {
        C::new(self.re * s, self.im * s)
    }
    fn inv(self) -> C {
        self.conj().scale(1.0 / self.norm2())
    }
    fn exp(self) -> C {
        let m = self.re.exp();
        C::new(m * self.im.cos(), m * self.im.sin())
    }
    fn ln(self) -> C {
        C::new(0.5 * self.norm2().ln(), self.im.atan2(self.re))
    }
    fn sqrt(self) -> C {
        (self.ln().scale(0.5)).exp()
    }
}

impl std::ops::Add for C {
    type Output = C;
    fn add(self, o: C) -> C {
        C::new(self.re + o.re, self.im + o.im)
    }
}

impl std::ops::Sub for C {
    type Output = C;
    fn sub(self, o: C) -> C {
        C::new(self.re - o.re, self.im - o.im)
    }
}

impl std::ops::Mul for C {
    type Output = C;
    fn mul(self, o: C) -> C {
        C::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}

impl std::ops::Div for C {
    type Output = C;
    fn div(self, o: C) -> C {
        let n = o.norm2();
        C::new(
            (self.re * o.re + self.im * o.im) / n,
            (self.im * o.re - self.re * o.im) / n,
        )
    }
}

/// Homogeneous stereographic coordinates of a sphere direction (the better
/// conditioned of the two equal forms).
fn lift(p: DVec3) -> [C; 2] {
    let p = p.normalize();
    if p.z <= 0.0 {
        [C::new(p.x, p.y), C::new(1.0 - p.z, 0.0)]
    } else {
        [C::new(1.0 + p.z, 0.0), C::new(p.x, -p.y)]
    }
}

/// The sphere point of `[w₁ : w₂]`.
fn project(w: [C; 2]) -> DVec3 {
    let (n1, n2) = (w[0].norm2(), w[1].norm2());
    let m = w[0] * w[1].conj();
    DVec3::new(2.0 * m.re, 2.0 * m.im, n1 - n2) / (n1 + n2)
}

/// A Möbius map of the sphere: `[w₁ : w₂] → [a w₁ + b w₂ : c w₁ + d w₂]`,
/// `ad − bc = 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Mobius {
    m: [[C; 2]; 2],
}

impl Mobius {
    pub const IDENTITY: Mobius = Mobius {
        m: [[C::ONE, C::ZERO], [C::ZERO, C::ONE]],
    };

    /// `m` scaled to determinant 1; `None` when singular.
    fn normalised(m: [[C; 2]; 2]) -> Option<Mobius> {
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        let size = det.norm2();
        if size.is_nan() || size <= 1e-300 || !size.is_finite() {
            return None;
        }
        let s = det.sqrt().inv();
        let m = m.map(|row| row.map(|x| x * s));
        m.iter()
            .flatten()
            .all(|x| x.re.is_finite() && x.im.is_finite())
            .then_some(Mobius { m })
    }

    pub fn apply(&self, p: DVec3) -> DVec3 {
        let w = lift(p);
        let m = &self.m;
        project([
            m[0][0] * w[0] + m[0][1] * w[1],
            m[1][0] * w[0] + m[1][1] * w[1],
        ])
    }

    /// `self ∘ other`.
    fn then_after(&self, other: &Mobius) -> Mobius {
        let (a, b) = (&self.m, &other.m);
        let mut m = [[C::ZERO; 2]; 2];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x = a[r][0] * b[0][c] + a[r][1] * b[1][c];
            }
        }
        Mobius { m }
    }

    /// The largest factor by which the map stretches lengths on the sphere
    /// (`σ₁²` of the unit-determinant matrix; the smallest is its inverse).
    pub fn stretch(&self) -> f64 {
        let f: f64 = self.m.iter().flatten().map(|x| x.norm2()).sum();
        0.5 * (f + (f * f - 4.0).max(0.0).sqrt())
    }

    pub fn inverse(&self) -> Mobius {
        let m = &self.m;
        Mobius {
            m: [[m[1][1], C::ZERO - m[0][1]], [C::ZERO - m[1][0], m[0][0]]],
        }
    }

    /// The map taking the distinct points `z` to `0, 1, ∞`.
    fn to_standard(z: [DVec3; 3]) -> Option<Mobius> {
        let [u, v, w] = z.map(lift);
        // [x, y] = x₁ y₂ − x₂ y₁: ζ → [ζ, u][v, w] / ([ζ, w][v, u]).
        let bracket = |x: [C; 2], y: [C; 2]| x[0] * y[1] - x[1] * y[0];
        let (k1, k2) = (bracket(v, w), bracket(v, u));
        Mobius::normalised([
            [k1 * u[1], C::ZERO - k1 * u[0]],
            [k2 * w[1], C::ZERO - k2 * w[0]],
        ])
    }

    /// The map taking `from[k]` to `to[k]` for three distinct points each.
    pub fn through_three(from: [DVec3; 3], to: [DVec3; 3]) -> Option<Mobius> {
        let f = Mobius::to_standard(from)?;
        let t = Mobius::to_standard(to)?;
        Some(t.inverse().then_after(&f))
    }

    /// `exp(Σ xₖ Eₖ)` (approximated to second order, then normalised) for
    /// the basis `Eₖ` of sl(2, ℂ): a small change of a map.
    pub(crate) fn small(x: [f64; 6]) -> Mobius {
        let a = C::new(x[0], x[1]);
        let b = C::new(x[2], x[3]);
        let c = C::new(x[4], x[5]);
        let g = [[a, b], [c, C::ZERO - a]];
        // I + G + G²/2, with G² = (a² + bc) I.
        let h = (a * a + b * c).scale(0.5);
        let m = [
            [C::ONE + g[0][0] + h, g[0][1]],
            [g[1][0], C::ONE + g[1][1] + h],
        ];
        Mobius::normalised(m).unwrap_or(Mobius::IDENTITY)
    }

    /// `Mˢ` along the one-parameter group through the identity and `M`
    /// (`s ∈ [0, 1]`), by Sylvester's formula on the eigenvalues; the sign
    /// of the matrix is chosen (it is free in PSL(2, ℂ)) for the shorter way.
    pub fn power(&self, s: f64) -> Mobius {
        let mut m = self.m;
        let tr = m[0][0] + m[1][1];
        if tr.re < 0.0 {
            m = m.map(|row| row.map(|x| C::ZERO - x));
        }
        let tr = m[0][0] + m[1][1];
        let disc = (tr * tr - C::new(4.0, 0.0)).sqrt();
        let l1 = (tr + disc).scale(0.5);
        let l2 = (tr - disc).scale(0.5);
        let gap = l1 - l2;
        let out = if gap.norm2() < 1e-18 {
            // Parabolic (or the identity): M = I + N with N² = 0, Mˢ = I + sN.
            [
                [C::ONE + (m[0][0] - C::ONE).scale(s), m[0][1].scale(s)],
                [m[1][0].scale(s), C::ONE + (m[1][1] - C::ONE).scale(s)],
            ]
        } else {
            let p1 = (l1.ln().scale(s)).exp();
            let p2 = (l2.ln().scale(s)).exp();
            // Mˢ = (p1 (M − l2 I) − p2 (M − l1 I)) / (l1 − l2).
            let mut out = [[C::ZERO; 2]; 2];
            for r in 0..2 {
                for c in 0..2 {
                    let id = if r == c { C::ONE } else { C::ZERO };
                    out[r][c] = (p1 * (m[r][c] - l2 * id) - p2 * (m[r][c] - l1 * id)) / gap;
                }
            }
            out
        };
        Mobius::normalised(out).unwrap_or(Mobius::IDENTITY)
    }

    /// The least-squares map of `from[k]` onto `to[k]` (sum of squared chord
    /// distances), by Levenberg–Marquardt over sl(2, ℂ) from the exact map of
    /// the best-spread three pairs (a rotation for fewer pairs). Exact for
    /// three pairs.
    pub fn fit(from: &[DVec3], to: &[DVec3]) -> Mobius {
        let n = from.len().min(to.len());
        let (from, to) = (&from[..n], &to[..n]);
        let mut best = match n {
            0 => return Mobius::IDENTITY,
            1 | 2 => rotation_guess(from, to),
            _ => spread_triple(from)
                .and_then(|[i, j, k]| {
                    Mobius::through_three([from[i], from[j], from[k]], [to[i], to[j], to[k]])
                })
                .unwrap_or(Mobius::IDENTITY),
        };
        let cost = |m: &Mobius| -> f64 {
            from.iter()
                .zip(to)
                .map(|(&f, &t)| (m.apply(f) - t.normalize()).length_squared())
                .sum()
        };
        let mut c = cost(&best);
        let mut lambda = 1e-3;
        for _ in 0..100 {
            if c < 1e-28 {
                break;
            }
            // Residuals and a forward-difference Jacobian in sl(2, ℂ).
            let residual = |m: &Mobius| -> Vec<f64> {
                from.iter()
                    .zip(to)
                    .flat_map(|(&f, &t)| (m.apply(f) - t.normalize()).to_array())
                    .collect()
            };
            let r0 = residual(&best);
            let h = 1e-7;
            let mut jac = vec![[0.0f64; 6]; r0.len()];
            for k in 0..6 {
                let mut x = [0.0; 6];
                x[k] = h;
                let rk = residual(&Mobius::small(x).then_after(&best));
                for (row, (a, b)) in jac.iter_mut().zip(rk.iter().zip(&r0)) {
                    row[k] = (a - b) / h;
                }
            }
            let mut jtj = [[0.0f64; 6]; 6];
            let mut jtr = [0.0f64; 6];
            for (row, &r) in jac.iter().zip(&r0) {
                for a in 0..6 {
                    jtr[a] += row[a] * r;
                    for b in 0..6 {
                        jtj[a][b] += row[a] * row[b];
                    }
                }
            }
            let mut improved = false;
            for _ in 0..20 {
                let mut m = jtj;
                for (a, row) in m.iter_mut().enumerate() {
                    row[a] += lambda * (1.0 + jtj[a][a]);
                }
                let Some(step) = solve6(m, jtr.map(|x| -x)) else {
                    lambda *= 10.0;
                    continue;
                };
                let trial = Mobius::small(step).then_after(&best);
                let tc = cost(&trial);
                if tc < c {
                    (best, c) = (trial, tc);
                    lambda = (lambda * 0.3).max(1e-12);
                    improved = true;
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        best
    }
}

/// A local descent of `cost` over Möbius maps from `start`: steps of
/// `±step` along each of the six directions of sl(2, ℂ) ([`Mobius::small`],
/// three turns and three boosts), the step halved when none lowers the
/// cost, down to `step / 32`. Returns the lowest cost and its map.
pub(crate) fn descend(start: Mobius, step: f64, cost: impl Fn(&Mobius) -> f64) -> (f64, Mobius) {
    let (mut best, mut c) = (start, cost(&start));
    let mut h = step;
    while h > step / 32.0 {
        let mut improved = false;
        for k in 0..6 {
            for sign in [1.0, -1.0] {
                let mut x = [0.0; 6];
                x[k] = sign * h;
                let trial = Mobius::small(x).then_after(&best);
                let tc = cost(&trial);
                if tc < c {
                    (best, c) = (trial, tc);
                    improved = true;
                }
            }
        }
        if !improved {
            h *= 0.5;
        }
    }
    (c, best)
}

/// The rotation (as a Möbius map) that best takes `from` to `to` for one or
/// two pairs: the shortest arc of the first, then a turn about it for the second.
fn rotation_guess(from: &[DVec3], to: &[DVec3]) -> Mobius {
    let (f0, t0) = (from[0].normalize(), to[0].normalize());
    let mut r = glam::DQuat::from_rotation_arc(f0, t0);
    if from.len() > 1 {
        // Turn about t0 so the second pair's directions around t0 agree.
        let f1 = r * from[1].normalize();
        let t1 = to[1].normalize();
        let (a, b) = (f1 - t0 * t0.dot(f1), t1 - t0 * t0.dot(t1));
        if a.length() > 1e-9 && b.length() > 1e-9 {
            r = glam::DQuat::from_rotation_arc(a.normalize(), b.normalize()) * r;
        }
    }
    // The rotation as the map taking three frame points.
    let frame = [DVec3::X, DVec3::Y, DVec3::Z];
    Mobius::through_three(frame, frame.map(|p| r * p)).unwrap_or(Mobius::IDENTITY)
}

/// The three points spanning the largest triangle (among the first 24).
fn spread_triple(points: &[DVec3]) -> Option<[usize; 3]> {
    let n = points.len().min(24);
    let mut best = (0.0, None);
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let (a, b, c) = (points[i], points[j], points[k]);
                let area = (b - a).cross(c - a).length();
                if area > best.0 {
                    best = (area, Some([i, j, k]));
                }
            }
        }
    }
    best.1
}

/// Solves a 6×6 system by Gaussian elimination with partial pivoting.
#[allow(clippy::needless_range_loop)] // elimination reads clearer with indices.
fn solve6(mut m: [[f64; 6]; 6], mut b: [f64; 6]) -> Option<[f64; 6]> {
    for col in 0..6 {
        let pivot = (col..6).max_by(|&x, &y| m[x][col].abs().total_cmp(&m[y][col].abs()))?;
        if m[pivot][col].abs() < 1e-300 {
            return None;
        }
        m.swap(col, pivot);
        b.swap(col, pivot);
        for r in col + 1..6 {
            let f = m[r][col] / m[col][col];
            for c in col..6 {
                m[r][c] -= f * m[col][c];
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0; 6];
    for r in (0..6).rev() {
        let s: f64 = (r + 1..6).map(|c| m[r][c] * x[c]).sum();
        x[r] = (b[r] - s) / m[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

fn all_positive(points: &[DVec3], triangles: &[[u32; 3]]) -> bool {
    triangles.iter().all(|t| {
        let [a, b, c] = t.map(|v| points[v as usize]);
        orient(a, b, c) > 0.0
    })
}

/// Repair sweeps of [`move_all`] at most.
const REPAIR_SWEEPS: usize = 16;

/// The corners of the triangles not strictly positive (exact), each once.
fn folded_corners(points: &[DVec3], triangles: &[[u32; 3]], mark: &mut [bool]) -> Vec<u32> {
    let mut out = Vec::new();
    for t in triangles {
        let [a, b, c] = t.map(|v| points[v as usize]);
        if orient(a, b, c) <= 0.0 {
            for &v in t {
                if !mark[v as usize] {
                    mark[v as usize] = true;
                    out.push(v);
                }
            }
        }
    }
    for &v in &out {
        mark[v as usize] = false;
    }
    out
}

/// Moves every vertex to `targets` at once, then repairs what folded, or
/// leaves `points` as they were and returns `false`.
///
/// All at once, because a smooth map carries each fan along with its vertex:
/// one vertex at a time, a vertex whose fan is smaller than its move folds
/// the fan against its not yet moved neighbours and is rejected, and so is
/// every neighbour after it (a limb's squeezed cap, 1e-9 sr triangles on
/// man.off, stayed put whole: 7,016 of the camel's 9,770 vertices missed
/// their image under the landmarks' Möbius fit). What can fold is a thin
/// triangle whose third corner lies near the great circle of the other two,
/// as a Möbius map takes great circles to small ones: its corners get
/// fold-rejecting moves toward their neighbours' mean or into their fan's
/// kernel ([`super::embed::relax_vertex`]) for up to [`REPAIR_SWEEPS`]
/// sweeps.
pub(crate) fn move_all(
    rings: &[Vec<u32>],
    triangles: &[[u32; 3]],
    points: &mut [DVec3],
    targets: &[DVec3],
) -> bool {
    let old = points.to_vec();
    points.copy_from_slice(targets);
    let mut mark = vec![false; points.len()];
    for _ in 0..REPAIR_SWEEPS {
        let bad = folded_corners(points, triangles, &mut mark);
        if bad.is_empty() {
            return true;
        }
        for v in bad {
            super::embed::relax_vertex(rings, points, v, None);
        }
    }
    if all_positive(points, triangles) {
        return true;
    }
    points.copy_from_slice(&old);
    false
}

/// Moves every vertex to its image under `map` along the path `Mᵏᐟⁿ`
/// (`n = steps`): each step all at once ([`move_all`]), or where that
/// leaves folds, by fold-rejecting moves of one vertex at a time (the
/// whole way, or half or a quarter of it, whichever keeps the vertex's fan
/// strictly positive) in up to `sweeps` Gauss–Seidel sweeps. Returns how
/// many vertices did not reach their image.
pub(crate) fn warp(
    rings: &[Vec<u32>],
    triangles: &[[u32; 3]],
    points: &mut [DVec3],
    map: &Mobius,
    steps: usize,
    sweeps: usize,
) -> usize {
    let start = points.to_vec();
    let mut targets = start.clone();
    for k in 1..=steps.max(1) {
        let m = map.power(k as f64 / steps.max(1) as f64);
        for ((t, &p), ring) in targets.iter_mut().zip(&start).zip(rings) {
            // Vertices of no triangle stay put.
            if !ring.is_empty() {
                *t = m.apply(p);
            }
        }
        if move_all(rings, triangles, points, &targets) {
            continue;
        }
        for _ in 0..sweeps {
            let mut moved = false;
            for v in 0..points.len() {
                if points[v] != targets[v] && !rings[v].is_empty() {
                    moved |= super::embed::move_vertex(rings, points, v as u32, targets[v]);
                }
            }
            if !moved {
                break;
            }
        }
    }
    (0..points.len())
        .filter(|&v| points[v] != targets[v] && !rings[v].is_empty())
        .count()
}

/// The hyperbolic translation of the ball taking `c` (inside it) to the
/// centre, on a sphere point: `(1 − |c|²)(x − c)/|x − c|² − c`. It spreads
/// the sphere away from `c`'s direction.
fn translate(c: DVec3, x: DVec3) -> DVec3 {
    let d = x - c;
    d * ((1.0 - c.length_squared()) / d.length_squared()) - c
}

/// Iterations of [`centre`] at most.
const CENTRE_ITERATIONS: usize = 200;

/// Möbius normalisation: moves `points` (a bijective embedding of
/// `triangles`) by hyperbolic translations until the centroid of the
/// vertices' surface areas `mass`, carried to the sphere, is at the sphere's
/// centre (to 1e-9), each step all at once with what folded repaired
/// ([`move_all`]; halved when that fails or the centroid gets no nearer). Returns the distance of the centroid from the centre at the
/// start and at the end.
pub(crate) fn centre(
    rings: &[Vec<u32>],
    points: &mut [DVec3],
    mass: &[f64],
    triangles: &[[u32; 3]],
) -> (f64, f64) {
    let total: f64 = mass.iter().sum();
    let centroid = |p: &[DVec3]| -> DVec3 {
        p.iter()
            .zip(mass)
            .map(|(&x, &m)| x.normalize_or_zero() * m)
            .sum::<DVec3>()
            / total.max(f64::MIN_POSITIVE)
    };
    let mut c = centroid(points);
    let start = c.length();
    let mut damping = 0.5;
    let mut trial = points.to_vec();
    for _ in 0..CENTRE_ITERATIONS {
        if c.length() < 1e-9 || damping < 1e-4 {
            break;
        }
        let step = c * damping;
        for ((t, &p), ring) in trial.iter_mut().zip(points.iter()).zip(rings) {
            if !ring.is_empty() {
                *t = translate(step, p.normalize());
            }
        }
        let before = points.to_vec();
        if !move_all(rings, triangles, points, &trial) {
            damping *= 0.5;
            continue;
        }
        let next = centroid(points);
        if next.length() < c.length() {
            c = next;
            damping = (damping * 1.5).min(0.75);
        } else {
            points.copy_from_slice(&before);
            damping *= 0.5;
        }
    }
    (start, c.length())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points() -> Vec<DVec3> {
        [
            [0.3, 0.4, 0.86],
            [-0.8, 0.1, 0.2],
            [0.1, -0.9, -0.3],
            [0.5, 0.5, -0.7],
            [-0.2, -0.3, -0.9],
        ]
        .iter()
        .map(|&p| DVec3::from_array(p).normalize())
        .collect()
    }

    #[test]
    fn lift_and_project_are_inverse() {
        for p in points().into_iter().chain([DVec3::Z, -DVec3::Z, DVec3::X]) {
            assert!((project(lift(p)) - p).length() < 1e-14, "{p}");
            assert!((Mobius::IDENTITY.apply(p) - p).length() < 1e-14);
        }
    }

    #[test]
    fn three_pairs_are_matched_exactly_and_powers_compose() {
        let p = points();
        let to = [p[3], p[4], p[0]];
        let m = Mobius::through_three([p[0], p[1], p[2]], to).unwrap();
        for k in 0..3 {
            assert!((m.apply(p[k]) - to[k]).length() < 1e-12);
        }
        let fitted = Mobius::fit(&p[..3], &to);
        for k in 0..3 {
            assert!((fitted.apply(p[k]) - to[k]).length() < 1e-12);
        }
        // M^½ ∘ M^½ = M.
        let h = m.power(0.5);
        for &x in &p {
            assert!((h.apply(h.apply(x)) - m.apply(x)).length() < 1e-9);
        }
        assert!((m.power(0.0).apply(p[1]) - p[1]).length() < 1e-12);
        assert!((m.power(1.0).apply(p[1]) - m.apply(p[1])).length() < 1e-9);
    }

    #[test]
    fn least_squares_recovers_a_map_from_five_pairs() {
        let p = points();
        let truth = Mobius::small([0.3, -0.2, 0.5, 0.1, -0.4, 0.2]);
        let to: Vec<DVec3> = p.iter().map(|&x| truth.apply(x)).collect();
        let m = Mobius::fit(&p, &to);
        for (&x, &y) in p.iter().zip(&to) {
            assert!((m.apply(x) - y).length() < 1e-9);
        }
        // One and two pairs: a rotation that matches them.
        let one = Mobius::fit(&p[..1], &to[..1]);
        assert!((one.apply(p[0]) - to[0]).length() < 1e-9);
        let two = Mobius::fit(&p[..2], &to[..2]);
        assert!((two.apply(p[0]) - to[0]).length() < 1e-6);
        assert!((two.apply(p[1]) - to[1]).length() < 1e-6);
    }

    #[test]
    fn translation_keeps_the_sphere_and_spreads_away_from_c() {
        let c = DVec3::new(0.2, -0.3, 0.4);
        for x in points() {
            assert!((translate(c, x).length() - 1.0).abs() < 1e-12);
        }
        // Points near c's direction spread away from it.
        let near = (c.normalize() + DVec3::new(0.05, 0.0, 0.0)).normalize();
        let far = translate(c, near);
        assert!(far.angle_between(c) > near.angle_between(c));
    }
}
