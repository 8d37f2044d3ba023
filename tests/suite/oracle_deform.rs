//! The oracle for deforming meshes: random walks of `DeformingState::set(t, lod)`
//! checked against the reference mesh of DESIGN.md for the CURRENT frame's
//! collapse sequence at the current LOD.
//!
//! The test assets are built here (stripify `T` once, simplify `V(t_k)` per
//! frame); the production builder lives elsewhere and is not needed for this.
//!
//! What is checked when:
//! * After EVERY step: the frame is `round(t (|r|-1))`, the LOD is what the
//!   `Lod` request means by its definition (computed here from the sequence's
//!   own tables: reference triangle counts, `errors()`), and the multiset hash
//!   and count of the triangles drawn by a GPU mirror (updated only through
//!   `take_dirty`) equal the reference of that frame at that LOD, as does
//!   `triangle_count()`.
//! * Full checks every `FULL_STRIDE`-th step, at every switch whose strategy
//!   is compared, and at the end: exact sorted multiset against
//!   `reference_mesh`, mirror strips == state strips.
//! * Strategy equivalence: at random frame switches and LOD jumps, a clone of
//!   the state is moved with the other strategy (steps vs one-pass rebuild),
//!   and both must hold identical strips (later steps replay recorded
//!   positions, so the buffer must be identical, not only draw the same).
//! * End of walk: the walked state equals fresh states moved straight to the
//!   final `(frame, lod)` by either strategy.
//! * The runtime's index width is the one each test names: `u16` for the assets (the body
//!   included, the crowd's near instance), `u32` for a mesh past 65,536 vertices
//!   (`random_frames_past_u16`), so both widths of every step and rebuild are walked.

use crate::common;

use common::{multiset_hash, random_sequence, reference_hashes, Mirror, Rng};
use morphlod::collapse::{canonical_multiset, CollapseSequence};
use morphlod::deform::{DeformError, SetError, Strategy};
use morphlod::io::LoadOptions;
use morphlod::io::MorphSource;
use morphlod::lodstrips::{IndexWidth, PARALLEL_SLOTS};
use morphlod::morph::Morph;
use morphlod::simplify::{simplify, SimplifyOptions};
use morphlod::strip::stripify;
use morphlod::{Asset, DeformingModel, DeformingState, Lod};
use rayon::prelude::*;
use std::sync::Arc;

/// A full multiset check every this many steps.
const FULL_STRIDE: usize = 97;

/// The asset of `morph` sampled at `frames` frames, built the way the paper
/// does: `S0` once on `T`, one QEM sequence per pose `V(t_k)`.
fn build_asset(morph: &Morph, frames: usize) -> Asset {
    let tris = morph.triangles();
    let s0 = stripify(tris, morph.vertex_count());
    let sequences: Vec<Arc<CollapseSequence>> = (0..frames)
        .into_par_iter()
        .map(|k| {
            let t = k as f32 / (frames - 1).max(1) as f32;
            Arc::new(simplify(
                &morph.positions_at(t),
                tris,
                &SimplifyOptions::default(),
            ))
        })
        .collect();
    Asset {
        v0: morph.v0(),
        v1: morph.v1(),
        s0,
        frames: sequences,
        blend: morph.target_blend(),
        surface: None,
        skin: None,
    }
}

fn load_morph(file: &str, source: MorphSource) -> Morph {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(file);
    morphlod::io::load_morph(&path, &LoadOptions::default(), &source)
        .unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// Strips of two states, compared entry by entry.
fn same_strips(a: &DeformingState, b: &DeformingState, what: &str) {
    assert_eq!(a.lengths(), b.lengths(), "{what}: strip lengths differ");
    for s in 0..a.lengths().len() {
        assert_eq!(a.strip(s), b.strip(s), "{what}: strip {s} differs");
    }
}

/// Per-frame reference tables.
struct Frames<'a> {
    tris: &'a [[u32; 3]],
    asset: &'a Asset,
    /// `(multiset hash, count)` of the reference mesh at every LOD.
    hashes: Vec<Vec<(u64, usize)>>,
    /// `errors()` of every sequence (squared distances).
    errors: Vec<Vec<f32>>,
}

