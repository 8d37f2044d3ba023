//! `morphlod export` of skinned characters (issue 51, item 7): the walker's LODs keep the skin,
//! every joint animation and the weight animation, each channel bit for bit; the LODs are
//! chosen over the skinned poses (the shared sequence of the skinned morph, not of the bind
//! pose); the Khronos validator reports no error and no warning and three.js loads every LOD as
//! a SkinnedMesh that both animations move. A file with two JOINTS/WEIGHTS sets keeps both,
//! and what an output cannot keep (an animation of an unrelated node) is named in a warning.

use crate::common;

use common::skinned::{Layout, SkinnedBar};
use common::validator::{run_node, validate};
use gltf::animation::util::ReadOutputs;
use morphlod::build::{Builder, Sequences};
use morphlod::io::{load_morph, LoadOptions, MorphSource};
use morphlod::simplify::{PoseError, SimplifyOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

fn walker() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_walker.glb")
}

/// `morphlod export INPUT --lods LODS --distance-weight 0 -o OUT` (the distance term does not
/// change what is kept, and would make the export ~100 times longer): its stderr.
fn export(input: &Path, lods: &str, out: &Path) -> String {
    let output = Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .arg("export")
        .arg(input)
        .args(["--lods", lods, "--distance-weight", "0", "-o"])
        .arg(out)
        .output()
        .expect("the morphlod binary runs");
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{stderr}");
    stderr
}

/// Every channel of `doc`'s animations: (animation name, target node name, path, interpolation,
/// key time bits, value bits).
type Channel = (String, String, String, String, Vec<u32>, Vec<u32>);

fn channels(doc: &gltf::Gltf, blob: &[u8]) -> Vec<Channel> {
    let mut out = Vec::new();
    for animation in doc.animations() {
        for channel in animation.channels() {
            let reader = channel.reader(|_| Some(blob));
            let times = reader.read_inputs().unwrap().map(f32::to_bits).collect();
            let values: Vec<u32> = match reader.read_outputs().unwrap() {
                ReadOutputs::Translations(v) | ReadOutputs::Scales(v) => {
                    v.flatten().map(f32::to_bits).collect()
                }
                ReadOutputs::Rotations(r) => r.into_f32().flatten().map(f32::to_bits).collect(),
                ReadOutputs::MorphTargetWeights(w) => w.into_f32().map(f32::to_bits).collect(),
            };
            out.push((
                animation.name().unwrap_or("").to_string(),
                channel.target().node().name().unwrap_or("").to_string(),
                format!("{:?}", channel.target().property()),
                format!("{:?}", channel.sampler().interpolation()),
                times,
                values,
            ));
        }
    }
    out
}

