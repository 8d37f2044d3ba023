//! Correspondence of the supermesh (issue 25): the measure
//! (`morph::supermesh::measure`, definitions in docs/DESIGN.md), landmarks
//! that close exactly without folds, bad landmark files, and man → camel with
//! the shipped landmarks.

use crate::common;
use std::path::Path;

use glam::DVec3;
use morphlod::mesh::IndexedMesh;
use morphlod::morph::supermesh::{
    measure, parse_landmarks, Connectivity, Origin, Side, Supermesh, SupermeshError,
    SupermeshOptions,
};
use proptest::prelude::*;

// ---------------------------------------------------------------- generators

struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A UV sphere `rings × segments` pushed in and out by radial noise and
/// stretched: a closed genus-0 mesh of any density.
fn blob(rings: u32, segments: u32, noise: f64, stretch: [f64; 3], seed: u64) -> IndexedMesh {
    let mut rng = Rng(seed);
    let mut p = vec![[0.0, 0.0, 1.0]];
    for i in 1..rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = std::f64::consts::TAU * j as f64 / segments as f64;
            p.push([
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ]);
        }
    }
    p.push([0.0, 0.0, -1.0]);
    let south = p.len() as u32 - 1;
    let id = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
    let mut t = Vec::new();
    for j in 0..segments {
        t.push([0, id(1, j), id(1, j + 1)]);
        t.push([south, id(rings - 1, j + 1), id(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let positions = p
        .iter()
        .map(|&q| {
            let r = 1.0 + noise * (rng.unit() - 0.5);
            (DVec3::from_array(q) * r * DVec3::from_array(stretch))
                .as_vec3()
                .to_array()
        })
        .collect();
    IndexedMesh::new(positions, t)
}

fn asset(name: &str) -> IndexedMesh {
    common::load_asset_mesh(name)
}

// ---------------------------------------------------------------- the measure

fn d64(p: [f32; 3]) -> DVec3 {
    DVec3::from_array(p.map(f64::from))
}

/// Twice the area vector of triangle `t` of `p`: its length is twice the area.
fn cross(p: &[DVec3], t: [u32; 3]) -> DVec3 {
    let [a, b, c] = t.map(|i| p[i as usize]);
    (b - a).cross(c - a)
}

/// The measure's weights (docs/DESIGN.md, "Correspondence measure"): per vertex the mean of
/// its area share at `t = 0` and at `t = 1`, a share being a third of its triangles' areas
/// over the total.
fn weights(tris: &[[u32; 3]], p0: &[DVec3], p1: &[DVec3]) -> Vec<f64> {
    let shares = |p: &[DVec3]| {
        let mut w = vec![0.0; p.len()];
        let total: f64 = tris.iter().map(|&t| cross(p, t).length() / 2.0).sum();
        for &t in tris {
            for i in t {
                w[i as usize] += cross(p, t).length() / 6.0 / total;
            }
        }
        w
    };
    let (w0, w1) = (shares(p0), shares(p1));
    w0.iter().zip(&w1).map(|(a, b)| 0.5 * (a + b)).collect()
}

/// The weighted centroid of `p` and its RMS radius about it.
fn centre_and_radius(p: &[DVec3], w: &[f64]) -> (DVec3, f64) {
    let c: DVec3 = p.iter().zip(w).map(|(&x, &w)| x * w).sum();
    let i: f64 = p
        .iter()
        .zip(w)
        .map(|(&x, &w)| w * x.distance_squared(c))
        .sum();
    (c, i.sqrt())
}

fn lerp(p0: &[DVec3], p1: &[DVec3], t: f64) -> Vec<DVec3> {
    p0.iter().zip(p1).map(|(&a, &b)| a.lerp(b, t)).collect()
}

/// The oracle of `s(t)`, straight from its definition: the RMS radius of the in-between about
/// its weighted centroid over the blend of the ends', the weights fixed.
fn s_of(p0: &[DVec3], p1: &[DVec3], w: &[f64], t: f64) -> f64 {
    let radius = |p: &[DVec3]| centre_and_radius(p, w).1;
    radius(&lerp(p0, p1, t)) / ((1.0 - t) * radius(p0) + t * radius(p1))
}

fn s_oracle(tris: &[[u32; 3]], v0: &[[f32; 3]], v1: &[[f32; 3]], t: f64) -> f64 {
    let p0: Vec<DVec3> = v0.iter().map(|&p| d64(p)).collect();
    let p1: Vec<DVec3> = v1.iter().map(|&p| d64(p)).collect();
    s_of(&p0, &p1, &weights(tris, &p0, &p1), t)
}

/// Everything the measure reports of the normalised ends, recomputed from the definitions in
/// docs/DESIGN.md apart from the library's code (its own helpers are not called): `s(t)`, `D`,
/// the √area and diagonal ratios at `t = ¼, ½, ¾`, and the map's distortion, each triangle's
/// singular values from the Gram matrices of its edges (`σ₁², σ₂²` the eigenvalues of
/// `G₀⁻¹G₁`, not the library's frames), percentiles by the triangles' mean area share.
struct Normalised {
    s: [f64; 3],
    d: f64,
    area_ratio: [f64; 3],
    diagonal_ratio: [f64; 3],
    area: [f64; 3],
    angle: [f64; 2],
    degenerate: f64,
}

fn normalised_oracle(tris: &[[u32; 3]], v0: &[[f32; 3]], v1: &[[f32; 3]]) -> Normalised {
    const T: [f64; 3] = [0.25, 0.5, 0.75];
    let p0: Vec<DVec3> = v0.iter().map(|&p| d64(p)).collect();
    let p1: Vec<DVec3> = v1.iter().map(|&p| d64(p)).collect();
    let w = weights(tris, &p0, &p1);
    let normalise = |p: &[DVec3]| -> Vec<DVec3> {
        let (c, r) = centre_and_radius(p, &w);
        p.iter().map(|&x| (x - c) / r).collect()
    };
    let (q0, q1) = (normalise(&p0), normalise(&p1));
    let d = (0..q0.len())
        .map(|i| w[i] * q0[i].distance_squared(q1[i]))
        .sum();
    let area = |q: &[DVec3]| {
        tris.iter()
            .map(|&t| cross(q, t).length() / 2.0)
            .sum::<f64>()
    };
    let diagonal = |q: &[DVec3]| {
        let lo = q.iter().fold(DVec3::INFINITY, |m, &x| m.min(x));
        let hi = q.iter().fold(DVec3::NEG_INFINITY, |m, &x| m.max(x));
        lo.distance(hi)
    };
    let ratio = |f: &dyn Fn(&[DVec3]) -> f64, t: f64| {
        f(&lerp(&q0, &q1, t)) / ((1.0 - t) * f(&q0) + t * f(&q1))
    };
    let root_area = |q: &[DVec3]| area(q).sqrt();
    // Distortion: B scaled to A's total area; per triangle σ₁σ₂ = √(det G₁ / det G₀) and
    // σ₁² + σ₂² = tr(G₀⁻¹G₁), G the Gram matrix of the edges from the first corner.
    let (total0, total1) = (area(&q0), area(&q1));
    let scale = (total0 / total1).sqrt();
    let mut values: Vec<(f64, f64, f64)> = Vec::new();
    let mut degenerate = 0.0;
    for &t in tris {
        let share = 0.25 * (cross(&q0, t).length() / total0 + cross(&q1, t).length() / total1);
        if cross(&q0, t).length() == 0.0 || cross(&q1, t).length() == 0.0 {
            degenerate += share;
            continue;
        }
        let gram = |q: &[DVec3], k: f64| {
            let [a, b, c] = t.map(|i| q[i as usize] * k);
            let (e, f) = (b - a, c - a);
            [e.dot(e), e.dot(f), f.dot(f)]
        };
        let ([a, b, c], [x, y, z]) = (gram(&q0, 1.0), gram(&q1, scale));
        let (det0, det1) = (a * c - b * b, x * z - y * y);
        // G₀⁻¹ = [c −b; −b a] / det0.
        let trace = (c * x - 2.0 * b * y + a * z) / det0;
        let product = (det1 / det0).sqrt();
        let root = (trace * trace - 4.0 * product * product).max(0.0).sqrt();
        let (s1, s2) = (((trace + root) / 2.0).sqrt(), ((trace - root) / 2.0).sqrt());
        values.push((s1 * s2, s1 / s2, share));
    }
    // The smallest value whose cumulative share reaches the fraction `f` of the total.
    let percentile = |key: fn(&(f64, f64, f64)) -> f64, f: f64| {
        let mut sorted: Vec<(f64, f64)> = values.iter().map(|v| (key(v), v.2)).collect();
        sorted.sort_by(|x, y| x.0.total_cmp(&y.0));
        let total: f64 = sorted.iter().map(|v| v.1).sum();
        let mut sum = 0.0;
        sorted
            .iter()
            .find(|v| {
                sum += v.1;
                sum >= f * total
            })
            .unwrap()
            .0
    };
    Normalised {
        s: T.map(|t| s_of(&q0, &q1, &w, t)),
        d,
        area_ratio: T.map(|t| ratio(&root_area, t)),
        diagonal_ratio: T.map(|t| ratio(&diagonal, t)),
        area: [0.05, 0.5, 0.95].map(|f| percentile(|v| v.0, f)),
        angle: [0.5, 0.95].map(|f| percentile(|v| v.1, f)),
        degenerate,
    }
}

/// A warp of space with no symmetry the measure could hide behind: twisted about z, stretched
/// along x, bulged on one side, turned and moved.
fn warp(p: DVec3) -> DVec3 {
    let (s, c) = (0.7 * p.z).sin_cos();
    let twisted = DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
    let bulged = DVec3::new(1.6 * twisted.x, twisted.y, twisted.z) * (1.0 + 0.3 * p.x.tanh());
    glam::DMat3::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), 0.5) * bulged
        + DVec3::new(0.5, -2.0, 1.0)
}

/// The measure against its definition: `s` as placed by the oracle on a wrongly matched copy
/// (where normalised `s(½)` is `√(1 − D/4)`), every normalised figure by the oracle on an
/// analytically warped copy with two triangles collapsed, then the identity and the placement.
#[test]
fn measure_matches_its_definition() {
    let a = blob(8, 12, 0.3, [1.0, 2.0, 0.5], 3);
    // A shuffled copy: the wrong correspondence shrinks the in-between.
    let mut b = a.clone();
    let n = b.positions.len();
    for i in 0..n / 2 {
        b.positions.swap(i, (i * 7 + 3) % n);
    }
    let m = measure(&a.triangles, &a.positions, &b.positions);
    for (k, t) in [0.25, 0.5, 0.75].into_iter().enumerate() {
        let o = s_oracle(&a.triangles, &a.positions, &b.positions, t);
        assert!(
            (m.s_placed[k] - o).abs() < 1e-9,
            "{k}: {} vs {o}",
            m.s_placed[k]
        );
    }
    assert!(m.s[1] < 0.9, "{m:?}");
    assert!((m.s[1] - (1.0 - m.d / 4.0).sqrt()).abs() < 1e-9, "{m:?}");
    // An analytically warped copy, two of its vertices merged in B (so the triangles on their
    // edge have no area there): every normalised figure against the oracle, each away from
    // what the identity gives.
    let mut warped = deformed(&a, warp);
    let [x, y, _] = a.triangles[40];
    warped.positions[x as usize] = warped.positions[y as usize];
    let m = measure(&a.triangles, &a.positions, &warped.positions);
    let o = normalised_oracle(&a.triangles, &a.positions, &warped.positions);
    let close = |what: &str, got: &[f64], want: &[f64]| {
        for (g, w) in got.iter().zip(want) {
            assert!(
                (g - w).abs() <= 1e-9 * w.abs().max(1.0),
                "{what}: {got:?}, oracle {want:?}"
            );
        }
    };
    close("s", &m.s, &o.s);
    close("D", &[m.d], &[o.d]);
    close("√area ratio", &m.area_ratio, &o.area_ratio);
    close("diagonal ratio", &m.diagonal_ratio, &o.diagonal_ratio);
    close("area distortion", &m.distortion.area, &o.area);
    close("angle distortion", &m.distortion.angle, &o.angle);
    close("degenerate", &[m.distortion.degenerate], &[o.degenerate]);
    for k in 0..3 {
        let t = [0.25, 0.5, 0.75][k];
        assert!(
            (m.s_placed[k] - s_oracle(&a.triangles, &a.positions, &warped.positions, t)).abs()
                < 1e-9
        );
        assert!(o.s[k] < 0.99 && o.d > 0.05, "s {:?}, D {}", o.s, o.d);
        assert!((o.area_ratio[k] - 1.0).abs() > 0.01, "{:?}", o.area_ratio);
        assert!(
            (o.diagonal_ratio[k] - 1.0).abs() > 0.01,
            "{:?}",
            o.diagonal_ratio
        );
    }
    assert!(
        o.area[0] < 0.9 && o.area[2] > 1.1 && o.angle[0] > 1.05,
        "{:?} {:?}",
        o.area,
        o.angle
    );
    assert!(
        o.degenerate > 0.0 && o.degenerate < 0.05,
        "{}",
        o.degenerate
    );
    // A scaled, moved copy under the identity: s = 1, D = 0, no distortion.
    let c: Vec<[f32; 3]> = a
        .positions
        .iter()
        .map(|p| p.map(|x| 4.0 * x - 2.0))
        .collect();
    let m = measure(&a.triangles, &a.positions, &c);
    assert!(m.d < 1e-10, "{m:?}");
    assert!(m.s.iter().all(|s| (s - 1.0).abs() < 1e-6), "{m:?}");
    assert!((m.distortion.angle[1] - 1.0).abs() < 1e-4, "{m:?}");
    assert!(m.d_placed > 1.0, "{m:?}");
    // Its placement: not turned, scaled ×4, moved; placed differently.
    let p = m.placement;
    assert!(
        p.turn_degrees < 0.01 && (p.scale - 4.0).abs() < 1e-4,
        "{p:?}"
    );
    assert!(p.offset > 0.5 && p.differs(m.d), "{p:?}");
    // A copy turned by 30° about z: that turn, in place; itself: nothing.
    let (sin, cos) = 30f32.to_radians().sin_cos();
    let turned: Vec<[f32; 3]> = a
        .positions
        .iter()
        .map(|p| [cos * p[0] - sin * p[1], sin * p[0] + cos * p[1], p[2]])
        .collect();
    let m = measure(&a.triangles, &a.positions, &turned);
    let p = m.placement;
    assert!(
        (p.turn_degrees - 30.0).abs() < 0.01 && p.turned_d < 1e-9,
        "{p:?}"
    );
    assert!((p.scale - 1.0).abs() < 1e-4 && p.differs(m.d), "{p:?}");
    let m = measure(&a.triangles, &a.positions, &a.positions);
    let p = m.placement;
    assert!(
        p.turn_degrees < 0.01 && p.offset < 1e-6 && !p.differs(m.d),
        "{p:?}"
    );
}

// ---------------------------------------------------------------- alignment

/// A mesh and a scaled, moved copy of it with its vertices shuffled (so
/// indices do not give the answer), overlaid: the automatic alignment
/// recovers about the identity (s ≈ 1, D ≈ 0).
#[test]
fn a_mesh_and_its_shuffled_scaled_copy_correspond() {
    let a = blob(16, 24, 0.2, [2.0, 1.0, 0.6], 9);
    let (b, _) = shuffled(&deformed(&a, |p| 2.5 * p + 1.0), 5);
    // The overlay, so the alignment is under test, not the renumbering.
    let options = SupermeshOptions {
        reuse_connectivity: false,
        ..SupermeshOptions::default()
    };
    let (_, r) = Supermesh::build(&a, &b, &options).unwrap();
    println!("{r}");
    let c = r.correspondence;
    assert!(c.s.iter().all(|&s| s > 0.98), "{c:?}");
    assert!(c.d < 0.05, "{c:?}");
    assert_eq!(r.fold_overs, 0);
}

/// The same, with the copy turned a quarter turn and more (placed
/// differently, as `man.off` is z-up and makehuman's body y-up): the
/// alignment follows the shapes, not the placement, so the report says B is
/// placed differently and B fitted onto A is the mesh itself (D 0.0000;
/// with the alignment by D as placed alone, checked by turning the choice
/// off, the fit leaves D 0.096).
#[test]
fn a_turned_copy_is_matched_by_shape_and_fits_back() {
    use morphlod::morph::supermesh::fit_b_onto_a;
    let a = blob(16, 24, 0.2, [2.0, 1.0, 0.6], 9);
    let turn = glam::DMat3::from_axis_angle(DVec3::new(1.0, 0.3, -0.2).normalize(), 1.9);
    let (b, _) = shuffled(&deformed(&a, |p| turn * p * 2.5 + 1.0), 5);
    let options = SupermeshOptions {
        reuse_connectivity: false,
        ..SupermeshOptions::default()
    };
    let (s, r) = Supermesh::build(&a, &b, &options).unwrap();
    let c = r.correspondence;
    assert!(c.placement.differs(c.d), "{r}");
    let fitted = measure(
        &s.triangles,
        &s.v0,
        &fit_b_onto_a(&s.triangles, &s.v0, &s.v1),
    );
    println!("{r}\nfitted: {fitted}");
    assert!(
        fitted.d < 0.05 && fitted.s.iter().all(|&x| x > 0.98),
        "{fitted:?}"
    );
    assert_eq!(r.fold_overs, 0);
}

// ------------------------------------- a mesh and a deformed copy of itself

/// `mesh` with each vertex moved by `f` (same indices).
fn deformed(mesh: &IndexedMesh, f: impl Fn(DVec3) -> DVec3) -> IndexedMesh {
    let positions = mesh
        .positions
        .iter()
        .map(|&p| f(DVec3::from_array(p.map(f64::from))).as_vec3().to_array())
        .collect();
    IndexedMesh::new(positions, mesh.triangles.clone())
}

/// `mesh` with its vertices renumbered at random (the same surface), so
/// indices do not give the correspondence; new vertex `i` is old `order[i]`.
fn shuffled(mesh: &IndexedMesh, seed: u64) -> (IndexedMesh, Vec<u32>) {
    let n = mesh.vertex_count();
    let mut rng = Rng(seed);
    let mut order: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        order.swap(i, (rng.unit() * (i + 1) as f64) as usize % (i + 1));
    }
    let mut inverse = vec![0u32; n];
    for (new, &old) in order.iter().enumerate() {
        inverse[old as usize] = new as u32;
    }
    let positions = order
        .iter()
        .map(|&old| mesh.positions[old as usize])
        .collect();
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| inverse[v as usize]))
        .collect();
    (IndexedMesh::new(positions, triangles), order)
}

