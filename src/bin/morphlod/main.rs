//! The `morphlod` command line. Each subcommand is a thin shell over the
//! library: it parses arguments, calls the library, and prints typed errors
//! as messages (exit code 1) instead of panics or Debug dumps.

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use morphlod::asset::{
    inspect, inspect_with, save_bytes, AssetLoadOptions, DEFAULT_MAX_BYTES, MAGIC,
};
use morphlod::build::{BuildReport, Builder, Progress, Sequences, DEFAULT_FRAMES};
use morphlod::deform::{DeformingModel, Lod};
use morphlod::gpu::{save_png, Context, DiscreteLevels, LevelsError, ShadeMode};
use morphlod::io::MorphSource;
use morphlod::io::{
    load_attributed, load_mesh, morph_from_pair, AttributeSummary, Format, LoadError, LoadOptions,
};
use morphlod::mesh::clean::{clean, CleanOptions};
use morphlod::morph::{Attributes, Morph, MorphError};
use morphlod::simplify::PoseError;
use morphlod::simplify::SimplifyOptions;
use morphlod::topology::analyze;
use morphlod::{Asset, IndexedMesh};
use std::io::{IsTerminal, Read};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

mod baselines;
mod bench;
mod bench_baselines;
mod export;
mod output;
mod plot;
mod sheet;
mod supermesh;

use bench::{run_bench, BenchOptions};
use export::ExportArgs;
use output::{check_folder, check_output, Written};
use sheet::{render_sheet, SheetOptions};
use supermesh::{build_supermesh, read_landmarks, SupermeshArgs};

#[derive(Parser)]
#[command(
    name = "morphlod",
    version,
    about = "Continuous LOD triangle strips for morphing meshes"
)]
struct Cli {
    /// Without a subcommand, `demo` runs on the embedded default asset.
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Print each file's contents: for a mesh its format, counts, cleaning
    /// summary and topology; for a .mlod asset its frames, LODs and section sizes.
    Info(InfoArgs),
    /// Build a .mlod asset: per-frame LOD collapse sequences over common strips.
    Build(BuildArgs),
    /// The supermesh of two closed genus-0 meshes of different connectivity, written as
    /// glTF binary (base = A, one morph target to B, an animation 0 → 1 → 0), with its report.
    Supermesh(SupermeshArgs),
    /// The original and its LODs (one collapse sequence simplified over sampled poses) as one
    /// glTF binary: every LOD keeps all morph targets, attributes, the material and the weight
    /// animation; the chain is declared with MSFT_lod.
    Export(ExportArgs),
    /// Render a .mlod asset headless to a PNG: one cell per (t, lod), columns t, rows LOD.
    Render(RenderArgs),
    /// Frame-rate benchmark of a .mlod asset headless: linear and exponential LOD sweeps over
    /// the animation, drawn as LOD strips, as triangle lists of the same LOD, and at full detail.
    Bench(BenchArgs),
    /// The main job on the embedded default (makehuman_head.glb, jawOpen): build the
    /// per-frame LOD model, then render contact sheets headless to PNG files.
    Demo(DemoArgs),
}

#[derive(Args)]
struct BuildArgs {
    /// A glTF file with morph targets (with --target or --animation), or two
    /// mesh files: V(0) and V(1). Two meshes with different triangles (closed,
    /// genus 0) are morphed over their supermesh.
    #[arg(required = true, num_args = 1..=2, value_name = "INPUT")]
    inputs: Vec<PathBuf>,
    /// glTF: morph from the base mesh to this morph target (name or index).
    #[arg(long, value_name = "NAME|INDEX", conflicts_with = "animation")]
    target: Option<String>,
    /// glTF: follow this weight animation (name or index) over its duration.
    #[arg(long, value_name = "NAME|INDEX")]
    animation: Option<String>,
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

#[derive(Args)]
struct RenderArgs {
    /// The .mlod asset to render.
    asset: PathBuf,
    /// Times t in [0, 1], comma-separated: one column each. Values outside are
    /// clamped into [0, 1] (with a note); NaN is refused.
    #[arg(
        long = "t",
        value_delimiter = ',',
        default_value = "0.5",
        allow_negative_numbers = true
    )]
    ts: Vec<f32>,
    /// LOD fractions in [0, 1] (0 = full detail), comma-separated: one row each.
    /// Values outside are clamped into [0, 1] (with a note); NaN is refused.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0",
        allow_negative_numbers = true
    )]
    lod: Vec<f32>,
    /// `textured`: the asset's material and smooth normals (faceted for an asset without a
    /// surface); `smooth`: smooth normals, one colour; `faceted` (or `base`): the drawn
    /// triangles' own normals, one colour; `strips`: every strip its own colour, faceted.
    #[arg(long, value_enum, default_value_t = Colour::Textured)]
    color: Colour,
    /// Cell size in pixels.
    #[arg(long, default_value_t = 384)]
    size: u32,
    /// The PNG to write.
    #[arg(short, long, value_name = "OUT.png")]
    output: PathBuf,
    /// Most memory loading the asset (and building its LOD model) may take, in MiB;
    /// a file that would need more is refused before it is decoded.
    #[arg(long = "memory-budget", value_name = "MB", default_value_t = DEFAULT_MAX_BYTES >> 20)]
    memory_budget: u64,
}

