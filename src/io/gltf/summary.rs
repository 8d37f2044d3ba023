//! What `morphlod info` prints for a glTF file: its meshes with their morph targets, its
//! skins, and its animations with the channels that drive morph weights and those that move
//! a skin's joints. Reads the structure and the keyframe times only, no vertex data.

use super::document::Document;
use super::{display_name, interpolation, quoted, target_names};
use crate::io::LoadError;
use crate::morph::Interpolation;
use gltf::accessor::Dimensions;
use gltf::mesh::Mode;
use std::fmt;
use std::path::Path;

/// A summary of a glTF file: its meshes with their morph targets, and its
/// animations with the channels that drive morph weights.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfSummary {
    pub meshes: Vec<MeshSummary>,
    pub skins: Vec<SkinSummary>,
    pub animations: Vec<AnimationSummary>,
}

/// A skin: its joints and the nodes that draw a mesh with it.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinSummary {
    pub index: usize,
    pub name: Option<String>,
    pub joints: usize,
    /// Whether it gives inverse bind matrices (identity where not, as the spec says).
    pub inverse_binds: bool,
    /// The nodes that draw a mesh with it: (node, mesh).
    pub users: Vec<(usize, usize)>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct MeshSummary {
    pub index: usize,
    pub name: Option<String>,
    pub primitives: usize,
    /// Sum of the primitives' POSITION counts.
    pub vertices: usize,
    /// Triangles as declared by the index counts and modes (strips and fans
    /// included; degenerate joints not yet removed); 0 for points and lines.
    pub triangles: usize,
    pub target_names: Vec<String>,
    pub default_weights: Vec<f32>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct AnimationSummary {
    pub index: usize,
    pub name: Option<String>,
    /// Channels whose path is `weights`.
    pub weight_channels: Vec<WeightChannelSummary>,
    /// Channels animating translation, rotation or scale (a skinned mesh's clip moves its
    /// joints with them).
    pub other_channels: usize,
    /// Of those, the channels on a skin's joints (`build --animation` plays them as the
    /// skinned deformation).
    pub joint_channels: usize,
    /// Time of the last keyframe of any channel, in seconds.
    pub duration: f32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct WeightChannelSummary {
    pub node: usize,
    /// The mesh of the node, whose weights the channel drives.
    pub mesh: Option<usize>,
    pub interpolation: Interpolation,
    pub keyframes: usize,
    /// Time of the last keyframe, in seconds.
    pub duration: f32,
}

/// Reads the file's structure and the animation keyframe times (for durations);
/// vertex data is not read.
pub fn inspect(path: &Path) -> Result<GltfSummary, LoadError> {
    let doc = Document::open(path)?;
    let meshes = doc
        .document
        .meshes()
        .map(|mesh| {
            let mut vertices = 0;
            let mut triangles = 0;
            for primitive in mesh.primitives() {
                let count = primitive
                    .get(&gltf::Semantic::Positions)
                    .map_or(0, |a| a.count());
                vertices += count;
                let corners = primitive.indices().map_or(count, |a| a.count());
                triangles += match primitive.mode() {
                    Mode::Triangles => corners / 3,
                    Mode::TriangleStrip | Mode::TriangleFan => corners.saturating_sub(2),
                    _ => 0,
                };
            }
            let target_count = mesh
                .primitives()
                .next()
                .map_or(0, |p| p.morph_targets().len());
            Ok(MeshSummary {
                index: mesh.index(),
                name: mesh.name().map(str::to_string),
                primitives: mesh.primitives().len(),
                vertices,
                triangles,
                target_names: target_names(&mesh, target_count),
                default_weights: doc.default_weights(&mesh, target_count)?,
            })
        })
        .collect::<Result<Vec<_>, LoadError>>()?;
    let skins: Vec<SkinSummary> = (doc.document.skins())
        .map(|skin| SkinSummary {
            index: skin.index(),
            name: skin.name().map(str::to_string),
            joints: skin.joints().count(),
            inverse_binds: skin.inverse_bind_matrices().is_some(),
            users: (doc.document.nodes())
                .filter(|node| node.skin().is_some_and(|s| s.index() == skin.index()))
                .filter_map(|node| Some((node.index(), node.mesh()?.index())))
                .collect(),
        })
        .collect();
    let joints: std::collections::HashSet<usize> = (doc.document.skins())
        .flat_map(|skin| skin.joints().map(|joint| joint.index()).collect::<Vec<_>>())
        .collect();
    let animations = doc
        .document
        .animations()
        .map(|animation| {
            let mut weight_channels = Vec::new();
            let (mut other_channels, mut joint_channels, mut duration) = (0, 0, 0.0f32);
            for channel in animation.channels() {
                let sampler = channel.sampler();
                let element = format!(
                    "animation {} sampler {} input",
                    display_name(animation.name(), animation.index()),
                    sampler.index()
                );
                let times = doc.read_floats(&sampler.input(), &element, Dimensions::Scalar)?;
                duration = duration.max(times.last().copied().unwrap_or(0.0));
                let node = channel.target().node();
                if channel.target().property() != gltf::animation::Property::MorphTargetWeights {
                    other_channels += 1;
                    joint_channels += usize::from(joints.contains(&node.index()));
                    continue;
                }
                weight_channels.push(WeightChannelSummary {
                    node: node.index(),
                    mesh: node.mesh().map(|m| m.index()),
                    interpolation: interpolation(sampler.interpolation()),
                    keyframes: times.len(),
                    duration: times.last().copied().unwrap_or(0.0),
                });
            }
            Ok(AnimationSummary {
                index: animation.index(),
                name: animation.name().map(str::to_string),
                weight_channels,
                other_channels,
                joint_channels,
                duration,
            })
        })
        .collect::<Result<Vec<_>, LoadError>>()?;
    Ok(GltfSummary {
        meshes,
        skins,
        animations,
    })
}

impl fmt::Display for GltfSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} mesh(es)", self.meshes.len())?;
        for m in &self.meshes {
            writeln!(
                f,
                "  mesh {} {}: {} primitive(s), {} vertices, {} triangles",
                m.index,
                quoted(&m.name),
                m.primitives,
                m.vertices,
                m.triangles
            )?;
            if !m.target_names.is_empty() {
                writeln!(f, "    {} morph target(s):", m.target_names.len())?;
                for (i, name) in m.target_names.iter().enumerate() {
                    let w = m.default_weights.get(i).copied().unwrap_or(0.0);
                    writeln!(f, "      {i} '{name}' (default weight {w})")?;
                }
            }
        }
        if !self.skins.is_empty() {
            writeln!(f, "{} skin(s)", self.skins.len())?;
        }
        for s in &self.skins {
            let users: Vec<String> = (s.users.iter())
                .map(|(node, mesh)| format!("node {node} (mesh {mesh})"))
                .collect();
            writeln!(
                f,
                "  skin {} {}: {} joints, {} inverse bind matrices; drawn by {}",
                s.index,
                quoted(&s.name),
                s.joints,
                if s.inverse_binds { "with" } else { "identity" },
                if users.is_empty() {
                    "no node".to_string()
                } else {
                    users.join(", ")
                }
            )?;
        }
        writeln!(f, "{} animation(s)", self.animations.len())?;
        for a in &self.animations {
            writeln!(
                f,
                "  animation {} {}: {} weight channel(s), {} other channel(s) ({} on skin joints), {} s",
                a.index,
                quoted(&a.name),
                a.weight_channels.len(),
                a.other_channels,
                a.joint_channels,
                a.duration
            )?;
            for c in &a.weight_channels {
                let mesh = c
                    .mesh
                    .map_or("no mesh".to_string(), |m| format!("mesh {m}"));
                writeln!(
                    f,
                    "    weights of node {} ({mesh}): {}, {} keyframes, {} s",
                    c.node,
                    c.interpolation.name(),
                    c.keyframes,
                    c.duration
                )?;
            }
        }
        Ok(())
    }
}
