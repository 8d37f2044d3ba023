//! Discrete LODs of a morph as one glTF 2.0 binary (GLB) file that any engine loads: the
//! original and each LOD as its own mesh and node (`<name>_LOD0`, `_LOD1`, ...), every one
//! keeping all morph targets, the vertex attributes and the material, and driven by the same
//! animations; the chain declared with `MSFT_lod` on the LOD0 node.
//!
//! All LODs are reference meshes of ONE collapse sequence simplified over sampled poses
//! ([`crate::build::Sequences::Shared`] with [`PoseError::Max`]), so each LOD's connectivity
//! serves every pose of the animation; for a skinned morph the poses are skinned
//! ([`Morph::positions_at`]), so the LODs are chosen over the clip's poses, not the bind pose. Collapses make no new vertices: a LOD keeps a subset
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
//! * every animation of the file ([`crate::io::gltf::SourceScene::animations`]), each
//!   written under its name with its weight channel driving every LOD node and its channels on
//!   those nodes' translations, rotations and scales: a node's channels drive that node, the
//!   mesh node's drive every LOD node, keys and values as the file has them (a source without
//!   a weight animation of its own gets the morph's, named `weights`);
//! * the vertex attributes a morph does not hold (TANGENT, JOINTS_n, WEIGHTS_n, further
//!   TEXCOORD and COLOR sets, application-specific `_NAME`s) and the targets' TANGENT deltas,
//!   each kept vertex's bytes as stored, the sets renumbered after the morph's own;
//! * its material whole (factors, every texture with its sampler and image, extensions),
//!   texture coordinates sets renumbered as the attributes are.
//!
//! Other meshes of the file, other children of the mesh node, cameras and lights are not
//! written; [`crate::io::gltf::SourceScene::left_out`] lists what of the mesh is not.
//!
//! # Quantized and compressed files
//!
//! With [`ExportOptions::quantize`] the meshes are written as `KHR_mesh_quantization` allows
//! (`quantize.rs`): positions as `UNSIGNED_SHORT`s on one uniform [`Grid`] for the whole morph
//! (every LOD, every target), whose dequantising translation and uniform scale go on the LOD
//! nodes (composed with the source's local transform; for a skinned mesh into the inverse bind
//! matrices, glTF ignoring a skinned node's transform); every target's POSITION deltas as the
//! `SHORT` difference of grid points `q(base + delta) − q(base)`, so a target's pose at weight
//! 1 is a grid point and `base + Σ w·delta` is the same weighted sum of grid points for every
//! reader; normals and normal deltas as normalized `BYTE`s or `SHORT`s; UVs in `[0, 1]` as
//! normalized `UNSIGNED_SHORT`s; indices as `UNSIGNED_SHORT`s where they fit. Colours, the
//! source's raw attributes, the animation and the skin stay as they are. A mesh node whose own
//! transform is animated (and not skinned) is refused: its channels would overwrite the
//! dequantising transform. [`Lod::quantization_error`] is measured over the LOD's vertices and
//! these poses: `poses` weight sets evenly over the animation, the default weights, and each
//! target alone at weight 1. Quantization runs after the LODs are chosen, so it changes none.
//!
//! With [`ExportOptions::compress`] (`compress.rs`) every buffer view but the images is
//! compressed with `EXT_meshopt_compression` (ATTRIBUTES for vertex, delta, animation and skin
//! data, the OCTAHEDRAL filter for normals, TRIANGLES for indices), the views pointing into a
//! data-less fallback buffer, and each LOD's target deltas of one attribute are one view (one
//! stream and one view's JSON instead of one per target). Both extensions are listed in
//! `extensionsRequired`: a client without them cannot read the meshes. The reader
//! ([`crate::io::gltf`]) decodes such files and reads quantized attributes as their integer
//! values (the node transform is not applied unless asked for).
//!
//! One file a stage, in the order [`export_glb`] runs them after checking its input here and
//! building the shared sequence: `levels` (the step each LOD stops at, and its mesh in
//! vertex-cache order), then for the file `mesh` (each LOD as a glTF mesh, quantized with
//! `quantize`), `material`, `animation` (the weight track and the source's node channels) and
//! `scene` (the nodes, skin and extensions around them, and the GLB container), all writing
//! their buffer views through `compress`.

mod animation;
mod compress;
mod levels;
mod material;
mod mesh;
mod quantize;
mod scene;
#[cfg(test)]
mod tests;

