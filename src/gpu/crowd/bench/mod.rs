//! The crowd benchmark (`morphlod bench --crowd N`): N instances of one asset in a scene
//! ([`CrowdScene`]: a grid seen whole from above, or a walk through the crowd at eye height),
//! each playing the asset's animation at its own phase, drawn by one [`Crowd`] in one pass per
//! frame; the same instances with LOD by screen error and at full detail, in the same run; and,
//! given a shared sequence, the same instances as discrete LODs ([`DiscreteCrowd`]: per
//! instance the coarsest level within the same screen error, one instanced draw per level,
//! culled as the crowd culls), the alternative a user would pick instead, with levels at given
//! fractions or chosen by error down to what the scene's farthest instance needs.
//!
//! Per frame it times the CPU `set`, `prepare` and the recording of the pass; the GPU with
//! timestamp queries where the device has `TIMESTAMP_QUERY`: around the render pass, and from
//! the start of the frame's encoder to the pass's end where it also has
//! `TIMESTAMP_QUERY_INSIDE_ENCODERS` (the compute passes `Crowd::prepare_with` records before
//! the render pass, i.e. the scatters and the tail lists' expansion, then count as GPU time),
//! else as submit + wait; and always submit + wait too (the wall time from `queue.submit` to
//! the end of `device.poll(wait)`: what a frame costs when the CPU waits for it, submission,
//! compute passes and render pass included). It counts bytes uploaded, triangles drawn,
//! instances by what they are drawn from, frame switches and LOD steps, the crowd's GPU bytes,
//! and the screen error each mode actually draws (each instance in view: the error of what it
//! draws over a pixel's size at its distance), so that equal error is seen, not assumed.
//! Figures are for benchmarks, never for tests.

mod report;
mod scene;
mod timer;

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;

pub use self::scene::{CrowdBenchScene, CrowdScene};
use self::timer::FrameTimer;
use super::{
    Crowd, CrowdError, CrowdPath, CrowdRecords, CrowdUpload, DiscreteCrowd, DrawnFrom, InstanceId,
    SharedSequence,
};
use crate::asset::Asset;
use crate::deform::{DeformingModel, Lod};
use crate::gpu::{Context, GpuAsset, GpuError, RenderTarget};

/// What the crowd benchmark runs.
#[derive(Clone, Debug)]
pub struct CrowdBenchOptions {
    /// Instances in the scene.
    pub instances: u32,
    /// Where they stand and where the camera goes.
    pub scene: CrowdScene,
    /// Frames measured per mode (after 3 warm-up frames).
    pub frames: usize,
    /// Render frames per loop of the animation (120: one loop per 2 s at 60 fps).
    pub period: usize,
    /// Offscreen target size.
    pub width: u32,
    pub height: u32,
    /// Screen-space error of the LOD and discrete modes, in pixels.
    pub pixels: f32,
    /// The LOD mode's own screen-space error, where it differs (so that it can be compared
    /// with the discrete mode at a drawn error no larger than the discrete mode's).
    pub lod_pixels: Option<f32>,
    /// Also run full detail (slow on a software rasteriser with many instances).
    pub full_detail: bool,
    /// Also run discrete LODs, cut from this shared sequence (of the same asset's vertices).
    pub discrete: Option<DiscreteOptions>,
    /// The crowd's path; `None`: what [`Crowd::new`] picks for the device.
    pub path: Option<CrowdPath>,
    /// What the crowd's instances hold by distance.
    pub records: CrowdRecords,
}

impl Default for CrowdBenchOptions {
    fn default() -> Self {
        CrowdBenchOptions {
            instances: 100,
            scene: CrowdScene::Grid,
            frames: 60,
            period: 120,
            width: 1920,
            height: 1080,
            pixels: 1.0,
            lod_pixels: None,
            full_detail: true,
            discrete: None,
            path: None,
            records: CrowdRecords::default(),
        }
    }
}

/// The discrete mode of the crowd bench: a shared sequence and how its levels are chosen.
#[derive(Clone, Debug)]
pub struct DiscreteOptions {
    pub sequence: SharedSequence,
    pub levels: DiscreteChoice,
}

/// How the discrete mode's levels are chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum DiscreteChoice {
    /// Full detail and the levels at these triangle fractions (`morphlod export --lods`).
    Fractions(Vec<f32>),
    /// By error, as gltfpack users chain LODs with `-si`: full detail and one level per
    /// halving of the error from what the scene's farthest instance may draw at the bench's
    /// pixel error down to what its nearest may (at most 16 levels; levels on one step are
    /// one).
    ByError,
}

