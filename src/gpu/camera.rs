//! A camera that frames an object: view and projection fitted to its bounding box, in wgpu's
//! clip space (right-handed world, y up, depth in [0, 1]; glam's `directx` convention).
//!
//! The box is enclosed in its bounding sphere so the fit holds for any view direction and for
//! every pose of a morph when the caller passes the union of both poses' bounds.

use glam::{Mat4, Vec3};

use super::GpuError;

/// How the fitted camera projects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with this vertical field of view, in radians, in (0, π).
    Perspective { vertical_fov: f32 },
    /// Orthographic: parallel rays, no foreshortening.
    Orthographic,
}

/// A view and a projection matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// World to view space (right-handed, the camera looks down -z).
    pub view: Mat4,
    /// View to wgpu clip space.
    pub proj: Mat4,
}

impl Camera {
    /// Projection * view: what [`super::Object::set_view_proj`] takes.
    pub fn view_proj(&self) -> Mat4 {
        self.proj * self.view
    }
}

/// Depth range slack: near and far planes sit this fraction of the sphere's radius outside it,
/// so surface points on the sphere are not clipped by rounding.
const DEPTH_MARGIN: f32 = 0.05;

/// A camera looking along `direction` at the box `min..max`, which it shows whole in a viewport
/// of `aspect` = width / height.
///
/// The up vector is +y unless `direction` is (nearly) vertical, where it is -z. A box with no
/// extent (one point) is framed as a sphere of radius 1 around it.
pub fn fit_to_bounds(
    min: [f32; 3],
    max: [f32; 3],
    direction: Vec3,
    aspect: f32,
    projection: Projection,
) -> Result<Camera, GpuError> {
    let (lo, hi) = (Vec3::from(min), Vec3::from(max));
    if !lo.is_finite() || !hi.is_finite() || lo.cmpgt(hi).any() {
        return Err(GpuError::InvalidParameter {
            what: "bounds",
            value: format!("{lo}..{hi}"),
            expected: "min and max must be finite with min <= max on every axis",
        });
    }
    if !direction.is_finite() || direction.length_squared() == 0.0 {
        return Err(GpuError::InvalidParameter {
            what: "view direction",
            value: format!("{direction}"),
            expected: "the direction must be finite and nonzero",
        });
    }
    if !(aspect.is_finite() && aspect > 0.0) {
        return Err(GpuError::InvalidParameter {
            what: "aspect ratio",
            value: aspect.to_string(),
            expected: "width / height must be finite and positive",
        });
    }
    let centre = (lo + hi) * 0.5;
    let radius = match (hi - lo).length() * 0.5 {
        r if r > 0.0 && r.is_finite() => r,
        _ => 1.0,
    };
    let forward = direction.normalize();
    let up = if forward.cross(Vec3::Y).length_squared() < 1e-6 {
        Vec3::NEG_Z
    } else {
        Vec3::Y
    };
    let (distance, proj) = match projection {
        Projection::Perspective { vertical_fov } => {
            if !(vertical_fov > 0.0 && vertical_fov < std::f32::consts::PI) {
                return Err(GpuError::InvalidParameter {
                    what: "vertical field of view",
                    value: vertical_fov.to_string(),
                    expected: "the angle is in radians and must lie strictly between 0 and π",
                });
            }
            // The sphere fits when its radius subtends at most the narrower half-angle.
            let half_y = vertical_fov * 0.5;
            let half_x = (half_y.tan() * aspect).atan();
            let distance = radius / half_y.min(half_x).sin();
            let near = (distance - radius * (1.0 + DEPTH_MARGIN)).max(distance * 1e-3);
            let far = distance + radius * (1.0 + DEPTH_MARGIN);
            let proj =
                glam::camera::rh::proj::directx::perspective(vertical_fov, aspect, near, far);
            (distance, proj)
        }
        Projection::Orthographic => {
            let (half_w, half_h) = if aspect >= 1.0 {
                (radius * aspect, radius)
            } else {
                (radius, radius / aspect)
            };
            // Any distance past the sphere works; 2r keeps near and far well separated.
            let distance = 2.0 * radius;
            let near = distance - radius * (1.0 + DEPTH_MARGIN);
            let far = distance + radius * (1.0 + DEPTH_MARGIN);
            let proj = glam::camera::rh::proj::directx::orthographic(
                -half_w, half_w, -half_h, half_h, near, far,
            );
            (distance, proj)
        }
    };
    let eye = centre - forward * distance;
    let view = glam::camera::rh::view::look_at_mat4(eye, centre, up);
    Ok(Camera { view, proj })
}

