//! The simplifier's side of a mesh with seams: the seam rule asked about each collapse, the
//! attribute corners kept in step with the collapses, and the attribute error of a collapse.

use glam::DVec3;

use super::attributes::AttributeMetric;
use super::{corner, holds};
use crate::mesh::adjacency::NONE;
use crate::seams::SeamRule;

/// The simplifier's view of the seams: the rule, and per live triangle its attribute
/// corners (kept in step with the topology triangles as collapses re-point them).
pub(super) struct Seams<'r, 'm> {
    pub(super) rule: &'r SeamRule<'m>,
    pub(super) corners: Vec<[u32; 3]>,
    /// Scratch for the rule's `(a, b)` pairs.
    pub(super) pairs: Vec<(u32, u32)>,
    /// The attribute error, when the mesh has weighted attributes.
    pub(super) metric: Option<AttributeMetric>,
}

impl Seams<'_, '_> {
    /// Folds the attribute error of every attribute vertex of the collapse being made (the
    /// pairs of the last [`allows`](Self::allows)) into its target.
    pub(super) fn merge_metric(&mut self) {
        if let Some(metric) = &mut self.metric {
            for &(a, b) in &self.pairs {
                metric.merge(a, b);
            }
        }
    }

    /// The attribute error of `u → w` (0 without a metric): the sum over the attribute
    /// vertices of `u` on edge `uw` (in `fan`, the live triangles of `u` over `tris`) of
    /// moving each onto the copy of `w` across the edge, at `w`'s position `p`.
    pub(super) fn attribute_cost(
        &self,
        tris: &[[u32; 3]],
        fan: &[u32],
        u: u32,
        w: u32,
        p: DVec3,
    ) -> f64 {
        let Some(metric) = &self.metric else {
            return 0.0;
        };
        // A manifold edge has two triangles; one attribute vertex of u on both counts once.
        let mut counted = [NONE; 2];
        let mut total = 0.0;
        for &t in fan {
            let tri = tris[t as usize];
            if !holds(tri, w) {
                continue;
            }
            let c = self.corners[t as usize];
            let (a, b) = (c[corner(tri, u)], c[corner(tri, w)]);
            if counted.contains(&a) {
                continue;
            }
            counted[(counted[0] != NONE) as usize] = a;
            total += metric.error(a, p, b);
        }
        total
    }

    /// Re-points the attribute corners of the surviving triangles `kept` by the pairs of
    /// the last [`allows`](Self::allows) (the collapse being made), as
    /// [`crate::seams::expand`] does.
    pub(super) fn move_corners(&mut self, kept: &[u32]) {
        for &t in kept {
            let tri = &mut self.corners[t as usize];
            for a in tri.iter_mut() {
                if let Ok(i) = self.pairs.binary_search_by_key(a, |&(x, _)| x) {
                    *a = self.pairs[i].1;
                }
            }
        }
    }

    /// Asks the rule about `u → w` over `fan`, the live triangles of `u`.
    pub(super) fn allows(&mut self, u: u32, w: u32, fan: &[u32]) -> bool {
        let corners = &self.corners;
        self.rule
            .map_collapse(
                u,
                w,
                fan.iter().map(|&t| corners[t as usize]),
                &mut self.pairs,
            )
            .is_ok()
    }
}