/// Mean and 95th percentile of one figure over the measured frames.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stat {
    pub mean: f64,
    pub p95: f64,
}

impl Stat {
    fn of(mut values: Vec<f64>) -> Stat {
        if values.is_empty() {
            return Stat::default();
        }
        values.sort_by(f64::total_cmp);
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let at = ((values.len() as f64 * 0.95).ceil() as usize).clamp(1, values.len()) - 1;
        Stat {
            mean,
            p95: values[at],
        }
    }
}

/// Per-frame figures of one mode, over its measured frames.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModeFigures {
    /// `lod` (screen error), `full` (full detail) or `discrete` (discrete LODs by the same
    /// screen error).
    pub mode: &'static str,
    /// Milliseconds.
    pub set_ms: Stat,
    pub prepare_ms: Stat,
    pub record_ms: Stat,
    /// GPU milliseconds of the frame's work: the compute passes and the render pass, or the
    /// render pass alone, by timestamps, or submit + wait ([`CrowdBenchReport::gpu_timing`]).
    pub gpu_ms: Stat,
    /// GPU milliseconds of the render pass alone, by timestamps (0 without them).
    pub pass_ms: Stat,
    /// Submit + wait, milliseconds.
    pub wait_ms: Stat,
    pub uploaded_bytes: Stat,
    pub writes: Stat,
    pub triangles: Stat,
    /// Indices the draws read (restarts included; [`super::CrowdStats::indices`]).
    pub indices: Stat,
    /// Instances whose frame changed, and the steps the LODs of the others moved by (none in
    /// discrete LODs: one connectivity for all).
    pub frame_switches: Stat,
    pub lod_steps: Stat,
    /// Draw calls (multi-draws, or instanced draws of discrete levels).
    pub draws: Stat,
    /// Instances out of view (drawing nothing), and the others by what they are drawn from
    /// (LOD mode: [`DrawnFrom`]; none else).
    pub culled: Stat,
    pub from_regions: Stat,
    pub from_copies: Stat,
    pub from_tails: Stat,
    /// GPU bytes of the crowd ([`super::CrowdStats::gpu_bytes`]; the discrete mode's levels,
    /// instances and asset).
    pub gpu_bytes: Stat,
    /// Screen error drawn, in pixels: each frame's mean over the instances in view, and the
    /// largest of any instance in any measured frame.
    pub error_px: Stat,
    pub max_error_px: f64,
    /// Every measured frame, in order (for plots).
    pub frames: Vec<FrameFigures>,
}

/// One measured frame of a mode.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameFigures {
    /// CPU `set` + `prepare` + record, milliseconds.
    pub cpu_ms: f64,
    /// GPU time as [`CrowdBenchReport::gpu_timing`] says, milliseconds.
    pub gpu_ms: f64,
    pub triangles: f64,
    pub uploaded_bytes: f64,
    /// Mean and largest screen error drawn, pixels.
    pub error_px: f64,
    pub max_error_px: f64,
}

/// One level of the discrete mode.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelFigures {
    /// Share of the full triangles (asked, or that the level keeps where chosen by error).
    pub fraction: f32,
    pub triangles: usize,
    /// Object-space error (a distance).
    pub error: f32,
    /// Instances drawing it, mean over the measured frames.
    pub instances: f64,
}

/// What [`run_crowd_bench`] measured.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CrowdBenchReport {
    pub adapter: String,
    pub instances: u32,
    /// [`CrowdScene::name`].
    pub scene: &'static str,
    pub vertices: u32,
    pub frames_sampled: usize,
    /// How GPU time was taken: `timestamps (compute + render passes)`, `timestamps (render
    /// pass)` or `submit + wait`.
    pub gpu_timing: &'static str,
    /// The crowd's path, the vertex entry point that drew the asset and its largest compact
    /// copy ([`CrowdRecords`]).
    pub path: String,
    /// Host bytes per instance (runtime, lengths, record and block mirrors), as the crowd
    /// accounts them after its LOD mode.
    pub host_bytes_per_instance: f64,
    /// GPU bytes per instance (its area of index memory, record, placement and pose) after
    /// the LOD mode.
    pub gpu_bytes_per_instance: f64,
    /// GPU bytes of the shared asset.
    pub shared_gpu_bytes: u64,
    /// Spawning: the CPU milliseconds of adding every instance, and the LOD mode's first frame
    /// (every instance's first move and its upload): CPU `set` + `prepare` milliseconds and the
    /// bytes uploaded.
    pub spawn_ms: f64,
    pub first_frame_ms: f64,
    pub first_frame_bytes: u64,
    pub modes: Vec<ModeFigures>,
    /// The discrete mode's levels (empty when it did not run).
    pub levels: Vec<LevelFigures>,
}

