//! The frame-rate benchmark of the papers: a deforming object animated over `t = 0 → 1` while
//! its LOD sweeps from full detail to the coarsest, linearly and exponentially, drawn three ways
//! in the same run on the same adapter:
//!
//! * **strips** — a [`LodObject`]: `set(t, lod)`, `prepare`, one multi-draw;
//! * **list** — the same triangles as a plain triangle list, rebuilt and re-uploaded per frame
//!   (what an application without LOD strips does to show the same LOD);
//! * **full** — full detail without LOD: the strips `S0` and, for the full-detail ratio, the
//!   same triangles as a list, both uploaded once; the strips also drawn with one indirect
//!   record per strip ([`Draws::PerRegion`]) beside the default grouped records, so the run
//!   shows what grouping saves.
//!
//! The list of a frame is the live strips decoded into triangles
//! ([`morphlod::strip::strip_triangles`]): one pass over the live indices, cheaper than
//! [`CollapseSequence::reference_mesh`](morphlod::collapse::CollapseSequence::reference_mesh)
//! (which resolves every vertex's survivor and maps every original triangle) and drawing the
//! identical triangle multiset (the oracle tests check strips against the reference mesh).
//!
//! Every object is shaded in [`BenchOptions::shade`] (textured by default, which an asset
//! without a surface draws faceted); each frame the strips are also drawn faceted, so the run
//! shows what smooth shading and the texture cost against the flat shading on the same frames.
//!
//! GPU frame time is the wall time of `queue.submit` plus `device.poll(wait)` for one pass that
//! draws one object into an offscreen target, the fastest of [`BenchOptions::repeats`] such
//! passes per object and frame: the first also flushes the frame's staged `write_buffer`
//! copies, the others draw the same state again. CPU time of `set` and `prepare` is measured
//! around the calls.
//! `plot.rs` draws the rows; the JSON holds them all.

use std::fmt::Write as _;
use std::sync::Arc;
use std::time::Instant;

use morphlod::asset::Asset;
use morphlod::deform::{DeformingModel, Lod};
use morphlod::gpu::camera::frame_both_poses;
use morphlod::gpu::{
    s0_regions, BuildAhead, Context, DrawCounter, Draws, GpuError, LodObject, MorphPipeline,
    Object, RenderTarget, ShadeMode, Topology,
};
use morphlod::strip::strip_triangles;
use morphlod::Error;

/// A frame at 24 frames per second, in milliseconds: the budget the CPU cost is compared to.
pub const FRAME_24FPS_MS: f64 = 1000.0 / 24.0;

/// How LOD moves over the animation (`x = frame / (frames − 1)`, `t = x`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sweep {
    /// LOD fraction `x`.
    Linear,
    /// LOD fraction `(1024^x − 1) / 1023`: long near full detail, fast at the end, so most
    /// frames change the LOD by few collapses.
    Exponential,
}

impl Sweep {
    /// The sweep's name in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Sweep::Linear => "linear",
            Sweep::Exponential => "exponential",
        }
    }

    /// The LOD fraction at position `x` in `[0, 1]`.
    pub fn fraction(self, x: f32) -> f32 {
        match self {
            Sweep::Linear => x,
            Sweep::Exponential => (1024f32.powf(x) - 1.0) / 1023.0,
        }
    }
}

/// Benchmark settings.
#[derive(Clone, Copy, Debug)]
pub struct BenchOptions {
    /// Frames per sweep (at least 2).
    pub frames: usize,
    /// Width and height of the offscreen target, in pixels.
    pub size: u32,
    /// Draws of each object per frame; its GPU time is the fastest (at least 1). One sample a
    /// frame on a shared machine is mostly scheduling noise; the minimum of a few is the cost.
    pub repeats: usize,
    /// How every object is shaded (an asset without a surface draws faceted whatever this
    /// says).
    pub shade: ShadeMode,
    /// Whether the strips object builds its next frames ahead (`LodObject::set_build_ahead`).
    pub build_ahead: BuildAhead,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            frames: 240,
            size: 512,
            repeats: 3,
            shade: ShadeMode::Textured,
            build_ahead: BuildAhead::Auto,
        }
    }
}

