//! Polygon faces (OBJ `f`, OFF and PLY faces with more than three corners):
//! non-convex polygons are ear-clipped in their best-fit plane, keeping their
//! orientation; convex ones keep the fan from the first corner, so meshes made
//! of triangles and convex polygons load exactly as before.

use morphlod::io::{load_mesh, obj, off, ply, LoadOptions};
use morphlod::IndexedMesh;
use proptest::prelude::*;
use std::path::Path;

/// FNV-1a over the triangles' little-endian bytes.
fn hash(triangles: &[[u32; 3]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in triangles.iter().flatten().flat_map(|i| i.to_le_bytes()) {
        h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// The bundled assets' triangles, hashed with the loaders as they were before
/// polygons were ear-clipped (commit 440f13c): they must not change.
#[test]
fn bundled_assets_triangles_unchanged() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    for (name, triangles, expected) in [
        ("cow.off", 5804, 0x0a80_d9b7_98c7_c4ce_u64),
        ("man.off", 34986, 0xf80c_2470_f873_3ad9),
        ("camel.off", 19536, 0xbb86_8a5c_7714_c003),
        ("bull.off", 12396, 0x129a_fc01_d08e_3231),
        ("bunny.obj", 3674, 0xfc14_2dd5_9a88_a64d),
    ] {
        let mesh = load_mesh(&dir.join(name), &LoadOptions::default()).unwrap();
        assert_eq!(mesh.triangle_count(), triangles, "{name}");
        assert_eq!(hash(&mesh.triangles), expected, "{name}");
    }
}

type P = [f64; 3];

fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: P, b: P) -> P {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: P, b: P) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A U (a 3×3 square with a 1×2 notch cut from the top middle), counter-clockwise
/// seen from +z: area 7. Fanned from corner 0 it fills the notch and flips a triangle.
const U: [[f64; 2]; 8] = [
    [0.0, 0.0],
    [3.0, 0.0],
    [3.0, 3.0],
    [2.0, 3.0],
    [2.0, 1.0],
    [1.0, 1.0],
    [1.0, 3.0],
    [0.0, 3.0],
];

/// Even-odd point-in-polygon test in the xy plane.
fn inside_u(p: [f64; 2]) -> bool {
    let mut inside = false;
    for i in 0..U.len() {
        let (a, b) = (U[i], U[(i + 1) % U.len()]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// The U placed in 3D by `place` (a rigid motion, or one that keeps areas), as an OBJ face.
fn u_obj(place: impl Fn([f64; 2]) -> P, reversed: bool) -> String {
    let mut text = String::new();
    for p in U {
        let q = place(p);
        text += &format!("v {} {} {}\n", q[0], q[1], q[2]);
    }
    let mut corners: Vec<usize> = (1..=U.len()).collect();
    if reversed {
        corners.reverse();
    }
    text += "f";
    for c in corners {
        text += &format!(" {c}");
    }
    text + "\n"
}

/// Checks that `mesh` triangulates the U exactly: `U.len() - 2` triangles, every one
/// facing `normal` (so none flipped), inside the U (by its centroid), with areas adding
/// up to the U's area 7 (so nothing overlaps and nothing is missing).
fn assert_triangulates_u(mesh: &IndexedMesh, unplace: impl Fn(P) -> [f64; 2], normal: P) {
    assert_eq!(mesh.triangle_count(), U.len() - 2, "{:?}", mesh.triangles);
    let mut area = 0.0;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize].map(f64::from));
        let n = cross(sub(b, a), sub(c, a));
        let facing = dot(n, normal);
        assert!(
            facing > 0.0,
            "triangle {t:?} is flipped: {:?}",
            mesh.triangles
        );
        area += facing.abs() / 2.0 / dot(normal, normal).sqrt();
        let centroid = [0, 1, 2].map(|i| (a[i] + b[i] + c[i]) / 3.0);
        assert!(
            inside_u(unplace(centroid)),
            "triangle {t:?} lies outside the U: {:?}",
            mesh.triangles
        );
    }
    assert!(
        (area - 7.0).abs() < 1e-4,
        "area {area}: {:?}",
        mesh.triangles
    );
}

#[test]
fn u_shaped_obj_face_is_triangulated_inside_the_polygon() {
    let flat = |p: [f64; 2]| [p[0], p[1], 0.0];
    let mesh = obj::parse(u_obj(flat, false).as_bytes(), Path::new("u.obj")).unwrap();
    assert_triangulates_u(&mesh, |p| [p[0], p[1]], [0.0, 0.0, 1.0]);
    // Clockwise seen from +z: the same area, every triangle facing -z.
    let mesh = obj::parse(u_obj(flat, true).as_bytes(), Path::new("u.obj")).unwrap();
    assert_triangulates_u(&mesh, |p| [p[0], p[1]], [0.0, 0.0, -1.0]);
}

/// Tilted out of every coordinate plane: the polygon's plane comes from its
/// Newell normal, not from dropping an axis.
#[test]
fn tilted_u_is_triangulated_in_its_own_plane() {
    // An orthonormal frame: x' = (2,2,1)/3, y' = (-2,1,2)/3, normal x' × y' = (1,-2,2)/3.
    let ex = [2.0 / 3.0, 2.0 / 3.0, 1.0 / 3.0];
    let ey = [-2.0 / 3.0, 1.0 / 3.0, 2.0 / 3.0];
    let place = |p: [f64; 2]| [0, 1, 2].map(|i| 10.0 + p[0] * ex[i] + p[1] * ey[i]);
    let unplace = |q: P| {
        let d = sub(q, [10.0; 3]);
        [dot(d, ex), dot(d, ey)]
    };
    let mesh = obj::parse(u_obj(place, false).as_bytes(), Path::new("u.obj")).unwrap();
    assert_triangulates_u(&mesh, unplace, cross(ex, ey));
}

#[test]
fn u_shaped_off_and_ply_faces_too() {
    let mut off_text = format!("OFF\n{} 1 0\n", U.len());
    let mut ply_text = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
        U.len()
    );
    for p in U {
        off_text += &format!("{} {} 0\n", p[0], p[1]);
        ply_text += &format!("{} {} 0\n", p[0], p[1]);
    }
    let face: String = (0..U.len()).map(|i| format!(" {i}")).collect();
    off_text += &format!("{}{face}\n", U.len());
    ply_text += &format!("{}{face}\n", U.len());
    let flat = |p: P| [p[0], p[1]];
    let mesh = off::parse(off_text.as_bytes(), Path::new("u.off")).unwrap();
    assert_triangulates_u(&mesh, flat, [0.0, 0.0, 1.0]);
    let mesh = ply::parse(ply_text.as_bytes(), Path::new("u.ply")).unwrap();
    assert_triangulates_u(&mesh, flat, [0.0, 0.0, 1.0]);
}

