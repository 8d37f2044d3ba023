//! Discrete LODs of a morph as one glTF 2.0 binary (GLB) file that any engine loads: the
//! original and each LOD as its own mesh and node (`<name>_LOD0`, `_LOD1`, ...), every one
//! keeping all morph targets, the vertex attributes and the material, and driven by the same
//! weight animation; the chain declared with `MSFT_lod` on the LOD0 node.
//!
//! All LODs are reference meshes of ONE collapse sequence simplified over sampled poses
//! ([`crate::build::Sequences::Shared`] with [`PoseError::Max`]), so each LOD's connectivity
//! serves every pose of the animation. Collapses make no new vertices: a LOD keeps a subset
//! of the source vertices, and every value written for a kept vertex (position, normal, UV,
//! colour, each target's POSITION and NORMAL delta) is the source's `f32`, copied bit for bit.
//!
//! `MSFT_lod` says that a client without the extension loads the highest LOD and ignores the
//! others, so only the LOD0 node is in the scene; the lower LODs are top-level nodes (named,
//! each with its mesh) that tools can still list and pick. Indices are reordered for the
//! vertex cache with meshoptimizer, and vertices numbered in the order the indices first use
//! them (vertex-fetch locality).
//!
//! The meshes are written in the morph's own coordinates. [`ExportOptions::source`] keeps
//! what the source file has around the mesh ([`crate::io::gltf::source_scene`]):
//! * its place in the scene: the ancestors of the node that instanced the mesh are written as
//!   they were (names, local transforms as matrix or TRS, bit for bit), the LOD0 node takes
//!   that node's place under them with its local transform (and its children, when they are
//!   joints), and every lower LOD node carries the same local transform. `MSFT_lod` puts a
//!   lower LOD where the LOD0 node is, under LOD0's parent, so a local transform is what it
//!   needs; a tool that places an out-of-scene LOD node at the root sees it without the
//!   ancestors' transforms, which the extension does not define. Composed world matrices are
//!   never written, so nothing written is a sheared matrix the source did not have. (A
//!   source loaded with `apply_transforms` has its placement baked into the vertices and
//!   needs no nodes.)
//! * its skin: the joints and skeleton with their ancestors (names, transforms, hierarchy),
//!   the inverse bind matrices bit for bit, and the skin bound to every LOD node;
//! * its animation's channels on those nodes' translations, rotations and scales
//!   ([`crate::io::gltf::SourceNode::tracks`]), in the one animation written beside the
//!   weight track: a node's channels drive that node, the mesh node's drive every LOD node,
//!   keys and values as the file has them;
//! * the vertex attributes a morph does not hold (TANGENT, JOINTS_n, WEIGHTS_n, further
//!   TEXCOORD and COLOR sets, application-specific `_NAME`s) and the targets' TANGENT deltas,
//!   each kept vertex's bytes as stored, the sets renumbered after the morph's own;
//! * its material whole (factors, every texture with its sampler and image, extensions),
//!   texture coordinates sets renumbered as the attributes are.
//!
//! Other meshes of the file, other children of the mesh node, cameras and lights are not
//! written; [`crate::io::gltf::SourceScene::left_out`] lists what of the mesh is not.

use crate::build::{BuildError, Builder, Sequences, MAX_FRAMES};
use crate::collapse::CollapseSequence;
use crate::io::gltf::write::{
    bounds, f32_bytes, glb, index_accessor, number, quote, vec3_accessor, Bin, Json, ARRAY_BUFFER,
    FLOAT, UNSIGNED_INT,
};
use crate::io::gltf::{
    texture_infos, NodeTrack, NodeTransform, RawAttribute, SourceMaterial, SourceScene,
};
use crate::morph::{ImageFormat, Interpolation, Morph, WeightTrack, Weights};
use crate::seams::StepBoundaries;
use crate::simplify::{PoseError, SimplifyOptions, DISTANCE_WEIGHT};
use std::fmt::Write as _;
use thiserror::Error;

/// Poses the shared sequence is simplified over when the caller gives no count.
pub const DEFAULT_POSES: usize = 32;