/// What one frame of one sweep measured.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRow {
    pub sweep: Sweep,
    pub frame: usize,
    pub t: f32,
    /// The requested LOD fraction.
    pub lod: f32,
    /// The sampled animation frame and the LOD in its collapses.
    pub asset_frame: usize,
    pub steps: usize,
    /// Triangles and live indices the strips draw.
    pub triangles: usize,
    pub indices: usize,
    /// CPU time of `LodObject::set` and `LodObject::prepare`, microseconds.
    pub set_us: f64,
    pub prepare_us: f64,
    /// Whether this frame's `set` switched to a frame built ahead (`BuildAhead`).
    pub built_ahead: bool,
    /// Index and indirect bytes the strips uploaded this frame.
    pub upload_bytes: u64,
    /// `write_buffer` calls of that upload (index and indirect; uniforms not counted).
    pub upload_writes: usize,
    /// Draw calls the strips object issued this frame.
    pub draws: u64,
    /// Indirect draw records in the strips object's one multi-draw.
    pub records: usize,
    pub strips_ms: f64,
    /// The same strips in the same frame, drawn faceted (equal to `strips_ms` up to noise when
    /// the shade mode is faceted).
    pub faceted_ms: f64,
    /// Triangles of the list and the CPU time to decode it, microseconds.
    pub list_triangles: usize,
    pub list_build_us: f64,
    /// Index and indirect bytes the list uploaded this frame.
    pub list_upload_bytes: u64,
    pub list_ms: f64,
    /// Full detail without LOD: strips `S0` and the same triangles as a list.
    pub full_strips_ms: f64,
    pub full_list_ms: f64,
    /// Full-detail strips `S0` drawn with one indirect record per strip.
    pub full_per_strip_ms: f64,
}

/// A whole benchmark run.
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub adapter: String,
    pub backend: String,
    pub device_type: String,
    pub vertices: usize,
    /// Triangles and bytes of the whole strip index buffer at full detail.
    pub full_triangles: usize,
    pub full_index_bytes: u64,
    pub rows: Vec<FrameRow>,
}

