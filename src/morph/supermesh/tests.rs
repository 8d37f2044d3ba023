use super::alignment::{align_b, normalised, pair_tips, Tables};
use super::embed::Embedded;
use super::refine::refine_alignment;
use super::*;
use glam::{DMat3, DVec3};

/// A star-shaped blob: an icosphere (4 → 1 splits) pushed in and out.
fn blob(level: u32, seed: u64) -> IndexedMesh {
    let sphere = IndexedMesh::icosphere(level as u8);
    let mut state = seed;
    let positions = sphere
        .positions
        .iter()
        .map(|&q| {
            let r = 1.0 + 0.3 * (crate::random::next_unit(&mut state) - 0.5);
            let q = DVec3::from_array(q.map(f64::from));
            (q * r * DVec3::new(2.0, 1.0, 0.6)).as_vec3().to_array()
        })
        .collect();
    IndexedMesh::new(positions, sphere.triangles)
}

/// An icosphere with spikes out of the icosahedron's vertices `at`
/// (lengths 1.0, 1.3, …, so no turn of the sphere maps the spikes onto
/// each other), a little radial noise.
fn spiked(level: u32, seed: u64, at: &[usize]) -> IndexedMesh {
    let mut mesh = blob(level, seed);
    let dir = |p: [f32; 3]| DVec3::from_array(p.map(f64::from)).normalize();
    let spikes: Vec<DVec3> = at.iter().map(|&v| dir(mesh.positions[v])).collect();
    let mut state = seed;
    for p in &mut mesh.positions {
        let q = dir(*p);
        let bump: f64 = spikes
            .iter()
            .enumerate()
            .map(|(k, &d)| {
                let x = (1.0 - q.angle_between(d) / 0.5).max(0.0);
                (1.0 + 0.3 * k as f64) * x * x
            })
            .sum();
        let noise = 0.02 * (crate::random::next_unit(&mut state) - 0.5);
        *p = (q * (1.0 + noise + bump)).as_vec3().to_array();
    }
    mesh
}

/// The limb-tip pairing on a spiked mesh and a scaled copy with its
/// vertices shuffled whose sphere embedding is the mesh's under a Möbius
/// warp and a rotation, against a wrong rotation: every tip is paired
/// with its twin, and the warped map is the identity correspondence
/// (D ≈ 0, each vertex on its twin's sphere point).
#[test]
fn tip_pairing_recovers_the_identity_of_a_warped_shuffled_copy() {
    let a = spiked(3, 5, &[0, 3, 5, 8, 10]);
    let n = a.vertex_count();
    // B vertex i is A vertex order[i].
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut state = 99u64;
    for i in (1..n).rev() {
        let j = (crate::random::next_unit(&mut state) * (i + 1) as f64) as usize % (i + 1);
        order.swap(i, j);
    }
    let mut twin = vec![0u32; n];
    for (new, &old) in order.iter().enumerate() {
        twin[old as usize] = new as u32;
    }
    let b = IndexedMesh::new(
        order
            .iter()
            .map(|&v| a.positions[v as usize].map(|c| 2.0 * c - 0.5))
            .collect(),
        a.triangles
            .iter()
            .map(|t| t.map(|v| twin[v as usize]))
            .collect(),
    );
    let sa = embed::embed(&a.positions, &a.triangles, &mut |_| {}).unwrap();
    let mut sb: Vec<DVec3> = order.iter().map(|&v| sa[v as usize]).collect();
    let rings = embed::build_rings(n, &b.triangles).unwrap();
    let warp = mobius::Mobius::small([0.3, -0.1, 0.2, 0.2, -0.1, 0.3]);
    assert_eq!(mobius::warp(&rings, &b.triangles, &mut sb, &warp, 8, 4), 0);
    assert!(align::rotate(
        &mut sb,
        &b.triangles,
        align::random_rotation(3, 1.0)
    ));
    let (ta, tb) = (
        Tables::new(&a, Side::A).unwrap(),
        Tables::new(&b, Side::B).unwrap(),
    );
    let wrong = DMat3::from_rotation_x(1.5);
    let (warped, report) = pair_tips((&a, &ta, &sa), (&b, &tb, &sb), wrong, DMat3::IDENTITY);
    println!("{report}");
    assert!(
        report.tips_a.len() >= 5 && report.tips_b.len() >= 5,
        "{report}"
    );
    assert!(report.pairs.len() >= 5, "{report}");
    for p in &report.pairs {
        assert_eq!(p.b, twin[p.a as usize], "{report}");
    }
    assert!(report.d < 1e-3 && report.rotation_d > 0.1, "{report}");
    let warped = warped.expect("the pairing beats a wrong rotation");
    let mean: f64 = (0..n)
        .map(|v| sa[v].angle_between(warped[twin[v] as usize]))
        .sum::<f64>()
        / n as f64;
    assert!(mean < 1e-3, "mean angle between twins {mean}");
}

