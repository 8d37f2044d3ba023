//! OFF (Object File Format, as written by Geomview, CGAL, the Princeton
//! Shape Benchmark): a header `[ST][C][N]OFF`, the counts `V F [E]`, `V`
//! vertex records, then `F` face records `n i0 .. i(n-1) [colour]`.
//!
//! Records are read one per line, not as a free token stream: the extra
//! per-vertex values (colours with 3 or 4 components, normals, texture
//! coordinates) and per-face colours vary in number between writers, and one
//! record per line is what every writer does, so the line is the only
//! reliable record boundary. Only the first three vertex values and the `n`
//! face indices are used; the rest of a line is ignored.

use super::polygon::Polygons;
use super::text::{self, capacity, coordinate, count, integer, tokens};
use super::{read, validated, LoadError, Location};
use crate::mesh::IndexedMesh;
use std::path::Path;

/// Reads and parses an OFF file.
pub fn load(path: &Path) -> Result<IndexedMesh, LoadError> {
    parse(&read(path)?, path)
}

/// Parses OFF bytes; `path` only names the file in errors.
pub fn parse(bytes: &[u8], path: &Path) -> Result<IndexedMesh, LoadError> {
    let bytes = text::strip_bom(bytes);
    let syntax = |line: usize, message: String| LoadError::Syntax {
        path: path.to_path_buf(),
        at: Location::Line(line),
        message,
    };
    // Non-blank lines with comments removed: OFF allows `#` comments and
    // blank lines anywhere, even between records.
    let mut records = text::lines(bytes)
        .map(|(n, line)| (n, text::strip_comment(line)))
        .filter(|(_, line)| tokens(line).next().is_some());

    let Some((header_line, header)) = records.next() else {
        return Err(syntax(
            1,
            "the file has no OFF header: it is empty or only comments".into(),
        ));
    };
    let mut header_tokens = tokens(header).peekable();
    // The keyword is optional in the Princeton spec: a first line of numbers is the counts.
    let first_is_count = header_tokens
        .peek()
        .is_some_and(|t| t.iter().all(u8::is_ascii_digit));
    if !first_is_count {
        let keyword = header_tokens.next().unwrap_or_default();
        check_keyword(keyword, path, header_line)?;
        if header_tokens.peek() == Some(&&b"BINARY"[..]) {
            return Err(LoadError::Unsupported {
                path: path.to_path_buf(),
                what: "binary OFF".into(),
                hint: "convert it to ASCII OFF, OBJ or PLY".into(),
            });
        }
    }
    // The counts either follow the keyword on its line or fill the next line.
    let (counts_line, counts): (usize, Vec<&[u8]>) = if header_tokens.peek().is_some() {
        (header_line, header_tokens.collect())
    } else {
        match records.next() {
            Some((n, line)) => (n, tokens(line).collect()),
            None => {
                return Err(LoadError::Truncated {
                    path: path.to_path_buf(),
                    expected: "the vertex and face counts after the OFF keyword".into(),
                })
            }
        }
    };
    let at = Location::Line(counts_line);
    let (vertex_count, face_count) = match counts.as_slice() {
        [v, f] | [v, f, _] => (
            count(v, "the vertex count", path, &at)?,
            count(f, "the face count", path, &at)?,
        ),
        _ => {
            return Err(syntax(
                counts_line,
                format!(
                    "expected the counts `vertices faces [edges]`, found {} values",
                    counts.len()
                ),
            ))
        }
    };

    // "0 0 0\n" is the shortest vertex record and "3 0 0 0\n" the shortest face.
    let mut positions = Vec::with_capacity(capacity(vertex_count, bytes.len(), 6));
    for i in 0..vertex_count {
        let Some((n, line)) = records.next() else {
            return Err(LoadError::Truncated {
                path: path.to_path_buf(),
                expected: format!(
                    "vertex {i} of the {vertex_count} announced on line {counts_line}"
                ),
            });
        };
        let at = Location::Line(n);
        let mut values = tokens(line);
        let mut position = [0.0f32; 3];
        for (axis, slot) in position.iter_mut().enumerate() {
            let token = values.next().ok_or_else(|| {
                syntax(
                    n,
                    format!("vertex {i} has {axis} coordinates, it needs x y z"),
                )
            })?;
            *slot = coordinate(token, path, &at)?;
        }
        positions.push(position);
    }

    let mut triangles = Vec::with_capacity(capacity(face_count, bytes.len(), 8));
    let mut corners: Vec<u32> = Vec::new();
    let mut polygons = Polygons::default();
    for i in 0..face_count {
        let Some((n, line)) = records.next() else {
            return Err(LoadError::Truncated {
                path: path.to_path_buf(),
                expected: format!("face {i} of the {face_count} announced on line {counts_line}"),
            });
        };
        let at = Location::Line(n);
        let mut values = tokens(line);
        let size_token = values.next().unwrap_or_default();
        let size = count(size_token, "the face size", path, &at)?;
        if size < 3 {
            return Err(LoadError::FaceTooSmall {
                path: path.to_path_buf(),
                at,
                corners: size,
            });
        }
        // Filled from the tokens actually present, never reserved by `size`,
        // so a face claiming a billion corners costs nothing.
        corners.clear();
        for token in values.by_ref().take(size) {
            let index = integer(token, "the vertex index", path, &at)?;
            let vertex = u32::try_from(index)
                .ok()
                .filter(|&v| (v as usize) < positions.len())
                .ok_or_else(|| LoadError::IndexOutOfRange {
                    path: path.to_path_buf(),
                    at: at.clone(),
                    index,
                    vertices: positions.len(),
                })?;
            corners.push(vertex);
        }
        if corners.len() < size {
            return Err(syntax(
                n,
                format!(
                    "face {i} announces {size} vertices but lists {}",
                    corners.len()
                ),
            ));
        }
        polygons.push(&corners, &mut triangles, n);
    }
    polygons.finish(&positions, &mut triangles, path, Location::Line)?;
    validated(IndexedMesh::new(positions, triangles), path)
}

