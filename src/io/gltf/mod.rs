//! glTF 2.0 (`.gltf` + `.bin` / data URIs) and GLB input: one mesh's triangles,
//! its morph targets and the weight animations that drive them (this module: file → mesh,
//! file → [`Morph`]), plus a summary of the file for `morphlod info` ([`summary`]).
//!
//! Everything goes through one internal `Document` (`document.rs`): the GLB container is
//! split there (the `gltf` crate's GLB reader subtracts the header size from the
//! declared length unchecked), the JSON is parsed and validated by the `gltf`
//! crate after a pre-check its validator needs, every buffer is resolved and
//! length-checked, and accessors are read by our own bounds-checked reader
//! (`accessor.rs`) instead of `gltf`'s `Reader`, which slices with file-provided offsets
//! and strides and panics when they point past the data.

mod accessor;
mod animation;
mod attributes;
mod document;
pub(crate) mod meshopt_compression;
#[cfg(test)]
mod morph_tests;
mod nodes;
mod primitives;
mod scene;
mod skin;
#[cfg(test)]
mod skin_tests;
#[cfg(feature = "export")]
pub(crate) use scene::texture_infos;
pub mod summary;
pub mod write;

pub use crate::skin::{NodeProperty, NodeTrack};
pub use summary::{
    inspect, AnimationSummary, GltfSummary, MeshSummary, SkinSummary, WeightChannelSummary,
};

use crate::io::{AttributedMesh, LoadError, LoadOptions};
use crate::mesh::IndexedMesh;
use crate::morph::{Attributes, Interpolation, Morph, MorphTarget, WeightTrack, Weights};
use crate::skin::Skinning;
use attributes::VertexAttributes;
use document::Document;
use skin::SkinRead;
use std::path::Path;

/// Which poses of a glTF mesh's morph targets make the morph.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MorphSource {
    /// One target, by name (from `mesh.extras.targetNames`) or index:
    /// `V(0)` = base (all weights 0, ignoring the mesh's default weights, so the
    /// morph shows exactly that target), `V(1)` = base + the target at weight 1.
    Target(String),
    /// A weight animation, by name or index, played over its whole duration,
    /// evaluated with its own interpolation (STEP, LINEAR or CUBICSPLINE). For a skinned
    /// mesh (its node has a skin, its primitives JOINTS_0 and WEIGHTS_0) any animation: a
    /// skinned morph whose clip is the animation's channels on the skeleton and whose weights
    /// are its weight channel (held to the animation's length), or the mesh's default weights
    /// when it has none ([`crate::skin`]).
    Animation(String),
    /// A skinned mesh's animation `animation` (as [`MorphSource::Animation`]) with the weight
    /// channel of animation `weights` (another one, such as a body's shape animation beside a
    /// walk), played over the clip: as `t` runs over `[0, 1]` the clip plays once and the
    /// weight animation once, each over its own length.
    AnimationWithWeights { animation: String, weights: String },
    /// `V(0)` = base (all weights 0), `V(1)` = the mesh's default weights
    /// (`mesh.weights`, all 0 when absent).
    DefaultWeights,
}

/// Loads the triangles of one mesh (all its triangle primitives, concatenated).
/// `options.gltf_mesh` picks the mesh by name or index (default: the first);
/// with `options.apply_transforms` the world matrix of the first node that
/// instances the mesh is applied (winding flipped under a mirroring matrix so
/// front faces stay counter-clockwise).
pub fn load_mesh(path: &Path, options: &LoadOptions) -> Result<IndexedMesh, LoadError> {
    let doc = Document::open(path)?;
    let mesh = doc.select_mesh(options.gltf_mesh.as_deref())?;
    let geometry = doc.geometry(&mesh, false)?;
    let mut mesh_out = IndexedMesh::new(geometry.positions, geometry.triangles);
    if options.apply_transforms {
        doc.transform(&mesh, &mut mesh_out, &mut [])?;
    }
    super::validated(mesh_out, path)
}

/// A node's local transform as a glTF file states it.
#[derive(Clone, Debug, PartialEq)]
pub enum NodeTransform {
    /// `matrix`, column-major.
    Matrix([f32; 16]),
    /// `translation`, `rotation` (a unit quaternion x, y, z, w) and `scale`.
    Trs {
        translation: [f32; 3],
        rotation: [f32; 4],
        scale: [f32; 3],
    },
}

