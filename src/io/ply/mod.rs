//! PLY (Stanford polygon format), ASCII and binary little-endian.
//!
//! The header declares elements, each a count and a record layout of scalar
//! and list properties. Only `vertex` (its `x y z`, any scalar type, and where present
//! its normal `nx ny nz`, texture coordinates `u v`, `s t`, `texture_u texture_v` or
//! `texture_s texture_t`, and colour `red green blue [alpha]`) and `face` (its
//! `vertex_indices` / `vertex_index` list) are kept;
//! every other property and element (`edge`, `material`, ...) must still
//! be stepped over exactly, because in a binary file its bytes sit between the
//! ones we want. Big-endian files are rejected rather than byte-swapped: they
//! are rare, and a wrong guess would load garbage silently.
//!
//! PLY texture coordinates have `v` up (as OBJ's); they are flipped to glTF's `v` down
//! (`v' = 1 − v`), the convention [`crate::morph::Attributes::uvs`] states.
//!
//! PLY colours are display (sRGB-encoded) values, integers scaled by their type's maximum
//! (`uchar` by 255, as scanners and MeshLab write them) or floats in `[0, 1]`; they are
//! decoded to the linear values [`crate::morph::Attributes::colors`] holds, alpha as is.

use super::attributed::{srgb_to_linear, AttributedMesh};
use super::polygon::Polygons;
use super::text::{self, capacity, finite_f32};
use super::{read, validated, LoadError, Location};
use crate::mesh::IndexedMesh;
use crate::morph::Attributes;
use std::path::Path;

/// Reads and parses a PLY file.
pub fn load(path: &Path) -> Result<IndexedMesh, LoadError> {
    parse(&read(path)?, path)
}

/// Reads and parses a PLY file with its vertex normals and texture coordinates.
pub fn load_attributed(path: &Path) -> Result<AttributedMesh, LoadError> {
    parse_attributed(&read(path)?, path)
}

/// Parses PLY bytes; `path` only names the file in errors.
pub fn parse(bytes: &[u8], path: &Path) -> Result<IndexedMesh, LoadError> {
    Ok(parse_attributed(bytes, path)?.positions)
}

