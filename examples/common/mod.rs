//! What the demos (`face_to_face`, `body_morph`) share: the command line, the asset cache and
//! build, the scene (one [`LodObject`] per morph plus the text readout) drawn into a pass the
//! demo owns, the window loop (winit) and the headless frame sequence.
//!
//! A demo only says which morphs it shows (labels and poses); everything else is here, so the
//! two demos behave and look the same.
//!
//! The scene follows the library's caller-owned pattern: the demo owns the device, queue, the
//! surface (or an offscreen [`Target`]) and the render pass; [`Scene::update`] runs the CPU
//! model and uploads, [`Scene::draw`] records one multi-draw for the mesh and the text.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::{Mat4, Vec3};
use glyphon::{
    Attrs, Buffer, Cache, Color, ColorMode, Family, FontSystem, Metrics, Resolution, Shaping,
    SwashCache, TextArea, TextAtlas, TextBounds, TextRenderer, Viewport,
};
use indicatif::{ProgressBar, ProgressStyle};
use morphlod::build::Progress;
use morphlod::gpu::bench::Sweep;
use morphlod::gpu::{save_png, Context, LodObject, MorphPipeline, ShadeMode, Target, Upload};
use morphlod::io::LoadOptions;
use morphlod::mesh::clean::{clean, CleanOptions};
use morphlod::morph::MorphSource;
use morphlod::simplify::SimplifyOptions;
use morphlod::{Asset, Builder, DeformingModel, IndexedMesh, Lod, Morph};
use thiserror::Error;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// The one font of the readout, compiled in: CI machines and containers have no system fonts.
const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSansMono.ttf");
const FONT_FAMILY: &str = "DejaVu Sans Mono";
/// Readout font size and line height, in physical pixels.
const FONT_SIZE: f32 = 15.0;
const LINE_HEIGHT: f32 = 19.0;

/// Background: the contact sheets' dark grey, which no lit surface colour matches.
const CLEAR: wgpu::Color = wgpu::Color {
    r: 0.08,
    g: 0.08,
    b: 0.1,
    a: 1.0,
};
const SKIN: [f32; 4] = [0.85, 0.62, 0.5, 1.0];
const AMBIENT: f32 = 0.25;
const FOV_Y: f32 = 30.0 * std::f32::consts::PI / 180.0;
/// Seconds from one pose to the other while playing (then back: t ping-pongs).
const MORPH_SECONDS: f32 = 2.0;
/// The coarsest LOD fraction the headless sweep reaches: at 1.0 a mesh simplified "to the end"
/// has almost nothing left to look at.
const HEADLESS_COARSEST: f32 = 0.97;

