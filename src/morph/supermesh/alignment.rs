//! Stage 3 as [`Supermesh::build`](super::Supermesh::build) runs it, over the kernels of
//! `align.rs`, `mobius.rs` and `tips.rs`: the tables read of each cleaned mesh ([`Tables`]),
//! B's sphere aligned with A's ([`align_b`]: Möbius normalisation, the rotation search, the
//! limb-tip pairing of [`pair_tips`], or the landmarks' Möbius fit and drag), and the
//! alignment residual as overlaid ([`final_residual`]).

use glam::{DMat3, DVec3};

use super::align::Residual;
use super::check;
use super::embed::{self, Embedded};
use super::report::{AlignmentReport, TipPair, TipReport};
use super::sphere::SphereMesh;
use super::{align, mobius, tips};
use super::{Side, SupermeshError, SupermeshOptions};
use crate::mesh::clean::Cleaned;
use crate::mesh::IndexedMesh;

/// Sweeps of area-proportional relaxation of both embeddings after the
/// landmark drag (man stood up → camel with the shipped landmarks: 0 → 30
/// → 150 → 500 sweeps give 180.8k → 159.0k → 138.8k → 132.0k supermesh
/// vertices and s(½) 0.897 → 0.901 → 0.905 → 0.907; 150 costs about a
/// second in the dev profile).
const LANDMARK_RELAX_SWEEPS: usize = 150;

/// Steps along the path from the identity to the landmarks' Möbius map
/// ([`mobius::warp`]).
const MOBIUS_STEPS: usize = 32;

/// The largest stretch ([`mobius::Mobius::stretch`]) of a tip pairing's
/// Möbius map that is scored: past it the fit is near singular (tips nearly
/// on one point of either sphere), not a correspondence.
const MAX_TIP_STRETCH: f64 = 100.0;

/// The best tip pairings (by their fit's score) that get a local descent
/// over Möbius maps ([`mobius::descend`]) before the comparison with the
/// rotation search.
const TIP_DESCENTS: usize = 2;

pub(super) fn normalised(mesh: &IndexedMesh, mass: &[f64]) -> Vec<DVec3> {
    let frame = align::Frame::new(&mesh.positions, mass);
    mesh.positions.iter().map(|&p| frame.apply(p)).collect()
}

/// What the alignment and the refinement read of one cleaned mesh, built
/// once: its vertex rings, vertex masses (a third of each triangle's area)
/// and normalised positions (as in the correspondence measure).
pub(super) struct Tables {
    pub(super) rings: Vec<Vec<u32>>,
    pub(super) mass: Vec<f64>,
    pub(super) normalised: Vec<DVec3>,
}

impl Tables {
    pub(super) fn new(mesh: &IndexedMesh, side: Side) -> Result<Tables, SupermeshError> {
        let rings = rings_of(mesh, side)?;
        let mass = embed::vertex_masses(&mesh.positions, &mesh.triangles);
        let normalised = normalised(mesh, &mass);
        Ok(Tables {
            rings,
            mass,
            normalised,
        })
    }
}

/// Each vertex's ring of neighbours; a mesh whose rings cannot be built
/// was not embeddable either.
fn rings_of(mesh: &IndexedMesh, side: Side) -> Result<Vec<Vec<u32>>, SupermeshError> {
    embed::build_rings(mesh.vertex_count(), &mesh.triangles).map_err(|e| {
        SupermeshError::Embedding {
            mesh: side,
            what: format!("{e:?}"),
        }
    })
}

