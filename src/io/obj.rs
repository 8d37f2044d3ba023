//! Wavefront OBJ: the geometry subset, `v` positions and `f` polygons.
//!
//! Texture coordinates, normals, groups, smoothing groups, materials, lines
//! and points carry nothing a triangle mesh of positions needs, so their
//! statements (and any unknown statement) are skipped; only the vertex part
//! of each `v/vt/vn` face corner is used. Polygons are triangulated by
//! `io::polygon`: the fan when convex, ear clipping when not.

use super::polygon::Polygons;
use super::text::{self, coordinate, integer, tokens};
use super::{read, validated, LoadError, Location};
use crate::mesh::IndexedMesh;
use std::path::Path;

/// Reads and parses an OBJ file.
pub fn load(path: &Path) -> Result<IndexedMesh, LoadError> {
    parse(&read(path)?, path)
}

/// Parses OBJ bytes; `path` only names the file in errors.
pub fn parse(bytes: &[u8], path: &Path) -> Result<IndexedMesh, LoadError> {
    let bytes = text::strip_bom(bytes);
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut faces = Faces::default();
    // Positive indices may legally point at vertices defined further down
    // (some exporters write faces first), so they are range-checked once all
    // vertices are known; the largest one and its line are enough for that.
    let mut largest: Option<(u32, usize)> = None;
    // A statement ending in `\` continues on the next line; its pieces are
    // joined here and the statement reports the line it started on.
    let mut joined: Vec<u8> = Vec::new();
    let mut joined_from: Option<usize> = None;

    for (n, raw) in text::lines(bytes) {
        let line = text::strip_comment(raw);
        if let Some(head) = line.strip_suffix(b"\\") {
            joined.extend_from_slice(head);
            joined.push(b' ');
            joined_from.get_or_insert(n);
            continue;
        }
        let (line, n) = match joined_from.take() {
            Some(first) => {
                joined.extend_from_slice(line);
                (&joined[..], first)
            }
            None => (line, n),
        };
        statement(line, n, path, &mut positions, &mut faces, &mut largest)?;
        joined.clear();
    }
    // A `\` on the last line continues into nothing: parse what was joined.
    if let Some(first) = joined_from {
        statement(
            &joined,
            first,
            path,
            &mut positions,
            &mut faces,
            &mut largest,
        )?;
    }
    if let Some((index, line)) = largest {
        if index as usize >= positions.len() {
            return Err(LoadError::IndexOutOfRange {
                path: path.to_path_buf(),
                at: Location::Line(line),
                index: i64::from(index) + 1,
                vertices: positions.len(),
            });
        }
    }
    let Faces {
        mut triangles,
        polygons,
        ..
    } = faces;
    polygons.finish(&positions, &mut triangles, path, Location::Line)?;
    validated(IndexedMesh::new(positions, triangles), path)
}

/// The faces read so far, and the corner buffer reused for each.
#[derive(Default)]
struct Faces {
    triangles: Vec<[u32; 3]>,
    corners: Vec<u32>,
    polygons: Polygons,
}

/// One logical line: a `v` or `f` statement is parsed, anything else skipped.
fn statement(
    line: &[u8],
    n: usize,
    path: &Path,
    positions: &mut Vec<[f32; 3]>,
    faces: &mut Faces,
    largest: &mut Option<(u32, usize)>,
) -> Result<(), LoadError> {
    let at = Location::Line(n);
    let mut words = tokens(line);
    match words.next() {
        Some(b"v") => {
            // `v x y z [w]` or the common `v x y z r g b` colour extension:
            // only x y z matter here.
            let mut position = [0.0f32; 3];
            for (axis, slot) in position.iter_mut().enumerate() {
                let token = words.next().ok_or_else(|| LoadError::Syntax {
                    path: path.to_path_buf(),
                    at: at.clone(),
                    message: format!("`v` has {axis} coordinates, it needs x y z"),
                })?;
                *slot = coordinate(token, path, &at)?;
            }
            positions.push(position);
        }
        Some(b"f") => {
            let Faces {
                triangles,
                corners,
                polygons,
            } = faces;
            corners.clear();
            for corner in words {
                // `v`, `v/vt`, `v//vn`, `v/vt/vn`: the vertex is the first field.
                let field = corner.split(|&b| b == b'/').next().unwrap_or_default();
                let index = integer(field, "the vertex index", path, &at)?;
                corners.push(resolve(index, positions.len(), path, &at, n, largest)?);
            }
            if corners.len() < 3 {
                return Err(LoadError::FaceTooSmall {
                    path: path.to_path_buf(),
                    at,
                    corners: corners.len(),
                });
            }
            polygons.push(corners, triangles, n);
        }
        _ => {}
    }
    Ok(())
}

/// A 0-based vertex from an OBJ index: `i > 0` is 1-based, `i < 0` counts
/// back from the last vertex defined so far (so it is resolved now, while
/// "so far" is known), 0 is an error.
fn resolve(
    index: i64,
    defined: usize,
    path: &Path,
    at: &Location,
    line: usize,
    largest: &mut Option<(u32, usize)>,
) -> Result<u32, LoadError> {
    let out_of_range = || LoadError::IndexOutOfRange {
        path: path.to_path_buf(),
        at: at.clone(),
        index,
        vertices: defined,
    };
    if index == 0 {
        return Err(LoadError::ZeroIndex {
            path: path.to_path_buf(),
            at: at.clone(),
        });
    }
    if index > 0 {
        // u32::MAX is the strip restart index, so the largest usable vertex is MAX - 1.
        let vertex = u32::try_from(index - 1)
            .ok()
            .filter(|&v| v < u32::MAX)
            .ok_or_else(out_of_range)?;
        if largest.is_none_or(|(max, _)| vertex > max) {
            *largest = Some((vertex, line));
        }
        return Ok(vertex);
    }
    let back = usize::try_from(index.unsigned_abs()).map_err(|_| out_of_range())?;
    let vertex = defined.checked_sub(back).ok_or_else(out_of_range)?;
    u32::try_from(vertex).map_err(|_| out_of_range())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obj(text: &str) -> Result<IndexedMesh, LoadError> {
        parse(text.as_bytes(), Path::new("test.obj"))
    }

    #[test]
    fn corner_forms_and_polygons() {
        let mesh = obj("# quad and triangle\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0 0.5 0.5 0.5\nv 0 1 0\nvt 0 0\nvn 0 0 1\ng g1\ns 1\nusemtl m\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf 1//1 3//1 4//1\nf 2/1 3/1 1/1\nl 1 2\np 3\n")
            .unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.positions[2], [1.0, 1.0, 0.0]);
        assert_eq!(
            mesh.triangles,
            vec![[0, 1, 2], [0, 2, 3], [0, 2, 3], [1, 2, 0]]
        );
    }

    #[test]
    fn negative_indices_are_relative_to_vertices_so_far() {
        let mesh = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 1 1 0\nf -3 -1 -2\n").unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [1, 3, 2]]);
    }

    #[test]
    fn continuation_crlf_and_forward_reference() {
        let mesh = obj("f 1 2 \\\r\n 3\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\n").unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn bunny_loads() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/bunny.obj");
        let mesh = load(&path).unwrap();
        assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (1839, 3674));
    }
}
