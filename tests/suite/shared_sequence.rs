//! One collapse sequence for every pose (`Sequences::Shared`, `simplify_poses`): what it is
//! for and that it holds.
//!
//! Error over the animation at equal triangle counts (10%, 5%, 2%): the maximum and the mean
//! over 64 evenly spaced `t` of the symmetric Hausdorff distance and RMS (Metro-style
//! sampling, `morphlod::metrics`) between a LOD at `t` and the full mesh `V(t)`, in % of the
//! diagonal of `V(t)`, for
//! * (s) the shared pose-aware sequence over 32 sampled poses, error = maximum over poses
//!   (the default, `PoseError::Max`);
//! * (x) the same with error = mean over poses (Mohr and Gleicher's sum);
//! * (b) one sequence of the rest pose `V(0)`;
//! * (m) `meshopt::simplify` of the base pose with `Regularize` (what gltfpack does for meshes
//!   with morph targets), drawn at every `t`;
//! * (a) the per-frame sequences (frame `round(31 t)` at `t`);
//! * (d) (s) with the distance term (`SimplifyOptions::distance_weight` = `DISTANCE_WEIGHT`,
//!   `--distance-weight 4`), in the printed table only (its build is slow for the test
//!   profile).
//!
//! `cargo test --release --test suite shared_sequence:: -- --ignored --nocapture`

use morphlod::build::Sequences;
use morphlod::io::MorphSource;
use morphlod::morph::Morph;
use morphlod::simplify::{simplify, simplify_poses, PoseError, SimplifyOptions, DISTANCE_WEIGHT};
use morphlod::{Builder, DeformingModel, DeformingState, Lod};
use rayon::prelude::*;

use crate::common;
use common::{lod_for, meshopt_simplify_with, FullSurface};

const FRAMES: usize = 32;

/// Symmetric Hausdorff and RMS of `lod` against the full mesh at `t`, in % of the diagonal.
fn error_at(morph: &Morph, t: f32, lod: &[[u32; 3]], samples: usize) -> (f64, f64) {
    let tris = morph.triangles();
    let pos = morph.positions_at(t);
    let diagonal = common::diagonal(&pos);
    let e = FullSurface::new(&pos, tris, samples).error(lod);
    (100.0 * e.hausdorff / diagonal, 100.0 * e.rms / diagonal)
}

const METHODS: [&str; 6] = [
    "(s) shared max",
    "(x) shared mean",
    "(b) rest pose",
    "(m) meshopt",
    "(a) per-frame",
    "(d) shared+dist",
];

