//! The oracle: random walks of `set_lod` checked against the reference mesh of
//! DESIGN.md (`canonical_multiset(seq.reference_mesh(T, l))`).
//!
//! What is checked when:
//! * After EVERY step, on every mesh: the multiset hash of the oriented
//!   triangles drawn by a GPU mirror (a copy of the index buffer kept up to
//!   date only through `take_dirty`, so a missing dirty range fails here, and
//!   decoded by `common::strip_draw`, the GPU's strip rules written independently
//!   of `morphlod::strip`, so a parity rule flipped in the library fails here too)
//!   equals the reference multiset hash at that LOD, and the drawn triangle
//!   count equals the reference count and `StripsState::triangle_count`. The
//!   reference hashes of all LODs come from one incremental pass over the
//!   sequence, which is itself compared with `reference_mesh` at every full check.
//! * Full checks (exact sorted multisets, mirror == state, index count never
//!   above `S0`): every step on meshes up to `FULL_EVERY_STEP_TRIANGLES`
//!   triangles, every `FULL_STRIDE`-th step and the last one on bigger meshes.
//! * End of walk: the walked state equals a fresh state of a model built again
//!   from the same inputs, moved straight from LOD 0 (same index contents and
//!   lengths, which this model guarantees: every LOD has one buffer state).

use crate::common;

use common::{degenerate, random_sequence, reference_hashes, strips_draw, Mirror, Rng};
use morphlod::collapse::{canonical_multiset, Collapse, CollapseSequence};
use morphlod::lodstrips::{IndexWidth, LodStrips, StripsState};
use morphlod::strip::{stripify, Strips};
use proptest::prelude::*;

/// Meshes up to this size get a full multiset check after every step.
const FULL_EVERY_STEP_TRIANGLES: usize = 3000;
/// Bigger meshes get one every this many steps.
const FULL_STRIDE: usize = 97;

/// Drives `steps` random `set_lod` calls and checks the invariant (see module docs).
fn walk(tris: &[[u32; 3]], strips: &Strips, seq: &CollapseSequence, steps: usize, rng: &mut Rng) {
    let model = LodStrips::build(strips, seq).expect("model builds");
    let reference = reference_hashes(tris, seq);
    let max = model.max_lod();
    assert_eq!(reference.len(), max + 1);
    let s0_len = strips.indices.len();
    let every_step = tris.len() <= FULL_EVERY_STEP_TRIANGLES;
    let mut state = StripsState::new(&model);
    let width = IndexWidth::for_vertices(seq.vertex_count);
    assert_eq!(state.index_width(), width, "the narrowest width");
    let mut mirror = Mirror::new(model.region_offsets(), state.indices(), state.lengths());
    let full = |l: usize, mirror: &Mirror, state: &StripsState| {
        let drawn = canonical_multiset(mirror.triangles());
        let expected = canonical_multiset(seq.reference_mesh(tris, l));
        assert_eq!(
            drawn, expected,
            "drawn triangles differ from the reference at LOD {l}"
        );
        assert_eq!(
            mirror.lens.as_slice(),
            state.lengths(),
            "mirror lengths at LOD {l}"
        );
        for s in 0..model.strip_count() {
            assert_eq!(
                Some(mirror.strip(s).into()),
                state.strip(s),
                "mirror strip {s} at LOD {l}"
            );
        }
        assert!(state.index_count() <= s0_len);
    };
    full(0, &mirror, &state);
    for step in 0..steps {
        let l = state.lod();
        let target = rng.walk_lod(l, max);
        let target = if rng.below(4) == 0 && target == l {
            (l + 17).min(max)
        } else {
            target
        };
        state.set_lod(&model, target).expect("same model");
        assert_eq!(state.lod(), target);
        let dirty = state.take_dirty();
        mirror.upload(&dirty, state.indices(), state.lengths());
        let (hash, count) = reference[target];
        assert_eq!(
            mirror.count, count,
            "triangle count at LOD {target} (step {step})"
        );
        assert_eq!(
            state.triangle_count(),
            count,
            "reported triangle count at LOD {target}"
        );
        assert_eq!(
            mirror.hash, hash,
            "drawn multiset hash at LOD {target} (step {step})"
        );
        if every_step || step % FULL_STRIDE == 0 || step + 1 == steps {
            full(target, &mirror, &state);
        }
    }
    // A model built again from the same inputs, moved straight to the final LOD.
    let rebuilt = LodStrips::build(strips, seq).expect("model builds");
    assert_eq!(
        rebuilt.byte_size(),
        model.byte_size(),
        "build is deterministic"
    );
    let mut fresh = StripsState::new(&rebuilt);
    fresh.set_lod(&rebuilt, state.lod()).expect("same model");
    assert_eq!(fresh.lengths(), state.lengths());
    for s in 0..model.strip_count() {
        assert_eq!(
            fresh.strip(s),
            state.strip(s),
            "walked strip {s} differs from a direct move"
        );
    }
}

