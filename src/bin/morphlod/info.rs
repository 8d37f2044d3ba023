//! `morphlod info`: each file's report, a mesh's (format, counts, cleaning, topology,
//! attributes, glTF contents) or a `.mlod` asset's.

use crate::build::ms;
use crate::load::{budget, clean_options, is_asset, load_surface, read_asset, weld_mode};
use clap::Args;
use morphlod::asset::{inspect_with, DEFAULT_MAX_BYTES};
use morphlod::io::{load_mesh, AttributeSummary, Format, LoadOptions};
use morphlod::mesh::clean::{clean, CleanOptions};
use morphlod::topology::analyze;
use morphlod::IndexedMesh;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Args)]
pub(crate) struct InfoArgs {
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

/// Reports every file, continuing past failures so one bad file in a batch
/// does not hide the others; the exit code says whether any failed.
pub(crate) fn info(args: &InfoArgs) -> ExitCode {
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
