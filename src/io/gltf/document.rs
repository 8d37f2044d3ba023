//! The validated glTF document: container split, JSON pre-check and validation, buffers
//! resolved and length-checked, and the mesh-level reads (geometry, targets, default
//! weights, weight tracks, node transforms). Accessor data is read in `accessor.rs`.

use super::accessor::triangulate;
use super::attributes::{MeshAttributes, VertexAttributes};
use super::{display_name, interpolation, list_names, pick};
use crate::io::LoadError;
use crate::mesh::IndexedMesh;
use crate::morph::WeightTrack;
use base64::Engine;
use gltf::accessor::Dimensions;
use gltf::mesh::Mode;
use std::path::{Path, PathBuf};

/// The largest accessor without a buffer view we materialise (it reads as zeros
/// plus sparse values): its count comes from the file and no data backs it, so
/// a few bytes of JSON could otherwise ask for gigabytes. 256 MiB holds a
/// 22-million-vertex sparse morph target.
pub(super) const MAX_VIEWLESS_BYTES: usize = 1 << 28;

/// Triangle primitives of one mesh, concatenated: positions, triangles and, for a morph,
/// per-target POSITION deltas and the vertex attributes concatenated the same way.
pub(super) struct Geometry {
    pub(super) positions: Vec<[f32; 3]>,
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) targets: Vec<Vec<[f32; 3]>>,
    /// Empty unless read for a morph.
    pub(super) attributes: VertexAttributes,
}

