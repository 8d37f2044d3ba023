//! The crowd benchmark (`morphlod bench --crowd N`): N instances of one asset on a grid seen
//! from above and in front, each playing the asset's animation at its own phase, drawn by one
//! [`Crowd`] in one pass per frame; the same instances with LOD by screen error and at full
//! detail, in the same run; and, given the levels of a shared sequence, the same instances as
//! discrete LODs ([`DiscreteCrowd`]: per instance the coarsest level within the same screen
//! error, one instanced draw per level), the alternative a user would pick instead.
//!
//! Per frame it times the CPU `set`, `prepare` and the recording of the pass; the GPU with
//! timestamp queries where the device has `TIMESTAMP_QUERY`: around the render pass, and from
//! the start of the frame's encoder to the pass's end where it also has
//! `TIMESTAMP_QUERY_INSIDE_ENCODERS` (the compute passes `Crowd::prepare_with` records before
//! the render pass, i.e. the scatters and the tail lists' expansion, then count as GPU time),
//! else as submit + wait; and always submit + wait too (the wall time from `queue.submit` to
//! the end of `device.poll(wait)`: what a frame costs when the CPU waits for it, submission,
//! compute passes and render pass included). It counts bytes uploaded, triangles drawn and frame switches. Figures are
//! for benchmarks, never for tests.

use std::sync::Arc;
use std::time::Instant;

use glam::{Mat4, Vec3};

use super::{
    Crowd, CrowdError, CrowdPath, CrowdRecords, CrowdUpload, DiscreteCrowd, DiscreteLevels,
    InstanceId,
};
use crate::asset::Asset;
use crate::deform::{DeformingModel, Lod};
use crate::gpu::camera::{fit_to_bounds, Projection};
use crate::gpu::{Context, GpuAsset, RenderTarget};

/// What the crowd benchmark runs.
#[derive(Clone, Debug)]
pub struct CrowdBenchOptions {
    /// Instances on the grid.
    pub instances: u32,
    /// Frames measured per mode (after 3 warm-up frames).
    pub frames: usize,
    /// Render frames per loop of the animation (120: one loop per 2 s at 60 fps).
    pub period: usize,
    /// Offscreen target size.
    pub width: u32,
    pub height: u32,
    /// Screen-space error of the LOD mode, in pixels.
    pub pixels: f32,
    /// Also run full detail (slow on a software rasteriser with many instances).
    pub full_detail: bool,
    /// Also run discrete LODs with these levels (of the same asset's vertices).
    pub discrete: Option<DiscreteLevels>,
    /// The crowd's path; `None`: what [`Crowd::new`] picks for the device.
    pub path: Option<CrowdPath>,
    /// The crowd's compact area.
    pub records: CrowdRecords,
}

impl Default for CrowdBenchOptions {
    fn default() -> Self {
        CrowdBenchOptions {
            instances: 100,
            frames: 60,
            period: 120,
            width: 1920,
            height: 1080,
            pixels: 1.0,
            full_detail: true,
            discrete: None,
            path: None,
            records: CrowdRecords::default(),
        }
    }
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

/// Per-frame figures of one mode.
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
    /// Instances whose frame changed (none in discrete LODs: one connectivity for all).
    pub frame_switches: Stat,
    /// Draw calls (multi-draws, or instanced draws of discrete levels).
    pub draws: Stat,
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
}

/// One level of the discrete mode.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelFigures {
    /// Share of the full triangles asked.
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
    pub vertices: u32,
    pub frames_sampled: usize,
    /// How GPU time was taken: `timestamps (compute + render passes)`, `timestamps (render
    /// pass)` or `submit + wait`.
    pub gpu_timing: &'static str,
    /// The crowd's path, the vertex entry point that drew the asset and the slots of its
    /// instances' compact area ([`CrowdRecords`]).
    pub path: String,
    /// Host bytes per instance (runtime, lengths, record and block mirrors).
    pub host_bytes_per_instance: f64,
    /// GPU bytes per instance (index slots, record, block).
    pub gpu_bytes_per_instance: f64,
    /// GPU bytes of the shared asset.
    pub shared_gpu_bytes: u64,
    pub modes: Vec<ModeFigures>,
    /// The discrete mode's levels (empty when it did not run).
    pub levels: Vec<LevelFigures>,
}

