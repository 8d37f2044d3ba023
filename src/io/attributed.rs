//! Meshes with their vertex attributes: what [`load_attributed`](super::load_attributed) reads
//! from any format, and the two-mesh morph made from a pair of them ([`morph_from_pair`]).
//!
//! Formats index attributes differently: glTF and PLY give one normal and UV per vertex,
//! OBJ gives every face corner its own `v/vt/vn` triple. An [`AttributedMesh`] holds both
//! views: the file's positions as [`load_mesh`](super::load_mesh) returns them, and the
//! *attribute vertices* the GPU draws, one per distinct corner triple, each naming its
//! position, so a position is split exactly where its corners' attributes differ (a seam).

use crate::mesh::IndexedMesh;
use crate::morph::{Attributes, Morph, MorphError, MorphTarget};
use std::collections::HashMap;

/// A mesh as the file stores it, in two indexings (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct AttributedMesh {
    /// One vertex per position of the file, as [`super::load_mesh`] returns it.
    pub positions: IndexedMesh,
    /// Per attribute vertex, its vertex in `positions`.
    pub position_of: Vec<u32>,
    /// The triangles of `positions` (same order, same corners), over attribute vertices.
    pub triangles: Vec<[u32; 3]>,
    /// One value per attribute vertex where present.
    pub attributes: Attributes,
}

impl AttributedMesh {
    /// A mesh whose vertices are its attribute vertices (glTF, PLY, OFF, an OBJ without
    /// `vt`/`vn`).
    pub(super) fn unsplit(positions: IndexedMesh, attributes: Attributes) -> AttributedMesh {
        AttributedMesh {
            position_of: (0..positions.vertex_count() as u32).collect(),
            triangles: positions.triangles.clone(),
            positions,
            attributes,
        }
    }

    /// The mesh over attribute vertices: what the GPU draws.
    pub fn mesh(&self) -> IndexedMesh {
        IndexedMesh::new(
            self.position_of
                .iter()
                .map(|&p| self.positions.positions[p as usize])
                .collect(),
            self.triangles.clone(),
        )
    }

    /// A position-only morph over the attribute vertices with these attributes (no
    /// targets): what [`Morph::topology`] and [`Morph::normals`] need to describe a single
    /// mesh.
    pub fn to_static_morph(&self) -> Result<Morph, MorphError> {
        let mesh = self.mesh();
        let weights = crate::morph::Weights::TwoPose {
            w0: Vec::new(),
            w1: Vec::new(),
        };
        Morph::from_parts(mesh.triangles, mesh.positions, Vec::new(), weights)?
            .with_attributes(self.attributes.clone())
    }
}

/// The linear value of an sRGB-encoded colour channel in `[0, 1]` (the sRGB transfer
/// function, IEC 61966-2-1): OBJ and PLY vertex colours are display values, glTF's COLOR_0
/// and [`Attributes::colors`] are linear.
pub(super) fn srgb_to_linear(encoded: f32) -> f32 {
    if encoded <= 0.04045 {
        encoded / 12.92
    } else {
        ((encoded + 0.055) / 1.055).powf(2.4)
    }
}

/// The two-pose morph from `a` to `b` for meshes of one connectivity (checked on their
/// positions as [`Morph::from_meshes`] does; its errors say when they differ). The morph
/// has `a`'s attribute vertices and attributes, each vertex moving to its position in `b`;
/// where both meshes have normals, `b`'s minus `a`'s are the target's normal deltas (an
/// attribute vertex takes `b`'s normal at its first corner).
pub fn morph_from_pair(a: &AttributedMesh, b: &AttributedMesh) -> Result<Morph, MorphError> {
    let by_position = Morph::from_meshes(&a.positions, &b.positions)?;
    let split = by_position.select(&a.position_of, a.triangles.clone())?;
    let normal_deltas = match (&a.attributes.normals, &b.attributes.normals) {
        (Some(na), Some(nb)) => Some(normal_deltas(a, b, na, nb)),
        _ => None,
    };
    let target = MorphTarget {
        normal_deltas,
        ..split.targets()[0].clone()
    };
    Morph::from_parts(
        split.triangles().to_vec(),
        split.base().to_vec(),
        vec![target],
        split.weights().clone(),
    )?
    .with_attributes(a.attributes.clone())
}

/// Per attribute vertex of `a`, `b`'s normal at the matching corner minus `a`'s. Triangles
/// correspond in order; `b`'s may start at another corner (`Morph::from_meshes` accepts
/// rotations), so each is aligned on its positions first.
fn normal_deltas(
    a: &AttributedMesh,
    b: &AttributedMesh,
    na: &[[f32; 3]],
    nb: &[[f32; 3]],
) -> Vec<[f32; 3]> {
    let mut out: Vec<Option<[f32; 3]>> = vec![None; na.len()];
    let position = |mesh: &AttributedMesh, v: u32| mesh.position_of[v as usize];
    for (ta, tb) in a.triangles.iter().zip(&b.triangles) {
        let first = position(a, ta[0]);
        let shift = (0..3).find(|&j| position(b, tb[j]) == first).unwrap_or(0);
        for k in 0..3 {
            let (va, vb) = (ta[k] as usize, tb[(k + shift) % 3] as usize);
            if out[va].is_none() {
                let (p, q) = (na[va], nb[vb]);
                out[va] = Some([q[0] - p[0], q[1] - p[1], q[2] - p[2]]);
            }
        }
    }
    // A vertex no triangle uses keeps its normal.
    out.into_iter().map(|d| d.unwrap_or([0.0; 3])).collect()
}

