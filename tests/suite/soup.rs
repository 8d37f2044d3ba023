//! Triangle soups: meshes whose triangles share no vertex (every triangle its
//! own three vertices, as many DCC exporters write them). They are detected in
//! the library ([`morphlod::mesh::clean::detect_soup`]) and welded by default, so
//! they simplify like the surface they are instead of tearing at every coarse LOD.

use morphlod::io::{obj, off};
use morphlod::mesh::clean::{clean, CleanOptions};
use morphlod::topology::analyze;
use morphlod::IndexedMesh;
use std::path::Path;

fn cow() -> IndexedMesh {
    off::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cow.off")).unwrap()
}

/// The OBJ text of `mesh` with every triangle given its own three vertices.
pub fn soup_obj(mesh: &IndexedMesh) -> String {
    let mut text = String::new();
    for t in &mesh.triangles {
        for &v in t {
            let p = mesh.positions[v as usize];
            text += &format!("v {} {} {}\n", p[0], p[1], p[2]);
        }
    }
    for i in 0..mesh.triangles.len() {
        text += &format!("f {} {} {}\n", 3 * i + 1, 3 * i + 2, 3 * i + 3);
    }
    text
}

/// A soup of a closed mesh is welded by default back into that closed mesh.
#[test]
fn soup_of_a_closed_mesh_is_welded_by_default() {
    let cow = cow();
    let soup = obj::parse(soup_obj(&cow).as_bytes(), Path::new("soup.obj")).unwrap();
    assert_eq!(soup.vertex_count(), 3 * cow.triangle_count());
    let cleaned = clean(&soup, &CleanOptions::default()).unwrap();
    let welded_cow = clean(
        &cow,
        &CleanOptions {
            weld: true,
            ..CleanOptions::default()
        },
    )
    .unwrap();
    assert_eq!(cleaned.mesh.vertex_count(), welded_cow.mesh.vertex_count());
    assert_eq!(cleaned.mesh.triangle_count(), cow.triangle_count());
    assert_eq!(
        analyze(&cleaned.mesh).unwrap(),
        analyze(&welded_cow.mesh).unwrap()
    );
    let soup_found = cleaned.report.soup.expect("the soup is reported");
    assert_eq!(soup_found.triangles, cow.triangle_count());
    assert!(cleaned.report.soup_welded);
    assert!(
        cleaned.report.to_string().contains("soup"),
        "{}",
        cleaned.report
    );
}

/// With `weld_soup` off the soup is reported, not welded.
#[test]
fn soup_weld_can_be_turned_off() {
    let soup = obj::parse(soup_obj(&cow()).as_bytes(), Path::new("soup.obj")).unwrap();
    let options = CleanOptions {
        weld: false,
        weld_soup: false,
    };
    let cleaned = clean(&soup, &options).unwrap();
    assert_eq!(cleaned.report.welded_vertices, 0);
    assert!(cleaned.report.soup.is_some());
    assert!(!cleaned.report.soup_welded);
}

/// Detection is strict: one shared vertex, or a single triangle, is not a soup,
/// and such meshes are cleaned exactly as before.
#[test]
fn detection_is_strict() {
    use morphlod::mesh::clean::detect_soup;
    let cow = cow();
    assert_eq!(detect_soup(&cow), None);
    let single = IndexedMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    assert_eq!(detect_soup(&single), None);
    // Two triangles with their own vertices at the same corners: a soup.
    let mut positions = single.positions.clone();
    positions.extend([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]);
    let two = IndexedMesh::new(positions.clone(), vec![[0, 1, 2], [3, 4, 5]]);
    let found = detect_soup(&two).expect("a soup");
    assert_eq!((found.triangles, found.shared_positions), (2, 2));
    // Add a third triangle sharing vertex 0 with the first: not a soup any more.
    positions.push([-1.0, 0.0, 0.0]);
    let three = IndexedMesh::new(positions, vec![[0, 1, 2], [3, 4, 5], [0, 2, 6]]);
    assert_eq!(detect_soup(&three), None);
    let cleaned = clean(&three, &CleanOptions::default()).unwrap();
    assert!(cleaned.report.is_unchanged(), "{}", cleaned.report);
}

/// The cow itself (not a soup, with one pair of coincident vertices) is unchanged by default.
#[test]
fn ordinary_meshes_are_not_welded() {
    let cow = cow();
    let cleaned = clean(&cow, &CleanOptions::default()).unwrap();
    assert!(cleaned.report.is_unchanged());
    assert_eq!(cleaned.report.soup, None);
}

/// In a morph, a soup is welded only where the copies coincide in every pose: a
/// triangle that flies apart in `V(1)` keeps its own vertices, the rest is joined.
#[test]
fn morph_soup_welds_only_copies_that_coincide_in_every_pose() {
    use morphlod::morph::Morph;
    let cow = cow();
    let a = obj::parse(soup_obj(&cow).as_bytes(), Path::new("a.obj")).unwrap();
    let mut b = a.clone();
    for p in &mut b.positions {
        p[1] += 1.0; // the whole soup moves up in V(1)
    }
    // Triangle 0 flies further: its three vertices no longer meet their copies in V(1).
    for v in 0..3 {
        b.positions[v][0] += 5.0;
    }
    let morph = Morph::from_meshes(&a, &b).unwrap();
    let (cleaned, report) = morph.clean(&CleanOptions::default()).unwrap();
    assert!(report.soup_welded);
    let welded_cow = 2903;
    assert_eq!(cleaned.vertex_count(), welded_cow + 3, "{report}");
    assert_eq!(cleaned.triangle_count(), cow.triangle_count());
}
