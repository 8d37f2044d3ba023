//! `EXT_meshopt_compression` on the read side: a compressed buffer view's bytes, decoded with
//! meshoptimizer's decoders (the `meshopt` crate, linked with the `export` feature) after
//! checking everything the extension's JSON says against its specification, so a corrupt or
//! inconsistent view is refused with what is wrong, never decoded into garbage silently where
//! the codec can tell.
//!
//! The bitstream versions are those the extension defines (its Appendix A); the exporter
//! writes the same (`export::compress`).

/// The extension's name.
pub const EXT_MESHOPT_COMPRESSION: &str = "EXT_meshopt_compression";
/// Vertex codec version the extension defines (the exporter's; the reader checks the header).
#[cfg(feature = "export")]
pub(crate) const VERTEX_CODEC_VERSION: i32 = 0;
/// Header byte of an ATTRIBUTES stream (vertex codec version 0).
pub(crate) const ATTRIBUTES_HEADER: u8 = 0xa0;
/// Header byte of a TRIANGLES stream (index codec version 1).
pub(crate) const TRIANGLES_HEADER: u8 = 0xe1;
/// Header byte of an INDICES stream (index sequence codec version 1).
pub(crate) const INDICES_HEADER: u8 = 0xd1;

/// One compressed view as its extension object describes it.
struct Compressed<'a> {
    data: &'a [u8],
    stride: usize,
    count: usize,
    mode: &'a str,
    filter: &'a str,
}

/// The decoded bytes of buffer view `view` (its JSON object `json`, whose
/// `extensions.EXT_meshopt_compression` is `ext`): `byteStride × count` bytes, which the
/// view's `byteLength` must equal. `buffers`: the file's loaded buffers. `Err`: what is
/// wrong, in a sentence.
pub(super) fn decode_view(
    json: &serde_json::Value,
    ext: &serde_json::Value,
    buffers: &[Vec<u8>],
) -> Result<Vec<u8>, String> {
    let number = |name: &str, default: Option<u64>| -> Result<usize, String> {
        match ext.get(name) {
            Some(v) => v
                .as_u64()
                .map(|v| v as usize)
                .ok_or_else(|| format!("{name} is not a non-negative integer")),
            None => default
                .map(|d| d as usize)
                .ok_or_else(|| format!("{name} is missing")),
        }
    };
    let buffer = number("buffer", None)?;
    let offset = number("byteOffset", Some(0))?;
    let length = number("byteLength", None)?;
    let stride = number("byteStride", None)?;
    let count = number("count", None)?;
    let mode = ext
        .get("mode")
        .and_then(|m| m.as_str())
        .ok_or("mode is missing")?;
    let filter = match ext.get("filter") {
        Some(f) => f.as_str().ok_or("filter is not a string")?,
        None => "NONE",
    };
    let bytes = buffers
        .get(buffer)
        .ok_or_else(|| format!("buffer {buffer} does not exist"))?;
    let data = offset
        .checked_add(length)
        .and_then(|end| bytes.get(offset..end))
        .ok_or_else(|| {
            format!(
                "byteOffset {offset} + byteLength {length} runs past buffer {buffer} ({} bytes)",
                bytes.len()
            )
        })?;
    let parent_stride = json.get("byteStride").and_then(|s| s.as_u64());
    if parent_stride.is_some_and(|s| s as usize != stride) {
        return Err(format!(
            "byteStride {stride} differs from the view's {}",
            parent_stride.unwrap_or(0)
        ));
    }
    let parent_length = json.get("byteLength").and_then(|l| l.as_u64()).unwrap_or(0) as usize;
    if stride.checked_mul(count) != Some(parent_length) {
        return Err(format!(
            "byteStride {stride} × count {count} differs from the view's byteLength {parent_length}"
        ));
    }
    let view = Compressed {
        data,
        stride,
        count,
        mode,
        filter,
    };
    check(&view)?;
    decode(&view)
}

/// The extension's validity rules ("For the extension object to be valid, the following must
/// hold") and the stream's header byte.
fn check(view: &Compressed) -> Result<(), String> {
    let (stride, filter) = (view.stride, view.filter);
    let header = match view.mode {
        "ATTRIBUTES" => {
            if stride == 0 || !stride.is_multiple_of(4) || stride > 256 {
                return Err(format!(
                    "ATTRIBUTES with byteStride {stride}: it must be a multiple of 4 up to 256"
                ));
            }
            let fits = match filter {
                "NONE" | "EXPONENTIAL" => true,
                "OCTAHEDRAL" => stride == 4 || stride == 8,
                "QUATERNION" => stride == 8,
                other => return Err(format!("unknown filter {other:?}")),
            };
            if !fits {
                return Err(format!("filter {filter} with byteStride {stride}"));
            }
            ATTRIBUTES_HEADER
        }
        "TRIANGLES" | "INDICES" => {
            if stride != 2 && stride != 4 {
                return Err(format!(
                    "{} with byteStride {stride}: it must be 2 or 4",
                    view.mode
                ));
            }
            if filter != "NONE" {
                return Err(format!("{} with filter {filter}", view.mode));
            }
            if view.mode == "TRIANGLES" && !view.count.is_multiple_of(3) {
                return Err(format!(
                    "TRIANGLES of {} indices, not a multiple of 3",
                    view.count
                ));
            }
            if view.mode == "TRIANGLES" {
                TRIANGLES_HEADER
            } else {
                INDICES_HEADER
            }
        }
        other => return Err(format!("unknown mode {other:?}")),
    };
    match view.data.first() {
        Some(&h) if h == header => Ok(()),
        Some(h) => Err(format!(
            "{} stream starts with 0x{h:02x}, not 0x{header:02x}: the data is corrupt or of another codec version",
            view.mode
        )),
        None => Err("the compressed data is empty".into()),
    }
}