/// Per method and percent: (max H, mean H, max RMS, mean RMS, mean triangles) over `times`;
/// method (d) only `with_distance`.
fn table(
    name: &str,
    morph: &Morph,
    percents: &[usize],
    times: usize,
    samples: usize,
    with_distance: bool,
) -> Vec<Vec<[f64; 5]>> {
    let tris = morph.triangles();
    let build = |sequences, options| {
        Builder::new(morph)
            .frames(FRAMES)
            .sequences(sequences)
            .simplify_options(options)
            .build()
            .expect("the morph builds")
            .0
    };
    let quadrics = SimplifyOptions::default;
    let start = std::time::Instant::now();
    let shared_max = build(Sequences::Shared(PoseError::Max), quadrics());
    println!("{name}: (s) built in {:.2?}", start.elapsed());
    let shared_mean = build(Sequences::Shared(PoseError::Mean), quadrics());
    let per_frame = build(Sequences::PerFrame, quadrics());
    let shared_distance = with_distance.then(|| {
        let options = SimplifyOptions {
            distance_weight: DISTANCE_WEIGHT,
            ..SimplifyOptions::default()
        };
        let start = std::time::Instant::now();
        let asset = build(Sequences::Shared(PoseError::Max), options);
        println!("{name}: (d) built in {:.2?}", start.elapsed());
        asset
    });
    let v0 = morph.v0();
    let lods: Vec<Vec<Vec<Vec<[u32; 3]>>>> = percents
        .iter()
        .map(|p| {
            let target = tris.len() * p / 100;
            let reference = |seq: &morphlod::CollapseSequence| {
                seq.reference_mesh(tris, lod_for(seq, tris, target))
            };
            let mut methods = vec![
                vec![reference(&shared_max.frames[0])],
                vec![reference(&shared_mean.frames[0])],
                vec![reference(&per_frame.frames[0])],
                vec![meshopt_simplify_with(
                    &v0,
                    tris,
                    target,
                    meshopt::SimplifyOptions::Regularize,
                )],
                per_frame.frames.par_iter().map(|s| reference(s)).collect(),
            ];
            if let Some(asset) = &shared_distance {
                methods.push(vec![reference(&asset.frames[0])]);
            }
            methods
        })
        .collect();
    // rows[i][p][m] = (H, RMS, triangles) at time i.
    let rows: Vec<Vec<Vec<(f64, f64, usize)>>> = (0..times)
        .into_par_iter()
        .map(|i| {
            let t = i as f32 / (times - 1) as f32;
            let k = (t * (FRAMES - 1) as f32).round() as usize;
            lods.iter()
                .map(|methods| {
                    methods
                        .iter()
                        .map(|lods| {
                            let lod = &lods[if lods.len() == 1 { 0 } else { k }];
                            let (h, rms) = error_at(morph, t, lod, samples);
                            (h, rms, lod.len())
                        })
                        .collect()
                })
                .collect()
        })
        .collect();
    println!(
        "\n{name}: {} triangles, {FRAMES} poses/frames, {times} t, % of the V(t) diagonal",
        tris.len()
    );
    println!(
        "{:>4} | {:<16} | {:>8} {:>8} | {:>8} {:>8} | {:>6}",
        "keep", "method", "max H", "mean H", "max RMS", "mean RMS", "tris"
    );
    let mut out = Vec::new();
    for (p, percent) in percents.iter().enumerate() {
        let mut per_method = Vec::new();
        for (m, method) in METHODS.iter().enumerate().take(lods[p].len()) {
            let column: Vec<(f64, f64, usize)> = rows.iter().map(|r| r[p][m]).collect();
            let n = column.len() as f64;
            let stats = [
                column.iter().map(|c| c.0).fold(0.0, f64::max),
                column.iter().map(|c| c.0).sum::<f64>() / n,
                column.iter().map(|c| c.1).fold(0.0, f64::max),
                column.iter().map(|c| c.1).sum::<f64>() / n,
                column.iter().map(|c| c.2 as f64).sum::<f64>() / n,
            ];
            println!(
                "{percent:>3}% | {method:<16} | {:>7.3}% {:>7.3}% | {:>7.4}% {:>7.4}% | {:>6.0}",
                stats[0], stats[1], stats[2], stats[3], stats[4]
            );
            per_method.push(stats);
        }
        let [s, x, _, m, a] = [0, 1, 2, 3, 4].map(|i| per_method[i][0]);
        println!(
            "{percent:>3}% | max-over-t H: (s)/(m) {:.3} (goal <= 0.7), (x)/(m) {:.3}, (s)/(a) {:.3} (goal <= 1.25), (x)/(a) {:.3}",
            s / m,
            x / m,
            s / a,
            x / a
        );
        if let Some(d) = per_method.get(5) {
            println!(
                "{percent:>3}% | max-over-t H: (d)/(m) {:.3}, (d)/(s) {:.3}, (d)/(a) {:.3}",
                d[0] / m,
                d[0] / s,
                d[0] / a
            );
        }
        out.push(per_method);
    }
    out
}

#[test]
#[ignore = "prints the pose-aware quality table; run in release"]
fn pose_aware_quality_over_the_animation() {
    let body =
        common::load_asset_morph("makehuman_body.glb", MorphSource::Animation("morph".into()));
    table(
        "makehuman_body (animation over its 4 morphs)",
        &body,
        &[10, 5, 2],
        64,
        50_000,
        true,
    );
    let face = common::load_asset_morph(
        "makehuman_face.glb",
        MorphSource::Animation("expressions".into()),
    );
    table(
        "makehuman_face (expressions animation, seams)",
        &face,
        &[10, 5, 2],
        64,
        50_000,
        true,
    );
    let head =
        common::load_asset_morph("makehuman_head.glb", MorphSource::Animation("morph".into()));
    table(
        "makehuman_head (expression animation)",
        &head,
        &[10, 5, 2],
        64,
        50_000,
        true,
    );
}

