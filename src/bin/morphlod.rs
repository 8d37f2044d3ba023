//! The `morphlod` command line. Each subcommand is a thin shell over the
//! library: it parses arguments, calls the library, and prints typed errors
//! as messages (exit code 1) instead of panics or Debug dumps.

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use morphlod::asset::{inspect, save_bytes, MAGIC};
use morphlod::build::{BuildReport, Builder, Progress, DEFAULT_FRAMES};
use morphlod::io::{load_mesh, Format, LoadOptions};
use morphlod::mesh::clean::{clean, CleanOptions};
use morphlod::mesh::IndexedMesh;
use morphlod::morph::{Morph, MorphSource};
use morphlod::topology::analyze;
use std::io::{IsTerminal, Read};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "morphlod",
    version,
    about = "Continuous LOD triangle strips for morphing meshes"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print each file's contents: for a mesh its format, counts, cleaning
    /// summary and topology; for a .mlod asset its frames, LODs and section sizes.
    Info(InfoArgs),
    /// Build a .mlod asset: per-frame LOD collapse sequences over common strips.
    Build(BuildArgs),
}

#[derive(Args)]
struct BuildArgs {
    /// A glTF file with morph targets (with --target or --animation), or two
    /// mesh files with the same connectivity: V(0) and V(1).
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
    /// Sampled animation frames |r| (1 samples t = 0 only).
    #[arg(long, default_value_t = DEFAULT_FRAMES)]
    frames: usize,
    /// Merge vertices with identical V(0) positions. Only for files whose
    /// copies coincide in every pose: a copy that moves apart tears otherwise.
    #[arg(long)]
    weld: bool,
    /// The .mlod file to write.
    #[arg(short, long, value_name = "OUT.mlod")]
    output: PathBuf,
}

#[derive(Args)]
struct InfoArgs {
    /// Mesh files (.obj, .off, .ply, .gltf, .glb) or .mlod assets.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Merge vertices with identical positions before the topology report.
    #[arg(long)]
    weld: bool,
    /// glTF: the mesh to load, by name or index (default: the first).
    #[arg(long, value_name = "NAME|INDEX")]
    mesh: Option<String>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Info(args) => info(&args),
        Command::Build(args) => match build(&args) {
            Ok(()) => ExitCode::SUCCESS,
            Err(message) => {
                eprintln!("error: {message}");
                ExitCode::FAILURE
            }
        },
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
            asset_info(path)
        } else {
            info_one(path, &options, args.weld)
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
fn info_one(path: &Path, options: &LoadOptions, weld: bool) -> Result<String, String> {
    let mesh = load_mesh(path, options).map_err(|e| e.to_string())?;
    let cleaned =
        clean(&mesh, &CleanOptions { weld }).map_err(|e| format!("{}: {e}", path.display()))?;
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
    out += &format!("cleaning (weld {})\n", if weld { "on" } else { "off" });
    out += &format!("{}\n", cleaned.report);
    out += &format!("topology (after cleaning)\n{topology}\n");
    if Format::from_path(path) == Some(Format::Gltf) {
        let summary = morphlod::io::gltf::inspect(path).map_err(|e| e.to_string())?;
        out += &format!("glTF contents\n{summary}");
    }
    Ok(out)
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

fn asset_info(path: &Path) -> Result<String, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let start = Instant::now();
    let (_, info) = inspect(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
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
    let total = Instant::now();
    let options = LoadOptions {
        gltf_mesh: args.mesh.clone(),
        ..LoadOptions::default()
    };
    let morph = load_morph(args, &options)?;
    let load_time = total.elapsed();

    // Cleaning decisions (welds, dropped triangles) are taken on V(0) and
    // applied to every pose through `select`, so all poses keep one connectivity.
    let clean_start = Instant::now();
    let base = IndexedMesh::new(morph.v0(), morph.triangles().to_vec());
    let cleaned = clean(&base, &CleanOptions { weld: args.weld }).map_err(|e| e.to_string())?;
    let morph = morph
        .select(&cleaned.vertex_map, cleaned.mesh.triangles)
        .map_err(|e| e.to_string())?;
    let clean_time = clean_start.elapsed();
    println!(
        "cleaning (weld {})\n{}",
        if args.weld { "on" } else { "off" },
        cleaned.report
    );

    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(args.frames as u64);
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
    let built = Builder::new(&morph)
        .frames(args.frames)
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
            let a = load_mesh(a, options).map_err(|e| e.to_string())?;
            let b = load_mesh(b, options).map_err(|e| e.to_string())?;
            Morph::from_meshes(&a, &b).map_err(|e| e.to_string())
        }
        [path] => {
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
            if Format::from_path(path) != Some(Format::Gltf) {
                return Err(format!(
                    "{}: --target and --animation need a glTF file (.gltf, .glb); for other formats give two meshes",
                    path.display()
                ));
            }
            Morph::from_gltf(path, options, &source).map_err(|e| e.to_string())
        }
        _ => Err("give one glTF file or two meshes".into()),
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
