//! Progressive Meshes (Hoppe 1996) as the LodStrips paper benchmarks it: the mesh kept as one
//! indexed triangle list that every LOD step edits in place, with a record per step.
//!
//! Hoppe's `ecol`/`vsplit` pair becomes, for our half-edge collapse `u → w`:
//! * `ecol`: the faces holding both `u` and `w` vanish, every other live corner holding `u`
//!   is rewritten to `w`;
//! * `vsplit`: the inverse, from the same record.
//!
//! As in Hoppe's implementation (and Direct3D's `ID3DXPMesh`), faces are stored in the order in
//! which they vanish, last first, so the live mesh is always a prefix of the face array and a
//! step only moves the prefix end; the record names the corners to rewrite, so neither
//! direction searches the mesh. No strips: PM sends three indices per triangle, which is the
//! rendering cost the LodStrips paper charges it with (its Table 2).

use super::{Baseline, BaselineError, Primitive, Regions};
use morphlod::collapse::CollapseSequence;

/// Faces that are degenerate in the input never draw: they sort behind every live face.
const NEVER_LIVE: u32 = 0;

/// A progressive mesh and its current LOD.
#[derive(Clone, Debug)]
pub struct ProgressiveMesh {
    /// `u` of step `j` at `2j`, `w` at `2j + 1` (what a `vsplit` writes back, and `ecol` writes).
    collapses: Vec<u32>,
    /// Corners step `j` rewrites are `corners[corner_start[j]..corner_start[j + 1]]`, each
    /// `3 · face + k` in the ordered face array.
    corner_start: Vec<u32>,
    corners: Vec<u32>,
    /// Live faces at each LOD: `live_faces[l]` (`max_lod + 1` entries). Hoppe stores the faces
    /// a `vsplit` adds; a count per LOD is the same information, indexable in both directions.
    live_faces: Vec<u32>,
    /// The face array at LOD 0, three indices per face, faces ordered by when they vanish.
    faces0: Vec<u32>,
    /// Runtime state: the face array at the current LOD (one region, edited in place) and the
    /// LOD.
    faces: Regions,
    lod: usize,
}

impl ProgressiveMesh {
    /// Records `seq` over `triangles` (the mesh the sequence simplifies).
    pub fn build(
        triangles: &[[u32; 3]],
        seq: &CollapseSequence,
    ) -> Result<ProgressiveMesh, BaselineError> {
        seq.validate()?;
        let vertices = seq.vertex_count as usize;
        if let Some(&vertex) = triangles
            .iter()
            .flatten()
            .find(|&&v| v as usize >= vertices)
        {
            return Err(BaselineError::VertexOutOfRange {
                what: "a triangle",
                vertex,
                vertices,
            });
        }
        let max = seq.len();
        // Replay the sequence on a copy: each face's last live LOD + 1 ("death"), and the
        // (face, corner) rewrites of every step, in input face numbers for now.
        let mut mapped = triangles.to_vec();
        let mut incident: Vec<Vec<u32>> = vec![Vec::new(); vertices];
        let degenerate = |t: [u32; 3]| t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
        let mut death: Vec<u32> = vec![max as u32 + 1; triangles.len()];
        for (f, t) in triangles.iter().enumerate() {
            if degenerate(*t) {
                death[f] = NEVER_LIVE;
                continue;
            }
            for &v in t {
                incident[v as usize].push(f as u32);
            }
        }
        let mut steps: Vec<Vec<(u32, u8)>> = Vec::with_capacity(max);
        for (j, c) in seq.collapses.iter().enumerate() {
            let mut rewrites = Vec::new();
            let faces = std::mem::take(&mut incident[c.u as usize]);
            let mut kept = Vec::with_capacity(faces.len());
            for f in faces {
                // Faces that vanished at an earlier step stay listed under their other
                // corners; they are dropped here, when one of those collapses.
                if death[f as usize] <= j as u32 {
                    continue;
                }
                let t = &mut mapped[f as usize];
                if t.contains(&c.w) {
                    // Holds both ends: the collapse removes it (alive at LOD j, not at j + 1).
                    death[f as usize] = j as u32 + 1;
                    continue;
                }
                for (k, v) in t.iter_mut().enumerate() {
                    if *v == c.u {
                        *v = c.w;
                        rewrites.push((f, k as u8));
                    }
                }
                kept.push(f);
            }
            incident[c.w as usize].extend(kept);
            steps.push(rewrites);
        }
        // Order faces by death, latest first (stable, so the input order breaks ties).
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        order.sort_by_key(|&f| std::cmp::Reverse(death[f as usize]));
        let mut position = vec![0u32; triangles.len()];
        for (p, &f) in order.iter().enumerate() {
            position[f as usize] = p as u32;
        }
        let faces0: Vec<u32> = order.iter().flat_map(|&f| triangles[f as usize]).collect();
        let mut corner_start = Vec::with_capacity(max + 1);
        let mut corners = Vec::new();
        corner_start.push(0);
        for rewrites in &steps {
            corners.extend(
                rewrites
                    .iter()
                    .map(|&(f, k)| 3 * position[f as usize] + u32::from(k)),
            );
            corner_start.push(corners.len() as u32);
        }
        // live_faces[l] = faces with death > l: all faces less those dead by l.
        let mut dying = vec![0u32; max + 2];
        for &d in &death {
            dying[d as usize] += 1;
        }
        let mut live = triangles.len() as u32;
        let live_faces: Vec<u32> = (0..=max)
            .map(|l| {
                live -= dying[l];
                live
            })
            .collect();
        Ok(ProgressiveMesh {
            collapses: seq.collapses.iter().flat_map(|c| [c.u, c.w]).collect(),
            corner_start,
            corners,
            live_faces,
            faces: {
                let mut faces = Regions::new(vec![0, faces0.len() as u32]);
                faces.write(0, &faces0);
                faces.clear_changed();
                faces
            },
            faces0,
            lod: 0,
        })
    }
}

impl Baseline for ProgressiveMesh {
    fn name(&self) -> &'static str {
        "PM"
    }

    fn primitive(&self) -> Primitive {
        Primitive::Triangles
    }

    fn max_lod(&self) -> usize {
        self.collapses.len() / 2
    }

    fn lod(&self) -> usize {
        self.lod
    }

    fn set_lod(&mut self, lod: usize) -> Result<(), BaselineError> {
        let max = self.max_lod();
        if lod > max {
            return Err(BaselineError::LodOutOfRange { lod, max });
        }
        // ecol: coarser.
        while self.lod < lod {
            let j = self.lod;
            let w = self.collapses[2 * j + 1];
            for i in self.corner_start[j]..self.corner_start[j + 1] {
                self.faces.live[self.corners[i as usize] as usize] = w;
            }
            self.lod += 1;
        }
        // vsplit: finer, the same records backwards.
        while self.lod > lod {
            let j = self.lod - 1;
            let u = self.collapses[2 * j];
            for i in self.corner_start[j]..self.corner_start[j + 1] {
                self.faces.live[self.corners[i as usize] as usize] = u;
            }
            self.lod -= 1;
        }
        self.faces
            .set_len(0, 3 * self.live_faces[self.lod] as usize);
        Ok(())
    }

    region_methods!(faces);

    fn model_bytes(&self) -> usize {
        4 * (self.collapses.len()
            + self.corner_start.len()
            + self.corners.len()
            + self.live_faces.len()
            + self.faces0.len())
    }

    fn state_bytes(&self) -> usize {
        self.faces.state_bytes() + 8
    }
}