impl NodeTransform {
    /// The transform that moves nothing.
    pub const IDENTITY: NodeTransform = NodeTransform::Trs {
        translation: [0.0; 3],
        rotation: [0.0, 0.0, 0.0, 1.0],
        scale: [1.0; 3],
    };
}

/// One node of a scene: its name and local transform, exactly as the file has them, and its
/// parent.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceNode {
    pub name: Option<String>,
    pub transform: NodeTransform,
    /// The parent's index in [`SourceScene::nodes`] (always smaller than this node's);
    /// `None` for a scene root.
    pub parent: Option<usize>,
}

/// One animation of the file, as far as it drives what an export writes.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceAnimation {
    /// Its index in the file.
    pub index: usize,
    pub name: Option<String>,
    /// Its channel on the weights of the mesh's node, as the file has it.
    pub weights: Option<WeightTrack>,
    /// Its channels on the translations, rotations and scales of [`SourceScene::nodes`]: the
    /// node's index there and the track.
    pub channels: Vec<(usize, NodeTrack)>,
}

/// A skin as the file has it, its nodes as indices in [`SourceScene::nodes`].
#[derive(Clone, Debug, PartialEq)]
pub struct SourceSkin {
    pub name: Option<String>,
    pub joints: Vec<usize>,
    pub skeleton: Option<usize>,
    /// Column-major, one per joint (a file's extra ones dropped).
    pub inverse_bind_matrices: Option<Vec<[f32; 16]>>,
}

/// A vertex attribute a morph does not hold, as the file stores it: an export writes each
/// kept vertex's element bytes unchanged.
#[derive(Clone, Debug, PartialEq)]
pub struct RawAttribute {
    /// The file's name for it (`TANGENT`, `JOINTS_0`, `TEXCOORD_1`, `_BATCHID`, ...).
    pub semantic: String,
    /// The accessor type: `SCALAR`, `VEC2`, `VEC3` or `VEC4`.
    pub kind: &'static str,
    /// The accessor's componentType (5120 BYTE to 5126 FLOAT).
    pub component_type: u32,
    pub normalized: bool,
    /// One element per vertex of the primitives concatenated (as the morph's vertices are),
    /// tightly packed, little-endian.
    pub data: Vec<u8>,
}

impl RawAttribute {
    /// Bytes per component.
    pub fn component_size(&self) -> usize {
        match self.component_type {
            5120 | 5121 => 1,
            5122 | 5123 => 2,
            _ => 4,
        }
    }

    /// Bytes per element (one vertex's value).
    pub fn element_size(&self) -> usize {
        let components = match self.kind {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 4,
        };
        components * self.component_size()
    }
}

/// The material of the mesh's first primitive as the file has it, for an export to write
/// again: every factor, texture and extension, not only what a morph draws with.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceMaterial {
    /// The material object verbatim, but for its texture infos (every `...Texture` member
    /// with an `index`, in the core material or in its extensions): each `index` names one of
    /// `textures`; `texCoord` still names the file's TEXCOORD set.
    pub json: serde_json::Value,
    pub textures: Vec<SourceTexture>,
    pub images: Vec<SourceImage>,
    /// The extensions the material and its texture infos use, and which of them the file
    /// requires.
    pub extensions_used: Vec<String>,
    pub extensions_required: Vec<String>,
}

/// A texture of a [`SourceMaterial`]: its image (an index in [`SourceMaterial::images`]) and
/// its sampler object as the file has it (`None`: glTF's default sampler).
#[derive(Clone, Debug, PartialEq)]
pub struct SourceTexture {
    pub image: usize,
    pub sampler: Option<serde_json::Value>,
}

/// An encoded image as the file stores it (header checked).
#[derive(Clone, Debug, PartialEq)]
pub struct SourceImage {
    pub format: crate::morph::ImageFormat,
    pub bytes: Vec<u8>,
}

