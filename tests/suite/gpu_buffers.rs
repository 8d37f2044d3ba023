//! What the GPU really holds: after every `prepare`, the object's index and indirect buffers are
//! copied back from the device and the triangles one `multi_draw_indexed_indirect` over them
//! draws are decoded by the GPU's own rules (`common::gpu::draw_indexed_indirect`: records,
//! restarts, strip parity, degenerate triangles skipped). They must be the reference mesh of
//! DESIGN.md as a multiset of oriented triangles: one lost, extra or flipped triangle fails,
//! where the pixel oracle (tests/suite/image_oracle.rs) sees a single lost triangle only sometimes.
//!
//! * `object_draws_the_reference_mesh_over_lods`: a single-sequence `gpu::Object` (cow, QEM
//!   sequence) driven by the LOD runtime's dirty logs over a random walk of LODs, in all three
//!   draw groupings.
//! * `lod_object_draws_frame_k_over_a_walk_with_frame_switches`: a `LodObject` (makehuman_head's
//!   weight animation, built by `Builder`) over a random walk of `(t, lod)` with frame switches;
//!   at every step the reference mesh of frame `k = round(t (|r| - 1))` at the current LOD.
//! * `exponential_sweep_uploads_at_most_5_percent`: the upload goal of issue 5 asserted:
//!   mean index + indirect bytes per frame (writes and patch lists, as sent) over the bench's
//!   exponential sweep ≤ 5% of the full index buffer.
//! * `scattered_edits_are_patched_and_every_patch_lands`: frames of many scattered edits go
//!   through the index scatter (exactly the changed words, huge runs as writes, few spans as
//!   writes only), and the buffer read back equals the mirror with every changed word at its
//!   new value: a dropped or misplaced patch fails.
//! * `lod_walk_with_frame_switches_reads_back_as_the_mirror`: the head's `LodObject` over a
//!   random walk of LOD steps and frame switches; after every `prepare` the GPU index buffer
//!   equals the mirror, and the walk used both the scatter and writes-only frames.
//! * `apply_dirty_on_the_pool_matches_write_region`: random dirty logs, frame switches large
//!   enough for `apply_dirty`'s pooled path among them, give the mirror, records and uploads
//!   of `write_region` per touched strip; the mirror is the layout built from scratch (live
//!   strips, restarts up to each capacity, separators; some strips hundreds of slots long),
//!   and the buffer read back equals the mirror.
//!
//! GPU set-up: `common::gpu::Gpu` (fails without an adapter when `CI` is set: `morphlod::ci::is_ci`).

use crate::common;

use std::path::Path;
use std::sync::Arc;

use common::gpu::Gpu;
use common::Rng;
use morphlod::collapse::canonical_multiset;
use morphlod::gpu::{Draws, LodObject, Object, Topology, Upload, RESTART};
use morphlod::io::MorphSource;
use morphlod::io::{load_mesh, LoadOptions};
use morphlod::lodstrips::{Dirty, DirtyRange, LodStrips, StripsState};
use morphlod::morph::Morph;
use morphlod::simplify::{simplify, SimplifyOptions};
use morphlod::strip::stripify;
use morphlod::{Asset, Builder, DeformingModel, Lod};

fn asset_path(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name)
}

fn head_morph() -> Morph {
    morphlod::io::load_morph(
        &asset_path("makehuman_head.glb"),
        &LoadOptions::default(),
        &MorphSource::Animation("morph".into()),
    )
    .expect("the head's animation loads")
}

/// The head's animation built with `frames` sampled frames, and its shared model.
fn head_asset(frames: usize) -> (Morph, Asset, Arc<DeformingModel>) {
    let morph = head_morph();
    let (asset, _) = Builder::new(&morph)
        .frames(frames)
        .build()
        .expect("the head builds");
    let model = Arc::new(DeformingModel::new(&asset).expect("the built asset is valid"));
    (morph, asset, model)
}

/// Fails with the first differences between two canonical multisets.
fn assert_same_triangles(drawn: &[[u32; 3]], reference: &[[u32; 3]], what: &str) {
    if drawn == reference {
        return;
    }
    let missing: Vec<_> = reference
        .iter()
        .filter(|t| !drawn.contains(t))
        .take(5)
        .collect();
    let extra: Vec<_> = drawn
        .iter()
        .filter(|t| !reference.contains(t))
        .take(5)
        .collect();
    panic!(
        "{what}: the GPU draws {} triangles, the reference has {}; missing (first 5) {missing:?}, \
         extra {extra:?}",
        drawn.len(),
        reference.len()
    );
}

