//! Crowd: a field of MakeHuman bodies, each playing the body's weight animation (4 whole-body
//! targets) at its own phase, with textured faces playing their expressions among them, all
//! drawn by one `gpu::Crowd`: the poses, targets and texture of each asset uploaded once, one
//! `multi_draw_indexed_indirect` per asset, the weights blended on the GPU. The camera flies
//! around and over the field and every instance takes its own LOD from its distance (a screen
//! error of `--pixels`), so near bodies keep their detail and far ones drop most of it.
//!
//! ```sh
//! cargo run --release --example crowd                     # window; headless without a display
//! cargo run --release --example crowd -- --headless --instances 300 --frames 60
//! cargo run --release --example crowd -- --walkers        # skinned walkers instead of bodies
//! ```
//!
//! `--walkers`: the bodies are MakeHuman walkers (`makehuman_walker.glb`, its `walk` clip with
//! the `morph` weights), skinned on the GPU by the crowd, each at its own phase and speed.
//!
//! Instances out of the camera's view draw nothing (`Crowd::set_culling`, on by default). The
//! readout shows instances (and those out of view), triangles drawn (and at full detail), the
//! CPU's `set`, `prepare` and recording, the GPU's time (submit + wait) and what was uploaded.
//! Keys in the window: space pauses the animation and the flight, up/down a finer/coarser
//! screen error, q quits. The two assets are built on first use and cached in `out/crowd/`
//! (see `common`).

// The crowd uses the demos' asset cache, readout and window; not their one-object scene.
#[allow(dead_code)]
mod common;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use clap::Parser;
use glam::{Mat4, Vec3};
use morphlod::gpu::{
    Context, Crowd, CrowdStats, CrowdUpload, DrawCounter, GpuAsset, InstanceId, RenderTarget,
};
use morphlod::io::{load_morph, LoadOptions, MorphSource};
use morphlod::{DeformingModel, Lod};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::WindowId;

use common::cache::{BuiltMorph, Library};
use common::headless::{check_growth, remove_old_frames, resident_mb};
use common::scene::Readout;
use common::window::{no_display, window_event, DemoWindow, FrameClock, KeyAction, Presenter};
use common::{Demo, DemoError, MorphSpec, NamedMorph};

const BODY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/makehuman_body.glb");
const FACE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/makehuman_face.glb");
const WALKER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/makehuman_walker.glb");
const DEMO: Demo = Demo {
    name: "crowd",
    sources: &[BODY, FACE],
};
/// Vertical field of view of the flying camera.
const FOV_Y: f32 = 50.0 * std::f32::consts::PI / 180.0;
/// Every `FACE_EVERY`-th cell of the field holds a face instead of a body.
const FACE_EVERY: u32 = 5;
/// Grid spacing across (x) and along (z) the field, in body units (a body is 1.67 tall).
const SPACING: (f32, f32) = (1.25, 1.1);
/// Seconds of one turn of the camera around the field (window; headless: one turn over the
/// frames).
const TURN_SECONDS: f32 = 40.0;
/// Simulated seconds per headless frame.
const HEADLESS_STEP: f32 = 1.0 / 15.0;

/// A field of animated bodies and faces drawn by one crowd, with per-instance LOD.
#[derive(Parser, Debug)]
#[command(name = "crowd")]
struct Args {
    /// Instances on the field (every 5th a face, the others bodies)
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    instances: u32,
    /// Render a frame sequence to numbered PNGs instead of opening a window (automatic when no
    /// window can be opened): one turn of the camera around the field
    #[arg(long)]
    headless: bool,
    /// Frames of the headless sequence
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    frames: u32,
    /// Window or image size in pixels, WIDTHxHEIGHT
    #[arg(long, default_value = "1280x720", value_parser = common::parse_size)]
    size: (u32, u32),
    /// Directory for the built assets and the headless frames [default: out/crowd]
    #[arg(long)]
    out: Option<PathBuf>,
    /// Sampled animation frames |r| per built asset (part of the cache key)
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u16).range(2..=4096))]
    build_frames: u16,
    /// Screen-space error of every instance's LOD, in pixels
    #[arg(long, default_value_t = 1.0, value_parser = parse_pixels)]
    pixels: f32,
    /// Headless: fail when the resident set grows by more than this many MB between the end of
    /// the first tenth of the frames (warm-up) and the last frame (Linux only)
    #[arg(long)]
    max_growth_mb: Option<f64>,
    /// Draw the instances out of view too (to compare: the same pixels, more vertices)
    #[arg(long)]
    no_culling: bool,
    /// Skinned walkers instead of the bodies (the walker's `walk` clip with its `morph`
    /// weights), each at its own phase and speed
    #[arg(long)]
    walkers: bool,
}