/// Runs the crowd benchmark of `asset` (with `model` made from it) on `ctx`.
pub fn run_crowd_bench(
    ctx: &Context,
    asset: &Asset,
    model: Arc<DeformingModel>,
    options: &CrowdBenchOptions,
) -> Result<CrowdBenchReport, CrowdError> {
    let (device, queue) = (&ctx.device, &ctx.queue);
    let gpu = GpuAsset::from_asset(device, asset)?;
    let shared = Arc::clone(&gpu);
    let vertices = gpu.vertex_count();
    let target = RenderTarget::new(device, options.width, options.height, wgpu::Color::BLACK)?;
    let (color, depth) = (RenderTarget::COLOR_FORMAT, Some(RenderTarget::DEPTH_FORMAT));
    let mut crowd = match options.path {
        Some(path) => Crowd::with_path(device, color, depth, path)?,
        None => Crowd::new(device, color, depth),
    };
    crowd.set_records(options.records);
    let id = crowd.add_asset(device, gpu, Arc::clone(&model), options.instances.max(1))?;
    let timer = FrameTimer::new(device, queue);

    // The grid: columns along x, rows along z, one asset's size plus a tenth apart.
    let both: Vec<[f32; 3]> = asset.v0.iter().chain(&asset.v1).copied().collect();
    let (lo, hi) = crate::mesh::bounds(&both).ok_or(crate::gpu::GpuError::NoVertices)?;
    let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
    let size = hi - lo;
    let spacing = size.max_element() * 1.1;
    let side = (f64::from(options.instances).sqrt().ceil() as u32).max(1);
    let grid_max = lo + Vec3::new(spacing * side as f32, size.y, spacing * side as f32);
    let fov = 0.8;
    let aspect = options.width as f32 / options.height as f32;
    let camera = fit_to_bounds(
        lo.into(),
        grid_max.into(),
        Vec3::new(0.0, -0.45, -1.0),
        aspect,
        Projection::Perspective { vertical_fov: fov },
    )?;
    let eye = camera.view.inverse().transform_point3(Vec3::ZERO);
    crowd.set_view_proj(camera.view_proj());
    let mut ids: Vec<InstanceId> = Vec::new();
    let mut distances = Vec::new();
    let mut transforms = Vec::new();
    for i in 0..options.instances {
        let place = Vec3::new(
            (i % side) as f32 * spacing,
            0.0,
            (i / side) as f32 * spacing,
        );
        transforms.push(Mat4::from_translation(place));
        ids.push(crowd.add(id, Mat4::from_translation(place))?);
        distances.push((place + (lo + hi) * 0.5 - eye).length());
    }
    let mut discrete = match &options.discrete {
        Some(levels) => {
            let mut d = DiscreteCrowd::new(
                device,
                RenderTarget::COLOR_FORMAT,
                Some(RenderTarget::DEPTH_FORMAT),
                shared,
                levels.clone(),
                &transforms,
            )?;
            d.set_view_proj(camera.view_proj());
            Some(d)
        }
        None => None,
    };
    let mut modes = vec!["lod"];
    if options.full_detail {
        modes.push("full");
    }
    if discrete.is_some() {
        modes.push("discrete");
    }
    let mut per_level = vec![0usize; options.discrete.as_ref().map_or(0, |l| l.levels().len())];
    let stats = crowd.stats();
    let mut report = CrowdBenchReport {
        adapter: format!(
            "{} ({:?})",
            ctx.adapter_info().name,
            ctx.adapter_info().backend
        ),
        instances: options.instances,
        vertices,
        frames_sampled: model.frame_count(),
        gpu_timing: match &timer {
            Some(timer) if timer.encoder_start => "timestamps (compute + render passes)",
            Some(_) => "timestamps (render pass)",
            None => "submit + wait",
        },
        path: format!(
            "{:?} ({}; compact area {} slots)",
            crowd.path(),
            crowd.vertex_entry_point(id).unwrap_or("-"),
            crowd.compact_slots(id),
        ),
        gpu_bytes_per_instance: stats.instance_gpu_bytes as f64
            / f64::from(options.instances.max(1)),
        shared_gpu_bytes: stats.shared_gpu_bytes,
        ..Default::default()
    };

    let warm = 3;
    let mut moves = Vec::with_capacity(ids.len());
    for mode in modes {
        let mut rows: [Vec<f64>; 12] = Default::default();
        let mut frames = Vec::with_capacity(options.frames);
        let mut renderer = match (mode, discrete.as_mut()) {
            ("discrete", Some(d)) => Renderer::Discrete(d),
            _ => Renderer::Crowd(&mut crowd),
        };
        for f in 0..options.frames + warm {
            let before: Vec<usize> = renderer.frames(&ids);
            moves.clear();
            for (i, &instance) in ids.iter().enumerate() {
                // Each instance at its own phase (a golden-ratio spread).
                let phase = (i as f32 * 0.618_034).fract();
                let t = (f as f32 / options.period.max(1) as f32 + phase).fract();
                let lod = match mode {
                    "full" => Lod::Steps(0),
                    _ => {
                        Lod::screen_error(options.pixels, distances[i], fov, options.height as f32)
                    }
                };
                moves.push((instance, t, lod));
            }
            // As an application would: the crowd's scatters ride in the frame's submission.
            // The encoder is the application's (made every frame in every mode), so it is
            // made before the timers.
            let mut encoder = device.create_command_encoder(&Default::default());
            if let Some(timer) = &timer {
                timer.start(&mut encoder);
            }
            let a = Instant::now();
            renderer.set(&moves)?;
            let b = Instant::now();
            let upload = renderer.prepare_with(device, queue, &mut encoder);
            let c = Instant::now();
            {
                let writes = timer.as_ref().map(FrameTimer::writes);
                let mut pass = target.begin_timed_pass(&mut encoder, writes);
                renderer.render(&mut pass);
            }
            if let Some(timer) = &timer {
                timer.resolve(&mut encoder);
            }
            let commands = encoder.finish();
            let d = Instant::now();
            queue.submit([commands]);
            device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(crate::gpu::GpuError::from)?;
            let e = Instant::now();
            let gpu = timer
                .as_ref()
                .map(|timer| timer.read_ms(device, queue))
                .transpose()?;
            if f < warm {
                continue;
            }
            let after = renderer.frames(&ids);
            let switches = before.iter().zip(&after).filter(|(p, q)| p != q).count();
            let ms = |x: Instant, y: Instant| (y - x).as_secs_f64() * 1e3;
            let values = [
                ms(a, b),
                ms(b, c),
                ms(c, d),
                gpu.map_or(ms(d, e), |(frame, _)| frame),
                gpu.map_or(0.0, |(_, pass)| pass),
                ms(d, e),
                upload.bytes as f64,
                upload.writes as f64,
                renderer.triangles() as f64,
                switches as f64,
                renderer.draws() as f64,
                renderer.indices() as f64,
            ];
            if let Renderer::Discrete(d) = &renderer {
                for &l in d.instance_levels() {
                    per_level[l] += 1;
                }
            }
            for (row, value) in rows.iter_mut().zip(values) {
                row.push(value);
            }
            frames.push(FrameFigures {
                cpu_ms: values[0] + values[1] + values[2],
                gpu_ms: values[3],
                triangles: values[8],
            });
        }
        let [set, prepare, record, gpu, pass, wait, bytes, writes, triangles, switches, draws, indices] =
            rows.map(Stat::of);
        report.modes.push(ModeFigures {
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
            frame_switches: switches,
            draws,
            indices,
            frames,
        });
    }
    if let Some(d) = &discrete {
        let frames = options.frames.max(1) as f64;
        report.levels = d
            .levels()
            .levels()
            .iter()
            .zip(&per_level)
            .map(|(level, &count)| LevelFigures {
                fraction: level.fraction,
                triangles: level.triangles.len(),
                error: level.error,
                instances: count as f64 / frames,
            })
            .collect();
    }
    report.host_bytes_per_instance =
        crowd.stats().instance_host_bytes as f64 / f64::from(options.instances.max(1));
    Ok(report)
}

