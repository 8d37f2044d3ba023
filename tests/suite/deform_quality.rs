//! The reason per-frame sequences exist: geometric error over the animation.
//!
//! For a morph, at 10% and 5% of the triangles, the mean over 64 evenly spaced
//! `t ∈ [0, 1]` of the symmetric Hausdorff distance (and RMS) between a LOD mesh
//! at `t` and the full mesh `V(t)`, for
//! * (a) per-frame sequences as [`Builder`] makes them: |r| = 32 frames sampled at `t_k = k/31`, each
//!   simplified on its own pose; at `t` the frame `k = round(31 t)` is used, its
//!   reference mesh at the first LOD with at most the target triangle count,
//!   over the exact positions `V(t)` (as the GPU blends them);
//! * (b) one sequence computed at `t = 0` used for every `t` (frame 0 of (a));
//! * (c) `meshopt::simplify` run on `V(t)` itself, to the same triangle count:
//!   a per-pose optimum, not continuous.
//!
//! Errors are in percent of the bounding-box diagonal of `V(t)`, Metro-style
//! surface sampling ([`morphlod::metrics`]). The goal for the body with
//! the baby target (a large deformation): (a) ≤ 0.7 × (b) and (a) ≤ 1.2 × (c).
//! The head with its expression animation (a small deformation) is the
//! control: there (a) ≈ (b) is expected.
//!
//! `cargo test --profile bench --test suite deform_quality:: -- --ignored --nocapture`

use std::path::Path;

use morphlod::io::LoadOptions;
use morphlod::io::MorphSource;
use morphlod::Builder;

use crate::common;
use common::{lod_for, FullSurface};
use rayon::prelude::*;

/// Sampled frames of the per-frame builder (the CLI's default).
const FRAMES: usize = 32;
/// Evaluation times, evenly spaced over `[0, 1]`.
const TIMES: usize = 64;
/// Samples per surface and comparison (plus every vertex of the surface).
const SAMPLES: usize = 50_000;
const PERCENTS: [usize; 2] = [10, 5];

/// Per time: for each percent, (a), (b), (c) as (Hausdorff %, RMS %, triangles).
type Row = Vec<[(f64, f64, usize); 3]>;