#[derive(Args)]
struct BenchArgs {
    /// The .mlod asset to benchmark (with `--baselines`, a mesh file: .off, .obj, .ply, .glb).
    asset: PathBuf,
    /// Instead of the sweeps, the LodStrips paper's comparison on a mesh: Progressive Meshes,
    /// MTS, Skip Strips and LodStrips from one QEM sequence, their spatial cost (Table 1) and
    /// the linear and exponential tests (Table 2); `--frames` per test, `--json` the rows,
    /// `--plot` vertices and strips sent over the linear test (the paper's Fig. 1).
    #[arg(long, conflicts_with = "crowd")]
    baselines: bool,
    /// Frames per sweep.
    #[arg(long, default_value_t = 240)]
    frames: usize,
    /// Width and height of the offscreen target, in pixels.
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// Draws of each object per frame; the fastest counts (the first also carries the uploads).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u16).range(1..))]
    repeats: u16,
    /// How every object is shaded (as `render --color`); the strips are also timed faceted
    /// each frame, for the cost of the shading.
    #[arg(long, value_enum, default_value_t = Colour::Textured)]
    shade: Colour,
    /// Also write every frame's measurements to this JSON file.
    #[arg(long, value_name = "OUT.json")]
    json: Option<PathBuf>,
    /// Whether the sweeps' strips object builds its next frames on a thread of their own
    /// (`gpu::BuildAhead`; `auto`: models of at least 65,536 slots of `S0`).
    #[arg(long = "build-ahead", value_name = "WHEN", value_parser = ["auto", "always", "never"], default_value = "auto")]
    build_ahead: String,
    /// Also plot frame time and triangles over both sweeps to this PNG file.
    #[arg(long, value_name = "OUT.png")]
    plot: Option<PathBuf>,
    /// Most memory loading the asset (and building its LOD model) may take, in MiB;
    /// a file that would need more is refused before it is decoded.
    #[arg(long = "memory-budget", value_name = "MB", default_value_t = DEFAULT_MAX_BYTES >> 20)]
    memory_budget: u64,
    /// Instead of the sweeps, a crowd of N instances on a grid (LOD by 1 px of screen error
    /// and full detail), each at its own phase; `--frames` frames per mode, 1920x1080 unless
    /// `--size` is given, `--json` writes the report.
    #[arg(long, value_name = "N")]
    crowd: Option<u32>,
    /// Render frames per loop of the animation in the crowd bench.
    #[arg(long, default_value_t = 120)]
    period: usize,
    /// The crowd bench's path (first-instance needs INDIRECT_FIRST_INSTANCE); default: the
    /// first-instance path where the device has it.
    #[arg(long = "crowd-path", value_name = "PATH", value_parser = ["first-instance", "base-vertex"])]
    crowd_path: Option<String>,
    /// The crowd bench's compact area per instance, as a share of its strip regions' index
    /// slots in 0..=1 (`gpu::CrowdRecords`): an instance whose live strips fit in it draws a
    /// packed copy of them; 0 turns the copies off.
    #[arg(long, value_name = "SHARE", default_value_t = morphlod::gpu::CrowdRecords::default().compact_share)]
    compact_share: f32,
    /// The crowd bench's tail lists (`gpu::CrowdRecords`): the most triangles of a frame's
    /// coarsest LODs that its instances draw from one list per frame, expanded on the GPU,
    /// instead of from their own strips; 0 turns them off.
    #[arg(long, value_name = "TRIANGLES", default_value_t = morphlod::gpu::CrowdRecords::default().tail_triangles)]
    tail_triangles: u32,
    /// The crowd bench's discrete LODs (full detail and `--levels`, as `morphlod export
    /// --lods`) are cut from this asset's one shared sequence: a build of the same source with
    /// `--sequence shared`. Without it they are cut from the benchmarked asset when it was
    /// built so, and not run otherwise.
    #[arg(long, value_name = "SHARED.mlod")]
    levels_from: Option<PathBuf>,
    /// Triangle fractions of the crowd bench's discrete levels below full detail, in (0, 1),
    /// strictly decreasing (the default is `morphlod export`'s).
    #[arg(long, value_delimiter = ',', default_value = "0.5,0.25,0.1")]
    levels: Vec<f32>,
    /// Leave out the crowd bench's full-detail mode (slow with many instances on a software
    /// rasteriser).
    #[arg(long)]
    skip_full: bool,
}