/// What one mode of the bench draws with: the crowd (LOD or full detail) or discrete LODs.
enum Renderer<'a> {
    Crowd(&'a mut Crowd),
    Discrete(&'a mut DiscreteCrowd),
}

impl Renderer<'_> {
    /// `moves` name the instances in order (the discrete renderer's order too).
    fn set(&mut self, moves: &[(InstanceId, f32, Lod)]) -> Result<(), CrowdError> {
        match self {
            Renderer::Crowd(c) => c.set(moves),
            Renderer::Discrete(d) => {
                let moves: Vec<(f32, Lod)> = moves.iter().map(|&(_, t, lod)| (t, lod)).collect();
                d.set(&moves)
            }
        }
    }

    fn prepare_with(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
    ) -> CrowdUpload {
        match self {
            Renderer::Crowd(c) => c.prepare_with(device, queue, encoder),
            // A discrete crowd has nothing to scatter (its base crowd holds no asset): writes.
            Renderer::Discrete(d) => d.prepare(device, queue),
        }
    }

    fn render(&self, pass: &mut wgpu::RenderPass<'_>) {
        match self {
            Renderer::Crowd(c) => c.render(pass),
            Renderer::Discrete(d) => d.render(pass),
        }
    }

    fn triangles(&self) -> usize {
        match self {
            Renderer::Crowd(c) => c.stats().triangles,
            Renderer::Discrete(d) => d.triangles(),
        }
    }

    fn indices(&self) -> u64 {
        match self {
            Renderer::Crowd(c) => c.stats().indices,
            Renderer::Discrete(d) => 3 * d.triangles() as u64,
        }
    }

    /// One multi-draw per asset, or one draw per level in use.
    fn draws(&self) -> usize {
        match self {
            Renderer::Crowd(c) => usize::from(c.stats().instances > 0),
            Renderer::Discrete(d) => d.draws(),
        }
    }

    /// Each instance's frame (the discrete levels have none: every pose one connectivity).
    fn frames(&self, ids: &[InstanceId]) -> Vec<usize> {
        match self {
            Renderer::Crowd(c) => ids
                .iter()
                .map(|&id| c.at(id).map_or(usize::MAX, |at| at.frame))
                .collect(),
            Renderer::Discrete(_) => vec![0; ids.len()],
        }
    }
}

