//! The supermesh of two closed genus-0 meshes (`morph::supermesh`): property
//! tests on generated spheres, the bundled pairs, and the bad-input table.
//!
//! What every supermesh must satisfy (`check`): one closed manifold with
//! χ = 2; every triangle strictly positive on the sphere (exact) and the
//! spherical areas summing to 4π; `V = V_A + V_B − coincident + crossings`
//! (a B vertex exactly on an A vertex is one vertex, `Origin::Both`), counting the
//! vertices the meshes' triangles use (cleaning drops the others); A's vertices
//! bit for bit in `V(0)` and B's in `V(1)`, by the input's own indices; every crossing
//! on its A edge in `V(0)`, on its B edge in `V(1)` and on both great arcs on the sphere;
//! the surface at `t = 0` is A (same area, Hausdorff ≤ 1e-6 of the diagonal) and at
//! `t = 1` is B.

use crate::common;
use std::collections::HashMap;

use glam::{DMat3, DVec3};
use morphlod::mesh::IndexedMesh;
use morphlod::metrics::hausdorff;
use morphlod::morph::supermesh::{
    Origin, Side, Supermesh, SupermeshError, SupermeshOptions, SupermeshReport,
};
use morphlod::topology::analyze;
use proptest::prelude::*;

// ---------------------------------------------------------------- generators

/// The same surface with every triangle split in four (midpoints on the edges).
fn refined(mesh: &IndexedMesh) -> IndexedMesh {
    let mut p: Vec<DVec3> = mesh
        .positions
        .iter()
        .map(|&q| DVec3::from_array(q.map(f64::from)))
        .collect();
    let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
    let mut out = Vec::with_capacity(mesh.triangles.len() * 4);
    for t in &mesh.triangles {
        let mut m = [0u32; 3];
        for i in 0..3 {
            let (a, b) = (t[i].min(t[(i + 1) % 3]), t[i].max(t[(i + 1) % 3]));
            m[i] = *mid.entry((a, b)).or_insert_with(|| {
                p.push((p[a as usize] + p[b as usize]) * 0.5);
                p.len() as u32 - 1
            });
        }
        out.push([t[0], m[0], m[2]]);
        out.push([m[0], t[1], m[1]]);
        out.push([m[2], m[1], t[2]]);
        out.push([m[0], m[1], m[2]]);
    }
    IndexedMesh::new(p.iter().map(|v| v.as_vec3().to_array()).collect(), out)
}

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

/// A star-shaped blob: radial noise, an anisotropic stretch and a rotation.
fn blob(level: u32, noise: f64, stretch: [f64; 3], seed: u64) -> IndexedMesh {
    let mut rng = Rng(seed);
    let axis = DVec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5 + 1e-3).normalize();
    let rotation = DMat3::from_axis_angle(axis, 6.0 * rng.unit());
    let mut mesh = IndexedMesh::icosphere(level as u8);
    for p in &mut mesh.positions {
        let r = 1.0 + noise * (rng.unit() - 0.5);
        let q = DVec3::from_array(p.map(f64::from)) * r * DVec3::from_array(stretch);
        *p = (rotation * q + DVec3::new(0.3, -0.2, 0.1))
            .as_vec3()
            .to_array();
    }
    mesh
}

// ---------------------------------------------------------------- the oracle

fn area(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| DVec3::from_array(positions[v as usize].map(f64::from)));
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

fn orient(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let p = |v: DVec3| robust::Coord3D {
        x: v.x,
        y: v.y,
        z: v.z,
    };
    robust::orient3d(p(a), p(b), p(c), p(DVec3::ZERO))
}

fn spherical_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (a, b, c) = (a.normalize(), b.normalize(), c.normalize());
    2.0 * a
        .dot(b.cross(c))
        .atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a))
}

