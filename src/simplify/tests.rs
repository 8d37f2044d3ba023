use super::*;
use std::collections::HashMap;

/// An `n`×`n` grid of quads over `[0,1]²` at height `z` (a disk: one boundary loop).
pub(crate) fn grid(n: u32, z: f32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            pos.push([i as f32 / n as f32, j as f32 / n as f32, z]);
        }
    }
    let mut tris = Vec::new();
    let row = n + 1;
    for j in 0..n {
        for i in 0..n {
            let v = j * row + i;
            tris.push([v, v + 1, v + row + 1]);
            tris.push([v, v + row + 1, v + row]);
        }
    }
    (pos, tris)
}

/// A UV sphere of radius 1 around `center`, outward-facing, with pole vertices.
fn sphere(stacks: u32, slices: u32, center: [f32; 3]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut pos = vec![[center[0], center[1], center[2] + 1.0]];
    for i in 1..stacks {
        let theta = std::f32::consts::PI * i as f32 / stacks as f32;
        for j in 0..slices {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / slices as f32;
            pos.push([
                center[0] + theta.sin() * phi.cos(),
                center[1] + theta.sin() * phi.sin(),
                center[2] + theta.cos(),
            ]);
        }
    }
    let south = pos.len() as u32;
    pos.push([center[0], center[1], center[2] - 1.0]);
    let ring = |i: u32, j: u32| 1 + (i - 1) * slices + j % slices;
    let mut tris = Vec::new();
    for j in 0..slices {
        tris.push([0, ring(1, j), ring(1, j + 1)]);
        tris.push([south, ring(stacks - 1, j + 1), ring(stacks - 1, j)]);
    }
    for i in 1..stacks - 1 {
        for j in 0..slices {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j),
                ring(i + 1, j + 1),
            );
            tris.push([a, c, d]);
            tris.push([a, d, b]);
        }
    }
    (pos, tris)
}

/// A torus (genus 1, closed) with radii 1 and 0.35.
fn torus(major: u32, minor: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut pos = Vec::new();
    for i in 0..major {
        let a = 2.0 * std::f32::consts::PI * i as f32 / major as f32;
        for j in 0..minor {
            let b = 2.0 * std::f32::consts::PI * j as f32 / minor as f32;
            let r = 1.0 + 0.35 * b.cos();
            pos.push([r * a.cos(), r * a.sin(), 0.35 * b.sin()]);
        }
    }
    let id = |i: u32, j: u32| (i % major) * minor + j % minor;
    let mut tris = Vec::new();
    for i in 0..major {
        for j in 0..minor {
            tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    (pos, tris)
}

/// A grid with the middle quads removed: an annulus, two boundary loops.
fn annulus() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (pos, tris) = grid(9, 0.0);
    let tris = tris
        .into_iter()
        .filter(|t| {
            let c = t.iter().fold([0.0f32; 2], |s, &v| {
                [
                    s[0] + pos[v as usize][0] / 3.0,
                    s[1] + pos[v as usize][1] / 3.0,
                ]
            });
            !((0.34..0.66).contains(&c[0]) && (0.34..0.66).contains(&c[1]))
        })
        .collect();
    (pos, tris)
}

/// Appends mesh `b` to mesh `a` as a second component.
fn join(
    a: (Vec<[f32; 3]>, Vec<[u32; 3]>),
    b: (Vec<[f32; 3]>, Vec<[u32; 3]>),
) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (mut pos, mut tris) = a;
    let base = pos.len() as u32;
    pos.extend(b.0);
    tris.extend(b.1.iter().map(|t| t.map(|v| v + base)));
    (pos, tris)
}

/// Topology of a triangle list, measured from scratch (the oracle side).
#[derive(Debug, PartialEq)]
struct Topology {
    euler: i64,
    components: usize,
    boundary_loops: usize,
}

fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        parent[v as usize] = parent[parent[v as usize] as usize];
        v = parent[v as usize];
    }
    v
}

