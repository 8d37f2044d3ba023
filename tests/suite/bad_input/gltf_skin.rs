//! Malformed skins: each broken variant of the generated bar (tests/common/skinned.rs) is
//! refused with the typed error that names the file, the element and what to do; weights a
//! little off are renormalised with a note; more than four influences load and reduce to four
//! with the error stated.

use crate::common;

use common::skinned::{accessor, Layout, SkinnedBar};
use morphlod::io::{load_morph_noted, LoadError, LoadOptions, MorphSource};
use morphlod::morph::Morph;
use morphlod::skin::SkinError;
use serde_json::json;
use std::path::PathBuf;

fn write(bar: &SkinnedBar, name: &str) -> PathBuf {
    bar.write(&common::scratch_dir("bad_skin", name), "bar.glb")
}

fn load(bar: &SkinnedBar, name: &str) -> Result<(Morph, Vec<String>), LoadError> {
    let source = MorphSource::Animation("bend".into());
    load_morph_noted(&write(bar, name), &LoadOptions::default(), &source)
}

/// One broken variant: what it changes, the error expected and what its message must say.
struct Case {
    name: &'static str,
    change: fn(&mut SkinnedBar),
    expect: fn(&LoadError) -> bool,
    says: &'static [&'static str],
}

fn skin(e: &LoadError) -> Option<&SkinError> {
    match e {
        LoadError::GltfSkin { source, .. } => Some(source),
        _ => None,
    }
}

fn data(e: &LoadError) -> bool {
    matches!(e, LoadError::GltfData { .. })
}

fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "joint_out_of_range",
            change: |b| b.set_u16(accessor::JOINTS, 5, 1, 7),
            expect: |e| {
                matches!(
                    skin(e),
                    Some(SkinError::JointOutOfRange {
                        vertex: 5,
                        influence: 1,
                        joint: 7,
                        joints: 3
                    })
                )
            },
            says: &["skin 'chain'", "vertex 5 names joint 7", "3 joints"],
        },
        Case {
            name: "weights_far_from_one",
            change: |b| b.set_f32(accessor::WEIGHTS, 3, 0, 0.5),
            expect: |e| matches!(skin(e), Some(SkinError::WeightSum { vertex: 3, .. })),
            says: &["sum to 0.5", "normalise the weights"],
        },
        Case {
            name: "negative_weight",
            change: |b| {
                b.set_f32(accessor::WEIGHTS, 10, 0, 1.25);
                b.set_f32(accessor::WEIGHTS, 10, 1, -0.25);
            },
            expect: |e| {
                matches!(
                    skin(e),
                    Some(SkinError::BadWeight {
                        vertex: 10,
                        influence: 1,
                        ..
                    })
                )
            },
            says: &["-0.25", "not negative"],
        },
        Case {
            name: "nan_weight",
            change: |b| b.set_f32(accessor::WEIGHTS, 2, 0, f32::NAN),
            expect: data,
            says: &["WEIGHTS_0", "NaN"],
        },
        Case {
            name: "nan_inverse_bind",
            change: |b| b.set_f32(accessor::INVERSE_BINDS, 1, 5, f32::NAN),
            expect: data,
            says: &["inverseBindMatrices", "NaN"],
        },
        Case {
            name: "singular_inverse_bind",
            change: |b| {
                for row in 0..3 {
                    b.set_f32(accessor::INVERSE_BINDS, 1, row, 0.0);
                }
            },
            expect: |e| matches!(skin(e), Some(SkinError::InverseBind { joint: 1, .. })),
            says: &["joint 1", "'j1'", "singular"],
        },
        Case {
            name: "too_few_inverse_binds",
            change: |b| b.json["accessors"][accessor::INVERSE_BINDS]["count"] = json!(2),
            expect: data,
            says: &["has 2 matrices for 3 joints"],
        },
        Case {
            name: "skeleton_outside_the_scene",
            change: |b| b.json["scenes"][0]["nodes"] = json!([0]),
            expect: data,
            says: &[
                "joint node 2 is not in scene 0",
                "put the skeleton in that scene",
            ],
        },
        Case {
            name: "sheared_ancestor",
            change: |b| b.json["nodes"][1]["matrix"][4] = json!(0.5),
            expect: data,
            says: &["node 'rig'", "shears"],
        },
        Case {
            name: "float_joints",
            change: |b| b.json["accessors"][accessor::JOINTS]["componentType"] = json!(5126),
            expect: data,
            says: &["JOINTS_0", "UNSIGNED_BYTE or UNSIGNED_SHORT"],
        },
        Case {
            name: "integer_weights",
            change: |b| {
                b.json["accessors"][accessor::WEIGHTS]["componentType"] = json!(5121);
                b.json["accessors"][accessor::WEIGHTS]["count"] = json!(36);
            },
            expect: data,
            says: &["WEIGHTS_0", "normalized"],
        },
        Case {
            name: "joints_without_weights",
            change: |b| {
                b.json["meshes"][0]["primitives"][0]["attributes"]["JOINTS_1"] =
                    json!(accessor::JOINTS)
            },
            expect: data,
            says: &["no JOINTS_1 and WEIGHTS_1 pair"],
        },
        Case {
            name: "non_unit_rotation_key",
            change: |b| {
                let output = b.json["animations"][0]["samplers"][0]["output"]
                    .as_u64()
                    .unwrap();
                b.set_f32(output as usize, 2, 3, 2.0);
            },
            expect: |e| matches!(skin(e), Some(SkinError::Channel { channel: 0, .. })),
            says: &["node 'root'", "length"],
        },
        Case {
            name: "key_times_out_of_order",
            change: |b| {
                let input = b.json["animations"][0]["samplers"][3]["input"]
                    .as_u64()
                    .unwrap();
                b.set_f32(input as usize, 2, 0, 0.2);
            },
            expect: data,
            says: &["sampler 3", "strictly increasing"],
        },
    ]
}

