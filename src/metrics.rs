//! Geometric error between two triangle meshes by surface sampling, as Metro
//! (Cignoni et al.) measures it: points spread over one surface by area, plus
//! its vertices, each measured to the exact closest point of the other surface;
//! then the other way round. The symmetric Hausdorff distance is the larger of
//! the two one-sided maxima.
//!
//! This module owns the sampling (deterministic: an in-file SplitMix64 seeded
//! by the caller), the closest-point query (Ericson's region test, in `f64`)
//! and the bounding volume hierarchy that accelerates it. Benchmarks that
//! compare many LODs against one original build its [`SurfaceIndex`] and
//! samples once and call [`directed_error`] per LOD; one-off comparisons call
//! [`hausdorff`].

use glam::DVec3;

use crate::mesh::{validate_indices, MeshError};

/// Distances from the samples of one surface to the other surface (object units).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DirectedError {
    pub max: f64,
    pub mean: f64,
    pub rms: f64,
    pub samples: usize,
}

/// Both directions and their symmetric summary: each symmetric figure is the
/// larger of the two one-sided figures (for `hausdorff` that is the definition;
/// for `mean` and `rms` it is the conservative choice).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    pub hausdorff: f64,
    pub rms: f64,
    pub mean: f64,
    pub a_to_b: DirectedError,
    pub b_to_a: DirectedError,
}

/// Seeds used by [`hausdorff`] for the two surfaces: fixed, so every
/// benchmark run measures the same points.
const SEED_A: u64 = 0x6d6f_7270_686c_6f64;
const SEED_B: u64 = 0x9e37_79b9_7f4a_7c15;

/// Symmetric error between meshes `a` and `b`, with `samples` area-weighted
/// points on each surface plus each surface's used vertices.
///
/// A surface without any area has no samples but its vertices; against a
/// surface without triangles every distance is infinite.
pub fn hausdorff(
    a_positions: &[[f32; 3]],
    a_triangles: &[[u32; 3]],
    b_positions: &[[f32; 3]],
    b_triangles: &[[u32; 3]],
    samples: usize,
) -> Result<ErrorStats, MeshError> {
    let a_index = SurfaceIndex::new(a_positions, a_triangles)?;
    let b_index = SurfaceIndex::new(b_positions, b_triangles)?;
    let a_samples = sample_surface(a_positions, a_triangles, samples, SEED_A)?;
    let b_samples = sample_surface(b_positions, b_triangles, samples, SEED_B)?;
    Ok(symmetric(
        directed_error(&a_samples, &b_index),
        directed_error(&b_samples, &a_index),
    ))
}

/// Combines the two directions into [`ErrorStats`].
pub fn symmetric(a_to_b: DirectedError, b_to_a: DirectedError) -> ErrorStats {
    ErrorStats {
        hausdorff: a_to_b.max.max(b_to_a.max),
        rms: a_to_b.rms.max(b_to_a.rms),
        mean: a_to_b.mean.max(b_to_a.mean),
        a_to_b,
        b_to_a,
    }
}

/// One-sided error: every sample's distance to the surface in `target`.
pub fn directed_error(samples: &[DVec3], target: &SurfaceIndex) -> DirectedError {
    let mut out = DirectedError {
        samples: samples.len(),
        ..DirectedError::default()
    };
    if samples.is_empty() {
        return out;
    }
    let mut sum = 0.0;
    let mut sum_sq = 0.0;
    for &p in samples {
        let d2 = target.distance_squared(p);
        let d = d2.sqrt();
        out.max = out.max.max(d);
        sum += d;
        sum_sq += d2;
    }
    out.mean = sum / samples.len() as f64;
    out.rms = (sum_sq / samples.len() as f64).sqrt();
    out
}