fn parse_pixels(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(pixels) if pixels.is_finite() && pixels > 0.0 => Ok(pixels),
        _ => Err(format!(
            "'{text}' is not a screen error: give a number of pixels above 0, e.g. 1"
        )),
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    common::exit_code(&DEMO, run(&args))
}

fn run(args: &Args) -> Result<(), DemoError> {
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(DEMO.name));
    std::fs::create_dir_all(&out).map_err(|source| DemoError::Io {
        path: out.clone(),
        source,
    })?;
    let animation = |path: &str, name: &str, label: &str| -> Result<NamedMorph, DemoError> {
        let source = MorphSource::Animation(name.into());
        let morph = load_morph(Path::new(path), &LoadOptions::default(), &source)
            .map_err(DemoError::lib)?;
        Ok(NamedMorph {
            label: label.into(),
            morph: MorphSpec::Ready(Box::new(morph)),
        })
    };
    let (bodies, sources): (NamedMorph, &[&str]) = if args.walkers {
        let source = MorphSource::AnimationWithWeights {
            animation: "walk".into(),
            weights: "morph".into(),
        };
        let morph = load_morph(Path::new(WALKER), &LoadOptions::default(), &source)
            .map_err(DemoError::lib)?;
        let walker = NamedMorph {
            label: "walker-walk".into(),
            morph: MorphSpec::Ready(Box::new(morph)),
        };
        (walker, &[WALKER, FACE])
    } else {
        (animation(BODY, "morph", "body-morph")?, DEMO.sources)
    };
    let morphs = vec![bodies, animation(FACE, "expressions", "face-expressions")?];
    let library = Library::new(sources, &out, morphs, args.build_frames)?;
    let assets = [library.load(0)?, library.load(1)?];
    if args.headless {
        return run_headless(args, &assets, &out);
    }
    if let Some(reason) = no_display() {
        println!("crowd: no window can be opened ({reason}); rendering headless instead");
        return run_headless(args, &assets, &out);
    }
    let event_loop = match EventLoop::new() {
        Ok(event_loop) => event_loop,
        Err(error) => {
            println!("crowd: no window can be opened ({error}); rendering headless instead");
            return run_headless(args, &assets, &out);
        }
    };
    let mut app = App {
        args,
        assets: &assets,
        window: None,
        outcome: None,
    };
    let ran = event_loop.run_app(&mut app);
    match app.outcome {
        Some(Outcome::NoWindow(reason)) => {
            println!("crowd: no window can be opened ({reason}); rendering headless instead");
            run_headless(args, &assets, &out)
        }
        Some(Outcome::Failed(error)) => Err(error),
        None => ran.map_err(|error| DemoError::Window(error.to_string())),
    }
}

/// One asset on the field: its place in the crowd and what LOD and time need of it.
struct Kind {
    id: morphlod::gpu::AssetId,
    model: Arc<DeformingModel>,
    /// Seconds of one loop of its animation.
    duration: f32,
    /// Triangles at full detail.
    triangles: usize,
}

/// One instance: its asset, id, where its centre is, and its phase in the animation.
struct Member {
    kind: usize,
    id: InstanceId,
    centre: Vec3,
    phase: f32,
    /// Clip time per second: 1, or a walker's own pace (0.8 to 1.2).
    speed: f32,
}

/// What one frame cost and sent, for the readout and the console.
#[derive(Clone, Debug, Default)]
struct Figures {
    set: Duration,
    prepare: Duration,
    record: Duration,
    /// Submit + wait.
    gpu: Duration,
    upload: CrowdUpload,
    /// Triangles, instances (and those out of view) and bytes of the crowd after the frame's
    /// `prepare`.
    stats: CrowdStats,
    /// Draw calls the crowd recorded (one multi-draw per asset).
    draws: u64,
}

/// The crowd, its instances, the camera's path and the readout.
struct Field {
    crowd: Crowd,
    kinds: Vec<Kind>,
    members: Vec<Member>,
    /// Half the field's diagonal (the field is centred on the origin).
    radius: f32,
    pixels: f32,
    readout: Readout,
    /// The window's scale factor: the readout keeps its size in logical pixels.
    text_scale: f32,
    adapter: String,
    last: Figures,
    moves: Vec<(InstanceId, f32, Lod)>,
}

