//! The skinned pose against an independent computation: three.js's own skinning
//! (`.ci/gltf-loader/skin.mjs`: its AnimationMixer sets the clips' times, its
//! `SkinnedMesh.getVertexPosition` morphs and skins every vertex on the CPU) agrees with
//! [`morphlod::skin::Skinning::pose_at`], reached through [`morphlod::Morph::positions_at`],
//! within 1e-4 of the bounding-box diagonal, at times on keys, between keys and past the end,
//! for the walker (`walk`, and `walk` with `morph`'s weights) and for a generated bar
//! (tests/common/skinned.rs: LINEAR, STEP and CUBICSPLINE channels, a matrix ancestor, a
//! weight channel in the same animation, float or normalized weights). Where node or three.js
//! is missing the tests say so and pass, except under CI.

use crate::common;

use base64::Engine;
use common::skinned::{Layout, SkinnedBar};
use common::validator::run_node;
use morphlod::io::{load_morph, LoadOptions, MorphSource};
use morphlod::morph::Morph;
use std::path::Path;

/// three.js's skinned positions of mesh 0 of `file` at each sample (clip name → seconds);
/// `None` where node or three.js is missing (outside CI).
pub(crate) fn three_positions(
    file: &Path,
    samples: &[Vec<(&str, f32)>],
) -> Option<Vec<Vec<[f32; 3]>>> {
    let json: Vec<serde_json::Value> = samples
        .iter()
        .map(|s| {
            serde_json::Value::Object(s.iter().map(|&(c, t)| (c.to_string(), t.into())).collect())
        })
        .collect();
    let arg = serde_json::to_string(&json).unwrap();
    let (ok, report) = run_node(
        "gltf-loader",
        "three",
        "skin.mjs",
        &[file.as_os_str(), "0".as_ref(), arg.as_ref()],
    )?;
    assert!(ok, "{report}");
    let parsed: serde_json::Value = serde_json::from_str(report.lines().next().unwrap()).unwrap();
    Some(
        parsed["positions"]
            .as_array()
            .unwrap()
            .iter()
            .map(|b64| {
                let bytes = base64::engine::general_purpose::STANDARD
                    .decode(b64.as_str().unwrap())
                    .unwrap();
                bytes
                    .chunks_exact(12)
                    .map(|c| {
                        std::array::from_fn(|i| {
                            f32::from_le_bytes(c[4 * i..4 * i + 4].try_into().unwrap())
                        })
                    })
                    .collect()
            })
            .collect(),
    )
}

/// The largest distance between the morph's pose at each `t` and three's at the matching
/// sample, over the diagonal of the morph's pose; fails above 1e-4.
fn agree(name: &str, morph: &Morph, ts: &[f32], three: &[Vec<[f32; 3]>]) {
    for (&t, theirs) in ts.iter().zip(three) {
        let ours = morph.positions_at(t);
        assert_eq!(ours.len(), theirs.len(), "{name}: vertex counts");
        let diagonal = common::diagonal(&ours) as f32;
        let far = ours
            .iter()
            .zip(theirs)
            .map(|(&a, &b)| glam::Vec3::from(a).distance(glam::Vec3::from(b)))
            .fold(0.0f32, f32::max);
        println!(
            "{name} t = {t}: largest distance {:.2e} of the diagonal",
            far / diagonal
        );
        assert!(
            far <= 1e-4 * diagonal,
            "{name} at t = {t}: three.js's pose is {far} away ({} of the diagonal {diagonal})",
            far / diagonal
        );
    }
}

/// The walker's `walk` at times on its keys (every 1/24 s), between them and at both ends,
/// with the default weights and with `morph`'s weights played over the walk (three plays
/// `morph` at 8 × the walk's time: both over t ∈ [0, 1]).
#[test]
fn the_walker_skins_as_three_js_skins_it() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_walker.glb");
    let ts = [0.0, 1.0 / 24.0, 0.13, 0.3, 0.5, 0.77, 0.99, 1.0];
    let walk = load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("walk".into()),
    )
    .unwrap();
    let samples: Vec<Vec<(&str, f32)>> = ts.iter().map(|&t| vec![("walk", t)]).collect();
    let Some(three) = three_positions(&path, &samples) else {
        return;
    };
    agree("walk", &walk, &ts, &three);
    let source = MorphSource::AnimationWithWeights {
        animation: "walk".into(),
        weights: "morph".into(),
    };
    let both = load_morph(&path, &LoadOptions::default(), &source).unwrap();
    let samples: Vec<Vec<(&str, f32)>> = ts
        .iter()
        .map(|&t| vec![("walk", t), ("morph", 8.0 * t)])
        .collect();
    let three = three_positions(&path, &samples).unwrap();
    agree("walk with morph's weights", &both, &ts, &three);
}

/// The bar at times around every key of its channels (1.2 s long; STEP keys at 0.4 and
/// 0.9 s, the others at 0, 0.6 and 1.2 s) and after its end, stored with float weights and
/// with UNSIGNED_BYTE joints and normalized UNSIGNED_SHORT weights.
#[test]
fn the_generated_bar_skins_as_three_js_skins_it() {
    let dir = common::scratch_dir("skin_oracle", "bar");
    let seconds = [0.0, 0.1, 0.39, 0.41, 0.6, 0.77, 0.95, 1.2, 1.5];
    for layout in [Layout::Float, Layout::Normalized] {
        let path = SkinnedBar::new(layout).write(&dir, &format!("{layout:?}.glb"));
        let morph = load_morph(
            &path,
            &LoadOptions::default(),
            &MorphSource::Animation("bend".into()),
        )
        .unwrap();
        let skinning = morph.skinning().unwrap();
        assert_eq!(
            (skinning.clip.duration, skinning.clip.channels.len()),
            (1.2, 5)
        );
        assert!(!morph.looping());
        let samples: Vec<Vec<(&str, f32)>> = seconds.iter().map(|&s| vec![("bend", s)]).collect();
        let Some(three) = three_positions(&path, &samples) else {
            return;
        };
        let ts: Vec<f32> = seconds.iter().map(|s| s / 1.2).collect();
        agree(&format!("bar ({layout:?})"), &morph, &ts, &three);
    }
}
