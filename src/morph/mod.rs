//! The supermesh of a same-connectivity morph: one triangulation `T` with poses
//! `V(t)`, `t ∈ [0, 1]`, written as a base mesh plus weighted morph-target deltas
//! `V(t) = base + Σ w_i(t) D_i` (the glTF morph model).
//!
//! The weights `w(t)` are either
//! * **two-pose** ([`Weights::TwoPose`]): linear in `t`, `w(t) = (1 − t) w0 + t w1`, so
//!   `V(t)` is exactly the linear blend of `V(0)` and `V(1)`; or
//! * **animated** ([`Weights::Animated`]): a glTF weight animation played over its
//!   duration, `t = τ / duration`. `V(t)` is then generally not linear in `t`.
//!
//! The GPU runtime stores `V(0)` and `V(1)` and blends them linearly with `t`: for
//! two-pose morphs that is exact. For animated morphs the asset also carries a
//! [`TargetBlend`] (the targets the animation drives and its weight track), and the GPU
//! draws `V(0) + Σ (w_i(t) − w_i(0)) D_i`, the same surface as [`Morph::positions_at`]
//! up to float rounding.
//!
//! A **skinned** morph ([`Morph::with_skinning`], `skinned.rs`) also carries a skin and a
//! clip ([`Skinning`]): its pose at `t` is the morphed pose above, skinned at the clip's time
//! `t · duration` (morph first, then skin, as glTF defines it); `V(0)`, `V(1)` stay the
//! morphed (bind-space) poses the GPU stores, and [`Morph::positions_at`] is the skinned one.

mod attributes;
mod skinned;
pub mod supermesh;
pub(crate) mod track;

pub use attributes::{
    vertex_normals, Attributes, ImageFormat, Material, Normals, Sampler, Texture, TopologyMap,
};
pub use track::{Interpolation, WeightTrack};

use crate::mesh::clean::{clean_poses, CleanOptions, CleanReport};
use crate::mesh::{IndexedMesh, MeshError};
use crate::skin::{SkinError, Skinning};
use thiserror::Error;

/// One morph target: per-vertex position offsets added with a weight, and optionally
/// normal offsets (glTF's NORMAL target attribute).
#[derive(Clone, Debug, PartialEq)]
pub struct MorphTarget {
    pub name: String,
    pub deltas: Vec<[f32; 3]>,
    /// Normal deltas, one per vertex; `None`: computed ([`Morph::normals`]).
    pub normal_deltas: Option<Vec<[f32; 3]>>,
}

/// How the target weights depend on `t ∈ [0, 1]`.
#[derive(Clone, Debug, PartialEq)]
pub enum Weights {
    /// `w(t) = (1 − t) w0 + t w1`; one weight per target in each.
    TwoPose { w0: Vec<f32>, w1: Vec<f32> },
    /// `w(t) = track(t · track.duration())`.
    Animated(WeightTrack),
}

/// A deforming mesh over one triangulation. Fields are private so the length
/// invariants checked by the constructors hold: every pose and every delta array
/// has `vertex_count` entries, every triangle indexes below it, every weight
/// vector has one entry per target.
#[derive(Clone, Debug, PartialEq)]
pub struct Morph {
    triangles: Vec<[u32; 3]>,
    base: Vec<[f32; 3]>,
    targets: Vec<MorphTarget>,
    weights: Weights,
    attributes: Attributes,
    /// For a morph made from two poses ([`Morph::from_poses`]): `V(1)` as given, which
    /// `base + (v1 − v0)` need not reproduce bit for bit; `positions_at(1)` returns it.
    end_pose: Option<Vec<[f32; 3]>>,
    /// For a skinned morph: the skin and the clip that pose it ([`Morph::with_skinning`]).
    skinning: Option<Box<Skinning>>,
}

