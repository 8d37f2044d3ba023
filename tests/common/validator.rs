//! The Khronos glTF validator (the `gltf-validator` npm package, pinned in
//! `.ci/gltf-validator`, run under node), for every test that writes glTF
//! (tests/suite/gltf_validator.rs, tests/suite/export.rs); and [`run_node`], which runs any of the
//! node harnesses in `.ci/` (tests/suite/gltf_loader.rs). Where node or the package is missing the
//! helpers say so and return `None`, except under CI (`morphlod::ci::is_ci`), where a missing
//! harness fails.

use std::ffi::OsStr;
use std::path::Path;
use std::process::Command;

/// Runs `node .ci/<dir>/<script> args...` when node and `.ci/<dir>/node_modules/<package>` are
/// there: (exit code 0, stdout and stderr). `None` when they are not, outside CI; under CI a
/// missing harness panics ([`super::skip_outside_ci`]).
pub fn run_node(dir: &str, package: &str, script: &str, args: &[&OsStr]) -> Option<(bool, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(".ci").join(dir);
    let installed = dir.join("node_modules").join(package).is_dir();
    let node = Command::new("node").arg("--version").output().is_ok();
    if !(installed && node) {
        let why = format!(
            "{package} is not installed (node found: {node}; package installed: {installed}); \
             run `npm ci` in {}",
            dir.display()
        );
        super::skip_outside_ci(&why);
        return None;
    }
    let out = Command::new("node")
        .arg(dir.join(script))
        .args(args)
        .output()
        .expect("node runs");
    let report = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    Some((out.status.success(), report))
}

/// Runs the validator on `files`: (exit code 0, the JSON lines it printed).
pub fn validate(files: &[&Path]) -> Option<(bool, String)> {
    let args: Vec<&OsStr> = files.iter().map(|f| f.as_os_str()).collect();
    run_node("gltf-validator", "gltf-validator", "validate.mjs", &args)
}
