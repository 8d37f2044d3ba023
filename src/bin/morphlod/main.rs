//! The `morphlod` command line. Each subcommand is a thin shell over the
//! library: it parses arguments, calls the library, and prints typed errors
//! as messages (exit code 1) instead of panics or Debug dumps.
//!
//! One file a command (`info`, `build`, `supermesh`, `export`, `render`, `bench_command`,
//! `demo`), each with its arguments, over the shared `args` and `load` (and `output`); the
//! engines under them are `sheet`, `bench`, `bench_baselines` (with `baselines/`) and `plot`.

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

mod args;
mod baselines;
mod bench;
mod bench_baselines;
mod bench_command;
mod build;
mod demo;
mod export;
mod info;
mod load;
mod output;
mod plot;
mod render;
mod sheet;
mod supermesh;

use bench_command::{bench, BenchArgs};
use build::{build, BuildArgs};
use demo::{demo, DemoArgs};
use export::ExportArgs;
use info::{info, InfoArgs};
use render::{render, RenderArgs};
use supermesh::SupermeshArgs;

#[derive(Parser)]
#[command(
    name = "morphlod",
    version,
    about = "Continuous LOD triangle strips for morphing meshes"
)]
struct Cli {
    /// Without a subcommand, `demo` runs on the embedded default asset.
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Print each file's contents: for a mesh its format, counts, cleaning
    /// summary and topology; for a .mlod asset its frames, LODs and section sizes.
    Info(InfoArgs),
    /// Build a .mlod asset: per-frame LOD collapse sequences over common strips.
    Build(BuildArgs),
    /// The supermesh of two closed genus-0 meshes of different connectivity, written as
    /// glTF binary (base = A, one morph target to B, an animation 0 → 1 → 0), with its report.
    Supermesh(SupermeshArgs),
    /// The original and its LODs (one collapse sequence simplified over sampled poses) as one
    /// glTF binary: every LOD keeps all morph targets, attributes, the material and the weight
    /// animation; the chain is declared with MSFT_lod.
    Export(ExportArgs),
    /// Render a .mlod asset headless to a PNG: one cell per (t, lod), columns t, rows LOD.
    Render(RenderArgs),
    /// Frame-rate benchmark of a .mlod asset headless: linear and exponential LOD sweeps over
    /// the animation, drawn as LOD strips, as triangle lists of the same LOD, and at full detail.
    Bench(BenchArgs),
    /// The main job on the embedded default (makehuman_head.glb, jawOpen): build the
    /// per-frame LOD model, then render contact sheets headless to PNG files.
    Demo(DemoArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let done = match cli.command {
        Some(Command::Info(args)) => return info(&args),
        Some(Command::Build(args)) => build(&args),
        Some(Command::Supermesh(args)) => supermesh::supermesh(&args),
        Some(Command::Export(args)) => export::export(&args),
        Some(Command::Render(args)) => render(&args),
        Some(Command::Bench(args)) => bench(&args),
        Some(Command::Demo(args)) => demo(&args),
        None => demo(&DemoArgs {
            output: PathBuf::from("out"),
        }),
    };
    match done {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