#[cfg(feature = "export")]
fn decode(view: &Compressed) -> Result<Vec<u8>, String> {
    let failed = |e: ::meshopt::Error| {
        format!(
            "{} data of {} bytes does not decode to {} elements of {} bytes ({e}): the data is corrupt",
            view.mode,
            view.data.len(),
            view.count,
            view.stride
        )
    };
    let (data, count) = (view.data, view.count);
    match view.mode {
        "TRIANGLES" | "INDICES" => {
            let triangles = view.mode == "TRIANGLES";
            if view.stride == 2 {
                let indices: Vec<u16> = match triangles {
                    true => ::meshopt::decode_index_buffer(data, count),
                    false => ::meshopt::decode_index_sequence(data, count),
                }
                .map_err(failed)?;
                Ok(indices.iter().flat_map(|i| i.to_le_bytes()).collect())
            } else {
                let indices: Vec<u32> = match triangles {
                    true => ::meshopt::decode_index_buffer(data, count),
                    false => ::meshopt::decode_index_sequence(data, count),
                }
                .map_err(failed)?;
                Ok(indices.iter().flat_map(|i| i.to_le_bytes()).collect())
            }
        }
        _ => {
            let mut bytes = decode_attributes(data, view.stride, count).map_err(failed)?;
            unfilter(&mut bytes, view.stride, view.filter);
            Ok(bytes)
        }
    }
}

/// Without the `meshopt` crate nothing decodes: a typed refusal that says how to get it.
#[cfg(not(feature = "export"))]
fn decode(view: &Compressed) -> Result<Vec<u8>, String> {
    Err(format!(
        "{} data compressed with {EXT_MESHOPT_COMPRESSION}: build morphlod with its `export` feature to read it",
        view.mode
    ))
}

/// An element of `N` bytes: the decoder takes the element as a type (arrays past 32 have no
/// `Default`).
#[cfg(feature = "export")]
#[derive(Clone, Copy)]
struct Element<const N: usize>([u8; N]);

#[cfg(feature = "export")]
impl<const N: usize> Default for Element<N> {
    fn default() -> Self {
        Element([0; N])
    }
}

/// An ATTRIBUTES stream of `count` elements of `stride` bytes (a multiple of 4 up to 256,
/// checked), decoded.
#[cfg(feature = "export")]
fn decode_attributes(data: &[u8], stride: usize, count: usize) -> ::meshopt::Result<Vec<u8>> {
    fn decode<const N: usize>(data: &[u8], count: usize) -> ::meshopt::Result<Vec<u8>> {
        let elements: Vec<Element<N>> = ::meshopt::decode_vertex_buffer(data, count)?;
        Ok(elements.iter().flat_map(|e| e.0).collect())
    }
    macro_rules! by_stride {
        ($($n:literal)*) => {
            match stride {
                $($n => decode::<$n>(data, count),)*
                _ => unreachable!("byteStride {stride} was checked"),
            }
        };
    }
    by_stride!(4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64 68 72 76 80 84 88 92 96 100 104
        108 112 116 120 124 128 132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192
        196 200 204 208 212 216 220 224 228 232 236 240 244 248 252 256)
}

/// Applies `filter` (the extension's Appendix B) to decoded elements in place.
#[cfg(feature = "export")]
fn unfilter(bytes: &mut [u8], stride: usize, filter: &str) {
    fn shorts(bytes: &[u8]) -> Vec<[i16; 4]> {
        bytes
            .chunks_exact(8)
            .map(|e| std::array::from_fn(|k| i16::from_le_bytes([e[2 * k], e[2 * k + 1]])))
            .collect()
    }
    fn put_shorts(bytes: &mut [u8], values: &[[i16; 4]]) {
        for (e, v) in bytes.chunks_exact_mut(8).zip(values) {
            for k in 0..4 {
                e[2 * k..2 * k + 2].copy_from_slice(&v[k].to_le_bytes());
            }
        }
    }
    match (filter, stride) {
        ("OCTAHEDRAL", 4) => {
            let mut values: Vec<[i8; 4]> = bytes
                .chunks_exact(4)
                .map(|e| std::array::from_fn(|k| e[k] as i8))
                .collect();
            ::meshopt::decode_filter_oct(&mut values);
            for (e, v) in bytes.chunks_exact_mut(4).zip(&values) {
                e.copy_from_slice(&v.map(|c| c as u8));
            }
        }
        ("OCTAHEDRAL", _) => {
            let mut values = shorts(bytes);
            ::meshopt::decode_filter_oct(&mut values);
            put_shorts(bytes, &values);
        }
        ("QUATERNION", _) => {
            let mut values = shorts(bytes);
            ::meshopt::decode_filter_quat(&mut values);
            put_shorts(bytes, &values);
        }
        ("EXPONENTIAL", _) => {
            // Each 32-bit component decodes on its own, whatever the stride.
            let mut values: Vec<[u32; 1]> = bytes
                .chunks_exact(4)
                .map(|e| [u32::from_le_bytes([e[0], e[1], e[2], e[3]])])
                .collect();
            ::meshopt::decode_filter_exp(&mut values);
            for (e, v) in bytes.chunks_exact_mut(4).zip(&values) {
                e.copy_from_slice(&v[0].to_le_bytes());
            }
        }
        _ => {}
    }
}
