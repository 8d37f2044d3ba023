//! Position quadrics (Garland–Heckbert): the plane quadric, and every vertex's sum of its
//! face planes, boundary and seam edge planes and the regularizing point quadric.

use glam::DVec3;

use super::{dvec, SimplifyOptions};

/// Symmetric 4×4 plane quadric `Σ w (n·p + d)²`, with the total weight `w`
/// kept so the error can be reported as a weighted mean.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Quadric {
    pub(super) a00: f64,
    pub(super) a11: f64,
    pub(super) a22: f64,
    pub(super) a10: f64,
    pub(super) a20: f64,
    pub(super) a21: f64,
    pub(super) b0: f64,
    pub(super) b1: f64,
    pub(super) b2: f64,
    pub(super) c: f64,
    pub(super) w: f64,
}

impl Quadric {
    /// The plane `n·p + d = 0` (`n` unit length) with weight `w`.
    pub(super) fn plane(n: DVec3, d: f64, w: f64) -> Self {
        Self {
            a00: n.x * n.x * w,
            a11: n.y * n.y * w,
            a22: n.z * n.z * w,
            a10: n.x * n.y * w,
            a20: n.x * n.z * w,
            a21: n.y * n.z * w,
            b0: n.x * d * w,
            b1: n.y * d * w,
            b2: n.z * d * w,
            c: d * d * w,
            w,
        }
    }

    /// Squared distance to the point `p`, times `w`.
    pub(super) fn point(p: DVec3, w: f64) -> Self {
        Self {
            a00: w,
            a11: w,
            a22: w,
            a10: 0.0,
            a20: 0.0,
            a21: 0.0,
            b0: -p.x * w,
            b1: -p.y * w,
            b2: -p.z * w,
            c: p.length_squared() * w,
            w,
        }
    }

    pub(super) fn add(&mut self, o: &Quadric) {
        self.a00 += o.a00;
        self.a11 += o.a11;
        self.a22 += o.a22;
        self.a10 += o.a10;
        self.a20 += o.a20;
        self.a21 += o.a21;
        self.b0 += o.b0;
        self.b1 += o.b1;
        self.b2 += o.b2;
        self.c += o.c;
        self.w += o.w;
    }

    /// `Q(p) / W`: weighted mean squared distance (object units²). `abs`
    /// because rounding can make a true zero slightly negative.
    pub(super) fn error(&self, p: DVec3) -> f64 {
        if self.w > 0.0 {
            self.sum(p).abs() / self.w
        } else {
            0.0
        }
    }

    /// `Q(p)`, the weighted sum.
    pub(super) fn sum(&self, p: DVec3) -> f64 {
        let rx = self.a00 * p.x + 2.0 * (self.a10 * p.y + self.a20 * p.z + self.b0);
        let ry = self.a11 * p.y + 2.0 * (self.a21 * p.z + self.b1);
        let rz = self.a22 * p.z + 2.0 * self.b2;
        self.c + rx * p.x + ry * p.y + rz * p.z
    }
}

/// Face quadrics, boundary edge quadrics and the regularizing point quadric of every vertex.
pub(super) fn quadrics(
    pos: &[[f32; 3]],
    tris: &[[u32; 3]],
    boundary_edges: &[[u32; 3]],
    seam_edges: &[[u32; 3]],
    options: &SimplifyOptions,
) -> Vec<Quadric> {
    let mut q = vec![Quadric::default(); pos.len()];
    let face = |t: [u32; 3], weight: f64| {
        let [p0, p1, p2] = t.map(|v| dvec(pos[v as usize]));
        let cross = (p1 - p0).cross(p2 - p0);
        let double_area = cross.length();
        let n = if double_area > 0.0 {
            cross / double_area
        } else {
            DVec3::ZERO
        };
        Quadric::plane(n, -n.dot(p0), double_area.sqrt() * weight)
    };
    for &t in tris {
        let f = face(t, 1.0);
        for v in t {
            q[v as usize].add(&f);
        }
    }
    // Border edges, and each side of a seam edge (half the seam weight, so a seam edge as a
    // whole weighs `seam_weight`).
    let bw = options.boundary_weight as f64;
    let sw = 0.5 * options.seam_weight as f64;
    let edges = boundary_edges
        .iter()
        .map(|e| (e, bw))
        .chain(seam_edges.iter().map(|e| (e, sw)))
        .filter(|&(_, weight)| weight > 0.0);
    for (&[from, to, tri], weight) in edges {
        let t = tris[tri as usize];
        // The corner that is neither end: xor cancels the two ends out.
        let apex = t[0] ^ t[1] ^ t[2] ^ from ^ to;
        let (p0, p1, p2) = (
            dvec(pos[from as usize]),
            dvec(pos[to as usize]),
            dvec(pos[apex as usize]),
        );
        let edge = p1 - p0;
        // The plane holds the edge and is perpendicular to the triangle: its
        // normal is the component of (p2 - p0) perpendicular to the edge.
        let perp =
            (p2 - p0) - edge * ((p2 - p0).dot(edge) / edge.length_squared().max(f64::MIN_POSITIVE));
        let perp = perp.normalize_or_zero();
        let mut e = Quadric::plane(perp, -perp.dot(p0), edge.length() * weight);
        // The face plane too, with the same weight but no share of the mean
        // (meshoptimizer: stabilises collapses along the border both ways).
        let mut f = face(t, weight);
        f.w = 0.0;
        e.add(&f);
        q[from as usize].add(&e);
        q[to as usize].add(&e);
    }
    let r = options.regularization as f64;
    for (v, qv) in q.iter_mut().enumerate() {
        let p = Quadric::point(dvec(pos[v]), qv.w * r);
        qv.add(&p);
    }
    q
}
