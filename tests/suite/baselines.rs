//! The bench's baselines (issue 26: Progressive Meshes, MTS, Skip Strips; the bench binary's
//! `baselines` module, compiled here by path) held to the same oracle as our LodStrips: after
//! every step of a random walk of `set_lod` (up, down, jumps to 0, to the coarsest and
//! anywhere), what a mirror updated only through `take_changed` draws equals the reference
//! mesh at that LOD (docs/DESIGN.md, "Definitions: the oracle"): its multiset hash and count
//! every step, the exact sorted multiset on small meshes every step and on real ones every
//! `FULL_STRIDE` steps. Strips are decoded by `common::strip_draw` (the GPU's rules), lists
//! three indices a triangle. Then Skip Strips' view-dependent mode, walked by a moving and
//! jumping viewpoint (and random cuts): every frame what it draws equals the mesh of its cut
//! (each original triangle mapped through its vertices' displayed ancestors, degenerate ones
//! dropped), the cut is one of the hierarchy's, and every drawn triangle is one that some
//! uniform LOD has (the dependencies' guarantee: no fold-over the simplifier did not check).
//! Then bad input: each refusal is a typed error.

use crate::common;
use crate::oracle::{grid, messy, sphere};

use common::{random_sequence, reference_hashes, strip_draw, tri_hash, Rng};
use morphlod::collapse::{
    canonical, canonical_multiset, Collapse, CollapseSequence, SequenceError,
};
use morphlod::lodstrips::Indices;
use morphlod::strip::{stripify, Strips};
use std::collections::HashSet;

#[path = "../../src/bin/morphlod/baselines/mod.rs"]
#[allow(dead_code)] // the bench reads what the walks do not (sizes, names)
mod model;

use model::mts::Mts;
use model::pm::ProgressiveMesh;
use model::skip_strips::{Adapted, SkipStrips};
use model::{Baseline, BaselineError, Primitive};

/// Meshes up to this size get the exact multiset compared every step.
const FULL_EVERY_STEP_TRIANGLES: usize = 3000;
const FULL_STRIDE: usize = 61;

/// The three baselines over one mesh and sequence.
fn build_all(tris: &[[u32; 3]], strips: &Strips, seq: &CollapseSequence) -> Vec<Box<dyn Baseline>> {
    vec![
        Box::new(ProgressiveMesh::build(tris, seq).expect("PM builds")),
        Box::new(Mts::build(strips, seq).expect("MTS builds")),
        Box::new(SkipStrips::build(strips, seq).expect("Skip Strips build")),
    ]
}

/// What a region draws, as the GPU would.
fn region_draws(primitive: Primitive, live: Indices) -> Vec<[u32; 3]> {
    let live = live.to_vec();
    match primitive {
        Primitive::Strips => strip_draw(&live),
        Primitive::Triangles => live
            .chunks(3)
            .map(|c| [c[0], c[1], c[2]])
            .filter(|t| !common::degenerate(*t))
            .collect(),
    }
}

/// The GPU's copy of a model's regions, updated only for the regions `take_changed` names,
/// with the multiset hash and count of what each draws.
struct Mirror {
    regions: Vec<Vec<u32>>,
    hashes: Vec<(u64, usize)>,
}

impl Mirror {
    fn new(model: &mut dyn Baseline) -> Mirror {
        let n = model.region_count();
        let mut mirror = Mirror {
            regions: vec![Vec::new(); n],
            hashes: vec![(0, 0); n],
        };
        model.take_changed();
        for r in 0..n {
            mirror.copy(model, r);
        }
        mirror
    }

    fn copy(&mut self, model: &dyn Baseline, r: usize) {
        let live = model.region(r);
        assert!(
            live.len() <= model.region_capacity(r),
            "{}: region {r} overflows its capacity",
            model.name()
        );
        self.regions[r] = live.to_vec();
        let tris = region_draws(model.primitive(), live);
        self.hashes[r] = (
            tris.iter().fold(0u64, |h, &t| h.wrapping_add(tri_hash(t))),
            tris.len(),
        );
    }

    fn update(&mut self, model: &mut dyn Baseline) {
        for r in model.take_changed() {
            self.copy(model, r as usize);
        }
    }

    fn hash(&self) -> (u64, usize) {
        self.hashes
            .iter()
            .fold((0u64, 0usize), |(h, c), &(rh, rc)| {
                (h.wrapping_add(rh), c + rc)
            })
    }

