//! Appearance attributes of a morph's vertices, and the welded surface under them.
//!
//! A character made in a DCC tool splits a vertex wherever an attribute is discontinuous (a UV
//! seam, a hard normal): glTF's *attribute vertices*. The morph keeps those vertices (the GPU
//! draws them, with one index buffer over one vertex buffer), and [`TopologyMap`] welds the
//! ones that coincide in every pose into *topology vertices*, the surface the simplifier works
//! on. A topology vertex with more than one attribute vertex is a *seam vertex*.
//!
//! A morph without attributes has no seams: every vertex is its own topology vertex, whatever
//! the positions, so position-only meshes simplify exactly as they always did.

use super::{Morph, MorphError};

/// Per-vertex appearance attributes, one entry per (attribute) vertex where present.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Attributes {
    /// Normals of the base pose (glTF NORMAL, OBJ `vn`, PLY `nx ny nz`). Unit length in the
    /// source; stored as given. `None`: computed ([`Morph::normals`]).
    pub normals: Option<Vec<[f32; 3]>>,
    /// Texture coordinates (glTF TEXCOORD_0: origin at the image's top-left corner, `v` down;
    /// loaders of formats with `v` up flip it to this convention).
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Vertex colours (glTF COLOR_0), linear RGBA in `[0, 1]`; RGB sources get alpha 1.
    pub colors: Option<Vec<[f32; 4]>>,
    /// The material of the mesh (one per morph).
    pub material: Material,
}

/// The surface's material: glTF's `pbrMetallicRoughness` base colour, which is what morphlod
/// draws (factor times texture times vertex colour).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: Option<String>,
    /// Linear RGBA base colour factor; glTF's default is opaque white.
    pub base_color: [f32; 4],
    pub texture: Option<Texture>,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: None,
            base_color: [1.0; 4],
            texture: None,
        }
    }
}

/// A base-colour texture: the encoded image as the source stored it (decoded by the renderer,
/// re-embedded as is by writers) and its sampler.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub format: ImageFormat,
    pub bytes: Vec<u8>,
    pub sampler: Sampler,
}

/// Encodings a texture may have (the two glTF core allows).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Jpeg,
}

impl ImageFormat {
    /// The MIME type glTF names it by.
    pub fn mime_type(self) -> &'static str {
        match self {
            ImageFormat::Png => "image/png",
            ImageFormat::Jpeg => "image/jpeg",
        }
    }
}

/// Texture sampling as glTF's sampler object states it, with glTF's enum codes (`9728`
/// NEAREST, `9729` LINEAR, `9984..=9987` the mipmap minification filters; `33071`
/// CLAMP_TO_EDGE, `33648` MIRRORED_REPEAT, `10497` REPEAT). `None` filters: the renderer picks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampler {
    pub mag_filter: Option<u32>,
    pub min_filter: Option<u32>,
    pub wrap_s: u32,
    pub wrap_t: u32,
}

impl Default for Sampler {
    fn default() -> Self {
        Sampler {
            mag_filter: None,
            min_filter: None,
            wrap_s: 10497,
            wrap_t: 10497,
        }
    }
}

impl Attributes {
    /// True when the source gave any per-vertex attribute (normals, UVs or colours).
    pub fn has_vertex_attributes(&self) -> bool {
        self.normals.is_some() || self.uvs.is_some() || self.colors.is_some()
    }

    /// Checks counts and finiteness against a morph of `vertices` vertices.
    pub(super) fn validate(&self, vertices: usize) -> Result<(), MorphError> {
        fn check<const N: usize>(
            name: &'static str,
            values: &Option<Vec<[f32; N]>>,
            vertices: usize,
        ) -> Result<(), MorphError> {
            let Some(values) = values else {
                return Ok(());
            };
            if values.len() != vertices {
                return Err(MorphError::AttributeCount {
                    attribute: name,
                    count: values.len(),
                    vertices,
                });
            }
            match values.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
                Some(vertex) => Err(MorphError::AttributeNotFinite {
                    attribute: name,
                    vertex,
                }),
                None => Ok(()),
            }
        }
        check("NORMAL", &self.normals, vertices)?;
        check("TEXCOORD_0", &self.uvs, vertices)?;
        check("COLOR_0", &self.colors, vertices)?;
        if !self.material.base_color.iter().all(|c| c.is_finite()) {
            return Err(MorphError::AttributeNotFinite {
                attribute: "baseColorFactor",
                vertex: 0,
            });
        }
        Ok(())
    }
}