/// Why a morph could not be built.
#[derive(Debug, Error)]
pub enum MorphError {
    #[error("the poses have {a} and {b} vertices; a morph needs one vertex count")]
    PoseSizeMismatch { a: usize, b: usize },
    #[error("the meshes have {a} and {b} triangles; a same-connectivity morph needs one triangle list (meshes of different connectivity need the supermesh builder, morph::supermesh)")]
    TriangleCountMismatch { a: usize, b: usize },
    #[error("the meshes differ first at triangle {index}: {a:?} versus {b:?}; a same-connectivity morph needs one triangle list (meshes of different connectivity need the supermesh builder, morph::supermesh)")]
    TriangleMismatch {
        index: usize,
        a: [u32; 3],
        b: [u32; 3],
    },
    #[error("the morph has no triangles ({vertices} vertices)")]
    Empty { vertices: usize },
    #[error("triangle {triangle} uses vertex {index}, but the morph has only {vertices} vertices")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertices: usize,
    },
    #[error("{pose}: vertex {vertex} is not finite ({value:?})")]
    NonFinite {
        pose: String,
        vertex: usize,
        value: [f32; 3],
    },
    #[error("morph target '{target}' has {deltas} deltas for {vertices} vertices")]
    TargetSize {
        target: String,
        deltas: usize,
        vertices: usize,
    },
    #[error("the weights give {weights} values for {targets} morph targets")]
    WeightCount { weights: usize, targets: usize },
    #[error("vertex map entry {position} is {index}, but the morph has only {vertices} vertices")]
    VertexMapOutOfRange {
        position: usize,
        index: u32,
        vertices: usize,
    },
    #[error("a weight track needs at least one keyframe and one target (got {keyframes} keyframes, {targets} targets)")]
    TrackEmpty { keyframes: usize, targets: usize },
    #[error("keyframe {keyframe} has time {time} after {previous}: keyframe times must be finite and strictly increasing")]
    TrackTimes {
        keyframe: usize,
        previous: f32,
        time: f32,
    },
    #[error("a {interpolation} track with {keyframes} keyframes and {targets} targets needs {expected} output values, but has {values}")]
    TrackValueCount {
        interpolation: &'static str,
        keyframes: usize,
        targets: usize,
        expected: usize,
        values: usize,
    },
    #[error("two-pose weight {index} is not finite")]
    WeightNotFinite { index: usize },
    #[error("weight track output value {index} is not finite")]
    TrackValue { index: usize },
    #[error("{attribute} has {count} values for {vertices} vertices: give one per vertex")]
    AttributeCount {
        attribute: &'static str,
        count: usize,
        vertices: usize,
    },
    #[error("{attribute} of vertex {vertex} is not finite: fix the source file")]
    AttributeNotFinite {
        attribute: &'static str,
        vertex: usize,
    },
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error("the skin: {0}")]
    Skin(#[from] SkinError),
}

/// Whether `a` and `b` share their connectivity, as [`Morph::from_meshes`]
/// requires: the same vertex count and the same triangle list (same order,
/// same orientation; a triangle may start at another corner). The error says
/// what differs first.
pub fn same_connectivity(a: &IndexedMesh, b: &IndexedMesh) -> Result<(), MorphError> {
    if a.positions.len() != b.positions.len() {
        return Err(MorphError::PoseSizeMismatch {
            a: a.positions.len(),
            b: b.positions.len(),
        });
    }
    if a.triangles.len() != b.triangles.len() {
        return Err(MorphError::TriangleCountMismatch {
            a: a.triangles.len(),
            b: b.triangles.len(),
        });
    }
    match a
        .triangles
        .iter()
        .zip(&b.triangles)
        .position(|(&[p, q, r], &y)| y != [p, q, r] && y != [q, r, p] && y != [r, p, q])
    {
        Some(index) => Err(MorphError::TriangleMismatch {
            index,
            a: a.triangles[index],
            b: b.triangles[index],
        }),
        None => Ok(()),
    }
}