/// How the LODs below the original are chosen. Either way each LOD is a step boundary of the
/// shared sequence (no seam torn open).
#[derive(Clone, Debug, PartialEq)]
pub enum LodSteps {
    /// Triangle fractions, each in (0, 1], strictly decreasing (`[0.5, 0.25, 0.1]`): per
    /// fraction `f`, the finest LOD with at most `floor(f · triangles)` triangles.
    Fractions(Vec<f32>),
    /// Error bounds relative to the diagonal of the base pose's bounding box, each finite
    /// and > 0, strictly increasing (`[0.002, 0.01]`: 0.2 % and 1 % of the diagonal): per
    /// bound `e`, the coarsest LOD whose error is at most `e · diagonal`. A LOD's error is
    /// the shared sequence's own: the square root of the largest collapse error so far, each
    /// collapse's error being its worst over the sampled poses ([`PoseError::Max`]), each
    /// pose's error scaled to the base pose's size (so the bound is relative to each pose's
    /// own size) — an RMS distance to the planes of the original surface around the
    /// collapsed vertices, not a measured Hausdorff distance. For a mesh with UVs or given normals the collapse
    /// error also holds the attribute term ([`crate::simplify::SimplifyOptions::uv_weight`],
    /// `normal_weight`), so a bound limits how far the texture and shading drift too. With the
    /// distance term ([`crate::simplify::SimplifyOptions::distance_weight`] `w`, on by default
    /// here) the error is at least `w ×` the squared distance between the LOD and the
    /// full surface that the term tracks, so a bound `e` also keeps every removed vertex
    /// within `e · diagonal / √w` of the LOD in the base pose.
    Errors(Vec<f32>),
}

/// What to export.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportOptions {
    /// The LODs below the original (default: fractions `[0.5, 0.25, 0.1]`).
    pub lods: LodSteps,
    /// Poses sampled over `t ∈ [0, 1]` for the shared sequence (1 to the builder's maximum).
    pub poses: usize,
    /// The simplifier's options for the shared sequence (default: [`SimplifyOptions`]'s, with
    /// the attribute error on for meshes with UVs or given normals, and the distance term on
    /// at [`DISTANCE_WEIGHT`]: an export is made once, offline, and the term lowers the LODs'
    /// Hausdorff error by a quarter to a half for a build many times longer; BENCHMARKS.md).
    pub simplify: SimplifyOptions,
    /// The meshes' default weights (`mesh.weights`), one per target; `None`: the weights at
    /// `t = 0`.
    pub default_weights: Option<Vec<f32>>,
    /// Mesh and node names are `<name>_LOD<i>`.
    pub name: String,
    /// What the source file has besides the morph ([`crate::io::gltf::source_scene`]): its
    /// nodes are written as they are (names, local transforms, parents), the LOD nodes take
    /// the mesh node's place and local transform (LOD0 also its children), each node's
    /// [`crate::io::gltf::SourceNode::tracks`] join the animation, the skin binds every LOD,
    /// and the raw attributes are written for each kept vertex bit for bit. Empty (the
    /// default): the LOD0 node is a scene root with no transform.
    pub source: SourceScene,
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            lods: LodSteps::Fractions(vec![0.5, 0.25, 0.1]),
            poses: DEFAULT_POSES,
            simplify: SimplifyOptions {
                distance_weight: DISTANCE_WEIGHT,
                ..SimplifyOptions::default()
            },
            default_weights: None,
            name: "mesh".into(),
            source: SourceScene::default(),
        }
    }
}

/// Why an export failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ExportError {
    #[error("--lods {lods:?}: give triangle fractions in (0, 1], strictly decreasing (e.g. 0.5,0.25,0.1)")]
    Fractions { lods: Vec<f32> },
    #[error("--error {errors:?}: give error bounds relative to the bounding-box diagonal, finite, > 0 and strictly increasing (e.g. 0.002,0.01)")]
    Errors { errors: Vec<f32> },
    #[error("--poses {poses}: sample 1 to {max} poses (1 simplifies the rest pose only)", max = MAX_FRAMES)]
    Poses { poses: usize },
    #[error("{given} default weights for {targets} morph targets: give one per target")]
    DefaultWeights { given: usize, targets: usize },
    #[error("LOD fraction {fraction} leaves no triangle of {triangles}: choose a larger fraction")]
    Empty { fraction: f32, triangles: usize },
    #[error("error bound {error} leaves no triangle of {triangles}: choose a smaller bound")]
    EmptyError { error: f32, triangles: usize },
    #[error("the source scene does not fit the morph: {0}")]
    Source(String),
    #[error("simplifying over the poses: {0}")]
    Build(#[from] BuildError),
}

/// One exported level: which source vertices it keeps and its triangles over them.
#[derive(Clone, Debug, PartialEq)]
pub struct Lod {
    /// The fraction asked for with [`LodSteps::Fractions`]; with [`LodSteps::Errors`] the
    /// fraction of the original's triangles the LOD keeps (1 for LOD0).
    pub fraction: f32,
    /// The shared sequence's error at this LOD ([`LodSteps::Errors`]), relative to the
    /// base pose's bounding-box diagonal (0 for LOD0).
    pub error: f32,
    /// Collapses of the shared sequence applied (0 for LOD0).
    pub step: usize,
    /// `source_vertex[i]`: the source vertex written as the LOD's vertex `i`.
    pub source_vertex: Vec<u32>,
    /// Triangles over the LOD's vertices, in vertex-cache order.
    pub triangles: Vec<[u32; 3]>,
}

