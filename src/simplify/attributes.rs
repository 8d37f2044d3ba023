//! The attribute error of UVs and normals (Hoppe 1999 in meshoptimizer's form), added to the
//! position error on a mesh with seams.

use glam::DVec3;

use super::quadric::Quadric;
use super::{dvec, SimplifyOptions};
use crate::seams::SeamRule;

/// The attribute error (Hoppe 1999, "New quadric metric for simplifying meshes with
/// appearance attributes", in meshoptimizer's form): every triangle fits each attribute
/// channel `k` with the linear function `g_k · p + d_k` over its plane that takes the corner
/// values at the corners; attribute vertex `a` sums, area-weighted over its triangles,
/// `(g_k · p + d_k − x_k)²` over the channels. Moving `a` onto attribute vertex `b` at
/// position `p` costs that sum with `x` = `b`'s attributes: how far `b`'s values are from
/// what `a`'s triangles interpolate there. Channels are pre-scaled by their weight
/// ([`SimplifyOptions::uv_weight`]). Unlike the position error the sum is not divided by
/// the weight (as in meshoptimizer): area × deviation² is a squared length, so a deviation
/// costs in proportion to the size of the region it spans, and a shape whose attributes are
/// linear in position (normals on a sphere cost nothing) never becomes the cheapest thing to
/// destroy. Expanded, the terms without `x` are a position quadric and the rest need, per
/// channel, `Σ w g_k` and `Σ w d_k`.
pub(super) struct AttributeMetric {
    channels: usize,
    /// Per attribute vertex, its `channels` scaled values.
    values: Vec<f64>,
    quadric: Vec<Quadric>,
    /// Per attribute vertex and channel, `[Σ w g_k, Σ w d_k]` (gradient x, y, z, offset).
    gradient: Vec<[f64; 4]>,
}

/// At most two UV and three normal channels.
const MAX_CHANNELS: usize = 5;

impl AttributeMetric {
    /// The metric of the attribute `corners` of the triangles `tris` over `pos` (topology
    /// positions), or `None` when no attribute has weight.
    pub(super) fn new(
        pos: &[[f32; 3]],
        tris: &[[u32; 3]],
        corners: &[[u32; 3]],
        rule: &SeamRule,
        options: &SimplifyOptions,
    ) -> Option<Self> {
        let n = rule.vertex_count();
        let uv_scale = options.uv_weight as f64;
        let normal_scale = options.normal_weight as f64;
        let uvs = rule.uvs().filter(|_| uv_scale > 0.0);
        let normals = rule.normals().filter(|_| normal_scale > 0.0);
        let channels = uvs.map_or(0, |_| 2) + normals.map_or(0, |_| 3);
        if channels == 0 {
            return None;
        }
        let mut values = Vec::with_capacity(n * channels);
        for a in 0..n {
            if let Some(uvs) = uvs {
                values.extend(uvs[a].map(|x| x as f64 * uv_scale));
            }
            if let Some(normals) = normals {
                values.extend(normals[a].map(|x| x as f64 * normal_scale));
            }
        }
        let mut metric = AttributeMetric {
            channels,
            values,
            quadric: vec![Quadric::default(); n],
            gradient: vec![[0.0; 4]; n * channels],
        };
        for (&t, &c) in tris.iter().zip(corners) {
            metric.add_triangle(t.map(|v| dvec(pos[v as usize])), c);
        }
        Some(metric)
    }

    /// Adds the fitted functions of the triangle at positions `p` with attribute corners `c`
    /// to each corner, weighted by the triangle's area.
    fn add_triangle(&mut self, p: [DVec3; 3], c: [u32; 3]) {
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let w = 0.5 * e1.cross(e2).length();
        // The gradients of the barycentric coordinates of corners 1 and 2 within the plane
        // (from the Gram matrix of the edges); zero on a degenerate triangle, which has no
        // weight anyway.
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = d11 * d22 - d12 * d12;
        let inv = if det > 0.0 { 1.0 / det } else { 0.0 };
        let grad1 = (e1 * d22 - e2 * d12) * inv;
        let grad2 = (e2 * d11 - e1 * d12) * inv;
        let k = self.channels;
        let mut q = Quadric {
            w,
            ..Quadric::default()
        };
        let mut g = [[0.0f64; 4]; MAX_CHANNELS];
        for (ch, gk) in g.iter_mut().enumerate().take(k) {
            let x = c.map(|a| self.values[a as usize * k + ch]);
            let grad = grad1 * (x[1] - x[0]) + grad2 * (x[2] - x[0]);
            let d = x[0] - grad.dot(p[0]);
            // w (g·p + d)², with no share of the weight (that is the triangle's, once).
            let mut term = Quadric::plane(grad, d, w);
            term.w = 0.0;
            q.add(&term);
            *gk = [grad.x * w, grad.y * w, grad.z * w, d * w];
        }
        for a in c {
            self.quadric[a as usize].add(&q);
            let rows = &mut self.gradient[a as usize * k..(a as usize + 1) * k];
            for (row, gk) in rows.iter_mut().zip(&g) {
                for i in 0..4 {
                    row[i] += gk[i];
                }
            }
        }
    }