impl Frames<'_> {
    /// The LOD `lod` means in frame `k`, by the definitions in `Lod`'s docs,
    /// computed from the reference tables by linear scans.
    fn expected(&self, k: usize, lod: Lod) -> usize {
        let max = self.asset.frames[k].len();
        match lod {
            Lod::Steps(l) => l.min(max),
            Lod::Fraction(f) => (f.clamp(0.0, 1.0) * max as f32).round() as usize,
            Lod::Triangles(n) => self.hashes[k]
                .iter()
                .position(|&(_, c)| c <= n)
                .unwrap_or(max),
            Lod::MaxError(e) => self.errors[k]
                .iter()
                .rposition(|&x| x.sqrt() <= e)
                .unwrap_or(0),
        }
    }

    /// A request of a random kind that means LOD `target` of frame `k` (or,
    /// for budgets and bounds between two tables entries, a nearby LOD).
    fn request(&self, k: usize, target: usize, rng: &mut Rng) -> Lod {
        let max = self.asset.frames[k].len();
        match rng.below(4) {
            0 => Lod::Steps(if target == max && rng.below(2) == 0 {
                max + 1 + rng.below(5)
            } else {
                target
            }),
            1 => match rng.below(8) {
                0 => Lod::Fraction(-0.5),
                1 => Lod::Fraction(1.5),
                _ => Lod::Fraction((target as f32 + rng.unit() - 0.5) / max.max(1) as f32),
            },
            2 => {
                let count = self.hashes[k][target].1;
                Lod::Triangles(match rng.below(3) {
                    0 => count.saturating_sub(1),
                    1 => count + 1,
                    _ => count,
                })
            }
            _ => {
                let e = self.errors[k][target].sqrt();
                Lod::MaxError(match rng.below(4) {
                    0 => e * 1.0001,
                    1 => e * 0.9999,
                    2 if target == 0 => -1.0,
                    _ => e,
                })
            }
        }
    }

    fn full_check(&self, k: usize, l: usize, mirror: &Mirror, state: &DeformingState, at: &str) {
        let reference = self.asset.frames[k].reference_mesh(self.tris, l);
        assert_eq!(
            (multiset_hash(&reference), reference.len()),
            self.hashes[k][l],
            "{at}: one-pass reference tables disagree with reference_mesh"
        );
        assert_eq!(
            canonical_multiset(mirror.triangles()),
            canonical_multiset(reference),
            "{at}: drawn triangles differ from the reference of frame {k} at LOD {l}"
        );
        assert_eq!(
            mirror.lens.as_slice(),
            state.lengths(),
            "{at}: mirror lengths"
        );
        for s in 0..mirror.strip_count() {
            assert_eq!(
                Some(mirror.strip(s).into()),
                state.strip(s),
                "{at}: mirror strip {s}"
            );
        }
        assert!(state.index_count() <= self.asset.s0.indices.len());
    }
}