/// Flips the edge `t[1] → t[2]` of triangle `t` (with the triangle across it).
fn flip(mesh: &mut IndexedMesh, t: usize) {
    let [p, q, w] = mesh.triangles[t];
    let k = mesh
        .triangles
        .iter()
        .position(|u| (0..3).any(|j| u[j] == w && u[(j + 1) % 3] == q))
        .unwrap();
    let x = mesh.triangles[k]
        .into_iter()
        .find(|&v| v != w && v != q)
        .unwrap();
    mesh.triangles[t] = [p, q, x];
    mesh.triangles[k] = [p, x, w];
}

/// An elongated blob along z (z in about ±3): a limb-like closed mesh, with
/// a few quads' diagonals flipped so its triangulation has no symmetry (the
/// uv sphere's has 48, and a twist can make a turned one closer in D).
fn rod(seed: u64) -> IndexedMesh {
    let segments = 24;
    let mut mesh = blob(20, segments, 0.1, [0.8, 0.6, 3.0], seed);
    for quad in (0..18 * segments as usize).step_by(37) {
        // The quad's first triangle [a, b, c] has its diagonal at c → a.
        let t = 2 * segments as usize + 2 * quad;
        mesh.triangles[t].rotate_left(1);
        flip(&mut mesh, t);
    }
    mesh
}

