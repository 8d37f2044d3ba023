//! The material: the morph's own (OBJ, OFF, PLY, a supermesh) or the source's glTF
//! material whole, with its textures, samplers and images embedded.

use super::compress::{Buffers, Codec};
use crate::io::gltf::write::{number, quote};
use crate::io::gltf::{texture_infos, SourceMaterial, SourceScene};
use crate::morph::{ImageFormat, Morph};
use std::fmt::Write as _;

/// The morph's own material (and its texture, image and sampler) as top-level JSON members,
/// for a source without a glTF material (OBJ, OFF, PLY, a supermesh): base colour and
/// texture, written as a dielectric (`metallicFactor` 0), which is what those formats' diffuse
/// colour means; glTF's default of 1 would draw it as bare metal.
pub(super) fn material_json(morph: &Morph, buffers: &mut Buffers) -> String {
    let material = &morph.attributes().material;
    let name = material
        .name
        .as_ref()
        .map_or(String::new(), |n| format!(r#""name":{},"#, quote(n)));
    let factor: Vec<String> = material.base_color.iter().map(|&c| number(c)).collect();
    let Some(texture) = &material.texture else {
        return format!(
            r#""materials":[{{{name}"pbrMetallicRoughness":{{"baseColorFactor":[{}],"metallicFactor":0}}}}]"#,
            factor.join(",")
        );
    };
    let image = image_json(&texture.bytes, texture.format, buffers);
    let s = &texture.sampler;
    let mut sampler = format!(r#""wrapS":{},"wrapT":{}"#, s.wrap_s, s.wrap_t);
    if let Some(f) = s.mag_filter {
        let _ = write!(sampler, r#","magFilter":{f}"#);
    }
    if let Some(f) = s.min_filter {
        let _ = write!(sampler, r#","minFilter":{f}"#);
    }
    format!(
        r#""materials":[{{{name}"pbrMetallicRoughness":{{"baseColorFactor":[{}],"baseColorTexture":{{"index":0}},"metallicFactor":0}}}}],"textures":[{{"sampler":0,"source":0}}],"samplers":[{{{sampler}}}],"images":[{image}]"#,
        factor.join(","),
    )
}

/// An `images` entry for encoded image `bytes`, embedded in the BIN chunk.
fn image_json(bytes: &[u8], format: ImageFormat, buffers: &mut Buffers) -> String {
    // Encoded images are compressed already: written as they are.
    let view = buffers.view(bytes.to_vec(), 1, false, None, Codec::Plain);
    format!(
        r#"{{"bufferView":{view},"mimeType":"{}"}}"#,
        format.mime_type()
    )
}

/// The source's material written again ([`SourceMaterial`]): its object with every texture
/// info's `texCoord` renumbered to the TEXCOORD set as written (`raw_names`), its textures,
/// samplers and images (embedded in the BIN chunk, whatever the file had); top-level JSON
/// members like [`material_json`]'s.
pub(super) fn source_material_json(
    morph: &Morph,
    source: &SourceScene,
    material: &SourceMaterial,
    raw_names: &[String],
    buffers: &mut Buffers,
) -> String {
    // A set n of the file → the set written: the morph's UVs are TEXCOORD_0, a carried set
    // is where `written_names` put it.
    let written_set = |n: u64| -> u64 {
        if n == source.uv_set as u64 && morph.attributes().uvs.is_some() {
            return 0;
        }
        let name = format!("TEXCOORD_{n}");
        source
            .attributes
            .iter()
            .zip(raw_names)
            .find(|(a, _)| a.semantic == name)
            .and_then(|(_, written)| written.strip_prefix("TEXCOORD_")?.parse().ok())
            // The loader kept only infos whose set is written.
            .unwrap_or(0)
    };
    let mut object = material.json.clone();
    texture_infos(&mut object, &mut |_, info| {
        let set = written_set(info["texCoord"].as_u64().unwrap_or(0));
        // Absent means set 0: left absent when it stays 0.
        if info.get("texCoord").is_some() || set != 0 {
            info["texCoord"] = set.into();
        }
        // (`get_mut`: indexing a missing member would insert a null.)
        let transform = info
            .get_mut("extensions")
            .and_then(|e| e.get_mut("KHR_texture_transform"))
            .and_then(|t| t.get_mut("texCoord"));
        if let Some(set) = transform {
            *set = written_set(set.as_u64().unwrap_or(0)).into();
        }
        true
    });
    let mut samplers = Vec::new();
    let textures: Vec<String> = material
        .textures
        .iter()
        .map(|t| match &t.sampler {
            Some(sampler) => {
                samplers.push(sampler.to_string());
                format!(
                    r#"{{"sampler":{},"source":{}}}"#,
                    samplers.len() - 1,
                    t.image
                )
            }
            None => format!(r#"{{"source":{}}}"#, t.image),
        })
        .collect();
    let images: Vec<String> = material
        .images
        .iter()
        .map(|image| image_json(&image.bytes, image.format, buffers))
        .collect();
    let mut out = format!(r#""materials":[{object}]"#);
    for (name, list) in [
        ("textures", textures),
        ("samplers", samplers),
        ("images", images),
    ] {
        if !list.is_empty() {
            let _ = write!(out, r#","{name}":[{}]"#, list.join(","));
        }
    }
    out
}