/// What an export carries from a glTF file besides the morph (module `scene`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SourceScene {
    /// The node that instances the mesh and its ancestors; for a skinned mesh also the
    /// skin's joints and skeleton and theirs. Parents come before their children.
    pub nodes: Vec<SourceNode>,
    /// The node that instances the mesh, in `nodes`; `None` (and `nodes` empty) when no
    /// node does.
    pub mesh_node: Option<usize>,
    /// The mesh node's skin, kept when the mesh binds its vertices to it (JOINTS_0 and
    /// WEIGHTS_0 on every primitive).
    pub skin: Option<SourceSkin>,
    /// Every animation of the file that drives the mesh's weights or one of `nodes`, in file
    /// order (an animation that drives neither is named in `left_out`).
    pub animations: Vec<SourceAnimation>,
    /// The vertex attributes a morph does not hold: all but POSITION, NORMAL, COLOR_0 and
    /// the TEXCOORD set of the base-colour texture, kept when every primitive stores them
    /// alike (JOINTS_n and WEIGHTS_n only in pairs, and only with a skin).
    pub attributes: Vec<RawAttribute>,
    /// Per morph target, its deltas of those attributes (TANGENT, where every primitive
    /// gives them and the base has TANGENT).
    pub target_attributes: Vec<Vec<RawAttribute>>,
    /// The material, whole; `None` for a primitive without one (glTF's default material).
    pub material: Option<SourceMaterial>,
    /// The TEXCOORD set the morph's UVs were read from (the base-colour texture's).
    pub uv_set: u32,
    /// What the file has for this mesh that is not carried, a line each.
    pub left_out: Vec<String>,
}

/// What an export of the mesh `options` picks carries from the file besides the morph
/// ([`SourceScene`]): its nodes, skin, every animation's channels on them and on the mesh's
/// weights, the material and the vertex attributes a morph does not hold. The nodes'
/// placement is the one [`load_mesh`] applies with `options.apply_transforms`, which is
/// itself ignored here: the raw attributes are as stored, in the mesh's own coordinates, so
/// they go with a morph loaded without it (a baked transform would not turn their TANGENTs).
pub fn source_scene(path: &Path, options: &LoadOptions) -> Result<SourceScene, LoadError> {
    let doc = Document::open(path)?;
    let mesh = doc.select_mesh(options.gltf_mesh.as_deref())?;
    doc.source_scene(&mesh)
}

/// One mesh with its vertex attributes and material ([`crate::io::load_attributed`]):
/// chosen and placed by `options` as [`load_mesh`] does; its targets are not kept.
pub fn load_attributed(path: &Path, options: &LoadOptions) -> Result<AttributedMesh, LoadError> {
    let data = read_morph(&Document::open(path)?, options)?;
    Ok(AttributedMesh::unsplit(
        super::validated(data.mesh, path)?,
        data.attributes,
    ))
}

/// What [`load_morph`] needs from a file: the selected mesh
/// (transformed as [`load_mesh`] does), its targets with deltas transformed by the
/// same matrix, its vertex attributes and material, its default weights, and every
/// animation of the file with the weight track that animates this mesh (`None` when it
/// does not).
struct GltfMorph {
    mesh: IndexedMesh,
    mesh_name: String,
    targets: Vec<MorphTarget>,
    attributes: Attributes,
    default_weights: Vec<f32>,
    /// Per animation of the file, its weight track for this mesh.
    animations: Vec<Option<WeightTrack>>,
}

fn read_morph(doc: &Document, options: &LoadOptions) -> Result<GltfMorph, LoadError> {
    let mesh = doc.select_mesh(options.gltf_mesh.as_deref())?;
    let geometry = doc.geometry(&mesh, true)?;
    let names = target_names(&mesh, geometry.targets.len());
    let mut mesh_out = IndexedMesh::new(geometry.positions, geometry.triangles);
    let mut deltas = geometry.targets;
    let VertexAttributes {
        mut normals,
        uvs,
        colors,
        mut target_normals,
        material,
    } = geometry.attributes;
    if options.apply_transforms {
        doc.transform(&mesh, &mut mesh_out, &mut deltas)?;
        doc.transform_normals(&mesh, normals.as_mut(), &mut target_normals)?;
    }
    let default_weights = doc.default_weights(&mesh, deltas.len())?;
    let animations = doc
        .document
        .animations()
        .map(|animation| doc.weight_track(&animation, &mesh, deltas.len()))
        .collect::<Result<Vec<_>, LoadError>>()?;
    let targets = names
        .into_iter()
        .zip(deltas)
        .zip(target_normals)
        .map(|((name, deltas), normal_deltas)| MorphTarget {
            name,
            deltas,
            normal_deltas,
        })
        .collect();
    let attributes = Attributes {
        normals,
        uvs,
        colors,
        material: doc.material(material)?,
    };
    Ok(GltfMorph {
        mesh: mesh_out,
        mesh_name: display_name(mesh.name(), mesh.index()),
        targets,
        attributes,
        default_weights,
        animations,
    })
}