/// Each side's vertices against the other's surface at their sphere
/// points: `Σ m ‖q − other(x)‖² / Σ m` over A's and over B's vertices.
fn vertex_d(a: &IndexedMesh, b: &IndexedMesh, sa: &[DVec3], sb: &[DVec3]) -> f64 {
    let one = |m: &IndexedMesh, s: &[DVec3], o: &IndexedMesh, so: &[DVec3]| {
        let (mm, mo) = (
            embed::vertex_masses(&m.positions, &m.triangles),
            embed::vertex_masses(&o.positions, &o.triangles),
        );
        let (q, qo) = (normalised(m, &mm), normalised(o, &mo));
        let surface = align::Surface::new(so, &o.triangles, &qo);
        let (mut hint, mut rng) = (0, 1);
        let sum: f64 = (0..s.len())
            .map(|v| mm[v] * (q[v] - surface.at(s[v], &mut hint, &mut rng)).length_squared())
            .sum();
        sum / mm.iter().sum::<f64>()
    };
    one(a, sa, b, sb) + one(b, sb, a, sa)
}

/// The refinement stage lowers D on two shapes of different
/// connectivity, keeps both embeddings bijective and the landmarks where
/// they are.
#[test]
fn refinement_lowers_d_and_keeps_embeddings_and_landmarks() {
    let (a, b) = (blob(3, 5), blob(2, 11));
    let mut embedded = Embedded {
        a: embed::embed(&a.positions, &a.triangles, &mut |_| {}).unwrap(),
        b: embed::embed(&b.positions, &b.triangles, &mut |_| {}).unwrap(),
    };
    let landmarks = [(0, 0), (40, 17)];
    let options = SupermeshOptions::default();
    let (ta, tb) = (
        Tables::new(&a, Side::A).unwrap(),
        Tables::new(&b, Side::B).unwrap(),
    );
    let (mut sb, _, turn, _) =
        align_b((&a, &ta), (&b, &tb), &mut embedded, &landmarks, &options).unwrap();
    let before = vertex_d(&a, &b, &embedded.a, &sb);
    let pins = landmarks.map(|(la, lb)| (embedded.a[la as usize], sb[lb as usize]));
    refine_alignment(
        (&a, &ta, &mut embedded.a),
        (&b, &tb, &mut sb),
        &landmarks,
        turn,
    );
    let after = vertex_d(&a, &b, &embedded.a, &sb);
    println!("D over both sides' vertices {before:.4} -> {after:.4}");
    assert!(after < 0.8 * before, "{before} -> {after}");
    assert_eq!(sphere::check_embedding(&embedded.a, &a.triangles).0, 0);
    assert_eq!(sphere::check_embedding(&sb, &b.triangles).0, 0);
    for ((la, lb), (pa, pb)) in landmarks.into_iter().zip(pins) {
        assert_eq!((embedded.a[la as usize], sb[lb as usize]), (pa, pb));
        assert_eq!(pa, pb);
    }
}

/// A mesh and a scaled, moved copy whose sphere embedding is the mesh's
/// under a Möbius warp and a rotation: the alignment recovers the
/// identity correspondence (each vertex on its twin, D ≈ 0).
#[test]
fn alignment_recovers_the_identity_under_a_mobius_warp_and_rotation() {
    let a = blob(3, 5);
    let mut b = a.clone();
    for p in &mut b.positions {
        *p = p.map(|c| 3.0 * c + 1.5);
    }
    let sphere = embed::embed(&a.positions, &a.triangles, &mut |_| {}).unwrap();
    for (k, boost) in [
        [0.2, 0.1, -0.3, 0.2, 0.1, 0.0],
        [0.0, 0.5, 0.3, -0.1, 0.2, 0.4],
    ]
    .into_iter()
    .enumerate()
    {
        let warp = mobius::Mobius::small(boost);
        let mut warped = sphere.clone();
        let rings = embed::build_rings(warped.len(), &b.triangles).unwrap();
        assert_eq!(
            mobius::warp(&rings, &b.triangles, &mut warped, &warp, 8, 4),
            0
        );
        let rotation = align::random_rotation(k as u64, 1.0);
        assert!(align::rotate(&mut warped, &b.triangles, rotation));
        let mut embedded = Embedded {
            a: sphere.clone(),
            b: warped,
        };
        let before: f64 = embedded
            .a
            .iter()
            .zip(&embedded.b)
            .map(|(x, y)| x.angle_between(*y))
            .sum::<f64>()
            / sphere.len() as f64;
        let (ta, tb) = (
            Tables::new(&a, Side::A).unwrap(),
            Tables::new(&b, Side::B).unwrap(),
        );
        let (points, _, _, _) = align_b(
            (&a, &ta),
            (&b, &tb),
            &mut embedded,
            &[],
            &SupermeshOptions::default(),
        )
        .unwrap();
        let after: f64 = embedded
            .a
            .iter()
            .zip(&points)
            .map(|(x, y)| x.angle_between(*y))
            .sum::<f64>()
            / sphere.len() as f64;
        println!("mean angle between twins {before:.4} -> {after:.4} rad");
        assert!(before > 0.3, "{before}");
        assert!(after < 0.01, "{before} -> {after}");
    }
}
