//! Resident memory of a `LodObject`, and of a `gpu::Crowd`, drawn frame after frame stays flat.
//!
//! An application draws its objects every frame for hours: any per-frame growth, in morphlod or
//! in how it drives the driver, ends in an out-of-memory kill. Each test draws a weight animation
//! (morph targets, LOD and `t` moving, so frame switches, index uploads and target weights
//! change all the time) for a few thousand frames and measures the process's
//! resident set (`/proc/self/statm`) after a warm-up and at the end: one `LodObject` of the
//! head, and a crowd of two assets, three instances each (cubes with a weight animation: the
//! crowd's unrolled weight sum; grids with LOD: its index-patch scatter; one multi-draw per
//! asset).
//!
//! Bound: at most [`GROWTH_BOUND_MB`] over [`FRAMES`] frames after warm-up. Before the fix
//! (a loop over the targets in the vertex shader, which lavapipe answered with ~0.3 MB of
//! host memory per draw) the object's run grew by about 900 MB; the crowd's grew by 2.4 GB
//! while `shaders/shade.wgsl` branched on the shade mode in the fragment stage.
//!
//! Alone in its test binary: tests running beside it in one process would move its resident set;
//! the two tests here take turns ([`ONE_AT_A_TIME`]).
//! Linux only (`/proc`); elsewhere the test says so and passes.

use std::sync::{Arc, Mutex};

mod common;

use morphlod::gpu::{Crowd, GpuAsset, InstanceId, LodObject, RenderTarget};
use morphlod::{Asset, Builder, DeformingModel, Lod};

/// Frames drawn before the first measurement: pipelines, staging pools and caches fill up.
const WARM_UP: usize = 300;
/// Frames drawn between the two measurements.
const FRAMES: usize = 3000;
/// Largest growth of the resident set allowed over [`FRAMES`] frames.
const GROWTH_BOUND_MB: f64 = 16.0;
/// Instances of the crowd test, half of each asset.
const INSTANCES: u32 = 6;

/// Held by each test while it runs: the other one's allocations would move its resident set.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Resident set size in MB, or `None` where `/proc/self/statm` does not exist.
fn resident_mb() -> Option<f64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: f64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    // statm counts pages; every Linux target morphlod runs on uses 4 KiB pages.
    Some(pages * 4096.0 / 1e6)
}

/// The head's weight animation (8 targets), built with 8 frames.
fn head_asset() -> Asset {
    common::animated_asset("makehuman_head.glb", "morph", 8)
}

/// `t` at frame `frame`: 0 → 1 → 0 over 400 frames (crossing every sampled frame), from
/// `phase` (0 … 1) of the way.
fn ping_pong(frame: usize, phase: f32) -> f32 {
    let x = (frame as f32 / 200.0 + 2.0 * phase) % 2.0;
    if x <= 1.0 {
        x
    } else {
        2.0 - x
    }
}

/// Draws `draw(frame)` for the warm-up and [`FRAMES`] more, then checks the growth of the
/// resident set between the two.
fn assert_flat(what: &str, mut draw: impl FnMut(usize)) {
    (0..WARM_UP).for_each(&mut draw);
    let before = resident_mb().expect("statm");
    (WARM_UP..WARM_UP + FRAMES).for_each(&mut draw);
    let after = resident_mb().expect("statm");
    let growth = after - before;
    eprintln!(
        "{what}: resident set {before:.1} MB after warm-up, {after:.1} MB after {FRAMES} more frames"
    );
    assert!(
        growth <= GROWTH_BOUND_MB,
        "{what}: resident memory grew by {growth:.1} MB over {FRAMES} frames (bound {GROWTH_BOUND_MB} MB)"
    );
}