/// A small deterministic hash of `i` to `[0, 1)`: per-instance turns, colours and phases that
/// are the same on every run.
fn unit(i: u32, salt: u32) -> f32 {
    let mut x = i.wrapping_mul(0x9e37_79b9) ^ salt.wrapping_mul(0x85eb_ca6b);
    x ^= x >> 15;
    x = x.wrapping_mul(0x2c1b_3c6d);
    x ^= x >> 12;
    (x >> 8) as f32 / (1u32 << 24) as f32
}

impl Field {
    fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        adapter: &wgpu::AdapterInfo,
        color_format: wgpu::TextureFormat,
        assets: &[BuiltMorph; 2],
        args: &Args,
    ) -> Result<Field, DemoError> {
        let mut crowd = Crowd::new(device, color_format, Some(RenderTarget::DEPTH_FORMAT));
        crowd.set_culling(!args.no_culling);
        let faces = args.instances / FACE_EVERY;
        let counts = [args.instances - faces, faces];
        let mut kinds = Vec::new();
        for (built, &count) in assets.iter().zip(&counts) {
            let gpu = GpuAsset::from_asset(device, &built.asset).map_err(DemoError::lib)?;
            let id = crowd.add_asset(device, gpu, Arc::clone(&built.model), count.max(1))?;
            // A skinned asset plays its clip, the others their weight track.
            let clip = built.asset.skin.as_ref().map(|s| s.clip.duration);
            let track = built.asset.blend.as_ref().map(|b| b.track.duration());
            let duration = clip.or(track).map_or(2.0, |d| d.max(1e-3));
            kinds.push(Kind {
                id,
                model: Arc::clone(&built.model),
                duration,
                triangles: built.model.layout().triangle_count(),
            });
        }
        let bounds = |built: &BuiltMorph| {
            let (lo, hi) = morphlod::mesh::bounds(&built.asset.v0).unwrap_or(([0.0; 3], [0.0; 3]));
            (Vec3::from(lo), Vec3::from(hi))
        };
        // Bodies stand on y = 0; a face is scaled to half a body's height and floats at a
        // body's head height, so both read as people from far away.
        let (body_lo, body_hi) = bounds(&assets[0]);
        let (face_lo, face_hi) = bounds(&assets[1]);
        let face_scale = 0.5 * (body_hi.y - body_lo.y) / (face_hi.y - face_lo.y).max(1e-6);
        let local = [
            Mat4::from_translation(Vec3::new(0.0, -body_lo.y, 0.0)),
            Mat4::from_translation(Vec3::new(0.0, 0.8 * (body_hi.y - body_lo.y), 0.0))
                * Mat4::from_scale(Vec3::splat(face_scale))
                * Mat4::from_translation(-(face_lo + face_hi) * 0.5),
        ];
        let centres = [
            Vec3::new(0.0, 0.5 * (body_hi.y - body_lo.y), 0.0),
            Vec3::new(0.0, 0.8 * (body_hi.y - body_lo.y), 0.0),
        ];
        let side = (f64::from(args.instances).sqrt().ceil() as u32).max(1);
        let rows = args.instances.div_ceil(side);
        let mut members = Vec::new();
        for i in 0..args.instances {
            let kind = usize::from(i % FACE_EVERY == FACE_EVERY - 1);
            let jitter = Vec3::new(unit(i, 1) - 0.5, 0.0, unit(i, 2) - 0.5) * 0.3;
            let at = Vec3::new(
                (i % side) as f32 * SPACING.0 - 0.5 * (side - 1) as f32 * SPACING.0,
                0.0,
                (i / side) as f32 * SPACING.1 - 0.5 * (rows - 1) as f32 * SPACING.1,
            ) + jitter;
            let turn = Mat4::from_rotation_y((unit(i, 3) - 0.5) * 1.6);
            let model = Mat4::from_translation(at) * turn * local[kind];
            let id = crowd.add(kinds[kind].id, model)?;
            // Bodies have no texture: one colour each, skin to cloth tones.
            let color = [
                0.45 + 0.45 * unit(i, 4),
                0.35 + 0.35 * unit(i, 5),
                0.3 + 0.4 * unit(i, 6),
                1.0,
            ];
            crowd.set_color(id, color)?;
            members.push(Member {
                kind,
                id,
                centre: at + centres[kind],
                phase: unit(i, 7),
                speed: if args.walkers && kind == 0 {
                    0.8 + 0.4 * unit(i, 8)
                } else {
                    1.0
                },
            });
        }
        let half = Vec3::new(
            0.5 * side as f32 * SPACING.0,
            0.0,
            0.5 * rows as f32 * SPACING.1,
        );
        Ok(Field {
            crowd,
            kinds,
            members,
            radius: half.length().max(1.0),
            pixels: args.pixels,
            readout: Readout::new(device, queue, color_format),
            text_scale: 1.0,
            adapter: format!("{} ({:?})", adapter.name, adapter.backend),
            last: Figures::default(),
            moves: Vec::new(),
        })
    }

    /// The camera at turn `angle` (radians) around the field: on a circle through its edges,
    /// rising and falling over the heads, looking at a point across the field, so the nearest
    /// bodies are a few units away and the farthest the whole field away.
    fn camera(&self, angle: f32, aspect: f32) -> (Mat4, Vec3) {
        let r = self.radius * 0.85;
        // Always above the heads (1.67 units), lowest twice a turn.
        let height = 3.2 + 1.3 * (angle * 2.0).sin();
        let eye = Vec3::new(r * angle.cos(), height, r * angle.sin());
        let look = Vec3::new(-0.3 * r * angle.sin(), 0.0, 0.3 * r * angle.cos());
        let view = glam::camera::rh::view::look_at_mat4(eye, look, Vec3::Y);
        let far = 3.0 * self.radius + 10.0;
        let proj = glam::camera::rh::proj::directx::perspective(FOV_Y, aspect, 0.05, far);
        (proj * view, eye)
    }

    /// Moves every instance to its time at `seconds` and its LOD at the camera of `angle`,
    /// uploads (the scatters recorded into `encoder`, which must draw the field after them and
    /// be submitted before the next update), and lays out the readout (with the previous
    /// frame's GPU time).
    #[allow(clippy::too_many_arguments)]
    fn update(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        (width, height): (u32, u32),
        seconds: f32,
        angle: f32,
        status: &str,
    ) -> Result<(), DemoError> {
        let (view_proj, eye) = self.camera(angle, width as f32 / height.max(1) as f32);
        self.moves.clear();
        for m in &self.members {
            let kind = &self.kinds[m.kind];
            let t = (seconds * m.speed / kind.duration + m.phase).fract();
            let distance = (m.centre - eye).length();
            let lod = Lod::screen_error(self.pixels, distance, FOV_Y, height as f32);
            self.moves.push((m.id, t, lod));
        }
        let start = Instant::now();
        self.crowd.set(&self.moves)?;
        let set = start.elapsed();
        self.crowd.set_view_proj(view_proj);
        let start = Instant::now();
        // The crowd's scatters go in the frame's encoder, submitted with its pass.
        let upload = self.crowd.prepare_with(device, queue, encoder);
        self.last = Figures {
            set,
            prepare: start.elapsed(),
            upload,
            stats: self.crowd.stats(),
            ..self.last.clone()
        };
        let text = self.readout_text(status);
        self.readout
            .prepare(device, queue, (width, height), self.text_scale, &text)
    }

    /// Records the crowd (one multi-draw per asset) and the readout.
    fn draw(&mut self, pass: &mut wgpu::RenderPass<'_>) -> Result<(), DemoError> {
        let start = Instant::now();
        let mut counter = DrawCounter::new(pass);
        self.crowd.render(&mut counter);
        self.last.draws = counter.draw_calls;
        self.last.record = start.elapsed();
        self.readout.draw(pass)
    }

    /// Submits `encoder` and waits for the GPU: the frame's GPU time (submit + wait).
    fn submit(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: wgpu::CommandEncoder,
    ) {
        let start = Instant::now();
        queue.submit([encoder.finish()]);
        // A lost device shows as a failed poll; the next frame's surface or read-back says why.
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        self.last.gpu = start.elapsed();
    }

    fn full_detail_triangles(&self) -> usize {
        self.members
            .iter()
            .map(|m| self.kinds[m.kind].triangles)
            .sum()
    }

    fn readout_text(&self, status: &str) -> String {
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let last = &self.last;
        let faces = self.members.iter().filter(|m| m.kind == 1).count();
        let full = self.full_detail_triangles();
        let frames: usize = self
            .kinds
            .iter()
            .map(|k| k.model.frame_count())
            .max()
            .unwrap_or(0);
        let stats = &last.stats;
        let per_instance = |bytes: u64| bytes as f64 / 1e3 / stats.instances.max(1) as f64;
        format!(
            "{status}\n\
             instances {} ({} bodies, {faces} faces), {frames} sampled frames each, {} out of view\n\
             triangles {} drawn of {} at full detail ({:.1}%), LOD {:.2} px\n\
             draws     {} multi-draw(s): one per asset\n\
             CPU ms    set {:.2}  prepare {:.2}  record {:.3}\n\
             GPU ms    {:.1} (submit + wait, previous frame)\n\
             upload    {:.1} KB: {} index patches, {} writes, {} dispatches\n\
             memory    per instance {:.0} KB host, {:.0} KB GPU; shared {:.1} MB GPU\n\
             adapter   {}",
            self.members.len(),
            self.members.len() - faces,
            stats.culled,
            stats.triangles,
            full,
            100.0 * stats.triangles as f64 / full.max(1) as f64,
            self.pixels,
            last.draws,
            ms(last.set),
            ms(last.prepare),
            ms(last.record),
            ms(last.gpu),
            last.upload.bytes as f64 / 1e3,
            last.upload.patches,
            last.upload.writes,
            last.upload.dispatches,
            per_instance(stats.instance_host_bytes),
            per_instance(stats.instance_gpu_bytes),
            stats.shared_gpu_bytes as f64 / 1e6,
            self.adapter,
        )
    }
}

