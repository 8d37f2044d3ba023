//! What an export carries from its source file besides the morph ([`super::source_scene`]):
//! where the mesh stands in its scene (the node that instances it and its ancestors, and
//! for a skinned mesh the skin's joints, skeleton and their ancestors), every animation's
//! channels on those nodes and on the mesh's weights, and the vertex attributes morphlod
//! does not interpret (TANGENT,
//! JOINTS_n, WEIGHTS_n, further TEXCOORD and COLOR sets, application-specific `_NAME`s), as
//! the file stores them.

use super::document::Document;
use super::{
    display_name, NodeTransform, RawAttribute, SourceAnimation, SourceImage, SourceMaterial,
    SourceNode, SourceScene, SourceSkin, SourceTexture,
};
use crate::io::image_header::image_size;
use crate::io::LoadError;
use gltf::accessor::Dimensions;
use std::collections::BTreeSet;

/// One attribute as the primitives read so far store it, and why it cannot be carried.
struct Gathered {
    semantic: String,
    attribute: Option<RawAttribute>,
    /// Primitives that gave it.
    given: usize,
    problem: Option<String>,
}

impl Document {
    /// The source scene of `mesh` (see [`SourceScene`]).
    pub(super) fn source_scene(&self, mesh: &gltf::Mesh) -> Result<SourceScene, LoadError> {
        let mut left_out = Vec::new();
        let RawAttributes {
            mut attributes,
            target_attributes,
            uv_set,
            uvs,
            material,
        } = self.raw_attributes(mesh, &mut left_out)?;
        // The TEXCOORD sets written: the morph's UVs and the carried ones.
        let sets: Vec<u32> = attributes
            .iter()
            .filter_map(|a| a.semantic.strip_prefix("TEXCOORD_")?.parse().ok())
            .chain(uvs.then_some(uv_set))
            .collect();
        let material = match material {
            Some(index) => Some(self.source_material(index, &sets, &mut left_out)?),
            None => None,
        };
        let others: Vec<String> = self
            .document
            .meshes()
            .filter(|m| m.index() != mesh.index())
            .map(|m| display_name(m.name(), m.index()))
            .collect();
        if !others.is_empty() {
            left_out.push(format!(
                "meshes {}: one mesh is exported (choose it with --mesh)",
                others.join(", ")
            ));
        }
        let Some(instance) = self.instance(mesh) else {
            drop_skinning(&mut attributes, "no node instances the mesh", &mut left_out);
            for animation in self.document.animations() {
                left_out.push(format!(
                    "animation {}: no node instances the mesh",
                    display_name(animation.name(), animation.index())
                ));
            }
            return Ok(SourceScene {
                attributes,
                target_attributes,
                material,
                uv_set,
                left_out,
                ..SourceScene::default()
            });
        };
        let parents = self.parents();
        // The skin, kept only with the JOINTS_n/WEIGHTS_n pairs that bind vertices to it.
        let skin = match instance.skin() {
            Some(skin) if attributes.iter().any(|a| a.semantic == "JOINTS_0") => Some(skin),
            Some(skin) => {
                left_out.push(format!(
                    "skin {}: the mesh has no JOINTS_0 and WEIGHTS_0 on every primitive to bind it",
                    display_name(skin.name(), skin.index())
                ));
                None
            }
            None => {
                drop_skinning(&mut attributes, "its node has no skin", &mut left_out);
                None
            }
        };
        // The nodes written: the instancing node, and the skin's joints and skeleton, each
        // with its ancestors; parents before children (by depth), else in file order.
        let mut wanted = vec![instance.index()];
        if let Some(skin) = &skin {
            wanted.extend(skin.joints().map(|j| j.index()));
            wanted.extend(skin.skeleton().map(|s| s.index()));
        }
        let order = self.with_ancestors(&wanted, &parents);
        let mut position = vec![usize::MAX; parents.len()];
        for (i, &n) in order.iter().enumerate() {
            position[n] = i;
        }
        let source_nodes: Vec<gltf::Node> = self.document.nodes().collect();
        let nodes = order
            .iter()
            .map(|&n| {
                let node = &source_nodes[n];
                SourceNode {
                    name: node.name().map(str::to_owned),
                    transform: transform(node),
                    parent: parents[n].map(|p| position[p]),
                }
            })
            .collect();
        let animations = self.source_animations(mesh, &order, &mut left_out)?;
        let skin = match skin {
            Some(skin) => Some(self.skin(&skin, &position, &attributes)?),
            None => None,
        };
        Ok(SourceScene {
            nodes,
            mesh_node: Some(position[instance.index()]),
            skin,
            animations,
            attributes,
            target_attributes,
            material,
            uv_set,
            left_out,
        })
    }

