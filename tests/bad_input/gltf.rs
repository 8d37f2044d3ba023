//! Malformed glTF / GLB inputs: each must give a typed error naming the element
//! at fault, never a panic. The files are built here from one small valid
//! document (a triangle with one morph target and a weight animation) by
//! changing one thing at a time.

use morphlod::io::gltf::{inspect, load_mesh};
use morphlod::io::{LoadError, LoadOptions};
use morphlod::morph::{Morph, MorphError, MorphSource};
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
fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
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

/// A fresh directory per test (tests run in parallel).
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("morphlod-bad-gltf-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(test: &str, name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch(test).join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn load(path: &Path) -> Result<morphlod::IndexedMesh, LoadError> {
    load_mesh(path, &LoadOptions::default())
}

fn animated(path: &Path) -> Result<Morph, MorphError> {
    Morph::from_gltf(
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

#[test]
fn bad_glb_magic() {
    let mut bytes = valid_glb();
    bytes[3] = b'X';
    let err = load(&write("magic", "file.glb", &bytes)).unwrap_err();
    assert!(matches!(err, LoadError::GltfContainer { .. }), "{err:?}");
    assert!(err.to_string().contains("magic"), "{err}");
}

#[test]
fn glb_chunk_length_past_end() {
    let mut bytes = valid_glb();
    bytes[12..16].copy_from_slice(&100_000u32.to_le_bytes());
    let err = load(&write("chunk", "file.glb", &bytes)).unwrap_err();
    assert!(matches!(err, LoadError::GltfContainer { .. }), "{err:?}");
    assert!(err.to_string().contains("chunk 0"), "{err}");
}

#[test]
fn truncated_glb() {
    let bytes = valid_glb();
    for cut in [5, 12, 30, bytes.len() - 10] {
        let err = load(&write("truncated", "file.glb", &bytes[..cut])).unwrap_err();
        assert!(
            matches!(err, LoadError::GltfContainer { .. }),
            "{cut}: {err:?}"
        );
        let message = err.to_string();
        assert!(
            message.contains("header") || message.contains("truncated"),
            "{message}"
        );
    }
}

#[test]
fn glb_header_length_below_header_size() {
    // The `gltf` crate's own GLB reader underflows on this; ours must not.
    let mut bytes = valid_glb();
    bytes[8..12].copy_from_slice(&4u32.to_le_bytes());
    let err = load(&write("short-length", "file.glb", &bytes)).unwrap_err();
    assert!(matches!(err, LoadError::GltfContainer { .. }), "{err:?}");
}

#[test]
fn invalid_json() {
    let err = load(&write("json", "file.gltf", b"{\"asset\": {\"version\": ")).unwrap_err();
    assert!(matches!(err, LoadError::GltfJson { .. }), "{err:?}");
    assert!(err.to_string().contains("invalid glTF JSON"), "{err}");
}

#[test]
fn position_accessor_index_out_of_range() {
    // The `gltf` validator indexes accessors[POSITION] unchecked.
    let path = glb_variant("position-index", r#""POSITION": 0}"#, r#""POSITION": 42}"#);
    let err = load(&path).unwrap_err();
    assert!(matches!(err, LoadError::GltfJson { .. }), "{err:?}");
    assert!(err.to_string().contains("POSITION"), "{err}");
}

#[test]
fn accessor_reads_past_its_buffer_view() {
    let path = glb_variant(
        "past-view",
        r#""componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0]"#,
        r#""componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0]"#,
    );
    let err = load(&path).unwrap_err();
    assert!(matches!(err, LoadError::GltfData { .. }), "{err:?}");
    let message = err.to_string();
    assert!(
        message.contains("accessor 0") && message.contains("buffer view 0"),
        "{message}"
    );
}

#[test]
fn buffer_view_past_its_buffer() {
    let path = glb_variant(
        "view-past-buffer",
        r#"{"buffer": 0, "byteOffset": 88, "byteLength": 8}"#,
        r#"{"buffer": 0, "byteOffset": 88, "byteLength": 80}"#,
    );
    let err = animated(&path).unwrap_err();
    assert!(
        matches!(err, MorphError::Load(LoadError::GltfData { .. })),
        "{err:?}"
    );
    assert!(err.to_string().contains("buffer view 4"), "{err}");
}

#[test]
fn index_out_of_range() {
    let mut bin = valid_bin();
    bin[38..40].copy_from_slice(&7u16.to_le_bytes());
    let json = json_with_buffer(r#"{"byteLength": 96}"#);
    let err = load(&write("index", "file.glb", &glb(&json, &bin))).unwrap_err();
    assert!(matches!(err, LoadError::GltfData { .. }), "{err:?}");
    let message = err.to_string();
    assert!(
        message.contains("mesh 'tri' primitive 0") && message.contains("index 1 is 7"),
        "{message}"
    );
}

#[test]
fn nan_position() {
    let mut bin = valid_bin();
    bin[16..20].copy_from_slice(&f32::NAN.to_le_bytes());
    let json = json_with_buffer(r#"{"byteLength": 96}"#);
    let err = load(&write("nan", "file.glb", &glb(&json, &bin))).unwrap_err();
    assert!(matches!(err, LoadError::GltfData { .. }), "{err:?}");
    let message = err.to_string();
    assert!(
        message.contains("accessor 0") && message.contains("element 1 component 1 is NaN"),
        "{message}"
    );
}

#[test]
fn lines_primitive_is_unsupported() {
    let path = glb_variant("lines", r#""mode": 4"#, r#""mode": 1"#);
    let err = load(&path).unwrap_err();
    assert!(matches!(err, LoadError::GltfUnsupported { .. }), "{err:?}");
    let message = err.to_string();
    assert!(
        message.contains("primitive 0") && message.contains("Lines"),
        "{message}"
    );
}

#[test]
fn missing_external_bin() {
    let json = json_with_buffer(r#"{"uri": "missing.bin", "byteLength": 96}"#);
    let err = load(&write("missing-bin", "file.gltf", json.as_bytes())).unwrap_err();
    assert!(
        matches!(err, LoadError::GltfExternal { buffer: 0, .. }),
        "{err:?}"
    );
    assert!(err.to_string().contains("missing.bin"), "{err}");
}

#[test]
fn external_bin_loads_when_present() {
    // The counterpart of the missing-file case, so the case above fails for the
    // right reason.
    let dir = scratch("external-bin");
    std::fs::write(dir.join("tri data.bin"), valid_bin()).unwrap();
    let json = json_with_buffer(r#"{"uri": "tri%20data.bin", "byteLength": 96}"#);
    let path = dir.join("file.gltf");
    std::fs::write(&path, json).unwrap();
    assert_eq!(load(&path).unwrap().triangles, vec![[0, 1, 2]]);
}

#[test]
fn bad_base64_data_uri() {
    let json = json_with_buffer(
        r#"{"uri": "data:application/octet-stream;base64,@@not base64@@", "byteLength": 96}"#,
    );
    let err = load(&write("base64", "file.gltf", json.as_bytes())).unwrap_err();
    assert!(matches!(err, LoadError::GltfData { .. }), "{err:?}");
    let message = err.to_string();
    assert!(
        message.contains("buffer 0") && message.contains("base64"),
        "{message}"
    );
}

#[test]
fn data_uri_shorter_than_byte_length() {
    use base64::Engine;
    let data = base64::engine::general_purpose::STANDARD.encode(&valid_bin()[..40]);
    let json = json_with_buffer(&format!(
        r#"{{"uri": "data:application/octet-stream;base64,{data}", "byteLength": 96}}"#
    ));
    let err = load(&write("short-uri", "file.gltf", json.as_bytes())).unwrap_err();
    assert!(matches!(err, LoadError::GltfData { .. }), "{err:?}");
    assert!(err.to_string().contains("byteLength 96"), "{err}");
}

#[test]
fn target_size_mismatch() {
    // The target's accessor covers 2 vertices of a 3-vertex primitive.
    let path = glb_variant(
        "target-size",
        r#"{"bufferView": 2, "componentType": 5126, "count": 3"#,
        r#"{"bufferView": 2, "componentType": 5126, "count": 2"#,
    );
    let err = animated(&path).unwrap_err();
    assert!(
        matches!(err, MorphError::Load(LoadError::GltfData { .. })),
        "{err:?}"
    );
    let message = err.to_string();
    assert!(
        message.contains("target 0")
            && message.contains("2 deltas")
            && message.contains("3 vertices"),
        "{message}"
    );
}

#[test]
fn target_count_differs_from_weights() {
    let path = glb_variant("weights", r#""weights": [0]"#, r#""weights": [0, 0.5]"#);
    let err = animated(&path).unwrap_err();
    assert!(
        matches!(err, MorphError::Load(LoadError::GltfData { .. })),
        "{err:?}"
    );
    assert!(err.to_string().contains("mesh 'tri' weights"), "{err}");
}

#[test]
fn animation_sampler_count_mismatch() {
    // 2 keyframe times but 1 output value for 1 target.
    let path = glb_variant(
        "sampler",
        r#"{"bufferView": 4, "componentType": 5126, "count": 2"#,
        r#"{"bufferView": 4, "componentType": 5126, "count": 1"#,
    );
    let err = animated(&path).unwrap_err();
    assert!(
        matches!(err, MorphError::Load(LoadError::GltfData { .. })),
        "{err:?}"
    );
    let message = err.to_string();
    assert!(
        message.contains("animation 'lift' sampler 0")
            && message.contains("2 keyframes")
            && message.contains("has 1"),
        "{message}"
    );
}

#[test]
fn animation_times_not_increasing() {
    let mut bin = valid_bin();
    bin[84..88].copy_from_slice(&0.0f32.to_le_bytes());
    let json = json_with_buffer(r#"{"byteLength": 96}"#);
    let err = animated(&write("times", "file.glb", &glb(&json, &bin))).unwrap_err();
    assert!(
        matches!(err, MorphError::Load(LoadError::GltfData { .. })),
        "{err:?}"
    );
    assert!(err.to_string().contains("strictly increasing"), "{err}");
}

/// The `gltf` crate validates an animation's samplers but not its channels; an
/// unknown target path used to panic in `Checked::unwrap` (found by the
/// mutation proptest below), an out-of-range target node in an unchecked index.
#[test]
fn animation_channel_with_unknown_path_or_node() {
    for (test, from, to, says) in [
        (
            "channel_path",
            r#""path": "weights""#,
            r#""path": "weighus""#,
            "target.path",
        ),
        (
            "channel_node",
            r#""target": {"node": 0"#,
            r#""target": {"node": 7"#,
            "target.node",
        ),
    ] {
        let path = glb_variant(test, from, to);
        for err in [
            morphlod::io::gltf::inspect(&path).unwrap_err(),
            load(&path).unwrap_err(),
        ] {
            assert!(matches!(err, LoadError::GltfJson { .. }), "{err:?}");
            assert!(err.to_string().contains(says), "{err}");
        }
        let err = animated(&path).unwrap_err();
        assert!(
            matches!(err, MorphError::Load(LoadError::GltfJson { .. })),
            "{err:?}"
        );
    }
}

#[test]
fn cyclic_node_hierarchy_terminates() {
    // A node that is its own child: placing the mesh must not loop forever.
    let path = glb_variant(
        "cycle",
        r#""nodes": [{"mesh": 0}]"#,
        r#""nodes": [{"mesh": 0, "children": [0]}]"#,
    );
    let options = LoadOptions {
        apply_transforms: true,
        ..LoadOptions::default()
    };
    match load_mesh(&path, &options) {
        Ok(mesh) => assert_eq!(mesh.triangles, vec![[0, 1, 2]]),
        Err(err) => assert!(matches!(err, LoadError::GltfJson { .. }), "{err:?}"),
    }
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

fn animated_cube(path: &Path) -> Result<Morph, MorphError> {
    Morph::from_gltf(
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
    let morph = Morph::from_gltf(
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

#[test]
fn sparse_index_out_of_range() {
    // Sparse index 2 (the third u16 of view 1, at byte 4) in a 2-element accessor.
    let bad = SPARSE_TARGET
        .replace(r#""count": 3"#, r#""count": 2"#)
        .replace(
            r#""bufferView": 1, "componentType": 5123"#,
            r#""bufferView": 1, "byteOffset": 4, "componentType": 5123"#,
        );
    let path = glb_variant("sparse-range", DENSE_TARGET, &bad);
    let err = animated(&path).unwrap_err();
    assert!(
        matches!(err, MorphError::Load(LoadError::GltfData { .. })),
        "{err:?}"
    );
    let message = err.to_string();
    assert!(
        message.contains("accessor 2") && message.contains("sparse entry 0 replaces element 2"),
        "{message}"
    );
}

#[test]
fn huge_viewless_accessor_is_refused_before_allocating() {
    let huge = SPARSE_TARGET.replace(r#""count": 3"#, r#""count": 4000000000"#);
    let path = glb_variant("huge-sparse", DENSE_TARGET, &huge);
    let err = animated(&path).unwrap_err();
    assert!(
        matches!(err, MorphError::Load(LoadError::GltfUnsupported { .. })),
        "{err:?}"
    );
    assert!(err.to_string().contains("accessor 2"), "{err}");
}
