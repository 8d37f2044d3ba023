//! Seams through the pipeline, on generated morphs split at UV seams (tests/common:
//! `seamed_sphere`, `cut_grid`) and on `makehuman_face.glb`: the builder's attribute-level sequences move whole topology
//! vertices, no boundary LOD opens a crack or folds a UV triangle, the runtime shows only
//! step boundaries, and random walks draw the attribute-level reference mesh.

use crate::common;

use common::{cut_grid, seamed_sphere, strip_draw, Rng};
use morphlod::collapse::{canonical_multiset, CollapseSequence};
use morphlod::deform::{DeformError, Strategy};
use morphlod::morph::{Attributes, Morph};
use morphlod::seams::{check_steps, expand, SeamError, SeamRule, StepBoundaries, Wedges};
use morphlod::simplify::{simplify, simplify_with_seams, SimplifyOptions};
use morphlod::{Asset, Builder, DeformingModel, DeformingState, Lod};

const FRAMES: usize = 5;

/// The generated morphs, and the MakeHuman face (its own UV seams, 52 targets, the
/// `expressions` animation: normal deltas for the GPU-blended targets).
fn morphs() -> Vec<(&'static str, Morph)> {
    let face = morphlod::io::load_morph(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_face.glb"),
        &Default::default(),
        &morphlod::io::MorphSource::Animation("expressions".into()),
    )
    .unwrap();
    vec![
        ("sphere", seamed_sphere(12, 16)),
        ("cut grid", cut_grid(12)),
        ("makehuman_face", face),
    ]
}

fn build(morph: &Morph) -> Asset {
    Builder::new(morph).frames(FRAMES).build().unwrap().0
}

/// The step boundaries of `seq`, from their definition.
fn boundaries(seq: &CollapseSequence, topology: &[u32]) -> Vec<usize> {
    let c = &seq.collapses;
    (0..=c.len())
        .filter(|&l| {
            l == 0 || l == c.len() || topology[c[l - 1].u as usize] != topology[c[l].u as usize]
        })
        .collect()
}

/// Twice the signed UV area of a triangle.
fn uv_area(uvs: &[[f32; 2]], t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|v| uvs[v as usize].map(f64::from));
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

#[test]
fn the_generated_morphs_have_seams() {
    for (name, morph) in morphs() {
        let map = morph.topology();
        assert!(map.seam_vertices() > 0, "{name}: no seam");
        assert!(map.topology_count < morph.vertex_count(), "{name}");
    }
}

#[test]
fn every_frame_moves_whole_topology_vertices() {
    for (name, morph) in morphs() {
        let asset = build(&morph);
        let surface = asset
            .surface
            .as_ref()
            .expect("a morph with UVs gets a surface");
        let map = morph.topology();
        assert_eq!(surface.topology, map.of_vertex);
        let wedges = Wedges::new(&map.of_vertex);
        for (k, seq) in asset.frames.iter().enumerate() {
            seq.validate().unwrap();
            check_steps(seq, &wedges, &map.of_vertex)
                .unwrap_or_else(|e| panic!("{name} frame {k}: {e}"));
            assert!(
                seq.len() > morph.vertex_count() / 2,
                "{name} frame {k}: {} collapses",
                seq.len()
            );
        }
    }
}

/// At every boundary LOD of every frame: copies of one position at full detail still share a
/// topology vertex (no crack), and no triangle's UV orientation flipped or vanished.
#[test]
fn no_cracks_and_no_uv_folds_at_any_boundary() {
    for (name, morph) in morphs() {
        let asset = build(&morph);
        let map = morph.topology();
        let uvs = morph.attributes().uvs.as_ref().unwrap();
        let tris = morph.triangles();
        for (k, seq) in asset.frames.iter().enumerate() {
            let bounds = boundaries(seq, &map.of_vertex);
            assert!(bounds.len() > 10, "{name} frame {k}");
            for &l in &bounds {
                let anc = seq.survivors(l);
                let mut survivor_topology = vec![u32::MAX; map.topology_count];
                for (v, &a) in anc.iter().enumerate() {
                    let t = &mut survivor_topology[map.of_vertex[v] as usize];
                    let s = map.of_vertex[a as usize];
                    assert!(
                        *t == u32::MAX || *t == s,
                        "{name} frame {k} LOD {l}: copies of topology vertex {} part (crack)",
                        map.of_vertex[v]
                    );
                    *t = s;
                }
                for &t in tris {
                    let mapped = t.map(|v| anc[v as usize]);
                    if mapped[0] == mapped[1] || mapped[1] == mapped[2] || mapped[0] == mapped[2] {
                        continue;
                    }
                    let (before, after) = (uv_area(uvs, t), uv_area(uvs, mapped));
                    assert!(
                        before == 0.0 || (after != 0.0 && (after > 0.0) == (before > 0.0)),
                        "{name} frame {k} LOD {l}: {t:?} -> {mapped:?} folds in UV ({before} -> {after})"
                    );
                }
            }
        }
    }
}