impl Morph {
    /// The general validated constructor: a base pose, targets and their weights.
    pub fn from_parts(
        triangles: Vec<[u32; 3]>,
        base: Vec<[f32; 3]>,
        targets: Vec<MorphTarget>,
        weights: Weights,
    ) -> Result<Morph, MorphError> {
        let n = base.len();
        if triangles.is_empty() {
            return Err(MorphError::Empty { vertices: n });
        }
        check_triangles(&triangles, n)?;
        check_finite("base pose", &base)?;
        for target in &targets {
            if target.deltas.len() != n {
                return Err(MorphError::TargetSize {
                    target: target.name.clone(),
                    deltas: target.deltas.len(),
                    vertices: n,
                });
            }
            check_finite(&format!("morph target '{}'", target.name), &target.deltas)?;
            if let Some(normals) = &target.normal_deltas {
                if normals.len() != n {
                    return Err(MorphError::TargetSize {
                        target: format!("{} (NORMAL)", target.name),
                        deltas: normals.len(),
                        vertices: n,
                    });
                }
                check_finite(
                    &format!("normal deltas of morph target '{}'", target.name),
                    normals,
                )?;
            }
        }
        let weight_counts = match &weights {
            Weights::TwoPose { w0, w1 } => {
                if let Some(bad) = w0.iter().chain(w1).position(|w| !w.is_finite()) {
                    return Err(MorphError::WeightNotFinite { index: bad });
                }
                [w0.len(), w1.len()]
            }
            Weights::Animated(track) => [track.targets(), track.targets()],
        };
        if let Some(&bad) = weight_counts.iter().find(|&&c| c != targets.len()) {
            return Err(MorphError::WeightCount {
                weights: bad,
                targets: targets.len(),
            });
        }
        Ok(Morph {
            triangles,
            base,
            targets,
            weights,
            attributes: Attributes::default(),
            end_pose: None,
            skinning: None,
        })
    }

    /// The same morph with these vertex attributes (one value per vertex each), checked.
    pub fn with_attributes(mut self, attributes: Attributes) -> Result<Morph, MorphError> {
        attributes.validate(self.vertex_count())?;
        self.attributes = attributes;
        Ok(self)
    }

    /// `V(t) = (1 − t) v0 + t v1` over one triangulation. Stored as base `v0`
    /// plus one target `v1 − v0`, and `v1` itself: `v0()` and `v1()` return the two poses
    /// bit for bit (a supermesh keeps every input vertex exactly); in between, `V(t)` is
    /// `v0 + t (v1 − v0)`.
    pub fn from_poses(
        triangles: Vec<[u32; 3]>,
        v0: Vec<[f32; 3]>,
        v1: Vec<[f32; 3]>,
    ) -> Result<Morph, MorphError> {
        if v0.len() != v1.len() {
            return Err(MorphError::PoseSizeMismatch {
                a: v0.len(),
                b: v1.len(),
            });
        }
        check_finite("pose V(1)", &v1)?;
        let deltas: Vec<[f32; 3]> = v0
            .iter()
            .zip(&v1)
            .map(|(a, b)| [b[0] - a[0], b[1] - a[1], b[2] - a[2]])
            .collect();
        let target = MorphTarget {
            name: "V(1)".to_string(),
            deltas,
            normal_deltas: None,
        };
        let weights = Weights::TwoPose {
            w0: vec![0.0],
            w1: vec![1.0],
        };
        let mut morph = Morph::from_parts(triangles, v0, vec![target], weights)?;
        morph.end_pose = Some(v1);
        Ok(morph)
    }

    /// A two-pose morph from two meshes with the same connectivity: same vertex
    /// count and the same triangle list (same order, same orientation; a
    /// triangle may start at another corner, `[1, 2, 0]` for `[0, 1, 2]`).
    /// The triangles of `a` are used; `b` gives the pose `V(1)`.
    pub fn from_meshes(a: &IndexedMesh, b: &IndexedMesh) -> Result<Morph, MorphError> {
        same_connectivity(a, b)?;
        Morph::from_poses(
            a.triangles.clone(),
            a.positions.clone(),
            b.positions.clone(),
        )
    }