/// Issue 12's goals, asserted: on the body's animation at 10% of the triangles, the
/// max-over-t Hausdorff error of the shared pose-aware sequence (maximum over poses, the
/// default) is at most 0.7× that of meshoptimizer on the base pose and at most 1.25× that of
/// the per-frame sequences. Fewer times and samples than the table to fit the test profile.
/// (With the mean over poses the first fails; without the per-pose scale the second does,
/// 1.70×: the baby pose, much smaller than the others, was given up. The 17 t include its
/// peak at t = 5/8.)
#[test]
fn shared_sequence_beats_base_pose_simplification_on_the_body() {
    let body =
        common::load_asset_morph("makehuman_body.glb", MorphSource::Animation("morph".into()));
    let rows = table("makehuman_body, 10%", &body, &[10], 17, 20_000, false);
    let [s, _, _, m, a] = [0, 1, 2, 3, 4].map(|i| rows[0][i][0]);
    assert!(
        s <= 0.7 * m,
        "shared sequence (max over poses) {s:.3}% vs meshopt on the base pose {m:.3}%: goal <= 0.7x"
    );
    assert!(
        s <= 1.25 * a,
        "shared sequence (max over poses) {s:.3}% vs the per-frame sequences {a:.3}%: goal <= 1.25x"
    );
}

/// Issue 12's goal on the face with what `export` builds by default (the shared sequence with
/// the distance term): max-over-t Hausdorff error at most 0.7× meshoptimizer's on the base pose
/// at 10% and 5% of the triangles, and at 2% no worse than 0.8× (measured 0.73: the goal's
/// 0.7 is not met there; docs/benchmarks-log.md, "The face at 2%: what is left, and what did
/// not close it (2026-11-25)"). Quadrics alone give 1.06 at 2%, so this fails if the
/// term is lost. 17 t and 20,000 samples a side to fit the test profile.
#[test]
fn export_sequence_beats_base_pose_simplification_on_the_face() {
    let face = common::load_asset_morph(
        "makehuman_face.glb",
        MorphSource::Animation("expressions".into()),
    );
    let tris = face.triangles();
    let (asset, _) = Builder::new(&face)
        .frames(FRAMES)
        .sequences(Sequences::Shared(PoseError::Max))
        .simplify_options(SimplifyOptions {
            // What `morphlod::export::ExportOptions::default()` simplifies with.
            distance_weight: DISTANCE_WEIGHT,
            ..SimplifyOptions::default()
        })
        .build()
        .expect("the face builds");
    let sequence = &asset.frames[0];
    let v0 = face.v0();
    for (percent, goal) in [(10, 0.7), (5, 0.7), (2, 0.8)] {
        let target = tris.len() * percent / 100;
        let ours = sequence.reference_mesh(tris, lod_for(sequence, tris, target));
        let meshopt =
            meshopt_simplify_with(&v0, tris, target, meshopt::SimplifyOptions::Regularize);
        let worst = |lod: &[[u32; 3]]| {
            (0..17)
                .into_par_iter()
                .map(|i| error_at(&face, i as f32 / 16.0, lod, 20_000).0)
                .reduce(|| 0.0, f64::max)
        };
        let (d, m) = (worst(&ours), worst(&meshopt));
        println!(
            "face {percent}%: export's sequence {d:.3}%, meshopt {m:.3}%: {:.3}",
            d / m
        );
        assert!(
            d <= goal * m,
            "{percent}%: export's sequence {d:.3}% vs meshopt on the base pose {m:.3}%: goal <= {goal}x"
        );
    }
}

