//! `gpu::LodObject` on a real adapter (lavapipe in CI).
//!
//! * `lod_object_renders_like_a_hand_driven_object`: over a walk of `(t, lod)` states, a
//!   `LodObject` renders pixel for pixel like a `gpu::Object` driven by hand from its own
//!   `DeformingState` (the wiring the LodObject replaces), with one draw per frame; a refused (NaN) `t`
//!   changes nothing, `t` and LOD outside `[0, 1]` are clamped.
//! * `object_buffers_match_layout_built_from_scratch`: a proptest over random walks (LOD up,
//!   down, jumps, frame switches, draw grouping, strip colouring and merge gap changed
//!   mid-walk, bad calls): after every move the object's index and indirect mirrors equal the
//!   layout built from scratch from the runtime's strips, the records draw exactly the strips'
//!   triangles, and after every `prepare` the index and indirect buffers copied back from the GPU
//!   equal that layout (the uploads brought everything that changed). Part of the walk plays
//!   the animation with the next frames built ahead, and switches take them.
//!
//! * `weight_animation_plays_on_the_gpu`: an asset built from makehuman_head's weight
//!   animation (8 targets, both end poses equal to the base) renders, at several `t`, like a
//!   static object holding the CPU's exact pose `Morph::positions_at(t)`, and visibly moves.
//!
//! Every test gets its device from `common::gpu::Gpu::new`: it fails when no adapter exists and
//! `CI` is set (`morphlod::ci::is_ci`), and skips with a printed reason elsewhere.

use crate::common;

use std::sync::Arc;

use common::gpu::Gpu;
use common::strip_draw;

use morphlod::deform::SetError;
use morphlod::gpu::{
    self, BuildAhead, Draws, GpuError, LodObject, Object, ShadeMode, Topology, Upload, RESTART,
};
use morphlod::io::LoadOptions;
use morphlod::io::MorphSource;
use morphlod::lodstrips::Dirty;
use morphlod::{Asset, Builder, DeformingModel, DeformingState, Error, Lod};

/// An `n × n` vertex grid (`common::grid_morph`) that bulges along z in `V(1)`, built into an
/// asset of `frames` sampled frames.
fn grid_asset(n: u32, frames: usize) -> Asset {
    let side = (n - 1) as f32;
    let morph = common::grid_morph(n, |x, y| {
        let (fx, fy) = (x as f32 / side, y as f32 / side);
        let bulge = (std::f32::consts::PI * fx).sin() * (std::f32::consts::PI * fy).sin();
        // Slightly uneven heights so the simplifier's errors are not all tied.
        side * (0.4 * bulge + 0.05 * (7.0 * fx + 3.0 * fy).sin())
    });
    Builder::new(&morph)
        .frames(frames)
        .build()
        .expect("grid asset builds")
        .0
}