/// Runs both sweeps over `asset` (with its runtime `model`) on `context`'s device.
pub fn run_bench(
    context: &Context,
    asset: &Asset,
    model: &Arc<DeformingModel>,
    options: &BenchOptions,
) -> Result<BenchReport, Error> {
    let (device, queue) = (&context.device, &context.queue);
    let frames = options.frames.max(2);
    let target = RenderTarget::new(device, options.size, options.size, wgpu::Color::BLACK)?;
    let pipeline = MorphPipeline::new(
        device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );
    let camera = frame_both_poses(asset, glam::Vec3::new(-0.35, -0.15, -1.0))?.view_proj();

    let regions = s0_regions(model);
    // Strip by strip: the regions hold no restart between strips.
    let full_list: Vec<u32> = regions
        .iter()
        .flat_map(|strip| strip_triangles(strip))
        .flatten()
        .collect();
    let full_triangles = full_list.len() / 3;
    // Every object carries the asset's surface and targets, so all draw the same pose and
    // shading.
    let list_object = |live: &[u32]| {
        Object::from_asset(device, &pipeline, Topology::List, asset, &[live.to_vec()])
    };
    let full_s0 = || Object::from_asset(device, &pipeline, Topology::Strip, asset, &regions);
    let mut full_strips = full_s0()?;
    let mut full_per_strip = full_s0()?;
    full_per_strip.set_draws(Draws::PerRegion)?;
    let mut full = list_object(&full_list)?;
    // The per-frame list starts as the full list too: its region has room for every triangle.
    let mut list = list_object(&full_list)?;
    let track = asset.blend.as_ref().map(|blend| &blend.track);
    for object in [&mut full_strips, &mut full_per_strip, &mut full, &mut list] {
        object.set_view_proj(camera);
        object.set_shade_mode(options.shade);
    }

    let repeats = options.repeats.max(1);
    // The fastest of `count` draws of `object`; the first also carries the frame's uploads.
    let fastest = |target: &RenderTarget, object: &Object, count: usize| {
        (0..count).try_fold(f64::INFINITY, |best, _| {
            gpu_frame(device, queue, target, object).map(|(ms, _)| best.min(ms))
        })
    };
    let mut rows = Vec::with_capacity(2 * frames);
    for sweep in [Sweep::Linear, Sweep::Exponential] {
        let mut strips = LodObject::new(device, &pipeline, asset, Arc::clone(model))?;
        strips.set_view_proj(camera);
        strips.set_shade_mode(options.shade);
        strips.set_build_ahead(options.build_ahead);
        // Warm-up: first draws create pipelines' backing state and fill caches.
        strips.prepare(queue);
        gpu_frame(device, queue, &target, strips.object())?;
        for i in 0..frames {
            let x = i as f32 / (frames - 1) as f32;
            let (t, lod) = (x, sweep.fraction(x));

            // As an application would: the index scatter rides in the frame's one submission.
            // The encoder is the application's (made every frame with or without LOD), so it
            // is made before the timers.
            let mut encoder = device.create_command_encoder(&Default::default());
            let taken = strips.state().switches_built_ahead();
            let start = Instant::now();
            strips.set(t, Lod::Fraction(lod))?;
            let set_us = micros(start);
            let built_ahead = strips.state().switches_built_ahead() > taken;
            let start = Instant::now();
            let upload = strips.prepare_with(queue, &mut encoder);
            let prepare_us = micros(start);
            let (first_ms, draws) = gpu_frame_in(device, queue, &target, strips.object(), encoder)?;
            let strips_ms = first_ms.min(fastest(&target, strips.object(), repeats - 1)?);
            // The same state faceted; the switch uploads the uniforms, which the first of the
            // repeated draws carries (so at least two draws).
            strips.set_shade_mode(ShadeMode::Faceted);
            strips.prepare(queue);
            let faceted_ms = fastest(&target, strips.object(), repeats.max(2))?;
            strips.set_shade_mode(options.shade);
            strips.prepare(queue);

            let start = Instant::now();
            let (mut live, mut strip) = (Vec::new(), Vec::new());
            for s in 0..strips.object().region_count() {
                // The runtime's strip widened (it may be `u16`) into one reused buffer.
                strip.clear();
                if let Some(indices) = strips.state().strip(s) {
                    indices.extend_mapped(&mut strip, |_, v| v);
                }
                live.extend(strip_triangles(&strip).flatten());
            }
            let list_build_us = micros(start);
            list.write_region(0, &live)?;
            list.set_pose(t, track)?;
            let list_upload = list.prepare(queue);
            let list_ms = fastest(&target, &mut list, repeats)?;

            full_strips.set_pose(t, track)?;
            full_strips.prepare(queue);
            let full_strips_ms = fastest(&target, &mut full_strips, repeats)?;
            full.set_pose(t, track)?;
            full.prepare(queue);
            let full_list_ms = fastest(&target, &mut full, repeats)?;
            full_per_strip.set_pose(t, track)?;
            full_per_strip.prepare(queue);
            let full_per_strip_ms = fastest(&target, &mut full_per_strip, repeats)?;

            let state = strips.state();
            rows.push(FrameRow {
                sweep,
                frame: i,
                t,
                lod,
                asset_frame: state.frame(),
                steps: state.lod(),
                triangles: state.triangle_count(),
                indices: state.index_count(),
                set_us,
                prepare_us,
                built_ahead,
                upload_bytes: upload.geometry_bytes(),
                upload_writes: upload.geometry_writes(),
                draws,
                records: strips.object().indirect_args().len(),
                strips_ms,
                faceted_ms,
                list_triangles: live.len() / 3,
                list_build_us,
                list_upload_bytes: list_upload.geometry_bytes(),
                list_ms,
                full_strips_ms,
                full_list_ms,
                full_per_strip_ms,
            });
        }
    }
    let info = context.adapter_info();
    Ok(BenchReport {
        adapter: info.name,
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        vertices: asset.v0.len(),
        full_triangles,
        full_index_bytes: model.layout().s0().len() as u64 * 4,
        rows,
    })
}

