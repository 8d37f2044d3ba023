//! The builder's own tests: bad inputs refused, junctions that must not join, a strip that
//! dies and comes back.

use super::*;
use crate::collapse::canonical_multiset;
use crate::lodstrips::{LodError, LodStrips, StripsState};
use crate::strip::{strip_triangles, Strips};

fn seq(n: u32, pairs: &[(u32, u32)]) -> CollapseSequence {
    CollapseSequence::from_pairs(n, pairs)
}

fn drawn(model: &LodStrips, state: &StripsState) -> Vec<[u32; 3]> {
    let mut t = Vec::new();
    for s in 0..model.strip_count() {
        let strip = state.strip(s).map(|s| s.to_vec()).unwrap_or_default();
        t.extend(strip_triangles(&strip));
    }
    canonical_multiset(t)
}

#[test]
fn rejects_bad_inputs() {
    let strips = Strips {
        indices: vec![0, 1, 2],
        offsets: vec![0, 3],
    };
    let bad = Strips {
        indices: vec![0, 1, 2],
        offsets: vec![0, 2],
    };
    assert!(matches!(
        LodStrips::build(&bad, &seq(3, &[])),
        Err(ChangeListError::BadOffsets { .. })
    ));
    assert!(matches!(
        LodStrips::build(&strips, &seq(2, &[])),
        Err(ChangeListError::IndexOutOfRange { index: 2, .. })
    ));
    assert!(matches!(
        LodStrips::build(&strips, &seq(3, &[(0, 0)])),
        Err(ChangeListError::Sequence(_))
    ));
}

#[test]
fn junctions_never_join_vertices_into_a_new_triangle() {
    // Strip 0: collapsing 3 → 2 and 4 → 5 leaves `0 1 2 2 5 5 6 7`; the
    // middle `2 5` is unneeded, but cutting it would draw (1, 2, 5) and
    // (2, 5, 6). Strip 1: `8 9 10 10 10 10 11 12` after 13, 14 → 10 may
    // lose two 10s (`(aa)+ → aa`), never three (the trap described in `docs/DESIGN.md`).
    let indices = vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 13, 14, 10, 11, 12];
    let strips = Strips {
        indices: indices.clone(),
        offsets: vec![0, 8, 16],
    };
    let tris = strips.triangles();
    let s = seq(15, &[(3, 2), (4, 5), (13, 10), (14, 10)]);
    let model = LodStrips::build(&strips, &s).unwrap();
    let mut state = StripsState::new(&model);
    for l in [2, 4, 1, 3, 0, 4, 2, 0] {
        state.set_lod(&model, l).unwrap();
        assert_eq!(
            drawn(&model, &state),
            canonical_multiset(s.reference_mesh(&tris, l))
        );
        assert_eq!(state.triangle_count(), s.reference_mesh(&tris, l).len());
    }
    state.set_lod(&model, 4).unwrap();
    assert_eq!(state.strip(0).unwrap().to_vec(), [0, 1, 2, 2, 5, 5, 6, 7]);
    assert_eq!(state.strip(1).unwrap().to_vec(), [8, 9, 10, 10, 11, 12]);
}

#[test]
fn dead_strip_vanishes_and_comes_back() {
    let strips = Strips {
        indices: vec![0, 1, 2, 3],
        offsets: vec![0, 4],
    };
    let s = seq(4, &[(3, 2), (2, 1)]);
    let model = LodStrips::build(&strips, &s).unwrap();
    let mut state = StripsState::new(&model);
    state.set_lod(&model, 2).unwrap();
    assert_eq!(state.index_count(), 0);
    state.set_lod(&model, 0).unwrap();
    assert_eq!(state.strip(0).unwrap().to_vec(), [0, 1, 2, 3]);
    let dirty = state.take_dirty();
    assert_eq!(dirty.lengths, vec![0]);
    assert_eq!(state.strip(1), None);
    let other = LodStrips::build(&strips, &s).unwrap();
    assert_eq!(state.set_lod(&other, 1), Err(LodError::WrongModel));
}