/// Runs the crowd benchmark of `asset` (with `model` made from it) on `ctx`: lays out the
/// scene, makes the crowd (and the discrete crowd), then measures each mode over the same
/// frames of the same camera.
pub fn run_crowd_bench(
    ctx: &Context,
    asset: &Asset,
    model: Arc<DeformingModel>,
    options: &CrowdBenchOptions,
) -> Result<CrowdBenchReport, CrowdError> {
    let (device, queue) = (&ctx.device, &ctx.queue);
    let gpu = GpuAsset::from_asset(device, asset)?;
    let target = RenderTarget::new(device, options.width, options.height, wgpu::Color::BLACK)?;
    let (color, depth) = (RenderTarget::COLOR_FORMAT, Some(RenderTarget::DEPTH_FORMAT));
    let timer = FrameTimer::new(device, queue);

    // layOutScene: the instances' transforms and centres, the camera of every frame.
    let both: Vec<[f32; 3]> = asset.v0.iter().chain(&asset.v1).copied().collect();
    let (lo, hi) = crate::mesh::bounds(&both).ok_or(GpuError::NoVertices)?;
    let aspect = options.width as f32 / options.height as f32;
    let bounds = (Vec3::from(lo), Vec3::from(hi));
    let scene = CrowdBenchScene::new(options.scene, options.instances, bounds, aspect)?;
    let frames = options.frames + WARM;

    // makeCrowds: the LOD crowd, and the discrete one with its levels.
    let mut crowd = match options.path {
        Some(path) => Crowd::with_path(device, color, depth, path)?,
        None => Crowd::new(device, color, depth),
    };
    crowd.set_records(options.records);
    let shared = Arc::clone(&gpu);
    let id = crowd.add_asset(device, gpu, Arc::clone(&model), options.instances)?;
    let spawn = Instant::now();
    let ids = (scene.transforms().iter())
        .map(|&t| crowd.add(id, t))
        .collect::<Result<Vec<InstanceId>, _>>()?;
    let spawn_ms = spawn.elapsed().as_secs_f64() * 1e3;
    let mut discrete = match &options.discrete {
        Some(discrete) => {
            let levels = match &discrete.levels {
                DiscreteChoice::Fractions(f) => discrete.sequence.levels(f),
                DiscreteChoice::ByError => {
                    let bounds = error_bounds(&scene, frames, options);
                    discrete.sequence.levels_within(&bounds)
                }
            };
            let levels = levels?;
            let d = DiscreteCrowd::new(device, color, depth, shared, levels, scene.transforms())?;
            Some(d)
        }
        None => None,
    };

    // measureModes: each mode over the same frames and camera.
    let mut report = CrowdBenchReport {
        adapter: format!(
            "{} ({:?})",
            ctx.adapter_info().name,
            ctx.adapter_info().backend
        ),
        instances: options.instances,
        scene: options.scene.name(),
        vertices: model.layout().vertex_count() as u32,
        frames_sampled: model.frame_count(),
        gpu_timing: match &timer {
            Some(timer) if timer.encoder_start => "timestamps (compute + render passes)",
            Some(_) => "timestamps (render pass)",
            None => "submit + wait",
        },
        path: format!(
            "{:?} ({}; compact copies up to {} words)",
            crowd.path(),
            crowd.vertex_entry_point(id).unwrap_or("-"),
            crowd.compact_slots(id),
        ),
        ..Default::default()
    };
    let mut modes = vec!["lod"];
    if options.full_detail {
        modes.push("full");
    }
    if discrete.is_some() {
        modes.push("discrete");
    }
    let mut per_level = vec![0usize; discrete.as_ref().map_or(0, |d| d.levels().levels().len())];
    for mode in modes {
        let mut renderer = match (mode, discrete.as_mut()) {
            ("discrete", Some(d)) => Renderer::Discrete(d),
            _ => Renderer::Crowd(&mut crowd, &ids),
        };
        let run = Run {
            ctx,
            target: &target,
            timer: timer.as_ref(),
            scene: &scene,
            model: &model,
            options,
        };
        let (figures, first) = run.measure(mode, &mut renderer, &mut per_level)?;
        report.modes.push(figures);
        if mode == "lod" {
            (report.first_frame_ms, report.first_frame_bytes) = first;
            report.spawn_ms = spawn_ms;
            let stats = crowd.stats();
            let count = f64::from(options.instances.max(1));
            report.host_bytes_per_instance = stats.instance_host_bytes as f64 / count;
            report.gpu_bytes_per_instance = stats.instance_gpu_bytes as f64 / count;
            report.shared_gpu_bytes = stats.shared_gpu_bytes;
        }
    }
    if let Some(d) = &discrete {
        let frames = options.frames.max(1) as f64;
        report.levels = (d.levels().levels().iter().zip(&per_level))
            .map(|(level, &count)| LevelFigures {
                fraction: level.fraction,
                triangles: level.triangles.len(),
                error: level.error,
                instances: count as f64 / frames,
            })
            .collect();
    }
    Ok(report)
}