/// Why a demo stopped.
#[derive(Debug, Error)]
pub enum DemoError {
    #[error(transparent)]
    Morphlod(#[from] morphlod::Error),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("--morph {index}: this demo has {count} morphs, numbered from 0")]
    NoSuchMorph { index: usize, count: usize },
    #[error("the window failed: {0}")]
    Window(String),
    #[error("drawing the readout text failed: {0}")]
    Text(String),
}

impl DemoError {
    fn lib(error: impl Into<morphlod::Error>) -> DemoError {
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
}

fn parse_size(text: &str) -> Result<(u32, u32), String> {
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
    /// The glTF file the morphs come from.
    pub source: &'static str,
}

/// One morph a demo can show: `V(0)` → `V(1)` over the source mesh's triangulation.
pub struct NamedMorph {
    /// Shown in the readout and part of the cache file's name.
    pub label: String,
    pub morph: Morph,
}

/// The cleaned base mesh of a glTF file and every target as a whole pose (base + deltas).
pub struct TargetPoses {
    pub triangles: Vec<[u32; 3]>,
    pub base: Vec<[f32; 3]>,
    /// (name, pose) per morph target, in file order.
    pub targets: Vec<(String, Vec<[f32; 3]>)>,
}

impl TargetPoses {
    /// Loads every morph target of the first mesh of `path`, cleaned once on the base pose
    /// (the builder needs triangles without repeated corners) and applied to all poses alike.
    pub fn load(path: &Path) -> Result<TargetPoses, DemoError> {
        let morph = Morph::from_gltf(path, &LoadOptions::default(), &MorphSource::DefaultWeights)
            .map_err(DemoError::lib)?;
        let base = IndexedMesh::new(morph.base().to_vec(), morph.triangles().to_vec());
        let cleaned = clean(&base, &CleanOptions { weld: false }).map_err(DemoError::lib)?;
        let morph = morph
            .select(&cleaned.vertex_map, cleaned.mesh.triangles)
            .map_err(DemoError::lib)?;
        let targets = morph
            .targets()
            .iter()
            .map(|target| {
                let pose = morph
                    .base()
                    .iter()
                    .zip(&target.deltas)
                    .map(|(p, d)| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
                    .collect();
                (target.name.clone(), pose)
            })
            .collect();
        Ok(TargetPoses {
            triangles: morph.triangles().to_vec(),
            base: morph.base().to_vec(),
            targets,
        })
    }

    /// `V(0)` = `a`, `V(1)` = `b`, labelled `label`.
    pub fn morph(
        &self,
        label: String,
        a: &[[f32; 3]],
        b: &[[f32; 3]],
    ) -> Result<NamedMorph, DemoError> {
        let morph = Morph::from_poses(self.triangles.clone(), a.to_vec(), b.to_vec())
            .map_err(DemoError::lib)?;
        Ok(NamedMorph { label, morph })
    }

    /// Neutral (the base mesh) → each target, in file order.
    pub fn neutral_morphs(&self) -> Result<Vec<NamedMorph>, DemoError> {
        self.targets
            .iter()
            .map(|(name, pose)| self.morph(format!("neutral-to-{name}"), &self.base, pose))
            .collect()
    }
}

/// Runs a demo: builds (or loads) its assets, then opens a window, or renders headless when
/// asked to or when no window can be opened.
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
    let assets = load_or_build_all(Path::new(demo.source), &out, &morphs, args.build_frames)?;
    if args.headless {
        return run_headless(demo, args, &assets, &out);
    }
    match run_window(demo, args, &assets)? {
        WindowOutcome::Closed => Ok(()),
        WindowOutcome::NoWindow(reason) => {
            println!(
                "{}: no window can be opened ({reason}); rendering headless instead",
                demo.name
            );
            run_headless(demo, args, &assets, &out)
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

// ---------------------------------------------------------------------------------------------
// Asset cache

/// A built morph, ready for the GPU.
pub struct BuiltMorph {
    pub label: String,
    pub asset: Asset,
    pub model: Arc<DeformingModel>,
}

fn load_or_build_all(
    source: &Path,
    out: &Path,
    morphs: &[NamedMorph],
    frames: u16,
) -> Result<Vec<BuiltMorph>, DemoError> {
    let bytes = std::fs::read(source).map_err(|source_error| DemoError::Io {
        path: source.to_path_buf(),
        source: source_error,
    })?;
    // The content, not the path or the modification time: an edited or replaced source file
    // gets new assets, an untouched checkout elsewhere reuses them.
    let source_hash = crc32fast::hash(&bytes);
    let mut built = Vec::with_capacity(morphs.len());
    for (i, named) in morphs.iter().enumerate() {
        let path = out.join(cache_name(&named.label, source_hash, frames));
        let asset = load_or_build(named, &path, frames, (i + 1, morphs.len()))?;
        let model = Arc::new(DeformingModel::new(&asset).map_err(DemoError::lib)?);
        built.push(BuiltMorph {
            label: named.label.clone(),
            asset,
            model,
        });
    }
    Ok(built)
}

/// The cache file of one morph: label, frame count, and a hash of the source file's content
/// together with every build parameter and the program that builds, so any change to them
/// names another file.
fn cache_name(label: &str, source_hash: u32, frames: u16) -> String {
    // Target names come from the file: keep the name to characters every file system takes
    // (the hash below still covers the exact label).
    let safe: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    // The simplifier and stripifier can change without a version bump (and do, while the
    // library is developed): the executable's size and modification time stand for the code
    // that built the asset, so a rebuilt demo rebuilds its assets (about a second each).
    let program = std::env::current_exe()
        .and_then(std::fs::metadata)
        .map(|m| format!("{} bytes, modified {:?}", m.len(), m.modified().ok()))
        .unwrap_or_default();
    let parameters = format!(
        "source {source_hash:08x}; label {label}; frames {frames}; simplify {:?}; \
         morphlod {} (file format {}, program {program})",
        SimplifyOptions::default(),
        env!("CARGO_PKG_VERSION"),
        morphlod::asset::VERSION,
    );
    format!(
        "{safe}.f{frames}.{source_hash:08x}{:08x}.mlod",
        crc32fast::hash(parameters.as_bytes())
    )
}

fn load_or_build(
    named: &NamedMorph,
    path: &Path,
    frames: u16,
    (number, count): (usize, usize),
) -> Result<Asset, DemoError> {
    if path.exists() {
        // A cached file is used only if it loads (checksums, structure) and holds exactly the
        // poses this morph has; anything else is rebuilt and overwritten.
        match Asset::load(path) {
            Ok(asset) if matches_morph(&asset, &named.morph, frames) => {
                println!(
                    "[{number}/{count}] {}: cached {}",
                    named.label,
                    path.display()
                );
                return Ok(asset);
            }
            Ok(_) => println!(
                "[{number}/{count}] {}: {} holds another morph; rebuilding",
                named.label,
                path.display()
            ),
            Err(error) => println!(
                "[{number}/{count}] {}: cached file does not load ({error}); rebuilding",
                named.label
            ),
        }
    }
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(u64::from(frames));
        if let Ok(style) =
            ProgressStyle::with_template("{msg} {bar:32} {pos}/{len} frames [{elapsed_precise}]")
        {
            bar.set_style(style);
        }
        bar.set_message(format!("[{number}/{count}] building {}", named.label));
        bar
    });
    let progress = |p: Progress| {
        if let Some(bar) = &bar {
            bar.set_position(p.frames_done as u64);
        }
    };
    let start = Instant::now();
    let built = Builder::new(&named.morph)
        .frames(usize::from(frames))
        .progress(&progress)
        .build();
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let (asset, report) = built.map_err(DemoError::lib)?;
    asset.save(path).map_err(DemoError::lib)?;
    println!(
        "[{number}/{count}] {}: built {} frames ({} triangles, {} strips) in {:.1} s on {} threads -> {}",
        named.label,
        frames,
        report.triangles,
        report.strips,
        start.elapsed().as_secs_f64(),
        report.threads,
        path.display()
    );
    Ok(asset)
}

fn matches_morph(asset: &Asset, morph: &Morph, frames: u16) -> bool {
    asset.frames.len() == usize::from(frames) && asset.v0 == morph.v0() && asset.v1 == morph.v1()
}

// ---------------------------------------------------------------------------------------------
// The scene: what is shown and how it is controlled

/// How the LOD is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
enum LodControl {
    /// The paper's parameter: 0 = full detail, 1 = coarsest.
    Fraction(f32),
    /// Screen-space error bound in pixels, turned into an object-space bound at the camera's
    /// distance ([`Lod::screen_error`]).
    Pixels(f32),
}

/// The user-controlled view state, shared by the window and the headless sweep.
struct View {
    t: f32,
    /// +1 or -1: the direction t moves while playing.
    direction: f32,
    playing: bool,
    lod: LodControl,
    strips: bool,
    yaw: f32,
    pitch: f32,
    /// Camera distance relative to the distance that frames the object.
    zoom: f32,
}

impl View {
    fn new(strips: bool) -> View {
        // The contact sheets' view direction (-0.35, -0.15, -1), as orbit angles.
        View {
            t: 0.0,
            direction: 1.0,
            playing: true,
            lod: LodControl::Fraction(0.0),
            strips,
            yaw: 0.35f32.atan2(1.0),
            pitch: (0.15f32 / (0.35f32 * 0.35 + 0.15 * 0.15 + 1.0).sqrt()).asin(),
            zoom: 1.0,
        }
    }