    /// Every animation's channels on the weights of the node instancing `mesh` and on the
    /// transforms of `kept` (the written nodes, in order); an animation that drives neither
    /// is named in `left_out`, as are channels on other nodes.
    fn source_animations(
        &self,
        mesh: &gltf::Mesh,
        kept: &[usize],
        left_out: &mut Vec<String>,
    ) -> Result<Vec<SourceAnimation>, LoadError> {
        let targets = mesh
            .primitives()
            .next()
            .map_or(0, |p| p.morph_targets().len());
        let instance = self.instance(mesh).map(|n| n.index());
        let mut out = Vec::new();
        for animation in self.document.animations() {
            let name = display_name(animation.name(), animation.index());
            let weights = match targets {
                0 => None,
                _ => self.weight_track(&animation, mesh, targets)?,
            };
            let mut channels = Vec::new();
            for (at, &node) in kept.iter().enumerate() {
                channels.extend(
                    self.node_tracks(&animation, node)?
                        .into_iter()
                        .map(|t| (at, t)),
                );
            }
            let elsewhere: BTreeSet<usize> = animation
                .channels()
                .map(|c| c.target().node().index())
                .filter(|n| !kept.contains(n) && Some(*n) != instance)
                .collect();
            if !elsewhere.is_empty() {
                left_out.push(format!(
                    "animation {name}: its channels on nodes {elsewhere:?} (not the mesh's node, \
                     its skeleton or their ancestors)"
                ));
            }
            if weights.is_none() && channels.is_empty() {
                left_out.push(format!(
                    "animation {name}: it drives none of the nodes exported"
                ));
                continue;
            }
            out.push(SourceAnimation {
                index: animation.index(),
                name: animation.name().map(str::to_owned),
                weights,
                channels,
            });
        }
        Ok(out)
    }

    /// `skin` with its joints and skeleton as positions in the written nodes; its inverse
    /// bind matrices checked (FLOAT MAT4, at least one per joint, finite) and every JOINTS_n
    /// value checked to name one of its joints.
    fn skin(
        &self,
        skin: &gltf::Skin,
        position: &[usize],
        attributes: &[RawAttribute],
    ) -> Result<SourceSkin, LoadError> {
        let element = format!("skin {}", display_name(skin.name(), skin.index()));
        let joints: Vec<usize> = skin.joints().map(|j| position[j.index()]).collect();
        let inverse_bind_matrices = self.inverse_binds(skin)?.map(|floats| {
            floats
                .chunks_exact(16)
                .map(|m| std::array::from_fn(|i| m[i]))
                .collect()
        });
        for attribute in attributes
            .iter()
            .filter(|a| a.semantic.starts_with("JOINTS_"))
        {
            if !matches!(attribute.component_type, 5121 | 5123) || attribute.kind != "VEC4" {
                return Err(self.data_error(
                    &format!("{element} ({})", attribute.semantic),
                    "joints must be VEC4 UNSIGNED_BYTE or UNSIGNED_SHORT".into(),
                ));
            }
            let size = attribute.component_size();
            let too_far = attribute.data.chunks_exact(size).position(|c| {
                let j = match size {
                    1 => c[0] as usize,
                    _ => u16::from_le_bytes([c[0], c[1]]) as usize,
                };
                j >= joints.len()
            });
            if let Some(i) = too_far {
                return Err(self.data_error(
                    &format!("{element} ({})", attribute.semantic),
                    format!("vertex {} names joint {} of {}", i / 4, i % 4, joints.len()),
                ));
            }
        }
        Ok(SourceSkin {
            name: skin.name().map(str::to_owned),
            joints,
            skeleton: skin.skeleton().map(|s| position[s.index()]),
            inverse_bind_matrices,
        })
    }