/// Every property of the module docs; `samples` for the Hausdorff checks.
fn check(a: &IndexedMesh, b: &IndexedMesh, s: &Supermesh, r: &SupermeshReport, samples: usize) {
    // Closed manifold sphere.
    let topo = analyze(&IndexedMesh::new(s.v0.clone(), s.triangles.clone())).unwrap();
    assert!(topo.is_closed_manifold(), "{topo}");
    assert_eq!(topo.components, 1, "{topo}");
    assert_eq!(topo.euler_characteristic, 2, "{topo}");
    assert_eq!(topo.isolated_vertices, 0, "{topo}");
    // Bijective on the sphere.
    let mut sphere_area = 0.0;
    for t in &s.triangles {
        let [p, q, w] = t.map(|v| s.sphere[v as usize]);
        assert!(
            orient(p, q, w) > 0.0,
            "triangle {t:?} not positive on the sphere"
        );
        sphere_area += spherical_area(p, q, w);
    }
    let four_pi = 4.0 * std::f64::consts::PI;
    assert!(
        (sphere_area - four_pi).abs() < 1e-6 * four_pi,
        "area {sphere_area}"
    );
    assert_eq!(r.fold_overs, 0);
    // V = V_A + V_B + crossings; each input vertex once, bit for bit.
    let crossings = s
        .origins
        .iter()
        .filter(|o| matches!(o, Origin::Crossing { .. }))
        .count();
    assert_eq!(crossings, r.crossings);
    let both = s
        .origins
        .iter()
        .filter(|o| matches!(o, Origin::Both { .. }))
        .count();
    assert_eq!(both, r.coincident);
    let (used_a, used_b) = (used(a), used(b));
    let count = |used: &[bool]| used.iter().filter(|&&u| u).count();
    assert_eq!(
        s.vertex_count(),
        count(&used_a) + count(&used_b) - both + crossings
    );
    let mut seen_a = vec![false; a.vertex_count()];
    let mut seen_b = vec![false; b.vertex_count()];
    // Each input vertex's point on the sphere, for the crossings' arcs.
    let mut sphere_a = vec![None; a.vertex_count()];
    let mut sphere_b = vec![None; b.vertex_count()];
    for (i, o) in s.origins.iter().enumerate() {
        match *o {
            Origin::A(v) => sphere_a[v as usize] = Some(s.sphere[i]),
            Origin::B(v) => sphere_b[v as usize] = Some(s.sphere[i]),
            Origin::Both { a: va, b: vb } => {
                sphere_a[va as usize] = Some(s.sphere[i]);
                sphere_b[vb as usize] = Some(s.sphere[i]);
            }
            Origin::Crossing { .. } => {}
        }
    }
    for (i, o) in s.origins.iter().enumerate() {
        match *o {
            Origin::A(v) => {
                assert!(!std::mem::replace(&mut seen_a[v as usize], true));
                assert_eq!(
                    s.v0[i].map(f32::to_bits),
                    a.positions[v as usize].map(f32::to_bits)
                );
            }
            Origin::B(v) => {
                assert!(!std::mem::replace(&mut seen_b[v as usize], true));
                assert_eq!(
                    s.v1[i].map(f32::to_bits),
                    b.positions[v as usize].map(f32::to_bits)
                );
            }
            Origin::Both { a: va, b: vb } => {
                assert!(!std::mem::replace(&mut seen_a[va as usize], true));
                assert!(!std::mem::replace(&mut seen_b[vb as usize], true));
                assert_eq!(
                    s.v0[i].map(f32::to_bits),
                    a.positions[va as usize].map(f32::to_bits)
                );
                assert_eq!(
                    s.v1[i].map(f32::to_bits),
                    b.positions[vb as usize].map(f32::to_bits)
                );
            }
            Origin::Crossing { a_edge, b_edge } => {
                for (mesh, edge, pose, sphere, name) in [
                    (a, a_edge, &s.v0, &sphere_a, "A"),
                    (b, b_edge, &s.v1, &sphere_b, "B"),
                ] {
                    let what = format!("crossing {i} on {name} edge {edge:?}");
                    assert!(
                        edge[0] < edge[1] && is_edge(mesh, edge),
                        "{what}: not an edge"
                    );
                    on_segment(pose[i], edge.map(|v| mesh.positions[v as usize]), &what);
                    let ends = edge.map(|v| sphere[v as usize].expect("an input vertex"));
                    on_arc(s.sphere[i], ends, &what);
                }
            }
        }
    }
    assert_eq!(seen_a, used_a);
    assert_eq!(seen_b, used_b);
    // The surfaces at t = 0 and t = 1.
    for (pose, mesh, name) in [(&s.v0, a, "t = 0 vs A"), (&s.v1, b, "t = 1 vs B")] {
        let (sa, ma) = (
            area(pose, &s.triangles),
            area(&mesh.positions, &mesh.triangles),
        );
        assert!((sa - ma).abs() <= 1e-6 * ma, "{name}: area {sa} vs {ma}");
        let h = hausdorff(
            pose,
            &s.triangles,
            &mesh.positions,
            &mesh.triangles,
            samples,
        )
        .unwrap();
        let diag = common::diagonal(&mesh.positions);
        println!(
            "  {name}: Hausdorff {:.3e} = {:.3e} of the diagonal, area {sa:.9} vs {ma:.9}",
            h.hausdorff,
            h.hausdorff / diag
        );
        assert!(
            h.hausdorff <= 1e-6 * diag,
            "{name}: Hausdorff {} of diagonal {diag}",
            h.hausdorff
        );
    }
    // And a morph can be made of it.
    let morph = s.to_morph().unwrap();
    assert_eq!(morph.vertex_count(), s.vertex_count());
}

