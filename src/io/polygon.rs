//! Triangulating polygon faces (OBJ `f`, OFF and PLY faces of more than three
//! corners), shared by the text and PLY loaders.
//!
//! A polygon is first written as the fan from its first corner,
//! `(c0, ci, ci+1)`, the moment it is read: the vertices it names may not be
//! read yet (OBJ faces may point forward, PLY may list faces before
//! vertices). Once the file is read, [`Polygons::finish`] looks at each
//! polygon of four or more corners in its best-fit plane (the plane of its
//! Newell normal, which points the way the corners turn, so the polygon's
//! orientation is kept) and:
//!
//! - **convex** (every turn the same way, one turn around; collinear and
//!   repeated corners allowed): keeps the fan. That is what every
//!   triangulation of it would be worth, and what these loaders always
//!   produced, so meshes of triangles and convex polygons load bit-identical;
//! - **non-convex and simple** (a U, an L, a comb): ear clipping, so the
//!   triangles cover exactly the polygon and all face the polygon's way.
//!   Each polygon of `n` corners still gives `n − 2` triangles in its slot,
//!   so the triangle order of the file is kept;
//! - **degenerate** (zero area: all corners on a line or a point) or
//!   **self-intersecting** (a bow tie, a pentagram): there is no correct
//!   triangulation. Documented fallback: the fan stays (for the part ear
//!   clipping could not reach, the fan of what remains). Degenerate triangles
//!   are then left to [`crate::mesh::clean`], which counts or drops them;
//! - non-convex with more than [`MAX_EAR_CLIPPED_CORNERS`] corners: refused
//!   with [`LoadError::PolygonTooLarge`], since ear clipping is quadratic.
//!
//! Nothing here can panic on any input: corners are validated by the loader
//! before [`Polygons::finish`] runs, and all geometry is in f64.

use super::{LoadError, Location};
use std::path::Path;

/// The most corners a non-convex polygon may have: ear clipping is
/// `O(corners × reflex corners)`, about 10⁸ steps here at worst.
pub const MAX_EAR_CLIPPED_CORNERS: usize = 10_000;

/// A polygon of four or more corners already written as a fan.
struct Deferred {
    /// Index of its first fan triangle.
    first: usize,
    corners: u32,
    /// Where it was read (a line, or a record index), for errors.
    at: usize,
}

/// The polygon faces of one file, fanned as read and fixed by [`Polygons::finish`].
#[derive(Default)]
pub(crate) struct Polygons {
    deferred: Vec<Deferred>,
}

impl Polygons {
    /// Appends the fan of `corners` (at least 3) to `triangles`, and remembers
    /// a polygon of four or more corners for [`Polygons::finish`].
    pub(crate) fn push(&mut self, corners: &[u32], triangles: &mut Vec<[u32; 3]>, at: usize) {
        let first = triangles.len();
        if let Some((&c0, rest)) = corners.split_first() {
            for pair in rest.windows(2) {
                triangles.push([c0, pair[0], pair[1]]);
            }
        }
        if corners.len() > 3 {
            self.deferred.push(Deferred {
                first,
                corners: corners.len() as u32,
                at,
            });
        }
    }

    /// Re-triangulates the non-convex polygons in place (see the module docs).
    /// Every corner must index `positions` (the loaders check that first).
    /// `location` turns the `at` given to [`Polygons::push`] into a [`Location`].
    pub(crate) fn finish(
        &self,
        positions: &[[f32; 3]],
        triangles: &mut [[u32; 3]],
        path: &Path,
        location: impl Fn(usize) -> Location,
    ) -> Result<(), LoadError> {
        let mut corners: Vec<u32> = Vec::new();
        let mut scratch = Scratch::default();
        for polygon in &self.deferred {
            let n = polygon.corners as usize;
            let Some(slot) = triangles.get_mut(polygon.first..polygon.first + n - 2) else {
                continue;
            };
            // The fan encodes the corners: c0, then each triangle's second
            // corner, then the last triangle's third.
            corners.clear();
            corners.push(slot[0][0]);
            corners.extend(slot.iter().map(|t| t[1]));
            corners.push(slot[n - 3][2]);
            if corners.iter().any(|&c| c as usize >= positions.len()) {
                continue; // The loader reports it; never index out of range here.
            }
            match classify(&corners, positions, &mut scratch) {
                Shape::ConvexOrDegenerate => {}
                Shape::Concave if n > MAX_EAR_CLIPPED_CORNERS => {
                    return Err(LoadError::PolygonTooLarge {
                        path: path.to_path_buf(),
                        at: location(polygon.at),
                        corners: n,
                        limit: MAX_EAR_CLIPPED_CORNERS,
                    })
                }
                Shape::Concave => ear_clip(&corners, &mut scratch, slot),
            }
        }
        Ok(())
    }
}

enum Shape {
    /// Keep the fan.
    ConvexOrDegenerate,
    /// Ear-clip; `scratch.points` holds the projected corners.
    Concave,
}