/// A morph from a glTF mesh's morph targets (see [`MorphSource`]). The mesh is
/// chosen and placed by `options` exactly as [`load_mesh`] does (a skinned mesh is not placed:
/// its joints place it). What loading changed is dropped; [`load_morph_noted`] returns it.
pub fn load_morph(
    path: &Path,
    options: &LoadOptions,
    source: &MorphSource,
) -> Result<Morph, LoadError> {
    load_morph_noted(path, options, source).map(|(morph, _)| morph)
}

/// [`load_morph`], and what loading changed that a user should be told, a line each (a
/// skin's weights renormalised).
pub fn load_morph_noted(
    path: &Path,
    options: &LoadOptions,
    source: &MorphSource,
) -> Result<(Morph, Vec<String>), LoadError> {
    let doc = Document::open(path)?;
    let mesh = doc.select_mesh(options.gltf_mesh.as_deref())?;
    let clip = match source {
        MorphSource::Animation(a) => Some((a, None)),
        MorphSource::AnimationWithWeights { animation, weights } => {
            Some((animation, Some(weights.as_str())))
        }
        _ => None,
    };
    if let Some((animation, weights)) = clip {
        if let Some(read) = doc.skin_of(&mesh)? {
            // The skin places the mesh: its node's transform is not applied.
            let options = LoadOptions {
                apply_transforms: false,
                ..options.clone()
            };
            let data = read_morph(&doc, &options)?;
            return skinned_morph(&doc, data, read, animation, weights);
        }
        if weights.is_some() {
            return Err(LoadError::NotSkinned {
                path: path.to_path_buf(),
                mesh: display_name(mesh.name(), mesh.index()),
                what: "a weight animation played beside a clip".into(),
            });
        }
    }
    let data = read_morph(&doc, options)?;
    let shown = path.to_path_buf();
    if data.targets.is_empty() {
        return Err(LoadError::NoTargets {
            path: shown,
            mesh: data.mesh_name,
        });
    }
    let mut targets = data.targets;
    let weights = match source {
        MorphSource::Target(wanted) => {
            let names: Vec<Option<&str>> = targets.iter().map(|t| Some(t.name.as_str())).collect();
            let Some(i) = pick(wanted, &names) else {
                return Err(LoadError::NoSuchTarget {
                    path: shown,
                    wanted: wanted.clone(),
                    available: list_names(&names),
                });
            };
            // Only the chosen target contributes, so keep only its deltas.
            targets = vec![targets.swap_remove(i)];
            Weights::TwoPose {
                w0: vec![0.0],
                w1: vec![1.0],
            }
        }
        MorphSource::DefaultWeights => Weights::TwoPose {
            w0: vec![0.0; targets.len()],
            w1: data.default_weights,
        },
        MorphSource::Animation(wanted)
        | MorphSource::AnimationWithWeights {
            animation: wanted, ..
        } => {
            let i = animation_index(&doc, wanted)?;
            match data.animations.into_iter().nth(i).flatten() {
                Some(track) => Weights::Animated(track),
                None => {
                    return Err(LoadError::NoWeightChannel {
                        path: shown,
                        animation: wanted.clone(),
                        mesh: data.mesh_name,
                    })
                }
            }
        }
    };
    let morph = Morph::from_parts(data.mesh.triangles, data.mesh.positions, targets, weights)?
        .with_attributes(data.attributes)?;
    Ok((morph, Vec::new()))
}

/// The animation `wanted` names (a name, else a decimal index).
fn animation_index(doc: &Document, wanted: &str) -> Result<usize, LoadError> {
    let names: Vec<Option<&str>> = doc.document.animations().map(|a| a.name()).collect();
    pick(wanted, &names).ok_or_else(|| LoadError::NoSuchAnimation {
        path: doc.path.clone(),
        wanted: wanted.to_string(),
        available: list_names(&names),
    })
}

