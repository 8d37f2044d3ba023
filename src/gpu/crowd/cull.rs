//! Instances out of view draw nothing: per `prepare`, each instance's bounding sphere (its
//! asset's sphere around both poses, grown by its weights' reach, under its transform) is
//! tested against the view's six clip planes, and the record of an instance wholly outside
//! one of them gets `instance_count = 0` on the GPU (its mirror keeps the record it draws when
//! in view). The test is conservative: an instance with any point in the clip volume is never
//! culled, so culling changes no pixel, only the vertices the GPU runs.

use glam::{Mat4, Vec3, Vec4};

use super::pipeline::{InstanceBlock, PoseBlock, WEIGHT_SLOTS};
use super::pool::RECORD_WORDS;
use super::CrowdAsset;

/// The word of a record (five `u32`s) that holds its instance count.
const INSTANCE_COUNT_WORD: u32 = 1;

/// Slack on the plane distances, relative to the sphere's size and place: the GPU's clip
/// test and this one round differently, and a sphere that grazes a plane must stay drawn.
const SLACK: f32 = 1e-3;

/// The six planes of a view's clip volume (wgpu's: `-w ≤ x, y ≤ w`, `0 ≤ z ≤ w`), each
/// `n · p + d ≥ 0` inside, `n` of unit length; a plane whose normal is zero (an infinite far
/// plane) is left out.
pub(super) struct Frustum {
    planes: Vec<Vec4>,
    /// The crowd's clock: root motion moves each instance's sphere by its velocity since.
    clock: f32,
}

impl Frustum {
    /// The clip volume of `view_proj` at crowd clock `clock`.
    pub(super) fn new(view_proj: Mat4, clock: f32) -> Frustum {
        let (x, y, z, w) = (
            view_proj.row(0),
            view_proj.row(1),
            view_proj.row(2),
            view_proj.row(3),
        );
        let planes = [w + x, w - x, w + y, w - y, z, w - z]
            .into_iter()
            .filter_map(|p| {
                let length = p.truncate().length();
                (length > 0.0 && length.is_finite()).then(|| p / length)
            })
            .collect();
        Frustum { planes, clock }
    }

    /// Whether the sphere at `center` of `radius` (world space) lies wholly outside one plane.
    /// NaN anywhere: not outside.
    fn outside(&self, center: Vec3, radius: f32) -> bool {
        let slack = SLACK * (radius + center.abs().max_element());
        self.planes
            .iter()
            .any(|p| p.truncate().dot(center) + p.w < -(radius + slack))
    }
}

/// Whether the instance of `block` and `pose` of an asset bounded by `bound` (object space),
/// whose targets move a vertex at most `reach[k]` per unit weight before the skin and
/// `stretch` times that after it (1 unskinned), lies wholly outside `frustum`. A model matrix
/// with a projective row is never culled.
pub(super) fn outside(
    frustum: &Frustum,
    (block, pose): (&InstanceBlock, &PoseBlock),
    (center, radius): ([f32; 3], f32),
    (reach, stretch): (&[f32], f32),
) -> bool {
    let model = Mat4::from_cols_array_2d(&block.model);
    if model.row(3) != Vec4::W {
        return false;
    }
    // The vertex stage adds the slots' weighted deltas to the blend of the poses (and skins
    // the sum).
    let reached = (0..WEIGHT_SLOTS)
        .filter(|&slot| pose.weights[slot] != 0.0)
        .map(|slot| {
            pose.weights[slot].abs()
                * reach
                    .get(pose.target(slot) as usize)
                    .copied()
                    .unwrap_or(f32::NAN)
        })
        .fold(0.0, |r, d| r + d);
    let grown = radius + stretch * reached;
    // The longest axis the transform scales by bounds the sphere's image.
    let scale = [model.x_axis, model.y_axis, model.z_axis]
        .iter()
        .map(|axis| axis.truncate().length())
        .fold(0.0, f32::max);
    let moved = block.offset_at(frustum.clock);
    frustum.outside(
        model.transform_point3(Vec3::from(center)) + moved,
        grown * scale,
    )
}