    /// The same morph on a subset of the vertices, renumbered: new vertex `i` is
    /// old vertex `vertex_map[i]`, and `triangles` index the new vertices. This
    /// applies one cleaning result (computed once, e.g. on `V(0)`) identically to
    /// the base and every target, so all poses keep one connectivity.
    pub fn select(
        &self,
        vertex_map: &[u32],
        triangles: Vec<[u32; 3]>,
    ) -> Result<Morph, MorphError> {
        let n = self.base.len();
        if let Some((position, &index)) = vertex_map
            .iter()
            .enumerate()
            .find(|(_, &v)| v as usize >= n)
        {
            return Err(MorphError::VertexMapOutOfRange {
                position,
                index,
                vertices: n,
            });
        }
        fn gather<T: Copy>(values: &[T], vertex_map: &[u32]) -> Vec<T> {
            vertex_map.iter().map(|&v| values[v as usize]).collect()
        }
        let targets = self
            .targets
            .iter()
            .map(|t| MorphTarget {
                name: t.name.clone(),
                deltas: gather(&t.deltas, vertex_map),
                normal_deltas: t.normal_deltas.as_ref().map(|d| gather(d, vertex_map)),
            })
            .collect();
        let a = &self.attributes;
        let attributes = Attributes {
            normals: a.normals.as_ref().map(|v| gather(v, vertex_map)),
            uvs: a.uvs.as_ref().map(|v| gather(v, vertex_map)),
            colors: a.colors.as_ref().map(|v| gather(v, vertex_map)),
            material: a.material.clone(),
        };
        let mut morph = Morph::from_parts(
            triangles,
            gather(&self.base, vertex_map),
            targets,
            self.weights.clone(),
        )?
        .with_attributes(attributes)?;
        morph.end_pose = self.end_pose.as_ref().map(|v| gather(v, vertex_map));
        morph.skinning = self.skinning.as_ref().map(|s| {
            Box::new(Skinning {
                skin: s.skin.select(vertex_map),
                clip: s.clip.clone(),
            })
        });
        Ok(morph)
    }

