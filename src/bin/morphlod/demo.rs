//! `morphlod demo` (and `morphlod` alone): the embedded face built into a per-frame LOD
//! model, then drawn to two contact sheets.

use crate::build::stage_table;
use crate::load::clean_morph;
use crate::output::{check_folder, check_output, Written};
use crate::render::render_to_png;
use crate::sheet::SheetOptions;
use clap::Args;
use morphlod::asset::DEFAULT_MAX_BYTES;
use morphlod::build::Builder;
use morphlod::deform::Lod;
use morphlod::gpu::ShadeMode;
use morphlod::io::{LoadOptions, MorphSource};
use morphlod::mesh::clean::CleanOptions;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Args)]
pub(crate) struct DemoArgs {
    /// Where to write the contact sheets (PNG).
    #[arg(short, long, value_name = "DIR", default_value = "out")]
    pub(crate) output: PathBuf,
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

pub(crate) fn demo(args: &DemoArgs) -> Result<(), String> {
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