/// In PLY the faces may come before the vertices: the polygon is triangulated once both are read.
#[test]
fn ply_faces_before_vertices() {
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        U.len()
    );
    text += &format!("{}", U.len());
    for i in 0..U.len() {
        text += &format!(" {i}");
    }
    text += "\n";
    for p in U {
        text += &format!("{} {} 0\n", p[0], p[1]);
    }
    let mesh = ply::parse(text.as_bytes(), Path::new("u.ply")).unwrap();
    assert_triangulates_u(&mesh, |p| [p[0], p[1]], [0.0, 0.0, 1.0]);
}

/// OBJ faces may name vertices defined further down.
#[test]
fn obj_face_before_its_vertices() {
    let text = u_obj(|p| [p[0], p[1], 0.0], false);
    let (vertices, face) = text.split_at(text.find('f').unwrap());
    let mesh = obj::parse(format!("{face}{vertices}").as_bytes(), Path::new("u.obj")).unwrap();
    assert_triangulates_u(&mesh, |p| [p[0], p[1]], [0.0, 0.0, 1.0]);
}

/// Convex polygons, including ones with collinear corners and repeated
/// corners, keep the fan from corner 0.
#[test]
fn convex_polygons_keep_the_fan() {
    let text = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nf 1 2 3 4 5 6\nf 1 2 2 4 6\n";
    let mesh = obj::parse(text.as_bytes(), Path::new("convex.obj")).unwrap();
    assert_eq!(
        mesh.triangles,
        vec![
            [0, 1, 2],
            [0, 2, 3],
            [0, 3, 4],
            [0, 4, 5],
            [0, 1, 1],
            [0, 1, 3],
            [0, 3, 5]
        ]
    );
}

