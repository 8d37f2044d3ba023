//! Malformed files: every loader must answer with the specific typed error,
//! naming the line or element at fault, and must never panic or allocate by
//! an untrusted header count. The last test mutates valid files at random.

use morphlod::io::{load_mesh, obj, off, ply, LoadError, LoadOptions, Location};
use morphlod::mesh::MeshError;
use proptest::prelude::*;
use std::path::Path;

fn obj(text: &[u8]) -> LoadError {
    obj::parse(text, Path::new("bad.obj")).expect_err("the OBJ should be rejected")
}

fn off(text: &[u8]) -> LoadError {
    off::parse(text, Path::new("bad.off")).expect_err("the OFF should be rejected")
}

fn ply(bytes: &[u8]) -> LoadError {
    ply::parse(bytes, Path::new("bad.ply")).expect_err("the PLY should be rejected")
}

/// Asserts the error's message names `needle` (a line, element, or value),
/// so a user can find the fault.
fn says(err: &LoadError, needle: &str) {
    let message = err.to_string();
    assert!(
        message.contains(needle),
        "{message:?} should mention {needle:?}"
    );
}

const PLY_ASCII_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

/// A binary little-endian PLY: `vertex_count` / `face_count` go in the
/// header as given, whatever the body holds.
fn binary_ply(
    vertex_count: u64,
    face_count: u64,
    positions: &[[f32; 3]],
    faces: &[&[i32]],
) -> Vec<u8> {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {vertex_count}\nproperty float x\nproperty float y\nproperty float z\nelement face {face_count}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    for p in positions {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for face in faces {
        bytes.push(face.len() as u8);
        for i in *face {
            bytes.extend_from_slice(&i.to_le_bytes());
        }
    }
    bytes
}

const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

// ---- OBJ -------------------------------------------------------------------

#[test]
fn obj_index_zero() {
    let err = obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    assert!(
        matches!(
            err,
            LoadError::ZeroIndex {
                at: Location::Line(4),
                ..
            }
        ),
        "{err}"
    );
    says(&err, "line 4");
}

#[test]
fn obj_negative_index_out_of_range() {
    let err = obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
    assert!(
        matches!(
            err,
            LoadError::IndexOutOfRange {
                at: Location::Line(4),
                index: -4,
                vertices: 3,
                ..
            }
        ),
        "{err}"
    );
    says(&err, "-4");
}

#[test]
fn obj_positive_index_out_of_range() {
    let err = obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 99\n");
    assert!(
        matches!(
            err,
            LoadError::IndexOutOfRange {
                at: Location::Line(5),
                index: 99,
                ..
            }
        ),
        "{err}"
    );
    says(&err, "line 5");
}

#[test]
fn obj_nan_and_overflowing_coordinates() {
    let err = obj(b"v 0 0 0\nv NaN 0 0\n");
    assert!(
        matches!(
            err,
            LoadError::NonFinite {
                at: Location::Line(2),
                ..
            }
        ),
        "{err}"
    );
    // Finite as text, infinite as f32: as unusable as inf.
    let err = obj(b"v 0 0 1e39\n");
    assert!(
        matches!(
            err,
            LoadError::NonFinite {
                at: Location::Line(1),
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn obj_face_with_two_vertices() {
    let err = obj(b"v 0 0 0\nv 1 0 0\nf 1 2\n");
    assert!(
        matches!(
            err,
            LoadError::FaceTooSmall {
                at: Location::Line(3),
                corners: 2,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn obj_unparsable_number_and_index() {
    let err = obj(b"v 0 0 0.0.0\n");
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(1),
                ..
            }
        ),
        "{err}"
    );
    says(&err, "0.0.0");
    let err = obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 three\n");
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(4),
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn obj_empty_and_garbage_have_no_mesh() {
    for bytes in [&b""[..], b"\x00\x01\x02\xff\xfe garbage \x7f\n\x89PNG\r\n"] {
        let err = obj(bytes);
        assert!(
            matches!(
                err,
                LoadError::InvalidMesh {
                    source: MeshError::Empty { .. },
                    ..
                }
            ),
            "{err}"
        );
    }
}

#[test]
fn obj_non_utf8() {
    // Latin-1 in a comment or a group name is harmless; in a number it is an error.
    let ok = obj::parse(
        b"# caf\xe9\ng d\xe9cor\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        Path::new("x.obj"),
    );
    assert!(ok.is_ok(), "{ok:?}");
    let err = obj(b"v 0 0 0\nv 1 \xe90 0\n");
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(2),
                ..
            }
        ),
        "{err}"
    );
}

// ---- OFF -------------------------------------------------------------------

#[test]
fn off_truncated() {
    let err = off(b"OFF\n3 1 0\n0 0 0\n1 0 0\n");
    assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
    says(&err, "vertex 2 of the 3");
    let err = off(b"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    says(&err, "face 1 of the 2");
}

#[test]
fn off_huge_counts_tiny_body() {
    // Reserving by these counts would ask for ~100 GB before noticing.
    let err = off(b"OFF\n9000000000 9000000000 0\n0 0 0\n");
    assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
}

#[test]
fn off_bad_header() {
    let err = off(b"OFFF\n3 1 0\n");
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(1),
                ..
            }
        ),
        "{err}"
    );
    let err = off(b"OFF\n3 one 0\n");
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(2),
                ..
            }
        ),
        "{err}"
    );
    let err = off(b"OFF BINARY\n3 1 0\n");
    assert!(matches!(err, LoadError::Unsupported { .. }), "{err}");
}

