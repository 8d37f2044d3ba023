//! The node tree: the node instancing a mesh, parents, world matrices, and the transforms
//! applied to positions, target deltas and normals.

use super::display_name;
use super::document::Document;
use crate::io::LoadError;
use crate::mesh::IndexedMesh;

impl Document {
    /// The first node instancing `mesh`.
    pub(super) fn instance(&self, mesh: &gltf::Mesh) -> Option<gltf::Node<'_>> {
        self.document
            .nodes()
            .find(|n| n.mesh().map(|m| m.index()) == Some(mesh.index()))
    }

    /// Per node, the node whose `children` hold it.
    pub(super) fn parents(&self) -> Vec<Option<usize>> {
        let mut parents = vec![None; self.document.nodes().len()];
        for node in self.document.nodes() {
            for child in node.children() {
                parents[child.index()] = Some(node.index());
            }
        }
        parents
    }

    /// World matrix of the first node instancing `mesh` (identity when none),
    /// applied to the positions (as points) and target deltas (as vectors).
    pub(super) fn transform(
        &self,
        mesh: &gltf::Mesh,
        out: &mut IndexedMesh,
        deltas: &mut [Vec<[f32; 3]>],
    ) -> Result<(), LoadError> {
        let Some(node) = self.instance(mesh) else {
            return Ok(());
        };
        let matrix = self.world_matrix(node.index());
        for p in &mut out.positions {
            *p = matrix.transform_point3(glam::Vec3::from(*p)).to_array();
        }
        for target in deltas.iter_mut() {
            for d in target.iter_mut() {
                *d = matrix.transform_vector3(glam::Vec3::from(*d)).to_array();
            }
        }
        if matrix.determinant() < 0.0 {
            for t in &mut out.triangles {
                t.swap(1, 2);
            }
        }
        let element = format!("node {} transform", display_name(node.name(), node.index()));
        let bad = out
            .positions
            .iter()
            .chain(deltas.iter().flatten())
            .any(|p| !p.iter().all(|c| c.is_finite()));
        if bad {
            return Err(self.data_error(
                &element,
                "makes a position non-finite (overflow or NaN in the matrix)".to_string(),
            ));
        }
        Ok(())
    }

    /// Applies the transform [`Document::transform`] applied to the positions to the
    /// normals and target normal deltas: the inverse transpose of the world matrix's linear
    /// part, then per vertex the factor that makes the base normal unit length again (applied
    /// to the vertex's deltas too, so `normalize(base + Σ w D)` turns exactly as the surface
    /// does). Without base normals the deltas are scaled by the matrix's mean scale instead.
    pub(super) fn transform_normals(
        &self,
        mesh: &gltf::Mesh,
        normals: Option<&mut Vec<[f32; 3]>>,
        deltas: &mut [Option<Vec<[f32; 3]>>],
    ) -> Result<(), LoadError> {
        let Some(node) = self.instance(mesh) else {
            return Ok(());
        };
        let linear = glam::Mat3::from_mat4(self.world_matrix(node.index()));
        let normal_matrix = linear.inverse().transpose();
        let apply =
            |v: [f32; 3], scale: f32| (normal_matrix * glam::Vec3::from(v) * scale).to_array();
        let vertices = deltas
            .iter()
            .flatten()
            .map(Vec::len)
            .chain(normals.as_ref().map(|n| n.len()))
            .max()
            .unwrap_or(0);
        let finite = |values: &[[f32; 3]]| values.iter().flatten().all(|c| c.is_finite());
        let scales: Vec<f32> = match normals {
            Some(normals) => normals
                .iter_mut()
                .map(|n| {
                    let length = (normal_matrix * glam::Vec3::from(*n)).length();
                    let scale = if length > 0.0 { 1.0 / length } else { 1.0 };
                    *n = apply(*n, scale);
                    scale
                })
                .collect(),
            None => vec![normal_matrix.determinant().abs().cbrt().recip(); vertices],
        };
        let mut all_finite = scales.iter().all(|s| s.is_finite());
        for target in deltas.iter_mut().flatten() {
            for (d, &scale) in target.iter_mut().zip(&scales) {
                *d = apply(*d, scale);
            }
            all_finite &= finite(target);
        }
        if !all_finite || !normal_matrix.is_finite() {
            return Err(self.data_error(
                &format!("node {} transform", display_name(node.name(), node.index())),
                "makes a normal non-finite (a singular matrix, or overflow)".to_string(),
            ));
        }
        Ok(())
    }

    /// `nodes` and all their ancestors, each once, parents before children: by depth, then
    /// in file order (`parents` as [`parents`](Self::parents) gives them).
    pub(super) fn with_ancestors(&self, nodes: &[usize], parents: &[Option<usize>]) -> Vec<usize> {
        let mut kept = std::collections::BTreeSet::new();
        for &node in nodes {
            let mut current = Some(node);
            // `precheck` refused cyclic hierarchies; the bound keeps this walk finite regardless.
            while let (Some(n), true) = (current, kept.len() <= parents.len()) {
                if !kept.insert(n) {
                    break;
                }
                current = parents[n];
            }
        }
        let depth = |mut n: usize| {
            let mut d = 0;
            while let (Some(p), true) = (parents[n], d <= parents.len()) {
                n = p;
                d += 1;
            }
            d
        };
        let mut order: Vec<usize> = kept.into_iter().collect();
        order.sort_by_key(|&n| (depth(n), n));
        order
    }

    pub(super) fn world_matrix(&self, node: usize) -> glam::Mat4 {
        let local = |i: usize| {
            self.document
                .nodes()
                .nth(i)
                .map_or(glam::Mat4::IDENTITY, |n| {
                    glam::Mat4::from_cols_array_2d(&n.transform().matrix())
                })
        };
        let parents = self.parents();
        let mut matrix = local(node);
        let mut current = node;
        // `precheck` refused cyclic hierarchies; the bound keeps this walk finite regardless.
        for _ in 0..self.document.nodes().len() {
            match parents[current] {
                Some(p) => {
                    matrix = local(p) * matrix;
                    current = p;
                }
                None => break,
            }
        }
        matrix
    }
}