    /// The vertex attributes of `mesh`'s primitives that a morph does not hold, and per
    /// target its TANGENT deltas, concatenated over the primitives with POSITION as the
    /// geometry is; one that some primitive lacks or stores in another format is left out,
    /// with a line in `left_out`. Skipped: POSITION, NORMAL, COLOR_0 and the TEXCOORD set
    /// the material's base-colour texture samples (the morph's own).
    fn raw_attributes(
        &self,
        mesh: &gltf::Mesh,
        left_out: &mut Vec<String>,
    ) -> Result<RawAttributes, LoadError> {
        let primitives: Vec<gltf::Primitive> = mesh
            .primitives()
            .filter(|p| p.get(&gltf::Semantic::Positions).is_some())
            .collect();
        let Some(first) = primitives.first() else {
            return Ok(RawAttributes::default());
        };
        let uv_set = first
            .material()
            .pbr_metallic_roughness()
            .base_color_texture()
            .map_or(0, |info| info.tex_coord());
        let uvs = primitives
            .iter()
            .all(|p| p.get(&gltf::Semantic::TexCoords(uv_set)).is_some());
        let own = |s: &gltf::Semantic| {
            use gltf::Semantic::*;
            matches!(s, Positions | Normals | Colors(0))
                || matches!(s, TexCoords(set) if *set == uv_set)
        };
        let mesh_name = display_name(mesh.name(), mesh.index());
        let material = first.material().index();
        if let Some(other) = primitives.iter().find(|p| p.material().index() != material) {
            left_out.push(format!(
                "the material of primitive {} (and any other that differs from the first's): \
                 the LODs are one primitive, drawn with the first primitive's material",
                other.index()
            ));
        }
        let mut vertex: Vec<Gathered> = first
            .attributes()
            .filter(|(s, _)| !own(s))
            .map(|(s, _)| Gathered::new(s.to_string()))
            .collect();
        let targets = first.morph_targets().len();
        let mut tangents: Vec<Gathered> = (0..targets)
            .map(|k| Gathered::new(format!("target {k} TANGENT")))
            .collect();
        for primitive in &primitives {
            let element = format!("mesh {mesh_name} primitive {}", primitive.index());
            let count = primitive
                .get(&gltf::Semantic::Positions)
                .map_or(0, |a| a.count());
            for (semantic, accessor) in primitive.attributes().filter(|(s, _)| !own(s)) {
                let name = semantic.to_string();
                if !vertex.iter().any(|g| g.semantic == name) {
                    left_out.push(format!(
                        "{name}: primitive {} has it, the first primitive does not",
                        primitive.index()
                    ));
                }
                let Some(g) = vertex.iter_mut().find(|g| g.semantic == name) else {
                    continue;
                };
                let what = format!("{element} {name}");
                g.append(self, &accessor, count, primitive.index(), &what)?;
            }
            for g in &mut vertex {
                let given = primitive
                    .attributes()
                    .any(|(s, _)| s.to_string() == g.semantic);
                if !given {
                    g.absent(primitive.index());
                }
            }
            for (k, (target, g)) in primitive.morph_targets().zip(&mut tangents).enumerate() {
                match target.tangents() {
                    Some(accessor) => {
                        let what = format!("{element} target {k} TANGENT");
                        g.append(self, &accessor, count, primitive.index(), &what)?;
                    }
                    None => g.absent(primitive.index()),
                }
            }
        }
        let mut keep = |g: Gathered| match (g.attribute, g.problem) {
            (Some(a), None) => Some(a),
            // A target without TANGENT deltas on any primitive has nothing to leave out.
            _ if g.given == 0 => None,
            (_, problem) => {
                left_out.push(format!("{}: {}", g.semantic, problem.unwrap_or_default()));
                None
            }
        };
        let mut attributes: Vec<RawAttribute> = vertex.into_iter().filter_map(&mut keep).collect();
        let has_tangents = attributes.iter().any(|a| a.semantic == "TANGENT");
        let target_attributes = tangents
            .into_iter()
            .map(|g| {
                let tangent = keep(g).filter(|_| has_tangents).map(|mut a| {
                    a.semantic = "TANGENT".into();
                    a
                });
                tangent.into_iter().collect()
            })
            .collect();
        // JOINTS_n and WEIGHTS_n bind a vertex only together.
        let mut unpaired = Vec::new();
        for a in &attributes {
            let other = match a.semantic.strip_prefix("JOINTS_") {
                Some(set) => format!("WEIGHTS_{set}"),
                None => match a.semantic.strip_prefix("WEIGHTS_") {
                    Some(set) => format!("JOINTS_{set}"),
                    None => continue,
                },
            };
            if !attributes.iter().any(|b| b.semantic == other) {
                unpaired.push((a.semantic.clone(), other));
            }
        }
        for (semantic, other) in unpaired {
            attributes.retain(|a| a.semantic != semantic);
            left_out.push(format!("{semantic}: {other} is not carried"));
        }
        Ok(RawAttributes {
            attributes,
            target_attributes,
            uv_set,
            uvs,
            material,
        })
    }