fn dvec(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// SplitMix64 (Steele, Lea, Flood): tiny, fast, and good enough to scatter
/// sample points; kept here so results never depend on an external crate's
/// algorithm changes.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`, from the top 53 bits.
    fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// `count` points spread uniformly by area over the triangles (a triangle is
/// picked with probability proportional to its area, then a uniform point in
/// it), followed by every vertex the triangles use. Deterministic for a seed.
pub fn sample_surface(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    count: usize,
    seed: u64,
) -> Result<Vec<DVec3>, MeshError> {
    validate_indices(triangles, positions.len())?;
    let corners = |t: &[u32; 3]| t.map(|v| dvec(positions[v as usize]));
    let mut cumulative = Vec::with_capacity(triangles.len());
    let mut total = 0.0;
    for t in triangles {
        let [a, b, c] = corners(t);
        total += 0.5 * (b - a).cross(c - a).length();
        cumulative.push(total);
    }
    let mut out = Vec::with_capacity(count + positions.len());
    if total > 0.0 {
        let mut rng = SplitMix64(seed);
        for _ in 0..count {
            let r = rng.next_f64() * total;
            let t = cumulative
                .partition_point(|&c| c <= r)
                .min(triangles.len() - 1);
            let [a, b, c] = corners(&triangles[t]);
            // Square root of the first variate makes the point uniform over the area.
            let s = rng.next_f64().sqrt();
            let u = rng.next_f64();
            out.push(a * (1.0 - s) + b * (s * (1.0 - u)) + c * (s * u));
        }
    }
    let mut used = vec![false; positions.len()];
    for t in triangles {
        for &v in t {
            if !std::mem::replace(&mut used[v as usize], true) {
                out.push(dvec(positions[v as usize]));
            }
        }
    }
    Ok(out)
}

/// Triangles per BVH leaf: small leaves keep the exact triangle tests few.
const LEAF_SIZE: usize = 4;

/// A BVH node: a leaf holds `count > 0` triangles from `first`; an inner node
/// (`count == 0`) has children `first` and `second`.
#[derive(Clone, Copy, Debug)]
struct Node {
    min: DVec3,
    max: DVec3,
    first: u32,
    second: u32,
    count: u32,
}

/// A triangle surface prepared for closest-point queries: a bounding volume
/// hierarchy over the triangles, split at the median centroid along the
/// longest axis (so depth stays about `log2(n / 4)`).
#[derive(Clone, Debug, Default)]
pub struct SurfaceIndex {
    triangles: Vec<[DVec3; 3]>,
    nodes: Vec<Node>,
}

impl SurfaceIndex {
    pub fn new(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Result<Self, MeshError> {
        validate_indices(triangles, positions.len())?;
        let tris: Vec<[DVec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|v| dvec(positions[v as usize])))
            .collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * tris.len() / LEAF_SIZE + 1);
        if !tris.is_empty() {
            build(&mut nodes, &tris, &mut order, 0);
        }
        let triangles = order.iter().map(|&t| tris[t as usize]).collect();
        Ok(Self { triangles, nodes })
    }

    /// Squared distance from `p` to the nearest point of the surface
    /// (infinite for an empty surface).
    pub fn distance_squared(&self, p: DVec3) -> f64 {
        let mut best = f64::INFINITY;
        if self.nodes.is_empty() {
            return best;
        }
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = self.nodes[i as usize];
            if box_distance_squared(&node, p) >= best {
                continue;
            }
            if node.count > 0 {
                let s = node.first as usize;
                for t in &self.triangles[s..s + node.count as usize] {
                    best = best.min((closest_point(p, t[0], t[1], t[2]) - p).length_squared());
                }
                continue;
            }
            let (a, b) = (node.first, node.second);
            let da = box_distance_squared(&self.nodes[a as usize], p);
            let db = box_distance_squared(&self.nodes[b as usize], p);
            // Nearer child last, so it is popped first and tightens `best` early.
            let (near, far, d_far) = if da <= db { (a, b, db) } else { (b, a, da) };
            if d_far < best {
                stack.push(far);
            }
            stack.push(near);
        }
        best
    }
}

fn build(nodes: &mut Vec<Node>, tris: &[[DVec3; 3]], order: &mut [u32], first: usize) -> u32 {
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = DVec3::splat(f64::NEG_INFINITY);
    for &t in order.iter() {
        for p in tris[t as usize] {
            min = min.min(p);
            max = max.max(p);
        }
    }
    let index = nodes.len() as u32;
    nodes.push(Node {
        min,
        max,
        first: first as u32,
        second: 0,
        count: order.len() as u32,
    });
    if order.len() <= LEAF_SIZE {
        return index;
    }
    let extent = max - min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let centroid = |t: u32| {
        let [a, b, c] = tris[t as usize];
        (a + b + c)[axis]
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| centroid(a).total_cmp(&centroid(b)));
    let (left, right) = order.split_at_mut(mid);
    let l = build(nodes, tris, left, first);
    let r = build(nodes, tris, right, first + mid);
    let node = &mut nodes[index as usize];
    node.first = l;
    node.second = r;
    node.count = 0;
    index
}

fn box_distance_squared(node: &Node, p: DVec3) -> f64 {
    let d = (node.min - p).max(p - node.max).max(DVec3::ZERO);
    d.length_squared()
}

/// `n / d`, or 0 where `d` is not positive (a degenerate edge or triangle).
fn ratio(n: f64, d: f64) -> f64 {
    if d > 0.0 {
        n / d
    } else {
        0.0
    }
}