#[test]
fn lod_object_renders_like_a_hand_driven_object() -> Result<(), Error> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let asset = grid_asset(12, 5);
    let model = Arc::new(DeformingModel::new(&asset)?);
    let pipeline = &ctx.pipeline;
    let target = ctx.target(96, 96, wgpu::Color::BLUE);

    let mut lod_object = LodObject::new(device, pipeline, &asset, Arc::clone(&model))?;
    let regions: Vec<Vec<u32>> = (0..asset.s0.len())
        .filter_map(|i| asset.s0.strip(i).map(<[u32]>::to_vec))
        .collect();
    let mut by_hand = Object::new(
        device,
        pipeline,
        Topology::Strip,
        &asset.v0,
        &asset.v1,
        &regions,
    )?;
    let mut state = DeformingState::new(&model);
    let camera = gpu::camera::frame_both_poses(&asset, glam::Vec3::new(0.3, -0.4, -1.0))?;
    lod_object.set_view_proj(camera.view_proj());
    by_hand.set_view_proj(camera.view_proj());

    let states = [
        (0.0, 0.0),
        (0.0, 0.6),
        (0.3, 0.6),
        (0.5, 0.9),
        (0.5, 0.2),
        (1.0, 1.0),
        (0.75, 0.4),
        (0.1, 0.0),
    ];
    let mut coarse_seen = false;
    for (frame, &(t, lod)) in states.iter().enumerate() {
        lod_object.set(t, Lod::Fraction(lod))?;
        lod_object.prepare(queue);
        // One multi-draw per frame, of the object's own records (checked by render_one).
        let image = ctx.render_one(&target, lod_object.object());

        state.set(&model, t, Lod::Fraction(lod))?;
        let dirty = state.take_dirty();
        by_hand.apply_dirty(&dirty, state.indices(), state.lengths())?;
        by_hand.set_t(t)?;
        by_hand.prepare(queue);
        let expected = ctx.render_one(&target, &by_hand);

        assert_eq!(
            lod_object.state().triangle_count(),
            state.triangle_count(),
            "state {frame}: triangle counts differ"
        );
        coarse_seen |= state.triangle_count() < asset.s0.indices.len() / 3;
        assert!(
            image == expected,
            "state {frame} (t {t}, lod {lod}): LodObject image differs from the hand-driven object"
        );
    }
    assert!(coarse_seen, "the walk never left full detail");

    // A refused (NaN) t or LOD changes neither the runtime nor the GPU mirror.
    let before = (
        lod_object.state().frame(),
        lod_object.state().lod(),
        counts(lod_object.object()),
    );
    assert!(matches!(
        lod_object.set(f32::NAN, Lod::Fraction(0.0)),
        Err(SetError::TimeNaN)
    ));
    assert!(matches!(
        lod_object.set(0.5, Lod::Fraction(f32::NAN)),
        Err(SetError::LodNaN(_))
    ));
    assert_eq!(
        before,
        (
            lod_object.state().frame(),
            lod_object.state().lod(),
            counts(lod_object.object()),
        )
    );
    // t and the LOD fraction outside [0, 1] are clamped, as on the CPU.
    lod_object.set(1.5, Lod::Fraction(2.0))?;
    let last = model.frame_count() - 1;
    assert_eq!(lod_object.state().frame(), last);
    assert_eq!(
        lod_object.state().lod(),
        model.frame_changes(last).expect("frame").max_lod()
    );
    lod_object.set(-1.0, Lod::Fraction(-1.0))?;
    assert_eq!(
        (lod_object.state().frame(), lod_object.state().lod()),
        (0, 0)
    );
    Ok(())
}

#[test]
fn weight_animation_plays_on_the_gpu() -> Result<(), Error> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_head.glb");
    let source = MorphSource::Animation("morph".into());
    let morph =
        morphlod::io::load_morph(&path, &LoadOptions::default(), &source).expect("head animation");
    let asset = Builder::new(&morph)
        .frames(3)
        .build()
        .expect("head builds")
        .0;
    assert!(asset.blend.is_some(), "an animated asset keeps its targets");
    assert_eq!(
        asset.v0, asset.v1,
        "the head's animation starts and ends at the base pose"
    );
    let model = Arc::new(DeformingModel::new(&asset)?);
    let pipeline = &ctx.pipeline;
    let size = 256;
    let target = ctx.target(size, size, wgpu::Color::BLACK);
    // Face on: the expressions move the mouth, eyes and brows towards the viewer's side.
    let camera = gpu::camera::frame_both_poses(&asset, glam::Vec3::new(0.0, 0.0, -1.0))?;
    let regions: Vec<Vec<u32>> = (0..asset.s0.len())
        .filter_map(|i| asset.s0.strip(i).map(<[u32]>::to_vec))
        .collect();
    let mut animated = LodObject::new(device, pipeline, &asset, Arc::clone(&model))?;
    animated.set_view_proj(camera.view_proj());
    let render_pose = |pose: &[[f32; 3]]| -> Result<image::RgbaImage, Error> {
        let mut fixed = Object::new(device, pipeline, Topology::Strip, pose, pose, &regions)?;
        fixed.set_view_proj(camera.view_proj());
        fixed.prepare(queue);
        Ok(target.render(device, queue, &[&fixed])?)
    };
    let rest = render_pose(&asset.v0)?;
    let differing = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
    };
    let mut most_moved = 0;
    for t in [0.1, 0.3, 0.45, 0.7, 0.9] {
        animated.set(t, Lod::Fraction(0.0))?;
        animated.prepare(queue);
        let image = target.render(device, queue, &[animated.object()])?;
        let exact = render_pose(&morph.positions_at(t))?;
        let moved = differing(&exact, &rest);
        most_moved = most_moved.max(moved);
        // V(0) + Σ c_k D_k and base + Σ w_k D_k round differently in the last bit, which can
        // flip a few pixels on silhouettes and depth ties; the animation moves far more.
        let mismatch = differing(&image, &exact);
        assert!(
            mismatch * 20 <= moved.max(20) && mismatch <= (size * size / 500) as usize,
            "t {t}: {mismatch} pixels differ from the CPU pose (the animation moved {moved})"
        );
    }
    assert!(
        most_moved > 200,
        "the animation moved only {most_moved} pixels: the test would not see a static GPU pose"
    );
    Ok(())
}