/// Frames drawn before the measured ones in each mode (the scene's frames `0..WARM`).
pub const CROWD_BENCH_WARM_FRAMES: usize = 3;
const WARM: usize = CROWD_BENCH_WARM_FRAMES;

/// The error bounds of [`DiscreteChoice::ByError`]: from what the farthest instance may draw
/// over the scene's frames at the bench's pixel error, halving down to what the nearest may.
fn error_bounds(scene: &CrowdBenchScene, frames: usize, options: &CrowdBenchOptions) -> Vec<f32> {
    let (mut near, mut far) = (f32::INFINITY, 0.0f32);
    for f in 0..frames {
        let (_, eye) = scene.camera(f);
        for centre in scene.centres() {
            let d = (*centre - eye).length();
            near = near.min(d);
            far = far.max(d);
        }
    }
    let px = |d: f32| options.pixels * scene.units_per_pixel(d, options.height);
    let (least, most) = (px(near), px(far));
    (0..16)
        .map(|j| most / (1u32 << j) as f32)
        .take_while(|&e| e >= least * 0.5 && e > 0.0 && e.is_finite())
        .collect()
}

/// One mode's measurement: the shared parts.
struct Run<'a> {
    ctx: &'a Context,
    target: &'a RenderTarget,
    timer: Option<&'a FrameTimer>,
    scene: &'a CrowdBenchScene,
    model: &'a DeformingModel,
    options: &'a CrowdBenchOptions,
}