/// Stage 3: both embeddings Möbius-normalised, then B's sphere rotated to
/// the smallest `D`, or with landmarks mapped by their least-squares Möbius
/// fit and its landmarks pulled exactly onto A's (see `align.rs`).
pub(super) fn align_b(
    (a, ta): (&IndexedMesh, &Tables),
    (b, tb): (&IndexedMesh, &Tables),
    embedded: &mut Embedded,
    landmarks: &[(u32, u32)],
    options: &SupermeshOptions,
) -> Result<Aligned, SupermeshError> {
    let (mass_a, mass_b) = (&ta.mass, &tb.mass);
    let (rings_a, rings) = (&ta.rings, &tb.rings);
    let mut report = AlignmentReport::default();
    // Centring moves shared points of radial embeddings apart: kept as they are.
    if options.align && !options.radial {
        report.centroid_a = mobius::centre(rings_a, &mut embedded.a, mass_a, &a.triangles);
        report.centroid_b = mobius::centre(rings, &mut embedded.b, mass_b, &b.triangles);
    }
    let (qa, qb) = (&ta.normalised, &tb.normalised);
    let samples = align::samples(&embedded.a, qa, mass_a, 4000);
    let lookup = align::SurfaceLookup::new(&SphereMesh::new(&embedded.b, &b.triangles), qb);
    report.before = align::residual(&samples, &lookup, DMat3::IDENTITY);
    report.after = report.before;
    let mut points = embedded.b.clone();
    // The rotation with the smallest D as placed, unless the one with the
    // smallest D after turning A's shape (blind to placement) is under half
    // of it: then B is placed differently (man.off is z-up, makehuman's
    // body y-up: D 1.27 as placed, 0.17 turned), and the correspondence
    // follows the shapes; the refinement then works in the turned frame.
    let (rotation, turn) = if options.align {
        let b_samples = align::samples(&embedded.b, qb, mass_b, 4000);
        let extra = align::moment_candidates(&samples, &b_samples);
        let placed = align::search_rotation(&samples, &lookup, &extra, false);
        let turned = align::search_rotation(&samples, &lookup, &extra, true);
        if align::cost(&samples, &lookup, turned, true)
            < 0.5 * align::cost(&samples, &lookup, placed, false)
        {
            (turned, align::shape_turn(&samples, &lookup, turned))
        } else {
            (placed, DMat3::IDENTITY)
        }
    } else {
        (DMat3::IDENTITY, DMat3::IDENTITY)
    };
    let mut tips = None;
    if landmarks.is_empty() && options.tips && options.align && !options.radial {
        let (warped, tip_report) =
            pair_tips((a, ta, &embedded.a), (b, tb, &embedded.b), rotation, turn);
        tips = Some(tip_report);
        if let Some(warped) = warped {
            return Ok((warped, report, turn, tips));
        }
    }
    if !align::rotate(&mut points, &b.triangles, rotation) {
        return Err(SupermeshError::Embedding {
            mesh: Side::B,
            what: "rounding of the alignment rotation folded a triangle".into(),
        });
    }
    if landmarks.is_empty() {
        return Ok((points, report, turn, tips));
    }
    // Landmarks: from the automatic alignment, the landmarks' least-squares
    // Möbius map (exact for three pairs), then the drag for what it leaves.
    report.landmarks_before = Some(align::landmark_angles(&embedded.a, &points, landmarks));
    let (from, to): (Vec<DVec3>, Vec<DVec3>) = landmarks
        .iter()
        .map(|&(la, lb)| (points[lb as usize], embedded.a[la as usize]))
        .unzip();
    let fit = mobius::Mobius::fit(&from, &to);
    report.mobius_unreached = Some(mobius::warp(
        rings,
        &b.triangles,
        &mut points,
        &fit,
        MOBIUS_STEPS,
        4,
    ));
    report.landmarks_fit = Some(align::landmark_angles(&embedded.a, &points, landmarks));
    // The pairs meet halfway (each embedding dragged half as far), then
    // whatever is left is closed from B's side, then from A's.
    let goals: Vec<DVec3> = landmarks
        .iter()
        .map(|&(la, lb)| {
            let (x, y) = (embedded.a[la as usize], points[lb as usize]);
            (x.normalize() + y.normalize()).normalize_or(x)
        })
        .collect();
    let index = |side: usize| -> Vec<(u32, u32)> {
        landmarks
            .iter()
            .enumerate()
            .map(|(k, &p)| (k as u32, if side == 0 { p.0 } else { p.1 }))
            .collect()
    };
    let (pairs_a, pairs_b) = (index(0), index(1));
    align::pull_landmarks(mass_a, rings_a, &mut embedded.a, &goals, &pairs_a, 400);
    align::pull_landmarks(mass_b, rings, &mut points, &goals, &pairs_b, 400);
    align::pull_landmarks(mass_b, rings, &mut points, &embedded.a, landmarks, 400);
    let swapped: Vec<(u32, u32)> = landmarks.iter().map(|&(la, lb)| (lb, la)).collect();
    align::pull_landmarks(mass_a, rings_a, &mut embedded.a, &points, &swapped, 400);
    if let Some((pair, &(la, lb))) = landmarks
        .iter()
        .enumerate()
        .find(|(_, &(la, lb))| points[lb as usize] != embedded.a[la as usize])
    {
        return Err(SupermeshError::LandmarkUnreached {
            pair,
            angle: points[lb as usize].angle_between(embedded.a[la as usize]),
        });
    }
    // The drag squeezes and stretches caps around the landmarks, which makes
    // the overlay cross more and blends the wrong points near them: both
    // embeddings relaxed toward area-proportional again, landmarks pinned
    // (fold-rejecting, so every pair stays on one point).
    let (free_a, free_b) = free_vertices(embedded.a.len(), points.len(), landmarks);
    embed::relax(
        mass_a,
        rings_a,
        &mut embedded.a,
        &free_a,
        LANDMARK_RELAX_SWEEPS,
    );
    embed::relax(mass_b, rings, &mut points, &free_b, LANDMARK_RELAX_SWEEPS);
    report.landmarks_after = Some(align::landmark_angles(&embedded.a, &points, landmarks));
    // The landmarks say which parts correspond, whatever the placement.
    Ok((points, report, DMat3::IDENTITY, None))
}

