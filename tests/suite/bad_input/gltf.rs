//! Malformed glTF / GLB inputs: each must give a typed error naming the element
//! at fault, never a panic. The files are built here from one small valid
//! document (a triangle with one morph target and a weight animation) by
//! changing one thing at a time.

use morphlod::io::gltf::{inspect, load_mesh};
use morphlod::io::MorphSource;
use morphlod::io::{LoadError, LoadOptions};
use morphlod::morph::Morph;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

/// Binary layout of the valid document (96 bytes):
/// 0..36 positions, 36..42 u16 indices (+2 padding), 44..80 target deltas,
/// 80..88 animation times (0 s, 1 s), 88..96 weights (0, 1).
fn valid_bin() -> Vec<u8> {
    let mut bin = Vec::new();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        v.iter().for_each(|c| bin.extend(c.to_le_bytes()));
    }
    [0u16, 1, 2, 0]
        .iter()
        .for_each(|i| bin.extend(i.to_le_bytes()));
    for v in [[0.0f32, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]] {
        v.iter().for_each(|c| bin.extend(c.to_le_bytes()));
    }
    [0.0f32, 1.0, 0.0, 1.0]
        .iter()
        .for_each(|f| bin.extend(f.to_le_bytes()));
    bin
}

/// The valid document; `BUFFER` is replaced by the buffer object.
const VALID_JSON: &str = r#"{
  "asset": {"version": "2.0"},
  "buffers": [BUFFER],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 36},
    {"buffer": 0, "byteOffset": 36, "byteLength": 6},
    {"buffer": 0, "byteOffset": 44, "byteLength": 36},
    {"buffer": 0, "byteOffset": 80, "byteLength": 8},
    {"buffer": 0, "byteOffset": 88, "byteLength": 8}
  ],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
    {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 1], "max": [0, 0, 1]},
    {"bufferView": 3, "componentType": 5126, "count": 2, "type": "SCALAR"},
    {"bufferView": 4, "componentType": 5126, "count": 2, "type": "SCALAR"}
  ],
  "meshes": [{"name": "tri", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4, "targets": [{"POSITION": 2}]}],
              "weights": [0], "extras": {"targetNames": ["lift"]}}],
  "nodes": [{"mesh": 0}],
  "animations": [{"name": "lift", "samplers": [{"input": 3, "output": 4, "interpolation": "LINEAR"}],
                  "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}]}]
}"#;

fn json_with_buffer(buffer: &str) -> String {
    VALID_JSON.replace("BUFFER", buffer)
}

/// A GLB container (header, padded JSON chunk, BIN chunk).
pub(crate) fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

fn valid_glb() -> Vec<u8> {
    glb(&json_with_buffer(r#"{"byteLength": 96}"#), &valid_bin())
}

/// A directory per case (tests run in parallel) under cargo's scratch directory for
/// integration tests: the same path on every run, so runs overwrite their files instead of
/// leaving a directory per process in the system's temporary directory. Not emptied here:
/// a case may write several files (a `.gltf` and its `.bin`).
fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bad_gltf_{test}"));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub(crate) fn write(test: &str, name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch(test).join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn load(path: &Path) -> Result<morphlod::IndexedMesh, LoadError> {
    load_mesh(path, &LoadOptions::default())
}

fn animated(path: &Path) -> Result<Morph, LoadError> {
    morphlod::io::load_morph(
        path,
        &LoadOptions::default(),
        &MorphSource::Animation("lift".to_string()),
    )
}

/// The GLB form of a variation of the valid JSON (same binary data).
fn glb_variant(test: &str, from: &str, to: &str) -> PathBuf {
    let json = json_with_buffer(r#"{"byteLength": 96}"#);
    assert!(
        json.contains(from),
        "test setup: '{from}' not in the document"
    );
    write(
        test,
        "file.glb",
        &glb(&json.replacen(from, to, 1), &valid_bin()),
    )
}

#[test]
fn valid_document_loads() {
    // The baseline every other case breaks: it must load, or the cases prove nothing.
    let path = write("valid", "file.glb", &valid_glb());
    let mesh = load(&path).unwrap();
    assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    let morph = animated(&path).unwrap();
    assert_eq!(morph.positions_at(0.5)[1], [1.0, 0.0, 0.5]);
    assert_eq!(inspect(&path).unwrap().meshes[0].target_names, ["lift"]);
}

/// Which loader a case goes through.
#[derive(Clone, Copy, Debug)]
enum Via {
    /// `load_mesh`.
    Mesh,
    /// `load_mesh` and `inspect`, both with the same error.
    MeshAndInspect,
    /// `io::load_morph` of the animation 'lift': the error must be a file error, not
    /// `LoadError::Morph`.
    Animation,
}

/// One malformed document: its bytes (written to `file`), the typed error expected, the words
/// its message must all contain, and words of which it must contain at least one.
struct Case {
    name: String,
    file: &'static str,
    bytes: Vec<u8>,
    via: Via,
    expect: fn(&LoadError) -> bool,
    says: &'static [&'static str],
    says_one_of: &'static [&'static str],
}

fn case(
    name: &str,
    file: &'static str,
    bytes: impl Into<Vec<u8>>,
    via: Via,
    expect: fn(&LoadError) -> bool,
    says: &'static [&'static str],
) -> Case {
    Case {
        name: name.to_string(),
        file,
        bytes: bytes.into(),
        via,
        expect,
        says,
        says_one_of: &[],
    }
}

