//! The `morphlod` command line. Each subcommand is a thin shell over the
//! library: it parses arguments, calls the library, and prints typed errors
//! as messages (exit code 1) instead of panics or Debug dumps.

use clap::{Args, Parser, Subcommand};
use morphlod::io::{load_mesh, Format, LoadOptions};
use morphlod::mesh::clean::{clean, CleanOptions};
use morphlod::topology::analyze;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

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
    /// Print each mesh file's format, counts, cleaning summary and topology.
    Info(InfoArgs),
}

#[derive(Args)]
struct InfoArgs {
    /// Mesh files (.obj, .off, .ply, .gltf, .glb).
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
        match info_one(path, &options, args.weld) {
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