/// What [`align_b`] gives: B's aligned sphere points, the report, the turn
/// of A's normalised shape into B's frame (the identity unless B is placed
/// differently) and the limb-tip pairing's report (cleaned indices).
pub(super) type Aligned = (Vec<DVec3>, AlignmentReport, DMat3, Option<TipReport>);

/// The limb-tip pairing (`tips.rs`; docs/DESIGN.md, "Alignment"): every
/// candidate pairing's least-squares Möbius map of B's tip sphere points
/// onto A's, scored by `D` both ways without moving a vertex (B's surface
/// read at the map's inverse); the best [`TIP_DESCENTS`] then descend over
/// Möbius maps by that score ([`mobius::descend`], on 1000 samples a side,
/// within [`MAX_TIP_STRETCH`]); the best, if it scores under the rotation
/// search's `rotation`, is warped whole ([`mobius::warp`]) and scored again
/// as warped. Returns B's warped sphere points when that still beats the
/// rotation, and the report (cleaned vertex indices).
pub(super) fn pair_tips(
    (a, ta, a_sphere): (&IndexedMesh, &Tables, &[DVec3]),
    (b, tb, b_sphere): (&IndexedMesh, &Tables, &[DVec3]),
    rotation: DMat3,
    turn: DMat3,
) -> (Option<Vec<DVec3>>, TipReport) {
    let tips_a = tips::find(&a.positions, &ta.rings, &ta.mass);
    let tips_b = tips::find(&b.positions, &tb.rings, &tb.mass);
    let pa: Vec<DVec3> = tips_a
        .iter()
        .map(|&v| turn * ta.normalised[v as usize])
        .collect();
    let pb: Vec<DVec3> = tips_b.iter().map(|&v| tb.normalised[v as usize]).collect();
    let candidates = tips::pairings(&pa, &pb);
    let samples_a = align::samples(a_sphere, &ta.normalised, &ta.mass, 4000);
    let samples_b = align::samples(b_sphere, &tb.normalised, &tb.mass, 4000);
    let surface = |sphere: &[DVec3], mesh: &IndexedMesh, t: &Tables| {
        align::SurfaceLookup::new(&SphereMesh::new(sphere, &mesh.triangles), &t.normalised)
    };
    let (lookup_a, lookup_b) = (surface(a_sphere, a, ta), surface(b_sphere, b, tb));
    let score = |back: &dyn Fn(DVec3) -> DVec3, forth: &dyn Fn(DVec3) -> DVec3| {
        align::two_way_cost(
            (&samples_a, &lookup_a),
            (&samples_b, &lookup_b),
            turn,
            back,
            forth,
        )
    };
    let inverse = rotation.transpose();
    let rotation_d = score(&|x| inverse * x, &|y| rotation * y);
    let mut scored: Vec<(f64, mobius::Mobius, usize)> = candidates
        .iter()
        .enumerate()
        .filter_map(|(k, pairs)| {
            let (from, to): (Vec<DVec3>, Vec<DVec3>) = pairs
                .iter()
                .map(|&(i, j)| (b_sphere[tips_b[j] as usize], a_sphere[tips_a[i] as usize]))
                .unzip();
            let map = mobius::Mobius::fit(&from, &to);
            let stretch = map.stretch();
            if stretch.is_nan() || stretch > MAX_TIP_STRETCH {
                return None;
            }
            let back = map.inverse();
            let d = score(&|x| back.apply(x), &|y| map.apply(y));
            (!d.is_nan()).then_some((d, map, k))
        })
        .collect();
    scored.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
    // The fit lines up the tips, not the shapes between them: the best few
    // descend by D (on fewer samples), within the stretch cap.
    let few_a = align::samples(a_sphere, &ta.normalised, &ta.mass, 1000);
    let few_b = align::samples(b_sphere, &tb.normalised, &tb.mass, 1000);
    for entry in scored.iter_mut().take(TIP_DESCENTS) {
        let (_, map) = mobius::descend(entry.1, 0.1, |m| {
            if m.stretch() > MAX_TIP_STRETCH {
                return f64::INFINITY;
            }
            let back = m.inverse();
            align::two_way_cost(
                (&few_a, &lookup_a),
                (&few_b, &lookup_b),
                turn,
                &|x| back.apply(x),
                &|y| m.apply(y),
            )
        });
        let back = map.inverse();
        let d = score(&|x| back.apply(x), &|y| map.apply(y));
        if d < entry.0 {
            (entry.0, entry.1) = (d, map);
        }
    }
    scored.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
    let mut report = TipReport {
        tips_a: tips_a.clone(),
        tips_b: tips_b.clone(),
        candidates: candidates.len(),
        d: rotation_d,
        rotation_d,
        runner_up_d: scored.first().map(|s| s.0),
        ..TipReport::default()
    };
    let Some(&(fit_d, map, k)) = scored.first() else {
        return (None, report);
    };
    if fit_d >= rotation_d {
        return (None, report);
    }
    let mut warped = b_sphere.to_vec();
    mobius::warp(&tb.rings, &b.triangles, &mut warped, &map, MOBIUS_STEPS, 4);
    let samples_w = align::samples(&warped, &tb.normalised, &tb.mass, 4000);
    let lookup_w = surface(&warped, b, tb);
    let warped_d = align::two_way_cost(
        (&samples_a, &lookup_a),
        (&samples_w, &lookup_w),
        turn,
        &|x| x,
        &|y| y,
    );
    if warped_d.is_nan() || warped_d >= rotation_d {
        report.runner_up_d = Some(warped_d);
        return (None, report);
    }
    report.d = warped_d;
    report.runner_up_d = Some(scored.get(1).map_or(rotation_d, |s| s.0.min(rotation_d)));
    report.stretch = map.stretch();
    report.pairs = candidates[k]
        .iter()
        .map(|&(i, j)| {
            let (va, vb) = (tips_a[i], tips_b[j]);
            TipPair {
                a: va,
                b: vb,
                a_position: a.positions[va as usize],
                b_position: b.positions[vb as usize],
            }
        })
        .collect();
    (Some(warped), report)
}