#[test]
fn object_draws_the_reference_mesh_over_lods() {
    let Some(gpu) = Gpu::new() else {
        return;
    };
    let mesh = load_mesh(&asset_path("cow.off"), &LoadOptions::default()).expect("cow loads");
    let strips = stripify(&mesh.triangles, mesh.positions.len());
    let seq = simplify(
        &mesh.positions,
        &mesh.triangles,
        &SimplifyOptions::default(),
    );
    let model = LodStrips::build(&strips, &seq).expect("the cow's model builds");
    let max = model.max_lod();
    let mut rng = Rng(0xC0_FFEE);
    for draws in [
        Draws::Grouped {
            max_indices: morphlod::gpu::GROUP_INDICES,
        },
        Draws::Grouped { max_indices: 256 },
        Draws::PerRegion,
    ] {
        let mut state = StripsState::new(&model);
        let regions: Vec<Vec<u32>> = (0..model.strip_count())
            .map(|s| state.strip(s).unwrap_or_default().to_vec())
            .collect();
        let mut object = Object::new(
            gpu.device(),
            &gpu.pipeline,
            Topology::Strip,
            &mesh.positions,
            &mesh.positions,
            &regions,
        )
        .expect("the cow uploads");
        object.set_draws(draws).expect("strip objects group");
        let mut lod = 0usize;
        for step in 0..40 {
            // Jumps anywhere, small steps up and down, both ends.
            lod = match rng.below(5) {
                0 => rng.below(max + 1),
                1 => lod.saturating_sub(1 + rng.below(20)),
                2 => (lod + 1 + rng.below(20)).min(max),
                3 => 0,
                _ => max - rng.below(max / 10 + 1),
            };
            state.set_lod(&model, lod).expect("same model");
            let dirty = state.take_dirty();
            object
                .apply_dirty(&dirty, state.indices(), state.lengths())
                .expect("the runtime's dirty log fits the object");
            object.prepare(gpu.queue());
            let drawn = gpu.drawn_by(&object, mesh.positions.len());
            let what = format!("{draws:?} step {step}, LOD {lod} of {max}");
            assert!(
                drawn.indices == object.index_mirror(),
                "{what}: the GPU index buffer differs from the object's mirror"
            );
            assert_same_triangles(
                &canonical_multiset(drawn.triangles),
                &canonical_multiset(seq.reference_mesh(&mesh.triangles, lod)),
                &what,
            );
        }
    }
}

#[test]
fn lod_object_draws_frame_k_over_a_walk_with_frame_switches() {
    let Some(gpu) = Gpu::new() else {
        return;
    };
    const FRAMES: usize = 6;
    let (morph, asset, model) = head_asset(FRAMES);
    let tris = morph.triangles();
    let mut object = LodObject::new(gpu.device(), &gpu.pipeline, &asset, Arc::clone(&model))
        .expect("the head uploads");
    let vertices = asset.v0.len();
    let mut rng = Rng(0x5EED_F4A3);
    let (mut t, mut fraction) = (0.0f32, 0.0f32);
    let mut frames_seen = [false; FRAMES];
    let mut switches = 0;
    for step in 0..60 {
        match rng.below(5) {
            // t moves across one or more sampled frames, LOD kept.
            0 | 1 => t = rng.unit(),
            // LOD finer or coarser at the same t.
            2 => fraction = (fraction + 0.15 * (rng.unit() - 0.5)).clamp(0.0, 1.0),
            // A jump in both.
            3 => (t, fraction) = (rng.unit(), rng.unit()),
            // A frame switch at a coarse level, to a far frame.
            _ => (t, fraction) = (1.0 - t, 0.7 + 0.3 * rng.unit()),
        }
        let before = object.state().frame();
        object.set(t, Lod::Fraction(fraction)).expect("t in [0, 1]");
        object.prepare(gpu.queue());
        // The frame of t, computed here: nearest sample t_k = k / (|r| - 1).
        let k = (0..FRAMES)
            .min_by(|&a, &b| {
                let d = |k: usize| (k as f32 / (FRAMES - 1) as f32 - t).abs();
                d(a).total_cmp(&d(b))
            })
            .expect("frames");
        let state = object.state();
        assert_eq!(state.frame(), k, "step {step}: t {t} shows frame {k}");
        switches += usize::from(state.frame() != before);
        frames_seen[k] = true;
        let lod = state.lod();
        let drawn = gpu.drawn_by(object.object(), vertices);
        assert_same_triangles(
            &canonical_multiset(drawn.triangles),
            &canonical_multiset(asset.frames[k].reference_mesh(tris, lod)),
            &format!("step {step}: t {t} (frame {k}), LOD {lod} (fraction {fraction})"),
        );
    }
    assert!(
        switches >= 20 && frames_seen.iter().all(|&s| s),
        "the walk must switch frames often ({switches}) and visit every frame ({frames_seen:?})"
    );
}