/// The harness of docs/benchmarks-log.md, "The face at 2%": the face's shared sequence with the
/// distance term, built with the options in `FACE_OPTIONS` (space-separated `field=value` of
/// [`SimplifyOptions`]: `distance_weight`, `normal_weight`, `uv_weight`, `seam_weight`,
/// `regularization`, `min_normal_cos`, `boundary_weight`; unset, what `export` uses), at 10, 5
/// and 2% of the triangles over 17 t with 20,000 samples a side: the symmetric Hausdorff
/// error (each one-sided part: LOD→full, full→LOD), the sequence's own bound
/// `sqrt(largest error / distance_weight)` in the base pose, and the ratio to meshoptimizer's.
///
/// `FACE_OPTIONS="normal_weight=0.05" cargo test --release --test suite \
///     shared_sequence::face_levels_under_options -- --ignored --nocapture`
#[test]
#[ignore = "prints the face's levels under the options given; run in release"]
fn face_levels_under_options() {
    let mut options = SimplifyOptions {
        distance_weight: DISTANCE_WEIGHT,
        ..SimplifyOptions::default()
    };
    for pair in std::env::var("FACE_OPTIONS")
        .unwrap_or_default()
        .split_whitespace()
    {
        let (field, value) = pair.split_once('=').expect("field=value");
        let value: f32 = value.parse().expect("a number");
        match field {
            "distance_weight" => options.distance_weight = value,
            "normal_weight" => options.normal_weight = value,
            "uv_weight" => options.uv_weight = value,
            "seam_weight" => options.seam_weight = value,
            "regularization" => options.regularization = value,
            "min_normal_cos" => options.min_normal_cos = value,
            "boundary_weight" => options.boundary_weight = value,
            other => panic!("unknown option {other}"),
        }
    }
    let face = common::load_asset_morph(
        "makehuman_face.glb",
        MorphSource::Animation("expressions".into()),
    );
    let tris = face.triangles();
    let (asset, _) = Builder::new(&face)
        .frames(FRAMES)
        .sequences(Sequences::Shared(PoseError::Max))
        .simplify_options(options.clone())
        .build()
        .expect("the face builds");
    let sequence = &asset.frames[0];
    let v0 = face.v0();
    let diagonal = common::diagonal(&v0);
    println!("{options:?}");
    for percent in [10, 5, 2] {
        let target = tris.len() * percent / 100;
        let level = lod_for(sequence, tris, target);
        let ours = sequence.reference_mesh(tris, level);
        let meshopt =
            meshopt_simplify_with(&v0, tris, target, meshopt::SimplifyOptions::Regularize);
        // Per t: (H, LOD→full, full→LOD) in % of V(t)'s diagonal; the largest over t.
        let worst = |lod: &[[u32; 3]]| {
            (0..17)
                .into_par_iter()
                .map(|i| {
                    let pos = face.positions_at(i as f32 / 16.0);
                    let d = 100.0 / common::diagonal(&pos);
                    let e = FullSurface::new(&pos, tris, 20_000).error(lod);
                    [e.hausdorff * d, e.a_to_b.max * d, e.b_to_a.max * d]
                })
                .reduce(|| [0.0; 3], |a, b| std::array::from_fn(|k| a[k].max(b[k])))
        };
        let ([h, lod_full, full_lod], [m, ..]) = (worst(&ours), worst(&meshopt));
        let largest = sequence.collapses[..level]
            .iter()
            .map(|c| c.error as f64)
            .fold(0.0, f64::max);
        let bound = 100.0 * (largest / options.distance_weight as f64).sqrt() / diagonal;
        println!(
            "{percent}%: {} triangles, H {h:.3}% (LOD->full {lod_full:.3}%, full->LOD {full_lod:.3}%), bound {bound:.3}%, meshopt {m:.3}%, ratio {:.3}",
            ours.len(),
            h / m
        );
    }
}

/// A flat grid (`V(0)`) and the same grid twisted about its centre (`V(1)`: each point turned
/// by `π/2 (1 − r/R)` inside the radius `R`). The twist preserves area and orientation, so every
/// full-detail triangle faces +z in both poses, but a large triangle whose corners turn by
/// different angles can flip in the twisted pose.
fn grid_poses(side: u32) -> TwoPoses {
    let morph = common::grid_morph(side, |_, _| 0.0);
    let c = (side - 1) as f32 / 2.0;
    let twisted = morph
        .v0()
        .iter()
        .map(|&[x, y, _]| {
            let (dx, dy) = (x - c, y - c);
            let angle =
                0.5 * std::f32::consts::PI * (1.0 - (dx * dx + dy * dy).sqrt() / c).max(0.0);
            let (sin, cos) = angle.sin_cos();
            [c + cos * dx - sin * dy, c + sin * dx + cos * dy, 0.0]
        })
        .collect();
    TwoPoses(morph.v0(), twisted, morph.triangles().to_vec())
}

/// `V(0)`, `V(1)` and the triangles.
struct TwoPoses(Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<[u32; 3]>);

