//! File → [`Morph`] on the bundled glTF assets: targets, animations, default weights,
//! node transforms, and the GPU target blend an animated morph carries.

use super::*;
use crate::morph::{ImageFormat, Sampler, TargetBlend};
use std::path::PathBuf;

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name)
}

fn close(a: &[[f32; 3]], b: &[[f32; 3]], tolerance: f32) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(p, q)| (0..3).all(|c| (p[c] - q[c]).abs() <= tolerance))
}

fn target(path: &Path, name: &str) -> Morph {
    load_morph(
        path,
        &LoadOptions::default(),
        &MorphSource::Target(name.to_string()),
    )
    .unwrap()
}

#[test]
fn body_target_and_animation() {
    let path = asset("makehuman_body.glb");
    let old = target(&path, "caucasian-female-old");
    assert_eq!((old.vertex_count(), old.triangle_count()), (13_380, 26_756));
    assert!(old.is_linear());
    assert_eq!(old.v0(), old.base());
    assert_ne!(old.v1(), old.v0());
    // Linear: the midpoint pose is the average of the end poses.
    let (v0, v1) = (old.v0(), old.v1());
    let mid: Vec<[f32; 3]> = v0
        .iter()
        .zip(&v1)
        .map(|(a, b)| {
            [
                (a[0] + b[0]) / 2.0,
                (a[1] + b[1]) / 2.0,
                (a[2] + b[2]) / 2.0,
            ]
        })
        .collect();
    assert!(close(&old.positions_at(0.5), &mid, 1e-6));

    let animated = load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("morph".to_string()),
    )
    .unwrap();
    assert!(!animated.is_linear());
    assert_eq!(animated.targets().len(), 4);
    // Keys at 0..8 s; target i peaks at 2i+1 s: t = 1/8 is 1 s, t = 3/8 is 3 s.
    assert_eq!(animated.weights_at(0.125), vec![1.0, 0.0, 0.0, 0.0]);
    assert_eq!(animated.weights_at(0.375), vec![0.0, 1.0, 0.0, 0.0]);
    assert_eq!(animated.weights_at(0.0625), vec![0.5, 0.0, 0.0, 0.0]);
    assert_eq!(animated.weights_at(1.0), vec![0.0; 4]);
    // At 3 s the animation shows exactly the second target's V(1).
    assert!(close(&animated.positions_at(0.375), &old.v1(), 1e-6));
}

/// What the GPU draws for a weight animation, computed on the CPU: `V(0)` plus the
/// blend's targets weighted by the track's offsets.
fn gpu_pose(v0: &[[f32; 3]], blend: &TargetBlend, t: f32) -> Vec<[f32; 3]> {
    let mut offsets = Vec::new();
    blend.track.offsets_at(t, &mut offsets);
    let mut out = v0.to_vec();
    for (deltas, &c) in blend.deltas.iter().zip(&offsets) {
        for (p, d) in out.iter_mut().zip(deltas) {
            for axis in 0..3 {
                p[axis] += c * d[axis];
            }
        }
    }
    out
}

#[test]
fn target_blend_reproduces_the_animation_from_v0() {
    for (file, driven) in [
        ("makehuman_body.glb", 4),
        ("makehuman_head.glb", 8),
        ("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf", 2),
    ] {
        let animated = load_morph(
            &asset(file),
            &LoadOptions::default(),
            &MorphSource::Animation("0".to_string()),
        )
        .unwrap();
        let blend = animated.target_blend().expect("an animation needs targets");
        assert_eq!(blend.deltas.len(), driven, "{file}");
        assert_eq!(blend.track.targets(), driven, "{file}");
        let v0 = animated.v0();
        let mut moved = false;
        for t in [0.0, 0.0625, 0.2, 0.375, 0.5, 0.61, 0.9, 1.0] {
            let expected = animated.positions_at(t);
            assert!(
                close(&gpu_pose(&v0, &blend, t), &expected, 1e-5),
                "{file} t={t}"
            );
            moved |= expected != v0;
        }
        assert!(
            moved,
            "{file}: the animation never leaves V(0); the test shows nothing"
        );
    }
    let two_pose = target(&asset("makehuman_head.glb"), "jawOpen");
    assert_eq!(two_pose.target_blend(), None);
}