/// Panics (naming the LOD) unless the mesh is edge-manifold, consistently
/// oriented and free of duplicate triangles; returns its topology.
fn inspect(n: usize, tris: &[[u32; 3]], lod: usize) -> Topology {
    let mut half: HashMap<(u32, u32), u32> = HashMap::new();
    let mut faces: HashMap<[u32; 3], u32> = HashMap::new();
    for t in tris {
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "LOD {lod}: degenerate {t:?}"
        );
        for c in 0..3 {
            *half.entry((t[c], t[(c + 1) % 3])).or_default() += 1;
        }
        let mut key = *t;
        key.sort_unstable();
        let dup = faces.entry(key).or_default();
        *dup += 1;
        assert_eq!(*dup, 1, "LOD {lod}: duplicate triangle {t:?}");
    }
    let mut edges = 0i64;
    let mut component = (0..n as u32).collect::<Vec<_>>();
    let mut boundary = (0..n as u32).collect::<Vec<_>>();
    let mut on_boundary = vec![false; n];
    for (&(a, b), &k) in &half {
        assert_eq!(k, 1, "LOD {lod}: half-edge {a}->{b} used {k} times");
        let opposite = half.contains_key(&(b, a));
        if !opposite || a < b {
            edges += 1;
        }
        let (ra, rb) = (find(&mut component, a), find(&mut component, b));
        component[ra as usize] = rb;
        if !opposite {
            on_boundary[a as usize] = true;
            on_boundary[b as usize] = true;
            let (ra, rb) = (find(&mut boundary, a), find(&mut boundary, b));
            boundary[ra as usize] = rb;
        }
    }
    let mut used = vec![false; n];
    for t in tris {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let vertices = used.iter().filter(|&&u| u).count() as i64;
    let components = (0..n as u32)
        .filter(|&v| used[v as usize] && find(&mut component, v) == v)
        .count();
    let boundary_loops = (0..n as u32)
        .filter(|&v| on_boundary[v as usize] && find(&mut boundary, v) == v)
        .count();
    Topology {
        euler: vertices - edges + tris.len() as i64,
        components,
        boundary_loops,
    }
}

/// Simplifies to the end and checks every LOD against the input topology.
/// Returns the sequence and the final (vertex, triangle) counts.
fn check_run(pos: &[[f32; 3]], tris: &[[u32; 3]]) -> (CollapseSequence, usize, usize) {
    let seq = simplify(pos, tris, &SimplifyOptions::default());
    seq.validate().unwrap();
    assert_eq!(seq.vertex_count as usize, pos.len());
    let start = inspect(pos.len(), tris, 0);
    for lod in 1..=seq.len() {
        let mesh = seq.reference_mesh(tris, lod);
        assert_eq!(inspect(pos.len(), &mesh, lod), start, "LOD {lod}");
    }
    let last = seq.reference_mesh(tris, seq.len());
    let mut used: Vec<u32> = last.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    (seq, used.len(), last.len())
}

#[test]
fn sphere_runs_to_a_tetrahedron_without_flips() {
    let (pos, tris) = sphere(10, 16, [0.0; 3]);
    let (seq, v, t) = check_run(&pos, &tris);
    assert_eq!((v, t), (4, 4));
    assert_eq!(seq.len(), pos.len() - 4);
    // Every vertex stays on the convex sphere, so an outward-facing
    // triangle is one whose normal points away from the centre.
    for lod in 0..=seq.len() {
        for tri in seq.reference_mesh(&tris, lod) {
            let [a, b, c] = tri.map(|v| {
                let p = pos[v as usize];
                DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
            });
            let outward = (b - a).cross(c - a).dot(a + b + c);
            assert!(outward > 0.0, "LOD {lod}: triangle {tri:?} faces inward");
        }
    }
    // Costs are non-negative mean squared distances; a flat-ish start is cheap.
    assert!(seq.collapses.iter().all(|c| c.error >= 0.0));
    assert!(seq.collapses[0].error < seq.collapses[seq.len() - 1].error);
}

#[test]
fn disk_keeps_its_boundary_and_ends_at_one_triangle() {
    let (pos, tris) = grid(6, 0.0);
    let (_, v, t) = check_run(&pos, &tris);
    assert_eq!((v, t), (3, 1));
}

