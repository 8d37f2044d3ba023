//! The deforming runtime's own tests: rebuilds in chunks and from tails, switches to frames
//! built ahead, and walks of frame switches, each against stepping from `S0`.

use std::sync::Arc;

use super::plan::Plan;
use super::*;
use crate::asset::Asset;
use crate::simplify::{simplify, SimplifyOptions};
use crate::strip::stripify;

/// A grid of `n × n` quads, a wave that grows from `t = 0` to `t = 1`, sampled at
/// `frames` frames: each frame's sequence differs, so a frame switch rewrites most strips.
fn wave_asset(n: u32, frames: usize) -> Asset {
    wave_tiles(1, n, frames)
}

/// [`wave_asset`] as `tiles` separate grids of `n` × `n` quads side by side, so that a
/// small mesh has many strips (a few a tile).
fn wave_tiles(tiles: u32, n: u32, frames: usize) -> Asset {
    let pos = |x: u32, y: u32, t: f32| {
        let (fx, fy) = (x as f32, y as f32);
        [
            fx,
            fy,
            t * (0.7 * fx).sin() * (0.5 * fy).cos() + 0.02 * fx * fy,
        ]
    };
    let side = n + 1;
    let tile = side * side;
    let mut tris = Vec::new();
    for first in (0..tiles).map(|k| k * tile) {
        for y in 0..n {
            for x in 0..n {
                let a = first + y * side + x;
                tris.push([a, a + 1, a + side + 1]);
                tris.push([a, a + side + 1, a + side]);
            }
        }
    }
    // Tile k lies `k (side + 1)` along x, one column apart from the tile before.
    let at = |t: f32| -> Vec<[f32; 3]> {
        (0..tiles * tile)
            .map(|i| {
                let (k, j) = (i / tile, i % tile);
                pos(k * (side + 1) + j % side, j / side, t)
            })
            .collect()
    };
    let vertices = (tiles * tile) as usize;
    Asset {
        v0: at(0.0),
        v1: at(1.0),
        s0: stripify(&tris, vertices),
        frames: (0..frames)
            .map(|k| {
                let t = k as f32 / (frames - 1) as f32;
                Arc::new(simplify(&at(t), &tris, &SimplifyOptions::default()))
            })
            .collect(),
        blend: None,
        surface: None,
        skin: None,
    }
}

/// Two rebuilds of one move left the same buffer (stale tails included), lengths, LOD,
/// triangle count and dirty log (both taken).
fn same_rebuild(a: &mut DeformingState, b: &mut DeformingState, at: &str) {
    assert_eq!(a.indices(), b.indices(), "{at}");
    assert_eq!(a.lengths(), b.lengths(), "{at}");
    assert_eq!(
        (a.lod(), a.triangle_count()),
        (b.lod(), b.triangle_count()),
        "{at}"
    );
    assert_eq!(a.take_dirty(), b.take_dirty(), "{at}");
}

/// A rebuild cut into chunks on the thread pool (what one large object's frame switch
/// does) leaves the buffer, lengths and dirty log of a rebuild on one thread, and the
/// buffer of stepping there, over a random walk of frame switches and LOD jumps. The
/// mesh has 240 strips (60 tiles) and chunks of 1–1500 slots, cut at multiples of 64
/// strips: two to four chunks, which start at empty strips or live ones; every third
/// move reuses one survivor table, which is not flat after it links forward (that
/// rebuild stays on one thread and must give the same).
#[test]
fn chunked_rebuild_equals_one_thread_and_steps() {
    let asset = wave_tiles(60, 4, 5);
    let model = DeformingModel::new(&asset).expect("model builds");
    let (mut one, mut chunked, mut steps) = (
        DeformingState::new(&model),
        DeformingState::new(&model),
        DeformingState::new(&model),
    );
    let mut seed = 0x2545_f491_u64;
    let mut unit = || crate::random::next_unit(&mut seed) as f32;
    let mut shared = Survivors::new();
    let mut switches = 0;
    for step in 0..150 {
        let t = unit();
        let lod = match step % 7 {
            0 => Lod::Fraction(0.0),
            1 => Lod::Fraction(1.0),
            _ => Lod::Fraction(unit()),
        };
        let plan = one
            .plan(&model, t, lod, Strategy::Rebuild)
            .expect("valid request");
        switches += usize::from(plan.frame != one.frame());
        one.apply(&model, plan, &mut Survivors::new());
        let frame = &model.frames[plan.frame].changes;
        let chunk = 1 + (unit() * 1500.0) as usize;
        let mut fresh = Survivors::new();
        let anc = if step % 3 == 0 {
            &mut shared
        } else {
            &mut fresh
        };
        chunked
            .state
            .rebuild_in_chunks(&model.layout, frame, plan.lod, anc, chunk);
        chunked.frame = plan.frame;
        steps
            .set_with(&model, t, lod, Strategy::Steps)
            .expect("valid request");
        same_rebuild(&mut chunked, &mut one, &format!("step {step}"));
        assert_eq!(chunked.changes(), one.changes(), "step {step}");
        // Stepping leaves other values in the regions' tails; the live strips are equal.
        assert_eq!(steps.lengths(), one.lengths(), "step {step}");
        for s in 0..one.lengths().len() {
            assert_eq!(steps.strip(s), one.strip(s), "step {step}, strip {s}");
        }
    }
    assert!(switches > 50, "{switches} frame switches");
}