/// Twisted by up to ±90° about the long axis (z).
fn twist(p: DVec3) -> DVec3 {
    let (s, c) = (p.z * std::f64::consts::FRAC_PI_6).sin_cos();
    DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z)
}

/// Bent by 90° in the xz plane (the axis onto a quarter circle).
fn bend(p: DVec3) -> DVec3 {
    let radius = 6.0 / std::f64::consts::FRAC_PI_2;
    let theta = p.z / radius;
    let r = radius - p.x;
    DVec3::new(radius - r * theta.cos(), p.y, r * theta.sin())
}

/// Inflated in the middle (up to 1.6× thicker) and thinned at the ends.
fn inflate(p: DVec3) -> DVec3 {
    let k = 0.7 + 0.9 * (1.0 - (p.z / 3.0).powi(2)).max(0.0);
    DVec3::new(k * p.x, k * p.y, p.z)
}

/// Two poses of one mesh (same vertex order and triangles): the supermesh
/// is that connectivity, `V(0) = A` and `V(1) = B` bit for bit, and the
/// report says so.
#[test]
fn two_poses_of_one_mesh_use_their_connectivity() {
    let a = rod(4);
    let b = deformed(&a, twist);
    // Landmarks that pair a vertex with itself agree with the connectivity.
    let options = SupermeshOptions {
        landmarks: vec![(0, 0), (5, 5)],
        ..SupermeshOptions::default()
    };
    let (s, r) = Supermesh::build(&a, &b, &options).unwrap();
    println!("{r}");
    assert_eq!(r.connectivity, Connectivity::Same);
    assert!(r.to_string().contains("the same"), "{r}");
    assert_eq!(s.triangles, a.triangles);
    assert_eq!(s.v0, a.positions);
    assert_eq!(s.v1, b.positions);
    assert!(s.origins.iter().enumerate().all(|(i, &o)| o
        == Origin::Both {
            a: i as u32,
            b: i as u32
        }));
    assert_eq!((r.vertices, r.crossings), (a.vertex_count(), 0));
    assert_eq!(
        r.correspondence,
        measure(&a.triangles, &a.positions, &b.positions)
    );
    // A triangle starting at another corner is the same triangle.
    let mut c = b.clone();
    c.triangles[3].rotate_left(1);
    let (s, r) = Supermesh::build(&a, &c, &SupermeshOptions::default()).unwrap();
    assert_eq!(r.connectivity, Connectivity::Same);
    assert_eq!(s.triangles, a.triangles);
    // Landmarks that ask for another correspondence, or the option off: overlaid.
    for options in [
        SupermeshOptions {
            landmarks: vec![(0, 0), (30, 300)],
            ..SupermeshOptions::default()
        },
        SupermeshOptions {
            reuse_connectivity: false,
            ..SupermeshOptions::default()
        },
    ] {
        let (_, r) = Supermesh::build(&a, &b, &options).unwrap();
        assert_eq!(r.connectivity, Connectivity::Overlaid);
    }
    // Shuffled, it is not the same connectivity (but see the next test).
    let (_, r) = Supermesh::build(&a, &shuffled(&b, 1).0, &SupermeshOptions::default()).unwrap();
    assert_ne!(r.connectivity, Connectivity::Same);
}

