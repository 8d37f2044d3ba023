//! The Khronos glTF validator (the `gltf-validator` npm package, pinned in
//! `.ci/gltf-validator`, run under node), for every test that writes glTF
//! (tests/gltf_validator.rs, tests/export.rs). Where node or the package is missing the
//! helpers say so and return `None`, except under `CI=true`, where a missing validator fails.

use std::path::{Path, PathBuf};
use std::process::Command;

/// `node` and the validator script with its package installed, or `None` (outside CI).
fn validator() -> Option<(PathBuf, PathBuf)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(".ci/gltf-validator");
    let script = dir.join("validate.mjs");
    let installed = dir.join("node_modules/gltf-validator").is_dir();
    let node = Command::new("node").arg("--version").output().is_ok();
    if installed && node {
        return Some((PathBuf::from("node"), script));
    }
    let why = format!(
        "the glTF validator is not installed (node found: {node}; package installed: {installed}); \
         run `npm ci` in {}",
        dir.display()
    );
    assert!(std::env::var("CI").as_deref() != Ok("true"), "{why}");
    eprintln!("skipped: {why}");
    None
}

/// Runs the validator on `files`: (exit code 0, the JSON lines it printed).
pub fn validate(files: &[&Path]) -> Option<(bool, String)> {
    let (node, script) = validator()?;
    let out = Command::new(node)
        .arg(script)
        .args(files)
        .output()
        .expect("node runs");
    let report = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    Some((out.status.success(), report))
}