pub(crate) fn micros(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e6
}

/// Draws `object` alone into `target` and returns the milliseconds of submit + wait.
pub(crate) fn gpu_frame(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    target: &RenderTarget,
    object: &Object,
) -> Result<(f64, u64), GpuError> {
    let encoder = device.create_command_encoder(&Default::default());
    gpu_frame_in(device, queue, target, object, encoder)
}

/// [`gpu_frame`] recorded after what `encoder` already holds (a scatter from
/// `Object::prepare_with`).
fn gpu_frame_in(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    target: &RenderTarget,
    object: &Object,
    mut encoder: wgpu::CommandEncoder,
) -> Result<(f64, u64), GpuError> {
    let draws = {
        let mut pass = target.begin_pass(&mut encoder);
        let mut counter = DrawCounter::new(&mut pass);
        object.render(&mut counter);
        counter.draw_calls
    };
    let command = encoder.finish();
    let start = Instant::now();
    queue.submit([command]);
    device.poll(wgpu::PollType::wait_indefinitely())?;
    Ok((start.elapsed().as_secs_f64() * 1e3, draws))
}

fn mean(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.iter().sum::<f64>() / values.len() as f64
}

fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    match sorted.len() {
        0 => 0.0,
        n if n % 2 == 1 => sorted[n / 2],
        n => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
    }
}

/// Pearson correlation of two equally long series (0 when either is constant).
fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let (ma, mb) = (mean(a), mean(b));
    let (mut cov, mut va, mut vb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        cov += (x - ma) * (y - mb);
        va += (x - ma) * (x - ma);
        vb += (y - mb) * (y - mb);
    }
    if va == 0.0 || vb == 0.0 {
        return 0.0;
    }
    cov / (va * vb).sqrt()
}

impl BenchReport {
    fn column(&self, sweep: Sweep, f: impl Fn(&FrameRow) -> f64) -> Vec<f64> {
        self.rows
            .iter()
            .filter(|r| r.sweep == sweep)
            .map(f)
            .collect()
    }

    /// Per row, whether it moved to another sampled frame than the row before it in its sweep
    /// (`None` for a sweep's first row).
    fn frame_switches(&self) -> Vec<Option<bool>> {
        let mut previous: Option<&FrameRow> = None;
        self.rows
            .iter()
            .map(|row| {
                let switched = previous
                    .filter(|p| p.sweep == row.sweep)
                    .map(|p| p.asset_frame != row.asset_frame);
                previous = Some(row);
                switched
            })
            .collect()
    }