#[test]
fn off_index_out_of_range_and_negative() {
    let err = off(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    assert!(
        matches!(
            err,
            LoadError::IndexOutOfRange {
                at: Location::Line(6),
                index: 7,
                vertices: 3,
                ..
            }
        ),
        "{err}"
    );
    let err = off(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n");
    assert!(
        matches!(err, LoadError::IndexOutOfRange { index: -1, .. }),
        "{err}"
    );
}

#[test]
fn off_infinite_coordinate() {
    let err = off(b"OFF\n3 1 0\n0 0 0\n1 0 -inf\n0 1 0\n3 0 1 2\n");
    assert!(
        matches!(
            err,
            LoadError::NonFinite {
                at: Location::Line(4),
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn off_empty_and_face_too_small() {
    let err = off(b"");
    assert!(matches!(err, LoadError::Syntax { .. }), "{err}");
    let err = off(b"# only a comment\n\n");
    assert!(matches!(err, LoadError::Syntax { .. }), "{err}");
    let err = off(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
    assert!(
        matches!(
            err,
            LoadError::FaceTooSmall {
                at: Location::Line(6),
                corners: 2,
                ..
            }
        ),
        "{err}"
    );
}

// ---- PLY ASCII -------------------------------------------------------------

#[test]
fn ply_ascii_truncated() {
    let text = format!("{PLY_ASCII_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1\n");
    let err = ply(text.as_bytes());
    assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
    says(&err, "face 0 of the 1");
}

#[test]
fn ply_ascii_nan_and_index_out_of_range() {
    let err = ply(format!("{PLY_ASCII_HEADER}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n").as_bytes());
    assert!(matches!(err, LoadError::NonFinite { .. }), "{err}");
    says(&err, "line 11 (vertex 1)");
    let err = ply(format!("{PLY_ASCII_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n").as_bytes());
    assert!(
        matches!(err, LoadError::IndexOutOfRange { index: -2, .. }),
        "{err}"
    );
    says(&err, "face 0");
}

#[test]
fn ply_missing_face_element() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
    let err = ply(text.as_bytes());
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(7),
                ..
            }
        ),
        "{err}"
    );
    says(&err, "element face");
}

#[test]
fn ply_wrong_list_types() {
    // Float vertex indices.
    let text = PLY_ASCII_HEADER.replace("list uchar int", "list uchar float");
    let err = ply(text.as_bytes());
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(8),
                ..
            }
        ),
        "{err}"
    );
    // Float list count.
    let text = PLY_ASCII_HEADER.replace("list uchar int", "list float int");
    let err = ply(text.as_bytes());
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(8),
                ..
            }
        ),
        "{err}"
    );
    // Indices declared as a scalar, not a list.
    let text = PLY_ASCII_HEADER.replace("list uchar int vertex_indices", "int vertex_indices");
    let err = ply(text.as_bytes());
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(8),
                ..
            }
        ),
        "{err}"
    );
    // Unknown type name.
    let text = PLY_ASCII_HEADER.replace("property float y", "property float128 y");
    let err = ply(text.as_bytes());
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(5),
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn ply_bad_magic_big_endian_and_missing_end_header() {
    let err = ply(b"PLY\nformat ascii 1.0\nend_header\n");
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(1),
                ..
            }
        ),
        "{err}"
    );
    let err = ply(b"");
    assert!(
        matches!(
            err,
            LoadError::Syntax {
                at: Location::Line(1),
                ..
            }
        ),
        "{err}"
    );
    let err = ply(PLY_ASCII_HEADER
        .replace("ascii", "binary_big_endian")
        .as_bytes());
    assert!(matches!(err, LoadError::Unsupported { .. }), "{err}");
    says(&err, "binary_little_endian");
    let err = ply(b"ply\nformat ascii 1.0\nelement vertex 3\n");
    assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
    says(&err, "end_header");
}