#[derive(Default)]
struct Scratch {
    /// The corners projected onto the polygon's plane, turning counter-clockwise.
    points: Vec<[f64; 2]>,
    prev: Vec<usize>,
    next: Vec<usize>,
    ear: Vec<bool>,
    /// The polygon's edges of non-zero length, for the convexity test.
    edges: Vec<[f64; 2]>,
}

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross3(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot3(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross2(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Projects the polygon onto its Newell plane (into `scratch.points`) and
/// decides whether the fan is right.
fn classify(corners: &[u32], positions: &[[f32; 3]], scratch: &mut Scratch) -> Shape {
    let point = |c: u32| positions[c as usize].map(f64::from);
    // Centred on the first corner, so far-from-origin polygons keep their precision.
    let origin = point(corners[0]);
    let n = corners.len();
    let mut normal = [0.0; 3];
    for i in 0..n {
        let a = sub(point(corners[i]), origin);
        let b = sub(point(corners[(i + 1) % n]), origin);
        let c = cross3(a, b);
        normal = [normal[0] + c[0], normal[1] + c[1], normal[2] + c[2]];
    }
    let length = dot3(normal, normal).sqrt();
    if length.is_nan() || length <= 0.0 || !length.is_finite() {
        return Shape::ConvexOrDegenerate; // Zero area: no plane, no right answer.
    }
    let normal = normal.map(|c| c / length);
    // u ⟂ normal, v = normal × u: (u, v, normal) is right-handed, so the
    // polygon turns counter-clockwise in (u, v).
    let helper = if normal[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = cross3(helper, normal);
    let u_len = dot3(u, u).sqrt();
    let u = u.map(|c| c / u_len);
    let v = cross3(normal, u);
    scratch.points.clear();
    scratch.points.extend(corners.iter().map(|&c| {
        let p = sub(point(c), origin);
        [dot3(p, u), dot3(p, v)]
    }));

    // Convex: no turn the wrong way, and the turns add up to one revolution
    // (a pentagram turns the right way at every corner but twice around).
    // Zero-length edges (repeated corners) are skipped.
    let Scratch { points, edges, .. } = scratch;
    let scale = points
        .iter()
        .flatten()
        .fold(0.0f64, |m, &c| m.max(c.abs()))
        .max(f64::MIN_POSITIVE);
    edges.clear();
    edges.extend(
        (0..n)
            .map(|i| {
                let (a, b) = (points[i], points[(i + 1) % n]);
                [b[0] - a[0], b[1] - a[1]]
            })
            .filter(|e| e[0].abs().max(e[1].abs()) > scale * 1e-12),
    );
    let mut turning = 0.0;
    for i in 0..edges.len() {
        let (a, b) = (edges[i], edges[(i + 1) % edges.len()]);
        let cross = a[0] * b[1] - a[1] * b[0];
        let dot = a[0] * b[0] + a[1] * b[1];
        let norm = (a[0].hypot(a[1])) * (b[0].hypot(b[1]));
        if cross < -1e-9 * norm {
            return Shape::Concave;
        }
        turning += cross.atan2(dot);
    }
    if turning < 3.0 * std::f64::consts::PI {
        Shape::ConvexOrDegenerate
    } else {
        Shape::Concave
    }
}

/// Ear clipping over `scratch.points` (counter-clockwise), writing the
/// `corners.len() − 2` triangles into `out`. An ear is a corner turning
/// counter-clockwise whose triangle with its two neighbours holds no other
/// remaining reflex corner; clipping one changes only its neighbours' status,
/// so each is re-tested only then. When no ear is left (a self-intersecting
/// polygon), the rest is fanned, as documented in the module.
fn ear_clip(corners: &[u32], scratch: &mut Scratch, out: &mut [[u32; 3]]) {
    let n = corners.len();
    let Scratch {
        points,
        prev,
        next,
        ear,
        ..
    } = scratch;
    prev.clear();
    prev.extend((0..n).map(|i| (i + n - 1) % n));
    next.clear();
    next.extend((0..n).map(|i| (i + 1) % n));
    let convex = |i: usize, prev: &[usize], next: &[usize]| {
        cross2(points[prev[i]], points[i], points[next[i]]) > 0.0
    };
    // Reflex (or straight) corners are the only ones that can block an ear.
    let mut reflex: Vec<usize> = (0..n).filter(|&i| !convex(i, prev, next)).collect();
    let is_ear = |i: usize, prev: &[usize], next: &[usize], reflex: &[usize]| {
        let (a, b, c) = (prev[i], i, next[i]);
        if !convex(i, prev, next) {
            return false;
        }
        let (pa, pb, pc) = (points[a], points[b], points[c]);
        !reflex.iter().any(|&r| {
            let p = points[r];
            r != a
                && r != b
                && r != c
                && p != pa
                && p != pb
                && p != pc
                && cross2(pa, pb, p) >= 0.0
                && cross2(pb, pc, p) >= 0.0
                && cross2(pc, pa, p) >= 0.0
        })
    };
    ear.clear();
    ear.extend((0..n).map(|i| is_ear(i, prev, next, &reflex)));

    let mut written = 0;
    let mut remaining = n;
    let mut current = 0;
    // Corners looked at since the last clip: a full round without an ear means none is left.
    let mut unproductive = 0;
    while remaining > 3 {
        if ear[current] {
            let (a, c) = (prev[current], next[current]);
            out[written] = [corners[a], corners[current], corners[c]];
            written += 1;
            remaining -= 1;
            next[a] = c;
            prev[c] = a;
            reflex.retain(|&r| r != current);
            for v in [a, c] {
                if convex(v, prev, next) {
                    reflex.retain(|&r| r != v);
                }
                ear[v] = is_ear(v, prev, next, &reflex);
            }
            // Restart from the previous corner: ears next to a clip come first,
            // as in the usual formulation.
            current = a;
            unproductive = 0;
            continue;
        }
        current = next[current];
        unproductive += 1;
        if unproductive > remaining {
            break; // Self-intersecting: no ear left.
        }
    }
    // The last triangle, or the fan of what is left.
    let first = current;
    let mut b = next[first];
    while written < out.len() && next[b] != first {
        out[written] = [corners[first], corners[b], corners[next[b]]];
        written += 1;
        b = next[b];
    }
}
