//! One LOD as a glTF mesh: the kept vertices' attributes and morph targets (sparse where
//! that is smaller), the source's raw attributes byte for byte, and the indices.

use super::Lod;
use crate::io::gltf::write::{
    bounds, f32_bytes, index_accessor, number, quote, vec3_accessor, Bin, Json, ARRAY_BUFFER,
    FLOAT, UNSIGNED_INT,
};
use crate::io::gltf::{RawAttribute, SourceScene};
use crate::morph::Morph;

/// The values of `source` at the LOD's vertices.
fn gather<T: Copy>(source: &[T], lod: &Lod) -> Vec<T> {
    lod.source_vertex
        .iter()
        .map(|&v| source[v as usize])
        .collect()
}

/// A morph target's deltas: sparse (only the entries that are not `+0.0` in every
/// component, the rest read as zeros) when that is smaller, as the sources usually store
/// them (a target moves part of the mesh). A `-0.0` is stored explicitly, so every value
/// reads back bit for bit.
fn delta_accessor(bin: &mut Bin, json: &mut Json, data: &[[f32; 3]], with_bounds: bool) -> usize {
    let mut moved: Vec<u32> = (0..data.len() as u32)
        .filter(|&v| data[v as usize].iter().any(|x| x.to_bits() != 0))
        .collect();
    // Sparse costs 4 index bytes + 12 value bytes per moved vertex, dense 12 per vertex.
    if moved.len() * 16 >= data.len() * 12 {
        return vec3_accessor(bin, json, data, with_bounds);
    }
    let bounds = with_bounds
        .then(|| bounds(data))
        .map_or(String::new(), |(lo, hi)| {
            let list = |v: Vec<f32>| v.into_iter().map(number).collect::<Vec<_>>().join(",");
            format!(r#","min":[{}],"max":[{}]"#, list(lo), list(hi))
        });
    // No bufferView: the accessor starts as zeros (glTF 2.0, 3.6.2.3), then the moved
    // vertices are substituted. A target that moves nothing still lists vertex 0: readers
    // such as the `gltf` crate refuse an accessor with neither a bufferView nor a sparse part.
    if moved.is_empty() {
        moved.push(0);
    }
    let indices = bin.push(moved.iter().flat_map(|i| i.to_le_bytes()).collect());
    let indices = json.view(indices, None);
    let values = moved
        .iter()
        .flat_map(|&v| data[v as usize])
        .collect::<Vec<f32>>();
    let values = json.view(bin.push(f32_bytes(values.iter())), None);
    let sparse = format!(
        r#","sparse":{{"count":{},"indices":{{"bufferView":{indices},"componentType":{UNSIGNED_INT}}},"values":{{"bufferView":{values}}}}}"#,
        moved.len()
    );
    json.accessors.push(format!(
        r#"{{"componentType":{FLOAT},"count":{},"type":"VEC3"{bounds}{sparse}}}"#,
        data.len()
    ));
    json.accessors.len() - 1
}

/// `data`, `width` floats per element of glTF type `kind`, as a buffer view (with `target`,
/// when given) and accessor.
pub(super) fn flat_accessor(
    bin: &mut Bin,
    json: &mut Json,
    data: &[f32],
    width: usize,
    kind: &str,
    target: Option<u32>,
) -> usize {
    let view = json.view(bin.push(f32_bytes(data.iter())), target);
    json.accessor(view, FLOAT, data.len() / width, kind, None)
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

/// `attribute`'s elements at the LOD's vertices, byte for byte, as a vertex buffer view (its
/// stride padded to 4 bytes, as glTF asks of vertex attributes) and accessor.
fn raw_accessor(bin: &mut Bin, json: &mut Json, attribute: &RawAttribute, lod: &Lod) -> usize {
    let size = attribute.element_size();
    let stride = size.next_multiple_of(4);
    let mut data = Vec::with_capacity(stride * lod.source_vertex.len());
    for &v in &lod.source_vertex {
        let v = v as usize;
        data.extend_from_slice(&attribute.data[v * size..(v + 1) * size]);
        data.resize(data.len() + stride - size, 0);
    }
    let view = json.strided_view(
        bin.push(data),
        (stride != size).then_some(stride),
        Some(ARRAY_BUFFER),
    );
    json.normalized_accessor(
        view,
        attribute.component_type,
        attribute.normalized,
        lod.source_vertex.len(),
        attribute.kind,
        None,
    )
}

/// One mesh's JSON for `lod`, its data pushed into `bin`; `raw_names`: what the source's raw
/// attributes are written as ([`written_names`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn mesh_json(
    morph: &Morph,
    lod: &Lod,
    name: &str,
    default_weights: &[f32],
    source: &SourceScene,
    raw_names: &[String],
    bin: &mut Bin,
    json: &mut Json,
) -> String {
    let attributes = morph.attributes();
    let mut fields = vec![format!(
        r#""POSITION":{}"#,
        vec3_accessor(bin, json, &gather(morph.base(), lod), true)
    )];
    if let Some(normals) = &attributes.normals {
        let acc = vec3_accessor(bin, json, &gather(normals, lod), false);
        fields.push(format!(r#""NORMAL":{acc}"#));
    }
    if let Some(uvs) = &attributes.uvs {
        let data: Vec<f32> = gather(uvs, lod).into_iter().flatten().collect();
        let acc = flat_accessor(bin, json, &data, 2, "VEC2", Some(ARRAY_BUFFER));
        fields.push(format!(r#""TEXCOORD_0":{acc}"#));
    }
    if let Some(colors) = &attributes.colors {
        let data: Vec<f32> = gather(colors, lod).into_iter().flatten().collect();
        let acc = flat_accessor(bin, json, &data, 4, "VEC4", Some(ARRAY_BUFFER));
        fields.push(format!(r#""COLOR_0":{acc}"#));
    }
    for (attribute, name) in source.attributes.iter().zip(raw_names) {
        let acc = raw_accessor(bin, json, attribute, lod);
        fields.push(format!("{}:{acc}", quote(name)));
    }
    // Target NORMAL deltas only where the base has normals and every target gives them:
    // a target attribute needs its base attribute.
    let normal_deltas =
        attributes.normals.is_some() && morph.targets().iter().all(|t| t.normal_deltas.is_some());
    let targets: Vec<String> = morph
        .targets()
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let pos = delta_accessor(bin, json, &gather(&t.deltas, lod), true);
            let mut fields = vec![format!(r#""POSITION":{pos}"#)];
            if let Some(nd) = t.normal_deltas.as_ref().filter(|_| normal_deltas) {
                let n = delta_accessor(bin, json, &gather(nd, lod), false);
                fields.push(format!(r#""NORMAL":{n}"#));
            }
            for attribute in source.target_attributes.get(k).into_iter().flatten() {
                let acc = raw_accessor(bin, json, attribute, lod);
                fields.push(format!("{}:{acc}", quote(&attribute.semantic)));
            }
            format!("{{{}}}", fields.join(","))
        })
        .collect();
    let index_acc = index_accessor(bin, json, &lod.triangles);
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