#[test]
fn the_walker_keeps_its_skin_and_animations_on_every_lod() {
    let dir = common::scratch_dir("export_skinned", "walker");
    let out = dir.join("walker.glb");
    let stderr = export(&walker(), "0.1", &out);
    assert!(
        !stderr.contains("not exported"),
        "nothing is left out: {stderr}"
    );
    let bytes = std::fs::read(&out).unwrap();
    let exported = gltf::Gltf::from_slice(&bytes).unwrap();
    let source = gltf::Gltf::from_slice(&std::fs::read(walker()).unwrap()).unwrap();
    let (ours, theirs) = (
        channels(&exported, exported.blob.as_deref().unwrap()),
        channels(&source, source.blob.as_deref().unwrap()),
    );
    // Every joint channel of `walk`, bit for bit, on the node of the same name; `morph`'s
    // weight channel on both LOD nodes.
    let joint_channels: Vec<&Channel> = theirs
        .iter()
        .filter(|c| c.2 != "MorphTargetWeights")
        .collect();
    assert_eq!(joint_channels.len(), 14);
    for c in &joint_channels {
        assert!(
            ours.contains(c),
            "walk's channel on {} {} is kept",
            c.1,
            c.2
        );
    }
    let weights = theirs.iter().find(|c| c.2 == "MorphTargetWeights").unwrap();
    for lod in ["makehuman_walker_LOD0", "makehuman_walker_LOD1"] {
        let on_lod = (
            weights.0.clone(),
            lod.to_string(),
            weights.2.clone(),
            weights.3.clone(),
            weights.4.clone(),
            weights.5.clone(),
        );
        assert!(ours.contains(&on_lod), "morph's weights drive {lod}");
    }
    let names: Vec<&str> = exported.animations().filter_map(|a| a.name()).collect();
    assert_eq!(names, ["walk", "morph"]);
    let skin = exported.skins().next().expect("the skin");
    assert_eq!(skin.joints().count(), 53);
    let skinned = exported.nodes().filter(|n| n.skin().is_some()).count();
    assert_eq!(skinned, 2, "both LOD nodes are bound to the skin");

    // The LOD is the shared sequence's over the skinned poses (walk, morph's weights beside
    // it), as the export simplifies them, and not the bind pose's.
    let source = MorphSource::AnimationWithWeights {
        animation: "walk".into(),
        weights: "morph".into(),
    };
    let morph = load_morph(&walker(), &LoadOptions::default(), &source).unwrap();
    let simplify = SimplifyOptions::default();
    let shared = |morph: &morphlod::Morph| {
        Builder::new(morph)
            .frames(morphlod::export::DEFAULT_POSES)
            .sequences(Sequences::Shared(PoseError::Max))
            .simplify_options(simplify.clone())
            .build()
            .unwrap()
            .0
            .frames[0]
            .clone()
    };
    let skinned_sequence = shared(&morph);
    let lod1 = exported.meshes().nth(1).unwrap();
    let triangles = lod1.primitives().next().unwrap().indices().unwrap().count() / 3;
    let at = |sequence: &morphlod::CollapseSequence| {
        common::lod_for(sequence, morph.triangles(), morph.triangles().len() / 10)
    };
    let step = at(&skinned_sequence);
    assert_eq!(
        skinned_sequence
            .reference_mesh(morph.triangles(), step)
            .len(),
        triangles
    );
    let bind = load_morph(
        &walker(),
        &LoadOptions::default(),
        &MorphSource::Animation("morph".into()),
    )
    .unwrap();
    let rest_sequence = shared(&bind);
    let kept = |sequence: &morphlod::CollapseSequence, step: usize| -> Vec<u32> {
        let mut alive: Vec<u32> = (0..morph.vertex_count() as u32).collect();
        for c in &sequence.collapses[..step] {
            alive[c.u as usize] = u32::MAX;
        }
        alive.retain(|&v| v != u32::MAX);
        alive
    };
    let ours_kept = kept(&skinned_sequence, step);
    assert_ne!(
        ours_kept,
        kept(&rest_sequence, at(&rest_sequence)),
        "not the bind pose's LOD"
    );
    let positions = lod1
        .primitives()
        .next()
        .unwrap()
        .get(&gltf::Semantic::Positions)
        .unwrap();
    assert_eq!(
        positions.count(),
        ours_kept.len(),
        "the skinned sequence's vertices are kept"
    );

    if let Some((ok, report)) = validate(&[&out]) {
        assert!(
            ok && report.contains("\"errors\":0,\"warnings\":0"),
            "{report}"
        );
    }
    let expected = format!(
        r#"{{"name":"makehuman_walker","targets":4,"normalTargets":false,"lods":[{{"vertices":13380,"indices":80268}},{{"vertices":{},"indices":{}}}]}}"#,
        ours_kept.len(),
        3 * triangles
    );
    let Some((ok, report)) = run_node(
        "gltf-loader",
        "three",
        "load.mjs",
        &[out.as_os_str(), expected.as_ref()],
    ) else {
        return;
    };
    assert!(ok, "{report}");
    assert_eq!(report.matches(r#""bones":53,"#).count(), 2, "{report}");
    assert!(report.contains(r#""driven":2,"skinMoved":2"#), "{report}");
    assert!(
        report.contains(r#""animations":["walk","morph"]"#),
        "{report}"
    );
}

/// The bar with two JOINTS/WEIGHTS sets keeps both on every LOD, and an animation of a node
/// outside the mesh, its skeleton and their ancestors is named in a warning, not dropped
/// silently; the file still validates.
#[test]
fn a_second_influence_set_is_kept_and_what_is_not_is_named() {
    let dir = common::scratch_dir("export_skinned", "bar");
    let mut bar = SkinnedBar::new(Layout::TwoSets);
    bar.json["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"name": "lamp"}));
    bar.json["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(5.into());
    let spin = bar.json["animations"][0]["samplers"][0].clone();
    bar.json["animations"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"name": "lamp", "samplers": [spin],
            "channels": [{"sampler": 0, "target": {"node": 5, "path": "rotation"}}]}));
    let input = bar.write(&dir, "bar.glb");
    let out = dir.join("bar_lods.glb");
    let stderr = export(&input, "0.5", &out);
    assert!(
        stderr.contains("warning: not exported: animation 'lamp'"),
        "{stderr}"
    );
    let exported = gltf::Gltf::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    for mesh in exported.meshes() {
        let primitive = mesh.primitives().next().unwrap();
        for semantic in [gltf::Semantic::Joints(1), gltf::Semantic::Weights(1)] {
            assert!(primitive.get(&semantic).is_some(), "{semantic:?} is kept");
        }
    }
    let names: Vec<&str> = exported.animations().filter_map(|a| a.name()).collect();
    assert_eq!(names, ["bend"]);
    if let Some((ok, report)) = validate(&[&out]) {
        assert!(ok && report.contains("\"errors\":0"), "{report}");
    }
}

/// A broken skin stops `build` and `export` with exit code 1, the file and the fault named,
/// and nothing written.
#[test]
fn a_broken_skin_writes_nothing() {
    let dir = common::scratch_dir("export_skinned", "broken");
    let mut bar = SkinnedBar::new(Layout::Float);
    bar.set_u16(common::skinned::accessor::JOINTS, 5, 1, 7);
    let input = bar.write(&dir, "broken.glb");
    for (command, out) in [("build", "broken.mlod"), ("export", "broken_lods.glb")] {
        let out = dir.join(out);
        let output = Command::new(env!("CARGO_BIN_EXE_morphlod"))
            .arg(command)
            .arg(&input)
            .args(["--animation", "bend", "-o"])
            .arg(&out)
            .output()
            .expect("the morphlod binary runs");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{command}: {stderr}");
        assert!(
            stderr.contains("broken.glb") && stderr.contains("vertex 5 names joint 7"),
            "{command}: {stderr}"
        );
        assert!(!out.exists(), "{command} wrote {out:?}");
    }
}
