//! glTF 2.0 (`.gltf` + `.bin` / data URIs) and GLB input: one mesh's triangles,
//! its morph targets and the weight animations that drive them, plus a summary
//! of the file for `morphlod info`.
//!
//! Everything goes through one internal `Document`: the GLB container is split
//! here (the `gltf` crate's GLB reader subtracts the header size from the
//! declared length unchecked), the JSON is parsed and validated by the `gltf`
//! crate after a pre-check its validator needs, every buffer is resolved and
//! length-checked, and accessors are read by our own bounds-checked reader
//! instead of `gltf`'s `Reader`, which slices with file-provided offsets and
//! strides and panics when they point past the data.

use crate::io::{LoadError, LoadOptions};
use crate::mesh::IndexedMesh;
use crate::morph::{Interpolation, MorphTarget, WeightTrack};
use base64::Engine;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::fmt;
use std::path::{Path, PathBuf};

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

/// What [`crate::morph::Morph::from_gltf`] needs from a file: the selected mesh
/// (transformed as [`load_mesh`] does), its targets with deltas transformed by the
/// same matrix, its default weights, and every animation of the file with the
/// weight track that animates this mesh (`None` when it does not).
pub(crate) struct GltfMorph {
    pub mesh: IndexedMesh,
    pub mesh_name: String,
    pub targets: Vec<MorphTarget>,
    pub default_weights: Vec<f32>,
    pub animations: Vec<AnimationWeights>,
}

pub(crate) struct AnimationWeights {
    pub name: Option<String>,
    pub track: Option<WeightTrack>,
}

pub(crate) fn load_morph(path: &Path, options: &LoadOptions) -> Result<GltfMorph, LoadError> {
    let doc = Document::open(path)?;
    let mesh = doc.select_mesh(options.gltf_mesh.as_deref())?;
    let geometry = doc.geometry(&mesh, true)?;
    let names = target_names(&mesh, geometry.targets.len());
    let mut mesh_out = IndexedMesh::new(geometry.positions, geometry.triangles);
    let mut deltas = geometry.targets;
    if options.apply_transforms {
        doc.transform(&mesh, &mut mesh_out, &mut deltas)?;
    }
    let default_weights = doc.default_weights(&mesh, deltas.len())?;
    let animations = doc
        .document
        .animations()
        .map(|animation| {
            Ok(AnimationWeights {
                name: animation.name().map(str::to_string),
                track: doc.weight_track(&animation, &mesh, deltas.len())?,
            })
        })
        .collect::<Result<Vec<_>, LoadError>>()?;
    let targets = names
        .into_iter()
        .zip(deltas)
        .map(|(name, deltas)| MorphTarget { name, deltas })
        .collect();
    Ok(GltfMorph {
        mesh: mesh_out,
        mesh_name: display_name(mesh.name(), mesh.index()),
        targets,
        default_weights,
        animations,
    })
}