    fn triangles(&self, primitive: Primitive) -> Vec<[u32; 3]> {
        self.regions
            .iter()
            .flat_map(|live| region_draws(primitive, live.into()))
            .collect()
    }
}

/// Walks every baseline `steps` times over `seq` and checks the oracle after every step.
fn walk(name: &str, tris: &[[u32; 3]], seq: &CollapseSequence, steps: usize, seed: u64) {
    let n = seq.vertex_count as usize;
    let strips = stripify(tris, n);
    let reference = reference_hashes(tris, seq);
    let every_step = tris.len() <= FULL_EVERY_STEP_TRIANGLES;
    for mut model in build_all(tris, &strips, seq) {
        let mut rng = Rng(seed);
        let label = format!("{name}, {}", model.name());
        let max = model.max_lod();
        assert_eq!(max, seq.len(), "{label}: one LOD per collapse");
        let mut mirror = Mirror::new(model.as_mut());
        let full = |l: usize, mirror: &Mirror, model: &dyn Baseline| {
            assert_eq!(
                canonical_multiset(mirror.triangles(model.primitive())),
                canonical_multiset(seq.reference_mesh(tris, l)),
                "{label}: drawn triangles differ from the reference at LOD {l}"
            );
        };
        full(0, &mirror, model.as_ref());
        assert_eq!(mirror.hash(), reference[0], "{label} at LOD 0");
        for step in 0..steps {
            let l = model.lod();
            let target = rng.walk_lod(l, max);
            model.set_lod(target).expect("LOD in range");
            assert_eq!(model.lod(), target, "{label}");
            mirror.update(model.as_mut());
            assert_eq!(
                mirror.hash(),
                reference[target],
                "{label}: drawn multiset (hash, count) at LOD {target}, step {step}"
            );
            if every_step || step % FULL_STRIDE == 0 || step + 1 == steps {
                full(target, &mirror, model.as_ref());
            }
        }
        // The walked state equals a fresh model moved straight there.
        let mut fresh = build_all(tris, &strips, seq)
            .into_iter()
            .find(|m| m.name() == model.name())
            .expect("same model");
        fresh.set_lod(model.lod()).expect("in range");
        for r in 0..model.region_count() {
            assert_eq!(
                canonical_multiset(region_draws(model.primitive(), model.region(r))),
                canonical_multiset(region_draws(fresh.primitive(), fresh.region(r))),
                "{label}: region {r} after the walk differs from a direct move"
            );
        }
    }
}

#[test]
fn generated_meshes_random_sequences() {
    let cases = [
        (
            "grid with holes",
            grid(16, 12, |x, y| (x * 7 + y * 3) % 11 == 0),
        ),
        ("sphere", sphere(3)),
        ("messy", messy()),
    ];
    for (k, (name, (tris, n))) in cases.iter().enumerate() {
        let seq = random_sequence(tris, *n, usize::MAX, &mut Rng(10 + k as u64));
        walk(name, tris, &seq, 1500, 20 + k as u64);
    }
}

#[test]
fn partial_and_empty_sequences() {
    let (tris, n) = sphere(2);
    for (k, steps) in [0, 1, 7].into_iter().enumerate() {
        let seq = random_sequence(&tris, n, steps, &mut Rng(30 + k as u64));
        walk("sphere, partial", &tris, &seq, 100, 40 + k as u64);
    }
}

/// A real mesh with the simplifier's (QEM) sequence, as the bench builds it.
#[test]
fn cow_qem_sequence() {
    let mesh = common::load_asset_mesh("cow.off");
    let seq = morphlod::simplify::simplify(
        &mesh.positions,
        &mesh.triangles,
        &morphlod::simplify::SimplifyOptions::default(),
    );
    walk("cow.off (QEM)", &mesh.triangles, &seq, 600, 50);
}

/// A second real mesh with a random edge-collapse sequence (orders QEM never picks).
#[test]
fn bunny_random_sequence() {
    let mesh = common::load_asset_mesh("bunny.obj");
    let n = mesh.positions.len();
    let seq = random_sequence(&mesh.triangles, n, usize::MAX, &mut Rng(60));
    walk("bunny.obj (random)", &mesh.triangles, &seq, 600, 61);
}