    fn advance(&mut self, seconds: f32) {
        if !self.playing {
            return;
        }
        self.t += self.direction * seconds / MORPH_SECONDS;
        if self.t >= 1.0 {
            self.t = 1.0;
            self.direction = -1.0;
        } else if self.t <= 0.0 {
            self.t = 0.0;
            self.direction = 1.0;
        }
    }

    fn step_t(&mut self, delta: f32) {
        self.playing = false;
        self.t = (self.t + delta).clamp(0.0, 1.0);
    }

    /// Coarser (`coarser` = true) or finer by one step of the current LOD control.
    fn step_lod(&mut self, coarser: bool) {
        self.lod = match self.lod {
            LodControl::Fraction(f) => {
                let step = if coarser { 0.05 } else { -0.05 };
                LodControl::Fraction((f + step).clamp(0.0, 1.0))
            }
            LodControl::Pixels(p) => {
                let factor = if coarser { 1.5 } else { 1.0 / 1.5 };
                LodControl::Pixels((p * factor).clamp(0.05, 500.0))
            }
        };
    }

    fn toggle_lod_control(&mut self) {
        self.lod = match self.lod {
            LodControl::Fraction(_) => LodControl::Pixels(1.0),
            LodControl::Pixels(_) => LodControl::Fraction(0.0),
        };
    }
}

/// A camera orbiting the morph's bounding sphere.
struct Orbit {
    view_proj: Mat4,
    eye_direction: Vec3,
    distance: f32,
}

fn orbit(centre: Vec3, radius: f32, view: &View, aspect: f32) -> Orbit {
    let d = Vec3::new(
        view.pitch.cos() * view.yaw.sin(),
        view.pitch.sin(),
        view.pitch.cos() * view.yaw.cos(),
    );
    // The sphere fits when its radius subtends at most the narrower half-angle of the view.
    let half_y = FOV_Y * 0.5;
    let half_x = (half_y.tan() * aspect).atan();
    let distance = radius / half_y.min(half_x).sin() * view.zoom;
    let near = (distance - radius * 1.05).max(distance * 1e-2);
    let far = distance + radius * 1.05;
    let eye = centre + d * distance;
    let view_matrix = glam::camera::rh::view::look_at_mat4(eye, centre, Vec3::Y);
    let proj = glam::camera::rh::proj::directx::perspective(FOV_Y, aspect, near, far);
    Orbit {
        view_proj: proj * view_matrix,
        eye_direction: d,
        distance,
    }
}

/// What one frame did, for the readout.
#[derive(Clone, Debug, Default)]
struct FrameStats {
    /// CPU time of `set` + `prepare`.
    cpu: Duration,
    upload: Upload,
    draw_calls: u64,
}

/// One object per morph (all on the GPU, sharing one pipeline, so switching is instant), the
/// view state and the readout.
struct Scene {
    objects: Vec<SceneObject>,
    current: usize,
    view: View,
    readout: Readout,
    /// Whether the device can colour strips (`INDIRECT_FIRST_INSTANCE`).
    strip_colours: bool,
    adapter: String,
    last: FrameStats,
    /// Whether the readout lists the keys (the window) or not (headless frames).
    show_keys: bool,
    /// The window's scale factor: the readout keeps its size in logical pixels.
    text_scale: f32,
}

/// The readout's key help, under the figures.
const KEYS: &str =
    "\nkeys  <-/-> t  space play/pause  up/down LOD finer/coarser  l fraction/pixels\n      \
                    s strip colours  n next morph  drag orbit  wheel zoom  r reset view  q quit";

struct SceneObject {
    label: String,
    object: LodObject,
    centre: Vec3,
    radius: f32,
}

impl Scene {
    fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        adapter: &wgpu::AdapterInfo,
        color_format: wgpu::TextureFormat,
        morphs: &[BuiltMorph],
        args: &CommonArgs,
    ) -> Result<Scene, DemoError> {
        let pipeline = MorphPipeline::new(device, color_format, Some(Target::DEPTH_FORMAT));
        let mut objects = Vec::with_capacity(morphs.len());
        for built in morphs {
            let mut object =
                LodObject::new(device, &pipeline, &built.asset, Arc::clone(&built.model))
                    .map_err(DemoError::lib)?;
            object.set_color(SKIN);
            let both: Vec<[f32; 3]> = built
                .asset
                .v0
                .iter()
                .chain(&built.asset.v1)
                .copied()
                .collect();
            // Built assets have vertices; an empty one would have failed DeformingModel::new.
            let (min, max) = morphlod::mesh::bounds(&both).unwrap_or(([0.0; 3], [0.0; 3]));
            let (min, max) = (Vec3::from(min), Vec3::from(max));
            let radius = ((max - min).length() * 0.5).max(1e-6);
            objects.push(SceneObject {
                label: built.label.clone(),
                object,
                centre: (min + max) * 0.5,
                radius,
            });
        }
        Ok(Scene {
            objects,
            current: args.morph,
            view: View::new(args.strips),
            readout: Readout::new(device, queue, color_format),
            strip_colours: device
                .features()
                .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE),
            adapter: format!("{} ({:?})", adapter.name, adapter.backend),
            last: FrameStats::default(),
            show_keys: true,
            text_scale: 1.0,
        })
    }

