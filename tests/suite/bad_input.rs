//! Malformed files: every loader must answer with the specific typed error,
//! naming the line or element at fault, and must never panic or allocate by
//! an untrusted header count. The cases are one table (`malformed_meshes`), run
//! by one loop that reports every failing row; the last test mutates valid
//! files at random.

use morphlod::io::{load_mesh, obj, off, ply, AttributedMesh, LoadError, LoadOptions, Location};
use morphlod::mesh::MeshError;
use proptest::prelude::*;
use std::path::Path;

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

// ---- the table -------------------------------------------------------------

/// Which parser a case feeds.
#[derive(Clone, Copy, Debug)]
enum Format {
    Obj,
    Off,
    Ply,
}

/// One malformed input: the bytes, the typed error expected (a predicate over the variant and
/// its fields) and the words its message must contain so a user can find the fault.
struct Case {
    name: &'static str,
    format: Format,
    bytes: Vec<u8>,
    expect: fn(&LoadError) -> bool,
    says: &'static [&'static str],
}

fn case(
    name: &'static str,
    format: Format,
    bytes: impl Into<Vec<u8>>,
    expect: fn(&LoadError) -> bool,
    says: &'static [&'static str],
) -> Case {
    Case {
        name,
        format,
        bytes: bytes.into(),
        expect,
        says,
    }
}

fn parse(format: Format, bytes: &[u8]) -> Result<morphlod::IndexedMesh, LoadError> {
    match format {
        Format::Obj => obj::parse(bytes, Path::new("bad.obj")),
        Format::Off => off::parse(bytes, Path::new("bad.off")),
        Format::Ply => ply::parse(bytes, Path::new("bad.ply")),
    }
}

/// The reason a row fails, or `None` when the input is refused as expected.
fn check(case: &Case) -> Option<String> {
    let err = match parse(case.format, &case.bytes) {
        Ok(_) => return Some("accepted".to_string()),
        Err(err) => err,
    };
    if !(case.expect)(&err) {
        return Some(format!("unexpected error {err:?}"));
    }
    let message = err.to_string();
    case.says
        .iter()
        .find(|needle| !message.contains(*needle))
        .map(|needle| format!("{message:?} should mention {needle:?}"))
}

/// Runs every row and fails once, listing every row that failed.
fn run(cases: &[Case]) {
    let failures: Vec<String> = cases
        .iter()
        .filter_map(|c| check(c).map(|why| format!("{} ({:?}): {why}", c.name, c.format)))
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} malformed inputs were not refused as expected:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

fn line(n: usize) -> Location {
    Location::Line(n)
}