/// The tip report's vertices in the input meshes' indices.
pub(super) fn input_indices(report: &mut TipReport, ca: &Cleaned, cb: &Cleaned) {
    for v in &mut report.tips_a {
        *v = ca.vertex_map[*v as usize];
    }
    for v in &mut report.tips_b {
        *v = cb.vertex_map[*v as usize];
    }
    for p in &mut report.pairs {
        p.a = ca.vertex_map[p.a as usize];
        p.b = cb.vertex_map[p.b as usize];
    }
}

/// The limb tips of a mesh (docs/DESIGN.md, "Alignment"): the prominent
/// local maxima of its average geodesic distance, most prominent first, at
/// most eight; input vertex indices. A sphere-like mesh has one (its
/// global maximum). The mesh must pass the supermesh's checks (closed,
/// manifold, genus 0, one component); its errors name mesh A.
pub fn limb_tips(mesh: &IndexedMesh) -> Result<Vec<u32>, SupermeshError> {
    let cleaned = check::prepare(mesh, Side::A)?;
    let tables = Tables::new(&cleaned.mesh, Side::A)?;
    Ok(
        tips::find(&cleaned.mesh.positions, &tables.rings, &tables.mass)
            .into_iter()
            .map(|v| cleaned.vertex_map[v as usize])
            .collect(),
    )
}

/// The vertices of A and of B in no landmark pair.
pub(super) fn free_vertices(
    na: usize,
    nb: usize,
    landmarks: &[(u32, u32)],
) -> (Vec<u32>, Vec<u32>) {
    let free = |n: usize, side: &dyn Fn(&(u32, u32)) -> u32| -> Vec<u32> {
        let mut pinned = vec![false; n];
        for p in landmarks {
            pinned[side(p) as usize] = true;
        }
        (0..n as u32).filter(|&v| !pinned[v as usize]).collect()
    };
    (free(na, &|p| p.0), free(nb, &|p| p.1))
}

/// The alignment residual as overlaid (after landmarks and perturbation).
pub(super) fn final_residual(
    (ta, a_sphere): (&Tables, &[DVec3]),
    (b, tb, b_sphere): (&IndexedMesh, &Tables, &[DVec3]),
) -> Residual {
    let samples = align::samples(a_sphere, &ta.normalised, &ta.mass, 4000);
    let lookup =
        align::SurfaceLookup::new(&SphereMesh::new(b_sphere, &b.triangles), &tb.normalised);
    align::residual(&samples, &lookup, DMat3::IDENTITY)
}