    /// Material `index` as the file has it ([`SourceMaterial`]). A texture info whose
    /// TEXCOORD set is not carried (`sets`: those that are), or whose texture has no image
    /// of its own, is left out with a line in `left_out`, as are texture extensions.
    fn source_material(
        &self,
        index: usize,
        sets: &[u32],
        left_out: &mut Vec<String>,
    ) -> Result<SourceMaterial, LoadError> {
        let raw = &self.raw;
        let mut json = raw["materials"][index].clone();
        let mut textures: Vec<(usize, SourceTexture)> = Vec::new();
        let mut images: Vec<(usize, SourceImage)> = Vec::new();
        let mut failure = None;
        let material = format!("material {index}");
        texture_infos(&mut json, &mut |member, info| {
            let Some(texture) = info["index"].as_u64().map(|t| t as usize) else {
                return false;
            };
            let set = info["texCoord"].as_u64().unwrap_or(0) as u32;
            let set = info["extensions"]["KHR_texture_transform"]["texCoord"]
                .as_u64()
                .map_or(set, |s| s as u32);
            if !sets.contains(&set) {
                left_out.push(format!(
                    "{material} {member}: its TEXCOORD_{set} is not on every primitive"
                ));
                return false;
            }
            let source = &raw["textures"][texture];
            if let Some(extensions) = source["extensions"].as_object() {
                let names: Vec<&String> = extensions.keys().collect();
                left_out.push(format!("texture {texture}: extensions {names:?}"));
            }
            let Some(image) = source["source"].as_u64().map(|i| i as usize) else {
                left_out.push(format!(
                    "{material} {member}: texture {texture} has no core image source"
                ));
                return false;
            };
            let slot = match textures.iter().position(|(t, _)| *t == texture) {
                Some(slot) => slot,
                None => {
                    let at = match images.iter().position(|(i, _)| *i == image) {
                        Some(at) => at,
                        None => {
                            let read = self.image_bytes(image).and_then(|bytes| {
                                image_size(&bytes)
                                    .map(|(format, _, _)| SourceImage { format, bytes })
                                    .map_err(|message| LoadError::GltfImage {
                                        path: self.path.clone(),
                                        image,
                                        message,
                                    })
                            });
                            match read {
                                Ok(read) => images.push((image, read)),
                                Err(e) => {
                                    failure.get_or_insert(e);
                                    return false;
                                }
                            }
                            images.len() - 1
                        }
                    };
                    let sampler = source["sampler"]
                        .as_u64()
                        .map(|k| raw["samplers"][k as usize].clone());
                    textures.push((texture, SourceTexture { image: at, sampler }));
                    textures.len() - 1
                }
            };
            info["index"] = slot.into();
            true
        });
        if let Some(e) = failure {
            return Err(e);
        }
        let mut extensions_used = Vec::new();
        extension_names(&json, &mut extensions_used);
        let required: Vec<&str> = raw["extensionsRequired"]
            .as_array()
            .map_or(Vec::new(), |r| {
                r.iter().filter_map(|e| e.as_str()).collect()
            });
        let extensions_required = extensions_used
            .iter()
            .filter(|e| required.contains(&e.as_str()))
            .cloned()
            .collect();
        Ok(SourceMaterial {
            json,
            textures: textures.into_iter().map(|(_, t)| t).collect(),
            images: images.into_iter().map(|(_, i)| i).collect(),
            extensions_used,
            extensions_required,
        })
    }
}

/// What [`Document::raw_attributes`] reads.
#[derive(Default)]
struct RawAttributes {
    attributes: Vec<RawAttribute>,
    target_attributes: Vec<Vec<RawAttribute>>,
    /// The TEXCOORD set of the base-colour texture, and whether every primitive has it (so
    /// the morph holds it as its UVs).
    uv_set: u32,
    uvs: bool,
    /// The first primitive's material.
    material: Option<usize>,
}