#[test]
fn exponential_sweep_uploads_at_most_5_percent() {
    let Some(gpu) = Gpu::new() else {
        return;
    };
    // The bench's exponential sweep (`morphlod bench`): frame i of N, x = i / (N - 1), t = x,
    // LOD fraction (1024^x - 1) / 1023; bytes are index + indirect writes of `prepare`,
    // against a full upload of S0's indices.
    const SWEEP: usize = 240;
    let (_, asset, model) = head_asset(16);
    let mut object =
        LodObject::new(gpu.device(), &gpu.pipeline, &asset, model).expect("the head uploads");
    object.prepare(gpu.queue());
    let full_bytes = asset.s0.indices.len() as f64 * 4.0;
    let mut bytes = 0u64;
    for i in 0..SWEEP {
        let x = i as f32 / (SWEEP - 1) as f32;
        let fraction = (1024f32.powf(x) - 1.0) / 1023.0;
        object.set(x, Lod::Fraction(fraction)).expect("t in [0, 1]");
        bytes += object.prepare(gpu.queue()).geometry_bytes();
    }
    assert_eq!(
        object.state().lod(),
        model_max(&object),
        "the sweep ends at the coarsest level"
    );
    let percent = 100.0 * bytes as f64 / SWEEP as f64 / full_bytes;
    eprintln!(
        "exponential sweep over {SWEEP} frames: mean upload {percent:.2}% of a full index upload"
    );
    assert!(
        percent > 0.0 && percent <= 5.0,
        "exponential sweep: mean upload {percent:.2}% of a full index upload, goal <= 5% (issue 5)"
    );
}

fn model_max(object: &LodObject) -> usize {
    let k = object.state().frame();
    object
        .model()
        .frame_changes(k)
        .expect("the current frame exists")
        .max_lod()
}

/// Reads the index buffer back and checks it against the mirror: every word the frame changed
/// (against `before`, the buffer read back after the previous frame) must hold its new value,
/// so a patch dropped, misplaced or run before an older write fails here. Returns the buffer
/// and the number of changed words outside the frame's direct writes (what the scatter
/// carried).
fn check_readback(
    gpu: &Gpu,
    object: &Object,
    before: &[u32],
    upload: &Upload,
    what: &str,
) -> (Vec<u32>, u64) {
    let after = gpu.read_words(object.index_buffer());
    let mirror = object.index_mirror();
    if let Some(at) = (0..mirror.len()).find(|&i| after[i] != mirror[i]) {
        panic!(
            "{what}: the GPU index buffer differs from the mirror at word {at}: {} (was {}), \
             mirror {}; {upload:?}",
            after[at], before[at], mirror[at]
        );
    }
    let written = |i: usize| {
        upload
            .index_ranges
            .iter()
            .any(|r| r.start <= 4 * i as u64 && 4 * (i as u64) < r.end)
    };
    let changed = (0..mirror.len())
        .filter(|&i| before[i] != mirror[i] && !written(i))
        .count() as u64;
    (after, changed)
}