/// A rebuild at a frame's coarse LODs reads the frame's tail alone; it leaves the buffer,
/// lengths, dirty log, LOD and triangle count of the full rebuild, at every LOD from just
/// before the tail to the coarsest, whatever frame and LOD the state was at. Fails when the
/// tail is missing an entry or maps a value to the wrong survivor. (The wave's tails hold
/// no copy born inside them; the walks over the head and body in the suite's
/// `oracle_deform` do, and fail when a tail loses a copy's birth.)
#[test]
fn tail_rebuild_equals_full_rebuild() {
    // A larger wave than `wave_model`'s, so that each frame's tail spans a few dozen LODs.
    let model = &DeformingModel::new(&wave_asset(48, 3)).expect("model builds");
    let mut seed = 0x9e37_79b9_u64;
    let mut covered = 0;
    for (k, frame) in model.frames.iter().map(|f| &f.changes).enumerate() {
        let ((tail, entries), max) = (frame.tail_extent(), frame.max_lod());
        assert!(tail < max, "frame {k}: tail at {tail} of {max}");
        assert!(
            entries <= model.layout.s0().len() / crate::lodstrips::TAIL_SHARE,
            "frame {k}: tail holds {entries} entries"
        );
        for l in tail.saturating_sub(2)..=max {
            // From another frame at a random LOD, or this frame at a random LOD.
            let from = crate::random::next_unit(&mut seed);
            let other = (k + 1 + (from * 4.0) as usize) % model.frames.len();
            let start = model.frames[other].changes.max_lod() as f64 * from;
            let mut full = DeformingState::new(model);
            let plan = full
                .plan(model, 0.0, Lod::Steps(0), Strategy::Rebuild)
                .expect("valid request");
            let at = Plan {
                frame: if l % 2 == 0 { other } else { k },
                lod: start as usize,
                ..plan
            };
            full.apply(model, at, &mut Survivors::new());
            full.take_dirty();
            let mut from_tail = full.clone();
            full.state.rebuild_in_chunks(
                &model.layout,
                frame,
                l,
                &mut Survivors::new(),
                usize::MAX,
            );
            let from = &model.frames[from_tail.frame].changes;
            from_tail
                .state
                .rebuild(&model.layout, from, frame, l, &mut Survivors::new());
            same_rebuild(&mut from_tail, &mut full, &format!("frame {k}, LOD {l}"));
            covered += usize::from(l >= tail);
        }
    }
    assert!(covered > 20, "{covered} LODs rebuilt from a tail");
}