/// A limb-like mesh and a twisted, a bent and an inflated copy of itself
/// with the vertices shuffled: the alignment leads to the renumbering, so
/// the supermesh is the mesh itself (1× the input, not the ≈ 8.6× of an
/// overlay) and every vertex is blended with its own twin (s ≥ 0.95).
#[test]
fn a_mesh_and_its_deformed_shuffled_copy_correspond() {
    let a = rod(7);
    for (name, f) in [
        ("twisted", twist as fn(DVec3) -> DVec3),
        ("bent", bend),
        ("inflated", inflate),
    ] {
        let (b, order) = shuffled(&deformed(&a, f), 11);
        let (s, r) = Supermesh::build(&a, &b, &SupermeshOptions::default()).unwrap();
        println!("{name}:\n{r}");
        let c = r.correspondence;
        assert!(c.s.iter().all(|&s| s >= 0.95), "{name}: {c:?}");
        assert_eq!(r.connectivity, Connectivity::Renumbered, "{name}");
        assert_eq!((r.vertices, r.fold_overs), (a.vertex_count(), 0), "{name}");
        assert_eq!(s.triangles, a.triangles);
        assert_eq!(s.v0, a.positions);
        for (i, &o) in s.origins.iter().enumerate() {
            let Origin::Both { a: va, b: vb } = o else {
                panic!("{name}: vertex {i} is {o:?}");
            };
            assert_eq!((va, order[vb as usize]), (i as u32, i as u32), "{name}");
            assert_eq!(s.v1[i], b.positions[vb as usize]);
        }
    }
    // Landmarks seed the renumbering (the twin of a vertex, and one that is not).
    let (b, order) = shuffled(&deformed(&a, twist), 3);
    let twin = |v: u32| order.iter().position(|&o| o == v).unwrap() as u32;
    let options = SupermeshOptions {
        landmarks: vec![(10, twin(10)), (200, twin(200))],
        ..SupermeshOptions::default()
    };
    let (s, r) = Supermesh::build(&a, &b, &options).unwrap();
    assert_eq!(r.connectivity, Connectivity::Renumbered);
    assert!(s.origins.contains(&Origin::Both {
        a: 200,
        b: twin(200)
    }));
    let options = SupermeshOptions {
        landmarks: vec![(10, twin(10)), (200, twin(201))],
        ..SupermeshOptions::default()
    };
    let (_, r) = Supermesh::build(&a, &b, &options).unwrap();
    assert_eq!(r.connectivity, Connectivity::Overlaid);
    // One edge flipped: the same counts, not the same triangles: overlaid.
    let mut c = b.clone();
    flip(&mut c, 100);
    let (_, r) = Supermesh::build(&a, &c, &SupermeshOptions::default()).unwrap();
    assert_eq!((r.connectivity, r.fold_overs), (Connectivity::Overlaid, 0));
}