/// Which topology vertex each vertex belongs to: vertices whose base positions and target
/// deltas are equal bit for bit (so they coincide in every pose) weld into one, when the morph
/// has vertex attributes; otherwise the identity.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopologyMap {
    /// Per vertex, its topology vertex in `0..topology_count`, numbered in order of first
    /// appearance (so the identity map is `0, 1, 2, …`).
    pub of_vertex: Vec<u32>,
    pub topology_count: usize,
}

impl TopologyMap {
    pub fn identity(vertices: usize) -> TopologyMap {
        TopologyMap {
            of_vertex: (0..vertices as u32).collect(),
            topology_count: vertices,
        }
    }

    pub fn is_identity(&self) -> bool {
        self.topology_count == self.of_vertex.len()
    }

    /// Topology vertices that carry more than one vertex (split at a seam).
    pub fn seam_vertices(&self) -> usize {
        let mut count = vec![0u32; self.topology_count];
        for &t in &self.of_vertex {
            count[t as usize] += 1;
        }
        count.iter().filter(|&&c| c > 1).count()
    }

    /// `triangles` renumbered to topology vertices.
    pub fn triangles(&self, triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
        triangles
            .iter()
            .map(|t| t.map(|v| self.of_vertex[v as usize]))
            .collect()
    }
}

/// Area-weighted vertex normals of `positions` over the welded surface: every triangle adds
/// its unnormalised face normal (length twice its area) to its three topology vertices, and
/// each vertex gets its topology vertex's sum, normalised. A vertex whose sum vanishes gets
/// `+Z`.
pub fn vertex_normals(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    topology: &TopologyMap,
) -> Vec<[f32; 3]> {
    let mut sums = vec![[0.0f64; 3]; topology.topology_count];
    for t in triangles {
        let [a, b, c] = t.map(|v| positions[v as usize].map(f64::from));
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        for &v in t {
            let s = &mut sums[topology.of_vertex[v as usize] as usize];
            s[0] += n[0];
            s[1] += n[1];
            s[2] += n[2];
        }
    }
    topology
        .of_vertex
        .iter()
        .map(|&t| {
            let s = sums[t as usize];
            let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
            if len > 0.0 && len.is_finite() {
                [
                    (s[0] / len) as f32,
                    (s[1] / len) as f32,
                    (s[2] / len) as f32,
                ]
            } else {
                [0.0, 0.0, 1.0]
            }
        })
        .collect()
}

/// The normals of a morph as the renderer blends them: `N(t) = normalize(base + Σ w_k(t) D_k)`
/// (glTF's rule), with computed normals and deltas where the source gave none.
#[derive(Clone, Debug, PartialEq)]
pub struct Normals {
    /// Base normals, one per vertex.
    pub base: Vec<[f32; 3]>,
    /// Per target (in [`Morph::targets`] order), one delta per vertex.
    pub deltas: Vec<Vec<[f32; 3]>>,
}