/// Checks that `state`, just moved to `(t, lod)`, equals a fresh state stepped there
/// from `S0`, and that its dirty log replayed onto `mirror` (its buffer and lengths as
/// of the last take) gives its strips; takes the log.
fn same_as_stepped(
    state: &mut DeformingState,
    model: &DeformingModel,
    t: f32,
    lod: Lod,
    mirror: &mut (Vec<u32>, Vec<u32>),
    at: &str,
) {
    let mut fresh = DeformingState::new(model);
    fresh
        .set_with(model, t, lod, Strategy::Steps)
        .expect("valid request");
    assert_eq!(state.frame(), fresh.frame(), "{at}");
    assert_eq!(
        (state.lod(), state.triangle_count()),
        (fresh.lod(), fresh.triangle_count()),
        "{at}"
    );
    assert_eq!(state.lengths(), fresh.lengths(), "{at}");
    let offsets = state.region_offsets().to_vec();
    for s in 0..offsets.len() - 1 {
        assert_eq!(state.strip(s), fresh.strip(s), "{at}, strip {s}");
    }
    let dirty = state.take_dirty();
    let (indices, lens) = mirror;
    for r in &dirty.ranges {
        let o = offsets[r.strip as usize] as usize;
        let span = o + r.start as usize..o + r.end as usize;
        state
            .indices()
            .slice(span.clone())
            .copy_to(&mut indices[span]);
    }
    for &s in &dirty.lengths {
        lens[s as usize] = state.lengths()[s as usize];
    }
    assert_eq!(&lens[..], state.lengths(), "{at}");
    for s in 0..offsets.len() - 1 {
        let live = offsets[s] as usize..(offsets[s] + lens[s]) as usize;
        assert_eq!(
            Some(indices[live].into()),
            state.strip(s),
            "{at}, strip {s}"
        );
    }
}

/// Switches that take a frame built ahead (at the LOD they go to, or at another one they
/// step from; built from `S0` or from the last build, of any frame) leave the strips of
/// stepping from `S0`, and a dirty log that takes the old strips to them; builds for a
/// frame the walk does not go to, or made while another is under way, change nothing.
/// Fails when the swap marks a strip's old live length instead of its new one, leaves
/// unmarked a strip the build emptied, or files the strips left behind under the frame
/// built (the next build then rebuilds them as if they were of that frame).
#[test]
fn switches_to_frames_built_ahead_equal_stepping_from_s0() {
    let model = Arc::new(DeformingModel::new(&wave_asset(24, 6)).expect("model builds"));
    let frames = model.frame_count();
    let mut state = DeformingState::new(&model);
    let mut mirror = (state.indices().to_vec(), state.lengths().to_vec());
    let mut seed = 0x51_7cc1_b727_u64;
    let mut unit = || crate::random::next_unit(&mut seed) as f32;
    let (mut started, mut elsewhere, mut f) = (0, 0, 0.5);
    for i in 0..240 {
        let k = state.frame();
        let frame = match i % 5 {
            0 | 1 => (k + 1) % frames,
            2 => k.saturating_sub(1),
            3 => k,
            _ => (unit() * frames as f32) as usize % frames,
        };
        // The LOD drifts as a camera's would, with a jump now and then, and the coarsest
        // (a frame's tail) every seventh move.
        f = if i % 11 == 0 {
            unit()
        } else {
            (f + 0.03 * (unit() - 0.5)).clamp(0.0, 1.0)
        };
        let lod = Lod::Fraction(if i % 7 == 0 { 1.0 } else { f });
        // The build: at the LOD the move goes to, near it, far from it, or for another
        // frame than the move's.
        let (to, ahead) = match i % 4 {
            0 => (frame, Lod::Fraction(f)),
            1 => (frame, Lod::Fraction((f + 0.02 * unit()).min(1.0))),
            2 => (frame, Lod::Fraction(unit())),
            _ => ((frame + 1) % frames, lod),
        };
        let l = model.resolve(to, ahead).expect("valid LOD");
        // Every third run of three moves builds nothing: the strips a switch left behind
        // stay as they were filed, and a later switch to their frame may take them.
        let build = (i / 3) % 3 != 2;
        if build && state.build_ahead_at(&model, to, l) {
            started += 1;
            elsewhere += usize::from(to != frame);
            // Most builds finish before the move; a few are left running, so that the
            // move may go on without them (and the build, taken after it, is of a frame
            // the state is no longer at).
            if i % 9 != 0 {
                state.wait_ahead();
            }
        }
        let t = frame as f32 / (frames - 1) as f32;
        state.set(&model, t, lod).expect("valid request");
        state.wait_ahead();
        same_as_stepped(
            &mut state,
            &model,
            t,
            lod,
            &mut mirror,
            &format!("move {i}"),
        );
    }
    let taken = state.switches_built_ahead();
    assert!(taken > 30, "{taken} of {started} builds taken");
    assert!(elsewhere > 10, "{elsewhere} builds for frames not gone to");
    // The build's buffer counts in the state's bytes.
    let width = state.index_width().bytes();
    assert!(state.heap_bytes() > 2 * state.indices().len() * width);
}