fn cases() -> Vec<Case> {
    use Format::{Obj, Off, Ply};
    use LoadError as E;
    let header = PLY_ASCII_HEADER;
    let good_binary = binary_ply(3, 1, &TRIANGLE, &[&[0, 1, 2]]);
    let body_start = good_binary.len() - 3 * 12 - (1 + 3 * 4);
    let mut list_past_end = binary_ply(3, 1, &TRIANGLE, &[]);
    list_past_end.push(255);
    list_past_end.extend_from_slice(&0i32.to_le_bytes());
    // A sawtooth polygon of 10,003 corners: non-convex, past the ear-clipping limit.
    let mut sawtooth = String::new();
    let teeth = 10_000;
    let mut corners = vec![[0, 0], [teeth, 0]];
    corners.extend((0..=teeth).rev().map(|k| [k, 1 + k % 2]));
    for [x, y] in &corners {
        sawtooth += &format!("v {x} {y} 0\n");
    }
    sawtooth += "f";
    for i in 1..=corners.len() {
        sawtooth += &format!(" {i}");
    }
    sawtooth += "\n";
    vec![
        // ---- OBJ
        case("index zero", Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
            |e| matches!(e, E::ZeroIndex { at, .. } if *at == line(4)), &["line 4"]),
        case("index zero, last corner", Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n",
            |e| matches!(e, E::ZeroIndex { at, .. } if *at == line(4)), &[]),
        case("negative index out of range", Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
            |e| matches!(e, E::IndexOutOfRange { at, index: -4, vertices: 3, .. } if *at == line(4)),
            &["-4"]),
        case("negative index counts the vertices so far", Obj, "v 0 0 0\nv 1 0 0\nf 1 2 -3\nv 0 1 0\n",
            |e| matches!(e, E::IndexOutOfRange { at, index: -3, vertices: 2, .. } if *at == line(3)),
            &[]),
        case("positive index out of range", Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 99\n",
            |e| matches!(e, E::IndexOutOfRange { at, index: 99, .. } if *at == line(5)),
            &["line 5"]),
        case("positive index past every vertex of the file", Obj,
            "v 0 0 0\nv 1 0 0\nf 1 2 4\nv 0 1 0\nf 1 2 3\n",
            |e| matches!(e, E::IndexOutOfRange { at, index: 4, vertices: 3, .. } if *at == line(3)),
            &[]),
        case("NaN coordinate", Obj, "v 0 0 0\nv NaN 0 0\n",
            |e| matches!(e, E::NonFinite { at, .. } if *at == line(2)), &[]),
        case("infinite coordinate", Obj, "v 0 0 0\nv 1 inf 0\n",
            |e| matches!(e, E::NonFinite { at, .. } if *at == line(2)), &[]),
        // Finite as text, infinite as f32: as unusable as inf.
        case("coordinate overflowing f32", Obj, "v 0 0 1e39\n",
            |e| matches!(e, E::NonFinite { at, .. } if *at == line(1)), &[]),
        case("face with two vertices", Obj, "v 0 0 0\nv 1 0 0\nf 1 2\n",
            |e| matches!(e, E::FaceTooSmall { at, corners: 2, .. } if *at == line(3)), &[]),
        case("unparsable number", Obj, "v 0 0 0.0.0\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(1)), &["0.0.0"]),
        case("word for a number", Obj, "v 0 0 zero\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(1)), &[]),
        case("two coordinates", Obj, "v 0 0\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(1)), &[]),
        case("unparsable index", Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 three\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(4)), &[]),
        case("empty", Obj, "",
            |e| matches!(e, E::InvalidMesh { source: MeshError::Empty { .. }, .. }), &[]),
        case("garbage", Obj, &b"\x00\x01\x02\xff\xfe garbage \x7f\n\x89PNG\r\n"[..],
            |e| matches!(e, E::InvalidMesh { source: MeshError::Empty { .. }, .. }), &[]),
        case("Latin-1 in a number", Obj, &b"v 0 0 0\nv 1 \xe90 0\n"[..],
            |e| matches!(e, E::Syntax { at, .. } if *at == line(2)), &[]),
        case("non-convex polygon past the ear-clipping limit", Obj, sawtooth,
            |e| matches!(e, E::PolygonTooLarge { at, corners: 10_003, limit: 10_000, .. } if *at == line(10_004)),
            &["line 10004", "non-convex polygon of 10003 corners", "10000"]),
        // ---- OFF
        case("truncated vertices", Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n",
            |e| matches!(e, E::Truncated { .. }), &["vertex 2 of the 3"]),
        case("truncated faces", Off, "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            |_| true, &["face 1 of the 2"]),
        // Reserving by these counts would ask for ~100 GB before noticing.
        case("huge counts, tiny body", Off, "OFF\n9000000000 9000000000 0\n0 0 0\n",
            |e| matches!(e, E::Truncated { .. }), &[]),
        case("counts past u32, tiny body", Off, "OFF\n4000000000 4000000000 0\n0 0 0\n",
            |e| matches!(e, E::Truncated { .. }), &["vertex 1 of the 4000000000"]),
        case("bad keyword", Off, "OFFF\n3 1 0\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(1)), &[]),
        case("word for a count", Off, "OFF\n3 one 0\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(2)), &[]),
        case("binary OFF", Off, "OFF BINARY\n3 1 0\n",
            |e| matches!(e, E::Unsupported { .. }), &[]),
        case("4OFF", Off, "4OFF\n3 1 0\n", |e| matches!(e, E::Unsupported { .. }), &[]),
        case("index out of range", Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
            |e| matches!(e, E::IndexOutOfRange { at, index: 7, vertices: 3, .. } if *at == line(6)),
            &[]),
        case("index one past the end", Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
            |e| matches!(e, E::IndexOutOfRange { at, index: 3, vertices: 3, .. } if *at == line(6)),
            &[]),
        case("negative index", Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
            |e| matches!(e, E::IndexOutOfRange { index: -1, .. }), &[]),
        case("infinite coordinate", Off, "OFF\n3 1 0\n0 0 0\n1 0 -inf\n0 1 0\n3 0 1 2\n",
            |e| matches!(e, E::NonFinite { at, .. } if *at == line(4)), &[]),
        case("NaN coordinate", Off, "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
            |e| matches!(e, E::NonFinite { at, .. } if *at == line(4)), &[]),
        case("empty", Off, "", |e| matches!(e, E::Syntax { .. }), &[]),
        case("only a comment", Off, "# only a comment\n\n", |e| matches!(e, E::Syntax { .. }), &[]),
        case("face with two vertices", Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
            |e| matches!(e, E::FaceTooSmall { at, corners: 2, .. } if *at == line(6)), &[]),
        case("face shorter than its count", Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(6)), &[]),
        // ---- PLY, ASCII
        case("ASCII truncated face", Ply, format!("{header}0 0 0\n1 0 0\n0 1 0\n3 0 1\n"),
            |e| matches!(e, E::Truncated { .. }), &["face 0 of the 1"]),
        case("ASCII NaN", Ply, format!("{header}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
            |e| matches!(e, E::NonFinite { .. }), &["line 11 (vertex 1)"]),
        case("ASCII negative index", Ply, format!("{header}0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n"),
            |e| matches!(e, E::IndexOutOfRange { index: -2, .. }), &["face 0"]),
        case("ASCII index out of range names the record and line", Ply,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar uint vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 3\n",
            |e| matches!(e, E::IndexOutOfRange {
                at: Location::Record { element, index: 1, line: Some(14) }, index: 3, vertices: 3, ..
            } if element == "face"),
            &[]),
        case("missing face element", Ply,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(7)), &["element face"]),
        case("float vertex indices", Ply, header.replace("list uchar int", "list uchar float"),
            |e| matches!(e, E::Syntax { at, .. } if *at == line(8)), &[]),
        case("float list count", Ply, header.replace("list uchar int", "list float int"),
            |e| matches!(e, E::Syntax { at, .. } if *at == line(8)), &[]),
        case("indices as a scalar", Ply,
            header.replace("list uchar int vertex_indices", "int vertex_indices"),
            |e| matches!(e, E::Syntax { at, .. } if *at == line(8)), &[]),
        case("unknown type name", Ply, header.replace("property float y", "property float128 y"),
            |e| matches!(e, E::Syntax { at, .. } if *at == line(5)), &[]),
        case("bad magic", Ply, "PLY\nformat ascii 1.0\nend_header\n",
            |e| matches!(e, E::Syntax { at, .. } if *at == line(1)), &[]),
        case("empty", Ply, "", |e| matches!(e, E::Syntax { at, .. } if *at == line(1)), &[]),
        case("big endian", Ply, header.replace("ascii", "binary_big_endian"),
            |e| matches!(e, E::Unsupported { .. }), &["binary_little_endian"]),
        case("no end_header", Ply, "ply\nformat ascii 1.0\nelement vertex 3\n",
            |e| matches!(e, E::Truncated { .. }), &["end_header"]),
        // ---- PLY, binary little-endian
        case("binary truncated mid vertex", Ply, &good_binary[..body_start + 12 + 6],
            |e| matches!(e, E::Truncated { .. }), &["vertex 1 of the 3"]),
        case("binary huge counts, tiny body", Ply,
            binary_ply(4_000_000_000, 4_000_000_000, &TRIANGLE, &[]),
            |e| matches!(e, E::Truncated { .. }), &["vertex 3 of the 4000000000"]),
        // A face whose list count (255) runs past the end of the data.
        case("binary face list past the end", Ply, list_past_end,
            |e| matches!(e, E::Truncated { .. }), &["face 0 of the 1"]),
        case("binary index out of range names the record", Ply,
            binary_ply(3, 2, &TRIANGLE, &[&[0, 1, 2], &[0, 1, 3]]),
            |e| matches!(e, E::IndexOutOfRange {
                at: Location::Record { element, index: 1, line: None }, index: 3, vertices: 3, ..
            } if element == "face"),
            &["face 1"]),
        case("binary NaN", Ply,
            binary_ply(3, 1, &[[0.0; 3], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]], &[&[0, 1, 2]]),
            |e| matches!(e, E::NonFinite { .. }), &["vertex 1"]),
        case("binary face with two vertices", Ply, binary_ply(3, 1, &TRIANGLE, &[&[0, 1]]),
            |e| matches!(e, E::FaceTooSmall { corners: 2, .. }), &[]),
    ]
}

#[test]
fn malformed_meshes() {
    run(&cases());
}

/// The runner itself: a row whose input is accepted, whose error is another variant, or whose
/// message lacks a word fails, and every failing row is listed.
#[test]
fn the_table_runner_reports_every_failing_row() {
    let rows = [
        case(
            "accepted",
            Format::Off,
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            |_| true,
            &[],
        ),
        case(
            "wrong variant",
            Format::Off,
            "OFF\n3 1 0\n",
            |e| matches!(e, LoadError::NonFinite { .. }),
            &[],
        ),
        case(
            "missing word",
            Format::Off,
            "OFF\n3 1 0\n",
            |_| true,
            &["no such words"],
        ),
        case(
            "fine",
            Format::Off,
            "OFFF\n",
            |e| matches!(e, LoadError::Syntax { .. }),
            &[],
        ),
    ];
    let verdicts: Vec<bool> = rows.iter().map(|c| check(c).is_some()).collect();
    assert_eq!(verdicts, [true, true, true, false]);
    let failure = std::panic::catch_unwind(|| run(&rows)).expect_err("three rows fail");
    let message = failure
        .downcast_ref::<String>()
        .expect("assert! formats its message");
    assert!(
        message.contains("3 of 4")
            && ["accepted", "wrong variant", "missing word"]
                .iter()
                .all(|name| message.contains(name)),
        "{message}"
    );
}

/// Latin-1 in a comment or a group name is harmless (in a number it is an error, see the table).
#[test]
fn obj_latin1_outside_numbers_loads() {
    let ok = obj::parse(
        b"# caf\xe9\ng d\xe9cor\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        Path::new("x.obj"),
    );
    assert!(ok.is_ok(), "{ok:?}");
}

/// A UTF-8 byte-order mark (what Windows editors put first) is not part of the
/// first line: every format loads the same with and without it.
#[test]
fn byte_order_mark_is_ignored() {
    for (name, bytes) in valid_inputs() {
        let plain = parse_any(name, &bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        let marked = [&b"\xEF\xBB\xBF"[..], &bytes].concat();
        let with_mark =
            parse_any(name, &marked).unwrap_or_else(|e| panic!("{name} with a BOM: {e}"));
        assert_eq!(with_mark, plain, "{name} with a BOM");
    }
}

/// The valid files the table's cases break, and that the mutation tests start from, load.
#[test]
fn valid_inputs_load() {
    for (name, bytes) in valid_inputs() {
        let mesh = parse_any(name, &bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(mesh.validate().is_ok(), "{name}");
    }
}

// ---- dispatch --------------------------------------------------------------

#[test]
fn missing_file_and_unknown_extension() {
    let options = LoadOptions::default();
    let err = load_mesh(Path::new("/nonexistent/dir/mesh.off"), &options).unwrap_err();
    assert!(matches!(err, LoadError::Io { .. }), "{err}");
    assert!(
        err.to_string().contains("/nonexistent/dir/mesh.off"),
        "{err}"
    );
    let err = load_mesh(Path::new("mesh.stl"), &options).unwrap_err();
    assert!(matches!(err, LoadError::Unsupported { .. }), "{err}");
    assert!(err.to_string().contains("stl"), "{err}");
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
#[cfg(feature = "cli")]
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
        (
            "uv.obj",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\nvn 0 0 1\n\
              f 1/1/1 2/2/1 3/3/1\nf 1/5/1 3/-3/1 4/4/-1\n"
                .to_vec(),
        ),
        (
            "n.ply",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
              0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n0 1 0 0 0 1 0 1\n3 0 1 2\n"
                .to_vec(),
        ),
    ]
}

/// The attribute-vertex parse of an OBJ or PLY input (OFF has no attributes).
fn parse_attributed(name: &str, bytes: &[u8]) -> Option<Result<AttributedMesh, LoadError>> {
    let path = Path::new(name);
    match name.rsplit('.').next() {
        Some("obj") => Some(obj::parse_attributed(bytes, path)),
        Some("ply") => Some(ply::parse_attributed(bytes, path)),
        _ => None,
    }
}

/// What every accepted attributed mesh must be: its own position mesh valid, every
/// attribute vertex naming a position, one value per attribute vertex, and the same
/// triangles (per corner, the same positions) as the position mesh.
fn check_attributed(mesh: &AttributedMesh) -> Result<(), String> {
    mesh.positions.validate().map_err(|e| e.to_string())?;
    let n = mesh.position_of.len();
    if mesh
        .position_of
        .iter()
        .any(|&p| p as usize >= mesh.positions.vertex_count())
    {
        return Err("an attribute vertex names no position".into());
    }
    let a = &mesh.attributes;
    if a.normals.as_ref().is_some_and(|v| v.len() != n)
        || a.uvs.as_ref().is_some_and(|v| v.len() != n)
    {
        return Err("attribute count differs from the vertex count".into());
    }
    let corners = |t: &[u32; 3]| t.map(|v| mesh.position_of.get(v as usize).copied());
    let same = mesh.triangles.len() == mesh.positions.triangles.len()
        && mesh
            .triangles
            .iter()
            .zip(&mesh.positions.triangles)
            .all(|(a, b)| corners(a) == b.map(Some));
    if !same {
        return Err("the attribute triangles are not the position triangles".into());
    }
    mesh.mesh().validate().map_err(|e| e.to_string())
}

/// The attributed parses of the valid inputs succeed and are consistent.
#[test]
fn valid_inputs_load_with_attributes() {
    for (name, bytes) in valid_inputs() {
        if name == "a.obj" {
            // Its corners name `vt`/`vn` the file never states: only positions load.
            let err = parse_attributed(name, &bytes).unwrap().unwrap_err();
            assert!(err.to_string().contains("names no `vt` statement"), "{err}");
            continue;
        }
        if let Some(parsed) = parse_attributed(name, &bytes) {
            let mesh = parsed.unwrap_or_else(|e| panic!("{name}: {e}"));
            check_attributed(&mesh).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
    let uv = parse_attributed("uv.obj", &valid_inputs()[4].1)
        .unwrap()
        .unwrap();
    // Position 0 has corners (vt 1) and (vt 5), position 2 (vt 3, then vt -3: the same)
    // twice: one seam.
    assert_eq!(uv.position_of, vec![0, 0, 1, 2, 3]);
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
        which in any::<prop::sample::Index>(),
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..8),
        cut in any::<prop::sample::Index>(),
        truncate in any::<bool>(),
    ) {
        let inputs = valid_inputs();
        let (name, mut bytes) = inputs[which.index(inputs.len())].clone();
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
        if let Some(Ok(mesh)) = parse_attributed(name, &bytes) {
            if let Err(why) = check_attributed(&mesh) {
                prop_assert!(false, "{}", why);
            }
        }
    }
}

// The per-format files under tests/suite/bad_input/.
mod gltf;
mod gltf_attributes;
mod gltf_skin;