fn table(file: &str, source: MorphSource) -> Vec<[(f64, f64); 3]> {
    let name = format!("{file} ({source:?})");
    let morph = common::load_asset_morph(file, source);
    let tris = morph.triangles();
    let (asset, _) = Builder::new(&morph)
        .frames(FRAMES)
        .build()
        .expect("the morph builds");
    let frames = asset.frames;
    for seq in &frames {
        seq.validate().expect("a valid sequence");
    }
    let targets: Vec<usize> = PERCENTS.iter().map(|p| tris.len() * p / 100).collect();
    // Each frame's LOD triangles at each target: index lists do not depend on
    // t, only the positions they are drawn with do.
    let lods: Vec<Vec<Vec<[u32; 3]>>> = frames
        .par_iter()
        .map(|seq| {
            targets
                .iter()
                .map(|&target| seq.reference_mesh(tris, lod_for(seq, tris, target)))
                .collect()
        })
        .collect();

    let rows: Vec<Row> = (0..TIMES)
        .into_par_iter()
        .map(|i| {
            let t = i as f32 / (TIMES - 1) as f32;
            let k = (t * (FRAMES - 1) as f32).round() as usize;
            let pos = morph.positions_at(t);
            let diagonal = common::diagonal(&pos);
            let full = FullSurface::new(&pos, tris, SAMPLES);
            targets
                .iter()
                .enumerate()
                .map(|(p, &target)| {
                    let theirs = common::meshopt_simplify(&pos, tris, target);
                    let candidates = [&lods[k][p], &lods[0][p], &theirs];
                    candidates.map(|lod| {
                        assert!(
                            !lod.is_empty() && lod.len() <= target,
                            "{name} t={t}: {} triangles for a target of {target}",
                            lod.len()
                        );
                        let e = full.error(lod);
                        assert!(e.hausdorff.is_finite() && e.rms.is_finite());
                        (
                            100.0 * e.hausdorff / diagonal,
                            100.0 * e.rms / diagonal,
                            lod.len(),
                        )
                    })
                })
                .collect()
        })
        .collect();

    println!(
        "\n{name}: {} triangles, {FRAMES} frames, mean over {TIMES} t (% of V(t) diagonal)",
        tris.len()
    );
    println!(
        "{:>5} | {:>9} {:>9} {:>9} | {:>9} {:>9} {:>9} | {:>6} {:>6} | {:>17}",
        "keep",
        "H (a)",
        "H (b)",
        "H (c)",
        "RMS (a)",
        "RMS (b)",
        "RMS (c)",
        "a/b",
        "a/c",
        "mean tris a/b/c"
    );
    let mut out = Vec::new();
    for (p, percent) in PERCENTS.iter().enumerate() {
        let mean = |m: usize, f: &dyn Fn((f64, f64, usize)) -> f64| {
            rows.iter().map(|r| f(r[p][m])).sum::<f64>() / rows.len() as f64
        };
        let h = [0, 1, 2].map(|m| mean(m, &|x| x.0));
        let rms = [0, 1, 2].map(|m| mean(m, &|x| x.1));
        let count = [0, 1, 2].map(|m| mean(m, &|x| x.2 as f64));
        println!(
            "{:>4}% | {:>8.4}% {:>8.4}% {:>8.4}% | {:>8.4}% {:>8.4}% {:>8.4}% | {:>6.3} {:>6.3} | {:>5.0} {:>5.0} {:>5.0}",
            percent,
            h[0], h[1], h[2],
            rms[0], rms[1], rms[2],
            h[0] / h[1],
            h[0] / h[2],
            count[0], count[1], count[2]
        );
        out.push([0, 1, 2].map(|m| (h[m], rms[m])));
    }
    // Where along the animation the methods part: (a) and (b) coincide at
    // t = 0 and drift apart as the pose leaves the one (b) was built on.
    for (p, percent) in PERCENTS.iter().enumerate() {
        let along: Vec<String> = [0, TIMES / 4, TIMES / 2, 3 * TIMES / 4, TIMES - 1]
            .iter()
            .map(|&i| {
                let r = rows[i][p];
                format!(
                    "t={:.2}: {:.3}/{:.3}/{:.3}",
                    i as f64 / (TIMES - 1) as f64,
                    r[0].0,
                    r[1].0,
                    r[2].0
                )
            })
            .collect();
        println!(
            "{percent:>4}% H% (a)/(b)/(c) along t | {}",
            along.join(" | ")
        );
    }
    out
}

#[test]
#[ignore = "prints the quality-over-the-animation table; run with --profile bench"]
fn quality_over_the_animation() {
    let body = table(
        "makehuman_body.glb",
        MorphSource::Target("caucasian-male-baby".into()),
    );
    for (p, row) in PERCENTS.iter().zip(&body) {
        let (a, b, c) = (row[0].0, row[1].0, row[2].0);
        println!(
            "body {p}%: (a) <= 0.7 (b): {} ({:.3}), (a) <= 1.2 (c): {} ({:.3})",
            if a <= 0.7 * b { "met" } else { "NOT met" },
            a / b,
            if a <= 1.2 * c { "met" } else { "NOT met" },
            a / c
        );
    }
    table("makehuman_head.glb", MorphSource::Animation("morph".into()));
}