fn check_mesh(name: &str, tris: &[[u32; 3]], n: usize, steps: usize, seed: u64) {
    let mut rng = Rng(seed);
    let strips = stripify(tris, n);
    let seq = random_sequence(tris, n, usize::MAX, &mut rng);
    eprintln!(
        "{name}: {} triangles, {} strips, {} indices, {} collapses",
        tris.len(),
        strips.len(),
        strips.indices.len(),
        seq.len()
    );
    report(name, &strips, &seq);
    walk(tris, &strips, &seq, steps, &mut rng);
}

/// Prints indices per drawn triangle at some LODs and the change-list size.
fn report(name: &str, strips: &Strips, seq: &CollapseSequence) {
    let model = LodStrips::build(strips, seq).expect("model builds");
    let mut state = StripsState::new(&model);
    let mut line = String::new();
    for pct in [0, 25, 50, 75, 90] {
        state
            .set_lod(&model, model.max_lod() * pct / 100)
            .expect("same model");
        line += &format!(
            " L{pct}: {:.2}",
            state.index_count() as f64 / state.triangle_count().max(1) as f64
        );
    }
    eprintln!(
        "{name}: indices/triangle{line}; change bytes/collapse {:.1}, model/indexed {:.2}",
        model.change_bytes() as f64 / model.max_lod().max(1) as f64,
        model.byte_size() as f64 / (strips_draw(strips).len().max(1) * 12) as f64
    );
}

// ---------------------------------------------------------------- generators

/// Triangles and vertex count.
pub(crate) type Mesh = (Vec<[u32; 3]>, usize);

/// A `w × h` grid of quads split into two triangles each, with the quads for
/// which `hole(x, y)` is true left out.
pub(crate) fn grid(w: u32, h: u32, hole: impl Fn(u32, u32) -> bool) -> Mesh {
    let mut t = Vec::new();
    for y in 0..h {
        for x in 0..w {
            if hole(x, y) {
                continue;
            }
            let a = y * (w + 1) + x;
            let b = a + 1;
            let c = a + w + 1;
            let d = c + 1;
            if (x + y) % 2 == 0 {
                t.push([a, b, d]);
                t.push([a, d, c]);
            } else {
                t.push([a, b, c]);
                t.push([b, d, c]);
            }
        }
    }
    (t, ((w + 1) * (h + 1)) as usize)
}

/// A subdivided octahedron (closed, genus 0) with `level` 1:4 splits.
pub(crate) fn sphere(level: u32) -> Mesh {
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let mut n = 6u32;
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for t in &tris {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    n += 1;
                    n - 1
                });
            }
            next.push([t[0], m[0], m[2]]);
            next.push([m[0], t[1], m[1]]);
            next.push([m[2], m[1], t[2]]);
            next.push([m[0], m[1], m[2]]);
        }
        tris = next;
    }
    (tris, n as usize)
}

/// Several components, a non-manifold fin, duplicated and flipped triangles.
pub(crate) fn messy() -> Mesh {
    let (mut t, n1) = grid(6, 5, |x, y| x == 2 && y == 2);
    let (s, n2) = sphere(2);
    t.extend(s.iter().map(|tri| tri.map(|v| v + n1 as u32)));
    let n = (n1 + n2) as u32;
    // A fin on grid edge 0-1 and a fan of three triangles on one edge.
    t.push([0, 1, n]);
    t.push([1, 0, n + 1]);
    t.push([0, 1, n + 2]);
    // Duplicates and a flipped copy.
    t.push(t[5]);
    t.push(t[5]);
    t.push([t[7][0], t[7][2], t[7][1]]);
    (t, n as usize + 3)
}

#[test]
fn generated_meshes_random_sequences() {
    let cases: Vec<(&str, Mesh)> = vec![
        (
            "grid with holes",
            grid(30, 20, |x, y| (x * 7 + y * 3) % 11 == 0),
        ),
        ("sphere", sphere(4)),
        ("messy", messy()),
        // Vertex numbers on both sides of 65,535: the runtime's `u32` width.
        (
            "grid past u16",
            past_u16(grid(30, 20, |x, y| (x * 7 + y * 3) % 11 == 0)),
        ),
    ];
    for (k, (name, (tris, n))) in cases.iter().enumerate() {
        check_mesh(name, tris, *n, 10_000, 1 + k as u64);
    }
}

/// `mesh` with its vertices numbered from 65,000 (those below unused): a model of more than
/// 65,536 vertices, stored `u32` wide.
fn past_u16((tris, n): Mesh) -> Mesh {
    let first = 65_000;
    let tris = tris.iter().map(|t| t.map(|v| v + first)).collect();
    (tris, n + first as usize)
}

#[test]
fn partial_sequences_and_empty() {
    // A sequence that stops early, and the empty sequence.
    let (tris, n) = sphere(3);
    let strips = stripify(&tris, n);
    let mut rng = Rng(99);
    for steps in [0, 1, 5, 40] {
        let seq = random_sequence(&tris, n, steps, &mut rng);
        walk(&tris, &strips, &seq, 300, &mut rng);
    }
}

