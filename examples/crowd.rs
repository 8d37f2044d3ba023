//! Crowd: a field of MakeHuman walkers (`makehuman_walker.glb`: its `walk` clip with the
//! `morph` weights), each at its own phase and pace, walking across the field and turning
//! back at its edges, with textured faces playing their expressions among them, all drawn by
//! one `gpu::Crowd`: the poses, targets, skin and texture of each asset uploaded once, one
//! `multi_draw_indexed_indirect` per asset, the weights blended and the skin applied on the
//! GPU (per walker only its phase; its walk across the field is root motion,
//! `Crowd::set_velocity`, moved on the GPU by the crowd's clock). The camera flies around and
//! over the field and every instance takes its own LOD from its distance (a screen error of
//! `--pixels`), so near walkers keep their detail and far ones drop most of it.
//!
//! ```sh
//! cargo run --release --example crowd                     # window; headless without a display
//! cargo run --release --example crowd -- --headless --instances 300 --frames 60
//! cargo run --release --example crowd -- --bodies         # morphing bodies in place instead
//! cargo run --release --example crowd -- --sheet 8        # out/crowd/sheet.png: 8 frames in a row
//! ```
//!
//! `--bodies`: MakeHuman bodies playing the body's weight animation (4 whole-body targets) in
//! place, unskinned, instead of the walkers.
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
    sources: &[WALKER, FACE],
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

/// A field of walkers (or morphing bodies) and faces drawn by one crowd, with per-instance LOD.
#[derive(Parser, Debug)]
#[command(name = "crowd")]
struct Args {
    /// Instances on the field (every 5th a face, the others walkers or bodies)
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
    /// Bodies morphing in place (the body's weight animation) instead of the skinned walkers
    #[arg(long)]
    bodies: bool,
    /// Headless: also write `sheet.png`, N of the frames in a row (evenly spaced over the
    /// sequence, without the readout), with the camera turning at the window's pace instead of
    /// once over the frames
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(2..=16))]
    sheet: Option<u32>,
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
    let (bodies, sources): (NamedMorph, &[&str]) = if !args.bodies {
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
        (walker, DEMO.sources)
    } else {
        (animation(BODY, "morph", "body-morph")?, &[BODY, FACE])
    };
    let morphs = vec![bodies, animation(FACE, "expressions", "face-expressions")?];
    let library = Library::new(sources, &out, morphs, args.build_frames)?;
    let assets = [library.load(0)?, library.load(1)?];
    if args.headless || args.sheet.is_some() {
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
    /// Its object-space ground velocity at its clip's own pace ([`stride_velocity`]): zero
    /// for an asset that does not walk.
    stride: Vec3,
    /// Object to world before its place and heading (standing on the ground, or a face
    /// floating at head height), and its centre's height above its place.
    local: Mat4,
    centre: f32,
}

/// One instance: its asset, id, where it is and where it walks, and its phase in the
/// animation.
struct Member {
    kind: usize,
    id: InstanceId,
    /// Its place on the ground at the field's second `since`, heading (radians about y) and
    /// world velocity from then on (the crowd moves it by the same on the GPU).
    place: Vec3,
    since: f32,
    heading: f32,
    velocity: Vec3,
    phase: f32,
    /// Clip time per second: 1, or a walker's own pace (0.8 to 1.2).
    speed: f32,
}

impl Member {
    /// Its place on the ground at the field's second `seconds`.
    fn place_at(&self, seconds: f32) -> Vec3 {
        self.place + (seconds - self.since) * self.velocity
    }
}

/// The ground velocity at which a skinned asset's clip, played at its own pace, does not
/// slide its feet (object space, units per second; zero without a skin): the walk is in
/// place, so the foot on the ground slides backwards at the walking speed. Sampled at 48
/// times of the loop: at each, the lowest vertex (the planted foot) and how far it moves to
/// the next sample; the median per axis leaves out the steps from one foot to the other.
fn stride_velocity(asset: &morphlod::Asset) -> Vec3 {
    const SAMPLES: usize = 48;
    let Some(skinning) = &asset.skin else {
        return Vec3::ZERO;
    };
    let step = skinning.clip.duration / SAMPLES as f32;
    let poses: Vec<Vec<[f32; 3]>> = (0..=SAMPLES)
        .map(|i| asset.pose_at(i as f32 / SAMPLES as f32))
        .collect();
    let (mut xs, mut zs) = (Vec::new(), Vec::new());
    for pair in poses.windows(2) {
        let lowest = (0..pair[0].len()).min_by(|&a, &b| pair[0][a][1].total_cmp(&pair[0][b][1]));
        if let Some(v) = lowest {
            xs.push((pair[1][v][0] - pair[0][v][0]) / step);
            zs.push((pair[1][v][2] - pair[0][v][2]) / step);
        }
    }
    let median = |values: &mut Vec<f32>| {
        values.sort_by(f32::total_cmp);
        values.get(values.len() / 2).copied().unwrap_or(0.0)
    };
    // The body moves against its planted foot.
    -Vec3::new(median(&mut xs), 0.0, median(&mut zs))
}

