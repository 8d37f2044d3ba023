//! A skinned mesh read as glTF 2.0 has it (§3.7.3): per vertex every JOINTS_n/WEIGHTS_n set
//! (joints UNSIGNED_BYTE or UNSIGNED_SHORT; weights FLOAT or normalized UNSIGNED_BYTE or
//! UNSIGNED_SHORT), the inverse bind matrices (identity where absent), the joints' nodes and
//! their ancestors with their rest transforms, and an animation's channels on them as a
//! [`Clip`]. The skinned mesh node's own transform is not read: the specification ignores it.

use super::display_name;
use super::document::Document;
use crate::io::LoadError;
use crate::skin::{Clip, JointChannel, Renormalized, Skeleton, Skin, SkinError, NO_PARENT, TRS};
use gltf::accessor::{DataType, Dimensions};

/// A skin as [`Document::skin_of`] read it.
pub(super) struct SkinRead {
    pub(super) skin: Skin,
    /// What renormalising the weights changed.
    pub(super) renormalized: Renormalized,
    /// Per skeleton node, its node in the file.
    pub(super) nodes: Vec<usize>,
    /// How messages name the skin (`skin 'name'`).
    pub(super) element: String,
}

impl Document {
    /// The skin of the node instancing `mesh`, when that node has one and every primitive
    /// binds its vertices to it (JOINTS_0 and WEIGHTS_0): the skin with the vertices' joints
    /// and weights (renormalised where their sums are off within the tolerance,
    /// [`Skin::normalize_weights`], what it did returned) and checked; `None` for an unskinned
    /// mesh.
    pub(super) fn skin_of(&self, mesh: &gltf::Mesh) -> Result<Option<SkinRead>, LoadError> {
        let Some(instance) = self.instance(mesh) else {
            return Ok(None);
        };
        let Some(skin) = instance.skin() else {
            return Ok(None);
        };
        let primitives: Vec<gltf::Primitive> = mesh
            .primitives()
            .filter(|p| p.get(&gltf::Semantic::Positions).is_some())
            .collect();
        let binds = |p: &gltf::Primitive| p.get(&gltf::Semantic::Joints(0)).is_some();
        if primitives.is_empty() || !primitives.iter().all(binds) {
            return Ok(None);
        }
        let element = format!("skin {}", display_name(skin.name(), skin.index()));
        let skin_error = |source: SkinError| LoadError::GltfSkin {
            path: self.path.clone(),
            skin: element.clone(),
            source,
        };
        let (skeleton, joint_nodes, nodes) = self.skeleton(&skin, instance.index(), &element)?;
        let (influences, joints, weights) = self.influences(mesh, &primitives)?;
        let mut out = Skin {
            skeleton,
            joint_nodes,
            inverse_binds: self.inverse_binds(&skin)?.unwrap_or_else(|| {
                (0..skin.joints().count())
                    .flat_map(|_| glam::Mat4::IDENTITY.to_cols_array())
                    .collect()
            }),
            influences,
            joints,
            weights,
        };
        let renormalized = out.normalize_weights().map_err(skin_error)?;
        let vertices = out.joints.len() / influences;
        out.validate(vertices).map_err(skin_error)?;
        Ok(Some(SkinRead {
            skin: out,
            renormalized,
            nodes,
            element,
        }))
    }

    /// The skin's inverse bind matrices as the file stores them (FLOAT MAT4, at least one
    /// per joint, finite; 16 floats a joint, extra ones dropped), or `None` when it has none.
    pub(super) fn inverse_binds(&self, skin: &gltf::Skin) -> Result<Option<Vec<f32>>, LoadError> {
        let Some(accessor) = skin.inverse_bind_matrices() else {
            return Ok(None);
        };
        let joints = skin.joints().count();
        let what = format!(
            "skin {} inverseBindMatrices",
            display_name(skin.name(), skin.index())
        );
        if accessor.dimensions() != Dimensions::Mat4 || accessor.data_type() != DataType::F32 {
            return Err(self.data_error(
                &what,
                format!(
                    "is {:?} {:?}; glTF asks for FLOAT MAT4",
                    accessor.data_type(),
                    accessor.dimensions()
                ),
            ));
        }
        if accessor.count() < joints {
            return Err(self.data_error(
                &what,
                format!("has {} matrices for {joints} joints", accessor.count()),
            ));
        }
        // Decoded and checked finite as every float accessor is.
        let mut floats = self.read_floats(&accessor, &what, Dimensions::Mat4)?;
        floats.truncate(16 * joints);
        Ok(Some(floats))
    }