    /// Moves the current object to the view's `(t, LOD)`, uploads what changed and lays out
    /// the readout for a `width` x `height` frame. `status` is the first readout line.
    fn update(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (width, height): (u32, u32),
        status: &str,
    ) -> Result<(), DemoError> {
        let view = &self.view;
        let Some(current) = self.objects.get_mut(self.current) else {
            return Ok(());
        };
        let camera = orbit(
            current.centre,
            current.radius,
            view,
            width as f32 / height.max(1) as f32,
        );
        let lod = match view.lod {
            LodControl::Fraction(f) => Lod::Fraction(f),
            LodControl::Pixels(p) => Lod::screen_error(p, camera.distance, FOV_Y, height as f32),
        };
        let object = &mut current.object;
        let start = Instant::now();
        object.set(view.t, lod).map_err(DemoError::lib)?;
        object.set_view_proj(camera.view_proj);
        object
            .set_light(camera.eye_direction + Vec3::Y * 0.5, AMBIENT)
            .map_err(DemoError::lib)?;
        object.set_shade_mode(if view.strips {
            ShadeMode::StripColours
        } else {
            ShadeMode::BaseColour
        });
        let upload = object.prepare(queue);
        let cpu = start.elapsed();
        self.last = FrameStats {
            cpu,
            upload,
            draw_calls: self.last.draw_calls,
        };
        let text = self.readout_text(status, lod);
        self.readout
            .prepare(device, queue, (width, height), self.text_scale, &text)
    }

    /// Records the current object (one multi-draw) and the readout into `pass`, whose
    /// attachments have the formats the scene was made for.
    fn draw(&mut self, pass: &mut wgpu::RenderPass<'_>) -> Result<(), DemoError> {
        if let Some(current) = self.objects.get_mut(self.current) {
            let before = current.object.object().draw_calls();
            current.object.render(pass);
            self.last.draw_calls = current.object.object().draw_calls() - before;
        }
        self.readout.draw(pass)
    }