/// An exported file and what it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Export {
    /// The GLB file's bytes.
    pub glb: Vec<u8>,
    /// LOD0 (the original) first, then one per fraction or error bound.
    pub lods: Vec<Lod>,
}

/// Exports `morph` and its LODs (module docs). The animation written is the morph's weight
/// track ([`Weights::Animated`]); a two-pose morph gets a LINEAR 0 → 1 → 0 animation over
/// two seconds (the weights of `t = 0`, `t = 1`, `t = 0`), so a viewer plays it.
pub fn export_glb(morph: &Morph, options: &ExportOptions) -> Result<Export, ExportError> {
    match &options.lods {
        LodSteps::Fractions(f) => check_fractions(f)?,
        LodSteps::Errors(e) => check_errors(e)?,
    }
    if options.poses == 0 || options.poses > MAX_FRAMES {
        return Err(ExportError::Poses {
            poses: options.poses,
        });
    }
    let targets = morph.targets().len();
    let default_weights = match &options.default_weights {
        Some(w) if w.len() != targets => {
            return Err(ExportError::DefaultWeights {
                given: w.len(),
                targets,
            })
        }
        Some(w) => w.clone(),
        None => morph.weights_at(0.0),
    };
    check_source(morph, &options.source)?;
    let (asset, _) = Builder::new(morph)
        .frames(options.poses)
        .sequences(Sequences::Shared(PoseError::Max))
        .simplify_options(options.simplify.clone())
        .build()?;
    let sequence = &asset.frames[0];
    let boundaries = StepBoundaries::new(sequence, &morph.topology().of_vertex);
    let triangles = morph.triangles();

    let diagonal = diagonal(morph.base());
    let errors = sequence.errors();
    let relative = |step: usize| errors[step].max(0.0).sqrt() / diagonal;
    let mut lods = vec![compact(triangles.to_vec(), 1.0, 0, 0.0)];
    match &options.lods {
        LodSteps::Fractions(fractions) => {
            for &fraction in fractions {
                let step = step_for(sequence, &boundaries, triangles, fraction)?;
                let mesh = sequence.reference_mesh(triangles, step);
                lods.push(compact(mesh, fraction, step, relative(step)));
            }
        }
        LodSteps::Errors(bounds) => {
            for &bound in bounds {
                let step = step_for_error(&errors, &boundaries, bound * diagonal);
                let mesh = sequence.reference_mesh(triangles, step);
                if mesh.is_empty() {
                    return Err(ExportError::EmptyError {
                        error: bound,
                        triangles: triangles.len(),
                    });
                }
                let fraction = mesh.len() as f32 / triangles.len() as f32;
                lods.push(compact(mesh, fraction, step, relative(step)));
            }
        }
    }
    let glb = write_glb(morph, &lods, &default_weights, options);
    Ok(Export { glb, lods })
}

fn check_fractions(lods: &[f32]) -> Result<(), ExportError> {
    let in_range = lods.iter().all(|&f| f > 0.0 && f <= 1.0);
    let decreasing = lods.windows(2).all(|w| w[0] > w[1]);
    if lods.is_empty() || !in_range || !decreasing {
        return Err(ExportError::Fractions {
            lods: lods.to_vec(),
        });
    }
    Ok(())
}

fn check_errors(errors: &[f32]) -> Result<(), ExportError> {
    let in_range = errors.iter().all(|&e| e.is_finite() && e > 0.0);
    let increasing = errors.windows(2).all(|w| w[0] < w[1]);
    if errors.is_empty() || !in_range || !increasing {
        return Err(ExportError::Errors {
            errors: errors.to_vec(),
        });
    }
    Ok(())
}

