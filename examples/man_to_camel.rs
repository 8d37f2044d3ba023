//! ManToCamel: a standing man morphing into a camel, with continuous LOD (the deforming-mesh
//! LodStrips paper's HorseToMan model, with the shared assets `man.off` → `camel.off`).
//!
//! The two meshes have different connectivity (17,495 and 9,770 vertices): the morph runs over
//! their supermesh (`morphlod::morph::supermesh`), one triangulation with a pose on each. The
//! man's file is z-up, the camel's y-up: the demo stands the man up (y is the viewer's up), so
//! the morph does not also rotate him through 90 degrees. The correspondence comes from the
//! shipped landmark pairs `assets/man_camel.landmarks` (a rotation changes no vertex index, so
//! they serve the stood-up man as well).
//!
//! ```sh
//! cargo run --release --example man_to_camel              # window; headless without a display
//! cargo run --release --example man_to_camel -- --headless --frames 24
//! cargo run --release --example man_to_camel -- --landmarks pairs.txt
//! cargo run --release --example man_to_camel -- --no-landmarks   # automatic correspondence
//! ```
//!
//! The asset (supermesh and per-frame LOD) is built on first use and cached in
//! `out/man_to_camel/` (see `common`); the cache key covers both files' content, the
//! supermesh options (seed, landmarks) and the LOD build parameters.

// The glTF-target helpers in `common` (TargetPoses, ready morphs) serve the other demos.
#[allow(dead_code)]
mod common;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use common::{CommonArgs, Demo, DemoError, MorphSpec, NamedMorph};
use morphlod::io::{load_mesh, LoadOptions};
use morphlod::morph::supermesh::{parse_landmarks, Landmarks, Supermesh, SupermeshOptions};
use morphlod::IndexedMesh;

const MAN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/man.off");
const CAMEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/camel.off");
/// The shipped landmark pairs man ↔ camel (head, hands → front feet, feet → hind feet, …).
const LANDMARKS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/man_camel.landmarks");

const DEMO: Demo = Demo {
    name: "man_to_camel",
    sources: &[MAN, CAMEL],
};

/// A man morphing into a camel over their supermesh, with continuous LOD.
#[derive(Parser, Debug)]
#[command(name = "man_to_camel")]
struct Args {
    #[command(flatten)]
    common: CommonArgs,
    /// Landmark pairs for the supermesh: one `vertex_in_man vertex_in_camel` a line
    /// (default: the shipped assets/man_camel.landmarks)
    #[arg(long, value_name = "PAIRS.txt", conflicts_with = "no_landmarks")]
    landmarks: Option<PathBuf>,
    /// The automatic correspondence, without landmark pairs
    #[arg(long)]
    no_landmarks: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    common::exit_code(&DEMO, run(&args))
}

fn run(args: &Args) -> Result<(), DemoError> {
    // The shipped pairs unless the user gives others or none.
    let path = match (&args.landmarks, args.no_landmarks) {
        (_, true) => None,
        (Some(path), false) => Some(path.clone()),
        (None, false) => Some(PathBuf::from(LANDMARKS)),
    };
    let landmarks = match &path {
        None => Landmarks::default(),
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|source| DemoError::Io {
                path: path.clone(),
                source,
            })?;
            parse_landmarks(&text)
                .map_err(|e| DemoError::Supermesh(format!("{}: {e}", path.display())))?
        }
    };
    let options = SupermeshOptions {
        landmarks: landmarks.pairs.clone(),
        ..SupermeshOptions::default()
    };
    // The algorithm's version and the options' Debug form (landmarks, seed, perturbation,
    // alignment) are the cache key: a reworked embedding must not reuse an old supermesh.
    let key = format!(
        "supermesh v{}; {options:?}; man stood up (x, z, -y)",
        morphlod::morph::supermesh::ALGORITHM_VERSION
    );
    let make = move || {
        let man = stand_up(
            load_mesh(Path::new(MAN), &LoadOptions::default())
                .map_err(|e| DemoError::Morphlod(e.into()))?,
        );
        let camel = load_mesh(Path::new(CAMEL), &LoadOptions::default())
            .map_err(|e| DemoError::Morphlod(e.into()))?;
        let start = Instant::now();
        let (supermesh, report) = Supermesh::build(&man, &camel, &options)
            .map_err(|e| DemoError::Supermesh(landmarks.explain(&e)))?;
        println!(
            "man_to_camel: supermesh built in {:.0} ms\n{report}",
            start.elapsed().as_secs_f64() * 1e3
        );
        supermesh
            .to_morph()
            .map_err(|e| DemoError::Morphlod(e.into()))
    };
    let morphs = vec![NamedMorph {
        label: "man-to-camel".into(),
        morph: MorphSpec::Deferred {
            key,
            make: Box::new(make),
        },
    }];
    common::run(&DEMO, &args.common, morphs)
}

/// The man's file is z-up: turn him y-up by a proper rotation about x (`(x, y, z)` →
/// `(x, z, −y)`), so triangles keep their winding.
fn stand_up(mut mesh: IndexedMesh) -> IndexedMesh {
    for p in &mut mesh.positions {
        *p = [p[0], p[2], -p[1]];
    }
    mesh
}