impl CrowdAsset {
    /// Brings the instance counts of this asset's records on the GPU in line with `frustum`
    /// (none: every instance in view), as patches appended to the waiting record patches
    /// (after `set`'s and `add`'s, so they win): 0 for every instance out of view, every
    /// prepare (8 bytes each, so that a record patched meanwhile cannot draw it), and its
    /// record's count for one that came back.
    pub(super) fn cull(&mut self, frustum: Option<&Frustum>) {
        let reach = self
            .gpu
            .targets()
            .map_or(&[][..], |targets| targets.reach.as_slice());
        let bound = self.gpu.bound();
        let reach = (reach, self.gpu.stretch());
        let instances = self.blocks.iter().zip(&self.poses);
        for (member, instance) in self.members.iter_mut().zip(instances) {
            let Some(member) = member else {
                continue;
            };
            let page = &mut self.pool.pages[member.record.page as usize];
            let count = page.records[member.record.entry as usize].instance_count;
            let hide = count > 0
                && frustum.is_some_and(|frustum| outside(frustum, instance, bound, reach));
            let word = member.record.entry * RECORD_WORDS + INSTANCE_COUNT_WORD;
            if hide {
                page.record_patches.push([word, 0]);
            } else if member.hidden {
                page.record_patches.push([word, count]);
            }
            member.hidden = hide;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Clip space as world space: the identity view sees x and y in -1..1, z in 0..1.
    fn clip_cube() -> Frustum {
        Frustum::new(Mat4::IDENTITY, 0.0)
    }

    fn at(x: f32, scale: f32) -> InstanceBlock {
        let model =
            Mat4::from_translation(Vec3::new(x, 0.0, 0.5)) * Mat4::from_scale(Vec3::splat(scale));
        InstanceBlock::new(model)
    }

    /// Whether the instance of `block` at rest (no weights) is out.
    fn out(frustum: &Frustum, block: &InstanceBlock, bound: ([f32; 3], f32)) -> bool {
        outside(frustum, (block, &PoseBlock::default()), bound, (&[], 1.0))
    }

    /// A unit sphere at x = 4 is 3 beyond the plane x = 1: out. Its transform's scale, its
    /// weights times their targets' reach, and a point anywhere within the slack bring it
    /// back; a projective transform or a NaN is never out.
    #[test]
    fn spheres_out_of_view_only() {
        let frustum = clip_cube();
        let bound = ([0.0; 3], 1.0);
        assert!(out(&frustum, &at(4.0, 1.0), bound));
        assert!(!out(&frustum, &at(0.5, 1.0), bound));
        // Scaled by 3 (on one axis is enough), the sphere reaches x = 1.
        assert!(!out(&frustum, &at(4.0, 3.0), bound));
        let stretched = Mat4::from_translation(Vec3::new(4.0, 0.0, 0.5))
            * Mat4::from_scale(Vec3::new(1.0, 3.0, 1.0));
        assert!(!out(&frustum, &InstanceBlock::new(stretched), bound));
        // Target 1 moves a vertex up to 5 per unit weight: weight -0.5 grows the radius to 3.5.
        let mut weighted = PoseBlock::default();
        weighted.set_weights(&[0.0, -0.5]);
        let weighted = (&at(4.0, 1.0), &weighted);
        assert!(!outside(&frustum, weighted, bound, (&[0.0, 5.0], 1.0)));
        assert!(outside(&frustum, weighted, bound, (&[5.0, 0.0], 1.0)));
        // Reach 1 grows it to 1.5 (out); a skin that stretches the deltas 5 times, to 3.5.
        assert!(outside(&frustum, weighted, bound, (&[0.0, 1.0], 1.0)));
        assert!(!outside(&frustum, weighted, bound, (&[0.0, 1.0], 5.0)));
        // Grazing: a sphere whose surface is on the plane, or just within the slack, is kept.
        assert!(!out(&frustum, &at(2.0, 1.0), bound));
        assert!(!out(&frustum, &at(2.0 + 1e-4, 1.0), bound));
        assert!(out(&frustum, &at(2.1, 1.0), bound));
        let mut projective = at(4.0, 1.0);
        projective.model[0][3] = 0.5;
        assert!(!out(&frustum, &projective, bound));
        assert!(!out(&frustum, &at(4.0, 1.0), ([0.0; 3], f32::NAN)));
        assert!(!out(&frustum, &at(f32::NAN, 1.0), bound));
    }

    /// Root motion moves the sphere: at x = 4 moving -1.5 a second since clock 2, the unit
    /// sphere is at x = 4 at clock 2 (out), at x = 1 at clock 4 (in), and past the far side
    /// at clock 6.5 (x = -2.75, out).
    #[test]
    fn moving_spheres_are_tested_where_they_are() {
        let bound = ([0.0; 3], 1.0);
        let mut walking = at(4.0, 1.0);
        walking.motion = [-1.5, 0.0, 0.0, 2.0];
        let at_clock = |clock: f32| out(&Frustum::new(Mat4::IDENTITY, clock), &walking, bound);
        assert!(at_clock(2.0));
        assert!(!at_clock(4.0));
        assert!(at_clock(6.5));
    }

    /// The near and far planes cull too; a far plane at infinity (a zero normal) is left out.
    #[test]
    fn depth_planes() {
        let frustum = clip_cube();
        let bound = ([0.0; 3], 0.1);
        let depth = |z: f32| InstanceBlock::new(Mat4::from_translation(Vec3::new(0.0, 0.0, z)));
        assert!(out(&frustum, &depth(-0.5), bound));
        assert!(out(&frustum, &depth(1.5), bound));
        assert!(!out(&frustum, &depth(0.5), bound));
        // z' = 1 - 1/z style: row 2 equals row 3, so w - z has no normal.
        let infinite = Mat4::from_cols_array_2d(&[
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 1.0],
            [0.0, 0.0, 0.0, 0.0],
        ]);
        assert_eq!(Frustum::new(infinite, 0.0).planes.len(), 5);
    }
}
