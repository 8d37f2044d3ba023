//! Geometry on the unit sphere shared by every stage: the exact orientation
//! predicate, spherical triangle meshes with face adjacency, point location by
//! walking, projective barycentric coordinates and spherical areas.
//!
//! Sphere points are `f64` rays from the origin: only their direction matters,
//! so they need not be exactly unit length. A spherical triangle `(a, b, c)` is
//! positively oriented (counter-clockwise seen from outside) when
//! `det[a; b; c] > 0`, decided exactly by Shewchuk's `orient3d` with the origin
//! as fourth point.

use glam::DVec3;
use robust::{orient3d, Coord3D};

use crate::mesh::adjacency::{triangle_neighbors, EdgeMap, NONE};
use crate::random::next_below;

fn coord(p: DVec3) -> Coord3D<f64> {
    Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// `det[a; b; c]` with the exact sign (the value is approximate): positive when
/// `a, b, c` turn counter-clockwise seen from outside the sphere, that is when
/// `c` lies left of the great arc `a → b`.
#[inline]
pub(crate) fn orient(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    // orient3d(a, b, c, d) = det[a − d; b − d; c − d]; with d = 0 it is det[a; b; c].
    orient3d(coord(a), coord(b), coord(c), coord(DVec3::ZERO))
}

/// [`orient`] under Simulation of Simplicity (Edelsbrunner & Mücke 1990):
/// never zero. Coordinate `c` of the point with global index `id` is
/// perturbed by `ε^(2^(3 id + c))`; when the exact determinant is zero its
/// sign is that of the first non-vanishing coefficient of the expansion in
/// ε, each an exact determinant of the rows with some rows replaced by unit
/// vectors. The same points always get the same answer, and the answers are
/// those of one configuration in general position (the perturbed one), so
/// the general-position overlay logic runs unchanged on coincident input.
/// A zero is returned as `±1e-300`, so callers that interpolate by the value
/// put the point where it is: on the line.
pub(crate) fn orient_sos(p: [DVec3; 3], id: [u32; 3]) -> f64 {
    let exact = orient(p[0], p[1], p[2]);
    if exact != 0.0 {
        return exact;
    }
    // Entries (row, column) from the most perturbed (lowest index) on.
    let mut entries = [(0u64, 0usize, 0usize); 9];
    for r in 0..3 {
        for c in 0..3 {
            entries[r * 3 + c] = (3 * id[r] as u64 + c as u64, r, c);
        }
    }
    entries.sort_unstable();
    for mask in 1u32..512 {
        let mut rows = p;
        let (mut used_r, mut used_c) = (0u8, 0u8);
        let mut ok = true;
        for (b, &(_, r, c)) in entries.iter().enumerate() {
            if mask >> b & 1 == 1 {
                if used_r >> r & 1 == 1 || used_c >> c & 1 == 1 {
                    ok = false;
                    break;
                }
                used_r |= 1 << r;
                used_c |= 1 << c;
                let mut e = DVec3::ZERO;
                e[c] = 1.0;
                rows[r] = e;
            }
        }
        if !ok {
            continue;
        }
        let o = orient(rows[0], rows[1], rows[2]);
        if o != 0.0 {
            return 1e-300f64.copysign(o);
        }
    }
    // Unreachable: three unit rows of a permutation have a non-zero determinant.
    1e-300
}

/// Whether `a` and `b` are exactly the same direction.
pub(crate) fn same_direction(a: DVec3, b: DVec3) -> bool {
    use robust::{orient2d, Coord};
    let zero = Coord { x: 0.0, y: 0.0 };
    let c = |x: f64, y: f64| Coord { x, y };
    orient2d(c(a.x, a.y), c(b.x, b.y), zero) == 0.0
        && orient2d(c(a.y, a.z), c(b.y, b.z), zero) == 0.0
        && orient2d(c(a.z, a.x), c(b.z, b.x), zero) == 0.0
        && a.dot(b) > 0.0
}

/// Area of the spherical triangle with vertices in the directions `a, b, c`
/// (signed: negative when clockwise), by Van Oosterom–Strackee.
pub(crate) fn spherical_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (a, b, c) = (a.normalize(), b.normalize(), c.normalize());
    let num = a.dot(b.cross(c));
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// Projective barycentric coordinates of the direction `p` in the spherical
/// triangle `(a, b, c)`: where the ray through `p` meets the plane of the chord
/// triangle `abc`. They map great arcs to straight chords, so interpolating a
/// surface triangle with them reproduces it exactly. Sum to 1; all positive
/// when `p` is strictly inside.
pub(crate) fn projective_barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let d = [p.dot(b.cross(c)), a.dot(p.cross(c)), a.dot(b.cross(p))];
    let sum = d[0] + d[1] + d[2];
    if sum.abs() > 0.0 && sum.is_finite() {
        d.map(|x| x / sum)
    } else {
        [1.0 / 3.0; 3]
    }
}

/// The parameter `t` at which the great arc `a → b` meets the plane through
/// the origin with signed distances `da` (of `a`) and `db` (of `b`): the point
/// `(1 − t) a + t b` of the chord. Clamped to `[0, 1]`.
pub(crate) fn chord_parameter(da: f64, db: f64) -> f64 {
    let den = da - db;
    if den == 0.0 || !den.is_finite() {
        return 0.5;
    }
    (da / den).clamp(0.0, 1.0)
}

/// A closed triangle mesh embedded on the sphere, with face adjacency.
pub(crate) struct SphereMesh<'a> {
    pub points: &'a [DVec3],
    pub triangles: &'a [[u32; 3]],
    /// `neighbors[t][i]`: the face across edge `triangles[t][i] → triangles[t][i+1]`.
    pub neighbors: Vec<[u32; 3]>,
}

