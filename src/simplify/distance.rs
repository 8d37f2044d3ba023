//! The distance term ([`SimplifyOptions::distance_weight`]): every removed vertex stays
//! attached to the nearest live triangle, and a collapse is priced by how far it takes the
//! coarse surface from the full one, both ways.

use super::{holds, SimplifyOptions, State};
use crate::mesh::adjacency::{VertexTriangles, NONE};
use crate::metrics::closest_point;

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

/// The removed vertices of [`SimplifyOptions::distance_weight`], each attached to one live
/// triangle: per triangle a list threaded through the vertices (`head[t]`, then `next[v]`;
/// `NONE` ends it).
pub(super) struct Attached {
    pub(super) weight: f64,
    pub(super) head: Vec<u32>,
    pub(super) next: Vec<u32>,
    /// Scratch: the vertices a collapse detaches.
    pub(super) loose: Vec<u32>,
    /// The full-detail triangles, and each vertex's among them.
    pub(super) original: Vec<[u32; 3]>,
    pub(super) ring: VertexTriangles,
    /// Whether a vertex's queued cost includes the distance term (it is priced lazily, when
    /// the cheaper cost without it reaches the top: the term only adds).
    pub(super) exact: Vec<bool>,
    /// Per vertex, whether every vertex of its full-detail triangles stands still.
    pub(super) ring_still: Vec<bool>,
}

impl Attached {
    /// The term before any collapse: nothing removed, nothing priced with it yet; `original`
    /// are the full-detail triangles, `ring` each vertex's among them.
    pub(super) fn new(
        options: &SimplifyOptions,
        original: Vec<[u32; 3]>,
        ring: VertexTriangles,
        ring_still: Vec<bool>,
    ) -> Self {
        let n = ring.vertex_count();
        Attached {
            weight: options.distance_weight as f64,
            head: vec![NONE; original.len()],
            next: vec![NONE; n],
            loose: Vec::new(),
            original,
            ring,
            exact: vec![false; n],
            ring_still,
        }
    }
}

/// Per vertex, whether it stands still (the same position in every pose), and whether every
/// vertex of its full-detail triangles `tris` (`vt`) does: see `State::still`.
pub(super) fn standing_still(
    poses: &[&[[f32; 3]]],
    tris: &[[u32; 3]],
    vt: &VertexTriangles,
) -> (Vec<bool>, Vec<bool>) {
    let n = poses[0].len();
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
}

impl State<'_, '_, '_> {
    /// [`cost`](Self::cost) with the distance term: the position error is the larger of the
    /// quadric error and the distance term. Above `limit` the result is only a lower bound
    /// (the pricing stops as soon as it cannot come under `limit`).
    pub(super) fn exact_cost(&self, u: u32, w: u32, limit: f64, near: &mut Vec<u32>) -> f64 {
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

    /// Detaches `u` and the vertices attached to its triangles `fan` (a collapse of `u` is
    /// being made): they wait in `loose` until [`reattach`](Self::reattach).
    pub(super) fn detach(&mut self, u: u32, fan: &[u32]) {
        if let Some(attached) = &mut self.attached {
            attached.loose.clear();
            attached.loose.push(u);
            for &t in fan {
                let mut x = std::mem::replace(&mut attached.head[t as usize], NONE);
                while x != NONE {
                    attached.loose.push(x);
                    x = attached.next[x as usize];
                }
            }
        }
    }

    /// Attaches each detached vertex to its nearest triangle of `kept` (the re-pointed
    /// triangles of the collapse onto `w`), or to a triangle of `w` when none is left.
    pub(super) fn reattach(&mut self, w: u32, kept: &[u32]) {
        if let Some(mut attached) = self.attached.take() {
            for &x in &attached.loose {
                let (_, t) = self.nearest(x, kept, w, Some, 0.0);
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
    }
}