impl Morph {
    /// The welded surface under the vertices (see the module docs).
    pub fn topology(&self) -> TopologyMap {
        if !self.attributes.has_vertex_attributes() {
            return TopologyMap::identity(self.vertex_count());
        }
        let mut first: std::collections::HashMap<Vec<u32>, u32> =
            std::collections::HashMap::with_capacity(self.vertex_count());
        let mut of_vertex = Vec::with_capacity(self.vertex_count());
        let mut key = Vec::with_capacity(3 * (1 + self.targets.len()));
        for v in 0..self.vertex_count() {
            key.clear();
            key.extend(self.base[v].map(f32::to_bits));
            for target in &self.targets {
                key.extend(target.deltas[v].map(f32::to_bits));
            }
            // Copies bound to other joints part when skinned: they are other vertices.
            if let Some(skin) = self.skinning.as_deref().map(|s| &s.skin) {
                let i = skin.influences;
                key.extend(&skin.joints[v * i..(v + 1) * i]);
                key.extend(skin.weights[v * i..(v + 1) * i].iter().map(|w| w.to_bits()));
            }
            let next = first.len() as u32;
            of_vertex.push(*first.entry(key.clone()).or_insert(next));
        }
        TopologyMap {
            topology_count: first.len(),
            of_vertex,
        }
    }

