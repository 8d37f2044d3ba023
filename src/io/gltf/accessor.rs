//! Bounds-checked accessor reads (vectors, floats, indices, sparse accessors) and the
//! corner list → triangle conversion of the primitive modes.

use super::document::{Document, MAX_VIEWLESS_BYTES, QUANTIZATION};
use crate::io::LoadError;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

impl Document {
    pub(super) fn read_vec3(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
    ) -> Result<Vec<[f32; 3]>, LoadError> {
        let flat = self.read_floats(accessor, element, Dimensions::Vec3)?;
        Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// Reads float or normalized-integer components (glTF §3.11 decoding) and
    /// rejects non-finite values; plain integers (their values) only in a file that uses
    /// KHR_mesh_quantization.
    pub(super) fn read_floats(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
        dimensions: Dimensions,
    ) -> Result<Vec<f32>, LoadError> {
        let element = format!("accessor {} ({element})", accessor.index());
        if accessor.dimensions() != dimensions {
            return Err(self.data_error(
                &element,
                format!(
                    "has type {:?}, expected {dimensions:?}",
                    accessor.dimensions()
                ),
            ));
        }
        let data_type = accessor.data_type();
        let integers = data_type != DataType::F32 && !accessor.normalized();
        if integers && (data_type == DataType::U32 || !self.uses(QUANTIZATION)) {
            return Err(self.unsupported(
                &element,
                format!("non-normalized {data_type:?} components without {QUANTIZATION}"),
            ));
        }
        let bytes = self.gather(accessor, &element)?;
        let values: Vec<f32> = match data_type {
            DataType::F32 => bytes
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
            _ if integers => integer_values(data_type, &bytes),
            DataType::I8 => bytes
                .iter()
                .map(|&b| (b as i8 as f32 / 127.0).max(-1.0))
                .collect(),
            DataType::U8 => bytes.iter().map(|&b| b as f32 / 255.0).collect(),
            DataType::I16 => bytes
                .chunks_exact(2)
                .map(|b| (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0))
                .collect(),
            DataType::U16 => bytes
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0)
                .collect(),
            DataType::U32 => {
                return Err(self.unsupported(
                    &element,
                    "normalized UNSIGNED_INT components (not allowed by glTF)".to_string(),
                ))
            }
        };
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            let c = dimensions.multiplicity();
            return Err(self.data_error(
                &element,
                format!(
                    "element {} component {} is {}: fix the exporter or the file",
                    i / c,
                    i % c,
                    values[i]
                ),
            ));
        }
        Ok(values)
    }

    pub(super) fn read_indices(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
    ) -> Result<Vec<u32>, LoadError> {
        let element = format!("accessor {} ({element})", accessor.index());
        if accessor.dimensions() != Dimensions::Scalar || accessor.normalized() {
            return Err(self.data_error(
                &element,
                "indices must be non-normalized SCALAR values".to_string(),
            ));
        }
        let bytes = self.gather(accessor, &element)?;
        match accessor.data_type() {
            DataType::U8 => Ok(bytes.iter().map(|&b| b as u32).collect()),
            DataType::U16 => Ok(bytes
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]) as u32)
                .collect()),
            DataType::U32 => Ok(bytes
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect()),
            other => Err(self.data_error(
                &element,
                format!(
                    "indices must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, not {other:?}"
                ),
            )),
        }
    }

    /// True when the file lists `extension` in `extensionsUsed`.
    pub(super) fn uses(&self, extension: &str) -> bool {
        super::document::uses(&self.raw, extension)
    }

    /// The bytes of a buffer view (decoded, when it is compressed), after checking the view
    /// lies inside its buffer.
    pub(super) fn view_bytes(
        &self,
        view: &gltf::buffer::View,
        element: &str,
    ) -> Result<&[u8], LoadError> {
        if let Some(Some(decoded)) = self.decoded.get(view.index()) {
            // Decoded to exactly byteLength bytes (checked by the decoder).
            return Ok(decoded);
        }
        let buffer = self
            .buffers
            .get(view.buffer().index())
            .map_or(&[][..], |b| b);
        let end = view.offset().checked_add(view.length());
        match end {
            Some(end) if end <= buffer.len() => Ok(&buffer[view.offset()..end]),
            _ => Err(self.data_error(
                element,
                format!(
                    "buffer view {} (byteOffset {}, byteLength {}) runs past the end of buffer {} ({} bytes)",
                    view.index(),
                    view.offset(),
                    view.length(),
                    view.buffer().index(),
                    buffer.len()
                ),
            )),
        }
    }

    /// The accessor's elements as tightly packed little-endian bytes, with its
    /// sparse substitutions applied. Every offset, stride and count comes from
    /// the file, so each range is checked (with overflow-checked arithmetic)
    /// before it is read.
    pub(super) fn gather(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
    ) -> Result<Vec<u8>, LoadError> {
        let matrix = matches!(
            accessor.dimensions(),
            Dimensions::Mat2 | Dimensions::Mat3 | Dimensions::Mat4
        );
        if matrix && accessor.data_type().size() < 4 {
            // Byte and short matrix columns carry alignment padding; nothing read uses them
            // (inverse bind matrices are FLOAT, whose columns are packed).
            return Err(
                self.unsupported(element, "matrix accessors of bytes or shorts".to_string())
            );
        }
        let size = accessor.size();
        let count = accessor.count();
        let mut out = match accessor.view() {
            Some(view) => {
                let bytes = self.view_bytes(&view, element)?;
                let stride = view.stride().unwrap_or(size);
                if stride < size {
                    return Err(self.data_error(
                        element,
                        format!("byteStride {stride} is smaller than one element ({size} bytes)"),
                    ));
                }
                let end = match count {
                    0 => Some(accessor.offset()),
                    _ => stride
                        .checked_mul(count - 1)
                        .and_then(|s| s.checked_add(accessor.offset()))
                        .and_then(|s| s.checked_add(size)),
                };
                if end.is_none_or(|e| e > bytes.len()) {
                    return Err(self.data_error(
                        element,
                        format!(
                            "byteOffset {} + byteStride {stride} × ({count} − 1) + {size} runs past buffer view {} ({} bytes)",
                            accessor.offset(),
                            view.index(),
                            bytes.len()
                        ),
                    ));
                }
                let mut out = Vec::with_capacity(count * size);
                for i in 0..count {
                    let start = accessor.offset() + i * stride;
                    out.extend_from_slice(&bytes[start..start + size]);
                }
                out
            }
            None => {
                let bytes = count.checked_mul(size).filter(|&b| b <= MAX_VIEWLESS_BYTES);
                let Some(bytes) = bytes else {
                    return Err(self.unsupported(
                        element,
                        format!("an accessor without bufferView of {count} elements of {size} bytes (at most {MAX_VIEWLESS_BYTES} bytes)"),
                    ));
                };
                vec![0; bytes]
            }
        };
        if let Some(sparse) = accessor.sparse() {
            let n = sparse.count();
            let indices = sparse.indices();
            let index_size = match indices.index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            let index_bytes = self.view_bytes(&indices.view(), element)?;
            let value_bytes = self.view_bytes(&sparse.values().view(), element)?;
            let index_range = n
                .checked_mul(index_size)
                .and_then(|l| l.checked_add(indices.offset()))
                .filter(|&e| e <= index_bytes.len());
            let value_range = n
                .checked_mul(size)
                .and_then(|l| l.checked_add(sparse.values().offset()))
                .filter(|&e| e <= value_bytes.len());
            if index_range.is_none() || value_range.is_none() {
                return Err(self.data_error(
                    element,
                    format!("sparse storage of {n} entries runs past its buffer views"),
                ));
            }
            let index_bytes = &index_bytes[indices.offset()..];
            let value_bytes = &value_bytes[sparse.values().offset()..];
            for s in 0..n {
                let b = &index_bytes[s * index_size..(s + 1) * index_size];
                let target = match index_size {
                    1 => b[0] as usize,
                    2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
                };
                if target >= count {
                    return Err(self.data_error(
                        element,
                        format!("sparse entry {s} replaces element {target}, but the accessor has {count}"),
                    ));
                }
                out[target * size..(target + 1) * size]
                    .copy_from_slice(&value_bytes[s * size..(s + 1) * size]);
            }
        }
        Ok(out)
    }
}

