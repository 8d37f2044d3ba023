//! Issue 13 item 2 (part): equal frames share their data after load. A file
//! whose 4,096 frames repeat one frame (two bytes a frame on disk) must not
//! make 4,096 copies of that frame's change lists.

use morphlod::build::Builder;
use morphlod::deform::DeformingModel;
use morphlod::Asset;

use crate::common;
use common::grid_morph;

/// A valid asset of a `side`² grid whose frames are `pattern` (indices into two built frames:
/// frame 0 simplifies the flat grid, frame 1 its bumps, so the two differ).
fn asset_with_frames(side: u32, pattern: &[usize]) -> Asset {
    let morph = grid_morph(side, |x, y| ((x * 7 + y * 3) % 5) as f32 * 0.1);
    let (mut asset, _) = Builder::new(&morph).frames(2).build().expect("build");
    let built = asset.frames.clone();
    asset.frames = pattern.iter().map(|&i| built[i].clone()).collect();
    // Through the file, as a user gets it.
    Asset::from_bytes(&asset.to_bytes()).expect("a valid file")
}

#[test]
fn repeated_frames_share_their_change_lists() {
    let asset = asset_with_frames(40, &[0; 4096]);
    let model = DeformingModel::new(&asset).unwrap();
    assert_eq!(model.frame_count(), 4096);
    let first = model.frame_changes(0).unwrap();
    for k in [1, 2047, 4095] {
        assert!(
            std::ptr::eq(first, model.frame_changes(k).unwrap()),
            "frame {k} holds its own copy of frame 0's change lists"
        );
    }
    assert_eq!(model.distinct_frames(), 1);
}

/// Frames equal to an earlier, non-adjacent frame share too; different frames do not.
#[test]
fn only_equal_frames_are_shared() {
    let asset = asset_with_frames(20, &[0, 0, 1, 1, 0, 1]);
    assert_ne!(
        asset.frames[0], asset.frames[2],
        "the two built frames differ"
    );
    let model = DeformingModel::new(&asset).unwrap();
    let f = |k| model.frame_changes(k).unwrap() as *const _;
    assert_eq!(f(0), f(1));
    assert_eq!(f(0), f(4));
    assert_eq!(f(2), f(3));
    assert_eq!(f(2), f(5));
    assert_ne!(f(0), f(2));
    assert_eq!(model.distinct_frames(), 2);
}

/// Frames whose coded bytes are equal but not adjacent (the file codes each in full)
/// share one sequence after load.
#[test]
fn equal_coded_frames_share_one_sequence_after_load() {
    let asset = asset_with_frames(20, &[0, 1, 0, 1, 0, 1, 0, 1]);
    assert_ne!(
        asset.frames[0], asset.frames[1],
        "the two built frames differ"
    );
    assert_eq!(asset.frames.len(), 8);
    assert_eq!(asset.distinct_frames(), 2);
    for k in 2..8 {
        assert!(std::sync::Arc::ptr_eq(
            &asset.frames[k],
            &asset.frames[k % 2]
        ));
    }
}

/// The builder simplifies a pose once: frames whose sampled positions are equal (a mesh
/// morphed to itself) share one sequence, and the file is the same as before.
#[test]
fn builder_shares_frames_with_equal_poses() {
    let morph = grid_morph(30, |_, _| 0.0);
    let (asset, report) = Builder::new(&morph).frames(64).build().expect("build");
    assert_eq!(asset.frames.len(), 64);
    assert_eq!(asset.distinct_frames(), 1);
    assert_eq!(report.collapses.len(), 64);
    // A morph that moves: every frame its own pose, so its own sequence, none shared wrongly
    // (five distinct sequences in memory), each the one simplifying its pose alone gives.
    let moving = grid_morph(12, |x, y| ((x * 7 + y * 3) % 5) as f32 * 0.1);
    let (asset, _) = Builder::new(&moving).frames(5).build().expect("build");
    assert_eq!(asset.distinct_frames(), 5);
    let options = morphlod::simplify::SimplifyOptions::default();
    let collapses = |seq: &morphlod::CollapseSequence| -> Vec<(u32, u32)> {
        seq.collapses.iter().map(|c| (c.u, c.w)).collect()
    };
    for (k, frame) in asset.frames.iter().enumerate() {
        let pose = moving.positions_at(k as f32 / 4.0);
        let alone = morphlod::simplify::simplify(&pose, moving.triangles(), &options);
        assert_eq!(collapses(frame), collapses(&alone), "frame {k}");
    }
    let back = Asset::from_bytes(&asset.to_bytes()).unwrap();
    assert_eq!(back, asset);
}