/// Parses PLY bytes with the vertices' normals, texture coordinates and colours where the header
/// declares them (one per vertex: PLY vertices are attribute vertices).
pub fn parse_attributed(bytes: &[u8], path: &Path) -> Result<AttributedMesh, LoadError> {
    let bytes = text::strip_bom(bytes);
    let header = Header::parse(bytes, path)?;
    let body = bytes.get(header.body_start..).unwrap_or_default();
    let mut reader = match header.encoding {
        Encoding::Ascii => Reader::Ascii(Tokens {
            bytes: body,
            pos: 0,
            line: header.lines + 1,
        }),
        Encoding::BinaryLittleEndian => Reader::Binary {
            bytes: body,
            pos: 0,
        },
    };
    let layout = header.mesh_layout(path)?;
    let vertex_count = header.elements[layout.vertex].count;

    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut normals: Vec<[f32; 3]> = Vec::new();
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    let mut colors: Vec<[f32; 4]> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut corners: Vec<u32> = Vec::new();
    let mut polygons = Polygons::default();
    for (e, element) in header.elements.iter().enumerate() {
        // Reserve only what the body can hold at the element's smallest
        // record size: the header count alone is not trusted.
        let min_bytes = element.min_record_bytes(header.encoding);
        if e == layout.vertex {
            positions.reserve(capacity(element.count, body.len(), min_bytes));
        } else if e == layout.face {
            triangles.reserve(capacity(element.count, body.len(), min_bytes));
        }
        // A record without properties occupies no bytes: a corrupt header
        // could declare billions of them and spin here for nothing.
        if element.properties.is_empty() {
            continue;
        }
        for index in 0..element.count {
            let record = Record {
                element,
                index,
                path,
            };
            if e == layout.vertex {
                let mut position = [0.0f32; 3];
                let mut normal = [0.0f32; 3];
                let mut uv = [0.0f32; 2];
                // Opaque unless an `alpha` property says otherwise.
                let mut color = [1.0f32; 4];
                for (p, property) in element.properties.iter().enumerate() {
                    let slot = match (layout.slot(p), property.kind) {
                        (Slot::Position(axis), Kind::Scalar(ty)) => (&mut position[axis], ty),
                        (Slot::Normal(axis), Kind::Scalar(ty)) => (&mut normal[axis], ty),
                        (Slot::Uv(axis), Kind::Scalar(ty)) => (&mut uv[axis], ty),
                        (Slot::Color(channel), Kind::Scalar(ty)) => {
                            let value = reader.coordinate(ty, &record)?;
                            color[channel] = channel_value(value, ty, channel);
                            continue;
                        }
                        _ => {
                            reader.skip(property.kind, &record)?;
                            continue;
                        }
                    };
                    *slot.0 = reader.coordinate(slot.1, &record)?;
                }
                positions.push(position);
                if layout.normal.is_some() {
                    normals.push(normal);
                }
                if layout.uv.is_some() {
                    uvs.push([uv[0], 1.0 - uv[1]]);
                }
                if layout.color.is_some() {
                    colors.push(color);
                }
            } else if e == layout.face {
                for (p, property) in element.properties.iter().enumerate() {
                    let (count_type, item_type) = match property.kind {
                        Kind::List(count, item) if p == layout.indices => (count, item),
                        kind => {
                            reader.skip(kind, &record)?;
                            continue;
                        }
                    };
                    let size = reader.list_size(count_type, &record)?;
                    if size < 3 {
                        return Err(LoadError::FaceTooSmall {
                            path: path.to_path_buf(),
                            at: reader.location(&record),
                            corners: size,
                        });
                    }
                    // Pushed as read, never reserved by `size`: a corrupt
                    // count meets the end of the data before any allocation.
                    corners.clear();
                    for _ in 0..size {
                        let value = reader.integer(item_type, &record)?;
                        let vertex = u32::try_from(value)
                            .ok()
                            .filter(|&v| (v as usize) < vertex_count)
                            .ok_or_else(|| LoadError::IndexOutOfRange {
                                path: path.to_path_buf(),
                                at: reader.location(&record),
                                index: value,
                                vertices: vertex_count,
                            })?;
                        corners.push(vertex);
                    }
                    polygons.push(&corners, &mut triangles, index);
                }
            } else {
                for property in &element.properties {
                    reader.skip(property.kind, &record)?;
                }
            }
        }
    }
    let faces = &header.elements[layout.face].name;
    polygons.finish(&positions, &mut triangles, path, |index| Location::Record {
        element: faces.clone(),
        index,
        line: None,
    })?;
    let mesh = validated(IndexedMesh::new(positions, triangles), path)?;
    let attributes = Attributes {
        normals: layout.normal.map(|_| normals),
        uvs: layout.uv.map(|_| uvs),
        colors: layout.color.map(|_| colors),
        ..Attributes::default()
    };
    Ok(AttributedMesh::unsplit(mesh, attributes))
}

/// A colour channel in `[0, 1]`, linear: integers scaled by their type's maximum, the RGB
/// channels decoded from sRGB (channel 3 is alpha, stored linear in every format).
fn channel_value(value: f32, ty: Scalar, channel: usize) -> f32 {
    let max = match ty {
        Scalar::I8 => f32::from(i8::MAX),
        Scalar::U8 => f32::from(u8::MAX),
        Scalar::I16 => f32::from(i16::MAX),
        Scalar::U16 => f32::from(u16::MAX),
        Scalar::I32 => i32::MAX as f32,
        Scalar::U32 => u32::MAX as f32,
        Scalar::F32 | Scalar::F64 => 1.0,
    };
    let encoded = (value / max).clamp(0.0, 1.0);
    if channel == 3 {
        encoded
    } else {
        srgb_to_linear(encoded)
    }
}

