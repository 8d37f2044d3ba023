//! Wavefront OBJ: `v` positions, `f` polygons, and the `vt` texture coordinates and `vn`
//! normals their corners name.
//!
//! Groups, smoothing groups, materials, lines and points carry nothing a triangle mesh
//! needs, so their statements (and any unknown statement) are skipped. Polygons are
//! triangulated by `io::polygon`: the fan when convex, ear clipping when not.
//!
//! [`parse`] returns one vertex per `v` (the position mesh every loader returns).
//! [`parse_attributed`] also returns the *attribute vertices*: a position is split wherever
//! its corners' `(vt, vn)` pairs differ (a UV seam or a hard edge), and each split vertex
//! carries its UV and normal. OBJ's UVs have `v` up; they are flipped to glTF's `v` down
//! (`v' = 1 − v`), the convention [`Attributes::uvs`] states. A `vt` or `vn` used by only
//! some corners is ignored (a corner without it has nothing to give its vertex).
//!
//! Vertex colours come from the common `v x y z r g b` extension (MeshLab, ZBrush,
//! three.js's OBJLoader): display values in `[0, 1]`, decoded from sRGB to the linear values
//! [`Attributes::colors`] holds, alpha 1. They are used when every `v` has them.

use super::attributed::{split_corners, srgb_to_linear, AttributedMesh};
use super::polygon::Polygons;
use super::text::{self, coordinate, integer, tokens};
use super::{read, validated, LoadError, Location};
use crate::mesh::IndexedMesh;
use crate::morph::Attributes;
use std::path::Path;

/// Reads and parses an OBJ file.
pub fn load(path: &Path) -> Result<IndexedMesh, LoadError> {
    parse(&read(path)?, path)
}

/// Reads and parses an OBJ file with its `vt`/`vn` attributes ([`parse_attributed`]).
pub fn load_attributed(path: &Path) -> Result<AttributedMesh, LoadError> {
    parse_attributed(&read(path)?, path)
}

/// Parses OBJ bytes; `path` only names the file in errors.
pub fn parse(bytes: &[u8], path: &Path) -> Result<IndexedMesh, LoadError> {
    Ok(ObjFile::parse(bytes, path)?.mesh)
}

/// Parses OBJ bytes into attribute vertices (see the module docs).
pub fn parse_attributed(bytes: &[u8], path: &Path) -> Result<AttributedMesh, LoadError> {
    ObjFile::parse(bytes, path)?.split(path)
}

/// What a file holds: the position mesh, the `vt` and `vn` values, and per face corner
/// which of them it names.
struct ObjFile {
    mesh: IndexedMesh,
    uvs: Vec<[f32; 2]>,
    normals: Vec<[f32; 3]>,
    /// The `r g b` of each `v` that has them, in file order: the file's colours when every
    /// `v` does (then there are as many as positions).
    colors: Vec<[f32; 3]>,
    faces: Faces,
    /// The first `vt`/`vn` index that names nothing: an error for [`parse_attributed`]
    /// only, since [`parse`] has never read them (and so keeps loading such files).
    bad_attribute: Option<LoadError>,
    largest: Largest,
}

/// The `(vt, vn)` a face corner names, 0-based.
#[derive(Clone, Copy)]
struct Corner {
    vertex: u32,
    uv: Option<u32>,
    normal: Option<u32>,
}

/// The largest forward index seen and its line, per kind: range-checked once the whole
/// file is read, since positive indices may point at statements further down.
#[derive(Default)]
struct Largest {
    vertex: Option<(u32, usize)>,
    uv: Option<(u32, usize)>,
    normal: Option<(u32, usize)>,
}

