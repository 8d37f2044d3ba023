//! Resident memory of a `LodObject` drawn frame after frame stays flat.
//!
//! An application draws its objects every frame for hours: any per-frame growth, in morphlod or
//! in how it drives the driver, ends in an out-of-memory kill. This test draws the head's
//! weight animation (morph targets, LOD and `t` moving, so frame switches, index uploads and
//! target offsets change all the time) for a few thousand frames and measures the process's
//! resident set (`/proc/self/statm`) after a warm-up and at the end.
//!
//! Bound: at most [`GROWTH_BOUND_MB`] over [`FRAMES`] frames after warm-up. Before the fix
//! (a loop over the targets in the vertex shader, which lavapipe answered with ~0.3 MB of
//! host memory per draw) the same run grew by about 900 MB.
//!
//! Alone in its test binary: tests running beside it in one process would move its resident set.
//! Linux only (`/proc`); elsewhere the test says so and passes.

use std::sync::Arc;

mod common;

use morphlod::gpu::LodObject;
use morphlod::io::LoadOptions;
use morphlod::io::MorphSource;
use morphlod::{Builder, DeformingModel, Lod};

/// Frames drawn before the first measurement: pipelines, staging pools and caches fill up.
const WARM_UP: usize = 300;
/// Frames drawn between the two measurements.
const FRAMES: usize = 3000;
/// Largest growth of the resident set allowed over [`FRAMES`] frames.
const GROWTH_BOUND_MB: f64 = 16.0;

/// Resident set size in MB, or `None` where `/proc/self/statm` does not exist.
fn resident_mb() -> Option<f64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: f64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    // statm counts pages; every Linux target morphlod runs on uses 4 KiB pages.
    Some(pages * 4096.0 / 1e6)
}

#[test]
fn lod_object_memory_stays_flat_over_thousands_of_frames() {
    if resident_mb().is_none() {
        eprintln!("skipping: no /proc/self/statm on this system");
        return;
    }
    let Some(gpu) = common::gpu::Gpu::new() else {
        return;
    };
    let (device, queue) = (gpu.device(), gpu.queue());

    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_head.glb");
    let morph = morphlod::io::load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("morph".into()),
    )
    .expect("the head's weight animation loads");
    let (asset, _) = Builder::new(&morph)
        .frames(8)
        .build()
        .expect("the head builds");
    assert!(asset.blend.is_some(), "the asset carries its morph targets");
    let model = Arc::new(DeformingModel::new(&asset).expect("model"));

    let target = gpu.target(128, 128, wgpu::Color::BLACK);
    let mut object = LodObject::new(device, &gpu.pipeline, &asset, model).expect("object");

    // t runs 0 → 1 → 0 (crossing every sampled frame) while the LOD sweeps with another period.
    let mut draw = |frame: usize| {
        let phase = (frame % 200) as f32 / 199.0;
        let t = if (frame / 200).is_multiple_of(2) {
            phase
        } else {
            1.0 - phase
        };
        let lod = (frame % 137) as f32 / 136.0;
        object.set(t, Lod::Fraction(lod)).expect("set");
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
    };
    (0..WARM_UP).for_each(&mut draw);
    let before = resident_mb().expect("statm");
    (WARM_UP..WARM_UP + FRAMES).for_each(&mut draw);
    let after = resident_mb().expect("statm");
    let growth = after - before;
    eprintln!(
        "resident set: {before:.1} MB after warm-up, {after:.1} MB after {FRAMES} more frames"
    );
    assert!(
        growth <= GROWTH_BOUND_MB,
        "resident memory grew by {growth:.1} MB over {FRAMES} frames (bound {GROWTH_BOUND_MB} MB)"
    );
}