use crate::build::{BuildError, Builder, Sequences, MAX_FRAMES};
use crate::io::gltf::SourceScene;
use crate::morph::Morph;
use crate::seams::{step_for_error, StepBoundaries};
use crate::simplify::{PoseError, SimplifyOptions, DISTANCE_WEIGHT};
pub use compress::EXT_MESHOPT_COMPRESSION;
use levels::{compact, diagonal, step_for};
use mesh::Quantization;
pub use quantize::{Grid, QuantizeOptions};
use scene::write_glb;
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
    /// Hausdorff error by a quarter to a half for a build many times longer; BENCHMARKS.md,
    /// "Export and compression").
    pub simplify: SimplifyOptions,
    /// The meshes' default weights (`mesh.weights`), one per target; `None`: the weights at
    /// `t = 0`.
    pub default_weights: Option<Vec<f32>>,
    /// Mesh and node names are `<name>_LOD<i>`.
    pub name: String,
    /// What the source file has besides the morph ([`crate::io::gltf::source_scene`]): its
    /// nodes are written as they are (names, local transforms, parents), the LOD nodes take
    /// the mesh node's place and local transform (LOD0 also its children), every
    /// [`crate::io::gltf::SourceScene::animations`] is written, the skin binds every LOD,
    /// and the raw attributes are written for each kept vertex bit for bit. Empty (the
    /// default): the LOD0 node is a scene root with no transform.
    pub source: SourceScene,
    /// Write positions, normals, UVs and target deltas as `KHR_mesh_quantization` integers
    /// with these bit counts (module docs, "Quantized and compressed files"); `None` (the
    /// default): as `FLOAT`s, bit for bit.
    pub quantize: Option<QuantizeOptions>,
    /// Compress every buffer view but the images with `EXT_meshopt_compression`; implies
    /// quantization ([`QuantizeOptions::default`] when `quantize` is `None`).
    pub compress: bool,
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
            quantize: None,
            compress: false,
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
    #[error("--{what}-bits {bits}: give {min} to {max} bits")]
    Bits {
        what: &'static str,
        bits: u32,
        min: u32,
        max: u32,
    },
    #[error("level {level} has a vertex or triangle out of range, or no triangle (the mesh has {vertices} vertices): give levels of this mesh, as morphlod::export::levels makes them")]
    Level { level: usize, vertices: usize },
    #[error("the mesh's node has an animated transform, which would replace the dequantising transform --quantize puts there: export without --quantize and --compress")]
    QuantizedAnimatedNode,
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
    /// Bytes of the LOD's mesh data in the file's BIN chunk (vertex attributes, targets,
    /// indices; compressed when the file is).
    pub bytes: usize,
    /// With quantization: the largest distance between a pose of the LOD as written and as
    /// the morph describes it, over its vertices and the measured poses (module docs,
    /// "Quantized and compressed files"), relative to the base pose's bounding-box diagonal;
    /// 0 without.
    pub quantization_error: f32,
}

/// An exported file and what it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Export {
    /// The GLB file's bytes.
    pub glb: Vec<u8>,
    /// LOD0 (the original) first, then one per fraction or error bound.
    pub lods: Vec<Lod>,
    /// With quantization, the positions' grid: a position is stored as
    /// [`Grid::quantize`] and read as [`Grid::dequantize`].
    pub grid: Option<Grid>,
}

/// Exports `morph` and its LODs (module docs). The animation written is the morph's weight
/// track ([`Weights::Animated`](crate::morph::Weights::Animated)); a two-pose morph gets a
/// LINEAR 0 → 1 → 0 animation over two seconds (the weights of `t = 0`, `t = 1`, `t = 0`),
/// so a viewer plays it.
pub fn export_glb(morph: &Morph, options: &ExportOptions) -> Result<Export, ExportError> {
    check_levels(options)?;
    let written = check_written(morph, options)?;
    let lods = choose_levels(morph, options)?;
    write_levels(morph, lods, options, written)
}

/// Writes `lods` (LOD0 first; each over `morph`'s vertices, as [`levels`] gives them) as
/// [`export_glb`] writes its own: for levels chosen over other poses than `morph`'s animation
/// (a [`levels`] call on the same mesh with another weight track), written with this
/// morph's animation, names, source scene and quantization. [`ExportOptions::lods`] is not
/// used; [`ExportOptions::poses`] only counts the poses a quantized file's error is measured
/// over. A level with a vertex or triangle out of range is refused.
pub fn export_glb_levels(
    morph: &Morph,
    lods: Vec<Lod>,
    options: &ExportOptions,
) -> Result<Export, ExportError> {
    let n = morph.vertex_count();
    if lods.is_empty() {
        return Err(ExportError::Level {
            level: 0,
            vertices: n,
        });
    }
    for (level, lod) in lods.iter().enumerate() {
        let count = lod.source_vertex.len();
        let outside = lod.source_vertex.iter().any(|&v| v as usize >= n)
            || lod.triangles.iter().flatten().any(|&v| v as usize >= count);
        if outside || lod.triangles.is_empty() {
            return Err(ExportError::Level { level, vertices: n });
        }
    }
    let written = check_written(morph, options)?;
    write_levels(morph, lods, options, written)
}