fn run_headless(args: &Args, assets: &[BuiltMorph; 2], out: &Path) -> Result<(), DemoError> {
    let context = Context::headless().map_err(DemoError::lib)?;
    let info = context.adapter_info();
    let (width, height) = args.size;
    let (device, queue) = (&context.device, &context.queue);
    let target = RenderTarget::new(device, width, height, common::CLEAR).map_err(DemoError::lib)?;
    let mut field = Field::new(
        device,
        queue,
        &info,
        RenderTarget::COLOR_FORMAT,
        assets,
        args,
    )?;
    let frames = args.frames;
    println!(
        "crowd: rendering {frames} frames of {} instances headless on {} ({:?}), {width}x{height}",
        args.instances, info.name, info.backend
    );
    remove_old_frames(out)?;
    let warm_up = (frames / 10).max(1);
    let mut warm_resident = None;
    let mut written = Vec::new();
    // Per-frame figures after the first (which moves every instance from full detail).
    let mut sums = [0.0f64; 6];
    for i in 0..frames {
        let angle = std::f32::consts::TAU * i as f32 / frames as f32;
        let status = format!("crowd  headless frame {}/{frames}", i + 1);
        let mut encoder = device.create_command_encoder(&Default::default());
        field.update(
            device,
            queue,
            &mut encoder,
            (width, height),
            i as f32 * HEADLESS_STEP,
            angle,
            &status,
        )?;
        {
            let mut pass = target.begin_pass(&mut encoder);
            field.draw(&mut pass)?;
        }
        field.submit(device, queue, encoder);
        let image = target.read_image(device, queue).map_err(DemoError::lib)?;
        let path = out.join(format!("frame_{i:04}.png"));
        morphlod::gpu::save_png(&image, &path).map_err(DemoError::lib)?;
        let f = &field.last;
        println!(
            "  {} triangles {:8} culled {:5} set {:6.2} ms prepare {:6.2} ms record {:5.2} ms GPU {:7.1} ms uploaded {:8} B",
            path.display(),
            f.stats.triangles,
            f.stats.culled,
            f.set.as_secs_f64() * 1e3,
            f.prepare.as_secs_f64() * 1e3,
            f.record.as_secs_f64() * 1e3,
            f.gpu.as_secs_f64() * 1e3,
            f.upload.bytes,
        );
        if i > 0 {
            let figures = [f.set, f.prepare, f.record, f.gpu].map(|d| d.as_secs_f64() * 1e3);
            let counts = [f.upload.bytes as f64 / 1e3, f.stats.triangles as f64];
            for (sum, value) in sums.iter_mut().zip(figures.into_iter().chain(counts)) {
                *sum += value;
            }
        }
        written.push(path);
        if i + 1 == warm_up {
            warm_resident = resident_mb();
        }
    }
    if frames > 1 {
        let [set, prepare, record, gpu, kb, triangles] = sums.map(|s| s / f64::from(frames - 1));
        println!(
            "crowd: mean of frames 2..{frames}: set {set:.2} ms, prepare {prepare:.2} ms, \
             record {record:.3} ms, GPU {gpu:.1} ms (submit + wait), uploaded {kb:.1} KB, \
             {triangles:.0} triangles"
        );
    }
    check_growth("crowd", warm_resident, warm_up, frames, args.max_growth_mb)?;
    if let (Some(first), Some(last)) = (written.first(), written.last()) {
        println!(
            "crowd: {frames} frames written: {} .. {}",
            first.display(),
            last.display()
        );
    }
    Ok(())
}