/// Attribute vertices from per-corner keys: `corners[i]` is the (position, attribute key)
/// of corner `i` (three per triangle); equal pairs share a vertex. Vertices are numbered by
/// position, then by first appearance, so an unsplit file keeps its vertex order. Returns
/// per vertex its position and its key, and the triangles over the vertices.
pub(super) fn split_corners<K: Copy + Eq + std::hash::Hash>(
    corners: &[(u32, K)],
) -> (Vec<(u32, K)>, Vec<[u32; 3]>) {
    let mut first: HashMap<(u32, K), u32> = HashMap::with_capacity(corners.len());
    let mut vertices: Vec<(u32, K)> = Vec::new();
    let first_ids: Vec<u32> = corners
        .iter()
        .map(|&corner| {
            *first.entry(corner).or_insert_with(|| {
                vertices.push(corner);
                vertices.len() as u32 - 1
            })
        })
        .collect();
    // Stable: ties (one position, several keys) keep their order of first appearance.
    let mut order: Vec<u32> = (0..vertices.len() as u32).collect();
    order.sort_by_key(|&v| vertices[v as usize].0);
    let mut renumber = vec![0u32; vertices.len()];
    for (new, &old) in order.iter().enumerate() {
        renumber[old as usize] = new as u32;
    }
    let triangles = first_ids
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]].map(|v| renumber[v as usize]))
        .collect();
    let vertices = order.iter().map(|&v| vertices[v as usize]).collect();
    (vertices, triangles)
}

/// What `morphlod info` reports about a morph's appearance: its attributes, material and
/// texture, and how its attribute vertices weld into topology vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct AttributeSummary {
    /// Attribute vertices (what the GPU draws).
    pub vertices: usize,
    /// Topology vertices ([`Morph::topology`]): the welded surface the simplifier works on.
    pub topology_vertices: usize,
    /// Topology vertices with more than one attribute vertex.
    pub seam_vertices: usize,
    /// Whether the source gave normals (otherwise they are computed).
    pub normals: bool,
    pub uvs: bool,
    pub colors: bool,
    pub material: Option<String>,
    pub base_color: [f32; 4],
    pub texture: Option<TextureSummary>,
    pub targets: usize,
    /// Targets whose NORMAL deltas the source gave (the others' are computed).
    pub targets_with_normal_deltas: usize,
}

#[derive(Clone, Debug, PartialEq)]
pub struct TextureSummary {
    pub format: crate::morph::ImageFormat,
    pub bytes: usize,
    /// Width and height from the image header ([`super::image_size`]).
    pub size: Option<(u32, u32)>,
    pub sampler: crate::morph::Sampler,
}

impl AttributeSummary {
    pub fn of(morph: &Morph) -> AttributeSummary {
        let topology = morph.topology();
        let a = morph.attributes();
        AttributeSummary {
            vertices: morph.vertex_count(),
            topology_vertices: topology.topology_count,
            seam_vertices: topology.seam_vertices(),
            normals: a.normals.is_some(),
            uvs: a.uvs.is_some(),
            colors: a.colors.is_some(),
            material: a.material.name.clone(),
            base_color: a.material.base_color,
            texture: a.material.texture.as_ref().map(|t| TextureSummary {
                format: t.format,
                bytes: t.bytes.len(),
                size: super::image_size(&t.bytes).ok().map(|(_, w, h)| (w, h)),
                sampler: t.sampler,
            }),
            targets: morph.targets().len(),
            targets_with_normal_deltas: morph
                .targets()
                .iter()
                .filter(|t| t.normal_deltas.is_some())
                .count(),
        }
    }
}

impl std::fmt::Display for AttributeSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let given = |present: bool| if present { "given" } else { "none" };
        writeln!(
            f,
            "  vertices          {} attribute vertices on {} topology vertices ({} seam vertices)",
            self.vertices, self.topology_vertices, self.seam_vertices
        )?;
        let normals = if self.normals {
            "given"
        } else {
            "none in the file: computed (area-weighted over the welded surface)"
        };
        writeln!(f, "  normals           {normals}")?;
        writeln!(f, "  uvs               {}", given(self.uvs))?;
        writeln!(f, "  colours           {}", given(self.colors))?;
        let name = self
            .material
            .as_ref()
            .map_or("(unnamed)".to_string(), |n| format!("'{n}'"));
        writeln!(
            f,
            "  material          {name}, base colour {:?}",
            self.base_color
        )?;
        match &self.texture {
            None => writeln!(f, "  texture           none")?,
            Some(t) => {
                let size = t
                    .size
                    .map_or(String::new(), |(w, h)| format!(", {w} x {h} pixels"));
                let filter = |f: Option<u32>| f.map_or("default".to_string(), |f| f.to_string());
                writeln!(
                    f,
                    "  texture           {}, {} bytes{size}; sampler mag {} min {} wrap {}/{}",
                    t.format.mime_type(),
                    t.bytes,
                    filter(t.sampler.mag_filter),
                    filter(t.sampler.min_filter),
                    t.sampler.wrap_s,
                    t.sampler.wrap_t
                )?;
            }
        }
        if self.targets > 0 {
            let computed = match self.targets - self.targets_with_normal_deltas {
                0 => "",
                _ => " (the others computed)",
            };
            writeln!(
                f,
                "  normal deltas     given for {} of {} targets{computed}",
                self.targets_with_normal_deltas, self.targets
            )?;
        }
        Ok(())
    }
}
