//! Geometric quality of our collapse sequences against `meshopt::simplify`.
//!
//! For each real mesh (cow, bunny, man, the MakeHuman body), the reference mesh of our sequence at 10%, 5% and 2% of
//! the triangles is compared, by symmetric Hausdorff distance and RMS (Metro-style
//! surface sampling, [`morphlod::metrics`]), with meshoptimizer's result at the
//! same triangle count, both against the original. meshopt is given an error
//! limit of the whole mesh extent so only the count stops it; where it stops
//! short of the count, both are compared at the count it reached.
//!
//! Print the table with
//! `cargo test --release --test suite simplify_quality:: -- --ignored --nocapture`.

use std::path::Path;

use morphlod::metrics::{directed_error, sample_surface, symmetric, ErrorStats, SurfaceIndex};
use morphlod::simplify::{simplify, SimplifyOptions};
use morphlod::IndexedMesh;

use crate::common;
use common::lod_for;

/// Samples per surface: enough that the RMS is stable to well under 1%.
const SAMPLES: usize = 200_000;

fn load(name: &str) -> IndexedMesh {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name);
    // glTF: the base mesh with its node transform, as the renderer would place it.
    let options = morphlod::io::LoadOptions {
        apply_transforms: true,
        ..Default::default()
    };
    match morphlod::io::load_mesh(&path, &options) {
        Ok(m) => m,
        Err(e) => panic!("{name}: {e}"),
    }
}

/// Error of `tris` (over the original vertex buffer) against the original surface.
fn error(
    mesh: &IndexedMesh,
    original: &SurfaceIndex,
    original_samples: &[glam::DVec3],
    tris: &[[u32; 3]],
) -> ErrorStats {
    let index = SurfaceIndex::new(&mesh.positions, tris).expect("indices in range");
    let samples = sample_surface(&mesh.positions, tris, SAMPLES, 2).expect("indices in range");
    symmetric(
        directed_error(&samples, original),
        directed_error(original_samples, &index),
    )
}

#[test]
#[ignore = "prints the quality table; run in release"]
fn quality_vs_meshopt() {
    println!(
        "{:<18} {:>5} {:>11} | {:>10} {:>10} | {:>10} {:>10} | {:>6} {:>6}",
        "mesh", "keep", "tris", "H ours", "H meshopt", "RMS ours", "RMS mopt", "H x", "RMS x"
    );
    let mut worst = (0.0f64, 0.0f64);
    for name in ["cow.off", "bunny.obj", "man.off", "makehuman_body.glb"] {
        let mesh = load(name);
        mesh.validate().unwrap();
        let seq = simplify(
            &mesh.positions,
            &mesh.triangles,
            &SimplifyOptions::default(),
        );
        seq.validate().unwrap();
        let original = SurfaceIndex::new(&mesh.positions, &mesh.triangles).unwrap();
        let original_samples =
            sample_surface(&mesh.positions, &mesh.triangles, SAMPLES, 1).unwrap();
        let diagonal = {
            let (lo, hi) = mesh.bounds().unwrap();
            ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
                as f64
        };
        for percent in [10usize, 5, 2] {
            let target = mesh.triangles.len() * percent / 100;
            let theirs = common::meshopt_simplify(&mesh.positions, &mesh.triangles, target);
            let ours = seq.reference_mesh(
                &mesh.triangles,
                lod_for(&seq, &mesh.triangles, theirs.len()),
            );
            let e_ours = error(&mesh, &original, &original_samples, &ours);
            let e_theirs = error(&mesh, &original, &original_samples, &theirs);
            let ratio = (
                e_ours.hausdorff / e_theirs.hausdorff,
                e_ours.rms / e_theirs.rms,
            );
            worst = (worst.0.max(ratio.0), worst.1.max(ratio.1));
            // Errors in percent of the bounding box diagonal, as Metro reports them.
            let pct = |d: f64| 100.0 * d / diagonal;
            println!(
                "{:<18} {:>4}% {:>5}/{:<5} | {:>9.4}% {:>9.4}% | {:>9.4}% {:>9.4}% | {:>6.3} {:>6.3}",
                name,
                percent,
                ours.len(),
                theirs.len(),
                pct(e_ours.hausdorff),
                pct(e_theirs.hausdorff),
                pct(e_ours.rms),
                pct(e_theirs.rms),
                ratio.0,
                ratio.1
            );
        }
    }
    println!(
        "worst ratio ours/meshopt: Hausdorff {:.3}, RMS {:.3} (goal <= 1.15)",
        worst.0, worst.1
    );
}

/// Issue 3's quality goal, asserted in CI on a mid-size mesh: at 10% of the triangles our
/// reference mesh's symmetric Hausdorff distance to the original is within 1.15× of
/// `meshopt::simplify`'s at the same count. The bunny at 10% is 1.070× in the full table
/// (docs/benchmarks-log.md, "Simplifier quality against meshopt", 200k samples); this run uses
/// fewer samples to stay fast in the test profile. (Of the 10% rows, cow is 1.208× and man 1.154×:
/// the goal is not met on every mesh, see the table.)
#[test]
fn bunny_at_10_percent_within_1_15_of_meshopt() {
    const FEW: usize = 40_000;
    let mesh = load("bunny.obj");
    let seq = simplify(
        &mesh.positions,
        &mesh.triangles,
        &SimplifyOptions::default(),
    );
    let original = SurfaceIndex::new(&mesh.positions, &mesh.triangles).unwrap();
    let original_samples = sample_surface(&mesh.positions, &mesh.triangles, FEW, 1).unwrap();
    let error = |tris: &[[u32; 3]]| {
        let index = SurfaceIndex::new(&mesh.positions, tris).expect("indices in range");
        let samples = sample_surface(&mesh.positions, tris, FEW, 2).expect("indices in range");
        symmetric(
            directed_error(&samples, &original),
            directed_error(&original_samples, &index),
        )
    };
    let target = mesh.triangles.len() / 10;
    let theirs = common::meshopt_simplify(&mesh.positions, &mesh.triangles, target);
    let ours = seq.reference_mesh(
        &mesh.triangles,
        lod_for(&seq, &mesh.triangles, theirs.len()),
    );
    assert!(ours.len() <= theirs.len() && theirs.len() <= target);
    let ratio = error(&ours).hausdorff / error(&theirs).hausdorff;
    eprintln!(
        "bunny 10%: {} / {} triangles, Hausdorff ours / meshopt = {ratio:.3}",
        ours.len(),
        theirs.len()
    );
    assert!(
        ratio <= 1.15,
        "bunny at 10%: Hausdorff {ratio:.3}× meshopt's, goal <= 1.15×"
    );
}
