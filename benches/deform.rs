//! The deforming-mesh runtime on makehuman_body.glb (animation 'morph',
//! 32 frames; `cargo bench --bench deform`):
//!
//! * `switch/*`: a frame switch at 50% LOD (frames 0 ↔ 16 alternately) by
//!   stepping (refine to 0, coarsen under the new frame), by the one-pass
//!   rebuild, and by the automatic choice; each includes `take_dirty`. The CPU-time line
//!   adds a rebuild at 99 % of the collapses, where a crowd's instances are.
//! * `sweep/*`: LOD changes inside one frame, a linear sweep (0 → max → 0 one
//!   step at a time) and an exponential one (jumps that halve, alternating
//!   direction), forced to stepping; throughput = collapses applied.
//! * `build/model`: `DeformingModel::new` from the Asset (32 frames' change lists).
//!
//! Before the timings it prints the sizes: bytes per frame in RAM (change
//! stream alone, and everything a frame holds) and per vertex, and the same
//! runtime figures in CPU time of the thread (from `/proc/thread-self/schedstat`,
//! Linux; fastest of 5 rounds): on a shared, overloaded machine the wall
//! clock that criterion reports also counts time spent waiting for a core.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use morphlod::deform::Strategy;
use morphlod::io::LoadOptions;
use morphlod::io::{load_morph, MorphSource};
use morphlod::{Asset, Builder, DeformingModel, DeformingState, Lod};

const FRAMES: usize = 32;

fn body_asset() -> Asset {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_body.glb");
    let morph = load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("morph".into()),
    )
    .expect("makehuman_body.glb loads");
    let (asset, _) = Builder::new(&morph)
        .frames(FRAMES)
        .build()
        .expect("the body builds");
    asset
}

fn report_sizes(asset: &Asset, model: &DeformingModel) {
    let n = asset.v0.len();
    let stream: Vec<usize> = (0..model.frame_count())
        .filter_map(|k| model.frame_changes(k).map(|f| f.change_bytes()))
        .collect();
    let all = model.frame_bytes();
    let mean = |v: &[usize]| v.iter().sum::<usize>() as f64 / v.len().max(1) as f64;
    let collapses = mean(&asset.frames.iter().map(|f| f.len()).collect::<Vec<_>>());
    println!(
        "makehuman_body: {n} vertices, {} S0 indices, {} strips, {FRAMES} frames, {collapses:.0} collapses/frame",
        asset.s0.indices.len(),
        asset.s0.len()
    );
    println!(
        "per frame in RAM: change stream {:.1} KB ({:.1} B/collapse, {:.1} B/vertex); all frame data {:.1} KB ({:.1} B/vertex); shared S0 + regions {:.1} KB",
        mean(&stream) / 1000.0,
        mean(&stream) / collapses,
        mean(&stream) / n as f64,
        mean(&all) / 1000.0,
        mean(&all) / n as f64,
        model.layout().byte_size() as f64 / 1000.0,
    );
    let copies = mean(
        &(0..model.frame_count())
            .filter_map(|k| model.frame_changes(k).map(|f| f.copy_count()))
            .collect::<Vec<_>>(),
    );
    println!(
        "  of which: collapse pairs, lifetimes of {} S0 slots and {copies:.0} copies, samples and error table {:.1} KB ({:.1} B/vertex)",
        asset.s0.indices.len(),
        (mean(&all) - mean(&stream)) / 1000.0,
        (mean(&all) - mean(&stream)) / n as f64,
    );
}

/// Nanoseconds this thread has run on a CPU, if the kernel reports it.
fn cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// CPU time of `work` divided by `units`, fastest of 5 rounds.
fn cpu_per(units: u64, mut work: impl FnMut()) -> Option<f64> {
    let mut best = f64::MAX;
    for _ in 0..5 {
        let start = cpu_ns()?;
        work();
        best = best.min((cpu_ns()? - start) as f64 / units.max(1) as f64);
    }
    Some(best)
}

/// The LOD targets of the exponential sweep (jumps of max, max/2, ...,
/// alternating up and down, then back to 0) and the collapses they apply.
fn exponential_targets(max: usize) -> (Vec<usize>, u64) {
    let mut targets = Vec::new();
    let (mut span, mut at, mut up, mut moved) = (max, 0usize, true, 0u64);
    while span > 0 {
        let next = if up {
            (at + span).min(max)
        } else {
            at.saturating_sub(span)
        };
        moved += at.abs_diff(next) as u64;
        targets.push(next);
        at = next;
        up = !up;
        span /= 2;
    }
    moved += at as u64;
    targets.push(0);
    (targets, moved)
}