#[test]
fn target_blend_keeps_only_driven_targets() {
    let tris = vec![[0, 1, 2]];
    let base = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let deltas = |z: f32| vec![[0.0, 0.0, z]; 3];
    let targets = vec![
        MorphTarget {
            name: "idle".into(),
            deltas: deltas(5.0),
            normal_deltas: None,
        },
        MorphTarget {
            name: "lift".into(),
            deltas: deltas(1.0),
            normal_deltas: None,
        },
    ];
    let track = WeightTrack::new(
        Interpolation::Linear,
        vec![0.0, 2.0],
        vec![0.0, 0.0, 0.0, 1.0],
        2,
    )
    .unwrap();
    let morph = Morph::from_parts(tris, base.clone(), targets, Weights::Animated(track)).unwrap();
    let blend = morph.target_blend().unwrap();
    assert_eq!(blend.deltas, vec![deltas(1.0)]);
    assert!(close(
        &gpu_pose(&base, &blend, 0.5),
        &morph.positions_at(0.5),
        0.0
    ));
}

#[test]
fn head_has_eight_targets() {
    let path = asset("makehuman_head.glb");
    let jaw = target(&path, "jawOpen");
    assert_eq!((jaw.vertex_count(), jaw.triangle_count()), (4_437, 8_818));
    let by_index = target(&path, "0");
    assert_eq!(by_index.v1(), jaw.v1());
    let animated = load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("0".to_string()),
    )
    .unwrap();
    assert_eq!(animated.targets().len(), 8);
    let err = load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Target("smile".to_string()),
    )
    .unwrap_err();
    let message = err.to_string();
    assert!(matches!(err, LoadError::NoSuchTarget { .. }));
    assert!(
        message.contains("no morph target 'smile'; the file has: 0 'jawOpen', 1 'mouthSmileLeft'")
            && message.contains("7 'mouthPucker'"),
        "{message}"
    );
}

#[test]
fn cube_animation_matches_its_targets() {
    let path = asset("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf");
    let options = LoadOptions::default();
    let animated = load_morph(
        &path,
        &options,
        &MorphSource::Animation("Square".to_string()),
    )
    .unwrap();
    assert_eq!(
        (animated.vertex_count(), animated.triangle_count()),
        (24, 12)
    );
    let Weights::Animated(track) = animated.weights() else {
        panic!("expected an animated morph");
    };
    assert_eq!((track.keyframes(), track.targets()), (127, 2));
    assert!((track.duration() - 4.2).abs() < 1e-4);
    // Keyframe 1 at 1/30 s holds weights (0.001284, 0) in the file.
    let w = animated.weights_at((1.0 / 30.0) / track.duration());
    assert!(
        (w[0] - 0.001_284).abs() < 1e-5 && w[1].abs() < 1e-7,
        "{w:?}"
    );
    // V(t) = base + Σ w_i(t) D_i where D_i = V_i(1) − base from the target morphs.
    let targets = [target(&path, "0"), target(&path, "1")];
    let t = 0.37;
    let w = animated.weights_at(t);
    let ends: Vec<Vec<[f32; 3]>> = targets.iter().map(|m| m.v1()).collect();
    let expected: Vec<[f32; 3]> = (0..animated.vertex_count())
        .map(|v| {
            let base = animated.base()[v];
            let moved = |c: usize| {
                base[c] + w[0] * (ends[0][v][c] - base[c]) + w[1] * (ends[1][v][c] - base[c])
            };
            [moved(0), moved(1), moved(2)]
        })
        .collect();
    assert!(close(&animated.positions_at(t), &expected, 1e-6));
    let missing =
        load_morph(&path, &options, &MorphSource::Animation("Walk".to_string())).unwrap_err();
    assert!(
        missing
            .to_string()
            .contains("no animation 'Walk'; the file has: 0 'Square'"),
        "{missing}"
    );
}

#[test]
fn default_weights_morph_ends_at_the_default_pose() {
    let path = asset("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf");
    let morph = load_morph(&path, &LoadOptions::default(), &MorphSource::DefaultWeights).unwrap();
    // The cube's default weights are (0, 0): both poses are the base.
    assert_eq!(morph.v0(), morph.v1());
    assert_eq!(morph.v0(), morph.base());
}

