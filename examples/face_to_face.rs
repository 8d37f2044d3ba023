//! FaceToFace: the makehuman head morphing from one facial expression to the next, with
//! continuous LOD (the deforming-mesh LodStrips paper's FaceToFace model).
//!
//! Morph `i` runs from expression `i` to expression `i + 1` (cyclically) of the head's 8
//! morph targets: `V(0)` = base + target A, `V(1)` = base + target B; `n` steps to the next
//! pair. `--neutral` morphs from the neutral face to each expression instead.
//!
//! ```sh
//! cargo run --release --example face_to_face              # window; headless without a display
//! cargo run --release --example face_to_face -- --headless --frames 24
//! ```
//!
//! The assets are built on first use and cached in `out/face_to_face/` (see `common`).

mod common;

use std::path::Path;
use std::process::ExitCode;

use clap::Parser;
use common::{CommonArgs, Demo, DemoError, NamedMorph, TargetPoses};

const DEMO: Demo = Demo {
    name: "face_to_face",
    sources: &[concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/makehuman_head.glb"
    )],
};

/// The makehuman head morphing between facial expressions, with continuous LOD.
#[derive(Parser, Debug)]
#[command(name = "face_to_face")]
struct Args {
    #[command(flatten)]
    common: CommonArgs,
    /// Morph from the neutral face to each expression instead of between expressions
    #[arg(long)]
    neutral: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    common::exit_code(&DEMO, run(&args))
}

fn run(args: &Args) -> Result<(), DemoError> {
    let poses = TargetPoses::load(Path::new(DEMO.sources[0]))?;
    let morphs = if args.neutral {
        poses.neutral_morphs()?
    } else {
        expression_pairs(&poses)?
    };
    common::run(&DEMO, &args.common, morphs)
}

/// Expression `i` → expression `i + 1`, wrapping around, so `n` walks through every target.
fn expression_pairs(poses: &TargetPoses) -> Result<Vec<NamedMorph>, DemoError> {
    let targets = &poses.targets;
    (0..targets.len())
        .map(|i| {
            let (a, pose_a) = &targets[i];
            let (b, pose_b) = &targets[(i + 1) % targets.len()];
            poses.morph(format!("{a}-to-{b}"), pose_a, pose_b)
        })
        .collect()
}