/// Seam vertices only move along their seam: the simplifier without the seam rule tears the
/// sphere's seams (so the checks above can fail), with it the expansion never refuses.
#[test]
fn the_rule_is_what_keeps_seams_closed() {
    let morph = seamed_sphere(12, 16);
    let map = morph.topology();
    let rule = SeamRule::new(&map, morph.attributes().uvs.as_deref());
    let pose = morph.positions_at(0.5);
    let tris = morph.triangles();
    let welded_tris = map.triangles(tris);
    let mut welded_pose = vec![[0.0f32; 3]; map.topology_count];
    for (v, &t) in map.of_vertex.iter().enumerate() {
        welded_pose[t as usize] = pose[v];
    }
    let blind = simplify(&welded_pose, &welded_tris, &SimplifyOptions::default());
    assert!(matches!(
        expand(&blind, tris, &rule),
        Err(SeamError::Refused { .. })
    ));
    let seamed = simplify_with_seams(&pose, tris, &rule, &SimplifyOptions::default());
    let expanded = expand(&seamed, tris, &rule).unwrap();
    assert_eq!(expanded.vertex_count as usize, morph.vertex_count());
}

/// Without seams (every vertex its own topology vertex) and without UVs, the seam-aware
/// simplifier makes exactly the position-only sequence, and its expansion is itself.
#[test]
fn without_seams_the_sequence_is_unchanged() {
    let morph = common::grid_morph(9, |x, y| 0.2 * (x * y) as f32);
    let colored = morph
        .clone()
        .with_attributes(Attributes {
            colors: Some(vec![[1.0, 0.5, 0.0, 1.0]; morph.vertex_count()]),
            ..Default::default()
        })
        .unwrap();
    let map = colored.topology();
    assert!(map.is_identity());
    let rule = SeamRule::new(&map, None);
    let pose = morph.positions_at(0.7);
    let plain = simplify(&pose, morph.triangles(), &SimplifyOptions::default());
    let seamed = simplify_with_seams(&pose, morph.triangles(), &rule, &SimplifyOptions::default());
    assert_eq!(plain, seamed);
    assert_eq!(expand(&seamed, morph.triangles(), &rule).unwrap(), plain);
    // A position-only morph builds with no surface.
    assert!(build(&morph).surface.is_none());
    assert!(build(&colored).surface.is_some());
}

