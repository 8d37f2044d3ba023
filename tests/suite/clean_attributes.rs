//! Cleaning a morph keeps its vertex attributes: welding merges only vertices whose
//! position, target deltas and attributes (normals, normal deltas, UVs, colours) are all
//! equal, and every attribute array follows the kept vertices.

use morphlod::mesh::clean::CleanOptions;
use morphlod::morph::{Attributes, Morph, MorphTarget, Weights};

/// A unit square as a triangle soup (two triangles, six vertices). Vertices 0/3 and 2/4 sit
/// at the same two corners; `uvs` and the normal deltas decide which of them may weld.
fn soup(uvs: Vec<[f32; 2]>, normal_deltas: Vec<[f32; 3]>) -> Morph {
    let base = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let target = MorphTarget {
        name: "lift".to_string(),
        deltas: vec![[0.0, 0.0, 1.0]; 6],
        normal_deltas: Some(normal_deltas),
    };
    let weights = Weights::TwoPose {
        w0: vec![0.0],
        w1: vec![1.0],
    };
    Morph::from_parts(vec![[0, 1, 2], [3, 4, 5]], base, vec![target], weights)
        .unwrap()
        .with_attributes(Attributes {
            normals: Some(vec![[0.0, 0.0, 1.0]; 6]),
            uvs: Some(uvs),
            colors: Some((0..6).map(|i| [i as f32 / 8.0, 0.0, 0.0, 1.0]).collect()),
            ..Attributes::default()
        })
        .unwrap()
}

#[test]
fn welding_merges_only_vertices_with_equal_attributes() {
    // Colours differ everywhere here, so nothing welds.
    let uvs = vec![
        [0.0, 0.0],
        [1.0, 0.0],
        [1.0, 1.0],
        [0.0, 0.0],
        [1.0, 1.0],
        [0.0, 1.0],
    ];
    let morph = soup(uvs.clone(), vec![[0.0; 3]; 6]);
    let (kept, report) = morph.clean(&CleanOptions::default()).unwrap();
    assert!(report.soup_welded, "{report}");
    assert_eq!(kept.vertex_count(), 6);

    // Equal colours at the shared corners: both pairs weld; their attributes follow.
    let mut same = morph.attributes().clone();
    same.colors = Some(vec![[0.5, 0.5, 0.5, 1.0]; 6]);
    let morph = soup(uvs.clone(), vec![[0.0; 3]; 6])
        .with_attributes(same.clone())
        .unwrap();
    let (welded, report) = morph.clean(&CleanOptions::default()).unwrap();
    assert_eq!(report.welded_vertices, 2, "{report}");
    assert_eq!(welded.vertex_count(), 4);
    assert_eq!(welded.triangles(), &[[0, 1, 2], [0, 2, 3]]);
    assert_eq!(
        welded.attributes().uvs.as_deref(),
        Some(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]][..])
    );
    assert_eq!(welded.attributes().colors.as_ref().map(Vec::len), Some(4));
    assert_eq!(welded.attributes().normals.as_ref().map(Vec::len), Some(4));
    assert_eq!(
        welded.targets()[0].normal_deltas.as_ref().map(Vec::len),
        Some(4)
    );

    // A UV seam at corner (0, 0): vertices 0 and 3 stay apart, 2 and 4 weld.
    let mut seam = uvs.clone();
    seam[3] = [0.5, 0.0];
    let mut seamed = same.clone();
    seamed.uvs = Some(seam);
    let (kept, report) = morph
        .with_attributes(seamed)
        .unwrap()
        .clean(&CleanOptions::default())
        .unwrap();
    assert_eq!(report.welded_vertices, 1, "{report}");
    assert_eq!(kept.vertex_count(), 5);
    assert_eq!(kept.attributes().uvs.as_ref().unwrap()[3], [0.5, 0.0]);
    assert_eq!(kept.topology().seam_vertices(), 1);

    // Different normal deltas at corner (1, 1): 2 and 4 stay apart, 0 and 3 weld.
    let mut deltas = vec![[0.0; 3]; 6];
    deltas[4] = [0.0, 0.1, 0.0];
    let morph = soup(uvs, deltas).with_attributes(same).unwrap();
    let (kept, report) = morph.clean(&CleanOptions::default()).unwrap();
    assert_eq!(report.welded_vertices, 1, "{report}");
    assert_eq!(
        kept.targets()[0].normal_deltas.as_ref().unwrap()[3],
        [0.0, 0.1, 0.0]
    );
}

#[test]
fn dropping_unused_vertices_keeps_attributes_aligned() {
    // Vertex 1 is unused: dropped, and every attribute array loses its entry too.
    let base = vec![
        [0.0, 0.0, 0.0],
        [9.0, 9.0, 9.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let morph = Morph::from_poses(vec![[0, 2, 3]], base.clone(), base)
        .unwrap()
        .with_attributes(Attributes {
            uvs: Some(vec![[0.0, 0.0], [9.0, 9.0], [1.0, 0.0], [0.0, 1.0]]),
            ..Attributes::default()
        })
        .unwrap();
    let (kept, report) = morph.clean(&CleanOptions::default()).unwrap();
    assert_eq!(report.unreferenced_vertices, 1);
    assert_eq!(
        kept.attributes().uvs.as_deref(),
        Some(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]][..])
    );
}
