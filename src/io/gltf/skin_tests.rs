//! The skinned walker read as glTF defines it: skin, skeleton, clip and weights.

use super::*;
use std::path::PathBuf;

fn walker() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_walker.glb")
}

fn distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    glam::Vec3::from(a).distance(glam::Vec3::from(b))
}

/// The walker's `walk`: 53 joints over 54 skeleton nodes (the joints and the mesh-less root
/// above them), 4 influences a vertex, 14 channels over 1 s that end where they start, the
/// body's 4 targets at their default weights; a loop, so t = 1 shows the pose of t = 0.
#[test]
fn the_walker_loads_as_a_skinned_loop() {
    let source = MorphSource::Animation("walk".into());
    let (morph, notes) = load_morph_noted(&walker(), &LoadOptions::default(), &source).unwrap();
    assert!(notes.is_empty(), "{notes:?}");
    let skinning = morph.skinning().expect("skinned");
    let skin = &skinning.skin;
    assert_eq!(skin.joint_count(), 53);
    assert_eq!(skin.influences, 4);
    assert_eq!(skin.joints.len(), 4 * 13_380);
    assert_eq!(
        (skinning.clip.name.as_str(), skinning.clip.duration),
        ("walk", 1.0)
    );
    assert_eq!(skinning.clip.channels.len(), 14);
    assert!(skinning.clip.looping && morph.looping());
    assert_eq!(morph.targets().len(), 4);
    assert!(matches!(morph.weights(), Weights::TwoPose { w0, w1 } if w0 == w1));
    assert_eq!(
        morph.v0(),
        morph.base(),
        "default weights 0: V(0) is the bind pose"
    );
    let (start, end) = (morph.positions_at(0.0), morph.positions_at(1.0));
    let moved = morph.positions_at(0.25);
    let gap = start.iter().zip(&end).map(|(&a, &b)| distance(a, b));
    assert!(gap.fold(0.0, f32::max) < 1e-4);
    let stride = start.iter().zip(&moved).map(|(&a, &b)| distance(a, b));
    assert!(
        stride.fold(0.0, f32::max) > 0.05,
        "a quarter of the walk moves the legs"
    );
}

/// `morph` drives the weights and no joint: the skeleton stays at rest, where the inverse
/// bind matrices undo the joints' rest transforms, so the skinned pose is the morphed one;
/// played beside `walk`, the clip is the walk and the weights are `morph`'s.
#[test]
fn weights_come_from_the_clip_or_another_animation() {
    let rest = load_morph(
        &walker(),
        &LoadOptions::default(),
        &MorphSource::Animation("morph".into()),
    )
    .unwrap();
    assert!(rest.skinning().unwrap().clip.channels.is_empty());
    for t in [0.0, 0.3, 0.8] {
        let (skinned, morphed) = (rest.positions_at(t), rest.morphed_at(t));
        let far = skinned
            .iter()
            .zip(&morphed)
            .map(|(&a, &b)| distance(a, b))
            .fold(0.0, f32::max);
        assert!(far < 1e-5, "t = {t}: {far}");
    }
    let both = MorphSource::AnimationWithWeights {
        animation: "walk".into(),
        weights: "morph".into(),
    };
    let morph = load_morph(&walker(), &LoadOptions::default(), &both).unwrap();
    let Weights::Animated(track) = morph.weights() else {
        panic!("the weights are morph's track");
    };
    assert_eq!(track.duration(), 8.0);
    assert_eq!(morph.skinning().unwrap().clip.duration, 1.0);
    let unskinned = MorphSource::AnimationWithWeights {
        animation: "0".into(),
        weights: "0".into(),
    };
    let body = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_body.glb");
    let err = load_morph(&body, &LoadOptions::default(), &unskinned).unwrap_err();
    assert!(matches!(err, LoadError::NotSkinned { .. }), "{err}");
}