    /// The base normals and per-target normal deltas: the source's where given; otherwise the
    /// area-weighted normals of the base pose over the welded surface ([`vertex_normals`]),
    /// and for a target without NORMAL deltas the difference between the normals of
    /// `base + D_k` and of the base.
    pub fn normals(&self) -> Normals {
        let topology = self.topology();
        let computed_base = vertex_normals(&self.base, &self.triangles, &topology);
        let base = self
            .attributes
            .normals
            .clone()
            .unwrap_or_else(|| computed_base.clone());
        let deltas = self
            .targets
            .iter()
            .map(|target| match &target.normal_deltas {
                Some(d) => d.clone(),
                None => {
                    let moved: Vec<[f32; 3]> = self
                        .base
                        .iter()
                        .zip(&target.deltas)
                        .map(|(p, d)| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
                        .collect();
                    vertex_normals(&moved, &self.triangles, &topology)
                        .iter()
                        .zip(&computed_base)
                        .map(|(n, b)| [n[0] - b[0], n[1] - b[1], n[2] - b[2]])
                        .collect()
                }
            })
            .collect();
        Normals { base, deltas }
    }

    /// The unit normals `N(t) = normalize(base + Σ w_k(t) D_k)` ([`Morph::normals`]); a vertex
    /// whose sum vanishes gets `+Z`.
    pub fn normals_at(&self, t: f32) -> Vec<[f32; 3]> {
        let normals = self.normals();
        let weights = self.weights_at(t);
        let mut out = normals.base;
        for (deltas, &w) in normals.deltas.iter().zip(&weights) {
            if w == 0.0 {
                continue;
            }
            for (n, d) in out.iter_mut().zip(deltas) {
                n[0] += w * d[0];
                n[1] += w * d[1];
                n[2] += w * d[2];
            }
        }
        for n in &mut out {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            *n = if len > 0.0 && len.is_finite() {
                [n[0] / len, n[1] / len, n[2] / len]
            } else {
                [0.0, 0.0, 1.0]
            };
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::morph::{MorphTarget, Weights};
    use proptest::prelude::*;

    /// A morph whose vertex `v` sits on point `points[v]` of a small set (so some coincide), with
    /// one target that moves point `p` by `lift[p]`, except that `split` vertices get a delta of
    /// their own; random triangles over the vertices.
    fn morph(points: &[usize], split: &[bool], triangles: &[[u32; 3]], with_uvs: bool) -> Morph {
        let n = points.len();
        let at = |p: usize| [p as f32, (p * p % 7) as f32, (p % 3) as f32];
        let base: Vec<[f32; 3]> = points.iter().map(|&p| at(p)).collect();
        let deltas: Vec<[f32; 3]> = points
            .iter()
            .zip(split)
            .enumerate()
            .map(|(v, (&p, &s))| [0.0, 0.0, if s { 10.0 + v as f32 } else { p as f32 * 0.5 }])
            .collect();
        let target = MorphTarget {
            name: "t".into(),
            deltas,
            normal_deltas: None,
        };
        let m = Morph::from_parts(
            triangles.to_vec(),
            base,
            vec![target],
            Weights::TwoPose {
                w0: vec![0.0],
                w1: vec![1.0],
            },
        )
        .unwrap();
        if with_uvs {
            m.with_attributes(Attributes {
                uvs: Some(vec![[0.5, 0.5]; n]),
                ..Default::default()
            })
            .unwrap()
        } else {
            m
        }
    }

    fn case() -> impl Strategy<Value = (Vec<usize>, Vec<bool>, Vec<[u32; 3]>)> {
        (3usize..40).prop_flat_map(|n| {
            (
                prop::collection::vec(0usize..12, n),
                prop::collection::vec(prop::bool::weighted(0.1), n),
                prop::collection::vec(
                    (0..n as u32, 0..n as u32, 0..n as u32)
                        .prop_filter("distinct corners", |(a, b, c)| a != b && b != c && a != c)
                        .prop_map(|(a, b, c)| [a, b, c]),
                    1..30,
                ),
            )
        })
    }

    proptest! {
        /// Vertices weld exactly when their base positions and target deltas are bit-equal,
        /// numbered in order of first appearance; the counts and the renumbered triangles follow.
        #[test]
        fn topology_welds_exactly_the_coinciding_vertices((points, split, tris) in case()) {
            let m = morph(&points, &split, &tris, true);
            let map = m.topology();
            let n = points.len();
            prop_assert_eq!(map.of_vertex.len(), n);
            let same = |a: usize, b: usize| points[a] == points[b] && !split[a] && !split[b];
            for a in 0..n {
                for b in 0..n {
                    prop_assert_eq!(map.of_vertex[a] == map.of_vertex[b], a == b || same(a, b));
                }
            }
            let mut next = 0;
            for &t in &map.of_vertex {
                prop_assert!(t <= next);
                if t == next {
                    next += 1;
                }
            }
            prop_assert_eq!(map.topology_count, next as usize);
            let mut copies = vec![0; map.topology_count];
            for &t in &map.of_vertex {
                copies[t as usize] += 1;
            }
            prop_assert_eq!(map.seam_vertices(), copies.iter().filter(|&&c| c > 1).count());
            let welded = map.triangles(&tris);
            for (w, t) in welded.iter().zip(&tris) {
                prop_assert_eq!(*w, t.map(|v| map.of_vertex[v as usize]));
            }
            // Without vertex attributes nothing welds.
            let plain = morph(&points, &split, &tris, false).topology();
            prop_assert!(plain.is_identity());
            prop_assert_eq!(plain, TopologyMap::identity(n));
        }

        /// Normals are unit length (or +Z where the sum vanishes), equal on copies of one
        /// topology vertex, and do not change when the mesh is scaled.
        #[test]
        fn vertex_normals_are_unit_shared_and_scale_free((points, split, tris) in case()) {
            let m = morph(&points, &split, &tris, true);
            let map = m.topology();
            let normals = vertex_normals(m.base(), &tris, &map);
            for (v, n) in normals.iter().enumerate() {
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                prop_assert!((len - 1.0).abs() < 1e-5, "vertex {v}: {n:?}");
                for (u, o) in normals.iter().enumerate() {
                    if map.of_vertex[u] == map.of_vertex[v] {
                        prop_assert_eq!(n, o);
                    }
                }
            }
            let scaled: Vec<[f32; 3]> = m.base().iter().map(|p| p.map(|c| c * 4.0)).collect();
            for (a, b) in normals.iter().zip(vertex_normals(&scaled, &tris, &map)) {
                for i in 0..3 {
                    prop_assert!((a[i] - b[i]).abs() < 1e-5, "{a:?} vs {b:?}");
                }
            }
        }
    }

    #[test]
    fn a_flat_counter_clockwise_fan_faces_up() {
        let pos = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-1.0, -1.0, 0.0],
        ];
        let tris = [[0, 1, 2], [0, 2, 3], [0, 3, 1]];
        for n in vertex_normals(&pos, &tris, &TopologyMap::identity(4)) {
            assert_eq!(n, [0.0, 0.0, 1.0]);
        }
    }
}