/// Drives `steps` random `set` calls over `(t, lod)`; see the module docs.
/// The state's indices must be stored `width` wide.
fn walk(name: &str, tris: &[[u32; 3]], asset: &Asset, steps: usize, seed: u64, width: IndexWidth) {
    let model = DeformingModel::new(asset).expect("model builds");
    let frames = Frames {
        tris,
        asset,
        hashes: asset
            .frames
            .par_iter()
            .map(|seq| reference_hashes(tris, seq))
            .collect(),
        errors: asset.frames.iter().map(|seq| seq.errors()).collect(),
    };
    let r = asset.frames.len();
    // Frame k samples t = k / last; a loop's t = 1 is frame 0 again (`frame_at`).
    let looping = asset.looping();
    let last = if looping {
        r as f32
    } else {
        (r - 1).max(1) as f32
    };
    let end = if looping { 0 } else { r - 1 };
    let mut rng = Rng(seed);
    let mut state = DeformingState::new(&model);
    assert_eq!(state.index_width(), width, "{name}: index width");
    let mut mirror = Mirror::new(state.region_offsets(), state.indices(), state.lengths());
    frames.full_check(0, 0, &mirror, &state, name);
    let mut used = [0usize; 2];
    let mut compared = 0usize;
    for step in 0..steps {
        let at = format!("{name} step {step}");
        let k0 = state.frame();
        let (t, k) = match rng.below(8) {
            // A new frame: anywhere, a neighbour, an end, or out of range.
            0 => {
                let k = rng.below(r);
                ((k as f32 + rng.unit() * 0.9 - 0.45) / last, k)
            }
            1 => {
                let k = match (rng.below(2) == 0, looping) {
                    (true, true) => (k0 + 1) % r,
                    (true, false) => (k0 + 1).min(r - 1),
                    (false, _) => k0.saturating_sub(1),
                };
                (k as f32 / last, k)
            }
            2 => match rng.below(4) {
                0 => (0.0, 0),
                1 => (1.0, end),
                2 => (-3.0, 0),
                _ => (7.5, end),
            },
            // The same frame, somewhere within its rounding window.
            _ => ((k0 as f32 + rng.unit() * 0.9 - 0.45) / last, k0),
        };
        let max = asset.frames[k].len();
        let l0 = state.lod().min(max);
        let target = match rng.below(16) {
            0 => 0,
            1 => max,
            2 | 3 => rng.below(max + 1),
            4 => max / 2,
            5..=9 => (l0 + 1 + rng.below(3)).min(max),
            _ => l0.saturating_sub(1 + rng.below(3)),
        };
        let lod = frames.request(k, target, &mut rng);
        let expected = frames.expected(k, lod);
        let strategy = match rng.below(10) {
            0 => Strategy::Steps,
            1 => Strategy::Rebuild,
            _ => Strategy::Auto,
        };
        // Compare strategies at some frame switches and big jumps.
        let other = (k != k0 || l0.abs_diff(expected) > 8) && rng.below(6) == 0;
        let before = other.then(|| state.clone());
        let how = state
            .set_with(&model, t, lod, strategy)
            .expect("valid request");
        used[usize::from(how == Strategy::Rebuild)] += 1;
        assert_eq!(state.frame(), k, "{at}: frame for t = {t}");
        assert_eq!(state.lod(), expected, "{at}: LOD for {lod:?} in frame {k}");
        let dirty = state.take_dirty();
        mirror.upload(&dirty, state.indices(), state.lengths());
        let (hash, count) = frames.hashes[k][expected];
        assert_eq!(mirror.count, count, "{at}: drawn triangle count");
        assert_eq!(
            state.triangle_count(),
            count,
            "{at}: reported triangle count"
        );
        assert_eq!(mirror.hash, hash, "{at}: drawn multiset hash ({how:?})");
        if let Some(mut twin) = before {
            let flip = if how == Strategy::Rebuild {
                Strategy::Steps
            } else {
                Strategy::Rebuild
            };
            assert_eq!(twin.set_with(&model, t, lod, flip), Ok(flip));
            same_strips(&state, &twin, &format!("{at}: {how:?} vs {flip:?}"));
            assert_eq!(twin.triangle_count(), count);
            compared += 1;
        }
        if step % FULL_STRIDE == 0 || step + 1 == steps {
            frames.full_check(k, expected, &mirror, &state, &at);
        }
    }
    eprintln!(
        "{name}: {r} frames, {steps} steps ({} by steps, {} by rebuild, {compared} compared)",
        used[0], used[1]
    );
    assert!(used[0] > 0 && used[1] > 0, "both strategies ran");
    // Fresh states moved straight to the final (frame, lod), both ways.
    let t = state.frame() as f32 / last;
    for how in [Strategy::Steps, Strategy::Rebuild] {
        let mut fresh = DeformingState::new(&model);
        fresh
            .set_with(&model, t, Lod::Steps(state.lod()), how)
            .expect("valid request");
        same_strips(&state, &fresh, &format!("{name}: walked vs fresh {how:?}"));
    }
}

#[test]
fn makehuman_head_animation() {
    let morph = load_morph("makehuman_head.glb", MorphSource::Animation("morph".into()));
    let asset = build_asset(&morph, 12);
    walk(
        "makehuman_head 'morph'",
        morph.triangles(),
        &asset,
        10_000,
        1,
        IndexWidth::U16,
    );
}