/// Issue 4's quality goal, asserted in CI: on the body with the baby target at 10% of the
/// triangles, the mean Hausdorff error of the per-frame sequences (a) is at most 0.7× that of the
/// one rest-pose sequence (b). The full table above measures 0.589 (64 times, 50k samples); this
/// run samples 16 times with 20k samples each to fit the test profile.
#[test]
fn body_baby_per_frame_at_most_0_7_of_rest_pose() {
    const TIMES: usize = 16;
    const FEW: usize = 20_000;
    let morph = common::load_asset_morph(
        "makehuman_body.glb",
        MorphSource::Target("caucasian-male-baby".into()),
    );
    let tris = morph.triangles();
    let (asset, _) = Builder::new(&morph)
        .frames(FRAMES)
        .build()
        .expect("the morph builds");
    let target = tris.len() / 10;
    let lods: Vec<Vec<[u32; 3]>> = asset
        .frames
        .par_iter()
        .map(|seq| seq.reference_mesh(tris, lod_for(seq, tris, target)))
        .collect();
    let errors: Vec<(f64, f64)> = (0..TIMES)
        .into_par_iter()
        .map(|i| {
            let t = i as f32 / (TIMES - 1) as f32;
            let k = (t * (FRAMES - 1) as f32).round() as usize;
            let pos = morph.positions_at(t);
            let full = FullSurface::new(&pos, tris, FEW);
            (
                full.error(&lods[k]).hausdorff,
                full.error(&lods[0]).hausdorff,
            )
        })
        .collect();
    let (a, b) = errors
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
    let ratio = a / b;
    eprintln!("body, baby target, 10%: mean Hausdorff per-frame / rest-pose = {ratio:.3}");
    assert!(
        ratio <= 0.7,
        "body, baby target, 10%: per-frame sequences {ratio:.3}× the rest-pose error, goal <= 0.7×"
    );
}

/// Issue 10: LOD quality over t of the man → camel supermesh asset (16 frames, as the demo
/// builds it): symmetric Hausdorff and RMS of the LOD at 10% and 2% of the triangles against
/// the full supermesh `V(t)`, in % of the diagonal of `V(t)`, at t = 0, 0.25, 0.5, 0.75, 1.
/// The goal at 10%: below 0.5% at every t.
///
/// `cargo test --release --test suite deform_quality::man_to_camel -- --ignored --nocapture`
#[test]
#[ignore = "prints the man → camel supermesh quality table; run in release"]
fn man_to_camel_supermesh_quality_over_t() {
    use morphlod::morph::supermesh::{Supermesh, SupermeshOptions};
    const FRAMES: usize = 16;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let load =
        |name: &str| morphlod::io::load_mesh(&dir.join(name), &LoadOptions::default()).unwrap();
    let (man, camel) = (load("man.off"), load("camel.off"));
    let (supermesh, report) =
        Supermesh::build(&man, &camel, &SupermeshOptions::default()).expect("a supermesh");
    let morph = supermesh.to_morph().expect("a morph");
    let tris = morph.triangles();
    let (asset, _) = Builder::new(&morph)
        .frames(FRAMES)
        .build()
        .expect("the morph builds");
    let model = morphlod::DeformingModel::new(&asset).expect("a model");
    let in_memory = model.frame_bytes();
    let file = asset.to_bytes().len();
    println!(
        "\nman -> camel supermesh: {} vertices, {} triangles, {FRAMES} frames, {SAMPLES} samples; \
         file {file} B; per frame in memory (change lists, tables) mean {:.0} B",
        report.vertices,
        report.triangles,
        in_memory.iter().sum::<usize>() as f64 / in_memory.len() as f64
    );
    println!(
        "{:>5} | {:>6} | {:>9} {:>9} | {:>9}",
        "keep", "t", "H %", "RMS %", "triangles"
    );
    let mut worst_10 = 0.0f64;
    for percent in [10usize, 2] {
        let target = tris.len() * percent / 100;
        for t in [0.0f32, 0.25, 0.5, 0.75, 1.0] {
            let k = (t * (FRAMES - 1) as f32).round() as usize;
            let seq = &asset.frames[k];
            let lod = seq.reference_mesh(tris, lod_for(seq, tris, target));
            let pos = morph.positions_at(t);
            let diagonal = common::diagonal(&pos);
            let e = FullSurface::new(&pos, tris, SAMPLES).error(&lod);
            let (h, rms) = (100.0 * e.hausdorff / diagonal, 100.0 * e.rms / diagonal);
            if percent == 10 {
                worst_10 = worst_10.max(h);
            }
            println!(
                "{percent:>4}% | {t:>6.2} | {h:>8.4}% {rms:>8.4}% | {:>9}",
                lod.len()
            );
        }
    }
    println!(
        "goal at 10%: Hausdorff below 0.5% of the diagonal at every t: {} (worst {worst_10:.4}%)",
        if worst_10 < 0.5 { "met" } else { "NOT met" }
    );
}
