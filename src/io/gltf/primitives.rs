//! A mesh's triangle primitives read and concatenated: positions, triangles, morph-target
//! POSITION deltas, vertex attributes, and the mesh's default weights.

use super::accessor::triangulate;
use super::attributes::{MeshAttributes, VertexAttributes};
use super::display_name;
use super::document::Document;
use crate::io::LoadError;
use gltf::mesh::Mode;

/// Triangle primitives of one mesh, concatenated: positions, triangles and, for a morph,
/// per-target POSITION deltas and the vertex attributes concatenated the same way.
pub(super) struct Geometry {
    pub(super) positions: Vec<[f32; 3]>,
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) targets: Vec<Vec<[f32; 3]>>,
    /// Empty unless read for a morph.
    pub(super) attributes: VertexAttributes,
}

impl Document {
    /// The mesh's triangle primitives concatenated; with `morph`, also their morph targets'
    /// POSITION deltas and the vertex attributes. A primitive without POSITION is skipped
    /// (glTF: clients "SHOULD skip primitive's rendering").
    pub(super) fn geometry(&self, mesh: &gltf::Mesh, morph: bool) -> Result<Geometry, LoadError> {
        let mut out = Geometry {
            positions: Vec::new(),
            triangles: Vec::new(),
            targets: Vec::new(),
            attributes: VertexAttributes::default(),
        };
        let mut attributes = MeshAttributes::default();
        let mut first = true;
        let mesh_name = display_name(mesh.name(), mesh.index());
        for primitive in mesh.primitives() {
            let element = format!("mesh {mesh_name} primitive {}", primitive.index());
            let mode = primitive.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                return Err(self.unsupported(
                    &element,
                    format!("primitive mode {mode:?} (morphlod needs triangles)"),
                ));
            }
            let Some(position) = primitive.get(&gltf::Semantic::Positions) else {
                continue;
            };
            let positions = self.read_vec3(&position, &format!("{element} POSITION"))?;
            // u32 indices with 0xFFFFFFFF reserved as the strip restart downstream.
            let total = out.positions.len() + positions.len();
            if total >= u32::MAX as usize {
                return Err(self.unsupported(
                    &element,
                    format!("a mesh of {total} vertices (at most 4294967294)"),
                ));
            }
            let offset = out.positions.len() as u32;
            let corners = match primitive.indices() {
                Some(indices) => self.read_indices(&indices, &format!("{element} indices"))?,
                None => (0..positions.len() as u32).collect(),
            };
            if let Some((i, &v)) = corners
                .iter()
                .enumerate()
                .find(|(_, &v)| v as usize >= positions.len())
            {
                return Err(self.data_error(
                    &element,
                    format!(
                        "index {i} is {v}, but POSITION has only {} vertices",
                        positions.len()
                    ),
                ));
            }
            let triangles = triangulate(mode, &corners)
                .map_err(|message| self.data_error(&element, message))?;
            out.triangles.extend(
                triangles
                    .iter()
                    .map(|t| [t[0] + offset, t[1] + offset, t[2] + offset]),
            );
            if morph {
                self.append_targets(
                    &primitive,
                    &element,
                    positions.len(),
                    first,
                    &mut out.targets,
                )?;
                self.append_attributes(&primitive, &element, positions.len(), &mut attributes)?;
            }
            first = false;
            out.positions.extend(positions);
        }
        if morph {
            out.attributes = attributes.finish();
        }
        Ok(out)
    }

    /// Appends one primitive's POSITION deltas to the per-target arrays (`first`: the
    /// first primitive read, which sets the target count). Every primitive of a mesh must
    /// have the same number of targets (glTF §3.7.2.2).
    pub(super) fn append_targets(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
        vertices: usize,
        first: bool,
        targets: &mut Vec<Vec<[f32; 3]>>,
    ) -> Result<(), LoadError> {
        let count = primitive.morph_targets().len();
        if first {
            targets.resize(count, Vec::new());
        } else if count != targets.len() {
            return Err(self.data_error(
                element,
                format!(
                    "has {count} morph targets but the first primitive has {}; all primitives of a mesh need the same targets",
                    targets.len()
                ),
            ));
        }
        for (t, (target, out)) in primitive
            .morph_targets()
            .zip(targets.iter_mut())
            .enumerate()
        {
            let target_element = format!("{element} target {t} POSITION");
            match target.positions() {
                Some(accessor) => {
                    let deltas = self.read_vec3(&accessor, &target_element)?;
                    if deltas.len() != vertices {
                        return Err(self.data_error(
                            &target_element,
                            format!(
                                "has {} deltas but the primitive has {vertices} vertices",
                                deltas.len()
                            ),
                        ));
                    }
                    out.extend(deltas);
                }
                // A target without POSITION moves no vertex of this primitive.
                None => out.extend(std::iter::repeat_n([0.0; 3], vertices)),
            }
        }
        Ok(())
    }

    /// `mesh.weights`, or zeros when absent; its length must match the targets.
    pub(super) fn default_weights(
        &self,
        mesh: &gltf::Mesh,
        targets: usize,
    ) -> Result<Vec<f32>, LoadError> {
        match mesh.weights() {
            None => Ok(vec![0.0; targets]),
            Some(w) if w.len() == targets && w.iter().all(|x| x.is_finite()) => Ok(w.to_vec()),
            Some(w) => Err(self.data_error(
                &format!("mesh {} weights", display_name(mesh.name(), mesh.index())),
                format!(
                    "has {} entries {w:?} for {targets} morph targets; it needs one finite weight per target",
                    w.len()
                ),
            )),
        }
    }
}
