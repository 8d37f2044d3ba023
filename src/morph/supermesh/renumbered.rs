//! Two meshes with the same triangles up to a renumbering of B's vertices (a
//! mesh and a posed copy written out in another vertex order). Any overlay of
//! two such embeddings that do not coincide exactly has at least
//! `V_A + V_B` vertices plus the crossings of nearly parallel edges, and
//! which twin a vertex is blended with is only as good as the alignment;
//! the renumbering itself is both smaller (A's triangulation) and the exact
//! identity map.
//!
//! Found by propagation: a seed (A's directed edge `u → v` taken to B's
//! `x → y`) fixes the map of the triangle on its left, and each triangle's
//! map fixes its neighbours', so one seed decides the whole map in one pass
//! over A's directed edges, or fails at the first triangle with no image.
//! Seeds come from the connectivity (a few of A's vertices of the rarest
//! colours under Weisfeiler–Lehman refinement, each with every B vertex of
//! its colour) and from the aligned sphere embeddings (B's vertices nearest
//! to a few of A's), and among the maps found (a symmetric triangulation has
//! several) the one with the smallest `D` is kept.

use std::collections::HashMap;

use glam::DVec3;

use super::measure::measure;
use crate::mesh::IndexedMesh;

/// How many A vertices seed the search, and how many of B's vertices
/// nearest to each on the sphere are tried as its twin.
const SEED_VERTICES: usize = 8;
const NEAREST: usize = 6;

/// At most this many complete maps are compared by `D`.
const MAX_MAPS: usize = 12;

/// A closed oriented triangulation's directed edges: `(u, v)` → the index
/// `3 t + k` of the corner pair, whose triangle's third vertex follows `v`.
struct Edges {
    index: HashMap<(u32, u32), u32>,
}

impl Edges {
    /// `None` when a directed edge repeats (not an oriented manifold).
    fn new(triangles: &[[u32; 3]]) -> Option<Edges> {
        let mut index = HashMap::with_capacity(3 * triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let e = (tri[k], tri[(k + 1) % 3]);
                if index.insert(e, (3 * t + k) as u32).is_some() {
                    return None;
                }
            }
        }
        Some(Edges { index })
    }
}

/// The third vertex of the triangle left of directed edge `e` (`3 t + k`).
fn third(triangles: &[[u32; 3]], e: u32) -> u32 {
    triangles[e as usize / 3][(e as usize % 3 + 2) % 3]
}

/// The vertex map A → B carrying A's directed edge `seed.0` onto B's
/// `seed.1` and every triangle of A onto a triangle of B with its
/// orientation, if there is one.
fn propagate(
    a: &[[u32; 3]],
    ea: &Edges,
    b: &[[u32; 3]],
    eb: &Edges,
    vertices: usize,
    seed: ((u32, u32), (u32, u32)),
) -> Option<Vec<u32>> {
    let mut map = vec![u32::MAX; vertices];
    let mut inverse = vec![u32::MAX; vertices];
    let mut assign = |from: u32, to: u32| -> bool {
        let (f, t) = (&mut map[from as usize], &mut inverse[to as usize]);
        if *f == u32::MAX && *t == u32::MAX {
            (*f, *t) = (to, from);
            true
        } else {
            *f == to && *t == from
        }
    };
    let ((u, v), (x, y)) = seed;
    if !(assign(u, x) && assign(v, y)) {
        return None;
    }
    let mut visited = vec![false; 3 * a.len()];
    let mut stack = vec![(*ea.index.get(&(u, v))?, *eb.index.get(&(x, y))?)];
    while let Some((e, f)) = stack.pop() {
        if std::mem::replace(&mut visited[e as usize], true) {
            continue;
        }
        let (t, k) = (e as usize / 3, e as usize % 3);
        let (s, l) = (f as usize / 3, f as usize % 3);
        let (w, z) = (third(a, e), third(b, f));
        if !assign(w, z) {
            return None;
        }
        // The other two edges of this triangle, then the twin of each of the three.
        for j in 0..3 {
            let (ae, be) = ((3 * t + (k + j) % 3) as u32, (3 * s + (l + j) % 3) as u32);
            let (p, q) = (a[t][(k + j) % 3], a[t][(k + j + 1) % 3]);
            let (r, o) = (b[s][(l + j) % 3], b[s][(l + j + 1) % 3]);
            if !visited[ae as usize] {
                stack.push((ae, be));
            }
            let twin = ea.index.get(&(q, p)).copied();
            let image = eb.index.get(&(o, r)).copied();
            match (twin, image) {
                (Some(te), Some(ti)) => {
                    if !visited[te as usize] {
                        stack.push((te, ti));
                    }
                }
                (None, None) => {}
                _ => return None,
            }
        }
    }
    map.iter().all(|&m| m != u32::MAX).then_some(map)
}

/// Rounds of colour refinement in [`colour_seeds`].
const COLOUR_ROUNDS: usize = 4;

/// Seed vertices from colour classes, and the largest class tried.
const COLOUR_SEEDS: usize = 4;
const MAX_CLASS: usize = 64;