/// Where a point fell: strictly inside a face, or on something (degenerate).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Location {
    Inside(u32),
    /// Exactly on an edge or vertex of the face (an orientation was zero).
    Degenerate(u32),
}

impl<'a> SphereMesh<'a> {
    pub fn new(points: &'a [DVec3], triangles: &'a [[u32; 3]]) -> Self {
        let edges = EdgeMap::new(triangles);
        let neighbors = triangle_neighbors(triangles, &edges);
        SphereMesh {
            points,
            triangles,
            neighbors,
        }
    }

    pub fn corners(&self, t: u32) -> [DVec3; 3] {
        self.triangles[t as usize].map(|v| self.points[v as usize])
    }

    /// The face containing direction `p`, by a remembering stochastic visibility
    /// walk from `start` (Devillers et al.): cross an edge that has `p` strictly
    /// on its outer side, trying the edges from a pseudo-random first one so the
    /// walk cannot cycle for ever. Falls back to a scan of every face when the
    /// walk is long (far start, or a cycle on the sphere).
    pub fn locate(&self, p: DVec3, start: u32, rng: &mut u64) -> Location {
        let max_steps = 64 + 4 * (self.triangles.len() as f64).sqrt() as usize;
        let mut t = start.min(self.triangles.len() as u32 - 1);
        let mut previous = NONE;
        for _ in 0..max_steps {
            match self.step(t, p, previous, rng) {
                Step::Found => return Location::Inside(t),
                Step::OnBoundary => return Location::Degenerate(t),
                Step::Next(n) => {
                    previous = t;
                    t = n;
                }
            }
        }
        self.scan(p)
    }

    fn step(&self, t: u32, p: DVec3, previous: u32, rng: &mut u64) -> Step {
        let c = self.corners(t);
        let first = next_below(rng, 3) as usize;
        let mut zero = false;
        for k in 0..3 {
            let i = (first + k) % 3;
            let n = self.neighbors[t as usize][i];
            if n == previous {
                continue;
            }
            let o = orient(c[i], c[(i + 1) % 3], p);
            if o < 0.0 && n != NONE {
                return Step::Next(n);
            }
            zero |= o == 0.0;
        }
        // The edge back to the previous face was skipped: check it last.
        for i in 0..3 {
            if self.neighbors[t as usize][i] == previous {
                let o = orient(c[i], c[(i + 1) % 3], p);
                if o < 0.0 {
                    return Step::Next(previous);
                }
                zero |= o == 0.0;
            }
        }
        if zero {
            Step::OnBoundary
        } else {
            Step::Found
        }
    }

    fn scan(&self, p: DVec3) -> Location {
        let mut degenerate = None;
        for t in 0..self.triangles.len() as u32 {
            let c = self.corners(t);
            let o = [
                orient(c[0], c[1], p),
                orient(c[1], c[2], p),
                orient(c[2], c[0], p),
            ];
            if o.iter().all(|&x| x > 0.0) {
                return Location::Inside(t);
            }
            if o.iter().all(|&x| x >= 0.0) {
                degenerate = Some(t);
            }
        }
        // A bijective embedding covers the sphere, so one of the two was found.
        Location::Degenerate(degenerate.unwrap_or(0))
    }
}

enum Step {
    Found,
    OnBoundary,
    Next(u32),
}

/// Counts the faces that are not strictly positively oriented (exact) and sums
/// the spherical areas: a bijective embedding has no such face and area 4π.
pub(crate) fn check_embedding(points: &[DVec3], triangles: &[[u32; 3]]) -> (usize, f64) {
    let mut folds = 0;
    let mut area = 0.0;
    for t in triangles {
        let [a, b, c] = t.map(|v| points[v as usize]);
        if orient(a, b, c) <= 0.0 {
            folds += 1;
        }
        area += spherical_area(a, b, c);
    }
    (folds, area)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orient_is_positive_counter_clockwise_from_outside() {
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        assert!(orient(x, y, z) > 0.0);
        assert!(orient(y, x, z) < 0.0);
        assert_eq!(orient(x, y, x + y), 0.0);
        let area = spherical_area(x, y, z);
        assert!((area - std::f64::consts::PI / 2.0).abs() < 1e-12);
    }

    #[test]
    fn simulation_of_simplicity_is_consistent_and_never_zero() {
        let (x, y) = (DVec3::X, DVec3::Y);
        let m = x + y;
        // Collinear: never zero, and antisymmetric under swapping two rows.
        let o = orient_sos([x, y, m], [0, 1, 2]);
        assert!(o != 0.0);
        assert_eq!(orient_sos([y, x, m], [1, 0, 2]).signum(), -o.signum());
        // Coincident points: still a sign; a point and its copy are on
        // opposite sides of each other's edges in a consistent way.
        let s1 = orient_sos([x, y, x], [0, 1, 5]);
        let s2 = orient_sos([y, x, x], [1, 0, 5]);
        assert!(s1 != 0.0 && s2 == -s1);
        assert!(same_direction(x * 2.0, x) && !same_direction(x, -x) && !same_direction(x, m));
    }

    #[test]
    fn projective_barycentrics_reproduce_chord_points() {
        let (a, b, c) = (DVec3::X, DVec3::Y, DVec3::Z);
        let q = 0.2 * a + 0.3 * b + 0.5 * c;
        let l = projective_barycentric(q.normalize() * 7.0, a, b, c);
        for (x, y) in l.iter().zip([0.2, 0.3, 0.5]) {
            assert!((x - y).abs() < 1e-12);
        }
    }
}