#[derive(Args)]
struct DemoArgs {
    /// Where to write the contact sheets (PNG).
    #[arg(short, long, value_name = "DIR", default_value = "out")]
    output: PathBuf,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum SequenceArg {
    PerFrame,
    Shared,
}

/// The simplifier's optional error terms: how much UVs and given normals count (meshes with
/// attributes; others never use them), and the distance term.
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct SimplifyWeights {
    /// Weight of the UV error (0 = geometry only; see `SimplifyOptions::uv_weight`).
    #[arg(long, default_value_t = morphlod::simplify::UV_WEIGHT, value_parser = weight, allow_negative_numbers = true)]
    uv_weight: f32,
    /// Weight of the normal error (0 = geometry only; see `SimplifyOptions::normal_weight`).
    #[arg(long, default_value_t = morphlod::simplify::NORMAL_WEIGHT, value_parser = weight, allow_negative_numbers = true)]
    normal_weight: f32,
    /// Weight of the distance term (0 = off): lower Hausdorff error, most at low triangle
    /// counts, for a build many times longer (see `SimplifyOptions::distance_weight`).
    /// Default: 4 for one shared sequence (export, build --sequence shared), 0 for per-frame
    /// sequences (one simplification per frame).
    #[arg(long, value_parser = weight, allow_negative_numbers = true)]
    distance_weight: Option<f32>,
}

impl SimplifyWeights {
    /// The options for a shared sequence (`shared`) or per-frame ones.
    pub(crate) fn simplify_options(self, shared: bool) -> SimplifyOptions {
        let distance = if shared {
            morphlod::simplify::DISTANCE_WEIGHT
        } else {
            0.0
        };
        SimplifyOptions {
            uv_weight: self.uv_weight,
            normal_weight: self.normal_weight,
            distance_weight: self.distance_weight.unwrap_or(distance),
            ..SimplifyOptions::default()
        }
    }
}

fn weight(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(w) if w.is_finite() && w >= 0.0 => Ok(w),
        _ => Err(format!(
            "'{text}' is not a weight: give a finite number >= 0 (0 turns the term off)"
        )),
    }
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum PoseErrorArg {
    Mean,
    Max,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Colour {
    Textured,
    Smooth,
    #[value(alias = "base")]
    Faceted,
    Strips,
}

impl Colour {
    fn shade(self) -> ShadeMode {
        match self {
            Colour::Textured => ShadeMode::Textured,
            Colour::Smooth => ShadeMode::Smooth,
            Colour::Faceted => ShadeMode::Faceted,
            Colour::Strips => ShadeMode::StripColours,
        }
    }
}

#[derive(Args)]
struct InfoArgs {
    /// Mesh files (.obj, .off, .ply, .gltf, .glb) or .mlod assets.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Merge vertices with identical positions before the topology report.
    /// A triangle soup (no vertex shared by two triangles) is welded without it.
    #[arg(long)]
    weld: bool,
    /// Weld nothing, not even a triangle soup.
    #[arg(long, conflicts_with = "weld")]
    no_weld: bool,
    /// glTF: the mesh to load, by name or index (default: the first).
    #[arg(long, value_name = "NAME|INDEX")]
    mesh: Option<String>,
    /// Most memory loading the asset may take, in MiB;
    /// a file that would need more is refused before it is decoded.
    #[arg(long = "memory-budget", value_name = "MB", default_value_t = DEFAULT_MAX_BYTES >> 20)]
    memory_budget: u64,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let done = match cli.command {
        Some(Command::Info(args)) => return info(&args),
        Some(Command::Build(args)) => build(&args),
        Some(Command::Supermesh(args)) => supermesh::supermesh(&args),
        Some(Command::Export(args)) => export::export(&args),
        Some(Command::Render(args)) => render(&args),
        Some(Command::Bench(args)) => bench(&args),
        Some(Command::Demo(args)) => demo(&args),
        None => demo(&DemoArgs {
            output: PathBuf::from("out"),
        }),
    };
    match done {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

/// Reports every file, continuing past failures so one bad file in a batch
/// does not hide the others; the exit code says whether any failed.
fn info(args: &InfoArgs) -> ExitCode {
    let options = LoadOptions {
        gltf_mesh: args.mesh.clone(),
        ..LoadOptions::default()
    };
    let mut failed = false;
    let mut printed = false;
    for path in &args.files {
        let report = if is_asset(path) {
            asset_info(path, args.memory_budget)
        } else {
            info_one(path, &options, &clean_options(args.weld, args.no_weld))
        };
        match report {
            Ok(report) => {
                // A blank line between reports, none before the first.
                if printed {
                    println!();
                }
                print!("{report}");
                printed = true;
            }
            Err(message) => {
                eprintln!("error: {message}");
                failed = true;
            }
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// The report for one file, built whole so a failure midway prints nothing
/// half-done.
fn info_one(
    path: &Path,
    options: &LoadOptions,
    clean_options: &CleanOptions,
) -> Result<String, String> {
    let mesh = load_mesh(path, options).map_err(|e| e.to_string())?;
    let cleaned = clean(&mesh, clean_options).map_err(|e| format!("{}: {e}", path.display()))?;
    let topology = analyze(&cleaned.mesh).map_err(|e| format!("{}: {e}", path.display()))?;
    let format = Format::from_path(path).map_or("unknown", Format::name);
    let mut out = format!("{}\n", path.display());
    out += &format!("  format            {format}\n");
    out += &format!(
        "  raw               {} vertices, {} triangles\n",
        mesh.vertex_count(),
        mesh.triangle_count()
    );
    if let Some((lo, hi)) = mesh.bounds() {
        out += &format!("  bounds            {lo:?} .. {hi:?}\n");
    }
    out += &format!("cleaning ({})\n", weld_mode(clean_options));
    out += &format!("{}\n", cleaned.report);
    out += &format!("topology (after cleaning)\n{topology}\n");
    let start = Instant::now();
    let surface = load_surface(path, options)?;
    let load = start.elapsed();
    out += &format!(
        "attributes (loaded with them in {})\n{}",
        ms(load),
        AttributeSummary::of(&surface)
    );
    let topology = surface.topology();
    if !topology.is_identity() {
        // The report above counts attribute vertices, split at seams; the simplifier sees
        // the surface with those copies joined.
        let mut positions = vec![[0.0; 3]; topology.topology_count];
        for (v, &t) in topology.of_vertex.iter().enumerate() {
            positions[t as usize] = surface.base()[v];
        }
        let welded = IndexedMesh::new(positions, topology.triangles(surface.triangles()));
        let report = analyze(&welded).map_err(|e| format!("{}: {e}", path.display()))?;
        out += &format!("topology of the welded surface (seam copies joined)\n{report}\n");
    }
    if Format::from_path(path) == Some(Format::Gltf) {
        let summary = morphlod::io::gltf::inspect(path).map_err(|e| e.to_string())?;
        out += &format!("glTF contents\n{summary}");
    }
    Ok(out)
}

/// The file as the pipeline sees it: a glTF mesh with its targets (at their default
/// weights) and attributes, or any mesh with its attributes and no targets.
fn load_surface(path: &Path, options: &LoadOptions) -> Result<Morph, String> {
    if Format::from_path(path) == Some(Format::Gltf) {
        match morphlod::io::load_morph(path, options, &MorphSource::DefaultWeights) {
            Err(LoadError::NoTargets { .. }) => {}
            other => return other.map_err(|e| e.to_string()),
        }
    }
    let morph = load_attributed(path, options)
        .map_err(|e| e.to_string())?
        .to_static_morph()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    check_texture(morph.attributes(), path)?;
    Ok(morph)
}

/// Refuses a base-colour texture that does not decode. Loading checks only the image's header
/// (the core does not link an image decoder), so without this a broken image would be built or
/// exported and fail only when drawn.
fn check_texture(attributes: &Attributes, path: &Path) -> Result<(), String> {
    match &attributes.material.texture {
        Some(texture) => morphlod::gpu::decode_texture(texture)
            .map(drop)
            .map_err(|e| format!("{}: {e}", path.display())),
        None => Ok(()),
    }
}

/// A `.mlod` file by extension, or any file starting with the `.mlod` magic.
fn is_asset(path: &Path) -> bool {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mlod"))
    {
        return true;
    }
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| head == MAGIC)
}

/// `--memory-budget MB` as load options.
fn budget(mb: u64) -> AssetLoadOptions {
    AssetLoadOptions {
        max_bytes: mb.saturating_mul(1 << 20),
    }
}

fn asset_info(path: &Path, memory_budget: u64) -> Result<String, String> {
    let options = budget(memory_budget);
    let bytes = read_asset(path, &options)?;
    let start = Instant::now();
    let (_, info) =
        inspect_with(&bytes, &options).map_err(|e| format!("{}: {e}", path.display()))?;
    let decode = start.elapsed();
    let mut out = format!(
        "{}\n  format            morphlod asset (.mlod)\n",
        path.display()
    );
    out += &format!("{info}\n");
    out += &format!("  decode            {}\n", ms(decode));
    Ok(out)
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

/// Loads the inputs into one morph, cleans it, builds, writes and reports.
fn build(args: &BuildArgs) -> Result<(), String> {
    let inputs = command_inputs(&args.inputs, args.landmarks.as_deref());
    check_output(&args.output, Written::Mlod, &inputs)?;
    let total = Instant::now();
    let options = LoadOptions {
        gltf_mesh: args.mesh.clone(),
        ..LoadOptions::default()
    };
    let morph = load_morph(args, &options)?;
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

/// The files a command reads: its input meshes and the landmarks file, if any. No output
/// may be one of them ([`check_output`]).
pub(crate) fn command_inputs<'a>(
    inputs: impl IntoIterator<Item = &'a PathBuf>,
    landmarks: Option<&'a Path>,
) -> Vec<&'a Path> {
    inputs
        .into_iter()
        .map(PathBuf::as_path)
        .chain(landmarks)
        .collect()
}

/// `--weld` / `--no-weld` as cleaning options (neither: only a triangle soup is welded).
fn clean_options(weld: bool, no_weld: bool) -> CleanOptions {
    CleanOptions {
        weld,
        weld_soup: !no_weld,
    }
}

fn weld_mode(options: &CleanOptions) -> &'static str {
    match (options.weld, options.weld_soup) {
        (true, _) => "weld on",
        (false, true) => "weld off, triangle soups welded",
        (false, false) => "weld off",
    }
}

/// Cleans through [`Morph::clean`] (decisions on V(0), welds only where every
/// pose agrees, one connectivity for all poses) and prints the cleaning summary.
fn clean_morph(morph: Morph, options: &CleanOptions) -> Result<Morph, String> {
    let (morph, report) = morph.clean(options).map_err(|e| e.to_string())?;
    println!("cleaning ({})\n{report}", weld_mode(options));
    Ok(morph)
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
            let source = match (&args.target, &args.animation) {
                (Some(t), _) => MorphSource::Target(t.clone()),
                (None, Some(a)) => MorphSource::Animation(a.clone()),
                (None, None) => {
                    return Err(format!(
                        "{}: one input needs --target NAME or --animation NAME (`morphlod info {}` lists them), or give two meshes",
                        path.display(),
                        path.display()
                    ))
                }
            };
            let morph =
                morphlod::io::load_morph(path, options, &source).map_err(|e| e.to_string())?;
            check_texture(morph.attributes(), path)?;
            Ok(morph)
        }
        _ => Err("give one glTF file or two meshes".into()),
    }
}

/// Two meshes as a morph from the first to the second: directly when they share their
/// connectivity, else over their supermesh (with the optional landmark pairs).
pub(crate) fn load_pair(
    a_path: &Path,
    b_path: &Path,
    landmarks: Option<&Path>,
    options: &LoadOptions,
) -> Result<Morph, String> {
    let a = load_attributed(a_path, options).map_err(|e| e.to_string())?;
    let b = load_attributed(b_path, options).map_err(|e| e.to_string())?;
    // The morph takes the first mesh's material.
    check_texture(&a.attributes, a_path)?;
    match morph_from_pair(&a, &b) {
        Ok(morph) => {
            if landmarks.is_some() {
                eprintln!("note: the meshes have the same connectivity: no supermesh is built and --landmarks is not used");
            }
            Ok(morph)
        }
        Err(
            MorphError::PoseSizeMismatch { .. }
            | MorphError::TriangleCountMismatch { .. }
            | MorphError::TriangleMismatch { .. },
        ) => {
            let landmarks = read_landmarks(landmarks)?;
            let (supermesh, report) =
                build_supermesh(&a.positions, &b.positions, &landmarks, true)?;
            println!(
                "{} and {} have different connectivity: built a supermesh ({} vertices, {} triangles, {} crossings)\n{report}",
                a_path.display(),
                b_path.display(),
                report.vertices,
                report.triangles,
                report.crossings
            );
            warn_fold_overs(&report);
            supermesh.to_morph().map_err(|e| e.to_string())
        }
        Err(e) => Err(e.to_string()),
    }
}

/// A supermesh with fold-overs is not a bijection between the surfaces (a morphlod bug):
/// say so, the build goes on.
fn warn_fold_overs(report: &morphlod::morph::supermesh::SupermeshReport) {
    if report.fold_overs > 0 {
        eprintln!(
            "warning: {} supermesh triangle(s) fold over on the sphere (should be 0; please report this with the meshes)",
            report.fold_overs
        );
    }
}

fn stage_table(report: &BuildReport, load: Duration, clean: Duration) -> String {
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

/// Renders one asset's (t, lod) grid to a PNG and prints what each cell drew.
fn render(args: &RenderArgs) -> Result<(), String> {
    check_output(&args.output, Written::Png, &[&args.asset])?;
    let ts = unit_values("t", &args.ts)?;
    let fractions = unit_values("lod", &args.lod)?;
    check_sheet_size(args.size, ts.len(), fractions.len())?;
    let budget = budget(args.memory_budget);
    let bytes = read_asset(&args.asset, &budget)?;
    let asset = Asset::from_bytes_with(&bytes, &budget)
        .map_err(|e| format!("{}: {e}", args.asset.display()))?;
    drop(bytes);
    let options = SheetOptions {
        cell: args.size,
        shade: args.color.shade(),
        ..SheetOptions::default()
    };
    let lods: Vec<Lod> = fractions.iter().map(|&f| Lod::Fraction(f)).collect();
    render_to_png(asset, &ts, &lods, &options, &args.output, budget.max_bytes)
}

/// One rule for `--t` and `--lod`, the library's: values outside [0, 1] are clamped (the
/// CLI says so on stderr), NaN is refused.
fn unit_values(name: &str, values: &[f32]) -> Result<Vec<f32>, String> {
    values
        .iter()
        .map(|&v| {
            if v.is_nan() {
                return Err(format!(
                    "--{name}: {v} is not a number; give values in [0, 1]"
                ));
            }
            let clamped = v.clamp(0.0, 1.0);
            if clamped != v {
                eprintln!("note: {name} {v} is outside [0, 1]: clamped to {clamped}");
            }
            Ok(clamped)
        })
        .collect()
}

/// The most pixels a contact sheet may have: 8192 x 8192, 256 MiB as RGBA, the
/// sheet being assembled in memory before it is written.
const MAX_SHEET_PIXELS: u64 = 8192 * 8192;

/// Refuses a sheet whose image would pass [`MAX_SHEET_PIXELS`], before anything is allocated.
fn check_sheet_size(cell: u32, columns: usize, rows: usize) -> Result<(), String> {
    let (w, h) = (
        u64::from(cell) * columns as u64,
        u64::from(cell) * rows as u64,
    );
    if w.saturating_mul(h) > MAX_SHEET_PIXELS || cell == 0 {
        return Err(format!(
            "the sheet would be {w} x {h} pixels ({columns} columns x {rows} rows of {cell}); \
             the limit is {MAX_SHEET_PIXELS} pixels (8192 x 8192) and a cell must be at least 1: \
             lower --size or give fewer --t / --lod values"
        ));
    }
    Ok(())
}

/// The bytes of a `.mlod` file, or a clear error for a mesh or a directory given instead.
fn read_asset(path: &Path, options: &AssetLoadOptions) -> Result<Vec<u8>, String> {
    if path.is_dir() {
        return Err(format!(
            "{}: is a directory, not a .mlod asset",
            path.display()
        ));
    }
    if !is_asset(path) && Format::from_path(path).is_some() {
        return Err(format!(
            "{}: this is a mesh: build it first with `morphlod build` (then give the .mlod file)",
            path.display()
        ));
    }
    let length = std::fs::metadata(path)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .len();
    if length > options.max_bytes {
        let e = morphlod::asset::AssetError::OverBudget {
            needed: length,
            budget: options.max_bytes,
        };
        return Err(format!("{}: {e}", path.display()));
    }
    std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Runs the frame-rate benchmark and prints its summary (and writes the rows as JSON).
fn bench(args: &BenchArgs) -> Result<(), String> {
    if let Some(path) = &args.json {
        check_output(path, Written::Json, &[&args.asset])?;
    }
    if let Some(path) = &args.plot {
        check_output(path, Written::Png, &[&args.asset])?;
    }
    if args.baselines {
        return baselines_bench(args);
    }
    let budget = budget(args.memory_budget);
    let bytes = read_asset(&args.asset, &budget)?;
    let mut asset = Asset::from_bytes_with(&bytes, &budget)
        .map_err(|e| format!("{}: {e}", args.asset.display()))?;
    drop(bytes);
    let model =
        Arc::new(DeformingModel::with_budget(&asset, budget.max_bytes).map_err(|e| e.to_string())?);
    let levels = match args.crowd {
        Some(_) => discrete_levels(args, &asset, &budget)?,
        None => None,
    };
    // The model holds what the runtime needs of the sequences; the bench reads the poses only.
    asset.release_frames();
    let context = Context::headless().map_err(|e| e.to_string())?;
    if let Some(instances) = args.crowd {
        return crowd_bench(args, instances, &context, &asset, model, levels);
    }
    let info = context.adapter_info();
    println!(
        "bench on {} ({:?}, {:?}): {} frames per sweep, {}x{} target",
        info.name, info.backend, info.device_type, args.frames, args.size, args.size
    );
    let options = BenchOptions {
        frames: args.frames,
        size: args.size,
        repeats: usize::from(args.repeats),
        shade: args.shade.shade(),
        build_ahead: match args.build_ahead.as_str() {
            "always" => morphlod::gpu::BuildAhead::Always,
            "never" => morphlod::gpu::BuildAhead::Never,
            _ => morphlod::gpu::BuildAhead::Auto,
        },
    };
    let report = run_bench(&context, &asset, &model, &options).map_err(|e| e.to_string())?;
    print!("{}", report.summary());
    if let Some(path) = &args.json {
        std::fs::write(path, report.to_json()).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("rows written to {}", path.display());
    }
    if let Some(path) = &args.plot {
        plot::write_plot(&report, path)?;
        println!("plot written to {}", path.display());
    }
    Ok(())
}

/// `bench --baselines MESH`: the LodStrips paper's tables ([`bench_baselines`]).
fn baselines_bench(args: &BenchArgs) -> Result<(), String> {
    let path = &args.asset;
    let mesh = morphlod::io::load_mesh(path, &morphlod::io::LoadOptions::default())
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let start = Instant::now();
    let seq = morphlod::simplify::simplify(
        &mesh.positions,
        &mesh.triangles,
        &SimplifyOptions::default(),
    );
    let simplify_s = start.elapsed().as_secs_f64();
    let context = Context::headless().map_err(|e| e.to_string())?;
    let info = context.adapter_info();
    println!(
        "baselines on {} ({:?}, {:?}): {} frames per test, {}x{} target, {} repeats; QEM sequence in {simplify_s:.1} s",
        info.name, info.backend, info.device_type, args.frames, args.size, args.size, args.repeats
    );
    let name = path.file_stem().map_or_else(
        || path.display().to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    let options = bench_baselines::BaselineOptions {
        frames: args.frames,
        size: args.size,
        repeats: usize::from(args.repeats),
    };
    let report = bench_baselines::run_baselines(&context, &name, &mesh, &seq, &options)?;
    print!("{}", report.markdown());
    if let Some(path) = &args.json {
        std::fs::write(path, report.to_json()).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("report written to {}", path.display());
    }
    if let Some(path) = &args.plot {
        plot::write_baselines_plot(&report, path)?;
        println!("plot written to {}", path.display());
    }
    Ok(())
}

/// The crowd bench's discrete levels: from `--levels-from` (checked to have the benchmarked
/// asset's vertices), else from the asset when it has one shared sequence; `None` (with a
/// note) when it has per-frame sequences.
fn discrete_levels(
    args: &BenchArgs,
    asset: &Asset,
    budget: &AssetLoadOptions,
) -> Result<Option<DiscreteLevels>, String> {
    let fractions = &args.levels;
    let Some(path) = &args.levels_from else {
        return match DiscreteLevels::from_asset(asset, fractions) {
            Ok(levels) => Ok(Some(levels)),
            Err(e @ LevelsError::NotShared { .. }) => {
                println!("discrete LODs not run: {e}, and pass it with --levels-from");
                Ok(None)
            }
            Err(e) => Err(format!("{}: {e}", args.asset.display())),
        };
    };
    let bytes = read_asset(path, budget)?;
    let source =
        Asset::from_bytes_with(&bytes, budget).map_err(|e| format!("{}: {e}", path.display()))?;
    if source.v0 != asset.v0 || source.v1 != asset.v1 {
        return Err(format!(
            "{}: its poses are not those of {}; build both from the same source",
            path.display(),
            args.asset.display()
        ));
    }
    DiscreteLevels::from_asset(&source, fractions)
        .map(Some)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// `bench --crowd N`: the crowd benchmark ([`morphlod::gpu::run_crowd_bench`]).
fn crowd_bench(
    args: &BenchArgs,
    instances: u32,
    context: &Context,
    asset: &Asset,
    model: Arc<DeformingModel>,
    discrete: Option<DiscreteLevels>,
) -> Result<(), String> {
    let size_given = args.size != 512;
    let options = morphlod::gpu::CrowdBenchOptions {
        instances,
        frames: args.frames,
        period: args.period,
        width: if size_given { args.size } else { 1920 },
        height: if size_given { args.size } else { 1080 },
        path: args.crowd_path.as_deref().map(|path| match path {
            "base-vertex" => morphlod::gpu::CrowdPath::BaseVertex,
            _ => morphlod::gpu::CrowdPath::FirstInstance,
        }),
        full_detail: !args.skip_full,
        discrete,
        records: morphlod::gpu::CrowdRecords {
            compact_share: args.compact_share,
            tail_triangles: args.tail_triangles,
        },
        ..Default::default()
    };
    let report = morphlod::gpu::run_crowd_bench(context, asset, model, &options)
        .map_err(|e| e.to_string())?;
    print!("{}", report.summary());
    if let Some(path) = &args.json {
        std::fs::write(path, report.to_json()).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("report written to {}", path.display());
    }
    if let Some(path) = &args.plot {
        plot::write_crowd_plot(&report, path)?;
        println!("plot written to {}", path.display());
    }
    Ok(())
}

/// The default asset, compiled in so `cargo run` works from any directory of the checkout: the
/// textured face, so the picture shows normals, UVs and seams surviving the LOD.
const DEMO_INPUT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/makehuman_face.glb");
const DEMO_TARGET: &str = "jawOpen";
const DEMO_FRAMES: usize = 16;

/// The demo's files in its `--output` folder: the asset and the two contact sheets.
const DEMO_ASSET: &str = "demo.mlod";
const DEMO_SHEETS: [(ShadeMode, &str); 2] = [
    (ShadeMode::Textured, "demo.png"),
    (ShadeMode::StripColours, "demo_strips.png"),
];

fn demo(args: &DemoArgs) -> Result<(), String> {
    check_folder(&args.output)?;
    let input = Path::new(DEMO_INPUT);
    check_output(&args.output.join(DEMO_ASSET), Written::Mlod, &[input])?;
    for (_, name) in DEMO_SHEETS {
        check_output(&args.output.join(name), Written::Png, &[input])?;
    }
    println!("morphlod demo: {DEMO_INPUT}, target '{DEMO_TARGET}', {DEMO_FRAMES} frames");
    let source = MorphSource::Target(DEMO_TARGET.into());
    let morph = morphlod::io::load_morph(Path::new(DEMO_INPUT), &LoadOptions::default(), &source)
        .map_err(|e| e.to_string())?;
    let morph = clean_morph(morph, &CleanOptions::default())?;
    let (asset, report) = Builder::new(&morph)
        .frames(DEMO_FRAMES)
        .build()
        .map_err(|e| e.to_string())?;
    print!("{}", stage_table(&report, Duration::ZERO, Duration::ZERO));
    std::fs::create_dir_all(&args.output).map_err(|e| format!("{}: {e}", args.output.display()))?;
    let path = args.output.join(DEMO_ASSET);
    asset.save(&path).map_err(|e| e.to_string())?;
    println!("asset written to {}", path.display());

    let ts = [0.0, 0.25, 0.5, 0.75, 1.0];
    let lods = [Lod::Fraction(0.0), Lod::Fraction(0.75), Lod::Fraction(0.95)];
    for (shade, name) in DEMO_SHEETS {
        let options = SheetOptions {
            shade,
            ..SheetOptions::default()
        };
        render_to_png(
            asset.clone(),
            &ts,
            &lods,
            &options,
            &args.output.join(name),
            DEFAULT_MAX_BYTES,
        )?;
    }
    Ok(())
}

/// Renders headless (no window is opened: this works on machines without a display) and
/// says where the image went.
fn render_to_png(
    mut asset: Asset,
    ts: &[f32],
    lods: &[Lod],
    options: &SheetOptions,
    output: &Path,
    max_bytes: u64,
) -> Result<(), String> {
    let model =
        Arc::new(DeformingModel::with_budget(&asset, max_bytes).map_err(|e| e.to_string())?);
    // The model holds what the runtime needs of the sequences; the sheet reads the poses only.
    asset.release_frames();
    let asset = &asset;
    let context = Context::headless().map_err(|e| e.to_string())?;
    let adapter = context.adapter_info();
    let (sheet, cells) =
        render_sheet(&context, asset, &model, ts, lods, options).map_err(|e| e.to_string())?;
    save_png(&sheet, output).map_err(|e| e.to_string())?;
    println!(
        "rendered on {} ({:?}); columns t, rows LOD",
        adapter.name, adapter.backend
    );
    println!("      t    lod  frame  collapses  triangles  indices  idx/tri  uploaded");
    for c in &cells {
        let fraction = match c.lod {
            Lod::Fraction(f) => format!("{f:.2}"),
            other => format!("{other:?}"),
        };
        println!(
            "  {:5.2}  {:>5}  {:5}  {:9}  {:9}  {:7}  {:7.2}  {:6} B",
            c.t,
            fraction,
            c.frame,
            c.steps,
            c.triangles,
            c.indices,
            c.indices as f64 / c.triangles.max(1) as f64,
            c.upload_bytes
        );
    }
    println!("image written to {}", output.display());
    Ok(())
}