/// Refuses a source scene that does not describe `morph`: raw attributes of another vertex
/// or target count, nodes whose parents do not come first, a skin without a mesh node or
/// without JOINTS_0 and WEIGHTS_0 to bind it (and skinning attributes without a skin),
/// indices out of range.
fn check_source(morph: &Morph, source: &SourceScene) -> Result<(), ExportError> {
    let fail = |message: String| Err(ExportError::Source(message));
    let vertices = morph.vertex_count();
    let targets = &source.target_attributes;
    if !targets.is_empty() && targets.len() != morph.targets().len() {
        return fail(format!(
            "target attributes for {} targets, the morph has {}",
            targets.len(),
            morph.targets().len()
        ));
    }
    for a in source.attributes.iter().chain(targets.iter().flatten()) {
        let known = matches!(a.kind, "SCALAR" | "VEC2" | "VEC3" | "VEC4")
            && matches!(a.component_type, 5120..=5123 | 5125 | 5126);
        if !known || a.data.len() != vertices * a.element_size() {
            return fail(format!(
                "attribute {} ({} of component type {}, {} bytes) for {vertices} vertices",
                a.semantic,
                a.kind,
                a.component_type,
                a.data.len()
            ));
        }
    }
    if let Some(a) = targets
        .iter()
        .flatten()
        .find(|a| !source.attributes.iter().any(|b| b.semantic == a.semantic))
    {
        return fail(format!(
            "target deltas of {}, which the base lacks",
            a.semantic
        ));
    }
    let n = source.nodes.len();
    if let Some(i) = source
        .nodes
        .iter()
        .enumerate()
        .position(|(i, node)| node.parent.is_some_and(|p| p >= i))
    {
        return fail(format!("node {i}'s parent does not come before it"));
    }
    if source.mesh_node.is_some_and(|m| m >= n) || (source.mesh_node.is_none() && n > 0) {
        return fail(format!("mesh node {:?} of {n} nodes", source.mesh_node));
    }
    let skinning = |prefix: &str| {
        source
            .attributes
            .iter()
            .any(|a| a.semantic.starts_with(prefix))
    };
    match &source.skin {
        Some(skin) => {
            let in_range = skin.joints.iter().chain(&skin.skeleton).all(|&j| j < n);
            if !in_range || skin.joints.is_empty() || source.mesh_node.is_none() {
                return fail(format!(
                    "skin with joints {:?} and skeleton {:?} over {n} nodes, mesh node {:?}",
                    skin.joints, skin.skeleton, source.mesh_node
                ));
            }
            let binds = ["JOINTS_0", "WEIGHTS_0"]
                .iter()
                .all(|s| source.attributes.iter().any(|a| a.semantic == *s));
            if !binds {
                return fail("a skin, but no JOINTS_0 and WEIGHTS_0 to bind the vertices".into());
            }
        }
        None if skinning("JOINTS_") || skinning("WEIGHTS_") => {
            return fail("JOINTS_n or WEIGHTS_n without a skin".into())
        }
        None => {}
    }
    Ok(())
}