/// The GLB of the valid document with `from` replaced by `to` in its JSON (same binary data).
fn variant(from: &str, to: &str) -> Vec<u8> {
    let json = json_with_buffer(r#"{"byteLength": 96}"#);
    assert!(
        json.contains(from),
        "test setup: '{from}' not in the document"
    );
    glb(&json.replacen(from, to, 1), &valid_bin())
}

/// The GLB of the valid document with its binary data edited by `edit`.
fn with_bin(edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut bin = valid_bin();
    edit(&mut bin);
    glb(&json_with_buffer(r#"{"byteLength": 96}"#), &bin)
}

/// The errors a case's loaders return, or why the row fails.
fn errors(case: &Case, path: &Path) -> Result<Vec<LoadError>, String> {
    let mesh = |r: Result<morphlod::IndexedMesh, LoadError>| r.err().ok_or("load_mesh accepted it");
    Ok(match case.via {
        Via::Mesh => vec![mesh(load(path))?],
        Via::MeshAndInspect => vec![
            inspect(path).err().ok_or("inspect accepted it")?,
            mesh(load(path))?,
        ],
        Via::Animation => match animated(path) {
            Ok(_) => return Err("io::load_morph accepted it".into()),
            Err(LoadError::Morph(other)) => return Err(format!("not a load error: {other:?}")),
            Err(err) => vec![err],
        },
    })
}

fn check(case: &Case) -> Option<String> {
    let path = write(&case.name.replace(' ', "-"), case.file, &case.bytes);
    let errors = match errors(case, &path) {
        Ok(errors) => errors,
        Err(why) => return Some(why),
    };
    errors.iter().find_map(|err| {
        if !(case.expect)(err) {
            return Some(format!("unexpected error {err:?}"));
        }
        let message = err.to_string();
        if let Some(needle) = case.says.iter().find(|n| !message.contains(*n)) {
            return Some(format!("{message:?} should mention {needle:?}"));
        }
        let one_of = case.says_one_of;
        (!one_of.is_empty() && !one_of.iter().any(|n| message.contains(n)))
            .then(|| format!("{message:?} should mention one of {one_of:?}"))
    })
}

fn cases() -> Vec<Case> {
    use LoadError as E;
    use Via::{Animation, Mesh, MeshAndInspect};
    let valid = valid_glb();
    let mut bad_magic = valid.clone();
    bad_magic[3] = b'X';
    let mut long_chunk = valid.clone();
    long_chunk[12..16].copy_from_slice(&100_000u32.to_le_bytes());
    // The `gltf` crate's own GLB reader underflows on this; ours must not.
    let mut short_length = valid.clone();
    short_length[8..12].copy_from_slice(&4u32.to_le_bytes());
    let short_uri = {
        use base64::Engine;
        let data = base64::engine::general_purpose::STANDARD.encode(&valid_bin()[..40]);
        json_with_buffer(&format!(
            r#"{{"uri": "data:application/octet-stream;base64,{data}", "byteLength": 96}}"#
        ))
    };
    // Sparse index 2 (the third u16 of view 1, at byte 4) in a 2-element accessor.
    let sparse_out_of_range = SPARSE_TARGET
        .replace(r#""count": 3"#, r#""count": 2"#)
        .replace(
            r#""bufferView": 1, "componentType": 5123"#,
            r#""bufferView": 1, "byteOffset": 4, "componentType": 5123"#,
        );
    let mut cases = vec![
        case(
            "bad magic",
            "file.glb",
            bad_magic,
            Mesh,
            |e| matches!(e, E::GltfContainer { .. }),
            &["magic"],
        ),
        case(
            "chunk length past the end",
            "file.glb",
            long_chunk,
            Mesh,
            |e| matches!(e, E::GltfContainer { .. }),
            &["chunk 0"],
        ),
        case(
            "header length below the header size",
            "file.glb",
            short_length,
            Mesh,
            |e| matches!(e, E::GltfContainer { .. }),
            &[],
        ),
        case(
            "invalid JSON",
            "file.gltf",
            &b"{\"asset\": {\"version\": "[..],
            Mesh,
            |e| matches!(e, E::GltfJson { .. }),
            &["invalid glTF JSON"],
        ),
        // The `gltf` validator indexes accessors[POSITION] unchecked.
        case(
            "POSITION accessor out of range",
            "file.glb",
            variant(r#""POSITION": 0}"#, r#""POSITION": 42}"#),
            Mesh,
            |e| matches!(e, E::GltfJson { .. }),
            &["POSITION"],
        ),
        case(
            "accessor reads past its buffer view",
            "file.glb",
            variant(
                r#""componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0]"#,
                r#""componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0]"#,
            ),
            Mesh,
            |e| matches!(e, E::GltfData { .. }),
            &["accessor 0", "buffer view 0"],
        ),
        case(
            "buffer view past its buffer",
            "file.glb",
            variant(
                r#"{"buffer": 0, "byteOffset": 88, "byteLength": 8}"#,
                r#"{"buffer": 0, "byteOffset": 88, "byteLength": 80}"#,
            ),
            Animation,
            |e| matches!(e, E::GltfData { .. }),
            &["buffer view 4"],
        ),
        case(
            "index out of range",
            "file.glb",
            with_bin(|bin| bin[38..40].copy_from_slice(&7u16.to_le_bytes())),
            Mesh,
            |e| matches!(e, E::GltfData { .. }),
            &["mesh 'tri' primitive 0", "index 1 is 7"],
        ),
        case(
            "NaN position",
            "file.glb",
            with_bin(|bin| bin[16..20].copy_from_slice(&f32::NAN.to_le_bytes())),
            Mesh,
            |e| matches!(e, E::GltfData { .. }),
            &["accessor 0", "element 1 component 1 is NaN"],
        ),
        case(
            "lines primitive",
            "file.glb",
            variant(r#""mode": 4"#, r#""mode": 1"#),
            Mesh,
            |e| matches!(e, E::GltfUnsupported { .. }),
            &["primitive 0", "Lines"],
        ),
        case(
            "missing external .bin",
            "file.gltf",
            json_with_buffer(r#"{"uri": "missing.bin", "byteLength": 96}"#),
            Mesh,
            |e| matches!(e, E::GltfExternal { buffer: 0, .. }),
            &["missing.bin"],
        ),
        case(
            "bad base64 data URI",
            "file.gltf",
            json_with_buffer(
                r#"{"uri": "data:application/octet-stream;base64,@@not base64@@", "byteLength": 96}"#,
            ),
            Mesh,
            |e| matches!(e, E::GltfData { .. }),
            &["buffer 0", "base64"],
        ),
        case(
            "data URI shorter than byteLength",
            "file.gltf",
            short_uri,
            Mesh,
            |e| matches!(e, E::GltfData { .. }),
            &["byteLength 96"],
        ),
        // The target's accessor covers 2 vertices of a 3-vertex primitive.
        case(
            "target size mismatch",
            "file.glb",
            variant(
                r#"{"bufferView": 2, "componentType": 5126, "count": 3"#,
                r#"{"bufferView": 2, "componentType": 5126, "count": 2"#,
            ),
            Animation,
            |e| matches!(e, E::GltfData { .. }),
            &["target 0", "2 deltas", "3 vertices"],
        ),
        case(
            "target count differs from weights",
            "file.glb",
            variant(r#""weights": [0]"#, r#""weights": [0, 0.5]"#),
            Animation,
            |e| matches!(e, E::GltfData { .. }),
            &["mesh 'tri' weights"],
        ),
        // 2 keyframe times but 1 output value for 1 target.
        case(
            "animation sampler count mismatch",
            "file.glb",
            variant(
                r#"{"bufferView": 4, "componentType": 5126, "count": 2"#,
                r#"{"bufferView": 4, "componentType": 5126, "count": 1"#,
            ),
            Animation,
            |e| matches!(e, E::GltfData { .. }),
            &["animation 'lift' sampler 0", "2 keyframes", "has 1"],
        ),
        case(
            "animation times not increasing",
            "file.glb",
            with_bin(|bin| bin[84..88].copy_from_slice(&0.0f32.to_le_bytes())),
            Animation,
            |e| matches!(e, E::GltfData { .. }),
            &["strictly increasing"],
        ),
        // The `gltf` crate validates an animation's samplers but not its channels; an unknown
        // target path used to panic in `Checked::unwrap` (found by the mutation proptest), an
        // out-of-range target node in an unchecked index.
        case(
            "channel with an unknown path",
            "file.glb",
            variant(r#""path": "weights""#, r#""path": "weighus""#),
            MeshAndInspect,
            |e| matches!(e, E::GltfJson { .. }),
            &["target.path"],
        ),
        case(
            "channel with an unknown path, animated",
            "file.glb",
            variant(r#""path": "weights""#, r#""path": "weighus""#),
            Animation,
            |e| matches!(e, E::GltfJson { .. }),
            &[],
        ),
        case(
            "channel with an unknown node",
            "file.glb",
            variant(r#""target": {"node": 0"#, r#""target": {"node": 7"#),
            MeshAndInspect,
            |e| matches!(e, E::GltfJson { .. }),
            &["target.node"],
        ),
        case(
            "channel with an unknown node, animated",
            "file.glb",
            variant(r#""target": {"node": 0"#, r#""target": {"node": 7"#),
            Animation,
            |e| matches!(e, E::GltfJson { .. }),
            &[],
        ),
        case(
            "sparse index out of range",
            "file.glb",
            variant(DENSE_TARGET, &sparse_out_of_range),
            Animation,
            |e| matches!(e, E::GltfData { .. }),
            &["accessor 2", "sparse entry 0 replaces element 2"],
        ),
        case(
            "huge viewless accessor, refused before allocating",
            "file.glb",
            variant(
                DENSE_TARGET,
                &SPARSE_TARGET.replace(r#""count": 3"#, r#""count": 4000000000"#),
            ),
            Animation,
            |e| matches!(e, E::GltfUnsupported { .. }),
            &["accessor 2"],
        ),
    ];
    for cut in [5, 12, 30, valid.len() - 10] {
        let mut truncated = case(
            &format!("truncated at {cut}"),
            "file.glb",
            &valid[..cut],
            Mesh,
            |e| matches!(e, E::GltfContainer { .. }),
            &[],
        );
        truncated.says_one_of = &["header", "truncated"];
        cases.push(truncated);
    }
    cases
}

#[test]
fn malformed_documents() {
    let cases = cases();
    let failures: Vec<String> = cases
        .iter()
        .filter_map(|c| check(c).map(|why| format!("{} ({:?}): {why}", c.name, c.via)))
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} malformed glTF inputs were not refused as expected:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

#[test]
fn external_bin_loads_when_present() {
    // The counterpart of the table's missing-file case, so that case fails for the
    // right reason.
    let dir = scratch("external-bin");
    std::fs::write(dir.join("tri data.bin"), valid_bin()).unwrap();
    let json = json_with_buffer(r#"{"uri": "tri%20data.bin", "byteLength": 96}"#);
    let path = dir.join("file.gltf");
    std::fs::write(&path, json).unwrap();
    assert_eq!(load(&path).unwrap().triangles, vec![[0, 1, 2]]);
}

/// A node that is its own child breaks glTF's rule that the node hierarchy is a set of trees:
/// the file is invalid, so loading it (with or without node transforms, and its animation) is a
/// typed JSON error naming the node, never a hang or a mesh placed by a partial walk.
#[test]
fn cyclic_node_hierarchy_is_refused() {
    let path = glb_variant(
        "cycle",
        r#""nodes": [{"mesh": 0}]"#,
        r#""nodes": [{"mesh": 0, "children": [0]}]"#,
    );
    for apply_transforms in [true, false] {
        let options = LoadOptions {
            apply_transforms,
            ..LoadOptions::default()
        };
        let err = load_mesh(&path, &options).expect_err("a cyclic hierarchy is invalid glTF");
        assert!(matches!(err, LoadError::GltfJson { .. }), "{err:?}");
        let message = err.to_string();
        assert!(
            message.contains("node 0") && message.contains("cycle"),
            "{message}"
        );
    }
    assert!(matches!(animated(&path), Err(LoadError::GltfJson { .. })));
    // Two parents of one node break the same rule.
    let path = glb_variant(
        "two-parents",
        r#""nodes": [{"mesh": 0}]"#,
        r#""nodes": [{"mesh": 0}, {"children": [0]}, {"children": [0]}]"#,
    );
    let err = load(&path).expect_err("a node with two parents is invalid glTF");
    assert!(matches!(err, LoadError::GltfJson { .. }), "{err:?}");
    assert!(err.to_string().contains("at most one parent"), "{err}");
}

/// AnimatedMorphCube as one GLB, built in memory from the .gltf and .bin.
fn cube_glb() -> Vec<u8> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/AnimatedMorphCube-glTF");
    let json = std::fs::read(dir.join("AnimatedMorphCube.gltf")).unwrap();
    let bin = std::fs::read(dir.join("AnimatedMorphCube.bin")).unwrap();
    let mut root: ::gltf::json::Root = ::gltf::json::deserialize::from_slice(&json).unwrap();
    root.buffers[0].uri = None;
    let json = ::gltf::json::serialize::to_string(&root).unwrap();
    glb(&json, &bin)
}

#[test]
fn cube_glb_loads() {
    let path = write("cube", "cube.glb", &cube_glb());
    let mesh = load(&path).unwrap();
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (24, 12));
    assert_eq!(animated_cube(&path).unwrap().vertex_count(), 24);
}

fn animated_cube(path: &Path) -> Result<Morph, LoadError> {
    morphlod::io::load_morph(
        path,
        &LoadOptions::default(),
        &MorphSource::Animation("0".to_string()),
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Random byte edits anywhere in the cube's GLB (header, JSON, binary data):
    /// loading returns Ok or a typed error, never panics, and whatever loads is
    /// usable (indices in range, finite positions, one position per vertex).
    #[test]
    fn mutated_cube_glb_never_panics(
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        cut in proptest::option::of(any::<prop::sample::Index>()),
    ) {
        let mut bytes = cube_glb();
        for (at, value) in edits {
            let i = at.index(bytes.len());
            bytes[i] = value;
        }
        if let Some(cut) = cut {
            bytes.truncate(cut.index(bytes.len()));
        }
        let path = write("proptest", "case.glb", &bytes);
        if let Ok(mesh) = load(&path) {
            let n = mesh.vertex_count();
            prop_assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
            prop_assert!(mesh.positions.iter().flatten().all(|c| c.is_finite()));
        }
        let _ = inspect(&path);
        if let Ok(morph) = animated_cube(&path) {
            let n = morph.vertex_count();
            prop_assert!(morph.triangles().iter().flatten().all(|&i| (i as usize) < n));
            for t in [0.0, 0.3, 1.0] {
                prop_assert_eq!(morph.positions_at(t).len(), n);
            }
        }
    }
}

/// The target as a sparse accessor without a buffer view: zeros except the
/// entries listed (index 0 from view 1, value (0, 0, 1) from view 2).
const SPARSE_TARGET: &str = r#"{"componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 1],
    "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5123}, "values": {"bufferView": 2}}}"#;

const DENSE_TARGET: &str = r#"{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 1], "max": [0, 0, 1]}"#;

#[test]
fn sparse_target_deltas_load() {
    let path = glb_variant("sparse", DENSE_TARGET, SPARSE_TARGET);
    let morph = morphlod::io::load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Target("lift".to_string()),
    )
    .unwrap();
    assert_eq!(
        morph.v1(),
        vec![[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    );
}