/// Every broken variant is refused as its row says; the report lists every row that is not.
#[test]
fn broken_skins_are_refused_with_what_is_wrong() {
    let failures: Vec<String> = cases()
        .into_iter()
        .filter_map(|case| {
            let mut bar = SkinnedBar::new(Layout::Float);
            (case.change)(&mut bar);
            let err = match load(&bar, case.name) {
                Ok(_) => return Some(format!("{}: accepted", case.name)),
                Err(err) => err,
            };
            let message = err.to_string();
            if !(case.expect)(&err) {
                return Some(format!("{}: unexpected error {err:?}", case.name));
            }
            let missing = case.says.iter().find(|s| !message.contains(*s));
            let named = message.contains("bar.glb");
            match (missing, named) {
                (Some(s), _) => Some(format!("{}: {message:?} should say {s:?}", case.name)),
                (None, false) => Some(format!("{}: {message:?} does not name the file", case.name)),
                (None, true) => None,
            }
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Sums off by 2 % (8-bit rounding, lax exporters) are renormalised, with a note saying how
/// many vertices and how far; the skin then sums to 1.
#[test]
fn weights_a_little_off_are_renormalised_with_a_note() {
    let mut bar = SkinnedBar::new(Layout::Float);
    bar.set_f32(accessor::WEIGHTS, 3, 0, 0.98);
    bar.set_f32(accessor::WEIGHTS, 33, 2, 0.99);
    let (morph, notes) = load(&bar, "renormalised").unwrap();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("2 vertices") && notes[0].contains("0.98"),
        "{notes:?}"
    );
    let skin = &morph.skinning().unwrap().skin;
    for w in skin.weights.chunks_exact(skin.influences) {
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }
    assert!(
        (skin.weights[12] - 1.0).abs() < 1e-6,
        "vertex 3: 0.98 / 0.98"
    );
}

/// Two JOINTS/WEIGHTS sets load as 8 influences (a vertex uses at most 3 joints: up to two
/// in its first set, a tenth of its weight on a third); reduced to 4, nothing is dropped and
/// the pose stays; reduced to 2, the vertices of the rings that blend two joints lose the
/// tenth, and the report says so and how far the pose moves.
#[test]
fn more_than_four_influences_load_and_reduce_with_the_error_stated() {
    let (mut morph, _) = load(&SkinnedBar::new(Layout::TwoSets), "two_sets").unwrap();
    let skin = &morph.skinning().unwrap().skin;
    assert_eq!(skin.influences, 8);
    let full: Vec<Vec<[f32; 3]>> = (0..5).map(|k| morph.positions_at(k as f32 / 4.0)).collect();
    let four = morph.reduce_influences(4).unwrap();
    assert_eq!(four.vertices, 0, "no vertex has more than 4 joints");
    for (k, pose) in full.iter().enumerate() {
        let now = morph.positions_at(k as f32 / 4.0);
        let far = now
            .iter()
            .zip(pose)
            .map(|(&a, &b)| glam::Vec3::from(a).distance(glam::Vec3::from(b)))
            .fold(0.0, f32::max);
        assert!(far < 1e-5, "reduced to 4, the pose stays: {far}");
    }
    let two = morph.reduce_influences(2).unwrap();
    // Rings 2-4 and 6-7 blend two joints plus the extra one: 20 vertices lose a weight.
    assert_eq!(two.vertices, 20);
    assert!((two.max_dropped_weight - 0.1).abs() < 1e-6, "{two:?}");
    assert!(
        two.max_displacement > 0.0,
        "the pose moves where a joint is dropped"
    );
    assert_eq!(morph.skinning().unwrap().skin.influences, 2);
}