/// Triangles of the reference meshes at every LOD of `seq` that face -z or degenerate in
/// `pose`.
fn flipped(seq: &morphlod::CollapseSequence, tris: &[[u32; 3]], pose: &[[f32; 3]]) -> usize {
    (0..=seq.len())
        .flat_map(|lod| seq.reference_mesh(tris, lod))
        .filter(|t| {
            let [a, b, c] = t.map(|v| glam::Vec3::from(pose[v as usize]));
            (b - a).cross(c - a).z <= 0.0
        })
        .count()
}

/// Equal poses change nothing: the shared sequence of `[p, p]` (mean or max) is `p`'s own
/// sequence, collapse for collapse, error for error.
#[test]
fn repeated_poses_give_the_single_pose_sequence() {
    let TwoPoses(v0, v1, tris) = grid_poses(12);
    for pose in [&v0, &v1] {
        let one = simplify(pose, &tris, &SimplifyOptions::default());
        for combine in [PoseError::Mean, PoseError::Max] {
            let two = simplify_poses(&[pose, pose], &tris, &SimplifyOptions::default(), combine);
            assert_eq!(one, two, "{combine:?}");
        }
    }
}

/// A pose counts by its error relative to its own size: scaling one pose by 4 (a power of two,
/// so every product scales exactly) leaves the shared sequence unchanged, collapse for collapse
/// and error for error (errors are in the first pose's units). Without the per-pose scale the
/// larger pose's errors (16× here) decide alone, and its bumps are kept at the other's cost.
#[test]
fn scaling_a_pose_changes_nothing() {
    let side = 16;
    let bumps = |cx: f32, cy: f32| {
        common::grid_morph(side, move |x, y| {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            2.0 * (-(dx * dx + dy * dy) / 6.0).exp()
        })
        .v1()
    };
    let a = bumps(4.0, 4.0);
    let b = bumps(11.0, 10.0);
    let b4: Vec<[f32; 3]> = b.iter().map(|p| p.map(|c| 4.0 * c)).collect();
    let tris = common::grid_morph(side, |_, _| 0.0).triangles().to_vec();
    for combine in [PoseError::Max, PoseError::Mean] {
        let options = SimplifyOptions::default();
        let plain = simplify_poses(&[&a, &b], &tris, &options, combine);
        let scaled = simplify_poses(&[&a, &b4], &tris, &options, combine);
        assert_eq!(plain, scaled, "{combine:?}");
    }
}

/// The shared sequence refuses every collapse that flips a triangle in any pose: no triangle
/// of any LOD faces -z in either pose of the twisted grid. The rest pose's own sequence does
/// flip triangles of the twisted pose (so the check can fail).
#[test]
fn no_pose_flips_a_triangle() {
    let TwoPoses(v0, v1, tris) = grid_poses(16);
    for combine in [PoseError::Mean, PoseError::Max] {
        let seq = simplify_poses(&[&v0, &v1], &tris, &SimplifyOptions::default(), combine);
        seq.validate().expect("a valid sequence");
        assert_eq!(flipped(&seq, &tris, &v0), 0, "{combine:?}, pose 0");
        assert_eq!(flipped(&seq, &tris, &v1), 0, "{combine:?}, pose 1");
    }
    let rest = simplify(&v0, &tris, &SimplifyOptions::default());
    assert!(
        flipped(&rest, &tris, &v1) > 0,
        "the rest-pose sequence flips none"
    );
}

/// The runtime takes a shared asset as it is: one frame, no frame switches, every `t` shows
/// the same connectivity, and LOD requests resolve against the one frame.
#[test]
fn a_shared_asset_has_one_frame_for_every_t() {
    let TwoPoses(v0, v1, tris) = grid_poses(10);
    let morph = Morph::from_poses(tris, v0, v1).expect("a morph");
    let (asset, report) = Builder::new(&morph)
        .frames(8)
        .sequences(Sequences::Shared(PoseError::Mean))
        .build()
        .expect("it builds");
    assert_eq!(asset.frames.len(), 1);
    assert_eq!(report.collapses.len(), 1);
    let model = DeformingModel::new(&asset).expect("a model");
    let mut state = DeformingState::new(&model);
    for (t, fraction) in [(0.0, 0.5), (0.3, 0.5), (1.0, 0.9), (0.6, 0.1)] {
        state
            .set(&model, t, Lod::Fraction(fraction))
            .expect("a valid request");
        assert_eq!(state.frame(), 0);
    }
}