/// A PLY scalar type, with its aliases (`float` = `float32`, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &[u8]) -> Option<Scalar> {
        Some(match name {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    /// A list: the count's type, then the items' type.
    List(Scalar, Scalar),
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
    line: usize,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
    line: usize,
}

impl Element {
    /// The fewest bytes one record can take: every scalar at its size and
    /// every list empty in binary; a one-character token and a separator per
    /// value in ASCII.
    fn min_record_bytes(&self, encoding: Encoding) -> usize {
        self.properties
            .iter()
            .map(|p| match (encoding, p.kind) {
                (Encoding::Ascii, _) => 2,
                (Encoding::BinaryLittleEndian, Kind::Scalar(ty) | Kind::List(ty, _)) => ty.size(),
            })
            .sum()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    BinaryLittleEndian,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset of the first body byte, just after `end_header`'s newline.
    body_start: usize,
    /// Number of header lines, so ASCII body lines keep file line numbers.
    lines: usize,
}

/// Where the wanted data sits: element and property indices into the header.
struct MeshLayout {
    vertex: usize,
    /// The `x`, `y`, `z` property indices of the vertex element.
    xyz: [usize; 3],
    /// The `nx`, `ny`, `nz` scalar properties, when all three are declared.
    normal: Option<[usize; 3]>,
    /// The texture coordinate pair of scalar properties, when declared.
    uv: Option<[usize; 2]>,
    /// The `red`, `green`, `blue` scalar properties when all three are declared, and
    /// `alpha` when it is too.
    color: Option<([usize; 3], Option<usize>)>,
    face: usize,
    /// The vertex-index list property of the face element.
    indices: usize,
}

/// What a vertex property holds.
enum Slot {
    Position(usize),
    Normal(usize),
    Uv(usize),
    /// Red, green, blue, alpha: 0 to 3.
    Color(usize),
    Other,
}

impl MeshLayout {
    fn slot(&self, property: usize) -> Slot {
        let find = |axes: &[usize]| axes.iter().position(|&a| a == property);
        if let Some(axis) = find(&self.xyz) {
            return Slot::Position(axis);
        }
        if let Some(axis) = self.normal.as_ref().and_then(|n| find(n)) {
            return Slot::Normal(axis);
        }
        if let Some(axis) = self.uv.as_ref().and_then(|uv| find(uv)) {
            return Slot::Uv(axis);
        }
        match self.color {
            Some((_, Some(alpha))) if alpha == property => Slot::Color(3),
            Some((rgb, _)) => find(&rgb).map_or(Slot::Other, Slot::Color),
            None => Slot::Other,
        }
    }
}

/// The names exporters give a vertex's texture coordinates.
const UV_NAMES: [[&str; 2]; 4] = [
    ["u", "v"],
    ["s", "t"],
    ["texture_u", "texture_v"],
    ["texture_s", "texture_t"],
];

impl Header {
    fn parse(bytes: &[u8], path: &Path) -> Result<Header, LoadError> {
        let syntax = |line: usize, message: String| LoadError::Syntax {
            path: path.to_path_buf(),
            at: Location::Line(line),
            message,
        };
        let mut encoding = None;
        let mut elements: Vec<Element> = Vec::new();
        let mut offset = 0usize;
        for (n, line) in text::lines(bytes) {
            // The body starts after this line's '\n'; `lines` strips it (and a '\r').
            offset = bytes.len().min(offset + raw_len(bytes, offset));
            let mut words = text::tokens(line);
            let keyword = words.next().unwrap_or_default();
            if n == 1 {
                if keyword != b"ply" || words.next().is_some() {
                    return Err(syntax(
                        1,
                        "not a PLY file: the first line must be `ply`".into(),
                    ));
                }
                continue;
            }
            match keyword {
                b"format" => {
                    let kind = words.next().unwrap_or_default();
                    encoding = Some(match kind {
                        b"ascii" => Encoding::Ascii,
                        b"binary_little_endian" => Encoding::BinaryLittleEndian,
                        b"binary_big_endian" => {
                            return Err(LoadError::Unsupported {
                                path: path.to_path_buf(),
                                what: "binary_big_endian PLY".into(),
                                hint: "convert it to binary_little_endian or ascii (for example with meshlab or `plyfile`)".into(),
                            })
                        }
                        other => {
                            return Err(syntax(
                                n,
                                format!("unknown PLY format {:?} (expected ascii or binary_little_endian)", text::show(other)),
                            ))
                        }
                    });
                }
                b"comment" | b"obj_info" | b"" => {}
                b"element" => {
                    let (Some(name), Some(count), None) =
                        (words.next(), words.next(), words.next())
                    else {
                        return Err(syntax(n, "expected `element NAME COUNT`".into()));
                    };
                    elements.push(Element {
                        name: String::from_utf8_lossy(name).into_owned(),
                        count: text::count(count, "the element count", path, &Location::Line(n))?,
                        properties: Vec::new(),
                        line: n,
                    });
                }
                b"property" => {
                    let Some(element) = elements.last_mut() else {
                        return Err(syntax(n, "a property before any element".into()));
                    };
                    let parts: Vec<&[u8]> = words.collect();
                    let scalar = |name: &[u8]| {
                        Scalar::from_name(name).ok_or_else(|| {
                            syntax(n, format!("unknown property type {:?}", text::show(name)))
                        })
                    };
                    let (kind, name) = match parts.as_slice() {
                        [b"list", count, item, name] => {
                            let count = scalar(count)?;
                            if !count.is_integer() {
                                return Err(syntax(n, "a list's count type must be an integer type".into()));
                            }
                            (Kind::List(count, scalar(item)?), name)
                        }
                        [ty, name] => (Kind::Scalar(scalar(ty)?), name),
                        _ => {
                            return Err(syntax(
                                n,
                                "expected `property TYPE NAME` or `property list COUNT_TYPE ITEM_TYPE NAME`".into(),
                            ))
                        }
                    };
                    element.properties.push(Property {
                        name: String::from_utf8_lossy(name).into_owned(),
                        kind,
                        line: n,
                    });
                }
                b"end_header" => {
                    let Some(encoding) = encoding else {
                        return Err(syntax(n, "the header has no `format` line".into()));
                    };
                    return Ok(Header {
                        encoding,
                        elements,
                        body_start: offset,
                        lines: n,
                    });
                }
                other => {
                    return Err(syntax(
                        n,
                        format!("unknown header keyword {:?}", text::show(other)),
                    ))
                }
            }
        }
        if bytes.is_empty() {
            return Err(syntax(1, "the file is empty".into()));
        }
        Err(LoadError::Truncated {
            path: path.to_path_buf(),
            expected: "the `end_header` line".into(),
        })
    }

    /// Finds the vertex coordinates and the face index list, checking their types.
    fn mesh_layout(&self, path: &Path) -> Result<MeshLayout, LoadError> {
        let syntax = |line: usize, message: String| LoadError::Syntax {
            path: path.to_path_buf(),
            at: Location::Line(line),
            message,
        };
        let find = |name: &str| self.elements.iter().position(|e| e.name == name);
        let end = self.lines;
        let vertex = find("vertex")
            .ok_or_else(|| syntax(end, "the header declares no `element vertex`".into()))?;
        let face = find("face").ok_or_else(|| {
            syntax(
                end,
                "the header declares no `element face`: this is a point cloud, not a mesh".into(),
            )
        })?;
        let vertices = &self.elements[vertex];
        let mut xyz = [0usize; 3];
        for (slot, axis) in xyz.iter_mut().zip(["x", "y", "z"]) {
            let p = vertices
                .properties
                .iter()
                .position(|p| p.name == axis)
                .ok_or_else(|| {
                    syntax(
                        vertices.line,
                        format!("`element vertex` has no `{axis}` property"),
                    )
                })?;
            if let Kind::List(..) = vertices.properties[p].kind {
                return Err(syntax(
                    vertices.properties[p].line,
                    format!("vertex property `{axis}` must be a scalar, not a list"),
                ));
            }
            *slot = p;
        }
        // Normals and UVs are optional: a name declared as a list is not one.
        let scalar = |name: &str| {
            vertices
                .properties
                .iter()
                .position(|p| p.name == name && matches!(p.kind, Kind::Scalar(_)))
        };
        let normal = match ["nx", "ny", "nz"].map(scalar) {
            [Some(x), Some(y), Some(z)] => Some([x, y, z]),
            _ => None,
        };
        let uv = UV_NAMES.iter().find_map(|names| match names.map(scalar) {
            [Some(u), Some(v)] => Some([u, v]),
            _ => None,
        });
        let color = match ["red", "green", "blue"].map(scalar) {
            [Some(r), Some(g), Some(b)] => Some(([r, g, b], scalar("alpha"))),
            _ => None,
        };
        let faces = &self.elements[face];
        let indices = faces
            .properties
            .iter()
            .position(|p| p.name == "vertex_indices" || p.name == "vertex_index")
            .ok_or_else(|| {
                syntax(
                    faces.line,
                    "`element face` has no `vertex_indices` (or `vertex_index`) list".into(),
                )
            })?;
        let property = &faces.properties[indices];
        match property.kind {
            Kind::List(_, item) if item.is_integer() => {}
            _ => {
                return Err(syntax(
                    property.line,
                    format!("`{}` must be a list of an integer type", property.name),
                ))
            }
        }
        Ok(MeshLayout {
            vertex,
            xyz,
            normal,
            uv,
            color,
            face,
            indices,
        })
    }
}

/// Length of the line starting at `offset`, including its '\n' if present.
fn raw_len(bytes: &[u8], offset: usize) -> usize {
    let rest = bytes.get(offset..).unwrap_or_default();
    match rest.iter().position(|&b| b == b'\n') {
        Some(at) => at + 1,
        None => rest.len(),
    }
}

/// The record being read, for error messages.
struct Record<'a> {
    element: &'a Element,
    index: usize,
    path: &'a Path,
}

impl Record<'_> {
    fn truncated(&self) -> LoadError {
        LoadError::Truncated {
            path: self.path.to_path_buf(),
            expected: format!(
                "{} {} of the {} declared on header line {}",
                self.element.name, self.index, self.element.count, self.element.line
            ),
        }
    }
}

