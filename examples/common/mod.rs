//! What the demos (`face_to_face`, `body_morph`) share: the command line, the asset cache and
//! build, the scene (one `LodObject` per morph plus the text readout) drawn into a pass the
//! demo owns, the window loop (winit) and the headless frame sequence.
//!
//! A demo only says which morphs it shows (labels and poses); everything else is here, so the
//! two demos behave and look the same.
//!
//! The scene follows the library's caller-owned pattern: the demo owns the device, queue, the
//! surface (or an offscreen `RenderTarget`) and the render pass; `Scene::update` runs the CPU model
//! and uploads, `Scene::draw` records one multi-draw for the mesh and the text.
//!
//! * `cache` — each morph's `.mlod` file, built when first shown and missing, stale or damaged;
//! * `scene` — objects, view state, camera, readout text;
//! * `headless` — the PNG frame sequence; `window` — the winit window.

pub mod cache;
pub mod headless;
pub mod scene;
pub mod window;

use std::path::{Path, PathBuf};

use morphlod::io::LoadOptions;
use morphlod::io::{load_morph, MorphSource};
use morphlod::mesh::clean::{clean, CleanOptions};
use morphlod::morph::{MorphTarget, Weights};
use morphlod::{IndexedMesh, Morph};
use thiserror::Error;

use cache::Library;
use headless::run_headless;
use scene::Command;
use window::{run_window, WindowOutcome};

/// Background: the contact sheets' dark grey, which no lit surface colour matches.
pub const CLEAR: wgpu::Color = wgpu::Color {
    r: 0.08,
    g: 0.08,
    b: 0.1,
    a: 1.0,
};

/// Why a demo stopped.
#[derive(Debug, Error)]
pub enum DemoError {
    #[error(transparent)]
    Morphlod(#[from] morphlod::Error),
    /// A crowd refused a call (only the crowd demo makes one).
    #[error(transparent)]
    Crowd(#[from] morphlod::gpu::CrowdError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("--morph {index}: this demo has {count} morphs, numbered from 0")]
    NoSuchMorph { index: usize, count: usize },
    /// A supermesh build failed (man_to_camel; the other demos compile it unused).
    #[allow(dead_code)]
    #[error("{0}")]
    Supermesh(String),
    #[error("the window failed: {0}")]
    Window(String),
    #[error("drawing the readout text failed: {0}")]
    Text(String),
    #[error("the resident set grew by {growth_mb:.1} MB over frames {from}..{to} (--max-growth-mb {bound_mb}): memory is not bounded")]
    MemoryGrowth {
        growth_mb: f64,
        bound_mb: f64,
        from: u32,
        to: u32,
    },
}

impl DemoError {
    pub fn lib(error: impl Into<morphlod::Error>) -> DemoError {
        DemoError::Morphlod(error.into())
    }
}

/// Options every demo takes.
#[derive(clap::Args, Debug, Clone)]
pub struct CommonArgs {
    /// Render a frame sequence to numbered PNGs instead of opening a window (automatic when no
    /// window can be opened)
    #[arg(long)]
    pub headless: bool,
    /// Frames of the headless sequence: t sweeps 0 → 1 while the LOD coarsens
    #[arg(long, default_value_t = 24, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub frames: u32,
    /// Window or image size in pixels, WIDTHxHEIGHT
    #[arg(long, default_value = "1280x800", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Directory for the built assets and the headless frames [default: out/<demo>]
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Sampled animation frames |r| per built asset (part of the cache key)
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u16).range(2..=4096))]
    pub build_frames: u16,
    /// The morph to start with (headless: the one rendered), 0-based
    #[arg(long, default_value_t = 0)]
    pub morph: usize,
    /// Start with one colour per strip
    #[arg(long)]
    pub strips: bool,
    /// Headless: fail when the resident set grows by more than this many MB between the end of
    /// the first tenth of the frames (warm-up) and the last frame (Linux only)
    #[arg(long)]
    pub max_growth_mb: Option<f64>,
    /// Headless: keys pressed before the first frame, by the names the window knows them by,
    /// comma-separated (`],m`: the next morph, smooth shading); t and the LOD still follow the
    /// sweep
    #[arg(long, value_delimiter = ',', value_parser = parse_key)]
    pub keys: Vec<Command>,
}

fn parse_key(name: &str) -> Result<Command, String> {
    match Command::for_key(name) {
        Some(Command::Quit) | None => Err(format!(
            "'{name}' is not a key the demo acts on headless: give a character key (], [, n, m, s, l, r) \
             or ArrowLeft, ArrowRight, ArrowUp, ArrowDown, Space"
        )),
        Some(command) => Ok(command),
    }
}

pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let parsed = text
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if (16..=8192).contains(&w) && (16..=8192).contains(&h) => Ok((w, h)),
        _ => Err(format!(
            "'{text}' is not a size: give WIDTHxHEIGHT with each side 16 to 8192, e.g. 1280x800"
        )),
    }
}

/// A demo's fixed facts.
pub struct Demo {
    /// The example's name: output folder, messages.
    pub name: &'static str,
    /// The files the morphs come from (their content is part of every cache key).
    pub sources: &'static [&'static str],
}