    /// Cleans the morph ([`crate::mesh::clean`]) once on `V(0)` and applies the
    /// result to every pose and attribute through [`Morph::select`], so all poses keep one
    /// connectivity. Welding (asked for, or of a triangle soup) merges only
    /// vertices that coincide in `V(0)` and in every target's offsets, that is
    /// in every pose (a copy that moves apart in some pose is kept apart), and that
    /// have equal attributes (normals, normal deltas, UVs, colours) and, for a skinned morph,
    /// equal joints and weights: the copies of a position on either side of a seam stay
    /// apart.
    pub fn clean(&self, options: &CleanOptions) -> Result<(Morph, CleanReport), MorphError> {
        let base = IndexedMesh::new(self.v0(), self.triangles.clone());
        // Welding compares per-vertex triples bit for bit: a UV (u, v) is compared as
        // (u, v, 0) and a colour (r, g, b, a) as (r, g, b) and (a, 0, 0).
        let a = &self.attributes;
        let uvs = a
            .uvs
            .as_ref()
            .map(|uvs| uvs.iter().map(|&[u, v]| [u, v, 0.0]).collect::<Vec<_>>());
        let colors = a.colors.as_ref().map(|colors| {
            let rgb: Vec<[f32; 3]> = colors.iter().map(|&[r, g, b, _]| [r, g, b]).collect();
            let alpha: Vec<[f32; 3]> = colors.iter().map(|&[.., a]| [a, 0.0, 0.0]).collect();
            [rgb, alpha]
        });
        let skin = self.skin_triples();
        let also: Vec<&[[f32; 3]]> = self
            .targets
            .iter()
            .flat_map(|t| std::iter::once(&t.deltas).chain(&t.normal_deltas))
            .chain(&a.normals)
            .chain(&uvs)
            .chain(colors.iter().flatten())
            .chain(&skin)
            .map(Vec::as_slice)
            .collect();
        let cleaned = clean_poses(&base, &also, options)?;
        let morph = self.select(&cleaned.vertex_map, cleaned.mesh.triangles)?;
        Ok((morph, cleaned.report))
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    pub fn base(&self) -> &[[f32; 3]] {
        &self.base
    }

    pub fn targets(&self) -> &[MorphTarget] {
        &self.targets
    }

    pub fn weights(&self) -> &Weights {
        &self.weights
    }

    /// The vertex attributes and material (empty for position-only sources).
    pub fn attributes(&self) -> &Attributes {
        &self.attributes
    }

    pub fn vertex_count(&self) -> usize {
        self.base.len()
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// True when `V(t)` is exactly the linear blend of `V(0)` and `V(1)`, i.e. the
    /// GPU's two-pose blend reproduces it at every `t` (never for a skinned morph).
    pub fn is_linear(&self) -> bool {
        matches!(self.weights, Weights::TwoPose { .. }) && self.skinning.is_none()
    }

    /// The target weights at `t` (clamped to `[0, 1]`; NaN reads as 0).
    pub fn weights_at(&self, t: f32) -> Vec<f32> {
        let mut out = Vec::new();
        self.weights_at_into(t, &mut out);
        out
    }

    fn weights_at_into(&self, t: f32, out: &mut Vec<f32>) {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        match &self.weights {
            Weights::TwoPose { w0, w1 } => {
                out.clear();
                out.extend(w0.iter().zip(w1).map(|(&a, &b)| a + (b - a) * t));
            }
            Weights::Animated(track) => track.sample_into(t * track.duration(), out),
        }
    }

    /// The positions `V(t)`: for a skinned morph the skinned pose ([`Morph::skinning`]).
    pub fn positions_at(&self, t: f32) -> Vec<[f32; 3]> {
        let mut out = Vec::new();
        self.positions_at_into(t, &mut out);
        out
    }

    /// The positions `V(t)` into `out` (resized to the vertex count), so frame
    /// loops reuse one allocation.
    pub fn positions_at_into(&self, t: f32, out: &mut Vec<[f32; 3]>) {
        match &self.skinning {
            None => self.morphed_at_into(t, out),
            Some(skinning) => {
                let mut bind = Vec::with_capacity(self.base.len());
                self.morphed_at_into(t, &mut bind);
                let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
                *out = skinning.pose_at(&bind, t * skinning.clip.duration);
            }
        }
    }

    /// The morphed positions `base + Σ w_i(t) D_i` (for a two-pose morph, `V(1)` as given at
    /// `t ≥ 1`), before any skinning: the bind-space pose of a skinned morph, `V(t)` of any
    /// other.
    pub fn morphed_at(&self, t: f32) -> Vec<[f32; 3]> {
        let mut out = Vec::new();
        self.morphed_at_into(t, &mut out);
        out
    }

    fn morphed_at_into(&self, t: f32, out: &mut Vec<[f32; 3]>) {
        if let (Some(end), true) = (&self.end_pose, t >= 1.0) {
            out.clear();
            out.extend_from_slice(end);
            return;
        }
        let mut weights = Vec::with_capacity(self.targets.len());
        self.weights_at_into(t, &mut weights);
        out.clear();
        out.extend_from_slice(&self.base);
        for (target, &w) in self.targets.iter().zip(&weights) {
            // Animations hold most targets at 0 most of the time: skipping them
            // also keeps base + 0·D bit-identical to the base.
            if w == 0.0 {
                continue;
            }
            for (p, d) in out.iter_mut().zip(&target.deltas) {
                p[0] += w * d[0];
                p[1] += w * d[1];
                p[2] += w * d[2];
            }
        }
    }

    /// `V(0)`, the first pose the GPU runtime stores (for a skinned morph the bind-space
    /// pose, [`morphed_at`](Self::morphed_at)).
    pub fn v0(&self) -> Vec<[f32; 3]> {
        self.morphed_at(0.0)
    }

    /// `V(1)`, the second pose the GPU runtime stores (bind space, as `V(0)`).
    pub fn v1(&self) -> Vec<[f32; 3]> {
        self.morphed_at(1.0)
    }

    /// What the GPU needs besides `V(0)` and `V(1)` to draw this morph exactly: `None` for a
    /// two-pose morph (the linear blend is exact), otherwise the targets that the animation
    /// drives (nonzero weight at some key) with its track restricted to them.
    pub fn target_blend(&self) -> Option<TargetBlend> {
        let Weights::Animated(track) = &self.weights else {
            return None;
        };
        let driven: Vec<usize> = (0..self.targets.len())
            .filter(|&k| track.drives(k))
            .collect();
        Some(TargetBlend {
            deltas: driven
                .iter()
                .map(|&k| self.targets[k].deltas.clone())
                .collect(),
            track: track.select(&driven),
        })
    }
}

/// The morph targets of a weight animation, for drawing it on the GPU: the drawn position at
/// `t` is `V(0) + Σ_k c_k(t) D_k` with `c_k(t) = w_k(t) − w_k(0)` ([`WeightTrack::offsets_at`]),
/// which equals `base + Σ_k w_k(t) D_k` because `V(0) = base + Σ_k w_k(0) D_k`. Storing the
/// offsets from `V(0)` rather than the base keeps `V(0)` the pose every other part of the
/// runtime (bounds, cameras, the two-pose blend) already knows.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetBlend {
    /// Per target, one delta per vertex.
    pub deltas: Vec<Vec<[f32; 3]>>,
    /// The weights of these targets (one track column per entry of `deltas`), played over
    /// `t ∈ [0, 1]` as `track(t · duration)`.
    pub track: WeightTrack,
}

fn check_triangles(triangles: &[[u32; 3]], vertices: usize) -> Result<(), MorphError> {
    for (t, tri) in triangles.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertices) {
            return Err(MorphError::IndexOutOfRange {
                triangle: t,
                index,
                vertices,
            });
        }
    }
    Ok(())
}