#[test]
fn makehuman_body_animation() {
    let morph = load_morph("makehuman_body.glb", MorphSource::Animation("morph".into()));
    let asset = build_asset(&morph, 10);
    walk(
        "makehuman_body 'morph'",
        morph.triangles(),
        &asset,
        10_000,
        2,
        IndexWidth::U16,
    );
}

#[test]
fn makehuman_body_baby_target() {
    let morph = load_morph(
        "makehuman_body.glb",
        MorphSource::Target("caucasian-male-baby".into()),
    );
    let asset = build_asset(&morph, 8);
    walk(
        "makehuman_body baby",
        morph.triangles(),
        &asset,
        10_000,
        3,
        IndexWidth::U16,
    );
}

#[test]
fn animated_morph_cube() {
    let path = "AnimatedMorphCube-glTF/AnimatedMorphCube.gltf";
    let morph = load_morph(path, MorphSource::Animation("0".into()));
    let asset = build_asset(&morph, 16);
    walk(
        "AnimatedMorphCube",
        morph.triangles(),
        &asset,
        10_000,
        4,
        IndexWidth::U16,
    );
}

/// The walker's `walk`, built by the production [`morphlod::Builder`] over its skinned poses:
/// a loop, so its 8 frames sample `t_k = k / 8` and `t` wraps from frame 7 to frame 0. Each
/// frame is the simplifier's sequence of the skinned pose at its time (the CPU reference,
/// `Morph::positions_at`), errors rounded as the asset stores them, and the walk draws every
/// frame's reference mesh at every LOD it reaches.
#[test]
fn makehuman_walker_skinned_loop() {
    let morph = load_morph(
        "makehuman_walker.glb",
        MorphSource::Animation("walk".into()),
    );
    let (asset, _) = morphlod::Builder::new(&morph)
        .frames(8)
        .build()
        .expect("the walker builds");
    assert!(asset.looping() && asset.skin.is_some());
    assert_eq!(asset.skin.as_ref(), morph.skinning());
    let tris = morph.triangles();
    asset.frames.par_iter().enumerate().for_each(|(k, seq)| {
        let pose = morph.positions_at(k as f32 / 8.0);
        let own = simplify(&pose, tris, &SimplifyOptions::default());
        let pairs = |s: &CollapseSequence| -> Vec<(u32, u32)> {
            s.collapses.iter().map(|c| (c.u, c.w)).collect()
        };
        assert_eq!(
            pairs(seq),
            pairs(&own),
            "frame {k}: the skinned pose's sequence"
        );
        let quantized = own
            .collapses
            .iter()
            .map(|c| morphlod::asset::quantize_error(c.error));
        assert!(
            seq.collapses.iter().map(|c| c.error).eq(quantized),
            "frame {k}: errors"
        );
    });
    // The poses differ: frame 2 (a quarter of the walk) is not frame 0's sequence.
    assert_ne!(asset.frames[0], asset.frames[2]);
    walk(
        "makehuman_walker 'walk'",
        tris,
        &asset,
        10_000,
        6,
        IndexWidth::U16,
    );
}

/// Frames whose sequences have nothing in common: random collapse orders
/// over a grid with holes (every frame a different order and length), which
/// stresses rebuilds and switches far more than neighbouring poses do.
#[test]
fn unrelated_random_frames() {
    let (tris, asset) = random_frames(24, 16, 0, 9);
    walk("random frames", &tris, &asset, 10_000, 5, IndexWidth::U16);
}

/// [`unrelated_random_frames`] past `u16`: the grid's vertices are numbered from 64,000, so
/// its model has 98,371 vertices, its indices lie on both sides of 65,535 and its runtime
/// stores them as `u32` (a `u16` buffer would wrap the upper ones, and the hashes fail). Its
/// `S0` holds at least [`PARALLEL_SLOTS`] slots, so rebuilds from scratch run in chunks on
/// the pool too (with more than one thread). A few frames and a short walk: the width's paths
/// are what it adds.
#[test]
fn random_frames_past_u16() {
    let (tris, asset) = random_frames(200, 170, 64_000, 4);
    assert!(asset.v0.len() > 1 << 16);
    assert!(asset.s0.indices.len() >= PARALLEL_SLOTS);
    walk(
        "random frames past u16",
        &tris,
        &asset,
        1_500,
        8,
        IndexWidth::U32,
    );
}