#[test]
fn scattered_edits_are_patched_and_every_patch_lands() {
    let Some(gpu) = Gpu::new() else {
        return;
    };
    // 300 small regions [0, 1, 2, 3] (5 slots each with the separator), then one of 20,000.
    const SMALL: usize = 300;
    const LONG: usize = 20_000;
    let mut regions = vec![vec![0u32, 1, 2, 3]; SMALL];
    regions.push((0..LONG as u32).map(|i| i % 4).collect());
    let v: Vec<[f32; 3]> = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let mut object = Object::new(
        gpu.device(),
        &gpu.pipeline,
        Topology::Strip,
        &v,
        &v,
        &regions,
    )
    .expect("the object uploads");
    object.prepare(gpu.queue());
    let mut before = gpu.read_words(object.index_buffer());
    assert!(before == object.index_mirror());

    // Frame 1: the last index of every third small region, 100 words 15 slots apart: one
    // header each with its value inline, no write (100 writes would cost 100 calls), padded
    // to 112 headers.
    for r in (0..SMALL).step_by(3) {
        object.write_region(r, &[0, 1, 2, 1]).expect("fits");
    }
    let upload = object.prepare(gpu.queue());
    assert_eq!(
        (
            upload.index_ranges.len(),
            upload.scattered_words,
            upload.scatter_bytes,
            upload.scatters
        ),
        (0, 100, 112 * 8, 1),
        "{upload:?}"
    );
    let (after, patched) = check_readback(&gpu, &object, &before, &upload, "frame 1");
    assert_eq!(patched, 100, "every patch carries a changed word");
    before = after;

    // Frames 2 and 3, prepared back to back before anything is read: the same words changed
    // back, plus the long region rewritten (a run of 20,000 changed words: one write), then
    // other scattered words (two per region, 2 apart: two single-word headers) and one word
    // inside the long run. Queue order must apply frame 2's list before frame 3's overwrites
    // the patch buffer.
    for r in (0..SMALL).step_by(3) {
        object.write_region(r, &[0, 1, 2, 3]).expect("fits");
    }
    let shifted: Vec<u32> = (0..LONG as u32).map(|i| (i + 1) % 4).collect();
    object.write_region(SMALL, &shifted).expect("fits");
    let frame2 = object.prepare(gpu.queue());
    let long_start = 4 * object.region_range(SMALL).expect("exists").start as u64;
    assert_eq!(
        frame2.index_ranges,
        vec![long_start..long_start + 4 * LONG as u64],
        "{frame2:?}"
    );
    assert_eq!((frame2.scattered_words, frame2.scatters), (100, 1));
    for r in (1..SMALL).step_by(3) {
        object.write_region(r, &[3, 1, 2, 0]).expect("fits");
    }
    let mut long = shifted.clone();
    long[2500] = 3 - long[2500];
    object.write_region(SMALL, &long).expect("fits");
    let frame3 = object.prepare(gpu.queue());
    assert!(frame3.index_ranges.is_empty(), "{frame3:?}");
    assert_eq!((frame3.scattered_words, frame3.scatters), (201, 1));
    let both = Upload {
        index_ranges: frame2.index_ranges.clone(),
        ..Upload::default()
    };
    let (after, patched) = check_readback(&gpu, &object, &before, &both, "frames 2 and 3");
    // Against the buffer after frame 1: frame 2's 100 words (back to their first values) and
    // frame 3's 200 in the small regions; frame 3's word in the long run lies in frame 2's
    // write, which this count leaves out.
    assert_eq!(patched, 300, "changed words outside the long run's write");
    before = after;

    // Frame 4: one region emptied (one span): a write, no scatter.
    object.write_region(7, &[]).expect("fits");
    let upload = object.prepare(gpu.queue());
    assert_eq!(
        (upload.scattered_words, upload.scatters),
        (0, 0),
        "{upload:?}"
    );
    let start = 4 * object.region_range(7).expect("exists").start as u64;
    assert_eq!(upload.index_ranges, vec![start..start + 16]);
    let (_, patched) = check_readback(&gpu, &object, &before, &upload, "frame 4");
    assert_eq!(patched, 0);
    assert_eq!(object.index_mirror()[start as usize / 4], RESTART);
}