/// Accepts `[ST][C][N]OFF`; rejects the 4D and n-dimensional variants, whose
/// vertex records have a different number of coordinates.
fn check_keyword(keyword: &[u8], path: &Path, line: usize) -> Result<(), LoadError> {
    let mut rest = keyword;
    for prefix in [&b"ST"[..], b"C", b"N"] {
        rest = rest.strip_prefix(prefix).unwrap_or(rest);
    }
    if rest == b"OFF" {
        return Ok(());
    }
    if rest == b"4OFF" || rest == b"nOFF" || rest == b"4nOFF" {
        return Err(LoadError::Unsupported {
            path: path.to_path_buf(),
            what: format!("{:?} (4D or n-dimensional OFF)", text::show(keyword)),
            hint: "only 3D OFF meshes can be loaded".into(),
        });
    }
    Err(LoadError::Syntax {
        path: path.to_path_buf(),
        at: Location::Line(line),
        message: format!(
            "expected the OFF keyword (OFF, COFF, NOFF, CNOFF, STOFF...), found {:?}",
            text::show(keyword)
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn off(text: &str) -> Result<IndexedMesh, LoadError> {
        parse(text.as_bytes(), Path::new("test.off"))
    }

    #[test]
    fn quad_and_triangle_with_comments() {
        let mesh = off("OFF\n# a comment\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0 # trailing\n\n2 2 2\n4 0 1 2 3\n3 1 4 2\n")
            .unwrap();
        assert_eq!(mesh.positions.len(), 5);
        assert_eq!(mesh.positions[4], [2.0, 2.0, 2.0]);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [1, 4, 2]]);
    }

    #[test]
    fn counts_on_keyword_line_and_crlf() {
        let mesh = off("OFF 3 1 0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n").unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn coff_noff_extra_values_ignored() {
        // COFF: RGBA per vertex, and a face colour after the indices.
        let coff = off("COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2 1.0 0.5 0.25\n").unwrap();
        assert_eq!(coff.positions[1], [1.0, 0.0, 0.0]);
        assert_eq!(coff.triangles, vec![[0, 1, 2]]);
        let noff = off("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 2 1 0\n").unwrap();
        assert_eq!(noff.triangles, vec![[2, 1, 0]]);
        assert!(off("STCNOFF\n3 1\n0 0 0 0 0 1 1 1 1 0.5 0.5\n1 0 0 0 0 1 1 1 1 0.5 0.5\n0 1 0 0 0 1 1 1 1 0.5 0.5\n3 0 1 2\n").is_ok());
    }

    #[test]
    fn keyword_is_optional() {
        assert!(off("3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").is_ok());
    }

    #[test]
    fn real_assets_load() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
        for (name, v, t) in [
            ("cow.off", 2904, 5804),
            ("man.off", 17_495, 34_986),
            ("camel.off", 9_770, 19_536),
            ("bull.off", 6_200, 12_396),
        ] {
            let mesh = load(&dir.join(name)).unwrap();
            assert_eq!(
                (mesh.vertex_count(), mesh.triangle_count()),
                (v, t),
                "{name}"
            );
        }
    }
}