/// The length of the diagonal of `positions`' bounding box; 1 when that is 0 (one point, or
/// none), so relative and absolute errors agree on a degenerate mesh.
fn diagonal(positions: &[[f32; 3]]) -> f32 {
    let (lo, hi) = bounds(positions);
    let d = (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f32>().sqrt();
    if d > 0.0 && d.is_finite() {
        d
    } else {
        1.0
    }
}

/// The last step boundary at which the sequence's error (`errors[l]`, squared) is at most
/// `bound` (a distance): errors never decrease with the step, so that is the floor of the
/// last step within the bound.
fn step_for_error(errors: &[f32], boundaries: &StepBoundaries, bound: f32) -> usize {
    let within = errors.partition_point(|&e| e.max(0.0).sqrt() <= bound);
    // errors[0] = 0 is always within, so `within` ≥ 1.
    boundaries.floor(within - 1)
}

/// The first step boundary whose reference mesh has at most `fraction` of the triangles:
/// the fewest collapses that reach the count (binary search, the count never grows with the
/// step), moved up to a boundary so no seam is torn.
fn step_for(
    sequence: &CollapseSequence,
    boundaries: &StepBoundaries,
    triangles: &[[u32; 3]],
    fraction: f32,
) -> Result<usize, ExportError> {
    let goal = (fraction as f64 * triangles.len() as f64).floor() as usize;
    let count = |l: usize| sequence.reference_mesh(triangles, l).len();
    let (mut lo, mut hi) = (0, sequence.len());
    while lo < hi {
        let mid = (lo + hi) / 2;
        if count(mid) <= goal {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    let step = boundaries.ceil(lo);
    if count(step) == 0 {
        return Err(ExportError::Empty {
            fraction,
            triangles: triangles.len(),
        });
    }
    Ok(step)
}

/// The LOD of `mesh` (over source vertices): indices in vertex-cache order, then only the
/// vertices used, numbered by first use.
fn compact(mesh: Vec<[u32; 3]>, fraction: f32, step: usize, error: f32) -> Lod {
    let flat: Vec<u32> = mesh.into_iter().flatten().collect();
    let vertex_bound = flat.iter().max().map_or(0, |&v| v as usize + 1);
    let ordered = meshopt::optimize_vertex_cache(&flat, vertex_bound);
    let mut new_of = vec![u32::MAX; vertex_bound];
    let mut source_vertex = Vec::new();
    let reindexed: Vec<u32> = ordered
        .iter()
        .map(|&v| {
            let slot = &mut new_of[v as usize];
            if *slot == u32::MAX {
                *slot = source_vertex.len() as u32;
                source_vertex.push(v);
            }
            *slot
        })
        .collect();
    Lod {
        fraction,
        error,
        step,
        source_vertex,
        triangles: reindexed
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
    }
}

/// The weight animation to write: the morph's own track, or 0 → 1 → 0 for two poses.
fn animation(morph: &Morph) -> Option<WeightTrack> {
    match morph.weights() {
        Weights::Animated(track) => Some(track.clone()),
        Weights::TwoPose { w0, w1 } => {
            let values = [w0.as_slice(), w1, w0].concat();
            WeightTrack::new(Interpolation::Linear, vec![0.0, 1.0, 2.0], values, w0.len()).ok()
        }
    }
}

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

fn flat_accessor(
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
fn written_names(morph: &Morph, attributes: &[RawAttribute]) -> Vec<String> {
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
fn mesh_json(
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

/// The morph's own material (and its texture, image and sampler) as top-level JSON members,
/// for a source without a glTF material (OBJ, OFF, PLY, a supermesh): base colour and
/// texture, written as a dielectric (`metallicFactor` 0), which is what those formats' diffuse
/// colour means; glTF's default of 1 would draw it as bare metal.
fn material_json(morph: &Morph, bin: &mut Bin, json: &mut Json) -> String {
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
    let image = image_json(&texture.bytes, texture.format, bin, json);
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
fn image_json(bytes: &[u8], format: ImageFormat, bin: &mut Bin, json: &mut Json) -> String {
    let view = json.view(bin.push(bytes.to_vec()), None);
    format!(
        r#"{{"bufferView":{view},"mimeType":"{}"}}"#,
        format.mime_type()
    )
}

/// The source's material written again ([`SourceMaterial`]): its object with every texture
/// info's `texCoord` renumbered to the TEXCOORD set as written (`raw_names`), its textures,
/// samplers and images (embedded in the BIN chunk, whatever the file had); top-level JSON
/// members like [`material_json`]'s.
fn source_material_json(
    morph: &Morph,
    source: &SourceScene,
    material: &SourceMaterial,
    raw_names: &[String],
    bin: &mut Bin,
    json: &mut Json,
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
        .map(|image| image_json(&image.bytes, image.format, bin, json))
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

/// The animation JSON member (empty when there is nothing to play): the weight track's
/// sampler with one `weights` channel per LOD node, and one sampler per node track with a
/// channel on each of the nodes it drives.
fn animation_json(
    weights: Option<&WeightTrack>,
    node_tracks: &[(Vec<usize>, &NodeTrack)],
    lods: usize,
    bin: &mut Bin,
    json: &mut Json,
) -> String {
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    let input = |bin: &mut Bin, json: &mut Json, times: &[f32]| {
        let view = json.view(bin.push(f32_bytes(times.iter())), None);
        let (t0, t1) = (times[0], times[times.len() - 1]);
        json.accessor(
            view,
            FLOAT,
            times.len(),
            "SCALAR",
            Some((vec![t0], vec![t1])),
        )
    };
    if let Some(track) = weights {
        let input = input(bin, json, track.times());
        let output = flat_accessor(bin, json, track.values(), 1, "SCALAR", None);
        samplers.push(format!(
            r#"{{"input":{input},"output":{output},"interpolation":"{}"}}"#,
            track.interpolation().name()
        ));
        channels.extend(
            (0..lods).map(|node| {
                format!(r#"{{"sampler":0,"target":{{"node":{node},"path":"weights"}}}}"#)
            }),
        );
    }
    for (nodes, track) in node_tracks {
        let input = input(bin, json, &track.times);
        let width = track.property.components();
        let kind = if width == 4 { "VEC4" } else { "VEC3" };
        let output = flat_accessor(bin, json, &track.values, width, kind, None);
        let sampler = samplers.len();
        samplers.push(format!(
            r#"{{"input":{input},"output":{output},"interpolation":"{}"}}"#,
            track.interpolation.name()
        ));
        channels.extend(nodes.iter().map(|node| {
            format!(
                r#"{{"sampler":{sampler},"target":{{"node":{node},"path":"{}"}}}}"#,
                track.property.name()
            )
        }));
    }
    if samplers.is_empty() {
        return String::new();
    }
    format!(
        r#","animations":[{{"name":"weights","samplers":[{}],"channels":[{}]}}]"#,
        samplers.join(","),
        channels.join(",")
    )
}

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

fn write_glb(
    morph: &Morph,
    lods: &[Lod],
    default_weights: &[f32],
    options: &ExportOptions,
) -> Vec<u8> {
    let name = &options.name;
    let mut bin = Bin::default();
    let mut json = Json::default();
    let names: Vec<String> = (0..lods.len()).map(|i| format!("{name}_LOD{i}")).collect();
    let source = &options.source;
    let raw_names = written_names(morph, &source.attributes);
    let meshes: Vec<String> = lods
        .iter()
        .zip(&names)
        .map(|(lod, n)| {
            mesh_json(
                morph,
                lod,
                n,
                default_weights,
                source,
                &raw_names,
                &mut bin,
                &mut json,
            )
        })
        .collect();
    let material = match &source.material {
        Some(material) => {
            source_material_json(morph, source, material, &raw_names, &mut bin, &mut json)
        }
        None => material_json(morph, &mut bin, &mut json),
    };
    let mut used = vec!["MSFT_lod".to_string()];
    let mut required = Vec::new();
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
    let node_tracks: Vec<(Vec<usize>, &NodeTrack)> = source
        .nodes
        .iter()
        .enumerate()
        .flat_map(|(i, node)| {
            let driven: Vec<usize> = if Some(i) == mesh_node {
                (0..lods.len()).collect()
            } else {
                vec![written[i]]
            };
            node.tracks.iter().map(move |t| (driven.clone(), t))
        })
        .collect();
    let weights = if morph.targets().is_empty() {
        None
    } else {
        animation(morph)
    };
    let animation = animation_json(
        weights.as_ref(),
        &node_tracks,
        lods.len(),
        &mut bin,
        &mut json,
    );
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
            if let Some(matrices) = &skin.inverse_bind_matrices {
                let data: Vec<f32> = matrices.iter().flatten().copied().collect();
                let acc = flat_accessor(&mut bin, &mut json, &data, 16, "MAT4", None);
                fields.push(format!(r#""inverseBindMatrices":{acc}"#));
            }
            format!(r#","skins":[{{{}}}]"#, fields.join(","))
        }
        None => String::new(),
    };
    let own = mesh_node.map_or(String::new(), |m| {
        transform_json(&source.nodes[m].transform)
    });
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
        r#"{{"asset":{{"version":"2.0","generator":"morphlod export"}},{extensions},"scene":0,"scenes":[{{"nodes":[{roots}]}}],"nodes":[{nodes}],"meshes":[{meshes}]{skin},{material}{animation},"buffers":[{{"byteLength":{len}}}],"bufferViews":[{views}],"accessors":[{accessors}]}}"#,
        roots = roots.join(","),
        nodes = nodes.join(","),
        meshes = meshes.join(","),
        len = bin.bytes.len(),
        views = json.views.join(","),
        accessors = json.accessors.join(","),
    );
    glb(text.into_bytes(), bin.bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::morph::MorphTarget;

    /// Two triangles per cell of an `n × n` vertex grid, row by row.
    fn grid_triangles(n: u32) -> Vec<[u32; 3]> {
        let mut triangles = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let v = y * n + x;
                triangles.push([v, v + 1, v + n]);
                triangles.push([v + 1, v + n + 1, v + n]);
            }
        }
        triangles
    }

    /// A 5 × 5 grid with a target that moves two vertices (one by `-0.0` only) and one that
    /// moves nothing: both are written sparse and read back bit for bit at every LOD.
    #[test]
    fn sparse_deltas_read_back_bit_for_bit() {
        let n = 5u32;
        let base: Vec<[f32; 3]> = (0..n * n)
            .map(|v| [(v % n) as f32, (v / n) as f32, ((v * 7) % 3) as f32 * 0.1])
            .collect();
        let triangles = grid_triangles(n);
        let mut moving = vec![[0.0f32; 3]; base.len()];
        moving[3] = [-0.0, 0.0, 0.0];
        moving[12] = [0.0, 0.0, 1.5];
        let targets = vec![
            MorphTarget {
                name: "moving".into(),
                deltas: moving,
                normal_deltas: None,
            },
            MorphTarget {
                name: "still".into(),
                deltas: vec![[0.0; 3]; base.len()],
                normal_deltas: None,
            },
        ];
        let weights = Weights::TwoPose {
            w0: vec![0.0, 0.0],
            w1: vec![1.0, 0.0],
        };
        let morph = Morph::from_parts(triangles, base, targets, weights).unwrap();
        let export = export_glb(
            &morph,
            &ExportOptions {
                lods: LodSteps::Fractions(vec![0.5]),
                ..ExportOptions::default()
            },
        )
        .unwrap();
        let gltf = gltf::Gltf::from_slice(&export.glb).unwrap();
        let blob = gltf.blob.clone().unwrap();
        for (mesh, lod) in gltf.meshes().zip(&export.lods) {
            let primitive = mesh.primitives().next().unwrap();
            for accessor in primitive.morph_targets().filter_map(|t| t.positions()) {
                assert!(accessor.sparse().is_some() && accessor.view().is_none());
            }
            let reader = primitive.reader(|_| Some(&blob[..]));
            for (read, source) in reader.read_morph_targets().zip(morph.targets()) {
                let read: Vec<[u32; 3]> = read.0.unwrap().map(|d| d.map(f32::to_bits)).collect();
                let expected: Vec<[u32; 3]> = lod
                    .source_vertex
                    .iter()
                    .map(|&v| source.deltas[v as usize].map(f32::to_bits))
                    .collect();
                assert_eq!(read, expected, "{}", source.name);
            }
        }
    }

    /// A bumpy `n × n` grid whose one target raises a ridge: collapse errors spread over
    /// several orders of magnitude.
    fn bumpy_grid(n: u32) -> Morph {
        let height = |x: u32, y: u32| ((x as f32 * 0.9).sin() * (y as f32 * 0.6).cos()) * 0.3;
        let base: Vec<[f32; 3]> = (0..n * n)
            .map(|v| [(v % n) as f32, (v / n) as f32, height(v % n, v / n)])
            .collect();
        let triangles = grid_triangles(n);
        let ridge = (0..n * n)
            .map(|v| [0.0, 0.0, if v % n == n / 2 { 1.0 } else { 0.0 }])
            .collect();
        let targets = vec![MorphTarget {
            name: "ridge".into(),
            deltas: ridge,
            normal_deltas: None,
        }];
        let weights = Weights::TwoPose {
            w0: vec![0.0],
            w1: vec![1.0],
        };
        Morph::from_parts(triangles, base, targets, weights).unwrap()
    }

    /// Each error step is the coarsest step boundary of the shared sequence within its bound:
    /// its error (relative to the diagonal) is at most the bound, the next boundary's is
    /// above it, and the LODs get coarser as the bounds grow.
    #[test]
    fn error_steps_are_the_coarsest_boundaries_within_each_bound() {
        let morph = bumpy_grid(16);
        let bounds = vec![0.002, 0.01, 0.03, 0.1];
        let options = ExportOptions {
            lods: LodSteps::Errors(bounds.clone()),
            ..ExportOptions::default()
        };
        let export = export_glb(&morph, &options).unwrap();
        let (asset, _) = Builder::new(&morph)
            .frames(DEFAULT_POSES)
            .sequences(Sequences::Shared(PoseError::Max))
            .simplify_options(options.simplify.clone())
            .build()
            .unwrap();
        let sequence = &asset.frames[0];
        let errors = sequence.errors();
        let boundaries = StepBoundaries::new(sequence, &morph.topology().of_vertex);
        // sqrt(2 · 15²) plus the bumps' height: the grid's diagonal.
        let diagonal = diagonal(morph.base());
        assert!((diagonal - 15.0 * 2f32.sqrt()).abs() < 0.1, "{diagonal}");
        assert_eq!(export.lods.len(), bounds.len() + 1);
        let mut steps = vec![0];
        for (lod, &bound) in export.lods[1..].iter().zip(&bounds) {
            assert!(boundaries.is_boundary(lod.step), "{lod:?}");
            let error = errors[lod.step].sqrt() / diagonal;
            assert_eq!(lod.error, error);
            assert!(error <= bound, "{bound}: {lod:?}");
            if lod.step < sequence.len() {
                let next = boundaries.ceil(lod.step + 1);
                assert!(
                    errors[next].sqrt() / diagonal > bound,
                    "{bound}: step {next}"
                );
            }
            steps.push(lod.step);
        }
        assert!(steps.windows(2).all(|w| w[0] <= w[1]), "{steps:?}");
        // The bounds span the sequence: the LODs are not all the same.
        assert!(steps[1] > 0 && steps[bounds.len()] > steps[1], "{steps:?}");
        let counts: Vec<usize> = export.lods.iter().map(|l| l.triangles.len()).collect();
        assert!(counts.windows(2).all(|w| w[0] >= w[1]), "{counts:?}");
    }

    #[test]
    fn error_bounds_must_be_positive_finite_and_increase() {
        for bad in [
            vec![],
            vec![0.0],
            vec![-0.01],
            vec![f32::NAN],
            vec![f32::INFINITY],
            vec![0.01, 0.01],
            vec![0.02, 0.01],
        ] {
            let options = ExportOptions {
                lods: LodSteps::Errors(bad.clone()),
                ..ExportOptions::default()
            };
            let err = export_glb(&bumpy_grid(4), &options).unwrap_err();
            assert!(matches!(err, ExportError::Errors { .. }), "{bad:?}");
            assert!(err.to_string().contains("--error"), "{err}");
        }
        assert!(check_errors(&[0.001, 0.5, 2.0]).is_ok());
    }

    /// A raw attribute of `semantic`: one FLOAT SCALAR per vertex.
    fn raw(semantic: &str, vertices: usize) -> RawAttribute {
        RawAttribute {
            semantic: semantic.into(),
            kind: "SCALAR",
            component_type: FLOAT,
            normalized: false,
            data: vec![0; 4 * vertices],
        }
    }

    /// Carried TEXCOORD and COLOR sets are numbered on after the morph's own, in order and
    /// without gaps; JOINTS and WEIGHTS from 0; other names are kept.
    #[test]
    fn carried_sets_are_numbered_after_the_morphs_own() {
        let plain = bumpy_grid(3);
        let vertices = plain.vertex_count();
        let with_uvs = plain
            .clone()
            .with_attributes(crate::morph::Attributes {
                uvs: Some(vec![[0.0; 2]; vertices]),
                ..Default::default()
            })
            .unwrap();
        let carried: Vec<RawAttribute> = [
            "TEXCOORD_3",
            "TANGENT",
            "TEXCOORD_1",
            "COLOR_2",
            "JOINTS_1",
            "WEIGHTS_1",
            "_ID",
        ]
        .iter()
        .map(|s| raw(s, vertices))
        .collect();
        assert_eq!(
            written_names(&with_uvs, &carried),
            [
                "TEXCOORD_2",
                "TANGENT",
                "TEXCOORD_1",
                "COLOR_0",
                "JOINTS_0",
                "WEIGHTS_0",
                "_ID"
            ]
        );
        assert_eq!(
            written_names(&plain, &carried),
            [
                "TEXCOORD_1",
                "TANGENT",
                "TEXCOORD_0",
                "COLOR_0",
                "JOINTS_0",
                "WEIGHTS_0",
                "_ID"
            ]
        );
    }

    /// A source scene that does not describe the morph is refused before anything is built.
    #[test]
    fn a_source_scene_that_does_not_fit_is_refused() {
        use crate::io::gltf::{SourceNode, SourceSkin};
        let morph = bumpy_grid(4);
        let vertices = morph.vertex_count();
        let node = |parent| SourceNode {
            name: None,
            transform: NodeTransform::IDENTITY,
            tracks: Vec::new(),
            parent,
        };
        let skin = SourceSkin {
            name: None,
            joints: vec![1],
            skeleton: None,
            inverse_bind_matrices: None,
        };
        let skinned = SourceScene {
            nodes: vec![node(None), node(None)],
            mesh_node: Some(0),
            skin: Some(skin.clone()),
            attributes: vec![raw("JOINTS_0", vertices), raw("WEIGHTS_0", vertices)],
            ..SourceScene::default()
        };
        let export = |source: SourceScene| {
            export_glb(
                &morph,
                &ExportOptions {
                    source,
                    ..ExportOptions::default()
                },
            )
        };
        assert!(export(skinned.clone()).is_ok());
        let bad = [
            SourceScene {
                attributes: vec![raw("_ID", vertices - 1)],
                ..SourceScene::default()
            },
            SourceScene {
                target_attributes: vec![vec![], vec![]],
                ..SourceScene::default()
            },
            SourceScene {
                attributes: vec![raw("_ID", vertices)],
                target_attributes: vec![vec![raw("TANGENT", vertices)]],
                ..SourceScene::default()
            },
            SourceScene {
                nodes: vec![node(Some(1)), node(None)],
                ..skinned.clone()
            },
            SourceScene {
                mesh_node: Some(2),
                ..skinned.clone()
            },
            SourceScene {
                skin: Some(SourceSkin {
                    joints: vec![2],
                    ..skin.clone()
                }),
                ..skinned.clone()
            },
            SourceScene {
                attributes: vec![raw("JOINTS_0", vertices)],
                ..skinned.clone()
            },
            SourceScene {
                skin: None,
                ..skinned.clone()
            },
        ];
        for source in bad {
            let err = export(source.clone()).unwrap_err();
            assert!(matches!(err, ExportError::Source(_)), "{source:?}: {err}");
        }
    }

    #[test]
    fn fractions_must_lie_in_0_1_and_decrease() {
        for bad in [
            vec![],
            vec![0.0],
            vec![1.5],
            vec![0.5, 0.5],
            vec![0.2, 0.4],
            vec![f32::NAN],
        ] {
            assert!(check_fractions(&bad).is_err(), "{bad:?}");
        }
        assert!(check_fractions(&[1.0, 0.5, 0.01]).is_ok());
    }
}
