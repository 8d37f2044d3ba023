//! Pose-aware pricing: a vertex holds one quadric per pose, each pose's error is scaled to
//! the first pose's size, and [`PoseError`] combines them.

use glam::DVec3;

use super::{dvec, PoseError, State};

/// Per pose, the factor that puts its errors in the first pose's scale: the squared ratio of
/// the first pose's bounding-box diagonal to its own (1 for the first, and where either
/// diagonal is 0), so scaling one pose uniformly does not change the sequence.
pub(super) fn pose_scales(poses: &[&[[f32; 3]]]) -> Vec<f64> {
    let first = diagonal_squared(poses[0]);
    poses
        .iter()
        .map(|pos| {
            let own = diagonal_squared(pos);
            if first > 0.0 && own > 0.0 && first != own {
                first / own
            } else {
                1.0
            }
        })
        .collect()
}

/// The squared diagonal of the bounding box of `pos` (0 for no vertex or a non-finite one).
fn diagonal_squared(pos: &[[f32; 3]]) -> f64 {
    let (lo, hi) = pos.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(dvec(p)), hi.max(dvec(p))),
    );
    let d = (hi - lo).length_squared();
    if d.is_finite() {
        d
    } else {
        0.0
    }
}

impl State<'_, '_, '_> {
    /// The position of `v` in pose `pose`.
    pub(super) fn p(&self, pose: usize, v: u32) -> DVec3 {
        dvec(self.poses[pose][v as usize])
    }

    /// Each pose's quadric error of `u` at `w`'s position in that pose, scaled to the first
    /// pose's size and combined over the poses ([`PoseError`]).
    pub(super) fn position_cost(&self, u: u32, w: u32) -> f64 {
        let count = self.poses.len();
        let quadrics = &self.quadric[u as usize * count..(u as usize + 1) * count];
        let mut errors = quadrics
            .iter()
            .enumerate()
            .map(|(pose, q)| q.error(self.p(pose, w)) * self.pose_scale[pose]);
        let first = errors.next().unwrap_or(0.0);
        match self.combine {
            PoseError::Mean => errors.fold(first, |a, e| a + e) / count as f64,
            PoseError::Max => errors.fold(first, f64::max),
        }
    }
}