impl Run<'_> {
    /// Draws `mode` over the scene's frames (after [`WARM`] unmeasured ones) and gathers its
    /// figures, and its first frame's CPU `set` + `prepare` milliseconds and upload; adds the
    /// discrete levels' instance counts to `per_level`.
    fn measure(
        &self,
        mode: &'static str,
        renderer: &mut Renderer,
        per_level: &mut [usize],
    ) -> Result<(ModeFigures, (f64, u64)), CrowdError> {
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let options = self.options;
        let mut rows: [Vec<f64>; 19] = Default::default();
        let mut frames = Vec::with_capacity(options.frames);
        let mut moves = Vec::with_capacity(self.scene.centres().len());
        let mut before = renderer.places();
        let mut first = (0.0, 0);
        let pixels = match mode {
            "lod" => options.lod_pixels.unwrap_or(options.pixels),
            _ => options.pixels,
        };
        for f in 0..options.frames + WARM {
            // moveInstances: each at its own phase (a golden-ratio spread), its LOD by its
            // distance from this frame's eye.
            let (view_proj, eye) = self.scene.camera(f);
            renderer.set_view_proj(view_proj);
            moves.clear();
            for (i, centre) in self.scene.centres().iter().enumerate() {
                let phase = (i as f32 * 0.618_034).fract();
                let t = (f as f32 / options.period.max(1) as f32 + phase).fract();
                let lod = match mode {
                    "full" => Lod::Steps(0),
                    _ => {
                        let distance = (*centre - eye).length();
                        let height = options.height as f32;
                        Lod::screen_error(pixels, distance, self.scene.fov(), height)
                    }
                };
                moves.push((t, lod));
            }
            // drawFrame: as an application would, the crowd's scatters in the frame's
            // submission; the encoder is the application's (made every frame in every mode),
            // so it is made before the timers.
            let mut encoder = device.create_command_encoder(&Default::default());
            if let Some(timer) = self.timer {
                timer.start(&mut encoder);
            }
            let a = Instant::now();
            renderer.set(&moves)?;
            let b = Instant::now();
            let upload = renderer.prepare_with(device, queue, &mut encoder);
            let c = Instant::now();
            {
                let writes = self.timer.map(FrameTimer::writes);
                let mut pass = self.target.begin_timed_pass(&mut encoder, writes);
                renderer.render(&mut pass);
            }
            if let Some(timer) = self.timer {
                timer.resolve(&mut encoder);
            }
            let commands = encoder.finish();
            let d = Instant::now();
            queue.submit([commands]);
            device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(GpuError::from)?;
            let e = Instant::now();
            let gpu = self
                .timer
                .map(|timer| timer.read_ms(device, queue))
                .transpose()?;
            // countFrame: where each instance is and the error it draws.
            let ms = |x: Instant, y: Instant| (y - x).as_secs_f64() * 1e3;
            if f == 0 {
                first = (ms(a, c), upload.bytes);
            }
            let after = renderer.places();
            if f < WARM {
                before = after;
                continue;
            }
            let drawn = self.drawn(renderer, &after, eye);
            let (mut switches, mut steps) = (0, 0);
            for (p, q) in before.iter().zip(&after) {
                match (p, q) {
                    (Some(p), Some(q)) if p.frame == q.frame => steps += p.lod.abs_diff(q.lod),
                    (Some(p), Some(q)) => switches += usize::from(p.frame != q.frame),
                    _ => {}
                }
            }
            before = after;
            if let Renderer::Discrete(d) = renderer {
                for &l in d.instance_levels().iter().flatten() {
                    per_level[l] += 1;
                }
            }
            let values = [
                ms(a, b),
                ms(b, c),
                ms(c, d),
                gpu.map_or(ms(d, e), |(frame, _)| frame),
                gpu.map_or(0.0, |(_, pass)| pass),
                ms(d, e),
                upload.bytes as f64,
                upload.writes as f64,
                drawn.triangles as f64,
                switches as f64,
                renderer.draws() as f64,
                drawn.indices as f64,
                steps as f64,
                drawn.culled as f64,
                drawn.from[0] as f64,
                drawn.from[1] as f64,
                drawn.from[2] as f64,
                renderer.gpu_bytes() as f64,
                drawn.mean_px,
            ];
            for (row, value) in rows.iter_mut().zip(values) {
                row.push(value);
            }
            frames.push(FrameFigures {
                cpu_ms: values[0] + values[1] + values[2],
                gpu_ms: values[3],
                triangles: values[8],
                uploaded_bytes: values[6],
                error_px: drawn.mean_px,
                max_error_px: drawn.max_px,
            });
        }
        let max_error_px = frames.iter().fold(0.0, |m: f64, f| m.max(f.max_error_px));
        let [set, prepare, record, gpu, pass, wait, bytes, writes, triangles, switches, draws, indices, steps, culled, regions, copies, tails, gpu_bytes, error] =
            rows.map(Stat::of);
        let figures = ModeFigures {
            mode,
            set_ms: set,
            prepare_ms: prepare,
            record_ms: record,
            gpu_ms: gpu,
            pass_ms: pass,
            wait_ms: wait,
            uploaded_bytes: bytes,
            writes,
            triangles,
            indices,
            frame_switches: switches,
            lod_steps: steps,
            draws,
            culled,
            from_regions: regions,
            from_copies: copies,
            from_tails: tails,
            gpu_bytes,
            error_px: error,
            max_error_px,
            frames,
        };
        Ok((figures, first))
    }

    /// What the instances in view draw at `places` (a crowd's) or at their levels (discrete
    /// LODs), seen from `eye`: triangles, indices read, instances out of view and by what they
    /// are drawn from, and the screen error: the error of what each draws over a pixel's size
    /// at its distance.
    fn drawn(&self, renderer: &Renderer, places: &[Option<Place>], eye: Vec3) -> Drawn {
        let height = self.options.height;
        let px = |error: f32, i: usize| {
            let distance = (self.scene.centres()[i] - eye).length();
            error / self.scene.units_per_pixel(distance, height)
        };
        let mut drawn = Drawn::default();
        let mut errors = Vec::with_capacity(places.len());
        match renderer {
            Renderer::Crowd(crowd, _) => {
                let stats = crowd.stats();
                drawn.triangles = stats.triangles;
                drawn.indices = stats.indices;
                for (i, place) in places.iter().enumerate() {
                    let Some(place) = place else { continue };
                    if place.culled {
                        drawn.culled += 1;
                        continue;
                    }
                    match place.from {
                        DrawnFrom::Regions => drawn.from[0] += 1,
                        DrawnFrom::Copy => drawn.from[1] += 1,
                        DrawnFrom::Tail => drawn.from[2] += 1,
                        DrawnFrom::S0 => {}
                    }
                    errors.push(px(self.model.error_at(place.frame, place.lod), i));
                }
            }
            Renderer::Discrete(d) => {
                drawn.triangles = d.triangles();
                drawn.indices = 3 * d.triangles() as u64;
                let levels = d.levels().levels();
                for (i, level) in d.instance_levels().iter().enumerate() {
                    match level {
                        Some(l) => errors.push(px(levels[*l].error, i)),
                        None => drawn.culled += 1,
                    }
                }
            }
        }
        drawn.mean_px =
            errors.iter().map(|&e| f64::from(e)).sum::<f64>() / errors.len().max(1) as f64;
        drawn.max_px = errors.iter().fold(0.0f32, |m, &e| m.max(e)).into();
        drawn
    }
}

