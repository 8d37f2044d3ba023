//! `morphlod supermesh` and the different-connectivity path of `morphlod build`: the
//! supermesh of two meshes with progress per stage, its report, and the glTF output.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::output::{check_output, command_inputs, Written};
use clap::Args;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use morphlod::asset::save_bytes;
use morphlod::io::gltf::write::GltfMorph;
use morphlod::io::{load_mesh, LoadOptions};
use morphlod::mesh::IndexedMesh;
use morphlod::metrics::hausdorff;
use morphlod::morph::supermesh::{
    fit_b_onto_a, parse_landmarks, Landmarks, Stage, Supermesh, SupermeshOptions, SupermeshReport,
};

#[derive(Args)]
pub struct SupermeshArgs {
    /// The mesh at t = 0 (closed, genus 0).
    pub a: PathBuf,
    /// The mesh at t = 1 (closed, genus 0).
    pub b: PathBuf,
    /// Landmark pairs: one `vertex_in_a vertex_in_b` a line (0-based file vertex order).
    #[arg(long, value_name = "PAIRS.txt")]
    pub landmarks: Option<PathBuf>,
    /// Fit B onto A first: turn, move and scale B by the similarity that best takes it onto A
    /// under the correspondence (the report's `placement` line), so the morph changes the
    /// shape alone. Without it V(1) is B bit for bit, as given.
    #[arg(long)]
    pub fit: bool,
    /// Without landmarks, keep the rotation search's alignment: do not pair the limb tips
    /// of A and B (the report's `limb tips` line; docs/DESIGN.md, "Alignment").
    #[arg(long)]
    pub no_tips: bool,
    /// Surface samples per mesh for the Hausdorff distances of the report.
    #[arg(long, default_value_t = 50_000)]
    pub samples: usize,
    /// The glTF binary file to write (.glb): base = V(0), one morph target = V(1) − V(0).
    #[arg(short, long, value_name = "OUT.glb")]
    pub output: PathBuf,
}

