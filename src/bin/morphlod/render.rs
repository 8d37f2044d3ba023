//! `morphlod render`: a `.mlod` asset's (t, lod) grid drawn headless to one PNG contact
//! sheet ([`crate::sheet`]), with what each cell drew.

use crate::args::Colour;
use crate::load::{budget, read_asset};
use crate::output::{check_output, Written};
use crate::sheet::{render_sheet, SheetOptions};
use clap::Args;
use morphlod::asset::DEFAULT_MAX_BYTES;
use morphlod::deform::{DeformingModel, Lod};
use morphlod::gpu::{save_png, Context};
use morphlod::Asset;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Args)]
pub(crate) struct RenderArgs {
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

/// Renders one asset's (t, lod) grid to a PNG and prints what each cell drew.
pub(crate) fn render(args: &RenderArgs) -> Result<(), String> {
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

/// Renders headless (no window is opened: this works on machines without a display) and
/// says where the image went.
pub(crate) fn render_to_png(
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