    /// The skeleton of `skin`: its joints and all their ancestors, parents before children
    /// ([`Document::with_ancestors`]), with rest transforms (a matrix decomposed, refused where
    /// no translation, rotation and scale reproduce it); each joint's node in it; and each
    /// of its nodes' index in the file. Every joint must be in the scene that shows the
    /// skinned mesh's node `mesh_node`.
    fn skeleton(
        &self,
        skin: &gltf::Skin,
        mesh_node: usize,
        element: &str,
    ) -> Result<(Skeleton, Vec<u32>, Vec<usize>), LoadError> {
        let parents = self.parents();
        let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        self.check_scene(mesh_node, &joints, &parents, element)?;
        let order = self.with_ancestors(&joints, &parents);
        let mut position = vec![NO_PARENT; parents.len()];
        for (i, &n) in order.iter().enumerate() {
            position[n] = i as u32;
        }
        let nodes: Vec<gltf::Node> = self.document.nodes().collect();
        let mut skeleton = Skeleton::default();
        for &n in &order {
            let node = &nodes[n];
            skeleton
                .parents
                .push(parents[n].map_or(NO_PARENT, |p| position[p]));
            skeleton.rest.extend(self.rest_transform(node)?);
            skeleton.names.push(node.name().unwrap_or("").to_string());
        }
        let joint_nodes = joints.iter().map(|&j| position[j]).collect();
        Ok((skeleton, joint_nodes, order))
    }

    /// A node's local transform as translation, rotation and scale ([`TRS`] floats); a matrix
    /// is decomposed, and refused when the decomposition does not give it back (within `1e-5`
    /// of its largest entry): it shears or projects, which a joint's animation, made of
    /// translations, rotations and scales, cannot.
    fn rest_transform(&self, node: &gltf::Node) -> Result<[f32; TRS], LoadError> {
        let (t, r, s) = match node.transform() {
            gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => (translation, rotation, scale),
            gltf::scene::Transform::Matrix { matrix } => {
                let m = glam::Mat4::from_cols_array_2d(&matrix);
                let (s, r, t) = m.to_scale_rotation_translation();
                let back = glam::Mat4::from_scale_rotation_translation(s, r, t);
                let largest = m.to_cols_array().iter().fold(1.0f32, |a, v| a.max(v.abs()));
                let off = (m - back)
                    .to_cols_array()
                    .iter()
                    .fold(0.0f32, |a, v| a.max(v.abs()));
                if off.is_nan() || off > 1e-5 * largest {
                    return Err(self.data_error(
                        &format!("node {}", display_name(node.name(), node.index())),
                        "is a joint (or a joint's ancestor) whose matrix is no translation, \
                         rotation and scale (it shears or projects): give it as one"
                            .to_string(),
                    ));
                }
                (t.to_array(), r.to_array(), s.to_array())
            }
        };
        let mut out = [0.0; TRS];
        out[..3].copy_from_slice(&t);
        out[3..7].copy_from_slice(&r);
        out[7..].copy_from_slice(&s);
        Ok(out)
    }

    /// Refuses a skin with a joint outside the scene that shows the skinned mesh's node
    /// `mesh_node` (the default scene when it holds it, else the first that does; the default
    /// or first scene when none does): nothing in the scene would place that joint. A file
    /// without scenes is not checked.
    fn check_scene(
        &self,
        mesh_node: usize,
        joints: &[usize],
        parents: &[Option<usize>],
        element: &str,
    ) -> Result<(), LoadError> {
        let root = |mut n: usize| {
            for _ in 0..parents.len() {
                match parents[n] {
                    Some(p) => n = p,
                    None => break,
                }
            }
            n
        };
        let scenes: Vec<gltf::Scene> = self.document.scenes().collect();
        let holds = |s: &gltf::Scene, node: usize| s.nodes().any(|r| r.index() == root(node));
        let default = self.document.default_scene().map_or(0, |s| s.index());
        let shown = match scenes.iter().find(|s| holds(s, mesh_node)) {
            Some(_) if scenes.get(default).is_some_and(|s| holds(s, mesh_node)) => default,
            Some(first) => first.index(),
            None => default,
        };
        let Some(scene) = scenes.get(shown) else {
            return Ok(());
        };
        match joints.iter().find(|&&j| !holds(scene, j)) {
            Some(&joint) => Err(self.data_error(
                element,
                format!(
                    "joint node {} is not in scene {}, which shows the skinned mesh: \
                     put the skeleton in that scene",
                    joint,
                    display_name(scene.name(), scene.index())
                ),
            )),
            None => Ok(()),
        }
    }