/// A `LodObject` over a random walk (steps, frame switches, jumps) reads back as its mirror
/// after every frame, whether `prepare` submits the scatter or `prepare_with` records it into
/// an encoder the caller submits.
#[test]
fn lod_walk_with_frame_switches_reads_back_as_the_mirror() {
    let Some(gpu) = Gpu::new() else {
        return;
    };
    const FRAMES: usize = 6;
    let (_, asset, model) = head_asset(FRAMES);
    let mut object = LodObject::new(gpu.device(), &gpu.pipeline, &asset, Arc::clone(&model))
        .expect("the head uploads");
    object.prepare(gpu.queue());
    let mut before = gpu.read_words(object.object().index_buffer());
    let mut rng = Rng(0x5CA7_7E12);
    let (mut t, mut fraction) = (0.0f32, 0.0f32);
    let (mut scattered, mut written_only, mut switches, mut patched_words) = (0, 0, 0, 0u64);
    // Frames whose scatter rode in the caller's encoder (`prepare_with`).
    let mut scattered_with = 0;
    for step in 0..50 {
        let lod = match rng.below(4) {
            // One to three collapses finer or coarser at the same t.
            0 | 1 => {
                let lod = object.state().lod();
                let steps = 1 + rng.below(3);
                Lod::Steps(if rng.below(2) == 0 {
                    lod.saturating_sub(steps)
                } else {
                    lod + steps
                })
            }
            // Another sampled frame, LOD kept.
            2 => {
                t = rng.unit();
                Lod::Fraction(fraction)
            }
            // A jump in both.
            _ => {
                (t, fraction) = (rng.unit(), rng.unit());
                Lod::Fraction(fraction)
            }
        };
        let frame = object.state().frame();
        object.set(t, lod).expect("t in [0, 1]");
        switches += usize::from(object.state().frame() != frame);
        // Every other frame the scatter goes in the caller's encoder, applied by its submission.
        let with = step % 2 == 1;
        let upload = if with {
            let mut encoder = gpu.device().create_command_encoder(&Default::default());
            let upload = object.prepare_with(gpu.queue(), &mut encoder);
            gpu.queue().submit([encoder.finish()]);
            upload
        } else {
            object.prepare(gpu.queue())
        };
        scattered_with += usize::from(with) * upload.scatters;
        let what = format!("step {step}: t {t}, {lod:?}, prepare_with {with}");
        let (after, patched) = check_readback(&gpu, object.object(), &before, &upload, &what);
        assert!(
            patched <= upload.scattered_words,
            "{what}: {patched} changed words outside the writes, {} words scattered",
            upload.scattered_words
        );
        patched_words += patched;
        scattered += upload.scatters;
        written_only += usize::from(upload.scatters == 0 && !upload.index_ranges.is_empty());
        before = after;
    }
    assert!(
        switches >= 10
            && scattered >= 5
            && scattered_with >= 2
            && written_only >= 5
            && patched_words > 0,
        "the walk must switch frames ({switches}) and use the scatter ({scattered} frames, \
         {scattered_with} of them in the caller's encoder, {patched_words} changed words \
         patched) and writes only ({written_only} frames)"
    );
}