/// Little-endian integer components of `data_type` (not `U32` or `F32`) as their values.
fn integer_values(data_type: DataType, bytes: &[u8]) -> Vec<f32> {
    match data_type {
        DataType::I8 => bytes.iter().map(|&b| b as i8 as f32).collect(),
        DataType::U8 => bytes.iter().map(|&b| b as f32).collect(),
        DataType::I16 => bytes
            .chunks_exact(2)
            .map(|b| i16::from_le_bytes([b[0], b[1]]) as f32)
            .collect(),
        _ => bytes
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]) as f32)
            .collect(),
    }
}

/// Corner list → triangles. Strips alternate orientation, so odd triangles swap
/// their last two corners (glTF §3.7.2.1) to stay front-facing; strip and fan
/// triangles with a repeated corner are the joints exporters use to stitch
/// strips and draw nothing, so they are dropped.
pub(super) fn triangulate(mode: Mode, corners: &[u32]) -> Result<Vec<[u32; 3]>, String> {
    match mode {
        Mode::Triangles => {
            if !corners.len().is_multiple_of(3) {
                return Err(format!(
                    "TRIANGLES needs a multiple of 3 indices, has {}",
                    corners.len()
                ));
            }
            Ok(corners
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect())
        }
        Mode::TriangleStrip => Ok(corners
            .windows(3)
            .enumerate()
            .map(|(i, w)| {
                if i % 2 == 0 {
                    [w[0], w[1], w[2]]
                } else {
                    [w[0], w[2], w[1]]
                }
            })
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect()),
        Mode::TriangleFan => Ok(corners
            .windows(2)
            .skip(1)
            .map(|w| [w[0], w[1], corners[0]])
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect()),
        other => Err(format!("primitive mode {other:?} is not triangles")),
    }
}