fn report_cpu_times(model: &DeformingModel) {
    let far = 16.0 / (FRAMES - 1) as f32;
    let mut line = String::from("CPU time:");
    // The last at a crowd's LOD: 99 % of the collapses (about 1 % of the triangles).
    for (name, how, lod) in [
        ("switch steps", Strategy::Steps, 0.5),
        ("switch rebuild", Strategy::Rebuild, 0.5),
        ("switch auto", Strategy::Auto, 0.5),
        ("switch rebuild at 99 %", Strategy::Rebuild, 0.99),
    ] {
        let mut state = DeformingState::new(model);
        let _ = state.set(model, 0.0, Lod::Fraction(lod));
        // Enough work per round that the scheduler-tick granularity of the
        // CPU-time counter (a few ms) stays below a few percent.
        let rounds = if how == Strategy::Steps { 200 } else { 4000 };
        let per = cpu_per(rounds, || {
            for i in 0..rounds {
                let t = if i % 2 == 0 { far } else { 0.0 };
                let _ = state.set_with(model, t, Lod::Fraction(lod), how);
                black_box(state.take_dirty());
            }
        });
        line += &format!(" {name} {:.1} µs;", per.unwrap_or(f64::NAN) / 1000.0);
    }
    let max = model.frame_changes(0).map_or(0, |f| f.max_lod());
    let mut state = DeformingState::new(model);
    let repeats = 40;
    let linear = cpu_per(2 * max as u64 * repeats, || {
        for _ in 0..repeats {
            for l in (1..=max).chain((0..max).rev()) {
                let _ = state.set_with(model, 0.0, Lod::Steps(l), Strategy::Steps);
            }
            black_box(state.take_dirty());
        }
    });
    let (targets, moved) = exponential_targets(max);
    let exponential = cpu_per(moved * repeats, || {
        for _ in 0..repeats {
            for &l in &targets {
                let _ = state.set_with(model, 0.0, Lod::Steps(l), Strategy::Steps);
            }
            black_box(state.take_dirty());
        }
    });
    println!(
        "{line} LOD step linear {:.1} ns/collapse, exponential {:.1} ns/collapse",
        linear.unwrap_or(f64::NAN),
        exponential.unwrap_or(f64::NAN)
    );
}

fn bench(c: &mut Criterion) {
    let asset = body_asset();
    let model = DeformingModel::new(&asset).expect("model builds");
    report_sizes(&asset, &model);
    report_cpu_times(&model);
    let mut group = c.benchmark_group("deform");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));

    let far = 16.0 / (FRAMES - 1) as f32;
    for (name, how) in [
        ("switch/steps", Strategy::Steps),
        ("switch/rebuild", Strategy::Rebuild),
        ("switch/auto", Strategy::Auto),
    ] {
        let mut state = DeformingState::new(&model);
        state
            .set(&model, 0.0, Lod::Fraction(0.5))
            .expect("valid request");
        let mut flip = false;
        group.throughput(Throughput::Elements(1));
        group.bench_function(name, |b| {
            b.iter(|| {
                flip = !flip;
                let t = if flip { far } else { 0.0 };
                let used = state.set_with(&model, t, Lod::Fraction(0.5), how);
                black_box(state.take_dirty());
                used
            })
        });
    }

    let mut state = DeformingState::new(&model);
    let max = model.frame_changes(0).map_or(0, |f| f.max_lod());
    group.throughput(Throughput::Elements(2 * max as u64));
    group.bench_function("sweep/linear", |b| {
        b.iter(|| {
            for l in (1..=max).chain((0..max).rev()) {
                let _ = state.set_with(&model, 0.0, Lod::Steps(l), Strategy::Steps);
            }
            black_box(state.take_dirty());
        })
    });
    let (targets, moved) = exponential_targets(max);
    group.throughput(Throughput::Elements(moved));
    group.bench_function("sweep/exponential", |b| {
        b.iter(|| {
            for &l in &targets {
                let _ = state.set_with(&model, 0.0, Lod::Steps(l), Strategy::Steps);
            }
            black_box(state.take_dirty());
        })
    });

    group.throughput(Throughput::Elements(FRAMES as u64));
    group.sample_size(10);
    group.bench_function("build/model", |b| {
        b.iter(|| DeformingModel::new(black_box(&asset)))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