fn mix(h: u64, x: u64) -> u64 {
    let mut z = (h ^ x).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Each vertex's colour after rounds of Weisfeiler–Lehman refinement
/// (degree, then the colour with the sorted colours of the neighbours): a
/// renumbering keeps every colour, so a twin has its vertex's colour.
fn colours(n: usize, triangles: &[[u32; 3]]) -> Vec<u64> {
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    for t in triangles {
        for k in 0..3 {
            neighbours[t[k] as usize].push(t[(k + 1) % 3]);
        }
    }
    let mut colour: Vec<u64> = neighbours.iter().map(|r| r.len() as u64).collect();
    let mut around = Vec::new();
    for _ in 0..COLOUR_ROUNDS {
        colour = (0..n)
            .map(|v| {
                around.clear();
                around.extend(neighbours[v].iter().map(|&u| colour[u as usize]));
                around.sort_unstable();
                around.iter().fold(mix(0, colour[v]), |h, &c| mix(h, c))
            })
            .collect();
    }
    colour
}

/// Seeds from the connectivity alone: the A vertices of the rarest colours
/// (see [`colours`]), each with every B vertex of its colour; none when the
/// colour counts differ (then no renumbering exists).
pub(crate) fn colour_seeds(a: &IndexedMesh, b: &IndexedMesh) -> Vec<(u32, Vec<u32>)> {
    if a.vertex_count() != b.vertex_count() {
        return Vec::new();
    }
    let (ca, cb) = (
        colours(a.vertex_count(), &a.triangles),
        colours(b.vertex_count(), &b.triangles),
    );
    let mut class_a: HashMap<u64, u32> = HashMap::new();
    for &c in &ca {
        *class_a.entry(c).or_default() += 1;
    }
    let mut class_b: HashMap<u64, Vec<u32>> = HashMap::new();
    for (v, &c) in cb.iter().enumerate() {
        class_b.entry(c).or_default().push(v as u32);
    }
    if class_a.len() != class_b.len()
        || class_a
            .iter()
            .any(|(c, &k)| class_b.get(c).map(Vec::len) != Some(k as usize))
    {
        return Vec::new();
    }
    let mut order: Vec<u32> = (0..a.vertex_count() as u32).collect();
    order.sort_by_key(|&v| (class_a[&ca[v as usize]], v));
    let mut seen = Vec::new();
    order
        .into_iter()
        .filter(|&v| {
            let c = ca[v as usize];
            let fresh = !seen.contains(&c) && class_b[&c].len() <= MAX_CLASS;
            seen.push(c);
            fresh
        })
        .take(COLOUR_SEEDS)
        .map(|v| (v, class_b[&ca[v as usize]].clone()))
        .collect()
}

/// Seeds from the aligned embeddings: a few of A's vertices, spread over
/// its numbering, each with the B vertices nearest to it on the sphere.
pub(crate) fn sphere_seeds(a_sphere: &[DVec3], b_sphere: &[DVec3]) -> Vec<(u32, Vec<u32>)> {
    let n = a_sphere.len();
    let count = SEED_VERTICES.min(n);
    let k = NEAREST.min(b_sphere.len());
    if k == 0 {
        return Vec::new();
    }
    (0..count)
        .map(|s| {
            let u = (s * n / count) as u32;
            let mut nearest: Vec<(f64, u32)> = b_sphere
                .iter()
                .enumerate()
                .map(|(x, &p)| (-p.dot(a_sphere[u as usize]), x as u32))
                .collect();
            nearest.select_nth_unstable_by(k - 1, |p, q| p.0.total_cmp(&q.0));
            nearest.truncate(k);
            nearest.sort_by(|p, q| p.0.total_cmp(&q.0));
            (u, nearest.into_iter().map(|(_, x)| x).collect())
        })
        .collect()
}

/// The renumbering `map` (A vertex `i` is B vertex `map[i]`) under which B
/// has A's triangles, tried from `seeds` (an A vertex and candidates for
/// its twin, most likely first; every outgoing edge of a candidate is
/// tried), with the smallest `D` among the maps found; `None` when the
/// meshes differ or no seed finds the map. Both meshes are cleaned, closed
/// and oriented.
pub(crate) fn find(
    a: &IndexedMesh,
    b: &IndexedMesh,
    seeds: &[(u32, Vec<u32>)],
) -> Option<Vec<u32>> {
    let n = a.vertex_count();
    if n != b.vertex_count() || a.triangle_count() != b.triangle_count() || n == 0 {
        return None;
    }
    let (ea, eb) = (Edges::new(&a.triangles)?, Edges::new(&b.triangles)?);
    // One outgoing edge per A vertex, every outgoing edge per B vertex.
    let mut out_a = vec![u32::MAX; n];
    let mut out_b: Vec<Vec<u32>> = vec![Vec::new(); n];
    for tri in &a.triangles {
        for k in 0..3 {
            out_a[tri[k] as usize] = tri[(k + 1) % 3];
        }
    }
    for tri in &b.triangles {
        for k in 0..3 {
            out_b[tri[k] as usize].push(tri[(k + 1) % 3]);
        }
    }
    let mut maps: Vec<Vec<u32>> = Vec::new();
    'seeds: for (u, candidates) in seeds {
        let u = *u;
        let Some(&v) = out_a.get(u as usize).filter(|&&v| v != u32::MAX) else {
            continue;
        };
        for &x in candidates {
            for &y in out_b.get(x as usize).into_iter().flatten() {
                if maps
                    .iter()
                    .any(|m| m[u as usize] == x && m[v as usize] == y)
                {
                    continue;
                }
                let seed = ((u, v), (x, y));
                if let Some(map) = propagate(&a.triangles, &ea, &b.triangles, &eb, n, seed) {
                    maps.push(map);
                    if maps.len() >= MAX_MAPS {
                        break 'seeds;
                    }
                }
            }
        }
    }
    maps.into_iter()
        .map(|map| {
            let v1: Vec<[f32; 3]> = map.iter().map(|&m| b.positions[m as usize]).collect();
            (measure(&a.triangles, &a.positions, &v1).d, map)
        })
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, map)| map)
}