/// The skinned morph of `data` posed by the skin `read` and the clip of animation
/// `animation`; its weights from `weights`' weight channel when given, else from the clip's
/// own (held to the clip's length), else the mesh's default weights, constant. It loops when
/// both the joints and the weights end where they start.
fn skinned_morph(
    doc: &Document,
    data: GltfMorph,
    read: SkinRead,
    animation: &str,
    weights: Option<&str>,
) -> Result<(Morph, Vec<String>), LoadError> {
    let animations: Vec<gltf::Animation> = doc.document.animations().collect();
    let clip_animation = &animations[animation_index(doc, animation)?];
    let mut clip = doc.clip(clip_animation, &read)?;
    let mut tracks = data.animations.into_iter();
    let track = match weights {
        Some(wanted) => {
            let i = animation_index(doc, wanted)?;
            let track = tracks.nth(i).flatten();
            if track.is_none() {
                return Err(LoadError::NoWeightChannel {
                    path: doc.path.clone(),
                    animation: wanted.to_string(),
                    mesh: data.mesh_name,
                });
            }
            track
        }
        None => tracks
            .nth(clip_animation.index())
            .flatten()
            .map(|t| t.held_until(clip.duration)),
    };
    let weights_loop = track.as_ref().is_none_or(WeightTrack::returns_to_start);
    clip.looping = weights_loop && clip.returns_to_start(&read.skin.skeleton);
    let weights = match track {
        Some(track) => Weights::Animated(track),
        None => Weights::TwoPose {
            w0: data.default_weights.clone(),
            w1: data.default_weights,
        },
    };
    let mut notes = Vec::new();
    let changed = read.renormalized;
    if changed.vertices > 0 {
        notes.push(format!(
            "{}: the weights of {} vertices did not sum to 1 (furthest: {}) and were renormalised",
            read.element, changed.vertices, changed.worst_sum
        ));
    }
    let morph = Morph::from_parts(
        data.mesh.triangles,
        data.mesh.positions,
        data.targets,
        weights,
    )?
    .with_attributes(data.attributes)?
    .with_skinning(Skinning {
        skin: read.skin,
        clip,
    })?;
    Ok((morph, notes))
}

pub(super) fn quoted(name: &Option<String>) -> String {
    name.as_ref()
        .map_or("(unnamed)".to_string(), |n| format!("'{n}'"))
}

/// `name` when present, else the index as text: how messages name an element.
pub(super) fn display_name(name: Option<&str>, index: usize) -> String {
    name.map_or(index.to_string(), |n| format!("'{n}'"))
}

/// Finds an element by exact name first, then by decimal index: names win so
/// a mesh literally called "2" stays reachable.
pub(super) fn pick(wanted: &str, names: &[Option<&str>]) -> Option<usize> {
    names
        .iter()
        .position(|n| *n == Some(wanted))
        .or_else(|| wanted.parse::<usize>().ok().filter(|&i| i < names.len()))
}