/// The exact closest point to `p` on triangle `abc` (Ericson, *Real-Time
/// Collision Detection*, 5.1.5): classify `p` against the Voronoi regions of
/// the vertices, then the edges, else project onto the face.
pub fn closest_point(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * ratio(d1, d1 - d3);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * ratio(d2, d2 - d6);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ratio(d4 - d3, (d4 - d3) + (d5 - d6));
    }
    let denom = va + vb + vc;
    if denom > 0.0 {
        a + ab * (vb / denom) + ac * (vc / denom)
    } else {
        // Zero-area triangle that no region test caught: its closest point is
        // on one of its edges.
        [(a, b), (b, c), (c, a)]
            .map(|(s, e)| {
                s + (e - s) * ratio((p - s).dot(e - s), (e - s).length_squared()).clamp(0.0, 1.0)
            })
            .into_iter()
            .min_by(|x, y| {
                (*x - p)
                    .length_squared()
                    .total_cmp(&(*y - p).length_squared())
            })
            .unwrap_or(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::tests::grid;

    #[test]
    fn identical_meshes_have_zero_error() {
        let (p, t) = grid(8, 0.0);
        let e = hausdorff(&p, &t, &p, &t, 2000).unwrap();
        assert!(e.hausdorff < 1e-6, "{e:?}");
        assert!(e.rms < 1e-6, "{e:?}");
        assert_eq!(e.a_to_b.samples, 2000 + 81);
    }

    #[test]
    fn offset_plane_error_is_the_offset() {
        let (a, ta) = grid(4, 0.0);
        let (b, tb) = grid(7, 0.25);
        let e = hausdorff(&a, &ta, &b, &tb, 3000).unwrap();
        for d in [e.hausdorff, e.rms, e.mean, e.a_to_b.max, e.b_to_a.max] {
            assert!((d - 0.25).abs() < 1e-6, "{e:?}");
        }
    }

    #[test]
    fn small_known_case() {
        // A unit right triangle against the same triangle with its apex
        // raised by h: from a to b the worst point is the apex (distance
        // h/sqrt(1+h²) to the tilted plane), from b to a it is the raised apex (h).
        let h = 0.5f32;
        let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let b = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, h]];
        let t = [[0u32, 1, 2]];
        let e = hausdorff(&a, &t, &b, &t, 5000).unwrap();
        let h = h as f64;
        assert!((e.b_to_a.max - h).abs() < 1e-6, "{e:?}");
        assert!(
            (e.a_to_b.max - h / (1.0 + h * h).sqrt()).abs() < 1e-6,
            "{e:?}"
        );
        assert!((e.hausdorff - h).abs() < 1e-6);
        // Mean of b→a: the height over a uniform triangle is h times the mean
        // of the barycentric coordinate, 1/3 (the vertices nudge it slightly).
        assert!((e.b_to_a.mean - h / 3.0).abs() < 0.01, "{e:?}");
    }

    #[test]
    fn closest_point_regions() {
        let a = DVec3::new(0.0, 0.0, 0.0);
        let b = DVec3::new(1.0, 0.0, 0.0);
        let c = DVec3::new(0.0, 1.0, 0.0);
        let cases = [
            (DVec3::new(-1.0, -1.0, 2.0), a),
            (DVec3::new(2.0, -0.5, 0.0), b),
            (DVec3::new(-0.1, 3.0, 0.0), c),
            (DVec3::new(0.5, -2.0, 1.0), DVec3::new(0.5, 0.0, 0.0)),
            (DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.5, 0.5, 0.0)),
            (DVec3::new(0.2, 0.3, -4.0), DVec3::new(0.2, 0.3, 0.0)),
        ];
        for (p, want) in cases {
            assert!((closest_point(p, a, b, c) - want).length() < 1e-12, "{p}");
        }
        // Degenerate (collinear) triangle: nearest point of the segment.
        let q = closest_point(DVec3::new(0.5, 1.0, 0.0), a, b, DVec3::new(2.0, 0.0, 0.0));
        assert!((q - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-12);
    }

    #[test]
    fn bvh_matches_brute_force() {
        let (p, t) = grid(10, 0.0);
        // Bend the grid so the BVH has to pick between overlapping boxes.
        let p: Vec<[f32; 3]> = p
            .iter()
            .map(|v| [v[0], v[1], (v[0] * 6.0).sin() * 0.3])
            .collect();
        let index = SurfaceIndex::new(&p, &t).unwrap();
        let mut rng = SplitMix64(7);
        for _ in 0..500 {
            let q = DVec3::new(
                rng.next_f64() * 1.4 - 0.2,
                rng.next_f64() * 1.4 - 0.2,
                rng.next_f64() - 0.5,
            );
            let brute = t
                .iter()
                .map(|tri| {
                    let [a, b, c] = tri.map(|v| dvec(p[v as usize]));
                    (closest_point(q, a, b, c) - q).length_squared()
                })
                .fold(f64::INFINITY, f64::min);
            assert!((index.distance_squared(q) - brute).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_index_is_an_error() {
        let p = [[0.0f32; 3]; 3];
        let err = hausdorff(&p, &[[0, 1, 3]], &p, &[[0, 1, 2]], 10).unwrap_err();
        assert!(matches!(
            err,
            MeshError::IndexOutOfRange {
                triangle: 0,
                index: 3,
                ..
            }
        ));
    }
}
