//! `morphlod bench`: its arguments and the choice between the LOD sweeps ([`mod@crate::bench`]),
//! the LodStrips paper's baselines ([`crate::bench_baselines`]) and the crowd
//! ([`morphlod::gpu::run_crowd_bench`]), each with its summary, JSON and plot.

use crate::args::Colour;
use crate::bench::{run_bench, BenchOptions};
use crate::load::{budget, read_asset};
use crate::output::{check_output, Written};
use crate::{bench_baselines, plot};
use clap::Args;
use morphlod::asset::{AssetLoadOptions, DEFAULT_MAX_BYTES};
use morphlod::deform::DeformingModel;
use morphlod::gpu::{
    Context, CrowdScene, DiscreteChoice, DiscreteOptions, LevelsError, SharedSequence,
};
use morphlod::simplify::SimplifyOptions;
use morphlod::Asset;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

#[derive(Args)]
pub(crate) struct BenchArgs {
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
    /// Instead of the sweeps, a crowd of N instances (LOD by 1 px of screen error and full
    /// detail), each at its own phase; `--frames` frames per mode, 1920x1080 unless `--size`
    /// is given, `--json` writes the report.
    #[arg(long, value_name = "N")]
    crowd: Option<u32>,
    /// The crowd bench's scene: `grid` (seen whole from above, a fixed camera) or
    /// `walk-through` (the camera walks through the crowd at eye height: a few instances
    /// close up, a band in the middle, most far).
    #[arg(long, value_name = "SCENE", value_parser = ["grid", "walk-through"], default_value = "grid")]
    scene: String,
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
    /// The crowd bench's discrete levels below full detail: `auto` (by error, as gltfpack's
    /// `-si` chains: one level per halving of the error from what the scene's farthest
    /// instance may draw at 1 px down to what its nearest may), or triangle fractions in
    /// (0, 1), strictly decreasing (`morphlod export --lods`: 0.5,0.25,0.1 is its default).
    #[arg(long, value_name = "auto|F1,F2,...", default_value = "auto", value_parser = parse_levels)]
    levels: DiscreteChoice,
    /// The crowd bench's screen-space error, in pixels (its LOD and discrete modes).
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    pixels: f32,
    /// The crowd bench's LOD mode at this screen-space error instead (to compare it with the
    /// discrete mode at a drawn error no larger than the discrete mode's).
    #[arg(long, value_name = "PX")]
    lod_pixels: Option<f32>,
    /// Leave out the crowd bench's full-detail mode (slow with many instances on a software
    /// rasteriser).
    #[arg(long)]
    skip_full: bool,
}

/// Runs the frame-rate benchmark and prints its summary (and writes the rows as JSON).
pub(crate) fn bench(args: &BenchArgs) -> Result<(), String> {
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

/// `--levels`: `auto`, or fractions (checked when the levels are made).
fn parse_levels(text: &str) -> Result<DiscreteChoice, String> {
    if text == "auto" {
        return Ok(DiscreteChoice::ByError);
    }
    (text.split(','))
        .map(|f| f.trim().parse::<f32>().map_err(|e| format!("{f:?}: {e}")))
        .collect::<Result<Vec<f32>, String>>()
        .map(DiscreteChoice::Fractions)
}

/// The crowd bench's discrete mode: the shared sequence of `--levels-from` (checked to have
/// the benchmarked asset's vertices), else of the asset when it has one; `None` (with a
/// note) when it has per-frame sequences. Fractions are checked here.
fn discrete_levels(
    args: &BenchArgs,
    asset: &Asset,
    budget: &AssetLoadOptions,
) -> Result<Option<DiscreteOptions>, String> {
    let checked = |sequence: SharedSequence, at: &std::path::Path| {
        if let DiscreteChoice::Fractions(fractions) = &args.levels {
            sequence
                .levels(fractions)
                .map_err(|e| format!("{}: {e}", at.display()))?;
        }
        Ok(Some(DiscreteOptions {
            sequence,
            levels: args.levels.clone(),
        }))
    };
    let Some(path) = &args.levels_from else {
        return match SharedSequence::from_asset(asset) {
            Ok(sequence) => checked(sequence, &args.asset),
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
    let sequence = SharedSequence::from_asset(&source);
    checked(
        sequence.map_err(|e| format!("{}: {e}", path.display()))?,
        path,
    )
}

/// `bench --crowd N`: the crowd benchmark ([`morphlod::gpu::run_crowd_bench`]).
fn crowd_bench(
    args: &BenchArgs,
    instances: u32,
    context: &Context,
    asset: &Asset,
    model: Arc<DeformingModel>,
    discrete: Option<DiscreteOptions>,
) -> Result<(), String> {
    let size_given = args.size != 512;
    let options = morphlod::gpu::CrowdBenchOptions {
        instances,
        scene: match args.scene.as_str() {
            "walk-through" => CrowdScene::WalkThrough,
            _ => CrowdScene::Grid,
        },
        frames: args.frames,
        period: args.period,
        width: if size_given { args.size } else { 1920 },
        height: if size_given { args.size } else { 1080 },
        path: args.crowd_path.as_deref().map(|path| match path {
            "base-vertex" => morphlod::gpu::CrowdPath::BaseVertex,
            _ => morphlod::gpu::CrowdPath::FirstInstance,
        }),
        full_detail: !args.skip_full,
        pixels: args.pixels,
        lod_pixels: args.lod_pixels,
        discrete,
        records: morphlod::gpu::CrowdRecords {
            compact_share: args.compact_share,
            tail_triangles: args.tail_triangles,
        },
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
