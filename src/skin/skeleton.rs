//! The joint hierarchy: every node a skin's joints hang from (the joints and their
//! ancestors up to the scene's root), each with its parent and its rest local transform as
//! translation, rotation and scale, and the world matrices of a set of local transforms.

use super::SkinError;
use glam::{Mat4, Quat, Vec3};

/// [`Skeleton::parents`] of a scene root.
pub const NO_PARENT: u32 = u32::MAX;

/// Floats per local transform: translation `x y z`, rotation `x y z w` (a unit quaternion,
/// glTF's order), scale `x y z`.
pub const TRS: usize = 10;

/// How far from 1 a rotation's length may be (glTF asks for unit quaternions; the validator
/// allows rounding, and normalized integer keys stand a step off): beyond it the quaternion
/// scales what it turns, which is refused as damaged data.
pub const UNIT_TOLERANCE: f32 = 1e-3;

/// The nodes whose world transforms move a skin's joints, parents before children.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skeleton {
    /// Per node its parent's index, smaller than its own, or [`NO_PARENT`] for a scene root.
    pub parents: Vec<u32>,
    /// Per node its rest local transform, [`TRS`] floats (a node the file gives as a matrix is
    /// decomposed; one that no translation, rotation and scale reproduce is refused by the
    /// reader, as three.js would decompose it too).
    pub rest: Vec<f32>,
    /// Per node its name in the source (empty when it has none), for messages.
    pub names: Vec<String>,
}

impl Skeleton {
    pub fn node_count(&self) -> usize {
        self.parents.len()
    }

    /// Node `node` as messages name it: `'name'` or its index.
    pub fn display(&self, node: usize) -> String {
        match self.names.get(node).filter(|n| !n.is_empty()) {
            Some(name) => format!("'{name}'"),
            None => node.to_string(),
        }
    }

    /// Checks what [`globals`](Self::globals) relies on: one rest transform and one name per
    /// node, parents before children, finite rest transforms with unit rotations.
    pub fn validate(&self) -> Result<(), SkinError> {
        let n = self.parents.len();
        if self.rest.len() != n * TRS || self.names.len() != n {
            return Err(SkinError::SkeletonSize {
                nodes: n,
                rest: self.rest.len(),
                names: self.names.len(),
            });
        }
        for (node, &parent) in self.parents.iter().enumerate() {
            if parent != NO_PARENT && parent as usize >= node {
                return Err(SkinError::ParentOrder { node, parent });
            }
        }
        for (node, trs) in self.rest.chunks_exact(TRS).enumerate() {
            check_trs(trs).map_err(|problem| SkinError::Rest {
                node: self.display(node),
                problem,
            })?;
        }
        Ok(())
    }

    /// The world matrix of every node from its local transform (`locals`: [`TRS`] floats per
    /// node), into `out`: `G(i) = G(parent(i)) · L(i)`, a root's `G` its `L` (glTF 2.0,
    /// "Transformations").
    pub fn globals(&self, locals: &[f32], out: &mut Vec<Mat4>) {
        out.clear();
        for (node, trs) in locals.chunks_exact(TRS).enumerate() {
            let local = trs_matrix(trs);
            let global = match self.parents[node] {
                NO_PARENT => local,
                p => out[p as usize] * local,
            };
            out.push(global);
        }
    }
}

/// The matrix `T · R · S` of one local transform ([`TRS`] floats).
pub fn trs_matrix(trs: &[f32]) -> Mat4 {
    Mat4::from_scale_rotation_translation(
        Vec3::new(trs[7], trs[8], trs[9]),
        Quat::from_xyzw(trs[3], trs[4], trs[5], trs[6]),
        Vec3::new(trs[0], trs[1], trs[2]),
    )
}

/// Why one local transform cannot be used: a value that is not finite, or a rotation that is
/// not a unit quaternion within [`UNIT_TOLERANCE`].
pub(super) fn check_trs(trs: &[f32]) -> Result<(), String> {
    if let Some(i) = trs.iter().position(|v| !v.is_finite()) {
        return Err(format!("component {i} of its transform is {}", trs[i]));
    }
    let length = Quat::from_slice(&trs[3..7]).length();
    if (length - 1.0).abs() > UNIT_TOLERANCE {
        return Err(format!(
            "its rotation {:?} has length {length}, not 1",
            &trs[3..7]
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A root moved by (1, 0, 0) and turned 90° about z, its child moved by (0, 2, 0) and
    /// scaled by 3: the child's origin lands at (1, 0, 0) + R (0, 2, 0) = (-1, 0, 0).
    #[test]
    fn globals_compose_parents_first() {
        let half = std::f32::consts::FRAC_1_SQRT_2;
        let skeleton = Skeleton {
            parents: vec![NO_PARENT, 0],
            rest: vec![
                1.0, 0.0, 0.0, 0.0, 0.0, half, half, 1.0, 1.0, 1.0, //
                0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0, 3.0, 3.0, 3.0,
            ],
            names: vec!["root".into(), String::new()],
        };
        skeleton.validate().unwrap();
        let mut globals = Vec::new();
        skeleton.globals(&skeleton.rest, &mut globals);
        let origin = globals[1].transform_point3(Vec3::ZERO);
        assert!(
            (origin - Vec3::new(-1.0, 0.0, 0.0)).length() < 1e-6,
            "{origin}"
        );
        // The child's x axis: scaled by 3, turned onto y.
        let x = globals[1].transform_vector3(Vec3::X);
        assert!((x - Vec3::new(0.0, 3.0, 0.0)).length() < 1e-5, "{x}");
        assert_eq!(skeleton.display(0), "'root'");
        assert_eq!(skeleton.display(1), "1");
    }

    #[test]
    fn validate_names_what_is_wrong() {
        let mut skeleton = Skeleton {
            parents: vec![NO_PARENT, 0],
            rest: [[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]; 2].concat(),
            names: vec![String::new(); 2],
        };
        skeleton.validate().unwrap();
        skeleton.parents = vec![1, NO_PARENT];
        assert!(matches!(
            skeleton.validate(),
            Err(SkinError::ParentOrder { node: 0, parent: 1 })
        ));
        skeleton.parents = vec![NO_PARENT, 0];
        skeleton.rest[13] = 2.0;
        let err = skeleton.validate().unwrap_err();
        assert!(err.to_string().contains("length"), "{err}");
        skeleton.rest[13] = 0.0;
        skeleton.rest[0] = f32::NAN;
        assert!(matches!(skeleton.validate(), Err(SkinError::Rest { .. })));
    }
}
