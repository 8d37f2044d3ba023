//! One LOD as a glTF mesh: the kept vertices' attributes and morph targets (sparse where
//! that is smaller), the source's raw attributes byte for byte, and the indices; with
//! `--quantize` positions, normals, UVs and deltas as `KHR_mesh_quantization` integers.

use super::compress::{Buffers, Codec};
use super::quantize::{snorm, unorm16, Grid, QuantizeOptions};
use super::Lod;
use crate::io::gltf::write::{
    f32_bytes, number, quote, Json, ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER, FLOAT, UNSIGNED_INT,
};
use crate::io::gltf::{RawAttribute, SourceScene};
use crate::morph::Morph;

// The integer component types quantized attributes are written in.
const BYTE: u32 = 5120;
const UNSIGNED_BYTE: u32 = 5121;
const SHORT: u32 = 5122;
const UNSIGNED_SHORT: u32 = 5123;

/// The values of `source` at the LOD's vertices.
fn gather<T: Copy>(source: &[T], lod: &Lod) -> Vec<T> {
    lod.source_vertex
        .iter()
        .map(|&v| source[v as usize])
        .collect()
}

/// One attribute's elements as its accessor reads them: tightly packed, `size` bytes each.
pub(super) struct Elements {
    bytes: Vec<u8>,
    size: usize,
    component: u32,
    normalized: bool,
    kind: &'static str,
    /// `,"min":[..],"max":[..]`, or empty.
    bounds: String,
}

impl Elements {
    /// `FLOAT` elements of `N` components, with their bounds when `with_bounds`.
    pub(super) fn floats<const N: usize>(data: &[[f32; N]], with_bounds: bool) -> Elements {
        let bounds = match with_bounds {
            true => bounds_json(data.iter().map(|e| e.map(f64::from)), number_f64),
            false => String::new(),
        };
        Elements {
            bytes: f32_bytes(data.iter().flatten()),
            size: 4 * N,
            component: FLOAT,
            normalized: false,
            kind: KINDS[N],
            bounds,
        }
    }

    /// Integer elements of `N` components, each written in `size` bytes (1 or 2) of component
    /// type `component`, with their bounds when `with_bounds`.
    fn integers<const N: usize>(
        data: &[[i32; N]],
        component: u32,
        normalized: bool,
        with_bounds: bool,
    ) -> Elements {
        let size = if matches!(component, BYTE | UNSIGNED_BYTE) {
            1
        } else {
            2
        };
        let bytes = data
            .iter()
            .flatten()
            .flat_map(|&c| c.to_le_bytes().into_iter().take(size))
            .collect();
        let bounds = match with_bounds {
            true => bounds_json(data.iter().map(|e| e.map(f64::from)), |x| {
                (x as i64).to_string()
            }),
            false => String::new(),
        };
        Elements {
            bytes,
            size: size * N,
            component,
            normalized,
            kind: KINDS[N],
            bounds,
        }
    }

    fn count(&self) -> usize {
        self.bytes.len() / self.size
    }