/// Calls `f(member, info)` on every texture info in `value` (an object member whose name
/// ends in `Texture` and that has an `index`: glTF's and its extensions' convention; not
/// inside `extras`), in document order; an info for which `f` returns false is removed.
pub(crate) fn texture_infos(
    value: &mut serde_json::Value,
    f: &mut impl FnMut(&str, &mut serde_json::Value) -> bool,
) {
    match value {
        serde_json::Value::Object(members) => {
            let mut removed = Vec::new();
            // `extras` is the application's own: nothing in it is a texture reference.
            for (name, member) in members.iter_mut().filter(|(name, _)| *name != "extras") {
                if name.ends_with("Texture") && member.get("index").is_some() {
                    if !f(name, member) {
                        removed.push(name.clone());
                    }
                } else {
                    texture_infos(member, f);
                }
            }
            for name in removed {
                members.remove(&name);
            }
        }
        serde_json::Value::Array(items) => {
            for item in items {
                texture_infos(item, f);
            }
        }
        _ => {}
    }
}

/// The names of every `extensions` object's members in `value`, each once, in order.
fn extension_names(value: &serde_json::Value, out: &mut Vec<String>) {
    match value {
        serde_json::Value::Object(members) => {
            for (name, member) in members {
                if name == "extensions" {
                    for extension in member.as_object().into_iter().flat_map(|e| e.keys()) {
                        if !out.contains(extension) {
                            out.push(extension.clone());
                        }
                    }
                }
                extension_names(member, out);
            }
        }
        serde_json::Value::Array(items) => {
            for item in items {
                extension_names(item, out);
            }
        }
        _ => {}
    }
}

impl Gathered {
    fn new(semantic: String) -> Gathered {
        Gathered {
            semantic,
            attribute: None,
            given: 0,
            problem: None,
        }
    }

    /// Appends one primitive's values (`count`: its vertices); the attribute is left out
    /// when their format differs from an earlier primitive's.
    fn append(
        &mut self,
        doc: &Document,
        accessor: &gltf::Accessor,
        count: usize,
        primitive: usize,
        what: &str,
    ) -> Result<(), LoadError> {
        let kind = match accessor.dimensions() {
            Dimensions::Scalar => "SCALAR",
            Dimensions::Vec2 => "VEC2",
            Dimensions::Vec3 => "VEC3",
            Dimensions::Vec4 => "VEC4",
            other => {
                return Err(doc.data_error(
                    what,
                    format!("is {other:?}; a vertex attribute is SCALAR or VEC2 to VEC4"),
                ))
            }
        };
        if accessor.count() != count {
            return Err(doc.data_error(
                what,
                format!(
                    "has {} elements, but POSITION has {count}",
                    accessor.count()
                ),
            ));
        }
        self.given += 1;
        if self.problem.is_some() {
            return Ok(());
        }
        let data = doc.gather(accessor, what)?;
        let (component_type, normalized) =
            (accessor.data_type().as_gl_enum(), accessor.normalized());
        let format = |kind: &str, component: u32, normalized: bool| {
            format!(
                "{kind} of component type {component}{}",
                if normalized { " normalized" } else { "" }
            )
        };
        match &mut self.attribute {
            None => {
                self.attribute = Some(RawAttribute {
                    semantic: self.semantic.clone(),
                    kind,
                    component_type,
                    normalized,
                    data,
                })
            }
            Some(a)
                if (a.kind, a.component_type, a.normalized)
                    == (kind, component_type, normalized) =>
            {
                a.data.extend(data)
            }
            Some(a) => {
                self.problem = Some(format!(
                    "primitive {primitive} stores it as {}, an earlier one as {}",
                    format(kind, component_type, normalized),
                    format(a.kind, a.component_type, a.normalized)
                ))
            }
        }
        Ok(())
    }

    /// The primitive lacks the attribute: it is left out.
    fn absent(&mut self, primitive: usize) {
        if self.problem.is_none() {
            self.problem = Some(format!("primitive {primitive} has none"));
        }
    }
}

/// A node's local transform as the file states it.
fn transform(node: &gltf::Node) -> NodeTransform {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            NodeTransform::Matrix(glam::Mat4::from_cols_array_2d(&matrix).to_cols_array())
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => NodeTransform::Trs {
            translation,
            rotation,
            scale,
        },
    }
}

/// Leaves out every JOINTS_n and WEIGHTS_n: without a skin they bind to nothing.
fn drop_skinning(attributes: &mut Vec<RawAttribute>, why: &str, left_out: &mut Vec<String>) {
    attributes.retain(|a| {
        let skinning = a.semantic.starts_with("JOINTS_") || a.semantic.starts_with("WEIGHTS_");
        if skinning {
            left_out.push(format!("{}: {why}", a.semantic));
        }
        !skinning
    });
}