/// The vertices a mesh's triangles use (a triangle that repeats a vertex counts for nothing:
/// cleaning drops it).
fn used(mesh: &IndexedMesh) -> Vec<bool> {
    let mut used = vec![false; mesh.vertex_count()];
    for t in &mesh.triangles {
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            t.iter().for_each(|&v| used[v as usize] = true);
        }
    }
    used
}

/// Whether `edge` (low index first) is an edge of a triangle of `mesh`.
fn is_edge(mesh: &IndexedMesh, edge: [u32; 2]) -> bool {
    mesh.triangles.iter().any(|t| {
        (0..3).any(|k| {
            let (p, q) = (t[k], t[(k + 1) % 3]);
            [p.min(q), p.max(q)] == edge
        })
    })
}

/// `p` lies on the segment `ends` (within f32 rounding of the segment's length).
fn on_segment(p: [f32; 3], ends: [[f32; 3]; 2], what: &str) {
    let [p, e0, e1] = [p, ends[0], ends[1]].map(|q| DVec3::from_array(q.map(f64::from)));
    let d = e1 - e0;
    let t = (p - e0).dot(d) / d.length_squared();
    let off = (e0 + d * t - p).length();
    let tolerance = 1e-5 * d.length().max(e0.length()).max(e1.length());
    assert!(
        (-1e-6..=1.0 + 1e-6).contains(&t) && off <= tolerance,
        "{what}: {p} is {off:e} off the segment, at t = {t}"
    );
}

/// `p` lies on the shorter great arc between the unit vectors `ends`.
fn on_arc(p: DVec3, ends: [DVec3; 2], what: &str) {
    let n = ends[0].cross(ends[1]).normalize();
    let off = p.dot(n).abs();
    let between = ends[0].cross(p).dot(n) >= -1e-9 && p.cross(ends[1]).dot(n) >= -1e-9;
    assert!(
        off <= 1e-9 && between,
        "{what}: {p} is {off:e} off the arc, between its ends: {between}"
    );
}

fn build(
    a: &IndexedMesh,
    b: &IndexedMesh,
    options: &SupermeshOptions,
) -> (Supermesh, SupermeshReport) {
    // The overlay itself is under test, also where A and B share their triangles.
    let options = SupermeshOptions {
        reuse_connectivity: false,
        ..options.clone()
    };
    Supermesh::build(a, b, &options).unwrap_or_else(|e| panic!("supermesh: {e}"))
}

// ---------------------------------------------------------------- properties

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    #[test]
    fn blobs_of_different_densities(
        la in 0u32..3, lb in 0u32..3, seed in any::<u64>(),
        noise in 0.0f64..0.6, sx in 0.3f64..3.0,
    ) {
        let a = blob(la, noise, [1.0, 1.0, 1.0], seed);
        let b = blob(lb, noise * 0.5, [sx, 1.0, 1.0 / sx], seed ^ 0xabcdef);
        let options = SupermeshOptions { seed, ..SupermeshOptions::default() };
        let (s, r) = build(&a, &b, &options);
        check(&a, &b, &s, &r, 500);
    }

    #[test]
    fn a_mesh_with_itself_and_with_its_refinement(level in 0u32..3, seed in any::<u64>()) {
        let a = blob(level, 0.3, [1.0, 2.0, 0.5], seed);
        let options = SupermeshOptions { seed, ..SupermeshOptions::default() };
        let (s, r) = build(&a, &a, &options);
        check(&a, &a, &s, &r, 500);
        overlays_onto_itself(&a);
        let b = refined(&a);
        let (s, r) = build(&a, &b, &options);
        check(&a, &b, &s, &r, 500);
    }
}