/// What one frame drew ([`Run::drawn`]).
#[derive(Default)]
struct Drawn {
    triangles: usize,
    indices: u64,
    culled: usize,
    /// In view, drawn from their regions, compact copies and tail lists.
    from: [usize; 3],
    mean_px: f64,
    max_px: f64,
}

/// Where a crowd's instance is, as the bench counts it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Place {
    frame: usize,
    lod: usize,
    from: DrawnFrom,
    culled: bool,
}

/// What one mode of the bench draws with: the crowd (LOD or full detail) and its instances, or
/// discrete LODs.
enum Renderer<'a> {
    Crowd(&'a mut Crowd, &'a [InstanceId]),
    Discrete(&'a mut DiscreteCrowd),
}

impl Renderer<'_> {
    /// `moves` name the instances in order.
    fn set(&mut self, moves: &[(f32, Lod)]) -> Result<(), CrowdError> {
        match self {
            Renderer::Crowd(c, ids) => {
                let moves: Vec<(InstanceId, f32, Lod)> = (ids.iter())
                    .zip(moves)
                    .map(|(&id, &(t, lod))| (id, t, lod))
                    .collect();
                c.set(&moves)
            }
            Renderer::Discrete(d) => d.set(moves),
        }
    }

    fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        match self {
            Renderer::Crowd(c, _) => c.set_view_proj(view_proj),
            Renderer::Discrete(d) => d.set_view_proj(view_proj),
        }
    }

    fn prepare_with(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
    ) -> CrowdUpload {
        match self {
            Renderer::Crowd(c, _) => c.prepare_with(device, queue, encoder),
            // A discrete crowd has nothing to scatter (its base crowd holds no asset): writes.
            Renderer::Discrete(d) => d.prepare(device, queue),
        }
    }

    fn render(&self, pass: &mut wgpu::RenderPass<'_>) {
        match self {
            Renderer::Crowd(c, _) => c.render(pass),
            Renderer::Discrete(d) => d.render(pass),
        }
    }

    /// Draw calls: the crowd's multi-draws (one per asset and page), or one per level in use.
    fn draws(&self) -> usize {
        match self {
            Renderer::Crowd(c, ids) => ids.first().map_or(0, |id| {
                let asset = id.asset();
                (0..c.pages(asset))
                    .filter(|&p| c.drawn_records(asset, p) > 0)
                    .count()
            }),
            Renderer::Discrete(d) => d.draws(),
        }
    }

    /// GPU bytes of what draws the mode (the crowd's stats, or the discrete crowd's).
    fn gpu_bytes(&self) -> u64 {
        match self {
            Renderer::Crowd(c, _) => c.stats().gpu_bytes,
            Renderer::Discrete(d) => d.gpu_bytes(),
        }
    }

    /// Each crowd instance's place (none in discrete LODs: one connectivity for all).
    fn places(&self) -> Vec<Option<Place>> {
        match self {
            Renderer::Crowd(c, ids) => (ids.iter())
                .map(|&id| {
                    c.at(id).ok().map(|at| Place {
                        frame: at.frame,
                        lod: at.lod,
                        from: at.from,
                        culled: at.culled,
                    })
                })
                .collect(),
            Renderer::Discrete(d) => vec![None; d.instance_levels().len()],
        }
    }
}