    fn readout_text(&self, status: &str, lod: Lod) -> String {
        let Some(current) = self.objects.get(self.current) else {
            return status.to_string();
        };
        let state = current.object.state();
        let model = current.object.model();
        let frame = state.frame();
        let max_steps = model.resolve(frame, Lod::Fraction(1.0)).unwrap_or(0);
        let lod_line = match (self.view.lod, lod) {
            (LodControl::Pixels(p), Lod::MaxError(e)) => {
                format!("LOD   screen error {p:.2} px = {e:.2e} units")
            }
            (LodControl::Fraction(f), _) | (LodControl::Pixels(f), _) => {
                format!("LOD   fraction {f:.2}")
            }
        };
        let triangles = state.triangle_count();
        let indices = state.index_count();
        let upload = &self.last.upload;
        let shading = match (self.view.strips, self.strip_colours) {
            (false, _) => "base colour",
            (true, true) => "one colour per strip",
            (true, false) => "strips (this device lacks INDIRECT_FIRST_INSTANCE: one colour)",
        };
        format!(
            "{status}\n\
             morph {}/{}: {}\n\
             t     {:.3} {}   sampled frame k = {} of {}\n\
             {lod_line}   -> {} of {} collapses\n\
             drawn {} triangles, {} indices ({:.2} per triangle), {} mesh draw call(s)\n\
             upload {} B this frame (index+indirect {} B, uniforms {} B), set+prepare {:.3} ms\n\
             shade {shading}   adapter {}{}",
            self.current + 1,
            self.objects.len(),
            current.label,
            self.view.t,
            if self.view.playing {
                "playing"
            } else {
                "paused "
            },
            frame,
            model.frame_count(),
            state.lod(),
            max_steps,
            triangles,
            indices,
            indices as f64 / triangles.max(1) as f64,
            self.last.draw_calls,
            upload.bytes(),
            upload.geometry_bytes(),
            upload.uniform_bytes,
            self.last.cpu.as_secs_f64() * 1e3,
            self.adapter,
            if self.show_keys { KEYS } else { "" },
        )
    }

    fn next_morph(&mut self) {
        self.current = (self.current + 1) % self.objects.len().max(1);
    }
}

// ---------------------------------------------------------------------------------------------
// Readout text (glyphon)

/// The on-screen text: glyphon's atlas and renderer with the embedded font only.
struct Readout {
    font_system: FontSystem,
    swash_cache: SwashCache,
    viewport: Viewport,
    atlas: TextAtlas,
    renderer: TextRenderer,
    buffer: Buffer,
}

impl Readout {
    fn new(device: &wgpu::Device, queue: &wgpu::Queue, format: wgpu::TextureFormat) -> Readout {
        let mut db = glyphon::fontdb::Database::new();
        db.load_font_data(FONT.to_vec());
        // No system fonts are loaded: the text looks the same everywhere, and works where none
        // are installed.
        let mut font_system = FontSystem::new_with_locale_and_db("en-US".to_string(), db);
        let cache = Cache::new(device);
        let viewport = Viewport::new(device, &cache);
        // Web mode stores glyph colours as given: right for the linear (non-sRGB) formats the
        // demos draw into, where the mesh's shader output is also stored as is.
        let color_mode = if format.is_srgb() {
            ColorMode::Accurate
        } else {
            ColorMode::Web
        };
        let mut atlas = TextAtlas::with_color_mode(device, queue, &cache, format, color_mode);
        // The text is drawn in the mesh's pass, which has a depth buffer: the text pipeline
        // must declare it, and neither tests nor writes depth so it stays on top.
        let depth = wgpu::DepthStencilState {
            format: Target::DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::Always),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        };
        let renderer = TextRenderer::new(
            &mut atlas,
            device,
            wgpu::MultisampleState::default(),
            Some(depth),
        );
        let buffer = Buffer::new(&mut font_system, Metrics::new(FONT_SIZE, LINE_HEIGHT));
        Readout {
            font_system,
            swash_cache: SwashCache::new(),
            viewport,
            atlas,
            renderer,
            buffer,
        }
    }

    fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (width, height): (u32, u32),
        scale: f32,
        text: &str,
    ) -> Result<(), DemoError> {
        self.viewport.update(queue, Resolution { width, height });
        self.buffer
            .set_size(Some(width as f32 / scale), Some(height as f32 / scale));
        self.buffer.set_text(
            text,
            &Attrs::new().family(Family::Name(FONT_FAMILY)),
            Shaping::Basic,
            None,
        );
        self.buffer.shape_until_scroll(&mut self.font_system, false);
        let bounds = TextBounds {
            left: 0,
            top: 0,
            right: width as i32,
            bottom: height as i32,
        };
        let area = |offset: f32, color: Color| TextArea {
            buffer: &self.buffer,
            left: (10.0 + offset) * scale,
            top: (8.0 + offset) * scale,
            scale,
            bounds,
            default_color: color,
            custom_glyphs: &[],
        };
        // A dark copy one pixel down-right under the light text keeps it readable over the mesh.
        self.renderer
            .prepare(
                device,
                queue,
                &mut self.font_system,
                &mut self.atlas,
                &self.viewport,
                [
                    area(1.0, Color::rgb(0, 0, 0)),
                    area(0.0, Color::rgb(235, 235, 235)),
                ],
                &mut self.swash_cache,
            )
            .map_err(|e| DemoError::Text(e.to_string()))
    }

    fn draw(&mut self, pass: &mut wgpu::RenderPass<'_>) -> Result<(), DemoError> {
        self.renderer
            .render(&self.atlas, &self.viewport, pass)
            .map_err(|e| DemoError::Text(e.to_string()))?;
        self.atlas.trim();
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Headless: a frame sequence into numbered PNGs

fn run_headless(
    demo: &Demo,
    args: &CommonArgs,
    morphs: &[BuiltMorph],
    out: &Path,
) -> Result<(), DemoError> {
    let context = Context::headless().map_err(DemoError::lib)?;
    let info = context.adapter_info();
    let (width, height) = args.size;
    let device = &context.device;
    let queue = &context.queue;
    let target = Target::new(device, width, height, CLEAR).map_err(DemoError::lib)?;
    let mut scene = Scene::new(device, queue, &info, Target::COLOR_FORMAT, morphs, args)?;
    scene.view.playing = false;
    scene.show_keys = false;
    let frames = args.frames;
    println!(
        "{}: rendering {frames} frames of '{}' headless on {} ({:?}), {width}x{height}",
        demo.name, morphs[args.morph].label, info.name, info.backend
    );
    remove_old_frames(out)?;
    let mut first = None;
    let mut last = PathBuf::new();
    for i in 0..frames {
        // The bench's linear sweep: t runs 0 → 1 while the LOD coarsens with it.
        let x = if frames > 1 {
            i as f32 / (frames - 1) as f32
        } else {
            0.0
        };
        scene.view.t = x;
        scene.view.lod = LodControl::Fraction(HEADLESS_COARSEST * Sweep::Linear.fraction(x));
        let status = format!("{}  headless frame {}/{frames}", demo.name, i + 1);
        let start = Instant::now();
        scene.update(device, queue, (width, height), &status)?;
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = target.begin_pass(&mut encoder);
            scene.draw(&mut pass)?;
        }
        queue.submit([encoder.finish()]);
        let image = target.read_image(device, queue).map_err(DemoError::lib)?;
        let path = out.join(format!("frame_{i:04}.png"));
        save_png(&image, &path).map_err(DemoError::lib)?;
        let state = scene.objects[scene.current].object.state();
        println!(
            "  {} t {:.3} k {:2} lod {:5} triangles {:6} indices {:6} uploaded {:7} B  {:.1} ms",
            path.display(),
            x,
            state.frame(),
            state.lod(),
            state.triangle_count(),
            state.index_count(),
            scene.last.upload.bytes(),
            start.elapsed().as_secs_f64() * 1e3
        );
        first.get_or_insert_with(|| path.clone());
        last = path;
    }
    if let Some(first) = first {
        println!(
            "{}: {frames} frames written: {} .. {}",
            demo.name,
            first.display(),
            last.display()
        );
    }
    Ok(())
}