impl ObjFile {
    fn parse(bytes: &[u8], path: &Path) -> Result<ObjFile, LoadError> {
        let bytes = text::strip_bom(bytes);
        let mut file = ObjFile {
            mesh: IndexedMesh::default(),
            uvs: Vec::new(),
            normals: Vec::new(),
            colors: Vec::new(),
            faces: Faces::default(),
            bad_attribute: None,
            largest: Largest::default(),
        };
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
            file.statement(line, n, path)?;
            joined.clear();
        }
        // A `\` on the last line continues into nothing: parse what was joined.
        if let Some(first) = joined_from {
            file.statement(&joined, first, path)?;
        }
        file.check_forward_vertices(path)?;
        let positions = std::mem::take(&mut file.mesh.positions);
        let mut triangles = std::mem::take(&mut file.faces.triangles);
        file.faces
            .polygons
            .finish(&positions, &mut triangles, path, Location::Line)?;
        file.mesh = validated(IndexedMesh::new(positions, triangles), path)?;
        Ok(file)
    }

    /// Positive indices may legally point at vertices defined further down (some
    /// exporters write faces first), so they are range-checked once all vertices are
    /// known; the largest one and its line are enough for that.
    fn check_forward_vertices(&self, path: &Path) -> Result<(), LoadError> {
        if let Some((index, line)) = self.largest.vertex {
            if index as usize >= self.mesh.positions.len() {
                return Err(LoadError::IndexOutOfRange {
                    path: path.to_path_buf(),
                    at: Location::Line(line),
                    index: i64::from(index) + 1,
                    vertices: self.mesh.positions.len(),
                });
            }
        }
        Ok(())
    }

    /// [`ObjFile::check_forward_vertices`] for the `vt` and `vn` indices, and the first
    /// index that named nothing when it was read.
    fn check_attribute_indices(&mut self, path: &Path) -> Result<(), LoadError> {
        if let Some(error) = self.bad_attribute.take() {
            return Err(error);
        }
        for (largest, defined, kind) in [
            (self.largest.uv, self.uvs.len(), "vt"),
            (self.largest.normal, self.normals.len(), "vn"),
        ] {
            if let Some((index, line)) = largest {
                if index as usize >= defined {
                    return Err(attribute_out_of_range(
                        path,
                        &Location::Line(line),
                        kind,
                        i64::from(index) + 1,
                        defined,
                    ));
                }
            }
        }
        Ok(())
    }

    /// The attribute vertices: one per distinct (position, vt, vn) among the triangles'
    /// corners, with `vt` and `vn` used only when every corner names one.
    fn split(mut self, path: &Path) -> Result<AttributedMesh, LoadError> {
        self.check_attribute_indices(path)?;
        let corners = &self.faces.corners;
        let with_uvs = !corners.is_empty() && corners.iter().all(|c| c.uv.is_some());
        let with_normals = !corners.is_empty() && corners.iter().all(|c| c.normal.is_some());
        // Colours belong to positions, so they never split a vertex.
        let colors = (self.colors.len() == self.mesh.vertex_count()).then(|| {
            self.colors
                .iter()
                .map(|&[r, g, b]| {
                    let [r, g, b] = [r, g, b].map(|c| srgb_to_linear(c.clamp(0.0, 1.0)));
                    [r, g, b, 1.0]
                })
                .collect::<Vec<_>>()
        });
        if !with_uvs && !with_normals {
            let attributes = Attributes {
                colors,
                ..Attributes::default()
            };
            return Ok(AttributedMesh::unsplit(self.mesh, attributes));
        }
        let mut keyed = Vec::with_capacity(3 * self.mesh.triangles.len());
        for (t, triangle) in self.mesh.triangles.iter().enumerate() {
            // Triangulation keeps each polygon's triangles in its slot and uses only its
            // corners, so each triangle corner is a corner of its face.
            let face = self.faces.triangle_face[t] as usize;
            let start = self.faces.face_start[face] as usize;
            let end = self
                .faces
                .face_start
                .get(face + 1)
                .map_or(corners.len(), |&e| e as usize);
            for &v in triangle {
                let corner = corners[start..end].iter().find(|c| c.vertex == v);
                let key = corner.map_or((None, None), |c| {
                    (c.uv.filter(|_| with_uvs), c.normal.filter(|_| with_normals))
                });
                keyed.push((v, key));
            }
        }
        let (vertices, triangles) = split_corners(&keyed);
        let uvs = with_uvs.then(|| {
            vertices
                .iter()
                .map(|&(_, (uv, _))| {
                    let [u, v] = uv.map_or([0.0; 2], |i| self.uvs[i as usize]);
                    [u, 1.0 - v]
                })
                .collect()
        });
        let normals = with_normals.then(|| {
            vertices
                .iter()
                .map(|&(_, (_, n))| n.map_or([0.0; 3], |i| self.normals[i as usize]))
                .collect()
        });
        let colors =
            colors.map(|colors| vertices.iter().map(|&(p, _)| colors[p as usize]).collect());
        Ok(AttributedMesh {
            positions: self.mesh,
            position_of: vertices.iter().map(|&(p, _)| p).collect(),
            triangles,
            attributes: Attributes {
                normals,
                uvs,
                colors,
                ..Attributes::default()
            },
        })
    }
}