fn asset(name: &str) -> morphlod::IndexedMesh {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name);
    let mesh = if name.ends_with(".obj") {
        morphlod::io::obj::load(&path)
    } else {
        morphlod::io::off::load(&path)
    };
    mesh.unwrap_or_else(|e| panic!("{name}: {e}"))
}

const ASSETS: [&str; 5] = ["cow.off", "bunny.obj", "man.off", "bull.off", "camel.off"];

#[test]
fn real_assets_random_sequences() {
    for (k, name) in ASSETS.iter().enumerate() {
        let mesh = asset(name);
        check_mesh(
            name,
            &mesh.triangles,
            mesh.positions.len(),
            10_000,
            100 + k as u64,
        );
    }
}

#[test]
fn real_assets_qem_sequences() {
    for (k, name) in ASSETS.iter().enumerate() {
        let mesh = asset(name);
        let n = mesh.positions.len();
        let strips = stripify(&mesh.triangles, n);
        let seq = morphlod::simplify::simplify(
            &mesh.positions,
            &mesh.triangles,
            &morphlod::simplify::SimplifyOptions::default(),
        );
        seq.validate().expect("QEM sequence is valid");
        let label = format!("{name} (QEM)");
        report(&label, &strips, &seq);
        walk(
            &mesh.triangles,
            &strips,
            &seq,
            10_000,
            &mut Rng(200 + k as u64),
        );
    }
}

/// S0 must not cost more indices than meshopt's strips (vertex-cache strip
/// order, then `meshopt::stripify` with restarts), counting one restart
/// between our strips as meshopt counts its own.
#[test]
fn real_assets_strips_beat_meshopt() {
    for name in ASSETS {
        let mesh = asset(name);
        let n = mesh.positions.len();
        let strips = stripify(&mesh.triangles, n);
        let expected =
            canonical_multiset(mesh.triangles.iter().copied().filter(|t| !degenerate(*t)));
        assert_eq!(canonical_multiset(strips_draw(&strips)), expected, "{name}");
        let flat: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        let ordered = meshopt::optimize_vertex_cache_strip(&flat, n);
        let theirs = meshopt::stripify(&ordered, n, u32::MAX).expect("meshopt stripify");
        let ours = strips.indices.len() + strips.len().saturating_sub(1);
        let tris = mesh.triangles.len() as f64;
        eprintln!(
            "{name}: ours {:.3} indices/triangle ({:.3} with restarts, {} strips, {:.1} indices/strip), meshopt {:.3}",
            strips.indices.len() as f64 / tris,
            ours as f64 / tris,
            strips.len(),
            strips.indices.len() as f64 / strips.len().max(1) as f64,
            theirs.len() as f64 / tris
        );
        assert!(
            ours <= theirs.len(),
            "{name}: {ours} indices vs meshopt {}",
            theirs.len()
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Random grids with random holes, random duplicated and flipped extra
    /// triangles, random sequences: the full multiset is checked every step.
    #[test]
    fn random_meshes(
        w in 1u32..12,
        h in 1u32..12,
        holes in proptest::collection::vec(any::<u32>(), 0..20),
        extra in proptest::collection::vec((any::<u32>(), any::<u32>(), any::<u32>()), 0..8),
        seed in any::<u64>(),
    ) {
        let (mut tris, n) = grid(w, h, |x, y| holes.contains(&(x * 31 + y * 17)) || holes.iter().any(|&k| k % 97 == x * 12 + y));
        for &(a, b, c) in &extra {
            let t = [a % n as u32, b % n as u32, c % n as u32];
            tris.push(t);
            if a % 3 == 0 {
                tris.push(t);
            }
        }
        let strips = stripify(&tris, n);
        let mut rng = Rng(seed);
        let seq = random_sequence(&tris, n, usize::MAX, &mut rng);
        walk(&tris, &strips, &seq, 200, &mut rng);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    /// Adversarial strips: random index sequences over a small alphabet (so
    /// full of repeats, swaps and degenerate runs from the start) as `S0`, the
    /// triangles they draw as `T`, and collapses between arbitrary live
    /// vertices (not only edges). Exercises every reduction rule on inputs
    /// no stripifier would produce.
    #[test]
    fn random_strips_arbitrary_collapses(
        strips in proptest::collection::vec(proptest::collection::vec(0u32..9, 0..40), 1..6),
        seed in any::<u64>(),
    ) {
        let n = 9usize;
        let mut s0 = Strips { indices: Vec::new(), offsets: vec![0] };
        for st in &strips {
            s0.indices.extend_from_slice(st);
            s0.offsets.push(s0.indices.len() as u32);
        }
        let tris = strips_draw(&s0);
        let mut rng = Rng(seed);
        let mut live: Vec<u32> = (0..n as u32).collect();
        let mut collapses = Vec::new();
        while live.len() > 1 && rng.below(12) != 0 {
            let u = live.swap_remove(rng.below(live.len()));
            let w = live[rng.below(live.len())];
            collapses.push(Collapse { u, w, error: 0.0 });
        }
        let seq = CollapseSequence { vertex_count: n as u32, collapses };
        walk(&tris, &s0, &seq, 60, &mut rng);
    }
}