/// Degenerate polygons (all corners on a line, or at one point) and
/// self-intersecting ones (a bow tie) have no correct triangulation: they
/// load as the fan, as documented, and never panic.
#[test]
fn degenerate_and_self_intersecting_polygons_fall_back_to_the_fan() {
    let fan = vec![[0, 1, 2], [0, 2, 3]];
    for text in [
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3 4\n",
        "v 0 0 0\nv 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3 4\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4\n",
    ] {
        let mesh = obj::parse(text.as_bytes(), Path::new("odd.obj")).unwrap();
        assert_eq!(mesh.triangles, fan, "{text}");
    }
    // A pentagram (self-intersecting, every turn the same way): five triangles' worth
    // of corners, three triangles out, no panic.
    let mut text = String::new();
    for k in 0..5 {
        let a = std::f64::consts::TAU * f64::from(k * 2 % 5) / 5.0;
        text += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    text += "f 1 2 3 4 5\n";
    let mesh = obj::parse(text.as_bytes(), Path::new("star.obj")).unwrap();
    assert_eq!(mesh.triangle_count(), 3);
}

/// A comb: a non-convex polygon with many reflex corners is ear-clipped
/// correctly and quickly.
#[test]
fn comb_with_many_teeth() {
    let teeth = 500;
    let t = f64::from(teeth);
    let mut points = vec![[0.0, 0.0], [2.0 * t, 0.0], [2.0 * t, 1.0]];
    // Back along the top, right to left: a tooth 1 wide and 2 high at [2k, 2k + 1].
    for k in (0..teeth).rev() {
        let x = f64::from(k) * 2.0;
        points.extend([[x + 1.0, 1.0], [x + 1.0, 3.0], [x, 3.0], [x, 1.0]]);
    }
    let mut text = String::new();
    for p in &points {
        text += &format!("v {} {} 0\n", p[0], p[1]);
    }
    text += "f";
    for i in 1..=points.len() {
        text += &format!(" {i}");
    }
    text += "\n";
    let start = std::time::Instant::now();
    let mesh = obj::parse(text.as_bytes(), Path::new("comb.obj")).unwrap();
    assert!(start.elapsed().as_secs_f64() < 5.0);
    let mut area = 0.0;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize].map(f64::from));
        let z = cross(sub(b, a), sub(c, a))[2];
        assert!(z > 0.0, "flipped or degenerate {t:?}");
        area += z / 2.0;
    }
    // The base strip 2·teeth × 1 and teeth teeth of 1 × 2.
    let expected = f64::from(teeth) * 2.0 + f64::from(teeth) * 2.0;
    assert!(
        (area - expected).abs() < 1e-6,
        "area {area}, expected {expected}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Any polygon (random corners, repeats and all, in 3D) loads without
    /// panicking into exactly `n - 2` triangles of its own corners.
    #[test]
    fn random_polygons_give_n_minus_2_triangles(
        points in proptest::collection::vec((-4i32..4, -4i32..4, -1i32..2), 3..24),
        flat in any::<bool>(),
    ) {
        let mut text = String::new();
        for (x, y, z) in &points {
            text += &format!("v {x} {y} {}\n", if flat { 0 } else { *z });
        }
        text += "f";
        for i in 1..=points.len() {
            text += &format!(" {i}");
        }
        text += "\n";
        let mesh = obj::parse(text.as_bytes(), Path::new("random.obj")).unwrap();
        prop_assert_eq!(mesh.triangle_count(), points.len() - 2);
        let mut used: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        prop_assert!(used.iter().all(|&v| (v as usize) < points.len()));
    }
}