#[test]
fn bad_targets_and_weights_are_typed_errors() -> Result<(), Error> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let device = &ctx.device;
    let pipeline = &ctx.pipeline;
    let pose = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let mut object = Object::new(
        device,
        pipeline,
        Topology::Strip,
        &pose,
        &pose,
        &[vec![0, 1, 2]],
    )?;
    let one = vec![[0.0, 0.0, 1.0]; 3];
    assert!(matches!(
        object.set_targets(device, pipeline, &[one.clone(), vec![[0.0; 3]; 2]]),
        Err(gpu::GpuError::TargetLength {
            target: 1,
            len: 2,
            vertices: 3
        })
    ));
    assert!(matches!(
        object.set_targets(device, pipeline, &vec![one.clone(); 65]),
        Err(gpu::GpuError::TargetCount {
            targets: 65,
            max: 64
        })
    ));
    let mut nan = one.clone();
    nan[2][1] = f32::NAN;
    assert!(matches!(
        object.set_targets(device, pipeline, &[nan]),
        Err(gpu::GpuError::NonFiniteDelta {
            target: 0,
            vertex: 2,
            ..
        })
    ));
    // Refused targets left the object without any: a weight for one target is refused too.
    assert!(object.set_target_weights(&[0.5]).is_err());
    object.set_targets(device, pipeline, &[one])?;
    object.set_target_weights(&[0.5])?;
    assert!(object.set_target_weights(&[0.5, 0.5]).is_err());
    assert!(object.set_target_weights(&[f32::INFINITY]).is_err());
    Ok(())
}

/// The live length of every region and the draw records.
fn counts(object: &Object) -> (Vec<u32>, Vec<u32>) {
    let records = object.indirect_args().iter().map(|a| a.index_count);
    (object.lengths().to_vec(), records.collect())
}

/// One move of a random walk over a [`LodObject`].
#[derive(Clone, Debug)]
enum Move {
    /// `set(t, Fraction(lod))`: a jump, a frame switch when `t` lands on another frame.
    Set { t: f32, lod: f32, prepare: bool },
    /// `set` at the same `t`, `steps` collapses finer or coarser.
    Step {
        finer: bool,
        steps: usize,
        prepare: bool,
    },
    /// `set_draws`: per region (`None`) or groups of at most this many slots.
    Draws(Option<u32>),
    /// Strip colouring on or off (strip colours draw per region).
    Shade(bool),
    /// `set_merge_gap` in bytes.
    Gap(u64),
    /// Calls that must fail with a typed error and change nothing.
    Bad,
    /// `set(t + dt, Fraction(lod + dlod))`, both clamped to `[0, 1]` (`lod` the walk's last
    /// fraction): an animation playing and a camera drifting, whose next frames are built
    /// ahead while the walk checks the buffers.
    Play { dt: f32, dlod: f32 },
    /// `set_build_ahead`: always (`true`) or never.
    Ahead(bool),
}

