//! Files `morphlod export` writes, loaded by a real client: three.js's GLTFLoader under node
//! (`.ci/gltf-loader/load.mjs`, `three` pinned in its package-lock.json). Every LOD node loads
//! as a mesh with the vertex and index counts written and one POSITION (and NORMAL) morph
//! attribute per target, and the animation clip moves every LOD's morphTargetInfluences in step.
//! `.ci/run` installs node and the package (`npm ci`); where they are missing the tests say so
//! and pass, except under CI (`CI` set to anything but empty, `0` or `false`), where a missing
//! harness fails.

use crate::common;

use common::validator::run_node;
use gltf::json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name)
}

fn temp_dir(name: &str) -> PathBuf {
    common::scratch_dir("gltf_loader", name)
}

fn export(inputs: &[PathBuf], lods: &str, out: &Path) {
    let output = Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .arg("export")
        .args(inputs)
        // What three.js loads does not depend on the distance term, which would make each
        // export ~100 times longer (see `export_lods` in tests/suite/export.rs).
        .args(["--lods", lods, "--distance-weight", "0", "-o"])
        .arg(out)
        .output()
        .expect("the morphlod binary runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// What the file holds, read back with the `gltf` crate (which tests/suite/export.rs checks against
/// the source bit for bit): the loader's expectations as JSON.
fn expected(glb: &[u8], name: &str) -> String {
    let gltf = gltf::Gltf::from_slice(glb).expect("the GLB parses");
    let mut targets = 0;
    let mut normal_targets = true;
    let lods: Vec<String> = gltf
        .meshes()
        .map(|mesh| {
            let p = mesh.primitives().next().expect("one primitive");
            targets = p.morph_targets().count();
            normal_targets &= p.morph_targets().all(|t| t.normals().is_some());
            let vertices = p.get(&gltf::Semantic::Positions).unwrap().count();
            let indices = p.indices().unwrap().count();
            format!(r#"{{"vertices":{vertices},"indices":{indices}}}"#)
        })
        .collect();
    format!(
        r#"{{"name":"{name}","targets":{targets},"normalTargets":{},"lods":[{}]}}"#,
        normal_targets && targets > 0,
        lods.join(",")
    )
}

/// three.js loads `file`: (the harness passed, its report).
fn load(file: &Path, expected: &str) -> Option<(bool, String)> {
    run_node(
        "gltf-loader",
        "three",
        "load.mjs",
        &[file.as_os_str(), expected.as_ref()],
    )
}

/// The face (52 targets with NORMAL deltas, a texture, seams), the AnimatedMorphCube sample
/// (.gltf with an external buffer; also under a TRS and a matrix ancestor), the face as a
/// skinned character and a supermesh pair (bunny.obj → cow.off, one target): every LOD loads
/// in three.js with all its targets, driven by the animation; the skinned one's LODs are
/// SkinnedMeshes over the skin's two joints.
#[test]
fn exported_files_load_in_three_js() {
    let dir = temp_dir("exported");
    let cube = asset("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf");
    let mut cases = vec![
        (
            vec![asset("makehuman_face.glb")],
            "makehuman_face",
            "0.5,0.25,0.1",
        ),
        (
            vec![asset("bunny.obj"), asset("cow.off")],
            "bunny",
            "0.5,0.1",
        ),
    ];
    if cube.exists() {
        cases.push((vec![cube], "AnimatedMorphCube", "0.6,0.3"));
        // The cube under two named ancestors: LOD0 is found in the scene below them.
        cases.push((vec![common::rigged_cube(&dir)], "rigged", "0.6,0.3"));
    }
    // A skinned character: every LOD a SkinnedMesh over the skin's two joints.
    cases.push((vec![common::skinned_face(&dir).0], "skinned", "0.5,0.1"));
    for (inputs, name, lods) in cases {
        let out = dir.join(format!("{name}.glb"));
        export(&inputs, lods, &out);
        let expected = expected(&std::fs::read(&out).unwrap(), name);
        let Some((ok, report)) = load(&out, &expected) else {
            return;
        };
        assert!(ok, "{name}: {report}");
        assert!(report.contains(r#""ok":true"#), "{report}");
        let lods = lods.split(',').count() + 1;
        assert!(report.contains(&format!(r#""driven":{lods}"#)), "{report}");
        if name == "skinned" {
            for i in 0..lods {
                let skinned = format!(r#""name":"skinned_LOD{i}""#);
                assert!(report.contains(&skinned), "{skinned}: {report}");
            }
            assert_eq!(report.matches(r#""bones":2,"#).count(), lods, "{report}");
            assert!(!report.contains(r#""skinned":0"#), "{report}");
            assert!(report.contains(r#""spine.quaternion""#), "{report}");
        }
        if name == "rigged" {
            // The source moves "rig" and turns the cube node: the rig's track, and one
            // rotation track per LOD node.
            assert!(report.contains(r#""rig.position""#), "{report}");
            for i in 0..lods {
                let track = format!(r#""rigged_LOD{i}.quaternion""#);
                assert!(report.contains(&track), "{track}: {report}");
            }
        }
    }
}

/// The harness can fail: the face exported, then its last LOD's animation channel removed (a
/// file the Khronos validator still passes, but whose last LOD would freeze in a viewer).
#[test]
fn a_lod_the_animation_does_not_drive_is_reported() {
    let dir = temp_dir("undriven");
    let out = dir.join("face.glb");
    export(&[asset("makehuman_face.glb")], "0.5,0.1", &out);
    let bytes = std::fs::read(&out).unwrap();
    let expected = expected(&bytes, "makehuman_face");
    let glb = gltf::Glb::from_slice(&bytes).unwrap();
    let mut json: Value = gltf::json::deserialize::from_slice(&glb.json).unwrap();
    let channels = json["animations"][0]["channels"].as_array_mut().unwrap();
    assert_eq!(channels.len(), 3);
    channels.pop();
    let json = gltf::json::serialize::to_vec(&json).unwrap();
    let broken = gltf::Glb {
        header: glb.header,
        json: json.into(),
        bin: glb.bin.clone(),
    };
    let file = dir.join("undriven.glb");
    std::fs::write(&file, broken.to_vec().unwrap()).unwrap();
    let Some((ok, report)) = load(&file, &expected) else {
        return;
    };
    assert!(!ok, "{report}");
    assert!(
        report.contains("makehuman_face_LOD2: 0 morphTargetInfluences tracks"),
        "{report}"
    );
}