#[test]
fn select_applies_a_cleaning_result_to_every_target() {
    use crate::mesh::clean::{clean, CleanOptions};
    let morph = target(&asset("makehuman_body.glb"), "caucasian-male-baby");
    let base = IndexedMesh::new(morph.v0(), morph.triangles().to_vec());
    let cleaned = clean(
        &base,
        &CleanOptions {
            weld: true,
            ..CleanOptions::default()
        },
    )
    .unwrap();
    let kept = morph
        .select(&cleaned.vertex_map, cleaned.mesh.triangles.clone())
        .unwrap();
    assert_eq!(kept.v0(), cleaned.mesh.positions);
    let v1 = morph.v1();
    let expected: Vec<[f32; 3]> = cleaned.vertex_map.iter().map(|&v| v1[v as usize]).collect();
    assert_eq!(kept.v1(), expected);
}

#[test]
fn transformed_morph_moves_deltas_with_the_node() {
    // The cube's node scales by 100 and rotates: target offsets scale too.
    let path = asset("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf");
    let source = MorphSource::Target("1".to_string());
    let plain = load_morph(&path, &LoadOptions::default(), &source).unwrap();
    let placed = LoadOptions {
        apply_transforms: true,
        ..LoadOptions::default()
    };
    let moved = load_morph(&path, &placed, &source).unwrap();
    let length = |m: &Morph, v: usize| {
        let (a, b) = (m.v0()[v], m.v1()[v]);
        ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
    };
    let v = (0..plain.vertex_count())
        .max_by(|&a, &b| length(&plain, a).total_cmp(&length(&plain, b)))
        .unwrap();
    assert!(length(&plain, v) > 0.01);
    assert!((length(&moved, v) / length(&plain, v) - 100.0).abs() < 1e-2);
}

/// The MakeHuman face (assets/README.md), the asset `morphlod info` used to refuse: its last
/// target (`tongueOut`) has POSITION and NORMAL accessors with neither `bufferView` nor
/// `sparse`, which glTF defines as zeros. Values are checked against the file's bytes as
/// decoded independently (Python `struct` over the GLB's BIN chunk).
#[test]
fn face_loads_with_its_attributes() {
    let path = asset("makehuman_face.glb");
    let morph = load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("expressions".to_string()),
    )
    .unwrap();
    assert_eq!(
        (morph.vertex_count(), morph.triangle_count()),
        (4_632, 8_818)
    );
    let targets = morph.targets();
    assert_eq!(targets.len(), 52);
    assert_eq!(
        (targets[0].name.as_str(), targets[51].name.as_str()),
        ("browDownLeft", "tongueOut")
    );
    assert!(targets.iter().all(|t| t.normal_deltas.is_some()));
    // Target 0's NORMAL is sparse (661 entries): entry 0 replaces vertex 118.
    let first = targets[0].normal_deltas.as_ref().unwrap();
    assert_eq!(
        first[118],
        [-0.003_942_847_3, 0.004_565_629, -0.001_068_156_3]
    );
    assert_eq!(first.iter().filter(|d| **d != [0.0; 3]).count(), 661);
    // The zero-initialised target reads as zeros.
    let last = &targets[51];
    assert!(last.deltas.iter().all(|d| *d == [0.0; 3]));
    assert!(last
        .normal_deltas
        .as_ref()
        .unwrap()
        .iter()
        .all(|d| *d == [0.0; 3]));

    let a = morph.attributes();
    let normals = a.normals.as_ref().unwrap();
    assert_eq!(normals.len(), 4_632);
    assert_eq!(normals[0], [-0.163_085_4, 0.036_696_64, 0.985_929_25]);
    let uvs = a.uvs.as_ref().unwrap();
    assert_eq!(uvs[0], [0.833_218, 0.551_853]);
    assert!(a.colors.is_none());
    assert_eq!(a.material.name.as_deref(), Some("skin"));
    assert_eq!(a.material.base_color, [1.0; 4]);
    let texture = a.material.texture.as_ref().unwrap();
    assert_eq!(texture.format, ImageFormat::Jpeg);
    assert_eq!(texture.bytes.len(), 31_373);
    assert_eq!(
        texture.sampler,
        Sampler {
            mag_filter: Some(9729),
            min_filter: Some(9987),
            wrap_s: 33071,
            wrap_t: 33071
        }
    );
    // `file(1)` says: baseline JPEG, 1024x1024, 3 components.
    assert_eq!(
        crate::io::image_size(&texture.bytes).unwrap(),
        (ImageFormat::Jpeg, 1024, 1024)
    );

    // 4,632 attribute vertices on 4,437 positions: 191 positions carry a seam.
    let topology = morph.topology();
    assert_eq!(topology.topology_count, 4_437);
    assert_eq!(topology.seam_vertices(), 191);
}