/// ASCII body tokens with the line each one is on.
struct Tokens<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Tokens<'a> {
    fn next(&mut self) -> Option<&'a [u8]> {
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        self.bytes.get(start..self.pos).filter(|t| !t.is_empty())
    }
}

enum Reader<'a> {
    Ascii(Tokens<'a>),
    Binary { bytes: &'a [u8], pos: usize },
}

/// A value read as its declared type.
enum Number {
    Int(i64),
    Float(f64),
}

impl Reader<'_> {
    fn location(&self, record: &Record) -> Location {
        Location::Record {
            element: record.element.name.clone(),
            index: record.index,
            line: match self {
                Reader::Ascii(tokens) => Some(tokens.line),
                Reader::Binary { .. } => None,
            },
        }
    }

    fn number(&mut self, ty: Scalar, record: &Record) -> Result<Number, LoadError> {
        match self {
            Reader::Ascii(tokens) => {
                let token = tokens.next().ok_or_else(|| record.truncated())?;
                let at = self.location(record);
                if ty.is_integer() {
                    text::integer(token, "the value", record.path, &at).map(Number::Int)
                } else {
                    // Straight to f32 when that is the declared type, to keep
                    // the correctly rounded value (see `text::coordinate`).
                    let value = text::coordinate(token, record.path, &at)?;
                    Ok(Number::Float(f64::from(value)))
                }
            }
            Reader::Binary { bytes, pos } => {
                let end = pos
                    .checked_add(ty.size())
                    .filter(|&end| end <= bytes.len())
                    .ok_or_else(|| record.truncated())?;
                let raw = bytes.get(*pos..end).ok_or_else(|| record.truncated())?;
                *pos = end;
                Ok(decode(ty, raw))
            }
        }
    }

    /// A vertex coordinate as a finite `f32`.
    fn coordinate(&mut self, ty: Scalar, record: &Record) -> Result<f32, LoadError> {
        match self.number(ty, record)? {
            Number::Int(value) => Ok(value as f32),
            Number::Float(value) => finite_f32(value, record.path, &self.location(record)),
        }
    }

    /// A value of an integer type (the header checks guarantee the type, and
    /// an ASCII token like `1.5` already fails as "not an integer").
    fn integer(&mut self, ty: Scalar, record: &Record) -> Result<i64, LoadError> {
        match self.number(ty, record)? {
            Number::Int(value) => Ok(value),
            Number::Float(value) => Err(LoadError::Syntax {
                path: record.path.to_path_buf(),
                at: self.location(record),
                message: format!("expected an integer, found {value}"),
            }),
        }
    }

    /// A list's item count, which must be a non-negative integer.
    fn list_size(&mut self, count_type: Scalar, record: &Record) -> Result<usize, LoadError> {
        let value = self.integer(count_type, record)?;
        usize::try_from(value).map_err(|_| LoadError::Syntax {
            path: record.path.to_path_buf(),
            at: self.location(record),
            message: format!("a list has a negative length {value}"),
        })
    }

    /// Steps over one property of a record without keeping it.
    fn skip(&mut self, kind: Kind, record: &Record) -> Result<(), LoadError> {
        let (items, ty) = match kind {
            Kind::Scalar(ty) => (1, ty),
            Kind::List(count, item) => (self.list_size(count, record)?, item),
        };
        match self {
            // Checked against the remaining bytes before moving, so a corrupt
            // list length is a truncation error, not an overflow.
            Reader::Binary { bytes, pos } => {
                *pos = items
                    .checked_mul(ty.size())
                    .and_then(|len| pos.checked_add(len))
                    .filter(|&end| end <= bytes.len())
                    .ok_or_else(|| record.truncated())?;
            }
            Reader::Ascii(tokens) => {
                for _ in 0..items {
                    tokens.next().ok_or_else(|| record.truncated())?;
                }
            }
        }
        Ok(())
    }
}