/// A mesh overlaid on itself with no rotation: every B vertex lies exactly
/// on its A twin and every edge on its twin, so the supermesh is the mesh.
fn overlays_onto_itself(a: &IndexedMesh) {
    let options = SupermeshOptions {
        perturb: false,
        align: false,
        ..SupermeshOptions::default()
    };
    let (s, r) = build(a, a, &options);
    println!("{r}");
    check(a, a, &s, &r, 300);
    assert_eq!(s.vertex_count(), a.vertex_count());
    assert_eq!(s.triangles.len(), a.triangles.len());
    assert_eq!((r.crossings, r.coincident), (0, a.vertex_count()));
    for (i, o) in s.origins.iter().enumerate() {
        let Origin::Both { a: va, b: vb } = *o else {
            panic!("vertex {i} is {o:?}");
        };
        assert_eq!(va, vb);
        let bits = a.positions[va as usize].map(f32::to_bits);
        assert_eq!(s.v0[i].map(f32::to_bits), bits);
        assert_eq!(s.v1[i].map(f32::to_bits), bits);
    }
}

#[test]
fn identical_meshes_without_perturbation_merge_into_the_mesh() {
    overlays_onto_itself(&IndexedMesh::icosphere(1));
    overlays_onto_itself(&blob(2, 0.4, [2.0, 1.0, 0.5], 11));
}

/// The octahedron with vertices at ±1 on the axes: every 1 → 4 midpoint
/// refinement of it has exact (dyadic) coordinates.
fn octahedron() -> IndexedMesh {
    IndexedMesh::new(
        vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ],
        vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ],
    )
}

#[test]
fn a_mesh_with_its_refinement_without_perturbation() {
    // Radially embedded, every coarse vertex lies exactly on a fine vertex
    // and every coarse edge passes exactly through fine vertices along
    // fine edges: the supermesh is the fine mesh.
    let options = SupermeshOptions {
        perturb: false,
        align: false,
        radial: true,
        reuse_connectivity: false,
        ..SupermeshOptions::default()
    };
    let mut a = octahedron();
    for _ in 0..3 {
        let b = refined(&a);
        for (x, y) in [(&a, &b), (&b, &a)] {
            let (s, r) = build(x, y, &options);
            println!("{r}");
            check(x, y, &s, &r, 300);
            assert_eq!(s.vertex_count(), b.vertex_count());
            assert_eq!(s.triangles.len(), b.triangles.len());
            assert_eq!((r.crossings, r.coincident), (0, a.vertex_count()));
        }
        overlays_onto_itself(&b);
        a = b;
    }
    // Not star-shaped about the origin: a clear error.
    let mut off = octahedron();
    for p in &mut off.positions {
        p[0] += 3.0;
    }
    let e = Supermesh::build(&off, &off, &options)
        .map(|_| ())
        .unwrap_err();
    assert!(matches!(e, SupermeshError::Embedding { .. }), "{e}");
    assert!(e.to_string().contains("star-shaped"), "{e}");
}

#[test]
fn landmarks_are_pulled_together() {
    let a = blob(2, 0.2, [1.0, 1.0, 1.0], 7);
    let b = blob(1, 0.2, [2.0, 1.0, 0.5], 8);
    let options = SupermeshOptions {
        landmarks: vec![(0, 5), (40, 17), (100, 33)],
        ..SupermeshOptions::default()
    };
    let (s, r) = build(&a, &b, &options);
    check(&a, &b, &s, &r, 300);
    let (before, after) = (
        r.alignment.landmarks_before.unwrap(),
        r.alignment.landmarks_after.unwrap(),
    );
    // Each landmark is pulled onto its partner (the overlay then turns B by
    // a tiny random rotation, at most 2 · 2e-3 rad).
    println!("landmarks {before:?} -> {after:?}");
    assert!(before.max > 0.1, "{before:?}");
    assert!(after.max < 5e-3, "{before:?} -> {after:?}");
    // Without the random rotation each landmark pair ends exactly on one
    // sphere point: one supermesh vertex of both meshes.
    let exact = SupermeshOptions {
        perturb: false,
        ..options
    };
    let (s, r) = build(&a, &b, &exact);
    check(&a, &b, &s, &r, 300);
    assert_eq!(r.alignment.landmarks_after.unwrap().max, 0.0);
    for &(la, lb) in &exact.landmarks {
        assert!(
            s.origins.contains(&Origin::Both { a: la, b: lb }),
            "landmark pair ({la}, {lb}) not merged"
        );
    }
}