/// What [`check_written`] settles before the levels are chosen.
struct Written {
    default_weights: Vec<f32>,
    quantize: Option<QuantizeOptions>,
}

/// Checks the options about what is written (default weights, source scene, quantization).
fn check_written(morph: &Morph, options: &ExportOptions) -> Result<Written, ExportError> {
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
    let quantize = match (options.quantize, options.compress) {
        (Some(q), _) => Some(q),
        (None, true) => Some(QuantizeOptions::default()),
        (None, false) => None,
    };
    if let Some(q) = &quantize {
        q.check()?;
        let source = &options.source;
        let animated = source.animations.iter().any(|a| {
            a.channels
                .iter()
                .any(|(node, _)| Some(*node) == source.mesh_node)
        });
        if animated && source.skin.is_none() {
            return Err(ExportError::QuantizedAnimatedNode);
        }
    }
    Ok(Written {
        default_weights,
        quantize,
    })
}

/// Quantizes (when asked) and writes the file of checked levels and options.
fn write_levels(
    morph: &Morph,
    mut lods: Vec<Lod>,
    options: &ExportOptions,
    Written {
        default_weights,
        quantize,
    }: Written,
) -> Result<Export, ExportError> {
    let diagonal = diagonal(morph.base());
    // Quantized after the LODs are chosen: the choice does not depend on it.
    let quantization = quantize.map(|options| {
        let grid = Grid::new(morph, options.position_bits);
        let deltas = morph
            .targets()
            .iter()
            .map(|t| {
                morph
                    .base()
                    .iter()
                    .zip(&t.deltas)
                    .map(|(&b, &d)| grid.delta(b, d))
                    .collect()
            })
            .collect();
        Quantization {
            options,
            grid,
            deltas,
        }
    });
    if let Some(q) = &quantization {
        let poses = quantize::error_poses(morph, options.poses, &default_weights);
        let errors = quantize::vertex_errors(morph, &q.grid, &q.deltas, &poses);
        for lod in &mut lods {
            lod.quantization_error = quantize::lod_error(&errors, lod, diagonal);
        }
    }
    let written = write_glb(
        morph,
        &lods,
        &default_weights,
        options,
        quantization.as_ref(),
    );
    for (lod, bytes) in lods.iter_mut().zip(written.lod_bytes) {
        lod.bytes = bytes;
    }
    Ok(Export {
        glb: written.glb,
        lods,
        grid: quantization.map(|q| q.grid),
    })
}

/// The levels [`export_glb`] writes, LOD0 (the original) first, without writing a file: the
/// same checks of [`ExportOptions::lods`] and [`ExportOptions::poses`], the same shared
/// sequence and the same choice of steps, so a caller that draws or imports the LODs itself
/// (the Python package, the Blender add-on) gets exactly what `morphlod export` would write.
/// The other options (names, source scene, quantization) are not used.
pub fn levels(morph: &Morph, options: &ExportOptions) -> Result<Vec<Lod>, ExportError> {
    check_levels(options)?;
    choose_levels(morph, options)
}

/// Refuses LOD steps and pose counts that [`choose_levels`] cannot use.
fn check_levels(options: &ExportOptions) -> Result<(), ExportError> {
    match &options.lods {
        LodSteps::Fractions(f) => check_fractions(f)?,
        LodSteps::Errors(e) => check_errors(e)?,
    }
    if options.poses == 0 || options.poses > MAX_FRAMES {
        return Err(ExportError::Poses {
            poses: options.poses,
        });
    }
    Ok(())
}

/// The shared sequence over `options.poses` sampled poses, and LOD0 and one LOD per fraction
/// or error bound on it (checked options).
fn choose_levels(morph: &Morph, options: &ExportOptions) -> Result<Vec<Lod>, ExportError> {
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
    Ok(lods)
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
    for (i, a) in source.animations.iter().enumerate() {
        if let Some(&(node, _)) = a.channels.iter().find(|(node, _)| *node >= n) {
            return fail(format!("animation {i} drives node {node} of {n} nodes"));
        }
        if let Some(w) = a
            .weights
            .as_ref()
            .filter(|w| w.targets() != morph.targets().len())
        {
            return fail(format!(
                "animation {i} has weights for {} targets, the morph has {}",
                w.targets(),
                morph.targets().len()
            ));
        }
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