/// How the window loop ended, other than by a close.
enum Outcome {
    NoWindow(String),
    Failed(DemoError),
}

struct App<'a> {
    args: &'a Args,
    assets: &'a [BuiltMorph; 2],
    window: Option<WindowState>,
    outcome: Option<Outcome>,
}

/// The window's field and presenter. Fields drop in declaration order: the crowd's GPU
/// resources before the device and surface.
struct WindowState {
    field: Field,
    presenter: Presenter,
    clock: FrameClock,
    /// Simulated seconds: the animation's and the camera's time, stopped while paused.
    seconds: f32,
    playing: bool,
}

impl App<'_> {
    fn stop(&mut self, event_loop: &ActiveEventLoop, outcome: Outcome) {
        self.outcome = Some(outcome);
        self.window = None;
        event_loop.exit();
    }
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let title = format!("morphlod crowd: {} instances", self.args.instances);
        let presenter = match Presenter::open(event_loop, &title, self.args.size) {
            Ok(presenter) => presenter,
            Err(reason) => return self.stop(event_loop, Outcome::NoWindow(reason)),
        };
        let field = Field::new(
            &presenter.device,
            &presenter.queue,
            &presenter.adapter,
            presenter.config.format,
            self.assets,
            self.args,
        );
        match field {
            Ok(mut field) => {
                field.text_scale = (presenter.window.scale_factor() as f32).clamp(0.5, 4.0);
                println!(
                    "crowd: window open on {} ({:?}), {} instances",
                    presenter.adapter.name, presenter.adapter.backend, self.args.instances
                );
                presenter.window.request_redraw();
                self.window = Some(WindowState {
                    field,
                    presenter,
                    clock: FrameClock::new(),
                    seconds: 0.0,
                    playing: true,
                });
            }
            Err(error) => self.stop(event_loop, Outcome::Failed(error)),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        if let Some(error) = window_event(&mut self.window, event_loop, event) {
            self.stop(event_loop, Outcome::Failed(error));
        }
    }
}