    /// The cost of moving attribute vertex `a` onto attribute vertex `b` at position `p`.
    pub(super) fn error(&self, a: u32, p: DVec3, b: u32) -> f64 {
        let k = self.channels;
        let q = &self.quadric[a as usize];
        let mut sum = q.sum(p);
        let rows = &self.gradient[a as usize * k..(a as usize + 1) * k];
        for (row, &x) in rows
            .iter()
            .zip(&self.values[b as usize * k..(b as usize + 1) * k])
        {
            let fitted = row[0] * p.x + row[1] * p.y + row[2] * p.z + row[3];
            sum += x * (x * q.w - 2.0 * fitted);
        }
        // Rounding can make a true zero slightly negative.
        sum.abs()
    }

    /// Folds the error of attribute vertex `a` into `b` (a collapse moved `a` onto `b`).
    pub(super) fn merge(&mut self, a: u32, b: u32) {
        let qa = self.quadric[a as usize];
        self.quadric[b as usize].add(&qa);
        let k = self.channels;
        for ch in 0..k {
            let ga = self.gradient[a as usize * k + ch];
            let gb = &mut self.gradient[b as usize * k + ch];
            for i in 0..4 {
                gb[i] += ga[i];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::holds;

    /// The attribute error against its definition: for each triangle of the attribute vertex,
    /// area × Σ over the weighted channels of (the triangle's interpolation at `p`'s projection
    /// onto its plane − the target's value)², summed; merged vertices sum both triangle sets.
    #[test]
    fn attribute_error_is_the_area_weighted_interpolation_misfit() {
        let mut rng = 0x1234_5678_u64;
        let mut unit = move || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let n = 6;
        let pos: Vec<[f32; 3]> = (0..n).map(|_| [unit(), unit(), unit()]).collect();
        let uvs: Vec<[f32; 2]> = (0..n).map(|_| [unit(), unit()]).collect();
        let normals: Vec<[f32; 3]> = (0..n).map(|_| [unit(), unit(), unit()]).collect();
        let tris = [[0u32, 1, 2], [0, 2, 3], [0, 3, 4], [5, 1, 0]];
        let map = crate::morph::TopologyMap::identity(n);
        let rule = SeamRule::new(&map, Some(&uvs)).with_normals(Some(&normals));
        let options = SimplifyOptions {
            uv_weight: 2.0,
            normal_weight: 0.5,
            ..Default::default()
        };
        let mut metric = AttributeMetric::new(&pos, &tris, &tris, &rule, &options).unwrap();
        let values = |v: u32| {
            let (uv, nm) = (uvs[v as usize], normals[v as usize]);
            [
                uv[0] * 2.0,
                uv[1] * 2.0,
                nm[0] * 0.5,
                nm[1] * 0.5,
                nm[2] * 0.5,
            ]
            .map(f64::from)
        };
        let misfit = |t: [u32; 3], p: DVec3, b: u32| {
            let [a, bb, c] = t.map(|v| dvec(pos[v as usize]));
            let normal = (bb - a).cross(c - a);
            let q = p - normal * (p - a).dot(normal) / normal.length_squared();
            let whole = normal.length();
            let l1 = (q - a).cross(c - a).dot(normal) / (whole * whole);
            let l2 = (bb - a).cross(q - a).dot(normal) / (whole * whole);
            let x = [values(t[0]), values(t[1]), values(t[2])];
            let target = values(b);
            0.5 * whole
                * (0..5)
                    .map(|k| {
                        let fitted = x[0][k] * (1.0 - l1 - l2) + x[1][k] * l1 + x[2][k] * l2;
                        (fitted - target[k]).powi(2)
                    })
                    .sum::<f64>()
        };
        let oracle = |of: &[u32], p: DVec3, b: u32| {
            tris.iter()
                .flat_map(|&t| of.iter().filter(move |&&a| holds(t, a)).map(move |_| t))
                .map(|t| misfit(t, p, b))
                .sum::<f64>()
        };
        let close = |got: f64, want: f64| (got - want).abs() <= 1e-9 * (1.0 + want.abs());
        for a in 0..n as u32 {
            for b in 0..n as u32 {
                let p = DVec3::new(unit() as f64, unit() as f64, unit() as f64);
                let (got, want) = (metric.error(a, p, b), oracle(&[a], p, b));
                assert!(close(got, want), "{a} -> {b} at {p}: {got} vs {want}");
            }
        }
        metric.merge(0, 1);
        let p = DVec3::new(0.3, 0.7, 0.2);
        let (got, want) = (metric.error(1, p, 4), oracle(&[0, 1], p, 4));
        assert!(close(got, want), "merged: {got} vs {want}");
    }
}
