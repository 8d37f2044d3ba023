//! glTF that morphlod writes, checked by the Khronos glTF validator (the `gltf-validator` npm
//! package, pinned in `.ci/gltf-validator`, run under node): 0 errors. `.ci/run` installs node
//! and the package (`npm ci`); where they are missing the tests say so and pass, except under
//! CI (`CI` set to anything but empty, `0` or `false`), where a missing validator fails.

use crate::common;

use common::validator::validate;
use std::path::{Path, PathBuf};
use std::process::Command;

fn temp_dir(name: &str) -> PathBuf {
    common::scratch_dir("gltf_validator", name)
}

/// `morphlod supermesh bunny.obj cow.off -o S.glb` (a supermesh of two real meshes of
/// different connectivity, one morph target and an animation) passes with 0 errors and 0
/// warnings.
#[test]
fn supermesh_glb_passes_the_khronos_validator() {
    let dir = temp_dir("supermesh");
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let glb = dir.join("bunny_cow.glb");
    let out = Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .arg("supermesh")
        .arg(assets.join("bunny.obj"))
        .arg(assets.join("cow.off"))
        .arg("-o")
        .arg(&glb)
        .output()
        .expect("the morphlod binary runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let Some((ok, report)) = validate(&[&glb]) else {
        return;
    };
    assert!(ok, "{report}");
    assert!(report.contains("\"errors\":0,\"warnings\":0"), "{report}");
}

/// The harness can fail: a GLB whose JSON chunk names a buffer view past the end of its
/// binary chunk is reported with an error and a nonzero exit.
#[test]
fn the_validator_reports_a_broken_file() {
    let json = br#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4}],"bufferViews":[{"buffer":0,"byteLength":400}]}  "#;
    let bin = [0u8; 4];
    let mut glb = Vec::new();
    let total = 12 + 8 + json.len() + 8 + bin.len();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(json);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    assert_eq!(json.len() % 4, 0, "chunks are 4-byte aligned");
    let dir = temp_dir("broken");
    let file = dir.join("broken.glb");
    std::fs::write(&file, glb).unwrap();
    let Some((ok, report)) = validate(&[&file]) else {
        return;
    };
    assert!(!ok, "{report}");
    assert!(!report.contains("\"errors\":0"), "{report}");
}

/// One CI rule for every harness (`morphlod::ci::is_ci`, applied by
/// `common::skip_outside_ci`): a missing node harness is a failure under `CI=1`, `CI=true` or
/// `CI=yes` (CI services spell it differently), and a printed skip with `CI` empty, `0` or
/// `false`. The probe below runs in a child process of this test binary with `CI` set.
#[test]
fn a_missing_harness_fails_under_any_ci_value() {
    for (ci, fails) in [
        ("1", true),
        ("true", true),
        ("yes", true),
        ("", false),
        ("0", false),
        ("false", false),
    ] {
        let out = Command::new(std::env::current_exe().unwrap())
            .args([
                "gltf_validator::missing_harness_probe",
                "--exact",
                "--ignored",
            ])
            .env("CI", ci)
            .output()
            .expect("the test binary runs");
        let report = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            report.contains("running 1 test"),
            "the probe did not run: {report}"
        );
        assert_eq!(!out.status.success(), fails, "CI={ci:?}: {report}");
        let said = if fails {
            "a CI run must not skip"
        } else {
            "skipping"
        };
        assert!(report.contains(said), "CI={ci:?}: {report}");
    }
}

/// Asks for a harness that is never installed; run by
/// `a_missing_harness_fails_under_any_ci_value` with `CI` set.
#[test]
#[ignore = "a probe: run by a_missing_harness_fails_under_any_ci_value"]
fn missing_harness_probe() {
    assert!(
        common::validator::run_node("no-such-harness", "no-such-package", "x.mjs", &[]).is_none()
    );
}
