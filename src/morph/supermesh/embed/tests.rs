use super::collapse::{collapse_to_tetrahedron, split};
use super::*;
use crate::morph::supermesh::sphere::check_embedding;

fn tetrahedron() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    (
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
    )
}

fn cube() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut p = Vec::new();
    for i in 0..8 {
        p.push([(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32]);
    }
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut t = Vec::new();
    for q in quads {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
    }
    (p, t)
}

/// A closed capped cylinder of radius `r` and length `len` along x,
/// `segments` around and `rings` along.
pub(crate) fn finger(
    r: f32,
    len: f32,
    segments: u32,
    rings: u32,
) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut p = Vec::new();
    for i in 0..=rings {
        let x = len * i as f32 / rings as f32;
        for j in 0..segments {
            let a = std::f32::consts::TAU * j as f32 / segments as f32;
            p.push([x, r * a.cos(), r * a.sin()]);
        }
    }
    let cap0 = p.len() as u32;
    p.push([-r, 0.0, 0.0]);
    let cap1 = p.len() as u32;
    p.push([len + r, 0.0, 0.0]);
    let id = |i: u32, j: u32| i * segments + j % segments;
    let mut t = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            t.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
        }
    }
    for j in 0..segments {
        t.push([cap0, id(0, j + 1), id(0, j)]);
        t.push([cap1, id(rings, j), id(rings, j + 1)]);
    }
    (p, t)
}

fn embeds(p: &[[f32; 3]], t: &[[u32; 3]]) {
    let r =
        crate::topology::analyze(&crate::mesh::IndexedMesh::new(p.to_vec(), t.to_vec())).unwrap();
    assert_eq!(r.genus(), Some(0), "{r}");
    let points = embed(p, t, &mut |_| {}).expect("embeds");
    println!("{:?}", quality(&points, p, t));
    let (folds, area) = check_embedding(&points, t);
    assert_eq!(folds, 0);
    assert!((area - 4.0 * std::f64::consts::PI).abs() < 1e-9);
}

#[test]
fn tetrahedron_embeds() {
    let (p, t) = tetrahedron();
    embeds(&p, &t);
}

#[test]
fn cube_embeds() {
    let (p, t) = cube();
    embeds(&p, &t);
}

#[test]
fn thin_finger_embeds() {
    // 1:50 aspect, 12 around, 300 along.
    let (p, t) = finger(0.01, 1.0, 12, 300);
    embeds(&p, &t);
}

/// A Möbius map carried through whole on a thin limb's embedding, whose
/// tip cap has triangles far smaller than the map moves them: one vertex
/// at a time (fold-rejecting moves, the whole, half or a quarter of the
/// way, in Gauss–Seidel sweeps) the cap stays behind, as every move
/// folds a fan against its unmoved neighbours; all at once
/// ([`super::super::mobius::warp`]) it moves with its vertices. Likewise
/// the Möbius centring reaches the centre.
#[test]
fn mobius_maps_carry_a_thin_limb_through() {
    use super::super::mobius::{centre, warp, Mobius};
    let (p, t) = finger(0.01, 1.0, 12, 120);
    let points = embed(&p, &t, &mut |_| {}).expect("embeds");
    let rings = build_rings(p.len(), &t).unwrap();
    let map = Mobius::small([0.36, 0.16, -0.28, 0.12, 0.2, -0.24]);
    let mut one_by_one = points.clone();
    for k in 1..=8 {
        let m = map.power(k as f64 / 8.0);
        for _ in 0..4 {
            for (v, &x) in points.iter().enumerate() {
                move_vertex(&rings, &mut one_by_one, v as u32, m.apply(x));
            }
        }
    }
    let behind = (0..p.len())
        .filter(|&v| one_by_one[v] != map.apply(points[v]))
        .count();
    assert!(behind > p.len() / 2, "{behind}");
    let mut warped = points.clone();
    assert_eq!(warp(&rings, &t, &mut warped, &map, 8, 4), 0);
    assert_eq!(check_embedding(&warped, &t).0, 0);
    let mass = vertex_masses(&p, &t);
    let mut centred = points.clone();
    let (before, after) = centre(&rings, &mut centred, &mass, &t);
    assert!(before > 0.1 && after < 1e-6, "{before} -> {after}");
    assert_eq!(check_embedding(&centred, &t).0, 0);
}

#[test]
fn collapse_and_split_are_inverse() {
    let (p, t) = finger(0.1, 1.0, 8, 10);
    let original = build_rings(p.len(), &t).unwrap();
    let mut rings = original.clone();
    let h = collapse_to_tetrahedron(&p, &mut rings).unwrap();
    assert_eq!(rings.iter().filter(|r| !r.is_empty()).count(), 4);
    for k in (0..h.records.len()).rev() {
        let (u, ring) = h.ring(k);
        split(&mut rings, u, ring);
    }
    // Same cyclic rings.
    for (a, b) in rings.iter().zip(&original) {
        assert_eq!(a.len(), b.len());
        let i = a.iter().position(|&x| x == b[0]).unwrap();
        let rotated: Vec<u32> = a[i..].iter().chain(&a[..i]).copied().collect();
        assert_eq!(&rotated, b);
    }
}
