//! The topology rules (module docs), checked on the current mesh before a collapse is made.

use super::classify::Kind;
use super::{after_before, corner, holds, State};
use crate::mesh::adjacency::NONE;

impl State<'_, '_, '_> {
    /// Every rule in the module docs, on the current mesh.
    pub(super) fn is_valid(&mut self, u: u32, w: u32) -> bool {
        let ku = self.kind[u as usize];
        if !matches!(ku, Kind::Interior | Kind::Border) || self.kind[w as usize] == Kind::Collapsed
        {
            return false;
        }
        // The triangles on edge uw: their apexes, and whether the edge is
        // traversed once each way (manifold) or once (boundary). Meanwhile mark
        // u's neighbours for the link condition below.
        let stamp = self.next_stamp();
        let mut shared = 0usize;
        let mut apex = [NONE; 2];
        let mut forward = [false; 2];
        let (su, lu) = (
            self.span[u as usize].start,
            self.span[u as usize].len as usize,
        );
        let (sw, lw) = (
            self.span[w as usize].start,
            self.span[w as usize].len as usize,
        );
        for i in su..su + lu {
            let tri = self.tris[self.pool[i] as usize];
            for v in tri {
                self.mark[v as usize] = stamp;
            }
            if holds(tri, w) {
                if shared == 2 {
                    return false;
                }
                let (cu, cw) = (corner(tri, u), corner(tri, w));
                apex[shared] = tri[3 - cu - cw];
                forward[shared] = (cu + 1) % 3 == cw;
                shared += 1;
            }
        }
        let edge_ok = match ku {
            Kind::Interior => shared == 2 && forward[0] != forward[1],
            Kind::Border => shared == 1 && self.kind[w as usize] == Kind::Border,
            Kind::Locked | Kind::Collapsed => false,
        };
        if !edge_ok {
            return false;
        }
        if lu + lw <= 2 * shared {
            // Nothing would remain of this component.
            return false;
        }

        // Link condition: no neighbour of u that w also reaches through a
        // triangle not on edge uw. Tested without branches (`&`, `|`): the
        // outcome per corner is unpredictable and almost always "fine".
        let mut linked = false;
        for i in sw..sw + lw {
            let tri = self.tris[self.pool[i] as usize];
            let off_edge = !holds(tri, u);
            for v in tri {
                linked |= off_edge
                    & (v != w)
                    & (self.mark[v as usize] == stamp)
                    & (v != apex[0])
                    & (v != apex[1]);
            }
        }
        if linked {
            return false;
        }

        let min_cos = self.options.min_normal_cos as f64;
        for i in su..su + lu {
            let tri = self.tris[self.pool[i] as usize];
            if holds(tri, w) {
                continue;
            }
            let [a, b] = after_before(tri, u);
            // A triangle whose other corners are both apexes becomes (w, a, b):
            // if w already has that triangle the collapse squashes a tetrahedron.
            let both_apex = ((a == apex[0]) | (a == apex[1])) & ((b == apex[0]) | (b == apex[1]));
            if both_apex && self.has_triangle(w, a, b) {
                return false;
            }
            for pose in 0..self.poses.len() {
                let (pu, pw) = (self.p(pose, u), self.p(pose, w));
                let (pa, pb) = (self.p(pose, a), self.p(pose, b));
                let before = (pa - pu).cross(pb - pu);
                let after = (pa - pw).cross(pb - pw);
                let limit = min_cos * (before.length_squared() * after.length_squared()).sqrt();
                // Anything but "greater" rejects, NaN (non-finite input) included.
                if before.dot(after).partial_cmp(&limit) != Some(std::cmp::Ordering::Greater) {
                    return false;
                }
            }
        }
        match &mut self.seams {
            Some(seams) => seams.allows(u, w, &self.pool[su..su + lu]),
            None => true,
        }
    }

    /// Whether a live triangle of `w` uses exactly the vertices `{w, a, b}`.
    fn has_triangle(&self, w: u32, a: u32, b: u32) -> bool {
        self.list(w).iter().any(|&t| {
            let tri = self.tris[t as usize];
            holds(tri, a) & holds(tri, b)
        })
    }
}