/// `0 'a', 1 (unnamed), ...` for "not found" messages.
pub(super) fn list_names(names: &[Option<&str>]) -> String {
    if names.is_empty() {
        return "(none)".to_string();
    }
    names
        .iter()
        .enumerate()
        .map(|(i, n)| n.map_or(format!("{i} (unnamed)"), |n| format!("{i} '{n}'")))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Target names from `mesh.extras.targetNames` (the de-facto convention); a
/// missing or non-string entry becomes `target {i}`.
pub(super) fn target_names(mesh: &gltf::Mesh, count: usize) -> Vec<String> {
    let names: Vec<gltf::json::Value> = mesh
        .extras()
        .as_ref()
        .and_then(|raw| gltf::json::deserialize::from_str::<gltf::json::Value>(raw.get()).ok())
        .and_then(|extras| extras.get("targetNames")?.as_array().cloned())
        .unwrap_or_default();
    (0..count)
        .map(|i| {
            names
                .get(i)
                .and_then(|v| v.as_str())
                .map_or(format!("target {i}"), str::to_string)
        })
        .collect()
}

pub(super) fn interpolation(i: gltf::animation::Interpolation) -> Interpolation {
    match i {
        gltf::animation::Interpolation::Step => Interpolation::Step,
        gltf::animation::Interpolation::Linear => Interpolation::Linear,
        gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
    }
}

#[cfg(test)]
mod tests {
    use super::accessor::triangulate;
    use super::document::percent_decode;
    use super::*;
    use gltf::mesh::Mode;
    use std::path::PathBuf;

    #[test]
    fn strips_keep_orientation_and_fans_follow_the_spec() {
        // Strip 0 1 2 3 4: triangles (0,1,2), (1,3,2), (2,3,4): all the same winding
        // as drawn by a GPU strip (odd triangles swapped).
        assert_eq!(
            triangulate(Mode::TriangleStrip, &[0, 1, 2, 3, 4]).unwrap(),
            vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]
        );
        // Degenerate joints (repeated corners) are dropped; parity still counts
        // them: (3,4,5) sits at odd position 5, so it is drawn as (3,5,4).
        assert_eq!(
            triangulate(Mode::TriangleStrip, &[0, 1, 2, 2, 3, 3, 4, 5]).unwrap(),
            vec![[0, 1, 2], [3, 5, 4]]
        );
        // Fan 0 1 2 3: (1,2,0), (2,3,0) per glTF §3.7.2.1.
        assert_eq!(
            triangulate(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap(),
            vec![[1, 2, 0], [2, 3, 0]]
        );
        assert!(triangulate(Mode::Triangles, &[0, 1]).is_err());
    }

    #[test]
    fn pick_prefers_names_then_indices() {
        let names = [Some("a"), None, Some("0")];
        assert_eq!(pick("a", &names), Some(0));
        assert_eq!(pick("0", &names), Some(2));
        assert_eq!(pick("1", &names), Some(1));
        assert_eq!(pick("3", &names), None);
        assert_eq!(list_names(&names), "0 'a', 1 (unnamed), 2 '0'");
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("my%20mesh.bin"), "my mesh.bin");
        assert_eq!(percent_decode("100%"), "100%");
    }

    fn asset(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("assets")
            .join(name)
    }

    #[test]
    fn loads_the_animated_morph_cube() {
        let path = asset("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf");
        let mesh = load_mesh(&path, &LoadOptions::default()).unwrap();
        assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (24, 12));
        mesh.validate().unwrap();
        // The node scales by 100: the cube's 0.01 half-size becomes 1.
        let placed = LoadOptions {
            apply_transforms: true,
            ..LoadOptions::default()
        };
        let moved = load_mesh(&path, &placed).unwrap();
        let (lo, hi) = moved.bounds().unwrap();
        assert!(
            lo.iter().chain(&hi).all(|c| (c.abs() - 1.0).abs() < 1e-3),
            "{lo:?} {hi:?}"
        );
        let summary = inspect(&path).unwrap();
        assert_eq!(summary.meshes.len(), 1);
        assert_eq!(summary.meshes[0].target_names.len(), 2);
        assert_eq!(summary.animations.len(), 1);
        let channel = &summary.animations[0].weight_channels[0];
        assert_eq!(channel.interpolation, Interpolation::Linear);
        assert_eq!(channel.keyframes, 127);
        assert!((channel.duration - 4.2).abs() < 1e-3);
        let text = summary.to_string();
        assert!(
            text.contains("'Cube'") && text.contains("'Square'"),
            "{text}"
        );
    }

    #[test]
    fn loads_the_makehuman_files() {
        let body = asset("makehuman_body.glb");
        let mesh = load_mesh(&body, &LoadOptions::default()).unwrap();
        assert_eq!(
            (mesh.vertex_count(), mesh.triangle_count()),
            (13_380, 26_756)
        );
        mesh.validate().unwrap();
        let summary = inspect(&body).unwrap();
        assert_eq!(
            summary.meshes[0].target_names,
            [
                "caucasian-male-young",
                "caucasian-female-old",
                "caucasian-male-baby",
                "universal-male-young-averagemuscle-maxweight"
            ]
        );
        assert_eq!(summary.meshes[0].default_weights, vec![0.0; 4]);
        let channel = &summary.animations[0].weight_channels[0];
        assert_eq!((channel.keyframes, channel.duration), (9, 8.0));
        let head = asset("makehuman_head.glb");
        let summary = inspect(&head).unwrap();
        let m = &summary.meshes[0];
        assert_eq!((m.vertices, m.triangles), (4_437, 8_818));
        assert_eq!(m.target_names.len(), 8);
        assert_eq!(m.target_names[0], "jawOpen");
        assert_eq!(m.target_names[7], "mouthPucker");
    }

    #[test]
    fn unknown_mesh_lists_the_available_ones() {
        let path = asset("makehuman_head.glb");
        let options = LoadOptions {
            gltf_mesh: Some("face".to_string()),
            ..LoadOptions::default()
        };
        let err = load_mesh(&path, &options).unwrap_err();
        assert!(matches!(err, LoadError::GltfNotFound { kind: "mesh", .. }));
        assert!(
            err.to_string()
                .contains("no mesh 'face'; the file has: 0 (unnamed)"),
            "{err}"
        );
    }
}