/// The faces read so far, and the corner buffer reused for each.
#[derive(Default)]
struct Faces {
    triangles: Vec<[u32; 3]>,
    polygons: Polygons,
    /// Every face's corners, in file order.
    corners: Vec<Corner>,
    /// Per face, the index of its first corner in `corners`.
    face_start: Vec<u32>,
    /// Per triangle, its face.
    triangle_face: Vec<u32>,
    /// The current face's vertices, for the triangulation.
    vertices: Vec<u32>,
}

impl ObjFile {
    /// One logical line: a `v`, `vt`, `vn` or `f` statement is parsed, anything else
    /// skipped.
    fn statement(&mut self, line: &[u8], n: usize, path: &Path) -> Result<(), LoadError> {
        let at = Location::Line(n);
        let mut words = tokens(line);
        let keyword = words.next();
        // `v x y z [w]` (or the common `v x y z r g b` colour extension), `vn x y z`,
        // `vt u [v [w]]`: the leading coordinates are read, `v` of `vt` defaulting to 0.
        let mut read = |needed: usize, out: &mut [f32]| -> Result<(), LoadError> {
            let keyword = String::from_utf8_lossy(keyword.unwrap_or_default()).into_owned();
            for (axis, slot) in out.iter_mut().enumerate() {
                match words.next() {
                    Some(token) => *slot = coordinate(token, path, &at)?,
                    None if axis >= needed => break,
                    None => {
                        return Err(LoadError::Syntax {
                            path: path.to_path_buf(),
                            at: at.clone(),
                            message: format!(
                                "`{keyword}` has {axis} coordinates, it needs {needed}"
                            ),
                        })
                    }
                }
            }
            Ok(())
        };
        match keyword {
            Some(b"v") => {
                // `x y z`, then `w` or the colour extension's `r g b`: exactly six numbers
                // are a position and a colour.
                let colored = tokens(line).count() == 7;
                let mut values = [0.0f32; 6];
                read(3, &mut values[..if colored { 6 } else { 3 }])?;
                let [x, y, z, r, g, b] = values;
                if colored {
                    self.colors.push([r, g, b]);
                }
                self.mesh.positions.push([x, y, z]);
            }
            Some(b"vt") => {
                let mut uv = [0.0f32; 2];
                read(1, &mut uv)?;
                self.uvs.push(uv);
            }
            Some(b"vn") => {
                let mut normal = [0.0f32; 3];
                read(3, &mut normal)?;
                self.normals.push(normal);
            }
            Some(b"f") => self.face(words, n, path)?,
            _ => {}
        }
        Ok(())
    }

    /// An `f` statement: corners `v`, `v/vt`, `v//vn` or `v/vt/vn`.
    fn face<'a>(
        &mut self,
        words: impl Iterator<Item = &'a [u8]>,
        n: usize,
        path: &Path,
    ) -> Result<(), LoadError> {
        let at = Location::Line(n);
        let first_corner = self.faces.corners.len();
        self.faces.vertices.clear();
        for corner in words {
            let mut fields = corner.split(|&b| b == b'/');
            let field = fields.next().unwrap_or_default();
            let index = integer(field, "the vertex index", path, &at)?;
            let defined = self.mesh.positions.len();
            let vertex = resolve(index, defined, path, &at, n, &mut self.largest.vertex)?;
            let mut attribute = |kind: &'static str| -> Option<u32> {
                let field = fields.next().filter(|f| !f.is_empty())?;
                let (defined, largest) = match kind {
                    "vt" => (self.uvs.len(), &mut self.largest.uv),
                    _ => (self.normals.len(), &mut self.largest.normal),
                };
                let resolved =
                    integer(field, &format!("the `{kind}` index"), path, &at).and_then(|index| {
                        resolve(index, defined, path, &at, n, largest)
                            .map_err(|_| attribute_out_of_range(path, &at, kind, index, defined))
                    });
                match resolved {
                    Ok(i) => Some(i),
                    Err(error) => {
                        self.bad_attribute.get_or_insert(error);
                        None
                    }
                }
            };
            let uv = attribute("vt");
            let normal = attribute("vn");
            self.faces.vertices.push(vertex);
            self.faces.corners.push(Corner { vertex, uv, normal });
        }
        let faces = &mut self.faces;
        if faces.vertices.len() < 3 {
            return Err(LoadError::FaceTooSmall {
                path: path.to_path_buf(),
                at,
                corners: faces.vertices.len(),
            });
        }
        let face = faces.face_start.len() as u32;
        faces.face_start.push(first_corner as u32);
        faces
            .triangle_face
            .extend(std::iter::repeat_n(face, faces.vertices.len() - 2));
        faces
            .polygons
            .push(&faces.vertices, &mut faces.triangles, n);
        Ok(())
    }
}