#[cfg(test)]
mod tests {
    use crate::io::LoadOptions;
    use base64::Engine;
    use serde_json::json;

    /// A mesh of two one-triangle primitives (no node, no skin) whose attributes disagree:
    /// both have TEXCOORD_1 (FLOAT) and JOINTS_0/WEIGHTS_0, only the first TANGENT, and `_ID`
    /// is FLOAT in one and normalized UNSIGNED_SHORT in the other.
    fn disagreeing_primitives(dir: &std::path::Path) -> std::path::PathBuf {
        let mut bin: Vec<u8> = Vec::new();
        let mut views = Vec::new();
        let mut push = |bytes: Vec<u8>| {
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
            bin.extend(bytes);
            bin.resize(bin.len().next_multiple_of(4), 0);
            views.len() - 1
        };
        let floats = |v: &[f32]| v.iter().flat_map(|f| f.to_le_bytes()).collect::<Vec<u8>>();
        let positions = push(floats(&[0., 0., 0., 1., 0., 0., 0., 1., 0.]));
        let uvs = push(floats(&[0.; 6]));
        let tangents = push(floats(&[1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1.]));
        let ids = push(floats(&[1., 2., 3.]));
        let short_ids = push(vec![1, 0, 2, 0, 3, 0, 0, 0]);
        let joints = push(vec![0; 12]);
        let weights = push(floats(&[1., 0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0.]));
        let accessor = |view: usize, component: u32, kind: &str, normalized: bool| {
            json!({"bufferView": view, "componentType": component, "count": 3, "type": kind,
                "normalized": normalized})
        };
        let mut accessors = vec![
            accessor(positions, 5126, "VEC3", false),
            accessor(uvs, 5126, "VEC2", false),
            accessor(tangents, 5126, "VEC4", false),
            accessor(ids, 5126, "SCALAR", false),
            accessor(short_ids, 5123, "SCALAR", true),
            accessor(joints, 5121, "VEC4", false),
            accessor(weights, 5126, "VEC4", false),
        ];
        accessors[0]["min"] = json!([0., 0., 0.]);
        accessors[0]["max"] = json!([1., 1., 0.]);
        let gltf = json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": bin.len(), "uri": format!(
                "data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(&bin))}],
            "bufferViews": views,
            "accessors": accessors,
            "meshes": [{"primitives": [
                {"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 1, "TANGENT": 2,
                    "_ID": 3, "JOINTS_0": 5, "WEIGHTS_0": 6}},
                {"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 1, "_ID": 4,
                    "JOINTS_0": 5, "WEIGHTS_0": 6}}
            ]}]
        });
        let path = dir.join("disagreeing.gltf");
        std::fs::write(&path, serde_json::to_vec(&gltf).unwrap()).unwrap();
        path
    }

    /// What every primitive stores alike is carried, over both primitives; the rest is left
    /// out with a line naming the attribute and why.
    #[test]
    fn attributes_the_primitives_disagree_on_are_left_out_with_a_reason() {
        let dir = std::env::temp_dir().join(format!("morphlod-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = disagreeing_primitives(&dir);
        let scene = super::super::source_scene(&path, &LoadOptions::default()).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let carried: Vec<&str> = scene
            .attributes
            .iter()
            .map(|a| a.semantic.as_str())
            .collect();
        assert_eq!(carried, ["TEXCOORD_1"]);
        assert_eq!(
            scene.attributes[0].data.len(),
            2 * 3 * 8,
            "both primitives' vertices"
        );
        assert_eq!(scene.uv_set, 0);
        assert!(scene.skin.is_none() && scene.nodes.is_empty() && scene.mesh_node.is_none());
        let expected = [
            "TANGENT: primitive 1 has none",
            "_ID: primitive 1 stores it as SCALAR of component type 5123 normalized, an earlier one as SCALAR of component type 5126",
            "JOINTS_0: no node instances the mesh",
            "WEIGHTS_0: no node instances the mesh",
        ];
        for line in expected {
            assert!(
                scene.left_out.iter().any(|l| l == line),
                "{line}: {:?}",
                scene.left_out
            );
        }
        assert_eq!(scene.left_out.len(), expected.len(), "{:?}", scene.left_out);
    }
}