// ---- PLY binary ------------------------------------------------------------

#[test]
fn ply_binary_valid_then_truncated_mid_vertex() {
    let bytes = binary_ply(3, 1, &TRIANGLE, &[&[0, 1, 2]]);
    assert!(ply::parse(&bytes, Path::new("ok.ply")).is_ok());
    let header_len = bytes.len() - 3 * 12 - (1 + 3 * 4);
    let err = ply(&bytes[..header_len + 12 + 6]);
    assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
    says(&err, "vertex 1 of the 3");
}

#[test]
fn ply_binary_huge_counts_tiny_body() {
    let err = ply(&binary_ply(4_000_000_000, 4_000_000_000, &TRIANGLE, &[]));
    assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
    says(&err, "vertex 3 of the 4000000000");
    // A face whose list count (255) runs past the end of the data.
    let mut bytes = binary_ply(3, 1, &TRIANGLE, &[]);
    bytes.push(255);
    bytes.extend_from_slice(&0i32.to_le_bytes());
    let err = ply(&bytes);
    assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
    says(&err, "face 0 of the 1");
}

#[test]
fn ply_binary_index_out_of_range_names_the_record() {
    let err = ply(&binary_ply(3, 2, &TRIANGLE, &[&[0, 1, 2], &[0, 1, 3]]));
    match &err {
        LoadError::IndexOutOfRange {
            at,
            index: 3,
            vertices: 3,
            ..
        } => assert_eq!(
            at,
            &Location::Record {
                element: "face".into(),
                index: 1,
                line: None
            }
        ),
        other => panic!("unexpected {other}"),
    }
    says(&err, "face 1");
}