/// Random walks (up, down, jumps, frame switches) with every kind of `Lod`: the runtime lands
/// on a step boundary, the one the request names by the rules of `DeformingModel::resolve`,
/// and the strips draw the attribute-level reference mesh there.
#[test]
fn random_walks_draw_the_reference_at_boundaries() {
    for (name, morph) in morphs() {
        let asset = build(&morph);
        let topology = &asset.surface.as_ref().unwrap().topology;
        let model = DeformingModel::new(&asset).unwrap();
        let tris = morph.triangles();
        let bounds: Vec<StepBoundaries> = asset
            .frames
            .iter()
            .map(|s| StepBoundaries::new(s, topology))
            .collect();
        let mut state = DeformingState::new(&model);
        let mut rng = Rng(0x5EA4 ^ name.len() as u64);
        for step in 0..400 {
            let t = match rng.below(4) {
                0 => state.frame() as f32 / (FRAMES - 1) as f32,
                _ => rng.unit(),
            };
            let k = model.frame_at(t).unwrap();
            let seq = &asset.frames[k];
            let max = seq.len();
            let near = state.lod() as i64 + rng.below(9) as i64 - 4;
            let steps = if rng.below(3) == 0 {
                rng.below(max + 2)
            } else {
                near.clamp(0, max as i64) as usize
            };
            let (lod, expected) = match rng.below(4) {
                0 => (Lod::Steps(steps), bounds[k].floor(steps)),
                1 => {
                    let f = rng.unit();
                    let l = ((f * max as f32).round() as usize).min(max);
                    (Lod::Fraction(f), bounds[k].floor(l))
                }
                2 => {
                    let budget = rng.below(tris.len() + 1);
                    // The finest boundary drawing at most `budget` triangles (else the last);
                    // counts never grow along a sequence, so a binary search finds it.
                    let b = boundaries(seq, topology);
                    let l = b[b
                        .partition_point(|&l| seq.reference_mesh(tris, l).len() > budget)
                        .min(b.len() - 1)];
                    (Lod::Triangles(budget), l)
                }
                _ => {
                    let e = rng.unit() * 0.05;
                    let errors = seq.errors();
                    let l = (0..=max)
                        .rev()
                        .find(|&l| errors[l].max(0.0).sqrt() <= e)
                        .unwrap();
                    (Lod::MaxError(e), bounds[k].floor(l))
                }
            };
            // Now and then, the same move by the other strategy must give the same strips.
            let other = (step % 7 == 0).then(|| {
                let mut other = state.clone();
                other.set_with(&model, t, lod, Strategy::Rebuild).unwrap();
                other
            });
            let used = state.set_with(&model, t, lod, Strategy::Steps).unwrap();
            assert_eq!(used, Strategy::Steps);
            if let Some(other) = other {
                assert_eq!(other.lengths(), state.lengths(), "{name} step {step}");
                for s in 0..state.lengths().len() {
                    assert_eq!(
                        other.strip(s),
                        state.strip(s),
                        "{name} step {step}: strip {s}"
                    );
                }
            }
            assert_eq!(state.frame(), k, "{name} step {step}");
            assert_eq!(
                state.lod(),
                expected,
                "{name} step {step}: {lod:?} in frame {k}"
            );
            assert!(bounds[k].is_boundary(state.lod()), "{name} step {step}");
            let drawn: Vec<[u32; 3]> = (0..state.lengths().len())
                .flat_map(|s| strip_draw(state.strip(s).unwrap()))
                .collect();
            assert_eq!(
                canonical_multiset(drawn),
                canonical_multiset(seq.reference_mesh(tris, state.lod())),
                "{name} step {step}: frame {k} LOD {}",
                state.lod()
            );
        }
    }
}

/// A model refuses a surface that does not fit its poses, and a frame that splits a step.
#[test]
fn the_model_checks_the_surface() {
    let asset = build(&cut_grid(8));
    let mut short = asset.clone();
    short.surface.as_mut().unwrap().topology.pop();
    assert!(matches!(
        DeformingModel::new(&short),
        Err(DeformError::SurfaceSize { .. })
    ));
    let topology = &asset.surface.as_ref().unwrap().topology;
    let c = &asset.frames[0].collapses;
    let split = (1..c.len())
        .filter(|&i| topology[c[i].u as usize] == topology[c[i - 1].u as usize])
        .map(|i| {
            let mut f = (*asset.frames[0]).clone();
            let moved = f.collapses.remove(i);
            f.collapses.insert(0, moved);
            f
        })
        .find(|f| f.validate().is_ok())
        .expect("some step's collapse can go first");
    let mut broken = asset.clone();
    broken.frames[0] = std::sync::Arc::new(split);
    assert!(matches!(
        DeformingModel::new(&broken),
        Err(DeformError::Seams { frame: 0, .. })
    ));
}