/// A validated glTF document with its buffers loaded and length-checked.
pub(super) struct Document {
    pub(super) path: PathBuf,
    pub(super) document: gltf::Document,
    pub(super) raw: serde_json::Value,
    pub(super) buffers: Vec<Vec<u8>>,
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
            .map(|buffer| load_buffer(path, &buffer, bin))
            .collect::<Result<Vec<_>, LoadError>>()?;
        Ok(Document {
            path: path.to_path_buf(),
            document,
            raw,
            buffers,
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

    /// The mesh's triangle primitives concatenated; with `morph`, also their morph targets'
    /// POSITION deltas and the vertex attributes. A primitive without POSITION is skipped
    /// (glTF: clients "SHOULD skip primitive's rendering").
    pub(super) fn geometry(&self, mesh: &gltf::Mesh, morph: bool) -> Result<Geometry, LoadError> {
        let mut out = Geometry {
            positions: Vec::new(),
            triangles: Vec::new(),
            targets: Vec::new(),
            attributes: VertexAttributes::default(),
        };
        let mut attributes = MeshAttributes::default();
        let mut first = true;
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
                continue;
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
            if morph {
                self.append_targets(
                    &primitive,
                    &element,
                    positions.len(),
                    first,
                    &mut out.targets,
                )?;
                self.append_attributes(&primitive, &element, positions.len(), &mut attributes)?;
            }
            first = false;
            out.positions.extend(positions);
        }
        if morph {
            out.attributes = attributes.finish();
        }
        Ok(out)
    }

    /// Appends one primitive's POSITION deltas to the per-target arrays (`first`: the
    /// first primitive read, which sets the target count). Every primitive of a mesh must
    /// have the same number of targets (glTF §3.7.2.2).
    pub(super) fn append_targets(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
        vertices: usize,
        first: bool,
        targets: &mut Vec<Vec<[f32; 3]>>,
    ) -> Result<(), LoadError> {
        let count = primitive.morph_targets().len();
        if first {
            targets.resize(count, Vec::new());
        } else if count != targets.len() {
            return Err(self.data_error(
                element,
                format!(
                    "has {count} morph targets but the first primitive has {}; all primitives of a mesh need the same targets",
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
    pub(super) fn default_weights(
        &self,
        mesh: &gltf::Mesh,
        targets: usize,
    ) -> Result<Vec<f32>, LoadError> {
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
    pub(super) fn weight_track(
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
        let (element, times, values) =
            self.sampler_keys(animation, &sampler, Dimensions::Scalar)?;
        WeightTrack::new(
            interpolation(sampler.interpolation()),
            times,
            values,
            targets,
        )
        .map(Some)
        .map_err(|e| self.data_error(&element, e.to_string()))
    }

    /// The first node instancing `mesh`.
    pub(super) fn instance(&self, mesh: &gltf::Mesh) -> Option<gltf::Node<'_>> {
        self.document
            .nodes()
            .find(|n| n.mesh().map(|m| m.index()) == Some(mesh.index()))
    }

    /// How messages name `sampler` of `animation`, its key times and its output values (of
    /// `dimensions` each), as floats.
    fn sampler_keys(
        &self,
        animation: &gltf::Animation,
        sampler: &gltf::animation::Sampler,
        dimensions: Dimensions,
    ) -> Result<(String, Vec<f32>, Vec<f32>), LoadError> {
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
        let values =
            self.read_floats(&sampler.output(), &format!("{element} output"), dimensions)?;
        Ok((element, times, values))
    }

    /// The channels of `animation` on node `node`'s translation, rotation and scale, checked
    /// as [`WeightTrack::new`] checks a weight track: finite, strictly increasing times, and
    /// finite values, as many as the keys ask for.
    pub(super) fn node_tracks(
        &self,
        animation: &gltf::Animation,
        node: usize,
    ) -> Result<Vec<super::NodeTrack>, LoadError> {
        use gltf::animation::Property;
        let mut tracks = Vec::new();
        for channel in animation.channels() {
            if channel.target().node().index() != node {
                continue;
            }
            let (property, dimensions) = match channel.target().property() {
                Property::Translation => (super::NodeProperty::Translation, Dimensions::Vec3),
                Property::Rotation => (super::NodeProperty::Rotation, Dimensions::Vec4),
                Property::Scale => (super::NodeProperty::Scale, Dimensions::Vec3),
                Property::MorphTargetWeights => continue,
            };
            let sampler = channel.sampler();
            let (element, times, values) = self.sampler_keys(animation, &sampler, dimensions)?;
            let interpolation = interpolation(sampler.interpolation());
            let per_key = property.components()
                * if interpolation == crate::morph::Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
            let problem = if times.is_empty() {
                Some("has no keyframe".to_string())
            } else if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[0] >= w[1])
            {
                Some("has key times that are not finite and strictly increasing".to_string())
            } else if values.len() != times.len() * per_key {
                Some(format!(
                    "has {} output values for {} keys, expected {}",
                    values.len(),
                    times.len(),
                    times.len() * per_key
                ))
            } else if values.iter().any(|v| !v.is_finite()) {
                Some("has a value that is not finite".to_string())
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err(self.data_error(&element, problem));
            }
            tracks.push(super::NodeTrack {
                property,
                interpolation,
                times,
                values,
            });
        }
        Ok(tracks)
    }

    /// Per node, the node whose `children` hold it.
    pub(super) fn parents(&self) -> Vec<Option<usize>> {
        let mut parents = vec![None; self.document.nodes().len()];
        for node in self.document.nodes() {
            for child in node.children() {
                parents[child.index()] = Some(node.index());
            }
        }
        parents
    }

    /// World matrix of the first node instancing `mesh` (identity when none),
    /// applied to the positions (as points) and target deltas (as vectors).
    pub(super) fn transform(
        &self,
        mesh: &gltf::Mesh,
        out: &mut IndexedMesh,
        deltas: &mut [Vec<[f32; 3]>],
    ) -> Result<(), LoadError> {
        let Some(node) = self.instance(mesh) else {
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

    /// Applies the transform [`Document::transform`] applied to the positions to the
    /// normals and target normal deltas: the inverse transpose of the world matrix's linear
    /// part, then per vertex the factor that makes the base normal unit length again (applied
    /// to the vertex's deltas too, so `normalize(base + Σ w D)` turns exactly as the surface
    /// does). Without base normals the deltas are scaled by the matrix's mean scale instead.
    pub(super) fn transform_normals(
        &self,
        mesh: &gltf::Mesh,
        normals: Option<&mut Vec<[f32; 3]>>,
        deltas: &mut [Option<Vec<[f32; 3]>>],
    ) -> Result<(), LoadError> {
        let Some(node) = self.instance(mesh) else {
            return Ok(());
        };
        let linear = glam::Mat3::from_mat4(self.world_matrix(node.index()));
        let normal_matrix = linear.inverse().transpose();
        let apply =
            |v: [f32; 3], scale: f32| (normal_matrix * glam::Vec3::from(v) * scale).to_array();
        let vertices = deltas
            .iter()
            .flatten()
            .map(Vec::len)
            .chain(normals.as_ref().map(|n| n.len()))
            .max()
            .unwrap_or(0);
        let finite = |values: &[[f32; 3]]| values.iter().flatten().all(|c| c.is_finite());
        let scales: Vec<f32> = match normals {
            Some(normals) => normals
                .iter_mut()
                .map(|n| {
                    let length = (normal_matrix * glam::Vec3::from(*n)).length();
                    let scale = if length > 0.0 { 1.0 / length } else { 1.0 };
                    *n = apply(*n, scale);
                    scale
                })
                .collect(),
            None => vec![normal_matrix.determinant().abs().cbrt().recip(); vertices],
        };
        let mut all_finite = scales.iter().all(|s| s.is_finite());
        for target in deltas.iter_mut().flatten() {
            for (d, &scale) in target.iter_mut().zip(&scales) {
                *d = apply(*d, scale);
            }
            all_finite &= finite(target);
        }
        if !all_finite || !normal_matrix.is_finite() {
            return Err(self.data_error(
                &format!("node {} transform", display_name(node.name(), node.index())),
                "makes a normal non-finite (a singular matrix, or overflow)".to_string(),
            ));
        }
        Ok(())
    }

    pub(super) fn world_matrix(&self, node: usize) -> glam::Mat4 {
        let local = |i: usize| {
            self.document
                .nodes()
                .nth(i)
                .map_or(glam::Mat4::IDENTITY, |n| {
                    glam::Mat4::from_cols_array_2d(&n.transform().matrix())
                })
        };
        let parents = self.parents();
        let mut matrix = local(node);
        let mut current = node;
        // `precheck` refused cyclic hierarchies; the bound keeps this walk finite regardless.
        for _ in 0..self.document.nodes().len() {
            match parents[current] {
                Some(p) => {
                    matrix = local(p) * matrix;
                    current = p;
                }
                None => break,
            }
        }
        matrix
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