// ---------------------------------------------------------------- landmarks

fn random_pairs(rng: &mut Rng, k: usize, na: usize, nb: usize) -> Vec<(u32, u32)> {
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    while pairs.len() < k {
        let (a, b) = (
            (rng.unit() * na as f64) as u32,
            (rng.unit() * nb as f64) as u32,
        );
        if pairs.iter().all(|&(x, y)| x != a && y != b) {
            pairs.push((a, b));
        }
    }
    pairs
}

/// `k` random vertices of A, each paired with the vertex of B in the most
/// similar direction from the centre (both blobs are star-shaped about it):
/// pairs that agree with each other, as a user's would.
fn consistent_pairs(rng: &mut Rng, k: usize, a: &IndexedMesh, b: &IndexedMesh) -> Vec<(u32, u32)> {
    let dir = |p: [f32; 3]| DVec3::from_array(p.map(f64::from)).normalize();
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    while pairs.len() < k {
        let va = (rng.unit() * a.vertex_count() as f64) as u32;
        let d = dir(a.positions[va as usize]);
        let vb = (0..b.vertex_count() as u32)
            .max_by(|&x, &y| {
                d.dot(dir(b.positions[x as usize]))
                    .total_cmp(&d.dot(dir(b.positions[y as usize])))
            })
            .unwrap();
        if pairs.iter().all(|&(x, y)| x != va && y != vb) {
            pairs.push((va, vb));
        }
    }
    pairs
}