/// A frame switch's dirty log is applied on the pool (`apply_dirty` cuts its pieces into
/// chunks past 32 k words): over random logs — whole-buffer switches, a few strips, logs out
/// of strip order with repeats — the mirror, the lengths, the draw records and what
/// `prepare` sends equal a second object given each touched strip by `write_region`, and
/// the GPU buffer read back equals the mirror.
#[test]
fn apply_dirty_on_the_pool_matches_write_region() {
    let Some(gpu) = Gpu::new() else {
        return;
    };
    // At least two threads, so that large logs take the pool's path.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build_global();
    const VERTICES: usize = 1000;
    let mut rng = Rng(0xD1A7_7E55);
    // Every 50th strip long, so that a strip may leave more positions than one piece of
    // restarts (256).
    let capacities: Vec<usize> = (0..2500)
        .map(|s| 1 + rng.below(if s % 50 == 0 { 700 } else { 100 }))
        .collect();
    let mut runtime: Vec<Vec<u32>> = capacities
        .iter()
        .map(|&c| (0..c).map(|_| rng.below(VERTICES) as u32).collect())
        .collect();
    let mut lengths: Vec<u32> = capacities.iter().map(|&c| c as u32).collect();
    let positions: Vec<[f32; 3]> = (0..VERTICES).map(|i| [i as f32, 0.0, 0.0]).collect();
    let new_object = || {
        Object::new(
            gpu.device(),
            &gpu.pipeline,
            Topology::Strip,
            &positions,
            &positions,
            &runtime,
        )
        .expect("the strips fit")
    };
    let (mut object, mut diffed) = (new_object(), new_object());
    object.prepare(gpu.queue());
    diffed.prepare(gpu.queue());
    for round in 0..12 {
        let strips = capacities.len();
        // Whole switches (every strip, past the pool's threshold), or a few strips.
        let touched: Vec<usize> = if round % 3 == 0 {
            (0..strips).collect()
        } else {
            (0..40).map(|_| rng.below(strips)).collect()
        };
        let mut dirty = Dirty::default();
        for &s in &touched {
            let cap = capacities[s];
            let len = if rng.below(3) == 0 {
                lengths[s] as usize
            } else {
                rng.below(cap + 1)
            };
            // Rewrite part of the strip (all of it at a switch, as the rebuild marks it),
            // keeping some values (unchanged words split spans).
            let (a, b) = if round % 3 == 0 {
                (0, cap)
            } else {
                (rng.below(cap + 1), rng.below(cap + 1))
            };
            for v in &mut runtime[s][a.min(b)..a.max(b)] {
                if rng.below(4) != 0 {
                    *v = rng.below(VERTICES) as u32;
                }
            }
            dirty.ranges.push(DirtyRange {
                strip: s as u32,
                start: a.min(b) as u32,
                end: a.max(b) as u32,
            });
            // The positions a strip grows by are read from the runtime too.
            if len as u32 != lengths[s] {
                lengths[s] = len as u32;
                dirty.lengths.push(s as u32);
            }
        }
        if round % 3 == 0 {
            dirty.ranges.dedup_by_key(|r| r.strip);
        } else {
            // Another runtime's log: any order, repeats.
            dirty.ranges.reverse();
            dirty.lengths.reverse();
        }
        if round % 3 == 0 {
            // `apply_dirty` diffs on the pool from 2^15 copied words (`PARALLEL_WORDS`).
            let copied: usize = lengths.iter().map(|&l| l as usize).sum();
            assert!(
                copied >= 1 << 15,
                "round {round}: {copied} words miss the pool"
            );
        }
        let packed: Vec<u32> = runtime.iter().flatten().copied().collect();
        object
            .apply_dirty(&dirty, &packed, &lengths)
            .expect("the log fits the object");
        let mut all: Vec<usize> = touched.clone();
        all.sort_unstable();
        all.dedup();
        for &s in &all {
            diffed
                .write_region(s, &runtime[s][..lengths[s] as usize])
                .expect("the strip fits");
        }
        let what = format!("round {round} ({} strips touched)", all.len());
        assert!(
            object.index_mirror() == diffed.index_mirror(),
            "{what}: the mirror differs from write_region's"
        );
        // And from the layout built from scratch: each live strip, restarts up to its
        // capacity, one separator.
        let layout: Vec<u32> = (0..strips)
            .flat_map(|s| {
                let live = &runtime[s][..lengths[s] as usize];
                let rest = capacities[s] - live.len() + 1;
                live.iter()
                    .copied()
                    .chain(std::iter::repeat_n(RESTART, rest))
            })
            .collect();
        assert!(
            object.index_mirror() == layout.as_slice(),
            "{what}: the mirror differs from the layout"
        );
        assert_eq!(object.lengths(), diffed.lengths(), "{what}: lengths");
        let records = |o: &Object| -> Vec<u8> {
            o.indirect_args()
                .iter()
                .flat_map(|a| a.as_bytes().to_vec())
                .collect()
        };
        assert_eq!(records(&object), records(&diffed), "{what}: records");
        let (sent, reference) = (object.prepare(gpu.queue()), diffed.prepare(gpu.queue()));
        assert_eq!(
            (
                &sent.index_ranges,
                sent.scattered_words,
                &sent.indirect_ranges
            ),
            (
                &reference.index_ranges,
                reference.scattered_words,
                &reference.indirect_ranges
            ),
            "{what}: apply_dirty must send what write_region sends"
        );
        let drawn = gpu.drawn_by(&object, VERTICES);
        assert!(
            drawn.indices == object.index_mirror(),
            "{what}: the GPU index buffer differs from the mirror"
        );
    }
}