impl DemoWindow for WindowState {
    fn presenter(&mut self) -> &mut Presenter {
        &mut self.presenter
    }

    fn set_text_scale(&mut self, scale: f32) {
        self.field.text_scale = scale;
    }

    fn key(&mut self, key: &Key) -> KeyAction {
        match key.as_ref() {
            Key::Named(NamedKey::Escape) | Key::Character("q") => return KeyAction::Quit,
            Key::Named(NamedKey::Space) => self.playing = !self.playing,
            Key::Named(NamedKey::ArrowUp) => {
                self.field.pixels = (self.field.pixels / 1.5).max(0.05)
            }
            Key::Named(NamedKey::ArrowDown) => {
                self.field.pixels = (self.field.pixels * 1.5).min(500.0)
            }
            _ => {}
        }
        KeyAction::Continue
    }

    fn redraw(&mut self) -> Result<(), DemoError> {
        let elapsed = self.clock.tick();
        if self.playing {
            self.seconds += elapsed;
        }
        let Some(frame) = self.presenter.frame()? else {
            return Ok(());
        };
        let (width, height) = (self.presenter.config.width, self.presenter.config.height);
        let status = format!(
            "crowd  {:.1} fps  {:.1} ms/frame  {width}x{height}  {}  \
             keys: space pause, up/down finer/coarser, q quit",
            self.clock.fps,
            self.clock.frame_ms,
            if self.playing { "playing" } else { "paused" },
        );
        let angle = std::f32::consts::TAU * self.seconds / TURN_SECONDS;
        let (device, queue) = (&self.presenter.device, &self.presenter.queue);
        let mut encoder = device.create_command_encoder(&Default::default());
        self.field.update(
            device,
            queue,
            &mut encoder,
            (width, height),
            self.seconds,
            angle,
            &status,
        )?;
        let view = frame.texture.create_view(&Default::default());
        {
            let mut pass = self.presenter.begin_pass(&mut encoder, &view);
            self.field.draw(&mut pass)?;
        }
        self.field.submit(device, queue, encoder);
        self.presenter.present(frame);
        Ok(())
    }
}