/// The frame's timestamps, resolved and read back after each frame: the start of its encoder
/// (where the device has `TIMESTAMP_QUERY_INSIDE_ENCODERS`), the render pass's start and end.
struct FrameTimer {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period: f64,
    /// Whether the encoder's start is timed (query 0).
    encoder_start: bool,
}

impl FrameTimer {
    /// A timer where the device has `TIMESTAMP_QUERY`, else `None`.
    fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Option<FrameTimer> {
        let features = device.features();
        if !features.contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("crowd bench frame"),
            ty: wgpu::QueryType::Timestamp,
            count: 3,
        });
        let resolved = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crowd bench timestamps"),
            size: 3 * wgpu::QUERY_SIZE as u64,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(FrameTimer {
            queries,
            resolved,
            period: f64::from(queue.get_timestamp_period()),
            encoder_start: features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS),
        })
    }

    /// Times the start of the frame's encoder, before anything is recorded in it. (Vulkan
    /// writes it once the commands before it, the frame's buffer writes included, are done.)
    fn start(&self, encoder: &mut wgpu::CommandEncoder) {
        if self.encoder_start {
            encoder.write_timestamp(&self.queries, 0);
        }
    }

    fn writes(&self) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(1),
            end_of_pass_write_index: Some(2),
        }
    }

    /// Resolves the frame's timestamps (recorded after the pass, in the same encoder).
    fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..3, &self.resolved, 0);
    }

    /// The frame's GPU milliseconds (from the encoder's start where it is timed, else from the
    /// pass's) and the render pass's, read back once the frame has run.
    fn read_ms(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<(f64, f64), crate::gpu::GpuError> {
        let encoder = device.create_command_encoder(&Default::default());
        let bytes = crate::gpu::readback::read_back(device, queue, encoder, &self.resolved)?;
        let [start, pass_start, end]: [u64; 3] = bytemuck::pod_read_unaligned(&bytes);
        let ms = |from: u64| end.saturating_sub(from) as f64 * self.period / 1e6;
        let frame = if self.encoder_start {
            start
        } else {
            pass_start
        };
        Ok((ms(frame), ms(pass_start)))
    }
}