    /// The summary table and the goals, met or not, as text.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "adapter: {} ({}, {}); {} vertices, {} triangles, full index buffer {} bytes",
            self.adapter,
            self.backend,
            self.device_type,
            self.vertices,
            self.full_triangles,
            self.full_index_bytes
        );
        let _ = writeln!(
            out,
            "{:<12} {:<20} {:>12} {:>12}",
            "sweep", "measure", "mean", "median"
        );
        type Column = (&'static str, fn(&FrameRow) -> f64);
        let columns: [Column; 16] = [
            ("triangles", |r| r.triangles as f64),
            ("set us", |r| r.set_us),
            ("prepare us", |r| r.prepare_us),
            ("upload B (strips)", |r| r.upload_bytes as f64),
            ("upload writes", |r| r.upload_writes as f64),
            ("list build us", |r| r.list_build_us),
            ("upload B (list)", |r| r.list_upload_bytes as f64),
            ("GPU ms strips", |r| r.strips_ms),
            ("GPU ms faceted", |r| r.faceted_ms),
            ("strips/faceted", |r| r.strips_ms / r.faceted_ms.max(1e-9)),
            ("GPU ms list", |r| r.list_ms),
            ("GPU ms full strips", |r| r.full_strips_ms),
            ("GPU ms full list", |r| r.full_list_ms),
            ("GPU ms full 1/strip", |r| r.full_per_strip_ms),
            ("draw records", |r| r.records as f64),
            ("strips/list", |r| r.strips_ms / r.list_ms.max(1e-9)),
        ];
        for sweep in [Sweep::Linear, Sweep::Exponential] {
            for (name, f) in columns {
                let values = self.column(sweep, f);
                let _ = writeln!(
                    out,
                    "{:<12} {:<20} {:>12.3} {:>12.3}",
                    sweep.name(),
                    name,
                    mean(&values),
                    median(&values)
                );
            }
        }

        let all = |f: fn(&FrameRow) -> f64| -> Vec<f64> { self.rows.iter().map(f).collect() };
        let full_ratio =
            median(&all(|r| r.full_strips_ms)) / median(&all(|r| r.full_list_ms)).max(1e-9);
        let per_strip_ratio =
            median(&all(|r| r.full_per_strip_ms)) / median(&all(|r| r.full_list_ms)).max(1e-9);
        let cpu = mean(&all(|r| (r.set_us + r.prepare_us) / 1e3));
        let cpu_max = all(|r| (r.set_us + r.prepare_us) / 1e3)
            .into_iter()
            .fold(0.0, f64::max);
        let cpu_percent = 100.0 * cpu / FRAME_24FPS_MS;
        let upload = mean(&self.column(Sweep::Exponential, |r| r.upload_bytes as f64));
        let upload_percent = 100.0 * upload / (self.full_index_bytes.max(1) as f64);
        // Frames that moved to another sampled frame (connectivity changes) against the rest.
        // Upload bytes: the exponential sweep's switches and its other frames after its first.
        // CPU: where the mean goes, the frame switches (a rebuild each) and the other frames.
        let (mut switching, mut staying) = (Vec::new(), Vec::new());
        let (mut switch_ms, mut other_ms, mut built_ahead) = (Vec::new(), Vec::new(), 0);
        for (row, switched) in self.rows.iter().zip(self.frame_switches()) {
            let (bytes, ms) = (row.upload_bytes as f64, (row.set_us + row.prepare_us) / 1e3);
            match switched {
                Some(true) => switch_ms.push(ms),
                _ => other_ms.push(ms),
            }
            built_ahead += usize::from(row.built_ahead);
            match switched {
                Some(true) if row.sweep == Sweep::Exponential => switching.push(bytes),
                Some(false) if row.sweep == Sweep::Exponential => staying.push(bytes),
                _ => {}
            }
        }
        let share = |ms: &[f64]| ms.iter().sum::<f64>() / self.rows.len().max(1) as f64;
        let linear_tris = self.column(Sweep::Linear, |r| r.triangles as f64);
        let linear_ms = self.column(Sweep::Linear, |r| r.strips_ms);
        let falls = correlation(&linear_tris, &linear_ms);
        let met = |ok: bool| if ok { "met" } else { "NOT met" };
        let _ = writeln!(out, "goals:");
        let _ = writeln!(
            out,
            "  full-detail strips / list GPU time (medians): {full_ratio:.3} (goal <= 1.05: {})",
            met(full_ratio <= 1.05)
        );
        let _ = writeln!(
            out,
            "    (the same strips with one indirect record per strip: {per_strip_ratio:.3})"
        );
        let _ = writeln!(
            out,
            "  frame time vs triangles, linear sweep, correlation: {falls:.3} (goal > 0, time falls with triangles: {})",
            met(falls > 0.0)
        );
        let _ = writeln!(
            out,
            "  CPU set+prepare: mean {cpu:.4} ms = {cpu_percent:.3}% of a 24 fps frame (goal <= 1%: {}), max {cpu_max:.4} ms (goal <= 2 ms: {})",
            met(cpu_percent <= 1.0),
            met(cpu_max <= 2.0)
        );
        let _ = writeln!(
            out,
            "    ({} frame switches, {} of them to a frame built ahead: median {:.3} ms, {:.3} ms of the mean; {} other frames: median {:.3} ms, {:.3} ms of the mean)",
            switch_ms.len(),
            built_ahead,
            median(&switch_ms),
            share(&switch_ms),
            other_ms.len(),
            median(&other_ms),
            share(&other_ms)
        );
        let _ = writeln!(
            out,
            "  exponential sweep upload: mean {upload:.0} B = {upload_percent:.2}% of a full index upload (goal <= 5%: {})",
            met(upload_percent <= 5.0)
        );
        let _ = writeln!(
            out,
            "    ({} frame switches: mean {:.0} B; {} other frames: mean {:.0} B, median {:.0} B)",
            switching.len(),
            mean(&switching),
            staying.len(),
            mean(&staying),
            median(&staying)
        );
        out
    }

    /// The run as JSON: adapter, sizes and one object per frame row.
    pub fn to_json(&self) -> String {
        let mut out = String::new();
        let _ = write!(
            out,
            "{{\"adapter\":{},\"backend\":{},\"device_type\":{},\"vertices\":{},\"full_triangles\":{},\"full_index_bytes\":{},\"rows\":[",
            serde_json::Value::from(self.adapter.as_str()),
            serde_json::Value::from(self.backend.as_str()),
            serde_json::Value::from(self.device_type.as_str()),
            self.vertices,
            self.full_triangles,
            self.full_index_bytes
        );
        for (i, r) in self.rows.iter().enumerate() {
            let _ = write!(
                out,
                "{}\n{{\"sweep\":\"{}\",\"frame\":{},\"t\":{},\"lod\":{},\"asset_frame\":{},\"steps\":{},\"triangles\":{},\"indices\":{},\"set_us\":{:.3},\"prepare_us\":{:.3},\"built_ahead\":{},\"upload_bytes\":{},\"upload_writes\":{},\"draws\":{},\"records\":{},\"strips_ms\":{:.4},\"faceted_ms\":{:.4},\"list_triangles\":{},\"list_build_us\":{:.3},\"list_upload_bytes\":{},\"list_ms\":{:.4},\"full_strips_ms\":{:.4},\"full_list_ms\":{:.4},\"full_per_strip_ms\":{:.4}}}",
                if i == 0 { "" } else { "," },
                r.sweep.name(),
                r.frame,
                r.t,
                r.lod,
                r.asset_frame,
                r.steps,
                r.triangles,
                r.indices,
                r.set_us,
                r.prepare_us,
                r.built_ahead,
                r.upload_bytes,
                r.upload_writes,
                r.draws,
                r.records,
                r.strips_ms,
                r.faceted_ms,
                r.list_triangles,
                r.list_build_us,
                r.list_upload_bytes,
                r.list_ms,
                r.full_strips_ms,
                r.full_list_ms,
                r.full_per_strip_ms
            );
        }
        out.push_str("\n]}\n");
        out
    }
}

