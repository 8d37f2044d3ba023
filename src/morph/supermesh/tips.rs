//! Limb tips and their pairings: the automatic alignment of shapes that
//! differ, a biped and a quadruped (issue 25, item 4; docs/DESIGN.md,
//! "Alignment").
//!
//! 1. [`find`]: the tips of a mesh are the prominent local maxima of its
//!    average geodesic distance (AGD: far from everything else), the
//!    approximate AGD being the mean of [`SOURCES`] Dijkstra runs over the
//!    edge graph from sources spread by area (`O(k n log n)`). Prominence is
//!    the topographic one (0-dimensional persistence of the superlevel sets:
//!    how far a peak falls before its component joins a higher peak's),
//!    over the mean AGD; a sphere has one tip (its global maximum), the man
//!    five (head, hands, feet), the camel six (head, feet, tail).
//! 2. [`pairings`]: partial injective maps of A's tips to B's of at least
//!    three pairs, under two priors on the normalised shapes (A's turned into
//!    B's frame when B is placed differently): the *up* prior (the y axis,
//!    glTF's and the demo's up: a pairing may not turn the height order of
//!    two tips round by more than [`HEIGHT_MARGIN`]) and the *left/right*
//!    prior (no mirror: every three pairs span a tetrahedron with the
//!    centroid of the same handedness in both shapes, so a left hand does
//!    not go to the right front foot when the right hand goes to the left).
//!    Most pairs first, then the smallest height mismatch; at most
//!    [`MAX_CANDIDATES`].
//!
//! Each pairing's least-squares Möbius map is then scored against the
//! rotation search by `pair_tips` (`alignment.rs`).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// Sources of the geodesic distances whose mean approximates the AGD.
const SOURCES: usize = 16;

/// Most tips kept per mesh (the most prominent).
pub(crate) const MAX_TIPS: usize = 8;

/// A tip's prominence at least this fraction of the mean AGD (man, camel:
/// the limbs 0.29–1.16, everything else under 0.09).
const PROMINENCE: f64 = 0.1;

/// The up prior's slack, in units of each shape's RMS radius.
const HEIGHT_MARGIN: f64 = 0.3;

/// Triple products (RMS radius units cubed) smaller than this leave the
/// handedness of three pairs undecided.
const HANDEDNESS_MIN: f64 = 0.05;

/// Pairings scored at most.
pub(crate) const MAX_CANDIDATES: usize = 64;

/// Partial maps the enumeration visits at most.
const VISIT_BUDGET: usize = 50_000;

