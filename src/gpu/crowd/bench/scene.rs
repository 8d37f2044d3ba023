//! Where the crowd bench's instances stand and where its camera is, frame by frame
//! ([`CrowdScene`]), and how much screen error what an instance draws makes there.

use glam::{DVec3, Mat4, Vec3};

use crate::gpu::camera::{fit_to_bounds, look_to, perspective, Projection};
use crate::gpu::GpuError;

/// The scene of the crowd bench (`morphlod bench --crowd N --scene …`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CrowdScene {
    /// The instances on a square grid, the asset's size plus a tenth apart, seen whole from
    /// above and in front by a fixed camera: every instance keeps its distance, most are far.
    #[default]
    Grid,
    /// The instances on a jittered square grid about 0.8 of the asset's height apart (1.4 m
    /// for a person), each turned its own way; the camera at eye height walks through them
    /// between two columns at 0.9 of the asset's height a second (1.5 m/s), its view
    /// swinging ±29° from side to side every 4 s: a few instances within 2 m (full detail,
    /// drawn from their regions), a band in the middle, most far, and about half of them
    /// behind the camera or beside the view.
    WalkThrough,
}

impl CrowdScene {
    /// Its name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            CrowdScene::Grid => "grid",
            CrowdScene::WalkThrough => "walk-through",
        }
    }
}

/// Render frames a second of the walk (the camera's pace and swing).
const FRAMES_PER_SECOND: f32 = 60.0;

/// A [`CrowdScene`] laid out for one asset and viewport: the instances' transforms and
/// centres, and the camera of each frame; what the crowd bench draws.
pub struct CrowdBenchScene {
    transforms: Vec<Mat4>,
    centres: Vec<Vec3>,
    fov: f32,
    camera: Camera,
}

enum Camera {
    Fixed { view_proj: Mat4, eye: Vec3 },
    Walk(Walk),
}

/// The walking camera: where it starts, its pace and swing, its projection.
struct Walk {
    start: Vec3,
    /// Units a frame along +z.
    step: f32,
    proj: Mat4,
}

impl CrowdBenchScene {
    /// `instances` placed as `kind` says, of an asset whose two poses span `lo..hi`, seen in a
    /// viewport of `aspect` = width / height.
    pub fn new(
        kind: CrowdScene,
        instances: u32,
        (lo, hi): (Vec3, Vec3),
        aspect: f32,
    ) -> Result<CrowdBenchScene, GpuError> {
        let size = hi - lo;
        let side = (f64::from(instances).sqrt().ceil() as u32).max(1);
        let fov = 0.8;
        let centre = (lo + hi) * 0.5;
        match kind {
            CrowdScene::Grid => {
                // Columns along x, rows along z, one asset's size plus a tenth apart.
                let spacing = size.max_element() * 1.1;
                let grid_max = lo + Vec3::new(spacing * side as f32, size.y, spacing * side as f32);
                let camera = fit_to_bounds(
                    lo.into(),
                    grid_max.into(),
                    Vec3::new(0.0, -0.45, -1.0),
                    aspect,
                    Projection::Perspective { vertical_fov: fov },
                )?;
                let eye = camera.view.inverse().transform_point3(Vec3::ZERO);
                let transforms: Vec<Mat4> = (0..instances)
                    .map(|i| {
                        let (x, z) = ((i % side) as f32, (i / side) as f32);
                        Mat4::from_translation(Vec3::new(x * spacing, 0.0, z * spacing))
                    })
                    .collect();
                Ok(CrowdBenchScene::placed(
                    transforms,
                    centre,
                    fov,
                    Camera::Fixed {
                        view_proj: camera.view_proj(),
                        eye,
                    },
                ))
            }
            CrowdScene::WalkThrough => {
                let height = size.y.max(1e-6);
                // About 0.8 of a height apart, never closer than 1.2 footprints.
                let spacing = (0.8 * height).max(1.2 * size.x.max(size.z));
                let rows = instances.div_ceil(side).max(1);
                let transforms: Vec<Mat4> = (0..instances)
                    .map(|i| {
                        // Jittered by at most 0.15 spacing: the walkway between two columns
                        // stays clear.
                        let jitter = Vec3::new(unit(i, 1) - 0.5, 0.0, unit(i, 2) - 0.5) * 0.3;
                        let (x, z) = ((i % side) as f32, (i / side) as f32);
                        let at = (Vec3::new(x, 0.0, z) + jitter) * spacing;
                        let turn = Mat4::from_rotation_y(std::f32::consts::TAU * unit(i, 3));
                        Mat4::from_translation(at) * turn
                    })
                    .collect();
                // Between the two middle columns, a quarter into the rows, at eye height.
                let start = Vec3::new(
                    ((side / 2) as f32 - 0.5).max(0.5) * spacing,
                    lo.y + 0.93 * height,
                    0.25 * rows as f32 * spacing,
                );
                let field = spacing * side.max(rows) as f32;
                let (near, far) = (0.02 * height, 2.0 * field + height);
                let proj = perspective(fov.into(), aspect.into(), near.into(), far.into());
                let proj = proj.as_mat4();
                let walk = Walk {
                    start,
                    step: 0.9 * height / FRAMES_PER_SECOND,
                    proj,
                };
                Ok(CrowdBenchScene::placed(
                    transforms,
                    centre,
                    fov,
                    Camera::Walk(walk),
                ))
            }
        }
    }

