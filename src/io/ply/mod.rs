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
//!
//! One file a stage: `header.rs` parses the header, `layout.rs` finds where the mesh data sits
//! in it, `reader.rs` reads the body's values as declared; this file reads the records into
//! the mesh ([`parse_attributed`]).

mod header;
mod layout;
mod reader;
#[cfg(test)]
mod tests;

use super::attributed::{srgb_to_linear, AttributedMesh};
use super::polygon::Polygons;
use super::text::{self, capacity};
use super::{read, validated, LoadError, Location};
use crate::mesh::IndexedMesh;
use crate::morph::Attributes;
use std::path::Path;

use header::{Encoding, Header, Kind, Scalar};
use layout::Slot;
use reader::{Reader, Record, Tokens};

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