/// The wave model of `wave_asset(24, 6)`, built once for the property test.
fn wave_model() -> &'static DeformingModel {
    static MODEL: std::sync::OnceLock<DeformingModel> = std::sync::OnceLock::new();
    MODEL.get_or_init(|| DeformingModel::new(&wave_asset(24, 6)).expect("model builds"))
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config::with_cases(24))]

    /// Over a random walk of frame switches (the same frame, a neighbour up or down, a
    /// jump) at LODs from full detail to the coarsest, rebuilt or moved the cheaper way,
    /// every state equals a fresh one stepped from `S0` to its frame and LOD, and its
    /// dirty log replayed onto a copy of its buffer gives its strips: rebuilds that read
    /// only the strips and entries alive before and after leave nothing out.
    #[test]
    fn frame_switch_walks_equal_stepping_from_s0(
        moves in proptest::collection::vec(
            (0u8..4, 0u8..64, 0.0f32..1.0, proptest::bool::weighted(0.8)),
            1..40,
        )
    ) {
        let model = wave_model();
        let frames = model.frame_count();
        let mut state = DeformingState::new(model);
        let mut mirror = (state.indices().to_vec(), state.lengths().to_vec());
        for (i, &(kind, pick, f, rebuild)) in moves.iter().enumerate() {
            let k = state.frame();
            let frame = match kind {
                0 => k,
                1 => (k + 1).min(frames - 1),
                2 => k.saturating_sub(1),
                _ => pick as usize % frames,
            };
            let t = frame as f32 / (frames - 1) as f32;
            let lod = match pick % 4 {
                0 => Lod::Fraction(0.0),
                1 => Lod::Fraction(1.0),
                2 => Lod::Fraction(f),
                _ => Lod::Fraction(1.0 - 0.1 * f),
            };
            let strategy = if rebuild { Strategy::Rebuild } else { Strategy::Auto };
            state.set_with(model, t, lod, strategy).expect("valid request");
            proptest::prop_assert_eq!(state.frame(), frame);
            same_as_stepped(&mut state, model, t, lod, &mut mirror, &format!("move {i}"));
        }
    }
}

/// `error_at` is the error `Lod::MaxError` compares with, independently of its tables: on
/// every frame it is 0 at full detail and, at every LOD, the square root of the largest
/// recorded collapse error so far (the frame's sequence read directly, errors rounded as the
/// model stores them, so within a bfloat16 step); a request for a LOD's own error resolves to
/// that LOD or a coarser one of the same error, and one just below it to a finer LOD.
#[test]
fn error_at_is_what_max_error_bounds() {
    let asset = wave_asset(6, 3);
    let model = DeformingModel::new(&asset).expect("model builds");
    let mut checked = 0;
    for (k, sequence) in asset.frames.iter().enumerate() {
        let recorded = sequence.errors();
        let max = model.frame_changes(k).expect("frame").max_lod();
        assert_eq!(model.error_at(k, 0), 0.0, "frame {k}");
        for (l, &recorded) in recorded.iter().enumerate().take(max + 1) {
            let e = model.error_at(k, l);
            let truth = recorded.max(0.0).sqrt();
            assert!(
                (e - truth).abs() <= truth * 1e-2,
                "frame {k}, LOD {l}: {e} against {truth}"
            );
            let at = model.resolve(k, Lod::MaxError(e)).expect("resolves");
            assert!(at >= l && model.error_at(k, at) == e, "frame {k}, LOD {l}");
            if l > 0 && e > model.error_at(k, l - 1) {
                let below = model
                    .resolve(k, Lod::MaxError(e * (1.0 - 1e-6)))
                    .expect("resolves");
                assert!(below < l, "frame {k}, LOD {l}");
                checked += 1;
            }
        }
        // Past the coarsest LOD: the coarsest's.
        assert_eq!(model.error_at(k, max + 5), model.error_at(k, max));
    }
    assert!(checked > 20, "{checked} error steps");
}
