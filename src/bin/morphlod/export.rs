//! `morphlod export`: the original and its LODs as one glTF binary ([`morphlod::export`]).

use crate::args::SimplifyWeights;
use crate::load::{load_pair, load_surface};
use crate::output::{check_output, command_inputs, Written};
use clap::Args;
use morphlod::export::{export_glb, ExportOptions, LodSteps, QuantizeOptions, DEFAULT_POSES};
use morphlod::io::gltf::SourceScene;
use morphlod::io::{Format, LoadError, LoadOptions, MorphSource};
use morphlod::morph::{Morph, Weights};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Args)]
pub(crate) struct ExportArgs {
    /// A glTF file (all its morph targets, driven by its first weight animation, or by its
    /// default weights without one), or two meshes V(0) and V(1) (OBJ/OFF/PLY/glTF; of
    /// different connectivity: morphed over their supermesh).
    #[arg(required = true, num_args = 1..=2, value_name = "INPUT")]
    inputs: Vec<PathBuf>,
    /// Triangle fractions of the LODs below the original, in (0, 1], strictly decreasing.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.5,0.25,0.1",
        allow_negative_numbers = true
    )]
    lods: Vec<f32>,
    /// Instead of --lods: one LOD per error bound, relative to the bounding-box diagonal
    /// (0.01 = 1 %), > 0 and strictly increasing: the coarsest LOD whose simplification
    /// error, worst over the sampled poses, is within the bound.
    #[arg(
        long,
        value_delimiter = ',',
        conflicts_with = "lods",
        allow_negative_numbers = true,
        value_name = "E1,E2,..."
    )]
    error: Option<Vec<f32>>,
    /// Poses sampled over the animation for the one collapse sequence all LODs come from.
    #[arg(long, default_value_t = DEFAULT_POSES)]
    poses: usize,
    #[command(flatten)]
    weights: SimplifyWeights,
    /// glTF: the weight animation to follow (name or index; default: the first); for a
    /// skinned mesh the clip whose skinned poses the LODs are chosen over. Every animation of
    /// the file is written either way.
    #[arg(long, value_name = "NAME|INDEX")]
    animation: Option<String>,
    /// glTF, skinned mesh: the animation whose weights play beside the clip while the LODs are
    /// chosen (default: the clip's own, else the file's first weight animation).
    #[arg(long = "weights", value_name = "NAME|INDEX")]
    weight_animation: Option<String>,
    /// glTF: the mesh to export, by name or index (default: the first).
    #[arg(long, value_name = "NAME|INDEX")]
    mesh: Option<String>,
    /// Two meshes of different connectivity: landmark pairs for the supermesh.
    #[arg(long, value_name = "PAIRS.txt")]
    landmarks: Option<PathBuf>,
    /// Store positions, normals, UVs and morph deltas as integers (KHR_mesh_quantization; the
    /// positions on one grid, dequantised by the nodes' transform): half to two thirds the size, every
    /// position within half a grid step. Clients must support the extension.
    #[arg(long)]
    quantize: bool,
    /// Compress the meshes and animation with EXT_meshopt_compression (implies --quantize):
    /// several times smaller. Clients must support the extension (three.js with its
    /// MeshoptDecoder and Babylon.js do).
    #[arg(long)]
    compress: bool,
    /// With --quantize or --compress: bits per position component (1 to 15).
    #[arg(long, default_value_t = QuantizeOptions::default().position_bits)]
    position_bits: u32,
    /// With --quantize or --compress: bits per normal component (4 to 16).
    #[arg(long, default_value_t = QuantizeOptions::default().normal_bits)]
    normal_bits: u32,
    /// With --quantize or --compress: bits per texture coordinate (1 to 16).
    #[arg(long, default_value_t = QuantizeOptions::default().uv_bits)]
    uv_bits: u32,
    /// The .glb file to write.
    #[arg(short, long, value_name = "OUT.glb")]
    output: PathBuf,
}