/// `s` as a JSON string literal.
/// `bench_rows_are_consistent`: a short `run_bench` on a small morphing grid: row count, one
/// draw per frame, triangle counts equal to the reference mesh of `docs/DESIGN.md`
/// (`CollapseSequence::reference_mesh`) and to the list drawn beside, uploads exactly where the
/// strips changed, and the JSON holds every row. Uses `gpu::test_context`: fails without an
/// adapter under CI (`morphlod::ci::is_ci`), skips elsewhere.
#[cfg(test)]
mod tests {
    use super::*;
    use morphlod::{gpu, Builder, Morph};

    /// An `n × n` vertex grid in the xy plane (`V(0)`) that bulges along z (`V(1)`), built into an
    /// asset of `frames` sampled frames.
    fn grid_asset(n: u32, frames: usize) -> Asset {
        let mut v0 = Vec::new();
        let mut v1 = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let (fx, fy) = (x as f32 / (n - 1) as f32, y as f32 / (n - 1) as f32);
                // Slightly uneven heights so the simplifier's errors are not all tied.
                let z0 = 0.05 * (7.0 * fx + 3.0 * fy).sin();
                v0.push([fx - 0.5, fy - 0.5, z0]);
                let bulge = (std::f32::consts::PI * fx).sin() * (std::f32::consts::PI * fy).sin();
                v1.push([fx - 0.5, fy - 0.5, z0 + 0.4 * bulge]);
            }
        }
        let mut triangles = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let i = y * n + x;
                triangles.push([i, i + 1, i + n]);
                triangles.push([i + 1, i + n + 1, i + n]);
            }
        }
        let morph = Morph::from_poses(triangles, v0, v1).expect("valid grid morph");
        Builder::new(&morph)
            .frames(frames)
            .build()
            .expect("grid asset builds")
            .0
    }

    #[test]
    fn bench_rows_are_consistent() -> Result<(), Error> {
        let Some(ctx) = gpu::test_context()? else {
            return Ok(());
        };
        let asset = grid_asset(10, 4);
        let model = Arc::new(DeformingModel::new(&asset)?);
        let frames = 7;
        let report = run_bench(
            &ctx,
            &asset,
            &model,
            &BenchOptions {
                frames,
                size: 48,
                repeats: 2,
                shade: ShadeMode::Textured,
                build_ahead: BuildAhead::Always,
            },
        )?;
        let original: Vec<[u32; 3]> = (0..asset.s0.len())
            .filter_map(|i| asset.s0.strip(i))
            .flat_map(strip_triangles)
            .collect();
        assert_eq!(report.full_triangles, original.len());
        assert_eq!(report.full_index_bytes, asset.s0.indices.len() as u64 * 4);
        assert_eq!(report.rows.len(), 2 * frames);

        for sweep in [Sweep::Linear, Sweep::Exponential] {
            let rows: Vec<_> = report.rows.iter().filter(|r| r.sweep == sweep).collect();
            assert_eq!(rows.len(), frames);
            // Every sweep starts from a fresh object at frame 0, full detail.
            let mut previous = (0usize, 0usize, asset.s0.indices.len());
            for row in &rows {
                let at = format!("{} frame {}", sweep.name(), row.frame);
                assert_eq!(row.draws, 1, "{at}: one draw per frame");
                let reference = asset.frames[row.asset_frame].reference_mesh(&original, row.steps);
                assert_eq!(row.triangles, reference.len(), "{at}: reference mesh");
                assert_eq!(row.list_triangles, row.triangles, "{at}: list beside");
                let now = (row.asset_frame, row.steps, row.indices);
                if row.indices != previous.2 {
                    assert!(
                        row.upload_bytes > 0,
                        "{at}: strips changed, nothing uploaded"
                    );
                }
                if now == previous || (row.steps == 0 && previous.1 == 0) {
                    assert_eq!(row.upload_bytes, 0, "{at}: nothing changed, bytes uploaded");
                }
                assert!(row.strips_ms > 0.0 && row.list_ms > 0.0 && row.full_strips_ms > 0.0);
                previous = now;
            }
            let first = rows.first().expect("rows");
            assert_eq!((first.steps, first.triangles), (0, original.len()));
            let last = rows.last().expect("rows");
            let last_frame = asset.frames.len() - 1;
            assert_eq!(
                (last.asset_frame, last.steps),
                (last_frame, asset.frames[last_frame].len()),
                "{}: the sweep ends at the coarsest LOD of the last frame",
                sweep.name()
            );
        }
        // Both sweeps pass every sampled frame once, in order; a sweep's first row (frame 0,
        // after the other sweep's last) is no switch.
        let switched = report.frame_switches();
        assert_eq!((switched[0], switched[frames]), (None, None));
        let switches = switched.iter().filter(|s| **s == Some(true)).count();
        assert_eq!(switches, 2 * (asset.frames.len() - 1));
        // Only a frame switch takes a frame built ahead.
        for (row, switched) in report.rows.iter().zip(&switched) {
            assert!(
                !row.built_ahead || *switched == Some(true),
                "row {}",
                row.frame
            );
        }
        let json = report.to_json();
        assert_eq!(json.matches("\"sweep\":").count(), report.rows.len());
        assert!(report.summary().contains("goals:"));
        Ok(())
    }
}