    /// The accessor's JSON over `view` (`None`: no bufferView), with `more` members after.
    fn accessor(&self, json: &mut Json, view: Option<usize>, more: &str) -> usize {
        let view = view.map_or(String::new(), |v| format!(r#""bufferView":{v},"#));
        let normalized = if self.normalized {
            r#","normalized":true"#
        } else {
            ""
        };
        json.accessors.push(format!(
            r#"{{{view}"componentType":{},"count":{}{normalized},"type":"{}"{}{more}}}"#,
            self.component,
            self.count(),
            self.kind,
            self.bounds
        ));
        json.accessors.len() - 1
    }
}

const KINDS: [&str; 5] = ["", "SCALAR", "VEC2", "VEC3", "VEC4"];

/// `,"min":[..],"max":[..]` of `elements`, each number written by `write`.
fn bounds_json<const N: usize>(
    elements: impl Iterator<Item = [f64; N]>,
    write: impl Fn(f64) -> String,
) -> String {
    let mut lo = [f64::INFINITY; N];
    let mut hi = [f64::NEG_INFINITY; N];
    for e in elements {
        for k in 0..N {
            lo[k] = lo[k].min(e[k]);
            hi[k] = hi[k].max(e[k]);
        }
    }
    let list = |v: [f64; N]| v.map(&write).join(",");
    format!(r#","min":[{}],"max":[{}]"#, list(lo), list(hi))
}

/// An `f32` value held in an `f64` as JSON ([`number`]).
fn number_f64(x: f64) -> String {
    number(x as f32)
}

/// `elements` as a vertex buffer view (each element padded to 4 bytes, as glTF asks of vertex
/// attributes, with `byteStride` when padded) and its accessor.
pub(super) fn vertex_accessor(buffers: &mut Buffers, elements: &Elements, codec: Codec) -> usize {
    let view = padded_view(buffers, elements, Some(ARRAY_BUFFER), codec);
    elements.accessor(&mut buffers.json, Some(view), "")
}

/// A buffer view of `elements`, each padded to a multiple of 4 bytes (`byteStride` written
/// when that pads).
fn padded_view(
    buffers: &mut Buffers,
    elements: &Elements,
    target: Option<u32>,
    codec: Codec,
) -> usize {
    let (size, stride) = (elements.size, elements.size.next_multiple_of(4));
    let mut data = Vec::with_capacity(stride * elements.count());
    for e in elements.bytes.chunks_exact(size) {
        data.extend_from_slice(e);
        data.resize(data.len() + stride - size, 0);
    }
    buffers.view(data, stride, stride != size, target, codec)
}

/// The accessors of every target's deltas of one attribute. Compressed, the targets' deltas
/// of each element size are one buffer view, one accessor after the other (one codec stream
/// and one view's JSON instead of one per target); else each target's are
/// [`delta_accessor`]'s.
fn delta_accessors(buffers: &mut Buffers, targets: &[Elements]) -> Vec<usize> {
    if !buffers.compress {
        return targets.iter().map(|e| delta_accessor(buffers, e)).collect();
    }
    let mut accessors = vec![0; targets.len()];
    let mut sizes: Vec<usize> = targets.iter().map(|e| e.size).collect();
    sizes.sort_unstable();
    sizes.dedup();
    for size in sizes {
        let members: Vec<usize> = (0..targets.len())
            .filter(|&k| targets[k].size == size)
            .collect();
        let stride = size.next_multiple_of(4);
        let mut data = Vec::new();
        let mut offsets = Vec::with_capacity(members.len());
        for &k in &members {
            offsets.push(data.len());
            for e in targets[k].bytes.chunks_exact(size) {
                data.extend_from_slice(e);
                data.resize(data.len() + stride - size, 0);
            }
        }
        let view = buffers.view(data, stride, true, Some(ARRAY_BUFFER), Codec::Attributes);
        for (&k, offset) in members.iter().zip(offsets) {
            let at = match offset {
                0 => String::new(),
                o => format!(r#","byteOffset":{o}"#),
            };
            accessors[k] = targets[k].accessor(&mut buffers.json, Some(view), &at);
        }
    }
    accessors
}

/// A morph target's deltas: sparse (only the elements that are not all zero bytes, i.e. not
/// `+0.0` or `0` in every component; the rest read as zeros) when that is smaller, as the
/// sources usually store them (a target moves part of the mesh). A `-0.0` is stored
/// explicitly, so every value reads back bit for bit. Compressed, always dense: runs of zero
/// deltas cost the codec next to nothing, and dense views are what the codec is made for.
fn delta_accessor(buffers: &mut Buffers, elements: &Elements) -> usize {
    let size = elements.size;
    let mut moved: Vec<u32> = (0..elements.count() as u32)
        .filter(|&v| {
            let v = v as usize;
            elements.bytes[v * size..(v + 1) * size]
                .iter()
                .any(|&b| b != 0)
        })
        .collect();
    // Sparse costs 4 index bytes + the value per moved vertex, dense the padded value per
    // vertex.
    let dense = size.next_multiple_of(4) * elements.count();
    if buffers.compress || moved.len() * (4 + size) >= dense {
        return vertex_accessor(buffers, elements, Codec::Attributes);
    }
    // No bufferView: the accessor starts as zeros (glTF 2.0, 3.6.2.3), then the moved
    // vertices are substituted. A target that moves nothing still lists vertex 0: readers
    // such as the `gltf` crate refuse an accessor with neither a bufferView nor a sparse part.
    if moved.is_empty() {
        moved.push(0);
    }
    let indices: Vec<u8> = moved.iter().flat_map(|i| i.to_le_bytes()).collect();
    let indices = buffers.view(indices, 4, false, None, Codec::Attributes);
    let values: Vec<u8> = moved
        .iter()
        .flat_map(|&v| &elements.bytes[v as usize * size..(v as usize + 1) * size])
        .copied()
        .collect();
    let values = buffers.view(values, size, false, None, Codec::Attributes);
    let sparse = format!(
        r#","sparse":{{"count":{},"indices":{{"bufferView":{indices},"componentType":{UNSIGNED_INT}}},"values":{{"bufferView":{values}}}}}"#,
        moved.len()
    );
    elements.accessor(&mut buffers.json, None, &sparse)
}

/// `data`, `width` floats per element of glTF type `kind`, as a buffer view (with `target`,
/// when given) and accessor; compressed (losslessly) like the rest.
pub(super) fn flat_accessor(
    buffers: &mut Buffers,
    data: &[f32],
    width: usize,
    kind: &str,
    target: Option<u32>,
) -> usize {
    let view = buffers.view(
        f32_bytes(data.iter()),
        4 * width,
        false,
        target,
        Codec::Attributes,
    );
    buffers
        .json
        .accessor(view, FLOAT, data.len() / width, kind, None)
}

/// The name each raw attribute is written under. glTF numbers the sets of TEXCOORD, COLOR,
/// JOINTS and WEIGHTS from 0 without gaps, so each carried set is renumbered in order after
/// the morph's own (TEXCOORD_0 for its UVs, COLOR_0 for its colours); the others keep theirs.
pub(super) fn written_names(morph: &Morph, attributes: &[RawAttribute]) -> Vec<String> {
    let set = |semantic: &str| {
        let (prefix, n) = semantic.rsplit_once('_')?;
        let n: u32 = n.parse().ok()?;
        ["TEXCOORD", "COLOR", "JOINTS", "WEIGHTS"]
            .contains(&prefix)
            .then(|| (prefix.to_string(), n))
    };
    let own = morph.attributes();
    attributes
        .iter()
        .map(|a| match set(&a.semantic) {
            Some((prefix, n)) => {
                let first = match prefix.as_str() {
                    "TEXCOORD" => own.uvs.is_some() as usize,
                    "COLOR" => own.colors.is_some() as usize,
                    _ => 0,
                };
                let before = attributes
                    .iter()
                    .filter_map(|b| set(&b.semantic))
                    .filter(|(p, m)| *p == prefix && *m < n)
                    .count();
                format!("{prefix}_{}", first + before)
            }
            None => a.semantic.clone(),
        })
        .collect()
}

/// `attribute`'s elements at the LOD's vertices, byte for byte, as a vertex buffer view and
/// accessor.
fn raw_accessor(buffers: &mut Buffers, attribute: &RawAttribute, lod: &Lod) -> usize {
    let size = attribute.element_size();
    let mut bytes = Vec::with_capacity(size * lod.source_vertex.len());
    for &v in &lod.source_vertex {
        let v = v as usize;
        bytes.extend_from_slice(&attribute.data[v * size..(v + 1) * size]);
    }
    let elements = Elements {
        bytes,
        size,
        component: attribute.component_type,
        normalized: attribute.normalized,
        kind: attribute.kind,
        bounds: String::new(),
    };
    vertex_accessor(buffers, &elements, Codec::Attributes)
}

/// What `--quantize` writes with: the options, the positions' grid and every target's grid
/// deltas (`deltas[k][v]`, source vertex `v`).
pub(super) struct Quantization {
    pub(super) options: QuantizeOptions,
    pub(super) grid: Grid,
    pub(super) deltas: Vec<Vec<[i16; 3]>>,
}

/// Normal-like values (unit normals, normal deltas) as normalized integers of `bits`.
fn snorm_elements(data: &[[f32; 3]], bits: u32) -> Elements {
    let values: Vec<[i32; 3]> = data
        .iter()
        .map(|n| n.map(|x| snorm(x, bits) as i32))
        .collect();
    let component = if bits <= 8 { BYTE } else { SHORT };
    Elements::integers(&values, component, true, false)
}

/// Unit normals as a vertex accessor: compressed, in the OCTAHEDRAL filter (`bits` per
/// octahedral coordinate, decoded to normalized `BYTE`s or `SHORT`s); else as normalized
/// integers of `bits`.
fn normal_accessor(buffers: &mut Buffers, normals: &[[f32; 3]], bits: u32) -> usize {
    if !buffers.compress {
        return vertex_accessor(buffers, &snorm_elements(normals, bits), Codec::Attributes);
    }
    let unit: Vec<[f32; 4]> = normals.iter().map(|n| [n[0], n[1], n[2], 0.0]).collect();
    let (bytes, component, stride): (Vec<u8>, u32, usize) = if bits <= 8 {
        let encoded = meshopt::encode_filter_oct::<i8>(&unit, bits as i32);
        let bytes = encoded.iter().flatten().map(|&c| c as u8).collect();
        (bytes, BYTE, 4)
    } else {
        let encoded = meshopt::encode_filter_oct::<i16>(&unit, bits as i32);
        let bytes = encoded
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        (bytes, SHORT, 8)
    };
    let view = buffers.view(bytes, stride, true, Some(ARRAY_BUFFER), Codec::Octahedral);
    buffers
        .json
        .normalized_accessor(view, component, true, normals.len(), "VEC3", None)
}

/// UVs as normalized `UNSIGNED_SHORT`s of `bits` when all lie in `[0, 1]`, else `FLOAT`.
fn uv_elements(uvs: &[[f32; 2]], bits: u32) -> Elements {
    if !uvs.iter().flatten().all(|x| (0.0..=1.0).contains(x)) {
        return Elements::floats(uvs, false);
    }
    let values: Vec<[i32; 2]> = uvs
        .iter()
        .map(|uv| uv.map(|x| unorm16(x, bits) as i32))
        .collect();
    Elements::integers(&values, UNSIGNED_SHORT, true, false)
}

/// One mesh's JSON for `lod`, its data pushed into `buffers`; `raw_names`: what the source's
/// raw attributes are written as ([`written_names`]); `quantization`: with `--quantize`.
#[allow(clippy::too_many_arguments)]
pub(super) fn mesh_json(
    morph: &Morph,
    lod: &Lod,
    name: &str,
    default_weights: &[f32],
    source: &SourceScene,
    raw_names: &[String],
    quantization: Option<&Quantization>,
    buffers: &mut Buffers,
) -> String {
    let attributes = morph.attributes();
    let positions = match quantization {
        Some(q) => {
            let values: Vec<[i32; 3]> = lod
                .source_vertex
                .iter()
                .map(|&v| q.grid.quantize(morph.base()[v as usize]).map(i32::from))
                .collect();
            Elements::integers(&values, UNSIGNED_SHORT, false, true)
        }
        None => Elements::floats(&gather(morph.base(), lod), true),
    };
    let mut fields = vec![format!(
        r#""POSITION":{}"#,
        vertex_accessor(buffers, &positions, Codec::Attributes)
    )];
    let normal_bits = quantization.map(|q| q.options.normal_bits);
    if let Some(normals) = &attributes.normals {
        let normals = gather(normals, lod);
        let acc = match normal_bits {
            Some(bits) => normal_accessor(buffers, &normals, bits),
            None => vertex_accessor(
                buffers,
                &Elements::floats(&normals, false),
                Codec::Attributes,
            ),
        };
        fields.push(format!(r#""NORMAL":{acc}"#));
    }
    if let Some(uvs) = &attributes.uvs {
        let uvs = gather(uvs, lod);
        let elements = match quantization {
            Some(q) => uv_elements(&uvs, q.options.uv_bits),
            None => Elements::floats(&uvs, false),
        };
        let acc = vertex_accessor(buffers, &elements, Codec::Attributes);
        fields.push(format!(r#""TEXCOORD_0":{acc}"#));
    }
    if let Some(colors) = &attributes.colors {
        let elements = Elements::floats(&gather(colors, lod), false);
        let acc = vertex_accessor(buffers, &elements, Codec::Attributes);
        fields.push(format!(r#""COLOR_0":{acc}"#));
    }
    for (attribute, name) in source.attributes.iter().zip(raw_names) {
        let acc = raw_accessor(buffers, attribute, lod);
        fields.push(format!("{}:{acc}", quote(name)));
    }
    // Target NORMAL deltas only where the base has normals and every target gives them:
    // a target attribute needs its base attribute.
    let with_normal_deltas =
        attributes.normals.is_some() && morph.targets().iter().all(|t| t.normal_deltas.is_some());
    let position_deltas: Vec<Elements> = morph
        .targets()
        .iter()
        .enumerate()
        .map(|(k, t)| match quantization {
            Some(q) => {
                let values: Vec<[i32; 3]> = gather(&q.deltas[k], lod)
                    .into_iter()
                    .map(|d| d.map(i32::from))
                    .collect();
                Elements::integers(&values, SHORT, false, true)
            }
            None => Elements::floats(&gather(&t.deltas, lod), true),
        })
        .collect();
    let normal_deltas: Vec<Elements> = morph
        .targets()
        .iter()
        .filter_map(|t| t.normal_deltas.as_ref().filter(|_| with_normal_deltas))
        .map(|nd| {
            let nd = gather(nd, lod);
            match normal_bits {
                // A component past ±1 (a normal turned by more than 90°) is clamped.
                Some(bits) => snorm_elements(&nd, bits),
                None => Elements::floats(&nd, false),
            }
        })
        .collect();
    let positions = delta_accessors(buffers, &position_deltas);
    let normals = delta_accessors(buffers, &normal_deltas);
    let targets: Vec<String> = (0..morph.targets().len())
        .map(|k| {
            let mut fields = vec![format!(r#""POSITION":{}"#, positions[k])];
            if let Some(n) = normals.get(k) {
                fields.push(format!(r#""NORMAL":{n}"#));
            }
            for attribute in source.target_attributes.get(k).into_iter().flatten() {
                let acc = raw_accessor(buffers, attribute, lod);
                fields.push(format!("{}:{acc}", quote(&attribute.semantic)));
            }
            format!("{{{}}}", fields.join(","))
        })
        .collect();
    let index_acc = index_accessor(buffers, lod, quantization.is_some());
    let primitive_targets = if targets.is_empty() {
        String::new()
    } else {
        format!(r#","targets":[{}]"#, targets.join(","))
    };
    let mesh_weights = if targets.is_empty() {
        String::new()
    } else {
        let names: Vec<String> = morph.targets().iter().map(|t| quote(&t.name)).collect();
        let weights: Vec<String> = default_weights.iter().map(|&w| number(w)).collect();
        format!(
            r#","weights":[{}],"extras":{{"targetNames":[{}]}}"#,
            weights.join(","),
            names.join(",")
        )
    };
    format!(
        r#"{{"name":{},"primitives":[{{"attributes":{{{}}},"indices":{index_acc},"material":0,"mode":4{primitive_targets}}}]{mesh_weights}}}"#,
        quote(name),
        fields.join(",")
    )
}

/// The LOD's triangles as an index view (a TRIANGLES stream when compressed) and its SCALAR
/// accessor: `UNSIGNED_SHORT` when `narrow` and the LOD has at most 65,535 vertices (glTF
/// reserves the type's largest value), else `UNSIGNED_INT`.
fn index_accessor(buffers: &mut Buffers, lod: &Lod, narrow: bool) -> usize {
    let flat = lod.triangles.iter().flatten();
    let (bytes, size, component): (Vec<u8>, usize, u32) =
        if narrow && lod.source_vertex.len() <= u16::MAX as usize {
            let bytes = flat.flat_map(|&i| (i as u16).to_le_bytes()).collect();
            (bytes, 2, UNSIGNED_SHORT)
        } else {
            (
                flat.flat_map(|i| i.to_le_bytes()).collect(),
                4,
                UNSIGNED_INT,
            )
        };
    let view = buffers.view(
        bytes,
        size,
        false,
        Some(ELEMENT_ARRAY_BUFFER),
        Codec::Triangles,
    );
    buffers
        .json
        .accessor(view, component, lod.triangles.len() * 3, "SCALAR", None)
}