fn move_strategy() -> impl proptest::strategy::Strategy<Value = Move> {
    use proptest::prelude::*;
    let budget = prop::sample::select(vec![0u32, 8, 24, 64, 200, u32::MAX]);
    prop_oneof![
        3 => (0.0f32..=1.0, 0.0f32..=1.0, any::<bool>())
            .prop_map(|(t, lod, prepare)| Move::Set { t, lod, prepare }),
        3 => (any::<bool>(), 1usize..30, any::<bool>())
            .prop_map(|(finer, steps, prepare)| Move::Step { finer, steps, prepare }),
        1 => prop::option::of(budget).prop_map(Move::Draws),
        1 => any::<bool>().prop_map(Move::Shade),
        1 => prop::sample::select(vec![0u64, 8, 32, 256]).prop_map(Move::Gap),
        1 => Just(Move::Bad),
        4 => (-0.1f32..0.2, -0.03f32..0.03).prop_map(|(dt, dlod)| Move::Play { dt, dlod }),
        1 => any::<bool>().prop_map(Move::Ahead),
    ]
}

/// The buffers an object must hold, built from scratch: every region's live strip, RESTART
/// up to its capacity, one RESTART separator; records cutting the regions greedily by
/// `draws` (a region opens a new record when the slots since the record's first region would
/// exceed the budget), each from its first region's start to its last live index.
fn expected_layout(
    strips: &[Vec<u32>],
    capacities: &[usize],
    draws: Draws,
    first_instance: bool,
) -> (Vec<u32>, Vec<[u32; 5]>) {
    let mut indices = Vec::new();
    let mut starts = Vec::new();
    for (strip, &capacity) in strips.iter().zip(capacities) {
        starts.push(indices.len() as u32);
        indices.extend_from_slice(strip);
        indices.resize(indices.len() + capacity - strip.len() + 1, RESTART);
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut slots = 0u64;
    for (r, &capacity) in capacities.iter().enumerate() {
        let own = capacity as u64 + 1;
        let budget = match draws {
            Draws::PerRegion => 0,
            Draws::Grouped { max_indices } => u64::from(max_indices),
        };
        match groups.last_mut() {
            Some(group) if slots + own <= budget => {
                group.push(r);
                slots += own;
            }
            _ => {
                groups.push(vec![r]);
                slots = own;
            }
        }
    }
    let records = groups
        .iter()
        .enumerate()
        .map(|(g, group)| {
            let first = starts[group[0]];
            let end = group
                .iter()
                .filter(|&&r| !strips[r].is_empty())
                .map(|&r| starts[r] + strips[r].len() as u32)
                .max()
                .unwrap_or(first);
            let instance = if first_instance { g as u32 } else { 0 };
            [end - first, 1, first, 0, instance]
        })
        .collect();
    (indices, records)
}

fn record_words(object: &Object) -> Vec<u32> {
    object
        .indirect_args()
        .iter()
        .flat_map(|a| {
            [
                a.index_count,
                a.instance_count,
                a.first_index,
                a.base_vertex as u32,
                a.first_instance,
            ]
        })
        .collect()
}

#[test]
fn object_buffers_match_layout_built_from_scratch() -> Result<(), Error> {
    use proptest::test_runner::{Config, TestRunner};
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let asset = grid_asset(10, 5);
    let model = Arc::new(DeformingModel::new(&asset)?);
    let pipeline = &ctx.pipeline;
    let capacities: Vec<usize> = (0..asset.s0.len())
        .map(|i| asset.s0.strip(i).map_or(0, <[u32]>::len))
        .collect();
    let first_instance = ctx.first_instance_enabled();
    let mut runner = TestRunner::new(Config {
        cases: 48,
        ..Config::default()
    });
    let walks = proptest::collection::vec(move_strategy(), 1..40);
    // Frames that used the index scatter and frames that went by writes only, over all walks.
    let (scattered, written_only) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
    // Switches that took a frame built ahead, over all walks.
    let built_ahead = std::cell::Cell::new(0);
    let result = runner.run(&walks, |moves| {
        let mut object = LodObject::new(device, pipeline, &asset, Arc::clone(&model))
            .expect("the grid asset uploads");
        // The grid is far smaller than what `Auto` builds ahead for.
        object.set_build_ahead(BuildAhead::Always);
        let mut fraction = 0.0f32;
        let (mut t, mut draws, mut strip_colours) = (
            0.0f32,
            gpu::Draws::Grouped {
                max_indices: gpu::GROUP_INDICES,
            },
            false,
        );
        for (i, step) in moves.iter().enumerate() {
            let what = format!("move {i} {step:?}");
            let mut prepare = true;
            match *step {
                Move::Set {
                    t: to,
                    lod,
                    prepare: p,
                } => {
                    object.set(to, Lod::Fraction(lod)).expect("valid t");
                    (t, fraction, prepare) = (to, lod, p);
                }
                Move::Step {
                    finer,
                    steps,
                    prepare: p,
                } => {
                    let lod = object.state().lod();
                    let lod = if finer {
                        lod.saturating_sub(steps)
                    } else {
                        lod + steps
                    };
                    object.set(t, Lod::Steps(lod)).expect("valid t");
                    prepare = p;
                }
                Move::Draws(budget) => {
                    draws = budget.map_or(Draws::PerRegion, |max_indices| Draws::Grouped {
                        max_indices,
                    });
                    object.set_draws(draws).expect("strip objects group");
                }
                Move::Shade(on) => {
                    strip_colours = on;
                    object.set_shade_mode(if on {
                        ShadeMode::StripColours
                    } else {
                        ShadeMode::Faceted
                    });
                }
                Move::Gap(bytes) => object.object_mut().set_merge_gap(bytes),
                Move::Play { dt, dlod } => {
                    t = (t + dt).clamp(0.0, 1.0);
                    fraction = (fraction + dlod).clamp(0.0, 1.0);
                    object.set(t, Lod::Fraction(fraction)).expect("valid t");
                }
                Move::Ahead(on) => object.set_build_ahead(if on {
                    BuildAhead::Always
                } else {
                    BuildAhead::Never
                }),
                Move::Bad => {
                    let before = (
                        object.object().index_mirror().to_vec(),
                        record_words(object.object()),
                    );
                    let state = object.state();
                    let (indices, lengths) = (state.indices().to_vec(), state.lengths().to_vec());
                    let short = &indices[..indices.len() - 1];
                    let target = object.object_mut();
                    assert!(matches!(
                        target.apply_dirty(&Dirty::default(), short, &lengths),
                        Err(GpuError::LayoutMismatch { .. })
                    ));
                    let mut too_long = lengths.clone();
                    too_long[0] = capacities[0] as u32 + 1;
                    let dirty = Dirty {
                        ranges: Vec::new(),
                        lengths: vec![0],
                    };
                    assert!(matches!(
                        target.apply_dirty(&dirty, &indices, &too_long),
                        Err(GpuError::RegionOverflow { region: 0, .. })
                    ));
                    assert!(matches!(
                        target.write_region(capacities.len(), &[]),
                        Err(GpuError::NoSuchRegion { .. })
                    ));
                    assert!(matches!(
                        target.write_region(0, &[u32::MAX - 1]),
                        Err(GpuError::IndexOutOfRange { .. })
                    ));
                    let after = (target.index_mirror().to_vec(), record_words(target));
                    assert!(
                        before == after,
                        "{what}: a refused call changed the mirrors"
                    );
                }
            }

            let state = object.state();
            let strips: Vec<Vec<u32>> = (0..capacities.len())
                .map(|s| state.strip(s).unwrap_or_default().to_vec())
                .collect();
            let drawn = if strip_colours {
                Draws::PerRegion
            } else {
                draws
            };
            let (indices, records) = expected_layout(&strips, &capacities, drawn, first_instance);
            let gpu_object = object.object();
            assert!(
                gpu_object.index_mirror() == indices.as_slice(),
                "{what}: index mirror differs from the layout built from scratch"
            );
            let words: Vec<u32> = records.iter().flatten().copied().collect();
            assert_eq!(record_words(gpu_object), words, "{what}: draw records");
            assert_eq!(gpu_object.lengths(), state.lengths(), "{what}: lengths");
            // The records draw exactly the strips' triangles, in order.
            let by_records: Vec<[u32; 3]> = gpu_object
                .indirect_args()
                .iter()
                .flat_map(|a| {
                    let span = a.first_index as usize..(a.first_index + a.index_count) as usize;
                    strip_draw(&indices[span])
                })
                .collect();
            let by_strips: Vec<[u32; 3]> = strips.iter().flat_map(strip_draw).collect();
            assert!(
                by_records == by_strips,
                "{what}: records draw other triangles"
            );

            if prepare {
                // What the GPU holds, copied back: the uploads must have brought both buffers
                // to the layout built from scratch.
                let upload: Upload = object.prepare(queue);
                scattered.set(scattered.get() + upload.scatters);
                written_only.set(
                    written_only.get()
                        + usize::from(upload.scatters == 0 && !upload.index_ranges.is_empty()),
                );
                let gpu_indices = ctx.read_words(object.object().index_buffer());
                let gpu_records = ctx.read_words(object.object().indirect_buffer());
                assert!(
                    gpu_indices == indices,
                    "{what}: the GPU index buffer differs from the layout built from scratch \
                     (uploaded {upload:?})"
                );
                assert_eq!(
                    &gpu_records[..words.len()],
                    words.as_slice(),
                    "{what}: the GPU indirect records differ (uploaded {:?})",
                    upload.indirect_ranges
                );
            }
        }
        built_ahead.set(built_ahead.get() + object.state().switches_built_ahead());
        Ok(())
    });
    if let Err(failure) = result {
        panic!("{failure}");
    }
    assert!(
        built_ahead.get() > 0,
        "no switch of the walks took a frame built ahead"
    );
    assert!(
        scattered.get() > 0 && written_only.get() > 0,
        "the walks must upload by the scatter ({} frames) and by writes only ({} frames)",
        scattered.get(),
        written_only.get()
    );
    Ok(())
}

/// An animation played forward and back with the LOD drifting, on a `LodObject` that builds
/// its next frames ahead: after every frame's `prepare` the index and indirect buffers copied
/// back from the GPU equal the layout built from scratch from a `DeformingState` moved to the
/// same `(t, lod)` without builds, and most frame switches took a frame built ahead.
#[test]
fn frames_built_ahead_upload_the_strips_of_their_frame() -> Result<(), Error> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let asset = grid_asset(12, 5);
    let model = Arc::new(DeformingModel::new(&asset)?);
    let capacities: Vec<usize> = (0..asset.s0.len())
        .map(|i| asset.s0.strip(i).map_or(0, <[u32]>::len))
        .collect();
    let mut object = LodObject::new(device, &ctx.pipeline, &asset, Arc::clone(&model))?;
    object.set_build_ahead(BuildAhead::Always);
    let draws = Draws::Grouped {
        max_indices: gpu::GROUP_INDICES,
    };
    let mut oracle = DeformingState::new(&model);
    let mut switches = 0;
    for i in 0..120 {
        // Forward over the frames, then back, four frames per sampled frame.
        let x = if i < 60 { i } else { 119 - i } as f32 / 59.0;
        let lod = Lod::Fraction(0.2 + 0.5 * x + 0.01 * (i as f32 * 0.7).sin());
        // Builds take microseconds on this grid, but the walk's test threads share two cores
        // with lavapipe's: wait, so that the count below does not depend on the load.
        while object.state().building_ahead() {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let before = object.state().frame();
        object.set(x, lod)?;
        switches += usize::from(object.state().frame() != before);
        object.prepare(queue);
        oracle.set_with(&model, x, lod, morphlod::deform::Strategy::Steps)?;
        let strips: Vec<Vec<u32>> = (0..capacities.len())
            .map(|s| oracle.strip(s).unwrap_or_default().to_vec())
            .collect();
        let (indices, records) =
            expected_layout(&strips, &capacities, draws, ctx.first_instance_enabled());
        let words: Vec<u32> = records.iter().flatten().copied().collect();
        assert!(
            ctx.read_words(object.object().index_buffer()) == indices,
            "frame {i}: the GPU index buffer differs from the layout built from scratch"
        );
        let gpu_records = ctx.read_words(object.object().indirect_buffer());
        assert_eq!(&gpu_records[..words.len()], words.as_slice(), "frame {i}");
    }
    let taken = object.state().switches_built_ahead() as usize;
    assert!(
        switches >= 8 && taken * 4 >= switches * 3,
        "{taken} of {switches} frame switches took a frame built ahead"
    );
    Ok(())
}
