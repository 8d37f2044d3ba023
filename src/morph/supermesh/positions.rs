//! The two poses of the supermesh: `V(0)` on A and `V(1)` on B.
//!
//! * An A vertex copies its A position into `V(0)` (bit for bit) and takes
//!   `V(1)` from the projective barycentric coordinates of its sphere point in
//!   the B face holding it; a B vertex the other way round.
//! * A crossing lies on an A edge and a B edge: each pose interpolates the
//!   edge's endpoints with the chord parameter of that edge (1D), so it lies on
//!   both surfaces' edges.
//!
//! Projective barycentrics map great arcs to straight chords, and each overlay
//! polygon to a straight-sided polygon of the chord triangle, so the supermesh
//! at `t = 0` tiles A's triangles exactly and at `t = 1` B's.

use glam::DVec3;

use super::overlay::{Node, Overlay};
use super::sphere::projective_barycentric;
use super::{Origin, Supermesh};
use crate::mesh::clean::Cleaned;

fn d(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

fn f(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// One mesh with its sphere embedding.
pub(crate) struct Surface<'a> {
    pub positions: &'a [[f32; 3]],
    pub triangles: &'a [[u32; 3]],
    pub sphere: &'a [DVec3],
}

impl Surface<'_> {
    /// The surface point over sphere point `p`, which lies in face `face`.
    fn at(&self, p: DVec3, face: u32) -> [f32; 3] {
        let t = self.triangles[face as usize];
        let [a, b, c] = t.map(|v| self.sphere[v as usize]);
        let l = projective_barycentric(p, a, b, c);
        let q = t.map(|v| d(self.positions[v as usize]));
        f(q[0] * l[0] + q[1] * l[1] + q[2] * l[2])
    }

    fn on_edge(&self, e: [u32; 2], t: f64) -> [f32; 3] {
        let (p, q) = (
            d(self.positions[e[0] as usize]),
            d(self.positions[e[1] as usize]),
        );
        f(p + (q - p) * t)
    }
}

/// `(V(0), V(1))` for every overlay node.
pub(crate) fn poses(overlay: &Overlay, a: &Surface, b: &Surface) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    overlay
        .nodes
        .iter()
        .zip(&overlay.sphere)
        .map(|(node, &p)| match *node {
            Node::A(v) => (a.positions[v as usize], b.at(p, overlay.a_in_b[v as usize])),
            Node::B(v) => (a.at(p, overlay.b_in_a[v as usize]), b.positions[v as usize]),
            Node::Both(va, vb) => (a.positions[va as usize], b.positions[vb as usize]),
            Node::Crossing {
                a: ea,
                ta,
                b: eb,
                tb,
            } => (a.on_edge(ea, ta), b.on_edge(eb, tb)),
        })
        .unzip()
}

/// Stage 6: poses and origins (in input indices).
pub(super) fn assemble(
    ca: &Cleaned,
    cb: &Cleaned,
    a_sphere: &[DVec3],
    b_sphere: &[DVec3],
    overlay: &Overlay,
) -> Supermesh {
    let surface_a = Surface {
        positions: &ca.mesh.positions,
        triangles: &ca.mesh.triangles,
        sphere: a_sphere,
    };
    let surface_b = Surface {
        positions: &cb.mesh.positions,
        triangles: &cb.mesh.triangles,
        sphere: b_sphere,
    };
    let (v0, v1) = poses(overlay, &surface_a, &surface_b);
    let (ma, mb) = (&ca.vertex_map, &cb.vertex_map);
    let origins = overlay
        .nodes
        .iter()
        .map(|n| match *n {
            Node::A(v) => Origin::A(ma[v as usize]),
            Node::B(v) => Origin::B(mb[v as usize]),
            Node::Both(a, b) => Origin::Both {
                a: ma[a as usize],
                b: mb[b as usize],
            },
            Node::Crossing { a, b, .. } => Origin::Crossing {
                a_edge: a.map(|v| ma[v as usize]),
                b_edge: b.map(|v| mb[v as usize]),
            },
        })
        .collect();
    Supermesh {
        triangles: overlay.triangles.clone(),
        v0,
        v1,
        origins,
        sphere: overlay.sphere.clone(),
    }
}