#[test]
fn lod_object_memory_stays_flat_over_thousands_of_frames() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    if resident_mb().is_none() {
        eprintln!("skipping: no /proc/self/statm on this system");
        return;
    }
    let Some(gpu) = common::gpu::Gpu::new() else {
        return;
    };
    let (device, queue) = (gpu.device(), gpu.queue());
    let asset = head_asset();
    let model = Arc::new(DeformingModel::new(&asset).expect("model"));

    let target = gpu.target(128, 128, wgpu::Color::BLACK);
    let mut object = LodObject::new(device, &gpu.pipeline, &asset, model).expect("object");

    // t runs 0 → 1 → 0 while the LOD sweeps with another period.
    assert_flat("LodObject", |frame| {
        let lod = (frame % 137) as f32 / 136.0;
        object
            .set(ping_pong(frame, 0.0), Lod::Fraction(lod))
            .expect("set");
        object.prepare(queue);
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = target.begin_pass(&mut encoder);
            object.render(&mut pass);
        }
        queue.submit([encoder.finish()]);
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("poll");
    });
}

/// The Khronos AnimatedMorphCube's weight animation (2 targets, normals), built with 6 frames:
/// instances with weights (the crowd's unrolled weight sum and smooth shading) at a fraction of
/// the head's vertex work, which llvmpipe runs on the CPU. Its faces are split at every corner,
/// so it has no LOD: the grid brings the index patches.
fn cube_asset() -> Asset {
    common::animated_asset("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf", "Square", 6)
}

/// A 12 x 12 grid bulging from `V(0)` to `V(1)`, 6 frames: LOD and frame switches, so every
/// frame patches index slots (the scatter), faceted.
fn grid_asset() -> Asset {
    let morph = common::grid_morph(12, |x, y| {
        let (fx, fy) = (x as f32 / 11.0, y as f32 / 11.0);
        0.4 * (3.0 * fx).sin() * (2.0 * fy + 0.3).sin() + 0.1 * (7.0 * fx * fy).sin()
    });
    Builder::new(&morph)
        .frames(6)
        .build()
        .expect("the grid builds")
        .0
}

#[test]
fn crowd_memory_stays_flat_over_thousands_of_frames() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    if resident_mb().is_none() {
        eprintln!("skipping: no /proc/self/statm on this system");
        return;
    }
    let Some(gpu) = common::gpu::Gpu::new() else {
        return;
    };
    let (device, queue) = (gpu.device(), gpu.queue());
    // A tiny target: the cost is the per-frame work, not the pixels.
    let target = gpu.target(32, 32, wgpu::Color::BLACK);
    let mut crowd = Crowd::new(
        device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );
    let mut ids: Vec<InstanceId> = Vec::new();
    for asset in [cube_asset(), grid_asset()] {
        let model = Arc::new(DeformingModel::new(&asset).expect("model"));
        let shared = GpuAsset::from_asset(device, &asset).expect("GPU asset");
        let id = crowd
            .add_asset(device, shared, model, INSTANCES / 2)
            .expect("asset");
        for _ in 0..INSTANCES / 2 {
            let i = ids.len();
            let at = glam::Vec3::new(i as f32 * 0.3 - 0.75, 0.0, 0.0);
            let model =
                glam::Mat4::from_translation(at) * glam::Mat4::from_scale(glam::Vec3::splat(0.2));
            ids.push(crowd.add(id, model).expect("instance"));
        }
    }
    let mut moves = Vec::with_capacity(ids.len());
    let (mut patches, mut tail_jobs) = (0, 0);
    // Every instance at its own phase of t (its own weights and frame) and its own LOD sweep.
    assert_flat("Crowd", |frame| {
        moves.clear();
        for (i, &instance) in ids.iter().enumerate() {
            let phase = i as f32 / INSTANCES as f32;
            let period = 97 + 20 * i;
            let lod = (frame % period) as f32 / (period - 1) as f32;
            moves.push((instance, ping_pong(frame, phase), Lod::Fraction(lod)));
        }
        crowd.set(&moves).expect("set");
        let upload = crowd.prepare(device, queue);
        patches += upload.patches;
        tail_jobs += upload.tail_jobs;
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = target.begin_pass(&mut encoder);
            crowd.render(&mut pass);
        }
        queue.submit([encoder.finish()]);
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("poll");
    });
    assert!(patches > 0, "the LOD sweeps patched no index slot");
    // The tail expansion (a compute loop, the kind of shader that leaked in lavapipe's
    // vertex stage) ran too.
    assert!(tail_jobs > 0, "no instance was drawn from a tail list");
}