impl CrowdBenchReport {
    /// A table: one row per mode, mean and p95 of every figure.
    pub fn summary(&self) -> String {
        let mut out = format!(
            "crowd of {} x {} vertices ({} sampled frames) on {}; path {}; GPU time: {}\n\
             per instance: {:.1} KB host, {:.1} KB GPU; shared asset: {:.1} MB GPU\n\
             mode      set ms (p95)    prepare ms (p95)  record ms (p95)   GPU ms (p95)      pass ms (p95)     wait ms (p95)     upload KB (p95)   writes  triangles  frame switches  draws  indices\n",
            self.instances,
            self.vertices,
            self.frames_sampled,
            self.adapter,
            self.path,
            self.gpu_timing,
            self.host_bytes_per_instance / 1e3,
            self.gpu_bytes_per_instance / 1e3,
            self.shared_gpu_bytes as f64 / 1e6,
        );
        for m in &self.modes {
            let pair = |s: Stat| format!("{:7.2} ({:6.2})", s.mean, s.p95);
            out += &format!(
                "{:9} {}  {}  {}  {}  {}  {}  {:8.1} ({:7.1}) {:6.1} {:10.0} {:6.1} {:14.1} {:8.0}\n",
                m.mode,
                pair(m.set_ms),
                pair(m.prepare_ms),
                pair(m.record_ms),
                pair(m.gpu_ms),
                pair(m.pass_ms),
                pair(m.wait_ms),
                m.uploaded_bytes.mean / 1e3,
                m.uploaded_bytes.p95 / 1e3,
                m.writes.mean,
                m.triangles.mean,
                m.frame_switches.mean,
                m.draws.mean,
                m.indices.mean,
            );
        }
        for (l, level) in self.levels.iter().enumerate() {
            out += &format!(
                "discrete level {l}: {:.2} of the triangles asked, {} triangles, error {:.3e}, {:.1} instances\n",
                level.fraction, level.triangles, level.error, level.instances
            );
        }
        out
    }

    /// The report as one JSON object.
    pub fn to_json(&self) -> String {
        let stat = |s: Stat| serde_json::json!({ "mean": s.mean, "p95": s.p95 });
        let modes: Vec<serde_json::Value> = self
            .modes
            .iter()
            .map(|m| {
                serde_json::json!({
                    "mode": m.mode,
                    "set_ms": stat(m.set_ms),
                    "prepare_ms": stat(m.prepare_ms),
                    "record_ms": stat(m.record_ms),
                    "gpu_ms": stat(m.gpu_ms),
                    "pass_ms": stat(m.pass_ms),
                    "wait_ms": stat(m.wait_ms),
                    "uploaded_bytes": stat(m.uploaded_bytes),
                    "writes": stat(m.writes),
                    "triangles": stat(m.triangles),
                    "frame_switches": stat(m.frame_switches),
                    "draws": stat(m.draws),
                    "indices": stat(m.indices),
                    "frames": m
                        .frames
                        .iter()
                        .map(|f| serde_json::json!([f.cpu_ms, f.gpu_ms, f.triangles]))
                        .collect::<Vec<_>>(),
                })
            })
            .collect();
        serde_json::json!({
            "adapter": self.adapter,
            "instances": self.instances,
            "vertices": self.vertices,
            "frames_sampled": self.frames_sampled,
            "gpu_timing": self.gpu_timing,
            "path": self.path,
            "host_bytes_per_instance": self.host_bytes_per_instance,
            "gpu_bytes_per_instance": self.gpu_bytes_per_instance,
            "shared_gpu_bytes": self.shared_gpu_bytes,
            "frame_columns": ["cpu_ms", "gpu_ms", "triangles"],
            "modes": modes,
            "levels": self
                .levels
                .iter()
                .map(|l| serde_json::json!({
                    "fraction": l.fraction,
                    "triangles": l.triangles,
                    "error": l.error,
                    "instances": l.instances,
                }))
                .collect::<Vec<_>>(),
        })
        .to_string()
    }
}