/// The angle about y of a horizontal direction, from +z towards +x (what
/// `Mat4::from_rotation_y` adds to it).
fn heading_of(direction: Vec3) -> f32 {
    direction.x.atan2(direction.z)
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
    /// Half the field's extent along x and z: walkers turn back at its edges.
    half: Vec3,
    pixels: f32,
    readout: Readout,
    /// Whether the readout is drawn (not on a sheet's frames: they show the walk).
    show_readout: bool,
    /// The window's scale factor: the readout keeps its size in logical pixels.
    text_scale: f32,
    adapter: String,
    last: Figures,
    moves: Vec<(InstanceId, f32, Lod)>,
}

/// Places `member` on the ground at `place` at the field's second `since` (the crowd's clock
/// now), heading `heading`: its transform and, for a walker, its velocity (its stride at its
/// pace, along its heading), on the crowd and on the member.
fn field_place(
    crowd: &mut Crowd,
    kinds: &[Kind],
    member: &mut Member,
    (place, since): (Vec3, f32),
    heading: f32,
) -> Result<(), DemoError> {
    let kind = &kinds[member.kind];
    // The asset walks along `stride` unturned: turned by `heading - heading_of(stride)` it
    // walks along `heading`.
    let turn = if kind.stride == Vec3::ZERO {
        heading
    } else {
        heading - heading_of(kind.stride)
    };
    let model = Mat4::from_translation(place) * Mat4::from_rotation_y(turn) * kind.local;
    let velocity = member.speed * Mat4::from_rotation_y(turn).transform_vector3(kind.stride);
    crowd.set_transform(member.id, model)?;
    crowd.set_velocity(member.id, velocity)?;
    member.place = place;
    member.since = since;
    member.heading = heading;
    member.velocity = velocity;
    Ok(())
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
        let bounds = |built: &BuiltMorph| {
            let (lo, hi) = morphlod::mesh::bounds(&built.asset.v0).unwrap_or(([0.0; 3], [0.0; 3]));
            (Vec3::from(lo), Vec3::from(hi))
        };
        // Bodies stand on y = 0; a face is scaled to half a body's height and floats at a
        // body's head height, so both read as people from far away.
        let (body_lo, body_hi) = bounds(&assets[0]);
        let (face_lo, face_hi) = bounds(&assets[1]);
        let height = body_hi.y - body_lo.y;
        let face_scale = 0.5 * height / (face_hi.y - face_lo.y).max(1e-6);
        let local = [
            Mat4::from_translation(Vec3::new(0.0, -body_lo.y, 0.0)),
            Mat4::from_translation(Vec3::new(0.0, 0.8 * height, 0.0))
                * Mat4::from_scale(Vec3::splat(face_scale))
                * Mat4::from_translation(-(face_lo + face_hi) * 0.5),
        ];
        let centres = [0.5 * height, 0.8 * height];
        let mut kinds = Vec::new();
        for (k, (built, &count)) in assets.iter().zip(&counts).enumerate() {
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
                stride: stride_velocity(&built.asset),
                local: local[k],
                centre: centres[k],
            });
        }
        if kinds[0].stride != Vec3::ZERO {
            println!(
                "crowd: the walkers walk at {:.2} units a second at their clip's pace (their feet do not slide)",
                kinds[0].stride.length()
            );
        }
        let side = (f64::from(args.instances).sqrt().ceil() as u32).max(1);
        let rows = args.instances.div_ceil(side);
        let half = Vec3::new(
            0.5 * side as f32 * SPACING.0,
            0.0,
            0.5 * rows as f32 * SPACING.1,
        );
        let mut members = Vec::new();
        for i in 0..args.instances {
            let kind = usize::from(i % FACE_EVERY == FACE_EVERY - 1);
            let jitter = Vec3::new(unit(i, 1) - 0.5, 0.0, unit(i, 2) - 0.5) * 0.3;
            let place = Vec3::new(
                (i % side) as f32 * SPACING.0 - 0.5 * (side - 1) as f32 * SPACING.0,
                0.0,
                (i / side) as f32 * SPACING.1 - 0.5 * (rows - 1) as f32 * SPACING.1,
            ) + jitter;
            // Walkers head anywhere; the others face the field's front, turned a little.
            let stride = kinds[kind].stride;
            let heading = if stride == Vec3::ZERO {
                (unit(i, 3) - 0.5) * 1.6
            } else {
                unit(i, 3) * std::f32::consts::TAU
            };
            let speed = if stride == Vec3::ZERO {
                1.0
            } else {
                0.8 + 0.4 * unit(i, 8)
            };
            let mut member = Member {
                kind,
                id: crowd.add(kinds[kind].id, Mat4::IDENTITY)?,
                place,
                since: 0.0,
                heading,
                velocity: Vec3::ZERO,
                phase: unit(i, 7),
                speed,
            };
            field_place(&mut crowd, &kinds, &mut member, (place, 0.0), heading)?;
            // Bodies have no texture: one colour each, skin to cloth tones.
            let color = [
                0.45 + 0.45 * unit(i, 4),
                0.35 + 0.35 * unit(i, 5),
                0.3 + 0.4 * unit(i, 6),
                1.0,
            ];
            crowd.set_color(member.id, color)?;
            members.push(member);
        }
        Ok(Field {
            crowd,
            kinds,
            members,
            radius: half.length().max(1.0),
            half,
            pixels: args.pixels,
            readout: Readout::new(device, queue, color_format),
            show_readout: args.sheet.is_none(),
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
        // This frame's view before `set`: an instance `set` sees out of view is parked at its
        // coarsest LOD (with the last frame's view, one coming into view would be drawn so).
        self.crowd.set_view_proj(view_proj);
        // The walkers walk on the GPU (root motion by the crowd's clock); one that passed an
        // edge of the field turns back into it (one placement written).
        self.crowd.set_clock(seconds)?;
        self.turn_back_at_edges(seconds)?;
        self.moves.clear();
        for m in &self.members {
            let kind = &self.kinds[m.kind];
            let t = (seconds * m.speed / kind.duration + m.phase).fract();
            let centre = m.place_at(seconds) + Vec3::new(0.0, kind.centre, 0.0);
            let distance = (centre - eye).length();
            let lod = Lod::screen_error(self.pixels, distance, FOV_Y, height as f32);
            self.moves.push((m.id, t, lod));
        }
        // The crowd's `set` (the field's own loops above are the application's).
        let start = Instant::now();
        self.crowd.set(&self.moves)?;
        let set = start.elapsed();
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
        let text = match self.show_readout {
            true => self.readout_text(status),
            false => String::new(),
        };
        self.readout
            .prepare(device, queue, (width, height), self.text_scale, &text)
    }

    /// Turns each walker that walked out of the field at `seconds` back into it: its
    /// heading mirrored at the edge it passed, from where it is now.
    fn turn_back_at_edges(&mut self, seconds: f32) -> Result<(), DemoError> {
        let half = self.half;
        for m in &mut self.members {
            let at = m.place_at(seconds);
            let v = m.velocity;
            let out_x = (at.x > half.x && v.x > 0.0) || (at.x < -half.x && v.x < 0.0);
            let out_z = (at.z > half.z && v.z > 0.0) || (at.z < -half.z && v.z < 0.0);
            if out_x || out_z {
                let turned = Vec3::new(
                    if out_x { -v.x } else { v.x },
                    0.0,
                    if out_z { -v.z } else { v.z },
                );
                let heading = heading_of(turned);
                field_place(&mut self.crowd, &self.kinds, m, (at, seconds), heading)?;
            }
        }
        Ok(())
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
        let people = if self.kinds[0].stride == Vec3::ZERO {
            "bodies"
        } else {
            "walkers"
        };
        let per_instance = |bytes: u64| bytes as f64 / 1e3 / stats.instances.max(1) as f64;
        format!(
            "{status}\n\
             instances {} ({} {people}, {faces} faces), {frames} sampled frames each, {} out of view\n\
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
    let mut sheet = Vec::new();
    for i in 0..frames {
        let seconds = i as f32 * HEADLESS_STEP;
        // One turn over the frames; for a sheet the window's pace (the walk, not the flight).
        let angle = match args.sheet {
            Some(_) => std::f32::consts::TAU * seconds / TURN_SECONDS,
            None => std::f32::consts::TAU * i as f32 / frames as f32,
        };
        let status = format!("crowd  headless frame {}/{frames}", i + 1);
        let mut encoder = device.create_command_encoder(&Default::default());
        field.update(
            device,
            queue,
            &mut encoder,
            (width, height),
            seconds,
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
        if let Some(n) = args.sheet {
            // Frames 0, ⌊F/N⌋, … of F: N evenly spaced.
            if (i * n) % frames < n && sheet.len() < n as usize {
                sheet.push(image);
            }
        }
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
    if !sheet.is_empty() {
        let path = out.join("sheet.png");
        let mut row = image::RgbaImage::new(width * sheet.len() as u32, height);
        for (k, frame) in sheet.iter().enumerate() {
            image::imageops::replace(&mut row, frame, i64::from(width) * k as i64, 0);
        }
        morphlod::gpu::save_png(&row, &path).map_err(DemoError::lib)?;
        println!(
            "crowd: {} frames, {:.2} s apart, in a row: {}",
            sheet.len(),
            f64::from(frames) / sheet.len() as f64 * f64::from(HEADLESS_STEP),
            path.display()
        );
    }
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
