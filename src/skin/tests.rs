//! The skin's definitions checked on cases computed by hand.

use super::*;
use crate::keyframes::Interpolation;

/// A root at the origin and its child "arm" at (0, 1, 0), which turns about z from 0° at
/// 0 s to 90° at 1 s (LINEAR); the arm's inverse bind matrix undoes its rest translation.
/// Vertex 0 (1, 1, 0) follows the arm alone, vertex 1 (1, 1, 0) half the root, half the arm,
/// vertex 2 the root.
fn arm() -> Skinning {
    let (s, c) = (45f32.to_radians().sin(), 45f32.to_radians().cos());
    let skeleton = Skeleton {
        parents: vec![NO_PARENT, 0],
        rest: vec![
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, //
            0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0,
        ],
        names: vec!["root".into(), "arm".into()],
    };
    let mut inverse_binds = Mat4::IDENTITY.to_cols_array().to_vec();
    inverse_binds.extend(Mat4::from_translation(Vec3::new(0.0, -1.0, 0.0)).to_cols_array());
    Skinning {
        skin: Skin {
            skeleton,
            joint_nodes: vec![0, 1],
            inverse_binds,
            influences: 2,
            joints: vec![1, 0, 0, 1, 0, 0],
            weights: vec![1.0, 0.0, 0.5, 0.5, 1.0, 0.0],
        },
        clip: Clip {
            name: "raise".into(),
            duration: 1.0,
            looping: false,
            channels: vec![JointChannel {
                node: 1,
                track: NodeTrack {
                    property: NodeProperty::Rotation,
                    interpolation: Interpolation::Linear,
                    times: vec![0.0, 1.0],
                    values: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, s, c],
                },
            }],
        },
    }
}

fn close(a: &[[f32; 3]], b: &[[f32; 3]]) {
    for (p, q) in a.iter().zip(b) {
        assert!(
            Vec3::from(*p).distance(Vec3::from(*q)) < 1e-6,
            "{a:?} vs {b:?}"
        );
    }
}

/// At 1 s the arm has turned 90°: (1, 1, 0) → (0, 2, 0); the half-bound vertex lands
/// halfway, (0.5, 1.5, 0); at ½ s (45°) the arm's vertex is at (cos 45°, 1 + sin 45°, 0);
/// the bind pose at 0 s; the root's vertex never moves.
#[test]
fn pose_is_linear_blend_skinning() {
    let arm = arm();
    arm.validate(3).unwrap();
    let bind = vec![[1.0, 1.0, 0.0]; 3];
    close(&arm.pose_at(&bind, 0.0), &bind);
    close(
        &arm.pose_at(&bind, 1.0),
        &[[0.0, 2.0, 0.0], [0.5, 1.5, 0.0], [1.0, 1.0, 0.0]],
    );
    let h = std::f32::consts::FRAC_1_SQRT_2;
    close(&arm.pose_at(&bind, 0.5)[..1], &[[h, 1.0 + h, 0.0]]);
    // The baked matrices are the joint matrices at each time, one after the other.
    let baked = arm.bake(&arm.clip.key_times());
    assert_eq!(arm.clip.key_times(), vec![0.0, 1.0]);
    let mut at_one = Vec::new();
    arm.joint_matrices(1.0, &mut at_one);
    assert_eq!(baked.len(), 2 * 2 * 16);
    assert_eq!(&baked[32..], &at_one[..]);
    assert!(!arm.clip.returns_to_start(&arm.skin.skeleton));
}

/// A vertex bound to the same joint twice with its weights split moves like one bound once;
/// reduced to one influence, the half-bound vertex follows the joint listed first of two
/// equal weights (the root) and the displacement is what it no longer follows of the arm.
#[test]
fn reduction_keeps_the_largest_and_reports_the_error() {
    let mut arm = arm();
    arm.skin.joints[0..2].copy_from_slice(&[1, 1]);
    arm.skin.weights[0..2].copy_from_slice(&[0.25, 0.75]);
    let bind = vec![[1.0, 1.0, 0.0]; 3];
    let full = arm.pose_at(&bind, 1.0);
    close(&full[..1], &[[0.0, 2.0, 0.0]]);
    let reduction = arm.reduce_influences(1, &bind);
    assert_eq!(arm.skin.influences, 1);
    assert_eq!(arm.skin.joints, vec![1, 0, 0]);
    assert_eq!(arm.skin.weights, vec![1.0, 1.0, 1.0]);
    assert_eq!(
        reduction.vertices, 1,
        "only the half-bound vertex lost a joint"
    );
    assert_eq!(reduction.max_dropped_weight, 0.5);
    // At 1 s it was at (0.5, 1.5, 0), now at (1, 1, 0).
    assert!((reduction.max_displacement - 0.5f32.hypot(0.5)).abs() < 1e-6);
    arm.validate(3).unwrap();
}