/// The asset of [`unrelated_random_frames`]: a `w × h` grid with holes, its vertices numbered
/// from `first` (those below unused), and `frames` frames of random sequences (the middle one
/// empty).
fn random_frames(w: u32, h: u32, first: u32, frames: usize) -> (Vec<[u32; 3]>, Asset) {
    let mut tris = Vec::new();
    for y in 0..h {
        for x in 0..w {
            if (x * 7 + y * 3) % 11 == 0 {
                continue;
            }
            let a = first + y * (w + 1) + x;
            let (b, c, d) = (a + 1, a + w + 1, a + w + 2);
            tris.push([a, b, d]);
            tris.push([a, d, c]);
        }
    }
    let n = (first + (w + 1) * (h + 1)) as usize;
    let mut rng = Rng(77);
    let sequences: Vec<Arc<CollapseSequence>> = (0..frames)
        .map(|k| {
            let steps = if k == frames / 2 { 0 } else { usize::MAX - k };
            Arc::new(random_sequence(&tris, n, steps, &mut rng))
        })
        .collect();
    let asset = Asset {
        v0: vec![[0.0; 3]; n],
        v1: vec![[1.0; 3]; n],
        s0: stripify(&tris, n),
        frames: sequences,
        blend: None,
        surface: None,
        skin: None,
    };
    (tris, asset)
}

/// A rebuild logs only what changed (what a crowd uploads after a frame switch): every logged
/// range starts and ends at a position whose value changed or that the strip grew by, every
/// such position is logged, and a rebuild to where the state already is logs nothing. The walk
/// moves like a crowd's instance, to the neighbouring frame at a similar LOD, where most
/// indices stay; it must log fewer positions than the strips hold (the whole strips before).
#[test]
fn rebuild_logs_only_changed_positions() {
    let morph = common::grid_morph(24, |x, y| {
        0.4 * (x as f32 * 0.4).sin() * (y as f32 * 0.3).cos() + 0.05 * x as f32
    });
    let frames = 6;
    let asset = build_asset(&morph, frames);
    let model = DeformingModel::new(&asset).expect("model builds");
    let mut state = DeformingState::new(&model);
    let mut rng = Rng(11);
    let (mut logged, mut live) = (0usize, 0usize);
    for step in 0..60 {
        let k = (step / 2) % frames;
        let t = k as f32 / (frames - 1) as f32;
        let lod = Lod::Fraction(0.3 + 0.5 * rng.unit());
        let before = state.clone();
        let how = state.set_with(&model, t, lod, Strategy::Rebuild);
        assert_eq!(how, Ok(Strategy::Rebuild));
        let dirty = state.take_dirty();
        let changed = |s: usize, i: usize| {
            before.strip(s).and_then(|o| o.get(i)) != state.strip(s).and_then(|n| n.get(i))
        };
        for r in &dirty.ranges {
            let s = r.strip as usize;
            assert!(r.start < r.end, "step {step}: empty range {r:?}");
            assert!(
                changed(s, r.start as usize) && changed(s, r.end as usize - 1),
                "step {step}: range {r:?} not tight"
            );
            logged += (r.end - r.start) as usize;
        }
        for s in 0..state.lengths().len() {
            let old = before.lengths()[s] as usize;
            let grown = dirty.lengths.contains(&(s as u32));
            for i in 0..state.lengths()[s] as usize {
                let in_range = dirty
                    .ranges
                    .iter()
                    .any(|r| r.strip as usize == s && (r.start..r.end).contains(&(i as u32)));
                assert!(
                    !changed(s, i) || in_range || (grown && i >= old),
                    "step {step}: strip {s} position {i} changed unlogged"
                );
            }
        }
        assert_eq!(
            state.lengths() != before.lengths(),
            !dirty.lengths.is_empty(),
            "step {step}: lengths logged"
        );
        live += state.index_count();
        // The same place again: nothing to upload.
        state
            .set_with(&model, t, lod, Strategy::Rebuild)
            .expect("valid request");
        assert_eq!(state.take_dirty(), Default::default(), "step {step}");
    }
    eprintln!("rebuilds logged {logged} of {live} live positions");
    assert!(logged < live, "{logged} logged of {live} live");
}