    /// Every vertex's joints and weights over `primitives` (each with POSITION, in order),
    /// every JOINTS_n/WEIGHTS_n set of the first primitive in turn (4 influences a set): the
    /// influence count, the joints and the weights as stored (not yet normalised).
    fn influences(
        &self,
        mesh: &gltf::Mesh,
        primitives: &[gltf::Primitive],
    ) -> Result<(usize, Vec<u32>, Vec<f32>), LoadError> {
        let sets = (0..)
            .take_while(|&n| primitives[0].get(&gltf::Semantic::Joints(n)).is_some())
            .count() as u32;
        let mesh_name = display_name(mesh.name(), mesh.index());
        let mut per_primitive = Vec::with_capacity(primitives.len());
        for primitive in primitives {
            let element = format!("mesh {mesh_name} primitive {}", primitive.index());
            let count = primitive
                .get(&gltf::Semantic::Positions)
                .map_or(0, |a| a.count());
            let mut joints = Vec::new();
            let mut weights = Vec::new();
            for set in 0..sets {
                let (Some(j), Some(w)) = (
                    primitive.get(&gltf::Semantic::Joints(set)),
                    primitive.get(&gltf::Semantic::Weights(set)),
                ) else {
                    return Err(self.data_error(
                        &element,
                        format!(
                            "has no JOINTS_{set} and WEIGHTS_{set} pair, which the first \
                             primitive binds its vertices with: give every primitive the same sets"
                        ),
                    ));
                };
                joints.push(self.joint_indices(&j, &format!("{element} JOINTS_{set}"), count)?);
                weights.push(self.weights(&w, &format!("{element} WEIGHTS_{set}"), count)?);
            }
            per_primitive.push((count, joints, weights));
        }
        let influences = 4 * sets as usize;
        let vertices: usize = per_primitive.iter().map(|p| p.0).sum();
        let mut joints = Vec::with_capacity(vertices * influences);
        let mut weights = Vec::with_capacity(vertices * influences);
        // Per vertex its sets one after the other: influence 4 n + c is set n's component c.
        for (count, j, w) in per_primitive {
            for v in 0..count {
                for set in 0..sets as usize {
                    joints.extend_from_slice(&j[set][4 * v..4 * v + 4]);
                    weights.extend_from_slice(&w[set][4 * v..4 * v + 4]);
                }
            }
        }
        Ok((influences, joints, weights))
    }

    /// One JOINTS_n accessor's values: VEC4 of UNSIGNED_BYTE or UNSIGNED_SHORT, not
    /// normalized, one per vertex.
    fn joint_indices(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
        vertices: usize,
    ) -> Result<Vec<u32>, LoadError> {
        let size = match accessor.data_type() {
            DataType::U8 => 1,
            DataType::U16 => 2,
            _ => 0,
        };
        if size == 0 || accessor.dimensions() != Dimensions::Vec4 || accessor.normalized() {
            return Err(self.data_error(
                element,
                "joints must be VEC4 of UNSIGNED_BYTE or UNSIGNED_SHORT, not normalized".into(),
            ));
        }
        self.check_count(accessor, element, vertices)?;
        let bytes = self.gather(accessor, element)?;
        Ok(bytes
            .chunks_exact(size)
            .map(|c| match size {
                1 => c[0] as u32,
                _ => u16::from_le_bytes([c[0], c[1]]) as u32,
            })
            .collect())
    }

    /// One WEIGHTS_n accessor's values: VEC4 of FLOAT, or of normalized UNSIGNED_BYTE or
    /// UNSIGNED_SHORT (read as `value / 255` or `/ 65535`), one per vertex.
    fn weights(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
        vertices: usize,
    ) -> Result<Vec<f32>, LoadError> {
        let allowed = match accessor.data_type() {
            DataType::F32 => true,
            DataType::U8 | DataType::U16 => accessor.normalized(),
            _ => false,
        };
        if !allowed || accessor.dimensions() != Dimensions::Vec4 {
            return Err(self.data_error(
                element,
                "weights must be VEC4 of FLOAT, or of normalized UNSIGNED_BYTE or UNSIGNED_SHORT"
                    .into(),
            ));
        }
        self.check_count(accessor, element, vertices)?;
        self.read_floats(accessor, element, Dimensions::Vec4)
    }

    fn check_count(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
        vertices: usize,
    ) -> Result<(), LoadError> {
        match accessor.count() == vertices {
            true => Ok(()),
            false => Err(self.data_error(
                element,
                format!(
                    "has {} elements, but POSITION has {vertices}",
                    accessor.count()
                ),
            )),
        }
    }

    /// `animation`'s channels on the skin's skeleton nodes as a clip (checked on the
    /// skeleton) lasting the animation's length (its channels' last key, any target); whether
    /// it loops is left to the caller, who knows the weights played with it. Channels on
    /// other nodes do not move the joints and are not part of it.
    pub(super) fn clip(
        &self,
        animation: &gltf::Animation,
        read: &SkinRead,
    ) -> Result<Clip, LoadError> {
        let element = &read.element;
        let mut channels = Vec::new();
        for (s, &node) in read.nodes.iter().enumerate() {
            for track in self.node_tracks(animation, node)? {
                channels.push(JointChannel {
                    node: s as u32,
                    track,
                });
            }
        }
        let duration = animation
            .channels()
            .map(|c| {
                self.read_floats(&c.sampler().input(), element, Dimensions::Scalar)
                    .map(|t| t.last().copied().unwrap_or(0.0))
            })
            .try_fold(0.0f32, |a, t| t.map(|t| a.max(t)))?;
        let clip = Clip {
            name: animation.name().unwrap_or("").to_string(),
            duration,
            looping: false,
            channels,
        };
        clip.validate(&read.skin.skeleton)
            .map_err(|source| LoadError::GltfSkin {
                path: self.path.clone(),
                skin: element.to_string(),
                source,
            })?;
        Ok(clip)
    }
}