#[test]
fn weights_are_renormalised_within_the_tolerance_and_refused_beyond() {
    let mut arm = arm();
    arm.skin.weights[2..4].copy_from_slice(&[0.5, 0.49]);
    assert!(matches!(
        arm.validate(3),
        Err(SkinError::WeightSum { vertex: 1, .. })
    ));
    let changed = arm.skin.normalize_weights().unwrap();
    assert_eq!(changed.vertices, 1);
    assert_eq!(changed.worst_sum, 0.99);
    arm.validate(3).unwrap();
    arm.skin.weights[2..4].copy_from_slice(&[0.5, 0.2]);
    let err = arm.skin.normalize_weights().unwrap_err();
    assert!(err.to_string().contains("sum to 0.7"), "{err}");
    arm.skin.weights[2..4].copy_from_slice(&[1.5, -0.5]);
    assert!(matches!(
        arm.skin.normalize_weights(),
        Err(SkinError::BadWeight {
            vertex: 1,
            influence: 1,
            ..
        })
    ));
}

#[test]
fn bad_skins_are_refused_with_what_is_wrong() {
    let arm = arm();
    let mut bad = arm.clone();
    bad.skin.joints[3] = 2;
    assert!(matches!(
        bad.validate(3),
        Err(SkinError::JointOutOfRange {
            vertex: 1,
            influence: 1,
            joint: 2,
            joints: 2
        })
    ));
    let mut flat = arm.clone();
    flat.skin.inverse_binds[16 + 5] = 0.0;
    let err = flat.validate(3).unwrap_err();
    assert!(err.to_string().contains("singular"), "{err}");
    assert!(err.to_string().contains("'arm'"), "{err}");
    let mut nan = arm.clone();
    nan.skin.inverse_binds[3] = f32::NAN;
    assert!(nan.validate(3).is_err());
    assert!(matches!(
        arm.validate(4),
        Err(SkinError::VertexData { vertices: 4, .. })
    ));
    let mut off = arm.clone();
    off.clip.channels[0].node = 5;
    assert!(matches!(
        off.validate(3),
        Err(SkinError::ChannelNode { node: 5, .. })
    ));
    let mut short = arm;
    short.clip.duration = 0.5;
    assert!(matches!(short.validate(3), Err(SkinError::Duration { .. })));
}

/// The arm turns 90° in 1 s: baked at the base 60 keys a second its vertex cuts the chord
/// between keys, `1 - cos(0.75°)` ≈ 8.6e-5 of its unit radius (3.8e-5 of the bind pose's
/// diagonal, √5); `intervals_within` bakes finer until the drift, measured on every vertex
/// at 16 times an interval, is within the tolerance, and stops at the base where the
/// tolerance is loose, the bind pose has no size, or the keys would pass the budget.
#[test]
fn keys_are_baked_close_enough_for_the_tolerance() {
    let arm = arm();
    let bind = vec![[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 0.0, 0.0]];
    let diagonal = 5f32.sqrt();
    let base = BakedClip::intervals_for(&arm.clip);
    assert_eq!(base, 60);
    let drift = |n: usize| BakedClip::bake(&arm, n).max_error(&arm, &bind, 16 * n + 1) / diagonal;
    assert!(drift(base) > BAKE_TOLERANCE, "{}", drift(base));
    let n = BakedClip::intervals_within(&arm, &bind, BAKE_TOLERANCE);
    assert!(n > base && drift(n) <= BAKE_TOLERANCE, "{n}: {}", drift(n));
    // Not wastefully fine: half as many keys would not do.
    assert!(drift(n / 2) > BAKE_TOLERANCE, "{n}");
    assert_eq!(BakedClip::intervals_within(&arm, &bind, 1e-3), base);
    assert_eq!(
        BakedClip::intervals_within(&arm, &[[1.0, 1.0, 0.0]; 3], 1e-9),
        base
    );
    // A clip whose base keys pass the budget keeps them (the caller checks its limits).
    let mut long = arm.clone();
    long.clip.duration = 1e4;
    long.clip.channels[0].track.times[1] = 1e4;
    let long_base = BakedClip::intervals_for(&long.clip);
    assert!(4 * BakedClip::floats(long_base, 2) > KEY_BUDGET);
    assert_eq!(
        BakedClip::intervals_within(&long, &bind, BAKE_TOLERANCE),
        long_base
    );
}
