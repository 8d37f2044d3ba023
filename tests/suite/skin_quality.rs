//! The drawn LOD's error on a skinned character (issue 51, item 5), measured on the skinned
//! pose at dense times over the walker's `walk` loop, between the sampled frames too.
//!
//! At time `t` each method draws its LOD (the first with at most the target's triangles) over
//! the exact skinned pose `V(t)` ([`morphlod::Morph::positions_at`], what the GPU will draw),
//! and the error is the symmetric Hausdorff distance to the full skinned mesh at `t` (Metro
//! style surface samples, [`morphlod::metrics`]), in percent of `V(t)`'s bounding-box
//! diagonal. The methods:
//! * per-frame sequences as `morphlod build --animation walk --frames K` makes them: the frame
//!   `DeformingModel::frame_at(t)` shows (a loop: frames at `k / K`, wrapping);
//! * `--sequence shared` over the same `K` poses: one connectivity for every `t`;
//! * a rest-pose sequence: one sequence simplified on the bind pose, used at every `t`;
//! * gltfpack 1.3 (`gltfpack -i makehuman_walker.glb -o out.glb -si 0.1`, and with `-noq`),
//!   when the `GLTFPACK` environment variable names its executable: its output read back as
//!   a skinned morph by morphlod's reader and posed by its own (resampled) `walk`; and its
//!   `-noq` LOD's triangles over the source's vertices and `walk` (the mesh alone).
//!
//! The target is gltfpack's triangle count when it runs (10 % of the triangles asked), else
//! 10 %. The goals: per-frame max over the clip ≤ 0.7 × the rest-pose sequence's and
//! ≤ 0.7 × gltfpack's.
//!
//! `GLTFPACK=path/to/gltfpack cargo test --profile bench --test suite skin_quality:: -- --ignored --nocapture`

use crate::common;

use morphlod::build::{Builder, Sequences};
use morphlod::collapse::CollapseSequence;
use morphlod::io::{load_morph, LoadOptions, MorphSource};
use morphlod::metrics::{directed_error, sample_surface, symmetric, SurfaceIndex};
use morphlod::morph::Morph;
use morphlod::simplify::{simplify, PoseError, SimplifyOptions};
use morphlod::DeformingModel;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

fn walker_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_walker.glb")
}