/// A summary of a glTF file: its meshes with their morph targets, and its
/// animations with the channels that drive morph weights.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfSummary {
    pub meshes: Vec<MeshSummary>,
    pub animations: Vec<AnimationSummary>,
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
    /// Channels animating translation, rotation or scale (not used by morphlod).
    pub other_channels: usize,
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
    let animations = doc
        .document
        .animations()
        .map(|animation| {
            let mut weight_channels = Vec::new();
            let mut other_channels = 0;
            for channel in animation.channels() {
                if channel.target().property() != gltf::animation::Property::MorphTargetWeights {
                    other_channels += 1;
                    continue;
                }
                let sampler = channel.sampler();
                let element = format!(
                    "animation {} sampler {} input",
                    display_name(animation.name(), animation.index()),
                    sampler.index()
                );
                let times = doc.read_floats(&sampler.input(), &element, Dimensions::Scalar)?;
                let node = channel.target().node();
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
            })
        })
        .collect::<Result<Vec<_>, LoadError>>()?;
    Ok(GltfSummary { meshes, animations })
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
        writeln!(f, "{} animation(s)", self.animations.len())?;
        for a in &self.animations {
            writeln!(
                f,
                "  animation {} {}: {} weight channel(s), {} other channel(s)",
                a.index,
                quoted(&a.name),
                a.weight_channels.len(),
                a.other_channels
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

fn quoted(name: &Option<String>) -> String {
    name.as_ref()
        .map_or("(unnamed)".to_string(), |n| format!("'{n}'"))
}

/// `name` when present, else the index as text: how messages name an element.
fn display_name(name: Option<&str>, index: usize) -> String {
    name.map_or(index.to_string(), |n| format!("'{n}'"))
}

/// Finds an element by exact name first, then by decimal index: names win so
/// a mesh literally called "2" stays reachable.
pub(crate) fn pick(wanted: &str, names: &[Option<&str>]) -> Option<usize> {
    names
        .iter()
        .position(|n| *n == Some(wanted))
        .or_else(|| wanted.parse::<usize>().ok().filter(|&i| i < names.len()))
}

/// `0 'a', 1 (unnamed), ...` for "not found" messages.
pub(crate) fn list_names(names: &[Option<&str>]) -> String {
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
fn target_names(mesh: &gltf::Mesh, count: usize) -> Vec<String> {
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

fn interpolation(i: gltf::animation::Interpolation) -> Interpolation {
    match i {
        gltf::animation::Interpolation::Step => Interpolation::Step,
        gltf::animation::Interpolation::Linear => Interpolation::Linear,
        gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
    }
}

/// The largest accessor without a buffer view we materialise (it reads as zeros
/// plus sparse values): its count comes from the file and no data backs it, so
/// a few bytes of JSON could otherwise ask for gigabytes. 256 MiB holds a
/// 22-million-vertex sparse morph target.
const MAX_VIEWLESS_BYTES: usize = 1 << 28;

/// Triangle primitives of one mesh, concatenated: positions, triangles and, when
/// asked, per-target POSITION deltas concatenated the same way.
struct Geometry {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    targets: Vec<Vec<[f32; 3]>>,
}

/// A validated glTF document with its buffers loaded and length-checked.
struct Document {
    path: PathBuf,
    document: gltf::Document,
    buffers: Vec<Vec<u8>>,
}

impl Document {
    fn open(path: &Path) -> Result<Document, LoadError> {
        let bytes = super::read(path)?;
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
        precheck(&root).map_err(json_error)?;
        let document = gltf::Document::from_json(root).map_err(|e| json_error(e.to_string()))?;
        let buffers = document
            .buffers()
            .map(|buffer| load_buffer(path, &buffer, bin))
            .collect::<Result<Vec<_>, LoadError>>()?;
        Ok(Document {
            path: path.to_path_buf(),
            document,
            buffers,
        })
    }

    fn data_error(&self, element: &str, message: String) -> LoadError {
        LoadError::GltfData {
            path: self.path.clone(),
            element: element.to_string(),
            message,
        }
    }

    fn unsupported(&self, element: &str, what: String) -> LoadError {
        LoadError::GltfUnsupported {
            path: self.path.clone(),
            element: element.to_string(),
            what,
        }
    }

    fn select_mesh(&self, wanted: Option<&str>) -> Result<gltf::Mesh<'_>, LoadError> {
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

    fn geometry(&self, mesh: &gltf::Mesh, with_targets: bool) -> Result<Geometry, LoadError> {
        let mut out = Geometry {
            positions: Vec::new(),
            triangles: Vec::new(),
            targets: Vec::new(),
        };
        let mesh_name = display_name(mesh.name(), mesh.index());
        for primitive in mesh.primitives() {
            let element = format!("mesh {mesh_name} primitive {}", primitive.index());
            let mode = primitive.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                return Err(self.unsupported(
                    &element,
                    format!("primitive mode {mode:?} (morphlod needs triangles)"),
                ));
            }
            let Some(position) = primitive.get(&gltf::Semantic::Positions) else {
                return Err(self.data_error(&element, "has no POSITION attribute".to_string()));
            };
            let positions = self.read_vec3(&position, &format!("{element} POSITION"))?;
            // u32 indices with 0xFFFFFFFF reserved as the strip restart downstream.
            let total = out.positions.len() + positions.len();
            if total >= u32::MAX as usize {
                return Err(self.unsupported(
                    &element,
                    format!("a mesh of {total} vertices (at most 4294967294)"),
                ));
            }
            let offset = out.positions.len() as u32;
            let corners = match primitive.indices() {
                Some(indices) => self.read_indices(&indices, &format!("{element} indices"))?,
                None => (0..positions.len() as u32).collect(),
            };
            if let Some((i, &v)) = corners
                .iter()
                .enumerate()
                .find(|(_, &v)| v as usize >= positions.len())
            {
                return Err(self.data_error(
                    &element,
                    format!(
                        "index {i} is {v}, but POSITION has only {} vertices",
                        positions.len()
                    ),
                ));
            }
            let triangles = triangulate(mode, &corners)
                .map_err(|message| self.data_error(&element, message))?;
            out.triangles.extend(
                triangles
                    .iter()
                    .map(|t| [t[0] + offset, t[1] + offset, t[2] + offset]),
            );
            if with_targets {
                self.append_targets(&primitive, &element, positions.len(), &mut out.targets)?;
            }
            out.positions.extend(positions);
        }
        Ok(out)
    }

    /// Appends one primitive's POSITION deltas to the per-target arrays. Every
    /// primitive of a mesh must have the same number of targets (glTF §3.7.2.2).
    fn append_targets(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
        vertices: usize,
        targets: &mut Vec<Vec<[f32; 3]>>,
    ) -> Result<(), LoadError> {
        let count = primitive.morph_targets().len();
        if primitive.index() == 0 {
            targets.resize(count, Vec::new());
        } else if count != targets.len() {
            return Err(self.data_error(
                element,
                format!(
                    "has {count} morph targets but primitive 0 has {}; all primitives of a mesh need the same targets",
                    targets.len()
                ),
            ));
        }
        for (t, (target, out)) in primitive
            .morph_targets()
            .zip(targets.iter_mut())
            .enumerate()
        {
            let target_element = format!("{element} target {t} POSITION");
            match target.positions() {
                Some(accessor) => {
                    let deltas = self.read_vec3(&accessor, &target_element)?;
                    if deltas.len() != vertices {
                        return Err(self.data_error(
                            &target_element,
                            format!(
                                "has {} deltas but the primitive has {vertices} vertices",
                                deltas.len()
                            ),
                        ));
                    }
                    out.extend(deltas);
                }
                // A target without POSITION moves no vertex of this primitive.
                None => out.extend(std::iter::repeat_n([0.0; 3], vertices)),
            }
        }
        Ok(())
    }

    /// `mesh.weights`, or zeros when absent; its length must match the targets.
    fn default_weights(&self, mesh: &gltf::Mesh, targets: usize) -> Result<Vec<f32>, LoadError> {
        match mesh.weights() {
            None => Ok(vec![0.0; targets]),
            Some(w) if w.len() == targets && w.iter().all(|x| x.is_finite()) => Ok(w.to_vec()),
            Some(w) => Err(self.data_error(
                &format!("mesh {} weights", display_name(mesh.name(), mesh.index())),
                format!(
                    "has {} entries {w:?} for {targets} morph targets; it needs one finite weight per target",
                    w.len()
                ),
            )),
        }
    }

    /// The weight track of the first channel of `animation` that drives the
    /// weights of a node instancing `mesh`; `None` when there is none.
    fn weight_track(
        &self,
        animation: &gltf::Animation,
        mesh: &gltf::Mesh,
        targets: usize,
    ) -> Result<Option<WeightTrack>, LoadError> {
        let channel = animation.channels().find(|c| {
            c.target().property() == gltf::animation::Property::MorphTargetWeights
                && c.target().node().mesh().map(|m| m.index()) == Some(mesh.index())
        });
        let Some(channel) = channel else {
            return Ok(None);
        };
        let sampler = channel.sampler();
        let element = format!(
            "animation {} sampler {}",
            display_name(animation.name(), animation.index()),
            sampler.index()
        );
        let times = self.read_floats(
            &sampler.input(),
            &format!("{element} input"),
            Dimensions::Scalar,
        )?;
        let values = self.read_floats(
            &sampler.output(),
            &format!("{element} output"),
            Dimensions::Scalar,
        )?;
        WeightTrack::new(
            interpolation(sampler.interpolation()),
            times,
            values,
            targets,
        )
        .map(Some)
        .map_err(|e| self.data_error(&element, e.to_string()))
    }

    /// World matrix of the first node instancing `mesh` (identity when none),
    /// applied to the positions (as points) and target deltas (as vectors).
    fn transform(
        &self,
        mesh: &gltf::Mesh,
        out: &mut IndexedMesh,
        deltas: &mut [Vec<[f32; 3]>],
    ) -> Result<(), LoadError> {
        let Some(node) = self
            .document
            .nodes()
            .find(|n| n.mesh().map(|m| m.index()) == Some(mesh.index()))
        else {
            return Ok(());
        };
        let matrix = self.world_matrix(node.index());
        for p in &mut out.positions {
            *p = matrix.transform_point3(glam::Vec3::from(*p)).to_array();
        }
        for target in deltas.iter_mut() {
            for d in target.iter_mut() {
                *d = matrix.transform_vector3(glam::Vec3::from(*d)).to_array();
            }
        }
        if matrix.determinant() < 0.0 {
            for t in &mut out.triangles {
                t.swap(1, 2);
            }
        }
        let element = format!("node {} transform", display_name(node.name(), node.index()));
        let bad = out
            .positions
            .iter()
            .chain(deltas.iter().flatten())
            .any(|p| !p.iter().all(|c| c.is_finite()));
        if bad {
            return Err(self.data_error(
                &element,
                "makes a position non-finite (overflow or NaN in the matrix)".to_string(),
            ));
        }
        Ok(())
    }

    fn world_matrix(&self, node: usize) -> glam::Mat4 {
        let count = self.document.nodes().len();
        let mut parent = vec![None; count];
        for n in self.document.nodes() {
            for child in n.children() {
                if let Some(slot) = parent.get_mut(child.index()) {
                    *slot = Some(n.index());
                }
            }
        }
        let local = |i: usize| {
            self.document
                .nodes()
                .nth(i)
                .map_or(glam::Mat4::IDENTITY, |n| {
                    glam::Mat4::from_cols_array_2d(&n.transform().matrix())
                })
        };
        let mut matrix = local(node);
        let mut current = node;
        // `precheck` refused cyclic hierarchies; the bound keeps this walk finite regardless.
        for _ in 0..count {
            match parent.get(current).copied().flatten() {
                Some(p) => {
                    matrix = local(p) * matrix;
                    current = p;
                }
                None => break,
            }
        }
        matrix
    }

    fn read_vec3(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
    ) -> Result<Vec<[f32; 3]>, LoadError> {
        let flat = self.read_floats(accessor, element, Dimensions::Vec3)?;
        Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// Reads float or normalized-integer components (glTF §3.11 decoding) and
    /// rejects non-finite values; plain integers would need KHR_mesh_quantization.
    fn read_floats(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
        dimensions: Dimensions,
    ) -> Result<Vec<f32>, LoadError> {
        let element = format!("accessor {} ({element})", accessor.index());
        if accessor.dimensions() != dimensions {
            return Err(self.data_error(
                &element,
                format!(
                    "has type {:?}, expected {dimensions:?}",
                    accessor.dimensions()
                ),
            ));
        }
        let data_type = accessor.data_type();
        if data_type != DataType::F32 && !accessor.normalized() {
            return Err(self.unsupported(
                &element,
                format!("non-normalized {data_type:?} components (KHR_mesh_quantization)"),
            ));
        }
        let bytes = self.gather(accessor, &element)?;
        let values: Vec<f32> = match data_type {
            DataType::F32 => bytes
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
            DataType::I8 => bytes
                .iter()
                .map(|&b| (b as i8 as f32 / 127.0).max(-1.0))
                .collect(),
            DataType::U8 => bytes.iter().map(|&b| b as f32 / 255.0).collect(),
            DataType::I16 => bytes
                .chunks_exact(2)
                .map(|b| (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0))
                .collect(),
            DataType::U16 => bytes
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0)
                .collect(),
            DataType::U32 => {
                return Err(self.unsupported(
                    &element,
                    "normalized UNSIGNED_INT components (not allowed by glTF)".to_string(),
                ))
            }
        };
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            let c = dimensions.multiplicity();
            return Err(self.data_error(
                &element,
                format!(
                    "element {} component {} is {}: fix the exporter or the file",
                    i / c,
                    i % c,
                    values[i]
                ),
            ));
        }
        Ok(values)
    }

    fn read_indices(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
    ) -> Result<Vec<u32>, LoadError> {
        let element = format!("accessor {} ({element})", accessor.index());
        if accessor.dimensions() != Dimensions::Scalar || accessor.normalized() {
            return Err(self.data_error(
                &element,
                "indices must be non-normalized SCALAR values".to_string(),
            ));
        }
        let bytes = self.gather(accessor, &element)?;
        match accessor.data_type() {
            DataType::U8 => Ok(bytes.iter().map(|&b| b as u32).collect()),
            DataType::U16 => Ok(bytes
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]) as u32)
                .collect()),
            DataType::U32 => Ok(bytes
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect()),
            other => Err(self.data_error(
                &element,
                format!(
                    "indices must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, not {other:?}"
                ),
            )),
        }
    }

    /// The bytes of a buffer view, after checking the view lies inside its buffer.
    fn view_bytes(&self, view: &gltf::buffer::View, element: &str) -> Result<&[u8], LoadError> {
        let buffer = self
            .buffers
            .get(view.buffer().index())
            .map_or(&[][..], |b| b);
        let end = view.offset().checked_add(view.length());
        match end {
            Some(end) if end <= buffer.len() => Ok(&buffer[view.offset()..end]),
            _ => Err(self.data_error(
                element,
                format!(
                    "buffer view {} (byteOffset {}, byteLength {}) runs past the end of buffer {} ({} bytes)",
                    view.index(),
                    view.offset(),
                    view.length(),
                    view.buffer().index(),
                    buffer.len()
                ),
            )),
        }
    }

    /// The accessor's elements as tightly packed little-endian bytes, with its
    /// sparse substitutions applied. Every offset, stride and count comes from
    /// the file, so each range is checked (with overflow-checked arithmetic)
    /// before it is read.
    fn gather(&self, accessor: &gltf::Accessor, element: &str) -> Result<Vec<u8>, LoadError> {
        if matches!(
            accessor.dimensions(),
            Dimensions::Mat2 | Dimensions::Mat3 | Dimensions::Mat4
        ) {
            // Matrix columns carry alignment padding; no morph data uses them.
            return Err(self.unsupported(element, "matrix accessors".to_string()));
        }
        let size = accessor.size();
        let count = accessor.count();
        let mut out = match accessor.view() {
            Some(view) => {
                let bytes = self.view_bytes(&view, element)?;
                let stride = view.stride().unwrap_or(size);
                if stride < size {
                    return Err(self.data_error(
                        element,
                        format!("byteStride {stride} is smaller than one element ({size} bytes)"),
                    ));
                }
                let end = match count {
                    0 => Some(accessor.offset()),
                    _ => stride
                        .checked_mul(count - 1)
                        .and_then(|s| s.checked_add(accessor.offset()))
                        .and_then(|s| s.checked_add(size)),
                };
                if end.is_none_or(|e| e > bytes.len()) {
                    return Err(self.data_error(
                        element,
                        format!(
                            "byteOffset {} + byteStride {stride} × ({count} − 1) + {size} runs past buffer view {} ({} bytes)",
                            accessor.offset(),
                            view.index(),
                            bytes.len()
                        ),
                    ));
                }
                let mut out = Vec::with_capacity(count * size);
                for i in 0..count {
                    let start = accessor.offset() + i * stride;
                    out.extend_from_slice(&bytes[start..start + size]);
                }
                out
            }
            None => {
                let bytes = count.checked_mul(size).filter(|&b| b <= MAX_VIEWLESS_BYTES);
                let Some(bytes) = bytes else {
                    return Err(self.unsupported(
                        element,
                        format!("an accessor without bufferView of {count} elements of {size} bytes (at most {MAX_VIEWLESS_BYTES} bytes)"),
                    ));
                };
                vec![0; bytes]
            }
        };
        if let Some(sparse) = accessor.sparse() {
            let n = sparse.count();
            let indices = sparse.indices();
            let index_size = match indices.index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            let index_bytes = self.view_bytes(&indices.view(), element)?;
            let value_bytes = self.view_bytes(&sparse.values().view(), element)?;
            let index_range = n
                .checked_mul(index_size)
                .and_then(|l| l.checked_add(indices.offset()))
                .filter(|&e| e <= index_bytes.len());
            let value_range = n
                .checked_mul(size)
                .and_then(|l| l.checked_add(sparse.values().offset()))
                .filter(|&e| e <= value_bytes.len());
            if index_range.is_none() || value_range.is_none() {
                return Err(self.data_error(
                    element,
                    format!("sparse storage of {n} entries runs past its buffer views"),
                ));
            }
            let index_bytes = &index_bytes[indices.offset()..];
            let value_bytes = &value_bytes[sparse.values().offset()..];
            for s in 0..n {
                let b = &index_bytes[s * index_size..(s + 1) * index_size];
                let target = match index_size {
                    1 => b[0] as usize,
                    2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
                };
                if target >= count {
                    return Err(self.data_error(
                        element,
                        format!("sparse entry {s} replaces element {target}, but the accessor has {count}"),
                    ));
                }
                out[target * size..(target + 1) * size]
                    .copy_from_slice(&value_bytes[s * size..(s + 1) * size]);
            }
        }
        Ok(out)
    }
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
        gltf::buffer::Source::Uri(uri) => {
            if let Some(rest) = uri.strip_prefix("data:") {
                let Some((header, payload)) = rest.split_once(',') else {
                    return Err(data_error(
                        "data URI has no ',' before its data".to_string(),
                    ));
                };
                if !header.ends_with(";base64") {
                    return Err(LoadError::GltfUnsupported {
                        path: path.to_path_buf(),
                        element,
                        what: format!("a data URI that is not base64 (data:{header})"),
                    });
                }
                base64::engine::general_purpose::STANDARD
                    .decode(payload)
                    .map_err(|e| data_error(format!("data URI is not valid base64: {e}")))?
            } else if uri.contains("://") {
                return Err(LoadError::GltfUnsupported {
                    path: path.to_path_buf(),
                    element,
                    what: format!("the non-local URI '{uri}'"),
                });
            } else {
                let file = path
                    .parent()
                    .unwrap_or(Path::new(""))
                    .join(percent_decode(uri));
                std::fs::read(&file).map_err(|source| LoadError::GltfExternal {
                    path: path.to_path_buf(),
                    buffer: buffer.index(),
                    file,
                    source,
                })?
            }
        }
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

