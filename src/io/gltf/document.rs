//! The validated glTF document: container split, JSON pre-check and validation, buffers
//! resolved and length-checked, URIs decoded. What is read from it lives above it: accessor
//! data in `accessor.rs`, vertex attributes and the material in `attributes.rs`, the mesh's
//! primitives in `primitives.rs`, the node tree in `nodes.rs`, animation channels in
//! `animation.rs`.

use super::meshopt_compression::EXT_MESHOPT_COMPRESSION;
use super::{list_names, pick};
use crate::io::LoadError;
use base64::Engine;
use std::path::{Path, PathBuf};

/// The largest accessor without a buffer view we materialise (it reads as zeros
/// plus sparse values): its count comes from the file and no data backs it, so
/// a few bytes of JSON could otherwise ask for gigabytes. 256 MiB holds a
/// 22-million-vertex sparse morph target.
pub(super) const MAX_VIEWLESS_BYTES: usize = 1 << 28;

/// `KHR_mesh_quantization`: integer vertex attributes, which this reader reads as their values.
pub(super) const QUANTIZATION: &str = "KHR_mesh_quantization";

/// A validated glTF document with its buffers loaded and length-checked.
pub(super) struct Document {
    pub(super) path: PathBuf,
    pub(super) document: gltf::Document,
    pub(super) raw: serde_json::Value,
    pub(super) buffers: Vec<Vec<u8>>,
    /// Per buffer view, its bytes decoded when it is compressed (`EXT_meshopt_compression`).
    pub(super) decoded: Vec<Option<Vec<u8>>>,
}

impl Document {
    pub(super) fn open(path: &Path) -> Result<Document, LoadError> {
        let bytes = crate::io::read(path)?;
        let is_glb = bytes.starts_with(b"glTF")
            || path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
        let (json, bin) = if is_glb {
            split_glb(path, &bytes)?
        } else {
            (bytes.as_slice(), None)
        };
        let json_error = |message: String| LoadError::GltfJson {
            path: path.to_path_buf(),
            message,
        };
        let root: gltf::json::Root =
            gltf::json::deserialize::from_slice(json).map_err(|e| json_error(e.to_string()))?;
        // The same JSON untyped, for what an export copies as the file has it (materials
        // with their extensions, which the typed tree drops).
        let raw: serde_json::Value =
            serde_json::from_slice(json).map_err(|e| json_error(e.to_string()))?;
        precheck(&root).map_err(json_error)?;
        validate(&root).map_err(json_error)?;
        let document = gltf::Document::from_json_without_validation(root);
        let buffers = document
            .buffers()
            .map(|buffer| match is_placeholder(&raw, &buffer, is_glb) {
                true => Ok(Vec::new()),
                false => load_buffer(path, &buffer, bin),
            })
            .collect::<Result<Vec<_>, LoadError>>()?;
        let decoded = decode_views(path, &raw, &buffers)?;
        Ok(Document {
            path: path.to_path_buf(),
            document,
            raw,
            buffers,
            decoded,
        })
    }

    pub(super) fn data_error(&self, element: &str, message: String) -> LoadError {
        LoadError::GltfData {
            path: self.path.clone(),
            element: element.to_string(),
            message,
        }
    }

    pub(super) fn unsupported(&self, element: &str, what: String) -> LoadError {
        LoadError::GltfUnsupported {
            path: self.path.clone(),
            element: element.to_string(),
            what,
        }
    }

    pub(super) fn select_mesh(&self, wanted: Option<&str>) -> Result<gltf::Mesh<'_>, LoadError> {
        let names: Vec<Option<&str>> = self.document.meshes().map(|m| m.name()).collect();
        let index = match wanted {
            Some(w) => pick(w, &names),
            None => (!names.is_empty()).then_some(0),
        };
        index
            .and_then(|i| self.document.meshes().nth(i))
            .ok_or_else(|| LoadError::GltfNotFound {
                path: self.path.clone(),
                kind: "mesh",
                wanted: wanted.unwrap_or("(the first mesh)").to_string(),
                available: list_names(&names),
            })
    }
}