/// A `vt` or `vn` index that names nothing (0, or beyond the statements of its kind).
fn attribute_out_of_range(
    path: &Path,
    at: &Location,
    kind: &str,
    index: i64,
    defined: usize,
) -> LoadError {
    LoadError::Syntax {
        path: path.to_path_buf(),
        at: at.clone(),
        message: format!(
            "`{kind}` index {index} names no `{kind}` statement (the file has {defined}; indices start at 1, negative ones count back)"
        ),
    }
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
    use crate::io::morph_from_pair;
    use crate::morph::MorphError;

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
    fn vertex_colours_follow_their_positions_across_uv_seams() {
        // Vertex 1 is split by two UVs; both copies keep its colour.
        let text = "v 0 0 0 1 0 0\nv 1 0 0 0 0.5 1\nv 0 1 0 0 0 0\nv 1 1 0 1 1 1\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nf 2/1 4/2 3/3\n";
        let mesh = parse_attributed(text.as_bytes(), Path::new("c.obj")).unwrap();
        let colors = mesh
            .attributes
            .colors
            .as_ref()
            .expect("every `v` has r g b");
        assert_eq!(colors.len(), mesh.position_of.len());
        assert_eq!(mesh.position_of.len(), 5, "vertex 1 split at the seam");
        for (vertex, &p) in mesh.position_of.iter().enumerate() {
            let expected = match p {
                0 => [1.0, 0.0, 0.0, 1.0],
                // sRGB 0.5 is linear 0.2140...
                1 => [0.0, srgb_to_linear(0.5), 1.0, 1.0],
                2 => [0.0, 0.0, 0.0, 1.0],
                _ => [1.0; 4],
            };
            assert_eq!(colors[vertex], expected, "vertex {vertex} at position {p}");
        }
        assert!((srgb_to_linear(0.5) - 0.21404).abs() < 1e-4);
        // Without UVs or normals the colours still come through, one per position.
        let plain = parse_attributed(
            b"v 0 0 0 1 0 0\nv 1 0 0 1 0 0\nv 0 1 0 1 0 0\nf 1 2 3\n",
            Path::new("p.obj"),
        )
        .unwrap();
        assert_eq!(plain.attributes.colors.map(|c| c.len()), Some(3));
        // `w` (four numbers) is not a colour, and colours on only some `v` are not used.
        for text in [
            "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n",
            "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        ] {
            let mesh = parse_attributed(text.as_bytes(), Path::new("w.obj")).unwrap();
            assert!(mesh.attributes.colors.is_none(), "{text}");
        }
    }

    #[test]
    fn bunny_loads() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/bunny.obj");
        let mesh = load(&path).unwrap();
        assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (1839, 3674));
    }

    /// Two unit quads side by side sharing the edge x = 1. The UVs agree at (1, 1) but not
    /// at (1, 0): a seam there, so 6 positions make 7 attribute vertices.
    fn quads(z: f32, normal: &str) -> AttributedMesh {
        let text = format!(
            "v 0 0 {z}\nv 1 0 {z}\nv 1 1 {z}\nv 0 1 {z}\nv 2 0 {z}\nv 2 1 {z}\n\
             vt 0 0\nvt 0.5 0\nvt 0.5 1\nvt 0 1\nvt 0.75 0\nvt 1 0\nvt 1 1\nvn {normal}\n\
             f 1/1/1 2/2/1 3/3/1 4/4/1\nf 2/5/1 5/6/1 6/7/1 3/3/1\n"
        );
        parse_attributed(text.as_bytes(), Path::new("quads.obj")).unwrap()
    }

    #[test]
    fn obj_corners_split_at_the_seam_only() {
        let mesh = quads(0.0, "0 0 1");
        assert_eq!(mesh.positions.vertex_count(), 6);
        // Position 1 has two (vt, vn) pairs; every other position one. Vertices are
        // numbered by position, then by first appearance.
        assert_eq!(mesh.position_of, vec![0, 1, 1, 2, 3, 4, 5]);
        assert_eq!(
            mesh.triangles,
            vec![[0, 1, 3], [0, 3, 4], [2, 5, 6], [2, 6, 3]]
        );
        // v flipped to glTF's convention: (0.5, 0) -> (0.5, 1), (0.5, 1) -> (0.5, 0).
        let uvs = mesh.attributes.uvs.as_ref().unwrap();
        assert_eq!(uvs[1], [0.5, 1.0]);
        assert_eq!(uvs[2], [0.75, 1.0]);
        assert_eq!(uvs[3], [0.5, 0.0]);
        assert_eq!(
            mesh.attributes.normals.as_deref(),
            Some(&[[0.0, 0.0, 1.0]; 7][..])
        );
        let morph = mesh.to_static_morph().unwrap();
        let topology = morph.topology();
        assert_eq!((topology.topology_count, topology.seam_vertices()), (6, 1));
        // The split mesh draws the same triangles at the same places.
        let split = mesh.mesh();
        for (a, b) in split.triangles.iter().zip(&mesh.positions.triangles) {
            assert_eq!(
                a.map(|v| split.positions[v as usize]),
                b.map(|v| mesh.positions.positions[v as usize])
            );
        }
    }

    #[test]
    fn obj_attributes_some_corners_lack_are_dropped() {
        // The second face's corners have no `vt`: only the normals are kept, and they do
        // not differ, so nothing is split.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n\
                    f 1/1/1 2/2/1 3/3/1\nf 1//1 3//1 4//1\n";
        let mesh = parse_attributed(text.as_bytes(), Path::new("mixed.obj")).unwrap();
        assert!(mesh.attributes.uvs.is_none());
        assert_eq!(mesh.attributes.normals.as_ref().map(Vec::len), Some(4));
        assert_eq!(mesh.position_of, vec![0, 1, 2, 3]);
        // Without any `vt`/`vn`, the file's vertices are kept as they are.
        let plain = parse_attributed(
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 9 9 9\nf 1 2 3\n",
            Path::new("p.obj"),
        )
        .unwrap();
        assert_eq!(plain.position_of, vec![0, 1, 2, 3]);
        assert!(!plain.attributes.has_vertex_attributes());
    }

    #[test]
    fn obj_attribute_indices_are_checked_when_read() {
        let text = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n";
        // The position loader never used `vt`, and still loads the file.
        assert!(crate::io::obj::parse(text, Path::new("bad.obj")).is_ok());
        let err = parse_attributed(text, Path::new("bad.obj")).unwrap_err();
        assert!(matches!(err, LoadError::Syntax { .. }), "{err:?}");
        assert!(
            err.to_string()
                .contains("line 5: `vt` index 2 names no `vt` statement (the file has 1"),
            "{err}"
        );
        let forward = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//3 2//1 3//1\nvn 0 0 1\n";
        let err = parse_attributed(forward, Path::new("fwd.obj")).unwrap_err();
        assert!(err.to_string().contains("`vn` index 3"), "{err}");
        let garbage = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/x 2/1 3/1\n";
        let err = parse_attributed(garbage, Path::new("x.obj")).unwrap_err();
        assert!(err.to_string().contains("\"x\" is not an integer"), "{err}");
    }

    #[test]
    fn a_pair_morphs_the_first_meshes_attribute_vertices() {
        let a = quads(0.0, "0 0 1");
        let b = quads(2.0, "0 1 0");
        let morph = morph_from_pair(&a, &b).unwrap();
        assert_eq!(morph.vertex_count(), 7);
        assert_eq!(morph.attributes(), &a.attributes);
        assert!(morph.v1().iter().all(|p| p[2] == 2.0));
        assert_eq!(
            morph.targets()[0].normal_deltas.as_deref(),
            Some(&[[0.0, 1.0, -1.0]; 7][..])
        );
        // Without normals on one side there are no normal deltas to give.
        let mut bare = b.clone();
        bare.attributes.normals = None;
        let morph = morph_from_pair(&a, &bare).unwrap();
        assert!(morph.targets()[0].normal_deltas.is_none());
        // Different connectivity is reported as Morph::from_meshes reports it.
        let mut other = b;
        other.positions.triangles.swap(0, 1);
        assert!(matches!(
            morph_from_pair(&a, &other),
            Err(MorphError::TriangleMismatch { index: 0, .. })
        ));
    }
}