/// One morph a demo can show: `V(0)` → `V(1)` over the source mesh's triangulation.
pub struct NamedMorph {
    /// Shown in the readout and part of the cache file's name.
    pub label: String,
    pub morph: MorphSpec,
}

/// A morph's poses, or how to make them when no cached asset holds them.
pub enum MorphSpec {
    /// Poses known up front: a cached asset is used only if it holds exactly them.
    Ready(Box<Morph>),
    /// Made only when the cache has no asset for it (a supermesh build takes seconds):
    /// `key` names every parameter of that build and is part of the cache key, together
    /// with the content of the demo's source files. (Only man_to_camel makes one.)
    #[allow(dead_code)]
    Deferred {
        key: String,
        make: Box<dyn Fn() -> Result<Morph, DemoError>>,
    },
}

/// The cleaned morph of a glTF file: its base mesh, vertex attributes and every morph target
/// (position and normal deltas), from which a demo makes its two-pose morphs.
pub struct TargetPoses {
    morph: Morph,
}

impl TargetPoses {
    /// Loads the first mesh of `path` with its targets and attributes, cleaned once on the base
    /// pose (the builder needs triangles without repeated corners) and applied to every target
    /// and attribute alike.
    pub fn load(path: &Path) -> Result<TargetPoses, DemoError> {
        let morph = load_morph(path, &LoadOptions::default(), &MorphSource::DefaultWeights)
            .map_err(DemoError::lib)?;
        let base = IndexedMesh::new(morph.base().to_vec(), morph.triangles().to_vec());
        let cleaned = clean(
            &base,
            &CleanOptions {
                weld: false,
                weld_soup: false,
            },
        )
        .map_err(DemoError::lib)?;
        let morph = morph
            .select(&cleaned.vertex_map, cleaned.mesh.triangles)
            .map_err(DemoError::lib)?;
        Ok(TargetPoses { morph })
    }

    /// A two-pose morph over the file's triangles and attributes: `V(0)` = base + target
    /// `from` (the base itself for `None`), `V(1)` = base + target `to`, with the targets'
    /// normal deltas, so the normals deform with the face.
    fn morph(&self, from: Option<usize>, to: usize) -> Result<NamedMorph, DemoError> {
        let targets = self.morph.targets();
        let name = |k: Option<usize>| k.map_or("neutral", |k| targets[k].name.as_str());
        let label = format!("{}-to-{}", name(from), name(Some(to)));
        let chosen: Vec<MorphTarget> = from
            .into_iter()
            .chain([to])
            .map(|k| targets[k].clone())
            .collect();
        // The last target goes from weight 0 to 1, a `from` target from 1 to 0.
        let n = chosen.len();
        let w0 = (0..n).map(|k| f32::from(u8::from(k + 1 < n))).collect();
        let w1 = (0..n).map(|k| f32::from(u8::from(k + 1 == n))).collect();
        let morph = Morph::from_parts(
            self.morph.triangles().to_vec(),
            self.morph.base().to_vec(),
            chosen,
            Weights::TwoPose { w0, w1 },
        )
        .and_then(|morph| morph.with_attributes(self.morph.attributes().clone()))
        .map_err(DemoError::lib)?;
        Ok(NamedMorph {
            label,
            morph: MorphSpec::Ready(Box::new(morph)),
        })
    }

    /// Neutral (the base mesh) → each target, in file order.
    pub fn neutral_morphs(&self) -> Result<Vec<NamedMorph>, DemoError> {
        (0..self.morph.targets().len())
            .map(|k| self.morph(None, k))
            .collect()
    }

    /// Target `i` → target `i + 1`, wrapping around, so stepping walks through every target.
    /// (Only face_to_face `--pairs` uses it; the other demos compile it unused.)
    #[allow(dead_code)]
    pub fn pair_morphs(&self) -> Result<Vec<NamedMorph>, DemoError> {
        let count = self.morph.targets().len();
        (0..count)
            .map(|i| self.morph(Some(i), (i + 1) % count))
            .collect()
    }
}

/// Runs a demo: opens a window, or renders headless when asked to or when no window can be
/// opened. Each morph's asset is loaded (built when not cached) when it is first shown, so a
/// demo of many morphs starts as fast as one of a single morph.
pub fn run(demo: &Demo, args: &CommonArgs, morphs: Vec<NamedMorph>) -> Result<(), DemoError> {
    if args.morph >= morphs.len() {
        return Err(DemoError::NoSuchMorph {
            index: args.morph,
            count: morphs.len(),
        });
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(demo.name));
    std::fs::create_dir_all(&out).map_err(|source| DemoError::Io {
        path: out.clone(),
        source,
    })?;
    let library = Library::new(demo.sources, &out, morphs, args.build_frames)?;
    if args.headless {
        return run_headless(demo, args, &library, &out);
    }
    match run_window(demo, args, &library)? {
        WindowOutcome::Closed => Ok(()),
        WindowOutcome::NoWindow(reason) => {
            println!(
                "{}: no window can be opened ({reason}); rendering headless instead",
                demo.name
            );
            run_headless(demo, args, &library, &out)
        }
    }
}

/// Prints the error and turns the result into the process's exit code (1 on error).
pub fn exit_code(demo: &Demo, result: Result<(), DemoError>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("{}: error: {error}", demo.name);
            std::process::ExitCode::FAILURE
        }
    }
}