#[test]
fn ply_binary_nan_and_small_face() {
    let err = ply(&binary_ply(
        3,
        1,
        &[[0.0; 3], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[&[0, 1, 2]],
    ));
    assert!(matches!(err, LoadError::NonFinite { .. }), "{err}");
    says(&err, "vertex 1");
    let err = ply(&binary_ply(3, 1, &TRIANGLE, &[&[0, 1]]));
    assert!(
        matches!(err, LoadError::FaceTooSmall { corners: 2, .. }),
        "{err}"
    );
}

// ---- dispatch --------------------------------------------------------------

#[test]
fn missing_file_and_unknown_extension() {
    let options = LoadOptions::default();
    let err = load_mesh(Path::new("/nonexistent/dir/mesh.off"), &options).unwrap_err();
    assert!(matches!(err, LoadError::Io { .. }), "{err}");
    says(&err, "/nonexistent/dir/mesh.off");
    let err = load_mesh(Path::new("mesh.stl"), &options).unwrap_err();
    assert!(matches!(err, LoadError::Unsupported { .. }), "{err}");
    says(&err, "stl");
}

#[test]
fn extension_is_case_insensitive() {
    let dir = std::env::temp_dir().join(format!("morphlod-bad-input-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("TRI.OFF");
    std::fs::write(&path, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
    let mesh = load_mesh(&path, &LoadOptions::default());
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(mesh.unwrap().triangles, vec![[0, 1, 2]]);
}

/// The CLI turns a load error into one located message and exit code 1,
/// still reporting the good files given with it.
#[test]
fn cli_info_reports_errors_without_panic() {
    let dir = std::env::temp_dir().join(format!("morphlod-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.off");
    std::fs::write(&bad, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n").unwrap();
    let good = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/bunny.obj");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .arg("info")
        .arg(&bad)
        .arg(&good)
        .output()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("line 6: vertex index 5 is out of range"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stdout.contains("1839 vertices, 3674 triangles"), "{stdout}");
    assert!(stdout.contains("genus             0"), "{stdout}");
}

// ---- fuzzing by mutation ---------------------------------------------------

fn valid_inputs() -> Vec<(&'static str, Vec<u8>)> {
    let ascii = format!("{PLY_ASCII_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    vec![
        (
            "a.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1/1/1 2//2 -1\nf 1 2 3 4\n".to_vec(),
        ),
        (
            "a.off",
            b"COFF 4 2 0\n0 0 0 1 1 1\n1 0 0 1 1 1\n0 1 0 1 1 1\n1 1 0 1 1 1\n4 0 1 3 2\n3 0 1 2\n"
                .to_vec(),
        ),
        ("a.ply", ascii.into_bytes()),
        ("b.ply", binary_ply(3, 1, &TRIANGLE, &[&[0, 1, 2]])),
    ]
}

fn parse_any(name: &str, bytes: &[u8]) -> Result<morphlod::IndexedMesh, LoadError> {
    let path = Path::new(name);
    match name.rsplit('.').next() {
        Some("obj") => obj::parse(bytes, path),
        Some("off") => off::parse(bytes, path),
        _ => ply::parse(bytes, path),
    }
}

/// Every prefix of every valid input parses without panicking; a binary
/// PLY needs all of its bytes, so each of its strict prefixes is an error.
#[test]
fn every_truncation_is_handled() {
    for (name, bytes) in valid_inputs() {
        for len in 0..bytes.len() {
            let result = parse_any(name, &bytes[..len]);
            if name == "b.ply" {
                assert!(result.is_err(), "{name} cut at {len} was accepted");
            }
            if let Ok(mesh) = result {
                assert!(mesh.validate().is_ok(), "{name} cut at {len}");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Random byte edits and truncations of valid files: parsing returns
    /// (never panics), and whatever it accepts is a valid mesh.
    #[test]
    fn mutated_files_never_panic(
        which in 0usize..4,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..8),
        cut in any::<prop::sample::Index>(),
        truncate in any::<bool>(),
    ) {
        let inputs = valid_inputs();
        let (name, mut bytes) = inputs[which].clone();
        for (at, byte) in edits {
            let i = at.index(bytes.len());
            bytes[i] = byte;
        }
        if truncate {
            bytes.truncate(cut.index(bytes.len()));
        }
        if let Ok(mesh) = parse_any(name, &bytes) {
            prop_assert!(mesh.validate().is_ok());
        }
    }
}

// A test crate root resolves `mod x;` beside itself (tests/x.rs), so the
// per-format files under tests/bad_input/ need explicit paths.
#[path = "bad_input/gltf.rs"]
mod gltf;