    fn placed(transforms: Vec<Mat4>, centre: Vec3, fov: f32, camera: Camera) -> CrowdBenchScene {
        let centres = transforms
            .iter()
            .map(|t| t.transform_point3(centre))
            .collect();
        CrowdBenchScene {
            transforms,
            centres,
            fov,
            camera,
        }
    }

    /// Each instance's transform.
    pub fn transforms(&self) -> &[Mat4] {
        &self.transforms
    }

    /// The world-space centre of each instance's box, whose distance to the eye sets its LOD.
    pub fn centres(&self) -> &[Vec3] {
        &self.centres
    }

    /// The vertical field of view, radians.
    pub fn fov(&self) -> f32 {
        self.fov
    }

    /// The camera at frame `f` (the bench's frames count from 0, warm-up frames included):
    /// projection * view, and the eye.
    pub fn camera(&self, f: usize) -> (Mat4, Vec3) {
        match &self.camera {
            Camera::Fixed { view_proj, eye } => (*view_proj, *eye),
            Camera::Walk(walk) => {
                let eye = walk.start + Vec3::Z * (walk.step * f as f32);
                // ±0.5 rad (29°) of yaw over a 4 s swing, looking a little down.
                let phase = std::f32::consts::TAU * f as f32 / (4.0 * FRAMES_PER_SECOND);
                let yaw = 0.5 * phase.sin();
                let direction = Vec3::new(yaw.sin(), -0.05, yaw.cos()).normalize();
                let view = look_to(eye.as_dvec3(), direction.as_dvec3(), DVec3::Y).as_mat4();
                (walk.proj * view, eye)
            }
        }
    }

    /// World units one pixel spans at `distance` from the eye, in a viewport `height` pixels
    /// tall (what [`crate::deform::Lod::screen_error`] divides by).
    pub fn units_per_pixel(&self, distance: f32, height: u32) -> f32 {
        2.0 * distance * (self.fov * 0.5).tan() / height as f32
    }
}

/// A small deterministic hash of `i` to `[0, 1)`: per-instance jitter and turns that are the
/// same on every run.
fn unit(i: u32, salt: u32) -> f32 {
    let mut x = i.wrapping_mul(0x9e37_79b9) ^ salt.wrapping_mul(0x85eb_ca6b);
    x ^= x >> 15;
    x = x.wrapping_mul(0x2c1b_3c6d);
    x ^= x >> 12;
    (x >> 8) as f32 / (1u32 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The walk-through's camera walks between two columns at eye height: over its first
    /// seconds a few instances are within a height of the eye, a band within ten, most
    /// farther; about half of them are behind the camera or out of the view's sides.
    #[test]
    fn the_walk_has_near_middle_and_far_instances() {
        let (lo, hi) = (Vec3::new(-0.3, 0.0, -0.15), Vec3::new(0.3, 1.7, 0.15));
        let scene = CrowdBenchScene::new(CrowdScene::WalkThrough, 10_000, (lo, hi), 16.0 / 9.0)
            .expect("a scene");
        for f in [0, 60, 120, 240] {
            let (view_proj, eye) = scene.camera(f);
            assert!((eye.y - 0.93 * 1.7).abs() < 1e-4, "eye height");
            let distances: Vec<f32> = scene.centres.iter().map(|c| (*c - eye).length()).collect();
            let near = distances.iter().filter(|&&d| d < 2.0).count();
            let middle = distances
                .iter()
                .filter(|&&d| (2.0..17.0).contains(&d))
                .count();
            assert!((2..=16).contains(&near), "frame {f}: {near} within 2 units");
            assert!(middle > 100, "frame {f}: {middle} in the middle band");
            // Nobody stands in the walkway.
            assert!(distances.iter().all(|&d| d > 0.3), "frame {f}");
            let in_front = scene
                .centres
                .iter()
                .filter(|c| {
                    let clip = view_proj * c.extend(1.0);
                    clip.w > 0.0 && clip.x.abs() <= clip.w
                })
                .count();
            assert!(
                (2_000..8_000).contains(&in_front),
                "frame {f}: {in_front} in front and within the sides"
            );
        }
        // 1.5 units a second at 60 frames a second.
        let (_, a) = scene.camera(0);
        let (_, b) = scene.camera(60);
        assert!(((b - a).length() - 0.9 * 1.7).abs() < 1e-3);
    }
}