/// URIs in glTF are percent-encoded (`my%20mesh.bin`).
fn percent_decode(uri: &str) -> String {
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

/// Corner list → triangles. Strips alternate orientation, so odd triangles swap
/// their last two corners (glTF §3.7.2.1) to stay front-facing; strip and fan
/// triangles with a repeated corner are the joints exporters use to stitch
/// strips and draw nothing, so they are dropped.
fn triangulate(mode: Mode, corners: &[u32]) -> Result<Vec<[u32; 3]>, String> {
    match mode {
        Mode::Triangles => {
            if !corners.len().is_multiple_of(3) {
                return Err(format!(
                    "TRIANGLES needs a multiple of 3 indices, has {}",
                    corners.len()
                ));
            }
            Ok(corners
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect())
        }
        Mode::TriangleStrip => Ok(corners
            .windows(3)
            .enumerate()
            .map(|(i, w)| {
                if i % 2 == 0 {
                    [w[0], w[1], w[2]]
                } else {
                    [w[0], w[2], w[1]]
                }
            })
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect()),
        Mode::TriangleFan => Ok(corners
            .windows(2)
            .skip(1)
            .map(|w| [w[0], w[1], corners[0]])
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect()),
        other => Err(format!("primitive mode {other:?} is not triangles")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