/// Input that cleaning changes: A with an unused vertex in front (every index after it moves
/// down by one in the cleaned mesh) and a degenerate triangle. Origins, crossings and
/// landmarks all speak of the input's indices: the checks run on the uncleaned A, and a
/// landmark pair given in input indices ends as one `Origin::Both` of those indices. A
/// landmark on the unused vertex, and a B vertex in two pairs, are refused.
#[test]
fn origins_and_landmarks_use_the_input_indices() {
    // landmarks_are_pulled_together's pair and landmarks, A's indices moved up by one.
    let clean = blob(2, 0.2, [1.0, 1.0, 1.0], 7);
    // The unused vertex at the blob's centre: inside the bounds, so the diagonal is the surface's.
    let mut positions = vec![[0.3, -0.2, 0.1]];
    positions.extend_from_slice(&clean.positions);
    let mut triangles: Vec<[u32; 3]> = clean.triangles.iter().map(|t| t.map(|v| v + 1)).collect();
    triangles.insert(3, [5, 5, 7]);
    let a = IndexedMesh::new(positions, triangles);
    let b = blob(1, 0.2, [2.0, 1.0, 0.5], 8);
    let options = SupermeshOptions {
        landmarks: vec![(1, 5), (41, 17), (101, 33)],
        perturb: false,
        ..SupermeshOptions::default()
    };
    let (s, r) = build(&a, &b, &options);
    assert!(r.crossings > 0, "{r}");
    check(&a, &b, &s, &r, 300);
    for &(la, lb) in &options.landmarks {
        assert!(
            s.origins.contains(&Origin::Both { a: la, b: lb }),
            "landmark pair ({la}, {lb}) not merged"
        );
    }
    let refused = |landmarks: Vec<(u32, u32)>| {
        let options = SupermeshOptions {
            landmarks,
            ..SupermeshOptions::default()
        };
        Supermesh::build(&a, &b, &options).map(|_| ()).unwrap_err()
    };
    let e = refused(vec![(1, 5), (0, 17)]);
    assert!(
        matches!(
            e,
            SupermeshError::LandmarkUnused {
                pair: 1,
                mesh: Side::A,
                vertex: 0
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("used by no triangle"), "{e}");
    let e = refused(vec![(1, 5), (41, 17), (101, 5)]);
    assert!(
        matches!(
            e,
            SupermeshError::LandmarkRepeated {
                first: 0,
                second: 2,
                mesh: Side::B,
                vertex: 5
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("twice"), "{e}");
}

#[test]
fn progress_reports_every_stage() {
    use morphlod::morph::supermesh::Stage;
    use std::sync::Mutex;
    let seen = Mutex::new(Vec::new());
    let progress = |stage: Stage, f: f32| seen.lock().unwrap().push((stage, f));
    let options = SupermeshOptions {
        progress: Some(&progress),
        ..SupermeshOptions::default()
    };
    let a = IndexedMesh::icosphere(1);
    let b = blob(2, 0.3, [1.0, 1.0, 1.0], 3);
    let (_, r) = build(&a, &b, &options);
    let seen = seen.into_inner().unwrap();
    for stage in Stage::ALL {
        assert!(seen.contains(&(stage, 1.0)), "{stage:?} never finished");
        assert!(r.stage_seconds.iter().any(|&(s, _)| s == stage));
    }
}

// ---------------------------------------------------------------- bad input

fn tetrahedron(offset: f32) -> IndexedMesh {
    IndexedMesh::new(
        vec![
            [offset, 0.0, 0.0],
            [offset + 1.0, 0.0, 0.0],
            [offset, 1.0, 0.0],
            [offset, 0.0, 1.0],
        ],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
    )
}

fn torus() -> IndexedMesh {
    let (n, m) = (8u32, 6u32);
    let id = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut p = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (u, v) = (
                i as f32 / n as f32 * std::f32::consts::TAU,
                j as f32 / m as f32 * std::f32::consts::TAU,
            );
            p.push([
                (2.0 + v.cos()) * u.cos(),
                (2.0 + v.cos()) * u.sin(),
                v.sin(),
            ]);
        }
    }
    let mut t = Vec::new();
    for i in 0..n {
        for j in 0..m {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    IndexedMesh::new(p, t)
}

#[test]
fn bad_input_gets_typed_errors() {
    let good = IndexedMesh::icosphere(1);
    let mut open = good.clone();
    open.triangles.pop();
    let mut two = tetrahedron(0.0);
    let other = tetrahedron(5.0);
    two.positions.extend(other.positions);
    two.triangles
        .extend(other.triangles.iter().map(|t| t.map(|v| v + 4)));
    let mut fin = good.clone();
    let [x, y, _] = fin.triangles[0];
    fin.positions.push([3.0, 3.0, 3.0]);
    fin.positions.push([3.0, -3.0, 3.0]);
    let n = fin.positions.len() as u32;
    fin.triangles.push([x, y, n - 2]);
    fin.triangles.push([y, x, n - 1]);
    let mut nan = good.clone();
    nan.positions[3][1] = f32::NAN;
    let empty = IndexedMesh::default();
    let flat = IndexedMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2], [0, 2, 1]],
    );
    let mut degenerate = good.clone();
    degenerate.triangles[0] = [0, 0, 1];

    let options = SupermeshOptions::default();
    let err = |m: &IndexedMesh| {
        Supermesh::build(&good, m, &options)
            .map(|_| ())
            .unwrap_err()
    };
    assert!(
        matches!(
            err(&open),
            SupermeshError::Open {
                mesh: Side::B,
                loops: 1,
                edges: 3
            }
        ),
        "{}",
        err(&open)
    );
    assert!(matches!(
        err(&torus()),
        SupermeshError::Genus {
            mesh: Side::B,
            genus: 1
        }
    ));
    assert!(matches!(
        err(&two),
        SupermeshError::Components { components: 2, .. }
    ));
    assert!(
        matches!(err(&fin), SupermeshError::NonManifold { .. }),
        "{}",
        err(&fin)
    );
    assert!(matches!(
        err(&nan),
        SupermeshError::InvalidMesh { mesh: Side::B, .. }
    ));
    assert!(matches!(err(&empty), SupermeshError::InvalidMesh { .. }));
    assert!(matches!(
        err(&flat),
        SupermeshError::TooSmall { vertices: 3, .. }
    ));
    assert!(
        matches!(
            err(&degenerate),
            SupermeshError::DegenerateTriangles { count: 1, .. }
        ),
        "{}",
        err(&degenerate)
    );
    // The same checks on A name A.
    let e = Supermesh::build(&torus(), &good, &options)
        .map(|_| ())
        .unwrap_err();
    assert!(matches!(
        e,
        SupermeshError::Genus {
            mesh: Side::A,
            genus: 1
        }
    ));
    assert!(e.to_string().contains("genus 1"), "{e}");
    // Landmarks out of range.
    let options = SupermeshOptions {
        landmarks: vec![(0, 0), (1, 9999)],
        ..SupermeshOptions::default()
    };
    let e = Supermesh::build(&good, &good, &options)
        .map(|_| ())
        .unwrap_err();
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
}

// ---------------------------------------------------------------- bundled pairs

fn asset(name: &str) -> IndexedMesh {
    common::load_asset_mesh(name)
}

fn pair(a: &str, b: &str) {
    let (ma, mb) = (asset(a), asset(b));
    let (s, r) = build(&ma, &mb, &SupermeshOptions::default());
    println!("{a} -> {b}\n{r}");
    check(&ma, &mb, &s, &r, 20_000);
}

#[test]
fn cow_to_bull() {
    pair("cow.off", "bull.off");
}

#[test]
fn bunny_to_cow() {
    pair("bunny.obj", "cow.off");
}

#[test]
fn man_to_camel() {
    pair("man.off", "camel.off");
}

#[test]
fn man_to_makehuman_body() {
    let b = asset("makehuman_body.glb");
    let topo = analyze(&b).unwrap();
    println!("makehuman_body.glb\n{topo}");
    match Supermesh::build(&asset("man.off"), &b, &SupermeshOptions::default()) {
        Ok((s, r)) => {
            println!("{r}");
            check(&asset("man.off"), &b, &s, &r, 20_000);
        }
        Err(e) => panic!("{e}"),
    }
}
