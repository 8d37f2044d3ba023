//! How good a correspondence is: the measure of issue 25, on any two poses of
//! one triangulation (a supermesh's `V(0)`, `V(1)`, or a same-connectivity
//! pair). Definitions (docs/DESIGN.md, "Correspondence measure"):
//!
//! * weights `wᵢ`: the mean of vertex `i`'s area share at `t = 0` and at
//!   `t = 1` (a third of its triangles' areas over the total), fixed for all
//!   `t`, summing to 1;
//! * normalised ends `qᵏᵢ = (pᵏᵢ − cₖ) / √Iₖ` with `cₖ = Σ wᵢ pᵏᵢ` and
//!   `Iₖ = Σ wᵢ ‖pᵏᵢ − cₖ‖²`: centred, unit RMS radius, not rotated;
//! * `s(t) = √I(t) / ((1 − t) √I₀ + t √I₁)` with `I(t)` the weighted second
//!   moment of `(1 − t) p⁰ + t p¹` about its weighted centroid: the RMS
//!   radius of the in-between against the blend of the ends' (1 for a scaled
//!   copy under the identity map). Normalised, `I₀ = I₁ = 1`;
//! * `D = Σ wᵢ ‖q⁰ᵢ − q¹ᵢ‖²`, with `I(½) = (I₀ + I₁)/2 − D/4` exactly, so
//!   `s(½) = √(1 − D/4)` normalised: D is the objective the alignment
//!   minimises. `D` as placed uses `p` instead of `q` (file units²);
//! * area and diagonal ratios: `√area(t)` and the bounding-box diagonal of
//!   the normalised in-between against the blend of the ends';
//! * distortion of the map A → B, per triangle of the normalised poses (B
//!   scaled to A's total area): the singular values `σ₁ ≥ σ₂` of the linear
//!   map taking the triangle at `t = 0` to it at `t = 1`; area distortion
//!   `σ₁σ₂`, angle distortion `σ₁/σ₂` (1 for a conformal map); percentiles
//!   weighted by the triangles' mean area share. Triangles of zero area in
//!   either pose (slivers of the overlay) have no such map and are counted
//!   as `degenerate` (their area share).

use glam::DVec3;

/// The in-betweens measured: `t = ¼, ½, ¾`.
pub const MEASURED_T: [f64; 3] = [0.25, 0.5, 0.75];

/// Distortion of the map from the `t = 0` pose to the `t = 1` pose.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Distortion {
    /// Area distortion `σ₁σ₂`: 5th, 50th and 95th area-weighted percentiles.
    pub area: [f64; 3],
    /// Angle distortion `σ₁/σ₂ ≥ 1`: 50th and 95th area-weighted percentiles.
    pub angle: [f64; 2],
    /// Area share of the triangles with zero area in either pose.
    pub degenerate: f64,
}

/// How B is placed against A under the correspondence: the similarity
/// transform (turn, move, scale) that best takes A's end onto B's (weighted
/// least squares over the corresponding points, centroids and RMS radii as
/// in the measure). The normalised measure ignores it; the ends as placed,
/// and so the morph, include it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Placement {
    /// Angle (degrees) of the best rotation from A's normalised end to B's.
    pub turn_degrees: f64,
    /// `D` of the normalised ends with A's turned by that rotation (against
    /// [`Correspondence::d`]: how much of the mismatch the turn explains).
    pub turned_d: f64,
    /// Distance between the weighted centroids over A's RMS radius.
    pub offset: f64,
    /// B's RMS radius over A's.
    pub scale: f64,
}

impl Placement {
    /// Whether B is placed differently from A, given `d` (the normalised
    /// ends' [`Correspondence::d`]): turned by more than 20° where the turn
    /// explains at least half of `d` (between different shapes the best
    /// turn is mostly their difference, not their placement), moved by more
    /// than half A's RMS radius, or scaled outside `[0.67, 1.5]`. The morph
    /// then also turns, moves or scales the shape.
    pub fn differs(&self, d: f64) -> bool {
        (self.turn_degrees > 20.0 && self.turned_d < 0.5 * d)
            || self.offset > 0.5
            || !(0.67..=1.5).contains(&self.scale)
    }
}

