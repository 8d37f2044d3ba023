//! The file's buffer views, written plain or compressed with `EXT_meshopt_compression`
//! (meshoptimizer's codecs through the `meshopt` crate).
//!
//! Compressed, a view's bytes go through the codec its use calls for (ATTRIBUTES for vertex,
//! morph-delta, animation and skin data, TRIANGLES for triangle lists) into the GLB's BIN
//! chunk (buffer 0); the view itself points into a fallback buffer (buffer 1) that has no
//! data and is marked `"fallback": true`, so the file requires the extension. Images are
//! written plain: they are compressed already.
//!
//! The extension's bitstreams (its Appendix A) are versioned by their header byte; meshoptimizer
//! 1.x writes a newer vertex codec version by default, so the one the extension defines is
//! asked for.
//!
//! The codec versions (and the reader that checks them) are in
//! `io::gltf::meshopt_compression`; the index codec's default version in meshoptimizer 1.x
//! is the extension's (`0xe1`), which the reader checks on every view it decodes.

pub use crate::io::gltf::meshopt_compression::EXT_MESHOPT_COMPRESSION;
use crate::io::gltf::meshopt_compression::VERTEX_CODEC_VERSION;
use crate::io::gltf::write::{Bin, Json};
use std::fmt::Write as _;

/// How a buffer view's bytes are stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Codec {
    /// As they are, whatever the file's compression (images).
    Plain,
    /// ATTRIBUTES mode, no filter: the bytes read back exactly.
    Attributes,
    /// ATTRIBUTES mode with the OCTAHEDRAL filter: the elements are unit vectors encoded by
    /// `meshopt::encode_filter_oct` (4 or 8 bytes each), decoded to normalized integers.
    Octahedral,
    /// TRIANGLES mode: a triangle list of `u16` or `u32` indices.
    Triangles,
}

impl Codec {
    fn filter(self) -> &'static str {
        match self {
            Codec::Octahedral => r#","filter":"OCTAHEDRAL""#,
            _ => "",
        }
    }
}

/// The buffer views and accessors being written, plain or compressed.
#[derive(Default)]
pub(super) struct Buffers {
    pub(super) bin: Bin,
    pub(super) json: Json,
    /// Compress with `EXT_meshopt_compression` (all but [`Codec::Plain`] views).
    pub(super) compress: bool,
    /// Length of the fallback buffer: every compressed view's uncompressed bytes.
    pub(super) fallback: usize,
}

impl Buffers {
    pub(super) fn new(compress: bool) -> Buffers {
        Buffers {
            compress,
            ..Buffers::default()
        }
    }

    /// A view of `data`, whose elements are `element` bytes each (a multiple of 4 for the
    /// attribute codecs, 2 or 4 for triangles), with `byteStride` when `strided` (vertex
    /// attributes) and `target` when given; its index.
    pub(super) fn view(
        &mut self,
        data: Vec<u8>,
        element: usize,
        strided: bool,
        target: Option<u32>,
        codec: Codec,
    ) -> usize {
        if !self.compress || codec == Codec::Plain {
            let stride = strided.then_some(element);
            return self.json.strided_view(self.bin.push(data), stride, target);
        }
        let (encoded, mode, stride) = match codec {
            Codec::Triangles => (encode_triangles(&data, element), "TRIANGLES", element),
            _ => {
                let stride = attribute_stride(element);
                debug_assert!(!strided || stride == element, "vertex stride {element}");
                (encode_attributes(&data, stride), "ATTRIBUTES", stride)
            }
        };
        let count = data.len() / stride;
        let (at, length) = self.bin.push(encoded);
        let offset = self.fallback.next_multiple_of(4);
        self.fallback = offset + data.len();
        let mut view = format!(
            r#"{{"buffer":1,"byteOffset":{offset},"byteLength":{}"#,
            data.len()
        );
        if strided {
            let _ = write!(view, r#","byteStride":{element}"#);
        }
        if let Some(t) = target {
            let _ = write!(view, r#","target":{t}"#);
        }
        let _ = write!(
            view,
            r#","extensions":{{"{EXT_MESHOPT_COMPRESSION}":{{"buffer":0,"byteOffset":{at},"byteLength":{length},"byteStride":{stride},"count":{count},"mode":"{mode}"{}}}}}}}"#,
            codec.filter()
        );
        self.json.views.push(view);
        self.json.views.len() - 1
    }

    /// The `buffers` JSON array: the BIN chunk, and with compression the fallback buffer.
    pub(super) fn buffers_json(&self) -> String {
        let bin = format!(r#"{{"byteLength":{}}}"#, self.bin.bytes.len());
        if !self.compress {
            return format!("[{bin}]");
        }
        format!(
            r#"[{bin},{{"byteLength":{},"extensions":{{"{EXT_MESHOPT_COMPRESSION}":{{"fallback":true}}}}}}]"#,
            self.fallback.max(1)
        )
    }
}

/// The stride an ATTRIBUTES stream of `element`-byte elements is encoded with. The crate's
/// encoder takes the element as a type, so each stride the exporter's vertex views have (4
/// to 16 bytes) is its own instance; other data (matrices) is encoded as 4-byte elements,
/// which the extension allows for a view without `byteStride`.
fn attribute_stride(element: usize) -> usize {
    if matches!(element, 8 | 12 | 16) {
        element
    } else {
        4
    }
}

/// `data` as an ATTRIBUTES stream of `element`-byte elements ([`attribute_stride`]).
fn encode_attributes(data: &[u8], element: usize) -> Vec<u8> {
    fn encode<const N: usize>(data: &[u8]) -> Vec<u8> {
        let elements: Vec<[u8; N]> = data
            .chunks_exact(N)
            .map(|c| c.try_into().expect("chunks of N bytes"))
            .collect();
        // Level 2 is the encoder's default; version 0 ignores the level.
        meshopt::encode_vertex_buffer_level(&elements, 2, Some(VERTEX_CODEC_VERSION))
            .expect("encoding into a buffer of the bound's size succeeds")
    }
    match element {
        8 => encode::<8>(data),
        12 => encode::<12>(data),
        16 => encode::<16>(data),
        _ => encode::<4>(data),
    }
}

/// A triangle list of `u16` (`element` 2) or `u32` indices as a TRIANGLES stream.
fn encode_triangles(data: &[u8], element: usize) -> Vec<u8> {
    let indices: Vec<u32> = match element {
        2 => data
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]) as u32)
            .collect(),
        _ => data
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
    };
    let vertices = indices.iter().max().map_or(0, |&i| i as usize + 1);
    meshopt::encode_index_buffer(&indices, vertices)
        .expect("encoding into a buffer of the bound's size succeeds")
}