fn walk(path: &Path) -> Morph {
    load_morph(
        path,
        &LoadOptions::default(),
        &MorphSource::Animation("walk".into()),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// What a method draws at `t`: its positions and triangles.
type Drawn = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// A method: its name and what it draws at each `t`.
struct Method {
    name: String,
    draw: Box<dyn Fn(f32) -> Drawn + Sync>,
}

/// Each frame's LOD with at most `target` triangles.
fn frame_lods(
    sequences: &[std::sync::Arc<CollapseSequence>],
    tris: &[[u32; 3]],
    target: usize,
) -> Vec<Vec<[u32; 3]>> {
    sequences
        .par_iter()
        .map(|seq| seq.reference_mesh(tris, common::lod_for(seq, tris, target)))
        .collect()
}

/// Per-frame sequences of `frames` frames, drawn by the frame the model shows at `t`.
fn per_frame(morph: &'static Morph, frames: usize, target: usize) -> Method {
    let (asset, _) = Builder::new(morph).frames(frames).build().unwrap();
    let lods = frame_lods(&asset.frames, morph.triangles(), target);
    let model = DeformingModel::new(&asset).unwrap();
    Method {
        name: format!("per-frame {frames}"),
        draw: Box::new(move |t| {
            let k = model.frame_at(t).unwrap();
            (morph.positions_at(t), lods[k].clone())
        }),
    }
}

/// One sequence for every `t`.
fn one(morph: &'static Morph, name: String, seq: &CollapseSequence, target: usize) -> Method {
    let lod = seq.reference_mesh(
        morph.triangles(),
        common::lod_for(seq, morph.triangles(), target),
    );
    Method {
        name,
        draw: Box::new(move |t| (morph.positions_at(t), lod.clone())),
    }
}

/// `$GLTFPACK -i makehuman_walker.glb -o OUT -si 0.1 EXTRA...`: the output's path; `None`
/// without `GLTFPACK`.
fn run_gltfpack(extra: &[&str]) -> Option<PathBuf> {
    let exe = std::env::var_os("GLTFPACK")?;
    let dir = common::scratch_dir("skin_quality", &format!("gltfpack{}", extra.join("")));
    let out = dir.join("out.glb");
    let status = std::process::Command::new(exe)
        .arg("-i")
        .arg(walker_path())
        .arg("-o")
        .arg(&out)
        .args(["-si", "0.1"])
        .args(extra)
        .status()
        .expect("gltfpack runs");
    assert!(status.success());
    Some(out)
}

/// gltfpack's output for `extra` options, read back and posed by its own `walk`, and its
/// triangle count; `None` without `GLTFPACK`.
fn gltfpack(extra: &[&str]) -> Option<(Method, usize)> {
    let morph: &'static Morph = Box::leak(Box::new(walk(&run_gltfpack(extra)?)));
    let triangles = morph.triangle_count();
    let name = format!("gltfpack -si 0.1 {}", extra.join(" "));
    Some((
        Method {
            name,
            draw: Box::new(move |t| (morph.positions_at(t), morph.triangles().to_vec())),
        },
        triangles,
    ))
}

/// gltfpack's `-noq` LOD mesh (its triangles) over the walker's own vertices and animation:
/// the mesh alone, without gltfpack's resampled and quantized animation. Its vertices are the
/// source's (a simplifier keeps a subset), found by their bind positions, bit for bit; `None`
/// without `GLTFPACK`, or when a vertex is not found.
fn gltfpack_mesh(morph: &'static Morph) -> Option<Method> {
    let out = run_gltfpack(&["-noq"])?;
    let packed = walk(&out);
    let bits = |p: &[f32; 3]| p.map(f32::to_bits);
    let source: std::collections::HashMap<[u32; 3], u32> = morph
        .base()
        .iter()
        .enumerate()
        .map(|(v, p)| (bits(p), v as u32))
        .collect();
    let vertex: Option<Vec<u32>> = packed
        .base()
        .iter()
        .map(|p| source.get(&bits(p)).copied())
        .collect();
    let vertex = vertex?;
    let lod: Vec<[u32; 3]> = packed
        .triangles()
        .iter()
        .map(|t| t.map(|v| vertex[v as usize]))
        .collect();
    Some(Method {
        name: "gltfpack mesh, our walk".into(),
        draw: Box::new(move |t| (morph.positions_at(t), lod.clone())),
    })
}

/// The full skinned mesh at one time, sampled once.
struct Full {
    index: SurfaceIndex,
    samples: Vec<glam::DVec3>,
    count: usize,
    diagonal: f64,
}

impl Full {
    fn new(positions: &[[f32; 3]], tris: &[[u32; 3]], count: usize) -> Full {
        Full {
            index: SurfaceIndex::new(positions, tris).unwrap(),
            samples: sample_surface(positions, tris, count, 1).unwrap(),
            count,
            diagonal: common::diagonal(positions),
        }
    }

    /// Symmetric Hausdorff distance of a drawn mesh to it, in % of the diagonal.
    fn error(&self, (positions, tris): &Drawn) -> f64 {
        let index = SurfaceIndex::new(positions, tris).unwrap();
        let samples = sample_surface(positions, tris, self.count, 2).unwrap();
        let e = symmetric(
            directed_error(&samples, &self.index),
            directed_error(&self.samples, &index),
        );
        100.0 * e.hausdorff / self.diagonal
    }
}

/// Per method, its error at each of `times` evenly spaced `t ∈ [0, 1)` (the loop).
fn errors(morph: &Morph, methods: &[Method], times: usize, samples: usize) -> Vec<Vec<f64>> {
    let rows: Vec<Vec<f64>> = (0..times)
        .into_par_iter()
        .map(|i| {
            let t = i as f32 / times as f32;
            let full = Full::new(&morph.positions_at(t), morph.triangles(), samples);
            methods.iter().map(|m| full.error(&(m.draw)(t))).collect()
        })
        .collect();
    (0..methods.len())
        .map(|m| rows.iter().map(|r| r[m]).collect())
        .collect()
}

fn max(values: impl Iterator<Item = f64>) -> f64 {
    values.fold(0.0, f64::max)
}

#[test]
#[ignore = "prints the walker's error table over its clip; run with --profile bench (GLTFPACK for gltfpack's rows)"]
fn skinned_quality_over_the_clip() {
    const TIMES: usize = 192;
    const SAMPLES: usize = 50_000;
    let morph: &'static Morph = Box::leak(Box::new(walk(&walker_path())));
    let tris = morph.triangles();
    let packed = gltfpack(&[]);
    let packed_noq = gltfpack(&["-noq"]);
    let target = packed.as_ref().map_or(tris.len() / 10, |p| p.1);
    let rest = simplify(&morph.v0(), tris, &SimplifyOptions::default());
    let shared = |frames: usize| {
        let (asset, _) = Builder::new(morph)
            .frames(frames)
            .sequences(Sequences::Shared(PoseError::Max))
            .build()
            .unwrap();
        one(morph, format!("shared {frames}"), &asset.frames[0], target)
    };
    let mut methods = vec![
        per_frame(morph, 8, target),
        per_frame(morph, 16, target),
        per_frame(morph, 32, target),
        shared(16),
        one(morph, "rest pose".into(), &rest, target),
    ];
    methods.extend(packed.map(|p| p.0));
    methods.extend(packed_noq.map(|p| p.0));
    methods.extend(gltfpack_mesh(morph));
    let errors = errors(morph, &methods, TIMES, SAMPLES);
    println!(
        "\nmakehuman_walker 'walk': {} triangles, target {target}; symmetric Hausdorff over {TIMES} times in [0, 1), % of V(t)'s diagonal",
        tris.len()
    );
    println!(
        "{:<24} | {:>8} {:>8} | {:>10} {:>10} | {:>6} {:>7}",
        "method", "max", "mean", "at frames", "mid frames", "/rest", "/gltfpk"
    );
    let rest_max = max(errors[4].iter().copied());
    let pack_max = (methods.len() > 5).then(|| max(errors[5].iter().copied()));
    for (m, e) in methods.iter().zip(&errors) {
        // Frames at k / K: on the grid of TIMES every TIMES / K steps, midpoints half way.
        let k: usize = m
            .name
            .strip_prefix("per-frame ")
            .and_then(|k| k.parse().ok())
            .unwrap_or(0);
        let (at, mid) = match k {
            0 => ("-".to_string(), "-".to_string()),
            k => {
                let step = TIMES / k;
                let pick = |offset: usize| {
                    let worst = max(e
                        .iter()
                        .enumerate()
                        .filter(|(i, _)| i % step == offset)
                        .map(|(_, v)| *v));
                    format!("{worst:.4}%")
                };
                (pick(0), pick(step / 2))
            }
        };
        let worst = max(e.iter().copied());
        println!(
            "{:<24} | {:>7.4}% {:>7.4}% | {:>10} {:>10} | {:>6.3} {:>7}",
            m.name,
            worst,
            e.iter().sum::<f64>() / e.len() as f64,
            at,
            mid,
            worst / rest_max,
            pack_max.map_or("-".into(), |p| format!("{:.3}", worst / p))
        );
    }
}

/// Issue 51's error goal in CI: on the walker at 10 % of the triangles, the per-frame
/// sequences of 16 frames drawn at dense times (between frames too) stay at most 0.7 × the
/// rest-pose sequence's error, max over the clip. (The table above gives the full figures;
/// this samples 24 times with 10,000 samples each.)
#[test]
fn walker_per_frame_at_most_0_7_of_rest_pose() {
    let morph: &'static Morph = Box::leak(Box::new(walk(&walker_path())));
    let target = morph.triangle_count() / 10;
    let rest = simplify(&morph.v0(), morph.triangles(), &SimplifyOptions::default());
    let methods = [
        per_frame(morph, 16, target),
        one(morph, "rest pose".into(), &rest, target),
    ];
    let errors = errors(morph, &methods, 24, 10_000);
    let (ours, theirs) = (
        max(errors[0].iter().copied()),
        max(errors[1].iter().copied()),
    );
    assert!(
        ours <= 0.7 * theirs,
        "per-frame {ours:.4}% against the rest pose's {theirs:.4}% of the diagonal"
    );
}