/// Deletes the `frame_NNNN.png` files of an earlier run, so a shorter sequence does not leave
/// a longer one's tail behind it. Nothing else in `out` is touched.
fn remove_old_frames(out: &Path) -> Result<(), DemoError> {
    let io = |source| DemoError::Io {
        path: out.to_path_buf(),
        source,
    };
    for entry in std::fs::read_dir(out).map_err(io)? {
        let path = entry.map_err(io)?.path();
        let is_frame = path
            .file_name()
            .and_then(|name| name.to_str())
            .and_then(|name| name.strip_prefix("frame_")?.strip_suffix(".png"))
            .is_some_and(|number| number.len() == 4 && number.bytes().all(|b| b.is_ascii_digit()));
        if is_frame {
            std::fs::remove_file(&path).map_err(|source| DemoError::Io { path, source })?;
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// The window

enum WindowOutcome {
    /// The user closed the window.
    Closed,
    /// No window could be opened (no display, no surface, no event loop): why.
    NoWindow(String),
}

fn run_window(
    demo: &Demo,
    args: &CommonArgs,
    morphs: &[BuiltMorph],
) -> Result<WindowOutcome, DemoError> {
    // winit would say the same, prefixed with its source location; this reads better.
    if cfg!(all(
        unix,
        not(target_os = "macos"),
        not(target_os = "android")
    )) && ["DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"]
        .iter()
        .all(|name| std::env::var_os(name).is_none_or(|value| value.is_empty()))
    {
        return Ok(WindowOutcome::NoWindow(
            "DISPLAY and WAYLAND_DISPLAY are not set".into(),
        ));
    }
    let event_loop = match EventLoop::new() {
        Ok(event_loop) => event_loop,
        Err(error) => return Ok(WindowOutcome::NoWindow(error.to_string())),
    };
    let mut app = App {
        demo,
        args,
        morphs,
        window: None,
        result: None,
    };
    let ran = event_loop.run_app(&mut app);
    match app.result {
        Some(result) => result,
        None => match ran {
            Ok(()) => Ok(WindowOutcome::Closed),
            Err(error) => Err(DemoError::Window(error.to_string())),
        },
    }
}

struct App<'a> {
    demo: &'a Demo,
    args: &'a CommonArgs,
    morphs: &'a [BuiltMorph],
    window: Option<WindowState>,
    /// Set when the loop must end with something other than a normal close.
    result: Option<Result<WindowOutcome, DemoError>>,
}

impl App<'_> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, result: Result<WindowOutcome, DemoError>) {
        self.result = Some(result);
        // Drop the surface before the loop ends, while its window still exists.
        self.window = None;
        event_loop.exit();
    }
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        match WindowState::new(event_loop, self.demo, self.args, self.morphs) {
            Ok(state) => {
                state.window.request_redraw();
                self.window = Some(state);
            }
            // Nothing was shown yet: the headless path can still do the job.
            Err(Setup::NoWindow(reason)) => {
                self.fail(event_loop, Ok(WindowOutcome::NoWindow(reason)))
            }
            Err(Setup::Failed(error)) => self.fail(event_loop, Err(error)),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(state) = &mut self.window else {
            return;
        };
        match event {
            WindowEvent::CloseRequested => {
                self.window = None;
                event_loop.exit();
            }
            WindowEvent::Resized(size) => state.resize(size),
            WindowEvent::ScaleFactorChanged { scale_factor, .. } => {
                state.scene.text_scale = (scale_factor as f32).clamp(0.5, 4.0);
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key,
                        state: ElementState::Pressed,
                        ..
                    },
                ..
            } => {
                let action = state.key(&logical_key);
                if action == KeyAction::Quit {
                    self.window = None;
                    event_loop.exit();
                }
            }
            WindowEvent::MouseInput {
                state: pressed,
                button: MouseButton::Left,
                ..
            } => state.dragging = pressed == ElementState::Pressed,
            WindowEvent::CursorMoved { position, .. } => {
                let at = (position.x as f32, position.y as f32);
                if state.dragging {
                    if let Some((x, y)) = state.cursor {
                        let view = &mut state.scene.view;
                        view.yaw -= (at.0 - x) * 0.01;
                        view.pitch = (view.pitch + (at.1 - y) * 0.01).clamp(-1.4, 1.4);
                    }
                }
                state.cursor = Some(at);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                let view = &mut state.scene.view;
                view.zoom = (view.zoom * 0.9f32.powf(lines)).clamp(0.05, 20.0);
            }
            WindowEvent::RedrawRequested => {
                if let Err(error) = state.redraw() {
                    self.fail(event_loop, Err(error));
                }
            }
            _ => {}
        }
    }
}

