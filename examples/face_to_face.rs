//! FaceToFace: the MakeHuman face, textured and smooth-shaded, morphing from the neutral face to
//! each of its 52 ARKit-style expressions, with continuous LOD (the deforming-mesh LodStrips
//! paper's FaceToFace model, on a real character asset: UV seams, normals, a skin texture).
//!
//! Morph `k` runs from the neutral face (`V(0)`) to expression `k` (`V(1)`), normals blended
//! with the expression's NORMAL deltas. `]` (or `n`) shows the next expression, `[` the
//! previous, `m` cycles textured / smooth / faceted; the readout names the expression.
//! `--pairs` morphs from each expression to the next instead.
//!
//! ```sh
//! cargo run --release --example face_to_face              # window; headless without a display
//! cargo run --release --example face_to_face -- --headless --frames 24
//! ```
//!
//! Each morph's asset is built the first time it is shown and cached in `out/face_to_face/`
//! (see `common`).

mod common;

use std::path::Path;
use std::process::ExitCode;

use clap::Parser;
use common::{CommonArgs, Demo, DemoError, TargetPoses};

const DEMO: Demo = Demo {
    name: "face_to_face",
    sources: &[concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/makehuman_face.glb"
    )],
};

/// The MakeHuman face morphing to its facial expressions, with continuous LOD.
#[derive(Parser, Debug)]
#[command(name = "face_to_face")]
struct Args {
    #[command(flatten)]
    common: CommonArgs,
    /// Morph from each expression to the next instead of from the neutral face
    #[arg(long)]
    pairs: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    common::exit_code(&DEMO, run(&args))
}

fn run(args: &Args) -> Result<(), DemoError> {
    let poses = TargetPoses::load(Path::new(DEMO.sources[0]))?;
    let morphs = if args.pairs {
        poses.pair_morphs()?
    } else {
        poses.neutral_morphs()?
    };
    common::run(&DEMO, &args.common, morphs)
}