fn check_closed(
    s: &Supermesh,
    r: &morphlod::morph::supermesh::SupermeshReport,
    pairs: &[(u32, u32)],
) {
    assert_eq!(r.fold_overs, 0);
    assert_eq!(r.alignment.landmarks_after.unwrap().max, 0.0, "{r}");
    for &(la, lb) in pairs {
        assert!(
            s.origins.contains(&Origin::Both { a: la, b: lb }),
            "({la}, {lb}) not merged"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// Landmark pairs that agree with each other, on two different blobs
    /// (one rotated and stretched): every pair ends on one sphere point
    /// (residual 0, one supermesh vertex of both meshes), no triangle folds.
    #[test]
    fn consistent_landmarks_close_exactly_without_folds(seed in any::<u64>(), k in 1usize..6) {
        let a = blob(10, 16, 0.3, [1.0, 1.0, 1.0], seed);
        let b = blob(7, 11, 0.2, [2.0, 1.0, 0.5], seed ^ 0x5eed);
        let pairs = consistent_pairs(&mut Rng(seed), k, &a, &b);
        let options = SupermeshOptions { landmarks: pairs.clone(), seed, ..SupermeshOptions::default() };
        let (s, r) = Supermesh::build(&a, &b, &options).unwrap_or_else(|e| panic!("{pairs:?}: {e}"));
        check_closed(&s, &r, &pairs);
    }
}

/// Random pairs (which may contradict each other) on 32 fixed cases: either every pair closes
/// exactly without folds, or a typed error names the pair the fold-rejecting drag could not
/// close; never a half-closed result. The cases are seeds 0 to 29 (all close) and two of the
/// six of seeds 0 to 255 that give up (250 of 256 close), so both outcomes are met; at least
/// 28 must close, or a build that gave up on everything would pass.
#[test]
fn random_landmarks_close_or_name_the_pair() {
    let mut closed = 0;
    for i in (0..30u64).chain([138, 159]) {
        let seed = common::mix(i);
        let k = 1 + (i % 5) as usize;
        let a = blob(10, 16, 0.3, [1.0, 1.0, 1.0], seed);
        let b = blob(7, 11, 0.2, [2.0, 1.0, 0.5], seed ^ 0x5eed);
        let pairs = random_pairs(&mut Rng(seed), k, a.vertex_count(), b.vertex_count());
        let options = SupermeshOptions {
            landmarks: pairs.clone(),
            seed,
            ..SupermeshOptions::default()
        };
        match Supermesh::build(&a, &b, &options) {
            Ok((s, r)) => {
                check_closed(&s, &r, &pairs);
                closed += 1;
            }
            Err(e) => {
                let unreached = matches!(e, SupermeshError::LandmarkUnreached { .. });
                assert!(unreached, "case {i}: {e}");
                assert!(e.landmark_pair().unwrap() < pairs.len(), "case {i}: {e}");
            }
        }
    }
    assert!(closed >= 28, "{closed} of 32 cases closed");
}

#[test]
fn bad_landmarks_are_typed_errors_naming_the_pair() {
    let a = blob(6, 8, 0.2, [1.0, 1.0, 1.0], 1);
    let b = blob(5, 7, 0.2, [1.0, 1.0, 1.0], 2);
    let build = |pairs: Vec<(u32, u32)>| {
        let options = SupermeshOptions {
            landmarks: pairs,
            ..SupermeshOptions::default()
        };
        Supermesh::build(&a, &b, &options).map(|_| ()).unwrap_err()
    };
    let text = "# pairs\n0 0\n\n5 9999   # out of range\n";
    let parsed = parse_landmarks(text).unwrap();
    let e = build(parsed.pairs.clone());
    assert!(
        matches!(
            e,
            SupermeshError::LandmarkOutOfRange {
                pair: 1,
                mesh: Side::B,
                vertex: 9999,
                ..
            }
        ),
        "{e}"
    );
    assert!(
        parsed.explain(&e).starts_with("landmarks line 4: "),
        "{}",
        parsed.explain(&e)
    );
    for (pairs, mesh) in [
        (vec![(0, 1), (2, 3), (0, 4)], Side::A),
        (vec![(0, 1), (2, 3), (4, 3)], Side::B),
    ] {
        let e = build(pairs);
        assert!(
            matches!(e, SupermeshError::LandmarkRepeated { first: 0, second: 2, mesh: m, .. } if m == mesh)
                || matches!(e, SupermeshError::LandmarkRepeated { first: 1, second: 2, mesh: m, .. } if m == mesh),
            "{e}"
        );
        assert_eq!(e.landmark_pair(), Some(2));
    }
    assert!(parse_landmarks("# nothing\n").is_err());
}

// ---------------------------------------------------------------- man → camel

/// The man's file is z-up: stood up as the demo does (`(x, y, z)` → `(x, z, −y)`).
fn stood_up(mut mesh: IndexedMesh) -> IndexedMesh {
    for p in &mut mesh.positions {
        *p = [p[0], p[2], -p[1]];
    }
    mesh
}

/// man → camel with the shipped landmarks: the in-betweens keep their size
/// (s ≥ 0.9 at ¼, ½, ¾, the goal: 0.930, 0.906, 0.930 measured;
/// 0.930, 0.905, 0.930 with the drag from a fraction of the Möbius fit;
/// 0.924, 0.897, 0.924 before the embeddings were relaxed after the drag;
/// 0.737, 0.626, 0.737 with the alignment before issue 25), every pair on
/// one point, no fold-overs.
#[test]
fn man_to_camel_with_the_shipped_landmarks() {
    let man = stood_up(asset("man.off"));
    let camel = asset("camel.off");
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/man_camel.landmarks"),
    )
    .unwrap();
    let landmarks = parse_landmarks(&text).unwrap();
    let options = SupermeshOptions {
        landmarks: landmarks.pairs.clone(),
        ..SupermeshOptions::default()
    };
    let (s, r) = Supermesh::build(&man, &camel, &options)
        .unwrap_or_else(|e| panic!("{}", landmarks.explain(&e)));
    println!("{r}");
    let c = r.correspondence;
    assert!(c.s.iter().all(|&s| s >= 0.9), "{c:?}");
    assert_eq!(r.fold_overs, 0);
    assert_eq!(r.alignment.landmarks_after.unwrap().max, 0.0);
    // The landmarks' Möbius fit carried through whole (7,016 of the camel's
    // 9,770 vertices were left behind before), and the man's embedding
    // centred (it stalled at 0.31).
    assert_eq!(r.alignment.mobius_unreached, Some(0), "{r}");
    assert!(r.alignment.centroid_a.1 < 1e-6, "{r}");
    // The goal: no larger than 1.3x the automatic supermesh (91,188
    // vertices; 97,075 measured, 138,765 before).
    assert!(r.vertices <= 118_000, "{r}");
    for &(la, lb) in &landmarks.pairs {
        assert!(s.origins.contains(&Origin::Both { a: la, b: lb }));
    }
}

/// Inputs the proptests above once failed on (pair 0 left 0.066 and 0.043
/// rad short): two landmarks close on a coarse mesh each dragged the other
/// back in its own turn. Kept as named cases so they run on every seed.
#[test]
fn near_landmarks_do_not_pull_each_other_back() {
    for (seed, k) in [(12568329709619157204u64, 4), (12650222338893363106, 5)] {
        let a = blob(10, 16, 0.3, [1.0, 1.0, 1.0], seed);
        let b = blob(7, 11, 0.2, [2.0, 1.0, 0.5], seed ^ 0x5eed);
        let pairs = consistent_pairs(&mut Rng(seed), k, &a, &b);
        let options = SupermeshOptions {
            landmarks: pairs.clone(),
            seed,
            ..SupermeshOptions::default()
        };
        let (s, r) =
            Supermesh::build(&a, &b, &options).unwrap_or_else(|e| panic!("{pairs:?}: {e}"));
        check_closed(&s, &r, &pairs);
    }
}

/// `fit_b_onto_a`: a mesh and its turned, moved and scaled copy under the
/// identity map: the fit puts the copy back on the mesh (the similarity's
/// oracle), and the measure then finds the ends the same.
#[test]
fn the_fit_takes_a_turned_moved_scaled_copy_back_onto_the_mesh() {
    use morphlod::morph::supermesh::fit_b_onto_a;
    let a = blob(8, 12, 0.3, [2.0, 1.0, 0.6], 3);
    let turn = glam::DMat3::from_axis_angle(DVec3::new(1.0, -2.0, 0.5).normalize(), 1.1);
    let b = deformed(&a, |p| turn * p * 2.5 + DVec3::new(3.0, -1.0, 7.0));
    let before = measure(&a.triangles, &a.positions, &b.positions);
    assert!(before.placement.differs(before.d), "{before:?}");
    let fitted = fit_b_onto_a(&a.triangles, &a.positions, &b.positions);
    for (f, p) in fitted.iter().zip(&a.positions) {
        let d = (0..3).map(|k| (f[k] - p[k]).abs()).fold(0.0f32, f32::max);
        assert!(d < 1e-4, "{f:?} {p:?}");
    }
    let after = measure(&a.triangles, &a.positions, &fitted);
    assert!(after.d < 1e-8 && after.d_placed < 1e-8, "{after:?}");
    assert!(!after.placement.differs(after.d), "{after:?}");
}

// ---------------------------------------------------------------- limb tips

/// A UV sphere with a spike out of each direction in `spikes` (radius
/// `1 + length · (1 − θ/0.45)²` within 0.45 rad of it, lengths 1.0, 1.25, …).
fn spiked_sphere(spikes: &[DVec3]) -> IndexedMesh {
    let sphere = blob(40, 80, 0.0, [1.0, 1.0, 1.0], 0);
    deformed(&sphere, |p| {
        let bump: f64 = spikes
            .iter()
            .enumerate()
            .map(|(k, &d)| {
                let x = (1.0 - p.angle_between(d) / 0.45).max(0.0);
                (1.0 + 0.25 * k as f64) * x * x
            })
            .sum();
        p * (1.0 + bump)
    })
}

/// The tip finder on spheres with k spikes at random, well-separated
/// directions: exactly k tips, one on each spike; a plain sphere has at
/// most its global maximum (docs/DESIGN.md, "Alignment").
#[test]
fn limb_tips_are_the_spikes_of_a_spiked_sphere() {
    use morphlod::morph::supermesh::limb_tips;
    let plain = limb_tips(&blob(40, 80, 0.02, [1.0, 1.0, 1.0], 7)).unwrap();
    assert!(plain.len() <= 1, "{plain:?}");
    let mut rng = Rng(25);
    for k in 1..=6 {
        // Directions at least 1.2 rad apart, by rejection.
        let mut spikes: Vec<DVec3> = Vec::new();
        while spikes.len() < k {
            let z = 2.0 * rng.unit() - 1.0;
            let phi = std::f64::consts::TAU * rng.unit();
            let r = (1.0 - z * z).sqrt();
            let d = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            if spikes.iter().all(|s| s.angle_between(d) > 1.2) {
                spikes.push(d);
            }
        }
        let mesh = spiked_sphere(&spikes);
        let tips = limb_tips(&mesh).unwrap();
        assert_eq!(tips.len(), k, "{k} spikes: tips {tips:?}");
        for s in &spikes {
            let on: Vec<u32> = tips
                .iter()
                .copied()
                .filter(|&v| {
                    let p = DVec3::from_array(mesh.positions[v as usize].map(f64::from));
                    p.angle_between(*s) < 0.2
                })
                .collect();
            assert_eq!(on.len(), 1, "{k} spikes: spike {s} has tips {on:?}");
        }
    }
    // Not a closed surface: the supermesh's typed error, no panic.
    let mut open = blob(6, 8, 0.0, [1.0, 1.0, 1.0], 1);
    open.triangles.pop();
    assert!(matches!(limb_tips(&open), Err(SupermeshError::Open { .. })));
}