/// A buffer with no data of its own that only compressed views point at
/// (`EXT_meshopt_compression`'s fallback buffer): marked `"fallback": true`, or, in a file
/// that uses the extension, without a URI and not the GLB's BIN chunk (buffer 0). Nothing is
/// loaded for it; a plain view pointing into it is refused when read.
fn is_placeholder(raw: &serde_json::Value, buffer: &gltf::Buffer, glb: bool) -> bool {
    let json = &raw["buffers"][buffer.index()];
    let marked = json["extensions"][EXT_MESHOPT_COMPRESSION]["fallback"] == true;
    let bin_chunk = glb && buffer.index() == 0;
    marked || (uses(raw, EXT_MESHOPT_COMPRESSION) && json.get("uri").is_none() && !bin_chunk)
}

/// True when the file (its JSON `raw`) lists `extension` in `extensionsUsed`.
pub(super) fn uses(raw: &serde_json::Value, extension: &str) -> bool {
    raw["extensionsUsed"]
        .as_array()
        .is_some_and(|used| used.iter().any(|e| e == extension))
}

/// Every compressed buffer view decoded (`EXT_meshopt_compression`, [`super::meshopt`]); a
/// view that does not decode is refused with what is wrong.
fn decode_views(
    path: &Path,
    raw: &serde_json::Value,
    buffers: &[Vec<u8>],
) -> Result<Vec<Option<Vec<u8>>>, LoadError> {
    let views = raw["bufferViews"].as_array().map_or(&[][..], |v| v);
    views
        .iter()
        .enumerate()
        .map(|(i, view)| {
            let Some(ext) = view["extensions"].get(EXT_MESHOPT_COMPRESSION) else {
                return Ok(None);
            };
            super::meshopt_compression::decode_view(view, ext, buffers)
                .map(Some)
                .map_err(|message| LoadError::GltfCompressed {
                    path: path.to_path_buf(),
                    view: i,
                    message,
                })
        })
        .collect()
}

/// Splits a GLB file into its JSON chunk and optional BIN chunk, checking the
/// header and every chunk length against the actual byte count (GLB spec §4.4).
fn split_glb<'a>(path: &Path, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>), LoadError> {
    let error = |message: String| LoadError::GltfContainer {
        path: path.to_path_buf(),
        message,
    };
    let word = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at.checked_add(4)?)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(magic), Some(version), Some(length)) = (bytes.get(0..4), word(4), word(8)) else {
        return Err(error(format!(
            "the file has {} bytes, less than the 12-byte GLB header",
            bytes.len()
        )));
    };
    if magic != b"glTF" {
        return Err(error(format!(
            "bad magic {magic:?}: a GLB file starts with \"glTF\""
        )));
    }
    if version != 2 {
        return Err(error(format!(
            "GLB version {version}; only version 2 is supported"
        )));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(error(format!(
            "the header declares {length} bytes but the file has {}: it is truncated",
            bytes.len()
        )));
    }
    let mut json = None;
    let mut bin = None;
    let mut at = 12;
    let mut chunk = 0;
    while at < length {
        let (Some(chunk_length), Some(kind)) = (word(at), word(at + 4)) else {
            return Err(error(format!(
                "chunk {chunk} header at byte {at} runs past the end"
            )));
        };
        let start = at + 8;
        let end = start
            .checked_add(chunk_length as usize)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                error(format!(
                    "chunk {chunk} at byte {at} declares {chunk_length} bytes, but only {} remain",
                    length.saturating_sub(start)
                ))
            })?;
        let body = &bytes[start..end];
        match (chunk, kind) {
            (0, 0x4E4F_534A) => json = Some(body),
            (0, _) => {
                return Err(error(format!(
                    "the first chunk has type 0x{kind:08X}; it must be JSON"
                )))
            }
            (1, 0x004E_4942) => bin = Some(body),
            // Unknown chunk types must be ignored (GLB spec §4.4.3).
            _ => {}
        }
        at = end;
        chunk += 1;
    }
    match json {
        Some(json) => Ok((json, bin)),
        None => Err(error("the file has no JSON chunk".to_string())),
    }
}

