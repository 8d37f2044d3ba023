//! The makehuman body morphing from its base shape to each of its 4 whole-body targets
//! (young man, old woman, baby, heavy muscular man), with continuous LOD; `n` cycles through
//! the targets.
//!
//! ```sh
//! cargo run --release --example body_morph               # window; headless without a display
//! cargo run --release --example body_morph -- --headless --frames 24
//! ```
//!
//! The assets are built on first use and cached in `out/body_morph/` (see `common`).

mod common;

use std::path::Path;
use std::process::ExitCode;

use clap::Parser;
use common::{CommonArgs, Demo, DemoError, TargetPoses};

const DEMO: Demo = Demo {
    name: "body_morph",
    sources: &[concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/makehuman_body.glb"
    )],
};

/// The makehuman body morphing to each of its whole-body targets, with continuous LOD.
#[derive(Parser, Debug)]
#[command(name = "body_morph")]
struct Args {
    #[command(flatten)]
    common: CommonArgs,
}

fn main() -> ExitCode {
    let args = Args::parse();
    common::exit_code(&DEMO, run(&args))
}

fn run(args: &Args) -> Result<(), DemoError> {
    let poses = TargetPoses::load(Path::new(DEMO.sources[0]))?;
    common::run(&DEMO, &args.common, poses.neutral_morphs()?)
}
