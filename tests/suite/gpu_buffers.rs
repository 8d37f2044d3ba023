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
//!   mean index + indirect bytes per frame over the bench's exponential sweep ≤ 5% of the
//!   full index buffer.
//!
//! GPU set-up: `common::gpu::Gpu` (fails without an adapter when `CI` is set: `morphlod::ci::is_ci`).

use crate::common;

use std::path::Path;
use std::sync::Arc;

use common::gpu::Gpu;
use common::Rng;
use morphlod::collapse::canonical_multiset;
use morphlod::gpu::{Draws, LodObject, Object, Topology};
use morphlod::io::MorphSource;
use morphlod::io::{load_mesh, LoadOptions};
use morphlod::lodstrips::{LodStrips, StripsState};
use morphlod::morph::Morph;
use morphlod::simplify::{simplify, SimplifyOptions};
use morphlod::strip::stripify;
use morphlod::{Builder, DeformingModel, Lod};

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
            .map(|s| state.strip(s).unwrap_or(&[]).to_vec())
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
    let morph = head_morph();
    let tris = morph.triangles();
    let (asset, _) = Builder::new(&morph)
        .frames(FRAMES)
        .build()
        .expect("the head builds");
    let model = Arc::new(DeformingModel::new(&asset).expect("the built asset is valid"));
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
    let morph = head_morph();
    let (asset, _) = Builder::new(&morph)
        .frames(16)
        .build()
        .expect("the head builds");
    let model = Arc::new(DeformingModel::new(&asset).expect("the built asset is valid"));
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