/// The mesh of a cut through the hierarchy, from the display vertices alone: every original
/// triangle mapped through each vertex's displayed ancestor (walking the collapses backwards,
/// a merged `u` takes `w`'s, already resolved since `w` merges later), degenerate ones dropped.
fn cut_mesh(tris: &[[u32; 3]], seq: &CollapseSequence, displayed: &[u32]) -> Vec<[u32; 3]> {
    let n = seq.vertex_count as usize;
    let mut shown = vec![false; n];
    for &v in displayed {
        assert!(!shown[v as usize], "vertex {v} displayed twice");
        shown[v as usize] = true;
    }
    let mut anc: Vec<u32> = (0..n as u32).collect();
    for c in seq.collapses.iter().rev() {
        if !shown[c.u as usize] {
            anc[c.u as usize] = anc[c.w as usize];
        }
    }
    tris.iter()
        .map(|t| t.map(|v| anc[v as usize]))
        .filter(|&t| !common::degenerate(t))
        .collect()
}

/// Panics unless the display vertices are a cut of the hierarchy: a vertex that never merges
/// is displayed, the merged children of every vertex are the first ones in merge order, and a
/// merged vertex has all its children merged. Returns whether the cut is a uniform LOD (the
/// merged vertices are exactly the first collapses' `u`).
fn check_cut(seq: &CollapseSequence, displayed: &[u32], label: &str) -> bool {
    let n = seq.vertex_count as usize;
    let mut shown = vec![false; n];
    for &v in displayed {
        shown[v as usize] = true;
    }
    let rank = seq.ranks();
    for v in 0..n {
        assert!(
            shown[v] || rank[v] != morphlod::collapse::NEVER,
            "{label}: root {v} not displayed"
        );
    }
    let mut gap = vec![false; n];
    for (j, c) in seq.collapses.iter().enumerate() {
        let merged = !shown[c.u as usize];
        assert!(
            !(merged && gap[c.w as usize]),
            "{label}: step {j} merged after a later sibling split"
        );
        gap[c.w as usize] |= !merged;
        assert!(
            !(merged && gap[c.u as usize]),
            "{label}: step {j} merged with a child split"
        );
    }
    let merged = n - displayed.len();
    seq.collapses
        .iter()
        .enumerate()
        .all(|(j, c)| shown[c.u as usize] == (j >= merged))
}

/// Every oriented triangle some uniform LOD draws (canonical): the original ones, then at each
/// collapse the triangles of `u`'s class remapped, the new ones among them.
fn sequence_triangles(tris: &[[u32; 3]], seq: &CollapseSequence) -> HashSet<[u32; 3]> {
    let n = seq.vertex_count as usize;
    let mut anc: Vec<u32> = (0..n as u32).collect();
    let mut of: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut all = HashSet::new();
    for (t, tri) in tris.iter().enumerate() {
        if !common::degenerate(*tri) {
            all.insert(canonical(*tri));
        }
        for &v in tri {
            of[v as usize].push(t);
        }
    }
    for c in &seq.collapses {
        let moved = std::mem::take(&mut of[c.u as usize]);
        for a in anc.iter_mut().filter(|a| **a == c.u) {
            *a = c.w;
        }
        for &t in &moved {
            let m = tris[t].map(|v| anc[v as usize]);
            if !common::degenerate(m) {
                all.insert(canonical(m));
            }
        }
        of[c.w as usize].extend(moved);
    }
    all
}