/// What the `gltf` validator misses, checked before it and the accessors run:
/// it indexes `accessors[POSITION]` unchecked, and it validates an animation's
/// samplers but never its channels, so an unknown target path or an
/// out-of-range target node would reach `Checked::unwrap` or an unchecked index
/// in the crate's accessors and panic.
fn precheck(root: &gltf::json::Root) -> Result<(), String> {
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            if channel.target.node.value() >= root.nodes.len() {
                return Err(format!(
                    "animations[{a}].channels[{c}].target.node refers to node {}, but the file has {} nodes",
                    channel.target.node.value(),
                    root.nodes.len()
                ));
            }
            if channel.target.path == gltf::json::validation::Checked::Invalid {
                return Err(format!(
                    "animations[{a}].channels[{c}].target.path is not one of translation, rotation, scale, weights"
                ));
            }
        }
    }
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &primitive.attributes {
                if index.value() >= root.accessors.len() {
                    return Err(format!(
                        "meshes[{m}].primitives[{p}].attributes.{} refers to accessor {}, but the file has {} accessors",
                        semantic.to_string(),
                        index.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    check_hierarchy(root)
}

/// The `gltf` crate's validation (what `gltf::Document::from_json` runs), minus its reports
/// about things the glTF 2.0 specification allows (gltf-rs/gltf#346), which every reader here
/// handles:
/// * an accessor with neither `bufferView` nor `sparse` ("When undefined, the accessor MUST be
///   initialized with zeros"): read as zeros (`Document::gather`);
/// * a texture without `source` ("an extension or other mechanism SHOULD supply an alternate
///   texture source"): no image morphlod can use, so the material is drawn untextured;
/// * a primitive without POSITION ("client implementations SHOULD skip primitive's
///   rendering"): skipped (`Document::geometry`).
///
/// Everything else the crate reports is kept: its accessors index and unwrap what it checked.
fn validate(root: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::validation::{Error, Validate};
    let allowed = |path: &str, error: Error| {
        // The extensions this reader implements (the `gltf` crate does not).
        if error == Error::Unsupported {
            return [QUANTIZATION, EXT_MESHOPT_COMPRESSION].iter().any(|e| {
                path.starts_with("extensionsRequired[") && path.ends_with(&format!("\"{e}\""))
            });
        }
        if error != Error::Missing {
            return false;
        }
        let index_of = |prefix: &str, suffix: &str| -> Option<usize> {
            path.strip_prefix(prefix)?
                .strip_suffix(suffix)?
                .parse()
                .ok()
        };
        if let Some(a) = index_of("accessors[", "].bufferView") {
            return root
                .accessors
                .get(a)
                .is_some_and(|a| a.buffer_view.is_none());
        }
        if let Some(t) = index_of("textures[", "].source") {
            return root
                .textures
                .get(t)
                .is_some_and(|t| t.source.value() == u32::MAX as usize);
        }
        // `meshes[m].primitives[p].attributes["POSITION"]`, reported only when it is absent.
        path.starts_with("meshes[") && path.ends_with(".attributes[\"POSITION\"]")
    };
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        let path = path().0;
        if !allowed(&path, error) {
            errors.push(format!("{path}: {error}"));
        }
    });
    match errors.is_empty() {
        true => Ok(()),
        false => Err(errors.join("; ")),
    }
}

/// The node hierarchy must be a set of disjoint strict trees (glTF 2.0, "Nodes and
/// Hierarchy"): no node has two parents and none is its own ancestor. A file that breaks this
/// is invalid, so it is refused with the node named rather than placed by some partial walk.
fn check_hierarchy(root: &gltf::json::Root) -> Result<(), String> {
    let count = root.nodes.len();
    let mut parent: Vec<Option<usize>> = vec![None; count];
    for (n, node) in root.nodes.iter().enumerate() {
        for child in node.children.iter().flatten() {
            let c = child.value();
            match parent.get_mut(c) {
                None => {
                    return Err(format!(
                        "nodes[{n}].children refers to node {c}, but the file has {count} nodes"
                    ))
                }
                Some(Some(p)) => {
                    return Err(format!(
                        "node {c} is a child of both node {p} and node {n}; a node has at most one parent"
                    ))
                }
                Some(slot) => *slot = Some(n),
            }
        }
    }
    // 0: not seen, 1: on the walk from the current start, 2: leads to a root.
    let mut state = vec![0u8; count];
    let mut walk = Vec::new();
    for start in 0..count {
        let mut current = Some(start);
        while let Some(c) = current {
            match state[c] {
                2 => break,
                1 => {
                    return Err(format!(
                        "node {c} is its own ancestor: the node hierarchy has a cycle, glTF allows only trees"
                    ))
                }
                _ => {
                    state[c] = 1;
                    walk.push(c);
                    current = parent[c];
                }
            }
        }
        for c in walk.drain(..) {
            state[c] = 2;
        }
    }
    Ok(())
}

/// One buffer's bytes (exactly `byteLength`) from the GLB BIN chunk, a base64
/// data URI or a file relative to the glTF file.
fn load_buffer(
    path: &Path,
    buffer: &gltf::Buffer,
    bin: Option<&[u8]>,
) -> Result<Vec<u8>, LoadError> {
    let element = format!("buffer {}", buffer.index());
    let data_error = |message: String| LoadError::GltfData {
        path: path.to_path_buf(),
        element: element.clone(),
        message,
    };
    let data = match buffer.source() {
        gltf::buffer::Source::Bin => bin
            .ok_or_else(|| {
                data_error("refers to the GLB binary chunk, but the file has none".to_string())
            })?
            .to_vec(),
        gltf::buffer::Source::Uri(uri) => read_uri(path, uri).map_err(|e| match e {
            UriError::External { file, source } => LoadError::GltfExternal {
                path: path.to_path_buf(),
                buffer: buffer.index(),
                file,
                source,
            },
            UriError::Unsupported(what) => LoadError::GltfUnsupported {
                path: path.to_path_buf(),
                element: element.clone(),
                what,
            },
            UriError::Data(message) => data_error(message),
        })?,
    };
    if data.len() < buffer.length() {
        return Err(data_error(format!(
            "declares byteLength {} but its data has only {} bytes",
            buffer.length(),
            data.len()
        )));
    }
    let mut data = data;
    data.truncate(buffer.length());
    Ok(data)
}

/// Why a URI's bytes could not be had.
pub(super) enum UriError {
    /// A file relative to the glTF file that cannot be read.
    External {
        file: PathBuf,
        source: std::io::Error,
    },
    /// A scheme or encoding morphlod does not read.
    Unsupported(String),
    /// A malformed data URI.
    Data(String),
}

/// The bytes a glTF URI names: a base64 data URI, or a percent-encoded path relative to
/// the glTF file at `path` (remote URIs are not fetched).
pub(super) fn read_uri(path: &Path, uri: &str) -> Result<Vec<u8>, UriError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((header, payload)) = rest.split_once(',') else {
            return Err(UriError::Data(
                "data URI has no ',' before its data".to_string(),
            ));
        };
        if !header.ends_with(";base64") {
            return Err(UriError::Unsupported(format!(
                "a data URI that is not base64 (data:{header})"
            )));
        }
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| UriError::Data(format!("data URI is not valid base64: {e}")));
    }
    if uri.contains("://") {
        return Err(UriError::Unsupported(format!("the non-local URI '{uri}'")));
    }
    let file = path
        .parent()
        .unwrap_or(Path::new(""))
        .join(percent_decode(uri));
    std::fs::read(&file).map_err(|source| UriError::External { file, source })
}

/// URIs in glTF are percent-encoded (`my%20mesh.bin`).
pub(super) fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (bytes[i], hex) {
            (b'%', Some(byte)) => {
                out.push(byte);
                i += 3;
            }
            (b, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}