/// `mesh` cut in two UV islands by the plane `x = centre`: a vertex used on both sides gets one
/// copy per side, each side a planar UV projection (the far side shifted), so the cut is a seam
/// loop. It bends into a second pose. Also returns the same morph welded and without attributes.
fn cut_in_two(mesh: &morphlod::IndexedMesh) -> (Morph, Morph) {
    let (pos, tris) = (&mesh.positions, &mesh.triangles);
    let cx = pos.iter().map(|p| p[0] as f64).sum::<f64>() / pos.len() as f64;
    let (lo, hi) = pos.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| {
        (lo.min(p[1]), hi.max(p[1]))
    });
    let bend = |p: [f32; 3]| {
        let s = (p[1] - lo) / (hi - lo).max(f32::MIN_POSITIVE);
        [p[0] + 0.2 * (hi - lo) * (3.0 * s).sin(), p[1], p[2]]
    };
    let mut copy = std::collections::HashMap::new();
    let (mut v0, mut uvs, mut split_tris) = (Vec::new(), Vec::new(), Vec::new());
    for t in tris {
        let side = u32::from(t.iter().map(|&v| pos[v as usize][0] as f64).sum::<f64>() / 3.0 > cx);
        split_tris.push(t.map(|v| {
            *copy.entry((v, side)).or_insert_with(|| {
                let p = pos[v as usize];
                v0.push(p);
                uvs.push([p[1] + side as f32 * 10.0, p[2]]);
                v0.len() as u32 - 1
            })
        }));
    }
    let v1: Vec<[f32; 3]> = v0.iter().map(|&p| bend(p)).collect();
    let seamed = Morph::from_poses(split_tris, v0, v1)
        .unwrap()
        .with_attributes(Attributes {
            uvs: Some(uvs),
            ..Default::default()
        })
        .unwrap();
    let welded = Morph::from_poses(
        tris.clone(),
        pos.clone(),
        pos.iter().map(|&p| bend(p)).collect(),
    )
    .unwrap();
    (seamed, welded)
}

/// `morph` welded into its topology vertices, without attributes: what a position-only
/// source of the same shape would be.
fn welded(morph: &Morph) -> Morph {
    let map = morph.topology();
    let weld = |values: &[[f32; 3]]| {
        let mut out = vec![[0.0f32; 3]; map.topology_count];
        for (v, &t) in map.of_vertex.iter().enumerate() {
            out[t as usize] = values[v];
        }
        out
    };
    let targets = morph
        .targets()
        .iter()
        .map(|t| morphlod::morph::MorphTarget {
            name: t.name.clone(),
            deltas: weld(&t.deltas),
            normal_deltas: None,
        })
        .collect();
    Morph::from_parts(
        map.triangles(morph.triangles()),
        weld(morph.base()),
        targets,
        morph.weights().clone(),
    )
    .unwrap()
}

/// Builds `morph` with `frames` frames and prints what it costs (see `measure_seam_cost`).
fn measure(what: &str, morph: &Morph, frames: usize) {
    let start = std::time::Instant::now();
    let (asset, report) = Builder::new(morph).frames(frames).build().unwrap();
    let wall = start.elapsed();
    let bytes = asset.to_bytes();
    let info = morphlod::asset::inspect(&bytes).unwrap().1;
    let section = |tag: &str| {
        info.sections
            .iter()
            .find(|s| s.tag.trim_end() == tag)
            .map_or(0, |s| s.bytes)
    };
    let model = DeformingModel::new(&asset).unwrap();
    let changes: usize = model.frame_bytes().iter().sum();
    let attribute: usize = asset.frames.iter().map(|f| f.len()).sum();
    let topology: usize = match &asset.surface {
        Some(s) => asset
            .frames
            .iter()
            .map(|f| boundaries(f, &s.topology).len() - 1)
            .sum(),
        None => attribute,
    };
    println!(
        "  {what}: {} vertices ({} seam); build {:.0} ms (frames {:.0} ms cpu); {topology} topology collapses, {attribute} attribute collapses ({:.3} per topology collapse); FRMS {} B = {:.2} B per topology collapse; SURF {} B; TEXR {} B; change lists + tables {} B = {:.1} B per topology collapse; file {} B",
        report.vertices,
        report.seam_vertices,
        wall.as_secs_f64() * 1e3,
        report.frames_cpu().as_secs_f64() * 1e3,
        attribute as f64 / topology as f64,
        section("FRMS"),
        section("FRMS") as f64 / topology as f64,
        section("SURF"),
        section("TEXR"),
        changes,
        changes as f64 / topology as f64,
        bytes.len(),
    );
}