#[test]
fn flat_interior_collapses_before_the_boundary_moves() {
    // Interior vertices of a flat grid cost nothing; border vertices pay
    // their edge planes unless collinear. So all 25 interior vertices and
    // the 20 non-corner border vertices (collinear, also free) go first,
    // and no corner moves before every free vertex is gone.
    let (pos, tris) = grid(6, 0.0);
    let seq = simplify(&pos, &tris, &SimplifyOptions::default());
    let corners = [0u32, 6, 42, 48];
    let first_corner = seq
        .collapses
        .iter()
        .position(|c| corners.contains(&c.u))
        .unwrap();
    assert!(first_corner >= 45, "a corner moved at step {first_corner}");
    assert!(seq.collapses[..45].iter().all(|c| c.error < 1e-6));
}

#[test]
fn annulus_keeps_both_loops() {
    let (pos, tris) = annulus();
    let (seq, v, _) = check_run(&pos, &tris);
    assert!(!seq.is_empty());
    // Two loops of at least three vertices each survive.
    assert!(v >= 6, "{v} vertices left");
}

#[test]
fn torus_keeps_its_genus() {
    let (pos, tris) = torus(16, 8);
    let (seq, v, _) = check_run(&pos, &tris);
    assert!(seq.len() > pos.len() / 2, "only {} collapses", seq.len());
    assert!(v >= 7, "a torus needs at least 7 vertices, {v} left");
}

#[test]
fn components_end_separately() {
    let mesh = join(
        sphere(6, 10, [0.0; 3]),
        join(sphere(5, 8, [3.0, 0.0, 0.0]), grid(4, 5.0)),
    );
    let (_, v, t) = check_run(&mesh.0, &mesh.1);
    assert_eq!((v, t), (4 + 4 + 3, 4 + 4 + 1));
}

#[test]
fn non_manifold_and_degenerate_input_does_not_panic() {
    // A fin (three triangles on one edge), a repeated-index triangle, an
    // out-of-range index and a duplicated triangle, next to a clean grid.
    let (mut pos, mut tris) = grid(4, 0.0);
    let base = pos.len() as u32;
    pos.extend([
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [0.5, 1.0, 1.0],
        [0.5, -1.0, 1.0],
        [0.5, 0.0, 2.0],
    ]);
    tris.extend([
        [base, base + 1, base + 2],
        [base + 1, base, base + 3],
        [base, base + 1, base + 4],
        [base, base, base + 1],
        [base, base + 1, 999],
        [0, 1, 6],
    ]);
    let seq = simplify(&pos, &tris, &SimplifyOptions::default());
    seq.validate().unwrap();
    // The fin's edge vertices are non-manifold and never move.
    assert!(seq.collapses.iter().all(|c| c.u != base && c.u != base + 1));
}

#[test]
fn real_meshes_run_to_a_tetrahedron() {
    // Both are closed genus-0 surfaces: the topology must hold at every LOD
    // checked (every 16th and the last 64) and the sequence must reach the
    // minimum, a tetrahedron.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    for mesh in [
        crate::io::obj::load(&dir.join("bunny.obj")),
        crate::io::off::load(&dir.join("cow.off")),
    ] {
        let mesh = mesh.unwrap();
        let (pos, tris) = (&mesh.positions, &mesh.triangles);
        let seq = simplify(pos, tris, &SimplifyOptions::default());
        seq.validate().unwrap();
        let start = inspect(pos.len(), tris, 0);
        assert_eq!(
            (start.euler, start.components, start.boundary_loops),
            (2, 1, 0)
        );
        for lod in (0..=seq.len()).filter(|l| l % 16 == 0 || l + 64 > seq.len()) {
            let lod_mesh = seq.reference_mesh(tris, lod);
            assert_eq!(inspect(pos.len(), &lod_mesh, lod), start, "LOD {lod}");
        }
        assert_eq!(seq.reference_mesh(tris, seq.len()).len(), 4);
    }
}