/// Signed area of `t`'s projection on the xy plane, doubled.
fn area_xy(p: &[[f32; 3]], t: [u32; 3]) -> f32 {
    let [a, b, c] = t.map(|v| p[v as usize]);
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Walks the view-dependent Skip Strip of a mesh for `frames` frames: the eye mostly moves a
/// little, sometimes jumps, and some frames ask for a uniform LOD or for a random cut instead
/// (the criterion then wants each merge by a coin, the hardest case for the dependencies).
/// After every frame, what a mirror updated through `take_changed` draws is the mesh of the
/// cut, the cut is one of the hierarchy's, and every drawn triangle is one of the sequence's
/// (with `planar`, every one keeps its xy orientation too).
fn view_walk(
    name: &str,
    tris: &[[u32; 3]],
    positions: &[[f32; 3]],
    seq: &CollapseSequence,
    frames: usize,
    planar: bool,
    seed: u64,
) {
    let n = seq.vertex_count as usize;
    let strips = stripify(tris, n);
    let mut model = SkipStrips::build(&strips, seq).expect("Skip Strips build");
    let known = sequence_triangles(tris, seq);
    if planar {
        for &t in &known {
            assert!(
                area_xy(positions, t) > 0.0,
                "{name}: the sequence flips {t:?}"
            );
        }
    }
    let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in positions {
        for k in 0..3 {
            min[k] = min[k].min(p[k]);
            max[k] = max[k].max(p[k]);
        }
    }
    let diag = (0..3)
        .map(|k| (max[k] - min[k]).powi(2))
        .sum::<f32>()
        .sqrt();
    // Half the merges are wanted at one diagonal's distance.
    let mut errors: Vec<f32> = seq.collapses.iter().map(|c| c.error.sqrt()).collect();
    errors.sort_by(f32::total_cmp);
    let tolerance = errors.get(errors.len() / 2).copied().unwrap_or(0.0) / diag;
    let mut rng = Rng(seed);
    let point = |rng: &mut Rng, spread: f32| -> [f32; 3] {
        std::array::from_fn(|k| (min[k] + max[k]) / 2.0 + (rng.unit() - 0.5) * spread * diag)
    };
    let mut eye = point(&mut rng, 3.0);
    let mut mirror = Mirror::new(&mut model);
    let mut total = Adapted::default();
    let mut mixed_frames = 0;
    for frame in 0..frames {
        let label = format!("{name}, frame {frame}");
        match rng.below(16) {
            0 => model.set_lod(rng.below(seq.len() + 1)).expect("in range"),
            1 | 2 => {
                let salt = rng.next();
                let done = model.adapt(|m| {
                    common::mix(salt ^ u64::from(m.parent) ^ (u64::from(m.switch.to_bits()) << 32))
                        .is_multiple_of(2)
                });
                total.refused += done.refused;
            }
            k => {
                if k < 5 {
                    eye = point(&mut rng, 3.0);
                } else {
                    let step = point(&mut rng, 0.1);
                    for k in 0..3 {
                        eye[k] += step[k] - (min[k] + max[k]) / 2.0;
                    }
                }
                let done = model
                    .adapt_to_view(positions, eye, tolerance)
                    .expect("positions match");
                total.merges += done.merges;
                total.splits += done.splits;
                total.refused += done.refused;
            }
        }
        mirror.update(&mut model);
        let displayed = model.displayed();
        assert_eq!(
            model.lod(),
            n - displayed.len(),
            "{label}: lod counts merges"
        );
        if !check_cut(seq, displayed, &label) {
            mixed_frames += 1;
        }
        let expected = cut_mesh(tris, seq, displayed);
        let hash = expected
            .iter()
            .fold(0u64, |h, &t| h.wrapping_add(tri_hash(t)));
        assert_eq!(
            mirror.hash(),
            (hash, expected.len()),
            "{label}: drawn multiset (hash, count) differs from the cut's mesh"
        );
        let drawn = mirror.triangles(Primitive::Strips);
        if tris.len() <= FULL_EVERY_STEP_TRIANGLES || frame % FULL_STRIDE == 0 {
            assert_eq!(
                canonical_multiset(drawn.iter().copied()),
                canonical_multiset(expected),
                "{label}: drawn triangles differ from the cut's mesh"
            );
        }
        for &t in &drawn {
            assert!(
                known.contains(&canonical(t)),
                "{label}: {t:?} is in no uniform LOD: the dependencies let a fold-over through"
            );
            if planar {
                assert!(area_xy(positions, t) > 0.0, "{label}: {t:?} flipped");
            }
        }
    }
    // The walk really was view-dependent, moved both ways, and met the dependencies.
    assert!(
        mixed_frames > frames / 4,
        "{name}: {mixed_frames} mixed cuts"
    );
    assert!(total.merges > 0 && total.splits > 0, "{name}: {total:?}");
    assert!(total.refused > 0, "{name}: no operation was ever refused");
}

/// The cut mesh of a uniform LOD is the LodStrips reference mesh at that LOD (so the
/// view-dependent oracle extends the uniform one), and after `set_lod` the model's display
/// vertices are that cut.
#[test]
fn cut_mesh_of_a_uniform_lod_is_the_reference_mesh() {
    let (tris, n) = sphere(2);
    let seq = random_sequence(&tris, n, usize::MAX, &mut Rng(90));
    let mut model = SkipStrips::build(&stripify(&tris, n), &seq).expect("builds");
    for lod in [0, 1, seq.len() / 3, seq.len() - 1, seq.len()] {
        model.set_lod(lod).expect("in range");
        assert!(check_cut(&seq, model.displayed(), "uniform"), "LOD {lod}");
        assert_eq!(
            cut_mesh(&tris, &seq, model.displayed()),
            seq.reference_mesh(&tris, lod),
            "LOD {lod}"
        );
    }
}

/// A planar grid with holes and its QEM sequence: the view walk, and no drawn triangle ever
/// flips (every triangle of every uniform LOD keeps its orientation, checked first).
#[test]
fn skip_strips_view_dependent_grid() {
    let (tris, n) = grid(24, 18, |x, y| (x * 5 + y * 3) % 13 == 0);
    let positions: Vec<[f32; 3]> = (0..n as u32)
        .map(|v| [(v % 25) as f32, (v / 25) as f32, 0.0])
        .collect();
    let seq = morphlod::simplify::simplify(
        &positions,
        &tris,
        &morphlod::simplify::SimplifyOptions::default(),
    );
    view_walk("grid", &tris, &positions, &seq, 300, true, 91);
}

/// The cow with the simplifier's sequence, as the bench builds it.
#[test]
fn skip_strips_view_dependent_cow() {
    let mesh = common::load_asset_mesh("cow.off");
    let seq = morphlod::simplify::simplify(
        &mesh.positions,
        &mesh.triangles,
        &morphlod::simplify::SimplifyOptions::default(),
    );
    view_walk(
        "cow.off",
        &mesh.triangles,
        &mesh.positions,
        &seq,
        200,
        false,
        92,
    );
}

#[test]
fn view_with_wrong_positions_is_refused() {
    let (tris, n) = sphere(1);
    let seq = random_sequence(&tris, n, 5, &mut Rng(93));
    let mut model = SkipStrips::build(&stripify(&tris, n), &seq).expect("builds");
    let err = model
        .adapt_to_view(&[[0.0; 3]; 2], [0.0; 3], 1.0)
        .expect_err("two positions");
    assert_eq!(
        err,
        BaselineError::PositionCount {
            positions: 2,
            vertices: n
        }
    );
    assert!(model.take_changed().is_empty());
}

#[test]
fn lod_out_of_range_is_refused_and_changes_nothing() {
    let (tris, n) = sphere(1);
    let seq = random_sequence(&tris, n, 5, &mut Rng(70));
    let strips = stripify(&tris, n);
    for mut model in build_all(&tris, &strips, &seq) {
        model.set_lod(3).expect("in range");
        model.take_changed();
        let before: Vec<Vec<u32>> = (0..model.region_count())
            .map(|r| model.region(r).to_vec())
            .collect();
        let err = model.set_lod(seq.len() + 1).expect_err("out of range");
        assert_eq!(
            err,
            BaselineError::LodOutOfRange {
                lod: seq.len() + 1,
                max: seq.len()
            },
            "{}",
            model.name()
        );
        assert!(err.to_string().contains("0..=5"), "{err}");
        assert_eq!(model.lod(), 3);
        assert!(model.take_changed().is_empty(), "{}", model.name());
        for (r, live) in before.iter().enumerate() {
            assert_eq!(model.region(r), live.into(), "{}", model.name());
        }
    }
}

#[test]
fn bad_inputs_are_typed_errors() {
    let (tris, n) = sphere(1);
    let strips = stripify(&tris, n);
    // A sequence over fewer vertices than the mesh names.
    let short = CollapseSequence {
        vertex_count: 3,
        collapses: Vec::new(),
    };
    assert!(matches!(
        ProgressiveMesh::build(&tris, &short),
        Err(BaselineError::VertexOutOfRange {
            what: "a triangle",
            ..
        })
    ));
    assert!(matches!(
        Mts::build(&strips, &short),
        Err(BaselineError::VertexOutOfRange {
            what: "a strip",
            ..
        })
    ));
    assert!(matches!(
        SkipStrips::build(&strips, &short),
        Err(BaselineError::VertexOutOfRange {
            what: "a strip",
            ..
        })
    ));
    // An invalid sequence: a vertex collapsing onto itself.
    let selfish = CollapseSequence {
        vertex_count: n as u32,
        collapses: vec![Collapse {
            u: 2,
            w: 2,
            error: 0.0,
        }],
    };
    let expected = BaselineError::Sequence(SequenceError::SelfCollapse { step: 0, vertex: 2 });
    assert_eq!(
        ProgressiveMesh::build(&tris, &selfish).err(),
        Some(expected.clone())
    );
    assert_eq!(Mts::build(&strips, &selfish).err(), Some(expected.clone()));
    assert_eq!(SkipStrips::build(&strips, &selfish).err(), Some(expected));
    // Strips whose offsets do not cover their indices.
    let broken = Strips {
        indices: strips.indices.clone(),
        offsets: vec![0, 2],
    };
    let seq = random_sequence(&tris, n, 3, &mut Rng(80));
    assert_eq!(
        Mts::build(&broken, &seq).err(),
        Some(BaselineError::BadStrips)
    );
    assert_eq!(
        SkipStrips::build(&broken, &seq).err(),
        Some(BaselineError::BadStrips)
    );
}

/// `morphlod bench --baselines` on the cow, three frames a test: one run holds the four models'
/// sizes and every frame of both tests; the strip baselines send the same display strips;
/// each test ends at the coarsest LOD; LodStrips is the smallest model as the report gives it
/// (Table 1's claim, a size, not a timing; tests/baseline_sizes.rs measures the models'
/// buffers behind these figures). A mesh that does not exist is refused with its path.
#[cfg(feature = "cli")]
#[test]
fn bench_baselines_writes_both_tables() {
    use crate::cli::{morphlod, no_adapter, text};

    let dir = common::scratch_dir("baselines", "bench");
    let json = dir.join("cow.json");
    let cow = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cow.off");
    let args = [
        "bench",
        "--baselines",
        cow.to_str().expect("utf-8 path"),
        "--frames",
        "3",
        "--repeats",
        "1",
        "--size",
        "64",
        "--json",
        json.to_str().expect("utf-8 path"),
    ];
    let out = morphlod(&args);
    if no_adapter(&out) {
        return;
    }
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", text(&out.stderr));
    assert!(
        stdout.contains("Table 1.") && stdout.contains("Table 2."),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json written"))
            .expect("valid JSON");
    let sizes = report["sizes"].as_array().expect("sizes");
    let names: Vec<&str> = sizes.iter().filter_map(|s| s["model"].as_str()).collect();
    assert_eq!(names, ["PM", "MTS", "Skip Strips", "LodStrips"]);
    let bytes = |name: &str| {
        sizes.iter().find(|s| s["model"] == name).expect("model")["bytes"]
            .as_u64()
            .expect("bytes")
    };
    for other in ["PM", "MTS", "Skip Strips"] {
        assert!(bytes("LodStrips") < bytes(other), "LodStrips vs {other}");
    }
    let rows = report["rows"].as_array().expect("rows");
    assert_eq!(rows.len(), 2 * 4 * 3);
    let max_lod = report["max_lod"].as_u64().expect("max_lod");
    for test in ["linear", "exponential"] {
        let frame = |model: &str, frame: u64| {
            rows.iter()
                .find(|r| r["test"] == test && r["model"] == model && r["frame"] == frame)
                .expect("row")
        };
        for f in 0..3 {
            assert_eq!(
                frame("MTS", f)["vertices"],
                frame("Skip Strips", f)["vertices"]
            );
            assert_eq!(frame("MTS", f)["strips"], frame("Skip Strips", f)["strips"]);
        }
        for model in names.iter() {
            assert_eq!(frame(model, 2)["lod"].as_u64(), Some(max_lod), "{model}");
        }
    }

    // Table 3: the view-dependent fly-in, one row a frame, merging while the eye is far and
    // splitting again as it comes near.
    assert!(stdout.contains("Table 3."), "{stdout}");
    let view = report["view_dependent"].as_array().expect("view_dependent");
    assert_eq!(view.len(), 3);
    let total = |k: &str| view.iter().map(|r| r[k].as_u64().expect(k)).sum::<u64>();
    assert!(total("merges") > 0 && total("splits") > 0, "{view:?}");
    let missing = dir.join("missing.off");
    let out = morphlod(&[
        "bench",
        "--baselines",
        missing.to_str().expect("utf-8 path"),
    ]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("missing.off"),
        "{}",
        text(&out.stderr)
    );
}