/// Reads and parses a landmarks file; errors name the file and the line.
pub fn read_landmarks(path: Option<&Path>) -> Result<Landmarks, String> {
    let Some(path) = path else {
        return Ok(Landmarks::default());
    };
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse_landmarks(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Builds the supermesh of `a` and `b` with a progress bar per stage (or a line per
/// finished stage when stderr is not a terminal). An error about a landmark pair names
/// its line in the landmarks file. `tips`: [`SupermeshOptions::tips`].
pub fn build_supermesh(
    a: &IndexedMesh,
    b: &IndexedMesh,
    landmarks: &Landmarks,
    tips: bool,
) -> Result<(Supermesh, SupermeshReport), String> {
    let terminal = std::io::stderr().is_terminal();
    let multi = MultiProgress::new();
    let bars: Vec<(Stage, ProgressBar)> = if terminal {
        Stage::ALL
            .iter()
            .map(|&stage| {
                let bar = multi.add(ProgressBar::new(1000));
                if let Ok(style) =
                    ProgressStyle::with_template("{prefix:>10} {bar:40} {percent:>3}% [{elapsed}]")
                {
                    bar.set_style(style);
                }
                bar.set_prefix(stage.name());
                (stage, bar)
            })
            .collect()
    } else {
        Vec::new()
    };
    // The embeddings report their end twice (their own loop and the stage): say it once.
    let done = std::sync::Mutex::new(Vec::new());
    let progress = |stage: Stage, fraction: f32| {
        if let Some((_, bar)) = bars.iter().find(|(s, _)| *s == stage) {
            bar.set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
            if fraction >= 1.0 {
                bar.finish();
            }
        } else if !terminal && fraction >= 1.0 {
            let mut done = done
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            if !done.contains(&stage) {
                done.push(stage);
                eprintln!("supermesh: {} done", stage.name());
            }
        }
    };
    let options = SupermeshOptions {
        landmarks: landmarks.pairs.clone(),
        progress: Some(&progress),
        tips,
        ..SupermeshOptions::default()
    };
    let built = Supermesh::build(a, b, &options);
    for (_, bar) in &bars {
        bar.finish_and_clear();
    }
    built.map_err(|e| landmarks.explain(&e))
}

/// The Hausdorff distance of the supermesh at t = 0 to A and at t = 1 to B, each as a
/// fraction of that mesh's bounding-box diagonal.
pub fn surface_errors(
    supermesh: &Supermesh,
    a: &IndexedMesh,
    b: &IndexedMesh,
    samples: usize,
) -> Result<String, String> {
    let mut out = String::new();
    for (name, pose, mesh) in [
        ("t = 0 to A", &supermesh.v0, a),
        ("t = 1 to B", &supermesh.v1, b),
    ] {
        let stats = hausdorff(
            pose,
            &supermesh.triangles,
            &mesh.positions,
            &mesh.triangles,
            samples,
        )
        .map_err(|e| e.to_string())?;
        let diagonal = diagonal(mesh);
        out += &format!(
            "  Hausdorff {name}  {:.3e} of the diagonal (RMS {:.3e}; {} + {} samples)\n",
            stats.hausdorff / diagonal,
            stats.rms / diagonal,
            stats.a_to_b.samples,
            stats.b_to_a.samples
        );
    }
    Ok(out)
}

fn diagonal(mesh: &IndexedMesh) -> f64 {
    mesh.bounds().map_or(1.0, |(lo, hi)| {
        let d: f64 = (0..3).map(|k| f64::from(hi[k] - lo[k]).powi(2)).sum();
        d.sqrt().max(f64::MIN_POSITIVE)
    })
}

/// A supermesh with fold-overs is not a bijection between the surfaces (a morphlod bug):
/// say so, the build goes on.
pub fn warn_fold_overs(report: &SupermeshReport) {
    if report.fold_overs > 0 {
        eprintln!(
            "warning: {} supermesh triangle(s) fold over on the sphere (should be 0; please report this with the meshes)",
            report.fold_overs
        );
    }
}

/// `morphlod supermesh A B -o S.glb`.
pub fn supermesh(args: &SupermeshArgs) -> Result<(), String> {
    let inputs = command_inputs([&args.a, &args.b], args.landmarks.as_deref());
    check_output(&args.output, Written::Glb, &inputs)?;
    let total = Instant::now();
    let landmarks = read_landmarks(args.landmarks.as_deref())?;
    let options = LoadOptions::default();
    let a = load_mesh(&args.a, &options).map_err(|e| e.to_string())?;
    let b = load_mesh(&args.b, &options).map_err(|e| e.to_string())?;
    let (mut supermesh, report) = build_supermesh(&a, &b, &landmarks, !args.no_tips)?;
    println!(
        "supermesh of {} and {}\n{report}",
        args.a.display(),
        args.b.display()
    );
    warn_fold_overs(&report);
    let measure = Instant::now();
    print!("{}", surface_errors(&supermesh, &a, &b, args.samples)?);
    println!(
        "  measure           {:.3} s",
        measure.elapsed().as_secs_f64()
    );

    if args.fit {
        // After the Hausdorff check, which compares V(1) with B as given.
        supermesh.v1 = fit_b_onto_a(&supermesh.triangles, &supermesh.v0, &supermesh.v1);
        println!(
            "  fit               B fitted onto A (--fit: V(1) is B turned, moved and scaled)\n{}",
            morphlod::morph::supermesh::measure(&supermesh.triangles, &supermesh.v0, &supermesh.v1)
        );
    }
    let write = Instant::now();
    let name = format!(
        "{} to {}",
        stem(&args.a).unwrap_or("A"),
        stem(&args.b).unwrap_or("B")
    );
    let gltf = GltfMorph::two_pose(
        &name,
        supermesh.triangles.clone(),
        &supermesh.v0,
        &supermesh.v1,
        1.0,
    );
    let bytes = gltf.to_glb().map_err(|e| e.to_string())?;
    save_bytes(&args.output, &bytes).map_err(|e| e.to_string())?;
    println!(
        "  write             {:.3} s ({} bytes)",
        write.elapsed().as_secs_f64(),
        bytes.len()
    );
    println!("  total             {:.3} s", total.elapsed().as_secs_f64());
    println!(
        "glTF written to {} (base = V(0), morph target = V(1) − V(0), animation 0 → 1 → 0 over 2 s)",
        args.output.display()
    );
    Ok(())
}

fn stem(path: &Path) -> Option<&str> {
    path.file_stem()?.to_str()
}