fn d3(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// Approximate average geodesic distance of every vertex over the edge
/// graph (`rings`: each vertex's neighbours): the mean distance to
/// [`SOURCES`] vertices spread over the surface by area (`mass`, in vertex
/// order at equal steps of the cumulative area).
pub(crate) fn average_geodesic(
    positions: &[[f32; 3]],
    rings: &[Vec<u32>],
    mass: &[f64],
) -> Vec<f64> {
    let n = positions.len();
    let total: f64 = mass.iter().sum();
    let mut sources = Vec::with_capacity(SOURCES);
    let mut acc = 0.0;
    for (v, &m) in mass.iter().enumerate() {
        acc += m;
        while sources.len() < SOURCES
            && acc >= (sources.len() as f64 + 0.5) / SOURCES as f64 * total
        {
            sources.push(v as u32);
        }
    }
    if sources.is_empty() || total.is_nan() || total <= 0.0 {
        return vec![0.0; n];
    }
    let count = sources.len() as f64;
    // Summed in source order, not by a parallel reduction: the same input
    // gives the same bits, so the same tips and the same supermesh.
    let distances: Vec<Vec<f64>> = sources
        .par_iter()
        .map(|&s| dijkstra(positions, rings, s))
        .collect();
    let mut sum = vec![0.0; n];
    for d in &distances {
        for (x, y) in sum.iter_mut().zip(d) {
            *x += y;
        }
    }
    sum.into_iter()
        .map(|d| if d.is_finite() { d / count } else { 0.0 })
        .collect()
}

/// Edge-graph distances from `source` (infinite where unreachable).
fn dijkstra(positions: &[[f32; 3]], rings: &[Vec<u32>], source: u32) -> Vec<f64> {
    let mut dist = vec![f64::INFINITY; positions.len()];
    dist[source as usize] = 0.0;
    // Non-negative floats order as their bits.
    let mut heap = BinaryHeap::from([Reverse((0u64, source))]);
    while let Some(Reverse((bits, v))) = heap.pop() {
        let d = f64::from_bits(bits);
        if d > dist[v as usize] {
            continue;
        }
        let p = d3(positions[v as usize]);
        for &w in &rings[v as usize] {
            let nd = d + (d3(positions[w as usize]) - p).length();
            if nd < dist[w as usize] {
                dist[w as usize] = nd;
                heap.push(Reverse((nd.to_bits(), w)));
            }
        }
    }
    dist
}

/// The limb tips of a mesh: its prominent AGD maxima (module docs), most
/// prominent first, at most [`MAX_TIPS`]. Empty for an empty mesh.
pub(crate) fn find(positions: &[[f32; 3]], rings: &[Vec<u32>], mass: &[f64]) -> Vec<u32> {
    let agd = average_geodesic(positions, rings, mass);
    let used: Vec<u32> = (0..positions.len() as u32)
        .filter(|&v| !rings[v as usize].is_empty())
        .collect();
    let total: f64 = used.iter().map(|&v| mass[v as usize]).sum();
    let mean = used
        .iter()
        .map(|&v| agd[v as usize] * mass[v as usize])
        .sum::<f64>()
        / total;
    if used.is_empty() || mean.is_nan() || mean <= 0.0 {
        return Vec::new();
    }
    let mut order = used;
    order.sort_by(|&x, &y| agd[y as usize].total_cmp(&agd[x as usize]).then(x.cmp(&y)));
    // Union-find over the superlevel sets, each component's root knowing
    // its peak: when a vertex joins components, all but the highest peak's
    // die there, their peaks' prominence the fall from peak to that vertex.
    let mut parent = vec![u32::MAX; positions.len()];
    let mut peak = vec![u32::MAX; positions.len()];
    let mut prominence: Vec<(u32, f64)> = Vec::new();
    fn root(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let up = parent[parent[x as usize] as usize];
            parent[x as usize] = up;
            x = up;
        }
        x
    }
    let mut roots: Vec<u32> = Vec::new();
    for &v in &order {
        roots.clear();
        for &w in &rings[v as usize] {
            if parent[w as usize] != u32::MAX {
                let r = root(&mut parent, w);
                if !roots.contains(&r) {
                    roots.push(r);
                }
            }
        }
        // The highest peak survives (ties: the lower vertex index).
        let best = roots.iter().copied().min_by(|&x, &y| {
            let (px, py) = (peak[x as usize], peak[y as usize]);
            agd[py as usize]
                .total_cmp(&agd[px as usize])
                .then(px.cmp(&py))
        });
        match best {
            None => {
                parent[v as usize] = v;
                peak[v as usize] = v;
            }
            Some(best) => {
                for &r in &roots {
                    if r != best {
                        let p = peak[r as usize];
                        prominence.push((p, agd[p as usize] - agd[v as usize]));
                        parent[r as usize] = best;
                    }
                }
                parent[v as usize] = best;
            }
        }
    }
    let (highest, lowest) = (order[0], order[order.len() - 1]);
    prominence.push((highest, agd[highest as usize] - agd[lowest as usize]));
    prominence.retain(|&(_, p)| p >= PROMINENCE * mean);
    prominence.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.cmp(&y.0)));
    prominence.truncate(MAX_TIPS);
    prominence.into_iter().map(|(v, _)| v).collect()
}

