//! `morphlod build`: the inputs loaded into one morph, cleaned, built into a `.mlod` asset,
//! written, read back and reported stage by stage.

use crate::args::SimplifyWeights;
use crate::load::{check_texture, clean_morph, clean_options, load_pair};
use crate::output::{check_output, command_inputs, Written};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use morphlod::asset::{inspect, save_bytes};
use morphlod::build::{BuildReport, Builder, Progress, Sequences, DEFAULT_FRAMES};
use morphlod::io::{Format, LoadOptions, MorphSource};
use morphlod::morph::Morph;
use morphlod::simplify::PoseError;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Args)]
pub(crate) struct BuildArgs {
    /// A glTF file with morph targets (with --target or --animation), or two
    /// mesh files: V(0) and V(1). Two meshes with different triangles (closed,
    /// genus 0) are morphed over their supermesh.
    #[arg(required = true, num_args = 1..=2, value_name = "INPUT")]
    inputs: Vec<PathBuf>,
    /// glTF: morph from the base mesh to this morph target (name or index).
    #[arg(long, value_name = "NAME|INDEX", conflicts_with = "animation")]
    target: Option<String>,
    /// glTF: follow this weight animation (name or index) over its duration; for a skinned
    /// mesh any animation: its joint channels pose the skin (a clip that ends where it starts
    /// is a loop: frames at t = k/|r|), its weight channel (if any) the targets.
    #[arg(long, value_name = "NAME|INDEX")]
    animation: Option<String>,
    /// glTF, skinned mesh: play this animation's weight channel beside the --animation clip,
    /// each once over t ∈ [0, 1] (a body's shape animation beside a walk).
    #[arg(long = "weights", value_name = "NAME|INDEX", requires = "animation")]
    weight_animation: Option<String>,
    /// Skinned mesh: the most joints a vertex keeps (the GPU's 4); a vertex with more keeps its
    /// largest weights, renormalised, and the displacement this makes is reported.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(1..=16))]
    max_influences: u8,
    /// glTF: the mesh to load, by name or index (default: the first).
    #[arg(long, value_name = "NAME|INDEX")]
    mesh: Option<String>,
    /// Sampled animation frames |r| (1 samples t = 0 only). With `--sequence shared`, the
    /// poses the one sequence is simplified over.
    #[arg(long, default_value_t = DEFAULT_FRAMES)]
    frames: usize,
    /// `per-frame`: one collapse sequence per sampled frame (coarse levels follow the shape at
    /// each moment). `shared`: one sequence simplified over all sampled poses at once (one
    /// connectivity per LOD for every t: no frame switches, one change list).
    #[arg(long, value_enum, default_value_t = SequenceArg::PerFrame)]
    sequence: SequenceArg,
    /// With `--sequence shared`: a collapse costs the maximum or the mean over the poses of
    /// its quadric error.
    #[arg(long, value_enum, default_value_t = PoseErrorArg::Max)]
    pose_error: PoseErrorArg,
    #[command(flatten)]
    weights: SimplifyWeights,
    /// Two meshes of different connectivity: landmark pairs for the supermesh, one
    /// `vertex_in_a vertex_in_b` a line.
    #[arg(long, value_name = "PAIRS.txt")]
    landmarks: Option<PathBuf>,
    /// Merge vertices at identical positions in every pose. A triangle soup
    /// (no vertex shared by two triangles) is welded without it.
    #[arg(long)]
    weld: bool,
    /// Weld nothing, not even a triangle soup.
    #[arg(long, conflicts_with = "weld")]
    no_weld: bool,
    /// The .mlod file to write.
    #[arg(short, long, value_name = "OUT.mlod")]
    output: PathBuf,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum SequenceArg {
    PerFrame,
    Shared,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum PoseErrorArg {
    Mean,
    Max,
}

/// Loads the inputs into one morph, cleans it, builds, writes and reports.
pub(crate) fn build(args: &BuildArgs) -> Result<(), String> {
    let inputs = command_inputs(&args.inputs, args.landmarks.as_deref());
    check_output(&args.output, Written::Mlod, &inputs)?;
    let total = Instant::now();
    let options = LoadOptions {
        gltf_mesh: args.mesh.clone(),
        ..LoadOptions::default()
    };
    let mut morph = load_morph(args, &options)?;
    report_skin(&mut morph, args.max_influences as usize);
    let load_time = total.elapsed();
    let clean_start = Instant::now();
    let morph = clean_morph(morph, &clean_options(args.weld, args.no_weld))?;
    if let Some(blend) = morph.target_blend() {
        eprintln!(
            "note: a weight animation: the asset keeps the {} targets it drives ({} keyframes, {}) \
             and the GPU blends them per frame",
            blend.deltas.len(),
            blend.track.keyframes(),
            blend.track.interpolation().name()
        );
    }
    let clean_time = clean_start.elapsed();

    let bar = std::io::stderr().is_terminal().then(|| {
        // A shared sequence is one job, however many poses it samples.
        let jobs = match args.sequence {
            SequenceArg::PerFrame => args.frames,
            SequenceArg::Shared => 1,
        };
        let bar = ProgressBar::new(jobs as u64);
        if let Ok(style) =
            ProgressStyle::with_template("frames {bar:40} {pos}/{len} [{elapsed_precise}]")
        {
            bar.set_style(style);
        }
        bar
    });
    let progress = |p: Progress| match &bar {
        Some(bar) => bar.set_position(p.frames_done as u64),
        None => eprintln!("frame {}/{} done", p.frames_done, p.frames),
    };
    let sequences = match (args.sequence, args.pose_error) {
        (SequenceArg::PerFrame, _) => Sequences::PerFrame,
        (SequenceArg::Shared, PoseErrorArg::Mean) => Sequences::Shared(PoseError::Mean),
        (SequenceArg::Shared, PoseErrorArg::Max) => Sequences::Shared(PoseError::Max),
    };
    let built = Builder::new(&morph)
        .frames(args.frames)
        .sequences(sequences)
        .simplify_options(
            args.weights
                .simplify_options(args.sequence == SequenceArg::Shared),
        )
        .progress(&progress)
        .build();
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let (asset, report) = built.map_err(|e| e.to_string())?;

    let encode_start = Instant::now();
    let bytes = asset.to_bytes();
    let encode_time = encode_start.elapsed();
    let write_start = Instant::now();
    save_bytes(&args.output, &bytes).map_err(|e| e.to_string())?;
    let write_time = write_start.elapsed();
    // Decoding the bytes just written checks them and gives the load time.
    let decode_start = Instant::now();
    let (decoded, info) = inspect(&bytes).map_err(|e| e.to_string())?;
    let decode_time = decode_start.elapsed();
    if decoded != asset {
        return Err(format!(
            "{}: the written asset does not read back equal to the built one (a morphlod bug)",
            args.output.display()
        ));
    }

    print!("{}", stage_table(&report, load_time, clean_time));
    println!("  encode            {}", ms(encode_time));
    println!("  write             {} (atomic save)", ms(write_time));
    println!(
        "  decode            {} (what loading the file costs)",
        ms(decode_time)
    );
    println!("  total             {}", ms(total.elapsed()));
    println!("asset {}\n{info}", args.output.display());
    Ok(())
}

fn load_morph(args: &BuildArgs, options: &LoadOptions) -> Result<Morph, String> {
    match args.inputs.as_slice() {
        [a, b] => {
            if args.target.is_some() || args.animation.is_some() {
                return Err("--target and --animation choose a glTF morph; with two input meshes the morph runs from the first to the second".into());
            }
            load_pair(a, b, args.landmarks.as_deref(), options)
        }
        [path] => {
            if Format::from_path(path) != Some(Format::Gltf) {
                // An OBJ, OFF or PLY file is one mesh: it has no targets to pick.
                return Err(format!(
                    "{}: a single input must be a glTF file with morph targets (.gltf, .glb); \
                     to morph a {} mesh, give two meshes with the same connectivity: \
                     `morphlod build V0 V1 -o OUT.mlod`",
                    path.display(),
                    Format::from_path(path).map_or("mesh", Format::name)
                ));
            }
            let source = match (&args.target, &args.animation, &args.weight_animation) {
                (Some(t), _, _) => MorphSource::Target(t.clone()),
                (None, Some(a), None) => MorphSource::Animation(a.clone()),
                (None, Some(a), Some(w)) => MorphSource::AnimationWithWeights {
                    animation: a.clone(),
                    weights: w.clone(),
                },
                (None, None, _) => {
                    return Err(format!(
                        "{}: one input needs --target NAME or --animation NAME (`morphlod info {}` lists them), or give two meshes",
                        path.display(),
                        path.display()
                    ))
                }
            };
            let (morph, notes) = morphlod::io::load_morph_noted(path, options, &source)
                .map_err(|e| e.to_string())?;
            for note in notes {
                eprintln!("warning: {note}");
            }
            check_texture(morph.attributes(), path)?;
            Ok(morph)
        }
        _ => Err("give one glTF file or two meshes".into()),
    }
}

/// For a skinned morph: keeps at most `max` influences a vertex (saying what that moved) and
/// says what the asset keeps of the skin and clip.
fn report_skin(morph: &mut Morph, max: usize) {
    if let Some(reduction) = morph.reduce_influences(max).filter(|r| r.vertices > 0) {
        let diagonal = morphlod::mesh::bounds(&morph.v0()).map_or(1.0, |(lo, hi)| {
            glam::Vec3::from(hi).distance(glam::Vec3::from(lo))
        });
        eprintln!(
            "warning: {} vertices had more than {max} joints: each keeps its {max} largest \
             weights, renormalised (dropped at most {:.4} of a vertex's weight; the pose moves by \
             at most {:.3e}, {:.2e} of the bind pose's diagonal, over the clip's keys)",
            reduction.vertices,
            reduction.max_dropped_weight,
            reduction.max_displacement,
            reduction.max_displacement / diagonal
        );
    }
    if let Some(skinning) = morph.skinning() {
        let (skin, clip) = (&skinning.skin, &skinning.clip);
        eprintln!(
            "note: a skinned mesh: {} joints, {} influences a vertex; clip '{}' ({} s, {} channels){}; \
             the asset keeps the skin and the clip, and every frame simplifies the skinned pose",
            skin.joint_count(),
            skin.influences,
            clip.name,
            clip.duration,
            clip.channels.len(),
            if clip.looping {
                ", a loop: frames sample t = k/|r| and the last is followed by the first"
            } else {
                ""
            }
        );
    }
}

pub(crate) fn stage_table(report: &BuildReport, load: Duration, clean: Duration) -> String {
    let frames = report.frame_times.len().max(1) as u32;
    let slowest = report.frame_times.iter().max().copied().unwrap_or_default();
    let mut out = format!(
        "build: {} vertices, {} triangles, {} frames, {} threads\n",
        report.vertices,
        report.triangles,
        report.frame_times.len(),
        report.threads
    );
    out += &format!("  load              {}\n", ms(load));
    out += &format!("  clean             {}\n", ms(clean));
    out += &format!(
        "  strips            {} ({} strips, {} indices; beside the frames)\n",
        ms(report.strip_time),
        report.strips,
        report.strip_indices
    );
    out += &format!(
        "  frames            {} wall, {} CPU ({} per frame mean, {} slowest)\n",
        ms(report.frames_wall),
        ms(report.frames_cpu()),
        ms(report.frames_cpu() / frames),
        ms(slowest)
    );
    out += &format!("  build wall        {}\n", ms(report.wall));
    out
}

pub(crate) fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}
