//! The file: LOD nodes in the source's node tree, `MSFT_lod`, skin, extensions, and the GLB
//! container around the JSON and the BIN chunk.

use super::animation::{animation, animations_json, WrittenAnimation};
use super::compress::{Buffers, EXT_MESHOPT_COMPRESSION};
use super::material::{material_json, source_material_json};
use super::mesh::{flat_accessor, mesh_json, written_names, Quantization};
use super::quantize::Grid;
use super::{ExportOptions, Lod};
use crate::io::gltf::write::{glb, number, quote};
use crate::io::gltf::NodeTransform;
use crate::morph::Morph;
use std::fmt::Write as _;

/// Screen coverage below which each LOD gives way to the next, for `MSFT_screencoverage`:
/// keeping triangles per covered pixel constant, LOD `i + 1` (a fraction `f` of the
/// triangles) suffices below `f / 2` of the screen when the full mesh is meant for half the
/// screen and more; the last LOD stays down to 0 (never culled).
fn screen_coverage(lods: &[Lod]) -> Vec<f32> {
    let mut coverage: Vec<f32> = lods[1..].iter().map(|l| 0.5 * l.fraction).collect();
    coverage.push(0.0);
    coverage
}

/// A node's transform as glTF node properties, each after a comma; nothing for the identity
/// (the properties' defaults), so an untransformed node stays bare.
fn transform_json(transform: &NodeTransform) -> String {
    let list = |values: &[f32]| {
        values
            .iter()
            .map(|&v| number(v))
            .collect::<Vec<_>>()
            .join(",")
    };
    match transform {
        NodeTransform::Matrix(m) if *m == glam::Mat4::IDENTITY.to_cols_array() => String::new(),
        NodeTransform::Matrix(m) => format!(r#","matrix":[{}]"#, list(m)),
        NodeTransform::Trs {
            translation,
            rotation,
            scale,
        } => {
            let mut out = String::new();
            if *translation != [0.0; 3] {
                let _ = write!(out, r#","translation":[{}]"#, list(translation));
            }
            if *rotation != [0.0, 0.0, 0.0, 1.0] {
                let _ = write!(out, r#","rotation":[{}]"#, list(rotation));
            }
            if *scale != [1.0; 3] {
                let _ = write!(out, r#","scale":[{}]"#, list(scale));
            }
            out
        }
    }
}

/// `transform` followed by the dequantising transform of `grid` (translation `offset`,
/// uniform scale `step`), as one local transform of the same kind: a TRS stays a TRS (the
/// uniform scale commutes with the rotation), a matrix stays a matrix.
fn dequantized(transform: &NodeTransform, grid: &Grid) -> NodeTransform {
    let offset = glam::Vec3::from_array(grid.offset);
    match transform {
        NodeTransform::Trs {
            translation,
            rotation,
            scale,
        } => {
            let s = glam::Vec3::from_array(*scale);
            let t = glam::Vec3::from_array(*translation)
                + glam::Quat::from_array(*rotation) * (s * offset);
            NodeTransform::Trs {
                translation: t.to_array(),
                rotation: *rotation,
                scale: (s * grid.step).to_array(),
            }
        }
        NodeTransform::Matrix(m) => NodeTransform::Matrix(
            (glam::Mat4::from_cols_array(m) * dequantizing_matrix(grid)).to_cols_array(),
        ),
    }
}

/// The matrix that maps grid coordinates to positions.
fn dequantizing_matrix(grid: &Grid) -> glam::Mat4 {
    glam::Mat4::from_scale_rotation_translation(
        glam::Vec3::splat(grid.step),
        glam::Quat::IDENTITY,
        glam::Vec3::from_array(grid.offset),
    )
}

/// What [`write_glb`] wrote.
pub(super) struct Written {
    pub(super) glb: Vec<u8>,
    /// Per LOD, the bytes of its mesh's data in the BIN chunk (compressed, when it is).
    pub(super) lod_bytes: Vec<usize>,
}

/// The GLB file of `lods` (LOD0 first): meshes, material, animation, skin and the nodes in
/// the source's tree, as the module docs describe; quantized with `quantization`, compressed
/// with `options.compress`.
pub(super) fn write_glb(
    morph: &Morph,
    lods: &[Lod],
    default_weights: &[f32],
    options: &ExportOptions,
    quantization: Option<&Quantization>,
) -> Written {
    let name = &options.name;
    let mut buffers = Buffers::new(options.compress);
    let names: Vec<String> = (0..lods.len()).map(|i| format!("{name}_LOD{i}")).collect();
    let source = &options.source;
    let raw_names = written_names(morph, &source.attributes);
    let mut lod_bytes = Vec::with_capacity(lods.len());
    let meshes: Vec<String> = lods
        .iter()
        .zip(&names)
        .map(|(lod, n)| {
            let before = buffers.bin.bytes.len();
            let mesh = mesh_json(
                morph,
                lod,
                n,
                default_weights,
                source,
                &raw_names,
                quantization,
                &mut buffers,
            );
            lod_bytes.push(buffers.bin.bytes.len() - before);
            mesh
        })
        .collect();
    let material = match &source.material {
        Some(material) => source_material_json(morph, source, material, &raw_names, &mut buffers),
        None => material_json(morph, &mut buffers),
    };
    let mut used = vec!["MSFT_lod".to_string()];
    let mut required = Vec::new();
    // Both change what the data means: a client without them cannot read the meshes.
    let mut codecs = Vec::new();
    if quantization.is_some() {
        codecs.push("KHR_mesh_quantization".to_string());
    }
    if options.compress {
        codecs.push(EXT_MESHOPT_COMPRESSION.to_string());
    }
    used.extend(codecs.iter().cloned());
    required.extend(codecs);
    if let Some(material) = &source.material {
        used.extend(material.extensions_used.iter().cloned());
        required.extend(material.extensions_required.iter().cloned());
    }
    let extensions = {
        let list = |names: &[String]| names.iter().map(|n| quote(n)).collect::<Vec<_>>().join(",");
        let mut out = format!(r#""extensionsUsed":[{}]"#, list(&used));
        if !required.is_empty() {
            let _ = write!(out, r#","extensionsRequired":[{}]"#, list(&required));
        }
        out
    };
    // The LOD nodes are 0..lods (the animation and MSFT_lod address them so); the source's
    // other nodes follow in their order, the mesh node's place taken by LOD0.
    let mesh_node = source.mesh_node;
    let mut written = Vec::with_capacity(source.nodes.len());
    let mut next = lods.len();
    for i in 0..source.nodes.len() {
        if Some(i) == mesh_node {
            written.push(0);
        } else {
            written.push(next);
            next += 1;
        }
    }
    // Every LOD node stands where the mesh node stood, so its channels drive each of them;
    // another node's drive that node.
    let driven = |i: usize| -> Vec<usize> {
        if Some(i) == mesh_node {
            (0..lods.len()).collect()
        } else {
            vec![written[i]]
        }
    };
    let targets = !morph.targets().is_empty();
    let mut animations: Vec<WrittenAnimation> = source
        .animations
        .iter()
        .enumerate()
        .map(|(i, a)| WrittenAnimation {
            name: a.name.clone().unwrap_or_else(|| format!("animation {i}")),
            weights: a.weights.clone().filter(|_| targets),
            channels: a.channels.iter().map(|(n, t)| (driven(*n), t)).collect(),
        })
        .collect();
    // Without a weight animation of its own in the source, the morph's plays.
    if targets && !animations.iter().any(|a| a.weights.is_some()) {
        animations.push(WrittenAnimation {
            name: "weights".into(),
            weights: animation(morph),
            channels: Vec::new(),
        });
    }
    let animation = animations_json(&animations, lods.len(), &mut buffers);
    // A skinned mesh's node transform is ignored (glTF 2.0, 3.7.3.3), so the dequantising
    // transform goes into every inverse bind matrix instead: joint · IBM · D · q.
    let grid = quantization.map(|q| &q.grid);
    let skin_grid = grid.filter(|_| source.skin.is_some());
    let skin = match &source.skin {
        Some(skin) => {
            let joints: Vec<String> = skin
                .joints
                .iter()
                .map(|&j| written[j].to_string())
                .collect();
            let mut fields = vec![format!(r#""joints":[{}]"#, joints.join(","))];
            if let Some(name) = &skin.name {
                fields.push(format!(r#""name":{}"#, quote(name)));
            }
            if let Some(skeleton) = skin.skeleton {
                fields.push(format!(r#""skeleton":{}"#, written[skeleton]));
            }
            let matrices = match (&skin.inverse_bind_matrices, skin_grid) {
                (Some(m), None) => Some(m.clone()),
                (m, Some(grid)) => {
                    let d = dequantizing_matrix(grid);
                    let identity = vec![glam::Mat4::IDENTITY.to_cols_array(); skin.joints.len()];
                    let m = m.as_ref().unwrap_or(&identity);
                    Some(
                        m.iter()
                            .map(|m| (glam::Mat4::from_cols_array(m) * d).to_cols_array())
                            .collect(),
                    )
                }
                (None, None) => None,
            };
            if let Some(matrices) = matrices {
                let data: Vec<f32> = matrices.iter().flatten().copied().collect();
                let acc = flat_accessor(&mut buffers, &data, 16, "MAT4", None);
                fields.push(format!(r#""inverseBindMatrices":{acc}"#));
            }
            format!(r#","skins":[{{{}}}]"#, fields.join(","))
        }
        None => String::new(),
    };
    let own = mesh_node.map_or(NodeTransform::IDENTITY, |m| {
        source.nodes[m].transform.clone()
    });
    let own = match grid.filter(|_| skin_grid.is_none()) {
        Some(grid) => transform_json(&dequantized(&own, grid)),
        None => transform_json(&own),
    };
    let bind = if skin.is_empty() { "" } else { r#","skin":0"# };
    let ids: Vec<String> = (1..lods.len()).map(|i| i.to_string()).collect();
    let coverage: Vec<String> = screen_coverage(lods).into_iter().map(number).collect();
    let children_json = |i: usize| {
        let list: Vec<String> = (0..source.nodes.len())
            .filter(|&c| source.nodes[c].parent == Some(i))
            .map(|c| written[c].to_string())
            .collect();
        if list.is_empty() {
            String::new()
        } else {
            format!(r#","children":[{}]"#, list.join(","))
        }
    };
    let nodes: Vec<String> = names
        .iter()
        .enumerate()
        .map(|(i, n)| {
            // LOD0 holds the mesh node's children and declares the chain.
            let mut lod = String::new();
            if i == 0 {
                lod += &mesh_node.map_or(String::new(), children_json);
                let _ = write!(
                    lod,
                    r#","extensions":{{"MSFT_lod":{{"ids":[{}]}}}},"extras":{{"MSFT_screencoverage":[{}]}}"#,
                    ids.join(","),
                    coverage.join(",")
                );
            }
            format!(r#"{{"name":{},"mesh":{i}{bind}{own}{lod}}}"#, quote(n))
        })
        .chain(
            (0..source.nodes.len())
                .filter(|&i| Some(i) != mesh_node)
                .map(|i| {
                    let node = &source.nodes[i];
                    let name = node
                        .name
                        .as_deref()
                        .map_or(String::new(), |n| format!(r#","name":{}"#, quote(n)));
                    let body = format!(
                        "{name}{}{}",
                        children_json(i),
                        transform_json(&node.transform)
                    );
                    // Each property follows a comma; the object opens without one.
                    format!("{{{}}}", body.strip_prefix(',').unwrap_or(""))
                }),
        )
        .collect();
    let roots: Vec<String> = if source.nodes.is_empty() {
        vec!["0".into()]
    } else {
        (0..source.nodes.len())
            .filter(|&i| source.nodes[i].parent.is_none())
            .map(|i| written[i].to_string())
            .collect()
    };
    let mut text = String::new();
    let _ = write!(
        text,
        r#"{{"asset":{{"version":"2.0","generator":"morphlod export"}},{extensions},"scene":0,"scenes":[{{"nodes":[{roots}]}}],"nodes":[{nodes}],"meshes":[{meshes}]{skin},{material}{animation},"buffers":{buffers},"bufferViews":[{views}],"accessors":[{accessors}]}}"#,
        roots = roots.join(","),
        nodes = nodes.join(","),
        meshes = meshes.join(","),
        buffers = buffers.buffers_json(),
        views = buffers.json.views.join(","),
        accessors = buffers.json.accessors.join(","),
    );
    Written {
        glb: glb(text.into_bytes(), buffers.bin.bytes),
        lod_bytes,
    }
}