/// Candidate pairings of A's tips with B's (module docs), as index pairs
/// into `a` and `b` (the tips' normalised positions, A's turned into B's
/// frame), most pairs first, then the smallest height mismatch; at most
/// [`MAX_CANDIDATES`]. Empty when either side has fewer than three tips.
pub(crate) fn pairings(a: &[DVec3], b: &[DVec3]) -> Vec<Vec<(usize, usize)>> {
    if a.len() < 3 || b.len() < 3 {
        return Vec::new();
    }
    let mut out: Vec<(f64, Vec<(usize, usize)>)> = Vec::new();
    let mut partial: Vec<(usize, usize)> = Vec::new();
    let mut used = vec![false; b.len()];
    let mut visits = 0;
    extend(a, b, 0, &mut partial, &mut used, &mut out, &mut visits);
    out.sort_by(|x, y| y.1.len().cmp(&x.1.len()).then(x.0.total_cmp(&y.0)));
    out.truncate(MAX_CANDIDATES);
    out.into_iter().map(|(_, p)| p).collect()
}

/// Whether the pair `(i, j)` can join `partial` under the priors.
fn admissible(
    a: &[DVec3],
    b: &[DVec3],
    partial: &[(usize, usize)],
    (i, j): (usize, usize),
) -> bool {
    let ordered = partial.iter().all(|&(k, l)| {
        let (ha, hb) = (a[i].y - a[k].y, b[j].y - b[l].y);
        !(ha > HEIGHT_MARGIN && hb < -HEIGHT_MARGIN || ha < -HEIGHT_MARGIN && hb > HEIGHT_MARGIN)
    });
    ordered
        && partial.iter().enumerate().all(|(x, &(k, l))| {
            partial[x + 1..].iter().all(|&(m, o)| {
                let da = DMat3::from_cols(a[i], a[k], a[m]).determinant();
                let db = DMat3::from_cols(b[j], b[l], b[o]).determinant();
                da.abs() < HANDEDNESS_MIN || db.abs() < HANDEDNESS_MIN || (da > 0.0) == (db > 0.0)
            })
        })
}

/// Depth-first: A's tip `i` unpaired or paired with each free B tip.
fn extend(
    a: &[DVec3],
    b: &[DVec3],
    i: usize,
    partial: &mut Vec<(usize, usize)>,
    used: &mut [bool],
    out: &mut Vec<(f64, Vec<(usize, usize)>)>,
    visits: &mut usize,
) {
    *visits += 1;
    if *visits > VISIT_BUDGET {
        return;
    }
    // Too few A tips left to reach three pairs.
    if partial.len() + (a.len() - i) < 3 {
        return;
    }
    if i == a.len() {
        let mismatch = partial.iter().map(|&(k, l)| (a[k].y - b[l].y).abs()).sum();
        out.push((mismatch, partial.clone()));
        return;
    }
    for j in 0..b.len() {
        if !used[j] && admissible(a, b, partial, (i, j)) {
            used[j] = true;
            partial.push((i, j));
            extend(a, b, i + 1, partial, used, out, visits);
            partial.pop();
            used[j] = false;
        }
    }
    extend(a, b, i + 1, partial, used, out, visits);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirrored_and_upside_down_pairings_are_left_out() {
        // Head, two hands, two feet, each side alike.
        let tips = [
            DVec3::new(0.0, 1.8, 0.0),
            DVec3::new(-1.0, 0.0, 0.3),
            DVec3::new(1.0, 0.0, 0.3),
            DVec3::new(-0.3, -1.8, 0.0),
            DVec3::new(0.3, -1.8, 0.0),
        ];
        let all = pairings(&tips, &tips);
        assert!(!all.is_empty() && all.len() <= MAX_CANDIDATES);
        let identity: Vec<(usize, usize)> = (0..5).map(|k| (k, k)).collect();
        assert_eq!(all[0], identity);
        // Swapping the hands mirrors; head to a foot turns heights round.
        assert!(!all.contains(&vec![(0, 0), (1, 2), (2, 1), (3, 3), (4, 4)]));
        assert!(all
            .iter()
            .all(|p| !p.contains(&(0, 3)) && !p.contains(&(0, 4))));
        assert!(all.iter().all(|p| p.len() >= 3));
        assert!(pairings(&tips[..2], &tips).is_empty());
    }
}