/// A perspective camera looking along `direction` that frames the union of both poses of
/// `asset`, so the object does not jump between frames of an animation.
pub fn frame_both_poses(asset: &crate::asset::Asset, direction: Vec3) -> Result<Camera, GpuError> {
    let both: Vec<[f32; 3]> = asset.v0.iter().chain(&asset.v1).copied().collect();
    let (min, max) = crate::mesh::bounds(&both).ok_or(GpuError::NoVertices)?;
    fit_to_bounds(
        min,
        max,
        direction,
        1.0,
        Projection::Perspective {
            vertical_fov: 30f32.to_radians(),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every corner of the box must land inside clip space (x, y in [-1, 1], z in [0, 1]),
    /// and the box must fill a good part of the view (the fit is tight, not just safe).
    #[test]
    fn fitted_box_is_inside_clip_space_and_fills_it() {
        let (min, max) = ([-1.0, 2.0, 5.0], [3.0, 2.5, 9.0]);
        let cases = [
            (Vec3::NEG_Z, 1.0),
            (Vec3::new(1.0, -0.5, -0.3), 16.0 / 9.0),
            (Vec3::NEG_Y, 0.5),
            (Vec3::Y, 1.0),
        ];
        for (direction, aspect) in cases {
            for projection in [
                Projection::Perspective { vertical_fov: 0.8 },
                Projection::Orthographic,
            ] {
                let camera =
                    fit_to_bounds(min, max, direction, aspect, projection).expect("valid input");
                let m = camera.view_proj();
                let mut extent = 0.0f32;
                for k in 0..8 {
                    let corner = Vec3::new(
                        if k & 1 == 0 { min[0] } else { max[0] },
                        if k & 2 == 0 { min[1] } else { max[1] },
                        if k & 4 == 0 { min[2] } else { max[2] },
                    );
                    let clip = m.project_point3(corner);
                    let what = format!("{direction} {aspect} {projection:?}: {clip}");
                    assert!(clip.x.abs() <= 1.0 && clip.y.abs() <= 1.0, "{what}");
                    assert!((0.0..=1.0).contains(&clip.z), "{what}");
                    extent = extent.max(clip.x.abs()).max(clip.y.abs());
                }
                assert!(extent > 0.4, "{direction} {projection:?}: extent {extent}");
            }
        }
    }

    #[test]
    fn rejects_bad_input() {
        let ok = |r: Result<Camera, GpuError>| r.is_ok();
        let persp = Projection::Perspective { vertical_fov: 1.0 };
        assert!(ok(fit_to_bounds([0.0; 3], [0.0; 3], Vec3::Z, 1.0, persp)));
        assert!(!ok(fit_to_bounds([1.0; 3], [0.0; 3], Vec3::Z, 1.0, persp)));
        assert!(!ok(fit_to_bounds(
            [f32::NAN; 3],
            [0.0; 3],
            Vec3::Z,
            1.0,
            persp
        )));
        assert!(!ok(fit_to_bounds(
            [0.0; 3],
            [1.0; 3],
            Vec3::ZERO,
            1.0,
            persp
        )));
        assert!(!ok(fit_to_bounds([0.0; 3], [1.0; 3], Vec3::Z, 0.0, persp)));
        let wide = Projection::Perspective { vertical_fov: 4.0 };
        assert!(!ok(fit_to_bounds([0.0; 3], [1.0; 3], Vec3::Z, 1.0, wide)));
    }
}