/// The correspondence measure (module docs) of two poses of one triangulation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Correspondence {
    /// `s(t)` at [`MEASURED_T`], normalised ends.
    pub s: [f64; 3],
    /// `√area(t)` over the blend of the ends', normalised.
    pub area_ratio: [f64; 3],
    /// Bounding-box diagonal over the blend of the ends', normalised.
    pub diagonal_ratio: [f64; 3],
    /// `D` of the normalised ends (`s(½) = √(1 − D/4)`).
    pub d: f64,
    /// `s(t)` of the ends as placed.
    pub s_placed: [f64; 3],
    /// `D` of the ends as placed (file units squared).
    pub d_placed: f64,
    /// RMS radius `√Iₖ` of each end as placed.
    pub rms_radius: [f64; 2],
    pub distortion: Distortion,
    /// The similarity that best takes A's end onto B's.
    pub placement: Placement,
}

fn d3(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

fn triangle_area(p: &[DVec3], t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|v| p[v as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// Each vertex's area share at one pose (sums to 1 over used vertices).
fn area_shares(p: &[DVec3], triangles: &[[u32; 3]]) -> Vec<f64> {
    let mut share = vec![0.0; p.len()];
    let mut total = 0.0;
    for t in triangles {
        let a = triangle_area(p, t);
        total += a;
        for &v in t {
            share[v as usize] += a / 3.0;
        }
    }
    if total > 0.0 {
        share.iter_mut().for_each(|s| *s /= total);
    }
    share
}

/// Weighted centroid and second moment about it.
fn moments(p: &[DVec3], w: &[f64]) -> (DVec3, f64) {
    let c: DVec3 = p.iter().zip(w).map(|(&x, &w)| x * w).sum();
    let i = p
        .iter()
        .zip(w)
        .map(|(&x, &w)| w * (x - c).length_squared())
        .sum();
    (c, i)
}

fn lerp(a: &[DVec3], b: &[DVec3], t: f64) -> Vec<DVec3> {
    a.iter().zip(b).map(|(&x, &y)| x.lerp(y, t)).collect()
}

fn diagonal(p: &[DVec3], used: &[bool]) -> f64 {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for (&x, _) in p.iter().zip(used).filter(|(_, &u)| u) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if lo.x <= hi.x {
        (hi - lo).length()
    } else {
        0.0
    }
}

/// `(s(t), D)` for poses `p0`, `p1` with weights `w`: the RMS radius of the
/// in-between about its weighted centroid over the blend of the ends'.
fn spread(p0: &[DVec3], p1: &[DVec3], w: &[f64]) -> ([f64; 3], f64) {
    let (_, i0) = moments(p0, w);
    let (_, i1) = moments(p1, w);
    let s = MEASURED_T.map(|t| {
        let (_, it) = moments(&lerp(p0, p1, t), w);
        let blend = (1.0 - t) * i0.sqrt() + t * i1.sqrt();
        if blend > 0.0 {
            it.sqrt() / blend
        } else {
            1.0
        }
    });
    let d = p0
        .iter()
        .zip(p1)
        .zip(w)
        .map(|((&x, &y), &w)| w * (x - y).length_squared())
        .sum();
    (s, d)
}

/// Measures the correspondence `v0[i] ↔ v1[i]` over `triangles` (module docs).
pub fn measure(triangles: &[[u32; 3]], v0: &[[f32; 3]], v1: &[[f32; 3]]) -> Correspondence {
    let p0: Vec<DVec3> = v0.iter().map(|&p| d3(p)).collect();
    let p1: Vec<DVec3> = v1.iter().map(|&p| d3(p)).collect();
    let (s0, s1) = (area_shares(&p0, triangles), area_shares(&p1, triangles));
    let w: Vec<f64> = s0.iter().zip(&s1).map(|(a, b)| 0.5 * (a + b)).collect();
    let (s_placed, d_placed) = spread(&p0, &p1, &w);
    let normalise = |p: &[DVec3]| -> (Vec<DVec3>, f64) {
        let (c, i) = moments(p, &w);
        let r = if i > 0.0 { i.sqrt() } else { 1.0 };
        (p.iter().map(|&x| (x - c) / r).collect(), r)
    };
    let (q0, r0) = normalise(&p0);
    let (q1, r1) = normalise(&p1);
    let turn = super::align::nearest_rotation(
        q0.iter()
            .zip(&q1)
            .zip(&w)
            .map(|((&x, &y), &w)| {
                glam::DMat3::from_cols(y * (w * x.x), y * (w * x.y), y * (w * x.z))
            })
            .fold(glam::DMat3::ZERO, |m, x| m + x),
    );
    let cosine = 0.5 * (turn.x_axis.x + turn.y_axis.y + turn.z_axis.z - 1.0);
    let placement = Placement {
        turn_degrees: cosine.clamp(-1.0, 1.0).acos().to_degrees(),
        turned_d: q0
            .iter()
            .zip(&q1)
            .zip(&w)
            .map(|((&x, &y), &w)| w * (y - turn * x).length_squared())
            .sum(),
        offset: (moments(&p1, &w).0 - moments(&p0, &w).0).length() / r0,
        scale: r1 / r0,
    };
    let (s, d) = spread(&q0, &q1, &w);
    let mut used = vec![false; p0.len()];
    for t in triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let area = |p: &[DVec3]| triangles.iter().map(|t| triangle_area(p, t)).sum::<f64>();
    let (a0, a1) = (area(&q0).sqrt(), area(&q1).sqrt());
    let (g0, g1) = (diagonal(&q0, &used), diagonal(&q1, &used));
    let ratio = |x: f64, e0: f64, e1: f64, t: f64| {
        let blend = (1.0 - t) * e0 + t * e1;
        if blend > 0.0 {
            x / blend
        } else {
            1.0
        }
    };
    let mut area_ratio = [0.0; 3];
    let mut diagonal_ratio = [0.0; 3];
    for (k, &t) in MEASURED_T.iter().enumerate() {
        let q = lerp(&q0, &q1, t);
        area_ratio[k] = ratio(area(&q).sqrt(), a0, a1, t);
        diagonal_ratio[k] = ratio(diagonal(&q, &used), g0, g1, t);
    }
    Correspondence {
        s,
        area_ratio,
        diagonal_ratio,
        d,
        s_placed,
        d_placed,
        rms_radius: [r0, r1],
        distortion: distortion(triangles, &q0, &q1),
        placement,
    }
}

/// `v1` (B's end) moved onto `v0` (A's) by the similarity of [`Placement`]:
/// `p ↦ c₀ + (r₀ / r₁) Rᵀ (p − c₁)`, with the weighted centroids `cₖ`, RMS
/// radii `rₖ` and the turn `R` that best takes A's normalised end onto B's.
/// For a morph of the shape alone when B is placed differently (the
/// normalised measure is unchanged but for the turn: its `D` becomes
/// [`Placement::turned_d`]).
pub fn fit_b_onto_a(triangles: &[[u32; 3]], v0: &[[f32; 3]], v1: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let p0: Vec<DVec3> = v0.iter().map(|&p| d3(p)).collect();
    let p1: Vec<DVec3> = v1.iter().map(|&p| d3(p)).collect();
    let (s0, s1) = (area_shares(&p0, triangles), area_shares(&p1, triangles));
    let w: Vec<f64> = s0.iter().zip(&s1).map(|(a, b)| 0.5 * (a + b)).collect();
    let ((c0, i0), (c1, i1)) = (moments(&p0, &w), moments(&p1, &w));
    let radius = |i: f64| if i > 0.0 { i.sqrt() } else { 1.0 };
    let (r0, r1) = (radius(i0), radius(i1));
    let turn = super::align::nearest_rotation(
        p0.iter()
            .zip(&p1)
            .zip(&w)
            .map(|((&x, &y), &w)| {
                let (x, y) = ((x - c0) / r0, (y - c1) / r1);
                glam::DMat3::from_cols(y * (w * x.x), y * (w * x.y), y * (w * x.z))
            })
            .fold(glam::DMat3::ZERO, |m, x| m + x),
    );
    let back = turn.transpose() * (r0 / r1);
    p1.iter()
        .map(|&p| (c0 + back * (p - c1)).as_vec3().to_array())
        .collect()
}

/// Singular values `σ₁ ≥ σ₂` of the linear map taking triangle `p` to `q`
/// (each in its own plane); `None` when either has no area.
pub(crate) fn singular_values(p: [DVec3; 3], q: [DVec3; 3]) -> Option<(f64, f64)> {
    // Each triangle's edges in an orthonormal frame of its plane.
    let frame = |t: [DVec3; 3]| -> Option<[[f64; 2]; 2]> {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let x = e1.try_normalize()?;
        let n = e1.cross(e2).try_normalize()?;
        let y = n.cross(x);
        Some([[e1.dot(x), e2.dot(x)], [0.0, e2.dot(y)]])
    };
    let (ep, eq) = (frame(p)?, frame(q)?);
    // J = Eq · Ep⁻¹ (Ep upper triangular).
    let det_p = ep[0][0] * ep[1][1];
    if det_p.abs() < f64::MIN_POSITIVE || !det_p.is_finite() {
        return None;
    }
    let inv = [
        [ep[1][1] / det_p, -ep[0][1] / det_p],
        [0.0, ep[0][0] / det_p],
    ];
    let j = [
        [
            eq[0][0] * inv[0][0] + eq[0][1] * inv[1][0],
            eq[0][0] * inv[0][1] + eq[0][1] * inv[1][1],
        ],
        [
            eq[1][0] * inv[0][0] + eq[1][1] * inv[1][0],
            eq[1][0] * inv[0][1] + eq[1][1] * inv[1][1],
        ],
    ];
    let frob = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
    let det = (j[0][0] * j[1][1] - j[0][1] * j[1][0]).abs();
    let root = (frob * frob - 4.0 * det * det).max(0.0).sqrt();
    let s1 = (0.5 * (frob + root)).sqrt();
    let s2 = if s1 > 0.0 { det / s1 } else { 0.0 };
    (s2 > 0.0 && s1.is_finite()).then_some((s1, s2))
}

/// Area-weighted percentile `f` of `(value, weight)` pairs.
fn percentile(values: &mut [(f64, f64)], f: f64) -> f64 {
    values.sort_by(|x, y| x.0.total_cmp(&y.0));
    let total: f64 = values.iter().map(|v| v.1).sum();
    let mut acc = 0.0;
    for &(v, w) in values.iter() {
        acc += w;
        if acc >= f * total {
            return v;
        }
    }
    values.last().map_or(1.0, |v| v.0)
}

fn distortion(triangles: &[[u32; 3]], q0: &[DVec3], q1: &[DVec3]) -> Distortion {
    let total = |q: &[DVec3]| triangles.iter().map(|t| triangle_area(q, t)).sum::<f64>();
    let (t0, t1) = (total(q0), total(q1));
    if t0 <= 0.0 || t1 <= 0.0 {
        return Distortion::default();
    }
    // B scaled to A's total area, so an area-preserving map has σ₁σ₂ = 1.
    let scale = (t0 / t1).sqrt();
    let mut area = Vec::with_capacity(triangles.len());
    let mut angle = Vec::with_capacity(triangles.len());
    let mut degenerate = 0.0;
    for t in triangles {
        let weight = 0.5 * (triangle_area(q0, t) / t0 + triangle_area(q1, t) / t1);
        let p = t.map(|v| q0[v as usize]);
        let q = t.map(|v| q1[v as usize] * scale);
        match singular_values(p, q) {
            Some((s1, s2)) => {
                area.push((s1 * s2, weight));
                angle.push((s1 / s2, weight));
            }
            None => degenerate += weight,
        }
    }
    Distortion {
        area: [0.05, 0.5, 0.95].map(|f| percentile(&mut area, f)),
        angle: [0.5, 0.95].map(|f| percentile(&mut angle, f)),
        degenerate,
    }
}

impl std::fmt::Display for Correspondence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let row = |x: [f64; 3]| format!("{:.3} {:.3} {:.3}", x[0], x[1], x[2]);
        writeln!(
            f,
            "  correspondence    s(¼ ½ ¾) {}, √area ratio {}, diagonal ratio {}, D {:.4} (normalised: centred, unit RMS radius)",
            row(self.s),
            row(self.area_ratio),
            row(self.diagonal_ratio),
            self.d
        )?;
        writeln!(
            f,
            "  as placed         s(¼ ½ ¾) {}, D {:.4e} (RMS radius A {:.4e}, B {:.4e})",
            row(self.s_placed),
            self.d_placed,
            self.rms_radius[0],
            self.rms_radius[1]
        )?;
        let p = &self.placement;
        writeln!(
            f,
            "  placement         B is A turned {:.1}° (D {:.4} turned), moved {:.2} and scaled ×{:.3} (RMS radius units of A){}",
            p.turn_degrees,
            p.turned_d,
            p.offset,
            p.scale,
            if p.differs(self.d) {
                ": placed differently, so the morph also turns, moves or scales the shape; fit B onto A by this similarity for a morph of the shape alone (`morphlod supermesh --fit`, or `fit_b_onto_a`; V(1) stays B as given otherwise)"
            } else {
                ""
            }
        )?;
        let d = &self.distortion;
        write!(
            f,
            "  map distortion    area p5 {:.3} p50 {:.3} p95 {:.3}, angle p50 {:.3} p95 {:.3}, degenerate {:.2e} of the area",
            d.area[0], d.area[1], d.area[2], d.angle[0], d.angle[1], d.degenerate
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> (Vec<[u32; 3]>, Vec<[f32; 3]>) {
        (
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
        )
    }

    #[test]
    fn a_similar_copy_under_the_identity_measures_one() {
        let (t, p) = tetra();
        let r = glam::DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 1.1);
        let q: Vec<[f32; 3]> = p
            .iter()
            .map(|&x| (r * d3(x) * 3.0 + DVec3::splat(5.0)).as_vec3().to_array())
            .collect();
        let m = measure(&t, &p, &q);
        // Normalised ends are not rotated: D counts the rotation.
        assert!(m.d > 0.1, "{m:?}");
        let m = measure(
            &t,
            &p,
            &p.iter()
                .map(|&x| x.map(|c| 2.0 * c - 1.0))
                .collect::<Vec<_>>(),
        );
        assert!(m.d < 1e-12, "{m:?}");
        for k in 0..3 {
            assert!((m.s[k] - 1.0).abs() < 1e-9, "{m:?}");
            assert!((m.area_ratio[k] - 1.0).abs() < 1e-6, "{m:?}");
            assert!((m.diagonal_ratio[k] - 1.0).abs() < 1e-6, "{m:?}");
            assert!((m.s_placed[k] - 1.0).abs() < 1e-9, "{m:?}");
        }
        assert!((m.distortion.area[1] - 1.0).abs() < 1e-6);
        assert!((m.distortion.angle[1] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn s_at_half_is_the_identity_with_d() {
        // Swap two vertices: a wrong correspondence shrinks the in-between.
        let (t, p) = tetra();
        let mut q = p.clone();
        q.swap(1, 3);
        let m = measure(&t, &p, &q);
        assert!(m.s[1] < 0.99, "{m:?}");
        assert!((m.s[1] - (1.0 - m.d / 4.0).sqrt()).abs() < 1e-9, "{m:?}");
    }

    #[test]
    fn singular_values_of_a_stretch() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let q = [DVec3::ZERO, DVec3::X * 3.0, DVec3::Z * 0.5];
        let (s1, s2) = singular_values(p, q).unwrap();
        assert!((s1 - 3.0).abs() < 1e-12 && (s2 - 0.5).abs() < 1e-12);
        assert!(singular_values(p, [DVec3::ZERO, DVec3::X, DVec3::X]).is_none());
    }
}