/// Why the window could not be set up.
enum Setup {
    /// No window, surface or adapter for it: fall back to headless.
    NoWindow(String),
    /// Something else (the scene's GPU resources): an error.
    Failed(DemoError),
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum KeyAction {
    Continue,
    Quit,
}

/// Everything that lives as long as the window. Fields drop in declaration order: the surface
/// before the window it draws into.
struct WindowState {
    scene: Scene,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    depth: wgpu::TextureView,
    device: wgpu::Device,
    queue: wgpu::Queue,
    name: &'static str,
    last_frame: Instant,
    /// Frames and seconds counted since the fps figure was last updated.
    fps_window: (u32, Duration),
    fps: f32,
    frame_ms: f32,
    dragging: bool,
    cursor: Option<(f32, f32)>,
    window: Arc<Window>,
}

impl WindowState {
    fn new(
        event_loop: &ActiveEventLoop,
        demo: &Demo,
        args: &CommonArgs,
        morphs: &[BuiltMorph],
    ) -> Result<WindowState, Setup> {
        let (width, height) = args.size;
        let attributes = Window::default_attributes()
            .with_title(format!("morphlod {}", demo.name))
            .with_inner_size(PhysicalSize::new(width, height));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| Setup::NoWindow(format!("creating the window failed: {e}")))?,
        );
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(
                Box::new(event_loop.owned_display_handle()),
            ));
        let surface = instance
            .create_surface(Arc::clone(&window))
            .map_err(|e| Setup::NoWindow(format!("creating a surface failed: {e}")))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .map_err(|e| Setup::NoWindow(format!("no adapter can present to the window: {e}")))?;
        // As the headless context: strip colouring needs a nonzero first_instance per draw.
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("morphlod demo device"),
            required_features: adapter.features() & wgpu::Features::INDIRECT_FIRST_INSTANCE,
            required_limits: adapter.limits(),
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .map_err(|e| Setup::NoWindow(format!("the adapter could not create a device: {e}")))?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| Setup::NoWindow("the surface does not work with this adapter".into()))?;
        // A linear format, like the offscreen target: the shader's colours are stored as is,
        // so the window shows what the headless PNGs show.
        let capabilities = surface.get_capabilities(&adapter);
        if let Some(&linear) = capabilities.formats.iter().find(|f| !f.is_srgb()) {
            config.format = linear;
        }
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&device, &config);
        let depth = depth_view(&device, config.width, config.height);
        let mut scene = Scene::new(
            &device,
            &queue,
            &adapter.get_info(),
            config.format,
            morphs,
            args,
        )
        .map_err(Setup::Failed)?;
        scene.text_scale = (window.scale_factor() as f32).clamp(0.5, 4.0);
        println!(
            "{}: window open on {} ({:?}), surface {:?}",
            demo.name,
            adapter.get_info().name,
            adapter.get_info().backend,
            config.format
        );
        Ok(WindowState {
            scene,
            surface,
            config,
            depth,
            device,
            queue,
            name: demo.name,
            last_frame: Instant::now(),
            fps_window: (0, Duration::ZERO),
            fps: 0.0,
            frame_ms: 0.0,
            dragging: false,
            cursor: None,
            window,
        })
    }

    fn resize(&mut self, size: PhysicalSize<u32>) {
        // A minimised window has size 0, which a surface cannot have: keep the old one.
        if size.width == 0 || size.height == 0 {
            return;
        }
        self.config.width = size.width;
        self.config.height = size.height;
        self.surface.configure(&self.device, &self.config);
        self.depth = depth_view(&self.device, size.width, size.height);
        self.window.request_redraw();
    }

    fn key(&mut self, key: &Key) -> KeyAction {
        let view = &mut self.scene.view;
        match key.as_ref() {
            Key::Named(NamedKey::Escape) | Key::Character("q") => return KeyAction::Quit,
            Key::Named(NamedKey::Space) => view.playing = !view.playing,
            Key::Named(NamedKey::ArrowRight) => view.step_t(0.05),
            Key::Named(NamedKey::ArrowLeft) => view.step_t(-0.05),
            Key::Named(NamedKey::ArrowUp) => view.step_lod(false),
            Key::Named(NamedKey::ArrowDown) => view.step_lod(true),
            Key::Character("l") => view.toggle_lod_control(),
            Key::Character("s") => view.strips = !view.strips,
            Key::Character("r") => {
                let fresh = View::new(view.strips);
                (view.yaw, view.pitch, view.zoom) = (fresh.yaw, fresh.pitch, fresh.zoom);
            }
            Key::Character("n") => self.scene.next_morph(),
            _ => {}
        }
        self.window.request_redraw();
        KeyAction::Continue
    }

    fn redraw(&mut self) -> Result<(), DemoError> {
        let now = Instant::now();
        let elapsed = now - self.last_frame;
        self.last_frame = now;
        self.scene.view.advance(elapsed.as_secs_f32());
        self.fps_window.0 += 1;
        self.fps_window.1 += elapsed;
        if self.fps_window.1 >= Duration::from_millis(500) {
            let seconds = self.fps_window.1.as_secs_f32();
            self.fps = self.fps_window.0 as f32 / seconds;
            self.frame_ms = seconds * 1e3 / self.fps_window.0 as f32;
            self.fps_window = (0, Duration::ZERO);
        }

        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(frame)
            | wgpu::CurrentSurfaceTexture::Suboptimal(frame) => frame,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                self.window.request_redraw();
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.device, &self.config);
                self.window.request_redraw();
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(DemoError::Window(
                    "the surface texture failed validation".into(),
                ))
            }
        };
        let status = format!(
            "{}  {:.1} fps  {:.2} ms/frame  {}x{}",
            self.name, self.fps, self.frame_ms, self.config.width, self.config.height
        );
        self.scene.update(
            &self.device,
            &self.queue,
            (self.config.width, self.config.height),
            &status,
        )?;
        let view = frame.texture.create_view(&Default::default());
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("demo frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(CLEAR),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.scene.draw(&mut pass)?;
        }
        self.queue.submit([encoder.finish()]);
        self.window.pre_present_notify();
        self.queue.present(frame);
        // Continuous redraw: the animation plays and the fps figure measures real frames.
        self.window.request_redraw();
        Ok(())
    }
}

/// The depth buffer of the window's pass, in the format the pipelines were made for.
fn depth_view(device: &wgpu::Device, width: u32, height: u32) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("demo depth"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: Target::DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}