/// With the distance term, at every LOD each vertex removed so far lies within
/// `sqrt(error / distance_weight)` of the coarse surface, `error` the largest collapse
/// error so far: a collapse prices the distance of every vertex it moves before it is
/// made and attaches each to a live triangle. On the bunny (a real scan, curved and
/// noisy) and a bumped disk (a boundary). Fails if the term is left out of the cost, or a
/// collapse forgets a vertex its triangles held.
#[test]
fn distance_term_bounds_how_far_removed_vertices_are() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let bunny = crate::io::obj::load(&dir.join("bunny.obj")).unwrap();
    let (mut disk, disk_tris) = grid(24, 0.0);
    for p in &mut disk {
        p[2] = 0.2 * (6.0 * p[0]).sin() * (5.0 * p[1]).cos();
    }
    let options = SimplifyOptions {
        distance_weight: DISTANCE_WEIGHT,
        ..SimplifyOptions::default()
    };
    for (pos, tris) in [(&bunny.positions, &bunny.triangles), (&disk, &disk_tris)] {
        let seq = simplify(pos, tris, &options);
        seq.validate().unwrap();
        let step = (seq.len() / 10).max(1);
        for lod in (step..=seq.len()).step_by(step) {
            let largest = seq.collapses[..lod]
                .iter()
                .map(|c| c.error as f64)
                .fold(0.0, f64::max);
            // The recorded error is an f32.
            let bound = (largest / DISTANCE_WEIGHT as f64).sqrt() * (1.0 + 1e-5) + 1e-12;
            let surface =
                crate::metrics::SurfaceIndex::new(pos, &seq.reference_mesh(tris, lod)).unwrap();
            let farthest = pos
                .iter()
                .map(|&p| surface.distance_squared(dvec(p)).sqrt())
                .fold(0.0, f64::max);
            assert!(
                farthest <= bound,
                "LOD {lod}: a removed vertex is {farthest} from the surface, bound {bound}"
            );
        }
    }
}

/// The distance term's prices are made on the rayon pool, several at a time: the sequence
/// is the same collapse for collapse, error for error, on one thread and on four. Two
/// poses of a bumped disk (a border, so both kinds of targets are priced). Fails if a
/// price lands on another vertex, or if pricing changed what a later price reads.
#[test]
fn the_distance_term_gives_one_sequence_on_any_number_of_threads() {
    let (flat, tris) = grid(24, 0.0);
    let bumped = |a: f32, b: f32| -> Vec<[f32; 3]> {
        flat.iter()
            .map(|&[x, y, _]| [x, y, 0.2 * (a * x).sin() * (b * y).cos()])
            .collect()
    };
    let (p0, p1) = (bumped(6.0, 5.0), bumped(3.0, 7.0));
    let options = SimplifyOptions {
        distance_weight: DISTANCE_WEIGHT,
        ..SimplifyOptions::default()
    };
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let seq = pool.install(|| simplify_poses(&[&p0, &p1], &tris, &options, PoseError::Max));
        seq.collapses
            .iter()
            .map(|c| (c.u, c.w, c.error.to_bits()))
            .collect::<Vec<_>>()
    };
    let one = on(1);
    assert!(one.len() > 500, "{} collapses", one.len());
    assert_eq!(one, on(4));
}

/// The distance term lowers the symmetric Hausdorff error of the bunny at 2% and 5% of its
/// triangles by a fifth or more against the quadrics alone (measured: see
/// docs/benchmarks-log.md, "The distance term: (d), what `export` builds by default
/// (2026-11-24)").
#[test]
fn distance_term_lowers_the_hausdorff_error() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let bunny = crate::io::obj::load(&dir.join("bunny.obj")).unwrap();
    let (pos, tris) = (&bunny.positions, &bunny.triangles);
    let quadrics = simplify(pos, tris, &SimplifyOptions::default());
    let distance = simplify(
        pos,
        tris,
        &SimplifyOptions {
            distance_weight: DISTANCE_WEIGHT,
            ..SimplifyOptions::default()
        },
    );
    for percent in [5, 2] {
        let target = tris.len() * percent / 100;
        let error = |seq: &CollapseSequence| {
            let lod = (0..=seq.len())
                .find(|&l| seq.reference_mesh(tris, l).len() <= target)
                .unwrap();
            let mesh = seq.reference_mesh(tris, lod);
            crate::metrics::hausdorff(pos, tris, pos, &mesh, 20_000)
                .unwrap()
                .hausdorff
        };
        let (q, d) = (error(&quadrics), error(&distance));
        eprintln!("bunny {percent}%: Hausdorff {d:.5} with the term, {q:.5} without");
        assert!(d <= 0.8 * q, "{percent}%: {d} with the term vs {q} without");
    }
}

#[test]
fn empty_input() {
    let seq = simplify(&[], &[], &SimplifyOptions::default());
    assert!(seq.is_empty());
    assert_eq!(seq.vertex_count, 0);
}