/// Decodes one little-endian scalar; `raw` has exactly `ty.size()` bytes.
fn decode(ty: Scalar, raw: &[u8]) -> Number {
    let mut buf = [0u8; 8];
    for (slot, &b) in buf.iter_mut().zip(raw) {
        *slot = b;
    }
    let [b0, b1, b2, b3, ..] = buf;
    match ty {
        Scalar::I8 => Number::Int(i64::from(b0 as i8)),
        Scalar::U8 => Number::Int(i64::from(b0)),
        Scalar::I16 => Number::Int(i64::from(i16::from_le_bytes([b0, b1]))),
        Scalar::U16 => Number::Int(i64::from(u16::from_le_bytes([b0, b1]))),
        Scalar::I32 => Number::Int(i64::from(i32::from_le_bytes([b0, b1, b2, b3]))),
        Scalar::U32 => Number::Int(i64::from(u32::from_le_bytes([b0, b1, b2, b3]))),
        Scalar::F32 => Number::Float(f64::from(f32::from_le_bytes([b0, b1, b2, b3]))),
        Scalar::F64 => Number::Float(f64::from_le_bytes(buf)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ply(bytes: &[u8]) -> Result<IndexedMesh, LoadError> {
        parse(bytes, Path::new("test.ply"))
    }

    #[test]
    fn ascii_with_extra_properties_and_elements() {
        let text = "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nelement vertex 4\r\nproperty float nx\r\nproperty float32 x\r\nproperty double y\r\nproperty uchar red\r\nproperty int z\r\nelement face 2\r\nproperty list uchar int vertex_indices\r\nproperty list ushort float texcoord\r\nelement edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\nend_header\r\n9 0 0 255 0\r\n9 1 0 255 0\r\n9 1 1 255 0\r\n9 0 1 255 3\r\n4 0 1 2 3 2 0.5 0.5\r\n3 3 2 1 0\r\n0 1\r\n";
        let mesh = ply(text.as_bytes()).unwrap();
        assert_eq!(
            mesh.positions,
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 3.0]
            ]
        );
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 1]]);
    }

    /// Binary little-endian PLY: double coordinates between other scalars, a
    /// face element with a skipped list before the indices, an `edge` element.
    #[test]
    fn binary_little_endian_skips_by_size() {
        let header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty uint8 flag\nproperty float64 x\nproperty float64 y\nproperty float64 z\nproperty short s\nelement face 1\nproperty list uint16 float32 uv\nproperty list uint int32 vertex_index\nelement edge 1\nproperty list uchar int vertices\nend_header\n";
        let mut bytes = header.as_bytes().to_vec();
        for (i, p) in [[0.0f64, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]]
            .iter()
            .enumerate()
        {
            bytes.push(i as u8);
            for c in p {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
            bytes.extend_from_slice(&(-7i16).to_le_bytes());
        }
        bytes.extend_from_slice(&2u16.to_le_bytes());
        bytes.extend_from_slice(&0.25f32.to_le_bytes());
        bytes.extend_from_slice(&0.75f32.to_le_bytes());
        bytes.extend_from_slice(&3u32.to_le_bytes());
        for v in [2i32, 1, 0] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.push(2);
        bytes.extend_from_slice(&0i32.to_le_bytes());
        bytes.extend_from_slice(&1i32.to_le_bytes());
        let mesh = ply(&bytes).unwrap();
        assert_eq!(mesh.positions[2], [0.0, 1.0, 0.5]);
        assert_eq!(mesh.triangles, vec![[2, 1, 0]]);
        // One byte short of the edge record: truncation names the element.
        let err = ply(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
        assert!(err.to_string().contains("edge 0 of the 1"), "{err}");
    }

    /// The cow written as ASCII and as binary PLY loads back bit for bit.
    #[test]
    fn cow_round_trips_through_both_encodings() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cow.off");
        let cow = crate::io::off::load(&path).unwrap();
        let header = |format: &str| {
            format!(
                "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
                cow.vertex_count(),
                cow.triangle_count()
            )
        };
        let mut ascii = header("ascii");
        let mut binary = header("binary_little_endian").into_bytes();
        for p in &cow.positions {
            // `{:?}` prints the shortest text that parses back to the same f32.
            ascii += &format!("{:?} {:?} {:?}\n", p[0], p[1], p[2]);
            for c in p {
                binary.extend_from_slice(&c.to_le_bytes());
            }
        }
        for t in &cow.triangles {
            ascii += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
            binary.push(3);
            for v in t {
                binary.extend_from_slice(&v.to_le_bytes());
            }
        }
        assert_eq!(ply(ascii.as_bytes()).unwrap(), cow);
        assert_eq!(ply(&binary).unwrap(), cow);
    }

    #[test]
    fn normals_and_texture_coordinates_are_read() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float nx\nproperty float y\nproperty float z\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty float s\nproperty float t\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
                    0 0 0 0 0 1 255 0 0\n1 0 0 0 0 1 255 1 0.25\n0 0 1 0 1 0 255 0 1\n3 0 1 2\n";
        let mesh = parse_attributed(text.as_bytes(), Path::new("n.ply")).unwrap();
        assert_eq!(mesh.positions.positions[2], [0.0, 1.0, 0.0]);
        assert_eq!(
            mesh.attributes.normals.as_deref(),
            Some(&[[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]][..])
        );
        // `t` flipped to glTF's convention.
        assert_eq!(
            mesh.attributes.uvs.as_deref(),
            Some(&[[0.0, 1.0], [1.0, 0.75], [0.0, 0.0]][..])
        );
        assert_eq!(mesh.position_of, vec![0, 1, 2]);
        // Only `nx ny` (no `nz`) is not a normal; `u` without `v` is not a UV.
        let partial = PLY_PARTIAL;
        let mesh = parse_attributed(partial.as_bytes(), Path::new("p.ply")).unwrap();
        assert!(!mesh.attributes.has_vertex_attributes());
        assert_eq!(mesh.positions.positions[1], [1.0, 0.0, 0.0]);
    }

    #[test]
    fn colours_are_read_and_decoded_from_srgb() {
        // `uchar` channels with alpha, as MeshLab writes them; properties in any order.
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty uchar alpha\nproperty float x\nproperty uchar blue\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
                    255 0 0 0 0 255 0\n128 1 255 0 0 0 255\n0 0 10 1 0 255 255\n3 0 1 2\n";
        let mesh = parse_attributed(text.as_bytes(), Path::new("c.ply")).unwrap();
        let colors = mesh
            .attributes
            .colors
            .expect("red, green and blue are declared");
        assert_eq!(colors[0], [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(colors[1], [0.0, 1.0, 1.0, 128.0 / 255.0]);
        // sRGB 10/255 lies on the transfer function's linear segment: 10/255/12.92.
        assert!(
            (colors[2][2] - 10.0 / 255.0 / 12.92).abs() < 1e-7,
            "{colors:?}"
        );
        assert_eq!(colors[2][3], 0.0);
        // Float channels are in [0, 1]; no `alpha` means opaque; mid-grey decodes to ~0.214.
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float red\nproperty float green\nproperty float blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
                    0 0 0 0.5 0.5 0.5\n1 0 0 1 1 1\n0 1 0 0 0 0\n3 0 1 2\n";
        let mesh = parse_attributed(text.as_bytes(), Path::new("f.ply")).unwrap();
        let colors = mesh.attributes.colors.unwrap();
        assert!((colors[0][0] - 0.21404).abs() < 1e-4, "{colors:?}");
        assert_eq!(colors[1], [1.0; 4]);
        // `red` alone is not a colour.
        let mesh = parse_attributed(
            PLY_PARTIAL.replace("float u", "uchar red").as_bytes(),
            Path::new("r.ply"),
        );
        assert!(mesh.unwrap().attributes.colors.is_none());
    }

    const PLY_PARTIAL: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float u\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1 1 1\n1 0 0 1 1 1\n0 1 0 1 1 1\n3 0 1 2\n";

    #[test]
    fn binary_normals_and_uvs() {
        let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty double nx\nproperty double ny\nproperty double nz\nproperty float texture_u\nproperty float texture_v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
        for (p, uv) in [
            ([0.0f32, 0.0, 0.0], [0.0f32, 0.0]),
            ([1.0, 0.0, 0.0], [1.0, 0.0]),
            ([0.0, 1.0, 0.0], [0.0, 1.0]),
        ] {
            p.iter().for_each(|c| bytes.extend(c.to_le_bytes()));
            [0.0f64, 0.0, -1.0]
                .iter()
                .for_each(|c| bytes.extend(c.to_le_bytes()));
            uv.iter().for_each(|c| bytes.extend(c.to_le_bytes()));
        }
        bytes.push(3);
        [0i32, 1, 2]
            .iter()
            .for_each(|i| bytes.extend(i.to_le_bytes()));
        let mesh = parse_attributed(&bytes, Path::new("b.ply")).unwrap();
        assert_eq!(
            mesh.attributes.normals.as_deref(),
            Some(&[[0.0, 0.0, -1.0]; 3][..])
        );
        assert_eq!(
            mesh.attributes.uvs.as_deref(),
            Some(&[[0.0, 1.0], [1.0, 1.0], [0.0, 0.0]][..])
        );
    }
}