#[test]
fn bad_assets_and_requests_are_rejected() {
    let tris = vec![[0, 1, 2], [0, 2, 3]];
    let good = Asset {
        v0: vec![[0.0; 3]; 4],
        v1: vec![[1.0; 3]; 4],
        s0: stripify(&tris, 4),
        frames: vec![Arc::new(random_sequence(&tris, 4, 2, &mut Rng(1)))],
        blend: None,
        surface: None,
        skin: None,
    };
    let model = DeformingModel::new(&good).expect("valid asset");
    let bad = |edit: &dyn Fn(&mut Asset)| {
        let mut a = good.clone();
        edit(&mut a);
        DeformingModel::new(&a).expect_err("invalid asset accepted")
    };
    assert_eq!(bad(&|a| a.frames.clear()), DeformError::NoFrames);
    assert!(matches!(
        bad(&|a| a.v1.pop().map(drop).unwrap_or(())),
        DeformError::PoseSizeMismatch { v0: 4, v1: 3 }
    ));
    assert!(matches!(
        bad(&|a| a.v0[2][1] = f32::NAN),
        DeformError::NonFinite {
            pose: "V(0)",
            vertex: 2,
            ..
        }
    ));
    assert!(matches!(
        bad(&|a| a.s0.indices[0] = 9),
        DeformError::Strips(_)
    ));
    assert!(matches!(
        bad(&|a| a.s0.offsets.push(99)),
        DeformError::Strips(_)
    ));
    assert!(matches!(
        bad(&|a| a.frames.push(Arc::new(CollapseSequence {
            vertex_count: 5,
            collapses: Vec::new()
        }))),
        DeformError::FrameVertexCount { frame: 1, .. }
    ));
    assert!(matches!(
        bad(&|a| {
            let mut s = (*a.frames[0]).clone();
            s.collapses.push(s.collapses[0]);
            a.frames.push(Arc::new(s));
        }),
        DeformError::Sequence { frame: 1, .. }
    ));
    for e in [bad(&|a| a.frames.clear()), bad(&|a| a.v0[2][1] = f32::NAN)] {
        assert!(!e.to_string().is_empty());
    }

    let mut state = DeformingState::new(&model);
    assert_eq!(
        state.set(&model, f32::NAN, Lod::Steps(1)),
        Err(SetError::TimeNaN)
    );
    assert!(matches!(
        state.set(&model, 0.5, Lod::Fraction(f32::NAN)),
        Err(SetError::LodNaN(_))
    ));
    assert!(matches!(
        state.set(&model, 0.5, Lod::MaxError(f32::NAN)),
        Err(SetError::LodNaN(_))
    ));
    let other = DeformingModel::new(&good).expect("valid asset");
    assert_eq!(
        state.set(&other, 0.5, Lod::Steps(1)),
        Err(SetError::WrongModel)
    );
    // Refused requests leave the state alone.
    assert_eq!((state.frame(), state.lod()), (0, 0));
    assert!(state.take_dirty().ranges.is_empty());
    state
        .set(&model, 1.0, Lod::Fraction(1.0))
        .expect("valid request");
    assert_eq!(state.lod(), 2);
}

#[test]
fn screen_error_projects_pixels_to_object_units() {
    // 90° field of view, 1000 pixels tall, 10 units away: the viewport spans
    // 20 units, so 2 pixels are 0.04 units.
    match Lod::screen_error(2.0, 10.0, std::f32::consts::FRAC_PI_2, 1000.0) {
        Lod::MaxError(e) => assert!((e - 0.04).abs() < 1e-6, "{e}"),
        other => panic!("{other:?}"),
    }
}