fn check_finite(pose: &str, values: &[[f32; 3]]) -> Result<(), MorphError> {
    match values.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(vertex) => Err(MorphError::NonFinite {
            pose: pose.to_string(),
            vertex,
            value: values[vertex],
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f32) -> IndexedMesh {
        IndexedMesh::new(
            vec![[0.0, 0.0, z], [1.0, 0.0, z], [1.0, 1.0, z], [0.0, 1.0, z]],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn from_meshes_blends_and_reports_mismatches() {
        let morph = Morph::from_meshes(&quad(0.0), &quad(2.0)).unwrap();
        assert_eq!(morph.positions_at(0.25)[2], [1.0, 1.0, 0.5]);
        assert_eq!(morph.v1(), quad(2.0).positions);

        let mut flipped = quad(2.0);
        flipped.triangles[1] = [0, 3, 2];
        let err = Morph::from_meshes(&quad(0.0), &flipped).unwrap_err();
        assert!(matches!(
            err,
            MorphError::TriangleMismatch {
                index: 1,
                a: [0, 2, 3],
                b: [0, 3, 2]
            }
        ));
        assert!(err
            .to_string()
            .contains("triangle 1: [0, 2, 3] versus [0, 3, 2]"));

        let mut fewer = quad(2.0);
        fewer.positions.pop();
        fewer.triangles.pop();
        assert!(matches!(
            Morph::from_meshes(&quad(0.0), &fewer),
            Err(MorphError::PoseSizeMismatch { a: 4, b: 3 })
        ));
        let mut one_triangle = quad(2.0);
        one_triangle.triangles.pop();
        assert!(matches!(
            Morph::from_meshes(&quad(0.0), &one_triangle),
            Err(MorphError::TriangleCountMismatch { a: 2, b: 1 })
        ));
    }

    /// `[0, 1, 2]` and `[1, 2, 0]` are one triangle (same corners, same orientation):
    /// meshes differing only in each triangle's starting corner are one connectivity,
    /// and the first mesh's triangles are used. The reverse `[0, 2, 1]` is not.
    #[test]
    fn from_meshes_accepts_rotated_triangles() {
        let mut rotated = quad(2.0);
        rotated.triangles = rotated
            .triangles
            .iter()
            .map(|&[a, b, c]| [b, c, a])
            .collect();
        let morph = Morph::from_meshes(&quad(0.0), &rotated).unwrap();
        assert_eq!(morph.triangles(), &quad(0.0).triangles[..]);
        assert_eq!(morph.v1(), rotated.positions);
        rotated.triangles[1] = [0, 3, 2];
        assert!(matches!(
            Morph::from_meshes(&quad(0.0), &rotated),
            Err(MorphError::TriangleMismatch { index: 1, .. })
        ));
    }

    /// `from_poses` keeps both poses bit for bit, also where `v0 + (v1 − v0)` rounds away
    /// from `v1` (here 1e8 + (0.1 − 1e8) = 0 in f32), and `select` carries the end pose along.
    #[test]
    fn from_poses_keeps_v1_bit_for_bit() {
        let v0 = vec![[1e8, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let v1 = vec![[0.1, 0.0, 0.0], [0.0, 1.0, 0.5], [0.0, 0.25, 1.0]];
        let d = v1[0][0] - v0[0][0];
        assert_ne!(v0[0][0] + d, v1[0][0], "the case rounding loses");
        let morph = Morph::from_poses(vec![[0, 1, 2]], v0.clone(), v1.clone()).unwrap();
        assert_eq!(morph.v0(), v0);
        assert_eq!(morph.v1(), v1);
        assert_eq!(morph.positions_at(2.0), v1, "t is clamped to 1");
        let kept = morph.select(&[2, 0, 1], vec![[1, 2, 0]]).unwrap();
        assert_eq!(kept.v1(), vec![v1[2], v1[0], v1[1]]);
    }

    #[test]
    fn select_applies_one_mapping_to_every_pose() {
        let morph = Morph::from_meshes(&quad(0.0), &quad(2.0)).unwrap();
        // Keep vertices 2, 0, 3 (renumbered 0, 1, 2) and the triangle (0, 2, 3).
        let kept = morph.select(&[2, 0, 3], vec![[1, 0, 2]]).unwrap();
        assert_eq!(
            kept.v0(),
            vec![[1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        );
        assert_eq!(
            kept.v1(),
            vec![[1.0, 1.0, 2.0], [0.0, 0.0, 2.0], [0.0, 1.0, 2.0]]
        );
        assert!(matches!(
            morph.select(&[0, 9], vec![[0, 1, 1]]),
            Err(MorphError::VertexMapOutOfRange {
                position: 1,
                index: 9,
                vertices: 4
            })
        ));
        assert!(matches!(
            morph.select(&[0, 1], vec![[0, 1, 2]]),
            Err(MorphError::IndexOutOfRange {
                triangle: 0,
                index: 2,
                vertices: 2
            })
        ));
    }
    #[test]
    fn from_parts_checks_lengths() {
        let base = quad(0.0).positions;
        let short = MorphTarget {
            name: "short".to_string(),
            deltas: vec![[0.0; 3]; 3],
            normal_deltas: None,
        };
        let err = Morph::from_parts(
            vec![[0, 1, 2]],
            base.clone(),
            vec![short],
            Weights::TwoPose {
                w0: vec![0.0],
                w1: vec![1.0],
            },
        )
        .unwrap_err();
        assert!(
            err.to_string()
                .contains("'short' has 3 deltas for 4 vertices"),
            "{err}"
        );
        let err = Morph::from_parts(
            vec![[0, 1, 2]],
            base,
            vec![],
            Weights::TwoPose {
                w0: vec![0.0],
                w1: vec![],
            },
        )
        .unwrap_err();
        assert!(matches!(
            err,
            MorphError::WeightCount {
                weights: 1,
                targets: 0
            }
        ));
    }
}