pub(crate) fn export(args: &ExportArgs) -> Result<(), String> {
    let inputs = command_inputs(&args.inputs, args.landmarks.as_deref());
    check_output(&args.output, Written::Glb, &inputs)?;
    let options = LoadOptions {
        gltf_mesh: args.mesh.clone(),
        ..LoadOptions::default()
    };
    let start = Instant::now();
    let (morph, default_weights, source) = match args.inputs.as_slice() {
        [a, b] => (
            load_pair(a, b, args.landmarks.as_deref(), &options)?,
            None,
            SourceScene::default(),
        ),
        [path] => {
            let (morph, weights) = load_gltf(path, args.animation.as_deref(), &options)?;
            let source =
                morphlod::io::gltf::source_scene(path, &options).map_err(|e| e.to_string())?;
            // A skinned clip without weights of its own is posed beside the file's first
            // weight animation, so the LODs see the targets' poses too.
            let beside = args.weight_animation.clone().or_else(|| {
                let first = source.animations.iter().find(|a| a.weights.is_some());
                first.map(|a| a.index.to_string())
            });
            let morph = match (morph.skinning(), morph.weights(), beside) {
                (Some(_), Weights::TwoPose { .. }, Some(weights)) => {
                    let source = MorphSource::AnimationWithWeights {
                        animation: args.animation.clone().unwrap_or("0".into()),
                        weights,
                    };
                    morphlod::io::load_morph(path, &options, &source).map_err(|e| e.to_string())?
                }
                _ => morph,
            };
            (morph, weights, source)
        }
        _ => return Err("give one glTF file or two meshes".into()),
    };
    for line in &source.left_out {
        eprintln!("warning: not exported: {line}");
    }
    let name = args.inputs[0]
        .file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
    // One shared sequence over every pose: seconds to tens of seconds with the distance term,
    // and no natural unit of progress inside it, so a spinner says it is working.
    let spinner = std::io::stderr().is_terminal().then(|| {
        let spinner = indicatif::ProgressBar::new_spinner();
        spinner.set_message(format!(
            "simplifying over {} poses ({} triangles)",
            args.poses,
            morph.triangles().len()
        ));
        spinner.enable_steady_tick(std::time::Duration::from_millis(120));
        spinner
    });
    let export = export_glb(
        &morph,
        &ExportOptions {
            lods: match &args.error {
                Some(errors) => LodSteps::Errors(errors.clone()),
                None => LodSteps::Fractions(args.lods.clone()),
            },
            poses: args.poses,
            simplify: args.weights.simplify_options(true),
            default_weights,
            name,
            source,
            quantize: (args.quantize || args.compress).then_some(QuantizeOptions {
                position_bits: args.position_bits,
                normal_bits: args.normal_bits,
                uv_bits: args.uv_bits,
            }),
            compress: args.compress,
        },
    )
    .map_err(|e| e.to_string());
    if let Some(spinner) = spinner {
        spinner.finish_and_clear();
    }
    let export = export?;
    std::fs::write(&args.output, &export.glb)
        .map_err(|e| format!("{}: cannot write: {e}", args.output.display()))?;
    // Quantized files also give each LOD's quantisation error (max over its vertices and the
    // measured poses).
    let quantized = export.grid.is_some();
    let extra = if quantized { "  quantization/diag" } else { "" };
    println!("LOD  fraction  triangles  vertices  collapses  error/diagonal     bytes{extra}");
    for (i, lod) in export.lods.iter().enumerate() {
        let extra = if quantized {
            format!("  {:>17.3e}", lod.quantization_error)
        } else {
            String::new()
        };
        println!(
            "{i:>3}  {:>8.4}  {:>9}  {:>8}  {:>9}  {:>14.3e}  {:>8}{extra}",
            lod.fraction,
            lod.triangles.len(),
            lod.source_vertex.len(),
            lod.step,
            lod.error,
            lod.bytes,
        );
    }
    println!(
        "wrote {} ({} bytes, {} morph targets) in {:.2} s",
        args.output.display(),
        export.glb.len(),
        morph.targets().len(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// A glTF mesh with all its targets, driven by the chosen (or first) weight animation, and
/// the mesh's default weights; a skinned mesh posed by the chosen (or first) animation as its
/// clip. Without an animation (and none asked for) the morph runs from the base to the
/// default weights; without targets or a skin it is the static mesh.
fn load_gltf(
    path: &Path,
    animation: Option<&str>,
    options: &LoadOptions,
) -> Result<(Morph, Option<Vec<f32>>), String> {
    if Format::from_path(path) != Some(Format::Gltf) {
        return Err(format!(
            "{}: a single input must be a glTF file (.gltf, .glb); to export a {} mesh, \
             give two meshes V(0) V(1)",
            path.display(),
            Format::from_path(path).map_or("mesh", Format::name)
        ));
    }
    let by_default = load_surface(path, options)?;
    let default_weights = match by_default.weights() {
        Weights::TwoPose { w1, .. } if !by_default.targets().is_empty() => Some(w1.clone()),
        _ => None,
    };
    let source = MorphSource::Animation(animation.unwrap_or("0").to_string());
    match morphlod::io::load_morph_noted(path, options, &source) {
        Ok((morph, notes)) => {
            for note in notes {
                eprintln!("warning: {note}");
            }
            Ok((morph, default_weights))
        }
        Err(
            LoadError::NoSuchAnimation { .. }
            | LoadError::NoWeightChannel { .. }
            | LoadError::NoTargets { .. },
        ) if animation.is_none() => Ok((by_default, default_weights)),
        Err(e) => Err(e.to_string()),
    }
}