/// The cost of seams (docs/benchmarks-log.md, "Seams"): real meshes cut into two UV islands, and
/// the MakeHuman face (its own UV seams, 52 targets, the `expressions` animation), built with
/// their attributes against the same morphs welded without them.
/// `cargo test --release --test suite seams:: -- --ignored --nocapture`
#[test]
#[ignore]
fn measure_seam_cost() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    for file in ["cow.off", "bunny.obj", "man.off"] {
        let mesh = morphlod::io::load_mesh(&dir.join(file), &Default::default()).unwrap();
        let (seamed, welded) = cut_in_two(&mesh);
        println!("{file}, 8 frames:");
        measure("welded, no attributes", &welded, 8);
        measure("cut, with UVs", &seamed, 8);
    }
    let face = morphlod::io::load_morph(
        &dir.join("makehuman_face.glb"),
        &Default::default(),
        &morphlod::io::MorphSource::Animation("expressions".into()),
    )
    .unwrap();
    println!(
        "makehuman_face.glb, {} targets, 32 frames:",
        face.targets().len()
    );
    measure("welded, no attributes", &welded(&face), 32);
    measure("with its attributes", &face, 32);
}

/// The rule on a small cut grid (side 4: the cut runs up column 2 from the bottom border to row
/// 2, so (2, 0) and (2, 1) have a left and a right copy and the cut ends at (2, 2)): interior
/// vertices move freely, seam vertices only along the seam, nothing across it.
#[test]
fn the_rule_frees_interiors_and_holds_seams() {
    let morph = cut_grid(4);
    let map = morph.topology();
    let rule = SeamRule::new(&map, morph.attributes().uvs.as_deref());
    let base = morph.base();
    let at = |x: f32, y: f32| {
        let v = base.iter().position(|p| p[0] == x && p[1] == y).unwrap();
        map.of_vertex[v]
    };
    assert_eq!(Wedges::new(&map.of_vertex).of(at(2.0, 1.0)).len(), 2);
    assert_eq!(Wedges::new(&map.of_vertex).of(at(2.0, 2.0)).len(), 1);
    let one = |u: u32, w: u32| {
        let seq = CollapseSequence::from_pairs(map.topology_count as u32, &[(u, w)]);
        expand(&seq, morph.triangles(), &rule)
    };
    // Interior, off the seam: one copy onto one copy.
    assert_eq!(one(at(1.0, 1.0), at(0.0, 1.0)).unwrap().len(), 1);
    // Along the seam onto its end: both copies onto the end's single copy.
    let zip = one(at(2.0, 1.0), at(2.0, 2.0)).unwrap();
    assert_eq!(zip.len(), 2);
    assert!(zip
        .collapses
        .iter()
        .all(|c| map.of_vertex[c.w as usize] == at(2.0, 2.0)));
    // Across the seam, or the end down onto a seam vertex: a tear.
    for (u, w) in [(at(2.0, 1.0), at(1.0, 1.0)), (at(2.0, 2.0), at(2.0, 1.0))] {
        assert!(matches!(
            one(u, w),
            Err(SeamError::Refused {
                refusal: morphlod::seams::Refusal::Tear,
                ..
            })
        ));
    }
}

/// `Refusal::UvFold`, directly: a fan of four triangles around vertex 0 (no seams), collapsed
/// 0 → 1. The surviving triangle (0, 2, 3) becomes (1, 2, 3); with vertex 1's UV across the
/// UV edge (2, 3) from vertex 0's it turns over in UV space and the rule refuses, with the
/// same UV on vertex 0's side it passes, and without UVs (geometry alone) it passes.
#[test]
fn a_collapse_that_flips_a_uv_triangle_is_refused() {
    use morphlod::morph::TopologyMap;
    use morphlod::seams::Refusal;
    let fan = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
    let map = TopologyMap::identity(5);
    let uvs = |uv1: [f32; 2]| vec![[0.0, 0.0], uv1, [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
    let collapse = |uvs: Option<&[[f32; 2]]>| {
        let rule = SeamRule::new(&map, uvs);
        let mut pairs = Vec::new();
        rule.map_collapse(0, 1, fan.iter().copied(), &mut pairs)
            .map(|()| pairs)
    };
    // The line through UVs 2 and 3 is v = u + 1; vertex 0's UV (0, 0) lies below it, (-1, 2)
    // above (and on the same side of the line through UVs 3 and 4: only (1, 2, 3) turns).
    let across = uvs([-1.0, 2.0]);
    assert_eq!(collapse(Some(&across)), Err(Refusal::UvFold));
    let same_side = uvs([1.0, 0.0]);
    assert_eq!(collapse(Some(&same_side)), Ok(vec![(0, 1)]));
    assert_eq!(collapse(None), Ok(vec![(0, 1)]));
}
